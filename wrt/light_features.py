"""Which costly kinds of light a scene's :class:`wrt.light_sampling.DeviceLights` holds: the key of the shading
kernels' variants.

NVRTC inlines every device function into the kernel that calls it, so the path kernel compiled the draws of every
kind of light whether a scene had one or not (87 s on an H100 host, ``benchmarks/GPU_NOTES.md`` row 90). The light
functions whose size sets that time are built per :class:`LightFeatures` (``..._for(features)`` in
:mod:`wrt.light_sampling`, :mod:`wrt.integrators.emitters`, ``path`` and ``whitted``), their branches for a feature
left out dropped by ``wp.static``, an integrator's kernels for one set of features in a Warp module of their own
(:func:`wrt.integrators.path.features_module`); the Renderer launches the variant of the lights it uploaded
(:func:`light_features` of the host rows the upload is made of: ``wrt.light_table.LightTable.features``). A variant
meets lights of a kind it lacks only if its key was stale: it then draws nothing from them (no wrong memory reads), as
a light it does not have.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class LightFeatures:
    """Coarse flags, those of the largest compile-time savings (a trial on this code: glowing shapes and the lights
    drawn as shapes out -60% of the path module's NVRTC time; shaping and IES out -18%)."""

    shape_lights: bool = True  # glowing analytic shapes, cylinder, line, ellipsoid and elliptic tube lights
    shaping: bool = True  # ShapingAPI cones, focus and IES profiles on analytic lights


ALL_FEATURES = LightFeatures()  # every feature compiled: the module-level kernels, right for any scene
NO_FEATURES = LightFeatures(shape_lights=False, shaping=False)

# LIGHT_* codes (wrt.light_sampling) of the analytic lights drawn through the shapes' code: cylinder, ellipsoid,
# elliptic tube and line. Plain numbers, so that this module needs no Warp import; test_light_features checks them.
SHAPE_LIGHT_KINDS = (4, 8, 9, 10)


def light_features(kinds, shaped, glowing: bool) -> LightFeatures:
    """The features a light table needs whose analytic lights have the LIGHT_* ``kinds`` (those of
    ``DeviceLights.kinds``) and ``shaped`` (per light, whether its cone, focus or IES profile is on:
    ``DeviceLights.shaping[k][3] != 0``), and whose entries hold glowing shapes where ``glowing``. Taken from the
    host rows :func:`wrt.light_table.build_lights` uploads: read back from the device arrays, each upload waited on
    two copies to the host."""
    shape_lights = glowing or bool(np.isin(np.asarray(kinds, np.int32), SHAPE_LIGHT_KINDS).any())
    return LightFeatures(shape_lights=bool(shape_lights), shaping=bool(np.any(shaped)))
