"""Lights: UsdLux lights and emissive triangles, their radiometry, and sampling them from a shading point (the UsdLux
prims are read by :mod:`wrt.usd_lights`).

Radiometry (every quantity is linear RGB; ``color`` below always means ``intensity * 2^exposure * color``,
times the blackbody colour when ``enableColorTemperature`` is on):

- **Area lights** (``SphereLight``, ``RectLight``, ``DiskLight``, ``CylinderLight``) emit radiance
  ``L = color``, or ``color / A`` with ``normalize`` on, where ``A`` is the world-space emitting area
  (``4 pi r^2``, ``w h``, ``pi r^2``, ``2 pi r l``; transforms included). Rect and disk lights emit from their
  -Z side only; spheres and cylinders (no caps) emit outwards. A rect light's texture multiplies ``L`` where it
  lies (bilinearly filtered, clamped at the edges; upright seen from the lit side: the top-left texel at local
  ``(+X, +Y)``).
- ``SphereLight`` with ``treatAsPoint``: a point light of radiant intensity ``I = pi r^2 L`` (the sphere's
  intensity seen from afar), ``I = color / 4`` with ``normalize``.
- **DistantLight** with ``normalize`` on: ``color`` is the illuminance ``E`` at normal incidence. With ``normalize``
  off, ``color`` is the radiance of the sun disc of angular diameter ``angle``, so ``E = color * pi sin^2(angle/2)``.
  ``angle = 0`` makes a delta light whose ``color`` is ``E`` either way.
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
  light through their diffuse lobe and their specular lobes (:func:`lobe_factor`); camera rays see lights unscaled.
- **Shaping** (``ShapingAPI`` cone, softness, focus and focus tint, :mod:`wrt.light_shaping`) multiplies what sphere,
  rect, disk and cylinder lights emit in each direction, after ``normalize``, for light sampling and for rays that
  see the light alike.

Light and shadow linking (``collection:lightLink``, ``collection:shadowLink``) limit the geometry a UsdLux light lights
and the geometry that casts its shadows (:mod:`wrt.light_links`). Lights are invisible to shadow rays (they never
occlude) but visible to camera and bounce rays, which pass through them and pick up their radiance. Stages with no
UsdLux light and no emissive material get :func:`default_lights`: a headlight along the view direction and a grey dome.

Sampling: light ``k`` is picked with probability ``0.5 * power_k / sum(power) + 0.5 / count`` (a shaped light's power
times the share its shaping lets out); spheres are sampled by the cone they subtend; rect lights, and disk lights
that look large, uniformly by solid angle (Urena et al. 2013; disks through the square around them;
:mod:`wrt.spherical_rect`); other disk lights, rect lights that look tiny, cylinder and triangle lights uniformly by
area (cylinders: the half facing the shading point); soft distant lights
uniformly in their cone; a constant dome cosine-weighted about the shading normal and a textured dome by the
luminance of its filtered texture averaged over each texel (piecewise-constant 2D distribution, Pharr et al., PBRT
4th ed., A.5 and 12.5), so that every direction the filtered texture lights can be drawn.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import warp as wp

from .errors import SceneError, check_fields
from .geometry import stable_length
from .light_links import CASTS_SHADOW, DeviceLinks, LinkCollection, link_groups, upload_links
from .light_shaping import Shaping, cone_and_focus, primary_axis
from .materials import DeviceMaterials, cut_out, eval_emission
from .sampling import (
    INV_PI,
    PI,
    basis_x,
    basis_y,
    cdf_remainder,
    sample_cdf,
    sample_concentric_disk,
    sample_cosine_hemisphere,
    sample_uniform_cone,
    sample_uniform_sphere,
    to_world,
)
from .scene import DeviceScene, DistantLight
from .spherical_rect import sample_spherical_rect, solid_angle_usable, spherical_rect, spherical_rect_pdf
from .textures import WRAP_CLAMP, WRAP_REPEAT, wrap_coord

LIGHT_DISTANT = wp.constant(0)
LIGHT_SPHERE = wp.constant(1)
LIGHT_RECT = wp.constant(2)
LIGHT_DISK = wp.constant(3)
LIGHT_CYLINDER = wp.constant(4)
LIGHT_DOME = wp.constant(5)
LIGHT_POINT = wp.constant(6)
LIGHT_TRIANGLE = wp.constant(7)

# DeviceLights.shadows: what blocks a light's shadow rays.
SHADOWS_OFF = wp.constant(0)  # nothing: ShadowAPI's shadow:enable is off (the rays are not traced)
SHADOWS_ON = wp.constant(1)  # every prim
SHADOWS_LINKED = wp.constant(2)  # only the prims its collection:shadowLink includes (it leaves some out)

# A disk light is sampled by solid angle through the square around it, which wastes the 21% of samples that fall
# outside the disk: worth it only where the disk looks large (sr of the square), where area sampling is noisy.
DISK_SOLID_ANGLE_LEAST = wp.constant(1.0)

HEADLIGHT_ILLUMINANCE = 0.8 * math.pi  # default headlight: a white surface facing the camera shows 0.8 from it
DEFAULT_DOME_RADIANCE = (0.2, 0.2, 0.2)  # default dome: adds 0.2 * albedo to an unoccluded surface
INPUTS_PREFIX = "inputs:"  # UsdLux attributes carry it since USD 21.05; older files author the bare names


# Host-side lights -------------------------------------------------------------------------------------------------


# check_fields specs shared by the lights below.
_COLOR = ("color", (3,), 0.0, np.float32)  # a negative colour would take light away: negative pixels
_TO_WORLD = ("to_world", (4, 4), None, np.float64)
# UsdLux's diffuse and specular multipliers: a negative one would take light away.
_MULTIPLIERS = (("diffuse", (), 0.0, float), ("specular", (), 0.0, float))


def _size(name: str) -> tuple:
    """The check_fields spec of a size: a NaN or infinite one lit nothing without a word."""
    return (name, (), 0.0, float)


def _axes(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
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
    diffuse: float = 1.0
    specular: float = 1.0
    light_link: LinkCollection | None = None
    shadow_link: LinkCollection | None = None

    def __post_init__(self):
        check_fields(self, ("position", (3,), None, np.float64), _size("radius"), _COLOR,
                     ("axis", (3,), None, np.float64), *_MULTIPLIERS)
        self.axis = self.unit_axis()
        _check_shaping(self)

    def unit_axis(self) -> np.ndarray:
        """``(3,)`` ``axis`` made unit, as the shaping uses it (it may be set to any length after construction)."""
        axis = np.asarray(self.axis, np.float64)
        length = float(np.linalg.norm(axis)) if axis.shape == (3,) else 0.0
        if not (length > 0.0 and math.isfinite(length)):
            raise SceneError(f"SphereLight axis must be a nonzero finite 3-vector, got {axis.tolist()}",
                             prim=self.path or None)
        return axis / length

    @property
    def area(self) -> float:
        return 4.0 * math.pi * self.radius**2

    @property
    def radiance(self) -> np.ndarray:
        """``(3,)`` emitted radiance."""
        return _normalized(self.color, self.area, self.normalize)

    @property
    def intensity(self) -> np.ndarray:
        """``(3,)`` radiant intensity when treated as a point."""
        if self.normalize:
            return np.asarray(self.color, np.float32) / 4.0
        return (np.asarray(self.color, np.float32) * math.pi * self.radius**2).astype(np.float32)


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

    def __post_init__(self):
        check_fields(self, _TO_WORLD, _size("width"), _size("height"), _COLOR, *_MULTIPLIERS)
        _check_shaping(self)
        self.texture = _checked_texture(self)

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, _, _ = _axes(self.to_world)
        return x * self.width, y * self.height

    @property
    def area(self) -> float:
        u, v = self.edges()
        return float(np.linalg.norm(np.cross(u, v)))

    @property
    def radiance(self) -> np.ndarray:
        return _normalized(self.color, self.area, self.normalize)


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

    def __post_init__(self):
        check_fields(self, _TO_WORLD, _size("radius"), _COLOR, *_MULTIPLIERS)
        _check_shaping(self)

    @property
    def area(self) -> float:
        x, y, _, _ = _axes(self.to_world)
        return float(math.pi * np.linalg.norm(np.cross(x * self.radius, y * self.radius)))

    @property
    def radiance(self) -> np.ndarray:
        return _normalized(self.color, self.area, self.normalize)


@dataclasses.dataclass
class CylinderLight:
    """``UsdLux.CylinderLight``: a tube of ``length`` along local X and ``radius``, emitting outwards (no caps).

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

    def __post_init__(self):
        check_fields(self, _TO_WORLD, _size("length"), _size("radius"), _COLOR, *_MULTIPLIERS)
        _check_shaping(self)

    def world_shape(self) -> tuple[np.ndarray, float]:
        """World-space axis vector (full length) and radius (mean of the Y and Z scales)."""
        x, y, z, _ = _axes(self.to_world)
        return x * self.length, self.radius * 0.5 * (np.linalg.norm(y) + np.linalg.norm(z))

    @property
    def area(self) -> float:
        axis, r = self.world_shape()
        return float(2.0 * math.pi * r * np.linalg.norm(axis))

    @property
    def radiance(self) -> np.ndarray:
        return _normalized(self.color, self.area, self.normalize)


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
        path: prim path of the emitting mesh: the :attr:`wrt.Scene.meshes` entries of that path (not instanced).
        color: ``(3,)`` ``intensity * 2**exposure * color``.
        normalize: divide by the world-space area of the mesh.
        material_sync: ``light:materialSyncMode``. ``"noMaterialResponse"`` (LightAPI's fallback): radiance
            ``color`` everywhere, which camera rays see too (the surface should reflect nothing: :func:`wrt.load_usd`
            gives such meshes a black material). ``"materialGlowTintsLight"`` (MeshLightAPI's): ``color`` times the
            ``emissiveColor`` of each triangle's material (triangles that do not glow emit nothing);
            ``"independent"``: ``color`` everywhere. In these two, camera rays see the material as it is, its own
            glow included.
        shadows: the light casts shadows (``ShadowAPI`` ``inputs:shadow:enable``).
        diffuse: multiplier of the light on diffuse reflection (``inputs:diffuse``; UsdLux's non-physical control).
        specular: multiplier of the light on specular reflection and transmission (``inputs:specular``).
        light_link: the prims it lights (``collection:lightLink``, :class:`wrt.LinkCollection`); None: every prim.
        shadow_link: the prims that cast its shadows (``collection:shadowLink``); None: every prim.
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

    def __post_init__(self):
        check_fields(self, _COLOR, *_MULTIPLIERS)
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

    def __post_init__(self):
        check_fields(self, _COLOR, _TO_WORLD, *_MULTIPLIERS)
        self.texture = _checked_texture(self)


def _checked_texture(light) -> np.ndarray | None:
    """``light.texture`` as float32, or None; any shape but ``(H, W, 3 or 4)`` raises, naming the light (it failed
    deep in Warp, a TypeError about 'dome_texels')."""
    if light.texture is None:
        return None
    try:
        texture = np.asarray(light.texture, np.float32)
    except (TypeError, ValueError):
        texture = np.zeros(0)
    if texture.ndim != 3 or texture.shape[2] not in (3, 4) or texture.size == 0:
        shape = getattr(light.texture, "shape", type(light.texture).__name__)
        raise SceneError(f"{type(light).__name__} texture must be an (H, W, 3) or (H, W, 4) array of numbers, got "
                         f"{shape}", prim=light.path or None)
    return texture


def _emitted_texels(texture: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` float32 RGB of a light's texture with negative, NaN and infinite texels made 0."""
    texels = np.ascontiguousarray(texture[..., :3], np.float32)
    return np.nan_to_num(np.maximum(texels, 0.0), nan=0.0, posinf=0.0)


def _check_shaping(light) -> None:
    """Refuses a ``shaping`` that is not a :class:`Shaping` (or None), naming the light."""
    if light.shaping is not None and not isinstance(light.shaping, Shaping):
        raise SceneError(f"{type(light).__name__} shaping must be a wrt.Shaping or None, got "
                         f"{type(light.shaping).__name__}", prim=light.path or None)


def _normalized(color, area: float, normalize: bool) -> np.ndarray:
    color = np.asarray(color, np.float32)
    if not normalize:
        return color.copy()
    return (color / area).astype(np.float32) if area > 0.0 else np.zeros(3, np.float32)


def default_lights(forward) -> list:
    """The lights of a stage with none: a headlight travelling along ``forward`` (illuminance
    :data:`HEADLIGHT_ILLUMINANCE`) and a constant dome of radiance :data:`DEFAULT_DOME_RADIANCE`."""
    forward = np.asarray(forward, np.float64)
    return [
        DistantLight(direction=forward / np.linalg.norm(forward), color=np.full(3, HEADLIGHT_ILLUMINANCE),
                     path="<headlight>"),
        DomeLight(color=np.asarray(DEFAULT_DOME_RADIANCE, np.float32), path="<dome>"),
    ]


# Device side -----------------------------------------------------------------------------------------------------


@wp.struct
class DeviceLights:
    """Every light on the device: ``[0, num_analytic)`` are UsdLux lights, the rest triangles of emissive materials
    and of mesh lights."""

    kinds: wp.array[wp.int32]  # LIGHT_* kind
    radiance: wp.array[wp.vec3]  # L (area, dome, soft distant), E (delta distant), I (point); triangles: see params
    position: wp.array[wp.vec3]  # centre; for distant lights the direction of travel
    axis_u: wp.array[wp.vec3]  # rect: full X edge; disk: X radius vector; cylinder: full axis
    axis_v: wp.array[wp.vec3]  # rect: full Y edge; disk: Y radius vector
    normal: wp.array[wp.vec3]  # rect, disk: unit emitting normal
    params: wp.array[wp.vec4]  # (radius | cos of half angle, solid angle of cone, area | 1 - cos, right-angled axes);
    # triangles: (1: radiance times the material's emission, 1: camera rays see the radiance, 1: a mesh light's, 0)
    prims: wp.array[wp.int32]  # triangle id of LIGHT_TRIANGLE entries
    shadows: wp.array[wp.int32]  # SHADOWS_ON, SHADOWS_OFF or SHADOWS_LINKED: what blocks the light
    shaping: wp.array[wp.vec4]  # (cone angle, smooth start (radians), focus, 1); all 0: unshaped (light_shaping)
    shaping_axis: wp.array[wp.vec3]  # unit primary axis (the light's -Z) of shaped lights
    focus_tint: wp.array[wp.vec3]  # ShapingAPI focusTint of shaped lights
    pmf: wp.array[float]  # selection probability of each light
    cdf: wp.array[float]  # (count + 1) running sum of pmf
    count: int  # number of lights
    num_analytic: int  # number of UsdLux lights but mesh lights (they come first; then emissive and mesh triangles)
    dome: int  # index of the dome light, -1 without one
    dome_to_local: wp.mat33  # world direction -> dome frame
    dome_textured: int  # 1 when the dome has a texture (a lat-long image in texels, described by texture[dome])
    dome_row_cdf: wp.array[float]  # (H + 1) marginal CDF over rows of filtered luminance * sin(theta)
    dome_col_cdf: wp.array[float]  # (H (W + 1)) CDF over columns in each row, row y's from y (W + 1)
    dome_mean: wp.vec3  # radiance averaged over the sphere
    texture: wp.array[wp.vec3i]  # (offset into texels, width, height) of a rect or dome light's texture; width 0: none
    texels: wp.array[wp.vec3]  # the rect and dome lights' textures, row-major from the top row, one after the other
    lobe_scale: wp.array[wp.vec2]  # (diffuse, specular) multipliers (UsdLux inputs:diffuse, inputs:specular)
    headlight: int  # index of the default headlight, -1 without one: it travels along each view's direction
    headlight_dirs: wp.array[wp.vec3]  # (V,) unit direction of travel of the headlight in view (camera) V
    links: DeviceLinks  # light and shadow linking of the analytic lights (wrt.light_links)


@wp.struct
class LightSample:
    """A sampled direction towards a light."""

    wi: wp.vec3  # unit direction from the shading point towards the light
    dist: float  # distance to the sampled point (inf for distant and dome lights)
    value: wp.vec3  # incident radiance / solid-angle pdf; for delta lights the illuminance E (or I / d^2)
    pdf: float  # solid-angle pdf of the light sampling strategy (0 for delta lights)


@dataclasses.dataclass
class HostLights:
    """The flattened light list (numpy) before upload; see :class:`DeviceLights`."""

    kinds: list
    radiance: list
    position: list
    axis_u: list
    axis_v: list
    normal: list
    params: list
    prims: list
    power: list
    shadows: list
    shaping: list
    shaping_axis: list
    focus_tint: list
    texture: list
    lobe_scale: list


LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 luminance weights of linear RGB


def luminance_np(c) -> float:
    return float(np.asarray(c, np.float64) @ LUMINANCE)


@dataclasses.dataclass
class EmitterTriangles:
    """The triangle lights of a scene (:func:`emitter_triangles`), one row each.

    Attributes:
        ids: ``(E,)`` int32 geometry ids (rows of ``Scene.geometry()``).
        power: ``(E,)`` float64 power weights for light selection.
        radiance: ``(E, 3)`` float32 radiance factor: 1 for emissive materials, a mesh light's (normalized) colour.
        params: ``(E, 4)`` float32 :class:`DeviceLights` ``params`` of triangle lights.
        owner: ``(E,)`` int32 index of the :class:`MeshLight` (in the list given) the triangle belongs to, -1: none.
    """

    ids: np.ndarray
    power: np.ndarray
    radiance: np.ndarray
    params: np.ndarray
    owner: np.ndarray


def emitter_triangles(scene, materials_emission, mesh_lights: list) -> EmitterTriangles:
    """Every emissive triangle that is not instanced (emissive prototype triangles still emit where rays hit them,
    but are not sampled as lights), then the triangles of each of ``mesh_lights`` that emit (a mesh light's
    triangles are its, not plain emissive ones).

    Raises:
        SceneError: a mesh light that names no mesh of the scene (instanced ones included).
    """
    points, indices = scene.geometry()
    flat = scene.num_flat_triangles
    tri_materials = scene.triangle_materials()[:flat]
    sided = scene.triangle_double_sided()[:flat]
    emission = np.asarray(materials_emission, np.float64).reshape(-1, 3)
    glow = emission @ LUMINANCE  # per material

    def areas(ids):
        a, b, c = (points[indices[ids, k]].astype(np.float64) for k in range(3))
        return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)

    owner = np.full(flat, -1, np.int32)
    starts = np.concatenate([[0], np.cumsum([len(m.indices) for m in scene.meshes])]).astype(np.int64)
    by_path = {}
    for k, mesh in enumerate(scene.meshes):
        by_path.setdefault(mesh.path, []).append(np.arange(starts[k], starts[k + 1]))
    for j, light in enumerate(mesh_lights):
        if light.path not in by_path:
            raise SceneError("MeshLight names no mesh of the scene (meshes inside instances cannot be lights)",
                             prim=light.path or None)
        rows = np.concatenate(by_path[light.path])
        if (owner[rows] >= 0).any():  # the second would silently take every triangle
            raise SceneError("two MeshLights name the same mesh; give it one light", prim=light.path)
        owner[rows] = j

    # Emissive materials: radiance factor 1 times the material's emission (params[0] = 1).
    ids = np.nonzero((glow[tri_materials] > 0.0) & (owner < 0))[0]
    rows = [(ids, math.pi * areas(ids) * glow[tri_materials[ids]], np.ones((len(ids), 3)), (1, 0, 0, 0), -1)]
    for j, light in enumerate(mesh_lights):
        ids = np.nonzero(owner == j)[0]
        area = areas(ids)
        L = _normalized(light.color, float(area.sum()), light.normalize).astype(np.float64)
        tints = light.material_sync == GLOW_TINTS_LIGHT
        if tints:
            keep = glow[tri_materials[ids]] > 0.0  # the light tints the glow: no glow, no light
            ids, area = ids[keep], area[keep]
            power = math.pi * area * ((L * emission[tri_materials[ids]]) @ LUMINANCE)
        else:
            power = math.pi * area * float(L @ LUMINANCE)
        params = (float(tints), float(light.material_sync == NO_MATERIAL_RESPONSE), 1, 0)
        rows.append((ids, power, np.tile(L, (len(ids), 1)), params, j))
    ids = np.concatenate([r[0] for r in rows]).astype(np.int32)
    return EmitterTriangles(
        ids=ids,
        power=np.concatenate([r[1] for r in rows]) * np.where(sided[ids], 2.0, 1.0),
        radiance=np.concatenate([r[2] for r in rows]).astype(np.float32),
        params=np.concatenate([np.tile(np.asarray(r[3], np.float32), (len(r[0]), 1)) for r in rows]),
        owner=np.concatenate([np.full(len(r[0]), r[4], np.int32) for r in rows]),
    )


def build_lights(lights: list, scene, material_emission: list, device) -> DeviceLights:
    """Flattens ``lights`` (host light objects) plus the emissive triangles of ``scene`` into :class:`DeviceLights`.

    Args:
        lights: the UsdLux lights (scene lights or :func:`default_lights`).
        scene: the :class:`wrt.Scene` (for emissive triangles and the scene radius).
        material_emission: per device material (index 0 = default material) a ``(3,)`` emission estimate.
        device: Warp device.
    """
    lower, upper = scene.bounds()
    radius = max(float(np.linalg.norm(np.asarray(upper, np.float64) - lower)) / 2.0, 1e-6)
    h = HostLights(*([] for _ in dataclasses.fields(HostLights)))
    zero = np.zeros(3)
    domes = [light for light in lights if isinstance(light, DomeLight)]
    if len(domes) > 1:
        warnings.warn(f"{len(domes)} dome lights: only the first ({domes[0].path}) is used", stacklevel=3)
    dome_index, dome = -1, None
    mesh_lights = [light for light in lights if isinstance(light, MeshLight)]
    for light in lights:
        if isinstance(light, MeshLight):
            continue  # its triangles come after the analytic lights
        if isinstance(light, DomeLight):
            if light is not domes[0]:
                continue
            dome_index, dome = len(h.kinds), light
            _add(h, LIGHT_DOME, light.color, zero, zero, zero, zero, (0, 0, 0, 0), 0, 0.0)
        elif isinstance(light, DistantLight):
            d = np.asarray(light.direction, np.float64)
            e = light.illuminance
            if light.angle > 0.0:
                half = math.radians(min(light.angle, 180.0)) / 2.0
                one_minus = 2.0 * math.sin(half / 2.0) ** 2  # 1 - cos(half) without cancellation
                cone = 2.0 * math.pi * one_minus
                radiance = e / max(light.solid_angle_factor, 1e-30)
                _add(h, LIGHT_DISTANT, radiance, d, zero, zero, zero, (math.cos(half), cone, one_minus, 0), 0, 0.0)
            else:
                _add(h, LIGHT_DISTANT, e, d, zero, zero, zero, (1.0, 0.0, 0, 0), 0, 0.0)
            h.power[-1] = luminance_np(e) * math.pi * radius**2
        elif isinstance(light, SphereLight):
            if light.treat_as_point:
                i = light.intensity
                _add(h, LIGHT_POINT, i, light.position, zero, zero, zero, (0, 0, 0, 0), 0,
                     4.0 * math.pi * luminance_np(i))
            else:
                L = light.radiance
                _add(h, LIGHT_SPHERE, L, light.position, zero, zero, zero, (light.radius, 0, light.area, 0), 0,
                     math.pi * light.area * luminance_np(L))
            _add_shaping(h, light.shaping, light.unit_axis(), emits_behind=True)
        elif isinstance(light, RectLight):
            u, v = light.edges()
            _, _, z, origin = _axes(light.to_world)
            n = _emitting_normal(u, v, z)
            L = light.radiance
            texels = None if light.texture is None else _emitted_texels(light.texture)
            mean = np.ones(3) if texels is None else texels.reshape(-1, 3).mean(axis=0, dtype=np.float64)
            _add(h, LIGHT_RECT, L, origin, u, v, n, (0, 0, light.area, _right_angled(u, v)), 0,
                 math.pi * light.area * luminance_np(L * mean))
            h.texture[-1] = texels
            _add_shaping(h, light.shaping, primary_axis(light.to_world, n), emits_behind=False)
        elif isinstance(light, DiskLight):
            x, y, z, origin = _axes(light.to_world)
            u, v = x * light.radius, y * light.radius
            n = _emitting_normal(u, v, z)
            L = light.radiance
            _add(h, LIGHT_DISK, L, origin, u, v, n, (0, 0, light.area, _right_angled(u, v)), 0,
                 math.pi * light.area * luminance_np(L))
            _add_shaping(h, light.shaping, primary_axis(light.to_world, n), emits_behind=False)
        elif isinstance(light, CylinderLight):
            axis, r = light.world_shape()
            origin = _axes(light.to_world)[3]
            L = light.radiance
            _add(h, LIGHT_CYLINDER, L, origin, axis, zero, zero, (r, 0, light.area, 0), 0,
                 math.pi * light.area * luminance_np(L))
            _add_shaping(h, light.shaping, primary_axis(light.to_world, (0.0, 0.0, -1.0)), emits_behind=True)
        else:
            raise TypeError(f"unsupported light {type(light).__name__}")
        h.shadows[-1] = SHADOWS_ON if light.shadows else SHADOWS_OFF
        h.lobe_scale[-1] = np.array([light.diffuse, light.specular], np.float32)
    num_analytic = len(h.kinds)

    # Emissive triangles, then those of mesh lights, which carry their light's shadows and multipliers: appended as
    # columns below (one Python row per triangle took 24 us each, 24 s for a million-triangle emissive ceiling).
    tris = emitter_triangles(scene, material_emission, mesh_lights)

    # Dome texture (packed with the rect lights' textures) and its sampling distribution.
    row_cdf = np.array([0.0, 1.0], np.float32)
    col_cdf = np.array([0.0, 1.0], np.float32)
    dome_mean = np.zeros(3, np.float32)
    dome_rot = np.eye(3)
    if dome is not None:
        dome_rot = _nearest_rotation(np.asarray(dome.to_world, np.float64)[:3, :3]).T
        dome_mean = np.asarray(dome.color, np.float32)
        if dome.texture is not None:
            texels = h.texture[dome_index] = _emitted_texels(dome.texture)
            row_cdf, col_cdf, mean = _dome_distribution(texels)
            dome_mean = (dome_mean * mean).astype(np.float32)
        if num_analytic:
            h.power[dome_index] = 4.0 * math.pi**2 * radius**2 * luminance_np(dome_mean)

    # Selection probabilities.
    n = num_analytic + len(tris.ids)
    power = np.concatenate([np.asarray(h.power, np.float64), tris.power])
    power = np.maximum(np.nan_to_num(power, nan=0.0), 0.0)
    pmf = np.zeros(max(n, 1))
    if n:
        pmf[:n] = 0.5 / n + (0.5 * power / power.sum() if power.sum() > 0 else 0.5 / n)
        pmf[:n] /= pmf[:n].sum()
    cdf = np.concatenate([[0.0], np.cumsum(pmf[:n])]) if n else np.array([0.0, 1.0])
    if n:
        cdf[-1] = 1.0

    e = len(tris.ids)
    owned = tris.owner >= 0
    tri_shadows = np.full(e, SHADOWS_ON, np.int32)
    tri_lobes = np.ones((e, 2), np.float32)
    if mesh_lights:
        modes = np.array([SHADOWS_ON if light.shadows else SHADOWS_OFF for light in mesh_lights], np.int32)
        tri_shadows[owned] = modes[tris.owner[owned]]
        tri_lobes[owned] = np.float32([[light.diffuse, light.specular] for light in mesh_lights])[tris.owner[owned]]

    def arr(values, dtype, width=3, triangles=None):
        """The analytic lights' ``values`` and the triangles' rows below them (``triangles``: None for zeros)."""
        numpy_type = np.int32 if dtype == wp.int32 else np.float32
        shape = (-1, width) if width > 1 else (-1,)
        rows = np.zeros((e, width) if width > 1 else e, numpy_type) if triangles is None else triangles
        data = np.concatenate([np.asarray(values, numpy_type).reshape(shape), np.asarray(rows, numpy_type)])
        return wp.array(data if len(data) else np.zeros((1, width) if width > 1 else 1, numpy_type), dtype=dtype,
                        device=device)

    d = DeviceLights()
    d.kinds = arr(h.kinds, wp.int32, 1, np.full(e, LIGHT_TRIANGLE, np.int32))
    d.radiance = arr(h.radiance, wp.vec3, 3, tris.radiance)
    d.position = arr(h.position, wp.vec3)
    d.axis_u = arr(h.axis_u, wp.vec3)
    d.axis_v = arr(h.axis_v, wp.vec3)
    d.normal = arr(h.normal, wp.vec3)
    d.params = arr(h.params, wp.vec4, 4, tris.params)
    d.prims = arr(h.prims, wp.int32, 1, tris.ids)
    d.shaping = arr(h.shaping, wp.vec4, 4)
    d.shaping_axis = arr(h.shaping_axis, wp.vec3)
    d.focus_tint = arr(h.focus_tint, wp.vec3)
    d.lobe_scale = arr(h.lobe_scale, wp.vec2, 2, tri_lobes)
    d.pmf = wp.array(pmf.astype(np.float32), dtype=float, device=device)
    d.cdf = wp.array(cdf.astype(np.float32), dtype=float, device=device)
    d.count = n
    d.num_analytic = num_analytic
    d.dome = dome_index
    d.dome_to_local = wp.mat33(*dome_rot.astype(np.float32).reshape(-1))
    d.dome_textured = 1 if (dome is not None and dome.texture is not None) else 0
    d.dome_row_cdf = wp.array(row_cdf, dtype=float, device=device)
    d.dome_col_cdf = wp.array(col_cdf, dtype=float, device=device)
    d.dome_mean = wp.vec3(*dome_mean.tolist())
    d.texture, d.texels = _upload_textures(h.texture, n, device)
    d.headlight = -1  # set by the renderer, which knows the cameras (set_headlight_directions)
    d.headlight_dirs = wp.zeros(1, dtype=wp.vec3, device=device)
    # Links of the analytic lights in device order (the dome's at dome_index; a second dome is not on the device),
    # then of the mesh lights, whose triangles share their light's column.
    on_device = [light for light in lights if not isinstance(light, (DomeLight, MeshLight)) or light is dome]
    columns = np.concatenate([np.arange(num_analytic), np.where(tris.owner >= 0, num_analytic + tris.owner, -1)])
    links = link_groups(scene, on_device + mesh_lights)
    d.links = upload_links(links, device, columns)
    d.shadows = wp.array(_shadow_modes(np.concatenate([np.int32(h.shadows).reshape(-1), tri_shadows]), links,
                                       columns), dtype=wp.int32, device=device)
    return d


def _shadow_modes(shadows: np.ndarray, links, columns: np.ndarray) -> np.ndarray:
    """``shadows`` (int32 :data:`SHADOWS_ON` or :data:`SHADOWS_OFF` per device light, at least one entry) with
    :data:`SHADOWS_LINKED` for the lights on whose column of ``links`` (:class:`wrt.light_links.HostLinks`, None: no
    linking) some geometry casts no shadow."""
    if len(shadows) == 0:
        return np.zeros(1, np.int32)
    if links is None:
        return shadows
    leaves_out = np.any((links.masks & CASTS_SHADOW) == 0, axis=0)  # per column
    linked = (shadows == SHADOWS_ON) & (columns >= 0)
    linked[linked] = leaves_out[columns[linked]]
    return np.where(linked, np.int32(SHADOWS_LINKED), shadows).astype(np.int32)


def _upload_textures(textures: list, count: int, device) -> tuple[wp.array, wp.array]:
    """The ``(offset, width, height)`` of each of ``count`` lights' texture (``(H, W, 3)`` or None; lights past the
    list have none) and their texels packed one after the other (one white texel when there are none)."""
    info = np.zeros((max(count, 1), 3), np.int32)
    offset = 1
    for k, texels in enumerate(textures):
        if texels is not None:
            info[k] = (offset, texels.shape[1], texels.shape[0])
            offset += texels.shape[0] * texels.shape[1]
    # Filled in place: a list of the images concatenated held a second copy of them all (a dome's 400 MB at 8k).
    packed = np.ones((offset, 3), np.float32)
    for k, texels in enumerate(textures):
        if texels is not None:
            packed[info[k][0] : info[k][0] + texels.shape[0] * texels.shape[1]] = texels.reshape(-1, 3)
    return wp.array(info, dtype=wp.vec3i, device=device), wp.array(packed, dtype=wp.vec3, device=device)


def set_headlight_directions(d: DeviceLights, index: int, forwards, device) -> None:
    """Makes light ``index`` of ``d`` (the delta :class:`DistantLight` of :func:`default_lights`; -1: none) a
    headlight travelling along ``forwards[k]`` (``(V, 3)``, any length) in view ``k``, so that view ``k`` of a batch
    is lit as a render of camera ``k`` alone is."""
    d.headlight = index
    if index >= 0:
        f = np.asarray(forwards, np.float64).reshape(-1, 3)
        dirs = wp.array((f / np.linalg.norm(f, axis=1, keepdims=True)).astype(np.float32), dtype=wp.vec3, device=device)
        old = getattr(d, "headlight_dirs", None)
        if old is not None and old.shape == dirs.shape and old.device == dirs.device:
            old.assign(dirs)  # in place, so that a recorded CUDA graph sees the new directions (see set_cameras)
        else:
            d.headlight_dirs = dirs


def _add(h: HostLights, kind, radiance, position, u, v, normal, params, prim, power):
    h.kinds.append(int(kind))
    h.radiance.append(np.asarray(radiance, np.float32))
    h.position.append(np.asarray(position, np.float32))
    h.axis_u.append(np.asarray(u, np.float32))
    h.axis_v.append(np.asarray(v, np.float32))
    h.normal.append(np.asarray(normal, np.float32))
    h.params.append(np.asarray(params, np.float32))
    h.prims.append(int(prim))
    h.power.append(float(power))
    h.shadows.append(SHADOWS_ON)
    h.shaping.append(np.zeros(4, np.float32))
    h.shaping_axis.append(np.zeros(3, np.float32))
    h.focus_tint.append(np.zeros(3, np.float32))
    h.texture.append(None)
    h.lobe_scale.append(np.ones(2, np.float32))


def _add_shaping(h: HostLights, shaping: Shaping | None, axis, emits_behind: bool) -> None:
    """Gives the light added last ``shaping`` around unit ``axis`` (nothing where it changes nothing), and scales
    its power by the share the shaping lets out."""
    params = None if shaping is None else shaping.device_params(emits_behind)
    if params is None:
        return
    h.shaping[-1] = np.array([*params, 1.0], np.float32)
    h.shaping_axis[-1] = np.asarray(axis, np.float32)
    h.focus_tint[-1] = np.asarray(shaping.focus_tint, np.float32)
    h.power[-1] *= shaping.power_fraction(emits_behind)


def _right_angled(u, v) -> float:
    """1.0 when edges ``u`` and ``v`` are at right angles (a sheared transform makes a parallelogram or a tilted
    ellipse, which solid-angle sampling does not cover), else 0.0."""
    lengths = float(np.linalg.norm(u) * np.linalg.norm(v))
    return 1.0 if lengths > 0.0 and abs(float(np.dot(u, v))) <= 1e-6 * lengths else 0.0


def _emitting_normal(u, v, z) -> np.ndarray:
    """Unit normal of the plane spanned by ``u, v`` on the side of the light's -Z axis."""
    n = np.cross(u, v)
    length = np.linalg.norm(n)
    if length == 0.0:
        return np.zeros(3)
    n = n / length
    return n if np.dot(n, -np.asarray(z)) >= 0.0 else -n


def _nearest_rotation(m: np.ndarray) -> np.ndarray:
    """The orthogonal ``(3, 3)`` matrix nearest to ``m`` (polar decomposition ``U V^T`` of its SVD; a mirror where
    ``m`` mirrors): a dome turns with its transform's rotation only. Its transpose must be its inverse, as light
    sampling turns dome directions to the world by the transpose: the columns of a sheared or unevenly scaled
    rotation merely normalized were not perpendicular, and the dome lit by its samples differed from the one seen."""
    u, _, vt = np.linalg.svd(m)
    return u @ vt


def _dome_distribution(texels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row and column CDFs of ``luminance * sin(theta)`` over a ``(H, W, 3)`` lat-long image (``(H + 1,)``, and
    ``(H (W + 1),)``: each row's in turn), and its mean radiance over the sphere, both of the bilinearly filtered
    image that :func:`dome_radiance` looks up.

    Each texel's weight is the luminance of the filtered image averaged over the texel: ``[1/8, 3/4, 1/8]`` of it and
    its neighbours along each axis (longitude wrapping around, latitude clamped at the poles). It is positive wherever
    the filtered image is, so light sampling can draw every lit direction: the texels' own luminance gave a black
    texel next to a bright one no share although filtering lights half of it.
    """
    hgt = texels.shape[0]
    theta = (np.arange(hgt) + 0.5) / hgt * np.pi
    sin_t = np.sin(theta)[:, None]
    lum = 0.2126 * texels[..., 0] + 0.7152 * texels[..., 1] + 0.0722 * texels[..., 2]
    lum = 0.75 * lum + 0.125 * (np.roll(lum, 1, axis=1) + np.roll(lum, -1, axis=1))
    rows = np.concatenate([lum[:1], lum, lum[-1:]])
    lum = 0.75 * rows[1:-1] + 0.125 * (rows[:-2] + rows[2:])
    f = lum * sin_t + 1e-8 * (sin_t + 1e-6)  # a black image still has directions to draw
    col = np.concatenate([np.zeros((hgt, 1)), np.cumsum(f, axis=1)], axis=1)
    row_sums = col[:, -1]
    row = np.concatenate([[0.0], np.cumsum(row_sums)])
    # Filtering along a row keeps its mean (longitude wraps around); across rows it does not, as sin(theta) weighs
    # the rows unequally: the mean over the sphere weighs each row's mean by the integral of its latitude hat
    # function times sin(theta) over 2 (which sums to 1).
    row_means = texels.mean(axis=1, dtype=np.float64)
    mean = _latitude_hat_weights(hgt) @ row_means / 2.0
    return row.astype(np.float32), col.reshape(-1).astype(np.float32), mean.astype(np.float32)


def _latitude_hat_weights(hgt: int) -> np.ndarray:
    """``(H,)`` integrals over ``theta`` in ``[0, pi]`` of ``sin(theta)`` times the weight row ``j`` of an ``H``-row
    lat-long image has in its bilinear filtering: 1 at the row's centre ``theta_j = (j + 1/2) pi / H``, falling
    linearly to 0 at the neighbouring centres, and 1 from the first and last centres to the poles (clamped)."""
    centres = (np.arange(hgt) + 0.5) / hgt * np.pi
    weights = np.zeros(hgt)
    weights[0] += 1.0 - np.cos(centres[0])  # clamped from the +Y pole down to the first centre
    weights[-1] += 1.0 + np.cos(centres[-1])  # and from the last centre to the -Y pole
    # Between centres a and b = a + dtheta the lower row's weight rises as (theta - a) / dtheta: its integral with
    # sin(theta) is [G(b) - G(a) + a (cos b - cos a)] / dtheta, G = sin(theta) - theta cos(theta) (by parts).
    a, b = centres[:-1], centres[1:]
    total = np.cos(a) - np.cos(b)
    rising = (np.sin(b) - b * np.cos(b) - np.sin(a) + a * np.cos(a) + a * (np.cos(b) - np.cos(a))) / (np.pi / hgt)
    weights[1:] += rising
    weights[:-1] += total - rising
    return weights


# Device functions ------------------------------------------------------------------------------------------------


@wp.func
def dome_direction_uv(lights: DeviceLights, d: wp.vec3):
    """Lat-long texture coordinates ``(u, v)`` in [0, 1] (v = 0 at the top row) of world direction ``d``."""
    local_dir = lights.dome_to_local * d
    lon = wp.atan2(local_dir[0], local_dir[2])
    lat = wp.asin(wp.clamp(local_dir[1], -1.0, 1.0))
    return wp.vec2(0.5 * (1.0 - lon / PI), 0.5 - lat / PI)


@wp.func
def filtered_texel(texels: wp.array[wp.vec3], info: wp.vec3i, x: float, y: float, wrap_x: int):
    """Bilinearly filtered value of the light texture ``info`` = (offset into ``texels``, width, height) at
    continuous texel coordinates ``(x, y)`` from its top-left corner (texel centres at half-integers). Columns wrap
    by ``wrap_x`` (``WRAP_REPEAT``: lat-long longitude; ``WRAP_CLAMP``), rows clamp (the poles, a rect's edges)."""
    if not (wp.isfinite(x) and wp.isfinite(y)):
        return wp.vec3(0.0)
    w = info[1]
    h = info[2]
    # Keep the integer part in range before converting (a huge coordinate would overflow int).
    fx = wp.clamp(x, -1.0, float(w) + 1.0) - 0.5
    fy = wp.clamp(y, -1.0, float(h) + 1.0) - 0.5
    x0f = wp.floor(fx)
    y0f = wp.floor(fy)
    tx = fx - x0f
    ty = fy - y0f
    x0 = wrap_coord(int(x0f), w, wrap_x)
    x1 = wrap_coord(int(x0f) + 1, w, wrap_x)
    row0 = info[0] + wrap_coord(int(y0f), h, WRAP_CLAMP) * w
    row1 = info[0] + wrap_coord(int(y0f) + 1, h, WRAP_CLAMP) * w
    top = texels[row0 + x0] * (1.0 - tx) + texels[row0 + x1] * tx
    bottom = texels[row1 + x0] * (1.0 - tx) + texels[row1 + x1] * tx
    return top * (1.0 - ty) + bottom * ty


@wp.func
def dome_radiance(lights: DeviceLights, d: wp.vec3):
    """Radiance of the dome light arriving from world direction ``-d`` (i.e. seen along ``d``)."""
    k = lights.dome
    if k < 0:
        return wp.vec3(0.0)
    L = lights.radiance[k]
    if lights.dome_textured == 0:
        return L
    uv = dome_direction_uv(lights, d)
    info = lights.texture[k]
    texel = filtered_texel(lights.texels, info, uv[0] * float(info[1]), uv[1] * float(info[2]), WRAP_REPEAT)
    return wp.cw_mul(L, texel)


@wp.func
def dome_pdf(lights: DeviceLights, d: wp.vec3, n: wp.vec3):
    """Solid-angle pdf with which :func:`sample_light` draws direction ``d`` from the dome (``n``: shading normal)."""
    if lights.dome_textured == 0:
        if wp.length(n) == 0.0:
            return 0.25 * INV_PI
        return wp.max(wp.dot(n, d), 0.0) * INV_PI
    uv = dome_direction_uv(lights, d)
    info = lights.texture[lights.dome]
    w = info[1]
    h = info[2]
    x = wp.clamp(int(uv[0] * float(w)), 0, w - 1)
    y = wp.clamp(int(uv[1] * float(h)), 0, h - 1)
    total = lights.dome_row_cdf[h]
    if total <= 0.0:
        return 0.0
    f = lights.dome_col_cdf[y * (w + 1) + x + 1] - lights.dome_col_cdf[y * (w + 1) + x]
    pdf_uv = f / total * float(w * h)
    # The Jacobian of (u, v) -> direction at d itself, not at the texel's centre row: sample_light draws (u, v)
    # uniformly inside the texel, so only this matches what it draws (coarse maps were biased, +4% with 2 rows).
    y_local = wp.normalize(lights.dome_to_local * d)[1]
    sin_t = wp.sqrt(wp.max(1.0 - y_local * y_local, 0.0))
    if sin_t <= 0.0:
        return 0.0
    return pdf_uv / (2.0 * PI * PI * sin_t)


@wp.func
def emission_shaping(lights: DeviceLights, k: int, w: wp.vec3):
    """The colour factor of light ``k``'s ShapingAPI on the radiance it emits along unit ``w`` (1 where unshaped:
    :mod:`wrt.light_shaping`)."""
    params = lights.shaping[k]
    if params[3] == 0.0:
        return wp.vec3(1.0)
    return cone_and_focus(params, lights.shaping_axis[k], lights.focus_tint[k], w)


@wp.func
def plane_coords(u: wp.vec3, v: wp.vec3, q: wp.vec3):
    """``(a, b)`` with ``q = a u + b v`` for ``q`` in the plane of edges ``u, v`` (from their origin): the
    coordinates along the edges of a rect light (in [-0.5, 0.5] on it) or along the radius vectors of a disk light,
    which a transform can shear out of right angles (a projection on each edge is right for perpendicular edges
    only). Solved from those projections, ``q.u / u.u`` and ``q.v / v.v``, which stay in float32 range wherever
    the edges do."""
    uu = wp.dot(u, u)
    vv = wp.dot(v, v)
    if uu <= 0.0 or vv <= 0.0:
        return wp.vec2(wp.inf, wp.inf)
    pu = wp.dot(q, u) / uu
    pv = wp.dot(q, v) / vv
    ku = wp.dot(u, v) / uu
    kv = wp.dot(u, v) / vv
    s = 1.0 - ku * kv  # sin^2 of the angle between the edges
    if s <= 0.0:
        return wp.vec2(wp.inf, wp.inf)
    return wp.vec2((pu - ku * pv) / s, (pv - kv * pu) / s)


@wp.func
def light_texture(lights: DeviceLights, k: int, q: wp.vec3):
    """Light ``k``'s texture at point ``q`` on it, filtered (1 without a texture). A rect light's texture lies
    upright seen from its lit side: column 0 at local +X, row 0 (the top) at local +Y."""
    info = lights.texture[k]
    if info[1] == 0:
        return wp.vec3(1.0)
    ab = plane_coords(lights.axis_u[k], lights.axis_v[k], q - lights.position[k])  # (-0.5, -0.5) at local -X, -Y
    return filtered_texel(lights.texels, info, (0.5 - ab[0]) * float(info[1]), (0.5 - ab[1]) * float(info[2]),
                          WRAP_CLAMP)


@wp.func
def lobe_factor(lights: DeviceLights, k: int, diffuse_share: wp.vec3):
    """The factor of light ``k``'s ``diffuse`` and ``specular`` multipliers on light a surface reflects with
    ``diffuse_share`` of it (per channel) through its diffuse lobe and the rest through its specular lobes."""
    m = lights.lobe_scale[k]
    return wp.vec3(m[1]) + (m[0] - m[1]) * diffuse_share


@wp.func
def lit_bsdf(lights: DeviceLights, k: int, f_diffuse: wp.vec3, f_specular: wp.vec3):
    """The BSDF value light ``k`` is reflected with: the diffuse lobe's ``f_diffuse`` and the specular lobes'
    ``f_specular`` (:func:`wrt.bsdf.eval_bsdf_lobes`) scaled by the light's ``diffuse`` and ``specular``
    multipliers."""
    m = lights.lobe_scale[k]
    return f_diffuse * m[0] + f_specular * m[1]


@wp.func
def sphere_cone(lights: DeviceLights, k: int, p: wp.vec3):
    """``(cos_max, 1 - cos_max)`` of the cone the sphere light subtends at ``p``; ``cos_max = 2`` when inside."""
    c = lights.position[k]
    r = lights.params[k][0]
    d2 = wp.length_sq(c - p)
    if d2 <= r * r:
        return 2.0, 0.0
    sin2 = r * r / d2
    cos_max = wp.sqrt(wp.max(0.0, 1.0 - sin2))
    one_minus = sin2 / (1.0 + cos_max)  # 1 - cos_max without cancellation
    return cos_max, one_minus


@wp.func
def intersect_sphere(c: wp.vec3, r: float, o: wp.vec3, d: wp.vec3):
    """Nearest ``t > 0`` where unit ray ``o + t d`` enters the sphere from outside; inf if none."""
    oc = o - c
    if wp.dot(oc, oc) <= r * r:
        return float(wp.inf)
    # The half chord from the ray's closest approach to the centre, r^2 - |closest - c|^2, as wrt/primitives.py
    # does (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems 2019): b^2 - c
    # cancels in float32 for a sphere small next to its distance, and rays saw a light 1000 radii away 15% too large.
    dd = wp.dot(d, d)
    t_mid = -wp.dot(oc, d) / dd
    closest = oc + t_mid * d
    half2 = r * r - wp.dot(closest, closest)
    if half2 < 0.0:
        return float(wp.inf)
    t = t_mid - wp.sqrt(half2 / dd)
    if t <= 0.0:
        return float(wp.inf)
    return t


@wp.func
def intersect_light(lights: DeviceLights, k: int, o: wp.vec3, d: wp.vec3):
    """Distance along unit ray ``(o, d)`` to the emitting side of analytic light ``k`` (inf if missed or not
    emitting towards the ray) and the cosine at the light (1 for spheres)."""
    kind = lights.kinds[k]
    c = lights.position[k]
    if kind == LIGHT_SPHERE:
        return intersect_sphere(c, lights.params[k][0], o, d), 1.0
    if kind == LIGHT_RECT or kind == LIGHT_DISK:
        n = lights.normal[k]
        denom = wp.dot(d, n)
        if denom >= 0.0:
            return float(wp.inf), 0.0
        t = wp.dot(c - o, n) / denom
        if t <= 0.0:
            return float(wp.inf), 0.0
        ab = plane_coords(lights.axis_u[k], lights.axis_v[k], o + t * d - c)
        inside = False
        if kind == LIGHT_RECT:
            inside = wp.abs(ab[0]) <= 0.5 and wp.abs(ab[1]) <= 0.5
        else:
            inside = wp.length_sq(ab) <= 1.0
        if inside:
            return t, -denom
        return float(wp.inf), 0.0
    if kind == LIGHT_CYLINDER:
        axis = lights.axis_u[k]
        half = 0.5 * wp.length(axis)
        if half <= 0.0:
            return float(wp.inf), 0.0
        w = axis / (2.0 * half)
        r = lights.params[k][0]
        oc = o - c
        dp = d - wp.dot(d, w) * w
        op = oc - wp.dot(oc, w) * w
        a = wp.dot(dp, dp)
        b = wp.dot(op, dp)
        cc = wp.dot(op, op) - r * r
        if a <= 0.0 or cc <= 0.0:
            return float(wp.inf), 0.0
        disc = b * b - a * cc
        if disc < 0.0:
            return float(wp.inf), 0.0
        t = (-b - wp.sqrt(disc)) / a
        if t <= 0.0 or wp.abs(wp.dot(oc + t * d, w)) > half:
            return float(wp.inf), 0.0
        radial = op + t * dp
        return t, wp.max(-wp.dot(d, radial / r), 0.0)
    return float(wp.inf), 0.0


@wp.func
def seen_rect(lights: DeviceLights, k: int, p: wp.vec3):
    """Rect light ``k``, or the square around disk light ``k``, as seen from ``p``, and whether lights of its kind
    are sampled by solid angle from there (else by area; see :mod:`wrt.spherical_rect`)."""
    u = lights.axis_u[k]
    v = lights.axis_v[k]
    scale = float(1.0)  # rect: full edges; disk: radius vectors
    least = float(0.0)
    if lights.kinds[k] == LIGHT_DISK:
        scale = 2.0
        least = DISK_SOLID_ANGLE_LEAST
    r = spherical_rect(p, lights.position[k] - 0.5 * scale * (u + v), scale * u, scale * v)
    return r, lights.params[k][3] > 0.0 and solid_angle_usable(r, least)


@wp.func
def area_light_pdf(lights: DeviceLights, k: int, p: wp.vec3, n: wp.vec3, d: wp.vec3, dist: float, cos_l: float):
    """Solid-angle pdf (without the selection probability) of analytic light ``k`` sampled from ``p`` (shading normal
    ``n``, zero if none) and seen along unit ``d`` at distance ``dist`` with cosine ``cos_l``."""
    kind = lights.kinds[k]
    if kind == LIGHT_SPHERE:
        cos_max, one_minus = sphere_cone(lights, k, p)
        if cos_max > 1.0 or one_minus <= 0.0:
            return 0.0
        return 1.0 / (2.0 * PI * one_minus)
    area = lights.params[k][2]
    if kind == LIGHT_CYLINDER:
        area = 0.5 * area  # sampling covers the half facing the shading point
    if cos_l <= 0.0 or area <= 0.0:
        return 0.0
    if kind == LIGHT_RECT or kind == LIGHT_DISK:
        r, by_solid_angle = seen_rect(lights, k, p)
        if by_solid_angle:
            return spherical_rect_pdf(r, n, p + dist * d)
    return dist * dist / (cos_l * area)


@wp.func
def distant_in_cone(lights: DeviceLights, k: int, d: wp.vec3):
    """True when a ray along ``d`` looks into the disc of soft distant light ``k``."""
    # Compare chords, |d - axis|^2 = 2 (1 - cos): float32 rounds the cosine of a small disc by up to 25% of its
    # distance from 1 (a 0.05 degree sun looked 1.5 times its size), while the chord keeps its relative precision.
    cone = lights.params[k][1]
    return cone > 0.0 and wp.length_sq(d + lights.position[k]) <= 2.0 * lights.params[k][2]


@wp.func
def triangle_light_pdf(scene: DeviceScene, double_sided: int, prim: int, o: wp.vec3, d: wp.vec3, dist: float):
    """Solid-angle pdf of uniform area sampling of triangle ``prim`` seen from ``o`` along unit ``d``; 0 from its
    back when it is single-sided."""
    a = scene.points[scene.indices[prim, 0]]
    b = scene.points[scene.indices[prim, 1]]
    c = scene.points[scene.indices[prim, 2]]
    cr = wp.cross(b - a, c - a)
    area2 = stable_length(cr)
    if area2 <= 0.0:
        return 0.0
    cos_l = -wp.dot(d, cr / area2)
    if double_sided == 1:
        cos_l = wp.abs(cos_l)
    if cos_l <= 0.0:
        return 0.0
    return dist * dist / (cos_l * 0.5 * area2)


@wp.func
def triangle_emission(lights: DeviceLights, mats: DeviceMaterials, k: int, m: int, st: wp.vec2):
    """Radiance that triangle light ``k`` (of material ``m``) emits at ``st``: its radiance factor times the
    material's ``emissiveColor``, or the factor alone for a mesh light whose light does not follow its material
    (``materialSyncMode`` ``independent`` or ``noMaterialResponse``)."""
    L = lights.radiance[k]
    if lights.params[k][0] > 0.0:
        L = wp.cw_mul(L, eval_emission(mats, m, st))
    return L


@wp.func
def shadow_direction(lights: DeviceLights, k: int, wi: wp.vec3):
    """The direction of the shadow ray towards light ``k``: ``wi``, or zero for a light that casts no shadows (a
    zero direction can hit nothing, so every accelerator reports the ray unblocked)."""
    return wp.where(lights.shadows[k] != SHADOWS_OFF, wi, wp.vec3(0.0))


@wp.func
def sampled_alone(lights: DeviceLights, k: int):
    """Light ``k`` is left to light sampling alone (MIS weight 1): its shadow rays pass geometry (any, or what its
    shadowLink leaves out) at which a BSDF-sampled ray towards it would stop, losing its share of the light."""
    return lights.shadows[k] != SHADOWS_ON


@wp.func
def sample_light(
    lights: DeviceLights,
    scene: DeviceScene,
    mats: DeviceMaterials,
    uvs: wp.array2d[wp.vec2],
    tri_materials: wp.array[wp.int32],
    tri_double_sided: wp.array[wp.int32],
    k: int,
    p: wp.vec3,
    n: wp.vec3,
    u1: float,
    u2: float,
):
    """A direction from ``p`` (shading normal ``n``, zero if none) towards light ``k``; see :class:`LightSample`."""
    out = LightSample()
    out.wi = wp.vec3(0.0, 0.0, 1.0)
    out.dist = float(wp.inf)
    out.value = wp.vec3(0.0)
    out.pdf = 0.0
    kind = lights.kinds[k]
    if kind == LIGHT_DISTANT:
        d = -lights.position[k]
        cone = lights.params[k][1]
        if cone > 0.0:
            out.wi = to_world(sample_uniform_cone(u1, u2, lights.params[k][2]), d)
            out.pdf = 1.0 / cone
            out.value = lights.radiance[k] * cone
        else:
            out.wi = d
            out.value = lights.radiance[k]
        return out
    if kind == LIGHT_POINT:
        to = lights.position[k] - p
        d2 = wp.length_sq(to)
        if d2 > 0.0:
            out.dist = wp.sqrt(d2)
            out.wi = to / out.dist
            out.value = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -out.wi)) / d2
        return out
    if kind == LIGHT_DOME:
        if lights.dome_textured == 0:
            if wp.length(n) > 0.0:
                out.wi = to_world(sample_cosine_hemisphere(u1, u2), n)
            else:
                out.wi = sample_uniform_sphere(u1, u2)
        else:
            w = lights.texture[k][1]
            h = lights.texture[k][2]
            # A row by the marginal CDF, then a column by that row's CDF; where u fell inside each places the
            # direction in the texel.
            y = sample_cdf(lights.dome_row_cdf, 0, h, u1)
            fy = cdf_remainder(lights.dome_row_cdf, 0, h, y, u1)
            x = sample_cdf(lights.dome_col_cdf, y * (w + 1), w, u2)
            fx = cdf_remainder(lights.dome_col_cdf, y * (w + 1), w, x, u2)
            uu = (float(x) + fx) / float(w)
            vv = (float(y) + fy) / float(h)
            lon = PI * (1.0 - 2.0 * uu)
            lat = PI * (0.5 - vv)
            local = wp.vec3(wp.cos(lat) * wp.sin(lon), wp.sin(lat), wp.cos(lat) * wp.cos(lon))
            out.wi = wp.normalize(wp.transpose(lights.dome_to_local) * local)
        out.pdf = dome_pdf(lights, out.wi, n)
        if out.pdf > 0.0:
            out.value = dome_radiance(lights, out.wi) / out.pdf
        return out
    if kind == LIGHT_SPHERE:
        c = lights.position[k]
        r = lights.params[k][0]
        cos_max, one_minus = sphere_cone(lights, k, p)
        if cos_max > 1.0 or one_minus <= 0.0:
            return out  # inside the sphere: it emits outwards only
        axis = wp.normalize(c - p)
        out.wi = wp.normalize(to_world(sample_uniform_cone(u1, u2, one_minus), axis))
        t = intersect_sphere(c, r, p, out.wi)
        if t == wp.inf:
            t = wp.dot(c - p, out.wi)  # grazing: rounding missed the sphere by a hair
        out.dist = t
        out.pdf = 1.0 / (2.0 * PI * one_minus)
        out.value = wp.cw_mul(lights.radiance[k], emission_shaping(lights, k, -out.wi)) * (2.0 * PI * one_minus)
        return out

    # Area sampling (rect and disk lights that look large: by solid angle), cylinder, triangle.
    pdf_solid_angle = float(0.0)  # > 0: q was sampled by solid angle with this pdf
    q = wp.vec3(0.0)
    ln = wp.vec3(0.0)
    area = float(0.0)
    L = wp.vec3(0.0)
    two_sided = int(0)
    if kind == LIGHT_RECT or kind == LIGHT_DISK:
        ln = lights.normal[k]
        area = lights.params[k][2]
        L = lights.radiance[k]
        seen, by_solid_angle = seen_rect(lights, k, p)
        if by_solid_angle:
            q, inside = sample_spherical_rect(seen, n, u1, u2)
            if not inside:
                return out
            pdf_solid_angle = spherical_rect_pdf(seen, n, q)
            if kind == LIGHT_DISK:  # a point of the square around the disk: keep it if it lies on the disk
                if wp.length_sq(plane_coords(lights.axis_u[k], lights.axis_v[k], q - lights.position[k])) > 1.0:
                    return out
        elif kind == LIGHT_RECT:
            q = lights.position[k] + (u1 - 0.5) * lights.axis_u[k] + (u2 - 0.5) * lights.axis_v[k]
        else:
            dd = sample_concentric_disk(u1, u2)
            q = lights.position[k] + dd[0] * lights.axis_u[k] + dd[1] * lights.axis_v[k]
        L = wp.cw_mul(L, light_texture(lights, k, q))
    elif kind == LIGHT_CYLINDER:
        # Only the half of the tube facing p can be seen from it: sample that half uniformly by area.
        axis = lights.axis_u[k]
        along = wp.normalize(axis)
        to_p = p - lights.position[k]
        phi0 = wp.atan2(wp.dot(to_p, basis_y(along)), wp.dot(to_p, basis_x(along)))
        phi = phi0 + (u2 - 0.5) * PI
        radial = wp.cos(phi) * basis_x(along) + wp.sin(phi) * basis_y(along)
        q = lights.position[k] + (u1 - 0.5) * axis + lights.params[k][0] * radial
        ln = radial
        area = 0.5 * lights.params[k][2]
        L = lights.radiance[k]
    else:
        prim = lights.prims[k]
        a = scene.points[scene.indices[prim, 0]]
        b = scene.points[scene.indices[prim, 1]]
        c = scene.points[scene.indices[prim, 2]]
        su = wp.sqrt(u1)
        bu = u2 * su  # weight of b
        bv = 1.0 - su  # weight of c ... (any uniform barycentric split works)
        bw = 1.0 - bu - bv
        q = bw * a + bu * b + bv * c
        cr = wp.cross(b - a, c - a)
        area = 0.5 * stable_length(cr)
        if area <= 0.0:
            return out
        ln = cr / (2.0 * area)
        st = bw * uvs[prim, 0] + bu * uvs[prim, 1] + bv * uvs[prim, 2]
        L = triangle_emission(lights, mats, k, tri_materials[prim], st)
        if cut_out(mats, tri_materials[prim], st):
            # A hole of an emissive cut-out: rays pass it and see no light there, so it sends none either.
            L = wp.vec3(0.0)
        two_sided = tri_double_sided[prim]
    to = q - p
    d2 = wp.length_sq(to)
    if d2 <= 0.0 or area <= 0.0:
        return out
    dist = wp.sqrt(d2)
    wi = to / dist
    cos_l = -wp.dot(wi, ln)
    if two_sided == 1:
        cos_l = wp.abs(cos_l)
    if cos_l <= 0.0:
        return out
    out.wi = wi
    out.dist = dist
    if pdf_solid_angle > 0.0:
        out.pdf = pdf_solid_angle
    else:
        out.pdf = d2 / (cos_l * area)
    out.value = wp.cw_mul(L, emission_shaping(lights, k, -wi)) / out.pdf
    return out


@wp.func
def sample_light_in_view(
    lights: DeviceLights,
    scene: DeviceScene,
    mats: DeviceMaterials,
    uvs: wp.array2d[wp.vec2],
    tri_materials: wp.array[wp.int32],
    tri_double_sided: wp.array[wp.int32],
    k: int,
    view: int,
    p: wp.vec3,
    n: wp.vec3,
    u1: float,
    u2: float,
):
    """:func:`sample_light` for a path of camera ``view``: the default headlight (a delta distant light) arrives
    along that camera's viewing direction."""
    ls = sample_light(lights, scene, mats, uvs, tri_materials, tri_double_sided, k, p, n, u1, u2)
    if k == lights.headlight:
        ls.wi = -lights.headlight_dirs[view]
    return ls
