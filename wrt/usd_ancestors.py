"""Answers a prim gets from its nearest ancestor that has one, kept per prim, so a deep hierarchy is walked once.

USD's own queries of this kind (``FindPrimvarWithInheritance``, ``ComputePurpose``, and ``ComputeBoundMaterial``'s
search for bindings) walk every ancestor of the prim asked about; asked for every prim of a deep hierarchy, that is
quadratic in its depth (a mesh under each of 2,000 nested Xforms: 2M ancestor visits per query, some 30 s to load).
:class:`AncestorMemo` walks up only to the first prim whose answer is known. The rules are USD's, restated:
``UsdGeomPrimvarsAPI::FindPrimvarWithInheritance`` and ``UsdGeomImageable::ComputePurposeInfo`` (``primvarsAPI.cpp``,
``imageable.cpp``).
"""

from __future__ import annotations

from pxr import Usd, UsdGeom

from .usd_values import token_typed

KEEP_LOOKING = object()  # an ``own`` answer: this prim says nothing, ask its parent


class AncestorMemo:
    """``memo(prim)``: ``own(p)`` of the nearest of ``prim`` and its ancestors (up to the pseudo-root, which is not
    asked) whose ``own`` is not :data:`KEEP_LOOKING`, else ``default``; each prim's answer is kept by path.

    Args:
        own: ``(Usd.Prim) -> answer or KEEP_LOOKING``.
        default: the answer when no prim up to the root has one.
    """

    def __init__(self, own, default=None):
        self.own = own
        self.default = default
        self.known = {}  # prim path -> answer

    def __call__(self, prim: Usd.Prim):
        pending = []  # paths from prim up to the answer, which say nothing themselves
        p = prim
        while True:
            if not p or p.IsPseudoRoot():
                answer = self.default
                break
            path = p.GetPath()
            if path in self.known:
                answer = self.known[path]
                break
            own = self.own(p)
            if own is not KEEP_LOOKING:
                answer = self.known[path] = own
                break
            pending.append(path)
            p = p.GetParent()
        for path in pending:
            self.known[path] = answer
        return answer


BLOCKED = UsdGeom.Primvar()  # a non-constant primvar above: it blocks inheritance (an invalid primvar)
# A non-constant primvar on a PointInstancer above: it blocks inheritance as well, but is the instances' own (one value
# per instance, as Hydra's instancer primvars: Instances.colors, Instances.opacities), applied where a prim has none.
PER_INSTANCE = UsdGeom.Primvar()


class InheritedPrimvars:
    """``find(prim, name)``: ``UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)``, each ancestor's answer
    kept: the prim's own primvar when it has an authored value, else the nearest ancestor's primvar ``name`` that has
    one, if constant (a non-constant one blocks: an invalid primvar), else the prim's own (maybe invalid)."""

    def __init__(self):
        self.memos = {}  # primvar name -> AncestorMemo of the search from a prim upwards

    def find(self, prim: Usd.Prim, name: str) -> UsdGeom.Primvar:
        found = self.lookup(prim, name)
        return UsdGeom.PrimvarsAPI(prim).GetPrimvar(name) if found is None else found

    def lookup(self, prim: Usd.Prim, name: str) -> UsdGeom.Primvar | None:
        """:meth:`find`'s answer with its kinds of none told apart: the primvar found (it has a value),
        :data:`BLOCKED` where a non-constant one on an ancestor blocks inheritance (:data:`PER_INSTANCE` on a
        PointInstancer), None where no prim up to the root (of the prototype, in one) has one: only then does a native
        instance's colour reach ``prim``, as the walk of its instance proxy goes on through the instance."""
        local = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
        if local.HasAuthoredValue():
            return local
        memo = self.memos.get(name)
        if memo is None:
            attr_name = name if name.startswith("primvars:") else "primvars:" + name  # (USD's _MakeNamespaced)
            memo = self.memos[name] = AncestorMemo(_primvar_on(attr_name))
        return memo(prim.GetParent())


def _primvar_on(attr_name: str):
    """The ``own`` of the upward search for primvar attribute ``attr_name``."""

    def own(p: Usd.Prim):
        attr = p.GetAttribute(attr_name)
        if attr and attr.HasAuthoredValue():
            primvar = UsdGeom.Primvar(attr)
            if primvar:
                if primvar.GetInterpolation() == UsdGeom.Tokens.constant:
                    return primvar
                return PER_INSTANCE if p.IsA(UsdGeom.PointInstancer) else BLOCKED
        return KEEP_LOOKING

    return own


def _authored_purpose(p: Usd.Prim):
    """``p``'s authored purpose, if it is imageable and has one."""
    img = UsdGeom.Imageable(p)
    if img:
        attr = img.GetPurposeAttr()
        if attr.HasAuthoredValue():
            if not token_typed(attr):  # a string "guide": ComputePurpose reads the fallback, inherited below it
                return UsdGeom.Tokens.default_
            return attr.Get() or KEEP_LOOKING  # an empty token says nothing
    return KEEP_LOOKING


