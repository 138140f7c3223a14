"""Load time of stages of many small prims: ``wrt.load_usd`` CPU time per mesh, per light and per placed instance.

Writes three stages under a temporary folder (``--keep DIR``: there, kept):

- ``meshes``: ``--meshes`` distinct 4-quad meshes (each its own points and translate, in groups of 100 under rotated
  Xforms; a third with a constant displayColor, half with vertex ``st``, four in five bound to one of 8
  UsdPreviewSurface materials);
- ``lights``: ``--lights`` SphereLights and RectLights, half each, each translated and turned, with a colour;
- ``nested``: ``--trees`` native instances under ``/World``, two in three of a tree and the others of a branch, in
  turn (a tree: a trunk, 4 native branches of 6 native leaves each, and a PointInstancer of 8 fruit clusters, each
  a nested PointInstancer of 5 berries and a native leaf), and a PointInstancer of ``--trees`` trees and bushes;
- ``natives``: ``--natives`` native instances of 4 prototypes (rocks, lamps, crates, bushes: nested Xforms, meshes
  bound to plain and textured materials, a guide mesh, a nested native rock and a PointInstancer of leaves with
  per-instance ``st`` in each bush) in groups of 100 under rotated and translated Xforms, each moved, turned and
  scaled; one in 5 with a constant displayColor, one in 7 bound to a material, every crate with a constant ``st``,
  one in 50 invisible; and a PointInstancer of ``--natives // 4`` pebbles and tufts with per-instance ``st``,
  displayColor, orientations and scales.

Each stage is loaded ``--repeats`` times after one warm-up load; the median CPU seconds of this process (steadier than
wall time on a shared machine) and wall seconds are printed, with the CPU time per prim.

Usage: python benchmarks/load_stages.py [--meshes 5000] [--lights 2000] [--trees 2000] [--natives 20000]
                                       [--repeats 3] [--only natives] [--keep DIR]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

import wrt
from wrt.image import write_srgb_png

STAGES = ["meshes", "lights", "nested", "natives"]
_QUADS = [0, 1, 4, 3, 1, 2, 5, 4, 3, 4, 7, 6, 4, 5, 8, 7]  # a 3x3 grid of points, 4 quads


def _materials(stage, rng, n):
    found = []
    for k in range(n):
        material = UsdShade.Material.Define(stage, f"/Looks/M{k}")
        shader = UsdShade.Shader.Define(stage, f"/Looks/M{k}/S")
        shader.CreateIdAttr("UsdPreviewSurface")
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rng.random(3)))
        shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(rng.random()))
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        found.append(material)
    return found


def _quad_grid(stage, path, offset, rng):
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = np.array([(x, y, 0.0) for y in range(3) for x in range(3)], np.float32) * 0.1
    points += rng.normal(0, 0.01, points.shape).astype(np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr([4, 4, 4, 4])
    mesh.CreateFaceVertexIndicesAttr(_QUADS)
    mesh.AddTranslateOp().Set(Gf.Vec3d(*offset))
    return mesh


def write_meshes(path: Path, n: int, rng) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    materials = _materials(stage, rng, 8)
    for k in range(n):
        group = f"/World/G{k // 100}"
        if k % 100 == 0:
            UsdGeom.Xform.Define(stage, group).AddRotateZOp().Set(float(k % 37))
        mesh = _quad_grid(stage, f"{group}/M{k}", rng.normal(0, 10, 3), rng)
        if k % 3 == 0:
            mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(*rng.random(3))])
        if k % 2 == 0:
            st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                          UsdGeom.Tokens.vertex)
            st.Set(Vt.Vec2fArray.FromNumpy(rng.random((9, 2)).astype(np.float32)))
        if k % 5 != 0:
            UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(materials[k % len(materials)])
    stage.GetRootLayer().Save()


def write_lights(path: Path, n: int, rng) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    _quad_grid(stage, "/Floor", (0, 0, 0), rng)
    for k in range(n):
        if k % 2:
            light = UsdLux.SphereLight.Define(stage, f"/Lights/L{k}")
            light.CreateRadiusAttr(0.05)
        else:
            light = UsdLux.RectLight.Define(stage, f"/Lights/L{k}")
            light.CreateWidthAttr(0.3)
            light.CreateHeightAttr(0.2)
        light.CreateIntensityAttr(float(5 + k % 10))
        light.CreateColorAttr(Gf.Vec3f(*rng.random(3)))
        UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(*rng.normal(0, 10, 3)))
        UsdGeom.Xformable(light).AddRotateXYZOp().Set(Gf.Vec3f(*rng.normal(0, 30, 3)))
    stage.GetRootLayer().Save()


def _instance(stage, path, target):
    prim = stage.DefinePrim(path, "Xform")
    prim.GetReferences().AddInternalReference(target)
    prim.SetInstanceable(True)
    return prim


def _instancer(stage, path, targets, indices, positions):
    instancer = UsdGeom.PointInstancer.Define(stage, path)
    instancer.CreatePrototypesRel().SetTargets([Sdf.Path(t) for t in targets])
    instancer.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(indices, np.int32)))
    instancer.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(positions, np.float32)))


def write_nested(path: Path, trees: int, rng) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    leaf_look = _materials(stage, rng, 1)[0]
    UsdGeom.Xform.Define(stage, "/Protos/Leaf")
    UsdShade.MaterialBindingAPI.Apply(_quad_grid(stage, "/Protos/Leaf/Blade", (0, 0, 0), rng).GetPrim()).Bind(
        leaf_look)
    UsdGeom.Xform.Define(stage, "/Protos/Branch")
    _quad_grid(stage, "/Protos/Branch/Stem", (0, 0, 0), rng)
    for j in range(6):
        UsdGeom.Xformable(_instance(stage, f"/Protos/Branch/Leaf{j}", "/Protos/Leaf")).AddTranslateOp().Set(
            Gf.Vec3d(0.1 * j, 0, 0.2))
    UsdGeom.Xform.Define(stage, "/Protos/Tree")
    _quad_grid(stage, "/Protos/Tree/Trunk", (0, 0, 0), rng)
    for j in range(4):
        UsdGeom.Xformable(_instance(stage, f"/Protos/Tree/Branch{j}", "/Protos/Branch")).AddRotateZOp().Set(90.0 * j)
    fruit = "/Protos/Tree/Fruit"
    UsdGeom.Imageable(stage.DefinePrim(f"{fruit}/Protos", "Scope")).MakeInvisible()
    UsdGeom.Xform.Define(stage, f"{fruit}/Protos/Cluster")
    UsdGeom.Sphere.Define(stage, f"{fruit}/Protos/Cluster/Berries/P/Ball").CreateRadiusAttr(0.02)
    _instancer(stage, f"{fruit}/Protos/Cluster/Berries", [f"{fruit}/Protos/Cluster/Berries/P"], [0] * 5,
               [(0.03 * i, 0, 0) for i in range(5)])
    _instance(stage, f"{fruit}/Protos/Cluster/Leaf", "/Protos/Leaf")
    _instancer(stage, fruit, [f"{fruit}/Protos/Cluster"], [0] * 8, rng.normal(0, 0.3, (8, 3)))
    for k in range(trees):  # trees and branches in turn (every third a branch)
        tree = _instance(stage, f"/World/Tree{k}", "/Protos/Tree" if k % 3 else "/Protos/Branch")
        UsdGeom.Xformable(tree).AddTranslateOp().Set(Gf.Vec3d(*rng.normal(0, 20, 3)))
    _instance(stage, "/World/Forest/Protos/T", "/Protos/Tree")
    UsdGeom.Xform.Define(stage, "/World/Forest/Protos/Bush")
    for j in range(3):
        UsdGeom.Xformable(_instance(stage, f"/World/Forest/Protos/Bush/B{j}", "/Protos/Branch")).AddTranslateOp().Set(
            Gf.Vec3d(j, 0, 0))
    _instancer(stage, "/World/Forest", ["/World/Forest/Protos/T", "/World/Forest/Protos/Bush"],
               np.arange(trees) % 2, rng.normal(0, 30, (trees, 3)))
    for holder in ("/Protos", "/World/Forest/Protos"):  # (Define made them defs): drawn only where instanced
        stage.GetPrimAtPath(holder).SetSpecifier(Sdf.SpecifierOver)
    stage.GetRootLayer().Save()


def _textured_material(stage, path: str, png: str):
    """A UsdPreviewSurface whose diffuseColor is texture ``png`` read at the ``st`` primvar."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    reader = UsdShade.Shader.Define(stage, f"{path}/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    image = UsdShade.Shader.Define(stage, f"{path}/Image")
    image.CreateIdAttr("UsdUVTexture")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(png)
    image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    image.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(image.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def _bind(prim_or_schema, material) -> None:
    prim = prim_or_schema if isinstance(prim_or_schema, Usd.Prim) else prim_or_schema.GetPrim()
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def _constant_primvar(prim, name: str, type_name, value) -> None:
    UsdGeom.PrimvarsAPI(prim).CreatePrimvar(name, type_name, UsdGeom.Tokens.constant).Set(value)


def _vertex_st(mesh, rng) -> None:
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set(Vt.Vec2fArray.FromNumpy(rng.random((9, 2)).astype(np.float32)))


def _native_prototypes(stage, rng, looks: list, tex) -> list[str]:
    """Rock, Lamp, Crate and Bush under ``/Protos`` (see the module docstring); their paths."""
    UsdGeom.Xform.Define(stage, "/Protos/Rock")
    pivot = UsdGeom.Xform.Define(stage, "/Protos/Rock/Pivot")
    pivot.AddRotateZOp().Set(30.0)
    pivot.AddScaleOp().Set(Gf.Vec3f(1.5, 1.0, 0.7))
    body = _quad_grid(stage, "/Protos/Rock/Pivot/Body", (0, 0, 0.1), rng)
    _vertex_st(body, rng)
    _bind(body, tex)
    _quad_grid(stage, "/Protos/Rock/Lichen", (0.05, 0.05, 0.2), rng)  # unbound, no colour: takes the instance's
    UsdGeom.Xform.Define(stage, "/Protos/Lamp")
    pole = UsdGeom.Xform.Define(stage, "/Protos/Lamp/Pole")
    pole.AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.5))
    _bind(_quad_grid(stage, "/Protos/Lamp/Pole/Shaft", (0, 0, 0), rng), looks[1])
    head = UsdGeom.Xform.Define(stage, "/Protos/Lamp/Head")
    head.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1.0))
    _bind(head, looks[2])  # inherited by the glass
    UsdGeom.Xform.Define(stage, "/Protos/Lamp/Head/Bulb").AddRotateXOp().Set(20.0)
    glass = _quad_grid(stage, "/Protos/Lamp/Head/Bulb/Glass", (0, 0, 0), rng)
    glass.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.9, 0.9, 0.5)])
    guide = _quad_grid(stage, "/Protos/Lamp/Guide", (0, 0, 2), rng)
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    UsdGeom.Xform.Define(stage, "/Protos/Crate")
    _bind(_quad_grid(stage, "/Protos/Crate/Box", (0, 0, 0), rng), tex)  # no st: the instance's constant one
    UsdGeom.Xform.Define(stage, "/Protos/Crate/Lid").AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.3))
    _bind(_quad_grid(stage, "/Protos/Crate/Lid/Top", (0, 0, 0), rng), looks[3])
    UsdGeom.Xform.Define(stage, "/Protos/Bush")
    UsdGeom.Xformable(_instance(stage, "/Protos/Bush/Stone", "/Protos/Rock")).AddScaleOp().Set(Gf.Vec3f(0.5, 0.5, 0.5))
    leaves = "/Protos/Bush/Leaves"
    UsdGeom.Imageable(stage.DefinePrim(f"{leaves}/Protos", "Scope")).MakeInvisible()
    UsdGeom.Xform.Define(stage, f"{leaves}/Protos/Leaf")
    _bind(_quad_grid(stage, f"{leaves}/Protos/Leaf/Blade", (0, 0, 0), rng), tex)  # no st: the instancer's
    _instancer(stage, leaves, [f"{leaves}/Protos/Leaf"], [0] * 6, rng.normal(0, 0.3, (6, 3)))
    st = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(leaves)).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                                        UsdGeom.Tokens.vertex)
    st.Set(Vt.Vec2fArray.FromNumpy((np.arange(12).reshape(6, 2) % 4 / 4).astype(np.float32)))
    return ["/Protos/Rock", "/Protos/Lamp", "/Protos/Crate", "/Protos/Bush"]


