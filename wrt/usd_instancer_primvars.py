"""Primvars authored on a ``UsdGeom.PointInstancer``, applied to its instances as UsdGeomPointInstancer's primvar
rules have them: ``constant`` or ``uniform``, the whole value to each instance; ``vertex``, ``varying`` or
``faceVarying``, one element per instance; each instance's value is a constant primvar at the root of its
prototype. ``displayColor`` (or the colour primvar the prototypes' materials read) and ``displayOpacity`` are read
per instance at shading time; texture coordinates (``st``) and ``widths`` make a copy of the prototype per distinct
value."""

from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdGeom

from .color_spaces import linear_colors
from .unique import unique_rows
from .usd_contents import Context
from .usd_primvars import (
    CONSTANT_OF_SEVERAL,
    finite_colors,
    first_of_constant,
    indices_type_problem,
    one_value_as_array,
    past_float32_as_inf,
    quaternion_typed,
    unit_opacities,
)
from .usd_values import value_at

MAX_INSTANCE_UVS = 64  # distinct st a PointInstancer gives the instances of one prototype (a copy of it each)
MAX_INSTANCE_WIDTHS = 64  # distinct primvars:widths a PointInstancer gives the instances of one prototype, likewise


class InstancerPrimvarReading:
    """PointInstancer primvar reading of the stage reader (``time``, ``_skip``)."""

    @staticmethod
    def _constant_primvar(prim: Usd.Prim, name: str) -> bool:
        """PointInstancer ``prim`` has primvar ``name``, of constant interpolation (an inherited primvar, which
        Hydra does not make an instance primvar)."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
        return bool(primvar) and primvar.HasValue() and primvar.GetInterpolation() == UsdGeom.Tokens.constant

    def _instance_color_name(self, prim: Usd.Prim, wanted: list[str]) -> str | None:
        """The colour primvar of PointInstancer ``prim`` that colours its instances of a prototype whose geometry
        lacks the primvars ``wanted`` (``displayColor`` when it lacks none): the first of them it has, or None. An
        instance has one colour: where it has several of them, the others are ignored with a warning."""
        api = UsdGeom.PrimvarsAPI(prim)
        found = [name for name in wanted or ["displayColor"] if api.GetPrimvar(name).HasValue()]
        if len(found) > 1:
            self._skip("PointInstancers give one colour per instance: primvars past the first that their prototypes' "
                       "materials read were ignored", prim, ", ".join(found[1:]))
        return found[0] if found else None

    def _instance_colors(self, prim: Usd.Prim, n: int, name: str) -> np.ndarray | None:
        """``(n, 3)`` float32 colour of each of the ``n`` instances of PointInstancer ``prim``, from its colour
        primvar ``name`` (``displayColor``, or the one its prototypes' materials read; the rgb of a 4-vector one)
        (see :meth:`_instance_values`)."""
        values = self._instance_values(prim, n, name, (3, 4))
        if values is None:
            return None
        values = linear_colors(values[:, :3], [UsdGeom.PrimvarsAPI(prim).GetPrimvar(name).GetAttr()], prim, self._skip)
        # NaN here would mean "no colour" (Instances.colors) and inf would shade as inf.
        return np.broadcast_to(finite_colors(values.astype(np.float32), prim, name, self._skip), (n, 3))

    def _instance_uv_groups(self, prim: Usd.Prim, n: int, wanted: list[str], beneath: bool, rows: np.ndarray,
                            ctx: Context, uvs_by_name: dict) -> list[tuple]:
        """``[(outer_uv, rows), ...]``: the instances ``rows`` of one prototype of PointInstancer ``prim`` by the
        texture coordinates handed to its meshes that lack the primvars ``wanted``: the instancer's st of each
        (:meth:`_instance_uvs`, kept in ``uvs_by_name``) over what ``ctx.outer_uv`` hands down for the others. Storm
        reads such an instance primvar in the material's primvar reader (``HdGet_st()`` where the mesh has none): one
        palette texel per instance. Each distinct st is a copy of the prototype, so past :data:`MAX_INSTANCE_UVS` of
        them all read the reader's fallback, with a warning."""
        for name in wanted:
            if name not in uvs_by_name:
                uvs_by_name[name] = self._instance_uvs(prim, n, name, beneath)
        names = [name for name in wanted if uvs_by_name[name] is not None]
        if not names:
            return [(ctx.outer_uv, rows)]
        st = np.concatenate([uvs_by_name[name][rows] for name in names], axis=1)
        st[~np.isfinite(st)] = np.inf  # none (named in a warning): one value, so that the NaNs key one group
        distinct, group = unique_rows(st)  # (np.unique(axis=0) took 1.4 s for 1M instances)
        if len(distinct) > MAX_INSTANCE_UVS:
            self._skip(f"PointInstancer texture coordinates of more than {MAX_INSTANCE_UVS} distinct values per "
                       "prototype were ignored (each is a copy of the prototype): the textures there show their "
                       "fallback", prim, f"{', '.join(names)}: {len(distinct)} distinct st for {len(rows)} instances")
            return [(tuple(entry for entry in ctx.outer_uv or () if entry[0] not in names) or None, rows)]
        groups = []
        for k, values in enumerate(distinct):
            outer = dict(ctx.outer_uv or ())
            for j, name in enumerate(names):
                outer.pop(name, None)  # the instancer's st is nearer than one handed down from above
                if np.isfinite(values[2 * j:2 * j + 2]).all():
                    outer[name] = (float(values[2 * j]), float(values[2 * j + 1]))
            groups.append((tuple(sorted(outer.items())) or None, rows[group.reshape(-1) == k]))
        return groups

    def _instance_uvs(self, prim: Usd.Prim, n: int, name: str, beneath: bool) -> np.ndarray | None:
        """``(n, 2)`` float64 st of each of the ``n`` instances of PointInstancer ``prim`` from its texture-coordinate
        primvar ``name`` (the first two components; NaN where not finite in float32, with a warning), or None without
        a usable one (see :meth:`_instance_values`). A constant one reaches the prototypes beneath the instancer by
        inheritance instead, read with their geometry, as a constant colour does."""
        if beneath and self._constant_primvar(prim, name):  # the prototypes inherit it instead
            return None
        if not UsdGeom.PrimvarsAPI(prim).GetPrimvar(name).HasValue():
            return None
        values = self._instance_values(prim, n, name, (2, 3, 4))
        if values is None:
            return None
        # A double past float32 is none too: handed down as it was, the mesh's float32 st held inf there.
        values = np.array(np.broadcast_to(past_float32_as_inf(values[:, :2]), (n, 2)))
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():
            self._skip("PointInstancer texture coordinates that are not finite were read as none: the textures there "
                       "show their fallback", prim, f"{name}, {int(bad.sum())} of {n} instances")
            values[bad] = np.nan
        return values

    def _instance_widths(self, prim: Usd.Prim, n: int, beneath: bool) -> np.ndarray | None:
        """``(n,)`` float64 ``primvars:widths`` of each of the ``n`` instances of PointInstancer ``prim`` (see
        :meth:`_instance_values`), or None without a usable one. As UsdGeomPointInstancer's primvar rules have it,
        each instance's is a constant widths at the root of its prototype, sizing its points and curves that have no
        widths primvar of their own; a constant one reaches the prototypes beneath the instancer by inheritance
        instead, read with their geometry. Only that one was read: the others were dropped without a word."""
        if beneath and self._constant_primvar(prim, "widths"):  # the prototypes inherit it instead
            return None
        if not UsdGeom.PrimvarsAPI(prim).GetPrimvar("widths").HasValue():
            return None
        values = self._instance_values(prim, n, "widths", (1,))
        return None if values is None else np.broadcast_to(values[:, 0], (n,))

    def _instance_width_groups(self, prim: Usd.Prim, widths, rows: np.ndarray, ctx: Context) -> list[tuple]:
        """``[(outer_widths, rows), ...]``: the instances ``rows`` of one prototype of PointInstancer ``prim`` by the
        width (``widths``, from :meth:`_instance_widths`, or None: ``ctx.outer_widths`` for all) handed to its points
        and curves without widths, each distinct one a copy of the prototype: past :data:`MAX_INSTANCE_WIDTHS` of
        them they keep ``ctx.outer_widths``, with a warning."""
        if widths is None:
            return [(ctx.outer_widths, rows)]
        distinct, group = np.unique(widths[rows], return_inverse=True)  # (NaNs as one: drawn as none, named)
        if len(distinct) > MAX_INSTANCE_WIDTHS:
            self._skip(f"PointInstancer widths of more than {MAX_INSTANCE_WIDTHS} distinct values per prototype were "
                       "ignored (each is a copy of the prototype)", prim,
                       f"{len(distinct)} distinct widths for {len(rows)} instances")
            return [(ctx.outer_widths, rows)]
        # One NaN object, so that the content read with it is found again (NaN != NaN).
        return [(math.nan if math.isnan(w) else float(w), rows[group.reshape(-1) == k]) for k, w in enumerate(distinct)]

    def _instance_opacities(self, prim: Usd.Prim, n: int) -> np.ndarray | None:
        """``(n,)`` float32 ``displayOpacity`` of each of the ``n`` instances of PointInstancer ``prim`` (see
        :meth:`_instance_values`; NaN read as 1 and values clamped to [0, 1], as on meshes), or None without one."""
        if not UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayOpacity").HasValue():
            return None
        values = self._instance_values(prim, n, "displayOpacity", (1,))
        if values is None:
            return None
        return np.broadcast_to(unit_opacities(values.reshape(-1), prim, self._skip).astype(np.float32), (n,))

    def _instance_values(self, prim: Usd.Prim, n: int, name: str, widths: tuple) -> np.ndarray | None:
        """``(1 or n, k)`` float64 values of PointInstancer ``prim``'s primvar ``name``, ``k`` one of ``widths`` (an
        array of numbers has ``k = 1``): ``constant`` or ``uniform`` gives one value to all, ``vertex``, ``varying`` or
        ``faceVarying`` one element (``elementSize`` values) per instance (after its ``indices``, which pick whole
        elements), read at the reader's time as ``ComputeFlattened`` reads it (:func:`value_at`: interpolated between
        samples), also where velocities move the instances: USD holds positions, orientations, scales and protoIndices
        at their earlier sample then (``ComputeInstanceTransformsAtTime``), not primvars, and meshes moved by
        velocities read theirs so too (a colour sampled red at 0 and green at 10 was red at 5, not USD's (0.5, 0.5, 0)).
        Of several values for one instance the first, with a warning. None, with a warning naming it and what was
        expected, when it cannot be used: another type, interpolation, or a length other than ``n``."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
        # (a constant one holding one value rather than an array is that value, as on a gprim: it was unreadable)
        raw = one_value_as_array(value_at(primvar.GetAttr(), self.time), primvar.GetAttr(), primvar.GetInterpolation())
        unreadable = f"PointInstancer {name} that cannot be read was ignored"
        try:
            values = np.asarray(raw if raw is not None else [], np.float64)
        except (TypeError, ValueError):  # no numbers (strings, tokens, asset paths): it stopped the load
            self._skip(unreadable, prim, f"{primvar.GetTypeName()} holding {type(raw).__name__}")
            return None
        if values.ndim == 1:  # an array of numbers
            values = values[:, None]
        size = primvar.GetElementSize()
        if (values.ndim != 2 or values.shape[1] not in widths or size < 1 or len(values) % size
                or quaternion_typed(primvar.GetAttr(), self.time)):
            self._skip(unreadable, prim, f"{primvar.GetTypeName()} of elementSize {size} holding {len(values)} values")
            return None
        if (wrong_type := indices_type_problem(primvar)) is not None:
            self._skip(unreadable, prim, wrong_type)
            return None
        elements = values.reshape(-1, size, values.shape[1])  # an element: the elementSize values one index picks
        if primvar.IsIndexed():  # flattened as ComputeFlattened does, at the same time as the values
            raw = value_at(primvar.GetIndicesAttr(), self.time)
            indices = np.asarray(raw if raw is not None else [], np.int64).reshape(-1)
            if np.any((indices < 0) | (indices >= len(elements))):
                self._skip(unreadable, prim, f"indices out of range for {len(elements)} elements")
                return None
            elements = elements[indices]
        values = elements.reshape(-1, values.shape[1])
        interpolation = primvar.GetInterpolation()
        # UsdGeomPointInstancer's primvar rules: constant or uniform, the whole value applies to each instance (Hydra's
        # instancer data source makes both constant; uniform was ignored with a warning); vertex, varying and
        # faceVarying, one value per instance (Hydra makes them instance primvars; faceVarying was ignored too).
        per_instance = (n, "one per instance")
        expected = {"constant": (1, "1"), "uniform": (1, "1, for all instances"), "vertex": per_instance,
                    "varying": per_instance, "faceVarying": per_instance}
        if interpolation not in expected:
            self._skip(f"PointInstancer {name} of an interpolation other than constant, uniform, vertex, varying or "
                       "faceVarying was ignored", prim, interpolation)
            return None
        if interpolation in ("constant", "uniform") and len(values) > 1:
            # The whole value applies to each instance, which a prototype's gprim reads as a constant primvar of
            # several values: its first, with a warning, as UsdImaging reads it (and as it read the instancer's
            # constant one inherited beneath it). Where the prototypes lay elsewhere it was ignored.
            values = first_of_constant(values, prim, str(primvar.GetAttr().GetName()), self._skip)
        elif interpolation in expected and size > 1:
            # Each instance's element (its elementSize values) is its constant value there, read likewise: the first
            # of each. An elementSize other than 1 was ignored with a warning.
            self._skip(CONSTANT_OF_SEVERAL, prim, f"{primvar.GetAttr().GetName()} of elementSize {size}")
            values = elements[:, 0]
        if len(values) != expected[interpolation][0]:
            count, meaning = expected[interpolation]
            self._skip(f"PointInstancer {name} of the wrong length was ignored", prim,
                       f"{interpolation} with {len(values)} values, expected {count} ({meaning})")
            return None
        return values
