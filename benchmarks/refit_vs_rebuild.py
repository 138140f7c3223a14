"""Refit or rebuild? Times both for deforming meshes and measures what a refitted tree costs in tracing, to pick
``wrt.animation.REFIT_SAH_LIMIT``.

A displaced sphere is deformed by growing amounts (its displacement waves travel: triangles move along the surface
and away from where the builder grouped them). For each amount it reports, in one run on one device: build time,
refit time, the refitted tree's SAH cost relative to a fresh build, and incoherent-ray throughput of both trees.

Usage: python benchmarks/refit_vs_rebuild.py [--device cpu] [--triangles 100000 1000000] [--rays 200000]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import warp as wp

from wrt.bvh import build_bvh
from wrt.bvh.refit import Refitter
from wrt.bvh.stats import sah_cost
from wrt.cli import positive_int
from wrt.procedural import displaced_sphere
from wrt.rays import random_rays
from wrt.scene import Scene
from wrt.trace import HitBuffer, trace_bvh_kernel


def deform(points: np.ndarray, amount: float) -> np.ndarray:
    """Vertices moved by a swirl whose angle grows with height, ``amount`` radians at the poles."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    a = amount * y
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * x - s * z, y * (1 + 0.2 * amount), s * x + c * z], axis=1).astype(np.float32)


def trace_mrays(device_bvh, rays, device, repeats=5) -> float:
    n = len(rays[0])
    hits = HitBuffer(n, device)
    args = dict(dim=n, inputs=[device_bvh, *rays], outputs=hits.outputs, device=device)
    wp.launch(trace_bvh_kernel, **args)
    times = []
    for _ in range(repeats):
        wp.synchronize_device(device)
        start = time.perf_counter()
        wp.launch(trace_bvh_kernel, **args)
        wp.synchronize_device(device)
        times.append(time.perf_counter() - start)
    return n / statistics.median(times) / 1e6


def timed(fn, repeats=3):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return 1e3 * min(times), out


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--triangles", type=positive_int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--rays", type=positive_int, default=200_000)
    parser.add_argument("--builder", default="sah")
    args = parser.parse_args()
    device = wp.get_device(args.device)
    print(f"device {device.name} ({device}), warp {wp.config.version}, builder {args.builder}\n")
    print("| triangles | deformation | build ms | refit ms | refit SAH / fresh SAH | Mrays/s refit | Mrays/s fresh |")
    print("|---|---|---|---|---|---|---|")
    for n in args.triangles:
        points, indices = displaced_sphere(n)
        bvh = build_bvh(points, indices, args.builder, device=device)
        refitter = Refitter(bvh, bvh.to_device(points, indices, device), device)
        o, d = random_rays(Scene.from_triangles(points * 1.5, indices), args.rays, seed=1)
        for amount in (0.0, 0.25, 0.5, 1.0, 2.0, 4.0):
            moved = deform(points, amount)
            build_ms, fresh = timed(lambda: build_bvh(moved, indices, args.builder, device=device))
            refit_ms, refitted = timed(lambda: refitter.refit(moved, indices))
            rays = [wp.array(o, dtype=wp.vec3, device=device), wp.array(d, dtype=wp.vec3, device=device),
                    wp.zeros(len(o), dtype=float, device=device), wp.full(len(o), np.inf, dtype=float, device=device)]
            ratio = sah_cost(refitted) / sah_cost(fresh)
            m_refit = trace_mrays(refitter.device_bvh, rays, device)
            m_fresh = trace_mrays(fresh.to_device(moved, indices, device), rays, device)
            print(f"| {len(indices):,} | {amount:g} | {build_ms:.1f} | {refit_ms:.1f} | {ratio:.3f} | {m_refit:.2f} "
                  f"| {m_fresh:.2f} |", flush=True)


if __name__ == "__main__":
    main()
