"""Primvar edge cases on every kind of prim that reads one (meshes, gprims, Points, curves, native instances,
PointInstancers). With ``time=None`` a colour primvar whose values or indices have only time samples is read at their
first sample (README: "any value that has only time samples ... is read at its first sample"); the oracle is USD's own
``Primvar.ComputeFlattened`` at the first sample's time code. Indices that USD cannot read as indices (authored as
another type than ``int[]``), colours authored as quaternions and PointInstancer opacities that hold no numbers drop
the primvar with a warning: none stops the load.
"""

from __future__ import annotations

import re
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


@pytest.mark.parametrize("indices_type", ["int64[]", "float[]", "string[]"])
@pytest.mark.parametrize("kind", ["Mesh", "Cube", "Points", "BasisCurves", "instance", "PointInstancer"])
def test_indices_of_another_type_than_int_are_dropped_with_a_warning(tmp_path, kind, indices_type):
    """USD reads no indices from ``primvars:displayColor:indices`` authored as another type than ``int[]``
    (``ComputeFlattened`` fails): the primvar is dropped with a warning naming the prim and the type, the prim drawn
    grey as if it had none. Such indices raised in ``ComputeFlattened`` and stopped the load (gprims, Points,
    curves, instances); meshes and PointInstancers read them as indices, and ``string[]`` ones stopped the load."""
    path = str(tmp_path / "scene.usda")
    holder = _stage(path, "Cube" if kind == "PointInstancer" else kind, False)
    stage = Usd.Stage.Open(path)
    if kind == "PointInstancer":  # the Cube as the prototype of one instance, nearer the camera; its colour on the
        # instancer
        stage.GetPrimAtPath("/Thing").RemoveProperty("primvars:displayColor")
        instancer = UsdGeom.PointInstancer.Define(stage, "/Instancer")
        instancer.CreatePrototypesRel().AddTarget("/Thing")
        instancer.CreatePositionsAttr([(0, 0, 1)])
        instancer.CreateProtoIndicesAttr([0])
        primvar = UsdGeom.PrimvarsAPI(instancer).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                               UsdGeom.Tokens.vertex)
        holder = "/Instancer"
    else:
        primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(holder)).GetPrimvar("displayColor")
    primvar.GetAttr().Clear()
    primvar.Set(Vt.Vec3fArray([RED, GREEN]))
    kinds = {"int64[]": (Sdf.ValueTypeNames.Int64Array, Vt.Int64Array([1])),
             "float[]": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([1.0])),
             "string[]": (Sdf.ValueTypeNames.StringArray, Vt.StringArray(["x"]))}
    value_type, value = kinds[indices_type]
    stage.GetPrimAtPath(holder).CreateAttribute("primvars:displayColor:indices", value_type).Set(value)
    stage.GetRootLayer().Save()
    assert primvar.IsIndexed() and not primvar.GetIndices()  # USD: indexed, but it reads no indices
    with pytest.warns(UserWarning, match=rf"(?s)displayColor:indices is {indices_type.replace('[]', '')}.*{holder}"):
        scene = wrt.load_usd(path)
    img = wrt.render(scene, camera="/Cam", width=8, height=8, integrator="albedo", device="cpu")
    np.testing.assert_allclose(img.aovs["albedo"][4, 4], 0.5, atol=1e-5)  # no displayColor: the default grey


