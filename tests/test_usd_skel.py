"""Tests for wrt.usd_skel: meshes skinned by a UsdSkel skeleton are drawn as USD poses them at the load's time.

The reference is USD's own ``UsdSkel.BakeSkinning``, run on the stage opened again with a session layer as edit
target: it writes the posed points (in each mesh's own space, or a transform for rigidly bound meshes) as time
samples at every integer time code, which ``UsdGeom.XformCache`` then places in the world.
"""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Sdf, Usd, UsdGeom, UsdSkel  # noqa: E402

from wrt.usd import load_usd  # noqa: E402

IDENTITY = "( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1) )"
AT_X1 = "( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (1, 0, 0, 1) )"
SEGMENTS = 4  # of the bar, along x from 0 to 2
PROXIES = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


def fmt(values) -> str:
    return "[" + ", ".join(str(tuple(v)) if isinstance(v, (tuple, list)) else repr(v) for v in values) + "]"


def bar():
    """A square bar of quads along x (4 points per ring), its vertex normals and 2 influences per point: the mesh's
    joint 1 ("root") below x = 0.5, joint 0 ("root/tip") beyond x = 1.5, blended in between."""
    points, normals, joint_indices, joint_weights, counts, indices = [], [], [], [], [], []
    ring = [(-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1)]
    for i in range(SEGMENTS + 1):
        x = 2.0 * i / SEGMENTS
        s = min(max(x - 0.5, 0.0), 1.0)
        for y, z in ring:
            points.append((x, y, z))
            normals.append((0.0, y, z))
            joint_indices += [1, 0]
            joint_weights += [1 - s, s]
    for i in range(SEGMENTS):
        for k in range(4):
            a, b = i * 4 + k, i * 4 + (k + 1) % 4
            indices += [a, b, b + 4, a + 4]
            counts.append(4)
    return points, normals, joint_indices, joint_weights, counts, indices


def skel_root(root="/Root", bad_index=False, animation=True) -> str:
    """A SkelRoot at ``root``: a 2-joint skeleton (moved and turned by its own transform) whose animation bends,
    stretches and lifts it over time samples 1, 5 and 10; a bar skinned by it (joints in another order than the
    skeleton's, a geomBindTransform, a blend shape and a transform of its own, which skinning replaces), a quad
    bound rigidly to the tip and a quad moved by a blend shape only (in its own space)."""
    points, normals, joint_indices, joint_weights, counts, indices = bar()
    if bad_index:
        joint_indices[0] = 7
    name = root.rsplit("/", 1)[1]
    source = f"rel skel:animationSource = <{root}/Anim>" if animation else ""
    return f"""
def SkelRoot "{name}" (
    prepend apiSchemas = ["SkelBindingAPI"]
)
{{
    rel skel:skeleton = <{root}/Skel>
    double3 xformOp:translate = (0, 1, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]

    def Skeleton "Skel" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {{
        uniform token[] joints = ["root", "root/tip"]
        uniform matrix4d[] bindTransforms = [{IDENTITY}, {AT_X1}]
        uniform matrix4d[] restTransforms = [{IDENTITY}, {AT_X1}]
        {source}
        double3 xformOp:translate = (0, 0, 2)
        float xformOp:rotateY = 30
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    }}

    def SkelAnimation "Anim"
    {{
        uniform token[] joints = ["root/tip", "root"]
        float3[] translations.timeSamples = {{
            1: [(1, 0, 0), (0, 0, 0)], 5: [(1, 0, 0), (0, 0.5, 0)], 10: [(1, 0, 0), (0.2, 0.3, 0)] }}
        quatf[] rotations.timeSamples = {{
            1: [(0.9659258, 0, 0, 0.258819), (1, 0, 0, 0)],
            5: [(0.7071068, 0, 0, 0.7071068), (0.9659258, 0.258819, 0, 0)],
            10: [(0.5, 0, 0, 0.8660254), (1, 0, 0, 0)] }}
        half3[] scales.timeSamples = {{ 1: [(1, 1, 1), (1, 1, 1)], 10: [(1, 2, 1), (1, 1, 1)] }}
        uniform token[] blendShapes = ["bulge"]
        float[] blendShapeWeights.timeSamples = {{ 1: [0.5], 10: [1] }}
    }}

    def Mesh "Bar" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {{
        int[] faceVertexCounts = {fmt(counts)}
        int[] faceVertexIndices = {fmt(indices)}
        point3f[] points = {fmt(points)}
        uniform token subdivisionScheme = "none"
        normal3f[] normals = {fmt(normals)} (
            interpolation = "vertex"
        )
        uniform token[] skel:joints = ["root/tip", "root"]
        int[] primvars:skel:jointIndices = {fmt(joint_indices)} (
            elementSize = 2
            interpolation = "vertex"
        )
        float[] primvars:skel:jointWeights = {fmt(joint_weights)} (
            elementSize = 2
            interpolation = "vertex"
        )
        matrix4d primvars:skel:geomBindTransform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (-0.5, 0, 0, 1) )
        uniform token[] skel:blendShapes = ["bulge"]
        rel skel:blendShapeTargets = <{root}/Bar/bulge>
        double3 xformOp:translate = (5, 5, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]

        def BlendShape "bulge"
        {{
            uniform vector3f[] offsets = [(0, 0.3, 0), (0, 0.3, 0)]
            uniform int[] pointIndices = [9, 10]
        }}
    }}

    def Mesh "Rigid" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {{
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(2, -0.2, 0), (2.4, -0.2, 0), (2.4, 0.2, 0), (2, 0.2, 0)]
        int[] primvars:skel:jointIndices = [1] (
            interpolation = "constant"
        )
        float[] primvars:skel:jointWeights = [1] (
            interpolation = "constant"
        )
        double3 xformOp:translate = (0, 0, 1)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}

    def Mesh "Face" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {{
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        uniform token[] skel:blendShapes = ["bulge"]
        rel skel:blendShapeTargets = <{root}/Face/bulge>
        double3 xformOp:translate = (0, 0, -3)
        uniform token[] xformOpOrder = ["xformOp:translate"]

        def BlendShape "bulge"
        {{
            uniform vector3f[] offsets = [(0, 0, 0.5)]
            uniform int[] pointIndices = [2]
        }}
    }}
}}
"""


def replaced_once(body: str, old: str, new: str) -> str:
    """``body`` with ``old``, which it holds exactly once (else the edit would miss or hit twice), made ``new``."""
    assert body.count(old) == 1, old
    return body.replace(old, new)


def write(tmp_path, body: str) -> str:
    path = tmp_path / "skinned.usda"
    path.write_text(f'#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 10\n    upAxis = "Y"\n)\n{body}\n')
    return str(path)


def baked(path: str, uninstance=()) -> Usd.Stage:
    """The stage at ``path`` with USD's skinning baked into a session layer (``uninstance``: prims made not
    instanceable first, since BakeSkinning cannot write into instance prototypes)."""
    stage = Usd.Stage.Open(path)
    stage.SetEditTarget(Usd.EditTarget(stage.GetSessionLayer()))
    for p in uninstance:
        stage.GetPrimAtPath(p).SetInstanceable(False)
    assert UsdSkel.BakeSkinning(stage.Traverse())
    return stage


def fan(counts, indices):
    """Triangles ``(T, 3)`` of a fan triangulation, in face order (the order wrt documents)."""
    tris, start = [], 0
    for n in counts:
        tris += [(indices[start], indices[start + k + 1], indices[start + k + 2]) for k in range(n - 2)]
        start += n
    return np.array(tris, np.int64).reshape(-1, 3)


def world_triangles(stage: Usd.Stage, mesh_path: str, time: Usd.TimeCode):
    """``(T, 3, 3)`` world-space corners and ``(T, 3, 3)`` unit world normals (or None) of a mesh of the baked stage."""
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(mesh_path))
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(mesh.GetPrim()))
    points = np.array(mesh.GetPointsAttr().Get(time), np.float64) @ m[:3, :3] + m[3, :3]
    tris = fan(mesh.GetFaceVertexCountsAttr().Get(), mesh.GetFaceVertexIndicesAttr().Get())
    normals = mesh.GetNormalsAttr().Get(time)
    if normals is not None:
        normals = np.array(normals, np.float64) @ np.linalg.inv(m[:3, :3]).T
        normals = (normals / np.linalg.norm(normals, axis=1, keepdims=True))[tris]
    return points[tris], normals


