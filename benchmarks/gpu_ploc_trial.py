"""PLOC build variants against ``wp.Mesh(lbvh)`` and the previous package, in one run (GPU_NOTES rows 13, 14, 21).

Builds one displaced sphere (10M triangles by default) with ``wp.Mesh(bvh_constructor="lbvh")``, with ``ploc`` from
a copy of the package taken before the change (``--baseline DIR`` holding ``wrt_old/``), and with the current
``ploc`` for each ``--tails`` value of ``wrt.bvh.ploc.TAIL_CLUSTERS`` (the cluster count below which one thread
block finishes the clustering). Per variant: median and minimum build time of ``--repeats`` synchronized runs after a
warm-up, the ratio to ``wp.Mesh(lbvh)``, the number of global clustering iterations, the per-stage times of one
more run, the SAH cost (C_t = C_i = 1) and whether the tree equals the baseline's.

    python benchmarks/gpu_ploc_trial.py --baseline .gpu/ploc [--triangles 10000000] [--tails 8192,4096,2048]
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import sys
import time

import numpy as np
import warp as wp

FIELDS = ("lowers", "uppers", "left_first", "prim_count", "prim_ids")


def timed_ms(fn) -> float:
    """Milliseconds of one synchronized run of ``fn``."""
    wp.synchronize()
    start = time.perf_counter()
    fn()
    wp.synchronize()
    return 1e3 * (time.perf_counter() - start)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", help="folder holding wrt_old/, a copy of the wrt package before the change")
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--triangles", type=int, default=10_000_000)
    parser.add_argument("--tails", default="8192", help="comma list of TAIL_CLUSTERS values to try")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    wp.config.quiet = True
    wp.init()
    import wrt.bvh.ploc as ploc
    from wrt.bvh import build_bvh_device
    from wrt.procedural import displaced_sphere

    device = wp.get_device(args.device)
    points, indices = displaced_sphere(args.triangles)
    pts = wp.array(points, dtype=wp.vec3, device=device)
    idx = wp.array(indices, dtype=wp.int32, device=device)
    print(f"## ploc variants: {len(indices):,} triangles on {device.alias} ({device.name}), warp {wp.config.version}\n")

    constructor = "lbvh" if device.is_cuda else "sah"  # wp.Mesh has no CPU lbvh
    reference_name = f"wp.Mesh {constructor}"
    subjects = {reference_name: lambda: wp.Mesh(pts, idx.reshape((-1,)), bvh_constructor=constructor)}
    old_build = None
    if args.baseline:
        sys.path.insert(0, args.baseline)
        old_build = importlib.import_module("wrt_old.bvh").build_bvh_device
        subjects["old ploc"] = lambda: old_build(pts, idx, "ploc", device=device)
    tails = [int(t) for t in args.tails.split(",")]
    for tail in tails:
        subjects[f"ploc tail {tail}"] = lambda tail=tail: build_with_tail(ploc, tail, pts, idx, device)

    small = displaced_sphere(20_000)
    for name, fn in subjects.items():  # compile, then one full-size warm-up
        if name != reference_name:
            (old_build if name == "old ploc" else build_bvh_device)(*small, "ploc", device=device)
        fn()
    times = {name: [] for name in subjects}
    for _ in range(args.repeats):  # subjects take turns
        for name, fn in subjects.items():
            times[name].append(timed_ms(fn))

    reference = statistics.median(times[reference_name])
    old_tree = old_build(pts, idx, "ploc", device=device) if old_build else None
    print(f"| build | median ms | min ms | / {reference_name} | iterations | SAH cost | tree = old |")
    print("|---|---|---|---|---|---|---|")
    stage_rows = {}
    for name, values in times.items():
        mid = statistics.median(values)
        row = f"| {name} | {mid:.1f} | {min(values):.1f} | {mid / reference:.2f}x"
        if name.startswith("ploc tail"):
            tail = int(name.split()[-1])
            reads = count_reads(ploc)
            timers = {}
            tree = build_with_tail(ploc, tail, pts, idx, device, timers=timers)
            stage_rows[name] = {k: v[-1] if isinstance(v, list) else v for k, v in timers.items()}
            same = "-" if old_tree is None else same_tree(tree, old_tree)
            cost = tree.to_host().stats(epo_samples=0)["sah_cost"]
            row += f" | {reads()} | {cost:.3f} | {same} |"
        elif name == "old ploc":
            row += f" | - | {old_tree.to_host().stats(epo_samples=0)['sah_cost']:.3f} | - |"
        else:
            row += " | - | - | - |"
        print(row, flush=True)
    print("\n### Stages of one synchronized run (ms)\n")
    names = list(dict.fromkeys(s for stages in stage_rows.values() for s in stages))
    print("| stage | " + " | ".join(stage_rows) + " |\n" + "|---" * (len(stage_rows) + 1) + "|")
    for s in names:
        print(f"| {s} | " + " | ".join(f"{stages.get(s, float('nan')):.2f}" for stages in stage_rows.values()) + " |")
    return 0


def build_with_tail(ploc, tail: int, pts, idx, device, timers=None):
    from wrt.bvh import build_bvh_device

    saved = ploc.TAIL_CLUSTERS
    ploc.TAIL_CLUSTERS = tail
    try:
        return build_bvh_device(pts, idx, "ploc", device=device, timers=timers)
    finally:
        ploc.TAIL_CLUSTERS = saved


def count_reads(ploc):
    """Counts the clustering's reads back (one per global iteration) from now on; returns a reader."""
    calls = [0]
    read = ploc.read_int

    def counting(*a, **k):
        calls[0] += 1
        return read(*a, **k)

    ploc.read_int = counting

    def result():
        ploc.read_int = read
        return calls[0]

    return result


def same_tree(a, b) -> str:
    return "yes" if all(np.array_equal(getattr(a, f).numpy(), getattr(b, f).numpy()) for f in FIELDS) else "no"


if __name__ == "__main__":
    sys.exit(main())
