"""Reads a USD stage into a :class:`wrt.scene.Scene`: world-space triangles, materials, cameras and lights.

:func:`load_usd` walks the stage in pre-order, keeps every visible ``UsdGeom.Mesh`` whose purpose is ``default`` or
``render`` (or one the render settings' ``includedPurposes`` list: :mod:`wrt.render_settings`), fan-triangulates its
faces with :func:`triangulate` (leaving out ``holeIndices``), bakes the world transform into the points, and carries
shading normals, ``displayColor`` and ``displayOpacity`` (its own, else a constant one inherited from an ancestor;
opacity for the default material only), texture coordinates and the bound material (:mod:`wrt.materials`) per
triangle. UsdLux lights, mesh lights (``MeshLightAPI``) too, are read by :mod:`wrt.usd_lights`; meshes skinned by a
UsdSkel skeleton are posed by :mod:`wrt.usd_skel`. Bad topology raises :class:`wrt.errors.SceneError` naming the
file and the prim; things that are skipped but a user might expect to see (unsupported gprims, lights or shaders)
produce one warning each.

Gprims (:mod:`wrt.primitives`): ``UsdGeom.Sphere`` (``radius``), ``Cube`` (``size``), ``Cylinder`` and ``Cone``
(``height``, ``radius``, ``axis``; capped), ``Capsule`` (``height`` of the cylindrical part, ``radius``, ``axis``),
``Plane`` (``width``, ``length``, ``axis``, ``doubleSided``) and the tapered ``Cylinder_1`` and ``Capsule_1``
(``height``, ``radiusBottom``, ``radiusTop``, ``axis``; see :func:`wrt.primitives.tapered_shape`) become analytic
shapes intersected in their own space,
with ``displayColor`` (constant; other interpolations use the mean), material binding, ``doubleSided`` and
``orientation``. With ``tessellate_gprims`` they become triangle meshes instead (vertices on the surface, analytic
vertex normals; see :func:`wrt.primitives.tessellate`). Gprims whose size is zero, negative or not finite are
skipped with a warning (one radius of a ``Cylinder_1`` or ``Capsule_1`` may be 0), and so are volumes (the gprim
types left); one whose world box is past float32's range raises, as mesh points do, and one flattened by a zero
scale is drawn as its (flat) tessellation, with a warning. ``Points`` and curves
(``BasisCurves``, ``HermiteCurves``, ``NurbsCurves``) become instances of spheres and tube pieces
(:mod:`wrt.usd_tubes`), each shape a content of its own; ``TetMesh`` (its boundary) and ``NurbsPatch``
(tessellated) become meshes (:mod:`wrt.usd_surfaces`).

Instancing (:mod:`wrt.instancing`): native instances (``instanceable`` prims) and ``UsdGeom.PointInstancer``
instances are not flattened. Each native prototype and each prim a PointInstancer's ``prototypes`` relationship
targets is read once, in its own space, into a ``Scene.prototypes`` entry, and every instance becomes one row of
``Scene.instances`` (prototype index and 4x4 transform). Nesting (instancers and instances inside prototypes, at any
depth) is resolved into that single level. PointInstancers read ``protoIndices``, ``positions``, ``orientations``
(or ``orientationsf``), ``scales``, ``invisibleIds`` and ``inactiveIds`` (``ComputeMaskAtTime``); the instance
transform is ``translate(position) * rotate(orientation) * scale(scale)`` after the prototype root's own transform
(``IncludeProtoXform``), as ``ComputeInstanceTransformsAtTime`` computes it. Between and beyond time samples,
``positions`` (and a mesh's ``points``) with ``velocities`` (and ``accelerations``) authored at the same samples are
the earlier sample moved by them, and orientations with ``angularVelocities`` the earlier sample turned by them, as
USD computes it; then every per-instance attribute is held at its earlier sample (USD's velocity path), and without
either they are all interpolated. A ``protoIndices`` entry out of range, a prototype target that does not exist, or
per-instance arrays shorter than ``protoIndices`` (``ids`` too, where a mask uses them) raise
:class:`wrt.errors.SceneError` naming the instancer; instances whose transform is singular (a zero scale) are
skipped with a warning naming each one (``/instancer[index]``), and so are the instances of an inactive prototype
(or one under an inactive prim). Visibility and purpose inside a PointInstancer's prototype are taken from the
prototype root down (the scope holding the prototypes is often made invisible so they are not drawn in place). A
material bound on or above a native instance (chosen by the meshes' rule, :func:`wrt.materials.bound_material`:
preview bindings included) applies to the prototype's meshes that bind none themselves (on the faces that their
``materialBind`` subsets leave unbound), and to all of them (subsets and nested instances included) when it
is bound ``strongerThanDescendants``. A constant ``displayColor`` on or above a native instance colours the
prototype's meshes and gprims that have none (a copy of the prototype per colour, up to ``MAX_INHERITED_COLORS``).
A PointInstancer's ``primvars:displayColor`` (``constant``, or ``vertex``/``varying``: one per instance, flattened
through its indices, read as ``positions`` are) becomes ``Instances.colors`` instead, no copy per colour: it colours
the prototype meshes and gprims that have no displayColor of their own at shading time; instances nested in a
coloured one take the colour of the nearest instancer that gives one. Other interpolations and other lengths are
ignored with a warning naming the instancer. Where a material reads another colour primvar
(:meth:`wrt.materials.MaterialReader.color_primvars`), the colours of the faces bound to it come from that primvar
instead (each face from its own material's), and all of the above (inheritance, native instances, PointInstancer
primvars) applies to it in place of ``displayColor``.
Cameras inside native instances are read at their instance-proxy paths
(``/Instance/Cam``, placed by the instance), in invisible instances too, as cameras under invisible prims are; cameras
inside PointInstancer prototypes and lights inside any prototype are skipped with a warning.

Time: ``time=None`` reads ``Usd.TimeCode.Default()``. A mesh attribute (or a visibility) that has no authored
default value but has time samples is read at its earliest sample instead, so meshes animated from frame 1 still
load, and a prim hidden at frame 1 stays hidden. Transforms and cameras get the same fallback, op by op and
attribute by attribute (:mod:`wrt.usd_xforms`), so a camera animated only through time samples is where its first
frame puts it rather than at the origin, and an op that authors a default beside its samples gives the default.
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom, UsdLux, UsdProc, UsdShade

from .camera import Camera
from .errors import SceneError, TimeRangeWarning
from .instancing import Instances, Prototype, group_rows, invert_transforms, world_boxes
from .light_links import part_path, resolve_expressions
from .materials import MaterialReader, bound_material
from .primitives import (
    DEFAULT_SEGMENTS,
    MAX_SEGMENTS,
    Shape,
    axis_rotation,
    shape_transform,
    tapered_shape,
    tessellate,
)
from .render_settings import RenderSettings, read_render_settings
from .resources import check_host_memory
from .scene import MIN_METERS_PER_UNIT, Mesh, Scene
from .subdivision import MAX_REFINE_LEVEL, REFINED_QUAD_BYTES, Refinement, refined_quads
from .tubes import place_round, width_axis
from .usd_lights import read_light, sync_mesh_material
from .usd_primvars import finite_colors, unit_opacities
from .usd_skel import SkelPoser
from .usd_surfaces import SurfaceReader
from .usd_tubes import TubeReader
from .usd_values import held_value, moved_positions, read_time, spun_rotations, value_at
from .usd_variants import apply_variants
from .usd_xforms import xform_cache

_RENDERED_PURPOSES = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)  # other purposes: guide, proxy
_INTERPOLATIONS = ("constant", "uniform", "varying", "vertex", "faceVarying")
_FLIP = np.array([0, 2, 1])  # corner permutation that reverses a triangle's winding, keeping corner 0
MAX_INHERITED_COLORS = 64  # distinct displayColors handed down by instances, per native prototype (one copy each)


def triangulate(face_counts, face_indices) -> tuple[np.ndarray, np.ndarray]:
    """Fan-triangulates polygons around the first vertex of each face.

    Face ``f`` with ``n`` vertices becomes the ``n - 2`` consecutive triangles ``(v0, v[k+1], v[k+2])`` for
    ``k = 0 .. n-3``. Faces with fewer than 3 vertices give no triangle but still consume their indices.

    Args:
        face_counts: ``(F,)`` int, vertices per face (USD ``faceVertexCounts``).
        face_indices: ``(N,)`` int, the concatenated face vertices (USD ``faceVertexIndices``); only its
            length is used, to check that the counts cover it exactly.

    Returns:
        ``tri_corners`` ``(T, 3)`` int64 positions into ``face_indices`` (so the triangle vertices are
        ``face_indices[tri_corners]``) and ``face_ids`` ``(T,)`` int64, the source face of each triangle.

    Raises:
        ValueError: a count is negative, or the counts do not sum to ``len(face_indices)``.
    """
    counts = np.asarray(face_counts, dtype=np.int64).reshape(-1)
    n_indices = len(np.asarray(face_indices).reshape(-1))
    if counts.size and counts.min() < 0:
        f = int(np.argmax(counts < 0))
        raise ValueError(f"faceVertexCounts[{f}] = {counts[f]} is negative")
    total = int(counts.sum())
    if total != n_indices:
        raise ValueError(f"faceVertexCounts sum to {total} but there are {n_indices} faceVertexIndices")

    # Each face starts at the running sum of the counts before it and gives max(n - 2, 0) triangles.
    starts = np.cumsum(counts) - counts
    n_tris = np.maximum(counts - 2, 0)
    face_ids = np.repeat(np.arange(len(counts), dtype=np.int64), n_tris)
    # k = index of the triangle inside its face's fan.
    first_tri = np.cumsum(n_tris) - n_tris
    k = np.arange(len(face_ids), dtype=np.int64) - first_tri[face_ids]
    s = starts[face_ids]
    tri_corners = np.stack([s, s + k + 1, s + k + 2], axis=1)
    return tri_corners, face_ids


def load_usd(path, *, time=None, tessellate_gprims: bool | int = False, refine_level: int = 0, variants=None,
             render_settings: str | None = None) -> Scene:
    """Reads the meshes, gprims, instances, materials, cameras and lights of a USD stage.

    Args:
        path: a file USD can open (``.usd``, ``.usda``, ``.usdc``, ``.usdz``).
        time: the time code to read; ``None`` means ``Usd.TimeCode.Default()`` (see the module docstring for
            the fallback to the earliest time sample).
        tessellate_gprims: ``False``: gprims are analytic shapes; ``True``: triangle meshes of
            ``wrt.primitives.DEFAULT_SEGMENTS`` segments per circle; an int: that many segments (3 to 4096).
        refine_level: Catmull-Clark steps (0 to ``wrt.subdivision.MAX_REFINE_LEVEL``) applied to meshes whose
            ``subdivisionScheme`` is ``catmullClark`` (USD's fallback), as Hydra's refine level; each step makes
            four times the faces. 0 draws the control cage, smooth-shaded, as usdview does at low complexity.
        variants: variant selections, prim path -> {variant set: variant} (``{"/World/Car": {"paint": "red"}}``),
            made on the session layer before anything is read (:mod:`wrt.usd_variants`); the file is left as it is.
        render_settings: path of the ``RenderSettings`` prim to read into ``Scene.render_settings``; ``None``: the
            one the stage's ``renderSettingsPrimPath`` names, if any (:mod:`wrt.render_settings`). Its
            ``includedPurposes`` choose the purposes drawn besides ``default``.

    Returns:
        The :class:`wrt.scene.Scene`; triangle ids follow the stage's pre-order traversal.

    Raises:
        wrt.errors.SceneError: the file is missing or not USD, or a mesh, primvar or camera is invalid, a variant
            selection names a prim, set or variant that does not exist, or the render settings are not a
            ``RenderSettings`` prim or hold a value the schema does not allow.

    Warns:
        UserWarning: the stage has composition errors (a reference, payload or subLayer that does not compose); the
            scene holds the rest.
    """
    try:
        source = os.fspath(path)
    except TypeError:  # os.fspath's message named no argument
        raise TypeError(f"path must be a file path (str or os.PathLike), got {type(path).__name__}") from None
    if time is None:
        time_code = Usd.TimeCode.Default()
    elif isinstance(time, Usd.TimeCode):
        time_code = time
    else:
        try:
            value = float(time)
        except (TypeError, ValueError):  # float()'s message named no argument: "could not convert string to float"
            value = math.nan
        if not math.isfinite(value):
            raise ValueError(f"time must be a finite time code or None, got {time!r}")
        time_code = Usd.TimeCode(value)

    stage = _open_stage(source)
    if variants:
        apply_variants(stage, source, variants)
    _warn_composition_errors(stage, source)
    _warn_other_layer_units(stage, source)
    settings = read_render_settings(stage, source, render_settings)
    if stage.GetTimeCodesPerSecond() <= 0:
        # usd-core hangs in time-sample queries on such stages; wrt never makes them, but say what was found.
        warnings.warn(f"{os.path.basename(source)}: timeCodesPerSecond = {stage.GetTimeCodesPerSecond():g} is invalid; "
                      "time samples are read only at their authored time codes")
    if not time_code.IsDefault():
        _check_time_in_range(stage, source, time_code.GetValue())
    segments = 0
    if tessellate_gprims is True:
        segments = DEFAULT_SEGMENTS
    elif tessellate_gprims is not False and tessellate_gprims is not None:
        if not isinstance(tessellate_gprims, (int, np.integer)) or not 3 <= tessellate_gprims <= MAX_SEGMENTS:
            raise ValueError(f"tessellate_gprims must be a bool or an int from 3 to {MAX_SEGMENTS}, got "
                             f"{tessellate_gprims!r}")
        segments = int(tessellate_gprims)
    if isinstance(refine_level, bool) or not isinstance(refine_level, (int, np.integer)) or not (
        0 <= refine_level <= MAX_REFINE_LEVEL
    ):
        raise ValueError(f"refine_level must be an int from 0 to {MAX_REFINE_LEVEL}, got {refine_level!r}")
    reader = _StageReader(stage, source, time_code, segments, int(refine_level), settings)
    try:
        return reader.read()
    finally:
        # The material reader and the skeleton poser hold the stage reader's skip method: a cycle that kept the
        # stage and its layers open until the next garbage collection, so a file edited and loaded again in that
        # time read as before.
        reader.materials = None
        reader.skel = None
        reader.tubes = None
        reader.surfaces = None


def _warn_composition_errors(stage: Usd.Stage, source: str) -> None:
    """Warns about the stage's composition errors (a reference, payload or subLayer whose file is missing, a
    reference to a prim path that is not there): USD only prints them from C++ to stderr, where Python cannot catch
    them, and composes the stage without what they would bring in. A warning, not an error: partially composed
    stages are common and the rest still renders."""
    errors = sorted(str(e).strip().rstrip(".") for e in stage.GetCompositionErrors())  # sorted: USD's order varies
    if errors:
        shown = "; ".join(errors[:3]) + ("; ..." if len(errors) > 3 else "")
        warnings.warn(
            f"{source}: {len(errors)} composition error(s); what they would bring in is missing from the scene: "
            f"{shown}",
            stacklevel=3,
        )


def _warn_other_layer_units(stage: Usd.Stage, source: str) -> None:
    """Warns about layers the stage composes (references, payloads, subLayers) that author a ``metersPerUnit`` or
    ``upAxis`` other than the stage's. USD does not convert them and neither does wrt (their geometry is drawn as
    authored), so a robot authored in metres referenced into a centimetre stage was drawn 100 times too small, and a
    Z-up one in a Y-up stage on its side, without a word; a reference that scales or turns it itself is right."""

    def shown(value) -> str:
        return f"{value:g}" if isinstance(value, float) else str(value)

    own = (stage.GetRootLayer(), stage.GetSessionLayer())
    stage_values = {"metersPerUnit": UsdGeom.GetStageMetersPerUnit(stage), "upAxis": UsdGeom.GetStageUpAxis(stage)}
    for key, value in stage_values.items():
        others = sorted(
            f"{os.path.basename(layer.identifier)}: {shown(layer.pseudoRoot.GetInfo(key))}"
            for layer in stage.GetUsedLayers()
            if layer not in own and layer.pseudoRoot.HasInfo(key) and layer.pseudoRoot.GetInfo(key) != value
        )
        if others:
            warnings.warn(
                f"{os.path.basename(source)}: {key} = {shown(value)}, but {len(others)} layer(s) it composes author "
                f"another ({', '.join(others[:3])}{', ...' if len(others) > 3 else ''}); USD does not convert them and "
                "neither does wrt: they are drawn as authored",
                stacklevel=3,
            )


def _check_time_in_range(stage: Usd.Stage, source: str, time: float) -> None:
    """Warns about a time outside the stage's authored ``[startTimeCode, endTimeCode]``. USD evaluates any time
    (values hold at the nearest sample), and stages do animate outside their advertised range (teapot_scene_1000
    says [1, 1] and moves its camera over 0-479), so this is a warning, not an error. Reads only layer metadata,
    never time samples, which can hang usd-core on stages with ``timeCodesPerSecond = 0``."""
    if not stage.HasAuthoredTimeCodeRange():
        return
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    if not start <= time <= end:
        warnings.warn(f"{os.path.basename(source)}: time {time:g} is {outside_range(start, end)}", TimeRangeWarning,
                      stacklevel=3)


def outside_range(start: float, end: float) -> str:
    """The words of a :class:`TimeRangeWarning`, after the time or frames it is about."""
    return f"outside the stage's time range [{start:g}, {end:g}]; USD holds the values of the nearest time samples"


def stage_time_range(path) -> tuple[float, float] | None:
    """The authored ``(startTimeCode, endTimeCode)`` of the stage at ``path``, or None when not both are authored or
    the file cannot be read. Read from its root layer alone, without composing the stage: ``Usd.Stage`` reads them
    there (or from its session layer, where wrt authors none)."""
    try:
        layer = Sdf.Layer.FindOrOpen(os.fspath(path))
    except Tf.ErrorException:
        return None
    if layer is None or not (layer.HasStartTimeCode() and layer.HasEndTimeCode()):
        return None
    return float(layer.startTimeCode), float(layer.endTimeCode)


def _open_stage(source: str) -> Usd.Stage:
    try:
        stage = Usd.Stage.Open(source)
    except Tf.ErrorException as e:
        if not os.path.exists(source):
            raise SceneError("file not found", path=source) from None
        raise SceneError(f"USD cannot open this file ({_tf_message(e)})", path=source) from None
    if stage is None:
        raise SceneError("USD cannot open this file", path=source)
    return stage


_PROTOTYPE_PREDICATE = Usd.PrimIsActive & Usd.PrimIsLoaded & ~Usd.PrimIsAbstract  # see _StageReader._content


def _tf_message(error: Exception) -> str:
    """The quoted reasons inside a ``Tf.ErrorException`` text, without the C++ file and line noise."""
    # A reason may span lines (the text parser's ends in a newline before its closing quote).
    reasons = re.findall(r" : '(.*?)'\s*(?=\n\s*Error in|\Z)", str(error), flags=re.DOTALL)
    reasons = [re.sub(r"pxrInternal_\w+?::", "", r).strip() for r in reasons]
    return "; ".join(r for r in reasons if r) or str(error).strip()


class _LocalMesh:
    """A mesh's data in its own space, before the world transform; shared by all instances of a prototype."""

    def __init__(self, points, vertex_ids, face_ids, flip, normals, colors, double_sided, uvs=None, cage=None,
                 refinement=None, opacities=None):
        self.points = points  # (V, 3) float64, local space
        self.vertex_ids = vertex_ids  # (T, 3) int64 rows into points, winding as authored
        self.face_ids = face_ids  # (T,) int64 source face
        self.flip = flip  # orientation = leftHanded
        self.normals = normals  # (values (K, 3) float64 local, corner index (T, 3) into values) or None
        self.colors = colors  # colour primvar -> (values (K, 3) float32, corner index (T, 3)), those the mesh has
        self.double_sided = double_sided
        self.uvs = uvs  # (values (K, 2) float64, corner index (T, 3)) or None
        self.cage = cage  # (faceVertexCounts, faceVertexIndices) of a mesh to get smooth normals from them, else None
        # A Refinement of the points (control cage) into the points vertex_ids index, or None: applied after posing.
        self.refinement = refinement
        self.opacities = opacities  # displayOpacity (values (K,) float32, corner index (T, 3)) or None


