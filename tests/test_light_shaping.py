"""Light shaping (UsdLux ShapingAPI): spot cones, their soft edges and the focus, against the schema's formulas.

Every expected value is computed here from the formulas of the ShapingAPI attribute docs (UsdLux ``schema.usda``):
``theta`` is the angle between the direction light leaves in and the light's -Z axis; the cone keeps
``1 - smoothstep(theta, cut (1 - softness), cut)`` and nothing beyond ``cut``; the focus multiplies by
``tint + (1 - tint) |cos theta|^focus``.
"""

import math
import warnings

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdLux
from shading_helpers import pixel_points, quad, top_down_camera
from test_lights import ALBEDO, write_stage

import wrt
from wrt.lights import CylinderLight, DiskLight, RectLight, SphereLight

HEIGHT = 1.0  # of the light above the plane z = 0
RADIUS = 0.02  # of the small sphere and disk lights: they look at most 1.2 degrees wide from the plane
RES = 24  # pixels per side of the checked patch
PATCH = 3.0  # side of the patch, scene units: up to 65 degrees off the light's axis at its corners
# Angles this close to a hard cone edge are not checked: a jittered pixel spans up to 5.4 degrees there, and the small
# lights 2.3.
BAND = math.radians(4.0)


def spec_smoothstep(x, lo, hi):
    """The cubic Hermite step, a plain step where ``lo = hi``."""
    if hi <= lo:
        return np.where(x <= lo, 0.0, 1.0)
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def spec_cone(theta, angle_deg, softness):
    cut = math.radians(angle_deg)
    return np.where(theta > cut, 0.0, 1.0 - spec_smoothstep(theta, cut * (1 - softness), cut))


def make_light(kind, shaping, radiance=np.full(3, 500.0)):
    """A small light of ``kind`` at HEIGHT above the origin, its -Z axis pointing down at the plane."""
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, HEIGHT)
    if kind == "disk":
        return DiskLight(to_world=to_world, radius=RADIUS, color=radiance, shaping=shaping, path="/Spot")
    return SphereLight(position=(0, 0, HEIGHT), radius=RADIUS, color=radiance, treat_as_point=kind == "point",
                       shaping=shaping, path="/Spot")


def unshaped_irradiance(kind, points, radiance):
    """Irradiance on the plane from the unshaped small light (``(H, W, 3)``) and the angle off its axis."""
    to_light = np.array([0.0, 0.0, HEIGHT]) - points
    d2 = (to_light**2).sum(-1)
    cos = to_light[..., 2] / np.sqrt(d2)
    # A sphere above the horizon lights like a point of intensity pi r^2 L; a small disk facing the plane adds
    # its own cosine.
    e = np.pi * RADIUS**2 * cos / d2 * (cos if kind == "disk" else 1.0)
    return e[..., None] * np.broadcast_to(radiance, 3), np.arccos(cos)


def under_the_light(points):
    """The four central pixels, whose camera rays can pass through the small lights (and see them)."""
    return (np.abs(points[..., 0]) < 0.13) & (np.abs(points[..., 1]) < 0.13)


def render_plane(lights, integrator="path", spp=16, res=RES, patch=PATCH, seed=3):
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=list(lights))
    img = wrt.render(scene, camera=top_down_camera(height=patch), width=res, height=res, spp=spp, seed=seed,
                     device="cpu", integrator=integrator, max_depth=1)
    assert np.isfinite(img.rgb).all()
    return img.rgb, pixel_points((0, 0, 0), patch, res, res)


@pytest.mark.parametrize("kind", ["point", "sphere", "disk"])
def test_hard_cone_lights_inside_as_unshaped_and_nothing_outside(kind):
    """A 30-degree spot: inside the cone the plane gets the unshaped closed form, outside nothing (it was lit
    everywhere: ShapingAPI was not read)."""
    rgb, points = render_plane([make_light(kind, wrt.Shaping(cone_angle=30.0))], spp=1 if kind == "point" else 16)
    unshaped, theta = unshaped_irradiance(kind, points, 500.0)
    expected = ALBEDO * unshaped / np.pi
    inside = theta < math.radians(30.0) - BAND
    outside = theta > math.radians(30.0) + BAND
    assert inside.sum() > 20 and outside.sum() > 200
    ratio = rgb[inside] / expected[inside]
    assert abs(ratio.mean() - 1) < 0.02 and np.abs(ratio - 1).max() < 0.05, ratio.mean()
    assert rgb[outside].max() == 0.0, rgb[outside].max()


