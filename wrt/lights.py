"""Lights: the UsdLux lights users construct and their radiometry, which emissive triangles share (the UsdLux prims
are read by :mod:`wrt.usd_lights`; :mod:`wrt.light_table` builds the device's light table from them and
:mod:`wrt.light_sampling` samples it from a shading point).

Radiometry (every quantity is linear RGB; ``color`` below always means ``intensity * 2^exposure * color``,
times the blackbody colour when ``enableColorTemperature`` is on):

- **Area lights** (``SphereLight``, ``RectLight``, ``DiskLight``, ``CylinderLight``) emit radiance
  ``L = color``, or ``color / A`` with ``normalize`` on, where ``A`` is the world-space emitting area
  (``4 pi r^2``, ``w h``, ``pi r^2``, ``2 pi r l``; transforms included: a sphere scaled unevenly or sheared is an
  ellipsoid, a cylinder so scaled across its axis an elliptic or oblique tube, whose areas are integrated
  numerically, :mod:`wrt.affine_lights`). Rect and disk lights emit from their
  -Z side only; spheres and cylinders (no caps) emit outwards. A rect light's texture multiplies ``L`` where it
  lies (bilinearly filtered, clamped at the edges; upright seen from the lit side: the top-left texel at local
  ``(+X, +Y)``).
- ``SphereLight`` with ``treatAsPoint``: a point light of radiant intensity ``I = pi r^2 L`` (the sphere's
  intensity seen from afar), ``I = color / 4`` with ``normalize``; an ellipsoid's ``I = A L / 4`` (its intensity
  averaged over directions: a convex body's mean projected area is a quarter of its area, Cauchy).
- ``CylinderLight`` with ``treatAsLine`` (UsdLux: "effectively, a zero-radius cylinder"): a line light along the
  tube's axis, of intensity per unit length ``dI/ds = I_s sin(theta)`` in a direction at ``theta`` to the axis (the
  tube's projected width ``2 r sin(theta)`` per unit length seen from afar: ``I_s = 2 r L``), ``I_s = color / (pi l)``
  with ``normalize``; an elliptic or oblique tube's ``I_s = A L / (pi l)`` (its power, ``pi A L``, as the round tube's
  is, over the ``pi^2 l`` that ``sin(theta)`` integrates to). Like a point light it is sampled (by the angle each
  point of it is seen at) and never seen by rays.
- **DistantLight** with ``normalize`` on: ``color`` is the illuminance ``E`` at normal incidence. With ``normalize``
  off, ``color`` is the radiance of the sun disc of angular diameter ``angle``, so ``E = color * pi sin^2(angle/2)``.
  ``angle = 0`` makes a delta light whose ``color`` is ``E`` either way. Half the angle is clamped to [0, pi], as
  UsdLux clamps it: past 180 degrees the disc reaches surfaces turned away from it, and ``normalize`` divides by
  UsdLux's ``(2 - sin^2(angle/2)) pi`` instead.
- **DomeLight**: radiance ``color * texture(direction)`` (``texture = 1`` without a file; ``normalize`` is
  ignored). Latitude-longitude textures follow the OpenEXR convention: +Y is the pole, longitude 0 is +Z,
  longitude pi/2 is +X, the left image edge is longitude +pi (other ``texture:format`` layouts are resampled to
  lat-long when read: :mod:`wrt.dome_formats`); lookups are bilinear, wrapping around in longitude and clamped at
  the poles. ``DomeLight_1`` with ``poleAxis = "Z"`` (or
  ``"scene"`` on a Z-up stage) is turned so its pole is +Z.
- **Emissive triangles**: UsdPreviewSurface ``emissiveColor`` is the surface radiance, from the front side of
  single-sided meshes and from both sides of double-sided ones.
- **Mesh lights** (:class:`MeshLight`, UsdLux ``MeshLightAPI``): the mesh's triangles emit ``L = color`` (``color / A``
  with ``normalize``, ``A`` the mesh's world-space area), times the material's ``emissiveColor`` in the
  ``materialGlowTintsLight`` mode, sided as emissive triangles. Camera rays see the material's glow (the light in
  ``noMaterialResponse``); rays a surface scattered see what light sampling draws.
- A Lambertian surface of albedo ``rho`` under illuminance ``E`` therefore shows radiance ``rho E / pi``.
- **Multipliers** ``diffuse`` and ``specular`` (UsdLux's non-physical controls) scale what surfaces reflect of a
  light through their diffuse lobe and their specular lobes (:func:`wrt.light_sampling.lobe_factor`); camera rays
  see lights unscaled.
- **Shaping** (``ShapingAPI`` cone, softness, focus and focus tint, and an IES profile, :mod:`wrt.light_shaping`,
  :mod:`wrt.ies`) multiplies what sphere, rect, disk and cylinder lights emit in each direction, after ``normalize``,
  for light sampling and for rays that see the light alike.

Light and shadow linking (``collection:lightLink``, ``collection:shadowLink``) limit the geometry a UsdLux light lights
and the geometry that casts its shadows (:mod:`wrt.light_links`). ``ShadowAPI``: ``shadow:enable`` off lets the
light through every occluder, ``shadow:color`` tints what occluders stop of it (``shadow_color``: the shadowed
surface gets the light times the colour), and ``shadow:distance`` limits how far from a surface point occluders cast
its shadows (``shadow_distance``), fading out over the last ``shadow_falloff`` of it (as ``shadow_falloff_gamma``
shapes the fade). Lights are invisible to shadow rays (they never
occlude) but visible to camera and bounce rays, which pass through them and pick up their radiance. Stages with no
UsdLux light and no emissive material get :func:`default_lights`: a headlight along the view direction and a grey dome;
not those whose lights all give none (hidden or skipped: ``Scene.dark_lights``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .affine_lights import ellipsoid_area, elliptic_tube_area, flat, right_angled, similar
from .errors import SceneError, bottom_row_problem, check_fields, check_flags, prim_path, stray_field, unit_vector
from .light_links import LinkCollection
from .light_shaping import Shaping
from .ray_batch import host_array
from .scene import DistantLight

HEADLIGHT_ILLUMINANCE = 0.8 * math.pi  # default headlight: a white surface facing the camera shows 0.8 from it
DEFAULT_DOME_RADIANCE = (0.2, 0.2, 0.2)  # default dome: adds 0.2 * albedo to an unoccluded surface


# check_fields specs shared by the lights below.
_COLOR = ("color", (3,), 0.0, np.float32)  # a negative colour would take light away: negative pixels
_TO_WORLD = ("to_world", (4, 4), None, np.float64)
# UsdLux's diffuse and specular multipliers: a negative one would take light away.
_MULTIPLIERS = (("diffuse", (), 0.0, float), ("specular", (), 0.0, float))


def _size(name: str) -> tuple:
    """The check_fields spec of a size: a NaN or infinite one lit nothing without a word."""
    return (name, (), 0.0, float)


def check_shadow_api(light) -> None:
    """Checks a light's ``shadow_color`` (None, or ``(3,)`` finite numbers >= 0), ``shadow_distance`` and
    ``shadow_falloff`` (finite numbers) and ``shadow_falloff_gamma`` (a finite number >= 0), naming the light:
    ShadowAPI's inputs, as :mod:`wrt.light_table` uploads them."""
    if light.shadow_color is not None:
        check_fields(light, ("shadow_color", (3,), 0.0, np.float32))
    check_fields(light, ("shadow_distance", (), None, float), ("shadow_falloff", (), None, float),
                 ("shadow_falloff_gamma", (), 0.0, float))


