"""LBVH: Morton codes and a radix tree (Karras, "Maximizing Parallelism in the Construction of BVHs, Octrees, and
k-d Trees", HPG 2012), as Warp kernels on ``cpu`` and ``cuda``.

1. Each triangle's centroid is quantized to 10 or 21 bits per axis in the cube around the centroid box (cubic
   cells: per-axis scaling gave 8% worse SAH cost on turbineblade_199k) and its bits interleaved into a 30-bit or
   63-bit Morton code (Lauterbach et al. 2009).
2. The codes are radix sorted (stable, so equal codes keep the id order).
3. Long runs of equal codes are ordered by a second code: when more than :func:`run_limit` triangles share a code
   (a dense cluster far from the rest: every code of 1e5 triangles 1e-3 across was equal with one triangle 1e10 away),
   each run gets a 30-bit Morton code of its centroids in the run's own centroid box, and the triangles are sorted
   by (run, second code). Without it a run's triangles stayed in id order, a spatially random tree: rays into that
   cluster visited 28k nodes each (``sah``: 57).
4. One thread per internal node ``i`` finds its key range and split from the longest common prefix ``delta`` of
   neighbouring keys (Karras 2012, Figure 4), the key being the code, then the second code, then the index.
   Node ``i``'s children are ``gamma`` and ``gamma + 1`` (a leaf when the range ends there).
5. ``flatten.py`` turns the radix tree into the canonical layout (depth guarantee, bounds, SAH leaf collapse).
"""

from __future__ import annotations

import warp as wp

from .common import BuildInput, read_int, stage
from .flatten import flatten_source
from .layout import DeviceFlatBvh

wp.set_module_options({"enable_backward": False})

RUN_LIMIT = 16  # a run of equal Morton codes longer than run_limit(n) gets second codes (see module docstring)
RUN_SHARE = 1024  # ... where run_limit(n) is at least n / RUN_SHARE
SUB_AXIS_BITS = wp.constant(10)  # bits per axis of a second code
SUB_BITS = wp.constant(30)  # bits of a second code; a run index takes the bits above them in the sort key


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
def common_prefix(codes: wp.array[wp.uint64], subcodes: wp.array[wp.uint64], refined: int, n: int, i: int, j: int):
    """Karras' ``delta(i, j)``: common prefix length of keys ``i`` and ``j``, -1 outside ``[0, n)``.

    A key is the 64-bit code, then (with ``refined``) the ``SUB_BITS``-bit second code, then the 32-bit index, so
    every key is distinct."""
    result = int(-1)
    if j >= 0 and j < n:
        a = codes[i]
        b = codes[j]
        if a != b:
            result = clz64(a ^ b)
        elif refined != 0 and subcodes[i] != subcodes[j]:
            result = 64 + clz64(subcodes[i] ^ subcodes[j]) - (64 - SUB_BITS)
        else:
            result = 64 + SUB_BITS + clz64(wp.uint64(i ^ j)) - 32
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
def long_runs_kernel(
    codes: wp.array[wp.uint64],
    limit: int,
    # outputs
    starts: wp.array[wp.int32],
    long_runs: wp.array[wp.int32],
):
    """Flags the first slot of each run of equal sorted codes; counts the slots that end a stretch of more than
    ``limit`` equal codes."""
    i = wp.tid()
    start = int(1)
    if i > 0:
        if codes[i] == codes[i - 1]:
            start = 0
    starts[i] = start
    if i > limit:
        if codes[i] == codes[i - limit - 1]:
            wp.atomic_add(long_runs, 0, 1)


@wp.kernel
def run_bounds_kernel(
    slot_prims: wp.array[wp.int32],
    centroids: wp.array[wp.vec3],
    run_ends: wp.array[wp.int32],
    # outputs
    run_lowers: wp.array[wp.vec3],
    run_uppers: wp.array[wp.vec3],
):
    """Centroid box of each run (``run_ends[i]``: the inclusive scan of the start flags, run ``run_ends[i] - 1``)."""
    i = wp.tid()
    c = centroids[slot_prims[i]]
    r = run_ends[i] - 1
    wp.atomic_min(run_lowers, r, c)
    wp.atomic_max(run_uppers, r, c)


@wp.kernel
def run_keys_kernel(
    slot_prims: wp.array[wp.int32],
    centroids: wp.array[wp.vec3],
    run_ends: wp.array[wp.int32],
    run_lowers: wp.array[wp.vec3],
    run_uppers: wp.array[wp.vec3],
    # outputs
    keys: wp.array[wp.uint64],
):
    """Sort key (run index, second code): the Morton code of the centroid in its run's centroid box."""
    i = wp.tid()
    r = run_ends[i] - 1
    sub = morton_code(centroids[slot_prims[i]], run_lowers[r], run_uppers[r], SUB_AXIS_BITS)
    keys[i] = (wp.uint64(r) << wp.uint64(SUB_BITS)) | sub


