"""Tree shape against CPU traversal speed: leaf size and SAH cost ratio of wrt's ``sah`` tree, at 1 thread.

For each scene this builds one ``sah`` tree per setting ``leaf_size:ratio`` (``ratio`` = ``intersection_cost /
traversal_cost``, with ``traversal_cost = 1``), converts it to each layout asked for, and traces the same rays
through all of them and through ``wp.Mesh(bvh_constructor="sah")`` in one process. Launches are interleaved: after a
warm-up of every subject, each timed round runs every subject once, in an order rotated from round to round, so a
slow spell of the machine spreads over all of them. Reported: median Mrays/s per subject, its ratio to
``wp.Mesh(sah)`` and to the default tree (``8:1``) in the same layout, and per setting the build time, node count,
node bytes and SAH cost.

Example::

    python benchmarks/tree_shape_cpu.py --scenes asset:turbineblade_199k asset:chess_set
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
import warp as wp

from wrt.bench import hardware, resolve_scene
from wrt.bvh import build_bvh
from wrt.bvh.layout import convert_layout, layout_kernels
from wrt.cli import positive_int
from wrt.rays import ray_set
from wrt.trace import HitBuffer, mesh_box, trace_bvh_kernel, trace_mesh_kernel

DEFAULT_SETTING = "8:1"  # the library's defaults: leaf_size 8, intersection_cost / traversal_cost = 1
SETTINGS = ("8:0.5", "8:1", "8:2", "8:4", "4:1", "4:2", "2:1", "1:1")  # leaf_size:ratio grid of the default run


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
        accel_args = self.input if isinstance(self.input, list) else [self.input]  # a mesh: id and box
        wp.launch(self.kernel, self.n, inputs=[*accel_args, *self.rays], outputs=self.hits.outputs, device=self.device)
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


def setting_arg(text: str) -> str:
    """An argparse type: a ``leaf_size:ratio`` setting, checked (kept as text: it names the table's columns)."""
    try:
        leaf, ratio = parse_setting(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not LEAF_SIZE:RATIO, e.g. 8:1") from None
    if leaf < 1 or not (math.isfinite(ratio) and ratio > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: the leaf size must be >= 1 and the ratio a positive number")
    return text


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
    warp = Subject("warp:sah", trace_mesh_kernel, [mesh.id, *mesh_box(points)], device)
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
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--scenes", nargs="+", default=["asset:turbineblade_199k", "asset:chess_set"],
                        help="scenes, as wrt bench names them")
    parser.add_argument("--rays", nargs="+", default=["primary", "diffuse", "incoherent"], help="ray kinds")
    parser.add_argument("--settings", nargs="+", type=setting_arg, default=list(SETTINGS),
                        help="sah trees as leaf_size:ratio, ratio = intersection_cost / traversal_cost")
    parser.add_argument("--layouts", nargs="+", default=["binary", "compact"],
                        help="binary, compact, wide or wide8")
    parser.add_argument("--n-rays", type=positive_int, default=200_000, help="rays per group (diffuse: as many as hit)")
    parser.add_argument("--repeats", type=positive_int, default=7, help="timed launches per subject, after one warm-up")
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
            print(f"# {scene_name} {kind}: " + ", ".join(f"{k} {v['mrays']:.2f}" for k, v in result.items()),
                  flush=True)
        del subjects

    # Speed table: one row per (scene, rays, layout); one column per setting.
    print()
    print(f"Hardware: CPU {info['cpu']} ({info['cpu_cores']} cores), Warp {info['warp']}, device {device}, 1 thread; "
          f"median of {args.repeats} interleaved launches after a warm-up.")
    print()
    head = ("| scene | rays | n | layout | wp.Mesh(sah) | " + " | ".join(args.settings)
            + " | best / default | best / wp.Mesh |")
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
           " | ".join(f"{layout} MB" for layout in args.layouts) + " |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for scene_name, builds in all_builds.items():
        for setting, b in builds.items():
            if setting == "warp:sah":
                print(f"| {scene_name.split(':')[-1]} | wp.Mesh(sah) | {b['build_s']:.3f} |"
                      + " |" * (5 + len(args.layouts)))
                continue
            print(f"| {scene_name.split(':')[-1]} | {setting} | {b['build_s']:.3f} | {b['nodes']} | {b['leaves']} | "
                  f"{b['mean_leaf']:.2f} | {b['max_depth']} | {b['sah']:.2f} | "
                  + " | ".join(f"{b['bytes'][layout] / 2**20:.1f}" for layout in args.layouts) + " |")
    print()
    print("| scene | rays | setting | nodes / ray (binary) | triangle tests / ray |")
    print("|---|---|---|---|---|")
    for scene_name, kind, n, result in all_rows:
        for setting in args.settings:
            key = next((f"{setting}/{layout}" for layout in ("binary", "compact") if f"{setting}/{layout}" in result),
                       None)
            if key:
                r = result[key]
                print(f"| {scene_name.split(':')[-1]} | {kind} | {setting} ({key.split('/')[1]}) | "
                      f"{r['nodes_per_ray']:.1f} | {r['tests_per_ray']:.1f} |")


if __name__ == "__main__":
    main()
