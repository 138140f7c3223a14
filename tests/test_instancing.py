"""Instancing: PointInstancers and native instances load as prototypes plus instances (never flattened), trace
through the two-level BVH in agreement with ``wp.Mesh`` on the flattened ``Scene.triangles()``, shade exactly like
their flattened copies (mirrored, sheared and non-uniformly scaled ones included), and cost at most 128 bytes of
device memory each. Bad instancer data raises or is skipped with the prim path named.
"""

from __future__ import annotations

import importlib
import re
import warnings

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt  # noqa: E402

import wrt  # noqa: E402
from wrt.compare import compare_hits, near_edge_world  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.rays import camera_rays, random_rays  # noqa: E402
from wrt.scene import Mesh  # noqa: E402
from wrt.trace import check_finite_transforms, get_accelerator  # noqa: E402

MAX_TIE_FRACTION = 1e-4  # as tests/test_trace.py
MAX_BYTES_PER_INSTANCE = 128  # the issue's bound on device memory per instance


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path, **kwargs)


def octahedron(stage, path, color=(0.8, 0.3, 0.2)):
    """A closed, single-sided octahedron with authored vertex normals and a displayColor."""
    pts = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    faces = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in pts])
    mesh.CreateFaceVertexCountsAttr([3] * len(faces))
    mesh.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)  # polygonal: USD ignores a subdivision mesh's normals
    mesh.CreateNormalsAttr([Gf.Vec3f(*p) for p in pts])
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateDisplayColorPrimvar().Set([Gf.Vec3f(*color)])
    mesh.CreateDoubleSidedAttr(False)
    return mesh


def random_affine(rng, n, mirror_every=3):
    """``(n, 4, 4)`` column-vector transforms: rotation, non-uniform scale, shear, translation; every
    ``mirror_every``-th one mirrored."""
    m = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        scale = np.diag(rng.uniform(0.4, 1.6, 3) * (-1 if i % mirror_every == 0 else 1))
        shear = np.eye(3)
        shear[0, 1], shear[1, 2] = rng.uniform(-0.5, 0.5, 2)
        m[i, :3, :3] = q @ shear @ scale
    m[:, :3, 3] = rng.uniform(-6, 6, (n, 3))
    return m


def python_scene(rng, n=60) -> wrt.Scene:
    """A ground quad plus ``n`` instances of two prototypes, with mirrored and sheared transforms."""
    stage = Usd.Stage.CreateInMemory()
    ids = {}
    protos = []
    for name, path in (("a", "/A"), ("b", "/B")):
        oct_mesh = octahedron(stage, path)
        pts = np.array(oct_mesh.GetPointsAttr().Get(), np.float32)
        tris = np.array(oct_mesh.GetFaceVertexIndicesAttr().Get(), np.int32).reshape(-1, 3)
        if name == "b":
            pts = pts * [1.0, 0.3, 2.0]
        ids[name] = len(protos)
        protos.append(Prototype(path, [Mesh(path, pts, tris, np.arange(len(tris)), double_sided=True)]))
    ground = Mesh("/Ground", [[-9, -7, -9], [9, -7, -9], [9, -7, 9], [-9, -7, 9]], [[0, 2, 1], [0, 3, 2]], [0, 0])
    instances = Instances.from_transforms(np.arange(n) % 2, random_affine(rng, n))
    return wrt.Scene(meshes=[ground], prototypes=protos, instances=instances)


def check_agreement(scene, origins, directions) -> dict:
    """Ray by ray against wp.Mesh on Scene.triangles(), with the tie rules of wrt.compare."""
    ours = wrt.trace(scene, origins, directions, accel="wrt")
    theirs = wrt.trace(scene, origins, directions, accel="warp")
    scale = float(np.abs(scene.triangles()[0]).max())
    ties = near_edge_world(scene, ours, origins, directions, scale) | near_edge_world(
        scene, theirs, origins, directions, scale
    )
    report = compare_hits(ours, theirs, directions=directions, scale=scale, ties=ties)
    assert report["disagreements"] == 0, report
    assert report["tie_disagreements"] <= MAX_TIE_FRACTION * report["rays"], report
    both = (ours.prim >= 0) & (theirs.prim >= 0)
    # The same triangle of the same instance, apart from ties between neighbours.
    assert np.mean(ours.prim[both] == theirs.prim[both]) > 0.999
    assert np.mean(ours.instance[both] == theirs.instance[both]) > 0.999
    return report


# Loading


PROTOTYPES_UNDER_OVER = """#usda 1.0
def PointInstancer "PI"
{
    rel prototypes = [</PI/Prototypes/source_1>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (10, 0, 0)]
    over "Prototypes"
    {
        def Xform "source_1"
        {
            def Mesh "T"
            {
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
                point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
            }
        }
    }
}
"""


def test_instancer_prototypes_under_an_over_are_drawn_only_through_the_instancer(tmp_path):
    """A common layout keeps prototypes under an ``over`` so they are not drawn in place; the instancer still draws
    them (USD computes both instance transforms; wrt once found no prims there, since they are not "defined")."""
    path = tmp_path / "pi_over.usda"
    path.write_text(PROTOTYPES_UNDER_OVER)
    stage = Usd.Stage.Open(str(path))
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    assert len(pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default())) == 2
    stats = load(path).stats()
    assert (stats["instances"], stats["rendered_triangles"], stats["meshes"]) == (2, 2, 0)


TRIANGLE = """{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}"""


def test_a_prototypes_material_bound_from_outside_too_is_one_material(tmp_path):
    """A Material inside a native instance's prototype, bound inside it and by a mesh outside through an instance
    proxy's path, was read twice (keyed by the prototype's path, then by the proxy's): two entries in
    ``Scene.materials`` and two material ids in the AOV for what USD binds as one prim of the prototype."""
    asset = Usd.Stage.CreateNew(str(tmp_path / "asset.usda"))
    asset.SetDefaultPrim(UsdGeom.Xform.Define(asset, "/A").GetPrim())
    geo = octahedron(asset, "/A/Geo")
    material = UsdShade.Material.Define(asset, "/A/Looks/Red")
    shader = UsdShade.Shader.Define(asset, "/A/Looks/Red/S")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.9, 0.1, 0.1))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(geo.GetPrim()).Bind(material)
    asset.Save()
    stage = Usd.Stage.CreateNew(str(tmp_path / "scene.usda"))
    for k, x in enumerate((-2.5, 0.0)):
        inst = stage.DefinePrim(f"/World/I{k}", "Xform")
        inst.GetReferences().AddReference("./asset.usda")
        inst.SetInstanceable(True)
        UsdGeom.Xformable(inst).AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
    outside = octahedron(stage, "/World/Outside")
    outside.AddTranslateOp().Set(Gf.Vec3d(2.5, 0, 0))
    UsdShade.MaterialBindingAPI.Apply(outside.GetPrim()).Bind(UsdShade.Material(stage.GetPrimAtPath("/World/I0/Looks/Red")))
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    stage.Save()
    bound = [UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(p)).ComputeBoundMaterial()[0].GetPrim()
             for p in ("/World/I0/Geo", "/World/I1/Geo", "/World/Outside")]
    in_prototype = {str((p.GetPrimInPrototype() if p.IsInstanceProxy() else p).GetPath()) for p in bound}
    scene = load(tmp_path / "scene.usda")
    assert len(scene.materials) == len(in_prototype) == 1
    ids = wrt.render(scene, camera="/Cam", width=60, height=20, integrator="albedo").aovs["material"][10]
    assert {int(ids[j]) for j in (15, 30, 45)} == {0}  # the two instances and the outside mesh


def test_overs_inside_a_native_prototype_are_not_drawn_as_in_a_plain_reference(tmp_path):
    """A mesh defined under an ``over`` inside a referenced asset is not drawn (it is not defined), instanced or not:
    the instance drew it (its prototype was walked as a PointInstancer's is, where "defined" is not asked of the
    prototype's ancestors), one triangle more than the same asset referenced plainly."""
    (tmp_path / "asset.usda").write_text(f'#usda 1.0\n(\n    defaultPrim = "A"\n)\ndef Xform "A"\n{{\n'
                                         f'    def Mesh "Shown"\n{TRIANGLE}\n    over "Kept"\n    {{\n'
                                         f'        def Mesh "Overridden"\n{TRIANGLE}\n    }}\n}}\n')
    path = tmp_path / "scene.usda"
    path.write_text('#usda 1.0\ndef Xform "Plain" (\n    references = @./asset.usda@\n)\n{\n}\n'
                    'def Xform "Inst" (\n    instanceable = true\n    references = @./asset.usda@\n)\n{\n}\n')
    scene = load(path)
    assert [m.path for m in scene.meshes] == ["/Plain/Shown"]
    assert [[m.path for m in p.meshes] for p in scene.prototypes] == [["/Inst/Shown"]]  # named by its instance


def test_overs_inside_a_pointinstancer_prototype_are_not_drawn(tmp_path):
    """Below a prototype that is defined (under an ``over`` or not), an ``over`` and what it holds are not drawn, as
    Hydra's prototype predicate leaves them out (a defining specifier on each prim, not on its ancestors); a prototype
    that is an ``over`` itself is skipped with a warning naming it (it was drawn)."""
    path = tmp_path / "pi_over.usda"
    path.write_text(f"""#usda 1.0
def PointInstancer "PI"
{{
    rel prototypes = [</PI/Protos/P>, </PI/Protos/Q>]
    int[] protoIndices = [0, 0, 1]
    point3f[] positions = [(0, 0, 0), (10, 0, 0), (20, 0, 0)]
    over "Protos"
    {{
        def Xform "P"
        {{
            def Mesh "T"
{TRIANGLE}
            over "Kept"
            {{
                def Mesh "U"
{TRIANGLE}
            }}
        }}
        over "Q"
        {{
            def Mesh "V"
{TRIANGLE}
        }}
    }}
}}
""")
    with pytest.warns(UserWarning, match=r"not defined.*\(/PI/Protos/Q: 1\): /PI$"):
        scene = wrt.load_usd(path)
    assert [[m.path for m in p.meshes] for p in scene.prototypes] == [["/PI/Protos/P/T"]]
    assert len(scene.instances) == 2


def test_pointinstancer_prototypes_that_are_classes_are_skipped_with_a_warning(tmp_path):
    """A prototype that is a ``class`` prim or lies under one (prototypes kept in a class scope) is abstract: USD's
    ``PrimIsAbstract``, which Hydra's prototype predicate and a walk of the prototype with it leave out, so nothing is
    drawn; its instances are skipped with a warning naming it, as those of an ``over`` are (they vanished without a
    word)."""
    path = tmp_path / "pi_class.usda"
    path.write_text(f"""#usda 1.0
class Scope "_Protos"
{{
    def Xform "Tree"
    {{
        def Mesh "T"
{TRIANGLE}
    }}
}}
class Xform "_Bush"
{{
    def Mesh "T"
{TRIANGLE}
}}
def PointInstancer "PI"
{{
    rel prototypes = [</_Protos/Tree>, </_Bush>, </PI/Protos/P>]
    int[] protoIndices = [0, 1, 2, 0]
    point3f[] positions = [(0, 0, 0), (10, 0, 0), (20, 0, 0), (30, 0, 0)]
    def Scope "Protos"
    {{
        def Xform "P"
        {{
            def Mesh "T"
{TRIANGLE}
        }}
    }}
}}
""")
    stage = Usd.Stage.Open(str(path))
    abstract = [str(t) for t in UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")).GetPrototypesRel().GetTargets()
                if stage.GetPrimAtPath(t).IsAbstract()]
    assert abstract == ["/_Protos/Tree", "/_Bush"]
    with pytest.warns(UserWarning, match=r"class prims.*\(/_Protos/Tree: 1, /_Bush: 1\): /PI$"):
        scene = wrt.load_usd(path)
    assert [[m.path for m in p.meshes] for p in scene.prototypes] == [["/PI/Protos/P/T"]]
    assert len(scene.instances) == 1


PURPOSE_USDA = """#usda 1.0
def Xform "Lib"
{
    def Mesh "Tri"
    {
        uniform token purpose = "render"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
    def Mesh "Plain"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 5), (1, 0, 5), (0, 1, 5)]
    }
}
def Xform "G"
{
    uniform token purpose = "guide"
    def Xform "Ref" (references = </Lib>)
    {
        double3 xformOp:translate = (10, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Xform "Inst" (instanceable = true
        references = </Lib>)
    {
        double3 xformOp:translate = (20, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def Xform "Inst" (instanceable = true
    references = </Lib>)
{
    double3 xformOp:translate = (30, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def test_purpose_inside_instances_is_computed_as_usd_does(tmp_path):
    """Under a guide ancestor, a prototype mesh of authored render purpose is drawn and one without is not, for a
    native instance as for a plain reference (the instance was dropped whole); the same prototype instanced outside
    the guide draws both. Against UsdGeom's ComputePurpose through instance proxies."""
    path = tmp_path / "purpose.usda"
    path.write_text(PURPOSE_USDA)
    stage = Usd.Stage.Open(str(path))
    proxies = Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate))
    xforms = UsdGeom.XformCache()
    expected = sorted(
        tuple(np.array(xforms.GetLocalToWorldTransform(p)).T[:3, 3] + UsdGeom.Mesh(p).GetPointsAttr().Get()[0])
        for p in proxies
        if p.IsA(UsdGeom.Mesh) and UsdGeom.Imageable(p).ComputePurpose() in ("default", "render")
    )
    assert len(expected) == 6  # Lib (2), G/Ref/Tri, G/Inst/Tri, Inst (2)
    points, indices = load(path).triangles()
    assert sorted(map(tuple, points[indices][:, 0].tolist())) == expected


