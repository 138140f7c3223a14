"""Renders the same small scenes on two devices and prints how far apart the images are: the cut-out canopy
(camera, bounce and shadow rays through holes), PointInstancer displayColors (mesh and gprim prototypes) and gold
spheres at three roughnesses (the multiple-scattering lobe). wrt's shade kernels round alike on every device (no FMA
contraction), so on a CUDA host the CPU and GPU images are expected to be equal.

Usage: python benchmarks/gpu_feature_parity.py [--width 96] [--devices cpu,cuda:0]
"""

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

import wrt
from wrt.procedural import displaced_sphere_scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from cut_out_canopy import write_canopy  # noqa: E402
from test_instance_colors import CAMERA, HEIGHT, WIDTH, instancer_stage  # noqa: E402


def compare(name: str, scene, devices: list[str], **kwargs) -> None:
    a, b = (wrt.render(scene, device=device, **kwargs) for device in devices)
    diff = np.abs(a.rgb - b.rgb)
    same_prim = float((a.aovs["prim"] == b.aovs["prim"]).mean())
    albedo = float(np.abs(a.aovs["albedo"] - b.aovs["albedo"]).max())
    print(f"{name}: mean {devices[0]} {a.rgb.mean():.5f} {devices[1]} {b.rgb.mean():.5f}; max |diff| {diff.max():.3g}, "
          f"mean {diff.mean():.3g}; prim equal {same_prim:.4f}; albedo max diff {albedo:.3g}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--width", type=int, default=96, help="width of the canopy images")
    parser.add_argument("--devices", default="cpu,cuda:0", help="the two devices to compare")
    parser.add_argument("--out", type=Path, default=Path("/tmp"), help="folder for the generated stages")
    args = parser.parse_args()
    devices = args.devices.split(",")
    warnings.simplefilter("ignore")

    canopy_path = args.out / "parity_canopy.usda"
    write_canopy(canopy_path, 3000, 12, 0)
    canopy = wrt.load_usd(canopy_path)
    for integrator in ("whitted", "path", "ao"):
        compare(f"canopy {integrator}", canopy, devices, width=args.width, height=64, integrator=integrator, spp=4,
                max_depth=3)
    for gprim in (False, True):
        scene = wrt.load_usd(instancer_stage(args.out / f"parity_instancer_{gprim}.usda", gprim=gprim))
        compare(f"instancer colours gprim={gprim}", scene, devices, camera=CAMERA, width=WIDTH, height=HEIGHT,
                integrator="path", spp=4)
    for roughness in (0.05, 0.5, 1.0):
        scene = displaced_sphere_scene(20000)
        scene.materials = [wrt.Material(diffuse_color=(1.0, 0.78, 0.34), metallic=1.0, roughness=roughness)]
        for mesh in scene.meshes:
            mesh.material_ids = np.zeros(len(mesh.indices), np.int32)
        compare(f"gold sphere roughness {roughness}", scene, devices, width=64, height=64, integrator="path", spp=8,
                max_depth=4)


if __name__ == "__main__":
    main()