def loaded(path, time):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a posed mesh loads without a warning
        return load_usd(path, time=time)


@pytest.mark.parametrize("time", [None, 5.0, 7.0])
def test_skinned_meshes_match_usd_bake_skinning(tmp_path, time):
    """Points (skinned, blend shape applied, in the skeleton's space placed by the skeleton, not by the mesh's own
    transform) and vertex normals match BakeSkinning's at a sample, between samples and at ``time=None``, which reads
    the sample-only animation at its first sample (7 is exact too: BakeSkinning bakes every integer time code)."""
    path = write(tmp_path, skel_root())
    stage = baked(path)
    at = Usd.TimeCode.EarliestTime() if time is None else Usd.TimeCode(time)
    scene = loaded(path, time)
    by_path = {m.path: m for m in scene.meshes}
    for mesh_path in ("/Root/Bar", "/Root/Rigid", "/Root/Face"):
        expected, normals = world_triangles(stage, mesh_path, at)
        mesh = by_path[mesh_path]
        np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
        if normals is not None:
            np.testing.assert_allclose(mesh.normals, normals, atol=2e-6)
    # The authored points under the mesh's own transform, and the pose at time 10, are far from that: the test sees
    # a mesh left unposed or posed at another time.
    authored = np.array(bar()[0]) + (5, 6, 5)
    assert np.abs(by_path["/Root/Bar"].points - authored).max() > 1.0
    later, _ = world_triangles(stage, "/Root/Bar", Usd.TimeCode(10))
    assert np.abs(by_path["/Root/Bar"].points[by_path["/Root/Bar"].indices] - later).max() > 0.2


def wide_influences(body: str, per_point: int) -> str:
    """``body`` with the bar's influences spread over ``per_point`` (>= 2) entries a point: its two weights halved,
    the rest small weights on both joints, so that no point's weights sum to 1."""
    _, _, joint_indices, joint_weights, _, _ = bar()
    indices, weights = [], []
    for k in range(0, len(joint_indices), 2):
        extra = per_point - 2
        indices += joint_indices[k : k + 2] + [j % 2 for j in range(extra)]
        weights += [0.5 * w for w in joint_weights[k : k + 2]] + [0.05 * (j + 1) for j in range(extra)]
    for name, old, new in (("Indices", joint_indices, indices), ("Weights", joint_weights, weights)):
        text = f"primvars:skel:joint{name} = {fmt(old)} (\n            elementSize = 2"
        body = replaced_once(body, text,
                             f"primvars:skel:joint{name} = {fmt(new)} (\n            elementSize = {per_point}")
    return body


@pytest.mark.parametrize("case", ["dualQuaternion", "2 per point, not summing to 1", "5 per point", "8 per point"])
def test_skinning_methods_and_influence_counts_match_bake_skinning(tmp_path, case):
    """Dual quaternion skinning (of a joint scaled 2 along y by time 10), and up to 8 influences a point whose
    weights do not sum to 1 (UsdSkel does not normalise them), pose the bar and its normals as BakeSkinning does."""
    body = skel_root()
    if case == "dualQuaternion":
        old = 'uniform token[] skel:joints = ["root/tip", "root"]'
        body = replaced_once(body, old, f'{old}\n        uniform token skel:skinningMethod = "dualQuaternion"')
    else:
        body = wide_influences(body, int(case[0]))
    path = write(tmp_path, body)
    stage = baked(path)
    for time in (7.0, 10.0):
        expected, normals = world_triangles(stage, "/Root/Bar", Usd.TimeCode(time))
        mesh = {m.path: m for m in loaded(path, time).meshes}["/Root/Bar"]
        np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
        np.testing.assert_allclose(mesh.normals, normals, atol=2e-6)


def test_influences_whose_indices_have_only_time_samples_are_read_at_their_first_sample(tmp_path):
    """Joint indices and weights stored as indexed primvars whose ``:indices`` have only a time sample (at 1, the
    animation's first) are posed at ``time=None`` as BakeSkinning poses them at time 1. ``ComputeFlattened`` at the
    default time raised on them, and the bar was drawn unposed with a warning."""
    path = write(tmp_path, skel_root())
    indexed_influences(path, time=Usd.TimeCode(1))
    expected, _ = world_triangles(baked(path), "/Root/Bar", Usd.TimeCode(1))
    mesh = {m.path: m for m in loaded(path, None).meshes}["/Root/Bar"]
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)


def test_skinned_meshes_inside_instances_are_posed(tmp_path):
    """A SkelRoot inside a native prototype is posed once, in the prototype's space, and placed by each instance."""
    instances = "\n".join(
        f'def Xform "{name}" (\n    instanceable = true\n    prepend references = </Proto>\n)\n{{\n'
        f'    double3 xformOp:translate = ({x}, 0, 0)\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n}}'
        for name, x in (("A", 3), ("B", -3))
    )
    path = write(tmp_path, 'class Xform "Proto"\n{\n' + skel_root("/Proto/Root") + "\n}\n" + instances)
    stage = baked(path, uninstance=("/A", "/B"))
    scene = loaded(path, 5.0)
    assert len(scene.prototypes) == 1 and len(scene.instances.prototype) == 2
    points, indices = scene.triangles()
    expected = [world_triangles(stage, f"/{name}/Root/{mesh}", Usd.TimeCode(5))[0]
                for name in ("A", "B") for mesh in ("Bar", "Rigid", "Face")]
    np.testing.assert_allclose(points[indices], np.concatenate(expected), atol=2e-6)


@pytest.mark.parametrize("outer", ["Xform", "SkelRoot", "SkelRoot bound"])
def test_skinned_meshes_in_a_point_instancer_prototype_are_posed(tmp_path, outer):
    """A SkelRoot that is a PointInstancer's prototype is posed in place (its meshes as BakeSkinning poses them) and
    drawn by every instance: each of ``Scene.triangles()`` is one of the posed triangles moved by one instance's
    transform (``ComputeInstanceTransformsAtTime``, the SkelRoot's own transform applied to the points), one to one.
    Under an outer SkelRoot too: UsdSkel's cache populated from that one leaves out the instancer's subtree, and
    BakeSkinning poses the prototype from its own SkelRoot; wrt posed from the outer one and drew it unposed (5.9 from
    BakeSkinning's points), saying its skinning failed. A ``skel:skeleton`` bound on the outer SkelRoot alone binds
    nothing there (BakeSkinning leaves the meshes as authored): wrt left them so but said their skinning failed."""
    prototype = skel_root("/World/PI/Protos/Root")
    binding = "rel skel:skeleton = </World/PI/Protos/Root/Skel>"
    if outer == "SkelRoot bound":  # the binding moved from the prototype's SkelRoot up to the outer one
        assert prototype.count(binding) == 1
        prototype = prototype.replace(binding, "")
    prototype = "\n".join("        " + line for line in prototype.splitlines())
    path = write(tmp_path, f"""
def {outer.split()[0]} "World" (
    prepend apiSchemas = ["SkelBindingAPI"]
)
{{
    {binding if outer == "SkelRoot bound" else ""}
    def PointInstancer "PI"
    {{
        rel prototypes = [</World/PI/Protos/Root>]
        int[] protoIndices = [0, 0]
        point3f[] positions = [(0, 0, 0), (10, 0, 0)]
        quath[] orientations = [(1, 0, 0, 0), (0.7071068, 0, 0.7071068, 0)]
        def Scope "Protos"
        {{
{prototype}
        }}
    }}
}}
""")
    stage = baked(path)
    time = Usd.TimeCode(5)
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/PI"))
    placed = np.array(instancer.ComputeInstanceTransformsAtTime(time, time, UsdGeom.PointInstancer.ExcludeProtoXform))
    in_place = np.concatenate([world_triangles(stage, f"/World/PI/Protos/Root/{mesh}", time)[0]
                               for mesh in ("Bar", "Rigid", "Face")]).reshape(-1, 3)
    expected = np.concatenate([(in_place @ m[:3, :3] + m[3, :3]).reshape(-1, 9) for m in placed])
    points, indices = loaded(path, 5.0).triangles()
    got = points[indices].reshape(-1, 9).astype(np.float64)
    distance = np.abs(got[:, None, :] - expected[None, :, :]).max(axis=2)
    assert got.shape == expected.shape
    assert distance.min(axis=1).max() < 2e-6 and sorted(distance.argmin(axis=1)) == list(range(len(expected)))


