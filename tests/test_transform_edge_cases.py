"""USD transform and instancing edge cases against USD's own API and float64 ray casting: PointInstancer orientations
off unit length (``ComputeInstanceTransformsAtTime``), instances flattened by a zero scale (``XformCache`` on instance
proxies, Moller-Trumbore in float64 on USD's world triangles)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, Vt  # noqa: E402

import wrt  # noqa: E402

DEFAULT = Usd.TimeCode.Default()


def load(path, **kwargs) -> wrt.Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # singular-instance and similar warnings are not the point here
        return wrt.load_usd(path, **kwargs)


def triangle(stage, path):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    return mesh


@pytest.mark.parametrize("precision", ["half", "float"])
def test_pointinstancer_orientations_off_unit_length_place_instances_as_usd_does(tmp_path, precision):
    """Orientations of length 0.6 and 1.7 (schema-invalid, but authored), unit ones rounded to ``quath``, and a zero
    quaternion: the instance transforms are ComputeInstanceTransformsAtTime's, which builds the matrix from the
    quaternion as stored (GfMatrix4d::SetRotate; Storm's shader does the same). wrt normalised them first: a rotation
    where USD has a scaled, turned one (1.7: a 2.9x larger instance turned by another angle)."""
    rng = np.random.default_rng(5)
    path = str(tmp_path / "quats.usda")
    stage = Usd.Stage.CreateNew(path)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    triangle(stage, "/PI/Proto")
    pi.CreatePrototypesRel().SetTargets(["/PI/Proto"])
    unit = rng.normal(size=(6, 4))
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    lengths = np.array([1.0, 1.0, 0.6, 1.7, 0.6, 1.7])[:, None]
    quats = np.vstack([unit * lengths, [[0.0, 0.0, 0.0, 0.0]]])  # (i, j, k, real)
    n = len(quats)
    pi.CreateProtoIndicesAttr([0] * n)
    pi.CreatePositionsAttr([Gf.Vec3f(3.0 * i, 0, 0) for i in range(n)])
    pi.CreateScalesAttr([Gf.Vec3f(1.0, 2.0, 0.5)] * n)
    if precision == "half":
        pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(float(q[3]), *map(float, q[:3])) for q in quats]))
    else:
        pi.CreateOrientationsfAttr(Vt.QuatfArray([Gf.Quatf(float(q[3]), *map(float, q[:3])) for q in quats]))
    stage.Save()

    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(DEFAULT, DEFAULT)])
    assert abs(np.linalg.det(expected[3, :3, :3])) > 2.0  # the oracle does not normalise (the point of the test)
    got = load(path).instances.to_world
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6)


def cube(stage, path):
    """A closed single-sided cube of side 2 about the origin, quads wound outwards."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    mesh.CreateFaceVertexCountsAttr([4] * 6)
    mesh.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    mesh.CreateDoubleSidedAttr(False)
    return mesh


def usd_world_triangles(stage) -> np.ndarray:
    """``(T, 3, 3)`` float64 world-space fan triangles of every mesh drawn, by USD's API: instance proxies placed by
    ``XformCache``, PointInstancer instances by ``ComputeInstanceTransformsAtTime`` times the instancer's transform."""
    xforms = UsdGeom.XformCache(DEFAULT)
    found = []

    def fan(mesh, m):
        points = np.array(mesh.GetPointsAttr().Get(), np.float64) @ m[:3, :3] + m[3, :3]
        counts, indices = mesh.GetFaceVertexCountsAttr().Get(), list(mesh.GetFaceVertexIndicesAttr().Get())
        start = 0
        for n in counts:
            face = indices[start:start + n]
            found.extend(points[[face[0], face[k], face[k + 1]]] for k in range(1, n - 1))
            start += n

    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()))
    for prim in it:
        if prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()
            pi = UsdGeom.PointInstancer(prim)
            instancer = np.array(xforms.GetLocalToWorldTransform(prim))
            protos = pi.GetPrototypesRel().GetTargets()
            for index, m in zip(pi.GetProtoIndicesAttr().Get(), pi.ComputeInstanceTransformsAtTime(DEFAULT, DEFAULT)):
                for p in Usd.PrimRange(stage.GetPrimAtPath(protos[index])):
                    if p.IsA(UsdGeom.Mesh):
                        # The prototype root's own transform is in m (IncludeProtoXform, the default).
                        root = stage.GetPrimAtPath(protos[index])
                        relative = np.array(xforms.ComputeRelativeTransform(p, root)[0]) if p != root else np.eye(4)
                        fan(UsdGeom.Mesh(p), relative @ np.array(m) @ instancer)
        elif prim.IsA(UsdGeom.Mesh) and not str(prim.GetPath()).startswith("/Lib"):
            fan(UsdGeom.Mesh(prim), np.array(xforms.GetLocalToWorldTransform(prim)))
    return np.array(found)


