"""The ``normals`` integrator's PNG stores ``0.5 (n + 1)`` as it is (``round(255 v)``), as normal maps are stored and
as the ``normal`` AOV's preview is: the two PNGs of one render are the same pixels. The integrator's was sRGB-encoded
(0.5 written as 188, not 128), so a normal read back from it was wrong."""

import numpy as np
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