@pytest.mark.parametrize("outer", ["Xform", "SkelRoot"])
def test_a_skeleton_bound_above_the_skel_root_poses_as_in_usd(tmp_path, outer):
    """``skel:skeleton`` authored on an Xform above the SkelRoot binds nothing: UsdSkel resolves bindings from the
    SkelRoot down, and BakeSkinning leaves the meshes as authored. wrt took it as bound (``GetInheritedSkeleton``
    walks past the SkelRoot) and drew the bar 5.9 and the rigid quad 1.9 from USD's points. Authored on an outer
    SkelRoot, it binds the inner one's meshes (UsdSkel resolves them from the outer one): wrt populated UsdSkel's
    cache from the inner one and drew the bar 1.39 and the blend-shape quad 0.36 from BakeSkinning's points."""
    binding = "rel skel:skeleton = </World/Root/Skel>"
    inner = skel_root("/World/Root")
    assert inner.count(binding) == 1
    inner = "\n".join("    " + line for line in inner.replace(binding, "").splitlines())
    path = write(tmp_path, f'def {outer} "World" (\n    prepend apiSchemas = ["SkelBindingAPI"]\n)\n{{\n'
                           f"    {binding}\n{inner}\n}}\n")
    stage = baked(path)
    by_path = {m.path: m for m in loaded(path, 5.0).meshes}
    for name in ("Bar", "Rigid", "Face"):
        expected, _ = world_triangles(stage, f"/World/Root/{name}", Usd.TimeCode(5))
        mesh = by_path[f"/World/Root/{name}"]
        np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)


BAD_SKELETONS = {  # a skeleton or influences that cannot pose the bar: (text of skel_root(), its replacement)
    "no animation or rest pose": ("uniform matrix4d[] restTransforms", "uniform matrix4d[] unusedTransforms"),
    # UsdSkel's ComputeSkinningTransforms then returns the joints' unbound skeleton-space transforms (its failure is
    # not seen from Python): the bar was drawn bent and moved by them, 6.3 away from USD's pose, without a word.
    "bind transforms for one joint of two": (f"bindTransforms = [{IDENTITY}, ", "bindTransforms = ["),
    # NaN joint weights or animation made the load fail: "/Root/Bar: points are not finite after the world transform".
    "NaN joint weight": ("primvars:skel:jointWeights = [1.0,", "primvars:skel:jointWeights = [nan,"),
    "NaN joint translation": ("5: [(1, 0, 0), (0, 0.5, 0)]", "5: [(1, 0, 0), (nan, 0.5, 0)]"),
    # A bind transform that cannot be inverted (UsdSkel requires them invertible): Gf's inverse of it is FLT_MAX
    # scaled, and the load failed on the rigidly bound quad: "/Root/Rigid: points are not finite after the world
    # transform".
    "singular bind transform": (f"bindTransforms = [{IDENTITY}, {AT_X1}]",
                                f"bindTransforms = [{IDENTITY}, {AT_X1.replace('(1, 0, 0, 0)', '(0, 0, 0, 0)')}]"),
}


@pytest.mark.parametrize("case", ["bad joint index", *BAD_SKELETONS])
def test_failed_skinning_keeps_unposed_points_with_a_warning(tmp_path, case):
    """A mesh whose skinning fails is drawn in its authored points under its own transform, and named."""
    body = skel_root(bad_index=case == "bad joint index", animation=case != "no animation or rest pose")
    if case in BAD_SKELETONS:
        old, new = BAD_SKELETONS[case]
        assert old in body
        body = body.replace(old, new)
    path = write(tmp_path, body)
    with pytest.warns(UserWarning, match=r"UsdSkel skinning failed.*unposed points.*/Root/Bar"):
        scene = load_usd(path, time=5.0)
    mesh = {m.path: m for m in scene.meshes}["/Root/Bar"]
    authored = np.array(bar()[0], np.float64) + (5, 6, 5)  # the mesh's and the SkelRoot's translations
    np.testing.assert_allclose(mesh.points, authored, atol=1e-6)


def test_an_inactive_skeleton_leaves_its_meshes_unposed_as_bake_skinning_named_in_the_warning(tmp_path):
    """A deactivated Skeleton poses nothing (BakeSkinning leaves its meshes as authored); the warning said it had
    'no animation or rest transforms for its joints', though it has both."""
    old = 'def Skeleton "Skel" (\n'
    path = write(tmp_path, replaced_once(skel_root(), old, old + "        active = false\n"))
    with pytest.warns(UserWarning, match=r"skinning failed.*\(the skeleton /Root/Skel is inactive: 2\): "
                                         r"/Root/Bar, /Root/Rigid$"):
        scene = load_usd(path, time=5.0)
    stage = baked(path)
    by_path = {m.path: m for m in scene.meshes}
    for mesh_path in ("/Root/Bar", "/Root/Rigid"):
        expected, _ = world_triangles(stage, mesh_path, Usd.TimeCode(5))
        np.testing.assert_allclose(by_path[mesh_path].points[by_path[mesh_path].indices], expected, atol=2e-6)


REFUSED_INFLUENCES = {  # joint influences UsdSkel's query refuses: (text of skel_root(), its replacement)
    "weights of another interpolation": ('2\n            interpolation = "vertex"\n        )\n        matrix4d',
                                         '2\n            interpolation = "constant"\n        )\n        matrix4d'),
    "indices of elementSize 0": ('elementSize = 2\n            interpolation = "vertex"\n        )\n        float[]',
                                 'elementSize = 0\n            interpolation = "vertex"\n        )\n        float[]'),
}


@pytest.mark.parametrize("case", REFUSED_INFLUENCES)
def test_influences_usd_refuses_are_named_and_the_mesh_posed_as_bake_skinning_poses_it(tmp_path, case):
    """UsdSkel ignores such influences (printing a warning that names no mesh) and bakes the blend shapes alone: wrt
    drew the same without a word of its own."""
    old, new = REFUSED_INFLUENCES[case]
    body = skel_root()
    assert old in body
    path = write(tmp_path, body.replace(old, new))
    with pytest.warns(UserWarning, match=r"joint influences that UsdSkel cannot use .* not skinned.*: /Root/Bar$"):
        scene = load_usd(path, time=5.0)
    mesh = {m.path: m for m in scene.meshes}["/Root/Bar"]
    expected, _ = world_triangles(baked(path), "/Root/Bar", Usd.TimeCode(5.0))
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=1e-5)


UNUSABLE_INFLUENCES = {  # joint influences UsdSkel's typed reads fail on: (text of skel_root(), its replacement)
    "float[] indices": ("int[] primvars:skel:jointIndices = [1, 0", "float[] primvars:skel:jointIndices = [1, 0"),
    "int64[] indices": ("int[] primvars:skel:jointIndices = [1, 0", "int64[] primvars:skel:jointIndices = [1, 0"),
    "double[] weights": ("float[] primvars:skel:jointWeights = [1.0", "double[] primvars:skel:jointWeights = [1.0"),
}


def indexed_influences(path: str, indices_type=Sdf.ValueTypeNames.IntArray, first=None,
                       time=Usd.TimeCode.Default()) -> None:
    """The bar's jointIndices and jointWeights of ``path`` stored as indexed primvars (their distinct pairs, an index
    per point), the indices authored as ``indices_type`` at ``time`` (a time sample only, where not the default);
    ``first``: the weights' first index, when given."""
    stage = Usd.Stage.Open(path)
    for name in ("skel:jointIndices", "skel:jointWeights"):
        primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Root/Bar")).GetPrimvar(name)
        values = list(primvar.Get())
        pairs = [tuple(values[i:i + 2]) for i in range(0, len(values), 2)]  # elementSize 2: an index per pair
        distinct = sorted(set(pairs))
        primvar.Set(primvar.GetTypeName().type.pythonClass([v for pair in distinct for v in pair]))
        indices = [distinct.index(pair) for pair in pairs]
        if first is not None and name == "skel:jointWeights":
            indices[0] = first
        holder = primvar.GetAttr().GetPrim()
        attr = holder.CreateAttribute(f"primvars:{name}:indices", indices_type)
        attr.Set(indices_type.type.pythonClass(indices), time)
    stage.Save()


