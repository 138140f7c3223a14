"""Writes ``animated.usda``: a small animated stage that exercises every way wrt follows a scene across frames.

- frames 1-2: a waving sheet deforms (mesh points are time-sampled) -> the BVH is refitted;
- frames 2-5: a PointInstancer moves its cubes and an animated Sphere gprim moves -> only the TLAS is rebuilt;
- frames 5-8: only the camera and the sun move -> the BVH is reused as it is.

Usage: ``python scenes/make_animated_scene.py [OUT.usda]`` (default ``scenes/animated.usda``).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, Vt

FIRST, LAST = 1, 8
USD_SUFFIXES = (".usda", ".usdc", ".usd")  # the formats USD writes a new layer in


def sheet(n: int, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An ``n x n`` grid of quads over [-1, 1]^2 at height z = a wave that travels with ``t``."""
    u = np.linspace(-1.0, 1.0, n + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    z = 0.25 * np.sin(3.0 * x + 1.7 * t) * np.cos(2.0 * y)
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).reshape(-1)
    quads = np.stack([a, a + n + 1, a + n + 2, a + 1], axis=1)
    return points, np.full(len(quads), 4), quads.reshape(-1)


def write(path: Path) -> Path:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetStartTimeCode(FIRST)
    stage.SetEndTimeCode(LAST)
    stage.SetTimeCodesPerSecond(24)
    UsdGeom.Xform.Define(stage, "/World")

    ground = UsdGeom.Mesh.Define(stage, "/World/Ground")
    ground.CreatePointsAttr(Vt.Vec3fArray([(-4, -4, -0.6), (4, -4, -0.6), (4, 4, -0.6), (-4, 4, -0.6)]))
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    ground.CreateDisplayColorAttr([(0.6, 0.6, 0.6)])

    wave = UsdGeom.Mesh.Define(stage, "/World/Sheet")
    points_attr = wave.CreatePointsAttr()
    for t in (1, 2):  # held after frame 2
        points, counts, indices = sheet(12, t)
        points_attr.Set(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)), t)
    wave.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts.astype(np.int32)))
    wave.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices.astype(np.int32)))
    wave.CreateDisplayColorAttr([(0.2, 0.5, 0.9)])

    instancer = UsdGeom.PointInstancer.Define(stage, "/World/Cubes")
    cube = UsdGeom.Mesh.Define(stage, "/World/Cubes/Proto/Box")
    corners = [(x, y, z) for z in (-0.15, 0.15) for y in (-0.15, 0.15) for x in (-0.15, 0.15)]
    cube.CreatePointsAttr(corners)
    cube.CreateFaceVertexCountsAttr([4] * 6)
    cube.CreateFaceVertexIndicesAttr([0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5])
    cube.CreateDisplayColorAttr([(0.9, 0.4, 0.2)])
    instancer.CreatePrototypesRel().SetTargets([Sdf.Path("/World/Cubes/Proto")])
    instancer.CreateProtoIndicesAttr([0] * 5)
    positions = instancer.CreatePositionsAttr()
    for t in range(2, 6):  # held before frame 2 and after frame 5
        a = 0.4 * (t - 2)
        positions.Set([Gf.Vec3f(1.6 * math.cos(a + k * 1.25), 1.6 * math.sin(a + k * 1.25), 0.3) for k in range(5)], t)

    ball = UsdGeom.Sphere.Define(stage, "/World/Ball")
    ball.CreateRadiusAttr(0.3)
    ball.CreateDisplayColorAttr([(0.3, 0.8, 0.3)])
    move = ball.AddTranslateOp()
    for t in range(2, 6):
        move.Set(Gf.Vec3d(-0.5 + 0.25 * (t - 2), 0.0, 0.8), t)

    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.CreateNormalizeAttr(True)  # intensity is the illuminance (not the sun disk's radiance)
    sun.CreateAngleAttr(1.0)
    turn = sun.AddRotateXYZOp()
    for t in (5, LAST):
        turn.Set(Gf.Vec3f(30.0 + 3.0 * (t - 5), 20.0, 0.0), t)

    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    camera.CreateFocalLengthAttr(24.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    xform = camera.AddTransformOp()
    for t in (5, LAST):
        eye = Gf.Vec3d(6.0 * math.cos(0.1 * t), -6.0 * math.sin(0.1 * t) - 2.0, 4.0)
        view = Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 0, 1)).GetInverse()
        xform.Set(view, t)
    stage.GetRootLayer().Save()
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    parser.add_argument("output", nargs="?", type=Path, default=Path(__file__).with_name("animated.usda"),
                        help="USD file to write (.usda, .usdc or .usd); default scenes/animated.usda")
    args = parser.parse_args(argv)
    if args.output.suffix.lower() not in USD_SUFFIXES:  # --help was taken for the name: USD's traceback
        parser.error(f"{args.output}: give a USD file name (.usda, .usdc or .usd)")
    print(write(args.output))


if __name__ == "__main__":
    main()
