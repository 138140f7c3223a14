"""The colour space of USD colour values and their conversion to linear Rec.709, the space wrt renders in.

USD's colour guides make an attribute's ``colorSpace`` metadata the source colour space of its values: a colour
constant of a shader, a light's ``inputs:color``, a colour primvar such as ``displayColor``. A colour value is read
in its space and brought to linear Rec.709 (:func:`linear_rec709`): the space's transfer function decoded
(:func:`wrt.textures.decode_curve`: ``srgb_rec709_scene`` by sRGB's curve, ``g22_rec709_scene`` as ``max(x, 0)^2.2``),
then its primaries converted (a ``(3, 3)`` matrix from USD's own ``Gf.ColorSpace`` RGB-to-XYZ matrices, whose white
points are adapted to D65 as ``Gf.ColorSpace.Convert`` converts: ``lin_ap1_scene``, ACEScg, ``(1, 0, 0)`` is
``(1.705, -0.130, -0.024)``). Names are USD's canonical ones (``GfColorSpaceNames``) and MaterialX's
(:data:`COLOR_SPACES`); ``data``, ``raw``, ``identity`` and ``unknown`` are read as stored. An image file (a
MaterialX image node's) is decoded and converted alike, its texels once at load (:func:`file_color_space`).
"""

from __future__ import annotations

import contextlib
import contextvars
import functools

import numpy as np

from .textures import PRIMARIES_SEPARATOR, decode_curve

# Colour space name -> (wrt's transfer function, as wrt.textures.decode_curve takes it; the USD name of the linear
# space of its primaries, None for Rec.709's). MaterialX's (Specification 1.39) as its colour transforms decode them:
# max(x, 0)^2.2 or ^1.8, rec709_display's ^2.4 (cmlib's NG_rec709_display_to_lin_rec709), Adobe RGB's ^(563/256),
# sRGB's curve for srgb_displayp3; USD's canonical (Color Interop Forum) names, GfColorSpaceNames, by the transfer
# function Gf.ColorSpace declares for each (the same ones: MaterialX 1.39's colour management remaps them to its own,
# srgb_rec709_scene to srgb_texture, g24_rec709_scene to rec709_display, ...).
LINEAR_REC709 = "lin_rec709_scene"
AP1, AP0, P3, ADOBE, REC2020, XYZ = ("lin_ap1_scene", "lin_ap0_scene", "lin_p3d65_scene", "lin_adobergb_scene",
                                     "lin_rec2020_scene", "lin_ciexyzd65_scene")
ADOBE_GAMMA = f"gamma {563 / 256}"
COLOR_SPACES = {"srgb_texture": ("sRGB", None), "lin_rec709": ("raw", None), "raw": ("raw", None),
                "lin_srgb": ("raw", None), "g22_rec709": ("gamma 2.2", None), "g18_rec709": ("gamma 1.8", None),
                "rec709_display": ("gamma 2.4", None),
                "acescg": ("raw", AP1), "lin_ap1": ("raw", AP1), "g22_ap1": ("gamma 2.2", AP1),
                "g18_ap1": ("gamma 1.8", AP1), "adobergb": (ADOBE_GAMMA, ADOBE), "lin_adobergb": ("raw", ADOBE),
                "srgb_displayp3": ("sRGB", P3), "lin_displayp3": ("raw", P3),
                "srgb_rec709_scene": ("sRGB", None), LINEAR_REC709: ("raw", None),
                "g22_rec709_scene": ("gamma 2.2", None), "g18_rec709_scene": ("gamma 1.8", None),
                "g24_rec709_scene": ("gamma 2.4", None), AP1: ("raw", AP1), "g22_ap1_scene": ("gamma 2.2", AP1),
                "srgb_ap1_scene": ("sRGB", AP1), AP0: ("raw", AP0), "srgb_p3d65_scene": ("sRGB", P3),
                P3: ("raw", P3), ADOBE: ("raw", ADOBE), "g22_adobergb_scene": (ADOBE_GAMMA, ADOBE),
                REC2020: ("raw", REC2020), XYZ: ("raw", XYZ),
                # USD's names of no colour transform (Gf.ColorSpace's data spaces): the values are read as stored.
                "data": ("raw", None), "identity": ("raw", None), "unknown": ("raw", None)}
