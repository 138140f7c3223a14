"""Materials: UsdPreviewSurface read through UsdShade bindings, uploaded to the device and evaluated per hit.

Reading (:class:`MaterialReader`, used by :func:`wrt.load_usd`):

- Each mesh's material is ``UsdShade.MaterialBindingAPI.ComputeBoundMaterial(purpose="full")``, which applies
  USD's rules: direct and ``collection`` bindings, ``bindMaterialAs`` strength, inheritance down namespace, and
  ``material:binding:full`` over all-purpose bindings. Where that gives no material, or one without a
  surface wrt reads, a ``preview``-purpose binding to one it reads is used instead (:func:`bound_material`).
  The render settings' ``materialBindingPurposes``, when authored, replace that rule by their order.
  ``GeomSubset``\\ s of family ``materialBind`` override the mesh's material on their faces (subsets of points or
  edges are ignored with a warning).
- The material is read from the first of its surface outputs, render contexts' (``outputs:mtlx:surface``, ...)
  before the universal ``outputs:surface`` as Storm picks them, that leads to a ``UsdPreviewSurface`` (or MaterialX's
  ``ND_UsdPreviewSurface_surfaceshader``, its textures MaterialX's nodes of UsdUVTexture, UsdTransform2d and
  UsdPrimvarReader: :data:`UV_TEXTURE_IDS`) or to a MaterialX ``standard_surface`` or OpenPBR, which are mapped onto
  this model (:mod:`wrt.materialx`). Anything else (MDL, other
  MaterialX surfaces, no surface) falls back to a Lambertian surface of the shader's constant base colour where one is
  authored (:data:`FALLBACK_COLOR_INPUTS`), else to the default material (displayColor, else grey), with one warning
  per material, never an error.
- Inputs read: ``diffuseColor``, ``emissiveColor``, ``useSpecularWorkflow``, ``specularColor``, ``metallic``,
  ``roughness``, ``clearcoat``, ``clearcoatRoughness``, ``opacity``, ``opacityThreshold``, ``ior``. Any of them may
  be a constant or a ``UsdUVTexture`` output (``r``/``g``/``b``/``a``/``rgb``) with ``file``, ``st`` (from a
  ``UsdPrimvarReader_float2``, optionally through a ``UsdTransform2d``, or a constant; unconnected and unauthored:
  the mesh's ``st``, a ``UsdTransform2d``'s ``in`` Sdr's (0, 0)), ``wrapS``/``wrapT`` (``useMetadata``, the
  fallback, is ``black``: no wrap metadata is read from image files), ``scale``, ``bias``,
  ``fallback`` and ``sourceColorSpace``. A constant colour input with a ``colorSpace`` is decoded to linear from it
  (:meth:`MaterialReader._decoded_color`). ``diffuseColor`` may also come from a mesh's colour primvar through a
  ``UsdPrimvarReader_float3`` (or a MaterialX reader, :data:`COLOR_PRIMVAR_READERS`) of any ``varname``
  (:class:`PrimvarInput`): ``wrt.usd`` reads that primvar into the per-corner colours of the faces bound to that
  material where it reads ``displayColor`` otherwise (:meth:`MaterialReader.color_primvars`), and a mesh without it
  shows the reader's ``fallback``. ``normal`` is read from a ``UsdUVTexture``'s ``rgb`` output only (a tangent-space
  normal map: :func:`wrt.shade.shading_point`); ``occlusion`` is ignored, and a material whose
  ``outputs:displacement`` displaces, or that says ``opacityMode = presence`` (drawn as ``transparent``), is reported.
- A texture that cannot be read is replaced by its ``fallback`` value times ``scale`` plus ``bias``, with one warning
  per file.
- A ``file`` with ``<UDIM>`` in its name reads each tile that exists (1001 to 1100, as ``UsdShade.UdimUtils``
  resolves them) as an image of its own: :attr:`TextureInput.tiles`. Missing tiles read the ``fallback``; a pattern
  without any tile is replaced by it, with one warning naming the material and the pattern.
- An input that is not a finite number (NaN, inf, or authored with a wrong type) keeps its schema default, with one
  warning per material and problem naming the inputs (one authored with another count of numbers than its type's,
  a ``float3 roughness``, is named with that count).

Device side: :class:`DeviceMaterials` holds every material (index 0 is the default material: Lambertian, albedo =
displayColor or grey 0.5, opacity = displayOpacity or 1) and every texture; :func:`eval_surface` returns the
:class:`wrt.bsdf.Surface` at a hit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from .assignments import CountsAssignments, mark_checked
from .bsdf import Surface
from .errors import SceneError, check_fields, did_you_mean, eight_bit_colors, flag, int32_problem, stray_field
from .microfacet_albedo import GgxAlbedo, ggx_albedo_tables
from .textures import (
    FILTER_CLOSEST,
    FILTER_MODES,
    HALF_MAX,
    PACK_TEXELS,
    UDIM_FIRST,
    UDIM_TILES,
    WRAP_CLAMP,
    WRAP_MODES,
    TextureError,
    decode_curve,
    image_scale,
    materialx_texels,
    nearest_texel,
    outside_to_fallback,
    pack_images,
    preview_texels,
    read_image,
    reads_in_place,
    sample_image,
    split_color_space,
    stored_texels,
    udim_tile,
)
from .usd_values import asset_in_layer, value_at
from .wording import counted

SLOTS = (  # the texturable inputs, in device slot order
    "diffuseColor",
    "emissiveColor",
    "specularColor",
    "metallic",
    "roughness",
    "opacity",
    "clearcoat",
    "clearcoatRoughness",
    "normal",  # a tangent-space normal map (a texture only: see MaterialReader._read_normal_map)
)
SLOT_DIFFUSE = wp.constant(0)
SLOT_EMISSIVE = wp.constant(1)
SLOT_SPECULAR = wp.constant(2)
SLOT_METALLIC = wp.constant(3)
SLOT_ROUGHNESS = wp.constant(4)
SLOT_OPACITY = wp.constant(5)
SLOT_CLEARCOAT = wp.constant(6)
SLOT_CLEARCOAT_ROUGHNESS = wp.constant(7)
SLOT_NORMAL = wp.constant(8)
NUM_SLOTS = len(SLOTS)
CHANNELS = {"r": 0, "g": 1, "b": 2, "a": 3, "rgb": 4, "rgba": 4}  # UsdUVTexture outputs
FLAG_SPECULAR_WORKFLOW = wp.constant(1)  # useSpecularWorkflow = 1
FLAG_DISPLAY_COLOR = wp.constant(2)  # diffuseColor comes from the mesh's colour primvar (Material.color_primvar)
FLAG_THIN_WALLED = wp.constant(4)  # the dielectric of opacity < 1 is a thin sheet (Material.thin_walled)
MIN_IOR = wp.constant(1.0e-3)  # smaller (and negative) ior values are drawn as this index
DEFAULT_GREY = 0.5  # albedo of meshes with neither a material nor displayColor
# Shaders whose output is a mesh's colour primvar (the rgb of a 4-vector one), by id: the input naming the primvar and
# the one giving the value where a mesh lacks it (zero when unauthored, in both libraries).
COLOR_PRIMVAR_READERS = {
    **{f"UsdPrimvarReader_float{n}": ("varname", "fallback") for n in (3, 4)},
    **{f"ND_UsdPrimvarReader_{t}{n}": ("varname", "fallback") for t in ("color", "vector") for n in (3, 4)},
    **{f"ND_geompropvalue_{t}{n}": ("geomprop", "default") for t in ("color", "vector") for n in (3, 4)},
}
COLOR_READER_PREFIXES = ("ND_UsdPrimvarReader_color", "ND_geompropvalue_color")  # their fallback is a colour
TEXTURE_FALLBACK = (0.0, 0.0, 0.0, 1.0)  # UsdUVTexture's default fallback (RGBA)


def four_components(value, default) -> np.ndarray:
    """A UsdUVTexture ``scale``, ``bias`` or ``fallback`` as its four RGBA floats: three (a float3 authored where the
    schema has a float4) take ``default``'s alpha, a single number serves all four. ``np.resize`` repeated the red
    component into alpha, so ``scale = (0.5, 0.5, 0.5)`` halved the ``a`` output."""
    v = np.asarray(value if value is not None else default, np.float32).reshape(-1)
    if v.size == 3:
        return np.append(v, np.float32(default[3]))
    return np.resize(v, 4)


@dataclasses.dataclass
class TextureInput(CountsAssignments):
    """One ``UsdUVTexture`` feeding a material input.

    Attributes:
        image: index into ``Scene.textures`` (of a UDIM texture: its first tile found).
        channel: ``"r"``, ``"g"``, ``"b"``, ``"a"`` or ``"rgb"``: the texture output the input reads.
        wrap: ``(wrapS, wrapT)`` tokens: ``repeat``, ``mirror``, ``clamp``, ``black`` or ``fallback`` (``fallback``
            outside [0, 1], the image clamped inside, as MaterialX's ``constant``; a UDIM texture clamps within each
            tile instead).
        scale: ``(4,)`` multiplies the texel.
        bias: ``(4,)`` is added after ``scale``.
        transform: ``(3, 3)`` affine map applied to ``st`` (``UsdTransform2d``), column-vector convention; for a
            constant ``st`` its 2 x 2 part is zero and its translation that constant (:func:`constant_st_transform`).
        uv_set: name of the texture-coordinate primvar; None where ``st`` is a constant (no primvar is read).
        st_fallback: ``(2,)`` the ``st`` of a mesh without primvar ``uv_set`` (its ``UsdPrimvarReader_float2``'s
            ``fallback``), before ``transform``.
        tiles: None for one image; for a UDIM texture ``(UDIM_TILES,)`` int32, the ``Scene.textures`` index of tile
            ``UDIM_FIRST + u + 10 v`` at row ``u + 10 v``, -1 where that tile has no file.
        fallback: ``(4,)`` the texel where a UDIM texture has no tile (``st`` on a missing tile or outside the 10 x 10
            tiles), before ``scale`` and ``bias`` as every texel.
        filter: ``"linear"`` (bilinear between texel centres) or ``"closest"`` (the one texel whose square holds
            ``st``: MaterialX's ``filtertype`` ``closest``).
        mesh_frame: for a normal map, whether its tangent frame comes from the mesh's own ``uv_set`` coordinates
            (MaterialX's ``normalmap``, whose ``tangent`` is the geometry's ``Tworld`` whatever places the image)
            rather than from them after ``transform`` (UsdPreviewSurface's, the map's own ``st``); also, as
            MaterialX's ``normalmap`` decodes an input of 0, a value equal to ``bias`` (a black texel) is the flat
            normal.
    """

    image: int
    channel: str = "rgb"
    wrap: tuple[str, str] = ("repeat", "repeat")
    scale: np.ndarray = dataclasses.field(default_factory=lambda: np.ones(4, np.float32))
    bias: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(4, np.float32))
    transform: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3, dtype=np.float32))
    uv_set: str | None = "st"
    st_fallback: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2, np.float32))
    tiles: np.ndarray | None = None
    fallback: np.ndarray = dataclasses.field(default_factory=lambda: np.array(TEXTURE_FALLBACK, np.float32))
    filter: str = "linear"
    mesh_frame: bool = False

    def check(self, where: str = "TextureInput") -> None:
        """Raises ``ValueError`` (``TypeError`` for a ``uv_set`` that is no name) starting with ``where`` for a field
        of a wrong type, shape or value, and brings ``image`` to an ``int`` and the arrays to float32 (only where they
        are not so already: an array replaced at each check would look like an edit to the scene's caches). Run by
        :meth:`Material.check_textures`, naming the material and input, when the material is made, before a trace or
        render that follows an assignment to a field of either (:meth:`wrt.Scene.drop_stale_caches`), and at each
        upload. Unchecked, a NaN
        ``scale``, ``bias`` or ``transform`` rendered the texture black without a word, an ``image`` of 0.7 read image
        0, and a ``scale`` of 2 numbers or a ``(2, 2)`` transform failed at the upload with numpy's broadcast
        message."""
        # A 0-d array (np.array(2), a reduction's result) is one number, as it was taken before this check.
        number = isinstance(self.image, (int, float, np.number)) or (
            isinstance(self.image, np.ndarray) and self.image.ndim == 0)
        image = np.asarray(self.image) if number else np.asarray(None)
        if image.ndim != 0 or image.dtype.kind == "b" or int32_problem(image.reshape(1)):
            raise ValueError(f"{where}: image must be an integer, an index into scene.textures, got {self.image!r}")
        if type(self.image) is not int:
            self.image = int(image)
        # A channel or wrap mode of another name failed at the upload with a bare KeyError ('x').
        if not isinstance(self.channel, str) or self.channel not in CHANNELS:
            raise ValueError(f"{where}: channel must be one of {', '.join(CHANNELS)}, got {self.channel!r}"
                             f"{did_you_mean(self.channel, CHANNELS)}")
        wrap = tuple(self.wrap) if isinstance(self.wrap, (tuple, list)) else ()
        if len(wrap) != 2 or any(not isinstance(mode, str) or mode not in WRAP_MODES for mode in wrap):
            bad = [mode for mode in wrap if isinstance(mode, str) and mode not in WRAP_MODES]
            raise ValueError(f"{where}: wrap must be (wrapS, wrapT), each one of {', '.join(WRAP_MODES)}, got "
                             f"{self.wrap!r}{did_you_mean(bad[0], WRAP_MODES) if bad else ''}")
        if not isinstance(self.filter, str) or self.filter not in FILTER_MODES:
            raise ValueError(f"{where}: filter must be one of {', '.join(FILTER_MODES)}, got {self.filter!r}"
                             f"{did_you_mean(self.filter, FILTER_MODES)}")
        if not isinstance(self.mesh_frame, (bool, np.bool_)):
            raise TypeError(f"{where}: mesh_frame must be a bool, got {type(self.mesh_frame).__name__} "
                            f"{self.mesh_frame!r}")
        if self.uv_set is not None and not isinstance(self.uv_set, str):
            raise TypeError(f"{where}: uv_set must be a str, a primvar name such as 'st', or None (a constant st), "
                            f"got {type(self.uv_set).__name__} {self.uv_set!r}")
        for name, sizes, shape, default in (("scale", (1, 3, 4), (4,), (1.0, 1.0, 1.0, 1.0)),
                                            ("bias", (1, 3, 4), (4,), (0.0, 0.0, 0.0, 0.0)),
                                            ("fallback", (4,), (4,), None),
                                            ("transform", (9,), (3, 3), None),
                                            ("st_fallback", (2,), (2,), None)):
            value = getattr(self, name)
            if type(value) is np.ndarray and value.dtype == np.float32 and value.shape == shape and np.all(
                    np.isfinite(value)):
                continue  # as a check leaves it
            numbers = _finite_float32(value, sizes)
            if numbers is None:
                need = {(1, 3, 4): "1, 3 or 4 finite numbers (RGBA; 3 take the default alpha)",
                        (9,): "a (3, 3) matrix of finite numbers"}.get(sizes, f"{sizes[0]} finite numbers")
                raise ValueError(f"{where}: {name} must be {need}, got {value!r}")
            setattr(self, name, four_components(numbers, default) if default else numbers.reshape(shape))


def _finite_float32(value, sizes: tuple) -> np.ndarray | None:
    """``value`` as float32 numbers (flattened) when it holds a count in ``sizes`` of numbers finite in float32,
    else None (a string, None, a ragged list, NaN, 1e39)."""
    try:
        array = np.asarray(value)
    except ValueError:  # ragged
        return None
    if array.dtype.kind not in "biuf" or array.size not in sizes:
        return None
    with np.errstate(over="ignore"):
        numbers = array.astype(np.float32).reshape(-1)
    return numbers if np.all(np.isfinite(numbers)) else None


def constant_numbers(value) -> np.ndarray | None:
    """A constant input's ``value`` as flattened float64 numbers; None where it holds none: None, a ragged list, a
    string and an array of strings (a ``string[]`` or ``token[]``, which numpy reads as numbers: ``["0.7"]`` as
    0.7)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):  # a ragged list
        return None
    return array.astype(np.float64).reshape(-1) if array.dtype.kind in "biuf" else None


def bool_typed(value) -> bool:
    """Whether a constant input's ``value`` is a ``bool`` or ``bool[]``: USD's typed readers give none for a float or
    colour input (``bool inputs:emissiveColor = 1``), though numpy reads it as the number 1."""
    try:
        return np.asarray(value).dtype.kind == "b"
    except (TypeError, ValueError):  # a ragged list
        return False


def refused_constant(value, sizes: tuple) -> str:
    """Why a surface input's constant ``value``, which takes a count in ``sizes`` of numbers (``(1,)`` for a float,
    ``(1, 3, 4)`` for a colour), keeps the default: ``not a number`` (a string), ``authored with 3 numbers where one
    is expected`` (a ``float3 roughness``: it was called not a finite number, which its three are), else ``not a
    finite number`` (NaN, inf, past float32)."""
    if bool_typed(value):
        return "a bool, not a number"
    numbers = constant_numbers(value)
    if numbers is None:  # a string (or strings), None, a ragged list, a type of no numbers
        return "not a number"
    count = numbers.size
    if count not in sizes:
        if sizes == (1,):
            expected = "one is"
        elif len(sizes) == 1:
            expected = f"{sizes[0]} are"
        else:
            expected = f"{', '.join(map(str, sizes[:-1]))} or {sizes[-1]} are"
        return f"authored with {counted(count, 'number')} where {expected} expected"
    return "not a finite number"


@dataclasses.dataclass
class Material(CountsAssignments):
    """A UsdPreviewSurface; constants use the schema's fallback values.

    Attributes:
        path: prim path of the ``UsdShade.Material``.
        diffuse_color: ``(3,)`` linear RGB.
        emissive_color: ``(3,)`` emitted radiance, linear RGB.
        specular_color: ``(3,)`` F0 in the specular workflow.
        use_specular_workflow: ``useSpecularWorkflow``.
        metallic: 0 .. 1.
        roughness: 0 .. 1 (GGX alpha = roughness^2).
        opacity: 1 opaque; below 1 a smooth dielectric (see :mod:`wrt.bsdf`).
        opacity_threshold: > 0 turns opacity into a cut-out mask.
        ior: index of refraction.
        clearcoat: clearcoat weight.
        clearcoat_roughness: clearcoat roughness.
        clearcoat_ior: index of refraction of the clearcoat layer, whose F0 is ``((1 - n) / (1 + n))^2``; None (the
            default): ``ior``, as UsdPreviewSurface's specification has it (a MaterialX coat has its own index).
        specular_edge: the grazing reflectance (F90) of the specular lobe of a dielectric (``metallic`` 0) and of
            the specular workflow: 1, white, as UsdPreviewSurface specifies; 0 (with F0 0) leaves no specular lobe, as
            the fallback surface has; a MaterialX specular weight scales it as it scales F0 (:mod:`wrt.materialx`).
            At least 0; above 1 it is drawn as 1.
        thin_walled: the dielectric of ``opacity < 1`` is a sheet without thickness (a window pane modelled as one
            plane): it reflects both faces' light and lets the rest through unbent (see :mod:`wrt.bsdf`); no effect on
            an opaque surface.
        diffuse_from_display_color: diffuseColor is read from the mesh's colour primvar ``color_primvar`` (times
            ``color_primvar_scale``); ``diffuse_color`` is used where the mesh (and its instance) has none.
        color_primvar: the colour primvar (``displayColor``, ``temperature``, ...) diffuseColor reads.
        color_primvar_scale: ``(3,)`` multiplies the primvar's colour (a MaterialX ``multiply`` by a constant).
        textures: input name (one of :data:`SLOTS`) -> :class:`TextureInput`. ``"normal"`` is a tangent-space
            normal map (its ``rgb`` after ``scale`` and ``bias``, OpenGL convention: +Y up the map), which has no
            constant field: without it the mesh's normals are used.
    """

    path: str = ""
    diffuse_color: np.ndarray = dataclasses.field(default_factory=lambda: np.full(3, 0.18, np.float32))
    emissive_color: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3, np.float32))
    specular_color: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3, np.float32))
    use_specular_workflow: bool = False
    metallic: float = 0.0
    roughness: float = 0.5
    opacity: float = 1.0
    opacity_threshold: float = 0.0
    ior: float = 1.5
    clearcoat: float = 0.0
    clearcoat_roughness: float = 0.01
    clearcoat_ior: float | None = None
    specular_edge: float = 1.0
    thin_walled: bool = False
    diffuse_from_display_color: bool = False
    color_primvar: str = "displayColor"
    color_primvar_scale: np.ndarray = dataclasses.field(default_factory=lambda: np.ones(3, np.float32))
    textures: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        stray = stray_field(self)  # material.diffuseColor = (1, 0, 0), USD's spelling: kept and read by nothing
        if stray:
            raise SceneError(stray if self.path else f"Material {stray}", prim=self.path or None)
        _refuse_eight_bit(self)
        for name in ("diffuse_color", "emissive_color", "specular_color"):
            value = getattr(self, name)
            try:
                single = np.asarray(value).dtype.kind in "biuf" and np.size(value) == 1
            except ValueError:  # a ragged list: check_fields reports it
                single = False
            if single:  # one number for all three channels
                setattr(self, name, np.full(3, np.ravel(value)[0], np.float32))
        # NaN or inf reached every pixel the material covers, as a black image with no error.
        colors = [(name, (3,), None, np.float32) for name in ("diffuse_color", "emissive_color", "specular_color",
                                                               "color_primvar_scale")]
        numbers = [(name, (), None, float) for name in ("metallic", "roughness", "opacity", "opacity_threshold", "ior",
                                                         "clearcoat", "clearcoat_roughness")]
        numbers.append(("specular_edge", (), 0.0, float))
        if self.clearcoat_ior is not None:
            numbers.append(("clearcoat_ior", (), None, float))
        check_fields(self, *colors, *numbers)
        self._check_flags()
        self.check_textures()
        mark_checked(self)

    def _check_flags(self) -> None:
        """Raises ``TypeError`` naming the material for a flag that is no bool (``thin_walled="false"``, taken by its
        truth: a thin sheet without a word) and for a ``color_primvar`` that is no ``str``."""
        for name in ("use_specular_workflow", "thin_walled", "diffuse_from_display_color"):
            value = getattr(self, name)
            if type(value) is not bool:
                setattr(self, name, flag(value, f"{material_label(self)} {name}"))
        if not isinstance(self.color_primvar, str):
            raise TypeError(f"{material_label(self)} color_primvar must be a str, a primvar name such as "
                            f"'displayColor', got {type(self.color_primvar).__name__} {self.color_primvar!r}")

    def check_textures(self) -> None:
        """Raises ``ValueError`` naming the material when :attr:`textures` feeds an input that is not texturable or
        a normal map reads one channel. Run by the constructor and again at each upload: an entry added to the dict
        later (``material.textures["diffuse_color"] = ...``) is no assignment, and failed there with a bare
        ``tuple.index(x): x not in tuple``."""
        if not isinstance(self.textures, dict):  # None failed with "'NoneType' object is not iterable"
            raise TypeError(f"{material_label(self)} textures must be a dict of input name -> TextureInput, got "
                            f"{type(self.textures).__name__} {self.textures!r}")
        unknown = set(self.textures) - set(SLOTS)
        if unknown:
            raise ValueError(f"{material_label(self)} textures on unknown inputs {sorted(unknown)}; texturable "
                             f"inputs: {SLOTS}")
        for name, tex in self.textures.items():
            if not isinstance(tex, TextureInput):  # an image index or array failed at the upload on a missing field
                raise TypeError(f"{material_label(self)} textures[{name!r}] must be a wrt.TextureInput, got "
                                f"{type(tex).__name__}")
            tex.check(f"{material_label(self)} {name}")  # a field assigned since it was made (tex.scale = ...)
            mark_checked(tex)
        normal_map = self.textures.get("normal")
        if normal_map is not None and normal_map.channel != "rgb":
            raise ValueError(f"{material_label(self)} normal: a normal map reads the rgb output, not "
                             f"{normal_map.channel!r}")

    @property
    def uv_set(self) -> str:
        """The texture-coordinate primvar its textures read (``"st"`` when none reads one)."""
        for tex in self.textures.values():
            if tex.uv_set is not None:
                return tex.uv_set
        return "st"

    @property
    def emissive(self) -> bool:
        """True when the material emits light."""
        return bool(np.any(self.emissive_color > 0.0)) or "emissiveColor" in self.textures


