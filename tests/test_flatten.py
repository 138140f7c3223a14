"""flatten_source (bottom-up builder output -> canonical tree) against a direct top-down reference: the depth
guarantee's halving, the SAH leaf collapse, and the layout's structure, on random source trees shallow and deep."""

import numpy as np
import pytest
import warp as wp

from wrt.bvh import MAX_DEPTH
from wrt.bvh.flatten import flatten_source


def random_source_tree(rng, n, chain_probability):
    """A binary tree over slots ``0 .. n-1`` in flatten_source's input form, internal ids shuffled. With
    probability ``chain_probability`` a node splits off a single slot, which makes trees far deeper than the
    stack."""
    left, right, counts = (np.zeros(n - 1, np.int32) for _ in range(3))
    ids = iter(rng.permutation(n - 1))
    root = int(next(ids))
    todo = [(root, 0, n)]
    while todo:
        node, start, count = todo.pop()
        counts[node] = count
        if rng.random() < chain_probability:
            n_left = 1 if rng.random() < 0.5 else count - 1
        else:
            n_left = int(rng.integers(1, count))
        for refs, first, size in ((left, start, n_left), (right, start + n_left, count - n_left)):
            if size == 1:
                refs[node] = -first - 1
            else:
                refs[node] = next(ids)
                todo.append((int(refs[node]), first, size))
    return left, right, counts, root


def half_area(lo, hi):
    d = np.maximum(hi - lo, np.float32(0))
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0]


def reference(left, right, counts, root, slot_lowers, slot_uppers, leaf_size):
    """Emitted nodes as ``{(first slot, count): (lower, upper, is_leaf)}``, computed top-down as the builder issue
    states it: keep the source split while both children fit the stack, else halve the slot range from there on;
    then collapse by SAH (C_t = C_i = 1) wherever a subtree of at most ``leaf_size`` is cheaper as a leaf."""
    n = len(slot_lowers)
    nodes = []  # (first, count, depth, children)
    todo = [(0, n, root if n > 1 else None, 0, None)]
    while todo:
        first, count, src, depth, parent = todo.pop()
        nodes.append([first, count, []])
        if parent is not None:
            nodes[parent][2].append(len(nodes) - 1)
        if count == 1:
            continue
        n_left, srcs = count // 2, (None, None)
        if src is not None:
            cl = counts[left[src]] if left[src] >= 0 else 1
            if depth + 1 + int(np.ceil(np.log2(max(cl, count - cl)))) <= MAX_DEPTH - 1:
                n_left = cl
                srcs = tuple(int(r) if r >= 0 else None for r in (left[src], right[src]))
        me = len(nodes) - 1
        todo += [(first + n_left, count - n_left, srcs[1], depth + 1, me), (first, n_left, srcs[0], depth + 1, me)]
    boxes, cost, leaf = {}, {}, {}
    for i in reversed(range(len(nodes))):  # children come after their parent
        first, count, children = nodes[i]
        if not children:
            lo, hi = slot_lowers[first], slot_uppers[first]
            boxes[i], cost[i], leaf[i] = (lo, hi), half_area(lo, hi), True
            continue
        a, b = sorted(children, key=lambda c: nodes[c][0])
        lo, hi = np.minimum(boxes[a][0], boxes[b][0]), np.maximum(boxes[a][1], boxes[b][1])
        area = half_area(lo, hi)
        split, as_leaf = area + cost[a] + cost[b], np.float32(count) * area
        leaf[i] = count <= leaf_size and as_leaf <= split
        boxes[i], cost[i] = (lo, hi), as_leaf if leaf[i] else split
    out, todo = {}, [0]
    while todo:
        i = todo.pop()
        first, count, children = nodes[i]
        out[(first, count)] = (tuple(boxes[i][0]), tuple(boxes[i][1]), leaf[i])
        if not leaf[i]:
            todo += children
    return out


def emitted(bvh):
    """The same dictionary read from a flat tree, checking that every inner node's children are adjacent and
    cover its range, left first."""
    out, todo, ranges = {}, [0], {}
    order = []
    while todo:
        i = todo.pop()
        order.append(i)
        if bvh.prim_count[i] == 0:
            todo += [bvh.left_first[i], bvh.left_first[i] + 1]
    for i in reversed(order):
        if bvh.prim_count[i] > 0:
            ranges[i] = (int(bvh.left_first[i]), int(bvh.prim_count[i]))
        else:
            (a, na), (b, nb) = ranges[bvh.left_first[i]], ranges[bvh.left_first[i] + 1]
            assert a + na == b
            ranges[i] = (a, na + nb)
        out[ranges[i]] = (tuple(bvh.lowers[i]), tuple(bvh.uppers[i]), bool(bvh.prim_count[i] > 0))
    assert len(order) == bvh.num_nodes  # every node is reached once
    return out


@pytest.mark.parametrize("chain_probability", [0.0, 0.5, 0.95])
@pytest.mark.parametrize("seed", range(3))
def test_flatten_matches_the_top_down_reference(chain_probability, seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 1500))
    left, right, counts, root = random_source_tree(rng, n, chain_probability)
    slot_prims = rng.permutation(n).astype(np.int32)
    lowers = rng.uniform(-1, 0, (n, 3)).astype(np.float32)
    uppers = lowers + rng.uniform(0, 0.5, (n, 3)).astype(np.float32)
    leaf_size = int(rng.integers(1, 9))
    ints = [wp.array(a, dtype=wp.int32, device="cpu") for a in (slot_prims, left, right, counts)]
    boxes = [wp.array(b, dtype=wp.vec3, device="cpu") for b in (lowers, uppers)]
    bvh = flatten_source(*ints, root, *boxes, leaf_size=leaf_size).to_host()
    bvh.validate()
    np.testing.assert_array_equal(bvh.prim_ids, slot_prims)
    expected = reference(left, right, counts, root, lowers[slot_prims], uppers[slot_prims], leaf_size)
    assert emitted(bvh) == expected
    if chain_probability > 0.9:
        assert bvh.depths().max() == MAX_DEPTH - 1  # the source tree was far deeper: the halving ran


def test_flatten_halves_a_caterpillar_deeper_than_the_stack(np_rng):
    # Internal node i holds slot i on the left and node i + 1 on the right (depth n - 1).
    n = 200
    i = np.arange(n - 1)
    left = (-i - 1).astype(np.int32)
    right = np.where(i < n - 2, i + 1, -(n - 1) - 1).astype(np.int32)
    lowers = np_rng.uniform(-1, 0, (n, 3)).astype(np.float32)
    arrays = [wp.array(a, dtype=wp.int32, device="cpu") for a in (np.arange(n), left, right, n - i)]
    boxes = [wp.array(b, dtype=wp.vec3, device="cpu") for b in (lowers, lowers + 0.5)]
    bvh = flatten_source(*arrays, 0, *boxes, leaf_size=4).to_host()
    bvh.validate()
    assert bvh.depths().max() <= MAX_DEPTH - 1


def test_flatten_of_one_triangle_is_one_leaf():
    ints = [wp.array(a, dtype=wp.int32, device="cpu") for a in ([0], [], [], [])]
    boxes = [wp.array([v], dtype=wp.vec3, device="cpu") for v in ((0, 1, 2), (3, 4, 5))]
    bvh = flatten_source(*ints, 0, *boxes, leaf_size=4).to_host()
    assert bvh.num_nodes == 1 and bvh.prim_count[0] == 1 and bvh.left_first[0] == 0
    np.testing.assert_array_equal(bvh.lowers[0], (0, 1, 2))
