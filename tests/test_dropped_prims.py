"""A bad part of a stage is dropped with a warning naming the prim (and attribute), the rest loads as the same stage
without that part: a PointInstancer whose ``protoIndices``, ``positions``, ``orientations`` or ``scales`` are not of
their schema type, one whose prototype holds an instance of itself, and a prim or curve placed where float32 cannot
hold it (a NaN transform, a translation of 1e39) each stopped the whole load with ``SceneError`` (or were read
without a word)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402
from usda_text import write  # noqa: E402

import wrt  # noqa: E402

KEPT = """
def Mesh "Kept" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
"""  # the part of each stage that is good: it loads as it does alone


def load_warned(path):
    """The scene of ``path`` and the messages of the warnings its load gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    return scene, [str(w.message) for w in caught]


def assert_same_as_kept_alone(scene, tmp_path):
    """``scene`` holds what the stage of :data:`KEPT` alone holds: the same triangles, no instances."""
    alone = wrt.load_usd(write(tmp_path, KEPT, "alone.usda"))
    points, indices = scene.triangles()
    expected_points, expected_indices = alone.triangles()
    np.testing.assert_array_equal(points[indices], expected_points[expected_indices])
    assert [m.path for m in scene.meshes] == ["/Kept"]
    assert len(scene.instances) == 0 and not scene.shapes


@pytest.mark.parametrize("authored", ["float[] protoIndices = [0, 0.7, 1.6]", "int64[] protoIndices = [0, 0, 0]"])
def test_proto_indices_not_int_array_draw_no_instances(tmp_path, authored):
    """USD reads ``protoIndices`` as ``int[]`` only: ``ComputeInstanceTransformsAtTime`` computes no instances for a
    ``float[]`` or ``int64[]`` one (Hydra draws none). wrt truncated the floats to 0, 0, 1 without a word."""
    path = write(tmp_path, KEPT + f"""
def PointInstancer "P" {{
    {authored}
    point3f[] positions = [(0, 0, 0), (2, 0, 0), (4, 0, 0)]
    rel prototypes = [</P/Protos/A>, </P/Protos/B>]
    def Scope "Protos" {{
        def Cube "A" {{}}
        def Sphere "B" {{}}
    }}
}}
""")
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/P"))
    assert len(pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default())) == 0  # USD: none
    scene, messages = load_warned(path)
    assert_same_as_kept_alone(scene, tmp_path)
    found = [m for m in messages if "/P" in m and "protoIndices" in m]
    assert found and authored.split()[0] in found[0], messages


RECURSIVE = """
def PointInstancer "P" {
    int[] protoIndices = [0, 0, 1]
    point3f[] positions = [(0, 0, 0), (3, 0, 0), (6, 0, 0)]
    rel prototypes = [</P/Protos/A>, </P/Protos/B>]
    def Scope "Protos" {
        def Xform "A" {
            def Cube "Box" {}
            def PointInstancer "Inner" {
                int[] protoIndices = [0, 1]
                point3f[] positions = [(0, 2, 0), (0, 4, 0)]
                rel prototypes = [</P/Protos/A>, </P/Protos/B>]
            }
        }
        def Sphere "B" {}
    }
}
"""


def test_instances_of_a_prototype_inside_itself_are_skipped(tmp_path):
    """A prototype holding an instancer of itself would hold itself without end: those instances are skipped with a
    warning naming the inner instancer, and the stage loads as the same stage where the inner instancer targets
    only the other prototype (its instances of B drawn); it stopped the whole load with SceneError."""
    path = write(tmp_path, KEPT + RECURSIVE)
    scene, messages = load_warned(path)
    stage = Usd.Stage.Open(path)  # the oracle: the recursive instance hidden through USD's own invisibleIds
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/P/Protos/A/Inner")).GetInvisibleIdsAttr().Set([0])
    stage.GetRootLayer().Export(str(tmp_path / "hidden.usda"))
    expected = wrt.load_usd(tmp_path / "hidden.usda")
    points, indices = scene.triangles()
    expected_points, expected_indices = expected.triangles()
    np.testing.assert_array_equal(points[indices], expected_points[expected_indices])
    assert len(scene.instances) == len(expected.instances) > 0
    np.testing.assert_array_equal(scene.instances.to_world, expected.instances.to_world)
    assert [p.path for p in scene.prototypes] == [p.path for p in expected.prototypes]
    assert any("holds the instancer itself" in m and "/P/Protos/A/Inner" in m for m in messages), messages


@pytest.mark.parametrize("target", ["/World", "/World/PI"])
def test_a_prototype_holding_its_own_instancer_draws_none_of_its_instances(tmp_path, target):
    """A PointInstancer whose prototype is itself or an ancestor of it would place copies of itself without end
    (a cycle USD cannot compute): those instances are skipped with a warning naming the instancer and the prototype,
    and the stage loads as the same stage with them hidden through USD's own invisibleIds. Targeting an ancestor
    drew every instance one level deep (the prototype without the instancer's own instances), arbitrary."""
    path = write(tmp_path, KEPT + f"""
def Xform "World" {{
    def Sphere "S" {{}}
    def PointInstancer "PI" {{
        int[] protoIndices = [0, 0]
        point3f[] positions = [(0, 5, 0), (3, 5, 0)]
        rel prototypes = [<{target}>]
        def Cube "C" {{}}
    }}
}}
""")
    scene, messages = load_warned(path)
    stage = Usd.Stage.Open(path)
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/PI")).GetInvisibleIdsAttr().Set([0, 1])
    stage.GetRootLayer().Export(str(tmp_path / "hidden.usda"))
    expected = wrt.load_usd(tmp_path / "hidden.usda")
    assert len(scene.instances) == len(expected.instances) == 0
    assert [s.path for s in scene.shapes] == [s.path for s in expected.shapes] == ["/World/S"]
    assert any("holds the instancer itself" in m and f"({target}, 2 of 2 instances" in m and m.endswith("/World/PI")
               for m in messages), messages


