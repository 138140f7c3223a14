"""Textured UsdLux lights read from USD: dome texture layouts (``inputs:texture:format``) and RectLight textures.
Expected values come from each layout's definition written out here and from closed-form irradiance."""

import math
import warnings

import numpy as np
import pytest
from PIL import Image as PilImage
from shading_helpers import bilinear, dome_integral, quad

import wrt

ALBEDO = 0.5  # the default material's grey: radiance = ALBEDO * E / pi
CAP = math.radians(40.0)  # half-angle of the bright cap painted into the dome textures
N = 96  # probe size in pixels; the cross has faces of N / 3


def probe_directions(fmt, size):
    """Unit directions ``(size, size, 3)`` of the pixel centres of a ``size x size`` probe and a mask of the pixels
    inside its disc, from the layouts' definitions (Debevec's light probe pages): image right +X, up +Y, centre
    +Z; angular: the angle from +Z is ``pi r``; mirroredBall: the mirror normal at ``(a, b)`` is
    ``(a, b, sqrt(1 - r^2))`` and a ray from the camera along -Z reflects off it."""
    c = (np.arange(size) + 0.5) / size * 2 - 1
    a, b = np.meshgrid(c, -c)  # b up: row 0 is the top
    r = np.hypot(a, b)
    inside = r < 1
    if fmt == "angular":
        theta = np.pi * r
        s = np.where(r > 0, np.sin(theta) / np.where(r > 0, r, 1), 0)
        d = np.stack([a * s, b * s, np.cos(theta)], -1)
    else:
        n = np.stack([a, b, np.sqrt(np.maximum(1 - r * r, 0))], -1)
        incoming = np.array([0.0, 0.0, -1.0])
        d = incoming - 2 * (n @ incoming)[..., None] * n
    return d / np.linalg.norm(d, axis=-1, keepdims=True), inside


def cross_directions(face):
    """Unit directions ``(4 face, 3 face, 3)`` of a vertical cross's pixel centres and the mask of its six faces,
    each face the view from the centre along its axis: +X, +Z, -X in the middle row seen facing +Z (+X on the left),
    +Y above and -Y below +Z, -Z below -Y upside down."""
    c = (np.arange(face) + 0.5) / face * 2 - 1
    a, b = np.meshgrid(c, -c)  # a right, b up within a face
    one = np.ones_like(a)
    cells = {  # (row, column): direction of (a, b)
        (1, 1): (-a, b, one),  # +Z: right is -X
        (1, 0): (one, b, a),  # +X: turned left from +Z, right is +Z
        (1, 2): (-one, b, -a),  # -X: turned right from +Z, right is -Z
        (0, 1): (-a, one, -b),  # +Y: its lower edge meets +Z's upper edge
        (2, 1): (-a, -one, b),  # -Y: its upper edge meets +Z's lower edge
        (3, 1): (-a, -b, -one),  # -Z: its upper edge meets -Y's lower edge
    }
    d = np.zeros((4 * face, 3 * face, 3))
    inside = np.zeros((4 * face, 3 * face), bool)
    for (row, col), xyz in cells.items():
        block = np.stack(xyz, -1)
        d[row * face:(row + 1) * face, col * face:(col + 1) * face] = block / np.linalg.norm(block, axis=-1)[..., None]
        inside[row * face:(row + 1) * face, col * face:(col + 1) * face] = True
    return d, inside


