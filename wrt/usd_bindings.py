"""Material binding resolution one purpose at a time, and across native instances whose prototype is read once.

``UsdShade.MaterialBindingAPI.ComputeBoundMaterial(purpose)`` walks from a prim up to the root twice: first for
bindings of ``purpose`` alone (the nearest wins, unless one further up is ``strongerThanDescendants``: then the
highest such), and only when that walk finds no binding, again for all-purpose bindings (``materialBinding.cpp``;
the UsdShade "Material Resolution" rules). So a ``material:binding:full`` on an ancestor wins over an all-purpose
binding on the prim itself (and a binding to a prim that is no Material is a binding: :class:`Found`).

wrt reads a native instance's prototype once, its prims at their prototype paths (``/__Prototype_1/Mesh``), whose
walk stops at the prototype root; the instance prim and its ancestors are the rest of the instance proxy's walk.
:class:`OuterBinding` holds that rest's answer, per purpose, and :func:`combine` joins the two halves as the whole
walk would: the outer material when it is bound ``strongerThanDescendants``, else the inner one, else the outer one.
"""

from __future__ import annotations

import bisect
from typing import NamedTuple

from pxr import Sdf, Usd, UsdShade

ALL_PURPOSE = ""  # UsdShade.Tokens.allPurpose


class OuterBinding(NamedTuple):
    """What the walk of one binding purpose finds on and above a native instance (hashable: part of the key its
    prototype is read under)."""

    purpose: str  # the binding purpose ("" all-purpose, "full", "preview", ...)
    material: str  # path of the material the walk ends at ("": a binding to no Material, see Found)
    stronger: bool  # it wins over every binding inside the prototype (Found.stronger)


class Found(NamedTuple):
    """What the walk of one binding purpose ends at. A binding whose target is no Material (a missing prim, an
    Xform) is found as any other, a ``material`` that is not valid: it wins over weaker bindings above it, and a
    purpose's binding of it keeps ``ComputeBoundMaterial`` from falling back to all-purpose ones, as USD resolves it
    (a ``material:binding:full`` to a missing prim on an ancestor leaves its prims without a material)."""

    material: UsdShade.Material  # the bound material (not valid: the binding targets no Material)
    rel: Usd.Relationship | None  # the binding relationship; None for one found above a native instance
    stronger: bool  # that binding wins over one found below it (overrides_below: strongerThanDescendants)


def binding_purpose(rel: Usd.Relationship) -> str:
    """The purpose of binding relationship ``rel``: ``material:binding[:purpose]`` (direct) or
    ``material:binding:collection[:purpose]:name`` (a collection binding: its fourth part is the purpose where more
    follow, as ``ComputeBoundMaterial`` reads it, so ``...:collection:full:a:b`` binds for ``full`` alone; USD's
    ``GetCollectionBindingRels`` lists names of six parts or more under all-purpose, which it does not bind for).
    A collection's purpose was read as all-purpose (the name was taken for
    ``material:binding[:purpose][:collection:name]``): a ``full`` collection above a native instance lost to an
    all-purpose binding inside it, and ``materialBindingPurposes`` found no binding of its purposes in one."""
    parts = rel.GetName().split(":")
    if len(parts) > 2 and parts[2] == "collection":
        return parts[3] if len(parts) > 4 else ALL_PURPOSE
    return parts[2] if len(parts) > 2 else ALL_PURPOSE


AMBIGUOUS_PURPOSE = ("collection bindings named in six or more parts (material:binding:collection:<purpose>:<ns>:"
                     "<name>) have a purpose ambiguous between USD's calls: ComputeBoundMaterial, which wrt follows, "
                     "binds them for their fourth part alone, GetCollectionBindingRels lists them as all-purpose")


def has_ambiguous_purpose(name: str) -> bool:
    """Binding relationship name ``name`` is a collection binding of six or more parts, whose purpose
    :func:`binding_purpose` reads as ``ComputeBoundMaterial`` does, where ``GetCollectionBindingRels`` differs."""
    parts = name.split(":")
    return len(parts) > 5 and parts[:3] == ["material", "binding", "collection"]


IGNORED_BINDING = ("material bindings that USD ignores (a direct binding targets one prim; a collection binding a "
                   "collection and a prim) bind nothing; their prims are drawn as bound to what is bound above them")


