"""A count of attribute assignments on the objects a scene is made of (meshes, shapes, prototypes, instances,
materials and their texture inputs), so that :meth:`wrt.Scene.drop_stale_caches`, which runs before every render and
trace, can tell that no field was given a new value without walking every field of every mesh: that walk cost a
kept Renderer 70 ms per render (and per ``launch_frame``) on a scene of 20k meshes, where the frame itself took 2 ms.
"""

import threading

_count = 0
# Held by every counted assignment and by every scene's cache checks, drops and builds (wrt.Scene.lock): a field
# assigned from another thread in the middle of a build (a simulation's instances.to_world = poses each step while a
# render thread draws) was read once for the transforms' inverses and again for the record of what was built, and the
# render drew a TLAS of one pose with the inverses of the other, without a word (a quarter of the traces wrong), and
# kept doing so. One lock for all scenes: an object does not know the scenes it is in.
EDITS = threading.RLock()


class CountsAssignments:
    """Mixin: every attribute assignment (``mesh.points = ...``, also in ``__init__``) adds one to
    :func:`assignments`. In-place edits of arrays are not assignments (see :meth:`wrt.Scene.invalidate`)."""

    def __setattr__(self, name, value):
        # In its constructor, before its checks end (mark_checked): in no scene yet, so no lock. (Keyed on
        # _unchecked, which the first assignment sets, every field after the first waited for a build of any scene
        # in another thread.)
        if not self.__dict__.get("_made", False):
            self._assign(name, value)
            return
        with EDITS:  # not in the middle of a build in another thread
            self._assign(name, value)

    def _assign(self, name, value) -> None:
        global _count
        _count += 1
        super().__setattr__(name, value)
        # A field assigned after construction is checked as the constructor checks it before the next trace or
        # render (check_assigned): mesh.material_ids = ids[:-1] shifted the materials of every later mesh, and
        # material.diffuse_color = (nan, 0, 0) rendered black, each without a word.
        object.__setattr__(self, "_unchecked", True)


def mark_checked(obj) -> None:
    """Records that ``obj`` passed its checks (the end of its constructor's): :func:`check_assigned` skips it until a
    field is assigned again, and its fields are assigned under :data:`EDITS` from now on."""
    object.__setattr__(obj, "_unchecked", False)
    object.__setattr__(obj, "_made", True)


def mark_unchecked(obj) -> None:
    """Makes :func:`check_assigned` check ``obj`` again, as if a field had been assigned (its arrays may have been
    edited in place: ``Scene.invalidate``)."""
    object.__setattr__(obj, "_unchecked", True)


def check_assigned(objects) -> None:
    """Runs the constructor's checks again (``check()``, else ``__post_init__``) for each of ``objects`` that had a
    field assigned since it was last checked; they raise naming the object and field, and may convert the values
    (an array to its dtype) as the constructor does."""
    for obj in objects:
        if obj.__dict__.get("_unchecked", False):
            check = getattr(obj, "check", None) or obj.__post_init__
            check()
            mark_checked(obj)


def assignments() -> int:
    """How many attribute assignments :class:`CountsAssignments` objects have had in this process."""
    return _count
