"""USD transform and instancing edge cases against USD's own API: PointInstancer orientations off unit length
(``ComputeInstanceTransformsAtTime``), ..."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom, Vt  # noqa: E402

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