def is_ignored_binding(prim: Usd.Prim, name: str) -> bool:
    """Binding relationship ``name`` of ``prim`` has targets that ``ComputeBoundMaterial`` does not take as a binding
    (it goes on to the bindings above): a direct binding of a property or of several prims, a collection binding
    without a collection and a prim (in either order: ``ComputeBoundMaterial`` binds ``[</Looks/M>,
    </World.collection:c>]`` too). One without targets (deliberately unbound) is not. USD reads the targets forwarded
    through relationships (one targeting ``/World.looks``, which targets a Material, binds it)."""
    parts = name.split(":")
    if parts[:2] != ["material", "binding"]:
        return False
    rel = prim.GetRelationship(name)
    if not rel.GetTargets():
        return False
    targets = rel.GetForwardedTargets()
    if len(parts) > 2 and parts[2] == "collection":
        # A collection (a property) and a prim, whichever comes first.
        return sorted((t.IsPrimPath(), t.IsPropertyPath()) for t in targets) != [(False, True), (True, False)]
    return not (len(targets) == 1 and targets[0].IsPrimPath())


NOT_A_COLLECTION = ("collection material bindings whose collection target is no collection (an attribute, a "
                    "collection its prim does not apply, a missing prim) bind nothing, as USD ignores them; their "
                    "prims are drawn as bound to what is bound above them")  # warning reason


def not_a_collection(prim: Usd.Prim, name: str) -> Sdf.Path | None:
    """The target of collection binding ``name`` of ``prim`` in place of a collection where it names none that USD
    finds (``Usd.CollectionAPI.Get``: an attribute, ``collection:NAME`` of a prim that does not apply it, a missing
    prim): ``ComputeBoundMaterial`` then finds no prim in it and goes on to the bindings above, without a word (an
    attribute: a coding error that USD's Python API raises, failing the load). None for any other relationship, and
    for one :func:`is_ignored_binding` names."""
    if name.split(":")[:3] != ["material", "binding", "collection"] or is_ignored_binding(prim, name):
        return None
    collection = next((t for t in prim.GetRelationship(name).GetForwardedTargets() if t.IsPropertyPath()), None)
    if collection is None:  # no targets: deliberately unbound
        return None
    if Usd.CollectionAPI.IsCollectionAPIPath(collection) and Usd.CollectionAPI.Get(prim.GetStage(), collection):
        return None
    return collection


def hold_back(prim: Usd.Prim, name: str) -> None:
    """Sets collection binding ``name`` of ``prim``, whose collection target is no collection path at all (an
    attribute: :func:`not_a_collection`), to target its material alone in the stage's session layer (wrt's own stage:
    the user's files are untouched), a binding USD ignores alike without the coding error: USD's C++ finds no prim in
    such a collection (an invalid collection's membership is empty), but its Python API raises the error and with it
    the whole ``ComputeBoundMaterial``, which failed the load. Not inside a native prototype, whose prims take no
    opinions: there the load still fails, naming the prim and USD's error. (Frames keep no such stage: the edit is a
    change to it, so the next frame opens it again, and names the binding again.)"""
    rel = prim.GetRelationship(name)
    targets = rel.GetForwardedTargets()
    raising = [t for t in targets if t.IsPropertyPath() and not Usd.CollectionAPI.IsCollectionAPIPath(t)]
    if raising and not (prim.IsInstanceProxy() or prim.IsInPrototype()):
        stage = prim.GetStage()
        with Usd.EditContext(stage, stage.GetSessionLayer()):
            rel.SetTargets([t for t in rel.GetTargets() if t.IsPrimPath()])


def is_stronger(rel) -> bool:
    """Binding relationship ``rel`` says ``bindMaterialAs = strongerThanDescendants``."""
    return UsdShade.MaterialBindingAPI.GetMaterialBindingStrength(rel) == UsdShade.Tokens.strongerThanDescendants


def overrides_below(rel) -> bool:
    """Binding relationship ``rel``, where a walk ends, would also win over a binding found below its prim: it is
    :func:`is_stronger`, or it is a collection binding whose prim's direct binding of its purpose is. On one prim
    ``ComputeBoundMaterial`` asks the direct binding first, then takes a collection binding that holds the prim over
    a direct binding won there: a weaker collection beside a stronger direct binding wins over what is bound below,
    which a walk begun above it (from a native instance) cannot tell from its relationship alone."""
    if is_stronger(rel):
        return True
    if rel.GetName().split(":")[:3] != ["material", "binding", "collection"]:
        return False
    prim = rel.GetPrim()
    direct = UsdShade.MaterialBindingAPI(prim).GetDirectBindingRel(binding_purpose(rel))
    return bool(direct and direct.GetTargets()) and not is_ignored_binding(prim, direct.GetName()) and is_stronger(
        direct)


