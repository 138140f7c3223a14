"""``UsdGeom.PointInstancer`` instances: prototypes, ``protoIndices``, positions, orientations and scales (moved by
velocities as USD moves them) and the visibility mask; the instancer's primvars (``displayColor``,
``displayOpacity``, texture coordinates, ``widths``) are read by :mod:`wrt.usd_instancer_primvars`."""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, UsdGeom, Vt

from .instancing import group_rows
from .light_links import part_path
from .usd_contents import Content, Context, instance_looks, placed_indices, placed_name, placements
from .usd_instancer_primvars import InstancerPrimvarReading
from .usd_lights import UNRENDERED_PURPOSE, read_light, sphere_inputs
from .usd_placed_lights import placed_lights
from .usd_problems import authored_type
from .usd_values import held_value, spun_rotations, value_at

MISSING_PROTOTYPE = "missing"  # a prototypes target that names no prim (its instances are skipped)


class PointInstancerReading(InstancerPrimvarReading):
    """PointInstancer reading of the stage reader (``stage``, ``time``, ``contents``); the instancer's primvars are
    read by :class:`wrt.usd_instancer_primvars.InstancerPrimvarReading`."""

    def _read_instancer(self, prim: Usd.Prim, ctx: Context):
        """Instances of a ``UsdGeom.PointInstancer`` (see the module docstring), added to ``ctx.content`` prototype
        by prototype."""
        pi = UsdGeom.PointInstancer(prim)
        targets, protos = self._prototype_roots(prim, pi)
        proto_indices, in_range = self._proto_indices(prim, pi, len(protos))
        n = len(proto_indices)
        if n == 0:
            return
        m, parts = self._instance_transforms(prim, pi, n)
        if m is None:
            return
        colors_by_name = {}  # colour primvar -> (n, 3) colours of the instances, or None
        uvs_by_name = {}  # texture-coordinate primvar -> (n, 2) st of the instances (NaN: none), or None
        widths_by_name = {}  # "widths" -> (n,) primvars:widths of the instances, or None (read once, when wanted)
        opacities = self._instance_opacities(prim, n)
        keep = self._instance_mask(prim, pi, n)
        if keep is None:
            return
        keep &= in_range
        keep &= self._finite_instances(prim, m, parts, keep)
        to_space = self._to_space(prim, ctx)
        if to_space is None:  # named in a warning, and left out
            return
        with np.errstate(invalid="ignore", over="ignore"):  # the non-finite instances (left out by keep)
            to_space = to_space.T @ m
        # The kept instances of each prototype in index order, from one stable sort (a scan of every instance per
        # prototype took 6 s for 10000 prototypes and 1M instances).
        kept = np.flatnonzero(keep)
        # The purposes hidden on and above the instancer hide its prototypes' prims that have no opinion of their own
        # up to the root, as they hide a native instance's: an instancer invisible for its purpose drew its instances.
        hidden = self._hidden_purposes(prim, ctx)
        for path, target, group in zip(targets, protos, group_rows(proto_indices[kept], len(protos))):
            rows = kept[group]
            if len(rows) == 0:
                continue
            if target is MISSING_PROTOTYPE:
                # UsdImaging warns ("Targeted prototype was not found") and draws the other prototypes' instances.
                self._skip("instances of PointInstancer prototypes that do not exist were skipped", prim,
                           f"{path}, {len(rows)} of {n} instances")
                continue
            if target is None:
                self._skip("instances of inactive PointInstancer prototypes (or of prototypes under an inactive "
                           "prim) were skipped", prim, str(path))
                continue
            if not target.HasDefiningSpecifier():
                # An over holds opinions, no prim: Hydra's prototype predicate leaves it out, and what it holds.
                self._skip("instances of PointInstancer prototypes that are not defined (an over, not a def) were "
                           "skipped", prim, str(path))
                continue
            if target.IsAbstract():
                # A class, or a prim under one: Hydra's prototype predicate leaves it out (it drew nothing, unwarned).
                self._skip("instances of PointInstancer prototypes that are class prims (or under one) were skipped, "
                           "as Hydra skips them", prim, str(path))
                continue
            if prim.GetPath().HasPrefix(target.GetPath()):
                # The prototype is the instancer or an ancestor of it: each instance holds the instancer again, without
                # end (a cycle USD cannot compute). Its instances were drawn one level deep (the prototype without the
                # instancer's own instances, skipped below as an instance of itself), which is arbitrary.
                self._skip("PointInstancer instances of a prototype that holds the instancer itself (the instancer or "
                           "an ancestor of it: a cycle) were skipped", prim, f"{path}, {len(rows)} of {n} instances")
                continue
            if any(k[:2] == ("pi", str(target.GetPath())) for k in self.reading):
                # A prototype being read that holds an instancer of itself would hold itself without end (the other
                # prototypes' instances, and this one's at the levels above, are drawn): it stopped the whole load.
                self._skip("PointInstancer instances of a prototype that holds them (an instance of itself) were "
                           "skipped", prim, f"{path}, {len(rows)} of {n} instances")
                continue
            # The prototype's space is its parent's: the root's own transform is the most local part. Its purpose,
            # where nothing in it authors one, is the one its ancestors author (_prototype_purpose).
            purpose = self._prototype_purpose(target, prim, ctx, hidden)
            beneath = target.GetPath().HasPrefix(prim.GetPath())
            # A constant displayOpacity reaches the prototypes beneath the instancer by inheritance, as a constant
            # colour does (below); the instance opacities the others get reach prims without one past a non-constant
            # one above them (Context.blocked_opaque), as instance colours do: prototypes are read apart for each.
            target_opacities = None if beneath and self._constant_primvar(prim, "displayOpacity") else opacities
            parent = target.GetParent()

            def read_with(outer_uv, outer_widths=ctx.outer_widths, target=target, parent=parent, purpose=purpose,
                          opaque=target_opacities is None):
                key = ("pi", str(target.GetPath()), ctx.outer_bindings, ctx.outer_color, purpose, ctx.proxy,
                       outer_widths, not opaque, outer_uv, hidden)
                return key, self._content(key, target, parent, ctx.outer_bindings, purpose,
                                          outer_color=ctx.outer_color, outer_widths=outer_widths, proxy=ctx.proxy,
                                          instance_opacity=not opaque, outer_uv=outer_uv,
                                          outer_hidden=hidden)

            key, content = read_with(ctx.outer_uv)
            # The prototype's prims walk up through this instancer's ancestors: what they lack, this content lacks.
            ctx.content.outer_purposes |= content.outer_purposes
            if content.wants_widths and "widths" not in widths_by_name:
                widths_by_name["widths"] = self._instance_widths(prim, n, beneath)
            ctx.content.wants_widths |= content.wants_widths and widths_by_name.get("widths") is None
            uv_groups = self._instance_uv_groups(prim, n, content.outer_uvs, beneath, rows, ctx, uvs_by_name)
            ctx.content.want_uvs([name for name in content.outer_uvs if uvs_by_name.get(name) is None])
            ctx.content.want_colors(content.outer_colors)
            name = self._instance_color_name(prim, content.outer_colors)
            if name is not None and beneath and self._constant_primvar(prim, name):
                # A constant colour on the instancer reaches the prototypes beneath it by inheritance, read with their
                # geometry, and stops at a non-constant primvar of its name between (FindPrimvarWithInheritance);
                # Hydra makes only non-constant ones instance primvars. As an instance colour it went past that.
                name = None
            if name not in colors_by_name:
                colors_by_name[name] = None if name is None else self._instance_colors(prim, n, name)
            looks = instance_looks(colors_by_name[name], target_opacities)
            widths = widths_by_name.get("widths") if content.wants_widths else None
            for outer_uv, uv_rows in uv_groups:
                for outer_widths, group in self._instance_width_groups(prim, widths, uv_rows, ctx):
                    # Each distinct st or width the instancer gives is a copy of the prototype read with it
                    # (Context.outer_uv, Context.outer_widths).
                    same = (outer_uv, outer_widths) == (ctx.outer_uv, ctx.outer_widths)
                    group_key, group_content = (key, content) if same else read_with(outer_uv, outer_widths)
                    ctx.content.uv_misses += group_content.uv_misses
                    ctx.content.instances.append((group_key, to_space[group], str(prim.GetPath()),
                                                  group.astype(np.int32), None if looks is None else looks[group]))

    def _read_placed_lights(self, world: Content):
        """Appends to the scene one light per instance of each UsdLux light kept inside a PointInstancer's prototype
        (``Content.placed_lights``; nested instancers and native instances resolved as for the geometry,
        :func:`wrt.usd_contents.placements`), read as that light authored at its world transform (the instance's
        times its own in the prototype): sizes, normalization, shaping and links as there. Each is named by its
        path (an instance-proxy path inside native instances) and its index in each instancer, outermost first
        (``/Lamps/Proto/Light[3]``; ``/Protos/Light[/Lamps[3]]`` for an instancer it does not lie beneath,
        :func:`wrt.usd_contents.placed_name`); warnings name it so. They come in instance order, as the instances
        do."""
        if not any(content.placed_lights for content in self.contents.values()):
            return  # walking every placement (64,000 nested instances: a second) to find no light
        found, sources = [], {}  # (world-level source, indices at each level, light); source -> stage order
        for placement in placements(world, self.contents):
            for prim, to_space, purpose in placement.content.placed_lights:
                path = part_path(str(prim.GetPath()), placement.content.path, placement.root)
                indices = [placed_indices(placement.levels, row) for row in range(len(placement.to_world))]
                names = [placed_name(path, found_at, placement.makers) for found_at in indices]
                if purpose not in self.purposes:  # each instance named, as the world's lights are (wrt.usd)
                    for name in names:
                        self._skip_path(UNRENDERED_PURPOSE, name, f"purpose = {purpose}")

                def read(to_world, skip, prim=prim):
                    return read_light(prim, self.xforms, self.time, self.scene.up_axis, skip, to_world=to_world,
                                      textures=self.light_textures)

                lights = placed_lights(placement.to_world @ to_space, names, read, self._skip_path,
                                       lambda prim=prim: sphere_inputs(prim, self.time))
                source = sources.setdefault(placement.source, len(sources))
                found += [(source, at, light) for at, light in zip(indices, lights) if light is not None]
        self.scene.lights += [light for *_, light in sorted(found, key=lambda entry: entry[:2])]

    def _prototype_roots(self, prim: Usd.Prim, pi: UsdGeom.PointInstancer) -> tuple[list, list]:
        """The ``prototypes`` targets of ``pi`` and their prims, None for one that is inactive or under an inactive
        prim, :data:`MISSING_PROTOTYPE` for one that does not exist (the instances of both are skipped with a
        warning). A target that is a relationship stands for the targets USD forwards it to, as UsdImaging reads
        them (``GetForwardedTargets``), ``protoIndices`` indexing that list: its instances were skipped as of a
        prototype that does not exist."""
        targets = pi.GetPrototypesRel().GetForwardedTargets()
        protos = []
        for k, path in enumerate(targets):
            target = self.stage.GetPrimAtPath(path)
            if target and target.IsActive():
                protos.append(target)
            elif any(p and not p.IsActive() for p in map(self.stage.GetPrimAtPath, path.GetPrefixes())):
                protos.append(None)  # deactivated, as Hydra finds it: drawn nowhere (below, with a warning)
            else:  # it stopped the whole load with SceneError
                protos.append(MISSING_PROTOTYPE)
        return targets, protos

    def _proto_indices(self, prim: Usd.Prim, pi: UsdGeom.PointInstancer, n_protos: int) -> tuple:
        """``(n,)`` int64 ``protoIndices`` of ``pi`` and ``(n,)`` bool: those in range of its ``n_protos`` prototypes.
        The instances of the others (negative, or past the last prototype, as all are where ``prototypes`` targets
        nothing) are skipped with a warning saying how many, as UsdImaging skips them ("Invalid index found"); they
        stopped the whole load with SceneError. ``protoIndices`` of another type than ``int[]`` (``float[]``,
        ``int64[]``) give none, with a warning: ``ComputeInstanceTransformsAtTime`` computes no instances for them, and
        Hydra draws none (the floats were truncated without a word)."""
        attr = pi.GetProtoIndicesAttr()
        raw = value_at(attr, self.time)
        if raw is not None and not isinstance(raw, Vt.IntArray):
            self._skip("PointInstancers whose protoIndices are not int[] were skipped (USD computes no instances for "
                       "them)", prim, f"protoIndices is {self._authored_type(attr)}")
            return np.zeros(0, np.int64), np.zeros(0, bool)
        proto_indices = np.asarray(raw if raw is not None else [], np.int64).reshape(-1)
        in_range = (proto_indices >= 0) & (proto_indices < n_protos)
        if not in_range.all():
            i = int(np.argmin(in_range))
            self._skip("PointInstancer instances whose protoIndices are out of range of its prototypes were skipped",
                       prim, f"{int((~in_range).sum())} of {len(in_range)} instances, the first protoIndices[{i}] = "
                       f"{proto_indices[i]} for {n_protos} prototypes")
        return proto_indices, in_range

    def _instance_transforms(self, prim: Usd.Prim, pi: UsdGeom.PointInstancer, n: int) -> tuple:
        """``(n, 4, 4)`` column-vector transforms of the ``n`` instances of ``pi`` in its own space, their attributes
        read by :func:`held_value` when velocities move them, else by :func:`value_at` (its primvars are read by
        :func:`value_at` either way, as USD's are: :mod:`wrt.usd_instancer_primvars`), and the ``(name, (n, ...)
        values)`` of the attributes the transforms are made of (for :meth:`_finite_instances`).
        The transforms are None, with a warning, where ``positions`` is missing, blocked, shorter or longer than
        ``protoIndices``: ``ComputeInstanceTransformsAtTime`` computes none then (it warns, and Hydra draws nothing)."""
        t = self.time

        def per_instance(attr, width, name, default, value):
            if value is None or len(value) == 0:
                return None if default is None else np.tile(default, (n, 1))
            array = np.asarray(value, np.float64).reshape(len(value), -1)
            if default is not None and array.shape[1] == width and len(array) < n:
                # ComputeInstanceTransformsAtTime warns about these ("found [2] scales, but expected [3]") and then
                # reads past their end; Storm drops an instance primvar shorter than the instances. Read as unauthored
                # (identity), the rest of the instancer drawn: it stopped the whole load with SceneError.
                self._skip("PointInstancer orientations or scales shorter than protoIndices were ignored (read as "
                           "unauthored)", prim, f"{len(array)} {name} for {n} protoIndices")
                return None
            if array.shape != (len(value), width) or len(array) < n:
                raise self._error(f"{name} has {len(array)} entries; protoIndices has {n}", prim, attr)
            if len(array) > n and default is not None:
                # ComputeInstanceTransformsAtTime warns about these and uses the first n, as here.
                self._skip("PointInstancer orientations or scales longer than protoIndices: the entries past them "
                           "were ignored", prim, f"{len(array)} {name} for {n} protoIndices")
            return array[:n] if default is not None else array  # positions: the caller checks the length

        positions_attr, scales_attr = pi.GetPositionsAttr(), pi.GetScalesAttr()
        orient_attr, passed_over = _orientations_attr(pi)
        if passed_over is not None:
            self._skip("PointInstancer orientationsf authored as another type than quatf[] was passed over for the "
                       "orientations beside it, as USD reads them", prim, f"orientationsf is {passed_over}")
        # ComputeInstanceTransformsAtTime reads each as its schema type only (point3f[], quath[] or quatf[], float3[]):
        # positions of another (float[], double3[]) give no instances, orientations or scales of another are none. A
        # float[] raised SceneError; a double3[] or float4[] one was read as if of the schema's type.
        if not self._of_schema_type(positions_attr):
            self._skip("PointInstancers whose positions are not of the schema's type (point3f[]) were skipped (USD "
                       "computes no instance transforms for them)", prim,
                       f"positions is {self._authored_type(positions_attr)}")
            return None, None
        ignored = [a for a in (orient_attr, scales_attr) if not self._of_schema_type(a)]
        for attr in ignored:
            self._skip("PointInstancer orientations or scales not of the schema's type were ignored (read as "
                       "unauthored, as USD reads them)", prim, f"{attr.GetName()} is {self._authored_type(attr)}")
        moved = self._moved(pi, positions_attr)
        wrong_lengths = []
        spun = None if orient_attr in ignored else spun_rotations(
            orient_attr, pi.GetAngularVelocitiesAttr(), t, self.stage.GetTimeCodesPerSecond(), wrong_lengths)
        self._skip_wrong_rates(prim, wrong_lengths)
        # With usable velocities or angular velocities USD holds every attribute at its sample at or before the
        # time and moves from there; without, it interpolates them all.
        read = held_value if moved is not None or spun is not None else value_at
        raw = moved if moved is not None else _value_if_any(positions_attr, t, read)
        if raw is None or len(raw) < n:
            # ComputeInstanceTransformsAtTime computes none (it warns "no positions"), and Hydra draws none: the rest
            # of the stage is drawn. It stopped the load, for a missing or blocked positions too.
            blocked = raw is None and positions_attr.GetResolveInfo(t).ValueIsBlocked()
            found = "blocked" if blocked else "no" if raw is None else f"{len(raw)}"
            self._skip("PointInstancers with fewer positions than protoIndices were skipped (USD computes no instance "
                       "transforms for them)", prim, f"{found} positions for {n} protoIndices")
            return None, None
        positions = per_instance(positions_attr, 3, "positions", None, raw)
        if len(positions) > n:
            self._skip("PointInstancers whose positions are longer than protoIndices were skipped (USD computes no "
                       "instance transforms for them)", prim, f"{len(positions)} positions for {n} protoIndices")
            return None, None
        quats = per_instance(orient_attr, 4, str(orient_attr.GetName()), np.array([0.0, 0.0, 0.0, 1.0]),
                             None if orient_attr in ignored else
                             spun[0] if spun is not None else _value_if_any(orient_attr, t, read))
        if quats is None:  # ignored, and the angular velocities that turn them with them
            quats, spun = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), None
        scales = per_instance(scales_attr, 3, "scales", np.ones(3),
                              None if scales_attr in ignored else _value_if_any(scales_attr, t, read))
        if scales is None:
            scales = np.ones((n, 3))

        # Column-vector instance transforms: translate(position) @ spin @ rotate(orientation) @ scale(scale).
        m = np.zeros((n, 4, 4))
        with np.errstate(invalid="ignore", over="ignore"):  # non-finite instances are left out below
            m[:, :3, :3] = _quat_to_matrix(quats) * scales[:, None, :]
            if spun is not None:
                m[:, :3, :3] = spun[1][:n] @ m[:, :3, :3]
        m[:, :3, 3] = positions
        m[:, 3, 3] = 1.0
        velocity_names = "positions (moved by velocities or accelerations)" if moved is not None else "positions"
        spin_name = f"{orient_attr.GetName()} (turned by angularVelocities)"
        parts = [(velocity_names, positions), (str(orient_attr.GetName()), quats), ("scales", scales)]
        parts += [(spin_name, spun[1][:n])] if spun is not None else []
        return m, parts

    def _of_schema_type(self, attr: Usd.Attribute) -> bool:
        """``attr`` holds no value, or one of its schema's value type (``float3[]`` for ``point3f[]``: roles aside),
        or, for orientations, a quaternion array of either precision: a ``quatf[] orientations`` (common in files
        written by scripts) is taken as the rotation it plainly is, as wrt always read it, though
        ``ComputeInstanceTransformsAtTime`` reads only ``quath[]`` there."""
        authored = Sdf.ValueTypeNames.Find(self._authored_type(attr))
        if not attr.HasValue():
            return True
        if not authored:
            return False
        quaternions = {Sdf.ValueTypeNames.QuathArray.type, Sdf.ValueTypeNames.QuatfArray.type}
        if attr.GetTypeName().type in quaternions:
            return authored.type in quaternions
        return authored.type == attr.GetTypeName().type

    def _finite_instances(self, prim: Usd.Prim, m: np.ndarray, parts: list, shown: np.ndarray) -> np.ndarray:
        """``(n,)`` bool: the instances whose transform ``m`` (``(n, 4, 4)``) is finite. The others of ``shown`` (the
        instances drawn but for this) are left out with a warning naming the attribute (of ``parts``, ``(name, (n,
        ...) values)``) and how many: it stopped the whole load with SceneError. ``ComputeInstanceTransformsAtTime``
        hands back their non-finite matrices without a word, and a renderer can place such an instance nowhere; the
        other instances are drawn. One hidden anyway (``invisibleIds``, a ``protoIndices`` out of range) is not
        named: USD computes no matrix for a hidden one, and it was counted as skipped for its NaN."""
        finite = np.isfinite(m).all(axis=(1, 2))
        if finite[shown].all():
            return finite
        n, unnamed = len(m), ~finite & shown
        for name, values in parts:
            bad = ~np.isfinite(values.reshape(n, -1)).all(axis=1) & shown
            if bad.any():
                self._skip("PointInstancer instances with non-finite (NaN or inf) positions, orientations, scales or "
                           "velocities were skipped", prim, f"{int(bad.sum())} of {n} instances by {name}")
                unnamed &= ~bad
        if unnamed.any():  # finite parts whose product overflows
            self._skip("PointInstancer instances with non-finite (NaN or inf) positions, orientations, scales or "
                       "velocities were skipped", prim, f"{int(unnamed.sum())} of {n} instances by a transform that "
                       "overflows")
        return finite

    def _instance_mask(self, prim: Usd.Prim, pi: UsdGeom.PointInstancer, n: int) -> np.ndarray | None:
        """``(n,)`` bool: the instances of ``pi`` that ``invisibleIds`` and ``inactiveIds`` leave drawn; None, with a
        warning, where they hide some of ``ids`` of another length than ``protoIndices``."""
        keep = np.ones(n, bool)
        # As ComputeMaskAtTime computes it (inactiveIds' explicit items and invisibleIds name instances by their
        # ids, else by index; nothing named, no mask), but with invisibleIds and ids each read by value_at's
        # default-time rule, as positions are: ComputeMaskAtTime read the ids (or protoIndices, without ids) at
        # invisibleIds' time, so at the default time a still invisibleIds beside sampled ids found none and hid nothing.
        inactive = prim.GetMetadata("inactiveIds")
        invisible = self._ids_array(prim, pi.GetInvisibleIdsAttr(), "hide no instance")
        named = np.union1d(np.asarray(inactive.explicitItems if inactive else [], np.int64),
                           np.asarray(invisible if invisible is not None else [], np.int64).reshape(-1))
        if len(named) == 0:
            return keep
        ids = self._ids_array(prim, pi.GetIdsAttr(), "name no instance: instances are named by index")
        if ids is None:  # unauthored, or blocked at this time: instances are named by index
            ids = np.arange(n)
        shown = ~np.isin(np.asarray(ids, np.int64).reshape(-1), named)
        if shown.all():
            return keep
        if len(shown) != n:
            # The mask has one entry per id, and ComputeInstanceTransformsAtTime computes no instance where its length
            # is not protoIndices' (it warns): nothing is drawn, the rest of the stage is. Shorter ids stopped the
            # load with SceneError; longer ones were cut without a word.
            self._skip("PointInstancers whose ids are not as many as protoIndices while invisibleIds or inactiveIds "
                       "hide some were skipped (USD computes no instance transforms for them)", prim,
                       f"{len(shown)} ids for {n} protoIndices")
            return None
        keep &= shown
        return keep

    def _ids_array(self, prim: Usd.Prim, attr: Usd.Attribute, meaning: str):
        """``attr`` (``invisibleIds`` or ``ids``) at the reader's time, or None where it has no value or is of another
        type than ``int64[]`` (with a warning saying what that ``meaning``s): ``ComputeMaskAtTime`` reads no values
        from an ``int[]``, ``float[]`` or ``string[]`` one (Hydra's mask), where wrt read them as ids (invisibleIds
        hid instances USD draws), and letters stopped the load with SceneError."""
        raw = value_at(attr, self.time)
        if raw is not None and not isinstance(raw, Vt.Int64Array):
            self._skip(f"PointInstancer {attr.GetName()} of another type than int64[] were ignored, as USD ignores "
                       f"them: they {meaning}", prim, f"{attr.GetName()} is {self._authored_type(attr)}")
            return None
        return raw