def material_label(material: Material) -> str:
    """How messages name ``material``: ``material /Looks/Red:`` by its path, or ``Material`` where it has none (one
    made in Python), as its other fields' messages (``Material opacity must be ...``) and lights without a path name
    theirs; ``material :`` named nothing."""
    return f"material {material.path}:" if material.path else "Material"


def _refuse_eight_bit(material: Material) -> None:
    """Raises ``SceneError`` for reflectances given as 8-bit integers (``errors.eight_bit_colors``), as a mesh's,
    shape's or instances' colours are refused; checked before one number becomes three float32s, which hid the dtype.
    Emission is a radiance, so an integer above 1 means what it says."""
    for name in ("diffuse_color", "specular_color"):
        try:
            problem = eight_bit_colors(getattr(material, name))
        except ValueError:  # a ragged list: check_fields reports it
            continue
        if problem:
            raise SceneError(f"{name} {problem}" if material.path else f"Material {name} {problem}",
                             prim=material.path or None)


@dataclasses.dataclass
class PrimvarInput:
    """A mesh's colour primvar feeding diffuseColor (a ``UsdPrimvarReader_float3``, a MaterialX ``geompropvalue``).

    Attributes:
        name: the primvar (``displayColor``, ``temperature``, ...).
        fallback: ``(3,)`` the reader's value where a mesh lacks the primvar.
        scale: ``(3,)`` multiplies the primvar (and the fallback), as a MaterialX ``multiply`` by a constant does.
    """

    name: str
    fallback: np.ndarray
    scale: np.ndarray = dataclasses.field(default_factory=lambda: np.ones(3, np.float32))

    def apply(self, mat: Material):
        """Makes ``mat``'s diffuseColor this primvar. Where a mesh lacks it: the fallback times the scale, for
        ``displayColor`` too, as Storm shows it: UsdImaging publishes no displayColor a gprim does not author or
        inherit (``UsdImagingGprimAdapter::GetColor``), and Storm's primvar reader returns its fallback for a primvar
        the mesh lacks (``HdSt_CodeGen``'s primvar redirect)."""
        mat.diffuse_from_display_color = True
        mat.color_primvar = self.name
        mat.color_primvar_scale = np.asarray(self.scale, np.float32)
        mat.diffuse_color = np.asarray(self.fallback * self.scale, np.float32)


@wp.struct
class DeviceMaterials:
    """Every material and texture on the device; material 0 is the default (displayColor Lambert)."""

    colors: wp.array2d[wp.vec3]  # (M, 4) diffuseColor, emissiveColor, specularColor, colour primvar scale
    params: wp.array2d[float]  # (M, 9) metallic, roughness, opacity, opacityThreshold, ior, clearcoat,
    #                            clearcoatRoughness, the clearcoat's ior, specular_edge
    flags: wp.array[wp.int32]  # (M,) FLAG_* bits
    slots: wp.array2d[wp.int32]  # (M, NUM_SLOTS) texture binding per input, -1 for a constant
    tex_image: wp.array[wp.int32]  # (B,) image of each texture binding
    tex_channel: wp.array[wp.int32]  # (B,) 0..3 one channel, 4 rgb
    tex_wrap: wp.array[wp.vec2i]  # (B,) wrapS, wrapT codes (textures.WRAP_MODES)
    tex_filter: wp.array[wp.int32]  # (B,) filter codes (textures.FILTER_MODES)
    tex_scale: wp.array[wp.vec4]  # (B,)
    tex_bias: wp.array[wp.vec4]  # (B,)
    tex_transform: wp.array[wp.mat33]  # (B,) st transform
    tex_mesh_frame: wp.array[wp.int32]  # (B,) 1: a normal map's tangent frame from the untransformed st (mesh_frame)
    tex_tiles: wp.array[wp.int32]  # (B,) first row of the binding's UDIM table in tile_images, -1: one image
    tex_fallback: wp.array[wp.vec4]  # (B,) texel where a UDIM binding has no tile (then scaled and biased)
    tile_images: wp.array[wp.int32]  # (UDIM_TILES * U,) image of each tile of the U UDIM bindings, -1: none
    image_offsets: wp.array[wp.int32]  # (K,) first texel of each image
    image_sizes: wp.array[wp.vec2i]  # (K,) width, height
    image_scales: wp.array[wp.vec4]  # (K,) powers of two each image's channels are stored divided by (image_scale)
    texels: wp.array[wp.vec4h]  # all images, linear RGBA half floats
    count: int  # number of materials including the default
    ggx_albedo: GgxAlbedo  # albedo tables of the GGX lobe (multiple-scattering compensation, wrt.bsdf)


def default_material() -> Material:
    """Material 0: Lambertian with albedo from displayColor (grey 0.5 without one), no specular lobe (its
    ``specular_edge`` is 0: a specularColor of 0 still has UsdPreviewSurface's white grazing reflectance), and opacity
    from ``displayOpacity`` (opaque without one). Its index is 1: the ``1 - opacity`` that meets the dielectric
    passes straight through, unbent and unreflected, as Storm's fallback surface blends a see-through part over what
    lies behind it (index 1.5 would bend the view through a thin part as a lens does and mirror 4% of it)."""
    return Material(
        path="",
        diffuse_color=np.full(3, DEFAULT_GREY, np.float32),
        use_specular_workflow=True,
        specular_color=np.zeros(3, np.float32),
        roughness=1.0,
        ior=1.0,
        specular_edge=0.0,
        diffuse_from_display_color=True,
    )


def check_texture_input(tex: TextureInput, num_images: int, where: str):
    """Raises ``ValueError`` (``where`` names the material input) when ``tex`` indexes an image outside the
    ``num_images`` of the scene, or its UDIM table images other than those or -1; its own fields are checked by
    :meth:`TextureInput.check` (:meth:`Material.check_textures`)."""
    if not 0 <= tex.image < num_images:
        raise ValueError(f"{where} uses texture {tex.image}, but there are {num_images}")
    if tex.tiles is None:
        return
    tiles = np.asarray(tex.tiles)
    if tiles.shape != (UDIM_TILES,) or tiles.dtype.kind not in "iu":
        raise ValueError(f"{where}: UDIM tiles must be {UDIM_TILES} integers (tile {UDIM_FIRST} first), got "
                         f"{tiles.dtype} of shape {tiles.shape}")
    bad = np.flatnonzero((tiles < -1) | (tiles >= num_images))
    if len(bad):
        raise ValueError(f"{where}: UDIM tile {UDIM_FIRST + bad[0]} uses texture {tiles[bad[0]]}, but there are "
                         f"{num_images}")


def no_response_material() -> Material:
    """The last device material: it reflects, transmits and emits nothing (black, index 1: no Fresnel reflection),
    the surface of a mesh light of ``materialSyncMode`` ``noMaterialResponse`` ("as if there is no Material bound at
    all"), whatever material its mesh has (:attr:`wrt.light_table.LightTable.no_response`)."""
    return Material(path="<no material response>", diffuse_color=0.0, ior=1.0, specular_edge=0.0)


def mesh_frame_note(texture: TextureInput) -> str | None:
    """Why MaterialX normal map ``texture`` (``mesh_frame``) is not drawn in its ``Tworld`` frame, or None: that
    frame is the mesh's ``st`` (the ``tangent`` of texture-coordinate set 0, which is USD's ``st``), but a mesh holds
    one set of coordinates, those its images read, and the frame is taken from them. An image read through another
    primvar (``uv2`` turned 90 degrees from ``st``) turned the tilt with it, and one read at a constant ``st`` kept
    the surface's normal unless another texture had the mesh's ``st`` read, each without a word."""
    if not texture.mesh_frame or texture.uv_set == "st":
        return None
    if texture.uv_set is None:
        return ("its normal map is read at a constant texcoord: the mesh's st (MaterialX's Tworld) is read only where "
                "another of its textures reads st; elsewhere the map has no tangent frame and the surface's normal is "
                "used")
    return (f"its normal map reads primvar {texture.uv_set!r}: its tangent frame is taken from it, not from the "
            "mesh's st (MaterialX's Tworld), as a mesh holds one set of texture coordinates")