@pytest.mark.parametrize("case", [*UNUSABLE_INFLUENCES, "int64[] :indices", "an index out of range"])
def test_influences_usd_cannot_read_are_named_and_the_mesh_posed_as_bake_skinning_poses_it(tmp_path, case):
    """BakeSkinning leaves a bar whose jointIndices are not int[] (or jointWeights not float[]), or whose indexed
    influences it cannot flatten, unskinned, its blend shapes applied. wrt cast the values of another type to int32
    and float32 through numpy and skinned the bar without a word (6.2 from BakeSkinning's points), and drew a bar of
    unusable indices unposed, without its blend shapes (0.22 from them)."""
    body = skel_root()
    if case in UNUSABLE_INFLUENCES:
        old, new = UNUSABLE_INFLUENCES[case]
        body = replaced_once(body, old, new)
    path = write(tmp_path, body)
    if case == "int64[] :indices":
        indexed_influences(path, Sdf.ValueTypeNames.Int64Array)
    elif case == "an index out of range":
        indexed_influences(path, first=99)
    with pytest.warns(UserWarning, match=r"joint influences that UsdSkel cannot use .* not skinned.*: /Root/Bar$"):
        scene = load_usd(path, time=5.0)
    mesh = {m.path: m for m in scene.meshes}["/Root/Bar"]
    expected, _ = world_triangles(baked(path), "/Root/Bar", Usd.TimeCode(5.0))
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=1e-5)


RIGID_INDEX = 'int[] primvars:skel:jointIndices = [1] (\n            interpolation = "constant"'
BAD_RIGID = {  # a rigid binding that cannot pose the quad: (replacement of RIGID_INDEX, what the warning says)
    "joint out of range": (RIGID_INDEX.replace("[1]", "[5]"), r"jointIndices\[0\] = 5 is out of range"),
    "unknown skinning method": ('uniform token primvars:skel:skinningMethod = "linear"\n        ' + RIGID_INDEX,
                                "unknown skel:skinningMethod 'linear'"),
}


@pytest.mark.parametrize("case", list(BAD_RIGID))
def test_rigid_binding_that_fails_keeps_unposed_points_with_a_warning(tmp_path, case):
    """A rigidly bound mesh (constant influences) whose joint index is out of range, or whose skinningMethod is
    neither of UsdSkel's two: UsdSkel's SkinTransform fails into the identity, so the quad was drawn in its authored
    points placed by the skeleton, 1.0 from where they are, without a word. It is left unposed and named, as a
    skinned mesh with a bad index is."""
    replacement, why = BAD_RIGID[case]
    body = skel_root()
    assert RIGID_INDEX in body
    path = write(tmp_path, body.replace(RIGID_INDEX, replacement))
    with pytest.warns(UserWarning, match=rf"skinning failed.*{why}.*/Root/Rigid"):
        scene = load_usd(path, time=5.0)
    mesh = {m.path: m for m in scene.meshes}["/Root/Rigid"]
    authored = np.array([(2, -0.2, 0), (2.4, -0.2, 0), (2.4, 0.2, 0), (2, 0.2, 0)]) + (0, 1, 1)  # SkelRoot and own
    np.testing.assert_allclose(mesh.points, authored, atol=1e-6)


CESIUM_MAN = os.path.join(os.environ.get("WRT_ASSETS", "/work/shared/assets"),
                          "usd-wg/test_assets/USDZ/CesiumMan/CesiumMan.usdz")


@pytest.mark.skipif(not os.path.exists(CESIUM_MAN), reason="CesiumMan.usdz not in the shared assets")
@pytest.mark.parametrize("time", [None, 20.0])
def test_cesium_man_bounds_match_usd(time):
    """A glTF character (one skinned mesh, 19 joints, authored normals): wrt's world bounds are USD's bounds of the
    baked stage (the bind pose is a T-pose 1.14 wide; the walk is 0.4-0.5 wide)."""
    stage = baked(CESIUM_MAN)
    at = Usd.TimeCode.EarliestTime() if time is None else Usd.TimeCode(time)
    box = UsdGeom.BBoxCache(at, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render]).ComputeWorldBound(
        stage.GetPseudoRoot()).ComputeAlignedRange()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its material's warnings, if any, are not what this checks
        points, indices = load_usd(CESIUM_MAN, time=time).triangles()
    used = points[np.unique(indices)]
    np.testing.assert_allclose(used.min(axis=0), np.array(box.GetMin()), atol=1e-5)
    np.testing.assert_allclose(used.max(axis=0), np.array(box.GetMax()), atol=1e-5)


def test_face_varying_normals_are_skinned(tmp_path):
    """Normals authored per face corner are skinned with the influences of each corner's point: the bar's normals
    written faceVarying give BakeSkinning's skinned vertex normals (BakeSkinning skins vertex normals only)."""
    path = write(tmp_path, skel_root())
    _, expected = world_triangles(baked(path), "/Root/Bar", Usd.TimeCode(7))
    _, normals, _, _, _, indices = bar()
    authored = f'normal3f[] normals = {fmt(normals)} (\n            interpolation = "vertex"'
    corners = fmt([normals[i] for i in indices])
    per_corner = f'normal3f[] normals = {corners} (\n            interpolation = "faceVarying"'
    body = skel_root()
    assert authored in body
    path = write(tmp_path, body.replace(authored, per_corner))
    mesh = {m.path: m for m in loaded(path, 7.0).meshes}["/Root/Bar"]
    np.testing.assert_allclose(mesh.normals, expected, atol=2e-6)


def test_smooth_normals_of_a_subdivision_mesh_come_from_its_posed_points(tmp_path):
    """A catmullClark mesh without normals (the Face quad, lifted at one corner by a blend shape) is shaded with
    smooth normals of its posed points, as Storm draws it; they were made from the flat rest pose (all +z) and kept."""
    path = write(tmp_path, skel_root())
    stage = baked(path)
    points, _ = world_triangles(stage, "/Root/Face", Usd.TimeCode(7))
    quad = np.array([points[0, 0], points[0, 1], points[0, 2], points[1, 2]])  # corners 0..3 of the fan (0,1,2),(0,2,3)
    assert abs(quad[2, 2] - quad[0, 2]) > 0.2  # the blend shape lifts corner 2
    corner_normals = np.cross(np.roll(quad, -1, axis=0) - quad, np.roll(quad, 1, axis=0) - quad)  # one face per point
    corner_normals /= np.linalg.norm(corner_normals, axis=1, keepdims=True)
    mesh = {m.path: m for m in loaded(path, 7.0).meshes}["/Root/Face"]
    np.testing.assert_allclose(mesh.points[mesh.indices], points, atol=1e-5)  # posed as USD poses it
    np.testing.assert_allclose(mesh.normals, corner_normals[[[0, 1, 2], [0, 2, 3]]], atol=1e-5)


def test_refined_skinned_mesh_is_the_refinement_of_its_posed_cage(tmp_path):
    """``refine_level`` poses the cage, then refines it: the loaded points equal the Catmull-Clark refinement of
    BakeSkinning's posed points (in world space; refinement is affine, so the world transform commutes with it)."""
    from wrt.subdivision import Refinement

    body = skel_root().replace('subdivisionScheme = "none"', 'subdivisionScheme = "catmullClark"')  # the bar's
    assert body.count("catmullClark") == 1
    path = write(tmp_path, body)
    stage = baked(path)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Root/Bar"))
    time = Usd.TimeCode(7)
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(mesh.GetPrim()))
    posed = np.array(mesh.GetPointsAttr().Get(time), np.float64) @ m[:3, :3] + m[3, :3]
    counts, indices = mesh.GetFaceVertexCountsAttr().Get(), mesh.GetFaceVertexIndicesAttr().Get()
    expected = Refinement(counts, indices, len(posed), 2).vertex(posed)
    loaded_mesh = {x.path: x for x in load_usd(path, time=7.0, refine_level=2).meshes}["/Root/Bar"]
    assert len(loaded_mesh.indices) == 2 * 16 * len(counts)
    np.testing.assert_allclose(loaded_mesh.points, expected, atol=1e-5)