class _Content:
    """What one subtree draws, in one space (the world, or a prototype's): meshes, and instances of other contents."""

    def __init__(self, path: str):
        self.path = path  # prim path of the subtree root
        self.meshes: list[Mesh] = []  # in this content's space
        self.shapes: list[Shape] = []  # analytic gprims, in this content's space
        # (content key, (K, 4, 4) column-vector transforms to this space, source, indices, looks): looks are the
        # instances' (K, 4) colour and displayOpacity (NaN: none; see _looks), or None.
        self.instances: list = []
        self.uses_outer = False  # a mesh binds no material itself: a material bound above an instance applies
        # Colour primvars (displayColor, or the one a material reads) that a mesh or gprim lacks: one an instance
        # hands down applies.
        self.outer_colors: list[str] = []
        self.colors: dict = {}  # outer (primvar, colour) -> content key: this prototype read again with that colour
        self.cameras: list[Sdf.Path] = []  # cameras of a native prototype, relative to its root (nested ones too)
        self.prototype = -1  # index into Scene.prototypes once its meshes are placed there
        # (is a sphere, width axis (wrt.tubes.width_axis)) of the spheres or tube segments of a Points or curves prim:
        # instances of them stay round under any transform placed above (wrt.tubes.place_round).
        self.tube: tuple[bool, np.ndarray] | None = None

    def want_colors(self, names):
        """Records colour primvars that geometry in this content lacks (see :attr:`outer_colors`)."""
        self.outer_colors += [name for name in names if name not in self.outer_colors]


class _Context:
    """Where a walk is: the content being filled, how to reach its space, and what applies from outside."""

    def __init__(
        self,
        content: _Content,
        space_root: Usd.Prim | None = None,
        outer_material=None,
        world=False,
        outer_purpose=None,
        outer_forced=False,
        outer_color=None,
    ):
        self.content = content
        self.space_root = space_root  # transforms are relative to this prim (None: world / native prototype root)
        self.stop = space_root  # visibility and purpose are inherited from below this prim (None: everything)
        self.outer_material = outer_material  # material index bound above a native instance, or None
        self.outer_forced = outer_forced  # that binding is strongerThanDescendants: it wins over bindings inside
        self.outer_color = outer_color  # (primvar, (r, g, b)): constant colour inherited by a native instance, or None
        self.outer_purpose = outer_purpose  # a non-rendered purpose inherited by a native instance, or None
        self.world = world  # the stage itself (cameras and lights are read only here)


