"""Directions drawn over a rectangle by its solid angle mixed with cosine-weighted ones (wrt.spherical_rect, Urena et
al. 2013), against float64 oracles independent of its spherical angles: each bin's solid angle by Van Oosterom and
Strackee's arctangent, its cosine-weighted share by Lambert's closed form (tests/light_oracle.py). The bins' counts
must follow the mixture (a chi-square test), and the pdf reported for each draw must be the mixture's density there."""

import math

import numpy as np
import pytest
import warp as wp
from light_oracle import polygon_irradiance

from wrt.spherical_rect import REACH, sample_spherical_rect, spherical_rect, spherical_rect_pdf


@wp.kernel
def draw_kernel(
    p: wp.vec3,
    centre: wp.vec3,
    ex: wp.vec3,
    ey: wp.vec3,
    n: wp.vec3,
    # outputs
    points: wp.array[wp.vec3],
    inside: wp.array[wp.int32],
    pdfs: wp.array[float],
):
    """Per sample: the point of the rectangle's plane drawn from ``p`` (shading normal ``n``), whether it counts (it
    lies in the clipped rectangle) and the solid-angle pdf reported for it."""
    i = wp.tid()
    state = wp.rand_init(17, i)
    u1 = wp.randf(state)
    u2 = wp.randf(state)
    r = spherical_rect(p, centre, ex, ey)
    q, hit = sample_spherical_rect(r, n, u1, u2)
    points[i] = q
    inside[i] = wp.where(hit, 1, 0)
    pdfs[i] = spherical_rect_pdf(r, n, q)


def solid_angle(p, corners) -> float:
    """Solid angle of the convex polygon ``corners`` at ``p`` in float64: a fan of Van Oosterom and Strackee's
    triangles."""
    total = 0.0
    for k in range(1, len(corners) - 1):
        a, b, c = (np.asarray(x, np.float64) - p for x in (corners[0], corners[k], corners[k + 1]))
        la, lb, lc = (np.linalg.norm(x) for x in (a, b, c))
        numerator = abs(np.dot(a, np.cross(b, c)))
        denominator = la * lb * lc + np.dot(a, b) * lc + np.dot(b, c) * la + np.dot(c, a) * lb
        total += 2.0 * math.atan2(numerator, denominator)
    return total


