"""Writes the README screenshots into ``docs/``: a preview of the default room and wrt's render of the same view.

``docs/preview_room.png`` is ``wrt preview`` of the bundled room (camera frustum, BVH cut at depth 3, sample
rays to their hits, the rendered image on the image plane); ``docs/render_room.png`` is ``wrt render`` of the
room from the same camera; ``docs/preview_bunny_bvh.png`` shows the BVH of warp's bunny cut at depth 6, the
boxes coloured by their SAH cost share. PNGs are palette-quantised so that each stays well under 300 KB.

Run ``python scenes/make_screenshots.py`` (off-screen, no display needed) after changing the preview or the
renderer; the PNGs it writes are committed.
"""

import argparse
import sys
from pathlib import Path

import pyvista as pv
import warp as wp
import warp.examples
from PIL import Image as PilImage

import wrt
from wrt.cli import default_scene_path
from wrt.image import to_srgb8

MAX_BYTES = 300_000  # size limit for a committed PNG


def save_small(pixels, path: Path) -> int:
    """Writes ``(H, W, 3)`` uint8 pixels as an optimised 256-colour PNG; returns the file size in bytes."""
    image = PilImage.fromarray(pixels).quantize(colors=256, method=PilImage.Quantize.MEDIANCUT, dither=0)
    image.save(path, optimize=True)
    return path.stat().st_size


def main() -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"), help="output folder")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    wp.config.log_level = wp.LOG_WARNING  # keep Warp's start-up lines out of the output
    pv.OFF_SCREEN = True

    room = wrt.load_usd(default_scene_path())
    width, height = 640, 480
    shots = {}
    plotter = wrt.preview(room, bvh_depth=3, rays=48, image=True, width=width, height=height, window_size=(960, 640))
    shots["preview_room.png"] = plotter.screenshot(return_img=True)
    plotter.close()
    image = wrt.render(room, width=width, height=height, spp=4, device="cpu")
    shots["render_room.png"] = to_srgb8(image.rgb)

    bunny = wrt.load_usd(Path(warp.examples.get_asset_directory()) / "bunny.usd")
    plotter = wrt.preview(bunny, bvh_depth=6, bvh_color="sah", window_size=(960, 640))
    lower, upper = bunny.bounds()
    plotter.reset_camera(bounds=[v for pair in zip(lower, upper) for v in pair])  # the bunny, not its frustum
    plotter.camera.zoom(0.85)
    shots["preview_bunny_bvh.png"] = plotter.screenshot(return_img=True)
    plotter.close()

    status = 0
    for name, pixels in shots.items():
        size = save_small(pixels, out / name)
        print(f"wrote {out / name} ({size / 1000:.0f} KB)")
        if size > MAX_BYTES:
            print(f"error: {name} is over {MAX_BYTES // 1000} KB; do not commit it", file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