def upload_materials(materials: list[Material], textures: list[np.ndarray], device) -> DeviceMaterials:
    """Packs ``[default_material()] + materials + [no_response_material()]`` and ``textures`` into a
    :class:`DeviceMaterials` on ``device``."""
    all_materials = [default_material()] + list(materials) + [no_response_material()]
    m = len(all_materials)
    colors = np.zeros((m, 4, 3), np.float32)
    params = np.zeros((m, 9), np.float32)
    flags = np.zeros(m, np.int32)
    slots = np.full((m, NUM_SLOTS), -1, np.int32)
    bindings = []
    for k, mat in enumerate(all_materials):
        colors[k] = (mat.diffuse_color, mat.emissive_color, mat.specular_color, mat.color_primvar_scale)
        params[k] = (
            mat.metallic,
            mat.roughness,
            mat.opacity,
            mat.opacity_threshold,
            mat.ior,
            mat.clearcoat,
            mat.clearcoat_roughness,
            mat.ior if mat.clearcoat_ior is None else mat.clearcoat_ior,
            mat.specular_edge,
        )
        flags[k] = (
            (int(FLAG_SPECULAR_WORKFLOW) if mat.use_specular_workflow else 0)
            | (int(FLAG_DISPLAY_COLOR) if mat.diffuse_from_display_color else 0)
            | (int(FLAG_THIN_WALLED) if mat.thin_walled else 0)
        )
        mat.check_textures()
        for name, tex in mat.textures.items():
            check_texture_input(tex, len(textures), f"{material_label(mat)} {name}")
            slots[k, SLOTS.index(name)] = len(bindings)
            bindings.append(tex)
    b = max(len(bindings), 1)
    image = np.zeros(b, np.int32)
    channel = np.full(b, 4, np.int32)
    wrap = np.zeros((b, 2), np.int32)
    filters = np.zeros(b, np.int32)
    scale = np.ones((b, 4), np.float32)
    bias = np.zeros((b, 4), np.float32)
    transform = np.tile(np.eye(3, dtype=np.float32), (b, 1, 1))
    mesh_frame = np.zeros(b, np.int32)
    tiles = np.full(b, -1, np.int32)
    fallback = np.zeros((b, 4), np.float32)
    tile_tables = []
    for k, tex in enumerate(bindings):
        image[k] = tex.image
        channel[k] = CHANNELS[tex.channel]
        wrap[k] = (WRAP_MODES[tex.wrap[0]], WRAP_MODES[tex.wrap[1]])
        filters[k] = FILTER_MODES[tex.filter]
        scale[k] = tex.scale
        bias[k] = tex.bias
        transform[k] = tex.transform
        mesh_frame[k] = int(bool(tex.mesh_frame))
        fallback[k] = tex.fallback
        if tex.tiles is not None:
            tiles[k] = UDIM_TILES * len(tile_tables)
            tile_tables.append(np.asarray(tex.tiles, np.int32))
    tile_images = np.concatenate(tile_tables) if tile_tables else np.full(1, -1, np.int32)
    texels, offsets, sizes, image_scales = pack_images(textures)

    d = DeviceMaterials()
    d.colors = wp.array(colors, dtype=wp.vec3, device=device)
    d.params = wp.array(params, dtype=float, device=device)
    d.flags = wp.array(flags, dtype=wp.int32, device=device)
    d.slots = wp.array(slots, dtype=wp.int32, device=device)
    d.tex_image = wp.array(image, dtype=wp.int32, device=device)
    d.tex_channel = wp.array(channel, dtype=wp.int32, device=device)
    d.tex_wrap = wp.array(wrap, dtype=wp.vec2i, device=device)
    d.tex_filter = wp.array(filters, dtype=wp.int32, device=device)
    d.tex_scale = wp.array(scale, dtype=wp.vec4, device=device)
    d.tex_bias = wp.array(bias, dtype=wp.vec4, device=device)
    d.tex_transform = wp.array(transform, dtype=wp.mat33, device=device)
    d.tex_mesh_frame = wp.array(mesh_frame, dtype=wp.int32, device=device)
    d.tex_tiles = wp.array(tiles, dtype=wp.int32, device=device)
    d.tex_fallback = wp.array(fallback, dtype=wp.vec4, device=device)
    d.tile_images = wp.array(tile_images, dtype=wp.int32, device=device)
    d.image_offsets = wp.array(offsets, dtype=wp.int32, device=device)
    d.image_sizes = wp.array(sizes, dtype=wp.vec2i, device=device)
    d.image_scales = wp.array(image_scales, dtype=wp.vec4, device=device)
    d.texels = wp.array(texels, dtype=wp.vec4h, device=device)
    d.count = m
    d.ggx_albedo = ggx_albedo_tables(device)
    return d


@wp.func
def select_channel(c: wp.vec4, ch: int):
    """Channel ``ch`` (0..3) of ``c`` broadcast, or all of ``c`` for ``ch = 4`` (rgb)."""
    if ch < 4:
        return wp.vec4(c[ch])
    return c


@wp.func
def lookup_binding(mats: DeviceMaterials, b: int, st: wp.vec2):
    """The value of texture binding ``b`` at ``st``: ``texel * scale + bias``, one channel broadcast or RGBA; the
    texel filtered bilinearly, or the nearest one for the ``closest`` filter.

    A UDIM binding reads the tile under the transformed ``st``, at ``st`` minus the tile's corner, clamped at the
    tile's edges (bilinear filtering never mixes in a neighbouring tile, whatever ``wrapS``/``wrapT`` say); where that
    tile has no file, or ``st`` lies outside the tiles, the texture's fallback stands in for the texel (scaled and
    biased too, as MaterialX's UsdUVTexture graph feeds the image's default through them); so it does where ``st``
    is not finite (NaN or infinite texture coordinates, which the loader warns about) for any texture, and outside
    the unit square along a ``fallback`` wrap mode (MaterialX's ``constant`` address mode)."""
    xf = mats.tex_transform[b]
    p = xf * wp.vec3(st[0], st[1], 1.0)
    uv = wp.vec2(p[0], p[1])
    k = mats.tex_image[b]
    wrap = mats.tex_wrap[b]
    table = mats.tex_tiles[b]
    if table >= 0:
        tile = udim_tile(uv)
        k = -1
        if tile >= 0:
            k = mats.tile_images[table + tile]
        uv = uv - wp.vec2(wp.floor(uv[0]), wp.floor(uv[1]))
        wrap = wp.vec2i(WRAP_CLAMP, WRAP_CLAMP)
    c = mats.tex_fallback[b]
    if k >= 0 and wp.isfinite(uv[0]) and wp.isfinite(uv[1]) and not outside_to_fallback(uv, wrap):
        if mats.tex_filter[b] == FILTER_CLOSEST:
            c = nearest_texel(mats.texels, mats.image_offsets[k], mats.image_sizes[k], uv, wrap)
        else:
            c = sample_image(mats.texels, mats.image_offsets[k], mats.image_sizes[k], uv, wrap)
        c = wp.cw_mul(c, mats.image_scales[k])  # stored divided by them (powers of two: exact; 1 mostly)
    c = wp.cw_mul(c, mats.tex_scale[b]) + mats.tex_bias[b]
    return select_channel(c, mats.tex_channel[b])


@wp.func
def input_color(mats: DeviceMaterials, m: int, slot: int, st: wp.vec2, constant: wp.vec3):
    """A colour input: its texture when bound, else ``constant``."""
    b = mats.slots[m, slot]
    if b < 0:
        return constant
    c = lookup_binding(mats, b, st)
    return wp.vec3(c[0], c[1], c[2])


@wp.func
def input_float(mats: DeviceMaterials, m: int, slot: int, st: wp.vec2, constant: float):
    """A scalar input: its texture when bound, else ``constant``."""
    b = mats.slots[m, slot]
    if b < 0:
        return constant
    return lookup_binding(mats, b, st)[0]


@wp.func
def normal_map(mats: DeviceMaterials, m: int):
    """The texture binding of material ``m``'s normal map, -1 when it has none."""
    return mats.slots[m, SLOT_NORMAL]


@wp.func
def cut_out(mats: DeviceMaterials, m: int, st: wp.vec2):
    """True where material ``m`` has a hole at ``st``: ``opacity < opacityThreshold`` with a positive threshold."""
    threshold = mats.params[m, 3]
    if threshold <= 0.0:
        return False
    return wp.clamp(input_float(mats, m, SLOT_OPACITY, st, mats.params[m, 2]), 0.0, 1.0) < threshold


@wp.func
def eval_emission(mats: DeviceMaterials, m: int, st: wp.vec2):
    """``emissiveColor`` of material ``m`` at ``st``."""
    return input_color(mats, m, SLOT_EMISSIVE, st, mats.colors[m, 1])


@wp.func
def eval_surface(mats: DeviceMaterials, m: int, st: wp.vec2, display_color: wp.vec3, display_opacity: float):
    """Every UsdPreviewSurface input of material ``m`` at texture coordinate ``st``; ``display_color`` is the mesh's
    colour primvar there (NaN where the mesh and its instance have none), ``display_opacity`` its ``displayOpacity``
    (NaN where it has none), which only the default material (0) reads, as Storm's fallback surface does."""
    s = Surface()
    flags = mats.flags[m]
    base = mats.colors[m, 0]
    # A mesh without the primvar keeps the constant: the reader's fallback.
    if (flags & FLAG_DISPLAY_COLOR) != 0 and not wp.isnan(display_color[0]):
        base = wp.cw_mul(display_color, mats.colors[m, 3])
    emission = mats.colors[m, 1]
    specular = mats.colors[m, 2]
    metallic = mats.params[m, 0]
    roughness = mats.params[m, 1]
    opacity = mats.params[m, 2]
    clearcoat = mats.params[m, 5]
    clearcoat_roughness = mats.params[m, 6]
    # A bound texture replaces its input's constant. One lookup in a loop over the slots (its bound read at run time,
    # so that Warp does not unroll it), not one per input: a lookup is large, and each call site of it was compiled
    # again into every kernel that evaluates a surface (CUDA compile time). The normal map is read by the shading.
    for slot in range(mats.slots.shape[1]):
        b = mats.slots[m, slot]
        if b >= 0 and slot != SLOT_NORMAL:
            c = lookup_binding(mats, b, st)
            rgb = wp.vec3(c[0], c[1], c[2])
            if slot == SLOT_DIFFUSE:
                base = rgb
            elif slot == SLOT_EMISSIVE:
                emission = rgb
            elif slot == SLOT_SPECULAR:
                specular = rgb
            elif slot == SLOT_METALLIC:
                metallic = c[0]
            elif slot == SLOT_ROUGHNESS:
                roughness = c[0]
            elif slot == SLOT_OPACITY:
                opacity = c[0]
            elif slot == SLOT_CLEARCOAT:
                clearcoat = c[0]
            elif slot == SLOT_CLEARCOAT_ROUGHNESS:
                clearcoat_roughness = c[0]
    s.base_color = base
    s.emission = emission
    s.specular_color = specular
    s.metallic = wp.clamp(metallic, 0.0, 1.0)
    s.roughness = wp.clamp(roughness, 0.0, 1.0)
    s.opacity = wp.clamp(opacity, 0.0, 1.0)
    if m == 0 and not wp.isnan(display_opacity):
        s.opacity = wp.clamp(display_opacity, 0.0, 1.0)
    s.opacity_threshold = mats.params[m, 3]
    s.ior = wp.max(mats.params[m, 4], MIN_IOR)
    s.clearcoat = wp.clamp(clearcoat, 0.0, 1.0)
    s.clearcoat_roughness = wp.clamp(clearcoat_roughness, 0.0, 1.0)
    s.clearcoat_ior = wp.max(mats.params[m, 7], MIN_IOR)
    s.specular_workflow = wp.where((flags & FLAG_SPECULAR_WORKFLOW) != 0, 1, 0)
    s.thin_walled = wp.where((flags & FLAG_THIN_WALLED) != 0, 1, 0)
    s.specular_edge = wp.min(mats.params[m, 8], 1.0)
    # Keep colours physical: negative texels (or biases) would make energy from nothing, and a negative specularColor
    # (F0) negative pixels.
    s.base_color = wp.vec3(wp.max(s.base_color[0], 0.0), wp.max(s.base_color[1], 0.0), wp.max(s.base_color[2], 0.0))
    s.specular_color = wp.vec3(wp.max(s.specular_color[0], 0.0), wp.max(s.specular_color[1], 0.0),
                               wp.max(s.specular_color[2], 0.0))
    s.emission = wp.vec3(wp.max(s.emission[0], 0.0), wp.max(s.emission[1], 0.0), wp.max(s.emission[2], 0.0))
    return s


# Reading USD ---------------------------------------------------------------------------------------------------

# Shaders read as UsdPreviewSurface: its own id and MaterialX's node of it (the same inputs).
PREVIEW_SURFACE_IDS = ("UsdPreviewSurface", "ND_UsdPreviewSurface_surfaceshader")
# MaterialX's displacement shaders (stdlib_defs.mtlx): they move the surface by displacement (default 0) times scale
# (default 1), so that either at 0 moves nothing.
MATERIALX_DISPLACEMENT_IDS = ("ND_displacement_float", "ND_displacement_vector3")
# UsdUVTexture and MaterialX's nodes of it (libraries/bxdf/usd_preview_surface.mtlx: versions 2.2 and 2.3), which
# a MaterialX UsdPreviewSurface network reads its textures with; MaterialX's take their file's colour space from its
# colorSpace (else an authored sourceColorSpace) and have MaterialX's wrap modes (MATERIALX_WRAPS).
UV_TEXTURE_IDS = ("UsdUVTexture", "ND_UsdUVTexture", "ND_UsdUVTexture_23")
# MaterialX ND_UsdUVTexture wrapS/wrapT (default periodic) -> wrt's wrap mode. "black", the first of the node's
# modes, is MaterialX's constant address mode (modes are passed on by their index): the image's default outside
# [0, 1], which the node's graph makes its fallback.
MATERIALX_WRAPS = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "black": "fallback"}
ST_READER_PREFIXES = ("UsdPrimvarReader", "ND_UsdPrimvarReader")  # texture-coordinate readers (varname, fallback)
TRANSFORM2D_IDS = ("UsdTransform2d", "ND_UsdTransform2d")

# Base colour inputs of surface shaders other than UsdPreviewSurface, for their Lambertian fallback:
# (colour input, weight inputs that multiply it, texture input that replaces the colour when it names a file).
FALLBACK_COLOR_INPUTS = (
    ("diffuse_color_constant", ("diffuse_tint",), "diffuse_texture"),  # OmniPBR.mdl, OmniPBR_ClearCoat.mdl
    ("diffuse_reflection_color", ("diffuse_reflection_weight",), ""),  # OmniSurface.mdl
    ("base_color", ("base", "base_weight"), ""),  # MaterialX surfaces not read by wrt.materialx (gltf_pbr, ...)
)


def _surface_shaders(material):
    """The shaders that ``material``'s surface outputs lead to: every render context's (``outputs:mtlx:surface``,
    ...) first, in authored order, then the universal one, as Storm picks a context's output over the universal."""
    from pxr import UsdShade

    # GetSurfaceOutputs lists the universal output first; a render context's base name is "<context>:surface".
    for output in sorted(material.GetSurfaceOutputs(), key=lambda o: ":" not in o.GetBaseName()):
        for attr in output.GetValueProducingAttributes():
            yield UsdShade.Shader(attr.GetPrim())


def readable_surface(material):
    """The first shader a surface output of ``material`` leads to (render contexts' first, see
    :func:`_surface_shaders`) that wrt reads: a UsdPreviewSurface (or MaterialX's node of it), or a MaterialX
    standard_surface or OpenPBR (:mod:`wrt.materialx`); None when there is none."""
    from .materialx import MODELS  # that module imports this one

    readable = PREVIEW_SURFACE_IDS + tuple(MODELS)
    return next((s for s in _surface_shaders(material) if s and s.GetShaderId() in readable), None)


BINDING_TO_NO_MATERIAL = ("material bindings whose target is no Material (a missing prim, or a prim of another type) "
                          "bind nothing; their prims are drawn as bound to no material")


