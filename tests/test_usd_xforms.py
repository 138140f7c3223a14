"""Tests for wrt.usd_xforms: transforms at the default time, op by op where ops have time samples, from
``UsdGeom.XformCache`` elsewhere."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from gprim_stages import placed_shapes  # noqa: E402
from pxr import Gf, Sdf, Usd, UsdGeom  # noqa: E402
from usd_placements import drawn_placements  # noqa: E402

import wrt  # noqa: E402
import wrt.usd_xforms  # noqa: E402
from wrt.usd_xforms import DefaultTimeXforms  # noqa: E402

DEFAULT = Usd.TimeCode.Default()


def _op_by_op(prim: Usd.Prim) -> np.ndarray:
    """The oracle: ``prim``'s world transform with each op read at its default, or at its first time sample when it
    has only samples (wrt's rule), multiplied up the hierarchy in plain numpy."""
    world = np.eye(4)
    chain = []
    p = prim
    while not p.IsPseudoRoot():
        chain.append(p)
        p = p.GetParent()
    for q in reversed(chain):
        xformable = UsdGeom.Xformable(q)
        local = np.eye(4)
        for op in xformable.GetOrderedXformOps():
            attr = op.GetAttr()
            has_default = attr.Get(DEFAULT) is not None
            time = DEFAULT if has_default or not attr.GetTimeSamples() else attr.GetTimeSamples()[0]
            local = np.array(op.GetOpTransform(time)) @ local
        world = local if xformable.GetResetXformStack() else local @ world
    return world


def _robot_stage() -> Usd.Stage:
    """Links under a base read at its default (/Still/...) and under one animated only by time samples (/Moving/...),
    with pivots, an inverted op, orientations of each precision and a resetXformStack below the animated base."""
    stage = Usd.Stage.CreateInMemory()
    for base in ("Still", "Moving"):
        root = UsdGeom.Xform.Define(stage, f"/{base}")
        op = root.AddTranslateOp()
        if base == "Moving":
            op.Set(Gf.Vec3d(0, 0, 3), 1.0)  # only a sample: read at it
            op.Set(Gf.Vec3d(0, 0, 9), 2.0)
        else:
            op.Set(Gf.Vec3d(0, 0, 3))  # a default beside samples: read at the default, as ops without samples
            op.Set(Gf.Vec3d(0, 0, 9), 2.0)
        arm = UsdGeom.Xform.Define(stage, f"/{base}/Arm")
        arm.AddTranslateOp().Set(Gf.Vec3d(1, 0, 0))
        pivot = arm.AddTranslateOp(opSuffix="pivot")
        pivot.Set(Gf.Vec3f(0.2, 0.1, 0.3))
        arm.AddRotateXYZOp().Set(Gf.Vec3f(30, 45, 60))
        arm.AddTranslateOp(opSuffix="pivot", isInverseOp=True)
        for name, precision, quat in (("Half", UsdGeom.XformOp.PrecisionHalf, Gf.Quath(0.7071, 0, 0, 0.7071)),
                                      ("Float", UsdGeom.XformOp.PrecisionFloat, Gf.Quatf(0.9238795, 0.3826834, 0, 0)),
                                      ("Double", UsdGeom.XformOp.PrecisionDouble, Gf.Quatd(0.5, 0.5, 0.5, 0.5))):
            link = UsdGeom.Xform.Define(stage, f"/{base}/Arm/Link{name}")
            link.AddOrientOp(precision).Set(quat)
            link.AddScaleOp().Set(Gf.Vec3f(1, 2, 0.5))
        loose = UsdGeom.Xform.Define(stage, f"/{base}/Arm/Loose")
        loose.SetResetXformStack(True)
        loose.AddTransformOp().Set(Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(5, 6, 7)))
    return stage


def test_default_time_transforms_follow_each_op_and_resolve_only_sample_read_chains_in_python(monkeypatch):
    """Every prim's world transform is the op-by-op product, and only prims with an op read at a time sample up
    their chain are resolved op by op in Python: the still robot's come from XformCache (100k instances each
    resolved in Python took a quarter of their stage's load)."""
    stage = _robot_stage()
    resolved = []
    original = DefaultTimeXforms._local
    monkeypatch.setattr(DefaultTimeXforms, "_local", lambda self, prim: resolved.append(str(prim.GetPath())) or
                        original(self, prim))
    xforms = DefaultTimeXforms()
    for prim in stage.Traverse():
        np.testing.assert_allclose(np.array(xforms.GetLocalToWorldTransform(prim)), _op_by_op(prim), atol=1e-6,
                                   err_msg=str(prim.GetPath()))
    assert np.array(xforms.GetLocalToWorldTransform(stage.GetPrimAtPath("/Moving")))[3, 2] == 3.0  # its sample
    assert np.array(xforms.GetLocalToWorldTransform(stage.GetPrimAtPath("/Still")))[3, 2] == 3.0  # its default
    assert resolved and all(path.startswith("/Moving") for path in resolved), resolved
    assert len(resolved) == len(set(resolved))  # each once


def test_a_stage_without_time_samples_asks_no_op_of_any_prim(monkeypatch):
    """A still fleet (no layer holds a time sample): every transform comes from XformCache, with no per-op question
    for any prim; one sample anywhere and the ops are asked again, prim by prim."""
    stage = _robot_stage()
    stage.GetPrimAtPath("/Still").GetAttribute("xformOp:translate").ClearAtTime(2.0)  # its default stays
    stage.RemovePrim("/Moving")
    asked = []
    monkeypatch.setattr(wrt.usd_xforms, "read_time", lambda attr, time: asked.append(attr) or time)
    xforms, cache = DefaultTimeXforms(stage), UsdGeom.XformCache(DEFAULT)
    for prim in stage.Traverse():
        np.testing.assert_allclose(np.array(xforms.GetLocalToWorldTransform(prim)),
                                   np.array(cache.GetLocalToWorldTransform(prim)), atol=0, err_msg=str(prim.GetPath()))
    assert asked == []
    stage.GetPrimAtPath("/Still/Arm/Loose").GetAttribute("xformOp:transform").Set(Gf.Matrix4d(2.0), 5.0)
    DefaultTimeXforms(stage).GetLocalToWorldTransform(stage.GetPrimAtPath("/Still/Arm/LinkHalf"))
    assert asked