def shadow_api_row(light) -> np.ndarray | None:
    """``(6,)`` float32 ``(shadow colour, shadow distance, falloff, falloff gamma)`` of a light whose shadows
    ShadowAPI changes (a colour other than black or a distance >= 0, shadows on), or None: plain shadows (or none).
    The falloff is the width of the fading zone, at most the distance (as the schema says), 0 for none."""
    color = getattr(light, "shadow_color", None)
    distance = getattr(light, "shadow_distance", -1.0)
    tinted = color is not None and bool(np.any(np.asarray(color) > 0.0))
    if not light.shadows or not (tinted or distance >= 0.0):
        return None
    falloff = min(max(getattr(light, "shadow_falloff", -1.0), 0.0), distance) if distance >= 0.0 else 0.0
    gamma = getattr(light, "shadow_falloff_gamma", 1.0)
    return np.array([*(color if color is not None else np.zeros(3)), distance, falloff, gamma], np.float32)


def check_affine(light) -> None:
    """Refuses a light whose ``to_world`` has a bottom row other than ``(0, 0, 0, 1)``: only its top 3x4 is read, and
    a ``Gf.Matrix4d`` passed untransposed (translation in the bottom row) put the light at the origin, turned the
    other way, without a word.

    Raises:
        SceneError: naming the light and its bottom row.
    """
    problem = bottom_row_problem(f"{type(light).__name__} to_world", light.to_world)
    if problem:
        raise SceneError(problem, prim=light.path or None)


