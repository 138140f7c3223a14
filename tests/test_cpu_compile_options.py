"""The options wrt's Warp modules compile with on the CPU, read from Warp's resolved module options (nothing compiled).

A user's first render compiles the modules it launches, with none of the test suite's settings (tests/conftest.py
turns adjoints off for every module): each kernel module turns them off itself, and the integrators' modules keep
clang from inlining their large device functions into every call site (wrt.shade.SHADING_CPU_FLAGS).
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest
import warp as wp

WRT = Path(__file__).resolve().parents[1] / "wrt"
KERNEL_MODULES = sorted(
    "wrt." + ".".join(path.relative_to(WRT).with_suffix("").parts)
    for path in WRT.rglob("*.py")
    if "@wp.kernel" in path.read_text()
)
INTEGRATORS = ["wrt.integrators.whitted", "wrt.integrators.path", "wrt.integrators.ao"]
LLVM_INLINE_THRESHOLD = 225  # LLVM's own, where no -inline-threshold is given


def resolved_options(module_name: str) -> dict:
    importlib.import_module(module_name)
    return wp.get_module(module_name).resolve_options(wp.config)


def inline_threshold(flags: str) -> int:
    found = re.findall(r"-inline-threshold=(\d+)", flags)
    return int(found[-1]) if found else LLVM_INLINE_THRESHOLD


def test_the_kernel_modules_are_found():
    assert len(KERNEL_MODULES) > 20 and set(INTEGRATORS) <= set(KERNEL_MODULES)


@pytest.mark.parametrize("module_name", KERNEL_MODULES)
def test_each_kernel_module_compiles_no_adjoints(module_name):
    assert resolved_options(module_name)["enable_backward"] is False


@pytest.mark.parametrize("module_name", INTEGRATORS)
def test_the_integrators_compile_with_a_moderate_inline_threshold(module_name):
    """At Warp's default threshold of 9000 clang copied the large device functions into every call site: the whitted
    module's object code 437 KB (286 KB at 1000) and its compile 11.8 s of CPU (7.4 s), with slower shading."""
    assert inline_threshold(resolved_options(module_name)["cpu_compiler_flags"]) <= 1000


def test_the_inline_threshold_is_read_from_the_flags():
    assert inline_threshold("-march=native -mllvm=-inline-threshold=9000 -mllvm=-slp-recursion-max-depth=4") == 9000
    assert inline_threshold("-march=native") == LLVM_INLINE_THRESHOLD
