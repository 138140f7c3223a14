"""Contents: what one subtree of a stage draws in one space (the world's, or a prototype's), the walk context that
fills one, and the resolution of contents nested in each other (native instances, PointInstancers, at any depth)
into ``Scene.prototypes`` and one level of ``Scene.instances``."""

from __future__ import annotations

import copy
from typing import NamedTuple

import numpy as np
from pxr import Sdf, Usd

from .assignments import mark_checked
from .instancing import (
    NO_FLOAT32_INVERSE_SKIPPED,
    ZERO_SCALE_SKIPPED,
    Instances,
    Prototype,
    invert_transforms,
    singular_transforms,
    thicken_flat_transforms,
    unplaceable,
)
from .light_links import part_path
from .primitives import Shape
from .scene import Mesh, Scene, instances_past_float32
from .tubes import place_round
from .usd_placement_groups import MIN_GROUP, PlacedRows, drawn_root, expand_group, member_groups, nested_looks
from .usd_xforms import PROJECTIVE, divide_weights

# The prims a prototype's walk takes: active, loaded, not abstract, and with a defining specifier of their own,
# their ancestors' not asked (see wrt.usd's _content), as Hydra's prototype predicate takes them. Without the last
# clause an ``over`` inside a prototype was drawn, with all it holds: a native instance drew what the same asset
# referenced plainly (the world walk asks "defined") does not.
PROTOTYPE_PREDICATE = Usd.PrimIsActive & Usd.PrimIsLoaded & ~Usd.PrimIsAbstract & Usd.PrimHasDefiningSpecifier


class Content:
    """What one subtree draws, in one space (the world, or a prototype's): meshes, and instances of other contents."""

    def __init__(self, path: str):
        self.path = path  # prim path of the subtree root
        self.meshes: list[Mesh] = []  # in this content's space
        self.shapes: list[Shape] = []  # analytic gprims, in this content's space
        # (content key, (K, 4, 4) column-vector transforms to this space, source, indices, looks): looks are the
        # instances' (K, 4) colour and displayOpacity (NaN: none; see instance_looks), or None.
        self.instances: list = []
        # Binding purposes ("" all-purpose, "full", ...) whose walk from some prim inside finds no material up to this
        # content's root: there the bindings on and above an instance of it apply (Context.outer_bindings).
        self.outer_purposes: set[str] = set()
        # Colour primvars (displayColor, or the one a material reads) that a mesh or gprim lacks: one an instance
        # hands down applies.
        self.outer_colors: list[str] = []
        self.colors: dict = {}  # outer (primvar, colour) -> content key: this prototype read again with that colour
        # A Points or curves prim in it has no widths primvar (own or inherited inside): one an instance hands down
        # applies, and ``widths`` maps each such width to the key of this prototype read again with it.
        self.wants_widths = False
        self.widths: dict = {}
        # Texture-coordinate primvars (st, ...) that a mesh lacks (none inside up to its root): a constant one an
        # instance hands down applies, and ``uvs`` maps each such ((primvar, (s, t)), ...) to the key of this
        # prototype read again with it.
        self.outer_uvs: list[str] = []
        self.uvs: dict = {}
        # (mesh prim, path it is drawn at, primvar, fallback st) of the meshes that read their texture's fallback st
        # for want of one: named in a warning where no instance hands one down (wrt.usd_native_instances, which puts
        # them at their instance-proxy paths), once they reach the world.
        self.uv_misses: list[tuple] = []
        self.cameras: list[Sdf.Path] = []  # cameras of a native prototype, relative to its root (nested ones too)
        self.lights: list[Sdf.Path] = []  # UsdLux lights (not mesh lights) of a native prototype, likewise
        # (light prim, (4, 4) column-vector transform to this space, purpose) of the UsdLux lights of a PointInstancer's
        # prototype (those of native instances in it at their instance-proxy paths): one light per instance placed;
        # the purpose is the one the prototype's geometry there takes (Visibility._purpose).
        self.placed_lights: list[tuple[Usd.Prim, np.ndarray, str]] = []
        self.prototype = -1  # index into Scene.prototypes once its meshes are placed there
        # (is a sphere, width axis (wrt.tubes.width_axis)) of the spheres or tube segments of a Points or curves prim:
        # instances of them stay round under any transform placed above (wrt.tubes.place_round).
        self.tube: tuple[bool, np.ndarray] | None = None

    def want_colors(self, names):
        """Records colour primvars that geometry in this content lacks (see :attr:`outer_colors`)."""
        self.outer_colors += [name for name in names if name not in self.outer_colors]

    def want_uvs(self, names):
        """Records texture-coordinate primvars that meshes in this content lack (see :attr:`outer_uvs`)."""
        self.outer_uvs += [name for name in names if name not in self.outer_uvs]