# USD names MaterialX 1.39 has no transform for: a MaterialX image file in one is read as stored, named.
NO_MATERIALX_TRANSFORM = ("srgb_ap1_scene", AP0, REC2020, XYZ)


def reads_as_stored(name: str) -> bool:
    """Whether values in colour space ``name`` read as stored: linear Rec.709, or a data space."""
    return COLOR_SPACES.get(name) == ("raw", None)


@functools.cache
def gamut_matrix(primaries: str) -> np.ndarray:
    """The ``(3, 3)`` float64 matrix taking linear RGB of the primaries of USD colour space ``primaries`` to linear
    Rec.709: ``XYZ -> Rec.709`` after ``RGB -> XYZ``, both ``Gf.ColorSpace``'s (their white points adapted to D65)."""
    from pxr import Gf

    def to_xyz(name):
        return np.array(Gf.ColorSpace(name).GetRGBToXYZ(), np.float64)

    return np.linalg.solve(to_xyz(LINEAR_REC709), to_xyz(primaries))


def linear_rec709(values, name: str) -> np.ndarray:
    """``values`` (``(..., 3)`` or more channels, the rest kept, such as alpha) in known colour space ``name``
    (:data:`COLOR_SPACES`) as float64 linear Rec.709: decoded by its transfer function, then converted from its
    primaries. Values past float32's range after the decode or the conversion are +-inf (the caller names them): the
    conversion takes ACEScg's 3e38 red to 5.1e38, finite in float64 alone, which passed the readers' checks for
    values that are not finite and failed the load of a gprim or Points prim (a Shape's colour must be finite)."""
    from .usd_primvars import past_float32_as_inf  # that module imports this one

    transfer, primaries = COLOR_SPACES[name]
    out = np.array(values, np.float64)
    decode = decode_curve(transfer)
    with np.errstate(over="ignore", invalid="ignore"):
        if decode is not None:
            out[..., :3] = decode(out[..., :3])
        if primaries is not None:
            out[..., :3] = out[..., :3] @ gamut_matrix(primaries).T
    out[..., :3] = past_float32_as_inf(out[..., :3])
    return out


def input_attrs(inp) -> list:
    """The attribute of shader input ``inp``, then those its value comes from (the interface input it connects to):
    the attributes :func:`own_color_space` and :func:`attribute_color_space` read; none for no input."""
    return [inp.GetAttr(), *inp.GetValueProducingAttributes()] if inp else []


def own_color_space(attrs) -> str:
    """The first non-empty ``colorSpace`` metadata of attributes ``attrs`` (an input, then the interface input it
    reads), ``""`` where none has one (an empty one is none, as hdMtlx passes it on)."""
    for attr in attrs:
        name = str(attr.GetColorSpace()) if attr and attr.HasColorSpace() else ""
        if name:
            return name
    return ""


def inherited_color_space(attr) -> tuple[str, str]:
    """``(name, prim path)``: the colour space attribute ``attr`` (with no ``colorSpace`` of its own) takes from
    ``UsdColorSpaceAPI`` on its prim or its nearest ancestor with one whose ``colorSpace:name`` is authored, as USD's
    ``UsdColorSpaceAPI::ComputeColorSpaceName`` resolves it; ``("", "")`` where none has one (USD's default, linear
    Rec.709), and where ``attr`` has an empty ``colorSpace`` authored: USD resolves an attribute with one authored to
    that one, an empty one too, without asking its prims (an srgb_rec709_scene ``/World`` decoded a displayColor below
    it authored ``colorSpace = ""``, which USD reads as linear). Inside a native prototype the walk goes on through
    its instances (:func:`_instances_space`). The path names the prim that carries it, for a warning."""
    from pxr import Usd

    api = getattr(Usd, "ColorSpaceAPI", None)  # USD 25.05 and later
    prim = attr.GetPrim() if api is not None and attr and not attr.HasColorSpace() else None
    return _prim_space(prim, api) if prim else ("", "")


# Native prototype (Usd.Prim) -> what its instances inherit (_instances_space), kept over one load: each instance is
# walked once, not once per colour inside. Each load's own dict (instance_spaces_kept), in its thread's context: one
# module dict emptied at the end of each load was shared by loads at once in threads (Dask's threaded workers), and
# the first to end emptied the other's. None outside a load: nothing is kept.
_INSTANCE_SPACES: contextvars.ContextVar[dict | None] = contextvars.ContextVar("instance_spaces", default=None)
DIFFERING = "differing per instance"  # the name (unknown: read as linear, named) where the instances disagree