class _StageReader:
    """One pass over a stage; collects meshes, instances, cameras and lights and the warnings to emit."""

    def __init__(self, stage: Usd.Stage, source: str, time: Usd.TimeCode, segments: int = 0, refine_level: int = 0,
                 settings: RenderSettings | None = None):
        self.stage = stage
        self.settings = settings
        # Purposes drawn: the render settings' includedPurposes (default always), else default and render.
        self.purposes = settings.included_purposes if settings else _RENDERED_PURPOSES
        self.source = source
        self.time = time
        self.segments = segments  # > 0: gprims become meshes of this many segments per circle
        self.refine_level = refine_level  # Catmull-Clark steps for catmullClark meshes
        self.xforms = xform_cache(time, stage)  # sample-only transform ops read at their first sample (see above)
        self.contents = {}  # (kind, root path, outer material) -> _Content, each prototype read once
        self.reading = set()  # content keys being read (a prototype that contains itself is an error)
        # UsdShade materials and textures, read once each, bound by the settings' materialBindingPurposes if any.
        self.materials = MaterialReader(time, self._skip, settings.material_binding_purposes if settings else None)
        self.skel = SkelPoser(time, self._skip)  # poses meshes skinned by UsdSkel skeletons
        self.tubes = TubeReader(time, self._skip, self._error)  # Points and curves as spheres and tubes
        self.surfaces = SurfaceReader(time, self._skip, self._error)  # TetMesh and NurbsPatch as triangles
        self.skipped = {}  # reason -> [(prim path, detail or None)], reported once per reason at the end
        self.visibility = {}  # (prim path, stop path or None) -> no ancestor up to the stop is invisible
        self.prototype_cameras = {}  # native prototype path -> its cameras for hidden instances (_prototype_cameras)
        self.shown_prototypes = {}  # native prototype path -> the path it is shown at in messages (_shown_path)

    def _meters_per_unit(self) -> float:
        """The stage's ``metersPerUnit``; a value that is not a finite number above ``MIN_METERS_PER_UNIT`` (the depth
        of field divides by it) falls back to USD's own default, centimetres, with a warning."""
        value = float(UsdGeom.GetStageMetersPerUnit(self.stage))
        if math.isfinite(value) and value > MIN_METERS_PER_UNIT:
            return value
        fallback = float(UsdGeom.LinearUnits.centimeters)
        warnings.warn(f"{os.path.basename(self.source)}: metersPerUnit = {value:g} is not a finite number above "
                      f"{MIN_METERS_PER_UNIT:g}; using {fallback:g} (centimetres, USD's default)", stacklevel=4)
        return fallback

    def _up_axis(self) -> str:
        """The stage's ``upAxis``; anything but ``Y`` or ``Z`` (USD allows no other) falls back to ``Y``, USD's
        default, with a warning: an ``X`` stage was taken for Y-up without a word."""
        value = str(UsdGeom.GetStageUpAxis(self.stage))
        if value in ("Y", "Z"):
            return value
        warnings.warn(f"{os.path.basename(self.source)}: upAxis = {value!r} is not Y or Z; using Y (USD's default)",
                      stacklevel=4)
        return "Y"

    def read(self) -> Scene:
        scene = Scene(
            up_axis=self._up_axis(),
            meters_per_unit=self._meters_per_unit(),
            source=self.source,
            render_settings=self.settings,
        )
        self.scene = scene
        world = _Content("/")
        self._walk(self.stage.GetPseudoRoot(), _Context(world, world=True))
        scene.meshes = world.meshes
        scene.shapes = world.shapes
        inverses = self._place_instances(world, scene)
        scene.materials = self.materials.materials
        scene.textures = self.materials.textures
        if inverses is not None:
            scene.remember_instance_inverses(inverses)
        resolve_expressions(scene)  # linking collections in expression mode, against the paths drawn
        self._warn_skipped()
        return scene

    def _walk(self, root: Usd.Prim, ctx: _Context, predicate=Usd.PrimDefaultPredicate):
        """Reads the subtree at ``root`` into ``ctx.content`` (native instances are not entered: their prototype is
        read once, as its own content). The default predicate takes active, defined, loaded, concrete prims."""
        it = iter(Usd.PrimRange(root, predicate))
        for prim in it:
            try:
                self._read_prim(prim, it, ctx)
            except SceneError:
                raise
            except (Tf.ErrorException, ValueError, TypeError) as e:
                raise self._error(f"cannot read this prim ({_tf_message(e)})", prim) from e

    def _read_prim(self, prim: Usd.Prim, it, ctx: _Context):
        if prim.IsPseudoRoot() or prim.IsPrototype():
            return
        if prim.IsInstance() and not prim.IsA(UsdGeom.PointInstancer):
            # An instance of guide or proxy purpose is still read: a prototype prim of authored render purpose is
            # drawn, as USD computes purpose through instance proxies.
            if self._visible(prim, ctx.stop):
                purpose = self._purpose(prim, ctx)
                self._read_native_instance(prim, ctx, None if purpose in self.purposes else purpose)
                if prim.IsA(UsdGeom.Gprim) and purpose in self.purposes:
                    # A prototype holds only the instance's descendants (its root has no type and no properties):
                    # an instanceable mesh or gprim keeps its geometry on the instance prim, drawn as a prim of its own.
                    self._read_geometry(prim, ctx)
            else:
                # Cameras do not follow visibility (one under an invisible Xform is read): a hidden instance's are
                # read too, or a camera whose instance is hidden at some frame was missing from it.
                self._read_cameras(prim, self._prototype_cameras(prim.GetPrototype()), ctx)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.PointInstancer):
            # Its prototypes are drawn through the instancer only, so its subtree is not walked in place. An
            # instanceable instancer is read the same way: its prototypes are the instance proxies it targets (its
            # native prototype holds only those, not the instancer's own positions and indices).
            if self._rendered(prim, ctx):
                self._read_instancer(prim, ctx)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.Gprim):
            if self._rendered(prim, ctx):
                self._read_geometry(prim, ctx)
        elif prim.IsA(UsdProc.GenerativeProcedural):
            # Hydra's procedural plugins (hdGp) make its geometry in usdview and Karma; wrt has none to run.
            if self._rendered(prim, ctx):
                kind = prim.GetAttribute("primvars:hdGp:proceduralType")
                self._skip("GenerativeProcedural prims are not evaluated (wrt runs no procedural plugins); skipped",
                           prim, str(value_at(kind, self.time) or "no hdGp:proceduralType") if kind else None)
        elif prim.IsA(UsdGeom.Camera):
            self._read_cameras(prim, [Sdf.Path(".")], ctx)  # "." is the camera itself
        elif prim.IsA(UsdLux.DistantLight) or prim.HasAPI(UsdLux.LightAPI):
            if not ctx.world:
                self._skip("lights inside instance prototypes are not supported; skipped", prim)
            elif self._visible(prim):
                light = read_light(prim, self.xforms, self.time, self.scene.up_axis, self._skip)
                if light is not None:
                    self.scene.lights.append(light)

    def _read_geometry(self, prim: Usd.Prim, ctx: _Context):
        """Mesh or gprim ``prim`` into ``ctx.content``: a mesh, or an analytic shape (a mesh when tessellating)."""
        if prim.IsA(UsdGeom.Mesh) or prim.IsA(UsdGeom.TetMesh) or prim.IsA(UsdGeom.NurbsPatch):
            read = self._read_mesh if prim.IsA(UsdGeom.Mesh) else self._read_surface
            self._add_mesh(prim, read(prim, self._to_space(prim, ctx), ctx), ctx)
            return
        if prim.IsA(UsdGeom.Points) or prim.IsA(UsdGeom.Curves):
            self._not_a_mesh_light(prim, "Points and curves")
            self._read_tubes(prim, ctx)
            return
        if prim.HasAPI(UsdLux.VolumeLightAPI):
            self._skip("volume lights (VolumeLightAPI) are not supported: wrt has no volumes", prim, prim.GetTypeName())
        shape = self._read_gprim(prim, self._to_space(prim, ctx), ctx)
        if shape is not None and not self.segments and not invert_transforms(shape.to_world[None])[1][0]:
            # A zero scale (or one whose inverse is past float32) leaves no canonical space to intersect in: drawn
            # analytically the gprim vanished, while its tessellation, --accel warp and Storm draw it flat.
            self._skip(f"gprims with a singular transform (a zero scale) are drawn as triangle meshes of "
                       f"{DEFAULT_SEGMENTS} segments (flat), having no canonical space to intersect in", prim)
            self._add_mesh(prim, self._tessellated(shape, prim, DEFAULT_SEGMENTS), ctx)
        elif shape is not None and self.segments:
            self._add_mesh(prim, self._tessellated(shape, prim), ctx)
        elif shape is not None:
            self._not_a_mesh_light(prim, "gprims drawn analytically", "; load with tessellate_gprims=True to make "
                                   "them emit")
            ctx.content.shapes.append(shape)

    def _add_mesh(self, prim: Usd.Prim, mesh: Mesh | None, ctx: _Context):
        """Adds ``mesh`` (None: nothing), drawn for ``prim``, to ``ctx.content``, and its light when ``prim`` is a
        mesh light (MeshLightAPI, or LightAPI on another gprim) outside instances."""
        if mesh is None:
            return
        ctx.content.meshes.append(mesh)
        if not prim.HasAPI(UsdLux.LightAPI):
            return
        if not ctx.world:  # its triangles are not sampled, as emissive prototype triangles are not
            self._not_a_mesh_light(prim, "meshes inside instances")
            return
        light = read_light(prim, self.xforms, self.time, self.scene.up_axis, self._skip)
        if light is not None:
            sync_mesh_material(light, prim, mesh, self.materials, self._skip)
            self.scene.lights.append(light)

    def _not_a_mesh_light(self, prim: Usd.Prim, what: str, hint: str = ""):
        """Names ``prim`` in a warning when it has LightAPI (MeshLightAPI, VolumeLightAPI or LightAPI alone): it
        should emit, but wrt draws ``what`` as geometry that emits nothing (``hint``: what to do about it)."""
        if prim.HasAPI(UsdLux.LightAPI):
            self._skip(f"lights on {what} (LightAPI, MeshLightAPI) are not supported; drawn as geometry that emits "
                       f"nothing{hint}", prim, prim.GetTypeName())

    def _one_opacity(self, prim: Usd.Prim, one_per_prim: bool, keep_opaque: bool = False) -> float | None:
        """The ``displayOpacity`` of ``prim`` (its own or a constant inherited one) for prims drawn with the default
        material in one opacity (gprims, points, curves, tet meshes, NURBS patches): the mean of its values (see
        :func:`wrt.usd_primvars.unit_opacities`), as gprims take the mean displayColor, or None when it has none or
        is opaque (unless ``keep_opaque``, as :meth:`_read_opacities`). ``one_per_prim``: values that differ are named
        in a warning (their displayColor is read per element)."""
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("displayOpacity")
        if not (primvar and primvar.HasValue()):
            return None
        values = self._opacity_values(primvar)
        if values is None:
            self._skip("displayOpacity that is not an array of numbers was ignored", prim, str(primvar.GetTypeName()))
            return None
        if not len(values):
            return None
        values = unit_opacities(values, prim, self._skip)
        if one_per_prim and np.ptp(values) > 0.0:
            self._skip(f"{prim.GetTypeName()} prims are drawn in one opacity: the mean of their displayOpacity", prim,
                       primvar.GetInterpolation())
        mean = float(values.mean())
        return mean if mean < 1.0 or keep_opaque else None

    def _opacity_values(self, primvar) -> np.ndarray | None:
        """The flattened values of ``displayOpacity`` primvar ``primvar`` at the reader's time as float64 (maybe
        none), or None when they are not an array of numbers."""
        raw = primvar.ComputeFlattened(read_time(primvar.GetAttr(), self.time))
        values = np.asarray(raw if raw is not None else [])
        return values.astype(np.float64) if values.ndim == 1 and values.dtype.kind in "fiu" else None

    # Filters

    def _visible(self, prim: Usd.Prim, stop: Usd.Prim | None = None) -> bool:
        """No ancestor up to ``stop`` (or the root) invisible. Each visibility is read as mesh attributes are
        (``value_at``), so with ``time=None`` a prim hidden only by its first time sample is hidden, as its points are
        that sample's."""
        # Each prim's answer is kept (per stop): asking every prim of a deep hierarchy walked all its ancestors,
        # quadratic in the depth (a mesh under each of 1000 nested Xforms took 10 s).
        stop_path = stop.GetPath() if stop else None
        chain = []  # (key, prim) from prim up to the first ancestor already known, the stop or the root
        visible = True
        p = prim
        while p and p != stop and not p.IsPseudoRoot():
            key = (p.GetPath(), stop_path)
            known = self.visibility.get(key)
            if known is not None:
                visible = known
                break
            chain.append((key, p))
            p = p.GetParent()
        for key, p in reversed(chain):
            if visible:
                img = UsdGeom.Imageable(p)
                visible = not (img and value_at(img.GetVisibilityAttr(), self.time) == UsdGeom.Tokens.invisible)
            self.visibility[key] = visible
        return visible

    def _purpose(self, prim: Usd.Prim, ctx: _Context):
        """The purpose of ``prim``: its own or its nearest ancestor's authored purpose below ``ctx.stop``, else the
        one a native instance inherited (``ctx.outer_purpose``), else default."""
        if ctx.stop is None and ctx.outer_purpose is None:
            return UsdGeom.Imageable(prim).ComputePurpose()
        p = prim
        while p and p != ctx.stop and not p.IsPseudoRoot():
            img = UsdGeom.Imageable(p)
            attr = img.GetPurposeAttr() if img else None
            if attr is not None and attr.HasAuthoredValue():
                return attr.Get()
            p = p.GetParent()
        return ctx.outer_purpose or UsdGeom.Tokens.default_

    def _rendered(self, prim: Usd.Prim, ctx: _Context) -> bool:
        """Visible (below ``ctx.stop``) with a purpose drawn (default or render, or the render settings' own)."""
        return self._visible(prim, ctx.stop) and self._purpose(prim, ctx) in self.purposes

    # Transforms and instances

    def _to_space(self, prim: Usd.Prim, ctx: _Context) -> np.ndarray:
        """``(4, 4)`` row-vector (USD) transform from ``prim`` to the space of ``ctx``'s content."""
        if ctx.space_root is None:
            m = self.xforms.GetLocalToWorldTransform(prim)
        else:
            m, _ = self.xforms.ComputeRelativeTransform(prim, ctx.space_root)
        m = np.array(m, dtype=np.float64)
        if not np.all(np.isfinite(m)):
            raise self._error("world transform is not finite", prim)
        return m

    def _content(self, key: tuple, root: Usd.Prim, space_root, outer_material, outer_purpose=None,
                 outer_forced=False, outer_color=None) -> _Content:
        """The content of a prototype, read on first use."""
        if key not in self.contents:
            if key in self.reading:
                raise self._error("prototype contains an instance of itself", root)
            self.reading.add(key)
            content = _Content(str(root.GetPath()))
            # Prototypes are often kept under an ``over`` so they are not drawn in place; instanced, they are drawn
            # (as UsdImaging does), so "defined" is not asked of the prototype's ancestors.
            inside = _Context(content, space_root, outer_material, outer_purpose=outer_purpose,
                              outer_forced=outer_forced, outer_color=outer_color)
            self._walk(root, inside, _PROTOTYPE_PREDICATE)
            self.reading.discard(key)
            self.contents[key] = content
        return self.contents[key]

    def _moved(self, schema, positions: Usd.Attribute):
        """``positions`` (``points`` or a PointInstancer's ``positions``) of ``schema`` moved by its velocities and
        accelerations at this time (see :func:`wrt.usd_values.moved_positions`), or None to read them as they are."""
        velocities, accelerations = schema.GetVelocitiesAttr(), schema.GetAccelerationsAttr()
        return moved_positions(positions, velocities, accelerations, self.time, self.stage.GetTimeCodesPerSecond())

    def _read_native_instance(self, prim: Usd.Prim, ctx: _Context, purpose=None):
        """An instance of a native prototype; ``purpose``: the non-rendered purpose it inherits, if any."""
        prototype = prim.GetPrototype()
        if not prototype:
            self._skip("instances without a prototype were skipped", prim)
            return
        outer, forced = ctx.outer_material, ctx.outer_forced
        if not forced:
            material, binding = bound_material(prim, self.materials.purposes)  # as the meshes' own
            if material:
                outer = self.materials.material_index(material)
                # A strongerThanDescendants binding (on the instance or above it) overrides the prototype's own
                # bindings, as ComputeBoundMaterial on the instance proxies gives; it cannot be seen from inside.
                strength = UsdShade.MaterialBindingAPI.GetMaterialBindingStrength(binding)
                forced = strength == UsdShade.Tokens.strongerThanDescendants
        path = str(prototype.GetPath())
        if forced:
            key = ("native", path, outer, purpose, True, None)
            content = self._content(key, prototype, None, outer, purpose, outer_forced=True)
        else:
            key = ("native", path, None, purpose, False, None)
            content = self._content(key, prototype, None, None, purpose)
            if content.uses_outer and not material:
                ctx.content.uses_outer = True  # this instance's meshes take the material bound above its container
            if content.uses_outer and outer is not None:
                key = ("native", path, outer, purpose, False, None)
                content = self._content(key, prototype, None, outer, purpose)
        # A constant displayColor (or the colour primvar a material reads) on the instance or above it colours the
        # prototype's meshes that have none, as primvars are inherited through instance proxies (instances of one
        # prototype in different colours).
        own_color = self._inherited_color(prim, content.outer_colors)
        if own_color is None:
            ctx.content.want_colors(content.outer_colors)  # the colour may come from above this instance's container
        color = own_color if own_color is not None else ctx.outer_color
        if color is not None and color[0] in content.outer_colors:
            key = self._colored(key, content, color, prim)
        m = self._to_space(prim, ctx).T  # column vectors
        # A constant displayOpacity on the instance or above it is the opacity of the prototype's geometry that has
        # none: one value per instance (Instances.opacities), no copy of the prototype.
        opacity = self._inherited_opacity(prim)
        looks = None if opacity is None else _looks(None, np.array([opacity], np.float32))
        ctx.content.instances.append((key, m[None], str(prim.GetPath()), np.array([-1], np.int32), looks))
        self._read_cameras(prim, self.contents[key].cameras, ctx)

    def _inherited_color(self, prim: Usd.Prim, names: list[str]) -> tuple | None:
        """The constant colour primvar that native instance ``prim`` hands down to its prototype's meshes lacking
        one of ``names`` (the first of them it has): its own or its nearest ancestor's (up to the root of the
        prototype ``prim`` is in), as ``(name, (r, g, b))``, or None."""
        inherited = {str(p.GetPrimvarName()): p for p in UsdGeom.PrimvarsAPI(prim).FindInheritablePrimvars()}
        for name in names:
            primvar = inherited.get(name)
            if primvar is None:
                continue
            values = primvar.ComputeFlattened(read_time(primvar.GetAttr(), self.time))
            values = np.asarray(values if values is not None else [], np.float64).reshape(-1)
            if len(values) >= 3 and np.all(np.isfinite(values[:3])):
                return name, tuple(float(v) for v in values[:3])
            return None
        return None

    def _inherited_opacity(self, prim: Usd.Prim) -> float | None:
        """The constant ``displayOpacity`` native instance ``prim`` hands down to its prototype's geometry that has
        none (its own or its nearest ancestor's, as for :meth:`_inherited_color`; the mean of its values, see
        :func:`wrt.usd_primvars.unit_opacities`), or None."""
        inherited = {str(p.GetPrimvarName()): p for p in UsdGeom.PrimvarsAPI(prim).FindInheritablePrimvars()}
        primvar = inherited.get("displayOpacity")
        if primvar is None:
            return None
        values = self._opacity_values(primvar)
        if values is None or not len(values):
            return None
        return float(unit_opacities(values, prim, self._skip).mean())

    def _colored(self, key: tuple, content: _Content, color: tuple, prim: Usd.Prim) -> tuple:
        """The key of ``content`` (a native prototype read under ``key``) read again with inherited ``color``
        (``(primvar, (r, g, b))``); each colour is a copy of the prototype's geometry, so past
        :data:`MAX_INHERITED_COLORS` colours per prototype the instance keeps the prototype's own (with a warning)."""
        if color not in content.colors:
            if len(content.colors) >= MAX_INHERITED_COLORS:
                self._skip(f"instances inheriting more than {MAX_INHERITED_COLORS} colours per prototype keep "
                           "its own colours (each colour is a copy of the prototype)", prim)
                return key
            _, path, outer, purpose, forced, _ = key
            colored = ("native", path, outer, purpose, forced, color)
            self._content(colored, self.stage.GetPrimAtPath(path), None, outer, purpose, outer_forced=forced,
                          outer_color=color)
            content.colors[color] = colored
        return content.colors[color]

    def _read_cameras(self, prim: Usd.Prim, cameras: list, ctx: _Context):
        """The ``cameras`` at paths relative to ``prim`` (a camera itself, ``.``, or the cameras of native instance
        ``prim``, relative to its prototype): read when ``ctx`` is the world (at their instance-proxy paths,
        ``/Instance/Cam``, which USD places in the world), handed on to the native prototype being read (read
        through each of its instances), skipped with a warning inside a PointInstancer's prototype."""
        if not cameras:
            return
        if ctx.world:
            for relative in cameras:
                proxy = self.stage.GetPrimAtPath(prim.GetPath().AppendPath(relative))
                self.scene.cameras[str(proxy.GetPath())] = self._read_camera(proxy)
        elif ctx.space_root is None:
            here = prim.GetPath().MakeRelativePath(Sdf.Path(ctx.content.path))
            ctx.content.cameras += [here.AppendPath(relative) for relative in cameras]
        else:
            self._skip("cameras inside PointInstancer prototypes are not supported; skipped", prim)

    def _prototype_cameras(self, prototype: Usd.Prim) -> list:
        """Paths relative to ``prototype`` of the cameras in it and in the instances nested in it (as a read
        prototype's ``cameras``), without reading its geometry; none for an instance without a prototype."""
        if not prototype:
            return []
        key = prototype.GetPath()
        if key not in self.prototype_cameras:
            found = []
            it = iter(Usd.PrimRange(prototype, Usd.TraverseInstanceProxies(_PROTOTYPE_PREDICATE)))
            for p in it:
                if p.IsA(UsdGeom.PointInstancer):
                    it.PruneChildren()  # cameras in its prototypes are not read
                elif p.IsA(UsdGeom.Camera):
                    found.append(p.GetPath().MakeRelativePath(key))
            self.prototype_cameras[key] = found
        return self.prototype_cameras[key]

    def _read_instancer(self, prim: Usd.Prim, ctx: _Context):
        """Instances of a ``UsdGeom.PointInstancer`` (see the module docstring)."""
        pi = UsdGeom.PointInstancer(prim)
        t = self.time
        targets = pi.GetPrototypesRel().GetTargets()
        protos = []  # the prototype roots; None for one that is inactive or under an inactive prim
        for k, path in enumerate(targets):
            target = self.stage.GetPrimAtPath(path)
            if target and target.IsActive():
                protos.append(target)
            elif any(p and not p.IsActive() for p in map(self.stage.GetPrimAtPath, path.GetPrefixes())):
                protos.append(None)  # deactivated, as Hydra finds it: drawn nowhere (below, with a warning)
            else:
                raise self._error(f"prototypes[{k}] targets {path}, which does not exist", prim, None)
        raw = value_at(pi.GetProtoIndicesAttr(), t)
        proto_indices = np.asarray(raw if raw is not None else [], np.int64).reshape(-1)
        n = len(proto_indices)
        if n == 0:
            return
        bad = (proto_indices < 0) | (proto_indices >= len(protos))
        if bad.any():
            i = int(np.argmax(bad))
            raise self._error(
                f"protoIndices[{i}] = {proto_indices[i]} is out of range for {len(protos)} prototype(s)",
                prim,
                pi.GetProtoIndicesAttr(),
            )

        def per_instance(attr, width, name, default, value):
            if value is None or len(value) == 0:
                return None if default is None else np.tile(default, (n, 1))
            array = np.asarray(value, np.float64).reshape(len(value), -1)
            if array.shape != (len(value), width) or len(array) < n:
                raise self._error(f"{name} has {len(array)} entries; protoIndices has {n}", prim, attr)
            if not np.all(np.isfinite(array[:n])):
                i = int(np.argmax(~np.isfinite(array[:n]).all(axis=1)))
                raise self._error(f"{name}[{i}] is not finite", prim, attr)
            return array[:n]

        positions_attr, scales_attr = pi.GetPositionsAttr(), pi.GetScalesAttr()
        orient_attr = pi.GetOrientationsfAttr() if pi.GetOrientationsfAttr().HasValue() else pi.GetOrientationsAttr()
        moved = self._moved(pi, positions_attr)
        spun = spun_rotations(orient_attr, pi.GetAngularVelocitiesAttr(), t, self.stage.GetTimeCodesPerSecond())
        # With usable velocities or angular velocities USD holds every attribute at its sample at or before the
        # time and moves from there; without, it interpolates them all.
        read = held_value if moved is not None or spun is not None else value_at
        positions = per_instance(positions_attr, 3, "positions", None,
                                 moved if moved is not None else _value_if_any(positions_attr, t, read))
        if positions is None:
            raise self._error("positions is missing (PointInstancer needs one per protoIndices entry)", prim)
        quats = per_instance(orient_attr, 4, str(orient_attr.GetName()), np.array([0.0, 0.0, 0.0, 1.0]),
                             spun[0] if spun is not None else _value_if_any(orient_attr, t, read))
        scales = per_instance(scales_attr, 3, "scales", np.ones(3), _value_if_any(scales_attr, t, read))
        colors_by_name = {}  # colour primvar -> (n, 3) colours of the instances, or None
        opacities = self._instance_opacities(prim, n, read)

        # Column-vector instance transforms: translate(position) @ spin @ rotate(orientation) @ scale(scale).
        m = np.zeros((n, 4, 4))
        m[:, :3, :3] = _quat_to_matrix(quats) * scales[:, None, :]
        if spun is not None:
            m[:, :3, :3] = spun[1][:n] @ m[:, :3, :3]
        m[:, :3, 3] = positions
        m[:, 3, 3] = 1.0
        keep = np.ones(n, bool)
        # invisibleIds (and the ids it refers to) follow value_at's default-time rule, as positions do.
        mask = pi.ComputeMaskAtTime(read_time(pi.GetInvisibleIdsAttr(), t))
        if mask is not None and len(mask):
            if len(mask) < n:  # the mask has one entry per id: the instances past them have none
                raise self._error(f"ids has {len(mask)} entries; protoIndices has {n} (invisibleIds and inactiveIds "
                                  "name instances by id)", prim, pi.GetIdsAttr())
            keep &= np.asarray(mask, bool)[:n]
        to_space = self._to_space(prim, ctx).T @ m
        # The kept instances of each prototype in index order, from one stable sort (a scan of every instance per
        # prototype took 6 s for 10000 prototypes and 1M instances).
        kept = np.flatnonzero(keep)
        for path, target, group in zip(targets, protos, group_rows(proto_indices[kept], len(protos))):
            rows = kept[group]
            if len(rows) == 0:
                continue
            if target is None:
                self._skip("instances of inactive PointInstancer prototypes (or of prototypes under an inactive "
                           "prim) were skipped", prim, str(path))
                continue
            # The prototype's space is its parent's: the root's own transform is the most local part.
            key = ("pi", str(target.GetPath()), ctx.outer_material, ctx.outer_forced, ctx.outer_color)
            parent = target.GetParent()
            content = self._content(key, target, parent, ctx.outer_material, outer_forced=ctx.outer_forced,
                                    outer_color=ctx.outer_color)
            ctx.content.uses_outer |= content.uses_outer  # as for a nested native instance
            ctx.content.want_colors(content.outer_colors)
            name = self._instance_color_name(prim, content.outer_colors)
            if name not in colors_by_name:
                colors_by_name[name] = None if name is None else self._instance_colors(prim, n, read, name)
            looks = _looks(colors_by_name[name], opacities)
            ctx.content.instances.append((key, to_space[rows], str(prim.GetPath()), rows.astype(np.int32),
                                          None if looks is None else looks[rows]))

    def _instance_color_name(self, prim: Usd.Prim, wanted: list[str]) -> str | None:
        """The colour primvar of PointInstancer ``prim`` that colours its instances of a prototype whose geometry
        lacks the primvars ``wanted`` (``displayColor`` when it lacks none): the first of them it has, or None. An
        instance has one colour: where it has several of them, the others are ignored with a warning."""
        api = UsdGeom.PrimvarsAPI(prim)
        found = [name for name in wanted or ["displayColor"] if api.GetPrimvar(name).HasValue()]
        if len(found) > 1:
            self._skip("PointInstancers give one colour per instance: primvars past the first that their prototypes' "
                       "materials read were ignored", prim, ", ".join(found[1:]))
        return found[0] if found else None

    def _instance_colors(self, prim: Usd.Prim, n: int, read, name: str) -> np.ndarray | None:
        """``(n, 3)`` float32 colour of each of the ``n`` instances of PointInstancer ``prim``, from its colour
        primvar ``name`` (``displayColor``, or the one its prototypes' materials read; the rgb of a 4-vector one)
        (see :meth:`_instance_values`)."""
        values = self._instance_values(prim, n, read, name, (3, 4))
        if values is None:
            return None
        # NaN here would mean "no colour" (Instances.colors) and inf would shade as inf.
        return np.broadcast_to(finite_colors(np.array(values[:, :3], np.float32), prim, name, self._skip), (n, 3))

    def _instance_opacities(self, prim: Usd.Prim, n: int, read) -> np.ndarray | None:
        """``(n,)`` float32 ``displayOpacity`` of each of the ``n`` instances of PointInstancer ``prim`` (see
        :meth:`_instance_values`; NaN read as 1 and values clamped to [0, 1], as on meshes), or None without one."""
        if not UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayOpacity").HasValue():
            return None
        values = self._instance_values(prim, n, read, "displayOpacity", (1,))
        if values is None:
            return None
        return np.broadcast_to(unit_opacities(values.reshape(-1), prim, self._skip).astype(np.float32), (n,))

    def _instance_values(self, prim: Usd.Prim, n: int, read, name: str, widths: tuple) -> np.ndarray | None:
        """``(1 or n, k)`` float64 values of PointInstancer ``prim``'s primvar ``name``, ``k`` one of ``widths`` (an
        array of numbers has ``k = 1``): ``constant`` gives one value to all, ``vertex`` or ``varying`` one
        per instance (after its ``indices``), read by ``read`` as the positions are. None, with a warning naming it
        and what was expected, when it cannot be used: another type, interpolation, or a length other than ``n``."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
        raw = read(primvar.GetAttr(), self.time)
        values = np.asarray(raw if raw is not None else [], np.float64)
        if values.ndim == 1:  # an array of numbers
            values = values[:, None]
        unreadable = f"PointInstancer {name} that cannot be read was ignored"
        if values.ndim != 2 or values.shape[1] not in widths or primvar.GetElementSize() != 1:
            self._skip(unreadable, prim, f"{primvar.GetTypeName()} of elementSize {primvar.GetElementSize()}")
            return None
        if primvar.IsIndexed():  # flattened as ComputeFlattened does, at the same time as the values
            raw = read(primvar.GetIndicesAttr(), self.time)
            indices = np.asarray(raw if raw is not None else [], np.int64).reshape(-1)
            if np.any((indices < 0) | (indices >= len(values))):
                self._skip(unreadable, prim, f"indices out of range for {len(values)} values")
                return None
            values = values[indices]
        interpolation = primvar.GetInterpolation()
        expected = {"constant": (1, "1"), "vertex": (n, "one per instance"), "varying": (n, "one per instance")}
        if interpolation not in expected:
            self._skip(f"PointInstancer {name} of an interpolation other than constant, vertex or varying "
                       "was ignored", prim, interpolation)
            return None
        if len(values) != expected[interpolation][0]:
            count, meaning = expected[interpolation]
            self._skip(f"PointInstancer {name} of the wrong length was ignored", prim,
                       f"{interpolation} with {len(values)} values, expected {count} ({meaning})")
            return None
        return values

    def _place_instances(self, world: _Content, scene: Scene) -> np.ndarray | None:
        """Resolves nested instancing into ``scene.prototypes`` and one level of ``scene.instances``."""
        proto_ids, matrices, sources, source_ids, indices, colors_of = [], [], [], {}, [], []
        roots, root_ids, root_of = [], {}, []  # instance-proxy paths of the prototype roots (light_links)

        # Depth first, each instance before the instances nested in it (an explicit stack: a recursive closure
        # would refer to itself, a reference cycle that kept the stage open until a garbage collection). Each
        # entry carries the path its content's root is drawn at: a native instance's prim path (an instance proxy
        # path when nested), else the content's own path moved by the instance it is nested in.
        pending = [(self.contents[key], m, source, index, color, _drawn_root(key, source, self.contents[key].path))
                   for key, m, source, index, color in reversed(world.instances)]
        while pending:
            content, to_world, source, index, color, root = pending.pop()
            if content.meshes or content.shapes:
                if content.prototype < 0:
                    content.prototype = len(scene.prototypes)
                    scene.prototypes.append(Prototype(content.path, content.meshes, content.shapes))
                if source not in source_ids:
                    source_ids[source] = len(sources)
                    sources.append(source)
                if root not in root_ids:
                    root_ids[root] = len(roots)
                    roots.append(root)
                proto_ids.append(np.full(len(to_world), content.prototype, np.int32))
                matrices.append(to_world)
                indices.append(np.column_stack([np.full(len(to_world), source_ids[source]), index]))
                colors_of.append(color)
                root_of.append(np.full(len(to_world), root_ids[root], np.int32))
            for key, m, inner_source, _, inner in reversed(content.instances):
                # Nested instances keep the world-level source and index of the instance they are part of, and the
                # colour and opacity of the nearest instance that gives one.
                nested = self.contents[key]
                if nested.tube is None:
                    combined = (to_world[:, None] @ m[None]).reshape(-1, 4, 4)
                else:  # a Points or curves prim's spheres or tubes: round, as in a flattened copy of these instances
                    combined = place_round(to_world, m, *nested.tube)
                inner_root = part_path(_drawn_root(key, inner_source, nested.path), content.path, root)
                pending.append((nested, combined, source, np.repeat(index, len(m)),
                                _nested_looks(color, inner, len(to_world), len(m)), inner_root))
        if not proto_ids:
            return None
        # Instance order: world-level sources in stage order, a PointInstancer's instances in index order; the
        # instances nested inside one world-level instance stay together, in the order they were read.
        ids = np.concatenate(indices)
        order = np.lexsort((ids[:, 1], ids[:, 0]))  # stable
        ids = ids[order]
        to_world = np.concatenate(matrices)[order]
        projective = np.flatnonzero(np.any(to_world[:, 3] != (0.0, 0.0, 0.0, 1.0), axis=1))
        to_world[:, 3] = (0.0, 0.0, 0.0, 1.0)  # as for meshes: only the affine part is used
        colors, opacities = np.zeros((0, 3), np.float32), np.zeros(0, np.float32)  # none given: no arrays
        if any(c is not None for c in colors_of):  # NaN: instances without a colour or an opacity
            looks = np.concatenate([np.full((len(m), 4), np.nan, np.float32) if c is None else c
                                    for c, m in zip(colors_of, matrices)])[order]
            if not np.isnan(looks[:, :3]).all():
                colors = np.ascontiguousarray(looks[:, :3])
            if not np.isnan(looks[:, 3]).all():
                opacities = np.ascontiguousarray(looks[:, 3])
        instances = Instances(np.concatenate(proto_ids)[order], to_world, ids[:, 0], ids[:, 1], sources, colors,
                              roots, np.concatenate(root_of)[order], opacities)
        # Named once per USD instance: a Points or curves prim in it is an instance row per sphere or tube piece.
        for path in dict.fromkeys(instances.path(i) for i in projective):
            self._skip_path("world transform is projective; its last column was ignored", path)
        inverses, ok = invert_transforms(instances.to_world)
        for path in dict.fromkeys(instances.path(i) for i in np.flatnonzero(~ok)):
            self._skip_path("instances with a singular transform (a zero scale) were skipped", path)
        if not ok.all():
            instances = instances.take(ok)
        scene.instances = instances
        return inverses[ok]  # the scene's first trace needs them too

    # Meshes

    def _face_materials(self, prim: Usd.Prim, n_faces: int, ctx: _Context) -> np.ndarray | None:
        """``(F,)`` int32 material of each face of ``prim`` (-1: default), or None for none at all: its own bindings
        (:meth:`MaterialReader.face_materials`), and on the faces they leave unbound (all of them, or those outside
        its ``materialBind`` subsets) the material bound above the native instance being read; that one wins over
        its own when it is bound strongerThanDescendants."""
        own = None if ctx.outer_forced else self.materials.face_materials(prim, n_faces)
        if own is None:
            ctx.content.uses_outer = True
            return None if ctx.outer_material is None else np.full(n_faces, ctx.outer_material, np.int32)
        faces, unbound = own
        if unbound.any():
            ctx.content.uses_outer = True
            if ctx.outer_material is not None:
                faces = np.where(unbound, np.int32(ctx.outer_material), faces)
        return faces

    def _read_mesh(self, prim: Usd.Prim, m: np.ndarray, ctx: _Context) -> Mesh | None:
        """The mesh at ``prim`` with ``m`` (``(4, 4)`` row-vector transform to its content's space) baked in."""
        # Materials first: the texture-coordinate primvar to read depends on them.
        counts = self._int_array(prim, UsdGeom.Mesh(prim).GetFaceVertexCountsAttr())
        face_materials = self._face_materials(prim, len(counts), ctx)
        uv_set = self.materials.uv_set(face_materials, prim)
        color_names = self.materials.color_primvars(face_materials)
        default_faces = face_materials is None or bool(np.any(face_materials < 0))
        local = self._read_local_mesh(prim, counts, uv_set, color_names, default_faces, keep_opaque=not ctx.world)
        if local is None:
            return None
        # Smooth normals made from the cage are made again from the posed cage (as Storm does, which skins points
        # only): skinning the rest pose's normals left blend shapes' dents unshaded and joints' bends approximate.
        posed = self.skel.pose(prim, local.points, local.normals, local.vertex_ids, ctx.content.path)
        if posed is not None:
            # Skinned points are in the skeleton's space: the skeleton places them, not the mesh's own transform.
            local.points, local.normals, space = posed
            m = self._to_space(space, ctx)
        if local.refinement is not None:
            local.points = local.refinement.vertex(local.points)
        return self._bake(prim, m, ctx, local, face_materials, color_names)

    def _read_surface(self, prim: Usd.Prim, m: np.ndarray, ctx: _Context) -> Mesh | None:
        """A TetMesh (its boundary) or NurbsPatch (tessellated) at ``prim`` as a triangle mesh
        (:mod:`wrt.usd_surfaces`), with ``m`` (``(4, 4)`` row-vector transform to its content's space) baked in."""
        face_materials = self._face_materials(prim, 1, ctx)
        color_names = self.materials.color_primvars(face_materials)[:1]  # one material: one colour primvar
        if self.materials.uv_set(face_materials, prim):
            self._skip("TetMesh and NurbsPatch prims have no texture coordinates in wrt; left untextured", prim)
        points = self._point_array(prim)
        if points is None or len(points) == 0:
            return None
        primvar = _color_primvar(prim, color_names[0])
        primvar = primvar if primvar and primvar.HasValue() else None
        gprim = UsdGeom.Gprim(prim)
        flip = self._left_handed(prim, gprim, self.time)
        if prim.IsA(UsdGeom.TetMesh):
            surface = self.surfaces.tet_mesh(prim, points, primvar, flip)
        else:
            surface = self.surfaces.nurbs_patch(prim, points, primvar)
        if surface is None:
            return None
        cage = (np.full(len(surface.triangles), 3), surface.triangles.reshape(-1)) if surface.smooth else None
        double_sided = bool(value_at(gprim.GetDoubleSidedAttr(), self.time))
        colors = {} if surface.colors is None else {color_names[0]: surface.colors}
        default = face_materials is None or face_materials[0] < 0
        opacity = self._one_opacity(prim, True, not ctx.world) if default else None
        opacities = None if opacity is None else (np.array([opacity], np.float32), np.zeros_like(surface.triangles))
        local = _LocalMesh(surface.points, surface.triangles, surface.face_ids, flip, None, colors, double_sided,
                           cage=cage, opacities=opacities)
        return self._bake(prim, m, ctx, local, face_materials, color_names)

    def _bake(self, prim: Usd.Prim, m: np.ndarray, ctx: _Context, local: _LocalMesh, face_materials,
              color_names: list):
        """The :class:`Mesh` of ``local`` with ``m`` baked in; ``face_materials`` ``(F,)`` per source face or None."""
        if local.cage is not None:  # made from the final (posed) points, once
            local.normals = (vertex_normals(local.points, *local.cage, local.flip), local.vertex_ids)

        # Bake the transform (row-vector convention: p_world = p @ M[:3, :3] + M[3, :3]).
        if not np.allclose(m[:, 3], (0.0, 0.0, 0.0, 1.0)):
            self._skip("world transform is projective; its last column was ignored", prim)
        linear = m[:3, :3]
        points = local.points @ linear + m[3, :3]
        if not np.all(np.isfinite(points.astype(np.float32))):
            raise self._error("points are not finite after the world transform", prim)

        # A mirroring transform flips the winding just as leftHanded does; both together cancel.
        det = float(np.linalg.det(linear))
        flip = local.flip ^ (det < 0.0)
        order = _FLIP if flip else slice(None)
        indices = local.vertex_ids[:, order]

        normals = None
        if local.normals is not None:
            values, corner_index = local.normals
            # Normals transform by the inverse transpose; the sign-corrected cofactor matrix is the same up to
            # a positive scale and exists even for singular transforms.
            r0, r1, r2 = linear
            cofactor = np.stack([np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)])  # = det * inv(linear).T
            world = values @ (cofactor if det >= 0.0 else -cofactor)
            length = np.linalg.norm(world, axis=1, keepdims=True)
            good = np.isfinite(length) & (length > 0.0)
            world = np.where(good, world / np.where(good, length, 1.0), 0.0)  # zero where it cannot be normalised
            normals = world.astype(np.float32)[corner_index[:, order]]

        uvs = None
        if local.uvs is not None:
            values, corner_index = local.uvs
            uvs = values.astype(np.float32)[corner_index[:, order]]
        material_ids = None
        if face_materials is not None:
            material_ids = face_materials[np.clip(local.face_ids, 0, max(len(face_materials) - 1, 0))]
        colors = self._corner_colors(prim, local, color_names, material_ids, order, ctx)
        opacities = None
        if local.opacities is not None and (material_ids is None or bool(np.any(material_ids < 0))):
            values, corner_index = local.opacities
            opacities = values[corner_index[:, order]]

        return Mesh(
            path=str(prim.GetPath()),
            points=points,
            indices=indices,
            face_ids=local.face_ids,
            normals=normals,
            colors=colors,
            double_sided=local.double_sided,
            uvs=uvs,
            material_ids=material_ids,
            opacities=opacities,
        )

    def _corner_colors(self, prim, local: _LocalMesh, names: list, material_ids, order, ctx: _Context):
        """``(T, 3, 3)`` float32 colours at the corners of the mesh's triangles (winding ``order``), or None: each
        triangle's from the colour primvar its material reads (``names``, :meth:`MaterialReader.color_primvars`; the
        first for triangles of materials that read none), NaN rows where the mesh has not got it. A primvar the mesh
        lacks is one its content wants from above (:meth:`_Content.want_colors`): a native instance's constant
        colour of that name (``ctx.outer_color``) fills it in."""
        found = {}
        for name in names:
            if name in local.colors:
                values, corner_index = local.colors[name]
                found[name] = values[corner_index[:, order]]
            elif not _has_color(prim, name):
                ctx.content.want_colors([name])
                if ctx.outer_color is not None and ctx.outer_color[0] == name:
                    found[name] = np.tile(np.asarray(ctx.outer_color[1], np.float32), (len(local.face_ids), 3, 1))
        if len(names) == 1 or not found:
            return found.get(names[0])
        # Each triangle shades with its material's primvar; those of materials that read none keep the first.
        colors = np.full((len(local.face_ids), 3, 3), np.nan, np.float32)
        for k in np.unique(material_ids):
            name = self.materials.color_primvar_of(int(k)) or names[0]
            if name in found:
                rows = material_ids == k
                colors[rows] = found[name][rows]
        return colors

    # Gprims

    def _read_gprim(self, prim: Usd.Prim, m: np.ndarray, ctx: _Context) -> Shape | None:
        """The analytic shape of gprim ``prim`` with ``m`` (``(4, 4)`` row-vector transform to its content's space)
        and USD's size parameters folded into its transform, or None (with a warning) when it is not supported."""
        t = self.time

        def bad_size(detail):
            self._skip("gprims with a zero, negative or non-finite size were skipped", prim, detail)

        def number(attr, name, zero_ok=False):
            value = value_at(attr, t)
            value = float(value) if value is not None else float("nan")
            if not (math.isfinite(value) and (value > 0.0 or (zero_ok and value == 0.0))):
                bad_size(f"{name} = {value:g}")
                return None
            return value

        def axis_of(schema):
            # Any other token ("x", say) used to be read as Z without a word; USD computes no extent for it.
            axis = str(value_at(schema.GetAxisAttr(), t) or "Z")
            if axis not in ("X", "Y", "Z"):
                self._skip("gprims with an axis other than X, Y or Z were skipped", prim, f"axis = {axis!r}")
                return None
            return axis_rotation(axis)

        params = np.array([1.0, 0.0, 0.0, 1.0])
        linear = None  # (3, 3) canonical space -> the prim's space, for shapes centred at its origin
        local = None  # (4, 4) canonical space -> the prim's space, else
        type_name = prim.GetTypeName()
        if type_name == "Sphere":
            r = number(UsdGeom.Sphere(prim).GetRadiusAttr(), "radius")
            kind, linear = "sphere", None if r is None else np.eye(3) * r
        elif type_name == "Cube":
            size = number(UsdGeom.Cube(prim).GetSizeAttr(), "size")
            kind, linear = "box", None if size is None else np.eye(3) * (size / 2.0)
        elif type_name in ("Cylinder", "Cone"):
            schema = UsdGeom.Cylinder(prim) if type_name == "Cylinder" else UsdGeom.Cone(prim)
            h, r = number(schema.GetHeightAttr(), "height"), number(schema.GetRadiusAttr(), "radius")
            kind = type_name.lower()
            axis = None if h is None or r is None else axis_of(schema)
            linear = None if axis is None else axis @ np.diag([r, r, h / 2.0])
        elif type_name == "Capsule":
            schema = UsdGeom.Capsule(prim)
            h, r = number(schema.GetHeightAttr(), "height", zero_ok=True), number(schema.GetRadiusAttr(), "radius")
            kind = "capsule"
            axis = None if h is None or r is None else axis_of(schema)
            linear = None if axis is None else axis @ (np.eye(3) * r)
            if linear is not None:
                params[0] = h / (2.0 * r)
        elif type_name in ("Cylinder_1", "Capsule_1"):
            schema = UsdGeom.Cylinder_1(prim) if type_name == "Cylinder_1" else UsdGeom.Capsule_1(prim)
            h = number(schema.GetHeightAttr(), "height", zero_ok=type_name == "Capsule_1")
            # One radius may be 0 (a Cylinder_1 that is a cone, a Capsule_1 ending in a point), not both.
            bottom = number(schema.GetRadiusBottomAttr(), "radiusBottom", zero_ok=True)
            top = number(schema.GetRadiusTopAttr(), "radiusTop", zero_ok=True)
            if bottom == 0.0 and top == 0.0:
                bad_size("radiusBottom = radiusTop = 0")
            elif None not in (h, bottom, top):
                axis = axis_of(schema)
                if axis is not None:
                    kind, local, params[0], params[1] = tapered_shape(type_name, h, bottom, top)
                    local = shape_transform(axis) @ local
        elif type_name == "Plane":
            schema = UsdGeom.Plane(prim)
            w, length = number(schema.GetWidthAttr(), "width"), number(schema.GetLengthAttr(), "length")
            kind = "plane"
            axis = None if w is None or length is None else axis_of(schema)
            linear = None if axis is None else axis @ np.diag([w / 2.0, length / 2.0, 1.0])
        else:
            self._skip("gprims of this type (volumes) are not drawn: wrt has no volume renderer; skipped", prim,
                       type_name)
            return None
        if local is None:
            if linear is None:
                return None
            local = shape_transform(linear)
        gprim = UsdGeom.Gprim(prim)
        if self._left_handed(prim, gprim, t):
            params[3] = -1.0
        to_world = m.T @ local
        if not np.allclose(m[:, 3], (0.0, 0.0, 0.0, 1.0)):
            self._skip("world transform is projective; its last column was ignored", prim)
            to_world[3] = (0.0, 0.0, 0.0, 1.0)

        material_id, primvar, color = self._gprim_look(prim, ctx)
        if primvar is not None:
            color = np.full(3, 0.5, np.float32)
            values = np.asarray(primvar.ComputeFlattened(t) or [], np.float64)
            values = values[:, :3] if values.ndim == 2 else values.reshape(-1, 3)  # the rgb of a color4f
            if len(values) and np.all(np.isfinite(values)):
                color = values.mean(axis=0).astype(np.float32)
        shape = Shape(
            path=str(prim.GetPath()),
            kind=kind,
            to_world=to_world,
            params=params,
            color=color,
            material_id=material_id,
            double_sided=bool(value_at(gprim.GetDoubleSidedAttr(), t)),
            opacity=self._one_opacity(prim, False, not ctx.world) if material_id < 0 else None,
        )
        # As for mesh points: a box past float32 made the scene's bounds infinite and the render refuse them.
        if not np.abs(world_boxes(*shape.local_bounds(), to_world[None])).max() <= np.finfo(np.float32).max:
            raise self._error("bounds are not finite after the world transform", prim)
        return shape

    def _gprim_look(self, prim: Usd.Prim, ctx: _Context) -> tuple:
        """``(material_id, primvar, color)`` of gprim ``prim``: its material (-1: the default), bound as a mesh's; the
        colour primvar that material reads (``displayColor`` by default) when ``prim`` has a value of it (its own or
        an inherited constant one), else None; and then the constant colour a native instance hands down, if any
        (``(3,)`` float32), else None (its material's constant, grey by default, or its instance's colour)."""
        material = self._face_materials(prim, 1, ctx)
        color_name = self.materials.color_primvars(material)[0]
        primvar = _color_primvar(prim, color_name)
        color = None
        if not (primvar and primvar.HasValue()):
            primvar = None
            ctx.content.want_colors([color_name])
            if ctx.outer_color is not None and ctx.outer_color[0] == color_name:
                color = np.asarray(ctx.outer_color[1], np.float32)
        return -1 if material is None else int(material[0]), primvar, color

    def _read_tubes(self, prim: Usd.Prim, ctx: _Context):
        """A ``Points`` or curves prim as instances of spheres and tube segments (:mod:`wrt.usd_tubes`), one
        content per shape, so it is placed (and nested in prototypes) like any instance."""
        counts = None
        if prim.IsA(UsdGeom.Curves):
            counts = self._int_array(prim, UsdGeom.Curves(prim).GetCurveVertexCountsAttr())
        points = self._point_array(prim)
        if points is None or len(points) == 0:
            if points is not None and counts is not None and counts.any():  # as meshes with faces but no points
                self._skip(f"{prim.GetTypeName()} prims with curves but no points were skipped", prim)
            return
        material_id, primvar, color = self._gprim_look(prim, ctx)
        # displayOpacity per point or curve is one per instance, as colours are; a single value is the shapes' own.
        per_element = self._opacity_per_element(prim) if material_id < 0 else None
        opacity = self._one_opacity(prim, True, not ctx.world) if material_id < 0 and not per_element else None
        m = self._to_space(prim, ctx)
        if not np.allclose(m[:, 3], (0.0, 0.0, 0.0, 1.0)):
            self._skip("world transform is projective; its last column was ignored", prim)
        groups, constant = self.tubes.read(prim, points, m.T, primvar, counts, per_element)
        axis = width_axis(m.T[:3, :3])
        color = constant if constant is not None else color
        double_sided = bool(value_at(UsdGeom.Gprim(prim).GetDoubleSidedAttr(), self.time))
        path = str(prim.GetPath())
        for group in groups:
            shape = Shape(path, group.kind, np.eye(4), group.params, color if group.colors is None else None,
                          material_id, double_sided, opacity)
            content = _Content(path)
            content.tube = (group.kind == "sphere", axis)
            if self.segments:
                content.meshes.append(self._tessellated(shape, prim))
            else:
                content.shapes.append(shape)
            key = ("tubes", path, len(self.contents))  # a content of its own, placed only by these instances
            self.contents[key] = content
            ctx.content.instances.append((key, group.to_space, path, group.index,
                                          _looks(group.colors, group.opacities)))

    def _opacity_per_element(self, prim: Usd.Prim):
        """The ``displayOpacity`` primvar of Points or curves ``prim`` when it gives a value per point or curve (an
        interpolation other than ``constant``; ``uniform`` on curves, not on Points, which are one element), else
        None."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayOpacity")  # inherited ones are constant
        if not (primvar and primvar.HasValue()):
            return None
        interpolation = primvar.GetInterpolation()
        one = interpolation == "constant" or (interpolation == "uniform" and prim.IsA(UsdGeom.Points))
        return None if one else primvar

    def _point_array(self, prim: Usd.Prim) -> np.ndarray | None:
        """``(n, 3)`` float64 ``points`` of a point-based prim (moved by its velocities where they apply), ``(0, 3)``
        when it has none, or None (with a warning) when they are not an array of 3-vectors."""
        schema = UsdGeom.PointBased(prim)
        raw = self._moved(schema, schema.GetPointsAttr())
        if raw is None:
            raw = value_at(schema.GetPointsAttr(), self.time)
        points = np.asarray(raw if raw is not None else np.zeros((0, 3)))
        if points.size == 0:
            return np.zeros((0, 3))
        if points.ndim != 2 or points.shape[1] != 3 or points.dtype.kind != "f":
            self._skip(f"{prim.GetTypeName()} prims whose points are not an array of 3-vectors were skipped", prim,
                       f"{self._authored_type(schema.GetPointsAttr())} holding {type(raw).__name__}")
            return None
        return points.astype(np.float64)

    def _tessellated(self, shape: Shape, prim: Usd.Prim, segments: int | None = None) -> Mesh:
        """``shape`` as a triangle mesh of ``segments`` (default ``self.segments``) segments per circle."""
        points, indices, normals = tessellate(shape, segments or self.segments)
        n = len(indices)
        if not np.all(np.isfinite(points.astype(np.float32))):
            raise self._error("points are not finite after the world transform", prim)
        return Mesh(
            path=shape.path,
            points=points,
            indices=indices,
            face_ids=np.arange(n, dtype=np.int32),
            normals=normals,
            colors=None if shape.color is None else np.broadcast_to(shape.color, (n, 3, 3)),
            double_sided=shape.double_sided,
            material_ids=None if shape.material_id < 0 else np.full(n, shape.material_id, np.int32),
            opacities=None if shape.opacity is None else np.full((n, 3), shape.opacity, np.float32),
        )

    # Meshes

    def _read_local_mesh(self, prim: Usd.Prim, counts: np.ndarray, uv_set: str | None,
                         color_names=("displayColor",), default_faces=True, keep_opaque=False) -> _LocalMesh | None:
        """The mesh at ``prim`` in its own space, ``counts`` its faceVertexCounts (read first for the materials), with
        texture coordinates ``uv_set``, colours from the primvars ``color_names`` it has, and its ``displayOpacity``
        when some faces have the default material (``default_faces``; ``keep_opaque``: see
        :meth:`_read_opacities`)."""
        mesh = UsdGeom.Mesh(prim)
        t = self.time
        face_indices = self._int_array(prim, mesh.GetFaceVertexIndicesAttr())
        raw_points = self._moved(mesh, mesh.GetPointsAttr())
        if raw_points is None:
            raw_points = value_at(mesh.GetPointsAttr(), t)
        if len(counts) == 0 and len(face_indices) == 0:
            return None  # no faces: nothing to draw (indices without counts are refused by _check_topology)
        if raw_points is None or np.asarray(raw_points).size == 0:
            self._skip("meshes with faces but no points were skipped", prim)
            return None
        points = np.asarray(raw_points)
        if points.ndim != 2 or points.shape[1] != 3 or points.dtype.kind != "f":
            self._skip(
                "meshes whose points are not an array of 3-vectors were skipped",
                prim,
                f"{self._authored_type(mesh.GetPointsAttr())} holding {type(raw_points).__name__}",
            )
            return None
        points = points.astype(np.float64)

        # Check the topology before using it.
        self._check_topology(prim, counts, face_indices, points)
        scheme = value_at(mesh.GetSubdivisionSchemeAttr(), t)
        refinement = self._refinement(prim, scheme, counts, face_indices, len(points))
        polygons = (counts, face_indices) if refinement is None else (refinement.counts, refinement.face_indices)
        try:
            tri_corners, face_ids = triangulate(*polygons)
        except ValueError as e:
            raise self._error(str(e), prim, mesh.GetFaceVertexCountsAttr()) from None
        if refinement is not None:
            face_ids = refinement.parent_face[face_ids]  # the control face each refined triangle comes from

        # Faces listed in holeIndices are not drawn; their indices and uniform primvar entries still count.
        holes = self._int_array(prim, mesh.GetHoleIndicesAttr())
        if len(holes):
            bad = (holes < 0) | (holes >= len(counts))
            if bad.any():
                i = int(np.argmax(bad))
                detail = f"holeIndices[{i}] = {holes[i]} for {len(counts)} faces"
                self._skip("holeIndices out of range were ignored", prim, detail)
            drawn = ~np.isin(face_ids, holes)
            tri_corners, face_ids = tri_corners[drawn], face_ids[drawn]
        vertex_ids = polygons[1][tri_corners]

        topology = (counts, face_indices, tri_corners, face_ids, len(points), refinement)
        # A refined surface makes its own normals (USD: authored normals do not apply to subdivision surfaces).
        normals = self._read_normals(prim, mesh, topology) if refinement is None else None
        colors = {name: found for name in color_names if (found := self._read_colors(prim, topology, name)) is not None}
        uvs = self._read_uvs(prim, topology, uv_set) if uv_set else None
        opacities = self._read_opacities(prim, topology, keep_opaque) if default_faces else None
        flip = self._left_handed(prim, mesh, t)
        smooth = normals is None and scheme in SMOOTH_SCHEMES
        cage = polygons if smooth else None  # its normals are made in _read_mesh, after any posing and refining
        double_sided = bool(value_at(mesh.GetDoubleSidedAttr(), t))
        return _LocalMesh(points, vertex_ids, face_ids, flip, normals, colors, double_sided, uvs, cage, refinement,
                          opacities)

    def _refinement(self, prim, scheme, counts, face_indices, n_points) -> Refinement | None:
        """The Catmull-Clark refinement of a ``catmullClark`` mesh at ``self.refine_level``, or None."""
        if not self.refine_level or scheme not in SMOOTH_SCHEMES:
            return None
        if scheme != "catmullClark":
            self._skip("loop subdivision is not implemented; these meshes are drawn as their control cage", prim)
            return None
        # Refused before refining: past the memory, numpy failed deep inside the refinement without naming the mesh
        # (or the system killed the load).
        quads = refined_quads(counts, self.refine_level)
        check_host_memory(quads * REFINED_QUAD_BYTES, f"{self.source}: {self._shown_path(prim)}: refine_level "
                          f"{self.refine_level} ({quads:,} quads)")
        mesh, t = UsdGeom.Mesh(prim), self.time
        creases = corners = None
        crease_indices = self._int_array(prim, mesh.GetCreaseIndicesAttr())
        if len(crease_indices):
            sharpness = value_at(mesh.GetCreaseSharpnessesAttr(), t)
            creases = (crease_indices, self._int_array(prim, mesh.GetCreaseLengthsAttr()),
                       np.asarray(sharpness if sharpness is not None else [], np.float64))
        corner_indices = self._int_array(prim, mesh.GetCornerIndicesAttr())
        if len(corner_indices):
            sharpness = value_at(mesh.GetCornerSharpnessesAttr(), t)
            corners = (corner_indices, np.asarray(sharpness if sharpness is not None else [], np.float64))
        boundary = value_at(mesh.GetInterpolateBoundaryAttr(), t) or "edgeAndCorner"
        if boundary == "none":
            self._skip("interpolateBoundary = none is drawn as edgeOnly (boundary faces kept)", prim)
        elif boundary not in ("edgeOnly", "edgeAndCorner"):  # USD does not check allowed tokens (as orientation)
            self._skip("interpolateBoundary is not none, edgeOnly or edgeAndCorner; read as edgeAndCorner", prim,
                       repr(boundary))
            boundary = "edgeAndCorner"
        corner_boundary = boundary == "edgeAndCorner"
        try:
            return Refinement(counts, face_indices, n_points, self.refine_level, creases, corners, corner_boundary)
        except ValueError as e:
            self._skip("creases or corners that do not fit the mesh were ignored", prim, str(e))
            return Refinement(counts, face_indices, n_points, self.refine_level, corner_boundary=corner_boundary)

    def _int_array(self, prim: Usd.Prim, attr: Usd.Attribute) -> np.ndarray:
        """``(N,)`` int64 value of an ``int[]`` topology attribute at the read time (empty when it has none).

        Raises:
            SceneError: the value authored is not a 1-D array of integers (``float[]`` would be truncated and
                ``string[] ["3"]`` parsed by numpy without a word).
        """
        value = value_at(attr, self.time)
        if value is None:
            return np.zeros(0, np.int64)
        array = np.asarray(value)
        if array.ndim != 1 or array.dtype.kind not in "iu":
            raise self._error(f"{attr.GetName()} must be int[], not {self._authored_type(attr)}", prim, attr)
        return array.astype(np.int64)

    def _check_topology(self, prim, counts, face_indices, points):
        mesh = UsdGeom.Mesh(prim)
        if len(counts) == 0:
            raise self._error(
                f"there are {len(face_indices)} faceVertexIndices but no faceVertexCounts",
                prim,
                mesh.GetFaceVertexCountsAttr(),
            )
        # Faces of 0, 1 or 2 vertices are valid topology (UsdGeom.Mesh.ValidateTopology) that draws nothing.
        bad = counts < 0
        if bad.any():
            f = int(np.argmax(bad))
            raise self._error(f"faceVertexCounts[{f}] = {counts[f]} is negative", prim, mesh.GetFaceVertexCountsAttr())
        total = int(counts.sum())
        if total != len(face_indices):
            raise self._error(
                f"faceVertexCounts sum to {total} but there are {len(face_indices)} faceVertexIndices",
                prim,
                mesh.GetFaceVertexCountsAttr(),
            )
        bad = (face_indices < 0) | (face_indices >= len(points))
        if bad.any():
            i = int(np.argmax(bad))
            raise self._error(
                f"faceVertexIndices[{i}] = {face_indices[i]} is out of range for {len(points)} points",
                prim,
                mesh.GetFaceVertexIndicesAttr(),
            )
        bad = ~np.isfinite(points).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise self._error(f"points[{i}] = {tuple(points[i].tolist())} is not finite", prim, mesh.GetPointsAttr())

    def _read_normals(self, prim, mesh, topology):
        """``(values (K, 3) float64, corner index (T, 3))`` from ``primvars:normals`` or ``normals``, or None."""
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
        if primvar and primvar.HasValue():
            return self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology)
        attr = mesh.GetNormalsAttr()
        if attr.HasValue():
            return self._read_primvar(prim, attr, mesh.GetNormalsInterpolation(), None, topology)
        return None

    def _read_colors(self, prim, topology, name: str):
        """``(values (K, 3) float32, corner index (T, 3))`` from colour primvar ``name`` (``displayColor``, or the
        one the mesh's material reads; its own or inherited, see :func:`_color_primvar`; the rgb of a 4-vector one),
        or None."""
        primvar = _color_primvar(prim, name)
        if not (primvar and primvar.HasValue()):
            return None
        width = 4 if "Vec4" in primvar.GetTypeName().cppTypeName else 3
        found = self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology, width)
        if found is None:
            return None
        values, corner_index = found
        return finite_colors(np.array(values[:, :3], np.float32), prim, name, self._skip), corner_index

    def _read_opacities(self, prim, topology, keep_opaque=False):
        """``(values (K,) float32, corner index (T, 3))`` from ``displayOpacity`` (its own or a constant inherited one;
        every interpolation and indexing as colours, see :func:`wrt.usd_primvars.unit_opacities` for bad values), or
        None when it has none or is 1 everywhere (opaque: nothing to carry), unless ``keep_opaque`` (a prototype's
        geometry: its own 1 wins over an instance's opacity, Instances.opacities)."""
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("displayOpacity")
        if not (primvar and primvar.HasValue()):
            return None
        found = self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology, 1)
        if found is None:
            return None
        values, corner_index = found
        values = unit_opacities(values[:, 0], prim, self._skip)
        return None if np.all(values >= 1.0) and not keep_opaque else (values.astype(np.float32), corner_index)

    def _read_uvs(self, prim, topology, uv_set: str):
        """``(values (K, 2) float64, corner index (T, 3))`` of texture-coordinate primvar ``uv_set`` (when missing:
        the mesh's only 2-vector primvar, if it has exactly one), or None."""
        api = UsdGeom.PrimvarsAPI(prim)
        primvar = api.GetPrimvar(uv_set)
        if not (primvar and primvar.HasValue()):
            candidates = [
                p for p in api.GetPrimvarsWithValues() if str(p.GetTypeName()).rstrip("[]") in ("texCoord2f", "float2")
            ]
            if len(candidates) != 1:
                reason = "meshes without the texture-coordinate primvar their material reads were left untextured"
                self._skip(reason, prim, uv_set)
                return None
            primvar = candidates[0]
        return self._read_primvar(prim, primvar.GetAttr(), primvar.GetInterpolation(), primvar, topology, components=2)

    def _read_primvar(self, prim, attr, interpolation, primvar, topology, components=3):
        """Reads a primvar of ``components``-vectors and maps it to triangle corners.

        Returns ``(values (K, components) float64, corner_index (T, 3) int64)`` so that ``values[corner_index]`` is
        the per-corner data, or None (with a warning) when the value is not an array of such vectors.
        """
        counts, face_indices, tri_corners, face_ids, n_points, refinement = topology
        name = attr.GetName()
        raw = value_at(attr, self.time)
        values = np.asarray(raw) if raw is not None else np.zeros((0, components))
        if components == 1 and values.ndim == 1:  # float[]: one-number elements
            values = values[:, None]
        if values.ndim != 2 or values.shape[1] != components or values.dtype.kind not in "fiu":
            self._skip(
                f"{name} values that are not an array of {components}-vectors were ignored",
                prim,
                f"{self._authored_type(attr)} holding {type(raw).__name__}",
            )
            return None
        values = values.astype(np.float64)
        if interpolation not in _INTERPOLATIONS:
            self._skip(f"{name} with unknown interpolation {interpolation!r} was ignored", prim)
            return None
        if primvar is not None and primvar.GetElementSize() != 1:
            self._skip(f"{name} with elementSize != 1 was ignored", prim)
            return None

        # Element ids: through the primvar's indices when it is indexed, else the values themselves.
        indices = None
        if primvar is not None and primvar.IsIndexed():
            raw_indices = value_at(primvar.GetIndicesAttr(), self.time)
            indices = np.asarray(raw_indices if raw_indices is not None else [], dtype=np.int64).reshape(-1)
        n_elements = len(indices) if indices is not None else len(values)
        what = "indices" if indices is not None else "values"

        needed = {
            "constant": (1, "1"),
            "uniform": (len(counts), "one per face"),
            "vertex": (n_points, "one per point"),
            "varying": (n_points, "one per point"),
            "faceVarying": (len(face_indices), "one per face-vertex"),
        }[interpolation]
        if n_elements != needed[0]:
            raise self._error(
                f"{name} has {n_elements} {what}; {interpolation} interpolation needs {needed[0]} ({needed[1]})",
                prim,
                attr,
            )

        if indices is not None:
            bad = (indices < 0) | (indices >= len(values))
            if bad.any():
                i = int(np.argmax(bad))
                raise self._error(
                    f"{name}:indices[{i}] = {indices[i]} is out of range for {len(values)} values", prim, attr
                )
        if refinement is not None and interpolation in ("vertex", "varying", "faceVarying"):
            # Per point or per face-vertex data of the control cage becomes data of the refined mesh.
            per_element = values if indices is None else values[indices]
            if interpolation == "faceVarying":
                return refinement.face_varying(per_element), tri_corners
            refine = refinement.vertex if interpolation == "vertex" else refinement.varying
            return refine(per_element), refinement.face_indices[tri_corners]

        # Element of each triangle corner.
        if interpolation == "constant":
            corner = np.zeros(tri_corners.shape, dtype=np.int64)
        elif interpolation == "uniform":
            corner = np.repeat(face_ids[:, None], 3, axis=1)
        elif interpolation == "faceVarying":
            corner = tri_corners
        else:
            corner = face_indices[tri_corners]
        if indices is not None:
            corner = indices[corner]
        return values, corner

    # Cameras and lights

    def _read_camera(self, prim: Usd.Prim) -> Camera:
        camera = UsdGeom.Camera(prim)
        time = self.time

        def number(attr):
            return float(value_at(attr, time))

        near, far = value_at(camera.GetClippingRangeAttr(), time)
        projection = str(value_at(camera.GetProjectionAttr(), time))
        if projection != UsdGeom.Tokens.orthographic:
            if projection != UsdGeom.Tokens.perspective:  # as UsdGeom.Camera.GetCamera reads it
                self._skip("cameras with an unknown projection are perspective", prim, f"projection = {projection!r}")
            projection = "perspective"
        try:
            return Camera(
                to_world=np.array(self.xforms.GetLocalToWorldTransform(prim), dtype=np.float64).T,  # column vectors
                focal_length=number(camera.GetFocalLengthAttr()),
                horizontal_aperture=number(camera.GetHorizontalApertureAttr()),
                vertical_aperture=number(camera.GetVerticalApertureAttr()),
                horizontal_aperture_offset=number(camera.GetHorizontalApertureOffsetAttr()),
                vertical_aperture_offset=number(camera.GetVerticalApertureOffsetAttr()),
                clipping_range=(float(near), float(far)),
                clipping_planes=[tuple(plane) for plane in value_at(camera.GetClippingPlanesAttr(), time) or []],
                projection=projection,
                fit="expandAperture",  # USD's fallback aspectRatioConformPolicy
                f_stop=number(camera.GetFStopAttr()),
                focus_distance=number(camera.GetFocusDistanceAttr()),
                exposure_scale=_exposure_scale(camera, number),
                path=str(prim.GetPath()),
            )
        except ValueError as e:
            raise self._error(f"invalid camera: {e}", prim) from None

    # Errors and warnings

    def _property_stack(self, attr: Usd.Attribute) -> list:
        """The property specs of ``attr`` at the read time, strongest first (empty when USD cannot give them)."""
        try:
            return attr.GetPropertyStack(self.time)
        except Tf.ErrorException:
            return []

    def _authored_type(self, attr: Usd.Attribute) -> str:
        """The value type ``attr`` is authored with: a schema attribute's type name is the schema's whatever was
        authored (``float[] points`` read as ``point3f[]``, ``float3 points`` too); its strongest spec holds the
        authored one."""
        stack = self._property_stack(attr)
        return str(stack[0].typeName) if stack else str(attr.GetTypeName())

    def _error(self, message: str, prim: Usd.Prim, attr: Usd.Attribute | None = None) -> SceneError:
        """A SceneError naming the file and the prim, plus the layer the bad value is authored in if different."""
        if attr is not None:
            stack = self._property_stack(attr)
            root = self.stage.GetRootLayer()
            if stack and stack[0].layer != root:
                message += f" (authored in {stack[0].layer.identifier})"
        return SceneError(message, path=self.source, prim=self._shown_path(prim))

    def _left_handed(self, prim: Usd.Prim, gprim: UsdGeom.Gprim, t: Usd.TimeCode) -> bool:
        """Whether ``orientation`` is leftHanded. Any other token is read as USD's fallback, rightHanded, and named
        in a warning: USD does not check allowed tokens, so a misspelt leftHanded would flip every face unseen."""
        value = value_at(gprim.GetOrientationAttr(), t)
        if value not in (UsdGeom.Tokens.rightHanded, UsdGeom.Tokens.leftHanded):
            self._skip("orientation is neither rightHanded nor leftHanded; read as rightHanded", prim, repr(value))
        return value == UsdGeom.Tokens.leftHanded

    def _skip(self, reason: str, prim: Usd.Prim, detail: str | None = None):
        """Records a prim left out (or data ignored) for ``reason``; ``detail`` is tallied in the warning."""
        self._skip_path(reason, self._shown_path(prim), detail)

    def _shown_path(self, prim: Usd.Prim) -> str:
        """The path that names ``prim`` in errors and warnings, as usdview shows it: inside a native instance's
        prototype (``/__Prototype_1/Tri``, a name USD makes up per opening that no file holds), its proxy in the
        prototype's first drawn instance (``/A/Tri``; nested instances resolved the same way)."""
        path = str(prim.GetPath())
        if not prim.IsInPrototype():
            return path
        root = prim
        while not root.IsPrototype():
            root = root.GetParent()
        key = str(root.GetPath())
        if key not in self.shown_prototypes:
            instances = root.GetInstances()
            first = min(instances, key=lambda p: (p.IsAbstract(), str(p.GetPath()))) if instances else None
            self.shown_prototypes[key] = self._shown_path(first) if first else key
        return self.shown_prototypes[key] + path[len(key):]

    def _skip_path(self, reason: str, path: str, detail: str | None = None):
        self.skipped.setdefault(reason, []).append((path, detail))

    def _warn_skipped(self):
        """One warning per reason, with the count, a tally of details and the first few prim paths."""
        for reason, found in self.skipped.items():
            tally = {}
            for _, detail in found:
                if detail is not None:
                    tally[detail] = tally.get(detail, 0) + 1
            kinds = f" ({', '.join(f'{k}: {n}' for k, n in tally.items())})" if tally else ""
            paths = [p for p, _ in found]
            shown = ", ".join(paths[:3]) + (", ..." if len(paths) > 3 else "")
            warnings.warn(f"{self.source}: {reason}: {len(paths)} prim(s){kinds}: {shown}", stacklevel=4)


# Subdivision surfaces without authored normals are shaded with smooth vertex normals of their control cage, as
# usdview (Storm) draws them below its refinement levels; "none" and "bilinear" meshes keep their face normals.
SMOOTH_SCHEMES = ("catmullClark", "loop")


def vertex_normals(points: np.ndarray, counts: np.ndarray, face_indices: np.ndarray, left_handed: bool) -> np.ndarray:
    """``(V, 3)`` smooth normal of every point: the sum, over the polygon corners at it, of the cross product of the
    corner's two edges (each face weighted by its area near the point), normalised; zero where they cancel."""
    counts = counts.astype(np.int64)
    starts = np.cumsum(counts) - counts
    face = np.repeat(np.arange(len(counts)), counts)
    first, count = starts[face], counts[face]
    position = np.arange(len(face_indices)) - first
    corner = points[face_indices]
    following = points[face_indices[first + (position + 1) % count]]
    preceding = points[face_indices[first + (position - 1) % count]]
    normals = np.zeros_like(points)
    np.add.at(normals, face_indices, np.cross(following - corner, preceding - corner))
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 0.0, normals / np.where(length > 0.0, length, 1.0), 0.0)
    return -normals if left_handed else normals


