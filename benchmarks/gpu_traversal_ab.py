"""GPU traversal A/B: wrt's BVH layouts against ``wp.Mesh`` on the same rays, in one process.

Per (scene, ray kind) group every subject traces the same device ray buffer: wrt's binary, compact and wide (BVH4)
layouts over one SAH tree, ``wp.Mesh`` with the ``sah``, ``lbvh`` and (where Warp supports it on the device)
``cubql`` constructors, and, with ``--baseline``, the same wrt layouts from a copy of the package taken before the
traversal change (imported as ``wrt_old``; it shares the new tree, so only traversal code differs). Launches are
interleaved subject by subject; each subject gets warm-up launches, then ``--repeats`` launches timed with CUDA
events; the table gives the median in Mrays/s, the ratio to the best ``wp.Mesh`` of the group, and checks: hits
bit-identical (t, u, v, prim; blocked for shadow rays) between ``wrt_old`` and wrt, and the fraction of rays whose
``prim`` (or blocked flag) equals ``warp:sah``'s.

Scenes: ``sphere``, a displaced sphere (:func:`wrt.procedural.displaced_sphere`), or any asset id of the shared
assets (flattened), e.g. ``chess_set`` (1.43M triangles) or ``turbineblade_199k``. Ray kinds as in :mod:`wrt.rays`;
shadow rays use the any-hit kernels.

    python benchmarks/gpu_traversal_ab.py --assets .gpu/assets [--baseline .gpu] [--rays 2097152]
    python benchmarks/gpu_traversal_ab.py --device cpu --baseline .gpu --rays 65536 --constructors sah  # CPU check
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import inspect
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

START = time.perf_counter()


def log(msg: str) -> None:
    print(f"[{time.perf_counter() - START:6.1f}s] {msg}", flush=True)


class Subject:
    """One accelerator ready to trace the group's rays: ``launch()`` enqueues one trace; ``answer()`` reads it."""

    def __init__(self, name: str, kernel, accel_arg, rays: list, any_hit: bool, device, block_dim: int):
        self.name, self.kernel, self.accel_arg, self.rays, self.any_hit = name, kernel, accel_arg, rays, any_hit
        self.block_dim = block_dim
        n = len(rays[0])
        self.device = device
        if any_hit:
            self.outputs = [wp.zeros(n, dtype=wp.int32, device=device)]
        else:
            self.outputs = [wp.empty(n, dtype=float, device=device) for _ in range(3)]
            self.outputs += [wp.empty(n, dtype=wp.int32, device=device), wp.empty(n, dtype=wp.vec2i, device=device)]
        self.ms = []

    def launch(self) -> None:
        accel_args = self.accel_arg if isinstance(self.accel_arg, list) else [self.accel_arg]  # a mesh: id and box
        wp.launch(self.kernel, len(self.rays[0]), inputs=[*accel_args, *self.rays], outputs=self.outputs,
                  device=self.device, block_dim=self.block_dim)

    def timed(self) -> None:
        if not self.device.is_cuda:  # a CPU smoke run of the script
            start = time.perf_counter()
            self.launch()
            self.ms.append(1000.0 * (time.perf_counter() - start))
            return
        start, end = wp.Event(self.device, enable_timing=True), wp.Event(self.device, enable_timing=True)
        wp.record_event(start)
        self.launch()
        wp.record_event(end)
        wp.synchronize_event(end)
        self.ms.append(wp.get_event_elapsed_time(start, end))

    def answer(self) -> tuple:
        """``(blocked,)`` for any hit, ``(t bits, u bits, v bits, prim)`` for closest hit, as numpy arrays."""
        if self.any_hit:
            return (self.outputs[0].numpy(),)
        return (*(self.outputs[k].numpy().view(np.int32) for k in range(3)), self.outputs[3].numpy())


def depth_first(wide):
    """The wide tree ``wide`` (a host ``WideBvh``) with its nodes numbered in depth-first preorder, children in slot
    order, instead of level by level as the collapse numbers them (GPU_NOTES.md, next-session item 10: cuBQL keeps a
    node's subtree next to it). Same boxes and links, so the same hits."""
    width = wide.width
    inner = (wide.counts == 0).reshape(-1, width)
    refs = wide.refs.reshape(-1, width)
    order, stack = [], [0]
    while stack:
        node = stack.pop()
        order.append(node)
        stack.extend(refs[node][inner[node]][::-1].tolist())
    order = np.asarray(order, np.int64)
    new_id = np.empty(len(order), np.int64)
    new_id[order] = np.arange(len(order))
    slots = (order[:, None] * width + np.arange(width)).reshape(-1)
    new_refs = wide.refs[slots].copy()
    moved = wide.counts[slots] == 0
    new_refs[moved] = new_id[new_refs[moved]]
    return dataclasses.replace(wide, lowers=wide.lowers[slots], uppers=wide.uppers[slots],
                               refs=new_refs.astype(np.int32), counts=wide.counts[slots])


