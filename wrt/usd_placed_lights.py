"""The lights of one UsdLux light prim inside a PointInstancer's prototype, one per instance: the prim is read from USD
once (:func:`wrt.usd_lights.read_light` at one instance's transform) and that light is copied to the other instances,
each with its own transform applied. Read one by one, each instance took about 1 ms (10,000 lamps: 10 s and more).

A copy is exactly the light :func:`read_light` makes at that instance's transform: its sizes, colour, shaping, links,
texture and warnings do not depend on the transform, and what does (position, radius or ellipsoid frame, axis, area)
is computed with the same numpy operations. Instances whose transform changes more than that are read on their own
as before: a transform not affine, or beyond float32; one that a sphere light's shape (round or an ellipsoid) is not
clear under (told apart in numpy with a margin, so that a transform near a limit is read on its own), or that flattens
the sphere or a cylinder light; a normalized light it makes too small for its radiance to fit in float32; and lights
of other kinds (dome, distant).
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

from .affine_lights import FLAT_RATIO
from .light_shaping import Shaping, primary_axis, x_axis, y_axis
from .lights import CylinderLight, DiskLight, RectLight, SphereLight, round_tube
from .usd_lights import fits_float32

PLACED_KINDS = (SphereLight, RectLight, DiskLight, CylinderLight)  # the kinds copied; others are read per instance
MARGIN = 0.9  # factor on the tolerances of affine_lights.similar and flat by which a copy's shape must be clear
# (numpy's batched and single-matrix sums differ by rounding at most, far below 10%)
LARGEST = 1e38  # transforms and radii below this are finite in float32 as check_fields asks, with room for rounding


def placed_lights(to_worlds: np.ndarray, names: list[str], read, skip_path, sphere_inputs) -> list:
    """The light of one prototype light prim at each instance, in instance order (None where it is skipped).

    Args:
        to_worlds: ``(K, 4, 4)`` float64 column-vector local-to-world transforms, one per instance.
        names: ``K`` paths the lights are named by (warnings name them too).
        read: ``read(to_world, skip)``: :func:`wrt.usd_lights.read_light` of the prim at ``to_world`` (a ``(4, 4)``
            row of ``to_worlds``), warnings through ``skip(reason, prim, detail=None)``.
        skip_path: ``skip_path(reason, name, detail)`` records a warning about the light named ``name``.
        sphere_inputs: ``sphere_inputs()``: a SphereLight prim's ``(radius, treatAsPoint)`` as authored (read_light
            scales the radius by the transform, and makes the light a point where it comes to 0).
    """
    to_worlds = np.asarray(to_worlds, np.float64)
    if not len(to_worlds):  # a light with no instances places none
        return []

    def read_one(k: int):
        light = read(to_worlds[k], lambda reason, _, detail=None: skip_path(reason, names[k], detail))
        if light is not None:
            light.path = names[k]
        return light

    template, warned, shapes, sphere = _template(read, to_worlds, sphere_inputs)
    if template is None:  # skipped, or of a kind not copied: every instance is read on its own, each warned about
        return [read_one(k) for k in range(len(to_worlds))]
    lights = []
    for k in range(len(to_worlds)):
        light = _placed(template, to_worlds[k], shapes[k], sphere) if shapes[k] else None
        if light is None:
            lights.append(read_one(k))
            continue
        for reason, detail in warned:
            skip_path(reason, names[k], detail)
        light.path = names[k]
        lights.append(light)
    return lights


def _template(read, to_worlds: np.ndarray, sphere_inputs) -> tuple:
    """``(light, warnings, shapes, sphere)``: the light read at the first instance that places as a copy (its
    warnings ``(reason, detail)`` recorded: none of them is about the transform there), each instance's shape
    (:func:`_shapes`) and a sphere light's authored ``(radius, treatAsPoint)``; ``(None, [], None, None)`` where the
    light is skipped or of a kind not copied, or no instance places as a copy."""
    plain = _plain_rows(to_worlds)
    first = int(np.argmax(plain))
    for _ in range(2):  # the shapes are known once the kind is: at most one more read
        if not plain[first]:
            break
        warned = []
        light = read(to_worlds[first], lambda reason, _, detail=None: warned.append((reason, detail)))
        if not isinstance(light, PLACED_KINDS):
            break
        shapes = np.where(plain, _shapes(type(light), to_worlds[:, :3, :3]), 0)
        sphere = sphere_inputs() if isinstance(light, SphereLight) else None
        if shapes[first] and _placed(light, to_worlds[first], shapes[first], sphere) is not None:
            return light, warned, shapes, sphere
        if shapes[first] or not shapes.any():
            break  # the light there is not what a copy would be (too small for float32, a flattened tube)
        first = int(np.argmax(shapes > 0))
    return None, [], None, None


def _plain_rows(to_worlds: np.ndarray) -> np.ndarray:
    """``(K,)`` bool: transforms whose bottom row is exactly ``(0, 0, 0, 1)`` (read_light keeps them as they are)
    and whose entries are finite in float32."""
    bottom = np.all(to_worlds[:, 3] == (0.0, 0.0, 0.0, 1.0), axis=1)
    with np.errstate(invalid="ignore"):
        small = np.all(np.abs(to_worlds) < LARGEST, axis=(1, 2))
    return bottom & small


ROUND, ELLIPSOID = 1, 2  # shapes of a sphere light's copy (0: read on its own)


def _shapes(kind: type, m3: np.ndarray) -> np.ndarray:
    """``(K,)`` int: for sphere lights :data:`ROUND` where linear part ``m3[k]`` (``(K, 3, 3)``) turns and scales
    evenly (``affine_lights.similar``, held with :data:`MARGIN` to spare), :data:`ELLIPSOID` where it clearly does
    not and does not flatten the sphere (``affine_lights.flat``, with the same margin), 0 in between (read on its own);
    1 for the other kinds, whose copies decide the rest exactly (:func:`_placed`)."""
    if kind is not SphereLight:
        return np.ones(len(m3), np.int32)
    lengths = np.linalg.norm(m3, axis=1)  # (K, 3) column lengths
    mean = np.abs(lengths.mean(axis=1, keepdims=True))

    def similar(rtol: float) -> np.ndarray:
        even = np.all(np.abs(lengths - mean) <= rtol * mean, axis=1)  # relative alone, as affine_lights.similar
        return even & _right_angled(m3, lengths, rtol)

    with np.errstate(invalid="ignore"):
        s = np.linalg.svd(m3, compute_uv=False)
        solid = np.all(np.isfinite(s), axis=1) & (s[:, -1] > FLAT_RATIO * s[:, 0] / MARGIN)
    shapes = np.zeros(len(m3), np.int32)
    shapes[~similar(1e-4 / MARGIN) & solid] = ELLIPSOID
    shapes[similar(1e-4 * MARGIN)] = ROUND
    return shapes


def _right_angled(m3: np.ndarray, lengths: np.ndarray, rtol: float) -> np.ndarray:
    """``(K,)`` bool: the three columns of each of ``m3`` are at right angles (``affine_lights.right_angled``)."""
    ok = np.ones(len(m3), bool)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        dot = np.einsum("kr,kr->k", m3[:, :, i], m3[:, :, j])
        ok &= np.abs(dot) <= rtol * lengths[:, i] * lengths[:, j]
    return ok


def _placed(template, m: np.ndarray, shape: int, sphere: tuple | None):
    """A copy of ``template`` at column-vector transform ``m`` (``(4, 4)``, a plain row of :func:`_plain_rows`
    of ``shape``, :func:`_shapes`), as read_light makes it there; None where that light would differ from a copy
    (a sphere whose scaled radius is past float32, a normalized light too small for its radiance, a flattened
    tube). ``sphere``: a sphere light's authored ``(radius, treatAsPoint)``."""
    light = copy.copy(template)
    for field in dataclasses.fields(light):  # arrays and shaping of its own, as a light read on its own has
        value = getattr(light, field.name)
        if isinstance(value, np.ndarray) and field.name != "texture":  # one image per file: LightTextures
            setattr(light, field.name, value.copy())
        elif isinstance(value, Shaping):
            shaping = copy.copy(value)
            shaping.focus_tint = np.array(value.focus_tint, copy=True)
            light.shaping = shaping
    m3 = m[:3, :3].copy()
    if isinstance(light, SphereLight):
        # As usd_lights._read_kind reads it: a round sphere of the world radius, or an ellipsoid (its local radius
        # and frame); a point where the radius is 0.
        radius, treat = sphere
        light.frame = None
        if shape == ROUND:
            radius = radius * float(np.mean(np.linalg.norm(m3, axis=0)))
        else:
            light.frame = m3
        if not radius < LARGEST:
            return None
        light.position, light.radius, light.treat_as_point = m[:3, 3].copy(), radius, treat or radius <= 0.0
        if light.shaping is not None:
            light.axis = primary_axis(m, np.array([0.0, 0.0, -1.0]))
            light.x_axis = x_axis(m, np.array([1.0, 0.0, 0.0]))
            light.y_axis = y_axis(m)
    else:
        light.to_world = m.copy()
    if isinstance(light, CylinderLight) and light.length > 0.0 and light.radius > 0.0 and not light.treat_as_line:
        if not round_tube(m3) and light.tube() is None:  # flattened: read_light warns
            return None
    if light.normalize and not (isinstance(light, SphereLight) and light.treat_as_point
                                or isinstance(light, CylinderLight) and light.treat_as_line):
        area = light.area  # usd_lights._tiny_normalized: the lights it changes are read on their own
        if not (area > 0.0 and np.all(np.isfinite(light.radiance))):
            return None
    if not fits_float32(light):  # read on its own, to be skipped with read_light's warning
        return None
    return light
