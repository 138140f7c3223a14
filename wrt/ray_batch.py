"""Ray batches as :func:`wrt.trace` and :func:`wrt.occluded` take them: checked and put on the tracing device.

Origins and directions may be anything numpy converts (lists, float64 or integer arrays, non-contiguous views,
objects with ``__array__``), ``wp.array``s on any device (``vec3`` or ``(N, 3)`` floats), or GPU tensors that numpy
refuses but DLPack hands over (``torch`` on CUDA, CuPy). A ``wp.array`` of ``vec3`` already on the tracing device
is traced in place; anything else is copied. One ray may be a ``(3,)`` vector, and a single origin (or direction)
serves every ray of the other argument, as numpy broadcasts.

Hits have ``t_min <= t < t_max`` for the limits as given: they are rounded up to float32 (no float32 ``t`` lies
between a limit and its rounded-up value), and for wrt's kernels, which trace each ray scaled to a unit-ish
direction (``traverse.unit_ray``), rounded up once more where that scaling takes them below float32's normal range
(:func:`round_limits_for_unit_rays_kernel`).
"""

from __future__ import annotations

import decimal
import numbers

import numpy as np
import warp as wp

from .floats import unit_scales

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile

SMALLEST_NORMAL = wp.constant(wp.float64(2.0**-126))  # float32's smallest normal; below it floats step by 2^-149
SUBNORMAL_STEP = wp.constant(wp.float64(2.0**-149))  # float32's smallest subnormal, the step of every float below it
SUBNORMAL_STEPS = wp.constant(wp.float64(2.0**149))  # 1 / SUBNORMAL_STEP


@wp.func
def unit_ray_limit(limit: float, down: float, up: float):
    """``limit``, or the smallest float32 above it whose product with ``up`` is exact, for a ray that a kernel
    scales by ``(down, up)`` (``floats.unit_scales`` of its direction): ``traverse.unit_ray`` takes ``limit * up``
    as the limit of the scaled ray, and below float32's normal range that product rounds, to 0 at the end (along a
    direction of length 1e-30 a ``t_min`` of 1e-20 became 0, and an origin on a surface hit it at ``t = 0``). The
    scaled ray's ``t`` are float32, multiples of 2^-149 there, so rounding ``limit * up`` up to the next multiple
    keeps every comparison (``t >= t_min``, ``t < t_max``) as it is with ``limit`` itself, and ``t * down`` (the
    reported ``t``) is exact."""
    scaled = wp.float64(limit) * wp.float64(up)  # exact: two 24-bit significands
    if scaled == wp.float64(0.0) or not (wp.abs(scaled) < SMALLEST_NORMAL):  # also inf: exact, or none to round
        return limit
    return wp.float32(wp.ceil(scaled * SUBNORMAL_STEPS) * SUBNORMAL_STEP * wp.float64(down))  # exact: a float32


@wp.kernel
def round_limits_for_unit_rays_kernel(
    directions: wp.array[wp.vec3],
    # outputs (read and written in place)
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
):
    """Each ray's limits through :func:`unit_ray_limit`, with the scales its direction gets in the trace kernels."""
    i = wp.tid()
    down, up = unit_scales(directions[i])
    t_mins[i] = unit_ray_limit(t_mins[i], down, up)
    t_maxs[i] = unit_ray_limit(t_maxs[i], down, up)


def host_array(name: str, values):
    """``values`` as something numpy converts without a device copy failing: ``wp.array``s on a GPU (which refuse
    implicit conversion) are copied to the host, and GPU tensors are read through DLPack."""
    if isinstance(values, wp.array):
        return values.numpy()
    if isinstance(values, (np.ndarray, list, tuple, int, float)) or not hasattr(values, "__dlpack__"):
        return values
    try:
        np.asarray(values)
        return values
    except (TypeError, ValueError, RuntimeError):  # torch: TypeError "can't convert cuda:0 device type tensor"
        pass
    try:
        return wp.from_dlpack(values).numpy()
    except Exception as e:  # noqa: BLE001 - any failure of a foreign object is reported as unreadable input
        raise ValueError(f"{name}: cannot read a {type(values).__name__} ({e})") from None


