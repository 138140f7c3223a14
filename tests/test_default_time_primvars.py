"""With ``time=None`` a colour primvar whose values or indices have only time samples is read at their first sample
(README: "any value that has only time samples ... is read at its first sample"), on every kind of prim that reads
one: meshes, gprims, Points, curves, and the constant colour a native instance hands down to its prototype. The
oracle is USD's own ``Primvar.ComputeFlattened`` at the first sample's time code."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

import wrt

FIRST, LATER = 5.0, 10.0  # the time samples authored; nothing is authored at the default time unless said
RED, GREEN, BLUE, YELLOW = (0.9, 0.1, 0.1), (0.1, 0.8, 0.2), (0.1, 0.2, 0.9), (0.9, 0.8, 0.1)


def _color(prim: Usd.Prim, indexed_samples: bool) -> None:
    """A constant displayColor on ``prim``: its values sampled only (GREEN then BLUE), or, with
    ``indexed_samples``, values authored at the default time (RED, GREEN) and indices sampled only ([1] then [0])."""
    primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                      UsdGeom.Tokens.constant)
    if indexed_samples:
        primvar.Set(Vt.Vec3fArray([RED, GREEN]))
        indices = primvar.CreateIndicesAttr()
        indices.Set(Vt.IntArray([1]), FIRST)
        indices.Set(Vt.IntArray([0]), LATER)
    else:
        primvar.GetAttr().Set(Vt.Vec3fArray([GREEN]), FIRST)
        primvar.GetAttr().Set(Vt.Vec3fArray([BLUE]), LATER)


def _stage(path: str, kind: str, indexed_samples: bool) -> str:
    """A stage of one prim of ``kind`` (a colour ``holder`` prim's path returned) in front of camera ``/Cam``."""
    stage = Usd.Stage.CreateNew(path)
    if kind == "Mesh":
        mesh = UsdGeom.Mesh.Define(stage, "/Thing")
        mesh.CreatePointsAttr([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)])
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        holder = mesh.GetPrim()
    elif kind in ("Cube", "Sphere"):
        holder = stage.DefinePrim("/Thing", kind)
    elif kind == "Points":
        points = UsdGeom.Points.Define(stage, "/Thing")
        points.CreatePointsAttr([(0, 0, 0)])
        points.CreateWidthsAttr([2.0])
        holder = points.GetPrim()
    elif kind == "BasisCurves":
        curves = UsdGeom.BasisCurves.Define(stage, "/Thing")
        curves.CreateTypeAttr(UsdGeom.Tokens.linear)
        curves.CreatePointsAttr([(-1, 0, 0), (1, 0, 0)])
        curves.CreateCurveVertexCountsAttr([2])
        curves.CreateWidthsAttr([1.5])
        curves.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        holder = curves.GetPrim()
    else:  # "instance": a native instance of a Cube, the colour on the instance prim
        UsdGeom.Cube.Define(stage, "/Proto/Box")
        stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
        holder = stage.DefinePrim("/Thing", "Xform")
        holder.GetInherits().AddInherit("/Proto")
        holder.SetInstanceable(True)
    _color(holder, indexed_samples)
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    camera.AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    stage.GetRootLayer().Save()
    return str(holder.GetPath())


@pytest.mark.parametrize("indexed_samples", [False, True], ids=["sampled values", "sampled indices"])
@pytest.mark.parametrize("kind", ["Mesh", "Cube", "Sphere", "Points", "BasisCurves", "instance"])
def test_a_colour_with_only_time_samples_is_read_at_its_first_sample_by_default(tmp_path, kind, indexed_samples):
    path = str(tmp_path / "scene.usda")
    holder = _stage(path, kind, indexed_samples)
    stage = Usd.Stage.Open(path)
    primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(holder)).GetPrimvar("displayColor")
    expected = np.array(primvar.ComputeFlattened(Usd.TimeCode(FIRST))[0])  # USD's colour at the first sample
    assert not np.allclose(expected, primvar.ComputeFlattened(Usd.TimeCode(LATER))[0])  # (the samples differ)
    albedos = []
    for time in (None, FIRST):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = wrt.load_usd(path, time=time)
        img = wrt.render(scene, camera="/Cam", width=8, height=8, integrator="albedo", device="cpu")
        albedos.append(img.aovs["albedo"][4, 4])
    np.testing.assert_allclose(albedos[1], expected, atol=1e-5)  # read at the sample's time: USD's colour
    np.testing.assert_allclose(albedos[0], expected, atol=1e-5)  # and so with no time given