@contextlib.contextmanager
def instance_spaces_kept():
    """Keeps the colour spaces of native prototypes over the load inside, for it alone; dropped after it (a stage
    edited and loaded again may give others)."""
    token = _INSTANCE_SPACES.set({})
    try:
        yield
    finally:
        _INSTANCE_SPACES.reset(token)


def _prim_space(prim, api) -> tuple[str, str]:
    """``(name, prim path)`` UsdColorSpaceAPI gives ``prim``: its own authored ``colorSpace:name``, else its nearest
    ancestor's; at a native prototype's root, that of its instances."""
    while prim:
        if prim.HasAPI(api):
            name = str(api(prim).GetColorSpaceNameAttr().Get() or "")
            if name:
                return name, str(prim.GetPath())
        if prim.IsPrototype():
            return _instances_space(prim, api)
        prim = prim.GetParent()
    return "", ""


def _instances_space(prototype, api) -> tuple[str, str]:
    """The colour space the instances of native prototype ``prototype`` give the prims inside it, as USD resolves it
    for their instance proxies (ComputeColorSpaceName walks a proxy up through its instance and the instance's
    ancestors; a prototype's own root carries none of the instance's opinions, not even an asset's root
    ``colorSpace:name`` the instance references): the one they agree on, else :data:`DIFFERING` (read as linear and
    named, with the prims that carry them). A prototype's colours are read once for all its instances; the walk
    stopped at the prototype's root, and an instanced asset lost the colour space it has referenced plainly."""
    kept = _INSTANCE_SPACES.get()
    if kept is None:
        kept = {}
    if prototype not in kept:
        spaces = {instance.GetPath(): _prim_space(instance, api) for instance in prototype.GetInstances()}
        found = sorted(set(spaces.values()))
        names = {name for name, _ in found}
        if len(names) <= 1:
            kept[prototype] = (found[0][0], ", ".join(path for _, path in found)) if names else ("", "")
        else:  # the prims that carry each, and the first instance under none (where one is: all may be under one)
            none = next((str(path) for path, (name, _) in sorted(spaces.items()) if not name), "")
            kept[prototype] = DIFFERING, ", ".join(
                f"{name!r} on {path}" if name else f"none above {none}" for name, path in found)
    return kept[prototype]


def attribute_color_space(attrs) -> tuple[str, str]:
    """``(name, holder)``: the colour space of the values of attribute ``attrs[0]`` (then of the attributes its value
    comes from: the interface input, the light rig's input it connects to): the first ``colorSpace`` of their own
    (:func:`own_color_space`, ``holder`` ``""``), else the one ``attrs[0]`` inherits through ``UsdColorSpaceAPI``
    (:func:`inherited_color_space`, ``holder`` the path of the prim that carries it); ``("", "")`` for none, USD's
    default (linear Rec.709)."""
    own = own_color_space(attrs)
    return (own, "") if own or not attrs else inherited_color_space(attrs[0])


UNKNOWN_SPACE = "colour values in a colour space wrt does not know were read as linear Rec.709"
DIFFERING_SPACES = ("colour values inside a native prototype whose instances inherit different colour spaces "
                    "(UsdColorSpaceAPI) were read once for all of them, as linear Rec.709")


def unknown_space_words(name: str, attr, holder: str = "") -> str:
    """Words naming colour space ``name`` of attribute ``attr`` (inherited from the prim at ``holder``, if any) as one
    wrt does not know, for a warning."""
    return f"{attr.GetName()} in {name!r}{_inherited(holder)}"


