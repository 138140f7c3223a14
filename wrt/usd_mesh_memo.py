"""Meshes read at one time code of a kept stage (:class:`wrt.usd_frames.StageFrames`) and reused at another, where
USD itself says that nothing they are made from can differ.

A mesh's read (:meth:`wrt.usd_meshes.MeshReading._read_mesh`) takes: the mesh's own attributes and those of its
descendants (GeomSubsets), the ``primvars:`` its ancestors hand down (:class:`wrt.usd_ancestors.InheritedPrimvars`),
a skeleton's pose, its transform to its content's space, what its materials ask of it (their indices per face, the
texture-coordinate and colour primvars they read), and the context it is read in (world or prototype, an instance's
colour). The first three are asked of USD once per kept stage: a mesh is reusable only when no attribute of it or of
a descendant might vary (``UsdAttribute.ValueMightBeTimeVarying``; its own transform ops, ``visibility`` and
``extent`` aside, which its read does not take; ``velocities`` or ``accelerations`` authored at all
count as varying, as they move one sample of points; where value clips may reach, every attribute is asked, its
schema's unauthored ones too, an instance proxy's of its prim in the prototype,
:func:`wrt.usd_clips.asked_attributes`), no ``primvars:`` attribute above it might, and no ``SkelRoot`` is above it
(skinned meshes are read every time). The others are found again at every read, as a fresh read finds them, and
compared with those of the kept read: the transform's bytes, the material indices, primvar names and
fallbacks, and the context go into the comparison. Equal: the kept :class:`wrt.scene.Mesh` is handed out again (a new
object sharing its read-only arrays), or, where only the transform differs, the kept mesh in its own space is baked
with the new one. The warnings the kept read recorded (``_skip``) are recorded again, in the same order, and so are
the colour primvars its content wants from an instance. Anything else is read afresh.

Reads at the default time and at numeric times are kept apart: an attribute with one time sample and a default value
does not vary in time, but reads as the default at ``time=None``.
"""

from __future__ import annotations

import copy
from typing import NamedTuple

import numpy as np
from pxr import Usd

from .scene import Mesh
from .usd_clips import asked_attributes, asked_prim, under_clips
from .usd_meshes import LocalMesh

# Attributes that move the points of a point-based prim between (or past) samples, one sample of points too.
RATE_ATTRIBUTES = ("velocities", "accelerations")
INHERITED_PREFIX = "primvars:"  # the only attributes above a mesh whose values its read takes (transforms compared)
# A mesh's own attributes that its read does not take, which may vary: its transform (compared) and visibility (asked
# before the read), and its extent (never read).
PLACEMENT_ATTRIBUTES = ("visibility", "extent", "xformOpOrder")
XFORM_OP_PREFIX = "xformOp:"
# Reads kept per prim and context, the latest: a prototype read again for other bindings or an instance's colour is
# another read (a colour that varies would otherwise keep one read per frame).
KEPT_PER_KEY = 4


class MeshInputs(NamedTuple):
    """What a mesh's read takes that is found again at every read (see the module docstring)."""

    face_materials: bytes | None  # (F,) int32 material of each face, or None
    uv_source: tuple | None  # (texture-coordinate primvar, bytes of its (2,) fallback st[, instance's st]), or None
    color_names: tuple  # colour primvars read, in order
    color_primvars: tuple  # the colour primvar of each material the faces use (MaterialReader.color_primvar_of)
    default_faces: bool  # some faces have the default material (displayOpacity is read)
    outer_color: tuple | None  # the context's colours from a native instance (Context.outer_color)


class KeptMesh(NamedTuple):
    """One kept read of a mesh."""

    inputs: MeshInputs
    n_faces: int  # len(faceVertexCounts)
    count_skips: tuple  # (reason, path, detail) recorded while reading faceVertexCounts (before the materials)
    to_space: bytes  # the (4, 4) float64 transform baked in
    local: LocalMesh  # the mesh in its own space, refined, its smooth normals made (cage None)
    mesh: Mesh  # as baked with to_space; its arrays are read-only
    read_skips: tuple  # (reason, path, detail) recorded while reading ``local``, in order
    bake_skips: tuple  # those recorded while baking ``mesh``


