"""IES light profiles (UsdLux ShapingAPI ``shaping:ies:*``): the LM-63 parser and the profile on the light's emission.

Every expected value is computed here: a point light of intensity ``I`` shaped by a profile ``f(theta, phi)`` gives a
plane below it the irradiance ``I f cos(incidence) / d^2``, with ``theta`` the angle off the light's -Z axis and
``phi`` the angle round it from the light's +X towards +Y. The profiles are built so that the file's bilinear table is
exact: ``f = A(theta) B(phi)``, each piecewise linear with knots at the file's angles, and the horizontal symmetries
are unfolded here (a quadrant file mirrored into four, a half into two, ...) with ``np.interp``.
"""

import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux
from shading_helpers import pixel_points, quad, top_down_camera
from test_lights import ALBEDO, write_stage

import wrt
from wrt.ies import IesError, parse_ies

HEIGHT = 1.0  # of the light above the plane z = 0
RES = 24
PATCH = 3.0  # up to 65 degrees off the light's axis at the corners

VERTICAL = [0.0, 30.0, 60.0, 90.0]
A_VALUES = [400.0, 300.0, 120.0, 40.0]  # candela factor by vertical angle (degrees)


def ies_text(vertical, horizontal, candela, multiplier=1.0, ballast=1.0, header="IESNA:LM-63-2002") -> str:
    """An LM-63 file: ``candela[h][v]``, numbers wrapped over lines as real files do."""
    values = [f"{c:g}" for row in candela for c in row]
    body = "\n".join(" ".join(values[i:i + 7]) for i in range(0, len(values), 7))
    return (f"{header}\n[TEST] synthetic\n[MANUFAC] wrt\nTILT=NONE\n"
            f"1 -1 {multiplier:g} {len(vertical)} {len(horizontal)} 1 2 0 0 0\n{ballast:g} 1 10\n"
            f"{' '.join(f'{v:g}' for v in vertical)}\n{' '.join(f'{h:g}' for h in horizontal)}\n{body}\n")


def folded(phi_deg, horizontal):
    """``phi`` (degrees, [0, 360)) folded into the file's horizontal range by LM-63's symmetry."""
    phi = np.mod(phi_deg, 360.0)
    first, last = horizontal[0], horizontal[-1]
    if len(horizontal) == 1:
        return np.zeros_like(phi)
    if (first, last) == (0.0, 90.0):
        phi = np.where(phi > 180.0, 360.0 - phi, phi)
        return np.where(phi > 90.0, 180.0 - phi, phi)
    if (first, last) == (0.0, 180.0):
        return np.where(phi > 180.0, 360.0 - phi, phi)
    if (first, last) == (90.0, 270.0):  # mirrored about the 90-270 plane: phi -> 180 - phi
        return np.where(phi < 90.0, 180.0 - phi, np.where(phi > 270.0, 540.0 - phi, phi))
    return phi


def b_of(phi_deg, horizontal, b_values):
    """The horizontal factor: linear between the file's angles, round the circle from the last back to 0 (360)."""
    if horizontal[0] == 0.0 and horizontal[-1] > 180.0 and horizontal[-1] < 360.0:
        horizontal, b_values = horizontal + [360.0], b_values + [b_values[0]]
    return np.interp(folded(phi_deg, horizontal), horizontal, b_values)


def write_lamp(tmp_path, text, rotate=None, **inputs):
    """A stage with a point SphereLight (normalized: intensity ``color / 4`` = 1) at HEIGHT, its profile the IES
    text ``text`` in ``lamp.ies`` beside it, and ShapingAPI inputs ``inputs`` (``cone``, ``scale``,
    ``normalize``)."""
    (tmp_path / "lamp.ies").write_text(text)

    def build(stage):
        lamp = UsdLux.SphereLight.Define(stage, "/Lamp")
        lamp.CreateTreatAsPointAttr(True)
        lamp.CreateNormalizeAttr(True)
        lamp.CreateIntensityAttr(4.0)
        UsdGeom.XformCommonAPI(lamp).SetTranslate(Gf.Vec3d(0, 0, HEIGHT))
        if rotate is not None:
            UsdGeom.XformCommonAPI(lamp).SetRotate(Gf.Vec3f(*rotate))
        api = UsdLux.ShapingAPI.Apply(lamp.GetPrim())
        api.CreateShapingIesFileAttr(Sdf.AssetPath("./lamp.ies"))
        api.CreateShapingConeAngleAttr(inputs.get("cone", 180.0))
        if "scale" in inputs:
            api.CreateShapingIesAngleScaleAttr(inputs["scale"])
        if "normalize" in inputs:
            api.CreateShapingIesNormalizeAttr(inputs["normalize"])

    return write_stage(tmp_path, build)


