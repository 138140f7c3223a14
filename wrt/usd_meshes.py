"""A ``UsdGeom.Mesh`` read in its own space: topology checks, triangulation (:func:`triangulate`: fans, concave faces
ear-clipped by :mod:`wrt.polygons`), holes,
Catmull-Clark and bilinear (:mod:`wrt.subdivision`) and Loop (:mod:`wrt.loop_subdivision`) refinement, posing by a
skeleton (:mod:`wrt.usd_skel`) and smooth normals of subdivision surfaces; ``TetMesh`` and ``NurbsPatch`` prims read
the same way once :mod:`wrt.usd_surfaces` made them triangles."""

from __future__ import annotations

import copy

import numpy as np
from pxr import Usd, UsdGeom

from .errors import SceneError
from .loop_subdivision import LoopRefinement, refined_triangles
from .materials import used_materials
from .polygons import clip_concave_faces
from .resources import check_host_memory
from .scene import Mesh
from .subdivision import REFINED_QUAD_BYTES, BilinearRefinement, Refinement, refined_quads
from .subdivision_fvar import FACE_VARYING_MODES, FALLBACK_FACE_VARYING_MODE
from .usd_ancestors import PER_INSTANCE
from .usd_contents import Context
from .usd_values import value_at


def triangulate(face_counts, face_indices, points=None, on_problem=None,
                holes=None) -> tuple[np.ndarray, np.ndarray]:
    """Fan-triangulates polygons around the first vertex of each face; given ``points``, faces that are not convex
    are ear-clipped instead, so that their triangles stay inside them (:func:`wrt.polygons.clip_concave_faces`).

    Face ``f`` with ``n`` vertices becomes ``n - 2`` consecutive triangles: the fan ``(v0, v[k+1], v[k+2])`` for
    ``k = 0 .. n-3``, or for a concave face its ears, each listing its corners in the face's order (winding kept).
    Faces with fewer than 3 vertices give no triangle but still consume their indices.

    Args:
        face_counts: ``(F,)`` int, vertices per face (USD ``faceVertexCounts``).
        face_indices: ``(N,)`` int, the concatenated face vertices (USD ``faceVertexIndices``); without ``points``
            only its length is used, to check that the counts cover it exactly; with them, all in range.
        points: ``(V, 3)`` float, the points ``face_indices`` index, or None for the plain fan.
        on_problem: called ``(reason, detail)`` for concave faces left fanned (they cross themselves, or are huge).
        holes: face numbers that are not drawn (``holeIndices``, any out of range ignored): with ``points``, they
            keep their fan unchecked, no work and no warning for a face no one sees. The caller drops their rows.

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
    if points is not None:
        tri_corners = clip_concave_faces(points, counts, face_indices, tri_corners, on_problem, holes)
    return tri_corners, face_ids


class LocalMesh:
    """A mesh's data in its own space, before the world transform; shared by all instances of a prototype."""

    def __init__(self, points, vertex_ids, face_ids, flip, normals, colors, double_sided, uvs=None, cage=None,
                 refinement=None, opacities=None):
        self.points = points  # (V, 3) float64, local space
        self.vertex_ids = vertex_ids  # (T, 3) int64 rows into points, winding as authored
        self.face_ids = face_ids  # (T,) int64 source face
        self.flip = flip  # orientation = leftHanded
        self.normals = normals  # (values (K, 3) float64 local, corner index (T, 3) into values) or None
        self.colors = colors  # colour primvar -> (values (K, 3) float32, corner index (T, 3)), those the mesh has
        self.double_sided = double_sided
        self.uvs = uvs  # (values (K, 2) float64, corner index (T, 3)) or None
        self.cage = cage  # (faceVertexCounts, faceVertexIndices) of a mesh to get smooth normals from them, else None
        # A Refinement of the points (control cage) into the points vertex_ids index, or None: applied after posing.
        self.refinement = refinement
        self.opacities = opacities  # displayOpacity (values (K,) float32, corner index (T, 3)) or None


