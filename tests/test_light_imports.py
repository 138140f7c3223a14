"""``import wrt`` and ``wrt --help`` import no Warp kernels: each public name is imported from its module on first use.

Each check runs in a fresh interpreter, where no other test has imported a module yet. No timings are asserted: what
is checked is which modules a command line loads, and that the lazily imported names are the objects they were.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import warp as wp

# Where each public name was imported from when ``wrt/__init__.py`` imported them all (the oracle: written out here,
# not read from the package).
PUBLIC_NAMES = {
    "batch": ["BatchImage", "render_batch"],
    "bvh": ["FlatBvh", "build_bvh"],
    "camera": ["Camera"],
    "errors": ["SceneError"],
    "ies": ["IesError", "IesProfile", "read_ies"],
    "image": ["Image"],
    "instancing": ["Instances", "Prototype"],
    "light_links": ["LinkCollection"],
    "light_shaping": ["Shaping"],
    "lights": ["CylinderLight", "DiskLight", "DomeLight", "MeshLight", "RectLight", "SphereLight"],
    "materials": ["Material", "TextureInput"],
    "preview": ["preview", "to_pyvista"],
    "primitives": ["Shape"],
    "render": ["Renderer", "render"],
    "render_products": ["render_products"],
    "scene": ["DistantLight", "Mesh", "Scene"],
    "trace": ["Hits", "occluded", "trace"],
    "usd": ["load_usd"],
}

# Every command's help, then the modules loaded: none of Warp, usd-core or pyvista.
HELP_COMMANDS = """
import contextlib, io, json, sys
from wrt.cli import main
for argv in (["--help"], ["render", "--help"], ["preview", "--help"], ["bench", "--help"], ["bvh-stats", "--help"]):
    with contextlib.redirect_stdout(io.StringIO()) as out:
        try:
            main(argv)
        except SystemExit as e:
            assert e.code == 0, (argv, e.code)
    assert "usage: wrt" in out.getvalue(), argv
print(json.dumps(sorted(sys.modules)))
"""

# The submodules named as functions imported first, as other modules import them; then every public name, and *.
NAMES_IMPORTED = """
import importlib, json, sys
import wrt.render, wrt.trace
from wrt.preview import preview
from wrt import render_products
names = json.loads(sys.argv[1])
report = {"different": []}
for module, public in names.items():
    for name in public:
        if getattr(wrt, name) is not getattr(importlib.import_module(f"wrt.{module}"), name):
            report["different"].append(name)
star = {}
exec("from wrt import *", star)
report["star"] = sorted(name for name in star if name != "__builtins__")
report["all"] = sorted(wrt.__all__)
report["submodule"] = wrt.scene.__name__  # a submodule, as 'import wrt' made it an attribute
print(json.dumps(report))
"""

# The log level Warp has after 'import wrt' and then Warp's import (wrt quietens it), also where Warp's spec was
# looked up first (whether it is installed), and after a level set then, followed by a wrt module's import (kept).
LOG_LEVELS = """
import importlib.util
import wrt
assert importlib.util.find_spec("warp") is not None
import warp as wp
quietened = wp.config.log_level
wp.config.log_level = wp.LOG_INFO
wrt.Camera
print(quietened, wp.config.log_level)
"""

# wrt imported twice before Warp (its modules dropped from sys.modules in between, as a test or a notebook does to
# import it afresh), then Warp: each import of wrt's log-level module added its hook, and each hook asked the other.
REIMPORTED = """
import sys
import wrt
for name in [name for name in sys.modules if name == "wrt" or name.startswith("wrt.")]:
    del sys.modules[name]
import wrt
import warp as wp
print(wp.config.log_level)
"""

# Warp found by a finder that is the loader of every module it finds (a PEP 302 importer, as PyInstaller's is), then
# another module through it: the loader kept wrt's wrapper, which read 'config' of every module it loaded after Warp.
SHARED_LOADER = """
import importlib.machinery, importlib.util, sys
import wrt


class Importer:
    def find_spec(self, name, path=None, target=None):
        if name not in ("warp", "colorsys"):
            return None
        found = importlib.machinery.PathFinder.find_spec(name, path)
        self.loaders = {**getattr(self, "loaders", {}), name: found.loader}
        return importlib.util.spec_from_file_location(name, found.origin, loader=self,
                                                      submodule_search_locations=found.submodule_search_locations)

    def create_module(self, spec):
        return None

    def exec_module(self, module):
        self.loaders[module.__name__].exec_module(module)