def test_pointinstancer_transforms_match_usd(tmp_path):
    """Positions, orientations, scales, the prototype root's own transform, invisibleIds and the instancer's
    world transform, against UsdGeom.PointInstancer.ComputeInstanceTransformsAtTime."""
    rng = np.random.default_rng(3)
    path = str(tmp_path / "pi.usda")
    stage = Usd.Stage.CreateNew(path)
    world = UsdGeom.Xform.Define(stage, "/World")
    world.AddTranslateOp().Set((1, 2, 3))
    world.AddRotateYOp().Set(30)
    pi = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    pi.AddScaleOp().Set((2, 2, 2))
    protos = UsdGeom.Scope.Define(stage, "/World/PI/Protos")
    UsdGeom.Imageable(protos).MakeInvisible()  # hides the prototypes in place, not the instances
    a = UsdGeom.Xform.Define(stage, "/World/PI/Protos/A")
    a.AddTranslateOp().Set((0, 0.5, 0))  # the prototype root's own transform is part of every instance
    octahedron(stage, "/World/PI/Protos/A/Mesh")
    octahedron(stage, "/World/PI/Protos/B")
    pi.CreatePrototypesRel().SetTargets(["/World/PI/Protos/A", "/World/PI/Protos/B"])
    n = 7
    pi.CreateProtoIndicesAttr([0, 1, 0, 1, 0, 1, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(*p) for p in rng.uniform(-5, 5, (n, 3))])
    quats = rng.normal(size=(n, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    pi.CreateOrientationsfAttr(Vt.QuatfArray([Gf.Quatf(float(q[3]), Gf.Vec3f(*q[:3].tolist())) for q in quats]))
    scales = rng.uniform(0.5, 2.0, (n, 3))
    scales[2, 1] *= -1  # a mirrored instance
    pi.CreateScalesAttr([Gf.Vec3f(*s) for s in scales])
    pi.CreateInvisibleIdsAttr([3])
    stage.Save()

    scene = load(path)
    t = Usd.TimeCode.Default()
    instancer = np.array(UsdGeom.XformCache(t).GetLocalToWorldTransform(pi.GetPrim()))

    def oracle(proto_xform):
        m = pi.ComputeInstanceTransformsAtTime(t, t, proto_xform, UsdGeom.PointInstancer.IgnoreMask)
        return np.array([(np.array(x) @ instancer).T for x in m])  # row-vector USD -> column vectors

    kept = [0, 1, 2, 4, 5, 6]
    assert len(scene.instances) == 6 and scene.meshes == []
    assert [scene.instances.path(i) for i in range(6)] == [f"/World/PI[{k}]" for k in kept]
    np.testing.assert_array_equal(scene.instances.prototype, [0, 1, 0, 0, 1, 0])
    # Instance transforms place the prototype's space, which already holds the root's own transform ...
    np.testing.assert_allclose(scene.instances.to_world, oracle(UsdGeom.PointInstancer.ExcludeProtoXform)[kept],
                               atol=1e-5)
    # ... so the expanded triangles are the mesh points moved by USD's full instance transform.
    full = oracle(UsdGeom.PointInstancer.IncludeProtoXform)[kept]
    local = np.array(UsdGeom.Mesh(stage.GetPrimAtPath("/World/PI/Protos/B")).GetPointsAttr().Get(), np.float64)
    points, indices = scene.triangles()
    offsets = scene.instance_offsets()
    for i, m in enumerate(full):
        rows = indices[offsets[i] : offsets[i + 1]]
        expected = local @ m[:3, :3].T + m[:3, 3]  # A/Mesh and B are the same octahedron
        got = points[np.unique(rows)]
        np.testing.assert_allclose(np.sort(got, axis=0), np.sort(expected, axis=0), atol=1e-4)
    assert scene.instances.mirrored.sum() == 1
    assert [p.path for p in scene.prototypes] == ["/World/PI/Protos/A", "/World/PI/Protos/B"]
    assert scene.stats()["rendered_triangles"] == 6 * 8 and scene.stats()["unique_triangles"] == 2 * 8


def test_nested_instancing_resolves_to_one_level(tmp_path):
    """A PointInstancer inside a native prototype, drawn by two instanceable prims: 2 x 3 instances of one
    prototype, placed as the flattened stage (instance proxies) places them, each named by its instancer's
    instance-proxy path and index (``/I1/PI[2]``; all three were named ``/I1``)."""
    path = str(tmp_path / "nested.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/Asset")
    pi = UsdGeom.PointInstancer.Define(stage, "/Asset/PI")
    octahedron(stage, "/Asset/PI/Proto")
    pi.CreatePrototypesRel().SetTargets(["/Asset/PI/Proto"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(0, 0, 0), (3, 0, 0), (0, 3, 0)])
    stage.GetPrimAtPath("/Asset").SetSpecifier(pxr.Sdf.SpecifierClass)
    for name, x in (("I1", 10), ("I2", -10)):
        inst = UsdGeom.Xform.Define(stage, f"/{name}")
        inst.GetPrim().GetReferences().AddInternalReference("/Asset")
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set((x, 0, 0))
        inst.AddRotateZOp().Set(90)
    stage.Save()
    scene = load(path)
    assert len(scene.prototypes) == 1 and len(scene.instances) == 6
    assert [scene.instances.path(i) for i in range(6)] == [f"/I{a}/PI[{k}]" for a in (1, 2) for k in range(3)]
    t = Usd.TimeCode.Default()
    expected = []
    for name in ("I1", "I2"):
        proxy = UsdGeom.PointInstancer(stage.GetPrimAtPath(f"/{name}/PI"))
        world = np.array(UsdGeom.XformCache(t).GetLocalToWorldTransform(proxy.GetPrim()))
        expected += [(np.array(m) @ world).T for m in proxy.ComputeInstanceTransformsAtTime(t, t)]
    np.testing.assert_allclose(scene.instances.to_world, expected, atol=1e-9)


@pytest.mark.parametrize("inner_proto", ["/World/Outer/Protos/P/Inner/Q", "/Lib/Q"])
def test_nested_point_instancers_compose_usds_instance_transforms(tmp_path, inner_proto):
    """A PointInstancer inside another's prototype (each with its own transform, oriented and scaled instances, and
    prototypes with their own transforms; the inner prototype beside the instancer or under a moved /Lib, whose
    transform no instance takes): every world triangle is where USD's ComputeInstanceTransformsAtTime of each level,
    composed by hand with the inner instancer's transform relative to the outer prototype (XformCache), puts it."""
    path = str(tmp_path / "nested_pi.usda")
    stage = Usd.Stage.CreateNew(path)
    world = UsdGeom.Xform.Define(stage, "/World")
    world.AddTranslateOp().Set((1, 2, 3))
    world.AddRotateYOp().Set(25)
    lib = UsdGeom.Xform.Define(stage, "/Lib")
    lib.AddTranslateOp().Set((100, 0, 0))
    lib.MakeInvisible()
    outer = UsdGeom.PointInstancer.Define(stage, "/World/Outer")
    outer.AddRotateZOp().Set(30)
    outer.AddScaleOp().Set((2, 2, 2))
    proto = UsdGeom.Xform.Define(stage, "/World/Outer/Protos/P")
    proto.AddTranslateOp().Set((1, 0, 0))
    proto.AddRotateYOp().Set(20)
    inner = UsdGeom.PointInstancer.Define(stage, "/World/Outer/Protos/P/Inner")
    inner.AddTranslateOp().Set((0, 1, 0))
    inner.AddRotateXOp().Set(45)
    shape = octahedron(stage, inner_proto)
    shape.AddTranslateOp().Set((0, 0, 0.5))
    shape.AddScaleOp().Set((0.5, 0.25, 0.5))
    rng = np.random.default_rng(7)
    for pi, n in ((outer, 2), (inner, 3)):
        quats = rng.normal(size=(n, 4))
        quats /= np.linalg.norm(quats, axis=1, keepdims=True)
        pi.CreateProtoIndicesAttr([0] * n)
        pi.CreatePositionsAttr([Gf.Vec3f(*p) for p in rng.uniform(-5, 5, (n, 3))])
        pi.CreateOrientationsAttr([Gf.Quath(float(q[3]), *map(float, q[:3])) for q in quats])
        pi.CreateScalesAttr([Gf.Vec3f(*s) for s in rng.uniform(0.5, 2, (n, 3))])
    outer.CreatePrototypesRel().SetTargets([proto.GetPath()])
    inner.CreatePrototypesRel().SetTargets([shape.GetPath()])
    stage.Save()

    t = Usd.TimeCode.Default()
    cache = UsdGeom.XformCache(t)
    inner_in_proto = (np.array(cache.GetLocalToWorldTransform(inner.GetPrim()))
                      @ np.linalg.inv(np.array(cache.GetLocalToWorldTransform(proto.GetPrim()))))
    outer_world = np.array(cache.GetLocalToWorldTransform(outer.GetPrim()))
    points = np.c_[np.array(shape.GetPointsAttr().Get(), np.float64), np.ones(6)]
    faces = np.array(shape.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    expected = []  # row vectors, as Gf composes them: most local first
    for m_outer in outer.ComputeInstanceTransformsAtTime(t, t):
        for m_inner in inner.ComputeInstanceTransformsAtTime(t, t):
            world_points = points @ np.array(m_inner) @ inner_in_proto @ np.array(m_outer) @ outer_world
            expected.append(world_points[faces][:, :, :3])
    expected = np.concatenate(expected)
    got_points, got_indices = load(path).triangles()
    got = got_points[got_indices].astype(np.float64)

    def canonical(tris):  # each triangle as its corners in a fixed order, the triangles sorted
        tris = np.round(tris, 4)
        tris = np.array([tri[np.lexsort(tri.T[::-1])] for tri in tris]).reshape(len(tris), 9)
        return tris[np.lexsort(tris.T[::-1])]

    assert got.shape == expected.shape == (2 * 3 * 8, 3, 3)
    np.testing.assert_allclose(canonical(got), canonical(expected), atol=2e-4)


def write_instancer(tmp_path, proto_indices=(0, 0, 0), targets=("/PI/Proto",), positions=3, scales=None) -> str:
    path = str(tmp_path / "bad.usda")
    stage = Usd.Stage.CreateNew(path)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    octahedron(stage, "/PI/Proto")
    pi.CreatePrototypesRel().SetTargets(list(targets))
    pi.CreateProtoIndicesAttr(list(proto_indices))
    pi.CreatePositionsAttr([Gf.Vec3f(3.0 * k, 0, 0) for k in range(positions)])
    if scales is not None:
        pi.CreateScalesAttr([Gf.Vec3f(*s) for s in scales])
    stage.Save()
    return path


@pytest.mark.parametrize(
    "kwargs, kept, message",
    [
        ({"proto_indices": (0, 2, 0, -1)}, [0, 2], r"out of range of its prototypes were skipped.*"
         r"\(2 of 4 instances, the first protoIndices\[1\] = 2 for 1 prototypes: 1\)"),
        ({"proto_indices": (0, 1, 0, 1), "targets": ("/PI/Proto", "/Missing")}, [0, 2],
         r"prototypes that do not exist were skipped.*\(/Missing, 2 of 4 instances: 1\)"),
        ({"proto_indices": (0, 0, 0, 0), "targets": ()}, [], r"out of range of its prototypes were skipped.*"
         r"\(4 of 4 instances, the first protoIndices\[0\] = 0 for 0 prototypes: 1\)"),
    ],
    ids=["proto_index_out_of_range", "missing_prototype", "no_prototypes"],
)
def test_instances_of_bad_proto_indices_or_missing_prototypes_are_skipped_with_a_warning(tmp_path, kwargs, kept,
                                                                                         message):
    """A ``protoIndices`` entry out of range (negative, past the last prototype, or any where ``prototypes`` targets
    nothing) or a prototype target that does not exist stopped the whole load with SceneError. UsdImaging skips those
    instances with a warning ("Invalid index found", "Targeted prototype was not found") and draws the others: so
    does wrt, naming the file, the instancer and how many. The others are placed as USD places them once the bad
    entries are mended."""
    path = write_instancer(tmp_path, positions=4, **kwargs)
    stage = Usd.Stage.Open(path)
    octahedron(stage, "/Other")
    stage.Save()
    with pytest.warns(UserWarning, match=r"bad\.usda: .*PointInstancer.*" + message + r": /PI$"):
        scene = wrt.load_usd(path)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [f"/PI[{k}]" for k in kept]
    assert [m.path for m in scene.meshes] == ["/Other"]
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.GetPrototypesRel().SetTargets(["/PI/Proto"])
    pi.GetProtoIndicesAttr().Set([0] * 4)
    t = Usd.TimeCode.Default()
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    np.testing.assert_allclose(scene.instances.to_world.reshape(-1, 4, 4), expected[kept].reshape(-1, 4, 4))


def test_positions_longer_than_proto_indices_draw_nothing_with_a_warning_as_usd_computes(tmp_path):
    """``ComputeInstanceTransformsAtTime`` computes no transforms where ``positions`` has more entries than
    ``protoIndices`` (USD warns); wrt drew the first ones without a word. It draws none, with a warning naming the
    file, the instancer and both lengths."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0), positions=4)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    t = Usd.TimeCode.Default()
    assert len(pi.ComputeInstanceTransformsAtTime(t, t)) == 0
    with pytest.warns(UserWarning, match=r"bad\.usda: PointInstancers whose positions are longer than protoIndices "
                      r"were skipped.*\(4 positions for 3 protoIndices: 1\): /PI$"):
        scene = wrt.load_usd(path)
    assert len(scene.instances) == 0 and scene.meshes == []



@pytest.mark.parametrize("positions, shown", [("missing", "no"), ("blocked", "blocked"), (0, "0"), (2, "2")])
def test_an_instancer_without_a_position_per_instance_draws_nothing_with_a_warning(tmp_path, positions, shown):
    """``positions`` missing, blocked (over a weaker layer's), empty or shorter than ``protoIndices``:
    ``ComputeInstanceTransformsAtTime`` computes no transforms (USD warns "no positions") and Hydra draws none of the
    instances; wrt stopped the whole load with SceneError. The instancer draws nothing, with a warning naming the file,
    the instancer and the counts; the rest of the stage is drawn."""
    base = write_instancer(tmp_path, proto_indices=(0, 0, 0), positions=3 if positions == "blocked" else
                           (positions if isinstance(positions, int) else 0))
    path = str(tmp_path / "shot.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.GetRootLayer().subLayerPaths.append(base)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    if positions == "missing":
        Sdf.Layer.FindOrOpen(base).GetPrimAtPath("/PI").RemoveProperty(Sdf.Layer.FindOrOpen(base).GetPropertyAtPath(
            "/PI.positions"))
    elif positions == "blocked":
        pi.GetPositionsAttr().Block()
    octahedron(stage, "/Other")
    stage.Save()
    t = Usd.TimeCode.Default()
    assert len(pi.ComputeInstanceTransformsAtTime(t, t)) == 0  # the oracle: USD computes no instance
    assert not pi.GetPositionsAttr().HasValue() if positions in ("missing", "blocked") else True
    with pytest.warns(UserWarning, match=rf"shot\.usda: PointInstancers with fewer positions than protoIndices were "
                      rf"skipped .*\({shown} positions for 3 protoIndices: 1\): /PI$"):
        scene = wrt.load_usd(path)
    assert len(scene.instances) == 0 and [m.path for m in scene.meshes] == ["/Other"]

@pytest.mark.parametrize("name", ["scales", "orientations", "orientationsf"])
def test_orientations_or_scales_longer_than_proto_indices_are_cut_with_a_warning_as_usd_computes(tmp_path, name):
    """``ComputeInstanceTransformsAtTime`` warns about ``scales`` or ``orientations`` longer than ``protoIndices``
    and uses their first entries; wrt used them without a word. Same transforms as USD's, and a warning naming the
    instancer and both lengths."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0), positions=3)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    rng = np.random.default_rng(123)
    if name == "scales":
        pi.CreateScalesAttr([Gf.Vec3f(*v) for v in rng.uniform(0.5, 2.0, (4, 3))])
    else:
        q = rng.normal(size=(4, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        quat, array, attr = ((Gf.Quatf, Vt.QuatfArray, pi.CreateOrientationsfAttr) if name == "orientationsf"
                             else (Gf.Quath, Vt.QuathArray, pi.CreateOrientationsAttr))
        attr(array([quat(float(w), *map(float, v)) for *v, w in q]))
    stage.Save()
    with pytest.warns(UserWarning, match=r"bad\.usda: PointInstancer orientations or scales longer than protoIndices"
                      rf".*\(4 {name} for 3 protoIndices: 1\): /PI$"):
        scene = wrt.load_usd(path)
    t = Usd.TimeCode.Default()
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    assert expected.shape == (3, 4, 4)
    np.testing.assert_allclose(scene.instances.to_world, expected, atol=2e-3 if name == "orientations" else 1e-5)


@pytest.mark.parametrize("name", ["scales", "orientations", "orientationsf"])
def test_orientations_or_scales_shorter_than_proto_indices_are_ignored_with_a_warning(tmp_path, name):
    """``scales`` or ``orientations`` shorter than ``protoIndices``: ``ComputeInstanceTransformsAtTime`` warns ("found
    [2] scales, but expected [3]") and reads past their end, and Storm drops an instance primvar shorter than the
    instances; wrt stopped the whole load with SceneError. They are read as unauthored, with a warning naming the
    file, the instancer and both lengths: the transforms are USD's with the attribute blocked."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0), positions=3)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    if name == "scales":
        attr = pi.CreateScalesAttr([Gf.Vec3f(2, 3, 4)] * 2)
    elif name == "orientationsf":
        attr = pi.CreateOrientationsfAttr(Vt.QuatfArray([Gf.Quatf(0.6, 0.8, 0, 0)] * 2))
    else:
        attr = pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(0.6, 0.8, 0, 0)] * 2))
    octahedron(stage, "/Other")
    stage.Save()
    with pytest.warns(UserWarning, match=r"bad\.usda: PointInstancer orientations or scales shorter than protoIndices"
                      rf" were ignored.*\(2 {name} for 3 protoIndices: 1\): /PI$"):
        scene = wrt.load_usd(path)
    attr.Block()
    t = Usd.TimeCode.Default()
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    assert expected.shape == (3, 4, 4)
    np.testing.assert_allclose(scene.instances.to_world, expected, atol=1e-6)
    assert [m.path for m in scene.meshes] == ["/Other"]


@pytest.mark.parametrize("orientationsf", ["empty", "empty_first_sample"])
def test_orientations_are_read_where_orientationsf_is_empty_as_usd_picks_them(tmp_path, orientationsf):
    """USD reads ``orientationsf`` only where its value at the earliest time is a non-empty array
    (``UsesOrientationsf``), else ``orientations``: wrt took any authored ``orientationsf``, an empty one (which
    exporters write beside the ``quath[]`` they fill) too, and drew every instance unrotated. The oracle is
    ``ComputeInstanceTransformsAtTime``."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0), positions=3)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(0.6, 0.8, 0, 0), Gf.Quath(0.6, 0, 0.8, 0),
                                             Gf.Quath(0, 0, 0.6, 0.8)]))
    if orientationsf == "empty":
        pi.CreateOrientationsfAttr(Vt.QuatfArray())
    else:  # empty at its first sample, filled later: USD reads orientations at every time
        pi.CreateOrientationsfAttr().Set(Vt.QuatfArray(), 1)
        pi.GetOrientationsfAttr().Set(Vt.QuatfArray([Gf.Quatf(1, 0, 0, 0)] * 3), 2)
    stage.Save()
    for time in (None, 2):
        scene = load(path, time=time)
        t = Usd.TimeCode.Default() if time is None else Usd.TimeCode(time)
        expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
        assert expected.shape == (3, 4, 4) and not np.allclose(expected[:, :3, :3], np.eye(3))
        np.testing.assert_allclose(scene.instances.to_world, expected, atol=1e-6)



@pytest.mark.parametrize("authored", ["quath[]", "float4[]"])
def test_an_orientationsf_of_another_type_beside_orientations_reads_orientations_as_usd_does(tmp_path, authored):
    """``UsesOrientationsf`` reads ``orientationsf`` as ``quatf[]`` only: one authored as ``quath[]`` or ``float4[]``
    gives it no value, so ``ComputeInstanceTransformsAtTime`` turns the instances by the ``orientations`` beside it.
    wrt took any non-empty ``orientationsf``: it turned them by the quath[] one, and drew them unrotated (with a
    warning) for the float4[] one. The oracle is ``ComputeInstanceTransformsAtTime``."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0), positions=3)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(0.6, 0.8, 0, 0), Gf.Quath(0.6, 0, 0.8, 0),
                                             Gf.Quath(0, 0, 0.6, 0.8)]))
    spec = Sdf.AttributeSpec(stage.GetRootLayer().GetPrimAtPath("/PI"), "orientationsf", Sdf.ValueTypeNames.Find(
        authored))  # (USD's own API refuses a value of another type than the schema's)
    spec.default = (Vt.QuathArray([Gf.Quath(0, 1, 0, 0)] * 3) if authored == "quath[]" else
                    Vt.Vec4fArray([Gf.Vec4f(0, 0, 1, 0)] * 3))
    stage.Save()
    passed_over = rf"orientationsf authored as another type than quatf\[\].*orientationsf is {re.escape(authored)}"
    with pytest.warns(UserWarning, match=passed_over):
        scene = wrt.load_usd(path)
    t = Usd.TimeCode.Default()
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    assert expected.shape == (3, 4, 4) and not np.allclose(expected[:, :3, :3], np.eye(3))
    np.testing.assert_allclose(scene.instances.to_world, expected, atol=2e-3)

def test_invisible_and_inactive_ids_hide_instances_by_id_as_usd_masks_them(tmp_path):
    """``ids`` name the instances that ``invisibleIds`` and ``inactiveIds`` hide (not their indices), as
    ``ComputeMaskAtTime`` computes it (``ids`` of another length than ``protoIndices``: see the test below)."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0, 0), positions=4)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.CreateIdsAttr(Vt.Int64Array([40, 30, 20, 10]))
    pi.CreateInvisibleIdsAttr(Vt.Int64Array([30]))
    pi.DeactivateId(10)
    stage.Save()
    kept = np.flatnonzero(pi.ComputeMaskAtTime(Usd.TimeCode.Default()))
    assert kept.tolist() == [0, 2]
    scene = load(path)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [f"/PI[{k}]" for k in kept]


@pytest.mark.parametrize("ids, hidden", [((40, 30), 30), ((40, 30, 20, 10, 0), 0), ((40, 30, 20, 10, 0), 40),
                                         ((40, 30, 30, 10), 30), ((40, 30, 20), 99)],
                         ids=["shorter", "longer", "longer_hiding_a_first_id", "duplicates", "shorter_hiding_none"])
def test_ids_of_another_length_than_proto_indices_mask_as_usd_computes(tmp_path, ids, hidden):
    """``ids`` shorter or longer than ``protoIndices`` while ``invisibleIds`` hides one of them: ``ComputeMaskAtTime``
    makes one mask entry per id, and ``ComputeInstanceTransformsAtTime`` then computes no instance (it warns "mask
    of size [2], but expected size [4]"); shorter ids stopped the whole load with SceneError, longer ones were cut
    without a word. The instancer draws nothing, with a warning naming the file, the instancer and both lengths; the
    rest of the stage is drawn. Where nothing is hidden USD makes no mask and the ids' length does not matter;
    duplicate ids hide every instance that holds them, as USD's mask does."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0, 0), positions=4)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.CreateIdsAttr(Vt.Int64Array(ids))
    pi.CreateInvisibleIdsAttr(Vt.Int64Array([hidden]))
    octahedron(stage, "/Other")
    stage.Save()
    t = Usd.TimeCode.Default()
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)]).reshape(-1, 4, 4)
    mask_mismatch = len(ids) != 4 and hidden in ids
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    told = [str(w.message) for w in caught if "ids" in str(w.message)]
    if mask_mismatch:
        assert len(expected) == 0
        assert len(told) == 1 and re.search(r"bad\.usda: PointInstancers whose ids .* were skipped.*"
                                            rf"\({len(ids)} ids for 4 protoIndices: 1\): /PI$", told[0]), told
    else:
        assert told == [] and len(expected) > 0
    np.testing.assert_allclose(scene.instances.to_world.reshape(-1, 4, 4), expected, atol=1e-6)
    assert [m.path for m in scene.meshes] == ["/Other"]


@pytest.mark.parametrize("deactivated", ["/PI/Protos", "/PI/Protos/Q"], ids=["scope", "root"])
def test_instances_of_an_inactive_prototype_are_skipped_with_a_warning(tmp_path, deactivated):
    """A prototype under a deactivated scope (its prim is not on the stage) or deactivated itself draws nothing, as
    Hydra finds it; the instances of the other prototypes are drawn. The first raised "targets /PI/Protos/Q, which
    does not exist" (it is in the layer, deactivated), the second dropped its instances without a word."""
    path = write_instancer(tmp_path, proto_indices=(0, 1, 0, 1), targets=("/PI/Proto", "/PI/Protos/Q"), positions=4)
    stage = Usd.Stage.Open(path)
    octahedron(stage, "/PI/Protos/Q")
    stage.GetPrimAtPath(deactivated).SetActive(False)
    stage.Save()
    with pytest.warns(UserWarning, match=r"inactive PointInstancer prototypes.*\(/PI/Protos/Q: 1\): /PI$"):
        scene = wrt.load_usd(path)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == ["/PI[0]", "/PI[2]"]
    assert [p.path for p in scene.prototypes] == ["/PI/Proto"]


def test_zero_scale_instance_is_skipped_with_a_warning_naming_it(tmp_path):
    path = write_instancer(tmp_path, scales=[(1, 1, 1), (0, 0, 0), (1, 1, 1)])
    with pytest.warns(UserWarning, match=r"singular transform.*/PI\[1\]"):
        scene = wrt.load_usd(path)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == ["/PI[0]", "/PI[2]"]


def test_instance_whose_inverse_overflows_float32_is_skipped_with_the_singular_ones(tmp_path):
    """A scale of 1e-39 passes the float64 singularity test, but its inverse (1e39) is inf in float32, as the
    devices hold it: every ray into that instance became inf and it vanished without the singular ones' warning. It is
    skipped with a warning saying float32 cannot invert it (no zero scale, which it does not have)."""
    path = write_instancer(tmp_path, scales=[(1, 1, 1), (1e-39, 1e-39, 1e-39), (1, 1, 1)])
    with pytest.warns(UserWarning, match=r"cannot be inverted reliably in float32.*/PI\[1\]") as caught:
        scene = wrt.load_usd(path)
    assert not any("zero scale" in str(w.message) for w in caught)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == ["/PI[0]", "/PI[2]"]


def test_instance_placed_past_float32_is_skipped_saying_so(tmp_path):
    """A native instance translated by 1e39 (a double xformOp: float32 cannot place it) was skipped with the warning
    of a zero scale, which it does not have; the warning says where it is, and the instance beside it is drawn."""
    path = str(tmp_path / "far.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.CreateClassPrim("/Lib")
    octahedron(stage, "/Lib/Mesh")
    for name, x in (("/Far", 1e39), ("/Near", 0.0)):
        xform = UsdGeom.Xform.Define(stage, name)
        xform.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        xform.GetPrim().GetReferences().AddInternalReference("/Lib")
        xform.GetPrim().SetInstanceable(True)
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    said = [str(w.message) for w in caught]
    assert any(re.search(r"placed beyond float32's range.*: 1 prim\(s\): /Far$", m) for m in said), said
    assert not any("zero scale" in m for m in said), said
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == ["/Near"]


@pytest.mark.parametrize("accel", ["wrt", "wrt:wide", "warp"])
def test_instance_whose_scale_takes_its_prototype_past_float32_is_named(tmp_path, accel):
    """An instance scaled by 3e38 (finite, its origin placeable) takes a prototype 2 across (corners at +-2) to 6e38
    from its origin, past float32's 3.4e38: every build refused 'triangle vertices must be finite; triangle 2 uses
    one', a row of no triangle the scene holds, and a render without a camera the NaN eye of its default camera. The
    error names the instance, its prim path and its box (float64 numpy, here). (load_usd skips such an instance, with
    a warning: given the scale in Python, after the load.)"""
    path = str(tmp_path / "huge.usda")
    stage = Usd.Stage.CreateNew(path)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    tri = UsdGeom.Mesh.Define(stage, "/PI/Proto")
    tri.CreatePointsAttr([(-2, -2, 0), (2, -2, 0), (0, 2, 0)])
    tri.CreateFaceVertexCountsAttr([3])
    tri.CreateFaceVertexIndicesAttr([0, 1, 2])
    pi.CreatePrototypesRel().SetTargets(["/PI/Proto"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(3.0 * k, 0, 0) for k in range(3)])
    stage.Save()
    scene = wrt.load_usd(path)
    assert len(scene.instances) == 3
    scene.invalidate()
    scene.instances.to_world[2, :2, :2] = np.diag([3e38, 3e38])
    scale = 3e38  # the oracle: the triangle's box (+-2 in x and y) scaled, moved to x = 6
    lo, hi = [6.0 - 2.0 * scale, -2.0 * scale, 0.0], [6.0 + 2.0 * scale, 2.0 * scale, 0.0]
    assert max(map(abs, lo + hi)) > float(np.finfo(np.float32).max)
    kind, _, layout = accel.partition(":")
    message = (r"^instance 2 \(/PI\[2\]\) of prototype /PI/Proto: its transform takes the prototype's box to "
               + re.escape(f"{lo} to {hi}"))
    with pytest.raises(ValueError, match=message + r".*past float32's range"):
        wrt.trace(scene, np.float32([[0, 0, 5]]), np.float32([[0, 0, -1]]), accel=kind,
                  **({"layout": layout} if layout else {}))
    if accel == "wrt":
        with pytest.raises(ValueError, match=message):
            wrt.render(scene, width=4, height=4, device="cpu")
        scene.invalidate()
        scene.instances.to_world[2, :2, :2] = np.diag([1e38, 1e38])  # 2e38 + 6 is within float32: drawn
        assert wrt.trace(scene, np.float32([[0, 0, 5]]), np.float32([[0, 0, -1]])).t[0] == pytest.approx(5.0)


def test_instances_whose_transform_takes_their_prototype_past_float32_are_skipped_at_load(tmp_path):
    """A PointInstancer instance (or a native instance) whose scale takes its prototype's box past float32's 3.4e38,
    its origin placeable, was loaded without a word, and the trace then refused the whole scene naming it. It is left
    out with a warning naming the file, the prim and the instance index, as one placed past float32 is, and the rest
    is drawn. The oracle: USD's ComputeInstanceTransformsAtTime and the prototype's points, in float64."""
    path = str(tmp_path / "huge.usda")
    stage = Usd.Stage.CreateNew(path)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    octahedron(stage, "/PI/Proto")  # corners at +-1
    pi.CreatePrototypesRel().SetTargets(["/PI/Proto"])
    pi.CreateProtoIndicesAttr([0] * 5)
    pi.CreatePositionsAttr([Gf.Vec3f(3.0 * k, 0, 0) for k in range(5)])
    turned = Gf.Quath(Gf.Rotation(Gf.Vec3d(0, 0, 1), 45).GetQuat())
    pi.CreateOrientationsAttr([Gf.Quath(1)] * 2 + [turned] * 3)
    # A corner at 3e38 + 3 fits float32; turned 45 degrees, 3e38 along x and y reaches 4.2e38 on the diagonal and
    # 2.5e38 3.5e38, past float32's 3.4e38, while 2.2e38 does not (3.1e38).
    pi.CreateScalesAttr([Gf.Vec3f(1, 1, 1), Gf.Vec3f(3e38, 3e38, 3e38), Gf.Vec3f(3e38, 3e38, 1),
                         Gf.Vec3f(2.2e38, 2.2e38, 1), Gf.Vec3f(2.5e38, 2.5e38, 1)])
    stage.CreateClassPrim("/Lib")
    octahedron(stage, "/Lib/Mesh")
    for name, scale in (("/Big", 3.5e38), ("/Small", 2.0)):
        xform = UsdGeom.Xform.Define(stage, name)
        xform.AddTranslateOp().Set(Gf.Vec3d(0, 5, 0))
        xform.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(scale))
        xform.GetPrim().GetReferences().AddInternalReference("/Lib")
        xform.GetPrim().SetInstanceable(True)
    stage.Save()

    t = Usd.TimeCode.Default()
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    limit = float(np.finfo(np.float32).max)

    def past(m) -> bool:  # m: USD's row-vector matrix
        return bool(np.abs(np.c_[corners, np.ones(8)] @ np.array(m)).max() > limit)

    drawn = [f"/PI[{k}]" for k, m in enumerate(pi.ComputeInstanceTransformsAtTime(t, t)) if not past(m)]
    cache = UsdGeom.XformCache(t)
    drawn += [name for name in ("/Big", "/Small") if not past(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(
        name)))]
    assert drawn == ["/PI[0]", "/PI[1]", "/PI[3]", "/Small"]  # the oracle tells the cases apart as meant
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    said = [str(w.message) for w in caught]
    assert [m for m in said if "past float32" in m] == [
        f"{path}: instances whose transform takes their prototype past float32's range (|x| > 3.4e38) were skipped: "
        "3 prim(s): /PI[2], /PI[4], /Big"], said
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == sorted(drawn)
    hits = wrt.trace(scene, np.float32([[0, 0, 5], [0, 5, 5]]), np.float32([[0, 0, -1], [0, 0, -1]]))
    np.testing.assert_allclose(hits.t, [4.0, 3.0])
    assert wrt.render(scene, width=8, height=8, device="cpu").rgb.shape == (8, 8, 3)


def test_zero_scale_instance_is_drawn_flat_whole_through_nested_instances(tmp_path):
    """A PointInstancer instance of scale (0, 1, 1) whose prototype holds a turned native instance: composed in
    float64, that nested piece's transform is singular only up to rounding (a determinant of ~1e-16, not 0), which
    passed as invertible. The two-level BVH could not enter it, while the flattened triangles of ``--accel warp``
    and the other layouts drew it as a flat sheet that rays hit. It was then skipped as singular; USD draws it as that
    flat sheet, and so does wrt now (1e-4 thick, see thicken_flat_transforms), every accelerator alike."""
    path = str(tmp_path / "squashed.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.CreateClassPrim("/Lib")  # drawn only through the instances
    octahedron(stage, "/Lib/Mesh")
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    nested = UsdGeom.Xform.Define(stage, "/PI/Protos/Holder/Nested")
    nested.AddRotateXYZOp().Set(Gf.Vec3f(30, 40, 50))
    nested.GetPrim().GetReferences().AddInternalReference("/Lib")
    nested.GetPrim().SetInstanceable(True)
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Holder"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(3.0 * k, 0, 0) for k in range(3)])
    pi.CreateOrientationsAttr([Gf.Quath(0.9, 0.3, -0.2, 0.25)] * 3)
    pi.CreateScalesAttr([Gf.Vec3f(1, 1, 1), Gf.Vec3f(0, 1, 1), Gf.Vec3f(1, 1, 1)])
    stage.Save()
    scene = load(path)
    paths = [scene.instances.path(i) for i in range(len(scene.instances))]
    assert paths == ["/PI[0]", "/PI[1]", "/PI[2]"]
    # Rays along +z through the squashed instance at x = 3 (clear of the others, of radius 1 at x = 0 and 6), and
    # through the centres of the other two.
    grid = [[3.0 + x, y, -5.0] for x in np.linspace(-0.4, 0.4, 5) for y in np.linspace(-0.8, 0.8, 9)]
    origins = np.array(grid + [[0, 0, -5], [6, 0, -5]], np.float32)
    first = wrt.trace(scene, origins, [0, 0, 1])
    assert first.hit[:-2].sum() > 10 and set(first.instance[:-2][first.hit[:-2]].tolist()) == {1}
    assert first.instance[-2:].tolist() == [0, 2]
    for accel, layout in [("wrt", "compact"), ("warp", "binary")]:
        hits = wrt.trace(scene, origins, [0, 0, 1], accel=accel, layout=layout)
        assert hits.hit.tolist() == first.hit.tolist(), (accel, layout)
        assert hits.instance.tolist() == first.instance.tolist(), (accel, layout)
        np.testing.assert_allclose(hits.t[hits.hit], first.t[first.hit], rtol=1e-5, err_msg=f"{accel} {layout}")


def two_instance_stage(path):
    """A new stage at 24 time codes per second with a PointInstancer ``/PI`` of two instances of an octahedron."""
    stage = Usd.Stage.CreateNew(path)
    stage.SetTimeCodesPerSecond(24)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    octahedron(stage, "/PI/Proto")
    pi.CreatePrototypesRel().SetTargets(["/PI/Proto"])
    pi.CreateProtoIndicesAttr([0, 0])
    return stage, pi


def test_positions_move_by_velocities_between_samples_as_usd_computes(tmp_path):
    """A PointInstancer with velocities and accelerations, and a mesh with velocities whose point count changes
    between samples: between and beyond the samples, positions are the earlier sample moved by v dt + a dt^2 / 2
    (dt in seconds), against ComputeInstanceTransformsAtTime and ComputePointsAtTime. They were interpolated
    linearly (or, for the mesh, held at the earlier sample), ignoring the velocities."""
    path = str(tmp_path / "velocities.usda")
    stage, pi = two_instance_stage(path)
    for t, y in ((1.0, 0.0), (3.0, 5.0)):
        pi.CreatePositionsAttr().Set([Gf.Vec3f(0, y, 0), Gf.Vec3f(4, y, 0)], t)
        pi.CreateVelocitiesAttr().Set([Gf.Vec3f(24, 0, 0), Gf.Vec3f(0, 48, 0)], t)
        pi.CreateAccelerationsAttr().Set([Gf.Vec3f(0, 0, 576), Gf.Vec3f(0, 0, 0)], t)
    mesh = UsdGeom.Mesh.Define(stage, "/Particles")
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    mesh.CreatePointsAttr().Set([Gf.Vec3f(0, 0, 9), Gf.Vec3f(1, 0, 9), Gf.Vec3f(0, 1, 9)], 1.0)
    mesh.CreateVelocitiesAttr().Set([Gf.Vec3f(0, 0, 24)] * 3, 1.0)
    mesh.GetPointsAttr().Set([Gf.Vec3f(0, 0, 9), Gf.Vec3f(1, 0, 9), Gf.Vec3f(0, 1, 9), Gf.Vec3f(1, 1, 9)], 3.0)
    mesh.GetVelocitiesAttr().Set([Gf.Vec3f(0, 0, 24)] * 4, 3.0)
    stage.Save()
    for time in (0.5, 1.0, 1.5, 2.5, 3.0, 4.0):
        scene = load(path, time=time)
        t = Usd.TimeCode(time)
        expected = [np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)]
        np.testing.assert_allclose(scene.instances.to_world, expected, atol=1e-5)
        points = np.array(UsdGeom.PointBased(mesh).ComputePointsAtTime(t, t), np.float64)
        np.testing.assert_allclose(scene.meshes[0].points, points, atol=1e-6)
    # Between samples the instances did move: 1.5 is 1/48 s after the sample at 1.
    np.testing.assert_allclose(load(path, time=1.5).instances.to_world[:, :3, 3], [[0.5, 0, 0.125], [4, 1, 0]])


@pytest.mark.parametrize("rates", [(), ("velocities",), ("angularVelocities",), ("velocities", "angularVelocities")])
def test_orientations_and_scales_move_as_usd_computes(tmp_path, rates):
    """Positions, orientations and scales sampled at 1 and 10, with velocities and/or angular velocities or neither:
    wrt's instance transforms equal ComputeInstanceTransformsAtTime's at, between and beyond the samples. With either
    rate USD holds every attribute at the earlier sample (and turns orientations by the angular velocity); wrt
    interpolated orientations and scales, and ignored angular velocities, placing instances where USD does not."""
    path = str(tmp_path / "spin.usda")
    stage, pi = two_instance_stage(path)
    turn = Gf.Quath(Gf.Rotation(Gf.Vec3d(0.3, 1, -0.2), 70).GetQuat())
    for t, k in ((1.0, 0.0), (10.0, 1.0)):
        pi.CreatePositionsAttr().Set([Gf.Vec3f(0, 9 * k, 0), Gf.Vec3f(4, 0, 2 * k)], t)
        pi.CreateOrientationsAttr().Set([Gf.Quath(1, 0, 0, 0), turn if k else Gf.Quath(1, 0, 0, 0)], t)
        pi.CreateScalesAttr().Set([Gf.Vec3f(1 + k, 1, 1), Gf.Vec3f(1, 0.5, 1 + 2 * k)], t)
        if "velocities" in rates:
            pi.CreateVelocitiesAttr().Set([Gf.Vec3f(24, 0, 0), Gf.Vec3f(0, 48, 0)], t)
        if "angularVelocities" in rates:
            pi.CreateAngularVelocitiesAttr().Set([Gf.Vec3f(0, 0, 240), Gf.Vec3f(100, -50, 30)], t)
    stage.Save()
    for time in (0.5, 1.0, 5.5, 10.0, 12.0):
        t = Usd.TimeCode(time)
        expected = [np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)]
        np.testing.assert_allclose(load(path, time=time).instances.to_world, expected, atol=1e-5, err_msg=time)


@pytest.mark.parametrize("rate, count, base", [("velocities", 3, "positions"), ("angularVelocities", 1, "orientations"),
                                               ("accelerations", 4, "velocities")])
def test_rates_of_the_wrong_length_are_ignored_with_a_warning_as_usd_ignores_them(tmp_path, rate, count, base):
    """Velocities, angular velocities or accelerations with an entry count other than the instances' are ignored by
    ComputeInstanceTransformsAtTime, which warns ("found [3] velocities, but expected [2]"); wrt ignored them without
    a word. Same transforms as USD's, and a warning naming the instancer and both lengths."""
    path = str(tmp_path / "rates.usda")
    stage, pi = two_instance_stage(path)
    for t in (1.0, 10.0):
        pi.CreatePositionsAttr().Set([Gf.Vec3f(0, t, 0), Gf.Vec3f(4, 0, t)], t)
        pi.CreateOrientationsAttr().Set([Gf.Quath(1, 0, 0, 0)] * 2, t)
        pi.CreateVelocitiesAttr().Set([Gf.Vec3f(24, 0, 0)] * (count if rate == "velocities" else 2), t)
        if rate != "velocities":
            pi.GetPrim().CreateAttribute(rate, Sdf.ValueTypeNames.Vector3fArray).Set([Gf.Vec3f(0, 0, 240)] * count, t)
    stage.Save()
    with pytest.warns(UserWarning, match=rf"angularVelocities whose length .* were ignored.*\({count} {rate} for 2 "
                      rf"{base}: 1\): /PI$"):
        scene = wrt.load_usd(path, time=4.0)
    t = Usd.TimeCode(4.0)
    expected = [np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)]
    np.testing.assert_allclose(scene.instances.to_world, expected, atol=1e-5)