def _exposure_scale(camera: UsdGeom.Camera, number) -> float:
    """USD's ``ComputeLinearExposureScale`` of ``camera``, its attributes read by ``number`` (at the loader's time).
    In float64 without exceptions: an fStop of 0 or a huge exposure gives inf, which the Camera then refuses."""
    with np.errstate(all="ignore"):
        stops, fstop = np.float64(number(camera.GetExposureAttr())), np.float64(number(camera.GetExposureFStopAttr()))
        return float(np.exp2(stops) * number(camera.GetExposureTimeAttr()) * number(camera.GetExposureIsoAttr())
                     / 100.0 * number(camera.GetExposureResponsivityAttr()) / (fstop * fstop))


def _color_primvar(prim: Usd.Prim, name: str) -> UsdGeom.Primvar:
    """Colour primvar ``name`` (``displayColor``, ...) of ``prim``: its own when authored, else a constant one of its
    nearest ancestor that has one (USD's primvar inheritance, which usdview follows: a colour set on a group colours
    its meshes)."""
    return UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)


def _has_color(prim: Usd.Prim, name: str) -> bool:
    """``prim`` has colour primvar ``name`` of its own or inherits one inside its space (see
    :func:`_color_primvar`)."""
    primvar = _color_primvar(prim, name)
    return bool(primvar and primvar.HasValue())


