"""``UsdLux.DomeLight_1`` read from USD: its ``poleAxis`` orients the lat-long texture as the schema's documentation
says (``pxr/usd/usdLux/domeLight_1.h``): ``Y``, or ``scene`` on a Y-up stage, is the OpenEXR convention of the plain
DomeLight (+Y pole, longitude 0 at +Z, pi/2 at +X); ``Z``, or ``scene`` on a Z-up stage, puts the poles on -Z and +Z
and longitude 0 at -Y (the turn of +90 degrees about X that UsdImaging's ``_GetDomeOffset`` applies, so longitude
pi/2 stays at +X). The expected pixels are a float64 bilinear lookup of the texture at each camera ray's direction,
written from those sentences."""

import warnings

import numpy as np
import pytest
from PIL import Image as PilImage
from shading_helpers import bilinear
from test_light_textures import camera_directions

import wrt

# A 8 x 4 grey lat-long texture (a grey 8-bit PNG is read as stored: texel / 255), every texel distinct, so that a
# turned or mirrored dome shows other values.
TEXELS = (np.arange(32).reshape(4, 8) * 8 + 3).astype(np.uint8)
WIDTH, HEIGHT, FOV = 24, 12, 100


def dome_stage(tmp_path, kind, up_axis, pole=None, rotate_x=None):
    """A stage of ``up_axis`` holding one dome of type ``kind`` textured with :data:`TEXELS` (``poleAxis`` authored
    when ``pole`` is given, turned by ``rotate_x`` degrees about X when given)."""
    PilImage.fromarray(TEXELS, "L").save(tmp_path / "sky.png")
    lines = [f'#usda 1.0\n(\n    upAxis = "{up_axis}"\n)\ndef {kind} "Sky"\n{{',
             '    asset inputs:texture:file = @sky.png@', '    token inputs:texture:format = "latlong"']
    if pole is not None:
        lines.append(f'    uniform token poleAxis = "{pole}"')
    if rotate_x is not None:
        lines += [f"    float xformOp:rotateX = {rotate_x}", '    uniform token[] xformOpOrder = ["xformOp:rotateX"]']
    path = tmp_path / "dome.usda"
    path.write_text("\n".join(lines) + "\n}\n")
    return path


def expected_pixels(directions, pole_z, rotate_x=0.0):
    """``(P, 3)`` radiance of the dome along world ``directions`` ``(P, 3)``: the direction taken back into the
    dome's frame (undoing the prim's turn about X), then looked up by the schema's lat-long convention for the pole."""
    a = np.radians(rotate_x)
    turn = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    d = directions @ turn  # rows: turn^T d, the direction in the prim's frame
    if pole_z:  # latitude from +Z, longitude 0 at -Y, pi/2 at +X
        lon, lat = np.arctan2(d[:, 0], -d[:, 1]), np.arcsin(np.clip(d[:, 2], -1, 1))
    else:  # OpenEXR: latitude from +Y, longitude 0 at +Z, pi/2 at +X
        lon, lat = np.arctan2(d[:, 0], d[:, 2]), np.arcsin(np.clip(d[:, 1], -1, 1))
    width, height = TEXELS.shape[1], TEXELS.shape[0]
    x, y = (0.5 - lon / (2 * np.pi)) * width, (0.5 - lat / np.pi) * height  # left edge: longitude +pi
    return bilinear(np.repeat(TEXELS[..., None] / 255.0, 3, axis=-1), x, y, wrap_x=True)


def seen(path, forward, up):
    scene = wrt.load_usd(path)
    cam = wrt.Camera.look_at(eye=(0, 0, 0), target=forward, up=up, fov_y_deg=FOV)
    img = wrt.render(scene, camera=cam, width=WIDTH, height=HEIGHT, spp=1, device="cpu", integrator="path")
    return img.rgb.reshape(-1, 3), camera_directions(forward, up, FOV, WIDTH, HEIGHT)


VIEWS = [((0, -1, 0), (0, 0, 1)), ((1, 0, 0.3), (0, 0, 1)), ((0, 0, 1), (0, 1, 0))]  # -Y; +X, tilted up; +Z