def bound_material(prim, purposes: tuple[str, ...] | None = None, walk=None, readable=readable_surface) -> tuple:
    """The material bound to ``prim`` (a mesh, a subset or a native instance) for rendering, an invalid
    ``UsdShade.Material`` when none, and the binding relationship that binds it (None for one bound above a native
    instance).

    ``purposes`` (the render settings' ``materialBindingPurposes``, ``""`` for all-purpose bindings) orders the binding
    purposes: the material of the first purpose that binds one wrt can read, else of the first that binds any; a purpose
    bound to no Material ends the search. ``None`` (nothing authored): the ``full`` purpose first (it falls back to
    all-purpose bindings); when that binds nothing, or a material wrt cannot read (an MDL look, a MaterialX surface
    other than standard_surface and OpenPBR) while a ``material:binding:preview`` binds one it can (a UsdPreviewSurface,
    standard_surface or OpenPBR), the preview binding, as usdview shows it. USD's resolution for a full render
    (``full``, then all-purpose) never reaches preview bindings; without this an asset whose meshes bind their look only
    for preview was drawn in the default grey (a standard_surface or OpenPBR one until this accepted them there).
    (usdview takes a preview binding first also where the full one is readable: there wrt, a final-frame renderer, keeps
    the full one.)

    ``walk(purpose)``: the :class:`wrt.usd_bindings.Found` of the bindings of that purpose alone, or None (see
    :class:`wrt.usd_bindings.OwnWalks`, the default), as ``ComputeBoundMaterial`` walks them before it falls back
    to all-purpose ones. ``readable``: :func:`readable_surface`, or a reader's kept answers of it."""
    from pxr import Usd, UsdShade

    from .usd_bindings import ALL_PURPOSE, OwnWalks

    walk = walk or OwnWalks(prim)
    nothing = (UsdShade.Material(), Usd.Relationship())

    def with_fallback(purpose):  # ComputeBoundMaterial(purpose)
        found = walk(purpose) or walk(ALL_PURPOSE)
        return found[:2] if found else nothing

    if purposes is not None:
        # A purpose without a binding of its own passes its turn in the order.
        found = []
        for purpose in purposes:
            binding = walk(purpose)
            if binding is None:
                continue
            material, rel = binding[:2]
            if material and readable(material):
                return material, rel
            found.append((material, rel))
            if not material:
                # A binding to no Material binds nothing for its purpose, as ComputeBoundMaterial(purpose) answers
                # and Hydra takes the first purpose bound: later purposes are not asked. It was passed over as no
                # binding, so ["full", ""] drew the all-purpose material under it, and it went unnamed.
                break
        return found[0] if found else nothing
    full, full_binding = with_fallback(UsdShade.Tokens.full)
    if full and readable(full):
        return full, full_binding
    # USD's full render stops at all-purpose bindings; a preview look wrt can read is the asset's own look, drawn
    # rather than the default grey, whatever surface it is (UsdPreviewSurface, standard_surface, OpenPBR).
    preview, preview_binding = with_fallback(UsdShade.Tokens.preview)
    if preview and readable(preview):
        return preview, preview_binding
    return full, full_binding


def _shader_name(shader) -> str:
    """``info:id``, or the MDL/source asset's sub-identifier or file, for messages."""
    shader_id = shader.GetShaderId()
    if shader_id:
        return str(shader_id)
    for source_type in ("mdl", ""):
        sub = shader.GetSourceAssetSubIdentifier(source_type)
        asset = shader.GetSourceAsset(source_type)
        if sub or (asset and asset.path):
            return str(sub or asset.path)
    return "without info:id"


def _source_attribute(shader, name: str):
    """The attribute that input ``name`` of ``shader`` takes its value from: the input, an interface input it connects
    to, or a shader output; None when there is none."""
    inp = shader.GetInput(name)
    attrs = inp.GetValueProducingAttributes() if inp else []
    return attrs[0] if attrs else None


def _authoring_layer(attr, time):
    """The layer of the strongest opinion that gives ``attr`` a value (default or time samples), against which its
    relative asset paths resolve; None when there is none."""
    for spec in attr.GetPropertyStack(time) if attr else []:
        if spec.HasDefaultValue() or spec.layer.GetNumTimeSamplesForPath(spec.path):
            return spec.layer
    return None


def _anchored(path: str, layer) -> str:
    """Asset path ``path`` anchored to ``layer`` (None: as it is) as USD anchors it to the layer that authors it
    (``Sdf.ComputeAssetPathRelativeToLayer``): where a relative path is looked for. A search path (``tex.png``, no
    ``./``) found nowhere stays as it is."""
    from pxr import Sdf, Tf

    # A URI ("http://...": anchoring makes it "http:/..."), an expression or an anonymous layer: named as authored.
    if layer is None or not path or "://" in path or path.startswith("`") or layer.anonymous:
        return path
    try:
        return Sdf.ComputeAssetPathRelativeToLayer(layer, path)
    except Tf.ErrorException:  # (a malformed path)
        return path


def _where(path: str, layer) -> str:
    """Asset path ``path`` as a warning names it: with where it was looked for (:func:`_anchored`) where that is
    another path. A missing ``./tex.png`` of a referenced layer in a sub-folder was named as authored, under the
    root layer's name, where it was never looked for."""
    anchored = _anchored(path, layer)
    return path if anchored == path else f"{path} (looked for at {anchored})"


def _rgb(value) -> np.ndarray | None:
    """A constant input's value as ``(3,)`` float64 (one number for all three); None when it is not a finite one,
    in float32 too (a ``double3`` of 1e39 became an infinite colour, which stopped the load), and for a string (as
    :meth:`MaterialReader._set_constant`: numpy read a ``string`` diffuseColor "0.7" as the grey 0.7, and a
    ``string[]`` likewise)."""
    v = None if bool_typed(value) else constant_numbers(value)
    if v is None or v.size not in (1, 3, 4) or not np.all(np.abs(v) <= np.finfo(np.float32).max):
        return None
    return np.resize(v, 3) if v.size > 1 else np.full(3, v[0])


TRANSFORM2D_DEFAULTS = (("rotation", (0.0,)), ("scale", (1.0, 1.0)), ("translation", (0.0, 0.0)))  # the schema's


def _transform2d(rotation_deg: float, scale, translation) -> np.ndarray:
    """``UsdTransform2d``: ``st * scale``, rotated counter-clockwise, then translated, as a 3x3 matrix."""
    c, s = math.cos(math.radians(rotation_deg)), math.sin(math.radians(rotation_deg))
    m = np.array([[c * scale[0], -s * scale[1], translation[0]],
                  [s * scale[0], c * scale[1], translation[1]],
                  [0, 0, 1]])
    return m.astype(np.float32)


def two_finite_numbers(value) -> np.ndarray | None:
    """A texture coordinate constant as ``(2,)`` float64; None when it is not two numbers finite in float32 (a
    double2 of 1e39 became an infinite texture transform on the device, which stopped the load), nor for a string or
    a ``string[]`` (:func:`constant_numbers`)."""
    v = constant_numbers(value)
    return v if v is not None and v.size == 2 and np.all(np.abs(v) <= np.finfo(np.float32).max) else None


def constant_st_transform(transform: np.ndarray, st) -> np.ndarray:
    """The ``(3, 3)`` float32 texture transform that maps every ``st`` to the constant ``st`` (``(2,)``) mapped by
    ``transform``: a constant texture coordinate, as :attr:`TextureInput.transform`."""
    point = np.asarray(transform, np.float64) @ np.array([st[0], st[1], 1.0])
    m = np.eye(3)
    m[:2, :2] = 0.0
    m[:2, 2] = point[:2]
    with np.errstate(over="ignore"):  # a point past float32's range becomes inf, which the callers name
        return m.astype(np.float32)


def used_materials(face_materials: np.ndarray) -> np.ndarray:
    """The material indices ``face_materials`` (``(F,)`` int, -1: the default material) holds, sorted: the
    ``np.unique`` of it, counted instead of hashed (several times faster on a mesh's faces, asked at every load)."""
    return np.flatnonzero(np.bincount(np.asarray(face_materials, np.int64).reshape(-1) + 1)) - 1