def round_tube(m3: np.ndarray, rtol: float = 1e-4) -> bool:
    """Whether a CylinderLight of local-to-world linear part ``m3`` stays a round tube: its Y and Z axes of one
    length, at right angles to each other and to its X axis (the tube's)."""
    x, y, z = np.asarray(m3, np.float64).T
    # Relative alone (np.isclose's atol of 1e-8 made any tube thinner than 1e-8 round)
    return bool(np.isclose(np.linalg.norm(y), np.linalg.norm(z), rtol=rtol, atol=0.0)
                and right_angled(x, y, z, rtol=rtol))


def light_axes(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Columns X, Y, Z (scaled) and the origin of a column-vector ``(4, 4)`` transform."""
    m = np.asarray(to_world, np.float64).reshape(4, 4)
    return m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3]


@dataclasses.dataclass
class SphereLight:
    """``UsdLux.SphereLight``: a sphere emitting outwards.

    Attributes:
        position: ``(3,)`` world-space centre.
        radius: world-space radius.
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        normalize: divide by the area ``4 pi r^2``.
        treat_as_point: render as a point light.
        path: prim path.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        shaping: its :class:`Shaping` (``ShapingAPI``), or None.
        axis: ``(3,)`` world direction of the light's -Z axis, which its shaping is centred on (made unit).
        x_axis: ``(3,)`` world direction of the light's +X axis, where an IES profile's horizontal angles start (its
            part perpendicular to ``axis`` counts).
        y_axis: ``(3,)`` world direction of the light's +Y axis, or None: ``Z x X``. Under a mirroring transform it
            points the other way, and so do an IES profile's 90-degree angles (``load_usd`` sets it).
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
        shadow_color: ``(3,)`` the colour its shadows are tinted by (``ShadowAPI`` ``inputs:shadow:color``): occluded
            light arrives times it; None: black, plain shadows.
        shadow_distance: how far from a surface point occluders cast its shadows (``inputs:shadow:distance``);
            negative: any distance.
        shadow_falloff: the width of the zone at the end of ``shadow_distance`` over which its shadows fade out
            (``inputs:shadow:falloff``, at most the distance); 0 or negative (or no distance): none.
        shadow_falloff_gamma: shadow strength in that zone is ``t ** gamma``, ``t`` falling linearly from 1 at its
            start to 0 at ``shadow_distance`` (``inputs:shadow:falloffGamma``, >= 0).
        frame: ``(3, 3)`` linear part of the light's local-to-world transform, or None. With it ``radius`` is in
            its local units: the light is the ellipsoid ``position + radius * frame @ u`` (``|u| = 1``). A frame
            that flattens the sphere (a singular one) makes a sphere of the mean scaled radius.
    """

    position: np.ndarray
    radius: float
    color: np.ndarray
    normalize: bool = False
    treat_as_point: bool = False
    path: str = ""
    shadows: bool = True
    shaping: Shaping | None = None
    axis: np.ndarray = dataclasses.field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    x_axis: np.ndarray = dataclasses.field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    y_axis: np.ndarray | None = None
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None
    shadow_color: np.ndarray | None = None
    shadow_distance: float = -1.0
    shadow_falloff: float = -1.0
    shadow_falloff_gamma: float = 1.0
    frame: np.ndarray | None = None

    def __post_init__(self):
        check_fields(self, ("position", (3,), None, np.float64), _size("radius"), _COLOR,
                     ("axis", (3,), None, np.float64), ("x_axis", (3,), None, np.float64), *_MULTIPLIERS)
        check_flags(self, "normalize", "treat_as_point", "shadows")
        check_shadow_api(self)
        if self.frame is not None:
            check_fields(self, ("frame", (3, 3), None, np.float64))
        if self.y_axis is not None:
            check_fields(self, ("y_axis", (3,), None, np.float64))
        self.axis = self.unit_axis()
        _check_shaping(self)

    def ellipsoid(self) -> np.ndarray | None:
        """``(3, 3)`` float64 map from the unit sphere to the light (``radius * frame``), or None where the light is
        a round sphere (of :attr:`world_radius`): no frame, one that only turns and scales evenly, or a flat one."""
        if self.frame is None or similar(self.frame):
            return None
        m = self.radius * np.asarray(self.frame, np.float64)
        return None if flat(m) else m

    @property
    def world_radius(self) -> float:
        """The radius of a round light in the world: ``radius`` times the frame's mean scale."""
        if self.frame is None:
            return self.radius
        return self.radius * float(np.mean(np.linalg.norm(np.asarray(self.frame, np.float64), axis=0)))

    def unit_axis(self) -> np.ndarray:
        """``(3,)`` ``axis`` made unit, as the shaping uses it (it may be set to any length after construction)."""
        axis = np.asarray(self.axis, np.float64)
        length = float(np.linalg.norm(axis)) if axis.shape == (3,) else 0.0
        if not (length > 0.0 and math.isfinite(length)):
            raise SceneError(f"SphereLight axis must be a nonzero finite 3-vector, got {axis.tolist()}",
                             prim=self.path or None)
        return unit_vector(axis, length)  # the same array where it is unit already (checked before)

    @property
    def area(self) -> float:
        m = self.ellipsoid()
        return 4.0 * math.pi * self.world_radius**2 if m is None else ellipsoid_area(m)

    @property
    def radiance(self) -> np.ndarray:
        """``(3,)`` emitted radiance."""
        return normalized_radiance(self.color, self.area, self.normalize)

    @property
    def drawn_as_point(self) -> bool:
        """Whether the light is drawn as a point light: ``treat_as_point``, or a sphere of no size (a ``radius`` of
        0) or a normalized one too small for its radiance (``color / area``) to fit in float32, as ``load_usd`` makes
        such lights point lights (the limit they tend to). Built in Python they lit nothing, their radiance 0 or
        inf."""
        if self.treat_as_point or not self.world_radius > 0.0:
            return True
        return self.normalize and not (self.area > 0.0 and np.all(np.isfinite(self.radiance)))

    @property
    def intensity(self) -> np.ndarray:
        """``(3,)`` radiant intensity when treated as a point (averaged over directions for an ellipsoid)."""
        if self.normalize:
            return np.asarray(self.color, np.float32) / 4.0
        if self.ellipsoid() is not None:
            return (np.asarray(self.color, np.float32) * (self.area / 4.0)).astype(np.float32)
        return (np.asarray(self.color, np.float32) * math.pi * self.world_radius**2).astype(np.float32)


@dataclasses.dataclass
class RectLight:
    """``UsdLux.RectLight``: a ``width x height`` rectangle in the local XY plane emitting along local -Z.

    Attributes:
        to_world: ``(4, 4)`` column-vector local-to-world transform.
        width: along local X.
        height: along local Y.
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        normalize: divide by the world-space area.
        path: prim path.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        shaping: its :class:`Shaping` (``ShapingAPI``, centred on the local -Z axis), or None.
        texture: ``(H, W, 3)`` or ``(H, W, 4)`` float32 linear image (``inputs:texture:file``) multiplying the
            radiance, or None. Seen from the lit side it stands upright: its top-left texel at local ``(+X, +Y)``,
            its bottom-right at ``(-X, -Y)`` (UsdLux: "min coordinates at (+X, +Y)").
        texture_path: file the texture came from.
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
        shadow_color: ``(3,)`` the colour its shadows are tinted by (``ShadowAPI`` ``inputs:shadow:color``): occluded
            light arrives times it; None: black, plain shadows.
        shadow_distance: how far from a surface point occluders cast its shadows (``inputs:shadow:distance``);
            negative: any distance.
        shadow_falloff: the width of the zone at the end of ``shadow_distance`` over which its shadows fade out
            (``inputs:shadow:falloff``, at most the distance); 0 or negative (or no distance): none.
        shadow_falloff_gamma: shadow strength in that zone is ``t ** gamma``, ``t`` falling linearly from 1 at its
            start to 0 at ``shadow_distance`` (``inputs:shadow:falloffGamma``, >= 0).
    """

    to_world: np.ndarray
    width: float
    height: float
    color: np.ndarray
    normalize: bool = False
    path: str = ""
    shadows: bool = True
    shaping: Shaping | None = None
    texture: np.ndarray | None = None
    texture_path: str = ""
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None
    shadow_color: np.ndarray | None = None
    shadow_distance: float = -1.0
    shadow_falloff: float = -1.0
    shadow_falloff_gamma: float = 1.0

    def __post_init__(self):
        check_fields(self, _TO_WORLD, _size("width"), _size("height"), _COLOR, *_MULTIPLIERS)
        check_flags(self, "normalize", "shadows")
        check_shadow_api(self)
        check_affine(self)
        _check_shaping(self)
        self.texture = _checked_texture(self)

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, _, _ = light_axes(self.to_world)
        return x * self.width, y * self.height

    @property
    def area(self) -> float:
        u, v = self.edges()
        return float(np.linalg.norm(np.cross(u, v)))

    @property
    def radiance(self) -> np.ndarray:
        return normalized_radiance(self.color, self.area, self.normalize)


@dataclasses.dataclass
class DiskLight:
    """``UsdLux.DiskLight``: a disk of ``radius`` in the local XY plane emitting along local -Z.

    Attributes:
        to_world: ``(4, 4)`` column-vector local-to-world transform.
        radius: local radius.
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        normalize: divide by the world-space area.
        path: prim path.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        shaping: its :class:`Shaping` (``ShapingAPI``, centred on the local -Z axis), or None.
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
        shadow_color: ``(3,)`` the colour its shadows are tinted by (``ShadowAPI`` ``inputs:shadow:color``): occluded
            light arrives times it; None: black, plain shadows.
        shadow_distance: how far from a surface point occluders cast its shadows (``inputs:shadow:distance``);
            negative: any distance.
        shadow_falloff: the width of the zone at the end of ``shadow_distance`` over which its shadows fade out
            (``inputs:shadow:falloff``, at most the distance); 0 or negative (or no distance): none.
        shadow_falloff_gamma: shadow strength in that zone is ``t ** gamma``, ``t`` falling linearly from 1 at its
            start to 0 at ``shadow_distance`` (``inputs:shadow:falloffGamma``, >= 0).
    """

    to_world: np.ndarray
    radius: float
    color: np.ndarray
    normalize: bool = False
    path: str = ""
    shadows: bool = True
    shaping: Shaping | None = None
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None
    shadow_color: np.ndarray | None = None
    shadow_distance: float = -1.0
    shadow_falloff: float = -1.0
    shadow_falloff_gamma: float = 1.0

    def __post_init__(self):
        check_fields(self, _TO_WORLD, _size("radius"), _COLOR, *_MULTIPLIERS)
        check_flags(self, "normalize", "shadows")
        check_shadow_api(self)
        check_affine(self)
        _check_shaping(self)

    @property
    def area(self) -> float:
        x, y, _, _ = light_axes(self.to_world)
        return float(math.pi * np.linalg.norm(np.cross(x * self.radius, y * self.radius)))

    @property
    def radiance(self) -> np.ndarray:
        return normalized_radiance(self.color, self.area, self.normalize)


@dataclasses.dataclass
class CylinderLight:
    """``UsdLux.CylinderLight``: a tube of ``length`` along local X and ``radius``, emitting outwards (no caps); a
    transform scaling Y and Z unevenly, or shearing them, makes an elliptic or oblique tube.

    Attributes:
        to_world: ``(4, 4)`` column-vector local-to-world transform.
        length: along local X.
        radius: local radius.
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        normalize: divide by the world-space area.
        path: prim path.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        shaping: its :class:`Shaping` (``ShapingAPI``, centred on the local -Z axis), or None.
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
        shadow_color: ``(3,)`` the colour its shadows are tinted by (``ShadowAPI`` ``inputs:shadow:color``): occluded
            light arrives times it; None: black, plain shadows.
        shadow_distance: how far from a surface point occluders cast its shadows (``inputs:shadow:distance``);
            negative: any distance.
        shadow_falloff: the width of the zone at the end of ``shadow_distance`` over which its shadows fade out
            (``inputs:shadow:falloff``, at most the distance); 0 or negative (or no distance): none.
        shadow_falloff_gamma: shadow strength in that zone is ``t ** gamma``, ``t`` falling linearly from 1 at its
            start to 0 at ``shadow_distance`` (``inputs:shadow:falloffGamma``, >= 0).
        treat_as_line: render as a line light along the axis (UsdLux ``treatAsLine``; see the module docstring).
    """

    to_world: np.ndarray
    length: float
    radius: float
    color: np.ndarray
    normalize: bool = False
    path: str = ""
    shadows: bool = True
    shaping: Shaping | None = None
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None
    shadow_color: np.ndarray | None = None
    shadow_distance: float = -1.0
    shadow_falloff: float = -1.0
    shadow_falloff_gamma: float = 1.0
    treat_as_line: bool = False

    def __post_init__(self):
        check_fields(self, _TO_WORLD, _size("length"), _size("radius"), _COLOR, *_MULTIPLIERS)
        check_flags(self, "normalize", "shadows", "treat_as_line")
        check_shadow_api(self)
        check_affine(self)
        _check_shaping(self)

    def world_shape(self) -> tuple[np.ndarray, float]:
        """World-space axis vector (full length) and radius (mean of the Y and Z scales) of a round tube."""
        x, y, z, _ = light_axes(self.to_world)
        return x * self.length, self.radius * 0.5 * (np.linalg.norm(y) + np.linalg.norm(z))

    def tube(self) -> np.ndarray | None:
        """``(3, 3)`` float64 map from the unit tube (radius 1, length 1 along X) to the light, or None where the light
        is a round tube (:meth:`world_shape`): its Y and Z axes of one length at right angles to each other and to X,
        or a transform that flattens it (a singular one), for which the round tube of the mean scale stands in."""
        m3 = np.asarray(self.to_world, np.float64)[:3, :3]
        if round_tube(m3):
            return None
        m = m3 * np.array([self.length, self.radius, self.radius])
        return None if flat(m) else m

    @property
    def area(self) -> float:
        m = self.tube()
        if m is not None:
            return elliptic_tube_area(m)
        axis, r = self.world_shape()
        return float(2.0 * math.pi * r * np.linalg.norm(axis))

    @property
    def radiance(self) -> np.ndarray:
        return normalized_radiance(self.color, self.area, self.normalize)

    @property
    def drawn_as_line(self) -> bool:
        """Whether the light is drawn as a line light: ``treat_as_line``, or a normalized tube (its axis of some
        length) of radius 0 or too thin for its radiance (``color / area``) to fit in float32, as ``load_usd`` makes
        such lights line lights (UsdLux's "zero-radius cylinder", the limit they tend to, of the tube's power: a tube
        emits ``I_s sin(theta)`` per unit length whatever its radius). Built in Python they lit nothing, their
        radiance 0 or inf."""
        if self.treat_as_line:
            return True
        if not (self.normalize and np.linalg.norm(self.world_shape()[0]) > 0.0):
            return False
        return not (self.area > 0.0 and np.all(np.isfinite(self.radiance)))

    @property
    def line_intensity(self) -> np.ndarray:
        """``(3,)`` float32 ``I_s`` of the light treated as a line: radiant intensity per unit length at right angles
        to the axis (see the module docstring); 0 for a line of no length, which emits nothing."""
        length = float(np.linalg.norm(self.world_shape()[0]))
        if not length > 0.0:
            return np.zeros(3, np.float32)
        color = np.asarray(self.color, np.float64)
        per_length = color / (math.pi * length) if self.normalize else color * (self._line_area() / (math.pi * length))
        with np.errstate(over="ignore"):  # past float32: fits_float32 skips the light
            return per_length.astype(np.float32)

    def _line_area(self) -> float:
        """The lateral area of the tube a line light stands for, that of a tube flattened by its transform (a ribbon)
        included: the line keeps its power, and the round tube of the mean scaled radius that stands in for a
        flattened tube drawn as one (:meth:`tube`) made a ribbon's line 21% dimmer than one squashed by 1e-3."""
        m3 = np.asarray(self.to_world, np.float64)[:3, :3]
        if round_tube(m3):
            return self.area
        return elliptic_tube_area(m3 * np.array([self.length, self.radius, self.radius]))


# UsdLux light:materialSyncMode values: how a mesh light's material and its light relate (see MeshLight).
GLOW_TINTS_LIGHT = "materialGlowTintsLight"  # MeshLightAPI's fallback
INDEPENDENT = "independent"
NO_MATERIAL_RESPONSE = "noMaterialResponse"  # LightAPI's fallback
MATERIAL_SYNC_MODES = (GLOW_TINTS_LIGHT, INDEPENDENT, NO_MATERIAL_RESPONSE)


@dataclasses.dataclass
class MeshLight:
    """``UsdLux.MeshLightAPI`` (or ``LightAPI``) on a mesh: its triangles emit from their front side (both sides where
    the mesh is ``doubleSided``, as emissive materials do) and are sampled by area, as emissive triangles are.

    Attributes:
        path: prim path of the emitting mesh: the :attr:`wrt.Scene.meshes` entries of that path, and the prototype
            meshes of that path, which emit in each instance (each instance's copy normalized by its own area).
            A mesh light inside a native prototype is named by its instance proxy in the prototype's first instance
            (``/A/Light``, by path order), a name that stays when the stage is opened again, and lights from every
            instance; ``mesh`` then holds the prototype path its meshes have.
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        normalize: divide by the world-space area of the mesh.
        material_sync: ``light:materialSyncMode``. ``"noMaterialResponse"`` (LightAPI's fallback, and any mode
            on a mesh with no material): radiance ``color`` everywhere, which camera rays see too; the surface
            reflects, transmits and emits nothing else, whatever material the mesh has.
            ``"materialGlowTintsLight"`` (MeshLightAPI's): ``color`` times the ``emissiveColor`` of each triangle's
            material (triangles that do not glow emit nothing);
            ``"independent"``: ``color`` everywhere. In these two, camera rays see the material as it is, its own
            glow included.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
        mesh: path of the meshes that emit when it is not ``path``; "": ``path``.
        shadow_color, shadow_distance, shadow_falloff, shadow_falloff_gamma: its ShadowAPI inputs, as a
            :class:`SphereLight`'s; every triangle of the light casts its shadows so.
    """

    path: str
    color: np.ndarray
    normalize: bool = False
    material_sync: str = NO_MATERIAL_RESPONSE
    shadows: bool = True
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None
    mesh: str = ""
    shadow_color: np.ndarray | None = None
    shadow_distance: float = -1.0
    shadow_falloff: float = -1.0
    shadow_falloff_gamma: float = 1.0

    @property
    def mesh_path(self) -> str:
        """The path of the meshes that emit."""
        return self.mesh or self.path

    def __post_init__(self):
        check_fields(self, _COLOR, *_MULTIPLIERS)
        check_flags(self, "normalize", "shadows")
        check_shadow_api(self)
        if type(self.mesh) is not str:  # an int or pathlib path named no mesh: "MeshLight names no mesh of the scene"
            self.mesh = prim_path(self.mesh, f"wrt.MeshLight {self.path} mesh", optional=True)
        if self.material_sync not in MATERIAL_SYNC_MODES:
            raise SceneError(f"MeshLight material_sync must be one of {', '.join(MATERIAL_SYNC_MODES)}, got "
                             f"{self.material_sync!r}", prim=self.path or None)


@dataclasses.dataclass
class DomeLight:
    """``UsdLux.DomeLight``: radiance arriving from every direction.

    Attributes:
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        to_world: ``(4, 4)`` column-vector transform; its rotation turns the texture (the nearest rotation of a
            sheared or unevenly scaled transform).
        texture: ``(H, W, 4)`` float32 linear latitude-longitude image, or None for a constant dome.
        texture_path: file the texture came from.
        path: prim path.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
        shadow_color: ``(3,)`` the colour its shadows are tinted by (``ShadowAPI`` ``inputs:shadow:color``): occluded
            light arrives times it; None: black, plain shadows.
        shadow_distance: how far from a surface point occluders cast its shadows (``inputs:shadow:distance``);
            negative: any distance.
        shadow_falloff: the width of the zone at the end of ``shadow_distance`` over which its shadows fade out
            (``inputs:shadow:falloff``, at most the distance); 0 or negative (or no distance): none.
        shadow_falloff_gamma: shadow strength in that zone is ``t ** gamma``, ``t`` falling linearly from 1 at its
            start to 0 at ``shadow_distance`` (``inputs:shadow:falloffGamma``, >= 0).
    """

    color: np.ndarray
    to_world: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(4))
    texture: np.ndarray | None = None
    texture_path: str = ""
    path: str = ""
    shadows: bool = True
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None
    shadow_color: np.ndarray | None = None
    shadow_distance: float = -1.0
    shadow_falloff: float = -1.0
    shadow_falloff_gamma: float = 1.0

    def __post_init__(self):
        check_fields(self, _COLOR, _TO_WORLD, *_MULTIPLIERS)
        check_flags(self, "shadows")
        check_shadow_api(self)
        check_affine(self)
        self.texture = _checked_texture(self)