def linear_colors(values, attrs, prim, skip) -> np.ndarray:
    """``values`` (``(..., 3)``, the rgb) of colour attribute ``attrs[0]`` (a light's ``inputs:color``, a colour
    primvar; then the attributes its value comes from) as float64 linear Rec.709 from the colour space USD gives it
    (:func:`attribute_color_space`: its ``colorSpace``, else ``UsdColorSpaceAPI`` on its prim or an ancestor;
    :func:`linear_rec709`); as they are where it has none or one that reads as stored. One wrt does not know is
    read as linear Rec.709, named through ``skip(reason, prim, detail)`` with the attribute and the space."""
    attrs = [attr for attr in attrs if attr]
    name, holder = attribute_color_space(attrs)
    if not name or reads_as_stored(name):
        return np.asarray(values, np.float64)
    if name == DIFFERING:
        skip(DIFFERING_SPACES, prim, f"{attrs[0].GetName()}: {holder}")
        return np.asarray(values, np.float64)
    if name not in COLOR_SPACES:
        skip(UNKNOWN_SPACE, prim, unknown_space_words(name, attrs[0], holder))
        return np.asarray(values, np.float64)
    return linear_rec709(values, name)


def decoded_color(inp, value: np.ndarray, what: str, color: bool) -> tuple[np.ndarray | None, str | None]:
    """``(decoded, note)``: constant ``value`` of colour input ``inp`` (of a surface, an image's ``default``, any
    node's; 1 (a grey), 3 or 4 numbers, alpha kept) in linear Rec.709 (:func:`linear_rec709`) from the colour space of
    its ``colorSpace``, or that of the interface input it connects to, else the one it inherits through
    ``UsdColorSpaceAPI`` (:func:`attribute_color_space`), as MaterialX's ShaderGraph transforms a value bound to a node
    input of a colour type and as USD's colour guides resolve a value's space; as it is for other inputs and where there
    is none. ``note`` names a space wrt does not know (read as linear) as ``what``'s. ``color`` says whether the node's
    definition types the input ``color3`` or ``color4``: MaterialX decides by the nodedef's port, not by the USD
    attribute, so a ``float3`` base_color in ``srgb_texture`` is decoded, and so is one number on a colour port, the
    grey it is. ``decoded`` is None where the conversion passes float32's range."""
    if value.size not in (1, 3, 4) or not inp or not color:
        return value, None
    name, holder = attribute_color_space(input_attrs(inp))
    if name and name not in COLOR_SPACES:
        return value, f"{what} colour space {name!r}{_inherited(holder)} is read as linear Rec.709 (unknown to wrt)"
    if not name or reads_as_stored(name):
        return value, None
    rgb = np.broadcast_to(np.asarray(value, np.float64)[:3], 3)  # a grey: the same in each channel
    decoded = np.array(value, np.float64) if value.size == 4 else np.zeros(3)
    decoded[:3] = linear_rec709(rgb, name)
    if value.size == 1 and COLOR_SPACES[name][1] is None:
        decoded = decoded[:1]
    return (decoded if np.isfinite(decoded).all() else None), None


def file_color_space(file_input, what: str = "texture") -> tuple[str | None, str | None]:
    """``(space, note)``: wrt's colour space for a MaterialX image node's ``file`` input (its transfer function:
    ``sRGB``, ``raw`` or ``gamma <g>``, :data:`COLOR_SPACES`; ``<transfer> in <primaries>`` for a space of other
    primaries than Rec.709's, its texels converted from them at load, :func:`wrt.textures.convert_primaries`), from
    the ``colorSpace`` metadata of the input or of the interface input it connects to, else ``UsdColorSpaceAPI`` on
    its prim or an ancestor (:func:`attribute_color_space`; None where there is none), and the note to give, None
    but for a colour space wrt does not know or MaterialX has no transform for (read as ``raw``), naming it as
    ``what``'s (``texture``: a file's). The spaces of other transfer functions were read as stored: a ``g22_rec709``
    texel of 128 read 0.502 for MaterialX's 0.220; then those of other primaries were decoded alone, ACEScg's
    (0.5, 0.4, 0.3) read for Rec.709's (0.579, 0.388, 0.282)."""
    name, holder = attribute_color_space(input_attrs(file_input))
    if not name:
        return None, None
    if name not in COLOR_SPACES or name in NO_MATERIALX_TRANSFORM:
        return "raw", f"{what} colour space {name!r}{_inherited(holder)} is read as linear (no gamut conversion)"
    space, primaries = COLOR_SPACES[name]
    return (space if primaries is None else f"{space}{PRIMARIES_SEPARATOR}{primaries}"), None


def _inherited(holder: str) -> str:
    """Words for a colour space inherited from the prim at ``holder`` (none for ``""``, an attribute's own)."""
    return f" (inherited through UsdColorSpaceAPI on {holder})" if holder else ""
