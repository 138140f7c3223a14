"""CylinderLight ``treatAsLine``: UsdLux's "zero-radius cylinder", a line light along the tube's axis of intensity
``I_s sin(theta)`` per unit length (``I_s = 2 r L``, ``color / (pi l)`` with ``normalize``), checked against the
irradiance integrated over the line in float64."""

import warnings

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux
from shading_helpers import pixel_points, quad, top_down_camera

import wrt

ALBEDO = 0.5  # the default material's grey: radiance = ALBEDO * E / pi
RES = 16  # pixels per side of the patch that is checked
PATCH = 1.6  # side of the checked patch of the plane z = 0, scene units


def line_irradiance(points, start, end, per_length, n=20000) -> np.ndarray:
    """``(H, W)`` float64 irradiance at ``points`` (``(H, W, 3)``, on z = 0 facing +Z) from a line from ``start`` to
    ``end`` of intensity ``per_length * sin(theta)`` per unit length: the midpoint rule over ``n`` pieces."""
    start, end = np.asarray(start, np.float64), np.asarray(end, np.float64)
    length = np.linalg.norm(end - start)
    axis = (end - start) / length
    s = (np.arange(n) + 0.5) / n
    q = start + s[:, None] * (end - start)  # (n, 3) points of the line
    v = q[None, None] - points[:, :, None]  # (H, W, n, 3) from each point to the line
    d = np.linalg.norm(v, axis=-1)
    sin_t = np.linalg.norm(np.cross(v, axis), axis=-1) / d
    cos_r = np.maximum(v[..., 2], 0.0) / d
    return (per_length * sin_t * cos_r / d**2).sum(-1) * (length / n)


def line_stage(tmp_path, normalize: bool, treat="bool", radius=0.6, line=True) -> str:
    """A CylinderLight of length 3 and radius ``radius`` along X at height 1 over the patch, ``treatAsLine`` (set to
    ``line``) authored as a ``treat`` (a bool, or an int: not a bool)."""
    path = str(tmp_path / "line.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    light = UsdLux.CylinderLight.Define(stage, "/Tube")
    light.CreateLengthAttr(3.0)
    light.CreateRadiusAttr(radius)
    light.CreateIntensityAttr(2.0)
    light.CreateNormalizeAttr(normalize)
    light.CreateTreatAsLineAttr(line)
    UsdGeom.XformCommonAPI(light).SetTranslate(Gf.Vec3d(0.1, 0.2, 1.0))
    stage.Save()
    if treat == "int":  # as text: USD authors the schema's type through its API
        text = (tmp_path / "line.usda").read_text()
        assert "bool treatAsLine = 1" in text
        (tmp_path / "line.usda").write_text(text.replace("bool treatAsLine = 1", "int treatAsLine = 1"))
    return path


def render_plane(lights, spp=256):
    """Radiance ``(H, W)`` of a large grey plane z = 0 lit by ``lights`` (direct light only), seen from above through
    the light, and the world point under each pixel."""
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=list(lights))
    img = wrt.render(scene, camera=top_down_camera(height=PATCH), width=RES, height=RES, spp=spp, seed=1,
                     device="cpu", integrator="path", max_depth=1)
    assert (img.aovs["prim"] >= 0).all()
    return img.rgb.mean(axis=-1), pixel_points((0, 0, 0), PATCH, RES, RES)


@pytest.mark.parametrize("normalize", [False, True])
def test_a_cylinder_light_treated_as_a_line_lights_as_the_line_integral_says(tmp_path, normalize):
    """The tube of radius 0.6 at height 1 lights the plane as the line along its axis does (``I_s = 2 r L``, or
    ``color / (pi l)`` normalized: the tube's power either way), and camera rays through it see the plane. treatAsLine
    was not read: the tube was drawn, the pixels under it showing its radiance, and it lit the plane as a tube."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lights = wrt.load_usd(line_stage(tmp_path, normalize)).lights
    assert len(lights) == 1 and lights[0].treat_as_line
    rendered, points = render_plane(lights)
    per_length = 2.0 / (np.pi * 3.0) if normalize else 2.0 * 0.6 * 2.0
    expected = ALBEDO * line_irradiance(points, (-1.4, 0.2, 1.0), (1.6, 0.2, 1.0), per_length) / np.pi
    assert abs(rendered.mean() / expected.mean() - 1.0) < 0.02
    np.testing.assert_allclose(rendered, expected, rtol=0.1)  # pixels: E varies over each


@pytest.mark.parametrize("radius", [1e-40, 0.0])
def test_a_normalized_cylinder_light_too_thin_for_float32_is_its_line(tmp_path, radius):
    """A normalized tube's power is ``pi color`` whatever its radius, and its light ``I_s sin(theta)`` per unit length
    (``I_s = color / (pi l)``) as its projected width is ``2 r sin(theta)``. One of radius 1e-40, whose radiance
    ``color / (2 pi r l)`` passes float32's range, was skipped with a warning, and one of radius 0 (UsdLux's
    "zero-radius cylinder", treatAsLine's meaning) lit nothing: each is now the line along its axis, lighting the
    plane as the line integral in float64 says, without a warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lights = wrt.load_usd(line_stage(tmp_path, True, radius=radius, line=False)).lights
    assert [light.path for light in lights] == ["/Tube"] and lights[0].treat_as_line
    rendered, points = render_plane(lights)
    expected = ALBEDO * line_irradiance(points, (-1.4, 0.2, 1.0), (1.6, 0.2, 1.0), 2.0 / (np.pi * 3.0)) / np.pi
    assert abs(rendered.mean() / expected.mean() - 1.0) < 0.02
    np.testing.assert_allclose(rendered, expected, rtol=0.1)


