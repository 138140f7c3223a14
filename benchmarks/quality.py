"""BVH quality and CPU build speed: wrt's builders next to Warp's own trees on the same meshes.

Quality: for each scene, every wrt builder and Warp's ``wp.Mesh`` trees (read back through
``wrt.bvh.warp_mesh``) are measured by the same code (``FlatBvh.stats``): SAH cost and EPO under the same cost
constants, node/leaf counts, depths, leaf sizes, bytes, build time. The issue's quality claims are checked and
printed as PASS/MISS lines.

Speed: ``build_bvh(builder="sah")`` against ``wp.Mesh(bvh_constructor="sah")`` on the same device arrays, in the
same run, alternating, ``--repeats`` times each (min and median reported), on a generated ~1M-triangle mesh and
on each scene: wrt with one thread (like Warp's builder), with every core (its launches split between threads),
and from numpy input (upload and checks included).

Usage::

    python benchmarks/quality.py                       # turbineblade_199k and chess_set, all builders, speed
    python benchmarks/quality.py --scenes turbineblade_199k --no-speed --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

import wrt
from wrt.bvh import build_bvh
from wrt.bvh.report import collect_stats, format_table, parse_builders
from wrt.cli import non_negative_int, positive_int
from wrt.strict_json import strict_json

ASSETS = Path(os.environ.get("WRT_ASSETS", Path(__file__).resolve().parents[2] / "shared" / "assets"))
WRT_BUILDERS = "sweep_sah,sah,median,middle,lbvh,ploc"
WARP_BUILDERS = ("sah", "median", "cubql")  # wp.Mesh constructors available on the CPU (lbvh is CUDA only)


def cpu_name() -> str:
    """The CPU model from ``lscpu`` (or the platform string)."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        fields = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
        return f"{fields['Model name'].strip()}, {fields['CPU(s)'].strip()} logical CPUs"
    except (OSError, KeyError, subprocess.CalledProcessError):
        return platform.processor() or platform.machine()


def load_scene(asset_id: str) -> tuple[np.ndarray, np.ndarray]:
    """``(points, indices)`` of a manifest scene, loaded with ``wrt.load_usd``."""
    with open(ASSETS / "manifest.json") as f:
        entries = {e["id"]: e for e in json.load(f)["assets"]}
    if asset_id not in entries:
        raise SystemExit(f"quality.py: unknown asset {asset_id!r} (not in {ASSETS / 'manifest.json'})")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(ASSETS / entries[asset_id]["path"])
    points, indices = scene.triangles()
    return np.ascontiguousarray(points, np.float32), np.ascontiguousarray(indices, np.int32)


