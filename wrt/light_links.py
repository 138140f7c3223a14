"""Light linking and shadow linking (UsdLux ``collection:lightLink``, ``collection:shadowLink``): which drawn
geometry a light lights, and which casts its shadows.

A light's two collections are :class:`LinkCollection` objects (None: every prim, UsdLux's fallback). Membership is
decided per drawn geometry (a mesh, a gprim, a Points or curves prim, one prototype mesh or gprim in one instance) by
the prim path wrt knows for it (:func:`drawn_paths`): its own path; inside a native instance its instance-proxy path
(``/World/Instance/geo/mesh``); inside a PointInstancer's prototype the prototype prim's own path (under the
instancer in the usual layout), moved to the proxy path when the instancer is itself inside a native instance. A
collection in expression mode (``membershipExpression``) is USD's own query asked about each of these paths once
the stage's geometry is read (:func:`resolve_expressions`).

On the device every drawn geometry gets a *link group*: one per distinct combination of memberships, with one
``(groups, lights)`` mask array (:class:`DeviceLinks`). Geometry ids of non-instanced geometry index their group
directly; an instance holds one group for all of its prototype's parts, or (when its parts differ) an offset into a
list of per-part groups. Emissive triangles are not UsdLux lights: they light and are shadowed by everything; the
triangles of a mesh light (:class:`wrt.lights.MeshLight`) are linked as their light is.
"""

import dataclasses
import itertools
import types
from collections.abc import Mapping

import numpy as np
import warp as wp

from .errors import SceneError

# USD's path expansion rules (UsdCollectionMembershipQuery's rule map values).
EXPLICIT_ONLY = "explicitOnly"
EXPAND_PRIMS = "expandPrims"
EXPAND_PRIMS_AND_PROPERTIES = "expandPrimsAndProperties"
EXCLUDE = "exclude"
RULES = (EXPLICIT_ONLY, EXPAND_PRIMS, EXPAND_PRIMS_AND_PROPERTIES, EXCLUDE)

LIT = wp.constant(1)  # mask bit: the light lights the group's geometry (lightLink)
CASTS_SHADOW = wp.constant(2)  # mask bit: the group's geometry blocks the light's shadow rays (shadowLink)


