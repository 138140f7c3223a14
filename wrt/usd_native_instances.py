"""Native instances (``instanceable`` prims): each prototype read once per outer material, purpose, purposes hidden
above it (UsdGeomVisibilityAPI), inherited colour, inherited width of its points and curves and inherited texture
coordinates, and the instance placed as one row of its container's instances."""

from __future__ import annotations

import math

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from .usd_ancestors import PER_INSTANCE
from .usd_contents import Context, instance_looks
from .usd_primvars import PRIMVAR_DROPPED, flattened, past_float32_as_inf, quaternion_typed
from .usd_xforms import XFORM_OP_ORDER

MAX_INHERITED_COLORS = 64  # distinct displayColors handed down by instances, per native prototype (one copy each)
MAX_INHERITED_WIDTHS = 64  # distinct primvars:widths handed down by instances, per native prototype (one copy each)
MAX_INHERITED_UVS = 64  # distinct texture coordinates handed down by instances, per native prototype (one copy each)
_NAN = math.nan  # one NaN object, so that a NaN width or st handed down keys one copy (NaN != NaN)


class NativeInstanceReading:
    """Native instancing of the stage reader (``contents``, ``materials``)."""

    def _read_native_instance(self, prim: Usd.Prim, ctx: Context, purpose=None, hidden: frozenset = frozenset()):
        """An instance of a native prototype; ``purpose``: the purpose it hands down where not drawn (or hidden), or
        where an opinion gives it (``Context.outer_purpose``), else None; ``hidden``: the drawn purposes opinions on
        and above it hide (:meth:`_hidden_purposes`)."""
        prototype = prim.GetPrototype()
        if not prototype:
            self._skip("instances without a prototype were skipped", prim)
            return
        sibling = self._sibling_key(prim, prototype, ctx, purpose, hidden)
        kept = None if sibling is None else self.sibling_reads.get(sibling)
        if kept is not None:
            key, wanted = kept
            _want(ctx.content, wanted)
        else:
            before = len(self.skipped), _wanted(ctx.content)
            key = self._instance_key(prim, prototype, ctx, purpose, hidden)
            if sibling is not None and len(self.skipped) == before[0]:  # (a read that warned is read again: it warns)
                self.sibling_reads[sibling] = key, _wanted(ctx.content, before[1])
        # Its meshes that still lack one read the fallback: named (at their proxies in this instance) once this
        # reaches the world without one.
        root = Sdf.Path(self.contents[key].path)
        for mesh, at, name, fallback in self.contents[key].uv_misses:
            if at.HasPrefix(root):  # (a PointInstancer in it may draw a prototype from outside: kept at its path)
                at = prim.GetPath().AppendPath(at.MakeRelativePath(root))
            ctx.content.uv_misses.append((mesh, at, name, fallback))
        m = self._to_space(prim, ctx)
        if m is None:  # named in a warning, and left out
            return
        m = m.T  # column vectors
        # A constant displayOpacity on the instance or above it is the opacity of the prototype's geometry that has
        # none: one value per instance (Instances.opacities), no copy of the prototype.
        opacity = self._inherited_opacity(prim)
        found = self.inherited_primvars.lookup(prim, "displayOpacity") if opacity is None else None
        if ctx.blocked_opaque and found is not None and found is not PER_INSTANCE:  # (invalid primvars compare equal)
            # A non-constant one on the instance or above it blocks an outer instance's opacity, as a mesh's
            # (Context.blocked_opaque; a PointInstancer's instance opacities get past it, and are nearer).
            opacity = 1.0
        looks = None if opacity is None else instance_looks(None, np.array([opacity], np.float32))
        ctx.content.instances.append((key, m[None], str(prim.GetPath()), np.array([-1], np.int32), looks))
        self._read_cameras(prim, self.contents[key].cameras, ctx)
        self._read_lights(prim, self.contents[key].lights, ctx)

    def _instance_key(self, prim: Usd.Prim, prototype: Usd.Prim, ctx: Context, purpose, hidden: frozenset) -> tuple:
        """The content key native instance ``prim`` of ``prototype`` draws (its prototype read with what the
        instance hands down: bindings, colours, widths, texture coordinates), its container ``ctx.content`` told
        what the prototype lacks that may come from above the container."""
        hidden = self._hidden_inside(prototype, purpose, hidden)  # only those some prim inside can take
        # The walk of each binding purpose from a prim of the prototype goes on through the instance and its
        # ancestors (ComputeBoundMaterial on the instance proxies): what it finds there completes the walks inside.
        binding_prim = self._binding_prim(prim, ctx)
        path = str(prototype.GetPath())
        if self.materials.bindings_above.any(binding_prim) and self.collections_inside.reach(binding_prim):
            # A collection bound above holds some of its proxies and not others: its prims are resolved through
            # this instance's proxies (a copy of the prototype for it), their walks go on to the container's root.
            proxy = (path, str(binding_prim.GetPath()))
            key = ("native", path, ctx.outer_bindings, purpose, None, proxy, None, None, hidden)
            content = self._content(key, prototype, None, ctx.outer_bindings, purpose, proxy=proxy, outer_hidden=hidden)
            ctx.content.outer_purposes |= content.outer_purposes
        else:
            content, key = self._shared_prototype(prototype, binding_prim, ctx, purpose, hidden)
        # A constant displayColor (or the colour primvar a material reads) on the instance or above it colours the
        # prototype's meshes that have none, as primvars are inherited through instance proxies (instances of one
        # prototype in different colours).
        own = self._inherited_colors(prim, content.outer_colors)
        have = {name for name, _ in own}
        # The colours it has not may come from above this instance's container.
        ctx.content.want_colors([name for name in content.outer_colors if name not in have])
        # Only where nothing up to the root of its container has the primvar: a non-constant one on the instance or
        # above it (a PointInstancer's instance colours among them) blocks the walk of its proxies there.
        above = tuple((name, rgb) for name, rgb in ctx.outer_color or ()
                      if name not in have and name in content.outer_colors
                      and self.inherited_primvars.lookup(prim, name) is None)
        colors = tuple(sorted(own + above))
        if colors:
            key = self._copy_with(key, content.colors, colors, MAX_INHERITED_COLORS, "colours", prim, color=colors)
        # A constant primvars:widths on the instance or above it sizes the prototype's points and curves that have
        # no widths primvar, as FindPrimvarWithInheritance on the instance proxies finds it.
        if content.wants_widths:
            widths = self._inherited_widths(prim)
            if widths is None:
                ctx.content.wants_widths = True  # the width may come from above this instance's container
                widths = ctx.outer_widths
            if widths is not None:
                key = self._copy_with(key, self.contents[key].widths, widths, MAX_INHERITED_WIDTHS, "widths", prim,
                                      widths=widths)
        # A constant texture-coordinate primvar (st) on the instance or above it is read by the prototype's meshes
        # that have none, as FindPrimvarWithInheritance on the instance proxies finds it (one st per instance picking
        # a palette texel).
        if self.contents[key].outer_uvs:
            uvs = self._inherited_uvs(prim, ctx, self.contents[key].outer_uvs)
            if uvs:
                key = self._copy_with(key, self.contents[key].uvs, uvs, MAX_INHERITED_UVS, "texture coordinates",
                                      prim, uv=uvs)
        return key

    def _transform_only(self, prim: Usd.Prim, ctx: Context) -> bool:
        """World-level native instance ``prim`` authors nothing but its transform, and reads all else from its parent:
        no property but xformOpOrder and xformOp:* (its visibility, purpose, purpose visibilities, primvars and
        bindings are none of its own: USD's walks and wrt's read authored properties), no value clips reach it (whose
        values no property names), and it is no gprim (whose schema has primvars). Its siblings of one prototype read
        alike (:meth:`_sibling_key`, ``Visibility._sibling_state``)."""
        if not ctx.world:
            return False
        path = prim.GetPath()
        if self._transform_only_kept[0] != path:  # (asked twice for an instance: its state, then its read)
            found = not prim.IsA(UsdGeom.Gprim) and not self.clips_above(prim) and all(
                name == XFORM_OP_ORDER or name.startswith("xformOp:") for name in prim.GetAuthoredPropertyNames())
            self._transform_only_kept = path, found
        return self._transform_only_kept[1]

    def _sibling_key(self, prim: Usd.Prim, prototype: Usd.Prim, ctx: Context, purpose, hidden: frozenset):
        """The key under which the world-level native instance ``prim`` shares :meth:`_instance_key`'s answer with its
        siblings (``sibling_reads``), or None where it may not. Of instances under one parent, of one prototype,
        purpose and hidden purposes, that author nothing but their transform (:meth:`_transform_only`), each reads
        the same: their bindings, colours, opacity, widths and texture coordinates are their ancestors'; unless a
        collection is bound above them (one may hold some of them and not others). 10k instances of a few
        prototypes in rows of 100: each read its bindings and primvars again (a third of its read)."""
        if not self._transform_only(prim, ctx):
            return None
        if self.materials.bindings_above.any(prim) and self.collections_inside.bound_above(prim):
            return None
        return str(prototype.GetPath()), purpose, hidden, prim.GetPath().GetParentPath()

    def _shared_prototype(self, prototype: Usd.Prim, binding_prim: Usd.Prim, ctx: Context, purpose,
                          hidden: frozenset) -> tuple:
        """``(content, key)`` of the prototype of native instance ``binding_prim`` (in its container's namespace,
        see :meth:`_binding_prim`), read once for all instances whose bindings change no walk inside it."""
        missing = set()  # purposes whose walk finds nothing up to the root of this instance's container
        outer = self.materials.instance_bindings(binding_prim, ctx.outer_bindings, missing)
        path = str(prototype.GetPath())
        # Read once without them; again with them where they change a walk inside: one of them is bound
        # strongerThanDescendants, or gives a purpose that some walk inside finds nothing for.
        forced = outer is not None and any(entry.stronger for entry in outer)
        key = ("native", path, None, purpose, None, None, None, None, hidden)
        content = None if forced else self._content(key, prototype, None, None, purpose, outer_hidden=hidden)
        if forced or (outer is not None and any(entry.purpose in content.outer_purposes for entry in outer)):
            key = ("native", path, outer, purpose, None, None, None, None, hidden)
            content = self._content(key, prototype, None, outer, purpose, outer_hidden=hidden)
        # Purposes that neither the prototype nor this instance binds: its container's instances may.
        ctx.content.outer_purposes |= content.outer_purposes & missing
        return content, key

    def _read_through_instances(self, prim: Usd.Prim, relatives: list, ctx: Context, listed: str, read, what: str,
                                place=None):
        """The prims at paths ``relatives`` to ``prim`` (one prim itself, ``.``, or those of native instance
        ``prim``, relative to its prototype), which are read where they are placed, not as geometry: in the world,
        each through ``read(proxy)`` at its instance-proxy path (``/Instance/Cam``, which USD places in the world);
        inside a native prototype, handed on to it (``ctx.content``'s list ``listed``) to be read through each of
        its instances; inside a PointInstancer's prototype each through ``place(proxy)`` (to be read once per
        instance), or, without ``place``, skipped with a warning naming ``what`` they are."""
        if not relatives:
            return
        proxies = (self.stage.GetPrimAtPath(prim.GetPath().AppendPath(relative)) for relative in relatives)
        if ctx.world:
            for proxy in proxies:
                read(proxy)
        elif ctx.space_root is None:
            here = prim.GetPath().MakeRelativePath(Sdf.Path(ctx.content.path))
            getattr(ctx.content, listed).extend(here.AppendPath(relative) for relative in relatives)
        elif place is not None:
            for proxy in proxies:
                place(proxy)
        else:
            self._skip(f"{what} inside PointInstancer prototypes are not supported; skipped", prim)

    def _copy_with(self, key: tuple, copies: dict, value, limit: int, what: str, prim: Usd.Prim, **inherited) -> tuple:
        """The key of the native prototype read under ``key`` read again with an inherited value (``color``:
        ``((primvar, (r, g, b)), ...)``, ``widths``: a float, or ``uv``: ``((primvar, (s, t)), ...)``) in place of the
        key's, remembered in ``copies`` (that content's ``colors``, ``widths`` or ``uvs``) by ``value``. Each is a
        copy of the prototype's geometry, so past
        ``limit`` of them per prototype the instance keeps the prototype's own ``what`` (with a warning)."""
        if value not in copies:
            if len(copies) >= limit:
                self._skip(f"instances inheriting more than {limit} {what} per prototype keep its own {what} (each is "
                           "a copy of the prototype)", prim)
                return key
            _, path, outer, purpose, color, proxy, widths, uv, hidden = key
            color, widths = inherited.get("color", color), inherited.get("widths", widths)
            uv = inherited.get("uv", uv)
            copy = ("native", path, outer, purpose, color, proxy, widths, uv, hidden)
            self._content(copy, self.stage.GetPrimAtPath(path), None, outer, purpose, outer_color=color,
                          outer_widths=widths, proxy=proxy, outer_uv=uv, outer_hidden=hidden)
            copies[value] = copy
        return copies[value]

    def _inherited_widths(self, prim: Usd.Prim) -> float | None:
        """The constant ``primvars:widths`` native instance ``prim`` hands down (its own or its nearest ancestor's, up
        to the root of the prototype ``prim`` is in; its first value), or None."""
        primvar = self._inheritable_primvars(prim).get("widths")
        if primvar is None:
            return None
        values = flattened(primvar, self.time, primvar.GetAttr().GetPrim(), self._skip)
        values = np.asarray(values if values is not None else [], np.float64).reshape(-1)
        if not len(values):
            return None
        return float(values[0]) if not math.isnan(values[0]) else _NAN

    def _inherited_uvs(self, prim: Usd.Prim, ctx: Context, names: list[str]) -> tuple:
        """The constant texture-coordinate primvars of ``names`` that native instance ``prim`` hands down to its
        prototype's meshes lacking them, as ``((name, (s, t)), ...)``: its own or its nearest ancestor's (up to the
        root of the prototype ``prim`` is in; the first two components of its first value), else the one its
        container inherits (``ctx.outer_uv``) where nothing up to that root has the primvar (the names it has not
        may come from above its container, :meth:`Content.want_uvs`). A non-constant one on it or above it blocks."""
        above = dict(ctx.outer_uv or ())
        found = []
        for name in names:
            primvar = self.inherited_primvars.lookup(prim, name)
            if primvar is None or primvar is PER_INSTANCE:  # (a PointInstancer's st of each instance is handed down)
                ctx.content.want_uvs([name])
                st = above.get(name)
            elif primvar and primvar.GetInterpolation() == UsdGeom.Tokens.constant:
                st = self._first_st(primvar)
            else:  # blocked
                st = None
            if st is not None:
                found.append((name, st))
        return tuple(sorted(found))

    def _first_st(self, primvar: UsdGeom.Primvar) -> tuple | None:
        """The first two components of the first value of constant primvar ``primvar`` (2-, 3- or 4-vectors), or None
        when it holds none or is no array of such vectors (dropped with a warning, as a mesh's own)."""
        attr = primvar.GetAttr()
        holder = attr.GetPrim()
        raw = flattened(primvar, self.time, holder, self._skip)
        values = np.asarray(raw if raw is not None else [])
        if values.ndim != 2 or values.shape[1] not in (2, 3, 4) or values.dtype.kind not in "fiu" \
                or quaternion_typed(attr, self.time):  # (read as 4-vectors; a mesh drops its own)
            self._skip(f"{attr.GetName()} values that are not an array of 2-, 3- or 4-vectors were ignored", holder,
                       f"{self._authored_type(attr)} holding {type(raw).__name__}")
            return None
        if not len(values):  # st = []: an array of vectors, empty (it was named as no array of them), as a mesh's own
            self._skip(PRIMVAR_DROPPED, holder, f"{attr.GetName()} has 0 values; constant interpolation needs 1")
            return None
        st = past_float32_as_inf(values[0, :2])  # (a double past float32: inf, as the mesh's float32 st holds it)
        if not np.isfinite(st).all():  # as a mesh's own (MeshPrimvarReading._read_uvs)
            self._skip("texture coordinates that are not finite were read as none: the textures there show their "
                       "fallback", holder, f"{primvar.GetPrimvarName()}, constant, handed down to a prototype")
        # NaN as the one object: otherwise each instance's NaN st, a new float, was a new value (and a new copy of
        # the prototype) until the copies ran out, past which instances read the reader's fallback st instead.
        return tuple(_NAN if math.isnan(v) else v for v in st.tolist())


def _wanted(content, before=None) -> tuple:
    """What ``content`` has been told its prototypes lack (outer purposes, colours, widths, texture coordinates), or
    with ``before`` (an earlier answer) what was added since: :meth:`NativeInstanceReading._instance_key`'s telling,
    which :func:`_want` tells again (each telling only adds, in order)."""
    now = (set(content.outer_purposes), list(content.outer_colors), content.wants_widths, list(content.outer_uvs))
    if before is None:
        return now
    return (now[0] - before[0], [n for n in now[1] if n not in before[1]], now[2] and not before[2],
            [n for n in now[3] if n not in before[3]])


def _want(content, wanted: tuple) -> None:
    """Tells ``content`` again what :func:`_wanted` found added."""
    purposes, colors, widths, uvs = wanted
    content.outer_purposes |= purposes
    content.want_colors(colors)
    content.wants_widths = content.wants_widths or widths
    content.want_uvs(uvs)