def test_time_sampled_invisible_ids_follow_the_default_time_rule(tmp_path):
    """With ``time=None`` an instancer whose positions and invisibleIds have only time samples is read at their
    first sample, both of them: the mask USD computes there hides instance 1 (it was read at the default time,
    where invisibleIds has no value, and every instance was drawn)."""
    path = write_instancer(tmp_path)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.GetPositionsAttr().Set(pi.GetPositionsAttr().Get(), 1.0)
    pi.GetPositionsAttr().ClearDefault()
    pi.CreateInvisibleIdsAttr().Set(Vt.Int64Array([1]), 1.0)
    pi.GetInvisibleIdsAttr().Set(Vt.Int64Array([0, 2]), 5.0)
    stage.Save()
    first = np.flatnonzero(pi.ComputeMaskAtTime(Usd.TimeCode.EarliestTime()))
    assert list(first) == [0, 2]
    scene = load(path)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [f"/PI[{k}]" for k in first]
    assert [load(path, time=5.0).instances.path(0)] == ["/PI[1]"]


@pytest.mark.parametrize("sampled", ["protoIndices", "ids"])
def test_a_still_invisible_ids_hides_instances_numbered_by_time_sampled_ids(tmp_path, sampled):
    """With ``time=None`` an instancer whose ``invisibleIds`` is a default value but whose ``protoIndices`` (which
    number the instances without ``ids``) or ``ids`` have only time samples hides the instances it names: the mask was
    computed at the default time, where USD found no ids to match and hid nothing."""
    path = write_instancer(tmp_path)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.CreateInvisibleIdsAttr(Vt.Int64Array([7 if sampled == "ids" else 1]))
    attr = pi.GetProtoIndicesAttr() if sampled == "protoIndices" else pi.CreateIdsAttr()
    attr.Set(Vt.IntArray([0, 0, 0]) if sampled == "protoIndices" else Vt.Int64Array([5, 7, 9]), 1.0)
    attr.ClearDefault()
    stage.Save()
    first = np.flatnonzero(pi.ComputeMaskAtTime(Usd.TimeCode.EarliestTime()))
    assert list(first) == [0, 2]
    scene = load(path)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [f"/PI[{k}]" for k in first]


