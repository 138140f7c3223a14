"""Checked reads of a prim's geometric attributes at the stage reader's time: ``int[]`` topology arrays, point
arrays moved by their velocities, and ``orientation``; a value of the wrong type is an error or a warning naming the
prim."""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom, Vt

from .usd_values import moved_positions, schema_type_authored, schema_typed_value, value_at


class AttributeReading:
    """Typed attribute reads of the stage reader (``stage``, ``time``, ``_skip``, ``_error``)."""

    def _moved(self, schema, positions: Usd.Attribute):
        """``positions`` (``points`` or a PointInstancer's ``positions``) of ``schema`` moved by its velocities and
        accelerations at this time (see :func:`wrt.usd_values.moved_positions`), or None to read them as they are."""
        velocities, accelerations = schema.GetVelocitiesAttr(), schema.GetAccelerationsAttr()
        wrong_lengths = []
        moved = moved_positions(positions, velocities, accelerations, self.time, self.stage.GetTimeCodesPerSecond(),
                                wrong_lengths)
        self._skip_wrong_rates(schema.GetPrim(), wrong_lengths)
        return moved

    def _skip_wrong_rates(self, prim: Usd.Prim, wrong_lengths: list[str]):
        """Warns about velocities, accelerations or angularVelocities that were ignored for their length."""
        for detail in wrong_lengths:
            self._skip("velocities, accelerations or angularVelocities whose length is not that of what they move "
                       "were ignored, as USD ignores them", prim, detail)

    def _int_array(self, prim: Usd.Prim, attr: Usd.Attribute) -> np.ndarray:
        """``(N,)`` int64 value of an ``int[]`` topology attribute at the read time (empty when it has none).

        Raises:
            SceneError: the value authored is not ``int[]`` (``float[]`` would be truncated and ``string[] ["3"]``
                parsed by numpy without a word; ``int64[]`` and ``uint[]``, which numpy took as integers, are no
                faces to USD, whose typed read gets no value from them: ``GetFaceCount`` 0, usdview draws nothing).
        """
        value = value_at(attr, self.time)
        if value is not None and not isinstance(value, Vt.IntArray) and schema_type_authored(attr, self.time):
            # Read as USD's typed read reads it, with a warning naming the value passed over: an int64[] over an
            # int[] is passed over for the int[] at the default time (GetFaceCount counts its faces; a weaker
            # holeIndices = [] hides none) and for the schema's fallback at a time, where the read fails on it
            # (GetFaceCount(1) is 0: a mesh of no faces). With no int[] authored at all it is refused below.
            value = self._typed(prim, attr)
        if value is None:
            return np.zeros(0, np.int64)
        array = np.asarray(value)
        if array.ndim != 1 or array.dtype.kind not in "iu" or not isinstance(value, Vt.IntArray):
            raise self._error(f"{attr.GetName()} must be int[], not {self._authored_type(attr)}", prim, attr)
        return array.astype(np.int64)

    def _typed(self, prim: Usd.Prim, attr: Usd.Attribute, time: Usd.TimeCode | None = None):
        """``attr`` of ``prim`` as USD's typed readers read it (:func:`wrt.usd_values.schema_typed_value`), with a
        warning naming a value authored with another type than the schema's: a ``string orientation =
        "leftHanded"`` is rightHanded to USD and Hydra, an ``int doubleSided = 1`` single-sided, a ``float radius =
        3`` sphere of radius 1; wrt read the text and the number."""
        value, wrong = schema_typed_value(attr, self.time if time is None else time)
        if wrong is not None:
            self._skip("values authored with another type than the schema's were read as USD's typed readers read "
                       "them (a weaker opinion of the schema's type, else the schema's fallback)", prim, wrong)
        return value

    def _typed_points(self, prim: Usd.Prim, attr: Usd.Attribute, read) -> bool:
        """Whether ``points`` ``attr`` of ``prim`` (``read``: the value read from it, not None) is authored as the
        schema's ``point3f[]`` (or ``float3[]``, the same type); else a warning naming the type: USD reads no points
        from a ``point3d[]`` or ``half3[]`` one (``ComputePointsAtTime``: "no positions"; ``BBoxCache``: an empty
        box; usdview draws nothing), which wrt drew."""
        _, wrong = schema_typed_value(attr, self.time, read)
        if wrong is not None:
            self._skip("prims whose points are authored with another type than the schema's point3f[] were "
                       "skipped, as USD reads no points from them", prim, wrong)
        return wrong is None

    def _point_array(self, prim: Usd.Prim) -> np.ndarray | None:
        """``(n, 3)`` float64 ``points`` of a point-based prim (moved by its velocities where they apply), ``(0, 3)``
        when it has none, or None (with a warning) when they are not an array of 3-vectors or not ``point3f[]``."""
        schema = UsdGeom.PointBased(prim)
        raw = self._moved(schema, schema.GetPointsAttr())
        if raw is None:
            raw = value_at(schema.GetPointsAttr(), self.time)
        points = np.asarray(raw if raw is not None else np.zeros((0, 3)))
        if points.size == 0:
            return np.zeros((0, 3))
        if points.ndim != 2 or points.shape[1] != 3 or points.dtype.kind != "f":
            self._skip(f"{prim.GetTypeName()} prims whose points are not an array of 3-vectors were skipped", prim,
                       f"{self._authored_type(schema.GetPointsAttr())} holding {type(raw).__name__}")
            return None
        if not self._typed_points(prim, schema.GetPointsAttr(), raw):
            return None
        return points.astype(np.float64)

    def _left_handed(self, prim: Usd.Prim, gprim: UsdGeom.Gprim, t: Usd.TimeCode) -> bool:
        """Whether ``orientation`` is leftHanded. Any other token is read as USD's fallback, rightHanded, and named
        in a warning: USD does not check allowed tokens, so a misspelt leftHanded would flip every face unseen."""
        value = self._typed(prim, gprim.GetOrientationAttr(), t)
        if value not in (UsdGeom.Tokens.rightHanded, UsdGeom.Tokens.leftHanded):
            self._skip("orientation is neither rightHanded nor leftHanded; read as rightHanded", prim, repr(value))
        return value == UsdGeom.Tokens.leftHanded

