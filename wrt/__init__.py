"""wrt: a ray tracer for USD scenes written in NVIDIA Warp kernels.

Pipeline: USD stage -> :class:`Scene` -> BVH -> trace kernels (:class:`Hits`) -> shade kernels -> :class:`Image`.
"""

import warp as _wp

from .batch import BatchImage, render_batch
from .bvh import FlatBvh, build_bvh
from .camera import Camera
from .errors import SceneError
from .ies import IesError, IesProfile, read_ies
from .image import Image
from .instancing import Instances, Prototype
from .light_links import LinkCollection
from .light_shaping import Shaping
from .lights import CylinderLight, DiskLight, DomeLight, MeshLight, RectLight, SphereLight
from .materials import Material, TextureInput
from .preview import preview, to_pyvista  # pyvista itself is imported only when these are called
from .primitives import Shape
from .render import Renderer, render
from .render_products import render_products
from .scene import DistantLight, Mesh, Scene
from .trace import Hits, occluded, trace
from .usd import load_usd

__all__ = [
    "BatchImage",
    "render_batch",
    "Camera",
    "CylinderLight",
    "DiskLight",
    "DistantLight",
    "DomeLight",
    "FlatBvh",
    "Hits",
    "IesError",
    "IesProfile",
    "Image",
    "Instances",
    "LinkCollection",
    "Material",
    "Mesh",
    "MeshLight",
    "Prototype",
    "RectLight",
    "Renderer",
    "Scene",
    "SceneError",
    "Shape",
    "Shaping",
    "SphereLight",
    "TextureInput",
    "build_bvh",
    "load_usd",
    "occluded",
    "preview",
    "read_ies",
    "render",
    "render_products",
    "to_pyvista",
    "trace",
]
__version__ = "0.1.0"

# A library prints nothing unless asked: a first render printed Warp's start-up banner and a "Module ... load" line
# per kernel module (14 lines), which are Warp's info messages; its warnings and errors still show. Only Warp's default
# level is raised: a level set before importing wrt is kept, and ``wp.config.log_level = wp.LOG_INFO`` after it shows
# them again. (Warp 1.19 has no ``wp.config.quiet``; setting it does nothing.)
# This covers ``wrt`` command lines and the bench and animation worker processes too: their tasks are functions
# of wrt modules, pickled by reference, so a worker imports wrt before it runs one.
if _wp.config.log_level == _wp.LOG_INFO:
    _wp.config.log_level = _wp.LOG_WARNING