def test_cylinder_spot_lights_its_cone_as_unshaped_and_nothing_outside():
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, HEIGHT)

    def tube(shaping):
        return CylinderLight(to_world=to_world, length=0.1, radius=RADIUS, color=np.full(3, 500.0), shaping=shaping)

    shaped, points = render_plane([tube(wrt.Shaping(cone_angle=30.0))])
    plain, _ = render_plane([tube(None)])
    theta = np.arctan(np.hypot(points[..., 0], points[..., 1]) / HEIGHT)
    edge = math.radians(30.0) + np.array([-1, 1]) * (BAND + math.radians(3.0))  # the tube spans 6 degrees
    # Unshaped, the tube shines up into the camera too.
    inside, outside = (theta < edge[0]) & ~under_the_light(points), theta > edge[1]
    assert abs(shaped[inside].mean() / plain[inside].mean() - 1) < 0.02
    assert plain[outside].min() > 0.0 and shaped[outside].max() == 0.0


@pytest.mark.parametrize("kind", ["point", "sphere"])
def test_soft_cone_edge_follows_the_spec_smoothstep(kind):
    """Cone 40 degrees, softness 0.5: full light up to 20 degrees, then the spec's smoothstep down to 0 at 40."""
    rgb, points = render_plane([make_light(kind, wrt.Shaping(cone_angle=40.0, cone_softness=0.5))],
                               spp=1 if kind == "point" else 16)
    unshaped, theta = unshaped_irradiance(kind, points, 500.0)
    factor = spec_cone(theta, 40.0, 0.5)
    expected = ALBEDO * unshaped * factor[..., None] / np.pi
    if kind == "sphere":  # jittered pixels span 5 degrees, a quarter of the soft edge: only the total is exact
        assert abs(rgb.mean() / expected.mean() - 1) < 0.02, (rgb.mean(), expected.mean())
        return
    # One sample through each pixel centre: the formula at every pixel's angle.
    np.testing.assert_allclose(rgb, expected, rtol=1e-3, atol=1e-6 * expected.max())
    # Along the row through the centre, outwards: the shaped share of the unshaped light never grows.
    row = RES // 2
    share = rgb[row, row:, 0] / (ALBEDO * unshaped[row, row:, 0] / np.pi)
    assert np.all(np.diff(share) <= 1e-4), share
    assert share[0] > 0.999 and 0.1 < share[4] < 0.9 and share[-1] == 0.0


def test_focus_with_tint_scales_each_channel_by_the_spec_factor():
    """Focus 3 with a tint: each channel off the axis is ``tint + (1 - tint) cos^3`` of its unshaped value."""
    tint = np.array([0.2, 0.5, 0.0])
    light = make_light("point", wrt.Shaping(cone_angle=180.0, focus=3.0, focus_tint=tint))
    rgb, points = render_plane([light], spp=1)
    unshaped, theta = unshaped_irradiance("point", points, 500.0)
    focus = tint + (1 - tint) * np.abs(np.cos(theta))[..., None] ** 3
    np.testing.assert_allclose(rgb, ALBEDO * unshaped * focus / np.pi, rtol=1e-3)


def test_focus_on_an_area_light_matches_the_spec_factor():
    rgb, points = render_plane([make_light("sphere", wrt.Shaping(cone_angle=180.0, focus=5.0))], spp=16)
    unshaped, theta = unshaped_irradiance("sphere", points, 500.0)
    expected = ALBEDO * unshaped * np.cos(theta)[..., None] ** 5 / np.pi
    # Focus uses |cos|: the lamp shines back up at the camera, whose rays see it in the four central pixels.
    seen = under_the_light(points)
    # Jittered pixels at 60 degrees span a 30% change of cos^5: compare rings of 10 degrees.
    ring = np.floor(np.degrees(theta) / 10.0)
    for k in np.unique(ring[~seen]):
        sel = (ring == k) & ~seen
        ratio = rgb[sel].sum() / expected[sel].sum()
        assert abs(ratio - 1) < 0.02, (k * 10, ratio)


