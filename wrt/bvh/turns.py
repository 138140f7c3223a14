"""Leaf and node turns: the lanes of a CUDA warp take their traversal steps together, leaves or inner nodes.

A traversal loop step is a leaf (triangle tests) or an inner node (box tests), and the lanes of a warp execute the
step kinds that any of them takes one after the other. Nsight Compute on an H200 (BVH4, chess_set, incoherent rays)
showed the leaf code running with 1.2 of 32 lanes on average, nearly as often as the node code with 7.8: most loop
passes paid for both kinds, the leaf for a single lane. Aila and Laine's while-while loop ("Understanding the
Efficiency of Ray Traversal on GPUs", 2009) groups the kinds by having leaf lanes wait until no lane has a node
left; here leaf lanes wait only until half of the warp's active lanes hold a leaf (or no lane holds a node), and
then every lane with a leaf tests it while the others wait. On the H200 this was the best of the shares measured
(all, 2/3, 1/2, 1/3, 1/4, any): the BVH4 gained 9-15% on every ray kind, the binary layout 0-15% (GPU_NOTES.md, row
35).

The visiting order of each ray is unchanged (a waiting lane only skips a pass), so hits and node counts are the same
bit for bit. On the CPU every lane is alone: its step always has the turn.
"""

from __future__ import annotations

import warp as wp


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    const unsigned int lanes = __activemask();
    const int leaves = __popc(__ballot_sync(lanes, at_leaf));
    return leaves > 0 && 2 * leaves >= __popc(lanes);
#else
    return at_leaf;
#endif
""")
def leaf_turn(at_leaf: bool) -> bool:
    """True on a leaf turn of the calling lanes (see the module docstring): half of them or more are at a leaf, or
    all of them are. A lane whose step kind (``at_leaf``) differs from the turn waits for one pass; the turn always
    has at least one lane of its kind, so every ray finishes."""


@wp.func
def waits(at_leaf: bool) -> bool:
    """The calling lane skips this pass of its traversal loop: its step is not of the kind whose turn it is."""
    return leaf_turn(at_leaf) != at_leaf
