"""The BSDF's building blocks called directly in Warp kernels: sampled directions against the reported pdf (a
chi-square test, as pbrt and Mitsuba test their BSDFs), the multiple-scattering lobe's sampler against its pdf, the
GGX lobe against a float64 evaluation, sample weights that stay small (no fireflies), and finite weights at the
corners of the random numbers and of the shading frame."""

import math

import numpy as np
import pytest
import warp as wp

from wrt.bsdf import Surface, eval_bsdf, fresnel_dielectric, lobe_albedos, sample_bsdf, thin_dielectric_reflectance
from wrt.integrators.whitted import whitted_continuation
from wrt.microfacet_albedo import (
    GgxAlbedo,
    ggx_albedo_tables,
    load_table,
    lookup_ggx_albedo,
    lookup_ggx_average_loss,
    lookup_multiple_scattering_total,
    multiple_scattering_pdf,
    sample_multiple_scattering_cos,
)
from wrt.shade import keep_reflection_above

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])
N_PARAMS = 14  # base rgb, specular grey, metallic, roughness, opacity, ior, clearcoat, its roughness, workflow, thin,
# the clearcoat's ior, specular_edge


@wp.func
def surface_from(p: wp.array[float]):
    """A :class:`Surface` from the ``N_PARAMS`` numbers of :func:`params`."""
    s = Surface()
    s.base_color = wp.vec3(p[0], p[1], p[2])
    s.specular_color = wp.vec3(p[3])
    s.metallic = p[4]
    s.roughness = p[5]
    s.opacity = p[6]
    s.ior = p[7]
    s.clearcoat = p[8]
    s.clearcoat_roughness = p[9]
    s.specular_workflow = int(p[10])
    s.thin_walled = int(p[11])
    s.clearcoat_ior = p[12]
    s.specular_edge = p[13]
    return s


def params(base=(0.8, 0.6, 0.4), metallic=0.0, roughness=0.5, opacity=1.0, ior=1.5, clearcoat=0.0,
           clearcoat_roughness=0.01, specular=None, thin_walled=False, clearcoat_ior=1.5, edge=1.0) -> wp.array:
    """The surface numbers for :func:`surface_from` (``specular``: the specular workflow with that grey F0;
    ``edge``: the specular lobe's ``specular_edge``, 0 for the fallback surface's none)."""
    values = [*base, specular or 0.0, metallic, roughness, opacity, ior, clearcoat, clearcoat_roughness,
              0.0 if specular is None else 1.0, float(thin_walled), clearcoat_ior, edge]
    return wp.array(np.array(values, np.float32), dtype=float, device="cpu")


@wp.kernel
def sample_bsdf_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    n: wp.array[wp.vec3],
    wo: wp.array[wp.vec3],
    u: wp.array2d[float],
    # outputs
    wi: wp.array[wp.vec3],
    weight: wp.array[wp.vec3],
    pdf: wp.array[float],
    delta: wp.array[wp.int32],
):
    """Sample ``i``: :func:`sample_bsdf` at shading normal ``n[i]`` (also the geometric normal) for viewer
    ``wo[i]`` with the four numbers ``u[i]``."""
    i = wp.tid()
    s = surface_from(p)
    lobes = lobe_albedos(s, tables, wp.dot(n[i], wo[i]))
    b = sample_bsdf(s, tables, lobes, n[i], n[i], wo[i], 1, u[i, 0], u[i, 1], u[i, 2], u[i, 3])
    wi[i] = b.wi
    weight[i] = b.weight
    pdf[i] = b.pdf
    delta[i] = b.delta


@wp.kernel
def eval_bsdf_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    n: wp.array[wp.vec3],
    wo: wp.array[wp.vec3],
    wi: wp.array[wp.vec3],
    # outputs
    f: wp.array[wp.vec3],
    pdf: wp.array[float],
):
    """``(f, pdf)`` of :func:`eval_bsdf` for ``wo[i], wi[i]`` at normal ``n[i]``."""
    i = wp.tid()
    s = surface_from(p)
    fi, pi = eval_bsdf(s, tables, lobe_albedos(s, tables, wp.dot(n[i], wo[i])), n[i], n[i], wo[i], wi[i])
    f[i] = fi
    pdf[i] = pi


@wp.kernel
def whitted_continuation_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    ns: wp.array[wp.vec3],
    ng: wp.array[wp.vec3],
    wo: wp.array[wp.vec3],
    # outputs
    wi: wp.array[wp.vec3],
    weight: wp.array[wp.vec3],
):
    """Case ``i``: :func:`whitted_continuation` at shading normal ``ns[i]``, geometric ``ng[i]``, viewer ``wo[i]``,
    its reflection picked (``u = 0``)."""
    i = wp.tid()
    d, w, _ = whitted_continuation(surface_from(p), tables, ns[i], ng[i], 1, wo[i], 0.0)
    wi[i] = d
    weight[i] = w

def vec3s(a) -> wp.array:
    return wp.array(np.ascontiguousarray(a, np.float32), dtype=wp.vec3, device="cpu")


def sample(p, n, wo, u):
    """``(wi, weight, pdf, delta)`` numpy arrays, one row per row of ``u``; ``n`` and ``wo`` rows or one vector."""
    count = len(u)
    n, wo = (np.broadcast_to(np.asarray(x, np.float32), (count, 3)) for x in (n, wo))
    outs = [wp.empty(count, dtype=t, device="cpu") for t in (wp.vec3, wp.vec3, float, wp.int32)]
    u = wp.array(u.astype(np.float32), dtype=float, device="cpu")
    wp.launch(sample_bsdf_kernel, count, inputs=[p, ggx_albedo_tables("cpu"), vec3s(n), vec3s(wo), u], outputs=outs,
              device="cpu")
    return [o.numpy() for o in outs]


def evaluate(p, n, wo, wi):
    """``(f, pdf)`` numpy arrays of :func:`eval_bsdf` per row of ``wi``."""
    count = len(wi)
    n, wo = (np.broadcast_to(np.asarray(x, np.float32), (count, 3)) for x in (n, wo))
    f = wp.empty(count, dtype=wp.vec3, device="cpu")
    pdf = wp.empty(count, dtype=float, device="cpu")
    wp.launch(eval_bsdf_kernel, count, inputs=[p, ggx_albedo_tables("cpu"), vec3s(n), vec3s(wo), vec3s(wi)],
              outputs=[f, pdf], device="cpu")
    return f.numpy(), pdf.numpy()


def chi2_sf(x2: float, dof: int) -> float:
    """Upper tail of the chi-square distribution (Wilson and Hilferty's cube-root normal approximation)."""
    k = float(dof)
    z = ((x2 / k) ** (1.0 / 3.0) - (1.0 - 2.0 / (9.0 * k))) / math.sqrt(2.0 / (9.0 * k))
    return 0.5 * math.erfc(z / math.sqrt(2.0))


def chi2_test(observed: np.ndarray, expected: np.ndarray) -> tuple[float, float, int]:
    """``(p-value, chi-square, degrees of freedom)`` of histogram counts against expected counts, bins below 5
    expected counts merged (smallest first)."""
    order = np.argsort(expected.ravel())
    obs, exp = observed.ravel()[order], expected.ravel()[order]
    merged_obs, merged_exp, acc_o, acc_e = [], [], 0.0, 0.0
    for o, e in zip(obs, exp):
        acc_o, acc_e = acc_o + o, acc_e + e
        if acc_e >= 5.0:
            merged_obs.append(acc_o)
            merged_exp.append(acc_e)
            acc_o = acc_e = 0.0
    merged_obs[-1] += acc_o
    merged_exp[-1] += acc_e
    mo, me = np.array(merged_obs), np.array(merged_exp)
    x2 = float(((mo - me) ** 2 / me).sum())
    return chi2_sf(x2, len(mo) - 1), x2, len(mo) - 1


