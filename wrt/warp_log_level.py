"""Warp's default log level, raised by wrt: a library prints nothing unless asked.

A first render printed Warp's start-up banner and a "Module ... load" line per kernel module (14 lines), which are
Warp's info messages; its warnings and errors still show. Only Warp's default level is raised: a level set before
importing wrt is kept, and ``wp.config.log_level = wp.LOG_INFO`` after it shows them again. (Warp 1.19 has no
``wp.config.quiet``; setting it does nothing.)

``import wrt`` does not import Warp (see ``wrt/__init__.py``): where Warp is not imported yet, the level is raised the
moment it is, by whichever module imports it, so the rule above holds as it did when ``import wrt`` imported Warp.
This covers ``wrt`` command lines and the bench and animation worker processes too: their tasks are functions of wrt
modules, pickled by reference, so a worker imports wrt before it runs one.
"""

import sys
import threading


def raise_default_level(wp) -> None:
    """Raises module ``wp``'s (Warp's) log level from its default ``LOG_INFO`` to ``LOG_WARNING``; others are kept."""
    if wp.config.log_level == wp.LOG_INFO:
        wp.config.log_level = wp.LOG_WARNING


class _RaiseOnImport:
    """A ``sys.meta_path`` finder that finds nothing itself: asked for ``warp``, it hands on the spec the other
    finders give, with a loader that raises the level as soon as Warp's ``__init__`` has run, and then steps aside.
    Until Warp is imported it stays: ``importlib.util.find_spec("warp")``, asking whether Warp is installed, finds a
    spec that is never loaded.

    One is installed per process, whichever copy of this module installed it (``RAISES_WARP_LEVEL``), and one asked
    again while it asks the others (a finder that itself asks every finder on ``sys.meta_path``) answers nothing: wrt
    imported afresh (its modules dropped from ``sys.modules``) added a second hook, and ``import warp`` recursed
    between the two until a RecursionError."""

    RAISES_WARP_LEVEL = True  # how raise_default_level_of_warp tells a hook of any copy of this module

    def __init__(self):
        self._asking = threading.local()  # whether this thread is inside this hook's find_spec

    def find_spec(self, name, path=None, target=None):
        if name != "warp" or getattr(self._asking, "now", False):
            return None
        others = [finder for finder in sys.meta_path if finder is not self and hasattr(finder, "find_spec")]
        self._asking.now = True
        try:
            spec = next((spec for spec in (f.find_spec(name, path, target) for f in others) if spec is not None),
                        None)
        finally:
            self._asking.now = False
        if spec is not None and spec.loader is not None:
            loader = spec.loader
            run = loader.exec_module

            # The loader may be shared by many modules (a PEP 302 importer that is its own loader, PyInstaller's):
            # only Warp's run is followed, and the loader gets its own method back with it. Left in place, every
            # later import through it read a 'config' of its module: AttributeError for all of them.
            def exec_module(module):
                if module.__name__ != name:
                    return run(module)
                if getattr(loader, "__dict__", {}).get("exec_module") is exec_module:
                    del loader.exec_module
                run(module)
                if self in sys.meta_path:
                    sys.meta_path.remove(self)
                raise_default_level(module)

            try:
                loader.exec_module = exec_module
            except AttributeError:  # a loader that takes no attributes (slots): Warp keeps its level
                pass
        return spec


def raise_default_level_of_warp() -> None:
    """Raises Warp's default log level now if Warp is imported, else when it is."""
    if "warp" in sys.modules:
        raise_default_level(sys.modules["warp"])
    elif not any(getattr(finder, "RAISES_WARP_LEVEL", False) for finder in sys.meta_path):
        sys.meta_path.insert(0, _RaiseOnImport())
