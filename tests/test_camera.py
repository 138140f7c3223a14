"""Camera conventions: USD's film mapping, row 0 at the top, pixel centres, orthographic cameras."""

import math
import warnings

import numpy as np
import pytest
import warp as wp
from pxr import Gf, Usd, UsdGeom, UsdRender
from test_transform_edge_cases import triangle

import wrt
from wrt.camera import generate_rays_kernel
from wrt.procedural import sensor_scene
from wrt.rays import camera_rays
from wrt.render import resolve_camera, resolve_view


def quad_scene(x0, x1, y0, y1, z):
    points = [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]]
    return wrt.Scene.from_triangles(points, [[0, 1, 2], [0, 2, 3]])


def test_pixel_centres_and_horizontal_aperture_fit():
    # Camera at the origin looking down -Z; focal 50, horizontal aperture 36 -> half width 3.6 at depth 10.
    cam = wrt.Camera(focal_length=50.0, horizontal_aperture=36.0, vertical_aperture=24.0)
    scene = quad_scene(1.8, 100.0, -100.0, 100.0, -10.0)  # covers film x >= 0.5 of the half width
    for height in (100, 300):  # the vertical aperture follows the aspect; the column boundary does not move
        img = wrt.render(scene, camera=cam, width=200, height=height, device="cpu")
        hit_cols = np.flatnonzero(img.aovs["prim"][height // 2] >= 0)
        assert hit_cols.min() == 150 and hit_cols.max() == 199


@pytest.mark.parametrize("fit, square, wide, tall_pixels", [
    # Film (width, height) of apertures 20 x 10 for images of aspect 1 (30x30), 3 (60x20) and 1 again with pixels
    # half as wide as tall (40x20 at pixel aspect 0.5), worked out from UsdRender's words for each policy.
    ("horizontal", (20, 20), (20, 20 / 3), (20, 20)),
    ("vertical", (10, 10), (30, 10), (10, 10)),
    ("expandAperture", (20, 20), (30, 10), (20, 20)),  # grows one aperture: everything the camera frames stays
    ("cropAperture", (10, 10), (20, 20 / 3), (10, 10)),  # shrinks one: the image is filled
    ("adjustApertureWidth", (10, 10), (30, 10), (10, 10)),
    ("adjustApertureHeight", (20, 20), (20, 20 / 3), (20, 20)),
    ("adjustPixelAspectRatio", (20, 10), (20, 10), (20, 10)),  # the apertures as they are
])
def test_fit_takes_usd_conform_policies_and_pixel_aspect(fit, square, wide, tall_pixels):
    cam = wrt.Camera(horizontal_aperture=20, vertical_aperture=10, fit=fit)
    np.testing.assert_allclose(cam.film_size(30, 30), square)
    np.testing.assert_allclose(cam.film_size(60, 20), wide)
    narrow = wrt.Camera(horizontal_aperture=20, vertical_aperture=10, fit=fit, pixel_aspect_ratio=0.5)
    np.testing.assert_allclose(narrow.film_size(40, 20), tall_pixels)
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="pixel aspect ratio"):
            wrt.Camera(pixel_aspect_ratio=bad)


def test_row_zero_is_the_top_of_the_image():
    cam = wrt.Camera(focal_length=50.0, horizontal_aperture=36.0)
    # 200x100: film height 18 -> half height 1.8 at depth 10. A quad above y = 0.9 covers the top quarter.
    scene = quad_scene(-100.0, 100.0, 0.9, 100.0, -10.0)
    img = wrt.render(scene, camera=cam, width=200, height=100, device="cpu")
    rows = np.flatnonzero(img.aovs["prim"][:, 100] >= 0)
    assert rows.min() == 0 and rows.max() == 24


def test_depth_is_distance_along_the_primary_ray():
    cam = wrt.Camera(focal_length=50.0, horizontal_aperture=36.0)
    scene = quad_scene(-100.0, 100.0, -100.0, 100.0, -10.0)
    width, height = 64, 48
    img = wrt.render(scene, camera=cam, width=width, height=height, device="cpu")
    film_h = 36.0 * height / width
    j, i = np.meshgrid(np.arange(width), np.arange(height))
    x = ((j + 0.5) / width - 0.5) * 36.0 / 50.0
    y = (0.5 - (i + 0.5) / height) * film_h / 50.0
    expected = 10.0 * np.sqrt(1.0 + x**2 + y**2)
    np.testing.assert_allclose(img.aovs["depth"], expected, rtol=1e-5)


@pytest.mark.parametrize("scale", [1.0e-30, 1.0e-25, 1.0e20, 1.0e30])
def test_a_camera_scaled_with_its_scene_sees_it_at_the_scaled_depth(scale):
    """The camera and the quad of ``test_depth_is_distance_along_the_primary_ray`` scaled together by 1e-30 to
    1e30: every pixel sees the quad at the analytic depth times the scale. The ray's length was ``wp.length`` of
    components of the scale's size, whose squares overflow (1e20) or vanish (1e-25) in float32: every ray had a zero
    or NaN direction and the image was background."""
    to_world = np.diag([scale, scale, scale, 1.0])
    cam = wrt.Camera(to_world=to_world, focal_length=50.0, horizontal_aperture=36.0)
    scene = quad_scene(-100.0 * scale, 100.0 * scale, -100.0 * scale, 100.0 * scale, -10.0 * scale)
    width, height = 16, 12
    img = wrt.render(scene, camera=cam, width=width, height=height, device="cpu")
    j, i = np.meshgrid(np.arange(width), np.arange(height))
    x = ((j + 0.5) / width - 0.5) * 36.0 / 50.0
    y = (0.5 - (i + 0.5) / height) * 36.0 * height / width / 50.0
    np.testing.assert_allclose(img.aovs["depth"], 10.0 * scale * np.sqrt(1.0 + x**2 + y**2), rtol=1e-5)


def test_z_is_as_precise_as_depth_far_from_the_origin():
    """A tilted camera 1e6 from the world origin, 5 units above a quad: ``z`` (distance along the view axis) is the
    float64 one of the film, to the precision ``depth`` has there. It was taken from the hit point minus the eye, two
    float32 points of that size whose difference had lost its digits: 5e-3 off a z of 5, where depth was 1e-6 off.
    (An orthographic camera there starts its rays at film points rounded to float32 ulps of 1e6, 1/16: depth and z
    are as far off, measured from those points.)"""
    far = 1.0e6
    tilt = math.radians(10.0)
    forward = np.array([0.0, math.sin(tilt), -math.cos(tilt)])  # -Z turned by +10 degrees about X
    up = np.array([0.0, math.cos(tilt), math.sin(tilt)])
    to_world = np.eye(4)
    to_world[:3, 0], to_world[:3, 1], to_world[:3, 2], to_world[:3, 3] = (1, 0, 0), up, -forward, far
    cam = wrt.Camera(to_world=to_world, focal_length=50.0, horizontal_aperture=36.0)
    scene = quad_scene(far - 100.0, far + 100.0, far - 100.0, far + 100.0, far - 5.0)
    width, height = 32, 24
    img = wrt.render(scene, camera=cam, width=width, height=height, device="cpu")
    # The ray through each pixel centre, advancing one unit of depth along the view axis per unit (film at unit
    # depth): it meets the quad, 5 below the eye, at that depth.
    j, i = np.meshgrid(np.arange(width), np.arange(height))
    x = ((j + 0.5) / width - 0.5) * 36.0 / 50.0
    y = (0.5 - (i + 0.5) / height) * 36.0 * height / width / 50.0
    rays = x[..., None] * np.array([1.0, 0.0, 0.0]) + y[..., None] * up + forward
    z = 5.0 / -rays[..., 2]
    np.testing.assert_allclose(img.aovs["depth"], z * np.linalg.norm(rays, axis=-1), atol=2e-5)
    np.testing.assert_allclose(img.aovs["z"], z, atol=2e-5)

def test_look_at_fov_is_vertical():
    cam = wrt.Camera.look_at(eye=(0, 0, 0), target=(0, 0, -1), up=(0, 1, 0), fov_y_deg=90.0)
    scene = quad_scene(-1000.0, 1000.0, -1000.0, 1000.0, -10.0)
    origins, directions = camera_rays(scene, cam, width=40, height=20)
    d = directions.reshape(20, 40, 3)
    # The top row's rays are 0.5 pixel inside the 45-degree edge of the frustum.
    top = math.degrees(math.atan2(d[0, 20, 1], -d[0, 20, 2]))
    assert top == pytest.approx(math.degrees(math.atan((1.0 - 1.0 / 20) * 1.0)), abs=1e-3)
    np.testing.assert_allclose(origins, 0.0)


@pytest.mark.parametrize("length", [1e-13, 1e-200, 1e6])
def test_look_at_takes_an_up_of_any_length(length):
    """``up`` is a direction: its length changes nothing. The check for an up along the view compared the cross
    product of the unnormalised up with 1e-12, so an up of (0, 1e-13, 0) was refused as 'zero or parallel to the
    viewing direction'. Oracle: the closed-form frame of a camera at +Z looking at the origin with +Y up (the
    identity turned by nothing, placed at the eye)."""
    eye = (0.0, 0.0, 5.0)
    cam = wrt.Camera.look_at(eye, (0.0, 0.0, 0.0), (0.0, length, 0.0))
    want = np.eye(4)
    want[:3, 3] = eye
    np.testing.assert_array_equal(cam.to_world, want)
    with pytest.raises(ValueError, match="parallel to the viewing direction"):
        wrt.Camera.look_at(eye, (0.0, 0.0, 0.0), (0.0, 0.0, length))


def test_look_at_and_orthographic_take_another_fit():
    """fit="horizontal" puts the look_at angle (and the orthographic extent) across the width; passing it raised
    "got multiple values for keyword argument 'fit'"."""
    cam = wrt.Camera.look_at(eye=(0, 0, 0), target=(0, 0, -1), fov_y_deg=90.0, fit="horizontal")
    scene = quad_scene(-1000.0, 1000.0, -1000.0, 1000.0, -10.0)
    _, directions = camera_rays(scene, cam, width=40, height=20)
    d = directions.reshape(20, 40, 3)
    right = math.degrees(math.atan2(d[10, 39, 0], -d[10, 39, 2]))  # 0.5 pixel inside the 45-degree edge
    assert right == pytest.approx(math.degrees(math.atan(1.0 - 1.0 / 40)), abs=1e-3)
    ortho = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0, fit="horizontal")
    origins, _ = camera_rays(scene, ortho, width=40, height=20)
    assert origins.reshape(20, 40, 3)[10, 39, 0] == pytest.approx(1.0 - 1.0 / 40, abs=1e-6)  # 2 units wide


def test_helpers_take_the_projection_they_make():
    """projection="orthographic" to Camera.orthographic raised "got multiple values for keyword argument"."""
    for make, projection in ((wrt.Camera.orthographic, "orthographic"), (wrt.Camera.look_at, "perspective")):
        assert make((0, 0, 5), (0, 0, 0), projection=projection).snapshot() == make((0, 0, 5), (0, 0, 0)).snapshot()


def test_orthographic_camera_rays_are_parallel():
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=2.0)
    scene = quad_scene(-0.5, 0.5, -0.5, 0.5, 0.0)
    img = wrt.render(scene, camera=cam, width=40, height=40, device="cpu")
    hit = img.aovs["prim"] >= 0
    assert hit.sum() == 20 * 20  # the unit quad covers half the 2-unit view on each axis
    np.testing.assert_allclose(img.aovs["depth"][hit], 5.0, rtol=1e-6)


@pytest.mark.parametrize("focal_length, meters_per_unit, up_axis", [(0.0, 1.0, "Z"), (-35.0, 0.001, "Y")])
def test_orthographic_usd_camera_of_any_focal_length_is_framed_by_its_apertures(tmp_path, focal_length,
                                                                                 meters_per_unit, up_axis):
    """USD's orthographic frustum is the apertures alone (``GetCamera().frustum`` takes no focal length), and usdview
    draws an orthographic camera of ``focalLength = 0``; wrt skipped it as a camera of no positive focal length. Each
    pixel centre's ray of USD's frustum, met with the plane z = 0 in float64, says which pixels see the quad. The
    apertures are tenths of a scene unit whatever the stage's ``metersPerUnit`` and ``upAxis`` say."""
    path = tmp_path / "ortho.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    UsdGeom.SetStageUpAxis(stage, up_axis)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateProjectionAttr("orthographic")
    cam.CreateFocalLengthAttr(focal_length)
    cam.CreateHorizontalApertureAttr(40.0)  # 4 x 3 scene units
    cam.CreateVerticalApertureAttr(30.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0.3, -0.2, 5.0))  # no pixel centre on the quad's edges
    quad = UsdGeom.Mesh.Define(stage, "/Quad")
    quad.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    stage.Save()
    width, height = 16, 12
    img = wrt.render(wrt.load_usd(path), camera="/Cam", width=width, height=height, device="cpu")
    frustum = cam.GetCamera(Usd.TimeCode.Default()).frustum
    expected = np.zeros((height, width), bool)
    for i in range(height):
        for j in range(width):
            ray = frustum.ComputePickRay(Gf.Vec2d(2 * (j + 0.5) / width - 1, 1 - 2 * (i + 0.5) / height))
            o, d = np.array(ray.startPoint), np.array(ray.direction)
            x, y, _ = o - o[2] / d[2] * d
            expected[i, j] = abs(x) <= 1 and abs(y) <= 1
    assert 0 < expected.sum() < width * height
    np.testing.assert_array_equal(img.aovs["prim"] >= 0, expected)
    np.testing.assert_allclose(img.aovs["depth"][expected], 5.0, rtol=1e-6)  # from the camera's plane, straight on


