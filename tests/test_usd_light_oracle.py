"""UsdLux lights read from a stage and rendered (whitted and path) over a white Lambertian floor, against irradiance
integrated numerically over each light's surface or cone (tests/light_oracle.py): radiance = E / pi. Each case
authors intensity, exposure, colour, normalize or colour temperature and a transform, unevenly scaled where the
light's shape allows it: sphere and cylinder lights scaled unevenly or sheared are ellipsoids and elliptic or oblique
tubes, which the oracle integrates over the unit sphere's and tube's parameters through the transform's Jacobian."""

import math

import numpy as np
import pytest
from light_oracle import blackbody_rgb, cone_irradiance, cylinder, disk, irradiance, rect, sphere, trs
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

import wrt

PATCH, RES = 0.2, 8  # side of each checked floor patch and its pixels
CENTRES = [np.array([0.0, 0.0, 0.0]), np.array([0.7, -0.4, 0.0]), np.array([-1.2, 0.9, 0.0])]


def patch_points(centre, n=6):
    t = ((np.arange(n) + 0.5) / n - 0.5) * PATCH
    gx, gy = np.meshgrid(centre[0] + t, centre[1] + t)
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], -1)


def floor_stage(path, preview_surface):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-40, -40, 0), (40, -40, 0), (40, 40, 0), (-40, 40, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if preview_surface:  # ior 1: F0 0, a Lambertian of albedo 1 but for the specification's white F90, a grazing
        # lobe that a camera looking straight down barely sees (well within the tolerances below)
        shader = UsdShade.Shader.Define(stage, "/Look/Surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 1, 1))
        shader.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.0)
        look = UsdShade.Material.Define(stage, "/Look")
        look.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(floor.GetPrim()).Bind(look)
    else:
        floor.CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
    return stage


def author(light, xform, intensity, exposure=0.0, color=(1, 1, 1), normalize=False, kelvin=None):
    light.CreateIntensityAttr(intensity)
    light.CreateExposureAttr(exposure)
    light.CreateColorAttr(Gf.Vec3f(*color))
    light.CreateNormalizeAttr(normalize)
    if kelvin is not None:
        light.CreateEnableColorTemperatureAttr(True)
        light.CreateColorTemperatureAttr(kelvin)
    ops = UsdGeom.Xformable(light)
    if "matrix" in xform:  # a column-vector 4x4 (USD's matrices are row-vector: transposed)
        ops.AddTransformOp().Set(Gf.Matrix4d(*np.asarray(xform["matrix"], float).T.ravel()))
    else:
        ops.AddTranslateOp().Set(Gf.Vec3d(*xform.get("translate", (0, 0, 0))))
        ops.AddRotateXYZOp().Set(Gf.Vec3f(*xform.get("rotate_xyz", (0, 0, 0))))
        ops.AddScaleOp().Set(Gf.Vec3f(*xform.get("scale", (1, 1, 1))))
    emitted = np.array(color, float) * intensity * 2.0**exposure
    return emitted * (blackbody_rgb(kelvin) if kelvin is not None else 1.0)


def smoothstep(x, lo, hi):
    t = np.clip((x - lo) / (hi - lo), 0, 1)
    return t * t * (3 - 2 * t)


TILTED = dict(translate=(0.3, 0.1, 1.2), rotate_xyz=(20, -15, 30))


def rect_case(stage):  # scaled unevenly, normalized: radiance = power / world area
    xform = dict(TILTED, scale=(2.0, 0.5, 3.0))
    light = UsdLux.RectLight.Define(stage, "/Light")
    light.CreateWidthAttr(1.0)
    light.CreateHeightAttr(0.8)
    emitted = author(light, xform, 4.0, exposure=-1.0, color=(0.5, 1, 1), normalize=True)
    elements = rect(trs(**xform), 1.0, 0.8)
    return lambda p: irradiance(p, elements)[:, None] * emitted / elements[2].sum()


def disk_case(stage):  # an ellipse seen from its mirrored side
    xform = dict(translate=(-0.2, 0.3, 0.9), rotate_xyz=(10, 25, 0), scale=(1.5, -0.6, 2.0))
    light = UsdLux.DiskLight.Define(stage, "/Light")
    light.CreateRadiusAttr(0.5)
    emitted = author(light, xform, 6.0, exposure=0.5, color=(1, 1, 0.5), normalize=True)
    elements = disk(trs(**xform), 0.5)
    return lambda p: irradiance(p, elements)[:, None] * emitted / elements[2].sum()


def soft_cone_disk_case(stage):
    light = UsdLux.DiskLight.Define(stage, "/Light")
    light.CreateRadiusAttr(0.2)
    emitted = author(light, dict(translate=(0, 0, 1.0)), 5.0)
    shaping = UsdLux.ShapingAPI.Apply(light.GetPrim())
    shaping.CreateShapingConeAngleAttr(40.0)
    shaping.CreateShapingConeSoftnessAttr(0.5)
    a = math.radians(40.0)
    cone = lambda theta: np.where(theta > a, 0.0, 1 - smoothstep(theta, a * 0.5, a))  # noqa: E731
    elements = disk(trs((0, 0, 1.0)), 0.2)
    return lambda p: irradiance(p, elements, shaping=cone, axis=np.array([0, 0, -1.0]))[:, None] * emitted


def sphere_case(stage, treat_as_point=False):  # a point light keeps the sphere's power
    xform = dict(translate=(0.4, 0.2, 1.5), scale=(1.5, 1.5, 1.5))
    light = UsdLux.SphereLight.Define(stage, "/Light")
    light.CreateRadiusAttr(0.2)
    light.CreateTreatAsPointAttr(treat_as_point)
    emitted = author(light, xform, 5.0, exposure=1.0, color=(1, 0.5, 0.25))
    elements = sphere(trs(**xform), 0.2)
    return lambda p: irradiance(p, elements)[:, None] * emitted


def cylinder_case(stage):  # stretched along its axis
    xform = dict(translate=(0.2, -0.1, 0.8), rotate_xyz=(0, 0, 35), scale=(1.5, 1.0, 1.0))
    light = UsdLux.CylinderLight.Define(stage, "/Light")
    light.CreateLengthAttr(1.2)
    light.CreateRadiusAttr(0.1)
    emitted = author(light, xform, 3.0, color=(1, 0.8, 0.6), normalize=True)
    elements = cylinder(trs(**xform), 1.2, 0.1)
    return lambda p: irradiance(p, elements)[:, None] * emitted / elements[2].sum()


# Shear: local Y leans towards X and local Z towards Y, then a turn and a lift above the floor.
SHEARED = trs(translate=(-0.1, 0.2, 1.3), rotate_xyz=(15, 0, 40)) @ np.array(
    [[1.0, 0.7, 0.0, 0], [0, 1.0, -0.5, 0], [0, 0, 0.8, 0], [0, 0, 0, 1]])


def ellipsoid_case(stage, xform, normalize):  # a SphereLight scaled unevenly or sheared
    light = UsdLux.SphereLight.Define(stage, "/Light")
    light.CreateRadiusAttr(0.3)
    emitted = author(light, xform, 4.0, color=(1, 0.7, 0.4), normalize=normalize)
    elements = sphere(xform["matrix"] if "matrix" in xform else trs(**xform), 0.3)
    scale = 1.0 / elements[2].sum() if normalize else 1.0
    return lambda p: irradiance(p, elements)[:, None] * emitted * scale


def elliptic_tube_case(stage, xform, normalize):  # a CylinderLight scaled unevenly across its axis or sheared
    light = UsdLux.CylinderLight.Define(stage, "/Light")
    light.CreateLengthAttr(1.0)
    light.CreateRadiusAttr(0.15)
    emitted = author(light, xform, 3.0, color=(0.6, 0.8, 1), normalize=normalize)
    elements = cylinder(xform["matrix"] if "matrix" in xform else trs(**xform), 1.0, 0.15)
    scale = 1.0 / elements[2].sum() if normalize else 1.0
    return lambda p: irradiance(p, elements)[:, None] * emitted * scale


def distant_size_factor(angle_deg):
    """UsdLux's ``sizeFactor`` of a normalized DistantLight (the ``inputs:normalize`` doc): ``theta_max`` is half the
    angle clamped to [0, pi]; ``pi sin^2`` up to pi / 2, ``(2 - sin^2) pi`` beyond (a cone wider than a hemisphere)."""
    theta = min(max(math.radians(angle_deg) / 2, 0.0), math.pi)
    s2 = math.sin(theta) ** 2
    return math.pi * s2 if theta <= math.pi / 2 else (2 - s2) * math.pi


def distant_case(stage, normalize, angle=8.0, rotate_xyz=(30, 20, 0)):
    xform = dict(rotate_xyz=rotate_xyz)
    light = UsdLux.DistantLight.Define(stage, "/Light")
    light.CreateAngleAttr(angle)
    emitted = author(light, xform, 2.0, exposure=1.0, color=(1, 0.9, 0.8), normalize=normalize)
    if normalize:  # the intensity is the illuminance at normal incidence (for angles up to 180 degrees)
        emitted = emitted / distant_size_factor(angle)
    to_light = trs(**xform)[:3, :3] @ np.array([0, 0, 1.0])
    return lambda p: np.full((len(p), 1), cone_irradiance(to_light, min(angle, 360.0), 1.0)) * emitted


def dome_case(stage):
    emitted = author(UsdLux.DomeLight.Define(stage, "/Light"), {}, 0.5, exposure=-1.0, kelvin=4000.0)
    return lambda p: np.full((len(p), 1), math.pi) * emitted


def warm_rect_case(stage):
    light = UsdLux.RectLight.Define(stage, "/Light")
    light.CreateWidthAttr(1.5)
    light.CreateHeightAttr(1.5)
    emitted = author(light, dict(translate=(0, 0, 1.0)), 2.0, kelvin=3000.0)
    elements = rect(trs((0, 0, 1.0)), 1.5, 1.5)
    return lambda p: irradiance(p, elements)[:, None] * emitted


CASES = {
    "rect": (rect_case, 0.02),
    "disk": (disk_case, 0.02),
    "soft_cone_disk": (soft_cone_disk_case, 0.02),
    "sphere": (sphere_case, 0.02),
    "sphere_as_point": (lambda stage: sphere_case(stage, treat_as_point=True), 0.02),
    "cylinder": (cylinder_case, 0.02),
    "ellipsoid": (lambda stage: ellipsoid_case(stage, dict(TILTED, translate=(0.3, 0.1, 1.4), scale=(2.5, 0.6, 1.2)),
                                               normalize=True), 0.01),
    "sheared_ellipsoid": (lambda stage: ellipsoid_case(stage, dict(matrix=SHEARED), normalize=False), 0.01),
    "elliptic_tube": (lambda stage: elliptic_tube_case(stage, dict(TILTED, scale=(1.5, 3.0, 0.6)), normalize=True),
                      0.01),
    "oblique_tube": (lambda stage: elliptic_tube_case(stage, dict(matrix=SHEARED), normalize=False), 0.01),
    "distant": (lambda stage: distant_case(stage, False), 0.02),
    "distant_normalized": (lambda stage: distant_case(stage, True), 0.02),
    # Wider than a hemisphere (UsdLux clamps half the angle to [0, pi], not pi / 2), the sun low: the floor sees the
    # disc's directions beyond 90 degrees from its centre too.
    "distant_270": (lambda stage: distant_case(stage, False, 270.0, rotate_xyz=(0, 70, 0)), 0.02),
    "distant_300_normalized": (lambda stage: distant_case(stage, True, 300.0, rotate_xyz=(0, 100, 0)), 0.02),
    # The oracle's blackbody comes from a fit of the CIE curves, about 1% off them.
    "dome_4000K": (dome_case, 0.025),
    "rect_3000K": (warm_rect_case, 0.025),
}


@pytest.mark.parametrize("name", list(CASES))
def test_usd_light_lights_a_white_floor_as_the_numerical_integral(tmp_path, name):
    build, tol = CASES[name]
    stage = floor_stage(tmp_path / "light.usda", preview_surface=name.startswith("rect"))
    irradiance_at = build(stage)
    stage.Save()
    scene = wrt.load_usd(str(tmp_path / "light.usda"))
    for centre in CENTRES:
        expected = irradiance_at(patch_points(centre)).mean(0) / math.pi
        cam = wrt.Camera.orthographic(eye=centre + (0, 0, 0.02), target=centre, up=(0, 1, 0), height=PATCH)
        for integrator, spp in (("whitted", 256), ("path", 512)):
            img = wrt.render(scene, camera=cam, width=RES, height=RES, spp=spp, seed=7, device="cpu",
                             integrator=integrator)
            got = img.rgb.reshape(-1, 3).mean(0)
            np.testing.assert_allclose(got, expected, rtol=tol, atol=1e-4, err_msg=f"{integrator} at {centre}")
