"""The lecture's forest on one GPU: 50,000 trees of about 1M triangles each (5e10 rendered triangles), built once
per prototype and rendered at 1920x1080 with shadows. Prints build time, device memory and time per frame as a
markdown table (the lecture quotes 11 minutes for 50B polygons; the target is under 1 second per frame).

Self-contained: it writes the forest with ``scenes/forest.py`` (a ``.usdc`` in a temporary folder: one tree mesh and
a PointInstancer), loads it with ``wrt.load_usd`` (the tree becomes one prototype, the trees 50,000 instances), builds
wrt's two-level BVH (``wrt.tlas``: one BLAS for the tree, one for the ground, a TLAS over the instances) and renders
with the ``whitted`` integrator: one camera ray per pixel, one shadow ray towards the sun per hit, the sky dome as an
unoccluded term. Frames are timed after a warm-up frame (kernel compilation excluded), with the device synchronised
(``wp.ScopedTimer(synchronize=True)`` around the launches: ``frame ms``) and, separately, including the copy of the
image and its AOVs back to the host (``wall ms``).

Device memory: ``accel MB`` is what the two-level BVH holds (``InstancedAccelerator.device_bytes()``: BLAS nodes and
triangles, TLAS nodes, one 3x4 matrix and two ints per instance; ``bytes per instance`` divides all TLAS bytes by the
instances, so the fixed part, about 0.5 KB per BLAS, adds a few bytes to the 120 per instance in small runs: 126 for
``--small``); ``device MB`` is the growth of Warp's CUDA memory
pool over building the renderer (accelerator, shading data, lights), read with ``wp.get_mempool_used_mem_current``
(CPU runs report the accelerator's bytes there too).

Usage::

    python benchmarks/forest_gpu.py                          # the full forest on cuda:0 (a few minutes on an H100)
    python benchmarks/forest_gpu.py --small                  # 200 trees of 5,000 triangles on the CPU, 480x270
    python benchmarks/forest_gpu.py --trees 50000 --tree-triangles 1000000 --frames 5 --image forest.png
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scenes"))

import forest  # noqa: E402  (scenes/forest.py)

import wrt  # noqa: E402
from wrt.trace import get_accelerator  # noqa: E402

SMALL = {"trees": 200, "tree_triangles": 5_000, "width": 480, "height": 270, "device": "cpu", "frames": 2}


def device_used(device) -> int:
    """Bytes in use in the device's memory pool (0 where Warp cannot tell: the CPU, or no mempool)."""
    if device.is_cuda and wp.is_mempool_enabled(device):
        return int(wp.get_mempool_used_mem_current(device))
    return 0


