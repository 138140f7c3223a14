"""The random streams of paths (:func:`wrt.shade.path_rng`, drawn with :func:`wrt.sampling.rand01` as every integrator
draws them): uniform, and independent across pixels, samples, seeds and the dimensions of one path, measured in
float64 numpy on the numbers the kernels draw. A seed mixed with the pixel or sample index by addition or xor, or a
stream shared by neighbouring pixels a draw apart, fails here: such streams repeat tens of thousands of states and
correlate neighbours with r near 1, where independent ones stay within a few 1 / sqrt(N)."""

import math

import numpy as np
import warp as wp

from wrt.sampling import rand01
from wrt.shade import path_rng

WIDTH, HEIGHT, SAMPLES, DIMS = 64, 32, 8, 8
SEEDS = (0, 1)


@wp.kernel
def draw_streams_kernel(
    seeds: wp.array[wp.int32],
    pixels: int,
    samples: int,
    dims: int,
    # outputs
    draws: wp.array2d[float],
    states: wp.array2d[wp.uint32],
):
    """Path ``i``: pixel ``i % pixels`` of sample ``(i // pixels) % samples`` of seed ``seeds[i // (pixels *
    samples)]``; its first ``dims`` numbers and the generator state each is drawn from."""
    i = wp.tid()
    pixel = i % pixels
    sample = (i // pixels) % samples
    state = path_rng(seeds[i // (pixels * samples)], pixel, sample)
    for k in range(dims):
        states[i, k] = state
        u, state = rand01(state)
        draws[i, k] = u


def streams():
    """``(draws, states)``: float64 ``(seeds, samples, height, width, dims)`` and their uint32 states."""
    n = len(SEEDS) * SAMPLES * WIDTH * HEIGHT
    draws = wp.zeros((n, DIMS), dtype=float, device="cpu")
    states = wp.zeros((n, DIMS), dtype=wp.uint32, device="cpu")
    seeds = wp.array(SEEDS, dtype=wp.int32, device="cpu")
    wp.launch(draw_streams_kernel, n, inputs=[seeds, WIDTH * HEIGHT, SAMPLES, DIMS], outputs=[draws, states],
              device="cpu")
    shape = (len(SEEDS), SAMPLES, HEIGHT, WIDTH, DIMS)
    return draws.numpy().astype(np.float64).reshape(shape), states.numpy().reshape(shape)


def correlation(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Pearson's r of two equal-shaped arrays of U(0, 1) numbers, and the bound 6 / sqrt(N) that independent
    numbers stay under (a 6 sigma bound: the draws are fixed, and a broken stream gives r near 1)."""
    x = x.ravel() - x.mean()
    y = y.ravel() - y.mean()
    return float((x * y).sum() / math.sqrt((x * x).sum() * (y * y).sum())), 6.0 / math.sqrt(x.size)


def test_path_streams_are_uniform():
    u, _ = streams()
    for k in range(DIMS):
        x = u[..., k].ravel()
        assert x.min() >= 0.0 and x.max() < 1.0
        assert abs(x.mean() - 0.5) < 6.0 * math.sqrt(1.0 / 12.0 / x.size), k
        counts = np.histogram(x, bins=16, range=(0.0, 1.0))[0]
        expected = x.size / 16
        chi2 = ((counts - expected) ** 2 / expected).sum()
        assert chi2 < 15 + 6 * math.sqrt(2 * 15), (k, chi2)  # chi-square of 15 degrees of freedom: mean 15, sd 5.5
    pairs = np.histogram2d(u[..., 0].ravel(), u[..., 1].ravel(), bins=8, range=[[0, 1], [0, 1]])[0].ravel()
    expected = pairs.sum() / 64
    chi2 = ((pairs - expected) ** 2 / expected).sum()
    assert chi2 < 63 + 6 * math.sqrt(2 * 63), chi2  # dims 0 and 1 of a path fill the unit square evenly


def test_path_streams_are_uncorrelated_across_pixels_samples_seeds_and_dimensions():
    u, _ = streams()
    checks = {}
    for k in range(DIMS):
        checks[f"seed 0 vs 1, dim {k}"] = correlation(u[0, ..., k], u[1, ..., k])
        checks[f"sample s vs s+1, dim {k}"] = correlation(u[:, :-1, ..., k], u[:, 1:, ..., k])
        for j in range(max(0, k - 1), min(DIMS, k + 2)):  # j != k: a neighbour's stream shifted by one draw
            checks[f"pixel x vs x+1, dims {k}, {j}"] = correlation(u[..., :-1, k], u[..., 1:, j])
            checks[f"pixel y vs y+1, dims {k}, {j}"] = correlation(u[:, :, :-1, :, k], u[:, :, 1:, :, j])
        for j in range(k + 1, DIMS):
            checks[f"dims {k} vs {j} of a path"] = correlation(u[..., k], u[..., j])
    bad = {name: round(r, 4) for name, (r, bound) in checks.items() if abs(r) > bound}
    assert not bad, bad


def test_path_streams_share_no_more_states_than_chance():
    """Two paths that reach one 32-bit state draw the same numbers from there on. Independent streams meet only by
    chance, about as often as the birthday bound says (8 repeated states among these 262144); streams seeded from
    overlapping offsets repeat most of their states."""
    _, states = streams()
    flat = states.ravel()
    repeated = flat.size - np.unique(flat).size
    expected = flat.size * (flat.size - 1) / 2 / 2.0**32
    assert repeated < expected + 6 * math.sqrt(expected) + 5, (repeated, expected)