@dataclasses.dataclass(frozen=True)
class LinkCollection:
    """The prims a light's linking collection holds, as USD's path expansion rule map
    (``UsdCollectionAPI.ComputeMembershipQuery().GetAsPathExpansionRuleMap()``: includes, excludes and
    ``expansionRule`` resolved, included collections flattened in).

    Attributes:
        rules: prim path -> ``"explicitOnly"``, ``"expandPrims"``, ``"expandPrimsAndProperties"`` or ``"exclude"``;
            ``{"/": "expandPrims"}`` is every prim (``includeRoot``), ``{}`` none. Kept as a read-only copy: a
            change made in place would go unseen by a kept :class:`wrt.Renderer`; give the light a new collection.
    """

    rules: Mapping

    def __post_init__(self):
        if not isinstance(self.rules, Mapping):
            raise TypeError("LinkCollection rules must be a dict of prim path -> rule, got "
                            f"{type(self.rules).__name__}")
        # The copy made at construction is kept when the light is checked again before a render: a new one at each
        # check made a kept Renderer see a changed light, and build again.
        if self.rules is not getattr(self, "_own_rules", None):
            object.__setattr__(self, "rules", types.MappingProxyType(dict(self.rules)))
            object.__setattr__(self, "_own_rules", self.rules)
        for path, rule in self.rules.items():
            if not (isinstance(path, str) and path.startswith("/")):
                raise SceneError(f"LinkCollection rules: {path!r} is not an absolute prim path")
            if path != "/" and "" in path[1:].split("/"):  # '/World/' or '/World//Floor' would match no prim
                raise SceneError(f"LinkCollection rules: {path!r} has an empty path component (a doubled or trailing "
                                 "'/')")
            if rule not in RULES:
                raise SceneError(f"LinkCollection rules: {path} has rule {rule!r}; valid rules: {', '.join(RULES)}")

    def __reduce__(self):  # a read-only mapping does not pickle (scenes travel to other processes)
        return type(self), (dict(self.rules),)

    @classmethod
    def only(cls, *paths: str) -> "LinkCollection":
        """The prims at ``paths`` and below them."""
        return cls({path: EXPAND_PRIMS for path in paths})

    @classmethod
    def explicit(cls, *paths: str) -> "LinkCollection":
        """The prims at ``paths`` only, not those below them."""
        return cls(dict.fromkeys(paths, EXPLICIT_ONLY))

    @classmethod
    def excluding(cls, *paths: str) -> "LinkCollection":
        """Every prim but those at ``paths`` and below them."""
        return cls({"/": EXPAND_PRIMS, **{path: EXCLUDE for path in paths}})

    def includes(self, path: str) -> bool:
        """Whether prim ``path`` is a member, as ``UsdCollectionMembershipQuery.IsPathIncluded`` decides: walking up
        from the path, an ``exclude`` leaves it out, and any other rule takes it in, but ``explicitOnly`` only on the
        path itself (on an ancestor it is passed over); no rule: not a member. ``/`` is not a prim: never one."""
        path = here = path.rstrip("/") or "/"
        # A relative path (a Scene built in Python may name a mesh 'World/Floor') matches no rule but the root's; its
        # walk up never reached '/' and hung the render.
        while here != "/" and here.startswith("/"):
            rule = self.rules.get(here)
            if rule == EXCLUDE:
                return False
            if rule is not None and (rule != EXPLICIT_ONLY or here == path):
                return True
            here = here.rsplit("/", 1)[0] or "/"
        return path != "/" and self.rules.get("/") in (EXPAND_PRIMS, EXPAND_PRIMS_AND_PROPERTIES)

    def includes_each(self, paths: "PathIndex") -> np.ndarray:
        """``(P,)`` bool: :meth:`includes` of each of ``paths``' paths, the rules applied to every path below them at
        once (shallowest first, so the rule nearest a path wins, as the walk up from it decides; ``explicitOnly``
        marks its own path only, which is how the walk passes it over on the way up). Asking :meth:`includes` per
        light and drawn path took 14 s for 2,000 linked lights over 2,000 meshes."""
        root = self.rules.get("/") in (EXPAND_PRIMS, EXPAND_PRIMS_AND_PROPERTIES)
        found = np.full(len(paths.paths), root) & ~paths.is_root
        for path in sorted((p for p in self.rules if p != "/"), key=lambda p: p.count("/")):
            rule = self.rules[path]
            rows = paths.exactly.get(path, ()) if rule == EXPLICIT_ONLY else paths.below.get(path, ())
            found[list(rows)] = rule != EXCLUDE
        for k in paths.unusual:  # not absolute: asked one by one, as before
            found[k] = self.includes(paths.paths[k])
        return found


class PathIndex:
    """Drawn paths indexed for :meth:`LinkCollection.includes_each`: the rows of each path and of the paths at and
    below each prim path, found by the same walk up as :meth:`LinkCollection.includes` takes.

    Attributes:
        paths: the paths, in their order.
        exactly: prim path -> rows of ``paths`` that are that path.
        below: prim path -> rows of ``paths`` at or below it.
        is_root: ``(P,)`` bool, the paths that are ``/`` (members of no collection).
        unusual: rows of relative paths, which the walk up does not take apart.
    """

    def __init__(self, paths: list):
        self.paths = list(paths)
        self.exactly, self.below, self.unusual = {}, {}, []
        self.is_root = np.zeros(len(self.paths), bool)
        for k, path in enumerate(self.paths):
            here = path.rstrip("/") or "/"
            self.is_root[k] = here == "/"
            if not here.startswith("/"):
                self.unusual.append(k)
                continue
            self.exactly.setdefault(here, []).append(k)
            while here != "/":
                self.below.setdefault(here, []).append(k)
                here = here.rsplit("/", 1)[0] or "/"


@dataclasses.dataclass(frozen=True)
class MembershipExpression:
    """A linking collection in expression mode (``membershipExpression``, USD 24+) while a stage is read: USD's
    membership query of it, asked about each drawn path once the geometry is known (:func:`resolve_expressions`)
    and replaced by the :class:`LinkCollection` of its answers.

    Attributes:
        query: the collection's ``Usd.UsdCollectionMembershipQuery`` (its expression resolved, ``%`` references to
            other collections included; predicates such as ``{isa:Mesh}`` evaluated on the stage it came from).
    """

    query: object


