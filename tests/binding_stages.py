"""Random stages of material bindings and colour primvars, for :mod:`binding_oracle`.

:func:`write_stage` writes one stage per seed: groups of meshes (quads, sometimes a triangle) under nested Xforms
with direct bindings of every purpose (all, ``full``, ``preview``) and strength, collection bindings (includes,
excludes, every ``expansionRule``, collections that include collections), ``materialBind`` GeomSubsets (partition or
not), bindings to prims that are no Material and to prims that do not exist, bindings and colours inherited from a
class, materials from a referenced file, native instances (bindings on the prototype, on the instance, above it;
nested instances) and a PointInstancer whose prototypes bind; ``displayColor``, ``displayOpacity`` and ``tint`` (the
primvar one material reads) on meshes and ancestors, of every interpolation, indexed or not, blocked on some prims.
"""

from __future__ import annotations

import os
import random

from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

PREVIEW = ["M0", "M1", "M2", "M3"]  # UsdPreviewSurface materials of constant diffuseColor, under /Looks
TINT = "Tint"  # a UsdPreviewSurface whose diffuseColor reads primvar ``tint`` (fallback TINT_FALLBACK)
TINT_FALLBACK = (0.1, 0.2, 0.3)
MDL = "Mdl"  # an MDL look wrt cannot read (its full binding yields to a preview one)
EXTERNAL = "/ExtLooks/Ext"  # a UsdPreviewSurface in a referenced file
NOT_MATERIAL = "/Looks/NotAMaterial"  # an Xform
MISSING = "/Looks/Missing"  # no prim
PURPOSES = ["", "", "full", "preview"]  # "" is the all-purpose binding
STRENGTHS = [UsdShade.Tokens.weakerThanDescendants, UsdShade.Tokens.weakerThanDescendants,
             UsdShade.Tokens.strongerThanDescendants]
EXPANSIONS = ["expandPrims", "explicitOnly", "expandPrimsAndProperties"]
COLOR_NAMES = ["displayColor", "tint"]


def write_stage(directory: str, seed: int) -> str:
    """Writes the stage of ``seed`` (and the file of materials it references) into ``directory``; returns its
    path."""
    rng = random.Random(seed)
    ext_path = os.path.join(directory, f"looks_{seed}.usda")
    ext = Usd.Stage.CreateNew(ext_path)
    preview_material(ext, "/Looks/Ext", (0.9, 0.9, 0.1))
    ext.GetRootLayer().Save()

    path = os.path.join(directory, f"bind_{seed}.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.DefinePrim("/Looks", "Scope")
    for k, name in enumerate(PREVIEW):
        preview_material(stage, f"/Looks/{name}", (0.2 * k + 0.1, 0.5, 0.9 - 0.2 * k))
    tint_material(stage, f"/Looks/{TINT}", TINT_FALLBACK)
    _mdl_material(stage, f"/Looks/{MDL}")
    UsdGeom.Xform.Define(stage, NOT_MATERIAL)
    stage.DefinePrim("/ExtLooks").GetReferences().AddReference(os.path.basename(ext_path), "/Looks")

    gen = _Generator(stage, rng)
    world = UsdGeom.Xform.Define(stage, "/World").GetPrim()
    stage.SetDefaultPrim(world)
    gen.class_prim()
    gen.prototypes()
    gen.group(world, depth=0)
    if rng.random() < 0.7:
        gen.point_instancer(world)
    gen.decorate_all()
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)  # (defining prims in it made it a def)
    stage.GetRootLayer().Save()
    return path


