"""A wide BVH (BVH4, BVH8: :mod:`wrt.bvh.wide`) as boxes for :func:`wrt.preview`'s ``bvh_layout``.

The wide layout stores no box of its own per node, only its children's: a wide node's box here is the union of its
children's boxes (min and max of float32 values, so exact). Its leaves are child slots holding triangles; each is
drawn as a node one level below the wide node that holds it, as a binary leaf is one level below its parent. Cuts
then read as the binary tree's do: the cut at depth ``K`` is the wide nodes at depth ``K`` plus the leaves above
them, and every triangle reference lies in exactly one box of it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .bvh.wide import WideBvh


def check_drawn_layout(scene, layout: str, choice: str = "bvh_layout={!r}", binary: str = "bvh_layout='binary'"):
    """Refuses a ``layout`` other than binary for a scene with instances or analytic shapes: the preview draws its
    two-level BVH, which only the binary layout traces; :func:`wrt.trace` traces such a scene in another layout
    flattened (a tree of other boxes, ``compact`` too) or not at all (shapes). ``choice`` and ``binary`` name the
    option as the caller takes it (``--bvh-layout {}`` on the command line)."""
    if layout != "binary" and (len(scene.instances) or scene.shapes):
        raise ValueError(f"{choice.format(layout)}: {scene.source or 'the scene'} has instances or analytic shapes, "
                         f"traced through a two-level BVH that only the binary layout draws; use {binary}")


@dataclasses.dataclass
class WideBoxes:
    """The boxes of a :class:`wrt.bvh.wide.WideBvh`: its ``K`` wide nodes (rows ``0 .. K-1``, node ``k`` in row
    ``k``), then its leaf slots in slot order. Has the fields :func:`wrt.preview.select_bvh_nodes` and
    :func:`wrt.preview.bvh_boxes` read from a ``FlatBvh``.

    Attributes:
        lowers: ``(M, 3)`` float32 box minima.
        uppers: ``(M, 3)`` float32 box maxima.
        node_depths: ``(M,)`` int64 depth of each row (root 0; a leaf one below the wide node holding it).
        prim_count: ``(M,)`` int64 triangle references of a leaf, 0 for a wide node.
        refs_below: ``(M,)`` int64 triangle references below each row (a leaf's own).
        num_nodes: wide nodes ``K``, as ``wrt bvh-stats --layout`` counts them.
        num_prims: triangle references of the tree.
    """

    lowers: np.ndarray
    uppers: np.ndarray
    node_depths: np.ndarray
    prim_count: np.ndarray
    refs_below: np.ndarray
    num_nodes: int
    num_prims: int

    def depths(self) -> np.ndarray:
        return self.node_depths


def wide_boxes(wide: WideBvh) -> WideBoxes:
    """The boxes of ``wide``'s nodes and leaves (see module docstring)."""
    width, count = wide.width, wide.num_nodes
    counts = wide.counts.astype(np.int64).reshape(count, width)
    refs = wide.refs.astype(np.int64).reshape(count, width)
    used = counts >= 0
    lowers = np.where(used[..., None], wide.lowers.reshape(count, width, 3), np.float32(np.inf)).min(axis=1)
    uppers = np.where(used[..., None], wide.uppers.reshape(count, width, 3), np.float32(-np.inf)).max(axis=1)
    depths = np.zeros(count, np.int64)
    levels = [np.zeros(min(count, 1), np.int64)]  # wide nodes by depth, root first
    while len(levels[-1]):
        below = levels[-1]
        inner = counts[below] == 0
        children = refs[below][inner]
        depths[children] = depths[below][:, None].repeat(width, 1)[inner] + 1
        levels.append(children)
    # References below a wide node: its leaves' counts plus its inner children's, deepest level first.
    refs_below = np.where(counts > 0, counts, 0).sum(axis=1)
    for level in reversed(levels[:-1]):
        inner = counts[level] == 0
        below = np.zeros((len(level), width), np.int64)
        below[inner] = refs_below[refs[level][inner]]
        refs_below[level] += below.sum(axis=1)
    leaf = np.flatnonzero(wide.counts > 0)  # slot k * width + j
    leaf_counts = wide.counts[leaf].astype(np.int64)
    return WideBoxes(
        lowers=np.concatenate([lowers, wide.lowers[leaf]]).astype(np.float32),
        uppers=np.concatenate([uppers, wide.uppers[leaf]]).astype(np.float32),
        node_depths=np.concatenate([depths, depths[leaf // width] + 1]),
        prim_count=np.concatenate([np.zeros(count, np.int64), leaf_counts]),
        refs_below=np.concatenate([refs_below, leaf_counts]),
        num_nodes=count,
        num_prims=wide.num_prims,
    )
