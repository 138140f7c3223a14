"""A rect or disk light flush with a ceiling (the light's plane is the ceiling's, as a panel set into it): next-event
estimation reaches it (its shadow rays stop a few float32 rounding steps short of the light,
wrt.integrators.emitters.shadow_length), so the rays a surface scatters, and camera rays, must see it there too, or
the path tracer's MIS loses the share it gives those rays. Checked against Lambert's closed form for the floor below.
A light a little further behind a wall, from any distance, is neither reached nor seen."""

import math

import numpy as np
import pytest
from light_oracle import polygon_irradiance
from shading_helpers import pixel_points, quad, top_down_camera

import wrt
from wrt.lights import DiskLight, RectLight

ALBEDO = 0.5  # the default material's grey: radiance = ALBEDO * E / pi
HEIGHT = 0.37  # of the ceiling and the light above the floor z = 0: the light looks large from the floor
RADIANCE = 2.0
CENTRE = np.array([0.3, 0.1, HEIGHT])


def light_of(kind):
    to_world = np.eye(4)
    to_world[:3, 3] = CENTRE  # local -Z, the emitting side, looks down at the floor
    if kind == "rect":
        return RectLight(to_world=to_world, width=1.5, height=1.0, color=np.full(3, RADIANCE))
    return DiskLight(to_world=to_world, radius=0.7, color=np.full(3, RADIANCE))


def outline(kind):
    """The light's corners (the disk as a 512-gon), for Lambert's formula."""
    if kind == "rect":
        return [CENTRE + (x, y, 0) for x, y in ((-0.75, -0.5), (0.75, -0.5), (0.75, 0.5), (-0.75, 0.5))]
    phi = np.arange(512) / 512 * 2 * np.pi
    return list(CENTRE + 0.7 * np.stack([np.cos(phi), np.sin(phi), 0 * phi], -1))


def flush_scene(kind):
    floor = quad((0, 0, 0), (20, 0, 0), (0, 20, 0), name="/floor")
    ceiling = quad((0, 0, HEIGHT), (20, 0, 0), (0, 20, 0), name="/ceiling")
    return wrt.Scene(meshes=[floor, ceiling], lights=[light_of(kind)])


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("kind", ["rect", "disk"])
def test_a_light_flush_with_the_ceiling_lights_the_floor_as_lamberts_formula_says(kind, integrator):
    """Direct light on the floor (``max_depth`` 1) is the closed form, within four standard errors of the pixels'
    Monte Carlo noise. The path tracer's BSDF-sampled rays met the ceiling and not the light (the two at the same
    distance, the light was left out of the segment), so the floor got 0.67 (rect) and 0.64 (disk) of its light."""
    res, patch = 8, 0.4
    cam = top_down_camera((0.0, 0.0, 0.0), height=patch, distance=HEIGHT / 2)
    img = wrt.render(flush_scene(kind), camera=cam, width=res, height=res, spp=128, seed=5, device="cpu",
                     integrator=integrator, max_depth=1)
    points = pixel_points((0.0, 0.0, 0.0), patch, res, res).reshape(-1, 3)
    corners = outline(kind)
    expected = np.array([ALBEDO * polygon_irradiance(p, (0, 0, 1), corners, RADIANCE) / math.pi for p in points])
    residual = img.rgb[..., 0].ravel().astype(np.float64) - expected  # pixel areas vary E by under 0.1%
    error = residual.std() / math.sqrt(residual.size)
    assert abs(residual.mean()) < 4 * error + 2e-3 * expected.mean(), (residual.mean() / expected.mean(), error)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_camera_under_a_light_flush_with_the_ceiling_sees_the_light(integrator):
    """Camera rays looking up at the light see its radiance, as the floor below receives its light; the ceiling
    hid it at every pixel."""
    cam = wrt.Camera.orthographic(eye=CENTRE * (1, 1, 0.1), target=CENTRE, up=(0, 1, 0), height=0.8)
    img = wrt.render(flush_scene("rect"), camera=cam, width=8, height=8, spp=1, device="cpu",
                     integrator=integrator, max_depth=1)
    np.testing.assert_allclose(img.rgb, RADIANCE, rtol=1e-6)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("distance", [1.0, 1e3, 1e4])
