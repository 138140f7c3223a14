"""Where a GPU build's time goes: every kernel, scan and copy of one ``lbvh`` and one ``ploc`` build (each followed by
its 4-wide collapse) on a displaced sphere, recorded with Warp's CUDA activity timing (``wp.timing_begin``), summed
by activity. The gap between the wall time and the summed GPU time is launch overhead and host round trips.

Usage: python benchmarks/gpu_build_kernels.py [--triangles 10000000] [--device cuda:0]
"""

from __future__ import annotations

import argparse
import collections
import time

import warp as wp

from wrt.bvh import build_bvh_device
from wrt.bvh.collapse import collapse_wide
from wrt.procedural import displaced_sphere


def build_and_collapse(pts, idx, builder: str, device):
    tree = build_bvh_device(pts, idx, builder, device=device)
    return collapse_wide(tree.lowers, tree.uppers, tree.left_first, tree.prim_count, 4)


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--triangles", type=int, default=10_000_000)
    parser.add_argument("--device", default="cuda:0")
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    points, indices = displaced_sphere(args.triangles)
    pts = wp.array(points, dtype=wp.vec3, device=device)
    idx = wp.array(indices, dtype=wp.int32, device=device)
    print(f"{len(indices):,} triangles on {device.alias} ({device.name}), warp {wp.config.version}")
    for builder in ("lbvh", "ploc"):
        build_and_collapse(pts, idx, builder, device)  # compile and warm up
        wp.timing_begin(cuda_filter=wp.TIMING_ALL)
        start = time.perf_counter()
        build_and_collapse(pts, idx, builder, device)
        wp.synchronize_device(device)
        wall = 1e3 * (time.perf_counter() - start)
        results = wp.timing_end()
        totals = collections.defaultdict(lambda: [0, 0.0])
        for r in results:
            totals[r.name][0] += 1
            totals[r.name][1] += r.elapsed
        busy = sum(t for _, t in totals.values())
        print(f"\n### {builder} + 4-wide collapse: {wall:.2f} ms wall, {busy:.2f} ms of GPU activity\n")
        print("| activity | count | ms | share of wall |\n|---|---|---|---|")
        for name, (count, ms) in sorted(totals.items(), key=lambda kv: -kv[1][1]):
            print(f"| {name} | {count} | {ms:.3f} | {ms / wall:.1%} |")


if __name__ == "__main__":
    main()
