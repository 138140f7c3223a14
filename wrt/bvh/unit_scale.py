"""Builds scenes of extreme size in a unit-sized frame.

The builders compare float32 surface areas: past about 1e19 a box's area (1e38) overflows float32 to inf, and
below about 1e-19 it underflows to 0, so every split costs the same and the SAH builders chose as blindly as a
median (a tree of 1e30-sized triangles cost 95.0 in SAH against 66.8 for the same triangles at unit size). Scaling
by a power of two keeps every split decision of a unit-sized scene; the node boxes are scaled back afterwards.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

# A frame this large leaves room for sums of areas times counts (2**(2 * 32 + 30)) far from float32's 2**128.
SAFE_EXPONENT = 32


def unit_exponent(data) -> int:
    """``e`` with the largest coordinate of ``data``'s triangle boxes in ``[2**(e-1), 2**e)``, or 0 where it lies
    within ``2**SAFE_EXPONENT`` of 1 (no scaling needed). On the CPU read from the boxes' own memory (numpy views, no
    launch: a reduction and its wait cost a tiny tree's build a third more); on a GPU by one reduction. Not from the
    points, which may hold unused ones far out, nor from ``points[indices]``, a gather of 6.7 s for 10M triangles."""
    if data.device.is_cpu:
        lowers, uppers = data.prim_lowers.numpy(), data.prim_uppers.numpy()
        largest = max(float(np.abs(lowers).max(initial=0.0)), float(np.abs(uppers).max(initial=0.0)))
    else:
        largest = float(np.abs(data.root_bounds().numpy()[:2]).max())
    return size_exponent(largest)


def size_exponent(largest: float) -> int:
    """:func:`unit_exponent` of a largest coordinate ``largest``."""
    if largest == 0.0 or not math.isfinite(largest):
        return 0
    exponent = math.frexp(largest)[1]
    return exponent if abs(exponent) > SAFE_EXPONENT else 0


def _scaled(exact: np.ndarray, exponent: int, rounding: float, device) -> wp.array:
    """Float64 ``exact * 2**-exponent`` as a float32 vec3 array on ``device``, rounded towards ``rounding`` (-inf,
    +inf or 0: nearest) where the scaled value is not exact (subnormal): boxes stay conservative."""
    exact = exact * 2.0 ** -exponent
    value = exact.astype(np.float32)
    if rounding:
        off = value > exact if rounding < 0 else value < exact
        value[off] = np.nextafter(value[off], np.float32(rounding))
    return wp.array(value, dtype=wp.vec3, device=device)


def scale_input(data, exponent: int) -> None:
    """Scales ``data``'s triangle boxes and centroids by ``2**-exponent`` in place (the builders read no more). The
    centroids are the scaled boxes' centres, from float64: past 2**127 (1.7e38) the float32 centres the build made,
    ``0.5 * (lower + upper)``, had overflowed to inf, and every split was chosen blind."""
    lowers = data.prim_lowers.numpy().astype(np.float64)
    uppers = data.prim_uppers.numpy().astype(np.float64)
    device = data.prim_lowers.device
    data.prim_lowers = _scaled(lowers, exponent, -np.inf, device)
    data.prim_uppers = _scaled(uppers, exponent, np.inf, device)
    data.centroids = _scaled(0.5 * (lowers + uppers), exponent, 0.0, device)


def scale_boxes_back(tree, exponent: int) -> None:
    """Scales a tree built from :func:`scale_input`'s boxes back to world size (exact: a power of two of normal
    floats; the outward-rounded subnormals come back at most one step looser)."""
    for name in ("lowers", "uppers"):
        array = getattr(tree, name)
        value = (array.numpy().astype(np.float64) * 2.0 ** exponent).astype(np.float32)
        setattr(tree, name, wp.array(value, dtype=wp.vec3, device=array.device))