def test_usd_camera_maps_film_to_pixels(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "cam.usda"))
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(10.0)  # 36 x 10 is wider than the 4:3 image: its height is expanded, its width holds
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 1000.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 10.0))
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    mesh.CreatePointsAttr([(1.8, -100, 0), (100, -100, 0), (100, 100, 0), (1.8, 100, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    stage.Save()
    scene = wrt.load_usd(tmp_path / "cam.usda")
    img = wrt.render(scene, camera="/Cam", width=200, height=150, device="cpu")
    hit_cols = np.flatnonzero(img.aovs["prim"][75] >= 0)
    assert hit_cols.min() == 150 and hit_cols.max() == 199
    np.testing.assert_allclose(img.aovs["depth"][75, 199], 10.0 * math.hypot(1.0, (199.5 / 200 - 0.5) * 0.72),
                               rtol=1e-5)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("size", [(200, 100), (90, 120), (150, 100), (7, 1)])
def test_usd_camera_aperture_is_expanded_to_the_image_aspect(tmp_path, projection, size):
    """A USD camera's aperture is conformed to the image as USD's fallback ``aspectRatioConformPolicy``,
    ``expandAperture``, says (Hydra's default window policy, ``CameraUtilFit``): the whole aperture stays in view and
    the image shows more on the other axis. Each pixel's ray is the pick ray of USD's own frustum through the pixel
    centre, the frustum's window grown about its centre to the image aspect. The horizontal aperture was always kept:
    a 200x100 image of a 36x24 aperture cut away a quarter of its height."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "fit.usda"))
    posed_camera(stage, "/Cam", projection, HorizontalAperture=36.0, VerticalAperture=24.0,
                 HorizontalApertureOffset=3.0, VerticalApertureOffset=-2.0)
    stage.Save()
    width, height = size
    frustum = UsdGeom.Camera(stage.GetPrimAtPath("/Cam")).GetCamera(Usd.TimeCode.Default()).frustum
    window = frustum.GetWindow()
    (w, h), centre = window.GetSize(), window.GetMidpoint()
    w, h = max(w, h * width / height), max(h, w * height / width)  # expandAperture: grown, never cut
    frustum.SetWindow(Gf.Range2d(centre - Gf.Vec2d(w / 2, h / 2), centre + Gf.Vec2d(w / 2, h / 2)))
    origins, directions = camera_rays(wrt.load_usd(tmp_path / "fit.usda"), "/Cam", width=width, height=height)
    rays = [frustum.ComputePickRay(Gf.Vec2d(2.0 * (j + 0.5) / width - 1.0, 1.0 - 2.0 * (i + 0.5) / height))
            for i in range(height) for j in range(width)]  # pixel k = i * width + j, as camera_rays orders them
    starts = np.array([ray.startPoint for ray in rays])
    expected = np.array([ray.direction for ray in rays])
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(directions, expected, atol=1e-6)  # every pixel at once: the same bound per element
    from_start = origins - starts
    off_ray = from_start - np.sum(from_start * expected, axis=1, keepdims=True) * expected
    np.testing.assert_allclose(off_ray, 0.0, atol=1e-5)  # the origin lies on USD's pick ray


def _conformed(window: Gf.Range2d, policy: str, aspect: float) -> Gf.Range2d:
    """``window`` of a Gf.Frustum conformed to the image ``aspect`` as UsdRender's ``aspectRatioConformPolicy``
    says, about its centre (CameraUtilConformWindow, which usd-core lacks)."""
    (w, h), centre = window.GetSize(), window.GetMidpoint()
    if policy in ("expandAperture", "cropAperture"):  # grow (expand) or shrink (crop) the aperture that does not fit
        wider = w > aspect * h  # (a zero vertical aperture is narrower than any image)
        policy = "adjustApertureHeight" if wider == (policy == "expandAperture") else "adjustApertureWidth"
    if policy == "adjustApertureHeight":
        h = w / aspect
    elif policy == "adjustApertureWidth":
        w = h * aspect
    return Gf.Range2d(centre - Gf.Vec2d(w / 2, h / 2), centre + Gf.Vec2d(w / 2, h / 2))


def _quad(stage, path: str, x0: float, x1: float, z: float):
    quad = UsdGeom.Mesh.Define(stage, path)
    quad.CreatePointsAttr([(x0, -1, z), (x1, -1, z), (x1, 1, z), (x0, 1, z)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    quad.CreateDoubleSidedAttr(True)


@pytest.mark.parametrize("projection, near, vertical, policy", [
    ("orthographic", -10.0, 30.0, "expandAperture"),
    ("orthographic", -10.0, 0.0, "adjustApertureHeight"),
    ("orthographic", 0.5, 0.0, "expandAperture"),
    ("perspective", 0.5, 0.0, "expandAperture"),
])
def test_usd_camera_of_a_negative_orthographic_near_or_an_unread_zero_aperture_casts_usds_rays(
        tmp_path, projection, near, vertical, policy):
    """USD takes an orthographic camera whose near plane lies behind it (``clippingRange`` (-10, 100): it sees what
    lies up to 10 units behind its plane) and a ``verticalAperture`` of 0, which a conform policy that grows or
    adjusts that aperture never reads; wrt skipped both cameras as 'clipping range must satisfy 0 <= near < far' and
    'needs finite positive ... apertures'. Each pixel's ray runs from USD's near to its far plane (the frustum's
    projection matrix after the camera's view matrix, the window conformed to the image), and its first hit on two
    quads, one 3 units behind the camera's plane and one 5 in front, found in float64 on those segments, is the
    pixel's z."""
    path = str(tmp_path / "cam.usda")
    stage = Usd.Stage.CreateNew(path)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateProjectionAttr(projection)
    cam.CreateHorizontalApertureAttr(40.0)
    cam.CreateVerticalApertureAttr(vertical)
    cam.CreateClippingRangeAttr(Gf.Vec2f(near, 100.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0.3, -0.2, 5.0))  # no pixel centre on a quad's edge
    _quad(stage, "/Behind", -1.5, -0.25, 8.0)
    _quad(stage, "/Ahead", 0.25, 1.5, 0.0)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/Cam"])
    width, height = 16, 12
    settings.CreateResolutionAttr(Gf.Vec2i(width, height))
    settings.CreateAspectRatioConformPolicyAttr(policy)
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.Save()

    scene = wrt.load_usd(path)
    camera, w, h = resolve_view(scene)
    assert (w, h) == (width, height)
    rays = [wp.empty(w * h, dtype=wp.vec3, device="cpu") for _ in range(2)]
    rays += [wp.empty(w * h, dtype=float, device="cpu") for _ in range(2)]
    wp.launch(generate_rays_kernel, w * h, inputs=[camera.to_struct(w, h), w, h, 0, 0], outputs=rays, device="cpu")
    o, d, t_min, t_max = (r.numpy().astype(np.float64) for r in rays)

    usd_camera = cam.GetCamera(Usd.TimeCode.Default())
    frustum = usd_camera.frustum
    frustum.SetWindow(_conformed(frustum.GetWindow(), policy, width / height))
    clip_to_world = np.linalg.inv(np.linalg.inv(np.array(usd_camera.transform))
                                  @ np.array(frustum.ComputeProjectionMatrix()))
    k, j = (a.ravel() for a in np.meshgrid(range(height), range(width), indexing="ij"))
    ndc = np.stack([2 * (j + 0.5) / width - 1, 1 - 2 * (k + 0.5) / height], axis=1)
    ends = [np.concatenate([ndc, np.full((len(ndc), 1), z), np.ones((len(ndc), 1))], axis=1) @ clip_to_world
            for z in (-1.0, 1.0)]
    start, stop = (e[:, :3] / e[:, 3:] for e in ends)
    np.testing.assert_allclose(o + t_min[:, None] * d, start, atol=1e-4)
    np.testing.assert_allclose(o + t_max[:, None] * d, stop, atol=1e-3)

    expected = np.full(len(ndc), np.inf)
    for x0, x1, z in ((-1.5, -0.25, 8.0), (0.25, 1.5, 0.0)):
        s = (z - start[:, 2]) / (stop[:, 2] - start[:, 2])
        x, y = (start[:, a] + s * (stop[:, a] - start[:, a]) for a in (0, 1))
        hit = (0 <= s) & (s <= 1) & (x0 <= x) & (x <= x1) & (np.abs(y) <= 1)
        expected[hit] = np.minimum(expected[hit], 5.0 - z)  # camera-space depth, USD's cameraDepth
    assert np.isfinite(expected).any() and (near > 0 or (expected < 0).any())  # the quad behind is seen
    img = wrt.render(scene, camera=camera, width=w, height=h, device="cpu")
    np.testing.assert_allclose(img.aovs["z"].ravel(), expected, rtol=1e-5)


@pytest.mark.parametrize("policy", ["cropAperture", "adjustPixelAspectRatio"])
def test_a_zero_aperture_the_conform_policy_reads_names_the_camera(tmp_path, policy):
    """A zero verticalAperture is refused where the film would be flat (cropAperture shrinks the other aperture to
    it; adjustPixelAspectRatio keeps it), naming the camera, the aperture and the policy, and the render settings
    that ask for it, not with Python's ZeroDivisionError (adjustPixelAspectRatio's pixel shape)."""
    with pytest.raises(ValueError, match=rf"camera /Cam needs a positive vertical_aperture, which fit '{policy}'"):
        wrt.Camera(path="/Cam", vertical_aperture=0.0, fit=policy)
    path = str(tmp_path / "cam.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Camera.Define(stage, "/Cam").CreateVerticalApertureAttr(0.0)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/Cam"])
    settings.CreateAspectRatioConformPolicyAttr(policy)
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.Save()
    scene = wrt.load_usd(path)  # the camera's own expandAperture does not read it
    with pytest.raises(wrt.SceneError, match=rf"/Render/Settings renders camera /Cam with aspectRatioConformPolicy "
                                             rf"'{policy}', which it cannot take: .*vertical_aperture=0"):
        resolve_view(scene)
    for fit in ("horizontal", "adjustApertureHeight", "expandAperture"):
        assert wrt.Camera(vertical_aperture=0.0, fit=fit).film_size(40, 30) == (20.955, 20.955 * 30 / 40)
    with pytest.raises(ValueError, match=r"clipping range must satisfy 0 <= near < far"):
        wrt.Camera(clipping_range=(-1.0, 10.0))  # a perspective camera's near plane lies in front of it
    assert wrt.Camera(projection="orthographic", clipping_range=(-1.0, 10.0)).clipping_range == (-1.0, 10.0)


@pytest.mark.parametrize("seed", range(8))
def test_random_usd_cameras_cast_the_rays_of_usds_frustum(tmp_path, seed):
    """Random cameras (projection, film, offsets, clipping range, an animated position and focal length) under a
    sheared, unevenly scaled and maybe mirrored parent, framed by random render settings (resolution, pixel aspect
    ratio, conform policy, data window), at a time between samples: the ray of each pixel runs from the near to the
    far clipping plane of USD's own camera (``GetCamera(time)``'s frustum conformed to the image, its projection
    matrix after the inverse of the whole camera transform, as Hydra's view matrix), through the pixel centre's NDC."""
    rng = np.random.default_rng(seed)
    path = str(tmp_path / "cam.usda")
    stage = Usd.Stage.CreateNew(path)
    rig = UsdGeom.Xform.Define(stage, "/Rig")
    shear = np.eye(4)
    shear[1, 0], shear[2, 1] = rng.uniform(-0.5, 0.5, 2)
    rig.AddTransformOp().Set(Gf.Matrix4d(*shear.ravel()))
    rig.AddScaleOp().Set(Gf.Vec3f(*(rng.uniform(0.3, 3.0, 3) * rng.choice([-1.0, 1.0], 3))))
    cam = UsdGeom.Camera.Define(stage, "/Rig/Cam")
    translate, focal = cam.AddTranslateOp(), cam.CreateFocalLengthAttr()
    for time in (0.0, 10.0):  # read between the samples below
        translate.Set(Gf.Vec3d(*rng.uniform(-20.0, 20.0, 3)), time)
        focal.Set(float(rng.uniform(10.0, 100.0)), time)
    cam.AddRotateXYZOp().Set(Gf.Vec3f(*rng.uniform(-180.0, 180.0, 3)))
    cam.CreateProjectionAttr(str(rng.choice(["perspective", "orthographic"])))
    cam.CreateHorizontalApertureAttr(float(rng.uniform(5.0, 60.0)))
    cam.CreateVerticalApertureAttr(float(rng.uniform(5.0, 60.0)))
    cam.CreateHorizontalApertureOffsetAttr(float(rng.normal(0.0, 5.0)))
    cam.CreateVerticalApertureOffsetAttr(float(rng.normal(0.0, 5.0)))
    cam.CreateClippingRangeAttr(Gf.Vec2f(float(rng.uniform(0.1, 1.0)), float(rng.uniform(50.0, 500.0))))
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/Rig/Cam"])
    width, height = (int(n) for n in rng.integers(8, 24, 2))
    settings.CreateResolutionAttr(Gf.Vec2i(width, height))
    pixel_aspect = float(rng.choice([0.5, 1.0, 2.0]))
    settings.CreatePixelAspectRatioAttr(pixel_aspect)
    policy = str(rng.choice(["expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight",
                             "adjustPixelAspectRatio"]))
    settings.CreateAspectRatioConformPolicyAttr(policy)
    lower = rng.uniform(-0.2, 0.5, 2)  # the window may reach past the image (overscan)
    window = Gf.Vec4f(*lower, *(lower + rng.uniform(0.3, 0.7, 2)))
    window = np.array(settings.CreateDataWindowNDCAttr(window).Get())  # as read: float32
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.Save()
    time = float(rng.uniform(0.0, 10.0))

    camera, w, h = resolve_view(wrt.load_usd(path, time=time))
    rays = [wp.empty(w * h, dtype=wp.vec3, device="cpu") for _ in range(2)]
    rays += [wp.empty(w * h, dtype=float, device="cpu") for _ in range(2)]
    wp.launch(generate_rays_kernel, w * h, inputs=[camera.to_struct(w, h), w, h, 0, 0], outputs=rays, device="cpu")
    o, d, t_min, t_max = (r.numpy().astype(np.float64) for r in rays)

    usd_camera = cam.GetCamera(Usd.TimeCode(time))
    frustum = usd_camera.frustum
    frustum.SetWindow(_conformed(frustum.GetWindow(), policy, pixel_aspect * width / height))
    clip_to_world = np.linalg.inv(np.linalg.inv(np.array(usd_camera.transform))
                                  @ np.array(frustum.ComputeProjectionMatrix()))
    # The pixels whose centres lie in the data window ((0, 0) the lower-left corner, minimum edges in; past 1, pixels
    # beyond the image), rows from the top; each one's NDC on the near (-1) and far (1) clipping planes.
    columns = [j for j in range(-width, 2 * width) if window[0] <= (j + 0.5) / width < window[2]]
    rows = [k for k in reversed(range(-height, 2 * height)) if window[1] <= (k + 0.5) / height < window[3]]
    assert (w, h) == (len(columns), len(rows))
    k, j = (a.ravel() for a in np.meshgrid(rows, columns, indexing="ij"))
    ndc = np.stack([2 * (j + 0.5) / width - 1, 2 * (k + 0.5) / height - 1], axis=1)
    ends = [np.concatenate([ndc, np.full((len(ndc), 1), z), np.ones((len(ndc), 1))], axis=1) @ clip_to_world
            for z in (-1.0, 1.0)]
    near, far = (e[:, :3] / e[:, 3:] for e in ends)
    np.testing.assert_allclose(o + t_min[:, None] * d, near, atol=1e-5 * np.abs(near).max())
    np.testing.assert_allclose(o + t_max[:, None] * d, far, atol=1e-5 * np.abs(far).max())


@pytest.mark.parametrize("seed", range(6))
def test_random_clipping_planes_and_image_shapes_keep_usds_frustum(tmp_path, seed):
    """What the test above leaves out: 1 to 3 random ``clippingPlanes`` (animated, so read between samples) and a
    near plane at 0, cameras turned by ``orient``, ``rotateZYX`` and matrix ops under a mirrored, sheared parent, and
    images 1 pixel wide or tall (or both), of any pixel aspect, with windows reaching a whole image past [0, 1]. Each
    pixel's ray runs over the part of USD's near-to-far segment (as above) that every plane keeps, found in float64
    in camera space; a pixel whose segment no plane leaves anything of gets an empty t range."""
    rng = np.random.default_rng(100 + seed)
    path = str(tmp_path / "cam.usda")
    stage = Usd.Stage.CreateNew(path)
    rig = UsdGeom.Xform.Define(stage, "/Rig")
    parent = np.diag([*(rng.uniform(0.3, 3.0, 3) * rng.choice([-1.0, 1.0], 3)), 1.0])
    parent[1, 0], parent[2, 1] = rng.uniform(-0.5, 0.5, 2)
    rig.AddTransformOp().Set(Gf.Matrix4d(*parent.ravel()))
    cam = UsdGeom.Camera.Define(stage, "/Rig/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(*rng.uniform(-5.0, 5.0, 3)))
    cam.AddOrientOp().Set(Gf.Quatf(*map(float, rng.normal(size=4) / 2.0)).GetNormalized())
    cam.AddRotateZYXOp().Set(Gf.Vec3f(*rng.uniform(-180.0, 180.0, 3)))
    cam.CreateProjectionAttr(["perspective", "orthographic"][seed % 2])
    cam.CreateHorizontalApertureAttr(float(rng.uniform(5.0, 60.0)))
    cam.CreateVerticalApertureAttr(float(rng.uniform(5.0, 60.0)))
    cam.CreateHorizontalApertureOffsetAttr(float(rng.normal(0.0, 5.0)))
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.0 if seed < 2 else 0.5, 40.0))
    planes = cam.CreateClippingPlanesAttr()
    count = int(rng.integers(1, 4))
    for time in (0.0, 1.0):
        planes.Set([Gf.Vec4f(*map(float, rng.normal(size=4))) for _ in range(count)], time)
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/Rig/Cam"])
    width, height = [(1, 9), (11, 1), (1, 1), (37, 2), (3, 5), (2, 41)][seed]
    settings.CreateResolutionAttr(Gf.Vec2i(width, height))
    pixel_aspect = float(np.exp(rng.uniform(-1.0, 1.0)))
    settings.CreatePixelAspectRatioAttr(pixel_aspect)
    policy = ["expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight",
              "adjustPixelAspectRatio"][seed % 5]
    settings.CreateAspectRatioConformPolicyAttr(policy)
    window = settings.CreateDataWindowNDCAttr(Gf.Vec4f(-1.0, -0.5, 2.0, 1.5)).Get()
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.Save()

    o, d, t_min, t_max = (a.astype(np.float64) for a in camera_rays(wrt.load_usd(path, time=0.5), t_range=True))
    usd_camera = cam.GetCamera(Usd.TimeCode(0.5))
    frustum = usd_camera.frustum
    frustum.SetWindow(_conformed(frustum.GetWindow(), policy, float(np.float32(pixel_aspect)) * width / height))
    frustum.SetNearFar(Gf.Range1d(0.5, 40.0))  # a projection matrix needs near > 0; the segment is extended below
    to_world = np.array(usd_camera.transform)
    clip_to_world = np.linalg.inv(np.linalg.inv(to_world) @ np.array(frustum.ComputeProjectionMatrix()))
    columns = [j for j in range(-width, 2 * width) if window[0] <= (j + 0.5) / width < window[2]]
    rows = [k for k in reversed(range(-height, 2 * height)) if window[1] <= (k + 0.5) / height < window[3]]
    assert len(o) == len(columns) * len(rows)
    k, j = (a.ravel() for a in np.meshgrid(rows, columns, indexing="ij"))
    ndc = np.stack([2 * (j + 0.5) / width - 1, 2 * (k + 0.5) / height - 1], axis=1)
    near, far = ((np.c_[ndc, np.full(len(ndc), z), np.ones(len(ndc))] @ clip_to_world) for z in (-1.0, 1.0))
    near, far = near[:, :3] / near[:, 3:], far[:, :3] / far[:, 3:]
    near += (usd_camera.clippingRange.min - 0.5) / 39.5 * (far - near)  # points of a pixel's ray: affine in depth
    # Each plane keeps a part of the segment near + s (far - near), s in [0, 1]: its value is affine in s.
    s0, s1 = np.zeros(len(o)), np.ones(len(o))
    for plane in np.array(usd_camera.clippingPlanes, np.float64):
        at0, at1 = (np.c_[p, np.ones(len(p))] @ np.linalg.inv(to_world) @ plane for p in (near, far))
        rate = at1 - at0
        cross = -at0 / np.where(rate == 0.0, 1.0, rate)
        s0 = np.where(rate > 0.0, np.maximum(s0, cross), s0)
        s1 = np.where(rate < 0.0, np.minimum(s1, cross), np.where((rate == 0.0) & (at0 < 0.0), -1.0, s1))
    clear = np.abs(s1 - s0) > 1e-4  # not a segment cut at one end by a plane within rounding of the other
    np.testing.assert_array_equal((t_max <= t_min)[clear], (s1 <= s0)[clear])
    kept = clear & (s1 > s0)
    assert kept.sum() > 0
    for s, t in ((s0, t_min), (s1, t_max)):
        want = near + s[:, None] * (far - near)
        np.testing.assert_allclose((o + t[:, None] * d)[kept], want[kept], atol=2e-5 * np.abs(want).max())


def test_clipping_range_limits_depth():
    cam = wrt.Camera(focal_length=50.0, horizontal_aperture=36.0, clipping_range=(0.1, 5.0))
    scene = quad_scene(-100.0, 100.0, -100.0, 100.0, -10.0)
    with pytest.warns(UserWarning, match=r"camera sees nothing: its clipping range \(0.1, 5\) holds no part of the "
                      r"scene, which lies from 10 to 10 along its view"):
        img = wrt.render(scene, camera=cam, width=8, height=8, device="cpu")
    assert (img.aovs["prim"] == -1).all()
    # A scene in the camera's own plane lies at depth 0, which the warning gave as "from -0 to -0".
    with pytest.warns(UserWarning, match=r"which lies from 0 to 0 along its view"):
        wrt.render(quad_scene(-100.0, 100.0, -100.0, 100.0, 0.0), camera=cam, width=8, height=8, device="cpu")


def test_bad_camera_values_raise():
    with pytest.raises(ValueError, match="fov_y_deg"):
        wrt.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y_deg=0.0)
    with pytest.raises(ValueError, match="parallel"):
        wrt.Camera.look_at((0, 0, 0), (0, 1, 0), up=(0, 1, 0))
    with pytest.raises(ValueError, match="projection"):
        wrt.Camera(projection="fisheye")
    with pytest.raises(ValueError, match="clipping"):
        wrt.Camera(clipping_range=(5.0, 1.0))


@pytest.mark.parametrize(
    "call, message",
    [
        # Each was reported as something else: "cannot normalise vector [...]" not naming eye or target, "up is
        # parallel" for a 2-vector eye, numpy's "could not convert string" or reshape error, Python's comparison
        # TypeError, "too many values to unpack", "Camera.__init__() got an unexpected keyword argument".
        (lambda: wrt.Camera.look_at((0, 0, 5), (0, 0, 5)), r"eye and target are the same point \[0.0, 0.0, 5.0\]"),
        (lambda: wrt.Camera.look_at((np.nan, 0, 5), (0, 0, 0)), r"look_at: eye must be 3 finite numbers"),
        (lambda: wrt.Camera.look_at((0, 5), (0, 0)), r"look_at: eye must be 3 finite numbers, got \(0, 5\)"),
        (lambda: wrt.Camera.look_at((0, 0, 5), "origin"), r"look_at: target must be 3 finite numbers, got 'origin'"),
        (lambda: wrt.Camera.look_at((0, 0, 5), (0, 0, 0), up=(0, 0, 0)), r"up \[0.0, 0.0, 0.0\] is zero or"),
        (lambda: wrt.Camera.look_at((0, 5, 0), (0, 0, 0)), r"parallel to the viewing direction \[0.0, -1.0, 0.0\]"),
        (lambda: wrt.Camera.look_at((0, 0, 5), (0, 0, 0), fov_y_deg="45"), r"fov_y_deg must lie in .*, got '45'"),
        (lambda: wrt.Camera.look_at((0, 0, 5), (0, 0, 0), fov=60), r"Camera.look_at\(\) got an unexpected keyword "
         r"argument 'fov' \(did you mean 'fov_y_deg'\?\)"),
        (lambda: wrt.Camera.orthographic((0, 0, 5), (0, 0, 0), width=2), r"Camera.orthographic\(\) got an unexpected"),
        # Keywords the helper sets itself raised Python's "Camera() got multiple values for keyword argument", and
        # look_at(projection="orthographic") made an orthographic camera that ignored fov_y_deg.
        (lambda: wrt.Camera.orthographic((0, 0, 5), (0, 0, 0), vertical_aperture=3),
         r"Camera.orthographic\(\) works vertical_aperture out from height"),
        (lambda: wrt.Camera.orthographic((0, 0, 5), (0, 0, 0), horizontal_aperture=3),
         r"Camera.orthographic\(\) works horizontal_aperture out from height"),
        (lambda: wrt.Camera.orthographic((0, 0, 5), (0, 0, 0), projection="perspective"),
         r"Camera.orthographic\(\) makes orthographic cameras only, not projection='perspective': use Camera.look_at"),
        # A projection spelt right was met with "(did you mean 'orthographic'?)", itself, before the way to make one.
        (lambda: wrt.Camera.look_at((0, 0, 5), (0, 0, 0), projection="orthographic"),
         r"Camera.look_at\(\) makes perspective cameras only, not projection='orthographic': use Camera.orthographic"),
        (lambda: wrt.Camera.look_at((0, 0, 5), (0, 0, 0), to_world=np.eye(4)),
         r"Camera.look_at\(\) works to_world out from eye, target and up"),
        (lambda: wrt.Camera(fit="expand"), r"not 'expand' \(did you mean 'expandAperture'\?\)"),
        (lambda: wrt.Camera(to_world=np.eye(3)), r"camera to_world must be a \(4, 4\) matrix, got shape \(3, 3\)"),
        (lambda: wrt.Camera(clipping_range=(0.1, 1, 2)), r"clipping range must be \(near, far\), got \(0.1, 1, 2\)"),
    ],
)
def test_camera_arguments_from_a_notebook_get_errors_naming_them(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


NAN, INF = float("nan"), float("inf")


def asked_for(path, camera: str):
    """Loads ``path``, whose camera ``camera`` wrt cannot use: it is skipped with one warning naming it, and
    :func:`resolve_camera` (a render's ``camera=``, ``--camera``) raises why, which it returns from."""
    with pytest.warns(UserWarning, match="cameras wrt cannot use were skipped") as caught:
        scene = wrt.load_usd(path)
    assert camera not in scene.cameras and camera in scene.skipped_cameras
    assert any(camera in str(w.message) for w in caught)
    return resolve_camera(scene, camera)


@pytest.mark.parametrize(
    "attr, value",
    [
        ("horizontalApertureOffset", "nan"),
        ("verticalApertureOffset", "-inf"),
        ("horizontalAperture", "inf"),
        ("verticalAperture", "inf"),
        ("focalLength", "inf"),
        ("focusDistance", "inf"),
        ("fStop", "nan"),
    ],
)
def test_usd_camera_film_values_must_be_finite(tmp_path, attr, value):
    """A NaN or inf film value made every camera ray NaN: an image of background only, without a word. The camera
    is skipped with a warning, and asking for it raises."""
    path = tmp_path / "cam.usda"
    path.write_text(f"""#usda 1.0
def Camera "C"
{{
    float {attr} = {value}
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
""")
    with pytest.raises(wrt.SceneError, match=rf"cam\.usda: /C: camera needs finite.*{value}"):  # /C named once
        asked_for(path, "/C")


def test_usd_camera_errors_show_values_as_authored(tmp_path):
    """An aperture of 20.955, read as float32, was shown as 20.954999923706055: six significant digits give back
    the authored text (what USD's own float32 read prints to that precision)."""
    path = tmp_path / "cam.usda"
    path.write_text('#usda 1.0\ndef Camera "C"\n{\n    float focalLength = 0\n'
                    '    float horizontalAperture = 20.955\n    float verticalAperture = 15.2908\n}\n')
    stage = Usd.Stage.Open(str(path))
    authored = float(stage.GetPrimAtPath("/C").GetAttribute("horizontalAperture").Get())
    assert repr(authored) == "20.954999923706055"  # the float32 noise the message printed
    with pytest.raises(wrt.SceneError) as raised:
        asked_for(path, "/C")
    assert str(raised.value).endswith("cam.usda: /C: camera needs finite positive focalLength and apertures, got "
                                      "focal_length=0, apertures=20.955x15.2908"), str(raised.value)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(horizontal_aperture_offset=NAN),
        dict(vertical_aperture_offset=INF),
        dict(focal_length=INF),
        dict(f_stop=2.0, focus_distance=INF),
        dict(f_stop="2"),
        dict(focal_length=10**400),  # an int past float64's range: math.isfinite's OverflowError escaped check()
        dict(vertical_aperture_offset=-(10**400)),
        dict(focal_length="50"),  # look_at's aperture from it raised "can't multiply sequence by non-int"
    ],
)
def test_python_camera_film_values_must_be_finite(kwargs):
    with pytest.raises(ValueError, match=r"^camera needs finite"):
        wrt.Camera.look_at((0, 0, 10), (0, 0, 0), **kwargs)
    cam = wrt.Camera.look_at((0, 0, 10), (0, 0, 0))  # set on a kept Renderer's camera: refused at its render
    renderer = wrt.Renderer(sensor_scene(), camera=cam, width=4, height=4, device="cpu")
    for name, value in kwargs.items():
        setattr(cam, name, value)
    with pytest.raises(ValueError, match=r"^camera needs finite"):
        renderer.render()