def cap_texture(tmp_path, fmt, toward):
    """A greyscale PNG in layout ``fmt``, 1 within :data:`CAP` of direction ``toward`` and 0 elsewhere."""
    d, inside = cross_directions(N // 3) if fmt == "cubeMapVerticalCross" else probe_directions(fmt, N)
    toward = np.asarray(toward, np.float64) / np.linalg.norm(toward)
    bright = inside & (d @ toward > math.cos(CAP))
    path = tmp_path / f"{fmt}.png"
    PilImage.fromarray((bright * 255).astype(np.uint8), "L").save(path)
    return path


def dome_from_usd(tmp_path, texture, fmt):
    path = tmp_path / "dome.usda"
    path.write_text(
        '#usda 1.0\n(\n    upAxis = "Y"\n)\n'
        f'def DomeLight "Dome"\n{{\n    asset inputs:texture:file = @{texture.name}@\n'
        f'    token inputs:texture:format = "{fmt}"\n}}\n'
    )
    (dome,) = wrt.load_usd(path).lights
    return dome


def plane_facing(normal, lights, spp=64):
    """Mean radiance of a single-sided grey plane through the origin whose front faces ``normal``, lit by
    ``lights`` (direct light only), seen from the front."""
    n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
    u = np.cross(n, [0.3, 0.5, 0.7])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    plane = quad((0, 0, 0), 40 * u, 40 * v, name="/plane", double_sided=False)  # front: cross(u, v) = n
    cam = wrt.Camera.orthographic(eye=3 * n, target=(0, 0, 0), up=v, height=0.5)
    scene = wrt.Scene(meshes=[plane], lights=list(lights))
    img = wrt.render(scene, camera=cam, width=4, height=4, spp=spp, device="cpu", integrator="path", max_depth=1)
    return float(img.rgb.mean())


# A cap around a direction off the layout's centre, and one at its side, so that a mirrored or turned layout lights
# the wrong plane: angular and mirroredBall put +X right and +Y up of the +Z centre; the cross's middle row is the
# horizon seen from inside facing +Z, with the back face (-Z) upside down below -Y.
FORMAT_CASES = [
    ("angular", (1.0, 0.0, 0.0)),
    ("angular", (0.0, 0.6, -0.8)),
    ("mirroredBall", (1.0, 0.0, 0.0)),
    ("mirroredBall", (0.0, 0.6, 0.8)),
    ("cubeMapVerticalCross", (1.0, 0.0, 0.0)),
    ("cubeMapVerticalCross", (0.6, 0.0, 0.8)),
    ("cubeMapVerticalCross", (0.0, 0.5, -0.8)),
]


@pytest.mark.parametrize(("fmt", "toward"), FORMAT_CASES, ids=[f"{f}-{i}" for i, (f, _) in enumerate(FORMAT_CASES)])
def test_dome_texture_layout_lights_from_its_defined_direction(tmp_path, fmt, toward):
    """A bright cap of half-angle 40 degrees painted into a dome texture by the layout's definition lights a plane
    facing it with ``E = pi sin^2(40 deg)`` and one facing away not at all (the layouts were ignored with a
    warning: a constant dome of 1 lit both planes with E = pi)."""
    dome = dome_from_usd(tmp_path, cap_texture(tmp_path, fmt, toward), fmt)
    toward = np.asarray(toward, np.float64)
    facing = plane_facing(toward, [dome])
    assert facing == pytest.approx(ALBEDO * math.sin(CAP) ** 2, rel=0.05)
    assert plane_facing(-toward, [dome], spp=16) == 0.0


QUADRANTS = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 0]]], np.float32)  # red, green / blue, yellow


def textured_rect_light(tmp_path, intensity=2.0):
    """A 2 x 1 RectLight at z = 1 emitting down (-Z), textured with :data:`QUADRANTS` (a 2 x 2 PNG), read from USD."""
    PilImage.fromarray((QUADRANTS * 255).astype(np.uint8), "RGB").save(tmp_path / "quadrants.png")
    path = tmp_path / "rect.usda"
    path.write_text(
        '#usda 1.0\n(\n    upAxis = "Z"\n)\n'
        f'def RectLight "Panel"\n{{\n    float inputs:width = 2\n    float inputs:height = 1\n'
        f'    float inputs:intensity = {intensity}\n    asset inputs:texture:file = @quadrants.png@\n'
        '    double3 xformOp:translate = (0, 0, 1)\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
    )
    (light,) = wrt.load_usd(path).lights
    return light


