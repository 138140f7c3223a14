"""Seeded random stages of one UsdGeom gprim, placed many ways, and the rays to compare its analytic intersection
with a fine tessellation of the same stage.

:func:`write_stage` writes one gprim (``Sphere``, ``Cube``, ``Cylinder``, ``Cone``, ``Capsule``, ``Cylinder_1``,
``Capsule_1`` or ``Plane``) with every axis, random sizes (zero and tiny ones too), an authored ``extent`` that may be
wrong, ``doubleSided`` and ``orientation`` either way, under sheared, mirrored, non-uniform, huge or tiny transforms;
placed in the world, in native instances (nested too) or by a PointInstancer (negative scales included).

:func:`gprim_rays` aims rays at every placed copy of the shape: from outside at random points of its box, from
inside, along its axis (through the centre and just off it) and grazing its surface.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, Vt

GPRIM_TYPES = ("Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Cylinder_1", "Capsule_1", "Plane")


def random_size(rng, zero_ok: bool = False) -> float:
    """A gprim size: mostly near 1, sometimes tiny, huge or (when ``zero_ok``) zero."""
    pick = rng.random()
    if zero_ok and pick < 0.08:
        return 0.0
    if pick < 0.15:
        return float(10.0 ** rng.uniform(-4, -2))
    if pick < 0.2:
        return float(10.0 ** rng.uniform(1, 3))
    return float(rng.uniform(0.2, 3.0))


def random_linear(rng) -> np.ndarray:
    """``(3, 3)`` column-vector linear map: rotation, non-uniform scale, shear, sometimes a mirror, at a random
    magnitude (1e-3 to 1e3 now and then)."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    scale = np.exp(rng.uniform(-1.0, 1.0, 3)) if rng.random() < 0.6 else np.ones(3)
    m = q @ np.diag(scale)
    if rng.random() < 0.4:
        shear = np.eye(3)
        shear[rng.integers(3), rng.integers(3)] += rng.uniform(-1.5, 1.5)
        m = m @ shear
    if rng.random() < 0.3:
        m = m @ np.diag([-1.0, 1.0, 1.0])
    if rng.random() < 0.15:
        m = m * 10.0 ** rng.choice([-3.0, -2.0, 2.0, 3.0])
    if abs(np.linalg.det(m)) < 1e-12:
        m = np.eye(3)
    return m


def random_transform(rng, spread: float = 1.0) -> np.ndarray:
    """``(4, 4)`` column-vector affine transform (:func:`random_linear` and a translation of about ``spread``)."""
    m = np.eye(4)
    m[:3, :3] = random_linear(rng)
    m[:3, 3] = rng.uniform(-spread, spread, 3)
    return m


def set_transform(prim: Usd.Prim, m: np.ndarray) -> None:
    """Authors column-vector ``m`` as the prim's ``xformOp:transform`` (USD's matrices are row-vector)."""
    UsdGeom.Xformable(prim).AddTransformOp().Set(Gf.Matrix4d(np.asarray(m, np.float64).T.tolist()))


def define_gprim(stage: Usd.Stage, path: str, rng) -> str:
    """Defines a random gprim at ``path`` (see the module docstring); returns its type name."""
    type_name = str(rng.choice(GPRIM_TYPES))
    prim = stage.DefinePrim(path, type_name)
    axis = str(rng.choice(["X", "Y", "Z"]))
    if type_name == "Sphere":
        prim.GetAttribute("radius").Set(random_size(rng, True))
    elif type_name == "Cube":
        prim.GetAttribute("size").Set(random_size(rng, True))
    elif type_name in ("Cylinder", "Cone", "Capsule"):
        prim.GetAttribute("radius").Set(random_size(rng, True))
        prim.GetAttribute("height").Set(random_size(rng, True))
    elif type_name in ("Cylinder_1", "Capsule_1"):
        for name in ("radiusTop", "radiusBottom"):
            prim.GetAttribute(name).Set(random_size(rng, True) if rng.random() < 0.7 else 0.0)
        height = random_size(rng, True)
        if rng.random() < 0.3:  # near the edge cases: radii almost equal, or their difference almost the height
            bottom = random_size(rng)
            top = bottom * (1.0 + rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-7, -2))
            if rng.random() < 0.5:
                top = bottom * float(rng.uniform(0.0, 0.9))
                height = (bottom - top) * (1.0 + rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-6, -1))
            prim.GetAttribute("radiusBottom").Set(bottom)
            prim.GetAttribute("radiusTop").Set(top)
        prim.GetAttribute("height").Set(height)
    elif type_name == "Plane":
        prim.GetAttribute("width").Set(random_size(rng, True))
        prim.GetAttribute("length").Set(random_size(rng, True))
    if type_name != "Sphere" and type_name != "Cube":
        prim.GetAttribute("axis").Set(axis)
    gprim = UsdGeom.Gprim(prim)
    gprim.CreateDoubleSidedAttr(bool(rng.random() < 0.5))
    if rng.random() < 0.4:
        gprim.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    if rng.random() < 0.3:  # an extent, right or not: it bounds nothing that is drawn
        gprim.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*rng.uniform(-2, 0, 3)), Gf.Vec3f(*rng.uniform(0, 2, 3))]))
    if rng.random() < 0.6:
        set_transform(prim, random_transform(rng))
    return type_name


