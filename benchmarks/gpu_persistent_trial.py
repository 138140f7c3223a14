"""Trial: persistent threads for the binary closest-hit traversal (GPU_NOTES row 18).

Nsight Compute on the H200 (chess_set, 2M incoherent rays) shows ``trace_bvh_kernel`` running 7.6 active threads
per 32-thread warp: a warp lives as long as its longest ray, and the threads whose rays finished early idle. Here
each thread owns a fixed share of the rays (``ray, ray + T, ray + 2T, ...`` for ``T`` threads) and runs one flat
loop whose body visits one node; a thread whose ray is done writes its hit and starts its next ray inside the same
loop iteration, so it does not wait for the rest of its warp (Aila and Laine 2009 fetch rays dynamically; a static
share needs no atomics). Hits must be bit-identical to ``trace_bvh_kernel``'s.

    python benchmarks/gpu_persistent_trial.py --assets .gpu/assets [--scenes chess_set,sphere]
"""

from __future__ import annotations

import argparse
import importlib
import os
import statistics
import sys
from pathlib import Path

import numpy as np
import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gpu_traversal_ab import make_rays  # noqa: E402

from wrt import rays as rays_module  # noqa: E402
from wrt.bench import asset_path  # noqa: E402
from wrt.bvh import build_bvh  # noqa: E402
from wrt.bvh.layout import DeviceBvh  # noqa: E402
from wrt.bvh.stack import STACK_BUILD_OPTIONS, NodeStack  # noqa: E402
from wrt.bvh.traverse import order_children, reachable  # noqa: E402
from wrt.geometry import (  # noqa: E402
    ShearedRay,
    box_origins,
    box_reach,
    intersect_ray_box,
    intersect_ray_triangle,
    make_sheared_ray,
    ray_can_hit,
    safe_inverse,
)
from wrt.procedural import displaced_sphere_scene  # noqa: E402
from wrt.usd import load_usd  # noqa: E402

trace_module = importlib.import_module("wrt.trace")  # the module, not wrt.trace the function

wp.set_module_options({"enable_backward": False, "fuse_fp": False, "extra_build_options": STACK_BUILD_OPTIONS})


@wp.kernel
def trace_persistent_kernel(
    bvh: DeviceBvh,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    num_threads: int,
    # outputs
    ts: wp.array[float],
    us: wp.array[float],
    vs: wp.array[float],
    prims: wp.array[wp.int32],
    costs: wp.array[wp.vec2i],
):
    n = origins.shape[0]
    ray_id = wp.tid() - num_threads  # the ray in flight; negative: none yet
    origin = wp.vec3()
    origin_lower = wp.vec3()
    origin_upper = wp.vec3()
    inv_dir = wp.vec3()
    ray = ShearedRay()
    t_min = float(0.0)
    best_t = float(0.0)
    best_u = float(0.0)
    best_v = float(0.0)
    best_slot = int(-1)
    nodes = int(0)
    tests = int(0)
    stack = NodeStack()
    top = int(0)
    node = int(-1)
    while ray_id < n:
        if node >= 0:
            nodes += 1
            count = bvh.prim_count[node]
            first = bvh.left_first[node]
            if count > 0:
                for s in range(first, first + count):
                    tests += 1
                    hit, t, u, v = intersect_ray_triangle(ray, bvh.v0[s], bvh.v1[s], bvh.v2[s])
                    if hit and t >= t_min:
                        if t < best_t or (t == best_t and best_slot >= 0 and bvh.prim_ids[s] < bvh.prim_ids[best_slot]):
                            best_t = t
                            best_u = u
                            best_v = v
                            best_slot = s
                node = -1
            else:
                left, right, t_left, t_right = order_children(
                    bvh.lowers, bvh.uppers, first, origin_lower, origin_upper, inv_dir, t_min, best_t
                )
                node = -1
                if reachable(t_left, best_t):
                    node = left
                    if reachable(t_right, best_t):
                        wp.wrt_stack_push(stack, top, right, t_right)
                        top += 1
            while node < 0 and top > 0:
                top -= 1
                if wp.wrt_stack_t(stack, top) <= best_t:
                    node = wp.wrt_stack_ref(stack, top)
        if node < 0:
            # This thread's ray is done: write it, then start the next one of its share.
            if ray_id >= 0:
                prim = int(-1)
                t_out = float(wp.inf)
                if best_slot >= 0:
                    prim = bvh.prim_ids[best_slot]
                    t_out = best_t
                ts[ray_id] = t_out
                us[ray_id] = best_u
                vs[ray_id] = best_v
                prims[ray_id] = prim
                costs[ray_id] = wp.vec2i(nodes, tests)
            ray_id += num_threads
            if ray_id < n:
                origin = origins[ray_id]
                direction = directions[ray_id]
                t_min = t_mins[ray_id]
                best_t = t_maxs[ray_id]
                best_u = 0.0
                best_v = 0.0
                best_slot = -1
                nodes = 0
                tests = 0
                top = 0
                if bvh.num_prims > 0 and ray_can_hit(origin, direction, t_min, best_t):
                    ray = make_sheared_ray(origin, direction)
                    inv_dir = safe_inverse(direction)
                    origin_lower, origin_upper = box_origins(origin, direction, box_reach(bvh.lowers[0], bvh.uppers[0]))
                    root = intersect_ray_box(
                        origin_lower, origin_upper, inv_dir, bvh.lowers[0], bvh.uppers[0], t_min, best_t
                    )
                    if reachable(root, best_t):
                        node = 0