def test_rect_light_texture_is_filtered_and_seen_upright_from_the_lit_side(tmp_path):
    """A camera under the light looking up at its lit side sees the 2 x 2 texture upright, as an image viewer shows
    it (UsdLux: "a texture file's min coordinates should be at (+X, +Y) and max coordinates at (-X, -Y)": texel
    column c's centre at local X = 1 - (c + 1/2) on this 2-wide light, row r's at Y = 1/4 - r / 2), and bilinearly
    filtered: ramps between the texel centres, constant beyond them. It was looked up at the nearest texel: four flat
    quadrants, off by up to 1.3 of 2 next to their edges."""
    light = textured_rect_light(tmp_path)
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor")
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 1), up=(0, 1, 0), height=0.9)  # inside the light
    width, height = 16, 8
    img = wrt.render(wrt.Scene(meshes=[floor], lights=[light]), camera=cam, width=width, height=height, spp=1,
                     device="cpu", integrator="path", max_depth=1)
    # Pixel centres on the light: looking up +Z with +Y up, the image's right is -X.
    x = -((np.arange(width) + 0.5) / width - 0.5) * 0.9 * width / height
    y = (0.5 - (np.arange(height) + 0.5) / height) * 0.9
    xx, yy = np.meshgrid(x, y)
    # The light spans X in [-1, 1] and Y in [-0.5, 0.5]: one texel per unit along X, two along Y.
    expected = 2.0 * bilinear(QUADRANTS, 1.0 - xx.ravel(), 2.0 * (0.5 - yy.ravel()))
    np.testing.assert_allclose(img.rgb.reshape(-1, 3), expected, rtol=1e-5, atol=1e-6)
    assert img.rgb[0, 0] == pytest.approx([2.0, 0.0, 0.0])  # the top-left (red) texel at the camera's top left


def test_rect_light_texture_colours_the_light_it_sends(tmp_path):
    """Under the red quadrant, the floor's irradiance is the integral over the light of its filtered texture times
    ``L cos cos / r^2`` (numerically, on a fine grid), (1.04, 0.59, 0.66). The texture was ignored with a warning and
    the floor lit white, 2.01 in every channel; the nearest texel's quadrants gave (1.05, 0.53, 0.69)."""
    light = textured_rect_light(tmp_path)
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor")
    center = np.array([0.5, 0.1])
    cam = wrt.Camera.orthographic(eye=(*center, 0.5), target=(*center, 0), up=(0, 1, 0), height=0.05)
    img = wrt.render(wrt.Scene(meshes=[floor], lights=[light]), camera=cam, width=4, height=4, spp=1024,
                     device="cpu", integrator="path", max_depth=1)
    # Midpoints of a 400 x 200 grid over the light (X in [-1, 1], Y in [-0.5, 0.5], one unit above the floor).
    xs = (np.arange(400) + 0.5) / 400 * 2 - 1
    ys = (np.arange(200) + 0.5) / 200 - 0.5
    xx, yy = (g.ravel() for g in np.meshgrid(xs, ys))
    radiance = 2.0 * bilinear(QUADRANTS, 1.0 - xx, 2.0 * (0.5 - yy))
    r2 = (xx - center[0]) ** 2 + (yy - center[1]) ** 2 + 1.0
    expected = (radiance / r2[:, None] ** 2).sum(axis=0) * (2.0 / 400) * (1.0 / 200)  # cos * cos / r^2 = 1 / r^4
    np.testing.assert_allclose(img.rgb.reshape(-1, 3).mean(axis=0), ALBEDO * expected / np.pi, rtol=0.03)


