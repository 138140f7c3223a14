"""Writes ``mostly_static.usda``: an animated stage where almost everything holds still, to measure what each frame's
load spends on prims that cannot have changed (``benchmarks/RESULTS.md``, "Frames of a mostly static stage").

- ``/World/Static/Mesh_NNN``: ``COUNT`` (200) bumpy grids of 50 x 100 quads (10,000 triangles each) with texture
  coordinates, bound round-robin to 20 UsdPreviewSurface materials (every fifth reads ``grid.png``, written beside
  the stage); half are ``catmullClark`` (smooth normals made from the cage), half ``none``;
- ``/World/Mover``: an Xform whose translate is time-sampled, holding one mesh;
- ``/World/Wave``: a mesh whose points are time-sampled (it deforms);
- a camera and a distant light, both static.

Usage: ``python scenes/make_mostly_static_scene.py [OUT.usda] [COUNT]`` (default ``scenes/mostly_static.usda``, 200).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

FIRST, LAST = 1, 48
MATERIALS = 20


def bumpy_grid(nx: int, ny: int, phase: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points, face counts, face indices and per-vertex st of an ``nx x ny`` quad grid over [0, 1] x [0, 0.5]."""
    u, v = np.linspace(0.0, 1.0, nx + 1), np.linspace(0.0, 0.5, ny + 1)
    x, y = np.meshgrid(u, v, indexing="ij")
    z = 0.05 * np.sin(12.0 * x + phase) * np.cos(9.0 * y - phase)
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    a = (i * (ny + 1) + j).reshape(-1)
    quads = np.stack([a, a + ny + 1, a + ny + 2, a + 1], axis=1).reshape(-1)
    st = np.stack([x, 2.0 * y], axis=-1).reshape(-1, 2)
    return points, np.full(nx * ny, 4), quads, st


def define_mesh(stage: Usd.Stage, path: str, points, counts, indices, st=None) -> UsdGeom.Mesh:
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts.astype(np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices.astype(np.int32)))
    if st is not None:
        primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                          UsdGeom.Tokens.vertex)
        primvar.Set(Vt.Vec2fArray.FromNumpy(st.astype(np.float32)))
    return mesh


def define_material(stage: Usd.Stage, path: str, k: int, texture: str | None) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.2 + 0.6 * (k % 4) / 3)
    color = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    if texture is None:
        color.Set(Gf.Vec3f(0.3 + 0.6 * (k % 3) / 2, 0.4, 0.9 - 0.5 * (k % 5) / 4))
    else:
        reader = UsdShade.Shader.Define(stage, f"{path}/St")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        image = UsdShade.Shader.Define(stage, f"{path}/Image")
        image.CreateIdAttr("UsdUVTexture")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(texture)
        image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        color.ConnectToSource(image.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def write_texture(path: Path) -> None:
    from PIL import Image

    i, j = np.meshgrid(np.arange(256), np.arange(256), indexing="ij")
    checks = ((i // 32 + j // 32) % 2).astype(np.uint8)
    rgb = np.stack([60 + 180 * checks, 90 + 60 * checks, 200 - 120 * checks], axis=-1).astype(np.uint8)
    Image.fromarray(rgb).save(path)


def write(path: Path, count: int = 200) -> Path:
    write_texture(path.with_name("grid.png"))
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetStartTimeCode(FIRST)
    stage.SetEndTimeCode(LAST)
    stage.SetTimeCodesPerSecond(24)
    UsdGeom.Xform.Define(stage, "/World")
    materials = [define_material(stage, f"/World/Looks/M{k:02d}", k, "grid.png" if k % 5 == 0 else None)
                 for k in range(MATERIALS)]

    side = int(np.ceil(np.sqrt(count)))
    for n in range(count):
        points, counts, indices, st = bumpy_grid(100, 50, 0.37 * n)
        mesh = define_mesh(stage, f"/World/Static/Mesh_{n:03d}", points, counts, indices, st)
        if n % 2:
            mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.AddTranslateOp().Set(Gf.Vec3d(1.1 * (n % side), 0.6 * (n // side), 0.0))
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(materials[n % MATERIALS])

    mover = UsdGeom.Xform.Define(stage, "/World/Mover")
    move = mover.AddTranslateOp()
    for t in (FIRST, LAST):
        move.Set(Gf.Vec3d(0.5 * side * (t - FIRST) / (LAST - FIRST), -1.0, 0.3), t)
    define_mesh(stage, "/World/Mover/Box", *bumpy_grid(10, 10, 0.0)[:3])

    wave = define_mesh(stage, "/World/Wave", *bumpy_grid(40, 40, 0.0))
    wave.AddTranslateOp().Set(Gf.Vec3d(-2.0, 0.0, 0.0))
    for t in range(FIRST, LAST + 1, 4):
        wave.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(bumpy_grid(40, 40, 0.3 * t)[0].astype(np.float32)), t)

    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(40.0, 20.0, 0.0))
    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    camera.CreateFocalLengthAttr(24.0)
    centre = Gf.Vec3d(0.55 * side, 0.3 * side, 0.0)
    view = Gf.Matrix4d().SetLookAt(centre + Gf.Vec3d(0.0, -0.8 * side, 0.7 * side), centre, Gf.Vec3d(0, 0, 1))
    camera.AddTransformOp().Set(view.GetInverse())
    stage.GetRootLayer().Save()
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    parser.add_argument("output", nargs="?", type=Path, default=Path(__file__).with_name("mostly_static.usda"),
                        help="USD file to write (.usda, .usdc or .usd); default scenes/mostly_static.usda")
    parser.add_argument("count", nargs="?", type=int, default=200, help="static meshes (default 200)")
    args = parser.parse_args(argv)
    if args.output.suffix.lower() not in (".usda", ".usdc", ".usd"):  # --help was taken for the name
        parser.error(f"{args.output}: give a USD file name (.usda, .usdc or .usd)")
    if args.count < 1:
        parser.error(f"count must be a positive integer, got {args.count}")
    print(write(args.output, args.count))


if __name__ == "__main__":
    main()