sys.meta_path.insert(1, Importer())  # behind wrt's hook, before the path finder
import warp as wp
import colorsys
print(wp.config.log_level, colorsys.rgb_to_hsv(1.0, 0.0, 0.0)[2])
"""


def run_python(script: str, *args: str) -> str:
    """The standard output of ``script`` run with ``args`` in a fresh interpreter."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    result = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, env=env,
                            timeout=600)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_help_imports_neither_warp_nor_usd_nor_pyvista():
    """``wrt --help`` and each ``wrt COMMAND --help`` imported every kernel module (their names and limits came from
    them), Warp parsing each kernel's source, and usd-core with them: 1.7 s of a 4.3 s wait on a 2-core VM."""
    modules = json.loads(run_python(HELP_COMMANDS))
    loaded = [name for name in modules if name.split(".")[0] in ("warp", "pxr", "pyvista")]
    assert loaded == []
    assert "wrt.cli" in modules and "wrt.render" not in modules


def test_every_public_name_is_its_modules_object():
    """Imported on first use, each name of ``wrt.__all__`` is the object its module defines, as when
    ``wrt/__init__.py`` imported them all; ``wrt.render`` and ``wrt.trace`` stay the functions after their modules are
    imported, and ``from wrt import *`` gives every name."""
    report = json.loads(run_python(NAMES_IMPORTED, json.dumps(PUBLIC_NAMES)))
    every = sorted(name for names in PUBLIC_NAMES.values() for name in names)
    assert report["different"] == []
    assert report["all"] == every and report["star"] == every
    assert report["submodule"] == "wrt.scene"


def test_warp_imported_after_wrt_is_quietened_and_a_level_set_then_kept():
    """``import wrt`` no longer imports Warp; Warp's default log level is still raised when Warp is imported after
    it, and a level set after that is kept when a wrt module is imported."""
    quietened, kept = map(int, run_python(LOG_LEVELS).split())
    assert (quietened, kept) == (wp.LOG_WARNING, wp.LOG_INFO)


def test_warp_imports_after_wrt_was_imported_afresh():
    """wrt imported, its modules dropped from ``sys.modules`` and imported again, all before Warp: ``import warp``
    then failed with a RecursionError (the two hooks of the two module copies each handed the question to the
    other). Warp imports, and its default level is raised once, as after a single ``import wrt``."""
    assert int(run_python(REIMPORTED)) == wp.LOG_WARNING


def test_modules_load_after_warp_through_a_loader_they_share_with_it():
    """A loader that loads several modules, Warp among them: wrt's hook replaced its ``exec_module`` for good, so
    each module it loaded after Warp failed (``module 'colorsys' has no attribute 'config'``). Warp's level is raised
    and the next module imports as Python's own loader imports it."""
    level, value = run_python(SHARED_LOADER).split()
    assert (int(level), float(value)) == (wp.LOG_WARNING, 1.0)


def test_dir_of_wrt_offers_its_names_and_submodules_only():
    """``dir(wrt)`` (and tab completion) listed the lazy loader's own imports (``importlib``, ``sys``, ``types``) and
    its hook's function as if they were wrt's: every public name it lists is a name of ``wrt.__all__`` or a module of
    the package (found by Python's own finder)."""
    script = """
import importlib.util, json
import wrt
names = [n for n in dir(wrt) if not n.startswith("_")]
print(json.dumps([n for n in names if n not in wrt.__all__ and importlib.util.find_spec("wrt." + n) is None]))
"""
    assert json.loads(run_python(script)) == []


def test_aov_names_are_the_renderers_buffers():
    """``wrt.options.AOV_NAMES`` is written out for the command line (``--aov``, ``--aov-dir``); the renderer's AOV
    buffers, in their order, then ``coverage`` (made from their count of hits), are what ``Image.aovs`` holds."""
    from wrt.options import AOV_NAMES
    from wrt.render import _AovBuffers

    assert AOV_NAMES == (*_AovBuffers.SPEC, "coverage")
