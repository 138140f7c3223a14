"""Generates the lecture's forest as a USD stage: one procedural tree, instanced N times by a PointInstancer.

"50K trees each with 1M polygons = 50B polygons" (the ray tracing lecture, acceleration structures): the tree is a
tapered trunk plus leaves (each leaf a quad, two triangles) scattered in a crown; ``tree_triangles`` sets its size
(about 1M at full detail). ``n_trees`` instances stand on a square ground quad with random positions, yaw and
scale, under a sun (a ``DistantLight``, so renders have shadows) and a dim sky dome, seen by one camera from the
forest's edge. Y is up, one unit is one metre; trees are about 10 m tall.

The tree mesh is written once, so the file grows with ``tree_triangles`` and not with ``n_trees`` (a PointInstancer
stores a position, an orientation, a scale and a prototype index per instance). The geometry is deterministic in
``seed``.

    python scenes/forest.py forest.usdc --trees 1000 --tree-triangles 10000
    wrt render forest.usdc --width 640 --height 360
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

TREE_HEIGHT = 10.0  # metres, trunk base to crown top, before the instance scale
TRUNK_HEIGHT = 4.0  # metres of bare trunk below the crown
TRUNK_RADIUS = 0.35  # metres at the base
TRUNK_SEGMENTS = 16  # sides of the trunk
TRUNK_RINGS = 8  # rings along the trunk (the trunk has 2 * TRUNK_SEGMENTS * TRUNK_RINGS triangles)
LEAF_SIZE = 0.35  # metres, edge of a leaf quad (scaled down as leaves get denser, see tree_mesh)
SPACING = 8.0  # metres between neighbouring trees on average
TRUNK_COLOR = (0.30, 0.18, 0.09)  # linear displayColor
LEAF_COLOR = (0.10, 0.35, 0.08)
GROUND_COLOR = (0.25, 0.22, 0.15)


def tree_mesh(tree_triangles: int = 1_000_000, seed: int = 0) -> dict:
    """The procedural tree, centred on the origin at ground level.

    Args:
        tree_triangles: total triangles of trunk and leaves (at least the trunk's 256; leaves are pairs).
        seed: random seed of the leaf placement.

    Returns:
        dict ``{"trunk": (points (V, 3) float32, indices (T, 3) int32), "leaves": (points, indices)}``; every face
        is a triangle, counter-clockwise seen from outside for the trunk.
    """
    rng = np.random.default_rng(seed)
    # Trunk: a tapered tube, open at both ends (the bottom stands on the ground, the top is inside the crown).
    z = np.linspace(0.0, TRUNK_HEIGHT + 0.5 * (TREE_HEIGHT - TRUNK_HEIGHT), TRUNK_RINGS + 1)
    radius = TRUNK_RADIUS * (1.0 - 0.6 * z / z[-1])
    phi = np.linspace(0.0, 2.0 * np.pi, TRUNK_SEGMENTS, endpoint=False)
    trunk_points = np.stack(
        [np.outer(radius, np.cos(phi)), np.repeat(z[:, None], TRUNK_SEGMENTS, 1), -np.outer(radius, np.sin(phi))], -1
    ).reshape(-1, 3)
    i = np.arange(TRUNK_SEGMENTS)
    j = (i + 1) % TRUNK_SEGMENTS
    quads = []
    for r in range(TRUNK_RINGS):
        a, b = r * TRUNK_SEGMENTS, (r + 1) * TRUNK_SEGMENTS
        quads.append(np.stack([a + i, a + j, b + j, b + i], 1))
    quads = np.concatenate(quads)
    trunk = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])

    # Leaves: quads in an ellipsoidal crown, denser towards its surface, randomly oriented.
    n_leaves = max((int(tree_triangles) - len(trunk)) // 2, 1)
    crown_centre = np.array([0.0, TRUNK_HEIGHT + 0.5 * (TREE_HEIGHT - TRUNK_HEIGHT), 0.0])
    crown_radii = np.array([3.0, 0.5 * (TREE_HEIGHT - TRUNK_HEIGHT), 3.0])
    direction = rng.normal(size=(n_leaves, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    centres = crown_centre + direction * crown_radii * rng.uniform(0.0, 1.0, (n_leaves, 1)) ** 0.25
    # Keep the crown's leaf area about constant: smaller leaves when there are more of them.
    size = LEAF_SIZE * min(1.0, math.sqrt(20_000 / n_leaves) * 2.0)
    u = rng.normal(size=(n_leaves, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(u, rng.normal(size=(n_leaves, 3)))
    v /= np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)
    half = 0.5 * size
    corners = np.stack([centres - half * u - half * v, centres + half * u - half * v,
                        centres + half * u + half * v, centres - half * u + half * v], 1)
    leaf_points = corners.reshape(-1, 3)
    k = 4 * np.arange(n_leaves)[:, None]
    leaves = np.concatenate([k + [0, 1, 2], k + [0, 2, 3]])
    return {
        "trunk": (trunk_points.astype(np.float32), trunk.astype(np.int32)),
        "leaves": (leaf_points.astype(np.float32), leaves.astype(np.int32)),
    }


def forest_layout(n_trees: int, seed: int = 0) -> dict:
    """Instance placement: ``positions`` ``(N, 3)``, ``yaw`` ``(N,)`` radians, ``scales`` ``(N,)`` and the ground's
    half extent, on a jittered grid so trees do not overlap."""
    rng = np.random.default_rng(seed + 1)
    side = max(int(math.ceil(math.sqrt(n_trees))), 1)
    half = 0.5 * side * SPACING
    cells = rng.permutation(side * side)[:n_trees]
    x = (cells % side + 0.5 + rng.uniform(-0.35, 0.35, n_trees)) * SPACING - half
    z = (cells // side + 0.5 + rng.uniform(-0.35, 0.35, n_trees)) * SPACING - half
    positions = np.stack([x, np.zeros(n_trees), z], 1)
    return {
        "positions": positions,
        "yaw": rng.uniform(0.0, 2.0 * np.pi, n_trees),
        "scales": rng.uniform(0.7, 1.3, n_trees),
        "half_extent": half + SPACING,
    }


def write_forest(path, n_trees: int = 1000, tree_triangles: int = 10_000, seed: int = 0) -> dict:
    """Writes the forest stage to ``path`` (``.usda`` text or ``.usdc`` binary; use ``.usdc`` for big trees).

    Returns:
        dict with ``path``, ``n_trees``, ``tree_triangles`` (actual), ``rendered_triangles`` (trees only, plus the
        2 ground triangles) and ``seconds`` spent.
    """
    from pxr import Gf, Usd, UsdGeom, UsdLux, Vt

    start = time.perf_counter()
    tree = tree_mesh(tree_triangles, seed)
    layout = forest_layout(n_trees, seed)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    # Ground: one quad, facing up.
    h = layout["half_extent"]
    ground = UsdGeom.Mesh.Define(stage, "/World/Ground")
    ground.CreatePointsAttr(Vt.Vec3fArray([(-h, 0, -h), (h, 0, -h), (h, 0, h), (-h, 0, h)]))
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    ground.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    ground.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(*GROUND_COLOR)])

    # The tree prototype: trunk and leaves, under the instancer (its Prototypes scope is hidden in place).
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/Trees")
    prototypes = UsdGeom.Scope.Define(stage, "/World/Trees/Prototypes")
    UsdGeom.Imageable(prototypes).MakeInvisible()
    UsdGeom.Xform.Define(stage, "/World/Trees/Prototypes/Tree")
    for name, (points, indices), color, double_sided in (
        ("Trunk", tree["trunk"], TRUNK_COLOR, False),
        ("Leaves", tree["leaves"], LEAF_COLOR, True),
    ):
        mesh = UsdGeom.Mesh.Define(stage, f"/World/Trees/Prototypes/Tree/{name}")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(indices), 3, np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices.reshape(-1)))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(double_sided)
        mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(*color)])
    instancer.CreatePrototypesRel().SetTargets(["/World/Trees/Prototypes/Tree"])
    n = int(n_trees)
    instancer.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(n, np.int32)))
    instancer.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(layout["positions"].astype(np.float32)))
    half_yaw = 0.5 * layout["yaw"]
    quats = np.stack([np.zeros(n), np.sin(half_yaw), np.zeros(n), np.cos(half_yaw)], 1)  # (i, j, k, real)
    instancer.CreateOrientationsAttr(Vt.QuathArray.FromNumpy(quats.astype(np.float16)))
    instancer.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(np.repeat(layout["scales"][:, None], 3, 1).astype(np.float32)))

    # Camera at the forest's edge, looking across it and slightly down.
    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    eye = Gf.Vec3d(-0.5 * h, 30.0, -0.5 * h)
    target = Gf.Vec3d(-0.5 * h + 60.0, 0.0, -0.5 * h + 80.0)
    view = Gf.Matrix4d().SetLookAt(eye, target, Gf.Vec3d(0, 1, 0)).GetInverse()
    camera.AddTransformOp().Set(view)
    camera.CreateFocalLengthAttr(24.0)
    camera.CreateHorizontalApertureAttr(36.0)
    camera.CreateVerticalApertureAttr(20.25)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 10.0 * h))

    # A sun low enough for long shadows, and a dim sky.
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(3.0)  # with normalize on: the illuminance at normal incidence
    sun.CreateNormalizeAttr(True)
    sun.CreateAngleAttr(0.53)
    sun.CreateColorAttr(Gf.Vec3f(1.0, 0.95, 0.85))
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set((-35.0, 40.0, 0.0))
    sky = UsdLux.DomeLight.Define(stage, "/World/Sky")
    sky.CreateIntensityAttr(0.3)
    sky.CreateColorAttr(Gf.Vec3f(0.6, 0.75, 1.0))
    stage.GetRootLayer().Save()
    per_tree = len(tree["trunk"][1]) + len(tree["leaves"][1])
    return {
        "path": str(path),
        "n_trees": n,
        "tree_triangles": per_tree,
        "rendered_triangles": n * per_tree + 2,
        "seconds": time.perf_counter() - start,
    }


MIN_TREE_TRIANGLES = 2 * TRUNK_SEGMENTS * TRUNK_RINGS + 2  # the trunk and one leaf


def _int_at_least(minimum: int):
    """An argparse type: an integer >= ``minimum`` (a negative --trees ended in 'math domain error', and a
    --tree-triangles below the trunk's count gave trees of another size than asked, without a word)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    return parse


def main(argv=None):
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("output", nargs="?", default="forest.usdc", help="stage to write (.usda or .usdc)")
    parser.add_argument("--trees", type=_int_at_least(1), default=1000, help="number of tree instances")
    parser.add_argument("--tree-triangles", type=_int_at_least(MIN_TREE_TRIANGLES), default=10_000,
                        help="triangles per tree (about 1e6 at full detail)")
    parser.add_argument("--seed", type=_int_at_least(0), default=0, help="random seed")
    args = parser.parse_args(argv)
    folder = Path(args.output).parent
    if Path(args.output).suffix not in (".usd", ".usda", ".usdc"):
        parser.error(f"cannot write {args.output}: give a .usd, .usda or .usdc file")
    if not folder.is_dir() or Path(args.output).is_dir():
        parser.error(f"cannot write {args.output}: {folder} is not a folder" if not folder.is_dir()
                     else f"cannot write {args.output}: it is a folder")
    info = write_forest(Path(args.output), args.trees, args.tree_triangles, args.seed)
    print(
        f"wrote {info['path']}: {info['n_trees']:,} trees x {info['tree_triangles']:,} triangles = "
        f"{info['rendered_triangles']:,} rendered triangles ({info['seconds']:.1f} s)"
    )


if __name__ == "__main__":
    main()