@pytest.mark.parametrize("kwargs, shown", [
    (dict(f_stop=-2.0, focus_distance=5.0), "f_stop=-2"),
    (dict(f_stop=2.0, focus_distance=-5.0), "focus_distance=-5"),
    (dict(f_stop=-2.0), "f_stop=-2"),  # focus_distance 0: was a pinhole all the same, unsaid
])
def test_python_camera_lens_values_must_not_be_negative(kwargs, shown):
    """USD's fStop "defaults to 0.0, which turns off focusing"; focusDistance is a distance: a negative one of
    either has no meaning, and such a camera rendered as a pinhole without a word. Refused as a negative aperture is."""
    with pytest.raises(ValueError, match=rf"^camera needs a non-negative fStop and focusDistance.*{shown}$"):
        wrt.Camera.look_at((0, 0, 10), (0, 0, 0), **kwargs)


@pytest.mark.parametrize("attr", ["fStop", "focusDistance"])
def test_usd_camera_of_negative_lens_value_is_skipped(tmp_path, attr):
    """A UsdGeom.Camera of fStop or focusDistance -2 rendered as a pinhole, unsaid: skipped with a warning naming it,
    as a camera of a negative aperture is, and asking for it raises naming the value."""
    other = "focusDistance" if attr == "fStop" else "fStop"
    path = tmp_path / "cam.usda"
    path.write_text(f'#usda 1.0\ndef Camera "C"\n{{\n    float {attr} = -2\n    float {other} = 4\n}}\n')
    with pytest.raises(wrt.SceneError, match=r"cam\.usda: /C: camera needs a non-negative fStop and focusDistance"):
        asked_for(path, "/C")


