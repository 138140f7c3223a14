"""``whitted`` keeps one emissive triangle of several drawn by power (resampled importance sampling,
:mod:`wrt.emitter_resampling`): a floor lit by large emitters tessellated into hundreds of triangles (a ceiling
panel, a wall far to the side straddling the floor's horizon with half its cells facing away, a textured panel) gets
Lambert's closed form within its Monte Carlo noise, and under the panel that noise is well below the plain
power-only pick's (one candidate), measured in the same scene and sample count."""

import math

import numpy as np
import pytest
from light_oracle import polygon_irradiance
from shading_helpers import pixel_points, quad
from test_subtended_tube import irradiance_from

import wrt
import wrt.emitter_resampling
from wrt.glowing_spheres import GLOW_CAPPED_CYLINDER

ALBEDO = 0.5
RADIANCE = 2.0
CEILING = 2.5  # height of the ceiling panel over the floor z = 0
PANEL = 4.0  # side of the ceiling panel, centred over the origin


def tessellated_rect(origin, u, v, cells, faces_away=None, name="/glow", material=0):
    """Single-sided rectangle ``origin + s u + t v`` (s, t in [0, 1]) as ``cells`` x ``cells`` cells of two
    triangles, its front along ``cross(u, v)``, texture coordinates ``(s, t)``; the cells where ``faces_away[i, j]``
    (i along u) wound the other way. Returns the mesh and the corners ``(C, 4, 3)`` of the cells facing front."""
    origin, u, v = (np.asarray(x, np.float64) for x in (origin, u, v))
    faces_away = np.zeros((cells, cells), bool) if faces_away is None else faces_away
    points, indices, uvs, facing = [], [], [], []
    for i in range(cells):
        for j in range(cells):
            st = np.array([(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)], np.float64) / cells
            corners = origin + st[:, :1] * u + st[:, 1:] * v
            order = [[0, 1, 2], [0, 2, 3]] if not faces_away[i, j] else [[0, 2, 1], [0, 3, 2]]
            first = len(points) * 4
            points.append(corners)
            indices += [[first + k for k in tri] for tri in order]
            uvs += [st[tri] for tri in order]
            if not faces_away[i, j]:
                facing.append(corners)
    mesh = wrt.Mesh(name, np.concatenate(points), np.array(indices, np.int32), None, double_sided=False,
                    material_ids=np.full(len(indices), material, np.int32))
    mesh.uvs = np.array(uvs, np.float32)
    return mesh, np.array(facing)


def ceiling_panel(cells):
    """The ceiling panel facing down over the floor (u, v wound so that cross(u, v) is -z)."""
    half = PANEL / 2
    return tessellated_rect((half, -half, CEILING), (-PANEL, 0, 0), (0, PANEL, 0), cells)


def render_floor(glow, centre, patch, res, spp, seed=7, materials=None, textures=None, scale=1.0, floor=None,
                 floor_mesh=None):
    """The red channel (or all three) of an orthographic view down at a ``patch`` wide square of the floor
    (material ``floor``, None: Lambertian; mesh ``floor_mesh``, None: a quad facing up, its material ids set here)
    lit by ``glow`` (a mesh or a list of them), every length of the scene and the camera times ``scale``."""
    mats = materials or [wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE)]
    floor_material = floor or wrt.Material(diffuse_color=ALBEDO, use_specular_workflow=True)  # no specular
    floor = floor_mesh or quad((0, 0, 0), (400, 0, 0), (0, 400, 0), name="/floor")
    floor.material_ids = np.full(len(floor.indices), len(mats), np.int32)
    mats = mats + [floor_material]
    meshes = [floor] + (glow if isinstance(glow, list) else [glow])
    for mesh in meshes:
        mesh.points = mesh.points * scale
    centre = np.asarray(centre, np.float64) * scale
    cam = wrt.Camera.orthographic(eye=centre + (0, 0, scale), target=centre, up=(0, 1, 0), height=patch * scale,
                                  clipping_range=(0.01 * scale, 1e6 * scale))
    img = wrt.render(wrt.Scene(meshes=meshes, materials=mats, textures=textures or []), camera=cam,
                     width=res, height=res, spp=spp, seed=seed, device="cpu", integrator="whitted", max_depth=1)
    return img.rgb.astype(np.float64)


