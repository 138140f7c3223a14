"""Seeded random USD stages of small meshes seen by a random camera, and what the camera sees, per pixel, by USD's
own API and float64 brute force.

:func:`write_stage` writes convex polygons (triangles to octagons, quads), several polygons in one mesh (one of them
sometimes a hole), and small closed polyhedra (tetrahedra, cuboids, octahedra, prisms), some ``doubleSided``, some
``leftHanded``, under Xforms of random translate / rotate / scale ops and matrices (negative and uneven scales and
shears, so some are mirrored); some placed as native instances (instanceable prims referencing a prototype: an
abstract ``class`` or a prim drawn in place too, nested in other prototypes), some by a PointInstancer (positions,
``orientationsf``, scales with negative, uneven and zero ones; prototypes a mesh, an Xform of meshes and native
instances, or another PointInstancer; instancers inside native prototypes too); sometimes a closed room around
everything; and a ``UsdGeom.Camera`` (perspective, wide-angle too, or orthographic; random film, aperture offsets,
a clipping range that sometimes cuts the geometry; scaled and sheared, never mirrored) under a rotated, scaled rig.
No two faces are coplanar and overlapping (the placements are random floats).

:func:`camera_view` is the oracle: see its docstring for the rules it follows.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom, Vt

WIDTH, HEIGHT = 40, 30  # image size of the comparison


# Stage --------------------------------------------------------------------------------------------------------------


def _ellipse_polygon(rng, n: int) -> np.ndarray:
    """``(n, 3)`` corners of a convex planar polygon: points of a random ellipse in a random plane, by angle, CCW
    about the plane's normal ``u x v``, at least 0.25 rad apart (no sliver corners)."""
    u, v = np.linalg.qr(rng.normal(size=(3, 2)))[0].T
    while True:
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * np.pi]))
        if gaps.min() > 0.25:
            break
    a, b = rng.uniform(0.6, 1.6, 2)
    return a * np.cos(angles)[:, None] * u + b * np.sin(angles)[:, None] * v


