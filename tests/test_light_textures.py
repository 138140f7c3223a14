"""Textured UsdLux lights read from USD: dome texture layouts (``inputs:texture:format``) and RectLight textures.
Expected values come from each layout's definition written out here and from closed-form irradiance."""

import math

import numpy as np
import pytest
from PIL import Image as PilImage
from shading_helpers import quad

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


def test_rect_light_texture_is_seen_upright_from_the_lit_side(tmp_path):
    """A camera under the light looking up at its lit side sees the texture as an image viewer shows it: top-left
    texel at local (+X, +Y), which is the camera's top left (UsdLux: "a texture file's min coordinates should be at
    (+X, +Y) and max coordinates at (-X, -Y)"). The texture was ignored with a warning: all of it showed white 2."""
    light = textured_rect_light(tmp_path)
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor")
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 1), up=(0, 1, 0), height=0.9)  # inside the light
    img = wrt.render(wrt.Scene(meshes=[floor], lights=[light]), camera=cam, width=8, height=4, spp=1, device="cpu",
                     integrator="path", max_depth=1)
    seen = img.rgb.reshape(2, 2, 2, 4, 3)  # (texture row, pixel row, texture column, pixel column, rgb)
    expected = np.broadcast_to(2.0 * QUADRANTS[:, None, :, None, :], seen.shape)
    np.testing.assert_allclose(seen, expected, rtol=1e-6)


def rect_view_factor(x0, x1, y0, y1, p, height):
    """View factor from a point ``p`` of the plane z = 0 (facing up) to the parallel rectangle ``[x0, x1] x [y0,
    y1]`` at z = ``height``: inclusion-exclusion of the corner formula (odd in both its arguments)."""
    def corner(a, b):
        A, B = a / height, b / height
        sa, sb = np.sqrt(1 + A * A), np.sqrt(1 + B * B)
        return (A / sa * np.arctan(B / sa) + B / sb * np.arctan(A / sb)) / (2 * np.pi)

    px, py = p
    return corner(x1 - px, y1 - py) - corner(x0 - px, y1 - py) - corner(x1 - px, y0 - py) + corner(x0 - px, y0 - py)


def test_rect_light_texture_colours_the_light_it_sends(tmp_path):
    """Under the red quadrant, the floor's irradiance is the sum over the four quadrants of the texture of their
    colour times pi L times their view factor (closed form), (1.05, 0.53, 0.69); the texture was ignored with a
    warning and the floor lit white, 2.01 in every channel."""
    light = textured_rect_light(tmp_path)
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor")
    center = np.array([0.5, 0.1])
    cam = wrt.Camera.orthographic(eye=(*center, 0.5), target=(*center, 0), up=(0, 1, 0), height=0.05)
    img = wrt.render(wrt.Scene(meshes=[floor], lights=[light]), camera=cam, width=4, height=4, spp=1024,
                     device="cpu", integrator="path", max_depth=1)
    # Quadrant (row, column) of the texture covers local x in [0, 1] for column 0 (+X) and y in [0, 0.5] for row 0.
    expected = np.zeros(3)
    for row, (y0, y1) in enumerate([(0.0, 0.5), (-0.5, 0.0)]):
        for col, (x0, x1) in enumerate([(0.0, 1.0), (-1.0, 0.0)]):
            expected += QUADRANTS[row, col] * 2.0 * np.pi * rect_view_factor(x0, x1, y0, y1, center, 1.0)
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
    """A 2:1 image is lat-long as before; an authored ``latlong`` on a square image is not second-guessed; an image
    of another shape is read as lat-long with a warning naming the dome and its size."""
    rng = np.random.default_rng(123)
    for name, (height, width) in (("wide", (8, 16)), ("square", (8, 8)), ("odd", (8, 12))):
        PilImage.fromarray(rng.integers(0, 255, (height, width, 3), np.uint8)).save(tmp_path / f"{name}.png")
    wide = dome_from_usd(tmp_path, tmp_path / "wide.png", "automatic")
    assert wide.texture.shape[:2] == (8, 16)
    assert dome_from_usd(tmp_path, tmp_path / "square.png", "latlong").texture.shape[:2] == (8, 8)
    with pytest.warns(UserWarning, match=r"automatic.*read as latlong.*12x8.*/Dome"):
        odd = dome_from_usd(tmp_path, tmp_path / "odd.png", "automatic")
    assert odd.texture.shape[:2] == (8, 12)
