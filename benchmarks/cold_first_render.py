"""Wall time of a first render in a fresh process: what a new user waits for, mostly Warp compiling wrt's kernels.

Run it with an empty kernel cache to time the compile (``WARP_CACHE_PATH=/tmp/empty python
benchmarks/cold_first_render.py path scene.usda --device cuda:0``); the second render of the same process shows the
render alone. Prints the import and load time, the first render and the second; with ``--modules``, also Warp's line
for each module the renders load (its name, device, milliseconds, and whether it was compiled or read from the cache),
which splits the first render's time by module.
"""

import argparse
import time

t0 = time.perf_counter()
import warp as wp  # noqa: E402

import wrt  # noqa: E402
import wrt.render  # noqa: E402  (import wrt imports it at first use: timed with the import, as before, not the render)


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("integrator", choices=("whitted", "path", "ao", "normals", "depth", "albedo"))
    parser.add_argument("scene", help="USD file")
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--modules", action="store_true", help="print Warp's load line for each module loaded")
    args = parser.parse_args()
    if args.modules:
        wp.config.log_level = wp.LOG_INFO  # Warp's "Module ... load ... took ... ms" lines (wrt quietens them)
    scene = wrt.load_usd(args.scene)
    times = [time.perf_counter()]
    for _ in range(2):
        wrt.render(scene, width=args.width, height=args.height, integrator=args.integrator, device=args.device)
        wp.synchronize()
        times.append(time.perf_counter())
    first, second = times[1] - times[0], times[2] - times[1]
    print(f"{args.integrator} on {args.device}: import + load {times[0] - t0:.1f} s, first render {first:.1f} s, "
          f"second {second:.2f} s (kernel cache {wp.config.kernel_cache_dir})", flush=True)


if __name__ == "__main__":
    main()
