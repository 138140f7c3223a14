"""Reading UsdLux light prims into the host-side lights of :mod:`wrt.lights` (their radiometry lives there; the
device side in :mod:`wrt.light_table` and :mod:`wrt.light_sampling`)."""

from __future__ import annotations

import math
import os

import numpy as np

from .affine_lights import flat, similar
from .color_spaces import linear_colors
from .errors import SceneError
from .light_links import read_collection
from .light_shaping import Shaping, primary_axis, read_shaping, x_axis, y_axis
from .lights import (
    GLOW_TINTS_LIGHT,
    MATERIAL_SYNC_MODES,
    NO_MATERIAL_RESPONSE,
    CylinderLight,
    DiskLight,
    DomeLight,
    MeshLight,
    RectLight,
    SphereLight,
    light_axes,
    round_tube,
)
from .scene import DistantLight
from .usd_xforms import affine_part

FLOAT32_MAX = float(np.finfo(np.float32).max)
FLOAT32_TINY = float(np.finfo(np.float32).tiny)  # the smallest normal float32 (1.2e-38)
INPUTS_PREFIX = "inputs:"  # UsdLux attributes carry it since USD 21.05; older files author the bare names
POLE_AXES = ("scene", "Y", "Z")  # DomeLight_1's allowedTokens for poleAxis
SHADER_ID = "light:shaderId"  # UsdLuxLightAPI's shader id; "<renderContext>:light:shaderId" for one renderer
# UsdLux lights of a purpose not drawn (guide, proxy) light all the same, as Hydra's renderers light them (they give
# lights no purpose; OpenUSD issue 3059), though UsdGeom says such a prim is not rendered: named in a warning.
UNRENDERED_PURPOSE = ("UsdLux lights of a purpose the render does not draw light the scene all the same, as Hydra's "
                      "renderers light them (UsdGeom would leave such a prim out)")
ANGLE_CLIP = 360.0  # a DistantLight's largest angle (UsdLux: 0 <= angle < 360), the whole sphere
MISTYPED_FLAGS = ("light switches authored with a type that is not bool (a string normalize) were read as the "
                  "schema's fallback, as USD's typed readers read them")


def read_light(prim, xforms, time, up_axis: str, skip, to_world=None, textures=None):
    """The light of a ``UsdLux`` light prim, or None (recorded through ``skip``) for unsupported kinds.

    Args:
        prim: a prim with ``UsdLux.LightAPI``.
        xforms: a ``UsdGeom.XformCache`` at ``time``.
        time: ``Usd.TimeCode``.
        up_axis: the stage's up axis, for ``DomeLight_1``'s ``poleAxis``.
        skip: ``skip(reason, prim, detail=None)``.
        to_world: ``(4, 4)`` float64 column-vector local-to-world transform placing the light (one instance of a
            PointInstancer's prototype), or None: the prim's own world transform.
        textures: a :class:`LightTextures` kept over one load: each texture file is read once, and the lights that
            name it share its image; None: read here.
    """
    get, legacy, mistyped, unevaluated, read_from = input_reader(prim, time)
    if to_world is None:
        to_world = np.array(xforms.GetLocalToWorldTransform(prim), dtype=np.float64).T  # column-vector convention
    result = _read_light(prim, to_world, time, up_axis, skip, get, LightTextures() if textures is None else textures,
                         read_from)
    if legacy:
        skip("light attributes without the inputs: prefix (UsdLux's names before it had one) were read as their "
             "inputs: attributes", prim, ", ".join(legacy))
    if unevaluated:
        skip("light inputs connected to a shading network (a shader's output) are read as authored on the light, as "
             "Storm reads them: wrt evaluates no light shaders", prim, ", ".join(unevaluated))
    if mistyped:
        skip("light inputs authored with another type than the schema's were read as USD's typed readers read them "
             "(a weaker opinion of the schema's type, else the schema's fallback)", prim, ", ".join(mistyped))
    return result


def input_reader(prim, time):
    """``(get, legacy, mistyped, unevaluated, read_from)``: ``get(attr, default)`` reads a light input of ``prim`` at
    ``time``
    (``default`` where it has no value), ``legacy`` lists the names it read without their ``inputs:`` prefix, for one
    warning, and ``mistyped`` the inputs it read authored with another type than the schema's (``double
    inputs:radius = 3``), which it reads as USD's typed readers do (:func:`wrt.usd_values.schema_typed_value`: a
    SphereLight of radius 0.5 to its extent and to Hydra, of radius 3 to wrt before); bool switches are
    :func:`flag`'s. An input connected to another prim (a light rig's NodeGraph) is read from the input its
    connections lead to (:func:`connected_source`); ``unevaluated`` names those connected to a shader's output.
    ``read_from`` maps an input's name to the attribute whose authored value ``get`` read (the input, the one its
    connections lead to, or its old unprefixed name), for its colour space."""
    from pxr import Sdf

    from .usd_values import read_time, schema_typed_value

    legacy, mistyped, unevaluated, read_from = [], [], [], {}
    # Names with scene description: an old name with an authored value is one of them (a schema's fallback is none).
    authored = set(prim.GetAuthoredPropertyNames())

    def get(attr, default):
        # Files written before UsdLux prefixed its inputs (Omniverse and Isaac Sim content of that time) author
        # "intensity", "radius", "texture:file" ...: USD no longer reads them, so such a light came out at the
        # schema's fallbacks (intensity 1, white, radius 0.5) without a word. The old name counts when the
        # prefixed one is not authored, as Omniverse's renderers still read it.
        name = attr.GetName() if attr is not None else ""
        if name in authored and attr.HasAuthoredConnections():  # a connection, not the light's own value, counts
            attr = connected_source(attr, unevaluated)
        has_value = bool(attr) and attr.HasAuthoredValue()
        if name.startswith(INPUTS_PREFIX) and not has_value:
            # An old name with no scene description has no authored value (most lights): not asked for.
            old_name = name[len(INPUTS_PREFIX):]
            old = prim.GetAttribute(old_name) if old_name in authored else None
            if old and old.HasAuthoredValue():
                if old.GetName() not in legacy:
                    legacy.append(old.GetName())
                attr, has_value = old, True
        if not attr:
            return default
        if has_value:
            read_from[name] = attr
        if has_value and attr.GetTypeName() != Sdf.ValueTypeNames.Bool:
            value, wrong = schema_typed_value(attr, time)
            if wrong is not None and wrong not in mistyped:
                mistyped.append(wrong)
            return default if value is None else value
        # value_at(attr, time), its HasAuthoredValue known: read_time only where it can matter.
        value = attr.Get(read_time(attr, time) if has_value else time)
        if value is None:  # a value block (= None) resolves to the schema's fallback, as USD's value resolution says:
            # a blocked DistantLight intensity was 1, not 50000 (an old unprefixed name has no fallback: default)
            value = prim.GetPrimDefinition().GetAttributeFallbackValue(attr.GetName())
        return default if value is None else value

    return get, legacy, mistyped, unevaluated, read_from


