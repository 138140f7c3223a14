"""One frame as a CUDA graph: ``Renderer.launch_frame`` recorded with ``wp.ScopedCapture`` and replayed, against the
same frame rendered with ``Renderer.render`` (host reads between bounces). The GPU issue's frame target: chess_set at
1920x1080 with shadows and one diffuse bounce (``path``, ``max_depth=2``, 1 spp) in <= 16 ms.

The camera is the default one (``wrt.camera.frame_scene``: the scene's bounding sphere in view, where chess_set's
board covers about 13% of the pixels), moved towards the centre by each factor of ``--distances`` (0.5: about half
of the camera rays hit).

Usage: python benchmarks/frame_capture.py [--scene asset:chess_set] [--width 1920 --height 1080] [--device cuda:0]
On the CPU it times ``launch_frame`` without capture (graphs are CUDA-only).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import numpy as np
import warp as wp

import wrt
from wrt.bench import hardware, resolve_scene
from wrt.bvh import traverse
from wrt.options import DEFAULT_MAX_DEPTH
from wrt.render import resolve_camera


def timed_ms(fn, device, repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        wp.synchronize_device(device)
        start = time.perf_counter()
        fn()
        wp.synchronize_device(device)
        times.append(1e3 * (time.perf_counter() - start))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="asset:chess_set")
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--device", default="cuda:0" if wp.is_cuda_available() else "cpu")
    parser.add_argument("--integrator", default="path")
    parser.add_argument("--max-depth", type=int, default=2, help="2: camera hit, its shadow ray, one bounce (path and "
                        "whitted only: the other integrators do not bounce)")
    parser.add_argument("--builder", default="sah")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--distances", default="1,0.5", help="camera distances, as fractions of the default one")
    parser.add_argument("--block-dims", help="comma list of CUDA threads per block of the trace launches to time "
                        "one after the other (default: wrt.bvh.traverse.TRACE_BLOCK_DIM)")
    args = parser.parse_args()
    device = wp.get_device(args.device)
    scene = resolve_scene(args.scene)
    print(f"{args.scene}: {scene.stats()['rendered_triangles']} triangles; {hardware(device)}")
    default = resolve_camera(scene, None)
    center = np.asarray(scene.bounds()).mean(axis=0)
    for distance in (float(d) for d in args.distances.split(",")):
        to_world = default.to_world.copy()
        to_world[:3, 3] = center + distance * (default.eye - center)  # along the line of sight
        camera = dataclasses.replace(default, to_world=to_world)
        for block in args.block_dims.split(",") if args.block_dims else [traverse.TRACE_BLOCK_DIM]:
            traverse.TRACE_BLOCK_DIM = int(block)
            print(f"\ncamera at {distance} of the default distance, trace launches of {block} threads per block")
            time_frame(scene, camera, device, args)


def time_frame(scene, camera, device, args) -> None:
    # Given to the integrators that read it alone: wrt.Renderer warns of a max_depth given to another (ao, normals)
    bounces = {"max_depth": args.max_depth} if args.integrator in DEFAULT_MAX_DEPTH else {}
    renderer = wrt.Renderer(
        scene,
        camera=camera,
        width=args.width,
        height=args.height,
        device=device,
        builder=args.builder,
        integrator=args.integrator,
        **bounces,
    )
    print(f"build {renderer.timers['build'][0]:.0f} ms ({args.builder}, accelerator {type(renderer.accel).__name__})")
    renderer.render()  # compile and allocate
    plain = timed_ms(lambda: renderer.render(), device, args.repeats)
    renderer.launch_frame()  # allocate the frame buffers before any capture
    launches = timed_ms(lambda: renderer.launch_frame(), device, args.repeats)
    rows = [("render() (host reads between bounces)", plain), ("launch_frame() (no host reads)", launches)]
    if device.is_cuda:
        with wp.ScopedCapture(device=device) as capture:
            renderer.launch_frame()
        rows.append(
            (
                "CUDA graph replay of launch_frame()",
                timed_ms(lambda: wp.capture_launch(capture.graph), device, args.repeats),
            )
        )
    print(
        f"\n{args.width}x{args.height}, {args.integrator} max_depth {args.max_depth}, 1 spp, median of {args.repeats}\n"
    )
    print("| how | median ms | min ms |")
    print("|---|---|---|")
    for name, times in rows:
        print(f"| {name} | {statistics.median(times):.2f} | {min(times):.2f} |")
    hit = float((renderer.frame_image().aovs["prim"] >= 0).mean())
    print(f"\ncamera rays that hit: {hit:.3f}")


if __name__ == "__main__":
    main()