def render_lamp(path):
    scene = wrt.load_usd(path)
    scene.meshes.append(quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane"))
    # One sample through each pixel centre: the formula at every pixel's point.
    img = wrt.render(scene, camera=top_down_camera(height=PATCH), width=RES, height=RES, spp=1, device="cpu",
                     integrator="whitted", max_depth=1)
    assert np.isfinite(img.rgb).all()
    return img.rgb, scene


def expected_radiance(profile, frame=np.eye(3)):
    """Radiance of the plane under a point light of intensity 1 at HEIGHT shaped by ``profile(theta, phi)``
    (degrees), the light's X, Y and Z axes the columns of ``frame``."""
    points = pixel_points((0, 0, 0), PATCH, RES, RES)
    out = points - np.array([0.0, 0.0, HEIGHT])
    d2 = (out**2).sum(-1)
    w = out / np.sqrt(d2)[..., None]
    local = w @ frame  # the emission direction in the light's frame
    theta = np.degrees(np.arccos(np.clip(-local[..., 2], -1.0, 1.0)))
    phi = np.degrees(np.arctan2(local[..., 1], local[..., 0]))
    cos_incidence = -w[..., 2]
    return ALBEDO / np.pi * profile(theta, phi) * cos_incidence / d2


def a_of(theta):
    return np.interp(theta, VERTICAL, A_VALUES, left=np.nan, right=0.0)


HORIZONTAL_CASES = {
    "one angle": ([0.0], [1.0]),
    "0-90": ([0.0, 45.0, 90.0], [1.0, 0.5, 0.2]),
    "0-180": ([0.0, 90.0, 180.0], [1.0, 0.3, 0.6]),
    "90-270": ([90.0, 180.0, 270.0], [0.3, 1.0, 0.6]),
    "0-360": ([0.0, 90.0, 180.0, 270.0, 360.0], [1.0, 0.4, 0.7, 0.2, 1.0]),
    "0-270, 360 left out": ([0.0, 90.0, 180.0, 270.0], [1.0, 0.4, 0.7, 0.2]),
}


@pytest.mark.parametrize("case", list(HORIZONTAL_CASES))
def test_point_light_profile_gives_candela_cos_over_r2(tmp_path, case):
    """Each horizontal symmetry of LM-63: the plane gets ``I f(theta, phi) cos / d^2`` (the profile was skipped with
    a warning: the plane was lit as by a bare point light)."""
    horizontal, b_values = HORIZONTAL_CASES[case]
    candela = [[a * b for a in A_VALUES] for b in b_values]
    rgb, _ = render_lamp(write_lamp(tmp_path, ies_text(VERTICAL, horizontal, candela)))

    def profile(theta, phi):
        return a_of(theta) * b_of(phi, horizontal, b_values)

    expected = expected_radiance(profile)
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())
    assert rgb[..., 0].max() > 0.0 and np.ptp(rgb[..., 0]) > 0.3 * rgb[..., 0].max()


def test_profile_turns_with_the_light(tmp_path):
    """The horizontal angles start at the light's +X: a lamp turned 90 degrees about Z turns its pattern."""
    horizontal, b_values = HORIZONTAL_CASES["0-360"]
    candela = [[a * b for a in A_VALUES] for b in b_values]
    rgb, _ = render_lamp(write_lamp(tmp_path, ies_text(VERTICAL, horizontal, candela), rotate=(0.0, 0.0, 90.0)))
    frame = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # columns: X -> +Y, Y -> -X

    def profile(theta, phi):
        return a_of(theta) * np.interp(np.mod(phi, 360.0), horizontal, b_values)

    expected = expected_radiance(profile, frame)
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


