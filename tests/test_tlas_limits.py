"""The TLAS moves a ray's origin along it to ``t0`` before entering an instance and reports ``t0 + t``
(``wrt.tlas.entry_ray``); ``wrt.tlas.shifted_limit`` turns the ray's limits into limits on ``t``. Checked here against
numpy's float32 sums, which round as the kernels do."""

import warnings

import numpy as np
import pytest
import warp as wp
from test_instancing import (
    OCTAHEDRON,
    barycentric_margins,
    closest_hits_numpy,
    octahedra_scene,
    octahedra_triangles,
    stretched_octahedra,
)

import wrt
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh
from wrt.tlas import shifted_limit


@wp.kernel
def shifted_limits_kernel(limits: wp.array[float], t0s: wp.array[float], out: wp.array[float]):
    i = wp.tid()
    out[i] = shifted_limit(limits[i], t0s[i])


def shifted_limits(limits: np.ndarray, t0s: np.ndarray) -> np.ndarray:
    out = wp.empty(len(limits), dtype=float, device="cpu")
    wp.launch(shifted_limits_kernel, len(limits), inputs=[wp.array(limits, dtype=float, device="cpu"),
                                                          wp.array(t0s, dtype=float, device="cpu")],
              outputs=[out], device="cpu")
    return out.numpy()


