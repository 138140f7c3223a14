"""Reads a USD stage into a :class:`wrt.scene.Scene`: world-space triangles, materials, cameras and lights.

:func:`load_usd` walks the stage in pre-order (instance proxies included, so native instances are expanded),
keeps every visible ``UsdGeom.Mesh`` whose purpose is ``default`` or ``render``, fan-triangulates its faces
with :func:`triangulate`, bakes the world transform into the points, and carries shading normals,
``displayColor``, texture coordinates and the bound material (:mod:`wrt.materials`) per triangle. UsdLux lights
are read by :mod:`wrt.lights`. Bad topology raises :class:`wrt.errors.SceneError` naming the file and
the prim; things that are skipped but a user might expect to see (other gprims, PointInstancers, unsupported
lights or shaders) produce one warning each.

Time: ``time=None`` reads ``Usd.TimeCode.Default()``. A mesh attribute that has no default value but has
time samples is read at its earliest sample instead, so meshes animated from frame 1 still load. Transforms
are read through ``UsdGeom.XformCache`` at the requested time code and get no such fallback.
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
from pxr import Gf, Tf, Usd, UsdGeom, UsdLux

from .camera import Camera
from .errors import SceneError
from .lights import read_light
from .materials import MaterialReader
from .scene import Mesh, Scene

_RENDERED_PURPOSES = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)  # other purposes: guide, proxy
_INTERPOLATIONS = ("constant", "uniform", "varying", "vertex", "faceVarying")
_FLIP = np.array([0, 2, 1])  # corner permutation that reverses a triangle's winding, keeping corner 0


def triangulate(face_counts, face_indices) -> tuple[np.ndarray, np.ndarray]:
    """Fan-triangulates polygons around the first vertex of each face.

    Face ``f`` with ``n`` vertices becomes the ``n - 2`` consecutive triangles ``(v0, v[k+1], v[k+2])`` for
    ``k = 0 .. n-3``. Faces with fewer than 3 vertices give no triangle but still consume their indices.

    Args:
        face_counts: ``(F,)`` int, vertices per face (USD ``faceVertexCounts``).
        face_indices: ``(N,)`` int, the concatenated face vertices (USD ``faceVertexIndices``); only its
            length is used, to check that the counts cover it exactly.

    Returns:
        ``tri_corners`` ``(T, 3)`` int64 positions into ``face_indices`` (so the triangle vertices are
        ``face_indices[tri_corners]``) and ``face_ids`` ``(T,)`` int64, the source face of each triangle.

    Raises:
        ValueError: a count is negative, or the counts do not sum to ``len(face_indices)``.
    """
    counts = np.asarray(face_counts, dtype=np.int64).reshape(-1)
    n_indices = len(np.asarray(face_indices).reshape(-1))
    if counts.size and counts.min() < 0:
        f = int(np.argmax(counts < 0))
        raise ValueError(f"faceVertexCounts[{f}] = {counts[f]} is negative")
    total = int(counts.sum())
    if total != n_indices:
        raise ValueError(f"faceVertexCounts sum to {total} but there are {n_indices} faceVertexIndices")

    # Each face starts at the running sum of the counts before it and gives max(n - 2, 0) triangles.
    starts = np.cumsum(counts) - counts
    n_tris = np.maximum(counts - 2, 0)
    face_ids = np.repeat(np.arange(len(counts), dtype=np.int64), n_tris)
    # k = index of the triangle inside its face's fan.
    first_tri = np.cumsum(n_tris) - n_tris
    k = np.arange(len(face_ids), dtype=np.int64) - first_tri[face_ids]
    s = starts[face_ids]
    tri_corners = np.stack([s, s + k + 1, s + k + 2], axis=1)
    return tri_corners, face_ids


def load_usd(path, *, time=None) -> Scene:
    """Reads the meshes, materials, cameras and lights of a USD stage.

    Args:
        path: a file USD can open (``.usd``, ``.usda``, ``.usdc``, ``.usdz``).
        time: the time code to read; ``None`` means ``Usd.TimeCode.Default()`` (see the module docstring for
            the fallback to the earliest time sample).

    Returns:
        The :class:`wrt.scene.Scene`; triangle ids follow the stage's pre-order traversal.

    Raises:
        wrt.errors.SceneError: the file is missing or not USD, or a mesh, primvar or camera is invalid.
    """
    source = os.fspath(path)
    if time is None:
        time_code = Usd.TimeCode.Default()
    elif isinstance(time, Usd.TimeCode):
        time_code = time
    else:
        time = float(time)
        if not math.isfinite(time):
            raise ValueError(f"time must be finite, got {time}")
        time_code = Usd.TimeCode(time)

    stage = _open_stage(source)
    if not time_code.IsDefault():
        _check_time_in_range(stage, source, time_code.GetValue())
    return _StageReader(stage, source, time_code).read()


def _check_time_in_range(stage: Usd.Stage, source: str, time: float) -> None:
    """Rejects a time outside the stage's authored ``[startTimeCode, endTimeCode]``; a stage without an authored
    range accepts any time (USD holds the nearest sample). Reads only layer metadata, never time samples, which
    can hang usd-core on stages with ``timeCodesPerSecond = 0``."""
    if not stage.HasAuthoredTimeCodeRange():
        return
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    if not start <= time <= end:
        raise ValueError(f"{os.path.basename(source)}: time {time:g} is outside the stage's time range [{start:g}, {end:g}]")


def _open_stage(source: str) -> Usd.Stage:
    try:
        stage = Usd.Stage.Open(source)
    except Tf.ErrorException as e:
        if not os.path.exists(source):
            raise SceneError("file not found", path=source) from None
        raise SceneError(f"USD cannot open this file ({_tf_message(e)})", path=source) from None
    if stage is None:
        raise SceneError("USD cannot open this file", path=source)
    return stage


def _tf_message(error: Exception) -> str:
    """The quoted reasons inside a ``Tf.ErrorException`` text, without the C++ file and line noise."""
    reasons = re.findall(r" : '(.*)'\s*$", str(error), flags=re.MULTILINE)
    return "; ".join(reasons) if reasons else str(error).strip()


def _get(attr: Usd.Attribute, time: Usd.TimeCode):
    """``attr`` at ``time``, or at its earliest time sample when ``time`` is default and it has no default.

    Reads ``EarliestTime`` rather than ``GetTimeSamples()[0]``: the result is the same, and ``GetTimeSamples``
    can hang usd-core 26.11 on stages with ``timeCodesPerSecond = 0``.
    """
    value = attr.Get(time)
    if value is None and time.IsDefault() and attr.HasValue():
        value = attr.Get(Usd.TimeCode.EarliestTime())
    return value


class _LocalMesh:
    """A mesh's data in its own space, before the world transform; shared by all instances of a prototype."""

    def __init__(self, points, vertex_ids, face_ids, flip, normals, colors, double_sided, uvs=None):
        self.points = points  # (V, 3) float64, local space
        self.vertex_ids = vertex_ids  # (T, 3) int64 rows into points, winding as authored
        self.face_ids = face_ids  # (T,) int64 source face
        self.flip = flip  # orientation = leftHanded
        self.normals = normals  # (values (K, 3) float64 local, corner index (T, 3) into values) or None
        self.colors = colors  # (values (K, 3) float32, corner index (T, 3)) or None
        self.double_sided = double_sided
        self.uvs = uvs  # (values (K, 2) float64, corner index (T, 3)) or None