class MeshMemo:
    """The kept reads of one kept stage, and USD's answers about which prims might vary."""

    def __init__(self, clip_roots: list = ()):
        self.clip_roots = list(clip_roots)  # prims with value clips (wrt.usd_clips.clip_roots): asked more below
        self._varies = {}  # prim path -> one of its own attributes might vary
        self._subtree = {}  # prim path -> _varies of it or a descendant
        self._inherits_varying = {}  # prim path -> a primvar on it or above it might vary
        self._kept: dict[tuple, list[KeptMesh]] = {}
        self.counts = {"reused": 0, "rebaked": 0, "read": 0}  # reads of each kind, for tests and benchmarks

    def __len__(self) -> int:
        """The number of reads kept."""
        return sum(map(len, self._kept.values()))

    def key(self, prim: Usd.Prim, ctx, time: Usd.TimeCode, skel_root) -> tuple | None:
        """The key ``prim``'s read in context ``ctx`` is kept under, or None when it cannot be reused (see the module
        docstring); ``skel_root(prim)``: its SkelRoot or None."""
        if skel_root(prim) is not None or self._subtree_varies(prim) or self._inherits(prim.GetParent()):
            return None
        # blocked_opaque (with world) decides how displayOpacity is read: Context.keep_opaque and blocked_opaque.
        return (str(prim.GetPath()), ctx.content.path, ctx.world, ctx.blocked_opaque, time.IsDefault())

    def counted(self, key: tuple | None) -> tuple[int, tuple] | None:
        """``(face count, warnings its read of faceVertexCounts recorded)`` of a kept read under ``key`` (they all
        have the same), or None."""
        kept = self._kept.get(key) if key is not None else None
        return (kept[0].n_faces, kept[0].count_skips) if kept else None

    def find(self, key: tuple, inputs: MeshInputs) -> KeptMesh | None:
        return next((k for k in self._kept.get(key, ()) if k.inputs == inputs), None)

    def keep(self, key: tuple, inputs: MeshInputs, counted: tuple[int, list], to_space: np.ndarray, local: LocalMesh,
             mesh: Mesh, read_skips: list, bake_skips: list) -> None:
        """Keeps a fresh read of a mesh: ``local`` as :meth:`MeshReading._read_mesh` baked it (smooth normals made),
        and the ``mesh`` it gave with ``to_space``; ``counted``: its face count and the warnings the read of its
        faceVertexCounts recorded (:meth:`counted`)."""
        self.counts["read"] += 1
        n_faces, count_skips = counted
        kept_local = copy.copy(local)
        kept_local.cage = None  # its smooth normals are made: a bake makes none anew
        kept_local.refinement = None  # applied to its points already
        entry = KeptMesh(inputs, n_faces, tuple(count_skips), np.ascontiguousarray(to_space, np.float64).tobytes(),
                         kept_local, copy.copy(mesh), tuple(read_skips), tuple(bake_skips))
        _freeze([vars(entry.mesh), vars(entry.local)])  # shared by the scenes of every read that reuses it
        kept = self._kept.setdefault(key, [])
        kept[:] = [k for k in kept if k.inputs != entry.inputs][-(KEPT_PER_KEY - 1):] + [entry]

    @staticmethod
    def inputs(face_materials, uv_source, color_names, color_primvars, default_faces, outer_color) -> MeshInputs:
        uv = None if uv_source is None else (uv_source[0], np.asarray(uv_source[1], np.float64).tobytes(),
                                             *uv_source[2:])  # (and an instance's st, Context.outer_uv)
        faces = None if face_materials is None else np.asarray(face_materials, np.int32).tobytes()
        return MeshInputs(faces, uv, tuple(color_names), tuple(color_primvars), bool(default_faces), outer_color)

    def _subtree_varies(self, prim: Usd.Prim) -> bool:
        path = prim.GetPath()
        if path not in self._subtree:
            self._subtree[path] = any(self._own_varies(p) for p in Usd.PrimRange(prim, Usd.PrimAllPrimsPredicate))
        return self._subtree[path]

    def _own_varies(self, prim: Usd.Prim) -> bool:
        path = prim.GetPath()
        if path not in self._varies:
            read = [a for a in asked_attributes(prim, self.clip_roots) if not _placement(a.GetName())]
            asked = asked_prim(prim) if under_clips(prim, self.clip_roots) else prim  # clips give rates too
            self._varies[path] = any(a.ValueMightBeTimeVarying() for a in read) or any(
                asked.HasAttribute(name) and asked.GetAttribute(name).HasAuthoredValue() for name in RATE_ATTRIBUTES)
        return self._varies[path]

    def _inherits(self, prim: Usd.Prim) -> bool:
        """Some ``primvars:`` attribute of ``prim`` or an ancestor might vary."""
        chain = []
        found = False
        while prim and not prim.IsPseudoRoot():
            path = prim.GetPath()
            if path in self._inherits_varying:
                found = self._inherits_varying[path]
                break
            chain.append(path)
            if any(a.GetName().startswith(INHERITED_PREFIX) and a.ValueMightBeTimeVarying()
                   for a in asked_attributes(prim, self.clip_roots)):
                found = True
                break
            prim = prim.GetParent()
        for path in chain:
            self._inherits_varying[path] = found
        return found


def _placement(name: str) -> bool:
    """``name`` is one of :data:`PLACEMENT_ATTRIBUTES` or a transform op's."""
    return name in PLACEMENT_ATTRIBUTES or name.startswith(XFORM_OP_PREFIX)


def _freeze(value) -> None:
    """Makes the numpy arrays in ``value`` (nested in tuples, lists and dicts) read-only."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, (tuple, list)):
        for item in value:
            _freeze(item)
    elif isinstance(value, dict):
        _freeze(list(value.values()))
