"""LBVH: Morton codes and a radix tree (Karras, "Maximizing Parallelism in the Construction of BVHs, Octrees, and
k-d Trees", HPG 2012), as Warp kernels on ``cpu`` and ``cuda``.

1. Each triangle's centroid is quantized to 10 or 21 bits per axis in the cube around the centroid box (cubic
   cells: per-axis scaling gave 8% worse SAH cost on turbineblade_199k) and its bits interleaved into a 30-bit or
   63-bit Morton code (Lauterbach et al. 2009).
2. The codes are radix sorted (stable, so equal codes keep the id order).
3. One thread per internal node ``i`` finds its key range and split from the longest common prefix ``delta`` of
   neighbouring codes (Karras 2012, Figure 4); equal codes are told apart by their indices (``64 + clz(i ^ j)``).
   Node ``i``'s children are ``gamma`` and ``gamma + 1`` (a leaf when the range ends there).
4. ``flatten.py`` turns the radix tree into the canonical layout (depth guarantee, bounds, SAH leaf collapse).
"""

from __future__ import annotations

import warp as wp

from .common import BuildInput, stage
from .flatten import flatten_source
from .layout import DeviceFlatBvh

wp.set_module_options({"enable_backward": False})


@wp.func
def expand_bits(x: wp.uint64):
    """Spreads the low 21 bits of ``x`` so that two zero bits follow each one (bit ``k`` moves to ``3 k``)."""
    x = x & wp.uint64(0x1FFFFF)
    x = (x | (x << wp.uint64(32))) & wp.uint64(0x1F00000000FFFF)
    x = (x | (x << wp.uint64(16))) & wp.uint64(0x1F0000FF0000FF)
    x = (x | (x << wp.uint64(8))) & wp.uint64(0x100F00F00F00F00F)
    x = (x | (x << wp.uint64(4))) & wp.uint64(0x10C30C30C30C30C3)
    x = (x | (x << wp.uint64(2))) & wp.uint64(0x1249249249249249)
    return x


@wp.func
def morton_code(c: wp.vec3, lower: wp.vec3, upper: wp.vec3, bits_per_axis: int):
    """Morton code of point ``c`` quantized to ``bits_per_axis`` bits per axis in the cube of side
    ``max(upper - lower)`` at ``lower``: cubic cells keep the curve's locality the same along every axis."""
    cells = float(1 << bits_per_axis)
    code = wp.uint64(0)
    extent = wp.max(wp.max(upper[0] - lower[0], upper[1] - lower[1]), upper[2] - lower[2])
    for axis in range(3):
        q = int(0)
        if extent > 0.0:
            q = wp.clamp(int((c[axis] - lower[axis]) / extent * cells), 0, (1 << bits_per_axis) - 1)
        code = code | (expand_bits(wp.uint64(q)) << wp.uint64(2 - axis))
    return code


@wp.func
def clz64(x: wp.uint64):
    """Leading zero bits of a 64-bit word (64 for 0)."""
    n = int(0)
    if x == wp.uint64(0):
        n = 64
    else:
        for shift in range(5, -1, -1):
            step = 1 << shift
            if (x >> wp.uint64(64 - step)) == wp.uint64(0):
                n += step
                x = x << wp.uint64(step)
    return n


@wp.func
def common_prefix(codes: wp.array[wp.uint64], n: int, i: int, j: int):
    """Karras' ``delta(i, j)``: common prefix length of keys ``i`` and ``j``, -1 outside ``[0, n)``.

    Equal codes are extended by their indices, so every key is distinct."""
    result = int(-1)
    if j >= 0 and j < n:
        a = codes[i]
        b = codes[j]
        if a == b:
            result = 64 + clz64(wp.uint64(i ^ j)) - 32
        else:
            result = clz64(a ^ b)
    return result


@wp.kernel
def morton_codes_kernel(
    centroids: wp.array[wp.vec3],
    bounds: wp.array[wp.vec3],
    bits_per_axis: int,
    # outputs
    keys32: wp.array[wp.uint32],
    keys64: wp.array[wp.uint64],
    values: wp.array[wp.int32],
):
    """Morton code of each centroid in the centroid box ``bounds[2], bounds[3]``, into the key array in use."""
    i = wp.tid()
    code = morton_code(centroids[i], bounds[2], bounds[3], bits_per_axis)
    if bits_per_axis == 10:
        keys32[i] = wp.uint32(code)
    else:
        keys64[i] = code
    values[i] = i


@wp.kernel
def widen_codes_kernel(
    keys32: wp.array[wp.uint32],
    # outputs
    codes: wp.array[wp.uint64],
):
    """Sorted 30-bit keys as 64-bit codes for the radix tree."""
    i = wp.tid()
    codes[i] = wp.uint64(keys32[i])


