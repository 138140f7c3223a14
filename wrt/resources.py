"""Memory planning: predict what a render will allocate and refuse it before allocating when it cannot fit.

The estimate counts the large buffers: triangles and per-corner shading data, the BVH (at most ``2N - 1`` nodes of
32 bytes plus ``40`` bytes of leaf-ordered triangle data per triangle) and the render's path and pixel buffers
(:func:`wrt.render.render_bytes`, summed from the buffers themselves). It is an upper bound within a small factor,
good enough to turn an absurd request into a clear message instead of an allocation failure deep inside a kernel
launch.
"""

from __future__ import annotations

import os
import re

TRIANGLE_BYTES = 12 * 3 + 36 * 2 + 64 + 40 + 4  # points, corner normals and colours, BVH nodes, leaf copies, ids

_UNITS = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def parse_bytes(text: str) -> int:
    """``"512M"``, ``"2G"``, ``"1.5g"``, ``"1000000"`` -> bytes; raises ``ValueError`` naming the format."""
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kKmMgGtT]?)[iI]?[bB]?\s*", str(text))
    if not match:
        raise ValueError(f"cannot read memory size {text!r}; use a number with an optional K, M, G or T suffix")
    return int(float(match.group(1)) * _UNITS[match.group(2).lower()])


def estimate_render_bytes(triangles: int, width: int, height: int, spp: int = 1) -> int:
    """Upper-bound bytes a render of ``width x height`` pixels and ``spp`` samples over ``triangles`` triangles
    allocates (a small image takes several samples per launch: its paths count)."""
    from .render import render_bytes, samples_per_launch

    pixels = int(width) * int(height)
    return int(triangles) * TRIANGLE_BYTES + render_bytes(pixels, pixels * samples_per_launch(pixels, spp))


def format_bytes(n: float) -> str:
    """``n`` bytes in the largest binary unit below it, to TiB; absurd sizes (``sphere:1e99``) in short exponent form
    instead of a number of 90 digits."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{int(n)} B" if unit == "B" else f"{n:.1f} {unit}" if n < 1e6 else f"{n:.3g} {unit}"
        n /= 1024


def available_host_bytes() -> int | None:
    """Bytes of host memory the system can still hand out (``MemAvailable`` on Linux), or ``None`` where unknown."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


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