def read_collection(collection, kind: str, skip):
    """The :class:`LinkCollection` of a UsdLux light's ``collection`` (``collection:lightLink`` or ``:shadowLink``,
    named by ``kind``), None when it holds every prim (UsdLux's fallback), or a :class:`MembershipExpression` for
    one in expression mode. A collection USD cannot resolve counts as every prim, with a warning through
    ``skip(reason, prim)``."""
    from pxr import Sdf, Tf

    try:
        query = collection.ComputeMembershipQuery()
        if not query.UsesPathExpansionRuleMap():
            if collection.ResolveCompleteMembershipExpression() == Sdf.PathExpression.Everything():
                return None
            return MembershipExpression(query)
        rules = {str(path): str(rule) for path, rule in query.GetAsPathExpansionRuleMap().items()}
    except Tf.ErrorException:  # one USD cannot resolve
        skip(f"{kind} collections USD cannot resolve are ignored; these lights use every prim", collection.GetPrim())
        return None
    unknown = sorted({rule for rule in rules.values() if rule not in RULES})
    if unknown:  # an expansionRule token of no meaning stopped the whole load with LinkCollection's SceneError
        skip(f"{kind} collections with an expansionRule USD does not define are read as expandPrims, as USD's query "
             "reads them", collection.GetPrim(), ", ".join(repr(rule) for rule in unknown))
        rules = {path: rule if rule in RULES else EXPAND_PRIMS for path, rule in rules.items()}
    if rules.get("/") in (EXPAND_PRIMS, EXPAND_PRIMS_AND_PROPERTIES) and EXCLUDE not in rules.values():
        return None
    return LinkCollection(rules)


def resolve_expressions(scene) -> None:
    """Replaces each :class:`MembershipExpression` among ``scene``'s light and shadow links by the
    :class:`LinkCollection` of the drawn paths (:func:`drawn_paths`) USD's query includes (``explicitOnly`` rules),
    or None when it includes all of them. Geometry added to the scene later is outside such a collection."""
    from pxr import Sdf

    expressions = [getattr(light, name) for light in scene.lights for name in ("light_link", "shadow_link")]
    if not any(isinstance(e, MembershipExpression) for e in expressions):
        return
    paths = drawn_paths(scene)
    # Each path made an Sdf.Path once, not once per light: building it cost three times USD's answer.
    sdf_paths = [Sdf.Path(path) for path in paths]
    for light in scene.lights:
        for name in ("light_link", "shadow_link"):
            expression = getattr(light, name)
            if isinstance(expression, MembershipExpression):
                members = list(itertools.compress(paths, map(expression.query.IsPathIncluded, sdf_paths)))
                found = None if len(members) == len(paths) else LinkCollection.explicit(*members)
                setattr(light, name, found)


def check_links(light) -> None:
    """Refuses ``light_link`` or ``shadow_link`` values that are not a :class:`LinkCollection` or None."""
    for name in ("light_link", "shadow_link"):
        value = getattr(light, name)
        if value is not None and not isinstance(value, LinkCollection):
            raise SceneError(f"{type(light).__name__} {name} must be a wrt.LinkCollection or None, got "
                             f"{type(value).__name__}", prim=getattr(light, "path", "") or None)


def part_path(path: str, prototype_root: str, proxy_root: str | None) -> str:
    """The path a prototype part at ``path`` is drawn at in an instance whose prototype root
    (``prototype_root``) lies at ``proxy_root`` (None: where it is); a path outside the root keeps its place."""
    if proxy_root is None or path == prototype_root:
        return path if proxy_root is None else proxy_root
    base = prototype_root.rstrip("/")
    if path.startswith(base + "/"):
        return proxy_root.rstrip("/") + path[len(base):]
    return path


@dataclasses.dataclass
class HostLinks:
    """Link groups of a scene's drawn geometry (see the module docstring), host side.

    Attributes:
        masks: ``(G, L)`` uint8 :data:`LIT` and :data:`CASTS_SHADOW` bits of each group for each analytic light.
        geometry_groups: ``(T + S,)`` int32 per geometry id: the group of non-instanced geometry, the part index
            (meshes, then shapes, of its prototype) of prototype geometry.
        instance_groups: ``(N,)`` int32 per instance: its group, or ``-1 - offset`` into ``part_groups`` where its
            prototype's parts are in different groups.
        part_groups: ``(P,)`` int32 groups of the parts of such instances, one run per distinct combination (shared by
            the instances whose parts fall in the same groups).
    """

    masks: np.ndarray
    geometry_groups: np.ndarray
    instance_groups: np.ndarray
    part_groups: np.ndarray

    @property
    def shadow_linked(self) -> bool:
        """Some geometry casts no shadow of some light: shadow rays must look past it."""
        return bool(np.any(self.masks & CASTS_SHADOW == 0))


