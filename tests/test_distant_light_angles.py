"""A DistantLight's ``inputs:angle`` outside UsdLux's range ``0 <= angle < 360`` is clipped to it, as UsdLux's
schema.usda says ("will be clipped to this range"), with a warning naming the prim; the floor under it shows the
irradiance of the clipped light, in float64 from the spec alone."""

import math
import re

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux
from shading_helpers import top_down_camera

import wrt

TILT = 30.0  # degrees between the light's direction and the floor's normal


def sun_over_floor(tmp_path, angle, intensity) -> str:
    """A white floor z = 0 (40 x 40) under a DistantLight tilted by :data:`TILT`, of ``angle`` and ``intensity``."""
    path = str(tmp_path / "lights.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateAngleAttr(angle)
    sun.CreateIntensityAttr(intensity)
    UsdGeom.XformCommonAPI(sun).SetRotate(Gf.Vec3f(TILT, 0.0, 0.0))
    stage.Save()
    return path


def floor_radiance(path, spp):
    scene = wrt.load_usd(path)
    assert [light.path for light in scene.lights] == ["/Sun"]
    img = wrt.render(scene, camera=top_down_camera(height=0.2), width=4, height=4, spp=spp, seed=1, device="cpu",
                     integrator="path", max_depth=1)
    return img.rgb


def clip_warning(angle, clipped):
    return re.escape("lights.usda: DistantLight inputs:angle outside UsdLux's range 0 <= angle < 360 was clipped to "
                     "it, as the schema says (a negative angle is 0: a perfectly parallel light): 1 prim(s) "
                     f"(inputs:angle = {angle:g}, read as {clipped:g}: 1): /Sun") + "$"


@pytest.mark.parametrize("angle", [-5.0, -1e-3, -math.inf])
def test_negative_angle_is_a_parallel_light(tmp_path, angle):
    """A negative angle was skipped as a negative radius is (the stage fell back to the default headlight); clipped
    to 0 it is a delta light whose intensity is the illuminance at normal incidence: the white floor shows
    ``E cos(tilt) / pi``. So is ``-inf``, below the range as any negative angle (it was skipped as not finite)."""
    path = sun_over_floor(tmp_path, angle, intensity=2.0)
    with pytest.warns(UserWarning, match=clip_warning(angle, 0.0)):
        rgb = floor_radiance(path, spp=1)
    np.testing.assert_allclose(rgb, 2.0 * math.cos(math.radians(TILT)) / math.pi, rtol=1e-5)


@pytest.mark.parametrize("angle", [400.0, math.inf])
def test_angle_past_360_is_the_whole_sphere(tmp_path, angle):
    """Past 360 degrees the angle is clipped to the whole sphere: an unnormalized light's intensity is the radiance
    of a sky all round, and the floor's upper hemisphere of it gives ``E = pi L`` whatever the tilt (white floor:
    radiance ``L``). So is ``inf``, past the range as 400 is (it was skipped as not finite, lighting nothing)."""
    path = sun_over_floor(tmp_path, angle, intensity=0.75)
    with pytest.warns(UserWarning, match=clip_warning(angle, 360.0)):
        rgb = floor_radiance(path, spp=256)
    assert abs(float(rgb.mean()) / 0.75 - 1.0) < 0.03, rgb.mean()


def test_a_nan_angle_is_skipped_naming_it(tmp_path):
    """NaN is in no range to clip to: the light is skipped, named with its angle, and lights nothing."""
    path = sun_over_floor(tmp_path, math.nan, intensity=1.0)
    with pytest.warns(UserWarning, match=r"non-finite size were skipped: 1 prim\(s\) \(inputs:angle = nan: 1\): /Sun"):
        scene = wrt.load_usd(path)
    assert not [light for light in scene.lights if light.path == "/Sun"]


def test_angles_in_range_are_read_as_authored(tmp_path, recwarn):
    path = sun_over_floor(tmp_path, 200.0, intensity=1.0)
    scene = wrt.load_usd(path)
    assert scene.lights[0].angle == pytest.approx(200.0)
    assert not [w for w in recwarn if "inputs:angle" in str(w.message)]
