"""Host cost of moving instances between renders, as a robot's links move each step: one instance moved, then a
small render with a kept ``wrt.Renderer``, in two ways alternating in one process on the same scene:

- ``kept``: only ``scene.instances.to_world`` is given new values, so the prototypes' BVHs and what is made of the
  triangles alone are kept and the TLAS alone is built again (stop 64);
- ``rebuilt``: the same move followed by ``scene.invalidate()``, which drops every cache: everything is built again,
  as every move did before.

Both draw the same image (checked each time). Prints the median wall seconds of each.

Usage: python benchmarks/instance_moves.py [--scene asset:chess_set] [--width 64 --height 48] [--moves 5]
                                           [--device cpu]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import warp as wp

import wrt
from wrt.bench import resolve_scene


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="asset:chess_set", help="a scene as wrt bench names them (instanced)")
    parser.add_argument("--width", type=int, default=64)
    parser.add_argument("--height", type=int, default=48)
    parser.add_argument("--moves", type=int, default=5, help="moves timed in each way")
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    scene = resolve_scene(args.scene)
    if not len(scene.instances):
        parser.error(f"{args.scene} has no instances to move")
    renderer = wrt.Renderer(scene, width=args.width, height=args.height, device=args.device)
    renderer.render()  # compiles and builds once, outside the timings
    size = float(np.max(scene.bounds()[1] - scene.bounds()[0]))
    seconds = {"kept": [], "rebuilt": []}
    base = scene.instances.to_world.copy()
    for j in range(args.moves):
        pose = base.copy()
        pose[0, :3, 3] += (j % 2 + 1) * 1e-3 * size  # another pose each time, so the kept way sees a move
        images = []
        for way in ("kept", "rebuilt"):
            start = time.perf_counter()
            scene.instances.to_world = pose.copy()
            if way == "rebuilt":
                scene.invalidate()
            images.append(renderer.render().rgb)
            wp.synchronize()
            seconds[way].append(time.perf_counter() - start)
        if not np.array_equal(*images):
            raise SystemExit("the two ways drew different images")
    print(f"{args.scene}, {len(scene.instances)} instances, {args.width}x{args.height} on {args.device}: one instance "
          f"moved, then a render: kept {statistics.median(seconds['kept']):.3f} s, rebuilt "
          f"{statistics.median(seconds['rebuilt']):.3f} s (medians of {args.moves})")


if __name__ == "__main__":
    main()