class OwnWalks:
    """``walk(purpose)``: the :class:`Found` of the walk of ``purpose`` bindings alone from ``prim`` up to its root
    (``ALL_PURPOSE``: all-purpose bindings), None where it finds no binding; one ``ComputeBoundMaterial`` call
    answers a purpose and, where it fell back, the all-purpose walk too."""

    def __init__(self, prim: Usd.Prim):
        self.binding = UsdShade.MaterialBindingAPI(prim)
        self.found = {}  # purpose -> Found or None

    def __call__(self, purpose: str) -> Found | None:
        if purpose not in self.found:
            material, rel = self.binding.ComputeBoundMaterial(purpose or UsdShade.Tokens.allPurpose)
            of = binding_purpose(rel) if rel else None  # (no relationship: no binding of either walk)
            found = Found(material, rel, overrides_below(rel)) if rel else None
            if of != purpose:  # the purpose's own walk found nothing: ComputeBoundMaterial fell back
                self.found[ALL_PURPOSE] = found
                found = None
            self.found[purpose] = found
        return self.found[purpose]


def combine(inner: Found | None, outer: OuterBinding | None, material_at) -> Found | None:
    """One purpose's whole walk: ``inner`` (the walk inside a native prototype) joined with ``outer`` (the rest, on
    and above the instance; None where it finds nothing); ``material_at(path)`` gives a ``UsdShade.Material``."""
    if outer is not None and (outer.stronger or inner is None):
        return Found(material_at(outer.material), None, outer.stronger)
    return inner


def outer_entry(outer: tuple | None, purpose: str) -> OuterBinding | None:
    """The entry of ``purpose`` in ``outer`` (a tuple of :class:`OuterBinding`), or None."""
    return next((entry for entry in outer or () if entry.purpose == purpose), None)


class CollectionsInside:
    """``reach(prim)``: a collection bound (``material:binding:collection:...``) on ``prim`` or an ancestor holds
    some of ``prim``'s descendants and not others, or ``prim`` without its descendants, so that the instance proxies
    of native instance ``prim`` bind unlike the instance itself (a collection that names ``/World/Inst/Body``): its
    prototype's prims are then resolved through this instance's proxies (``Context.proxy``). Each collection's
    membership (``ComputeMembershipQuery``) is computed once; one given by a membership expression counts as
    reaching inside."""

    def __init__(self, stage: Usd.Stage):
        self.stage = stage
        self.collections = {}  # prim path -> paths of the collections its collection bindings name
        self.members = {}  # collection path -> (path expansion rule map, its paths as sorted strings), or None
        self.above = None  # AncestorMemo of bound_above

    def reach(self, prim: Usd.Prim) -> bool:
        path = prim.GetPath()
        p = prim
        while p and not p.IsPseudoRoot():
            if any(not self._uniform(collection, path) for collection in self._bound_collections(p)):
                return True
            p = p.GetParent()
        return False

    def bound_above(self, prim: Usd.Prim) -> bool:
        """``prim`` or an ancestor binds a collection (each prim's answer kept): whether it is in the collection may
        tell it apart from its siblings."""
        if self.above is None:
            from .usd_ancestors import KEEP_LOOKING, AncestorMemo

            self.above = AncestorMemo(lambda p: True if self._bound_collections(p) else KEEP_LOOKING, default=False)
        return self.above(prim)

    def _bound_collections(self, p: Usd.Prim) -> list:
        path = p.GetPath()
        if path not in self.collections:
            found = []
            for name in p.GetAuthoredPropertyNames():
                if name.startswith("material:binding") and ":collection:" in name:
                    rel = p.GetRelationship(name)
                    # The collection is the target that is a property path, whichever comes first, as USD tells
                    # a collection binding's two targets apart.
                    collection = next((t for t in (rel.GetForwardedTargets() if rel else []) if t.IsPropertyPath()),
                                      None)
                    # (an attribute binds nothing, and Usd.CollectionAPI.Get raises on it)
                    if collection is not None and Usd.CollectionAPI.IsCollectionAPIPath(collection):
                        found.append(collection)
            self.collections[path] = found
        return self.collections[path]

    def _uniform(self, collection_path, path) -> bool:
        """The collection at ``collection_path`` holds all of the subtree at ``path`` or none of it."""
        if collection_path not in self.members:
            collection = Usd.CollectionAPI.Get(self.stage, collection_path)
            entry = ({}, [])  # no collection: it binds nothing
            if collection:
                query = collection.ComputeMembershipQuery()
                rules = query.GetAsPathExpansionRuleMap() if query.UsesPathExpansionRuleMap() else None
                entry = None if rules is None else (dict(rules), sorted(str(k) for k in rules))
            self.members[collection_path] = entry
        entry = self.members[collection_path]
        if entry is None:
            return False
        rules, keys = entry
        below = str(path) + "/"
        i = bisect.bisect_left(keys, below)
        if i < len(keys) and keys[i].startswith(below):  # a path inside the subtree is included or excluded
            return False
        return rules.get(path) != "explicitOnly"  # (the prim in, its descendants out)
