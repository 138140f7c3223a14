"""Materials read at one time code of a kept stage (:class:`wrt.usd_frames.StageFrames`) and reused at another,
where USD says that nothing they are read from can differ.

A material's read (:meth:`wrt.materials.MaterialReader.material_index`) takes the attributes of the shading prims its
outputs lead to (shaders and node graphs, inside the material or connected from elsewhere), and, through textures,
image files. Each material is asked once per kept stage whether it is reusable (:func:`network_might_vary`): the
material, the prims inside it and every prim its network's connections reach (connections do not vary in time) have
no attribute that might vary (``UsdAttribute.ValueMightBeTimeVarying``, which counts value clips; where clips may
reach, :func:`wrt.usd_clips.under_clips`, unauthored schema attributes too, an instance proxy's asked of its
prototype); one animated material, or one whose inputs clips give, leaves the others reused.
The order images are first looked up in numbers them in ``Scene.textures``, and a file
may change, so a reused material's image files are looked up again, in order (:func:`replay`): where each gives
the kept read's pixels (the memo's array, kept while the file keeps its stamp) or is still missing, the material is a
copy of the kept one, its texture indices those of this load; else it is read afresh. The warnings its read recorded
are recorded again, in order with those of the lookups. Reads at the default time and at time codes are kept apart
(an attribute with a default and one sample reads as either).
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
from pxr import Usd, UsdShade

from .usd_clips import asked_attributes, under_clips


@dataclasses.dataclass(frozen=True)
class FileLookup:
    """One :meth:`wrt.materials.MaterialReader.file_images` call of a kept read: its arguments, the span of the
    read's warnings it recorded (``skips``, start and end), what it gave (``image``, ``tiles``: indices in that
    load's ``Scene.textures``) and the pixel arrays behind them (``pixels``: the memo's, kept while the file is)."""

    args: tuple
    skips: tuple[int, int]
    image: int
    tiles: object
    pixels: tuple


@dataclasses.dataclass(frozen=True)
class KeptRead:
    """A material's kept read: the Material (or None), every warning it recorded and its image file lookups."""

    material: object
    skips: tuple
    lookups: tuple[FileLookup, ...]


class MaterialMemo:
    """The kept material reads of one kept stage.

    Args:
        clip_roots: prims with value clips (:func:`wrt.usd_clips.clip_roots`): the shading prims they may reach are
            asked more (:func:`network_might_vary`).
    """

    def __init__(self, clip_roots: list = ()):
        self.clip_roots = list(clip_roots)
        self._varies = {}  # material path -> network_might_vary, asked once per kept stage
        self._kept = {}  # (material path, default time) -> (Material or None, ((reason, shown path, detail), ...))
        # (resolved path, colour space) -> (file stamp, read-only pixels, {key: what was made from them}: derived)
        self._images = {}
        self.counts = {"reused": 0, "read": 0}  # reads of each kind, for tests and benchmarks
        # (prim path, outer bindings, purposes) -> (material, binding relationship, purposes whose walk found none):
        # MaterialReader.bound's answer. Bindings are relationships (never time-varying) and collections (their
        # membership too), resolved without a time: only composition changes them, and it reopens a kept stage.
        self.bindings = {}
        self.binding_counts = {"reused": 0}  # answers given again, for tests

    def reusable(self, material: UsdShade.Material) -> bool:
        """Nothing ``material``'s read takes might vary (:func:`network_might_vary`)."""
        path = str(material.GetPath())
        if path not in self._varies:
            self._varies[path] = network_might_vary(material.GetPrim(), self.clip_roots)
        return not self._varies[path]

    def find(self, material: UsdShade.Material, time: Usd.TimeCode) -> KeptRead | None:
        """The kept read of ``material`` at a time of this kind, or None."""
        return self._kept.get((str(material.GetPath()), time.IsDefault()))

    def keep(self, material: UsdShade.Material, time: Usd.TimeCode, read, skips: list, lookups: list,
             start: int) -> None:
        """Keeps ``read`` (a Material or None) of ``material``, the warnings it recorded (``skips``, from position
        ``start`` of the reader's list on) and its image file ``lookups``."""
        self.counts["read"] += 1
        # A lookup's UDIM tile table is the one the read put in its Material, which goes into this load's scene: the
        # memo keeps its own, or an edit of the scene's would be taken for the file's tiles at the next frame.
        lookups = [dataclasses.replace(f, skips=(f.skips[0] - start, f.skips[1] - start),
                                       tiles=None if f.tiles is None else f.tiles.copy()) for f in lookups]
        self._kept[(str(material.GetPath()), time.IsDefault())] = KeptRead(own_copy(read), tuple(skips),
                                                                           tuple(lookups))

    def image(self, resolved: str, color_space: str, load):
        """``load(resolved, color_space)``, the pixels of an image file, kept while the file (the package of one
        inside a ``.usdz``) keeps its stamp (:func:`wrt.usd_frames.file_stamp`): decoded once, whatever the
        materials (and lights: :class:`wrt.usd_lights.LightTextures`) that read it and whether they vary."""
        from pxr import Ar

        from .usd_frames import file_stamp

        stamp = file_stamp(Ar.SplitPackageRelativePathOuter(resolved)[0])
        kept = self._images.get((resolved, color_space))
        if stamp is not None and kept is not None and kept[0] == stamp:
            return kept[1]
        pixels = load(resolved, color_space)
        if stamp is not None:
            pixels.flags.writeable = False  # shared by the scenes of every load that reads it
            self._images[(resolved, color_space)] = (stamp, pixels, {})
        return pixels

    def derived(self, resolved: str, color_space: str, pixels, key, make):
        """``make()``, an array made from ``pixels`` alone (a dome's lat-long map of them: ``key`` says which), kept
        read-only with them while they are the kept pixels of ``resolved`` (:meth:`image`): a rewritten file is
        decoded again, and what it gives is made again."""
        kept = self._images.get((resolved, color_space))
        if kept is None or kept[1] is not pixels:
            return make()
        if key not in kept[2]:
            made = make()
            made.flags.writeable = False  # shared by the scenes of every load that reads it
            kept[2][key] = made
        return kept[2][key]