def test_blocked_ids_number_instances_by_index_as_usd_masks_them(tmp_path):
    """An ``ids`` attribute blocked at the time read (a value block among its samples) has no ids: USD's mask then
    names instances by index, as without ids. Reading it for the mask failed with "cannot read this prim" (int() of
    None) since the mask's ids were read by value_at."""
    path = write_instancer(tmp_path)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    pi.CreateInvisibleIdsAttr(Vt.Int64Array([1]))
    pi.CreateIdsAttr().Set(Vt.Int64Array([5, 7, 9]), 0.0)
    pi.GetIdsAttr().Set(Sdf.ValueBlock(), 1.0)
    stage.Save()
    shown = np.flatnonzero(pi.ComputeMaskAtTime(1.0))
    assert list(shown) == [0, 2]
    scene = load(path, time=1.0)
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [f"/PI[{k}]" for k in shown]


@pytest.mark.parametrize("asset_id", ["chess_set", "teapot_scene_1000", "teapot_layout_1000"])
def test_real_instanced_scenes_match_the_manifest_without_flattening(assets, asset_id):
    scene = load(assets(asset_id))
    entry = assets.manifest[asset_id]
    stats = scene.stats()
    assert stats["rendered_triangles"] == entry["triangles_rendered"]
    assert stats["unique_triangles"] == entry["triangles_unique"]
    assert ("triangles",) not in scene._cache  # counted without expanding the instances
    if asset_id == "teapot_scene_1000":
        # 23 PointInstancers (529 instances) and 471 instanceable teapots drawn in place; 133 prototypes.
        assert stats["meshes"] == 0 and stats["instances"] == 1000 and stats["prototypes"] == 133
        assert int((scene.instances.index >= 0).sum()) == entry["instances_pointinstancer"]
    if asset_id == "chess_set":
        assert stats["instances"] == entry["instances_pointinstancer"] == 16


def test_a_scene_and_its_meshes_print_as_counts(np_rng):
    """A cell ending in ``scene`` printed every array of every mesh (megabytes for a stage of a few thousand
    meshes); it prints the counts of ``stats()``, and a mesh its sizes and what it holds."""
    scene = python_scene(np_rng, n=5)  # a ground quad and 5 octahedra (8 triangles each) of two prototypes
    scene.materials.append(wrt.Material())
    assert repr(scene) == ("Scene(1 mesh, 42 triangles (18 unique), 0 shapes, 2 prototypes, 5 instances, "
                           "0 cameras, 0 lights, 1 material)")  # one of a kind in the singular ("1 meshes")
    scene.source = "x.usda"
    assert repr(scene).startswith("Scene('x.usda': 1 mesh,")
    ground = scene.meshes[0]
    assert repr(ground) == "Mesh('/Ground', 4 points, 2 triangles)"
    uvs = np.zeros((2, 3, 2), np.float32)
    assert repr(Mesh("/m", ground.points, ground.indices, [0, 0], uvs=uvs, double_sided=True)) == (
        "Mesh('/m', 4 points, 2 triangles, uvs, double-sided)")
    # Instances printed every transform and source path: 400 KB for 20,000 instanceable prims.
    assert repr(scene.instances) == "Instances(5 instances of 2 prototypes, 1 source)"
    many = wrt.Instances(np.zeros(20_000, np.int32), np.tile(np.eye(4), (20_000, 1, 1)), np.arange(20_000),
                         np.full(20_000, -1), sources=[f"/World/Tree_{i}" for i in range(20_000)],
                         colors=np.ones((20_000, 3)))
    assert repr(many) == "Instances(20,000 instances of 1 prototype, 20,000 sources, colors)"
    # A prototype of one triangle printed as "Mesh('/World/PI/Protos/Tri', 3 points, 1 triangles)".
    one = Mesh("/one", ground.points[:1], np.zeros((1, 3), np.int32), [0])
    assert repr(one) == "Mesh('/one', 1 point, 1 triangle)"


def test_a_scene_of_a_mesh_not_in_a_list_names_the_field():
    """``Scene(meshes=mesh)`` failed with "'Mesh' object is not iterable" from inside its first check, and a list
    holding something else than meshes later still; tuples are taken as lists."""
    mesh = Mesh("/m", np.zeros((3, 3)), [[0, 1, 2]], [0])
    with pytest.raises(TypeError, match=r"Scene\(meshes=...\) takes a list, got Mesh; use meshes=\[mesh\]"):
        wrt.Scene(meshes=mesh)
    with pytest.raises(TypeError, match=r"meshes\[1\] is a int, not a wrt.Mesh"):
        wrt.Scene(meshes=[mesh, 3])
    light = wrt.DistantLight(direction=(0, 0, -1), color=(1, 1, 1))
    with pytest.raises(TypeError, match=r"use lights=\[light\]"):
        wrt.Scene(meshes=[mesh], lights=light)
    with pytest.raises(TypeError, match="cameras"):
        wrt.Scene(cameras=[wrt.Camera.look_at((0, 0, 5), (0, 0, 0), (0, 1, 0), 40.0)])
    scene = wrt.Scene(meshes=(mesh,), lights=(light,))
    assert scene.meshes == [mesh] and scene.lights == [light]
    assert len(scene.triangles()[1]) == 1


def test_expanded_ids_round_trip(np_rng):
    scene = python_scene(np_rng, n=9)
    rows = np.arange(scene.stats()["rendered_triangles"])
    prim, instance = scene.split_ids(rows)
    np.testing.assert_array_equal(scene.expanded_ids(prim, instance), rows)
    assert (instance[: scene.num_flat_triangles] == -1).all() and instance[-1] == 8
    assert len(scene.triangles()[1]) == len(rows) == 2 + 9 * 8


# Tracing


def test_two_level_bvh_agrees_with_wp_mesh_on_transformed_instances(np_rng):
    scene = python_scene(np_rng)
    o1, d1 = camera_rays(scene, width=160, height=120)
    o2, d2 = random_rays(scene, 30_000, seed=5)
    report = check_agreement(scene, np.concatenate([o1, o2]), np.concatenate([d1, d2]))
    assert report["hits_a"] > 10_000
    assert isinstance(get_accelerator(scene), wrt.tlas.InstancedAccelerator)


@pytest.mark.parametrize("asset_id", ["chess_set", "teapot_scene_1000"])
def test_two_level_bvh_agrees_with_wp_mesh_on_real_scenes(assets, asset_id):
    scene = load(assets(asset_id))
    o1, d1 = camera_rays(scene, width=200, height=150)
    o2, d2 = random_rays(scene, 20_000, seed=7)
    report = check_agreement(scene, np.concatenate([o1, o2]), np.concatenate([d1, d2]))
    assert report["hits_a"] > 5_000


def test_hit_paths_name_the_usd_prims_and_instances_hit(tmp_path):
    """``Scene.hit_paths`` maps each hit back to USD by paths that stay when the stage is opened again: the mesh or
    gprim path, a native instance's part at its instance-proxy path (``/Plain/Body``, nested ones too), a
    PointInstancer's at its prototype prim's own path (moved into the native instance holding the instancer), and the
    instance (``/PI[index]``, or the instanceable prim; a nested one at its instance-proxy path, ``/Outer/Inner``,
    ``/Outer/Kit[0]``), compared with the prims pxr gives the rays' targets. A native instance's part was named by its
    prototype path (``/__Prototype_1/Body``), which USD renames per opening; a nested instance by the outermost one
    (``/Outer``)."""
    path = str(tmp_path / "paths.usda")
    stage = Usd.Stage.CreateNew(path)
    octahedron(stage, "/Ground").AddTranslateOp().Set((0, 0, 0))
    UsdGeom.Sphere.Define(stage, "/Ball").AddTranslateOp().Set((0, 0, -10))
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    octahedron(stage, "/PI/Protos/A/Mesh")
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/A"])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(10, 0, 0), (20, 0, 0), (30, 0, 0)])
    pi.CreateInvisibleIdsAttr([1])
    UsdGeom.Xform.Define(stage, "/Asset").GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)
    octahedron(stage, "/Asset/Body")
    UsdGeom.Xform.Define(stage, "/Nest").GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)  # an instance in an instance
    inner = UsdGeom.Xform.Define(stage, "/Nest/Inner")
    inner.GetPrim().GetReferences().AddInternalReference("/Asset")
    inner.GetPrim().SetInstanceable(True)
    kit = UsdGeom.PointInstancer.Define(stage, "/Nest/Kit")  # a PointInstancer in an instance
    octahedron(stage, "/Nest/Kit/Protos/A/Mesh")
    kit.CreatePrototypesRel().SetTargets(["/Nest/Kit/Protos/A"])
    kit.CreateProtoIndicesAttr([0])
    kit.CreatePositionsAttr([(0, 5, 0)])
    for name, source, y in (("Plain", "/Asset", 10), ("Plain2", "/Asset", 20), ("Outer", "/Nest", 30)):
        inst = UsdGeom.Xform.Define(stage, f"/{name}")
        inst.GetPrim().GetReferences().AddInternalReference(source)
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set((0, y, 0))
    stage.Save()
    scene = load(path)
    targets = {(0, 0, 0): ("/Ground", ""), (0, 0, -10): ("/Ball", ""), (10, 0, 0): ("/PI/Protos/A/Mesh", "/PI[0]"),
               (30, 0, 0): ("/PI/Protos/A/Mesh", "/PI[2]"), (0, 10, 0): ("/Plain/Body", "/Plain"),
               (0, 20, 0): ("/Plain2/Body", "/Plain2"), (0, 30, 0): ("/Outer/Inner/Body", "/Outer/Inner"),
               (0, 35, 0): ("/Outer/Kit/Protos/A/Mesh", "/Outer/Kit[0]"), (20, 0, 0): ("", "")}
    origins = np.array(list(targets), np.float64) + (0.1, 0.2, 5)  # each ray straight down -z onto its target
    hits = wrt.trace(scene, origins, [0, 0, -1])
    prims, instances = scene.hit_paths(hits)
    assert list(zip(prims, instances)) == list(targets.values())
    assert all(stage.GetPrimAtPath(p).IsInstanceProxy() for p in prims[4:8])
    # A prim id per path drawn: the two PointInstancer instances share one, each native instance's part has its own.
    ids, _ = scene.hit_prims(hits.local_prim, hits.instance)
    assert ids[2] == ids[3] and len(set(ids[:8])) == 7 and ids[8] == -1
    assert [scene.prim_paths()[i] for i in ids[:8]] == list(prims[:8])
    empty = scene.hit_paths(wrt.trace(scene, np.zeros((0, 3)), np.zeros((0, 3))))
    assert [len(a) for a in empty] == [0, 0]


def test_prim_lookup_is_made_once_per_scene_state(np_rng, monkeypatch):
    """``hit_paths``, ``hit_prims`` and ``prim_paths`` look prims up in one table the scene caches: made on each call,
    it took 0.4 s for 40k parts, and ``render_products`` made it twice per id layer. A replaced mesh makes it anew,
    and the list ``prim_paths`` returns is the caller's to change."""
    scene = python_scene(np_rng, n=9)
    made = []
    drawn_ids = wrt.scene.drawn_ids
    monkeypatch.setattr(wrt.scene, "drawn_ids", lambda s: made.append(s) or drawn_ids(s))
    hits = wrt.trace(scene, *camera_rays(scene, width=32, height=32))
    prims, _ = scene.hit_paths(hits)
    assert "/Ground" in prims and "/A" in prims  # the ground and a prototype's mesh are hit
    scene.hit_paths(hits)
    scene.hit_prims(hits.local_prim, hits.instance)
    paths = scene.prim_paths()
    assert len(made) == 1
    paths.append("/Mine")
    assert "/Mine" not in scene.prim_paths()
    scene.meshes[0] = Mesh("/Floor", scene.meshes[0].points, scene.meshes[0].indices, scene.meshes[0].face_ids)
    hits = wrt.trace(scene, *camera_rays(scene, width=32, height=32))  # those from before the edit are refused
    assert scene.prim_paths()[0] == "/Floor" and "/Floor" in scene.hit_paths(hits)[0] and len(made) == 2


def test_nested_instances_are_named_by_the_path_usdview_selects(tmp_path):
    """Instances nested two native instances deep are named by their instance-proxy paths (the outer instance's path
    plus the inner prim's path inside it: ``/Top/Mid/Inner``, ``/Top/Mid/Kit[1]``), each a prim of the stage that
    usdview selects; what a PointInstancer's prototype holds is named by the instancer's instance (``/Holder[1]``:
    the prototype is one prim for all its instances). All of ``/Top`` was named ``/Top``. The instance order (the
    ids) keeps each world-level instance's nested instances together."""
    path = str(tmp_path / "nested.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Xform.Define(stage, "/Asset").GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)
    octahedron(stage, "/Asset/Body")
    UsdGeom.Xform.Define(stage, "/Nest").GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)
    kit = UsdGeom.PointInstancer.Define(stage, "/Nest/Kit")
    octahedron(stage, "/Nest/Kit/Protos/A/Mesh")
    kit.CreatePrototypesRel().SetTargets(["/Nest/Kit/Protos/A"])
    kit.CreateProtoIndicesAttr([0, 0])
    kit.CreatePositionsAttr([(0, 5, 0), (5, 5, 0)])
    UsdGeom.Xform.Define(stage, "/Deep").GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)
    for name, source, parent in (("Inner", "/Asset", "/Nest"), ("Mid", "/Nest", "/Deep"), ("Top", "/Deep", ""),
                                 ("Inst", "/Asset", "/Holder/Protos/H")):
        inst = UsdGeom.Xform.Define(stage, f"{parent}/{name}")
        inst.GetPrim().GetReferences().AddInternalReference(source)
        inst.GetPrim().SetInstanceable(True)
    holder = UsdGeom.PointInstancer.Define(stage, "/Holder")  # a native instance in a PointInstancer's prototype
    holder.CreatePrototypesRel().SetTargets(["/Holder/Protos/H"])
    holder.CreateProtoIndicesAttr([0, 0])
    holder.CreatePositionsAttr([(0, -20, 0), (10, -20, 0)])
    stage.Save()
    scene = load(path)
    targets = {(0, 0, 0): ("/Top/Mid/Inner/Body", "/Top/Mid/Inner"),
               (0, 5, 0): ("/Top/Mid/Kit/Protos/A/Mesh", "/Top/Mid/Kit[0]"),
               (5, 5, 0): ("/Top/Mid/Kit/Protos/A/Mesh", "/Top/Mid/Kit[1]"),
               (0, -20, 0): ("/Holder/Protos/H/Inst/Body", "/Holder[0]"),
               (10, -20, 0): ("/Holder/Protos/H/Inst/Body", "/Holder[1]")}
    origins = np.array(list(targets), np.float64) + (0.1, 0.2, 5)
    hits = wrt.trace(scene, origins, [0, 0, -1])
    prims, instances = scene.hit_paths(hits)
    assert list(zip(prims, instances)) == list(targets.values())
    for name in ("/Top/Mid/Inner", "/Top/Mid/Kit"):
        assert stage.GetPrimAtPath(name).IsInstanceProxy()
    # Stage order (/Top before /Holder), and in /Top the order its prims were read in.
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [
        "/Top/Mid/Kit[0]", "/Top/Mid/Kit[1]", "/Top/Mid/Inner", "/Holder[0]", "/Holder[1]"]


@pytest.mark.parametrize("tessellate", [False, True])
def test_element_of_a_points_or_curves_hit_is_its_point_or_curve(tmp_path, tessellate):
    """``Scene.hit_prims``' element (the ``elementId`` AOV) of a Points or BasisCurves hit is the point or curve hit,
    within its prim as a face is within its mesh: in world-level prims, in a native instance and in a
    PointInstancer's prototype (each instance the same points), drawn as spheres and tubes or tessellated. It was 0
    on all of them (tessellated: the face of the tessellated sphere, 3904)."""
    path = str(tmp_path / "points.usda")
    stage = Usd.Stage.CreateNew(path)

    def cloud(prim_path, xs):
        points = UsdGeom.Points.Define(stage, prim_path)
        points.CreatePointsAttr([(x, 0, 0) for x in xs])
        points.CreateWidthsAttr([1.0] * len(xs))

    cloud("/Pts", [0, 3, 6])
    curves = UsdGeom.BasisCurves.Define(stage, "/Curves")
    curves.CreateTypeAttr("linear")
    curves.CreateCurveVertexCountsAttr([2, 2])
    curves.CreatePointsAttr([(0, 9, 0), (0, 11, 0), (3, 9, 0), (3, 11, 0)])
    curves.CreateWidthsAttr([0.5] * 4)
    UsdGeom.Xform.Define(stage, "/Cloud").GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)
    cloud("/Cloud/Pts", [0, 3, 6])
    outer = UsdGeom.Xform.Define(stage, "/Outer")
    outer.GetPrim().GetReferences().AddInternalReference("/Cloud")
    outer.GetPrim().SetInstanceable(True)
    outer.AddTranslateOp().Set((0, 20, 0))
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    cloud("/PI/Protos/A/Pts", [0, 3])
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/A"])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(0, 30, 0), (0, 40, 0)])
    stage.Save()
    scene = load(path, tessellate_gprims=tessellate)
    targets = {(0, 0): 0, (3, 0): 1, (6, 0): 2, (0, 10): 0, (3, 10): 1, (0, 20): 0, (3, 20): 1, (6, 20): 2,
               (0, 30): 0, (3, 30): 1, (3, 40): 1, (20, 0): -1}
    hits = wrt.trace(scene, [(x + 0.05, y + 0.05, 5) for x, y in targets], [0, 0, -1])
    _, elements = scene.hit_prims(hits.local_prim, hits.instance)
    assert elements.tolist() == list(targets.values())
    _, instances = scene.hit_paths(hits)
    assert list(instances[5:8]) == ["/Outer/Pts[0]", "/Outer/Pts[1]", "/Outer/Pts[2]"]  # each point an instance


def test_occluded_matches_closest_hit(np_rng):
    scene = python_scene(np_rng)
    origins, directions = random_rays(scene, 20_000, seed=9)
    hits = wrt.trace(scene, origins, directions)
    t_max = np.where(np.arange(len(origins)) % 2 == 0, np.inf, 0.5 * np.where(np.isfinite(hits.t), hits.t, 1.0))
    blocked = wrt.occluded(scene, origins, directions, t_max=t_max.astype(np.float32))
    np.testing.assert_array_equal(blocked, hits.t < t_max)


