"""Emissive triangles (a glowing material, a mesh light, a glowing quad inside an instance) just behind an opaque
wall light nothing in front of the wall, however far away: the wall blocks every straight path from the quad (a
float64 oracle of the scene's geometry needs no more than that). Shadow rays to an emissive triangle stopped 1e-4 of
their length short of it, so that they would not hit the triangle itself, which from 1000 away is 0.1, past a wall
0.05 in front of the quad: the floor was lit through it."""

import numpy as np
import pytest
from shading_helpers import quad, top_down_camera

import wrt

RADIANCE = 2.0
GAP = 0.05  # between the wall (x = 0) and the glowing quad behind it (x = -GAP)


def floor_beside_a_wall_with_a_glowing_quad_behind_it(distance, kind, wall=True):
    """A floor z = 0 from the wall x = 0 out to ``2 distance``, and a single-sided glowing quad ``distance / 2``
    across, GAP behind the wall, its front facing the floor through the wall; ``kind``: "material" (an emissive
    material), "mesh_light" (a :class:`wrt.MeshLight` on a quad of no glow), "instanced" (an emissive quad in a
    prototype drawn by one instance) or "instanced_wall" (the same, and the wall another instance of it, four times
    as large and turned to face away from the floor: the same triangles as the lamp's, in another instance)."""
    side = distance / 2
    centre = np.array([-GAP, 0.0, side])
    floor = quad((distance, 0, 0), (2 * distance, 0, 0), (0, 2 * distance, 0), name="/floor", material=1)
    meshes = [floor]
    if wall and kind != "instanced_wall":
        meshes.append(quad((0, 0, distance), (0, 2 * distance, 0), (0, 0, 2 * distance), name="/wall", material=1))
    glow = wrt.Material(diffuse_color=0.0, emissive_color=RADIANCE if kind != "mesh_light" else 0.0)
    grey = wrt.Material(diffuse_color=0.5)
    lights = []
    if kind.startswith("instanced"):
        lamp = quad((0, 0, 0), (0, side, 0), (0, 0, side), name="/P/lamp", material=0, double_sided=False)  # front +X
        to_world = np.eye(4)
        to_world[:3, 3] = centre
        transforms = [to_world]
        if wall and kind == "instanced_wall":
            turned = np.diag([-4.0, -4.0, 4.0, 1.0])  # front -X, 2 distance across, at x = 0
            turned[:3, 3] = (0, 0, side)
            transforms.append(turned)
        return wrt.Scene(meshes=meshes, materials=[glow, grey], prototypes=[wrt.Prototype("/P", [lamp])],
                         instances=wrt.Instances.from_transforms(np.zeros(len(transforms)), np.array(transforms)))
    meshes.append(quad(centre, (0, side, 0), (0, 0, side), name="/glow", material=0, double_sided=False))
    if kind == "mesh_light":
        lights.append(wrt.MeshLight("/glow", color=np.full(3, RADIANCE)))
    return wrt.Scene(meshes=meshes, materials=[glow, grey], lights=lights)


@pytest.mark.parametrize("kind", ["material", "mesh_light", "instanced", "instanced_wall"])
@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("distance", [10.0, 1e3, 1e4])
def test_a_floor_far_from_a_wall_gets_no_light_from_a_glowing_quad_behind_it(integrator, distance, kind):
    """Direct light (``max_depth`` 1) on a floor ``distance`` from the wall is 0; without the wall the same floor is
    lit. From 1000 and 10000 away the floor was lit through the wall by next-event estimation (both integrators),
    while the path tracer's scattered rays met the wall."""
    cam = top_down_camera((distance, 0.0, 0.0), height=1.0, distance=1.0)
    kwargs = dict(camera=cam, width=4, height=4, spp=16, seed=3, device="cpu", integrator=integrator, max_depth=1)
    lit = wrt.render(floor_beside_a_wall_with_a_glowing_quad_behind_it(distance, kind, wall=False), **kwargs)
    assert (lit.rgb > 0).all()
    img = wrt.render(floor_beside_a_wall_with_a_glowing_quad_behind_it(distance, kind), **kwargs)
    np.testing.assert_array_equal(img.rgb, 0.0)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_frame_launched_without_host_reads_draws_the_same_floors(integrator):
    """``launch_frame`` (what a recorded graph replays: a fixed number of passes, nothing read back) decides the
    shadow rays to the glowing quad as ``render`` does: the floor behind the wall black, the floor without it lit,
    the same pixels (one sample each)."""
    cam = top_down_camera((1e3, 0.0, 0.0), height=1.0, distance=1.0)
    for wall in (True, False):
        scene = floor_beside_a_wall_with_a_glowing_quad_behind_it(1e3, "material", wall=wall)
        renderer = wrt.Renderer(scene, camera=cam, width=4, height=4, device="cpu", integrator=integrator,
                                max_depth=1)
        renderer.launch_frame(seed=3)
        rendered = wrt.render(scene, camera=cam, width=4, height=4, spp=1, seed=3, device="cpu",
                              integrator=integrator, max_depth=1)
        np.testing.assert_array_equal(renderer.frame_image().rgb, rendered.rgb)
        assert (rendered.rgb > 0).all() != wall
