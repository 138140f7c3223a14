"""Reads a USD stage into a :class:`wrt.scene.Scene`: world-space triangles, materials, cameras and lights.

:func:`load_usd` walks the stage in pre-order, keeps every visible ``UsdGeom.Mesh`` whose purpose is ``default`` or
``render`` (or one the render settings' ``includedPurposes`` list: :mod:`wrt.render_settings`), triangulates its faces
with :func:`triangulate` (fans; concave faces ear-clipped by :mod:`wrt.polygons`; leaving out ``holeIndices``), bakes
the world transform into the points, and carries shading normals, ``displayColor`` and ``displayOpacity`` (its own, else
a constant one inherited from an ancestor; opacity for the default material only), texture coordinates and the bound
material (:mod:`wrt.materials`) per triangle. UsdLux lights, mesh lights (``MeshLightAPI``) too, are read by
:mod:`wrt.usd_lights`; meshes skinned by a UsdSkel skeleton are posed by :mod:`wrt.usd_skel`. A mesh whose topology
``UsdGeom.Mesh.ValidateTopology`` refuses, or accepts with negative counts that the others make up for, is skipped
with a warning naming the file, the prim and what is wrong;
topology of another type than ``int[]`` and points that are not finite raise :class:`wrt.errors.SceneError` naming
the file and the prim; things that are skipped but a user might expect to see (unsupported gprims, lights or
shaders) produce one warning each.

Gprims (:mod:`wrt.primitives`): ``UsdGeom.Sphere`` (``radius``), ``Cube`` (``size``), ``Cylinder`` and ``Cone``
(``height``, ``radius``, ``axis``; capped), ``Capsule`` (``height`` of the cylindrical part, ``radius``, ``axis``),
``Plane`` (``width``, ``length``, ``axis``, ``doubleSided``) and the tapered ``Cylinder_1`` and ``Capsule_1``
(``height``, ``radiusBottom``, ``radiusTop``, ``axis``; see :func:`wrt.primitives.tapered_shape`) become analytic
shapes intersected in their own space,
with ``displayColor`` (constant; other interpolations use the mean), material binding, ``doubleSided`` and
``orientation``. With ``tessellate_gprims`` they become triangle meshes instead (vertices on the surface, analytic
vertex normals; see :func:`wrt.primitives.tessellate`); one that emits (a mesh light, or bound to a material that
glows) is always such a mesh, inside instances too, as light sampling draws points on triangles. Gprims whose size is
zero, negative or not finite are skipped with a warning (one radius of a ``Cylinder_1`` or ``Capsule_1`` may be 0),
and so are volumes (the gprim types left); one whose world box is past float32's range raises, as mesh points do,
and one flattened into a plane by a zero scale is drawn thin (:func:`wrt.instancing.thicken_flat_transforms`).
``Points`` and curves (``BasisCurves``, ``HermiteCurves``, ``NurbsCurves``) become instances of spheres and tube pieces
(:mod:`wrt.usd_tubes`), each shape a content of its own; ``TetMesh`` (its boundary) and ``NurbsPatch``
(tessellated) become meshes (:mod:`wrt.usd_surfaces`).

Instancing (:mod:`wrt.instancing`): native instances (``instanceable`` prims) and ``UsdGeom.PointInstancer``
instances are not flattened. Each native prototype and each prim a PointInstancer's ``prototypes`` relationship
targets is read once, in its own space, into a ``Scene.prototypes`` entry, and every instance becomes one row of
``Scene.instances`` (prototype index and 4x4 transform). Nesting (instancers and instances inside prototypes, at any
depth) is resolved into that single level. PointInstancers read ``protoIndices``, ``positions``, ``orientations``
(or ``orientationsf``), ``scales``, ``invisibleIds`` and ``inactiveIds`` (masked as ``ComputeMaskAtTime`` masks,
with ``ids`` read by the same time rule as ``invisibleIds``); the instance transform is
``translate(position) * rotate(orientation) * scale(scale)`` after the prototype root's own transform
(``IncludeProtoXform``), as ``ComputeInstanceTransformsAtTime`` computes it. Between and beyond time samples,
``positions`` (and a mesh's ``points``) with ``velocities`` (and ``accelerations``) authored at the same samples are
the earlier sample moved by them, and orientations with ``angularVelocities`` the earlier sample turned by them, as
USD computes it; then every per-instance attribute is held at its earlier sample (USD's velocity path), and without
either they are all interpolated. A ``protoIndices`` entry out of range or a prototype target that does not exist skip
those instances with a warning naming the instancer (``protoIndices`` not ``int[]``, ``ids`` of another length than
``protoIndices`` where a mask uses them, or ``positions`` missing, blocked, shorter or longer: the instancer draws
nothing, with a warning, as USD computes no
instance; ``orientations`` or ``scales`` shorter: read as unauthored, with a warning); instances flattened into a plane
by a zero scale are drawn flat (:func:`wrt.instancing.thicken_flat_transforms`), those scaled to a line or a point are
skipped with a warning naming each one (``/instancer[index]``), and so are the instances of an inactive prototype (or
one under an inactive prim). Visibility inside a PointInstancer's prototype is taken from the prototype root down (the
scope holding the prototypes is often made invisible so they are not drawn in place), as UsdImaging takes it; purpose is
inherited through the prototype's ancestors too, as ``ComputePurpose`` and UsdImaging compute it. A
native prototype's prims bind as their instance proxies do: each binding purpose's walk inside the prototype goes
on through the instance and its ancestors (:mod:`wrt.usd_bindings`; a prototype is read again for instances whose
bindings change a walk inside), then the meshes' rule (:func:`wrt.materials.bound_material`) picks the purpose.
A constant ``displayColor`` on or above a native instance colours the prototype's meshes and gprims that have none
(a copy of the prototype per colour, up to ``MAX_INHERITED_COLORS``).
A PointInstancer's ``primvars:displayColor`` (``constant``, or ``vertex``/``varying``: one per instance, flattened
through its indices, read as ``positions`` are) becomes ``Instances.colors`` instead, no copy per colour: it colours
the prototype meshes and gprims that have no displayColor of their own at shading time; instances nested in a
coloured one take the colour of the nearest instancer that gives one. Other interpolations and other lengths are
ignored with a warning naming the instancer. Where a material reads another colour primvar
(:meth:`wrt.materials.MaterialReader.color_primvars`), the colours of the faces bound to it come from that primvar
instead (each face from its own material's), and all of the above (inheritance, native instances, PointInstancer
primvars) applies to it in place of ``displayColor``.
Cameras inside native instances are read at their instance-proxy paths
(``/Instance/Cam``, placed by the instance), in invisible instances too, as cameras under invisible prims are; UsdLux
lights inside them likewise, one light per visible instance (the paths ``UsdLux.LightListAPI.ComputeLightList``
lists). UsdLux lights inside PointInstancer prototypes are one light per drawn instance, read as the light authored at
the instance's world transform (:meth:`_read_placed_lights`); cameras there are skipped with a warning. Mesh lights
inside any prototype are each one light for all of its instances (:func:`wrt.light_table.emitter_triangles` samples
each instance's copy).

Time: ``time=None`` reads ``Usd.TimeCode.Default()``. A mesh attribute (or a visibility) that has no authored
default value but has time samples is read at its earliest sample instead, so meshes animated from frame 1 still
load, and a prim hidden at frame 1 stays hidden. Transforms and cameras get the same fallback, op by op and
attribute by attribute (:mod:`wrt.usd_xforms`), so a camera animated only through time samples is where its first
frame puts it rather than at the origin, and an op that authors a default beside its samples gives the default. An
``xformOpOrder`` naming an op that does not exist, or that is no transform op, is read as USD reads it (that op left
out, with a warning), for every prim placed and its ancestors.

This module holds :func:`load_usd` and the prim walk (``_StageReader``: which reader each prim goes to, transforms to
a content's space, prototypes read once); the reader's parts live in modules of their own: :mod:`wrt.usd_stage`
(opening, stage-wide checks), :mod:`wrt.usd_problems` (errors and warnings), :mod:`wrt.usd_visibility` (visibility
and purpose), :mod:`wrt.usd_ancestors` (inherited primvars, purposes and bindings, each prim's answer kept),
:mod:`wrt.usd_attributes` (checked attribute reads), :mod:`wrt.usd_meshes`,
:mod:`wrt.usd_mesh_primvars` and :mod:`wrt.usd_bake` (meshes), :mod:`wrt.usd_gprims` (gprims, points and curves),
:mod:`wrt.usd_looks` (colours and opacities), :mod:`wrt.usd_contents`, :mod:`wrt.usd_native_instances` and
:mod:`wrt.usd_point_instancer` and :mod:`wrt.usd_instancer_primvars` (instancing), :mod:`wrt.usd_cameras`.
"""