def connected_source(attr, unevaluated: list):
    """The attribute whose value light input ``attr`` (of authored connections) takes: the first input with a value
    that its connections lead to (``UsdShade.Input.GetValueProducingAttributes``: a light rig's NodeGraph input), as
    Hydra 2's UsdImaging reads a light's parameters; ``attr`` itself where they lead to none, or to a shader's output
    only (a shading network, which wrt does not evaluate: named in ``unevaluated``, as Storm reads it). Such a light
    was read as authored on itself: a rig's intensity of 5 lit as the light's own fallback of 1."""
    from pxr import UsdShade

    sources = UsdShade.Input(attr).GetValueProducingAttributes()
    for source in sources:
        if UsdShade.Utils.GetType(source.GetName()) == UsdShade.AttributeType.Input:
            return source
    if sources:
        words = f"{attr.GetName()} <- {sources[0].GetPath()}"
        if words not in unevaluated:
            unevaluated.append(words)
    return attr


def sphere_inputs(prim, time) -> tuple[float, bool]:
    """``(radius, treatAsPoint)`` of SphereLight ``prim`` as authored at ``time`` (a radius :func:`read_light` takes:
    it reads the prim first)."""
    from pxr import UsdLux

    get, *_ = input_reader(prim, time)
    light = UsdLux.SphereLight(prim)
    return float(get(light.GetRadiusAttr(), 0.5)), flag(get, light.GetTreatAsPointAttr(), False)


def flag(get, attr, fallback: bool, warn=None) -> bool:
    """A bool light input read with ``get`` (:func:`input_reader`), or its schema's ``fallback`` where it is authored
    with another type (``string inputs:normalize = "yes"``, an ``int`` or a ``token``): USD's typed readers
    (``Get<bool>``, which Hydra and UsdImaging use) fail on such a value and read the fallback, where Python's truth
    of the text turned ``"no"`` on. USD hands a bool-typed value to Python as a ``bool`` and nothing else does, so
    the value's Python type tells the authored one, also for an old unprefixed name. ``warn(detail)`` is told of
    each such input."""
    value = get(attr, fallback)
    if isinstance(value, bool):
        return value
    if warn is not None:
        warn(f"{attr.GetName()} = {value!r}")
    return fallback


class LightTextures:
    """The images of light textures, each file read once (``memory``: ``(resolved path, colour space)`` -> image, or
    the :class:`wrt.textures.TextureError` that reading it raised). A textured RectLight in a PointInstancer's
    prototype was read from disk once per instance (10,000 lamps, 10,000 reads of one file).

    Args:
        kept: a kept stage's :class:`wrt.usd_material_memo.MaterialMemo`, whose ``image`` decodes each file once
            for every frame while the file is unchanged (a dome's image was decoded at every frame), and keeps the
            lat-long map a dome's image is resampled to beside it (:meth:`latlong`), or None.
    """

    def __init__(self, kept=None):
        self.memory = {}
        self.kept = kept
        self.latlongs = {}  # (resolved path, layout) -> the lat-long image of a dome's texture, for this load
        self.dark = {}  # resolved path -> what of its colour cannot be emitted ("" for none), counted once per load
        self.profiles = {}  # resolved path -> its IES profile (or the IesError reading it), read once per load
        self.notes = {}  # (resolved path, colour space) -> what its read warned of (TextureWarning words)

    def latlong(self, resolved: str, image, fmt: str):
        """The lat-long image of ``image`` (:meth:`load` of ``resolved``) laid out as ``fmt``
        (:func:`wrt.dome_formats.to_latlong`), resampled once per load, and once for all the frames of a kept stage
        while the file is unchanged: about a second for a 1k angular map, at every frame before."""
        from . import dome_formats

        key = (resolved, fmt)
        if key not in self.latlongs:
            def resample():
                return dome_formats.to_latlong(image, fmt)

            self.latlongs[key] = resample() if self.kept is None else self.kept.derived(
                resolved, "auto", image, ("latlong", fmt), resample)
        return self.latlongs[key]

    def load(self, resolved: str, color_space: str = "auto"):
        """The image at ``resolved`` (:func:`wrt.textures.load_image`); raises its ``TextureError`` again for a
        file that could not be read. What the read warned of is kept in :attr:`notes`, for each light reading the
        file to name."""
        from .textures import TextureError, load_image

        key = (resolved, color_space)
        if key not in self.memory:
            told = self.notes.setdefault(key, [])

            def read(path, space):
                return load_image(path, space, told.append)

            try:
                if self.kept is None:
                    self.memory[key] = read(resolved, color_space)
                else:
                    self.memory[key] = image = self.kept.image(resolved, color_space, read)
                    # kept with the pixels, as MaterialReader keeps it: told by a later load taking them too
                    told[:] = self.kept.derived(resolved, color_space, image, "notes",
                                                lambda: np.array(told, dtype=object))
            except TextureError as e:
                self.memory[key] = e
        found = self.memory[key]
        if isinstance(found, TextureError):
            raise TextureError(str(found))
        return found


