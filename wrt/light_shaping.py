"""Light shaping (``UsdLux.ShapingAPI``): the cone, its softness, the focus and its tint, as factors on the radiance
a light emits in each direction.

The formulas are those of the ShapingAPI attribute docs in UsdLux's ``schema.usda`` (as shipped in usd-core 26.11;
also https://openusd.org/release/user_guides/schemas/usdLux/ShapingAPI.html), which OpenUSD's own hdEmbree renderer
follows. With ``theta`` the angle between the direction light leaves the light in and the light's primary axis (its
local -Z, in the world):

- focus: ``f = |cos theta|^focus`` and the colour factor ``focusTint + f (1 - focusTint)`` (a focus <= 0 does
  nothing; a white tint turns focus off);
- cone: ``1 - smoothstep(theta, theta_cut (1 - softness), theta_cut)`` with ``theta_cut`` the cone angle in radians
  and the softness clamped to [0, 1]: nothing beyond the cone, and with softness 0 a hard edge (full emission up to
  the cone angle itself).

A :class:`Shaping` built in Python refuses a value outside these ranges (cone angle [0, 180], softness [0, 1], focus
and tint >= 0), naming the field: a softness of 5 or a cone angle of 270 was clamped without a word. A stage's
values outside them are clamped by :func:`read_shaping`, as the schema says for the softness and the focus (the
cone formula gives no light below 0 degrees and no limit past 180), with a warning naming the light.

The cone is applied at its value, the fallback of 90 degrees included: sphere and cylinder lights with ShapingAPI
emit only into the half space in front of their -Z axis unless a wider cone (180: everywhere) is authored, as the
schema says (the sphere lights Omniverse writes carry an authored 180). Rect and disk lights emit into that half
space anyway, so a ShapingAPI at its fallbacks changes nothing there, and such lights are uploaded as unshaped (the
kernels then skip the factor). Every emission direction is shaped the same way, whether light sampling reaches the
light or a camera or bounce ray sees it: from outside the cone a light looks dark, and both strategies of multiple
importance sampling weigh the same radiance.

An IES profile (``shaping:ies:file``, :mod:`wrt.ies`) multiplies the emission too, by its candela value in the
direction light leaves in, in the light's frame: vertical angle ``theta`` off the primary axis (-Z), horizontal angle
from the light's +X towards its +Y. ``shaping:ies:angleScale`` rescales ``theta`` before the lookup as the schema
says (``theta / s`` for ``s > 0``, ``(theta - pi) / -s + pi`` for ``s < 0``), and ``shaping:ies:normalize`` divides
the profile by its mean intensity over the sphere or hemisphere it covers (:meth:`wrt.ies.IesProfile.mean_intensity`,
as OpenUSD's hdEmbree does), so that it shapes the light without changing its overall brightness much.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from .errors import SceneError, check_fields, check_flags
from .ies import IesError, IesProfile, parse_ies, read_ies

PROFILE_STEPS = 2048  # angles at which power_fraction integrates the shaping factor
SHAPING_RANGES = {  # field -> (lowest, highest, unit) of a Shaping's bounded inputs
    "cone_angle": (0.0, 180.0, " degrees"),  # off the axis: 180 lets every direction through
    "cone_softness": (0.0, 1.0, ""),  # share of the cone angle
}


@dataclasses.dataclass
class Shaping:
    """``UsdLux.ShapingAPI`` of a sphere, rect, disk or cylinder light (the light's ``shaping``).

    Attributes:
        cone_angle: degrees off the light's primary axis (its -Z) beyond which it emits nothing, in [0, 180] (the
            schema's fallback is 90; 180: no cone).
        cone_softness: the share of the cone angle over which emission fades smoothly to 0 at its edge, in [0, 1].
        focus: exponent of ``|cos|`` off the axis that narrows the emission, >= 0 (0: none).
        focus_tint: ``(3,)`` the colour factor the focus fades to off the axis, >= 0 (black: to nothing; white: no
            focus).
        ies: the :class:`wrt.ies.IesProfile` (``shaping:ies:file``, :func:`wrt.ies.read_ies`), or None.
        ies_angle_scale: ``shaping:ies:angleScale``: rescales the profile's vertical angles (0: as they are).
        ies_normalize: ``shaping:ies:normalize``: divide the profile by its mean intensity.

    Raises:
        SceneError: naming the field, for a value that is not a finite number or lies outside its range.
    """

    cone_angle: float = 90.0
    cone_softness: float = 0.0
    focus: float = 0.0
    focus_tint: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3, np.float32))
    ies: IesProfile | None = None
    ies_angle_scale: float = 0.0
    ies_normalize: bool = False
    path = ""  # check_fields names this prim: none (load_usd's warning names the light of a bad shaping)

    def __post_init__(self):
        check_fields(self, ("cone_angle", (), None, float), ("cone_softness", (), None, float),
                     ("focus", (), 0.0, float), ("focus_tint", (3,), 0.0, np.float32))
        for name, (low, high, unit) in SHAPING_RANGES.items():
            value = getattr(self, name)
            if not low <= value <= high:
                raise SceneError(f"Shaping {name} must be in [{low:g}, {high:g}]{unit}, got {value!r}",
                                 prim=self.path or None)
        if self.ies is not None and not isinstance(self.ies, IesProfile):
            raise SceneError(f"Shaping ies must be a wrt.ies.IesProfile or None, got {type(self.ies).__name__} "
                             "(wrt.read_ies reads a file)", prim=self.path or None)
        check_fields(self, ("ies_angle_scale", (), None, float))
        check_flags(self, "ies_normalize")

    def ies_scale(self) -> float:
        """What the profile's candela values are multiplied by: 1, or 1 / its mean intensity with ``ies_normalize``
        (1 for a profile that is dark everywhere, which nothing can normalize)."""
        if self.ies is None or not self.ies_normalize:
            return 1.0
        mean = self.ies.mean_intensity()
        return 1.0 / mean if mean > 0.0 else 1.0

    def ies_theta(self, theta: np.ndarray) -> np.ndarray:
        """The vertical angle of the IES profile looked up for directions ``theta`` (radians) off the primary axis:
        ``shaping:ies:angleScale`` ``s`` rescales it as :func:`wrt.ies.ies_factor` does (``theta / s`` for ``s > 0``,
        about pi for ``s < 0``)."""
        s = self.ies_angle_scale
        if s > 0.0:
            return theta / s
        if s < 0.0:
            return (theta - math.pi) / -s + math.pi
        return theta

    def _ies_span(self) -> tuple[float, float]:
        """``(lo, hi)`` radians off the primary axis that the profile's vertical range covers at its angle scale (the
        inverse of :meth:`ies_theta`)."""
        v0, v1 = math.radians(self.ies.vertical[0]), math.radians(self.ies.vertical[-1])
        s = self.ies_angle_scale
        if s > 0.0:
            return s * v0, s * v1
        if s < 0.0:
            return math.pi + s * (math.pi - v0), math.pi + s * (math.pi - v1)
        return v0, v1

    def at_fallbacks(self) -> bool:
        """True when every input has the schema's fallback value."""
        return ((self.cone_angle, self.cone_softness, self.focus) == (90.0, 0.0, 0.0) and not np.any(self.focus_tint)
                and self.ies is None)

    def device_params(self, emits_behind: bool) -> tuple[float, float, float] | None:
        """``(theta_cut, theta_smooth_start, focus)`` as :func:`cone_and_focus` takes them, or None where the shaping
        changes nothing on a light that emits up to 90 degrees off its axis (rect, disk; ``emits_behind`` False) or
        in every direction (sphere, cylinder)."""
        cut = math.radians(min(max(self.cone_angle, 0.0), 180.0))
        start = cut * (1.0 - min(max(self.cone_softness, 0.0), 1.0))
        focus = max(self.focus, 0.0)
        focus_acts = focus > 0.0 and bool(np.any(self.focus_tint != 1.0))
        widest = math.pi if emits_behind else 0.5 * math.pi  # the largest angle off the axis the light emits at
        if not focus_acts and start >= widest:  # full emission up to the smooth start, and nothing lies beyond it
            return None
        return cut, start, focus if focus_acts else 0.0

    def power_fraction(self, emits_behind: bool) -> float:
        """The share of the light's power that the shaping lets out (luminance), for picking lights by power: the
        factor (cone, focus and IES profile at its angle scale together) averaged over the directions of a uniform
        sphere (``emits_behind``) or of a Lambertian emitter (rect and disk lights, which emit ``cos`` off their
        axis, and nothing behind it). Integrated over the angles the profile covers, where it has one: an angle scale
        of 0.1 squeezes it into a cone of 1/100 the solid angle, and behind a rect light it gives nothing; its mean
        over the sphere was off by up to 20x there, 4x for a narrow spot on a rect light."""
        params = self.device_params(emits_behind)
        if params is None and self.ies is None:
            return 1.0
        cut, start, focus = params if params is not None else (math.pi, math.pi, 0.0)
        top = math.pi if emits_behind else 0.5 * math.pi
        lo, hi = (0.0, top) if self.ies is None else self._ies_span()
        # Nothing lies past the cut: integrating only up to it keeps a cone narrower than a step (all midpoints
        # outside it: a power of 0) and a hard edge between two midpoints exact.
        lo, hi = max(min(lo, hi), 0.0), min(max(lo, hi), top, cut)
        if hi <= lo:
            return 0.0
        step = (hi - lo) / PROFILE_STEPS
        theta = lo + (np.arange(PROFILE_STEPS) + 0.5) * step
        cos = np.cos(theta)
        weight = np.sin(theta) * (1.0 if emits_behind else cos)
        total = 2.0 if emits_behind else 0.5  # the weight's integral over [0, top]
        tint = float(np.dot(self.focus_tint, (0.2126, 0.7152, 0.0722)))
        factor = np.ones_like(theta) if focus <= 0.0 else tint + (1.0 - tint) * np.abs(cos) ** focus
        span = max(cut - start, 1e-30)
        t = np.clip((theta - start) / span, 0.0, 1.0)
        fade = np.where(theta <= start, 1.0, np.where(theta > cut, 0.0, 1.0 - t * t * (3.0 - 2.0 * t)))
        if self.ies is not None:
            factor = factor * self.ies.ring_means(self.ies_theta(theta)) * self.ies_scale()
        return float(np.sum(factor * fade * weight) * step / total)