class Context:
    """Where a walk is: the content being filled, how to reach its space, and what applies from outside."""

    def __init__(
        self,
        content: Content,
        space_root: Usd.Prim | None = None,
        outer_bindings=None,
        world=False,
        outer_purpose=None,
        outer_color=None,
        outer_widths=None,
        proxy=None,
        instance_opacity=False,
        outer_uv=None,
        outer_hidden=frozenset(),
    ):
        self.content = content
        self.space_root = space_root  # transforms are relative to this prim (None: world / native prototype root)
        self.stop = space_root  # visibility and purpose are inherited from below this prim (None: everything)
        # What each binding purpose's walk finds on and above the native instance being read (a tuple of
        # wrt.usd_bindings.OuterBinding), or None: the end of the walk of the prims inside.
        self.outer_bindings = outer_bindings
        # (prototype root path, path of the instance read): its prims bind as the instance's proxies at those paths
        # do (a collection bound above names some of them: wrt.usd_bindings.CollectionsInside), or None
        self.proxy = proxy
        # ((primvar, (r, g, b)), ...): constant colours inherited by a native instance (displayColor, a primvar a
        # material reads), or None
        self.outer_color = outer_color
        self.outer_widths = outer_widths  # constant primvars:widths inherited by a native instance (float), or None
        # ((primvar, (s, t)), ...): constant texture coordinates inherited by a native instance, or None
        self.outer_uv = outer_uv
        # The purpose inherited by a native instance or a PointInstancer prototype: a non-rendered one, or a rendered
        # one hidden there (outer_hidden) or that an opinion gives (a PointInstancer inside draws its prototypes by it,
        # a UsdGeomVisibilityAPI opinion inside hides the prims that inherit it), else None
        self.outer_purpose = outer_purpose
        # Drawn purposes that UsdGeomVisibilityAPI opinions on or above the native instance read hide: the prims
        # inside with no opinion of their own up to the prototype root are hidden for them (Visibility._rendered)
        self.outer_hidden = outer_hidden
        self.world = world  # the stage itself (cameras and UsdLux lights are read only here)
        # A PointInstancer's prototype whose instancer gives its instances a displayOpacity (Hydra's instance primvar)
        self.instance_opacity = instance_opacity

    @property
    def keep_opaque(self) -> bool:
        """A prim's own displayOpacity of 1 is kept: in a prototype it wins over its instance's opacity."""
        return not self.world

    @property
    def blocked_opaque(self) -> bool:
        """A prim whose displayOpacity a non-constant one above blocks (FindPrimvarWithInheritance finds none) is
        opaque, so that no instance's opacity reaches it either: in a prototype, but not in a PointInstancer's whose
        instancer gives its instances one, which reaches the prims without one past such a blocker, as its colour
        does (the nearest instance that gives an opacity is that instancer)."""
        return not self.world and not self.instance_opacity


class Placement(NamedTuple):
    """One content placed in the world by one entry of some content's instances, nested ones resolved."""

    content: Content
    to_world: np.ndarray  # (K, 4, 4) column-vector transforms, content -> world, outer instances major
    source: str  # the world-level prim that makes these instances (instance order)
    index: np.ndarray  # (K,) that prim's instance index of each (-1: a native instance)
    name: _Name  # how the instances are named (Instances.path)
    looks: np.ndarray | None  # (K, 4) colours and opacities (instance_looks), or None
    root: str  # the path the content's root is drawn at (an instance-proxy path inside native instances)
    levels: tuple  # per nesting level, outermost first, the (n_l,) instance indices there (-1: native); row
    # r of to_world is the r-th combination of them, outer major (see placed_indices)
    makers: tuple  # per nesting level, the path of the prim that makes its instances (an instance-proxy path inside
    # native instances): the PointInstancer an index of levels counts in