def test_mesh_joints_the_skeleton_lacks_are_posed_as_bake_skinning_poses_them(tmp_path):
    """``skel:joints`` naming a joint the skeleton does not have: its influences take the identity, as in
    BakeSkinning (and in wrt's skinned normals). ``ComputeSkinnedPoints`` gave those points another joint's transform:
    the bar's root end was drawn 1.56 away from BakeSkinning's points while its normals matched. USD says nothing of
    the missing joint (its SkinningQuery is valid, BakeSkinning succeeds); wrt poses as it does and names the mesh and
    the joint in a warning, which was silent."""
    body = skel_root().replace('skel:joints = ["root/tip", "root"]', 'skel:joints = ["root/tip", "root/missing"]')
    path = write(tmp_path, body)
    expected, normals = world_triangles(baked(path), "/Root/Bar", Usd.TimeCode(7))
    with pytest.warns(UserWarning, match=r"skel:joints name joints their skeleton lacks.*skel:joints\[1\] = "
                                         r"'root/missing' is not a joint of /Root/Skel.*: /Root/Bar$"):
        scene = load_usd(path, time=7.0)
    mesh = {m.path: m for m in scene.meshes}["/Root/Bar"]
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
    np.testing.assert_allclose(mesh.normals, normals, atol=2e-6)
    # An entry no point is weighted to moves nothing: no warning.
    extra = skel_root().replace('skel:joints = ["root/tip", "root"]', 'skel:joints = ["root/tip", "root", "spare"]')
    loaded(write(tmp_path, extra), 7.0)


MIRROR_X = "( (-1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1) )"


def mirrored(body: str, last_op: str) -> str:
    """``body`` with a scale of -1 along x after the xformOps of the prim whose last op is ``last_op``."""
    head = f"{last_op}\n        uniform token[] xformOpOrder = ["
    assert body.count(head) == 1, last_op
    start = body.index(head)
    end = body.index("]", start + len(head))
    return (body[:start] + "float3 xformOp:scale = (-1, 1, 1)\n        " + body[start:end] + ', "xformOp:scale"'
            + body[end:])


@pytest.mark.parametrize("normals", ["authored", "smooth"])
@pytest.mark.parametrize("mirror", ["mesh", "skeleton"])
def test_a_mirror_on_the_mesh_or_its_skeleton_shows_the_front_side_usd_shows(tmp_path, mirror, normals):
    """The front side (by winding: what back-face culling keeps) of a skinned mesh follows the mesh's own transform,
    as in BakeSkinning's stage, whose points are in the mesh's space, and in Storm (UsdSkelImaging skins into the
    mesh's space): the bar and the rigid quad mirrored with their geomBindTransforms (as an exporter writes a
    mirrored mesh) were drawn inside out, their smooth normals pointing in, and the bar under a mirrored skeleton
    too. (The rigid quad under the mirrored skeleton is left out: BakeSkinning gives it a transform of its own, which
    a mirror of the skeleton turns over, where Storm keeps the mesh's.)"""
    body = skel_root()
    if mirror == "mesh":
        body = mirrored(body, "double3 xformOp:translate = (5, 5, 5)")
        body = mirrored(body, "double3 xformOp:translate = (0, 0, 1)")
        body = body.replace("geomBindTransform = ( (1, 0, 0, 0)", "geomBindTransform = ( (-1, 0, 0, 0)")
        body = body.replace(RIGID_INDEX, f"matrix4d primvars:skel:geomBindTransform = {MIRROR_X}\n"
                                         f"        {RIGID_INDEX}")
        meshes = ("/Root/Bar", "/Root/Rigid", "/Root/Face")
    else:
        body = mirrored(body, "float xformOp:rotateY = 30")  # the Skeleton's
        meshes = ("/Root/Bar", "/Root/Face")
    if normals == "smooth":  # catmullClark, without normals: smooth ones made from the posed points
        authored = f'normal3f[] normals = {fmt(bar()[1])} (\n            interpolation = "vertex"\n        )'
        assert body.count(authored) == 1
        body = body.replace(authored, "").replace('subdivisionScheme = "none"', 'subdivisionScheme = "catmullClark"')
    path = write(tmp_path, body)
    stage = baked(path)
    time = Usd.TimeCode(5)
    by_path = {m.path: m for m in loaded(path, 5.0).meshes}
    for mesh_path in meshes:
        expected, expected_normals = world_triangles(stage, mesh_path, time)
        turn = np.sign(np.linalg.det(np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(
            stage.GetPrimAtPath(mesh_path)))[:3, :3]))
        front = turn * np.cross(expected[:, 1] - expected[:, 0], expected[:, 2] - expected[:, 0])
        mesh = by_path[mesh_path]
        got = mesh.points[mesh.indices]
        np.testing.assert_allclose(np.sort(got, axis=1), np.sort(expected, axis=1), atol=2e-6, err_msg=mesh_path)
        drawn = np.cross(got[:, 1] - got[:, 0], got[:, 2] - got[:, 0])
        assert (np.sum(drawn * front, axis=1) > 0).all(), mesh_path
        if normals == "smooth":  # on the front side but where the bulge folds the bar (2 of its 32 triangles)
            assert np.mean(np.sum(mesh.normals.sum(axis=1) * front, axis=1) > 0) > 0.9, mesh_path
        elif expected_normals is not None:  # authored ones, independent of the winding: the corners in either order
            np.testing.assert_allclose(mesh.normals.sum(axis=1), expected_normals.sum(axis=1), atol=1e-5)


ZERO_MATRIX = "( (0, 0, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0) )"
FLAT_MATRIX = "( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 0, 0), (0, 0, 0, 1) )"  # z scaled to 0
NAN_MATRIX = "( (nan, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1) )"


@pytest.mark.parametrize("mesh,matrix", [("Rigid", ZERO_MATRIX), ("Rigid", FLAT_MATRIX), ("Bar", ZERO_MATRIX),
                                         ("Bar", NAN_MATRIX)], ids=["rigid-zero", "rigid-flat", "bar-zero", "bar-nan"])
def test_a_geom_bind_transform_that_cannot_be_inverted_keeps_unposed_points_with_a_warning(tmp_path, mesh, matrix):
    """A zero or flattening ``primvars:skel:geomBindTransform`` (UsdSkel skins normals with its inverse transpose; USD
    says nothing and BakeSkinning collapses the mesh) drew the rigid quad or the skinned bar collapsed to a point or a
    plane, normals zero, without a word; a NaN one failed on the posed points, naming neither. The mesh is left
    unposed and named with the attribute, as a skeleton's singular bindTransforms are."""
    bound = np.array(eval(matrix.replace("nan", "float('nan')")), np.float64)
    assert not np.isfinite(bound).all() or np.linalg.det(bound[:3, :3]) == 0.0  # the oracle: NaN or singular
    body = skel_root()
    if mesh == "Rigid":
        body = body.replace(RIGID_INDEX, f"matrix4d primvars:skel:geomBindTransform = {matrix}\n        {RIGID_INDEX}")
        authored = np.array([(2, -0.2, 0), (2.4, -0.2, 0), (2.4, 0.2, 0), (2, 0.2, 0)]) + (0, 1, 1)
    else:
        old = "geomBindTransform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (-0.5, 0, 0, 1) )"
        assert old in body
        body = body.replace(old, f"geomBindTransform = {matrix}")
        authored = np.array(bar()[0], np.float64) + (5, 6, 5)  # the mesh's and the SkelRoot's translations
    why = "is not finite" if "nan" in matrix else r"cannot be inverted"
    with pytest.warns(UserWarning, match=rf"skinning failed.*geomBindTransform {why}.*/Root/{mesh}"):
        scene = load_usd(write(tmp_path, body), time=5.0)
    np.testing.assert_allclose({m.path: m for m in scene.meshes}[f"/Root/{mesh}"].points, authored, atol=1e-6)


def test_blend_shape_normal_offsets_turn_the_normals_as_bake_skinning_turns_them(tmp_path):
    """``normalOffsets`` of a blend shape and of its inbetween (the animation's weight, 0.83 at time 7, lies between
    them) are added to the bar's normals before skinning, and to the Face quad's own (blend shapes only). They were
    not applied: normals 0.34 from BakeSkinning's on the quad."""
    body = skel_root().replace('''            uniform int[] pointIndices = [9, 10]
''', '''            uniform int[] pointIndices = [9, 10]
            uniform vector3f[] normalOffsets = [(0, 0.8, 0.3), (0.5, 0, 0)]
            uniform vector3f[] inbetweens:half = [(0, 0.1, 0), (0, 0.1, 0)] (
                weight = 0.5
            )
            uniform vector3f[] inbetweens:half:normalOffsets = [(0.6, 0, 0), (0, -0.4, 0)]
''').replace('''            uniform int[] pointIndices = [2]
''', '''            uniform int[] pointIndices = [2]
            uniform vector3f[] normalOffsets = [(0, 0.5, 0)]
''').replace('''        rel skel:blendShapeTargets = </Root/Face/bulge>
''', '''        rel skel:blendShapeTargets = </Root/Face/bulge>
        uniform token subdivisionScheme = "none"
        normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)] (
            interpolation = "vertex"
        )
''')
    assert body.count("normalOffsets") == 3 and "normal3f[] normals = [(0, 0, 1)" in body
    path = write(tmp_path, body)
    stage = baked(path)
    by_path = {m.path: m for m in loaded(path, 7.0).meshes}
    for mesh_path in ("/Root/Bar", "/Root/Face"):
        expected, normals = world_triangles(stage, mesh_path, Usd.TimeCode(7))
        mesh = by_path[mesh_path]
        np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
        np.testing.assert_allclose(mesh.normals, normals, atol=2e-6)


