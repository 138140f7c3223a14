"""The 16-byte child records of the CUDA wide traversal (``wrt.bvh.packed``): written and read back bit for bit, and the
box that stands in for an empty child slot is missed by every ray."""

import numpy as np
import pytest
import warp as wp

from wrt.bvh.packed import load_child, pack_child
from wrt.geometry import box_origins, intersect_ray_box, safe_inverse

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.kernel
def round_trip_kernel(
    lowers: wp.array[wp.vec3],
    uppers: wp.array[wp.vec3],
    links: wp.array[wp.vec2i],
    children: wp.array[wp.vec4],
    out_boxes: wp.array2d[wp.vec3],
    out_links: wp.array[wp.vec2i],
):
    i = wp.tid()
    pack_child(children, i, lowers[i], uppers[i], links[i])
    lower, upper, link = load_child(children, i)
    out_boxes[i, 0] = lower
    out_boxes[i, 1] = upper
    out_links[i] = link


def test_records_round_trip_bit_for_bit():
    rng = np.random.default_rng(3)
    n = 64
    lowers = rng.normal(size=(n, 3)).astype(np.float32) * np.float32(1e6)
    lowers[0] = [np.float32(1e-38), -0.0, np.inf]  # subnormal-sized, negative zero and inf survive the trip
    uppers = lowers + np.abs(rng.normal(size=(n, 3))).astype(np.float32)
    # Links whose bit patterns are float subnormals (small ints), NaNs (-1) and the extremes.
    links = rng.integers(-(2**31), 2**31 - 1, size=(n, 2), dtype=np.int64).astype(np.int32)
    links[:4] = [[0, -1], [5, 0], [2**31 - 1, 8], [-(2**31), 3]]
    arrays = [wp.array(a, dtype=t) for a, t in ((lowers, wp.vec3), (uppers, wp.vec3), (links, wp.vec2i))]
    children, boxes, out_links = wp.empty(2 * n, dtype=wp.vec4), wp.empty((n, 2), dtype=wp.vec3), wp.empty(n, wp.vec2i)
    wp.launch(round_trip_kernel, n, inputs=[*arrays, children, boxes, out_links])
    np.testing.assert_array_equal(boxes.numpy()[:, 0].view(np.uint32), lowers.view(np.uint32))
    np.testing.assert_array_equal(boxes.numpy()[:, 1].view(np.uint32), uppers.view(np.uint32))
    np.testing.assert_array_equal(out_links.numpy(), links)


@wp.kernel
def empty_slot_kernel(
    origins: wp.array[wp.vec3], directions: wp.array[wp.vec3], t_max: float, entries: wp.array[float]
):
    i = wp.tid()
    origin_lower, origin_upper = box_origins(origins[i], directions[i], 0.0)
    entries[i] = intersect_ray_box(
        origin_lower, origin_upper, safe_inverse(directions[i]), wp.vec3(wp.inf), wp.vec3(wp.inf), 0.0, t_max
    )


@pytest.mark.parametrize("t_max", [1.0, 3.0e38, float("inf")])
def test_the_empty_slot_box_is_missed_by_every_ray(t_max):
    # Every sign pattern of the direction, zero components included (FLAT_INVERSE), from ordinary, huge and tiny
    # origins: the box at (+inf, +inf, +inf) must never be entered. The traversals enter a box when its entry is
    # below inf; with t_max = inf the entry of a ray going up all three axes comes out NaN, which fails that too.
    axes = np.array([-1.0, 0.0, 1.0], np.float32)
    dirs = np.stack(np.meshgrid(axes, axes, axes, indexing="ij"), -1).reshape(-1, 3)
    dirs = dirs[np.abs(dirs).sum(1) > 0]
    origins = np.array([[0, 0, 0], [1e30, -1e30, 3], [-1e-30, 2e-38, 0.5], [3e38, 3e38, 3e38]], np.float32)
    o = np.repeat(origins, len(dirs), 0)
    d = np.tile(dirs, (len(origins), 1))
    entries = wp.empty(len(o), dtype=float)
    wp.launch(empty_slot_kernel, len(o), inputs=[wp.array(o, dtype=wp.vec3), wp.array(d, dtype=wp.vec3), t_max,
                                                 entries])
    entered = entries.numpy() < np.inf
    assert not entered.any(), (o[entered], d[entered])