@pytest.mark.parametrize("vertical, values", [
    ([90.0, 135.0, 180.0], [50.0, 200.0, 400.0]),  # emits up only (the lamp is turned over)
    ([0.0, 90.0, 180.0], [10.0, 80.0, 400.0]),  # the whole sphere
])
def test_vertical_ranges_behind_the_horizon(tmp_path, vertical, values):
    """A lamp turned upside down (its -Z up) lights the plane with the profile's back half, theta past 90."""
    rgb, _ = render_lamp(write_lamp(tmp_path, ies_text(vertical, [0.0], [values]), rotate=(180.0, 0.0, 0.0)))
    frame = np.diag([1.0, -1.0, -1.0])  # turned about X: Y and Z flip

    def profile(theta, phi):
        return np.interp(theta, vertical, values, left=0.0, right=0.0)

    expected = expected_radiance(profile, frame)
    assert expected.min() > 0.0
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def test_a_downward_profile_leaves_the_upper_hemisphere_dark(tmp_path):
    """A 0-90 profile on a lamp turned upside down: the plane lies above its horizon and gets nothing."""
    rgb, _ = render_lamp(write_lamp(tmp_path, ies_text(VERTICAL, [0.0], [A_VALUES]), rotate=(180.0, 0.0, 0.0)))
    assert rgb.max() == 0.0


@pytest.mark.parametrize("scale", [0.5, -2.0])
def test_angle_scale_maps_theta_as_the_schema_says(tmp_path, scale):
    """``theta_ies = theta / s`` for ``s > 0``; ``(theta - pi) / -s + pi`` for ``s < 0`` (schema.usda)."""
    vertical, values = [0.0, 45.0, 90.0, 135.0, 180.0], [400.0, 200.0, 100.0, 60.0, 30.0]
    rgb, _ = render_lamp(write_lamp(tmp_path, ies_text(vertical, [0.0], [values]), scale=scale))

    def profile(theta, phi):
        t = theta / scale if scale > 0 else (theta - 180.0) / -scale + 180.0
        return np.interp(t, vertical, values, left=0.0, right=0.0)

    expected = expected_radiance(profile)
    unscaled = expected_radiance(lambda theta, phi: np.interp(theta, vertical, values))
    assert np.abs(expected / unscaled - 1.0).max() > 0.3  # the scale shows
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


