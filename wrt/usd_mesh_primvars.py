"""A mesh's primvars mapped to its triangle corners: normals, colours, ``displayOpacity`` and texture coordinates, of
every interpolation, indexed or not, and through a Catmull-Clark, Loop or bilinear refinement."""

from __future__ import annotations

import numpy as np
from pxr import Sdf, UsdGeom

from .color_spaces import linear_colors
from .usd_ancestors import BLOCKED
from .usd_primvars import (
    PRIMVAR_DROPPED,
    finite_colors,
    first_of_constant,
    indices_type_problem,
    one_value_as_array,
    past_float32_as_inf,
    unit_opacities,
)
from .usd_values import value_at

_INTERPOLATIONS = ("constant", "uniform", "varying", "vertex", "faceVarying")
# Array types of the primvars named as the texture coordinates a mesh has where it lacks the ones its material
# reads: every 2-, 3- and 4-vector _read_uvs reads (it takes the first two components), less those whose role says
# they are something else (point3f, normal3f, color3f, ...).
TEXTURE_COORDINATE_TYPES = ("texCoord2f[]", "texCoord2d[]", "texCoord2h[]", "texCoord3f[]", "texCoord3d[]",
                            "texCoord3h[]", "float2[]", "double2[]", "half2[]", "float3[]", "double3[]", "half3[]",
                            "float4[]", "double4[]", "half4[]")


def texture_coordinate_primvars(prim) -> list[str]:
    """The names of ``prim``'s primvars with values of :data:`TEXTURE_COORDINATE_TYPES`."""
    return [str(p.GetPrimvarName()) for p in UsdGeom.PrimvarsAPI(prim).GetPrimvarsWithValues()
            if str(p.GetTypeName()) in TEXTURE_COORDINATE_TYPES]


