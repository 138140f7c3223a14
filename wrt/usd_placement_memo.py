"""Visibility and transforms read at one time code of a kept stage (:class:`wrt.usd_frames.StageFrames`) and reused at
another, where USD says they cannot differ.

A prim's visibility answer (no prim from it up to a stop invisible, :meth:`wrt.usd_visibility.Visibility._visible`)
is kept where no ``visibility`` on that chain might vary (``UsdAttribute.ValueMightBeTimeVarying``); its transform to
the world or to an ancestor (:class:`wrt.usd_xforms.Xforms`) where no prim from it up to the root might move
(``UsdGeomXformable.TransformMightBeTimeVarying``) and a ``UsdGeom.XformCache`` gave it (a chain resolved op by op,
whose malformed ops are warned about at every read, is read again). Where value clips may reach a prim
(:func:`wrt.usd_clips.under_clips`) both count the clips that give its values, and an instance proxy (a light's or a
camera's, read through its instance) is asked through its prim in the prototype (:func:`wrt.usd_clips.asked_prim`):
USD says a proxy's clip-driven visibility or transform cannot vary. Reads at the default time and at time codes are
kept apart: a value with a default and one time sample does not vary in time, but reads as the default at ``time=None``.

Two answers the prim walk asks of each prim's ancestors hold for every time, and are kept whole: its purpose (a
uniform attribute, read at the default time) and which ancestor's primvar it inherits (decided by which prims author
a value and its interpolation, not by the value): value clips give no uniform value (such as a purpose) and no
metadata (an interpolation), and whether a clip-driven attribute has a value does not depend on the time.
"""

from __future__ import annotations

from pxr import Gf, Sdf, Tf, Usd, UsdGeom

from .usd_ancestors import ComputedPurposes, InheritedPrimvars
from .usd_clips import asked_prim, under_clips


class PlacementMemo:
    """The kept visibility answers and transforms of one kept stage, and USD's answers about which might vary.

    Args:
        clip_roots: the prims with value clips (:func:`wrt.usd_clips.clip_roots`).
    """

    def __init__(self, clip_roots: list = ()):
        self.clip_roots = list(clip_roots)
        self._visibility_varies = {}  # prim path -> its own visibility might vary
        self._moves = {Sdf.Path.absoluteRootPath: False}  # prim path -> its transform or an ancestor's might vary
        self._visible = ({}, {})  # [default time]: (prim path, stop path or None) -> visible, its chain still
        self._transforms = ({}, {})  # [default time]: (prim path, ancestor path or None) -> (Gf.Matrix4d, resets)
        self.counts = {"transforms": 0}  # transforms given again, for tests
        self.purposes = ComputedPurposes()  # the stage reader's computed_purposes at every load
        self.primvars = InheritedPrimvars()  # its inherited_primvars, likewise
        self.stage_has_motion = None  # its layers hold time samples at two times or more (usd_cameras), None: unasked

    def visible(self, time: Usd.TimeCode) -> dict:
        """The kept visibility answers at times of ``time``'s kind: ``(prim path, stop path or None) -> visible``
        (the stage reader adds those whose chain :meth:`visibility_still`)."""
        return self._visible[time.IsDefault()]

    def visibility_still(self, prim: Usd.Prim) -> bool:
        """``prim``'s own ``visibility`` cannot vary."""
        path = prim.GetPath()
        varies = self._visibility_varies.get(path)
        if varies is None:
            img = UsdGeom.Imageable(asked_prim(prim) if under_clips(prim, self.clip_roots) else prim)
            varies = self._visibility_varies[path] = bool(img and img.GetVisibilityAttr().ValueMightBeTimeVarying())
        return not varies

    def transform(self, time: Usd.TimeCode, prim: Usd.Prim, ancestor: Usd.Prim | None):
        """A copy of the kept ``(transform, resets)`` of ``prim`` to ``ancestor``'s space (None: the world's) at times
        of ``time``'s kind, or None."""
        kept = self._transforms[time.IsDefault()].get((prim.GetPath(), ancestor and ancestor.GetPath()))
        if kept is None:
            return None
        self.counts["transforms"] += 1
        return Gf.Matrix4d(kept[0]), kept[1]

    def keep_transform(self, time: Usd.TimeCode, prim: Usd.Prim, ancestor: Usd.Prim | None, m: Gf.Matrix4d,
                       resets: bool) -> None:
        """Keeps ``m``, the ``XformCache``'s transform of ``prim`` to ``ancestor``'s space, where nothing up to the
        root might move."""
        if not self._moves_or_above(prim):
            self._transforms[time.IsDefault()][(prim.GetPath(), ancestor and ancestor.GetPath())] = (Gf.Matrix4d(m),
                                                                                                      resets)

    def _moves_or_above(self, prim: Usd.Prim) -> bool:
        """The transform of ``prim`` or an ancestor might vary (memoised, walked without recursion)."""
        chain = []
        found = self._moves.get(prim.GetPath())
        while found is None:
            chain.append(prim)
            prim = prim.GetParent()
            found = self._moves.get(prim.GetPath())
        for p in reversed(chain):
            found = found or _moves(p, self.clip_roots)
            self._moves[p.GetPath()] = found
        return found


def _moves(prim: Usd.Prim, clip_roots: list) -> bool:
    """``prim``'s own transform might vary (asked of its prim in the prototype where clips may reach an instance
    proxy: its own answer misses them)."""
    if under_clips(prim, clip_roots):
        prim = asked_prim(prim)
    try:
        return prim.IsA(UsdGeom.Xformable) and UsdGeom.Xformable(prim).TransformMightBeTimeVarying()
    except Tf.ErrorException:  # a malformed xformOpOrder: such chains are read op by op, never kept
        return True