@pytest.mark.parametrize("height", [INF, NAN, "2", 10**400])
def test_orthographic_height_must_be_finite(height):
    with pytest.raises(ValueError, match="orthographic height must be a finite positive number"):
        wrt.Camera.orthographic((0, 0, 10), (0, 0, 0), height=height)


def test_python_camera_errors_have_no_double_space():
    with pytest.raises(ValueError, match=r"^camera transform is singular"):
        wrt.Camera(to_world=np.diag([0.0, 1.0, 1.0, 1.0])).to_struct(4, 4)


def test_python_camera_refuses_a_row_vector_matrix():
    """Only the top 3x4 of ``to_world`` is used: a ``Gf.Matrix4d`` passed without ``.T`` (its translation in the bottom
    row) put the camera at the origin, turned the other way, without a word."""
    m = Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(0, 1, 0), 30)) * Gf.Matrix4d().SetTranslate(Gf.Vec3d(1, 2, 10))
    with pytest.raises(ValueError, match=r"bottom row \[1.0, 2.0, 10.0, 1.0\].*transpose of a Gf.Matrix4d"):
        wrt.Camera(to_world=np.array(m))
    np.testing.assert_allclose(wrt.Camera(to_world=np.array(m).T).eye, m.ExtractTranslation())


def test_usd_camera_with_a_projective_transform_is_warned_about(tmp_path):
    """A camera whose world transform has a projective last column is read as its affine part with a warning naming
    it, as meshes and instances are; the column was dropped without a word."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "projective.usda"))
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTransformOp().Set(Gf.Matrix4d(1, 0, 0, 0.05, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 10, 1))
    stage.Save()
    with pytest.warns(UserWarning, match="projective.*/Cam"):
        scene = wrt.load_usd(tmp_path / "projective.usda")
    affine = Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 0, 10))
    np.testing.assert_array_equal(scene.cameras["/Cam"].to_world, np.array(affine).T)


def test_camera_animated_only_by_time_samples_uses_its_first_sample(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "anim_cam.usda"))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(10)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    op = cam.AddTranslateOp()
    op.Set(Gf.Vec3d(0.0, 2.0, 10.0), 1)  # no default value: only samples
    op.Set(Gf.Vec3d(5.0, 2.0, 10.0), 10)
    stage.Save()
    default = wrt.load_usd(tmp_path / "anim_cam.usda").cameras["/Cam"]
    np.testing.assert_allclose(default.eye, [0.0, 2.0, 10.0])  # the first frame, not the origin
    later = wrt.load_usd(tmp_path / "anim_cam.usda", time=10).cameras["/Cam"]
    np.testing.assert_allclose(later.eye, [5.0, 2.0, 10.0])


# A sheared, non-uniformly scaled and mirrored transform, for a camera's parent.
SHEARED_PARENT = Gf.Matrix4d(-1.0, 0.0, 0.0, 0.0, 0.5, 2.0, 0.0, 0.0, 0.0, 0.3, 3.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def posed_camera(stage, path: str, projection: str, parent: Gf.Matrix4d | None = None,
                 **attributes) -> UsdGeom.Camera:
    """A ``projection`` camera at ``path``, translated (1, 2, 3) and turned (10, 20, 30) degrees about X, Y and Z,
    authoring ``attributes`` (``HorizontalAperture=36.0``: ``CreateHorizontalApertureAttr(36.0)``); ``parent``: the
    transform of an Xform defined at its parent path."""
    if parent is not None:
        UsdGeom.Xform.Define(stage, path.rsplit("/", 1)[0]).AddTransformOp().Set(parent)
    cam = UsdGeom.Camera.Define(stage, path)
    cam.AddTranslateOp().Set(Gf.Vec3d(1.0, 2.0, 3.0))
    cam.AddRotateXYZOp().Set(Gf.Vec3f(10.0, 20.0, 30.0))
    cam.CreateProjectionAttr(projection)
    for name, value in attributes.items():
        getattr(cam, f"Create{name}Attr")(value)
    return cam


def _camera_under(tmp_path, parent: Gf.Matrix4d, projection: str) -> str:
    stage = Usd.Stage.CreateNew(str(tmp_path / f"cam_{projection}.usda"))
    posed_camera(stage, "/P/Cam", projection, parent, FocalLength=50.0, HorizontalAperture=36.0,
                 HorizontalApertureOffset=3.0, VerticalApertureOffset=-2.0)
    stage.Save()
    return str(tmp_path / f"cam_{projection}.usda")


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_camera_rays_are_camera_space_rays_moved_by_the_whole_transform(tmp_path, projection):
    """A camera under a sheared, non-uniformly scaled and mirrored parent: each pixel's ray is its camera-space ray
    moved by ComputeLocalToWorldTransform (as Hydra's view matrix maps it), not a ray of an undistorted frame."""
    path = _camera_under(tmp_path, SHEARED_PARENT, projection)
    stage = Usd.Stage.Open(path)
    m = UsdGeom.Camera(stage.GetPrimAtPath("/P/Cam")).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    width, height = 6, 4
    origins, directions = camera_rays(wrt.load_usd(path), "/P/Cam", width=width, height=height)
    expected_o, expected_d = [], []
    for i in range(height):
        for j in range(width):
            x = ((j + 0.5) / width - 0.5) * 36.0 + 3.0  # horizontal fit: film height 36 * 4 / 6
            y = (0.5 - (i + 0.5) / height) * 24.0 - 2.0
            if projection == "perspective":
                o, p = m.Transform(Gf.Vec3d(0, 0, 0)), m.Transform(Gf.Vec3d(x / 50.0, y / 50.0, -1.0))
            else:
                o = m.Transform(Gf.Vec3d(0.1 * x, 0.1 * y, 0.0))  # apertures in tenths of a unit
                p = m.Transform(Gf.Vec3d(0.1 * x, 0.1 * y, -1.0))
            expected_o.append(np.array(o))
            expected_d.append(np.array(p - o) / (p - o).GetLength())
    np.testing.assert_allclose(origins, expected_o, atol=1e-5)
    np.testing.assert_allclose(directions, expected_d, atol=1e-5)


SCALED_WORLD = """#usda 1.0
def Xform "World"
{{
    double3 xformOp:scale = ({s}, {s}, {s})
    uniform token[] xformOpOrder = ["xformOp:scale"]
    def Camera "Cam"
    {{
        token projection = "{projection}"
        float2 clippingRange = (1, 100)
        float focalLength = 50
        float horizontalAperture = {aperture}
        double3 xformOp:translate = (0, 0, 50)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def Mesh "Quad"
    {{
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)]
    }}
}}
"""


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_scaling_camera_and_scene_together_keeps_the_image(tmp_path, projection):
    """A units conversion on a common parent (scale 0.01 or 100) scales the clipping range and the orthographic
    view with the scene: the quad 50 units in front of a camera clipping at (1, 100) stays in view."""
    images = {}
    for s in (1.0, 0.01, 100.0):
        path = tmp_path / f"world_{s}.usda"
        path.write_text(SCALED_WORLD.format(s=s, projection=projection,
                                            aperture=40.0 if projection == "perspective" else 400.0))
        images[s] = wrt.render(wrt.load_usd(path), width=8, height=8, device="cpu", integrator="depth")
    hit = images[1.0].aovs["prim"] >= 0
    assert hit.sum() == 16  # the quad covers the middle half of the view on each axis
    for s in (0.01, 100.0):
        np.testing.assert_array_equal(images[s].aovs["prim"], images[1.0].aovs["prim"])
        np.testing.assert_allclose(images[s].aovs["depth"][hit], s * images[1.0].aovs["depth"][hit], rtol=1e-5)


def test_zero_scaled_camera_is_refused_only_when_used(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "zero.usda"))
    UsdGeom.Camera.Define(stage, "/Good").AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    UsdGeom.Camera.Define(stage, "/Flat").AddScaleOp().Set(Gf.Vec3f(0, 1, 1))
    triangle(stage, "/Tri")
    stage.Save()
    scene = wrt.load_usd(tmp_path / "zero.usda")
    assert wrt.render(scene, camera="/Good", width=4, height=4, device="cpu").rgb.shape == (4, 4, 3)
    with pytest.raises(ValueError, match="/Flat.*singular"):
        wrt.render(scene, camera="/Flat", width=4, height=4, device="cpu")