def link_groups(scene, lights: list):
    """The :class:`HostLinks` of ``scene``'s geometry for ``lights`` (the analytic lights, in device order), or
    None when no light links anything but every prim."""
    for light in lights:
        check_links(light)
    if all(light.light_link is None and light.shadow_link is None for light in lights):
        return None
    groups = {}  # mask row (bytes) of the linked lights -> group id
    instance_parts = _instance_parts(scene)
    paths = PathIndex(dict.fromkeys([m.path for m in scene.meshes] + [s.path for s in scene.shapes]
                                    + [path for parts, _ in instance_parts for path in parts]))
    rows = {path: k for k, path in enumerate(paths.paths)}
    # Bits of each path for the lights linked to less than every prim (the others' are LIT | CASTS_SHADOW for all);
    # a collection shared by several lights is applied once.
    linked = [k for k, light in enumerate(lights) if light.light_link is not None or light.shadow_link is not None]
    bits = np.zeros((len(paths.paths), len(linked)), np.uint8)
    applied = {}

    def members(collection) -> np.ndarray:
        if collection is None:
            return np.ones(len(paths.paths), bool)
        if id(collection) not in applied:
            applied[id(collection)] = (collection, collection.includes_each(paths))
        return applied[id(collection)][1]

    for column, k in enumerate(linked):
        bits[:, column] = np.where(members(lights[k].light_link), LIT, 0) | np.where(
            members(lights[k].shadow_link), CASTS_SHADOW, 0)

    def group_of(path: str) -> int:
        return groups.setdefault(bits[rows[path]].tobytes(), len(groups))

    # Geometry ids in their order: world triangles, prototype triangles, world shapes, prototype shapes; a prototype's
    # are numbered by part (its meshes, then its shapes).
    geometry = [np.full(len(m.indices), group_of(m.path), np.int32) for m in scene.meshes]
    geometry += [np.repeat(np.arange(len(p.meshes)), [len(m.indices) for m in p.meshes]) for p in scene.prototypes]
    geometry.append(np.array([group_of(s.path) for s in scene.shapes], np.int32))
    geometry += [np.arange(len(p.meshes), len(p.meshes) + len(p.shapes)) for p in scene.prototypes]

    instance_groups = np.zeros(len(scene.instances), np.int32)
    part_groups = []
    runs = {}  # the part groups of a prototype whose parts differ -> offset of their run in part_groups
    for parts, instances in instance_parts:
        found = tuple(group_of(path) for path in parts)
        if len(set(found)) <= 1:
            instance_groups[instances] = found[0] if found else 0
            continue
        if found not in runs:  # instances whose parts fall in the same groups share one run
            runs[found] = len(part_groups)
            part_groups += found
        instance_groups[instances] = -1 - runs[found]
    masks = np.full((len(groups), len(lights)), LIT | CASTS_SHADOW, np.uint8)
    masks[:, linked] = np.frombuffer(b"".join(groups), np.uint8).reshape(len(groups), len(linked))
    return HostLinks(masks, np.concatenate(geometry).astype(np.int32), instance_groups,
                     np.array(part_groups, np.int32))


def drawn_paths(scene) -> list:
    """The path of each drawn geometry of ``scene`` as linking decides its membership (see the module docstring):
    meshes and shapes, then the parts of each instance at the paths it draws them at, each path once."""
    return drawn_ids(scene)[0]


def drawn_ids(scene) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    """The :func:`drawn_paths` of ``scene`` and the index into them of each drawn geometry (``Scene.prim_paths``,
    ``Scene.hit_prims``): ``(paths, world, starts, parts)``, ``world`` ``(M + S,)`` of the non-instanced meshes and
    shapes, ``parts[starts[i] + k]`` of part ``k`` (meshes, then shapes) of instance ``i``'s prototype (int64)."""
    index = {}

    def ids(paths: list) -> np.ndarray:
        return np.array([index.setdefault(path, len(index)) for path in paths], np.int64)

    world = ids([m.path for m in scene.meshes] + [s.path for s in scene.shapes])
    starts, parts, offset = np.zeros(len(scene.instances), np.int64), [np.zeros(0, np.int64)], 0
    for paths, rows in _instance_parts(scene):
        starts[rows] = offset
        parts.append(ids(paths))
        offset += len(paths)
    return list(index), world, starts, np.concatenate(parts)