def unit_column(to_world, k: int) -> np.ndarray | None:
    """``(3,)`` float64 unit world direction of local axis ``k`` under ``to_world`` (``(4, 4)`` column-vector), or
    None where the transform flattens it."""
    axis = np.asarray(to_world, np.float64).reshape(4, 4)[:3, k]
    length = float(np.linalg.norm(axis))
    return axis / length if length > 0.0 else None


def primary_axis(to_world, fallback) -> np.ndarray:
    """``(3,)`` unit world direction of the light's -Z axis under ``to_world`` (``(4, 4)`` column-vector), or
    ``fallback`` where the transform flattens it."""
    z = unit_column(to_world, 2)
    return -z if z is not None else np.asarray(fallback, np.float64)


def x_axis(to_world, fallback) -> np.ndarray:
    """``(3,)`` unit world direction of the light's local +X axis under ``to_world`` (``(4, 4)`` column-vector),
    where an IES profile's horizontal angles start, or ``fallback`` where the transform flattens it."""
    x = unit_column(to_world, 0)
    return x if x is not None else np.asarray(fallback, np.float64)


def y_axis(to_world) -> np.ndarray | None:
    """``(3,)`` unit world direction of the light's local +Y axis under ``to_world`` (``(4, 4)`` column-vector), which
    tells a mirroring transform's horizontal angles apart (:func:`ies_frame`), or None where the transform flattens
    it."""
    return unit_column(to_world, 1)


