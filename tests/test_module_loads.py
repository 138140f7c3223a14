"""What the README's first command compiles: Warp builds a whole module (every kernel in it, with its adjoint unless
the module turns ``enable_backward`` off) the first time any of its kernels is launched, so on a fresh machine a
render pays for every kernel that shares a module with one it launches.

The render runs in a fresh interpreter, so that no other test has loaded a module; which modules were loaded comes
from Warp's module registry (``Module.execs``), which kernels were launched from a wrapper around ``wp.launch``, and
how often each module was loaded from Warp's own "Module ... load on device" lines.
"""

from __future__ import annotations

import collections
import json
import os
import re
import subprocess
import sys

import pytest

LAUNCHES_RECORDED = """
import json, sys
import warp as wp

launched = set()
_launch = wp.launch


def launch(kernel, *args, **kwargs):
    launched.add((kernel.module.name, kernel.key))
    return _launch(kernel, *args, **kwargs)


wp.launch = launch
"""

MODULES_REPORTED = """
kernels = {}
for name, module in list(sys.modules.items()):
    if name.startswith("wrt"):
        for value in list(vars(module).values()):
            if isinstance(value, wp.Kernel):
                kernels.setdefault(value.module.name, set()).add(value.key)
for name, key in launched:  # the integrators' modules per light features, whose kernels are made by factories
    kernels.setdefault(name, set()).update(k.key for k in wp.get_module(name)._get_live_kernels())
report = {}
for name, keys in kernels.items():
    module = wp.get_module(name)
    if module.execs:
        report[name] = {"kernels": sorted(keys), "launched": sorted(k for m, k in launched if m == name),
                        "enable_backward": module.options["enable_backward"]}
print(json.dumps(report))
"""

# wrt render on the CPU, writing argv[1], with the options that follow it
RENDER_AND_REPORT = LAUNCHES_RECORDED + """
from wrt.cli import main

wp.config.log_level = wp.LOG_INFO  # Warp's module-load lines (importing wrt quietened them)
main(["render", "--device", "cpu", "-o", sys.argv[1], *sys.argv[2:]])
""" + MODULES_REPORTED

# wrt.trace of one ray into the default scene, the README's first query
TRACE_AND_REPORT = LAUNCHES_RECORDED + """
import numpy as np

import wrt
from wrt.cli import default_scene_path

scene = wrt.load_usd(str(default_scene_path()))
hits = wrt.trace(scene, np.array([[0, 1, 5]], np.float32), np.array([[0, 0, -1]], np.float32), device="cpu")
assert hits.prim[0] >= 0  # the ray meets the room's back wall
""" + MODULES_REPORTED


def run_and_report(script: str, *args: str) -> str:
    """The standard output of ``script`` run with ``args`` in a fresh interpreter (launches split between two
    threads), whose last line is its report."""
    env = {**os.environ, "WRT_THREADS": "2"}
    result = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, timeout=600,
                            env=env)
    assert result.returncode == 0, result.stderr
    return result.stdout


def loaded_modules(stdout: str) -> dict:
    """``{module: {"kernels", "launched", "enable_backward"}}`` of the Warp modules that a run loaded."""
    return json.loads(stdout.strip().splitlines()[-1])


def unlaunched_kernels(modules: dict, allowed=frozenset()) -> dict:
    """``{module: kernels}`` of the loaded modules' kernels that were not launched, beyond ``allowed``."""
    unlaunched = {name: sorted(set(m["kernels"]) - set(m["launched"]) - set(allowed)) for name, m in modules.items()}
    return {name: keys for name, keys in unlaunched.items() if keys}


@pytest.fixture(scope="module")
def default_render(tmp_path_factory):
    """The standard output of a default ``wrt render`` (640x480, whitted, on the CPU, its launches split between two
    threads) in a fresh interpreter: Warp's log lines, then the report."""
    out = tmp_path_factory.mktemp("render") / "wrt.png"
    stdout = run_and_report(RENDER_AND_REPORT, str(out))
    assert out.is_file()
    return stdout


@pytest.fixture
def default_render_modules(default_render):
    """``{module: {"kernels", "launched", "enable_backward"}}`` of the Warp modules a default ``wrt render`` loaded."""
    return loaded_modules(default_render)


def test_default_render_compiles_no_backward_pass(default_render_modules):
    """Nothing differentiates a render: a module built with its adjoint kernels compiles about twice the code."""
    assert default_render_modules  # the render loaded modules, and the report found them
    with_adjoints = [name for name, m in default_render_modules.items() if m["enable_backward"]]
    assert with_adjoints == []


# Kernels a default render compiles without launching them, each kept beside the kernels it belongs with: the cost of
# compiling it is small, and a module of its own would be one more module to load.
COMPILED_UNLAUNCHED = {
    "trace_bvh_kernel_uncounted",  # the counting trace kernel's twin (traverse.closest_hit_kernels): bounce rays
    "split_rows_kernel",  # a few lines: rows of flattened instances back to (geometry id, instance)
    "mean_image_kernel",  # one line: the images of a batch of cameras
}


