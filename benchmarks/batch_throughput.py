"""Images per second of ``wrt.render_batch``: n cameras of 64x64 in one launch per pass, colour + depth, on a scene of
primitives plus meshes (``wrt.procedural.sensor_scene``). Newton's SensorTiledCamera publishes 485k-794k images/s for
4096 worlds at 64x64 (colour + depth, GPU not named); that is the reference range.

Usage: python benchmarks/batch_throughput.py [--device cuda:0] [--cameras 1024 4096] [--size 64] [--repeats 10]
"""

from __future__ import annotations

import argparse
import statistics
import time

import warp as wp

import wrt
from wrt.cli import positive_int
from wrt.integrators import INTEGRATORS
from wrt.procedural import ring_of_cameras, sensor_scene
from wrt.trace import resolve_device


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cuda:0" if wp.is_cuda_available() else "cpu")
    parser.add_argument("--cameras", type=positive_int, nargs="+", default=[1024, 4096])
    parser.add_argument("--size", type=positive_int, default=64)
    parser.add_argument("--repeats", type=positive_int, default=10)
    parser.add_argument("--blob-triangles", type=positive_int, default=20000, help="triangles of the mesh object")
    parser.add_argument("--integrators", nargs="+", default=["whitted", "ao"])
    args = parser.parse_args()
    bad = [name for name in args.integrators if name not in INTEGRATORS]
    if bad:  # checked before the scene is built and a kernel compiled, as the device is
        parser.error(f"--integrators: unknown integrator {bad[0]!r}; valid integrators: {', '.join(INTEGRATORS)}")
    try:
        device = resolve_device(args.device)
    except ValueError as e:
        parser.error(f"--device: {e}")
    scene = sensor_scene(boxes=8, spheres=4, blob_triangles=args.blob_triangles)
    print(f"device {device.name} ({device}), warp {wp.config.version}, scene {scene.stats()['rendered_triangles']} "
          f"triangles + {scene.stats()['rendered_shapes']} shapes, {args.size}x{args.size}")
    for integrator in args.integrators:
        for n in args.cameras:
            renderer = wrt.Renderer(scene, cameras=ring_of_cameras(n), width=args.size, height=args.size,
                                    device=device, integrator=integrator)
            renderer.render()  # compile and allocate
            times = []
            for _ in range(args.repeats):
                wp.synchronize_device(device)
                start = time.perf_counter()
                batch = renderer.render()
                wp.synchronize_device(device)
                times.append(time.perf_counter() - start)
            median = statistics.median(times)
            hit = float((batch.aovs["prim"].numpy() >= 0).mean())
            print(f"{integrator:8s} {n:5d} cameras: {1e3 * median:8.2f} ms per batch (min {1e3 * min(times):.2f}), "
                  f"{n / median:10.0f} images/s, {n * args.size**2 / median / 1e6:8.1f} Mpixel/s, hit {hit:.2f}")


if __name__ == "__main__":
    main()
