"""UsdRender products: every RenderProduct written at its own camera and resolution, its RenderVars read back with
OpenEXR and Pillow and compared with ``wrt.render``'s image and AOVs; unknown sources, file names a stage must not
steer outside the output folder, ``materialBindingPurposes`` and ``renderingColorSpace``."""

import importlib
import json
import re
import warnings
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from PIL import Image as PilImage
from usda_text import fmt, load, write

import wrt
from wrt.cli import build_parser, main
from wrt.rays import camera_rays

WORLD = """def Xform "World"
{
    def Cube "Box"
    {
        double size = 1
        color3f[] primvars:displayColor = [(0.8, 0.2, 0.2)]
    }
    def Sphere "Ball"
    {
        double radius = 0.4
        double3 xformOp:translate = (1, 0.3, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Camera "Front"
    {
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Camera "Tilted"
    {
        double3 xformOp:translate = (2, 1, 4)
        float3 xformOp:rotateXYZ = (-10, 25, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    }
}
"""


def var(name: str, source: str, data_type: str = "color3f", source_type: str = "raw") -> str:
    return (f'def RenderVar "{name}"\n{{\n    uniform token dataType = "{data_type}"\n'
            f'    uniform string sourceName = "{source}"\n    uniform token sourceType = "{source_type}"\n}}\n')


def product(name: str, vars_: list, product_name: str | None, extra: str = "") -> str:
    targets = ", ".join(f"</Render/Vars/{v}>" for v in vars_)
    named = f'token productName = "{product_name}"\n' if product_name is not None else ""
    return f'def RenderProduct "{name}"\n{{\n{named}rel orderedVars = [{targets}]\n{extra}}}\n'


VARS = (var("color", "color", "color4f") + var("Ci", "Ci") + var("depth", "cameraDepth", "float")
        + var("N", "Neye", "normal3f") + var("id", "primId", "int") + var("albedo", "albedo")
        + var("P", "P", "point3f") + var("pc", "patchCoord", "float3") + var("st", "st", "float2", "primvar")
        + var("lpe", "C<RD>L", source_type="lpe"))


def write_stage(tmp_path, products: str, names: list, settings: str = "", name: str = "shot.usda") -> str:
    targets = ", ".join(f"</Render/{n}>" for n in names)
    body = (WORLD + 'def Scope "Render"\n{\n'
            f'def RenderSettings "Settings"\n{{\nrel camera = </World/Front>\nuniform int2 resolution = (32, 16)\n'
            f'rel products = [{targets}]\n{settings}}}\n'
            + products + 'def Scope "Vars"\n{\n' + VARS + "}\n}\n")
    path = write(tmp_path, body, name)
    text = open(path).read().replace("(\n", '(\n    renderSettingsPrimPath = "/Render/Settings"\n', 1)
    open(path, "w").write(text)
    return path


def read_exr(path) -> dict:
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.array(c.pixels) for name, c in f.channels().items()}


def read_header(path) -> dict:
    with OpenEXR.File(str(path)) as f:
        return dict(f.header())  # a copy: the file's own is emptied when it closes


def eye_normals(stage_path: str, camera: str, normals: np.ndarray) -> np.ndarray:
    """World normals in the camera's space by pxr's own view matrix (the oracle of the Neye channel)."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.Open(stage_path)
    view = UsdGeom.Xformable(stage.GetPrimAtPath(camera)).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    view = view.GetInverse()
    out = np.array([view.TransformDir(Gf.Vec3d(*map(float, n))) for n in normals.reshape(-1, 3)])
    return out.reshape(normals.shape)


@pytest.mark.parametrize("with_alpha", [False, True])
def test_png_products_are_tagged_srgb_and_hold_the_srgb_pixels(tmp_path, with_alpha):
    """A PNG product was written sRGB-encoded without an sRGB chunk. It carries sRGB, gAMA and cHRM as the PNG
    specification recommends, and its data, decoded without Pillow, is the float64 sRGB of the channels scaled by
    2^exposure (alpha linear; the colour unpremultiplied by it, as PNG's alpha is unassociated)."""
    from png_chunks import decode_pixels, read_chunks, srgb_chunks_problems

    render_products = importlib.import_module("wrt.render_products")
    rng = np.random.default_rng(123)
    channels = {c: rng.uniform(0.0, 0.6, (4, 6)).astype(np.float32) for c in ("RGBA" if with_alpha else "RGB")}
    chunks = read_chunks(render_products.write_product(tmp_path / "beauty.png", channels, exposure=1.0))
    assert srgb_chunks_problems(chunks) == []
    x = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
    if with_alpha:
        x /= channels["A"].astype(np.float64)[..., None]
    x = np.clip(x * 2.0, 0.0, 1.0)
    expected = np.round(255.0 * np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055))
    if with_alpha:
        expected = np.dstack([expected, np.round(channels["A"].astype(np.float64) * 255.0)])
    np.testing.assert_array_equal(decode_pixels(chunks), expected)


def test_every_product_is_written_at_its_own_view_and_agrees_with_render(tmp_path):
    """A beauty PNG at the settings' camera and 32x16 and an EXR of beauty and AOVs at another camera and 20x10: the
    files have those sizes and channels, and every channel is what wrt.render gives for that view. wrt wrote no
    file (productName was never read) and rendered only the first product's view."""
    products = (product("Beauty", ["color"], "../../beauty.png")
                + product("Aovs", ["Ci", "depth", "N", "id", "albedo", "color"], "/somewhere/else/aovs.exr",
                          'rel camera = </World/Tilted>\nuniform int2 resolution = (20, 10)\n'))
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"])
    scene = load(stage)
    assert [(p.product, p.camera, p.resolution) for p in scene.render_settings.products] == [
        ("/Render/Beauty", "/World/Front", (32, 16)), ("/Render/Aovs", "/World/Tilted", (20, 10))]
    out = tmp_path / "out"
    written = wrt.render_products(scene, out, device="cpu")
    assert written == {"/Render/Beauty": out / "beauty.png", "/Render/Aovs": out / "aovs.exr"}
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == ["aovs.exr", "beauty.png", "shot.usda"]

    front = wrt.render(scene, device="cpu")  # the first product's view
    assert front.rgb.shape == (16, 32, 3)
    front.save(tmp_path / "front.png")
    beauty = np.asarray(PilImage.open(out / "beauty.png"))
    assert beauty.shape == (16, 32, 4)  # color4f: RGBA, alpha the camera ray's coverage
    np.testing.assert_array_equal(beauty[..., :3], np.asarray(PilImage.open(tmp_path / "front.png")))
    np.testing.assert_array_equal(beauty[..., 3], np.where(front.aovs["prim"] >= 0, 255, 0))
    assert 0 < (beauty[..., 3] > 0).mean() < 1

    tilted = wrt.render(scene, camera="/World/Tilted", width=20, height=10, device="cpu")
    exr = read_exr(out / "aovs.exr")
    assert sorted(exr) == sorted(["R", "G", "B", "depth", "N.X", "N.Y", "N.Z", "id", "albedo.R", "albedo.G",
                                  "albedo.B", "color.R", "color.G", "color.B", "color.A"])
    assert all(c.shape == (10, 20) and c.dtype == np.float32 for c in exr.values())
    rgb = np.stack([exr[c] for c in "RGB"], axis=-1)
    np.testing.assert_array_equal(rgb, tilted.rgb)  # Ci, the first beauty, in the default layer
    np.testing.assert_array_equal(np.stack([exr[f"color.{c}"] for c in "RGB"], -1), tilted.rgb)
    np.testing.assert_array_equal(exr["color.A"], tilted.aovs["prim"] >= 0)
    np.testing.assert_array_equal(exr["depth"], tilted.aovs["z"])  # cameraDepth: along the view axis, inf on a miss
    # primId names the prim drawn, by the header's table: the prims Scene.hit_paths gives the same camera's rays.
    table = json.loads(read_header(out / "aovs.exr")["id/paths"])
    prims, _ = scene.hit_paths(wrt.trace(scene, *camera_rays(scene, "/World/Tilted", 20, 10)))
    np.testing.assert_array_equal(np.array([table.get(str(int(i)), "") for i in exr["id"].ravel()]), prims)
    assert sorted(table.values()) == ["/World/Ball", "/World/Box"]
    np.testing.assert_array_equal(np.stack([exr[f"albedo.{c}"] for c in "RGB"], -1), tilted.aovs["albedo"])
    hit = tilted.aovs["prim"] >= 0
    assert 0 < hit.mean() < 1 and len(np.unique(exr["id"][hit])) >= 2  # both shapes seen, and the background
    neye = np.stack([exr[f"N.{c}"] for c in "XYZ"], axis=-1)
    np.testing.assert_allclose(neye, eye_normals(stage, "/World/Tilted", tilted.aovs["normal"]), atol=1e-5)
    assert np.all(neye[hit][:, 2] > 0)  # facing the camera, which looks down -Z


