"""``Image.save`` to ``.exr`` places a crop of the render settings' ``dataWindowNDC`` in its shot, as EXR render
products do: ``displayWindow`` the whole resolution, ``dataWindow`` the pixels whose centres lie in the window, rows
from the top. ``wrt render -o x.exr`` wrote the crop at the origin, as a whole image. The header is read back with
``struct`` (OpenEXR's file layout), not with the package that wrote it."""

import struct

import numpy as np
import pytest

import wrt
from wrt.cli import main

pytest.importorskip("OpenEXR")  # writes EXR files (an optional dependency of wrt, a test dependency)

RESOLUTION = (24, 12)
WINDOW = (0.1, 0.3, 0.6, 0.9)  # xmin, ymin, xmax, ymax; (0, 0) the lower left
BODY = f"""def Cube "Box"
{{
    double size = 1
}}
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        rel camera = </Cam>
        uniform int2 resolution = {RESOLUTION}
        uniform float4 dataWindowNDC = {WINDOW}
        rel products = </Render/Shot>
    }}
    def RenderProduct "Shot"
    {{
        token productName = "shot.exr"
    }}
}}
"""


def box2i_attributes(path) -> dict:
    """Every ``box2i`` attribute of a single-part EXR header: name -> ``((xmin, ymin), (xmax, ymax))``. The header
    follows the magic number and version: attributes of name, type (NUL-terminated), int32 size and value, up to an
    empty name."""
    data = open(path, "rb").read()
    assert data[:4] == b"\x76\x2f\x31\x01"
    at, boxes = 8, {}
    while data[at] != 0:
        name_end = data.index(b"\0", at)
        type_end = data.index(b"\0", name_end + 1)
        (size,) = struct.unpack_from("<i", data, type_end + 1)
        if data[name_end + 1:type_end] == b"box2i":
            x0, y0, x1, y1 = struct.unpack_from("<4i", data, type_end + 5)
            boxes[data[at:name_end].decode()] = ((x0, y0), (x1, y1))
        at = type_end + 5 + size
    return boxes


def test_saved_exr_of_a_crop_is_placed_in_its_shot(tmp_path):
    stage = tmp_path / "shot.usda"
    stage.write_text(f'#usda 1.0\n(\n    renderSettingsPrimPath = "/Render/Settings"\n)\n{BODY}')
    stage = str(stage)
    out = tmp_path / "x.exr"
    assert main(["render", stage, "-o", str(out), "-q"]) == 0
    width, height = RESOLUTION
    columns = [j for j in range(width) if WINDOW[0] <= (j + 0.5) / width < WINDOW[2]]
    rows = [i for i in range(height) if WINDOW[1] <= 1 - (i + 0.5) / height < WINDOW[3]]  # NDC y goes up
    boxes = box2i_attributes(out)
    assert boxes["displayWindow"] == ((0, 0), (width - 1, height - 1))
    assert boxes["dataWindow"] == ((columns[0], rows[0]), (columns[-1], rows[-1]))
    products = wrt.render_products(wrt.load_usd(stage), tmp_path / "products", device="cpu")
    assert box2i_attributes(products["/Render/Shot"]) == boxes  # the products' rule


def test_saved_exr_of_a_whole_image_is_at_the_origin(tmp_path):
    out = wrt.Image(rgb=np.zeros((3, 5, 3), np.float32)).save(tmp_path / "whole.exr")
    assert box2i_attributes(out) == {"displayWindow": ((0, 0), (4, 2)), "dataWindow": ((0, 0), (4, 2))}


def test_batch_exrs_of_a_crop_are_placed_in_their_shots(tmp_path):
    # BatchImage.image(k) carried no window: every batch EXR (render_batch, several cameras) was at the origin.
    stage = tmp_path / "shot.usda"
    stage.write_text(f'#usda 1.0\n(\n    renderSettingsPrimPath = "/Render/Settings"\n)\n{BODY}')
    scene = wrt.load_usd(str(stage))
    single = wrt.render(scene, camera="/Cam", device="cpu").save(tmp_path / "single.exr")
    batch = wrt.render_batch(scene, ["/Cam", "/Cam"], width=RESOLUTION[0], height=RESOLUTION[1], device="cpu")
    for k in range(len(batch)):
        out = batch.image(k).save(tmp_path / f"batch{k}.exr")
        assert box2i_attributes(out) == box2i_attributes(single)
    assert box2i_attributes(single)["dataWindow"] != box2i_attributes(single)["displayWindow"]  # a crop indeed
    free = wrt.Camera.look_at((0, 0, 5), (0, 0, 0))  # a wrt.Camera object: its image is whole, not cropped
    renderer = wrt.Renderer(scene, cameras=[free], width=8, height=6, device="cpu")
    assert box2i_attributes(renderer.render().image(0).save(tmp_path / "free.exr"))["dataWindow"] == ((0, 0), (7, 5))
    renderer = wrt.Renderer(scene, cameras=["/Cam"], device="cpu")
    renderer.set_cameras(["/Cam", "/Cam"])  # new cameras, their windows with them
    assert box2i_attributes(renderer.render().image(1).save(tmp_path / "set.exr")) == box2i_attributes(single)


@pytest.mark.parametrize("field, value, error, match", [
    # A NaN or negative ratio failed the write in OpenEXR's words ("Invalid pixel aspect ratio in image header"),
    # naming the temporary file; a window of two numbers failed unpacking; a fractional x0 was cut to 1, placing
    # the crop a pixel off in its shot; data="no" stored the colour as data, by its truth.
    ("pixel_aspect_ratio", float("nan"), ValueError, "pixel_aspect_ratio must be a finite positive number"),
    ("pixel_aspect_ratio", -2.0, ValueError, "pixel_aspect_ratio must be a finite positive number"),
    ("pixel_aspect_ratio", "2", ValueError, "pixel_aspect_ratio must be a finite positive number"),
    ("window", (8, 4), ValueError, r"window must be None or \(shot width, shot height, x0, y0\) integers"),
    ("window", (8, 4, 1.5, 0), ValueError, r"window must be None or \(shot width, shot height, x0, y0\) integers"),
    ("window", (0, 4, 1, 0), ValueError, "the shot at least 1x1"),
    ("data", "no", TypeError, "wrt.Image: data must be True or False"),
])
def test_image_settings_that_no_file_can_state_are_refused_naming_the_field(tmp_path, field, value, error, match):
    rgb = np.zeros((2, 3, 3), np.float32)
    with pytest.raises(error, match=match):
        wrt.Image(rgb=rgb, **{field: value})
    image = wrt.Image(rgb=rgb)
    setattr(image, field, value)  # set after the image was made: refused at the save, before a file is written
    with pytest.raises(error, match=match):
        image.save(tmp_path / "x.exr")
    assert not list(tmp_path.iterdir())


def test_image_settings_of_numpy_types_are_kept_as_python_numbers(tmp_path):
    image = wrt.Image(rgb=np.zeros((2, 3, 3), np.float32), pixel_aspect_ratio=np.float32(2.0),
                      window=(np.int64(8), 4, np.int32(1), 2), data=np.True_)
    assert (image.pixel_aspect_ratio, image.window, image.data) == (2.0, (8, 4, 1, 2), True)
    assert box2i_attributes(image.save(tmp_path / "x.exr")) == {"displayWindow": ((0, 0), (7, 3)),
                                                                "dataWindow": ((1, 2), (3, 3))}
