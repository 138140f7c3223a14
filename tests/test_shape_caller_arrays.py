"""A Shape's to_world given as a view of the caller's writeable array (poses[k] of an (N, 4, 4) stack, or a (16,) row
reshaped) is held as a copy: Scene.freeze made the view alone read-only, and the caller's edit of the stack moved the
shape under the cached trees. One of text, bools or complex values raises ValueError naming the shape, as other
non-numbers do. Oracle: float64 ray casting against the unit sphere as given (t = 5 - 1 = 4), numpy's dtype kinds."""

import warnings

import numpy as np
import pytest

import wrt
from wrt.primitives import Shape

ORIGIN, DIRECTION = np.float32([0, 0, 5]), np.float32([0, 0, -1])


@pytest.mark.parametrize("layout", ["stack row", "flat"])
def test_to_world_view_of_the_callers_array_is_copied(layout):
    poses = np.stack([np.eye(4)] * 2)
    given = poses[1] if layout == "stack row" else poses.reshape(2, 16)[1]
    sphere = Shape("/S", "sphere", given)
    scene = wrt.Scene(shapes=[sphere])
    assert wrt.trace(scene, ORIGIN, DIRECTION).t[0] == 4.0
    poses[1, 2, 3] = 2.0  # the caller's edit of their own stack, after the trace
    np.testing.assert_array_equal(sphere.to_world, np.eye(4))  # was moved up by 2, while traces kept t = 4
    assert wrt.trace(scene, ORIGIN, DIRECTION).t[0] == 4.0


@pytest.mark.parametrize("dtype", [str, bool, complex])
def test_to_world_not_real_numbers_raises(dtype):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy's ComplexWarning, before the fix
        with pytest.raises(ValueError, match="shape /S: to_world must be"):
            Shape("/S", "sphere", np.eye(4).astype(dtype))