@pytest.mark.parametrize(
    "surface, cos_o",
    [
        (dict(roughness=0.5), 0.7),
        (dict(roughness=0.2), 1.0),
        (dict(roughness=1.0), 0.2),
        (dict(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.3), 0.5),
        (dict(metallic=0.5, roughness=0.3, clearcoat=1.0, clearcoat_roughness=0.3), 0.7),
        (dict(roughness=0.0, clearcoat=0.5, clearcoat_roughness=0.2), 0.2),  # a delta lobe beside the others
        (dict(roughness=0.4, opacity=0.5), 0.6),  # glass: its delta events are left out of the histogram
        # Rough metals, where the multiple-scattering lobe (cosine-sampled) carries much of the light.
        (dict(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=1.0), 0.9),
        (dict(base=(0.9, 0.6, 0.2), metallic=1.0, roughness=0.8, clearcoat=0.5, clearcoat_roughness=0.6), 0.3),
        (dict(base=(0.5, 0.5, 0.5), specular=0.7, roughness=0.7), 0.5),
        # Smoother metals seen at grazing angles, whose multiple-scattering lobe (sampled from its table) leans to
        # grazing directions (sharper GGX peaks than these fall between the bins' integration points).
        (dict(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.25), 0.1),
        (dict(base=(1.0, 0.71, 0.29), metallic=1.0, roughness=0.3, clearcoat=0.5, clearcoat_roughness=0.25), 0.15),
    ],
)
def test_sampled_directions_follow_the_reported_pdf(surface, cos_o):
    """Non-delta directions drawn by ``sample_bsdf``, binned in (theta, phi), against the counts that ``eval_bsdf``'s
    pdf integrated over each bin predicts (bins below 5 expected counts merged); ``weight`` is ``f cos / pdf``."""
    count, n_theta, n_phi, sub = 200_000, 32, 64, 12
    p = params(**surface)
    n = np.array([0.0, 0.0, 1.0])
    wo = np.array([math.sqrt(1.0 - cos_o * cos_o), 0.0, cos_o])
    u = np.random.default_rng(11).random((count, 4))
    wi, weight, pdf, delta = sample(p, n, wo, u)
    assert np.isfinite(weight).all() and (weight >= 0.0).all()
    drawn = (delta == 0) & (pdf > 0.0)
    theta = np.arccos(np.clip(wi[drawn, 2], -1.0, 1.0))
    phi = np.arctan2(wi[drawn, 1], wi[drawn, 0]) % (2 * np.pi)
    observed = np.histogram2d(theta, phi, bins=[n_theta, n_phi], range=[[0, np.pi], [0, 2 * np.pi]])[0]

    # Integrate the pdf over each bin by the midpoint rule on a sub x sub grid.
    t = (np.arange(n_theta * sub) + 0.5) * (np.pi / (n_theta * sub))
    ph = (np.arange(n_phi * sub) + 0.5) * (2 * np.pi / (n_phi * sub))
    tt, pp = np.meshgrid(t, ph, indexing="ij")
    dirs = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    f, density = evaluate(p, n, wo, dirs)
    cell = np.sin(tt).ravel() * (np.pi / (n_theta * sub)) * (2 * np.pi / (n_phi * sub))
    expected = (density * cell).reshape(n_theta, sub, n_phi, sub).sum(axis=(1, 3)) * count

    p_value, x2, dof = chi2_test(observed, expected)
    assert p_value > 1e-3, (x2, dof, drawn.mean(), expected.sum() / count)

    # The sample's weight is the BSDF value times the cosine over the pdf, both from eval_bsdf.
    f_s, pdf_s = evaluate(p, n, wo, wi[drawn])
    np.testing.assert_allclose(pdf_s, pdf[drawn], rtol=1e-5)
    np.testing.assert_allclose(weight[drawn], f_s * (wi[drawn, 2] / pdf_s)[:, None], rtol=1e-4, atol=1e-7)


@wp.kernel
def sample_bent_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    n: wp.vec3,
    wo: wp.vec3,
    front: int,
    u: wp.array2d[float],
    # outputs
    wi: wp.array[wp.vec3],
    weight: wp.array[wp.vec3],
    pdf: wp.array[float],
    delta: wp.array[wp.int32],
):
    """Sample ``i`` of :func:`sample_bsdf` about the geometric normal +Z at shading normal ``n`` turned by
    :func:`keep_reflection_above` (as the shading points' are), viewer ``wo`` on the side ``front``."""
    i = wp.tid()
    s = surface_from(p)
    ng = wp.vec3(0.0, 0.0, 1.0)
    ns = keep_reflection_above(n, ng, wo)
    lobes = lobe_albedos(s, tables, wp.dot(ns, wo))
    b = sample_bsdf(s, tables, lobes, ns, ng, wo, front, u[i, 0], u[i, 1], u[i, 2], u[i, 3])
    wi[i] = b.wi
    weight[i] = b.weight
    pdf[i] = b.pdf
    delta[i] = b.delta


@wp.kernel
def eval_bent_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    n: wp.vec3,
    wo: wp.vec3,
    wi: wp.array[wp.vec3],
    # outputs
    f: wp.array[wp.vec3],
    pdf: wp.array[float],
    cos_i: wp.array[float],
):
    """``(f, pdf)`` of :func:`eval_bsdf` for ``wo, wi[i]`` at the shading normal of :func:`sample_bent_kernel`, and
    ``wi[i]``'s cosine to that normal."""
    i = wp.tid()
    s = surface_from(p)
    ng = wp.vec3(0.0, 0.0, 1.0)
    ns = keep_reflection_above(n, ng, wo)
    fi, pi = eval_bsdf(s, tables, lobe_albedos(s, tables, wp.dot(ns, wo)), ns, ng, wo, wi[i])
    f[i] = fi
    pdf[i] = pi
    cos_i[i] = wp.dot(ns, wi[i])


def sphere_directions(n_theta, n_phi, sub):
    """``(directions, solid angles)`` float64 of the midpoints of a ``(n_theta sub) x (n_phi sub)`` grid over the
    sphere in (theta from +Z, phi), row-major so that ``reshape(n_theta, sub, n_phi, sub)`` gathers each bin."""
    t = (np.arange(n_theta * sub) + 0.5) * (np.pi / (n_theta * sub))
    ph = (np.arange(n_phi * sub) + 0.5) * (2 * np.pi / (n_phi * sub))
    tt, pp = np.meshgrid(t, ph, indexing="ij")
    dirs = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    return dirs, np.sin(tt).ravel() * (np.pi / (n_theta * sub)) * (2 * np.pi / (n_phi * sub))