@pytest.mark.parametrize("base", ["Still", "Moving"])
def test_relative_transform_to_an_ancestor_matches_xform_cache(base):
    stage = _robot_stage()
    xforms, cache = DefaultTimeXforms(), UsdGeom.XformCache(1.0)  # at time 1 the ops below the bases read as wrt
    ancestor = stage.GetPrimAtPath(f"/{base}")
    for name in ("Arm/LinkHalf", "Arm/Loose"):
        prim = stage.GetPrimAtPath(f"/{base}/{name}")
        m, resets = xforms.ComputeRelativeTransform(prim, ancestor)
        expected, expected_resets = cache.ComputeRelativeTransform(prim, ancestor)
        assert resets == expected_resets
        np.testing.assert_allclose(np.array(m), np.array(expected), atol=1e-6)


def _box_corners(lower, upper, m: np.ndarray) -> np.ndarray:
    """``(8, 3)`` corners of the box ``[lower, upper]`` moved by column-vector ``m``."""
    corners = np.array([[(lower, upper)[i][0], (lower, upper)[j][1], (lower, upper)[k][2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)], np.float64)
    return corners @ m[:3, :3].T + m[:3, 3]


def test_a_reset_transform_inside_a_point_instancer_prototype_places_it_as_usd_bounds_it(tmp_path):
    """A prim that resets the transform stack below a PointInstancer's prototype root: its world transform over the
    prototype root's, as ``BBoxCache.ComputePointInstanceWorldBounds`` (and ``ComputeExtentAtTime``, and UsdImaging's
    instancer adapter) place it. It was placed by its own ops alone in the prototype parent's space, as if that parent
    (here under the moved instancer, and moved itself) sat at the world's origin: off by their transforms."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "pi.usda"))
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.AddTranslateOp().Set(Gf.Vec3d(100, 0, 0))
    pi.AddRotateZOp().Set(30.0)
    UsdGeom.Scope.Define(stage, "/PI/Protos")
    holder = UsdGeom.Xform.Define(stage, "/PI/Protos/Holder")  # a moved prim between the instancer and its prototype
    holder.AddTranslateOp().Set(Gf.Vec3d(0, 0, -7))
    proto = UsdGeom.Xform.Define(stage, "/PI/Protos/Holder/P")
    proto.AddTranslateOp().Set(Gf.Vec3d(0, 10, 0))
    proto.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    loose = UsdGeom.Xform.Define(stage, "/PI/Protos/Holder/P/Loose")
    loose.SetResetXformStack(True)
    loose.AddTranslateOp().Set(Gf.Vec3d(0, 0, 50))
    UsdGeom.Cube.Define(stage, "/PI/Protos/Holder/P/Loose/Cube")
    UsdGeom.Cube.Define(stage, "/PI/Protos/Holder/P/Kept")  # no reset: placed the same either way
    pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(1, 0, 0), (0, 3, 0)])
    pi.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), Gf.Quath(0.7071068, 0, 0.7071068, 0)])
    stage.GetRootLayer().Save()

    scene = wrt.load_usd(stage.GetRootLayer().realPath)
    placed = {}  # prim path -> [(8, 3) world corners of each instance's copy]
    for i in range(len(scene.instances)):
        for shape in scene.prototypes[scene.instances.prototype[i]].shapes:
            lower, upper = shape.local_bounds()
            placed.setdefault(shape.path, []).append(
                _box_corners(lower, upper, scene.instances.to_world[i] @ shape.to_world))
    bboxes = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    for name in ("Loose/Cube", "Kept"):
        cube_path = f"/PI/Protos/Holder/P/{name}"
        # The instances' bounds of that prim alone: the other cube made invisible for the question.
        other = "Kept" if name != "Kept" else "Loose"
        UsdGeom.Imageable(stage.GetPrimAtPath(f"/PI/Protos/Holder/P/{other}")).MakeInvisible()
        bboxes.Clear()
        bounds = bboxes.ComputePointInstanceWorldBounds(pi, [0, 1])
        UsdGeom.Imageable(stage.GetPrimAtPath(f"/PI/Protos/Holder/P/{other}")).MakeVisible()
        assert len(placed[cube_path]) == 2
        for got, box in zip(placed[cube_path], bounds):
            # USD's box of an instance is the prototype's bound (aligned in the prototype parent's world frame) moved
            # by the instance: the same centre as the cube's copy, and the copy inside its aligned range.
            center = np.array(box.GetMatrix().Transform(box.GetRange().GetMidpoint()))
            np.testing.assert_allclose(got.mean(axis=0), center, atol=1e-6, err_msg=name)
            aligned = box.ComputeAlignedRange()
            assert np.all(got >= np.array(aligned.GetMin()) - 1e-6) and np.all(got <= np.array(aligned.GetMax()) + 1e-6)


# Malformed xformOpOrder on every kind of prim wrt places: cubes' parents, a camera, a light, a native instance and a
# prim of its prototype, a PointInstancer and its prototype's root. Each prim's order as USD reads it is in
# MALFORMED_ORDERS: its ops with the bad ones left out.
MALFORMED = """#usda 1.0
(
    defaultPrim = "P"
)

def Xform "P"
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]

    def Xform "Typo"
    {
        double3 xformOp:translate = (1, 2, 3)
        float3 xformOp:scale = (2, 2, 2)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:translat", "xformOp:scale"]
        def Cube "C" {}
    }

    def Xform "InvertMissing"
    {
        double3 xformOp:translate = (4, 0, 0)
        float xformOp:rotateZ = 30
        uniform token[] xformOpOrder = ["xformOp:translate", "!invert!xformOp:scale:gone", "xformOp:rotateZ"]
        def Cube "C" {}
    }

    def Xform "StringTranslate"
    {
        string xformOp:translate = "up"
        double3 xformOp:translate:b = (0, 6, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:translate:b"]
        def Cube "C" {}
    }

    def Xform "NotAnOp"
    {
        double3 offset = (1, 1, 1)
        double3 xformOp:translate = (0, -6, 0)
        uniform token[] xformOpOrder = ["offset", "xformOp:translate"]
        def Cube "C" {}
    }

    def Xform "LateReset"
    {
        double3 xformOp:translate = (9, 9, 9)
        double3 xformOp:translate:after = (0, 0, -4)
        uniform token[] xformOpOrder = ["xformOp:translate", "!resetXformStack!", "xformOp:translate:after"]
        def Cube "C" {}
    }

    def Camera "Cam"
    {
        double3 xformOp:translate = (0, 1, 20)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY:missing"]
    }

    def SphereLight "Lamp"
    {
        double3 xformOp:translate = (3, 3, 3)
        uniform token[] xformOpOrder = ["xformOp:rotateXYZ", "xformOp:translate"]
    }

    def Xform "Inst" (
        instanceable = true
        references = </Proto>
    )
    {
        double3 xformOp:translate = (-5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:orient"]
    }

    def PointInstancer "PI"
    {
        double3 xformOp:translate = (0, -9, 0)
        uniform token[] xformOpOrder = ["xformOp:scale", "xformOp:translate"]
        int[] protoIndices = [0, 0]
        point3f[] positions = [(0, 0, 0), (3, 0, 0)]
        rel prototypes = </P/PI/Protos/Ball>
        def Scope "Protos"
        {
            def Xform "Ball"
            {
                double3 xformOp:translate = (0, 0, 1)
                uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:transform"]
                def Cube "C" {}
            }
        }
    }
}

class Xform "Proto"
{
    def Cube "C"
    {
        double3 xformOp:translate = (0, 2, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale:x"]
    }
}
"""
MALFORMED_ORDERS = {  # prim -> (its order with the bad ops left out, the warning that names it, the op named)
    "/P/Typo": (["xformOp:translate", "xformOp:scale"], "do not exist", "xformOp:translat"),
    "/P/InvertMissing": (["xformOp:translate", "xformOp:rotateZ"], "do not exist", "!invert!xformOp:scale:gone"),
    "/P/StringTranslate": (["xformOp:translate:b"], "no transform op", "xformOp:translate"),
    "/P/NotAnOp": (["xformOp:translate"], "no transform op", "offset"),
    "/P/LateReset": (["!resetXformStack!", "xformOp:translate:after"], "!resetXformStack!", "xformOp:translate"),
    "/P/Cam": (["xformOp:translate"], "do not exist", "xformOp:rotateY:missing"),
    "/P/Lamp": (["xformOp:translate"], "do not exist", "xformOp:rotateXYZ"),
    "/P/Inst": (["xformOp:translate"], "do not exist", "xformOp:orient"),
    "/P/PI": (["xformOp:translate"], "do not exist", "xformOp:scale"),
    "/P/PI/Protos/Ball": (["xformOp:translate"], "do not exist", "xformOp:transform"),
    "/Proto/C": (["xformOp:translate"], "do not exist", "xformOp:scale:x"),
}
ANIMATED = """
def Xform "Moving"
{
    double3 xformOp:translate.timeSamples = {1: (0, 0, 5), 2: (0, 0, 6)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def _sorted_transforms(ms) -> np.ndarray:
    """``(N, 16)`` the ``(4, 4)`` matrices ``ms`` flattened, rounded and sorted: placed copies compared as a set."""
    flat = np.round(np.array([np.asarray(m, np.float64).reshape(16) for m in ms]), 9)
    return flat[np.lexsort(flat.T[::-1])]


@pytest.mark.parametrize("time, usd_time, animated", [(None, DEFAULT, False), (None, 1.0, True), (1.0, 1.0, False)],
                         ids=["default-still", "default-animated", "time-1"])
def test_a_malformed_xform_op_order_places_prims_as_usd_leaving_out_the_bad_ops(tmp_path, time, usd_time, animated):
    """Ops named in xformOpOrder that do not exist (a typo, an !invert! of a missing op), that are no transform op
    (a string translate, an attribute outside xformOp:) and ops before a !resetXformStack! that is not first: every
    prim wrt places (gprims, a camera, a light, native and PointInstancer instances, their prototypes' prims) is
    where USD's XformCache puts it on the stage with those ops taken out of its order, and each prim and bad op is
    named in a warning. wrt placed a missing op as the identity without a word (as XformCache does; USD's own
    GetOrderedXformOps warns), and stopped the load with "cannot read this prim" naming the wrong prim for a string
    translate or a name outside xformOp:, which USD posts an error for and reads as the identity. At the default time
    with a time sample on the stage the ops are read op by op (wrt's first-sample rule), which covers that path; the
    oracle reads the stage at time 1, where every op reads as wrt reads it at the default time."""
    path = tmp_path / "malformed.usda"
    path.write_text(MALFORMED + (ANIMATED if animated else ""))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path, time=time)

    fixed = Usd.Stage.Open(Sdf.Layer.OpenAsAnonymous(str(path)))  # a copy: the file's layer stays as authored
    for prim_path, (order, _, _) in MALFORMED_ORDERS.items():
        fixed.GetPrimAtPath(prim_path).GetAttribute("xformOpOrder").Set(order)
    usd_time = Usd.TimeCode(usd_time)
    cubes = drawn_placements(fixed, lambda p: p.IsA(UsdGeom.Cube), usd_time)
    assert len(cubes) == len(placed_shapes(scene)) == 8
    np.testing.assert_allclose(_sorted_transforms([m for m, _ in placed_shapes(scene)]),
                               _sorted_transforms([m.T for _, _, m, _ in cubes]), atol=1e-6)
    cache = UsdGeom.XformCache(usd_time)
    camera = np.array(cache.GetLocalToWorldTransform(fixed.GetPrimAtPath("/P/Cam"))).T
    np.testing.assert_allclose(scene.cameras["/P/Cam"].to_world, camera, atol=1e-9)
    lamp = np.array(cache.GetLocalToWorldTransform(fixed.GetPrimAtPath("/P/Lamp")))[3, :3]
    np.testing.assert_allclose([light.position for light in scene.lights if light.path == "/P/Lamp"], [lamp])
    # The oracle is USD's reading: on the stage as authored, XformCache leaves each missing op out likewise (those
    # whose name is no op type's too, after posting an error for it).
    authored = Usd.Stage.Open(str(path))
    for prim_path in ("/P/InvertMissing/C", "/P/Cam", "/P/Lamp", "/P/LateReset/C"):
        np.testing.assert_allclose(np.array(UsdGeom.XformCache(usd_time).GetLocalToWorldTransform(
            authored.GetPrimAtPath(prim_path))), np.array(cache.GetLocalToWorldTransform(
                fixed.GetPrimAtPath(prim_path))), atol=1e-9, err_msg=prim_path)

    messages = [str(w.message) for w in caught if "xformOpOrder" in str(w.message)]
    for prim_path, (_, reason, op) in MALFORMED_ORDERS.items():
        shown = "/P/Inst/C" if prim_path == "/Proto/C" else prim_path  # named at its instance proxy
        named = [m for m in messages if reason in m]
        assert len(named) == 1, messages  # one warning per kind of problem
        assert named[0].startswith(f"{path}: "), named[0]
        assert f"({op}: 1" in named[0] or f", {op}: 1" in named[0], named[0]
        assert shown in named[0] or "..." in named[0], named[0]
    assert "8 prim(s)" in next(m for m in messages if "do not exist" in m)


def _spline(times_values) -> "pxr.Ts.Spline":
    """A double spline through ``(time, value)`` knots, curved between them."""
    from pxr import Ts

    spline = Ts.Spline("double")
    for time, value in times_values:
        knot = Ts.Knot("double")
        knot.SetTime(time)
        knot.SetValue(value)
        knot.SetNextInterpolation(Ts.InterpCurve)
        spline.SetKnot(knot)
    return spline


@pytest.mark.skipif(not hasattr(Usd.Attribute, "SetSpline"), reason="usd-core without attribute splines (before 25.05)")
@pytest.mark.parametrize("with_sample", [False, True])
def test_spline_animated_ops_at_the_default_time_read_their_first_knot(tmp_path, with_sample):
    """An op animated by a spline (USD 25.05's scalar attribute splines: rotateY, translateX) and no default is read
    at its first knot with ``time=None``, as an op with only time samples is read at its first sample: USD's answer at
    ``EarliestTime``. A stage without a single time sample took every op at its default, which a spline has not got
    (the identity), while the same op on a stage with a sample elsewhere read its first knot."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "spline.usda"))
    arm = UsdGeom.Xform.Define(stage, "/Arm")
    arm.AddRotateYOp(UsdGeom.XformOp.PrecisionDouble).GetAttr().SetSpline(_spline([(1.0, 30.0), (5.0, 90.0)]))
    arm.AddTranslateXOp(UsdGeom.XformOp.PrecisionDouble).GetAttr().SetSpline(_spline([(2.0, 1.5), (8.0, 4.0)]))
    mesh = UsdGeom.Mesh.Define(stage, "/Arm/Quad")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if with_sample:  # a time sample elsewhere: the ops were asked one by one, and read their first knot
        UsdGeom.Xform.Define(stage, "/Other").AddTranslateOp().Set(Gf.Vec3d(0, 5, 0), 3.0)
    stage.Save()
    expected = np.array(UsdGeom.XformCache(Usd.TimeCode.EarliestTime()).GetLocalToWorldTransform(mesh.GetPrim()))
    assert not np.allclose(expected, np.eye(4))  # the knots place it; the default would not
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(str(tmp_path / "spline.usda"))
    points = np.array(mesh.GetPointsAttr().Get(), np.float64) @ expected[:3, :3] + expected[3, :3]
    np.testing.assert_allclose(scene.meshes[0].points, points, atol=1e-6)


@pytest.mark.skipif(not hasattr(Usd.Attribute, "SetSpline"), reason="usd-core without attribute splines (before 25.05)")
@pytest.mark.parametrize("extrapolation", ["linear", "sloped", "loopRepeat"])
def test_splines_extrapolated_before_their_first_knot_are_read_at_it_with_the_default_time(tmp_path, extrapolation):
    """With ``time=None`` a spline is read at its first knot, whatever it does before it: ``EarliestTime`` (-1.8e308)
    took a linear or sloped extrapolation out to -inf, and the transform, the light, the camera and the sphere were
    skipped as not finite; a loop repeated the last knot's value there. The knot's time is the stage's, through the
    reference's layer offset. Oracle: USD's values at that knot's time (``XformCache``, ``attr.Get``)."""
    from pxr import Ts, UsdLux

    def spline(kind, knots):
        made = Ts.Spline(kind)
        for time, value in knots:
            made.SetKnot(Ts.Knot(kind, time=time, value=value, nextInterp=Ts.InterpLinear))
        before = Ts.Extrapolation({"linear": Ts.ExtrapLinear, "sloped": Ts.ExtrapSloped,
                                   "loopRepeat": Ts.ExtrapLoopRepeat}[extrapolation])
        before.slope = 4.0
        made.SetPreExtrapolation(before)
        return made

    inner = Usd.Stage.CreateNew(str(tmp_path / "rig.usda"))
    rig = UsdGeom.Xform.Define(inner, "/Rig")
    arm = UsdGeom.Xform.Define(inner, "/Rig/Arm")
    arm.AddRotateYOp().GetAttr().SetSpline(spline("float", [(1.0, 30.0), (5.0, 90.0)]))
    mesh = UsdGeom.Mesh.Define(inner, "/Rig/Arm/Quad")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdLux.SphereLight.Define(inner, "/Rig/Bulb").CreateIntensityAttr().SetSpline(spline("float", [(2.0, 3.0),
                                                                                                   (6.0, 7.0)]))
    UsdGeom.Camera.Define(inner, "/Rig/Cam").CreateFocalLengthAttr().SetSpline(spline("float", [(1.0, 30.0),
                                                                                                (5.0, 70.0)]))
    UsdGeom.Sphere.Define(inner, "/Rig/Ball").CreateRadiusAttr().SetSpline(spline("double", [(3.0, 0.5),
                                                                                             (5.0, 2.0)]))
    inner.SetDefaultPrim(rig.GetPrim())
    inner.Save()
    stage = Usd.Stage.CreateNew(str(tmp_path / "shot.usda"))
    stage.DefinePrim("/Shot").GetReferences().AddReference("rig.usda", Sdf.LayerOffset(10.0, 2.0))
    stage.Save()

    def at_first_knot(attr):
        first = Usd.TimeCode(min(attr.GetSpline().GetKnots().keys()))  # in the stage's time
        assert first.GetValue() > 10.0  # moved by the layer offset
        return attr.Get(first), first

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(str(tmp_path / "shot.usda"))
    quad, bulb = stage.GetPrimAtPath("/Shot/Arm/Quad"), stage.GetPrimAtPath("/Shot/Bulb")
    _, first = at_first_knot(stage.GetPrimAtPath("/Shot/Arm").GetAttribute("xformOp:rotateY"))
    to_world = np.array(UsdGeom.XformCache(first).GetLocalToWorldTransform(quad))
    points = np.array(UsdGeom.Mesh(quad).GetPointsAttr().Get(), np.float64) @ to_world[:3, :3] + to_world[3, :3]
    assert [m.path for m in scene.meshes] == ["/Shot/Arm/Quad"]
    np.testing.assert_allclose(scene.meshes[0].points, points, atol=1e-6)
    intensity, _ = at_first_knot(UsdLux.SphereLight(bulb).GetIntensityAttr())
    assert [light.path for light in scene.lights] == ["/Shot/Bulb"]
    np.testing.assert_allclose(scene.lights[0].color, [intensity] * 3)
    focal, _ = at_first_knot(stage.GetPrimAtPath("/Shot/Cam").GetAttribute("focalLength"))
    assert scene.cameras["/Shot/Cam"].focal_length == pytest.approx(focal)
    radius, _ = at_first_knot(stage.GetPrimAtPath("/Shot/Ball").GetAttribute("radius"))
    assert len(scene.shapes) == 1
    np.testing.assert_allclose(np.linalg.norm(scene.shapes[0].to_world[:3, 0]) * scene.shapes[0].params[0], radius,
                               rtol=1e-6)


VALUELESS = """#usda 1.0
def Xform "Empty"
{
    double3 xformOp:translate
    float3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
    def Cube "C" {}
}
def Xform "Paired"
{
    double3 xformOp:translate
    double3 xformOp:translate:b = (0, 3, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "!invert!xformOp:translate", "xformOp:translate:b"]
    def Cube "C" {}
}
def Xform "Unused"
{
    double3 xformOp:translate
    double3 xformOp:translate:b = (0, 0, 4)
    uniform token[] xformOpOrder = ["xformOp:translate:b"]
    def Cube "C" {}
}
def Xform "Moving"
{
    double3 xformOp:translate.timeSamples = {1: (0, 0, 5), 2: (0, 0, 6)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "C" {}
}
"""


@pytest.mark.parametrize("time", [None, 1.0], ids=["default", "time-1"])
def test_an_xform_op_declared_with_no_value_is_the_identity_with_a_warning(tmp_path, time):
    """An op in xformOpOrder declared with neither a default nor time samples is the identity, as USD's XformCache
    reads it (the oracle), and is named in a warning with its file and prim; it was the identity without a word. An
    op USD leaves out anyway (next to its own inverse, or not in xformOpOrder) is not named."""
    path = tmp_path / "valueless.usda"
    path.write_text(VALUELESS)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path, time=time)
    stage = Usd.Stage.Open(str(path))
    cubes = drawn_placements(stage, lambda p: p.IsA(UsdGeom.Cube), Usd.TimeCode(1.0))
    assert len(cubes) == len(placed_shapes(scene)) == 4
    np.testing.assert_allclose(_sorted_transforms([m for m, _ in placed_shapes(scene)]),
                               _sorted_transforms([m.T for _, _, m, _ in cubes]), atol=1e-9)
    named = [str(w.message) for w in caught if "no value" in str(w.message)]
    assert len(named) == 1 and named[0].startswith(f"{path}: "), named
    assert "1 prim(s) (xformOp:translate: 1): /Empty" in named[0], named[0]


SINGULAR_INVERSES = """#usda 1.0
def Xform "ZeroScale"
{
    double3 xformOp:translate = (1, 2, 3)
    float3 xformOp:scale = (1, 0, 1)
    uniform token[] xformOpOrder = ["xformOp:translate", "!invert!xformOp:scale"]
    def Cube "C" {}
}
def Xform "ZeroScaleX"
{
    double xformOp:scaleX = 0
    double xformOp:rotateZ = 30
    uniform token[] xformOpOrder = ["!invert!xformOp:scaleX", "xformOp:rotateZ"]
    def Cube "C" {}
}
def Xform "SingularMatrix"
{
    matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 0, 0, 0), (0, 0, 1, 0), (4, 0, 0, 1))
    double3 xformOp:translate = (0, 5, 0)
    uniform token[] xformOpOrder = ["!invert!xformOp:transform", "xformOp:translate"]
    def Cube "C" {}
}
def Xform "Invertible"
{
    float3 xformOp:scale = (2, 4, 0.5)
    uniform token[] xformOpOrder = ["!invert!xformOp:scale"]
    def Cube "C" {}
}
"""
SINGULAR_LEFT_OUT = {  # prim -> its order without the op that has no inverse
    "/ZeroScale": ["xformOp:translate"],
    "/SingularMatrix": ["xformOp:translate"],
}


@pytest.mark.parametrize("time", [None, 1.0])
def test_an_inverted_op_without_an_inverse_is_left_out_with_a_warning(tmp_path, time):
    """An !invert! of a scale with a zero component has no inverse: USD's XformCache gives inf and NaN, and wrt
    stopped the whole load ("world transform is not finite"), while an !invert! of a singular xformOp:transform (for
    which USD posts an error and takes the identity) was left out with a warning calling it no transform op. Both
    are left out (the identity), the rest of the stage drawn, with one warning naming each prim and op; every cube is
    where XformCache puts it with that op taken out of the order; an invertible inverted scale, and an inverted
    scaleX of 0 (which USD reads as a finite, flat matrix), stay as USD reads them."""
    path = tmp_path / "singular.usda"
    path.write_text(SINGULAR_INVERSES)
    authored = Usd.Stage.Open(str(path))
    usd_time = Usd.TimeCode.Default() if time is None else Usd.TimeCode(time)
    nan = np.array(UsdGeom.XformCache(usd_time).GetLocalToWorldTransform(authored.GetPrimAtPath("/ZeroScale/C")))
    assert not np.isfinite(nan).all()  # the case: USD's own cache has no finite transform there
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path, time=time)

    fixed = Usd.Stage.Open(Sdf.Layer.OpenAsAnonymous(str(path)))
    for prim_path, order in SINGULAR_LEFT_OUT.items():
        fixed.GetPrimAtPath(prim_path).GetAttribute("xformOpOrder").Set(order)
    cache = UsdGeom.XformCache(usd_time)
    expected = [np.array(cache.GetLocalToWorldTransform(p)).T for p in fixed.Traverse() if p.IsA(UsdGeom.Cube)]
    assert len(expected) == 4
    np.testing.assert_allclose(_sorted_transforms([m for m, _ in placed_shapes(scene)]),
                               _sorted_transforms(expected), atol=1e-3)  # (the flat one drawn a hair thick)
    (message,) = [str(w.message) for w in caught if "have no inverse" in str(w.message)]
    assert message.startswith(f"{path}: ") and "2 prim(s)" in message, message
    for prim_path, op in (("/ZeroScale", "!invert!xformOp:scale"), ("/SingularMatrix", "!invert!xformOp:transform")):
        assert prim_path in message and f"{op}: 1" in message, message
    assert "no transform op" not in " ".join(str(w.message) for w in caught)


WEIGHTED = """#usda 1.0
def Xform "H"
{
    matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (4, 0, 0, 2))
    uniform token[] xformOpOrder = ["xformOp:transform"]
    def Mesh "M"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
    def Xform "Inst" (instanceable = true
        references = </Lib>)
    {
        matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 3, 0, 0.5))
        uniform token[] xformOpOrder = ["xformOp:transform"]
    }
    def PointInstancer "PI"
    {
        rel prototypes = </H/PI/P/R>
        int[] protoIndices = [0, 0]
        point3f[] positions = [(0, 8, 0), (5, 8, 0)]
        def Scope "P"
        {
            def Xform "R" (references = </Lib>)
            {
                matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (1, 1, 1, 4))
                uniform token[] xformOpOrder = ["xformOp:transform"]
            }
        }
    }
    def Sphere "S"
    {
        double3 xformOp:translate = (0, 12, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def SphereLight "L"
    {
        double3 xformOp:translate = (0, 0, 6)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
class Xform "Lib"
{
    def Mesh "T"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    }
}
"""


def test_a_transform_whose_last_column_is_a_weight_places_prims_as_usd_transforms_points(tmp_path):
    """A last column (0, 0, 0, w) projects nothing: it is the matrix over w in homogeneous coordinates, as
    ``Gf.Matrix4d.Transform`` (and Hydra's divide) reads it, so ``m * 2`` draws as ``m``. wrt dropped the column as
    for a projective transform, with that warning: meshes, instances, PointInstancer instances, gprims and lights
    were drawn w times as large and as far from the origin (under w = 2: a triangle at x = 4..5, USD's at 2..2.5)."""
    path = tmp_path / "weighted.usda"
    path.write_text(WEIGHTED)
    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.XformCache()
    corners = [Gf.Vec3d(0, 0, 0), Gf.Vec3d(1, 0, 0), Gf.Vec3d(0, 1, 0)]

    def moved(m: Gf.Matrix4d) -> list:  # the oracle: USD's point transform, its divide by w included
        return [list(m.Transform(c)) for c in corners]

    expected = [moved(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(p))) for p in ("/H/M", "/H/Inst/T")]
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/H/PI"))
    root = stage.GetPrimAtPath("/H/PI/P/R")
    inside, _ = cache.ComputeRelativeTransform(stage.GetPrimAtPath("/H/PI/P/R/T"), root)
    for m in instancer.ComputeInstanceTransformsAtTime(DEFAULT, DEFAULT):
        expected.append(moved(inside * m * cache.GetLocalToWorldTransform(instancer.GetPrim())))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "projective" warning: nothing is dropped
        scene = wrt.load_usd(path)
    points, indices = scene.triangles()
    assert len(indices) == 4  # the mesh, the native instance's and the two PointInstancer instances'
    np.testing.assert_allclose(sorted(points[indices].tolist()), sorted(expected), atol=1e-6)
    (sphere,) = scene.shapes
    sphere_world = cache.GetLocalToWorldTransform(stage.GetPrimAtPath("/H/S"))
    np.testing.assert_allclose(sphere.to_world[:3, 3], sphere_world.Transform(Gf.Vec3d(0, 0, 0)))
    radius = (sphere_world.Transform(Gf.Vec3d(1, 0, 0)) - sphere_world.Transform(Gf.Vec3d(0, 0, 0))).GetLength()
    np.testing.assert_allclose(np.linalg.norm(sphere.to_world[:3, :3], axis=0), radius)  # a unit sphere, scaled
    (light,) = scene.lights
    light_world = cache.GetLocalToWorldTransform(stage.GetPrimAtPath("/H/L"))
    np.testing.assert_allclose(light.position, light_world.Transform(Gf.Vec3d(0, 0, 0)))