@pytest.mark.parametrize("vertical, span", [([0.0, 30.0, 60.0, 90.0], 2.0), ([0.0, 60.0, 120.0, 180.0], 4.0)])
def test_normalize_divides_by_the_mean_intensity(tmp_path, vertical, span):
    """``shaping:ies:normalize``: the profile over its mean over the hemisphere (a 0-90 file) or the sphere (0-180)
    it covers, the mean integrated here on a fine grid in float64."""
    horizontal, b_values = HORIZONTAL_CASES["0-180"]
    candela = [[a * b for a in A_VALUES] for b in b_values]

    def raw(theta, phi):
        return np.interp(theta, vertical, A_VALUES, left=0.0, right=0.0) * np.interp(
            folded(phi, horizontal), horizontal, b_values)

    t = (np.arange(2000) + 0.5) * (vertical[-1] / 2000)
    p = (np.arange(720) + 0.5) * 0.5
    tt, pp = np.meshgrid(t, p, indexing="ij")
    solid = np.sin(np.radians(tt)) * math.radians(vertical[-1] / 2000) * math.radians(0.5)
    mean = float((raw(tt, pp) * solid).sum() / (span * math.pi))
    rgb, _ = render_lamp(write_lamp(tmp_path, ies_text(vertical, horizontal, candela), normalize=True))
    expected = expected_radiance(lambda theta, phi: raw(theta, phi) / mean)
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def test_candela_multiplier_and_ballast_factor_scale_the_profile():
    """The file's candela multiplier and ballast factor multiply its values; LM-63-1995's ballast-lamp photometric
    factor too, where 2002's field of that place is 'future use'."""
    p = parse_ies(ies_text([0.0, 90.0], [0.0], [[10.0, 20.0]], multiplier=2.0, ballast=0.5), "a.ies")
    np.testing.assert_allclose(p.candela, [[10.0, 20.0]])
    old = ies_text([0.0, 90.0], [0.0], [[10.0, 20.0]], multiplier=3.0, header="IESNA:LM-63-1995")
    np.testing.assert_allclose(parse_ies(old.replace("\n1 1 10\n", "\n1 0.5 10\n"), "b.ies").candela, [[15.0, 30.0]])


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace("TILT=NONE", "TILT="), r"lamp\.ies:4: TILT= names nothing"),
    (lambda t: t.replace("TILT=NONE", "TILT=INCLUDE\n1 1.5\n0\n1"), r"lamp\.ies:5: the number of tilt angles must be"),
    (lambda t: t.replace("TILT=NONE", "TILT=INCLUDE\n1 2\n0 x\n1 1"), r"lamp\.ies:6: 'x' is not a number.*tilt angles"),
    (lambda t: t.replace("TILT=NONE\n", ""), r"lamp\.ies: no TILT= line"),
    (lambda t: t.replace(" 1 2 0 0 0", " 2 2 0 0 0"), r"lamp\.ies:5: photometric type B is not supported"),
    (lambda t: t.replace("0 30 60 90", "0 30 x 90"), r"lamp\.ies:7: 'x' is not a number"),
    (lambda t: t.rsplit("\n", 3)[0], r"lamp\.ies:\d+: the file ends early: expected 8 candela values"),
    (lambda t: t.replace("0 30 60 90", "0 60 30 90"), r"lamp\.ies: vertical angles must be ascending"),
    (lambda t: t.replace("\n0 90\n", "\n0 45\n"), r"horizontal angles 0-45 are none of LM-63's ranges"),
])
def test_malformed_files_name_the_file_and_line(edit, message):
    text = edit(ies_text(VERTICAL, [0.0, 90.0], [A_VALUES, A_VALUES]))
    with pytest.raises(IesError, match=message):
        parse_ies(text, "lamp.ies")


