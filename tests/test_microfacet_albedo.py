"""The GGX albedo tables of wrt/microfacet_albedo.py: the stored file against the script that makes it, and the
device lookups against the table (bilinear) and its average."""

import sys
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from wrt.microfacet_albedo import GgxAlbedo, ggx_albedo_tables, load_table, lookup_ggx_albedo, lookup_ggx_average_loss

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from make_ggx_albedo import N_MU, N_ROUGHNESS, vndf_albedo  # noqa: E402

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


def test_the_stored_table_is_what_the_generator_makes():
    """Rows of ``wrt/data/ggx_albedo.npy`` recomputed by ``benchmarks/make_ggx_albedo.py`` on a coarser grid (256
    instead of 512 per side: the two agree within 2e-3 at grazing views, 1e-4 elsewhere)."""
    table = load_table()
    assert table.shape == (N_ROUGHNESS, N_MU, 2)
    mu = np.linspace(0.0, 1.0, N_MU) ** 2
    for k in (3, 12, N_ROUGHNESS - 1):
        np.testing.assert_allclose(table[k], vndf_albedo(k / (N_ROUGHNESS - 1), mu, 256), atol=3e-3, err_msg=str(k))
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
    """At the nodes the lookups give the stored values, halfway between rows and columns (in ``sqrt(mu)``) their
    means; and ``1 - E_avg`` is ``2 int (1 - E(mu)) mu dmu`` of what the lookups return, so the
    multiple-scattering lobe gives back exactly what the looked-up ``E`` misses."""
    table = load_table()
    r = np.linspace(0.0, 1.0, N_ROUGHNESS)[:, None]
    s = np.linspace(0.0, 1.0, N_MU)[None, :]
    at_nodes, _ = lookup(device, r, s * s)
    np.testing.assert_allclose(at_nodes.reshape(table.shape), table, atol=1e-6)
    half_r = (r[:-1] + r[1:]) / 2
    half_s = (s[:, :-1] + s[:, 1:]) / 2
    between, _ = lookup(device, half_r, half_s * half_s)
    corners = (table[:-1, :-1] + table[1:, :-1] + table[:-1, 1:] + table[1:, 1:]) / 4
    np.testing.assert_allclose(between.reshape(corners.shape), corners, atol=1e-5)

    # Midpoint rule in mu on 20000 points for a few roughnesses, between and on the rows.
    count = 20_000
    mu = (np.arange(count) + 0.5) / count
    for rough in (0.05, 0.3, 0.5, 0.77, 1.0):
        albedo, loss = lookup(device, rough, mu)
        assert loss[0] == pytest.approx(2.0 * ((1.0 - albedo[:, 0]) * mu).mean(), abs=2e-5)
