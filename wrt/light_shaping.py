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
importance sampling weigh the same radiance. IES profiles (``shaping:ies:*``) are not supported.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from .errors import SceneError, check_fields

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

    Raises:
        SceneError: naming the field, for a value that is not a finite number or lies outside its range.
    """

    cone_angle: float = 90.0
    cone_softness: float = 0.0
    focus: float = 0.0
    focus_tint: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3, np.float32))
    path = ""  # check_fields names this prim: none (load_usd's warning names the light of a bad shaping)

    def __post_init__(self):
        check_fields(self, ("cone_angle", (), None, float), ("cone_softness", (), None, float),
                     ("focus", (), 0.0, float), ("focus_tint", (3,), 0.0, np.float32))
        for name, (low, high, unit) in SHAPING_RANGES.items():
            value = getattr(self, name)
            if not low <= value <= high:
                raise SceneError(f"Shaping {name} must be in [{low:g}, {high:g}]{unit}, got {value!r}",
                                 prim=self.path or None)

    def at_fallbacks(self) -> bool:
        """True when every input has the schema's fallback value."""
        return (self.cone_angle, self.cone_softness, self.focus) == (90.0, 0.0, 0.0) and not np.any(self.focus_tint)

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
        factor averaged over the directions of a uniform sphere (``emits_behind``) or a Lambertian emitter."""
        params = self.device_params(emits_behind)
        if params is None:
            return 1.0
        cut, start, focus = params
        top = math.pi if emits_behind else 0.5 * math.pi
        theta = (np.arange(PROFILE_STEPS) + 0.5) * (top / PROFILE_STEPS)
        cos = np.cos(theta)
        weight = np.sin(theta) * (1.0 if emits_behind else cos)
        tint = float(np.dot(self.focus_tint, (0.2126, 0.7152, 0.0722)))
        factor = np.ones_like(theta) if focus <= 0.0 else tint + (1.0 - tint) * np.abs(cos) ** focus
        span = max(cut - start, 1e-30)
        t = np.clip((theta - start) / span, 0.0, 1.0)
        fade = np.where(theta <= start, 1.0, np.where(theta > cut, 0.0, 1.0 - t * t * (3.0 - 2.0 * t)))
        return float(np.sum(factor * fade * weight) / np.sum(weight))


def primary_axis(to_world, fallback) -> np.ndarray:
    """``(3,)`` unit world direction of the light's -Z axis under ``to_world`` (``(4, 4)`` column-vector), or
    ``fallback`` where the transform flattens it."""
    z = np.asarray(to_world, np.float64).reshape(4, 4)[:3, 2]
    length = float(np.linalg.norm(z))
    return -z / length if length > 0.0 else np.asarray(fallback, np.float64)


SHAPING_INPUTS = ("cone:angle", "cone:softness", "focus", "focusTint", "ies:file")  # after "inputs:shaping:"


def read_shaping(prim, get, skip) -> tuple[Shaping | None, bool]:
    """The :class:`Shaping` of a light prim (None without ShapingAPI or an authored shaping input: Hydra reads the
    inputs either way) and whether it names an IES profile. Inputs outside the ranges a :class:`Shaping` takes are
    clamped to them, as the schema clamps the softness and ignores a negative focus, with a warning through ``skip``.

    Args:
        prim: a ``UsdLux`` light prim.
        get: ``get(attr, default)`` of :func:`wrt.usd_lights.read_light` (unprefixed names of old files included).
        skip: ``skip(reason, prim, detail=None)``.
    """
    from pxr import UsdLux

    names = [f"{prefix}shaping:{name}" for name in SHAPING_INPUTS for prefix in ("inputs:", "")]
    authored = any(prim.GetAttribute(n) and prim.GetAttribute(n).HasAuthoredValue() for n in names)
    if not (prim.HasAPI(UsdLux.ShapingAPI) or authored):
        return None, False
    api = UsdLux.ShapingAPI(prim)
    ies = get(api.GetShapingIesFileAttr(), None)
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
    return Shaping(**values), bool(getattr(ies, "path", "") if ies is not None else "")


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