def ies_frame(axis, x, y=None) -> np.ndarray:
    """``(3, 3)`` float32 rows: unit X and Y axes and the primary axis (``axis``, the light's -Z, unit) of a light
    whose X axis is ``x`` (made perpendicular to ``axis``; any perpendicular where it lies along it): the frame an IES
    profile is looked up in (:func:`wrt.ies.ies_factor`). Y is ``Z x X``, turned round where the light's own Y axis
    ``y`` (if given) points the other way: a mirroring transform mirrors the profile's horizontal angles too."""
    axis = np.asarray(axis, np.float64)
    x = np.asarray(x, np.float64) - np.dot(x, axis) * axis
    if not np.linalg.norm(x) > 1e-9:
        x = np.cross(axis, (1.0, 0.0, 0.0) if abs(axis[0]) < 0.9 else (0.0, 1.0, 0.0))
    x = x / np.linalg.norm(x)
    y_frame = np.cross(-axis, x)  # Y = Z x X, with Z = -axis
    if y is not None and np.dot(y_frame, y) < 0.0:
        y_frame = -y_frame
    return np.array([x, y_frame, axis], np.float32)


SHAPING_INPUTS = ("cone:angle", "cone:softness", "focus", "focusTint", "ies:file", "ies:angleScale",
                  "ies:normalize")  # after "inputs:shaping:"


