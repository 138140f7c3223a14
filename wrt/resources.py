"""Memory planning: predict what a render will allocate and refuse it before allocating when it cannot fit.

The estimate counts the large buffers: triangles and per-corner shading data, the BVH (at most ``2N - 1`` nodes of
32 bytes plus ``40`` bytes of leaf-ordered triangle data per triangle), the textures as uploaded
(:func:`device_texture_bytes`) and the render's path and pixel buffers (:func:`wrt.render.render_bytes`, summed from
the buffers themselves). It is an upper bound within a small factor,
good enough to turn an absurd request into a clear message instead of an allocation failure deep inside a kernel
launch.
"""

from __future__ import annotations

import math
import os
import re

TRIANGLE_BYTES = 12 * 3 + 36 * 2 + 64 + 40 + 4  # points, corner normals and colours, BVH nodes, leaf copies, ids

_UNITS = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def parse_bytes(text: str) -> int:
    """``"512M"``, ``"2G"``, ``"1.5g"``, ``"1000000"``, ``"1e9"`` -> bytes; raises ``ValueError`` naming the
    format (a size past float's range too)."""
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?)[iI]?[bB]?\s*", str(text))
    size = float(match.group(1)) * _UNITS[match.group(2).lower()] if match else math.inf
    if not math.isfinite(size):
        raise ValueError(f"cannot read memory size {text!r}; use a number with an optional K, M, G or T suffix")
    return int(size)


def estimate_render_bytes(triangles: int, width: int, height: int, spp: int = 1, textures: int = 0) -> int:
    """Upper-bound bytes a render of ``width x height`` pixels and ``spp`` samples over ``triangles`` triangles
    allocates (a small image takes several samples per launch: its paths count), ``textures`` bytes of textures
    (:func:`device_texture_bytes`) included."""
    from .render import render_bytes, samples_per_launch

    pixels = int(width) * int(height)
    return (int(triangles) * TRIANGLE_BYTES + int(textures)
            + render_bytes(pixels, pixels * samples_per_launch(pixels, spp)))


def device_texture_bytes(scene) -> int:
    """Device bytes of ``scene``'s textures as a render uploads them: the materials' images packed as RGBA half floats
    (:func:`wrt.textures.pack_images`: a ``vec4h`` per texel, an int32 first texel, a ``vec2i`` size and a ``vec4``
    of scales per image, at least one of each), and the lights' images as RGB float32 (:mod:`wrt.light_table`: a
    ``vec3`` per texel, each image once however many lights share it), with a dome's sampling CDFs (a float per row,
    and per texel and row).
    Left out, they were no part of the checks, though an 8k texture alone takes 512 MiB."""
    import numpy as np
    import warp as wp

    from .lights import DomeLight

    size = wp.types.type_size_in_bytes
    shapes = [np.shape(texture) for texture in scene.textures]
    texels = sum(shape[0] * shape[1] for shape in shapes)
    total = max(texels, 1) * size(wp.vec4h) + max(len(shapes), 1) * (size(wp.int32) + size(wp.vec2i)
                                                                    + size(wp.vec4))
    seen = set()
    for light in scene.lights:
        texture = getattr(light, "texture", None)
        if texture is None or id(texture) in seen:
            continue
        seen.add(id(texture))
        height, width = np.shape(texture)[:2]
        total += height * width * size(wp.vec3)
        if isinstance(light, DomeLight):
            total += (height + 1 + height * (width + 1)) * size(wp.float32)
    return total


def format_bytes(n: float) -> str:
    """``n`` bytes in the largest binary unit below it, to TiB; absurd sizes (``sphere:1e99``) in short exponent form
    instead of a number of 90 digits."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{int(n)} B" if unit == "B" else f"{n:.1f} {unit}" if n < 1e6 else f"{n:.3g} {unit}"
        n /= 1024


CGROUP_ROOT = "/sys/fs/cgroup"  # where the control groups (memory limits of containers and batch jobs) are mounted


def _read_number(path: str) -> int | None:
    """The integer in file ``path`` (``memory.max``, ``memory.current``), or None: missing, unreadable, ``max``."""
    try:
        with open(path) as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _reclaimable(stat_path: str) -> int:
    """Bytes of inactive file cache in a cgroup's ``memory.stat``: counted in its usage, but given back on demand."""
    try:
        with open(stat_path) as f:
            fields = dict(line.split() for line in f if line.count(" ") == 1)
    except (OSError, ValueError):
        return 0
    return int(fields.get("inactive_file", fields.get("total_inactive_file", 0)))


