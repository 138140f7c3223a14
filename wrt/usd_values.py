"""Reading a USD attribute at a time code, with wrt's rule for the default time: a value that has only time
samples is read at its first sample, as points and transforms are (``time=None`` in ``load_usd``); and positions
moved by their velocities between samples, as USD moves them."""

from __future__ import annotations

import numpy as np
from pxr import Usd


def value_at(attr: Usd.Attribute, time: Usd.TimeCode):
    """``attr`` at ``time``, or at its earliest time sample when ``time`` is default and it has no authored default
    (a schema fallback, such as visibility's ``inherited`` or a light's intensity, does not count)."""
    return attr.Get(read_time(attr, time))


def read_time(attr: Usd.Attribute, time: Usd.TimeCode) -> Usd.TimeCode:
    """The time code :func:`value_at` reads ``attr`` at: ``time``, or ``EarliestTime`` when ``time`` is default and
    ``attr`` has only time samples. For USD queries that read attributes themselves (a PointInstancer's mask).

    ``EarliestTime`` rather than ``GetTimeSamples()[0]``: the result is the same, and ``GetTimeSamples`` can hang
    usd-core 26.11 on stages with ``timeCodesPerSecond = 0``.
    """
    if (
        time.IsDefault()
        and attr.HasAuthoredValue()
        and attr.GetResolveInfo(time).GetSource() != Usd.ResolveInfoSourceDefault
    ):
        return Usd.TimeCode.EarliestTime()
    return time


def moved_positions(positions: Usd.Attribute, velocities: Usd.Attribute, accelerations: Usd.Attribute,
                    time: Usd.TimeCode, time_codes_per_second: float):
    """Positions (a PointInstancer's ``positions``, a point-based prim's ``points``) at ``time`` moved by their
    ``velocities`` and ``accelerations`` as USD computes them (``UsdGeomPointBased::ComputePointsAtTime``,
    ``UsdGeomPointInstancer::ComputeInstanceTransformsAtTime``): the sample at or before ``time`` plus
    ``v dt + a dt^2 / 2``, ``dt = (time - sample time) / timeCodesPerSecond`` in seconds. Velocities are used only
    when their samples bracket ``time`` at the same times as the positions' and they have one entry per position
    (accelerations likewise against the velocities); otherwise, or at the default time, returns None and the caller
    reads the positions as they are (interpolated between samples).

    Returns:
        ``(N, 3)`` float64 array, or None.
    """
    if time.IsDefault() or not (time_codes_per_second > 0) or not velocities.HasAuthoredValue():
        return None
    t = time.GetValue()
    sample, bracket = _bracket(positions, t)
    if sample is None or _bracket(velocities, t) != (sample, bracket):
        return None
    base = np.asarray(positions.Get(sample), np.float64).reshape(-1, 3)
    velocity = np.asarray(velocities.Get(sample) or [], np.float64).reshape(-1, 3)
    if len(velocity) != len(base):
        return None
    dt = (t - sample) / time_codes_per_second
    moved = base + dt * velocity
    if accelerations.HasAuthoredValue() and _bracket(accelerations, t) == (sample, bracket):
        acceleration = np.asarray(accelerations.Get(sample) or [], np.float64).reshape(-1, 3)
        if len(acceleration) == len(base):
            moved += 0.5 * dt * dt * acceleration
    return moved


def _bracket(attr: Usd.Attribute, t: float):
    """``(sample time at or before t, (lower, upper) samples around t)`` as USD's velocity sampling compares them
    (at a sample, the bracket just after it), or ``(None, None)`` when ``attr`` has no time samples."""
    found = attr.GetBracketingTimeSamples(t)
    if not found or attr.GetNumTimeSamples() == 0:
        return None, None
    lower, upper = found
    if lower == upper:
        found = attr.GetBracketingTimeSamples(t + Usd.TimeCode.SafeStep())
    return lower, tuple(found)
