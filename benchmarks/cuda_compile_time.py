"""Seconds that NVRTC takes to compile each Warp module a first GPU render loads, measured without a GPU.

Warp compiles a whole module (every kernel in it) to CUDA the first time one of its kernels is launched on a GPU, so
on a fresh machine the first frame waits for every module the render touches. Warp's bundled NVRTC compiles without
a driver, so this script generates each module's CUDA source (``ModuleBuilder.codegen("cuda")``, as ``Module.load``
does) and compiles it to CUBIN for ``--arch`` (an H100 is sm_90) in a scratch folder, printing per module: Python
codegen seconds, NVRTC seconds (wall clock and this process's CPU time), kernels, ``__global__`` entries (a module
with ``enable_backward`` has two per kernel) and the source size. A tiny module is compiled first so that building
NVRTC's precompiled header is not charged to the first module measured. Timings are of this machine: compare runs
on one machine, by CPU seconds where other work shares it (NVRTC compiles on one thread).

The default modules are those a ``wrt render`` loads on the default room and on chess_set (instanced: the TLAS) with
``--integrator path`` and ``whitted``, as ``tests/test_module_loads.py`` lists them on the CPU, plus the binned
builder's parallel splitter, which the ``sah`` build launches on CUDA only.

    python benchmarks/cuda_compile_time.py [--arch 90] [--modules wrt.shade,...] [--features all,none]
        [--set optimization_level=2] [--keep DIR] [--trace N]

The integrators' shading kernels are built per :class:`wrt.light_features.LightFeatures` (the kinds of light a scene
has), an integrator's kernels for one set of features in a module of their own (``wrt.integrators.path.no_features``,
...); ``--features`` names the variants to compile: ``all`` (every feature: any scene),
``none`` (the default room's: a sun and a dome) or features joined by ``+`` (``shape_lights+shaping``); ``""``
compiles none.

``--set`` overrides a module option for every module (``enable_backward=True``, ``fuse_fp=True``, ...); ``--trace N``
turns on NVRTC's ``--fdevice-time-trace`` and prints each module's seconds per stage of NVRTC, its N functions the
NVVM optimiser took longest on and its N kernels ptxas took longest on.
"""

from __future__ import annotations

import argparse
import ast
import importlib
import json
import sys
import tempfile
import time
from pathlib import Path

import warp as wp

# Modules of the kernels a default path or whitted render launches (default room and chess_set), in load order.
MODULES = (
    "wrt.bvh.common",
    "wrt.bvh.presplit",
    "wrt.bvh.binned",
    "wrt.bvh.binned_parallel",
    "wrt.coplanar",
    "wrt.reversed_polygons",
    "wrt.shade",
    "wrt.hidden_hits",
    "wrt.trace",
    "wrt.tlas",
    "wrt.integrators.path",
    "wrt.integrators.whitted",
)

# The factories of the kernels built per light features (wrt.light_features), as "module:factory": each integrator's
# kernels for one set of features share a module (wrt.integrators.path.features_module).
VARIANT_FACTORIES = (
    "wrt.integrators.path:shade_path_kernel_for",
    "wrt.integrators.path:add_unoccluded_kernel_for",
    "wrt.integrators.whitted:shade_whitted_kernel_for",
    "wrt.integrators.whitted:whitted_lights_kernel_for",
    "wrt.integrators.whitted:continue_whitted_kernel_for",
    "wrt.integrators.whitted:add_unoccluded_lights_kernel_for",
)


def parse_features(spec: str):
    """``all``, ``none`` or feature names joined by ``+`` as a :class:`wrt.light_features.LightFeatures`."""
    from wrt.light_features import ALL_FEATURES, NO_FEATURES, LightFeatures

    if spec in ("all", "none"):
        return ALL_FEATURES if spec == "all" else NO_FEATURES
    names, known = spec.split("+"), list(LightFeatures.__dataclass_fields__)
    unknown = [name for name in names if name not in known]
    if unknown:  # a misspelt name set no field: the variant without any feature was timed, as if "none" were asked
        raise ValueError(f"--features {spec!r}: unknown feature {unknown[0]!r}; features: {', '.join(known)} (or all, "
                         f"none)")
    return LightFeatures(**{name: name in names for name in known})


def variant_modules(specs: str) -> list:
    """``(name, module)`` of the modules of the kernels built per light features, for each comma-separated spec of
    ``specs``, every kernel of a module made before it is compiled."""
    out = {}
    for spec in filter(None, specs.split(",")):
        features = parse_features(spec)
        for entry in VARIANT_FACTORIES:
            module_name, factory = entry.split(":")
            module = getattr(importlib.import_module(module_name), factory)(features).module
            out[module.name] = module
    return list(out.items())


@wp.kernel
def warm_up_kernel(x: wp.array[float]):
    """A one-line kernel whose compile builds NVRTC's precompiled header before the modules are timed."""
    x[wp.tid()] = 1.0


def nvrtc_seconds() -> list[tuple[float, float]]:
    """Wraps ``warp._src.build.build_cuda`` (which ``Module._compile`` calls) to append the ``(wall, cpu)`` seconds
    of each call to the returned list. NVRTC runs in this process, so its CPU seconds are this process's: on a
    machine shared with other work they vary less than the wall-clock ones."""
    import warp._src.build as build

    times = []
    build_cuda = build.build_cuda

    def timed(*args, **kwargs):
        start, cpu = time.perf_counter(), time.process_time()
        try:
            return build_cuda(*args, **kwargs)
        finally:
            times.append((time.perf_counter() - start, time.process_time() - cpu))

    build.build_cuda = timed
    return times


