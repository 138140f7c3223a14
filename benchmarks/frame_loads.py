"""Per-frame load of animated stages: a fresh ``wrt.load_usd`` at every frame against ``wrt.usd_frames.StageFrames``
(the stage kept, meshes that cannot differ reused), as ``wrt render --frames`` loads them. Every kept load is checked
against the fresh one (every mesh array, bytes) before its time counts. Prints a markdown table.

Usage: python benchmarks/frame_loads.py [--frames 1:48:6] [--count 200] [--profile] [--assets DIR] [SCENE ...]

Without SCENE: ``scenes/make_mostly_static_scene.py``'s stage (``--count`` meshes of 10k triangles beside one moving
Xform and one deforming mesh) as .usda and .usdc, and the shared assets teapot_scene_1000 (frames 0:479:40, every
mesh deforms) and usdz_animated_cube (0:48:2, a textured cube that turns).
``--profile`` prints cProfile's top functions of one fresh and one kept load of each scene. The fresh loads are
timed before any stage is kept (a kept stage's layers would spare a fresh open the parse of the file).
"""

from __future__ import annotations

import argparse
import cProfile
import importlib.util
import json
import os
import pstats
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from wrt.animation import parse_frames
from wrt.usd import load_usd
from wrt.usd_frames import StageFrames

ROOT = Path(__file__).resolve().parents[1]
MESH_FIELDS = ("points", "indices", "face_ids", "normals", "colors", "uvs", "material_ids", "opacities")


def mostly_static(folder: Path, count: int) -> list[Path]:
    from pxr import Usd

    spec = importlib.util.spec_from_file_location("make_mostly_static_scene",
                                                  ROOT / "scenes" / "make_mostly_static_scene.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    usda = module.write(folder / "mostly_static.usda", count)
    usdc = folder / "mostly_static.usdc"
    Usd.Stage.Open(str(usda)).Export(str(usdc))
    return [usda, usdc]


def same_meshes(a, b) -> bool:
    meshes = lambda s: list(s.meshes) + [m for p in s.prototypes for m in p.meshes]  # noqa: E731
    if len(meshes(a)) != len(meshes(b)) or len(a.materials) != len(b.materials):
        return False
    for x, y in zip(meshes(a), meshes(b)):
        for name in MESH_FIELDS:
            u, v = getattr(x, name), getattr(y, name)
            if (u is None) != (v is None) or (u is not None and (u.shape != v.shape or u.tobytes() != v.tobytes())):
                return False
    return True


def profile(load, label: str) -> None:
    pr = cProfile.Profile()
    pr.enable()
    load()
    pr.disable()
    print(f"\n<details><summary>cProfile: {label}</summary>\n\n```")
    pstats.Stats(pr).sort_stats("cumulative").print_stats(14)
    print("```\n</details>\n")


def measure(path: Path, frames: list[float], do_profile: bool) -> dict:
    # Fresh loads first, with no stage kept: a kept stage holds its layers in USD's registry, and a fresh open of
    # the same file then takes them from there instead of parsing the file.
    fresh_ms = []
    for frame in frames:
        start = time.perf_counter()
        load_usd(path, time=frame)
        fresh_ms.append(1e3 * (time.perf_counter() - start))
    if do_profile:
        profile(lambda: load_usd(path, time=frames[-1]), f"{path.name}, fresh load_usd")
    kept = StageFrames(path)
    kept_ms = []
    for frame in frames:
        start = time.perf_counter()
        scene = kept.load(frame)
        kept_ms.append(1e3 * (time.perf_counter() - start))
        if not same_meshes(scene, load_usd(path, time=frame)):
            raise SystemExit(f"{path.name}: frame {frame}: the kept load differs from a fresh load")
    if do_profile:
        profile(lambda: kept.load(frames[-1]), f"{path.name}, StageFrames.load after {len(frames)} frames")
    triangles = sum(len(m.indices) for m in scene.meshes) + sum(len(m.indices) for p in scene.prototypes
                                                                for m in p.meshes)
    return {"triangles": triangles, "fresh": statistics.median(fresh_ms[1:] or fresh_ms), "first": kept_ms[0],
            "kept": statistics.median(kept_ms[1:] or kept_ms), "counts": kept.memo.counts if kept.memo else {},
            "materials": kept.material_memo.counts if kept.material_memo else {}}


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*", type=Path)
    parser.add_argument("--frames", default="1:48:6")
    parser.add_argument("--count", type=int, default=200)
    parser.add_argument("--profile", action="store_true")
    default_assets = os.environ.get("WRT_ASSETS", str(ROOT.parent / "shared" / "assets"))
    parser.add_argument("--assets", default=default_assets)
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # time-range and skipped-prim warnings, the same for both loads
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [(path, args.frames) for path in args.scenes]
        if not jobs:
            jobs = [(path, args.frames) for path in mostly_static(Path(tmp), args.count)]
            manifest = Path(args.assets) / "manifest.json"
            if manifest.is_file():
                entries = {a["id"]: a for a in json.loads(manifest.read_text())["assets"]}
                for asset_id, frames in (("teapot_scene_1000", "0:479:40"), ("usdz_animated_cube", "0:48:2")):
                    jobs.append((Path(args.assets) / entries[asset_id]["path"], frames))
        print("| scene | triangles | frames | fresh load_usd ms | kept: first ms | kept: then ms | speedup | "
              "meshes reused / rebaked / read | materials reused / read |")
        print("|---|---|---|---|---|---|---|---|---|")
        for path, frames in jobs:
            found = measure(path, parse_frames(frames), args.profile)
            c = found["counts"]
            print(f"| {path.name} | {found['triangles']:,} | {frames} | {found['fresh']:.0f} | {found['first']:.0f} | "
                  f"{found['kept']:.0f} | {found['fresh'] / found['kept']:.1f}x | "
                  f"{c.get('reused', 0)} / {c.get('rebaked', 0)} / {c.get('read', 0)} | "
                  f"{found['materials'].get('reused', 0)} / {found['materials'].get('read', 0)} |", flush=True)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