def warn_glowless_mesh_light(light: MeshLight, prim, mesh, materials, skip) -> None:
    """Names ``prim`` through ``skip`` when its mesh light ``light`` (drawn as ``mesh``, a :class:`wrt.Mesh`) is of
    ``materialGlowTintsLight`` and the material bound to it (``materials``: a :class:`wrt.materials.MaterialReader`)
    does not glow: it emits nothing. How the light and the material relate otherwise is settled where the lights
    are built, for scenes read and built in Python alike (:func:`wrt.light_table.emitter_triangles`)."""
    from .materials import can_emit

    used = [] if mesh.material_ids is None else sorted(set(mesh.material_ids[mesh.material_ids >= 0].tolist()))
    if used and light.material_sync == GLOW_TINTS_LIGHT:  # a mesh bound to no material has no glow to tint
        if not any(can_emit(materials.materials[k], materials.textures) for k in used):
            skip('mesh lights of light:materialSyncMode "materialGlowTintsLight" (MeshLightAPI\'s fallback) whose '
                 "material has no emissiveColor emit nothing (the light tints the material's glow); author "
                 '"independent" to emit the light\'s colour', prim)


def _read_light(prim, to_world, time, up_axis: str, skip, get, textures, read_from):
    """:func:`read_light` with ``get(attr, default)`` reading an attribute (or its unprefixed name; ``read_from``:
    :func:`input_reader`'s)."""
    from pxr import UsdLux

    light = UsdLux.LightAPI(prim)
    mistyped = []

    def warn_flag(detail):
        skip(MISTYPED_FLAGS, prim, detail)

    def read(attr, fallback, convert):
        """``convert`` of ``attr``'s value; ``fallback``'s for a value of the wrong type (a string intensity, a
        token colour), named in ``mistyped``: it stopped the whole load with "cannot read this prim"."""
        value = get(attr, fallback)
        try:
            return convert(value)
        except (TypeError, ValueError):
            mistyped.append(f"{attr.GetName()} = {value!r}")
            return convert(fallback)

    def vector(value):
        return np.array(value, dtype=np.float64)

    color_attr = light.GetColorAttr()
    color = read(color_attr, (1.0, 1.0, 1.0), vector)
    intensity = read(light.GetIntensityAttr(), 1.0, float)
    exposure = read(light.GetExposureAttr(), 0.0, float)
    blackbody = flag(get, light.GetEnableColorTemperatureAttr(), False, warn_flag)
    kelvin = read(light.GetColorTemperatureAttr(), 6500.0, float) if blackbody else 6500.0
    if mistyped:
        skip("lights whose colour, intensity, exposure or colour temperature is not a number were skipped", prim,
             ", ".join(mistyped))
        return None
    if color_attr.GetName() in read_from:  # authored: its colorSpace's (USD's default, the fallback, is linear)
        color = linear_colors(color, [color_attr, read_from[color_attr.GetName()]], prim, skip)
    if blackbody:
        if math.isnan(kelvin):  # UsdLux.BlackbodyTemperatureAsRgb segfaults on NaN (it clamps the rest)
            skip("lights whose colorTemperature is NaN were skipped", prim,
                 f"inputs:colorTemperature = {kelvin:g}")
            return None
        color = color * np.array(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64)
    # An exposure of 1024 or more overflows 2.0**exposure (a bare OverflowError out of load_usd): let it become
    # inf in numpy instead, and be skipped below like any other colour that is not finite.
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        unexposed = color * intensity
        color = (unexposed * np.exp2(exposure)).astype(np.float32)
    normalize = flag(get, light.GetNormalizeAttr(), False, warn_flag)
    m = np.asarray(to_world, dtype=np.float64)
    path = str(prim.GetPath())
    if not (np.all(np.isfinite(color)) and np.all(np.isfinite(m))):
        skip("lights whose colour * intensity * 2^exposure or transform is not finite were skipped", prim)
        return None
    dimmest = _below_float32(unexposed, exposure)
    if dimmest:
        skip("lights whose colour * intensity * 2^exposure lies below float32's normal range (1.2e-38: their colour "
             "is 0, or keeps few of its digits) were skipped", prim, dimmest)
        return None
    if np.any(color < 0.0):  # a light cannot take light away: negative pixels would follow
        skip("negative light colour or intensity was clamped to 0", prim)
        color = np.maximum(color, 0.0)
    m = affine_part(m.T, lambda reason: skip(reason, prim)).T
    multipliers = _multipliers(prim, light, skip, get)
    if multipliers is None:
        return None
    # The attribute counts whether or not ShadowAPI is applied, as in UsdLux's own fallback handling.
    shadows = flag(get, prim.GetAttribute("inputs:shadow:enable"), True, warn_flag)
    shadow_color, shadow_distance, falloff = (_shadow_api(prim, get, skip, read_from) if shadows
                                              else (None, -1.0, (-1.0, 1.0)))
    try:
        shaping = read_shaping(prim, get, skip, textures.profiles)
        result = _read_kind(prim, m, color, normalize, path, time, up_axis, skip, get, textures)
        result = _tiny_normalized(result, prim, skip)
        if result is not None and not fits_float32(result):
            skip("lights too large (a position or size past 8.5e37, or a point sphere's intensity past 3.4e38) to fit "
                 "in float32 were skipped", prim, _past_float32(result))
            result = None
        if shaping is not None:
            result = _shaped(result, shaping, m, prim, skip)
    except SceneError as e:  # a value the checks above let through, e.g. a radius that overflows once scaled
        skip("lights with values wrt cannot use were skipped", prim, str(e).removeprefix(f"{path}: "))
        return None
    if result is not None:
        authored = prim.GetAuthoredPropertyNames()
        _read_links_and_filters(prim, light, result, skip, authored)
        _warn_shader_ids(prim, skip, authored)
        result.shadows = shadows
        result.shadow_color, result.shadow_distance = shadow_color, shadow_distance
        result.shadow_falloff, result.shadow_falloff_gamma = falloff
        result.diffuse, result.specular = multipliers
    return result


