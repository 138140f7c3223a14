"""wrt: a ray tracer for USD scenes written in NVIDIA Warp kernels.

Pipeline: USD stage -> :class:`Scene` -> BVH -> trace kernels (:class:`Hits`) -> shade kernels -> :class:`Image`.
"""

from .bvh import FlatBvh, build_bvh
from .camera import Camera
from .errors import SceneError
from .image import Image
from .render import Renderer, render
from .scene import DistantLight, Mesh, Scene
from .trace import Hits, occluded, trace
from .usd import load_usd

__all__ = [
    "Camera",
    "DistantLight",
    "FlatBvh",
    "Hits",
    "Image",
    "Mesh",
    "Renderer",
    "Scene",
    "SceneError",
    "build_bvh",
    "load_usd",
    "occluded",
    "render",
    "trace",
]
__version__ = "0.1.0"