def cgroup_room() -> int | None:
    """Bytes the memory limit of this process's control group (a container, a Slurm or Kubernetes job) still
    allows: its limit less its usage, page cache it can reclaim left out; the tightest of the groups above it (v2);
    None where no limit is set. The system's MemAvailable does not see such a limit, and the kernel kills a process
    that passes it."""

    def room(folder: str, limit_file: str, usage_file: str) -> None:
        limit = _read_number(f"{folder}/{limit_file}")
        if limit is not None and limit < 1 << 60:  # v1 writes "no limit" as a number near 2^63, v2 as "max"
            usage = _read_number(f"{folder}/{usage_file}") or 0
            rooms.append(limit - usage + _reclaimable(f"{folder}/memory.stat"))

    rooms = []
    room(f"{CGROUP_ROOT}/memory", "memory.limit_in_bytes", "memory.usage_in_bytes")  # v1
    try:
        with open("/proc/self/cgroup") as f:
            group = next((line.strip()[3:] for line in f if line.startswith("0::")), "")
    except OSError:
        group = ""
    folder = f"{CGROUP_ROOT}/{group.strip('/')}".rstrip("/")
    while folder.startswith(CGROUP_ROOT):  # v2: the group, then each parent up to the root
        room(folder, "memory.max", "memory.current")
        folder = os.path.dirname(folder)
    return max(0, min(rooms)) if rooms else None


def address_space_room() -> int | None:
    """Bytes of address space ``ulimit -v`` (RLIMIT_AS) still leaves this process, or None without such a limit:
    past it every allocation fails."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
        if limit == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/status") as f:
            size = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))
    except (ImportError, OSError, ValueError, StopIteration):
        return None
    return max(0, limit - size)


def available_host_bytes() -> int | None:
    """Bytes of host memory this process can still get: the system's ``MemAvailable`` on Linux, less where a
    control group's limit or ``ulimit -v`` leaves less (:func:`cgroup_room`, :func:`address_space_room`); ``None``
    where none is known."""
    free = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    free = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    if free is None:
        try:
            free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):
            pass
    known = [n for n in (free, cgroup_room(), address_space_room()) if n is not None]
    return min(known) if known else None


def check_host_memory(needed: int, what: str) -> None:
    """Raises ``MemoryError`` naming ``what`` when ``needed`` bytes exceed the host memory still available: the
    operating system may otherwise kill the process part way through, with nothing written."""
    free = available_host_bytes()
    if free is not None and needed > free:
        raise MemoryError(
            f"{what} needs about {format_bytes(needed)} of host memory, {format_bytes(free)} is available"
        )


def check_memory(needed: int, device, max_memory: int | None = None, what: str = "this render") -> None:
    """Raises ``MemoryError`` naming ``what`` when ``needed`` bytes exceed ``max_memory``, the free memory of a CUDA
    device or, for the CPU device, the host memory available."""
    if max_memory is not None and needed > max_memory:
        raise MemoryError(
            f"{what} needs about {format_bytes(needed)}, more than --max-memory {format_bytes(max_memory)}; "
            "lower the resolution or raise the limit"
        )
    from .trace import resolve_device

    dev = resolve_device(device)
    if dev.is_cpu:
        check_host_memory(needed, what)
    if dev.is_cuda:
        free = getattr(dev, "free_memory", None)
        if free is not None and needed > free:
            raise MemoryError(
                f"{what} needs about {format_bytes(needed)} but {dev.alias} has {format_bytes(free)} free; "
                "lower the resolution or use another device"
            )