@pytest.mark.parametrize(
    "surface, tilt, cos_o, front",
    [
        # A dielectric under a rough clearcoat of its own index, the shading normal 30 degrees off the face.
        (dict(roughness=0.5, clearcoat=0.7, clearcoat_roughness=0.4, ior=1.3, clearcoat_ior=1.3), (0.5, 0.2), 0.6, 1),
        # The specular workflow, the normal leaning away from the viewer (kept so that the mirror direction is above).
        (dict(base=(0.3, 0.5, 0.2), specular=0.6, roughness=0.35), (-0.9, 0.3), 0.3, 1),
        # Gold over glass of index 0.7 seen from inside: a third of the draws are delta events.
        (dict(base=(1.0, 0.71, 0.29), metallic=1.0, roughness=0.8, opacity=0.6, ior=0.7), (0.3, -0.4), 0.45, 0),
        # A thin-walled sheet behind a smooth (delta) clearcoat, from the back side.
        (dict(roughness=0.3, opacity=0.5, thin_walled=True, clearcoat=1.0, clearcoat_roughness=0.0), (0.0, 0.6),
         0.8, 0),
        # Roughness 1 everywhere, seen head-on about a tilted normal.
        (dict(metallic=0.5, roughness=1.0, clearcoat=1.0, clearcoat_roughness=1.0), (0.4, 0.4), 1.0, 1),
        # A mirror (delta) dielectric lobe of index 1 (F0 0, white edge) over diffuse, a rough coat of index 2.
        (dict(roughness=0.0, ior=1.0, clearcoat=0.5, clearcoat_roughness=0.5, clearcoat_ior=2.0), (-0.3, 0.0), 0.2, 1),
    ],
)
def test_bent_normals_draw_directions_by_the_pdf_that_integrates_to_their_share(surface, tilt, cos_o, front):
    """At shading normals off the geometric one (as interpolated and mapped normals are), from either side, with glass,
    thin sheets, delta lobes, the specular workflow and indices below 1: the non-delta directions ``sample_bsdf`` draws
    follow ``eval_bsdf``'s pdf (chi-square on (theta, phi) bins about the face normal, the pdf integrated over each
    bin in float64), the pdf integrates to the share of the draws that are neither delta events nor lost below the
    surface (at most 1), and each draw's weight and pdf are ``f cos / pdf`` and the pdf ``eval_bsdf`` gives there."""
    count, n_theta, n_phi, sub = 100_000, 32, 64, 10
    p = params(**surface)
    n = np.array([tilt[0], tilt[1], 1.0]) / math.hypot(1.0, *tilt)
    phi = 2.3  # the viewer's azimuth, away from the tilt's
    wo = np.array([math.sqrt(1.0 - cos_o**2) * math.cos(phi), math.sqrt(1.0 - cos_o**2) * math.sin(phi), cos_o])
    u = wp.array(np.random.default_rng(5).random((count, 4)).astype(np.float32), dtype=float, device="cpu")
    outs = [wp.empty(count, dtype=t, device="cpu") for t in (wp.vec3, wp.vec3, float, wp.int32)]
    tables = ggx_albedo_tables("cpu")
    wp.launch(sample_bent_kernel, count, inputs=[p, tables, wp.vec3(*n), wp.vec3(*wo), front, u], outputs=outs,
              device="cpu")
    wi, weight, pdf, delta = (o.numpy() for o in outs)

    def evaluate_bent(directions):
        out = [wp.empty(len(directions), dtype=t, device="cpu") for t in (wp.vec3, float, float)]
        wp.launch(eval_bent_kernel, len(directions), inputs=[p, tables, wp.vec3(*n), wp.vec3(*wo), vec3s(directions)],
                  outputs=out, device="cpu")
        return [o.numpy().astype(np.float64) for o in out]

    assert np.isfinite(weight).all() and (weight >= 0.0).all() and np.isfinite(pdf).all()
    drawn = (delta == 0) & (pdf > 0.0)
    assert not weight[(delta == 0) & (pdf <= 0.0)].any()  # a draw lost below the surface carries nothing
    theta = np.arccos(np.clip(wi[drawn, 2], -1.0, 1.0))
    phis = np.arctan2(wi[drawn, 1], wi[drawn, 0]) % (2 * np.pi)
    observed = np.histogram2d(theta, phis, bins=[n_theta, n_phi], range=[[0, np.pi], [0, 2 * np.pi]])[0]
    dirs, cells = sphere_directions(n_theta, n_phi, sub)
    _, density, _ = evaluate_bent(dirs)
    probability = (density * cells).reshape(n_theta, sub, n_phi, sub).sum(axis=(1, 3))
    share = drawn.mean()
    assert probability.sum() <= 1.0 + 3e-3
    assert abs(probability.sum() - share) <= 4.0 * math.sqrt(share * (1.0 - share) / count) + 3e-3, share
    p_value, x2, dof = chi2_test(observed, probability * count)
    assert p_value > 1e-3, (x2, dof)

    f_s, pdf_s, cos_s = evaluate_bent(wi[drawn])
    np.testing.assert_allclose(pdf[drawn], pdf_s, rtol=1e-5)
    np.testing.assert_allclose(weight[drawn], f_s * (cos_s / pdf_s)[:, None], rtol=1e-4, atol=1e-7)


def ggx_reference(n, wo, wi, alpha):
    """Float64 ``(f, pdf)`` of a white metal (``F = 1``): ``D G2 / (4 cos_o cos_i)`` and ``G1 D / (4 cos_o)``. The
    vectors are made unit first: ``1 - cos_h^2`` is near ``a^2`` = 1.6e-7, so the 4e-8 by which a float32 unit vector
    misses length 1 would shift it by half."""
    n, wo, wi = (x / np.linalg.norm(x, axis=-1, keepdims=True) for x in (n, wo, wi))
    h = wo + wi
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    cos_o, cos_i, cos_h = ((n * x).sum(-1) for x in (wo, wi, h))
    a2 = alpha * alpha
    d = a2 / (np.pi * (cos_h**2 * (a2 - 1.0) + 1.0) ** 2)

    def lam(c):
        return 0.5 * (np.sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0)

    g1 = 1.0 / (1.0 + lam(cos_o))
    g2 = 1.0 / (1.0 + lam(cos_o) + lam(cos_i))
    return d * g2 / (4.0 * cos_o * cos_i), g1 * d / (4.0 * cos_o)