class MaterialReader:
    """Reads materials bound to meshes of one stage, once each; collects textures and fallback warnings.

    Args:
        time: ``Usd.TimeCode`` to read inputs at.
        skip: ``skip(reason, prim, detail=None)`` records a warning (see ``wrt.usd``); one reason per material.
        purposes: the render settings' ``materialBindingPurposes``, or None (see :func:`bound_material`).
        stage: the ``Usd.Stage`` read (materials bound above native instances are found in it by path).
        memo: a :class:`wrt.usd_material_memo.MaterialMemo` of reads to reuse and keep, or None.
        skipped: with ``memo``, the list ``skip`` records into, in order (``wrt.usd_problems``): a kept read's slice
            of it is kept with it, and added to it again where the read is reused.
    """

    def __init__(self, time, skip, purposes: tuple[str, ...] | None = None, stage=None, memo=None, skipped=None):
        from .usd_ancestors import BindingsAbove  # (pxr: imported where USD is read)

        self.stage = stage  # where materials bound above native instances are found by path
        self.memo = memo  # a wrt.usd_material_memo.MaterialMemo: reads kept at another time of the stage, or None
        self.skipped = skipped
        self.lookups = None  # while a read is being kept: its file_images calls (wrt.usd_material_memo.FileLookup)
        self.time = time
        self.skip = skip
        self.purposes = purposes
        self.bindings_above = BindingsAbove()  # whether a prim or an ancestor binds anything, each prim's answer kept
        self.materials: list[Material] = []
        self.textures: list[np.ndarray] = []
        self.texture_paths: list[str] = []
        self._by_path: dict[str, int] = {}  # material prim path (in its prototype) -> index, -1 for the default
        self._readable: dict = {}  # material prim path (Sdf.Path) -> its readable_surface
        # (resolved path, colour space) -> image index, -1 unreadable; a MaterialX image node's read of the file, laid
        # out as it takes the file's channels, under (resolved path, colour space, "materialx")
        self._images: dict[tuple, int] = {}
        self._channels: dict[tuple[str, str], tuple[int, ...]] = {}  # the same key -> its file's channels' places
        # (resolved path, colour space) -> (reason, detail) of what a file's read found wrong: told again with each
        # shader that names the file, as a fresh read of that shader would tell it
        self._file_problems: dict[tuple[str, str], tuple[str, str | None]] = {}
        # the same key -> what the read warned of (a Pillow warning, a PNG gamma not decoded), told with each shader
        self._file_notes: dict[tuple[str, str], list[str]] = {}
        self._udim: dict[tuple, np.ndarray] = {}  # (UDIM pattern, its layer, colour space) -> TextureInput.tiles
        self._udim_files: dict[tuple, list] = {}  # the same key -> the _images keys of its tiles' files

    # Bindings

    def readable_surface(self, material):
        """:func:`readable_surface` of ``material``, asked once per material of this load: each mesh's binding asked
        it again of the material's outputs and shaders (20,000 meshes bound to 500 materials: 40,000 walks)."""
        path = material.GetPath()
        if path not in self._readable:
            self._readable[path] = readable_surface(material)
        return self._readable[path]

    def bound(self, prim, outer: tuple | None = None, missing: set | None = None) -> tuple:
        """:func:`bound_material` of ``prim`` (under this reader's purposes); inside a native prototype ``outer``
        (:meth:`instance_bindings` of the instance being read) completes each purpose's walk, which stops at the
        prototype root (:func:`wrt.usd_bindings.combine`), and ``missing`` gains the purposes whose walk found no
        binding inside (those an instance's bindings may give). Where neither ``prim`` nor an ancestor authors a
        binding, no walk inside is asked of USD, whose search walks every ancestor (quadratic in the depth of a
        hierarchy with a mesh at each level). The answer is kept in :attr:`memo` for the next loads of its kept stage
        (:class:`wrt.usd_material_memo.MaterialMemo`: no binding can differ there)."""
        key = (prim.GetPath(), outer, self.purposes)
        # Named at every load, a kept binding too: kept, its walk (which named them) was not made again, and a kept
        # stage's later loads went without the warning that a fresh load gives.
        self._name_binding_problems(prim)
        kept = None if self.memo is None else self.memo.bindings.get(key)
        if kept is None:
            missed = set()
            kept = (*bound_material(prim, self.purposes, self._walk(prim, outer, missed), self.readable_surface),
                    frozenset(missed))
            if self.memo is not None:
                self.memo.bindings[key] = kept
        else:
            self.memo.binding_counts["reused"] += 1
        if missing is not None:
            missing |= kept[2]
        if kept[1] and not kept[0]:  # named at every load, as above
            self._name_binding_to_no_material(kept[1])
        return kept[:2]

    def _name_binding_to_no_material(self, rel):
        """Names binding relationship ``rel``, which ``ComputeBoundMaterial`` found and whose target is no Material (a
        missing prim, an Xform): it binds nothing, and its prims were drawn as bound to no material without a word. An
        emptied binding (no target, deliberately unbound) is no binding to USD and is not named. A target reached
        through relationships is named with the prim USD reached (``-> /World.relay -> /World/Xform``)."""
        targets = rel.GetTargets()
        if targets:  # a collection binding targets its collection, then its material
            reached = rel.GetForwardedTargets()
            through = f" -> {reached[-1]}" if reached and reached[-1] != targets[-1] else ""
            self.skip(BINDING_TO_NO_MATERIAL, rel.GetPrim(), f"{rel.GetName()} -> {targets[-1]}{through}")

    def _walk(self, prim, outer, missing):
        """``walk(purpose)`` of ``prim``: the :class:`wrt.usd_bindings.Found` of that purpose's bindings alone,
        joined with ``outer``, or None (see :meth:`bound`)."""
        from .usd_bindings import OwnWalks, combine, outer_entry

        own = OwnWalks(prim) if self._name_binding_problems(prim) else (lambda purpose: None)
        if outer is None and missing is None:
            return own

        def walk(purpose):
            found = own(purpose)
            if found is None and missing is not None:
                missing.add(purpose)
            return combine(found, outer_entry(outer, purpose), self._material_at)

        return walk

    def _name_binding_problems(self, prim) -> bool:
        """Whether ``prim`` or an ancestor binds anything (:attr:`bindings_above`); where one does, a warning names
        each binding on them, not named before in this load, whose purpose USD's calls disagree on, or whose
        targets USD ignores; a collection binding of an attribute is held back (:func:`wrt.usd_bindings.hold_back`)
        before any walk meets it."""
        from .usd_bindings import NOT_A_COLLECTION, hold_back

        binds = self.bindings_above.any(prim)
        for p, name, problem, *detail in self.bindings_above.problems(prim) if binds else ():
            self.skip(problem, p, detail[0] if detail else name)
            if problem == NOT_A_COLLECTION:
                hold_back(p, name)
        return binds

    def _material_at(self, path: str):
        from pxr import UsdShade

        return UsdShade.Material(self.stage.GetPrimAtPath(path)) if path else UsdShade.Material()

    def instance_bindings(self, prim, outer: tuple | None, missing: set) -> tuple | None:
        """What each binding purpose's walk finds on and above native instance ``prim`` (joined with ``outer``, its
        container's, inside a prototype), as a tuple of :class:`wrt.usd_bindings.OuterBinding` (None: nothing):
        the part of the walk of the instance's proxies that its prototype, read once, cannot see. ``missing``
        gains the purposes whose walk found nothing up to the root of ``prim``'s container."""
        from pxr import UsdShade

        from .usd_bindings import ALL_PURPOSE, OuterBinding

        purposes = self.purposes if self.purposes is not None else (UsdShade.Tokens.full, UsdShade.Tokens.preview)
        purposes = dict.fromkeys((*purposes, ALL_PURPOSE))
        if outer is None and not self.bindings_above.any(prim):
            # Nothing bound on or above it: each purpose's walk (below) finds nothing, as the walks of most of the
            # instances of a large stage do, which asked for each purpose took a tenth of their read.
            missing.update(purposes)
            return None
        walk = self._walk(prim, outer, missing)
        entries = []
        for purpose in purposes:
            found = walk(purpose)
            if found is not None and found.rel and not found.material:
                self._name_binding_to_no_material(found.rel)
            if found is not None:
                path = str(found.material.GetPath()) if found.material else ""
                entries.append(OuterBinding(purpose, path, found.stronger))
        return tuple(entries) or None

    def face_materials(self, prim, n_faces: int, outer: tuple | None = None,
                       missing: set | None = None) -> np.ndarray | None:
        """The material index of each face of mesh ``prim`` (``(F,)`` int32, -1: the default material), or None when
        the mesh and its subsets bind no material at all (the one face of a gprim, Points or BasisCurves prim: its
        own binding, its subsets ignored with a warning). A ``materialBind`` subset's faces take the subset's
        material (its walk passes through the mesh: a subset that binds nothing has the mesh's). ``outer``,
        ``missing``: see :meth:`bound`."""
        from pxr import UsdGeom, UsdShade, Vt

        from .usd_problems import authored_type

        material, _ = self.bound(prim, outer, missing)
        faces = np.full(n_faces, self.material_index(material) if material else -1, np.int32)
        bound = bool(material)
        subsets = UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets()
        if subsets and not prim.IsA(UsdGeom.Mesh):  # the subset holding index 0 bound all of a curves prim
            self.skip("materialBind subsets of prims other than meshes were ignored (their indices are no faces)",
                      prim, f"{prim.GetTypeName()}, subsets {', '.join(s.GetPrim().GetName() for s in subsets)}")
            subsets = []
        owner = np.full(n_faces, -1, np.int64)  # the subset (index into subsets) that gave each face its material
        for k, subset in enumerate(subsets):
            sub_material, _ = self.bound(subset.GetPrim(), outer, missing)
            if not sub_material:
                continue
            element_type = subset.GetElementTypeAttr().Get()
            if element_type != UsdGeom.Tokens.face:  # its indices are points or edges, not faces
                self.skip("materialBind subsets whose elementType is not face were ignored", subset.GetPrim(),
                          f"elementType = {element_type!r}")
                continue
            indices_attr = UsdGeom.Subset(subset.GetPrim()).GetIndicesAttr()
            indices = value_at(indices_attr, self.time)
            if indices is not None and not isinstance(indices, Vt.IntArray):
                # USD reads no indices from them (GetUnassignedIndices leaves every face unassigned): wrt read them
                # as faces (a float[] or a string "0"), and letters stopped the load with SceneError.
                self.skip("materialBind subsets whose indices are not int[] were ignored, as USD reads none from them",
                          subset.GetPrim(), f"indices is {authored_type(indices_attr, self.time)}")
                continue
            indices = np.asarray(indices if indices is not None else [], np.int64).reshape(-1)
            # Faces the mesh has not got: they were dropped without a word.
            outside = (indices < 0) | (indices >= n_faces)
            if outside.any():
                i = int(np.argmax(outside))
                self.skip("materialBind subset indices that are not faces of the mesh were ignored", subset.GetPrim(),
                          f"{int(outside.sum())} of {len(indices)}, e.g. indices[{i}] = {indices[i]} for {n_faces} "
                          "faces")
                indices = indices[~outside]
            # Faces an earlier subset bound to another material: the later subset wins (as before), now with a word,
            # since USD's materialBind family is nonOverlapping and which one a renderer draws is not defined.
            material = self.material_index(sub_material)
            taken = indices[(owner[indices] >= 0) & (faces[indices] != material)]
            if len(taken):
                earlier = sorted({subsets[j].GetPrim().GetName() for j in owner[taken].tolist()})
                self.skip("materialBind subsets share faces; a shared face takes the material of the last subset "
                          "listing it", subset.GetPrim(),
                          f"{len(np.unique(taken))} face(s) also in {', '.join(earlier)}")
            faces[indices] = material
            owner[indices] = k
            bound = True
        return faces if bound else None

    def uv_set(self, face_materials: np.ndarray | None, prim=None) -> str | None:
        """The texture-coordinate primvar to read for mesh ``prim`` whose faces use ``face_materials``; None when none
        of their textures reads one (untextured, or read at a constant ``st``). A mesh holds one set of texture
        coordinates: when its textures read several primvars, the first is used for all of them, and ``skip`` reports
        it."""
        names = []
        if face_materials is not None:
            for k in used_materials(face_materials):
                if k >= 0:
                    for texture in self.materials[k].textures.values():
                        if texture.uv_set is not None and texture.uv_set not in names:
                            names.append(texture.uv_set)
        if len(names) > 1 and prim is not None:
            self.skip(f"textures read several texture-coordinate primvars ({', '.join(names)}), but only one per "
                      f"mesh is supported; {names[0]!r} is used for all", prim)
        return names[0] if names else None

    def st_fallback(self, face_materials: np.ndarray | None, uv_set: str) -> np.ndarray:
        """``(2,)`` the ``st`` that mesh faces using ``face_materials`` take where the mesh lacks primvar ``uv_set``:
        the fallback of the first primvar reader of that name among their materials' textures (zero if none)."""
        for k in [] if face_materials is None else used_materials(face_materials):
            for texture in self.materials[k].textures.values() if k >= 0 else ():
                if texture.uv_set == uv_set:
                    return np.asarray(texture.st_fallback, np.float64)
        return np.zeros(2)

    def color_primvars(self, face_materials: np.ndarray | None) -> list[str]:
        """The colour primvars to read for a mesh (or gprim) whose faces use ``face_materials``: those its materials'
        diffuseColor reads (in material order), then ``displayColor`` for faces of the default material; just
        ``displayColor`` when no face reads one. The first is the one of faces whose material reads none (see
        :meth:`color_primvar_of`)."""
        names = []
        ids = [-1] if face_materials is None else used_materials(face_materials)
        for k in sorted(ids, key=lambda k: k < 0):  # the default material's displayColor last
            name = self.color_primvar_of(k)
            if name is not None and name not in names:
                names.append(name)
        return names or ["displayColor"]

    def color_primvar_of(self, material: int) -> str | None:
        """The colour primvar the faces of ``material`` (-1: the default material) shade with: ``displayColor`` for
        the default material, the primvar a material's diffuseColor reads, None for a material that reads none."""
        if material < 0:
            return "displayColor"
        mat = self.materials[material]
        return mat.color_primvar if mat.diffuse_from_display_color else None

    # Materials

    def material_index(self, material) -> int:
        """Index of ``material`` (a ``UsdShade.Material``) in :attr:`materials`, reading it on first use. An instance
        proxy's is its prim in the prototype: a material inside a native instance, bound inside it (read in the
        prototype) and from a mesh outside (through the proxy's path), was read and listed twice."""
        prim = material.GetPrim()
        path = str((prim.GetPrimInPrototype() if prim.IsInstanceProxy() else prim).GetPath())
        if path not in self._by_path:
            mat = self._kept_or_read(material)
            if mat is None:
                self._by_path[path] = -1
            else:
                self._by_path[path] = len(self.materials)
                self.materials.append(mat)
        return self._by_path[path]

    def _kept_or_read(self, material) -> Material | None:
        """:meth:`_read_material`, or the memo's read of it at another time that cannot differ, its image files looked
        up again (:func:`wrt.usd_material_memo.replay`: a file that changed has it read again)."""
        from .usd_material_memo import replay

        kept = None if self.memo is None else self.memo.find(material, self.time)
        if kept is not None:
            replayed = replay(self, kept)
            if replayed is not None:
                self.memo.counts["reused"] += 1
                return replayed[0]
        if self.memo is None or not self.memo.reusable(material):
            return self._read_material(material)
        start, outer = len(self.skipped), self.lookups
        self.lookups = []
        try:
            mat = self._read_material(material)
            self.memo.keep(material, self.time, mat, self.skipped[start:], self.lookups, start)
        finally:
            self.lookups = outer
        return mat

    def _read_material(self, material) -> Material | None:
        from .materialx import MODELS, read_materialx_surface  # that module imports this one

        prim = material.GetPrim()
        path = str(prim.GetPath())
        readable = self.readable_surface(material)  # render contexts' outputs before the universal one, as Storm
        if readable and readable.GetShaderId() in MODELS:  # standard_surface or OpenPBR (wrt/materialx.py)
            self._check_displacement(material)
            return read_materialx_surface(self, readable, path)
        # Else the shader Storm would draw (a render context's first) is named: the universal output may be absent.
        shader = readable or next((s for s in _surface_shaders(material) if s), None)
        if not readable:
            if not shader:
                found = [o.GetBaseName() for o in material.GetSurfaceOutputs() if o.HasConnectedSource()]
                what = f"no surface output leads to a shader (found: {', '.join(found) or 'none'})"
            else:
                what = f"shader {_shader_name(shader)} is not supported"
            color = self._fallback_color(material)
            if color is None:
                self.skip(f"material {path}: {what}; it falls back to displayColor or grey", prim)
                return None
            name, value = color
            value_text = ", ".join(f"{c:.3g}" for c in value)
            self.skip(f"material {path}: {what}; it falls back to a Lambertian surface of its {name} ({value_text})",
                      prim)
            # specularColor 0 and no grazing edge (specular_edge 0, as the fallback surface): no specular lobe
            return Material(path=path, diffuse_color=value, use_specular_workflow=True, roughness=1.0,
                            specular_edge=0.0)
        self._check_displacement(material)
        mat = Material(path=path)
        for name in SLOTS:
            if name == "normal":
                self._read_normal_map(shader, mat)
            else:
                self._read_input(shader, name, mat)
        for name, field in (("useSpecularWorkflow", "use_specular_workflow"),
                            ("opacityThreshold", "opacity_threshold"), ("ior", "ior")):
            found = self._producer(shader, name)
            if found is not None and found[0] == "shader":  # a texture: it was dropped without a word
                self.skip(f"material {path}: useSpecularWorkflow, opacityThreshold and ior are read as constants "
                          "only; connected to a shader, they keep their defaults", found[1].GetPrim(),
                          detail=f"{name} <- {_shader_name(found[1])}")
            elif found is not None:  # unauthored: the default stays
                self._set_constant(mat, name, field, False, found[1], shader.GetPrim())
        see_through = (mat.opacity < 1.0 or "opacity" in mat.textures) and mat.opacity_threshold <= 0
        if see_through and str(self._constant(shader, "opacityMode") or "") == "presence":
            self.skip("opacityMode = presence (opacity as coverage) is not supported; opacity below 1 is drawn as "
                      "glass, as opacityMode = transparent", prim)
        return mat

    def _check_displacement(self, material):
        """Reports ``material`` when its displacement output displaces: it leads to a UsdPreviewSurface whose
        ``displacement`` input is connected or not 0, or to any other shader. RenderMan and Karma move the surface;
        wrt draws it where the mesh is."""
        from pxr import UsdShade

        for output in material.GetDisplacementOutputs():
            for attr in output.GetValueProducingAttributes():
                if UsdShade.Utils.GetType(attr.GetName()) != UsdShade.AttributeType.Output:
                    continue  # a value on the material's own output: no shader displaces
                shader = UsdShade.Shader(attr.GetPrim())
                shader_id = shader.GetShaderId()
                if shader_id in PREVIEW_SURFACE_IDS and not self._nonzero(shader, "displacement", 0.0):
                    continue
                if shader_id in MATERIALX_DISPLACEMENT_IDS and not (self._nonzero(shader, "displacement", 0.0)
                                                                   and self._nonzero(shader, "scale", 1.0)):
                    continue
                self.skip("displacement (outputs:displacement) is not supported; these materials' surfaces are drawn "
                          "undisplaced", material.GetPrim(), detail=_shader_name(shader))
                return

    def _nonzero(self, shader, name: str, default: float) -> bool:
        """Whether input ``name`` of ``shader`` may be other than 0: connected, or a constant (``default``
        unauthored) that is not 0."""
        found = self._producer(shader, name)
        if found is None:
            return default != 0.0
        value = _rgb(found[1]) if found[0] == "value" else None
        return value is None or bool(value.any())

    def _fallback_color(self, material) -> tuple[str, np.ndarray] | None:
        """``(input name, (3,) colour)``: the constant base colour (times its weight) of a surface shader this reader
        does not support (OmniPBR, OmniSurface, MaterialX gltf_pbr, ...), from any render context; None
        when none is authored. Without it an OmniPBR car of a red ``diffuse_color_constant`` was drawn grey. The
        colour, and a colour-typed weight (OmniPBR's ``diffuse_tint``), in linear Rec.709 from its colour space
        (:meth:`_decoded_color`), as every other colour constant: an ``srgb_rec709_scene`` base colour was drawn as
        authored."""
        path = str(material.GetPath())
        for shader in _surface_shaders(material):
            for name, weights, replaced_by in FALLBACK_COLOR_INPUTS:
                color = _rgb(self._constant(shader, name))
                if color is None or (replaced_by and getattr(self._constant(shader, replaced_by), "path", "")):
                    continue
                color = self._decoded_color(shader, name, color, path)
                if color is None:  # past float32's range once decoded (named): not this one
                    continue
                for weight in weights:
                    w = _rgb(self._constant(shader, weight))
                    inp = shader.GetInput(weight)
                    if w is not None and inp and inp.GetTypeName().role == "Color":
                        w = self._decoded_color(shader, weight, w, path)
                    color = color if w is None else color * w
                if not np.all(np.abs(color) <= np.finfo(np.float32).max):  # each finite, their product not
                    continue
                return name, np.maximum(color, 0.0).astype(np.float32)
        return None

    def _producer(self, shader, name):
        """What feeds input ``name``: ``("value", v)``, ``("shader", source, output_name)`` or None. A connection to
        a prim or property that does not exist is no source, as USD resolves it (the input's own value, else none),
        and is named in a warning: a deleted or renamed texture node was drawn in the default colour without a
        word."""
        from pxr import UsdShade

        self._report_dangling(shader, name)
        attr = _source_attribute(shader, name)
        if attr is None:
            return None
        if UsdShade.Utils.GetType(attr.GetName()) == UsdShade.AttributeType.Output:
            base, _ = UsdShade.Utils.GetBaseNameAndType(attr.GetName())
            return ("shader", UsdShade.Shader(attr.GetPrim()), str(base))
        value = value_at(attr, self.time)
        return None if value is None else ("value", value)

    def _report_dangling(self, shader, name: str) -> None:
        """Warns about the connections of input ``name`` of ``shader`` whose target does not exist."""
        inp = shader.GetInput(name)
        if not inp or not inp.GetAttr().HasAuthoredConnections():
            return
        stage = shader.GetPrim().GetStage()
        for target in inp.GetAttr().GetConnections():
            if not (target.IsPropertyPath() and stage.GetAttributeAtPath(target)):
                self.skip("inputs connected to a prim or output that does not exist read their own value, else their "
                          "default", shader.GetPrim(), detail=f"{name} -> {target}")

    def _constant(self, shader, name):
        """The constant value of input ``name`` (following interface connections), or None."""
        found = self._producer(shader, name)
        return found[1] if found and found[0] == "value" else None

    def _read_input(self, shader, name: str, mat: Material):
        field = {"diffuseColor": "diffuse_color", "emissiveColor": "emissive_color", "specularColor": "specular_color",
                 "clearcoatRoughness": "clearcoat_roughness"}.get(name, name)
        is_color = name.endswith("Color")
        found = self._producer(shader, name)
        if found is None:
            return
        if found[0] == "value":
            value = found[1]
            # In its colorSpace (USD's source colour space of a colour attribute): a diffuseColor of 0.5 in
            # srgb_rec709_scene was read as 0.5 for 0.214. (The inputs of *Color are color3f in Sdr's definition.)
            if is_color and (rgb := _rgb(value)) is not None:
                value = self._decoded_color(shader, name, rgb, mat.path)
                if value is None:  # past float32's range: the default stays, named
                    return
            self._set_constant(mat, name, field, is_color, value, shader.GetPrim())
            return
        source, output = found[1], found[2]
        source_id = source.GetShaderId() or ""
        if source_id in UV_TEXTURE_IDS:
            tex, fallback = self._texture(source, output, mat.path)
            if tex is not None:
                mat.textures[name] = tex
            else:  # three numbers: a float input reads the first, as it reads the texture's red or its one channel
                value = fallback if is_color else fallback[:1]
                self._set_constant(mat, name, field, is_color, value, source.GetPrim())
        elif name == "diffuseColor" and source_id in COLOR_PRIMVAR_READERS:
            primvar = self.color_primvar_input(source, mat.path)
            if primvar.name:
                primvar.apply(mat)
            else:  # names no primvar: its fallback
                mat.diffuse_color = np.asarray(primvar.fallback * primvar.scale, np.float32)
        elif source_id.startswith(ST_READER_PREFIXES):
            varname = self._constant(source, "varname")
            fallback = self._constant(source, "fallback")
            if fallback is not None:
                self._set_constant(mat, name, field, is_color, fallback, source.GetPrim())
            self.skip(
                f"material {mat.path}: {name} reads primvar {varname!r}, which is not supported; its fallback is used",
                source.GetPrim(),
            )
        elif shader.GetShaderId() == PREVIEW_SURFACE_IDS[1] and source_id.startswith("ND_"):
            self._read_materialx_nodes(shader, name, field, is_color, mat)
        else:
            # The schema's default, as Storm draws it: UsdImaging passes a connected input no value (its value-producing
            # attribute is the output), and Storm's fallback for an unrecognized upstream node is then the Sdr default.
            self.skip(
                f"material {mat.path}: {name} is connected to an unsupported shader ({source_id or 'no info:id'}); "
                "its default is used, as Storm draws it (a value authored beside the connection is not read)",
                source.GetPrim(),
            )

    def _read_materialx_nodes(self, shader, name: str, field: str, is_color: bool, mat: Material):
        """Input ``name`` of MaterialX's ``ND_UsdPreviewSurface_surfaceshader`` ``shader`` fed by MaterialX's own
        nodes (``ND_image_*``, ``ND_tiledimage_*``, the math :mod:`wrt.materialx_fold` folds), read as a
        standard_surface input is (:func:`wrt.materialx.read_node_input`), its notes in one warning. MaterialX's
        own examples wire a UsdPreviewSurface so (usd_preview_surface_brass_tiled.mtlx: tiledimage nodes in a
        node graph): they were drawn in the inputs' defaults, as from an unsupported shader."""
        from .materialx import read_node_input  # that module imports this one

        value, texture, notes = read_node_input(self, shader, name, getattr(mat, field), mat.path)
        if notes:
            self.skip(f"material {mat.path}: {name} is drawn approximately: {'; '.join(notes)}", shader.GetPrim())
        if isinstance(texture, TextureInput):
            mat.textures[name] = texture
        else:
            self._set_constant(mat, name, field, is_color, value, shader.GetPrim())

    def color_primvar_input(self, reader, material_path: str) -> PrimvarInput:
        """The :class:`PrimvarInput` of ``reader`` (a shader of :data:`COLOR_PRIMVAR_READERS`). One that names no
        primvar (an empty name: Sdr's and the nodedefs' default) has ``name`` ``""``, with a warning: Storm's primvar
        redirect reads none then and gives the reader's fallback, which the caller takes as the input's constant (the
        input kept the surface's own constant)."""
        name_input, fallback_input = COLOR_PRIMVAR_READERS[reader.GetShaderId()]
        varname = self.primvar_name(reader, name_input, material_path).strip()
        fallback = _rgb(self._constant(reader, fallback_input))
        if fallback is not None and reader.GetShaderId().startswith(COLOR_READER_PREFIXES):
            # A colour in the reader's nodedef: decoded from its colorSpace (an srgb_texture 0.5 was read as 0.5);
            # a vector reader's (and UsdPrimvarReader_float3's, a float3 in Sdr) is data.
            fallback = self._decoded_color(reader, fallback_input, fallback, material_path)
        fallback = np.zeros(3, np.float32) if fallback is None else fallback.astype(np.float32)
        if not varname:
            self.skip(f"material {material_path}: a primvar reader names no primvar; its fallback is the input's "
                      "value, as Storm reads it", reader.GetPrim(), detail=f"{name_input} is empty")
        return PrimvarInput(varname, fallback)

    def primvar_name(self, reader, key: str, material_path: str) -> str:
        """The primvar name input ``key`` (``varname``, ``geomprop``) of primvar reader ``reader`` gives: its value (a
        token or a string, or an interface input's), or that of the MaterialX ``constant`` or ``dot`` string nodes
        feeding it (:func:`wrt.materialx.token_input`); ``""`` where it has none, or, with a warning, where another
        node feeds it. A name fed by a constant node was read as none: the reader's fallback on every point, said to
        be unauthored."""
        from .materialx import token_input  # that module imports this one

        name, notes = token_input(self, reader, key, "", material_path)
        for note in notes:
            self.skip(f"material {material_path}: {note}", reader.GetPrim())
        return name

    def _read_normal_map(self, shader, mat: Material):
        """``normal``: a ``UsdUVTexture``'s ``rgb`` output is a tangent-space normal map, used as its ``scale`` and
        ``bias`` make it (the specification's ``(2, 2, 2, 1)`` and ``(-1, -1, -1, 0)`` for a map stored in [0, 1]).
        A constant is ignored, as Storm ignores it; one other than the fallback (0, 0, 1) is reported, as is any
        other source. A map that cannot be read leaves the normals unchanged (its file is reported)."""
        found = self._producer(shader, "normal")
        if found is None:
            return
        if found[0] == "value":
            value = _rgb(found[1])
            if value is None or not np.allclose(value, (0.0, 0.0, 1.0)):
                self.skip(f"material {mat.path}: a constant normal is ignored (only a normal map perturbs normals)",
                          shader.GetPrim(), detail=str(found[1]))
            return
        source, output = found[1], found[2]
        if (source.GetShaderId() or "") not in UV_TEXTURE_IDS or output not in ("rgb", "rgba"):
            self.skip(f"material {mat.path}: normal is connected to {source.GetShaderId() or 'a shader'}'s {output} "
                      "output, not a UsdUVTexture's rgb; it is ignored", source.GetPrim())
            return
        tex, _ = self._texture(source, output, mat.path)
        if tex is not None:
            # MaterialX's UsdPreviewSurface graph feeds normal * 0.5 + 0.5 to a normalmap node, whose tangent is the
            # geometry's (Tworld, of the mesh's st), not that of the texture's coordinates after its UsdTransform2d.
            tex.mesh_frame = (shader.GetShaderId() or "") != "UsdPreviewSurface"
            note = mesh_frame_note(tex)
            if note is not None:
                self.skip(f"material {mat.path}: {note}", source.GetPrim())
            mat.textures["normal"] = tex

    def _set_constant(self, mat: Material, name: str, field: str, is_color: bool, value, prim):
        """Sets ``mat.field`` from input ``name``'s ``value``, authored on ``prim``; a value that is empty or not
        finite (or of a wrong type) keeps the field's default, with a warning: NaN would reach every pixel the material
        covers."""
        # A string of digits is no number, nor is a string[] of them: numpy would read "0.7" as 0.7.
        v = constant_numbers(value)
        # A bool is a number to numpy alone: a bool emissiveColor was read as grey 1; bool fields (thin_walled) take it.
        v = np.empty(0) if v is None or (bool_typed(value) and not isinstance(getattr(mat, field), bool)) else v
        # A colour is 1 (grey), 3 or 4 (rgba) numbers, anything else 1: a float2 colour was read as the grey of its
        # first number, an array of colours as its first, a matrix as its first entry, without a word.
        # Finite in float32 too, which the device reads: a double ior of 1e300 stopped the render (Material's check).
        sizes = (1, 3, 4) if is_color else (1,)
        if v.size not in sizes or not np.all(np.abs(v) <= np.finfo(np.float32).max):
            self.skip(f"material {mat.path}: an input is {refused_constant(value, sizes)}; its default is used", prim,
                      detail=name)
            return
        if is_color:
            setattr(mat, field, np.resize(v, 3).astype(np.float32) if v.size >= 3 else np.full(3, v[0], np.float32))
        else:
            setattr(mat, field, type(getattr(mat, field))(v[0]))  # the field's own type: float, or bool

    def _texture(self, tex, output: str, material_path: str):
        """A :class:`TextureInput` for ``UsdUVTexture`` ``tex`` read through ``output``, or ``(None, fallback)``
        when its image cannot be read: the ``fallback`` input times ``scale`` plus ``bias``, the value of output
        ``output``. The specification reads the fallback "if the texture cannot be read", in place of the texture's
        value, to which scale and bias apply; MaterialX's UsdUVTexture graph makes it the image node's default,
        multiplied and added to as every texel. It was used as it is, so a normal map (scale 2, bias -1) with a
        fallback of (0.5, 0.5, 1) was no flat normal."""
        if output not in CHANNELS:  # ("result", "out": no output of UsdUVTexture) was read as rgb without a word
            self.skip(f"material {material_path}: a UsdUVTexture output is none of r, g, b, a, rgb or rgba; it is "
                      "read as rgb", tex.GetPrim(), detail=output)
        channel = output if output in CHANNELS else "rgb"
        channel = "rgb" if channel == "rgba" else channel
        materialx = (tex.GetShaderId() or "") != "UsdUVTexture"
        fallback, scale, bias = (self._texture_vector(tex, name, default, material_path, materialx)
                                 for name, default in (("fallback", TEXTURE_FALLBACK), ("scale", (1.0, 1.0, 1.0, 1.0)),
                                                       ("bias", (0.0, 0.0, 0.0, 0.0))))
        with np.errstate(over="ignore", invalid="ignore"):  # a value past float32 is refused by _set_constant
            value = fallback * scale + bias
        fallback_value = channel_value(value.astype(np.float32), channel)

        # MaterialX's textures are raw where nothing says otherwise, as Storm hands them over (its default working
        # colour space is none); an 8-bit colour file was decoded as sRGB (UsdUVTexture's auto).
        color_space = str(self._constant(tex, "sourceColorSpace") or ("raw" if materialx else "auto"))
        file_space = None
        if materialx:  # the file's colorSpace, as MaterialX's image nodes, else sourceColorSpace as UsdUVTexture's
            from .color_spaces import file_color_space

            # MaterialX's nodedef has no sourceColorSpace; one authored is what the writer meant for this texture
            # (converters carry UsdUVTexture's over), so it is read as UsdUVTexture's where the file has no
            # colorSpace: a raw mask written so was decoded as sRGB (auto).
            file_space, note = file_color_space(tex.GetInput("file"))
            if note is not None:
                self.skip(f"material {material_path}: {note}", tex.GetPrim())
            if file_space is not None:  # a colorSpace is authored on the file (its transfer function is known)
                color_space = file_space
        if color_space not in ("auto", "sRGB", "raw") and file_space is None:
            # "linear" or "srgb" (tokens are case-sensitive) were read as auto without a word: an 8-bit map meant
            # linear was decoded as sRGB, 0.5 read as 0.21.
            self.skip(f"material {material_path}: sourceColorSpace is not one of auto, sRGB or raw; it is read as "
                      "auto", tex.GetPrim(), detail=color_space)
            color_space = "auto"
        if not materialx:
            self._note_unread_file_color_space(tex, material_path, color_space)
        image, tiles = self.file_images(tex, color_space, material_path)
        if image < 0:
            return None, fallback_value

        wrap_mode = self._materialx_wrap_mode if materialx else self._wrap_mode
        wraps = [wrap_mode(tex, key, material_path) for key in ("wrapS", "wrapT")]
        uv_set, transform, st_fallback = self._st_source(tex, material_path)
        if not np.all(np.isfinite(transform)):  # finite inputs whose product passes float32's range
            self.skip(f"material {material_path}: a texture's UsdTransform2d maps st past float32's range; the "
                      "texture's fallback value is used", tex.GetPrim())
            return None, fallback_value
        return (
            TextureInput(
                image=image,
                channel=channel,
                wrap=(wraps[0], wraps[1]),
                scale=scale,
                bias=bias,
                transform=transform,
                uv_set=uv_set,
                st_fallback=st_fallback,
                tiles=tiles,
                fallback=fallback,
            ),
            fallback_value,
        )

    def _texture_vector(self, tex, name: str, default: tuple, material_path: str,
                        materialx: bool = False) -> np.ndarray:
        """UsdUVTexture ``tex``'s ``scale``, ``bias`` or ``fallback`` (``name``) as its four RGBA float32 numbers
        (:func:`four_components`): ``default`` (the schema's) when unauthored, or when it is not 1, 3 or 4 finite
        numbers (:meth:`_finite_numbers`). An infinite scale made the albedo infinite and a NaN bias black, without a
        word; a float2 was stretched to four numbers; a string stopped the load with "cannot read this prim".
        MaterialX's ``ND_UsdUVTexture`` (``materialx``) declares the three ``color4``, so one authored with a
        ``colorSpace`` is decoded from it (alpha kept), as MaterialX transforms a value bound to a colour input;
        they were read as authored."""
        v = self._finite_numbers(tex, name, (1, 3, 4), "a UsdUVTexture scale, bias or fallback is not 1, 3 or 4 "
                                 "finite numbers", material_path)
        value = four_components(v, default)
        if materialx and v is not None:
            decoded = self._decoded_color(tex, name, value.astype(np.float64), material_path)
            return four_components(None, default) if decoded is None else decoded.astype(np.float32)
        if v is not None:
            self._note_unread_color_space(tex, name, material_path)
        return value

    def _decoded_color(self, node, name: str, value: np.ndarray, material_path: str) -> np.ndarray | None:
        """Colour constant ``value`` (float64, 3 or 4 numbers, alpha kept) of input ``name`` of shader ``node``
        in linear Rec.709 from its colour space (:func:`wrt.color_spaces.decoded_color`, as MaterialX's constants),
        its note (a colour space wrt does not know) given; None, named in a warning, where
        the decode passes float32's range (1e20 in sRGB), for the caller to keep its default."""
        from .color_spaces import decoded_color

        what = f"{node.GetPath()}'s {name}"
        decoded, note = decoded_color(node.GetInput(name), value, what, color=True)
        if note is not None:
            self.skip(f"material {material_path}: {note}", node.GetPrim())
        if decoded is None:
            self.skip(f"material {material_path}: {what} decoded from its colour space is past float32's range; its "
                      "default is used", node.GetPrim())
        return decoded

    def _note_unread_color_space(self, tex, name: str, material_path: str) -> None:
        """Names the colour space (its own, or of the interface input it reads) that a UsdUVTexture's ``fallback``,
        ``scale`` or ``bias`` (``name``) carries: they are ``float4`` in its Sdr definition, no colours, so their
        numbers are read as authored (a scale or bias is applied to decoded texels). It was left out without a word.
        A linear Rec.709 or data space, which reads alike, is not named."""
        from .color_spaces import attribute_color_space, input_attrs, reads_as_stored

        space = attribute_color_space(input_attrs(tex.GetInput(name)))[0]
        if space and not reads_as_stored(space):
            self.skip(f"material {material_path}: a UsdUVTexture's fallback, scale and bias are float4 in its "
                      "definition, no colours: they are read as authored, the colour space they carry is not read",
                      tex.GetPrim(), detail=f"{name} in {space!r}")

    def _finite_numbers(self, node, name: str, sizes: tuple, problem: str, material_path: str) -> np.ndarray | None:
        """Input ``name`` of shader ``node`` as float64 numbers; None when it is unauthored, and, with a warning
        (``problem``), when it is not a count in ``sizes`` of finite float32 numbers: as a UsdPreviewSurface input,
        it keeps its default then."""
        value = self._constant(node, name)
        if value is None:
            return None
        try:
            v = np.asarray(value)
            v = v.reshape(-1).astype(np.float64) if v.dtype.kind in "biuf" else np.empty(0)
        except (TypeError, ValueError):  # a string, ...
            v = np.empty(0)
        if v.size not in sizes or not np.all(np.abs(v) <= np.finfo(np.float32).max):  # NaN fails too
            self.skip(f"material {material_path}: {problem}; its default is used", node.GetPrim(),
                      detail=f"{name} = {value}")
            return None
        return v

    def _wrap_mode(self, tex, key: str, material_path: str) -> str:
        """``wrapS`` or ``wrapT`` (``key``) of UsdUVTexture ``tex`` as a :data:`WRAP_MODES` token. ``useMetadata``, the
        fallback, asks for the image file's own wrap metadata, which wrt does not read; without it the specification
        and Storm give ``black`` (a border of transparent black), so that is what it reads as. It was read as
        ``repeat``: a quad whose ``st`` run to 2 showed the image four times where usdview shows it once, in a corner
        of black. A token that is none of these is named in a warning and read as ``useMetadata``, as Storm does."""
        token = self._constant(tex, key)
        token = "useMetadata" if token is None else str(token)
        if token in WRAP_MODES and token != "fallback":  # (wrt's mode for MaterialX's constant: no UsdUVTexture token)
            return token
        if token != "useMetadata":
            self.skip(f"material {material_path}: {key} is not one of black, clamp, repeat, mirror or useMetadata; "
                      "it is read as useMetadata (black outside the image)", tex.GetPrim(), detail=token)
        return "black"

    def _materialx_wrap_mode(self, tex, key: str, material_path: str) -> str:
        """``wrapS`` or ``wrapT`` (``key``) of MaterialX's ``ND_UsdUVTexture`` ``tex`` as a :data:`WRAP_MODES` token
        (:data:`MATERIALX_WRAPS`; unauthored: ``periodic``), also from ``constant`` or ``dot`` string nodes
        (:func:`wrt.materialx.token_input`, as an image node's address modes; such a node's token was read as
        unauthored, ``periodic``, without a word); another token is named in a warning and read as ``periodic``."""
        from .materialx import token_input  # that module imports this one

        token, notes = token_input(self, tex, key, "periodic", material_path)
        for note in notes:
            self.skip(f"material {material_path}: {note}", tex.GetPrim())
        if token not in MATERIALX_WRAPS:
            self.skip(f"material {material_path}: {key} is not one of black, clamp, periodic or mirror; it is read as "
                      "periodic", tex.GetPrim(), detail=token)
        return MATERIALX_WRAPS.get(token, "repeat")

    def _st_source(self, tex, material_path: str) -> tuple[str | None, np.ndarray, np.ndarray]:
        """The primvar feeding ``tex``'s ``st``, the ``UsdTransform2d`` applied on the way (identity if none) and the
        primvar reader's ``fallback`` (``(2,)``, zero when unauthored, as in the schema). A shader other than those two
        on the way (a projection, a MaterialX node) is reported, and ``st`` read.

        An ``st`` (or a UsdTransform2d's ``in``) authored as a constant and connected to nothing is read there: the
        primvar is None and the transform maps every point to that constant, transformed. An ``st`` neither connected
        nor authored reads the mesh's ``st`` primvar, as MaterialX defines the node (``defaultgeomprop="UV0"``) and as
        assets leave it (the usd-wg Mini Car Kit), not the schema's fallback (0, 0). A UsdTransform2d's ``in``
        neither connected nor authored is Sdr's default, (0, 0), as Storm and MaterialX's ``ND_UsdTransform2d`` (no
        ``defaultgeomprop``) read it, with a warning: the texture shows one point. So does a primvar reader whose
        ``varname`` is empty or unauthored (Sdr's default ``""`` names no primvar): its ``fallback``, as Storm reads
        it."""
        transform = np.eye(3, dtype=np.float32)
        no_fallback = np.zeros(2, np.float32)
        found, node, name = self._producer(tex, "st"), tex, "st"
        passed = set()  # the transforms on the way: a chain that loops back (in fed by its own result) ends there
        while True:
            if found is not None and found[0] == "shader" and found[1].GetPrim().GetPath() in passed:
                # It went round a fixed number of times without a word: a rotation of 30 degrees drew 240.
                self.skip(f"material {material_path}: a texture's st comes through UsdTransform2d nodes that loop "
                          "back on themselves; each is applied once and the st primvar read", tex.GetPrim(),
                          detail=str(found[1].GetPrim().GetPath()))
                return "st", transform, no_fallback
            if found is not None and found[0] == "value":
                st = self._constant_st(found[1], node, name, material_path)
                if st is not None:
                    return None, constant_st_transform(transform, st), no_fallback
                return "st", transform, no_fallback
            if found is None or found[0] != "shader":
                return "st", transform, no_fallback
            node = found[1]
            node_id = node.GetShaderId() or ""
            if node_id.startswith(ST_READER_PREFIXES):
                varname = self.primvar_name(node, "varname", material_path)
                fallback = self._st_fallback(node, material_path)
                if not varname:
                    # Sdr's varname is "" (names no primvar): Storm's primvar redirect reads nothing and gives the
                    # fallback; wrt read the mesh's st without a word.
                    self.skip(f"material {material_path}: a texture-coordinate reader names no primvar (its varname is "
                              "empty or unauthored); its fallback st is read at every point, as Storm reads it",
                              node.GetPrim(), detail=f"fallback ({fallback[0]:g}, {fallback[1]:g})")
                    return None, constant_st_transform(transform, fallback), no_fallback
                return str(varname), transform, fallback
            if node_id == "ND_texcoord_vector2":  # MaterialX's UV0, USD's st
                index = self._constant(node, "index")
                if index not in (None, 0):
                    self.skip(f"material {material_path}: a texcoord node's index other than 0 is read as primvar st",
                              node.GetPrim(), detail=f"index = {index}")
                return "st", transform, no_fallback
            if node_id == "ND_geompropvalue_vector2":  # MaterialX's primvar reader: geomprop, default
                geomprop = self.primvar_name(node, "geomprop", material_path)
                fallback = self._st_fallback(node, material_path, "default")
                if not geomprop:  # names no primvar, as an empty varname (above)
                    self.skip(f"material {material_path}: a texture-coordinate reader names no primvar (its geomprop "
                              "is empty or unauthored); its default st is read at every point", node.GetPrim(),
                              detail=f"default ({fallback[0]:g}, {fallback[1]:g})")
                    return None, constant_st_transform(transform, fallback), no_fallback
                return str(geomprop), transform, fallback
            if node_id in TRANSFORM2D_IDS:
                passed.add(node.GetPrim().GetPath())
                with np.errstate(over="ignore", invalid="ignore"):  # past float32: inf, named by _texture
                    transform = transform @ self.transform2d_map(node, material_path)
                found, name = self._producer(node, "in"), "in"
                if found is None:
                    # Storm's material network reads an unconnected in's authored value, else Sdr's default (0, 0),
                    # never a primvar; wrt read the mesh's st.
                    self.skip(f"material {material_path}: a UsdTransform2d's in that is neither connected nor authored "
                              "reads (0, 0), its default in Sdr, as Storm reads it: its texture shows one point",
                              node.GetPrim())
                    return None, constant_st_transform(transform, (0.0, 0.0)), no_fallback
                continue
            mapped = self._materialx_texcoord_map(tex, node, material_path)
            if mapped is not None:
                passed.add(node.GetPrim().GetPath())
                with np.errstate(over="ignore", invalid="ignore"):  # past float32: inf, named by _texture
                    transform = (transform @ mapped[0]).astype(np.float32)
                found, name = mapped[1], "texcoord"
                continue
            self.skip("texture coordinates from shaders other than UsdPrimvarReader_float2 and UsdTransform2d are "
                      "not supported; these materials' textures read the st primvar", tex.GetPrim(),
                      detail=f"{material_path}: {node_id or 'no info:id'}")
            return "st", transform, no_fallback

    def _materialx_texcoord_map(self, tex, node, material_path: str) -> tuple | None:
        """``(map, source)`` of MaterialX's ``place2d`` or vector2 math node ``node`` between MaterialX's
        UsdUVTexture ``tex`` and its texture coordinates (:func:`wrt.materialx.texcoord_node_map`: its notes in a
        warning), as MaterialX's own UsdPreviewSurface example wires a place2d (usd_preview_normal_map.mtlx); None
        for another node, or for UsdUVTexture itself (Storm's UsdPreviewSurface network evaluates no MaterialX
        node)."""
        if (tex.GetShaderId() or "") == "UsdUVTexture":
            return None
        from .materialx import texcoord_node_map  # that module imports this one

        mapped = texcoord_node_map(self, node, material_path)
        if mapped is None:
            return None
        if mapped[2]:
            self.skip(f"material {material_path}: a texture's coordinates are moved approximately: "
                      f"{'; '.join(mapped[2])}", tex.GetPrim())
        return mapped[0], mapped[1]

    def transform2d_map(self, node, material_path: str) -> np.ndarray:
        """``(3, 3)`` float32 map of ``UsdTransform2d`` ``node`` (:func:`_transform2d`) from its inputs
        (:meth:`_transform2d_input`); past float32's range it holds inf, which its caller names."""
        rotation, scale, translation = (self._transform2d_input(node, name, default, material_path)
                                        for name, default in TRANSFORM2D_DEFAULTS)
        with np.errstate(over="ignore", invalid="ignore"):
            return _transform2d(rotation[0], scale, translation)

    def _transform2d_input(self, node, name: str, default: tuple, material_path: str) -> np.ndarray:
        """Input ``name`` of ``UsdTransform2d`` ``node`` as ``len(default)`` float64 numbers: ``default`` (the
        schema's) when unauthored, or when it is not that many finite numbers (:meth:`_finite_numbers`: a float for a
        float2, a string, NaN). A wrong type stopped the load with "cannot read this prim", and NaN made every lookup
        read the texture's fallback, without a word."""
        count = "one finite number" if len(default) == 1 else f"{len(default)} finite numbers"
        v = self._finite_numbers(node, name, (len(default),), f"a UsdTransform2d input is not {count}", material_path)
        return np.asarray(default, np.float64) if v is None else v

    def _constant_st(self, value, shader, name: str, material_path: str) -> np.ndarray | None:
        """``(2,)`` float64 constant texture coordinate ``value`` of input ``name`` of ``shader``; None, with a
        warning, when it is not two finite numbers (the mesh's ``st`` is read then)."""
        st = two_finite_numbers(value)
        if st is None:
            self.skip(f"material {material_path}: a constant texture coordinate is not two finite numbers; the st "
                      "primvar is read", shader.GetPrim(), detail=f"{name} = {value}")
        return st

    def _st_fallback(self, reader, material_path: str, name: str = "fallback") -> np.ndarray:
        """``(2,)`` float32 ``fallback`` (``name``: MaterialX's geompropvalue's ``default``) of texture-coordinate
        reader ``reader``: zero when unauthored; one that is not two finite numbers is zero too, with a warning."""
        value = self.st_reader_default(reader, name, material_path)
        if value is None:
            return np.zeros(2, np.float32)
        v = two_finite_numbers(value)
        if v is None:
            self.skip(f"material {material_path}: a texture-coordinate reader's fallback is not two finite numbers; "
                      "(0, 0) is used", reader.GetPrim(), detail=str(value))
            return np.zeros(2, np.float32)
        return v.astype(np.float32)

    def st_reader_default(self, reader, name: str, material_path: str):
        """The value of texture-coordinate reader ``reader``'s ``fallback`` (``name``: a geompropvalue's
        ``default``): its constant, or that of the MaterialX nodes feeding it folded
        (:func:`wrt.materialx.folded_input`: a ``constant`` node, math of constants; a node giving none is named in a
        warning); None where it has none. One fed by a constant node was read as unauthored, (0, 0), without a
        word."""
        found = self._producer(reader, name)
        if found is None or found[0] == "value":
            return None if found is None else found[1]
        from .materialx import folded_input  # that module imports this one

        value, notes = folded_input(self, reader, name, 2, "(0, 0)", material_path)
        for note in notes:
            self.skip(f"material {material_path}: {note}", reader.GetPrim())
        return value

    def _note_unread_file_color_space(self, tex, material_path: str, color_space: str) -> None:
        """Names a ``colorSpace`` on a UsdUVTexture's ``file`` (or the interface input it connects to) as not read:
        Storm decodes a UsdUVTexture by its ``sourceColorSpace`` alone (``auto`` where unauthored; hdSt's
        materialNetwork reads no colour space metadata for it), and so does wrt, so ``sourceColorSpace = raw``
        beside ``colorSpace = "srgb_rec709_scene"`` reads the file raw. Only MaterialX's image nodes (and its
        ``ND_UsdUVTexture``) take the file's colorSpace. It was left out without a word."""
        from .color_spaces import inherited_color_space, input_attrs, own_color_space, reads_as_stored

        file_input = tex.GetInput("file")
        name = own_color_space(input_attrs(file_input))
        if name:
            self.skip(f"material {material_path}: a UsdUVTexture file's colorSpace is not read (Storm reads "
                      f"sourceColorSpace alone); the file is decoded as sourceColorSpace {color_space}",
                      tex.GetPrim(), detail=name)
            return
        inherited = inherited_color_space(file_input.GetAttr())[0] if file_input else ""
        if inherited and not reads_as_stored(inherited):  # from UsdColorSpaceAPI on an ancestor: not read either
            self.skip(f"material {material_path}: a UsdUVTexture file's colour space inherited through "
                      "UsdColorSpaceAPI is not read (Storm reads sourceColorSpace alone); the file is decoded as "
                      f"sourceColorSpace {color_space}", tex.GetPrim(), detail=inherited)

    def file_images(self, shader, color_space: str, material_path: str, name: str = "file", layout: str = "preview"):
        """``(image, tiles)`` of the image file named by input ``name`` of ``shader`` (a UsdUVTexture or a MaterialX
        image node) in :attr:`textures`, its texels laid out as ``layout`` (:meth:`_load`) reads them: ``image`` is
        -1 (with a warning) when nothing can be read. ``tiles`` is None, or for a ``<UDIM>`` file the
        :attr:`TextureInput.tiles` table, ``image`` being its first tile; a read being kept records the call
        (:class:`wrt.usd_material_memo.FileLookup`)."""
        if self.lookups is None:
            return self._file_images(shader, color_space, material_path, name, layout)
        from .usd_material_memo import FileLookup

        start = len(self.skipped)
        image, tiles = self._file_images(shader, color_space, material_path, name, layout)
        self.lookups.append(FileLookup((shader, color_space, material_path, name, layout), (start, len(self.skipped)),
                                       image, tiles, self.pixels_of(image, tiles)))
        return image, tiles

    def pixels_of(self, image: int, tiles) -> tuple:
        """The images (read-only pixel arrays) ``image`` and the UDIM ``tiles`` found index in :attr:`textures`."""
        found = [image] + ([] if tiles is None else [int(k) for k in tiles if k >= 0])
        return tuple(self.textures[k] for k in found if k >= 0)

    def mark(self) -> tuple:
        """Where the images, textures and warnings of this reader stand: :meth:`rewind` forgets what came after."""
        return len(self.textures), len(self.skipped), len(self._images), len(self._udim)

    def rewind(self, mark: tuple) -> None:
        """Forgets the textures, warnings and looked-up files added since :meth:`mark` gave ``mark`` (the dicts keep
        their insertion order: what came after is their tail)."""
        textures, skipped, images, udim = mark
        del self.textures[textures:], self.texture_paths[textures:], self.skipped[skipped:]
        for cache, size in ((self._images, images), (self._udim, udim)):
            for key in list(cache)[size:]:
                del cache[key]
                if key[:2] not in self._images:  # (a MaterialX read's problems are told under its file's key)
                    self._file_problems.pop(key[:2], None)
                self._udim_files.pop(key, None)

    def _file_images(self, shader, color_space: str, material_path: str, name: str, layout: str):
        asset = self._constant(shader, name)
        if isinstance(asset, str) and asset:
            asset = self._string_asset(shader, name, asset)
        authored = getattr(asset, "path", "") or ""
        if "<UDIM>" not in authored:
            layer = None
            if authored and not getattr(asset, "resolvedPath", ""):  # not found: where it was looked for is told
                layer = _authoring_layer(_source_attribute(shader, name), self.time)
            return self._image(asset, color_space, shader.GetPrim(), layout, layer), None
        tiles = self._udim_tiles(_source_attribute(shader, name), authored, color_space, shader.GetPrim(),
                                 material_path, layout)
        found = tiles[tiles >= 0]
        return (int(found[0]) if len(found) else -1), tiles

    def _string_asset(self, shader, name: str, text: str):
        """An image file input ``name`` of ``shader`` authored as a string or token ``text`` rather than an asset, as
        the ``Sdf.AssetPath`` it names, resolved against the layer that authored it (its resolved path empty where
        there is no such file), with a warning naming the prim. Storm takes a string ``file`` as the path to open;
        it was reported as a file that was not found, the fallback drawn, though the file was there."""
        self.skip("image files authored as a string rather than an asset were resolved as asset paths",
                  shader.GetPrim(), detail=f"{name} = {text!r}")
        return asset_in_layer(text, _authoring_layer(_source_attribute(shader, name), self.time))

    def _udim_tiles(self, attr, authored: str, color_space: str, prim, material_path: str,
                    layout: str) -> np.ndarray:
        """``(UDIM_TILES,)`` int32 images of the tiles of UDIM pattern ``authored`` (-1: no such file), found as
        ``UsdShade.UdimUtils`` resolves them: relative to the layer that authored ``attr``'s value (also inside a
        ``.usdz``), tiles 1001 to 1100, their texels laid out as ``layout`` (:meth:`_load`). No tile at all is reported
        once per pattern, naming ``material_path``."""
        from pxr import UsdShade

        layer = _authoring_layer(attr, self.time)
        key = (authored, layer.identifier if layer else "", color_space, layout)
        if key not in self._udim:
            tiles = np.full(UDIM_TILES, -1, np.int32)
            files = []
            for resolved, tile in UsdShade.UdimUtils.ResolveUdimTilePaths(authored, layer) if layer else []:
                row = int(tile) - UDIM_FIRST
                if 0 <= row < UDIM_TILES:
                    tiles[row] = self._load(resolved, resolved, color_space, prim, layout)
                    files.append((resolved, color_space))
            self._udim[key] = tiles
            self._udim_files[key] = files
        else:  # a tile that could not be read is told for each shader that reads the pattern, not the first only
            for file_key in self._udim_files[key]:
                self._tell_file_problem(file_key, prim)
        if not np.any(self._udim[key] >= 0):  # told for each material that reads the pattern, not the first only
            self.skip(f"material {material_path}: texture {_where(authored, layer)}: no UDIM tile ({UDIM_FIRST} to "
                      f"{UDIM_FIRST + UDIM_TILES - 1}) was found; the texture's fallback value is used", prim)
        return self._udim[key]

    def _image(self, asset, color_space: str, prim, layout: str, layer=None) -> int:
        """Index of the image behind ``asset`` (an ``Sdf.AssetPath``) in :attr:`textures` (laid out as ``layout``:
        :meth:`_load`); -1 (with a warning) when it cannot be read. A file not found is named where it was looked
        for, anchored to ``layer``, the layer that authored it (:func:`_where`)."""
        from pxr import Sdf

        if asset is None:  # no file authored (or one fed by a node): the fallback, as for a file not found
            self.skip("a texture names no file (its file input has no value); the texture's fallback value is used",
                      prim)
            return -1
        if isinstance(asset, Sdf.AssetPath) and not asset.path:  # @@: it was "texture @@: the file was not found"
            self.skip("a texture names no file (its file input is the empty asset path @@); the texture's fallback "
                      "value is used", prim)
            return -1
        resolved = getattr(asset, "resolvedPath", "") or ""
        authored = getattr(asset, "path", "") or str(asset)
        if resolved:
            return self._load(resolved, authored, color_space, prim, layout)
        key = (_anchored(authored, layer), color_space)  # one relative path authored in two layers: two files
        if key not in self._images:
            self._images[key] = -1
            self._file_problems[key] = (f"texture {_where(authored, layer)}: the file was not found; the texture's "
                                        "fallback value is used", None)
        self._tell_file_problem(key, prim)
        return self._images[key]

    def _load(self, resolved: str, authored: str, color_space: str, prim, layout: str) -> int:
        """Index of the image at ``resolved`` in :attr:`textures`, read on first use, its texels laid out as
        ``layout`` reads them: ``preview`` as :func:`wrt.textures.load_image` decodes them (UsdUVTexture's
        channels: grey repeated into r, g and b, two channels grey + alpha), ``materialx`` as a MaterialX image node
        takes the file's channels (:func:`wrt.textures.materialx_texels`; the same image for a colour file, and one
        read of the file for both); -1 (with a warning naming ``authored``) when it cannot be read."""
        file_key = (resolved, color_space)
        key = file_key if layout == "preview" else file_key + (layout,)
        if key not in self._images:
            told = []  # what the read warned of (TextureWarning words): told with each shader, as problems are
            try:
                pixels, channels = self._file_pixels(resolved, color_space, told.append)
            except TextureError as e:
                self._file_problems[file_key] = (f"texture {authored}: {e}; the texture's fallback value is used",
                                                 None)
                self._images[key] = -1
            else:
                texels = self._laid_out(file_key, pixels, channels, layout)
                self._images[key] = self._texture_index(texels, file_key)
                unpacked = _unpacked_texels(texels, resolved) if self._images[key] == len(self.textures) - 1 else ""
                if unpacked:  # pack_images stores float16: they were changed without a word
                    self._file_problems[file_key] = (f"texture {authored}: texels that are NaN or infinite were "
                                                     "changed (NaN read as 0, infinite ones as the image's largest "
                                                     "stored value)", unpacked)
            if told:
                self._file_notes[file_key] = [f"texture {authored}: {words}" for words in dict.fromkeys(told)]
        self._tell_file_problem(file_key, prim)
        return self._images[key]

    def _file_pixels(self, resolved: str, color_space: str, warn=None) -> tuple[np.ndarray, tuple[int, ...]]:
        """:func:`wrt.textures.read_image` of the file: the pixels of a read of it already in :attr:`textures` (a
        MaterialX read of a colour file is its pixels), else decoded, through the memo where there is one (its
        pixels kept while the file keeps its stamp, and their channels beside them); ``warn``: ``read_image``'s."""
        file_key = (resolved, color_space)
        channels = self._channels.get(file_key)
        if channels is not None:
            for key, same in ((file_key, True), (file_key + ("materialx",), reads_in_place(channels))):
                if same and self._images.get(key, -1) >= 0:
                    return self.textures[self._images[key]], channels
        if self.memo is None:
            pixels, channels = read_image(resolved, color_space, warn)
        else:
            decoded, told = [], []

            def tell(words):  # (told at once: a read that fails tells what it warned of too)
                told.append(words)
                if warn is not None:
                    warn(words)

            def load(path, space):
                pixels, channels = read_image(path, space, tell)
                decoded.append(channels)
                return pixels

            pixels = self.memo.image(resolved, color_space, load)
            # What the read warned of, kept with the pixels (as LightTextures keeps it): a later load that takes the
            # kept pixels (a frame of StageFrames) tells it, as a fresh load does. It was told at the first alone.
            notes = self.memo.derived(resolved, color_space, pixels, "notes", lambda: np.array(told, dtype=object))
            for words in notes if warn is not None and not decoded else ():
                warn(words)
            # Kept pixels decoded by a light (wrt.usd_lights.LightTextures) have no channels kept: read again.
            kept = self.memo.derived(resolved, color_space, pixels, "channels", lambda: np.array(
                decoded[0] if decoded else read_image(resolved, color_space, warn)[1]))
            channels = tuple(int(c) for c in kept)
        self._channels[file_key] = channels
        return pixels, channels

    def _laid_out(self, file_key: tuple[str, str], pixels: np.ndarray, channels: tuple, layout: str) -> np.ndarray:
        """A file's ``pixels`` laid out as ``layout`` reads them (:func:`wrt.textures.preview_texels`,
        :func:`wrt.textures.materialx_texels`), kept with them by the memo (a kept material's replay finds the same
        array); ``pixels`` themselves where they lie so. Colour space ``sRGB`` (``srgb_texture``) and the ``gamma``
        ones decode the alpha that a grey + alpha file lays into a colour channel too; ``auto`` decodes only what
        :func:`read_image` decoded. A colour space of other primaries (``raw in lin_ap1_scene``) converts the colour
        laid out, as MaterialX transforms the image node's output."""
        transfer, primaries = split_color_space(file_key[1])
        if layout == "preview":
            def make():
                return preview_texels(pixels, channels, primaries)
        else:
            def make():
                return materialx_texels(pixels, channels, decode_curve(transfer), primaries)
        if self.memo is None or reads_in_place(channels) or (layout == "preview" and primaries is None):
            return make()
        return self.memo.derived(*file_key, pixels, layout, make)

    def _texture_index(self, texels: np.ndarray, file_key: tuple[str, str]) -> int:
        """Index of ``texels`` (of the file of ``file_key``) in :attr:`textures`: the one a read of the file in the
        other layout put there where it is the same array, else ``texels`` added at the end."""
        for key in (file_key, file_key + ("materialx",)):
            k = self._images.get(key, -1)
            if k >= 0 and self.textures[k] is texels:
                return k
        self.textures.append(texels)
        self.texture_paths.append(file_key[0])
        return len(self.textures) - 1

    def _tell_file_problem(self, key: tuple[str, str], prim) -> None:
        """Warns, naming shader ``prim``, of what the read of the file of ``key`` found wrong, if anything: at each
        lookup, so that every shader naming a file that cannot be read is named (the first one only was, and the
        other looks drew their fallback without a word)."""
        problem = self._file_problems.get(key)
        if problem is not None:
            self.skip(problem[0], prim, problem[1])
        for note in self._file_notes.get(key, ()):
            self.skip(note, prim)


