"""Native instances under and outside a ``renderVisibility = invisible`` opinion share one read of their prototype
where no prim inside it (through nested prototypes) can be of render purpose: the hidden purpose changes nothing
drawn there. The oracle for what is drawn is the same stage with its instances flattened (``instanceable = false``,
so USD's own ``ComputePurpose`` and ``ComputeEffectiveVisibility`` on the prims decide): camera rays hit the same."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402


def two_instances(tmp_path, inside: str, instanceable: bool) -> tuple[str, Usd.Stage]:
    """Instances /Hider/A (under renderVisibility = invisible) and /Plain/B of class /Asset, which holds a cube of
    default purpose and, by ``inside``, nothing more, a cube of render purpose, or a nested instance of /Kit (a
    render cube) or of /Bare (a default cube)."""
    path = str(tmp_path / f"{inside}_{instanceable}.usda")
    stage = Usd.Stage.CreateNew(path)
    stage.CreateClassPrim("/Asset")
    UsdGeom.Cube.Define(stage, "/Asset/D")
    stage.CreateClassPrim("/Kit")
    UsdGeom.Cube.Define(stage, "/Kit/R").CreatePurposeAttr("render")
    stage.CreateClassPrim("/Bare")
    UsdGeom.Cube.Define(stage, "/Bare/D")
    if inside == "render":
        UsdGeom.Cube.Define(stage, "/Asset/R").CreatePurposeAttr("render")
    elif inside in ("kit", "bare"):
        nested = UsdGeom.Xform.Define(stage, "/Asset/N")
        nested.AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
        nested.GetPrim().GetReferences().AddInternalReference("/Kit" if inside == "kit" else "/Bare")
        nested.GetPrim().SetInstanceable(instanceable)
    if inside == "render":
        UsdGeom.Xform(stage.GetPrimAtPath("/Asset/R")).AddTranslateOp().Set(Gf.Vec3d(0, -3, 0))
    hider = UsdGeom.Xform.Define(stage, "/Hider")
    UsdGeom.VisibilityAPI.Apply(hider.GetPrim()).CreateRenderVisibilityAttr("invisible")
    UsdGeom.Xform.Define(stage, "/Plain")
    for name, x in (("/Hider/A", 0.0), ("/Plain/B", 4.0)):
        instance = UsdGeom.Xform.Define(stage, name)
        instance.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        instance.GetPrim().GetReferences().AddInternalReference("/Asset")
        instance.GetPrim().SetInstanceable(instanceable)
    stage.Save()
    return path, stage


def down_rays():
    """A grid of rays looking down -z over both instances and everything in them."""
    xs, ys = np.meshgrid(np.linspace(-2.5, 6.5, 37), np.linspace(-5.5, 5.5, 45))
    origins = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 10.0)], axis=1).astype(np.float32)
    directions = np.tile(np.float32([0, 0, -1]), (len(origins), 1))
    return origins, directions


def load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path)


@pytest.mark.parametrize("inside", ["default", "render", "kit", "bare"])
def test_a_hidden_purpose_no_prim_inside_takes_shares_the_prototype(tmp_path, inside):
    """With only default-purpose cubes inside (``default``, ``bare``), /Asset was read twice, once per set of hidden
    purposes (two identical prototypes, two BLAS builds); with a render cube inside (``render``, ``kit``) the
    instances differ and the render cube is hidden under /Hider only. Either way the hits are the flattened stage's."""
    path, stage = two_instances(tmp_path, inside, instanceable=True)
    flat_path, flat_stage = two_instances(tmp_path, inside, instanceable=False)
    drawn = {str(p.GetPath()) for p in flat_stage.Traverse() if p.IsA(UsdGeom.Cube)
             and UsdGeom.Imageable(p).ComputeEffectiveVisibility(UsdGeom.Imageable(p).ComputePurpose()) != "invisible"}
    scene, flat = load(path), load(flat_path)
    assert set(flat.prim_paths()) == drawn and set(scene.prim_paths()) == drawn
    if inside in ("default", "render"):
        assert len(scene.prototypes) == (1 if inside == "default" else 2)
    elif inside == "bare":
        # /Asset and /Bare once each, whatever opinion is above the instances
        assert len(scene.prototypes) == 2
    origins, directions = down_rays()
    hits, flat_hits = wrt.trace(scene, origins, directions), wrt.trace(flat, origins, directions)
    np.testing.assert_array_equal(scene.hit_paths(hits)[0], flat.hit_paths(flat_hits)[0])
    np.testing.assert_allclose(hits.t, flat_hits.t, rtol=1e-6)
    assert (hits.prim >= 0).sum() > 0