OFFSETS, INDICES = "uniform vector3f[] offsets = [(0, 0, 0.4), (0, 0, 0.4)]", "uniform int[] pointIndices = [4, 5]"
BROKEN_SHAPES = {  # a second blend shape of the bar that does not fit it: (its attributes, what the warning says)
    "offsets": (["uniform vector3f[] offsets = [(0, 0, 0.4)]", INDICES], "1 offsets for 2 pointIndices"),
    "point index": ([OFFSETS, "uniform int[] pointIndices = [4, 20]"],
                    r"pointIndices\[1\] = 20 is out of range for 20 points"),
    "inbetween": ([OFFSETS, INDICES, "uniform vector3f[] inbetweens:half = [(0, 0, 0.1)] (weight = 0.5)"],
                  "1 inbetweens:half offsets for 2 pointIndices"),
    "normal offsets": ([OFFSETS, INDICES, "uniform vector3f[] normalOffsets = [(0, 1, 0)]"],
                       "1 normalOffsets for 2 pointIndices"),
    "NaN offset": (["uniform vector3f[] offsets = [(0, 0, nan), (0, 0, 0.4)]", INDICES], "offsets are not finite"),
}


@pytest.mark.parametrize("case", list(BROKEN_SHAPES))
def test_a_blend_shape_that_does_not_fit_is_left_out_with_a_warning(tmp_path, case):
    """A blend shape whose offsets do not fit the bar is left out, named with the mesh and what is wrong; the bar's
    good blend shape and its skinning still apply, as BakeSkinning poses the bar without the broken shape. USD failed
    the whole deformation for it: the bar was drawn unposed, 6.2 away, under a warning naming neither the shape nor
    what was wrong."""
    attributes, why = BROKEN_SHAPES[case]
    shape = "\n            ".join(attributes)
    body = skel_root().replace('''uniform token[] blendShapes = ["bulge"]
        float[] blendShapeWeights.timeSamples = { 1: [0.5], 10: [1] }''', '''uniform token[] blendShapes = ["bulge",
        "broken"]
        float[] blendShapeWeights.timeSamples = { 1: [0.5, 0.7], 10: [1, 1] }''').replace('''
            uniform int[] pointIndices = [9, 10]
        }''', f'''
            uniform int[] pointIndices = [9, 10]
        }}

        def BlendShape "broken"
        {{
            {shape}
        }}''')
    assert body.count('"broken"') == 2
    stage = baked(write(tmp_path, body))  # the broken shape authored but not bound: USD's pose without it
    bound = body.replace('''uniform token[] skel:blendShapes = ["bulge"]
        rel skel:blendShapeTargets = </Root/Bar/bulge>''', '''uniform token[] skel:blendShapes = ["bulge", "broken"]
        rel skel:blendShapeTargets = [</Root/Bar/bulge>, </Root/Bar/broken>]''')
    assert bound != body
    (tmp_path / "bound").mkdir()
    with pytest.warns(UserWarning, match=rf"blend shapes that do not fit their mesh were left out.*"
                                         rf"/Root/Bar/broken: {why}.*: /Root/Bar$"):
        scene = load_usd(write(tmp_path / "bound", bound), time=5.0)
    mesh = {m.path: m for m in scene.meshes}["/Root/Bar"]
    expected, normals = world_triangles(stage, "/Root/Bar", Usd.TimeCode(5))
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
    np.testing.assert_allclose(mesh.normals, normals, atol=2e-6)


UNPAIRED = {  # the Face quad's skel:blendShapes and skel:blendShapeTargets of other lengths: (lines, left out)
    "names": ('uniform token[] skel:blendShapes = ["bulge", "extra"]\n'
              "        rel skel:blendShapeTargets = </Root/Face/bulge>", r"skel:blendShapes \['extra'\] past its 1"),
    "targets": ('uniform token[] skel:blendShapes = ["bulge"]\n'
                "        rel skel:blendShapeTargets = [</Root/Face/bulge>, </Root/Face/extra>]",
                r"skel:blendShapeTargets \['/Root/Face/extra'\] past its 1"),
}


@pytest.mark.parametrize("case", list(UNPAIRED))
def test_blend_shapes_past_their_targets_are_left_out_with_a_warning_naming_the_mesh(tmp_path, case):
    """``skel:blendShapes[i]`` pairs with ``skel:blendShapeTargets[i]``; the entries past the shorter list are left
    out, named with the mesh, and the paired ``bulge`` still moves the Face quad's point 2 by its weight (0.5 at time
    1 to 1 at time 10). USD's ComputeSubShapeWeights refused the weights' size and with it every blend shape: the
    quad was drawn unposed under USD's 'Size of weights [2] != number of blend shapes [1]' alone, naming no mesh."""
    lines, left_out = UNPAIRED[case]
    animated = '''uniform token[] blendShapes = ["bulge", "extra"]
        float[] blendShapeWeights.timeSamples = { 1: [0.5, 0.7], 10: [1, 1] }'''
    bound = '''uniform token[] skel:blendShapes = ["bulge"]
        rel skel:blendShapeTargets = </Root/Face/bulge>'''
    body = skel_root().replace('''uniform token[] blendShapes = ["bulge"]
        float[] blendShapeWeights.timeSamples = { 1: [0.5], 10: [1] }''', animated).replace(bound, lines).replace(
        '''            uniform int[] pointIndices = [2]
        }''', '''            uniform int[] pointIndices = [2]
        }

        def BlendShape "extra"
        {
            uniform vector3f[] offsets = [(0, 0, 0.9)]
            uniform int[] pointIndices = [0]
        }''')
    assert animated in body and 'BlendShape "extra"' in body and lines in body
    with pytest.warns(UserWarning, match=rf"differ in length.*\({left_out} skel:.*: /Root/Face$"):
        scene = load_usd(write(tmp_path, body), time=5.0)
    weight = 0.5 + 0.5 * (5 - 1) / (10 - 1)  # bulge's, linearly between its samples
    points = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], np.float64)
    points[2] += weight * np.array([0, 0, 0.5])
    points += (0, 1, -3)  # the quad's translate and the SkelRoot's (blend shapes only: the mesh's own space)
    mesh = {m.path: m for m in scene.meshes}["/Root/Face"]
    np.testing.assert_allclose(mesh.points[mesh.indices], points[fan([4], [0, 1, 2, 3])], atol=1e-6)


@pytest.mark.parametrize("sampled", ["jointWeights", "geomBindTransform"])
def test_influences_with_only_time_samples_are_read_at_their_first_sample_with_the_default_time(tmp_path, sampled):
    """``time=None`` reads an attribute that has only time samples at its first sample, each attribute on its own
    (as every other attribute is read): the bar's jointWeights or geomBindTransform written as samples only, the
    jointIndices not. The influences were read at the jointIndices' time (the default): weights with no default
    value left the bar unposed under 'jointIndices and jointWeights do not match', and a sampled geomBindTransform
    was taken as the identity, 0.43 from USD's pose at the first sample."""
    path = write(tmp_path, skel_root())
    layer = Sdf.Layer.FindOrOpen(path)
    spec = layer.GetAttributeAtPath(f"/Root/Bar.primvars:skel:{sampled}")
    layer.SetTimeSample(spec.path, 1.0, spec.default)
    spec.ClearDefaultValue()
    layer.Save()
    stage = Usd.Stage.Open(path)
    assert stage.GetPrimAtPath("/Root/Bar").GetAttribute(f"primvars:skel:{sampled}").GetTimeSamples() == [1.0]
    expected, normals = world_triangles(baked(path), "/Root/Bar", Usd.TimeCode(1))
    mesh = {m.path: m for m in loaded(path, None).meshes}["/Root/Bar"]
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
    np.testing.assert_allclose(mesh.normals, normals, atol=2e-6)


