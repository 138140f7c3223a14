"""Seeded random USD stages built through composition and time, and USD's own answer for what they show.

:func:`write_stage` writes a root layer, a sublayer and a few asset layers into a folder: subLayers and references
with layer offsets (offset and scale), payloads, variant sets chosen by the referencing layer, inherits from a class
the root layer gives opinions to, instanceable prims (nested; assets whose root is a mesh or an instancer too),
PointInstancers (animated positions, orientations, scales, protoIndices and invisibleIds, velocities, accelerations
and angular velocities; ids, inactiveIds; prototypes under the instancer or beside it, under an ``over``),
animated transform ops of every kind (inverted ones, resetXformStack outside instances, an op order the root layer
rewrites), animated points (moved by velocities), topology and holes, animated and inherited visibility, inactive
prims, overs holding defined meshes, purposes, and ``timeCodesPerSecond`` / ``framesPerSecond`` that differ from
layer to layer (or fall back on each other). Faces are convex and planar at every time (each sample of a mesh's
points is an affine image of the same polygons, and so is their velocity), so a fan of each face is the
triangulation.

:func:`usd_triangles` is the oracle: the world-space triangles the stage shows at a time, from USD's own API
(``XformCache``, ``ComputeVisibility``, ``ComputePurpose``, ``Mesh`` points ``Get(time)`` or, with velocities,
``ComputePointsAtTime``, PointInstancer ``ComputeInstanceTransformsAtTime`` and ``ComputeMaskAtTime``), walking
instance proxies. Inside a PointInstancer's prototype, visibility is taken from the prototype root down (the scope
holding the prototypes is often hidden so they are not drawn in place: Hydra draws them through the instancer all the
same), and prototypes under an ``over`` are drawn, an ``over`` inside one not (Hydra's prototype predicate).
"""

from __future__ import annotations

import os

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

DRAWN_PURPOSES = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)
# A PointInstancer's prototypes are drawn though their ancestors are not defined (kept under an ``over``), as Hydra
# draws them: each prim needs a defining specifier of its own.
PROTOTYPE_PREDICATE = Usd.PrimIsActive & Usd.PrimIsLoaded & ~Usd.PrimIsAbstract & Usd.PrimHasDefiningSpecifier
SAMPLE_TIMES = (-3.0, 0.0, 1.0, 2.0, 3.5, 6.0, 10.0, 24.0)  # layer times that samples are authored at
RATES = (None, 12.0, 24.0, 30.0, 48.0)  # timeCodesPerSecond / framesPerSecond choices; None: not authored


