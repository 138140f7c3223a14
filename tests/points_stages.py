"""Seeded random stages of ``UsdGeom.Points`` for :mod:`points_oracle`: every way the schema gives widths
(``primvars:widths``, ``widths`` constant, uniform, vertex, varying, none), authored ``normals`` and ``ids`` (which
change nothing), transforms with non-uniform scale and shear, native instances, PointInstancer prototypes (whose
root has a transform of its own) and time-sampled points with velocities and accelerations."""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

WIDTH_MODES = ("none", "constant", "uniform", "vertex", "varying", "primvar_vertex", "primvar_constant")


def random_matrix(rng, spread=3.0, stretch=True) -> np.ndarray:
    """A ``(4, 4)`` row-vector transform: rotation, then scales from 0.4 to 2.5 on each axis (``stretch``; else one
    scale), a shear, and a translation within ``spread``."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    s = rng.uniform(0.4, 2.5, 3) if stretch else np.full(3, rng.uniform(0.4, 2.5))
    linear = q * s[None, :]
    if stretch:
        linear = linear @ (np.eye(3) + np.triu(rng.uniform(-0.4, 0.4, (3, 3)), 1))
    m = np.eye(4)
    m[:3, :3] = linear
    m[3, :3] = rng.uniform(-spread, spread, 3)
    return m


def set_matrix(prim, m: np.ndarray) -> None:
    UsdGeom.Xformable(prim).AddTransformOp().Set(Gf.Matrix4d(*m.reshape(-1).tolist()))


def define_points(stage, path: str, rng, n: int, mode: str, animated: bool = False) -> UsdGeom.Points:
    """A Points prim of ``n`` points within 1.5 of its origin with widths authored as ``mode``."""
    pts = UsdGeom.Points.Define(stage, path)
    p = rng.uniform(-1.5, 1.5, (n, 3))
    w = rng.uniform(0.15, 0.6, n)
    if animated:  # samples at 1 and 3 moved by velocities and accelerations in between
        attr = pts.CreatePointsAttr()
        v = rng.uniform(-6, 6, (n, 3))
        a = rng.uniform(-20, 20, (n, 3))
        for time, shift in ((1.0, 0.0), (3.0, 0.3)):
            attr.Set(Vt.Vec3fArray.FromNumpy((p + shift).astype(np.float32)), time)
            pts.CreateVelocitiesAttr().Set(Vt.Vec3fArray.FromNumpy(v.astype(np.float32)), time)
            pts.CreateAccelerationsAttr().Set(Vt.Vec3fArray.FromNumpy(a.astype(np.float32)), time)
    else:
        pts.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(p.astype(np.float32)))
    widths = Vt.FloatArray.FromNumpy(w.astype(np.float32))
    if mode == "constant" or mode == "uniform":
        pts.CreateWidthsAttr(Vt.FloatArray([float(w[0])]))
        pts.SetWidthsInterpolation(mode)
    elif mode in ("vertex", "varying"):
        pts.CreateWidthsAttr(widths)
        pts.SetWidthsInterpolation(mode)
    elif mode.startswith("primvar"):
        pts.CreateWidthsAttr(Vt.FloatArray([5.0] * n))  # the primvar wins over it
        interpolation = mode.split("_")[1]
        value = widths if interpolation == "vertex" else Vt.FloatArray([float(w[0])])
        UsdGeom.PrimvarsAPI(pts).CreatePrimvar("widths", Sdf.ValueTypeNames.FloatArray, interpolation).Set(value)
    if rng.uniform() < 0.5:  # normals and ids are not read: spheres stay spheres
        normals = rng.normal(size=(n, 3))
        pts.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(normals.astype(np.float32)))
        pts.SetNormalsInterpolation("vertex")
        pts.CreateIdsAttr(Vt.Int64Array([int(i) for i in rng.permutation(n)]))
    return pts


def write_stage(path: str, seed: int, animated: bool = False) -> Usd.Stage:
    """A stage of plain Points prims under transforms, a native instance pair and a PointInstancer of Points
    prototypes; saved at ``path``."""
    rng = np.random.default_rng(seed)
    stage = Usd.Stage.CreateNew(path)
    stage.SetMetadata("upAxis", "Y")
    stage.SetTimeCodesPerSecond(24.0)
    for k in range(3):
        xf = UsdGeom.Xform.Define(stage, f"/World/G{k}")
        set_matrix(xf.GetPrim(), random_matrix(rng))
        pts = define_points(stage, f"/World/G{k}/Cloud", rng, int(rng.integers(4, 12)),
                            WIDTH_MODES[int(rng.integers(len(WIDTH_MODES)))], animated)
        if rng.uniform() < 0.5:
            set_matrix(pts.GetPrim(), random_matrix(rng, spread=1.0))
    # Native instances of a prototype holding a Points prim.
    proto = stage.CreateClassPrim("/Proto")
    define_points(stage, "/Proto/Cloud", rng, 5, WIDTH_MODES[int(rng.integers(len(WIDTH_MODES)))], animated)
    set_matrix(stage.GetPrimAtPath("/Proto/Cloud"), random_matrix(rng, spread=0.5))
    for k in range(2):
        inst = stage.DefinePrim(f"/World/I{k}", "Xform")
        inst.GetReferences().AddInternalReference(proto.GetPath())
        inst.SetInstanceable(True)
        set_matrix(inst, random_matrix(rng, spread=4.0, stretch=bool(k)))
    # A PointInstancer whose prototype root (with a transform of its own) holds a Points prim.
    pi = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    set_matrix(pi.GetPrim(), random_matrix(rng, spread=2.0, stretch=False))
    root = UsdGeom.Xform.Define(stage, "/World/PI/Protos/Root")
    set_matrix(root.GetPrim(), random_matrix(rng, spread=0.5))
    define_points(stage, "/World/PI/Protos/Root/Cloud", rng, 4, WIDTH_MODES[int(rng.integers(len(WIDTH_MODES)))],
                  animated)
    pi.CreatePrototypesRel().SetTargets([root.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(-4, 4, (3, 3)).astype(np.float32)))
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(0.5, 1.5, (3, 3)).astype(np.float32)))
    q = rng.normal(size=(3, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(*map(float, row)) for row in q]))
    stage.GetRootLayer().Save()
    return stage
