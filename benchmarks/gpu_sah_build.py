"""GPU ``sah`` build time: nodes split by one thread per slot above ``parallel_min`` triangles, against one thread per
node, and against ``wp.Mesh(bvh_constructor="sah")`` in the same process.

Each variant is ``PARALLEL_MIN:SUBTREE_SIZE`` (``off`` for one thread per node everywhere) and builds the tree
that the accelerators build (``presplit=6``, ``wrt.trace.ACCELERATOR_PRESPLIT``) with ``build_bvh_device``, timed
with a synchronizing ``wp.ScopedTimer``, median of ``--repeats`` after one warm-up build. Variants of one subtree
size must give the same tree, bit for bit: the script says so, or exits 1. The subtree size changes the node
numbering (breadth first above it, depth first below), which the binary and compact layouts keep: ``--trace``
times their closest hit (``wrt bench``'s harness) on each variant's tree.

Usage::

    python benchmarks/gpu_sah_build.py --scenes asset:chess_set,sphere:1e7
    python benchmarks/gpu_sah_build.py --device cpu --scenes sphere:1e5 --variants off:4096,4096:4096  # dry run
"""

import argparse
import functools
import statistics
import sys

import numpy as np
import warp as wp

from wrt.bench import ANY_HIT_KINDS, _Subject, resolve_scene, time_runs
from wrt.bvh import binned, build_bvh_device
from wrt.rays import ray_set
from wrt.trace import ACCELERATOR_PRESPLIT

FIELDS = ("lowers", "uppers", "left_first", "prim_count", "prim_ids")


def parse_variant(text: str) -> tuple[int | None, int]:
    parallel, _, subtree = text.partition(":")
    return (binned.NO_PARALLEL if parallel == "off" else int(parallel)), int(subtree)


def build_ms(fn, repeats: int) -> tuple[float, object]:
    result = fn()  # warm-up (and kernel compilation)
    times = {}
    for _ in range(repeats):
        del result
        with wp.ScopedTimer("build", dict=times, print=False, synchronize=True):
            result = fn()
    return statistics.median(times["build"]), result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--scenes", default="asset:chess_set,sphere:1e7", help="comma-separated wrt bench scenes")
    parser.add_argument("--variants", default="off:4096,256:4096,256:64",
                        help="comma-separated PARALLEL_MIN:SUBTREE_SIZE, 'off' for no parallel nodes")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--skip-off-above", type=int, default=3_000_000,
                        help="skip the 'off' variant on meshes above this many triangles (tens of seconds each)")
    parser.add_argument("--trace", default="", help="comma-separated ray kinds to trace on each variant's tree")
    parser.add_argument("--rays", type=int, default=1 << 21, help="rays per kind with --trace")
    parser.add_argument("--layouts", default="binary", help="comma-separated layouts traced with --trace")
    args = parser.parse_args(argv)
    kinds = [k for k in args.trace.split(",") if k]
    device = wp.get_device(args.device)
    original = binned.build_binned
    same = True
    print(f"device {device.name}, warp {wp.__version__}, presplit={ACCELERATOR_PRESPLIT}, repeats {args.repeats}")
    for name in args.scenes.split(","):
        scene = resolve_scene(name)
        points, indices = scene.triangles()
        dev_points = wp.array(points, dtype=wp.vec3, device=device)
        dev_indices = wp.array(indices, dtype=wp.int32, device=device)
        mesh_ms, _ = build_ms(lambda: wp.Mesh(dev_points, dev_indices.flatten(), bvh_constructor="sah"), args.repeats)
        print(f"\n{name}: {len(indices):,} triangles; wp.Mesh(sah) {mesh_ms:.1f} ms\n")
        rays = {kind: ray_set(scene, kind, args.rays, seed=1) for kind in kinds}
        traced = [f"{layout} {kind} Mrays/s" for layout in args.layouts.split(",") for kind in kinds]
        print("| parallel_min | subtree_size | build ms | / wp.Mesh(sah) | nodes | same tree |" + "".join(
            f" {t} |" for t in traced))
        print("|---|---|---|---|---|---|" + "---|" * len(traced))
        reference = {}
        for text in args.variants.split(","):
            parallel_min, subtree = parse_variant(text)
            if parallel_min == binned.NO_PARALLEL and len(indices) > args.skip_off_above:
                print(f"| off | {subtree} | skipped | | | |")
                continue
            binned.build_binned = functools.partial(original, parallel_min=parallel_min, subtree_size=subtree)
            speeds = []
            try:
                build = functools.partial(build_bvh_device, dev_points, dev_indices, "sah",
                                          presplit=ACCELERATOR_PRESPLIT, device=device)
                ms, tree = build_ms(build, args.repeats)
                for layout in args.layouts.split(",") if kinds else []:
                    subject = _Subject("wrt:sah" + ("" if layout == "binary" else f":{layout}"), scene, device, 1)
                    for kind in kinds:
                        subject.prepare(*rays[kind], kind in ANY_HIT_KINDS)
                        speeds.append(len(rays[kind][0]) / statistics.median(time_runs(subject.run, 10)) / 1e6)
            finally:
                binned.build_binned = original
            arrays = {f: getattr(tree, f).numpy() for f in FIELDS}
            ref = reference.setdefault(subtree, arrays)
            equal = all(np.array_equal(arrays[f], ref[f]) for f in FIELDS)
            same &= equal
            label = "off" if parallel_min == binned.NO_PARALLEL else parallel_min
            print(f"| {label} | {subtree} | {ms:.1f} | {ms / mesh_ms:.2f}x | {len(arrays['left_first']):,} | "
                  f"{'yes' if equal else 'NO'} |" + "".join(f" {v:.0f} |" for v in speeds))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