def placements(world: Content, contents: dict):
    """Each :class:`Placement` of the contents instanced by ``world`` (the stage's content; ``contents``: key ->
    :class:`Content`), depth first, each instance before the instances nested in it."""
    return _placed(world.instances, contents)


def _placed(entries: list, contents: dict):
    """:func:`placements` of the world-level instance ``entries`` (``(key, m, source, index, looks)``)."""
    # An explicit stack: a recursive closure would refer to itself, a reference cycle that kept the stage open until
    # a garbage collection. Each entry carries the path its content's root is drawn at: a native instance's prim path
    # (an instance proxy path when nested), else the content's own path moved by the instance it is nested in.
    pending = [Placement(contents[key], m, source, index, _Name(source, index, key[0] == "native"), color,
                         drawn_root(key, source, contents[key].path), (index,), (source,))
               for key, m, source, index, color in reversed(entries)]
    while pending:
        placement = pending.pop()
        yield placement
        content, to_world, source, index, name, color, root, levels, makers = placement
        for key, m, inner_source, inner_index, inner in reversed(content.instances):
            # Nested instances keep the world-level source and index of the instance they are part of (instance
            # order), the name of the innermost instance a user can select (:class:`_Name`), and the colour and
            # opacity of the nearest instance that gives one.
            nested = contents[key]
            if nested.tube is None:
                combined = (to_world[:, None] @ m[None]).reshape(-1, 4, 4)
            else:  # a Points or curves prim's spheres or tubes: round, as in a flattened copy of these instances
                combined = place_round(to_world, m, *nested.tube)
            inner_root = part_path(drawn_root(key, inner_source, nested.path), content.path, root)
            maker = part_path(inner_source, content.path, root)
            pending.append(Placement(nested, combined, source, np.repeat(index, len(m)),
                                     name.nested(key, maker, inner_index),
                                     nested_looks(color, inner, len(to_world), len(m)), inner_root,
                                     levels + (inner_index,), makers + (maker,)))


def placed_indices(levels: tuple, row: int) -> list[int]:
    """The instance index at each nesting level (outermost first; -1: a native instance) of row ``row`` of a
    :class:`Placement` of ``levels``."""
    found = []
    for level in reversed(levels):
        row, k = divmod(row, len(level))
        found.append(int(level[k]))
    return found[::-1]


def placed_name(path: str, found_at: list[int], makers: tuple) -> str:
    """The name of the prototype prim at ``path`` placed at instance indices ``found_at`` (:func:`placed_indices`)
    of the instancers ``makers`` (:attr:`Placement.makers`): ``path`` and, outermost first, ``[k]`` for each
    PointInstancer's index, ``[/Instancer[k]]`` where ``path`` does not lie beneath that instancer (a prototype
    outside it, which another instancer may place too: both named ``/Protos/Bulb[0]`` could not be told apart)."""
    return path + "".join(f"[{k}]" if path.startswith(maker.rstrip("/") + "/") else f"[{maker}[{k}]]"
                          for k, maker in zip(found_at, makers) if k >= 0)