@pytest.mark.parametrize("broken, message", [
    (None, r"IES profiles \(shaping:ies:file\) that were not found are ignored.*\./lamp\.ies.*/Lamp"),
    ("TILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n100 oops 20\n",
     r"IES profiles \(shaping:ies:file\) that cannot be read are ignored.*lamp\.ies:6: 'oops' is not a number.*/Lamp"),
])
def test_a_profile_that_cannot_be_used_is_warned_about_and_the_light_emits_without_it(tmp_path, broken, message):
    path = write_lamp(tmp_path, broken or "")
    if broken is None:
        (tmp_path / "lamp.ies").unlink()
    with pytest.warns(UserWarning, match=message):
        rgb, scene = render_lamp(path)
    assert scene.lights[0].shaping.ies is None
    expected = expected_radiance(lambda theta, phi: np.ones_like(theta))  # the bare point light of intensity 1
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def test_a_profile_on_an_area_light_scales_what_it_emits_towards_the_plane():
    """A small disk light (its own cosine included) with a profile the same in every direction at 3 candela:
    three times the bare light, for light sampling and the camera rays that see it alike."""
    from wrt.ies import IesProfile
    from wrt.lights import DiskLight

    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, HEIGHT)

    def render(shaping):
        disk = DiskLight(to_world=to_world, radius=0.05, color=np.full(3, 50.0), shaping=shaping, path="/Disk")
        scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=[disk])
        return wrt.render(scene, camera=top_down_camera(height=PATCH), width=12, height=12, spp=16, seed=5,
                          device="cpu", integrator="path", max_depth=1).rgb

    flat = IesProfile([0.0, 90.0, 180.0], [0.0], [[3.0, 3.0, 3.0]])
    np.testing.assert_allclose(render(wrt.Shaping(ies=flat)), 3.0 * render(None), rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("make, message", [
    (lambda: wrt.IesProfile([0.0, 90.0], [0.0], [[1.0, 2.0, 3.0]]), r"candela must hold 1 x 2 values"),
    (lambda: wrt.IesProfile([0.0], [0.0], [[1.0]]), "at least 2 vertical angles"),
    (lambda: wrt.IesProfile([0.0, 200.0], [0.0], [[1.0, 1.0]]), r"vertical angles must lie in \[0, 180\]"),
    (lambda: wrt.IesProfile([0.0, 90.0], [0.0], [[1.0, -1.0]]), "finite and not negative"),
])
def test_profiles_built_in_python_are_checked(make, message):
    with pytest.raises(wrt.IesError, match=message):
        make()


def test_a_shaping_refuses_a_profile_that_is_not_one():
    """A file name where the profile goes (``Shaping(ies="lamp.ies")``) is refused, pointing at ``wrt.read_ies``."""
    with pytest.raises(wrt.SceneError, match="Shaping ies must be a wrt.ies.IesProfile or None, got str"):
        wrt.Shaping(ies="lamp.ies")
    with pytest.raises(wrt.SceneError, match="ies_angle_scale must be a finite number"):
        wrt.Shaping(ies=wrt.IesProfile([0.0, 90.0], [0.0], [[1.0, 1.0]]), ies_angle_scale=float("inf"))


def test_point_instanced_lamps_turn_their_profiles_with_their_instances(tmp_path):
    """A PointInstancer of profiled lamps: each copy's pattern turns with its instance's orientation (its X axis,
    where the horizontal angles start), and the lamps share the profile, read once. One lamp spun 90 degrees about Z
    over the plane lights it as a lamp turned so; the other hangs below the plane, facing away from it."""
    horizontal, b_values = HORIZONTAL_CASES["0-360"]
    (tmp_path / "lamp.ies").write_text(ies_text(VERTICAL, horizontal, [[a * b for a in A_VALUES] for b in b_values]))

    def build(stage):
        lamp = UsdLux.SphereLight.Define(stage, "/Lamps/Protos/Lamp")
        lamp.CreateTreatAsPointAttr(True)
        lamp.CreateNormalizeAttr(True)
        lamp.CreateIntensityAttr(4.0)
        api = UsdLux.ShapingAPI.Apply(lamp.GetPrim())
        api.CreateShapingIesFileAttr(Sdf.AssetPath("./lamp.ies"))
        api.CreateShapingConeAngleAttr(180.0)
        pi = UsdGeom.PointInstancer.Define(stage, "/Lamps")
        pi.CreatePrototypesRel().SetTargets([Sdf.Path("/Lamps/Protos/Lamp")])
        pi.CreateProtoIndicesAttr([0, 0])
        # The first instance (read for the others to copy) hangs below the plane; the second is the copy under test.
        pi.CreatePositionsAttr([(0.0, 0.0, -5.0), (0.0, 0.0, HEIGHT)])
        spin = Gf.Rotation(Gf.Vec3d(0, 0, 1), 90.0).GetQuat()
        pi.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), Gf.Quath(spin)])

    rgb, scene = render_lamp(write_stage(tmp_path, build))
    assert len(scene.lights) == 2 and scene.lights[0].shaping.ies is scene.lights[1].shaping.ies
    np.testing.assert_allclose(scene.lights[1].x_axis, (0.0, 1.0, 0.0), atol=1e-3)  # a half-precision quaternion
    frame = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # columns: X -> +Y, Y -> -X

    def profile(theta, phi):
        return a_of(theta) * np.interp(np.mod(phi, 360.0), horizontal, b_values)

    expected = expected_radiance(profile, frame)
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def test_a_mirrored_light_mirrors_its_profile():
    """A small disk light mirrored across its XZ plane (its Y axis turned to -Y): its local +Y, where the profile's
    90-degree plane lies, is the world's -Y, as USD's local space says (the profile was looked up with Y = Z x X,
    unmirrored)."""
    from wrt.lights import DiskLight

    horizontal, b_values = HORIZONTAL_CASES["0-360"]
    profile_file = wrt.IesProfile(VERTICAL, horizontal, [[a * b for a in A_VALUES] for b in b_values])
    to_world = np.diag([1.0, -1.0, 1.0, 1.0])
    to_world[:3, 3] = (0, 0, HEIGHT)
    radius, radiance = 0.002, 200.0  # small: the points sampled on it all see the profile alike
    disk = DiskLight(to_world=to_world, radius=radius, color=np.full(3, radiance),
                     shaping=wrt.Shaping(cone_angle=180.0, ies=profile_file), path="/Disk")
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")], lights=[disk])
    rgb = wrt.render(scene, camera=top_down_camera(height=PATCH), width=RES, height=RES, spp=1, device="cpu",
                     integrator="whitted", max_depth=1).rgb
    frame = np.diag([1.0, -1.0, 1.0])

    def profile(theta, phi):
        # The small disk: intensity L pi r^2 cos(theta) towards theta, times the profile.
        return radiance * np.pi * radius**2 * np.cos(np.radians(theta)) * a_of(theta) * np.interp(
            np.mod(phi, 360.0), horizontal, b_values)

    expected = expected_radiance(profile, frame)
    # Sampled points of the disk see the light a little off its centre's angles (2% near the axis, where phi turns).
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=0.02, atol=1e-3 * expected.max())


