"""The spatial-split trial builder (benchmarks/sbvh_trial.py, GPU_NOTES row 58): a valid tree with the plain SAH
tree's hits, and a lower SAH cost where long triangles overlap."""

import sys
from pathlib import Path

import numpy as np
import pytest

from wrt.bvh import build_bvh

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from sbvh_trial import build_sbvh  # noqa: E402
from test_presplit import closest_hits  # noqa: E402


def haystack(n: int, seed: int = 0):
    """Long diagonal triangles criss-crossing a cube, over a grid of small ones: the case spatial splits are for."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, size=(n, 3))
    b = rng.uniform(-1, 1, size=(n, 3))
    c = 0.5 * (a + b) + rng.normal(size=(n, 3)) * 0.02
    small = rng.uniform(-1, 1, size=(8 * n, 1, 3)) + rng.normal(size=(8 * n, 3, 3)) * 0.01
    tris = np.concatenate([np.stack([a, b, c], 1), small]).astype(np.float32)
    return tris.reshape(-1, 3), np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3)


def rays_at_triangles(points, indices, n: int, seed: int = 1):
    """Rays from outside the cube aimed at random points of random triangles."""
    rng = np.random.default_rng(seed)
    tri = points[indices[rng.integers(len(indices), size=n)]]
    w = rng.dirichlet(np.ones(3), size=n)
    targets = np.einsum("nk,nkc->nc", w, tri)
    origins = rng.normal(size=(n, 3))
    origins *= 3.0 / np.linalg.norm(origins, axis=1, keepdims=True)
    return origins.astype(np.float32), (targets - origins).astype(np.float32)


@pytest.fixture(scope="module")
def trees():
    points, indices = haystack(300)
    return points, indices, build_bvh(points, indices, "sah"), build_sbvh(points, indices)


def test_spatial_splits_lower_the_sah_cost_of_overlapping_triangles(trees):
    points, indices, plain, sbvh = trees
    sbvh.validate()
    assert sbvh.sbvh_stats["spatial"] > 0
    assert len(indices) < sbvh.num_prims  # some triangles were split between leaves
    assert sbvh.stats(epo_samples=0)["sah_cost"] < 0.9 * plain.stats(epo_samples=0)["sah_cost"]


@pytest.mark.parametrize("layout", ["binary", "wide"])
def test_sbvh_hits_equal_the_plain_trees(trees, layout):
    points, indices, plain, sbvh = trees
    origins, directions = rays_at_triangles(points, indices, 2000)
    before, _, blocked_before = closest_hits(plain, points, indices, layout, origins, directions)
    after, _, blocked_after = closest_hits(sbvh, points, indices, layout, origins, directions)
    assert (before[3] >= 0).mean() > 0.9
    for a, b in zip(before, after):
        assert np.array_equal(a.view(np.int32), b.view(np.int32))
    assert np.array_equal(blocked_before, blocked_after)
