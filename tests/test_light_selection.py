"""Light selection: next-event estimation draws light ``k`` by ``sample_cdf`` over the device's ``cdf`` with a uniform
``u`` (a multiple of 2^-24, ``wp.randf``) and divides its light by ``pmf[k]``; the estimate is unbiased only where
``pmf[k]`` is the probability of drawing ``k``. Checked by drawing with every one of the 2^24 values ``u`` can take."""

import numpy as np
import warp as wp

import wrt
from wrt.light_sampling import DeviceLights, pick_in_group
from wrt.light_table import build_lights
from wrt.lights import SphereLight
from wrt.materials import Material, emission_estimates
from wrt.sampling import sample_cdf

U_VALUES = 1 << 24  # wp.randf: (state >> 8) / 2^24


@wp.kernel
def draw_every_u_kernel(cdf: wp.array[float], count: int, picks: wp.array[wp.int32]):
    j = wp.tid()
    picks[j] = sample_cdf(cdf, 0, count, float(j) * (1.0 / 16777216.0))


def glowing_triangles(n, rng, lights=()):
    """The device lights of ``n`` glowing triangles of random sizes (power) and ``lights``."""
    corners = rng.random((n, 1, 3)) * 10 + rng.random((n, 3, 3)) * rng.uniform(0.01, 0.2, (n, 1, 1))
    mesh = wrt.Mesh("/glow", corners.reshape(-1, 3), np.arange(3 * n).reshape(n, 3), np.arange(n),
                    material_ids=np.zeros(n, np.int32))
    scene = wrt.Scene(meshes=[mesh], materials=[Material(emissive_color=(1.0, 1.0, 1.0))])
    return build_lights(list(lights), scene, emission_estimates(scene.materials, []), "cpu").device_lights


def test_each_lights_pmf_is_the_probability_it_is_drawn_with(np_rng):
    """200,000 glowing triangles of random sizes (selection by power): the share of the 2^24 draws that pick each
    light is its pmf. The pmf was the float64 power share rounded to float32 while the float32 cdf's steps are
    rounded to its 2^-24 grid near 1: lights were drawn up to 2.4% more or less often than their light was divided
    by, a fixed pattern of wrong light (7.7% at a million emitters, 14% at two million) that no sample count removes."""
    n = 200_000
    lights = glowing_triangles(n, np_rng)
    assert lights.count == n
    picks = wp.empty(U_VALUES, dtype=wp.int32, device="cpu")
    wp.launch(draw_every_u_kernel, U_VALUES, inputs=[lights.cdf, lights.count], outputs=[picks], device="cpu")
    drawn = np.bincount(picks.numpy(), minlength=n) / U_VALUES
    pmf = lights.pmf.numpy()[:n].astype(np.float64)
    np.testing.assert_allclose(pmf, drawn, rtol=1e-6, atol=0)


@wp.kernel
def pick_in_group_kernel(lights: DeviceLights, first: int, count: int, picks: wp.array[wp.int32],
                         probabilities: wp.array[float]):
    j = wp.tid()
    k, p = pick_in_group(lights, first, count, float(j) * (1.0 / 16777216.0))
    picks[j] = k - first
    probabilities[j] = p


def test_whitted_draws_each_triangle_with_the_probability_it_divides_by(np_rng):
    """Whitted lights all emissive triangles as one light group, drawing one by power: over the 2^24 values of ``u``
    each triangle is drawn as often as the probability it reports (its light is divided by it). Drawn through the
    lights' cdf from ``cdf[first] + u * (the rest)``, whose float32 sum rounds, beside a sphere light (which moves
    the triangles' cdf off 0), triangles were drawn up to 2.5% more or less often than their reported share."""
    n = 200_000
    sphere = SphereLight(position=(0, 0, 5), radius=0.5, color=np.full(3, 50.0))
    lights = glowing_triangles(n, np_rng, [sphere])
    first = lights.num_analytic
    assert lights.count - first == n
    picks = wp.empty(U_VALUES, dtype=wp.int32, device="cpu")
    probabilities = wp.empty(U_VALUES, dtype=float, device="cpu")
    wp.launch(pick_in_group_kernel, U_VALUES, inputs=[lights, first, n], outputs=[picks, probabilities], device="cpu")
    picks = picks.numpy()
    drawn = np.bincount(picks, minlength=n) / U_VALUES
    reported = np.zeros(n)
    reported[picks] = probabilities.numpy()
    np.testing.assert_allclose(reported, drawn, rtol=1e-6, atol=0)
