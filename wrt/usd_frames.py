"""One USD file loaded at many time codes (an animation's frames), keeping the opened stage and the meshes that
cannot differ between the loads: :meth:`StageFrames.load` gives the :class:`wrt.scene.Scene` that
:func:`wrt.load_usd` gives at that time, array for array, in any order of times.

The stage is opened once and kept while it is what a fresh open would give: every layer it uses is a local file whose
size, modification time and inode are those it had when opened, as are the files its value clips name (a missing
one still missing) and the folders its clip templates find files in (:mod:`wrt.usd_clips`), and no change was made to
the stage since (a ``Usd.Notice.StageContentsChanged``: an edit of one of its layers in memory). Anything else (a file
edited or replaced on disk, a layer that is no local file, composition errors, whose missing files may appear) opens it
afresh and forgets every kept mesh. A fresh :func:`wrt.load_usd` of a file whose layers a kept stage holds would read
those layers as USD holds them, not the file (USD's layer registry): so :func:`wrt.usd_stage.open_stage` first lets
go of kept stages whose files changed (:func:`release_changed`).

Meshes are reused by :class:`wrt.usd_mesh_memo.MeshMemo`, materials by :class:`wrt.usd_material_memo.MaterialMemo`,
visibility and transforms by :class:`wrt.usd_placement_memo.PlacementMemo` (which can be, and when); the arrays of
the meshes kept and the texture images are shared by the scenes of the loads and read-only from the load on
(:meth:`wrt.scene.Scene.invalidate` leaves them so: an edit in place would change later frames). So are the material
bindings (:attr:`wrt.usd_material_memo.MaterialMemo.bindings`: relationships and collections, resolved without a
time, which only a change of composition changes). Everything else (the prim walk,
textures, instancing, cameras, lights, render settings) is read at every load.
What opening the stage reports (USD's own diagnostics, such as invalid value clips, and wrt's warnings about layers
in other units) every load of a kept stage reports again, as a fresh load would.
"""

from __future__ import annotations

import os
import weakref

from pxr import Ar, Tf, Usd

from .usd_clips import clip_roots, clip_stamps
from .usd_material_memo import MaterialMemo
from .usd_mesh_memo import MeshMemo
from .usd_placement_memo import PlacementMemo

_KEPT = weakref.WeakSet()  # every StageFrames holding a stage, for release_changed


class StageFrames:
    """Loads one stage at many time codes (see the module docstring).

    Args:
        path: the USD file.
        **options: :func:`wrt.load_usd` options other than ``time`` (``tessellate_gprims``, ``refine_level``,
            ``variants``, ``render_settings``), the same for every load.

    Attributes:
        memo: the :class:`wrt.usd_mesh_memo.MeshMemo` of the kept stage (its ``counts`` say how each mesh was read),
            or None while no stage is kept.
        material_memo: its :class:`wrt.usd_material_memo.MaterialMemo`, likewise.
        placement_memo: its :class:`wrt.usd_placement_memo.PlacementMemo` (visibility and transforms), likewise.
    """

    def __init__(self, path, **options):
        self.path = path
        self.options = {"tessellate_gprims": False, "refine_level": 0, "variants": None, "render_settings": None,
                        **options}
        self.memo = None
        self.material_memo = self.placement_memo = None
        self._stage = None
        self._opened_with = None  # (source, variants) the kept stage was opened with
        self._stamps = {}  # file -> stamp (_stamp) of each layer the kept stage uses, when opened
        self._posted = []  # the USD diagnostics its opening posted (wrt.usd_stage.held_diagnostics)
        self._edited = [False]  # set by the stage's change notices (a list: the listener must not hold self)
        self._listener = None

    def load(self, time=None):
        """The :class:`wrt.scene.Scene` of :func:`wrt.load_usd` at ``time`` (see its arguments and errors)."""
        from .usd import load_stage_at

        o = self.options
        return load_stage_at(self.path, time, o["tessellate_gprims"], o["refine_level"], o["variants"],
                             o["render_settings"], frames=self)

    def stage(self, source: str, variants) -> Usd.Stage:
        """The kept stage of ``source`` with ``variants``, opened (with :func:`wrt.usd.open_variants`) unless the
        kept one is still what opening it gives; a kept one reports what opening it reported again, as opening it
        would (only the frame that opened it did): USD's own diagnostics (invalid value clips, ...), then the
        warnings about its layers in other units. A stage whose opening posted a USD error is not kept."""
        from .usd import open_variants
        from .usd_stage import post_again, reposted, warn_other_layer_units

        opened_with = (source, repr(variants))
        if self._stage is not None and (self._opened_with != opened_with or not self.unchanged()):
            self.release()
        if self._stage is None:
            posted = []
            stage = open_variants(source, variants, posted)
            clipped = clip_roots(stage)
            stamps = _layer_stamps(stage)
            clips = clip_stamps(stage, clipped, file_stamp) if stamps is not None else None
            if clips is None or stage.GetCompositionErrors() or not reposted(posted):
                return stage  # opened for this load alone; nothing kept
            self._stage, self._opened_with, self._stamps = stage, opened_with, {**stamps, **clips}
            self._posted = posted
            self.memo, self.material_memo = MeshMemo(clipped), MaterialMemo(clipped)
            self.placement_memo = PlacementMemo(clipped)
            edited = self._edited = [False]
            self._listener = Tf.Notice.Register(Usd.Notice.StageContentsChanged,
                                                lambda notice, sender: edited.__setitem__(0, True), stage)
            _KEPT.add(self)
            return stage
        post_again(self._posted)
        warn_other_layer_units(self._stage, source)
        return self._stage

    def unchanged(self) -> bool:
        """The kept stage is what opening its file now gives: not edited in memory, its layers' files as they were."""
        return not self._edited[0] and all(file_stamp(file) == stamp for file, stamp in self._stamps.items())

    def release(self) -> None:
        """Lets go of the kept stage and its meshes (the next load opens the file again)."""
        if self._listener is not None:
            self._listener.Revoke()
        self._stage = self._opened_with = self._listener = self.memo = self.material_memo = self.placement_memo = None
        self._stamps, self._posted = {}, []
        _KEPT.discard(self)


def release_changed() -> None:
    """Lets go of every kept stage that is no longer what opening its file gives, so that USD's layer registry no
    longer holds the layers as they were (a fresh load of the file reads it from disk)."""
    for frames in list(_KEPT):
        if not frames.unchanged():
            frames.release()


def _layer_stamps(stage: Usd.Stage) -> dict | None:
    """``{file: stamp}`` of every layer ``stage`` uses (the package of a layer inside a ``.usdz``), or None when one
    is not a local file (its changes could not be seen). Anonymous layers (the session layer) are the stage's own."""
    stamps = {}
    for layer in stage.GetUsedLayers():
        if layer.anonymous:
            continue
        file = Ar.SplitPackageRelativePathOuter(layer.realPath)[0] if layer.realPath else ""
        stamp = file_stamp(file) if file else None
        if stamp is None:
            return None
        stamps[file] = stamp
    return stamps


def file_stamp(file: str) -> tuple | None:
    """What changes when ``file`` is written or replaced: inode, size, modification and change times (ns)."""
    try:
        s = os.stat(file)
    except OSError:
        return None
    return s.st_ino, s.st_size, s.st_mtime_ns, s.st_ctime_ns
