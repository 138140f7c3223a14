"""Radiance ``.hdr`` (RGBE) images: flat, old and adaptive run-length scanlines, the eight resolution-line orders,
EXPOSURE / COLORCORR, XYZE, domes and material textures (also inside a ``.usdz``), and clean errors for corrupt
files. The files are written here by a small encoder of the format's definition (Ward, "Real Pixels", Graphics
Gems II): a component is ``m / 256 * 2^(E - 128)``, with the exponent of the pixel's brightest component."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom, UsdLux, UsdShade

import wrt
from wrt.textures import TextureError, load_image

STANDARD = "-Y {h} +X {w}"  # rows from the top down, each from left to right


def rgbe(rgb):
    """``(..., 4)`` uint8 RGBE pixels of ``(..., 3)`` non-negative floats (mantissas truncated, as writers do)."""
    rgb = np.asarray(rgb, np.float64)
    top = rgb.max(-1)
    _, exponent = np.frexp(top)  # top = f * 2^exponent, f in [0.5, 1)
    lit = top > 1e-32
    out = np.zeros(rgb.shape[:-1] + (4,), np.uint8)
    out[..., :3] = np.where(lit[..., None], np.floor(rgb * np.ldexp(1.0, 8 - exponent)[..., None]), 0)
    out[..., 3] = np.where(lit, exponent + 128, 0)
    return out


def from_rgbe(pixels):
    """The floats ``(..., 3)`` RGBE pixels stand for."""
    pixels = np.asarray(pixels, np.float64)
    return np.where(pixels[..., 3:] > 0, pixels[..., :3] / 256 * np.ldexp(1.0, pixels[..., 3:].astype(int) - 128), 0)


def packets(component):
    """Adaptive run-length packets of one component of a scanline: runs of 4 or more equal bytes (at most 127) as a
    run, everything else as literals of at most 128 bytes."""
    out, literal, i = bytearray(), bytearray(), 0
    while i < len(component):
        run = 1
        while i + run < len(component) and component[i + run] == component[i] and run < 127:
            run += 1
        if run >= 4:
            if literal:
                out += bytes([len(literal)]) + literal
                literal = bytearray()
            out += bytes([128 + run, component[i]])
            i += run
            continue
        literal.append(component[i])
        i += 1
        if len(literal) == 128:
            out += bytes([128]) + literal
            literal = bytearray()
    if literal:
        out += bytes([len(literal)]) + literal
    return bytes(out)


def encode(scanlines, rle):
    """Pixel data of ``(S, L, 4)`` uint8 RGBE scanlines, each flat or in the adaptive run-length form."""
    out = bytearray()
    for line in scanlines:
        if rle:
            out += bytes([2, 2, len(line) >> 8, len(line) & 255])
            out += b"".join(packets(line[:, c].tobytes()) for c in range(4))
        else:
            out += line.tobytes()
    return bytes(out)


def hdr_file(path, scanlines, resolution=None, rle=True, header=("FORMAT=32-bit_rle_rgbe",), magic="#?RADIANCE"):
    """Writes a Radiance file of ``(S, L, 4)`` RGBE scanlines (the standard resolution line unless given)."""
    s, length = scanlines.shape[:2]
    resolution = resolution or STANDARD.format(h=s, w=length)
    text = "\n".join([magic, *header, "", resolution]) + "\n"
    path.write_bytes(text.encode() + encode(scanlines, rle))
    return str(path)


def sky(h, w, seed=3):
    """A ``(h, w, 3)`` image over a wide range: smooth gradients (runs of equal bytes), noise (literals), zeros and
    a bright sun."""
    rng = np.random.default_rng(seed)
    rgb = np.empty((h, w, 3))
    rgb[:] = (0.2, 0.3, 0.5)
    rgb[..., 1] += 0.001 * (np.arange(w) // 3)
    rgb[h // 2 :] = rng.random((h - h // 2, w, 3)) * np.array([2.0, 1.0, 0.01])
    rgb[0, : w // 3] = 0.0
    rgb[h // 4, w // 2] = (5e4, 4e4, 3e4)
    return rgb


def assert_within_rgbe_precision(image, rgb):
    """Each component within 1/128 of the pixel's brightest (the RGBE step), alpha 1."""
    assert image.shape == rgb.shape[:2] + (4,) and image.dtype == np.float32
    tolerance = rgb.max(-1, keepdims=True) / 128
    assert np.all(np.abs(image[..., :3] - rgb) <= tolerance)
    np.testing.assert_array_equal(image[..., 3], 1.0)


