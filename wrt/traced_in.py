"""Which scene, and which state of it, a :class:`wrt.Hits` was traced in.

A hit's ids (``prim``, ``local_prim``, ``instance``) are rows, geometry ids and instances of the scene as it was
traced: in range of another scene, or of the same one after a mesh was added or the instances replaced, they name
other prims, and ``Scene.hit_paths`` named those without a word. :func:`wrt.trace` stamps its hits with
:class:`TracedIn`; the lookups that name prims by a hit's ids (``Scene.hit_paths``, ``Scene.hit_prims`` given the
Hits, ``wrt.rays.secondary_rays``) call :func:`check_traced_in` first.

A scene's ``identity`` is drawn when it is made and kept by its copies and pickles (a Dask worker's copy names the
same prims); its ``version`` is drawn again at every ``Scene.invalidate`` (the edit counter its Renderer and caches
follow: a mesh, shape, prototype, instance array or material replaced, or a list grown or shrunk, is noticed there),
so a copy edited apart from its original never shares a version with it. Both are plain strings: the stamp pickles.
"""

from __future__ import annotations

import secrets
from typing import NamedTuple


class TracedIn(NamedTuple):
    """Where hits were traced: the scene's identity and version (see the module docstring) and its ``source``."""

    scene: str
    version: str
    source: str | None


def new_token() -> str:
    """A fresh identity or version: random, so that copies in other processes do not draw the same one."""
    return secrets.token_hex(8)


def _described(source: str | None) -> str:
    return repr(source) if source else "built in Python"


def check_traced_in(scene, hits, what: str) -> None:
    """Raises ``ValueError`` (prefixed ``what``) when ``hits`` were traced in another scene than ``scene`` or in an
    earlier version of it; hits without a stamp (made by hand) are the caller's to vouch for. Edits since the last
    trace are noticed first (``Scene.drop_stale_caches``), as a trace would notice them."""
    stamp = getattr(hits, "traced_in", None)
    if stamp is None:
        return
    scene.drop_stale_caches()
    here = scene.traced_in
    if stamp.scene != here.scene:
        if stamp.source and stamp.source == here.source:
            theirs = f"another Scene of {stamp.source!r} (loaded or made apart from this one)"
        else:
            theirs = f"scene {stamp.source!r}" if stamp.source else "a scene built in Python"
        raise ValueError(f"{what}: these hits were traced in {theirs}, not in this one ({_described(here.source)}): "
                         "their ids name other prims here; name them with the scene they were traced in")
    if stamp.version != here.version:
        raise ValueError(f"{what}: the scene was edited since these hits were traced (a mesh, shape, prototype, "
                         "instance array or material added, removed or replaced, or invalidate() called), so their ids "
                         "may name other prims now: trace again")