class MeshPrimvarReading:
    """Mesh primvar reads of the stage reader (``time``, ``_skip``, ``_error``)."""

    def _read_normals(self, prim, mesh, topology):
        """``(values (K, 3) float64, corner index (T, 3))`` from ``primvars:normals`` or ``normals``, or None."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
        if primvar and primvar.HasValue():
            return self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology)
        attr = mesh.GetNormalsAttr()
        if attr.HasValue():
            return self._read_primvar(prim, attr, mesh.GetNormalsInterpolation(), None, topology)
        return None

    def _has_normals(self, prim, mesh) -> bool:
        """Whether the mesh has a ``primvars:normals`` or ``normals`` value (those :meth:`_read_normals` reads) that
        holds a normal at the time read: an empty array (an exporter's ``normals = []``) authors none, so a
        subdivision mesh's warning that its normals were ignored named it though nothing was."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
        for attr in ((primvar.GetAttr(),) if primvar else ()) + (mesh.GetNormalsAttr(),):
            value = value_at(attr, self.time) if attr.HasValue() else None
            if value is not None and not (hasattr(value, "__len__") and len(value) == 0):
                return True
        return False

    def _read_colors(self, prim, topology, name: str):
        """``(values (K, 3) float32, corner index (T, 3))`` from colour primvar ``name`` (``displayColor``, or the
        one the mesh's material reads; its own or inherited, see ``LookReading._color_primvar``; the rgb of a 4-vector
        one), or None."""
        primvar = self._color_primvar(prim, name)
        if not (primvar and primvar.HasValue()):
            return None
        # The authored type, not the schema's: displayColor is color3f[] in the schema whatever was authored, and
        # a color4f[] one (common in exported files) was dropped as "not an array of 3-vectors" on meshes alone.
        authored = Sdf.ValueTypeNames.Find(self._authored_type(primvar.GetAttr()))
        width = 4 if "Vec4" in (authored or primvar.GetTypeName()).cppTypeName else 3
        found = self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology, width)
        if found is None:
            return None
        values, corner_index = found
        values = linear_colors(values[:, :3], [primvar.GetAttr()], prim, self._skip)  # in its colour space
        return finite_colors(values.astype(np.float32), prim, name, self._skip), corner_index

    def _read_opacities(self, prim, topology, keep_opaque=False, blocked_opaque=False):
        """``(values (K,) float32, corner index (T, 3))`` from ``displayOpacity`` (its own or a constant inherited one;
        every interpolation and indexing as colours, see :func:`wrt.usd_primvars.unit_opacities` for bad values), or
        None when it has none or is 1 everywhere (opaque: nothing to carry), unless ``keep_opaque`` (a prototype's
        geometry: its own 1 wins over an instance's opacity, Instances.opacities). ``blocked_opaque``: a
        non-constant one above, which blocks inheritance, makes it opaque (``Context.blocked_opaque``)."""
        primvar = self.inherited_primvars.lookup(prim, "displayOpacity")
        if primvar is BLOCKED and blocked_opaque:  # a non-constant one above blocks an instance's opacity too
            return np.ones(1, np.float32), np.zeros(topology[2].shape, np.int64)
        if not (primvar and primvar.HasValue()):
            return None
        found = self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology, 1)
        if found is None:
            return None
        values, corner_index = found
        values = unit_opacities(values[:, 0], prim, self._skip)
        return None if np.all(values >= 1.0) and not keep_opaque else (values.astype(np.float32), corner_index)

    def _read_uvs(self, prim, topology, uv_set: str, fallback: np.ndarray, outer: tuple | None = None,
                  lacking: bool = False):
        """``(values (K, 2) float64, corner index (T, 3))`` of texture-coordinate primvar ``uv_set`` (the first two
        components of 3- or 4-vectors). A mesh without it, or whose one cannot be used (dropped with a warning), takes
        ``fallback`` (``(2,)``, its primvar reader's) at every corner, as the specification's UsdPrimvarReader gives,
        with a warning naming the primvar and the texture-coordinate primvars the mesh has: it read its only other
        2-vector primvar instead, silently, and without one sampled the texture at st = (0, 0) (whatever the
        fallback) while the warning said it was left untextured. Values that are not finite are kept, with a warning:
        the lookups there read the texture's fallback. A mesh without its own takes a constant one of its nearest
        ancestor that has one (``FindPrimvarWithInheritance``, as its colour primvars: UsdImaging hands every constant
        primvar down to the gprims below); it read the fallback there. In a native prototype, where nothing up to its
        root has one, ``outer`` (``(s, t)``, the constant one its instance inherits) is read at every corner.
        ``lacking``: neither the mesh nor a prim above it has the primvar; the caller names it in the warning
        (:meth:`_missing_uvs_warning`), which waits for the instances that may hand one down."""
        primvar = self.inherited_primvars.find(prim, uv_set)
        if primvar and primvar.HasValue():
            # 3- and 4-vectors (Houdini's uv, a vector, as texCoord3f[]) give their first two components, as Storm
            # reads texture coordinates (HdGet_<primvar>().xy); they were ignored.
            type_name = primvar.GetTypeName().cppTypeName
            width = 4 if "Vec4" in type_name else 3 if "Vec3" in type_name else 2
            found = self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology,
                                       components=width)
            if found is not None:
                return self._kept_st(prim, uv_set, found[0]), found[1]
            # Dropped (warned about): read as unauthored, the fallback below, not st = (0, 0) at every corner.
        elif outer is not None:
            return np.asarray(outer, np.float64).reshape(1, 2), np.zeros(topology[2].shape, np.int64)
        if not lacking:
            self._missing_uvs_warning(prim, uv_set, fallback)
        return np.asarray(fallback, np.float64).reshape(1, 2), np.zeros(topology[2].shape, np.int64)

    def _kept_st(self, prim, uv_set: str, values: np.ndarray) -> np.ndarray:
        """The first two components of texture coordinates ``values`` (of primvar ``uv_set``), kept as they are (a
        double past float32 as the inf the float32 st holds): texture lookups read the fallback wherever st is not
        finite, and a warning names how many are not."""
        values = past_float32_as_inf(values[:, :2])
        bad = int(np.count_nonzero(~np.isfinite(values).all(axis=1)))
        if bad:
            self._skip("texture coordinates that are not finite were read as none: the textures there show "
                       "their fallback", prim, f"{uv_set}: {bad} of {len(values)} values")
        return values

    def _missing_uvs_warning(self, prim, uv_set: str, fallback, at: str | None = None, others=None) -> None:
        """Names mesh ``prim`` (at path ``at``, its instance proxy's, where given), which reads its texture at the
        ``fallback`` st for want of primvar ``uv_set``, and the texture-coordinate primvars it has (``others``, found
        when not given: :func:`texture_coordinate_primvars`)."""
        others = texture_coordinate_primvars(prim) if others is None else others
        reason = ("meshes without the texture-coordinate primvar their material reads show the texture at the "
                  "primvar reader's fallback st")
        has = f"; the mesh has {', '.join(others)}" if others else ""
        detail = f"{uv_set}, fallback ({fallback[0]:g}, {fallback[1]:g}){has}"
        if at is None or at == str(prim.GetPath()):
            self._skip(reason, prim, detail)
        else:
            self._skip_path(reason, at, detail)

    def _read_primvar(self, prim, attr, interpolation, primvar, topology, components=3):
        """Reads a primvar of ``components``-vectors and maps it to triangle corners.

        Returns ``(values (K, components) float64, corner_index (T, 3) int64)`` so that ``values[corner_index]`` is
        the per-corner data, or None (with a warning) when the value is not an array of such vectors, an index is out
        of range or the length does not fit the interpolation (:data:`wrt.usd_primvars.PRIMVAR_DROPPED`).
        """
        counts, face_indices, tri_corners, face_ids, n_points, refinement = topology
        name = attr.GetName()
        raw = one_value_as_array(value_at(attr, self.time), attr, interpolation)
        if raw is None:  # blocked at this time (a time sample of None): no value, read as unauthored, as Hydra and
            return None  # gprims' colours read it; it was warned about as a primvar of 0 values that did not fit
        values = np.asarray(raw)
        if components == 1 and values.ndim == 1:  # float[]: one-number elements
            values = values[:, None]
        if values.ndim != 2 or values.shape[1] != components or values.dtype.kind not in "fiu":
            self._skip(
                f"{name} values that are not an array of {components}-vectors were ignored",
                prim,
                f"{self._authored_type(attr)} holding {type(raw).__name__}",
            )
            return None
        values = values.astype(np.float64)
        if interpolation not in _INTERPOLATIONS:
            self._skip(f"{name} with unknown interpolation {interpolation!r} was ignored", prim)
            return None
        if primvar is not None and primvar.GetElementSize() != 1:
            self._skip(f"{name} with elementSize != 1 was ignored", prim)
            return None

        # Element ids: through the primvar's indices when it is indexed, else the values themselves.
        indices = None
        if primvar is not None and (wrong_type := indices_type_problem(primvar)) is not None:
            self._skip(PRIMVAR_DROPPED, prim, wrong_type)
            return None
        if primvar is not None and primvar.IsIndexed():
            raw_indices = value_at(primvar.GetIndicesAttr(), self.time)
            indices = np.asarray(raw_indices if raw_indices is not None else [], dtype=np.int64).reshape(-1)
        if interpolation == "constant" and indices is not None:
            indices = first_of_constant(indices, prim, name, self._skip)
        elif interpolation == "constant":
            values = first_of_constant(values, prim, name, self._skip)
        n_elements = len(indices) if indices is not None else len(values)
        what = "indices" if indices is not None else "values"

        needed = {
            "constant": (1, "1"),
            "uniform": (len(counts), "one per face"),
            "vertex": (n_points, "one per point"),
            "varying": (n_points, "one per point"),
            "faceVarying": (len(face_indices), "one per face-vertex"),
        }[interpolation]
        # A primvar that does not fit is dropped, the mesh drawn as if it had none, as Hydra drops it (and USD's
        # ComputeFlattened fails for indices out of range): it stopped the load of the whole stage.
        if n_elements != needed[0]:
            self._skip(PRIMVAR_DROPPED, prim,
                       f"{name} has {n_elements} {what}; {interpolation} interpolation needs {needed[0]} ({needed[1]})")
            return None
        if indices is not None:
            bad = (indices < 0) | (indices >= len(values))
            if bad.any():
                i = int(np.argmax(bad))
                self._skip(PRIMVAR_DROPPED, prim,
                           f"{name}:indices[{i}] = {indices[i]} is out of range for {len(values)} values")
                return None
        if refinement is not None and interpolation in ("vertex", "varying", "faceVarying"):
            # Per point or per face-vertex data of the control cage becomes data of the refined mesh.
            per_element = values if indices is None else values[indices]
            if interpolation == "faceVarying":
                # An indexed primvar's indices say which face-vertices share a value (where its seams are); an
                # unindexed one has a value per face-vertex, all seams, as Storm hands both to OpenSubdiv.
                return refinement.face_varying(per_element, indices), tri_corners
            refine = refinement.vertex if interpolation == "vertex" else refinement.varying
            return refine(per_element), refinement.face_indices[tri_corners]

        # Element of each triangle corner.
        if interpolation == "constant":
            corner = np.zeros(tri_corners.shape, dtype=np.int64)
        elif interpolation == "uniform":
            corner = np.repeat(face_ids[:, None], 3, axis=1)
        elif interpolation == "faceVarying":
            corner = tri_corners
        else:
            corner = face_indices[tri_corners]
        if indices is not None:
            corner = indices[corner]
        return values, corner