def look_at_disk(eye, integrator):
    """Radiance of the centre pixel of a narrow camera at ``eye`` looking at a large shaped disk light."""
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, 2.0)
    light = DiskLight(to_world=to_world, radius=0.5, color=np.full(3, 3.0), shaping=wrt.Shaping(cone_angle=30.0))
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=[light])
    cam = wrt.Camera.look_at(eye, (0, 0, 2.0), up=(0, 1, 0), fov_y_deg=1.0)
    return wrt.render(scene, camera=cam, width=3, height=3, spp=4, device="cpu", integrator=integrator).rgb[1, 1]


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_camera_outside_the_cone_sees_the_light_dark(integrator):
    """The cone shapes every direction the light emits in, so the disk's face looks dark from 60 degrees off its
    axis and shows its radiance from 10 degrees off it (it showed 3 from both)."""
    inside = np.array([0.0, math.sin(math.radians(10)), -math.cos(math.radians(10))]) * 1.5 + (0, 0, 2.0)
    outside = np.array([0.0, math.sin(math.radians(60)), -math.cos(math.radians(60))]) * 1.5 + (0, 0, 2.0)
    np.testing.assert_allclose(look_at_disk(inside, integrator), 3.0, rtol=1e-5)
    np.testing.assert_allclose(look_at_disk(outside, integrator), 0.0, atol=1e-6)


def test_path_with_mis_agrees_with_whitted_light_sampling_on_a_large_shaped_light():
    """A large sphere spot close to the plane: BSDF-sampled rays that hit it (MIS-weighted in ``path``) must carry
    the shaped radiance as next-event estimation does, or ``path`` leaves whitted's light-only estimate."""
    shaping = wrt.Shaping(cone_angle=50.0, cone_softness=0.4, focus=2.0, focus_tint=(0.1, 0.3, 0.2))
    light = SphereLight(position=(0, 0, 0.8), radius=0.6, color=np.full(3, 2.0), shaping=shaping)
    whitted, _ = render_plane([light], integrator="whitted", spp=256, res=8, patch=2.0)
    path, _ = render_plane([light], integrator="path", spp=256, res=8, patch=2.0)
    assert whitted.mean() > 0.05
    assert abs(path.mean() / whitted.mean() - 1) < 0.02, (path.mean(), whitted.mean())
    np.testing.assert_allclose(path.reshape(4, 2, 4, 2, 3).mean(axis=(1, 3)),
                               whitted.reshape(4, 2, 4, 2, 3).mean(axis=(1, 3)), rtol=0.05)


def test_shaping_at_its_fallbacks_leaves_a_rect_light_bit_identical():
    """A rect light emits into the half space its cone of 90 degrees spans: the fallbacks change nothing, and such a
    light is uploaded as unshaped."""
    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, 1.0)
    plain = RectLight(to_world=to_world, width=1.0, height=0.5, color=np.full(3, 2.0))
    shaped = RectLight(to_world=to_world, width=1.0, height=0.5, color=np.full(3, 2.0), shaping=wrt.Shaping())
    a, _ = render_plane([plain], spp=4, res=8)
    b, _ = render_plane([shaped], spp=4, res=8)
    assert np.array_equal(a, b)


def test_editing_a_shaping_in_place_is_noticed_by_the_renderer():
    light = make_light("point", wrt.Shaping(cone_angle=60.0))
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=[light])
    renderer = wrt.Renderer(scene, camera=top_down_camera(height=PATCH), width=8, height=8, device="cpu")
    wide = renderer.render(spp=1).rgb
    light.shaping.cone_angle = 10.0
    narrow = renderer.render(spp=1).rgb
    assert (narrow > 0).sum() < (wide > 0).sum()


def test_a_sphere_light_axis_set_after_construction_is_used_as_a_direction():
    """``light.axis`` given a new, longer vector after the light was made (as ``shaping`` is edited above) points the
    cone the same way: only its direction counts. It was used unnormalised: a down axis of length 4 lit the plane
    far outside a 30-degree cone (every cosine above 1/4 clamped to 1)."""
    light = make_light("point", wrt.Shaping(cone_angle=30.0))
    reference, _ = render_plane([light], integrator="whitted", spp=1, res=8)
    light.axis = np.array([0.0, 0.0, -4.0])
    edited, _ = render_plane([light], integrator="whitted", spp=1, res=8)
    np.testing.assert_array_equal(edited, reference)