def preview_material(stage, path: str, color) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + "/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def tint_material(stage, path: str, fallback=None) -> UsdShade.Material:
    """A UsdPreviewSurface whose diffuseColor reads primvar ``tint`` (``fallback`` where a mesh has none; none
    authored: 0)."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + "/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    reader = UsdShade.Shader.Define(stage, path + "/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float3")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("tint")
    if fallback is not None:
        reader.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(*fallback))
    reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(reader.ConnectableAPI(), "result")
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def _mdl_material(stage, path: str) -> None:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + "/Shader")
    shader.SetSourceAsset(Sdf.AssetPath("OmniPBR.mdl"), "mdl")
    shader.SetSourceAssetSubIdentifier("OmniPBR", "mdl")
    material.CreateSurfaceOutput("mdl").ConnectToSource(shader.ConnectableAPI(), "out")


class _Generator:
    def __init__(self, stage: Usd.Stage, rng: random.Random):
        self.stage = stage
        self.rng = rng
        self.count = 0
        self.prims: list[Usd.Prim] = []  # everything made (groups, meshes, instances), decorated at the end
        self.meshes: list[Usd.Prim] = []
        self.protos: list[str] = []  # prototype roots (under the /Protos over)
        self.x = 0.0

    def name(self, stem: str) -> str:
        self.count += 1
        return f"{stem}{self.count}"

    # Hierarchy

    def group(self, parent: Usd.Prim, depth: int, in_proto: bool = False) -> None:
        rng = self.rng
        for _ in range(rng.randint(1, 3)):
            roll = rng.random()
            if roll < 0.08:
                self.gprim(parent)
            elif roll < 0.45 or depth >= 3:
                self.mesh(parent)
            elif roll < 0.75:
                g = UsdGeom.Xform.Define(self.stage, parent.GetPath().AppendChild(self.name("G"))).GetPrim()
                self.prims.append(g)
                if not in_proto and rng.random() < 0.25:
                    g.GetInherits().AddInherit("/_Base")
                self.group(g, depth + 1, in_proto)
            elif self.protos and (not in_proto or len(self.protos) > 1):
                self.instance(parent, in_proto)
            else:
                self.mesh(parent)

    def mesh(self, parent: Usd.Prim) -> Usd.Prim:
        rng = self.rng
        n_quads = rng.randint(1, 4)
        triangle = rng.random() < 0.3
        points, counts, indices = [], [], []
        for i in range(n_quads + 1):
            points += [(i, 0, 0), (i, 1, 0)]
        for i in range(n_quads):
            counts.append(4)
            indices += [2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1]
        if triangle:
            points.append((n_quads + 0.5, 0.5, 0))
            counts.append(3)
            indices += [2 * n_quads, len(points) - 1, 2 * n_quads + 1]
        mesh = UsdGeom.Mesh.Define(self.stage, parent.GetPath().AppendChild(self.name("Mesh")))
        mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
        mesh.CreateFaceVertexCountsAttr(counts)
        mesh.CreateFaceVertexIndicesAttr(indices)
        mesh.CreateSubdivisionSchemeAttr("none")
        mesh.AddTranslateOp().Set(Gf.Vec3d(self.x, 0, 0))
        self.x += 1.0
        prim = mesh.GetPrim()
        self.prims.append(prim)
        self.meshes.append(prim)
        return prim

    def gprim(self, parent: Usd.Prim) -> Usd.Prim:
        """A unit Cube or Sphere (drawn as an analytic shape: its own binding, one colour)."""
        kind = self.rng.choice([UsdGeom.Cube, UsdGeom.Sphere])
        gprim = kind.Define(self.stage, parent.GetPath().AppendChild(self.name(kind.__name__)))
        gprim.AddTranslateOp().Set(Gf.Vec3d(self.x, 0, 0))
        self.x += 1.0
        self.prims.append(gprim.GetPrim())
        return gprim.GetPrim()

    def class_prim(self) -> None:
        """``/_Base``: a class whose binding and colour the prims inheriting it get."""
        base = self.stage.CreateClassPrim("/_Base")
        rng = self.rng
        if rng.random() < 0.7:
            self.bind(base, self.material_target())
        if rng.random() < 0.5:
            self.constant_primvar(base, rng.choice(COLOR_NAMES + ["displayOpacity"]))

    def prototypes(self) -> None:
        """Prototype roots under the ``over`` ``/Protos`` (not drawn in place), instanced by reference."""
        self.stage.OverridePrim("/Protos")
        for k in range(self.rng.randint(0, 2)):
            root = UsdGeom.Xform.Define(self.stage, f"/Protos/P{k}").GetPrim()
            self.group(root, depth=2, in_proto=True)
            self.prims.append(root)
            self.protos.append(str(root.GetPath()))

    def instance(self, parent: Usd.Prim, in_proto: bool) -> None:
        choices = self.protos if not in_proto else self.protos[:-1]  # nested: only earlier prototypes, no cycle
        target = self.rng.choice(choices)
        prim = UsdGeom.Xform.Define(self.stage, parent.GetPath().AppendChild(self.name("Inst"))).GetPrim()
        prim.GetReferences().AddInternalReference(target)
        prim.SetInstanceable(True)
        self.prims.append(prim)

    def point_instancer(self, parent: Usd.Prim) -> None:
        pi = UsdGeom.PointInstancer.Define(self.stage, parent.GetPath().AppendChild(self.name("PI")))
        protos = UsdGeom.Scope.Define(self.stage, pi.GetPath().AppendChild("Protos")).GetPrim()
        targets = []
        for _ in range(self.rng.randint(1, 2)):
            root = UsdGeom.Xform.Define(self.stage, protos.GetPath().AppendChild(self.name("Proto"))).GetPrim()
            self.group(root, depth=2)
            self.prims.append(root)
            targets.append(root.GetPath())
        self.prims += [pi.GetPrim(), protos]
        pi.CreatePrototypesRel().SetTargets(targets)
        n = self.rng.randint(1, 4)
        pi.CreateProtoIndicesAttr([self.rng.randrange(len(targets)) for _ in range(n)])
        pi.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(3.0 * i, 5.0, 0.0) for i in range(n)]))

    # Bindings and primvars

    def material_target(self) -> str:
        roll = self.rng.random()
        if roll < 0.06:
            return NOT_MATERIAL
        if roll < 0.12:
            return MISSING
        if roll < 0.2:
            return EXTERNAL
        if roll < 0.32:
            return f"/Looks/{TINT}"
        if roll < 0.42:
            return f"/Looks/{MDL}"
        return "/Looks/" + self.rng.choice(PREVIEW)

    def bind(self, prim: Usd.Prim, target: str, purpose: str | None = None) -> None:
        rng = self.rng
        purpose = rng.choice(PURPOSES) if purpose is None else purpose
        UsdShade.MaterialBindingAPI.Apply(prim)
        name = "material:binding" + (":" + purpose if purpose else "")
        rel = prim.CreateRelationship(name, custom=False)
        rel.SetTargets([Sdf.Path(target)])
        if rng.random() < 0.4:
            UsdShade.MaterialBindingAPI.SetMaterialBindingStrength(rel, rng.choice(STRENGTHS))

    def collection_bind(self, prim: Usd.Prim) -> None:
        """A collection on ``prim`` of some of its descendants (or the prim), bound to a material."""
        rng = self.rng
        below = [p for p in Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate))]
        name = self.name("c")
        coll = Usd.CollectionAPI.Apply(prim, name)
        coll.CreateExpansionRuleAttr(rng.choice(EXPANSIONS))
        includes = rng.sample(below, min(len(below), rng.randint(1, 3)))
        for p in includes:
            coll.GetIncludesRel().AddTarget(p.GetPath())
        if rng.random() < 0.4:
            for p in rng.sample(below, min(len(below), rng.randint(1, 2))):
                coll.GetExcludesRel().AddTarget(p.GetPath())
        others = [c for c in Usd.CollectionAPI.GetAllCollections(prim) if c.GetName() != name]
        if others and rng.random() < 0.4:  # a collection that includes another collection
            coll.GetIncludesRel().AddTarget(rng.choice(others).GetCollectionPath())
        if rng.random() < 0.2:
            coll.CreateIncludeRootAttr(True)
        target = self.material_target()
        api = UsdShade.MaterialBindingAPI.Apply(prim)
        purpose = rng.choice(PURPOSES)
        rel = api.GetCollectionBindingRel(name, purpose)
        if not rel:  # (an unauthored one: USD's name for it, material:binding:collection[:purpose]:name)
            rel_name = "material:binding:collection:" + (purpose + ":" if purpose else "") + name
            rel = prim.CreateRelationship(rel_name, custom=False)
        rel.SetTargets([coll.GetCollectionPath(), Sdf.Path(target)])
        if rng.random() < 0.4:
            UsdShade.MaterialBindingAPI.SetMaterialBindingStrength(rel, rng.choice(STRENGTHS))

    def subsets(self, mesh: Usd.Prim) -> None:
        rng = self.rng
        n_faces = len(UsdGeom.Mesh(mesh).GetFaceVertexCountsAttr().Get())
        faces = list(range(n_faces))
        rng.shuffle(faces)
        family = rng.choice([UsdGeom.Tokens.partition, UsdGeom.Tokens.nonOverlapping, UsdGeom.Tokens.unrestricted])
        api = UsdShade.MaterialBindingAPI.Apply(mesh)
        k = 0
        while faces:
            take = faces[:rng.randint(1, len(faces))]
            if family == UsdGeom.Tokens.partition or rng.random() < 0.7:
                faces = faces[len(take):]
            k += 1
            subset = api.CreateMaterialBindSubset(f"sub{k}", Vt.IntArray(sorted(take)), UsdGeom.Tokens.face)
            if rng.random() < 0.8:
                self.bind(subset.GetPrim(), self.material_target())
            if k >= 3:
                break
        if family != UsdGeom.Tokens.unrestricted:  # (materialBind refuses it: unrestricted is left unauthored)
            api.SetMaterialBindSubsetsFamilyType(family)

    def constant_primvar(self, prim: Usd.Prim, name: str) -> None:
        api = UsdGeom.PrimvarsAPI(prim)
        rng = self.rng
        if name == "displayOpacity":
            pv = api.CreatePrimvar(name, Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.constant)
            pv.Set([round(rng.uniform(0.1, 1.0), 3)])
        else:
            pv = api.CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant)
            pv.Set([Gf.Vec3f(*(round(rng.random(), 3) for _ in range(3)))])

    def mesh_primvar(self, mesh: Usd.Prim, name: str) -> None:
        rng = self.rng
        m = UsdGeom.Mesh(mesh)
        interpolation = rng.choice(["constant", "uniform", "vertex", "varying", "faceVarying"])
        n = {"constant": 1, "uniform": len(m.GetFaceVertexCountsAttr().Get()),
             "vertex": len(m.GetPointsAttr().Get()), "varying": len(m.GetPointsAttr().Get()),
             "faceVarying": len(m.GetFaceVertexIndicesAttr().Get())}[interpolation]
        opacity = name == "displayOpacity"
        type_name = Sdf.ValueTypeNames.FloatArray if opacity else Sdf.ValueTypeNames.Color3fArray
        pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(name, type_name, interpolation)
        indexed = rng.random() < 0.4
        n_values = rng.randint(1, 3) if indexed else n

        def value():
            return round(rng.uniform(0.1, 1.0), 3) if opacity else Gf.Vec3f(*(round(rng.random(), 3) for _ in range(3)))

        pv.Set([value() for _ in range(n_values)])
        if indexed:
            pv.SetIndices(Vt.IntArray([rng.randrange(n_values) for _ in range(n)]))

    def decorate_all(self) -> None:
        """Bindings and primvars on random prims made, after the hierarchy is complete (collections see it all)."""
        rng = self.rng
        for prim in self.prims:
            if not prim.IsValid():
                continue
            is_mesh = prim.IsA(UsdGeom.Mesh)
            if rng.random() < 0.35:
                self.bind(prim, self.material_target())
            if rng.random() < 0.15:  # a second binding of another purpose
                self.bind(prim, self.material_target(), rng.choice(["full", "preview"]))
            if not is_mesh and rng.random() < 0.3:
                self.collection_bind(prim)
            if is_mesh and rng.random() < 0.3:
                self.subsets(prim)
            for name in COLOR_NAMES + ["displayOpacity"]:
                roll = rng.random()
                if roll < 0.25:
                    if is_mesh:
                        self.mesh_primvar(prim, name)
                    elif prim.IsA(UsdGeom.Gprim):
                        self.constant_primvar(prim, name)
                    else:
                        self.constant_primvar(prim, name)
                elif roll < 0.3:  # blocked here: USD's inheritance looks past it
                    type_name = Sdf.ValueTypeNames.FloatArray if name == "displayOpacity" else \
                        Sdf.ValueTypeNames.Color3fArray
                    UsdGeom.PrimvarsAPI(prim).CreatePrimvar(name, type_name, UsdGeom.Tokens.constant).GetAttr().Block()
                elif roll < 0.33 and not is_mesh and not prim.IsA(UsdGeom.PointInstancer):
                    # A non-constant primvar on a group: it blocks inheritance, an instancer's constant primvar too.
                    # (Not on the instancer itself: Hydra would make it an instance primvar.)
                    pv = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray
                                                                 if name != "displayOpacity"
                                                                 else Sdf.ValueTypeNames.FloatArray,
                                                                 UsdGeom.Tokens.uniform)
                    pv.Set([Gf.Vec3f(1, 0, 1)] if name != "displayOpacity" else [0.5])