@pytest.mark.parametrize("width, rle", [(40, True), (40, False), (5, False), (32768, False)])
def test_flat_and_run_length_scanlines_read_back(tmp_path, width, rle):
    """Adaptive run-length scanlines (runs and literals) and flat ones, including widths below 8 and above 32767,
    which cannot use the run-length form; before, Pillow could not read any of them."""
    rgb = sky(6 if width > 1000 else 12, width)
    pixels = rgbe(rgb)
    path = hdr_file(tmp_path / "sky.hdr", pixels, rle=rle)
    image = load_image(path)
    assert_within_rgbe_precision(image, rgb)
    np.testing.assert_array_equal(image[..., :3], from_rgbe(pixels).astype(np.float32))
    assert image[0, 0, 0] == 0.0 and image[len(rgb) // 4, width // 2, 0] > 4e4  # zeros stay zero; the sun


def test_components_decode_as_the_format_defines():
    """``m / 256 * 2^(E - 128)``, and 0 where ``E = 0`` whatever the mantissas; an RGBE ``#?RGBE`` first line."""
    import wrt.radiance_hdr as rh

    pixels = np.array([[[128, 64, 0, 129], [255, 1, 2, 120], [9, 9, 9, 0]]], np.uint8)
    data = b"#?RGBE\n\n-Y 1 +X 3\n" + pixels.tobytes()
    image = rh.read_radiance(data, "three.hdr")
    np.testing.assert_array_equal(image[0, 0, :3], [1.0, 0.5, 0.0])
    np.testing.assert_array_equal(image[0, 1, :3], np.array([255, 1, 2]) / 256 * 2.0**-8)
    np.testing.assert_array_equal(image[0, 2, :3], 0.0)


def test_a_flat_short_scanline_starting_like_a_run_length_header_is_read_flat(tmp_path):
    """A scanline of fewer than 8 pixels is always flat: its first pixel's bytes 2, 2, 0, 5 are a pixel."""
    pixels = np.array([[[2, 2, 0, 5], [200, 100, 50, 130], [1, 2, 3, 127]]], np.uint8)
    image = load_image(hdr_file(tmp_path / "short.hdr", pixels, rle=False))
    np.testing.assert_array_equal(image[0, :, :3], from_rgbe(pixels[0]).astype(np.float32))


def test_a_header_with_windows_line_ends_reads_as_with_unix_ones(tmp_path):
    """Windows tools end the header's lines with \\r\\n: such a file was refused ("the header does not end")."""
    pixels = rgbe(sky(12, 40))
    unix = hdr_file(tmp_path / "unix.hdr", pixels, header=("FORMAT=32-bit_rle_rgbe", "EXPOSURE=2"))
    data = Path(unix).read_bytes()
    split = data.index(b"-Y 12 +X 40\n") + len(b"-Y 12 +X 40\n")  # the header and resolution line, then pixels
    windows = tmp_path / "windows.hdr"
    windows.write_bytes(data[:split].replace(b"\n", b"\r\n") + data[split:])
    np.testing.assert_array_equal(load_image(str(windows)), load_image(unix))
    np.testing.assert_array_equal(load_image(unix)[..., :3], (from_rgbe(pixels) / 2).astype(np.float32))


def test_scanlines_of_the_shortest_packets_read_exactly(tmp_path):
    """Every pixel its own packet (runs of one, literals of one byte) with empty literals between them: the file
    of most packets per pixel a writer can make, which took 12 s for 2048 x 4096 pixels in a Python walk over the
    packet headers (0.7 s now), reads back exactly."""
    pixels = rgbe(sky(24, 300))
    data = bytearray()
    for line in pixels:
        data += bytes([2, 2, 300 >> 8, 300 & 255])
        for c in range(4):
            for k, value in enumerate(line[:, c]):
                data += bytes([129, value]) if k % 2 else bytes([0, 1, value])  # a run of 1; empty, then 1 byte
    path = tmp_path / "short_packets.hdr"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 24 +X 300\n" + bytes(data))
    np.testing.assert_array_equal(load_image(str(path))[..., :3], from_rgbe(pixels).astype(np.float32))


def test_old_run_length_scanlines_repeat_the_pixel_before(tmp_path):
    """Old-style runs: ``(1, 1, 1, n)`` repeats the previous pixel ``n`` times, consecutive markers add their bytes
    8 bits higher each (a count of 256 is ``(1, 1, 1, 0), (1, 1, 1, 1)``)."""
    a, b, c = (100, 50, 25, 130), (30, 200, 90, 126), (255, 128, 0, 128)
    line = [a, (1, 1, 1, 11), b, (1, 1, 1, 0), (1, 1, 1, 1), c] + [(130, 131, 132, 127)] * 30
    width = 1 + 11 + 1 + 256 + 1 + 30
    expected = np.array([a] * 12 + [b] * 257 + [c] + [(130, 131, 132, 127)] * 30, np.uint8)
    path = tmp_path / "old.hdr"
    path.write_bytes(f"#?RADIANCE\n\n-Y 2 +X {width}\n".encode() + 2 * np.array(line, np.uint8).tobytes())
    image = load_image(str(path))
    assert image.shape == (2, width, 4)
    np.testing.assert_array_equal(image[..., :3], np.broadcast_to(from_rgbe(expected), (2, width, 3)))


# Scanlines of each resolution line, written out from the image (row 0 at the top): Radiance's Y points up.
ORDERS = {
    "-Y {h} +X {w}": lambda img: img,
    "-Y {h} -X {w}": lambda img: img[:, ::-1],
    "+Y {h} +X {w}": lambda img: img[::-1],
    "+Y {h} -X {w}": lambda img: img[::-1, ::-1],
    "+X {w} -Y {h}": lambda img: img.transpose(1, 0, 2),  # columns left to right, each from the top down
    "+X {w} +Y {h}": lambda img: img[::-1].transpose(1, 0, 2),
    "-X {w} -Y {h}": lambda img: img[:, ::-1].transpose(1, 0, 2),
    "-X {w} +Y {h}": lambda img: img[::-1, ::-1].transpose(1, 0, 2),
}


@pytest.mark.parametrize("order", ORDERS)
def test_each_resolution_line_order_reads_upright(tmp_path, order):
    rgb = sky(9, 12)
    scanlines = np.ascontiguousarray(ORDERS[order](rgbe(rgb)))
    image = load_image(hdr_file(tmp_path / "o.hdr", scanlines, resolution=order.format(h=9, w=12)))
    assert_within_rgbe_precision(image, rgb)


def test_exposure_and_colorcorr_are_divided_out(tmp_path):
    """Radiance's definition: the pixels were multiplied by every EXPOSURE and COLORCORR line's numbers."""
    rgb = sky(8, 16)
    header = ("FORMAT=32-bit_rle_rgbe", "EXPOSURE=2", "EXPOSURE= 4.0", "COLORCORR=1 0.5 2", "PRIMARIES=ignored")
    image = load_image(hdr_file(tmp_path / "e.hdr", rgbe(rgb), header=header))
    plain = load_image(hdr_file(tmp_path / "p.hdr", rgbe(rgb)))
    np.testing.assert_allclose(image[..., :3], plain[..., :3] / (8 * np.array([1, 0.5, 2])), rtol=1e-6)


def test_xyze_pixels_are_converted_to_rec709(tmp_path):
    """XYZ of equal-energy white reads as RGB (1, 1, 1) and the XYZ of the Rec.709 primaries (chromaticities
    (0.64, 0.33), (0.30, 0.60), (0.15, 0.06), scaled to sum to that white) as pure red, green and blue."""
    xy = np.array([[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]])
    xyz = np.stack([xy[:, 0] / xy[:, 1], np.ones(3), (1 - xy.sum(1)) / xy[:, 1]], 1)  # rows: XYZ of R, G, B at Y = 1
    luminance = np.linalg.solve(xyz.T, np.ones(3))  # Y of each primary in white
    colours = np.vstack([np.ones(3), xyz * luminance[:, None]])[None]  # white, red, green, blue
    image = load_image(hdr_file(tmp_path / "x.hdr", rgbe(colours), rle=False, header=("FORMAT=32-bit_rle_xyze",)))
    expected = np.vstack([np.ones(3), np.eye(3)])
    np.testing.assert_allclose(image[0, :, :3], expected, atol=2.5 / 128)


def test_exponent_255_decodes_to_the_finite_value_the_format_defines(tmp_path):
    """E = 255 is ``m / 256 * 2^127`` (up to 1.7e38), in float32's range: it reads as float64 decoding gives it."""
    pixels = np.array([[[255, 255, 255, 255], [128, 1, 0, 255], [200, 100, 50, 254]]], np.uint8)
    image = load_image(hdr_file(tmp_path / "bright.hdr", pixels, rle=False))
    np.testing.assert_array_equal(image[0, :, :3], from_rgbe(pixels)[0].astype(np.float32))
    assert np.all(np.isfinite(image))


def test_bright_xyze_pixels_convert_without_overflow(tmp_path):
    """XYZ (v, v, v) of E = 255 is equal-energy white RGB (v, v, v), finite: the float32 matrix product overflowed
    to inf, which a dome reads as black."""
    pixels = np.array([[[255, 255, 255, 255], [128, 128, 128, 255]]], np.uint8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = load_image(hdr_file(tmp_path / "x.hdr", pixels, rle=False, header=("FORMAT=32-bit_rle_xyze",)))
    np.testing.assert_allclose(image[0, :, :3], from_rgbe(pixels)[0], rtol=1e-5)


def test_components_past_float32_after_exposure_are_clamped_with_a_warning_naming_the_file(tmp_path):
    """``EXPOSURE=0.25`` takes E = 255 components past 3.4e38: clamped to float32's largest value and counted in
    a warning naming the file (they were inf, which a light reads as 0); the others are divided as before."""
    pixels = np.array([[[255, 10, 0, 255], [128, 64, 32, 130]]], np.uint8)
    path = hdr_file(tmp_path / "sun.hdr", pixels, rle=False, header=("EXPOSURE=0.25",))
    with pytest.warns(UserWarning, match=r"sun\.hdr: 1 pixel component past float32's range"):
        image = load_image(path)
    expected = from_rgbe(pixels)[0] * 4.0  # float64
    assert image[0, 0, 0] == np.finfo(np.float32).max and expected[0, 0] > np.finfo(np.float32).max
    np.testing.assert_allclose(image[0, 0, 1:3], expected[0, 1:3], rtol=1e-6)
    np.testing.assert_allclose(image[0, 1, :3], expected[1], rtol=1e-6)


def latlong_sky(h=16):
    """A lat-long dome image: a blue-white sky above the horizon, a dim ground, a bright sun."""
    rgb = np.empty((h, 2 * h, 3))
    rgb[: h // 2] = (0.4, 0.6, 1.0)
    rgb[h // 2 :] = (0.05, 0.04, 0.03)
    rgb[h // 4, h // 2 : h // 2 + 2] = (40.0, 35.0, 30.0)
    return rgb


def dome_stage(folder, texture):
    """A grey plane facing +Y under a DomeLight textured by ``texture`` (a file name relative to ``folder``)."""
    stage = Usd.Stage.CreateNew(str(folder / "dome.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    plane = UsdGeom.Mesh.Define(stage, "/Plane")
    plane.CreatePointsAttr([(-20, 0, 20), (20, 0, 20), (20, 0, -20), (-20, 0, -20)])
    plane.CreateFaceVertexCountsAttr([4])
    plane.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    st = UsdGeom.PrimvarsAPI(plane).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    dome = UsdLux.DomeLight.Define(stage, "/Sky")
    dome.CreateTextureFileAttr(Sdf.AssetPath(texture))
    stage.Save()
    return str(folder / "dome.usda")


def render_plane(path):
    scene = wrt.load_usd(path)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=1.0)
    return wrt.render(scene, camera=cam, width=4, height=4, spp=16, device="cpu", integrator="path",
                      max_depth=1).rgb


def test_dome_with_an_hdr_texture_renders_as_the_same_image_in_exr(tmp_path):
    """Before, the .hdr could not be read: the dome fell back to its colour (white) with a warning."""
    OpenEXR = pytest.importorskip("OpenEXR")  # (the GPU host has none)

    pixels = rgbe(latlong_sky())
    (tmp_path / "exr").mkdir()
    rgb = from_rgbe(pixels).astype(np.float32)
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": rgb}) as f:
        f.write(str(tmp_path / "exr" / "sky.exr"))
    hdr_file(tmp_path / "sky.hdr", pixels)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(dome_stage(tmp_path, "sky.hdr"))
        hdr = render_plane(dome_stage(tmp_path, "sky.hdr"))
    np.testing.assert_allclose(scene.lights[0].texture[..., :3], rgb)
    exr = render_plane(dome_stage(tmp_path / "exr", "sky.exr"))
    assert hdr.mean() > 0.1
    np.testing.assert_allclose(hdr, exr, rtol=1e-5)


def test_a_dome_of_exponent_255_renders_as_the_same_dome_scaled_by_a_power_of_two(tmp_path):
    """Raising every exponent byte by k (the brightest to 255) multiplies the radiance, so the image, by exactly
    2^k. The dome's sampling CDFs summed past float32's range (inf): its light samples, so the path image, were
    wrong (12% off) without a word."""
    pixels = rgbe(latlong_sky())
    k = 255 - int(pixels[..., 3].max())
    bright = pixels.copy()
    bright[..., 3] = np.where(pixels[..., 3] > 0, pixels[..., 3].astype(int) + k, 0)
    (tmp_path / "bright").mkdir()
    hdr_file(tmp_path / "sky.hdr", pixels)
    hdr_file(tmp_path / "bright" / "sky.hdr", bright)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plain = render_plane(dome_stage(tmp_path, "sky.hdr")).astype(np.float64)
        lit = render_plane(dome_stage(tmp_path / "bright", "sky.hdr")).astype(np.float64)
    assert plain.mean() > 0.1
    np.testing.assert_allclose(lit / 2.0**k, plain, rtol=1e-4)


def test_hdr_textures_inside_a_usdz_light_a_dome_and_colour_a_material(tmp_path):
    """A DomeLight's texture and a UsdUVTexture ``file`` (linear under ``auto``, decoded under ``sRGB``) packed
    into a ``.usdz`` are read from the package."""
    rgb = latlong_sky(8)
    hdr_file(tmp_path / "sky.hdr", rgbe(rgb))
    layer = dome_stage(tmp_path, "sky.hdr")
    stage = Usd.Stage.Open(layer)
    material = UsdShade.Material.Define(stage, "/Looks/Sky")
    surface = UsdShade.Shader.Define(stage, "/Looks/Sky/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    for name, space in (("Linear", None), ("Srgb", "sRGB")):
        tex = UsdShade.Shader.Define(stage, f"/Looks/Sky/{name}")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("sky.hdr"))
        if space:
            tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(space)
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        input_name = "diffuseColor" if space is None else "emissiveColor"
        surface.CreateInput(input_name, Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/Plane")).Bind(material)
    stage.Save()
    package = str(tmp_path / "sky.usdz")
    with Sdf.ZipFileWriter.CreateNew(package) as writer:
        writer.AddFile(layer, "dome.usda")
        writer.AddFile(str(tmp_path / "sky.hdr"), "sky.hdr")
    (tmp_path / "sky.hdr").unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(package)
    assert_within_rgbe_precision(scene.lights[0].texture, rgb)
    linear, srgb = scene.textures
    assert_within_rgbe_precision(linear, rgb)
    np.testing.assert_allclose(srgb[..., :3], wrt.textures.srgb_to_linear(linear[..., :3]), rtol=1e-6)


def corrupt_files():
    """``(bytes, words the error must contain)`` of broken files."""
    line = encode(rgbe(sky(1, 16)), rle=True)
    good = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 16\n" + line + line
    head = good[: good.index(b"-Y")]
    return {
        "no magic": (b"RADIANCE\n\n-Y 2 +X 16\n" + line + line, "does not start with a #?RADIANCE"),
        "misnamed png": (b"\x89PNG\r\n\x1a\n" + bytes(40), "does not start with a #?RADIANCE"),
        "header without end": (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n-Y 2 +X 16\n", "header does not end"),
        "float format": (good.replace(b"32-bit_rle_rgbe", b"32-bit_rle_float"), "FORMAT=32-bit_rle_float"),
        "zero exposure": (good.replace(b"FORMAT", b"EXPOSURE=0\nFORMAT"), "EXPOSURE=0 is not 1 positive"),
        "short colorcorr": (good.replace(b"FORMAT", b"COLORCORR=1 2\nFORMAT"), "COLORCORR=1 2 is not 3 positive"),
        "same axis twice": (head + b"-Y 2 +Y 16\n" + line + line, "resolution line '-Y 2 +Y 16'"),
        "no resolution": (head + b"width 16\n" + line, "resolution line 'width 16'"),
        "zero size": (head + b"-Y 0 +X 16\n", "size 16 x 0 is empty"),
        "absurd size": (head + b"-Y 99999999 +X 99999999\n", "larger than 2^31"),
        "truncated": (good[:-9], "scanline 2 of 2: the file ends inside it"),
        "data missing": (good[: -len(line)], "scanline 2 of 2: the file ends inside it"),
        "run past the line end": (head + b"-Y 2 +X 16\n" + line[:4] + bytes([128 + 17, 7]) + line[6:] + line,
                                  "scanline 1 of 2: a run of component R passes the end of the line (16 pixels)"),
        "wrong scanline length": (head + b"-Y 2 +X 16\n" + line[:3] + b"\x11" + line[4:] + line,
                                  "scanline 1 of 2: its run-length header gives 17 pixels, the resolution line 16"),
        "flat data short": (head + b"-Y 2 +X 5\n" + bytes(range(100, 136)), "scanline 2 of 2: the file ends"),
        "old run first": (head + b"-Y 1 +X 5\n" + bytes([1, 1, 1, 4]) + bytes(16), "scanline 1 of 1: it starts "
                          "with a run-length marker"),
        "old run past the end": (head + b"-Y 1 +X 5\n" + bytes([9, 9, 9, 130, 1, 1, 1, 5]),
                                 "a run of 5 pixels passes the end of the line (5 pixels)"),
    }


@pytest.mark.parametrize("case", corrupt_files())
def test_corrupt_files_raise_a_texture_error_naming_file_and_fault(tmp_path, case):
    data, words = corrupt_files()[case]
    path = tmp_path / "bad.hdr"
    path.write_bytes(data)
    with pytest.raises(TextureError) as error:
        load_image(str(path))
    assert str(path) in str(error.value) and words in str(error.value)


def test_a_dome_with_a_corrupt_hdr_warns_naming_the_prim_and_keeps_its_colour(tmp_path):
    path = tmp_path / "sky.hdr"
    hdr_file(path, rgbe(latlong_sky(8)))
    path.write_bytes(path.read_bytes()[:-5])
    with pytest.warns(UserWarning, match=r"sky.hdr: scanline 8 of 8: the file ends inside it.*: /Sky"):
        scene = wrt.load_usd(dome_stage(tmp_path, "sky.hdr"))
    assert scene.lights[0].texture is None


def test_damaged_files_read_or_raise_a_texture_error():
    """Random truncations, byte changes, insertions and deletions in flat, adaptive and old run-length files of
    several orders: each reads as an RGBA image or raises TextureError (no IndexError, hang or huge allocation)."""
    import wrt.radiance_hdr as rh

    rng = np.random.default_rng(7)
    old_line = bytes([100, 50, 25, 130, 1, 1, 1, 11, 30, 200, 90, 126, 1, 1, 1, 0, 1, 1, 1, 1]) + bytes(range(100, 200))
    files = [b"#?RADIANCE\n\n-Y 1 +X 294\n" + old_line]
    for rle, order, shape in [(True, "-Y 6 +X 20", (6, 20)), (False, "-Y 6 -X 5", (6, 5)),
                              (True, "+X 20 -Y 9", (20, 9))]:  # shape: scanlines, pixels per scanline
        files.append(f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{order}\n".encode() + encode(rgbe(sky(*shape)), rle))
    outcomes = set()
    for _ in range(600):
        data = bytearray(files[rng.integers(len(files))])
        at = int(rng.integers(len(data)))
        change = rng.integers(4)
        if change == 0:
            del data[at:]
        elif change == 1:
            data[at] = rng.integers(256)
        elif change == 2:
            data[at:at] = rng.integers(0, 256, rng.integers(1, 5)).astype(np.uint8).tobytes()
        else:
            del data[at : at + rng.integers(1, 5)]
        try:
            image = rh.read_radiance(bytes(data), "damaged.hdr")
        except TextureError as e:
            assert "damaged.hdr" in str(e)
            outcomes.add("error")
        else:
            assert image.dtype == np.float32 and image.shape[2] == 4
            outcomes.add("read")
    assert outcomes == {"read", "error"}


def test_dome_cdfs_of_texels_at_float32s_largest_are_those_of_the_image_scaled_down():
    """A dome's sampling CDFs are normalized, so scaling the image leaves them as they are. Texels near float32's
    largest value (as read_radiance clamps a component past it, after an EXPOSURE below 1) overflowed float32 in the
    luminance filter: CDFs of NaN (inf / inf), so light samples of no direction."""
    from wrt.light_table import _dome_distribution

    rng = np.random.default_rng(123)
    texels = rng.random((6, 12, 3)).astype(np.float32)
    texels[2:4, 4:7] = 1.0  # a bright patch: neighbours at the largest value
    largest = np.float32(np.finfo(np.float32).max)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        row, col, mean = _dome_distribution(texels * largest)
    expected_row, expected_col, expected_mean = _dome_distribution(texels.astype(np.float64))
    np.testing.assert_allclose(row, expected_row, rtol=1e-6)
    np.testing.assert_allclose(col, expected_col, rtol=1e-6)
    np.testing.assert_allclose(mean / float(largest), expected_mean, rtol=1e-6)