def test_usd_shaping_is_read_with_the_light_axis(tmp_path):
    """ShapingAPI inputs come with the light; a sphere light's axis is its -Z in the world. Only an IES profile that
    is not found is warned about, naming its light and the file."""

    def build(stage):
        spot = UsdLux.SphereLight.Define(stage, "/Spot")
        api = UsdLux.ShapingAPI.Apply(spot.GetPrim())
        api.CreateShapingConeAngleAttr(30.0)
        api.CreateShapingConeSoftnessAttr(0.25)
        api.CreateShapingFocusAttr(2.0)
        api.CreateShapingFocusTintAttr(Gf.Vec3f(0.1, 0.2, 0.3))
        UsdGeom.XformCommonAPI(spot).SetRotate(Gf.Vec3f(0.0, 90.0, 0.0))  # -Z turned to -X
        plain = UsdLux.DiskLight.Define(stage, "/Plain")
        UsdLux.ShapingAPI.Apply(plain.GetPrim())
        ies = UsdLux.RectLight.Define(stage, "/Ies")
        UsdLux.ShapingAPI.Apply(ies.GetPrim()).CreateShapingIesFileAttr("lamp.ies")
        UsdLux.SphereLight.Define(stage, "/Bare")

    with pytest.warns(UserWarning, match=r"IES.*not found.*1 prim\(s\) \(lamp\.ies: 1\): /Ies$") as record:
        scene = wrt.load_usd(write_stage(tmp_path, build))
    assert not [w for w in record if "Spot" in str(w.message) or "Plain" in str(w.message)]
    lights = {light.path: light for light in scene.lights}
    spot = lights["/Spot"].shaping
    assert (spot.cone_angle, spot.cone_softness, spot.focus) == (30.0, 0.25, 2.0)
    np.testing.assert_allclose(spot.focus_tint, (0.1, 0.2, 0.3), rtol=1e-6)
    np.testing.assert_allclose(lights["/Spot"].axis, (-1, 0, 0), atol=1e-6)
    assert lights["/Plain"].shaping.at_fallbacks()
    assert lights["/Bare"].shaping is None