class MeshReading:
    """Mesh reading of the stage reader (``time``, ``refine_level``, ``materials``, ``skel``, ``surfaces``)."""

    def _read_mesh(self, prim: Usd.Prim, m: np.ndarray, ctx: Context) -> Mesh | None:
        """The mesh at ``prim`` with ``m`` (``(4, 4)`` row-vector transform to its content's space) baked in; a kept
        read of it reused where nothing it is made from differs (``mesh_memo``, :mod:`wrt.usd_mesh_memo`)."""
        memo = self.mesh_memo
        key = None if memo is None else memo.key(prim, ctx, self.time, self.skel.skel_root)
        counted = None if key is None else memo.counted(key)  # a kept read's: its counts cannot differ
        counts = None
        if counted is None:
            before = len(self.skipped)
            counts = self._int_array(prim, UsdGeom.Mesh(prim).GetFaceVertexCountsAttr())
            n_faces, count_skips = len(counts), self.skipped[before:]
        else:  # the warnings of the counts' read (a mistyped one passed over) recorded again, where a read gives them
            n_faces, count_skips = counted
            self.skipped += count_skips
        # Materials first: the texture-coordinate primvar to read depends on them.
        face_materials = self._face_materials(prim, n_faces, ctx)
        uv_set = self.materials.uv_set(face_materials, prim)
        uv_source = None if uv_set is None else (uv_set, self.materials.st_fallback(face_materials, uv_set))
        found = None if uv_set is None else self.inherited_primvars.lookup(prim, uv_set)
        if uv_set is not None and (found is None or found is PER_INSTANCE):  # (invalid primvars compare equal)
            # Neither the mesh nor a prim above it (up to its content's root) has it: a native instance's constant
            # one stands in (Content.want_uvs), as the walk of its proxies finds it, or the st a PointInstancer gives
            # each instance (one above it too: Storm reads that instance primvar where the mesh has none); without
            # one the fallback st is read, and named in a warning once no instance hands one down (Content.uv_misses).
            ctx.content.want_uvs([uv_set])
            outer = dict(ctx.outer_uv or ()).get(uv_set)
            if outer is None:
                ctx.content.uv_misses.append((prim, prim.GetPath(), uv_set, tuple(uv_source[1])))
            uv_source = (*uv_source, outer, True)
        color_names = self.materials.color_primvars(face_materials)
        default_faces = face_materials is None or bool(np.any(face_materials < 0))
        if key is not None:
            used = [] if face_materials is None else used_materials(face_materials).tolist()
            inputs = memo.inputs(face_materials, uv_source, color_names,
                                 [self.materials.color_primvar_of(k) for k in used], default_faces, ctx.outer_color)
            kept = memo.find(key, inputs)
            if kept is not None:
                return self._reuse_mesh(prim, m, ctx, kept, face_materials, color_names)
            if counts is None:
                before = len(self.skipped)
                counts = self._int_array(prim, UsdGeom.Mesh(prim).GetFaceVertexCountsAttr())
                del self.skipped[before:]  # recorded again from the kept read above
        start = len(self.skipped)  # the warnings from here on are this read's, kept with it
        local = self._read_local_mesh(prim, counts, uv_source, color_names, default_faces, ctx.keep_opaque,
                                      ctx.blocked_opaque)
        if local is None:
            if len(self.skipped) > start:  # skipped (named), not merely empty
                self._skipped_emitter(prim, face_materials)
            return None
        # Smooth normals made from the cage are made again from the posed cage (as Storm does, which skins
        # points only): skinning the rest pose's normals left blend shapes' dents unshaded and joints' bends
        # approximate.
        posed = self.skel.pose(prim, local.points, local.normals, local.vertex_ids, ctx.content.path)
        if posed is not None:
            # Skinned points are in the skeleton's space: the skeleton places them, not the mesh's own transform.
            local.points, local.normals, space = posed
            own = m
            m = self._to_space(space, ctx)
            if m is None:  # the skeleton cannot be placed: named, and the mesh left out
                return None
            # Its front side is still the one its own transform shows, as Storm draws it (UsdSkelImaging skins into
            # the mesh's space, its transform placing the result) and BakeSkinning bakes it; _bake reads it from the
            # skeleton's transform, a mirror that one has and the mesh's lacks (or the reverse) turned over.
            local.flip ^= bool(np.linalg.det(own[:3, :3]) < 0.0) != bool(np.linalg.det(m[:3, :3]) < 0.0)
        if local.refinement is not None:
            local.points = local.refinement.vertex(local.points)
        baked = len(self.skipped)
        mesh = self._bake(prim, m, ctx, local, face_materials, color_names)
        if key is not None and posed is None and mesh is not None:
            memo.keep(key, inputs, (n_faces, count_skips), m, local, mesh, self.skipped[start:baked],
                      self.skipped[baked:])
        return mesh

    def _reuse_mesh(self, prim: Usd.Prim, m: np.ndarray, ctx: Context, kept, face_materials, color_names: list):
        """The mesh of ``kept`` (a :class:`wrt.usd_mesh_memo.KeptMesh` whose inputs are this read's), with the
        warnings its read recorded recorded again: the kept mesh where ``m`` is the transform baked into it, else its
        mesh in its own space baked with ``m``."""
        self.skipped += kept.read_skips
        if np.ascontiguousarray(m, np.float64).tobytes() != kept.to_space:
            self.mesh_memo.counts["rebaked"] += 1
            return self._bake(prim, m, ctx, kept.local, face_materials, color_names)
        self.mesh_memo.counts["reused"] += 1
        self.skipped += kept.bake_skips
        ctx.content.want_colors(self._colors_from_above(prim, kept.local, color_names))  # as _bake asks
        return copy.copy(kept.mesh)

    def _read_surface(self, prim: Usd.Prim, m: np.ndarray, ctx: Context) -> Mesh | None:
        """A TetMesh (its boundary) or NurbsPatch (tessellated) at ``prim`` as a triangle mesh
        (:mod:`wrt.usd_surfaces`), with ``m`` (``(4, 4)`` row-vector transform to its content's space) baked in."""
        face_materials = self._face_materials(prim, 1, ctx)
        color_names = self.materials.color_primvars(face_materials)[:1]  # one material: one colour primvar
        uv_set = self.materials.uv_set(face_materials, prim)
        st_primvar, outer_st, lacking = None, None, False
        if uv_set is not None:
            found = self.inherited_primvars.lookup(prim, uv_set)  # own, or a constant above
            if found is None or found is PER_INSTANCE:  # (invalid primvars compare equal)
                # As for a mesh: the st a native instance or a PointInstancer hands down stands in (it was ignored,
                # the fallback read on every instance), and the missing one is named once no instance hands one down.
                ctx.content.want_uvs([uv_set])
                outer_st = dict(ctx.outer_uv or ()).get(uv_set)
                lacking = outer_st is None
            elif found.HasValue():  # (not BLOCKED: a non-constant one above)
                st_primvar = found
        points = self._point_array(prim)
        if points is None or len(points) == 0:
            return None
        primvar = self._color_primvar(prim, color_names[0])
        primvar = primvar if primvar and primvar.HasValue() else None
        gprim = UsdGeom.Gprim(prim)
        flip = self._left_handed(prim, gprim, self.time)
        try:
            if prim.IsA(UsdGeom.TetMesh):
                surface = self.surfaces.tet_mesh(prim, points, primvar, flip, st_primvar)
            else:
                surface = self.surfaces.nurbs_patch(prim, points, primvar, st_primvar)
        except SceneError as e:
            if not self._skipped_unreadable(e, prim):
                raise
            return None
        if surface is None:
            return None
        uvs = surface.uvs
        if uvs is not None:
            uvs = self._kept_st(prim, uv_set, uvs[0]), uvs[1]
        elif outer_st is not None:
            uvs = np.asarray(outer_st, np.float64).reshape(1, 2), np.zeros_like(surface.triangles)
        elif uv_set is not None:
            # Without the primvar, or with one dropped (warned about), the texture shows at the reader's fallback st,
            # as on a mesh; an authored st was not read at all (the fallback read there too).
            st = self.materials.st_fallback(face_materials, uv_set)
            if lacking:  # named once no instance hands one down, as for a mesh
                ctx.content.uv_misses.append((prim, prim.GetPath(), uv_set, tuple(st)))
            else:
                self._missing_uvs_warning(prim, uv_set, st)
            uvs = np.asarray(st, np.float64).reshape(1, 2), np.zeros_like(surface.triangles)
        cage = (np.full(len(surface.triangles), 3), surface.triangles.reshape(-1)) if surface.smooth else None
        double_sided = bool(self._typed(prim, gprim.GetDoubleSidedAttr()))
        colors = {} if surface.colors is None else {color_names[0]: surface.colors}
        default = face_materials is None or face_materials[0] < 0
        opacity = self._one_opacity(prim, True, ctx.keep_opaque, ctx.blocked_opaque) if default else None
        opacities = None if opacity is None else (np.array([opacity], np.float32), np.zeros_like(surface.triangles))
        local = LocalMesh(surface.points, surface.triangles, surface.face_ids, flip, None, colors, double_sided,
                          uvs=uvs, cage=cage, opacities=opacities)
        return self._bake(prim, m, ctx, local, face_materials, color_names)

    def _read_local_mesh(self, prim: Usd.Prim, counts: np.ndarray, uv_source: tuple | None,
                         color_names=("displayColor",), default_faces=True, keep_opaque=False,
                         blocked_opaque=False) -> LocalMesh | None:
        """The mesh at ``prim`` in its own space, ``counts`` its faceVertexCounts (read first for the materials), with
        texture coordinates ``uv_source`` (``(primvar, (2,) st where the mesh lacks it)`` or None), colours from the
        primvars ``color_names`` it has, and its ``displayOpacity`` when some faces have the default material
        (``default_faces``; ``keep_opaque``, ``blocked_opaque``: see :meth:`_read_opacities`)."""
        mesh = UsdGeom.Mesh(prim)
        t = self.time
        face_indices = self._int_array(prim, mesh.GetFaceVertexIndicesAttr())
        raw_points = self._moved(mesh, mesh.GetPointsAttr())
        if raw_points is None:
            raw_points = value_at(mesh.GetPointsAttr(), t)
        if len(counts) == 0 and len(face_indices) == 0:
            return None  # no faces: nothing to draw (indices without counts: topology_problem)
        if raw_points is None or np.asarray(raw_points).size == 0:
            self._skip("meshes with faces but no points were skipped", prim)
            return None
        points = np.asarray(raw_points)
        if points.ndim != 2 or points.shape[1] != 3 or points.dtype.kind != "f":
            self._skip(
                "meshes whose points are not an array of 3-vectors were skipped",
                prim,
                f"{self._authored_type(mesh.GetPointsAttr())} holding {type(raw_points).__name__}",
            )
            return None
        if not self._typed_points(prim, mesh.GetPointsAttr(), raw_points):
            return None
        points = points.astype(np.float64)

        # Check the topology before using it.
        problem = topology_problem(counts, face_indices, len(points))
        if problem is not None:
            # UsdGeomMesh.ValidateTopology refuses such a mesh, and usdview (Storm) and maya-usd's importer draw the
            # rest of the stage without it, as wrt skips other prims it cannot read; it stopped the whole load.
            self._skip("meshes of invalid topology were skipped", prim, problem)
            return None
        problem = face_count_problem(counts, len(face_indices))
        if problem is not None:  # triangulate refuses them: a SceneError that stopped the load
            self._skip("meshes whose faceVertexCounts UsdGeom.Mesh.ValidateTopology accepts but no faces can be made "
                       "of were skipped", prim, problem)
            return None
        points = self._finite_points(prim, points, face_indices)
        degenerate = int((counts < 3).sum())
        if degenerate:  # refined or not, as Storm warns "degenerated face found" (HdMeshUtil)
            self._skip("faces of fewer than three corners draw nothing", prim, f"{degenerate} of {len(counts)} faces")
        scheme = self._subdivision_scheme(prim, mesh)
        refinement = self._refinement(prim, scheme, counts, face_indices, len(points))
        polygons = (counts, face_indices) if refinement is None else (refinement.counts, refinement.face_indices)
        # Concave faces are clipped in the authored points; refined faces are fanned (quads; Loop's are triangles).
        plane_points = points if refinement is None else None
        # Faces listed in holeIndices are not drawn; their indices and uniform primvar entries still count.
        holes = self._int_array(prim, mesh.GetHoleIndicesAttr())
        try:
            tri_corners, face_ids = triangulate(*polygons, plane_points,
                                                lambda reason, detail: self._skip(reason, prim, detail), holes)
        except ValueError as e:
            raise self._error(str(e), prim, mesh.GetFaceVertexCountsAttr()) from None
        if refinement is not None:
            face_ids = refinement.parent_face[face_ids]  # the control face each refined triangle comes from

        if len(holes):
            bad = (holes < 0) | (holes >= len(counts))
            if bad.any():
                i = int(np.argmax(bad))
                detail = f"holeIndices[{i}] = {holes[i]} for {len(counts)} faces"
                self._skip("holeIndices out of range were ignored", prim, detail)
        if refinement is not None:  # interpolateBoundary = none hides the faces at boundary points too
            holes = np.union1d(holes, refinement.boundary_holes)
        if len(holes):
            drawn = ~np.isin(face_ids, holes)
            tri_corners, face_ids = tri_corners[drawn], face_ids[drawn]
        vertex_ids = polygons[1][tri_corners]

        topology = (counts, face_indices, tri_corners, face_ids, len(points), refinement)
        flip = self._left_handed(prim, mesh, t)
        normals = None
        if scheme == "none":
            normals = self._read_normals(prim, mesh, topology)
        elif self._has_normals(prim, mesh):
            # USD: normals "should not be authored on any Mesh that is subdivided", and UsdImaging hands them to Hydra
            # for "none" meshes only, so Storm shades the others as if they had none, refined or not. wrt shaded an
            # unrefined one with them (an exporter's hard normals on a mesh left at the default catmullClark looked
            # faceted here, smooth in usdview) and dropped them from a refined one silently.
            self._skip('authored normals of subdivision meshes were ignored, as USD and Storm ignore them (author '
                       'subdivisionScheme = "none" for a polygonal mesh)', prim, f"subdivisionScheme {scheme}")
        if normals is not None:
            normals = self._usable_normals(prim, normals, points[vertex_ids], flip)
        colors = {name: found for name in color_names if (found := self._read_colors(prim, topology, name)) is not None}
        uvs = self._read_uvs(prim, topology, *uv_source) if uv_source else None
        opacities = self._read_opacities(prim, topology, keep_opaque, blocked_opaque) if default_faces else None
        smooth = normals is None and scheme in SMOOTH_SCHEMES
        cage = polygons if smooth else None  # its normals are made in _read_mesh, after any posing and refining
        double_sided = bool(self._typed(prim, mesh.GetDoubleSidedAttr(), t))
        return LocalMesh(points, vertex_ids, face_ids, flip, normals, colors, double_sided, uvs, cage, refinement,
                          opacities)

    def _subdivision_scheme(self, prim: Usd.Prim, mesh: UsdGeom.Mesh) -> str:
        """The mesh's ``subdivisionScheme``; a token other than the four USD allows is warned about and read as
        ``catmullClark``, USD's fallback (USD does not check allowed tokens; Storm smooths such a mesh and
        OpenSubdiv refines it as Catmull-Clark). It was drawn flat, silently: a typo turned smooth shading off."""
        scheme = self._typed(prim, mesh.GetSubdivisionSchemeAttr())
        if scheme is None:  # blocked: the fallback
            return "catmullClark"
        if scheme not in SUBDIVISION_SCHEMES:
            self._skip("subdivisionScheme is not catmullClark, loop, bilinear or none; read as catmullClark", prim,
                       repr(str(scheme)))
            return "catmullClark"
        return scheme

    def _usable_normals(self, prim, normals, corner_points: np.ndarray, left_handed: bool):
        """``normals`` ``(values (K, 3), corner index (T, 3))`` with the corners whose value is zero or not finite
        given their triangle's face normal (``corner_points`` ``(T, 3, 3)``, winding as authored; flipped for
        ``left_handed``), with a warning naming the prim. Such a corner was zero after baking, and the shading
        normal near it leaned towards the triangle's other corners."""
        values, corner_index = normals
        lengths = np.linalg.norm(values, axis=1)
        bad_values = ~(np.isfinite(lengths) & (lengths > 0.0))
        if not bad_values.any():
            return normals
        bad = bad_values[corner_index]  # (T, 3)
        self._skip("authored normals that are zero or not finite were replaced by their triangles' face normals",
                   prim, f"{int(bad_values.sum())} of {len(values)} values")
        a, b, c = corner_points[:, 0], corner_points[:, 1], corner_points[:, 2]
        face = np.cross(b - a, c - a)
        face = -face if left_handed else face
        rows, cols = np.nonzero(bad)
        corner_index = corner_index.copy()
        corner_index[rows, cols] = len(values) + np.arange(len(rows))
        return np.concatenate([np.where(bad_values[:, None], 0.0, values), face[rows]]), corner_index

    def _refinement(self, prim, scheme, counts, face_indices, n_points) -> Refinement | None:
        """The refinement of a ``catmullClark``, ``loop`` or ``bilinear`` mesh at ``self.refine_level``, or None."""
        if not self.refine_level or scheme not in REFINED_SCHEMES:
            return None
        if scheme == "loop" and (counts > 3).any():
            # OpenSubdiv refuses such a mesh ("non-triangular faces not supported by Loop scheme").
            self._skip("loop meshes with faces of more than three corners are not refined (Loop subdivision takes "
                       "triangles only, as OpenSubdiv); drawn as their control cage", prim)
            return None
        # Refused before refining: past the memory, numpy failed deep inside the refinement without naming the mesh
        # (or the system killed the load).
        if scheme == "loop":
            faces, kind = refined_triangles(counts, self.refine_level), "triangles"
        else:
            faces, kind = refined_quads(counts, self.refine_level), "quads"
        check_host_memory(faces * REFINED_QUAD_BYTES, f"{self.source}: {self._shown_path(prim)}: refine_level "
                          f"{self.refine_level} ({faces:,} {kind})")
        if scheme == "bilinear":  # no creases, corners or boundary rules: every new point is an average
            return BilinearRefinement(counts, face_indices, n_points, self.refine_level)
        mesh, t = UsdGeom.Mesh(prim), self.time
        creases = corners = None
        crease_indices = self._int_array(prim, mesh.GetCreaseIndicesAttr())
        if len(crease_indices):
            sharpness = value_at(mesh.GetCreaseSharpnessesAttr(), t)
            creases = (crease_indices, self._int_array(prim, mesh.GetCreaseLengthsAttr()),
                       np.asarray(sharpness if sharpness is not None else [], np.float64))
        corner_indices = self._int_array(prim, mesh.GetCornerIndicesAttr())
        if len(corner_indices):
            sharpness = value_at(mesh.GetCornerSharpnessesAttr(), t)
            corners = (corner_indices, np.asarray(sharpness if sharpness is not None else [], np.float64))
        boundary = value_at(mesh.GetInterpolateBoundaryAttr(), t) or "edgeAndCorner"
        if boundary not in ("none", "edgeOnly", "edgeAndCorner"):  # USD does not check allowed tokens (as orientation)
            self._skip("interpolateBoundary is not none, edgeOnly or edgeAndCorner; read as edgeAndCorner", prim,
                       repr(boundary))
            boundary = "edgeAndCorner"
        face_varying = value_at(mesh.GetFaceVaryingLinearInterpolationAttr(), t) or FALLBACK_FACE_VARYING_MODE
        if face_varying not in FACE_VARYING_MODES:
            self._skip(f"faceVaryingLinearInterpolation is not one of {', '.join(FACE_VARYING_MODES)}; read as "
                       f"{FALLBACK_FACE_VARYING_MODE}", prim, repr(face_varying))
            face_varying = FALLBACK_FACE_VARYING_MODE
        options = {"boundary": boundary, "face_varying": face_varying}  # OpenSubdiv applies both to Loop meshes too
        if scheme == "loop":
            scheme_type = LoopRefinement
        else:
            scheme_type = Refinement
            options["triangle_smooth"] = value_at(mesh.GetTriangleSubdivisionRuleAttr(), t) == "smooth"
        try:
            return scheme_type(counts, face_indices, n_points, self.refine_level, creases, corners, **options)
        except ValueError as e:
            self._skip("creases or corners that do not fit the mesh were ignored", prim, str(e))
            return scheme_type(counts, face_indices, n_points, self.refine_level, **options)

    def _finite_points(self, prim, points: np.ndarray, face_indices: np.ndarray) -> np.ndarray:
        """``points``, or a copy with those no face uses that are not finite (NaN, inf) moved onto a point a face
        uses, with a warning naming the prim and how many: USD renderers ignore points no face uses, and such a point
        stopped the whole load. Raises SceneError naming the first point a face uses that is not finite."""
        bad = ~np.isfinite(points).all(axis=1)
        if not bad.any():
            return points
        used = np.zeros(len(points), bool)
        used[face_indices] = True
        if (bad & used).any():
            i = int(np.argmax(bad & used))
            raise self._error(f"points[{i}] = {tuple(points[i].tolist())} is not finite", prim,
                              UsdGeom.Mesh(prim).GetPointsAttr())
        # Onto a used point, not removed: vertex primvars and skinning weights keep their rows; the bounds, the
        # default camera and the trees take only points the triangles use, and this one is in none.
        self._skip("points no face uses that are not finite were ignored", prim,
                   f"{int(bad.sum())} of {len(points)} points")
        points = points.copy()
        # (a mesh of no faces, which draws nothing, has no used point: 0; indexing its first one raised IndexError)
        points[bad] = points[face_indices[0]] if len(face_indices) else 0.0
        return points