def test_a_python_cylinder_light_too_thin_for_float32_lights_as_its_line():
    """Built in Python, a normalized tube of radius 1e-40 (its radiance past float32) lit nothing; it lights as the
    line along its axis, as ``load_usd`` reads one, within 2% of the line integral in float64."""
    to_world = np.eye(4)
    to_world[:3, 3] = (0.1, 0.2, 1.0)
    tube = wrt.CylinderLight(to_world=to_world, length=3.0, radius=1e-40, color=np.full(3, 2.0), normalize=True)
    assert not np.all(np.isfinite(tube.radiance))  # as a tube, float32 cannot hold it
    rendered, points = render_plane([tube])
    expected = ALBEDO * line_irradiance(points, (-1.4, 0.2, 1.0), (1.6, 0.2, 1.0), 2.0 / (np.pi * 3.0)) / np.pi
    assert abs(rendered.mean() / expected.mean() - 1.0) < 0.02


def test_a_line_light_shorter_than_float32_can_square_lights_as_a_short_line():
    """A normalized line light 1e-25 long (``I_s l = color / pi``, its length well inside float32's range) lit
    nothing: the squares of its axis underflowed float32 to a length of 0. It lights the plane as a short line does,
    intensity ``I_s l sin(theta)`` at ``theta`` to its axis (float64 at each pixel's centre: 2% over the patch)."""
    to_world = np.eye(4)
    to_world[:3, 3] = (0.1, 0.2, 1.0)
    line = wrt.CylinderLight(to_world=to_world, length=1e-25, radius=0.0, color=np.full(3, 2.0), normalize=True,
                             treat_as_line=True)
    rendered, points = render_plane([line], spp=16)
    v = np.array([0.1, 0.2, 1.0]) - points  # to the line, from each point of the plane
    d = np.linalg.norm(v, axis=-1)
    sin_t = np.linalg.norm(np.cross(v, [1.0, 0.0, 0.0]), axis=-1) / d
    expected = ALBEDO * (2.0 / np.pi) * sin_t * (v[..., 2] / d) / d**2 / np.pi
    assert abs(rendered.mean() / expected.mean() - 1.0) < 0.02
    np.testing.assert_allclose(rendered, expected, rtol=0.1)  # pixels: E varies over each


def test_a_line_light_has_the_tubes_power():
    """The line's power ``pi^2 l I_s`` (``I_s sin(theta)`` integrated over the sphere and the length) is the tube's
    ``pi A L``, and ``color`` normalized (``L = color / A``: ``pi color``)."""
    to_world = np.eye(4)
    light = wrt.CylinderLight(to_world=to_world, length=2.0, radius=0.3, color=np.full(3, 5.0), treat_as_line=True)
    per_length = float(light.line_intensity[0])
    np.testing.assert_allclose(np.pi**2 * 2.0 * per_length, np.pi * light.area * 5.0, rtol=1e-6)
    normalized = wrt.CylinderLight(to_world=to_world, length=2.0, radius=0.3, color=np.full(3, 5.0), normalize=True,
                                   treat_as_line=True)
    np.testing.assert_allclose(np.pi**2 * 2.0 * float(normalized.line_intensity[0]), np.pi * 5.0, rtol=1e-6)


def test_treat_as_line_authored_as_an_int_is_the_fallback_with_a_warning(tmp_path):
    """``int treatAsLine = 1`` is not a bool: read as the schema's fallback (false), as USD's typed readers read it,
    with a warning naming it and the prim."""
    with pytest.warns(UserWarning, match=r"not bool.*treatAsLine = 1.*/Tube"):
        lights = wrt.load_usd(line_stage(tmp_path, False, treat="int")).lights
    assert not lights[0].treat_as_line