class StageWriter:
    """Writes one random composed stage (see the module docstring) from ``rng``; counts what it made."""

    def __init__(self, folder: str, rng: np.random.Generator, defaults: str = "mixed"):
        self.folder = folder
        self.rng = rng
        # "mixed": an animated attribute may author a default beside its samples; "never": none does (nor any
        # velocity), so wrt's time=None reads what USD reads at EarliestTime; "always": every one does, so wrt's
        # time=None reads what USD reads at the default time. "never" also leaves out the opinions of the class and
        # of the referencing prims: a default there under samples stronger than it (or samples under a stronger
        # default) is an authored default, which wrt's time=None reads as USD's default time does.
        self.defaults = defaults
        self.assets: list[str] = []  # file names of the asset layers written so far (each may reference earlier ones)
        # resetXformStack is authored only outside instances: inside one (an asset may be instanced, a prototype of a
        # PointInstancer is) USD resets to the world where Hydra resets to the instance (see usd_triangles).
        self.resets = False

    # Layers ----------------------------------------------------------------------------------------------------

    def new_layer(self, name: str) -> Usd.Stage:
        stage = Usd.Stage.CreateNew(os.path.join(self.folder, name))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        layer = stage.GetRootLayer()
        tcps, fps = self.rng.choice(len(RATES), 2)
        if RATES[tcps] is not None:
            layer.timeCodesPerSecond = RATES[tcps]
        if RATES[fps] is not None:
            layer.framesPerSecond = RATES[fps]
        return stage

    def offset(self) -> Sdf.LayerOffset:
        rng = self.rng
        if rng.random() < 0.3:
            return Sdf.LayerOffset()
        return Sdf.LayerOffset(float(rng.choice([-4.0, -1.5, 0.0, 2.0, 5.0])), float(rng.choice([0.5, 1.0, 2.0, 3.0])))

    def write(self) -> str:
        for k in range(int(self.rng.integers(1, 4))):
            self.write_asset(k)
        sub = self.new_layer("sub.usda")
        world = UsdGeom.Xform.Define(sub, "/World").GetPrim()
        self.resets = True
        self.subtree(sub, world.GetPath().AppendChild("FromSub"), 2)
        sub.GetRootLayer().Save()

        root = self.new_layer("root.usda")
        layer = root.GetRootLayer()
        layer.subLayerPaths.append("sub.usda")
        layer.subLayerOffsets[0] = self.offset()
        root.SetDefaultPrim(root.DefinePrim("/World", "Xform"))
        self.ops(root.GetPrimAtPath("/World"))
        klass = root.CreateClassPrim("/_class_Prop")
        if self.defaults != "never":
            self.class_opinions(root, klass)
        for i in range(int(self.rng.integers(1, 5))):
            self.reference(root, Sdf.Path(f"/World/R{i}"), overrides=True)
        self.subtree(root, Sdf.Path("/World/Local"), 2)
        layer.Save()
        return layer.realPath

    def write_asset(self, k: int):
        stage = self.new_layer(f"asset{k}.usda")
        kind = self.rng.random()
        if kind < 0.15:
            stage.SetDefaultPrim(self.mesh(stage, Sdf.Path("/Asset")))
        elif kind < 0.3:
            stage.SetDefaultPrim(self.instancer(stage, Sdf.Path("/Asset")))
        if kind < 0.3:
            stage.GetRootLayer().Save()
            self.assets.append(f"asset{k}.usda")
            return
        prim = UsdGeom.Xform.Define(stage, "/Asset").GetPrim()
        stage.SetDefaultPrim(prim)
        self.ops(prim)
        if self.rng.random() < 0.5:
            prim.GetInherits().AddInherit("/_class_Prop")
        self.mesh(stage, prim.GetPath().AppendChild("Body"))
        if self.rng.random() < 0.5:
            vset = prim.GetVariantSets().AddVariantSet("look")
            for name in ("a", "b", "c"):
                vset.AddVariant(name)
                vset.SetVariantSelection(name)
                with vset.GetVariantEditContext():
                    self.subtree(stage, prim.GetPath().AppendChild(f"V{name}"), 1)
            vset.SetVariantSelection(str(self.rng.choice(["a", "b", "c"])))
        self.subtree(stage, prim.GetPath().AppendChild("Parts"), 2)
        stage.GetRootLayer().Save()
        self.assets.append(f"asset{k}.usda")

    def class_opinions(self, stage: Usd.Stage, klass: Usd.Prim):
        """Opinions of the root layer on ``/_class_Prop``, inherited by the assets that inherit it."""
        rng = self.rng
        body = stage.OverridePrim(klass.GetPath().AppendChild("Body"))
        if rng.random() < 0.25:
            self.visibility(UsdGeom.Imageable(klass))
        if rng.random() < 0.4:
            self.visibility(UsdGeom.Imageable(body))
        if rng.random() < 0.3:
            UsdGeom.Imageable(body).CreatePurposeAttr(str(rng.choice(["render", "proxy", "guide", "default"])))
        if rng.random() < 0.3:
            op = UsdGeom.Xformable(klass).AddTranslateOp(opSuffix="fromClass")
            self.animate(op.GetAttr(), lambda: Gf.Vec3d(*rng.uniform(-2, 2, 3)))
        if rng.random() < 0.15:
            body.SetActive(False)

    # Prims -----------------------------------------------------------------------------------------------------

    def subtree(self, stage: Usd.Stage, path: Sdf.Path, depth: int):
        """A random prim at ``path`` and, for an Xform, children ``depth`` levels down."""
        rng = self.rng
        if rng.random() < 0.05:  # an over holding a defined mesh: neither is drawn, instanced or not
            self.mesh(stage, path.AppendChild("Overridden"))
            prim = stage.GetPrimAtPath(path)
            prim.SetSpecifier(Sdf.SpecifierOver)  # after the mesh: defining it defined its parent
            return prim
        choice = rng.random()
        if choice < 0.3 or depth == 0:
            prim = self.mesh(stage, path)
        elif choice < 0.45 and self.assets:
            prim = self.reference(stage, path)
        elif choice < 0.6:
            prim = self.instancer(stage, path)
        else:
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            self.ops(prim)
            for i in range(int(rng.integers(1, 4))):
                self.subtree(stage, path.AppendChild(f"C{i}"), depth - 1)
        self.imageable(prim)
        return prim

    def imageable(self, prim: Usd.Prim):
        rng = self.rng
        img = UsdGeom.Imageable(prim)
        if rng.random() < 0.25:
            self.visibility(img)
        if rng.random() < 0.15:
            img.CreatePurposeAttr(str(rng.choice(["render", "proxy", "guide", "default"])))
        if rng.random() < 0.05:
            prim.SetActive(False)

    def visibility(self, img: UsdGeom.Imageable):
        rng = self.rng
        attr = img.CreateVisibilityAttr()
        if rng.random() < 0.4:
            attr.Set(UsdGeom.Tokens.invisible)
        else:
            self.animate(attr, lambda: str(rng.choice(["inherited", "invisible"])), default=False)

    def reference(self, stage: Usd.Stage, path: Sdf.Path, overrides: bool = False) -> Usd.Prim:
        """A prim referencing (or taking as payload) a random asset with a random layer offset, maybe instanceable,
        maybe with overrides of the root layer (variant selection, visibility, op order)."""
        rng = self.rng
        prim = stage.DefinePrim(path, "Xform")
        asset = "./" + str(rng.choice(self.assets))
        if rng.random() < 0.3:
            prim.GetPayloads().AddPayload(Sdf.Payload(asset, Sdf.Path(), self.offset()))
        else:
            prim.GetReferences().AddReference(Sdf.Reference(asset, Sdf.Path(), self.offset()))
        if rng.random() < 0.5:
            prim.SetInstanceable(True)
        if not overrides:
            return prim
        vsets = prim.GetVariantSets()
        if vsets.HasVariantSet("look") and rng.random() < 0.7:
            vsets.GetVariantSet("look").SetVariantSelection(str(rng.choice(["a", "b", "c"])))
        xformable = UsdGeom.Xformable(prim)
        if rng.random() < 0.3:
            order = list(xformable.GetXformOpOrderAttr().Get() or [])
            rng.shuffle(order)
            xformable.GetXformOpOrderAttr().Set(order[: int(rng.integers(0, len(order) + 1))])
        if rng.random() < 0.3:
            op = xformable.AddScaleOp(opSuffix="fromRoot")
            self.animate(op.GetAttr(), lambda: Gf.Vec3f(*rng.uniform(0.5, 2.0, 3)))
        if self.resets and rng.random() < 0.1:
            xformable.SetResetXformStack(True)
        if self.defaults != "never":
            self.imageable(prim)
        return prim

    def mesh(self, stage: Usd.Stage, path: Sdf.Path) -> Usd.Prim:
        """A mesh of 1 to 3 convex planar faces; its points animated by affine maps of the same polygons."""
        rng = self.rng
        mesh = UsdGeom.Mesh.Define(stage, path)
        counts, base = self.polygons()
        if rng.random() < 0.12:
            return self.changing_mesh(mesh)
        mesh.CreateFaceVertexCountsAttr(counts)
        mesh.CreateFaceVertexIndicesAttr(list(range(len(base))))
        if rng.random() < 0.1:
            mesh.CreateHoleIndicesAttr([int(rng.integers(0, len(counts)))])

        def points():
            a = np.eye(3) + rng.uniform(-0.3, 0.3, (3, 3))
            return Vt.Vec3fArray.FromNumpy((base @ a.T + rng.uniform(-1, 1, 3)).astype(np.float32))

        times = self.animate(mesh.CreatePointsAttr(), points)

        def rates():
            b = rng.uniform(-0.5, 0.5, (3, 3))
            return Vt.Vec3fArray.FromNumpy((base @ b.T + rng.uniform(-1, 1, 3)).astype(np.float32))

        self.rates([mesh.CreateVelocitiesAttr(), mesh.CreateAccelerationsAttr()], times, rates)
        self.ops(mesh.GetPrim())
        return mesh.GetPrim()

    def polygons(self) -> tuple[list, np.ndarray]:
        """``(face vertex counts, (N, 3) points)`` of 1 to 3 random convex planar polygons, each its own points."""
        rng = self.rng
        counts, polygons = [], []
        for _ in range(int(rng.integers(1, 4))):
            n = int(rng.integers(3, 6))
            u, v = np.linalg.qr(rng.normal(size=(3, 2)))[0].T
            angles = np.sort(rng.uniform(0, 2 * np.pi, n))
            rim = np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v
            polygons.append(rng.uniform(-3, 3, 3) + rng.uniform(0.3, 1.0) * rim)
            counts.append(n)
        return counts, np.concatenate(polygons)

    def changing_mesh(self, mesh: UsdGeom.Mesh) -> Usd.Prim:
        """A mesh whose topology changes from sample to sample (each sample a different number of points, so USD
        holds them rather than interpolating), maybe with a default topology too."""
        rng = self.rng
        attrs = (mesh.CreateFaceVertexCountsAttr(), mesh.CreateFaceVertexIndicesAttr(), mesh.CreatePointsAttr())
        times = [float(t) for t in rng.choice(SAMPLE_TIMES, int(rng.integers(2, 4)), replace=False)]
        sizes = set()
        default = self.defaults == "always" or (self.defaults == "mixed" and rng.random() < 0.3)
        for t in times + ([Usd.TimeCode.Default()] if default else []):
            counts, points = self.polygons()
            while len(points) in sizes:
                counts, points = self.polygons()
            sizes.add(len(points))
            values = (counts, list(range(len(points))), Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
            for attr, value in zip(attrs, values):
                attr.Set(value, t if isinstance(t, Usd.TimeCode) else Usd.TimeCode(t))
        self.ops(mesh.GetPrim())
        return mesh.GetPrim()

    def instancer(self, stage: Usd.Stage, path: Sdf.Path) -> Usd.Prim:
        rng = self.rng
        pi = UsdGeom.PointInstancer.Define(stage, path)
        self.ops(pi.GetPrim())
        # The prototypes: under the instancer, or beside it under an ``over`` (not drawn in place, as it is not
        # defined) or a scope drawn in place too. Not beside an asset's root: a reference brings only the root's tree.
        library = path.AppendChild("Prototypes")
        beside = path.GetParentPath() != Sdf.Path.absoluteRootPath and rng.random() < 0.3
        over = beside and rng.random() < 0.6
        if over:
            library = path.GetParentPath().AppendChild(f"{path.name}_library")
        else:
            if beside:
                library = path.GetParentPath().AppendChild(f"{path.name}_library")
            scope = UsdGeom.Xform.Define(stage, library)
            if rng.random() < 0.6:
                scope.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
        targets, resets = [], self.resets
        self.resets = False
        for i in range(int(rng.integers(1, 4))):
            proto = library.AppendChild(f"P{i}")
            if self.assets and rng.random() < 0.3:
                prim = self.reference(stage, proto)
            elif rng.random() < 0.5:
                prim = self.mesh(stage, proto)
            else:
                prim = UsdGeom.Xform.Define(stage, proto).GetPrim()
                self.ops(prim)
                for j in range(int(rng.integers(1, 3))):
                    self.mesh(stage, proto.AppendChild(f"M{j}"))
            if rng.random() < 0.2:
                self.visibility(UsdGeom.Imageable(prim))
            targets.append(prim.GetPath())
        if over:  # after its prototypes: defining them defined it
            stage.GetPrimAtPath(library).SetSpecifier(Sdf.SpecifierOver)
        self.resets = resets
        pi.CreatePrototypesRel().SetTargets(targets)
        n = int(rng.integers(1, 7))
        self.animate(pi.CreateProtoIndicesAttr(), lambda: Vt.IntArray(rng.integers(0, len(targets), n).tolist()))
        times = self.animate(pi.CreatePositionsAttr(), lambda: Vt.Vec3fArray.FromNumpy(
            rng.uniform(-4, 4, (n, 3)).astype(np.float32)))
        self.rates([pi.CreateVelocitiesAttr(), pi.CreateAccelerationsAttr()], times,
                   lambda: Vt.Vec3fArray.FromNumpy(rng.uniform(-2, 2, (n, 3)).astype(np.float32)))
        if rng.random() < 0.7:
            half = rng.random() < 0.3
            attr = pi.CreateOrientationsAttr() if half else pi.CreateOrientationsfAttr()
            array = Vt.QuathArray if half else Vt.QuatfArray

            def orientations():
                q = rng.normal(size=(n, 4))
                q /= np.linalg.norm(q, axis=1, keepdims=True)
                quats = [Gf.Quatf(float(w), Gf.Vec3f(*map(float, xyz))) for *xyz, w in q]
                return array([Gf.Quath(x) for x in quats] if half else quats)

            times = self.animate(attr, orientations)
            self.rates([pi.CreateAngularVelocitiesAttr()], times,
                       lambda: Vt.Vec3fArray.FromNumpy(rng.uniform(-90, 90, (n, 3)).astype(np.float32)))
        if rng.random() < 0.5:
            self.animate(pi.CreateScalesAttr(), lambda: Vt.Vec3fArray.FromNumpy(rng.uniform(0.3, 2, (n, 3)).astype(
                np.float32)))
        if rng.random() < 0.4:
            pi.CreateIdsAttr(Vt.Int64Array(rng.permutation(100)[:n].tolist()))
        ids = list(pi.GetIdsAttr().Get() or range(n))
        if rng.random() < 0.4:
            self.animate(pi.CreateInvisibleIdsAttr(),
                         lambda: Vt.Int64Array([int(i) for i in ids if rng.random() < 0.3]))
        if rng.random() < 0.3:
            pi.DeactivateIds([int(i) for i in ids if rng.random() < 0.3])
        return pi.GetPrim()

    # Attributes ------------------------------------------------------------------------------------------------

    def ops(self, prim: Usd.Prim):
        """0 to 4 random transform ops, each a default value, time samples, or both."""
        rng = self.rng
        xformable = UsdGeom.Xformable(prim)
        for k in range(int(rng.integers(0, 5))):
            kind = str(rng.choice(["translate", "rotateX", "rotateY", "rotateZ", "rotateXYZ", "rotateZYX", "scale",
                                   "orient", "transform"]))
            suffix = f"op{k}"
            if kind == "translate":
                op, value = xformable.AddTranslateOp(opSuffix=suffix), lambda: Gf.Vec3d(*rng.uniform(-3, 3, 3))
            elif kind in ("rotateX", "rotateY", "rotateZ"):
                op = getattr(xformable, f"Add{kind[0].upper()}{kind[1:]}Op")(opSuffix=suffix)
                value = lambda: float(rng.uniform(-180, 180))  # noqa: E731
            elif kind in ("rotateXYZ", "rotateZYX"):
                op = getattr(xformable, f"Add{kind[0].upper()}{kind[1:]}Op")(opSuffix=suffix)
                value = lambda: Gf.Vec3f(*rng.uniform(-180, 180, 3))  # noqa: E731
            elif kind == "scale":
                op, value = xformable.AddScaleOp(opSuffix=suffix), lambda: Gf.Vec3f(*rng.uniform(0.4, 2.0, 3))
            elif kind == "orient":
                op = xformable.AddOrientOp(opSuffix=suffix)
                value = lambda: Gf.Quatf(*map(float, _unit_quat(rng)))  # noqa: E731
            else:
                op = xformable.AddTransformOp(opSuffix=suffix)
                value = lambda: _affine(rng)  # noqa: E731
            self.animate(op.GetAttr(), value)
            if rng.random() < 0.1:  # the same op again, inverted: "!invert!xformOp:..." in the op order
                xformable.AddXformOp(op.GetOpType(), op.GetPrecision(), suffix, isInverseOp=True)
        if self.resets and rng.random() < 0.08:
            xformable.SetResetXformStack(True)

    def animate(self, attr: Usd.Attribute, value, default: bool | None = None):
        """Authors ``value()`` on ``attr`` as a default, at 1 to 3 time samples, or both."""
        rng = self.rng
        how = rng.random()
        if default is None:
            default = how < 0.45 or how > 0.85
        if self.defaults != "mixed":
            default = how < 0.45 or self.defaults == "always"
        if default:
            attr.Set(value())
        times = []
        if how >= 0.45:
            times = [float(t) for t in rng.choice(SAMPLE_TIMES, int(rng.integers(1, 4)), replace=False)]
            for t in times:
                attr.Set(value(), Usd.TimeCode(t))
        return times

    def rates(self, attrs: list, times: list, value):
        """Authors ``value()`` on each of ``attrs`` (velocities, then accelerations, each with a chance) at the
        sample ``times`` of the attribute they move, most often all of them (USD uses them only then)."""
        rng = self.rng
        if not times or rng.random() < 0.5 or self.defaults == "never":
            return
        every = rng.random() < 0.8
        for attr in attrs:
            for t in times:
                if every or rng.random() < 0.5:
                    attr.Set(value(), Usd.TimeCode(t))
            if rng.random() < 0.5:
                break


def _unit_quat(rng) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def _affine(rng) -> Gf.Matrix4d:
    """A row-vector affine matrix: a rotation times an uneven scale, then a translation."""
    r = Gf.Matrix4d().SetRotate(Gf.Quatd(*map(float, _unit_quat(rng))))
    s = Gf.Matrix4d().SetScale(Gf.Vec3d(*rng.uniform(0.5, 1.8, 3)))
    return s * r * Gf.Matrix4d().SetTranslate(Gf.Vec3d(*rng.uniform(-3, 3, 3)))


def write_stage(folder: str, seed: int, defaults: str = "mixed") -> str:
    """Writes stage ``seed`` into ``folder`` (``defaults``: see :class:`StageWriter`); returns the root layer's
    path."""
    return StageWriter(folder, np.random.default_rng(seed), defaults).write()


# Oracle ------------------------------------------------------------------------------------------------------------


def usd_triangles(stage: Usd.Stage, time) -> tuple[np.ndarray, int]:
    """``((T, 3, 3) float64 world-space triangles the stage shows at ``time``, meshes drawn)`` by USD's own API;
    ``time`` a number or a ``Usd.TimeCode``."""
    tc = time if isinstance(time, Usd.TimeCode) else Usd.TimeCode(time)
    found = []
    _walk(stage.GetPseudoRoot(), tc, UsdGeom.XformCache(tc), None, np.eye(4), None, found)
    return (np.concatenate(found) if found else np.zeros((0, 3, 3))), len(found)


def _walk(root: Usd.Prim, tc: Usd.TimeCode, xforms: UsdGeom.XformCache, space: Usd.Prim | None, base: np.ndarray,
          stop: Usd.Prim | None, found: list, predicate=Usd.PrimDefaultPredicate, instancer_purpose: str | None = None):
    """Appends the fan triangles of the meshes drawn in ``root``'s subtree to ``found``. A prim is placed by its
    transform relative to ``space`` (its world transform when None) then row-vector ``base``; it is visible when
    nothing from it up to ``stop`` (included) is invisible, or, without a stop, by ``ComputeVisibility``; it is drawn
    by its purpose (:func:`_purpose`; ``instancer_purpose``: the purpose of the PointInstancer whose prototype
    ``root`` is in, if any).

    Inside an instance (native or a PointInstancer's) a resetXformStack resets to the instance's space, as Hydra
    draws instances; USD's own instance-proxy transforms reset to the world.
    """
    it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(predicate)))
    for prim in it:
        if prim.IsPseudoRoot():
            continue
        img = UsdGeom.Imageable(prim)
        hidden = (img.ComputeVisibility(tc) == UsdGeom.Tokens.invisible if stop is None
                  else not _shown_below(prim, stop, tc))
        if hidden:
            it.PruneChildren()
            continue
        to_world = (np.array(xforms.GetLocalToWorldTransform(prim)) if space is None
                    else np.array(xforms.ComputeRelativeTransform(prim, space)[0])) @ base
        purpose = _purpose(img, instancer_purpose)
        if prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()
            # Walked whatever its purpose: a guide instancer's prototype prims that author a drawn purpose are drawn.
            _instanced(prim, tc, xforms, to_world, found, purpose)
            continue
        if prim.IsA(UsdGeom.Mesh) and purpose in DRAWN_PURPOSES:
            found.append(_fan(prim, tc, to_world))
        if prim.IsInstance() and prim != root:
            it.PruneChildren()
            for child in prim.GetFilteredChildren(Usd.TraverseInstanceProxies(predicate)):
                _walk(child, tc, xforms, prim, to_world, stop, found, predicate, instancer_purpose)