# Files whose decoded texels lie in [0, 1] (8- or 16-bit integers): not scanned (a 4k texture at every kept frame).
_BOUNDED_FORMATS = (".png", ".jpg", ".jpeg", ".bmp", ".gif", ".tga", ".webp")


def _unpacked_texels(pixels: np.ndarray, resolved: str) -> str:
    """How many values of ``pixels`` (read from file ``resolved``) :func:`wrt.textures.pack_images` cannot store as
    they are, NaN and infinite ones ("" for none): finite ones fit, each image scaled by a power of two."""
    if np.asarray(pixels).dtype.kind != "f" or resolved.lower().rstrip("]").endswith(_BOUNDED_FORMATS):
        return ""
    if math.isfinite(float(pixels.max()) - float(pixels.min())):  # (not for a NaN or inf): two passes, no temporaries
        return ""
    nan, infinite = int(np.isnan(pixels).sum()), int(np.isinf(pixels).sum())
    found = [f"{n} {what}" for what, n in (("NaN", nan), ("infinite", infinite)) if n]
    return f"{', '.join(found)} of {np.size(pixels)} values" if found else ""


def wholly_cut_out(mat: Material) -> bool:
    """``mat`` is a hole everywhere (:func:`cut_out` true at every ``st``): a positive ``opacityThreshold`` above its
    constant ``opacity`` (clamped to [0, 1]; in float32, as the device compares them), with no texture on opacity."""
    threshold = np.float32(mat.opacity_threshold)
    return bool("opacity" not in mat.textures and threshold > 0.0
                and np.clip(np.float32(mat.opacity), np.float32(0.0), np.float32(1.0)) < threshold)


