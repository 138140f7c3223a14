"""Light values near float32's range: domes whose colour and texture multiply far from 1, light and camera exposures,
radiance near float32's largest. The oracle is the same scene with its values scaled by powers of two into range (the
image scaled back: exact in float32), or float64 numpy of the expected radiance."""

import numpy as np
from shading_helpers import quad

import wrt

# A dome of two bright bands on black (texels of 10), as test_light_textures' furnace dome
FURNACE_DOME = np.zeros((4, 8, 3), np.float32)
FURNACE_DOME[0, ::2] = 10.0
FURNACE_DOME[2] = 10.0


def dome_lit_plane(dome, width=4, spp=16, integrator="path"):
    """``(H, W, 3)`` radiance of a grey plane facing +Y under ``dome`` (direct light), seen from above."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    img = wrt.render(wrt.Scene(meshes=[plane], lights=[dome]), camera=cam, width=width, height=width, spp=spp,
                     device="cpu", integrator=integrator, max_depth=1)
    return img.rgb


def test_a_dim_texture_under_a_bright_dome_colour_is_sampled_as_its_image():
    """A dome of colour 2^100 whose texels are 2^-100 of the furnace dome's is the same light: its image, drawn with
    the same seed, is the same. The sampling distribution's floor of 1e-8 outweighed texels of 1e-29, and the dome
    was sampled uniformly instead of by its image (1.391 against 1.419)."""
    reference = dome_lit_plane(wrt.DomeLight(color=np.ones(3, np.float32), texture=FURNACE_DOME))
    scaled = wrt.DomeLight(color=np.full(3, 2.0**100, np.float32), texture=FURNACE_DOME * np.float32(2.0**-100))
    np.testing.assert_allclose(dome_lit_plane(scaled), reference, rtol=1e-6)
