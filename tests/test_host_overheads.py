"""Host-side work saved between renders and traces of one scene: what is kept must still follow every edit.

Oracles: ray/plane distances in float64 for moved instances, and a float64 cross product for triangle areas.
"""

from __future__ import annotations

import numpy as np
import pytest

import wrt
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh, Scene, has_area

SQUARE = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)  # z = 0, prototype space
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def placed(heights) -> np.ndarray:
    """``(N, 4, 4)`` transforms putting instance ``k`` at x = 3k, z = ``heights[k]``."""
    to_world = np.tile(np.eye(4), (len(heights), 1, 1))
    to_world[:, 0, 3] = 3.0 * np.arange(len(heights))
    to_world[:, 2, 3] = heights
    return to_world


def squares(heights) -> Scene:
    """Two prototypes (one square each, the second half as wide) and instances of them, alternately."""
    prototypes = [Prototype(f"/P{k}", [Mesh(f"/P{k}/M", SQUARE * [1, 1 - k / 2, 1], TRIANGLES, double_sided=True)])
                  for k in range(2)]
    return Scene(prototypes=prototypes, instances=Instances.from_transforms(np.arange(len(heights)) % 2,
                                                                            placed(heights)))


def down_rays(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A ray straight down onto the centre of each instance, from z = 10."""
    origins = np.stack([3.0 * np.arange(n), np.zeros(n), np.full(n, 10.0)], axis=1).astype(np.float32)
    return origins, np.tile(np.float32([0, 0, -1]), (n, 1))


def test_moved_instances_are_traced_where_they_are_now():
    heights = np.array([0.0, 1.0, 2.0])
    scene = squares(heights)
    origins, directions = down_rays(3)
    np.testing.assert_allclose(wrt.trace(scene, origins, directions).t, 10.0 - heights, rtol=1e-6)
    for step in range(1, 4):  # each step a new to_world, as a robot's links each simulation step
        heights = heights + [0.5, -0.25, 1.0 * step]
        scene.instances.to_world = placed(heights)
        hits = wrt.trace(scene, origins, directions)
        np.testing.assert_allclose(hits.t, 10.0 - heights, rtol=1e-6)
        np.testing.assert_array_equal(hits.instance, [0, 1, 2])


def test_moved_instances_keep_their_blases_and_geometry_caches():
    from wrt.trace import get_accelerator

    scene = squares([0.0, 1.0, 2.0])
    before = get_accelerator(scene)
    partners = scene.triangle_partners()
    materials = scene.triangle_materials()
    points = scene.to_device("cpu").points
    scene.instances.to_world = placed([0.5, 1.0, 2.0])
    after = get_accelerator(scene)
    # The prototypes' trees are the same objects (only the TLAS is built again); the old accelerator is left as it
    # was (a recorded graph replays its arrays), and the geometry-only caches are not made again.
    assert after is not before and all(a is b for a, b in zip(after.blas, before.blas))
    assert after.tlas is not before.tlas
    assert scene.triangle_partners() is partners and scene.triangle_materials() is materials
    assert scene.to_device("cpu").points is points  # the instances' transforms are uploaded anew, not the triangles
    origins, directions = down_rays(3)
    np.testing.assert_allclose(wrt.trace(scene, origins, directions).t, [9.5, 9.0, 8.0], rtol=1e-6)


@pytest.mark.parametrize("edit", ["points", "prototype_ids", "instances"])
def test_other_edits_build_anew(edit):
    from wrt.trace import get_accelerator

    scene = squares([0.0, 1.0, 2.0])
    before = get_accelerator(scene)
    points = scene.to_device("cpu").points
    origins, directions = down_rays(3)
    expected = np.array([10.0, 9.0, 8.0])
    if edit == "points":  # the first prototype's square lifted by 0.25 together with a move: both show
        mesh = scene.prototypes[0].meshes[0]
        mesh.points = mesh.points + np.float32([0, 0, 0.25])
        scene.instances.to_world = placed([1.0, 1.0, 2.0])
        expected = np.array([8.75, 9.0, 7.75])  # the third is of the first prototype too
    elif edit == "prototype_ids":  # the middle instance becomes a wide square, placed where it was
        scene.instances = Instances.from_transforms([0, 0, 0], placed([0.0, 1.0, 2.0]))
    else:  # a new Instances of two: the third ray misses
        scene.instances = Instances.from_transforms([0, 1], placed([0.0, 1.0]))
        expected = np.array([10.0, 9.0, np.inf])
    after = get_accelerator(scene)
    assert not any(a is b for a, b in zip(after.blas, before.blas))
    if edit == "points":
        np.testing.assert_array_equal(scene.to_device("cpu").points.numpy()[:4], SQUARE + np.float32([0, 0, 0.25]))
        assert scene.to_device("cpu").points is not points
    np.testing.assert_allclose(wrt.trace(scene, origins, directions).t, expected, rtol=1e-6)


def test_kept_renderer_draws_moved_instances():
    scene = squares([0.0, 0.0, 0.0])
    camera = wrt.Camera.look_at((3, 0, 10), (3, 0, 0), up=(0, 1, 0))
    # Pixel (4, 4) of 9 x 9 looks straight down.
    renderer = wrt.Renderer(scene, camera=camera, width=9, height=9, integrator="depth")
    centre = renderer.render().aovs["depth"][4, 4]
    scene.instances.to_world = placed([0.0, 4.0, 0.0])  # the middle square comes 4 units nearer the camera
    moved = renderer.render().aovs["depth"][4, 4]
    np.testing.assert_allclose([centre, moved], [10.0, 6.0], rtol=1e-5)


@pytest.mark.parametrize("only", [0, 63, 64, 65, 319, 320, 5000, None])
def test_has_area_finds_the_one_triangle_with_area(only):
    # Triangles of repeated corners, but (where ``only`` is given) one at a chunk boundary of the growing chunks.
    rng = np.random.default_rng(7)
    points = rng.random((6000, 3)).astype(np.float32)
    indices = np.repeat(np.arange(6000, dtype=np.int32)[:, None], 3, axis=1)
    if only is not None:
        indices[only] = [only, only + 1, only + 2]
    corners = points[indices].astype(np.float64)
    expected = bool(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).any())
    assert expected == (only is not None)
    assert has_area(points, indices) == expected
    assert has_area(points, indices, chunk=100) == expected


def test_bounds_follow_moved_instances_and_new_points_are_checked(monkeypatch):
    scene = squares([0.0, 1.0, 2.0])
    scene.meshes = [Mesh("/World/M", SQUARE * 0.5 + np.float32([0, 0, -3]), TRIANGLES)]
    np.testing.assert_array_equal(np.stack(scene.bounds()), [[-1, -1, -3], [7, 1, 2]])
    boxes = []  # the prototypes' own boxes made since: none, they did not change
    monkeypatch.setattr(Prototype, "bounds", lambda self: boxes.append(self.path))
    scene.instances.to_world = placed([0.0, 5.0, 2.0])
    np.testing.assert_array_equal(np.stack(scene.bounds()), [[-1, -1, -3], [7, 1, 5]])
    assert boxes == []
    monkeypatch.undo()
    wrt.trace(scene, *down_rays(3))  # checked and kept: the next points must be checked again
    bad = SQUARE.copy()
    bad[2, 2] = np.nan
    scene.meshes[0].points = bad
    with pytest.raises(wrt.SceneError, match=r"/World/M.*triangle 0 uses vertex 2"):
        wrt.trace(scene, *down_rays(3))


def test_instance_scaled_past_2_to_100_after_a_move_is_traced_in_new_blases():
    # Its BLAS is traced scaled by a power of two past that scale (wrt.tlas.instance_exponents): the kept
    # accelerator cannot follow such a move, and one is built anew.
    from wrt.trace import get_accelerator

    scene = squares([0.0, 1.0, 2.0])
    before = get_accelerator(scene)
    to_world = placed([0.0, 1.0, 2.0])
    to_world[1, 0, 0] = to_world[1, 1, 1] = to_world[1, 2, 2] = 2.0**110  # the middle square spread, at its height
    scene.instances.to_world = to_world
    after = get_accelerator(scene)
    # The middle square's prototype gets a BLAS of its new scale; the other prototype's BLAS is the one built first.
    assert [part[0] for part in after._blas_parts] == [1, 2] and after.blas[0] is before.blas[0]
    assert after.blas[1] is not before.blas[1] and after._blas_parts[1][3] != 0
    # The middle square (z = 1) now covers the first (z = 0); the third (z = 2) lies above it.
    np.testing.assert_allclose(wrt.trace(scene, *down_rays(3)).t, [9.0, 9.0, 8.0], rtol=1e-6)


def test_far_mesh_warning_follows_point_edits_not_instance_moves(monkeypatch):
    import warnings

    import wrt.scene as scene_module

    scene = squares([0.0, 1.0, 2.0])
    far = np.float32([[2e38, 0, 0], [2e38, 1, 0], [2e38, 0, 1]])  # past 2^126 (8.5e37), wrt.scene.TRACED_REACH
    scene.meshes = [Mesh("/World/Far", far, np.int32([[0, 1, 2]]))]

    def warned() -> list:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            wrt.trace(scene, *down_rays(3))
        return [str(w.message) for w in caught if "past 8.5e37" in str(w.message)]

    first = warned()
    assert len(first) == 1 and "/World/Far" in first[0]
    assert warned() == []  # a trace of the cached tree says nothing
    looked_at = []  # meshes looked at again: none, the move changed none
    reaches_past = scene_module._reaches_past
    monkeypatch.setattr(scene_module, "_reaches_past", lambda m, reach: looked_at.append(m) or reaches_past(m, reach))
    scene.instances.to_world = placed([0.5, 1.0, 2.0])
    assert ["/World/Far" in w for w in warned()] == [True]  # said again at the TLAS rebuild, as at a build
    assert looked_at == []
    scene.meshes[0].points = far / np.float32(1e30)
    assert warned() == []


@pytest.mark.filterwarnings("ignore:scene. coordinates past")  # the refused transforms' own warning
@pytest.mark.parametrize("bad", ["nan", "inf", "beyond_float32", "not_affine"])
def test_a_refused_move_keeps_the_blases_for_the_next_good_move(bad):
    # A move the scene refuses once dropped the held accelerator: the next good move rebuilt every BLAS.
    from wrt.trace import get_accelerator

    scene = squares([0.0, 1.0, 2.0])
    before = get_accelerator(scene)
    origins, directions = down_rays(3)
    first = wrt.trace(scene, origins, directions).t
    refused = placed([0.5, 1.0, 2.0])
    if bad == "not_affine":
        refused[1, 3, 2] = 1.0  # a projective bottom row
    else:
        refused[1, 0, 3] = {"nan": np.nan, "inf": np.inf, "beyond_float32": 1e39}[bad]
    scene.instances.to_world = refused
    with pytest.raises(ValueError, match=r"instance 1|/instances\[1\]"):
        wrt.trace(scene, origins, directions)
    for heights in ([0.0, 1.0, 2.0], [0.5, 1.0, 2.0]):  # back where it was, then the move meant
        scene.instances.to_world = placed(heights)
        after = get_accelerator(scene)
        assert len(after.blas) == len(before.blas) and all(a is b for a, b in zip(after.blas, before.blas))
        np.testing.assert_allclose(wrt.trace(scene, origins, directions).t, 10.0 - np.array(heights), rtol=1e-6)
    np.testing.assert_allclose(first, [10.0, 9.0, 8.0], rtol=1e-6)


def test_a_move_that_skips_a_prototypes_only_instance_keeps_the_other_blases():
    # A singular transform skips its instance (warned); where it was its prototype's only one, the accelerator needs
    # other BLASes and was built anew whole, and again when the instance came back: every BLAS twice.
    from wrt.trace import get_accelerator

    scene = squares([0.0, 1.0, 2.0])  # instances 0 and 2 of prototype 0, instance 1 of prototype 1
    before = get_accelerator(scene)
    origins, directions = down_rays(3)
    flat = placed([0.0, 1.0, 2.0])
    flat[1, :3, :3] = 0.0
    scene.instances.to_world = flat
    with pytest.warns(UserWarning, match=r"singular transform.*/instances\[1\]"):
        skipped = get_accelerator(scene)
    assert [part[0] for part in skipped._blas_parts] == [1] and skipped.blas[0] is before.blas[0]
    np.testing.assert_allclose(wrt.trace(scene, origins, directions).t, [10.0, np.inf, 8.0], rtol=1e-6)
    scene.instances.to_world = placed([0.0, 1.5, 2.0])
    back = get_accelerator(scene)
    assert [part[0] for part in back._blas_parts] == [1, 2] and back.blas[0] is before.blas[0]
    np.testing.assert_allclose(wrt.trace(scene, origins, directions).t, [10.0, 8.5, 8.0], rtol=1e-6)
    fresh = squares([0.0, 1.5, 2.0])  # the same scene built anew: the same hits, ray by ray
    hits, kept = wrt.trace(fresh, origins, directions), wrt.trace(scene, origins, directions)
    for name in ("t", "u", "v", "prim", "instance"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(hits, name), err_msg=name)


def test_build_seconds_of_a_move_that_needs_other_blases_times_only_what_it_built():
    # build_seconds is the time of the build that made the accelerator (README); one made with reuse=held counted the
    # BLASes it took from the held one too, timed by that earlier build: the time of neither build.
    from wrt.trace import get_accelerator

    scene = squares([0.0, 1.0, 2.0])  # instances 0 and 2 of prototype 0, instance 1 of prototype 1
    before = get_accelerator(scene)
    assert all(b.build_seconds > 0.0 for b in before.blas)
    flat = placed([0.0, 1.0, 2.0])
    flat[1, :3, :3] = 0.0
    scene.instances.to_world = flat
    with pytest.warns(UserWarning, match=r"singular transform.*/instances\[1\]"):
        skipped = get_accelerator(scene)
    assert skipped.blas[0] is before.blas[0]  # every BLAS taken, none built: the TLAS alone
    assert skipped.build_seconds == skipped.tlas.build_seconds
    scene.instances.to_world = placed([0.0, 1.5, 2.0])
    back = get_accelerator(scene)
    assert back.blas[0] is before.blas[0] and back.blas[1] is not before.blas[1]  # the instance's prototype built
    assert back.build_seconds == back.blas[1].build_seconds + back.tlas.build_seconds