# The kinds of light Scene.lights holds.
LIGHT_TYPES = (DistantLight, SphereLight, RectLight, DiskLight, CylinderLight, DomeLight, MeshLight)


def check_light_types(lights: list) -> None:
    """Raises ``TypeError`` naming ``scene.lights[k]``, the first entry of ``lights`` that is no wrt light (None, a
    Shaping, a path): it failed at the render with 'unsupported light NoneType', naming no entry. The Scene checks
    them when made, a render again (a light appended to the list since)."""
    for k, light in enumerate(lights):
        if not isinstance(light, LIGHT_TYPES):
            raise TypeError(f"scene.lights[{k}] is a {type(light).__name__}, not a wrt light (one of "
                            f"{', '.join('wrt.' + t.__name__ for t in LIGHT_TYPES)})")


# UsdLux inputs that wrt folds into a light's ``color``: no field of any light, so that set on one built in Python
# (``light.intensity = 2``) they were kept as attributes that no render reads.
FOLDED_INPUTS = ("intensity", "exposure", "color_temperature", "enable_color_temperature", "colorTemperature",
                 "enableColorTemperature")


def check_folded_inputs(light) -> None:
    """Refuses a light given an attribute named after a UsdLux input that wrt folds into ``color``
    (:data:`FOLDED_INPUTS`), or any other that is none of its fields (:func:`wrt.errors.stray_field`): a dataclass
    keeps any attribute, and the light shone on as before without a word.
    Checked with the light's fields before a render (:func:`wrt.render.check_lights`), not at each assignment, which
    would slow every light's construction (the loader's too).

    Raises:
        SceneError: naming the light and the attribute.
    """
    state = getattr(light, "__dict__", {})
    for name in FOLDED_INPUTS:
        if name in state:
            raise SceneError(f"{type(light).__name__} has no field {name}: its color is UsdLux's intensity * "
                             "2**exposure * color (times the blackbody colour of an enabled colorTemperature); set "
                             "color", prim=getattr(light, "path", "") or None)
    stray = stray_field(light) if dataclasses.is_dataclass(light) else ""  # light.angle = 5 on a SphereLight, ...
    if stray:
        raise SceneError(f"{type(light).__name__} {stray}", prim=getattr(light, "path", "") or None)


