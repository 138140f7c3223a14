"""A per-thread buffer of clusters (box, node reference, triangle count, height, nearest neighbour) that is not
zeroed: a small C++ type handed to Warp as an external native type, as in ``stack.py``.

Why: the hierarchical clustering of ``ploc.py`` merges the few clusters of one radix-tree node in one thread. Kept
in global memory, every distance evaluation is a scattered load (each thread works on its own slot range), which
made the clustering bound by L1 transactions; thread-local storage is interleaved across a warp, so the same
accesses coalesce. Warp's in-kernel arrays (``wp.zeros(shape=N)``) would zero the storage on every use.

Use: a module whose kernels use the buffer compiles the C++ definitions through its module options,
``wp.set_module_options({"extra_build_options": CLUSTER_BUILD_OPTIONS})``. ``b = ClusterBuffer()`` declares one
(``CLUSTER_CAPACITY`` entries, unchecked indices); ``wp.wrt_cluster_set(b, i, ref, lower, upper, count, height)``
writes entry ``i``, ``wp.wrt_cluster_move(b, src, dst)`` copies one, ``wp.wrt_cluster_set_nearest(b, i, j, d)``
records its nearest neighbour, and ``wp.wrt_cluster_<field>(b, i)`` reads a field.
"""

from __future__ import annotations

import ctypes

import warp as wp

CLUSTER_CAPACITY = 8  # entries: two children's clusters, each at most the clustering's largest target (4)

_PREAMBLE = f"""
namespace wrt {{
struct ClusterBuffer {{
    wp::vec3 lower[{CLUSTER_CAPACITY}];
    wp::vec3 upper[{CLUSTER_CAPACITY}];
    int ref[{CLUSTER_CAPACITY}];
    int count[{CLUSTER_CAPACITY}];
    int height[{CLUSTER_CAPACITY}];
    int nearest[{CLUSTER_CAPACITY}];
    float distance[{CLUSTER_CAPACITY}];
    CUDA_CALLABLE ClusterBuffer() {{}}  // uninitialised on purpose: entries are read only after they are set
}};
CUDA_CALLABLE inline void cluster_set(ClusterBuffer& b, int i, int ref, wp::vec3 lower, wp::vec3 upper, int count,
                                      int height)
{{
    b.ref[i] = ref;
    b.lower[i] = lower;
    b.upper[i] = upper;
    b.count[i] = count;
    b.height[i] = height;
}}
CUDA_CALLABLE inline void cluster_move(ClusterBuffer& b, int src, int dst)
{{
    b.ref[dst] = b.ref[src];
    b.lower[dst] = b.lower[src];
    b.upper[dst] = b.upper[src];
    b.count[dst] = b.count[src];
    b.height[dst] = b.height[src];
    b.nearest[dst] = b.nearest[src];
    b.distance[dst] = b.distance[src];
}}
CUDA_CALLABLE inline void cluster_set_nearest(ClusterBuffer& b, int i, int j, float d)
{{
    b.nearest[i] = j;
    b.distance[i] = d;
}}
CUDA_CALLABLE inline int cluster_ref(const ClusterBuffer& b, int i) {{ return b.ref[i]; }}
CUDA_CALLABLE inline wp::vec3 cluster_lower(const ClusterBuffer& b, int i) {{ return b.lower[i]; }}
CUDA_CALLABLE inline wp::vec3 cluster_upper(const ClusterBuffer& b, int i) {{ return b.upper[i]; }}
CUDA_CALLABLE inline int cluster_count(const ClusterBuffer& b, int i) {{ return b.count[i]; }}
CUDA_CALLABLE inline int cluster_height(const ClusterBuffer& b, int i) {{ return b.height[i]; }}
CUDA_CALLABLE inline int cluster_nearest(const ClusterBuffer& b, int i) {{ return b.nearest[i]; }}
CUDA_CALLABLE inline float cluster_distance(const ClusterBuffer& b, int i) {{ return b.distance[i]; }}
}}  // namespace wrt
"""

CLUSTER_BUILD_OPTIONS = wp.ModuleBuildOptions(extra_cuda_preamble=_PREAMBLE, extra_cpu_preamble=_PREAMBLE)


class ClusterBuffer(ctypes.Structure):
    """Host description of ``wrt::ClusterBuffer`` (Warp checks its size and alignment against the C++ type)."""

    _fields_ = [
        ("lower", ctypes.c_float * (3 * CLUSTER_CAPACITY)),
        ("upper", ctypes.c_float * (3 * CLUSTER_CAPACITY)),
        ("ref", ctypes.c_int32 * CLUSTER_CAPACITY),
        ("count", ctypes.c_int32 * CLUSTER_CAPACITY),
        ("height", ctypes.c_int32 * CLUSTER_CAPACITY),
        ("nearest", ctypes.c_int32 * CLUSTER_CAPACITY),
        ("distance", ctypes.c_float * CLUSTER_CAPACITY),
    ]


def _register() -> None:
    wp.build_experimental.add_native_type(ClusterBuffer, native_name="wrt::ClusterBuffer")
    add = wp.build_experimental.add_builtin
    b = ClusterBuffer
    entry = {"b": b, "i": int, "ref": int, "lower": wp.vec3, "upper": wp.vec3, "count": int, "height": int}
    add("wrt_cluster_set", entry, None, native_name="wrt::cluster_set")
    add("wrt_cluster_move", {"b": b, "src": int, "dst": int}, None, native_name="wrt::cluster_move")
    add("wrt_cluster_set_nearest", {"b": b, "i": int, "j": int, "d": float}, None, native_name="wrt::cluster_set_nearest")
    for field, dtype in (("ref", int), ("lower", wp.vec3), ("upper", wp.vec3), ("count", int), ("height", int)):
        add(f"wrt_cluster_{field}", {"b": b, "i": int}, dtype, native_name=f"wrt::cluster_{field}")
    add("wrt_cluster_nearest", {"b": b, "i": int}, int, native_name="wrt::cluster_nearest")
    add("wrt_cluster_distance", {"b": b, "i": int}, float, native_name="wrt::cluster_distance")


_register()
