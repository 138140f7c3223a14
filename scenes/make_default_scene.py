"""Writes ``wrt/data/default_room.usda``, the scene ``wrt render`` shows when given no file.

A small room (floor, three walls) holding a cube of quads, a hexagonal prism whose caps are hexagons (n-gons),
a square pyramid, a smooth UV sphere with authored vertex normals lit by a sun (a normalized distant light:
its intensity is the illuminance) and a sky dome, seen by one camera. Y is up, one unit is one metre. Every mesh
is double-sided, so no face is culled whichever way it is wound.

Run ``python scenes/make_default_scene.py`` after editing; the ``.usda`` it writes is committed.
"""

from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, Vt


def add_mesh(stage, path, points, counts, indices, color, normals=None, translate=(0, 0, 0), rotate_y=0.0):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in points]))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([int(c) for c in counts]))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in indices]))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateDoubleSidedAttr(True)
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set(Vt.Vec3fArray([Gf.Vec3f(*color)]))
    if normals is not None:
        mesh.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, n)) for n in normals]))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    xform = UsdGeom.XformCommonAPI(mesh)
    xform.SetTranslate(Gf.Vec3d(*translate))
    if rotate_y:
        xform.SetRotate(Gf.Vec3f(0.0, rotate_y, 0.0))
    return mesh


def box(sx, sy, sz):
    x, y, z = sx / 2, sy, sz / 2
    points = [(-x, 0, -z), (x, 0, -z), (x, 0, z), (-x, 0, z), (-x, y, -z), (x, y, -z), (x, y, z), (-x, y, z)]
    faces = [(0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
    return points, [4] * 6, [i for f in faces for i in f]


def hex_prism(radius, height):
    angles = np.arange(6) * np.pi / 3
    ring = [(radius * np.cos(a), 0.0, -radius * np.sin(a)) for a in angles]
    points = ring + [(x, height, z) for x, _, z in ring]
    faces = [list(range(5, -1, -1)), list(range(6, 12))]
    faces += [[k, (k + 1) % 6, 6 + (k + 1) % 6, 6 + k] for k in range(6)]
    return points, [len(f) for f in faces], [i for f in faces for i in f]


def pyramid(base, height):
    b = base / 2
    points = [(-b, 0, -b), (b, 0, -b), (b, 0, b), (-b, 0, b), (0, height, 0)]
    faces = [[3, 2, 1, 0], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    return points, [len(f) for f in faces], [i for f in faces for i in f]


def uv_sphere(radius, rings=16, segments=32):
    points, normals = [], []
    for i in range(rings + 1):
        theta = np.pi * i / rings
        for j in range(segments):
            phi = 2 * np.pi * j / segments
            n = (np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi))
            points.append(tuple(radius * c for c in n))
            normals.append(n)
    counts, indices = [], []
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            quad = [a, b, b + segments, a + segments]
            counts.append(4)
            indices += quad[::-1]  # counter-clockwise seen from outside
    return points, counts, indices, normals


def main(path: Path):
    stage = Usd.Stage.CreateNew(str(path)) if not path.exists() else Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    room = "/World/Room"
    UsdGeom.Xform.Define(stage, room)
    add_mesh(stage, f"{room}/Floor", [(-3, 0, -3), (3, 0, -3), (3, 0, 7), (-3, 0, 7)], [4], [3, 2, 1, 0], (0.8, 0.8, 0.75))
    add_mesh(stage, f"{room}/BackWall", [(-3, 0, -3), (3, 0, -3), (3, 4, -3), (-3, 4, -3)], [4], [0, 1, 2, 3], (0.75, 0.75, 0.8))
    add_mesh(stage, f"{room}/LeftWall", [(-3, 0, 7), (-3, 0, -3), (-3, 4, -3), (-3, 4, 7)], [4], [0, 1, 2, 3], (0.75, 0.2, 0.2))
    add_mesh(stage, f"{room}/RightWall", [(3, 0, -3), (3, 0, 7), (3, 4, 7), (3, 4, -3)], [4], [0, 1, 2, 3], (0.2, 0.6, 0.25))

    objects = "/World/Objects"
    UsdGeom.Xform.Define(stage, objects)
    add_mesh(stage, f"{objects}/Cube", *box(1.0, 1.0, 1.0), (0.9, 0.7, 0.2), translate=(-1.4, 0, -0.8), rotate_y=30)
    add_mesh(stage, f"{objects}/HexPrism", *hex_prism(0.55, 1.6), (0.25, 0.45, 0.85), translate=(1.5, 0, -1.2))
    add_mesh(stage, f"{objects}/Pyramid", *pyramid(1.0, 1.1), (0.85, 0.5, 0.7), translate=(0.4, 0, 0.9), rotate_y=20)
    points, counts, indices, normals = uv_sphere(0.6)
    add_mesh(stage, f"{objects}/Sphere", points, counts, indices, (0.9, 0.9, 0.9), normals, translate=(-0.2, 0.6, -1.5))

    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    camera.CreateFocalLengthAttr(28.0)
    camera.CreateHorizontalApertureAttr(36.0)
    camera.CreateVerticalApertureAttr(24.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.05, 100.0))
    eye, target = Gf.Vec3d(0.0, 2.1, 5.6), Gf.Vec3d(0.0, 1.0, -1.0)
    view = Gf.Matrix4d().SetLookAt(eye, target, Gf.Vec3d(0, 1, 0)).GetInverse()
    camera.AddTransformOp().Set(view)

    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(2.5)
    sun.CreateColorAttr(Gf.Vec3f(1.0, 0.97, 0.9))
    sun.CreateAngleAttr(0.53)
    sun.CreateNormalizeAttr(True)
    UsdGeom.XformCommonAPI(sun).SetRotate(Gf.Vec3f(-60.0, 25.0, 0.0), UsdGeom.XformCommonAPI.RotationOrderYXZ)

    sky = UsdLux.DomeLight.Define(stage, "/World/Sky")
    sky.CreateIntensityAttr(0.35)
    sky.CreateColorAttr(Gf.Vec3f(0.6, 0.75, 1.0))

    layer = stage.GetRootLayer()
    layer.documentation = "wrt default scene, generated by scenes/make_default_scene.py"
    layer.Export(str(path))


if __name__ == "__main__":
    main(Path(__file__).resolve().parents[1] / "wrt" / "data" / "default_room.usda")