def _below_float32(unexposed: np.ndarray, exposure: float) -> str:
    """What of a light's ``unexposed`` colour (``(3,)`` float64 ``color * intensity``) times ``2^exposure`` lies below
    float32's smallest normal number, though it is not 0, for the warning ("" where it does not): a light of
    intensity 1e-30 and exposure -80 (8e-55) became a float32 colour of 0 and lit nothing without a word."""
    largest = float(np.max(np.abs(unexposed)))
    if not (largest > 0.0 and math.isfinite(largest) and math.isfinite(exposure)):
        return ""
    if math.log2(largest) + exposure >= math.log2(FLOAT32_TINY):  # in logs: 2^exposure may underflow float64
        return ""
    return f"largest component {largest:.3g} * 2^{exposure:g}"


def _tiny_normalized(light, prim, skip):
    """``light``, or None: a normalized area light so small that its radiance (``color / area``) passes float32's
    range emitted nothing without a word but numpy's overflow warning, and one whose area underflowed float64 to 0
    (a double-precision transform scaling it by 1e-100) emitted nothing without any. A sphere becomes the point
    light it tends to (of intensity ``color / 4``), a cylinder the line light along its axis (``treatAsLine``, of
    intensity ``color / (pi l)``: the tube's power, ``pi color``, whatever its radius); the other shapes, and a
    cylinder whose line is too short for float32 too, are skipped with a warning naming them."""
    if not (isinstance(light, (SphereLight, RectLight, DiskLight, CylinderLight)) and light.normalize):
        return light
    if isinstance(light, SphereLight) and light.treat_as_point:
        return light
    if isinstance(light, CylinderLight) and light.treat_as_line:  # its intensity is color / (pi l): no area in it
        return light
    area = light.area
    if area > 0.0 and np.all(np.isfinite(light.radiance)):
        return light
    if isinstance(light, SphereLight):
        if area > 0.0 or light.world_radius > 0.0:
            light.treat_as_point = True
        return light
    if isinstance(light, CylinderLight) and light.drawn_as_line:
        # A tube too thin to hold its radiance, or of radius 0, is its axis, of the tube's power (drawn_as_line). It
        # was skipped (of radius 0: dark, as a tube of no area).
        light.treat_as_line = True
        if fits_float32(light):
            return light
        skip("normalized lights too small for their radiance (intensity / area) to fit in float32 were skipped", prim,
             f"CylinderLight of area {area:.3g} and length {np.linalg.norm(light.world_shape()[0]):.3g}")
        return None
    if area > 0.0 or _area_underflowed(light):
        skip("normalized lights too small for their radiance (intensity / area) to fit in float32 were skipped", prim,
             f"area {area:.3g}" if area > 0.0 else "area below float64's range")
        return None
    return light  # a light of no area (a size of 0, a transform that flattens it) emits nothing, as its sizes say


def fits_float32(light) -> bool:
    """Whether the light table can hold ``light`` in float32: the lengths that place a sphere, rect, disk or cylinder
    light (its centre, edges or radius vectors, axis and radius; an ellipsoid's or elliptic tube's map) below a
    quarter of float32's largest (:data:`LARGEST_LIGHT_LENGTH`: sums of two stay finite), and a point sphere's
    intensity below float32's largest. Sizes near 1e38 overflowed there behind numpy's bare warning, and the infinite
    lengths lit wrongly (a 1e38-wide RectLight over a grey plane: 0 or 0.3 where an infinite emitting plane gives
    the albedo). The area need not fit: lights are sampled in lengths scaled per light
    (:func:`wrt.light_sampling.light_scales`); a light 1e20 wide, its area past float32, was skipped."""
    if not isinstance(light, (SphereLight, RectLight, DiskLight, CylinderLight)):
        return True
    if isinstance(light, SphereLight) and light.drawn_as_point:
        with np.errstate(over="ignore"):  # an intensity past float32 is inf here: skipped by the caller
            return bool(np.all(np.abs(light.intensity) < FLOAT32_MAX))
    if isinstance(light, CylinderLight) and light.drawn_as_line:
        length = float(np.linalg.norm(light.world_shape()[0]))
        return length < FLOAT32_MAX and bool(np.all(np.abs(light.line_intensity) < FLOAT32_MAX))
    return _largest_length(light) < LARGEST_LIGHT_LENGTH


