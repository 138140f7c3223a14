"""wrt's own BVH: builders, the canonical flat layout, and traversal."""

from .build import MAX_DEPTH, Builder, build_bvh
from .layout import DeviceBvh, FlatBvh

__all__ = ["MAX_DEPTH", "Builder", "DeviceBvh", "FlatBvh", "build_bvh"]
