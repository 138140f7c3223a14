"""Reading a USD attribute at a time code, with wrt's rule for the default time: a value that has only time
samples is read at its first sample, as points and transforms are (``time=None`` in ``load_usd``)."""

from __future__ import annotations

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
