"""Writes the reference statistics that ``tests/test_integrators.py`` compares fast renders against.

The Cornell box (``cornell_box`` of the shared assets) is path traced at 4096 samples per pixel with the same
code, resolution and depth as the test, which renders only 64 spp; the mean linear RGB of the back, left and right
walls goes to ``tests/data/cornell_box_reference.json``. Only these statistics are stored, never the image.

Run from the repository root (takes a few minutes on a CPU, seconds on a GPU)::

    python benchmarks/make_references.py [--device cuda:0] [--spp 4096]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

SETTINGS = {"width": 64, "height": 64, "max_depth": 10}  # must match the test


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--spp", type=int, default=4096)
    parser.add_argument("--seed", type=int, default=12345)
    parser.add_argument("-o", "--output", default=str(ROOT / "tests" / "data" / "cornell_box_reference.json"))
    args = parser.parse_args(argv)

    from conftest import assets_dir, manifest
    from test_integrators import cornell_wall_means

    import wrt
    from wrt.strict_json import strict_json

    path = assets_dir() / manifest()["cornell_box"]["path"]
    scene = wrt.load_usd(path)
    start = time.perf_counter()
    renderer = wrt.Renderer(scene, device=args.device, integrator="path", width=SETTINGS["width"],
                            height=SETTINGS["height"], max_depth=SETTINGS["max_depth"])
    img = renderer.render(spp=args.spp, seed=args.seed, progress=True)
    seconds = time.perf_counter() - start
    out = {
        "scene": "cornell_box",
        "settings": {**SETTINGS, "spp": args.spp, "seed": args.seed, "integrator": "path"},
        "wall_means": cornell_wall_means(scene, img),
        "made_with": {"device": str(renderer.device), "seconds": round(seconds, 1),
                      "script": "benchmarks/make_references.py"},
    }
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(strict_json(out, indent=2) + "\n")
    print(strict_json(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
