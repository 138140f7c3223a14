"""How far apart are two builds of the path tracer on the same seed? Prints, per scene, the fraction of pixels that
differ beyond the tolerance of ``test_path_tracer_is_deterministic_and_device_independent`` (``rtol=1e-3,
atol=1e-4`` on any channel), the largest difference and whether the camera-ray AOVs already differ.

Two comparisons:

- default: ``cuda:0`` against ``cpu`` (run on a CUDA machine; about a minute, most of it compiling).
- ``--emulate {all,trace,shade}``: ``cpu`` against ``cpu`` with nvcc-like floating-point contraction (clang
  ``-ffp-contract=fast``, which fuses across statements as ``nvrtc --fmad=true`` does) on the kernel modules of that
  group whose ``fuse_fp`` option is on. Modules with ``fuse_fp`` off compile without contraction on both devices,
  so they are left alone. This shows on a CPU-only machine how sensitive the images are to last-bit rounding.

``--fused`` compiles the trace and shading modules with ``fuse_fp`` on (Warp's default, wrt's setting before it
turned contraction off there), to see the difference that setting makes.

Examples: ``python benchmarks/gpu_diagnose_path.py [--fused]``, ``python benchmarks/gpu_diagnose_path.py --emulate all
[--fused]``.
"""

import argparse
import importlib
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import assets_dir, manifest  # noqa: E402
from test_integrators import furnace_scene, glass_scene, mirror_scene  # noqa: E402

import wrt  # noqa: E402
from wrt.cli import default_scene_path  # noqa: E402
from wrt.lights import DomeLight  # noqa: E402

TRACE_MODULES = ("wrt.trace", "wrt.tlas")  # ray queries: BVH traversal and the ray-triangle test
SHADE_MODULES = ("wrt.shade", "wrt.integrators.path", "wrt.integrators.whitted", "wrt.integrators.ao")


def scenes():
    """``name -> (scene, render kwargs)``; the first is the scene and settings of the device test."""
    mirror = mirror_scene()
    mirror.lights.append(DomeLight(color=np.full(3, 0.3, np.float32)))
    mirror_cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)
    glass = glass_scene(opacity=0.5)
    glass.lights.append(DomeLight(color=np.full(3, 0.5, np.float32)))
    glass_cam = wrt.Camera.look_at(eye=(0, 0, 6), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=25)
    furnace_cam = wrt.Camera.look_at(eye=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=35)
    out = {
        "mirror (device test)": (mirror, {"camera": mirror_cam, "width": 24, "height": 24, "spp": 4, "seed": 11}),
        "mirror 96x96": (mirror, {"camera": mirror_cam, "width": 96, "height": 96, "spp": 4, "seed": 11}),
        "glass 64x64": (glass, {"camera": glass_cam, "width": 64, "height": 64, "spp": 4, "seed": 3}),
        "furnace 64x64": (furnace_scene(), {"camera": furnace_cam, "width": 64, "height": 64, "spp": 4, "seed": 1}),
        "default room 64x64": (wrt.load_usd(default_scene_path()), {"width": 64, "height": 64, "spp": 4, "seed": 2}),
    }
    entry = manifest().get("cornell_box")
    if entry and (assets_dir() / entry["path"]).exists():
        out["cornell 64x64"] = (wrt.load_usd(assets_dir() / entry["path"]),
                                {"width": 64, "height": 64, "spp": 8, "seed": 7})
    else:
        print(f"no cornell_box under {assets_dir()} (set WRT_ASSETS to the shared asset folder): skipped")
    return out


def render_all(cases: dict, device) -> dict:
    return {name: wrt.render(scene, device=device, integrator="path", **kw) for name, (scene, kw) in cases.items()}


def variant_modules() -> list:
    """The Warp modules of every variant of the shading kernels built per light features (wrt.light_features), each
    a module of its own that no module name reaches."""
    from itertools import product

    from wrt.integrators.path import shade_path_kernel_for
    from wrt.integrators.whitted import shade_whitted_kernel_for, whitted_lights_kernel_for
    from wrt.light_features import LightFeatures

    return [factory(LightFeatures(shape_lights=shapes, shaping=shaping)).module
            for shapes, shaping in product((False, True), repeat=2)
            for factory in (shade_path_kernel_for, shade_whitted_kernel_for, whitted_lights_kernel_for)]


def modules_of(names) -> list:
    """The Warp modules named ``names``, with the shading kernels' variants where an integrator's module is named."""
    modules = []
    for name in names:
        importlib.import_module(name)
        modules.append(wp.get_module(name))
    if any(name.startswith("wrt.integrators.") for name in names):
        modules += variant_modules()
    return modules


def set_options(module, options: dict) -> None:
    """``wp.set_module_options`` for a module object (a variant's has no name to pass)."""
    module.options.update(options)
    module.mark_modified()


def contract_like_nvcc(names) -> list:
    """Compiles the modules of ``names`` (those with ``fuse_fp`` on) for the CPU with contraction across statements."""
    flags = f"{wp.config.cpu_compiler_flags or '-march=native'} -ffp-contract=fast"
    changed = []
    for module in modules_of(names):
        if module.options["fuse_fp"]:
            set_options(module, {"cpu_compiler_flags": flags})
            changed.append(module.name)
    return changed


def compare(a: dict, b: dict) -> None:
    for name, x in a.items():
        y = b[name]
        close = np.isclose(x.rgb, y.rgb, rtol=1e-3, atol=1e-4).all(axis=-1)
        prim = float(np.mean(x.aovs["prim"] == y.aovs["prim"]))
        normal = float(np.mean((x.aovs["normal"] == y.aovs["normal"]).all(axis=-1)))
        mean = abs(float(x.rgb.mean()) / max(float(y.rgb.mean()), 1e-30) - 1)
        print(
            f"{name:22s} {100 * (1 - close.mean()):6.2f}% pixels differ ({(~close).sum()}/{close.size}), "
            f"max |diff| {np.abs(x.rgb - y.rgb).max():.3g}, image mean rel. diff {mean:.1e}, "
            f"camera hits: prim equal {prim:.4f}, normal bit-equal {normal:.4f}",
            flush=True,
        )


def main():
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--emulate", choices=["all", "trace", "shade"], help="CPU-only: contraction on these modules")
    parser.add_argument("--fused", action="store_true", help="fuse_fp on in the trace and shading modules")
    args = parser.parse_args()
    wp.config.quiet = True
    cases = scenes()
    if args.fused:
        for module in modules_of(TRACE_MODULES + SHADE_MODULES):
            set_options(module, {"fuse_fp": True})
    start = time.perf_counter()
    ref = render_all(cases, "cpu")
    if args.emulate:
        groups = {"all": TRACE_MODULES + SHADE_MODULES, "trace": TRACE_MODULES, "shade": SHADE_MODULES}
        changed = contract_like_nvcc(groups[args.emulate])
        print(f"cpu -ffp-contract=fast on {changed or 'nothing (fuse_fp is off everywhere)'} vs cpu:")
        other = render_all(cases, "cpu")
    else:
        print(f"cuda:0 ({wp.get_device('cuda:0').name}) vs cpu:")
        other = render_all(cases, "cuda:0")
    compare(other, ref)
    print(f"({time.perf_counter() - start:.0f} s including compilation)")


if __name__ == "__main__":
    main()