def test_a_profile_packed_in_a_usdz_lights_as_the_same_file_beside_the_stage(tmp_path):
    """A lamp and its IES file packed into one ``.usdz`` (the file resolves to ``lamp.usdz[lamp.ies]``, which no
    plain ``open`` reads): the plane gets ``I f(theta) cos / d^2``, as from the files unpacked. The profile was warned
    about as 'cannot be read (No such file or directory)' and the lamp lit as a bare point light."""
    from pxr import UsdUtils

    stage = write_lamp(tmp_path, ies_text(VERTICAL, [0.0], [A_VALUES]))
    packed = str(tmp_path / "lamp.usdz")
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(stage), packed)
    (tmp_path / "lamp.ies").unlink()  # only the package's copy is left
    rgb, scene = render_lamp(packed)
    assert scene.lights[0].shaping.ies is not None
    expected = expected_radiance(lambda theta, phi: a_of(theta))
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def test_a_mirrored_point_lamp_mirrors_its_profile(tmp_path):
    """A point SphereLight scaled by (1, -1, 1) (mirrored across its XZ plane): its local +Y, where the profile's
    90-degree plane lies, is the world's -Y, as for the mirrored disk above. Sphere lights kept only their -Z and X
    axes and looked the profile up with Y = Z x X, unmirrored: the pattern came out mirrored."""
    horizontal, b_values = HORIZONTAL_CASES["0-360"]
    path = write_lamp(tmp_path, ies_text(VERTICAL, horizontal, [[a * b for a in A_VALUES] for b in b_values]))
    stage = Usd.Stage.Open(path)
    UsdGeom.XformCommonAPI(stage.GetPrimAtPath("/Lamp")).SetScale(Gf.Vec3f(1.0, -1.0, 1.0))
    stage.Save()
    rgb, _ = render_lamp(path)

    def profile(theta, phi):
        return a_of(theta) * np.interp(np.mod(phi, 360.0), horizontal, b_values)

    expected = expected_radiance(profile, np.diag([1.0, -1.0, 1.0]))
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def test_errors_name_the_line_of_files_with_windows_text_in_their_keywords(tmp_path):
    """A keyword line holding a Windows-1252 ellipsis (byte 0x85, which Latin-1 reads as U+0085, a line break to
    Python's splitlines) and CRLF line ends: the error names the line the bad number is on, as an editor counts lines
    (by CR, LF, CRLF). It named the line after it."""
    text = ies_text(VERTICAL, [0.0], [A_VALUES]).replace("[TEST] synthetic", "[TEST] 12 \x85 synthetic")
    text = text.replace("0 30 60 90", "0 30 x 90").replace("\n", "\r\n")
    (tmp_path / "lamp.ies").write_bytes(text.encode("latin-1"))
    bad_line = text.split("\r\n").index("0 30 x 90") + 1
    with pytest.raises(IesError, match=rf"lamp\.ies:{bad_line}: 'x' is not a number"):
        wrt.read_ies(str(tmp_path / "lamp.ies"))