def run(args) -> dict:
    """Generates, loads, builds and renders; returns the measurements."""
    device = wp.get_device(args.device)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(args.keep) if args.keep else Path(folder) / "forest.usdc"
        info = forest.write_forest(path, args.trees, args.tree_triangles, args.seed)
        start = time.perf_counter()
        scene = wrt.load_usd(path)
        load_s = time.perf_counter() - start
    stats = scene.stats()

    # Build: BLAS per prototype, TLAS over the instances, shading data and lights on the device.
    wp.synchronize_device(device)
    before = device_used(device)
    start = time.perf_counter()
    renderer = wrt.Renderer(scene, width=args.width, height=args.height, device=device, builder=args.builder,
                            integrator=args.integrator)
    wp.synchronize_device(device)
    build_s = time.perf_counter() - start
    accel = get_accelerator(scene, "wrt", args.builder, device)
    accel_bytes = accel.device_bytes()
    pool_bytes = device_used(device) - before if device.is_cuda else accel_bytes["total"]

    # Frames: one warm-up (compiles kernels), then timed ones.
    image = renderer.render(spp=1)
    frame_ms, wall_ms = [], []
    for k in range(args.frames):
        start = time.perf_counter()
        image = renderer.render(spp=1, seed=k)
        wp.synchronize_device(device)
        wall_ms.append(1000.0 * (time.perf_counter() - start))
        frame_ms.append(renderer.timers["render"][-1])
    if args.image:
        image.save(args.image)
    hits = int((image.aovs["prim"] >= 0).sum())
    pixels = args.width * args.height
    frame = statistics.median(frame_ms)
    return {
        "device": (f"{device.alias} ({device.name})" if device.is_cuda
                   else f"cpu ({platform.processor() or platform.machine()})"),
        "trees": stats["instances"],
        "tree_triangles": info["tree_triangles"],
        "rendered_triangles": stats["rendered_triangles"],
        "unique_triangles": stats["unique_triangles"],
        "generate_s": info["seconds"],
        "load_s": load_s,
        "build_s": build_s,
        "bvh_build_s": accel.build_seconds,
        "accel_mb": accel_bytes["total"] / 2**20,
        "tlas_mb": accel_bytes["tlas"] / 2**20,
        "bytes_per_instance": accel_bytes["tlas"] / max(stats["instances"], 1),
        "device_mb": pool_bytes / 2**20,
        "resolution": f"{args.width}x{args.height}",
        "frame_ms": frame,
        "frame_ms_min": min(frame_ms),
        "wall_ms": statistics.median(wall_ms),
        "hit_fraction": hits / pixels,
        "mrays_s": (pixels + hits) / (frame / 1000.0) / 1e6,  # camera rays plus one shadow ray per hit
        "instances_seen": int(len(np.unique(image.aovs["instance"][image.aovs["instance"] >= 0]))),
    }


def table(r: dict) -> str:
    """The measurements as a markdown table."""
    rows = [
        ("device", r["device"]),
        ("trees x triangles per tree", f"{r['trees']:,} x {r['tree_triangles']:,}"),
        ("rendered triangles", f"{r['rendered_triangles']:,}"),
        ("unique triangles", f"{r['unique_triangles']:,}"),
        ("generate USD s", f"{r['generate_s']:.2f}"),
        ("load_usd s", f"{r['load_s']:.2f}"),
        ("build s (renderer: BVHs, uploads)", f"{r['build_s']:.2f}"),
        ("BVH build s (BLAS + TLAS)", f"{r['bvh_build_s']:.2f}"),
        ("accel MB (BLAS + TLAS)", f"{r['accel_mb']:.1f}"),
        ("TLAS MB / bytes per instance", f"{r['tlas_mb']:.2f} / {r['bytes_per_instance']:.0f}"),
        ("device MB (mempool growth)", f"{r['device_mb']:.1f}"),
        ("resolution, integrator", f"{r['resolution']}, whitted + sun shadows"),
        ("frame ms (median; min)", f"{r['frame_ms']:.1f}; {r['frame_ms_min']:.1f}"),
        ("wall ms incl. readback", f"{r['wall_ms']:.1f}"),
        ("Mrays/s (camera + shadow)", f"{r['mrays_s']:.1f}"),
        ("hit fraction / instances seen", f"{r['hit_fraction']:.2f} / {r['instances_seen']:,}"),
    ]
    lines = ["| measure | value |", "|---|---|"] + [f"| {k} | {v} |" for k, v in rows]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--trees", type=int, default=50_000, help="tree instances")
    parser.add_argument("--tree-triangles", type=int, default=1_000_000, help="triangles per tree")
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--device", default="cuda:0", help="Override the default Warp device")
    parser.add_argument("--builder", default="sah", help="BVH builder for every BLAS and the TLAS")
    parser.add_argument("--integrator", default="whitted", help="wrt integrator (whitted: camera + shadow rays)")
    parser.add_argument("--frames", type=int, default=5, help="timed frames after the warm-up frame")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--image", default=None, help="write the last frame here (PNG/EXR)")
    parser.add_argument("--keep", default=None, help="write the forest stage here instead of a temporary file")
    parser.add_argument("--small", action="store_true", help=f"a tiny CPU run: {SMALL}")
    args = parser.parse_args(argv)
    if args.small:
        for key, value in SMALL.items():
            setattr(args, key, value)
    wp.init()
    result = run(args)
    print(table(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