from __future__ import annotations

import math
import numbers
import os
import warnings

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdProc, UsdShade

from .color_spaces import instance_spaces_kept
from .errors import SceneError, prim_path, user_stacklevel
from .instancing import invert_transforms, thicken_flat_transforms
from .light_links import resolve_expressions
from .lights import MeshLight
from .materials import MaterialReader, can_emit
from .primitives import DEFAULT_SEGMENTS, MAX_SEGMENTS, Shape
from .render_settings import RenderSettings, read_render_settings
from .scene import Mesh, Scene
from .subdivision import MAX_REFINE_LEVEL
from .usd_ancestors import KEEP_LOOKING, AncestorMemo, ComputedPurposes, InheritedPrimvars, PurposeVisibilities
from .usd_attributes import AttributeReading
from .usd_bake import MeshBaking
from .usd_bindings import CollectionsInside
from .usd_cameras import CameraReading, why_not_read
from .usd_contents import PROTOTYPE_PREDICATE, Content, Context, named, place_instances
from .usd_draw_modes import stand_in_draw_mode
from .usd_gprims import GprimReading
from .usd_lights import UNRENDERED_PURPOSE, LightTextures, read_light, warn_glowless_mesh_light
from .usd_looks import LookReading
from .usd_material_memo import MaterialMemo
from .usd_mesh_memo import MeshMemo
from .usd_mesh_primvars import MeshPrimvarReading, texture_coordinate_primvars
from .usd_meshes import MeshReading, triangulate
from .usd_native_instances import NativeInstanceReading
from .usd_placement_memo import PlacementMemo
from .usd_point_instancer import PointInstancerReading
from .usd_problems import NOT_FINITE_TRANSFORM, ProblemReport
from .usd_skel import SkelPoser
from .usd_stage import (
    check_time_in_range,
    held_diagnostics,
    open_stage,
    stage_meters_per_unit,
    stage_up_axis,
    tf_message,
    trap_usd_diagnostics,
    warn_composition_errors,
    warn_other_layer_units,
)
from .usd_surfaces import SurfaceReader
from .usd_tubes import TubeReader
from .usd_values import value_at
from .usd_variants import UNKNOWN_SELECTION, apply_variants, unknown_selections
from .usd_visibility import Visibility
from .usd_xforms import xform_cache

_RENDERED_PURPOSES = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)  # other purposes: guide, proxy


def load_usd(path, *, time=None, tessellate_gprims: bool | int = False, refine_level: int = 0, variants=None,
             render_settings: str | None = None) -> Scene:
    """Reads the meshes, gprims, instances, materials, cameras and lights of a USD stage.

    Args:
        path: a file USD can open (``.usd``, ``.usda``, ``.usdc``, ``.usdz``).
        time: the time code to read; ``None`` means ``Usd.TimeCode.Default()`` (see the module docstring for
            the fallback to the earliest time sample).
        tessellate_gprims: ``False``: gprims are analytic shapes; ``True``: triangle meshes of
            ``wrt.primitives.DEFAULT_SEGMENTS`` segments per circle; an int: that many segments (3 to 4096).
        refine_level: subdivision steps (0 to ``wrt.subdivision.MAX_REFINE_LEVEL``) applied to meshes by their
            ``subdivisionScheme``: Catmull-Clark for ``catmullClark`` (USD's fallback), Loop for ``loop`` (triangle
            meshes only), bilinear for ``bilinear``, as Hydra's refine level; each step makes four times the faces.
            0 draws the control cage, smooth-shaded, as usdview does at low complexity.
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
        TypeError: ``time`` is not None, a number or a ``Usd.TimeCode`` (a bool or a string), ``render_settings``
            is no prim path (an int, bytes), or ``variants`` is no dict of prim path -> {variant set: variant}.
        ValueError: ``time`` is not finite, ``tessellate_gprims`` is no bool or int from 3 to 4096, or
            ``refine_level`` no int from 0 to ``wrt.subdivision.MAX_REFINE_LEVEL``.

    Warns:
        UserWarning: the stage has composition errors (a reference, payload or subLayer that does not compose); the
            scene holds the rest.
    """
    return load_stage_at(path, time, tessellate_gprims, refine_level, variants, render_settings)