def test_constant_influences_inherited_from_an_ancestor_bind_the_meshes_below_rigidly(tmp_path):
    """Constant jointIndices and jointWeights authored on an Xform are inherited by the meshes beneath it (as constant
    primvars are), which UsdSkel then moves rigidly with that joint: the quad under the Xform was drawn unposed, where
    BakeSkinning moves it with the tip (1.6 away), without a word."""
    body = skel_root().replace('''    def Mesh "Rigid" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {''', '''    def Xform "Holder" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {
        int[] primvars:skel:jointIndices = [1] (
            interpolation = "constant"
        )
        float[] primvars:skel:jointWeights = [1] (
            interpolation = "constant"
        )

    def Mesh "Rigid"
    {''').replace('''        int[] primvars:skel:jointIndices = [1] (
            interpolation = "constant"
        )
        float[] primvars:skel:jointWeights = [1] (
            interpolation = "constant"
        )
        double3 xformOp:translate = (0, 0, 1)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }''', '''        double3 xformOp:translate = (0, 0, 1)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    }''')
    assert 'def Xform "Holder"' in body and body.count('interpolation = "constant"') == 2
    path = write(tmp_path, body)
    stage = baked(path)
    expected, _ = world_triangles(stage, "/Root/Holder/Rigid", Usd.TimeCode(7))
    mesh = {m.path: m for m in loaded(path, 7.0).meshes}["/Root/Holder/Rigid"]
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)


def test_mesh_in_an_instance_skinned_by_a_skel_root_above_it_is_named(tmp_path):
    """A native instance under a SkelRoot whose prototype holds a skinned mesh (the SkelRoot and skeleton outside the
    prototype): USD poses each instance's proxy, which wrt (reading a prototype once for all its instances) cannot;
    the mesh was drawn unposed without a word. It still is, and is named."""
    instances = "\n".join(
        f'    def Xform "{name}" (\n        instanceable = true\n        prepend references = </Proto>\n    )\n    {{\n'
        f'        double3 xformOp:translate = ({x}, 0, 0)\n'
        f'        uniform token[] xformOpOrder = ["xformOp:translate"]\n    }}'
        for name, x in (("A", 3), ("B", -3))
    )
    root = skel_root()
    start, end = root.index('    def Mesh "Bar"'), root.index('    def Mesh "Rigid"')
    bar_mesh = root[start:end].replace("</Root/Bar/bulge>", "</Proto/Bar/bulge>")
    body = 'class Xform "Proto"\n{\n' + bar_mesh + "}\n" + root[:start] + instances + "\n" + root[end:]
    path = write(tmp_path, body)
    stage = Usd.Stage.Open(path)
    cache, root_prim = UsdSkel.Cache(), UsdSkel.Root(stage.GetPrimAtPath("/Root"))
    cache.Populate(root_prim, PROXIES)
    posed = {str(q.GetPrim().GetPath()) for b in cache.ComputeSkelBindings(root_prim, PROXIES)
             for q in b.GetSkinningTargets()}
    assert {"/Root/A/Bar", "/Root/B/Bar"} <= posed  # USD poses each instance's proxy
    with pytest.warns(UserWarning, match=r"UsdSkel skinning failed.*SkelRoot above its instance.*/Root/A/Bar"):
        scene = load_usd(path, time=5.0)
    assert len(scene.prototypes) == 1
    np.testing.assert_allclose(scene.prototypes[0].meshes[0].points, np.array(bar()[0]) + (5, 5, 5), atol=1e-6)


PROP_UNDER_SKEL_ROOT = """#usda 1.0
class Xform "Proto"
{
    def Mesh "Tri"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
}
def SkelRoot "Root" (
    prepend apiSchemas = ["SkelBindingAPI"]
)
{
    rel skel:skeleton = </Root/Skel>
    def Skeleton "Skel"
    {
        uniform token[] joints = ["j"]
        uniform matrix4d[] bindTransforms = [( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1) )]
        uniform matrix4d[] restTransforms = [( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1) )]
    }
    def Xform "Prop" (
        instanceable = true
        references = </Proto>
    )
    {
    }
}
"""


def test_an_unskinned_mesh_in_an_instance_under_a_skel_root_loads_as_usd_draws_it(tmp_path):
    """A plain prop instanced under a character's SkelRoot (no influences, no blend shapes): the check for a mesh
    that USD would pose per instance asked ``Usd.Prim.HasAuthoredValue``, which does not exist, and the load failed
    with an AttributeError."""
    path = tmp_path / "prop.usda"
    path.write_text(PROP_UNDER_SKEL_ROOT)
    stage = Usd.Stage.Open(str(path))
    cache, root = UsdSkel.Cache(), UsdSkel.Root(stage.GetPrimAtPath("/Root"))
    cache.Populate(root, PROXIES)
    targets = [q for b in cache.ComputeSkelBindings(root, PROXIES) for q in b.GetSkinningTargets()]
    assert not [q for q in targets if q.HasJointInfluences() or q.HasBlendShapes()]  # USD poses nothing
    scene = loaded(str(path), None)  # and wrt warns of nothing
    assert len(scene.prototypes) == 1 and len(scene.instances) == 1
    np.testing.assert_allclose(scene.prototypes[0].meshes[0].points, [(0, 0, 0), (1, 0, 0), (0, 1, 0)])


@pytest.mark.parametrize("animated", ["", "float[] blendShapeWeights = [1]",
                                      'uniform token[] blendShapes = ["bulge"]\n    float[] blendShapeWeights = []'])
def test_an_animation_that_names_no_blend_shapes_moves_none_as_bake_skinning(tmp_path, animated):
    """A SkelAnimation of joints only (no ``blendShapes``), one with weights but no names for them, or one naming
    ``bulge`` without a weight for it, binds no weight to the meshes' blend shapes: USD's mapper from its order to the
    mesh's maps none (the identity pads with 0), and BakeSkinning leaves them unmoved. wrt skipped remapping through
    a null or identity mapper and read the animation's weights as they were: the joints alone (or the missing weight)
    were warned of as blend shapes 'past its 0 skel:blendShapes' (the mesh's lists are one each), and the unnamed
    weight 1 moved the Face quad's point 2 by its bulge. The oracle: USD's BakeSkinning."""
    body = skel_root().replace('''uniform token[] blendShapes = ["bulge"]
        float[] blendShapeWeights.timeSamples = { 1: [0.5], 10: [1] }''', animated)
    assert "blendShapeWeights.timeSamples" not in body
    path = write(tmp_path, body)
    scene = loaded(path, 5.0)  # no warning
    expected, _ = world_triangles(baked(path), "/Root/Face", Usd.TimeCode(5.0))
    mesh = {m.path: m for m in scene.meshes}["/Root/Face"]
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=1e-6)


@pytest.mark.parametrize("target, why", [
    ("<{root}/Nope>", "no prim is there"),
    ("<{root}/Over>", r"it is only an 'over' \(defined nowhere\)"),
    ("<{root}/Typeless>", "it is a prim with no type, not a Skeleton"),
    ("<{root}/Bar/bulge>", "it is a BlendShape, not a Skeleton"),
])
def test_a_skeleton_binding_to_no_skeleton_leaves_the_meshes_unposed_named_with_the_target(tmp_path, target, why):
    """A ``skel:skeleton`` that targets a missing prim, an ``over`` or a prim of another type poses nothing (USD warns
    of the target alone); wrt said nothing. The meshes stay where USD's own transforms put their authored points."""
    old = "rel skel:skeleton = </Root/Skel>"
    body = replaced_once(skel_root(), old, "rel skel:skeleton = " + target.format(root="/Root"))
    body = body.replace('    def Skeleton "Skel"', '    over "Over"\n    {\n    }\n    def "Typeless"\n    {\n    }\n\n'
                        '    def Skeleton "Skel"', 1)
    path = write(tmp_path, body)
    named = rf"skel:skeleton targets {target[1:-1].format(root='/Root')}, but {why}"
    meshes = "/Root/Bar, /Root/Rigid, /Root/Face"
    with pytest.warns(UserWarning, match=rf"UsdSkel skinning failed.*\({named}: 3\): {meshes}$"):
        scene = load_usd(path, time=5.0)
    stage = Usd.Stage.Open(path)
    by_path = {m.path: m for m in scene.meshes}
    for mesh_path in ("/Root/Bar", "/Root/Rigid", "/Root/Face"):
        expected, _ = world_triangles(stage, mesh_path, Usd.TimeCode(5))
        np.testing.assert_allclose(by_path[mesh_path].points[by_path[mesh_path].indices], expected, atol=1e-6)