class _StageReader:
    """One pass over a stage; collects meshes, cameras and lights and the warnings to emit."""

    def __init__(self, stage: Usd.Stage, source: str, time: Usd.TimeCode):
        self.stage = stage
        self.source = source
        self.time = time
        self.xforms = UsdGeom.XformCache(time)
        self.prototype_cache = {}  # (prototype prim path, uv set) -> _LocalMesh or None, for instance proxies
        self.materials = MaterialReader(time, self._skip)  # UsdShade materials and textures, read once each
        self.skipped = {}  # reason -> [(prim path, detail or None)], reported once per reason at the end

    def read(self) -> Scene:
        scene = Scene(
            up_axis=str(UsdGeom.GetStageUpAxis(self.stage)),
            meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(self.stage)),
            source=self.source,
        )
        predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)  # active, defined, loaded, concrete
        it = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), predicate))
        for prim in it:
            try:
                self._read_prim(prim, it, scene)
            except SceneError:
                raise
            except (Tf.ErrorException, ValueError, TypeError) as e:
                raise self._error(f"cannot read this prim ({_tf_message(e)})", prim) from e
        scene.materials = self.materials.materials
        scene.textures = self.materials.textures
        self._warn_skipped()
        return scene

    def _read_prim(self, prim: Usd.Prim, it, scene: Scene):
        if prim.IsPseudoRoot():
            return
        if prim.IsA(UsdGeom.PointInstancer):
            # Its prototypes are only drawn through the instancer, so the whole subtree is left out.
            if self._rendered(prim):
                self._skip("PointInstancer prims are not supported yet; skipped", prim)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.Mesh):
            if self._rendered(prim):
                mesh = self._read_mesh(prim)
                if mesh is not None:
                    scene.meshes.append(mesh)
        elif prim.IsA(UsdGeom.Gprim):
            if self._rendered(prim):
                self._skip("gprims other than Mesh are not supported yet; skipped", prim, prim.GetTypeName())
        elif prim.IsA(UsdGeom.Camera):
            scene.cameras[str(prim.GetPath())] = self._read_camera(prim)
        elif prim.IsA(UsdLux.DistantLight) or prim.HasAPI(UsdLux.LightAPI):
            if self._visible(prim):
                light = read_light(prim, self.xforms, self.time, scene.up_axis, self._skip)
                if light is not None:
                    scene.lights.append(light)

    # Filters

    def _visible(self, prim: Usd.Prim) -> bool:
        return UsdGeom.Imageable(prim).ComputeVisibility(self.time) != UsdGeom.Tokens.invisible

    def _rendered(self, prim: Usd.Prim) -> bool:
        return self._visible(prim) and UsdGeom.Imageable(prim).ComputePurpose() in _RENDERED_PURPOSES

    # Meshes

    def _read_mesh(self, prim: Usd.Prim) -> Mesh | None:
        # Materials first: the texture-coordinate primvar to read depends on them.
        counts = _get(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr(), self.time)
        n_faces = len(counts) if counts is not None else 0
        face_materials = self.materials.face_materials(prim, n_faces)
        uv_set = self.materials.uv_set(face_materials)
        if prim.IsInstanceProxy():
            key = (prim.GetPrimInPrototype().GetPath(), uv_set)
            if key not in self.prototype_cache:
                self.prototype_cache[key] = self._read_local_mesh(prim, uv_set)
            local = self.prototype_cache[key]
        else:
            local = self._read_local_mesh(prim, uv_set)
        if local is None:
            return None

        # Bake the world transform (row-vector convention: p_world = p @ M[:3, :3] + M[3, :3]).
        m = np.array(self.xforms.GetLocalToWorldTransform(prim), dtype=np.float64)
        if not np.all(np.isfinite(m)):
            raise self._error("world transform is not finite", prim)
        if not np.allclose(m[:, 3], (0.0, 0.0, 0.0, 1.0)):
            self._skip("world transform is projective; its last column was ignored", prim)
        linear = m[:3, :3]
        points = local.points @ linear + m[3, :3]
        if not np.all(np.isfinite(points.astype(np.float32))):
            raise self._error("points are not finite after the world transform", prim)

        # A mirroring transform flips the winding just as leftHanded does; both together cancel.
        det = float(np.linalg.det(linear))
        flip = local.flip ^ (det < 0.0)
        order = _FLIP if flip else slice(None)
        indices = local.vertex_ids[:, order]

        normals = None
        if local.normals is not None:
            values, corner_index = local.normals
            # Normals transform by the inverse transpose; the sign-corrected cofactor matrix is the same up to
            # a positive scale and exists even for singular transforms.
            r0, r1, r2 = linear
            cofactor = np.stack([np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)])  # = det * inv(linear).T
            world = values @ (cofactor if det >= 0.0 else -cofactor)
            length = np.linalg.norm(world, axis=1, keepdims=True)
            good = np.isfinite(length) & (length > 0.0)
            world = np.where(good, world / np.where(good, length, 1.0), 0.0)  # zero where it cannot be normalised
            normals = world.astype(np.float32)[corner_index[:, order]]

        colors = None
        if local.colors is not None:
            values, corner_index = local.colors
            colors = values[corner_index[:, order]]

        uvs = None
        if local.uvs is not None:
            values, corner_index = local.uvs
            uvs = values.astype(np.float32)[corner_index[:, order]]
        material_ids = None
        if face_materials is not None:
            material_ids = face_materials[np.clip(local.face_ids, 0, max(n_faces - 1, 0))]

        return Mesh(
            path=str(prim.GetPath()),
            points=points,
            indices=indices,
            face_ids=local.face_ids,
            normals=normals,
            colors=colors,
            double_sided=local.double_sided,
            uvs=uvs,
            material_ids=material_ids,
        )

    def _read_local_mesh(self, prim: Usd.Prim, uv_set: str | None = None) -> _LocalMesh | None:
        mesh = UsdGeom.Mesh(prim)
        t = self.time
        counts = _get(mesh.GetFaceVertexCountsAttr(), t)
        face_indices = _get(mesh.GetFaceVertexIndicesAttr(), t)
        raw_points = _get(mesh.GetPointsAttr(), t)
        counts = np.asarray(counts if counts is not None else [], dtype=np.int64).reshape(-1)
        face_indices = np.asarray(face_indices if face_indices is not None else [], dtype=np.int64).reshape(-1)
        if len(counts) == 0:
            return None  # no faces: nothing to draw
        if raw_points is None or np.asarray(raw_points).size == 0:
            self._skip("meshes with faces but no points were skipped", prim)
            return None
        points = np.asarray(raw_points)
        if points.ndim != 2 or points.shape[1] != 3 or points.dtype.kind != "f":
            type_name = mesh.GetPointsAttr().GetTypeName()
            self._skip(
                "meshes whose points are not an array of 3-vectors were skipped",
                prim,
                f"{type_name} holding {type(raw_points).__name__}",
            )
            return None
        points = points.astype(np.float64)

        # Check the topology before using it.
        self._check_topology(prim, counts, face_indices, points)
        try:
            tri_corners, face_ids = triangulate(counts, face_indices)
        except ValueError as e:
            raise self._error(str(e), prim, mesh.GetFaceVertexCountsAttr()) from None
        vertex_ids = face_indices[tri_corners]

        holes = _get(mesh.GetHoleIndicesAttr(), t)
        if holes is not None and len(holes):
            self._skip("holeIndices are not supported; hole faces are rendered", prim)

        topology = (counts, face_indices, tri_corners, face_ids, len(points))
        normals = self._read_normals(prim, mesh, topology)
        colors = self._read_colors(prim, mesh, topology)
        uvs = self._read_uvs(prim, topology, uv_set) if uv_set else None
        flip = _get(mesh.GetOrientationAttr(), t) == UsdGeom.Tokens.leftHanded
        double_sided = bool(_get(mesh.GetDoubleSidedAttr(), t))
        return _LocalMesh(points, vertex_ids, face_ids, flip, normals, colors, double_sided, uvs)

    def _check_topology(self, prim, counts, face_indices, points):
        mesh = UsdGeom.Mesh(prim)
        bad = counts <= 0
        if bad.any():
            f = int(np.argmax(bad))
            kind = "negative" if counts[f] < 0 else "zero"
            raise self._error(f"faceVertexCounts[{f}] = {counts[f]} is {kind}", prim, mesh.GetFaceVertexCountsAttr())
        total = int(counts.sum())
        if total != len(face_indices):
            raise self._error(
                f"faceVertexCounts sum to {total} but there are {len(face_indices)} faceVertexIndices",
                prim,
                mesh.GetFaceVertexCountsAttr(),
            )
        bad = (face_indices < 0) | (face_indices >= len(points))
        if bad.any():
            i = int(np.argmax(bad))
            raise self._error(
                f"faceVertexIndices[{i}] = {face_indices[i]} is out of range for {len(points)} points",
                prim,
                mesh.GetFaceVertexIndicesAttr(),
            )
        bad = ~np.isfinite(points).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise self._error(f"points[{i}] = {tuple(points[i].tolist())} is not finite", prim, mesh.GetPointsAttr())

    def _read_normals(self, prim, mesh, topology):
        """``(values (K, 3) float64, corner index (T, 3))`` from ``primvars:normals`` or ``normals``, or None."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
        if primvar and primvar.HasValue():
            return self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology)
        attr = mesh.GetNormalsAttr()
        if attr.HasValue():
            return self._read_primvar(prim, attr, mesh.GetNormalsInterpolation(), None, topology)
        return None

    def _read_colors(self, prim, mesh, topology):
        """``(values (K, 3) float32, corner index (T, 3))`` from ``primvars:displayColor``, or None."""
        primvar = mesh.GetDisplayColorPrimvar()
        if not (primvar and primvar.HasValue()):
            return None
        found = self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology)
        if found is None:
            return None
        values, corner_index = found
        return values.astype(np.float32), corner_index

    def _read_uvs(self, prim, topology, uv_set: str):
        """``(values (K, 2) float64, corner index (T, 3))`` of texture-coordinate primvar ``uv_set`` (when missing:
        the mesh's only 2-vector primvar, if it has exactly one), or None."""
        api = UsdGeom.PrimvarsAPI(prim)
        primvar = api.GetPrimvar(uv_set)
        if not (primvar and primvar.HasValue()):
            candidates = [
                p for p in api.GetPrimvarsWithValues() if str(p.GetTypeName()).rstrip("[]") in ("texCoord2f", "float2")
            ]
            if len(candidates) != 1:
                self._skip("meshes without the texture-coordinate primvar their material reads were left untextured", prim, uv_set)
                return None
            primvar = candidates[0]
        return self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology, components=2)

    def _read_primvar(self, prim, attr, interpolation, primvar, topology, components=3):
        """Reads a primvar of ``components``-vectors and maps it to triangle corners.

        Returns ``(values (K, components) float64, corner_index (T, 3) int64)`` so that ``values[corner_index]`` is
        the per-corner data, or None (with a warning) when the value is not an array of such vectors.
        """
        counts, face_indices, tri_corners, face_ids, n_points = topology
        name = attr.GetName()
        raw = _get(attr, self.time)
        values = np.asarray(raw) if raw is not None else np.zeros((0, components))
        if values.ndim != 2 or values.shape[1] != components or values.dtype.kind not in "fiu":
            self._skip(
                f"{name} values that are not an array of {components}-vectors were ignored",
                prim,
                f"{attr.GetTypeName()} holding {type(raw).__name__}",
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
        if primvar is not None and primvar.IsIndexed():
            raw_indices = _get(primvar.GetIndicesAttr(), self.time)
            indices = np.asarray(raw_indices if raw_indices is not None else [], dtype=np.int64).reshape(-1)
        n_elements = len(indices) if indices is not None else len(values)
        what = "indices" if indices is not None else "values"

        needed = {
            "constant": (1, "1"),
            "uniform": (len(counts), "one per face"),
            "vertex": (n_points, "one per point"),
            "varying": (n_points, "one per point"),
            "faceVarying": (len(face_indices), "one per face-vertex"),
        }[interpolation]
        if n_elements != needed[0]:
            raise self._error(
                f"{name} has {n_elements} {what}; {interpolation} interpolation needs {needed[0]} ({needed[1]})",
                prim,
                attr,
            )

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
            bad = (indices < 0) | (indices >= len(values))
            if bad.any():
                i = int(np.argmax(bad))
                raise self._error(
                    f"{name}:indices[{i}] = {indices[i]} is out of range for {len(values)} values", prim, attr
                )
            corner = indices[corner]
        return values, corner

    # Cameras and lights

    def _read_camera(self, prim: Usd.Prim) -> Camera:
        cam = UsdGeom.Camera(prim).GetCamera(self.time)
        clip = cam.clippingRange
        try:
            return Camera(
                to_world=np.array(cam.transform, dtype=np.float64).T,  # Gf is row-vector; Camera is column-vector
                focal_length=float(cam.focalLength),
                horizontal_aperture=float(cam.horizontalAperture),
                vertical_aperture=float(cam.verticalAperture),
                horizontal_aperture_offset=float(cam.horizontalApertureOffset),
                vertical_aperture_offset=float(cam.verticalApertureOffset),
                clipping_range=(float(clip.min), float(clip.max)),
                projection="orthographic" if cam.projection == Gf.Camera.Orthographic else "perspective",
                f_stop=float(cam.fStop),
                focus_distance=float(cam.focusDistance),
                path=str(prim.GetPath()),
            )
        except ValueError as e:
            raise self._error(f"invalid camera: {e}", prim) from None

    # Errors and warnings

    def _error(self, message: str, prim: Usd.Prim, attr: Usd.Attribute | None = None) -> SceneError:
        """A SceneError naming the file and the prim, plus the layer the bad value is authored in if different."""
        if attr is not None:
            try:
                stack = attr.GetPropertyStack(self.time)
            except Tf.ErrorException:
                stack = []
            root = self.stage.GetRootLayer()
            if stack and stack[0].layer != root:
                message += f" (authored in {stack[0].layer.identifier})"
        return SceneError(message, path=self.source, prim=str(prim.GetPath()))

    def _skip(self, reason: str, prim: Usd.Prim, detail: str | None = None):
        """Records a prim left out (or data ignored) for ``reason``; ``detail`` is tallied in the warning."""
        self.skipped.setdefault(reason, []).append((str(prim.GetPath()), detail))

    def _warn_skipped(self):
        """One warning per reason, with the count, a tally of details and the first few prim paths."""
        for reason, found in self.skipped.items():
            tally = {}
            for _, detail in found:
                if detail is not None:
                    tally[detail] = tally.get(detail, 0) + 1
            kinds = f" ({', '.join(f'{k}: {n}' for k, n in tally.items())})" if tally else ""
            paths = [p for p, _ in found]
            shown = ", ".join(paths[:3]) + (", ..." if len(paths) > 3 else "")
            warnings.warn(f"{self.source}: {reason}: {len(paths)} prim(s){kinds}: {shown}", stacklevel=4)


__all__ = ["load_usd", "triangulate"]