def codegen_seconds() -> list[float]:
    """Wraps ``Module._run_codegen`` to append the seconds of each call to the returned list."""
    from warp._src.context import Module

    times = []
    run_codegen = Module._run_codegen

    def timed(self, *args, **kwargs):
        start = time.perf_counter()
        try:
            return run_codegen(self, *args, **kwargs)
        finally:
            times.append(time.perf_counter() - start)

    Module._run_codegen = timed
    return times


def compile_module(module, arch: int, out: Path) -> Path:
    """Compiles ``module`` to CUBIN for ``arch`` into ``out``; returns the CUDA source it compiled."""
    module.mark_modified()  # a new hash for options changed by --set
    module._compile(None, out, output_arch=arch, use_ptx=False)
    return next(out.glob("*.cu"))


PHASES = ("CUDA C++ Front-End", "NVVM Optimizer", "NVVM CodeGen", "Total PTXAS Time")  # NVRTC's stages, in order


def time_trace_summary(trace_path: Path, count: int) -> list[str]:
    """Lines on an NVRTC time trace: seconds per stage (front end, NVVM optimiser and code generation, ptxas), then
    the ``count`` functions the NVVM optimiser spent longest on and the ``count`` kernels ptxas spent longest on."""
    events = [e for e in json.loads(trace_path.read_text()).get("traceEvents", []) if e.get("ph") == "X"]
    phases = {name: sum(e["dur"] for e in events if e["name"] == name) / 1e6 for name in PHASES}
    lines = ["stages: " + ", ".join(f"{name} {seconds:.1f} s" for name, seconds in phases.items())]
    for event, label in (("OptFunction", "NVVM optimiser"), ("Optimizing compilation unit", "ptxas")):
        per_name = {}
        for e in events:
            if e["name"] == event:
                name = e.get("args", {}).get("detail") or e.get("args", {}).get("name", "")
                per_name[name] = per_name.get(name, 0.0) + e["dur"] / 1e6
        for name, seconds in sorted(per_name.items(), key=lambda item: -item[1])[:count]:
            lines.append(f"{label:>14s} {seconds:7.2f} s  {name[:110]}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--arch", type=int, default=90, help="SM architecture to compile for (H100: 90)")
    parser.add_argument("--modules", default=",".join(MODULES), help="comma list of modules to compile")
    parser.add_argument("--features", default="all",
                        help="comma list of light-feature variants of the shading kernels to compile (all, none, "
                             "or names joined by +)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="module option to override in every module (a Python literal), repeatable")
    parser.add_argument("--keep", help="folder to keep the generated sources and CUBINs in")
    parser.add_argument("--trace", type=int, default=0, metavar="N",
                        help="NVRTC time trace: print each module's N slowest functions")
    parser.add_argument("--path", help="folder to put first on sys.path (another checkout's wrt)")
    args = parser.parse_args()
    sys.path.insert(0, str(Path(args.path).resolve()) if args.path else str(Path(__file__).resolve().parents[1]))
    try:  # before the warm-up compile, which takes a while
        for spec in filter(None, args.features.split(",")):
            parse_features(spec)
    except ValueError as e:
        parser.error(str(e))
    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = ast.literal_eval(value)
    wp.config.quiet = True
    wp.init()
    if args.trace:
        overrides["compile_time_trace"] = True  # a module option, taken from wp.config when the module was made
    nvrtc, codegen = nvrtc_seconds(), codegen_seconds()
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="cuda_compile_time_"))

    compile_module(wp.get_module(__name__), args.arch, root / "warm_up")
    shipped = overrides or "as shipped"
    print(f"warm-up (precompiled header) {nvrtc[-1][0]:.1f} s; arch sm_{args.arch}; options {shipped}")
    print(f"{'module':26s} {'codegen s':>9s} {'nvrtc s':>8s} {'cpu s':>8s} {'kernels':>7s} {'entries':>7s} "
          f"{'source KB':>9s}")
    total, total_cpu = 0.0, 0.0
    modules = [(name, None) for name in filter(None, args.modules.split(","))]
    for name, module in modules + variant_modules(args.features):
        if module is None:
            importlib.import_module(name)
            module = wp.get_module(name)
        module.options.update(overrides)
        source = compile_module(module, args.arch, root / module.name)
        text = source.read_text()
        kernels = len(module._get_live_kernels())
        wall, cpu = nvrtc[-1]
        total, total_cpu = total + wall, total_cpu + cpu
        print(f"{name:26s} {codegen[-1]:9.2f} {wall:8.1f} {cpu:8.1f} {kernels:7d} {text.count('__global__'):7d} "
              f"{len(text) / 1024:9.0f}", flush=True)
        if args.trace:
            for trace in (root / module.name).glob("*time-trace*.json"):
                for line in time_trace_summary(trace, args.trace):
                    print("    " + line)
    print(f"{'total':26s} {'':9s} {total:8.1f} {total_cpu:8.1f}")
    if args.keep:
        print(f"sources and CUBINs in {root}")


if __name__ == "__main__":
    main()
