"""The rows :func:`wrt.usd_contents.place_instances` makes of nested instances, and the world-level instances of
one content placed together.

A stage of 2,000 native instances of a tree, each holding native instances of branches that hold leaves and a
PointInstancer of fruit, is 64,000 placements (one per instance and nested instance): walked one at a time, each
was a small matrix product, a name, a few small arrays and a dict lookup per id, over half of ``load_usd``. The
world-level entries of one content key (and as many rows, :func:`member_groups`), wherever they are in the stage,
place the same tree of nested contents, so a group is walked once for all its members (:func:`expand_group`): each
nested content's transforms are one batched product over the members, in the same order of operations as one
member's (outer transform first), so the same bits. Each member's rows are then added in stage order
(:meth:`PlacedRows.add_member`), its nested contents in the depth-first order of the one-at-a-time walk, and its
names, roots and prototypes get their ids in that order too: the arrays are those of the walk, row for row.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .light_links import part_path
from .tubes import place_round

MIN_GROUP = 2  # world-level entries of one content walked together (fewer: one at a time)


def drawn_root(key: tuple, source: str, content_path: str) -> str:
    """Where the root of the content placed under ``key`` by prim ``source`` is drawn, in the namespace of the
    content holding ``source``: a native instance's own path (its prototype root lies there); a PointInstancer's
    prototype, or the shapes of a Points or curves prim, stay where they are."""
    return source if key[0] == "native" else content_path


def nested_looks(outer: np.ndarray | None, inner: np.ndarray | None, n_outer: int, n_inner: int):
    """``(n_outer * n_inner, 4)`` colours and opacities (:func:`wrt.usd_contents.instance_looks`) of the instances
    nested ``n_inner`` in each of ``n_outer`` outer instances, in the order of their combined transforms (outer
    major): the inner instance's (``inner``, one row per nested instance), else the outer instance's (``outer``, one
    row per outer instance), colour and opacity each, NaN where neither gives one; None when neither has any."""
    if outer is None and inner is None:
        return None
    rows = n_outer * n_inner
    outer_rows = np.full((rows, 4), np.nan, np.float32) if outer is None else np.repeat(outer, n_inner, axis=0)
    if inner is None:
        return outer_rows
    inner_rows = np.tile(inner, (n_outer, 1))
    return np.where(np.isnan(inner_rows), outer_rows, inner_rows)


class Segment(NamedTuple):
    """Consecutive placed entries, as arrays: ``(E, 4)`` int64 prototype, world-level source, name and root ids of
    each entry, ``(E,)`` its rows, and per row its transform, world-level index, name index, looks (None: none in
    the segment) and element of a Points or curves prim (None: none in the segment)."""

    entries: np.ndarray
    counts: np.ndarray
    to_world: np.ndarray
    index: np.ndarray
    name_index: np.ndarray
    looks: np.ndarray | None
    element: np.ndarray | None


class PlacedRows:
    """The rows of placed entries, in order, and the ids of their prototypes, sources, names and roots (each
    numbered in the order first met). ``prototype_of(content)`` gives a content's prototype index (adding it)."""

    def __init__(self, prototype_of):
        self.prototype_of = prototype_of
        self.order_ids, self.source_ids = {}, {}  # prim paths: world-level sources (instance order); the names' prims
        self.root_ids = {}  # instance-proxy paths of the prototype roots (light_links)
        self.segments: list[Segment] = []
        self._entries, self._matrices, self._indices, self._names, self._looks, self._elements = [], [], [], [], [], {}
        # Members of groups added since the last segment: (group, member), and their entries and rows per entry.
        self._members, self._member_entries, self._member_counts = [], [], []

    def add(self, content, to_world, source, index, name, looks, root):
        """One placement (:class:`wrt.usd_contents.Placement`'s fields) of a content that draws something."""
        self._flush_members()
        if content.tube is not None:  # a Points or curves prim's sphere or tube piece: its point or curve
            self._elements[len(self._entries)] = name.own
        self._entries.append((self.prototype_of(content), self.order_ids.setdefault(source, len(self.order_ids)),
                              self.source_ids.setdefault(name.path, len(self.source_ids)),
                              self.root_ids.setdefault(root, len(self.root_ids))))
        self._matrices.append(to_world)
        self._indices.append(index)
        self._names.append(name.index)
        self._looks.append(looks)

    def _flush(self):
        """The placements added one at a time since the last segment, as one (numpy arrays made once: per-entry
        arrays took seconds for 40k nested instances)."""
        if not self._entries:
            return
        counts = np.array([len(m) for m in self._matrices], np.int64)
        element = None
        if self._elements:
            element = np.full(int(counts.sum()), -1, np.int32)
            starts = np.cumsum(counts) - counts
            for k, own in self._elements.items():
                element[starts[k] : starts[k] + counts[k]] = own
        looks = None
        if any(c is not None for c in self._looks):  # NaN: instances without a colour or an opacity
            looks = np.concatenate([np.full((len(m), 4), np.nan, np.float32) if c is None else c
                                    for c, m in zip(self._looks, self._matrices)])
        self.segments.append(Segment(np.array(self._entries, np.int64), counts, np.concatenate(self._matrices),
                                     np.concatenate(self._indices), np.concatenate(self._names), looks, element))
        self._entries, self._matrices, self._indices, self._names, self._looks, self._elements = [], [], [], [], [], {}

    def add_member(self, group: Group, member: int):
        """The rows of member ``member`` of ``group`` (:func:`expand_group`), as :meth:`add` adds them placement by
        placement, ids given in the same order."""
        if not group.contents:
            return  # nothing drawn: no ids either
        self._flush()
        order = self.order_ids.setdefault(group.sources[member], len(self.order_ids))
        ids, roots = self.source_ids, self.root_ids
        self._member_entries += [(self.prototype_of(content), order, ids.setdefault(name, len(ids)),
                                  roots.setdefault(root, len(roots)))
                                 for content, name, root in zip(group.contents, group.name_paths[member],
                                                                group.roots[member])]
        self._member_counts.append(group.counts)
        self._members.append((group, member))

    def _flush_members(self):
        """The members added since the last segment, as one: each group's rows gathered at once (a segment per member
        was an array operation per native instance: 100k of them)."""
        if not self._members:
            return
        if len(self._members) == 1:
            # One member (instances of grouped contents between ones placed alone: a flush each): its group's rows,
            # what the gathering below gives for it, without the array work around it (a tenth of the load).
            group, member = self._members[0]
            per_member = int(group.counts.sum())
            rows = slice(member * per_member, (member + 1) * per_member)
            fields = {name: None if getattr(group, name) is None else getattr(group, name)[rows]
                      for name in ("to_world", "index", "name_index", "looks", "element")}
            self.segments.append(Segment(np.array(self._member_entries, np.int64),
                                         np.concatenate(self._member_counts), **fields))
            self._members, self._member_entries, self._member_counts = [], [], []
            return
        groups = list({id(group): group for group, _ in self._members}.values())
        which = {id(group): k for k, group in enumerate(groups)}
        of_group = np.array([which[id(group)] for group, _ in self._members], np.int64)
        members = np.array([member for _, member in self._members], np.int64)
        per_member = np.array([int(group.counts.sum()) for group in groups], np.int64)
        lengths = per_member[of_group]
        starts = np.cumsum(lengths) - lengths  # each member's first row in the segment
        total = int(lengths.sum())
        fields = {}
        for name in ("to_world", "index", "name_index", "looks", "element"):
            arrays = [getattr(group, name) for group in groups]
            if all(a is None for a in arrays):
                fields[name] = None
                continue
            shape = next(a for a in arrays if a is not None).shape[1:]
            dtype = np.result_type(*(a for a in arrays if a is not None))
            fill = np.nan if name == "looks" else -1  # (a group without looks or elements: none, as add makes them)
            out = np.full((total, *shape), fill, dtype) if any(a is None for a in arrays) else \
                np.empty((total, *shape), dtype)
            for k, array in enumerate(arrays):
                if array is None:
                    continue
                mine = of_group == k
                out[_ranges(starts[mine], lengths[mine])] = array[_ranges(members[mine] * per_member[k],
                                                                          lengths[mine])]
            fields[name] = out
        self.segments.append(Segment(np.array(self._member_entries, np.int64), np.concatenate(self._member_counts),
                                     **fields))
        self._members, self._member_entries, self._member_counts = [], [], []

    def arrays(self) -> Segment | None:
        """All rows: ``entries`` repeated to one row each (``(R, 4)``), with ``counts`` None; None without rows."""
        self._flush()
        self._flush_members()
        if not self.segments:
            return None
        looks = element = None
        if any(s.looks is not None for s in self.segments):
            looks = np.concatenate([np.full((len(s.to_world), 4), np.nan, np.float32) if s.looks is None else s.looks
                                    for s in self.segments])
        if any(s.element is not None for s in self.segments):
            element = np.concatenate([np.full(len(s.to_world), -1, np.int32) if s.element is None else s.element
                                      for s in self.segments])
        entries = np.concatenate([np.repeat(s.entries, s.counts, axis=0) for s in self.segments])
        return Segment(entries, None, np.concatenate([s.to_world for s in self.segments]),
                       np.concatenate([s.index for s in self.segments]),
                       np.concatenate([s.name_index for s in self.segments]), looks, element)


