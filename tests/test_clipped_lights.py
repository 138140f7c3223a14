"""A camera's clipping range and clipping planes hide the area lights outside them, as they hide geometry."""

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

import wrt

RADIANCE = 10.0  # the rect light's intensity: its radiance, as camera rays see it (white, exposure 0)


def _light_stage(path: str, far: float, planes: list) -> None:
    """A camera at the origin looking down -Z with clipping range ``(0.1, far)`` and ``planes``, and a 4 x 4 rect light
    at depth 10 facing it, which fills the middle of the view; nothing else."""
    stage = Usd.Stage.CreateNew(path)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, far))
    cam.CreateClippingPlanesAttr([Gf.Vec4f(*p) for p in planes])
    light = UsdLux.RectLight.Define(stage, "/Light")
    light.CreateWidthAttr(4.0)
    light.CreateHeightAttr(4.0)
    light.CreateIntensityAttr(RADIANCE)
    light.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, -10.0))
    light.AddRotateYOp().Set(180.0)  # a rect light emits along its -Z: turned to face the camera
    stage.Save()


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("far, planes, seen", [
    (100.0, [], True),  # in range: the light fills the middle of the view
    (5.0, [], False),  # the far plane at depth 5 lies before the light
    (100.0, [(0.0, 0.0, 1.0, 5.0)], False),  # the camera-space plane z + 5 >= 0 keeps depths up to 5 only
])
def test_a_light_outside_the_clipping_range_or_planes_is_not_seen(tmp_path, integrator, far, planes, seen):
    """The camera ray through the middle pixel meets the light at depth 10. A far clipping plane at depth 5, or a
    clipping plane keeping depths below 5, cut it away as they cut geometry: the image is the empty background (0).
    A camera ray that met nothing took the light segment up to infinity, so the light showed at full radiance
    through both."""
    path = str(tmp_path / "light.usda")
    _light_stage(path, far, planes)
    image = wrt.render(wrt.load_usd(path), camera="/Cam", width=8, height=6, integrator=integrator, device="cpu")
    middle = image.rgb[2:4, 3:5]
    np.testing.assert_allclose(middle, RADIANCE if seen else 0.0, rtol=1e-5)
    if not seen:
        assert (image.rgb == 0.0).all()


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_the_camera_framing_a_stage_without_cameras_hides_no_light_past_the_geometry(tmp_path, integrator):
    """A stage of lights and no camera: the camera wrt makes frames the geometry (here none, so the unit cube around
    the origin) and sees the 100 x 100 rect light 30 units behind it across the whole view, at its radiance. Its
    clipping range ended a few units past the framed box, which (once the far plane hid lights) hid the light."""
    path = str(tmp_path / "lights_only.usda")
    stage = Usd.Stage.CreateNew(path)
    light = UsdLux.RectLight.Define(stage, "/Light")
    light.CreateWidthAttr(100.0)
    light.CreateHeightAttr(100.0)
    light.CreateIntensityAttr(RADIANCE)
    light.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, -30.0))
    light.AddRotateYOp().Set(180.0)  # facing +Z, where the camera wrt makes looks from
    stage.Save()
    image = wrt.render(wrt.load_usd(path), width=8, height=6, integrator=integrator, device="cpu")
    np.testing.assert_allclose(image.rgb, RADIANCE, rtol=1e-5)