def load_stage_at(path, time, tessellate_gprims, refine_level, variants, render_settings, frames=None) -> Scene:
    """:func:`load_usd` with its options in order, the stage kept by ``frames`` (a
    :class:`wrt.usd_frames.StageFrames`, or None: opened for this load alone) with the meshes it reused."""
    try:
        # bytes name the file they encode, as open() reads them: kept as bytes, the source broke every message
        source = os.fsdecode(os.fspath(path))
    except TypeError:  # os.fspath's message named no argument
        raise TypeError(f"path must be a file path (str or os.PathLike), got {type(path).__name__}") from None
    if not str(source).strip():  # SceneError named no file: 'file not found'
        raise SceneError(f"the scene path {source!r} is empty; give a USD file")
    time_code = _time_code(time)
    if render_settings is not None:  # an int failed in Boost.Python's words, naming no argument
        render_settings = prim_path(render_settings, "load_usd: render_settings")

    if frames is None:
        stage = open_variants(source, variants)
    else:
        stage = frames.stage(source, variants)
    settings = read_render_settings(stage, source, render_settings, time_code)  # at the render's time
    if stage.GetTimeCodesPerSecond() <= 0:
        # usd-core hangs in time-sample queries on such stages; wrt never makes them, but say what was found.
        warnings.warn(f"{os.path.basename(source)}: timeCodesPerSecond = {stage.GetTimeCodesPerSecond():g} is invalid; "
                      "time samples are read only at their authored time codes", stacklevel=user_stacklevel())
    if not (time_code.IsDefault() or time_code.IsEarliestTime()):  # EarliestTime: the first samples, no time
        check_time_in_range(stage, source, time_code.GetValue())
    segments = _gprim_segments(tessellate_gprims)
    _check_refine_level(refine_level)
    reader = _StageReader(stage, source, time_code, segments, int(refine_level), settings,
                          *(() if frames is None else (frames.memo, frames.material_memo, frames.placement_memo)))
    try:
        with instance_spaces_kept():
            scene = reader.read()
        _name_unread_settings_cameras(scene, stage)
        scene._variants = variants  # to open the stage as it was read again: what_is_at (a camera it lacks)
        return scene
    finally:
        # The material reader, the skeleton poser and the transforms hold the stage reader's skip method: a cycle that
        # kept the stage and its layers open until the next garbage collection, so a file edited and loaded again in
        # that time read as before.
        reader.xforms = None
        reader.materials = None
        reader.skel = None
        reader.tubes = None
        reader.surfaces = None


def _name_unread_settings_cameras(scene: Scene, stage: Usd.Stage) -> None:
    """Keeps in ``scene.skipped_cameras`` why a Camera the render settings (or a product) render is not read (an
    inactive one, one in a PointInstancer's prototypes: :func:`wrt.usd_cameras.why_not_read`), which a render from
    it raises; it said only that the camera was not among the cameras wrt reads."""
    settings = scene.render_settings
    named = [] if settings is None else [settings.camera, *(product.camera for product in settings.products)]
    for path in dict.fromkeys(p for p in named if p is not None):
        if path not in scene.cameras and path not in scene.skipped_cameras:
            why = why_not_read(stage, path)
            if why is not None:
                scene.skipped_cameras[path] = f"the Camera at {path} is not read: {why}"


def open_variants(source: str, variants, posted: list | None = None) -> Usd.Stage:
    """The stage at ``source`` with ``variants`` selected (see :func:`load_usd`), its composition errors and layers
    in other units warned about. ``posted``: a list that gets the USD diagnostics the opening posted and USD then
    reports (:func:`wrt.usd_stage.held_diagnostics`), for a stage kept for frames to report them again."""
    with trap_usd_diagnostics() as trap:
        stage = open_stage(source)
        if variants:
            apply_variants(stage, source, variants)
        warn_composition_errors(stage, source, trap)
        if posted is not None:
            posted += held_diagnostics(trap)
    warn_other_layer_units(stage, source)
    return stage


def _time_code(time) -> Usd.TimeCode:
    """``load_usd``'s ``time`` as a time code: None is the default time; a ``Usd.TimeCode`` is kept; else a finite
    real number (int, float, numpy scalar). A bool or a string is refused, not read as a number: ``time=True`` and
    ``time="1"`` both loaded frame 1, hiding a caller's mistake.

    Raises:
        TypeError: ``time`` is not None, a ``Usd.TimeCode`` or a real number.
        ValueError: ``time`` is NaN or infinite (a number or a ``Usd.TimeCode``).
    """
    if time is None:
        return Usd.TimeCode.Default()
    if isinstance(time, Usd.TimeCode):
        # USD keeps an infinite time code (a NaN one is the default time); velocities moved the points to inf, and
        # the load failed naming a mesh's points, with numpy's overflow warning. EarliestTime (-DBL_MAX) is finite.
        if not (time.IsDefault() or math.isfinite(time.GetValue())):
            raise ValueError(f"time must be a finite time code or None, got {time}")
        return time
    if isinstance(time, (bool, np.bool_)) or not isinstance(time, numbers.Real):
        raise TypeError(f"time must be a number, a Usd.TimeCode or None, got {type(time).__name__} {time!r}")
    value = float(time)
    if not math.isfinite(value):
        raise ValueError(f"time must be a finite time code or None, got {time!r}")
    return Usd.TimeCode(value)


def _gprim_segments(tessellate_gprims) -> int:
    """Segments per circle of tessellated gprims for ``load_usd``'s ``tessellate_gprims``; 0: analytic shapes."""
    if isinstance(tessellate_gprims, np.bool_):  # mask[k]: refused as 'a bool or an int', got True
        tessellate_gprims = bool(tessellate_gprims)
    if tessellate_gprims is True:
        return DEFAULT_SEGMENTS
    if tessellate_gprims is False or tessellate_gprims is None:
        return 0
    if not isinstance(tessellate_gprims, (int, np.integer)) or not 3 <= tessellate_gprims <= MAX_SEGMENTS:
        raise ValueError(f"tessellate_gprims must be a bool or an int from 3 to {MAX_SEGMENTS}, got "
                         f"{tessellate_gprims!r}")
    return int(tessellate_gprims)