def closest_hits_numpy(points, indices, origins, directions, t_min, t_max):
    """``(t, row)`` of the closest hit with ``t_min <= t < t_max`` of each ray on the triangles (Moller-Trumbore in
    float64), ``(inf, -1)`` for none."""
    p0, p1, p2 = (points[indices[:, k]].astype(np.float64) for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(directions[:, None], e2[None])
    det = (e1[None] * pv).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = origins[:, None] - p0[None]
        u = (tv * pv).sum(-1) / det
        qv = np.cross(tv, e1[None])
        v = (directions[:, None] * qv).sum(-1) / det
        t = (e2[None] * qv).sum(-1) / det
    ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= t_min[:, None]) & (t < t_max[:, None])
    t = np.where(ok, t, np.inf)
    best = t.min(axis=1)
    return best, np.where(np.isfinite(best), t.argmin(axis=1), -1)


def test_ray_intervals_across_instances_match_a_numpy_solution_ray_by_ray(np_rng):
    """Random ``[t_min, t_max)`` intervals, negative ones too, through mirrored and sheared instances and the ground:
    closest hits (two-level BVH and wp.Mesh on the flattened triangles) and any hits give what solving every
    ray against every triangle gives, ray by ray (the ground behind a ray's origin was missed by the BVH)."""
    scene = python_scene(np_rng, n=30)
    n = 2000
    origins = np_rng.uniform(-12, 12, (n, 3))
    directions = np_rng.normal(size=(n, 3))
    t_min = np_rng.uniform(-10, 10, n)
    t_max = t_min + np_rng.uniform(0, 12, n)
    t, row = closest_hits_numpy(*scene.triangles(), origins, directions, t_min, t_max)
    assert np.sum(np.isfinite(t) & (t < 0)) > 20 and np.sum(np.isfinite(t) & (t > 0)) > 20
    for accel in ("wrt", "warp"):
        hits = wrt.trace(scene, origins, directions, t_min=t_min, t_max=t_max, accel=accel)
        np.testing.assert_array_equal(hits.prim, row, err_msg=accel)
        np.testing.assert_allclose(hits.t, t, rtol=1e-4, atol=1e-4, err_msg=accel)
        blocked = wrt.occluded(scene, origins, directions, t_min=t_min, t_max=t_max, accel=accel)
        np.testing.assert_array_equal(blocked, row >= 0, err_msg=accel)


@pytest.mark.parametrize("prototype", [-1, 2])
def test_instance_of_a_missing_prototype_raises_naming_it(np_rng, prototype):
    """Python-built instances drawing prototype -1 or 2 of two: -1 drew the last prototype with accel="warp" (numpy
    indexing) and nothing with the two-level BVH, so the two disagreed without a word; 2 raised a bare IndexError."""
    scene = python_scene(np_rng, n=3)
    instances = Instances.from_transforms([0, prototype, 1], scene.instances.to_world)
    with pytest.raises(wrt.SceneError, match=rf"/instances\[1\]: draws prototype {prototype}, but the scene has 2"):
        wrt.Scene(meshes=scene.meshes, prototypes=scene.prototypes, instances=instances)
    scene.instances = instances  # set after the Scene was made: checked when it is traced
    for accel in ("wrt", "warp"):
        with pytest.raises(wrt.SceneError, match="draws prototype"):
            wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), accel=accel)


def test_instance_transform_in_row_vector_convention_raises_naming_it(np_rng, tmp_path):
    """Instance transforms are column-vector matrices; one passed in USD's row-vector convention (a Gf.Matrix4d, the
    transpose) has its translation in the bottom row, which only the top 3x4 being used dropped without a word (every
    such instance drawn at the origin). Python-built instances now raise; projective USD transforms warn and keep
    their affine part, as meshes do."""
    scene = python_scene(np_rng, n=3)
    transposed = scene.instances.to_world.copy()
    transposed[1] = transposed[1].T
    with pytest.raises(wrt.SceneError, match=r"/instances\[1\]: instance 1 has bottom row .* transpose of a Gf"):
        Instances.from_transforms([0, 1, 0], transposed)
    scene.instances.to_world[2, 3, 0] = 0.5  # changed in place after the Scene was made: checked when traced
    for accel in ("wrt", "warp"):
        with pytest.raises(wrt.SceneError, match=r"/instances\[2\]: instance 2 has bottom row \[0.5, 0.0, 0.0, 1.0\]"):
            wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), accel=accel)

    path = tmp_path / "projective.usda"
    path.write_text(INSTANCEABLE_GPRIMS.replace("INSTANCEABLE", "instanceable = true").replace(
        'double3 xformOp:translate = (9, 0, 0)',
        'matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0.5), (9, 0, 0, 1))').replace(
        'uniform token[] xformOpOrder = ["xformOp:translate"]\n}\ndef PointInstancer "F"',
        'uniform token[] xformOpOrder = ["xformOp:transform"]\n}\ndef PointInstancer "F"'))
    with pytest.warns(UserWarning, match=r"projective; its last column was ignored: 1 prim\(s\): /G$"):
        loaded = wrt.load_usd(path)
    g = [i for i in range(len(loaded.instances)) if loaded.instances.path(i).startswith("/G")]
    assert len(g) == 4  # Group's mesh Inner and the three trees of its nested Grove
    np.testing.assert_array_equal(loaded.instances.to_world[g][:, 3], np.tile([0, 0, 0, 1], (4, 1)))
    np.testing.assert_array_equal(loaded.instances.to_world[g][:, 0, 3], 9)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_instance_or_shape_transform_raises_naming_it(np_rng, bad):
    """A scene built in Python with a NaN or inf in an instance's (or a shape's) transform: the two-level BVH used
    to leave that instance out without a word, as if it had a zero scale; now it names it."""
    from wrt.primitives import Shape

    scene = python_scene(np_rng, n=4)
    scene.instances.to_world[2, 0, 3] = bad
    with pytest.raises(ValueError, match=r"instance 2 \(/instances\[2\]\) has a NaN or infinite transform"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)))
    shape = Shape("/Ball", "sphere", np.diag([1.0, bad, 1.0, 1.0]))
    scene = wrt.Scene(shapes=[shape])
    with pytest.raises(ValueError, match="shape /Ball has a NaN or infinite transform"):
        wrt.occluded(scene, np.zeros((1, 3)), np.ones((1, 3)))


@pytest.mark.parametrize("accel, layout", [("wrt", "binary"), ("wrt", "compact"), ("wrt", "wide8"), ("warp", "binary")])
@pytest.mark.parametrize("entry, bad", [((0, 0), np.nan), ((1, 1), np.inf), ((0, 3), np.nan), ((2, 3), 1e39)])
def test_instance_placed_by_no_float32_transform_raises_naming_it_in_every_accelerator(accel, layout, entry, bad):
    """An instance whose transform holds a NaN or inf, or whose translation float32 cannot hold (the devices place
    an instance's origin in float32), is one error naming it, whichever accelerator traces it. Only the two-level
    BVH raised; the flattened layouts and ``wp.Mesh`` left a NaN scale out without a word and named a NaN
    translation's triangle row, the two-level BVH left the 1e39 one out, and the scene warned each time that a
    zero scale was skipped."""
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    proto = Prototype("/P", [Mesh("/P/tri", tri, [[0, 1, 2]], [0], double_sided=True)])
    to_world = np.stack([np.eye(4)] * 3)
    to_world[2][entry] = bad
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "singular transform (a zero scale)" warning: it is no zero scale
        scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0, 0, 0], to_world))
    with pytest.raises(ValueError, match=r"instance 2 \(/instances\[2\]\) "):
        wrt.trace(scene, [[0.2, 0.2, 5.0]], [[0, 0, -1]], accel=accel, layout=layout)


@pytest.mark.parametrize("z_scale", [0.0, 1e-31])
def test_flat_instance_is_drawn_flat_alike_in_every_layout_and_in_wp_mesh(z_scale):
    """A scene built in Python with an instance squashed flat: drawn flat, as the USD loader draws such instances and
    as its baked mesh is (``Scene`` gives it a thickness of ``FLAT_THICKNESS`` of its size so that the two-level BVH
    can take rays into its space); the flattened triangles of the other layouts and of ``wp.Mesh`` show it alike (it
    was left out everywhere). The instance beside it is hit alike everywhere, and the rows of ``Scene.triangles()``
    keep their numbering."""
    from wrt.primitives import Shape, tessellate

    corners, faces, _ = tessellate(Shape("/Box", "box", np.eye(4)))  # the closed cube [-1, 1]^3
    box = Prototype("/Box", [Mesh("/Box/mesh", corners, faces, np.arange(len(faces)))])
    flat, upright = np.diag([1.0, 1.0, z_scale, 1.0]), np.eye(4)
    upright[0, 3] = 4.0
    scene = wrt.Scene(prototypes=[box], instances=Instances.from_transforms([0, 0], np.stack([flat, upright])))
    origins = np.array([[0.2, 0.3, 5.0], [4.2, 0.3, 5.0]], np.float32)
    directions = np.array([[0.0, 0.0, -1.0]] * 2, np.float32)
    assert len(scene.triangles()[1]) == 2 * len(faces)
    for accel, layout in [("wrt", "binary"), ("wrt", "compact"), ("wrt", "wide"), ("wrt", "wide8"), ("warp", "binary")]:
        hits = wrt.trace(scene, origins, directions, accel=accel, layout=layout)
        assert 0 <= hits.prim[0] < len(faces) and abs(hits.t[0] - 5.0) <= 2e-4, (accel, layout)
        assert hits.prim[1] >= len(faces) and hits.t[1] == 4.0, (accel, layout)
        np.testing.assert_array_equal(wrt.occluded(scene, origins, directions, accel=accel, layout=layout),
                                      [True, True], err_msg=f"{accel} {layout}")


def test_device_memory_grows_by_at_most_128_bytes_per_instance(np_rng):
    """Two scenes with the same prototype, 200 and 2000 instances: the BLAS is the same, the rest is per instance."""
    sizes = {}
    for n in (200, 2000):
        scene = python_scene(np.random.default_rng(1), n=n)
        sizes[n] = get_accelerator(scene).device_bytes()
    assert sizes[200]["blas"] == sizes[2000]["blas"]
    per_instance = (sizes[2000]["tlas"] - sizes[200]["tlas"]) / 1800
    assert 48 <= per_instance <= MAX_BYTES_PER_INSTANCE, sizes


def test_warp_accel_refuses_to_flatten_huge_instanced_scenes(np_rng, monkeypatch):
    import importlib

    monkeypatch.setattr(importlib.import_module("wrt.trace"), "WARP_MAX_TRIANGLES", 100)
    scene = python_scene(np_rng)
    with pytest.raises(ValueError, match="accel='wrt'"):
        wrt.trace(scene, np.zeros((1, 3)), np.ones((1, 3)), accel="warp")


# Shading