def test_a_free_text_line_that_begins_with_tilt_is_no_tilt_line():
    """LM-63-1986 files have free text lines before ``TILT=``; one that starts with the word ``Tilted`` is text. It
    was taken for the TILT line and the file refused as 'TILT= is not supported'."""
    text = ies_text(VERTICAL, [0.0], [A_VALUES]).replace("IESNA:LM-63-2002\n[TEST] synthetic\n[MANUFAC] wrt\n",
                                                           "ACME WALL WASHER\nTilted 15 degrees in its housing\n")
    np.testing.assert_allclose(parse_ies(text, "old.ies").candela, [A_VALUES])


# LM-63-2002 section 5.3: TILT=INCLUDE is followed by the lamp-to-luminaire geometry, the number of tilt angles, the
# angles and their multiplying factors, and then the photometric data (number of lamps, lumens per lamp, ...).
TILT_BLOCK = "TILT=INCLUDE\n1\n7\n0 15 30 45 60 75 90\n1.0 .95 .94 .90 .88 .87 .94\n"


@pytest.mark.parametrize("tilt", [TILT_BLOCK, "TILT=INCLUDE\n3 3\n0 45 90 1 0.8\n0.5\n", "TILT=INCLUDE\n2\n0\n",
                                  "TILT=lamp_tilt.dat\n"])
def test_tilt_data_is_read_past_with_a_warning_and_the_candela_table_kept(tilt):
    """A lamp's tilt (TILT=INCLUDE data before the photometric data, wrapped over lines as it may be, or a tilt file
    named by TILT=<file>) is ignored, as Cycles and hdEmbree ignore it, with a warning naming the file; the candela
    table comes out as the same file's with TILT=NONE. Such files were refused and the lamp lit without a profile."""
    candela = [A_VALUES, [v / 2 for v in A_VALUES], [v / 4 for v in A_VALUES]]
    plain = ies_text(VERTICAL, [0.0, 45.0, 90.0], candela, multiplier=2.0, ballast=0.5)
    with pytest.warns(UserWarning, match=r"tilted\.ies:4: TILT=\S+: the lamp tilt is ignored"):
        profile = parse_ies(plain.replace("TILT=NONE\n", tilt), "tilted.ies")
    np.testing.assert_array_equal(profile.candela, np.asarray(candela, np.float64))
    np.testing.assert_array_equal(profile.vertical, VERTICAL)
    np.testing.assert_array_equal(profile.horizontal, [0.0, 45.0, 90.0])


def test_a_lamp_with_tilt_data_lights_with_its_profile(tmp_path):
    """Through a stage: the TILT=INCLUDE lamp gives I f(theta) cos / d^2, with the tilt warned about naming the
    file, where it used to emit as a bare light."""
    text = ies_text(VERTICAL, [0.0], [A_VALUES]).replace("TILT=NONE\n", TILT_BLOCK)
    path = write_lamp(tmp_path, text)
    with pytest.warns(UserWarning, match=r"lamp\.ies:4: TILT=INCLUDE: the lamp tilt is ignored"):
        rgb, scene = render_lamp(path)
    assert scene.lights[0].shaping.ies is not None
    expected = expected_radiance(lambda theta, phi: a_of(theta))
    np.testing.assert_allclose(rgb[..., 0], expected, rtol=2e-3, atol=1e-4 * expected.max())


def flat_light(kind, shaping=None, color=1.0):
    """A rect (1.0 x 0.5), disk (radius 0.4) or sphere (radius 0.3) light 1 above the origin, its -Z down, of
    radiance ``color``; and its power unshaped, ``pi * area * L`` (a Lambertian emitter's), in float64."""
    from wrt.lights import DiskLight, RectLight, SphereLight

    to_world = np.eye(4)
    to_world[:3, 3] = (0, 0, HEIGHT)
    L = np.full(3, color)
    if kind == "rect":
        return RectLight(to_world=to_world, width=1.0, height=0.5, color=L, shaping=shaping), math.pi * 0.5 * color
    if kind == "disk":
        return DiskLight(to_world=to_world, radius=0.4, color=L, shaping=shaping), math.pi**2 * 0.16 * color
    return (SphereLight(position=(0, 0, HEIGHT), radius=0.3, color=L, shaping=shaping),
            math.pi * 4 * math.pi * 0.09 * color)