# Closed polyhedra, faces counter-clockwise seen from outside (right-handed: outward normals).
_TETRA = ([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
_BOX = ([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)],
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
_OCTA = ([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
         [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
_PRISM = ([[1, 0, -1], [-0.5, 0.87, -1], [-0.5, -0.87, -1], [1, 0, 1], [-0.5, 0.87, 1], [-0.5, -0.87, 1]],
          [[0, 2, 1], [3, 4, 5], [0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]])
POLYHEDRA = (_TETRA, _BOX, _OCTA, _PRISM)


def random_mesh_data(rng, polyhedron: bool = False) -> tuple[list, list, np.ndarray, str]:
    """``(face vertex counts, face vertex indices, (N, 3) points, kind)`` of one random mesh (module docstring), a
    closed polyhedron if ``polyhedron``."""
    pick = 0.0 if polyhedron else rng.random()
    if pick < 0.35:
        points, faces = POLYHEDRA[int(rng.integers(len(POLYHEDRA)))]
        points = np.array(points, float) * rng.uniform(0.5, 1.2, 3)  # uneven: a box is a cuboid
        return [len(f) for f in faces], [i for f in faces for i in f], points, "polyhedron"
    polygons = [_ellipse_polygon(rng, int(rng.choice([3, 4, 4, 5, 6, 8])))
                for _ in range(1 if pick < 0.7 else int(rng.integers(2, 4)))]
    if len(polygons) > 1:  # apart, so they do not overlap
        polygons = [p + rng.uniform(-2.0, 2.0, 3) for p in polygons]
    counts = [len(p) for p in polygons]
    return counts, list(range(sum(counts))), np.concatenate(polygons), "polygons"


def random_ops(rng, xformable: UsdGeom.Xformable, spread: float = 2.0, mirror: float = 0.3):
    """Random translate, rotate and scale ops (the scale uneven, negative on some axes with chance ``mirror``)."""
    if rng.random() < 0.9:
        xformable.AddTranslateOp().Set(Gf.Vec3d(*rng.uniform(-spread, spread, 3)))
    if rng.random() < 0.8:
        kind = str(rng.choice(["XYZ", "ZYX", "X", "Y", "Z"]))
        angles = rng.uniform(-180, 180, 3)
        if len(kind) == 3:
            getattr(xformable, f"AddRotate{kind}Op")().Set(Gf.Vec3f(*angles))
        else:
            getattr(xformable, f"AddRotate{kind}Op")().Set(float(angles[0]))
    if rng.random() < 0.7:
        scale = rng.uniform(0.5, 1.6, 3) if rng.random() < 0.6 else np.full(3, rng.uniform(0.5, 1.6))
        scale *= np.where(rng.random(3) < mirror, -1.0, 1.0)
        xformable.AddScaleOp().Set(Gf.Vec3f(*scale))
    if rng.random() < 0.2:  # a second rotation after the scale: a sheared placement
        xformable.AddRotateXYZOp(opSuffix="after").Set(Gf.Vec3f(*rng.uniform(-180, 180, 3)))
    if rng.random() < 0.15:  # a matrix: sheared, mirrored or not
        m = np.eye(4)
        m[:3, :3] += rng.uniform(-0.5, 0.5, (3, 3))
        m[:3, :3] *= rng.choice([-1.0, 1.0])
        xformable.AddTransformOp(opSuffix="shear").Set(Gf.Matrix4d(m.tolist()))


def define_mesh(stage: Usd.Stage, path: str, rng) -> UsdGeom.Mesh:
    counts, indices, points, _ = random_mesh_data(rng)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(indices)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    if rng.random() < 0.3:
        mesh.CreateDoubleSidedAttr(True)
    if rng.random() < 0.3:
        mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    if len(counts) > 1 and rng.random() < 0.15:
        mesh.CreateHoleIndicesAttr([int(rng.integers(len(counts)))])
    if rng.random() < 0.5:
        random_ops(rng, mesh, spread=1.0)
    return mesh


def define_group(stage: Usd.Stage, path: str, rng, depth: int = 1, leaves: tuple = (), instancers: bool = False):
    """An Xform of random ops holding 1 to 3 children: meshes, ``depth`` levels down groups, native instances of the
    ``leaves`` (class prims of meshes) and, with ``instancers``, a PointInstancer."""
    random_ops(rng, UsdGeom.Xform.Define(stage, path))
    for k in range(int(rng.integers(1, 4))):
        pick = rng.random()
        if depth > 0 and pick < 0.2:
            define_group(stage, f"{path}/G{k}", rng, depth - 1, leaves, instancers)
        elif leaves and pick < 0.35:
            define_instance(stage, f"{path}/I{k}", rng, str(rng.choice(leaves)))
        elif instancers and pick < 0.45:
            define_instancer(stage, f"{path}/PI{k}", rng, leaves)
        else:
            define_mesh(stage, f"{path}/M{k}", rng)


def define_instance(stage: Usd.Stage, path: str, rng, source: str):
    """An instanceable Xform of random ops referencing ``source``."""
    inst = UsdGeom.Xform.Define(stage, path)
    random_ops(rng, inst)
    inst.GetPrim().GetReferences().AddInternalReference(source)
    inst.GetPrim().SetInstanceable(True)


def define_instancer(stage: Usd.Stage, path: str, rng, leaves: tuple = (), nested: bool = True):
    """A PointInstancer of 1 to 5 instances of 1 or 2 prototypes under it: a mesh, an Xform of meshes and native
    instances of the ``leaves``, or (when ``nested``) a PointInstancer."""
    pi = UsdGeom.PointInstancer.Define(stage, path)
    random_ops(rng, pi, spread=1.0)
    protos = []
    for k in range(int(rng.integers(1, 3))):
        proto = f"{path}/Protos/P{k}"
        pick = rng.random()
        if pick < 0.4:
            define_mesh(stage, proto, rng)
        elif pick < 0.5 and nested:
            define_instancer(stage, proto, rng, leaves, nested=False)
        else:
            define_group(stage, proto, rng, depth=0, leaves=leaves)
        protos.append(proto)
    n = int(rng.integers(1, 6))
    pi.CreatePrototypesRel().SetTargets(protos)
    pi.CreateProtoIndicesAttr(Vt.IntArray([int(i) for i in rng.integers(0, len(protos), n)]))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(-2, 2, (n, 3)).astype(np.float32)))
    if rng.random() < 0.7:
        q = rng.normal(size=(n, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        pi.CreateOrientationsfAttr([Gf.Quatf(*map(float, r)) for r in q])
    if rng.random() < 0.7:
        scales = rng.uniform(0.5, 1.5, (n, 3)) * np.where(rng.random((n, 3)) < 0.25, -1.0, 1.0)
        if rng.random() < 0.15:  # an instance scaled to nothing: its transform has no inverse
            scales[rng.integers(n)] = 0.0
        pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(scales.astype(np.float32)))


def _look_at(eye, target, rng) -> Gf.Matrix4d:
    """Row-vector camera transform at ``eye`` looking (down its -Z) at ``target``, rolled at random."""
    forward = np.asarray(target, float) - eye
    forward /= np.linalg.norm(forward)
    up = rng.normal(size=3)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3], m[3, :3] = right, up, -forward, eye
    return Gf.Matrix4d(m.tolist())


def define_camera(stage: Usd.Stage, path: str, rng, centre: np.ndarray):
    """A camera 5 to 10 units from a point near ``centre``, looking at it, sometimes scaled (its world transform a
    rotation and a positive uniform scale, or now and then a shear and uneven scale of positive determinant: a
    mirrored camera flips the picture, not this hunt's business) under a rotated and scaled rig."""
    rig = UsdGeom.Xform.Define(stage, "/Rig")
    scale = float(rng.uniform(0.5, 2.0)) if rng.random() < 0.4 else 1.0
    rotate = Gf.Vec3f(*rng.uniform(-180, 180, 3))
    rig.AddRotateXYZOp().Set(rotate)
    rig.AddScaleOp().Set(Gf.Vec3f(float(rng.uniform(0.5, 2.0))))
    rig_m = np.array(rig.GetLocalTransformation())
    distance = float(rng.uniform(5.0, 10.0))
    direction = rng.normal(size=3)
    target = centre + rng.uniform(-1.0, 1.0, 3)
    eye = target + distance * direction / np.linalg.norm(direction)
    world = np.array(_look_at(eye, target, rng))
    cam = UsdGeom.Camera.Define(stage, path)
    world = np.diag([scale, scale, scale, 1.0]) @ world  # camera space is the world's divided by ``scale``
    if rng.random() < 0.2:  # sheared and unevenly scaled, not mirrored
        shear = np.eye(4)
        shear[:3, :3] += np.triu(rng.uniform(-0.3, 0.3, (3, 3)), 1)
        world = np.diag([*rng.uniform(0.7, 1.4, 3), 1.0]) @ shear @ world
    UsdGeom.Xformable(cam).AddTransformOp().Set(Gf.Matrix4d((world @ np.linalg.inv(rig_m)).tolist()))
    ortho = rng.random() < 0.35
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic if ortho else UsdGeom.Tokens.perspective)
    h_ap = float(rng.uniform(40.0, 100.0) if ortho else rng.uniform(20.0, 40.0))
    cam.CreateHorizontalApertureAttr(h_ap)
    cam.CreateVerticalApertureAttr(float(h_ap * rng.uniform(0.5, 1.2)))
    cam.CreateFocalLengthAttr(float(rng.uniform(15.0, 35.0) if rng.random() < 0.8 else rng.uniform(3.0, 10.0)))
    if rng.random() < 0.6:
        cam.CreateHorizontalApertureOffsetAttr(float(rng.normal(0.0, 0.15 * h_ap)))
        cam.CreateVerticalApertureOffsetAttr(float(rng.normal(0.0, 0.15 * h_ap)))
    # Camera-space clipping (the rig's scale divides world distances): sometimes cutting into the geometry.
    near = rng.uniform(0.01, 1.0) if rng.random() < 0.7 else rng.uniform(max(distance - 2.0, 0.01), distance)
    far = rng.uniform(distance + 5.0, distance + 50.0) if rng.random() < 0.7 else rng.uniform(distance, distance + 2)
    cam.CreateClippingRangeAttr(Gf.Vec2f(float(near / scale), float(max(far, near + 0.5) / scale)))


def write_stage(path: str, seed: int) -> str:
    """Writes stage ``seed`` (module docstring) at ``path``; returns the camera's path."""
    rng = np.random.default_rng(seed)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, str(rng.choice([UsdGeom.Tokens.y, UsdGeom.Tokens.z])))
    world = UsdGeom.Xform.Define(stage, "/World")
    random_ops(rng, world, spread=1.0, mirror=0.15)
    leaves = []  # class prims of meshes that instances anywhere (in other prototypes too) may reference
    for k in range(int(rng.integers(0, 3))):
        leaves.append(f"/_leaf{k}")
        stage.CreateClassPrim(leaves[-1])
        define_group(stage, f"{leaves[-1]}/Body", rng, depth=0)
    leaves = tuple(leaves)
    for k in range(int(rng.integers(2, 5))):
        define_group(stage, f"/World/G{k}", rng, leaves=leaves, instancers=True)
    for k in range(int(rng.integers(0, 3))):  # native instances of a prototype, abstract or drawn in place
        if rng.random() < 0.5:
            source = f"/_proto{k}"
            stage.CreateClassPrim(source)
            define_group(stage, f"{source}/Body", rng, leaves=leaves, instancers=True)
        else:
            source = f"/World/Source{k}"
            define_group(stage, source, rng, leaves=leaves, instancers=True)
        for j in range(int(rng.integers(1, 4))):
            define_instance(stage, f"/World/Inst{k}_{j}", rng, source)
    for k in range(int(rng.integers(0, 3))):
        define_instancer(stage, f"/World/PI{k}", rng, leaves)
    bound = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_]).ComputeWorldBound(
        stage.GetPseudoRoot())
    centre = np.array(bound.ComputeAlignedRange().GetMidpoint()) if not bound.GetRange().IsEmpty() else np.zeros(3)
    define_camera(stage, "/Rig/Cam", rng, centre)
    if rng.random() < 0.25:  # a closed room around everything, the camera inside: seen only where its inside is front
        counts, indices, points, _ = random_mesh_data(rng, polyhedron=True)
        room = UsdGeom.Mesh.Define(stage, "/World/Room")
        room.CreateFaceVertexCountsAttr(counts)
        room.CreateFaceVertexIndicesAttr(indices)
        room.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
        room.CreateOrientationAttr(str(rng.choice([UsdGeom.Tokens.rightHanded, UsdGeom.Tokens.leftHanded])))
        room.CreateDoubleSidedAttr(bool(rng.random() < 0.3))
        world_m = np.array(world.GetLocalTransformation())
        size = float(rng.uniform(25.0, 40.0) / abs(np.linalg.det(world_m[:3, :3])) ** (1 / 3))
        room.AddTranslateOp().Set(Gf.Vec3d(*(np.append(centre, 1.0) @ np.linalg.inv(world_m))[:3]))
        room.AddScaleOp().Set(Gf.Vec3f(size))
    stage.GetRootLayer().Save()
    return "/Rig/Cam"