def limit_pairs(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(limits, t0s)`` float32 over every scale: far apart, within a factor 2 of each other (where ``limit - t0``
    is exact and much finer than ``limit``), a float apart, zero, negative and subnormal; ``t0`` of either sign
    (a ray moved backwards, towards an instance behind its origin) against limits of either sign."""
    scale = 10.0 ** rng.uniform(-44, 37, n)
    limits = (scale * rng.choice([-1, 1], n) * rng.uniform(0.5, 1, n)).astype(np.float32)
    kind = rng.integers(0, 6, n)
    t0s = np.where(kind == 0, 10.0 ** rng.uniform(-44, 37, n), limits * rng.uniform(0.5, 2, n))
    t0s = np.where(kind == 2, np.nextafter(limits, rng.choice([-np.inf, np.inf], n)), t0s)
    t0s = np.where(kind == 3, limits * rng.uniform(0.999, 1.001, n), t0s)
    t0s = np.where(kind == 5, -(10.0 ** rng.uniform(-44, 37, n)), t0s).astype(np.float32)
    limits[kind == 4] = 0.0
    t0s[kind == 4] = np.abs(t0s[kind == 4]) * rng.choice([-1, 1], np.count_nonzero(kind == 4)).astype(np.float32)
    return limits, t0s


def test_a_shifted_limit_is_the_smallest_t_whose_reported_t0_plus_t_meets_the_limit(np_rng):
    """For every pair, ``x = shifted_limit(limit, t0)`` satisfies ``float32(t0 + x) >= limit`` while the float32
    below ``x`` does not (``t0 + t`` grows with ``t``, so a hit is kept exactly when its reported ``t`` is); and
    ``t0 = 0`` leaves the limit as it is, infinite limits too."""
    limits, t0s = limit_pairs(np_rng, 200_000)
    x = shifted_limits(limits, t0s)
    with np.errstate(over="ignore"):
        assert (t0s + x >= limits).all()
        below = np.nextafter(x, np.float32(-np.inf))
        assert (t0s + below < limits).all()
    assert np.array_equal(shifted_limits(limits, np.zeros_like(t0s)), limits)
    infinite = np.array([np.inf, -np.inf], np.float32)
    assert np.array_equal(shifted_limits(infinite, np.float32([3.0, 3.0])), infinite)


def sheared_octahedra_scene(scale: float):
    """Octahedra sheared by 300 (``test_instancing.stretched_octahedra``) with every length times ``scale`` (a power
    of two), rays from about 900 (times ``scale``) away aimed well inside random triangles, and the float64 closest
    hit of each: ``(scene, origins, directions, t, row, clear)``, ``clear`` where the hit lies more than 1% of its
    triangle inside it."""
    rng = np.random.default_rng(3)
    n_instances = 6
    to_world = stretched_octahedra(rng, "sheared", n_instances)
    to_world[:, :3, :] *= scale  # exact: a power of two
    scene = octahedra_scene(to_world)
    world, indices = octahedra_triangles(to_world[:, :3, :3], to_world[:, :3, 3])
    n = 2000
    aim = rng.integers(0, len(indices), n)
    targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[indices[aim]])
    origins = (targets + rng.normal(size=(n, 3)) * 900 * scale).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t, row = closest_hits_numpy(world, indices, o64, d64, np.zeros(n), np.full(n, np.inf))
    p0, p1, p2 = (world[indices[np.maximum(row, 0), k]] for k in range(3))
    hit = o64 + np.where(row >= 0, t, 0)[:, None] * d64
    inside = np.full(n, np.inf)
    for a, b in ((p0, p1), (p1, p2), (p2, p0)):  # the hit's distance to each edge's line
        edge = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
        inside = np.minimum(inside, np.linalg.norm(np.cross(hit - a, edge), axis=1))
    normal = np.cross(p1 - p0, p2 - p0)
    cosine = np.abs((normal * d64).sum(1)) / np.linalg.norm(normal, axis=1) / np.linalg.norm(d64, axis=1)
    clear = (row >= 0) & (inside > 1e-3 * scale) & (cosine > 0.1)
    return scene, origins, directions, t, row, clear


@pytest.mark.parametrize("scale", [2.0**-100, 2.0**100])
def test_a_scene_scaled_by_a_power_of_two_moves_its_rays_as_the_unscaled_one(scale):
    """The stretched instances of ``test_instancing`` (sheared by 300, rays from 900 away) with every length scaled by
    2^-100 or 2^100: each ray whose float64 hit is clear hits that triangle at the float64 ``t``, bit for bit as in
    the unscaled scene. ``moved_ray`` found ``t0`` from the local direction's ``d . d``, which for an instance
    2^-100 across overflows (2^200) and for one 2^100 across underflows: such rays were never moved, and 74 of the
    1,791 clear rays missed or hit another triangle at either scale (none unscaled)."""
    import wrt

    scene, origins, directions, t, row, clear = sheared_octahedra_scene(scale)
    assert clear.sum() > 0.8 * len(t)
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.prim[clear], row[clear])
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3)
    assert wrt.occluded(scene, origins, directions)[clear].all()
    unscaled = sheared_octahedra_scene(1.0)
    np.testing.assert_array_equal(hits.t, wrt.trace(unscaled[0], unscaled[1], unscaled[2]).t)


@pytest.mark.parametrize("kind", ["box", "sphere", "capsule"])
def test_a_shape_whose_canonical_ray_overflows_gives_no_hit_outside_the_limits(kind):
    """A shape 2^-100 across at the world origin inside a box 2^100 across, and rays from z = 2^102 going up (away
    from both: their hits lie at negative ``t``) with ``t_min`` at 1.5 times the big box's far face, which is then
    the closest hit, at ``t = -(2^100 + 2^102) / d_z`` (float64). In the small shape's space the ray's origin is
    2^202: no float32. The canonical box test took that infinite origin for a ray inside every slab and returned
    ``t = -inf``, which the TLAS kept as the closest hit (prim 0, far outside ``[t_min, t_max)``), and the any-hit
    query said occluded between ``t_min`` and 1.1 times the far face, where nothing lies. A canonical ray that is
    not finite now misses, as a BLAS takes it (``ray_can_hit``)."""
    import wrt
    from wrt.primitives import Shape

    small, big = 2.0**-100, 2.0**100
    scene = wrt.Scene(shapes=[Shape("/Small", kind, np.diag([small, small, small, 1.0])),
                              Shape("/Big", "box", np.diag([big, big, big, 1.0]))])
    origins = np.array([[0, 0, 2.0**102], [0, 0, 2.0**102], [2.0**99, 0, 2.0**102]], np.float32)
    directions = np.array([[0, 0, 1], [0, 0, 2.0**29], [0, 1e-3, 1]], np.float32)
    far_face = -(big + 2.0**102) / directions[:, 2].astype(np.float64)
    t_min = (1.5 * far_face).astype(np.float32)
    hits = wrt.trace(scene, origins, directions, t_min=t_min)
    np.testing.assert_array_equal(hits.prim, 1)
    np.testing.assert_allclose(hits.t, far_face, rtol=1e-6)
    t_max = (1.1 * far_face).astype(np.float32)
    assert not wrt.occluded(scene, origins, directions, t_min=t_min, t_max=t_max).any()
    assert not wrt.trace(scene, origins, directions, t_min=t_min, t_max=t_max).hit.any()


def aimed_rays(rng, world, indices, n: int, scale: float):
    """``n`` float32 rays from 1.5 to 6 ``scale`` away aimed well inside random triangles of ``world[indices]`` (a
    third of them along a world axis, give or take 1e-3), with their float64 closest hits ``t, row`` and ``clear``,
    the rays whose hit lies more than 0.02 inside its triangle."""
    aim = rng.integers(0, len(indices), n)
    targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[indices[aim]])
    away = rng.normal(size=(n, 3))
    axis = rng.integers(0, 3, n // 3)
    away[: n // 3] = rng.normal(scale=1e-3, size=(n // 3, 3))
    away[np.arange(n // 3), axis] = rng.choice([-1.0, 1.0], n // 3)
    away *= rng.uniform(1.5, 6, (n, 1)) / np.linalg.norm(away, axis=1, keepdims=True)
    origins = (targets + away * scale).astype(np.float32)
    directions = (-away).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t, row = closest_hits_numpy(world, indices, o64, d64, np.zeros(n), np.full(n, np.inf))
    clear = (row >= 0) & (barycentric_margins(world, indices, o64, d64, t, row) > 0.02)
    return origins, directions, t, row, clear


@pytest.mark.parametrize("scale", [1.0e36, 5.0e36, 5.0e-39, 3.0e-39])
def test_instances_scaled_past_2_to_100_hit_as_their_float64_triangles(scale):
    """Octahedra (half of them turned) scaled by 1e36 to 3e-39 (each within float32, as are their inverses), rays
    from 1.5 to 6 sizes away aimed well inside random triangles (a third of them along a world axis, give or take
    1e-3): each hits the float64 closest triangle. A ray moved into such an instance's space has a direction as long
    as the inverse scale: at 1e36 its components below 1e-38 (1% of it) were taken as 0 by the box test, and boxes
    it entered were culled; at 3e-39 it overflowed float32."""
    import wrt

    rng = np.random.default_rng(5)
    n_instances, n = 8, 2000
    to_world = np.tile(np.eye(4), (n_instances, 1, 1))
    for k in range(n_instances):  # half of them turned, half only scaled
        to_world[k, :3, :3] = (np.linalg.qr(rng.normal(size=(3, 3)))[0] if k % 2 else np.eye(3)) * scale
    to_world[:, :3, 3] = rng.uniform(-2, 2, (n_instances, 3)) * scale
    scene = octahedra_scene(to_world)
    world, indices = octahedra_triangles(to_world[:, :3, :3], to_world[:, :3, 3])
    origins, directions, t, row, clear = aimed_rays(rng, world, indices, n, scale)
    assert clear.sum() > 0.5 * n
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.prim[clear], row[clear])
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-4)
    assert wrt.occluded(scene, origins, directions)[clear].all()


@pytest.mark.parametrize("scale", [1.0e36, 3.0e-39])
def test_rays_from_inside_an_instance_scaled_past_2_to_100_never_leave_it(scale):
    """An icosphere instance scaled by 1e36 or 3e-39, rays from near its centre at every vertex and edge midpoint
    (and along the axes): every one hits it. Scaled by 3e-39, its prototype was first scaled into float32's
    subnormals with it, whose rounding opened a gap between its triangles that a ray passed through."""
    from test_robustness import icosphere

    import wrt

    points, faces = icosphere(3)
    proto = wrt.Prototype("/ball", meshes=[wrt.Mesh("/ball/mesh", points, faces, np.arange(len(faces)))])
    placed = np.diag([scale, scale, scale, 1.0])[None]
    scene = wrt.Scene(prototypes=[proto], instances=wrt.Instances.from_transforms([0], placed))
    p = points.astype(np.float64)
    targets = np.concatenate([p, (p[faces[:, 0]] + p[faces[:, 1]]) / 2, (p[faces[:, 1]] + p[faces[:, 2]]) / 2])
    rng = np.random.default_rng(0)
    targets = np.repeat(targets, 8, axis=0)
    inside = rng.uniform(-0.3, 0.3, targets.shape)
    origins = np.concatenate([inside, np.zeros((6, 3))]) * scale
    directions = np.concatenate([targets - inside, np.eye(3), -np.eye(3)])
    hits = wrt.trace(scene, origins.astype(np.float32), directions.astype(np.float32))
    assert (hits.prim >= 0).all(), np.flatnonzero(hits.prim < 0)
    assert wrt.occluded(scene, origins.astype(np.float32), directions.astype(np.float32)).all()


@pytest.mark.parametrize("unused, size, scale", [(1e30, 1.0, 1e36), (np.nan, 4.0, 1e37)])
def test_an_unused_point_does_not_change_an_instance_scaled_past_2_to_100(unused, size, scale):
    """Octahedra ``size`` across in their prototype, instanced at 1e36 or 1e37, whose prototype holds one more point
    no face uses, at 1e30 or NaN: the instances are traced in a BLAS scaled by the power of two of the prototype
    without that point (``instance_exponents``, its reach capped by ``SCALED_REACH``), every ray whose float64 hit
    is clear (a third along a world axis, give or take 1e-3) hits that triangle, and every hit is the one without the
    point. The exponent took the prototype's reach from every point: the unused 1e30 made it 25 instead of 120, and
    NaN counted as a reach of 1 (123 instead of 122, the points 2^125)."""
    from test_instancing import OCTAHEDRON

    import wrt
    from wrt.tlas import instance_exponents

    rng = np.random.default_rng(7)
    n_instances, n = 4, 1200
    to_world = np.tile(np.eye(4), (n_instances, 1, 1))
    for k in range(n_instances):
        to_world[k, :3, :3] = (np.linalg.qr(rng.normal(size=(3, 3)))[0] if k % 2 else np.eye(3)) * scale
    to_world[:, :3, 3] = rng.uniform(-1, 1, (n_instances, 3)) * scale  # within 8.5e37 (TRACED_REACH)
    pts, faces = OCTAHEDRON
    instances = wrt.Instances.from_transforms(np.zeros(n_instances, int), to_world)

    def scene_of(points):
        proto = wrt.Prototype("/Octa", [wrt.Mesh("/Octa/mesh", points.astype(np.float32), faces, np.arange(8))])
        return wrt.Scene(prototypes=[proto], instances=instances)

    scene = scene_of(np.concatenate([pts * size, [[unused, -unused, unused]]]))
    # The exponents of the prototype without the point, found as the float64 numbers say.
    largest = np.abs(np.linalg.inv(to_world[:, :3, :3])).reshape(n_instances, -1).max(axis=1)
    expected = np.minimum(1 - np.frexp(largest)[1], 125 - np.frexp(size)[1])
    np.testing.assert_array_equal(instance_exponents(scene), expected)
    world, indices = octahedra_triangles(to_world[:, :3, :3] * size, to_world[:, :3, 3])
    origins, directions, t, row, clear = aimed_rays(rng, world, indices, n, scale)
    assert clear.sum() > 0.5 * n
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.prim[clear], row[clear])
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3)
    assert wrt.occluded(scene, origins, directions)[clear].all()
    without = wrt.trace(scene_of(pts * size), origins, directions)
    np.testing.assert_array_equal(hits.prim, without.prim)
    np.testing.assert_array_equal(hits.t, without.t)


def test_an_update_across_2_to_100_names_the_instance_whose_scale_crossed_it():
    """Three octahedra at scale 1, then the same scene with the second scaled by 1e36 (traced in a BLAS scaled by
    2^120): ``InstancedAccelerator.update`` refuses it naming that instance and its scale, where it said "the scene's
    prototypes changed" (they had not), and ``follow`` (``FrameRenderer``'s step) then builds anew. A prototype that
    loses all its instances is still reported as a change of the prototypes."""
    from test_instancing import OCTAHEDRON, Instances, Mesh, Prototype

    import wrt
    from wrt.animation import follow

    to_world = np.tile(np.eye(4), (3, 1, 1))
    to_world[:, 0, 3] = [0, 3, 6]
    accel = wrt.tlas.InstancedAccelerator(octahedra_scene(to_world), "sah", "cpu")
    scaled = to_world.copy()
    scaled[1, :3, :3] *= 1e36
    scene = octahedra_scene(scaled)
    with pytest.raises(ValueError, match=r"instance /instances\[1\] crossed 2\^100") as error:
        accel.update(scene, refit_blas=False)
    assert "prototypes" not in str(error.value)
    assert follow(accel, scene, "tlas") == ("build", 0)
    pts, faces = OCTAHEDRON
    protos = [Prototype(f"/Octa{k}", [Mesh(f"/Octa{k}/mesh", pts, faces, np.arange(8))]) for k in range(2)]
    unused = wrt.Scene(prototypes=protos, instances=Instances.from_transforms(np.zeros(3, int), to_world))
    accel = wrt.tlas.InstancedAccelerator(
        wrt.Scene(prototypes=protos, instances=Instances.from_transforms(np.array([0, 1, 0]), to_world)), "sah", "cpu")
    with pytest.raises(ValueError, match="the scene's prototypes changed"):
        accel.update(unused, refit_blas=False)


@pytest.mark.parametrize("scale", [2.0**-110, 2.0**110])
def test_instances_of_a_prototype_of_shapes_alone_past_2_to_100_are_traced_without_a_numpy_warning(scale):
    """Instances scaled by 2^-110 or 2^110 of a prototype of one unit sphere (no triangles, so no BLAS to scale),
    beside an octahedron instance of the same scale: the sphere's instances get exponent 0 (the octahedron's the
    power of two that undoes its scale), tracing says nothing (warnings as errors), and unit rays from 10 radii
    above each sphere's centre hit it at 9 radii, the closed form. ``instance_exponents`` gave a prototype without
    triangles the exponent of a reach of 1e-38 (+25 at 2^-110), and the world-to-local matrix scaled by it (2^135)
    overflowed float32 in ``device_transforms``: numpy's bare "overflow encountered in cast" (an error under
    ``-W error``), for a matrix no BLAS reads."""
    from wrt.primitives import Shape
    from wrt.tlas import instance_exponents

    pts, faces = OCTAHEDRON
    protos = [Prototype("/Ball", shapes=[Shape("/Ball/sphere", "sphere", np.eye(4))]),
              Prototype("/Octa", [Mesh("/Octa/mesh", pts, faces, np.arange(8))])]
    to_world = np.tile(np.eye(4), (3, 1, 1))
    to_world[:, :3, :3] *= scale
    to_world[:, :3, 3] = np.array([(0.0, 0.0, 0.0), (5.0, 0.0, 0.0), (-5.0, 0.0, 0.0)]) * scale
    scene = wrt.Scene(prototypes=protos, instances=Instances.from_transforms([0, 0, 1], to_world))
    exponents = instance_exponents(scene)
    np.testing.assert_array_equal(exponents[:2], [0, 0])
    assert exponents[2] != 0  # the octahedron is traced in a scaled BLAS
    centres = to_world[:2, :3, 3]
    origins = (centres + [0.0, 0.0, 10.0 * scale]).astype(np.float32)
    directions = np.tile(np.float32([0.0, 0.0, -1.0]), (2, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.instance, [0, 1])
    np.testing.assert_allclose(hits.t, 9.0 * scale, rtol=1e-6)


def turned_octahedra(rng, scales, n_instances: int = 4):
    """``(scene, world, indices, rays)``: octahedra 2 from their prototype's origin, scaled by ``scales`` (rolled by
    one axis per instance) between two random turns, 8 apart; their float64 world triangles; and 4,000 rays from
    :func:`aimed_rays` at them, ``clear`` also asking that a ray meets its triangle at more than 0.2 of the normal."""
    to_world = np.tile(np.eye(4), (n_instances, 1, 1))
    for k in range(n_instances):
        q1, q2 = (np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(2))
        to_world[k, :3, :3] = q1 @ np.diag(np.roll(scales, k)) @ q2
        to_world[k, :3, 3] = (8.0 * k, 0.0, 0.0)
    pts, faces = OCTAHEDRON
    offset = np.array([2.0, 0.0, 0.0])
    proto = Prototype("/Octa", [Mesh("/Octa/mesh", pts + offset.astype(np.float32), faces, np.arange(8))])
    scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(n_instances, int), to_world))
    world, indices = octahedra_triangles(to_world[:, :3, :3], to_world[:, :3, 3] + to_world[:, :3, :3] @ offset)
    origins, directions, t, row, clear = aimed_rays(rng, world, indices, 4000, 1.0)
    p0, p1, p2 = (world[indices[row, k]] for k in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    cosine = np.abs((normal * directions).sum(1)) / np.linalg.norm(normal, axis=1) / np.linalg.norm(directions, axis=1)
    return scene, world, indices, (origins, directions, t, row, clear & (cosine > 0.2))


@pytest.mark.parametrize("squash", [1e-6, 3e-7])
def test_instances_squashed_between_two_turns_hit_as_their_float64_triangles(squash):
    """Octahedra 2 from their prototype's origin, squashed to ``squash`` between two turns (sheets of 1e-6 and 3e-7
    of their size; float32 holds their inverse within FLOAT32_INVERSE_TOLERANCE), rays from 1.5 to 6 sizes away
    aimed well inside random triangles: every ray whose float64 hit lies more than 0.02 inside its triangle, met at
    more than 0.2 of the normal, hits that instance at the float64 ``t``. Taken into the sheet's space through the
    float32 product of its inverse (entries of 1 / squash) and a point near it, the ray's local origin was rounded
    by up to 0.3 of the octahedron's size across the sheet, and 78 of 2,646 such rays (up to 0.33 inside) missed."""
    scene, _, _, (origins, directions, t, row, clear) = turned_octahedra(np.random.default_rng(11), [1.0, 1.0, squash])
    assert clear.sum() > 1000
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.instance[clear], row[clear] // 8)
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3)
    assert wrt.occluded(scene, origins, directions)[clear].all()


@pytest.mark.parametrize("scales", [(1.0, 1e-6, 1e-6), (1.0, 1e-3, 1e-6)])
def test_needles_and_ribbons_squashed_between_two_turns_stay_drawn(scales):
    """A needle (1, 1e-6, 1e-6) or a ribbon (1, 1e-3, 1e-6) between two turns is drawn as it is, as sheets are not
    (test above): nothing thickens a needle, so counting its float32 product's rounding skipped it (every ray
    missed), and a ribbon thickened to FLAT_THICKNESS (a tenth of its width) lost 204 of 3,089 clear rays (2 as it
    is). At least 99% of the clear rays hit their instance at the float64 ``t``."""
    scene, _, _, (origins, directions, t, row, clear) = turned_octahedra(np.random.default_rng(11), list(scales))
    assert clear.sum() > 1000
    hits = wrt.trace(scene, origins, directions)
    good = (hits.instance == row // 8) & np.isclose(hits.t, t, rtol=1e-3)
    assert good[clear].mean() > 0.99, (clear.sum(), (~good[clear]).sum())