CLIP_MANIFEST = """#usda 1.0
over "Rig"
{
    over "Arm"
    {
        double3 xformOp:translate
    }
}
"""


@pytest.mark.parametrize("manifest", [False, True])
@pytest.mark.parametrize("where", ["clips on the animated prim's parent", "clips on a referenced asset's root"])
def test_ops_given_only_by_value_clips_are_read_at_their_first_sample_with_the_default_time(tmp_path, manifest, where):
    """With ``time=None`` an op whose only values are the time samples of value clips is read at its first sample
    (USD's ``EarliestTime``), as an op with samples of its own is, fresh and through a kept stage alike. With a clip
    manifest (``manifestAssetPath``), USD opens no clip before a value is read, so no layer the stage used held a time
    sample: the 'still stage' shortcut took every op at its default, the identity, and the arm sat at the origin; a
    stage whose clips USD had opened for a generated manifest read (0, 3, 0)."""
    from wrt.usd_frames import StageFrames

    (tmp_path / "clip.usda").write_text('#usda 1.0\nover "Rig"\n{\n    over "Arm"\n    {\n        double3 '
                                        'xformOp:translate.timeSamples = { 0: (0, 3, 0), 10: (0, 5, 0) }\n    }\n}\n')
    (tmp_path / "manifest.usda").write_text(CLIP_MANIFEST)
    clips = ('    clips = { dictionary default = { asset[] assetPaths = [@./clip.usda@]\n'
             '        double2[] active = [(0, 0)]\n        double2[] times = [(0, 0), (10, 10)]\n'
             + ('        asset manifestAssetPath = @./manifest.usda@\n' if manifest else '')
             + '        string primPath = "/Rig" } }\n')
    rig = ('def Xform "Rig" (\n' + clips + ')\n{\n    def Xform "Arm"\n    {\n        double3 xformOp:translate\n'
           '        uniform token[] xformOpOrder = ["xformOp:translate"]\n        def Mesh "Tri"\n        {\n'
           '            int[] faceVertexCounts = [3]\n            int[] faceVertexIndices = [0, 1, 2]\n'
           '            point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0)]\n        }\n    }\n}\n')
    if where == "clips on the animated prim's parent":
        (tmp_path / "stage.usda").write_text("#usda 1.0\n" + rig)
        mesh_path = "/Rig/Arm/Tri"
    else:  # the asset's root authors the clips, which reach the stage through the reference
        (tmp_path / "asset.usda").write_text('#usda 1.0\n(\n    defaultPrim = "Rig"\n)\n' + rig)
        (tmp_path / "stage.usda").write_text('#usda 1.0\ndef Xform "Shot"\n{\n    def "Rig" (\n        references = '
                                             '@./asset.usda@\n    )\n    {\n    }\n}\n')
        mesh_path = "/Shot/Rig/Arm/Tri"
    path = str(tmp_path / "stage.usda")
    stage = Usd.Stage.Open(path)
    expected = np.array(UsdGeom.XformCache(Usd.TimeCode.EarliestTime()).GetLocalToWorldTransform(
        stage.GetPrimAtPath(mesh_path)))
    assert expected[3, 1] == 3.0  # the clip's first sample places it
    points = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0)], np.float64) @ expected[:3, :3] + expected[3, :3]
    del stage
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scenes = [wrt.load_usd(path), StageFrames(path).load(None)]
    for scene in scenes:
        drawn, indices = scene.triangles()
        np.testing.assert_allclose(drawn[indices[0]], points, atol=1e-6)