def test_a_zero_scaled_only_camera_is_skipped_with_a_warning_and_the_scene_framed(tmp_path):
    """The stage's first camera is the default view: a singular one stopped a plain render with a ValueError."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "flat.usda"))
    UsdGeom.Camera.Define(stage, "/Flat").AddScaleOp().Set(Gf.Vec3f(0, 0, 0))
    triangle(stage, "/Tri")
    stage.Save()
    with pytest.warns(UserWarning, match=r"cameras wrt cannot use were skipped.*singular.*/Flat"):
        scene = wrt.load_usd(tmp_path / "flat.usda")
    assert "/Flat" not in scene.cameras
    img = wrt.render(scene, width=8, height=8, device="cpu")
    assert img.aovs["coverage"].max() > 0  # framed by the default camera: the triangle is seen
    with pytest.raises(wrt.SceneError, match="/Flat.*singular"):
        wrt.render(scene, camera="/Flat", width=4, height=4, device="cpu")


CLIPPED_WORLD = """#usda 1.0
def Xform "World"
{{
    double3 xformOp:scale = ({s}, {s}, {s})
    uniform token[] xformOpOrder = ["xformOp:scale"]
    def Camera "Cam"
    {{
        float2 clippingRange = (1, 1000)
        float4[] clippingPlanes = {planes}
        float focalLength = 50
        float horizontalAperture = 40
        double3 xformOp:translate = (0, 0, 50)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def Mesh "Near"
    {{
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-100, -100, 10), (100, -100, 10), (100, 100, 10), (-100, 100, 10)]
    }}
    def Mesh "Far"
    {{
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-100, -100, 0), (100, -100, 0), (100, 100, 0), (-100, 100, 0)]
    }}
}}
"""


@pytest.mark.parametrize("scale", [1.0, 100.0])
def test_usd_clipping_planes_cut_geometry_away(tmp_path, scale):
    """Camera-space planes: x >= 0 keeps the right half of the view, z <= -45 cuts the near quad (camera depth 40)
    so the far one (depth 50) shows through; both scale with a scaled parent, as the clipping range does."""
    images = {}
    for name, planes in {"none": "[]", "cut": "[(1, 0, 0, 0), (0, 0, -1, -45)]"}.items():
        path = tmp_path / f"clipped_{name}_{scale}.usda"
        path.write_text(CLIPPED_WORLD.format(s=scale, planes=planes))
        images[name] = wrt.render(wrt.load_usd(path), width=8, height=8, device="cpu", integrator="depth")
    full, cut = images["none"].aovs, images["cut"].aovs
    assert (full["prim"] >= 0).all() and (full["depth"] < 45 * scale).all()  # the near quad, unclipped
    assert (cut["prim"][:, :4] == -1).all()  # left of the camera's x = 0 plane
    assert (cut["prim"][:, 4:] >= 0).all()
    np.testing.assert_allclose(cut["depth"][:, 4:].min(), 50 * scale, rtol=0.02)  # the far quad, near the centre


def test_camera_rays_give_the_t_range_the_render_clips_to(tmp_path):
    """The near quad (depth 40) lies before the clipping range's near end (45) and the x >= 0 plane cuts the left
    half: tracing camera_rays with their t range finds what the render's prim and depth AOVs show, the far quad on
    the right only; the bare rays still hit the near quad everywhere."""
    path = tmp_path / "clipped_range.usda"
    path.write_text(CLIPPED_WORLD.format(s=1.0, planes="[(1, 0, 0, 0)]").replace("(1, 1000)", "(45, 1000)"))
    scene = wrt.load_usd(path)
    aovs = wrt.render(scene, width=8, height=6, device="cpu", integrator="depth").aovs
    origins, directions, t_mins, t_maxs = camera_rays(scene, width=8, height=6, t_range=True)
    hits = wrt.trace(scene, origins, directions, t_min=t_mins, t_max=t_maxs)
    np.testing.assert_array_equal(hits.prim, aovs["prim"].ravel())
    np.testing.assert_allclose(hits.t, aovs["depth"].ravel(), rtol=1e-6)
    assert (aovs["prim"][:, :4] == -1).all() and (aovs["prim"][:, 4:] >= 0).all()
    far = np.linalg.norm(directions * 50.0 / np.abs(directions[:, 2:]), axis=1).reshape(6, 8)  # z = 0 from z = 50
    np.testing.assert_allclose(aovs["depth"][:, 4:], far[:, 4:], rtol=1e-5)
    bare = wrt.trace(scene, *camera_rays(scene, width=8, height=6))
    np.testing.assert_allclose(bare.t, 40.0 / 50.0 * far.ravel(), rtol=1e-5)  # the near quad, which the render clips


def test_clipping_planes_keep_their_digits_far_from_the_world_origin(tmp_path):
    """A camera a million units from the origin with a tilted camera-space clipping plane: the plane was moved to
    world space, where its offset d is about 1e6 and float32 kept no digits below 0.06, so the clip lay 0.03 off
    where the clipping range (camera space, about the eye) keeps every digit. The oracle: each pixel centre's ray of
    pxr's frustum met in float64 with the plane moved to world space by the camera's transform; the distance from
    the ray's start to it is the ray's t_min."""
    from pxr import Gf, Usd, UsdGeom

    path = str(tmp_path / "far_clip.usda")
    stage = Usd.Stage.CreateNew(path)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(1.0e6 + 0.3, -2.0e6 + 0.1, 5.0))
    cam.AddRotateXYZOp().Set(Gf.Vec3f(-10.0, 15.0, 5.0))
    cam.CreateClippingPlanesAttr([Gf.Vec4f(0.4, -0.3, -1.0, -2.0)])  # kept where 0.4 x - 0.3 y - z >= 2
    stage.Save()
    width, height = 12, 10  # narrower than the apertures: their height grows
    scene = wrt.load_usd(path)
    _, _, t_mins, _ = camera_rays(scene, "/Cam", width, height, t_range=True)
    usd_camera = cam.GetCamera(Usd.TimeCode.Default())
    frustum = usd_camera.frustum
    window = frustum.GetWindow()  # expanded to the image's aspect, as a stage camera's film is without settings
    half = window.GetSize()[0] / 2 * height / width
    frustum.SetWindow(Gf.Range2d(Gf.Vec2d(window.GetMin()[0], -half), Gf.Vec2d(window.GetMax()[0], half)))
    to_world = np.array(usd_camera.transform).T  # column vectors
    plane = np.array(usd_camera.clippingPlanes[0], np.float64) @ np.linalg.inv(to_world)
    eye = to_world[:3, 3]
    want = np.zeros(width * height)
    for i in range(height):
        for j in range(width):
            ray = frustum.ComputePickRay(Gf.Vec2d(2 * (j + 0.5) / width - 1, 1 - 2 * (i + 0.5) / height))
            d = np.array(ray.direction) / np.linalg.norm(ray.direction)
            want[i * width + j] = -(plane[:3] @ eye + plane[3]) / (plane[:3] @ d)  # from the eye, the rays' start
    assert want.min() > 1.0
    np.testing.assert_allclose(t_mins, want, atol=1e-4)


def test_clipping_planes_are_checked():
    with pytest.raises(ValueError, match="at most 8"):
        wrt.Camera(clipping_planes=np.tile([1.0, 0.0, 0.0, 0.0], (9, 1)))
    with pytest.raises(ValueError, match="non-zero normal"):
        wrt.Camera(clipping_planes=[(0.0, 0.0, 0.0, 1.0)])
    with pytest.raises(ValueError, match="finite"):
        wrt.Camera(clipping_planes=[(np.nan, 0.0, 1.0, 0.0)])


def test_default_time_reads_defaults_over_samples_for_transforms_and_cameras_too(tmp_path):
    """With ``time=None`` an attribute that authors both a default and time samples gives its default, as USD reads
    it at the default time; points did, but transforms and camera attributes gave their first sample."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "mixed.usda"))
    rig = UsdGeom.Xform.Define(stage, "/Rig")
    rig_op = rig.AddTranslateOp()
    rig_op.Set(Gf.Vec3d(0.0, 0.0, 10.0))  # default
    rig_op.Set(Gf.Vec3d(0.0, 0.0, 20.0), 1)
    cam = UsdGeom.Camera.Define(stage, "/Rig/Cam")
    cam.AddRotateYOp().Set(30.0, 1)  # only a sample: read at its first sample
    cam.CreateFocalLengthAttr(50.0)
    cam.GetFocalLengthAttr().Set(25.0, 1)
    stage.Save()
    reference = Usd.Stage.Open(str(tmp_path / "mixed.usda"))
    rig_default = np.array(UsdGeom.Xform.Get(reference, "/Rig").GetLocalTransformation(Usd.TimeCode.Default()))
    spin = np.array(UsdGeom.Xform.Get(reference, "/Rig/Cam").GetLocalTransformation(1.0))
    default = wrt.load_usd(tmp_path / "mixed.usda").cameras["/Rig/Cam"]
    assert default.focal_length == 50.0
    np.testing.assert_allclose(default.to_world, (spin @ rig_default).T, atol=1e-12)
    np.testing.assert_allclose(default.eye, [0.0, 0.0, 10.0])
    at_one = wrt.load_usd(tmp_path / "mixed.usda", time=1).cameras["/Rig/Cam"]
    assert at_one.focal_length == 25.0
    np.testing.assert_allclose(at_one.eye, [0.0, 0.0, 20.0])


def test_unknown_camera_projection_is_perspective_with_a_warning(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "fisheye.usda"))
    UsdGeom.Camera.Define(stage, "/Cam").CreateProjectionAttr("fisheye")
    stage.Save()
    with pytest.warns(UserWarning, match=r"unknown projection.*fisheye"):
        cam = wrt.load_usd(tmp_path / "fisheye.usda").cameras["/Cam"]
    assert cam.projection == "perspective"


