"""The solid angle a triangle subtends (wrt.spherical_triangle), against Girard's theorem in float64: a spherical
triangle's area is the sum of its angles less pi, a formula independent of Van Oosterom and Strackee's arctangent;
and directions drawn uniformly over it, whose irradiance estimate must be Lambert's closed form (float64)."""

import math

import numpy as np
import pytest
import warp as wp
from light_oracle import polygon_irradiance

from wrt.spherical_triangle import sample_spherical_triangle, seen_solid_angle


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


@wp.kernel
def solid_angles_kernel(
    points: wp.array[wp.vec3],
    corners: wp.array[wp.vec3],
    # outputs
    omega: wp.array[float],
):
    """The solid angle of triangle ``corners[3i : 3i + 3]`` seen from ``points[i]``."""
    i = wp.tid()
    omega[i] = seen_solid_angle(points[i], corners[3 * i], corners[3 * i + 1], corners[3 * i + 2])


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


@wp.kernel
def drawn_irradiance_kernel(
    p: wp.vec3,
    n: wp.vec3,
    a: wp.vec3,
    b: wp.vec3,
    c: wp.vec3,
    # outputs
    irradiance: wp.array[float],
):
    """Per sample: the irradiance estimate at ``p`` (normal ``n``) of triangle ``a, b, c`` of radiance 1 from one
    direction drawn uniformly over its solid angle, ``omega * max(cos, 0)``."""
    i = wp.tid()
    state = wp.rand_init(3, i)
    u1 = wp.randf(state)
    u2 = wp.randf(state)
    omega = seen_solid_angle(p, a, b, c)
    irradiance[i] = 0.0
    if omega > 0.0:
        w = sample_spherical_triangle(p, a, b, c, omega, u1, u2)
        irradiance[i] = omega * wp.max(wp.dot(n, w), 0.0)


# A triangle of unit legs in the plane z = 0 and points 1e-4 below it (normal up): under its inside near the centroid,
# under its inside 1e-4 from the hypotenuse's middle, and 1e-4 beyond that edge (lit from the triangle's side).
UNIT_TRIANGLE = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
NEAR_POINTS = {
    "under the inside": (0.3, 0.3, -1e-4),
    "under an edge, inside": (0.5 - 0.7e-4, 0.5 - 0.7e-4, -1e-4),
    "beside an edge, outside": (0.5 + 0.7e-4, 0.5 + 0.7e-4, -1e-4),
}


def assert_draws_give_lamberts_irradiance(p, n, corners, count=40000):
    """``count`` directions drawn over the solid angle of the triangle ``corners`` from ``p`` average, weighed by
    their pdf and cosine to unit normal ``n``, to Lambert's irradiance of the triangle (float64, clipped to the
    normal's hemisphere) within four standard errors plus 0.2%."""
    irradiance = wp.zeros(count, dtype=float, device="cpu")
    wp.launch(drawn_irradiance_kernel, count, inputs=[wp.vec3(*p), wp.vec3(*n), *(wp.vec3(*x) for x in corners)],
              outputs=[irradiance], device="cpu")
    estimates = irradiance.numpy().astype(np.float64)
    expected = polygon_irradiance(p, n, corners, 1.0)
    error = estimates.std() / math.sqrt(count)
    assert abs(estimates.mean() - expected) < 4 * error + 2e-3 * expected, (estimates.mean(), expected, error)


@pytest.mark.parametrize("first", [0, 1, 2])
@pytest.mark.parametrize("name", list(NEAR_POINTS))
def test_directions_drawn_near_the_triangles_plane_give_lamberts_irradiance(name, first):
    """Seen from 1e-4 of its size off its plane, a triangle spans nearly a hemisphere, or a lune whose corners on an
    edge near the point are nearly opposite: draws uniform over its solid angle average to Lambert's irradiance,
    whichever corner the draw starts from (``first``). Arvo's cos b' as a quotient, with the angle at the first corner
    an arccosine of a cosine near -1, gave 2% too much under the inside (0.4% of the light under other triangles),
    27% too little under an edge and twice too much beside it."""
    corners = np.roll(np.asarray(UNIT_TRIANGLE, np.float64), -first, axis=0)
    p, n = np.asarray(NEAR_POINTS[name], np.float64), np.array([0.0, 0.0, 1.0])
    assert_draws_give_lamberts_irradiance(p, n, corners)


def test_the_solid_angle_of_needles_seen_from_near_their_plane_is_girards():
    """Needle triangles (1 long, 1e-4 to 1 wide) turned and moved off the origin at random, seen from 1e-5 to 0.1 off
    their plane beside and under their long sides: the solid angle is Girard's (float64, of the corners and point as
    float32 holds them) within 1%. Van Oosterom's denominator as ``1 + a.b + b.c + c.a`` summed four terms near 1 to
    a value near 1e-6 (two corners nearly opposite seen from p, two nearly alike), and its numerator as the unit
    vectors' triple product cancelled too: a needle 2.6e-4 wide seen from 6.7e-5 under it got 44% too much solid
    angle (its light as much), one 1e-3 wide from 1e-4 under it 3.7%."""
    rng = np.random.default_rng(1)
    corners, points, expected = [], [], []
    while len(expected) < 200:
        turn, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        width, height = 10 ** rng.uniform(-4, 0), 10 ** rng.uniform(-5, -1)
        triangle = np.array([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, width, 0.0)])
        p = np.array([rng.uniform(-0.2, 1.2), rng.uniform(-2, 3) * width, -height])
        shift = rng.normal(size=3) * 3
        triangle = (triangle @ turn.T + shift).astype(np.float32)
        p = (p @ turn.T + shift).astype(np.float32)
        omega = girard(p.astype(np.float64), *triangle.astype(np.float64))
        if omega > 2e-3:  # sampled by solid angle (SOLID_ANGLE_MIN 1e-3), with room for rounding
            corners.append(triangle)
            points.append(p)
            expected.append(omega)
    got = wp.zeros(len(expected), dtype=float, device="cpu")
    wp.launch(solid_angles_kernel, len(expected), inputs=[wp.array(np.asarray(points), dtype=wp.vec3, device="cpu"),
              wp.array(np.concatenate(corners), dtype=wp.vec3, device="cpu")], outputs=[got], device="cpu")
    got = got.numpy().astype(np.float64)
    error = np.abs(got / np.asarray(expected) - 1.0)
    assert error.max() < 1e-2, (error.max(), int(error.argmax()))


NEEDLE = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1e-3, 0.0)]


@pytest.mark.parametrize("first", [0, 1, 2])
@pytest.mark.parametrize("p", [(0.5, 2e-4, -1e-4), (0.5, -1e-4, -1e-4)], ids=["under", "beside"])
def test_directions_drawn_near_a_needles_long_side_give_lamberts_irradiance(p, first):
    """A needle 1 long and 1e-3 wide seen from 1e-4 under its plane, under it or beside its long side: draws uniform
    over its solid angle average to Lambert's irradiance (float64, of the corners and point as float32 holds them),
    whichever corner the draw starts from. Its solid angle, their weight, was 3.7% too large (1.4% to 5% too much
    light)."""
    corners = np.roll(np.asarray(NEEDLE, np.float32), -first, axis=0).astype(np.float64)
    p, n = np.asarray(p, np.float32).astype(np.float64), np.array([0.0, 0.0, 1.0])
    assert_draws_give_lamberts_irradiance(p, n, corners)