def test_a_camera_far_from_a_wall_does_not_see_a_light_behind_it(integrator, distance):
    """A rect light 0.05 behind an opaque wall, facing the camera through it, lights nothing the camera sees: the
    wall, unlit, is black from any distance. Camera rays counted a light at t where t (1 - 1e-4) < t_max, the
    shadow rays' old margin (1e-4 of their length) taken of the camera's distance, so from 1000 away the light
    showed through the wall (its full radiance, 2). A flush light is still seen (the test above)."""
    wall = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/wall")
    to_world = np.eye(4)
    to_world[:3, :3] = np.diag([1.0, -1.0, -1.0])  # local -Z, the emitting side, along +Z: through the wall
    to_world[:3, 3] = (0, 0, -0.05)
    light = RectLight(to_world=to_world, width=2.0, height=2.0, color=np.full(3, RADIANCE), path="/Behind")
    cam = wrt.Camera.orthographic(eye=(0, 0, distance), target=(0, 0, 0), up=(0, 1, 0), height=1.0)
    img = wrt.render(wrt.Scene(meshes=[wall], lights=[light]), camera=cam, width=2, height=2, spp=1, device="cpu",
                     integrator=integrator, max_depth=1)
    np.testing.assert_array_equal(img.rgb, 0.0)


def floor_beside_a_wall_with_a_light_behind_it(distance, wall=True):
    """A floor z = 0 from a wall x = 0 out to ``2 distance``, and a rect light ``distance / 2`` across, 0.05 behind
    the wall (x = -0.05), its emitting side facing the floor through the wall."""
    floor = quad((distance, 0, 0), (2 * distance, 0, 0), (0, 2 * distance, 0), name="/floor")
    to_world = np.eye(4)
    to_world[:3, :3] = [[0, 0, -1], [-1, 0, 0], [0, 1, 0]]  # columns: local x, y, z; local -Z, emitting, along +X
    to_world[:3, 3] = (-0.05, 0, distance / 2)
    light = RectLight(to_world=to_world, width=distance / 2, height=distance / 2, color=np.full(3, RADIANCE),
                      path="/Behind")
    meshes = [floor]
    if wall:
        meshes.append(quad((0, 0, distance), (0, 2 * distance, 0), (0, 0, 2 * distance), name="/wall"))
    return wrt.Scene(meshes=meshes, lights=[light])


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("distance", [10.0, 1e3, 1e4])
def test_a_floor_far_from_a_wall_gets_no_light_from_behind_it(integrator, distance):
    """Direct light (``max_depth`` 1) on a floor ``distance`` from a wall, from a rect light 0.05 behind the wall, is
    0 (the wall blocks all of it): without the wall the same floor is lit. Shadow rays stopped 1e-4 of their length
    short of the light, and scattered rays counted a light 1e-4 of its distance behind what they hit, so from 1000
    away the floor was lit through the wall; now both margins are a few float32 rounding steps of the distances and
    coordinates involved."""
    cam = top_down_camera((distance, 0.0, 0.0), height=1.0, distance=1.0)
    kwargs = dict(camera=cam, width=4, height=4, spp=16, seed=3, device="cpu", integrator=integrator, max_depth=1)
    lit = wrt.render(floor_beside_a_wall_with_a_light_behind_it(distance, wall=False), **kwargs)
    assert (lit.rgb > 0).all()
    img = wrt.render(floor_beside_a_wall_with_a_light_behind_it(distance), **kwargs)
    np.testing.assert_array_equal(img.rgb, 0.0)


