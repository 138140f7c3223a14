"""A pytest plugin for a CUDA host: every :class:`wrt.Renderer` (so every ``wrt.render``) renders on ``cuda:0``, the
CPU when asked for included, so shading tests written for the CPU check the CUDA shade kernels against the same
analytic oracles. A test that compares two devices then compares ``cuda:0`` with itself, which proves nothing but
does not fail.

Usage, on the GPU host: ``PYTHONPATH=$PWD:$PWD/benchmarks python -m pytest -p render_on_cuda -s tests/test_x.py``
(``-s`` shows the line it prints, proof that it is active).
"""

import importlib

_render_module = importlib.import_module("wrt.render")  # the module: ``wrt.render`` is the function
_resolve = _render_module.resolve_device


def _on_cuda(device=None):
    return _resolve("cuda:0")


_render_module.resolve_device = _on_cuda
print("render_on_cuda: wrt.Renderer renders on cuda:0 whatever device it is given")
