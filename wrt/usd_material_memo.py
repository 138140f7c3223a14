"""Materials read at one time code of a kept stage (:class:`wrt.usd_frames.StageFrames`) and reused at another,
where USD says that nothing they are read from can differ.

A material's read (:meth:`wrt.materials.MaterialReader.material_index`) takes the attributes of the shading prims its
outputs lead to (shaders and node graphs, inside the material or connected from elsewhere), and, through textures,
image files. Which prims those are is not traced: materials are reused only on a stage where no ``UsdShade.Shader``
or ``NodeGraph`` (a ``Material`` is one) has an attribute that might vary (``UsdAttribute.ValueMightBeTimeVarying``),
asked once per kept stage, prototypes included; and only materials whose read looked up no image file (the order
images are first read in numbers them in ``Scene.textures``, and a file may change): the others are read afresh. A
reused material is a copy of the kept one, and the warnings its read recorded are recorded again. Reads at the
default time and at time codes are kept apart (an attribute with a default and one sample reads as either).
"""

from __future__ import annotations

import copy

from pxr import Usd, UsdShade


class MaterialMemo:
    """The kept material reads of one kept stage.

    Args:
        stage: the kept stage.
    """

    def __init__(self, stage: Usd.Stage):
        self.reusable = not shading_might_vary(stage)
        self._kept = {}  # (material path, default time) -> (Material or None, ((reason, shown path, detail), ...))
        # (resolved path, colour space) -> (file stamp, read-only pixels, {key: what was made from them}: derived)
        self._images = {}
        self.counts = {"reused": 0, "read": 0}  # reads of each kind, for tests and benchmarks
        # (prim path, outer bindings, purposes) -> (material, binding relationship, purposes whose walk found none):
        # MaterialReader.bound's answer. Bindings are relationships (never time-varying) and collections (their
        # membership too), resolved without a time: only composition changes them, and it reopens a kept stage.
        self.bindings = {}
        self.binding_counts = {"reused": 0}  # answers given again, for tests

    def find(self, path: str, time: Usd.TimeCode):
        """``(a copy of the kept Material or None, the warnings of its read)``, or None when none is kept."""
        kept = self._kept.get((path, time.IsDefault())) if self.reusable else None
        if kept is None:
            return None
        self.counts["reused"] += 1
        return copy.deepcopy(kept[0]), kept[1]

    def keep(self, path: str, time: Usd.TimeCode, material, skips: list) -> None:
        if self.reusable:
            self.counts["read"] += 1
            self._kept[(path, time.IsDefault())] = (copy.deepcopy(material), tuple(skips))


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


def shading_might_vary(stage: Usd.Stage) -> bool:
    """Some shader or node graph of ``stage`` (its native prototypes too) has an attribute that might vary."""
    roots = [stage.GetPseudoRoot(), *stage.GetPrototypes()]
    for root in roots:
        for prim in Usd.PrimRange(root, Usd.PrimAllPrimsPredicate):
            if (prim.IsA(UsdShade.Shader) or prim.IsA(UsdShade.NodeGraph)) and any(
                    a.ValueMightBeTimeVarying() for a in prim.GetAuthoredAttributes()):
                return True
    return False