def emission_estimates(materials: list[Material], textures: list[np.ndarray]) -> list[np.ndarray]:
    """Per device material (``[default] + materials``) a ``(3,)`` estimate of its emitted radiance
    (:func:`emission_estimate`). Used to find and weigh light sources."""
    return [np.zeros(3, np.float32)] + [emission_estimate(mat, textures) for mat in materials]


def emission_estimate(mat: Material, textures: list[np.ndarray]) -> np.ndarray:
    """``(3,)`` float32 estimate of the radiance ``mat`` emits, clamped to 0: the constant ``emissiveColor``, or the
    mean of its texture's emission (each texel after scale and bias, clamped to 0 as the device reads it;
    ``textures``: the scene's images). Zero where nothing is emitted."""
    tex = mat.textures.get("emissiveColor")
    if tex is None:
        return np.maximum(np.asarray(mat.emissive_color, np.float32), 0.0)
    # A UDIM texture: the mean of its tiles' means (each tile covers a unit square of st); without tiles its
    # fallback everywhere.
    return _texture_glow(tex, [tex.image] if tex.tiles is None else [k for k in tex.tiles if k >= 0], textures)


def tile_emission_estimates(mat: Material, textures: list[np.ndarray]) -> np.ndarray | None:
    """``(UDIM_TILES, 3)`` float32: per UDIM tile of ``mat``'s emission texture the :func:`emission_estimate` of
    that tile's image alone (the mean of its texels' emission), 0 for a tile without a file (where the texture's
    fallback stands in, :func:`wrt.sampled_emission.may_read_fallback`); None where ``mat`` has no UDIM texture on
    ``emissiveColor``."""
    tex = mat.textures.get("emissiveColor")
    if tex is None or tex.tiles is None:
        return None
    glow = np.zeros((UDIM_TILES, 3), np.float32)
    for tile, k in enumerate(tex.tiles):
        if k >= 0:
            glow[tile] = _texture_glow(tex, [int(k)], textures)
    return glow


