"""Trial builder (GPU_NOTES row 58): a spatial-split BVH (SBVH; Stich, Friedrich and Dietrich, "Spatial Splits in
Bounding Volume Hierarchies", HPG 2009), built level by level with numpy on the host, so its traversal speed can be
measured before any of it is written as Warp kernels.

Each level handles every open node at once. A node tries the best binned object split (centroid bins, as
``wrt.bvh.binned``) and, where the two children of that split overlap by more than ``alpha`` times the root's
area, the best spatial split: ``bins`` equal slabs of the node's box per axis, each reference clipped to every
slab it crosses (chopped binning), entry and exit counts per slab. A spatial split sends references that cross its
plane to both sides, each clipped to its side (Sutherland-Hodgman, ``wrt.bvh.presplit.clipped_bounds``), unless
one side alone is cheaper ("reference unsplitting", decided here per reference against the split's own boxes).
Leaves follow the SAH rule of ``wrt.bvh.common.choose_action``, and the depth guarantee of that module holds: a
node whose split would break it is halved. Spatial splits stop once the references outnumber the triangles
``budget`` times.

The result is a ``FlatBvh`` whose ``prim_ids`` may name a triangle in several leaves, as pre-split trees do, so
every layout conversion and traversal takes it unchanged.

    python benchmarks/sbvh_trial.py chess_set --alphas 1e-5,1e-6   # SAH cost and size against the shipped tree
    python benchmarks/gpu_traversal_ab.py --trees 8:1:6,sbvh:1e-5     # traversal speed beside it
"""

from __future__ import annotations

import time

import numpy as np
import warp as wp

from wrt.bvh.common import MAX_DEPTH
from wrt.bvh.layout import FlatBvh
from wrt.bvh.presplit import clipped_bounds, widened
from wrt.bvh.stats import half_areas

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.kernel
def clip_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    prims: wp.array[wp.int32],
    lo: wp.array[wp.vec3],
    hi: wp.array[wp.vec3],
    out_lo: wp.array[wp.vec3],
    out_hi: wp.array[wp.vec3],
):
    """Bounds of triangle ``prims[i]`` inside the box ``[lo[i], hi[i]]``, widened by their rounding
    (``presplit.widened``) and clamped to the box; the box itself where rounding leaves nothing (conservative, as
    ``presplit``)."""
    i = wp.tid()
    p = prims[i]
    b_lo = lo[i]
    b_hi = hi[i]
    a = points[indices[p, 0]]
    b = points[indices[p, 1]]
    c = points[indices[p, 2]]
    r = clipped_bounds(a, b, c, b_lo, b_hi)
    if r[0] <= r[3] and r[1] <= r[4] and r[2] <= r[5]:
        tri_lo = wp.min(wp.min(a, b), c)
        tri_hi = wp.max(wp.max(a, b), c)
        c_lo, c_hi = widened(wp.vec3(r[0], r[1], r[2]), wp.vec3(r[3], r[4], r[5]), tri_lo, tri_hi)
        out_lo[i] = wp.max(c_lo, b_lo)
        out_hi[i] = wp.min(c_hi, b_hi)
    else:
        out_lo[i] = b_lo
        out_hi[i] = b_hi