def _instance_parts(scene) -> list:
    """``(paths, rows)`` per distinct (prototype, proxy root) of ``scene``'s instances: the paths its prototype's
    parts (meshes, then shapes) are drawn at, and the instances drawn so. A PointInstancer's instances of a
    prototype share both: one entry for them all."""
    instances = scene.instances
    roots = instances.root if len(instances.roots) else np.full(len(instances), -1, np.int32)
    # One int64 key per pair, ordered as the pairs are (prototype, then root from -1): np.unique(axis=0) of the
    # stacked pairs sorts them as structured rows, 1.7 s for 1M PointInstancer instances, the keys 0.04 s.
    span = len(instances.roots) + 1
    keys, inverse = np.unique(instances.prototype.astype(np.int64) * span + roots + 1, return_inverse=True)
    pairs = np.stack([keys // span, keys % span - 1], axis=1)
    found = []
    for (proto, root), rows in zip(pairs, _rows_by_key(inverse.reshape(-1), len(pairs))):
        prototype = scene.prototypes[proto]
        proxy = instances.roots[root] if root >= 0 else None
        parts = [m.path for m in prototype.meshes] + [s.path for s in prototype.shapes]
        found.append(([part_path(path, prototype.path, proxy) for path in parts], rows))
    return found


def _rows_by_key(keys: np.ndarray, n: int) -> list:
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(n + 1))
    return [order[starts[g]:starts[g + 1]] for g in range(n)]


# Device side -----------------------------------------------------------------------------------------------------


@wp.struct
class DeviceLinks:
    """:class:`HostLinks` on the device; ``enabled = 0``: no linking (the arrays are one-entry placeholders)."""

    enabled: int  # 1 when some light links less than every prim
    shadow_linked: int  # 1 when some geometry casts no shadow of some light (shadow rays look past it)
    masks: wp.array2d[wp.uint8]  # (G, L) LIT | CASTS_SHADOW bits per group and analytic light
    geometry_groups: wp.array[wp.int32]  # (T + S,) group, or part index for prototype geometry
    instance_groups: wp.array[wp.int32]  # (N,) group, or -1 - offset into part_groups
    part_groups: wp.array[wp.int32]  # per-part groups of instances whose parts differ
    columns: wp.array[wp.int32]  # (lights,) column of masks of each device light; -1: linked to everything


def upload_links(host: HostLinks | None, device, columns=None) -> DeviceLinks:
    """The :class:`DeviceLinks` of ``host`` (None: linking off); ``columns`` gives the column of ``host.masks`` of
    each device light (-1: none, lit and shadowed by everything: emissive triangles), the lights' own indices when
    None (the triangles of a mesh light share their light's column)."""
    d = DeviceLinks()
    d.enabled = 0 if host is None else 1
    d.shadow_linked = int(host is not None and host.shadow_linked)

    def arr(values, dtype):
        values = np.asarray(values, np.int32)
        return wp.array(values if len(values) else np.zeros(1, np.int32), dtype=dtype, device=device)

    if host is None:
        d.masks = wp.full((1, 1), LIT | CASTS_SHADOW, dtype=wp.uint8, device=device)
        d.geometry_groups = d.instance_groups = d.part_groups = d.columns = arr([], wp.int32)
        return d
    d.masks = wp.array(host.masks, dtype=wp.uint8, device=device)
    d.geometry_groups = arr(host.geometry_groups, wp.int32)
    d.instance_groups = arr(host.instance_groups, wp.int32)
    d.part_groups = arr(host.part_groups, wp.int32)
    d.columns = arr(np.arange(host.masks.shape[1]) if columns is None else columns, wp.int32)
    return d


@wp.func
def link_group(links: DeviceLinks, prim: int, instance: int):
    """The link group of the geometry hit as ``(prim, instance)`` (0 when linking is off)."""
    if links.enabled == 0 or prim < 0:
        return 0
    g = links.geometry_groups[prim]
    if instance < 0:
        return g
    own = links.instance_groups[instance]
    if own >= 0:
        return own
    return links.part_groups[-1 - own + g]


@wp.func
def link_bit(links: DeviceLinks, group: int, k: int, bit: int):
    """Whether ``bit`` is set for ``group`` and light ``k``; true when linking is off, and for lights without a
    column (emissive triangles)."""
    if links.enabled == 0 or group < 0 or group >= links.masks.shape[0] or k < 0 or k >= links.columns.shape[0]:
        return True
    c = links.columns[k]
    if c < 0:
        return True
    return (int(links.masks[group, c]) & bit) != 0


@wp.func
def lit_by(links: DeviceLinks, group: int, k: int):
    """Light ``k`` lights geometry of link group ``group`` (``collection:lightLink``)."""
    return link_bit(links, group, k, LIT)


@wp.func
def casts_shadow(links: DeviceLinks, group: int, k: int):
    """Geometry of link group ``group`` blocks light ``k``'s shadow rays (``collection:shadowLink``)."""
    return link_bit(links, group, k, CASTS_SHADOW)
