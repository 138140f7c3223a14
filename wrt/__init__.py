"""wrt: a ray tracer for USD scenes written in NVIDIA Warp kernels.

Pipeline: USD stage -> :class:`Scene` -> BVH -> trace kernels (:class:`Hits`) -> shade kernels -> :class:`Image`.
"""

import warp as _wp

_wp.config.quiet = True

from .bvh import FlatBvh, build_bvh  # noqa: E402
from .camera import Camera  # noqa: E402
from .errors import SceneError  # noqa: E402
from .scene import DistantLight, Mesh, Scene  # noqa: E402
from .trace import Hits, occluded, trace  # noqa: E402

__all__ = [
    "Camera",
    "DistantLight",
    "FlatBvh",
    "Hits",
    "Mesh",
    "Scene",
    "SceneError",
    "build_bvh",
    "occluded",
    "trace",
]
__version__ = "0.1.0"