STATIC_WITH_BINDING_API = """
    def Mesh "Static" (
        prepend apiSchemas = ["SkelBindingAPI"]
    )
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        double3 xformOp:translate = (0, 0, 7)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
"""


@pytest.mark.parametrize("skeleton", ["</Root/Skel>", "</Root/Nope>"])
def test_a_static_mesh_with_the_binding_api_is_not_named_among_skinned_meshes(tmp_path, skeleton):
    """SkelBindingAPI, which exporters apply to every mesh under a SkelRoot, defines ``primvars:skel:jointIndices``
    and ``skel:blendShapes`` on a mesh that authors neither: it was taken for a skinned mesh, and beside a
    ``skel:skeleton`` that targets no Skeleton it was named among the meshes whose skinning failed (4 where 3 are
    skinned). It is drawn as authored, as BakeSkinning leaves it, and named with none of them."""
    body = skel_root()
    body = body[: body.rindex("}")] + STATIC_WITH_BINDING_API + "}\n"
    body = replaced_once(body, "rel skel:skeleton = </Root/Skel>", f"rel skel:skeleton = {skeleton}")
    path = write(tmp_path, body)
    if "Nope" in skeleton:
        named = r"skel:skeleton targets /Root/Nope, but no prim is there"
        with pytest.warns(UserWarning, match=rf"UsdSkel skinning failed.*\({named}: 3\): /Root/Bar, /Root/Rigid, "
                                             r"/Root/Face$"):
            scene = load_usd(path, time=5.0)
    else:
        scene = loaded(path, 5.0)  # no warning
    expected, _ = world_triangles(baked(path), "/Root/Static", Usd.TimeCode(5))
    mesh = {m.path: m for m in scene.meshes}["/Root/Static"]
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=1e-6)


@pytest.mark.parametrize("case", ["skeleton", "blend shape", "animation"])
def test_targets_inside_an_instance_prototype_are_named_under_its_first_instance(tmp_path, case):
    """A bad ``skel:skeleton``, ``skel:blendShapeTargets`` or ``skel:animationSource`` target inside a native
    instance's prototype was named by its prototype path (``/__Prototype_1/Root/Nope``, a name USD makes up per
    opening that no file holds); it is named under the prototype's first instance (``/A/Root/Nope``), as the meshes
    beside it are. The oracle: USD's ``GetPrototypes()`` and ``GetInstances()`` of the stage."""
    old, new, named = {
        "skeleton": ("rel skel:skeleton = </Root/Skel>", "rel skel:skeleton = </Root/Nope>",
                     "skel:skeleton targets {}/Root/Nope, but no prim is there"),
        "blend shape": ("rel skel:blendShapeTargets = </Root/Bar/bulge>",
                        "rel skel:blendShapeTargets = </Root/Bar/nope>",
                        "skel:blendShapeTargets[0] = {}/Root/Bar/nope: no prim is there"),
        "animation": ("rel skel:animationSource = </Root/Anim>", "rel skel:animationSource = </Root/NopeAnim>",
                      "skel:animationSource targets {}/Root/NopeAnim, but no prim is there"),
    }[case]
    body = replaced_once(skel_root("/Asset/Root"), *(x.replace("/Root", "/Asset/Root") for x in (old, new)))
    asset = tmp_path / "asset.usda"
    asset.write_text('#usda 1.0\ndef Xform "Asset"\n{\n' + body + "\n}\n")
    instances = "".join(f'def "{name}" (\n    references = @./asset.usda@</Asset>\n    instanceable = true\n)\n'
                        "{\n}\n" for name in ("B", "A"))
    path = write(tmp_path, instances)
    stage = Usd.Stage.Open(path)
    (prototype,) = stage.GetPrototypes()
    first = min(str(p.GetPath()) for p in prototype.GetInstances())
    assert first == "/A"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_usd(path, time=5.0)
    said = " ".join(str(w.message) for w in caught)
    assert named.format(first) in said, said
    assert "__Prototype" not in said, said


@pytest.mark.parametrize("target, why", [
    ("</Root/NopeAnim>", "no prim is there"),
    ("</Root/OverAnim>", r"it is only an 'over' \(defined nowhere\)"),
    ("</Root/Bar>", "it is a Mesh, not a SkelAnimation"),
    ("</Root/Anim>", "it is inactive"),
])
def test_an_animation_source_that_is_no_animation_poses_at_rest_named_with_the_target(tmp_path, target, why):
    """A Skeleton whose ``skel:animationSource`` targets a missing prim, an ``over``, a prim of another type or an
    inactive SkelAnimation poses its meshes at its rest transforms, as BakeSkinning does: a still character, of
    which wrt said nothing (USD warns of a missing target alone, naming no mesh). One warning names the skeleton, the
    target and why."""
    old = "rel skel:animationSource = </Root/Anim>"
    body = replaced_once(skel_root(), old, f"rel skel:animationSource = {target}")
    body = body.replace('    def SkelAnimation "Anim"\n',
                        '    over "OverAnim"\n    {\n    }\n    def SkelAnimation "Anim" (\n'
                        + ('        active = false\n' if why == "it is inactive" else "") + '    )\n', 1)
    path = write(tmp_path, body)
    named = rf"skel:animationSource targets {target[1:-1]}, but {why}"
    with pytest.warns(UserWarning, match=rf"targets no SkelAnimation.*\({named}: 1\): /Root/Skel$"):
        scene = load_usd(path, time=5.0)
    stage = baked(path)
    by_path = {m.path: m for m in scene.meshes}
    for mesh_path in ("/Root/Bar", "/Root/Rigid"):
        expected, _ = world_triangles(stage, mesh_path, Usd.TimeCode(5))
        np.testing.assert_allclose(by_path[mesh_path].points[by_path[mesh_path].indices], expected, atol=2e-6)
    (tmp_path / "animated").mkdir()
    animated, _ = world_triangles(baked(write(tmp_path / "animated", skel_root())), "/Root/Bar", Usd.TimeCode(5))
    assert np.abs(by_path["/Root/Bar"].points[by_path["/Root/Bar"].indices] - animated).max() > 0.2  # at rest


@pytest.mark.parametrize("targets, why", [
    ("</Root/Bar/nope>", "no prim is there"),
    ("</Root/Bar/ov>", r"it is only an 'over' \(defined nowhere\)"),
    ("</Root/Skel>", "it is a Skeleton, not a BlendShape"),
    ("[</Root/Bar/bulge>, </Root/Bar/nope>]", "no prim is there"),  # beside one that fits, which still applies
])
def test_a_blend_shape_target_that_is_no_blend_shape_is_left_out_and_the_mesh_posed(tmp_path, targets, why):
    """A ``skel:blendShapeTargets`` entry that is no BlendShape (missing, an ``over``, another type): USD's query keeps
    it with no sub-shape, yet gives it a weight for a sub-shape past the end, and wrt's skinning failed on it
    (IndexError), the whole mesh drawn unposed, 6.2 from BakeSkinning's pose. It is left out with a warning naming
    the mesh, the entry and why; the mesh is posed as BakeSkinning poses it."""
    old = "rel skel:blendShapeTargets = </Root/Bar/bulge>"
    body = replaced_once(skel_root(), old, f"rel skel:blendShapeTargets = {targets}")
    if targets.startswith("["):
        names = 'uniform token[] skel:blendShapes = ["bulge"]\n        rel skel:blendShapeTargets = ['
        body = body.replace(names, names.replace('["bulge"]', '["bulge", "gone"]'))
    over = '        over "ov"\n        {\n        }\n'
    body = body.replace('        def BlendShape "bulge"', over + '        def BlendShape "bulge"', 1)
    path = write(tmp_path, body)
    k, bad = (1, "/Root/Bar/nope") if targets.startswith("[") else (0, targets[1:-1])
    named = rf"skel:blendShapeTargets\[{k}\] = {bad}: {why}"
    with pytest.warns(UserWarning, match=rf"do not fit.*\({named}: 1\): /Root/Bar$"):
        scene = load_usd(path, time=5.0)
    stage = baked(path)
    mesh = {m.path: m for m in scene.meshes}["/Root/Bar"]
    expected, _ = world_triangles(stage, "/Root/Bar", Usd.TimeCode(5))
    np.testing.assert_allclose(mesh.points[mesh.indices], expected, atol=2e-6)