def lambert(centre, patch, res, corners):
    """The floor's radiance at each pixel centre under uniform polygons ``corners`` (float64, closed form)."""
    points = pixel_points(centre, patch, res, res).reshape(-1, 3)
    return np.array([ALBEDO * polygon_irradiance(p, (0, 0, 1), corners, RADIANCE) / math.pi for p in points])


def assert_unbiased(rendered, expected, what):
    """The mean residual within four standard errors of the pixels' noise (and 0.2% of the light for rounding)."""
    residual = rendered.ravel() - expected
    error = residual.std() / math.sqrt(residual.size)
    assert abs(residual.mean()) < 4 * error + 2e-3 * expected.mean(), (what, residual.mean() / expected.mean(),
                                                                       error / expected.mean())


@pytest.mark.parametrize("centre", [(0.3, -0.2, 0.0), (1.9, 1.2, 0.0), (3.5, 0.0, 0.0)])
def test_a_floor_under_a_tessellated_ceiling_panel_gets_lamberts_irradiance(centre):
    """2 x 16 x 16 triangles 2.5 over the floor: under the panel's middle, under its corner and off to its side."""
    glow, corners = ceiling_panel(16)
    rendered = render_floor(glow, centre, patch=0.4, res=8, spp=16)
    assert_unbiased(rendered[..., 0], lambert(centre, 0.4, 8, corners), centre)


def test_a_wall_far_to_the_side_half_below_the_horizon_and_half_facing_away_gets_lamberts_irradiance():
    """A glowing wall 6 to the side of the floor patch, 4 wide and from 1.9 below the floor to 2.1 above it: the
    cells below the floor's horizon and every other cell (wound to face away) send it nothing, so their weights are
    0, and a row straddles the horizon; the oracle is Lambert's formula over the facing cells' parts above it."""
    cells = 16
    checker = (np.arange(cells)[:, None] + np.arange(cells)[None]) % 2 == 1
    glow, corners = tessellated_rect((6.0, 2.0, -1.9), (0, -4.0, 0), (0, 0, 4.0), cells, faces_away=checker)
    above = corners[corners[:, :, 2].max(axis=1) > 0.0]
    assert 0 < len(above) < len(corners)
    above[:, :, 2] = np.maximum(above[:, :, 2], 0.0)  # upright rectangles: clipped at the horizon
    rendered = render_floor(glow, (0.0, 0.0, 0.0), patch=0.4, res=8, spp=16)
    assert_unbiased(rendered[..., 0], lambert((0, 0, 0), 0.4, 8, above), "wall")


