"""Primvars of point-based prims that are not meshes (points, curves, tet meshes, NURBS patches) read as
``(interpolation, values)`` pairs, checked against the number of values each interpolation needs on that prim:
shared by :mod:`wrt.usd_tubes` and :mod:`wrt.usd_surfaces`."""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd

from .color_spaces import linear_colors
from .usd_problems import authored_type
from .usd_values import read_time

# The warning of a primvar dropped: it is read as unauthored.
PRIMVAR_DROPPED = ("primvars that do not fit their prim (indices out of range, a length its interpolation does not "
                   "take) were ignored, read as unauthored, as Hydra drops them")


def index_problem(primvar, time: Usd.TimeCode) -> str | None:
    """What is wrong with the indices of indexed ``primvar`` at ``time`` (``displayColor:indices[2] = 5 is out of
    range for 1 values``), or None: the reason ``ComputeFlattened`` failed (it returns None, with a warning). The
    values and the indices are each read at their :func:`read_time`, as :func:`flattened` reads them."""
    if not primvar.IsIndexed():
        return None
    wrong_type = indices_type_problem(primvar)
    if wrong_type is not None:
        return wrong_type
    values_time, indices_time = read_times(primvar, time)
    indices = np.asarray(primvar.GetIndicesAttr().Get(indices_time) or [], np.int64).reshape(-1)
    values = primvar.GetAttr().Get(values_time)
    element = max(primvar.GetElementSize(), 1)
    n = len(values) // element if values is not None else 0
    bad = (indices < 0) | (indices >= n)
    if not bad.any():
        return None
    i = int(np.argmax(bad))
    what = "values" if element == 1 else f"elements of {element} values"
    return f"{primvar.GetPrimvarName()}:indices[{i}] = {indices[i]} is out of range for {n} {what}"


def indices_type_problem(primvar) -> str | None:
    """Words for the indices of indexed ``primvar`` authored as another type than ``int[]`` (``displayColor:indices
    is int64[], not int[]``), or None. USD reads no indices from them (``GetIndices`` fails): ``ComputeFlattened``
    raised, which stopped the load of a stage with such a gprim, Points, curves or native instance, and a mesh read
    them as indices (a ``string[]`` one stopped the load too)."""
    kind = primvar.GetIndicesAttr().GetTypeName()
    if not primvar.IsIndexed() or kind == Sdf.ValueTypeNames.IntArray:
        return None
    return f"{primvar.GetPrimvarName()}:indices is {kind}, not int[]"


def read_times(primvar, time: Usd.TimeCode) -> tuple:
    """``(values time, indices time)``: the :func:`read_time` of ``primvar``'s values and of its indices at the
    reader's ``time``. They differ only at the default time, where one of the two has only time samples (read at
    its first, as a mesh reads each) and the other a default value."""
    return read_time(primvar.GetAttr(), time), read_time(primvar.GetIndicesAttr(), time)


def flattened(primvar, time: Usd.TimeCode, prim, skip):
    """``primvar``'s values flattened through its indices at the reader's ``time``, or None with a warning
    (:data:`PRIMVAR_DROPPED`) through ``skip`` naming ``prim`` and the index out of range where USD cannot flatten
    it (``ComputeFlattened`` returns None then, and warns). The values and the indices are each read at their
    :func:`read_time`, as meshes read them: ``ComputeFlattened`` reads both at one time, so at the default time
    values with only time samples were read as none (a gprim's sampled displayColor was grey), and indices with
    only time samples made it raise, which stopped the load of the stage."""
    wrong_type = indices_type_problem(primvar)
    if wrong_type is not None:
        skip(PRIMVAR_DROPPED, prim, wrong_type)
        return None
    values_time, indices_time = read_times(primvar, time)
    if values_time == indices_time or not primvar.IsIndexed():
        raw = primvar.ComputeFlattened(values_time)
    else:
        raw = _flattened_apart(primvar, values_time, indices_time)
    if raw is None:
        problem = index_problem(primvar, time)
        if problem is not None:
            skip(PRIMVAR_DROPPED, prim, problem)
    return one_value_as_array(raw, primvar.GetAttr(), primvar.GetInterpolation())


