"""wrt: a ray tracer for USD scenes written in NVIDIA Warp kernels.

Pipeline: USD stage -> :class:`Scene` -> BVH -> trace kernels (:class:`Hits`) -> shade kernels -> :class:`Image`.

``import wrt`` imports none of the modules behind its names: each is imported the first time one of its names is
used (PEP 562), so that ``wrt --help`` and a script that needs a few names do not wait for all of them. Importing
them all took 2.0 s of CPU on a 2-core VM: Warp parsing the source of 464 kernels, functions and structs as they were
decorated, importing Warp, numpy and usd-core, compiling wrt's own source, and tearing it all down at exit.
"""

# Private names, so that dir(wrt) and tab completion offer wrt's names and submodules, not these
import importlib as _importlib
import importlib.util as _importlib_util
import sys as _sys
import types as _types

from .warp_log_level import raise_default_level_of_warp as _raise_default_level_of_warp

# Each submodule and the public names it gives (``wrt.render`` is the function, ``wrt.render.render`` in the module).
_NAMES_OF_MODULE = {
    "batch": ("BatchImage", "render_batch"),
    "bvh": ("FlatBvh", "build_bvh"),
    "camera": ("Camera",),
    "errors": ("SceneError",),
    "ies": ("IesError", "IesProfile", "read_ies"),
    "image": ("Image",),
    "instancing": ("Instances", "Prototype"),
    "light_links": ("LinkCollection",),
    "light_shaping": ("Shaping",),
    "lights": ("CylinderLight", "DiskLight", "DomeLight", "MeshLight", "RectLight", "SphereLight"),
    "materials": ("Material", "TextureInput"),
    "preview": ("preview", "to_pyvista"),  # pyvista itself is imported only when these are called
    "primitives": ("Shape",),
    "render": ("Renderer", "render"),
    "render_products": ("render_products",),
    "scene": ("DistantLight", "Mesh", "Scene"),
    "trace": ("Hits", "occluded", "trace"),
    "usd": ("load_usd",),
}
_MODULE_OF_NAME = {name: module for module, names in _NAMES_OF_MODULE.items() for name in names}

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

_raise_default_level_of_warp()


def __getattr__(name: str):
    """A public name, imported from its module on first use (and kept); else a submodule, imported, as ``import wrt``
    made ``wrt.scene`` or ``wrt.bvh`` an attribute when it imported them all."""
    if name in _MODULE_OF_NAME:
        value = getattr(_importlib.import_module(f".{_MODULE_OF_NAME[name]}", __name__), name)
        globals()[name] = value
        return value
    if not name.startswith("_") and _importlib_util.find_spec(f"{__name__}.{name}") is not None:
        return _importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list:
    return sorted({*globals(), *__all__})


class _Package(_types.ModuleType):
    """wrt's module type: a public function named as its own module (``render``, ``trace``, ``preview``,
    ``render_products``) stays the package's attribute when its module is imported. Python's import sets
    ``wrt.render`` to the module ``wrt.render`` after the module runs; the eager imports here rebound it to the
    function, and a lazy import must keep it so."""

    def __setattr__(self, name, value):
        if isinstance(value, _types.ModuleType) and value.__name__ == f"{__name__}.{name}" and name in _MODULE_OF_NAME:
            value = getattr(value, name)
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package
