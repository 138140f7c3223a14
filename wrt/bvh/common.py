"""Device math and host plumbing shared by every BVH builder: triangle bounds, the SAH leaf-or-split rule, the
depth guarantee and the checks on build input.

Depth guarantee: a node at depth ``d`` holding ``c`` primitives can always be finished by ``d + ceil(log2 c)``
by halving. Every builder keeps ``d + ceil(log2 c) <= MAX_DEPTH - 1`` for every node it emits and falls back to a
split that halves the count whenever its own split would break that (top-down builders decide this per node;
the bottom-up builders re-split their trees while flattening, see ``flatten.py``). Traversal can therefore use a
fixed stack of ``MAX_DEPTH`` entries.
"""

from __future__ import annotations

import contextlib
import math
import threading

import numpy as np
import warp as wp

from ..options import MAX_BINS as MAX_BINS  # re-exported: see wrt.options
from ..options import MAX_LEAF_SIZE as MAX_LEAF_SIZE

wp.set_module_options({"enable_backward": False})

MAX_DEPTH = 64  # deepest leaf is at depth MAX_DEPTH - 1; traversal stacks hold MAX_DEPTH entries
REDUCE_THREADS = 1 << 16  # threads of the bounds reduction (each folds a grid-strided share)

ACTION_LEAF = wp.constant(0)  # node becomes a leaf
ACTION_SPLIT = wp.constant(1)  # node splits where its builder chose
ACTION_HALVE = wp.constant(2)  # node splits its slot range in half (depth guarantee, coincident centroids)


@wp.func
def ceil_log2(n: int):
    """Smallest ``k`` with ``2**k >= n`` (0 for ``n <= 1``)."""
    k = int(0)
    while (1 << k) < n:
        k += 1
    return k


@wp.func
def half_area(lower: wp.vec3, upper: wp.vec3):
    """Half the surface area of a box; 0 for an empty (inverted) box."""
    d = wp.max(upper - lower, wp.vec3(0.0))
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0]


@wp.func
def widest_axis(extent: wp.vec3):
    """Axis of the largest component of ``extent`` (the first one on ties)."""
    axis = int(0)
    if extent[1] > extent[axis]:
        axis = 1
    if extent[2] > extent[axis]:
        axis = 2
    return axis


@wp.func
def choose_action(
    count: int,
    depth: int,
    area: float,
    has_split: bool,
    split_cost: float,
    n_left: int,
    use_sah: int,
    max_leaf_size: int,
    traversal_cost: float,
    intersection_cost: float,
    max_depth: int,
):
    """Leaf, the builder's split, or halving, for a node of ``count`` primitives at ``depth``.

    ``split_cost`` is the SAH numerator of the split, ``A(L) N(L) + A(R) N(R)``; with ``use_sah`` a node of at
    most ``max_leaf_size`` primitives stays a leaf unless splitting is expected to be cheaper,
    ``C_i N <= C_t + C_i split_cost / A`` (SAH leaf termination). Nodes above ``max_leaf_size`` always split.
    A split is taken only if both children can still be finished within ``max_depth`` by halving.
    """
    leaf_ok = count <= max_leaf_size
    if use_sah == 1 and leaf_ok and has_split and area > 0.0:
        leaf_ok = intersection_cost * float(count) <= traversal_cost + intersection_cost * split_cost / area
    action = ACTION_HALVE
    if count <= 1 or leaf_ok:
        action = ACTION_LEAF
    elif has_split and depth + 1 + ceil_log2(wp.max(n_left, count - n_left)) <= max_depth - 1:
        action = ACTION_SPLIT
    return action


@wp.kernel
def compute_prim_bounds_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    # outputs
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
):
    """Bounds and bounds-centre of every triangle."""
    i = wp.tid()
    a = points[indices[i, 0]]
    b = points[indices[i, 1]]
    c = points[indices[i, 2]]
    lo = wp.min(wp.min(a, b), c)
    hi = wp.max(wp.max(a, b), c)
    prim_lowers[i] = lo
    prim_uppers[i] = hi
    centroids[i] = 0.5 * (lo + hi)