def test_views_of_one_size_render_together_as_each_would_alone(tmp_path, monkeypatch):
    """Products at two cameras of one size are rendered by one Renderer (its lights and shading tables set up once:
    one per view took longer than the render for 40k parts), a third size by another; every file is what
    ``wrt.render`` of its view alone gives, bit for bit, with the path tracer's random samples too."""
    render_products = importlib.import_module("wrt.render_products")  # wrt.render_products is the function
    made = []

    class CountedRenderer(render_products.Renderer):
        def __init__(self, *args, **kwargs):
            made.append(kwargs.get("cameras") or [kwargs["camera"]])
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(render_products, "Renderer", CountedRenderer)
    tilted = 'rel camera = </World/Tilted>\nuniform int2 resolution = (32, 16)\n'
    products = (product("Front", ["Ci", "depth", "id"], "front.exr") + product("Tilted", ["Ci", "depth", "id"],
                                                                               "tilted.exr", tilted)
                + product("Small", ["Ci", "id"], "small.exr", 'uniform int2 resolution = (20, 10)\n'))
    scene = load(write_stage(tmp_path, products, ["Front", "Tilted", "Small"]))
    written = wrt.render_products(scene, tmp_path / "out", device="cpu", integrator="path", spp=3, seed=5)
    assert [len(cameras) for cameras in made] == [2, 1]
    for name, camera, (width, height) in (("Front", "/World/Front", (32, 16)), ("Tilted", "/World/Tilted", (32, 16)),
                                          ("Small", "/World/Front", (20, 10))):
        alone = wrt.render(scene, camera=camera, width=width, height=height, device="cpu", integrator="path", spp=3,
                           seed=5)
        channels = read_exr(written[f"/Render/{name}"])
        assert 0 < (alone.aovs["prim"] >= 0).mean() < 1
        np.testing.assert_array_equal(np.stack([channels[c] for c in "RGB"], axis=-1), alone.rgb)
        if "depth" in channels:
            np.testing.assert_array_equal(channels["depth"], alone.aovs["z"])  # RenderVar "depth" is cameraDepth
        ids, _ = scene.hit_prims(*scene.split_ids(alone.aovs["prim"].reshape(-1)))
        np.testing.assert_array_equal(channels["id"].reshape(-1), ids)


def test_products_of_views_rendered_are_written_before_a_later_batch_fails(tmp_path, monkeypatch):
    """The second batch of views (another size) fails, as out of memory or Ctrl-C would: the two products of the
    first view are already written and valid files (all were written after every view was rendered, so none was);
    the failing view's product is not."""
    render_products = importlib.import_module("wrt.render_products")  # wrt.render_products is the function
    calls = []

    class FailingRenderer(render_products.Renderer):
        def render(self, *args, **kwargs):
            calls.append(self.width)
            if len(calls) == 2:
                raise MemoryError("injected: out of memory in the second batch")
            return super().render(*args, **kwargs)

    monkeypatch.setattr(render_products, "Renderer", FailingRenderer)
    products = (product("Beauty", ["Ci"], "front.png") + product("Front", ["Ci", "depth"], "front.exr")
                + product("Small", ["Ci"], "small.png", 'uniform int2 resolution = (20, 10)\n'))
    scene = load(write_stage(tmp_path, products, ["Beauty", "Front", "Small"]))
    out = tmp_path / "out"
    with pytest.raises(MemoryError, match="injected"):
        wrt.render_products(scene, out, device="cpu")
    assert calls == [32, 20]
    alone = wrt.render(scene, camera="/World/Front", width=32, height=16, device="cpu")
    with PilImage.open(out / "front.png") as png:
        assert png.size == (32, 16) and png.mode == "RGB"
    channels = read_exr(out / "front.exr")
    np.testing.assert_array_equal(np.stack([channels[c] for c in "RGB"], axis=-1), alone.rgb)
    np.testing.assert_array_equal(channels["depth"], alone.aovs["z"])
    assert sorted(p.name for p in out.iterdir()) == ["front.exr", "front.png"]  # no partial or temporary file


def test_unknown_sources_are_left_out_with_a_warning_naming_the_render_var(tmp_path):
    """A raw source wrt has not (patchCoord), a primvar and an LPE other than the beauty: one warning each, naming the
    RenderVar; the product keeps what wrt has, and a product left with nothing is skipped, named."""
    products = (product("Mixed", ["pc", "depth", "st", "lpe"], "mixed.exr")
                + product("Nothing", ["pc"], "nothing.exr"))
    scene = load(write_stage(tmp_path, products, ["Mixed", "Nothing"]))
    with pytest.warns(UserWarning) as record:
        written = wrt.render_products(scene, tmp_path / "out", device="cpu")
    messages = [str(w.message) for w in record]
    for path, source in (("/Render/Vars/pc", "raw 'patchCoord'"), ("/Render/Vars/st", "primvar 'st'"),
                         ("/Render/Vars/lpe", "lpe 'C<RD>L'")):
        assert sum(f"RenderVar {path} ({source}) has no wrt output and is left out" in m for m in messages) >= 1
    assert any("/Render/Nothing has no RenderVar wrt can write; it is skipped" in m for m in messages)
    assert list(written) == ["/Render/Mixed"]
    assert sorted(read_exr(written["/Render/Mixed"])) == ["depth"]


def test_product_names_stay_in_the_output_folder(tmp_path):
    """productName is reduced to its last component: '../../x.png', an absolute path and a Windows path all land in
    OUTDIR; a second product of one name gets _2; no productName: the prim's name; a .png of several channels
    becomes .exr (said); a name without an extension gets one."""
    products = (product("A", ["color"], "../../x.png") + product("B", ["color"], "/tmp/elsewhere/x.png")
                + product("C", ["color"], None) + product("D", ["color", "depth"], "aovs.png")
                + product("E", ["depth"], "C:\\\\render\\\\shot.0001") + product("F", ["color"], ".."))
    scene = load(write_stage(tmp_path, products, list("ABCDEF")))
    out = tmp_path / "deep" / "out"
    with pytest.warns(UserWarning) as record:
        written = wrt.render_products(scene, out, device="cpu")
    assert {k: v.name for k, v in written.items()} == {
        "/Render/A": "x.png", "/Render/B": "x_2.png", "/Render/C": "C.png", "/Render/D": "aovs.exr",
        "/Render/E": "shot.0001.exr", "/Render/F": "F.png"}
    assert all(p.parent == out for p in written.values())
    files = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert files == sorted([f"deep/out/{p.name}" for p in written.values()] + ["shot.usda"])
    messages = " | ".join(str(w.message) for w in record)
    assert "/Render/B writes x.png, as an earlier product does; written as x_2.png" in messages
    assert ("/Render/D productName 'aovs.png': wrt writes PNG for a product of the beauty alone, EXR for any other "
            "RenderVar; written as aovs.exr") in messages


def test_a_product_name_too_long_for_a_file_system_is_shortened_before_any_render(tmp_path):
    """A productName past the 255 bytes a file name may have (here 200 two-byte letters) failed the write with "File
    name too long" after the render, the other products written; it is shortened to fit, whole letters, with a
    warning naming the product, and a second product of that name still gets a name of its own."""
    long_name = "\u00e9" * 200
    products = (product("Ok", ["color"], "ok.png") + product("Long", ["color"], long_name + ".png")
                + product("Again", ["Ci"], long_name + ".png"))
    scene = load(write_stage(tmp_path, products, ["Ok", "Long", "Again"]))
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        written = wrt.render_products(scene, tmp_path / "out", device="cpu")
    said = [str(w.message) for w in record]
    for prim in ("/Render/Long", "/Render/Again"):
        assert sum(f"{prim} productName" in m and "longer than the 255 bytes" in m for m in said) == 1, prim
    assert sum("/Render/Again writes" in m and "as an earlier product does" in m for m in said) == 1
    for prim in ("/Render/Long", "/Render/Again"):
        name = written[prim].name
        assert len(name.encode()) <= 255 and name.startswith("\u00e9" * 100) and name.endswith(".png"), prim
        assert PilImage.open(written[prim]).size == (32, 16)
    assert written["/Render/Again"].name == written["/Render/Long"].stem + "_2.png"


def test_a_png_product_of_one_data_channel_is_said_to_be_no_beauty(tmp_path):
    """productName 'depth.png' of the depth RenderVar alone is written as EXR: the warning said 'wrt writes several
    channels as EXR', of a product of one channel; what keeps it from PNG is that it is not the beauty."""
    scene = load(write_stage(tmp_path, product("D", ["depth"], "depth.png"), ["D"]))
    with pytest.warns(UserWarning) as record:
        written = wrt.render_products(scene, tmp_path / "out", device="cpu")
    assert written["/Render/D"].name == "depth.exr" and sorted(read_exr(written["/Render/D"])) == ["depth"]
    messages = [str(w.message) for w in record if "productName" in str(w.message)]
    assert len(messages) == 1 and "several channels" not in messages[0], messages
    assert "PNG for a product of the beauty alone, EXR for any other RenderVar; written as depth.exr" in messages[0]


def test_stage_without_products_is_an_error(tmp_path):
    scene = load(write_stage(tmp_path, "", []))
    with pytest.raises(ValueError, match=r"shot.usda: /Render/Settings has no RenderProduct to write"):
        wrt.render_products(scene, tmp_path / "out")


