"""A small run of every trace kernel (binary, compact, wide, wide8, TLAS with instances and shapes, wp.Mesh; closest
hit with and without cost counters, and any hit) for ``compute-sanitizer --tool memcheck``: few rays, so it finishes
under the sanitizer's slowdown.

Usage: compute-sanitizer --tool memcheck --error-exitcode 1 python benchmarks/sanitize_trace.py [--device cuda:0]
"""

from __future__ import annotations

import argparse

import numpy as np
import warp as wp

import wrt
from wrt.procedural import displaced_sphere, sensor_scene
from wrt.rays import random_rays
from wrt.trace import HitBuffer, get_accelerator


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--rays", type=int, default=20000)
    args = parser.parse_args()
    mesh = wrt.Scene.from_triangles(*displaced_sphere(20000))
    instanced = sensor_scene(blob_triangles=2000)
    for name, scene, accel, layout in [
        ("binary", mesh, "wrt", "binary"),
        ("compact", mesh, "wrt", "compact"),
        ("wide", mesh, "wrt", "wide"),
        ("wide8", mesh, "wrt", "wide8"),
        ("tlas", instanced, "wrt", "binary"),
        ("wp.Mesh", mesh, "warp", "binary"),
    ]:
        origins, directions = random_rays(scene, args.rays, seed=3)
        acc = get_accelerator(scene, accel, "sah", args.device, layout)
        hits = wrt.trace(scene, origins, directions, accel=accel, device=args.device, layout=layout)
        blocked = wrt.occluded(scene, origins, directions, accel=accel, device=args.device, layout=layout)
        rays = [wp.array(origins, dtype=wp.vec3, device=args.device),
                wp.array(directions, dtype=wp.vec3, device=args.device),
                wp.zeros(len(origins), dtype=float, device=args.device),
                wp.full(len(origins), np.inf, dtype=float, device=args.device)]
        uncounted = HitBuffer(len(origins), args.device)
        acc.intersect(*rays, uncounted, costs=False)
        same = np.array_equal(uncounted.t.numpy(), hits.t)
        print(f"{name:8s} {type(acc).__name__:22s} hits {hits.hit.mean():.3f} "
              f"blocked {np.mean(blocked):.3f} uncounted t identical {same}", flush=True)


if __name__ == "__main__":
    main()