# A profile of 1 candela out to 90 degrees (a downlight filling its hemisphere), at an angle scale, on a light: the
# share of the light's power it lets out, in closed form. theta_eff = theta / s (s > 0) reaches 90 degrees at
# theta = s pi / 2; for s < 0, theta_eff = (theta - pi) / -s + pi lies in [0, 90] for theta in [pi + s pi, pi + s pi/2].
# A Lambertian emitter (rect, disk) weighs directions by cos theta over its front half (sin^2 of the edge), a sphere
# all directions alike ((1 - cos) / 2 of the edge).
ANGLE_SCALED = {
    ("rect", 0.25): math.sin(math.pi / 8) ** 2,
    ("disk", 0.1): math.sin(math.pi / 20) ** 2,
    ("rect", 2.0): 1.0,  # stretched over the sphere: the whole front half
    ("rect", -0.5): 0.0,  # turned behind the light, which emits nothing there
    ("sphere", 0.25): (1.0 - math.cos(math.pi / 8)) / 2.0,
    ("sphere", -0.5): (math.cos(math.pi / 2) - math.cos(3 * math.pi / 4)) / 2.0,
    ("sphere", 0.0): 0.5,
}


@pytest.mark.parametrize("kind, scale", list(ANGLE_SCALED))
def test_light_selection_weighs_a_profile_at_its_angle_scale_and_the_lights_cosine(kind, scale):
    """Light selection picks lights by their power: one shaped by a profile and its ``angleScale`` beside an
    unshaped sphere light of known power is picked in the ratio of their powers (``pmf = 1 / 2n + power share / 2``),
    the profile's share worked out here in closed form. Before, the share was the profile's mean over the sphere (0.5
    here) whatever the angle scale and the light's own cosine: 3.4x too much for a rect light at scale 0.25, 20x for a
    disk at 0.1, infinitely much for a profile turned behind a rect light (picked for nothing: noise, not bias)."""
    from wrt import light_table
    from wrt.lights import SphereLight

    shaping = wrt.Shaping(ies=wrt.IesProfile([0.0, 90.0], [0.0], [[1.0, 1.0]]), ies_angle_scale=scale, cone_angle=180)
    shaped, bare_power = flat_light(kind, shaping, color=2.0)
    reference = SphereLight(position=(3, 0, 1), radius=0.2, color=np.ones(3))
    reference_power = math.pi * 4 * math.pi * 0.04
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")])
    device_lights = light_table.build_lights([shaped, reference], scene, [np.zeros(3)], "cpu").device_lights
    pmf = device_lights.pmf.numpy()[:2].astype(np.float64)
    expected = bare_power * ANGLE_SCALED[kind, scale] / (bare_power * ANGLE_SCALED[kind, scale] + reference_power)
    np.testing.assert_allclose(2.0 * pmf[0] - 0.5, expected, rtol=2e-3, atol=1e-6)


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_a_scaled_profile_beside_another_light_lights_as_the_two_alone(integrator):
    """The selection weights change noise, never the mean: a rect light with a profile squeezed by ``angleScale``
    0.25 beside a sphere light lights the plane as the sum of the two rendered alone (within noise)."""
    from wrt.lights import SphereLight

    shaping = wrt.Shaping(ies=wrt.IesProfile([0.0, 90.0], [0.0], [[1.0, 1.0]]), ies_angle_scale=0.25, cone_angle=180)
    rect, _ = flat_light("rect", shaping, color=20.0)
    sphere = SphereLight(position=(1.5, 0, 1), radius=0.2, color=np.full(3, 4.0))
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/plane")

    def render(lights, seed):
        return wrt.render(wrt.Scene(meshes=[plane], lights=lights), camera=top_down_camera(height=PATCH), width=16,
                          height=16, spp=256, seed=seed, device="cpu", integrator=integrator, max_depth=1).rgb

    both = render([rect, sphere], 1).mean()
    alone = render([rect], 2).mean() + render([sphere], 3).mean()
    assert alone > 0.0 and abs(both / alone - 1.0) < 0.01, (both, alone)
