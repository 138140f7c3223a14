"""The CPU's vectorised wide node step (``wrt.bvh.wide_cpu``) against the scalar slab test it stands in for."""

import numpy as np
import pytest
import warp as wp

from wrt.bvh.stack import WideStack
from wrt.bvh.wide_cpu import WIDE_BUILD_OPTIONS, device_node_boxes
from wrt.geometry import box_origins, intersect_ray_box, safe_inverse

wp.set_module_options({"enable_backward": False, "fuse_fp": False, "extra_build_options": WIDE_BUILD_OPTIONS})


@wp.kernel
def step_kernel(
    boxes: wp.array[float],
    links: wp.array[wp.vec2i],
    width: int,
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_max: float,
    sort: bool,
    # outputs: the child returned, then the stack as pushed (ref, t); -1 after the last entry
    next_ref: wp.array[int],
    pushed_refs: wp.array2d[int],
    pushed_t: wp.array2d[float],
):
    i = wp.tid()
    stack = WideStack()
    origin_lower, origin_upper = box_origins(origins[i], directions[i], 0.0)  # the least margin, as before
    inv_dir = safe_inverse(directions[i])
    step = wp.wrt_wide_enter(boxes, links, 0, width, origin_lower, origin_upper, inv_dir, 0.0, t_max, stack, 0, sort)
    next_ref[i] = step[0]
    for k in range(step[2]):
        pushed_refs[i, k] = wp.wrt_stack_ref(stack, k)
        pushed_t[i, k] = wp.wrt_stack_t(stack, k)


@wp.kernel
def scalar_kernel(
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_max: float,
    entries: wp.array2d[float],
):
    i, j = wp.tid()
    origin_lower, origin_upper = box_origins(origins[i], directions[i], 0.0)  # the least margin, as before
    inv_dir = safe_inverse(directions[i])
    entries[i, j] = intersect_ray_box(origin_lower, origin_upper, inv_dir, lowers[j], uppers[j], 0.0, t_max)


def _node(width, rng):
    """Child boxes on a grid with shared faces, one flat in y, one slot empty."""
    corner = rng.integers(0, 3, (width, 3)).astype(np.float32)
    lowers, uppers = corner, corner + rng.integers(1, 3, (width, 3)).astype(np.float32)
    uppers[1, 1] = lowers[1, 1]  # a flat box
    refs = np.arange(10, 10 + width, dtype=np.int32)
    counts = np.zeros(width, np.int32)
    counts[-1] = -1  # an empty slot: never entered whatever its box
    return lowers, uppers, np.stack([refs, counts], 1)


def _rays(rng, n):
    origins = rng.uniform(-1.0, 6.0, (n, 3)).astype(np.float32)
    directions = (rng.uniform(0.0, 4.0, (n, 3)) - origins).astype(np.float32)  # mostly towards the boxes
    # A third of the rays along an axis, from grid points: they run in the boxes' face planes.
    k = n // 3
    origins[:k] = rng.integers(0, 5, (k, 3)).astype(np.float32)
    directions[:k] = np.eye(3, dtype=np.float32)[rng.integers(0, 3, k)] * rng.choice([-1.0, 1.0], (k, 1))
    return origins, directions


@pytest.mark.parametrize("width", [4, 8])
@pytest.mark.parametrize("t_max", [np.inf, 2.5])
def test_wide_step_matches_the_scalar_slab_test(width, t_max):
    rng = np.random.default_rng(width)
    lowers, uppers, links = _node(width, rng)
    origins, directions = _rays(rng, 600)
    n = len(origins)
    arrays = [wp.array(a, dtype=wp.vec3, device="cpu") for a in (lowers, uppers, origins, directions)]
    entries = wp.empty((n, width), dtype=float, device="cpu")
    wp.launch(scalar_kernel, dim=(n, width), inputs=[*arrays, t_max, entries], device="cpu")
    entries = entries.numpy()
    entries[:, links[:, 1] < 0] = np.inf
    entered = (entries < np.inf) & (entries <= t_max)  # reachable: entered, at most at t_max
    assert entered.any(axis=1).mean() > 0.3 and (entered.sum(axis=1) > 1).any()

    boxes = device_node_boxes(arrays[0], arrays[1], width)
    device_links = wp.array(links, dtype=wp.vec2i, device="cpu")
    for sort in (True, False):
        next_ref = wp.empty(n, dtype=int, device="cpu")
        pushed_refs = wp.full((n, width), -1, dtype=int, device="cpu")
        pushed_t = wp.empty((n, width), dtype=float, device="cpu")
        wp.launch(
            step_kernel,
            dim=n,
            inputs=[boxes, device_links, width, arrays[2], arrays[3], t_max, sort],
            outputs=[next_ref, pushed_refs, pushed_t],
            device="cpu",
        )
        next_ref, pushed_refs, pushed_t = next_ref.numpy(), pushed_refs.numpy(), pushed_t.numpy()
        for i in range(n):
            slots = np.flatnonzero(entered[i])
            got = pushed_refs[i][pushed_refs[i] >= 0]
            if not sort:  # any hit: every entered child pushed, in slot order
                assert next_ref[i] == -1
                np.testing.assert_array_equal(got, links[slots, 0])
                continue
            order = slots[np.argsort(entries[i, slots], kind="stable")]  # nearest first, ties in slot order
            if len(order) == 0:
                assert next_ref[i] == -1 and len(got) == 0
                continue
            assert next_ref[i] == links[order[0], 0]
            np.testing.assert_array_equal(got, links[order[:0:-1], 0])  # the others, far to near
            # The same bits as the scalar test: culling against them must agree with the other layouts.
            np.testing.assert_array_equal(pushed_t[i, : len(got)], entries[i, order[:0:-1]])