def network_might_vary(material: Usd.Prim, clip_roots: list = ()) -> bool:
    """Some prim ``material``'s read may take (see the module docstring) has an attribute that might vary: the
    material, every prim inside it or inside a node graph its connections reach, and every prim that a connection of
    theirs names (at any depth; instance proxies and prototypes alike). Where value clips may reach a prim
    (:func:`wrt.usd_clips.under_clips`) every attribute it has is asked, its schema's unauthored ones too (clips give
    those values), and an instance proxy's are asked of its prim in the prototype: USD says an instance proxy's
    clip-driven input cannot vary (``ValueMightBeTimeVarying`` False, usd-core 0.26) while its prototype's says it
    might, and both read the same values. ``ValueMightBeTimeVarying`` counts clips: several clips, or one retimed,
    say True."""
    stage = material.GetStage()
    inside = Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)
    seen = set()
    todo = [material]
    while todo:
        prim = todo.pop()
        if not prim or prim.GetPath() in seen:
            continue
        seen.add(prim.GetPath())
        clipped = under_clips(prim, clip_roots)  # every attribute asked, of the prototype for a proxy
        if clipped and any(attr.ValueMightBeTimeVarying() for attr in asked_attributes(prim, clip_roots)):
            return True
        for attr in prim.GetAuthoredAttributes():
            if attr.ValueMightBeTimeVarying():
                return True
            todo += [stage.GetPrimAtPath(target.GetPrimPath()) for target in attr.GetConnections()]
        if prim.IsA(UsdShade.NodeGraph):  # a Material is one; what is inside it, connected or not
            todo += prim.GetFilteredChildren(inside)
    return False


def own_copy(value):
    """A copy of ``value`` (a Material, its TextureInputs, their fields) that shares nothing its holder may change: a
    kept read goes into one load's scene and each reuse into another's, whose caller may assign a field or edit an
    array in place, and neither may reach the memo or another frame. Its arrays are copied (small: colours, a 3 x 3
    transform, UDIM tile indices), numbers, strings and tuples of them shared (immutable), objects copied field by
    field without their ``__init__`` or ``__setattr__`` (a copy is as checked as its original). ``copy.deepcopy``
    gave the same at nearly three times the cost (its memo and reduce protocol for every field): 8 of the 88 ms of a
    kept frame of 300 textured materials, 3 now."""
    kind = type(value)
    if kind in _IMMUTABLE or value is None:
        return value
    if kind is np.ndarray and value.dtype != object:
        return value.copy()
    if kind is tuple and all(type(v) in _IMMUTABLE for v in value):
        return value
    if kind is dict:
        return {k: own_copy(v) for k, v in value.items()}
    if kind.__reduce_ex__ is object.__reduce_ex__ and not hasattr(kind, "__slots__") and hasattr(value, "__dict__"):
        copied = object.__new__(kind)  # what copy.copy makes of such an object, without its reduce protocol
        copied.__dict__.update({k: own_copy(v) for k, v in value.__dict__.items()})
        return copied
    return copy.deepcopy(value)  # anything else (a list, an array subclass, an unknown type): as before


_IMMUTABLE = {bool, int, float, str, bytes, np.bool_, np.int32, np.int64, np.float32, np.float64}


def replay(reader, kept: KeptRead) -> tuple | None:
    """``(a copy of the kept Material or None,)`` for ``reader``'s load, or None (``reader`` as it was) where an image
    file the read looked up changed. The lookups are made again in order, between the kept warnings, as a fresh read
    makes them: each file is resolved again and its images added to ``reader.textures`` (or found there), and its
    warnings recorded, where a fresh read would; the copy's texture indices are those it gave. Changed: a file found
    or decoded where it was not (a missing file that appeared, a new UDIM tile), or the other way, or other pixels
    than the kept read's (:meth:`MaterialMemo.image` decodes a file again when its stamp changed)."""
    mark = reader.mark()
    renumber = {-1: -1}
    done = 0
    for lookup in kept.lookups:
        reader.skipped += kept.skips[done:lookup.skips[0]]
        image, tiles = reader.file_images(*lookup.args)
        same = (image >= 0) == (lookup.image >= 0) and (tiles is None) == (lookup.tiles is None) and (
            tiles is None or np.array_equal(tiles >= 0, lookup.tiles >= 0))
        pixels = reader.pixels_of(image, tiles) if same else ()
        if not same or len(pixels) != len(lookup.pixels) or any(a is not b for a, b in zip(pixels, lookup.pixels)):
            reader.rewind(mark)
            return None
        renumber[lookup.image] = image
        if tiles is not None:
            renumber.update(zip(lookup.tiles.tolist(), tiles.tolist()))
        done = lookup.skips[1]
    reader.skipped += kept.skips[done:]
    material = own_copy(kept.material)
    for tex in getattr(material, "textures", {}).values():
        tex.image = renumber[tex.image]
        if tex.tiles is not None:
            tex.tiles = np.array([renumber[k] for k in tex.tiles.tolist()], tex.tiles.dtype)
    return (material,)