@pytest.mark.parametrize("kind", ["Mesh", "Cube", "Points", "BasisCurves", "instance", "PointInstancer"])
def test_a_display_color_of_quaternions_is_dropped_with_a_warning_on_every_prim(tmp_path, kind):
    """A ``quatf[]`` displayColor is no array of colours (USD's type is ``GfQuatf``, not a vector), whatever numpy
    makes of it: every prim drops it with a warning naming the type and draws the default grey, as meshes did. Other
    prims took its four numbers as an rgba (the identity quaternion as black) without a word."""
    path = str(tmp_path / "scene.usda")
    holder = _stage(path, "Cube" if kind == "PointInstancer" else kind, False)
    stage = Usd.Stage.Open(path)
    if kind == "PointInstancer":  # the Cube as the prototype of one instance, nearer the camera
        stage.GetPrimAtPath(holder).RemoveProperty("primvars:displayColor")
        instancer = UsdGeom.PointInstancer.Define(stage, "/Instancer")
        instancer.CreatePrototypesRel().AddTarget(holder)
        instancer.CreatePositionsAttr([(0, 0, 1)])
        instancer.CreateProtoIndicesAttr([0])
        holder = "/Instancer"
    stage.GetRootLayer().Save()
    layer = Sdf.Layer.FindOrOpen(path)
    spec = layer.GetPrimAtPath(holder)
    if "primvars:displayColor" in spec.properties:
        del spec.properties["primvars:displayColor"]
    colour = Sdf.AttributeSpec(spec, "primvars:displayColor", Sdf.ValueTypeNames.QuatfArray)
    colour.default = Vt.QuatfArray([Gf.Quatf(1.0)])  # the identity: (0, 0, 0) imaginary, 1 real
    colour.SetInfo("interpolation", UsdGeom.Tokens.constant)
    layer.Save()
    with pytest.warns(UserWarning, match=rf"(?s)quatf\[\].*{holder}"):
        scene = wrt.load_usd(path)
    img = wrt.render(scene, camera="/Cam", width=8, height=8, integrator="albedo", device="cpu")
    np.testing.assert_allclose(img.aovs["albedo"][4, 4], 0.5, atol=1e-5)  # no displayColor: the default grey


@pytest.mark.parametrize("value_type", ["string[]", "token[]", "asset[]", "string"])
def test_a_point_instancers_opacity_that_holds_no_numbers_is_dropped_with_a_warning(tmp_path, value_type):
    """A PointInstancer's ``displayOpacity`` authored with values that are no numbers (strings, tokens, asset paths)
    is dropped with a warning naming the instancer and the type, its instance drawn opaque in the default grey:
    converting them to floats raised, and the load of the whole stage stopped with SceneError."""
    path = str(tmp_path / "scene.usda")
    holder = _stage(path, "Cube", False)
    stage = Usd.Stage.Open(path)
    stage.GetPrimAtPath(holder).RemoveProperty("primvars:displayColor")
    instancer = UsdGeom.PointInstancer.Define(stage, "/Instancer")
    instancer.CreatePrototypesRel().AddTarget(holder)
    instancer.CreatePositionsAttr([(0, 0, 1)])  # nearer the camera than the prototype itself
    instancer.CreateProtoIndicesAttr([0])
    kinds = {"string[]": (Sdf.ValueTypeNames.StringArray, Vt.StringArray(["half"])),
             "token[]": (Sdf.ValueTypeNames.TokenArray, Vt.TokenArray(["half"])),
             "asset[]": (Sdf.ValueTypeNames.AssetArray, Sdf.AssetPathArray([Sdf.AssetPath("half.png")])),
             "string": (Sdf.ValueTypeNames.String, "half")}
    value_type_name, value = kinds[value_type]
    opacity = instancer.GetPrim().CreateAttribute("primvars:displayOpacity", value_type_name)
    opacity.Set(value)
    opacity.SetMetadata("interpolation", UsdGeom.Tokens.constant)
    stage.GetRootLayer().Save()
    with pytest.warns(UserWarning, match=rf"(?s)PointInstancer displayOpacity.*{re.escape(value_type)}.*/Instancer"):
        scene = wrt.load_usd(path)
    img = wrt.render(scene, camera="/Cam", width=8, height=8, integrator="albedo", device="cpu")
    np.testing.assert_allclose(img.aovs["albedo"][4, 4], 0.5, atol=1e-5)
    assert img.aovs["coverage"][4, 4] == 1.0  # opaque
