"""Host-side work saved between renders and traces of one scene: what is kept must still follow every edit.

Oracles: a float64 cross product for triangle areas.
"""

from __future__ import annotations

import numpy as np
import pytest

from wrt.scene import has_area


@pytest.mark.parametrize("only", [0, 63, 64, 65, 319, 320, 5000, None])
def test_has_area_finds_the_one_triangle_with_area(only):
    # Triangles of repeated corners, but (where ``only`` is given) one at a chunk boundary of the growing chunks.
    rng = np.random.default_rng(7)
    points = rng.random((6000, 3)).astype(np.float32)
    indices = np.repeat(np.arange(6000, dtype=np.int32)[:, None], 3, axis=1)
    if only is not None:
        indices[only] = [only, only + 1, only + 2]
    corners = points[indices].astype(np.float64)
    expected = bool(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).any())
    assert expected == (only is not None)
    assert has_area(points, indices) == expected
    assert has_area(points, indices, chunk=100) == expected
