"""Small helpers for the words of wrt's messages."""


def counted(n: int, noun: str, plural: str = "") -> str:
    """``n`` and ``noun``, plural unless ``n`` is 1: ``counted(1, "mesh", "meshes")`` is ``1 mesh``,
    ``counted(1070, "triangle")`` is ``1,070 triangles`` (``plural`` defaults to ``noun + "s"``)."""
    return f"{n:,} {noun if n == 1 else plural or noun + 's'}"
