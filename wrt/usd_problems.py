"""Errors and warnings of one stage read: a :class:`wrt.errors.SceneError` naming the file, the prim (as usdview
shows a prim inside a native prototype) and the layer a bad value is authored in; prims left out, or data ignored,
tallied into one warning per reason at the end of the read."""

from __future__ import annotations

import re
import warnings

from pxr import Sdf, Tf, Usd

from .errors import SceneError, user_stacklevel

# A native prototype's path in words, as USD names it per opening (/__Prototype_12), not inside a longer path.
PROTOTYPE_ROOT = re.compile(r"(?<![\w.])/__Prototype_\d+(?!\w)")
# A prim that cannot be placed is left out, the rest of the stage drawn, as an instance so placed is (wrt.usd_contents).
NOT_FINITE_TRANSFORM = "prims whose world transform is not finite (NaN or inf) were skipped"
BEYOND_FLOAT32 = "prims that their world transform places beyond float32's range (|x| > 3.4e38) were skipped"


def property_stack(attr: Usd.Attribute, time: Usd.TimeCode) -> list:
    """The property specs of ``attr`` at ``time``, strongest first (empty when USD cannot give them)."""
    try:
        return attr.GetPropertyStack(time)
    except Tf.ErrorException:
        return []


def authored_type(attr: Usd.Attribute, time: Usd.TimeCode) -> str:
    """The value type ``attr`` is authored with: a schema attribute's type name is the schema's whatever was authored
    (``float[] points`` read as ``point3f[]``, ``float3 points`` too); its strongest spec holds the authored one."""
    stack = property_stack(attr, time)
    return str(stack[0].typeName) if stack else str(attr.GetTypeName())