def topology_problem(counts: np.ndarray, face_indices: np.ndarray, n_points: int) -> str | None:
    """What makes ``faceVertexCounts`` ``counts`` and ``faceVertexIndices`` ``face_indices`` of a mesh of
    ``n_points`` points invalid exactly where ``UsdGeom.Mesh.ValidateTopology`` refuses them (counts whose sum, taken
    in int32 as USD takes it, is not the number of indices; an index out of range), or None. Valid topology there
    may still hold no faces to draw: negative counts that the others make up for (:func:`face_count_problem`), and
    faces of 0, 1 or 2 vertices, which draw nothing."""
    total = int(np.sum(counts, dtype=np.int64))
    if _int32_sum(total) != len(face_indices):  # a negative int32 sum, as USD's size_t, equals no length
        if len(counts) == 0:
            return f"there are {len(face_indices)} faceVertexIndices but no faceVertexCounts"
        negative = counts < 0
        why = ""
        if negative.any():  # the likelier mistake to name
            f = int(np.argmax(negative))
            why = f" (faceVertexCounts[{f}] = {counts[f]} is negative)"
        return f"faceVertexCounts sum to {total} but there are {len(face_indices)} faceVertexIndices{why}"
    bad = (face_indices < 0) | (face_indices >= n_points)
    if bad.any():
        i = int(np.argmax(bad))
        return f"faceVertexIndices[{i}] = {face_indices[i]} is out of range for {n_points} points"
    return None