def _past_float32(light) -> str:
    """What of ``light``, which :func:`fits_float32` refused, passes float32, for the warning: a point sphere's
    intensity, a line light's length or intensity, else its position, its size or both, whichever is past
    :data:`LARGEST_LIGHT_LENGTH` (its area was named, which need not fit; then a light placed far away was named for
    its "size")."""
    with np.errstate(over="ignore", invalid="ignore"):
        if isinstance(light, SphereLight) and light.drawn_as_point:
            # SphereLight.intensity in float64: the float32 one is inf here (normalized ones, color / 4, all fit).
            color = np.abs(np.asarray(light.color, np.float64))
            scale = light.area / 4.0 if light.ellipsoid() is not None else math.pi * light.world_radius**2
            return f"intensity {float(np.max(color)) * scale:.3g}"
        if isinstance(light, CylinderLight) and light.drawn_as_line:
            return (f"length {float(np.linalg.norm(light.world_shape()[0])):.3g}, intensity "
                    f"{float(np.max(np.abs(light.line_intensity))):.3g}")
    position, size = (_largest(lengths) for lengths in _placing_lengths(light))
    past = [f"{name} {value:.3g}" for name, value in (("position", position), ("size", size))
            if not value < LARGEST_LIGHT_LENGTH]  # NaN included
    return ", ".join(past) or f"size {size:.3g}"


LARGEST_LIGHT_LENGTH = FLOAT32_MAX / 4.0


def _largest_length(light) -> float:
    """The largest magnitude among the lengths that place a sphere, rect, disk or cylinder light (NaN where one is
    NaN), which :func:`fits_float32` keeps below :data:`LARGEST_LIGHT_LENGTH`."""
    position, shape = _placing_lengths(light)
    return _largest(position + shape)  # a NaN propagates: it fits nothing


def _placing_lengths(light) -> tuple[list, list]:
    """The lengths that place a sphere, rect, disk or cylinder light: ``(its centre, its shape)`` (edges or radius
    vectors, axis and radius; an ellipsoid's or elliptic tube's map)."""
    if isinstance(light, SphereLight):
        m = light.ellipsoid()
        return [light.position], [[light.world_radius]] + ([] if m is None else [m])
    if isinstance(light, RectLight):
        return [light_axes(light.to_world)[3]], [*light.edges()]
    if isinstance(light, DiskLight):
        x, y, _, origin = light_axes(light.to_world)
        return [origin], [x * light.radius, y * light.radius]
    m = light.tube()
    axis, radius = light.world_shape()
    return [light_axes(light.to_world)[3]], [axis, [radius]] + ([] if m is None else [m])


def _largest(lengths: list) -> float:
    """The largest magnitude in ``lengths`` (vectors or lists of lengths; NaN where one is NaN)."""
    return float(np.max(np.concatenate([np.abs(np.asarray(x, np.float64)).ravel() for x in lengths])))


def _area_underflowed(light) -> bool:
    """Whether the area of 0 of rect, disk or cylinder ``light`` is float64's underflow, not a size of 0 or a
    transform that flattens it: its sizes are above 0 and its axes, each scaled to a largest entry of 1 before they
    are crossed, span its surface (the tube's: its X axis and another)."""
    x, y, z, _ = light_axes(light.to_world)
    if isinstance(light, RectLight):
        sizes, spans = (light.width, light.height), [(x, y)]
    elif isinstance(light, DiskLight):
        sizes, spans = (light.radius,), [(x, y)]
    else:
        sizes, spans = (light.length, light.radius), [(x, y), (x, z)]

    def unit(axis):
        largest = float(np.abs(axis).max())
        return axis / largest if largest > 0.0 else axis

    return all(size > 0.0 for size in sizes) and any(np.any(np.cross(unit(a), unit(b)) != 0.0) for a, b in spans)


def _multipliers(prim, light, skip, get):
    """``(diffuse, specular)``: the light's multipliers on diffuse and specular reflection, negative ones clamped
    to 0 with a warning; None (skipped with a warning) when one is not a finite number."""
    values = []
    for attr, name in ((light.GetDiffuseAttr(), "diffuse"), (light.GetSpecularAttr(), "specular")):
        try:
            value = float(get(attr, 1.0))
        except (TypeError, ValueError):  # authored with a wrong type
            value = math.nan
        if not math.isfinite(value):
            skip("lights whose diffuse or specular multiplier is not a finite number were skipped", prim,
                 f"inputs:{name} = {value:g}")
            return None
        if value < 0.0:  # a light cannot take light away: negative pixels would follow
            skip("negative light diffuse and specular multipliers were clamped to 0", prim, f"inputs:{name}")
            value = 0.0
        values.append(value)
    return values


def _read_links_and_filters(prim, light, result, skip, authored):
    """Gives ``result`` the light's ``collection:lightLink`` and ``collection:shadowLink`` (:mod:`wrt.light_links`);
    reports light filters, which wrt does not render (Karma and RenderMan honour them, so a stage that relies on
    them rendered differently without a word). ``authored``: the prim's authored property names."""
    # A collection with nothing authored is UsdLux's fallback, every prim (None): USD's membership query, asked for
    # both collections of every light, took a tenth of reading a plain one.
    for name, api, kind in (("light_link", light.GetLightLinkCollectionAPI, "light linking"),
                            ("shadow_link", light.GetShadowLinkCollectionAPI, "shadow linking")):
        collection = api()
        prefix = f"collection:{collection.GetName()}:"
        held = any(n.startswith(prefix) for n in authored)
        setattr(result, name, read_collection(collection, kind, skip) if held else None)
    filters = light.GetFiltersRel().GetForwardedTargets() if light.GetFiltersRel() else []
    for target in filters:
        found = prim.GetStage().GetPrimAtPath(target)
        kind = (found.GetTypeName() if found else "") or "missing prim"
        skip("light filters (light:filters) are not supported; these lights shine unfiltered", prim, str(kind))


