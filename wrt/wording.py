"""Small helpers for the words of wrt's messages."""


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