@pytest.mark.parametrize("op", ["double3 xformOp:translate = (1e39, 0, 0)", "double3 xformOp:translate = (nan, 0, 0)",
                                "float3 xformOp:scale = (inf, 1, 1)", "double3 xformOp:scale = (1e39, 1e39, 1e39)"])
@pytest.mark.parametrize("prim", ["Mesh", "Sphere", "Points", "Curves", "Instance", "Instancer"])
def test_prim_placed_beyond_float32_is_dropped(tmp_path, op, prim):
    """A mesh, gprim, Points, curve, native instance or PointInstancer whose world transform is not finite, or which it
    takes past float32's range, is dropped with a warning naming it, as an instance so placed is; it stopped the
    whole load ('world transform is not finite', 'points are not finite after the world transform')."""
    bodies = {
        "Mesh": 'def Mesh "Bad" { int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 2]\n'
                ' point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]',
        "Sphere": 'def Sphere "Bad" {',
        "Points": 'def Points "Bad" { point3f[] points = [(0, 0, 0)]\n float[] widths = [1]',
        "Curves": 'def BasisCurves "Bad" { uniform token type = "linear"\n int[] curveVertexCounts = [2]\n'
                  ' point3f[] points = [(0, 0, 0), (1, 0, 0)]\n float[] widths = [0.1, 0.1]',
        "Instance": 'def Xform "Bad" (\n instanceable = true\n references = </Asset>\n) {',
        "Instancer": 'def PointInstancer "Bad" { int[] protoIndices = [0]\n point3f[] positions = [(0, 0, 0)]\n'
                     ' rel prototypes = </Asset>',
    }
    path = write(tmp_path, KEPT + 'over "Asset" {\n def Cube "Box" {}\n}\n' + bodies[prim] + f"""
    {op}
    uniform token[] xformOpOrder = ["{op.split()[1]}"]
}}
""")
    scene, messages = load_warned(path)
    assert_same_as_kept_alone(scene, tmp_path)
    assert any("/Bad" in m for m in messages), messages
    assert not any("encountered" in m for m in messages), messages  # numpy's overflow warnings name no prim


def curves(points: str, counts: str) -> str:
    """USDA of linear BasisCurves ``/Curves`` scaled by 10."""
    return f"""
def BasisCurves "Curves" {{
    uniform token type = "linear"
    int[] curveVertexCounts = {counts}
    point3f[] points = {points}
    float[] widths = [0.1] (
        interpolation = "constant"
    )
    float3 xformOp:scale = (10, 10, 10)
    uniform token[] xformOpOrder = ["xformOp:scale"]
}}
"""


def test_a_curve_placed_beyond_float32_is_left_out_the_others_drawn(tmp_path):
    """A curve whose points its transform takes past float32's range (1e38 scaled by 10) is left out with a warning
    naming the prim and curve, as one with a NaN point is, and the prim's other curves are drawn as that curve
    alone draws; it stopped the whole load ('curve points are past float32's range with their widths')."""
    good = "(0, 0, 0), (1, 0, 0), (1, 1, 0)"
    scene, messages = load_warned(write(tmp_path, curves(f"[{good}, (0, 0, 0), (1e38, 0, 0)]", "[3, 2]")))
    alone = wrt.load_usd(write(tmp_path, curves(f"[{good}]", "[3]"), "alone.usda"))
    assert len(scene.instances) == len(alone.instances) > 0
    np.testing.assert_array_equal(scene.instances.to_world, alone.instances.to_world)
    assert any("/Curves" in m and "first curve 1" in m for m in messages), messages


@pytest.mark.parametrize("authored", [
    "float[] positions = [0, 0, 0]", "double3[] positions = [(1, 0, 0)]",
    "point3f[] positions = [(1, 0, 0)]\n    float4[] orientations = [(0, 1, 0, 0)]",
    "point3f[] positions = [(1, 0, 0)]\n    float[] scales = [2]",
    "point3f[] positions = [(1, 0, 0)]\n    double3[] scales = [(2, 3, 4)]",
])
def test_instancer_attributes_not_of_the_schema_type_are_read_as_usd_reads_them(tmp_path, authored):
    """``ComputeInstanceTransformsAtTime`` reads positions, orientations and scales as their schema types only:
    positions of another type give no instances, orientations or scales of another are unauthored. wrt placed the
    instances as USD does, with a warning naming the instancer and the attribute; a float[] one raised SceneError
    ('positions has 3 entries; protoIndices has 1'), a double3[] or float4[] one was read as if of the schema's type."""
    path = write(tmp_path, KEPT + f"""
def PointInstancer "P" {{
    int[] protoIndices = [0]
    {authored}
    rel prototypes = </P/Protos/A>
    def Scope "Protos" {{
        def Cube "A" {{}}
    }}
}}
""")
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/P"))
    expected = [np.array(m).T for m in pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(),
                                                                           Usd.TimeCode.Default())]
    scene, messages = load_warned(path)
    assert len(scene.instances) == len(expected)
    np.testing.assert_allclose(scene.instances.to_world, np.reshape(expected, (-1, 4, 4)))
    name = authored.split("\n")[-1].split()[1]
    assert any("/P" in m and name in m for m in messages), messages