def _checked_texture(light) -> np.ndarray | None:
    """``light.texture`` as float32, or None; any shape but ``(H, W, 3 or 4)`` raises, naming the light (it failed
    deep in Warp, a TypeError about 'dome_texels'), and so do samples that are not floats, as ``scene.textures``'
    do: an 8-bit image (``uint8`` 0-255) lit the scene 255 times too brightly without a word."""
    if light.texture is None:
        return None
    try:  # one on a GPU copied to the host, as a mesh's arrays are
        texture = np.asarray(host_array(f"{type(light).__name__} texture", light.texture))
    except (TypeError, ValueError):
        texture = np.zeros(0)
    if texture.ndim != 3 or texture.shape[2] not in (3, 4) or texture.size == 0 or texture.dtype.kind not in "biuf":
        shape = getattr(light.texture, "shape", type(light.texture).__name__)
        raise SceneError(f"{type(light).__name__} texture must be an (H, W, 3) or (H, W, 4) array of numbers, got "
                         f"{shape}", prim=light.path or None)
    if texture.dtype.kind != "f":
        raise SceneError(f"{type(light).__name__} texture must hold linear float values, got {texture.dtype} (an 8-bit "
                         "image: wrt.textures.load_image reads files into linear float32 RGBA)",
                         prim=light.path or None)
    return texture.astype(np.float32, copy=False)


