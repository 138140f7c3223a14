"""A mesh read in its own space baked into its content's space as a :class:`wrt.scene.Mesh`: points, winding
(``leftHanded`` and mirroring transforms), normals, texture coordinates, materials, colours and opacities per triangle
corner."""

from __future__ import annotations

import numpy as np
from pxr import Usd

from .scene import Mesh
from .usd_contents import Context
from .usd_meshes import LocalMesh, vertex_normals
from .usd_problems import BEYOND_FLOAT32
from .usd_xforms import affine_part

_FLIP = np.array([0, 2, 1])  # corner permutation that reverses a triangle's winding, keeping corner 0


def _cofactor(linear: np.ndarray) -> np.ndarray:
    """``det * inv(linear).T`` of a ``(3, 3)`` matrix: rows ``r1 x r2``, ``r2 x r0``, ``r0 x r1``, computed with the
    products and differences ``np.cross`` takes (the same values), at once: three ``np.cross`` calls per mesh were a
    tenth of load_usd for 40k small meshes."""
    a, b = linear[[1, 2, 0]], linear[[2, 0, 1]]  # row k: the pair crossed
    return a[:, [1, 2, 0]] * b[:, [2, 0, 1]] - a[:, [2, 0, 1]] * b[:, [1, 2, 0]]


class MeshBaking:
    """Mesh baking of the stage reader (``materials``, ``_skip``, ``_error``)."""

    def _bake(self, prim: Usd.Prim, m: np.ndarray, ctx: Context, local: LocalMesh, face_materials,
              color_names: list):
        """The :class:`Mesh` of ``local`` with ``m`` baked in; ``face_materials`` ``(F,)`` per source face or None.
        None, with a warning, where ``m`` takes its points past float32's range."""
        if local.cage is not None:  # made from the final (posed) points, once
            local.normals = (vertex_normals(local.points, *local.cage, local.flip), local.vertex_ids)

        # Bake the transform (row-vector convention: p_world = p @ M[:3, :3] + M[3, :3]).
        m = affine_part(m, lambda reason: self._skip(reason, prim))
        linear = m[:3, :3]
        points = local.points @ linear + m[3, :3]
        with np.errstate(over="ignore"):  # said below, naming the prim: numpy's own warning named nothing
            beyond = not np.all(np.isfinite(points.astype(np.float32)))
        if beyond:
            self._skip(BEYOND_FLOAT32, prim)  # it stopped the whole load
            return None

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
            cofactor = _cofactor(linear)
            world = values @ (cofactor if det >= 0.0 else -cofactor)
            length = np.linalg.norm(world, axis=1, keepdims=True)
            good = np.isfinite(length) & (length > 0.0)
            world = np.where(good, world / np.where(good, length, 1.0), 0.0)  # zero where it cannot be normalised
            normals = world.astype(np.float32)[corner_index[:, order]]

        uvs = None
        if local.uvs is not None:
            values, corner_index = local.uvs
            uvs = values.astype(np.float32)[corner_index[:, order]]
        material_ids = None
        if face_materials is not None:
            material_ids = face_materials[np.clip(local.face_ids, 0, max(len(face_materials) - 1, 0))]
        colors = self._corner_colors(prim, local, color_names, material_ids, order, ctx)
        opacities = None
        if local.opacities is not None and (material_ids is None or bool(np.any(material_ids < 0))):
            values, corner_index = local.opacities
            opacities = values[corner_index[:, order]]

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
            opacities=opacities,
        )

    def _colors_from_above(self, prim, local: LocalMesh, names: list) -> list:
        """The colour primvars of ``names`` that ``local`` (the mesh at ``prim``) lacks and that no non-constant one
        above it blocks: those an instance's colour fills in."""
        return [name for name in names
                if name not in local.colors and self.inherited_primvars.lookup(prim, name) is None]

    def _corner_colors(self, prim, local: LocalMesh, names: list, material_ids, order, ctx: Context):
        """``(T, 3, 3)`` float32 colours at the corners of the mesh's triangles (winding ``order``), or None: each
        triangle's from the colour primvar its material reads (``names``, :meth:`MaterialReader.color_primvars`; the
        first for triangles of materials that read none), NaN rows where the mesh has not got it. A primvar the mesh
        lacks (and no non-constant one above it blocks) is one its content wants from above
        (:meth:`Content.want_colors`): a native instance's constant colour of that name (``ctx.outer_color``) fills it
        in."""
        found = {}
        from_above = self._colors_from_above(prim, local, names)
        ctx.content.want_colors(from_above)
        outer = dict(ctx.outer_color or ())
        for name in names:
            if name in local.colors:
                values, corner_index = local.colors[name]
                found[name] = values[corner_index[:, order]]
            elif name in from_above and name in outer:
                found[name] = np.tile(np.asarray(outer[name], np.float32), (len(local.face_ids), 3, 1))
        if len(names) == 1 or not found:
            return found.get(names[0])
        # Each triangle shades with its material's primvar; those of materials that read none keep the first.
        colors = np.full((len(local.face_ids), 3, 3), np.nan, np.float32)
        for k in np.unique(material_ids):
            name = self.materials.color_primvar_of(int(k)) or names[0]
            if name in found:
                rows = material_ids == k
                colors[rows] = found[name][rows]
        return colors