def _warn_shader_ids(prim, skip, authored):
    """Names ``prim`` for each shader id it authors, ``light:shaderId`` or a render context's
    ``<context>:light:shaderId`` (the ids ``UsdLux.LightAPI.GetShaderId`` hands a renderer), that is not the one of
    the light wrt draws: its schema's fallback (``SphereLight`` ..., ``MeshLight`` with MeshLightAPI, ``DomeLight``
    for DomeLight_1), its type's name, or ``MeshLight`` for a gprim. wrt runs no light shaders and renders the light
    as its UsdLux type says: a light whose id names another shader was drawn so without a word."""
    names = [name for name in authored if name == SHADER_ID or name.endswith(":" + SHADER_ID)]
    if not names:
        return
    from pxr import UsdGeom

    drawn = {"", str(prim.GetPrimDefinition().GetAttributeFallbackValue(SHADER_ID) or ""), prim.GetTypeName()}
    if prim.IsA(UsdGeom.Gprim):
        drawn.add("MeshLight")
    for name in names:
        shader_id = str(prim.GetAttribute(name).Get() or "")  # an empty one names none: the type's is drawn
        if shader_id not in drawn:
            skip("lights naming a shader (light:shaderId, or a render context's <context>:light:shaderId) other than "
                 "their UsdLux type's are rendered as that type says: wrt runs no light shaders", prim,
                 f"{name} = {shader_id}")


def _shadow_api(prim, get, skip, read_from) -> tuple[np.ndarray | None, float, tuple[float, float]]:
    """``(shadow colour, shadow distance, (falloff, falloff gamma))`` of a light that casts shadows (ShadowAPI's
    inputs, read whether or not the API is applied, as Hydra reads them): the colour None where it is black (plain
    shadows, most lights), the distance negative for none. A value of the wrong type, a negative colour or a negative
    gamma reads as the fallback, with a warning. The colour is read in its colour space as ``inputs:color`` is
    (``read_from``: :func:`input_reader`'s; it was read as linear Rec.709 whatever its space); channels a conversion
    from other primaries makes negative are clamped to 0, named."""
    wrong = []

    def read(name, fallback, convert):
        value = get(prim.GetAttribute(f"inputs:shadow:{name}"), fallback)
        if value is fallback:  # none authored (most lights): no conversion to pay for
            return fallback
        try:
            converted = convert(value)
        except (TypeError, ValueError):
            converted = None
        if converted is None or not np.all(np.isfinite(converted)):
            wrong.append(f"inputs:shadow:{name} = {value!r}")
            return fallback
        return converted

    color = read("color", None, lambda v: np.asarray(v, np.float64).reshape(3))
    if color is not None and np.any(color < 0.0):
        wrong.append(f"inputs:shadow:color = {tuple(color.tolist())}")
        color = None
    source = read_from.get("inputs:shadow:color")
    if color is not None and source is not None:  # authored: in its colour space (the fallback, black, is linear)
        color = linear_colors(color, [prim.GetAttribute("inputs:shadow:color"), source], prim, skip)
        if not np.all(np.isfinite(color)):
            wrong.append("inputs:shadow:color past float32's range in linear Rec.709")
            color = None
        elif np.any(color < 0.0):
            skip("shadow colours outside Rec.709's gamut (negative channels once converted from their colour space) "
                 "were clamped to 0", prim, f"inputs:shadow:color = {tuple(np.round(color, 4).tolist())}")
            color = np.maximum(color, 0.0)
    distance = read("distance", -1.0, float)
    falloff, gamma = read("falloff", -1.0, float), read("falloffGamma", 1.0, float)
    if gamma < 0.0:  # the schema's validator asks for >= 0: a negative power would sharpen the fade into a step
        wrong.append(f"inputs:shadow:falloffGamma = {gamma!r}")
        gamma = 1.0
    if wrong:
        skip("ShadowAPI inputs that are not finite numbers (or a negative shadow colour or falloff gamma) were read "
             "as the schema's fallbacks", prim, ", ".join(wrong))
    tinted = color is not None and bool(np.any(color > 0.0))
    return (color.astype(np.float32) if tinted else None), distance, (falloff, gamma)