def test_default_render_compiles_only_modules_of_launched_kernels(default_render_modules):
    """No module is loaded for a kernel the render does not launch: the path tracer, the wp.Mesh queries and the
    back-face and cut-out passes (the default scene is double-sided, without cut-outs) share no module with the
    kernels a whitted render launches."""
    assert unlaunched_kernels(default_render_modules, COMPILED_UNLAUNCHED) == {}
    assert all(m["launched"] for m in default_render_modules.values())


def test_a_path_render_compiles_only_modules_of_launched_kernels(tmp_path):
    """A path-traced render loads the path tracer's module (its kernels for the scene's light features:
    ``wrt.integrators.path.features_module``) and not the whitted one (each integrator is a module of its own,
    ``wrt/integrators/``), and compiles no more unlaunched kernels than a whitted render does."""
    out = tmp_path / "path.png"
    modules = loaded_modules(run_and_report(RENDER_AND_REPORT, str(out), "--integrator", "path", "--width", "64",
                                            "--height", "48"))
    assert out.is_file()
    assert "wrt.integrators.path.no_features" in modules  # the default room: a sun and a dome
    assert not [name for name in modules if name.startswith("wrt.integrators.whitted")]
    assert unlaunched_kernels(modules, COMPILED_UNLAUNCHED) == {}


# wrt.trace's kernels that a closest-hit query of wrt's BVH compiles without launching: the twin of the counting trace
# kernel it launches (a module of its own would compile the traversal code again for every render that traces bounce
# rays), the any-hit kernel and the instance rows' mapping (unused by an uninstanced scene).
TRACE_UNLAUNCHED = {"trace_bvh_kernel_uncounted", "occluded_bvh_kernel", "split_rows_kernel"}


def test_a_trace_compiles_no_module_of_the_renderer():
    """``wrt.trace`` (the README's first query) loads the BVH builder's modules, ``wrt.trace`` and the check of the
    rays' reach (``wrt.ray_reach``), none of the renderer's: shading, integrators and cut-out passes share no module
    with a trace."""
    modules = loaded_modules(run_and_report(TRACE_AND_REPORT))
    assert "wrt.trace" in modules
    traced = ("wrt.trace", "wrt.ray_reach")
    assert [name for name in modules if name not in traced and not name.startswith("wrt.bvh.")] == []
    assert unlaunched_kernels(modules, TRACE_UNLAUNCHED) == {}


def test_default_render_loads_each_module_once(default_render):
    """Launches split across threads load each module once: threads that reached a module's first launch together
    each compiled it (on an empty kernel cache the trace and whitted modules were compiled twice, on both cores)."""
    loads = collections.Counter(re.findall(r"^Module (\S+) \S+ load on device 'cpu'", default_render, re.M))
    assert loads  # Warp printed its module-load lines
    assert {name: n for name, n in loads.items() if n > 1} == {}


def test_an_instanced_trace_builds_each_module_once_per_device():
    """Warp keeps one build of a module per device and threads per block (``Module.execs``), so a kernel launched at
    another block size than its module's others builds the whole module again. ``RowSplitter`` launched
    ``split_rows_kernel`` at Warp's default 256 beside trace kernels at 64 threads per block on CUDA: every
    instanced ``accel="warp"`` or non-binary trace compiled ``wrt.trace`` twice. (On the CPU both are 256; the
    check bites under ``-p trace_on_cuda``.)"""
    import numpy as np
    import warp as wp

    import wrt
    from wrt.instancing import Instances

    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    proto = wrt.Prototype("/P", [wrt.Mesh("/P/Tri", points, np.array([[0, 1, 2]]), None)])
    to_world = np.broadcast_to(np.eye(4), (3, 4, 4)).copy()
    to_world[:, 2, 3] = [0.0, -1.0, -2.0]  # column-vector transforms: the translation is the last column
    scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(3, int), to_world))
    device = wp.get_device(getattr(wrt.trace, "keywords", {}).get("device", "cpu"))
    origins = np.array([[0.25, 0.25, 1.0]] * 2, np.float32)
    directions = np.array([[0.0, 0.0, -1.0]] * 2, np.float32)
    for accel, layout in (("warp", "binary"), ("wrt", "compact")):
        hits = wrt.trace(scene, origins, directions, accel=accel, layout=layout)
        assert list(hits.instance) == [0, 0] and list(hits.prim) == [0, 0], (accel, layout)
    for name in ("wrt.trace", "wrt.mesh_trace"):  # the second holds the wp.Mesh kernels
        builds = [block_dim for context, block_dim in wp.get_module(name).execs if context == device.context]
        assert len(builds) <= 1, (name, builds)