def place_instances(world: Content, contents: dict, scene: Scene, skip_path, stable_name=None,
                    min_group: int = MIN_GROUP) -> np.ndarray | None:
    """Resolves nested instancing into ``scene.prototypes`` and one level of ``scene.instances``: ``world`` is the
    stage's content, ``contents`` every content read (key -> :class:`Content`), ``skip_path(reason, path)`` records
    an instance left out, ``stable_name(path)`` is the path a prototype, mesh or shape read at ``path`` is named by
    in the scene (a native prototype's, which USD numbers anew per opening; None: its own). Returns the inverses of
    the instances' transforms, or None without instances."""

    def prototype_of(content: Content) -> int:
        """The index of ``content``'s prototype in ``scene.prototypes``, added at its first placement."""
        if content.prototype < 0:
            content.prototype = len(scene.prototypes)
            path, meshes, shapes = content.path, content.meshes, content.shapes
            if stable_name is not None:
                path = stable_name(path)
                meshes = [named(m, stable_name) for m in meshes]
                shapes = [named(s, stable_name) for s in shapes]
            scene.prototypes.append(Prototype(path, meshes, shapes))
        return content.prototype

    # World-level instances of one content are walked together (wrt.usd_placement_groups), the others one placement
    # at a time; the rows are the same, in the same order.
    placed_rows = PlacedRows(prototype_of)
    grouped = member_groups(world.instances, contents, min_group)
    expanded = {}  # a group's first position -> its rows
    for position, entry in enumerate(world.instances):
        if position in grouped:
            group, member = grouped[position]
            if group[0] not in expanded:
                expanded[group[0]] = expand_group([world.instances[p] for p in group], contents)
            placed_rows.add_member(expanded[group[0]], member)
            continue
        for content, to_world, source, index, name, color, root, *_ in _placed([entry], contents):
            if content.meshes or content.shapes:
                placed_rows.add(content, to_world, source, index, name, color, root)
    placed = placed_rows.arrays()
    if placed is None:
        return None
    prototype, world_source, name_source, root_of = placed.entries.T
    elements = placed.element is not None  # rows of Points or curves prims' spheres and tube pieces
    element = placed.element if elements else np.full(len(prototype), -1, np.int32)
    # Instance order: world-level sources in stage order, a PointInstancer's instances in index order; the
    # instances nested inside one world-level instance stay together, in the order they were read.
    world = np.stack([world_source, placed.index], axis=1)
    order = np.lexsort((world[:, 1], world[:, 0]))  # stable
    world, element = world[order], element[order]
    to_world = divide_weights(placed.to_world[order])  # (a copy: indexed)
    projective = np.flatnonzero(np.any(to_world[:, 3] != (0.0, 0.0, 0.0, 1.0), axis=1))
    to_world[:, 3] = (0.0, 0.0, 0.0, 1.0)  # as for meshes: only the affine part is used
    colors, opacities = np.zeros((0, 3), np.float32), np.zeros(0, np.float32)  # none given: no arrays
    if placed.looks is not None:  # NaN: instances without a colour or an opacity
        looks = placed.looks[order]
        if not np.isnan(looks[:, :3]).all():
            colors = np.ascontiguousarray(looks[:, :3])
        if not np.isnan(looks[:, 3]).all():
            opacities = np.ascontiguousarray(looks[:, 3])
    instances = Instances(prototype[order], to_world, name_source[order], placed.name_index[order],
                          list(placed_rows.source_ids), colors, list(placed_rows.root_ids), root_of[order], opacities,
                          element if elements else np.zeros(0, np.int32))
    # Named once per world-level USD instance, the one whose transform is at fault most often: a Points or curves
    # prim in it is an instance row per sphere or tube piece.
    world_sources = list(placed_rows.order_ids)

    def world_path(i: int) -> str:
        return world_sources[world[i, 0]] + (f"[{world[i, 1]}]" if world[i, 1] >= 0 else "")

    for path in dict.fromkeys(map(world_path, projective)):
        skip_path(PROJECTIVE, path)
    # A zero scale on one axis flattens an instance into a sheet that USD draws (and so does wrt, for a mesh that is
    # not instanced): it is drawn thin rather than skipped. Fewer directions than two leave nothing of any area. The
    # spheres and tubes of Points and curves are placed round (place_round), so theirs are not flattened but zero.
    # Every transform is inverted once; only the singular ones are looked at again (thickened and re-inverted).
    inverses, ok = invert_transforms(instances.to_world)
    singular = np.flatnonzero(~ok & (element < 0))  # mesh rows: Points and curves are not flattened
    if len(singular):
        thick, thickened = thicken_flat_transforms(instances.to_world[singular])
        rows = singular[thickened]
        if len(rows):
            instances.to_world[rows] = thick[thickened]  # the array made above: no one else holds it
            inverses[rows], ok[rows] = invert_transforms(instances.to_world[rows])
    # An instance placed past float32's range (a translation of 1e39) is no zero scale: said as it is.
    far = unplaceable(instances.to_world)
    refused = np.flatnonzero(~ok & ~far)  # only these are judged again (a determinant each: seconds for millions)
    zero = singular_transforms(instances.to_world[refused])  # told from a finite scale float32 cannot invert
    for path in dict.fromkeys(map(world_path, refused[zero])):
        skip_path(ZERO_SCALE_SKIPPED, path)
    for path in dict.fromkeys(map(world_path, refused[~zero])):
        skip_path(NO_FLOAT32_INVERSE_SKIPPED, path)
    for path in dict.fromkeys(map(world_path, np.flatnonzero(~ok & far))):
        skip_path("instances placed beyond float32's range (|x| > 3.4e38) were skipped", path)
    # One whose transform takes its prototype's box past float32 (a scale of 1e37) is left out likewise: kept, the
    # trace refused the whole scene for it, naming it.
    past = [i for i, _, _ in instances_past_float32(instances, scene.prototypes, first_only=False) if ok[i]]
    for path in dict.fromkeys(map(world_path, past)):
        skip_path("instances whose transform takes their prototype past float32's range (|x| > 3.4e38) were skipped",
                  path)
    ok[past] = False
    if not ok.all():
        instances = instances.take(ok)
    scene.instances = instances
    return inverses[ok]  # the scene's first trace needs them too