@pytest.mark.parametrize(
    "length, p, n",
    [
        (0.01, (707.0, 0.0, -707.0), (-1.0, 0.0, 1.0)),  # 1e5 lengths away
        (2.0, (3.0, 0.0, 2.0**-17), (-1.0, 0.0, 0.0)),  # on the axis past an end, 8e-6 off it (exact in float32)
        (2.0, (1.0 + 2.0**-12, 0.0, 2.0**-12), (-1.0, 0.0, 1.0)),  # beside an end
    ],
)
def test_line_light_samples_average_to_the_line_integral_far_away_and_near_its_axis(length, p, n):
    """``sample_light``'s estimates of a line light's irradiance average to the float64 line integral where float32
    rounds the angles it samples by: the span as a difference of two atans was 0.3% off 1e5 lengths away (a
    deterministic bias, far above the samples' spread), points stepped from an angle near pi / 2 put the estimate 1%
    off past an end."""
    from test_lights import light_estimates

    light = wrt.CylinderLight(to_world=np.eye(4), length=length, radius=0.5, color=np.full(3, 1.0), treat_as_line=True)
    p, n = np.asarray(p, np.float64), np.asarray(n, np.float64) / np.linalg.norm(n)
    estimates, _ = light_estimates(light, p, n, count=20000)
    # The oracle's pieces: graded towards p's foot on the line, where the integrand peaks near the axis.
    half = length / 2
    steps = np.geomspace(1e-9, 2 * length, 200)
    foot = float(np.clip(p[0], -half, half))
    cuts = np.unique(np.clip(np.concatenate([[-half, half], foot - steps, foot + steps]), -half, half))
    per_length = float(light.line_intensity[0])
    expected = sum(line_irradiance_at(p, n, a, b, per_length) for a, b in zip(cuts[:-1], cuts[1:]))
    error = estimates.std() / np.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < max(4 * error, 2e-4 * expected), (estimates.mean(), expected, error)


def line_irradiance_at(p, n, a, b, per_length, pieces=64) -> float:
    """Float64 irradiance at ``p`` (unit normal ``n``) from the part of a line light along X from ``x = a`` to
    ``b``: Gauss-Legendre over ``pieces`` nodes."""
    x, w = np.polynomial.legendre.leggauss(pieces)
    q = np.zeros((pieces, 3))
    q[:, 0] = 0.5 * (b - a) * x + 0.5 * (b + a)
    v = q - p
    d = np.linalg.norm(v, axis=1)
    sin_t = np.hypot(v[:, 1], v[:, 2]) / d
    cos_r = np.maximum(v @ n, 0.0) / d
    return float((per_length * sin_t * cos_r / d**2 * w).sum() * 0.5 * (b - a))


@pytest.mark.parametrize("squash", [0.0, 1e-9, 1e-3])
def test_a_line_light_squashed_across_its_axis_keeps_the_ribbons_power(tmp_path, squash):
    """A tube of radius r squashed along Z towards a ribbon, 2 r wide and l long, has the lateral area of the ribbon's
    two faces, 4 r l (squashed by 1e-3: the ellipse's perimeter, 4 r E(1 - 1e-6), barely more), so the line light
    it is treated as has ``I_s = A L / (pi l) = 4 r L / pi``. Where the transform flattened the tube (below 1e-6),
    the line took the round tube of the mean scaled radius (r / 2) instead, ``I_s = r L``: 21% dimmer than the tube
    squashed by 1e-3, and without the warning a flattened tube gets. Read from a stage, and built in Python."""
    r, length, radiance = 0.5, 2.0, 3.0
    # The oracle: the perimeter of the ellipse of semi-axes r and squash * r, the speed of (r cos t, squash r sin t)
    # summed over t in float64 (the trapezoid rule of a periodic integrand; 4 r for the flat one, to 1e-10).
    t = np.linspace(0.0, 2.0 * np.pi, 200_000, endpoint=False)
    perimeter = np.hypot(r * np.sin(t), squash * r * np.cos(t)).mean() * 2.0 * np.pi
    expected = perimeter * length * radiance / (np.pi * length)
    path = str(tmp_path / "ribbon.usda")
    stage = Usd.Stage.CreateNew(path)
    light = UsdLux.CylinderLight.Define(stage, "/Ribbon")
    light.CreateLengthAttr(length)
    light.CreateRadiusAttr(r)
    light.CreateIntensityAttr(radiance)
    light.CreateTreatAsLineAttr(True)
    light.AddScaleOp().Set(Gf.Vec3f(1.0, 1.0, squash))
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loaded = wrt.load_usd(path).lights[0]
    built = wrt.CylinderLight(to_world=np.diag([1.0, 1.0, squash, 1.0]), length=length, radius=r,
                              color=np.full(3, radiance), treat_as_line=True)
    for found in (loaded, built):
        np.testing.assert_allclose(found.line_intensity, np.full(3, expected), rtol=1e-5)
