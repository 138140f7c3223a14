"""GPU build speed of wrt's ``lbvh`` and ``ploc`` against ``wp.Mesh(bvh_constructor="lbvh")`` on a procedurally
generated 10M-triangle mesh, and the SAH cost of the trees against ``binned_sah``. Self-contained: it makes its own
mesh, prints markdown tables and PASS/MISS lines for the issue's GPU targets, and finishes in a few minutes.

Timings are wall clock around the build with ``wp.synchronize_device`` before and after, after warm-up builds
(kernel compilation excluded), ``--repeats`` runs each, alternating between builders; min and median are reported.
wrt's builds are timed twice: "device" stops with the canonical tree in GPU memory (``build_bvh_device``), which
is what ``wp.Mesh`` does; "to host" adds the copy of the tree to numpy (``build_bvh``).

``binned_sah`` is built on ``--binned-device`` (the host CPU by default): its per-node threads make the first levels
of a 10M-triangle build serial, which suits a CPU better than one GPU thread. The builders are deterministic, so the
tree is the same on either device up to float contraction.

Usage (on a CUDA machine)::

    python benchmarks/gpu_build.py                      # 10M triangles on cuda:0
    python benchmarks/gpu_build.py --triangles 2000000 --repeats 3
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
import warp as wp

from wrt.bvh import build_bvh, build_bvh_device
from wrt.bvh.warp_mesh import read_warp_bvh

SPEED_TARGET = 1.5  # wrt lbvh / ploc build time <= 1.5x wp.Mesh(lbvh)
QUALITY_TARGET = 1.10  # ploc SAH cost within 10% of binned_sah


def generated_mesh(n_target: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """About ``n_target`` triangles: a bumpy, jittered UV sphere (closed, uneven triangle sizes towards the poles)."""
    rings = max(int(np.sqrt(n_target / 4)), 2)
    segments = 2 * rings
    theta = np.linspace(0, np.pi, rings + 1, dtype=np.float32)
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False, dtype=np.float32)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    rng = np.random.default_rng(seed)
    r = 1 + 0.05 * np.sin(7 * t) * np.cos(11 * p) + 0.002 * rng.standard_normal(t.shape, dtype=np.float32)
    points = np.stack([r * np.sin(t) * np.cos(p), r * np.sin(t) * np.sin(p), r * np.cos(t)], -1).reshape(-1, 3)
    idx = np.arange((rings + 1) * segments, dtype=np.int32).reshape(rings + 1, segments)
    a, b = idx[:-1], np.roll(idx[:-1], -1, axis=1)
    c, d = idx[1:], np.roll(idx[1:], -1, axis=1)
    tris = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)])
    return points.astype(np.float32), tris.astype(np.int32)


def timed(fn, device) -> float:
    """Seconds ``fn()`` takes, with the device synchronized before and after."""
    wp.synchronize_device(device)
    start = time.perf_counter()
    result = fn()
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    del result
    return seconds


def check(label: str, ok: bool, detail: str) -> None:
    print(f"- {'PASS' if ok else 'MISS'}: {label} ({detail})")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    parser.add_argument("--triangles", type=int, default=10_000_000, help="approximate mesh size")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per builder")
    parser.add_argument("--device", default="cuda:0", help="device of the timed builds")
    parser.add_argument("--binned-device", default="cpu", help="device of the binned_sah reference build")
    parser.add_argument("--skip-quality", action="store_true", help="only time the builds")
    args = parser.parse_args(argv)
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    total_start = time.perf_counter()

    points, indices = generated_mesh(args.triangles)
    n = len(indices)
    print(f"## wrt GPU BVH builds: {n} triangles on {device.alias} ({device.name}), warp-lang {wp.config.version}\n")
    pts = wp.array(points, dtype=wp.vec3, device=device)
    idx_flat = wp.array(indices.reshape(-1), dtype=wp.int32, device=device)
    idx = idx_flat.reshape((-1, 3))
    warp_constructor = "lbvh" if device.is_cuda else "sah"  # wp.Mesh has no CPU lbvh

    builds = {
        f"wp.Mesh {warp_constructor}": lambda: wp.Mesh(pts, idx_flat, bvh_constructor=warp_constructor),
        "wrt lbvh 30-bit (device)": lambda: build_bvh_device(pts, idx, "lbvh", device=device),
        "wrt lbvh 63-bit (device)": lambda: build_bvh_device(pts, idx, "lbvh", morton_bits=63, device=device),
        "wrt ploc (device)": lambda: build_bvh_device(pts, idx, "ploc", device=device),
    }
    # Warm up: compile every kernel on a small mesh, then one full-size run each (allocator, caches).
    small = generated_mesh(10_000)
    for builder in ("lbvh", "ploc"):
        build_bvh_device(small[0], small[1], builder, device=device)
        build_bvh_device(small[0], small[1], builder, morton_bits=63, device=device)
    for fn in builds.values():
        timed(fn, device)
    print(f"warm-up done after {time.perf_counter() - total_start:.1f} s\n", flush=True)

    times = {name: [] for name in builds}
    for _ in range(args.repeats):
        for name, fn in builds.items():
            times[name].append(timed(fn, device))
    for builder in ("lbvh", "ploc"):
        times[f"wrt {builder} (to host)"] = [timed(lambda b=builder: build_bvh(pts, idx, b, device=device), device)]
    reference = min(times[f"wp.Mesh {warp_constructor}"])
    print(f"### Build time, {args.repeats} runs each (to-host rows: 1 run)\n")
    print(f"| build | min ms | median ms | min / wp.Mesh {warp_constructor} |\n|---|---|---|---|")
    for name, values in times.items():
        print(
            f"| {name} | {1e3 * min(values):.1f} | {1e3 * statistics.median(values):.1f} "
            f"| {min(values) / reference:.2f}x |"
        )
    print()
    for name in ("wrt lbvh 30-bit (device)", "wrt ploc (device)"):
        ratio = min(times[name]) / reference
        check(f"{name} <= {SPEED_TARGET}x wp.Mesh({warp_constructor})", ratio <= SPEED_TARGET, f"{ratio:.2f}x")
    sys.stdout.flush()

    if not args.skip_quality:
        print("\n### SAH cost (C_t = C_i = 1; wrt leaf_size 8 with SAH leaf collapse, Warp bvh_leaf_size 4)\n")
        trees = {
            "wrt lbvh 30-bit": build_bvh(pts, idx, "lbvh", device=device),
            "wrt ploc": build_bvh(pts, idx, "ploc", device=device),
        }
        start = time.perf_counter()
        trees[f"wrt binned_sah ({args.binned_device})"] = build_bvh(points, indices, "sah", device=args.binned_device)
        binned_seconds = time.perf_counter() - start
        trees[f"wp.Mesh {warp_constructor}"] = read_warp_bvh(
            wp.Mesh(pts, idx_flat, bvh_constructor=warp_constructor), builder=f"warp:{warp_constructor}"
        )
        print("| tree | SAH cost | nodes | leaves | max depth | mean leaf depth |\n|---|---|---|---|---|---|")
        costs = {}
        for name, tree in trees.items():
            tree.points = tree.indices = None  # SAH only: the EPO estimate would copy 10M triangles to float64
            s = tree.stats()
            costs[name] = s["sah_cost"]
            print(
                f"| {name} | {s['sah_cost']:.2f} | {s['nodes']} | {s['leaves']} | {s['max_depth']} "
                f"| {s['mean_leaf_depth']:.1f} |"
            )
        print(f"\n(binned_sah built on {args.binned_device} in {binned_seconds:.1f} s)\n")
        binned = costs[f"wrt binned_sah ({args.binned_device})"]
        ratio = costs["wrt ploc"] / binned
        check(
            f"ploc SAH within {100 * (QUALITY_TARGET - 1):.0f}% of binned_sah",
            ratio <= QUALITY_TARGET,
            f"{100 * (ratio - 1):+.2f}%",
        )
    print(f"\ntotal {time.perf_counter() - total_start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
