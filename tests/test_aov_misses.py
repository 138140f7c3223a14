"""What each AOV holds where the camera ray through the pixel centre hits nothing, as README's AOV paragraph and
``wrt.Image``'s docstring say: ``inf`` depths, zero vectors, -1 ids, zero coverage."""

import numpy as np
from pxr import Usd, UsdGeom

import wrt


def test_every_aov_of_a_miss_is_the_documented_value(tmp_path):
    """A unit sphere 6 units in front of the camera: the ray through the corner pixel centre of 64x48 passes it by
    about 1.3 units (the film's half diagonal at focal length 50 is 0.26 of the distance), the centre pixel's hits it
    at distance 5 (5.0003: the centre pixel is half a pixel off the axis)."""
    path = str(tmp_path / "ball.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Sphere.Define(stage, "/Ball")
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set((0.0, 0.0, 6.0))
    stage.Save()
    image = wrt.render(wrt.load_usd(path), camera="/Cam", width=64, height=48, spp=4, device="cpu")
    a = image.aovs
    assert a["prim"][24, 32] >= 0 and np.isclose(a["depth"][24, 32], 5.0, rtol=1e-3)
    miss = (0, 0)
    assert np.isinf(a["depth"][miss]) and np.isinf(a["z"][miss])
    for name in ("normal", "geometric_normal", "albedo"):
        np.testing.assert_array_equal(a[name][miss], [0.0, 0.0, 0.0], err_msg=name)
    for name in ("prim", "instance", "material"):
        assert a[name][miss] == -1, name
    assert a["coverage"][miss] == 0.0