def test_sphere_light_with_shaping_at_its_fallbacks_emits_in_front_only(tmp_path):
    """The fallback cone (90 degrees) keeps a shaped sphere light's emission in front of its -Z axis, as the schema
    says (Omniverse writes 180 for sphere lights that shine everywhere)."""

    def build(stage):
        lamp = UsdLux.SphereLight.Define(stage, "/Lamp")
        lamp.CreateRadiusAttr(0.05)
        UsdLux.ShapingAPI.Apply(lamp.GetPrim())
        UsdGeom.XformCommonAPI(lamp).SetTranslate(Gf.Vec3d(0, 0, 1))
        UsdGeom.XformCommonAPI(lamp).SetRotate(Gf.Vec3f(0.0, 180.0, 0.0))  # -Z turned up, away from the plane

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = wrt.load_usd(write_stage(tmp_path, build))
    scene.meshes.append(quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane"))
    # One sample through each pixel centre: the camera rays miss the lamp, whose top shines up at them.
    img = wrt.render(scene, camera=top_down_camera(height=1.0), width=4, height=4, spp=1, device="cpu")
    assert img.rgb.max() == 0.0
    scene.lights[0].shaping.cone_angle = 180.0
    assert wrt.render(scene, camera=top_down_camera(height=1.0), width=4, height=4, device="cpu").rgb.min() > 0.0


def test_usd_shaping_that_cannot_be_used_is_reported(tmp_path):
    """A cone angle that is not a number skips its light, and shaping on a distant light is not applied: each is
    warned about, naming the light."""

    def build(stage):
        bad = UsdLux.DiskLight.Define(stage, "/Bad")
        UsdLux.ShapingAPI.Apply(bad.GetPrim()).CreateShapingConeAngleAttr(float("nan"))
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        UsdLux.ShapingAPI.Apply(sun.GetPrim()).CreateShapingFocusAttr(4.0)

    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(write_stage(tmp_path, build))
    messages = "\n".join(str(w.message) for w in record)
    assert "skipped" in messages and "cone_angle must be a finite number" in messages and "/Bad" in messages
    assert "distant and dome lights is not supported" in messages and "/Sun" in messages
    assert [light.path for light in scene.lights] == ["/Sun"]


@pytest.mark.parametrize("fields, message", [
    (dict(cone_angle=270.0), r"Shaping cone_angle must be in \[0, 180\] degrees, got 270.0"),
    (dict(cone_angle=-5.0), r"Shaping cone_angle must be in \[0, 180\] degrees, got -5.0"),
    (dict(cone_softness=1.5), r"Shaping cone_softness must be in \[0, 1\], got 1.5"),
    (dict(cone_softness=-0.25), r"Shaping cone_softness must be in \[0, 1\], got -0.25"),
    (dict(focus=-1.0), "Shaping focus must be a finite number >= 0, got -1.0"),
    (dict(focus_tint=(0.5, -0.1, 0.0)), r"Shaping focus_tint must be finite numbers of shape \(3,\) >= 0"),
])
def test_shaping_out_of_its_range_is_refused_naming_the_field(fields, message):
    """The schema's ranges (softness [0, 1], focus >= 0; the cone is an angle off the axis, [0, 180]) were clamped
    without a word: a softness of 1.5 rendered as 1, a cone of -5 degrees as a dark light."""
    with pytest.raises(wrt.SceneError, match=message):
        wrt.Shaping(**fields)
    assert wrt.Shaping(cone_angle=180.0, cone_softness=1.0, focus=0.0).cone_angle == 180.0  # the ends are in range


def test_shaping_given_a_bad_value_after_it_was_made_is_refused_naming_the_light():
    light = make_light("disk", wrt.Shaping(cone_angle=30.0))
    light.shaping.cone_softness = 2.0
    with pytest.raises(wrt.SceneError, match=r"^/Spot: DiskLight shaping: Shaping cone_softness must be in \[0, 1\]"):
        render_plane([light], spp=1, res=2)


def test_usd_shaping_out_of_its_range_is_clamped_as_the_schema_says_with_a_warning(tmp_path):
    """The schema clamps the softness to [0, 1] and ignores a negative focus; a cone past 180 degrees limits nothing
    and one below 0 lets no light out. A stage's such values are read so (the light is kept, not skipped as a bad
    Shaping), and the warning names the light and the inputs."""

    def build(stage):
        wide = UsdLux.DiskLight.Define(stage, "/Wide")
        api = UsdLux.ShapingAPI.Apply(wide.GetPrim())
        api.CreateShapingConeAngleAttr(270.0)
        api.CreateShapingConeSoftnessAttr(1.5)
        api.CreateShapingFocusAttr(-2.0)
        api.CreateShapingFocusTintAttr(Gf.Vec3f(-0.5, 0.25, 0.0))
        shut = UsdLux.SphereLight.Define(stage, "/Shut")
        api = UsdLux.ShapingAPI.Apply(shut.GetPrim())
        api.CreateShapingConeAngleAttr(-10.0)
        api.CreateShapingConeSoftnessAttr(-1.0)
        UsdLux.SphereLight.Define(stage, "/Fine").GetPrim().ApplyAPI(UsdLux.ShapingAPI)

    with pytest.warns(UserWarning, match="light shaping inputs outside their range were clamped") as record:
        scene = wrt.load_usd(write_stage(tmp_path, build))
    message = "\n".join(str(w.message) for w in record if "shaping inputs" in str(w.message))
    assert "/Wide" in message and "/Shut" in message and "/Fine" not in message
    assert "inputs:shaping:cone:angle = 270" in message and "inputs:shaping:focus = -2" in message
    shapings = {light.path: light.shaping for light in scene.lights}
    wide, shut = shapings["/Wide"], shapings["/Shut"]
    assert (wide.cone_angle, wide.cone_softness, wide.focus) == (180.0, 1.0, 0.0)
    np.testing.assert_array_equal(wide.focus_tint, (0.0, 0.25, 0.0))
    assert (shut.cone_angle, shut.cone_softness) == (0.0, 0.0)
    assert shapings["/Fine"].at_fallbacks()


@pytest.mark.parametrize("make, message", [
    (lambda: wrt.Shaping(cone_angle=float("nan")), "Shaping cone_angle must be a finite number"),
    (lambda: wrt.Shaping(focus_tint=(1.0, 0.0)), "Shaping focus_tint must be finite numbers of shape"),
    (lambda: SphereLight(position=(0, 0, 1), radius=0.1, color=np.ones(3), shaping=30.0, path="/S"),
     "/S: SphereLight shaping must be a wrt.Shaping or None, got float"),
])
def test_bad_shaping_built_in_python_is_refused(make, message):
    with pytest.raises(wrt.SceneError, match=message.replace("(", r"\(")):
        make()


@pytest.mark.parametrize("emits_behind", [True, False])
@pytest.mark.parametrize("angle", [1e-3, 0.02, 0.1, 0.5, 30.0])
def test_power_fraction_of_a_hard_cone_is_its_closed_form(angle, emits_behind):
    """A hard cone of half angle ``a`` lets out ``(1 - cos a) / 2`` of a uniform sphere's power and ``sin^2 a`` of a
    Lambertian emitter's (float64 closed forms), at any angle > 0: it was 0 below half an integration step."""
    a = math.radians(angle)
    expected = (1.0 - math.cos(a)) / 2.0 if emits_behind else math.sin(a) ** 2
    got = wrt.Shaping(cone_angle=angle).power_fraction(emits_behind)
    assert got == pytest.approx(expected, rel=1e-5)