def _read_kind(prim, m, color, normalize, path, time, up_axis, skip, get, textures):
    """The light object of ``prim``'s UsdLux type (see :func:`read_light`)."""
    from pxr import UsdGeom, UsdLux

    def sizes(*attrs):
        """The values of ``(attr, name, fallback)`` size attributes, or None (skipped with a warning) when one is
        negative or not a finite number: a NaN or infinite radius or width lit nothing without a word."""
        values = []
        for attr, name, fallback in attrs:
            value = get(attr, fallback)
            try:
                value = float(value)
            except (TypeError, ValueError):  # authored with a wrong type
                value = math.nan
            if not (math.isfinite(value) and value >= 0.0):
                skip("lights with a negative or non-finite size were skipped", prim, f"inputs:{name} = {value:g}")
                return None
            values.append(value)
        return values

    if prim.IsA(UsdLux.DistantLight):
        d = UsdLux.DistantLight(prim)
        direction = m[:3, :3] @ np.array([0.0, 0.0, -1.0])
        length = np.linalg.norm(direction)
        if not length > 0.0:
            skip("lights with a degenerate transform were skipped", prim)
            return None
        angle = _distant_angle(get(d.GetAngleAttr(), 0.53), prim, skip)
        if angle is None:
            return None
        return DistantLight(direction=direction / length, color=color, path=path, angle=angle, normalize=normalize)
    if prim.IsA(UsdLux.SphereLight):
        s = UsdLux.SphereLight(prim)
        found = sizes((s.GetRadiusAttr(), "radius", 0.5))
        if found is None:
            return None
        radius = found[0]
        treat = flag(get, s.GetTreatAsPointAttr(), False, lambda detail: skip(MISTYPED_FLAGS, prim, detail))
        m3 = m[:3, :3].copy()
        if similar(m3):  # a round sphere: the world radius, as fast as ever
            radius = radius * float(np.mean(np.linalg.norm(m3, axis=0)))
            return SphereLight(m[:3, 3].copy(), radius, color, normalize, treat or radius <= 0.0, path)
        if radius > 0.0 and not treat and flat(radius * m3):
            skip("SphereLights flattened by their transform (a singular matrix: a disk or a line) are rendered as "
                 "spheres of the mean scaled radius", prim)
        # An ellipsoid (scaled unevenly or sheared): the sphere's image under the light's transform.
        return SphereLight(m[:3, 3].copy(), radius, color, normalize, treat or radius <= 0.0, path, frame=m3)
    if prim.IsA(UsdLux.RectLight):
        r = UsdLux.RectLight(prim)
        found = sizes((r.GetWidthAttr(), "width", 1.0), (r.GetHeightAttr(), "height", 1.0))
        if found is None:
            return None
        light = RectLight(m, found[0], found[1], color, normalize, path)
        light.texture, light.texture_path = _read_texture(prim, get(r.GetTextureFileAttr(), None), "RectLight", skip,
                                                        textures)
        return light
    if prim.IsA(UsdLux.DiskLight):
        found = sizes((UsdLux.DiskLight(prim).GetRadiusAttr(), "radius", 0.5))
        return None if found is None else DiskLight(m, found[0], color, normalize, path)
    if prim.IsA(UsdLux.CylinderLight):
        c = UsdLux.CylinderLight(prim)
        found = sizes((c.GetLengthAttr(), "length", 1.0), (c.GetRadiusAttr(), "radius", 0.5))
        if found is None:
            return None
        light = CylinderLight(m, found[0], found[1], color, normalize, path)
        light.treat_as_line = flag(get, c.GetTreatAsLineAttr(), False,
                                   lambda detail: skip(MISTYPED_FLAGS, prim, detail))
        if light.treat_as_line:  # its axis and area are all it keeps of the tube: a flattened one is no concern
            return light
        if not round_tube(m[:3, :3]) and found[0] > 0.0 and found[1] > 0.0 and light.tube() is None:
            skip("CylinderLights flattened by their transform (a singular matrix: a ribbon or a line) are rendered as "
                 "round tubes of the mean scaled radius", prim)
        return light
    if prim.IsA(UsdGeom.Gprim):  # LightAPI on a mesh (MeshLightAPI): wrt.usd checks it is drawn as one
        return MeshLight(path, color, normalize, _material_sync(prim, skip))
    dome_types = [UsdLux.DomeLight] + ([UsdLux.DomeLight_1] if hasattr(UsdLux, "DomeLight_1") else [])
    if any(prim.IsA(t) for t in dome_types):
        return _read_dome(prim, m, color, time, up_axis, skip, get, textures)
    skip(f"{prim.GetTypeName() or 'this'} lights are not supported; skipped", prim, prim.GetTypeName())
    return None


def _distant_angle(value, prim, skip) -> float | None:
    """A DistantLight's ``inputs:angle`` clipped to ``[0, 360]`` degrees, or None (skipped with a warning) when it is
    not a number (NaN, or authored with a wrong type). UsdLux's schema.usda says the angle "is assumed to be in the
    range 0 <= angle < 360, and will be clipped to this range": a negative one (``-inf`` too) is 0, a perfectly
    parallel (delta) light; one past 360 (``inf`` too) the whole sphere. A negative angle was skipped, as a negative
    radius is, and its light lit nothing; so was an infinite one. Either clip is named."""
    try:
        angle = float(value)
    except (TypeError, ValueError):  # authored with a wrong type
        angle = math.nan
    if math.isnan(angle):  # in no range to clip to
        skip("lights with a negative or non-finite size were skipped", prim, f"inputs:angle = {angle:g}")
        return None
    if 0.0 <= angle <= ANGLE_CLIP:
        return angle
    clipped = min(max(angle, 0.0), ANGLE_CLIP)
    skip(f"DistantLight inputs:angle outside UsdLux's range 0 <= angle < {ANGLE_CLIP:g} was clipped to it, as the "
         "schema says (a negative angle is 0: a perfectly parallel light)", prim,
         f"inputs:angle = {angle:g}, read as {clipped:g}")
    return clipped


def _material_sync(prim, skip) -> str:
    """The ``light:materialSyncMode`` of a mesh light (its schema's fallback: ``materialGlowTintsLight`` with
    MeshLightAPI, ``noMaterialResponse`` with LightAPI alone); a token UsdLux does not define counts as the fallback,
    with a warning."""
    from pxr import UsdLux

    attr = UsdLux.LightAPI(prim).GetMaterialSyncModeAttr()
    mode = str(attr.Get()) if attr else ""
    if mode not in MATERIAL_SYNC_MODES:
        fallback = GLOW_TINTS_LIGHT if prim.HasAPI(UsdLux.MeshLightAPI) else NO_MATERIAL_RESPONSE
        skip(f"light:materialSyncMode values other than {', '.join(MATERIAL_SYNC_MODES)} were read as the "
             "schema's fallback", prim, f"{mode!r}, read as {fallback}")
        mode = fallback
    return mode