def _check_refine_level(refine_level) -> None:
    """Raises for a ``load_usd`` ``refine_level`` that is not an int from 0 to ``MAX_REFINE_LEVEL``."""
    if isinstance(refine_level, bool) or not isinstance(refine_level, (int, np.integer)) or not (
        0 <= refine_level <= MAX_REFINE_LEVEL
    ):
        raise ValueError(f"refine_level must be an int from 0 to {MAX_REFINE_LEVEL}, got {refine_level!r}")


def _is_mesh_light(prim: Usd.Prim) -> bool:
    """``prim`` (a mesh or gprim) emits from its surface: it has LightAPI (alone or through MeshLightAPI), but not as
    part of VolumeLightAPI, whose light fills the volume the surface bounds (wrt has no volumes: it is named)."""
    return prim.HasAPI(UsdLux.LightAPI) and not prim.HasAPI(UsdLux.VolumeLightAPI)


class _StageReader(ProblemReport, Visibility, AttributeReading, LookReading, MeshReading, MeshPrimvarReading,
                   MeshBaking, GprimReading, NativeInstanceReading, PointInstancerReading, CameraReading):
    """One pass over a stage; collects meshes, instances, cameras and lights and the warnings to emit. The walk is
    here; what it does with each kind of prim comes from the mixins of the ``wrt.usd_*`` modules (see the module
    docstring), which share this object's state."""

    def __init__(self, stage: Usd.Stage, source: str, time: Usd.TimeCode, segments: int = 0, refine_level: int = 0,
                 settings: RenderSettings | None = None, mesh_memo: MeshMemo | None = None,
                 material_memo: MaterialMemo | None = None, placement_memo: PlacementMemo | None = None):
        self.stage = stage
        self.settings = settings
        # Purposes drawn: the render settings' includedPurposes (default always), else default and render.
        self.purposes = settings.included_purposes if settings else _RENDERED_PURPOSES
        self.source = source
        self.time = time
        self.segments = segments  # > 0: gprims become meshes of this many segments per circle
        self.refine_level = refine_level  # subdivision steps for catmullClark, loop and bilinear meshes
        # Sample-only ops read at their first sample (see above); a kept stage's still transforms given again.
        self.xforms = xform_cache(time, stage, self._skip, placement_memo)
        self.contents = {}  # (kind, root path, outer material) -> Content, each prototype read once
        self.reading = set()  # content keys being read (instances of a prototype inside itself are skipped)
        # UsdShade materials and textures, read once each, bound by the settings' materialBindingPurposes if any.
        self.collections_inside = CollectionsInside(stage)  # collection bindings that reach into native instances
        self.skipped = []  # [(reason, prim path, detail or None)], reported once per reason at the end
        self.materials = MaterialReader(time, self._skip, settings.material_binding_purposes if settings else None,
                                        stage=self.stage, memo=material_memo, skipped=self.skipped)
        self.skel = SkelPoser(time, self._skip, self._shown_path)  # poses meshes skinned by UsdSkel skeletons
        self.tubes = TubeReader(time, self._skip, self._error)  # Points and curves as spheres and tubes
        self.surfaces = SurfaceReader(time, self._skip, self._error)  # TetMesh and NurbsPatch as triangles
        self.mesh_memo = mesh_memo  # meshes read at another time of this stage, reused where nothing differs
        self.visibility = {}  # (prim path, stop path or None) -> no ancestor up to the stop is invisible
        self.placement_memo = placement_memo  # visibility answers (and transforms) of a kept stage that cannot vary
        # ComputePurpose and FindPrimvarWithInheritance, each prim's answer kept (a deep hierarchy), a kept stage's
        # for all its loads (neither answer depends on the time).
        self.computed_purposes = ComputedPurposes() if placement_memo is None else placement_memo.purposes
        self.inherited_primvars = InheritedPrimvars() if placement_memo is None else placement_memo.primvars
        self.sibling_reads = {}  # native instances' content keys shared with their siblings (_sibling_key)
        self._transform_only_kept = (None, False)  # (path, answer) of the last prim _transform_only was asked about
        self.sibling_states = {}  # (parent, prototype, type) -> _instance_state of its transform-only instances
        # Whether a prim or an ancestor authors value clips (each prim's answer kept)
        self.clips_above = AncestorMemo(lambda p: True if p.HasAuthoredMetadata("clips") else KEEP_LOOKING, False)
        self._inheritable_kept = None  # (path, {name: primvar}) of the last prim _inheritable_primvars was asked for
        self.purpose_visibilities = PurposeVisibilities()  # UsdGeomVisibilityAPI's opinions, each prim's answer kept
        # native prototype path -> (whether a PointInstancer or a UsdGeomVisibilityAPI prim is in it, the purposes
        # authored in it, nested ones too, None with a PointInstancer in it): _prototype_contents
        self.prototype_contents = {}
        self.prototype_cameras = {}  # native prototype path -> its cameras for hidden instances (_prototype_cameras)
        self.prototype_lights = {}  # native prototype path -> its UsdLux lights, for hidden instances
        self.shown_prototypes = {}  # native prototype path -> (abstract, the path it is named by) (_prototype_name)
        self.prototype_instance_counts = {}  # native prototype path -> times it is on the stage (_instance_count)
        self.instanced_lights = {}  # prim path -> MeshLight of the mesh lights read inside prototypes
        self.glowing_materials = {}  # material id -> whether it emits (a pass over its emission texture, once)
        self.light_textures = LightTextures(material_memo)  # the images of light textures, each file read once
        # Shown paths of the UsdLux lights the walk met (hidden, skipped or read) and of the meshes bound to an emissive
        # material that were skipped: a stage whose author lit it gets no default lights, even where none of these
        # gives light (Scene.dark_lights).
        self.authored_lights = {}

    def read(self) -> Scene:
        scene = Scene(
            up_axis=stage_up_axis(self.stage, self.source),
            meters_per_unit=stage_meters_per_unit(self.stage, self.source),
            source=self.source,
            render_settings=self.settings,
        )
        self.scene = scene
        world = Content("/")
        self._walk(self.stage.GetPseudoRoot(), Context(world, world=True))
        others = {}  # mesh -> its texture-coordinate primvars (each instance proxy of it has the same)
        for prim, at, uv_set, fallback in dict.fromkeys(world.uv_misses):  # no instance handed them one
            if prim not in others:
                others[prim] = texture_coordinate_primvars(prim)
            self._missing_uvs_warning(prim, uv_set, fallback, str(at), others[prim])
        scene.meshes = world.meshes
        scene.shapes = world.shapes
        # Prototypes and what they hold are named by their first instance's proxies (_stable_path), not by USD's
        # numbering (/__Prototype_N), which differs per opening; inside, the reader keeps USD's paths.
        inverses = place_instances(world, self.contents, scene, self._skip_path, self._stable_path)
        scene.materials = [named(material, self._stable_path) for material in self.materials.materials]
        scene.textures = self.materials.textures
        if inverses is not None:
            scene.remember_instance_inverses(inverses)
        self._read_placed_lights(world)
        resolve_expressions(scene)  # linking collections in expression mode, against the paths drawn
        self._add_instanced_lights()
        if not scene.lights:
            scene.dark_lights = list(self.authored_lights)
        self._warn_skipped()
        return scene

    def _walk(self, root: Usd.Prim, ctx: Context, predicate=Usd.PrimDefaultPredicate):
        """Reads the subtree at ``root`` into ``ctx.content`` (native instances are not entered: their prototype is
        read once, as its own content). The default predicate takes active, defined, loaded, concrete prims."""
        it = iter(Usd.PrimRange(root, predicate))
        for prim in it:
            try:
                self._read_prim(prim, it, ctx)
            except SceneError:
                raise
            except (Tf.ErrorException, ValueError, TypeError) as e:
                raise self._error(f"cannot read this prim ({tf_message(e)})", prim) from e

    def _read_prim(self, prim: Usd.Prim, it, ctx: Context):
        if prim.IsPseudoRoot() or prim.IsPrototype():
            return
        if prim.IsA(UsdShade.Material):
            # Hydra populates none of a Material's descendants (UsdImagingMaterialAdapter represents itself and its
            # descendants: its shaders are read as the material), so a mesh, light or camera kept under one (a swatch)
            # is not drawn; wrt drew it.
            it.PruneChildren()
            held = [self._shown_path(p) for p in Usd.PrimRange(prim, Usd.TraverseInstanceProxies()) if _drawable(p)]
            if held:
                self._skip("prims under a Material are not drawn, as Hydra populates none of its descendants", prim,
                           ", ".join(held[:3]) + (f" and {len(held) - 3} more" if len(held) > 3 else ""))
            return
        if prim.IsA(UsdLux.DistantLight) or prim.HasAPI(UsdLux.LightAPI):
            self.authored_lights[self._shown_path(prim)] = None  # as UsdLux's ComputeLightList lists it: hidden too
        draw_mode = stand_in_draw_mode(prim)
        if draw_mode is not None:
            self._skip("models whose model:drawMode asks for a stand-in (cards, bounds or origin) were drawn as full "
                       "geometry (wrt draws no stand-ins)", prim, f"model:drawMode = {draw_mode}")
        for selection in unknown_selections(prim):
            self._skip(UNKNOWN_SELECTION, prim, selection)
        if prim.IsInstance() and not prim.IsA(UsdGeom.PointInstancer):
            if prim.IsA(UsdGeom.Camera):
                # An instanceable camera keeps its camera (its attributes are on the instance prim, not in the
                # prototype), hidden or not, before the cameras inside it, as an instanceable gprim keeps its geometry.
                self._read_cameras(prim, [Sdf.Path(".")], ctx)
            # An instance of guide or proxy purpose is still read: a prototype prim of authored render purpose is
            # drawn, as USD computes purpose through instance proxies.
            visible, purpose, hidden = self._instance_state(prim, ctx)
            if visible:
                self._read_native_instance(prim, ctx, purpose, hidden)
                if prim.IsA(UsdGeom.Gprim) and self._rendered(prim, ctx):
                    # A prototype holds only the instance's descendants (its root has no type and no properties):
                    # an instanceable mesh or gprim keeps its geometry on the instance prim, drawn as a prim of its own.
                    self._read_geometry(prim, ctx)
                elif prim.IsA(UsdGeom.Gprim) and _is_mesh_light(prim):  # as a gprim's below: dark, named
                    self._name_undrawn_mesh_light(prim, ctx)
                elif not prim.IsA(UsdGeom.Gprim) and (prim.IsA(UsdLux.DistantLight) or prim.HasAPI(UsdLux.LightAPI)):
                    self._read_lights(prim, [Sdf.Path(".")], ctx)  # an instanceable light keeps its light likewise
            else:
                # Cameras do not follow visibility (one under an invisible Xform is read): a hidden instance's are
                # read too, or a camera whose instance is hidden at some frame was missing from it.
                self._read_cameras(prim, self._prototype_cameras(prim.GetPrototype()), ctx)
                hidden_lights = self._prototype_lights(prim.GetPrototype())  # authored all the same: no default lights
                if hidden_lights:
                    shown = Sdf.Path(self._shown_path(prim))
                    self.authored_lights.update((str(shown.AppendPath(light)), None) for light in hidden_lights)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.PointInstancer):
            # Its prototypes are drawn through the instancer only, so its subtree is not walked in place. An
            # instanceable instancer is read the same way: its prototypes are the instance proxies it targets (its
            # native prototype holds only those, not the instancer's own positions and indices). One of guide or
            # proxy purpose is read too, as instances are: a prototype prim of authored render purpose is drawn.
            if self._visible(prim, ctx.stop):
                self._read_instancer(prim, ctx)
            self._instancer_lights(prim)
            it.PruneChildren()
        elif prim.IsA(UsdGeom.Gprim):
            if self._rendered(prim, ctx):
                self._read_geometry(prim, ctx)
            elif _is_mesh_light(prim) and self._visible(prim, ctx.stop):
                self._name_undrawn_mesh_light(prim, ctx)
        elif prim.IsA(UsdProc.GenerativeProcedural):
            # Hydra's procedural plugins (hdGp) make its geometry in usdview and Karma; wrt has none to run.
            if self._rendered(prim, ctx):
                kind = prim.GetAttribute("primvars:hdGp:proceduralType")
                self._skip("GenerativeProcedural prims are not evaluated (wrt runs no procedural plugins); skipped",
                           prim, str(value_at(kind, self.time) or "no hdGp:proceduralType") if kind else None)
        elif prim.IsA(UsdGeom.Camera):
            self._read_cameras(prim, [Sdf.Path(".")], ctx)  # "." is the camera itself
        elif prim.IsA(UsdLux.DistantLight) or prim.HasAPI(UsdLux.LightAPI):
            self._read_lights(prim, [Sdf.Path(".")], ctx)  # "." is the light itself

    def _instance_state(self, prim: Usd.Prim, ctx: Context) -> tuple:
        """``(visible, purpose it hands down, hidden purposes)`` of native instance ``prim``
        (:meth:`_read_native_instance`'s arguments), shared by the siblings of one prototype that author nothing but
        their transform (:meth:`_transform_only`): their visibility, purpose and purpose visibilities are their
        parent's (each asked of every instance was a fifth of its read)."""
        prototype = prim.GetPrototype()
        key = None
        if prototype and self._transform_only(prim, ctx):
            key = prim.GetPath().GetParentPath(), prototype.GetPath(), prim.GetTypeName()  # (its fallbacks: its type)
            if key in self.sibling_states:
                return self.sibling_states[key]
        state = False, None, frozenset()
        if self._visible(prim, ctx.stop):
            purpose = self._purpose(prim, ctx)
            hidden = self._hidden_purposes(prim, ctx)
            state = True, self._instance_purpose(prim, ctx, purpose, hidden), hidden
        if key is not None:
            self.sibling_states[key] = state
        return state

    def _prototype_lights(self, prototype: Usd.Prim) -> list:
        """Paths relative to ``prototype`` of the UsdLux lights in it and in the instances nested in it, which
        ``ComputeLightList`` lists under each of its instances (hidden ones too), but those under a Material; none
        for an instance without a prototype. Looked for once per prototype, for hidden instances (the walk reads the
        others') and for PointInstancers' prototypes (:meth:`_instancer_lights`)."""
        if not prototype:
            return []
        key = prototype.GetPath()
        if key not in self.prototype_lights:
            found = []
            it = iter(Usd.PrimRange(prototype, Usd.TraverseInstanceProxies(PROTOTYPE_PREDICATE)))
            for p in it:
                if p.IsA(UsdShade.Material):
                    # Not under a Material, as the walk counts none there (_read_prim): Hydra populates none of its
                    # descendants, so such a light is no light of the stage. Counted here, a lamp kept under a
                    # prototype's material left a stage without the default lights, drawn black.
                    it.PruneChildren()
                elif p.IsA(UsdLux.DistantLight) or p.HasAPI(UsdLux.LightAPI):
                    found.append(p.GetPath().MakeRelativePath(key))
            self.prototype_lights[key] = found
        return self.prototype_lights[key]

    def _instancer_lights(self, prim: Usd.Prim):
        """Counts the UsdLux lights in PointInstancer ``prim``'s prototypes among the stage's lights
        (``authored_lights``), at their paths under it, as ``ComputeLightList`` lists them: its subtree is not walked,
        and its prototypes are read only for the instances it draws, so a hidden instancer's (or one of no instances)
        were never met, and the stage got the default lights."""
        for target in UsdGeom.PointInstancer(prim).GetPrototypesRel().GetForwardedTargets():  # as they are read
            root = self.stage.GetPrimAtPath(target)
            if root and PROTOTYPE_PREDICATE(root):  # as the prototypes read are (an over or a class draws nothing)
                shown = Sdf.Path(self._shown_path(root))
                self.authored_lights.update((str(shown.AppendPath(light)), None)
                                            for light in self._prototype_lights(root))

    def _read_lights(self, prim: Usd.Prim, lights: list, ctx: Context):
        """The UsdLux ``lights`` at paths relative to ``prim`` (a light itself, ``.``, or the lights of native
        instance ``prim``, relative to its prototype), read through :meth:`_read_through_instances` as cameras are:
        in the world, each visible one at its instance-proxy path (``/Lamp/Light``, USD's ``ComputeLightList`` path,
        placed by that instance's transform); inside a PointInstancer's prototype, each visible from the prototype
        root down (as its geometry) is kept with its transform to the prototype's space, and read once per instance
        when the walk is over (:meth:`_read_placed_lights`). Purpose does not hide lights, as in the world."""

        def read(proxy: Usd.Prim):
            if self._visible(proxy):
                self._name_unrendered_purpose(proxy)
                light = read_light(proxy, self.xforms, self.time, self.scene.up_axis, self._skip,
                                   textures=self.light_textures)
                if light is not None:
                    self.scene.lights.append(light)

        def place(proxy: Usd.Prim):
            m = self._to_space(proxy, ctx) if self._visible(proxy, ctx.stop) else None
            if m is not None:
                # Its purpose as the prototype's geometry takes it (named per instance once placed): its own or its
                # ancestors' in the prototype, else the instancer's or the native instance's (ctx.outer_purpose). USD's
                # ComputePurpose of the prim here says default under a guide instancer or a guide native instance.
                ctx.content.placed_lights.append((proxy, m.T, self._purpose(proxy, ctx)))

        self._read_through_instances(prim, lights, ctx, "lights", read, "UsdLux lights", place)

    def _name_unrendered_purpose(self, light: Usd.Prim):
        """Names UsdLux ``light`` when its computed purpose is one the render does not draw (guide, proxy): it still
        lights, as Hydra's renderers light it (they give lights no purpose; OpenUSD issue 3059), though UsdGeom says
        such a prim is not rendered: a guide lamp lit the image without a word. A light placed by a PointInstancer is
        named per instance, by the purpose its prototype's geometry takes (:meth:`_read_placed_lights`)."""
        purpose = self.computed_purposes.purpose(light)
        if purpose not in self.purposes:
            self._skip(UNRENDERED_PURPOSE, light, f"purpose = {purpose}")

    def _name_undrawn_mesh_light(self, prim: Usd.Prim, ctx: Context):
        """Names visible mesh light ``prim`` (MeshLightAPI, or LightAPI on a gprim) when its purpose is one the render
        does not draw: its geometry is left out, so it gives no light, where the other UsdLux lights of that purpose
        light all the same (:meth:`_name_unrendered_purpose`); a guide light panel went dark without a word."""
        purpose = self._purpose(prim, ctx)
        if purpose not in self.purposes:
            self._skip("mesh lights of a purpose the render does not draw give no light (their geometry is not "
                       "drawn), unlike the other UsdLux lights of that purpose", prim, f"purpose = {purpose}")

    def _read_geometry(self, prim: Usd.Prim, ctx: Context):
        """Mesh or gprim ``prim`` into ``ctx.content``: a mesh, or an analytic shape (a mesh when tessellating, or when
        the gprim is a mesh light or its material emits, outside instances)."""
        if prim.HasAPI(UsdLux.VolumeLightAPI):
            self._skip("volume lights (VolumeLightAPI) are not supported: wrt has no volumes", prim, prim.GetTypeName())
        if prim.IsA(UsdGeom.Mesh) or prim.IsA(UsdGeom.TetMesh) or prim.IsA(UsdGeom.NurbsPatch):
            read = self._read_mesh if prim.IsA(UsdGeom.Mesh) else self._read_surface
            m = self._to_space(prim, ctx)
            if m is not None:
                self._add_mesh(prim, read(prim, m, ctx), ctx)
            return
        if prim.IsA(UsdGeom.Points) or prim.IsA(UsdGeom.Curves):
            self._not_a_mesh_light(prim, "Points and curves")
            self._read_tubes(prim, ctx)
            return
        start = len(self.skipped)
        m = self._to_space(prim, ctx)
        shape = None if m is None else self._read_gprim(prim, m, ctx)
        if shape is None:
            self._warn_dark_mesh_light(prim)
            if len(self.skipped) > start:  # skipped (named): an emissive one lit the stage, as a skipped mesh does
                self._skipped_emitter(prim, self._face_materials(prim, 1, ctx))
        else:
            # A zero scale on one axis flattens the gprim into a disc or sheet, which Storm draws as its flat
            # tessellation, each half fronting its own side: it is drawn thin (as instances are), so each half keeps
            # its side. Drawn as that flat tessellation, whose halves overlap without sharing edges, culled back faces
            # hid up to 4 in 5 of its pixels. Only a singular transform is looked at again.
            invertible = invert_transforms(shape.to_world[None])[1][0]
            if not invertible:
                thick, flat = thicken_flat_transforms(shape.to_world[None])
                if flat[0]:  # thickened, and invertible now
                    shape.to_world, invertible = thick[0], True
        if shape is not None and not self.segments and not invertible:
            # A transform to a line or a point (or one whose inverse is past float32) leaves no canonical space to
            # intersect in: drawn analytically the gprim vanished, while its tessellation, --accel warp and Storm draw
            # it (as nothing of any area, or as the very large or small shape it is).
            self._skip(f"gprims with a singular transform (a zero scale) are drawn as triangle meshes of "
                       f"{DEFAULT_SEGMENTS} segments (flat), having no canonical space to intersect in", prim)
            self._add_mesh(prim, self._tessellated(shape, prim, DEFAULT_SEGMENTS), ctx)
        elif shape is not None and self.segments:
            self._add_mesh(prim, self._tessellated(shape, prim), ctx)
        elif shape is not None and (_is_mesh_light(prim) or self._glows(shape)):
            # Light sampling draws points on triangles, and rays that hit an emitter must see the surface sampled (its
            # radiance and pdf come from the triangle hit): a mesh light, or a gprim bound to a material that emits,
            # is drawn as its tessellation, inside instances too; the other gprims stay analytic.
            self._add_mesh(prim, self._tessellated(shape, prim, DEFAULT_SEGMENTS), ctx)
        elif shape is not None:
            ctx.content.shapes.append(shape)

    def _glows(self, shape: Shape) -> bool:
        """``shape``'s material emits: a constant ``emissiveColor`` above 0, or a texture on it whose mean emission
        (each texel after scale and bias, negatives read as 0) is, or whose fallback glows where the texture reads it
        (:func:`wrt.materials.can_emit`); the render reads on its triangles which of them glow."""
        return self._material_glows(shape.material_id)

    def _material_glows(self, material_id: int) -> bool:
        """Material ``material_id`` (-1: the default material, which emits nothing) emits (see :meth:`_glows`)."""
        if material_id < 0:
            return False
        glows = self.glowing_materials.get(material_id)
        if glows is None:
            material = self.materials.materials[material_id]
            glows = self.glowing_materials[material_id] = can_emit(material, self.materials.textures)
        return glows

    def _skipped_emitter(self, prim: Usd.Prim, face_materials: np.ndarray | None):
        """Counts mesh or gprim ``prim``, skipped, among the stage's lights (``authored_lights``) when a material it is
        bound to (``face_materials``: per face, or None) emits: its author lit the stage with it."""
        if face_materials is not None and any(self._material_glows(int(k)) for k in np.unique(face_materials)):
            self.authored_lights[self._shown_path(prim)] = None

    def _warn_dark_mesh_light(self, prim: Usd.Prim):
        """Names mesh light ``prim`` (MeshLightAPI, or LightAPI on a gprim) when its geometry was left out (invalid
        topology, no points, a bad size or transform: each named too): it gives no light."""
        if _is_mesh_light(prim):
            self._skip("mesh lights whose geometry was left out give no light", prim)

    def _add_mesh(self, prim: Usd.Prim, mesh: Mesh | None, ctx: Context):
        """Adds ``mesh`` (None: nothing), drawn for ``prim``, to ``ctx.content``, and its light when ``prim`` is a
        mesh light (MeshLightAPI, or LightAPI on another gprim) outside instances."""
        if mesh is None:
            self._warn_dark_mesh_light(prim)
            return
        ctx.content.meshes.append(mesh)
        if not _is_mesh_light(prim):
            return
        path = str(prim.GetPath())
        if not ctx.world and path in self.instanced_lights:  # a prototype read again (another outer material)
            return
        light = read_light(prim, self.xforms, self.time, self.scene.up_axis, self._skip)
        if light is None:
            return
        warn_glowless_mesh_light(light, prim, mesh, self.materials, self._skip)
        if ctx.world:
            self.scene.lights.append(light)
            return
        if prim.IsInPrototype():  # named as warnings and its mesh are, not by the prototype path (USD renumbers those)
            light.path = self._shown_path(prim)
        self.instanced_lights[path] = light  # added once the walk is over, unless drawn in place too

    def _not_a_mesh_light(self, prim: Usd.Prim, what: str):
        """Names ``prim`` in a warning when it is a mesh light (MeshLightAPI or LightAPI alone): it should emit, but
        wrt draws ``what`` as geometry that emits nothing."""
        if _is_mesh_light(prim):
            self._skip(f"lights on {what} (LightAPI, MeshLightAPI) are not supported; drawn as geometry that emits "
                       "nothing", prim, prim.GetTypeName())

    def _add_instanced_lights(self):
        """Adds the mesh lights read inside instance prototypes, each once, whatever the number of instances (its
        triangles are sampled in each: wrt.light_table.emitter_triangles). A PointInstancer's prototype may be a prim
        of the world too, drawn in place as well: its light, read there, covers the instances' copies."""
        world = {light.mesh_path for light in self.scene.lights if isinstance(light, MeshLight)}
        self.scene.lights += [light for path, light in self.instanced_lights.items() if path not in world]

    def _to_space(self, prim: Usd.Prim, ctx: Context) -> np.ndarray | None:
        """``(4, 4)`` row-vector (USD) transform from ``prim`` to the space of ``ctx``'s content, or None (with a
        warning naming ``prim``, which is left out) where it is not finite: as an instance so placed is skipped (it
        stopped the whole load)."""
        if ctx.space_root is None:
            m = self.xforms.GetLocalToWorldTransform(prim)
        else:
            m, resets = self.xforms.ComputeRelativeTransform(prim, ctx.space_root)
            if resets:
                m = self._reset_in_prototype(prim, ctx.space_root, m)
        m = np.array(m, dtype=np.float64)
        if not np.isfinite(m).all():
            self._skip(NOT_FINITE_TRANSFORM, prim)
            return None
        return m

    def _reset_in_prototype(self, prim: Usd.Prim, space_root: Usd.Prim, m: Gf.Matrix4d) -> Gf.Matrix4d:
        """The transform of ``prim``, which resets the transform stack (or is below a prim that does) inside the
        PointInstancer prototype whose parent is ``space_root``, to that parent's space: ``m`` is its own ops from the
        reset down. A reset below the prototype root is taken as ``BBoxCache.ComputePointInstanceWorldBounds``,
        ``ComputeExtentAtTime`` and UsdImaging's instancer adapter (``_CorrectTransform``) take it: the prim's world
        transform over the prototype root's, then the root's own; read as ``m`` alone, the prim was placed as if the
        prototype's parent sat at the origin. A reset on the root itself leaves ``m``, the root's own transform, as
        ``ComputeInstanceTransformsAtTime`` uses it (``IncludeProtoXform``)."""
        root = self.stage.GetPrimAtPath(prim.GetPath().GetPrefixes()[space_root.GetPath().pathElementCount])
        if not self.xforms.ComputeRelativeTransform(prim, root)[1]:
            return m  # the root resets, nothing below it
        root_world = self.xforms.GetLocalToWorldTransform(root)
        linear = np.array(root_world, np.float64)[:3, :3]
        if not abs(np.linalg.det(linear)) > 1e-9 * np.abs(linear).max() ** 3:
            return m  # the root is flattened in the world (a zero scale above it): no space to divide by
        local, _ = self.xforms.ComputeRelativeTransform(root, space_root)
        return self.xforms.GetLocalToWorldTransform(prim) * root_world.GetInverse() * local

    def _content(self, key: tuple, root: Usd.Prim, space_root, outer_bindings, outer_purpose=None,
                 outer_color=None, outer_widths=None, proxy=None, instance_opacity=False, outer_uv=None,
                 outer_hidden=frozenset()) -> Content:
        """The content of a prototype, read on first use."""
        if key not in self.contents:
            if key in self.reading:  # PointInstancers skip these first; native prototypes cannot (USD refuses cycles)
                raise self._error("prototype contains an instance of itself", root)
            self.reading.add(key)
            content = Content(str(root.GetPath()))
            # Prototypes are often kept under an ``over`` so they are not drawn in place; instanced, they are drawn
            # (as UsdImaging does), so "defined" is not asked of the prototype's ancestors.
            inside = Context(content, space_root, outer_bindings, outer_purpose=outer_purpose,
                              outer_color=outer_color, outer_widths=outer_widths, proxy=proxy,
                              instance_opacity=instance_opacity, outer_uv=outer_uv, outer_hidden=outer_hidden)
            self._walk(root, inside, PROTOTYPE_PREDICATE)
            self.reading.discard(key)
            self.contents[key] = content
        return self.contents[key]

    def _face_materials(self, prim: Usd.Prim, n_faces: int, ctx: Context) -> np.ndarray | None:
        """``(F,)`` int32 material of each face of ``prim`` (-1: default), or None for none at all
        (:meth:`MaterialReader.face_materials`): inside a native prototype each binding purpose's walk goes on past
        the prototype root through the bindings on and above the instance being read (``ctx.outer_bindings``), as
        ``ComputeBoundMaterial`` walks an instance proxy's."""
        return self.materials.face_materials(self._binding_prim(prim, ctx), n_faces, ctx.outer_bindings,
                                             ctx.content.outer_purposes)

    def _binding_prim(self, prim: Usd.Prim, ctx: Context) -> Usd.Prim:
        """The prim whose bindings ``prim`` has: itself, or in a prototype read for one instance (``ctx.proxy``)
        that instance's proxy of it."""
        if ctx.proxy is None:
            return prim
        root, instance = ctx.proxy
        return self.stage.GetPrimAtPath(prim.GetPath().ReplacePrefix(Sdf.Path(root), Sdf.Path(instance)))


def _drawable(prim: Usd.Prim) -> bool:
    """``prim`` is something the stage reader draws or reads: a gprim, an instancer, a camera or a light."""
    return (prim.IsA(UsdGeom.Gprim) or prim.IsA(UsdGeom.PointInstancer) or prim.IsA(UsdGeom.Camera)
            or prim.IsA(UsdLux.DistantLight) or prim.HasAPI(UsdLux.LightAPI))


__all__ = ["load_usd", "triangulate"]