def test_a_textured_tessellated_panel_lights_each_channel_from_its_half():
    """The ceiling panel as 2 x 8 x 8 triangles whose emission texture is red on the half s < 0.5 and green on the
    other: each channel gets Lambert's formula over its half alone (the weights read no texture; the texture's
    light reaches the pick through the triangles' power)."""
    glow, corners = ceiling_panel(8)
    texture = np.array([[[1, 0, 0, 1], [0, 1, 0, 1]]], np.float32)
    binding = wrt.TextureInput(image=0, scale=np.float32([RADIANCE, RADIANCE, RADIANCE, 1.0]), filter="closest")
    mats = [wrt.Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": binding})]
    centre = (0.8, 0.3, 0.0)
    rendered = render_floor(glow, centre, patch=0.4, res=8, spp=16, materials=mats, textures=[texture])
    # s runs along u = -x: the cells with s < 0.5 (the first half, i < 4) lie at x > 0.
    red = corners[corners[:, :, 0].min(axis=1) >= 0.0]
    green = corners[corners[:, :, 0].max(axis=1) <= 0.0]
    assert len(red) == len(green) == 32
    assert_unbiased(rendered[..., 0], lambert(centre, 0.4, 8, red), "red")
    assert_unbiased(rendered[..., 1], lambert(centre, 0.4, 8, green), "green")
    np.testing.assert_array_equal(rendered[..., 2], 0.0)


def test_resampling_makes_the_floor_under_a_tessellated_panel_much_less_noisy(monkeypatch):
    """The pixels' spread about Lambert's formula at 4 samples, with the default candidates against one candidate
    (the power-only pick): below 0.7 of it (it falls as about 1 / sqrt(M))."""
    glow, corners = ceiling_panel(16)
    centre, patch, res, spp = (1.0, 0.5, 0.0), 1.0, 16, 4
    expected = lambert(centre, patch, res, corners)
    noise = []
    for candidates in (1, wrt.emitter_resampling.EMITTER_CANDIDATES):
        monkeypatch.setattr(wrt.emitter_resampling, "EMITTER_CANDIDATES", candidates)
        rendered = render_floor(glow, centre, patch, res, spp)[..., 0].ravel()
        noise.append((rendered - expected).std() / expected.mean())
    plain, resampled = noise
    assert resampled < 0.7 * plain, noise


# Emitters of different sizes, distances and radiances (origin, u, v, cells, radiance): a dim ceiling panel of 128
# triangles 2.5 over the floor, a small bright quad 0.5 over it and a tilted quad to the side.
MIXED = [((2.0, -2.0, 2.5), (-4.0, 0, 0), (0, 4.0, 0), 8, 1.0), ((0.9, 0.4, 0.5), (-0.2, 0, 0), (0, 0.2, 0), 1, 30.0),
         ((3.0, 1.0, 0.2), (0, -1.0, 0), (-0.3, 0, 1.2), 2, 4.0)]
MIXED_VIEW = dict(centre=(1.0, 0.0, 0.0), patch=3.0, res=24)


def mixed_emitters():
    """``(meshes, materials, expected)``: the :data:`MIXED` emitters and Lambert's floor radiance under them at the
    pixels of :data:`MIXED_VIEW`."""
    meshes, mats, expected = [], [], 0.0
    for j, (origin, u, v, cells, radiance) in enumerate(MIXED):
        mesh, corners = tessellated_rect(origin, u, v, cells, name=f"/glow{j}", material=j)
        meshes.append(mesh)
        mats.append(wrt.Material(diffuse_color=0.0, emissive_color=radiance))
        expected = expected + lambert(MIXED_VIEW["centre"], MIXED_VIEW["patch"], MIXED_VIEW["res"], corners) * (
            radiance / RADIANCE)
    return meshes, mats, expected


def render_mixed(spp, seed=7, scale=1.0, floor=None):
    meshes, mats, _ = mixed_emitters()
    return render_floor(meshes, spp=spp, seed=seed, materials=mats, scale=scale, floor=floor, **MIXED_VIEW)[..., 0]


def test_emitters_of_different_sizes_and_radiances_get_lamberts_irradiance():
    """The floor under :data:`MIXED`: unbiased about the float64 closed form (the target's radiance and pick
    probability cancel in the resampling weight)."""
    assert_unbiased(render_mixed(spp=16), mixed_emitters()[2], "mixed")


def test_the_resampling_target_weighs_radiance_not_power(monkeypatch):
    """The pixels' spread about Lambert's formula under :data:`MIXED` at 16 samples, with the default candidates
    against one: below half of it. Weighed by solid angle times the power pick's lean (a triangle's power, its area
    times its radiance), a large dim triangle counted its area twice: 0.65 of it."""
    expected = mixed_emitters()[2]
    noise = []
    for candidates in (1, wrt.emitter_resampling.EMITTER_CANDIDATES):
        monkeypatch.setattr(wrt.emitter_resampling, "EMITTER_CANDIDATES", candidates)
        noise.append(np.sqrt(np.mean((render_mixed(spp=16).ravel() - expected) ** 2)) / expected.mean())
    plain, resampled = noise
    assert resampled < 0.5 * plain, noise


@pytest.mark.parametrize("scale", [2.0**-20, 2.0**20, 1e-6, 1e6])
def test_the_floor_under_mixed_emitters_is_the_same_image_at_any_scene_scale(scale):
    """Every length times ``scale`` (the camera's too): the same pixels, bit for bit at a power of two (which scales
    every length exactly), within float32's rounding of the corners otherwise; the target is a radiance times a
    solid angle, free of length."""
    base = render_mixed(spp=4)
    scaled = render_mixed(spp=4, scale=scale)
    if math.log2(scale).is_integer():
        np.testing.assert_array_equal(scaled, base)
    else:
        np.testing.assert_allclose(scaled, base, rtol=1e-3, atol=1e-4 * base.mean())


GLOSSY = wrt.Material(diffuse_color=0.5, metallic=1.0, roughness=0.5)  # a rough metal: no diffuse lobe


def glossy_reference(monkeypatch):
    """The glossy floor under :data:`MIXED` with one candidate (the power pick, which reads no target) at 512
    samples: no closed form reflects a GGX lobe's light, and this one is unbiased whatever the target."""
    monkeypatch.setattr(wrt.emitter_resampling, "EMITTER_CANDIDATES", 1)
    reference = render_mixed(spp=512, seed=11, floor=GLOSSY).ravel()
    monkeypatch.undo()
    return reference


def test_a_glossy_floor_under_mixed_emitters_is_unbiased_and_less_noisy(monkeypatch):
    """A rough metal floor under :data:`MIXED`: with the default candidates, unbiased about the power pick's image
    and, at 16 samples, below 0.55 of the power pick's spread about it (0.50). A target blind to the BSDF (a diffuse
    receiver's) left it at 0.60: the triangles the lobe turns away were kept as often as those it reflects."""
    reference = glossy_reference(monkeypatch)
    resampled = render_mixed(spp=16, floor=GLOSSY).ravel()
    assert_unbiased(resampled, reference, "glossy")
    monkeypatch.setattr(wrt.emitter_resampling, "EMITTER_CANDIDATES", 1)
    plain = render_mixed(spp=16, floor=GLOSSY).ravel()
    noise = [np.sqrt(np.mean((x - reference) ** 2)) / reference.mean() for x in (plain, resampled)]
    assert noise[1] < 0.55 * noise[0], noise


def test_a_wall_whose_triangles_centres_lie_below_the_horizon_still_lights_the_floor():
    """A glowing wall of two triangles from 3 below the floor to 1 above it: both centres lie below the floor's
    horizon, where the BSDF reflects nothing, yet the part above lights it; the target's BSDF factor keeps a floor,
    so they are still kept (without it the floor went black). Oracle: Lambert's formula over the part above."""
    glow, _ = tessellated_rect((3.0, 2.0, -3.0), (0, -4.0, 0), (0, 0, 4.0), 1)
    above = np.array([[(3.0, 2.0, 0.0), (3.0, -2.0, 0.0), (3.0, -2.0, 1.0), (3.0, 2.0, 1.0)]])
    rendered = render_floor(glow, (0.0, 0.0, 0.0), patch=0.4, res=8, spp=16)
    assert_unbiased(rendered[..., 0], lambert((0, 0, 0), 0.4, 8, above), "wall below the horizon")


TILT = np.array([0.45, 0.0, 0.89]) / np.hypot(0.45, 0.89)  # the shading normal of the smooth floor below


def tilted_floor(back):
    """The z = 0 floor as a double-sided mesh whose vertex normals all lean towards +x (:data:`TILT` on the side
    facing up): wound to face up, or (``back``) down with the normals negated, so the camera above sees its back."""
    points = np.array([(-200, -200, 0), (200, -200, 0), (200, 200, 0), (-200, 200, 0)], np.float64)
    indices = np.array([[0, 2, 1], [0, 3, 2]] if back else [[0, 1, 2], [0, 2, 3]], np.int32)
    normals = np.tile(-TILT if back else TILT, (4, 1))
    return wrt.Mesh("/floor", points, indices, None, normals=normals, double_sided=True)


def above_plane(polygon, n, p):
    """The part of convex ``polygon`` ``(k, 3)`` on the side of the plane through ``p`` that normal ``n`` faces
    (Sutherland-Hodgman), no corner repeated; fewer than 3 corners where none of its area is there."""
    out = []
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0)):
        da, db = np.dot(n, a - p), np.dot(n, b - p)
        if da >= 0:
            out.append(a)
        if (da > 0 > db) or (da < 0 < db):
            out.append(a + (b - a) * (da / (da - db)))
    return np.array(out)