# Oracle -------------------------------------------------------------------------------------------------------------


class Triangles:
    """World-space fan triangles of the meshes a stage draws, with what each belongs to (arrays of length T)."""

    def __init__(self):
        self.corners = []  # (3, 3) float64 world-space corners, in the mesh's winding
        self.front = []  # (3,) float64 unit normal of the side a camera ray sees of a single-sided mesh
        self.double_sided = []  # bool
        self.flipped = []  # bool: the front is the back of the world-space winding (leftHanded xor mirrored)
        self.boundary = []  # (3,) bool: edge k (corner k to corner k+1) is the polygon's edge, not a fan diagonal
        self.prim = []  # str: the path the mesh is drawn at
        self.instance = []  # str: the native instance or ``/PI[i]`` ("" for none)
        self.face = []  # int: the face of the mesh

    def add_mesh(self, mesh: UsdGeom.Mesh, to_world: np.ndarray, prim: str, instance: str):
        points = np.array(mesh.GetPointsAttr().Get(), np.float64)
        points = points @ to_world[:3, :3] + to_world[3, :3]
        counts = mesh.GetFaceVertexCountsAttr().Get()
        indices = np.array(mesh.GetFaceVertexIndicesAttr().Get(), int)
        flip = (mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded) != (np.linalg.det(to_world[:3, :3]) < 0)
        double_sided = bool(mesh.GetDoubleSidedAttr().Get())
        holes = set(mesh.GetHoleIndicesAttr().Get() or [])
        start = 0
        for f, n in enumerate(counts):
            face = indices[start:start + n]
            start += n
            if f in holes:
                continue
            for k in range(1, n - 1):  # the fan from the face's first corner
                corners = points[[face[0], face[k], face[k + 1]]]
                normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
                if not np.linalg.norm(normal) > 0:  # an instance scaled to nothing
                    continue
                self.corners.append(corners)
                self.front.append((-normal if flip else normal) / np.linalg.norm(normal))
                self.double_sided.append(double_sided)
                self.flipped.append(flip)
                self.boundary.append((k == 1, True, k == n - 2))
                self.prim.append(prim)
                self.instance.append(instance)
                self.face.append(f)

    def arrays(self):
        return (np.array(self.corners).reshape(-1, 3, 3), np.array(self.front).reshape(-1, 3),
                np.array(self.double_sided, bool), np.array(self.boundary, bool).reshape(-1, 3))


