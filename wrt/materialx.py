"""MaterialX ``standard_surface`` and OpenPBR surface shaders read as wrt materials (:class:`wrt.materials.Material`).

wrt's BSDF (:mod:`wrt.bsdf`) is UsdPreviewSurface's: Lambert under a GGX lobe whose F0 comes from ``ior`` and
``metallic``, a clearcoat of F0 0.04, a smooth dielectric for ``opacity < 1`` and cut-outs. Both MaterialX models
map onto it input by input (GGX ``alpha = roughness^2`` in all three, so roughness carries over unchanged):

=========================  ======================================  ======================================
wrt                        standard_surface                        OpenPBR
=========================  ======================================  ======================================
diffuseColor (and metal)   ``base * base_color``                   ``base_weight * base_color``
metallic                   ``metalness``                           ``base_metalness``
roughness                  ``specular_roughness``                  ``specular_roughness``
ior                        ``specular_IOR``, F0 scaled (below)     ``specular_ior``, F0 scaled (below)
clearcoat, its roughness   ``coat``, ``coat_roughness``            ``coat_weight``, ``coat_roughness``
emissiveColor (radiance)   ``emission * emission_color``           ``emission_luminance * emission_color``
opacity (cut-out, 0.5)     ``opacity`` (mean of its channels)      ``geometry_opacity``
opacity (dielectric)       ``1 - transmission``                    ``1 - transmission_weight``
=========================  ======================================  ======================================

Approximations, each named in the material's one warning when it changes what is drawn:

- The specular weight and the mean of the specular colour scale the dielectric F0 ``((ior - 1) / (ior + 1))^2``,
  as OpenPBR defines ``specular_weight``; wrt takes F0 from ``ior``, so ``ior`` becomes the index of that scaled F0,
  on the same side of 1 as the authored index (``specular = 0``: ``ior = 1``, no dielectric reflection; metals keep
  their reflection). The factor (at most 1) also scales the grazing reflectance, ``Material.specular_edge``, which
  UsdPreviewSurface has white: OpenPBR's weight scales the whole Fresnel curve, and a specular of 0 reflects nothing
  at any angle. A tinted specular colour loses its hue, and the changed ``ior`` also refracts transmitted light.
  An index below wrt's smallest (1e-3), negative ones too, is taken as that, as UsdPreviewSurface's ``ior`` is.
- Geometry opacity is a coverage; wrt has cut-outs, so it becomes a cut-out at 0.5 (a hole where it is below 0.5,
  as glTF's default alpha cutoff), which is exact for the 0/1 masks of leaves and fences. A constant between 0 and 1
  is rounded that way. With a cut-out, ``transmission`` is ignored (one opacity per material).
- ``transmission`` is wrt's smooth dielectric (opacity = 1 - transmission: Snell refraction at ``ior``);
  transmission colour, depth, scattering and roughness are ignored. With ``thin_walled`` (OpenPBR
  ``geometry_thin_walled``) true it is a thin-walled sheet instead (a window pane or a leaf modelled as one plane,
  :class:`wrt.materials.Material` ``thin_walled``): it reflects what both faces of a sheet of index ``ior`` reflect
  and lets the rest through unbent, with no inside. ``thin_walled`` changes nothing else: the opaque lobes already
  shade both sides of a surface alike, and of the lobes it turns into their thin forms (subsurface as translucency)
  wrt has none but transmission. A ``thin_walled`` fed by a node is ignored (a solid), with a note.
- The coat is wrt's clearcoat of index ``coat_IOR`` (OpenPBR ``coat_ior``; F0 ``((1 - n) / (1 + n))^2``, F90
  white, as MaterialX's graphs make the coat a dielectric of that index): ``coat_color`` is ignored, and so is a
  texture of the index (its constant is kept: the value authored beside the connection, else the default), as are
  textures of ``specular_IOR``, the specular weight and colour.
- A colour and its weight (``base_color`` and ``base``, the emission's) each from an image: the colour's texture
  times the weight's constant, its texture ignored.
- OpenPBR's ``emission_luminance`` is in nits; wrt's radiance is in UsdLux's units, where a light of intensity 1
  has luminance 1 nit, so the emitted radiance is ``emission_luminance * emission_color`` (MaterialX's own OpenPBR
  graph feeds that product to its ``uniform_edf`` unchanged). A 1000-nit panel is 1000 times a UsdLux light of
  intensity 1: lower the exposure.
- Lobes wrt does not have (diffuse roughness, subsurface, sheen/fuzz, thin film, anisotropy, coat-affected colour
  and roughness) are ignored.
- ``normal`` (OpenPBR ``geometry_normal``) from a tangent-space ``normalmap`` node of an image is wrt's normal map
  (:func:`wrt.shade.shading_point`, the same frame as UsdPreviewSurface's); from anything else it is ignored.
  ``coat_normal`` and ``tangent`` inputs are not read (the coat takes the mapped normal too). The normalmap's frame
  is the mesh's ``st`` (``Tworld``), not the image's placed coordinates; its own ``normal``, ``tangent`` and
  ``bitangent`` authored are not read, with a note.

An input is a constant, an input of the Material (or a NodeGraph) it connects to, or an image node: ``ND_image_*`` or
``ND_tiledimage_*`` (``float``, ``color3``, ``color4``, ``vector2/3/4``), reached directly or through a NodeGraph
output. An image node becomes a :class:`wrt.materials.TextureInput`: its output is the file's first channels, 0
past the file's but for a fourth of 1 (the specification's rule, as MaterialX's GLSL, MSL and OSL sample: a ``color3``
of a grey file is ``(c, 0, 0)``, a ``vector2`` of an ``R G`` EXR ``(R, G)``, of an RGB file ``(r, g)``, its third
channel 0 where a ``convert`` widens it; :func:`wrt.textures.materialx_texels`), ``file`` (for ``color3`` and
``color4`` nodes the
colour space from the attribute's ``colorSpace`` metadata: ``srgb_texture`` decoded (the node's output r, g and b,
whichever file channels they hold, as MaterialX transforms the output), ``g22_rec709`` and kin decoded by their
transfer function (wrt.color_spaces, USD's canonical names such as ``srgb_rec709_scene`` as MaterialX remaps
them; the colour of other primaries then converted to Rec.709's at load, as USD converts it),
``lin_rec709``/``raw`` and other linear spaces kept (USD's ``data``,
``identity`` and ``unknown`` too), none kept too (MaterialX's default working space is ``none``, no colour
management, and Storm reads MaterialX's textures raw); ``float`` and ``vector`` nodes read their data linear, as
MaterialX colour-manages colour types only), ``uaddressmode``/``vaddressmode`` (periodic, mirror, clamp; constant reads
the node's ``default`` outside [0, 1], black without one), ``filtertype`` (``closest``: the nearest texel; ``linear``
and ``cubic``: bilinear; these tokens from ``constant`` or ``dot`` string nodes too: :meth:`_Graph._token`),
``place2d`` and ``UsdTransform2d`` nodes and vector2 math of constants before its
``texcoord`` (:meth:`_Graph._texcoord`),
``uvtiling``/``uvoffset``/``realworldimagesize``/
``realworldtilesize`` of ``tiledimage`` as the texture transform, and texture coordinates from ``ND_texcoord_vector2``
(the mesh's ``st``) or a reader of :data:`TEXCOORD_READERS` (the primvar named by ``geomprop`` or ``varname``; its
``default`` or ``fallback`` where the mesh lacks it), or a constant ``texcoord`` (read there on every point). Where the
file cannot be read, the node's ``default`` is used (MaterialX's, 0 in every channel, when the node has none). A
``layer`` (of a multi-layer EXR) is not chosen (the file's unnamed layer is read: :func:`wrt.textures.exr_rgba`);
a note names the node and the layer.
``base_color`` may also come from a mesh's colour primvar: an ``ND_UsdPrimvarReader_color3``/``vector3`` or
``ND_geompropvalue_color3``/``vector3`` node (:class:`wrt.materials.PrimvarInput`; its ``fallback`` or ``default`` where
the mesh lacks it). Math and channel nodes between an input and these sources (``multiply``, ``add``, ``mix``,
``convert``, ...) are folded at load time (:mod:`wrt.materialx_fold`): into a constant, or into the texture's or
primvar's scale. Any other node keeps the input's constant: its own authored value (decoded from its
``colorSpace``), else the specification's default.
Defaults are the MaterialX library's (``libraries/bxdf/standard_surface.mtlx`` 1.0.1 and 1.0.0,
``open_pbr_surface.mtlx`` 1.1).
"""

