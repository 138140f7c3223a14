"""The solid angle a triangle subtends (wrt.spherical_triangle), against Girard's theorem in float64: a spherical
triangle's area is the sum of its angles less pi, a formula independent of Van Oosterom and Strackee's arctangent."""

import numpy as np
import pytest
import warp as wp

from wrt.spherical_triangle import seen_solid_angle


@wp.kernel
def solid_angle_kernel(
    p: wp.vec3,
    corners: wp.array[wp.vec3],
    # outputs
    omega: wp.array[float],
):
    """The solid angle of triangle ``corners[3i : 3i + 3]`` seen from ``p``."""
    i = wp.tid()
    omega[i] = seen_solid_angle(p, corners[3 * i], corners[3 * i + 1], corners[3 * i + 2])


def girard(p, a, b, c) -> float:
    """The solid angle of triangle ``a, b, c`` at ``p``, in float64: its spherical angles' sum less pi."""
    u = [np.asarray(x, np.float64) - p for x in (a, b, c)]
    u = [x / np.linalg.norm(x) for x in u]
    total = 0.0
    for k in range(3):
        at, left, right = u[k], u[(k + 1) % 3], u[(k + 2) % 3]
        t1 = left - np.dot(left, at) * at  # the tangents at ``at`` of the great circles to the two other corners
        t2 = right - np.dot(right, at) * at
        total += np.arccos(np.clip(np.dot(t1, t2) / (np.linalg.norm(t1) * np.linalg.norm(t2)), -1.0, 1.0))
    return total - np.pi


# Triangles seen from the origin: an octant's (pi / 2); a small one far off; one spread round the viewer just above
# its plane, whose corners' dot products sum below -1 (the arctangent's denominator negative: more than pi).
TRIANGLES = {
    "octant": [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)],
    "small and far": [(10.0, 0.0, 0.0), (10.0, 0.8, 0.0), (10.0, 0.0, 0.6)],  # 2.4e-3 sr: past SOLID_ANGLE_MIN
    "wide and near": [(1.0, 0.0, -0.05), (-0.5, 0.8660254, -0.05), (-0.5, -0.8660254, -0.05)],
}


@pytest.mark.parametrize("name", list(TRIANGLES))
def test_the_solid_angle_of_a_triangle_is_girards(name):
    corners = np.asarray(TRIANGLES[name], np.float32)
    omega = wp.zeros(1, dtype=float, device="cpu")
    wp.launch(solid_angle_kernel, 1, inputs=[wp.vec3(0.0, 0.0, 0.0), wp.array(corners, dtype=wp.vec3, device="cpu")],
              outputs=[omega], device="cpu")
    expected = girard(np.zeros(3), *corners.astype(np.float64))
    if name == "octant":
        assert expected == pytest.approx(np.pi / 2.0)
    if name == "wide and near":
        assert expected > np.pi  # past the arctangent's first half-turn
    assert omega.numpy()[0] == pytest.approx(expected, rel=1e-5)