def _check_shaping(light) -> None:
    """Refuses a ``shaping`` that is not a :class:`Shaping` (or None), or one given a bad value since it was made
    (``light.shaping.cone_angle = 270``), naming the light: the shaping's own check names no light."""
    if light.shaping is not None and not isinstance(light.shaping, Shaping):
        raise SceneError(f"{type(light).__name__} shaping must be a wrt.Shaping or None, got "
                         f"{type(light.shaping).__name__}", prim=light.path or None)
    if light.shaping is not None:
        try:
            light.shaping.__post_init__()
        except SceneError as e:
            raise SceneError(f"{type(light).__name__} shaping: {e}", prim=light.path or None) from None


def normalized_radiance(color, area: float, normalize: bool) -> np.ndarray:
    """``(3,)`` float32 radiance of a light of ``color`` and world-space ``area``: ``color / area`` with ``normalize``
    (0 for a zero area), else ``color``."""
    color = np.asarray(color, np.float32)
    if not normalize:
        return color.copy()
    with np.errstate(over="ignore", divide="ignore"):  # inf past float32's range (wrt.usd_lights reports it)
        return (color / np.float64(area)).astype(np.float32) if area > 0.0 else np.zeros(3, np.float32)


def default_lights(forward) -> list:
    """The lights of a stage with none: a headlight travelling along ``forward`` (illuminance
    :data:`HEADLIGHT_ILLUMINANCE`) and a constant dome of radiance :data:`DEFAULT_DOME_RADIANCE`."""
    forward = np.asarray(forward, np.float64)
    return [
        DistantLight(direction=forward / np.linalg.norm(forward), color=np.full(3, HEADLIGHT_ILLUMINANCE),
                     path="<headlight>"),
        DomeLight(color=np.asarray(DEFAULT_DOME_RADIANCE, np.float32), path="<dome>"),
    ]