from __future__ import annotations

import math
import re

import numpy as np

from .color_spaces import decoded_color, file_color_space
from .materials import (
    COLOR_PRIMVAR_READERS,
    MIN_IOR,
    TEXTURE_FALLBACK,
    TRANSFORM2D_IDS,
    Material,
    PrimvarInput,
    TextureInput,
    bool_typed,
    constant_numbers,
    constant_st_transform,
    four_components,
    mesh_frame_note,
    refused_constant,
    two_finite_numbers,
)
from .materialx_fold import MAX_DEPTH, TYPE_SIZES, Folded, Unfoldable, fold
from .usd_values import value_at

# role -> (input name, specification default); the roles are what wrt's model reads.
STANDARD_SURFACE_101 = {
    "base_weight": ("base", 1.0),
    "base_color": ("base_color", (0.8, 0.8, 0.8)),
    "metallic": ("metalness", 0.0),
    "specular_weight": ("specular", 1.0),
    "specular_color": ("specular_color", (1.0, 1.0, 1.0)),
    "roughness": ("specular_roughness", 0.2),
    "ior": ("specular_IOR", 1.5),
    "transmission": ("transmission", 0.0),
    "coat": ("coat", 0.0),
    "coat_color": ("coat_color", (1.0, 1.0, 1.0)),
    "coat_roughness": ("coat_roughness", 0.1),
    "coat_ior": ("coat_IOR", 1.5),
    "emission_weight": ("emission", 0.0),
    "emission_color": ("emission_color", (1.0, 1.0, 1.0)),
    "opacity": ("opacity", (1.0, 1.0, 1.0)),
    "thin_walled": ("thin_walled", False),
}
STANDARD_SURFACE_100 = {**STANDARD_SURFACE_101, "base_weight": ("base", 0.8), "base_color": ("base_color", (1.0,) * 3)}
OPEN_PBR_SURFACE = {
    "base_weight": ("base_weight", 1.0),
    "base_color": ("base_color", (0.8, 0.8, 0.8)),
    "metallic": ("base_metalness", 0.0),
    "specular_weight": ("specular_weight", 1.0),
    "specular_color": ("specular_color", (1.0, 1.0, 1.0)),
    "roughness": ("specular_roughness", 0.3),
    "ior": ("specular_ior", 1.5),
    "transmission": ("transmission_weight", 0.0),
    "coat": ("coat_weight", 0.0),
    "coat_color": ("coat_color", (1.0, 1.0, 1.0)),
    "coat_roughness": ("coat_roughness", 0.0),
    "coat_ior": ("coat_ior", 1.6),
    "emission_weight": ("emission_luminance", 0.0),
    "emission_color": ("emission_color", (1.0, 1.0, 1.0)),
    "opacity": ("geometry_opacity", 1.0),
    "thin_walled": ("geometry_thin_walled", False),
}
# Inputs of lobes wrt does not have, with the value that switches them off.
STANDARD_SURFACE_IGNORED = {"diffuse_roughness": 0.0, "subsurface": 0.0, "sheen": 0.0, "thin_film_thickness": 0.0,
                            "specular_anisotropy": 0.0, "coat_affect_color": 0.0, "coat_affect_roughness": 0.0}
OPEN_PBR_IGNORED = {"base_diffuse_roughness": 0.0, "subsurface_weight": 0.0, "fuzz_weight": 0.0,
                    "thin_film_weight": 0.0, "specular_roughness_anisotropy": 0.0}
NORMAL_INPUTS = {"ND_standard_surface_surfaceshader": "normal", "ND_standard_surface_surfaceshader_100": "normal",
                 "ND_open_pbr_surface_surfaceshader": "geometry_normal"}  # info:id -> its shading-normal input
MODELS = {  # info:id -> (inputs, ignored inputs)
    "ND_standard_surface_surfaceshader": (STANDARD_SURFACE_101, STANDARD_SURFACE_IGNORED),
    "ND_standard_surface_surfaceshader_100": (STANDARD_SURFACE_100, STANDARD_SURFACE_IGNORED),
    "ND_open_pbr_surface_surfaceshader": (OPEN_PBR_SURFACE, OPEN_PBR_IGNORED),
}
CUT_OUT_THRESHOLD = 0.5  # geometry opacity below this is a hole

IMAGE_NODE = re.compile(r"^ND_(tiled)?image_(float|color3|color4|vector2|vector3|vector4)$")
NORMAL_MAP_NODE = re.compile(r"^ND_normalmap(_float|_vector2)?$")  # 1.38's, and 1.39's of a float or vector2 scale
# Texture-coordinate readers an image's texcoord may connect to: info:id -> (input naming the primvar, the one giving
# the st of a mesh without it).
TEXCOORD_READERS = {"ND_geompropvalue_vector2": ("geomprop", "default"),
                    "ND_UsdPrimvarReader_vector2": ("varname", "fallback"),
                    "UsdPrimvarReader_float2": ("varname", "fallback")}
PLACE2D_ID = "ND_place2d_vector2"  # moves an image's texture coordinates: pivot, scale, rotate, offset, order
PLACE2D_INPUTS = (("pivot", (0.0, 0.0)), ("scale", (1.0, 1.0)), ("rotate", (0.0,)), ("offset", (0.0, 0.0)),
                  ("operationorder", (0.0,)))  # stdlib_defs.mtlx's defaults
# Vector2 math nodes read on texture coordinates, with a constant beside them: node -> (inputs the coordinates may
# enter by, each input's default: stdlib_defs.mtlx's). (ND_<op>_vector2, and ND_<op>_vector2FA whose in2 is a float.)
TEXCOORD_MATH = {"multiply": (("in1", "in2"), {"in1": 0.0, "in2": 1.0}), "divide": (("in1",), {"in2": 1.0}),
                 "add": (("in1", "in2"), {"in1": 0.0, "in2": 0.0}),
                 "subtract": (("in1", "in2"), {"in1": 0.0, "in2": 0.0}), "rotate2d": (("in",), {"amount": 0.0})}