def read_shaping(prim, get, skip, profiles: dict | None = None) -> Shaping | None:
    """The :class:`Shaping` of a light prim (None without ShapingAPI or an authored shaping input: Hydra reads the
    inputs either way), its IES profile included. Inputs outside the ranges a :class:`Shaping` takes are clamped to
    them, as the schema clamps the softness and ignores a negative focus, with a warning through ``skip``; an IES
    file that is not found or cannot be read is left out (the light emits without it), with a warning naming it.

    Args:
        prim: a ``UsdLux`` light prim.
        get: ``get(attr, default)`` of :func:`wrt.usd_lights.read_light` (unprefixed names of old files included).
        skip: ``skip(reason, prim, detail=None)``.
        profiles: resolved path -> its :class:`wrt.ies.IesProfile` or :class:`wrt.ies.IesError`, kept over one load
            so that each file is read once; None: read here.
    """
    from pxr import UsdLux

    # Among the names with scene description only (a value needs some): asking each of the 14 names cost a tenth
    # of reading a plain light.
    names = set(prim.GetAuthoredPropertyNames()).intersection(
        f"{prefix}shaping:{name}" for name in SHAPING_INPUTS for prefix in ("inputs:", ""))
    authored = any(prim.GetAttribute(n).HasAuthoredValue() or prim.GetAttribute(n).HasAuthoredConnections()
                   for n in names)  # a connected input (a light rig's) counts: get reads its source
    if not (prim.HasAPI(UsdLux.ShapingAPI) or authored):
        return None
    api = UsdLux.ShapingAPI(prim)
    values = {"cone_angle": get(api.GetShapingConeAngleAttr(), 90.0),
              "cone_softness": get(api.GetShapingConeSoftnessAttr(), 0.0),
              "focus": get(api.GetShapingFocusAttr(), 0.0),
              "focus_tint": get(api.GetShapingFocusTintAttr(), (0.0, 0.0, 0.0))}
    bounds = {name: (low, high) for name, (low, high, _) in SHAPING_RANGES.items()}
    bounds.update(focus=(0.0, math.inf), focus_tint=(0.0, math.inf))
    clamped = []
    for (name, (low, high)), usd_name in zip(bounds.items(), ("cone:angle", "cone:softness", "focus", "focusTint")):
        try:
            value = np.asarray(values[name], np.float64)
        except (TypeError, ValueError):  # not numbers: Shaping names them, and the light is skipped
            continue
        inside = np.clip(value, low, high)  # NaN stays NaN, for Shaping to refuse
        if np.any(inside != value) and not np.any(np.isnan(value)):
            clamped.append(f"inputs:shaping:{usd_name} = {values[name]}")
            values[name] = float(inside) if inside.ndim == 0 else inside
    if clamped:
        skip("light shaping inputs outside their range were clamped to it (cone angle [0, 180], softness [0, 1], "
             "focus and focus tint >= 0), as UsdLux clamps the softness and ignores a negative focus", prim,
             ", ".join(clamped))
    values["ies"] = _read_profile(prim, get(api.GetShapingIesFileAttr(), None), skip, profiles)
    if values["ies"] is not None:
        values["ies_angle_scale"] = get(api.GetShapingIesAngleScaleAttr(), 0.0)
        normalize = get(api.GetShapingIesNormalizeAttr(), False)
        values["ies_normalize"] = normalize if isinstance(normalize, bool) else False
        if not isinstance(normalize, bool):
            skip("light switches authored with a type that is not bool were read as the schema's fallback", prim,
                 f"inputs:shaping:ies:normalize = {normalize!r}")
    return Shaping(**values)