# (p, corner, ex, ey, n; drawn through the centre, corner + (ex + ey) / 2): a unit-height square filling 2.1 sr over a
# point facing it (cosine share 1/3); the same seen by a tilted normal; by a normal facing away from it (glass: the
# cosine draws turn towards the rectangle); a wide strip to the side; and a 2 x 2 square 0.002 above the point,
# clipped to REACH heights around its foot.
CASES = {
    "facing": ((0.0, 0.0, 0.0), (-1.0, -1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.0, 0.0, 1.0)),
    "tilted normal": ((0.3, 0.2, 0.0), (-1.0, -1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.6, 0.0, 0.8)),
    "normal facing away": ((0.3, 0.2, 0.0), (-1.0, -1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), (-0.6, 0.0, -0.8)),
    "strip to the side": ((3.0, 0.2, 0.0), (-1.0, -4.0, 1.0), (2.0, 0.0, 0.0), (0.0, 8.0, 0.0), (0.0, 0.0, 1.0)),
    "clipped": ((0.1, -0.2, 0.0), (-1.0, -1.0, 0.002), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.0, 0.0, 1.0)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_draws_follow_the_solid_angle_and_cosine_mixture(name):
    """The share ``omega / (2 pi)`` of cosine-weighted draws about the normal turned towards the rectangle (those that
    miss it count for nothing), the rest uniform in its solid angle ``omega``: the draws that land in each of 8 x 8
    bins of the (clipped) rectangle, and those that miss it, follow that mixture, and each draw reports its density."""
    p, corner, ex, ey, n = (np.asarray(x, np.float64) for x in CASES[name])
    # The rectangle as drawn: clipped to REACH heights around p's foot (a no-op but for "clipped").
    height = abs(corner[2] - p[2])
    lo = np.maximum(corner[:2], p[:2] - REACH * height)
    hi = np.minimum(corner[:2] + np.array([ex[0], ey[1]]), p[:2] + REACH * height)
    omega = solid_angle(p, [(lo[0], lo[1], corner[2]), (hi[0], lo[1], corner[2]), (hi[0], hi[1], corner[2]),
                            (lo[0], hi[1], corner[2])])
    share = omega / (2.0 * math.pi)
    axis = -n if n[2] < 0.0 else n  # towards the rectangle's plane, above the point

    count, bins = 200000, 8
    points, inside, pdfs = (wp.zeros(count, dtype=t, device="cpu") for t in (wp.vec3, wp.int32, float))
    centre = corner + 0.5 * (ex + ey)
    wp.launch(draw_kernel, count, inputs=[wp.vec3(*p), wp.vec3(*centre), wp.vec3(*ex), wp.vec3(*ey), wp.vec3(*n)],
              outputs=[points, inside, pdfs], device="cpu")
    q = points.numpy().astype(np.float64)[inside.numpy() == 1]
    cell = (hi - lo) / bins
    ij = np.clip(np.floor((q[:, :2] - lo) / cell).astype(int), 0, bins - 1)
    counts = np.bincount(ij[:, 0] * bins + ij[:, 1], minlength=bins * bins)
    expected = np.zeros(bins * bins)
    for i in range(bins):
        for j in range(bins):
            x0, y0 = lo + cell * (i, j)
            box = [(x0, y0, corner[2]), (x0 + cell[0], y0, corner[2]), (x0 + cell[0], y0 + cell[1], corner[2]),
                   (x0, y0 + cell[1], corner[2])]
            expected[i * bins + j] = ((1.0 - share) * solid_angle(p, box) / omega
                                      + share * polygon_irradiance(p, axis, box, 1.0) / math.pi)
    expected *= count
    missed = count - expected.sum()
    chi2 = ((counts - expected) ** 2 / expected).sum() + (count - len(q) - missed) ** 2 / max(missed, 1.0)
    dof = bins * bins
    assert chi2 < dof + 5.0 * math.sqrt(2.0 * dof), (chi2, dof)

    # The density reported for each draw: the mixture's at its direction.
    w = q - p
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    density = (1.0 - share) / omega + share * np.maximum(w @ axis, 0.0) / math.pi
    np.testing.assert_allclose(pdfs.numpy()[inside.numpy() == 1], density, rtol=2e-3)


def test_the_points_drawn_over_a_vast_turned_rectangle_lie_on_its_plane():
    """A turned square 2e6 wide seen from 0.65 off its plane near its centre: its height is measured from the centre,
    rounded at the point's distance from it. Measured from a corner, 1e6 away, it was rounded at 0.06 in float32,
    and the points drawn lay up to 9.5% of their distance off the plane (a glowing plane's own surface shadowed
    them)."""
    a, b = math.radians(30.0), math.radians(40.0)
    turn = np.array([[math.cos(b), -math.sin(b), 0.0], [math.sin(b), math.cos(b), 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])
    ex, ey, normal = (turn[:, i].astype(np.float32).astype(np.float64) for i in range(3))
    ex, ey = 2e6 * ex, 2e6 * ey
    centre = np.array([0.0, 0.0, 1.0])
    p = centre - 0.65 * normal + 0.1 * turn[:, 0] - 0.2 * turn[:, 1]
    count = 20000
    points, inside, pdfs = (wp.zeros(count, dtype=t, device="cpu") for t in (wp.vec3, wp.int32, float))
    wp.launch(draw_kernel, count, inputs=[wp.vec3(*p), wp.vec3(*centre), wp.vec3(*ex), wp.vec3(*ey), wp.vec3(0.0)],
              outputs=[points, inside, pdfs], device="cpu")
    q = points.numpy().astype(np.float64)[inside.numpy() == 1]
    assert len(q) > 0.99 * count
    true_normal = np.cross(ex, ey) / np.linalg.norm(np.cross(ex, ey))
    off = np.abs((q - centre) @ true_normal) / np.linalg.norm(q - p, axis=1)
    assert off.max() < 1e-5, off.max()