def floor_seeing_a_tilted_glowing_quad(back=False):
    """``(rendered, expected)`` radiance per pixel of a floor 60 from the centre of a 40 x 40 glowing quad 1 above it
    (direct light, ``path``), the quad seen at a grazing angle; ``back``: with a grey single-sided quad back to back
    with it (the same corners, facing up: its coincident partner, :mod:`wrt.twins`), listed first (the smaller
    geometry ids, which win ties). The scene is turned off the axes and moved off the origin, so rounding is not
    exact."""
    res, patch, height, x = 8, 0.4, 1.0, 60.0
    q, _ = np.linalg.qr(np.array([[0.8, 0.3, -0.5], [0.1, 0.9, 0.4], [0.6, -0.2, 0.7]]))
    q = q if np.linalg.det(q) > 0 else -q

    def placed(v, shift=0.0):
        return q @ np.asarray(v, np.float64) + shift

    floor = quad(placed((0, 0, 0), 37.3), placed((400, 0, 0)), placed((0, 400, 0)), name="/floor", material=1)
    glow = quad(placed((0, 0, height), 37.3), placed((-40, 0, 0)), placed((0, 40, 0)), name="/glow", material=0,
                double_sided=False)  # its front, cross(u, v), faces the floor
    meshes = [floor, glow]
    if back:
        meshes.insert(1, quad(placed((0, 0, height), 37.3), placed((40, 0, 0)), placed((0, 40, 0)), name="/back",
                              material=1, double_sided=False))
    mats = [wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE),
            wrt.Material(diffuse_color=ALBEDO, use_specular_workflow=True)]  # Lambertian: no specular
    cam = wrt.Camera.orthographic(eye=placed((x, 0, height / 2), 37.3), target=placed((x, 0, 0), 37.3),
                                  up=placed((0, 1, 0)), height=patch)
    img = wrt.render(wrt.Scene(meshes=meshes, materials=mats), camera=cam, width=res, height=res, spp=64,
                     seed=3, device="cpu", integrator="path", max_depth=1)
    corners = [np.array(c, np.float64) for c in ((-20, -20, height), (20, -20, height), (20, 20, height),
                                                 (-20, 20, height))]
    points = pixel_points((x, 0.0, 0.0), patch, res, res).reshape(-1, 3)  # in the frame before turning
    expected = np.array([ALBEDO * polygon_irradiance(p, (0, 0, 1), corners, RADIANCE) / math.pi for p in points])
    return img.rgb[..., 0].ravel().astype(np.float64), expected


def test_a_tilted_glowing_quad_seen_at_a_grazing_angle_does_not_shadow_its_own_light():
    """Shadow rays to an emissive triangle (geometry) are not blocked by the triangle they are aimed at: rounding
    puts it before their end (a few float32 rounding steps short of the light, as for analytic lights) where a floor
    sees a tilted glowing quad at a grazing angle, and a floor 60 from the centre of a 40 x 40 quad 1 above it got
    about 0.6 of Lambert's formula (shadow_length read the light's kind from ``kinds``, which holds the analytic
    lights' alone, past its end for the triangles, and gave them that margin without telling the quad apart)."""
    rendered, expected = floor_seeing_a_tilted_glowing_quad()
    residual = rendered - expected
    error = residual.std() / math.sqrt(residual.size)
    assert abs(residual.mean()) < 4 * error + 0.02 * expected.mean(), (residual.mean() / expected.mean(), error)


def test_a_glowing_quad_back_to_back_with_another_face_does_not_shadow_its_own_light():
    """The same with a grey face back to back with the glowing quad (a lamp's two sides as two single-sided quads):
    a shadow ray that rounding lets hit the back face first, where its coincident partner is the triangle the ray is
    aimed at, reaches the light, as a bounce ray hitting it there takes the partner. The floor got 0.92 of the
    formula when only the glowing triangle itself counted."""
    rendered, expected = floor_seeing_a_tilted_glowing_quad(back=True)
    residual = rendered - expected
    error = residual.std() / math.sqrt(residual.size)
    assert abs(residual.mean()) < 4 * error + 0.02 * expected.mean(), (residual.mean() / expected.mean(), error)