@wp.kernel
def second_codes_kernel(
    keys: wp.array[wp.uint64],
    # outputs
    subcodes: wp.array[wp.uint64],
):
    """The second codes out of the sorted (run, second code) keys."""
    i = wp.tid()
    subcodes[i] = keys[i] & ((wp.uint64(1) << wp.uint64(SUB_BITS)) - wp.uint64(1))


@wp.kernel
def radix_tree_kernel(
    codes: wp.array[wp.uint64],
    subcodes: wp.array[wp.uint64],
    refined: int,
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
    if common_prefix(codes, subcodes, refined, n, i, i + 1) < common_prefix(codes, subcodes, refined, n, i, i - 1):
        d = -1
    # Upper bound on the range length, then its exact other end j by binary search.
    delta_min = common_prefix(codes, subcodes, refined, n, i, i - d)
    l_max = int(2)
    while common_prefix(codes, subcodes, refined, n, i, i + l_max * d) > delta_min:
        l_max *= 2
    length = int(0)
    t = l_max / 2
    while t >= 1:
        if common_prefix(codes, subcodes, refined, n, i, i + (length + t) * d) > delta_min:
            length += t
        t = t / 2
    j = i + length * d
    # Split position: the last key sharing more than the range's common prefix with i.
    delta_node = common_prefix(codes, subcodes, refined, n, i, j)
    s = int(0)
    t = length
    while t > 1:
        t = (t + 1) / 2
        if common_prefix(codes, subcodes, refined, n, i, i + (s + t) * d) > delta_node:
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


def sorted_morton_order(data: BuildInput, morton_bits: int) -> tuple[wp.array, wp.array, wp.array | None]:
    """``(slot_prims, codes, subcodes)``: triangle ids in Morton order, their 64-bit codes and, when some run of
    equal codes is longer than :func:`run_limit`, their second codes (else ``None``; see module docstring), on
    ``data.device``."""
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
        return values[:n], codes, _second_codes(data, values, codes)


def run_limit(n: int) -> int:
    """Longest run of equal codes left in id order among ``n``. Ordering runs costs a sort of every key, so runs
    under 0.1% of the triangles are left alone: with any run of 17 ordered, the 10M-triangle sphere's GPU lbvh
    build went from 8.9 to 12.5 ms (its pole fans: thousands of triangles in one cell, in fan order already)."""
    return max(RUN_LIMIT, n // RUN_SHARE)


def _second_codes(data: BuildInput, values: wp.array, codes: wp.array) -> wp.array | None:
    """Sorts each run of more than :func:`run_limit` equal codes by second codes, in place in ``values`` (``2 n``
    entries, the sorted ids first), and returns every slot's second code; ``None`` when no run is that long."""
    n = data.num_prims
    starts = wp.empty(n, dtype=wp.int32)
    long_runs = wp.zeros(1, dtype=wp.int32)
    wp.launch(long_runs_kernel, n, inputs=[codes, run_limit(n)], outputs=[starts, long_runs])
    if read_int(long_runs, 0) == 0:
        return None
    run_ends = wp.empty(n, dtype=wp.int32)
    wp.utils.array_scan(starts, run_ends, inclusive=True)
    del starts
    runs = read_int(run_ends, n - 1)
    run_lowers = wp.full(runs, wp.vec3(float("inf")), dtype=wp.vec3)
    run_uppers = wp.full(runs, wp.vec3(-float("inf")), dtype=wp.vec3)
    slot_prims = values[:n]
    wp.launch(run_bounds_kernel, n, inputs=[slot_prims, data.centroids, run_ends], outputs=[run_lowers, run_uppers])
    keys = wp.empty(2 * n, dtype=wp.uint64)
    wp.launch(run_keys_kernel, n, inputs=[slot_prims, data.centroids, run_ends, run_lowers, run_uppers],
              outputs=[keys])
    # Runs are in code order and a run's index is above its second code, so this keeps the code order.
    wp.utils.radix_sort_pairs(keys, values, n, end_bit=SUB_BITS + max(1, (runs - 1).bit_length()))
    subcodes = wp.empty(n, dtype=wp.uint64)
    wp.launch(second_codes_kernel, n, inputs=[keys], outputs=[subcodes])
    return subcodes


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
            slot_prims, codes, subcodes = sorted_morton_order(data, morton_bits)
        with stage("radix tree", timers):
            inner = max(n - 1, 1)  # every entry is written when n > 1 and never read when n == 1
            src_left = wp.empty(inner, dtype=wp.int32)
            src_right = wp.empty(inner, dtype=wp.int32)
            src_counts = wp.empty(inner, dtype=wp.int32)
            if n > 1:
                refined = subcodes is not None
                inputs = [codes, subcodes if refined else codes, int(refined), n]
                wp.launch(radix_tree_kernel, n - 1, inputs=inputs, outputs=[src_left, src_right, src_counts])
        del codes, subcodes  # before the flatten allocates, so the memory pool hands it over (ploc.build_ploc says why)
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
