"""Watertightness and any-hit consistency on closed meshes of awkward shapes, at scales 1e-6 to 1e6 and far from
the origin, as meshes and as mirrored instances, through every builder and layout, against float64 oracles.

Every mesh is closed and oriented outward (its winding number is 1 inside), about 1 across, centred near 0:
a convex hull of random points (half of them on a sphere, so many facets are nearly coplanar), an icosphere with
jittered vertices (not convex), a thin box, and a cone whose base and side are fans of slivers around two vertices
of large valence. ``tests/test_robustness.py`` covers larger, well-shaped meshes with the default builder.
"""

import functools
import itertools
import warnings

import numpy as np
import pytest
import pyvista as pv
from test_robustness import edge_and_vertex_targets, icosphere

import wrt
from wrt.bvh.build import Builder
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh
from wrt.trace import WARP_BUILDERS


def outward(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` of a convex mesh turned so that their normals point away from the centroid of ``points``."""
    tri = points[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", normals, tri.mean(axis=1) - points.mean(axis=0)) < 0
    faces = faces.copy()
    faces[flip] = faces[flip][:, ::-1]
    return faces


def convex_hull(rng, n: int = 100):
    """``(points (V, 3) float64, faces (T, 3) int32)``: the hull of ``n`` normal points, half projected on the unit
    sphere."""
    p = rng.normal(size=(n, 3))
    p[: n // 2] /= np.linalg.norm(p[: n // 2], axis=1, keepdims=True)
    # The hull as the surface of pyvista's (VTK's) Delaunay tetrahedralisation: pyvista is a dependency, scipy not.
    with warnings.catch_warnings():  # pyvista 0.49 announces a new default for extract_surface's algorithm
        warnings.simplefilter("ignore")
        surface = pv.PolyData(p).delaunay_3d().extract_surface().triangulate()
    points = np.asarray(surface.points, np.float64)
    return points, outward(points, surface.faces.reshape(-1, 4)[:, 1:]).astype(np.int32)


def jittered_icosphere(rng, level: int = 2):
    """An icosphere whose vertices are moved 15% in or out and 1% sideways: closed, star-shaped, not convex."""
    p, f = icosphere(level)
    p = p.astype(np.float64) * rng.uniform(0.85, 1.15, (len(p), 1)) + rng.normal(scale=0.01, size=p.shape)
    return p, f


def thin_box(thickness: float):
    """A box 1 x 1 x ``thickness`` of 12 triangles (its sides are slivers of aspect ``1 / thickness``)."""
    corners = np.array(list(itertools.product([-0.5, 0.5], repeat=3)))
    corners[:, 2] *= thickness
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [(a, b, c) for a, b, c, d in quads] + [(a, c, d) for a, b, c, d in quads]
    return corners, outward(corners, np.array(faces)).astype(np.int32)


def cone_fan(segments: int, height: float = 1.0):
    """A cone over the unit disc in z = 0, apex at ``height``: its side a fan around the apex and its base a fan
    around the disc's centre, ``segments`` slivers each (aspect about ``segments / 6``)."""
    a = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    points = np.concatenate([np.column_stack([np.cos(a), np.sin(a), np.zeros(segments)]), [[0, 0, height], [0, 0, 0]]])
    i = np.arange(segments)
    j = (i + 1) % segments
    faces = np.concatenate([np.column_stack([i, j, np.full(segments, segments)]),
                            np.column_stack([j, i, np.full(segments, segments + 1)])])
    return points, faces.astype(np.int32)


def winding_numbers(points: np.ndarray, faces: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """The winding number of the closed mesh around each query point, float64 (Van Oosterom and Strackee's solid
    angle of each triangle, 1983): 1 inside an outward mesh, 0 outside, -1 inside a mirrored one."""
    total = np.zeros(len(queries))
    for k in range(0, len(faces), 2048):
        a, b, c = (points[faces[k:k + 2048, j]][None] - queries[:, None] for j in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        det = np.einsum("nmk,nmk->nm", a, np.cross(b, c))
        dots = (np.einsum("nmk,nmk->nm", a, b) * lc + np.einsum("nmk,nmk->nm", b, c) * la
                + np.einsum("nmk,nmk->nm", c, a) * lb)
        total += 2 * np.arctan2(det, la * lb * lc + dots).sum(axis=1)
    return total / (4 * np.pi)


def first_hits(points: np.ndarray, faces: np.ndarray, origins: np.ndarray, directions: np.ndarray, grow: float = 0.0):
    """``(t, cos, prim)`` of each ray's first hit with ``t > 0`` over every triangle, float64 (Moller-Trumbore), with
    the triangles grown by ``grow`` in barycentric terms (negative: shrunk); ``cos`` is the hit triangle's ``|cos|``
    with the ray. ``inf``, NaN and -1 on a miss."""
    best, cos = np.full(len(origins), np.inf), np.full(len(origins), np.nan)
    prim = np.full(len(origins), -1)
    for k in range(0, len(faces), 1024):
        p0, p1, p2 = (points[faces[k:k + 1024, j]] for j in range(3))
        e1, e2 = p1 - p0, p2 - p0
        pv = np.cross(directions[:, None], e2[None])
        det = np.einsum("nmk,mk->nm", pv, e1)
        tv = origins[:, None] - p0[None]
        qv = np.cross(tv, e1[None])
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.einsum("nmk,nmk->nm", tv, pv) / det
            v = np.einsum("nk,nmk->nm", directions, qv) / det
            t = np.einsum("mk,nmk->nm", e2, qv) / det
            t = np.where((u >= -grow) & (v >= -grow) & (u + v <= 1 + grow) & (t > 0), t, np.inf)
        j = t.argmin(axis=1)
        tj = t[np.arange(len(origins)), j]
        normals = np.cross(e1, e2)[j]
        c = np.abs(np.einsum("nk,nk->n", normals, directions)) / (
            np.linalg.norm(normals, axis=1) * np.linalg.norm(directions, axis=1))
        closer = tj < best
        best, cos, prim = np.where(closer, tj, best), np.where(closer, c, cos), np.where(closer, k + j, prim)
    return best, cos, prim


def aspects(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each triangle's longest edge over its height on that edge (1 for an equilateral one, large for a sliver)."""
    tri = points[faces]
    longest = np.max([np.linalg.norm(tri[:, k] - tri[:, k - 1], axis=1) for k in range(3)], axis=0)
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return longest**2 / area2


def surface_points(rng, points: np.ndarray, faces: np.ndarray, n: int) -> np.ndarray:
    """``n`` points on the mesh's edges, float64: vertices, edge midpoints and random points of edges, a third each
    (their rays meet two or more triangles exactly at their borders)."""
    face, corner = rng.integers(0, len(faces), n), rng.integers(0, 3, n)
    a, b = faces[face, corner], faces[face, (corner + 1) % 3]
    s = np.select([np.arange(n) % 3 == 0, np.arange(n) % 3 == 1], [np.zeros(n), np.full(n, 0.5)], rng.random(n))
    return points[a] + s[:, None] * (points[b] - points[a])


def interior_points(rng, points: np.ndarray, faces: np.ndarray, n: int) -> np.ndarray:
    """``n`` points strictly inside the closed mesh (float64, winding number within 1% of +-1), from up to ``4 n``
    candidates between its surface centroid and its vertices."""
    tri = points[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    centre = (tri.mean(axis=1) * area[:, None]).sum(axis=0) / area.sum()
    candidates = centre + rng.uniform(0.0, 0.6, (4 * n, 1)) * (points[rng.integers(0, len(points), 4 * n)] - centre)
    inside = np.abs(np.abs(winding_numbers(points, faces, candidates)) - 1) < 0.01
    return candidates[inside][:n]


def rotation(rng) -> np.ndarray:
    """A random rotation (or reflection) matrix, ``(3, 3)``."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q


# (mesh, scale, distance from the world origin, convex): each placed under a rotation, a non-uniform scale of 0.3 to
# 3 and a mirror, at its own distance, so that none lies in another's way.
PLACEMENTS = (("hull", 1e-6, 1e-4, True), ("jittered icosphere", 1e3, 1e6, False), ("thin box", 1.0, 10.0, True),
              ("cone fan", 1e-3, 1.0, True))
RAYS_PER_MESH = 150  # from inside, and as many from outside where the mesh has targets for them


@functools.lru_cache(maxsize=1)
def closed_mesh_scenes():
    """``(flat scene, instanced scene, rays)``: the meshes of :data:`PLACEMENTS` flattened into one mesh, and as one
    instance each of their own prototype; ``rays`` is a dict of float32 ``origins``, ``directions``, the float64
    ``t`` and ``cos`` of their first hit in the flat scene and in the instanced one's world (exact image of its
    float32 prototypes), ``clear`` (a hit that no edge within 1e-5 decides), ``convex`` (a hit at or before the
    target is required) and ``slack`` (how far float32 rounding may move the hit along the ray)."""
    rng = np.random.default_rng(5)
    shapes = {"hull": convex_hull(rng), "jittered icosphere": jittered_icosphere(rng), "thin box": thin_box(1e-3),
              "cone fan": cone_fan(300)}
    flat_points, flat_faces, world_points, prototypes, to_world, rays = [], [], [], [], [], []
    for k, (name, scale, distance, convex) in enumerate(PLACEMENTS):
        local, faces = shapes[name]
        local = local.astype(np.float32)
        linear = rotation(rng) @ np.diag(rng.uniform(0.3, 3.0, 3) * [1, 1, -1]) @ rotation(rng) * scale
        offset = rng.normal(size=3)
        offset *= distance / np.linalg.norm(offset)
        world = local.astype(np.float64) @ linear.T + offset
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = linear, offset
        base = sum(len(p) for p in flat_points)
        flat_points.append(world.astype(np.float32))
        flat_faces.append(faces + base)
        world_points.append(world)
        prototypes.append(Prototype(f"/P{k}", [Mesh(f"/P{k}/{name}", local, faces, np.arange(len(faces)))]))
        to_world.append(m)
        # Rays from inside towards points on edges and vertices; from outside within 30 degrees of the outward
        # direction at such points, where every face meeting there is seen from the front.
        targets = surface_points(rng, world, faces, RAYS_PER_MESH)
        inside = interior_points(rng, world, faces, RAYS_PER_MESH)
        size = np.ptp(world, axis=0).max()
        outside_targets, normals = edge_and_vertex_targets(world.astype(np.float32), faces, rng, per_edge=2)
        pick = rng.integers(0, len(outside_targets), RAYS_PER_MESH if len(outside_targets) else 0)
        approach = normals[pick] + 0.3 * rng.normal(size=(len(pick), 3)) / np.sqrt(3)
        approach /= np.linalg.norm(approach, axis=1, keepdims=True)
        outside_targets = outside_targets[pick].astype(np.float64)
        origins = np.concatenate([inside[: len(targets)], outside_targets + 3 * size * approach]).astype(np.float32)
        aims = np.concatenate([targets[: len(inside)], outside_targets])
        directions = (aims - origins).astype(np.float32)
        convex_hit = np.concatenate([np.full(min(len(inside), len(targets)), convex), np.ones(len(pick), bool)])
        reach = max(distance, np.abs(origins).max()) * np.linalg.cond(linear)  # float32 rounds the rays' moves there
        rays.append((origins, directions, convex_hit, np.full(len(origins), reach)))
    origins, directions, convex, reach = (np.concatenate(parts) for parts in zip(*rays))
    points, faces = np.concatenate(flat_points), np.concatenate(flat_faces)
    flat = wrt.Scene.from_triangles(points, faces)
    instanced = wrt.Scene(prototypes=prototypes, instances=Instances.from_transforms(np.arange(len(prototypes)),
                                                                                     np.array(to_world)))
    o, d = origins.astype(np.float64), directions.astype(np.float64)
    oracles = {}
    for key, pts in (("flat", points.astype(np.float64)), ("instanced", np.concatenate(world_points))):
        t, cos, prim = first_hits(pts, faces, o, d)
        clear = np.abs(first_hits(pts, faces, o, d, 1e-5)[0] - first_hits(pts, faces, o, d, -1e-5)[0]) <= 1e-4 * t
        # float32 moves a hit by epsilons of the coordinates the ray is moved at, across the face at its slope, and
        # by epsilons of t times the aspect of a sliver (README: Triangles).
        eps = 32 * 2.0**-23
        slack = eps * (t * (1 + aspects(pts, faces)[prim]) + reach / (np.linalg.norm(d, axis=1) * np.maximum(
            cos, 1e-12)))
        oracles[key] = {"t": t, "clear": clear, "slack": slack}
    return flat, instanced, {"origins": origins, "directions": directions, "convex": convex, **{
        k: v for k, v in oracles.items()}}


CONFIGS = [("wrt", b.value, "binary") for b in Builder] + [("wrt", b, layout) for b in ("sah", "lbvh")
                                                           for layout in ("compact", "wide", "wide8")]
CONFIGS += [("warp", b, "binary") for b in WARP_BUILDERS]


@pytest.mark.parametrize("instanced", [False, True], ids=["flat", "instanced"])
@pytest.mark.parametrize("accel, builder, layout", CONFIGS, ids=[":".join(c) for c in CONFIGS])
def test_rays_at_edges_and_vertices_of_closed_meshes_never_leak_and_any_hit_agrees(accel, builder, layout,
                                                                                    instanced):
    """Rays from inside each mesh (and from outside, facing the faces met there) aimed exactly at vertices, edge
    midpoints and random edge points, computed in float64 and rounded to float32: every one hits (wrt; ``wp.Mesh``
    is not watertight, README), at or before its target on the convex meshes, at the float64 oracle's ``t`` within
    the rounding of the rays' and instances' float32 coordinates. And ``occluded`` answers as ``trace`` does, with
    ``t_max = inf``, with ``t_max`` at the hit's ``t`` (no hit: nothing lies before the first), one ulp past it and
    with ``t_min`` at it (hits past a limit at a hit's own ``t`` are a known limit, README: only agreement is asked
    here). Instances and the layouts other than binary trace each mesh under a rotation, a non-uniform scale and a
    mirror (a negative determinant), the two-level traversal through the moved ray, the others flattened."""
    flat, instanced_scene, rays = closed_mesh_scenes()
    scene = instanced_scene if instanced else flat
    oracle = rays["instanced" if instanced else "flat"]
    o, d = rays["origins"], rays["directions"]
    query = {"accel": accel, "builder": builder, "layout": layout}
    hits = wrt.trace(scene, o, d, **query)
    if accel == "wrt":
        assert hits.hit.all(), f"{np.count_nonzero(~hits.hit)} of {len(o)} rays leaked"
        late = hits.t > 1 + oracle["slack"]
        assert not (late & rays["convex"]).any(), f"{np.count_nonzero(late & rays['convex'])} hit past the target"
    hit = hits.hit
    off = hit & oracle["clear"] & (np.abs(hits.t - oracle["t"]) > oracle["slack"])
    assert not off.any(), (np.flatnonzero(off)[:5], hits.t[off][:5], oracle["t"][off][:5])
    np.testing.assert_array_equal(wrt.occluded(scene, o, d, **query), hit)
    at = np.where(hit, hits.t, np.inf).astype(np.float32)
    assert not wrt.trace(scene, o, d, t_max=at, **query).hit.any()
    assert not wrt.occluded(scene, o, d, t_max=at, **query).any()
    for limits in ({"t_max": np.nextafter(at, np.float32(np.inf))}, {"t_min": at}):
        again = wrt.trace(scene, o, d, **limits, **query)
        np.testing.assert_array_equal(wrt.occluded(scene, o, d, **limits, **query), again.hit, str(limits.keys()))
        kept = again.hit & hit
        assert (again.t[kept] >= hits.t[kept]).all()  # nothing before the first hit
