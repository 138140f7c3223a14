"""Wide-node child records read with 16-byte loads on CUDA.

Warp reads a ``vec3`` or ``vec4`` array entry as separate 4-byte loads: a wide node's child box and link were
eight load instructions, a triangle nine. ``load_vec4`` reads one ``vec4`` in a single ``ld.global.nc.v4``, so a
child slot of the wide layout is two loads (``pack_child``). On an H200 the wide layout's trace kernels gained 6-20%
from it (GPU_NOTES.md, row 30): the traversal waits on the L1 more than it computes, and fewer load instructions
queue less there. Triangles packed the same way (three records with the id) were no faster (row 30).

Integers ride in the records as float bit patterns (``wrt.floats``), so the records are one ``vec4`` array.
"""

from __future__ import annotations

import warp as wp

from ..floats import float_bits, int_bits_as_float

_LOAD_VEC4 = """
#if defined(__CUDA_ARCH__)
    const float4 v = __ldg(reinterpret_cast<const float4*>(a.data) + i);
    return wp::vec4(v.x, v.y, v.z, v.w);
#else
    return reinterpret_cast<const wp::vec4*>(a.data)[i];
#endif
"""


@wp.func_native(_LOAD_VEC4)
def load_vec4(a: wp.array[wp.vec4], i: int) -> wp.vec4:
    """Entry ``i`` of a contiguous, read-only ``vec4`` array, in one 16-byte load on CUDA (Warp allocations are
    aligned to 256 bytes, so every entry is 16-byte aligned)."""


@wp.func
def pack_child(records: wp.array[wp.vec4], i: int, lower: wp.vec3, upper: wp.vec3, link: wp.vec2i):
    """Writes child slot ``i`` as records ``2i`` (lower, upper.x) and ``2i + 1`` (upper.y, upper.z, link)."""
    records[2 * i] = wp.vec4(lower[0], lower[1], lower[2], upper[0])
    records[2 * i + 1] = wp.vec4(upper[1], upper[2], int_bits_as_float(link[0]), int_bits_as_float(link[1]))


@wp.func
def load_child(records: wp.array[wp.vec4], i: int):
    """``(lower, upper, link)`` of child slot ``i`` written by ``pack_child``."""
    a = load_vec4(records, 2 * i)
    b = load_vec4(records, 2 * i + 1)
    return wp.vec3(a[0], a[1], a[2]), wp.vec3(a[3], b[0], b[1]), wp.vec2i(float_bits(b[2]), float_bits(b[3]))


@wp.func
def load_link(records: wp.array[wp.vec4], i: int):
    """The link of child slot ``i`` written by ``pack_child``: its second record only, one 16-byte load."""
    b = load_vec4(records, 2 * i + 1)
    return wp.vec2i(float_bits(b[2]), float_bits(b[3]))
