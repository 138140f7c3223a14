"""Attributes authored with another value type than their schema's (``float radius`` where UsdGeom says ``double``,
``double focalLength`` where it says ``float``, ``point3d[] points``), as files written as text by hand or by
exporters hold them, read as USD's typed readers read them: ``BBoxCache``, ``ComputeExtent``,
``UsdGeom.Camera.GetCamera`` and ``ComputePointsAtTime`` are the oracles, not wrt's own values."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

import wrt  # noqa: E402

GPRIMS = """#usda 1.0
def Sphere "FloatRadius" {
    float radius = 3
}
def Cube "IntSize" {
    int size = 5
    double3 xformOp:translate = (10, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cylinder "HalfHeight" {
    half height = 4
    double radius = 2
    double3 xformOp:translate = (20, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Cone "DoubleCone" {
    double height = 3
    double radius = 1.5
    double3 xformOp:translate = (30, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Capsule "FloatSamples" {
    float radius.timeSamples = {1: 0.25}
    double3 xformOp:translate = (40, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Sphere "OverWeaker" {
    double3 xformOp:translate = (50, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""

WEAKER = """#usda 1.0
over "OverWeaker" {
    double radius = 2.5
}
"""


def _load(path, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(path), **kwargs)
    return scene, [str(w.message) for w in caught]


def test_gprim_sizes_of_another_type_than_the_schemas_are_read_as_bbox_cache_reads_them(tmp_path):
    """A ``float radius = 3`` sphere is of radius 1 to USD (``Get<double>`` passes the float over for the fallback)
    and so to usdview; wrt drew it of radius 3. A ``float radius`` over a weaker layer's ``double radius`` reads
    the weaker one. Each gprim's tessellation fills the world box ``BBoxCache`` computes for it."""
    (tmp_path / "weak.usda").write_text(WEAKER)
    text = GPRIMS.replace('def Sphere "OverWeaker" {', 'def Sphere "OverWeaker" {\n    float radius = 7')
    text = text.replace("#usda 1.0\n", "#usda 1.0\n(\n    subLayers = [@./weak.usda@]\n)\n", 1)
    path = tmp_path / "gprims.usda"
    path.write_text(text)
    stage = Usd.Stage.Open(str(path))
    scene, messages = _load(path, tessellate_gprims=256)
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    drawn = {mesh.path: mesh for mesh in scene.meshes}
    assert sorted(drawn) == sorted(str(p.GetPath()) for p in stage.Traverse())
    for path_, mesh in drawn.items():
        box = cache.ComputeWorldBound(stage.GetPrimAtPath(path_)).ComputeAlignedRange()
        lower, upper = np.array(box.GetMin()), np.array(box.GetMax())
        np.testing.assert_allclose(mesh.points.min(0), lower, atol=2e-3, err_msg=path_)
        np.testing.assert_allclose(mesh.points.max(0), upper, atol=2e-3, err_msg=path_)
    wrong = [m for m in messages if "schema" in m]
    assert len(wrong) == 1, messages
    for name in ("5 prim(s)", "/FloatRadius", "float radius = 3", "int size = 5", "half height = 4",
                 "float radius = 7", "float radius = 0.25"):
        assert name in wrong[0]
