"""Primvars of point-based prims that are not meshes (points, curves, tet meshes, NURBS patches) read as
``(interpolation, values)`` pairs, checked against the number of values each interpolation needs on that prim:
shared by :mod:`wrt.usd_tubes` and :mod:`wrt.usd_surfaces`."""

from __future__ import annotations

import numpy as np
from pxr import Usd

from .usd_values import read_time


def finite_colors(values: np.ndarray, prim, name: str, skip) -> np.ndarray:
    """``values`` (rows of colour primvar ``name``), the rows that are not finite replaced by grey 0.5 with a warning
    through ``skip`` naming ``prim``: NaN or inf would render as a wrong colour; gprims fall back to grey too."""
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        skip(f"non-finite {name} values were replaced by grey 0.5", prim)
        values = np.where(bad[:, None], values.dtype.type(0.5), values)
    return values


CONSTANT_OF_SEVERAL = ("constant primvars holding several values were read as their first value, as UsdImaging "
                       "reads them")  # the warning of first_of_constant


def first_of_constant(values: np.ndarray, prim, name: str, skip) -> np.ndarray:
    """``values`` (or the indices of an indexed one) of primvar ``name`` of ``prim``, whose interpolation is
    ``constant``: when it holds several, the first only, with a warning through ``skip`` naming ``prim``. UsdImaging
    reads displayColor and displayOpacity so (``UsdImagingGprimAdapter::GetColor`` resizes such an array to one value
    and warns "even though it is marked constant"), and constant is also what an array authored without an
    interpolation reads as (``CreateDisplayColorAttr([...])`` in a script or converter writing per-point colours):
    such a stage raised SceneError, and a gprim took the mean of the values."""
    if len(values) <= 1:
        return values
    skip(CONSTANT_OF_SEVERAL, prim, name)
    return values[:1]


def unit_opacities(values: np.ndarray, prim, skip) -> np.ndarray:
    """``displayOpacity`` ``values`` ``(K,)`` clamped to [0, 1] and NaN read as 1 (opaque, the schema's fallback), each
    with a warning through ``skip`` naming ``prim``: the shading would clamp them too, but silently, hiding an
    exporter's mistake."""
    bad = np.isnan(values)
    if bad.any():
        skip("NaN displayOpacity values were read as 1 (opaque)", prim)
        values = np.where(bad, values.dtype.type(1.0), values)
    outside = (values < 0.0) | (values > 1.0)
    if outside.any():
        i = int(np.argmax(outside))
        skip("displayOpacity values outside [0, 1] were clamped", prim, f"{int(outside.sum())} of {len(values)}, "
             f"first {values[i]:g}")
        values = np.clip(values, 0.0, 1.0)
    return values


class FieldReader:
    """Reads primvars and primvar-like attributes (``widths``) at one time code.

    Args:
        time: the ``Usd.TimeCode`` read (see :func:`wrt.usd_values.value_at`).
        skip: ``skip(reason, prim, detail=None)`` records a warning naming the prim.
        error: ``error(message, prim, attr=None)`` returns the :class:`wrt.errors.SceneError` to raise.
    """

    def __init__(self, time: Usd.TimeCode, skip, error):
        self.time = time
        self.skip = skip
        self.error = error

    def check_weights(self, prim, attr, weights: np.ndarray) -> None:
        """Raises SceneError naming the first of NURBS ``pointWeights`` ``weights`` (of ``attr``) that is not a
        positive number."""
        bad = ~(np.isfinite(weights) & (weights > 0.0))
        if bad.any():
            i = int(np.argmax(bad))
            raise self.error(f"pointWeights[{i}] = {weights[i]:g} is not a positive number", prim, attr)

    def field(self, prim, primvar, sizes, components):
        """``(interpolation, (k, components) float64)`` of ``primvar`` (flattened through its indices), or None (with
        a warning) when its elementSize is not 1."""
        raw = primvar.ComputeFlattened(read_time(primvar.GetAttr(), self.time))
        if primvar.GetElementSize() != 1:
            self.skip(f"{primvar.GetPrimvarName()} with elementSize != 1 was ignored", prim)
            return None
        return self.values(prim, primvar.GetAttr(), raw, primvar.GetInterpolation(), sizes, components)

    def values(self, prim, attr, raw, interpolation, sizes, components):
        """``(interpolation, (k, components) float64)`` of the array ``raw`` of ``attr`` (the rgb of 4-vector colours;
        ``faceVarying`` read as ``varying``), checked against ``sizes`` (interpolation -> values needed).

        Raises:
            SceneError: not an array of numbers (or colours), an interpolation the prim type does not take, or the
                wrong length for it.
        """
        values = np.asarray(raw if raw is not None else np.zeros((0, components)))
        name = attr.GetName()
        shape = (components,) if components == 1 else (3, 4)
        if values.size == 0:
            values = np.zeros((0, components))
        elif values.dtype.kind in "fiu":
            values = values.astype(np.float64).reshape(len(values) if values.ndim else 1, -1)
        if values.dtype.kind not in "fiu" or values.shape[1] not in shape:
            what = "numbers" if components == 1 else "3- or 4-vectors"
            raise self.error(f"{name} must be an array of {what}, not {type(raw).__name__}", prim, attr)
        if interpolation == "constant":
            values = first_of_constant(values, prim, name, self.skip)
        if interpolation not in sizes:
            raise self.error(f"{name} has interpolation {interpolation!r}; {prim.GetTypeName()} prims take "
                             f"{', '.join(sizes)}", prim, attr)
        if len(values) != sizes[interpolation]:
            raise self.error(f"{name} has {len(values)} values; {interpolation} interpolation needs "
                             f"{sizes[interpolation]}", prim, attr)
        values = values[:, :components]
        if components == 3:
            values = finite_colors(values, prim, name, self.skip)
        interpolation = "varying" if interpolation == "faceVarying" else interpolation
        return interpolation, values


__all__ = ["CONSTANT_OF_SEVERAL", "FieldReader", "finite_colors", "first_of_constant", "unit_opacities"]
