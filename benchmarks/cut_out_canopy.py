"""Writes a canopy of cut-out leaves over a floor, lit by a distant light: the scene for timing shadow, camera and
bounce rays that pass cut-out holes (``wrt.hidden_hits.occluded_through_holes`` and ``intersect_visible``).

Each leaf is a quad of a UsdPreviewSurface whose ``opacity`` comes from the alpha of a checkerboard texture and
whose ``opacityThreshold`` is 0.5, so half of every leaf is a hole; the leaves lie in ``--layers`` loose layers, so a
ray towards the sun crosses several of them.

Usage: python benchmarks/cut_out_canopy.py OUT.usda [--leaves 20000] [--layers 12] [--seed 0]
then e.g. python benchmarks/frame_capture.py --scene OUT.usda
"""

import argparse
from pathlib import Path

import numpy as np
from PIL import Image
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt


def leaf_material(stage, texture: str) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, "/Looks/Leaf")
    surface = UsdShade.Shader.Define(stage, "/Looks/Leaf/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.5, 0.1))
    surface.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    reader = UsdShade.Shader.Define(stage, "/Looks/Leaf/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    image = UsdShade.Shader.Define(stage, "/Looks/Leaf/Alpha")
    image.CreateIdAttr("UsdUVTexture")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(texture)
    image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(image.ConnectableAPI(), "a")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


def write_canopy(path: Path, leaves: int, layers: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    rgba = np.zeros((8, 8, 4), np.uint8)
    rgba[..., :3] = 255
    rgba[..., 3] = 255 * ((np.arange(8)[:, None] + np.arange(8)[None, :]) % 2)  # checkerboard: half holes
    texture = path.with_suffix(".alpha.png")
    Image.fromarray(rgba, "RGBA").save(texture)

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-12, 0, -12), (12, 0, -12), (12, 0, 12), (-12, 0, 12)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])  # faces +y

    # Leaves: quads of side 0.6 at random places in the layers between y = 3 and y = 3 + layers, randomly tilted.
    centers = np.column_stack([rng.uniform(-10, 10, leaves), 3 + rng.integers(0, layers, leaves)
                               + rng.uniform(0, 0.5, leaves), rng.uniform(-10, 10, leaves)])
    corners = 0.3 * np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], float)
    tilt = rng.uniform(-0.4, 0.4, (leaves, 3))
    points = centers[:, None, :] + corners[None] + tilt[:, None, :] * corners[None, :, [2, 0, 1]]
    canopy = UsdGeom.Mesh.Define(stage, "/Canopy")
    canopy.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.reshape(-1, 3).astype(np.float32)))
    canopy.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(leaves, 4, np.int32)))
    canopy.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.arange(4 * leaves, dtype=np.int32)))
    canopy.CreateDoubleSidedAttr(True)
    st = UsdGeom.PrimvarsAPI(canopy).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                    UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray.FromNumpy(np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32), (leaves, 1))))
    UsdShade.MaterialBindingAPI.Apply(canopy.GetPrim()).Bind(leaf_material(stage, texture.name))

    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(3.0)
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set(Gf.Vec3f(-70, 20, 0))  # from above, a little aside
    UsdLux.DomeLight.Define(stage, "/Sky").CreateIntensityAttr(0.3)
    stage.GetRootLayer().Save()


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=Path, help="the .usda to write (the alpha texture goes beside it)")
    parser.add_argument("--leaves", type=int, default=20000)
    parser.add_argument("--layers", type=int, default=12)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    write_canopy(args.out, args.leaves, args.layers, args.seed)
    print(f"wrote {args.out}: {args.leaves} cut-out leaves in {args.layers} layers")


if __name__ == "__main__":
    main()
