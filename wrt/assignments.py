"""A count of attribute assignments on the objects a scene is made of (meshes, shapes, prototypes, instances,
materials and their texture inputs), so that :meth:`wrt.Scene.drop_stale_caches`, which runs before every render and
trace, can tell that no field was given a new value without walking every field of every mesh: that walk cost a
kept Renderer 70 ms per render (and per ``launch_frame``) on a scene of 20k meshes, where the frame itself took 2 ms.
"""

_count = 0


class CountsAssignments:
    """Mixin: every attribute assignment (``mesh.points = ...``, also in ``__init__``) adds one to
    :func:`assignments`. In-place edits of arrays are not assignments (see :meth:`wrt.Scene.invalidate`)."""

    def __setattr__(self, name, value):
        global _count
        _count += 1
        super().__setattr__(name, value)


def assignments() -> int:
    """How many attribute assignments :class:`CountsAssignments` objects have had in this process."""
    return _count
