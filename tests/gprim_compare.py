"""Ray-by-ray comparison of a gprim stage traced analytically and as a fine tessellation (:mod:`gprim_stages`).

The tessellation's vertices lie on the surface, so the two surfaces are within ``dev`` of each other: a few sagittas
of a chord, ``3 (1 - cos(pi / segments))`` in the shape's canonical space, times the largest stretch of its
canonical-to-world map. A ray is *robust* when the analytic hits of six copies of it, moved by ``2 dev`` along each
world axis, agree with it on hit or miss, on the prim and instance hit, and on the normal (within 45 degrees): it
lies away from silhouettes, rims and the surface near its origin. On robust rays the two scenes must agree on hit or
miss, on the prim and instance hit, on ``t`` within the spread of the moved copies' ``t`` (how far ``t`` moves when
the surface moves by ``dev``) and on the side hit (front or back, and so the facing of the normal). Any-hit queries
must agree with the closest hit: nothing before it, something just past it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import warp as wp
from gprim_stages import gprim_rays, placed_shapes, write_stage

import wrt
from wrt.scene import DeviceScene
from wrt.shade import shape_frame
from wrt.transforms import normal_to_world

COORD_ULPS = 64  # float32 ulps of the coordinates a hit is computed from, on top of the tessellation error


@wp.kernel
def hit_normals_kernel(
    scene: DeviceScene,
    prims: wp.array[wp.int32],
    instances: wp.array[wp.int32],
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    ts: wp.array[float],
    # outputs
    normals: wp.array[wp.vec3],
):
    """Unit world-space front normal of each hit (geometry id ``prims[i]``, -1 for a miss: zero), as shading sees
    it: a shape's outward normal (inward when leftHanded), a triangle's winding normal."""
    i = wp.tid()
    prim = prims[i]
    if prim < 0:
        normals[i] = wp.vec3(0.0)
        return
    instance = instances[i]
    n = wp.vec3(0.0)
    if prim >= scene.num_prims:
        p, n_shape, reach, err = shape_frame(scene, prim, instance, origins[i], directions[i], ts[i])
        n = n_shape
    else:
        a = scene.points[scene.indices[prim, 0]]
        b = scene.points[scene.indices[prim, 1]]
        c = scene.points[scene.indices[prim, 2]]
        n = wp.cross(b - a, c - a)
        if instance >= 0:
            n = normal_to_world(scene.world_to_local[instance], n)
    normals[i] = wp.normalize(n)


def hit_normals(scene, hits, origins, directions) -> np.ndarray:
    """``(N, 3)`` float64 unit front normals of ``hits`` (zero on a miss)."""
    device = "cpu"
    ds = scene.to_device(device)
    n = len(hits.t)
    out = wp.zeros(n, dtype=wp.vec3, device=device)
    wp.launch(hit_normals_kernel, n, inputs=[
        ds, wp.array(hits.local_prim.astype(np.int32), dtype=wp.int32, device=device),
        wp.array(hits.instance.astype(np.int32), dtype=wp.int32, device=device),
        wp.array(origins.astype(np.float32), dtype=wp.vec3, device=device),
        wp.array(directions.astype(np.float32), dtype=wp.vec3, device=device),
        wp.array(np.where(hits.prim >= 0, hits.t, 0.0).astype(np.float32), dtype=float, device=device),
    ], outputs=[out], device=device)
    return out.numpy().astype(np.float64)


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path, **kwargs)


def shape_deviation(segments: int) -> float:
    """How far a tessellation of ``segments`` strays from the canonical shape (radius 1): a few chord sagittas."""
    return 3.0 * (1.0 - math.cos(math.pi / segments))


def compare_stage(path: str, seed: int, n_rays: int, segments: int) -> dict:
    """Writes stage ``seed`` at ``path``, traces ``n_rays`` rays against it analytic and tessellated; returns counts
    and the rays of each kind of disagreement (see the module docstring)."""
    info = write_stage(path, seed)
    analytic = load(path)
    tess = load(path, tessellate_gprims=segments)
    out = dict(info, rays=0, robust=0, both_hit=0, problems={})
    placed = placed_shapes(analytic)
    if not placed:
        out["tess_triangles"] = len(tess.triangles()[1])
        return out
    rng = np.random.default_rng(seed + 1)
    o, d, aimed = gprim_rays(analytic, rng, n_rays)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    o, d = o32.astype(np.float64), d32.astype(np.float64)
    out["rays"] = len(o)

    # Per ray: the tessellation error and coordinate rounding of the shape it was aimed at and the shape it hit.
    stretch = np.array([np.linalg.norm(m[:3, :3], 2) for m, _ in placed])
    # The smallest world size of each shape: a flat one's in its plane.
    size = np.array([np.linalg.svd(m[:3, :2] if shape.kind in ("plane", "disk") else m[:3, :3])[1].min()
                     for m, shape in placed])
    reach = np.array([np.abs(m[:3, 3]).max() + s * (2.0 + float(shape.params[0]))
                      for (m, shape), s in zip(placed, stretch)])
    a = wrt.trace(analytic, o32, d32)
    t_pts = np.where(a.hit, a.t, 0.0)[:, None] * d
    eps = np.finfo(np.float32).eps
    coords = np.maximum(np.abs(o).max(1), np.abs(o + t_pts).max(1))
    dev = shape_deviation(segments) * stretch[aimed] + COORD_ULPS * eps * (reach[aimed] + coords)
    shape_rows = placed_index(analytic, a)
    hit_rows = shape_rows >= 0
    dev[hit_rows] = np.maximum(dev[hit_rows], shape_deviation(segments) * stretch[shape_rows[hit_rows]]
                               + COORD_ULPS * eps * (reach[shape_rows[hit_rows]] + coords[hit_rows]))
    delta = 2.0 * dev
    # Moved copies must stay near the ray: shapes that float32 coordinates cannot resolve to a tenth of their size
    # (1e-5 wide at 5 from the origin, say) are left out.
    resolved = delta < 0.1 * size[aimed]
    resolved[hit_rows] &= delta[hit_rows] < 0.1 * size[shape_rows[hit_rows]]

    t = wrt.trace(tess, o32, d32)
    na = hit_normals(analytic, a, o, d)
    nt = hit_normals(tess, t, o, d)
    pa, ia = analytic.hit_paths(a)
    pt, it = tess.hit_paths(t)

    # Robust rays: six copies moved by delta along the world axes agree with the ray.
    robust = resolved.copy()
    spread = np.zeros(len(o))
    for axis in range(3):
        for sign in (-1.0, 1.0):
            shift = np.zeros((len(o), 3))
            shift[:, axis] = sign * delta
            o_moved = (o + shift).astype(np.float32)
            b = wrt.trace(analytic, o_moved, d32)
            nb = hit_normals(analytic, b, o_moved.astype(np.float64), d)
            pb, ib = analytic.hit_paths(b)
            robust &= (b.hit == a.hit) & (pb == pa) & (ib == ia)
            both = a.hit & b.hit
            robust[both] &= np.einsum("ij,ij->i", na[both], nb[both]) > math.cos(math.pi / 4)
            spread[both] = np.maximum(spread[both], np.abs(b.t[both] - a.t[both]))
    out["robust"] = int(robust.sum())
    both = robust & a.hit & t.hit
    out["both_hit"] = int(both.sum())
    dlen = np.linalg.norm(d, axis=1)
    t_tol = spread + dev / dlen
    front_a = np.einsum("ij,ij->i", na, d) < 0
    front_t = np.einsum("ij,ij->i", nt, d) < 0
    problems = {
        "hit_miss": robust & (a.hit != t.hit),
        "t": both & ~(np.abs(np.where(both, a.t - t.t, 0.0)) <= t_tol),
        "paths": both & ((pa != pt) | (ia != it)),
        "side": both & (front_a != front_t),
        "normal": both & ~(np.einsum("ij,ij->i", na, nt) > 0.5),
    }
    # Any-hit queries against the closest hit: nothing before it, something just past it; misses stay misses.
    for name, scene, hits in (("analytic", analytic, a), ("tess", tess, t)):
        before = np.where(hits.hit, hits.t * (1.0 - 1e-3), np.inf).astype(np.float32)
        blocked = wrt.occluded(scene, o32, d32, t_max=before)
        problems[f"occluded_before_{name}"] = hits.hit & (hits.t > 0) & blocked
        after = np.where(hits.hit, hits.t * (1.0 + 1e-3) + 1e-30, np.inf).astype(np.float32)
        blocked = wrt.occluded(scene, o32, d32, t_max=after)
        problems[f"occluded_after_{name}"] = blocked != hits.hit
    out["problems"] = {k: np.flatnonzero(v) for k, v in problems.items() if v.any()}
    out["data"] = dict(o=o, d=d, a=a, t=t, na=na, nt=nt, t_tol=t_tol, dev=dev, aimed=aimed)
    return out


def placed_index(scene, hits) -> np.ndarray:
    """Row of :func:`placed_shapes` of each hit on an analytic shape, -1 elsewhere."""
    first = scene.num_geometry_triangles
    n_world = len(scene.shapes)
    per_proto = [len(p.shapes) for p in scene.prototypes]
    proto_start = np.concatenate([[0], np.cumsum(per_proto)]).astype(np.int64)
    inst_start = n_world + np.concatenate(
        [[0], np.cumsum([per_proto[p] for p in scene.instances.prototype])]).astype(np.int64)
    out = np.full(len(hits.t), -1, np.int64)
    for i in np.flatnonzero(hits.hit & (hits.local_prim >= first)):
        j = int(hits.local_prim[i]) - first
        inst = int(hits.instance[i])
        if inst < 0:
            out[i] = j
        else:
            proto = int(scene.instances.prototype[inst])
            out[i] = inst_start[inst] + (j - n_world - proto_start[proto])
    return out
