"""Differential tests of wrt's UsdSkel posing on generated stages (tests/skel_stages.py) against USD's own skinning
(tests/skel_oracle.py: ``SkinningQuery.ComputeSkinnedPoints``/``ComputeSkinnedTransform`` and ``BlendShapeQuery``
placed by the Skeleton prim's world transform).

Each seed's stage mixes joint trees, animations (time-sampled, static, partial and reordered, none), bindings on the
SkelRoot, an Xform or the mesh, nested SkelRoots, influences of both interpolations and 1 to 4 per point, local joint
orders, geomBindTransforms, blend shapes with inbetweens and pointIndices, both skinning methods and transforms above
and below the SkelRoot; seeds 0 to 9 cover all of these. A mesh USD fails to pose (a skeleton with neither animation
nor rest transforms) must be drawn unposed, with a warning.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdSkel, Vt  # noqa: E402
from skel_oracle import PREDICATE, world_points  # noqa: E402
from skel_stages import TIMES, generate  # noqa: E402

from wrt.usd import load_usd  # noqa: E402

SEEDS = range(12)
FAILED = "UsdSkel skinning failed"


def _tolerance(expected: np.ndarray) -> float:
    return 2e-5 * max(1.0, float(np.abs(expected).max()))  # float32 skinning of points up to ~10 from the origin


def _unposed(prim: Usd.Prim, time: Usd.TimeCode) -> np.ndarray:
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim))
    return np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get(time), np.float64) @ m[:3, :3] + m[3, :3]


def _expected(stage: Usd.Stage, time: Usd.TimeCode):
    """Mesh path -> ``(T, 3, 3)`` world corners as USD poses them (unposed where USD fails), and the paths USD
    fails to pose."""
    oracle = world_points(stage, time)
    expected, failed = {}, []
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), PREDICATE):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        path = str(prim.GetPath())
        answers = oracle.get(path + "#all", [oracle[path]])
        assert all((a is None) == (answers[0] is None) for a in answers), path  # nested SkelRoots agree
        points = oracle[path]
        if points is None:
            failed.append(path)
            points = _unposed(prim, time)
        triangles = np.array(UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        expected[path] = points[triangles]
    return expected, failed


def _load(path: str, time):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_usd(path, time=time)
    return scene, " ".join(str(w.message) for w in caught)


@pytest.mark.parametrize("time", [None, *TIMES])
@pytest.mark.parametrize("seed", SEEDS)
def test_generated_skinned_meshes_match_usd(tmp_path, seed, time):
    """Every mesh's world triangles equal USD's pose at samples, between them and at ``time=None`` (each attribute
    with only samples read at its first: USD's ``EarliestTime``); a mesh USD cannot pose is drawn unposed and the
    load warns (the warning lists the first few paths)."""
    path = generate(seed, str(tmp_path / f"skel{seed}.usda"))
    at = Usd.TimeCode.EarliestTime() if time is None else Usd.TimeCode(time)
    expected, failed = _expected(Usd.Stage.Open(path), at)
    scene, warned = _load(path, time)
    by_path = {m.path: m for m in scene.meshes}
    assert sorted(by_path) == sorted(expected)
    for mesh_path, corners in expected.items():
        mesh = by_path[mesh_path]
        np.testing.assert_allclose(mesh.points[mesh.indices], corners, atol=_tolerance(corners), err_msg=mesh_path)
    assert (FAILED in warned) == bool(failed), warned


@pytest.mark.parametrize("seed", range(4))
def test_generated_skinned_meshes_inside_instances_match_usd(tmp_path, seed):
    """The SkelRoots in a prototype drawn by two instances: every triangle of ``Scene.triangles()`` is one of USD's
    posed instance-proxy triangles (each instance placed by its own transform), one to one."""
    path = generate(seed, str(tmp_path / f"skel{seed}.usda"), instanced=True)
    for time in (1.0, 6.5):
        expected, _ = _expected(Usd.Stage.Open(path), Usd.TimeCode(time))
        expected = np.concatenate(list(expected.values())).reshape(-1, 9)
        scene, _ = _load(path, time)
        assert len(scene.prototypes) >= 1
        points, indices = scene.triangles()
        got = points[indices].reshape(-1, 9).astype(np.float64)
        assert got.shape == expected.shape
        distance = np.abs(got[:, None, :] - expected[None, :, :]).max(axis=2)
        tolerance = _tolerance(expected)
        assert distance.min(axis=1).max() < tolerance and distance.min(axis=0).max() < tolerance
        assert len(set(distance.argmin(axis=1))) == len(expected)  # one to one


def _first(stage, kind):
    return next((p for p in stage.Traverse() if p.IsA(kind)), None)


def _skinned(stage):
    return next(p for p in stage.Traverse() if p.GetAttribute("primvars:skel:jointIndices").HasAuthoredValue())


def _edit_array(attr, edit):
    """``attr``'s value at every time it has (its samples, or its default) replaced by ``edit(list)``."""
    times = attr.GetTimeSamples() or [Usd.TimeCode.Default()]
    for t in times:
        value = attr.Get(t)
        attr.Set(type(value)(edit(list(value))), t)


def _set_at(k, value):
    def edit(values):
        values[k] = value
        return values
    return edit


CORRUPTIONS = {  # bad skel data, applied to the first skinned mesh, Skeleton, SkelAnimation or BlendShape target
    "joint index out of range": lambda s: _edit_array(_skinned(s).GetAttribute("primvars:skel:jointIndices"),
                                                      _set_at(0, 99)),
    "negative joint index": lambda s: _edit_array(_skinned(s).GetAttribute("primvars:skel:jointIndices"),
                                                  _set_at(0, -1)),
    "NaN joint weight": lambda s: _edit_array(_skinned(s).GetAttribute("primvars:skel:jointWeights"),
                                              _set_at(0, float("nan"))),
    "infinite joint weight": lambda s: _edit_array(_skinned(s).GetAttribute("primvars:skel:jointWeights"),
                                                   _set_at(0, float("inf"))),
    "weights shorter than indices": lambda s: _edit_array(_skinned(s).GetAttribute("primvars:skel:jointWeights"),
                                                          lambda v: v[:-1]),
    "weights of another elementSize": lambda s: _skinned(s).GetAttribute("primvars:skel:jointWeights").SetMetadata(
        "elementSize", 5),
    "empty joint influences": lambda s: [_skinned(s).GetAttribute(f"primvars:skel:joint{name}").Set(array())
                                         for name, array in (("Indices", Vt.IntArray), ("Weights", Vt.FloatArray))],
    "no jointWeights": lambda s: _skinned(s).RemoveProperty("primvars:skel:jointWeights"),
    "joint indices of uniform interpolation": lambda s: _skinned(s).GetAttribute(
        "primvars:skel:jointIndices").SetMetadata("interpolation", "uniform"),
    "skeleton target missing": lambda s: UsdSkel.BindingAPI(_skinned(s)).CreateSkeletonRel().SetTargets(
        [Sdf.Path("/Nowhere/Skel")]),
    "skeleton target not a Skeleton": lambda s: UsdSkel.BindingAPI(_skinned(s)).CreateSkeletonRel().SetTargets(
        [_skinned(s).GetPath()]),
    "animation source missing": lambda s: UsdSkel.BindingAPI.Apply(_first(s, UsdSkel.Skeleton))
    .CreateAnimationSourceRel().SetTargets([Sdf.Path("/Nowhere/Anim")]),
    "animation source not an animation": lambda s: UsdSkel.BindingAPI.Apply(_first(s, UsdSkel.Skeleton))
    .CreateAnimationSourceRel().SetTargets([_skinned(s).GetPath()]),
    "animation shorter than its joints": lambda s: _edit_array(
        UsdSkel.Animation(_first(s, UsdSkel.Animation)).GetTranslationsAttr(), lambda v: v[:-1]),
    "NaN rotation": lambda s: _edit_array(UsdSkel.Animation(_first(s, UsdSkel.Animation)).GetRotationsAttr(),
                                          _set_at(0, Gf.Quatf(float("nan"), 0, 0, 0))),
    "zero scale": lambda s: _edit_array(UsdSkel.Animation(_first(s, UsdSkel.Animation)).GetScalesAttr(),
                                        _set_at(0, Gf.Vec3h(0, 0, 0))),
    "singular bindTransform": lambda s: _edit_array(UsdSkel.Skeleton(_first(s, UsdSkel.Skeleton))
                                                    .GetBindTransformsAttr(), _set_at(0, Gf.Matrix4d(0.0))),
    "unknown skinning method": lambda s: UsdSkel.BindingAPI(_skinned(s)).CreateSkinningMethodAttr("linear"),
    # The first joint once more at the end (renaming a joint instead would leave a mesh's skel:joints naming one the
    # skeleton lacks, which wrt poses as BakeSkinning does, not as ComputeSkinnedPoints: test_usd_skel.py).
    "duplicate joint names": lambda s: [_edit_array(_first(s, UsdSkel.Skeleton).GetAttribute(name), lambda v: v + v[:1])
                                        for name in ("joints", "bindTransforms", "restTransforms")],
    "children before parents": lambda s: _edit_array(UsdSkel.Skeleton(_first(s, UsdSkel.Skeleton)).GetJointsAttr(),
                                                     lambda v: v[::-1]),
    "blend shape target not a BlendShape": lambda s: next(
        UsdSkel.BindingAPI(p).GetBlendShapeTargetsRel().SetTargets([p.GetPath()]) for p in s.Traverse()
        if UsdSkel.BindingAPI(p).GetBlendShapeTargetsRel().GetTargets()),
}


# Corruptions whose pose comes from USD's BakeSkinning: the oracle's own assembly of UsdSkel's queries gives up on
# a blend shape target that is no BlendShape (ComputeDeformedPoints fails on its weight), where BakeSkinning leaves
# that blend shape out and poses the mesh.
BAKED = ("blend shape target not a BlendShape",)


def _baked(path: str, time: Usd.TimeCode):
    """:func:`_expected` from ``UsdSkel.BakeSkinning`` (exact at whole time codes) of the stage at ``path``."""
    stage = Usd.Stage.Open(path)
    stage.SetEditTarget(Usd.EditTarget(stage.GetSessionLayer()))
    assert UsdSkel.BakeSkinning(stage.Traverse())
    expected = {}
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), PREDICATE):
        if prim.IsA(UsdGeom.Mesh):
            triangles = np.array(UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
            expected[str(prim.GetPath())] = _unposed(prim, time)[triangles]  # the baked points, placed
    return expected, []


@pytest.mark.parametrize("case", list(CORRUPTIONS))
@pytest.mark.parametrize("seed", [0, 3])
def test_bad_skel_data_is_posed_as_usd_poses_it_or_left_unposed_with_a_warning(tmp_path, seed, case):
    """Bad skel data never fails the load: each mesh is drawn as USD poses it or, where USD cannot (or wrt finds the
    data broken), in its unposed points under a warning."""
    path = generate(seed, str(tmp_path / "skel.usda"), anim="sampled")
    stage = Usd.Stage.Open(path)
    CORRUPTIONS[case](stage)
    stage.GetRootLayer().Save()
    time = Usd.TimeCode(7.0 if case in BAKED else 6.5)  # BakeSkinning bakes whole time codes
    stage = Usd.Stage.Open(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # USD's own diagnostics of the bad data
        try:
            expected, _ = _baked(path, time) if case in BAKED else _expected(stage, time)
        except Tf.ErrorException:
            expected = {}
    scene, warned = _load(path, time.GetValue())
    for mesh in scene.meshes:
        got = mesh.points[mesh.indices]
        corners = expected.get(mesh.path)
        if corners is not None and np.isfinite(corners).all() and np.abs(got - corners).max() < _tolerance(corners):
            continue
        prim = stage.GetPrimAtPath(mesh.path)
        triangles = np.array(UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        unposed = _unposed(prim, time)[triangles]
        np.testing.assert_allclose(got, unposed, atol=_tolerance(unposed), err_msg=mesh.path)
        assert "UsdSkel" in warned, mesh.path