@pytest.mark.parametrize("roughness", [0.02, 0.03, 0.06])
def test_a_sharp_ggx_lobe_matches_a_float64_evaluation(roughness, np_rng):
    """A white metal (F = 1: f is GGX's D G2 / (4 cos_o cos_i) alone) at roughness just above the mirror threshold,
    under tilted shading normals, for light within a few alphas of the mirror direction. Near the peak
    ``cos_h^2 (a^2 - 1) + 1`` cancelled to rounding noise (D off by up to 2x) and to 0 where ``cos_h`` came out one ulp
    above 1: f and pdf infinite, the sample weight NaN and its path lost (a smooth sphere under a white dome: 0.985
    at roughness 0.02, 0.998 at 0.03)."""
    count = 4000
    alpha = roughness * roughness
    n = np_rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    wo = np_rng.normal(size=(count, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wo *= np.where((wo * n).sum(1) < 0.0, -1.0, 1.0)[:, None]
    wo[: count // 4] = n[: count // 4]  # normal view: the half vector sits on the normal itself
    # A half vector within about three alphas of n; wi its mirror of wo.
    tilt = np_rng.normal(size=(count, 3)) * (alpha * np_rng.random((count, 1)) * 3.0)
    h = n + tilt - (tilt * n).sum(1, keepdims=True) * n
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    wi = 2.0 * (wo * h).sum(1, keepdims=True) * h - wo
    keep = ((wi * n).sum(1) > 0.05) & ((wo * n).sum(1) > 0.05)
    n, wo, wi = n[keep], wo[keep], wi[keep]
    # The float32 directions are what the kernel sees: take the reference at exactly those.
    n, wo, wi = (x.astype(np.float32).astype(np.float64) for x in (n, wo, wi))
    f, pdf = evaluate(params(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=roughness), n, wo, wi)
    f_ref, pdf_ref = ggx_reference(n, wo, wi, alpha)
    assert np.isfinite(f).all() and np.isfinite(pdf).all()
    np.testing.assert_allclose(f[:, 0], f_ref, rtol=0.01)
    np.testing.assert_allclose(pdf, pdf_ref, rtol=0.01)

    # Sampling at the same tilted normals gives finite weights: F G2 / G1 <= 1 for this metal, over the probability
    # E of picking the GGX lobe beside its multiple-scattering lobe (above 0.97 for these lobes at cos_o > 0.05), and
    # the multiple-scattering lobe's table sampler keeps its weights within 1.7 of its albedo 1 - E.
    u = np_rng.random((len(n), 4))
    _, weight, _, _ = sample(params(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=roughness), n, wo, u)
    assert np.isfinite(weight).all()
    assert (weight <= 1.7).all() and (weight >= 0.0).all()


@pytest.mark.parametrize("cos_o", [0.3, 1e-4, 1e-6, 1e-7, 1e-8, 1e-12])
def test_grazing_views_match_a_float64_ggx_lobe(cos_o, np_rng):
    """A clearcoat alone (diffuseColor 0, ior 1 and specular_edge 0: no other lobe; F0 0.04, roughness 0.3, no
    multiple scattering) seen
    at grazing angles: ``f cos_i`` and the pdf against float64 GGX with Schlick's Fresnel, for light from every
    height down to a cosine of 1e-20. Smith's ``Lambda`` was clamped at a cosine of 1e-6, so below it, the viewer's or
    the light's, ``f cos_i`` came out as much too large as the cosine was small (100 times for a viewer at 1e-8, 1e14
    times for light at 1e-20), and ``f`` was infinite where both cosines were 1e-23 or less."""
    count, alpha = 4000, 0.09
    wo = np.array([math.sqrt(1.0 - cos_o * cos_o), 0.0, cos_o])
    wi = np_rng.normal(size=(count, 3))
    wi[:, 2] = np.abs(wi[:, 2])
    wi[: count // 4, 2] = 10.0 ** np_rng.uniform(-20.0, -2.0, count // 4)  # near the horizon
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo, wi = (x.astype(np.float32).astype(np.float64) for x in (wo, wi))  # what the kernel sees
    p = params(base=(0.0, 0.0, 0.0), ior=1.0, roughness=0.5, clearcoat=1.0, clearcoat_roughness=0.3, edge=0.0)
    f, pdf = evaluate(p, (0.0, 0.0, 1.0), wo, wi)
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    fresnel = 0.04 + 0.96 * (1.0 - h @ wo) ** 5
    f_ref, pdf_ref = ggx_reference(np.array([0.0, 0.0, 1.0]), wo[None], wi, alpha)
    assert np.isfinite(f).all() and np.isfinite(pdf).all()
    np.testing.assert_allclose(f[:, 0] * wi[:, 2], fresnel * f_ref * wi[:, 2], rtol=2e-3, atol=1e-30)
    np.testing.assert_allclose(pdf, pdf_ref, rtol=2e-3, atol=1e-30)


def test_a_surface_seen_and_lit_edge_on_stays_finite():
    """Viewer and light both at a cosine of 1e-30 (float32 holds it; ``4 cos_o cos_i`` does not): finite ``f`` and
    pdf for the GGX, multiple-scattering and clearcoat lobes."""
    wo = np.array([[1.0, 0.0, 1e-30]])
    wi = np.array([[-1.0, 0.0, 1e-30], [0.0, 1.0, 1e-30]])
    for p in (params(roughness=0.3), params(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.05, clearcoat=1.0,
                                          clearcoat_roughness=0.5)):
        f, pdf = evaluate(p, (0.0, 0.0, 1.0), wo, wi)
        assert np.isfinite(f).all() and np.isfinite(pdf).all(), (f, pdf)


@wp.kernel
def fresnel_dielectric_kernel(
    cos_i: wp.array[float],
    eta: wp.array[float],
    # outputs
    reflectance: wp.array[float],
):
    """``reflectance[i]``: :func:`fresnel_dielectric` at ``cos_i[i], eta[i]``."""
    i = wp.tid()
    reflectance[i] = fresnel_dielectric(cos_i[i], eta[i])


def test_the_dielectric_fresnel_term_matches_float64_at_every_angle_and_index():
    """Exact Fresnel reflectance against float64 for incidence cosines down to 1e-8 and indices from 1e-20 to 1e20:
    an index-matched interface (eta 1, as ior 1 gives) reflects nothing, also at grazing angles, where ``1 -
    cos^2`` rounded to 1 and made it total internal reflection (everything reflected below a cosine of 2.4e-4)."""
    cos_i = np.array([1.0, 0.7, 0.3, 0.01, 1e-3, 2e-4, 1e-4, 1e-6, 1e-8])
    eta = np.array([1e-20, 1e-3, 0.5, 1.0, 1.0001, 1.5, 1e3, 1e20])
    c, e = (x.ravel() for x in np.meshgrid(cos_i, eta, indexing="ij"))
    c, e = (x.astype(np.float32).astype(np.float64) for x in (c, e))
    out = wp.empty(len(c), dtype=float, device="cpu")
    wp.launch(fresnel_dielectric_kernel, len(c), inputs=[wp.array(c, dtype=float, device="cpu"),
                                                        wp.array(e, dtype=float, device="cpu")],
              outputs=[out], device="cpu")
    cos2_t = c * c + (1.0 - c * c) * (1.0 - 1.0 / (e * e))  # 1 - sin^2 / eta^2 cancels even in float64 at 1e-8
    cos_t = np.sqrt(np.maximum(cos2_t, 0.0))
    r_parl = (e * c - cos_t) / (e * c + cos_t)
    r_perp = (c - e * cos_t) / (c + e * cos_t)
    expected = np.where(cos2_t <= 0.0, 1.0, 0.5 * (r_parl**2 + r_perp**2))
    np.testing.assert_allclose(out.numpy(), expected, rtol=1e-3, atol=1e-6)  # float32 1 - 1 / 1.0001^2: 3e-4


def test_an_index_matched_glass_passes_grazing_light_straight_through(np_rng):
    """Glass of opacity 0 and ior 1 changes no direction: every sample is ``-wo`` with weight 1, down to grazing
    views (it was reflected below a cosine of 2.4e-4)."""
    cos_o = np.array([1.0, 0.5, 0.01, 3e-4, 2e-4, 1e-4, 1e-6, 1e-8], np.float64)
    wo = np.stack([np.sqrt(1.0 - cos_o**2), np.zeros_like(cos_o), cos_o], -1)
    wo = np.repeat(wo, 64, axis=0)
    wi, weight, _, delta = sample(params(opacity=0.0, ior=1.0), (0.0, 0.0, 1.0), wo, np_rng.random((len(wo), 4)))
    assert (delta == 1).all()
    np.testing.assert_allclose(weight, 1.0)
    np.testing.assert_allclose(wi, -wo, atol=1e-6)


@wp.kernel
def sample_bent_glass_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    n: wp.array[wp.vec3],
    wo: wp.array[wp.vec3],
    front: int,
    kept: int,
    u: wp.array2d[float],
    # outputs
    wi: wp.array[wp.vec3],
    weight: wp.array[wp.vec3],
    transmitted: wp.array[wp.int32],
):
    """Sample ``i`` of :func:`sample_bsdf` at shading normal ``n[i]`` (with ``kept``, turned by
    :func:`keep_reflection_above` as the shading points' are) about the geometric normal +Z, viewer ``wo[i]`` on the
    side ``front``."""
    i = wp.tid()
    s = surface_from(p)
    ng = wp.vec3(0.0, 0.0, 1.0)
    ns = n[i]
    if kept == 1:
        ns = keep_reflection_above(ns, ng, wo[i])
    lobes = lobe_albedos(s, tables, wp.dot(ns, wo[i]))
    b = sample_bsdf(s, tables, lobes, ns, ng, wo[i], front, u[i, 0], u[i, 1], u[i, 2], u[i, 3])
    wi[i] = b.wi
    weight[i] = b.weight
    transmitted[i] = b.transmitted


def sample_bent_glass(ior, front, kept, np_rng, count=20_000):
    """``(n, wo, wi, weight, transmitted)`` of clear glass sampled at random shading normals up to 90 degrees from
    the geometric normal +Z and random viewers above it, facing each other (``n . wo > 0``)."""
    unit = np_rng.normal(size=(2, count, 3))
    unit /= np.linalg.norm(unit, axis=-1, keepdims=True)
    unit[..., 2] = np.abs(unit[..., 2])
    n, wo = (x[np.einsum("ij,ij->i", unit[0], unit[1]) > 0.0] for x in unit)
    outs = [wp.empty(len(n), dtype=t, device="cpu") for t in (wp.vec3, wp.vec3, wp.int32)]
    u = wp.array(np_rng.random((len(n), 4)).astype(np.float32), dtype=float, device="cpu")
    wp.launch(sample_bent_glass_kernel, len(n), inputs=[params(opacity=0.0, ior=ior), ggx_albedo_tables("cpu"),
                                                       vec3s(n), vec3s(wo), front, kept, u], outputs=outs,
              device="cpu")
    return (n, wo, *(o.numpy() for o in outs))


@pytest.mark.parametrize("front", [1, 0])
@pytest.mark.parametrize("ior", [1.5, 1.2, 2.4])
def test_glass_about_a_bent_normal_transmits_below_and_reflects_above_the_surface(front, ior, np_rng):
    """Clear glass (opacity 0) at shading normals bent up to 90 degrees from the geometric normal +Z, viewers on both
    sides of the glass: a transmitted sample points below the surface and a reflected one above (the geometric side
    test, in float64). With the normals the shading points use (:func:`keep_reflection_above`) every sample weighs
    1: the interface absorbs nothing. Without it a mirror ray that would go below the surface weighs 0, as the
    opaque mirrors' do. Leaving the glass (``front`` 0), Snell's law about normals tilted towards the viewer sent 1
    in 10 transmitted directions back above the surface."""
    for kept in (1, 0):
        n, wo, wi, weight, transmitted = sample_bent_glass(ior, front, kept, np_rng)
        lit = weight[:, 0] > 0.0
        above = wi[:, 2].astype(np.float64) > 0.0
        assert not (lit & (transmitted == 1) & above).any(), "transmitted above the surface"
        assert not (lit & (transmitted == 0) & ~above).any(), "reflected below the surface"
        assert (transmitted == 1).sum() > len(n) // 20
        np.testing.assert_array_equal(weight[lit], 1.0)
        if kept:
            assert lit.all()
        else:
            mirror_below = 2.0 * np.einsum("ij,ij->i", n, wo) * n[:, 2] - wo[:, 2] <= 1e-6  # reflect(wo, n) . ng
            assert mirror_below[~lit].all()


@wp.kernel
def sheet_samples_kernel(
    p: wp.array[float],
    tables: GgxAlbedo,
    wo: wp.array[wp.vec3],
    front: int,
    whitted: int,
    u: wp.array2d[float],
    # outputs
    wi: wp.array[wp.vec3],
    weight: wp.array[wp.vec3],
    transmitted: wp.array[wp.int32],
):
    """Sample ``i`` of the continuation of a surface at normal +Z (shading and geometric) seen from ``wo[i]`` on the
    side ``front``: :func:`sample_bsdf` with the numbers ``u[i]``, or with ``whitted`` 1 :func:`whitted_continuation`
    with ``u[i, 1]``."""
    i = wp.tid()
    s = surface_from(p)
    n = wp.vec3(0.0, 0.0, 1.0)
    if whitted == 1:
        d, w, t = whitted_continuation(s, tables, n, n, front, wo[i], u[i, 1])
        wi[i] = d
        weight[i] = w
        transmitted[i] = t
    else:
        b = sample_bsdf(s, tables, lobe_albedos(s, tables, wo[i][2]), n, n, wo[i], front, u[i, 0], u[i, 1], u[i, 2],
                        u[i, 3])
        wi[i] = b.wi
        weight[i] = b.weight
        transmitted[i] = b.transmitted


def thin_sheet_reflectance_float64(cos_i, eta):
    """``R' = R + T^2 R / (1 - R^2)`` of a thin dielectric sheet, ``R`` the unpolarised Fresnel reflectance of an
    interface of relative index ``eta`` at incidence ``cos_i`` (s and p amplitudes, float64), ``T = 1 - R``; 1 at
    total internal reflection."""
    cos_i, eta = np.broadcast_arrays(np.asarray(cos_i, np.float64), np.asarray(eta, np.float64))
    cos2_t = 1.0 - (1.0 - cos_i**2) / eta**2
    cos_t = np.sqrt(np.maximum(cos2_t, 0.0))
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r = 0.5 * (r_s**2 + r_p**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        sheet = r + (1.0 - r) ** 2 * r / (1.0 - r**2)
    return np.where(cos2_t <= 0.0, 1.0, sheet)


@pytest.mark.parametrize("whitted", [0, 1])
@pytest.mark.parametrize("front", [1, 0])
@pytest.mark.parametrize("ior", [1.5, 1.33, 2.4, 0.75])
def test_a_thin_walled_sheet_reflects_both_faces_and_passes_the_rest_straight_through(ior, front, whitted):
    """Clear thin-walled glass (opacity 0) seen from either side at five angles, 4000 evenly spread lobe numbers per
    angle: the share of mirror samples is ``R' = R + T^2 R / (1 - R^2)`` (float64 Fresnel, within the grid's step),
    the same from both sides (a sheet has no inside), the rest leave along ``-wo`` (no refraction bend), and every
    sample weighs 1, so ``R' + T' = 1``: the sheet neither absorbs nor adds light. For the path tracer's lobe
    (:func:`sample_bsdf`) and Whitted's continuation. Before thin-walled glass, the sheet refracted (eta 1 / ior
    from the back) as the boundary of a solid."""
    cos_o = np.array([1.0, 0.8, 0.5, 0.2, 0.05])
    per = 4000
    wo = np.stack([np.sqrt(1.0 - cos_o**2), np.zeros_like(cos_o), cos_o], -1)
    wo = np.repeat(wo, per, axis=0)
    u = np.full((len(wo), 4), 0.5)
    u[:, 0] = 0.5  # the glass, not the (absent: opacity 0) opaque lobes
    u[:, 1] = np.tile((np.arange(per) + 0.5) / per, len(cos_o))
    outs = [wp.empty(len(wo), dtype=t, device="cpu") for t in (wp.vec3, wp.vec3, wp.int32)]
    wp.launch(sheet_samples_kernel, len(wo), inputs=[params(opacity=0.0, ior=ior, roughness=0.0, thin_walled=True),
                                                    ggx_albedo_tables("cpu"), vec3s(wo), front, whitted,
                                                    wp.array(u.astype(np.float32), dtype=float, device="cpu")],
              outputs=outs, device="cpu")
    wi, weight, transmitted = (o.numpy() for o in outs)
    np.testing.assert_allclose(weight, 1.0, rtol=1e-6)  # Whitted's reflection: (R' + T') / R' * R' in float32
    through = transmitted == 1
    np.testing.assert_allclose(wi[through], -wo[through], atol=1e-6)
    mirror = wo * np.array([-1.0, -1.0, 1.0])
    np.testing.assert_allclose(wi[~through], mirror[~through], atol=1e-6)
    reflected = (~through).reshape(len(cos_o), per).mean(axis=1)
    np.testing.assert_allclose(reflected, thin_sheet_reflectance_float64(cos_o, ior), atol=1.5 / per)


@wp.kernel
def thin_reflectance_kernel(
    cos_i: wp.array[float],
    eta: wp.array[float],
    # outputs
    reflectance: wp.array[float],
):
    """``reflectance[i]``: :func:`thin_dielectric_reflectance` at ``cos_i[i], eta[i]``."""
    i = wp.tid()
    reflectance[i] = thin_dielectric_reflectance(cos_i[i], eta[i])


def test_the_thin_sheet_reflectance_matches_float64():
    """``R'`` at seven angles and six indices against float64: 0 for an index-matched sheet (ior 1), twice a
    single face's ``R`` over ``1 + R`` otherwise, 1 where an index below 1 reflects everything at the first face."""
    cos_i = np.array([1.0, 0.9, 0.7, 0.5, 0.3, 0.1, 0.01])
    eta = np.array([0.75, 1.0, 1.2, 1.5, 2.4, 10.0])
    c, e = (x.ravel().astype(np.float32).astype(np.float64) for x in np.meshgrid(cos_i, eta, indexing="ij"))
    out = wp.empty(len(c), dtype=float, device="cpu")
    wp.launch(thin_reflectance_kernel, len(c), inputs=[wp.array(c, dtype=float, device="cpu"),
                                                      wp.array(e, dtype=float, device="cpu")],
              outputs=[out], device="cpu")
    np.testing.assert_allclose(out.numpy(), thin_sheet_reflectance_float64(c, e), rtol=1e-4, atol=1e-6)


def test_colours_above_one_give_finite_nonnegative_weights(np_rng):
    """A metal of diffuseColor (3, 1.5, 0.5) (colours above 1 are not refused) at roughness 1: the
    multiple-scattering lobe's colour ``F_avg^2 E_avg / (1 - F_avg (1 - E_avg))`` had a denominator of -0.8."""
    count = 20_000
    cos_o = np_rng.random(count)
    wo = np.stack([np.sqrt(1.0 - cos_o**2), np.zeros(count), cos_o], -1)
    p = params(base=(3.0, 1.5, 0.5), metallic=1.0, roughness=1.0)
    _, weight, pdf, _ = sample(p, (0.0, 0.0, 1.0), wo, np_rng.random((count, 4)))
    assert np.isfinite(weight).all() and np.isfinite(pdf).all()
    assert (weight >= 0.0).all()


@pytest.mark.parametrize("material", [
    dict(base=(0.8, 0.8, 0.8), specular=2.0, roughness=0.5),  # useSpecularWorkflow, specularColor 2
    dict(base=(0.8, 0.8, 0.8), specular=1.3, roughness=0.0),
    dict(base=(3.0, 3.0, 3.0), metallic=0.5, roughness=0.3),  # F0 = mix(0.04, 3, 0.5) = 1.52
])
def test_a_specular_reflectance_above_one_leaves_no_negative_diffuse_lobe(material, np_rng):
    """A BSDF is never negative: where the specular lobe reflects more than all the light (an F0 above 1, which
    inputs above 1 allow), the diffuse lobe below it gets nothing, not ``1 - albedo < 0`` of the light. ``f`` came out
    -0.23 and sample weights down to -2000."""
    count = 20_000
    cos_o = np_rng.random(count)
    wo = np.stack([np.sqrt(1.0 - cos_o**2), np.zeros(count), cos_o], -1)
    p = params(**material)
    _, weight, pdf, _ = sample(p, (0.0, 0.0, 1.0), wo, np_rng.random((count, 4)))
    assert np.isfinite(weight).all() and np.isfinite(pdf).all()
    assert (weight >= 0.0).all(), weight.min()
    wi = np_rng.normal(size=(count, 3))
    wi[:, 2] = np.abs(wi[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    f, density = evaluate(p, (0.0, 0.0, 1.0), wo, wi)
    assert (f >= 0.0).all() and (density >= 0.0).all(), f.min()


def test_the_largest_lobe_number_picks_a_lobe_of_nonzero_weight(np_rng):
    """``u1`` = 0.99999994 (the largest number ``rand01`` gives) picks a lobe for random materials and views. The lobe
    weights' float32 sum can fall one ulp short of 1, and such a ``u1`` took the clearcoat of weight 0: with the
    default clearcoat roughness (0.01, a mirror) its weight was 0 / 0, NaN, for 13% of random materials."""
    count = 20_000
    cos_o = np_rng.random(count)
    wo = np.stack([np.sqrt(1.0 - cos_o**2), np.zeros(count), cos_o], -1)
    u = np_rng.random((count, 4))
    u[:, 1] = 0.99999994
    materials = [((0.7, 0.5, 0.3), 0.0, 0.4), ((1.0, 1.0, 1.0), 0.3, 0.0), ((0.1, 0.9, 0.2), 0.7, 0.8)]
    for base, metallic, roughness in materials:
        _, weight, pdf, _ = sample(params(base=base, metallic=metallic, roughness=roughness), (0.0, 0.0, 1.0), wo, u)
        assert np.isfinite(weight).all() and np.isfinite(pdf).all(), (base, metallic, roughness)
        assert (weight >= 0.0).all()


@wp.kernel
def sample_weights_kernel(
    p: wp.array2d[float],
    tables: GgxAlbedo,
    cos_o: wp.array[float],
    u: wp.array2d[float],
    # outputs
    albedo: wp.array2d[wp.vec3],
    largest: wp.array2d[wp.vec3],
):
    """``albedo[m, k]``: the mean of ``sample_bsdf``'s weights (``f cos / pdf``) for material row ``p[m]`` and a
    viewer at ``cos_o[k]``, over the rows of ``u``: the share of uniform incident light it reflects, per channel;
    ``largest[m, k]`` the largest weight, per channel."""
    m, k = wp.tid()
    s = surface_from(p[m])
    n = wp.vec3(0.0, 0.0, 1.0)
    wo = wp.vec3(wp.sqrt(1.0 - cos_o[k] * cos_o[k]), 0.0, cos_o[k])
    lobes = lobe_albedos(s, tables, cos_o[k])
    total = wp.vec3(0.0)
    top = wp.vec3(0.0)
    for j in range(u.shape[0]):
        weight = sample_bsdf(s, tables, lobes, n, n, wo, 1, u[j, 0], u[j, 1], u[j, 2], u[j, 3]).weight
        total += weight
        top = wp.max(top, weight)
    albedo[m, k] = total / float(u.shape[0])
    largest[m, k] = top


def sample_weights(materials: list[dict], cos_o, np_rng, count=100_000) -> tuple[np.ndarray, np.ndarray]:
    """``(materials, len(cos_o), 3)`` Monte Carlo albedo and largest sample weight of each :func:`params` dict at
    each viewing cosine."""
    rows = np.stack([params(**m).numpy() for m in materials])
    outs = [wp.empty((len(materials), len(cos_o)), dtype=wp.vec3, device="cpu") for _ in range(2)]
    u = wp.array(np_rng.random((count, 4)).astype(np.float32), dtype=float, device="cpu")
    wp.launch(sample_weights_kernel, outs[0].shape, inputs=[wp.array(rows, dtype=float, device="cpu"),
                                                           ggx_albedo_tables("cpu"), wp.array(cos_o, dtype=float,
                                                                                             device="cpu"), u],
              outputs=outs, device="cpu")
    return outs[0].numpy(), outs[1].numpy()


@pytest.mark.parametrize("roughness", [0.05, 0.1, 0.2, 0.5, 0.8, 1.0])
def test_white_surfaces_reflect_all_the_light_at_every_angle(roughness, np_rng):
    """White materials without absorption: a metal, a dielectric (ior 1.5) over white diffuse, the specular
    workflow with specularColor 0.5 over white diffuse, and the dielectric under a rough clearcoat, reflect all the
    light at every viewing angle. The single-scattering GGX lobe lost the light that bounces between microfacets: the
    white metal reflected 0.92 at roughness 0.5 and 0.31 at roughness 1 seen from above; and the layers below a lobe
    got 1 - F, not 1 - the lobe's albedo: the white dielectric reflected 0.69 at roughness 1 seen at cos_o = 0.2,
    0.48 under the rough clearcoat."""
    white = (1.0, 1.0, 1.0)
    materials = [
        dict(base=white, metallic=1.0, roughness=roughness),
        dict(base=white, metallic=0.0, roughness=roughness),
        dict(base=white, specular=0.5, roughness=roughness),
        dict(base=white, metallic=0.0, roughness=roughness, clearcoat=1.0, clearcoat_roughness=roughness),
    ]
    cos_o = np.array([1.0, 0.5, 0.2], np.float32)
    albedo, _ = sample_weights(materials, cos_o, np_rng)
    np.testing.assert_allclose(albedo, 1.0, atol=0.01)


@pytest.mark.parametrize("cos_o", [0.02, 0.1, 0.3, 1.0])
def test_smooth_surfaces_reflect_the_specifications_schlick_fresnel_under_a_white_dome(cos_o, np_rng):
    """Smooth (mirror) lobes over a black base under uniform light reflect Schlick's ``F0 + (F90 - F0) (1 -
    cos_o)^5`` of the UsdPreviewSurface specification, in float64: in the specular workflow ``F0 = specularColor`` and
    ``F90`` white ("Edge color is assumed to be (1.0, 1.0, 1.0)"), as Storm's previewSurface.glslfx and MaterialX's
    graph have it; in the metallic workflow ``F90 = mix(1, diffuseColor, metallic)``. wrt took ``F90 = min(1, 50
    max(F0))``: the default specularColor 0 reflected nothing at grazing views (Storm: 0.9 at cos_o 0.02), and a
    gold metal a white rim (0.83 blue at cos_o 0.02) where its edge is its albedo."""
    black, gold = (0.0, 0.0, 0.0), np.array([1.0, 0.71, 0.29])
    cases = [  # (params, F0, F90)
        (dict(base=black, specular=0.0, roughness=0.0), np.zeros(3), np.ones(3)),
        (dict(base=black, specular=0.01, roughness=0.0), np.full(3, 0.01), np.ones(3)),
        (dict(base=black, specular=0.5, roughness=0.0), np.full(3, 0.5), np.ones(3)),
        (dict(base=tuple(gold), metallic=1.0, roughness=0.0), gold, gold),
    ]
    albedo, _ = sample_weights([c[0] for c in cases], np.array([cos_o], np.float32), np_rng, count=2000)
    m5 = (1.0 - np.float64(np.float32(cos_o))) ** 5
    expected = np.stack([f0 + (f90 - f0) * m5 for _, f0, f90 in cases])
    np.testing.assert_allclose(albedo[:, 0], expected, rtol=2e-4, atol=1e-6)


def grazing_hemisphere(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """``(directions, solid angles)`` float64 of a Gauss-Legendre product rule over the upper hemisphere for a viewer
    at azimuth 0 seen near the horizon: cosines ``mu = s^4`` clustered at the horizon, azimuths ``pi +- pi q^3``
    clustered about the mirror azimuth pi, where a grazing view's lobes are a few ``alpha^2`` wide (an even grid of
    2048 azimuths missed 60% of a roughness-0.1 metal's albedo at ``cos_o`` 1e-3)."""
    t, w = np.polynomial.legendre.leggauss(nodes)
    s, ws = 0.5 * (t + 1.0), 0.5 * w
    mu, d_mu = s**4, 4.0 * s**3 * ws
    half, d_half = np.pi * s**3, 3.0 * np.pi * s**2 * ws  # each half of the azimuths on the same nodes
    phi, d_phi = np.concatenate([np.pi - half, np.pi + half]), np.concatenate([d_half, d_half])
    mm, pp = np.meshgrid(mu, phi, indexing="ij")
    sin = np.sqrt(1.0 - mm**2)
    directions = np.stack([sin * np.cos(pp), sin * np.sin(pp), mm], -1).reshape(-1, 3)
    return directions, (d_mu[:, None] * d_phi[None, :]).ravel()


@pytest.mark.parametrize("roughness", [0.05, 0.3, 1.0])
def test_white_surfaces_seen_at_grazing_angles_reflect_all_the_light_by_quadrature(roughness, np_rng):
    """White lossless surfaces (a metal, a dielectric over white diffuse, the specular workflow, a dielectric under a
    clearcoat of that roughness) seen at ``cos_o`` 1e-4 and 1e-2: ``eval_bsdf``'s ``f cos_i`` integrated in float64
    over the hemisphere (:func:`grazing_hemisphere`) is 1 (the README's "within 1%"; measured within 5e-4), with no
    sampling noise, and its pdf integrates to the share of ``sample_bsdf``'s draws that stay above the surface."""
    white = (1.0, 1.0, 1.0)
    materials = [dict(base=white, metallic=1.0), dict(base=white), dict(base=white, specular=0.5),
                 dict(base=white, clearcoat=1.0, clearcoat_roughness=roughness)]
    directions, solid_angles = grazing_hemisphere(128)
    for material in materials:
        p = params(roughness=roughness, **material)
        for cos_o in (1e-4, 1e-2):
            wo = np.array([math.sqrt(1.0 - cos_o**2), 0.0, cos_o])
            f, density = evaluate(p, (0.0, 0.0, 1.0), wo, directions)
            albedo = (f.astype(np.float64) * (directions[:, 2] * solid_angles)[:, None]).sum(axis=0)
            np.testing.assert_allclose(albedo, 1.0, atol=2e-3, err_msg=f"{material}, cos_o {cos_o}")
            integral = float((density.astype(np.float64) * solid_angles).sum())
            _, _, pdf, delta = sample(p, (0.0, 0.0, 1.0), wo, np_rng.random((40_000, 4)))
            share = float(((delta == 0) & (pdf > 0.0)).mean())
            tolerance = 4.0 * math.sqrt(share * (1.0 - share) / 40_000) + 2e-3
            assert integral <= 1.0 + 1e-3 and abs(integral - share) <= tolerance, (integral, share, material, cos_o)


@pytest.mark.parametrize("roughness", [0.05, 0.3, 1.0])
def test_lobes_without_layers_below_are_reciprocal(roughness, np_rng):
    """Where no layer lies under the specular lobe (a metal, or a black base under a dielectric or specularColor lobe
    of any index, and no clearcoat) the README's layering, which reads ``cos_o`` only, drops out and ``f(wo, wi) =
    f(wi, wo)``: GGX with Fresnel at the half vector and the multiple-scattering lobe ``(1 - E(cos_o)) (1 -
    E(cos_i))`` are symmetric. Random pairs of directions, swapped."""
    count = 2000
    wo, wi = np_rng.normal(size=(2, count, 3))
    wo[:, 2], wi[:, 2] = np.abs(wo[:, 2]) + 0.01, np.abs(wi[:, 2]) + 0.01
    wo, wi = (x / np.linalg.norm(x, axis=1, keepdims=True) for x in (wo, wi))
    for material in [dict(base=(1.0, 0.71, 0.29), metallic=1.0), dict(base=(0.0, 0.0, 0.0), ior=1.5),
                     dict(base=(0.0, 0.0, 0.0), ior=0.7), dict(base=(0.0, 0.0, 0.0), specular=0.3)]:
        p = params(roughness=roughness, **material)
        forward, _ = evaluate(p, (0.0, 0.0, 1.0), wo, wi)  # per row: viewer wo[k], light wi[k]
        backward, _ = evaluate(p, (0.0, 0.0, 1.0), wi, wo)
        np.testing.assert_allclose(forward, backward, rtol=1e-5, atol=1e-9, err_msg=str(material))
        assert (forward >= 0.0).all() and forward.max() > 0.0


def test_white_furnace_over_roughness_specular_color_and_metallic(np_rng):
    """White diffuseColor under a white dome: over a grid of roughness, specularColor (specular workflow) and metallic
    (metallic workflow), with the specification's white grazing reflectance, no material reflects more than the light
    it receives: the mean sample weight is at most 1 within three standard errors of 8 independent batches and the
    albedo table's accuracy (2.5e-3 of float64, :mod:`wrt.microfacet_albedo`; the energy compensation restores what
    the table says a lobe loses)."""
    white = (1.0, 1.0, 1.0)
    materials = []
    for roughness in (0.0, 0.05, 0.2, 0.5, 1.0):
        materials += [dict(base=white, specular=spec, roughness=roughness) for spec in (0.0, 0.04, 0.5, 1.0)]
        materials += [dict(base=white, metallic=metallic, roughness=roughness) for metallic in (0.0, 0.5, 1.0)]
        materials += [dict(base=white, metallic=0.0, ior=1.0, roughness=roughness, clearcoat=1.0,
                            clearcoat_roughness=roughness)]
    cos_o = np.array([1.0, 0.5, 0.1, 0.02], np.float32)
    batches = np.stack([sample_weights(materials, cos_o, np_rng, count=10_000)[0] for _ in range(8)])
    mean = batches.mean(axis=0)
    standard_error = batches.std(axis=0, ddof=1) / math.sqrt(len(batches))
    excess = mean - 1.0 - 3.0 * standard_error - 2.5e-3
    worst = np.unravel_index(excess.argmax(), excess.shape)
    assert excess.max() <= 0.0, (mean[worst], standard_error[worst], materials[worst[0]], cos_o[worst[1]])


def test_no_surface_reflects_more_than_it_receives(np_rng):
    """Random materials of the supported inputs (colours in [0, 1], metallic, both workflows, clearcoat, every
    roughness) at random viewing angles reflect at most the light they receive, in every channel."""
    materials = []
    for _ in range(48):
        materials.append(dict(
            base=tuple(np_rng.random(3)), metallic=float(np_rng.choice([0.0, 1.0, np_rng.random()])),
            roughness=float(np_rng.random()), clearcoat=float(np_rng.choice([0.0, np_rng.random()])),
            clearcoat_roughness=float(np_rng.random()), ior=float(1.0 + np_rng.random()),
            specular=float(np_rng.random()) if np_rng.random() < 0.3 else None))
    cos_o = np.array([1.0, 0.6, 0.3, 0.1], np.float32)
    albedo, _ = sample_weights(materials, cos_o, np_rng, count=40_000)
    worst = np.unravel_index(albedo.argmax(), albedo.shape)
    assert albedo.max() <= 1.01, (albedo.max(), materials[worst[0]], cos_o[worst[1]])


@pytest.mark.parametrize(
    "material, bound",
    [
        (dict(base=(1.0, 1.0, 1.0), metallic=1.0), 3.0),
        (dict(base=(1.0, 0.71, 0.29), metallic=1.0), 3.0),  # gold
        (dict(base=(0.9, 0.6, 0.2), metallic=1.0, clearcoat=1.0), 3.0),
        # Seen at cos_o 0.01, a rough dielectric's GGX lobe reflects 0.08 to 0.12 of the light on average but up to
        # F = 1 at grazing half vectors: its samples there weigh up to 5.6, as before the multiple-scattering lobe
        # had its own sampler (the Fresnel factor is not importance-sampled).
        (dict(base=(1.0, 1.0, 1.0), metallic=0.0), 6.0),
        (dict(base=(0.8, 0.6, 0.4), metallic=0.0, clearcoat=1.0), 6.0),
    ],
)
def test_no_sample_weight_is_a_firefly(material, bound, np_rng):
    """The largest weight ``f cos / pdf`` of ``sample_bsdf`` (as the path tracer uses it) over roughness 0.03 to 1
    (the clearcoat's too) and viewing cosines 0.01 to 1 stays within a small bound. The multiple-scattering lobe of a
    smooth lobe lives in a narrow band of grazing directions; cosine-sampled, a white metal's samples weighed up to
    800 at roughness 0.05 and cos_o 0.01, 68 at roughness 0.1 and cos_o 0.1, 9 at roughness 0.2 and cos_o 0.1 (of
    100 000 samples per view; white pixels on the silhouettes of smooth metals lit indirectly), a gold metal's up to
    1100. The albedo stays at most 1."""
    roughness = [0.03, 0.05, 0.065, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0]
    materials = [dict(material, roughness=r, clearcoat_roughness=r) for r in roughness]
    cos_o = np.array([0.01, 0.03, 0.1, 0.3, 0.6, 1.0], np.float32)
    albedo, largest = sample_weights(materials, cos_o, np_rng, count=20_000)
    worst = np.unravel_index(largest.max(axis=-1).argmax(), largest.shape[:2])
    assert largest.max() <= bound, (largest.max(), roughness[worst[0]], cos_o[worst[1]])
    assert np.isfinite(albedo).all() and (albedo <= 1.02).all()


@wp.kernel
def multiple_scattering_sample_kernel(
    tables: GgxAlbedo,
    roughness: float,
    u: wp.array[float],
    # outputs
    mu: wp.array[float],
):
    """``mu[i]``: the cosine :func:`sample_multiple_scattering_cos` draws from ``u[i]``."""
    i = wp.tid()
    mu[i] = sample_multiple_scattering_cos(tables, roughness, lookup_multiple_scattering_total(tables, roughness), u[i])


@wp.kernel
def multiple_scattering_pdf_kernel(
    tables: GgxAlbedo,
    roughness: float,
    mu: wp.array[float],
    # outputs
    pdf: wp.array[float],
    lobe: wp.array[float],
):
    """``pdf[i]``: :func:`multiple_scattering_pdf` at ``mu[i]``; ``lobe[i]``: the shape of the lobe it samples,
    ``(1 - E(mu)) mu / (pi (1 - E_avg))`` (``f_ms cos`` over ``F_ms (1 - E(mu_o))``; a solid-angle density)."""
    i = wp.tid()
    pdf[i] = multiple_scattering_pdf(tables, roughness, lookup_multiple_scattering_total(tables, roughness), mu[i])
    loss = lookup_ggx_average_loss(tables, roughness)
    lobe[i] = (1.0 - lookup_ggx_albedo(tables, roughness, mu[i])[0]) * mu[i] / (math.pi * loss)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("roughness", [0.03, 0.065, 0.1, 0.3, 0.77, 1.0])
def test_multiple_scattering_directions_follow_their_pdf(roughness, device, np_rng):
    """Cosines drawn by ``sample_multiple_scattering_cos``, binned in ``mu^(1/4)`` (the table's columns; 4 bins per
    column), against the counts ``multiple_scattering_pdf`` predicts (``2 pi int pdf dmu`` over each bin), smooth and
    rough lobes, on and between the table's rows; the pdf integrates to 1 and follows the lobe it samples, so that a
    sample's weight ``f_ms cos / pdf`` is ``F_ms (1 - E(mu_o))`` times at most 1.7 (cosine-weighted: up to 19000 at
    roughness 0.03, 1500 at 0.065, 110 at 0.13)."""
    count, bins, sub = 200_000, 4 * (load_table().shape[1] - 1), 32
    tables = ggx_albedo_tables(device)
    mu = wp.empty(count, dtype=float, device=device)
    u = wp.array(np_rng.random(count).astype(np.float32), dtype=float, device=device)
    wp.launch(multiple_scattering_sample_kernel, count, inputs=[tables, roughness, u], outputs=[mu], device=device)
    observed = np.histogram(mu.numpy() ** 0.25, bins=bins, range=(0.0, 1.0))[0]

    # Midpoint rule in s = mu^(1/4) on sub points per bin: 2 pi pdf(mu) dmu = 2 pi pdf(s^4) 4 s^3 ds.
    s = (np.arange(bins * sub) + 0.5) / (bins * sub)
    pdf, lobe = (wp.empty(len(s), dtype=float, device=device) for _ in range(2))
    wp.launch(multiple_scattering_pdf_kernel, len(s), inputs=[tables, roughness, wp.array((s**4).astype(np.float32),
              dtype=float, device=device)], outputs=[pdf, lobe], device=device)
    pdf, lobe = pdf.numpy().astype(np.float64), lobe.numpy().astype(np.float64)
    probability = (2.0 * np.pi * pdf * 4.0 * s**3 / (bins * sub)).reshape(bins, sub).sum(axis=1)
    assert probability.sum() == pytest.approx(1.0, abs=1e-3)
    p_value, x2, dof = chi2_test(observed, probability * count)
    assert p_value > 1e-3, (x2, dof)

    # The lobe is a density too (the table's 1 - E_avg is its exact average; float32 keeps 2 digits of 1 - E near
    # E = 1 at roughness 0.03); the pdf covers it within 1.7.
    assert (2.0 * np.pi * lobe * 4.0 * s**3 / (bins * sub)).sum() == pytest.approx(1.0, abs=5e-3)
    assert ((lobe <= 0.0) | (pdf > 0.0)).all()
    ratio = lobe[pdf > 0.0] / pdf[pdf > 0.0]
    assert ratio.max() <= 1.7, ratio.max()


@pytest.mark.parametrize("surface", ["mirror", "glass"])
def test_whitted_ends_a_mirror_ray_below_the_geometric_surface(surface):
    """A shading normal bent so far that the mirror direction goes below the geometric face: Whitted's mirror ray
    carries no light there, as the path tracer's (``sample_bsdf`` zeroes it); it went on into the surface. The same
    view about the face normal still reflects. Above or below: float64 numpy."""
    p = params(base=(1, 1, 1), metallic=1.0, roughness=0.0) if surface == "mirror" else params(opacity=0.0,
                                                                                             roughness=0.0)
    ng = np.array([0.0, 0.0, 1.0])
    bent = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
    wo = np.array([-0.2, 0.0, 0.98]) / np.linalg.norm([-0.2, 0.0, 0.98])
    ns = np.stack([bent, ng])
    expected = 2.0 * (ns @ wo)[:, None] * ns - wo  # float64 mirror directions
    assert expected[0] @ ng < 0.0 < expected[1] @ ng and (ns @ wo > 0.0).all()
    wi, weight = (wp.empty(2, dtype=wp.vec3, device="cpu") for _ in range(2))
    wp.launch(whitted_continuation_kernel, 2, inputs=[p, ggx_albedo_tables("cpu"), vec3s(ns), vec3s([ng, ng]),
                                                      vec3s([wo, wo])], outputs=[wi, weight], device="cpu")
    np.testing.assert_allclose(wi.numpy()[1], expected[1], atol=1e-6)
    assert (weight.numpy()[1] > 0.0).all()
    np.testing.assert_array_equal(weight.numpy()[0], 0.0)
