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
import re

import pytest
import warp as wp

from wrt.integrators.path import shade_path_kernel_for
from wrt.integrators.whitted import shade_whitted_kernel_for, whitted_lights_kernel_for
from wrt.light_features import ALL_FEATURES, NO_FEATURES, LightFeatures

FUNCTION = re.compile(r'^(?:static [^\n]*CUDA_CALLABLE [^\n(]*?(\w+)\(|extern "C" __global__ void (\w+)\()', re.M)


def calls_in(*kernels: wp.Kernel) -> dict[str, collections.Counter]:
    """``{function: Counter(callee: call sites)}`` of the CUDA source Warp generates for the modules of ``kernels``,
    forward functions and kernels only; functions and kernels are keyed by their Python names (a function made by a
    factory, ``sample_light_for``, by the name of the function it returns)."""
    bodies = {}
    for module in {kernel.module.name: kernel.module for kernel in kernels}.values():
        options = module.resolve_options(wp.config) | {"output_arch": 90}
        source = module._run_codegen(options, False)[0]  # Warp's own codegen for the "cuda" target, as a load runs it
        starts = [(m.start(), m.group(1) or m.group(2)) for m in FUNCTION.finditer(source)]
        for (start, name), (end, _) in zip(starts, starts[1:] + [(len(source), "")]):
            if not name.startswith("adj_"):
                text = source[start:end]
                bodies[python_name(name)] = text[text.index("{"):]
    return {name: collections.Counter(python_name(m.group(1)) for m in re.finditer(r"\b(\w+_[0-9]+)\(", body)
                                      if python_name(m.group(1)) in bodies and python_name(m.group(1)) != name)
            for name, body in bodies.items()}


def python_name(native: str) -> str:
    """The Python name of a Warp function or kernel from its name in the generated source: Warp numbers each
    function (``_0``, ``_1``, ...), prefixes the factory of one made in a factory (``sample_light_for__locals__``) and
    suffixes kernels with their hash."""
    name = re.sub(r"(_[0-9a-f]{8}_cuda_kernel_forward|_[0-9]+)$", "", native)
    return name.rsplit("__locals__", 1)[-1]


def copies(calls: dict, root: str, name: str) -> int:
    """How many times ``name`` is inlined into ``root``: its call sites summed over every path of calls from it."""
    return sum(n * (1 if callee == name else copies(calls, callee, name)) for callee, n in calls[root].items())


@pytest.fixture(scope="module")
def path_calls():
    return calls_in(shade_path_kernel_for(ALL_FEATURES))


@pytest.fixture(scope="module")
def whitted_calls():
    return calls_in(shade_whitted_kernel_for(ALL_FEATURES), whitted_lights_kernel_for(ALL_FEATURES))


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


# The large draws each feature of wrt.light_features compiles into the path kernel (through the light draw, the lights
# a ray passes and the emission's MIS weight), which a scene without it leaves out.
FEATURE_FUNCTIONS = {
    "shape_lights": ["sample_tube", "sample_hull", "sample_ellipsoid", "shape_emission", "flat_hull",
                     "glowing_hull_pdf", "glowing_tube_pdf", "intersect_elliptic_tube", "tube_point_density"],
    "shaping": ["cone_and_focus", "ies_factor"],
}


@pytest.mark.parametrize("feature", sorted(FEATURE_FUNCTIONS))
def test_a_path_kernel_without_a_feature_compiles_none_of_its_draws(path_calls, feature):
    """The variant for scenes without ``feature`` holds no copy of its functions, the others keep theirs, and the
    variant of every feature (``path_calls``) holds them all."""
    calls = calls_in(shade_path_kernel_for(LightFeatures(**{feature: False})))
    for name in FEATURE_FUNCTIONS[feature]:
        assert copies(path_calls, "shade_path_kernel", name) >= 1, name
        assert name not in calls, name
    for other, names in FEATURE_FUNCTIONS.items():
        if other != feature:
            assert all(copies(calls, "shade_path_kernel", name) >= 1 for name in names), other


def test_whitted_kernels_without_features_compile_none_of_their_draws():
    calls = calls_in(shade_whitted_kernel_for(NO_FEATURES), whitted_lights_kernel_for(NO_FEATURES))
    assert not {name for names in FEATURE_FUNCTIONS.values() for name in names} & set(calls)