def as_float32(name: str, values, vectors: bool = False, round_up: bool = False) -> np.ndarray:
    """``values`` as a float32 numpy array, or ``ValueError`` naming ``name``: complex numbers were cast with only a
    warning (the imaginary part dropped), bools, dates and durations as 0/1 and counts without one, and text or
    ragged lists failed with numpy's message alone. Integers convert.

    With ``vectors`` (origins, directions: ``(N, 3)``), finite values that float32 cannot hold raise too: a value
    beyond its range became inf, and a non-zero direction below it ``(0, 0, 0)``, so the ray missed without a word.
    Limits convert as they are: a ``t_max`` of 1e39 as inf means the same (no float32 ``t`` reaches either).

    With ``round_up`` (limits), values are rounded toward +inf, not to the nearest float32: a float32 ``t`` then
    compares with the result (``t >= t_min``, ``t < t_max``) as with the value given. To the nearest, ``t_min = 1 +
    1e-12`` became 1 and kept a hit at ``t = 1``, and ``t_min = 1e-50`` became 0 and kept hits at ``t = 0``."""
    raw = host_array(name, values)
    try:
        raw = raw if isinstance(raw, np.ndarray) else np.asarray(raw)
        if raw.dtype.kind == "O":  # Python objects (ints beyond int64, None, text): checked one by one
            raw = _real_objects(raw, none_is_nan=not vectors)  # limits refuse NaN, saying what None should be
        if raw.dtype.kind not in "fiu":  # bool (0 and 1), complex, text, dates and durations (their counts), void
            raise TypeError(f"got dtype {raw.dtype}")
        with np.errstate(over="ignore"):  # overflow is reported below (vectors) or harmless (limits)
            array = np.asarray(raw, dtype=np.float32)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must hold real numbers ({e})") from None
    if vectors and raw.dtype.kind == "f" and raw.dtype.itemsize > 4 and raw.shape[-1:] == (3,) and raw.ndim <= 2:
        check_float32_range(name, raw.reshape(-1, 3), array.reshape(-1, 3))  # a (3,) vector is one row
    if round_up and raw.dtype.itemsize > 2:  # wider than float16 and int16: values float32 may not hold
        # Compared at raw's precision (float32 promotes exactly); NaN compares False and stays NaN. The step above
        # float32's largest value is inf, with numpy's "overflow encountered in nextafter" RuntimeWarning: a t_max of
        # np.finfo(np.float32).max (or -max for t_min) said it at every trace, though that value is kept as it is.
        with np.errstate(over="ignore"):
            array = np.where(array < raw, np.nextafter(array, np.float32(np.inf)), array)
    return array


def _real_objects(raw: np.ndarray, none_is_nan: bool) -> np.ndarray:
    """An object array as float64, or ``TypeError`` naming the first element that is not a real number (None is
    NaN with ``none_is_nan``): numpy converts None to NaN (a ray that misses without a word), ``"1"`` to 1 and True
    to 1."""
    for index, value in np.ndenumerate(raw):
        if value is None and none_is_nan:
            continue
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, decimal.Decimal)):
            what = "None" if value is None else f"{type(value).__name__} {value!r}"
            raise TypeError(f"got {what} at index {index}")
    try:
        return raw.astype(np.float64)
    except OverflowError:  # an int beyond float64's range (1e308)
        raise ValueError("got a number beyond float64's range") from None


def check_float32_range(name: str, raw: np.ndarray, array: np.ndarray) -> None:
    """Raises ``ValueError`` naming ``name`` and the first row where the float32 ``array`` lost a finite vector of
    ``raw``: a component beyond float32's range, or a non-zero direction that rounds to ``(0, 0, 0)`` (an origin
    of 1e-50 is only rounded to 0: where it lies is kept to float32's precision)."""
    overflow = (np.isinf(array) & np.isfinite(raw)).any(axis=1)
    vanished = ~array.any(axis=1) & (raw != 0).any(axis=1) & np.isfinite(raw).all(axis=1) & (name == "directions")
    bad = np.flatnonzero(overflow | vanished)
    if len(bad):
        i = int(bad[0])
        what = "beyond float32's range (|x| > 3.4e38)" if overflow[i] else "not zero, but (0, 0, 0) in float32"
        hint = "; only a direction's orientation matters (t is in units of its length): scale it" if (
            name == "directions") else ""
        raise ValueError(f"{name} row {i}, {raw[i].tolist()}, is {what}, and rays are traced in float32{hint}")


def _on_device(values, device) -> wp.array | None:
    """``values`` itself when it is a ``vec3`` (or ``(N, 3)`` float32) ``wp.array`` that kernels on ``device`` can
    read as it is, else None."""
    if not (isinstance(values, wp.array) and values.device == device and values.is_contiguous):
        return None
    if values.ndim == 1 and values.dtype == wp.vec3:
        return values
    if values.ndim == 2 and values.dtype == wp.float32 and values.shape[1] == 3:
        return values.view(wp.vec3)
    return None


def _vectors(name: str, values, device) -> wp.array | np.ndarray:
    """Rays of one argument: a device array to trace in place, or ``(N, 3)`` float32 numpy (a ``(3,)`` vector is
    one ray; an empty list none)."""
    in_place = _on_device(values, device)
    if in_place is not None:
        return in_place
    array = as_float32(name, values, vectors=True)
    if array.ndim == 1 and array.size in (0, 3):
        array = array.reshape(-1, 3)
    return array


def _numpy(rays) -> np.ndarray:
    return rays.numpy() if isinstance(rays, wp.array) else rays


def _shape(rays) -> tuple:
    return (len(rays), 3) if isinstance(rays, wp.array) else rays.shape


