"""How much of a GPU build's wall time is CUDA's memory pool mapping memory (GPU_NOTES row 23).

Part 1 times a 1 GB ``wp.empty`` fresh, after a free and a synchronisation (the pool's default release threshold, 0,
returns the memory to the system there), and right after a free with no synchronisation between (the pool hands
the same memory over). Part 2 times 10M-triangle builds of ``wp.Mesh(lbvh)``, wrt ``ploc`` and wrt ``lbvh`` in one
process, first at the default release threshold, then with the pool keeping 16 GB (for every subject alike).

    python benchmarks/gpu_mempool_probe.py [--triangles 10000000]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def synced_ms(fn):
    """``(milliseconds, result)`` of one synchronised call."""
    wp.synchronize()
    start = time.perf_counter()
    result = fn()
    wp.synchronize()
    return 1e3 * (time.perf_counter() - start), result


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=10_000_000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    wp.config.quiet = True
    wp.init()
    from wrt.bvh import build_bvh_device
    from wrt.procedural import displaced_sphere

    device = wp.get_device("cuda:0")
    print(f"{device.name}, warp {wp.config.version}, release threshold {wp.get_mempool_release_threshold(device)}")
    quarter_gb = (1 << 30) // 4  # int32 elements
    for _ in range(3):
        ms, block = synced_ms(lambda: wp.empty(quarter_gb, dtype=wp.int32, device=device))
        print(f"1 GB, fresh: {ms:.2f} ms")
        del block
        wp.synchronize()
        ms, block = synced_ms(lambda: wp.empty(quarter_gb, dtype=wp.int32, device=device))
        print(f"1 GB, after a free and a synchronisation: {ms:.2f} ms")

        def free_then_allocate():
            nonlocal block
            block = None
            return wp.empty(quarter_gb, dtype=wp.int32, device=device)

        ms, block = synced_ms(free_then_allocate)
        print(f"1 GB, right after a free: {ms:.2f} ms")
        del block
        wp.synchronize()

    points, indices = displaced_sphere(args.triangles)
    pts = wp.array(points, dtype=wp.vec3, device=device)
    idx = wp.array(indices, dtype=wp.int32, device=device)
    subjects = {
        "wp.Mesh lbvh": lambda: wp.Mesh(pts, idx.reshape((-1,)), bvh_constructor="lbvh"),
        "wrt ploc": lambda: build_bvh_device(pts, idx, "ploc", device=device),
        "wrt lbvh": lambda: build_bvh_device(pts, idx, "lbvh", device=device),
    }
    for threshold in (None, 16 << 30):
        if threshold is not None:
            wp.set_mempool_release_threshold(device, threshold)
        print(f"\n{len(indices):,} triangles, release threshold {wp.get_mempool_release_threshold(device)}")
        for name, build in subjects.items():
            build()
            times = [synced_ms(build)[0] for _ in range(args.repeats)]
            print(f"{name}: median {statistics.median(times):.2f} ms, min {min(times):.2f} ms")


if __name__ == "__main__":
    main()