@pytest.mark.parametrize("back", [False, True], ids=["front", "back"])
def test_a_smooth_floor_is_lit_by_the_cells_above_both_its_horizons(back):
    """A double-sided Lambertian floor whose vertex normals lean 27 degrees towards +x, seen on its front or its
    back, between two glowing walls that straddle both the geometric horizon and the shading normal's: the BSDF
    reflects light from above both, so the cells wholly below either send the floor nothing, and the pick (which
    weighs with the shading normal turned to the viewer's side) keeps every cell that does. Oracle: Lambert's
    formula about the shading normal over the cells' parts above both horizons. A pick weighing with the front
    side's normal left the back black."""
    west, west_cells = tessellated_rect((-3.0, -2.0, -1.0), (0, 4.0, 0), (0, 0, 4.0), 8, name="/west")
    east, east_cells = tessellated_rect((3.0, 2.0, -2.0), (0, -4.0, 0), (0, 0, 4.0), 8, name="/east")
    lambertian = wrt.Material(diffuse_color=ALBEDO, use_specular_workflow=True, specular_edge=0.0)
    centre, patch, res = (0.3, 0.1, 0.0), 0.4, 8
    rendered = render_floor([west, east], centre, patch, res, spp=32, floor=lambertian, floor_mesh=tilted_floor(back))
    expected = []
    for p in pixel_points(centre, patch, res, res).reshape(-1, 3):
        parts = [above_plane(above_plane(c, TILT, p), (0, 0, 1), p) for c in np.concatenate([west_cells, east_cells])]
        expected.append(sum(polygon_irradiance(p, TILT, q, RADIANCE) for q in parts if len(q) >= 3))
    expected = ALBEDO * np.array(expected) / math.pi
    assert_unbiased(rendered[..., 0], expected, "back" if back else "front")