@wp.kernel
def check_input_kernel(
    points: wp.array[wp.vec3],
    indices: wp.array2d[wp.int32],
    # outputs
    errors: wp.array[wp.int32],
):
    """The first triangle with an out-of-range index (``errors[0]``) and the first using a non-finite vertex
    (``errors[1]``); both start at the triangle count, which means none."""
    i = wp.tid()
    n = points.shape[0]
    for k in range(3):
        v = indices[i, k]
        if v < 0 or v >= n:
            wp.atomic_min(errors, 0, i)
        else:
            p = points[v]
            if not (wp.isfinite(p[0]) and wp.isfinite(p[1]) and wp.isfinite(p[2])):
                wp.atomic_min(errors, 1, i)


def check_triangles(points: wp.array, indices: wp.array) -> None:
    """Raises ValueError naming the first triangle that has an index outside ``points`` or uses a NaN or infinite
    vertex (vertices no triangle uses may be anything).

    Args:
        points: ``(V,)`` vec3 vertices.
        indices: ``(T, 3)`` int32 triangles, on the same device.
    """
    n = indices.shape[0]
    if n == 0:
        return
    errors = wp.full(2, n, dtype=wp.int32, device=indices.device)
    wp.launch(check_input_kernel, n, inputs=[points, indices], outputs=[errors], device=indices.device)
    bad_index, bad_point = (int(e) for e in errors.numpy())
    if bad_index < n:
        raise ValueError(f"triangle indices must lie in [0, {len(points)}); triangle {bad_index} has one outside")
    if bad_point < n:
        # Float64 input past float32's range became inf in the cast: say so, as "NaN or inf" alone named no value given.
        raise ValueError(f"triangle vertices must be finite in float32 (found NaN or inf, or a value past float32's "
                         f"3.4e38); triangle {bad_point} uses one")


@wp.kernel
def reduce_bounds_kernel(
    prim_lowers: wp.array[wp.vec3],
    prim_uppers: wp.array[wp.vec3],
    centroids: wp.array[wp.vec3],
    # outputs
    bounds: wp.array[wp.vec3],
):
    """``bounds = [lower, upper, centroid lower, centroid upper]`` of all primitives: each thread reduces a
    grid-strided share (coalesced), then folds it in with four float min/max atomics."""
    t = wp.tid()
    stride = REDUCE_THREADS
    big = wp.vec3(wp.inf)
    lo = big
    hi = -big
    c_lo = big
    c_hi = -big
    for i in range(t, prim_lowers.shape[0], stride):
        lo = wp.min(lo, prim_lowers[i])
        hi = wp.max(hi, prim_uppers[i])
        c_lo = wp.min(c_lo, centroids[i])
        c_hi = wp.max(c_hi, centroids[i])
    wp.atomic_min(bounds, 0, lo)
    wp.atomic_max(bounds, 1, hi)
    wp.atomic_min(bounds, 2, c_lo)
    wp.atomic_max(bounds, 3, c_hi)


def is_device_name(name: str) -> bool:
    """Whether ``name`` is a Warp device name: ``cpu``, ``cuda`` or ``cuda:N``."""
    kind, colon, ordinal = name.partition(":")
    return name in ("cpu", "cuda") or bool(kind == "cuda" and colon and ordinal.isdigit() and ordinal.isascii())


def device_name_hint(name) -> str:
    """`` (did you mean 'cpu'?)`` for a misspelt device name (``'CPU'``, ``'cpu:0'``, ``'Cuda:0'``, ``'gpu'``:
    Warp's names are lowercase), or an empty string."""
    from ..errors import did_you_mean

    if is_device_name(str(name)):  # a name Warp knows, of a device this machine lacks: nothing to correct
        return ""
    meant = str(name).strip().lower()
    meant = {"gpu": "cuda"}.get(meant, meant)
    return f" (did you mean {meant!r}?)" if is_device_name(meant) else did_you_mean(name, ("cpu", "cuda"))


def resolve_device(device) -> wp.Device:
    """``wp.get_device`` with a one-line ``ValueError`` naming the available devices (Warp's own error for
    ``"cuda"`` on a machine without one is a RuntimeError from deep inside)."""
    error = None
    if isinstance(device, str) and device.startswith("cuda") and not wp.is_cuda_available():
        # Refused before Warp looks: without a CUDA driver, wp.get_device("cuda") prints native CUDA errors to stderr
        # ("cuCtxGetCurrent_f: a suitable driver entry point was not found") before its own RuntimeError.
        error = RuntimeError("no CUDA driver")
    else:
        try:
            return wp.get_device(device)
        except (RuntimeError, ValueError, TypeError) as e:
            error = e
    available = ", ".join(d.alias for d in wp.get_devices())
    hint = device_name_hint(device) if isinstance(device, str) else ""
    raise ValueError(f"unknown or unavailable device {device!r}{hint}; available devices: {available}") from error


