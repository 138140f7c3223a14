"""The wide layout's node step on the CPU: every child box of a node tested at once with vector instructions.

On the CPU a Warp thread is a plain loop iteration, and the compiler does not vectorise a loop over a node's
children on its own. So the CPU keeps a wide node's child boxes as six runs of ``width`` floats (lower x, y, z, then
upper x, y, z), and one C++ function (``wrt::wide_enter``, registered as ``wp.wrt_wide_enter``) runs the slab test
of all four or eight children with clang vector types, turns the entered ones into a bit mask, orders them and
pushes them. In one A/B run on one CPU thread, wide8 went from 0.9-1.6x to 1.4-2.2x of ``wp.Mesh(sah)``
(RESULTS.md). CUDA, where each thread is already a SIMD lane, keeps the per-child boxes and the Warp code in
``wide.py``; ``on_cpu`` picks the branch at compile time.

The vector form repeats ``geometry.intersect_ray_box``'s arithmetic operation for operation (the CPU's
``box_origins``, no slack, no FMA contraction, the same min/max selects and rounding of the entry), so both give the
same bits, and the BVH4 the same visiting order as the CUDA path (BVH8 on CUDA pushes unsorted: ``wide.py``);
``tests/test_wide_simd.py`` compares them.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..geometry import ENTRY_SLACK, ROBUST_FAR_SLACK
from .stack import STACK_PREAMBLE, WideStack

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile

BOX_PLANES = 6  # lower x, y, z and upper x, y, z: one run of ``width`` floats each per node


def _float32_literal(value: float) -> str:
    return f"{float(np.float32(value))!r}f"


# The node step. The children's entry distances come from one vector slab test (loads are unaligned-safe,
# ``aligned(4)``); the entered ones (``reachable``: entry <= t_max, slot not empty) become a bit mask, and then:
# - closest hit (``sort``): the entered children are ordered by entry distance, ties in slot order (the insertion
#   order of the CUDA path), the others pushed far to near, and the nearest returned;
# - any hit: every entered child is pushed in slot order, and none is returned.
# Returns (ref, count, top): the child to visit next (ref -1: none) and the new stack size.
_PREAMBLE = (
    """