def write_natives(path: Path, n: int, rng) -> None:
    """The ``natives`` stage (see the module docstring): ``n`` native instances and a PointInstancer of ``n // 4``."""
    png = path.with_suffix(".png")
    checker = (np.indices((8, 8)).sum(axis=0) % 2)[..., None] * np.array([200, 40, 90]) + 30
    write_srgb_png(png, checker.astype(np.uint8))
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    looks = _materials(stage, rng, 6)
    tex = _textured_material(stage, "/Looks/Tex", f"./{png.name}")
    protos = _native_prototypes(stage, rng, looks, tex)
    palette = rng.random((6, 3))
    sts = rng.random((8, 2))
    for k in range(n):
        group = f"/World/B{k // 1000}/R{k // 100 % 10}"
        if k % 1000 == 0:
            UsdGeom.Xform.Define(stage, f"/World/B{k // 1000}").AddRotateZOp().Set(float(k // 1000 * 17 % 360))
        if k % 100 == 0:
            UsdGeom.Xform.Define(stage, group).AddTranslateOp().Set(Gf.Vec3d(k // 100 % 10 * 30.0, 0, 0))
        prim = _instance(stage, f"{group}/I{k}", protos[k % len(protos)])
        xform = UsdGeom.Xformable(prim)
        xform.AddTranslateOp().Set(Gf.Vec3d(*rng.normal(0, 10, 3)))
        xform.AddRotateZOp().Set(float(rng.uniform(0, 360)))
        xform.AddScaleOp().Set(Gf.Vec3f(*rng.uniform(0.5, 1.5, 3)))
        if k % 5 == 0:
            _constant_primvar(prim, "displayColor", Sdf.ValueTypeNames.Color3fArray,
                              [Gf.Vec3f(*palette[k // 5 % len(palette)])])
        if k % 7 == 0:
            _bind(prim, looks[k % len(looks)])
        if k % len(protos) == 2:  # a crate: its box reads this st
            _constant_primvar(prim, "st", Sdf.ValueTypeNames.TexCoord2fArray, [Gf.Vec2f(*sts[k // 4 % len(sts)])])
        if k % 50 == 49:
            UsdGeom.Imageable(prim).MakeInvisible()
    scatter = "/World/Scatter"
    UsdGeom.Xform.Define(stage, f"{scatter}/Protos/Pebble")
    _bind(_quad_grid(stage, f"{scatter}/Protos/Pebble/Stone", (0, 0, 0), rng), tex)  # no st: the instancer's
    UsdGeom.Xform.Define(stage, f"{scatter}/Protos/Tuft").AddRotateXOp().Set(90.0)
    _quad_grid(stage, f"{scatter}/Protos/Tuft/Blades", (0, 0, 0), rng)
    count = n // 4
    _instancer(stage, scatter, [f"{scatter}/Protos/Pebble", f"{scatter}/Protos/Tuft"], rng.integers(0, 2, count),
               rng.normal(0, 40, (count, 3)))
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath(scatter))
    quats = rng.normal(size=(count, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    instancer.CreateOrientationsAttr(Vt.QuathArray.FromNumpy(quats.astype(np.float16)))
    instancer.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(0.5, 2, (count, 3)).astype(np.float32)))
    api = UsdGeom.PrimvarsAPI(instancer.GetPrim())
    api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec2fArray.FromNumpy(rng.random((16, 2)).astype(np.float32)[rng.integers(0, 16, count)]))
    api.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec3fArray.FromNumpy(rng.random((count, 3)).astype(np.float32)))
    UsdGeom.Imageable(stage.GetPrimAtPath(f"{scatter}/Protos")).MakeInvisible()
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierOver)  # drawn only where instanced
    stage.GetRootLayer().Save()


def time_loads(path: Path, repeats: int) -> tuple[float, float, wrt.Scene]:
    """``(median CPU seconds, median wall seconds, scene)`` of ``repeats`` loads of ``path`` after a warm-up load."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
        cpus, walls = [], []
        for _ in range(repeats):
            wall, cpu = time.perf_counter(), time.process_time()
            scene = wrt.load_usd(path)
            cpus.append(time.process_time() - cpu)
            walls.append(time.perf_counter() - wall)
    return statistics.median(cpus), statistics.median(walls), scene


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--meshes", type=int, default=5000, help="distinct small meshes")
    parser.add_argument("--lights", type=int, default=2000, help="SphereLights and RectLights")
    parser.add_argument("--trees", type=int, default=2000, help="native trees and branches, and instanced trees")
    parser.add_argument("--natives", type=int, default=20000, help="native instances (and PointInstancer / 4)")
    parser.add_argument("--only", choices=STAGES, nargs="+", default=STAGES, help="stages to write and load")
    parser.add_argument("--repeats", type=int, default=3, help="timed loads of each stage (median)")
    parser.add_argument("--keep", type=Path, default=None, help="write the stages here and keep them")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.keep or Path(scratch)
        folder.mkdir(parents=True, exist_ok=True)
        writers = {"meshes": (write_meshes, args.meshes), "lights": (write_lights, args.lights),
                   "nested": (write_nested, args.trees), "natives": (write_natives, args.natives)}
        rng = np.random.default_rng(7)  # the first three from one generator, as at stop 59
        for name in args.only:
            write, size = writers[name]
            write(folder / f"{name}.usdc", size, np.random.default_rng(11) if name == "natives" else rng)
        for name, count, what in (("meshes", lambda s: len(s.meshes), "mesh"),
                                  ("lights", lambda s: len(s.lights), "light"),
                                  ("nested", lambda s: len(s.instances), "instance row"),
                                  ("natives", lambda s: len(s.instances), "instance row")):
            if name not in args.only:
                continue
            cpu, wall, scene = time_loads(folder / f"{name}.usdc", args.repeats)
            n = count(scene)
            print(f"{name}: {n:,} ({what}), load {cpu:.2f} s CPU ({wall:.2f} s wall), {1e3 * cpu / n:.4f} ms CPU per "
                  f"{what}")


if __name__ == "__main__":
    main()