def _exposed_cameras_stage(tmp_path, f_stop: float = 1.4) -> str:
    """A lit quad seen by two cameras in the same place: /Plain with USD's fallbacks and /Exposed with every exposure
    attribute authored."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "exposure.usda"))
    for name in ("Plain", "Exposed"):
        cam = UsdGeom.Camera.Define(stage, f"/{name}")
        cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    exposed = UsdGeom.Camera.Get(stage, "/Exposed")
    exposed.CreateExposureAttr(1.5)
    exposed.CreateExposureTimeAttr(0.5)
    exposed.CreateExposureIsoAttr(400.0)
    exposed.CreateExposureFStopAttr(f_stop)
    exposed.CreateExposureResponsivityAttr(0.8)
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    mesh.CreatePointsAttr([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    stage.Save()
    return str(tmp_path / "exposure.usda")


def test_camera_exposure_attributes_scale_the_radiance_images(tmp_path):
    """The camera's exposure attributes were ignored without a word. They scale path and whitted images by USD's own
    ComputeLinearExposureScale, for one camera and in a batch alike; ao and the quick looks are not radiance."""
    path = _exposed_cameras_stage(tmp_path)
    scene = wrt.load_usd(path)
    stage = Usd.Stage.Open(path)
    expected = UsdGeom.Camera.Get(stage, "/Exposed").ComputeLinearExposureScale()
    assert scene.cameras["/Exposed"].exposure_scale == pytest.approx(expected, rel=1e-6)
    assert expected != pytest.approx(1.0) and scene.cameras["/Plain"].exposure_scale == 1.0

    def image(camera, integrator="path"):
        return wrt.render(scene, camera=camera, width=12, height=8, spp=2, integrator=integrator, device="cpu").rgb

    plain = image("/Plain")
    assert plain.max() > 0
    np.testing.assert_allclose(image("/Exposed"), plain * expected, rtol=1e-5)
    np.testing.assert_allclose(image("/Exposed", "whitted"), image("/Plain", "whitted") * expected, rtol=1e-5)
    for integrator in ("ao", "normals"):
        np.testing.assert_array_equal(image("/Exposed", integrator), image("/Plain", integrator))
    cameras = [scene.cameras["/Plain"], scene.cameras["/Exposed"]]
    batch = wrt.render_batch(scene, cameras, 12, 8, spp=2, integrator="path", device="cpu")
    rgb = batch.rgb.numpy()
    np.testing.assert_array_equal(rgb[0], plain)
    np.testing.assert_allclose(rgb[1], plain * expected, rtol=1e-5)


def test_camera_exposure_that_is_not_finite_names_the_camera(tmp_path):
    with pytest.raises(wrt.SceneError, match=r"exposure\.usda: /Exposed: camera needs .*exposure scale.* inf"):
        asked_for(_exposed_cameras_stage(tmp_path, f_stop=0.0), "/Exposed")
    # Finite in float64 but inf in the float32 image: every lit pixel was inf.
    with pytest.raises(ValueError, match=r"exposure scale of at most 3\.403e\+38 .* got 1\.6\d*e\+60"):
        wrt.Camera.look_at((0, 0, 4), (0, 0, 0), exposure_scale=2.0**200)


BAD_CAMERAS = {  # camera -> what it authors that wrt.Camera cannot take, and the words of the reason
    "/ZeroFocal": ("float focalLength = 0", "finite positive focalLength and apertures, got focal_length=0,"),
    "/NegativeAperture": ("float horizontalAperture = -2", "apertures=-2x"),
    "/Inverted": ("float2 clippingRange = (5, 1)", "clipping range must satisfy 0 <= near < far, got (5.0, 1.0)"),
    "/NotFinite": ('double3 xformOp:translate = (nan, 0, 0)\n    uniform token[] xformOpOrder = ["xformOp:translate"]',
                   "transform is not finite"),
}


def test_a_camera_wrt_cannot_use_is_skipped_with_a_warning_unless_it_is_the_one_asked_for(tmp_path):
    """Cameras of a zero focal length, a negative aperture, an inverted clipping range and
    a transform that is not finite stopped the load of the stage, whichever camera was to render it. Now each is
    skipped with one warning naming the file, the camera and why; the stage's first usable camera is the default; a
    render asked for one (camera=, --camera: resolve_camera) or whose render settings name it raises that reason,
    naming the file and the camera (and the settings); camera= still overrides the settings' camera."""
    body = "".join(f'def Camera "{path[1:]}"\n{{\n    {authored}\n}}\n' for path, (authored, _) in BAD_CAMERAS.items())
    path = tmp_path / "cams.usda"
    path.write_text('#usda 1.0\n(\n    renderSettingsPrimPath = "/Render/Settings"\n)\n' + body + """
def Camera "Good"
{
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Scope "Render"
{
    def RenderSettings "Settings"
    {
        rel camera = </ZeroFocal>
        uniform int2 resolution = (8, 6)
    }
}
def Cube "Box"
{
}
""")
    assert UsdRender.Settings.Get(Usd.Stage.Open(str(path)), "/Render/Settings").GetCameraRel().GetTargets()
    with pytest.warns(UserWarning) as caught:
        scene = wrt.load_usd(path)
    (warned,) = [str(w.message) for w in caught if "cameras wrt cannot use" in str(w.message)]
    assert warned.startswith(f"{path}: ") and f"{len(BAD_CAMERAS)} prim(s)" in warned, warned
    assert all(reason in warned for _, reason in BAD_CAMERAS.values()), warned
    assert list(scene.cameras) == ["/Good"] and sorted(scene.skipped_cameras) == sorted(BAD_CAMERAS)
    for camera, (_, reason) in BAD_CAMERAS.items():
        with pytest.raises(wrt.SceneError) as raised:
            resolve_camera(scene, camera)
        assert str(raised.value).startswith(f"{path}: {camera}: ") and reason in str(raised.value), str(raised.value)
    # The render settings' camera, unless camera= overrides it; without settings, the first usable camera.
    with pytest.raises(wrt.SceneError, match=r"cams\.usda: /Render/Settings renders camera /ZeroFocal, which wrt "
                                             r"cannot use: camera needs finite positive focalLength"):
        resolve_view(scene)
    assert resolve_view(scene, "/Good")[0].path == "/Good"  # (a copy framed by the settings)
    assert resolve_view(scene, "/Good")[1:] == (8, 6)  # the settings' resolution still
    scene.render_settings = None
    assert resolve_view(scene)[0] is scene.cameras["/Good"]


MISTYPED_CAMERAS = {  # camera -> an attribute authored with another type than the schema's
    "/Range": "float clippingRange = 3",
    "/Range3": "float3 clippingRange = (1, 2, 3)",
    "/Planes": "float[] clippingPlanes = [1, 2]",
    "/Focal": "float2 focalLength = (1, 2)",
}


def test_a_camera_attribute_of_another_type_is_named_and_a_type_error_is_not_a_skipped_camera(tmp_path, monkeypatch):
    """A camera attribute authored with another type (a float clippingRange, a float[] clippingPlanes) raised
    "cannot unpack non-iterable float object" and then skipped the camera; ``GetCamera`` reads the schema's
    fallback there, and so does wrt, naming the attribute in a warning. The TypeError those raised was caught
    broadly, so a TypeError from wrt itself (here a Camera that raises one) became "camera skipped" too: it now
    propagates."""
    body = "".join(f'def Camera "{p[1:]}"\n{{\n    {authored}\n}}\n' for p, authored in MISTYPED_CAMERAS.items())
    path = tmp_path / "mistyped.usda"
    path.write_text("#usda 1.0\n" + body + 'def Camera "Good"\n{\n}\n')
    with pytest.warns(UserWarning, match="camera values authored with another type than the schema's") as caught:
        scene = wrt.load_usd(path)
    assert list(scene.cameras) == [*MISTYPED_CAMERAS, "/Good"]
    message = next(str(w.message) for w in caught if "another type" in str(w.message))
    assert all(authored in message for authored in MISTYPED_CAMERAS.values()), message
    stage = Usd.Stage.Open(str(path))
    for name, loaded in scene.cameras.items():
        gf = UsdGeom.Camera(stage.GetPrimAtPath(name)).GetCamera(Usd.TimeCode.Default())
        assert loaded.focal_length == gf.focalLength and len(loaded.clipping_planes) == len(gf.clippingPlanes)
        np.testing.assert_allclose(loaded.clipping_range, (gf.clippingRange.min, gf.clippingRange.max), rtol=1e-6)

    def broken(**kwargs):
        raise TypeError("a bug in wrt")

    monkeypatch.setattr(wrt.usd_cameras, "Camera", broken)
    with pytest.raises(wrt.SceneError, match=r"/Range: cannot read this prim \(a bug in wrt\)"):  # as any prim's bug
        wrt.load_usd(path)


CAMERA_ATTRIBUTES = ("projection", "focalLength", "horizontalAperture", "verticalAperture", "horizontalApertureOffset",
                     "verticalApertureOffset", "clippingRange", "clippingPlanes", "fStop", "focusDistance", "exposure",
                     "exposure:iso", "exposure:time", "exposure:fStop", "exposure:responsivity")


@pytest.mark.parametrize("blocked", [(name,) for name in CAMERA_ATTRIBUTES] + [CAMERA_ATTRIBUTES])
def test_a_blocked_camera_value_is_the_schema_fallback(tmp_path, blocked):
    """A camera value blocked (``= None``) over an authored one reads as the schema's fallback, as USD's own
    ``GetCamera`` reads it: a blocked projection over ``orthographic`` was the token 'None', perspective with a
    warning, and any other blocked value (a clipping range, a focal length) skipped the camera with a warning."""
    base = tmp_path / "base.usda"
    stage = Usd.Stage.CreateNew(str(base))
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    authored = {"projection": "orthographic", "focalLength": 35.0, "horizontalAperture": 30.0,
                "verticalAperture": 20.0, "horizontalApertureOffset": 1.0, "verticalApertureOffset": -1.0,
                "clippingRange": Gf.Vec2f(0.5, 50.0), "clippingPlanes": [Gf.Vec4f(0, 0, 1, 3)], "fStop": 2.8,
                "focusDistance": 10.0, "exposure": 1.0, "exposure:iso": 200.0, "exposure:time": 0.5,
                "exposure:fStop": 2.0, "exposure:responsivity": 2.0}
    for name, value in authored.items():
        cam.GetPrim().GetAttribute(name).Set(value)
    stage.Save()
    path = tmp_path / "shot.usda"
    shot = Usd.Stage.CreateNew(str(path))
    shot.GetRootLayer().subLayerPaths.append(str(base))
    for name in blocked:
        shot.GetPrimAtPath("/Cam").GetAttribute(name).Block()
    shot.Save()
    usd_cam = UsdGeom.Camera(shot.GetPrimAtPath("/Cam"))
    fallback = usd_cam.GetPrim().GetPrimDefinition().GetAttributeFallbackValue
    assert all(usd_cam.GetPrim().GetAttribute(name).Get() is None for name in blocked)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # neither skipped nor an unknown projection
        scene = wrt.load_usd(path)
    loaded = scene.cameras["/Cam"]
    value = {name: fallback(name) if name in blocked else usd_cam.GetPrim().GetAttribute(name).Get()
             for name in CAMERA_ATTRIBUTES}
    gf = usd_cam.GetCamera(Usd.TimeCode.Default())  # USD's own reading of a blocked value: the fallback too
    assert loaded.projection == ("orthographic" if gf.projection == Gf.Camera.Orthographic else "perspective")
    assert loaded.projection == str(value["projection"])
    np.testing.assert_allclose(
        [loaded.focal_length, loaded.horizontal_aperture, loaded.vertical_aperture, loaded.horizontal_aperture_offset,
         loaded.vertical_aperture_offset, loaded.f_stop, loaded.focus_distance],
        [gf.focalLength, gf.horizontalAperture, gf.verticalAperture, gf.horizontalApertureOffset,
         gf.verticalApertureOffset, gf.fStop, gf.focusDistance], rtol=1e-6)
    np.testing.assert_allclose(loaded.clipping_range, (gf.clippingRange.min, gf.clippingRange.max), rtol=1e-6)
    assert len(loaded.clipping_planes) == len(gf.clippingPlanes)
    np.testing.assert_allclose(loaded.exposure_scale, usd_cam.ComputeLinearExposureScale(), rtol=1e-6)


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(clipping_range=("a", "b")), ValueError, r"^camera clipping range must satisfy 0 <= near < far, got \('a'"),
    (dict(clipping_range=[0.1, [1, 2]]), ValueError, r"^camera clipping range must be \(near, far\), got \[0.1, \[1"),
    (dict(to_world="x"), ValueError, r"^camera to_world must be a \(4, 4\) matrix of numbers, got 'x'"),
    (dict(to_world=[[1, 0], [0]]), ValueError, r"^camera to_world must be a \(4, 4\) matrix of numbers"),
    (dict(clipping_planes="x"), ValueError, r"^camera clipping planes must be finite \(a, b, c, d\) rows .*got 'x'"),
    (dict(path=5), TypeError, r"^wrt.Camera: path must be a str"),
])
def test_python_camera_fields_of_another_type_are_refused_naming_the_field(kwargs, error, words):
    """A clipping range of strings failed with Python's "'<=' not supported between instances", a transform or
    clipping planes of text or a ragged list with numpy's conversion message, naming no camera; a path that is no
    string was kept and shown in messages. Refused as the other camera fields are, when made and when assigned before
    a render."""
    with pytest.raises(error, match=words):
        wrt.Camera(**kwargs)
    cam = wrt.Camera.look_at((0, 0, 10), (0, 0, 0))
    name, value = next(iter(kwargs.items()))
    setattr(cam, name, value)
    with pytest.raises(error, match=words):
        wrt.render(wrt.Scene.from_triangles(np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.int32([[0, 1, 2]])),
                   camera=cam, width=2, height=2)


def test_python_camera_takes_an_infinite_far_clip():
    """``clipping_range=(near, inf)`` is no far clip: the triangle 1e6 away is still drawn."""
    far = 1.0e6
    scene = wrt.Scene.from_triangles(np.float32([[-far, -far, -far], [far, -far, -far], [0, far, -far]]),
                                     np.int32([[0, 1, 2]]))
    cam = wrt.Camera.look_at((0, 0, 0), (0, 0, -1), clipping_range=(0.1, INF))
    image = wrt.render(scene, camera=cam, width=2, height=2, integrator="albedo")
    assert image.aovs["coverage"].min() == 1.0