def stage_triangles(stage: Usd.Stage) -> Triangles:
    """The triangles ``stage`` draws at the default time, by USD's API (``Camera.camera_view`` docstring)."""
    tc = Usd.TimeCode.Default()
    xforms = UsdGeom.XformCache(tc)
    out = Triangles()
    it = iter(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    for prim in it:
        if prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()  # its prototypes are drawn only through it
            _add_instances(prim, np.array(xforms.GetLocalToWorldTransform(prim)), xforms, out, None)
        elif prim.IsA(UsdGeom.Mesh):
            instance = ""
            p = prim
            while p and not p.IsPseudoRoot():
                if p.IsInstance():
                    instance = str(p.GetPath())
                    break
                p = p.GetParent()
            out.add_mesh(UsdGeom.Mesh(prim), np.array(xforms.GetLocalToWorldTransform(prim)), str(prim.GetPath()),
                         instance)
    return out


def _add_instances(prim: Usd.Prim, to_world: np.ndarray, xforms: UsdGeom.XformCache, out: Triangles,
                   name: str | None):
    """Adds the triangles of PointInstancer ``prim``'s instances, the instancer placed by row-vector ``to_world``;
    each named ``name`` or, for None, ``/PI[i]`` after its own index (an instancer in a prototype of another is named
    by the outer one's instance)."""
    tc = Usd.TimeCode.Default()
    pi = UsdGeom.PointInstancer(prim)
    transforms = pi.ComputeInstanceTransformsAtTime(tc, tc)  # the prototype root's own transform included
    protos = [prim.GetStage().GetPrimAtPath(p) for p in pi.GetPrototypesRel().GetTargets()]
    for i, (index, m) in enumerate(zip(pi.GetProtoIndicesAttr().Get(), transforms)):
        root, instance = protos[index], name or f"{prim.GetPath()}[{i}]"
        it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for part in it:
            rel = np.array(xforms.ComputeRelativeTransform(part, root)[0]) if part != root else np.eye(4)
            if part.IsA(UsdGeom.PointInstancer):
                it.PruneChildren()
                _add_instances(part, rel @ np.array(m) @ to_world, xforms, out, instance)
            elif part.IsA(UsdGeom.Mesh):
                out.add_mesh(UsdGeom.Mesh(part), rel @ np.array(m) @ to_world, str(part.GetPath()), instance)


def camera_rays(stage: Usd.Stage, camera: str, width: int, height: int):
    """``(near points, far points, eye, eye-plane normal, orthographic)``: each pixel centre's ray from the near to
    the far clipping plane, rows from the top, float64, by USD's own frustum (``GfCamera``) conformed to the image
    by ``expandAperture`` (UsdRender's fallback policy), its projection after the inverse of the camera's whole
    transform (Hydra's view matrix)."""
    usd_camera = UsdGeom.Camera(stage.GetPrimAtPath(camera)).GetCamera(Usd.TimeCode.Default())
    frustum = usd_camera.frustum
    window = frustum.GetWindow()
    (w, h), centre = window.GetSize(), window.GetMidpoint()
    w, h = max(w, h * width / height), max(h, w * height / width)  # expandAperture: grown, never cut
    frustum.SetWindow(Gf.Range2d(centre - Gf.Vec2d(w / 2, h / 2), centre + Gf.Vec2d(w / 2, h / 2)))
    to_world = np.array(usd_camera.transform)
    clip_to_world = np.linalg.inv(np.linalg.inv(to_world) @ np.array(frustum.ComputeProjectionMatrix()))
    i, j = (a.ravel() for a in np.meshgrid(np.arange(height), np.arange(width), indexing="ij"))
    ndc = np.stack([2 * (j + 0.5) / width - 1, 1 - 2 * (i + 0.5) / height], axis=1)
    ends = [np.concatenate([ndc, np.full((len(ndc), 1), z), np.ones((len(ndc), 1))], axis=1) @ clip_to_world
            for z in (-1.0, 1.0)]
    near, far = (e[:, :3] / e[:, 3:] for e in ends)
    ortho = usd_camera.projection == Gf.Camera.Orthographic
    return near, far, to_world[3, :3], to_world[:3, :3], ortho


def camera_view(stage: Usd.Stage, camera: str, width: int = WIDTH, height: int = HEIGHT, edge: float = 2e-3,
                tie: float = 1e-4, grazing: float = 0.02) -> dict:
    """What each pixel centre's camera ray sees, by float64 brute force over USD's triangles.

    Rules, written from USD's documentation and Hydra's behaviour (not from wrt):

    - Triangles: each mesh's faces fanned from their first corner, moved to world space by ``XformCache``'s
      local-to-world transform (on instance proxies for native instances: the prim is drawn at its proxy path, the
      instance is the instanceable prim), and by ``ComputeInstanceTransformsAtTime`` (the prototype root's own
      transform included) times the instancer's world transform for a PointInstancer's instances, drawn at the
      prototype's own path as instance ``/PI[i]``; the prototypes under the instancer are drawn only through it.
    - Rays: each pixel centre's NDC through USD's frustum (:func:`camera_rays`), from the near clipping plane to the
      far one (clipping planes perpendicular to the view axis, camera-space depths).
    - Sides (UsdGeomGprim ``orientation``; UsdGeom's "Coordinate System, Winding Order, Orientation, and Surface
      Normals"): a face's front is the side from which its corners run counter-clockwise (``rightHanded``: the
      normal ``(p1 - p0) x (p2 - p1)`` by the right-hand rule), clockwise for ``leftHanded``; and a transform of
      negative determinant (an odd number of mirroring scales; for instances the whole chain, instance transform
      included) flips the side again, since the orientation is the gprim's in its own space (normals move by the
      inverse transpose, which keeps the front the front under a mirror). So in world space the front normal is the
      world winding's cross product, negated once for ``leftHanded`` and once for a mirroring transform.
    - Culling: a camera ray does not see the back of a single-sided mesh (``doubleSided = false``, the fallback):
      it passes through and sees what lies behind (Hydra's back-face culling of camera rays, as usdview draws);
      ``doubleSided`` meshes are seen from both sides.
    - Depth: the distance along the ray from the eye (perspective) or from the camera's eye plane (orthographic),
      as wrt's ``depth`` AOV is documented; ``z``: the distance along the camera's view axis (its -Z, in world
      units); ``normal``: the seen face's unit normal, turned to face the ray. Faces in ``holeIndices`` are not drawn.

    Pixels where the answer is not well defined in float32 are left out (``valid`` False): the ray passes within
    ``edge`` (times the scene's size) of a polygon's edge of a face in front of (or at) the one seen; two seen
    candidates lie within ``tie`` (relative) of each other along the ray; the ray meets a face in front at a cosine
    below ``grazing`` (float32 rounding of the hit grows as one over it); or a candidate lies within ``tie`` of a
    clipping plane.

    Returns:
        dict of ``(H, W)`` arrays: ``valid`` bool, ``hit`` bool, ``prim`` / ``instance`` str, ``face`` int, ``depth``
        and ``z`` float64, ``normal`` ``(H, W, 3)``, and for coverage ``culled`` (the ray passed the back of a
        single-sided face before what it sees) and ``flipped`` (the face seen is a leftHanded or mirrored one, not
        both); plus ``triangles`` (count) and ``orthographic`` (bool).
    """
    tris = stage_triangles(stage)
    corners, front, double_sided, boundary = tris.arrays()
    near, far, eye, axes, ortho = camera_rays(stage, camera, width, height)
    n_pix = len(near)
    prim, instance = np.array(tris.prim + [""], object), np.array(tris.instance + [""], object)
    face = np.array(tris.face + [-1])
    out = {"valid": np.ones(n_pix, bool), "hit": np.zeros(n_pix, bool), "depth": np.full(n_pix, np.inf),
           "z": np.full(n_pix, np.inf), "culled": np.zeros(n_pix, bool), "flipped": np.zeros(n_pix, bool),
           "normal": np.zeros((n_pix, 3)), "triangles": len(corners)}
    seen_index = np.full(n_pix, -1)
    if len(corners):
        scale = max(np.abs(corners).max(), np.abs(eye).max(), 1.0)
        d = far - near  # (P, 3): s in [0, 1] runs from the near plane to the far one
        a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
        e1, e2 = b - a, c - a
        n = np.cross(e1, e2)  # (T, 3)
        denom = d @ n.T  # (P, T)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = ((a * n).sum(1)[None, :] - near @ n.T) / denom
            x = near[:, None, :] + s[..., None] * d[:, None, :]  # (P, T, 3) point on each plane
            # Barycentric weights of the corners, then each corner's distance to its opposite edge.
            area2 = (n * n).sum(1)
            w1 = (np.cross(x - a, e2) * n).sum(-1) / area2  # weight of b
            w2 = (np.cross(e1, x - a) * n).sum(-1) / area2  # weight of c
            w0 = 1.0 - w1 - w2
        # Distance from the plane point to each edge's line: weight of the opposite corner times its altitude.
        lengths = np.stack([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                            np.linalg.norm(a - c, axis=1)], 1)
        altitude = np.sqrt(area2)[:, None] / lengths  # (T, 3): edge 0 = ab (opposite c), 1 = bc (a), 2 = ca (b)
        dist = np.stack([w2, w0, w1], -1) * altitude[None]  # (P, T, 3) signed, positive inside
        finite = np.isfinite(s) & np.isfinite(dist).all(-1)
        inside = finite & (dist > 0).all(-1)
        unit_d = d / np.linalg.norm(d, axis=1, keepdims=True)
        cosine = np.abs(unit_d @ (n / np.sqrt(area2)[:, None]).T)
        facing = (unit_d @ front.T) < 0  # the ray meets the front
        seeable = double_sided[None, :] | facing
        visible = inside & seeable & (s >= 0) & (s <= 1)
        s_seen = np.where(visible, s, np.inf).min(1)  # (P,)
        seen_index = np.where(np.isfinite(s_seen), np.where(visible, s, np.inf).argmin(1), -1)
        culled = (inside & ~seeable & (s >= 0) & (s < s_seen[:, None])).any(1)  # seen through a back face
        # Left out: what lies in front of (or at) the seen hit and near an edge, a clipping plane, a tie or edge-on.
        span = np.linalg.norm(d, axis=1)  # s units to world units
        reach = np.minimum(s_seen, 1.0)[:, None] + tie + (edge * scale) / span[:, None]
        ahead = finite & (s > -tie) & (s <= reach)
        near_edge = ((np.abs(dist) < edge * scale) & boundary[None] & (dist > -edge * scale).all(-1)[..., None])
        bad = ahead & near_edge.any(-1)
        close_inside = finite & (dist > -edge * scale).all(-1) & seeable
        bad |= close_inside & ((np.abs(s) < tie) | (np.abs(s - 1) < tie))
        bad |= close_inside & ahead & (cosine < grazing)
        others = close_inside & (np.abs(s - s_seen[:, None]) <= tie * (1 + np.abs(s_seen[:, None])))
        others[np.arange(n_pix), np.maximum(seen_index, 0)] = False
        bad |= others & np.isfinite(s_seen)[:, None]
        out["valid"] = ~bad.any(1)
        hit = seen_index >= 0
        out["hit"] = hit
        points = near + np.where(hit, s_seen, 0.0)[:, None] * d
        if ortho:  # from the plane through the eye spanned by the camera's x and y axes
            eye_axis = np.cross(axes[0], axes[1])
            depth = np.abs(((points - eye) @ eye_axis) / (unit_d @ eye_axis))
        else:
            depth = np.linalg.norm(points - eye, axis=1)
        out["depth"] = np.where(hit, depth, np.inf)
        out["z"] = np.where(hit, (points - eye) @ (-axes[2] / np.linalg.norm(axes[2])), np.inf)
        normal = front[np.maximum(seen_index, 0)]
        normal = np.where(((normal * unit_d).sum(1) > 0)[:, None], -normal, normal)
        out["normal"] = np.where(hit[:, None], normal, 0.0)
        out["culled"] = culled
        out["flipped"] = hit & np.array(tris.flipped + [False])[seen_index]
    out["prim"], out["instance"], out["face"] = prim[seen_index], instance[seen_index], face[seen_index]
    for key in ("valid", "hit", "depth", "z", "prim", "instance", "face", "culled", "flipped"):
        out[key] = out[key].reshape(height, width)
    out["normal"] = out["normal"].reshape(height, width, 3)
    out["orthographic"] = ortho
    return out