def named(part, stable_name):
    """``part`` (a mesh, shape or material) named ``stable_name(part.path)``: itself, or a shallow copy (a kept stage's
    memo holds the read one) that keeps its checked state, only its path, a prim path, being new."""
    path = stable_name(part.path)
    if path == part.path:
        return part
    checked = not part.__dict__.get("_unchecked", False)
    renamed = copy.copy(part)
    renamed.path = path
    if checked:
        mark_checked(renamed)
    return renamed


class _Name:
    """How the instances of one entry of :func:`place_instances` are named (:meth:`wrt.instancing.Instances.path`):
    the prim a user selects for them in usdview, ``path``, and ``index`` ``(K,)`` into its arrays (-1: none), and
    each one's ``own`` index in the arrays of the prim that made it (a Points prim's point). A native instance's
    nested instances have instance-proxy paths (``/Outer/Inner``, ``/Outer/Kit[2]``: outer path plus the inner
    prim's path inside it), so each is named by its own; a PointInstancer's prototype is one prim for all its
    instances, so what is nested in it is named by the instancer's instance (``/PI[3]``)."""

    def __init__(self, path: str, index: np.ndarray, names_inside: bool, own: np.ndarray | None = None):
        self.path, self.index, self.names_inside = path, index, names_inside
        self.own = index if own is None else own

    def nested(self, key: tuple, path: str, index: np.ndarray) -> _Name:
        """The name of the instances nested in these by ``key`` at ``path`` (its instance-proxy path, when there is
        one), ``index`` ``(M,)`` in its arrays: ``(K * M,)`` rows, outer major, as the combined transforms."""
        own = index if len(self.index) == 1 else np.tile(index, len(self.index))
        if not self.names_inside:
            return _Name(self.path, np.repeat(self.index, len(index)), False, own)
        return _Name(path, own, key[0] == "native", own)


def instance_looks(colors: np.ndarray | None, opacities: np.ndarray | None) -> np.ndarray | None:
    """``(K, 4)`` float32 per-instance colour ``(K, 3)`` and opacity ``(K,)`` side by side, NaN for the one that is
    None; None when both are."""
    if colors is None and opacities is None:
        return None
    n = len(colors if colors is not None else opacities)
    looks = np.full((n, 4), np.nan, np.float32)
    if colors is not None:
        looks[:, :3] = colors
    if opacities is not None:
        looks[:, 3] = opacities
    return looks
