"""Frame-range speedup over several GPUs of one host: the same frames rendered on cuda:0 alone, then spread over
every CUDA device (``wrt render --frames ... --devices cuda:0,cuda:1``; one thread and one FrameRenderer per GPU).

Usage: python benchmarks/multi_gpu_frames.py [SCENE.usda] [--frames 1:8:0.25] [--width 1920 --height 1080 --spp 64]
Without SCENE it writes and uses scenes/make_animated_scene.py's stage.
"""

from __future__ import annotations

import argparse
import importlib.util
import tempfile
import time
from pathlib import Path

import warp as wp

from wrt.animation import parse_frames, pending_frames, render_frames

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene", nargs="?")
    parser.add_argument("--frames", default="1:8:0.25")
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--integrator", default="path")
    args = parser.parse_args()
    out = Path(tempfile.mkdtemp(prefix="wrt-frames-"))
    scene = args.scene
    if scene is None:
        spec = importlib.util.spec_from_file_location("make_animated_scene", ROOT / "scenes" / "make_animated_scene.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        scene = module.write(out / "animated.usda")
    devices = [f"cuda:{k}" for k in range(wp.get_cuda_device_count())] or ["cpu"]
    options = {"width": args.width, "height": args.height, "integrator": args.integrator, "spp": args.spp}
    names = ", ".join(wp.get_device(d).name for d in devices)
    print(f"{len(devices)} devices ({names}), warp {wp.config.version}, {args.width}x{args.height} {args.integrator} "
          f"{args.spp} spp, frames {args.frames}")
    frames = parse_frames(args.frames)
    for d in devices:  # compile and warm up every device first
        render_frames(scene, pending_frames(frames[:1], out / f"warm-{d[-1]}-#.png", False), devices=[d], **options)
    seconds, rate = {}, {}
    for group in ([devices[0]], devices) if len(devices) > 1 else ([devices[0]],):
        jobs = pending_frames(frames, out / f"{len(group)}gpu" / "f_####.png", False)
        start = time.perf_counter()
        rows = render_frames(scene, jobs, devices=group, **options)
        seconds[len(group)] = time.perf_counter() - start
        per = {d: sum(1 for r in rows if r["device"] == d) for d in group}
        render_ms = sorted(r["render_ms"] for r in rows)[len(rows) // 2]
        # Steady state: from the last device's first frame on (worker processes start and load the stage first).
        firsts = [min(r["finished_at"] for r in rows if r["device"] == d) for d in group]
        after = sorted(r["finished_at"] for r in rows if r["finished_at"] > max(firsts))
        rate[len(group)] = len(after) / (after[-1] - max(firsts)) if after else float("nan")
        print(f"{len(group)} GPU(s): {len(rows)} frames in {seconds[len(group)]:.2f} s wall "
              f"({len(rows) / seconds[len(group)]:.2f} frames/s; steady state {rate[len(group)]:.2f} frames/s; "
              f"median render {render_ms:.0f} ms; frames per device {per})")
    if len(seconds) > 1:
        n = len(devices)
        print(f"speedup on {n} GPUs: {seconds[1] / seconds[n]:.2f}x wall (worker start-up included), "
              f"{rate[n] / rate[1]:.2f}x steady state")


if __name__ == "__main__":
    main()
