"""Small helpers for the words of wrt's messages."""

import difflib


def counted(n: int, noun: str, plural: str = "") -> str:
    """``n`` and ``noun``, plural unless ``n`` is 1: ``counted(1, "mesh", "meshes")`` is ``1 mesh``,
    ``counted(1070, "triangle")`` is ``1,070 triangles`` (``plural`` defaults to ``noun + "s"``)."""
    return f"{n:,} {noun if n == 1 else plural or noun + 's'}"


def counted_of(n: int, total: int, noun: str, plural: str = "") -> str:
    """``n`` of ``total`` things: ``counted_of(1, 3, "scene")`` is ``1 of 3 scenes``; of a single thing, the count
    alone (``1 scene``, ``0 scenes``), where ``1 of 1 scenes`` read oddly."""
    if total == 1:
        return counted(n, noun, plural)
    return f"{n:,} of {counted(total, noun, plural)}"


def did_you_mean(value, valid) -> str:
    """`` (did you mean 'path'?)`` for the name of ``valid`` closest to a mistyped ``value`` (``"pth"``, ``"Path"``,
    ``"wide_8"``) or the one it is the start of (``"fov"``), or an empty string when none is close; for messages that
    then list every valid name."""
    names = {str(v).lower(): str(v) for v in valid}
    key = str(value).lower()
    close = difflib.get_close_matches(key, list(names), n=1, cutoff=0.6)
    if not close and len(key) >= 3:
        close = [n for n in names if n.startswith(key)][:2]
    return f" (did you mean {names[close[0]]!r}?)" if len(close) == 1 else ""