TEXCOORD_MATH_ID = re.compile(r"^ND_(multiply|divide|add|subtract|rotate2d)_vector2(FA)?$")
ADDRESS_MODES = {"periodic": "repeat", "mirror": "mirror", "clamp": "clamp", "constant": "black"}
def read_materialx_surface(reader, shader, path: str) -> Material:
    """The :class:`Material` for ``shader`` (a ``standard_surface`` or OpenPBR ``UsdShade.Shader``) of the material
    at ``path``, read by ``reader`` (a :class:`wrt.materials.MaterialReader`: its inputs, images and warnings). What
    is approximated or ignored goes into one warning for the material."""
    inputs, ignored = MODELS[shader.GetShaderId()]
    graph = _Graph(reader, shader, path, inputs)
    textures = {}
    primvar = None

    def put(slot, value, texture):
        nonlocal primvar
        if isinstance(texture, PrimvarInput):  # only base_color reads one (_Graph.read)
            primvar = texture
        elif texture is not None:
            textures[slot] = texture
        return value

    diffuse = put("diffuseColor", *graph.product("base_color", "base_weight"))
    emissive = put("emissiveColor", *graph.product("emission_color", "emission_weight"))
    metallic = put("metallic", *graph.scalar("metallic"))
    roughness = put("roughness", *graph.scalar("roughness"))
    clearcoat = put("clearcoat", *graph.scalar("coat"))
    clearcoat_roughness = put("clearcoatRoughness", *graph.scalar("coat_roughness"))
    ior = graph.ior(pure_metal=metallic >= 1.0 and "metallic" not in textures)
    thin_walled = graph.thin_walled()
    opacity, threshold, opacity_texture = graph.opacity(thin_walled)
    if opacity_texture is not None:
        textures["opacity"] = opacity_texture
    normal_map = graph.normal_map(NORMAL_INPUTS[shader.GetShaderId()])
    if normal_map is not None:
        textures["normal"] = normal_map
    clearcoat_ior = graph.coat_notes(clearcoat, "clearcoat" in textures)
    graph.ignored_notes(ignored)
    if graph.notes:
        reader.skip(f"material {path}: {shader.GetShaderId()} is drawn approximately: {'; '.join(graph.notes)}",
                    shader.GetPrim())
    mat = Material(path=path, diffuse_color=diffuse, emissive_color=emissive, metallic=metallic, roughness=roughness,
                   ior=ior, clearcoat=clearcoat, clearcoat_roughness=clearcoat_roughness, clearcoat_ior=clearcoat_ior,
                   specular_edge=min(max(graph.specular_factor, 0.0), 1.0),
                   opacity=opacity, opacity_threshold=threshold, thin_walled=thin_walled, textures=textures)
    if primvar is not None:
        primvar.apply(mat)
    return mat


def read_node_input(reader, shader, name: str, default, path: str) -> tuple:
    """``(constant, texture, notes)`` of input ``name`` of ``shader`` (of the material at ``path``) fed by MaterialX
    nodes, read as the surfaces' inputs are (:meth:`_Graph.read`: image nodes, and the nodes
    :func:`wrt.materialx_fold.fold` folds), ``default`` its value unauthored (three numbers: a colour, decoded from
    its colour space); ``notes`` says what is approximated or ignored."""
    graph = _Graph(reader, shader, path, {name: (name, default)})
    value, texture = graph.read(name)
    return value, texture, graph.notes


def texcoord_node_map(reader, node, path: str) -> tuple | None:
    """``(map, source, notes)`` of MaterialX node ``node`` (of the material at ``path``) on texture coordinates where
    it is a ``place2d`` or vector2 math of a constant: the ``(3, 3)`` float64 affine map it applies (as an image
    node's :meth:`_Graph._texcoord` reads it), :meth:`wrt.materials.MaterialReader._producer` of the input the
    coordinates come in by and the notes on it; None for any other node."""
    graph = _Graph(reader, node, path, {})
    node_id = node.GetShaderId() or ""
    if node_id == PLACE2D_ID:
        return graph._place2d(node), reader._producer(node, "texcoord"), graph.notes
    math_node = TEXCOORD_MATH_ID.match(node_id)
    mapped = graph._texcoord_math(node, math_node.group(1)) if math_node else None
    return None if mapped is None else (*mapped, graph.notes)


def token_input(reader, node, key: str, unauthored: str, path: str) -> tuple[str, list[str]]:
    """``(token, notes)`` of string input ``key`` of MaterialX node ``node`` (of the material at ``path``), read as
    an image node's address modes are (:meth:`_Graph._token`: its value, or that of the ``constant`` or ``dot``
    string nodes feeding it; ``unauthored`` where it has none, or, noted, where another node feeds it)."""
    graph = _Graph(reader, node, path, {})
    return graph._token(node, key, unauthored), graph.notes


def folded_input(reader, node, name: str, size: int, unauthored: str, path: str) -> tuple:
    """``(value, notes)`` of input ``name`` of MaterialX node ``node`` (of the material at ``path``) as ``size``
    numbers, read as a normalmap's ``scale`` is (:meth:`_Graph._folded_constant`: its value, or the constant the
    nodes feeding it fold to; None where it is unauthored or, noted, gives none)."""
    graph = _Graph(reader, node, path, {})
    return graph._folded_constant(node, name, size, unauthored), graph.notes


