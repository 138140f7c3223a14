"""A pytest plugin for a CUDA host: ``wrt.trace`` and ``wrt.occluded`` trace on ``cuda:0`` unless told otherwise, so
tests written for the CPU (the gprim differential, say) check the CUDA kernels against the same oracles.

Usage, on the GPU host: ``PYTHONPATH=$PWD:$PWD/benchmarks python -m pytest -p trace_on_cuda -s tests/test_x.py``
(``-s`` shows the line it prints, proof that it is active).
"""

import functools

import wrt

for _name in ("trace", "occluded"):
    setattr(wrt, _name, functools.partial(getattr(wrt, _name), device="cuda:0"))
print("trace_on_cuda: wrt.trace and wrt.occluded default to cuda:0")