# A glowing capped cylinder 0.02 thick and 6 long (axis along +y) lying 1.5 to the side of the patch, 0.3 over the
# floor: the patch lies well inside the ball around it, where the tube subtends about 0.02 sr.
TUBE = ("cylinder", GLOW_CAPPED_CYLINDER, 1.0, 0.02, 3.0)
TUBE_CENTRE = np.array([1.5, 0.0, 0.3])
TUBE_FRAME = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # columns: its X, Y and axis


def tube_beside_the_panel():
    """The ceiling panel (8 x 8 cells) and the thin glowing tube over the floor, one glowing material."""
    glow, corners = ceiling_panel(8)
    _, _, _, r, half = TUBE
    to_world = np.eye(4)
    to_world[:3, :3] = TUBE_FRAME @ np.diag([r, r, half])
    to_world[:3, 3] = TUBE_CENTRE
    tube = wrt.Shape("/Tube", "cylinder", to_world, material_id=0, params=np.array([1.0, 0.0, 0.0, 1.0], np.float32))
    floor = quad((0, 0, 0), (400, 0, 0), (0, 400, 0), name="/floor")
    floor.material_ids = np.full(len(floor.indices), 1, np.int32)
    mats = [wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE),
            wrt.Material(diffuse_color=ALBEDO, use_specular_workflow=True)]
    return wrt.Scene(meshes=[floor, glow], shapes=[tube], materials=mats), corners


def test_a_thin_glowing_tube_beside_a_panel_is_weighed_by_its_solid_angle():
    """Whitted's pick among the panel's triangles and the tube weighed the tube by the cone of a ball around it, a
    hemisphere's 2 pi anywhere inside the ball: it drew the tube nearly always, though the panel sends the floor
    160 times its light, and the floor's noise per pixel at 4 samples was 0.97 of its light. Weighed by about the
    solid angle the tube subtends, the floor stays unbiased about Lambert's formula for the panel plus a float64
    quadrature of the tube's irradiance, and its noise falls below 0.2 of its light (0.10 over four seeds)."""
    scene, corners = tube_beside_the_panel()
    centre, patch, res = (0.0, 0.0, 0.0), 1.0, 16
    cam = wrt.Camera.orthographic(eye=(0.0, 0.0, 1.0), target=centre, up=(0, 1, 0), height=patch,
                                  clipping_range=(0.01, 1e6))
    rendered = wrt.render(scene, camera=cam, width=res, height=res, spp=4, seed=7, device="cpu", integrator="whitted",
                          max_depth=1).rgb[..., 0].astype(np.float64)
    tube = []
    for p in pixel_points(centre, patch, res, res).reshape(-1, 3):
        local = (p - TUBE_CENTRE) @ TUBE_FRAME
        tube.append(irradiance_from(TUBE, local, TUBE_FRAME.T @ np.array([0.0, 0.0, 1.0]), n=96))
    expected = lambert(centre, patch, res, corners) + ALBEDO * RADIANCE * np.array(tube) / math.pi
    assert_unbiased(rendered, expected, "panel and tube")
    noise = (rendered.ravel() - expected).std() / expected.mean()
    assert noise < 0.2, noise