@pytest.mark.parametrize("clipping_range, words", [((5.0, 1.0), "must satisfy 0 <= near < far"),
                                                   ((1.0, 2.0, 3.0), r"must be \(near, far\)")])
def test_a_bad_clipping_range_names_the_camera(clipping_range, words):
    """A camera's other bad fields are named with its path ('camera /Cam transform is not finite'); its clipping
    range said only 'camera clipping range ...', naming no camera among the scene's, at the render after the
    assignment too."""
    with pytest.raises(ValueError, match=rf"^camera /Cam clipping range {words}"):
        wrt.Camera(path="/Cam", clipping_range=clipping_range)
    cam = wrt.Camera.look_at((0, 0, 10), (0, 0, 0), path="/Cam")
    cam.clipping_range = clipping_range
    with pytest.raises(ValueError, match=rf"^camera /Cam clipping range {words}"):
        wrt.render(wrt.Scene.from_triangles(np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.int32([[0, 1, 2]])),
                   camera=cam, width=2, height=2)


@pytest.mark.parametrize("meters_per_unit", [1.0, 0.01])
def test_default_camera_of_a_z_up_stage_is_the_y_up_one_turned_with_the_robot(tmp_path, meters_per_unit):
    """A stage without a camera is framed along its upAxis: the same robot (a tall box and an arm along +X) written
    Z-up, its points turned a quarter about +X (y, z -> -z, y), gets the Y-up stage's camera rays turned the same way,
    upright (image rows go down the up axis, columns along +X), whatever metersPerUnit says."""
    turn = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # +Y to +Z
    body = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (0.0, 2.0) for z in (-0.1, 0.1)])
    arm = np.array([[0.0, 1.8, 0.0], [1.0, 1.8, 0.0], [1.0, 1.9, 0.1]])
    rays = {}
    for axis, points in (("Y", np.vstack([body, arm])), ("Z", np.vstack([body, arm]) @ turn.T)):
        stage = Usd.Stage.CreateNew(str(tmp_path / f"robot_{axis}.usda"))
        UsdGeom.SetStageUpAxis(stage, axis)
        UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
        mesh = UsdGeom.Mesh.Define(stage, "/Robot/link")
        mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
        mesh.CreateFaceVertexCountsAttr([3, 3])
        mesh.CreateFaceVertexIndicesAttr([0, 3, 5, 8, 9, 10])
        stage.Save()
        rays[axis] = camera_rays(wrt.load_usd(tmp_path / f"robot_{axis}.usda"), None, 16, 12)
    np.testing.assert_allclose(rays["Z"][0], rays["Y"][0] @ turn.T, atol=1e-5)
    np.testing.assert_allclose(rays["Z"][1], rays["Y"][1] @ turn.T, atol=1e-6)
    d = rays["Z"][1].reshape(12, 16, 3)
    assert (np.diff(d[:, 8, 2]) < 0).all()  # down the image is down +Z
    assert (np.diff(d[6, :, 0]) > 0).all()  # right in the image is along +X: not mirrored


OCTAHEDRON = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
OCTAHEDRON_FACES = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]