@pytest.mark.parametrize(("kind", "up_axis", "pole", "pole_z"), [
    ("DomeLight_1", "Y", "Z", True),
    ("DomeLight_1", "Z", None, True),  # poleAxis "scene" (the schema's fallback) on a Z-up stage
    ("DomeLight_1", "Z", "scene", True),
    ("DomeLight_1", "Y", None, False),
    ("DomeLight_1", "Z", "Y", False),
    ("DomeLight", "Z", None, False),  # the plain dome keeps the +Y pole whatever the stage's up axis
])
def test_dome_texture_is_oriented_by_pole_axis_as_the_schema_says(tmp_path, kind, up_axis, pole, pole_z):
    path = dome_stage(tmp_path, kind, up_axis, pole)
    for forward, up in VIEWS:
        pixels, directions = seen(path, forward, up)
        np.testing.assert_allclose(pixels, expected_pixels(directions, pole_z), rtol=1e-4, atol=1e-4)


def test_pole_axis_turn_comes_before_the_prims_own_transform(tmp_path):
    """The pole's turn is the dome's own, applied before its transform (Hydra's ``domeOffset``): a DomeLight_1 of
    poleAxis Z turned 30 degrees about X shows the Z-pole texture turned by those 30 degrees."""
    path = dome_stage(tmp_path, "DomeLight_1", "Y", "Z", rotate_x=30)
    for forward, up in VIEWS:
        pixels, directions = seen(path, forward, up)
        np.testing.assert_allclose(pixels, expected_pixels(directions, True, rotate_x=30), rtol=1e-4, atol=1e-4)


def test_a_pole_axis_the_schema_does_not_allow_is_named_and_read_as_y(tmp_path):
    """``poleAxis = "X"`` (the schema allows scene, Y and Z) is read as Hydra reads it, the +Y pole with no turn, and
    named in a warning with the prim and the value: it was read as Y without a word, on a Z-up stage too."""
    path = dome_stage(tmp_path, "DomeLight_1", "Z", "X")
    with pytest.warns(UserWarning, match=r"poleAxis.*'X'.*/Sky"):
        (dome,) = wrt.load_usd(path).lights
    np.testing.assert_array_equal(dome.to_world, np.eye(4))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wrt.load_usd(dome_stage(tmp_path, "DomeLight_1", "Z", "Z"))


def sphere_irradiance(normal, radiance_along, n=256):
    """Float64 irradiance at a plane of unit ``normal`` under radiance ``radiance_along(directions)`` ``(P, 3)``:
    midpoint rule over an ``n x 2n`` grid of polar angle from +Z and azimuth."""
    theta = (np.arange(n) + 0.5) / n * np.pi
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    t, p = (g.ravel() for g in np.meshgrid(theta, phi, indexing="ij"))
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    weight = np.maximum(d @ np.asarray(normal, np.float64), 0.0) * np.sin(t) * (np.pi / n) ** 2
    return radiance_along(d).T @ weight


@pytest.mark.parametrize("normal", [(0, 0, 1), (1, 0, 0), (0, -0.6, 0.8)])
def test_light_sampling_draws_the_pole_axis_dome_that_rays_see(tmp_path, normal):
    """A DomeLight_1 of poleAxis Z, turned 30 degrees about X by its prim: the irradiance estimate of light sampling
    alone (its draws by the texture's luminance and their pdf) at planes facing its pole, its horizon and between is
    the float64 integral of the schema's orientation of the texture (the one camera rays are checked against above)
    times the cosine: guards the draws and their pdf against another frame than the lookup's."""
    from test_lights import light_estimates  # (the module that compiles the sampling kernel)

    (dome,) = wrt.load_usd(dome_stage(tmp_path, "DomeLight_1", "Y", "Z", rotate_x=30)).lights
    estimates, _ = light_estimates(dome, (0.0, 0.0, 0.0), normal, count=100000)
    expected = sphere_irradiance(normal, lambda d: expected_pixels(d, True, rotate_x=30))[0]
    error = estimates.std() / np.sqrt(len(estimates))
    assert abs(estimates.mean() - expected) < 4 * error + 1e-3 * expected, (estimates.mean(), expected, error)