def _ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The concatenated ``arange(start, start + length)`` of each ``(starts, lengths)`` pair, int64."""
    return np.repeat(starts - (np.cumsum(lengths) - lengths), lengths) + np.arange(int(lengths.sum()))


def member_groups(entries: list, contents: dict, min_group: int = MIN_GROUP) -> dict:
    """``{position: (group, member)}`` of the ``entries`` (a content's instances: ``(key, (K, 4, 4) m, source,
    index, looks)``) that :func:`expand_group` walks together: those of one key (of a content that nests instances:
    one without is one placement an entry, cheaper placed alone) and as many rows, looks given by all or none,
    indices of one dtype, in groups of at least ``min_group`` (``group``: the list of their positions)."""
    groups = {}
    for position, (key, m, _, index, looks) in enumerate(entries):
        if contents[key].instances:
            groups.setdefault((key, len(m), looks is None, index.dtype), []).append(position)
    return {position: (group, member) for group in groups.values() if len(group) >= min_group
            for member, position in enumerate(group)}


class _Placed(NamedTuple):
    """One nested content placed by each of the N members of a group: :class:`wrt.usd_contents.Placement` with a
    leading axis of members (strings: one per member)."""

    content: object
    to_world: np.ndarray  # (N, K, 4, 4)
    index: np.ndarray  # (N, K) world-level index
    name_paths: list  # (N,) str: the prim each member's instances are named by
    name_index: np.ndarray  # (N, K)
    names_inside: bool  # what is nested is named by its own path (see wrt.usd_contents._Name)
    own: np.ndarray  # (N, K) index in the arrays of the prim that made each
    looks: np.ndarray | None  # (N, K, 4)
    roots: list  # (N,) str


class Group(NamedTuple):
    """The rows of the N members of a group (:func:`expand_group`): per member, its ``(Q,)`` drawn placements' rows
    ``counts`` (one sum R for all), member-major arrays of ``N * R`` rows (see :class:`Segment`), and per member
    its source, and the name and root paths of its drawn placements."""

    contents: list  # (Q,) the contents drawn, in the depth-first order of one member's placements
    counts: np.ndarray  # (Q,) int64
    to_world: np.ndarray
    index: np.ndarray
    name_index: np.ndarray
    looks: np.ndarray | None
    element: np.ndarray | None
    sources: list  # (N,) str
    name_paths: list  # (N,) lists of (Q,) str
    roots: list  # (N,) lists of (Q,) str


def expand_group(members: list, contents: dict) -> Group:
    """The rows of the world-level entries ``members`` (one key and as many rows, :func:`member_groups`) and of
    everything nested in them, as :func:`wrt.usd_contents.placements` makes them one entry at a time."""
    key = members[0][0]
    content = contents[key]
    sources = [source for _, _, source, _, _ in members]
    index = np.stack([index for _, _, _, index, _ in members])
    looks = None if members[0][4] is None else np.stack([looks for *_, looks in members])
    first = _Placed(content, np.stack([m for _, m, *_ in members]), index, sources, index, key[0] == "native", index,
                    looks, [drawn_root(key, source, content.path) for source in sources])
    # The depth-first walk of the one-at-a-time placements, all members at once.
    placed, pending = [], [first]
    while pending:
        outer = pending.pop()
        placed.append(outer)
        n, k = outer.to_world.shape[:2]
        for inner_key, m, inner_source, inner_index, inner_looks in reversed(outer.content.instances):
            nested = contents[inner_key]
            if nested.tube is None:
                combined = (outer.to_world[:, :, None] @ m[None, None]).reshape(n, -1, 4, 4)
            else:
                combined = np.stack([place_round(t, m, *nested.tube) for t in outer.to_world])
            own = np.tile(inner_index, (n, k))
            if outer.names_inside:
                paths = [part_path(inner_source, outer.content.path, root) for root in outer.roots]
                names, name_index, inside = paths, own, inner_key[0] == "native"
            else:
                names, name_index, inside = outer.name_paths, np.repeat(outer.name_index, len(m), axis=1), False
            looks = nested_looks(None if outer.looks is None else outer.looks.reshape(-1, 4), inner_looks, n * k,
                                 len(m))
            root = drawn_root(inner_key, inner_source, nested.path)
            pending.append(_Placed(nested, combined, np.repeat(outer.index, len(m), axis=1), names, name_index, inside,
                                   own, None if looks is None else looks.reshape(n, -1, 4),
                                   [part_path(root, outer.content.path, r) for r in outer.roots]))
    drawn = [p for p in placed if p.content.meshes or p.content.shapes]
    n = len(members)

    def member_major(arrays):  # (N, K_j, ...) per placement -> rows member by member, placements in order
        if not arrays:
            return np.zeros(0)
        return np.concatenate([a.reshape(n, -1) for a in arrays], axis=1).reshape(-1, *arrays[0].shape[2:])

    looks = None
    if any(p.looks is not None for p in drawn):
        looks = member_major([np.full((n, p.to_world.shape[1], 4), np.nan, np.float32) if p.looks is None else p.looks
                              for p in drawn])
    element = None
    if any(p.content.tube is not None for p in drawn):
        element = member_major([p.own.astype(np.int32) if p.content.tube is not None
                                else np.full(p.own.shape, -1, np.int32) for p in drawn])
    return Group([p.content for p in drawn], np.array([p.to_world.shape[1] for p in drawn], np.int64),
                 member_major([p.to_world for p in drawn]), member_major([p.index for p in drawn]),
                 member_major([p.name_index for p in drawn]), looks, element, sources,
                 [list(paths) for paths in zip(*(p.name_paths for p in drawn))] if drawn else [[] for _ in members],
                 [list(paths) for paths in zip(*(p.roots for p in drawn))] if drawn else [[] for _ in members])