@wp.kernel
def radix_tree_kernel(
    codes: wp.array[wp.uint64],
    n: int,
    # outputs
    src_left: wp.array[wp.int32],
    src_right: wp.array[wp.int32],
    src_counts: wp.array[wp.int32],
):
    """Karras 2012: range, split and children of internal node ``i`` (leaf children as ``-slot - 1``)."""
    i = wp.tid()
    # Direction of the range: towards the neighbour with the longer common prefix.
    d = int(1)
    if common_prefix(codes, n, i, i + 1) < common_prefix(codes, n, i, i - 1):
        d = -1
    # Upper bound on the range length, then its exact other end j by binary search.
    delta_min = common_prefix(codes, n, i, i - d)
    l_max = int(2)
    while common_prefix(codes, n, i, i + l_max * d) > delta_min:
        l_max *= 2
    length = int(0)
    t = l_max / 2
    while t >= 1:
        if common_prefix(codes, n, i, i + (length + t) * d) > delta_min:
            length += t
        t = t / 2
    j = i + length * d
    # Split position: the last key sharing more than the range's common prefix with i.
    delta_node = common_prefix(codes, n, i, j)
    s = int(0)
    t = length
    while t > 1:
        t = (t + 1) / 2
        if common_prefix(codes, n, i, i + (s + t) * d) > delta_node:
            s += t
    gamma = i + s * d + wp.min(d, 0)
    first = wp.min(i, j)
    last = wp.max(i, j)
    left = gamma
    if first == gamma:
        left = -gamma - 1
    right = gamma + 1
    if last == gamma + 1:
        right = -gamma - 2
    src_left[i] = left
    src_right[i] = right
    src_counts[i] = last - first + 1


def sorted_morton_order(data: BuildInput, morton_bits: int) -> tuple[wp.array, wp.array]:
    """``(slot_prims, codes)``: triangle ids in Morton order and their 64-bit codes, on ``data.device``."""
    n = data.num_prims
    bits_per_axis = 10 if morton_bits == 30 else 21
    with wp.ScopedDevice(data.device):
        bounds = data.root_bounds()
        values = wp.empty(2 * n, dtype=wp.int32)
        codes = wp.empty(n, dtype=wp.uint64)
        if bits_per_axis == 10:
            keys32 = wp.empty(2 * n, dtype=wp.uint32)
            keys64 = wp.empty(1, dtype=wp.uint64)
        else:
            keys32 = wp.empty(1, dtype=wp.uint32)
            keys64 = wp.empty(2 * n, dtype=wp.uint64)
        wp.launch(
            morton_codes_kernel, n, inputs=[data.centroids, bounds, bits_per_axis], outputs=[keys32, keys64, values]
        )
        if bits_per_axis == 10:
            wp.utils.radix_sort_pairs(keys32, values, n, end_bit=30)
            wp.launch(widen_codes_kernel, n, inputs=[keys32], outputs=[codes])
        else:
            wp.utils.radix_sort_pairs(keys64, values, n, end_bit=63)
            wp.copy(codes, keys64, 0, 0, n)
        return values[:n], codes


def build_lbvh(
    data: BuildInput,
    *,
    leaf_size: int,
    morton_bits: int,
    traversal_cost: float = 1.0,
    intersection_cost: float = 1.0,
    timers: dict | None = None,
) -> DeviceFlatBvh:
    """Builds an LBVH over ``data`` (see module docstring) on ``data.device``; ``timers`` as in ``flatten_source``."""
    n = data.num_prims
    with wp.ScopedDevice(data.device):
        with stage("morton codes and sort", timers):
            slot_prims, codes = sorted_morton_order(data, morton_bits)
        with stage("radix tree", timers):
            inner = max(n - 1, 1)  # every entry is written when n > 1 and never read when n == 1
            src_left = wp.empty(inner, dtype=wp.int32)
            src_right = wp.empty(inner, dtype=wp.int32)
            src_counts = wp.empty(inner, dtype=wp.int32)
            if n > 1:
                wp.launch(radix_tree_kernel, n - 1, inputs=[codes, n], outputs=[src_left, src_right, src_counts])
        del codes  # before the flatten allocates, so the memory pool hands it over (ploc.build_ploc says why)
        return flatten_source(
            slot_prims,
            src_left,
            src_right,
            src_counts,
            0,
            data.prim_lowers,
            data.prim_uppers,
            leaf_size=leaf_size,
            traversal_cost=traversal_cost,
            intersection_cost=intersection_cost,
            builder="lbvh",
            timers=timers,
        )