def closest_t(triangles: np.ndarray, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """``(N,)`` float64 distance to the nearest triangle along each ray (inf: none), Moller-Trumbore in float64;
    triangles of no area (a cube's sides flattened into lines) are never hit."""
    p0, e1, e2 = triangles[:, 0], triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    best = np.full(len(origins), np.inf)
    for a, b, c in zip(p0, e1, e2):
        if np.linalg.norm(np.cross(b, c)) < 1e-12:
            continue
        h = np.cross(directions, c)
        det = h @ b
        s = origins - a
        u = np.einsum("ij,ij->i", s, h) / det
        q = np.cross(s, b)
        v = np.einsum("ij,ij->i", q, directions) / det
        t = (q @ c) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        best = np.where(hit & (t < best), t, best)
    return best


def test_instances_flattened_by_a_zero_scale_are_drawn_flat_as_usd_draws_them(tmp_path):
    """A single-sided cube instanced natively with ``scale (1, 0, 1)`` under a turn, by a PointInstancer with
    ``scales (1, 0, 1)`` and ``(1, 0, -1)`` (flat and mirrored), and referenced plainly with the same zero scale: USD
    (and Storm) draw each as a flat sheet, as wrt draws the plain one; the instances were skipped as singular. Rays
    from above and below hit the sheets where float64 ray casting on USD's world triangles does, at its distance, and
    camera rays see them from both sides (one face of the sheet fronts each side, as its world winding gives)."""
    path = str(tmp_path / "flat.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    cube(stage, "/Lib/Box")
    stage.GetPrimAtPath("/Lib").SetSpecifier(Sdf.SpecifierClass)
    for name, x, instanceable in (("Native", -6.0, True), ("Plain", 6.0, False)):
        xf = UsdGeom.Xform.Define(stage, f"/{name}")
        xf.AddTranslateOp().Set((x, 0.5, 0))
        xf.AddRotateXYZOp().Set((20, 35, 10))
        xf.AddScaleOp().Set((1.5, 0.0, 1.0))
        xf.GetPrim().GetReferences().AddInternalReference("/Lib")
        xf.GetPrim().SetInstanceable(instanceable)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    UsdGeom.Xform.Define(stage, "/PI/Protos/Box").GetPrim().GetReferences().AddInternalReference("/Lib")
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Box"])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(0, 0, -5), (0, -0.5, 5)])
    pi.CreateScalesAttr([(1, 0, 1), (1, 0, -1)])
    pi.CreateOrientationsfAttr([Gf.Quatf(Gf.Rotation(Gf.Vec3d(1, 0.3, 0.2), 25).GetQuat())] * 2)
    stage.Save()
    expected_triangles = usd_world_triangles(Usd.Stage.Open(path))

    scene = load(path)
    assert len(scene.instances) == 3
    rng = np.random.default_rng(2)
    n = 3000
    xz = rng.uniform((-8, -7), (8, 7), (n, 2))
    for side in (1.0, -1.0):
        origins = np.column_stack([xz[:, 0], np.full(n, 10.0 * side), xz[:, 1]])
        directions = np.column_stack([rng.normal(0, 0.1, n), np.full(n, -side), rng.normal(0, 0.1, n)])
        expected = closest_t(expected_triangles, origins, directions)
        hits = wrt.trace(scene, origins, directions)
        got = np.where(hits.prim >= 0, hits.t, np.inf)
        # Rays within float rounding of a sheet's outline may go either way.
        shifted = closest_t(expected_triangles, origins + 1e-4, directions)
        with np.errstate(invalid="ignore"):  # inf - inf: both miss
            near_edge = (np.isfinite(shifted) != np.isfinite(expected)) | (np.abs(shifted - expected) > 1e-3)
        assert np.isfinite(expected).sum() > n / 20
        assert np.array_equal(np.isfinite(got)[~near_edge], np.isfinite(expected)[~near_edge]), side
        both = np.isfinite(got) & np.isfinite(expected)
        # The sheets are drawn 1e-4 of their size thick (wrt.instancing.FLAT_THICKNESS).
        np.testing.assert_allclose(got[both], expected[both], rtol=0, atol=2e-4)
        # Camera rays, with back-face culling: a sheet seen from either side shows the face fronting it.
        camera = wrt.Camera.orthographic((0, 10 * side, 0), (0, 0, 0), up=(0, 0, 1), height=18.0)
        image = wrt.render(scene, camera=camera, width=36, height=36, integrator="albedo")
        seen = image.aovs["prim"] >= 0
        eye, axes = camera.to_world[:3, 3], camera.to_world[:3, :3]
        ys, xs = np.mgrid[0:36, 0:36]
        film = np.stack([(xs + 0.5) / 36 - 0.5, 0.5 - (ys + 0.5) / 36], -1).reshape(-1, 2) * 18.0
        pixel_origins = eye + film[:, :1] * axes[:, 0] + film[:, 1:] * axes[:, 1]
        view = np.tile(-axes[:, 2], (len(film), 1))
        expected_seen = np.isfinite(closest_t(expected_triangles, pixel_origins, view)).reshape(36, 36)
        assert expected_seen.sum() > 50 and np.mean(seen == expected_seen) > 0.97, side


@pytest.mark.parametrize("instanceable", [False, True])
def test_a_sphere_flattened_by_a_zero_scale_shows_its_whole_disc_from_both_sides(tmp_path, instanceable):
    """A single-sided ``Sphere`` of radius 2 under ``scale (1, 0, 1)``, plain or in a native instance: Storm draws a
    flat disc of radius 2, its upper half's faces fronting up and its lower half's down, so camera rays (back faces
    culled) see the whole disc from above and from below. The plain one was drawn as its flat tessellation, whose
    two halves overlap without sharing edges: culled back faces hid 10 of 52 pixels from above and 42 from below."""
    path = str(tmp_path / "disc.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Sphere.Define(stage, "/Lib/Ball").CreateRadiusAttr(2.0)
    stage.GetPrimAtPath("/Lib").SetSpecifier(Sdf.SpecifierClass)
    xf = UsdGeom.Xform.Define(stage, "/Disc")
    xf.AddScaleOp().Set((1.0, 0.0, 1.0))
    xf.GetPrim().GetReferences().AddInternalReference("/Lib")
    xf.GetPrim().SetInstanceable(instanceable)
    stage.Save()
    scene = load(path)
    size = 24
    ys, xs = np.mgrid[0:size, 0:size]
    film = np.stack([(xs + 0.5) / size - 0.5, 0.5 - (ys + 0.5) / size], -1) * 6.0  # 6 units across
    inside = np.hypot(film[..., 0], film[..., 1]) < 2.0  # the disc, seen straight on (either image orientation)
    edge = np.abs(np.hypot(film[..., 0], film[..., 1]) - 2.0) < 0.1
    for side in (1.0, -1.0):
        camera = wrt.Camera.orthographic((0, 10 * side, 0), (0, 0, 0), up=(0, 0, 1), height=6.0)
        seen = wrt.render(scene, camera=camera, width=size, height=size, integrator="albedo").aovs["prim"] >= 0
        assert np.array_equal(seen[~edge], inside[~edge]), (side, int(seen.sum()), int(inside.sum()))


def test_a_ball_mesh_flattened_by_a_zero_scale_shows_its_whole_disc_from_both_sides(tmp_path):
    """A single-sided triangle-mesh ball (a Sphere's tessellation, whose halves do not mirror each other) under
    ``scale (1, 0, 1)``: Storm draws a flat disc whose upper half fronts up and lower half down, so camera rays see
    all of it from either side. Baked flat, the halves overlap without sharing edges: before coplanar partners
    (``wrt.coplanar``) culled back faces hid the fronts over them, 136 of 192 pixels were seen from above, 56 from
    below. The mesh stays flat (it is not thickened as flattened instances and gprims are)."""
    ball = str(tmp_path / "ball.usda")
    stage = Usd.Stage.CreateNew(ball)
    UsdGeom.Sphere.Define(stage, "/Ball").CreateRadiusAttr(2.0)
    stage.Save()
    tessellated = load(ball, tessellate_gprims=True).meshes[0]
    path = str(tmp_path / "flat_ball.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/Flat").AddScaleOp().Set((1.0, 0.0, 1.0))
    mesh = UsdGeom.Mesh.Define(stage, "/Flat/Ball")
    mesh.CreatePointsAttr(np.asarray(tessellated.points, np.float64).tolist())
    mesh.CreateFaceVertexCountsAttr([3] * len(tessellated.indices))
    mesh.CreateFaceVertexIndicesAttr(np.asarray(tessellated.indices).reshape(-1).tolist())
    stage.Save()
    scene = load(path)
    size = 24
    ys, xs = np.mgrid[0:size, 0:size]
    film = np.stack([(xs + 0.5) / size - 0.5, 0.5 - (ys + 0.5) / size], -1) * 6.0
    inside = np.hypot(film[..., 0], film[..., 1]) < 1.95  # inside the tessellation's outline (64 segments)
    for side in (1.0, -1.0):
        camera = wrt.Camera.orthographic((0, 10 * side, 0), (0, 0, 0), up=(0, 0, 1), height=6.0)
        seen = wrt.render(scene, camera=camera, width=size, height=size, integrator="albedo").aovs["prim"] >= 0
        assert (seen & inside).sum() == inside.sum(), (side, int((seen & inside).sum()), int(inside.sum()))