class Clipper:
    """Runs ``clip_kernel`` on host arrays, on ``device`` (a GPU clips the chopped bins of a 1M-triangle scene in
    a fraction of the host's time)."""

    def __init__(self, points: np.ndarray, indices: np.ndarray, device):
        self.device = wp.get_device(device)
        self.points = wp.array(points, dtype=wp.vec3, device=self.device)
        self.indices = wp.array(indices, dtype=wp.int32, device=self.device)

    def __call__(self, prims: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = len(prims)
        if n == 0:
            return lo.copy(), hi.copy()
        d = self.device
        out_lo = wp.empty(n, dtype=wp.vec3, device=d)
        out_hi = wp.empty(n, dtype=wp.vec3, device=d)
        wp.launch(clip_kernel, n, inputs=[self.points, self.indices, wp.array(prims.astype(np.int32), device=d),
                                          wp.array(lo, dtype=wp.vec3, device=d), wp.array(hi, dtype=wp.vec3, device=d)],
                  outputs=[out_lo, out_hi], device=d)
        return out_lo.numpy(), out_hi.numpy()


def ceil_log2(n: np.ndarray) -> np.ndarray:
    return np.ceil(np.log2(np.maximum(n, 1))).astype(np.int64)


def sweep(blo, bhi, left_counts, right_counts):
    """SAH numerators ``A(L) N(L) + A(R) N(R)`` of the ``B - 1`` planes between ``B`` bins (``inf`` where a side is
    empty), and the two sides' boxes, for ``(K, B, 3)`` bin boxes and ``(K, B - 1)`` side counts."""
    llo = np.minimum.accumulate(blo, axis=1)[:, :-1]
    lhi = np.maximum.accumulate(bhi, axis=1)[:, :-1]
    rlo = np.minimum.accumulate(blo[:, ::-1], axis=1)[:, ::-1][:, 1:]
    rhi = np.maximum.accumulate(bhi[:, ::-1], axis=1)[:, ::-1][:, 1:]
    cost = half_areas(llo, lhi) * left_counts + half_areas(rlo, rhi) * right_counts
    cost[(left_counts == 0) | (right_counts == 0)] = np.inf
    return cost, llo, lhi, rlo, rhi


def bin_boxes(keys, lo, hi, size):
    blo = np.full((3, size), np.inf, np.float32)
    bhi = np.full((3, size), -np.inf, np.float32)
    grow_bins(blo, bhi, keys, lo, hi)
    return blo, bhi


def grow_bins(blo, bhi, keys, lo, hi):
    """Bins ``keys`` grown by the boxes ``[lo, hi]``; bins are ``(3, size)`` (numpy's ``ufunc.at`` is several times
    faster on one-dimensional arrays)."""
    for c in range(3):
        np.minimum.at(blo[c], keys, np.ascontiguousarray(lo[:, c]))
        np.maximum.at(bhi[c], keys, np.ascontiguousarray(hi[:, c]))


def spatial_bins(planes: np.ndarray, node: np.ndarray, x: np.ndarray, upper: bool, bins: int) -> np.ndarray:
    """Slab of each coordinate ``x`` in its node's planes (``(K, bins + 1)``): for a lower bound the last slab
    starting at or below it, for an upper bound the first slab ending at or above it."""
    p = planes[node]
    if upper:
        b = (p[:, 1:bins] < x[:, None]).sum(axis=1)  # first j with x <= planes[j + 1]
    else:
        b = (p[:, 1:bins] <= x[:, None]).sum(axis=1)  # last j with planes[j] <= x
    return b


def build_sbvh(points, indices, *, bins: int = 32, leaf_size: int = 8, traversal_cost: float = 1.0,
               intersection_cost: float = 1.0, alpha: float = 1e-5, budget: float = 2.0,
               unsplit: bool = True, clip_device="cpu", log=None) -> FlatBvh:
    """The SBVH of the triangles (see module docstring) as a host ``FlatBvh``, with ``sbvh_stats`` counting its
    spatial splits, object splits, halvings and leaves. ``alpha``: the object split's overlap, as a fraction of
    the root's area, above which spatial splits are tried; ``budget``: references per triangle at which they
    stop; ``clip_device``: where the clipping kernel runs; ``log``: called with a line per level."""
    start_time = time.perf_counter()
    points = np.ascontiguousarray(points, np.float32).reshape(-1, 3)
    indices = np.ascontiguousarray(indices, np.int32).reshape(-1, 3)
    clip = Clipper(points, indices, clip_device)
    tri = points[indices]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    prim = np.arange(len(indices), dtype=np.int64)
    node = np.zeros(len(indices), np.int64)  # refs sorted by node
    ids = np.zeros(1, np.int64)  # output id of each open node
    depth = 0
    out_lo, out_hi, out_lf, out_pc = [], [], [], []  # per level: (ids, values)
    leaf_slots = []  # prim arrays in slot order
    next_slot = 0
    total_nodes = 1
    root_area = None
    n_tri = len(indices)
    stats = {"spatial": 0, "object": 0, "halve": 0, "leaves": 0}
    while len(ids):
        k_nodes = len(ids)
        counts = np.bincount(node, minlength=k_nodes)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        nlo = np.minimum.reduceat(lo, starts, axis=0)
        nhi = np.maximum.reduceat(hi, starts, axis=0)
        out_lo.append((ids, nlo))
        out_hi.append((ids, nhi))
        area = half_areas(nlo, nhi)
        if root_area is None:
            root_area = area[0]
        cen = 0.5 * (lo + hi)
        clo = np.minimum.reduceat(cen, starts, axis=0)
        chi = np.maximum.reduceat(cen, starts, axis=0)

        # Best object split per node.
        obj_cost = np.full(k_nodes, np.inf)
        obj = np.zeros((k_nodes, 2), np.int64)  # axis, plane
        obj_boxes = np.zeros((k_nodes, 4, 3), np.float32)
        obj_counts = np.zeros((k_nodes, 2), np.int64)
        obj_bin = np.zeros((3, len(node)), np.int64)
        for axis in range(3):
            ext = (chi[:, axis] - clo[:, axis]).astype(np.float64)
            scale = np.where(ext > 0, bins / np.where(ext > 0, ext, 1.0), 0.0)
            b = np.floor((cen[:, axis] - clo[node, axis]) * scale[node]).astype(np.int64)
            b = np.clip(b, 0, bins - 1)
            obj_bin[axis] = b
            keys = node * bins + b
            bc = np.bincount(keys, minlength=k_nodes * bins).reshape(k_nodes, bins)
            blo, bhi = bin_boxes(keys, lo, hi, k_nodes * bins)
            lc = np.cumsum(bc, axis=1)[:, :-1]
            cost, llo, lhi, rlo, rhi = sweep(blo.T.reshape(k_nodes, bins, 3), bhi.T.reshape(k_nodes, bins, 3),
                                             lc, counts[:, None] - lc)
            j = np.argmin(cost, axis=1)
            c = cost[np.arange(k_nodes), j]
            better = c < obj_cost
            obj_cost[better] = c[better]
            obj[better] = np.stack([np.full(better.sum(), axis), j[better]], axis=1)
            r = np.arange(k_nodes)[better]
            jb = j[better]
            obj_boxes[better] = np.stack([llo[r, jb], lhi[r, jb], rlo[r, jb], rhi[r, jb]], axis=1)
            obj_counts[better] = np.stack([lc[r, jb], counts[better] - lc[r, jb]], axis=1)

        # Best spatial split where the object split's children overlap.
        overlap = half_areas(np.maximum(obj_boxes[:, 0], obj_boxes[:, 2]), np.minimum(obj_boxes[:, 1], obj_boxes[:, 3]))
        total_refs = next_slot + len(node)
        try_spatial = (overlap > alpha * root_area) & (counts > 1) & (total_refs < budget * n_tri)
        sp_cost = np.full(k_nodes, np.inf)
        sp = np.zeros((k_nodes, 2), np.int64)
        sp_counts = np.zeros((k_nodes, 2), np.int64)
        sp_boxes = np.zeros((k_nodes, 4, 3), np.float32)
        sp_planes = np.zeros((3, k_nodes, bins + 1), np.float32)
        if try_spatial.any():
            in_sp = try_spatial[node]
            ridx = np.nonzero(in_sp)[0]
            rn = node[ridx]
            for axis in range(3):
                w = (nhi[:, axis].astype(np.float64) - nlo[:, axis]) / bins
                planes = (nlo[:, axis, None] + w[:, None] * np.arange(bins + 1)).astype(np.float32)
                planes[:, 0] = nlo[:, axis]
                planes[:, bins] = nhi[:, axis]
                planes = np.maximum.accumulate(planes, axis=1)
                sp_planes[axis] = planes
                b0 = spatial_bins(planes, rn, lo[ridx, axis], False, bins)
                b1 = np.maximum(spatial_bins(planes, rn, hi[ridx, axis], True, bins), b0)
                entry = np.bincount(rn * bins + b0, minlength=k_nodes * bins).reshape(k_nodes, bins)
                exit_ = np.bincount(rn * bins + b1, minlength=k_nodes * bins).reshape(k_nodes, bins)
                single = b0 == b1
                blo, bhi = bin_boxes(rn[single] * bins + b0[single], lo[ridx[single]], hi[ridx[single]],
                                     k_nodes * bins)
                multi = np.nonzero(~single)[0]
                if len(multi):
                    reps = b1[multi] - b0[multi] + 1
                    pair_ref = np.repeat(multi, reps)
                    offs = np.repeat(np.cumsum(reps) - reps, reps)
                    slab = b0[pair_ref] + (np.arange(len(pair_ref)) - offs)
                    r = ridx[pair_ref]
                    slo, shi = lo[r].copy(), hi[r].copy()
                    slo[:, axis] = np.maximum(slo[:, axis], planes[rn[pair_ref], slab])
                    shi[:, axis] = np.minimum(shi[:, axis], planes[rn[pair_ref], slab + 1])
                    clo_, chi_ = clip(prim[r], slo, shi)
                    keys = rn[pair_ref] * bins + slab
                    grow_bins(blo, bhi, keys, clo_, chi_)
                lc = np.cumsum(entry, axis=1)[:, :-1]
                rc = np.cumsum(exit_[:, ::-1], axis=1)[:, ::-1][:, 1:]
                cost, llo, lhi, rlo, rhi = sweep(blo.T.reshape(k_nodes, bins, 3), bhi.T.reshape(k_nodes, bins, 3),
                                                 lc, rc)
                cost[(lc >= counts[:, None]) | (rc >= counts[:, None])] = np.inf  # every reference on one side
                cost[~try_spatial] = np.inf
                j = np.argmin(cost, axis=1)
                c = cost[np.arange(k_nodes), j]
                better = c < sp_cost
                sp_cost[better] = c[better]
                r_ = np.arange(k_nodes)[better]
                jb = j[better]
                sp[better] = np.stack([np.full(better.sum(), axis), jb], axis=1)
                sp_boxes[better] = np.stack([llo[r_, jb], lhi[r_, jb], rlo[r_, jb], rhi[r_, jb]], axis=1)
                sp_counts[better] = np.stack([lc[r_, jb], rc[r_, jb]], axis=1)

        use_sp = sp_cost < obj_cost
        best_cost = np.where(use_sp, sp_cost, obj_cost)
        n_left = np.where(use_sp, sp_counts[:, 0], obj_counts[:, 0])
        n_right = np.where(use_sp, sp_counts[:, 1], obj_counts[:, 1])
        has_split = np.isfinite(best_cost)
        leaf_ok = counts <= leaf_size
        sah_leaf = leaf_ok & has_split & (area > 0)
        leaf_ok[sah_leaf] = (intersection_cost * counts[sah_leaf]
                             <= traversal_cost + intersection_cost * best_cost[sah_leaf] / area[sah_leaf])
        is_leaf = (counts <= 1) | leaf_ok
        split_ok = has_split & (depth + 1 + ceil_log2(np.maximum(n_left, n_right)) <= MAX_DEPTH - 1)
        action = np.where(is_leaf, 0, np.where(split_ok, 1, 2))  # leaf, split, halve
        spatial = (action == 1) & use_sp
        stats["spatial"] += int(spatial.sum())
        stats["object"] += int(((action == 1) & ~use_sp).sum())
        stats["halve"] += int((action == 2).sum())
        stats["leaves"] += int((action == 0).sum())

        # Leaves: their references take the next slots in node order.
        leaf_nodes = np.nonzero(action == 0)[0]
        ref_leaf = action[node] == 0
        leaf_first = next_slot + np.concatenate([[0], np.cumsum(counts[leaf_nodes])[:-1]]) if len(leaf_nodes) else []
        out_lf.append((ids[leaf_nodes], np.asarray(leaf_first, np.int64)))
        out_pc.append((ids[leaf_nodes], counts[leaf_nodes]))
        leaf_slots.append(prim[ref_leaf])
        next_slot += int(ref_leaf.sum())

        # Inner nodes: children in pairs after every id so far.
        inner = np.nonzero(action != 0)[0]
        child_of = np.full(k_nodes, -1, np.int64)
        child_of[inner] = np.arange(len(inner)) * 2
        out_lf.append((ids[inner], total_nodes + child_of[inner]))
        out_pc.append((ids[inner], np.zeros(len(inner), np.int64)))
        new_ids = total_nodes + np.arange(2 * len(inner))
        total_nodes += 2 * len(inner)

        keep = ~ref_leaf
        rn = node[keep]
        ri = np.nonzero(keep)[0]
        act = action[rn]
        side = np.zeros(len(ri), np.int64)  # 0 left, 1 right, 2 both
        # Object splits: centroid bin at or below the plane goes left.
        o = act == 1
        o &= ~use_sp[rn]
        ax = obj[rn[o], 0]
        side[o] = (obj_bin[ax, ri[o]] > obj[rn[o], 1]).astype(np.int64)
        # Halving: the first half of the node's references (in their current order) goes left.
        h = act == 2
        rank = ri[h] - starts[rn[h]]
        side[h] = (rank >= counts[rn[h]] // 2).astype(np.int64)
        # Spatial splits.
        s = np.nonzero(act == 1)[0]
        s = s[use_sp[rn[s]]]
        if len(s):
            sn = rn[s]
            ax = sp[sn, 0]
            plane = sp_planes[ax, sn, sp[sn, 1] + 1]
            rlo_ax = lo[ri[s], ax]
            rhi_ax = hi[ri[s], ax]
            side_s = np.where(rhi_ax <= plane, 0, np.where(rlo_ax >= plane, 1, 2))
            if unsplit:
                st = np.nonzero(side_s == 2)[0]
                stn = sn[st]
                blo_, bhi_ = lo[ri[s[st]]], hi[ri[s[st]]]
                llo_, lhi_, rlo_, rhi_ = (sp_boxes[stn, q] for q in range(4))
                nl, nr = sp_counts[stn, 0], sp_counts[stn, 1]
                a_l, a_r = half_areas(llo_, lhi_), half_areas(rlo_, rhi_)
                c_both = a_l * nl + a_r * nr
                c_left = half_areas(np.minimum(llo_, blo_), np.maximum(lhi_, bhi_)) * nl + a_r * (nr - 1)
                c_right = a_l * (nl - 1) + half_areas(np.minimum(rlo_, blo_), np.maximum(rhi_, bhi_)) * nr
                choice = np.where((c_left < c_both) & (c_left <= c_right), 0,
                                  np.where(c_right < c_both, 1, 2))
                trial = side_s.copy()
                trial[st] = choice
                # A node where unsplitting would leave one child with every reference keeps its duplicates.
                left_n = np.bincount(sn, weights=(trial != 1), minlength=k_nodes)
                right_n = np.bincount(sn, weights=(trial != 0), minlength=k_nodes)
                bad = (left_n >= counts) | (right_n >= counts) | (left_n == 0) | (right_n == 0)
                trial[bad[sn] & (side_s == 2)] = 2
                side_s = trial
            side[s] = side_s
        both = side == 2
        bi = ri[both]
        n_both = len(bi)
        if n_both:
            bn = node[bi]
            ax = sp[bn, 0]
            plane = sp_planes[ax, bn, sp[bn, 1] + 1]
            l_hi = hi[bi].copy()
            l_hi[np.arange(n_both), ax] = plane
            r_lo = lo[bi].copy()
            r_lo[np.arange(n_both), ax] = plane
            llo2, lhi2 = clip(prim[bi], lo[bi], l_hi)
            rlo2, rhi2 = clip(prim[bi], r_lo, hi[bi])
        one = ~both
        new_node = np.concatenate([child_of[rn[one]] + side[one],
                                   child_of[node[bi]], child_of[node[bi]] + 1])
        new_lo = np.concatenate([lo[ri[one]], llo2, rlo2]) if n_both else lo[ri[one]]
        new_hi = np.concatenate([hi[ri[one]], lhi2, rhi2]) if n_both else hi[ri[one]]
        new_prim = np.concatenate([prim[ri[one]], prim[bi], prim[bi]])
        order = np.argsort(new_node, kind="stable")
        node, lo, hi, prim = new_node[order], new_lo[order], new_hi[order], new_prim[order]
        ids = new_ids
        depth += 1
        if log:
            log(f"  level {depth}: {k_nodes} nodes, {len(node)} open references, {n_both} duplicated")

    lowers = np.empty((total_nodes, 3), np.float32)
    uppers = np.empty((total_nodes, 3), np.float32)
    left_first = np.empty(total_nodes, np.int32)
    prim_count = np.empty(total_nodes, np.int32)
    for (i, v) in out_lo:
        lowers[i] = v
    for (i, v) in out_hi:
        uppers[i] = v
    for (i, v) in out_lf:
        left_first[i] = v
    for (i, v) in out_pc:
        prim_count[i] = v
    bvh = FlatBvh(lowers=lowers, uppers=uppers, left_first=left_first, prim_count=prim_count,
                  prim_ids=np.concatenate(leaf_slots).astype(np.int32), builder="sbvh",
                  build_seconds=time.perf_counter() - start_time)
    bvh.points, bvh.indices = points, indices
    bvh.sbvh_stats = stats
    return bvh


def main() -> None:
    import argparse

    from wrt.bench import asset_path
    from wrt.bvh import build_bvh
    from wrt.procedural import displaced_sphere_scene
    from wrt.usd import load_usd

    parser = argparse.ArgumentParser(description="SAH cost and size of SBVH trees against the accelerators' SAH "
                                     "tree (pre-split references), on the host.",
                                     allow_abbrev=False)
    parser.add_argument("scene", help="sphere (a displaced sphere) or a shared asset id, e.g. chess_set")
    parser.add_argument("--sphere", type=int, default=2_000_000, help="triangles of the displaced sphere")
    parser.add_argument("--alphas", default="1e-5", help="comma list of overlap thresholds (fraction of root area)")
    args = parser.parse_args()
    wp.config.quiet = True
    scene = displaced_sphere_scene(args.sphere) if args.scene == "sphere" else load_usd(asset_path(args.scene))
    points, indices = scene.triangles()
    ref = build_bvh(points, indices, "sah", presplit=6, device="cpu")
    print(f"{args.scene}: {len(indices)} triangles")
    print(f"  sah presplit 6: {ref.build_seconds:.1f} s, {ref.num_nodes} nodes, {len(ref.prim_ids)} slots, "
          f"SAH {ref.stats(epo_samples=0)['sah_cost']:.3f}")
    for alpha in (float(a) for a in args.alphas.split(",")):
        bvh = build_sbvh(points, indices, alpha=alpha)
        bvh.validate()
        print(f"  sbvh alpha {alpha:g}: {bvh.build_seconds:.1f} s, {bvh.num_nodes} nodes, {len(bvh.prim_ids)} "
              f"slots, SAH {bvh.stats(epo_samples=0)['sah_cost']:.3f}, {bvh.sbvh_stats}")


if __name__ == "__main__":
    main()
