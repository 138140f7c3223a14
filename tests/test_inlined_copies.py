"""How many copies of wrt's large device functions the CUDA compiler is given to inline into each shading kernel.

NVRTC inlines every ``@wp.func`` into its caller, so a function called from several places in a kernel (directly or
through other functions) is optimised and assembled once per call site: the path kernel drew each tube light through
its own copy of the tube draw, whitted's dome term compiled every light's draw again, and each textured input of a
surface its own texture lookup. A frame on a fresh GPU waited minutes for that (``benchmarks/cuda_compile_time.py``).
These tests read the call sites from Warp's generated CUDA source (no GPU needed) and count the copies along every
path of calls from a kernel, which must stay one per kernel for the functions whose size set the compile time.
"""

from __future__ import annotations

import collections
import importlib
import re

import pytest
import warp as wp

FUNCTION = re.compile(r'^(?:static [^\n]*CUDA_CALLABLE [^\n(]*?(\w+)\(|extern "C" __global__ void (\w+)\()', re.M)


def calls_in(module_name: str) -> dict[str, collections.Counter]:
    """``{function: Counter(callee: call sites)}`` of the CUDA source Warp generates for ``module_name``, forward
    functions and kernels only; kernels are keyed by their Python name."""
    importlib.import_module(module_name)
    module = wp.get_module(module_name)
    options = module.resolve_options(wp.config) | {"output_arch": 90}
    source = module._run_codegen(options, False)[0]  # Warp's own codegen for the "cuda" target, as a load runs it
    starts = [(m.start(), m.group(1) or m.group(2)) for m in FUNCTION.finditer(source)]
    bodies = {}
    for (start, name), (end, _) in zip(starts, starts[1:] + [(len(source), "")]):
        if not name.startswith("adj_"):
            text = source[start:end]
            bodies[re.sub(r"(_[0-9a-f]{8}_cuda_kernel_forward|_0)$", "", name)] = text[text.index("{"):]
    return {name: collections.Counter(m.group(1)[:-2] for m in re.finditer(r"\b(\w+_0)\(", body)
                                      if m.group(1)[:-2] in bodies and m.group(1)[:-2] != name)
            for name, body in bodies.items()}


def copies(calls: dict, root: str, name: str) -> int:
    """How many times ``name`` is inlined into ``root``: its call sites summed over every path of calls from it."""
    return sum(n * (1 if callee == name else copies(calls, callee, name)) for callee, n in calls[root].items())


@pytest.fixture(scope="module")
def path_calls():
    return calls_in("wrt.integrators.path")


@pytest.fixture(scope="module")
def whitted_calls():
    return calls_in("wrt.integrators.whitted")


@pytest.mark.parametrize("function", ["sample_tube", "shape_emission", "sample_dome", "seen_rect"])
def test_the_light_draw_holds_one_copy_of_each_large_draw(path_calls, function):
    """The three tube lights (cylinder, glowing tube, elliptic tube) share one tube draw, the three glowing shapes one
    emission read, the dome's draw is one function, and rect and disk lights and glowing planes and disks share one
    rect draw."""
    assert copies(path_calls, "sample_light", function) == 1


def test_a_surface_holds_one_texture_lookup(path_calls):
    """The eight textured inputs of a surface are read through one lookup (a loop over the slots)."""
    assert copies(path_calls, "eval_surface", "lookup_binding") == 1


def test_a_bilinear_lookup_wraps_each_row_and_column_once(path_calls):
    assert copies(path_calls, "sample_image", "wrap_coord") == 4


def test_a_tube_light_pdf_holds_one_tube_density(path_calls):
    """The cylinder's and the elliptic tube's pdfs, for rays that meet them, share one density."""
    assert copies(path_calls, "area_light_pdf", "tube_point_density") == 1


def test_each_path_bounce_draws_lights_through_one_copy(path_calls):
    assert copies(path_calls, "shade_path_kernel", "sample_light") == 1


@pytest.mark.parametrize("kernel, draws", [("shade_whitted_kernel", 0), ("whitted_lights_kernel", 1)])
def test_whitted_draws_every_light_only_where_it_lights_them(whitted_calls, kernel, draws):
    """Whitted's dome term draws the dome alone, not through the draw of every kind of light."""
    assert copies(whitted_calls, kernel, "sample_light") == draws