def _shaped(light, shaping: Shaping, m, prim, skip):
    """``light`` (or None) with ``shaping``: sphere, rect, disk and cylinder lights take it (a sphere also its -Z
    and X axes, from ``m``); distant and dome lights, which the ShapingAPI formulas are not written for, emit unshaped,
    with a warning unless the shaping is at its fallbacks."""
    if isinstance(light, (SphereLight, RectLight, DiskLight, CylinderLight)):
        light.shaping = shaping
        if isinstance(light, SphereLight):
            light.axis = primary_axis(m, light.axis)
            light.x_axis = x_axis(m, light.x_axis)
            light.y_axis = y_axis(m)
    elif light is not None and not shaping.at_fallbacks():
        skip("light shaping (ShapingAPI) on mesh lights, distant and dome lights is not supported; these lights emit "
             "unshaped", prim)
    return light


def _read_dome(prim, m, color, time, up_axis, skip, get, textures):
    from pxr import UsdLux

    from .dome_formats import FORMATS, fits_layout

    rotation = m.copy()
    if hasattr(UsdLux, "DomeLight_1") and prim.IsA(UsdLux.DomeLight_1):
        pole = str(get(UsdLux.DomeLight_1(prim).GetPoleAxisAttr(), "scene"))
        if pole not in POLE_AXES:  # UsdImaging's _GetDomeOffset turns the dome for scene and Z only: the rest is Y
            skip(f"DomeLight_1 poleAxis values other than {', '.join(POLE_AXES)} were read as Y (no turn), as Hydra "
                 "reads them", prim, f"poleAxis = {pole!r}")
        if pole == "Z" or (pole == "scene" and up_axis == "Z"):
            to_z = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], np.float64)  # +Y -> +Z
            rotation = m @ to_z
    dome = DomeLight(color=color, to_world=rotation, path=str(prim.GetPath()))
    attr = prim.GetAttribute("inputs:texture:file")
    asset = get(attr, None) if attr else None
    fmt = str(get(prim.GetAttribute("inputs:texture:format"), "automatic"))
    if fmt not in FORMATS:
        if asset is not None and (getattr(asset, "path", "") or ""):
            skip(f"DomeLight texture format {fmt!r} is not one of UsdLux's ({', '.join(FORMATS)}); the dome is "
                 "constant", prim)
        return dome
    texture, resolved = _read_texture(prim, asset, "DomeLight", skip, textures)
    dome.texture_path = resolved
    if texture is not None:
        height, width = texture.shape[:2]
        if fmt == "automatic" and not fits_layout(fmt, width, height):
            skip("DomeLight texture:format automatic: the image's shape is none of the layouts' (2:1 latlong, 1:1 "
                 "angular, 3:4 cubeMapVerticalCross); read as latlong", prim, f"{width}x{height}")
        elif not fits_layout(fmt, width, height):  # a cross or a probe labelled latlong was stretched silently
            skip(f"DomeLight texture:format {fmt}: the image's shape is not the layout's (2:1 latlong, 1:1 angular "
                 "or mirroredBall, 3:4 cubeMapVerticalCross); read as that layout, stretched to the image", prim,
                 f"{width}x{height}")
        dome.texture = textures.latlong(resolved, texture, fmt)
    return dome


def _read_texture(prim, asset, kind: str, skip, textures: LightTextures):
    """The ``(H, W, 4)`` image of a light's ``inputs:texture:file`` value ``asset`` (from ``textures``) and its
    resolved path, or ``(None, "")`` (with a warning through ``skip`` when a file is named but cannot be read)."""
    from .textures import TextureError

    if asset is None or not (getattr(asset, "path", "") or ""):
        return None, ""
    resolved = getattr(asset, "resolvedPath", "") or ""
    if not resolved:
        skip(f"{kind} texture {asset.path} was not found; the light's colour is used", prim)
        return None, ""
    try:
        image = textures.load(resolved)
    except TextureError as e:
        skip(f"{kind} texture: {e}; the light's colour is used", prim)
        image = None
    for words in dict.fromkeys(textures.notes.get((resolved, "auto"), ())):  # (Pillow's words, which name no file)
        skip(f"{kind} texture {resolved}: {words}", prim)
    if image is None:
        return None, ""
    attr = prim.GetAttribute("inputs:texture:file")
    if attr and attr.HasColorSpace() and str(attr.GetColorSpace()):
        # Storm reads a light's texture as UsdUVTexture's auto whatever the attribute's colorSpace says (hdSt's
        # dome light texture hardcodes it); UsdLux has no sourceColorSpace. An 8-bit colour file marked
        # lin_rec709_scene was sRGB-decoded without a word.
        skip(f"{kind} texture: the colorSpace of inputs:texture:file is not read; the image is decoded as Storm "
             "decodes a light's texture (UsdUVTexture's sourceColorSpace auto: sRGB for 8-bit colour, else as "
             "stored)", prim, str(attr.GetColorSpace()))
    if resolved not in textures.dark:
        textures.dark[resolved] = _unemitted(image, os.path.basename(resolved))
    if textures.dark[resolved]:  # light_table makes them 0: an HDR's sun stored as inf went black without a word
        skip("light texture texels that are negative, NaN or infinite emit nothing (read as 0)", prim,
             textures.dark[resolved])
    return image, resolved


def _unemitted(image: np.ndarray, name: str) -> str:
    """What of ``image``'s colour (``(H, W, 3+)``) a light cannot emit, named for a warning ("" for none)."""
    rgb = np.asarray(image)[..., :3]
    with np.errstate(invalid="ignore"):
        counts = {"NaN": int(np.isnan(rgb).sum()), "infinite": int(np.isinf(rgb).sum()),
                  "negative": int((rgb < 0).sum())}
    found = [f"{n} {what}" for what, n in counts.items() if n]
    return f"{name}: {', '.join(found)} of {rgb.size} values" if found else ""