def make_rays(scene, kind: str, n: int, device, rays_module, trace_fn):
    """About ``n`` rays of ``kind`` (see :func:`wrt.rays.ray_set`); secondary rays start at hits traced on the GPU."""
    if kind == "incoherent":
        return rays_module.incoherent_rays(scene, n, seed=1)
    width = max(round(np.sqrt(n * 4.0 / 3.0)), 1)
    origins, directions = rays_module.camera_rays(scene, width=width, height=max(n // width, 1))
    if kind == "primary":
        return origins, directions
    hits = trace_fn(scene, origins, directions, accel="warp", builder="sah", device=device)
    return rays_module.secondary_rays(scene, kind, origins, directions, hits, seed=1)


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--assets", help="shared asset folder (sets WRT_ASSETS)")
    parser.add_argument("--baseline", help="folder holding wrt_old/, a copy of the wrt package before the change")
    parser.add_argument("--device", default="cuda:0", help="Override the default Warp device")
    parser.add_argument("--rays", type=int, default=1 << 21, help="rays per group (secondary: those that hit)")
    parser.add_argument("--repeats", type=int, default=10, help="timed launches per subject (median reported)")
    parser.add_argument("--sphere", type=int, default=2_000_000, help="triangles of the displaced sphere")
    parser.add_argument("--scenes", default="chess_set,sphere", help="comma list of sphere and shared asset ids")
    parser.add_argument("--kinds", default="primary,shadow,diffuse,incoherent", help="comma list of ray kinds")
    parser.add_argument("--layouts", default="binary,compact,wide", help="wrt layouts to measure")
    parser.add_argument("--constructors", default="sah,lbvh,cubql", help="wp.Mesh constructors to measure")
    parser.add_argument("--trees", default="8:1:6",
                        help="wrt trees to measure, as LEAF_SIZE:INTERSECTION_COST[:PRESPLIT] (sah) or "
                        "sbvh:ALPHA[:BUDGET] (sbvh_trial.py) each; a +dfs suffix numbers the wide nodes depth first")
    parser.add_argument("--block-dims", help="comma list of CUDA threads per block; subjects at other than "
                        "wrt.bvh.traverse.TRACE_BLOCK_DIM (the default: what wrt launches) are NAME/bBLOCK")
    parser.add_argument("--old-mesh", action="store_true", help="with --baseline, also time the baseline package's "
                        "wp.Mesh kernels (old-warp:NAME), for a change of wrt's wp.Mesh trace path")
    parser.add_argument("--json", help="also write the rows here (default: $OUT/gpu_traversal_ab.json if $OUT is set)")
    args = parser.parse_args()
    if args.assets:
        os.environ["WRT_ASSETS"] = str(Path(args.assets).resolve())
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository's wrt, not an installed one

    wp.config.quiet = True
    wp.config.enable_backward = False  # forward kernels only: halves the compile time of wrt.trace
    wp.init()
    device = wp.get_device(args.device)
    with wp.ScopedDevice(device):  # CUDA events are recorded on the current device's stream
        run(args, device)


def run(args, device) -> None:
    """Measures every group (see module docstring) and prints one table per group."""
    from wrt import rays as rays_module
    from wrt.bench import asset_path
    from wrt.bvh import build_bvh
    from wrt.procedural import displaced_sphere_scene
    from wrt.strict_json import strict_json
    from wrt.usd import load_usd

    packages = {"wrt": "wrt"}
    if args.baseline:
        sys.path.insert(0, str(Path(args.baseline).resolve()))
        if (Path(args.baseline) / "wrt_old" / "bvh" / "stack.py").is_file():
            # Warp registers the ``wrt_stack_*`` builtins by name, so a second registration would hide the first:
            # both packages use the new package's stack types (the same C++ code).
            sys.modules["wrt_old.bvh.stack"] = importlib.import_module("wrt.bvh.stack")
        packages = {"old": "wrt_old", "wrt": "wrt"}
    trace_mods = {tag: importlib.import_module(f"{pkg}.trace") for tag, pkg in packages.items()}
    layout_mods = {tag: importlib.import_module(f"{pkg}.bvh.layout") for tag, pkg in packages.items()}
    new_trace = trace_mods["wrt"]
    gpu = f"{device.name}" if device.is_cuda else "cpu"
    log(f"device {device.alias}: {gpu}, Warp {wp.config.version}, packages {list(packages.values())}")

    rows = []
    for scene_name in args.scenes.split(","):
        log(f"scene {scene_name}: loading")
        scene = displaced_sphere_scene(args.sphere) if scene_name == "sphere" else load_usd(asset_path(scene_name))
        points, indices = scene.triangles()
        wrt_subjects = []  # (name, trace kernel, occluded kernel, device tree)
        for variant in args.trees.split(","):
            fields = variant.removesuffix("+dfs").split(":")
            log(f"scene {scene_name}: {len(indices)} triangles; building wrt tree {variant} on {device.alias}")
            start = time.perf_counter()
            if fields[0] == "sbvh":  # the spatial-split trial (sbvh_trial.py): sbvh:ALPHA[:BUDGET]
                from sbvh_trial import build_sbvh
                budget = {"budget": float(fields[2])} if len(fields) > 2 else {}
                flat = build_sbvh(points, indices, alpha=float(fields[1]), clip_device=device, **budget)
            else:
                leaf_size, intersection_cost = int(fields[0]), float(fields[1])
                presplit = {"presplit": int(fields[2])} if len(fields) > 2 else {}
                flat = build_bvh(points, indices, "sah", leaf_size=leaf_size, intersection_cost=intersection_cost,
                                 device=device, **presplit)
            log(f"  wrt tree {variant}: {1000 * (time.perf_counter() - start):.0f} ms, {flat.num_nodes} nodes, "
                f"SAH {flat.stats(epo_samples=0)['sah_cost']:.2f}")
            suffix = "" if variant == "8:1:6" else f"@{variant}"  # the accelerators' tree (trace.py) unnamed
            for layout in args.layouts.split(","):
                for tag, mod in layout_mods.items():
                    # The same tree as each package's own FlatBvh, so its kernels get their own struct types.
                    own = mod.FlatBvh(**{f.name: getattr(flat, f.name) for f in dataclasses.fields(flat)})
                    converted = mod.convert_layout(own, layout)
                    if variant.endswith("+dfs"):
                        if not layout.startswith("wide"):
                            continue
                        converted = depth_first(converted)
                    tree = converted.to_device(points, indices, device)
                    # Closest hit without per-ray cost counters where the package has such kernels (wrt.trace's
                    # Accelerator docstring): what renders trace their bounces with, and wp.Mesh counts nothing.
                    if layout == "binary":
                        trace = getattr(trace_mods[tag], "trace_bvh_kernel_uncounted", trace_mods[tag].trace_bvh_kernel)
                        kernels = trace, trace_mods[tag].occluded_bvh_kernel
                    elif "counted" in inspect.signature(mod.layout_kernels).parameters:
                        kernels = mod.layout_kernels(layout, counted=False)
                    else:
                        kernels = mod.layout_kernels(layout)
                    wrt_subjects.append((f"{tag}:{layout}{suffix}", *kernels, tree))
        mesh_points = wp.array(points, dtype=wp.vec3, device=device)
        mesh_indices = wp.array(indices.reshape(-1), dtype=wp.int32, device=device)
        meshes = {}
        for constructor in args.constructors.split(","):
            try:
                start = time.perf_counter()
                meshes[constructor] = wp.Mesh(mesh_points, mesh_indices, bvh_constructor=constructor)
                wp.synchronize_device(device)
                log(f"  wp.Mesh {constructor}: {1000 * (time.perf_counter() - start):.0f} ms")
            except Exception as e:  # noqa: BLE001 - cubql is not available everywhere
                log(f"  wp.Mesh {constructor}: skipped ({type(e).__name__}: {e})".splitlines()[0])

        for kind in args.kinds.split(","):
            origins, directions = make_rays(scene, kind, args.rays, device, rays_module, new_trace.trace)
            n = len(origins)
            any_hit = kind == "shadow"
            rays = [
                wp.array(origins, dtype=wp.vec3, device=device),
                wp.array(directions, dtype=wp.vec3, device=device),
                wp.zeros(n, dtype=float, device=device),
                wp.full(n, np.inf, dtype=float, device=device),
            ]
            mesh_kernel = new_trace.occluded_mesh_kernel if any_hit else new_trace.trace_mesh_kernel
            subjects = []
            default_block = importlib.import_module("wrt.bvh.traverse").TRACE_BLOCK_DIM
            for block in (int(b) for b in (args.block_dims or str(default_block)).split(",")):
                label = "" if block == default_block else f"/b{block}"
                subjects += [Subject(name + label, occluded if any_hit else closest, tree, rays, any_hit, device, block)
                             for name, closest, occluded, tree in wrt_subjects]
                subjects += [Subject(f"warp:{c}{label}", mesh_kernel, [m.id, *new_trace.mesh_box(points)], rays,
                                     any_hit, device, block)
                             for c, m in meshes.items()]
                if args.old_mesh and "old" in trace_mods:
                    old_trace = trace_mods["old"]
                    old_kernel = old_trace.occluded_mesh_kernel if any_hit else old_trace.trace_mesh_kernel
                    subjects += [Subject(f"old-warp:{c}{label}", old_kernel, [m.id, *old_trace.mesh_box(points)],
                                         rays, any_hit, device, block) for c, m in meshes.items()]
            log(f"{scene_name} {kind}: {n} rays, {len(subjects)} subjects; compiling and warming up")
            for s in subjects:
                s.launch()
                s.launch()
            wp.synchronize_device(device)
            for _ in range(args.repeats):
                for s in subjects:
                    s.timed()
            answers = {s.name: s.answer() for s in subjects}
            reference = answers.get("warp:sah")
            best_mesh = max((n / statistics.median(s.ms) / 1e3 for s in subjects if s.name.startswith("warp:")),
                            default=None)
            for s in subjects:
                mrays = n / statistics.median(s.ms) / 1e3
                row = {"scene": scene_name, "rays": kind, "n": n, "subject": s.name, "mrays": mrays,
                       "mrays_min": n / max(s.ms) / 1e3, "mrays_max": n / min(s.ms) / 1e3,
                       "x_best_mesh": mrays / best_mesh if best_mesh else None}
                if reference is not None:
                    row["agree_warp_sah"] = float(np.mean(answers[s.name][-1] == reference[-1]))
                old = answers.get("old:" + s.name.split(":", 1)[1]) if s.name.startswith("wrt:") else None
                if s.name.startswith("warp:"):  # the baseline's wp.Mesh kernel (--old-mesh), where it ran
                    old = answers.get("old-" + s.name)
                if "@" in s.name:  # another tree of the same triangles: the default tree's hits are the reference
                    old = answers.get(s.name.split("@")[0])
                if "/b" in s.name and old is None:  # another block size: the default block size's hits
                    old = answers.get(s.name.split("/b")[0])
                if old is not None:
                    row["identical_to_old"] = all(np.array_equal(a, b) for a, b in zip(answers[s.name], old))
                rows.append(row)
            print_group(rows[-len(subjects):])
    log("done")
    out = args.json or (os.path.join(os.environ["OUT"], "gpu_traversal_ab.json") if os.environ.get("OUT") else None)
    if out:
        Path(out).write_text(strict_json({"device": gpu, "warp": wp.config.version, "rows": rows}, indent=1))
        log(f"rows written to {out}")


def print_group(rows: list[dict]) -> None:
    """One table per (scene, ray kind): Mrays/s median (min-max), ratio to the best wp.Mesh, checks."""
    r0 = rows[0]
    print(f"\n{r0['scene']} / {r0['rays']} ({r0['n']} rays)")
    print(f"  {'subject':18s} {'Mrays/s':>9s} {'(min-max)':>17s} {'x best Mesh':>11s} {'agree sah':>9s} {'= old':>6s}")
    for r in rows:
        same = {True: "yes", False: "NO"}.get(r.get("identical_to_old"), "")
        ratio = "" if r["x_best_mesh"] is None else f"{r['x_best_mesh']:.2f}x"
        agree = "" if "agree_warp_sah" not in r else f"{100 * r['agree_warp_sah']:.2f}%"
        print(f"  {r['subject']:18s} {r['mrays']:9.1f} ({r['mrays_min']:7.1f}-{r['mrays_max']:7.1f}) {ratio:>11s} "
              f"{agree:>9s} {same:>6s}", flush=True)


if __name__ == "__main__":
    main()