def _orientations_attr(pi: UsdGeom.PointInstancer) -> tuple[Usd.Attribute, str | None]:
    """``(attr, passed_over)``: the orientations attribute of ``pi`` that USD reads (``UsesOrientationsf``):
    ``orientationsf`` where its value at the earliest time is a non-empty ``quatf[]``, else ``orientations`` at every
    time; and the type of an ``orientationsf`` of another type passed over for ``orientations`` (else None). Any
    authored ``orientationsf`` was taken: an empty one, which exporters write beside the ``quath[]`` they fill, left
    every instance unrotated, and a ``quath[]`` or ``float4[]`` one, which USD's typed read gets no value from,
    replaced the ``orientations`` beside it. A lone ``quath[] orientationsf`` is still read as the rotation it plainly
    is (:meth:`PointInstancerReading._of_schema_type`)."""
    orientationsf, orientations = pi.GetOrientationsfAttr(), pi.GetOrientationsAttr()
    earliest = orientationsf.Get(Usd.TimeCode.EarliestTime()) if orientationsf.HasValue() else None
    filled = earliest is not None and hasattr(earliest, "__len__") and len(earliest) > 0  # (a scalar: mistyped)
    if not filled or isinstance(earliest, Vt.QuatfArray):
        return (orientationsf if filled else orientations), None
    if not orientations.HasValue():
        return orientationsf, None
    return orientations, authored_type(orientationsf, Usd.TimeCode.EarliestTime())


def _value_if_any(attr: Usd.Attribute, time: Usd.TimeCode, read):
    """``read(attr, time)`` (:func:`value_at` or :func:`held_value`), or None when ``attr`` has no value."""
    return read(attr, time) if attr.HasValue() else None


def _quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` matrices (column vectors) of ``(N, 4)`` quaternions stored ``(i, j, k, real)`` as ``Gf.Quat*``
    arrays are, built from the quaternion as stored, without normalising, as ``ComputeInstanceTransformsAtTime``
    (``GfMatrix4d::SetRotate``) and Storm's instancing shader build them: a ``quath`` off unit length by its half
    precision (up to 2e-3 of the instance's size) or an authored quaternion of another length (schema-invalid) places
    the instance where USD and usdview place it, a non-rigid matrix (a zero quaternion is the identity)."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )
