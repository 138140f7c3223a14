"""Random gprim stages (:mod:`gprim_stages`) traced analytically agree ray by ray with a fine tessellation of the same
stage (:mod:`gprim_compare`): hit or miss away from silhouettes, ``t`` within the tessellation error, the side hit,
the prim and instance hit, and any-hit queries with closest hits."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pxr")

from gprim_compare import compare_stage  # noqa: E402

SEEDS = range(24)  # 24 stages of 240 rays: about 10 s on a CPU
SEGMENTS = 256  # per circle: the tessellation strays at most 2.3e-4 of a radius
# A known limit, kept failing on purpose: the float32 edge functions of a sliver triangle (aspect above about 1000)
# round t far enough to lose a hit. Weighing such hits in float64 fixed it and cost the GPU's BVH4 traversal 10-12% on
# incoherent rays (benchmarks/GPU_NOTES.md row 71), so it was not kept. Seed 4 is a needle capsule whose sides are such
# slivers at 256 segments.
SLIVER_LIMIT = pytest.mark.xfail(strict=True, reason="known limit: float32 rounding on sliver triangles (README)")


@pytest.mark.parametrize("seed", [pytest.param(s, marks=SLIVER_LIMIT) if s == 4 else s for s in SEEDS])
def test_analytic_gprims_agree_with_their_tessellation(tmp_path, seed):
    result = compare_stage(str(tmp_path / "stage.usda"), seed, 240, SEGMENTS)
    problems = {kind: rays[:5].tolist() for kind, rays in result["problems"].items()}
    assert not problems, (result["type"], result["placement"], problems)


def test_the_stages_make_a_comparison_that_can_fail(tmp_path):
    """The comparison sees a tessellation that is too coarse: 6 segments per circle stray far past the tolerance of
    256 (it is checked at 256's error), so robust rays disagree on ``t`` or on hit or miss."""
    import gprim_compare

    seen = 0
    for seed in (2, 3, 9):
        original = gprim_compare.shape_deviation
        try:
            gprim_compare.shape_deviation = lambda segments: original(SEGMENTS)
            result = compare_stage(str(tmp_path / f"s{seed}.usda"), seed, 240, 6)
        finally:
            gprim_compare.shape_deviation = original
        seen += sum(len(rays) for kind, rays in result["problems"].items() if kind in ("t", "hit_miss"))
        assert result["robust"] > 0.5 * result["rays"]
    assert seen > 0


def test_the_stages_cover_every_type_and_placement(tmp_path):
    from gprim_stages import GPRIM_TYPES, write_stage

    made = [write_stage(str(tmp_path / f"s{seed}.usda"), seed) for seed in SEEDS]
    assert {m["type"] for m in made} == set(GPRIM_TYPES)
    assert {m["placement"] for m in made} == {"world", "instances", "nested", "instancer"}
    assert np.mean([m["type"] == "Plane" for m in made]) < 0.5


@SLIVER_LIMIT
def test_a_ray_through_a_sliver_triangle_hits_it_where_float64_does():
    """One side triangle of a needle capsule's tessellation (1.4 long, 2e-5 wide) and a ray from inside the needle
    through its middle (barycentrics 0.24, 0.31): the float32 edge functions' rounding put the hit at t = -0.016, so
    the ray missed and went out through the wall; the closest hit and the any-hit query must both find it at the
    float64 distance."""
    import wrt

    corners = np.array([[-6.9858056e-01, -5.7865173e-04, -9.1379095e-04],
                        [6.9858056e-01, -5.7865173e-04, -9.1379095e-04],
                        [6.9858056e-01, -5.5605191e-04, -9.2771655e-04]], np.float32)
    origin = np.frombuffer(bytes.fromhex("ed81943d5ecdabb9649823ba"), np.float32).reshape(1, 3)
    direction = np.frombuffer(bytes.fromhex("189289ba36df36ba2a6b5cba"), np.float32).reshape(1, 3)
    # float64: Moller-Trumbore on the same float32 corners and ray.
    p, o, d = corners.astype(np.float64), origin[0].astype(np.float64), direction[0].astype(np.float64)
    e1, e2 = p[1] - p[0], p[2] - p[0]
    pv = np.cross(d, e2)
    det = e1 @ pv
    qv = np.cross(o - p[0], e1)
    expected = e2 @ qv / det
    assert 0.2 < (o - p[0]) @ pv / det < 0.3 and 0.25 < d @ qv / det < 0.35  # well inside the triangle
    scene = wrt.Scene.from_triangles(corners, np.array([[0, 1, 2]], np.int32))
    hits = wrt.trace(scene, origin, direction)
    assert hits.hit[0]
    np.testing.assert_allclose(hits.t[0], expected, rtol=1e-3)
    assert wrt.occluded(scene, origin, direction, t_max=np.float32(expected * 1.01))[0]
    assert not wrt.occluded(scene, origin, direction, t_max=np.float32(expected * 0.99))[0]