def resolve_device_option(value: str, option: str = "--device") -> wp.Device:
    """:func:`resolve_device` for a command-line option: its error names the option as typed."""
    try:
        return resolve_device(value)
    except ValueError as e:
        raise ValueError(f"{option} {value}: {e}") from None


class BuildInput:
    """Checked build input on one device: vertex and index arrays and the per-triangle bounds.

    Args:
        points: ``(V, 3)`` float32 vertex positions, numpy or ``wp.array`` (``vec3``).
        indices: ``(T, 3)`` int32 triangle vertex indices, numpy or ``wp.array``.
        device: Warp device to build on.

    Raises:
        ValueError: for out-of-range indices, non-finite vertices used by a triangle, or too many triangles.
    """

    def __init__(self, points, indices, device):
        self.device = resolve_device(device)
        if not isinstance(points, wp.array) and not isinstance(indices, wp.array):
            points, indices = triangle_arrays(points, indices)
        else:
            check_array_layouts(points, indices)
            if isinstance(indices, wp.array) and indices.dtype != wp.int32:
                # Other integer types are cast to int32 on the host: check their range first, as for numpy input.
                indices = indices.numpy()
                check_index_range(indices, int(np.prod(_layout(points)[0])) // 3)
        self.points = _as_device(points, wp.vec3, self.device, (-1,))
        self.indices = _as_device(indices, wp.int32, self.device, (-1, 3))
        self.num_prims = self.indices.shape[0]
        if self.num_prims >= 1 << 30:
            raise ValueError(f"too many triangles for one BVH: {self.num_prims}")
        if self.num_prims == 0:
            return
        check_triangles(self.points, self.indices)
        n = self.num_prims
        self.prim_lowers = wp.empty(n, dtype=wp.vec3, device=self.device)  # triangle box minimum
        self.prim_uppers = wp.empty(n, dtype=wp.vec3, device=self.device)  # triangle box maximum
        self.centroids = wp.empty(n, dtype=wp.vec3, device=self.device)  # triangle box centre
        wp.launch(
            compute_prim_bounds_kernel,
            n,
            inputs=[self.points, self.indices],
            outputs=[self.prim_lowers, self.prim_uppers, self.centroids],
            device=self.device,
        )

    def root_bounds(self) -> wp.array:
        """``(4,)`` vec3 device array: box lower, box upper, centroid lower, centroid upper of all triangles."""
        big = np.full(3, np.inf, np.float32)
        bounds = wp.array(np.stack([big, -big, big, -big]), dtype=wp.vec3, device=self.device)
        wp.launch(
            reduce_bounds_kernel,
            min(self.num_prims, REDUCE_THREADS),
            inputs=[self.prim_lowers, self.prim_uppers, self.centroids],
            outputs=[bounds],
            device=self.device,
        )
        return bounds


def _layout(a) -> tuple[tuple, str, str]:
    """The shape and dtype kind (numpy's ``"f"``, ``"i"``, ...) that ``a`` has as a numpy array, and its dtype (a
    numpy dtype, or a Warp dtype's name; both print as the name): a Warp vector dtype adds its length as a last
    axis."""
    if isinstance(a, wp.array):
        vector = wp.types.type_is_vector(a.dtype)
        scalar = a.dtype._wp_scalar_type_ if vector else a.dtype
        kind = "i" if wp.types.type_is_int(scalar) else "f" if wp.types.type_is_float(scalar) else "O"
        return tuple(a.shape) + ((wp.types.type_size(a.dtype),) if vector else ()), kind, a.dtype.__name__
    a = np.asarray(a)
    return a.shape, a.dtype.kind, a.dtype  # (not str(): the name is wanted only in an error, and costs per mesh)


def check_array_layouts(points, indices) -> None:
    """Raises ``ValueError`` naming the array unless ``points`` (numpy or ``wp.array``) has shape ``(V, 3)`` or
    ``(3V,)`` of real numbers and ``indices`` shape ``(T, 3)`` or ``(3T,)`` of integers. Warp arrays are held to
    the same rule as numpy ones: a ``(3, 4)`` Warp index array was reshaped into four triangles and float indices
    were truncated."""
    for name, a in (("points", points), ("indices", indices)):
        shape, kind, dtype = _layout(a)
        size = math.prod(shape)  # (np.prod of a shape: several us per array, for every mesh made)
        if not (len(shape) == 2 and shape[1] == 3 or len(shape) == 1 and size % 3 == 0):
            raise ValueError(f"{name} must have shape (N, 3) or (3N,), got {shape}")
        if name == "points" and kind not in "iuf":
            raise ValueError(f"points must be real numbers, got dtype {dtype}")
        if name == "indices" and size and kind not in "iu":
            raise ValueError(f"indices must be integers, got dtype {dtype}")


def triangle_arrays(points, indices) -> tuple[np.ndarray, np.ndarray]:
    """Host ``(points (V, 3) float32, indices (T, 3) int32)`` from array-likes of shape ``(V, 3)`` or ``(3V,)`` and
    ``(T, 3)`` or ``(3T,)``.

    Raises:
        ValueError: naming the array, for any other shape, indices that are not integers, or indices outside
            ``[0, V)`` (checked before the cast to int32, so 2**32 does not wrap round to 0).
    """
    points, indices = np.asarray(points), np.asarray(indices)
    check_array_layouts(points, indices)
    check_index_range(indices, points.size // 3)
    with np.errstate(over="ignore"):  # values past float32's range become inf, refused by check_triangles by name
        points = points.astype(np.float32)
    return points.reshape(-1, 3), indices.astype(np.int32).reshape(-1, 3)


def check_index_range(indices: np.ndarray, vertices: int) -> None:
    """Raises ``ValueError`` naming the first triangle with an index outside ``[0, vertices)`` (on the host, before
    any cast to int32, so 2**32 does not wrap round to 0)."""
    flat = indices.reshape(-1)
    outside = np.flatnonzero((flat < 0) | (flat >= vertices)) if flat.size else flat
    if len(outside):
        triangle = int(outside[0]) // 3
        raise ValueError(f"triangle indices must lie in [0, {vertices}); triangle {triangle} has one outside")


def _as_device(data, dtype, device, shape) -> wp.array:
    """``data`` (already checked by ``triangle_arrays`` unless a Warp array) as a contiguous Warp array of
    ``dtype`` on ``device``, reshaped to ``shape``."""
    if isinstance(data, wp.array):
        if data.device == device and data.is_contiguous:
            if dtype == wp.vec3 and data.dtype == wp.vec3:
                return data
            if dtype == wp.int32 and data.dtype == wp.int32:
                return data.reshape(shape)
        data = data.numpy()
    array = np.ascontiguousarray(np.asarray(data, dtype=np.float32 if dtype == wp.vec3 else np.int32))
    if dtype == wp.vec3:
        return wp.array(array.reshape(-1, 3), dtype=wp.vec3, device=device)
    return wp.array(array.reshape(shape), dtype=wp.int32, device=device)


# Per thread: device -> one pinned host int32, the target of read_int's copies. One word per device shared by all
# threads handed a thread building on a GPU the value another thread's copy had just written there.
_PINNED = threading.local()


def pinned_word(device) -> wp.array:
    """The calling thread's pinned host int32 that :func:`read_int` copies values of ``device`` into, made on first
    use."""
    words = _PINNED.__dict__.setdefault("words", {})
    key = str(device)
    if key not in words:
        words[key] = wp.empty(1, dtype=wp.int32, device="cpu", pinned=True)
    return words[key]


def read_int(array: wp.array, index: int) -> int:
    """One element of an int32 device array, as a Python int (synchronizes with the array's device).

    The builders call this once per level or iteration; a reused pinned word avoids allocating a host array and
    going through a pageable copy each time."""
    if array.device.is_cpu:
        return int(array.numpy()[index])
    word = pinned_word(array.device)
    wp.copy(word, array, 0, index, 1)
    wp.synchronize_stream(array.device.stream)
    return int(word.numpy()[0])


def stage(name: str, timers: dict | None):
    """A synchronizing ``wp.ScopedTimer`` that appends one build stage's milliseconds to ``timers[name]``; a no-op
    (no synchronization) without ``timers``."""
    if timers is None:
        return contextlib.nullcontext()
    return wp.ScopedTimer(name, dict=timers, print=False, synchronize=True)
