"""wrt's own BVH: builders, the canonical flat layout and its conversions, traversal, and statistics."""

from .build import MAX_DEPTH, Builder, build_bvh, build_bvh_device, builder_names
from .layout import LAYOUTS, DeviceBvh, DeviceFlatBvh, FlatBvh, convert_layout

__all__ = [
    "LAYOUTS",
    "MAX_DEPTH",
    "Builder",
    "DeviceBvh",
    "DeviceFlatBvh",
    "FlatBvh",
    "build_bvh",
    "build_bvh_device",
    "builder_names",
    "convert_layout",
]