def test_automatic_format_is_guessed_from_the_image_shape(tmp_path):
    """``texture:format = "automatic"`` (the schema's fallback) reads a square image as an angular probe and a 3:4 one
    as a vertical cross: the same dome as the format authored, lit from the cap's direction (it was read as lat-long:
    the square probe's cap, painted around +X, left the plane facing +X unlit)."""
    for fmt, toward in (("angular", (1.0, 0.0, 0.0)), ("cubeMapVerticalCross", (0.0, 0.5, -0.8))):
        texture = cap_texture(tmp_path, fmt, toward)
        automatic = dome_from_usd(tmp_path, texture, "automatic")
        np.testing.assert_array_equal(automatic.texture, dome_from_usd(tmp_path, texture, fmt).texture)
        assert automatic.texture.shape[1] == 2 * automatic.texture.shape[0]
    # The last one lights a plane facing its cap as the layout's definition says.
    assert plane_facing(toward, [automatic]) == pytest.approx(ALBEDO * math.sin(CAP) ** 2, rel=0.05)


def test_automatic_format_keeps_lat_long_and_an_authored_format(tmp_path):
    """A 2:1 image is lat-long as before; an authored ``latlong`` on a square image is not second-guessed (it is
    named as not of the layout's shape, test below); an image of another shape is read as lat-long with a warning
    naming the dome and its size."""
    rng = np.random.default_rng(123)
    for name, (height, width) in (("wide", (8, 16)), ("square", (8, 8)), ("odd", (8, 12))):
        PilImage.fromarray(rng.integers(0, 255, (height, width, 3), np.uint8)).save(tmp_path / f"{name}.png")
    wide = dome_from_usd(tmp_path, tmp_path / "wide.png", "automatic")
    assert wide.texture.shape[:2] == (8, 16)
    with pytest.warns(UserWarning, match=r"texture:format latlong: the image's shape is not the layout's"):
        assert dome_from_usd(tmp_path, tmp_path / "square.png", "latlong").texture.shape[:2] == (8, 8)
    with pytest.warns(UserWarning, match=r"automatic.*read as latlong.*12x8.*/Dome"):
        odd = dome_from_usd(tmp_path, tmp_path / "odd.png", "automatic")
    assert odd.texture.shape[:2] == (8, 12)


@pytest.mark.parametrize(("fmt", "shape"), [("angular", (8, 16)), ("mirroredBall", (8, 16)),
                                           ("cubeMapVerticalCross", (8, 16)), ("latlong", (12, 9))])
def test_an_authored_format_on_an_image_of_another_shape_is_named(tmp_path, fmt, shape):
    """An authored layout whose shape the image does not have (a 2:1 image said to be an angular or mirror-ball
    probe or a 3:4 cross, a 3:4 cross said to be lat-long) is read as authored, stretched to the image, and named
    with the dome and the image's size: it was stretched without a word. Images of the layout's shape stay
    silent."""
    height, width = shape
    PilImage.fromarray(np.full((height, width, 3), 128, np.uint8)).save(tmp_path / "odd.png")
    with pytest.warns(UserWarning, match=rf"texture:format {fmt}: the image's shape is not the layout's"
                                         rf".*{width}x{height}.*/Dome"):
        dome_from_usd(tmp_path, tmp_path / "odd.png", fmt)
    fitting = {"latlong": (8, 16), "cubeMapVerticalCross": (12, 9)}.get(fmt, (8, 8))
    PilImage.fromarray(np.full((*fitting, 3), 128, np.uint8)).save(tmp_path / "fits.png")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dome_from_usd(tmp_path, tmp_path / "fits.png", fmt)