def _clip_set(name: str, clip: str, manifest: str, prim_path: str) -> str:
    return (f'        dictionary {name} = {{ asset[] assetPaths = [@./{clip}@]\n        double2[] active = [(0, 0)]\n'
            f'        double2[] times = [(0, 0), (10, 10)]\n        asset manifestAssetPath = @./{manifest}@\n'
            f'        string primPath = "{prim_path}" }}\n')


def _over(path: str, body: str) -> str:
    """A usda layer of ``over`` prims down ``path`` (/A/B), ``body`` in the last."""
    names = path.strip("/").split("/")
    return "#usda 1.0\n" + "".join(f'over "{n}"\n{{\n' for n in names) + body + "}\n" * len(names)


def _xform(name: str, ops: list, inside: str = "", meta: str = "") -> str:
    declared = "".join(f"    {kind} xformOp:{op}\n" for kind, op in ops)
    order = ", ".join(f'"xformOp:{op}"' for _, op in ops)
    return (f'def Xform "{name}"{meta}\n{{\n{declared}    uniform token[] xformOpOrder = [{order}]\n'
            f'{inside}}}\n')


@pytest.mark.parametrize("layout", ["prototype", "partial manifest", "nested", "clip sets"])
def test_default_time_transforms_under_value_clips_match_usd_earliest_time(tmp_path, layout):
    """Ops given only by value clips with a manifest (289ce705) in the layouts clips take: clips inside a native
    instance's prototype (read through the proxies and the prototype alike; clips on the instance's asset root reach
    no prototype prim, and USD reads none), a manifest listing one of two animated ops (the other reads its
    default), clips on a prim and on its child, two named sets in ``clipSets``. Every op has samples only, so
    USD's ``XformCache(EarliestTime)`` is the oracle for wrt's default time."""
    def clips(*sets, order=None):
        listed = f'\n    clipSets = [{", ".join(chr(34) + s[0] + chr(34) for s in order)}]' if order else ""
        return " (\n    clips = {\n" + "".join(_clip_set(*s) for s in sets) + "    }" + listed + "\n)"

    rotate = ("float", "rotateX")
    move = _over("/Rig/Arm", "    double3 xformOp:translate.timeSamples = { 0: (0, 3, 0), 10: (0, 5, 0) }\n"
                 "    float xformOp:rotateX.timeSamples = { 0: 90, 10: 0 }\n")
    (tmp_path / "clip.usda").write_text(move)
    (tmp_path / "manifest.usda").write_text(_over("/Rig/Arm", "    double3 xformOp:translate\n"))
    default = ("default", "clip.usda", "manifest.usda", "/Rig")
    arm = [("double3", "translate")]  # no valueless op: that alone had the ops read one by one
    if layout == "prototype":
        (tmp_path / "asset.usda").write_text('#usda 1.0\n(\n    defaultPrim = "Top"\n)\n'
                                             + _xform("Top", [], _xform("Rig", [], _xform("Arm", arm), clips(default))))
        stage_text = "".join(f'def Xform "{n}" (\n    instanceable = true\n    references = @./asset.usda@\n)\n{{\n}}\n'
                             for n in ("A", "B"))
    elif layout == "partial manifest":
        # rotateX's default is USD's value: the manifest lists no rotateX, so the clip's samples of it are none
        stage_text = _xform("Rig", [], _xform("Arm", [*arm, rotate]), clips(default)).replace(
            "float xformOp:rotateX\n", "float xformOp:rotateX = 30\n")
    elif layout == "nested":
        (tmp_path / "hand.usda").write_text(_over("/Hand", "    double3 xformOp:translate.timeSamples = "
                                                  "{ 0: (7, 0, 0), 10: (8, 0, 0) }\n"))
        (tmp_path / "hand_manifest.usda").write_text(_over("/Hand", "    double3 xformOp:translate\n"))
        hand = _xform("Hand", [("double3", "translate")], meta=clips(("default", "hand.usda", "hand_manifest.usda",
                                                                      "/Hand")))
        stage_text = _xform("Rig", [], _xform("Arm", arm, hand), clips(default))
    else:
        (tmp_path / "scale.usda").write_text(_over("/Rig/Arm", "    double3 xformOp:scale.timeSamples = "
                                                   "{ 0: (2, 2, 2), 10: (1, 1, 1) }\n"))
        (tmp_path / "scale_manifest.usda").write_text(_over("/Rig/Arm", "    double3 xformOp:scale\n"))
        second = ("second", "scale.usda", "scale_manifest.usda", "/Rig")
        stage_text = _xform("Rig", [], _xform("Arm", [*arm, ("double3", "scale")]),
                            clips(default, second, order=(second, default)))
    (tmp_path / "stage.usda").write_text("#usda 1.0\n" + stage_text)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    prims = [p for top in (stage.GetPseudoRoot(), *stage.GetPrototypes())
             for p in Usd.PrimRange(top, Usd.TraverseInstanceProxies()) if p.IsA(UsdGeom.Xformable)]
    xforms = DefaultTimeXforms(stage)
    drawn = [np.array(xforms.GetLocalToWorldTransform(prim)) for prim in prims]  # before USD opens a clip to read
    cache, moved = UsdGeom.XformCache(Usd.TimeCode.EarliestTime()), 0
    for prim, got in zip(prims, drawn):
        expected = np.array(cache.GetLocalToWorldTransform(prim))
        moved += not np.allclose(expected, np.eye(4))
        np.testing.assert_allclose(got, expected, atol=1e-9, err_msg=str(prim.GetPath()))
    assert moved, [str(p.GetPath()) for p in prims]  # the clips do move the arm (a layout USD reads)