def test_settings_the_stage_does_not_choose_are_named_when_no_product_is_written(tmp_path, capsys):
    """A stage with RenderSettings and products but no renderSettingsPrimPath was refused with 'no render settings,
    so no RenderProduct to write', as if it had none: the message names the settings there are and how to choose."""
    path = write_stage(tmp_path, product("Beauty", ["color"], "beauty.png"), ["Beauty"])
    text = open(path).read().replace('    renderSettingsPrimPath = "/Render/Settings"\n', "")
    open(path, "w").write(text)
    assert main(["render", path, "--products", str(tmp_path / "out"), "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "RenderSettings prims in the stage: /Render/Settings" in errors[0], errors
    assert "--render-settings" in errors[0]
    with pytest.raises(ValueError, match=r"RenderSettings prims in the stage: /Render/Settings.*render_settings="):
        wrt.render_products(wrt.load_usd(path), tmp_path / "out")
    chosen = ["--render-settings", "/Render/Settings"]
    assert main(["render", path, "--products", str(tmp_path / "out"), "-q", *chosen]) == 0
    assert (tmp_path / "out" / "beauty.png").is_file()  # as the message says


@pytest.mark.parametrize("directory, error, message", [
    ("", ValueError, r"render_products: directory '' is empty"),  # Path('') is the current folder: written there
    # Refused at the first write, after the renders: 'cannot write notes.txt/out/a.png: notes.txt is a file, ...'.
    ("notes.txt/out", NotADirectoryError, r"render_products: directory notes.txt/out: notes.txt is a file, not a "
     "directory"),
    (" ", ValueError, r"render_products: directory ' ' is empty"),
    (None, TypeError, r"render_products: directory must be a folder path \(str or os.PathLike\), got NoneType"),
])
def test_a_directory_that_names_no_folder_is_refused_before_any_render(tmp_path, monkeypatch, directory, error,
                                                                       message):
    scene = load(write_stage(tmp_path, product("A", ["color"], "a.png"), ["A"]))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("a file")
    before = sorted(tmp_path.iterdir())
    products_module = importlib.import_module("wrt.render_products")  # wrt.render_products is the function
    monkeypatch.setattr(products_module, "render_views", lambda *args, **kwargs: pytest.fail("rendered"))
    with pytest.raises(error, match=message):
        wrt.render_products(scene, directory)
    assert sorted(tmp_path.iterdir()) == before


def test_a_product_file_that_is_a_folder_is_refused_before_any_render(tmp_path, monkeypatch):
    """DIR/a.png a folder: the product was rendered, then its write failed naming the temporary file ('[Errno 21] Is
    a directory: 'DIR/.a.png.<pid>.0.partial.png' -> 'DIR/a.png'')."""
    products_module = importlib.import_module("wrt.render_products")  # wrt.render_products is the function
    scene = load(write_stage(tmp_path, product("A", ["color"], "a.png"), ["A"]))
    (tmp_path / "out" / "a.png").mkdir(parents=True)
    monkeypatch.setattr(products_module, "render_views", lambda *args, **kwargs: pytest.fail("rendered"))
    with pytest.raises(IsADirectoryError, match=r"shot.usda: /Render/A: cannot write .*a\.png: it is a directory$"):
        wrt.render_products(scene, tmp_path / "out")
    assert not list((tmp_path / "out" / "a.png").iterdir())


def test_render_var_targets_that_are_not_render_vars_are_named(tmp_path):
    products = product("A", ["color"], "a.png").replace("</Render/Vars/color>",
                                                         "</Render/Vars/color>, </World/Box>")
    with pytest.warns(UserWarning, match=r"shot.usda: /Render/A: orderedVars targets /World/Box, which is a Cube, "
                      r"not a RenderVar; it is left out"):
        scene = wrt.load_usd(write_stage(tmp_path, products, ["A"]))
    assert [v.path for v in scene.render_settings.render_vars] == ["/Render/Vars/color"]



def test_a_later_product_that_cannot_be_read_is_left_out_and_the_stage_loads(tmp_path):
    """A second product whose camera does not exist and a third of resolution 0x0: each is left out with a warning
    naming it, and the stage renders its first product as before (the load failed on them, though a plain render
    uses the first product only, and rendering products wrote none)."""
    products = (product("A", ["color"], "a.png") + product("B", ["color"], "b.png", "rel camera = </World/Nope>\n")
                + product("C", ["color"], "c.png", "uniform int2 resolution = (0, 0)\n"))
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(write_stage(tmp_path, products, ["A", "B", "C"]))
    messages = " | ".join(str(w.message) for w in record)
    assert ("/Render/B: camera relationship targets /World/Nope, which is no prim, not a Camera; this RenderProduct "
            "is left out") in messages
    assert "/Render/C: resolution 0x0 must be positive; this RenderProduct is left out" in messages
    assert [p.product for p in scene.render_settings.products] == ["/Render/A"]
    assert wrt.render(scene, device="cpu").rgb.shape == (16, 32, 3)
    assert wrt.render_products(scene, tmp_path / "out", device="cpu") == {"/Render/A": tmp_path / "out" / "a.png"}


def test_a_first_product_that_cannot_be_read_is_left_out_as_later_ones_are(tmp_path):
    """A first product whose camera is no prim is left out with a warning as a later one is; the next product is the
    settings a plain render uses (its camera and 20x10). With no readable product at all the stage still loads and
    renders at the settings' own values, and rendering products says there is none. The load failed on the first."""
    products = (product("A", ["color"], "a.png", "rel camera = </World/Nope>\n")
                + product("B", ["color"], "b.png", 'rel camera = </World/Tilted>\nuniform int2 resolution = (20, 10)\n')
                + product("C", ["color"], "c.png", "uniform int2 resolution = (0, 0)\n"))
    with pytest.warns(UserWarning, match=r"/Render/A: camera relationship targets /World/Nope, which is no prim, "
                      r"not a Camera; this RenderProduct is left out"):
        scene = wrt.load_usd(write_stage(tmp_path, products, ["A", "B"]))
    settings = scene.render_settings
    assert (settings.product, settings.camera, settings.resolution) == ("/Render/B", "/World/Tilted", (20, 10))
    assert [p.product for p in settings.products] == ["/Render/B"]
    np.testing.assert_array_equal(wrt.render(scene, device="cpu").rgb,
                                  wrt.render(scene, camera="/World/Tilted", width=20, height=10, device="cpu").rgb)
    assert wrt.render_products(scene, tmp_path / "out", device="cpu") == {"/Render/B": tmp_path / "out" / "b.png"}

    with pytest.warns(UserWarning) as caught:
        scene = wrt.load_usd(write_stage(tmp_path, products, ["C", "A"], name="none.usda"))
    left_out = sorted(str(w.message).split(": ", 2)[1] for w in caught if "RenderProduct is left out" in str(w.message))
    assert left_out == ["/Render/A", "/Render/C"], [str(w.message) for w in caught]
    assert any("resolution 0x0 must be positive" in str(w.message) for w in caught)
    settings = scene.render_settings
    assert (settings.product, settings.camera, settings.resolution, settings.products) == (
        "", "/World/Front", (32, 16), ())
    assert wrt.render(scene, device="cpu").rgb.shape == (16, 32, 3)
    with pytest.raises(ValueError, match=r"/Render/Settings has no RenderProduct to write"):
        wrt.render_products(scene, tmp_path / "out2", device="cpu")


def test_a_product_too_large_fails_naming_it_before_any_file_is_written(tmp_path):
    """The second product asks for 200000 x 200000 pixels: the call fails naming that product, and the first
    product's file is not written (it was, and the error named no product)."""
    products = product("A", ["color"], "a.png") + product("B", ["color"], "b.png",
                                                          "uniform int2 resolution = (200000, 200000)\n")
    scene = load(write_stage(tmp_path, products, ["A", "B"]))
    with pytest.raises(ValueError, match=r"shot.usda: /Render/B: 200000x200000 is 40,000,000,000 pixels; "
                       "at most 67,108,864 are supported"):
        wrt.render_products(scene, tmp_path / "out", device="cpu")
    assert not (tmp_path / "out" / "a.png").exists()

def test_cli_products(tmp_path, capsys):
    products = product("Beauty", ["color"], "beauty.png") + product("Aovs", ["depth", "id"], "aovs.exr")
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"])
    assert main(["render", stage, "--products", str(tmp_path / "out"), "-q"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["aovs.exr", "beauty.png"]
    assert PilImage.open(tmp_path / "out" / "beauty.png").size == (32, 16)
    assert main(["render", stage, "--products", str(tmp_path / "o2"), "--width", "8", "-o", "x.png"]) == 2
    assert "wrt: error: -o, --width cannot be combined with --products" in capsys.readouterr().err
    # One image of a stage of several products says where the others are.
    assert main(["render", stage, "-o", str(tmp_path / "one.png"), "-q"]) == 0
    assert ("wrt: warning: shot.usda: /Render/Settings has 2 RenderProducts; this image is the first's, "
            "/Render/Beauty (--products DIR writes them all)") in capsys.readouterr().err
    # Not when --camera overrides the products' camera: the image is no product's, and the warning said it was.
    # (Another file: Python shows a warning of the same text once per process.)
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"], name="camera.usda")
    assert main(["render", stage, "-o", str(tmp_path / "cam.png"), "-q", "--camera", "/World/Front"]) == 0
    assert "RenderProducts" not in capsys.readouterr().err
    assert main(["render", stage, "-o", str(tmp_path / "cam.png"), "-q"]) == 0  # the same run warns without it
    assert "camera.usda: /Render/Settings has 2 RenderProducts" in capsys.readouterr().err
    # The frames of such a stage drew the first product's view without a word; now said once per run.
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"], name="frames.usda")
    assert main(["render", stage, "--frames", "1:2", "-o", str(tmp_path / "f_#.png"), "-q"]) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "RenderProducts" in line]
    assert said == ["wrt: warning: frames.usda: /Render/Settings has 2 RenderProducts; each frame is the first's, "
                    "/Render/Beauty (--products DIR --time T writes them all at one time)"], said
    assert PilImage.open(tmp_path / "f_2.png").size == (32, 16)


# The options of one image that --products refuses, each with a value (None: a flag).
REFUSED_WITH_PRODUCTS = {"-o": "x.png", "--width": "8", "--height": "8", "--camera": "/World/Front", "--aov": "depth",
                         "--aov-dir": "aovs", "--frames": "1:2", "--resume": None, "--log": "log.jsonl",
                         "--max-memory": "4G"}


@pytest.mark.parametrize("option", REFUSED_WITH_PRODUCTS)
def test_options_refused_with_products_are_the_ones_the_help_and_readme_name(option, tmp_path, capsys):
    """``--products`` refused ``--resume`` while ``wrt render --help`` and the README listed the refused options
    without it."""
    value = REFUSED_WITH_PRODUCTS[option]
    args = ["render", str(tmp_path / "none.usda"), "--products", str(tmp_path / "out"), option]
    assert main(args + ([value] if value is not None else [])) == 2  # refused before the (missing) file is read
    assert f"wrt: error: {option} cannot be combined with --products" in capsys.readouterr().err
    (commands,) = [a for a in build_parser()._actions if a.dest == "command"]
    (products,) = [a for a in commands.choices["render"]._actions if "--products" in a.option_strings]
    assert re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", products.help.split("Not with")[1])
    readme = " ".join((Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8").split())
    refused = readme.split("`--products` takes one scene and not ")[1].split(".")[0]
    assert f"`{option}`" in refused


def test_cli_view_line_names_where_the_camera_and_size_come_from(tmp_path, capsys):
    """--camera on a stage of two products whose first authors its own size: the image keeps that product's size
    (as USD reads it) and film, and a progress line says so, the camera and the size each with where it came from.
    The size was the first product's without a word (the warning naming that product is not shown with --camera)."""
    from pxr import Usd, UsdRender

    products = (product("Beauty", ["color"], "beauty.png", "uniform int2 resolution = (24, 12)\n")
                + product("Aovs", ["depth"], "aovs.exr", "uniform int2 resolution = (20, 10)\n"))
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"])
    usd = Usd.Stage.Open(stage)
    w, h = UsdRender.Product(usd.GetPrimAtPath("/Render/Beauty")).GetResolutionAttr().Get()
    out = tmp_path / "cam.png"
    assert main(["render", stage, "-o", str(out), "--camera", "/World/Tilted"]) == 0
    assert PilImage.open(out).size == (w, h)
    err = capsys.readouterr().err
    assert f"wrt: view: camera /World/Tilted (--camera), {w}x{h} (resolution of /Render/Beauty)" in err
    # Without --camera, the settings' camera; one size given keeps the product's aspect.
    assert main(["render", stage, "-o", str(out), "--width", str(2 * w)]) == 0
    settings_camera = UsdRender.Settings(usd.GetPrimAtPath("/Render/Settings")).GetCameraRel().GetTargets()[0]
    assert PilImage.open(out).size == (2 * w, 2 * h)
    assert (f"wrt: view: camera {settings_camera} (render settings), {2 * w}x{2 * h} (--width, aspect of "
            "/Render/Beauty)") in capsys.readouterr().err
    # A stage without render settings has no such line: wrt's defaults, as --help says.
    plain = write(tmp_path, WORLD, "plain.usda")
    assert main(["render", plain, "-o", str(out), "--width", "8", "--height", "4"]) == 0
    assert "view:" not in capsys.readouterr().err


# A camera at (1, 0.5, 10) turned 8 degrees about Y, with apertures of the 48x24 image's aspect (no conforming), over
# a mesh strip of three faces (a quad, a pentagon, a quad: 7 triangles) at z = 0, three instances of a quad at
# z = -1 and a sphere: every camera ray's hit is known from pxr's frustum and a little geometry.
STRIP_X = (-5.0, -4.0, -3.0, -2.0)  # face k of /Strip spans x in [STRIP_X[k], STRIP_X[k + 1]], |y| <= 1, z = 0
QUADS_X = (0.5, 2.0, 3.5)  # /PI's instances: x centres of quads 1.2 wide, |y| <= 1, z = -1
BALL = ((6.0, 0.0, 0.0), 1.0)  # /Ball: centre and radius


def add_shot(stage, camera: str, width: int, height: int, product_name: str, vars_: dict):
    """The stage's RenderSettings ``/Render/Settings`` of ``camera`` at ``width`` x ``height``, with one RenderProduct
    ``/Render/Shot`` named ``product_name`` of the RenderVars ``{name: (sourceName, aov name or None)}``; returns
    ``(settings, shot)``."""
    from pxr import Gf, Sdf, UsdRender

    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets([camera])
    settings.CreateResolutionAttr(Gf.Vec2i(width, height))
    shot = UsdRender.Product.Define(stage, "/Render/Shot")
    shot.CreateProductNameAttr(product_name)
    settings.CreateProductsRel().SetTargets(["/Render/Shot"])
    for var_name, (source, aov_name) in vars_.items():
        var = UsdRender.Var.Define(stage, f"/Render/Vars/{var_name}")
        var.CreateSourceNameAttr(source)
        if aov_name is not None:
            var.GetPrim().CreateAttribute("driver:parameters:aov:name", Sdf.ValueTypeNames.String).Set(aov_name)
        shot.GetOrderedVarsRel().AddTarget(var.GetPath())
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    return settings, shot


def planar_stage(tmp_path, vars_: dict, window=(0.0, 0.0, 1.0, 1.0), name: str = "ids.usda") -> str:
    """The stage above with one RenderProduct ``/Render/Shot`` of the RenderVars ``{name: (sourceName, aov name or
    None)}`` and ``dataWindowNDC`` ``window``."""
    from pxr import Gf, Usd, UsdGeom

    path = str(tmp_path / name)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    strip = UsdGeom.Mesh.Define(stage, "/Strip")
    x0, x1, x2, x3 = STRIP_X
    strip.CreatePointsAttr([(x0, -1, 0), (x1, -1, 0), (x1, 1, 0), (x0, 1, 0), (x2, -1, 0), (x2, 1, 0),
                            ((x1 + x2) / 2, 1.0, 0), (x3, -1, 0), (x3, 1, 0)])
    strip.CreateFaceVertexCountsAttr([4, 5, 4])
    strip.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 1, 4, 5, 6, 2, 4, 7, 8, 5])
    quad = UsdGeom.Mesh.Define(stage, "/PI/Protos/Quad/Mesh")
    quad.CreatePointsAttr([(-0.6, -1, 0), (0.6, -1, 0), (0.6, 1, 0), (-0.6, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Quad"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(x, 0, -1) for x in QUADS_X])
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr(BALL[1])
    ball.AddTranslateOp().Set(Gf.Vec3d(*BALL[0]))
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateFocalLengthAttr(25.0)
    cam.CreateHorizontalApertureAttr(40.0)
    cam.CreateVerticalApertureAttr(20.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(1, 0.5, 10))
    cam.AddRotateYOp().Set(8.0)
    add_shot(stage, "/Cam", 48, 24, "shot.exr", vars_)[1].CreateDataWindowNDCAttr(Gf.Vec4f(*window))
    stage.Save()
    return path


def expected_hits(stage_path: str, width: int = 48, height: int = 24) -> dict:
    """What the ray through each pixel centre of the full ``width x height`` image hits, from pxr's frustum of /Cam
    and the geometry above: world position ``P`` (0 on a miss), its camera-space ``Peye`` by pxr's view matrix, the
    ``prim`` and ``instance`` paths and the mesh ``face`` (-1 on a miss, 0 on the sphere), and ``clear``: the hit is
    no closer than 0.02 to an edge or a silhouette (its ids do not depend on rounding)."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.Open(stage_path)
    frustum = UsdGeom.Camera(stage.GetPrimAtPath("/Cam")).GetCamera(Usd.TimeCode.Default()).frustum
    view = frustum.ComputeViewMatrix()
    out = {"P": np.zeros((height, width, 3)), "Peye": np.zeros((height, width, 3)),
           "prim": np.full((height, width), "", object), "instance": np.full((height, width), "", object),
           "face": np.full((height, width), -1), "clear": np.ones((height, width), bool)}
    for i in range(height):
        for j in range(width):
            ray = frustum.ComputePickRay(Gf.Vec2d(2 * (j + 0.5) / width - 1, 1 - 2 * (i + 0.5) / height))
            o, d = np.array(ray.startPoint), np.array(ray.direction)
            found = []  # (t, P, prim, instance, face, margin to the nearest edge)
            for z, spans, prim in ((0.0, [(STRIP_X[k], STRIP_X[k + 1], k) for k in range(3)], "/Strip"),
                                   (-1.0, [(x - 0.6, x + 0.6, k) for k, x in enumerate(QUADS_X)],
                                    "/PI/Protos/Quad/Mesh")):
                t = (z - o[2]) / d[2]
                p = o + t * d
                for lo, hi, k in spans:
                    if lo <= p[0] <= hi and abs(p[1]) <= 1:
                        margin = min(p[0] - lo, hi - p[0], 1 - abs(p[1]))
                        if prim == "/Strip" and k == 1:  # the pentagon's top edges meet at its apex (x, 1)
                            margin = min(margin, 0.05)  # edges inside the face are no edges of it: any margin
                        inst = f"/PI[{k}]" if prim != "/Strip" else ""
                        found.append((t, p, prim, inst, k if prim == "/Strip" else 0, margin))
            centre, radius = np.array(BALL[0]), BALL[1]
            dn = d / np.linalg.norm(d)
            b = np.dot(o - centre, dn)
            disc = b * b - (np.dot(o - centre, o - centre) - radius**2)
            if disc > 0:
                t = -b - np.sqrt(disc)
                found.append((t / np.linalg.norm(d), o + t * dn, "/Ball", "", 0, np.sqrt(disc)))
            if not found:
                continue
            t, p, prim, inst, face, margin = min(found, key=lambda f: f[0])
            out["P"][i, j], out["prim"][i, j], out["instance"][i, j], out["face"][i, j] = p, prim, inst, face
            out["Peye"][i, j] = view.Transform(Gf.Vec3d(*p))
            out["clear"][i, j] = margin > 0.02
    return out


def test_positions_and_ids_of_the_hits(tmp_path):
    """P and Peye are the camera rays' hits in world and camera space (pxr's frustum and view matrix; 0 on a miss);
    primId is one id per prim drawn (every instance of the quad prototype shares it), named in the EXR header;
    elementId is the USD face (the pentagon's three triangles are face 1), 0 on the sphere; instanceId differs per
    PointInstancer instance (-1 off instances), named /PI[k]; prim keeps wrt's triangle ids."""
    stage = planar_stage(tmp_path, {"P": ("P", None), "Peye": ("Peye", None), "primId": ("primId", None),
                                    "elementId": ("elementId", None), "instanceId": ("instanceId", None),
                                    "prim": ("prim", None)})
    scene = load(stage)
    written = wrt.render_products(scene, tmp_path / "out", device="cpu")
    exr, header = read_exr(written["/Render/Shot"]), read_header(written["/Render/Shot"])
    want = expected_hits(stage)
    hit = want["prim"] != ""
    clear = want["clear"]
    assert clear.mean() > 0.5 and len(set(want["prim"][hit & clear])) == 3 and len(set(want["face"][clear])) == 4
    for name in ("P", "Peye"):
        got = np.stack([exr[f"{name}.{c}"] for c in "XYZ"], axis=-1)
        np.testing.assert_allclose(got[clear], want[name][clear], atol=2e-4)
        assert np.all(got[~hit] == 0)
    prims = json.loads(header["primId/paths"])
    assert sorted(prims.values()) == ["/Ball", "/PI/Protos/Quad/Mesh", "/Strip"]
    named = np.array([prims.get(str(int(i)), "") for i in exr["primId"].ravel()], object).reshape(want["prim"].shape)
    np.testing.assert_array_equal(named[clear], want["prim"][clear])
    assert np.all(exr["primId"][~hit] == -1)
    np.testing.assert_array_equal(exr["elementId"][clear], want["face"][clear])
    instances = json.loads(header["instanceId/paths"])
    named = np.array([instances.get(str(int(i)), "") for i in exr["instanceId"].ravel()], object)
    np.testing.assert_array_equal(named.reshape(want["instance"].shape)[clear], want["instance"][clear])
    assert len(set(exr["instanceId"][clear & (want["instance"] != "")])) == 3
    image = wrt.render(scene, device="cpu")
    np.testing.assert_array_equal(exr["prim"], image.aovs["prim"])  # wrt's triangle ids, under wrt's name
    assert len(np.unique(exr["prim"][want["prim"] == "/Strip"])) == 7  # triangles, not faces


def test_camera_space_positions_keep_their_digits_far_from_the_world_origin(tmp_path):
    """Peye of a camera a million units from the origin: the rays start at the eye in float32 (1000000.3 is
    1000000.3125 there), and Peye subtracted the float64 eye from their hits, an error of 0.0125 in x (a tenth of the
    values near the image centre) where cameraDepth and depth keep every digit. The oracle: each pixel centre's ray
    of pxr's frustum met with the plane z = 0 in float64, moved by pxr's view matrix."""
    from pxr import Gf, Usd, UsdGeom

    x = 1.0e6 + 0.3
    path = str(tmp_path / "far.usda")
    stage = Usd.Stage.CreateNew(path)
    plane = UsdGeom.Mesh.Define(stage, "/Plane")
    plane.CreatePointsAttr([(x - 50, -50, 0), (x + 50, -50, 0), (x + 50, 50, 0), (x - 50, 50, 0)])
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(x, 0.2, 5.0))
    cam.AddRotateXYZOp().Set(Gf.Vec3f(-10.0, 15.0, 0.0))
    width, height = 12, 8
    settings, _ = add_shot(stage, "/Cam", width, height, "far.exr",
                           {name: (name, None) for name in ("Peye", "cameraDepth")})
    settings.CreateAspectRatioConformPolicyAttr("adjustApertureHeight")  # the frustum's window, height set below
    stage.Save()
    exr = read_exr(wrt.render_products(load(path), tmp_path / "out", device="cpu")["/Render/Shot"])
    frustum = cam.GetCamera(Usd.TimeCode.Default()).frustum
    window = frustum.GetWindow()
    half = window.GetSize()[0] / 2 * height / width
    frustum.SetWindow(Gf.Range2d(Gf.Vec2d(window.GetMin()[0], -half), Gf.Vec2d(window.GetMax()[0], half)))
    view = np.array(frustum.ComputeViewMatrix()).T  # column vectors
    want = np.zeros((height, width, 3))
    for i in range(height):
        for j in range(width):
            ray = frustum.ComputePickRay(Gf.Vec2d(2 * (j + 0.5) / width - 1, 1 - 2 * (i + 0.5) / height))
            o, d = np.array(ray.startPoint), np.array(ray.direction)
            want[i, j] = view[:3, :3] @ (o - o[2] / d[2] * d) + view[:3, 3]
    got = np.stack([exr[f"Peye.{c}"] for c in "XYZ"], axis=-1)
    np.testing.assert_allclose(exr["cameraDepth"], -want[..., 2], atol=1e-4)  # (always kept its digits)
    np.testing.assert_allclose(got, want, atol=1e-4)


def test_prim_ids_of_native_instances_name_their_instance_proxy_paths(tmp_path):
    """Two native instances of one quad above the stage: their primIds differ and the header names them by the
    instance-proxy paths /Left/Body and /Right/Body (stable when the stage is opened again), as Scene.hit_paths names
    the same camera's hits; the PointInstancer's quads keep one id. Both were /__Prototype_1/Body, one id."""
    from pxr import Sdf, Usd, UsdGeom

    path = planar_stage(tmp_path, {"primId": ("primId", None), "instanceId": ("instanceId", None)})
    stage = Usd.Stage.Open(path)
    stage.DefinePrim("/Asset").SetSpecifier(Sdf.SpecifierClass)
    body = UsdGeom.Mesh.Define(stage, "/Asset/Body")
    body.CreatePointsAttr([(-0.6, -0.5, 0), (0.6, -0.5, 0), (0.6, 0.5, 0), (-0.6, 0.5, 0)])
    body.CreateFaceVertexCountsAttr([4])
    body.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    for name, x in (("Left", 0.5), ("Right", 3.5)):
        inst = UsdGeom.Xform.Define(stage, f"/{name}")
        inst.GetPrim().GetReferences().AddInternalReference("/Asset")
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set((x, 2.5, -1))
    stage.Save()
    scene = load(path)
    written = wrt.render_products(scene, tmp_path / "out", device="cpu")
    exr, header = read_exr(written["/Render/Shot"]), read_header(written["/Render/Shot"])
    table = json.loads(header["primId/paths"])
    assert sorted(table.values()) == ["/Ball", "/Left/Body", "/PI/Protos/Quad/Mesh", "/Right/Body", "/Strip"]
    prims, instances = scene.hit_paths(wrt.trace(scene, *camera_rays(scene, "/Cam", 48, 24)))
    np.testing.assert_array_equal(np.array([table.get(str(int(i)), "") for i in exr["primId"].ravel()]), prims)
    named = json.loads(header["instanceId/paths"])
    np.testing.assert_array_equal(np.array([named.get(str(int(i)), "") for i in exr["instanceId"].ravel()]),
                                  instances)
    assert {"/Left", "/Right"} <= set(named.values())


def test_cropped_product_is_placed_in_its_shot(tmp_path):
    """dataWindowNDC (0.1, 0.3, 0.6, 0.9) of 48x24: the EXR's display window is the whole shot and its data window
    the pixels whose centres lie in the window (counted here from the rule), rows from the top; each pixel of the
    crop is the one of the full image there (P from pxr's frustum)."""
    window = (0.1, 0.3, 0.6, 0.9)
    stage = planar_stage(tmp_path, {"P": ("P", None), "depth": ("depth", None)}, window)
    written = wrt.render_products(load(stage), tmp_path / "out", device="cpu")
    header, exr = read_header(written["/Render/Shot"]), read_exr(written["/Render/Shot"])
    columns = [j for j in range(48) if window[0] <= (j + 0.5) / 48 < window[2]]
    rows = [i for i in range(24) if window[1] <= 1 - (i + 0.5) / 24 < window[3]]  # NDC y goes up
    assert [list(v) for v in header["displayWindow"]] == [[0, 0], [47, 23]]
    assert [list(v) for v in header["dataWindow"]] == [[columns[0], rows[0]], [columns[-1], rows[-1]]]
    got = np.stack([exr[f"P.{c}"] for c in "XYZ"], axis=-1)
    assert got.shape == (len(rows), len(columns), 3)
    want = expected_hits(stage)
    crop = np.ix_(rows, columns)
    clear = want["clear"][crop] & (want["prim"][crop] != "")
    assert clear.sum() > 20
    np.testing.assert_allclose(got[clear], want["P"][crop][clear], atol=2e-4)


def test_exr_pixel_aspect_ratio_is_the_shape_the_pixels_were_rendered_with(tmp_path):
    """An EXR product's ``pixelAspectRatio`` is the one UsdRenderComputeSpec gives the product: the authored one,
    except under ``adjustPixelAspectRatio``, which "disregards" it and computes the apertures' aspect over the
    resolution's (the film is the apertures, so the pixels take that shape), also when a data window crops the
    image. The authored 2 was written there, which a compositor showed squashed to a quarter of the film's aspect."""
    from pxr import Usd, UsdGeom

    products = "".join(product(name, ["depth"], f"{name}.exr", extra) for name, extra in [
        ("Adjusted", 'uniform token aspectRatioConformPolicy = "adjustPixelAspectRatio"\n'),
        ("Cropped", 'uniform token aspectRatioConformPolicy = "adjustPixelAspectRatio"\n'
                    "uniform float4 dataWindowNDC = (0.25, 0, 1, 0.5)\n"),
        ("Fitted", 'uniform token aspectRatioConformPolicy = "cropAperture"\n'),
    ])
    stage = write_stage(tmp_path, products, ["Adjusted", "Cropped", "Fitted"],
                        settings="uniform float pixelAspectRatio = 2\n")
    written = wrt.render_products(load(stage), tmp_path / "out", device="cpu")
    usd_stage = Usd.Stage.Open(stage)
    front = UsdGeom.Camera(usd_stage.GetPrimAtPath("/World/Front")).GetCamera(Usd.TimeCode.Default())
    adjusted = (front.horizontalAperture / front.verticalAperture) / (32 / 16)  # UsdRenderComputeSpec's
    for name, ratio in [("Adjusted", adjusted), ("Cropped", adjusted), ("Fitted", 2.0)]:
        assert read_header(written[f"/Render/{name}"])["pixelAspectRatio"] == pytest.approx(ratio, rel=1e-6), name


def test_png_products_say_the_shape_of_their_pixels(tmp_path):
    """A PNG product of non-square pixels carried no pHYs chunk, so viewers showed it stretched (the EXR says it in
    its header, the test above). Its pHYs now holds the ratio UsdRenderComputeSpec gives the product, read by Pillow
    and png_chunks' reader; a product of square pixels has none (square is what a PNG without it means)."""
    from pxr import Usd, UsdGeom
    from test_render_settings import png_pixel_aspect_ratio

    products = "".join(product(name, ["color"], f"{name}.png", extra) for name, extra in [
        ("Adjusted", 'uniform token aspectRatioConformPolicy = "adjustPixelAspectRatio"\n'),
        ("Fitted", 'uniform token aspectRatioConformPolicy = "cropAperture"\n'),
        ("Square", 'uniform token aspectRatioConformPolicy = "cropAperture"\nuniform float pixelAspectRatio = 1\n'),
    ])
    stage = write_stage(tmp_path, products, ["Adjusted", "Fitted", "Square"],
                        settings="uniform float pixelAspectRatio = 2\n")
    written = wrt.render_products(load(stage), tmp_path / "out", spp=1, device="cpu")
    usd_stage = Usd.Stage.Open(stage)
    front = UsdGeom.Camera(usd_stage.GetPrimAtPath("/World/Front")).GetCamera(Usd.TimeCode.Default())
    adjusted = (front.horizontalAperture / front.verticalAperture) / (32 / 16)  # UsdRenderComputeSpec's
    assert abs(adjusted - 1.0) > 0.1
    for name, ratio in [("Adjusted", adjusted), ("Fitted", 2.0)]:
        assert png_pixel_aspect_ratio(written[f"/Render/{name}"]) == pytest.approx(ratio, rel=1e-5), name
    assert png_pixel_aspect_ratio(written["/Render/Square"]) is None


def test_aov_names_name_the_layers(tmp_path):
    """driver:parameters:aov:name, where authored, names a RenderVar's layer (RenderMan's channel name); the prim
    name otherwise; the first beauty stays R, G, B."""
    stage = planar_stage(tmp_path, {"beauty": ("color", "Ci"), "depthVar": ("cameraDepth", "Z"),
                                    "normals": ("normal", "Nworld"), "primvar": ("primId", None)})
    written = wrt.render_products(load(stage), tmp_path / "out", device="cpu")
    assert sorted(read_exr(written["/Render/Shot"])) == sorted(["R", "G", "B", "Z", "Nworld.X", "Nworld.Y",
                                                                 "Nworld.Z", "primvar"])


def test_exposure_with_exr_products_warns_once(tmp_path):
    """--exposure scales PNG products only: with EXR products one warning says so (as ``-o x.exr`` does)."""
    products = (product("Beauty", ["color"], "beauty.png") + product("A", ["depth"], "a.exr")
                + product("B", ["Ci", "depth"], "b.exr"))
    scene = load(write_stage(tmp_path, products, ["Beauty", "A", "B"]))
    with pytest.warns(UserWarning) as record:
        wrt.render_products(scene, tmp_path / "out", device="cpu", exposure=1.5)
    messages = [str(w.message) for w in record if "exposure" in str(w.message)]
    assert messages == ["shot.usda: exposure applies to .png products only; a.exr is written linear, unscaled"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wrt.render_products(scene, tmp_path / "out2", device="cpu", exposure=0.0)


def test_render_settings_warnings_point_at_the_load_usd_call(tmp_path):
    """Every warning about the render settings points at the caller's line, as wrt's other load warnings do; those
    of a product left out and of a stale renderSettingsPrimPath pointed into wrt (usd.py's call of
    read_render_settings), and a RenderVar target that is no RenderVar at a line of render_settings.py."""
    products = (product("A", ["color"], "a.png", "rel camera = </World/Nope>\n")
                + product("B", ["color"], "b.png").replace("orderedVars = [", "orderedVars = [</World/Box>, "))
    path = write_stage(tmp_path, products, ["A", "B"],
                       settings='uniform token renderingColorSpace = "srgb_texture"\n')
    stale = path.replace("shot.usda", "stale.usda")
    open(stale, "w").write(open(path).read().replace('"/Render/Settings"', '"/Render/Gone"'))
    for stage, expected in ((path, 3), (stale, 1)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            wrt.load_usd(stage)
        assert len(caught) == expected, [str(w.message) for w in caught]
        assert [w.filename for w in caught] == [__file__] * expected, [str(w.message) for w in caught]


def edge_quad_stage(tmp_path, color) -> str:
    """A stage rendering an EXR and a PNG product (RGBA) of a quad of ``color`` in a 20 x 10 film: camera at the origin
    looking down -Z, film 36 x 18 at focal length 50, so at z = -10 the columns are 0.36 wide (column j spans x in
    [-3.6 + 0.36 j, -3.24 + 0.36 j]); the quad spans x in [0.09, 1.17], covering 3/4 of column 10 and 1/4 of 13."""
    quad = fmt([[0.09, -100, -10], [1.17, -100, -10], [1.17, 100, -10], [0.09, 100, -10]])
    body = (f'def Mesh "Quad"\n{{\n    point3f[] points = {quad}\n    int[] faceVertexCounts = [4]\n'
            f'    int[] faceVertexIndices = [0, 1, 2, 3]\n    color3f[] primvars:displayColor = [{tuple(color)}]\n}}\n'
            'def DistantLight "Sun"\n{\n}\n'  # a light of its own: no default dome shows behind the quad
            'def Camera "Cam"\n{\n    float focalLength = 50\n    float horizontalAperture = 36\n'
            '    float verticalAperture = 18\n}\n'
            'def Scope "Render"\n{\n    def RenderSettings "Settings"\n    {\n        rel camera = </Cam>\n'
            '        uniform int2 resolution = (20, 10)\n        rel products = [</Render/Exr>, </Render/Png>]\n'
            '    }\n' + product("Exr", ["color"], "beauty.exr") + product("Png", ["color"], "beauty.png")
            + 'def Scope "Vars"\n{\n' + var("color", "color", "color4f") + "}\n}\n")
    path = write(tmp_path, body, "edges.usda")
    text = open(path).read().replace("(\n", '(\n    renderSettingsPrimPath = "/Render/Settings"\n', 1)
    open(path, "w").write(text)
    return path


def test_alpha_is_the_coverage_of_the_pixels_samples(tmp_path):
    """A quad whose left edge covers 3/4 of column 10 (its centre inside) and whose right edge covers 1/4 of column
    13 (its centre outside), against an empty black background at 256 spp: alpha, in the EXR and in the PNG, is the
    share of the pixel the quad covers, worked out from the film, as the antialiased colour is; the colour over
    alpha is the quad's. Alpha was the pixel-centre ray's hit (1 and 0 there): composited over a plate, one edge
    came out dark and the other glowed."""
    scene = load(edge_quad_stage(tmp_path, (0.8, 0.8, 0.8)))
    written = wrt.render_products(scene, tmp_path / "out", spp=256, device="cpu")
    coverage = np.zeros(20)
    coverage[[10, 11, 12, 13]] = [0.75, 1.0, 1.0, 0.25]
    exr = read_exr(written["/Render/Exr"])
    alpha = exr["A"]
    np.testing.assert_allclose(alpha, np.broadcast_to(coverage, (10, 20)), atol=0.1)
    np.testing.assert_array_equal(alpha[:, [11, 12]], 1.0)
    np.testing.assert_array_equal(alpha[:, :10], 0.0)
    # Premultiplied, as OpenEXR's RGBA is: an edge pixel's colour over its alpha is the inside's colour.
    rgb = np.stack([exr[c] for c in "RGB"], axis=-1)
    for edge, inside in ((10, 11), (13, 12)):
        np.testing.assert_allclose(rgb[:, edge] / alpha[:, edge, None], rgb[:, inside], rtol=0.05)
    png = np.asarray(PilImage.open(written["/Render/Png"]))
    assert png.shape == (10, 20, 4)
    np.testing.assert_array_equal(png[..., 3], np.round(alpha * 255))


def test_png_alpha_is_straight_so_it_composites_as_the_premultiplied_exr(tmp_path):
    """PNG alpha is unassociated (PNG specification, 4.3.2: colour not premultiplied), OpenEXR's RGBA premultiplied.
    The PNG product held the premultiplied colour under its coverage alpha: composited over a white plate as a PNG
    reader does (``C a + plate (1 - a)``), an edge a quad covers three quarters of came out darker than the EXR of
    the same render composited as premultiplied (``C + plate (1 - a)``), by ``C a (1 - a)``. Both now agree to the
    PNG's 8-bit rounding, and the edges' PNG colour is the inside's."""
    from png_chunks import decode_pixels, read_chunks

    written = wrt.render_products(load(edge_quad_stage(tmp_path, (0.8, 0.5, 0.3))), tmp_path / "out", spp=64,
                                  device="cpu")
    exr = read_exr(written["/Render/Exr"])
    alpha = exr["A"].astype(np.float64)
    assert 0.5 < alpha[0, 10] < 1.0 and 0.0 < alpha[0, 13] < 0.5  # the edges are partly covered
    png = decode_pixels(read_chunks(written["/Render/Png"])).astype(np.float64) / 255.0
    np.testing.assert_array_equal(png[..., 3], np.round(alpha * 255) / 255)
    srgb = png[..., :3]
    colour = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)  # straight, linear
    over_white_png = colour * png[..., 3:] + (1.0 - png[..., 3:])
    over_white_exr = np.stack([exr[c] for c in "RGB"], axis=-1) + (1.0 - alpha[..., None])
    np.testing.assert_allclose(over_white_png, over_white_exr, atol=0.01)
    for edge in (10, 13):  # the straight colour of an edge pixel is the quad's, as inside it
        np.testing.assert_allclose(colour[:, edge], colour[:, 11], atol=0.01)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_camera_depth_is_camera_space_depth_under_a_sheared_and_scaled_camera(tmp_path, projection):
    """RenderVar ``cameraDepth`` is Hydra's: minus the z of the hit by the view matrix (the inverse of the camera's
    whole transform), the ``Peye`` beside it, -z. Under a sheared and scaled parent it was wrt's ``z`` AOV (world
    units along the world view axis), 2.5 to 3 times it here. Oracle: float64 hits of each pixel centre's
    camera-space ray moved by pxr's ComputeLocalToWorldTransform, through pxr's inverse of it."""
    from pxr import Gf, Usd, UsdGeom
    from test_camera import SHEARED_PARENT, posed_camera

    path = str(tmp_path / "sheared.usda")
    stage = Usd.Stage.CreateNew(path)
    cam = posed_camera(stage, "/P/Cam", projection, SHEARED_PARENT, HorizontalAperture=36.0, VerticalAperture=24.0,
                       HorizontalApertureOffset=3.0)
    m = cam.ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    # A tilted plane in front of the camera, placed in the world by the camera's transform.
    corners = [m.Transform(Gf.Vec3d(x, y, -6.0 + 0.1 * x + 0.05 * y))
               for x, y in ((-20, -20), (20, -20), (20, 20), (-20, 20))]
    plane = UsdGeom.Mesh.Define(stage, "/Plane")
    plane.CreatePointsAttr(corners)
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    plane.CreateSubdivisionSchemeAttr("none")
    plane.CreateDoubleSidedAttr(True)
    width, height = 6, 4
    add_shot(stage, "/P/Cam", width, height, "shot.exr", {name: (name, None) for name in ("cameraDepth", "Peye")})
    stage.Save()

    exr = read_exr(wrt.render_products(load(path), tmp_path / "out", device="cpu")["/Render/Shot"])
    a, b, c = (np.array(p) for p in corners[:3])
    normal = np.cross(b - a, c - a)
    view = m.GetInverse()
    expected = np.zeros((height, width, 3))
    for i in range(height):
        for j in range(width):
            x = ((j + 0.5) / width - 0.5) * 36.0 + 3.0  # the film: the apertures, of the image's aspect
            y = (0.5 - (i + 0.5) / height) * 24.0
            near = (0.0, 0.0, 0.0) if projection == "perspective" else (0.1 * x, 0.1 * y, 0.0)
            far = (x / 50.0, y / 50.0, -1.0) if projection == "perspective" else (0.1 * x, 0.1 * y, -1.0)
            o, p = np.array(m.Transform(Gf.Vec3d(*near))), np.array(m.Transform(Gf.Vec3d(*far)))
            hit = o + np.dot(a - o, normal) / np.dot(p - o, normal) * (p - o)  # float64, in the world
            expected[i, j] = view.Transform(Gf.Vec3d(*hit))
    np.testing.assert_allclose(np.stack([exr[f"Peye.{c}"] for c in "XYZ"], -1), expected, atol=1e-4)
    np.testing.assert_allclose(exr["cameraDepth"], -expected[..., 2], rtol=1e-5)


def test_a_layer_whose_channel_another_layer_writes_gets_a_name_of_its_own(tmp_path):
    """RenderVars whose layers are named apart yet write one channel: the normal's layer ``N`` writes ``N.X``, and a
    depth RenderVar named ``N.X`` (driver:parameters:aov:name) writes a channel of that name too. The depth was
    written over the normal's X without a word; each now has channels of its own. Oracle: the hits of pxr's frustum
    (normal +Z on the planes, depth = distance from the camera)."""
    stage = planar_stage(tmp_path, {"normals": ("normal", "N"), "distance": ("depth", "N.X")})
    exr = read_exr(wrt.render_products(load(stage), tmp_path / "out", device="cpu")["/Render/Shot"])
    assert len(exr) == 4 and {"N.X", "N.Y", "N.Z"} <= set(exr)
    depth = exr[next(name for name in exr if name not in ("N.X", "N.Y", "N.Z"))]
    want = expected_hits(stage)
    planes = want["clear"] & np.isin(want["prim"], ["/Strip", "/PI/Protos/Quad/Mesh"])
    assert planes.sum() > 50
    normals = np.stack([exr[f"N.{c}"] for c in "XYZ"], axis=-1)
    np.testing.assert_allclose(normals[planes], np.broadcast_to([0.0, 0.0, 1.0], (planes.sum(), 3)), atol=1e-5)
    eye = np.array([1.0, 0.5, 10.0])
    np.testing.assert_allclose(depth[planes], np.linalg.norm(want["P"][planes] - eye, axis=-1), rtol=1e-5)


def test_layers_of_names_too_long_for_exr_keep_their_channels_and_paths(tmp_path):
    """OpenEXR cuts channel names to 255 bytes and drops longer attribute names, without a word: two RenderVars named
    by one 300-letter driver:parameters:aov:name wrote one channel (the later over the earlier), and the primId
    layer's ``<layer>/paths`` was missing. Long names are shortened, with a warning naming the RenderVar; every
    channel is read back with its values (pxr's frustum hits), and the paths name the prims drawn."""
    long_name = "p" * 300
    stage = planar_stage(tmp_path, {"ids": ("primId", long_name), "distance": ("depth", long_name)})
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        written = wrt.render_products(load(stage), tmp_path / "out", device="cpu")
    exr, header = read_exr(written["/Render/Shot"]), read_header(written["/Render/Shot"])
    assert len(exr) == 2 and all(len(name) <= 255 for name in exr)
    assert any("RenderVar /Render/Vars/ids: its layer name is longer than the 255 bytes" in str(w.message)
               for w in record)
    ids, depth = (exr[name] for name in sorted(exr, key=len))  # the second layer of one name has a _2 more
    want = expected_hits(stage)
    clear = want["clear"] & (want["prim"] != "")
    prims = json.loads(header[f"{sorted(exr, key=len)[0]}/paths"])
    named = np.array([prims.get(str(int(i)), "") for i in ids.ravel()], object).reshape(want["prim"].shape)
    np.testing.assert_array_equal(named[clear], want["prim"][clear])
    np.testing.assert_allclose(depth[clear], np.linalg.norm(want["P"][clear] - [1.0, 0.5, 10.0], axis=-1),
                               rtol=1e-5)


def test_an_overscanned_product_is_placed_in_its_shot_past_its_edges(tmp_path):
    """dataWindowNDC (-0.25, -0.25, 0.75, 0.75) of 48x24 reaches past the left and bottom edges (overscan): the EXR's
    data window starts at negative columns and ends past the last row, counted from the rule (centres in the window,
    NDC y up), the display window is the shot, and each pixel inside the shot holds the hit of that pixel of the full
    image (pxr's frustum)."""
    window = (-0.25, -0.25, 0.75, 0.75)
    stage = planar_stage(tmp_path, {"P": ("P", None)}, window)
    written = wrt.render_products(load(stage), tmp_path / "out", device="cpu")
    header, exr = read_header(written["/Render/Shot"]), read_exr(written["/Render/Shot"])
    columns = [j for j in range(-48, 96) if window[0] <= (j + 0.5) / 48 < window[2]]
    rows = [i for i in range(-24, 48) if window[1] <= 1 - (i + 0.5) / 24 < window[3]]
    assert columns[0] < 0 and rows[-1] > 23  # past the edges indeed
    assert [list(v) for v in header["displayWindow"]] == [[0, 0], [47, 23]]
    assert [list(v) for v in header["dataWindow"]] == [[columns[0], rows[0]], [columns[-1], rows[-1]]]
    got = np.stack([exr[f"P.{c}"] for c in "XYZ"], axis=-1)
    assert got.shape == (len(rows), len(columns), 3)
    inside_rows = [k for k, i in enumerate(rows) if 0 <= i < 24]
    inside_columns = [k for k, j in enumerate(columns) if 0 <= j < 48]
    inside = got[np.ix_(inside_rows, inside_columns)]
    want = expected_hits(stage)
    shot = np.ix_([rows[k] for k in inside_rows], [columns[k] for k in inside_columns])
    clear = want["clear"][shot] & (want["prim"][shot] != "")
    assert clear.sum() > 20
    np.testing.assert_allclose(inside[clear], want["P"][shot][clear], atol=2e-4)


@pytest.mark.parametrize(
    "product_name, png, name, said",
    [
        ("shot.", True, "shot.png", None),  # the dot before the extension wrt adds: not shot..png
        ("shot.0001.", False, "shot.0001.exr", None),
        ("shot..", True, "shot.png", None),
        (".png", True, "P.png", "an extension alone"),  # not the hidden file .png.png: the prim's name, as for none
        (".exr", False, "P.exr", "an extension alone"),
        (".tif", True, "P.png", "an extension alone"),
        ("...", True, "P.png", None),  # no name at all: the prim's, as for '.' and '..'
        (".beauty.png", True, "P.beauty.png", "begins with a dot"),  # was the hidden file .beauty.png
        ("..beauty.0001.exr", False, "P.beauty.0001.exr", "begins with a dot"),
        # A dotted word that is no image format is part of the name: '.beauty' was written as P.png, 'an extension
        # alone', and 'shot.beauty' and 'shot.diffuse' both as shot (shot.png and shot_2.png).
        (".beauty", True, "P.beauty.png", "begins with a dot"),
        ("shot.beauty", True, "shot.beauty.png", None),
        ("shot.diffuse", False, "shot.diffuse.exr", None),
        ("shot.TIFF", True, "shot.png", "wrt writes PNG or EXR"),
        # OpenImageIO's extensions that the list left out were kept as part of the name without a word (shot.heif.exr,
        # while shot.heic became shot.exr): HEIF, JPEG, PFM, Photoshop, JPEG 2000 and stereo/multiview EXR files.
        ("shot.heif", False, "shot.exr", "wrt writes PNG for a product"),
        ("shot.JFIF", True, "shot.png", "wrt writes PNG or EXR"),
        ("shot.pfm", False, "shot.exr", "wrt writes PNG for a product"),
        ("shot.psb", True, "shot.png", "wrt writes PNG or EXR"),
        ("shot.j2c", True, "shot.png", "wrt writes PNG or EXR"),
        ("shot.sxr", False, "shot.exr", "wrt writes PNG for a product"),
        ("shot.env", False, "shot.env.exr", None),  # also a pass's name: kept
    ],
)
def test_a_product_name_ending_in_a_dot_or_an_extension_alone_names_a_sensible_file(product_name, png, name, said):
    """productName 'shot.' was written as 'shot..png', '.png' as the hidden file '.png.png' and '.beauty.png' as the
    hidden '.beauty.png' (a templated name whose shot was empty). The README: a name without an extension gets one,
    no productName gives the prim's name; a name that begins with a dot (an extension alone too) gets the prim's name
    before it, with a warning naming the product and the file."""
    from types import SimpleNamespace

    from wrt.render_products import TakenNames, product_file_name

    product = SimpleNamespace(product_name=product_name, product="/Render/P")
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        assert product_file_name(product, png, "shot.usda", TakenNames()) == name
    messages = [str(w.message) for w in record]
    if said is None:
        assert not any("productName" in m and "format" not in m for m in messages), messages
    else:
        assert any(f"/Render/P productName {product_name!r}" in m and said in m and name in m for m in messages), \
            messages


@pytest.mark.parametrize("largest, rounded", [(2**24, 0), (2**24 + 1, 1), (2**31 - 1, 1)])
def test_id_channels_warn_only_where_an_id_is_rounded(largest, rounded):
    """Every integer up to 2^24 is exact in float32 (numpy's own round trip, the oracle); 2^24 itself was said to be
    rounded. Now the warning comes where an id changes, counting them."""
    from wrt.render_products import _Output, output_channels

    ids = np.array([[-1, 0, 2**24 - 1, largest]], np.int32)
    image = wrt.Image(rgb=np.zeros((1, 4, 3), np.float32), aovs={"prim": ids})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        camera = type("Camera", (), {"to_world": np.eye(4)})  # the prim layer reads no view
        channels, _ = output_channels(image, camera, None, [_Output("prim", "prim")])
    said = [str(w.message) for w in caught]
    assert len(said) == rounded and all("ids past 16777216" in s and f"{rounded} of them" in s for s in said)
    exact = ids.astype(np.float32).astype(np.int64) == ids
    np.testing.assert_array_equal(channels["prim"][exact], ids[exact])


def test_the_id_rounding_warning_counts_ids_not_pixels():
    """One prim of id 2^24 + 1 over three pixels and one of 2^24 + 3 over one: two ids rounded (the oracle: the set of
    ids that numpy's float32 round trip changes), in four pixels; it said '4 ids'. A miss (-1) is exact."""
    from wrt.render_products import _Output, output_channels

    ids = np.array([[2**24 + 1, -1, 2**24 + 1, 2**24 + 3, 2**24 + 1]], np.int32)
    changed = {int(i) for i in ids.ravel() if int(np.float32(i)) != int(i)}
    image = wrt.Image(rgb=np.zeros((1, 5, 3), np.float32), aovs={"prim": ids})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        camera = type("Camera", (), {"to_world": np.eye(4)})  # the prim layer reads no view
        output_channels(image, camera, None, [_Output("prim", "prim")])
    said = [str(w.message) for w in caught]
    assert len(said) == 1, said
    assert f"{len(changed)} of them (the largest {max(changed)}), in 4 pixels" in said[0], said


def test_an_exr_product_of_pixels_an_exr_header_cannot_state_fails_before_any_render(tmp_path, monkeypatch):
    """Pixels 2e6 times as wide as tall: OpenEXR's header takes pixel aspect ratios up to 1e6 (its own write of that
    header fails, the oracle); the product was rendered and then failed naming the temporary file. Now the call
    fails naming the product and the file before any render, no file written."""
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, "pixelAspectRatio": 2e6}
    with pytest.raises(Exception):
        with OpenEXR.File(header, {"R": np.zeros((2, 2), np.float32)}) as f:
            f.write(str(tmp_path / "oracle.exr"))
    products = product("A", ["color"], "a.png") + product("B", ["depth"], "b.exr")
    settings = "uniform float pixelAspectRatio = 2000000\n"
    scene = load(write_stage(tmp_path, products, ["A", "B"], settings=settings))
    products_module = importlib.import_module("wrt.render_products")  # wrt.render_products is the function
    monkeypatch.setattr(products_module, "render_views", lambda *args, **kwargs: pytest.fail("rendered"))
    with pytest.raises(ValueError, match=r"shot.usda: /Render/B: cannot write .*b\.exr: pixels 2e\+06 times as wide"):
        wrt.render_products(scene, tmp_path / "out", device="cpu")
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())


def test_wrt_render_of_an_exr_of_pixels_an_exr_header_cannot_state_fails_before_the_render(tmp_path, monkeypatch,
                                                                                           capsys):
    """``wrt render shot.usda -o shot.exr`` of settings with pixels 2e6 times as wide as tall (past the 1e6 OpenEXR's
    header takes: its own write fails, the test above) rendered the whole image, then failed at the save. Now it
    fails before the renderer is made, naming the file, nothing written."""
    path = write_stage(tmp_path, product("A", ["color"], "a.png"), ["A"],
                       settings="uniform float pixelAspectRatio = 2000000\n")
    monkeypatch.setattr(wrt, "Renderer", lambda *args, **kwargs: pytest.fail("rendered"))
    out = tmp_path / "shot.exr"
    assert main(["render", str(path), "-o", str(out), "--device", "cpu", "-q"]) != 0
    assert re.search(r"cannot write .*shot\.exr: pixels 2e\+06 times as wide", capsys.readouterr().err)
    assert not out.exists()