namespace wrt {
#if !defined(__CUDA_ARCH__)
// Entry distances of the L children of a node of width L (see intersect_ray_box) and the mask of those entered.
template <int L>
inline unsigned int enter_lanes(
    const float* p, const int* links, const wp::vec3& origin_lower, const wp::vec3& origin_upper,
    const wp::vec3& inv_dir, float t_min, float t_max, float* entry)
{
    typedef float fv __attribute__((ext_vector_type(L), aligned(4)));
    typedef int iv __attribute__((ext_vector_type(L), aligned(4)));
    const fv t0x = (*(const fv*)(p) - origin_lower[0]) * inv_dir[0];
    const fv t0y = (*(const fv*)(p + L) - origin_lower[1]) * inv_dir[1];
    const fv t0z = (*(const fv*)(p + 2 * L) - origin_lower[2]) * inv_dir[2];
    const fv t1x = (*(const fv*)(p + 3 * L) - origin_upper[0]) * inv_dir[0];
    const fv t1y = (*(const fv*)(p + 4 * L) - origin_upper[1]) * inv_dir[1];
    const fv t1z = (*(const fv*)(p + 5 * L) - origin_upper[2]) * inv_dir[2];
    const fv lo_x = t0x <= t1x ? t0x : t1x;
    const fv lo_y = t0y <= t1y ? t0y : t1y;
    const fv lo_z = t0z <= t1z ? t0z : t1z;
    const fv hi_x = t0x >= t1x ? t0x : t1x;
    const fv hi_y = t0y >= t1y ? t0y : t1y;
    const fv hi_z = t0z >= t1z ? t0z : t1z;
    const fv lo_t = t_min;
    const fv hi_t = t_max;
    const fv a = lo_x >= lo_y ? lo_x : lo_y;
    const fv b = lo_z >= lo_t ? lo_z : lo_t;
    const fv near = a >= b ? a : b;
    const fv c = hi_x <= hi_y ? hi_x : hi_y;
    const fv d = hi_z <= hi_t ? hi_z : hi_t;
    const fv far = c <= d ? c : d;
    const fv abs_near = near >= 0.0f ? near : -near;
    const fv e = near - abs_near * SLACK;
    iv count;
    for (int k = 0; k < L; ++k)
        count[k] = links[2 * k + 1];
    const fv abs_far = far >= 0.0f ? far : -far;
    const iv entered = (near <= far + abs_far * FAR_SLACK) & (e <= hi_t) & (count >= 0);
    *(fv*)entry = e;
    unsigned int mask = 0;
    for (int k = 0; k < L; ++k)
        mask |= (entered[k] ? 1u : 0u) << k;
    return mask;
}
#endif

CUDA_CALLABLE inline wp::vec3i wide_enter(
    const wp::array_t<float>& boxes, const wp::array_t<wp::vec2i>& links, int node,
    int width, const wp::vec3& origin_lower, const wp::vec3& origin_upper, const wp::vec3& inv_dir, float t_min,
    float t_max, WideStack& stack, int top, bool sort)
{
#if defined(__CUDA_ARCH__)
    return wp::vec3i(-1, 0, top);  // CUDA runs the Warp code instead (on_cpu)
#else
    float entry[8];
    const float* p = boxes.data + (size_t)node * (6 * width);
    const int* c = (const int*)(links.data + (size_t)node * width);
    unsigned int mask = width == 8
        ? enter_lanes<8>(p, c, origin_lower, origin_upper, inv_dir, t_min, t_max, entry)
        : enter_lanes<4>(p, c, origin_lower, origin_upper, inv_dir, t_min, t_max, entry);
    if (!sort) {
        for (; mask; mask &= mask - 1) {
            const int j = __builtin_ctz(mask);
            stack_push(stack, top++, c[2 * j], c[2 * j + 1], 0.0f);
        }
        return wp::vec3i(-1, 0, top);
    }
    if (mask == 0)
        return wp::vec3i(-1, 0, top);
    int order[8];
    int m = 0;
    for (; mask; mask &= mask - 1) {
        // Insertion by entry distance; a later slot goes after an equal one.
        const int j = __builtin_ctz(mask);
        int k = m++;
        for (; k > 0 && entry[order[k - 1]] > entry[j]; --k)
            order[k] = order[k - 1];
        order[k] = j;
    }
    for (int k = m - 1; k > 0; --k) {
        const int j = order[k];
        stack_push(stack, top++, c[2 * j], c[2 * j + 1], entry[j]);
    }
    return wp::vec3i(c[2 * order[0]], c[2 * order[0] + 1], top);
#endif
}
}  // namespace wrt
""".replace("FAR_SLACK", _float32_literal(ROBUST_FAR_SLACK)).replace("SLACK", _float32_literal(ENTRY_SLACK))
)

WIDE_BUILD_OPTIONS = wp.ModuleBuildOptions(
    extra_cuda_preamble=STACK_PREAMBLE + _PREAMBLE, extra_cpu_preamble=STACK_PREAMBLE + _PREAMBLE
)

wp.build_experimental.add_builtin(
    "wrt_wide_enter",
    {
        "boxes": wp.array(dtype=float),
        "links": wp.array(dtype=wp.vec2i),
        "node": int,
        "width": int,
        "origin_lower": wp.vec3,
        "origin_upper": wp.vec3,
        "inv_dir": wp.vec3,
        "t_min": float,
        "t_max": float,
        "stack": WideStack,
        "top": int,
        "sort": bool,
    },
    wp.vec3i,
    native_name="wrt::wide_enter",
)

_ON_CPU = """
#if defined(__CUDA_ARCH__)
    return false;
#else
    return true;
#endif
"""


@wp.func_native(_ON_CPU)
def on_cpu() -> bool:
    """True in code compiled for the CPU; a constant, so the compiler drops the other device's branch."""


@wp.kernel
def node_boxes_kernel(
    lowers: wp.array[wp.vec3], uppers: wp.array[wp.vec3], width: int, boxes: wp.array[float]
):
    """The plane runs of ``(K * width)`` child boxes: one thread per child slot."""
    c = wp.tid()
    node = c // width
    j = c - node * width
    base = node * BOX_PLANES * width + j
    for a in range(3):
        boxes[base + a * width] = lowers[c][a]
        boxes[base + (3 + a) * width] = uppers[c][a]


def device_node_boxes(lowers: wp.array, uppers: wp.array, width: int) -> wp.array:
    """The plane runs (see the module docstring) of ``(K * width)`` child boxes, on their device."""
    boxes = wp.empty(BOX_PLANES * lowers.shape[0], dtype=float, device=lowers.device)
    wp.launch(node_boxes_kernel, dim=lowers.shape[0], inputs=[lowers, uppers, width, boxes], device=lowers.device)
    return boxes


@wp.kernel
def links_kernel(refs: wp.array[wp.int32], counts: wp.array[wp.int32], links: wp.array[wp.vec2i]):
    c = wp.tid()
    links[c] = wp.vec2i(refs[c], counts[c])


def device_links(refs: wp.array, counts: wp.array) -> wp.array:
    """The ``(ref, count)`` pairs of the child slots, on their device."""
    links = wp.empty(refs.shape[0], dtype=wp.vec2i, device=refs.device)
    wp.launch(links_kernel, dim=refs.shape[0], inputs=[refs, counts, links], device=refs.device)
    return links
