"""``displayColor`` and ``displayOpacity`` beyond a mesh's own corners: colour primvars found with USD's inheritance,
the one opacity of prims drawn in one look (gprims, points, curves, tet meshes, patches), and the constant colour
and opacity a native instance hands down to its prototype."""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom

from .color_spaces import linear_colors
from .usd_ancestors import BLOCKED
from .usd_contents import Context
from .usd_primvars import PRIMVAR_DROPPED, finite_colors, first_of_constant, flattened, quaternion_typed, unit_opacities


class LookReading:
    """Colour and opacity reads of the stage reader (``time``, ``materials``, ``_skip``, ``inherited_primvars``: a
    :class:`wrt.usd_ancestors.InheritedPrimvars`)."""

    def _color_primvar(self, prim: Usd.Prim, name: str) -> UsdGeom.Primvar:
        """Colour primvar ``name`` (``displayColor``, ...) of ``prim``: its own when authored, else a constant one of
        its nearest ancestor that has one (USD's primvar inheritance, which usdview follows: a colour set on a group
        colours its meshes)."""
        return self.inherited_primvars.find(prim, name)

    def _one_opacity(self, prim: Usd.Prim, one_per_prim: bool, keep_opaque: bool = False,
                     blocked_opaque: bool = False) -> float | None:
        """The ``displayOpacity`` of ``prim`` (its own or a constant inherited one) for prims drawn with the default
        material in one opacity (gprims, points, curves, tet meshes, NURBS patches): the mean of its values (see
        :func:`wrt.usd_primvars.unit_opacities`), as gprims take the mean displayColor, or None when it has none or
        is opaque (unless ``keep_opaque``; ``blocked_opaque`` as :meth:`_read_opacities`). ``one_per_prim``: values
        that differ are named in a warning (their displayColor is read per element)."""
        primvar = self.inherited_primvars.lookup(prim, "displayOpacity")
        if primvar is BLOCKED and blocked_opaque:  # blocked above: no instance's opacity reaches it either
            return 1.0
        if not (primvar and primvar.HasValue()):
            return None
        values = self._opacity_values(primvar)
        if values is None:
            self._skip("displayOpacity that is not an array of numbers was ignored", prim, str(primvar.GetTypeName()))
            return None
        if not len(values):
            return None
        values = unit_opacities(values, prim, self._skip)
        if one_per_prim and np.ptp(values) > 0.0:
            self._skip(f"{prim.GetTypeName()} prims are drawn in one opacity: the mean of their displayOpacity", prim,
                       primvar.GetInterpolation())
        mean = float(values.mean())
        return mean if mean < 1.0 or keep_opaque else None

    def _opacity_values(self, primvar) -> np.ndarray | None:
        """The flattened values of ``displayOpacity`` primvar ``primvar`` at the reader's time as float64 (maybe
        none; a constant one's first, see :func:`wrt.usd_primvars.first_of_constant`), or None when they are not an
        array of numbers."""
        raw = flattened(primvar, self.time, primvar.GetAttr().GetPrim(), self._skip)
        values = np.asarray(raw if raw is not None else [])
        if values.ndim != 1 or values.dtype.kind not in "fiu":
            return None
        if primvar.GetInterpolation() == UsdGeom.Tokens.constant:  # not the mean of its values: the first
            values = first_of_constant(values, primvar.GetAttr().GetPrim(), primvar.GetAttr().GetName(), self._skip)
        return values.astype(np.float64)

    def _opacity_per_element(self, prim: Usd.Prim):
        """The ``displayOpacity`` primvar of Points or curves ``prim`` when it gives a value per point or curve (an
        interpolation other than ``constant``; ``uniform`` on curves, not on Points, which are one element), else
        None."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayOpacity")  # inherited ones are constant
        if not (primvar and primvar.HasValue()):
            return None
        interpolation = primvar.GetInterpolation()
        one = interpolation == "constant" or (interpolation == "uniform" and prim.IsA(UsdGeom.Points))
        return None if one else primvar

    def _gprim_look(self, prim: Usd.Prim, ctx: Context) -> tuple:
        """``(material_id, primvar, color)`` of gprim ``prim``: its material (-1: the default), bound as a mesh's; the
        colour primvar that material reads (``displayColor`` by default) when ``prim`` has a value of it (its own or
        an inherited constant one), else None; and then the constant colour a native instance hands down, if any
        (``(3,)`` float32), else None (its material's constant, grey by default, or its instance's colour)."""
        material = self._face_materials(prim, 1, ctx)
        color_name = self.materials.color_primvars(material)[0]
        primvar = self._color_primvar(prim, color_name)
        color = None
        if not (primvar and primvar.HasValue()):
            primvar = None
        if primvar is None and self.inherited_primvars.lookup(prim, color_name) is None:  # (not blocked above)
            ctx.content.want_colors([color_name])
            outer = dict(ctx.outer_color or ())
            if color_name in outer:
                color = np.asarray(outer[color_name], np.float32)
        return -1 if material is None else int(material[0]), primvar, color

    def _inheritable_primvars(self, prim: Usd.Prim) -> dict:
        """``{name: primvar}`` of ``UsdGeom.PrimvarsAPI(prim).FindInheritablePrimvars()`` (``prim``'s constant primvars
        and its ancestors', the nearest of each name), the last prim's kept (``_inheritable_kept``): a native instance
        asks for its colours, its opacity and its widths, each a walk of its ancestors."""
        path = prim.GetPath()
        if self._inheritable_kept is None or self._inheritable_kept[0] != path:
            found = {str(p.GetPrimvarName()): p for p in UsdGeom.PrimvarsAPI(prim).FindInheritablePrimvars()}
            self._inheritable_kept = (path, found)
        return self._inheritable_kept[1]

    def _inherited_colors(self, prim: Usd.Prim, names: list[str]) -> tuple:
        """The constant colour primvars that native instance ``prim`` hands down to its prototype's meshes lacking
        them, of ``names``: its own or its nearest ancestor's (up to the root of the prototype ``prim`` is in), as
        ``((name, (r, g, b)), ...)``, each name it has (a prototype's meshes may lack several: displayColor, and
        the primvar a material reads). Checked as a mesh checks the one it inherits outside instances, with its
        warnings naming the prim that holds it: one that is not an array of 3- or 4-vectors, or holds no value, is
        dropped (it was taken when it held three numbers, a ``float[]`` or a single ``color3f``, and skipped without a
        word otherwise), several values are read as the first, non-finite ones as grey 0.5 (both silently before)."""
        inherited = self._inheritable_primvars(prim)
        found = []
        for name in names:
            primvar = inherited.get(name)
            if primvar is None:
                continue
            attr = primvar.GetAttr()
            holder = attr.GetPrim()
            raw = flattened(primvar, self.time, holder, self._skip)
            if raw is None:  # indices out of range: dropped, with a warning
                continue
            values = np.asarray(raw)
            if values.size == 0:
                self._skip(PRIMVAR_DROPPED, holder, f"{attr.GetName()} has 0 values; constant interpolation needs 1")
                continue
            if (values.ndim != 2 or values.shape[1] not in (3, 4) or values.dtype.kind not in "fiu"
                    or quaternion_typed(attr, self.time)):
                self._skip(f"{attr.GetName()} values that are not an array of 3-vectors were ignored", holder,
                           f"{self._authored_type(attr)} holding {type(raw).__name__}")
                continue
            values = first_of_constant(values[:, :3].astype(np.float64), holder, attr.GetName(), self._skip)
            values = finite_colors(linear_colors(values, [attr], holder, self._skip), holder, name, self._skip)
            found.append((name, tuple(float(v) for v in values[0])))
        return tuple(found)

    def _inherited_opacity(self, prim: Usd.Prim) -> float | None:
        """The constant ``displayOpacity`` native instance ``prim`` hands down to its prototype's geometry that has
        none (its own or its nearest ancestor's, as for :meth:`_inherited_colors`; the mean of its values, see
        :func:`wrt.usd_primvars.unit_opacities`), or None."""
        primvar = self._inheritable_primvars(prim).get("displayOpacity")
        if primvar is None:
            return None
        values = self._opacity_values(primvar)
        if values is None or not len(values):
            return None
        return float(unit_opacities(values, prim, self._skip).mean())

