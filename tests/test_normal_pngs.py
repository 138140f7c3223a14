"""The ``normals`` integrator's PNG stores ``0.5 (n + 1)`` as it is (``round(255 v)``), as normal maps are stored and
as the ``normal`` AOV's preview is: the two PNGs of one render are the same pixels. The integrator's was sRGB-encoded
(0.5 written as 188, not 128), so a normal read back from it was wrong."""

import warnings

import numpy as np
import pytest
from PIL import Image as PilImage
from usda_text import load, write

import wrt
from wrt.cli import main

BODY = """def Sphere "Ball"
{
    double radius = 1
}
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 8)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def png_pixels(path) -> np.ndarray:
    with PilImage.open(path) as png:
        return np.asarray(png.convert("RGB"))


def test_normals_png_stores_the_normal_map_as_it_is(tmp_path):
    path = write(tmp_path, BODY)
    image = wrt.render(load(path), width=16, height=12, integrator="normals", device="cpu")
    normal = image.aovs["normal"].astype(np.float64)
    hit = image.aovs["prim"] >= 0
    assert hit.sum() > 20 and (~hit).sum() > 20
    np.testing.assert_allclose(np.linalg.norm(normal[hit], axis=-1), 1.0, atol=1e-5)
    want = np.where(hit[..., None], np.round(255.0 * 0.5 * (normal + 1.0)), 0.0)
    np.testing.assert_allclose(png_pixels(image.save(tmp_path / "n.png")), want, atol=1)  # float32 ties: 1 off
    # The normal read back from the PNG is the normal, within 8-bit steps.
    back = png_pixels(tmp_path / "n.png")[hit] / 255.0 * 2.0 - 1.0
    np.testing.assert_allclose(back, normal[hit], atol=1.0 / 255 + 1e-6)


def test_cli_normals_png_and_normal_aov_png_agree(tmp_path):
    path = write(tmp_path, BODY)
    out = tmp_path / "n.png"
    assert main(["render", path, "--integrator", "normals", "--aov", "normal", "--width", "16", "--height", "12",
                 "-o", str(out), "-q"]) == 0
    aov_png = [p for p in tmp_path.iterdir() if p.name.startswith("n.") and "normal" in p.name]
    assert len(aov_png) == 1, sorted(p.name for p in tmp_path.iterdir())
    np.testing.assert_array_equal(png_pixels(out), png_pixels(aov_png[0]))


def test_depth_png_and_depth_aov_png_are_depth_over_the_farthest_hit(tmp_path):
    # One convention for depth as a picture: grey = distance / farthest hit's, misses 0, stored unencoded. The
    # integrator's PNG was sRGB-encoded and the AOV preview a different grey ramp (0.1 to 0.9 from nearest to farthest).
    path = write(tmp_path, BODY)
    out = tmp_path / "d.png"
    assert main(["render", path, "--integrator", "depth", "--aov", "depth", "--width", "16", "--height", "12",
                 "-o", str(out), "-q"]) == 0
    image = wrt.render(load(path), width=16, height=12, integrator="depth", device="cpu")
    depth = image.aovs["depth"].astype(np.float64)
    hit = image.aovs["prim"] >= 0
    assert hit.sum() > 20 and (~hit).sum() > 20
    # The sphere of radius 1 seen from 8 away: its hits lie between 7 (the nearest point) and sqrt(63) (its rim).
    assert 7.0 - 1e-4 < depth[hit].min() and depth[hit].max() < 63 ** 0.5 + 1e-4
    want = np.repeat(np.where(hit, np.round(255.0 * depth / depth[hit].max()), 0.0)[..., None], 3, axis=-1)
    np.testing.assert_allclose(png_pixels(out), want, atol=1)
    aov_png = [p for p in tmp_path.iterdir() if p.name.startswith("d.") and "depth" in p.name]
    assert len(aov_png) == 1, sorted(p.name for p in tmp_path.iterdir())
    np.testing.assert_array_equal(png_pixels(out), png_pixels(aov_png[0]))


def test_hits_behind_an_orthographic_camera_s_plane_are_not_drawn_black_as_misses(tmp_path):
    """An orthographic camera of clippingRange (-10, 100) sees a quad 3 units behind its plane (depth -3) and one 5
    in front; the depth picture clipped the negative depth to 0, black as the misses around. README: hits run in
    proportion from grey 0.1 at the nearest to white at the farthest where some lies behind, misses 0. The pixel
    centres' hits are found in float64 from the camera's aperture (4 x 3 units, centred on (0.3, -0.2))."""
    from pxr import Gf, Usd, UsdGeom

    path = str(tmp_path / "ortho.usda")
    stage = Usd.Stage.CreateNew(path)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(40.0)  # tenths of a scene unit: 4 units
    cam.CreateVerticalApertureAttr(30.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(-10.0, 100.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0.3, -0.2, 5.0))
    quads = ((-1.5, -0.25, 8.0), (0.25, 1.5, 0.0))  # x from, x to, z (y from -1 to 1)
    for i, (x0, x1, z) in enumerate(quads):
        quad = UsdGeom.Mesh.Define(stage, f"/Quad{i}")
        quad.CreatePointsAttr([(x0, -1, z), (x1, -1, z), (x1, 1, z), (x0, 1, z)])
        quad.CreateFaceVertexCountsAttr([4])
        quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        quad.CreateDoubleSidedAttr(True)
    stage.Save()
    width, height = 16, 12
    x = 0.3 - 2.0 + 4.0 * (np.arange(width) + 0.5) / width
    y = -0.2 + 1.5 - 3.0 * (np.arange(height) + 0.5) / height
    depth = np.full((height, width), np.inf)
    for x0, x1, z in quads:
        depth[np.ix_(np.abs(y) <= 1.0, (x0 <= x) & (x <= x1))] = 5.0 - z
    hit = np.isfinite(depth)
    assert (depth[hit] < 0).any() and (depth[hit] > 0).any() and (~hit).any()
    near, far = depth[hit].min(), depth[hit].max()
    want = np.where(hit, 0.1 + 0.9 * (depth - near) / (far - near), 0.0)
    image = wrt.render(wrt.load_usd(path), camera="/Cam", width=width, height=height, integrator="depth",
                       device="cpu")
    np.testing.assert_allclose(image.aovs["depth"], np.where(hit, depth, np.inf), rtol=1e-5)
    np.testing.assert_allclose(image.rgb, np.repeat(want[..., None], 3, axis=-1), atol=1e-6)
    stored = png_pixels(image.save(tmp_path / "d.png"))[..., 0]
    assert (stored[hit] >= 25).all() and (stored[~hit] == 0).all()


def test_batch_normals_png_is_the_single_renders(tmp_path):
    path = write(tmp_path, BODY)
    scene = load(path)
    single = wrt.render(scene, camera="/Cam", width=16, height=12, integrator="normals", device="cpu")
    batch = wrt.render_batch(scene, ["/Cam"], width=16, height=12, integrator="normals", device="cpu")
    np.testing.assert_array_equal(png_pixels(batch.image(0).save(tmp_path / "b.png")),
                                  png_pixels(single.save(tmp_path / "s.png")))


def test_exposure_on_a_data_image_is_said_unused(tmp_path):
    # A normals or depth image's PNG is its data, which exposure leaves as they are: it was ignored without a word.
    pytest.importorskip("OpenEXR")  # (its EXR is saved too)
    path = write(tmp_path, BODY)
    image = wrt.render(load(path), width=8, height=6, integrator="depth", device="cpu")
    with pytest.warns(UserWarning, match="does not scale this image: it is data"):
        brighter = image.save(tmp_path / "up.png", exposure=2.0)
    np.testing.assert_array_equal(png_pixels(brighter), png_pixels(image.save(tmp_path / "plain.png")))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image.save(tmp_path / "linear.exr", exposure=2.0)  # linear files: exposure never applies, as documented
        wrt.Image(rgb=np.full((2, 2, 3), 0.1, np.float32)).save(tmp_path / "colour.png", exposure=2.0)


@pytest.mark.parametrize("integrator", ["normals", "depth"])
def test_cli_exposure_on_a_data_image_is_said_unused_once(tmp_path, capsys, integrator):
    path = write(tmp_path, BODY)
    assert main(["render", path, "--integrator", integrator, "--exposure", "1", "--width", "8", "--height", "6",
                 "-o", str(tmp_path / "x.png"), "-q"]) == 0
    err = capsys.readouterr().err
    assert err.count("does not scale") == 1 and f"the {integrator} integrator's image" in err, err


PRODUCT_STAGE = """#usda 1.0
(
    renderSettingsPrimPath = "/Render/Settings"
)
""" + BODY + """def Scope "Render"
{
    def RenderSettings "Settings"
    {
        rel camera = </Cam>
        uniform int2 resolution = (16, 12)
        rel products = </Render/Shot>
    }
    def RenderProduct "Shot"
    {
        token productName = "shot.png"
        rel orderedVars = </Render/Color>
    }
    def RenderVar "Color"
    {
        uniform string sourceName = "color"
        uniform token dataType = "color4f"
    }
}
"""


def test_png_product_of_normals_is_the_normal_map_as_it_is(tmp_path):
    # A normals PNG product was sRGB-encoded (and divided by coverage) where Image.save stores 0.5 (n + 1) as it is.
    stage = tmp_path / "shot.usda"
    stage.write_text(PRODUCT_STAGE)
    scene = wrt.load_usd(str(stage))
    with pytest.warns(UserWarning, match="does not scale the normals integrator's products"):
        files = wrt.render_products(scene, tmp_path / "out", integrator="normals", spp=4, device="cpu",
                                    exposure=1.0)
    image = wrt.render(scene, integrator="normals", device="cpu")
    normal = image.aovs["normal"].astype(np.float64)
    hit = image.aovs["prim"] >= 0
    assert hit.sum() > 20 and (~hit).sum() > 20
    with PilImage.open(files["/Render/Shot"]) as png:
        rgba = np.asarray(png)
    assert rgba.shape == (12, 16, 4)
    want = np.where(hit[..., None], np.round(255.0 * 0.5 * (normal + 1.0)), 0.0)
    np.testing.assert_allclose(rgba[..., :3], want, atol=1)  # float32 ties: 1 off
    np.testing.assert_array_equal(rgba[..., :3], png_pixels(image.save(tmp_path / "n.png")))
    np.testing.assert_array_equal(rgba[..., 3], np.round(255.0 * image.aovs["coverage"]))
