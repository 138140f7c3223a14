"""Command-line entry point: ``wrt render`` (more subcommands join as they land).

Bad input (a missing or broken file, an unknown option value) ends with one line on stderr and exit status 2;
no traceback is shown for it.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from importlib import resources
from pathlib import Path

EXIT_BAD_INPUT = 2  # exit status for bad input, as argparse uses for bad arguments


def default_scene_path() -> Path:
    """The bundled default scene (``scenes/default_room.usda`` in the source tree)."""
    return Path(str(resources.files("wrt") / "data" / "default_room.usda"))


class _Progress:
    """Prints one timing line per finished step to stderr (quiet with ``--quiet``)."""

    def __init__(self, quiet: bool):
        self.quiet = quiet

    def __call__(self, message: str, seconds: float | None = None):
        if not self.quiet:
            suffix = f" ({seconds:.2f} s)" if seconds is not None else ""
            print(f"wrt: {message}{suffix}", file=sys.stderr, flush=True)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line (``wrt: error: ...``) and exit status 2."""

    def error(self, message):
        self.exit(EXIT_BAD_INPUT, f"wrt: error: {message} (see '{self.prog} --help')\n")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {value}")
    return value


def _add_render(sub) -> None:
    from .bvh.build import Builder
    from .trace import ACCELERATORS

    p = sub.add_parser(
        "render",
        help="render a USD scene to an image",
        description="Render a USD scene with wrt's ray tracer. With no SCENE, renders the bundled default room.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    p.add_argument("scene", nargs="?", help="USD file (.usd, .usda, .usdc, .usdz); default: the bundled room")
    p.add_argument("-o", "--output", default="wrt.png", help="output image (.png 8-bit sRGB, .npy linear float)")
    p.add_argument("--width", type=_positive_int, default=640, help="image width in pixels")
    p.add_argument("--height", type=_positive_int, default=480, help="image height in pixels")
    p.add_argument("--camera", help="camera prim path; default: the stage's first camera, else one framing the scene")
    p.add_argument("--spp", type=_positive_int, default=1, help="samples per pixel")
    p.add_argument("--seed", type=int, default=0, help="seed of the pixel jitter")
    p.add_argument("--device", default="cpu", help="Warp device, e.g. cpu or cuda:0")
    builders = [b.value for b in Builder] + ["binned_sah"]
    p.add_argument("--builder", default="sah", choices=builders, help="BVH builder")
    p.add_argument("--accel", default="wrt", choices=ACCELERATORS, help="wrt's BVH or Warp's wp.Mesh")
    p.add_argument("--time", type=float, default=None, help="USD time code; default: the default time")
    p.add_argument("--aov-dir", help="also write depth.npy, normal.npy, albedo.npy and prim.npy into this folder")
    p.add_argument("-q", "--quiet", action="store_true", help="print no progress lines")
    p.set_defaults(run=_run_render)


def _run_render(args) -> int:
    import wrt

    progress = _Progress(args.quiet)
    path = Path(args.scene) if args.scene else default_scene_path()
    start = time.perf_counter()
    scene = wrt.load_usd(path, time=args.time)
    stats = scene.stats()
    progress(f"loaded {path.name}: {stats['rendered_triangles']} triangles in {stats['meshes']} meshes", time.perf_counter() - start)
    renderer = wrt.Renderer(
        scene,
        camera=args.camera,
        width=args.width,
        height=args.height,
        device=args.device,
        builder=args.builder,
        accel=args.accel,
    )
    progress(f"built {args.accel} BVH ({args.builder}) on {renderer.device}", renderer.timers["build"][0] / 1000.0)
    image = renderer.render(spp=args.spp, seed=args.seed)
    progress(f"rendered {args.width}x{args.height} at {args.spp} spp", renderer.timers["render"][0] / 1000.0)
    out = image.save(args.output)
    progress(f"wrote {out}")
    if args.aov_dir:
        for p in image.save_aovs(args.aov_dir):
            progress(f"wrote {p}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``wrt`` argument parser with every subcommand."""
    parser = _Parser(
        prog="wrt",
        description="wrt: a ray tracer for USD scenes written in NVIDIA Warp kernels.",
        epilog="Run 'wrt COMMAND --help' for the options of a command.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    _add_render(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Runs the ``wrt`` command line; returns the exit status."""
    args = build_parser().parse_args(argv)
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING  # keep Warp's start-up and module-load lines out of the CLI's output
    from .errors import SceneError

    def show_warning(message, category, filename, lineno, file=None, line=None):
        print(f"wrt: warning: {message}", file=sys.stderr)

    warnings.showwarning = show_warning
    try:
        return args.run(args)
    except (SceneError, ValueError, TypeError, FileNotFoundError, MemoryError) as e:
        message = str(e).splitlines()[0] if str(e) else type(e).__name__
        print(f"wrt: error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("wrt: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
