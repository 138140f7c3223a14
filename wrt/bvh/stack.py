"""Per-thread traversal stacks that are not zeroed: a small C++ type handed to Warp as an external native type.

Why: Warp 1.19's in-kernel ``wp.zeros(shape=N)`` is a ``fixedarray_t`` whose constructor value-initialises its
storage, and the generated code constructs it twice and copies it once (``T var;`` then ``var = T(N)``); a
``wp.types.vector(length=N)`` is zeroed too. On CUDA that was about 1.5 KB of local-memory stores per ray for the
two 64-entry stacks of the binary traversal (``trace_bvh_kernel`` PTX: four 64-iteration store loops before the
first node), and 6 KB+ for the wide layout. A traversal reads an entry only after pushing it, so the storage is
left uninitialised, as in Warp's own ``mesh_query_ray`` (a plain ``int stack[...]``).

Use: a module whose kernels call a traversal that uses these stacks compiles the C++ definitions through its
module options, ``wp.set_module_options({"extra_build_options": STACK_BUILD_OPTIONS})``. In a kernel,
``s = NodeStack()`` declares a stack; ``wp.wrt_stack_push(s, i, ref[, count][, t])`` writes entry ``i`` (the fields
not given are left as they are) and ``wp.wrt_stack_ref / wrt_stack_count / wrt_stack_t(s, i)`` read it. Each entry
is a node (or first slot of a leaf) ``ref``, a leaf triangle ``count`` and an entry distance ``t``; the index is not
bounds-checked (the builders' depth guarantee bounds it, see ``common.py``).

Warp's external-type API is marked experimental; ``warp-lang`` is pinned to 1.19.0 in ``pyproject.toml``.
"""

from __future__ import annotations

import ctypes

import warp as wp

from .common import MAX_DEPTH

WIDE_STACK = 8 * MAX_DEPTH  # entries of the wide layouts' stack: up to 7 pushes per wide level

# ctypes has no alignment attribute before Python 3.13: an empty array of the 16-byte-aligned ``long double`` (x86-64
# and aarch64 Linux and macOS) gives the host description the C++ entry's alignment. Where ``long double`` is 8-byte
# aligned (Windows), entries are 8-byte aligned, and a push is two 8-byte accesses instead of one.
_ALIGN_FIELD = ctypes.c_longdouble if ctypes.alignment(ctypes.c_longdouble) >= 16 else ctypes.c_double
ENTRY_ALIGN = ctypes.alignment(_ALIGN_FIELD)

_SIZES = {"NodeStack": MAX_DEPTH, "WideStack": WIDE_STACK}  # C++ name -> entries

STACK_PREAMBLE = """
namespace wrt {
// One 16-byte entry per level, so a push or a pop is one vector access to local memory instead of one per field
// (H200: within 3% either way by itself; the BVH4's ranked pushes are single stores with it; GPU_NOTES.md, row 33).
struct alignas(ENTRY_ALIGN) StackEntry {
    int ref;    // node, or first slot of a leaf
    float t;    // entry distance
    int count;  // triangles of a leaf (compact and wide layouts)
    int unused;
};
template <int N> struct Stack {
    StackEntry e[N];
    CUDA_CALLABLE Stack() {}  // uninitialised on purpose: entries are read only after they are pushed
};
template <int N> CUDA_CALLABLE inline void stack_push(Stack<N>& s, int i, int ref) { s.e[i].ref = ref; }
template <int N> CUDA_CALLABLE inline void stack_push(Stack<N>& s, int i, int ref, float t)
{
    s.e[i].ref = ref;
    s.e[i].t = t;
}
template <int N> CUDA_CALLABLE inline void stack_push(Stack<N>& s, int i, int ref, int count, float t)
{
    StackEntry entry = {ref, t, count, 0};
    s.e[i] = entry;
}
template <int N> CUDA_CALLABLE inline int stack_ref(const Stack<N>& s, int i) { return s.e[i].ref; }
template <int N> CUDA_CALLABLE inline int stack_count(const Stack<N>& s, int i) { return s.e[i].count; }
template <int N> CUDA_CALLABLE inline float stack_t(const Stack<N>& s, int i) { return s.e[i].t; }
""".replace("ENTRY_ALIGN", str(ENTRY_ALIGN))
STACK_PREAMBLE += "".join(f"using {name} = Stack<{n}>;\n" for name, n in _SIZES.items()) + "}  // namespace wrt\n"

STACK_BUILD_OPTIONS = wp.ModuleBuildOptions(extra_cuda_preamble=STACK_PREAMBLE, extra_cpu_preamble=STACK_PREAMBLE)


def _stack_type(name: str, n: int) -> type:
    """The host description of ``wrt::<name>`` (Warp checks its size and alignment against the C++ type)."""
    fields = [("entries", ctypes.c_int32 * (4 * n)), ("align", _ALIGN_FIELD * 0)]  # four int32 per entry
    cls = type(name, (ctypes.Structure,), {"_fields_": fields, "__doc__": f"Traversal stack of {n} entries."})
    wp.build_experimental.add_native_type(cls, native_name=f"wrt::{name}")
    add = wp.build_experimental.add_builtin
    add("wrt_stack_push", {"s": cls, "i": int, "ref": int}, None, native_name="wrt::stack_push")
    add("wrt_stack_push", {"s": cls, "i": int, "ref": int, "t": float}, None, native_name="wrt::stack_push")
    add("wrt_stack_push", {"s": cls, "i": int, "ref": int, "count": int, "t": float}, None,
        native_name="wrt::stack_push")
    add("wrt_stack_ref", {"s": cls, "i": int}, int, native_name="wrt::stack_ref")
    add("wrt_stack_count", {"s": cls, "i": int}, int, native_name="wrt::stack_count")
    add("wrt_stack_t", {"s": cls, "i": int}, float, native_name="wrt::stack_t")
    return cls


NodeStack = _stack_type("NodeStack", MAX_DEPTH)  # binary, compact and TLAS traversal: one entry per tree level
WideStack = _stack_type("WideStack", WIDE_STACK)  # wide layouts