def write_stage(path: str, seed: int) -> dict:
    """Writes stage ``seed`` to ``path``; returns what it made (``type``, ``placement``)."""
    rng = np.random.default_rng(seed)
    stage = Usd.Stage.CreateNew(path)
    world = UsdGeom.Xform.Define(stage, "/World").GetPrim()
    if rng.random() < 0.5:
        set_transform(world, random_transform(rng))
    placement = str(rng.choice(["world", "instances", "nested", "instancer"]))
    if placement == "world":
        type_name = define_gprim(stage, "/World/G", rng)
    elif placement in ("instances", "nested"):
        stage.CreateClassPrim("/Protos")
        proto = UsdGeom.Xform.Define(stage, "/Protos/P").GetPrim()
        type_name = define_gprim(stage, "/Protos/P/G", rng)
        target = "/Protos/P"
        if placement == "nested":
            outer = UsdGeom.Xform.Define(stage, "/Protos/Outer").GetPrim()
            for k in range(2):
                inner = UsdGeom.Xform.Define(stage, f"/Protos/Outer/In{k}").GetPrim()
                inner.GetReferences().AddInternalReference("/Protos/P")
                inner.SetInstanceable(True)
                set_transform(inner, random_transform(rng, 3.0))
            target = str(outer.GetPath())
        del proto
        for k in range(int(rng.integers(1, 4))):
            instance = UsdGeom.Xform.Define(stage, f"/World/I{k}").GetPrim()
            instance.GetReferences().AddInternalReference(target)
            instance.SetInstanceable(True)
            set_transform(instance, random_transform(rng, 6.0))
    else:
        instancer = UsdGeom.PointInstancer.Define(stage, "/World/PI")
        UsdGeom.Xform.Define(stage, "/World/PI/Protos")
        type_name = define_gprim(stage, "/World/PI/Protos/G", rng)
        instancer.CreatePrototypesRel().SetTargets(["/World/PI/Protos/G"])
        n = int(rng.integers(1, 5))
        instancer.CreateProtoIndicesAttr(Vt.IntArray([0] * n))
        instancer.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in rng.uniform(-6, 6, (n, 3))]))
        quats = rng.normal(size=(n, 4))
        quats /= np.linalg.norm(quats, axis=1, keepdims=True)
        instancer.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(float(q[0]), *map(float, q[1:])) for q in quats]))
        scales = rng.uniform(0.3, 2.0, (n, 3)) * rng.choice([-1.0, 1.0], (n, 3), p=[0.2, 0.8])
        instancer.CreateScalesAttr(Vt.Vec3fArray([Gf.Vec3f(*s) for s in scales]))
    stage.GetRootLayer().Save()
    return {"type": type_name, "placement": placement}


def placed_shapes(scene) -> list[tuple[np.ndarray, object]]:
    """``(canonical-to-world (4, 4), shape)`` of every drawn copy of every analytic shape of ``scene``."""
    out = [(s.to_world, s) for s in scene.shapes]
    for to_world, proto in zip(scene.instances.to_world, scene.instances.prototype):
        out += [(to_world @ s.to_world, s) for s in scene.prototypes[proto].shapes]
    return out


def gprim_rays(scene, rng, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(origins, directions, aimed)``: ``(N, 3)`` float64 world space and ``(N,)`` the row of
    :func:`placed_shapes` each ray is aimed at, aimed at the placed shapes of analytic ``scene``:
    half from outside through random points of the shape's box (1.3 times its size), a sixth from inside, a sixth
    along the axis (through the centre or just off it, either way) and a sixth grazing (perpendicular to the line
    from the centre)."""
    placed = placed_shapes(scene)
    if not placed:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)
    origins, directions = [], []
    aimed = rng.integers(len(placed), size=n)
    for k in range(n):
        m, shape = placed[aimed[k]]
        lower, upper = shape.local_bounds()
        lower, upper = np.where(upper - lower > 0, lower, -1.0), np.where(upper - lower > 0, upper, 1.0)
        centre_c = (lower + upper) / 2
        half = (upper - lower) / 2
        kind = k % 6
        if kind < 3:  # from outside through a point of the box
            target = centre_c + half * rng.uniform(-1.3, 1.3, 3)
            d = rng.normal(size=3)
            o = target - d / np.linalg.norm(d) * (4.0 * np.abs(half).max())
        elif kind == 3:  # from inside
            o = centre_c + half * rng.uniform(-0.6, 0.6, 3)
            d = rng.normal(size=3)
        elif kind == 4:  # along the axis
            side = rng.choice([-1.0, 1.0])
            o = centre_c + [0.0, 0.0, side * (3.0 * half[2] + 1.0)]
            if rng.random() < 0.5:
                o[:2] += rng.normal(scale=0.01, size=2)
            d = np.array([0.0, 0.0, -side])
        else:  # grazing: perpendicular to the line from the centre to a point about the surface's distance away
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            p = centre_c + u * rng.uniform(0.9, 1.1)
            d = np.cross(u, rng.normal(size=3))
            o = p - d / np.linalg.norm(d) * 4.0 * np.abs(half).max()
        origins.append(m[:3, :3] @ o + m[:3, 3])
        directions.append(m[:3, :3] @ d * float(10.0 ** rng.uniform(-1, 1)))  # lengths other than 1
    return np.array(origins), np.array(directions), aimed
