"""Tree shape against CPU traversal speed: leaf size and SAH cost ratio of wrt's ``sah`` tree, at 1 thread.

For each scene this builds one ``sah`` tree per setting ``leaf_size:ratio`` (``ratio`` = ``intersection_cost /
traversal_cost``, with ``traversal_cost = 1``), converts it to each layout asked for, and traces the same rays
through all of them and through ``wp.Mesh(bvh_constructor="sah")`` in one process. Launches are interleaved: after a
warm-up of every subject, each timed round runs every subject once, in an order rotated from round to round, so a
slow spell of the machine spreads over all of them. Reported: median Mrays/s per subject, its ratio to
``wp.Mesh(sah)`` and to the default tree (``8:1``) in the same layout, and per setting the build time, node count,
node bytes and SAH cost.

Besides the library's layouts, ``compact_aos`` is an experiment (defined here, not in the package): the compact
layout's node as one 64-byte struct per inner node (one array read instead of four) and the leaf triangles
interleaved (``tris[3 * slot + k]``, one array instead of three). Its hits must equal the compact layout's.

Example::

    python benchmarks/tree_shape_cpu.py --scenes asset:turbineblade_199k asset:chess_set
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import warp as wp

from wrt.bench import hardware, resolve_scene
from wrt.bvh import build_bvh
from wrt.bvh.compact import convert_compact
from wrt.bvh.layout import convert_layout, layout_kernels
from wrt.bvh.stack import STACK_BUILD_OPTIONS, NodeStack
from wrt.bvh.traverse import reachable
from wrt.geometry import intersect_ray_box, intersect_ray_triangle, make_sheared_ray, ray_is_valid, safe_inverse
from wrt.rays import ray_set
from wrt.trace import HitBuffer, trace_bvh_kernel, trace_mesh_kernel

wp.set_module_options({"enable_backward": False, "fuse_fp": False, "extra_build_options": STACK_BUILD_OPTIONS})


@wp.struct
class CompactNode:
    """One inner node of the compact layout in 64 contiguous bytes (field order of ``wrt.bvh.compact``)."""

    xy0: wp.vec4  # child 0 (lo.x, hi.x, lo.y, hi.y)
    xy1: wp.vec4  # child 1 (lo.x, hi.x, lo.y, hi.y)
    zz: wp.vec4  # (child 0 lo.z, hi.z, child 1 lo.z, hi.z)
    children: wp.vec4i  # (ref0, ref1, count0, count1)


@wp.struct
class DeviceCompactAosBvh:
    """The compact layout with array-of-structs nodes and interleaved triangles."""

    nodes: wp.array[CompactNode]  # inner nodes
    prim_ids: wp.array[wp.int32]  # slot -> triangle id
    tris: wp.array[wp.vec3]  # vertex k of slot s at 3 * s + k
    num_prims: int  # triangles in the tree


@wp.func
def compact_aos_intersect(bvh: DeviceCompactAosBvh, origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """``wrt.bvh.compact.compact_intersect`` on the array-of-structs layout (same visit order, same hits)."""
    best_t = t_max
    best_u = float(0.0)
    best_v = float(0.0)
    best_slot = int(-1)
    nodes = int(0)
    tests = int(0)
    if bvh.num_prims > 0 and ray_is_valid(direction):
        ray = make_sheared_ray(origin, direction)
        inv_dir = safe_inverse(direction)
        stack = NodeStack()
        top = int(0)
        ref = int(0)
        count = int(0)
        while ref >= 0:
            nodes += 1
            if count > 0:
                # Leaf: test its triangles, vertices next to each other.
                for s in range(ref, ref + count):
                    tests += 1
                    hit, t, u, v = intersect_ray_triangle(ray, bvh.tris[3 * s], bvh.tris[3 * s + 1], bvh.tris[3 * s + 2])
                    if hit and t >= t_min:
                        if t < best_t or (t == best_t and best_slot >= 0 and bvh.prim_ids[s] < bvh.prim_ids[best_slot]):
                            best_t = t
                            best_u = u
                            best_v = v
                            best_slot = s
                ref = -1
            else:
                # Inner node: one 64-byte read holds both child boxes and references.
                node = bvh.nodes[ref]
                a = node.xy0
                b = node.xy1
                z = node.zz
                ch = node.children
                t0 = float(wp.inf)
                t1 = float(wp.inf)
                if ch[2] >= 0:
                    t0 = intersect_ray_box(
                        origin, inv_dir, wp.vec3(a[0], a[2], z[0]), wp.vec3(a[1], a[3], z[1]), t_min, best_t
                    )
                if ch[3] >= 0:
                    t1 = intersect_ray_box(
                        origin, inv_dir, wp.vec3(b[0], b[2], z[2]), wp.vec3(b[1], b[3], z[3]), t_min, best_t
                    )
                near_ref = ch[0]
                near_count = ch[2]
                far_ref = ch[1]
                far_count = ch[3]
                if t1 < t0:
                    near_ref = ch[1]
                    near_count = ch[3]
                    far_ref = ch[0]
                    far_count = ch[2]
                    tmp = t0
                    t0 = t1
                    t1 = tmp
                ref = -1
                if reachable(t0, best_t):
                    ref = near_ref
                    count = near_count
                    if reachable(t1, best_t):
                        wp.wrt_stack_push(stack, top, far_ref, far_count, t1)
                        top += 1
            # Pop the next node that may still hold a hit no farther than the best one.
            while ref < 0 and top > 0:
                top -= 1
                if wp.wrt_stack_t(stack, top) <= best_t:
                    ref = wp.wrt_stack_ref(stack, top)
                    count = wp.wrt_stack_count(stack, top)
    prim = int(-1)
    if best_slot >= 0:
        prim = bvh.prim_ids[best_slot]
    else:
        best_t = wp.inf
    return best_t, best_u, best_v, prim, nodes, tests


@wp.kernel
def trace_compact_aos_kernel(
    bvh: DeviceCompactAosBvh,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
    # outputs
    ts: wp.array[float],
    us: wp.array[float],
    vs: wp.array[float],
    prims: wp.array[wp.int32],
    costs: wp.array[wp.vec2i],
):
    """Closest hit of every ray through the array-of-structs compact layout."""
    i = wp.tid()
    t, u, v, prim, nodes, tests = compact_aos_intersect(bvh, origins[i], directions[i], t_mins[i], t_maxs[i])
    ts[i] = t
    us[i] = u
    vs[i] = v
    prims[i] = prim
    costs[i] = wp.vec2i(nodes, tests)


DEFAULT_SETTING = "8:1"  # the library's defaults: leaf_size 8, intersection_cost / traversal_cost = 1
SETTINGS = ("8:0.5", "8:1", "8:2", "8:4", "4:1", "4:2", "2:1", "1:1")  # leaf_size:ratio grid of the default run


def compact_aos_to_device(bvh, points: np.ndarray, indices: np.ndarray, device) -> DeviceCompactAosBvh:
    """The FlatBvh ``bvh`` in the array-of-structs compact layout, on ``device``."""
    c = convert_compact(bvh)
    k = max(c.num_nodes, 1)
    raw = np.zeros((k, 16), np.float32)  # 16 words per node: xy0, xy1, zz, children (int bits)
    if c.num_nodes:
        raw[:, 0:4], raw[:, 4:8], raw[:, 8:12] = c.xy0, c.xy1, c.zz
        raw[:, 12:16] = c.children.astype(np.int32).view(np.float32)
    nodes = wp.zeros(k, dtype=CompactNode, device=device)
    assert nodes.strides[0] == 64, "CompactNode must be 64 bytes"
    if not wp.get_device(device).is_cpu:
        raise ValueError("compact_aos is filled through host memory: CPU only")
    np.ctypeslib.as_array(_bytes_view(nodes), (k * 64,))[:] = raw.view(np.uint8).reshape(-1)
    corners = np.asarray(points, np.float32)[np.asarray(indices)[c.prim_ids]].reshape(-1, 3)
    s = DeviceCompactAosBvh()
    s.nodes = nodes
    s.prim_ids = wp.array(c.prim_ids, dtype=wp.int32, device=device)
    s.tris = wp.array(corners if len(corners) else np.zeros((3, 3), np.float32), dtype=wp.vec3, device=device)
    s.num_prims = c.num_prims
    return s


def _bytes_view(array: wp.array):
    """A ctypes pointer to the bytes of a CPU ``wp.array``."""
    import ctypes

    return ctypes.cast(array.ptr, ctypes.POINTER(ctypes.c_uint8))


class Subject:
    """One accelerator on the prepared rays: ``run()`` traces them once at 1 thread (one CPU launch)."""

    def __init__(self, name: str, kernel, accel_input, device):
        self.name, self.kernel, self.input, self.device = name, kernel, accel_input, device
        self.times = []

    def prepare(self, rays: list, n: int):
        self.rays, self.n = rays, n
        self.hits = HitBuffer(n, self.device)
        self.times = []

    def run(self):
        wp.launch(self.kernel, self.n, inputs=[self.input, *self.rays], outputs=self.hits.outputs, device=self.device)
        wp.synchronize_device(self.device)

    def timed(self):
        start = time.perf_counter()
        self.run()
        self.times.append(time.perf_counter() - start)

    @property
    def mrays(self) -> float:
        return self.n / statistics.median(self.times) / 1e6


def parse_setting(text: str) -> tuple[int, float]:
    leaf, _, ratio = text.partition(":")
    return int(leaf), float(ratio or 1.0)


def build_subjects(scene, settings, layouts, device) -> tuple[list, dict]:
    """The ``wp.Mesh(sah)`` subject first, then one subject per (setting, layout); and per setting its build row."""
    points, indices = scene.triangles()
    points = np.ascontiguousarray(points, np.float32)
    indices = np.ascontiguousarray(indices, np.int32)
    mesh_points = wp.array(points, dtype=wp.vec3, device=device)
    mesh_indices = wp.array(indices.reshape(-1), dtype=wp.int32, device=device)
    start = time.perf_counter()
    mesh = wp.Mesh(mesh_points, mesh_indices, bvh_constructor="sah")
    warp_build = time.perf_counter() - start
    warp = Subject("warp:sah", trace_mesh_kernel, mesh.id, device)
    warp.keep = (mesh, mesh_points, mesh_indices)
    subjects = [warp]
    builds = {"warp:sah": {"build_s": warp_build}}
    for setting in settings:
        leaf, ratio = parse_setting(setting)
        bvh = build_bvh(points, indices, "sah", device=device, leaf_size=leaf, traversal_cost=1.0,
                        intersection_cost=ratio, threads=1)
        st = bvh.stats(traversal_cost=1.0, intersection_cost=1.0, epo_samples=0)  # SAH with the default constants
        builds[setting] = {
            "build_s": bvh.build_seconds,
            "nodes": st["nodes"],
            "leaves": st["leaves"],
            "mean_leaf": st["mean_leaf_size"],
            "max_depth": st["max_depth"],
            "sah": st["sah_cost"],
            "bytes": {},
        }
        for layout in layouts:
            if layout == "compact_aos":
                dev_bvh = compact_aos_to_device(bvh, points, indices, device)
                kernel = trace_compact_aos_kernel
                builds[setting]["bytes"][layout] = 64 * max(len(convert_compact(bvh).children), 1) + 4 * len(indices)
            else:
                converted = convert_layout(bvh, layout)
                dev_bvh = converted.to_device(points, indices, device)
                kernel = trace_bvh_kernel if layout == "binary" else layout_kernels(layout)[0]
                builds[setting]["bytes"][layout] = converted.bytes if hasattr(converted, "bytes") else st["bytes"]
            subjects.append(Subject(f"{setting}/{layout}", kernel, dev_bvh, device))
    return subjects, builds


def measure(subjects, origins, directions, repeats: int, device) -> dict:
    """Median Mrays/s of every subject on the same rays, interleaved; checks every subject against the first wrt one."""
    n = len(origins)
    rays = [
        wp.array(origins, dtype=wp.vec3, device=device),
        wp.array(directions, dtype=wp.vec3, device=device),
        wp.zeros(n, dtype=float, device=device),
        wp.full(n, np.inf, dtype=float, device=device),
    ]
    for s in subjects:
        s.prepare(rays, n)
        s.run()  # warm-up (and compilation)
    for r in range(repeats):
        k = r % len(subjects)
        for s in subjects[k:] + subjects[:k]:
            s.timed()
    # Every wrt tree must give the same closest hits (the tie rule is tree-independent); wp.Mesh: hit/miss and t.
    ref = subjects[1]
    ref_t, ref_prim = ref.hits.t.numpy(), ref.hits.prim.numpy()
    out = {}
    for s in subjects:
        t, prim = s.hits.t.numpy(), s.hits.prim.numpy()
        if s.name.startswith("warp"):
            same = float(np.mean(((prim >= 0) == (ref_prim >= 0)) & np.isclose(t, ref_t, rtol=1e-5, equal_nan=True)))
        else:
            same = float(np.mean((prim == ref_prim) & (t == ref_t)))
        cost = s.hits.cost.numpy()
        out[s.name] = {"mrays": s.mrays, "agree": same, "nodes_per_ray": float(cost[:, 0].mean()),
                       "tests_per_ray": float(cost[:, 1].mean()) if not s.name.startswith("warp") else None}
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--scenes", nargs="+", default=["asset:turbineblade_199k", "asset:chess_set"],
                        help="scenes, as wrt bench names them")
    parser.add_argument("--rays", nargs="+", default=["primary", "diffuse", "incoherent"], help="ray kinds")
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS),
                        help="sah trees as leaf_size:ratio, ratio = intersection_cost / traversal_cost")
    parser.add_argument("--layouts", nargs="+", default=["binary", "compact", "compact_aos"],
                        help="binary, compact, wide, wide8, or compact_aos (the experiment of this script)")
    parser.add_argument("--n-rays", type=int, default=200_000, help="rays per group (diffuse: as many as hit)")
    parser.add_argument("--repeats", type=int, default=7, help="timed launches per subject, after one warm-up")
    parser.add_argument("--device", default="cpu", help="Override the default Warp device")
    args = parser.parse_args(argv)
    if DEFAULT_SETTING not in args.settings:
        args.settings = [DEFAULT_SETTING, *args.settings]
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    info = hardware(device)
    all_rows, all_builds = [], {}
    for scene_name in args.scenes:
        scene = resolve_scene(scene_name)
        subjects, builds = build_subjects(scene, args.settings, args.layouts, device)
        all_builds[scene_name] = builds
        for kind in args.rays:
            origins, directions = ray_set(scene, kind, args.n_rays, seed=1)
            result = measure(subjects, origins, directions, args.repeats, device)
            all_rows.append((scene_name, kind, len(origins), result))
            print(f"# {scene_name} {kind}: " + ", ".join(f"{k} {v['mrays']:.2f}" for k, v in result.items()), flush=True)
        del subjects

    # Speed table: one row per (scene, rays, layout); one column per setting.
    print()
    print(f"Hardware: CPU {info['cpu']} ({info['cpu_cores']} cores), Warp {info['warp']}, device {device}, 1 thread; "
          f"median of {args.repeats} interleaved launches after a warm-up.")
    print()
    head = "| scene | rays | n | layout | wp.Mesh(sah) | " + " | ".join(args.settings) + " | best / default | best / wp.Mesh |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for scene_name, kind, n, result in all_rows:
        warp = result["warp:sah"]["mrays"]
        for layout in args.layouts:
            cells, values = [], {}
            default = result[f"{DEFAULT_SETTING}/{layout}"]["mrays"]
            for setting in args.settings:
                r = result[f"{setting}/{layout}"]
                values[setting] = r["mrays"]
                flag = "" if r["agree"] == 1.0 else f" (agree {100 * r['agree']:.3f}%)"
                cells.append(f"{r['mrays']:.2f} ({r['mrays'] / default:.2f}){flag}")
            best = max(values, key=values.get)
            print(f"| {scene_name.split(':')[-1]} | {kind} | {n} | {layout} | {warp:.2f} | " + " | ".join(cells)
                  + f" | {best} {values[best] / default:.2f}x | {values[best] / warp:.2f}x |")
    print()
    print("Cells: Mrays/s (ratio to the default tree 8:1 in the same layout).")
    print()
    head = "| scene | setting | build s (1 thread) | nodes | leaves | mean leaf | max depth | SAH (Ct=Ci=1) | " + \
           " | ".join(f"{l} MB" for l in args.layouts) + " |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for scene_name, builds in all_builds.items():
        for setting, b in builds.items():
            if setting == "warp:sah":
                print(f"| {scene_name.split(':')[-1]} | wp.Mesh(sah) | {b['build_s']:.3f} |" + " |" * (5 + len(args.layouts)))
                continue
            print(f"| {scene_name.split(':')[-1]} | {setting} | {b['build_s']:.3f} | {b['nodes']} | {b['leaves']} | "
                  f"{b['mean_leaf']:.2f} | {b['max_depth']} | {b['sah']:.2f} | "
                  + " | ".join(f"{b['bytes'][l] / 2**20:.1f}" for l in args.layouts) + " |")
    print()
    print("| scene | rays | setting | nodes / ray (binary) | triangle tests / ray |")
    print("|---|---|---|---|---|")
    for scene_name, kind, n, result in all_rows:
        for setting in args.settings:
            key = next((f"{setting}/{l}" for l in ("binary", "compact", "compact_aos") if f"{setting}/{l}" in result), None)
            if key:
                r = result[key]
                print(f"| {scene_name.split(':')[-1]} | {kind} | {setting} ({key.split('/')[1]}) | {r['nodes_per_ray']:.1f} | {r['tests_per_ray']:.1f} |")


if __name__ == "__main__":
    main()