def _value_if_any(attr: Usd.Attribute, time: Usd.TimeCode, read):
    """``read(attr, time)`` (:func:`value_at` or :func:`held_value`), or None when ``attr`` has no value."""
    return read(attr, time) if attr.HasValue() else None


def _drawn_root(key: tuple, source: str, content_path: str) -> str:
    """Where the root of the content placed under ``key`` by prim ``source`` is drawn, in the namespace of the
    content holding ``source``: a native instance's own path (its prototype root lies there); a PointInstancer's
    prototype, or the shapes of a Points or curves prim, stay where they are."""
    return source if key[0] == "native" else content_path


def _looks(colors: np.ndarray | None, opacities: np.ndarray | None) -> np.ndarray | None:
    """``(K, 4)`` float32 per-instance colour ``(K, 3)`` and opacity ``(K,)`` side by side, NaN for the one that is
    None; None when both are."""
    if colors is None and opacities is None:
        return None
    n = len(colors if colors is not None else opacities)
    looks = np.full((n, 4), np.nan, np.float32)
    if colors is not None:
        looks[:, :3] = colors
    if opacities is not None:
        looks[:, 3] = opacities
    return looks


def _nested_looks(outer: np.ndarray | None, inner: np.ndarray | None, n_outer: int, n_inner: int):
    """``(n_outer * n_inner, 4)`` colours and opacities (:func:`_looks`) of the instances nested ``n_inner`` in each
    of ``n_outer`` outer instances, in the order of their combined transforms (outer major): the inner instance's
    (``inner``, one row per nested instance), else the outer instance's (``outer``, one row per outer instance),
    colour and opacity each, NaN where neither gives one; None when neither has any."""
    if outer is None and inner is None:
        return None
    rows = n_outer * n_inner
    outer_rows = np.full((rows, 4), np.nan, np.float32) if outer is None else np.repeat(outer, n_inner, axis=0)
    if inner is None:
        return outer_rows
    inner_rows = np.tile(inner, (n_outer, 1))
    return np.where(np.isnan(inner_rows), outer_rows, inner_rows)


def _quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` rotation matrices (column vectors) of ``(N, 4)`` quaternions stored ``(i, j, k, real)`` as
    ``Gf.Quat*`` arrays are; normalised first, so every result is a rotation. USD's own instance transforms
    (``ComputeInstanceTransformsAtTime``) use the quaternion as stored: for ``quath`` orientations, unit length only
    to half precision, the two differ by up to about 2e-4 of the instance's size."""
    q = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-30)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )


__all__ = ["load_usd", "triangulate"]