def _is_none_at(values, row: int) -> bool:
    """Whether the per-ray limit ``row`` of ``values`` as given (a list, an object array) is None."""
    if not isinstance(values, (list, tuple, np.ndarray)) or (isinstance(values, np.ndarray) and values.dtype != object):
        return False
    flat = np.asarray(values, dtype=object).reshape(-1)
    return row < len(flat) and flat[row] is None


def _limits(name: str, values, default: float, n: int) -> np.ndarray:
    """``t_min`` or ``t_max``: a scalar or one value per ray, never NaN; ``None`` is the default.

    Shapes are those numpy broadcasts against the rays' ``(N, 3)`` as one value per ray: ``(N,)`` and ``(N, 1)``
    (``origins + t[:, None] * directions`` is how a numpy user writes a point at ``t``), and ``()``, ``(1,)``,
    ``(1, 1)`` for one value for every ray. ``(1, 3)``, which numpy would also broadcast, would be three values per
    ray: refused."""
    limits = as_float32(name, default if values is None else values, round_up=True)
    given = limits.shape
    if limits.ndim == 2 and limits.shape[1] == 1:  # a column: one value per row
        limits = limits[:, 0]
    if limits.shape == (1,) and n != 1:  # one value for every ray, as a scalar (a NaN then names no ray)
        limits = limits[0]
    if limits.shape not in ((), (n,)):
        raise ValueError(f"{name} must be a scalar or one value per ray: shape (), (1,), (1, 1), ({n},) or ({n}, 1); "
                         f"got shape {given}")
    nan = np.flatnonzero(np.isnan(limits))
    if len(nan):  # every ray would miss without a word (a list [None] converts to NaN)
        row = int(nan[0]) if limits.ndim else 0
        if _is_none_at(values, row):  # it said "must not be NaN; use inf (or None) for no limit" of [None, 4]
            raise ValueError(f"{name}[{row}] is None: one value per ray takes numbers only (None stands for the "
                             f"whole argument, the default); give {'inf for no limit' if default > 0 else '0'} there")
        where = f" (ray {nan[0]} is the first of {len(nan)})" if limits.ndim else ""
        raise ValueError(f"{name} must not be NaN{where}" + ("; use inf (or None) for no limit" if default > 0 else ""))
    return np.broadcast_to(limits, (n,)).copy()


def upload_rays(origins, directions, t_min, t_max, device, unit_rays: bool = False) -> list:
    """Checks a ray batch and puts it on ``device``: ``[origins, directions, t_mins, t_maxs]`` as device arrays;
    with ``unit_rays`` (kernels that trace through ``traverse.unit_ray``: wrt's own) the limits are rounded for them
    (:func:`unit_ray_limit`).

    Raises:
        ValueError: naming the argument that is not ``(N, 3)`` (or ``(3,)``) real numbers, a ``t_min``/``t_max`` of
            another length or NaN, or origins and directions of different lengths (other than one of them
            holding one ray).
    """
    o = _vectors("origins", origins, device)
    d = _vectors("directions", directions, device)
    (no, co), (nd, cd) = (_shape(r) if len(_shape(r)) == 2 else (None, None) for r in (o, d))
    if co != 3 or cd != 3 or (no != nd and 1 not in (no, nd)):
        same = " with the same N (or one ray)" if co == cd == 3 else ""
        # An (H, W, 3) grid of camera rays is a common input: say how to pass it (and to reshape the hits back).
        grid = any(len(_shape(r)) > 2 and _shape(r)[-1] == 3 for r in (o, d))
        hint = "; pass a grid of rays as grid.reshape(-1, 3) (and reshape the results to its shape)" if grid else ""
        raise ValueError(f"origins and directions must both be (N, 3) arrays{same}, got {_shape(o)} and {_shape(d)}"
                         + hint)
    n = nd if no == 1 else no  # one ray against many (or none), as numpy broadcasts (1, 3) with (0, 3) to (0, 3)
    if no != nd:
        o, d = (np.broadcast_to(_numpy(r), (n, 3)) if len(r) == 1 else r for r in (o, d))
    t_mins, t_maxs = _limits("t_min", t_min, 0.0, n), _limits("t_max", t_max, np.inf, n)
    rays = [
        r if isinstance(r, wp.array) else wp.array(np.ascontiguousarray(r), dtype=wp.vec3, device=device)
        for r in (o, d)
    ] + [wp.array(t, dtype=float, device=device) for t in (t_mins, t_maxs)]
    # Only a limit below 1 in magnitude can scale below float32's normal range (directions scale it by 2^-126 at
    # the least); the usual 0 and inf need no launch.
    if unit_rays and any(((np.abs(t) < 1) & (t != 0)).any() for t in (t_mins, t_maxs)):
        wp.launch(round_limits_for_unit_rays_kernel, n, inputs=[rays[1]], outputs=rays[2:], device=device)
    return rays
