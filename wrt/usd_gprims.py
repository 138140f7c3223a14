"""Gprims as analytic shapes (:mod:`wrt.primitives`): USD's size parameters and axis folded into the shape's
transform, or triangle meshes when tessellating; ``Points`` and curves as instances of spheres and tube pieces
(:mod:`wrt.usd_tubes`), each shape a content of its own."""

from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdGeom

from .color_spaces import linear_colors
from .errors import SceneError
from .instancing import world_boxes
from .primitives import (
    Shape,
    axis_rotation,
    shape_transform,
    tapered_shape,
    tessellate,
)
from .scene import Mesh
from .tubes import width_axis
from .usd_ancestors import PER_INSTANCE
from .usd_contents import Content, Context, instance_looks
from .usd_primvars import (
    PRIMVAR_DROPPED,
    finite_colors,
    first_of_constant,
    flattened,
    index_problem,
    quaternion_typed,
)
from .usd_problems import BEYOND_FLOAT32
from .usd_xforms import affine_part


class GprimReading:
    """Gprim reading of the stage reader (``time``, ``segments``, ``contents``, ``tubes``)."""

    def _read_gprim(self, prim: Usd.Prim, m: np.ndarray, ctx: Context) -> Shape | None:
        """The analytic shape of gprim ``prim`` with ``m`` (``(4, 4)`` row-vector transform to its content's space)
        and USD's size parameters folded into its transform, or None (with a warning) when it is not supported."""
        found = self._canonical_space(prim)
        if found is None:
            return None
        kind, local, params = found
        t = self.time
        gprim = UsdGeom.Gprim(prim)
        if self._left_handed(prim, gprim, t):
            params[3] = -1.0
        to_world = affine_part(m, lambda reason: self._skip(reason, prim)).T @ local

        material_id, primvar, color = self._gprim_look(prim, ctx)
        values = self._gprim_colors(prim, primvar) if primvar is not None else None
        if values is not None:  # (a primvar that cannot be used: dropped with a warning, the colour as if unauthored)
            color = values.mean(axis=0).astype(np.float32)
        shape = Shape(
            path=str(prim.GetPath()),
            kind=kind,
            to_world=to_world,
            params=params,
            color=color,
            material_id=material_id,
            double_sided=bool(self._typed(prim, gprim.GetDoubleSidedAttr(), t)),
            opacity=self._one_opacity(prim, False, ctx.keep_opaque, ctx.blocked_opaque) if material_id < 0 else None,
            st=self._gprim_st(prim, material_id, ctx),
        )
        # As for mesh points: a box past float32 made the scene's bounds infinite and the render refuse them (skipped).
        if not np.abs(world_boxes(*shape.local_bounds(), to_world[None])).max() <= np.finfo(np.float32).max:
            self._skip(BEYOND_FLOAT32, prim)
            return None
        return shape

    def _gprim_st(self, prim: Usd.Prim, material_id: int, ctx: Context) -> np.ndarray | None:
        """``(2,)`` texture coordinate of gprim ``prim`` for the primvar its material's textures read: its own or an
        inherited constant one (the first two numbers of its first value), as Storm hands constant primvars to the
        meshes it makes of gprims; where neither it nor a prim above it has one, the one a native instance or a
        PointInstancer hands down (``ctx.outer_uv``, as to a mesh: :meth:`Content.want_uvs`); None without any (the
        reader's fallback is read), and, with a warning, for one of another interpolation (wrt has no texture
        coordinates over a gprim) or that is not 2-, 3- or 4-vectors of finite numbers. It was ignored: the texture
        showed at the fallback."""
        uv_set = self.materials.uv_set(np.array([material_id]), prim) if material_id >= 0 else None
        if not uv_set:
            return None
        primvar = self.inherited_primvars.lookup(prim, uv_set)
        if primvar is None or primvar is PER_INSTANCE:  # (invalid primvars compare equal)
            ctx.content.want_uvs([uv_set])
            outer = dict(ctx.outer_uv or ()).get(uv_set)
            if outer is None:
                return None
            with np.errstate(over="ignore"):  # past float32: inf, named below
                st = np.asarray(outer, np.float64).reshape(-1)[:2].astype(np.float32)
            if not np.isfinite(st).all():
                # A NaN st handed down (named by the instance) or one past float32: Shape takes finite ones only,
                # and the load stopped with SceneError; as for a gprim's own such st, the reader's fallback is read.
                self._skip("a texture-coordinate primvar handed down to a gprim that is not finite numbers (in "
                           "float32) was ignored; its textures show at the primvar reader's fallback st", prim, uv_set)
                return None
            return st
        if not primvar.HasValue():  # BLOCKED: a non-constant one above
            return None
        if primvar.GetInterpolation() != UsdGeom.Tokens.constant:
            self._skip("gprims, Points and curves read only a constant texture-coordinate primvar; their textures show "
                       "at the primvar reader's fallback st", prim, f"{uv_set}: {primvar.GetInterpolation()}")
            return None
        # Flattened as other primvars are (values and indices each at their first sample with time=None; indices
        # USD reads none from dropped with a warning): ComputeFlattened at the reader's time ignored sampled values
        # and raised on sampled or int64[] indices, which stopped the load.
        raw = flattened(primvar, self.time, prim, self._skip)
        if raw is None and index_problem(primvar, self.time) is not None:
            return None  # (dropped, with a warning)
        values = np.asarray(raw)
        # Quaternions (quatf[]) read as 4-vectors, imaginary part first; a mesh drops them, as it drops a colour.
        if values.ndim != 2 or values.shape[1] not in (2, 3, 4) or values.dtype.kind not in "fiu" or not len(values) \
                or quaternion_typed(primvar.GetAttr(), self.time) \
                or not np.all(np.abs(values[0, :2]) <= np.finfo(np.float32).max):
            self._skip("a gprim's texture-coordinate primvar that is not 2-, 3- or 4-vectors of finite numbers was "
                       "ignored; its textures show at the primvar reader's fallback st", prim,
                       f"{uv_set}: {self._authored_type(primvar.GetAttr())}")
            return None
        return values[0, :2].astype(np.float32)

    def _gprim_colors(self, prim: Usd.Prim, primvar: UsdGeom.Primvar) -> np.ndarray | None:
        """``(k, 3)`` float64 values of colour primvar ``primvar`` of gprim ``prim``, whose mean colours it, or None
        with a warning where a mesh drops it too (:meth:`wrt.usd_mesh_primvars.MeshPrimvarReading._read_primvar`):
        indices out of range, values that are not an array of 3- or 4-vectors (a ``float[]`` of three values was read
        as one colour, of two failed with numpy's reshape message), an unknown interpolation, an elementSize other
        than 1, no values at all; non-finite values are grey 0.5, with a warning (they made the whole colour grey
        without a word). A non-constant one is taken at any length: the counts Hydra checks it against are those of
        the mesh UsdImaging makes of the gprim, which USD's API does not give and which change between versions."""
        t = self.time
        raw = flattened(primvar, t, prim, self._skip)
        if raw is None:  # indices out of range (with a warning), or no value
            return None
        name = primvar.GetAttr().GetName()
        interpolation = primvar.GetInterpolation()
        if hasattr(raw, "__len__") and len(raw) == 0:
            self._skip(PRIMVAR_DROPPED, prim, f"{name} has 0 values; {interpolation} interpolation needs some")
            return None
        values = np.asarray(raw)
        if (values.ndim != 2 or values.shape[1] not in (3, 4) or values.dtype.kind not in "fiu"
                or quaternion_typed(primvar.GetAttr(), t)):
            self._skip(f"{name} values that are not an array of 3-vectors were ignored", prim,
                       f"{self._authored_type(primvar.GetAttr())} holding {type(raw).__name__}")
            return None
        if interpolation not in ("constant", "uniform", "varying", "vertex", "faceVarying"):
            self._skip(f"{name} with unknown interpolation {interpolation!r} was ignored", prim)
            return None
        if primvar.GetElementSize() != 1:
            self._skip(f"{name} with elementSize != 1 was ignored", prim)
            return None
        values = values[:, :3].astype(np.float64)  # the rgb of a color4f
        if interpolation == UsdGeom.Tokens.constant:
            values = first_of_constant(values, prim, name, self._skip)
        return finite_colors(linear_colors(values, [primvar.GetAttr()], prim, self._skip), prim, name, self._skip)

    def _canonical_space(self, prim: Usd.Prim) -> tuple | None:
        """``(kind, local, params)`` of gprim ``prim``: its :class:`Shape` kind, the ``(4, 4)`` column-vector
        transform from the kind's canonical space to the prim's (USD's size parameters and axis folded in) and its
        ``(4,)`` params; None, with a warning, for a size or axis USD draws nothing for, or a type wrt does not draw."""
        t = self.time

        def bad_size(detail):
            self._skip("gprims with a zero, negative or non-finite size were skipped", prim, detail)

        def number(attr, name, zero_ok=False):
            value = self._typed(prim, attr, t)
            try:
                value = float(value) if value is not None else float("nan")
            except (TypeError, ValueError):  # authored with a wrong type: a string radius stopped the whole load
                bad_size(f"{name} = {value!r}")
                return None
            if not (math.isfinite(value) and (value > 0.0 or (zero_ok and value == 0.0))):
                bad_size(f"{name} = {value:g}")
                return None
            return value

        def axis_of(schema):
            # Any other token ("x", say) used to be read as Z without a word; USD computes no extent for it.
            axis = str(self._typed(prim, schema.GetAxisAttr(), t) or "Z")
            if axis not in ("X", "Y", "Z"):
                self._skip("gprims with an axis other than X, Y or Z were skipped", prim, f"axis = {axis!r}")
                return None
            return axis_rotation(axis)

        params = np.array([1.0, 0.0, 0.0, 1.0])
        linear = None  # (3, 3) canonical space -> the prim's space, for shapes centred at its origin
        local = None  # (4, 4) canonical space -> the prim's space, else
        type_name = prim.GetTypeName()
        if type_name == "Sphere":
            r = number(UsdGeom.Sphere(prim).GetRadiusAttr(), "radius")
            kind, linear = "sphere", None if r is None else np.eye(3) * r
        elif type_name == "Cube":
            size = number(UsdGeom.Cube(prim).GetSizeAttr(), "size")
            kind, linear = "box", None if size is None else np.eye(3) * (size / 2.0)
        elif type_name in ("Cylinder", "Cone"):
            schema = UsdGeom.Cylinder(prim) if type_name == "Cylinder" else UsdGeom.Cone(prim)
            h, r = number(schema.GetHeightAttr(), "height"), number(schema.GetRadiusAttr(), "radius")
            kind = type_name.lower()
            axis = None if h is None or r is None else axis_of(schema)
            linear = None if axis is None else axis @ np.diag([r, r, h / 2.0])
        elif type_name == "Capsule":
            schema = UsdGeom.Capsule(prim)
            h, r = number(schema.GetHeightAttr(), "height", zero_ok=True), number(schema.GetRadiusAttr(), "radius")
            kind = "capsule"
            axis = None if h is None or r is None else axis_of(schema)
            linear = None if axis is None else axis @ (np.eye(3) * r)
            if linear is not None:
                params[0] = h / (2.0 * r)
        elif type_name in ("Cylinder_1", "Capsule_1"):
            schema = UsdGeom.Cylinder_1(prim) if type_name == "Cylinder_1" else UsdGeom.Capsule_1(prim)
            h = number(schema.GetHeightAttr(), "height", zero_ok=type_name == "Capsule_1")
            # One radius may be 0 (a Cylinder_1 that is a cone, a Capsule_1 ending in a point), not both.
            bottom = number(schema.GetRadiusBottomAttr(), "radiusBottom", zero_ok=True)
            top = number(schema.GetRadiusTopAttr(), "radiusTop", zero_ok=True)
            if bottom == 0.0 and top == 0.0:
                bad_size("radiusBottom = radiusTop = 0")
            elif None not in (h, bottom, top):
                axis = axis_of(schema)
                if axis is not None:
                    kind, local, params[0], params[1] = tapered_shape(type_name, h, bottom, top)
                    local = shape_transform(axis) @ local
        elif type_name == "Plane":
            schema = UsdGeom.Plane(prim)
            w, length = number(schema.GetWidthAttr(), "width"), number(schema.GetLengthAttr(), "length")
            kind = "plane"
            axis = None if w is None or length is None else axis_of(schema)
            linear = None if axis is None else axis @ np.diag([w / 2.0, length / 2.0, 1.0])
        else:
            self._skip("gprims of this type (volumes) are not drawn: wrt has no volume renderer; skipped", prim,
                       type_name)
            return None
        if local is None:
            if linear is None:
                return None
            local = shape_transform(linear)
        return kind, local, params

    def _tessellated(self, shape: Shape, prim: Usd.Prim, segments: int | None = None) -> Mesh | None:
        """``shape`` as a triangle mesh of ``segments`` (default ``self.segments``) segments per circle, or None
        (with a warning) where its points are past float32's range."""
        points, indices, normals = tessellate(shape, segments or self.segments)
        n = len(indices)
        if not np.all(np.isfinite(points.astype(np.float32))):
            self._skip(BEYOND_FLOAT32, prim)
            return None
        return Mesh(
            path=shape.path,
            points=points,
            indices=indices,
            face_ids=np.arange(n, dtype=np.int32),
            normals=normals,
            colors=None if shape.color is None else np.broadcast_to(shape.color, (n, 3, 3)),
            double_sided=shape.double_sided,
            material_ids=None if shape.material_id < 0 else np.full(n, shape.material_id, np.int32),
            opacities=None if shape.opacity is None else np.full((n, 3), shape.opacity, np.float32),
            uvs=None if shape.st is None else np.broadcast_to(shape.st, (n, 3, 2)),
            tessellated_gprim=True,  # its element is 0, as the analytic shape's: face_ids number its triangles
        )

    def _read_tubes(self, prim: Usd.Prim, ctx: Context):
        """A ``Points`` or curves prim as instances of spheres and tube segments (:mod:`wrt.usd_tubes`), one
        content per shape, so it is placed (and nested in prototypes) like any instance."""
        counts = None
        if prim.IsA(UsdGeom.Curves):
            counts = self._int_array(prim, UsdGeom.Curves(prim).GetCurveVertexCountsAttr())
        points = self._point_array(prim)
        if points is None or len(points) == 0:
            if points is not None and counts is not None and counts.any():  # as meshes with faces but no points
                self._skip(f"{prim.GetTypeName()} prims with curves but no points were skipped", prim)
            return
        material_id, primvar, color = self._gprim_look(prim, ctx)
        # displayOpacity per point or curve is one per instance, as colours are; a single value is the shapes' own.
        per_element = self._opacity_per_element(prim) if material_id < 0 else None
        opacity = None
        if material_id < 0 and not per_element:
            opacity = self._one_opacity(prim, True, ctx.keep_opaque, ctx.blocked_opaque)
        m = self._to_space(prim, ctx)
        if m is None:
            return
        m = affine_part(m, lambda reason: self._skip(reason, prim))
        # Inside a native prototype USD's primvar inheritance stops at its root: a widths primvar handed down by
        # the instance (ctx.outer_widths) comes next, before the prim's widths attribute.
        if not self.tubes.has_widths_primvar(prim):
            ctx.content.wants_widths = True
        try:
            groups, constant = self.tubes.read(prim, points, m.T, primvar, counts, per_element,
                                               outer_widths=ctx.outer_widths)
        except SceneError as e:
            if not self._skipped_unreadable(e, prim):
                raise
            return
        axis = width_axis(m.T[:3, :3])
        color = constant if constant is not None else color
        double_sided = bool(self._typed(prim, UsdGeom.Gprim(prim).GetDoubleSidedAttr()))
        # Their constant st (own, inherited or handed down), as a gprim's: it was never read, and their textures
        # showed at the reader's fallback st without a word.
        st = self._gprim_st(prim, material_id, ctx)
        path = str(prim.GetPath())
        for group in groups:
            shape = Shape(path, group.kind, np.eye(4), group.params, color if group.colors is None else None,
                          material_id, double_sided, opacity, st=st)
            content = Content(path)
            content.tube = (group.kind == "sphere", axis)
            if self.segments:
                content.meshes += [mesh for mesh in [self._tessellated(shape, prim)] if mesh is not None]
            else:
                content.shapes.append(shape)
            key = ("tubes", path, len(self.contents))  # a content of its own, placed only by these instances
            self.contents[key] = content
            ctx.content.instances.append((key, group.to_space, path, group.index,
                                          instance_looks(group.colors, group.opacities)))

