"""The TLAS moves a ray's origin along it to ``t0`` before entering an instance and reports ``t0 + t``
(``wrt.tlas.entry_ray``); ``wrt.tlas.shifted_limit`` turns the ray's limits into limits on ``t``. Checked here against
numpy's float32 sums, which round as the kernels do."""

import numpy as np
import warp as wp

from wrt.tlas import shifted_limit


@wp.kernel
def shifted_limits_kernel(limits: wp.array[float], t0s: wp.array[float], out: wp.array[float]):
    i = wp.tid()
    out[i] = shifted_limit(limits[i], t0s[i])


def shifted_limits(limits: np.ndarray, t0s: np.ndarray) -> np.ndarray:
    out = wp.empty(len(limits), dtype=float, device="cpu")
    wp.launch(shifted_limits_kernel, len(limits), inputs=[wp.array(limits, dtype=float, device="cpu"),
                                                          wp.array(t0s, dtype=float, device="cpu")],
              outputs=[out], device="cpu")
    return out.numpy()


def limit_pairs(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(limits, t0s)`` float32 over every scale: far apart, within a factor 2 of each other (where ``limit - t0``
    is exact and much finer than ``limit``), a float apart, zero, negative and subnormal."""
    scale = 10.0 ** rng.uniform(-44, 37, n)
    limits = (scale * rng.choice([-1, 1], n) * rng.uniform(0.5, 1, n)).astype(np.float32)
    kind = rng.integers(0, 5, n)
    t0s = np.where(kind == 0, 10.0 ** rng.uniform(-44, 37, n), limits * rng.uniform(0.5, 2, n))
    t0s = np.where(kind == 2, np.nextafter(limits, rng.choice([-np.inf, np.inf], n)), t0s)
    t0s = np.where(kind == 3, limits * rng.uniform(0.999, 1.001, n), t0s).astype(np.float32)
    limits[kind == 4] = 0.0
    t0s[kind == 4] = np.abs(t0s[kind == 4])
    return limits, t0s


def test_a_shifted_limit_is_the_smallest_t_whose_reported_t0_plus_t_meets_the_limit(np_rng):
    """For every pair, ``x = shifted_limit(limit, t0)`` satisfies ``float32(t0 + x) >= limit`` while the float32
    below ``x`` does not (``t0 + t`` grows with ``t``, so a hit is kept exactly when its reported ``t`` is); and
    ``t0 = 0`` leaves the limit as it is, infinite limits too."""
    limits, t0s = limit_pairs(np_rng, 200_000)
    x = shifted_limits(limits, t0s)
    with np.errstate(over="ignore"):
        assert (t0s + x >= limits).all()
        below = np.nextafter(x, np.float32(-np.inf))
        assert (t0s + below < limits).all()
    assert np.array_equal(shifted_limits(limits, np.zeros_like(t0s)), limits)
    infinite = np.array([np.inf, -np.inf], np.float32)
    assert np.array_equal(shifted_limits(infinite, np.float32([3.0, 3.0])), infinite)