def face_count_problem(counts: np.ndarray, n_indices: int) -> str | None:
    """Why the faces of ``counts`` (``faceVertexCounts`` that :func:`topology_problem` finds valid, as USD does)
    cannot be cut from ``n_indices`` faceVertexIndices, or None: a negative count, or counts that sum to the indices
    only in int32 (USD's sum wraps round), so that no face has its own corners."""
    negative = counts < 0
    if negative.any():
        f = int(np.argmax(negative))
        return f"faceVertexCounts[{f}] = {counts[f]} is negative"
    total = int(np.sum(counts, dtype=np.int64))
    if total != n_indices:
        return (f"faceVertexCounts sum to {total} but there are {n_indices} faceVertexIndices (the same number in "
                "int32, where USD sums them)")
    return None


def _int32_sum(total: int) -> int:
    """``total`` wrapped round to int32, as ``ValidateTopology``'s ``std::accumulate`` of ints sums the counts."""
    return (total + 2**31) % 2**32 - 2**31


# Subdivision surfaces without authored normals are shaded with smooth vertex normals of their control cage, as
# usdview (Storm) draws them below its refinement levels; "none" and "bilinear" meshes keep their face normals.
SMOOTH_SCHEMES = ("catmullClark", "loop")
SUBDIVISION_SCHEMES = ("catmullClark", "loop", "bilinear", "none")  # the allowed tokens of subdivisionScheme
REFINED_SCHEMES = ("catmullClark", "loop", "bilinear")  # those refine_level refines