def _purpose(img: UsdGeom.Imageable, instancer_purpose: str | None) -> str:
    """``ComputePurpose``; inside a PointInstancer's prototype, where neither the prim nor an ancestor authors a
    purpose (``ComputePurposeInfo`` not inheritable), the instancer's, as UsdImaging's instancer adapter hands it down
    (``instanceInheritablePurpose``): a guide instancer draws the prototype prims that author render or default."""
    if instancer_purpose is None:
        return img.ComputePurpose()
    info = img.ComputePurposeInfo()
    return info.purpose if info.isInheritable else instancer_purpose


def _instanced(prim: Usd.Prim, tc: Usd.TimeCode, xforms: UsdGeom.XformCache, to_world: np.ndarray, found: list,
               purpose: str):
    """The triangles of PointInstancer ``prim``'s instances, the instancer placed by ``to_world``, of purpose
    ``purpose``."""
    pi = UsdGeom.PointInstancer(prim)
    # The prototype root's own transform is applied here rather than by IncludeProtoXform: that picks each
    # instance's prototype from protoIndices at its time sample at or before tc, read back at that time, which under a
    # layer offset can land just before the sample (the inverse offset does not round-trip: 3.5 -> 0.99999 for
    # offset 2, scale 1.5) and give the previous sample's prototypes, where protoIndices.Get(tc) gives this one's.
    transforms = pi.ComputeInstanceTransformsAtTime(tc, tc, UsdGeom.PointInstancer.ExcludeProtoXform,
                                                    UsdGeom.PointInstancer.IgnoreMask)
    indices = pi.GetProtoIndicesAttr().Get(tc) or []
    mask = pi.ComputeMaskAtTime(tc) or [True] * len(indices)
    stage = prim.GetStage()
    protos = [stage.GetPrimAtPath(p) for p in pi.GetPrototypesRel().GetTargets()]
    for index, m, keep in zip(indices, transforms, mask):
        proto = protos[index]
        if keep and proto and proto.IsActive():
            own = np.array(xforms.GetLocalTransformation(proto)[0])
            _walk(proto, tc, xforms, proto, own @ np.array(m) @ to_world, proto, found, PROTOTYPE_PREDICATE, purpose)


