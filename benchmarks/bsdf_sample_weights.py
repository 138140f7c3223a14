"""The largest sample weights ``f cos / pdf`` of ``wrt.bsdf.sample_bsdf``, as the path tracer uses them, over a grid
of materials, roughness and viewing cosines: a weight far above the albedo is a firefly (one bright pixel at a few
dozen samples per pixel). Each sample is also credited to the lobe that ``u1`` picked (diffuse, GGX, the
multiple-scattering lobe, clearcoat), so a large weight can be traced to the lobe that drew it; a direction drawn by
one lobe is weighted by the whole mixture's pdf, so a lobe that samples its own shape badly also raises the others'.

Usage: ``python benchmarks/bsdf_sample_weights.py [--samples 100000]`` (CPU, about 30 s with the kernel compiled).
Results: ``benchmarks/RESULTS.md``, "BSDF sample weights".
"""

import argparse

import numpy as np
import warp as wp

from wrt.bsdf import Surface, lobe_albedos, sample_bsdf
from wrt.microfacet_albedo import GgxAlbedo, ggx_albedo_tables

LOBES = ("diffuse", "ggx", "ms", "coat")  # wrt.bsdf.lobe_weights' order
MATERIALS = {  # name -> (diffuseColor, metallic, clearcoat); the clearcoat's roughness is the base's
    "white metal": ((1.0, 1.0, 1.0), 1.0, 0.0),
    "gold metal": ((1.0, 0.71, 0.29), 1.0, 0.0),
    "dielectric on white diffuse": ((1.0, 1.0, 1.0), 0.0, 0.0),
    "dielectric on red diffuse": ((0.8, 0.1, 0.1), 0.0, 0.0),
    "clearcoat on dielectric": ((0.8, 0.6, 0.4), 0.0, 1.0),
    "clearcoat on metal": ((0.9, 0.6, 0.2), 1.0, 1.0),
}
ROUGHNESS = (0.021, 0.03, 0.05, 0.065, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7, 1.0)
COS_O = (0.01, 0.03, 0.1, 0.3, 0.6, 1.0)


@wp.kernel
def largest_weights_kernel(
    base: wp.array[wp.vec3],
    metallic: wp.array[float],
    clearcoat: wp.array[float],
    roughness: wp.array[float],
    tables: GgxAlbedo,
    cos_o: wp.array[float],
    u: wp.array2d[float],
    # outputs
    largest: wp.array3d[float],
):
    """``largest[m, k, lobe]``: the largest channel of ``sample_bsdf``'s weight for material ``m`` seen at
    ``cos_o[k]`` over the rows of ``u``, among the samples whose ``u1`` picked ``lobe``."""
    m, k = wp.tid()
    s = Surface()
    s.base_color = base[m]
    s.metallic = metallic[m]
    s.roughness = roughness[m]
    s.opacity = 1.0
    s.ior = 1.5
    s.clearcoat = clearcoat[m]
    s.clearcoat_roughness = roughness[m]
    s.clearcoat_ior = 1.5
    s.specular_edge = 1.0  # UsdPreviewSurface's white F90
    n = wp.vec3(0.0, 0.0, 1.0)
    wo = wp.vec3(wp.sqrt(1.0 - cos_o[k] * cos_o[k]), 0.0, cos_o[k])
    lobes = lobe_albedos(s, tables, cos_o[k])
    w = lobes.weights
    for j in range(u.shape[0]):
        weight = sample_bsdf(s, tables, lobes, n, n, wo, 1, u[j, 0], u[j, 1], u[j, 2], u[j, 3]).weight
        lobe = int(3)
        if u[j, 1] < w[0]:
            lobe = 0
        elif u[j, 1] < w[0] + w[1]:
            lobe = 1
        elif u[j, 1] < w[0] + w[1] + w[2]:
            lobe = 2
        largest[m, k, lobe] = wp.max(largest[m, k, lobe], wp.max(weight[0], wp.max(weight[1], weight[2])))


def largest_weights(samples: int, seed: int = 5) -> np.ndarray:
    """``(materials, roughness, cos_o, lobes)`` largest weights."""
    rows = [(c, m, k, r) for c, m, k in MATERIALS.values() for r in ROUGHNESS]
    base, metallic, clearcoat, roughness = (np.array(x, np.float32) for x in zip(*rows))
    u = np.random.default_rng(seed).random((samples, 4)).astype(np.float32)
    out = wp.zeros((len(rows), len(COS_O), len(LOBES)), dtype=float, device="cpu")
    wp.launch(largest_weights_kernel, out.shape[:2], inputs=[
        wp.array(base, dtype=wp.vec3, device="cpu"), wp.array(metallic, device="cpu"),
        wp.array(clearcoat, device="cpu"), wp.array(roughness, device="cpu"), ggx_albedo_tables("cpu"),
        wp.array(np.array(COS_O, np.float32), device="cpu"), wp.array(u, device="cpu")], outputs=[out], device="cpu")
    return out.numpy().reshape(len(MATERIALS), len(ROUGHNESS), len(COS_O), len(LOBES))


def main():
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--samples", type=int, default=100_000, help="samples per material and viewing cosine")
    args = parser.parse_args()
    weights = largest_weights(args.samples)
    print(f"largest f cos / pdf (largest channel) of {args.samples} samples per cell")
    for name, per_material in zip(MATERIALS, weights):
        print(f"\n{name}: cos_o " + " ".join(f"{c:>7}" for c in COS_O) + " | by lobe " +
              " ".join(f"{lobe:>7}" for lobe in LOBES))
        for r, row in zip(ROUGHNESS, per_material):
            print(f"  roughness {r:5.3f}   " + " ".join(f"{x:7.2f}" for x in row.max(-1)) + " |         " +
                  " ".join(f"{x:7.2f}" for x in row.max(0)))


if __name__ == "__main__":
    main()