def camera_directions(forward, up, fov_y_deg, width, height):
    """Unit directions ``(height * width, 3)``, row-major from the top-left, of the rays through the pixel centres of
    ``Camera.look_at(eye=origin, target=forward, up=up, fov_y_deg=fov_y_deg)``: its film is ``2 tan(fov / 2)`` tall
    at unit depth and ``width / height`` times as wide, image right ``forward x up``."""
    f = np.asarray(forward, np.float64) / np.linalg.norm(forward)
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    film_up = np.cross(right, f)
    half = math.tan(math.radians(fov_y_deg) / 2)
    x = ((np.arange(width) + 0.5) / width * 2 - 1) * half * width / height
    y = (1 - (np.arange(height) + 0.5) / height * 2) * half
    d = f + x[None, :, None] * right + y[:, None, None] * film_up
    return (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(-1, 3)


def latlong_texel_coords(d, width, height):
    """Texel coordinates ``(x, y)`` from the top-left corner of unit directions ``d`` ``(P, 3)`` in a ``width x
    height`` lat-long image, OpenEXR convention: +Y up, longitude 0 (+Z) at the image centre, +X left of it, the left
    edge longitude +pi."""
    lon = np.arctan2(d[:, 0], d[:, 2])
    lat = np.arcsin(np.clip(d[:, 1], -1, 1))
    return (0.5 - lon / (2 * np.pi)) * width, (0.5 - lat / np.pi) * height


LATLONG_4X2 = np.array([[[4, 0, 1], [0, 0, 0], [1, 3, 0], [0, 2, 4]],
                        [[0, 1, 0], [3, 3, 3], [0, 0, 2], [2, 0, 0]]], np.float32)  # black texels beside bright ones


@pytest.mark.parametrize(("forward", "up"), [((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0)), ((0, 1, 0), (0, 0, 1))],
                         ids=["centre", "seam", "pole"])
def test_dome_texture_seen_by_camera_rays_is_bilinear(forward, up):
    """A 4 x 2 lat-long dome seen directly: each pixel shows the texture interpolated bilinearly between the texel
    centres along its ray's direction (an independent numpy evaluation), wrapping around across the image's left and
    right edges (the seam behind, -Z) and clamped towards the poles. The nearest texel gave flat blocks, off by up to
    2.5 (of at most 4)."""
    dome = wrt.DomeLight(color=np.ones(3, np.float32), texture=LATLONG_4X2)
    cam = wrt.Camera.look_at(eye=(0, 0, 0), target=forward, up=up, fov_y_deg=100)
    width, height = 24, 12
    img = wrt.render(wrt.Scene(meshes=[], lights=[dome]), camera=cam, width=width, height=height, spp=1,
                     device="cpu", integrator="path")
    x, y = latlong_texel_coords(camera_directions(forward, up, 100, width, height), 4, 2)
    np.testing.assert_allclose(img.rgb.reshape(-1, 3), bilinear(LATLONG_4X2, x, y, wrap_x=True), rtol=1e-4, atol=1e-4)


# Rows of 45 degrees: a checker of 10 and 0 around the +Y pole, black down to the horizon, 10 just below it, black
# below that. Filtering lights the black row above the horizon from the bright row below it.
FURNACE_DOME = np.zeros((4, 8, 3), np.float32)
FURNACE_DOME[0, ::2] = 10.0
FURNACE_DOME[2] = 10.0


def test_white_plane_under_a_high_contrast_dome_converges_to_the_filtered_irradiance():
    """A grey Lambertian plane facing up under :data:`FURNACE_DOME`: the path tracer's mean over 16 x 16 pixels
    converges to albedo times the numpy integral of the filtered dome's irradiance over pi, 2.749, within 4 standard
    errors (the nearest texel gave 2.500 exactly: sin^2(45 deg) of the checker's mean 5); whitted's spherical
    harmonics of the dome's irradiance (bands 0-2) come within 1% of it too (it showed the filtered dome's mean over
    the sphere, 4.2227, whatever lies above the plane)."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)  # front +Y
    dome = wrt.DomeLight(color=np.ones(3, np.float32), texture=FURNACE_DOME)
    scene = wrt.Scene(meshes=[plane], lights=[dome])
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    img = wrt.render(scene, camera=cam, width=16, height=16, spp=256, device="cpu", integrator="path", max_depth=1)
    pixels = img.rgb[..., 1].ravel()
    error = pixels.std() / math.sqrt(pixels.size)
    expected = ALBEDO * dome_integral(FURNACE_DOME, upper_only=True)[1]
    assert error < 0.01 * expected
    assert abs(pixels.mean() - expected) < 4 * error, (pixels.mean(), expected, error)
    whitted = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="whitted")
    np.testing.assert_allclose(whitted.rgb, expected, rtol=0.01)


def test_a_dome_sun_filtered_into_its_black_neighbours_is_light_sampled_there():
    """One texel of 10^4 in a 64 x 128 dome of 0.01, 45 degrees up: filtering spreads it over the 2 x 2 texels around
    its centre, and light sampling must draw those too. Sampled by the texels' own luminance, the black neighbours got
    no share: only rare BSDF samples found their light (fireflies up to 1500, a per-sample standard deviation of 24
    against 2, and 1.69 +- 0.19 where the filtered dome gives 1.92)."""
    sun = np.full((64, 128, 3), 0.01, np.float32)
    sun[16, 40] = 1e4
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)  # front +Y
    scene = wrt.Scene(meshes=[plane], lights=[wrt.DomeLight(color=np.ones(3, np.float32), texture=sun)])
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    img = wrt.render(scene, camera=cam, width=16, height=16, spp=64, device="cpu", integrator="path", max_depth=1)
    pixels = img.rgb[..., 1].ravel()
    error = pixels.std() / math.sqrt(pixels.size)
    expected = ALBEDO * dome_integral(sun, upper_only=True, n=1024)[1]
    assert error < 0.02 * expected, (error, expected)
    assert abs(pixels.mean() - expected) < 4 * error, (pixels.mean(), expected, error)


def cube_face_directions(size):
    """Unit directions ``(6, size * size, 3)`` through the pixel centres of the six 90-degree views along +-X, +-Y,
    +-Z and each pixel's solid angle ``(size * size,)`` (the same on every face: ``dA / (1 + x^2 + y^2)^1.5``), with
    the ``(forward, up)`` of each view."""
    c = (np.arange(size) + 0.5) / size * 2 - 1
    a, b = (g.ravel() for g in np.meshgrid(c, -c))
    solid_angle = (2.0 / size) ** 2 / (1 + a * a + b * b) ** 1.5
    views = [((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 1, 0)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0)),
             ((0, 1, 0), (0, 0, -1)), ((0, -1, 0), (0, 0, 1))]
    dirs = []
    for forward, up in views:
        f = np.asarray(forward, np.float64)
        right = np.cross(f, up)
        d = f + a[:, None] * right + b[:, None] * np.asarray(up, np.float64)
        dirs.append(d / np.linalg.norm(d, axis=1, keepdims=True))
    return np.stack(dirs), solid_angle, views


@pytest.mark.parametrize("shadows", [True, False], ids=["mis", "light_sampling_alone"])
def test_dome_under_a_sheared_transform_lights_as_camera_rays_see_it(shadows):
    """A textured dome under an unevenly scaled parent of its rotation (not a rotation: its rotated axes are no
    longer perpendicular) lights a grey plane facing +Y with the irradiance of the sky that camera rays see there:
    the integral of ``L cos`` over the upper hemisphere of six 90-degree camera views from the plane (128 x 128
    pixels each). Light sampling drew directions through the transposed matrix but looked their radiance and pdf up
    through the matrix itself (its columns normalized), so the two disagreed: the plane showed 0.474 for 0.516, and
    0.315 lit by light sampling alone (shadows off)."""
    rng = np.random.default_rng(5)
    texture = (rng.random((6, 12, 3)) ** 3 * 4).astype(np.float32)
    c, s = math.cos(0.7), math.sin(0.7)
    to_world = np.eye(4)
    to_world[:3, :3] = np.diag([1.0, 3.0, 1.0]) @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.array(
        [[1, 0, 0], [0, c, -s], [0, s, c]])
    dome = wrt.DomeLight(color=np.ones(3, np.float32), texture=texture, to_world=to_world, shadows=shadows)
    # What camera rays see, integrated with the cosine to +Y over the upper hemisphere.
    size = 128
    dirs, solid_angle, views = cube_face_directions(size)
    expected = 0.0
    for d, (forward, up) in zip(dirs, views):
        cam = wrt.Camera.look_at(eye=(0, 0, 0), target=forward, up=up, fov_y_deg=90)
        seen = wrt.render(wrt.Scene(meshes=[], lights=[dome]), camera=cam, width=size, height=size, spp=1,
                          device="cpu", integrator="path").rgb[..., 1].ravel()
        expected += (seen * np.maximum(d[:, 1], 0.0) * solid_angle).sum()
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)  # front +Y
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    img = wrt.render(wrt.Scene(meshes=[plane], lights=[dome]), camera=cam, width=16, height=16, spp=256,
                     device="cpu", integrator="path", max_depth=1)
    pixels = img.rgb[..., 1].ravel()
    error = pixels.std() / math.sqrt(pixels.size)
    assert error < 0.01 * ALBEDO * expected / np.pi
    assert abs(pixels.mean() - ALBEDO * expected / np.pi) < 4 * error, (pixels.mean(), ALBEDO * expected / np.pi, error)


def test_dome_under_a_transform_scaling_an_axis_to_zero_renders():
    """A dome whose transform scales one axis to 0 still turns by a rotation and lights a grey plane with the constant
    dome's ``albedo * L``; inverting its normalized matrix raised numpy's LinAlgError (singular matrix)."""
    to_world = np.diag([0.0, 1.0, 1.0, 1.0])
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)  # front +Y
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    dome = wrt.DomeLight(color=np.full(3, 2.0, np.float32), to_world=to_world)
    img = wrt.render(wrt.Scene(meshes=[plane], lights=[dome]), camera=cam, width=4, height=4, spp=16, device="cpu",
                     integrator="path", max_depth=1)
    np.testing.assert_allclose(img.rgb, ALBEDO * 2.0, rtol=1e-4)


@pytest.mark.parametrize("value, shown", [(math.nan, "16 NaN"), (math.inf, "16 infinite"), (-2.0, "16 negative")])
def test_light_texels_that_cannot_be_emitted_are_named_in_a_warning(tmp_path, value, shown):
    """Negative, NaN and infinite texels of a light's texture emit nothing (the light table makes them 0): an HDR
    whose sun overflowed half floats to inf lit with a black sun without a word."""
    pytest.importorskip("OpenEXR")  # wrt reads EXR through it
    from exr_bytes import half_exr

    red = np.ones((4, 8))
    red[:2, :4] = value  # 8 texels of the red channel and 8 of the green: 16 values
    (tmp_path / "sky.exr").write_bytes(half_exr(8, 4, {"R": red, "G": red, "B": np.ones((4, 8))}))
    (tmp_path / "dome.usda").write_text('#usda 1.0\ndef DomeLight "Dome"\n{\n'
                                        '    asset inputs:texture:file = @sky.exr@\n}\ndef Sphere "Ball"\n{\n}\n')
    with pytest.warns(UserWarning, match=rf"texels that are negative, NaN or infinite emit nothing .*sky\.exr: {shown} "
                                         r"of 96 values.*: /Dome$"):
        scene = wrt.load_usd(tmp_path / "dome.usda")
    img = wrt.render(scene, camera=wrt.Camera.look_at((0, 0, 5), (0, 0, 0)), width=8, height=6, spp=2, device="cpu",
                     integrator="path")
    assert np.isfinite(img.rgb).all() and (img.rgb >= 0).all()


def srgb_decoded(samples):
    """8-bit samples through the inverse sRGB transfer function in float64 (IEC 61966-2-1)."""
    x = np.asarray(samples, np.float64) / 255.0
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def light_from_usd(tmp_path, kind, texture, file_metadata=""):
    """The one light of a stage holding a ``kind`` light (``DomeLight`` or ``RectLight``) textured with
    ``texture`` (a file in ``tmp_path``); ``file_metadata``: metadata on its ``inputs:texture:file``."""
    path = tmp_path / "light.usda"
    fmt = '    token inputs:texture:format = "latlong"\n' if kind == "DomeLight" else ""
    path.write_text(f'#usda 1.0\ndef {kind} "Light"\n{{\n    asset inputs:texture:file = @{texture.name}@'
                    f'{file_metadata}\n{fmt}}}\n')
    (light,) = wrt.load_usd(path).lights
    return light


# Samples spanning the sRGB curve's linear toe (0..10), its knee and the top.
RAMP = np.array([[0, 5, 10, 11, 64, 128], [188, 200, 230, 250, 254, 255]], np.uint8)


@pytest.mark.parametrize("kind", ["DomeLight", "RectLight"])
def test_light_texture_of_8_bit_colour_is_srgb_decoded_and_grey_is_read_as_stored(tmp_path, kind):
    """UsdLux has no sourceColorSpace: Storm reads a dome's texture as UsdUVTexture's ``auto``
    (HdStAssetUvSubtextureIdentifier(..., sourceColorSpace = colorSpaceAuto) in hdSt's simpleLightingShader), so an
    8-bit RGB or RGBA PNG is sRGB-decoded and a grey PNG (8 or 16 bits) is read as stored. A RectLight's texture is
    read by the same rule. Checked against the sRGB curve in float64. No fix: nothing checked the light textures'
    transfer function (the other tests' texels are 0 and 255, the same under both)."""
    rgb = np.stack([RAMP, RAMP[:, ::-1], np.full_like(RAMP, 128)], -1)
    PilImage.fromarray(rgb, "RGB").save(tmp_path / "rgb.png")
    rgba = np.concatenate([rgb, np.full_like(RAMP, 77)[..., None]], -1)
    PilImage.fromarray(rgba, "RGBA").save(tmp_path / "rgba.png")
    PilImage.fromarray(RAMP, "L").save(tmp_path / "grey.png")
    PilImage.fromarray(RAMP.astype(np.uint16) * 257).save(tmp_path / "grey16.png")
    for name, samples in (("rgb.png", rgb), ("rgba.png", rgb)):
        texture = light_from_usd(tmp_path, kind, tmp_path / name).texture
        np.testing.assert_allclose(texture[..., :3], srgb_decoded(samples), atol=2e-6)
    grey = np.repeat(RAMP[..., None], 3, -1) / 255.0
    for name in ("grey.png", "grey16.png"):
        np.testing.assert_allclose(light_from_usd(tmp_path, kind, tmp_path / name).texture[..., :3], grey, atol=2e-6)


@pytest.mark.parametrize("kind", ["DomeLight", "RectLight"])
def test_light_texture_colour_space_metadata_is_named_as_not_read(tmp_path, kind):
    """A ``colorSpace`` on a light's ``inputs:texture:file`` is not what Storm reads (the dome's texture is read as
    ``auto`` whatever it says), so the image is decoded as ``auto`` (sRGB here, against float64) and the light and
    the colour space are named in a warning: an 8-bit colour file marked ``lin_rec709_scene`` was sRGB-decoded
    without a word."""
    rgb = np.stack([RAMP, RAMP[:, ::-1], np.full_like(RAMP, 128)], -1)
    PilImage.fromarray(rgb, "RGB").save(tmp_path / "rgb.png")
    linear = ' (\n        colorSpace = "lin_rec709_scene"\n    )'
    with pytest.warns(UserWarning, match=r"colorSpace of inputs:texture:file is not read.*lin_rec709_scene.*/Light"):
        light = light_from_usd(tmp_path, kind, tmp_path / "rgb.png", linear)
    np.testing.assert_allclose(light.texture[..., :3], srgb_decoded(rgb), atol=2e-6)