def shaded_stage(tmp_path, instanceable: bool) -> str:
    """A ground plane and four single-sided octahedra with authored normals under instanceable (or plain) Xforms:
    translated, non-uniformly scaled, sheared (a raw matrix, as xform_weird_matrix) and mirrored."""
    path = str(tmp_path / f"shaded_{int(instanceable)}.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    ground = UsdGeom.Mesh.Define(stage, "/Ground")
    ground.CreatePointsAttr([(-6, -1.5, -6), (6, -1.5, -6), (6, -1.5, 6), (-6, -1.5, 6)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    asset = UsdGeom.Xform.Define(stage, "/Asset")
    octahedron(stage, "/Asset/Body")
    octahedron(stage, "/Asset/Hat", color=(0.2, 0.4, 0.9)).AddTranslateOp().Set((0, 1.2, 0))
    asset.GetPrim().SetSpecifier(pxr.Sdf.SpecifierClass)
    shear = Gf.Matrix4d(1, 0, 0, 0, 0.6, 1, 0, 0, 0.3, -0.4, 0.8, 0, 2.5, 0, 0, 1)
    transforms = {
        "Plain": [("translate", (-2.5, 0, 0))],
        "Squashed": [("translate", (0, 0, -2.5)), ("scale", (1.6, 0.5, 0.9))],
        "Sheared": [("matrix", shear)],
        "Mirrored": [("translate", (0, 0, 2.5)), ("scale", (-1, 1, 1)), ("rotateY", 25.0)],
    }
    for name, ops in transforms.items():
        x = UsdGeom.Xform.Define(stage, f"/{name}")
        x.GetPrim().GetReferences().AddInternalReference("/Asset")
        x.GetPrim().SetInstanceable(instanceable)
        for kind, value in ops:
            {"translate": x.AddTranslateOp, "scale": x.AddScaleOp, "rotateY": x.AddRotateYOp,
             "matrix": x.AddTransformOp}[kind]().Set(value)
    stage.Save()
    return path


def test_instances_shade_like_their_flattened_copies(tmp_path):
    """The same stage with instanceable on and off: every AOV and the image agree, so hits, back-face culling,
    geometric and shading normals (inverse transpose, mirrored instances too) and materials are right."""
    instanced = load(shaded_stage(tmp_path, True))
    flat = load(shaded_stage(tmp_path, False))
    assert len(instanced.instances) == 4 and len(flat.instances) == 0
    assert instanced.stats()["rendered_triangles"] == flat.stats()["rendered_triangles"]
    camera = wrt.Camera.look_at((7, 5, 9), (0, 0, 0), (0, 1, 0), 45.0)
    a = wrt.render(instanced, camera=camera, width=96, height=72)
    b = wrt.render(flat, camera=camera, width=96, height=72)
    hit = b.aovs["prim"] >= 0
    assert hit.mean() > 0.3
    np.testing.assert_array_equal(a.aovs["prim"], b.aovs["prim"])  # same expanded triangle ids
    assert set(np.unique(a.aovs["instance"][hit])) == {-1, 0, 1, 2, 3}
    np.testing.assert_allclose(a.aovs["depth"][hit], b.aovs["depth"][hit], rtol=1e-5)
    # Barycentrics computed in prototype space differ from world-space ones by rounding only.
    for name in ("normal", "geometric_normal"):
        np.testing.assert_allclose(a.aovs[name], b.aovs[name], atol=5e-4)
    np.testing.assert_allclose(a.aovs["albedo"], b.aovs["albedo"], atol=1e-6)
    np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-3)


@pytest.mark.parametrize("asset_id", ["chess_set", "teapot_scene_1000"])
def test_real_instanced_scenes_render(assets, asset_id):
    scene = load(assets(asset_id), time=1 if asset_id == "teapot_scene_1000" else None)
    img = wrt.render(scene, width=80, height=60)
    hit = img.aovs["prim"] >= 0
    assert hit.mean() > 0.1
    seen = np.unique(img.aovs["instance"][hit])
    assert len(seen) > (10 if asset_id == "chess_set" else 100)
    assert ("triangles",) not in scene._cache  # rendered without flattening the instances
    # The AOVs name the same triangles as wrt.trace of the same camera rays.
    origins, directions = camera_rays(scene, width=80, height=60)
    hits = wrt.trace(scene, origins, directions)
    same = hits.prim.reshape(60, 80) == img.aovs["prim"]
    assert same.mean() > 0.99


PREVIEW_MATERIAL = """
    def Material "{name}"
    {{
        token outputs:surface.connect = </Looks/{name}/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "UsdPreviewSurface"
            token outputs:surface
        }}
    }}"""
BINDINGS = """#usda 1.0
def Scope "Looks"
{""" + "".join(PREVIEW_MATERIAL.format(name=name) for name in ("Red", "Blue", "Green")) + """
}
class "Lib"
{
    def Xform "Leaf"
    {
        def Mesh "Deep" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            DEEP_BINDING
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 3), (1, 0, 3), (0, 1, 3)]
        }
    }
    def Xform "Asset"
    {
        def Mesh "Own" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            OWN_BINDING
            int[] faceVertexCounts = [3, 3]
            int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
            def GeomSubset "Half" (prepend apiSchemas = ["MaterialBindingAPI"])
            {
                uniform token elementType = "face"
                uniform token familyName = "materialBind"
                int[] indices = [1]
                rel material:binding = </Looks/Green>
            }
        }
        def Mesh "Bare" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            BARE_BINDING
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]
        }
        def Xform "Nested" (instanceable = true
            references = </Lib/Leaf>)
        {
        }
        def PointInstancer "Scatter"
        {
            rel prototypes = [</Lib/Asset/Scatter/Dot>]
            int[] protoIndices = [0]
            point3f[] positions = [(0, 0, 0)]
            def Mesh "Dot"
            {
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
                point3f[] points = [(0, 0, 4), (1, 0, 4), (0, 1, 4)]
            }
        }
    }
}
def Xform "Strong" (instanceable = true
    references = </Lib/Asset>
    prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Looks/Blue> (bindMaterialAs = "strongerThanDescendants")
}
def Xform "Above" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Looks/Blue> (bindMaterialAs = "strongerThanDescendants")
    double3 xformOp:translate = (10, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Xform "Inside" (instanceable = true
        references = </Lib/Asset>)
    {
    }
}
def Xform "Weak" (instanceable = true
    references = </Lib/Asset>
    prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Looks/Blue>
    double3 xformOp:translate = (20, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


@pytest.mark.parametrize(
    "deep, bare, own",
    [("</Looks/Green>", None, "</Looks/Red>"), (None, "</Looks/Red>", "</Looks/Red>"), (None, None, None)],
)
def test_material_bindings_on_or_above_native_instances_bind_as_on_instance_proxies(tmp_path, deep, bare, own):
    """As ComputeBoundMaterial on the instance proxies says: a strongerThanDescendants binding on an instance (or an
    ancestor of it) binds every mesh and subset inside, nested instances included (the prototype's own bindings
    were kept); a plain one binds the meshes that bind nothing themselves, in nested instances and instancers too
    (these were left unbound when every mesh of the outer prototype itself had a binding), and the faces outside
    the materialBind subsets of a mesh that binds nothing itself (those got the default material)."""
    path = tmp_path / "bindings.usda"
    text = BINDINGS
    for name, target in (("DEEP_BINDING", deep), ("BARE_BINDING", bare), ("OWN_BINDING", own)):
        text = text.replace(name, f"rel material:binding = {target}" if target else "")
    path.write_text(text)
    scene = load(path)
    # Expected: the material of each triangle of every instance proxy mesh, keyed by its world-space centroid.
    stage = Usd.Stage.Open(str(path))
    expected = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        to_world = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
        points = np.array(mesh.GetPointsAttr().Get(), np.float64) @ to_world[:3, :3] + to_world[3, :3]
        corners = np.array(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        faces = {}
        for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
            bound, _ = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()
            faces.update({int(f): str(bound.GetPath()) for f in subset.GetIndicesAttr().Get()})
        bound, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        for f, tri in enumerate(corners):
            expected[tuple(np.round(points[tri].mean(axis=0), 4))] = faces.get(f, str(bound.GetPath()))
    found = {}
    for i in range(len(scene.instances)):
        to_world = scene.instances.to_world[i]
        for mesh in scene.prototypes[scene.instances.prototype[i]].meshes:
            world = mesh.points.astype(np.float64) @ to_world[:3, :3].T + to_world[:3, 3]
            ids = mesh.material_ids if mesh.material_ids is not None else np.full(len(mesh.indices), -1)
            for tri, k in zip(mesh.indices, ids):
                found[tuple(np.round(world[tri].mean(axis=0), 4))] = scene.materials[k].path if k >= 0 else ""
    assert len(expected) == 15 and scene.stats()["rendered_triangles"] == 15
    assert found == expected


CAMERA_RIGS = """#usda 1.0
class "Lib"
{
    def Xform "Lens"
    {
        double3 xformOp:translate = (0, 2, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        def Camera "Close"
        {
            double3 xformOp:translate = (0, 0, 3)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    }
    def Xform "Rig"
    {
        def Camera "Cam"
        {
            double3 xformOp:translate = (0, 0, 10)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
        def Xform "Mount" (instanceable = true
            references = </Lib/Lens>)
        {
            double3 xformOp:translate = (1, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
        def Mesh "T"
        {
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }
    }
}
def Xform "R1" (instanceable = true
    references = </Lib/Rig>)
{
    double3 xformOp:translate = (5, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Between"
{
}
def Xform "R2" (instanceable = true
    references = </Lib/Rig>)
{
    double xformOp:rotateY = 90
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
}
def PointInstancer "Scatter"
{
    rel prototypes = [</Scatter/Proto>]
    int[] protoIndices = [0]
    point3f[] positions = [(0, -9, 0)]
    def Xform "Proto" (instanceable = true
        references = </Lib/Rig>)
    {
    }
}
"""


def test_cameras_inside_native_instances_are_read_at_their_instance_proxy_paths(tmp_path):
    """A camera in an instanced asset is a camera of the stage (``/R1/Cam``, its instance proxy, placed by the
    instance), nested instances included; it was left out without a word, so ``camera="/R1/Cam"`` said the scene
    had no camera and a render without one framed the scene itself. Cameras in PointInstancer prototypes warn."""
    path = tmp_path / "rigs.usda"
    path.write_text(CAMERA_RIGS)
    with pytest.warns(UserWarning, match="cameras inside PointInstancer prototypes are not supported.*/Scatter"):
        scene = wrt.load_usd(path)
    stage = Usd.Stage.Open(str(path))
    expected = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()):
        if prim.IsA(UsdGeom.Camera) and not prim.GetPath().HasPrefix("/Scatter"):  # not the prototype in place
            expected[str(prim.GetPath())] = np.array(UsdGeom.Camera(prim).GetCamera().transform).T
    assert list(scene.cameras) == list(expected) == [
        "/R1/Cam", "/R1/Mount/Close", "/Between", "/R2/Cam", "/R2/Mount/Close"
    ]
    for name, to_world in expected.items():
        np.testing.assert_allclose(scene.cameras[name].to_world, to_world, atol=1e-12)
    image = wrt.render(scene, camera="/R2/Mount/Close", width=8, height=8)
    assert image.rgb.shape == (8, 8, 3)



def test_cameras_inside_hidden_native_instances_are_read_too(tmp_path):
    """Cameras do not follow visibility (one under an invisible Xform is read), but those of an invisible native
    instance, or of an invisible instance nested in a prototype, were left out: ``--frames`` with ``--camera
    /R1/Cam`` failed at every frame where the rig was hidden, and a render without a camera switched to another."""
    hidden = CAMERA_RIGS.replace(  # R1 hidden from time 2; the lens mount hidden inside every rig
        'double3 xformOp:translate = (5, 0, 0)', 'token visibility.timeSamples = { 1: "inherited", 2: "invisible" }\n'
        '    double3 xformOp:translate = (5, 0, 0)').replace(
        'references = </Lib/Lens>)\n        {',
        'references = </Lib/Lens>)\n        {\n            token visibility = "invisible"')
    assert hidden.count("invisible") == 2
    path = tmp_path / "hidden_rigs.usda"
    path.write_text(hidden)
    stage = Usd.Stage.Open(str(path))
    for time in (1.0, 2.0):
        with pytest.warns(UserWarning, match="cameras inside PointInstancer prototypes"):
            scene = wrt.load_usd(path, time=time)
        assert list(scene.cameras) == ["/R1/Cam", "/R1/Mount/Close", "/Between", "/R2/Cam", "/R2/Mount/Close"]
        for name, camera in scene.cameras.items():
            to_world = np.array(UsdGeom.Camera(stage.GetPrimAtPath(name)).GetCamera(time).transform).T
            np.testing.assert_allclose(camera.to_world, to_world, atol=1e-12)
        assert len(scene.instances) == (2 if time == 1.0 else 1) + 1  # the rigs drawn, and the Scatter one


def test_an_instanceable_camera_keeps_its_camera(tmp_path):
    """A Camera prim that is itself instanceable (a camera rig referenced with ``instanceable = true``, as tools that
    make every reference instanceable write it) is a camera of the stage at its own path, as USD lists it, before the
    cameras inside it, hidden or not, and inside a native prototype through each instance; its attributes live on the
    instance prim, not in the prototype, and it was left out (``camera="/ShotCam"`` said there was no such camera),
    while an instanceable gprim kept its geometry and an instanceable light its light."""
    (tmp_path / "rig.usda").write_text("""#usda 1.0
(
    defaultPrim = "Cam"
)
def Camera "Cam"
{
    float focalLength = 35
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Camera "Inner"
    {
        float focalLength = 20
    }
}
""")
    path = tmp_path / "shot.usda"
    path.write_text("""#usda 1.0
def Camera "ShotCam" (instanceable = true
    references = @./rig.usda@)
{
}
def Camera "HiddenCam" (instanceable = true
    references = @./rig.usda@)
{
    token visibility = "invisible"
    double3 xformOp:translate = (4, 0, 10)
}
def Xform "Set" (instanceable = true
    references = </Lib>)
{
    double3 xformOp:translate = (0, 5, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
class "Lib"
{
    def Camera "Crane" (instanceable = true
        references = @./rig.usda@)
    {
    }
}
""")
    scene = wrt.load_usd(path)
    stage = Usd.Stage.Open(str(path))
    expected = {str(p.GetPath()): np.array(UsdGeom.Camera(p).GetCamera().transform).T
                for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()) if p.IsA(UsdGeom.Camera)}
    assert list(scene.cameras) == list(expected) == [
        "/ShotCam", "/ShotCam/Inner", "/HiddenCam", "/HiddenCam/Inner", "/Set/Crane", "/Set/Crane/Inner"]
    for name, to_world in expected.items():
        np.testing.assert_allclose(scene.cameras[name].to_world, to_world, atol=1e-12)
        focal = UsdGeom.Camera(stage.GetPrimAtPath(name)).GetFocalLengthAttr().Get()
        assert scene.cameras[name].focal_length == pytest.approx(focal)

INSTANCEABLE_GPRIMS = """#usda 1.0
class "Lib"
{
    def Mesh "Tri"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
    def Sphere "Ball"
    {
        double radius = 0.5
    }
    def PointInstancer "Forest"
    {
        rel prototypes = [</Lib/Forest/Protos/Tree>]
        int[] protoIndices = [0, 0, 0]
        point3f[] positions = [(0, 0, 0), (0, 2, 0), (0, 4, 0)]
        def Scope "Protos"
        {
            def Mesh "Tree"
            {
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
                point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
            }
        }
    }
    def Xform "Group"
    {
        def Mesh "Inner" (INSTANCEABLE
            references = </Lib/Tri>)
        {
            double3 xformOp:translate = (0, 0, 2)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
        def PointInstancer "Grove" (INSTANCEABLE
            references = </Lib/Forest>)
        {
            double3 xformOp:translate = (0, 0, -2)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    }
}
def Mesh "A" (INSTANCEABLE
    references = </Lib/Tri>)
{
    double3 xformOp:translate = (3, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Sphere "B" (INSTANCEABLE
    references = </Lib/Ball>)
{
    double3 xformOp:translate = (6, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "G" (INSTANCEABLE
    references = </Lib/Group>)
{
    double3 xformOp:translate = (9, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def PointInstancer "F" (INSTANCEABLE
    references = </Lib/Forest>)
{
    double3 xformOp:translate = (12, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


@pytest.mark.parametrize("tessellate", [False, True])
def test_instanceable_meshes_gprims_and_instancers_are_drawn(tmp_path, tessellate):
    """A mesh, gprim or PointInstancer that is itself instanceable keeps its own data on the instance prim (its
    prototype holds only its descendants, and the prototype root has no type and no properties): it is drawn as the
    same stage with instancing off draws it, at the world level and inside prototypes (meshes and gprims were dropped
    without a word; an instancer's prototypes were drawn once, in place)."""
    scenes = []
    for flag in ("true", "false"):
        path = tmp_path / f"instanceable_{flag}.usda"
        path.write_text(INSTANCEABLE_GPRIMS.replace("INSTANCEABLE", f"instanceable = {flag}"))
        assert Usd.Stage.Open(str(path)).GetPrimAtPath("/A").IsInstance() == (flag == "true")
        scenes.append(load(path, tessellate_gprims=tessellate))
    instanced, flat = scenes
    rendered = flat.stats()["rendered_triangles"]
    assert instanced.stats()["rendered_triangles"] == rendered and (rendered > 100 if tessellate else rendered == 8)
    assert instanced.stats()["rendered_shapes"] == flat.stats()["rendered_shapes"] == (0 if tessellate else 1)

    def corners(scene):
        points, indices = scene.triangles()
        return np.sort(points[indices].reshape(len(indices), -1), axis=0)

    np.testing.assert_allclose(corners(instanced), corners(flat), atol=1e-6)
    origins = np.array([[3.2, 0.2, 5.0], [6.0, 0.0, 5.0], [9.2, 0.2, 5.0], [12.2, 4.2, 5.0], [9.2, 2.2, 5.0]])
    directions = np.tile([0.0, 0.0, -1.0], (5, 1))
    np.testing.assert_allclose(wrt.trace(instanced, origins, directions).t, [5.0, 4.5, 3.0, 5.0, 7.0], rtol=1e-5)


INHERITED_COLORS = """#usda 1.0
class "Lib"
{
    def Xform "Leaf"
    {
        def Mesh "Bare"
        {
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }
        def Sphere "Ball"
        {
            double radius = 0.2
            double3 xformOp:translate = (0, 0, 2)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
        def Mesh "Own"
        {
            color3f[] primvars:displayColor = [(0, 0, 1)]
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]
        }
    }
    def Xform "Pair"
    {
        def Xform "Plain" (instanceable = true
            references = </Lib/Leaf>)
        {
        }
        def Xform "Yellow" (instanceable = true
            references = </Lib/Leaf>)
        {
            color3f[] primvars:displayColor = [(1, 1, 0)]
            double3 xformOp:translate = (0, 5, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    }
}
def Xform "Red" (instanceable = true
    references = </Lib/Pair>)
{
    color3f[] primvars:displayColor = [(1, 0, 0)]
    double3 xformOp:translate = (10, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "Group"
{
    color3f[] primvars:displayColor = [(0, 1, 0)]
    def Xform "Green" (instanceable = true
        references = </Lib/Pair>)
    {
        double3 xformOp:translate = (20, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def Xform "Grey" (instanceable = true
    references = </Lib/Pair>)
{
    double3 xformOp:translate = (30, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def test_display_color_is_inherited_through_native_instances(tmp_path):
    """A constant displayColor on a native instance (or above it) colours the prototype's meshes and gprims that
    have none, as FindPrimvarWithInheritance on the instance proxies gives, nested instances included; a mesh's own
    colour wins. They were all grey 0.5: a prototype was read once, blind to the colours of its instances."""
    path = tmp_path / "colors.usda"
    path.write_text(INHERITED_COLORS)
    scene = load(path, tessellate_gprims=8)
    stage = Usd.Stage.Open(str(path))
    expected = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()):
        if prim.IsA(UsdGeom.Gprim):
            primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(UsdGeom.Tokens.primvarsDisplayColor)
            color = primvar.ComputeFlattened()[0] if primvar and primvar.HasValue() else (0.5, 0.5, 0.5)
            box = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_]).ComputeWorldBound(prim)
            expected[tuple(np.round(box.ComputeAlignedRange().GetMidpoint(), 3))] = tuple(np.round(color, 4))
    found = {}  # the colour of each prototype mesh in each instance, keyed by the centre of its world box
    for i in range(len(scene.instances)):
        to_world = scene.instances.to_world[i]
        for mesh in scene.prototypes[scene.instances.prototype[i]].meshes:
            world = mesh.points.astype(np.float64) @ to_world[:3, :3].T + to_world[:3, 3]
            color = mesh.colors[0, 0] if mesh.colors is not None else (0.5, 0.5, 0.5)
            centre = (world.min(axis=0) + world.max(axis=0)) / 2
            found[tuple(np.round(centre, 3))] = tuple(np.round(np.asarray(color, np.float64), 4))
    assert len(expected) == 3 * 2 * 3  # three instances of Pair, two of Leaf in each, three gprims in Leaf
    assert found == expected


def test_inherited_display_colors_are_capped_per_prototype(tmp_path, monkeypatch):
    """Each inherited colour is a copy of the prototype: past the cap an instance keeps the prototype's own colours,
    with a warning naming it, so instancing keeps its memory bound."""
    monkeypatch.setattr(importlib.import_module("wrt.usd_native_instances"), "MAX_INHERITED_COLORS", 2)
    path = tmp_path / "colors.usda"
    path.write_text(INHERITED_COLORS)
    with pytest.warns(UserWarning, match=r"more than 2 colours per prototype"):
        scene = wrt.load_usd(path)
    # Leaf as authored and in two of its three inherited colours (yellow, red; green is one too many).
    colors = sorted(tuple(np.round(p.meshes[0].colors[0, 0], 3)) if p.meshes[0].colors is not None else ()
                    for p in scene.prototypes)
    assert colors == [(), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0)]


@pytest.mark.parametrize("scale", [1e-25, 1e-12, 1e12, 1e25])
def test_instances_at_extreme_scales_hit_as_a_float64_solution_says(scale):
    """Octahedra scaled by 1e-25 ... 1e25 (turned, some mirrored, sheared; placed a few sizes apart, so the scene is
    float32-sized relative to itself), rays aimed inside random triangles from a few sizes away: the two-level
    BVH (whose BLAS sees directions of length ~1/scale) finds each ray's closest triangle and instance and its ``t``
    as solving every ray against every world triangle in float64 does, and any hit agrees. A guard: no failure was
    found here; ``accel="warp"`` (on the flattened triangles, on the CPU) misses all 3,000 at 1e-25 and 1e25."""
    rng = np.random.default_rng(11)
    n_instances = 16
    to_world = random_affine(rng, n_instances)
    to_world[:, :3, :] *= scale
    scene = wrt.Scene(prototypes=python_scene(rng, n=1).prototypes[:1],
                      instances=Instances.from_transforms(np.zeros(n_instances, int), to_world))
    mesh = scene.prototypes[0].meshes[0]
    world = np.concatenate([np.asarray(mesh.points, np.float64) @ m[:3, :3].T + m[:3, 3] for m in to_world])
    indices = np.concatenate([mesh.indices + 6 * i for i in range(n_instances)])
    n = 3000
    aim = rng.integers(0, len(indices), n)
    weights = rng.dirichlet([4, 4, 4], n)  # well inside the triangle: no edge ties
    targets = np.einsum("nk,nkj->nj", weights, world[indices[aim]])
    origins = (targets + rng.normal(size=(n, 3)) * 3 * scale).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    t, row = closest_hits_numpy(world, indices, origins.astype(np.float64), directions.astype(np.float64),
                                np.zeros(n), np.full(n, np.inf))
    assert np.isfinite(t).all()
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_allclose(hits.t, t, rtol=1e-3)  # a grazing ray or two err by 1.3e-4
    np.testing.assert_array_equal(hits.instance, row // 8)
    np.testing.assert_array_equal(hits.local_prim, row % 8)
    assert wrt.occluded(scene, origins, directions).all()


def test_instances_and_shapes_far_from_the_origin_are_traced_as_exactly_as_their_placement():
    """A sphere of radius 1 and an instanced octahedron (turned, mirrored) placed 1e5 from the world origin at
    float32-exact positions, rays from a few units away: each hit lies on the float64 surface to float32 precision of
    the rays' distance from it, and every ray aimed inside a triangle hits it. Rays moved into local space as
    ``A world + b`` summed terms of 1e5 that cancel: 1,999 of 2,000 hits on the sphere lay off its surface (by up to
    about 1% of its radius), and 38 of 2,000 rays got another triangle of the octahedron or none; ``A (world - c)``
    takes the difference first."""
    from wrt.primitives import Shape

    rng = np.random.default_rng(5)
    turn, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    centre = np.array([1e5 + 0.25, 1e5 - 0.5, -1e5 + 0.75])  # float32-exact
    to_world = np.eye(4)
    to_world[:3, :3] = turn @ np.diag([1.0, -1.0, 1.0])
    to_world[:3, 3] = centre
    n = 2000
    aim = rng.uniform(-0.6, 0.6, (n, 3)) @ to_world[:3, :3].T + centre
    origins = (aim + rng.normal(size=(n, 3)) * 3).astype(np.float32)
    directions = (aim - origins).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)

    ball = wrt.Scene(shapes=[Shape("/Ball", "sphere", to_world)])
    hits = wrt.trace(ball, origins, directions)
    assert hits.hit.all()  # every ray aims inside the sphere
    points = o64 + hits.t[:, None].astype(np.float64) * d64
    np.testing.assert_allclose(np.linalg.norm(points - centre, axis=1), 1.0, atol=1e-5)

    pts = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], np.float32)
    faces = np.array([(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)])
    proto = Prototype("/Octa", [Mesh("/Octa/mesh", pts, faces, np.arange(8))])
    octa = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0], to_world[None]))
    world = pts.astype(np.float64) @ to_world[:3, :3].T + centre
    weights = rng.dirichlet([4, 4, 4], n)
    targets = np.einsum("nk,nkj->nj", weights, world[faces[rng.integers(0, 8, n)]])
    origins = (targets + rng.normal(size=(n, 3)) * 3).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    t, row = closest_hits_numpy(world, faces, origins.astype(np.float64), directions.astype(np.float64), np.zeros(n),
                                np.full(n, np.inf))
    assert np.isfinite(t).all()
    hits = wrt.trace(octa, origins, directions)
    np.testing.assert_array_equal(hits.local_prim, row)
    # The hit points lie in their triangles' planes (float64), not merely along the rays near them.
    corners = world[faces[row]]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = origins.astype(np.float64) + hits.t[:, None].astype(np.float64) * directions.astype(np.float64)
    np.testing.assert_allclose(np.einsum("nj,nj->n", points - corners[:, 0], normals), 0.0, atol=1e-5)


@pytest.mark.xfail(strict=True, reason=(
    "an instance's or shape's translation c is held in float32 on the device ([A | c], wrt.transforms; kernels not "
    "changed here): a placement that float32 cannot hold is moved by up to half a float32 step of its distance from "
    "the world origin (5e-4 at 1e4), as much as a 1 mm object's size there; holding c as two float32s (c_hi + c_lo, "
    "subtracted in turn) would keep it, at 12 more bytes per instance"))
@pytest.mark.parametrize("kind", ["sphere", "instance"])
def test_small_objects_at_placements_float32_cannot_hold_are_hit_where_float64_puts_them(kind):
    """A sphere of radius 1e-3 and an instanced octahedron of that size, 1e4 from the world origin at a centre that is
    no float32 (3e-5 off the nearest, 3% of their size), rays from a few sizes away aimed inside them: the sphere's
    hit points lie on its float64 surface, and each ray aimed well inside a triangle hits that triangle at the
    float64 ``t``."""
    from wrt.primitives import Shape

    rng = np.random.default_rng(2)
    centre = np.array([1e4 + 1e-4 / 3, -7.5e3 + 2e-4 / 7, 3e3 + 1e-4 / 9])
    size = 1e-3
    to_world = np.eye(4)
    to_world[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] * size
    to_world[:3, 3] = centre
    n = 2000
    if kind == "sphere":
        scene = wrt.Scene(shapes=[Shape("/Ball", "sphere", to_world)])
        q = rng.normal(size=(n, 3))
        targets = centre + 0.7 * size * q / np.linalg.norm(q, axis=1, keepdims=True)
    else:
        pts = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], np.float32)
        faces = np.array([(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)])
        proto = Prototype("/Octa", [Mesh("/Octa/mesh", pts, faces, np.arange(8))])
        scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms([0], to_world[None]))
        world = pts.astype(np.float64) @ to_world[:3, :3].T + centre
        targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[faces[rng.integers(0, 8, n)]])
    origins = (targets + rng.normal(size=(n, 3)) * 3 * size).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    hits = wrt.trace(scene, origins, directions)
    if kind == "sphere":
        assert hits.hit.all()
        points = o64 + hits.t[:, None].astype(np.float64) * d64
        np.testing.assert_allclose(np.linalg.norm(points - centre, axis=1), size, rtol=1e-3)
    else:
        t, row = closest_hits_numpy(world, faces, o64, d64, np.zeros(n), np.full(n, np.inf))
        clear = barycentric_margins(world, faces, o64, d64, t, row) > 1e-2
        assert clear.sum() > 0.9 * n
        np.testing.assert_array_equal(hits.prim[clear], row[clear])
        np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3)


OCTAHEDRON = (np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], np.float32),
              np.array([(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]))


def octahedra_scene(to_world: np.ndarray) -> wrt.Scene:
    """Instances of the unit octahedron (``OCTAHEDRON``: points, faces) placed by ``(n, 4, 4)`` ``to_world``."""
    pts, faces = OCTAHEDRON
    proto = Prototype("/Octa", [Mesh("/Octa/mesh", pts, faces, np.arange(8))])
    return wrt.Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(len(to_world), int), to_world))


def octahedra_triangles(linear: np.ndarray, placed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(world, indices)``: the float64 world corners and the faces of octahedra placed as ``linear @ p + placed``
    (``(n, 3, 3)``, ``(n, 3)``), the triangles of :func:`octahedra_scene` for a float64 oracle."""
    pts, faces = OCTAHEDRON
    world = np.concatenate([pts.astype(np.float64) @ a.T + c for a, c in zip(linear, placed)])
    return world, np.concatenate([faces + 6 * i for i in range(len(linear))])


def stretched_octahedra(rng, stretch: str, n_instances: int) -> np.ndarray:
    """``(n, 4, 4)`` placements of the unit octahedron that stretch some directions far more than others: turned,
    sheared by 300 along a random pair of axes (``"sheared"``: its world shape a needle or a blade 300 long and 1/300
    thin) or squashed to 1e-6 along one axis (``"squashed"``: a sheet), translated within 2000 of the origin."""
    to_world = np.tile(np.eye(4), (n_instances, 1, 1))
    for k in range(n_instances):
        q1, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        q2, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        middle = np.eye(3)
        if stretch == "sheared":
            a, b = rng.choice(3, 2, replace=False)
            middle[a, b] = 300.0
        else:
            middle[2, 2] = 1e-6
        to_world[k, :3, :3] = q1 @ middle @ q2
    to_world[:, :3, 3] = rng.uniform(-2000, 2000, (n_instances, 3))
    return to_world


def aimed_from_afar(rng, world, indices, n: int = 3000):
    """``n`` float32 rays from about 900 away at points of random triangles of ``world[indices]``, with their float64
    closest hits ``(t, row)`` and whether each passes more than 1% of its triangle inside it (over 90% of them)."""
    aim = rng.integers(0, len(indices), n)
    targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[indices[aim]])
    origins = (targets + rng.normal(size=(n, 3)) * 900).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t, row = closest_hits_numpy(world, indices, o64, d64, np.zeros(n), np.full(n, np.inf))
    clear = barycentric_margins(world, indices, o64, d64, t, row) > 1e-2
    assert clear.sum() > 0.9 * n
    return origins, directions, t, row, clear


def barycentric_margins(points, indices, origins, directions, t, row) -> np.ndarray:
    """``(N,)`` float64 smallest barycentric weight of each ray's hit point in its triangle ``row`` (how far inside
    the triangle the ray passes, relative to it), NaN for misses."""
    out = np.full(len(t), np.nan)
    hit = row >= 0
    p0, p1, p2 = (points[indices[row[hit], k]].astype(np.float64) for k in range(3))
    p = origins[hit] + t[hit, None] * directions[hit]
    e1, e2, w = p1 - p0, p2 - p0, p - p0
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    w1, w2 = (w * e1).sum(1), (w * e2).sum(1)
    det = d11 * d22 - d12 * d12
    u, v = (d22 * w1 - d12 * w2) / det, (d11 * w2 - d12 * w1) / det
    out[hit] = np.minimum(np.minimum(u, v), 1 - u - v)
    return out


@pytest.mark.parametrize("stretch", ["sheared", "squashed"])
def test_rays_from_afar_hit_stretched_instances_as_a_float64_solution_says(stretch):
    """Octahedra sheared by 300 or squashed to 1e-6 along one axis, rays from about 900 away aimed well inside random
    triangles: every ray whose float64 closest hit lies more than 1% of its triangle inside it (the rest can go to
    a neighbour within float32's reach) hits that instance (that triangle of a sheared one) at the float64 ``t``,
    and is occluded."""
    rng = np.random.default_rng(3)
    n_instances = 6
    to_world = stretched_octahedra(rng, stretch, n_instances)
    scene = octahedra_scene(to_world)
    world, indices = octahedra_triangles(to_world[:, :3, :3], to_world[:, :3, 3])
    origins, directions, t, row, clear = aimed_from_afar(rng, world, indices)
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.instance[clear], row[clear] // 8)
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3)  # a ray along a needle errs by 1.8e-4
    if stretch == "sheared":  # a squashed sheet's two faces lie within float32's reach of each other: ties
        np.testing.assert_array_equal(hits.prim[clear], row[clear])
    assert wrt.occluded(scene, origins, directions)[clear].all()


@pytest.mark.parametrize("stretch", ["sheared", "squashed"])
def test_rays_from_afar_hit_stretched_analytic_spheres_as_a_float64_solution_says(stretch):
    """Spheres placed as the octahedra above (sheared by 300, or squashed to 1e-6: an ellipsoid 2e-6 thin), rays
    from about 900 away aimed at points halfway from each centre to its surface: each hits its sphere at the float64
    ``t`` (the ray and the ellipsoid solved in float64 in the unit sphere's space, from the ray's closest point to
    the centre), and is occluded; limits before or past the sphere leave no hit. The shapes' rays were moved into
    their space from their own origin, as instances' were: 2,498 of the 3,000 rays missed the squashed ones."""
    from wrt.primitives import Shape

    rng = np.random.default_rng(3)
    to_world = stretched_octahedra(rng, stretch, 6)
    scene = wrt.Scene(shapes=[Shape(f"/Ball{k}", "sphere", m) for k, m in enumerate(to_world)])
    n = 3000
    k = rng.integers(0, 6, n)
    q = rng.normal(size=(n, 3))
    halfway = 0.5 * q / np.linalg.norm(q, axis=1, keepdims=True)
    targets = np.einsum("nij,nj->ni", to_world[k, :3, :3], halfway) + to_world[k, :3, 3]
    origins = (targets + rng.normal(size=(n, 3)) * 900).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    inverse = np.linalg.inv(to_world[k, :3, :3])
    local_o = np.einsum("nij,nj->ni", inverse, origins - to_world[k, :3, 3])
    local_d = np.einsum("nij,nj->ni", inverse, directions.astype(np.float64))
    a, b = (local_d * local_d).sum(1), (local_o * local_d).sum(1)
    closest = local_o - (b / a)[:, None] * local_d
    half_chord = np.sqrt((1 - (closest * closest).sum(1)) / a)
    t, far = -b / a - half_chord, -b / a + half_chord
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.prim, k)
    np.testing.assert_allclose(hits.t, t, rtol=1e-3)
    assert wrt.occluded(scene, origins, directions).all()
    # Limits before the near side and past the far side (t0, the ray's closest point to the centre, lies between).
    for limits in ({"t_max": t * (1 - 1e-3)}, {"t_min": far * (1 + 1e-3)}):
        assert not wrt.trace(scene, origins, directions, **limits).hit.any()
        assert not wrt.occluded(scene, origins, directions, **limits).any()


@pytest.mark.parametrize("kind", ["octahedra", "spheres"])
@pytest.mark.parametrize("stretch", ["sheared", "squashed"])
def test_rays_from_afar_hit_stretched_instances_behind_their_origin_as_a_float64_solution_says(stretch, kind):
    """The rays of the two tests above turned round, so that the octahedron or sphere they were aimed at lies behind
    their origin, traced over ``t`` in ``[-inf, 0)`` (``t_min`` may be negative; the closest hit is the smallest
    ``t``): every ray whose float64 hit lies well inside a triangle (a sphere: every ray) hits that instance at the
    float64 ``t``, and is occluded. Their origin was moved towards an instance only where the instance lay ahead, and
    rays taken into its space from 900 away missed it (octahedra squashed: 972 of 2,907 rays, sheared: 43 of 2,850;
    spheres squashed: 783 of 3,000)."""
    from wrt.primitives import Shape

    rng = np.random.default_rng(3)
    to_world = stretched_octahedra(rng, stretch, 6)
    n = 3000
    if kind == "octahedra":
        scene = octahedra_scene(to_world)
        world, indices = octahedra_triangles(to_world[:, :3, :3], to_world[:, :3, 3])
        aim = rng.integers(0, len(indices), n)
        targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[indices[aim]])
    else:
        scene = wrt.Scene(shapes=[Shape(f"/Ball{k}", "sphere", m) for k, m in enumerate(to_world)])
        k = rng.integers(0, 6, n)
        q = rng.normal(size=(n, 3))
        halfway = 0.5 * q / np.linalg.norm(q, axis=1, keepdims=True)
        targets = np.einsum("nij,nj->ni", to_world[k, :3, :3], halfway) + to_world[k, :3, 3]
    origins = (targets + rng.normal(size=(n, 3)) * 900).astype(np.float32)
    directions = (origins - targets).astype(np.float32)  # away from the target: it lies behind, near t = -1
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    limits = {"t_min": -np.inf, "t_max": 0.0}
    if kind == "octahedra":
        t, row = closest_hits_numpy(world, indices, o64, d64, np.full(n, -np.inf), np.zeros(n))
        clear = barycentric_margins(world, indices, o64, d64, t, row) > 1e-2
        assert clear.sum() > 0.9 * n
        expected = row // 8
    else:  # the far side of the ellipsoid (the smaller t), solved in the unit sphere's space from its closest point
        inverse = np.linalg.inv(to_world[k, :3, :3])
        local_o = np.einsum("nij,nj->ni", inverse, o64 - to_world[k, :3, 3])
        local_d = np.einsum("nij,nj->ni", inverse, d64)
        a, b = (local_d * local_d).sum(1), (local_o * local_d).sum(1)
        closest = local_o - (b / a)[:, None] * local_d
        t = -b / a - np.sqrt((1 - (closest * closest).sum(1)) / a)
        clear, expected = np.ones(n, bool), k
    hits = wrt.trace(scene, origins, directions, **limits)
    label = f"{np.count_nonzero(hits.prim[clear] < 0)} of {clear.sum()} rays missed"
    if kind == "octahedra":
        np.testing.assert_array_equal(hits.instance[clear], expected[clear], err_msg=label)
    else:
        np.testing.assert_array_equal(hits.prim[clear], expected[clear], err_msg=label)
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3, err_msg=label)
    assert wrt.occluded(scene, origins, directions, **limits)[clear].all()


def test_rays_from_afar_hit_sheared_instances_of_an_off_centre_prototype_as_a_float64_solution_says():
    """The sheared octahedra of ``test_rays_from_afar_hit_stretched_instances_as_a_float64_solution_says`` with the
    prototype's octahedron moved 50 of its sizes off the prototype's origin, ``(50, 15, 0)``: every ray whose
    float64 closest hit lies more than 1% of its triangle inside it hits that instance at the float64 ``t``, and
    that triangle where the ray passes its edges farther than float32's step at the ray's origin (2,770 of them; of
    the rest, one grazes the needle 4e-5 from an edge, a third of that step, and takes the neighbour), as it does
    centred.
    Traced about the prototype's origin, whose distance scaled the rounding of the float32 inverse, 117 of the
    2,812 rays did not (50 of them in another instance); the BLAS is now built about its box's centre
    (``wrt.tlas.blas_centres``). The flattened layouts hit the right instance."""
    rng = np.random.default_rng(3)
    to_world = stretched_octahedra(rng, "sheared", 6)
    points, faces = OCTAHEDRON
    points = (points.astype(np.float64) + [50.0, 15.0, 0.0]).astype(np.float32)
    proto = Prototype("/Octa", [Mesh("/Octa/mesh", points, faces, np.arange(8))])
    scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(6, int), to_world))
    world = np.concatenate([points.astype(np.float64) @ m[:3, :3].T + m[:3, 3] for m in to_world])
    indices = np.concatenate([faces + 6 * i for i in range(6)])
    origins, directions, t, row, clear = aimed_from_afar(rng, world, indices)
    flat = wrt.trace(scene, origins, directions, layout="wide8")  # float32 world triangles: the right instance
    np.testing.assert_array_equal(flat.instance[clear], row[clear] // 8)
    hits = wrt.trace(scene, origins, directions)
    wrong = np.count_nonzero(hits.instance[clear] != row[clear] // 8)
    assert wrong == 0, f"{wrong} of {clear.sum()} rays hit another instance or missed"
    np.testing.assert_allclose(hits.t[clear], t[clear], rtol=1e-3)
    o64 = origins.astype(np.float64)
    resolved = clear & (edge_clearances(world, indices, o64, directions.astype(np.float64), row)
                        > 2.0**-23 * np.abs(o64).max(axis=1))
    assert resolved.sum() > 0.98 * clear.sum()
    wrong = np.count_nonzero(hits.prim[resolved] != row[resolved])
    assert wrong == 0, f"{wrong} of {resolved.sum()} rays hit another triangle or missed"


@pytest.mark.parametrize("with_sphere", [False, True])
def test_off_centre_instances_placed_far_at_float32_translations_are_hit_where_float64_puts_them(with_sphere):
    """Turned, stretched octahedra 20 of their sizes off their prototype's origin (so their BLAS is built about its
    centre), placed 1e6 to 1e7 from the world origin at translations float32 holds exactly (as a PointInstancer's
    float positions are), rays from 3 to 30 sizes away aimed well inside random triangles: each hits that triangle
    at the float64 ``t`` (to 1e-5 of the way over the cosine with the normal). Their BLAS's world origin
    ``c + L m`` is no float32 there: held as one, it moved the octahedra by up to half a float32 step of 1e7 (0.5,
    a quarter of their size), and 505 of 1,920 rays hit another triangle (``c`` and ``L m`` are held apart). With a
    sphere beside the octahedron in the prototype (40 sizes from it, where no ray passes), the same, and rays at the
    sphere hit it where the closed form says: its entry is placed from the instance's own origin."""
    rng = np.random.default_rng(8)
    n_instances, n = 6, 2000
    to_world = np.tile(np.eye(4), (n_instances, 1, 1))
    for k in range(n_instances):
        to_world[k, :3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] @ np.diag(rng.uniform(0.5, 2.0, 3))
    to_world[:, :3, 3] = (rng.choice([-1, 1], (n_instances, 3)) * 10 ** rng.uniform(6, 7, (n_instances, 3)))
    to_world[:, :3, 3] = to_world[:, :3, 3].astype(np.float32)
    points, faces = OCTAHEDRON
    points = (points.astype(np.float64) + [20.0, -14.0, 9.0]).astype(np.float32)
    ball = np.diag([0.5, 0.5, 0.5, 1.0])
    ball[:3, 3] = (-20.0, 14.0, -9.0)
    shapes = [wrt.Shape("/Octa/ball", "sphere", ball)] if with_sphere else []
    proto = Prototype("/Octa", [Mesh("/Octa/mesh", points, faces, np.arange(8))], shapes)
    scene = wrt.Scene(prototypes=[proto], instances=Instances.from_transforms(np.zeros(n_instances, int), to_world))
    assert wrt.tlas.blas_centres(scene).any()
    world = np.concatenate([points.astype(np.float64) @ m[:3, :3].T + m[:3, 3] for m in to_world])
    indices = np.concatenate([faces + 6 * i for i in range(n_instances)])
    aim = rng.integers(0, len(indices), n)
    targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], n), world[indices[aim]])
    away = rng.normal(size=(n, 3))
    away *= (rng.uniform(3, 30, n) / np.linalg.norm(away, axis=1))[:, None]
    origins = (targets + away).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t, row = closest_hits_numpy(world, indices, o64, d64, np.zeros(n), np.full(n, np.inf))
    clear = (barycentric_margins(world, indices, o64, d64, t, row) > 1e-2)
    clear &= edge_clearances(world, indices, o64, d64, row) > 1e-3
    assert clear.sum() > 0.9 * n
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.prim[clear], row[clear])
    p0, p1, p2 = (world[indices[np.maximum(row, 0), k]] for k in range(3))
    normal = np.cross(p1 - p0, p2 - p0)
    cosine = np.abs((normal * d64).sum(1)) / np.linalg.norm(normal, axis=1) / np.linalg.norm(d64, axis=1)
    off = np.abs(hits.t - t) > 1e-5 / cosine  # a grazing ray's t moves most with its hit point
    assert not off[clear].any(), f"{np.count_nonzero(off[clear])} of {clear.sum()} rays hit off the float64 t"
    if with_sphere:  # rays from 3 above each sphere's centre (float32: up to 0.5 off at 1e7) aimed at the centre
        centres = np.einsum("nij,j->ni", to_world[:, :3, :3], ball[:3, 3]) + to_world[:, :3, 3]
        linear = to_world[:, :3, :3] @ ball[:3, :3]
        starts = (centres + [0.0, 0.0, 3.0]).astype(np.float32)
        aims = (centres - starts).astype(np.float32)
        hits = wrt.trace(scene, starts, aims)
        np.testing.assert_array_equal(hits.instance, np.arange(n_instances))
        # The ellipsoid |inverse(linear) (start + t aim - centre)| = 1, solved in float64 (the nearer root).
        inverse = np.linalg.inv(linear)
        local_o = np.einsum("nij,nj->ni", inverse, starts.astype(np.float64) - centres)
        local_d = np.einsum("nij,nj->ni", inverse, aims.astype(np.float64))
        a, b = (local_d * local_d).sum(1), (local_o * local_d).sum(1)
        c = (local_o * local_o).sum(1) - 1.0
        np.testing.assert_allclose(hits.t, (-b - np.sqrt(b * b - a * c)) / a, rtol=1e-6)


def edge_clearances(points, indices, origins, directions, row) -> np.ndarray:
    """``(N,)`` float64 distance from each ray's line to the nearest edge line of its triangle ``row`` (any value
    for misses): below float32's step at the ray's origin, no float32 ray can tell the triangle from its
    neighbour."""
    p0, p1, p2 = (points[indices[np.maximum(row, 0), k]].astype(np.float64) for k in range(3))
    out = np.full(len(row), np.inf)
    for a, b in ((p0, p1), (p1, p2), (p2, p0)):
        normal = np.cross(directions, b - a)
        out = np.minimum(out, np.abs(((a - origins) * normal).sum(1)) / np.linalg.norm(normal, axis=1))
    return out


def aimed_rays(rng, targets: np.ndarray, zero_components: int) -> tuple[np.ndarray, np.ndarray]:
    """float32 rays from about 900 away to ``targets``, the last ``zero_components`` of each direction's components
    (of a random axis order) exactly zero; 0, 1 or 2."""
    targets = targets.astype(np.float32)
    offsets = rng.normal(size=targets.shape) * 900
    for i, axes in enumerate(rng.permuted(np.tile(np.arange(3), (len(targets), 1)), axis=1)):
        offsets[i, axes[3 - zero_components:]] = 0.0
    origins = (targets + offsets).astype(np.float32)
    return origins, targets - origins


@pytest.mark.parametrize("stretch", ["sheared", "squashed"])
def test_limits_around_the_moved_origin_keep_the_float64_hits_of_stretched_instances(stretch):
    """The TLAS moves a ray's origin to ``t0``, where it passes closest to an instance's local origin, before
    entering it, and reports ``t0 + t``. Against float64: limits past ``t0`` (``t_min``) or before it (``t_max``) or
    a window around it, rays starting inside an instance's box, directions with one or two zero components, and an
    instance at the world origin. Every ray whose float64 answer holds with limits moved 1e-3 of ``t`` either way
    gets it: the closest hit's instance, ``t`` (and triangle, sheared), a miss, and the any-hit query agrees."""
    rng = np.random.default_rng(5)
    n_instances = 7
    to_world = stretched_octahedra(rng, stretch, n_instances)
    # The last one unstretched, at the world origin, and fat enough for limits between its faces.
    to_world[-1] = np.eye(4)
    to_world[-1, :3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] * 50.0
    scene = octahedra_scene(to_world)
    # The instances as the device holds them (float32 [A | c], wrt.transforms), the squashed sheets thickened to
    # FLAT_THICKNESS (Scene.instances.to_world): float32 holds an inverse of 1e6 between two turns no better than
    # FLOAT32_INVERSE_TOLERANCE once applied (the corners it held moved by up to 1e-2, out of the sheet's plane too).
    held = np.linalg.inv(np.linalg.inv(scene.instances.to_world[:, :3, :3]).astype(np.float32).astype(np.float64))
    placed = scene.instances.to_world[:, :3, 3].astype(np.float32)
    world, indices = octahedra_triangles(held, placed)
    n = 1500
    aim = rng.integers(0, len(indices), 4 * n)
    targets = np.einsum("nk,nkj->nj", rng.dirichlet([4, 4, 4], 4 * n), world[indices[aim]])
    groups = [aimed_rays(rng, targets[k * n:(k + 1) * n], k) for k in range(3)]
    corners = world.reshape(n_instances, 6, 3)[aim[3 * n:] // 8]
    lower, upper = corners.min(axis=1), corners.max(axis=1)
    inside = (lower + rng.uniform(size=(n, 3)) * (upper - lower)).astype(np.float32)  # in the instance's world box
    groups.append((inside, targets[3 * n:].astype(np.float32) - inside))
    origins, directions = (np.concatenate(a) for a in zip(*groups))
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    # t0 of the instance aimed at, as the kernel finds it, and limits around it.
    inverse = np.linalg.inv(to_world[aim // 8, :3, :3])
    local_o = np.einsum("nij,nj->ni", inverse, o64 - to_world[aim // 8, :3, 3])
    local_d = np.einsum("nij,nj->ni", inverse, d64)
    t0 = np.maximum(-(local_o * local_d).sum(1) / (local_d * local_d).sum(1), 0.0)
    t_entry, _ = closest_hits_numpy(world, indices, o64, d64, np.zeros(len(t0)), np.full(len(t0), np.inf))
    spread = rng.uniform(0, 1.5, (len(t0), 2)) * np.abs(t0 - np.where(np.isfinite(t_entry), t_entry, 0))[:, None]
    mode = rng.integers(0, 4, len(t0))
    t_min = np.select([mode == 1, mode == 3], [t0 + spread[:, 0], t0 - spread[:, 0]], 0.0).astype(np.float32)
    t_max = np.select([mode == 2, mode == 3], [t0 - spread[:, 1], t0 + spread[:, 1]], np.inf).astype(np.float32)
    t_max[(mode == 2) & (t_max <= 0)] = np.inf
    lo, hi = t_min.astype(np.float64), t_max.astype(np.float64)
    t, row = closest_hits_numpy(world, indices, o64, d64, lo, hi)
    slack = 1e-3 * np.maximum(np.abs(np.where(np.isfinite(t), t, t0)), 1e-3)
    _, row_in = closest_hits_numpy(world, indices, o64, d64, lo + slack, hi - slack)
    _, row_out = closest_hits_numpy(world, indices, o64, d64, lo - slack, hi + slack)
    settled = (row_in == row) & (row_out == row)  # no hit within 1e-3 of t of either limit
    clear_hit = settled & (row >= 0) & (barycentric_margins(world, indices, o64, d64, t, row) > 1e-2)
    clear_miss = settled & (row < 0)
    group = np.arange(len(t)) // n
    assert all((clear_hit & (group == k)).sum() > 300 for k in range(4))
    assert all((clear_hit & (mode == m)).sum() > 50 and (clear_miss & (mode == m)).sum() > 30 for m in (1, 2, 3))
    hits = wrt.trace(scene, origins, directions, t_min=t_min, t_max=t_max)
    np.testing.assert_array_equal(hits.instance[clear_hit], row[clear_hit] // 8)
    np.testing.assert_allclose(hits.t[clear_hit], t[clear_hit], rtol=1e-3)
    if stretch == "sheared":
        np.testing.assert_array_equal(hits.prim[clear_hit], row[clear_hit])
    assert not hits.hit[clear_miss].any()
    blocked = wrt.occluded(scene, origins, directions, t_min=t_min, t_max=t_max)
    assert blocked[clear_hit].all() and not blocked[clear_miss].any()
    np.testing.assert_array_equal(blocked, hits.hit)


@pytest.mark.parametrize("name", ["positions", "scales", "orientations", "orientationsf", "velocities",
                                  "angularVelocities"])
def test_non_finite_instance_attributes_skip_those_instances_with_a_warning(tmp_path, name):
    """A NaN or inf in ``positions``, ``scales``, ``orientations`` (or ``orientationsf``) or in the ``velocities`` that
    move the positions stopped the whole load with SceneError. ``ComputeInstanceTransformsAtTime`` hands back
    non-finite matrices for those instances only: they are skipped, with a warning naming the file, the instancer,
    the attribute and how many; the other instances are USD's."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0, 0), positions=4)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    nan, inf = float("nan"), float("inf")
    t = Usd.TimeCode.Default()
    if name == "positions":
        pi.GetPositionsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(nan, 0, 0), Gf.Vec3f(6, 0, 0), Gf.Vec3f(0, inf, 0)])
    elif name == "scales":
        pi.CreateScalesAttr([Gf.Vec3f(1, 2, 3), Gf.Vec3f(1, inf, 1), Gf.Vec3f(2, 2, 2), Gf.Vec3f(nan, 1, 1)])
    elif name == "orientationsf":
        pi.CreateOrientationsfAttr(Vt.QuatfArray([Gf.Quatf(0.6, 0.8, 0, 0), Gf.Quatf(nan, 0, 0, 0),
                                                  Gf.Quatf(1, 0, 0, 0), Gf.Quatf(0, 0, inf, 0)]))
    elif name == "orientations":
        pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(0.6, 0.8, 0, 0), Gf.Quath(nan, 0, 0, 0),
                                                 Gf.Quath(1, 0, 0, 0), Gf.Quath(0, 0, inf, 0)]))
    elif name == "velocities":  # velocities move the positions sampled at 0 to time 1
        t = Usd.TimeCode(1.0)
        for time in (0.0, 2.0):
            pi.GetPositionsAttr().Set([Gf.Vec3f(3.0 * k, 0, 0) for k in range(4)], time)
            pi.CreateVelocitiesAttr().Set([Gf.Vec3f(1, 0, 0), Gf.Vec3f(nan, 0, 0), Gf.Vec3f(0, 1, 0),
                                           Gf.Vec3f(0, 0, inf)], time)
    else:  # angular velocities turn the orientations sampled at 0 to time 1 (a NaN one placed NaN without a word)
        t = Usd.TimeCode(1.0)
        for time in (0.0, 2.0):
            pi.GetPositionsAttr().Set([Gf.Vec3f(3.0 * k, 0, 0) for k in range(4)], time)
            pi.CreateOrientationsfAttr().Set(Vt.QuatfArray([Gf.Quatf(1, 0, 0, 0)] * 4), time)
            pi.CreateAngularVelocitiesAttr().Set([Gf.Vec3f(0, 0, 30), Gf.Vec3f(nan, 0, 0), Gf.Vec3f(0, 9, 0),
                                                  Gf.Vec3f(inf, 0, 0)], time)
    stage.Save()
    shown = {"velocities": "positions (moved by velocities or accelerations)",
             "angularVelocities": "orientationsf (turned by angularVelocities)"}.get(name, name)
    with pytest.warns(UserWarning, match=r"bad\.usda: PointInstancer instances with non-finite \(NaN or inf\) .*"
                      rf"were skipped.*\(2 of 4 instances by {re.escape(shown)}: 1\): /PI$"):
        scene = wrt.load_usd(path, time=None if t.IsDefault() else t.GetValue())
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    assert expected.shape == (4, 4, 4)
    finite = np.isfinite(expected).all(axis=(1, 2))
    assert list(finite) == [True, False, True, False]
    atol = 2e-3 if name == "orientations" else 1e-5  # quath rounding
    np.testing.assert_allclose(scene.instances.to_world, expected[finite], atol=atol)


def test_non_finite_instances_hidden_anyway_are_not_named_as_skipped(tmp_path):
    """A NaN position on an instance that ``invisibleIds`` hides, and an inf one on an instance whose ``protoIndices``
    is out of range: USD computes no matrix for the hidden one (``ComputeInstanceTransformsAtTime`` with its mask
    gives only the shown instances', all finite), and the other is skipped for its index alone. The instancer draws
    USD's finite shown instances, one warning naming the index and none a non-finite attribute; both were counted as
    skipped for their NaN or inf too."""
    path = write_instancer(tmp_path, proto_indices=(0, 0, 0, 7), positions=4)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    nan, inf = float("nan"), float("inf")
    pi.GetPositionsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(nan, 0, 0), Gf.Vec3f(6, 0, 0), Gf.Vec3f(inf, 0, 0)])
    pi.CreateInvisibleIdsAttr([1])
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    messages = [str(w.message) for w in caught]
    assert not any("non-finite" in m for m in messages), messages
    assert sum("out of range of its prototypes" in m for m in messages) == 1, messages
    t = Usd.TimeCode.Default()
    pi.GetProtoIndicesAttr().Set([0, 0, 0, 0])  # mended in memory: USD computes nothing with an index out of range
    shown = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    assert len(shown) == 3 and np.isfinite(shown[:2]).all()  # USD's mask: instances 0, 2 and 3 (3 out of range)
    np.testing.assert_allclose(scene.instances.to_world, shown[:2], atol=1e-6)


@pytest.mark.parametrize("prototype", [-1, 2])
@pytest.mark.parametrize("past", ["translation", "scale"])
def test_instance_of_a_missing_prototype_past_float32_is_named_for_its_index(np_rng, prototype, past):
    """An instance drawing prototype -1 or 2 of two, with a translation past float32 (1e39) or a scale that takes an
    octahedron past it (1e38): an accelerator's own check named the translation, and ``Scene.bounds`` left the
    instance out without a word; both now name the index as ``check_instances`` does."""
    scene = python_scene(np_rng, n=3)
    to_world = scene.instances.to_world.copy()
    if past == "translation":
        to_world[1, 0, 3] = 1e39
    else:
        to_world[1, :3, :3] *= 1e38
    scene.instances = Instances.from_transforms([0, prototype, 1], to_world)
    message = rf"/instances\[1\]: draws prototype {prototype}, but the scene has 2"
    with pytest.raises(wrt.SceneError, match=message):
        check_finite_transforms(scene)
    with pytest.raises(wrt.SceneError, match=message):
        scene.bounds()


@pytest.mark.parametrize("unused", [np.nan, np.inf])
def test_an_unused_nan_or_inf_point_leaves_the_prototype_box_check_on(unused):
    """A prototype mesh may hold points no triangle uses (NaN or infinite ones too: ``Scene.bounds`` reads the used
    points only), and an instance scaled by 1e37 takes its triangle, 50 across, to 5e38, past float32. An unused
    NaN point made the bound the check clears scenes with NaN, and the check passed every instance of every
    prototype: the scene's bounds went infinite, and the build failed on a triangle row of no mesh. The oracle: the
    used corners times the scale, in float64."""
    points = np.array([[0, 0, 0], [50, 0, 0], [0, 50, 0], [unused] * 3], np.float32)
    mesh = Mesh(path="/P/tri", points=points, indices=np.array([[0, 1, 2]], np.int32), face_ids=None)
    to_world = np.repeat(np.eye(4)[None], 2, axis=0)
    to_world[1, :3, :3] *= 1e37
    scene = wrt.Scene(prototypes=[Prototype(path="/P", meshes=[mesh])],
                      instances=Instances.from_transforms([0, 0], to_world))
    lo, hi = [0.0, 0.0, 0.0], [50.0 * 1e37, 50.0 * 1e37, 0.0]
    assert hi[0] > float(np.finfo(np.float32).max)
    message = r"^instance 1 .*of prototype /P: its transform takes the prototype's box to " + re.escape(f"{lo} to {hi}")
    with pytest.raises(ValueError, match=message):
        scene.check_instance_boxes()
    with pytest.raises(ValueError, match=message):
        check_finite_transforms(scene)


@pytest.mark.parametrize("name, value_type, values", [
    ("invisibleIds", "int[]", [1]), ("invisibleIds", "float[]", [1.0]), ("invisibleIds", "string[]", ["x"]),
    ("ids", "int[]", [7, 8, 9]), ("ids", "float[]", [7.0, 8.0, 9.0]), ("ids", "string[]", ["7", "8", "9"])])
def test_ids_of_another_type_than_int64_are_ignored_as_usds_mask_ignores_them(tmp_path, name, value_type, values):
    """``invisibleIds`` and ``ids`` are ``int64[]``: ``ComputeMaskAtTime`` (Hydra's mask) reads no values from one of
    another type, so it hides nothing (invisibleIds), or names the instances by index (ids). wrt read them as ids
    anyway (an int[] invisibleIds hid an instance USD draws; float ids hid none where USD hides one by index), and
    letters stopped the load with SceneError; now they are ignored with a warning naming the instancer and type."""
    path = str(tmp_path / "ids.usda")
    stage = Usd.Stage.CreateNew(path)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    UsdGeom.Cube.Define(stage, "/PI/P")
    pi.CreatePrototypesRel().AddTarget("/PI/P")
    pi.CreatePositionsAttr([(0, 0, 0), (3, 0, 0), (6, 0, 0)])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    if name == "ids":
        pi.CreateInvisibleIdsAttr(Vt.Int64Array([1]))  # by index (USD, as ids are unread): the middle one
    stage.GetRootLayer().Save()
    layer = Sdf.Layer.FindOrOpen(path)
    types = {"int[]": (Sdf.ValueTypeNames.IntArray, Vt.IntArray),
             "float[]": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray),
             "string[]": (Sdf.ValueTypeNames.StringArray, Vt.StringArray)}
    value_type_name, array = types[value_type]
    Sdf.AttributeSpec(layer.GetPrimAtPath("/PI"), name, value_type_name).default = array(values)
    layer.Save()
    stage = Usd.Stage.Open(path)
    mask = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")).ComputeMaskAtTime(Usd.TimeCode.Default())
    expected = [0.0, 6.0] if name == "ids" else [0.0, 3.0, 6.0]
    assert [x for x, keep in zip([0.0, 3.0, 6.0], mask or [True] * 3) if keep] == expected  # USD's mask
    with pytest.warns(UserWarning, match=rf"(?s){name} of another type than int64\[\].*/PI"):
        scene = wrt.load_usd(path)
    np.testing.assert_allclose(sorted(scene.instances.to_world[:, 0, 3]), expected)


def test_prototypes_targeting_a_relationship_are_the_prims_usd_forwards_to(tmp_path):
    """A ``prototypes`` target may be a relationship, which USD forwards (``GetForwardedTargets``): UsdImaging's
    PointInstancer adapter takes the forwarded prims as the prototypes, ``protoIndices`` indexing that list. wrt took
    the relationship path for a prototype that does not exist and skipped its instances with a warning (and a
    light in it was no light of the stage). Each instance now draws the prototype USD forwards its index to, placed
    as ``ComputeInstanceTransformsAtTime`` places it, and the light of a forwarded prototype shines once per
    instance of it (USD's schema helpers, which count GetTargets, are not what is drawn: they compute nothing
    here)."""
    from pxr import UsdLux

    path = str(tmp_path / "forwarded.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.Imageable(UsdGeom.Scope.Define(stage, "/Protos")).MakeInvisible()
    for name in "ABC":
        octahedron(stage, f"/Protos/{name}")
    UsdGeom.Xform.Define(stage, "/Protos/L")
    UsdLux.SphereLight.Define(stage, "/Protos/L/Lamp")
    world = UsdGeom.Xform.Define(stage, "/World").GetPrim()
    world.CreateRelationship("relay").SetTargets(["/Protos/B", "/World.chain"])
    world.CreateRelationship("chain").SetTargets(["/Protos/C", "/Protos/L"])
    pi = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    pi.CreatePrototypesRel().SetTargets(["/Protos/A", "/World.relay"])
    indices = [0, 1, 2, 2, 3, 3, 1]
    pi.CreateProtoIndicesAttr(indices)
    pi.CreatePositionsAttr([Gf.Vec3f(3.0 * k, 0, 0) for k in range(len(indices))])
    stage.Save()
    rel = pi.GetPrototypesRel()
    forwarded = [str(p) for p in rel.GetForwardedTargets()]  # USD's answer, which Hydra draws
    assert forwarded == ["/Protos/A", "/Protos/B", "/Protos/C", "/Protos/L"] and len(rel.GetTargets()) == 2
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    assert not any("PointInstancer" in str(w.message) for w in caught), [str(w.message) for w in caught]
    drawn = [k for k, index in enumerate(indices) if forwarded[index] != "/Protos/L"]  # L holds no geometry
    assert [scene.instances.path(i) for i in range(len(scene.instances))] == [f"/World/PI[{k}]" for k in drawn]
    assert [scene.prototypes[p].path for p in scene.instances.prototype] == [forwarded[indices[k]] for k in drawn]
    # ComputeInstanceTransformsAtTime checks protoIndices against GetTargets (2 here: it computes none), so it is
    # asked of the relationship with USD's forwarded targets authored in place of the relay.
    rel.SetTargets(rel.GetForwardedTargets())
    t = Usd.TimeCode.Default()
    expected = np.array([np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(t, t)])
    assert len(expected) == len(indices)
    np.testing.assert_allclose(scene.instances.to_world.reshape(-1, 4, 4), expected[drawn], atol=1e-6)
    lamps = [k for k, index in enumerate(indices) if forwarded[index] == "/Protos/L"]
    assert len(scene.lights) == len(lamps)
    np.testing.assert_allclose([light.position for light in scene.lights], expected[lamps][:, :3, 3], atol=1e-6)