def _read_profile(prim, asset, skip, profiles: dict | None):
    """The :class:`wrt.ies.IesProfile` of ``shaping:ies:file`` value ``asset`` (an ``Sdf.AssetPath`` or None), or
    None (with a warning naming the file where one is named but cannot be used)."""
    name = getattr(asset, "path", "") or ""
    if not name:
        return None
    resolved = getattr(asset, "resolvedPath", "") or ""
    if not resolved:
        skip("IES profiles (shaping:ies:file) that were not found are ignored; these lights emit without them", prim,
             name)
        return None
    profiles = {} if profiles is None else profiles
    if resolved not in profiles:
        try:
            profiles[resolved] = _read_resolved_profile(resolved)
        except IesError as e:
            profiles[resolved] = e
    found = profiles[resolved]
    if isinstance(found, IesError):
        skip("IES profiles (shaping:ies:file) that cannot be read are ignored; these lights emit without them", prim,
             str(found))
        return None
    return found


def _read_resolved_profile(resolved: str) -> IesProfile:
    """The profile of the IES file at resolved asset path ``resolved``: a file, or one packed in a ``.usdz``
    (``lamp.usdz[lamp.ies]``), which only USD's asset resolver opens, as it opens textures packed there."""
    from pxr import Ar

    if not Ar.IsPackageRelativePath(resolved):
        return read_ies(resolved)
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
    if asset is None:
        raise IesError(f"{resolved}: cannot be read (the package holds no such file)")
    return parse_ies(bytes(asset.GetBuffer()).decode("latin-1"), resolved)


@wp.func
def smooth_step(x: float, lo: float, hi: float):
    """0 up to ``lo``, 1 from ``hi`` on, the cubic Hermite step between; a step just after ``lo`` where ``lo = hi``
    (so a hard cone edge keeps the light at the cone angle itself)."""
    if x <= lo:
        return 0.0
    if x >= hi:
        return 1.0
    t = (x - lo) / (hi - lo)
    return t * t * (3.0 - 2.0 * t)


@wp.func
def cone_and_focus(params: wp.vec4, axis: wp.vec3, tint: wp.vec3, w: wp.vec3):
    """The colour factor of a shaped light (``params``: ``(theta_cut, theta_smooth_start, focus, 1)``, ``axis``: its
    unit primary axis, ``tint``: its focus tint) on the radiance it emits along unit ``w``."""
    cos_t = wp.clamp(wp.dot(w, axis), -1.0, 1.0)
    f = wp.vec3(1.0)
    if params[2] > 0.0:
        f = tint + (wp.vec3(1.0) - tint) * wp.pow(wp.abs(cos_t), params[2])
    return f * (1.0 - smooth_step(wp.acos(cos_t), params[1], params[0]))
