"""Where do CPU and GPU path-traced images of the same seed differ? Prints, per max depth, the fraction of pixels
that differ beyond float tolerance, and whether the primary-hit AOVs already differ. Run on a CUDA machine."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import wrt  # noqa: E402
from test_integrators import mirror_scene  # noqa: E402
from wrt.lights import DomeLight  # noqa: E402


def main():
    scene = mirror_scene()
    scene.lights.append(DomeLight(color=np.full(3, 0.3, np.float32)))
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)
    for depth in (1, 2, 3, 5, 8):
        kw = {"camera": cam, "width": 24, "height": 24, "spp": 4, "seed": 11, "integrator": "path", "max_depth": depth}
        g = wrt.render(scene, device="cuda:0", **kw)
        c = wrt.render(scene, device="cpu", **kw)
        close = np.isclose(g.rgb, c.rgb, rtol=1e-3, atol=1e-4).all(axis=-1)
        aov = {k: float(np.mean(g.aovs[k] == c.aovs[k])) for k in ("prim", "material")}
        worst = np.abs(g.rgb - c.rgb).max()
        print(f"max_depth {depth}: {100 * (1 - close.mean()):.2f}% pixels differ, max |diff| {worst:.4g}, AOV equal {aov}")
        if depth == 8:
            for i, j in list(zip(*np.nonzero(~close)))[:5]:
                print(f"  pixel {i},{j}: gpu {g.rgb[i, j]} cpu {c.rgb[i, j]} prim {g.aovs['prim'][i, j]}/{c.aovs['prim'][i, j]}")


if __name__ == "__main__":
    main()
