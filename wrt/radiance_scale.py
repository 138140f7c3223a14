"""Emitted radiance scaled by a power of two on the device, so that path estimates and pixel sums stay within float32.

A light's radiance is divided by sampling pdfs (a cosine-sampled dome's ``L / pdf`` is ``pi L / cos``) and summed over
the samples of a pixel in float32: under a dome of 1e38, which float32 holds, as it holds the image of a grey plane
under it (5e37), every sample passed 3.4e38 and was dropped, and the image came out black. Rendering is linear in what
lights and surfaces emit, so the device holds every emitted radiance times a power of two, ``scale``, that brings the
brightest into ``[1, 2)`` where it lies outside ``[2^-64, 2^64]`` (1 otherwise: ordinary scenes keep every bit), and
the image is divided by it, exactly, as a power of two divides.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from .materials import SLOTS, DeviceMaterials
from .textures import HALF_MAX, image_scale

SCALED_BRIGHTEST = 2.0**64  # the brightest emitted radiance the device holds unscaled
SCALED_DIMMEST = 2.0**-64  # and the dimmest brightest one
EMISSIVE_SLOT = SLOTS.index("emissiveColor")


def radiance_scale(brightest: float) -> float:
    """The power of two that brings ``brightest`` (the largest emitted radiance, float64) into ``[1, 2)``, kept a
    normal float32 (as is its inverse); 1 where it lies in ``[SCALED_DIMMEST, SCALED_BRIGHTEST]``, is 0 or is not
    finite."""
    if not (brightest > 0.0 and math.isfinite(brightest)) or SCALED_DIMMEST <= brightest <= SCALED_BRIGHTEST:
        return 1.0
    exponent = math.frexp(brightest)[1] - 1  # brightest in [2^exponent, 2^(exponent + 1))
    return math.ldexp(1.0, -min(max(exponent, -126), 126))


def glow_bounds(materials: list, textures: list) -> np.ndarray:
    """``(M + 2,)`` float64 bound on the radiance each device material (``[default] + materials + [no response]``)
    emits anywhere: its largest ``emissiveColor`` component, or for a texture (of ``textures``, the scene's images)
    ``T |scale| + |bias|``, ``T`` the largest of its images' texels, as stored (:func:`wrt.textures.pack_images`:
    an infinite one is at most 65504 times the image's scale), and its fallback's."""
    bounds = np.zeros(len(materials) + 2)
    largest = {}  # image -> its largest stored texel
    for k, mat in enumerate(materials, start=1):
        tex = mat.textures.get("emissiveColor")
        if tex is None:
            bounds[k] = float(np.max(np.abs(np.asarray(mat.emissive_color, np.float64))))
            continue
        texel = float(np.max(np.abs(np.asarray(tex.fallback, np.float64))))
        for image in [tex.image] if tex.tiles is None else [i for i in np.asarray(tex.tiles) if i >= 0]:
            if image not in largest:
                largest[image] = HALF_MAX * image_scale(textures[image])  # per channel
            texel = np.maximum(texel, largest[image])
        bounds[k] = float(np.max(texel * np.abs(np.asarray(tex.scale, np.float64))
                                 + np.abs(np.asarray(tex.bias, np.float64))))
    return bounds


def scaled_materials(mats: DeviceMaterials, scale: float, device) -> DeviceMaterials:
    """``mats``, or for a ``scale`` other than 1 a copy of it whose emission (constant ``emissiveColor`` and its
    texture bindings' scale and bias) is times ``scale``, the other arrays shared: ``mats`` itself is left as it is
    (a scene's cache holds it)."""
    if scale == 1.0:
        return mats
    out = DeviceMaterials()
    for name in DeviceMaterials.vars:
        setattr(out, name, getattr(mats, name))
    colors = mats.colors.numpy().copy()
    colors[:, 1] *= np.float32(scale)
    out.colors = wp.array(colors, dtype=wp.vec3, device=device)
    emissive = mats.slots.numpy()[:, EMISSIVE_SLOT]
    emissive = emissive[emissive >= 0]
    if len(emissive):
        tex_scale, tex_bias = mats.tex_scale.numpy().copy(), mats.tex_bias.numpy().copy()
        tex_scale[emissive] *= np.float32(scale)
        tex_bias[emissive] *= np.float32(scale)
        out.tex_scale = wp.array(tex_scale, dtype=wp.vec4, device=device)
        out.tex_bias = wp.array(tex_bias, dtype=wp.vec4, device=device)
    return out