@pytest.mark.parametrize("up_axis", ["Y", "Z"])
@pytest.mark.parametrize("size", [(40, 30), (30, 40), (12, 120), (120, 12)])
def test_the_camera_framing_a_stage_without_cameras_sees_all_of_it_at_any_aspect(size, up_axis):
    """The camera wrt makes for a scene without cameras keeps its whole square field of view in the image, as
    USD's expandAperture does: it kept the vertical one only, so a portrait image cut the scene at its sides (12x120:
    the octahedron ran off both sides, 100 of 264 border pixels hit). Oracle: a convex solid inside the view leaves
    the image's border pixels empty, and is crossed by the middle row and column; a width alone still gives 4:3."""
    scene = wrt.Scene.from_triangles(OCTAHEDRON, OCTAHEDRON_FACES)
    scene.up_axis = up_axis
    width, height = size
    prim = wrt.render(scene, width=width, height=height, integrator="albedo").aovs["prim"]
    border = np.concatenate([prim[0], prim[-1], prim[:, 0], prim[:, -1]])
    assert (border < 0).all(), f"{np.count_nonzero(border >= 0)} of {border.size} border pixels hit"
    assert (prim[height // 2] >= 0).any() and (prim[:, width // 2] >= 0).any()
    assert resolve_view(scene, None, width, None)[1:] == (width, round(width * 3 / 4))


def edge_renderer(rows: int) -> tuple[wrt.Renderer, np.ndarray]:
    """A renderer of an orthographic view, 4 pixels of 1 unit across and ``rows`` down, of a glowing half-plane
    ``x < -0.7`` (radiance 1, reflecting nothing) over black, and each column's exact share of the half-plane's
    area: its pixels' coverage, 1, 0.3, 0 and 0 (the second column's centre, x = -0.5, lies outside it)."""
    glow = wrt.Material(diffuse_color=0.0, use_specular_workflow=True, specular_color=0.0, specular_edge=0.0,
                        emissive_color=1.0)
    half_plane = wrt.Mesh("/half", [[-50, -1000, 0], [-0.7, -1000, 0], [-0.7, 1000, 0], [-50, 1000, 0]],
                          [[0, 1, 2], [0, 2, 3]], [0, 0], material_ids=[0, 0])
    scene = wrt.Scene(meshes=[half_plane], materials=[glow])
    cam = wrt.Camera.orthographic(eye=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), height=float(rows))
    left = np.arange(4) - 2.0  # the columns' left edges
    return (wrt.Renderer(scene, camera=cam, width=4, height=rows, device="cpu", integrator="whitted"),
            np.clip(-0.7 - left, 0.0, 1.0))


@pytest.mark.parametrize("spp", [2, 8])
def test_every_sample_of_several_spreads_over_the_pixel(spp):
    """Anti-aliasing of a straight edge: with several samples per pixel each pixel shows its exact area coverage
    (within 3 standard deviations of the mean of its column's samples). Sample 0 went through the pixel centre,
    a point sample weighing 1 / spp: the edge column, 0.3 covered with its centre outside, showed 0.15 at 2 spp and
    0.27 at 8. One sample per pixel still goes through the centre (0 there), and so do the AOVs' rays."""
    rows = 256
    renderer, exact = edge_renderer(rows)
    one = renderer.render(spp=1, seed=2)
    np.testing.assert_array_equal(one.rgb[..., 0].mean(axis=0), (exact >= 0.5).astype(np.float32))
    img = renderer.render(spp=spp, seed=2)
    sigma = np.sqrt(exact * (1.0 - exact) / (rows * spp))
    np.testing.assert_allclose(img.rgb[..., 0].mean(axis=0), exact, atol=3.0 * sigma.max())
    np.testing.assert_allclose(img.aovs["coverage"].mean(axis=0), exact, atol=3.0 * sigma.max())
    np.testing.assert_array_equal(img.aovs["prim"], one.aovs["prim"])  # through the pixel centres
    np.testing.assert_array_equal(img.aovs["depth"], one.aovs["depth"])
    renderer.render(spp=1, seed=2)  # a progressive render from one sample is that of all of them at once
    np.testing.assert_array_equal(renderer.render(spp=spp - 1, seed=2, resume=True).rgb, img.rgb)


@pytest.mark.parametrize("far, integrator", [(10.0, "normals"), (10.0, "path"), (-1.0, "path"), (-1.0, "whitted")])
def test_orthographic_camera_clipping_behind_its_plane_sees_past_a_culled_back_face(far, integrator):
    """An orthographic camera at z = 0 looking down -Z with its near plane 10 behind it (clipping range (-10, far)):
    a single-sided quad at z = 5, behind the camera's plane and facing -Z, shows the rays (from z = 10) its back
    face, which camera rays cull; the double-sided quad at z = 2, also behind the plane, lies beyond it along the
    rays and fills every pixel. The culled hit lies at t = -5: the re-trace started from t plus a step of
    ``t * 1e-6``, negative there, or 2^-125, which is no step at that t, found the culled face again at every pass,
    and the camera drew it instead of the quad beyond it. With ``far`` -1 the clipping range lies entirely behind
    the camera's plane and every ray's range ends at a negative ``t``: the culled face was re-traced, but the
    re-trace was marked by ``t_max > 0`` and its hit never replaced the culled one (the back face, prim 0 or 1)."""
    back = [[-2, -2, 5], [-2, 2, 5], [2, 2, 5], [2, -2, 5]]  # clockwise seen from +Z, where the rays come from
    seen = [[-2, -2, 2], [2, -2, 2], [2, 2, 2], [-2, 2, 2]]
    scene = wrt.Scene(meshes=[
        wrt.Mesh("/back", np.array(back, np.float32), [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32),
                 double_sided=False),
        wrt.Mesh("/seen", np.array(seen, np.float32), [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32)),
    ])
    camera = wrt.Camera.orthographic(eye=(0, 0, 0), target=(0, 0, -1), height=2.0, clipping_range=(-10.0, far))
    img = wrt.render(scene, camera=camera, width=6, height=4, device="cpu", integrator=integrator, spp=1)
    np.testing.assert_array_equal(img.aovs["prim"] // 2, 1)  # triangles 2 and 3: the quad beyond the culled face
    np.testing.assert_allclose(img.aovs["depth"], -2.0)  # its plane z = 2 lies 2 behind the camera's plane


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_orthographic_camera_of_negative_near_sees_a_light_behind_its_plane(integrator):
    """An orthographic camera at z = 0 looking down -Z, its near plane 10 behind it (clipping range (-10, 10)), and a
    RectLight at z = 5, behind the camera's plane, turned to emit along +Z, towards where the rays come from: it fills
    the view, and every pixel shows its radiance, 3 (UsdLux: intensity times colour, not normalized), as a quad there
    is seen. Camera rays start at t = -10; the lights were intersected from the ray's origin on the camera's plane,
    ahead of it only, and the light was not seen (black)."""
    facing_up = np.diag([1.0, -1.0, -1.0, 1.0])  # turned half round X: local -Z, its emitting side, along world +Z
    facing_up[2, 3] = 5.0
    light = wrt.RectLight(to_world=facing_up, width=4.0, height=4.0, color=np.full(3, 3.0, np.float32))
    far = [[-9, -9, -5], [9, -9, -5], [9, 9, -5], [-9, 9, -5]]
    scene = wrt.Scene(meshes=[wrt.Mesh("/far", np.array(far, np.float32), [[0, 1, 2], [0, 2, 3]],
                                       np.zeros(2, np.int32))], lights=[light])
    camera = wrt.Camera.orthographic(eye=(0, 0, 0), target=(0, 0, -1), height=2.0, clipping_range=(-10.0, 10.0))
    img = wrt.render(scene, camera=camera, width=6, height=4, device="cpu", integrator=integrator, spp=1)
    np.testing.assert_allclose(img.rgb, 3.0, rtol=1e-6)


def _usd_camera_stage(tmp_path, **attrs) -> str:
    """A stage with one camera ``/Cam`` (apertures 20 x 15, so a 4:3 image needs no conforming) whose attributes
    ``attrs`` (USD names: ``focalLength=1e-30``) are authored as floats."""
    path = str(tmp_path / "cam.usda")
    stage = Usd.Stage.CreateNew(path)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    attrs = {"horizontalAperture": 20.0, "verticalAperture": 15.0, **attrs}
    for name, value in attrs.items():
        cam.GetPrim().GetAttribute(name).Set(float(value))
    stage.Save()
    return path


def _pick_directions(path: str, width: int, height: int) -> np.ndarray:
    """Unit directions, float64, of ``Gf.Frustum.ComputePickRay`` of ``/Cam`` through each pixel centre."""
    stage = Usd.Stage.Open(path)  # held: a prim of a stage that was let go is invalid
    frustum = UsdGeom.Camera(stage.GetPrimAtPath("/Cam")).GetCamera(Usd.TimeCode.Default()).frustum
    rays = []
    for i in range(height):
        for j in range(width):
            d = np.array(frustum.ComputePickRay(Gf.Vec2d(2 * (j + 0.5) / width - 1, 1 - 2 * (i + 0.5) / height))
                         .direction)
            rays.append(d / np.linalg.norm(d))
    return np.array(rays)


@pytest.mark.parametrize("attrs", [
    {"focalLength": 1e-30},  # a field of view of almost 180 degrees: rays almost square to the view
    {"focalLength": 1e30},  # one of almost 0
    {"horizontalAperture": 1e30, "verticalAperture": 7.5e29},
    {"horizontalAperture": 2e-30, "verticalAperture": 1.5e-30},
])
def test_extreme_film_to_focal_ratios_cast_usds_rays(tmp_path, attrs):
    """Films 1e30 times wider or narrower than the focal length, within float32's range: each pixel's ray is the
    direction of ``Gf.Frustum.ComputePickRay`` through its centre."""
    path = _usd_camera_stage(tmp_path, **attrs)
    _, directions = camera_rays(wrt.load_usd(path), "/Cam", width=4, height=3)
    np.testing.assert_allclose(directions, _pick_directions(path, 4, 3), atol=1e-6)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_a_film_too_wide_for_float32_rays_is_refused_naming_the_camera_and_fields(tmp_path, projection):
    """Apertures of 1e30 over a focal length of 1e-30 put the film's corners 1e60 focal lengths off the view, past
    float32's range (an orthographic aperture of 1e40 tenths of a unit likewise): USD's frustum casts finite rays
    (``ComputePickRay``), but wrt's rays were NaN, and the image was background without a word. Such a camera is
    refused, naming it and the fields that make its film."""
    if projection == "perspective":
        path = _usd_camera_stage(tmp_path, focalLength=1e-30, horizontalAperture=1e30, verticalAperture=7.5e29)
        assert np.all(np.isfinite(_pick_directions(path, 4, 3)))  # the oracle has rays
        scene = wrt.load_usd(path)
        camera = "/Cam"
    else:
        scene = quad_scene(-1.0, 1.0, -1.0, 1.0, 0.0)
        camera = wrt.Camera.orthographic((0, 0, 5), (0, 0, 0), height=1e39, path="/Ortho")
    label = "/Cam" if projection == "perspective" else "/Ortho"
    message = rf"camera {label}: its film .* past float32's range .*focal_length=.*horizontal_aperture="
    with pytest.raises(ValueError, match=message):
        camera_rays(scene, camera, width=4, height=3)
    with pytest.raises(ValueError, match=message):
        wrt.render(scene, camera=camera, width=4, height=3, device="cpu")


def test_a_camera_scaled_by_1e38_casts_the_unscaled_cameras_rays():
    """A camera scaled by 1e38 (with its scene) makes directions of about 1e38 per unit of depth, within float32's
    range: its rays are the unscaled camera's, not refused as a film past that range."""
    scene = quad_scene(-1.0, 1.0, -1.0, 1.0, -5.0)
    plain = wrt.Camera(focal_length=35.0, horizontal_aperture=36.0, vertical_aperture=24.0)
    scaled = wrt.Camera(to_world=np.diag([1e38, 1e38, 1e38, 1.0]), focal_length=35.0, horizontal_aperture=36.0,
                        vertical_aperture=24.0)
    expected = camera_rays(scene, plain, width=4, height=3)[1]
    np.testing.assert_allclose(camera_rays(scene, scaled, width=4, height=3)[1], expected, atol=1e-6)


def test_a_film_past_float32s_range_through_its_pixel_aspect_ratio_names_it():
    """Square apertures under ``fit="horizontal"`` and a pixel aspect ratio of 1e-40 make the film 7.5e40 times
    taller than wide: the refusal names the pixel aspect ratio too, which the apertures and focal length alone do not
    explain."""
    cam = wrt.Camera(horizontal_aperture=20.0, vertical_aperture=20.0, pixel_aspect_ratio=1e-40, path="/Thin")
    with pytest.raises(ValueError, match=r"camera /Thin: its film .* past float32's range .*pixel_aspect_ratio=1e-40"):
        cam.to_struct(4, 3)


@pytest.mark.parametrize("up_axis", ["Y", "Z"])
@pytest.mark.parametrize("far, half", [(1e15, 1.0), (1e30, 1.0)])
def test_the_default_camera_of_a_box_far_from_the_origin_looks_as_it_does_near_it(far, half, up_axis):
    """frame_scene took its view from the rounded eye minus the centre: at 1e15 the eye's offset (about 2) rounded
    by 1/8 turned the view, and at 1e30 (where a box 2 across has no size in double either) the offsets vanished, the
    view turned straight down, refused as parallel to Y up, and a fuzzed stage failed to render. The camera now turns
    as it does for the same box at the origin, placed at the centre plus its offset."""
    from wrt.camera import frame_scene

    lower, upper = np.array([far - half, -half, far - half]), np.array([far + half, half, far + half])
    size = upper - lower  # in double: none at 1e30
    near = frame_scene(-size / 2, size / 2, up_axis)
    camera = frame_scene(lower, upper, up_axis)
    np.testing.assert_allclose(camera.to_world[:3, :3], near.to_world[:3, :3], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(camera.to_world[:3, 3], (lower + upper) / 2 + near.to_world[:3, 3])
    assert camera.clipping_range == near.clipping_range


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_a_near_plane_past_float32s_range_along_the_corner_rays_is_refused_naming_the_clipping_range(projection):
    """A camera scaled by 1e38 with its near plane at depth 3 puts it 3 * 1.17e38 along its corner rays (float64,
    below), past float32's largest value: the kernel's ``near * length`` was inf and those rays saw nothing, without
    a word. It is refused naming the clipping range; at depth 2.5 it renders, its rays' ``t_min`` the plain camera's
    times the scale."""
    scale = 1e38
    apertures = dict(focal_length=35.0, horizontal_aperture=36.0, vertical_aperture=24.0, projection=projection)
    if projection == "orthographic":
        apertures.update(horizontal_aperture=0.36, vertical_aperture=0.24)  # (tenths of a scene unit)
    scene = quad_scene(-1.0, 1.0, -1.0, 1.0, -5.0)
    corner = np.array([0.5 * 36.0 / 35.0, 0.5 * 36.0 / 35.0 / 1.5, 1.0]) if projection == "perspective" else [0, 0, 1]
    near = 3.0 if projection == "perspective" else 3.5
    assert near * scale * np.linalg.norm(corner) > np.finfo(np.float32).max
    scaled = wrt.Camera(to_world=np.diag([scale, scale, scale, 1.0]), clipping_range=(near, 1e6), **apertures)
    with pytest.raises(ValueError, match=r"camera.*clipping_range=\(3(\.5)?, 1e\+06\)"):
        camera_rays(scene, scaled, width=4, height=3)
    plain = wrt.Camera(clipping_range=(2.5, 1e6), **apertures)
    scaled.clipping_range = (2.5, 1e6)
    t_min = camera_rays(scene, scaled, width=4, height=3, t_range=True)[2]
    expected = camera_rays(scene, plain, width=4, height=3, t_range=True)[2].astype(np.float64) * scale
    assert np.all(np.isfinite(t_min))
    np.testing.assert_allclose(t_min, expected, rtol=1e-6)


def test_an_attribute_that_is_no_camera_field_is_refused_at_the_render():
    """``cam.fov = 30`` (or ``fov_y_deg``, ``eye``) was kept by the dataclass and read by nothing: the image came from
    the camera as it was, without a word; a kept Renderer drew it so too, and a batch named no camera."""
    scene = quad_scene(-1.0, 1.0, -1.0, 1.0, 0.0)
    cam = wrt.Camera.look_at((0, 0, 5), (0, 0, 0), fov_y_deg=40)
    renderer = wrt.Renderer(scene, camera=cam, width=4, height=4, device="cpu")
    renderer.render()
    cam.fov = 30
    with pytest.raises(ValueError, match=r"camera has no field 'fov' \(set as an attribute, it is read by nothing\); "
                                         r"its fields: to_world, focal_length, .*; for a field of view, "
                                         r"Camera.look_at\(eye, target, up, fov_y_deg\)"):
        renderer.render()
    with pytest.raises(ValueError, match="camera has no field 'fov'"):
        wrt.render(scene, camera=cam, width=4, height=4, device="cpu")
    del cam.fov
    cam.focal_lenght = 35
    with pytest.raises(ValueError, match=r"cameras\[1\] of 2: camera has no field 'focal_lenght' \(did you mean "
                                         r"'focal_length'\?\)"):
        wrt.render_batch(scene, [wrt.Camera.look_at((0, 0, 5), (0, 0, 0)), cam], 4, 4, device="cpu")
    del cam.focal_lenght
    np.testing.assert_array_equal(renderer.render().aovs["depth"],
                                  wrt.render(scene, camera=cam, width=4, height=4, device="cpu").aovs["depth"])


def test_cameras_compare_by_their_fields():
    """``cam == other`` and ``cam in cameras`` raised numpy's 'truth value of an array ... is ambiguous'."""
    cam = wrt.Camera.look_at((0, 1, 5), (0, 0, 0), fov_y_deg=40)
    same = wrt.Camera.look_at((0, 1, 5), (0, 0, 0), fov_y_deg=40)
    assert cam == same and cam in [wrt.Camera(), same] and not cam != same
    assert cam != wrt.Camera.look_at((0, 1, 5), (0, 0, 0), fov_y_deg=41) and cam != "camera"
    same.to_world[0, 3] += 1.0  # an edit in place
    assert cam != same


def test_cameras_of_equal_numbers_compare_equal_whatever_holds_them():
    """A ``to_world`` set as a list (or as float32, or as 16 numbers), a clipping range as a list, a focal length as
    ``np.float64``: ``Camera.__eq__`` compared the bytes of each field with its type, so these were unequal to a
    camera of the same numbers. Oracle: float64 numpy holds the same numbers for each pair (check() makes that
    array of them); a different number still differs."""
    base = wrt.Camera.look_at((0, 1, 5), (0, 0, 0), fov_y_deg=40, clipping_range=(0.5, 100.0))
    matrix = base.to_world.copy()
    matrix[0, 3] = -0.0  # the look-at's 0, as a minus zero
    base.to_world = matrix.copy()
    variants = {
        "to_world list": {"to_world": matrix.tolist()},
        "to_world 16 numbers": {"to_world": matrix.ravel().tolist()},
        "to_world plus zero": {"to_world": matrix + 0.0},
        "clipping_range list": {"clipping_range": [0.5, 100.0]},
        "clipping_range array": {"clipping_range": np.array([0.5, 100.0])},
        "focal_length float64": {"focal_length": np.float64(base.focal_length)},
        "clipping_planes list": {"clipping_planes": []},
    }
    for name, fields in variants.items():
        other = wrt.Camera.look_at((0, 1, 5), (0, 0, 0), fov_y_deg=40, clipping_range=(0.5, 100.0))
        for field, value in fields.items():
            setattr(other, field, value)
            kept = np.asarray(getattr(base, field), np.float64)
            assert np.array_equal(np.asarray(value, np.float64).reshape(kept.shape), kept), name  # the oracle
        assert other == base and base == other and other in [wrt.Camera(), base] and not other != base, name
        other.check()  # as a render does: the same camera after
        assert other == base, name
    exact = base.to_world.astype(np.float32)  # a look-at's numbers are not all float32's
    differs = wrt.Camera.look_at((0, 1, 5), (0, 0, 0), fov_y_deg=40, clipping_range=(0.5, 100.0))
    differs.to_world = exact
    assert not np.array_equal(exact.astype(np.float64), base.to_world) and differs != base
    differs.to_world = matrix.tolist()
    differs.to_world[0][3] = 1e-300
    assert differs != base
    assert wrt.Camera(clipping_range=[0.5, 100.0]) != wrt.Camera(clipping_range=(0.5, 101.0))


@pytest.mark.parametrize("low, high", [(-2e38, 2e38), (-8e37, 8e37), (1e37, 1e38), (1e38, 2e38)])
def test_the_default_camera_of_a_scene_near_float32s_range_stays_finite(low, high):
    """A scene reaching 2e38 (past wrt's traced reach, warned about) got a default camera 8.5e38 away, past float32's
    largest value: its float32 eye was inf, the preview's frustum NaN (numpy's "invalid value") and its rays' origins
    inf; so did one reaching 8e37, within reach. The eye now stays within 2^126 (8.5e37) on every axis, nearer along
    the same view, with a warning. Oracle: the float64 line from the eye to the box's centre is the camera's view
    (off the origin it turns towards the centre; a centre past 2^126 too: the eye is at 2^126 on each axis)."""
    from wrt.preview import frustum_corners

    lower, upper = np.full(3, low, np.float32), np.full(3, high, np.float32)
    points = np.array([lower, [upper[0], lower[1], upper[2]], upper], np.float32)
    scene = wrt.Scene.from_triangles(points, [[0, 1, 2]])
    with pytest.warns(UserWarning, match=r"frame_scene: the camera that frames the box .* past 8\.51e\+37 \(2\^126\)"):
        cam, width, height = resolve_view(scene, None, 8, 6)
    eye = cam.to_world[:3, 3]
    assert np.isfinite(cam.to_world.astype(np.float32)).all() and np.abs(eye).max() <= 2.0**126, cam.to_world
    centre = (lower.astype(np.float64) + upper) / 2
    np.testing.assert_allclose(-cam.to_world[:3, 2], (centre - eye) / np.linalg.norm(centre - eye), atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's "invalid value encountered" where the eye was inf
        assert np.isfinite(frustum_corners(cam, width, height, 1e30)).all()
        s = cam.to_struct(width, height)
        assert np.isfinite(np.array([s.origin, s.right, s.up, s.forward], np.float64)).all()
    with pytest.warns(UserWarning):  # frame_scene's again, and the scene's past traced reach where it is
        origins, directions = camera_rays(scene, None, width, height)
    assert np.isfinite(origins).all() and np.isfinite(directions).all() and (np.abs(directions).max(axis=1) > 0).all()