def generated_mesh(n_target: int = 1_000_000, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A closed, bumpy sphere of about ``n_target`` triangles (a UV grid with a displaced radius)."""
    rings = int(np.sqrt(n_target / 4))
    segments = 2 * rings
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    rng = np.random.default_rng(seed)
    bumps = 1 + 0.05 * np.sin(7 * t) * np.cos(11 * p) + 0.002 * rng.standard_normal(t.shape)
    points = np.stack([bumps * np.sin(t) * np.cos(p), bumps * np.sin(t) * np.sin(p), bumps * np.cos(t)], -1)
    idx = np.arange((rings + 1) * segments).reshape(rings + 1, segments)
    a, b = idx[:-1], np.roll(idx[:-1], -1, axis=1)
    c, d = idx[1:], np.roll(idx[1:], -1, axis=1)
    tris = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)])
    return points.reshape(-1, 3).astype(np.float32), tris.astype(np.int32)


def check(label: str, ok: bool, detail: str) -> str:
    line = f"- {'PASS' if ok else 'MISS'}: {label} ({detail})"
    print(line)
    return line


def quality(name: str, points, indices, args) -> dict:
    """The statistics table of one scene and the quality checks."""
    print(f"\n### {name}: {len(indices)} triangles\n", flush=True)
    rows = collect_stats(points, indices, args.builders, epo_samples=args.epo_samples, device="cpu")
    for leaf in (None, 1):
        for constructor in WARP_BUILDERS:
            row = collect_stats(
                points, indices, f"warp:{constructor}", warp_leaf_size=leaf, epo_samples=args.epo_samples
            )[0]
            if leaf is not None:
                if constructor == "cubql":
                    continue  # cubql's leaf size 1 is already its default
                row["builder"] += f" (leaf {leaf})"
            rows.append(row)
    print(format_table(rows), flush=True)
    cost = {r["builder"]: r["sah_cost"] for r in rows}
    checks = []
    if {"sweep_sah", "sah", "median"} <= cost.keys():
        sweep, binned, median = cost["sweep_sah"], cost["sah"], cost["median"]
        checks.append(
            check(
                "sweep_sah <= binned_sah <= median",
                sweep <= binned <= median,
                f"{sweep:.2f} <= {binned:.2f} <= {median:.2f}",
            )
        )
        checks.append(
            check("binned_sah within 3% of sweep_sah", binned <= 1.03 * sweep, f"+{100 * (binned / sweep - 1):.2f}%")
        )
        best_warp = min(cost["warp:sah"], cost.get("warp:sah (leaf 1)", np.inf))
        checks.append(
            check(
                "binned_sah <= Warp's sah tree",
                binned <= best_warp,
                f"{binned:.2f} vs {cost['warp:sah']:.2f} (leaf 4), "
                f"{cost.get('warp:sah (leaf 1)', float('nan')):.2f} (leaf 1)",
            )
        )
    if {"ploc", "sah"} <= cost.keys():
        checks.append(
            check(
                "ploc SAH within 10% of binned_sah (CPU build; same tree as on GPU)",
                cost["ploc"] <= 1.10 * cost["sah"],
                f"{100 * (cost['ploc'] / cost['sah'] - 1):+.2f}%",
            )
        )
    return {"scene": name, "triangles": int(len(indices)), "rows": rows, "checks": checks}


def speed(name: str, points, indices, repeats: int) -> dict:
    """CPU build time of wrt's binned SAH against ``wp.Mesh(bvh_constructor="sah")``, alternating."""
    pts = wp.array(points, dtype=wp.vec3, device="cpu")
    idx = wp.array(indices.reshape(-1), dtype=wp.int32, device="cpu")
    idx2 = idx.reshape((-1, 3))
    build_bvh(np.eye(3, dtype=np.float32), [[0, 1, 2]], device="cpu")  # load the kernels before timing
    cores = os.cpu_count() or 1
    times = {"wp.Mesh sah": [], "wrt sah, 1 thread": [], f"wrt sah, {cores} threads": [], "wrt sah, numpy input": []}
    for _ in range(repeats):
        start = time.perf_counter()
        mesh = wp.Mesh(pts, idx, bvh_constructor="sah")
        times["wp.Mesh sah"].append(time.perf_counter() - start)
        del mesh
        start = time.perf_counter()
        build_bvh(pts, idx2, "sah", threads=1, device="cpu")
        times["wrt sah, 1 thread"].append(time.perf_counter() - start)
        start = time.perf_counter()
        build_bvh(pts, idx2, "sah", threads=cores, device="cpu")
        times[f"wrt sah, {cores} threads"].append(time.perf_counter() - start)
        start = time.perf_counter()
        build_bvh(points, indices, "sah", device="cpu")
        times["wrt sah, numpy input"].append(time.perf_counter() - start)
    warp_min = min(times["wp.Mesh sah"])
    print(f"\n### CPU build time, {name}: {len(indices)} triangles, {repeats} runs each, alternating\n")
    print("| build | min s | median s | min / wp.Mesh min |\n|---|---|---|---|")
    for key, values in times.items():
        print(f"| {key} | {min(values):.3f} | {statistics.median(values):.3f} | {min(values) / warp_min:.2f}x |")
    ratio = min(times[f"wrt sah, {cores} threads"]) / warp_min
    single = min(times["wrt sah, 1 thread"]) / warp_min
    line = check(
        "CPU binned_sah <= 2x wp.Mesh(sah)", ratio <= 2.0, f"{ratio:.2f}x with {cores} threads, {single:.2f}x with 1"
    )
    return {"mesh": name, "triangles": int(len(indices)), "times": times, "ratio": ratio, "check": line}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        allow_abbrev=False,
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    parser.add_argument("--scenes", default="turbineblade_199k,chess_set", help="manifest ids, comma-separated")
    parser.add_argument("--builders", default=WRT_BUILDERS, help="wrt builders, comma-separated")
    parser.add_argument("--epo-samples", type=non_negative_int, default=1 << 16,
                        help="surface samples of the EPO estimate")
    parser.add_argument("--repeats", type=positive_int, default=5, help="runs per build in the speed comparison")
    parser.add_argument("--speed-triangles", type=positive_int, default=1_000_000,
                        help="size of the generated speed mesh")
    parser.add_argument("--no-speed", action="store_true", help="skip the build-speed comparison")
    parser.add_argument("--json", help="also write every number to this JSON file")
    args = parser.parse_args(argv)
    try:
        parse_builders(args.builders)
    except ValueError as e:
        parser.error(f"--builders: {e}")
    wp.config.quiet = True
    wp.init()
    print(
        f"wrt BVH quality and CPU build speed; warp-lang {wp.config.version}; CPU: {cpu_name()}; "
        "SAH/EPO constants C_t = C_i = 1; wrt leaf_size 8, Warp bvh_leaf_size 4 (its default) unless noted"
    )
    results = {"cpu": cpu_name(), "warp": wp.config.version, "quality": [], "speed": []}
    scenes = {}
    for name in [s for s in args.scenes.split(",") if s]:
        scenes[name] = load_scene(name)
        results["quality"].append(quality(name, *scenes[name], args))
    if not args.no_speed:
        meshes = {"generated sphere": generated_mesh(args.speed_triangles)}
        meshes.update(scenes)
        for name, (points, indices) in meshes.items():
            results["speed"].append(speed(name, points, indices, args.repeats))
    if args.json:
        with open(args.json, "w") as f:  # strict: a scene without area has no EPO (NaN), written as null
            f.write(strict_json(results, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
