"""Seeded random USD stages for the bounds oracle (:mod:`bounds_oracle`): what a loader must place and pick right.

:func:`write_stage` writes a root layer and a few asset layers into a folder. It mixes nested xforms with every op
kind (translate, rotations in all six orders, orient, scale with negative and zero components, a whole matrix), pivots
and other inverse ops, ``resetXformStack``, ops animated between time codes 0 and 10, native instances (instanceable
references to assets, nested), PointInstancers (orientations as ``quath`` or ``quatf``, scales, ``invisibleIds``,
prototypes with their own transforms, nested instancers and instances inside prototypes), references, payloads,
inherits and specializes, variant sets, ``over`` and ``class`` prims holding defined ones, inactive prims, purposes
and visibility, all six gprims with every axis, and meshes (left-handed or not). Asset layers author other
``metersPerUnit`` and ``upAxis`` than the root. Meshes use all of their points and author no extent, so USD's
computed extent is the box of what must be drawn.
"""

from __future__ import annotations

import os

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

TIME = 3.5  # the time code the stage is read at (animated ops have samples at 0 and 10)
AXES = ("X", "Y", "Z")
GPRIMS = ("Cube", "Sphere", "Cylinder", "Cone", "Capsule", "Plane")
ROTATIONS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


class StageWriter:
    """Writes one random stage from ``seed`` (see the module docstring)."""

    def __init__(self, folder: str, seed: int, max_depth: int = 3):
        self.folder = folder
        self.rng = np.random.default_rng(seed)
        self.max_depth = max_depth
        self.assets: list[str] = []  # asset layer file names, each with default prim /Asset
        self.names = 0
        # No resetXformStack in assets, which may be instanced: inside a native instance USD's instance proxies reset
        # to the world, where Hydra (and wrt) reset to the instance's space.
        self.writing_asset = False
        self.in_prototype = 0  # depth of PointInstancer prototypes being written

    def name(self, stem: str) -> str:
        self.names += 1
        return f"{stem}{self.names}"

    def chance(self, p: float) -> bool:
        return bool(self.rng.random() < p)

    def vector(self, scale: float = 2.0) -> Gf.Vec3d:
        return Gf.Vec3d(*(self.rng.uniform(-scale, scale, 3)))

    # Transforms -------------------------------------------------------------------------------------------------
    def add_ops(self, prim: Usd.Prim, *, allow_reset: bool = True) -> None:
        """A random op stack on ``prim`` (an Xformable)."""
        xf = UsdGeom.Xformable(prim)
        if allow_reset and not self.writing_asset and self.chance(0.12):
            xf.SetResetXformStack(True)
        pivot = self.name("pivot") if self.chance(0.3) else None
        if pivot:
            xf.AddTranslateOp(opSuffix=pivot).Set(self.vector())
        for _ in range(int(self.rng.integers(0, 4))):
            self.add_op(xf)
        if pivot:
            xf.AddTranslateOp(opSuffix=pivot, isInverseOp=True)
        if self.chance(0.15):  # an inverse op of one already in the stack
            # (not a scale, which may be zero: USD's inverse of it is NaN)
            ops = [op for op in xf.GetOrderedXformOps() if not op.IsInverseOp()
                   and op.GetOpType() != UsdGeom.XformOp.TypeScale]
            if ops:
                op = ops[int(self.rng.integers(len(ops)))]
                order = list(xf.GetXformOpOrderAttr().Get() or [])
                order.append("!invert!" + op.GetOpName())
                xf.GetXformOpOrderAttr().Set(order)

    def add_op(self, xf: UsdGeom.Xformable) -> None:
        kind = self.rng.choice(["translate", "rotate", "rotate1", "scale", "orient", "transform"])
        suffix = self.name("o")
        if kind == "translate":
            op = xf.AddTranslateOp(opSuffix=suffix)
            if self.chance(0.4):  # animated
                op.Set(self.vector(), 0.0)
                op.Set(self.vector(), 10.0)
            else:
                op.Set(self.vector())
        elif kind == "rotate":
            order = ROTATIONS[int(self.rng.integers(6))]
            op = getattr(xf, f"AddRotate{order}Op")(opSuffix=suffix)
            if self.chance(0.3):
                op.Set(Gf.Vec3f(*self.rng.uniform(-180, 180, 3)), 0.0)
                op.Set(Gf.Vec3f(*self.rng.uniform(-180, 180, 3)), 10.0)
            else:
                op.Set(Gf.Vec3f(*self.rng.uniform(-180, 180, 3)))
        elif kind == "rotate1":
            axis = AXES[int(self.rng.integers(3))]
            getattr(xf, f"AddRotate{axis}Op")(opSuffix=suffix).Set(float(self.rng.uniform(-180, 180)))
        elif kind == "scale":
            s = self.rng.choice([-2.0, -1.0, -0.5, 0.5, 1.0, 1.5, 3.0], 3)
            # (not inside a PointInstancer's prototype: BBoxCache bounds a nested instancer through the inverse of
            # a flattened prototype's transform, and answers boxes far off what ComputeInstanceTransformsAtTime places)
            if not self.in_prototype and self.chance(0.06):
                s[int(self.rng.integers(3))] = 0.0
            op = xf.AddScaleOp(opSuffix=suffix)
            if self.chance(0.2):
                op.Set(Gf.Vec3f(*s), 0.0)
                op.Set(Gf.Vec3f(*(s * 0.5)), 10.0)
            else:
                op.Set(Gf.Vec3f(*s))
        elif kind == "orient":
            q = self.rng.normal(size=4)
            q /= np.linalg.norm(q)
            xf.AddOrientOp(opSuffix=suffix).Set(Gf.Quatf(*q))
        else:
            m = self.rng.uniform(-1, 1, (3, 3)) + np.eye(3) * 1.5
            full = np.eye(4)
            full[:3, :3] = m
            full[3, :3] = self.rng.uniform(-2, 2, 3)
            xf.AddTransformOp(opSuffix=suffix).Set(Gf.Matrix4d(*full.ravel().tolist()))

    # Leaves -----------------------------------------------------------------------------------------------------
    def mesh(self, stage: Usd.Stage, path: str) -> Usd.Prim:
        """A mesh of random polygons over random points, each point used."""
        mesh = UsdGeom.Mesh.Define(stage, path)
        n = int(self.rng.integers(3, 10))
        points = self.rng.uniform(-1.5, 1.5, (n, 3))
        order = self.rng.permutation(n)
        counts, indices, k = [], [], 0
        while k < n:
            size = min(int(self.rng.integers(3, 6)), n)
            face = [int(order[(k + j) % n]) for j in range(size)]
            counts.append(size)
            indices += face
            k += size
        attr = mesh.CreatePointsAttr()
        if self.chance(0.2):  # animated
            attr.Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]), 0.0)
            attr.Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points[::-1] * 1.5]), 10.0)
        else:
            attr.Set(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
        mesh.CreateFaceVertexCountsAttr(counts)
        mesh.CreateFaceVertexIndicesAttr(indices)
        mesh.CreateSubdivisionSchemeAttr("none")
        if self.chance(0.4):
            mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
        return mesh.GetPrim()

    def gprim(self, stage: Usd.Stage, path: str) -> Usd.Prim:
        kind = GPRIMS[int(self.rng.integers(len(GPRIMS)))]
        prim = stage.DefinePrim(path, kind)
        size = lambda: float(self.rng.choice([0.3, 0.7, 1.0, 1.6]))  # noqa: E731
        if kind == "Cube":
            prim.CreateAttribute("size", Sdf.ValueTypeNames.Double).Set(size() * 2)
        elif kind == "Sphere":
            radius = prim.CreateAttribute("radius", Sdf.ValueTypeNames.Double)
            if self.chance(0.3):  # animated
                radius.Set(size(), 0.0)
                radius.Set(size(), 10.0)
            else:
                radius.Set(size())
        elif kind in ("Cylinder", "Cone", "Capsule"):
            prim.CreateAttribute("radius", Sdf.ValueTypeNames.Double).Set(size())
            prim.CreateAttribute("height", Sdf.ValueTypeNames.Double).Set(size() * 2)
        else:
            prim.CreateAttribute("width", Sdf.ValueTypeNames.Double).Set(size() * 2)
            prim.CreateAttribute("length", Sdf.ValueTypeNames.Double).Set(size() * 2)
        if kind != "Sphere" and kind != "Cube" and self.chance(0.8):
            prim.CreateAttribute("axis", Sdf.ValueTypeNames.Token, variability=Sdf.VariabilityUniform).Set(
                AXES[int(self.rng.integers(3))])
        return prim

    def points_or_curves(self, stage: Usd.Stage, path: str) -> Usd.Prim:
        """A Points prim or a linear or cubic BasisCurves prim, with widths (constant or per vertex)."""
        n = int(self.rng.integers(4, 8))
        points = Vt.Vec3fArray([Gf.Vec3f(*p) for p in self.rng.uniform(-1.5, 1.5, (n, 3))])
        if self.chance(0.5):
            prim = UsdGeom.Points.Define(stage, path)
        else:
            prim = UsdGeom.BasisCurves.Define(stage, path)
            prim.CreateCurveVertexCountsAttr([n])
            prim.CreateTypeAttr(self.rng.choice([UsdGeom.Tokens.linear, UsdGeom.Tokens.cubic]))
            prim.CreateBasisAttr(UsdGeom.Tokens.bspline)
        prim.CreatePointsAttr(points)
        if self.chance(0.5):
            prim.CreateWidthsAttr(Vt.FloatArray([float(w) for w in self.rng.uniform(0.05, 0.4, n)]))
            prim.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
        else:
            prim.CreateWidthsAttr(Vt.FloatArray([0.2]))
            prim.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        return prim.GetPrim()

    def leaf(self, stage: Usd.Stage, path: str) -> Usd.Prim:
        r = self.rng.random()
        prim = (self.mesh(stage, path) if r < 0.45 else self.gprim(stage, path) if r < 0.9
                else self.points_or_curves(stage, path))
        if self.chance(0.6):
            self.add_ops(prim)
        return prim

    # Tree -------------------------------------------------------------------------------------------------------
    def decorate(self, prim: Usd.Prim) -> None:
        """Visibility, purpose and activity on some prims."""
        if not prim.IsA(UsdGeom.Imageable):
            return
        im = UsdGeom.Imageable(prim)
        r = self.rng.random()
        if r < 0.06:
            im.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
        elif r < 0.09:
            attr = im.CreateVisibilityAttr()
            attr.Set(UsdGeom.Tokens.inherited, 0.0)
            attr.Set(UsdGeom.Tokens.invisible, 3.0)
        elif r < 0.13:
            im.CreatePurposeAttr(self.rng.choice([UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy,
                                                  UsdGeom.Tokens.render]))
        elif r < 0.16:
            prim.SetActive(False)

    def node(self, stage: Usd.Stage, parent: str, depth: int, *, in_asset: bool = False) -> None:
        """One random child of ``parent`` and its subtree."""
        path = f"{parent}/{self.name('N')}"
        choices = ["leaf", "leaf", "xform", "xform"]
        if depth < self.max_depth:
            choices += ["instancer", "variant", "over", "class"]
            if self.assets:
                choices += ["instance", "instance", "reference", "payload"]
            if not in_asset:
                choices += ["inherit", "specialize"]
        kind = choices[int(self.rng.integers(len(choices)))]
        if kind == "leaf" or depth >= self.max_depth + 1:
            prim = self.leaf(stage, path)
        elif kind == "xform":
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            self.add_ops(prim)
            for _ in range(int(self.rng.integers(1, 4))):
                self.node(stage, path, depth + 1, in_asset=in_asset)
        elif kind in ("instance", "reference", "payload"):
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            asset = self.assets[int(self.rng.integers(len(self.assets)))]
            offset = Sdf.LayerOffset(float(self.rng.choice([0.0, 0.0, 2.0, -1.5])),
                                     float(self.rng.choice([1.0, 1.0, 0.5, 2.0])))
            if kind == "payload":
                prim.GetPayloads().AddPayload(asset, layerOffset=offset)
            else:
                prim.GetReferences().AddReference(asset, layerOffset=offset)
            prim.SetInstanceable(kind == "instance" or self.chance(0.2))
            self.add_ops(prim)
        elif kind == "instancer":
            prim = self.instancer(stage, path, depth, in_asset)
        elif kind == "variant":
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            self.add_ops(prim)
            sets = prim.GetVariantSets().AddVariantSet("shape")
            for variant in ("a", "b"):
                sets.AddVariant(variant)
                sets.SetVariantSelection(variant)
                with sets.GetVariantEditContext():  # (no root-level classes from inside a variant)
                    self.node(stage, path, depth + 1, in_asset=True)
            sets.SetVariantSelection(self.rng.choice(["a", "b"]))
        elif kind in ("over", "class"):
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            self.node(stage, path, depth + 1, in_asset=in_asset)
            prim.SetSpecifier(Sdf.SpecifierOver if kind == "over" else Sdf.SpecifierClass)
        else:  # inherit / specialize a root-level class or def holding a leaf and an op
            base = f"/{self.name('Base')}"
            if kind == "inherit":
                stage.CreateClassPrim(base)
            else:
                stage.DefinePrim(base, "Xform") if self.chance(0.5) else stage.CreateClassPrim(base)
            self.leaf(stage, f"{base}/{self.name('L')}")
            prim = UsdGeom.Xform.Define(stage, path).GetPrim()
            arcs = prim.GetInherits().AddInherit if kind == "inherit" else prim.GetSpecializes().AddSpecialize
            arcs(base)
            self.add_ops(prim)
        self.decorate(prim)

    def instancer(self, stage: Usd.Stage, path: str, depth: int, in_asset: bool) -> Usd.Prim:
        pi = UsdGeom.PointInstancer.Define(stage, path)
        self.add_ops(pi.GetPrim())
        protos = f"{path}/Protos"
        scope = UsdGeom.Scope.Define(stage, protos)
        if self.chance(0.4):
            scope.CreateVisibilityAttr(UsdGeom.Tokens.invisible)  # hidden in place, drawn through the instancer
        targets = []
        self.in_prototype += 1
        for _ in range(int(self.rng.integers(1, 3))):
            target = f"{protos}/{self.name('P')}"
            r = self.rng.random()
            if r < 0.4:
                self.leaf(stage, target)
            elif r < 0.6 and depth < self.max_depth:
                self.instancer(stage, target, depth + 1, in_asset)
            elif r < 0.75 and self.assets:
                prim = UsdGeom.Xform.Define(stage, target).GetPrim()
                prim.GetReferences().AddReference(self.assets[int(self.rng.integers(len(self.assets)))])
                prim.SetInstanceable(True)
                self.add_ops(prim)
            else:
                UsdGeom.Xform.Define(stage, target)
                self.add_ops(stage.GetPrimAtPath(target))
                for _ in range(int(self.rng.integers(1, 3))):
                    self.node(stage, target, depth + 1, in_asset=in_asset)
            targets.append(target)
        self.in_prototype -= 1
        rel = pi.CreatePrototypesRel()
        for target in targets:
            rel.AddTarget(target)
        n = int(self.rng.integers(1, 6))
        pi.CreateProtoIndicesAttr(Vt.IntArray([int(i) for i in self.rng.integers(0, len(targets), n)]))
        positions = pi.CreatePositionsAttr()
        if self.chance(0.3):
            positions.Set(Vt.Vec3fArray([Gf.Vec3f(*self.rng.uniform(-4, 4, 3)) for _ in range(n)]), 0.0)
            positions.Set(Vt.Vec3fArray([Gf.Vec3f(*self.rng.uniform(-4, 4, 3)) for _ in range(n)]), 10.0)
        else:
            positions.Set(Vt.Vec3fArray([Gf.Vec3f(*self.rng.uniform(-4, 4, 3)) for _ in range(n)]))
        if self.chance(0.6):
            quats = self.rng.normal(size=(n, 4))
            quats /= np.linalg.norm(quats, axis=1, keepdims=True)
            if self.chance(0.5):
                pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(*(float(c) for c in q)) for q in quats]))
            else:
                pi.CreateOrientationsfAttr(Vt.QuatfArray([Gf.Quatf(*(float(c) for c in q)) for q in quats]))
        if self.chance(0.5):
            scales = self.rng.choice([-1.5, -1.0, 0.5, 1.0, 2.0], (n, 3))
            pi.CreateScalesAttr(Vt.Vec3fArray([Gf.Vec3f(*s) for s in scales]))
        ids = list(range(n))
        if self.chance(0.3):
            ids = [int(i) for i in self.rng.permutation(n) * 3 + 7]
            pi.CreateIdsAttr(Vt.Int64Array(ids))
        if self.chance(0.4):
            hidden = [ids[i] for i in np.flatnonzero(self.rng.random(n) < 0.4)]
            attr = pi.CreateInvisibleIdsAttr()
            if self.chance(0.3):  # animated
                attr.Set(Vt.Int64Array(hidden), 0.0)
                attr.Set(Vt.Int64Array(hidden[:1]), 3.0)
            else:
                attr.Set(Vt.Int64Array(hidden))
        if self.chance(0.2):
            pi.DeactivateIds([ids[int(self.rng.integers(n))]])
        if depth == 0 and not in_asset and self.chance(0.1):  # (nested, BBoxCache would still bound it)
            stage.GetPrimAtPath(targets[int(self.rng.integers(len(targets)))]).SetActive(False)
        return pi.GetPrim()

    # Layers -----------------------------------------------------------------------------------------------------
    def write_asset(self, index: int) -> str:
        name = f"asset{index}.usda"
        self.writing_asset = True
        stage = Usd.Stage.CreateNew(os.path.join(self.folder, name))
        UsdGeom.SetStageUpAxis(stage, AXES[1 + int(self.rng.integers(2))])
        UsdGeom.SetStageMetersPerUnit(stage, float(self.rng.choice([0.01, 1.0, 0.0254])))
        if self.chance(0.3):
            stage.SetTimeCodesPerSecond(float(self.rng.choice([12.0, 48.0])))
        if self.chance(0.2):
            root = self.leaf(stage, "/Asset")
        else:
            root = UsdGeom.Xform.Define(stage, "/Asset").GetPrim()
            for _ in range(int(self.rng.integers(1, 4))):
                self.node(stage, "/Asset", 1, in_asset=True)
        stage.SetDefaultPrim(root)
        stage.GetRootLayer().Save()
        self.writing_asset = False
        return "./" + name

    def write(self) -> str:
        for index in range(int(self.rng.integers(1, 4))):
            self.assets.append(self.write_asset(index))
        path = os.path.join(self.folder, "root.usda")
        stage = Usd.Stage.CreateNew(path)
        UsdGeom.SetStageUpAxis(stage, AXES[1 + int(self.rng.integers(2))])
        UsdGeom.SetStageMetersPerUnit(stage, float(self.rng.choice([0.01, 1.0])))
        stage.SetStartTimeCode(0.0)
        stage.SetEndTimeCode(10.0)
        UsdGeom.Xform.Define(stage, "/World")
        for _ in range(int(self.rng.integers(2, 6))):
            self.node(stage, "/World", 0)
        if self.chance(0.3):  # a sublayer holding more of /World
            sub = Usd.Stage.CreateNew(os.path.join(self.folder, "sub.usda"))
            UsdGeom.Xform.Define(sub, "/World")
            self.writing_asset = True
            self.node(sub, "/World", 1, in_asset=True)
            self.writing_asset = False
            sub.GetRootLayer().Save()
            stage.GetRootLayer().subLayerPaths.append("./sub.usda")
        stage.GetRootLayer().Save()
        return path


def write_stage(folder: str, seed: int) -> str:
    """Writes the stage of ``seed`` into ``folder``; returns the root layer's path (read it at :data:`TIME`)."""
    return StageWriter(folder, seed).write()
