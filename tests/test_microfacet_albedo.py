"""The GGX albedo tables of wrt/microfacet_albedo.py: the stored file against the script that makes it, and the
device lookups against the table (bilinear) and its average."""

import sys
from pathlib import Path

import numpy as np
import pytest
import warp as wp
from ggx_albedo_oracle import ggx_albedo

from wrt.bsdf import Surface, lobe_albedos
from wrt.microfacet_albedo import (
    GgxAlbedo,
    ggx_albedo_tables,
    load_table,
    lookup_ggx_albedo,
    lookup_ggx_average_loss,
    table_cosines,
    table_roughness,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from make_ggx_albedo import N_MU, N_ROUGHNESS, vndf_albedo  # noqa: E402

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


def test_the_stored_table_is_what_the_generator_makes():
    """Rows of ``wrt/data/ggx_albedo.npy`` recomputed by ``benchmarks/make_ggx_albedo.py`` on a coarser grid (256
    instead of 512 per side: the two agree within 2e-3 at grazing views, 1e-4 elsewhere)."""
    table = load_table()
    assert table.shape == (N_ROUGHNESS, N_MU, 2)
    mu = table_cosines(N_MU)
    for k in (3, 20, N_ROUGHNESS - 1):
        np.testing.assert_allclose(table[k], vndf_albedo(table_roughness(N_ROUGHNESS)[k], mu, 256), atol=3e-3,
                                   err_msg=str(k))
    # A white lobe keeps at most all the light, and its Schlick-grazing part is a part of it.
    assert (table[..., 0] <= 1.0).all() and (table[..., 1] >= 0.0).all() and (table[..., 1] <= table[..., 0]).all()


@wp.kernel
def lookup_kernel(
    tables: GgxAlbedo,
    roughness: wp.array[float],
    mu: wp.array[float],
    # outputs
    albedo: wp.array[wp.vec2],
    loss: wp.array[float],
):
    """``lookup_ggx_albedo`` and ``lookup_ggx_average_loss`` at ``roughness[i], mu[i]``."""
    i = wp.tid()
    albedo[i] = lookup_ggx_albedo(tables, roughness[i], mu[i])
    loss[i] = lookup_ggx_average_loss(tables, roughness[i])


def lookup(device, roughness, mu):
    roughness, mu = (np.ascontiguousarray(x, np.float32).ravel() for x in np.broadcast_arrays(roughness, mu))
    albedo = wp.empty(len(mu), dtype=wp.vec2, device=device)
    loss = wp.empty(len(mu), dtype=float, device=device)
    wp.launch(lookup_kernel, len(mu), inputs=[ggx_albedo_tables(device), wp.array(roughness, device=device),
                                              wp.array(mu, device=device)], outputs=[albedo, loss], device=device)
    return albedo.numpy(), loss.numpy()


@pytest.mark.parametrize("device", DEVICES)
def test_lookups_are_bilinear_and_the_average_loss_is_theirs(device):
    """At the nodes the lookups give the stored values, halfway between rows and columns (in the rows' coordinate and
    ``mu^(1/4)``) their means; and ``1 - E_avg`` is ``2 int (1 - E(mu)) mu dmu`` of what the lookups return, so the
    multiple-scattering lobe gives back exactly what the looked-up ``E`` misses."""
    table = load_table()
    r = table_roughness(N_ROUGHNESS)[:, None]
    s = np.linspace(0.0, 1.0, N_MU)[None, :]
    at_nodes, _ = lookup(device, r, s**4)
    np.testing.assert_allclose(at_nodes.reshape(table.shape), table, atol=1e-5)
    half_r = table_roughness(2 * N_ROUGHNESS - 1)[1::2, None]  # halfway between the rows in their coordinate
    half_s = (s[:, :-1] + s[:, 1:]) / 2
    between, _ = lookup(device, half_r, half_s**4)
    corners = (table[:-1, :-1] + table[1:, :-1] + table[:-1, 1:] + table[1:, 1:]) / 4
    np.testing.assert_allclose(between.reshape(corners.shape), corners, atol=1e-5)

    # Midpoint rule in mu on 20000 points for a few roughnesses, between and on the rows.
    count = 20_000
    mu = (np.arange(count) + 0.5) / count
    for rough in (0.05, 0.3, 0.5, 0.77, 1.0):
        albedo, loss = lookup(device, rough, mu)
        assert loss[0] == pytest.approx(2.0 * ((1.0 - albedo[:, 0]) * mu).mean(), abs=2e-5)


@wp.kernel
def lobe_albedos_kernel(
    tables: GgxAlbedo,
    f0: wp.vec3,
    roughness: wp.array[float],
    mu: wp.array[float],
    # outputs
    spec: wp.array[wp.vec3],
    spec_ms: wp.array[wp.vec3],
    coat: wp.array[float],
):
    """What ``lobe_albedos`` says a metal of reflectance ``f0`` under a clearcoat, both of ``roughness[i]``, reflects
    towards a viewer at ``mu[i]``: its GGX lobe, its multiple-scattering lobe and the clearcoat (weight 1)."""
    i = wp.tid()
    s = Surface()
    s.base_color = f0
    s.metallic = 1.0
    s.roughness = roughness[i]
    s.opacity = 1.0
    s.ior = 1.5
    s.clearcoat = 1.0
    s.clearcoat_roughness = roughness[i]
    s.clearcoat_ior = 1.5
    s.specular_edge = 1.0  # UsdPreviewSurface's white F90
    lobes = lobe_albedos(s, tables, mu[i])
    spec[i] = lobes.spec
    spec_ms[i] = lobes.spec_ms
    coat[i] = lobes.coat


@pytest.mark.parametrize("device", DEVICES)
def test_white_furnace_of_smooth_lobes_at_grazing_views_matches_a_float64_quadrature(device):
    """White and gold metals and a clearcoat, roughness 0.02 to 1 seen at cosines 1e-4 to 1: the single-scattering
    albedo the table gives (``f0 (E - B) + f90 B``) against a float64 quadrature written from the GGX model
    (``tests/ggx_albedo_oracle.py``), and the white furnace, what the GGX lobe really reflects plus what the
    compensation lobe adds (``1 - E`` looked up) or what the clearcoat leaves to a white base (``1 - C`` looked up),
    at most 1 (2e-3 for the table's interpolation). The 32 x 32 table, rows at roughness k / 31 and columns at ``mu =
    (j / 31)^2``, was off by up to 4% at cosines below 0.01: a white metal at roughness 0.05 reflected 1.023 at
    cosine 1e-4, a clearcoat at roughness 0.02 on white 1.05 at cosine 0.002 and 3% too little at 0.001."""
    roughness = np.array([0.02, 0.025, 0.03, 0.04, 0.05, 0.07, 0.1, 0.2, 0.5, 1.0])
    mu = np.array([1e-4, 3e-4, 1e-3, 2e-3, 5e-3, 1e-2, 0.1, 0.5])
    r, m = (x.ravel() for x in np.meshgrid(roughness, mu, indexing="ij"))
    r32, m32 = r.astype(np.float32), m.astype(np.float32)
    truth = np.array([ggx_albedo(max(float(a) ** 2, 4e-4), float(b), 100) for a, b in zip(r32, m32)])
    e, b = truth[:, :1], truth[:, 1:]
    tables = ggx_albedo_tables(device)
    arrays = [wp.array(x, dtype=float, device=device) for x in (r32, m32)]
    for f0 in ((1.0, 1.0, 1.0), (1.0, 0.71, 0.29)):
        outs = [wp.empty(len(r), dtype=t, device=device) for t in (wp.vec3, wp.vec3, float)]
        wp.launch(lobe_albedos_kernel, len(r), inputs=[tables, wp.vec3(*f0), *arrays], outputs=outs, device=device)
        spec, spec_ms, coat = (o.numpy().astype(np.float64) for o in outs)
        where = [f"roughness {a:g}, mu {c:g}" for a, c in zip(r, m)]
        # Schlick's F over the GGX lobe, f0 (E - B) + f90 B: a metal's f90 is its colour (UsdPreviewSurface), f0 E;
        # the clearcoat's is white, 0.04 (E - B) + B.
        for got, want in ((spec, np.asarray(f0) * e), (coat, 0.04 * (e - b) + b)):
            error = np.abs(got.reshape(len(r), -1) - want).max(axis=1)
            assert error.max() <= 3e-3, (f0, error.max(), where[error.argmax()])
        if f0 == (1.0, 1.0, 1.0):
            metal = e[:, 0] + spec_ms[:, 0]
            coated = (0.04 * (e - b) + b)[:, 0] + 1.0 - coat
            for furnace in (metal, coated):
                assert furnace.max() <= 1.002, (furnace.max(), where[furnace.argmax()])