class ProblemReport:
    """Errors and skipped prims of the stage reader (``stage``, ``source``, ``time``, ``skipped``,
    ``shown_prototypes``, ``prototype_instance_counts``)."""

    def _property_stack(self, attr: Usd.Attribute) -> list:
        """The property specs of ``attr`` at the read time, strongest first (empty when USD cannot give them)."""
        return property_stack(attr, self.time)

    def _authored_type(self, attr: Usd.Attribute) -> str:
        """:func:`authored_type` of ``attr`` at the read time."""
        return authored_type(attr, self.time)

    def _error(self, message: str, prim: Usd.Prim, attr: Usd.Attribute | None = None) -> SceneError:
        """A SceneError naming the file and the prim, plus the layer the bad value is authored in if different."""
        if attr is not None:
            stack = self._property_stack(attr)
            root = self.stage.GetRootLayer()
            if stack and stack[0].layer != root:
                message += f" (authored in {stack[0].layer.identifier})"
        return SceneError(message, path=self.source, prim=self._shown_path(prim))

    def _skip(self, reason: str, prim: Usd.Prim, detail: str | None = None):
        """Records a prim left out (or data ignored) for ``reason``; ``detail`` is tallied in the warning. A prim
        inside a native prototype is read once for all the instances that draw it: it is named in the first (see
        :meth:`_shown_path`), with the number of the others (``/A/Ball (and in 5 other instances)``)."""
        others = self._instance_count(prim) - 1 if prim.IsInPrototype() else 0
        shown = self._shown_path(prim) + (f" (and in {others} other instance{'s' * (others > 1)})" if others else "")
        self._skip_path(reason, shown, detail)

    def _skipped_unreadable(self, error: SceneError, prim: Usd.Prim) -> bool:
        """Whether ``error``, raised while reading the curves, Points, TetMesh or NurbsPatch ``prim``, is about
        ``prim`` itself (its topology or values); such a prim is then recorded as skipped, the fault in the detail,
        as a mesh of invalid topology is, so the rest of the stage is drawn (it stopped the whole load)."""
        if error.prim != self._shown_path(prim):
            return False
        self._skip(f"{prim.GetTypeName()} prims of invalid topology or values were skipped", prim, error.message)
        return True

    def _instance_count(self, prim: Usd.Prim) -> int:
        """How many times ``prim`` is on the stage outside classes: 1 outside native prototypes, else the sum over
        its prototype's instances that are not abstract (under a class), each counted as this counts it, so that
        nested instances multiply (two instances of a kit that holds three instances: six)."""
        if not prim.IsInPrototype():
            return 1
        root = prim
        while not root.IsPrototype():
            root = root.GetParent()
        key = str(root.GetPath())
        if key not in self.prototype_instance_counts:
            self.prototype_instance_counts[key] = sum(
                self._instance_count(p) for p in root.GetInstances() if not p.IsAbstract())
        return self.prototype_instance_counts[key]

    def _shown_path(self, prim: Usd.Prim) -> str:
        """The path that names ``prim`` in the scene, errors and warnings, as usdview shows it: inside a native
        instance's prototype (``/__Prototype_1/Tri``, a name USD makes up per opening that no file holds), its proxy
        in the prototype's first instance (``/A/Tri``, see :meth:`_prototype_name`)."""
        path = str(prim.GetPath())
        if not prim.IsInPrototype():
            return path
        root = prim
        while not root.IsPrototype():
            root = root.GetParent()
        return self._prototype_name(root)[1] + path[len(str(root.GetPath())):]

    def _prototype_name(self, prototype: Usd.Prim) -> tuple[bool, str]:
        """``(abstract, path)``: the path native prototype ``prototype`` is named by, that of its first instance
        (the least path, instances nested in other prototypes at their own names, so that USD's numbering, which
        differs per opening, chooses nothing), one under a class (abstract) only where it has no other."""
        key = str(prototype.GetPath())
        if key not in self.shown_prototypes:
            names = []
            for instance in prototype.GetInstances():
                if instance.IsInPrototype():
                    root = instance
                    while not root.IsPrototype():
                        root = root.GetParent()
                    abstract, _ = self._prototype_name(root)
                    names.append((abstract or instance.IsAbstract(), self._shown_path(instance)))
                else:
                    names.append((instance.IsAbstract(), str(instance.GetPath())))
            self.shown_prototypes[key] = min(names) if names else (True, key)
        return self.shown_prototypes[key]

    def _stable_path(self, path: str) -> str:
        """``path`` (a prim path, or one with an element index, ``/P/Points[3]``) named by :meth:`_shown_path` when
        it lies in a native prototype."""
        if not path.startswith("/"):
            return path
        end = path.find("/", 1)
        top = path if end < 0 else path[:end]
        root = self.stage.GetPrimAtPath(top) if Sdf.Path.IsValidPathString(top) else None
        if not root or not root.IsPrototype():
            return path
        return self._prototype_name(root)[1] + path[len(top):]

    def _skip_path(self, reason: str, path: str, detail: str | None = None):
        # In order: the slice of a read kept for other frames is its warnings (wrt.usd_mesh_memo, usd_material_memo).
        self.skipped.append((self._stable_words(reason), path, None if detail is None else self._stable_words(detail)))

    def _stable_words(self, words: str) -> str:
        """``words`` (a warning's reason or detail) with each native prototype path in it named under the
        prototype's first instance (:meth:`_stable_path`), as the prims are: a material, shader or connection target
        inside a prototype was named ``/__Prototype_1/Looks/Mat``, a name USD makes up per opening that no file
        holds (``material /__Prototype_1/Looks/Mat: ...``), where the prim beside it was ``/A/Looks/Mat/PBR``."""
        if not (isinstance(words, str) and "/__Prototype_" in words):  # (a detail may be any object words print)
            return words
        return PROTOTYPE_ROOT.sub(lambda found: self._stable_path(found.group(0)), words)

    def _warn_skipped(self):
        """One warning per reason, with the number of prims, a tally of details (the prims with each) and the first
        few prim paths, each prim counted and named once: a prim recorded for several of its primvars (a constant
        displayColor and displayOpacity of several values each) read '2 prim(s): /Ball, /Ball'."""
        by_reason = {}
        for reason, path, detail in self.skipped:
            by_reason.setdefault(reason, []).append((path, detail))
        for reason, found in by_reason.items():
            tally = {}
            for _, detail in dict.fromkeys(found):  # a record repeated whole (path and detail) counts once
                if detail is not None:
                    tally[detail] = tally.get(detail, 0) + 1
            kinds = f" ({', '.join(f'{k}: {n}' for k, n in tally.items())})" if tally else ""
            paths = list(dict.fromkeys(p for p, _ in found))
            shown = ", ".join(paths[:3]) + (", ..." if len(paths) > 3 else "")
            warnings.warn(f"{self.source}: {reason}: {len(paths)} prim(s){kinds}: {shown}",
                          stacklevel=user_stacklevel())