class _Graph:
    """The inputs of one surface shader, resolved through interface inputs and NodeGraph outputs, and the notes
    (approximations, unsupported nodes) for its material's warning."""

    def __init__(self, reader, shader, path: str, inputs: dict):
        self.reader = reader
        self.shader = shader
        self.path = path
        self.inputs = inputs
        self.notes: list[str] = []
        self.specular_factor = 1.0  # the specular weight times the mean specular colour (set by ior)

    def read(self, role: str) -> tuple[np.ndarray, TextureInput | PrimvarInput | None]:
        """``(constant, texture)`` of the input playing ``role``: the constant is ``(3,)`` or ``(1,)`` float64 (the
        texture's fallback where a texture is returned), the texture None unless an image node feeds the input
        (through nodes :func:`wrt.materialx_fold.fold` folds), or for ``base_color`` a colour primvar reader's
        :class:`wrt.materials.PrimvarInput`."""
        name, default = self.inputs[role]
        default = np.atleast_1d(np.asarray(default, np.float64))
        found = self.reader._producer(self.shader, name)
        if found is None:
            return default, None
        if found[0] == "value":
            value = _input_array(found[1], default.size)
            if value is None:
                problem = refused_constant(found[1], _input_sizes(default.size))
                self.notes.append(f"{name} is {problem}; its default is used")
                return default, None
            # The models' colour inputs (base_color, opacity, ...) are those of three numbers, all color3 in the
            # nodedefs.
            decoded = self._decoded(self.shader.GetInput(name), value, f"{name}'s", color=default.size == 3)
            if decoded is None:
                self.notes.append(f"{name} decoded from its colour space is past float32's range; its default is used")
                return default, None
            return decoded, None
        node = found[1]

        def leaf(source, source_id: str) -> Folded | None:
            if IMAGE_NODE.match(source_id):
                return Folded(*self._image(source, source_id))
            if role == "base_color" and source_id in COLOR_PRIMVAR_READERS:
                primvar = self.reader.color_primvar_input(source, self.path)
                value = primvar.fallback.astype(np.float64)
                return Folded(value, primvar) if primvar.name else Folded(value)  # no name: its fallback, a constant
            return None

        try:
            folded = fold(self.reader, node, leaf, output=found[2])
        except Unfoldable as e:
            node_id = e.node.GetShaderId() or "node without info:id"
            why = f"whose {e.problem}" if e.problem else "which is not supported"
            constant = self.unconnected(role)
            self.notes.append(f"{name} comes from a {node_id} node ({e.node.GetPath()}), {why}; its constant "
                              f"{_format(constant)} is used")
            return constant, None
        value = _array(folded.value, default.size)
        if value is None:  # a folded value past float64's range
            constant = self.unconnected(role)
            self.notes.append(f"{name} is not a finite number after its nodes; its constant {_format(constant)} is "
                              "used")
            return constant, None
        return value, folded.source

    def unconnected(self, role: str) -> np.ndarray:
        """The input playing ``role`` as it reads unconnected: the value authored beside its connection, decoded from
        its colorSpace, else its default; what it keeps where wrt cannot evaluate its node or ignores its texture.
        An ignored texture left the constant ``read`` returns beside it, the image's ``default`` (0 unauthored): a
        base_color image times a base image was black, a specular_IOR image drew a mirror (index 1e-3)."""
        name, default = self.inputs[role]
        default = np.atleast_1d(np.asarray(default, np.float64))
        inp = self.shader.GetInput(name)
        own = _input_array(value_at(inp.GetAttr(), self.reader.time), default.size) if inp else None
        own = None if own is None else self._decoded(inp, own, f"{name}'s", color=default.size == 3)
        return default if own is None else own

    def _decoded(self, inp, value: np.ndarray, what: str, color: bool) -> np.ndarray | None:
        """:func:`decoded_color` of ``value``, its note (a colour space wrt does not know) kept. A
        base_color of 0.5 in ``srgb_texture`` was read as 0.5 for MaterialX's 0.214. None where the decode passes
        float32's range (1e20 in ``srgb_texture``), for the caller to use its default: an emission_color so, times
        the emission weight 0, was NaN, and the stage failed to load."""
        decoded, note = decoded_color(inp, value, what, color)
        if note is not None:
            self.notes.append(note)
        return decoded

    def scalar(self, role: str) -> tuple[float, TextureInput | None]:
        """A float input: ``(constant, texture)``; a colour authored on it reads as its mean."""
        value, texture = self.read(role)
        return float(np.mean(value)), texture

    def product(self, color_role: str, weight_role: str) -> tuple[np.ndarray, TextureInput | None]:
        """``color * weight`` as ``((3,) constant, texture)``: a texture of either is scaled by the other's constant
        (a weight texture by the colour's mean, its tint lost); of two textures the colour's is kept."""
        color, color_texture = self.read(color_role)
        weight, weight_texture = self.read(weight_role)
        if color_texture is not None and weight_texture is not None:  # the weight's texture is ignored
            weight = self.unconnected(weight_role)
            self.notes.append(f"the texture of {self.inputs[weight_role][0]} is ignored (its colour is textured); "
                              f"its constant {_format(weight)} is used")
            weight_texture = None
        color, weight = np.resize(color, 3), float(np.mean(weight))
        (color_name, color_default), (weight_name, weight_default) = (self.inputs[color_role],
                                                                      self.inputs[weight_role])
        # Each finite, their product (or a texture's scale times the other) past float32's range: the defaults.
        if np.abs(color * weight).max() > np.finfo(np.float32).max or not all(
                _multiply(texture, factor, apply=False)
                for texture, factor in ((color_texture, weight), (weight_texture, float(np.mean(color))))
                if texture is not None):
            self.notes.append(f"{color_name} {_format(color)} times {weight_name} {weight:.3g} is not a finite float; "
                              "their defaults are used")
            default = np.resize(np.asarray(color_default, np.float64), 3) * float(weight_default)
            return default.astype(np.float32), None
        if color_texture is not None:
            _multiply(color_texture, weight)
            return (color * weight).astype(np.float32), color_texture
        if weight_texture is not None:
            _multiply(weight_texture, float(np.mean(color)))
            if np.ptp(color) > 1e-6:
                self.notes.append(f"{self.inputs[color_role][0]} {_format(color)} tints a textured weight: its mean "
                                  "is used")
            return (color * weight).astype(np.float32), weight_texture
        return (color * weight).astype(np.float32), None

    def ior(self, pure_metal: bool) -> float:
        """``ior`` whose dielectric F0 is the specular weight times the mean specular colour times the F0 of the
        authored index (textures of these three keep their constants). A ``pure_metal`` has no dielectric F0 to
        show, and no note about it."""
        ior, weight, color = (self._constant_of(role) for role in ("ior", "specular_weight", "specular_color"))
        authored = float(np.mean(ior))
        ior = max(authored, float(MIN_IOR))  # as wrt draws it: an index of -1 divided by zero below
        factor = float(np.mean(weight)) * float(np.mean(color))
        self.specular_factor = factor
        weight_name, color_name = self.inputs["specular_weight"][0], self.inputs["specular_color"][0]
        if np.ptp(np.resize(color, 3)) > 1e-6 and not pure_metal:
            self.notes.append(f"{color_name} {_format(color)} is reduced to its mean")
        if abs(factor - 1.0) < 1e-6:
            return ior
        f0 = ((ior - 1.0) / (ior + 1.0)) ** 2 * max(factor, 0.0)
        r = math.sqrt(min(f0, 0.99))
        scaled = (1.0 + r) / (1.0 - r)
        if ior < 1.0:  # the same F0 on the same side of 1: transmitted light bends the way the authored index does
            scaled = 1.0 / scaled
        if not pure_metal:
            self.notes.append(f"{weight_name} times the mean {color_name}, {factor:.3g}, scales the dielectric F0: "
                              f"{self.inputs['ior'][0]} {authored:.3g} is drawn as {scaled:.3g}")
        return scaled

    def thin_walled(self) -> bool:
        """The constant ``thin_walled`` (OpenPBR ``geometry_thin_walled``); False, with a note, where a node feeds it
        or its value is not a number."""
        name = self.inputs["thin_walled"][0]
        found = self.reader._producer(self.shader, name)
        if found is None:
            return False
        value = _array(found[1]) if found[0] == "value" else None
        if value is None:
            self.notes.append(f"{name} ({_describe(found)}) is ignored: the surface is drawn as a solid's boundary")
            return False
        return bool(value[0] != 0.0)

    def opacity(self, thin_walled: bool) -> tuple[float, float, TextureInput | None]:
        """``(opacity, opacityThreshold, texture)``: geometry opacity as a cut-out, else transmission as wrt's
        dielectric (a thin-walled sheet's where ``thin_walled``)."""
        coverage, coverage_texture = self.read("opacity")
        coverage = float(np.mean(coverage))
        transmission, transmission_texture = self.read("transmission")
        transmission = float(np.mean(transmission))
        opacity_name, transmission_name = self.inputs["opacity"][0], self.inputs["transmission"][0]
        if coverage_texture is not None or coverage < 1.0:
            if coverage_texture is not None and coverage_texture.channel in ("rgb", "rgba"):
                # A colour image: wrt reads one number per point, the first channel (not the mean of the three)
                self.notes.append(f"the texture of {opacity_name} is a colour image: its red channel is the cut-out")
            if coverage_texture is None and 0.0 < coverage < 1.0:
                rounded = "a hole" if coverage < CUT_OUT_THRESHOLD else "opaque"
                self.notes.append(f"{opacity_name} {coverage:.3g} is drawn {rounded} (a cut-out at "
                                  f"{CUT_OUT_THRESHOLD})")
            if transmission_texture is not None or transmission > 0.0:
                self.notes.append(f"{transmission_name} is ignored beside a cut-out {opacity_name}")
            return coverage, CUT_OUT_THRESHOLD, coverage_texture
        if transmission_texture is not None:  # opacity = 1 - (texel * scale + bias)
            transmission_texture.scale = -transmission_texture.scale
            transmission_texture.bias = 1.0 - transmission_texture.bias
        if transmission_texture is not None or transmission > 0.0:
            sheet = "thin-walled " if thin_walled else ""
            self.notes.append(f"{transmission_name} is drawn as a smooth {sheet}dielectric of opacity 1 - "
                              f"{transmission_name} (no colour, depth or roughness)")
        return 1.0 - transmission, 0.0, transmission_texture

    def normal_map(self, name: str) -> TextureInput | None:
        """The tangent-space normal map behind input ``name`` (``normal``, OpenPBR ``geometry_normal``): a
        ``normalmap`` node (tangent space) of a vector3 image node (read as data), whose ``in * 2 - 1`` with x and y
        times its ``scale`` is the normal (MaterialX's ``mx_normalmap``), as the texture's scale and bias. None where
        the input is unconnected, or (with a note) fed otherwise, or where the image cannot be read: the mesh's
        normals are used."""
        found = self.reader._producer(self.shader, name)
        if found is None:
            return None
        if found[0] == "value":
            self.notes.append(f"a constant {name} is ignored (only a normal map perturbs normals)")
            return None
        node = found[1]
        node_id = node.GetShaderId() or ""
        source = self.reader._producer(node, "in") if NORMAL_MAP_NODE.match(node_id) else None
        image_id = (source[1].GetShaderId() or "") if source is not None and source[0] == "shader" else ""
        space = self._token(node, "space", "tangent")
        if not (IMAGE_NODE.match(image_id) and image_id.endswith("_vector3") and space == "tangent"):
            what = f"a {node_id or 'node without info:id'} node ({node.GetPath()})"
            self.notes.append(f"{name} comes from {what}, not a tangent-space normalmap node of a vector3 image; "
                              "it is ignored")
            return None
        _, texture = self._image(source[1], image_id, unauthored_default=np.array([0.5, 0.5, 1.0]))
        if texture is None:
            return None
        if not np.any(texture.fallback[:3]):  # MaterialX's normalmap reads a value of 0 as the flat normal
            texture.fallback = np.array([0.5, 0.5, 1.0, texture.fallback[3]], np.float32)
        scale = self._folded_constant(node, "scale", 2, "1")
        sx, sy = (1.0, 1.0) if scale is None else scale
        texture.scale = np.array([2.0 * sx, 2.0 * sy, 2.0, 1.0], np.float32)
        texture.bias = np.array([-sx, -sy, -1.0, 0.0], np.float32)
        # MaterialX's normalmap takes its tangent from the geometry (Tworld: the mesh's st, as Storm computes it),
        # not from the image's coordinates: a place2d turning the image turned the normals' tilt with it.
        texture.mesh_frame = True
        for frame_input in ("normal", "tangent", "bitangent"):  # the nodedefs' Nworld, Tworld and Bworld
            found_frame = self.reader._producer(node, frame_input)
            if found_frame is not None:  # a frame wrt does not follow: it was dropped without a word
                self.notes.append(f"{node.GetPath()}: its {frame_input} ({_describe(found_frame)}) is not read; "
                                  "the mesh's is used")
        frame_note = mesh_frame_note(texture)
        if frame_note is not None:
            self.notes.append(f"{node.GetPath()}: {frame_note}")
        # A missing UDIM tile reads the image's default (0.5, 0.5, 1) decoded as every texel: the flat normal.
        return texture

    def coat_notes(self, coat: float, textured: bool) -> float:
        """The coat's index (``coat_IOR``, OpenPBR ``coat_ior``; at least wrt's smallest index, as ``ior``), and
        notes on the coat inputs wrt's clearcoat cannot follow, where the coat shows. The index was ignored (always
        1.5, with a note): a coat of index 2 reflected 0.04 head-on instead of 0.11."""
        coat_ior, coat_ior_texture = self.read("coat_ior")
        if coat_ior_texture is not None:
            coat_ior = self.unconnected("coat_ior")
        index = max(float(np.mean(coat_ior)), float(MIN_IOR))
        if coat <= 0.0 and not textured:
            return index
        color, color_texture = self.read("coat_color")
        if color_texture is not None or not np.allclose(color, 1.0):
            self.notes.append(f"{self.inputs['coat_color'][0]} is ignored (wrt's clearcoat is clear)")
        if coat_ior_texture is not None:
            self.notes.append(f"the texture of {self.inputs['coat_ior'][0]} is ignored (wrt has one constant coat "
                              f"index); its constant {_format(coat_ior)} is used")
        return index

    def _constant_of(self, role: str) -> np.ndarray:
        """The constant of the input playing ``role``, which wrt reads as a constant only (the dielectric's index):
        its :meth:`read` value, or, where an image feeds it, its :meth:`unconnected` value, the texture named in a
        note."""
        value, texture = self.read(role)
        if texture is None:
            return value
        value = self.unconnected(role)
        self.notes.append(f"the texture of {self.inputs[role][0]} is ignored (wrt has one constant ior); its constant "
                          f"{_format(value)} is used")
        return value

    def ignored_notes(self, ignored: dict):
        """Names the inputs of lobes wrt lacks (``ignored``: name -> the value that switches the lobe off) that are
        connected or authored with another value."""
        for name, off in ignored.items():
            found = self.reader._producer(self.shader, name)
            if found is None:
                continue
            value = _array(found[1]) if found[0] == "value" else None
            # Values equal to ``off`` (the common case) are close without np.allclose, whose 0.1 ms a call over the
            # lobes of 133 materials was 7% of teapotScene's load_usd.
            if value is None or not (bool((value == off).all()) or np.allclose(value, off)):
                self.notes.append(f"{name} ({_describe(found)}) is ignored")

    def _image(self, node, node_id: str, unauthored_default: np.ndarray | None = None
               ) -> tuple[np.ndarray, TextureInput | None]:
        """``(fallback, texture)`` of image node ``node``; texture None where its file cannot be read. ``fallback``
        is the node's ``default``, of the node's own type (an ``extract`` of a color4 image's alpha reads the
        default's alpha); unauthored, MaterialX's (``stdlib_defs.mtlx``: 0 in every channel of the type: an
        ``emission_color`` image whose file is missing emits nothing), or ``unauthored_default`` where given (a
        normal map's flat (0.5, 0.5, 1), for its missing UDIM tiles)."""
        reader = self.reader
        size = TYPE_SIZES[IMAGE_NODE.match(node_id).group(2)]
        default = self._image_default(node, size, color=node_id.endswith(("_color3", "_color4")))
        if default is not None:
            fallback = default
        elif unauthored_default is not None:
            fallback = np.asarray(unauthored_default, np.float64)
        else:
            fallback = np.zeros(size)
        file_input = node.GetInput("file")
        if not file_input:
            self.notes.append(f"image node {node.GetPath()} has no file; {_format(fallback)} is used")
            return fallback, None
        layer = self.reader._constant(node, "layer")
        if layer:  # a multi-layer EXR's layer, which was ignored without a word (textures.exr_rgba picks its own)
            self.notes.append(f"{node.GetPath()}: layer {str(layer)!r} is not chosen; the file's unnamed layer is read "
                              "(else its one layer of colour channels)")
        # MaterialX colour-manages colour types only: float and vector images (masks, normal maps) are data.
        color_space = self._color_space(file_input) if node_id.endswith(("_color3", "_color4")) else "raw"
        # MaterialX's channels, not UsdUVTexture's: a grey file is (c, 0, 0, 1), two channels (c0, c1, 0, 1)
        image, tiles = reader.file_images(node, color_space, self.path, layout="materialx")
        if image < 0:
            return fallback, None
        tiled = node_id.startswith("ND_tiledimage_")
        if tiled:
            wrap = ("repeat", "repeat")
        else:
            # "constant" gives the node's default outside [0, 1]: its fallback where authored, else the default's own
            # default, 0 in every channel (black).
            # A normal map's unauthored default reads (0.5, 0.5, 1), the flat normal MaterialX's normalmap makes of
            # the default's 0 (its black outside the image was a normal bent into the surface).
            modes = {**ADDRESS_MODES, "constant": "black" if default is None and unauthored_default is None
                     else "fallback"}
            wrap = tuple(self._address_mode(node, key, modes) for key in ("uaddressmode", "vaddressmode"))
        channel = "r" if node_id.endswith("_float") else "rgb"
        texture_filter = self._filter(node)
        transform = self._tiling(node) if tiled else np.eye(3, dtype=np.float32)
        uv_set, st_fallback, constant_st, placement = self._texcoord(node)
        with np.errstate(over="ignore", invalid="ignore"):  # past float32's range: inf, named below
            transform = (np.asarray(transform, np.float64) @ placement).astype(np.float32)
        if constant_st is not None:
            transform = constant_st_transform(transform, constant_st)
        if not np.all(np.isfinite(transform)):  # finite tiling and sizes whose product passes float32's range
            self.notes.append(f"the texture transform of {node.GetPath()} passes float32's range; "
                              f"{_format(fallback)} is used")
            return fallback, None
        texture = TextureInput(image=image, channel=channel, wrap=wrap, transform=transform, uv_set=uv_set,
                               st_fallback=st_fallback, tiles=tiles,
                               fallback=four_components(fallback, TEXTURE_FALLBACK), filter=texture_filter)
        if size == 2:  # a vector2 has no third channel: a convert to three gives it 0, not the file's blue
            texture.scale[2] = 0.0
        if size in (2, 3):  # nor a fourth: a convert to four gives it 1, not the file's alpha
            texture.scale[3], texture.bias[3] = 0.0, 1.0
        return fallback, texture

    def _image_default(self, node, size: int, color: bool) -> np.ndarray | None:
        """Image node ``node``'s ``default`` (``size`` channels, a ``color`` type's decoded from its colour space):
        its value, or the constant the nodes feeding it fold to (an ``ND_constant_color3``, math of constants:
        :func:`wrt.materialx_fold.fold`); None where it is unauthored, or where no constant comes out or it passes
        float32's range (named in a note). A default fed by a constant node was read as unauthored, 0, without a
        word: an image's glow outside [0, 1] (the ``constant`` address mode) or on a missing UDIM tile was lost."""
        found = self.reader._producer(node, "default")
        if found is None:
            return None
        if found[0] == "shader":  # each constant folded in its own colour space
            try:
                folded = fold(self.reader, found[1], lambda source, source_id: None, output=found[2])
            except Unfoldable as e:
                why = f"whose {e.problem}" if e.problem else "which is not supported"
                self.notes.append(f"{node.GetPath()}'s default comes from a {e.node.GetShaderId() or 'node'} node "
                                  f"({e.node.GetPath()}), {why}; MaterialX's default is used")
                return None
            default = _array(folded.value, size)
            if default is None:
                self.notes.append(f"{node.GetPath()}'s default is past float32's range after its nodes; MaterialX's "
                                  "default is used")
            return default
        default = _array(found[1], size)
        if default is not None:  # in its colorSpace, if any: the specification's example default is in lin_rec709
            default = self._decoded(node.GetInput("default"), default, f"{node.GetPath()}'s default", color=color)
            if default is None:
                self.notes.append(f"{node.GetPath()}'s default decoded from its colour space is past float32's range; "
                                  "MaterialX's default is used")
        return default

    def _folded_constant(self, node, name: str, size: int, unauthored: str) -> np.ndarray | None:
        """Input ``name`` of ``node`` as ``size`` numbers (one broadcast): its value (through interface inputs), or
        the constant the nodes feeding it fold to (:func:`wrt.materialx_fold.fold`: a ``constant`` node, math of
        constants), as :meth:`_image_default` reads a default; None where it is unauthored, or where its nodes fold to
        no constant or it is past float32's range (named in a note saying that ``unauthored``, its value unauthored,
        is used). A normalmap's ``scale`` or a tiledimage's ``uvtiling`` fed by a constant node read as unauthored
        (1) without a word."""
        found = self.reader._producer(node, name)
        if found is None:
            return None
        if found[0] == "shader":
            try:
                found = ("value", fold(self.reader, found[1], lambda source, source_id: None, output=found[2]).value)
            except Unfoldable as e:
                why = f"whose {e.problem}" if e.problem else "which is not supported"
                self.notes.append(f"{node.GetPath()}: {name} comes from a {e.node.GetShaderId() or 'node'} node "
                                  f"({e.node.GetPath()}), {why}; {unauthored} is used")
                return None
        value = _array(found[1], size)
        if value is None:
            self.notes.append(f"{node.GetPath()}: {name} ({_describe(found)}) is no {size} finite numbers; "
                              f"{unauthored} is used")
        return value

    def _token(self, node, key: str, unauthored: str) -> str:
        """String input ``key`` of ``node``: its value (through interface inputs), or that of the ``constant`` (or
        ``dot``) string nodes feeding it; ``unauthored`` where it has none, or (named in a note) where another node
        feeds it. MaterialX makes such inputs (address modes, ``filtertype``, ``space``) uniform, connectable to an
        interface input; a constant node's value fed to one was read as unauthored without a word."""
        found = self.reader._producer(node, key)
        for _ in range(MAX_DEPTH):
            if found is None or found[0] == "value":
                break
            source, source_id = found[1], found[1].GetShaderId() or ""
            port = {"ND_constant_string": "value", "ND_dot_string": "in"}.get(source_id)
            if port is None:
                self.notes.append(f"{node.GetPath()}: {key} comes from a {source_id or 'node without info:id'} node "
                                  f"({source.GetPath()}), not a constant string; it is read as {unauthored!r}")
                return unauthored
            found = self.reader._producer(source, port)
        else:
            self.notes.append(f"{node.GetPath()}: {key} comes through more than {MAX_DEPTH} nodes; it is read as "
                              f"{unauthored!r}")
            return unauthored
        return (str(found[1]) if found is not None else "") or unauthored

    def _address_mode(self, node, key: str, modes: dict) -> str:
        """wrt's wrap mode for image node ``node``'s ``uaddressmode`` or ``vaddressmode`` (``key``; unauthored:
        periodic) by ``modes``; a token MaterialX does not define (UsdUVTexture's ``repeat`` or ``black``) is named in
        a note and read as periodic, as Storm reads it. It was read so without a word."""
        token = self._token(node, key, "periodic")
        if token not in modes:
            self.notes.append(f"{node.GetPath()}: {key} {token!r} is none of constant, clamp, periodic or mirror; it "
                              "is read as periodic")
        return modes.get(token, "repeat")

    def _filter(self, node) -> str:
        """wrt's texture filter for image node ``node``'s ``filtertype``: ``closest`` reads the nearest texel, as
        MaterialX and Storm (a nearest sampler) read it; ``linear`` (the default) and ``cubic`` filter bilinearly,
        ``cubic`` named in a note. Another value is noted and read as ``linear``. ``closest`` was filtered
        bilinearly without a word: a pixel-art or id map blended its texels."""
        token = self._token(node, "filtertype", "linear")
        if token == "closest":
            return "closest"
        if token == "cubic":
            self.notes.append(f"{node.GetPath()}: filtertype cubic is read as linear (bilinear)")
        elif token != "linear":
            self.notes.append(f"{node.GetPath()}: filtertype {token!r} is none of closest, linear or cubic; it is "
                              "read as linear")
        return "linear"

    def _color_space(self, file_input) -> str:
        """wrt's colour space (``sRGB``, ``raw`` or ``gamma <g>``, ``<transfer> in <primaries>`` for other primaries)
        for an image's ``file`` input (:func:`file_color_space`); an unknown one is noted. None authored is ``raw``:
        MaterialX's working colour space defaults to ``none`` (no colour management) and Storm hands MaterialX its
        textures raw, so an 8-bit colour file read as UsdUVTexture's ``auto`` was decoded as sRGB where MaterialX
        reads it as stored."""
        space, note = file_color_space(file_input)
        if note is not None:
            self.notes.append(note)
        return space or "raw"

    def _tiling(self, node) -> np.ndarray:
        """``tiledimage``'s texture-coordinate map ``(st * uvtiling - uvoffset) / realworldimagesize *
        realworldtilesize`` as a 3x3 matrix (column-vector convention, as ``UsdTransform2d``'s)."""

        def pair(name, default):
            value = self._folded_constant(node, name, 2, _format(default))
            return value if value is not None else np.array(default, np.float64)

        tiling, offset = pair("uvtiling", (1, 1)), pair("uvoffset", (0, 0))
        image_size, tile_size = pair("realworldimagesize", (1, 1)), pair("realworldtilesize", (1, 1))
        if np.any(image_size == 0.0):
            self.notes.append(f"{node.GetPath()}: realworldimagesize has a zero; the real-world sizes are ignored")
            image_size = tile_size = np.ones(2)
        s = tile_size / image_size
        m = np.array([[tiling[0] * s[0], 0, -offset[0] * s[0]], [0, tiling[1] * s[1], -offset[1] * s[1]], [0, 0, 1]])
        with np.errstate(over="ignore"):  # past float32's range: inf, named in the note (_image)
            return m.astype(np.float32)

    def _texcoord(self, node) -> tuple[str | None, np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`_texcoord_source` of image node ``node``'s ``texcoord``, and the ``(3, 3)`` float64 map of the
        ``place2d`` nodes (:meth:`_place2d`), ``UsdTransform2d`` nodes (``MaterialReader.transform2d_map``) and
        vector2 math of constants (:meth:`_texcoord_math`) between them (identity without one), the image's nearest
        first."""
        placement = np.eye(3)
        found, holder = self.reader._producer(node, "texcoord"), node
        passed = set()  # the nodes on the way: a chain that loops back (fed by its own output) ends there
        while found is not None and found[0] == "shader":
            if found[1].GetPath() in passed:
                # It went round sixteen times, then was named as an unsupported node.
                self.notes.append(f"the texture coordinates of {node.GetPath()} come through nodes that loop back on "
                                  f"themselves ({found[1].GetPath()}); each is applied once and primvar st read")
                return "st", np.zeros(2, np.float32), None, placement
            node_id = found[1].GetShaderId() or ""
            if node_id == PLACE2D_ID:
                holder = found[1]
                placement = placement @ self._place2d(holder)
                found = self.reader._producer(holder, "texcoord")  # unconnected: UV0, st (defaultgeomprop)
                passed.add(holder.GetPath())
                continue
            if node_id in TRANSFORM2D_IDS:  # as it moves a UsdUVTexture's st: it was named as unsupported, st read
                holder = found[1]
                placement = placement @ self.reader.transform2d_map(holder, self.path)
                found = self.reader._producer(holder, "in")
                passed.add(holder.GetPath())
                if found is None:  # no defaultgeomprop: Sdr's and the nodedef's (0, 0), as for a UsdUVTexture
                    self.notes.append(f"{holder.GetPath()}: a UsdTransform2d's in that is neither connected nor "
                                      "authored reads (0, 0): its texture shows one point")
                    found = ("value", (0.0, 0.0))
                continue
            math_node = TEXCOORD_MATH_ID.match(node_id)
            mapped = self._texcoord_math(found[1], math_node.group(1)) if math_node else None
            if mapped is None:
                break
            holder = found[1]
            placement, found = placement @ mapped[0], mapped[1]
            passed.add(holder.GetPath())
        return (*self._texcoord_source(found, holder), placement)

    def _texcoord_math(self, node, op: str):
        """``(map, source)`` of a vector2 math node ``node`` (``op``: a key of :data:`TEXCOORD_MATH`) that reads
        texture coordinates through one input (``source``: :meth:`MaterialReader._producer` of that input) and a
        constant through the other: the ``(3, 3)`` float64 affine map it applies, as MaterialX defines the node
        (``rotate2d`` as :meth:`_place2d`'s turn); None (the caller names the node as unsupported) where neither or
        both inputs are fed by nodes, or the constant is not finite numbers."""
        inputs, defaults = TEXCOORD_MATH[op]
        names = ("in",) if op == "rotate2d" else ("in1", "in2")
        found = {name: self.reader._producer(node, name) for name in (*names, "amount")}
        fed = [name for name in names if found[name] is not None and found[name][0] == "shader"]
        if len(fed) != 1 or fed[0] not in inputs:
            return None
        other = "amount" if op == "rotate2d" else next(name for name in names if name != fed[0])
        value = defaults[other] if found[other] is None else _array(found[other][1], None)
        if value is None or np.size(value) not in (1, 2):
            return None
        c = np.resize(np.asarray(value, np.float64), 2)
        if op == "rotate2d":
            m = _turn(c[0])
        elif op in ("multiply", "divide"):
            if op == "divide" and np.any(c == 0.0):
                return None
            m = _affine(np.diag(c if op == "multiply" else 1.0 / c))
        elif op == "add" or fed[0] == "in1":  # st + c, st - c
            m = _affine(shift=c if op == "add" else -c)
        else:  # c - st
            m = _affine(-np.eye(2), c)
        return m, found[fed[0]]

    def _place2d(self, place) -> np.ndarray:
        """``(3, 3)`` float64 map of ``place2d`` node ``place``, as MaterialX's ``NG_place2d_vector2`` computes it with
        ``rotate2d``'s turn by ``a`` degrees, ``(x cos a + y sin a, -x sin a + y cos a)``: ``operationorder`` 0 (SRT)
        ``rot((st - pivot) / scale) - offset + pivot``, 1 (TRS) ``rot(st - pivot - offset) / scale + pivot``. An
        input fed by nodes is the constant they fold to (:func:`wrt.materialx_fold.fold`: a constant node, math of
        constants; it was named and the place2d ignored); one fed by another node, a scale with a zero or another
        order is named in a note and the node ignored (identity);
        a value that is not finite numbers of its type keeps its default, with a note. Such nodes were named as
        unsupported and the image read unplaced."""
        values = {}
        for name, default in PLACE2D_INPUTS:
            found = self.reader._producer(place, name)
            if found is not None and found[0] != "value":  # a constant node or math of constants: their value
                try:
                    found = ("value", fold(self.reader, found[1], lambda source, source_id: None,
                                           output=found[2]).value)
                except Unfoldable as e:
                    why = f", whose {e.problem}" if e.problem else ""
                    self.notes.append(f"{place.GetPath()}: {name} comes from a node; the place2d is ignored (a "
                                      f"{e.node.GetShaderId() or 'node'} node, {e.node.GetPath()}{why})")
                    return np.eye(3)
            value = None if found is None else _array(found[1], None)
            if found is not None and (value is None or value.size != len(default)):
                self.notes.append(f"{place.GetPath()}: {name} is not {len(default)} finite number(s); its default is "
                                  "used")
                value = None
            values[name] = np.asarray(default if value is None else value, np.float64).reshape(-1)
        pivot, scale, offset = values["pivot"], values["scale"], values["offset"]
        order = values["operationorder"][0]
        if np.any(scale == 0.0) or order not in (0.0, 1.0):
            self.notes.append(f"{place.GetPath()}: a scale of zero or an operationorder other than 0 or 1; the place2d "
                              "is ignored")
            return np.eye(3)
        turn, shrink = _turn(values["rotate"][0]), _affine(np.diag(1.0 / scale))
        if order == 0:
            return _affine(shift=pivot - offset) @ turn @ shrink @ _affine(shift=-pivot)
        return _affine(shift=pivot) @ shrink @ turn @ _affine(shift=-pivot - offset)

    def _texcoord_source(self, found, node) -> tuple[str | None, np.ndarray, np.ndarray | None]:
        """``(primvar, st_fallback, constant)`` of what feeds a ``texcoord`` (``found``, ``MaterialReader._producer``
        of ``node``'s): the primvar it reads (``st`` unless a ``geompropvalue`` or primvar reader names another), the
        ``(2,)`` st of a mesh without it (the ``geompropvalue``'s ``default``, a reader's ``fallback``; zero
        otherwise), and None; or, for a ``texcoord`` authored as a constant, ``(None, zero, (2,) constant)``: the
        image is read there on every point."""
        no_fallback = np.zeros(2, np.float32)
        if found is None:
            return "st", no_fallback, None  # MaterialX's default texcoord: the first set, which is USD's st
        if found[0] == "value":
            constant = two_finite_numbers(found[1])
            if constant is not None:
                return None, no_fallback, constant
            self.notes.append(f"the texcoord on {node.GetPath()} is not two finite numbers; primvar st is used")
            return "st", no_fallback, None
        source = found[1]
        source_id = source.GetShaderId() or ""
        if source_id == "ND_texcoord_vector2":
            index = self.reader._constant(source, "index")
            if index not in (None, 0):
                self.notes.append(f"texcoord index {index} is read as primvar st")
            return "st", no_fallback, None
        if source_id in TEXCOORD_READERS:
            name_input, default_input = TEXCOORD_READERS[source_id]
            name = self.reader.primvar_name(source, name_input, self.path)
            default = self.reader.st_reader_default(source, default_input, self.path)
            st_fallback = two_finite_numbers(default)
            if default is not None and st_fallback is None:
                self.notes.append(f"the default of {source.GetPath()} is not two finite numbers; (0, 0) is used")
            st_fallback = no_fallback if st_fallback is None else st_fallback.astype(np.float32)
            if not name:  # the nodedefs' (and Sdr's) "": no primvar is read, its default is; the mesh's st was read
                self.notes.append(f"the texcoord reader {source.GetPath()} names no primvar (its {name_input} is "
                                  f"empty or unauthored); its {default_input} is read on every point")
                return None, no_fallback, st_fallback.astype(np.float64)
            return str(name), st_fallback, None
        self.notes.append(f"texture coordinates from a {source_id or 'node without info:id'} node "
                          f"({source.GetPath()}) are not supported; primvar st is used")
        return "st", no_fallback, None

def _affine(linear=np.eye(2), shift=(0.0, 0.0)) -> np.ndarray:
    """The ``(3, 3)`` float64 map of texture coordinates ``st -> linear @ st + shift``."""
    m = np.eye(3)
    m[:2, :2], m[:2, 2] = linear, shift
    return m


def _turn(degrees: float) -> np.ndarray:
    """MaterialX's ``rotate2d`` of texture coordinates by ``degrees``, ``(x cos a + y sin a, -x sin a + y cos a)``,
    as a :func:`_affine` map (``place2d`` turns them so too)."""
    a = math.radians(degrees)
    return _affine(np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]))


def _multiply(texture, factor: float, apply: bool = True) -> bool:
    """Multiplies what ``texture`` (a :class:`TextureInput` or :class:`PrimvarInput`) gives by ``factor``: the scale
    and bias of every channel it reads. A texture read as one channel (a float image, an extract of alpha) reads
    its own channel, which scaling r, g and b alone missed for alpha: an emission mask kept no colour. Whether the
    results stay within float32's range (an infinite scale stopped the load); ``apply`` False only says so."""
    names = ("scale",) if isinstance(texture, PrimvarInput) else ("scale", "bias")
    reads = slice(0, 3) if isinstance(texture, PrimvarInput) or texture.channel in ("rgb", "rgba") else slice(0, 4)
    scaled = {}
    for name in names:
        values = np.array(getattr(texture, name), np.float64)
        values[reads] *= factor
        scaled[name] = values
    if not all(np.all(np.abs(v) <= np.finfo(np.float32).max) for v in scaled.values()):
        return False
    if apply:
        for name, values in scaled.items():
            setattr(texture, name, values.astype(np.float32))
    return True


def _input_array(value, size: int) -> np.ndarray | None:
    """:func:`_array` of a surface input's constant, ``size`` numbers of its type: None also when it has another shape
    (a colour, ``size`` 3, is 1, 3 or 4 numbers, a float one) or is a string, as for UsdPreviewSurface's inputs: a
    float2 colour was resized to ``(a, b, a)``, a matrix read as its first entries, a colour or a string of digits
    given for a float as its first number, without a word. A ``bool`` is none either (numpy's 1 for true): USD's
    typed readers give no bool for a colour or float input, and a bool base_color was drawn white."""
    numbers = None if bool_typed(value) else constant_numbers(value)
    return _array(numbers, size) if numbers is not None and numbers.size in _input_sizes(size) else None


def _input_sizes(size: int) -> tuple:
    """The counts of numbers a surface input of ``size`` numbers takes: a colour (3) is 1, 3 or 4."""
    return (1, 3, 4) if size == 3 else (size,)


def _array(value, size: int | None = None) -> np.ndarray | None:
    """A constant as a float64 array finite in float32 (``size`` 3 broadcasts one number); None when it is not one
    (a ``double`` of 1e300 passed as finite and stopped the load, a float32 material field being infinite), nor
    for a string or a ``string[]``, which numpy reads as numbers (``["0.5", "0"]`` as an offset of (0.5, 0))."""
    v = constant_numbers(value)
    if v is None or v.size == 0 or not np.all(np.abs(v) <= np.finfo(np.float32).max):
        return None
    if size is not None and v.size != size:
        v = np.full(size, v[0]) if v.size == 1 else np.resize(v, size)
    return v


def _format(value) -> str:
    v = np.atleast_1d(np.asarray(value, np.float64))
    return ", ".join(f"{x:.3g}" for x in v) if v.size > 1 else f"{v[0]:.3g}"


def _describe(found) -> str:
    """An input's value or, when connected, its source node, for a warning."""
    if found[0] == "value":
        return _format(found[1]) if _array(found[1]) is not None else repr(found[1])
    return f"connected to {found[1].GetShaderId() or found[1].GetPath()}"