def test_still_prims_beside_value_clips_ask_no_op(tmp_path, monkeypatch):
    """Clips under /Rig make its ops asked one by one (289ce705), not those of a still prim beside it: the stage-wide
    shortcut of a stage without time samples still holds for every prim that no clip set reaches."""
    (tmp_path / "clip.usda").write_text(_over("/Rig/Arm", "    double3 xformOp:translate.timeSamples = "
                                              "{ 0: (0, 3, 0), 10: (0, 5, 0) }\n"))
    (tmp_path / "manifest.usda").write_text(_over("/Rig/Arm", "    double3 xformOp:translate\n"))
    meta = " (\n    clips = {\n" + _clip_set("default", "clip.usda", "manifest.usda", "/Rig") + "    }\n)"
    move = [("double3", "translate")]
    still = _xform("Still", move, _xform("Arm", move)).replace("translate\n", "translate = (1, 2, 3)\n")
    (tmp_path / "stage.usda").write_text("#usda 1.0\n" + _xform("Rig", [], _xform("Arm", move), meta) + still)
    stage = Usd.Stage.Open(str(tmp_path / "stage.usda"))
    asked = []
    original = wrt.usd_xforms.read_time
    monkeypatch.setattr(wrt.usd_xforms, "read_time", lambda attr, time: asked.append(str(attr.GetPrimPath())) or
                        original(attr, time))
    xforms = DefaultTimeXforms(stage)
    drawn = {str(p.GetPath()): np.array(xforms.GetLocalToWorldTransform(p)) for p in stage.Traverse()}
    assert asked and set(asked) == {"/Rig/Arm"}, asked
    cache = UsdGeom.XformCache(Usd.TimeCode.EarliestTime())
    for path, got in drawn.items():
        np.testing.assert_allclose(got, np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(path))), atol=0)
    assert drawn["/Still/Arm"][3, :3].tolist() == [2, 4, 6] and drawn["/Rig/Arm"][3, 1] == 3