def one_value_as_array(raw, attr: Usd.Attribute, interpolation: str):
    """``raw`` (the value of primvar attribute ``attr``) as an array of one value where a constant primvar holds one
    value rather than an array (``texCoord2f primvars:st = (0.3, 0.6)``, ``color3f primvars:tint = (1, 0, 0)``), as
    ``ComputeFlattened`` gives it and UsdImaging hands it to the shader as the constant; else ``raw`` as it is. The
    readers take arrays only: such a primvar was dropped as "not an array of 2-vectors", and its texture drawn at
    the reader's fallback st, its colour at the reader's fallback. ``displayColor`` and ``displayOpacity`` stay as
    they are (dropped): UsdImaging reads those two into typed arrays (``UsdImagingGprimAdapter::GetColor``), which a
    single value does not fill."""
    if raw is None or interpolation != "constant" or attr.GetTypeName().isArray:
        return raw
    if attr.GetName() in ("primvars:displayColor", "primvars:displayOpacity"):
        return raw
    return [raw]


def _flattened_apart(primvar, values_time: Usd.TimeCode, indices_time: Usd.TimeCode):
    """``ComputeFlattened`` of ``primvar`` with its values read at ``values_time`` and its indices at
    ``indices_time``: the values where there are no indices or they are not an array, None for an index out of
    range, else the values through the indices (a numpy array). An index picks a run of ``elementSize`` values, as
    in ``ComputeFlattened`` (a skinned mesh's jointIndices and jointWeights have several per point)."""
    values = primvar.GetAttr().Get(values_time)
    indices = primvar.GetIndicesAttr().Get(indices_time)
    if values is None or indices is None or not primvar.GetAttr().GetTypeName().isArray:
        return values
    indices = np.asarray(indices, np.int64).reshape(-1)
    element = max(primvar.GetElementSize(), 1)
    if ((indices < 0) | (indices >= len(values) // element)).any():
        return None
    return np.asarray(values)[(indices[:, None] * element + np.arange(element)).reshape(-1)]


def past_float32_as_inf(values) -> np.ndarray:
    """Float64 ``values`` with those past float32's range made +-inf, as the cast to float32 makes them (with numpy's
    "overflow encountered in cast", which names nothing): the checks for values that are not finite then see them."""
    values = np.asarray(values, np.float64)
    return np.where(np.abs(values) > np.finfo(np.float32).max, np.copysign(np.inf, values), values)


def quaternion_typed(attr: Usd.Attribute, time: Usd.TimeCode) -> bool:
    """Whether ``attr`` is authored as quaternions (``quatf[]``, ``quatd[]``, ``quath[]``): numpy reads them as
    4-vectors (the imaginary part first), which a colour took as its rgb without a word (the identity's is black);
    a mesh drops such a colour primvar as no array of 3- or 4-vectors, and so do the other readers."""
    authored = Sdf.ValueTypeNames.Find(authored_type(attr, time))
    return "Quat" in (authored or attr.GetTypeName()).cppTypeName


def finite_colors(values: np.ndarray, prim, name: str, skip) -> np.ndarray:
    """``values`` (rows of colour primvar ``name``, linear Rec.709), the rows that are not finite replaced by grey 0.5
    and negative channels clamped to 0, each with a warning through ``skip`` naming ``prim``: NaN or inf would render
    as a wrong colour (gprims fall back to grey too), and a negative albedo was drawn black without a word. A channel
    a conversion from another colour space's primaries makes negative (a saturated ACEScg red) is clamped and named
    too, as a light's colour is (wrt.usd_lights)."""
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        skip(f"non-finite {name} values were replaced by grey 0.5", prim)
        values = np.where(bad[:, None], values.dtype.type(0.5), values)
    negative = (values < 0.0).any(axis=1)
    if negative.any():
        skip(f"negative {name} channels (authored, or outside Rec.709's gamut once converted from their colour "
             "space) were clamped to 0", prim)
        values = np.maximum(values, values.dtype.type(0.0))
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

    def authored(self, attr: Usd.Attribute) -> str:
        """The type ``attr`` is authored with (a schema attribute's type name is the schema's whatever the file
        holds: messages named it, "uOrder must be an int, not int" for a ``string uOrder``)."""
        return authored_type(attr, self.time)

    def check_weights(self, prim, attr, weights: np.ndarray) -> None:
        """Raises SceneError naming the first of NURBS ``pointWeights`` ``weights`` (of ``attr``) that is not a
        positive number."""
        bad = ~(np.isfinite(weights) & (weights > 0.0))
        if bad.any():
            i = int(np.argmax(bad))
            raise self.error(f"pointWeights[{i}] = {weights[i]:g} is not a positive number", prim, attr)

    def field(self, prim, primvar, sizes, components):
        """``(interpolation, (k, components) float64)`` of ``primvar`` (flattened through its indices), or None (with
        a warning) when its elementSize is not 1, an index is out of range or its length does not fit."""
        raw = flattened(primvar, self.time, prim, self.skip)
        if raw is None and index_problem(primvar, self.time) is not None:  # (dropped, with a warning)
            return None
        if primvar.GetElementSize() != 1:
            self.skip(f"{primvar.GetPrimvarName()} with elementSize != 1 was ignored", prim)
            return None
        return self.values(prim, primvar.GetAttr(), raw, primvar.GetInterpolation(), sizes, components)

    def values(self, prim, attr, raw, interpolation, sizes, components):
        """``(interpolation, (k, components) float64)`` of the array ``raw`` of ``attr`` (the rgb of 4-vector colours;
        ``faceVarying`` read as ``varying``), checked against ``sizes`` (interpolation -> values needed): None, with a
        warning (:data:`PRIMVAR_DROPPED`), for an interpolation the prim type does not take or the wrong length for
        it, as Hydra drops such a primvar (the prim is drawn as if it had none), and for a value that is not an array
        of ``components``-vectors (numbers, 3- or 4-vectors for colours, 2-, 3- or 4-vectors for texture
        coordinates), as meshes drop one
        (:meth:`wrt.usd_mesh_primvars.MeshPrimvarReading._read_primvar`): it stopped the whole load with SceneError.
        """
        if raw is None:  # blocked at this time (a time sample of None): no value, read as unauthored, as Hydra
            return None  # reads it; it was warned about as a primvar of 0 values that did not fit
        values = np.asarray(raw)
        name = attr.GetName()
        # Colours: 3- or 4-vectors (the rgb); texture coordinates: 2-, 3- or 4-vectors (the first two, as meshes).
        shape = {1: (1,), 2: (2, 3, 4)}.get(components, (3, 4))
        if values.size == 0:
            values = np.zeros((0, components))
        elif values.dtype.kind in "fiu":
            values = values.astype(np.float64).reshape(len(values) if values.ndim else 1, -1)
        if values.dtype.kind not in "fiu" or values.shape[1] not in shape or quaternion_typed(attr, self.time):
            self.skip(f"{name} values that are not an array of {components}-vectors were ignored", prim,
                      f"{authored_type(attr, self.time)} holding {type(raw).__name__}")
            return None
        if interpolation == "constant":
            values = first_of_constant(values, prim, name, self.skip)
        if interpolation not in sizes:
            self.skip(PRIMVAR_DROPPED, prim, f"{name} has interpolation {interpolation!r}; {prim.GetTypeName()} "
                      f"prims take {', '.join(sizes)}")
            return None
        if len(values) != sizes[interpolation]:
            self.skip(PRIMVAR_DROPPED, prim, f"{name} has {len(values)} values; {interpolation} interpolation "
                      f"needs {sizes[interpolation]}")
            return None
        values = values[:, :components]
        if components == 3:  # colours, in their colour space
            values = finite_colors(linear_colors(values, [attr], prim, self.skip), prim, name, self.skip)
        interpolation = "varying" if interpolation == "faceVarying" else interpolation
        return interpolation, values


__all__ = ["CONSTANT_OF_SEVERAL", "PRIMVAR_DROPPED", "FieldReader", "finite_colors", "first_of_constant", "flattened",
           "index_problem", "indices_type_problem", "one_value_as_array", "quaternion_typed",
           "unit_opacities"]
