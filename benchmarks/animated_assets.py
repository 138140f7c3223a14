"""Frame timings of the shared animated assets: what the BVH did each frame (build / refit / TLAS / static) and
how long loading, updating and rendering took. Prints a markdown table.

Usage: python benchmarks/animated_assets.py [--device cpu] [--width 320 --height 240] [--assets DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from collections import Counter
from pathlib import Path

import warp as wp

from wrt.animation import FrameRenderer, parse_frames

# id -> frames: each asset's animated range (teapot_scene_1000 advertises [1, 1] but moves its camera over 0-479).
ASSETS = {
    "spinning_pyramids": "1:192:8",
    "usdz_animated_cube": "0:48:2",
    "usdz_interpolation_test": "0:41:2",
    "usdz_box_animated": "0:89:4",
    "teapot_scene_1000": "0:479:40",
}


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    default_assets = os.environ.get("WRT_ASSETS", str(Path(__file__).resolve().parents[2] / "shared" / "assets"))
    parser.add_argument("--assets", default=default_assets)
    args = parser.parse_args()
    entries = {a["id"]: a for a in json.loads((Path(args.assets) / "manifest.json").read_text())["assets"]}
    device = wp.get_device(args.device)
    print(f"device {device.name} ({device}), warp {wp.config.version}, {args.width}x{args.height} whitted 1 spp\n")
    print("| asset | frames | BVH per frame | first frame ms | then: load ms | update ms | render ms (medians) |")
    print("|---|---|---|---|---|---|---|")
    for asset_id, frames in ASSETS.items():
        path = Path(args.assets) / entries[asset_id]["path"]
        renderer = FrameRenderer(path, width=args.width, height=args.height, device=device)
        start = time.perf_counter()
        for frame in parse_frames(frames):
            renderer.render(frame)
        log = renderer.log
        first = log[0]["load_ms"] + log[0]["update_ms"] + log[0]["render_ms"]
        rest = log[1:] or log
        med = {k: statistics.median(r[k] for r in rest) for k in ("load_ms", "update_ms", "render_ms")}
        changes = ", ".join(f"{n} {c}" for c, n in sorted(Counter(r["change"] for r in log).items()))
        rebuilt = sum(r.get("rebuilt_trees", 0) for r in log if r["change"] == "refit")  # BLASes past the refit limit
        changes += f" ({rebuilt} BLAS rebuilt in refits)" if rebuilt else ""
        print(f"| {asset_id} | {frames} ({len(log)}) | {changes} | {first:.0f} | {med['load_ms']:.1f} | "
              f"{med['update_ms']:.1f} | {med['render_ms']:.1f} |", flush=True)
        print(f"<!-- {asset_id}: {time.perf_counter() - start:.1f} s in all -->", flush=True)


if __name__ == "__main__":
    main()
