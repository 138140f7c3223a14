"""Which prims the stage reader draws: visibility (each prim's answer kept, per stop), purpose and
UsdGeomVisibilityAPI's purpose visibility (``renderVisibility`` ... hiding a drawn purpose other than default, as
``ComputeEffectiveVisibility(purpose)``), computed from a native instance's or PointInstancer prototype's root down
as USD computes them through instance proxies (a PointInstancer prototype's visibility from its root down, as
UsdImaging takes it; its purpose through its ancestors too; the purposes hidden on and above an instance or
instancer reach its prototype's prims that have no opinion of their own)."""

from __future__ import annotations

from pxr import Usd, UsdGeom

from .usd_contents import Context
from .usd_values import token_typed, value_at


class Visibility:
    """Visibility and purpose filters of the stage reader (``time``, ``purposes``, ``visibility``,
    ``placement_memo``: a kept stage's :class:`wrt.usd_placement_memo.PlacementMemo` or None,
    ``computed_purposes``: a :class:`wrt.usd_ancestors.ComputedPurposes`)."""

    def _visible(self, prim: Usd.Prim, stop: Usd.Prim | None = None) -> bool:
        """No ancestor up to ``stop`` (or the root) invisible. Each visibility is read as mesh attributes are
        (``value_at``), so with ``time=None`` a prim hidden only by its first time sample is hidden, as its points are
        that sample's."""
        # Each prim's answer is kept (per stop): asking every prim of a deep hierarchy walked all its ancestors,
        # quadratic in the depth (a mesh under each of 1000 nested Xforms took 10 s). A kept stage keeps those of
        # chains whose visibility cannot vary for its later loads (still).
        memo = self.placement_memo
        still = {} if memo is None else memo.visible(self.time)
        stop_path = stop.GetPath() if stop else None
        chain = []  # (key, prim) from prim up to the first ancestor already known, the stop or the root
        visible, is_still = True, memo is not None
        p = prim
        while p and p != stop and not p.IsPseudoRoot():
            key = (p.GetPath(), stop_path)
            if key in still:
                visible = still[key]
                break
            if key in self.visibility:  # read in this load: its chain might vary
                visible, is_still = self.visibility[key], False
                break
            chain.append((key, p))
            p = p.GetParent()
        for key, p in reversed(chain):
            if visible:
                img = UsdGeom.Imageable(p)
                attr = img.GetVisibilityAttr() if img else None  # a string "invisible" hid it; USD draws it
                visible = not (attr and value_at(attr, self.time) == UsdGeom.Tokens.invisible and token_typed(attr))
            self.visibility[key] = visible
            is_still = is_still and memo.visibility_still(p)
            if is_still:
                still[key] = visible
        return visible

    def _purpose(self, prim: Usd.Prim, ctx: Context):
        """The purpose of ``prim``: its own or its nearest ancestor's authored purpose below ``ctx.stop``, else the
        one a native instance inherited (``ctx.outer_purpose``), else default."""
        if ctx.stop is None and ctx.outer_purpose is None:
            return self.computed_purposes.purpose(prim)  # ComputePurpose, each ancestor's answer kept
        own = self._nearest_purpose(prim, ctx)
        return own if own is not None else ctx.outer_purpose or UsdGeom.Tokens.default_

    def _nearest_purpose(self, prim: Usd.Prim, ctx: Context):
        """The purpose authored on ``prim`` or its nearest ancestor below ``ctx.stop`` that authors one (as
        ``ComputePurpose`` reads it), or None where none does."""
        p = prim
        while p and p != ctx.stop and not p.IsPseudoRoot():
            img = UsdGeom.Imageable(p)
            attr = img.GetPurposeAttr() if img else None
            if attr is not None and attr.HasAuthoredValue():
                return attr.Get() if token_typed(attr) else UsdGeom.Tokens.default_
            p = p.GetParent()
        return None

    def _prototype_purpose(self, root: Usd.Prim, instancer: Usd.Prim, ctx: Context, hidden: frozenset = frozenset()):
        """The purpose that prototype ``root`` of PointInstancer ``instancer`` (read in ``ctx``) inherits, when it is
        one not drawn, one of ``hidden`` (the purposes hidden on and above the instancer) or a drawn one other than
        default (its prims without a purpose of their own are of it, so that the UsdGeomVisibilityAPI opinions for it
        in the prototype and above it reach them: read of default purpose, none did), else None. Purpose,
        unlike visibility, is inherited through the prototype's own ancestors, the scope holding it too, as
        ``ComputePurpose`` computes it; inside a native prototype, on through the instance and its ancestors
        (``ctx.outer_purpose``: USD computes it on the instance proxies); where none of them authors one, the
        instancer's purpose applies, as UsdImaging's instancer adapter gives it (``instanceInheritablePurpose``)."""
        parent = root.GetParent()
        info = UsdGeom.Imageable(parent).ComputePurposeInfo() if parent and not parent.IsPseudoRoot() else None
        if info is not None and info.isInheritable:
            purpose = info.purpose
        elif parent and parent.IsInPrototype() and ctx.outer_purpose is not None:
            purpose = ctx.outer_purpose
        else:
            purpose = self._purpose(instancer, ctx)
        drawn = purpose in self.purposes and purpose not in hidden
        return None if drawn and purpose == UsdGeom.Tokens.default_ else purpose

    def _instance_purpose(self, instance: Usd.Prim, ctx: Context, purpose: str, hidden: frozenset):
        """The purpose native ``instance`` (of computed ``purpose``) hands down to its prototype's prims
        (``Context.outer_purpose``): one not drawn, or one of ``hidden`` (the prims inside that inherit it are hidden
        too); a drawn one that an opinion gives, where a PointInstancer in the prototype may draw its prototypes by
        it (:meth:`_prototype_purpose`) or a UsdGeomVisibilityAPI opinion in it may hide the prims that inherit it
        (read of default purpose, they were drawn); else None, so that one read of the prototype serves the instances
        with and without such an opinion."""
        if purpose not in self.purposes or purpose in hidden:
            return purpose
        prototype = instance.GetPrototype()
        if not prototype:  # skipped by the reader, with a warning
            return None
        return self._authored_purpose(instance, ctx) if self._reads_purpose(prototype) else None

    def _reads_purpose(self, prototype: Usd.Prim) -> bool:
        """Whether native ``prototype`` holds a PointInstancer or a UsdGeomVisibilityAPI prim, in it or in the
        prototype of an instance in it (:meth:`_prototype_contents`)."""
        return self._prototype_contents(prototype)[0]

    def _hidden_inside(self, prototype: Usd.Prim, purpose, hidden: frozenset) -> frozenset:
        """The purposes of ``hidden`` that some prim of native ``prototype`` can take: the one its instance hands down
        (``purpose``, :meth:`_instance_purpose`) or one authored in it or in a nested prototype; all of them where a
        PointInstancer is in it (it may draw prototypes from outside by purpose). The prototype is read once per such
        set: keyed by every hidden purpose, it was read (and its BLAS built) again for an instance under a
        renderVisibility = invisible opinion though it held only prims of default purpose."""
        if not hidden:
            return hidden
        inside = self._prototype_contents(prototype)[1]
        return hidden if inside is None else hidden & (inside | {purpose})

    def _prototype_contents(self, prototype: Usd.Prim) -> tuple:
        """``(reads_purpose, purposes)`` of native ``prototype``, from one walk of its prims and of the prototypes of
        the instances in it, each prototype's answer kept (walked through instance proxies, every nested prototype
        was walked again for each instance of it: three levels of 40 nested instances loaded 8 times slower):
        whether a PointInstancer or a UsdGeomVisibilityAPI prim is among them (:meth:`_instance_purpose`), and the
        purposes authored on them, None where a PointInstancer is among them (:meth:`_hidden_inside`)."""
        key = prototype.GetPath()
        if key not in self.prototype_contents:
            reads, found = False, set()
            for p in Usd.PrimRange(prototype, Usd.PrimAllPrimsPredicate):
                nested = self._prototype_contents(p.GetPrototype()) if p.IsInstance() and p.GetPrototype() else None
                if p.IsA(UsdGeom.PointInstancer) or (nested is not None and nested[1] is None):
                    reads, found = True, None
                    break
                reads = reads or p.HasAPI(UsdGeom.VisibilityAPI) or (nested is not None and nested[0])
                if nested is not None:
                    found |= nested[1]
                img = UsdGeom.Imageable(p)
                attr = img.GetPurposeAttr() if img else None
                if attr is not None and attr.HasAuthoredValue() and token_typed(attr):
                    found.add(attr.Get())
            self.prototype_contents[key] = (reads, None if found is None else frozenset(found))
        return self.prototype_contents[key]

    def _authored_purpose(self, prim: Usd.Prim, ctx: Context):
        """The purpose an opinion gives ``prim`` (its own or an ancestor's, through the native instances it is in:
        ``ctx.outer_purpose``), or None where none does and the schema's fallback applies."""
        if ctx.stop is None and ctx.outer_purpose is None:
            info = UsdGeom.Imageable(prim).ComputePurposeInfo()
            return info.purpose if info.isInheritable else None
        own = self._nearest_purpose(prim, ctx)
        return own if own is not None else ctx.outer_purpose

    def _rendered(self, prim: Usd.Prim, ctx: Context) -> bool:
        """Visible (below ``ctx.stop``) with a purpose drawn (default or render, or the render settings' own), and not
        hidden for that purpose by ``UsdGeomVisibilityAPI`` (:class:`wrt.usd_ancestors.PurposeVisibilities`)."""
        if not self._visible(prim, ctx.stop):
            return False
        purpose = self._purpose(prim, ctx)
        return purpose in self.purposes and not self.purpose_visibilities.hidden(prim, purpose, ctx.outer_hidden)

    def _hidden_purposes(self, instance: Usd.Prim, ctx: Context) -> frozenset:
        """The drawn purposes that opinions on or above native ``instance`` hide (:meth:`_rendered`), which its
        prototype's prims without an opinion of their own inherit: USD walks an instance proxy's purpose visibility
        on through its instance. Only those read apart, a copy of the prototype each; it was read once for all
        instances, and an instance under renderVisibility = invisible drew its render prims, with a warning."""
        return frozenset(p for p in self.purposes if self.purpose_visibilities.hidden(instance, p, ctx.outer_hidden))