def _shown_below(prim: Usd.Prim, root: Usd.Prim, tc: Usd.TimeCode) -> bool:
    """No prim from ``prim`` up to ``root`` (itself included) is invisible at ``tc``."""
    p = prim
    while True:
        if UsdGeom.Imageable(p).GetVisibilityAttr().Get(tc) == UsdGeom.Tokens.invisible:
            return False
        if p == root:
            return True
        p = p.GetParent()


def _fan(prim: Usd.Prim, tc: Usd.TimeCode, to_world: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` fan triangles of a mesh's faces at ``tc``, moved by row-vector ``to_world``."""
    mesh = UsdGeom.Mesh(prim)
    # Moved by velocities where authored. Without, Get: ComputePointsAtTime reads the points at their sample at or
    # before tc first, and keeps them where Get(tc) has another length; read back at that time under a layer offset
    # they can be the previous sample's (see _instanced), and then stay, while the topology read at tc is newer.
    moved = mesh.GetVelocitiesAttr().HasAuthoredValue()
    points = mesh.ComputePointsAtTime(tc, tc) if moved else mesh.GetPointsAttr().Get(tc)
    points = np.array(points, np.float64).reshape(-1, 3)
    points = points @ to_world[:3, :3] + to_world[3, :3]
    counts = np.array(mesh.GetFaceVertexCountsAttr().Get(tc), int)
    indices = np.array(mesh.GetFaceVertexIndicesAttr().Get(tc), int)
    holes = set(mesh.GetHoleIndicesAttr().Get(tc) or [])
    rows, start = [], 0
    for f, n in enumerate(counts):
        face = indices[start:start + n]
        if f not in holes:
            rows += [(face[0], face[k], face[k + 1]) for k in range(1, n - 1)]
        start += n
    return points[np.array(rows, int).reshape(-1, 3)]


def unmatched(a: np.ndarray, b: np.ndarray, tol: float) -> tuple[list, list]:
    """Triangles of ``a`` and of ``b`` (``(T, 3, 3)``) left over when the two are matched as multisets, each
    triangle to one within ``tol`` (per coordinate, relative to 1 + the triangle's largest ``|x|``) with its corners in
    any order."""
    if len(b) == 0:
        return list(range(len(a))), []
    orders = [b[:, list(p)] for p in ((0, 1, 2), (1, 2, 0), (2, 0, 1), (0, 2, 1), (2, 1, 0), (1, 0, 2))]
    free = np.ones(len(b), bool)
    left_a = []
    for i, t in enumerate(a):
        err = np.full(len(b), np.inf)
        for ordered in orders:
            err = np.minimum(err, np.abs(ordered - t).reshape(len(b), -1).max(axis=1) / (1 + np.abs(t).max()))
        err[~free] = np.inf
        j = int(np.argmin(err))
        if err[j] <= tol:
            free[j] = False
        else:
            left_a.append(i)
    return left_a, np.flatnonzero(free).tolist()
