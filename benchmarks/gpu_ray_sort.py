"""Trial: does sorting rays by a Morton key before tracing pay on the GPU? (GPU_NOTES row 15)

Per (scene, ray kind): wrt binary on the rays as given, on rays pre-sorted on the host (traversal gain alone, for
two keys), and end to end with the sort on the device (key kernel + radix sort + a trace kernel that gathers each
ray by its sorted id and scatters the hit back); ``wp.Mesh`` sah/lbvh/cubql on the rays as given. Medians of
CUDA-event timed launches, interleaved. The answer was no (not kept in wrt); this script is the record.

    python benchmarks/gpu_ray_sort.py --assets .gpu/assets
    python benchmarks/gpu_ray_sort.py --device cpu --scenes sphere --sphere 20000 --rays 20000  # smoke run
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from wrt.bvh.layout import DeviceBvh  # noqa: E402
from wrt.bvh.stack import STACK_BUILD_OPTIONS  # noqa: E402
from wrt.bvh.traverse import bvh_intersect  # noqa: E402

wp.set_module_options({"enable_backward": False, "fuse_fp": False, "extra_build_options": STACK_BUILD_OPTIONS})


@wp.func
def spread5(x: int):
    """Bits 0..4 of x to every sixth bit."""
    r = int(0)
    for b in range(5):
        r = r | (((x >> b) & 1) << (6 * b))
    return r


@wp.func
def spread9(x: int):
    r = int(0)
    for b in range(9):
        r = r | (((x >> b) & 1) << (3 * b))
    return r


@wp.kernel
def ray_keys_kernel(origins: wp.array[wp.vec3], directions: wp.array[wp.vec3], lower: wp.vec3, scale: wp.vec3,
                    mode: int, keys: wp.array[wp.int32], ids: wp.array[wp.int32]):
    i = wp.tid()
    o = wp.cw_mul(origins[i] - lower, scale)  # 0..1 in the scene box
    d = wp.normalize(directions[i])
    key = int(0)
    if mode == 0:  # 6D Morton, 5 bits per dimension
        for a in range(3):
            qo = wp.clamp(int(o[a] * 31.0), 0, 31)
            qd = wp.clamp(int((d[a] * 0.5 + 0.5) * 31.0), 0, 31)
            key = key | (spread5(qo) << a) | (spread5(qd) << (3 + a))
    else:  # direction octant, then 3D Morton of the origin, 9 bits per axis
        octant = wp.where(d[0] < 0.0, 1, 0) + wp.where(d[1] < 0.0, 2, 0) + wp.where(d[2] < 0.0, 4, 0)
        for a in range(3):
            key = key | (spread9(wp.clamp(int(o[a] * 511.0), 0, 511)) << a)
        key = key | (octant << 27)
    keys[i] = key
    ids[i] = i


@wp.kernel
def trace_sorted_kernel(bvh: DeviceBvh, ids: wp.array[wp.int32], origins: wp.array[wp.vec3],
                        directions: wp.array[wp.vec3], t_mins: wp.array[float], t_maxs: wp.array[float],
                        ts: wp.array[float], us: wp.array[float], vs: wp.array[float], prims: wp.array[wp.int32],
                        costs: wp.array[wp.vec2i]):
    k = wp.tid()
    i = ids[k]
    t, u, v, prim, nodes, tests = bvh_intersect(bvh, origins[i], directions[i], t_mins[i], t_maxs[i])
    ts[i] = t
    us[i] = u
    vs[i] = v
    prims[i] = prim
    costs[i] = wp.vec2i(nodes, tests)


def timed(fn, device):
    if device.is_cpu:
        t0 = time.perf_counter()
        fn()
        return 1000 * (time.perf_counter() - t0)
    start, end = wp.Event(device, enable_timing=True), wp.Event(device, enable_timing=True)
    wp.record_event(start)
    fn()
    wp.record_event(end)
    wp.synchronize_event(end)
    return wp.get_event_elapsed_time(start, end)


def main():
    p = argparse.ArgumentParser(allow_abbrev=False)
    p.add_argument("--assets")
    p.add_argument("--rays", type=int, default=1 << 21)
    p.add_argument("--scenes", default="chess_set,sphere")
    p.add_argument("--kinds", default="incoherent,diffuse,primary")
    p.add_argument("--repeats", type=int, default=10)
    p.add_argument("--device", default="cuda:0")
    p.add_argument("--sphere", type=int, default=2_000_000)
    a = p.parse_args()
    if a.assets:
        os.environ["WRT_ASSETS"] = str(Path(a.assets).resolve())
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(a.device)
    wp.set_device(device)
    from wrt import rays as R
    from wrt.bench import asset_path
    from wrt.bvh import build_bvh
    from wrt.procedural import displaced_sphere_scene
    from wrt.trace import mesh_box, trace, trace_bvh_kernel, trace_mesh_kernel
    from wrt.usd import load_usd
    meshes_for = ("sah", "lbvh", "cubql") if device.is_cuda else ("sah",)
    print(device.name, wp.config.version, flush=True)
    for scene_name in a.scenes.split(","):
        scene = displaced_sphere_scene(a.sphere) if scene_name == "sphere" else load_usd(asset_path(scene_name))
        points, indices = scene.triangles()
        tree = build_bvh(points, indices, "sah", device=device).to_device(points, indices, device)
        mp = wp.array(points, dtype=wp.vec3)
        mi = wp.array(indices.reshape(-1), dtype=wp.int32)
        meshes = {c: wp.Mesh(mp, mi, bvh_constructor=c) for c in meshes_for}
        box = mesh_box(points)
        lo, hi = (np.asarray(b, np.float64) for b in scene.bounds())
        lower = wp.vec3(*lo.astype(np.float32))
        scale = wp.vec3(*(1.0 / np.maximum(hi - lo, 1e-30)).astype(np.float32))
        for kind in a.kinds.split(","):
            if kind == "incoherent":
                o, d = R.incoherent_rays(scene, a.rays, seed=1)
            else:
                w = round(np.sqrt(a.rays * 4 / 3))
                o, d = R.camera_rays(scene, width=w, height=a.rays // w)
                if kind != "primary":
                    h = trace(scene, o, d, accel="warp", builder="sah", device=device)
                    o, d = R.secondary_rays(scene, kind, o, d, h, seed=1)
            n = len(o)
            rays = [wp.array(o, dtype=wp.vec3), wp.array(d, dtype=wp.vec3), wp.zeros(n, dtype=float),
                    wp.full(n, np.inf, dtype=float)]
            outs = lambda: [wp.empty(n, dtype=float) for _ in range(3)] + [wp.empty(n, dtype=wp.int32),  # noqa: E731
                                                                          wp.empty(n, dtype=wp.vec2i)]
            keys = wp.empty(2 * n, dtype=wp.int32)
            ids = wp.empty(2 * n, dtype=wp.int32)
            subjects = {}
            o_plain = outs()
            subjects["wrt"] = (lambda: wp.launch(trace_bvh_kernel, n, inputs=[tree, *rays], outputs=o_plain), o_plain)
            for mode in (0, 1):
                wp.launch(ray_keys_kernel, n, inputs=[rays[0], rays[1], lower, scale, mode], outputs=[keys, ids])
                wp.utils.radix_sort_pairs(keys, ids, n)
                perm = ids.numpy()[:n]
                pre = [wp.array(r.numpy()[perm], dtype=r.dtype) for r in rays]
                o_pre = outs()
                subjects[f"wrt presorted k{mode}"] = (
                    lambda pre=pre, o_pre=o_pre: wp.launch(trace_bvh_kernel, n, inputs=[tree, *pre], outputs=o_pre),
                    o_pre)
                o_dev = outs()

                def sorted_trace(mode=mode, o_dev=o_dev):
                    wp.launch(ray_keys_kernel, n, inputs=[rays[0], rays[1], lower, scale, mode], outputs=[keys, ids])
                    wp.utils.radix_sort_pairs(keys, ids, n, end_bit=30)
                    wp.launch(trace_sorted_kernel, n, inputs=[tree, ids, *rays], outputs=o_dev)
                subjects[f"wrt devsort k{mode}"] = (sorted_trace, o_dev)

                def sort_only(mode=mode):
                    wp.launch(ray_keys_kernel, n, inputs=[rays[0], rays[1], lower, scale, mode], outputs=[keys, ids])
                    wp.utils.radix_sort_pairs(keys, ids, n, end_bit=30)
                subjects[f"sort only k{mode}"] = (sort_only, None)
            for c, m in meshes.items():
                o_m = outs()
                subjects[f"warp:{c}"] = (lambda m=m, o_m=o_m: wp.launch(trace_mesh_kernel, n,
                                                                       inputs=[m.id, *box, *rays], outputs=o_m), o_m)
            for fn, _ in subjects.values():
                fn()
                fn()
            wp.synchronize()
            ms = {k: [] for k in subjects}
            for _ in range(a.repeats):
                for k, (fn, _) in subjects.items():
                    ms[k].append(timed(fn, device))
            best = max(n / statistics.median(ms[k]) / 1e3 for k in ms if k.startswith("warp:"))
            ref = o_plain[3].numpy()
            print(f"\n{scene_name} {kind} {n} rays")
            for k in subjects:
                med = statistics.median(ms[k])
                extra = ""
                if subjects[k][1] is not None and "presorted" not in k:
                    same = np.array_equal(subjects[k][1][3].numpy(), ref)
                    extra = f" prims==wrt: {same}"
                mrays = n / med / 1e3
                print(f"  {k:22s} {med:8.3f} ms {mrays:8.1f} Mrays/s {mrays / best:5.2f}x best mesh{extra}", flush=True)


if __name__ == "__main__":
    main()