def _texture_glow(tex: TextureInput, images: list[int], textures: list[np.ndarray]) -> np.ndarray:
    """``(3,)`` float32, at least 0: the mean over ``images`` (of ``textures``) of the emission texture ``tex``
    returns on their texels (its fallback where there are none), for :func:`emission_estimate`."""
    scale, bias = np.asarray(tex.scale, np.float64), np.asarray(tex.bias, np.float64)
    if not images:
        mean = np.asarray(tex.fallback, np.float64) * scale + bias
    elif np.all(scale >= 0.0) and np.all(bias >= 0.0) and all(_stored_as_is(textures[k]) for k in images):
        mean = np.mean([textures[k].reshape(-1, 4).mean(axis=0) for k in images], axis=0) * scale + bias
    else:  # some texels emit less than nothing, read as 0 (a contrast stretch, bias < 0, of a mask still glows), or
        # are stored otherwise (NaN as 0, inf as the largest stored: a NaN or infinite mean made the emitter no light,
        # or the only one sampled), or are past 65504 (stored scaled, summed in float64)
        mean = np.mean([_glow_mean(textures[k], scale, bias) for k in images], axis=0)
    return np.maximum(channel_value(mean, tex.channel).astype(np.float32), 0.0)


def channel_value(value: np.ndarray, channel: str) -> np.ndarray:
    """``(3,)``: what an input of colour reads of a texture's ``(4,)`` ``value`` through output ``channel``
    (:data:`CHANNELS`): its first three for ``rgb`` and ``rgba``, else the one channel broadcast, as the device's
    ``select_channel``. ``rgba`` indexed a fifth channel (IndexError: the render of such an emission texture
    failed)."""
    k = CHANNELS[channel]
    return value[:3] if k == 4 else np.full(3, value[k], value.dtype)


def can_emit(mat: Material, textures: list[np.ndarray]) -> bool:
    """Whether ``mat`` can emit light anywhere: its :func:`emission_estimate` is above 0, or its emission texture's
    fallback (after scale and bias) glows where the lookup returns it, on a UDIM tile without a file (or outside the
    tiles) or outside the unit square under a ``fallback`` wrap (MaterialX's ``constant`` address mode). Which
    triangles glow is then read on them (:mod:`wrt.sampled_emission`); a texels' mean of 0 left a gprim that glows
    by its fallback analytic and unsampled."""
    return bool(emission_estimate(mat, textures).max() > 0.0) or fallback_glows(mat)


def fallback_glows(mat: Material) -> bool:
    """Whether ``mat``'s emission texture returns a fallback that glows (after scale and bias) where its lookup
    returns it for ordinary texture coordinates: on a UDIM tile without a file (or outside the tiles), or outside the
    unit square under a ``fallback`` wrap (MaterialX's ``constant`` address mode); :func:`can_emit` without a look
    at the texels."""
    tex = mat.textures.get("emissiveColor")
    if tex is None or (tex.tiles is None and "fallback" not in tex.wrap):
        return False
    value = np.asarray(tex.fallback, np.float64) * np.asarray(tex.scale, np.float64) + np.asarray(tex.bias, np.float64)
    return bool(np.max(channel_value(value, tex.channel)) > 0.0)


def _stored_as_is(image: np.ndarray) -> bool:
    """Every texel of ``image`` is in [0, 65504]: the device stores it as it is, and its float32 mean holds (a NaN
    fails the comparisons)."""
    return bool(image.min() >= 0.0 and image.max() <= HALF_MAX)


def _glow_mean(image: np.ndarray, scale: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``(4,)`` mean over ``image`` (``(H, W, 4)``) of ``max(texel * scale + bias, 0)``, per channel, as the device
    clamps each texel's emission, each texel as the device stores it (NaN as 0, infinite ones as the image's largest
    stored value: :func:`wrt.textures.pack_images`); summed in slices (no image-sized float64 temporaries). Scaling
    the mean instead estimated a mask stretched by ``scale`` 2, ``bias`` -1 at below 0: no light, though its bright
    texels glow."""
    flat = image.reshape(-1, 4)
    total = np.zeros(4)
    stored = image_scale(image)
    for start in range(0, len(flat), PACK_TEXELS):
        texels = stored_texels(flat[start : start + PACK_TEXELS], stored) * stored
        total += np.maximum(texels * scale + bias, 0.0).sum(axis=0)
    return total / max(len(flat), 1)