def timed(launch, device, repeats: int) -> float:
    """Median milliseconds of ``repeats`` launches (CUDA events), after two warm-ups."""
    launch()
    launch()
    ms = []
    for _ in range(repeats):
        if device.is_cuda:
            start, end = wp.Event(device, enable_timing=True), wp.Event(device, enable_timing=True)
            wp.record_event(start)
            launch()
            wp.record_event(end)
            wp.synchronize_event(end)
            ms.append(wp.get_event_elapsed_time(start, end))
        else:
            import time

            t0 = time.perf_counter()
            launch()
            ms.append(1000 * (time.perf_counter() - t0))
    return statistics.median(ms)


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    parser.add_argument("--assets", help="shared asset folder (sets WRT_ASSETS)")
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--scenes", default="chess_set,sphere")
    parser.add_argument("--kinds", default="primary,diffuse,incoherent")
    parser.add_argument("--rays", type=int, default=1 << 21)
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--threads-per-sm", default="768,1536,3072", help="persistent threads per SM to try")
    args = parser.parse_args()
    if args.assets:
        os.environ["WRT_ASSETS"] = str(Path(args.assets).resolve())
    device = wp.get_device(args.device)
    sms = max(device.sm_count, 1) if device.is_cuda else 1
    print(f"device {device.alias} {device.name if device.is_cuda else 'cpu'}, {sms} SMs, Warp {wp.config.version}")
    for scene_name in args.scenes.split(","):
        scene = displaced_sphere_scene(2_000_000) if scene_name == "sphere" else load_usd(asset_path(scene_name))
        points, indices = scene.triangles()
        tree = build_bvh(points, indices, "sah", device=device).to_device(points, indices, device)
        constructor = "cubql" if device.is_cuda else "sah"  # "mesh" in the output; cubql is CUDA-only
        mesh = wp.Mesh(wp.array(points, dtype=wp.vec3, device=device),
                       wp.array(indices.reshape(-1), dtype=wp.int32, device=device), bvh_constructor=constructor)
        box = trace_module.mesh_box(points)
        for kind in args.kinds.split(","):
            origins, directions = make_rays(scene, kind, args.rays, device, rays_module, trace_module.trace)
            n = len(origins)
            rays = [wp.array(origins, dtype=wp.vec3, device=device), wp.array(directions, dtype=wp.vec3, device=device),
                    wp.zeros(n, dtype=float, device=device), wp.full(n, np.inf, dtype=float, device=device)]

            def outputs():
                return [wp.zeros(n, dtype=float, device=device) for _ in range(3)] + [
                    wp.zeros(n, dtype=wp.int32, device=device), wp.zeros(n, dtype=wp.vec2i, device=device)]

            ref = outputs()
            ms_ref = timed(lambda: wp.launch(trace_module.trace_bvh_kernel, n, inputs=[tree, *rays], outputs=ref,
                                             device=device), device, args.repeats)
            mesh_out = outputs()
            ms_mesh = timed(lambda: wp.launch(trace_module.trace_mesh_kernel, n, inputs=[mesh.id, *box, *rays],
                                              outputs=mesh_out, device=device), device, args.repeats)
            line = f"{scene_name:10s} {kind:10s} {n:8d} rays  binary {n / ms_ref / 1e3:7.1f}"
            line += f"  mesh {n / ms_mesh / 1e3:7.1f}"
            for per_sm in [int(x) for x in args.threads_per_sm.split(",")]:
                threads = min(sms * per_sm, n)
                out = outputs()
                ms = timed(lambda: wp.launch(trace_persistent_kernel, threads, inputs=[tree, *rays, threads],
                                             outputs=out, device=device), device, args.repeats)
                same = all(np.array_equal(a.numpy(), b.numpy()) for a, b in zip(ref, out))
                line += f"  persistent@{per_sm} {n / ms / 1e3:7.1f} ({ms_ref / ms:.2f}x, {'same' if same else 'DIFF'})"
            print(line + "  Mrays/s", flush=True)


if __name__ == "__main__":
    main()