def vertex_normals(points: np.ndarray, counts: np.ndarray, face_indices: np.ndarray, left_handed: bool) -> np.ndarray:
    """``(V, 3)`` smooth normal of every point: the sum, over the polygon corners at it, of the cross product of the
    corner's two edges (each face weighted by its area near the point), normalised; zero where they cancel."""
    counts = counts.astype(np.int64)
    face_indices = np.asarray(face_indices)
    corner = np.ascontiguousarray(points.T)[:, face_indices]  # (3, N) each corner's point, axis first
    # Each corner's following and preceding corner in its face (the face's first and last wrapping round), taken from
    # the corners gathered once: for faces all of one size (quad or triangle meshes) by shifting each face's columns.
    k = int(counts[0]) if len(counts) else 0
    if k > 0 and bool((counts == k).all()):
        faces = corner.reshape(3, -1, k)
        following = np.concatenate([faces[:, :, 1:], faces[:, :, :1]], axis=2).reshape(3, -1)
        preceding = np.concatenate([faces[:, :, -1:], faces[:, :, :-1]], axis=2).reshape(3, -1)
    else:
        starts = np.cumsum(counts) - counts
        drawn = counts > 0
        following = np.arange(1, len(face_indices) + 1)
        following[starts[drawn] + counts[drawn] - 1] = starts[drawn]
        preceding = np.arange(-1, len(face_indices) - 1)
        preceding[starts[drawn]] = starts[drawn] + counts[drawn] - 1
        following, preceding = corner[:, following], corner[:, preceding]
    # The corner's two edges and their cross product, component by component: the products and differences np.cross
    # takes (the same values), which on (N, 3) rows took five times as long.
    a, b = following - corner, preceding - corner
    turns = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    if points.dtype == np.float64:
        # bincount adds the weights in input order in float64, as np.add.at does (the same sums, bit for bit), at a
        # tenth of its time: np.add.at was a third of load_usd for meshes of 400k points.
        normals = np.stack([np.bincount(face_indices, turn, len(points)) for turn in turns], axis=1)
    else:
        normals = np.zeros_like(points)
        np.add.at(normals, face_indices, np.stack(turns, axis=1))
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 0.0, normals / np.where(length > 0.0, length, 1.0), 0.0)
    return -normals if left_handed else normals

