"""A glowing quad (emissive triangles, no UsdLux light) that is large next to its height over a floor lights the floor
as Lambert's formula says under both integrators, and ``whitted``, which samples lights alone, gets there at a modest
sample count: its triangles are sampled by the solid angle they subtend (:mod:`wrt.spherical_triangle`). Sampled
uniformly by area, the samples of a floor 0.1 under a 40 x 40 quad landed far off to the side almost always, and
whitted's floor came out 0.07 of the formula at 64 samples (its light in rare bright pixels); 1 under it, 18% noisy."""

import math

import numpy as np
import pytest
from light_oracle import polygon_irradiance
from shading_helpers import pixel_points, quad

import wrt

ALBEDO = 0.5
RADIANCE = 2.0
SIDE = 40.0
CENTRE = np.array([0.3, -0.2, 0.0])  # of the quad and the floor patch seen, off the origin


def tessellated_quad(centre, side, cells, height):
    """A ``side`` square at ``height``, centred over ``centre``, as ``cells`` x ``cells`` quads (two triangles
    each), single-sided, its front facing down."""
    s = (np.arange(cells + 1) / cells - 0.5) * side
    ys, xs = np.meshgrid(s, s, indexing="ij")
    points = np.stack([centre[0] + xs.ravel(), centre[1] + ys.ravel(), np.full(xs.size, height)], -1)
    first = (np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None]).ravel()
    a, b, c, d = first, first + 1, first + cells + 1, first + cells + 2
    indices = np.concatenate([np.stack([a, c, d], -1), np.stack([a, d, b], -1)])  # wound to face -z
    return wrt.Mesh("/glow", points, indices, np.arange(len(indices)), double_sided=False,
                    material_ids=np.zeros(len(indices), np.int32))


def floor_radiance(height, integrator, cells, res=8, patch=0.4, spp=64):
    """The floor patch's radiance under the quad and the same from Lambert's formula, per pixel."""
    floor = quad(CENTRE, (400, 0, 0), (0, 400, 0), name="/floor", material=1)
    if cells == 1:
        glow = quad(CENTRE + (0, 0, height), (-SIDE, 0, 0), (0, SIDE, 0), name="/glow", material=0,
                    double_sided=False)  # its front, cross(u, v), faces the floor
    else:
        glow = tessellated_quad(CENTRE, SIDE, cells, height)
    mats = [wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE),
            wrt.Material(diffuse_color=ALBEDO, use_specular_workflow=True)]  # Lambertian: no specular
    cam = wrt.Camera.orthographic(eye=CENTRE + (0, 0, height / 2), target=CENTRE, up=(0, 1, 0), height=patch)
    img = wrt.render(wrt.Scene(meshes=[floor, glow], materials=mats), camera=cam, width=res, height=res, spp=spp,
                     seed=7, device="cpu", integrator=integrator, max_depth=1)
    half = SIDE / 2
    corners = [CENTRE + (x, y, height) for x, y in ((-half, -half), (half, -half), (half, half), (-half, half))]
    points = pixel_points(CENTRE, patch, res, res).reshape(-1, 3)
    expected = np.array([ALBEDO * polygon_irradiance(p, (0, 0, 1), corners, RADIANCE) / math.pi for p in points])
    return img.rgb[..., 0].ravel().astype(np.float64), expected


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("height", [0.1, 1.0, 10.0])
def test_a_floor_under_a_large_glowing_quad_gets_lamberts_irradiance(height, integrator):
    """Within four standard errors of the pixels' Monte Carlo noise, and that noise under 3% of the light (64
    samples): a mean of rare bright samples would pass the first on a noise estimate its own tail leaves out."""
    rendered, expected = floor_radiance(height, integrator, cells=1)
    residual = rendered - expected
    error = residual.std() / math.sqrt(residual.size)
    assert error < 0.03 * expected.mean(), (rendered.mean() / expected.mean(), error / expected.mean())
    assert abs(residual.mean()) < 4 * error + 2e-3 * expected.mean(), (rendered.mean() / expected.mean(), error)


@pytest.mark.parametrize("height", [0.1, 1.0, 10.0])
def test_path_lights_the_floor_as_lamberts_formula_says_under_a_finely_tessellated_quad(height):
    """The same quad as 20 x 20 cells (800 triangles, each sampled by its own solid angle or area) under ``path``,
    whose BSDF-sampled rays share the light by MIS."""
    rendered, expected = floor_radiance(height, "path", cells=20)
    residual = rendered - expected
    error = residual.std() / math.sqrt(residual.size)
    assert abs(residual.mean()) < 4 * error + 2e-3 * expected.mean(), (rendered.mean() / expected.mean(), error)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_glowing_quad_textured_half_red_half_green_lights_each_channel_from_its_half(integrator):
    """A point sampled by solid angle carries the texture's radiance at its own texture coordinates (the barycentric
    weights of where the direction meets the triangle): a floor 1 under a quad whose emission texture is red on one
    half and green on the other gets in each channel Lambert's formula over that half alone."""
    res, patch, height, spp = 8, 0.4, 1.0, 64
    texture = np.array([[[1, 0, 0, 1], [0, 1, 0, 1]]], np.float32)  # st.x < 0.5 red (x > centre), else green
    binding = wrt.TextureInput(image=0, scale=np.float32([RADIANCE, RADIANCE, RADIANCE, 1.0]), filter="closest")
    glow = quad(CENTRE + (0, 0, height), (-SIDE, 0, 0), (0, SIDE, 0), name="/glow", material=0, double_sided=False)
    glow.uvs = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], np.float32)
    floor = quad(CENTRE, (400, 0, 0), (0, 400, 0), name="/floor", material=1)
    mats = [wrt.Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": binding}),
            wrt.Material(diffuse_color=ALBEDO, use_specular_workflow=True)]
    cam = wrt.Camera.orthographic(eye=CENTRE + (0, 0, height / 2), target=CENTRE, up=(0, 1, 0), height=patch)
    img = wrt.render(wrt.Scene(meshes=[floor, glow], materials=mats, textures=[texture]), camera=cam, width=res,
                     height=res, spp=spp, seed=7, device="cpu", integrator=integrator, max_depth=1)
    points = pixel_points(CENTRE, patch, res, res).reshape(-1, 3)
    half = SIDE / 2
    for channel, (x0, x1) in ((0, (0.0, half)), (1, (-half, 0.0))):
        corners = [CENTRE + (x, y, height) for x, y in ((x0, -half), (x1, -half), (x1, half), (x0, half))]
        expected = np.array([ALBEDO * polygon_irradiance(p, (0, 0, 1), corners, RADIANCE) / math.pi for p in points])
        residual = img.rgb[..., channel].ravel().astype(np.float64) - expected
        error = residual.std() / math.sqrt(residual.size)
        assert abs(residual.mean()) < 4 * error + 2e-3 * expected.mean(), (channel, residual.mean(), error)
    np.testing.assert_array_equal(img.rgb[..., 2], 0.0)
