"""Seeded random stages of meshes (convex polygons, closed polyhedra; ``doubleSided``, ``leftHanded``, mirrored,
native instances, PointInstancers, nested) seen by a random ``UsdGeom.Camera``: wrt's camera AOVs (``prim`` as a
path, the USD face, ``instance``, ``depth``, ``z``, the side of ``geometric_normal``) match, pixel by pixel, a float64
brute-force oracle built from USD's own API (:mod:`aov_stages`), away from edges, ties, clipping planes and grazing
faces.

``WRT_AOV_STAGES`` raises the number of stages for longer local runs (400 stages, 120k pixels that see something,
take about a minute).
"""

from __future__ import annotations

import os
from collections import Counter

import numpy as np
from aov_compare import compare_stage
from aov_stages import camera_view, write_stage
from pxr import Usd, UsdGeom

STAGES = int(os.environ.get("WRT_AOV_STAGES", "20"))


def test_camera_aovs_match_usds_triangles_seen_through_usds_frustum(tmp_path):
    found, counts = [], Counter()
    for seed in range(STAGES):
        lines, seen = compare_stage(tmp_path, seed)
        found += lines
        counts += seen
    assert not found, f"{len(found)} pixels disagree:\n" + "\n".join(found[:40])
    # The stages show what the comparison is about: at 20 stages about 7,800 pixels see something, 2,000 of them
    # through a culled back face, 4,500 a leftHanded or mirrored face, 900 a native instance, 3,200 a PointInstancer's.
    assert counts["hit"] > 200 * STAGES and counts["compared"] > 0.9 * STAGES * 40 * 30
    for key in ("culled", "flipped", "native", "point_instancer", "orthographic"):
        assert counts[key] > 10 * STAGES, (key, counts)


def test_the_oracle_culls_by_orientation_and_by_the_transforms_handedness(tmp_path):
    """A quad wound counter-clockwise seen from the camera (at +Z, looking down -Z), in front of a double-sided
    backdrop: the camera sees the quad unless exactly one of ``leftHanded`` and a mirroring parent scale turns its
    front away (the mirror maps the local front normal +Z to -Z, though the world-space corners still run
    counter-clockwise seen from the camera)."""
    for left, mirror in ((False, False), (True, False), (False, True), (True, True)):
        stage = Usd.Stage.CreateInMemory()
        parent = UsdGeom.Xform.Define(stage, "/P")
        parent.AddScaleOp().Set((1.0, 1.0, -1.0) if mirror else (1.0, 1.0, 1.0))
        quad = UsdGeom.Mesh.Define(stage, "/P/Quad")
        z = -1.0 if mirror else 1.0  # at world z = 1 either way
        quad.CreatePointsAttr([(-1, -1, z), (1, -1, z), (1, 1, z), (-1, 1, z)])
        quad.CreateFaceVertexCountsAttr([4])
        quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        if left:
            quad.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
        back = UsdGeom.Mesh.Define(stage, "/Back")
        back.CreatePointsAttr([(-9, -9, -1), (9, -9, -1), (9, 9, -1), (-9, 9, -1)])
        back.CreateFaceVertexCountsAttr([4])
        back.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        back.CreateDoubleSidedAttr(True)
        cam = UsdGeom.Camera.Define(stage, "/Cam")
        cam.AddTranslateOp().Set((0.0, 0.0, 10.0))
        view = camera_view(stage, "/Cam", 8, 6)
        expected = "/Back" if left != mirror else "/P/Quad"
        assert view["prim"][3, 4] == expected, (left, mirror)
        assert view["culled"][3, 4] == (left != mirror)
        np.testing.assert_allclose(view["z"][3, 4], 11.0 if left != mirror else 9.0, rtol=1e-9)


def test_the_stages_are_reproducible(tmp_path):
    a, b = tmp_path / "a.usda", tmp_path / "b.usda"
    write_stage(str(a), 7)
    write_stage(str(b), 7)
    assert a.read_text() == b.read_text()
