"""Rebuilding many deformed prototypes in ``InstancedAccelerator.update``: the BLASes past their refit limit built
together (``wrt.bvh.build.build_bvhs``, as at load) against one by one (``build_bvh``, ``to_device`` and a new
``Refitter`` per tree: what ``update`` did before stop 55).

A scene of ``--prototypes`` small random meshes (``--triangles`` each, one instance each) is built, every vertex is
moved, and each run times, interleaved: ``update`` refitting only, ``update`` rebuilding every tree, and the refit
followed by the per-tree rebuilds. The trees of both rebuilds are checked equal (every node array, bit for bit)
before timing. Warp's CPU launches run on one thread; ``threads=1`` keeps the batch's split on one too.

Usage: python benchmarks/update_rebuild.py [--prototypes 2000] [--triangles 20 300] [--runs 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import wrt
import wrt.tlas
from wrt.bvh import build_bvh
from wrt.bvh.refit import Refitter
from wrt.cli import positive_int
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh

FIELDS = ("lowers", "uppers", "left_first", "prim_count", "prim_ids")


def prototype_scene(counts: list[int], rng, scale: float = 1.0) -> wrt.Scene:
    """One random mesh of ``counts[p]`` triangles per prototype, one instance each (spread over a line)."""
    protos = []
    for p, n in enumerate(counts):
        points = (rng.normal(size=(n + 2, 3)) * scale).astype(np.float32)
        indices = rng.integers(0, n + 2, (n, 3)).astype(np.int32)
        protos.append(Prototype(f"/P{p}", [Mesh(f"/P{p}/m", points, indices, np.arange(n))]))
    to_world = np.stack([np.eye(4)] * len(counts))
    to_world[:, 0, 3] = 3.0 * np.arange(len(counts))
    return wrt.Scene(prototypes=protos, instances=Instances.from_transforms(np.arange(len(counts)), to_world))


def moved(scene: wrt.Scene, rng) -> wrt.Scene:
    """The same topology with every vertex moved at random."""
    protos = [Prototype(p.path, [Mesh(m.path, rng.normal(size=m.points.shape).astype(np.float32) * 2, m.indices,
                                      np.arange(len(m.indices))) for m in p.meshes]) for p in scene.prototypes]
    return wrt.Scene(prototypes=protos, instances=scene.instances)


def one_by_one(accel, scene) -> None:
    """``update`` refitting every tree, then each tree built anew alone (the path before stop 55)."""
    accel.update(scene, refit_blas=True)
    points, indices = scene.geometry()
    for b, part in enumerate(accel._blas_parts):
        mesh = wrt.tlas._part_triangles(scene, points, indices, *part)
        tree = build_bvh(*mesh, accel.builder, device=accel.device, **accel.build_options)
        accel.blas[b], accel._device_blas[b] = tree, tree.to_device(*mesh, accel.device)
        accel._refitters[b] = Refitter(tree, accel._device_blas[b], accel.device)
    accel._build_tlas(scene)


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--prototypes", type=positive_int, default=2000)
    parser.add_argument("--triangles", type=positive_int, nargs=2, default=[20, 300], help="range per prototype")
    parser.add_argument("--runs", type=positive_int, default=7)
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    counts = rng.integers(args.triangles[0], args.triangles[1] + 1, args.prototypes).tolist()
    first = prototype_scene(counts, rng)
    second = moved(first, rng)

    def accel():
        return wrt.tlas.InstancedAccelerator(first, "sah", "cpu", threads=1)

    cases = {
        "refit only": lambda a: a.update(second, refit_blas=True),
        "rebuild all, together": lambda a: a.update(second, refit_blas=True, rebuild=lambda b, tree: True),
        "rebuild all, one by one": lambda a: one_by_one(a, second),
    }
    together, alone = accel(), accel()
    cases["rebuild all, together"](together)
    cases["rebuild all, one by one"](alone)
    for j, (x, y) in enumerate(zip(together.blas, alone.blas)):
        for field in FIELDS:
            a, b = np.asarray(getattr(x, field)), np.asarray(getattr(y, field))
            if a.dtype != b.dtype or a.shape != b.shape or not np.array_equal(a.view(np.uint8), b.view(np.uint8)):
                raise SystemExit(f"Validation failed: tree {j} {field} differs")
    times = {name: [] for name in cases}
    cpu = {name: [] for name in cases}  # process CPU time: steadier than wall time on a shared machine
    for _ in range(args.runs):
        for name, run in cases.items():
            a = accel()
            start, start_cpu = time.perf_counter(), time.process_time()
            run(a)
            times[name].append(time.perf_counter() - start)
            cpu[name].append(time.process_time() - start_cpu)
    print(f"{args.prototypes} prototypes, {sum(counts)} triangles; update, ms over {args.runs} interleaved runs")
    print("| case | wall median | wall min | CPU median | CPU min |\n|---|---|---|---|---|")
    for name, t in times.items():
        print(f"| {name} | {1000 * statistics.median(t):.0f} | {1000 * min(t):.0f} | "
              f"{1000 * statistics.median(cpu[name]):.0f} | {1000 * min(cpu[name]):.0f} |")


if __name__ == "__main__":
    main()