class ComputedPurposes:
    """``purpose(prim)``: ``UsdGeom.Imageable(prim).ComputePurpose()``, each ancestor's answer kept: the authored
    purpose of the nearest of ``prim`` and its imageable ancestors that has one, else ``prim``'s fallback."""

    def __init__(self):
        self.authored = AncestorMemo(_authored_purpose)

    def purpose(self, prim: Usd.Prim) -> str:
        found = self.authored(prim)
        if found is not None:
            return found
        img = UsdGeom.Imageable(prim)
        return (img.GetPurposeAttr().Get() if img else None) or UsdGeom.Tokens.default_


def _purpose_visibility_on(purpose: str):
    """The ``own`` of the upward search for ``purpose``'s visibility opinion (``renderVisibility``, ...)."""
    name = purpose + "Visibility"

    def own(p: Usd.Prim):
        # As ComputeEffectiveVisibility reads them: on imageable prims with UsdGeomVisibilityAPI applied only.
        if p.HasAPI(UsdGeom.VisibilityAPI) and UsdGeom.Imageable(p):
            attr = p.GetAttribute(name)
            if attr and attr.HasAuthoredValue() and token_typed(attr) and attr.Get():
                return attr.Get()
        return KEEP_LOOKING

    return own


class PurposeVisibilities:
    """``hidden(prim, purpose)``: the nearest authored opinion of ``UsdGeomVisibilityAPI`` for ``purpose`` (render,
    proxy or guide) on ``prim`` or an ancestor is ``invisible``, as ``ComputeEffectiveVisibility(purpose)`` finds it
    where overall visibility is not invisible (``visible`` or ``inherited`` nearer re-opens); each prim's answer
    kept. The opinions are uniform: the answer does not depend on the time. A guide with no opinion stays drawn
    where the render settings include guides (the schema's fallback, ``invisible``, is not applied). In a native
    prototype, where no prim up to its root has an opinion, the walk goes on through the instance read
    (``outer``: the purposes hidden on and above it), as USD's walk of an instance proxy does."""

    def __init__(self):
        self.memos = {}  # purpose -> AncestorMemo of the search from a prim upwards

    def hidden(self, prim: Usd.Prim, purpose: str, outer: frozenset = frozenset()) -> bool:
        if purpose not in (UsdGeom.Tokens.render, UsdGeom.Tokens.proxy, UsdGeom.Tokens.guide):
            return False
        memo = self.memos.get(purpose)
        if memo is None:
            memo = self.memos[purpose] = AncestorMemo(_purpose_visibility_on(purpose))
        found = memo(prim)
        if found is None:  # no opinion up to the root (of the prototype, in one)
            return purpose in outer
        return found == UsdGeom.Tokens.invisible


def _binds_here(p: Usd.Prim):
    """True when ``p`` authors a material binding relationship (direct or collection, any purpose)."""
    if any(name == "material:binding" or name.startswith("material:binding:") for name in p.GetAuthoredPropertyNames()):
        return True
    return KEEP_LOOKING


class BindingsAbove:
    """``any(prim)``: ``prim`` or an ancestor authors a ``material:binding`` relationship (direct or collection):
    without one, ``ComputeBoundMaterial`` finds no material, and its walk of the ancestors is spared."""

    def __init__(self):
        self.memo = AncestorMemo(_binds_here, default=False)
        self.checked = set()  # paths of the prims problems() has looked at

    def any(self, prim: Usd.Prim) -> bool:
        return bool(self.memo(prim))

    def problems(self, prim: Usd.Prim) -> list:
        """``[(p, name, problem[, detail])]``: the binding relationships of ``prim`` and its ancestors not asked
        before whose purpose USD's calls disagree on (:func:`wrt.usd_bindings.has_ambiguous_purpose`) or whose
        targets USD ignores (:func:`wrt.usd_bindings.is_ignored_binding`; :func:`wrt.usd_bindings.not_a_collection`,
        naming the target in ``detail``), with the words that say which; each prim looked at once."""
        from .usd_bindings import (
            AMBIGUOUS_PURPOSE,
            IGNORED_BINDING,
            NOT_A_COLLECTION,
            has_ambiguous_purpose,
            is_ignored_binding,
            not_a_collection,
        )

        found = []
        p = prim
        while p and not p.IsPseudoRoot() and p.GetPath() not in self.checked:
            self.checked.add(p.GetPath())
            for name in p.GetAuthoredPropertyNames():
                if has_ambiguous_purpose(name):
                    found.append((p, name, AMBIGUOUS_PURPOSE))
                elif is_ignored_binding(p, name):
                    found.append((p, name, IGNORED_BINDING))
                elif (target := not_a_collection(p, name)) is not None:
                    found.append((p, name, NOT_A_COLLECTION, f"{name} -> {target}"))
            p = p.GetParent()
        return found
