"""The device's light table: the host lights (:mod:`wrt.lights`) and the emissive triangles of a scene flattened
into :class:`wrt.light_sampling.DeviceLights` (one row per light, with its selection probability, shadow mode and
packed texture), and the sampling distribution of a textured dome.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import ClassVar, NamedTuple

import numpy as np
import warp as wp

from .dome_irradiance import device_coefficients, irradiance_coefficients
from .errors import SceneError, user_stacklevel
from .floats import FLOAT32_MAX
from .glowing_spheres import GlowingSpheres, ellipse_axes, glowing_spheres
from .light_features import LightFeatures, light_features
from .light_links import CASTS_SHADOW, link_groups, upload_links
from .light_sampling import (
    LIGHT_CYLINDER,
    LIGHT_DISK,
    LIGHT_DISTANT,
    LIGHT_DOME,
    LIGHT_ELLIPSOID,
    LIGHT_ELLIPTIC_TUBE,
    LIGHT_LINE,
    LIGHT_POINT,
    LIGHT_RECT,
    LIGHT_SPHERE,
    SHADOWS_LINKED,
    SHADOWS_OFF,
    SHADOWS_ON,
    SHADOWS_TINTED,
    DeviceLights,
)
from .light_shaping import Shaping, ies_frame, primary_axis
from .lights import (
    GLOW_TINTS_LIGHT,
    NO_MATERIAL_RESPONSE,
    CylinderLight,
    DiskLight,
    DomeLight,
    MeshLight,
    RectLight,
    SphereLight,
    light_axes,
    normalized_radiance,
    shadow_api_row,
)
from .radiance_scale import radiance_scale
from .sampled_emission import SampledEmission
from .scene import DistantLight


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
    shadow_api: list  # per light: wrt.lights.shadow_api_row, or None
    shaping: list
    shaping_axis: list
    focus_tint: list
    ies: list  # per light: its IES profile's wrt.ies.IesProfile.device_data, or None
    ies_frame: list
    texture: list
    lobe_scale: list
    shapes: list


LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 luminance weights of linear RGB
# Smallest UsdLux sizeFactor (pi sin^2(angle/2)) of a sun disc drawn as a disc: below it (about 6e-14 degrees
# across) the disc's radiance E / sizeFactor passes float32's range or its cone underflows, so it is a delta light of
# its illuminance, which no ray could tell apart from the disc (so is a brighter disc whose radiance passes it:
# drawn_as_disc).
SMALLEST_SUN_DISC = 1e-30
SELECTION_GRID = float(1 << 24)  # light selection's uniform numbers are multiples of 1 / SELECTION_GRID


def drawn_as_disc(light: DistantLight) -> bool:
    """Whether distant ``light`` is drawn as its sun disc: one of some angle whose radiance float32 holds (a
    normalized disc of 1e9 lux 1e-13 degrees across has 4e38; it raised a KeyError and drew inf), else as the delta
    light of its illuminance, the limit it tends to."""
    return light.angle > 0.0 and light.size_factor >= SMALLEST_SUN_DISC and bool(np.isfinite(light.radiance).all())


def seen_by_camera(light) -> bool:
    """Whether a camera ray can see ``light`` itself (:func:`wrt.integrators.emitters.lights_on_segment` and
    ``environment``, in the integrators that read lights): a dome, a distant light with a disc, an area light (a sphere
    that is not a point, a rect, a disk, a cylinder that is not a line). Point, line and delta distant lights light
    surfaces only; a mesh
    light is its mesh's triangles."""
    if isinstance(light, DistantLight):
        return drawn_as_disc(light)
    if isinstance(light, SphereLight):
        return not light.treat_as_point
    if isinstance(light, CylinderLight):
        return not light.drawn_as_line
    return isinstance(light, (DomeLight, RectLight, DiskLight, CylinderLight))


def luminance_np(c) -> float:
    return float(np.asarray(c, np.float64) @ LUMINANCE)


# Emitter entries made for instanced triangles (one per emissive prototype triangle and instance, 60 bytes of
# device arrays each, as every triangle's light-table row, 64 with light linking: 120 MB at the cap, whose rows
# build_lights made in 2 s on 2 cores): the instances past it (in instance order) keep their emission for rays that
# hit them but are not sampled, with a warning, so that a forest of glowing leaves cannot fill the device.
MAX_INSTANCED_EMITTERS = 2_000_000


@dataclasses.dataclass
class EmitterTriangles:
    """The triangle lights of a scene (:func:`emitter_triangles`), one row each: the world-space triangles, then
    those of instances, each sampled instance's consecutive.

    Attributes:
        ids: ``(E,)`` int32 geometry ids (rows of ``Scene.geometry()``).
        power: ``(E,)`` float64 power weights for light selection.
        radiance: ``(E, 3)`` float32 radiance factor: 1 for emissive materials, a mesh light's (normalized) colour.
        params: ``(E, 4)`` float32 :class:`DeviceLights` ``params`` of triangle lights.
        owner: ``(E,)`` int32 index of the :class:`MeshLight` (in the list given) the triangle belongs to, -1: none.
        instances: ``(E,)`` int32 instance that draws the row's prototype triangle, -1: world geometry.
        instance_first: ``(N,)`` int32 each instance's first row, -1 where none is sampled.
        unsampled: the emissive triangles of instances past the cap (not sampled), by instance source.
    """

    ids: np.ndarray
    power: np.ndarray
    radiance: np.ndarray
    params: np.ndarray
    owner: np.ndarray
    instances: np.ndarray = None
    instance_first: np.ndarray = None
    unsampled: UnsampledEmitters = None


@dataclasses.dataclass
class UnsampledEmitters:
    """The emissive instanced triangles left out of the light table past the cap on instanced emitter entries: they
    emit where rays hit them but are not sampled as lights.

    Attributes:
        triangles: how many (one per prototype triangle and instance).
        cap: the cap they are past (:data:`MAX_INSTANCED_EMITTERS`, or the one given).
        sources: ``(path, instances, triangles)`` per source prim of the instances left out
            (:meth:`wrt.instancing.Instances.source_path`: the PointInstancer or instanceable prim), in instance order.
    """

    triangles: int = 0
    cap: int = 0
    sources: list = dataclasses.field(default_factory=list)
    shapes: int = 0  # glowing analytic shapes not sampled, once per instance (wrt.glowing_spheres: squashed flat)
    spheres_past_cap: int = 0  # glowing spheres, tubes and hulls of instances past the cap (once per instance)

    MAX_NAMED: ClassVar[int] = 4  # sources named in :meth:`describe`; the rest are counted

    def describe(self) -> str:
        """``"6 emissive triangle(s) of 3 instance(s) past the first 2 instanced emitters sampled (/B: 2 of 1
        instance, /PI: 4 of 2 instances)"``; "" when there are none."""
        if self.triangles == 0:
            return "" if not self.spheres_past_cap else self._spheres_text()
        instances = sum(n for _, n, _ in self.sources)
        named = [f"{path}: {tris:,} of {n:,} instance{'s' if n > 1 else ''}"
                 for path, n, tris in self.sources[: self.MAX_NAMED]]
        if len(self.sources) > self.MAX_NAMED:
            named.append(f"and {len(self.sources) - self.MAX_NAMED:,} more sources")
        text = (f"{self.triangles:,} emissive triangle(s) of {instances:,} instance(s) past the first {self.cap:,} "
                f"instanced emitters sampled ({', '.join(named)})")
        return text + (f" and {self._spheres_text()}" if self.spheres_past_cap else "")

    def _spheres_text(self) -> str:
        return (f"{self.spheres_past_cap:,} glowing sphere(s), tube(s) or other shape(s) of instances past the first "
                f"{self.cap:,} instanced emitters sampled")


class _TriangleEmission:
    """The emission estimate of each triangle: its material's row of ``materials_emission`` (``(M, 3)``, per device
    material), or where given its row of ``sampled`` (a textured emitter's triangles read on themselves,
    :class:`wrt.sampled_emission.SampledEmission`); ``tri_materials`` ``(T,)``."""

    def __init__(self, materials_emission, tri_materials: np.ndarray, sampled: SampledEmission | None = None):
        self.materials = np.asarray(materials_emission, np.float64).reshape(-1, 3)
        self.tri_materials = tri_materials
        self.sampled = sampled

    def rgb(self, ids: np.ndarray) -> np.ndarray:
        """``(N, 3)`` float64 emission of triangles ``ids``."""
        rgb = self.materials[self.tri_materials[ids]]
        return rgb if self.sampled is None else self.sampled.over(ids, rgb)

    def glow(self, ids: np.ndarray) -> np.ndarray:
        """``(N,)`` float64 luminance of the emission of triangles ``ids``."""
        return self.rgb(ids) @ LUMINANCE

    def emissive(self) -> np.ndarray:
        """``(T,)`` bool: the triangles whose emission has a luminance above 0."""
        # Looked up in a table of the materials' answers (a float gather and a compare per triangle, twice, took 9 ms
        # of every Renderer of a chess set of 800k triangles and no glow at all).
        glowing = self.materials @ LUMINANCE > 0.0
        emissive = glowing[self.tri_materials] if glowing.any() else np.zeros(len(self.tri_materials), bool)
        if self.sampled is not None:
            inside = self.sampled.ids < len(self.tri_materials)  # (the rows of analytic shapes follow)
            emissive[self.sampled.ids[inside]] = self.sampled.values[inside] @ LUMINANCE > 0.0
        return emissive


def emitter_triangles(scene, materials_emission, mesh_lights: list, cap: int | None = None,
                      sampled: SampledEmission | None = None) -> EmitterTriangles:
    """Every emissive world-space triangle, then the triangles of each of ``mesh_lights`` that emit (a mesh light's
    triangles are its, not plain emissive ones), then the same for each instance's prototype triangles, in world
    space, for the first instances whose rows fit in ``cap`` (None: :data:`MAX_INSTANCED_EMITTERS`). A triangle's
    emission is its material's (``materials_emission``, per device material), or its row of ``sampled``
    (:func:`wrt.sampled_emission.sampled_emission`) where it has one.

    Raises:
        SceneError: a mesh light that names no mesh of the scene.
    """
    points, indices = scene.geometry()
    flat = scene.num_flat_triangles
    geometry = len(indices)
    tri_materials = scene.triangle_materials()[:geometry]
    sided = scene.triangle_double_sided()[:geometry]
    emission = _TriangleEmission(materials_emission, tri_materials, sampled)
    emissive = emission.emissive()

    def crosses(ids):
        a, b, c = (points[indices[ids, k]].astype(np.float64) for k in range(3))
        return np.cross(b - a, c - a)

    def areas(ids):
        return 0.5 * np.linalg.norm(crosses(ids), axis=1)

    owner = np.full(geometry, -1, np.int32)
    meshes = list(scene.meshes) + [m for p in scene.prototypes for m in p.meshes]  # geometry order
    starts = np.concatenate([[0], np.cumsum([len(m.indices) for m in meshes])]).astype(np.int64)
    by_path = {}  # mesh path -> its indices in meshes (only when asked for: 40k meshes took 0.3 s)
    for k, mesh in enumerate(meshes if mesh_lights else ()):
        by_path.setdefault(mesh.path, []).append(k)
    for j, light in enumerate(mesh_lights):
        if light.mesh_path not in by_path:
            raise SceneError("MeshLight names no mesh of the scene", prim=light.path or None)
        rows = np.concatenate([np.arange(starts[k], starts[k + 1]) for k in by_path[light.mesh_path]])
        if (owner[rows] >= 0).any():  # the second would silently take every triangle
            raise SceneError("two MeshLights name the same mesh; give it one light", prim=light.path)
        owner[rows] = j
    world_owner = owner[:flat]

    # Emissive materials: radiance factor 1 times the material's emission (params[0] = 1).
    ids = np.nonzero(emissive[:flat] & (world_owner < 0))[0]
    rows = [(ids, math.pi * areas(ids) * emission.glow(ids), np.ones((len(ids), 3)), (1, 0, 0, 0), -1)]
    for j, light in enumerate(mesh_lights):
        ids = np.nonzero(world_owner == j)[0]
        area = areas(ids)
        L = normalized_radiance(light.color, float(area.sum()), light.normalize).astype(np.float64)
        if not np.isfinite(L).all():  # left out, as a rect light of the kind is (_too_small)
            _warn_unbounded([light], len(ids))
            continue
        keep, lum, params = _mesh_light_terms(light, L, tri_materials[ids], emission.rgb(ids))
        ids, area = ids[keep], area[keep]
        rows.append((ids, math.pi * area * lum[keep], np.tile(L, (len(ids), 1)), params, j))
    ids = np.concatenate([r[0] for r in rows]).astype(np.int32)
    world = EmitterTriangles(
        ids=ids,
        power=np.concatenate([r[1] for r in rows]) * np.where(sided[ids], 2.0, 1.0),
        radiance=np.concatenate([r[2] for r in rows]).astype(np.float32),
        params=np.concatenate([np.tile(np.asarray(r[3], np.float32), (len(r[0]), 1)) for r in rows]),
        owner=np.concatenate([np.full(len(r[0]), r[4], np.int32) for r in rows]),
    )
    return _with_instances(scene, world, owner, crosses, tri_materials, sided, emission, emissive, mesh_lights,
                           MAX_INSTANCED_EMITTERS if cap is None else cap)


def _with_spheres(tris: EmitterTriangles, spheres: GlowingSpheres) -> EmitterTriangles:
    """``tris`` followed by the rows of ``spheres``: their radiance is their material's emission (factor 1, params
    ``(1, 0, 0, 0)``, as an emissive triangle's), their owner none; ``unsampled`` counts the glowing shapes left out
    (:attr:`UnsampledEmitters.shapes`, :attr:`UnsampledEmitters.spheres_past_cap`)."""
    s = len(spheres.ids)
    unsampled = dataclasses.replace(tris.unsampled, shapes=spheres.left_out, spheres_past_cap=spheres.past_cap)
    return dataclasses.replace(
        tris,
        ids=np.concatenate([tris.ids, spheres.ids]).astype(np.int32),
        power=np.concatenate([tris.power, spheres.power]),
        radiance=np.concatenate([tris.radiance, np.ones((s, 3), np.float32)]),
        params=np.concatenate([tris.params, np.tile(np.float32([1, 0, 0, 0]), (s, 1))]),
        owner=np.concatenate([tris.owner, np.full(s, -1, np.int32)]),
        instances=np.concatenate([tris.instances, spheres.instances]).astype(np.int32),
        unsampled=unsampled,
    )


def _unsampled(instances, counts: np.ndarray, sampled: np.ndarray, cap: int) -> UnsampledEmitters:
    """The :class:`UnsampledEmitters` of ``instances`` whose ``counts`` (``(N,)`` emissive prototype triangles each)
    are not ``sampled`` (``(N,)`` bool), by source prim in instance order."""
    left = np.flatnonzero(~sampled & (counts > 0))
    sources, first, per_source = np.unique(instances.source[left], return_index=True, return_counts=True)
    tris = np.bincount(np.searchsorted(sources, instances.source[left]), weights=counts[left], minlength=len(sources))
    named = [(instances.source_path(int(left[first[k]])), int(per_source[k]), int(tris[k])) for k in np.argsort(first)]
    return UnsampledEmitters(int(counts[left].sum()), cap, named)


def _mesh_light_terms(light: MeshLight, L, materials: np.ndarray, emission: np.ndarray):
    """``(keep, luminance, params)`` of mesh light ``light`` of radiance ``L`` (``(3,)``, normalized) on triangles
    of device ``materials`` that emit ``emission`` (``(N, 3)``, :class:`_TriangleEmission`): a light that tints its
    material's glow keeps only the triangles that glow."""
    # A mesh bound to no material has no glow to sync with: noMaterialResponse whatever its mode.
    sync = light.material_sync if (materials > 0).any() else NO_MATERIAL_RESPONSE
    params = (float(sync == GLOW_TINTS_LIGHT), float(sync == NO_MATERIAL_RESPONSE), 1, 0)
    if sync == GLOW_TINTS_LIGHT:
        return emission @ LUMINANCE > 0.0, (L * emission) @ LUMINANCE, params
    return np.ones(len(materials), bool), np.full(len(materials), float(L @ LUMINANCE)), params


def _with_instances(scene, world: EmitterTriangles, owner, crosses, tri_materials, sided,
                    emission: _TriangleEmission, emissive, mesh_lights: list, cap: int) -> EmitterTriangles:
    """``world`` followed by the rows of the instances' emissive prototype triangles, each sampled instance's in
    its prototype's order (geometry ids ascending), the first instances whose rows fit in ``cap``. Areas are the world
    areas of the moved triangles, ``|cof(A) ((b - a) x (c - a))| / 2`` for an instance's linear part ``A``; a
    normalized mesh light is divided by its area in each instance, as each instance of it is a light of its own."""
    n = len(scene.instances)
    instance_first = np.full(n, -1, np.int32)
    empty = dataclasses.replace(world, instances=np.full(len(world.ids), -1, np.int32), instance_first=instance_first,
                                unsampled=UnsampledEmitters(cap=cap))
    if n == 0:
        return empty
    # Each prototype's emitters (geometry ids, ascending) and their terms in one instance of unit transform; only
    # the prototypes that have some are visited (scenes of thousands of prototypes rarely have many).
    ranges = scene.prototype_ranges()
    candidates = np.flatnonzero((owner >= 0) | emissive)
    candidates = candidates[candidates >= scene.num_flat_triangles]
    protos = {}
    for p in np.unique(np.searchsorted(ranges[:, 0], candidates, side="right") - 1):
        first, count = ranges[p]
        ids = np.arange(first, first + count)
        own = owner[ids]
        glow = emission.glow(ids)
        emits = np.where(own < 0, glow > 0.0, False)
        per_area = np.where(emits, math.pi * glow, 0.0)
        radiance, params = np.ones((count, 3)), np.tile(np.float32([1, 0, 0, 0]), (count, 1))
        for j in np.unique(own[own >= 0]):
            mine = own == j
            light = mesh_lights[j]
            keep, lum, terms = _mesh_light_terms(light, np.asarray(light.color, np.float64), tri_materials[ids[mine]],
                                                 emission.rgb(ids[mine]))
            emits[mine], per_area[mine] = keep, math.pi * lum
            radiance[mine], params[mine] = np.asarray(light.color, np.float64), np.float32(terms)
        keep = np.flatnonzero(emits)
        if len(keep):
            # A normalized light is divided by the area of all its triangles, those that emit nothing (which tint
            # its colour by a glow of 0: a black UDIM tile, a subset's dark material) too, as in the world above
            # (None: all of them emit, and their areas are at hand).
            whole = {int(j): None if emits[own == j].all() else crosses(ids[own == j])
                     for j in np.unique(own[keep][own[keep] >= 0]) if mesh_lights[j].normalize}
            protos[int(p)] = (ids[keep], per_area[keep], radiance[keep], params[keep], own[keep], crosses(ids[keep]),
                              whole)

    # The first instances (in instance order) whose rows fit in the cap; singular (invisible) ones get none.
    per_prototype = np.zeros(max(len(ranges), 1), np.int64)
    for p, terms in protos.items():
        per_prototype[p] = len(terms[0])
    counts = per_prototype[scene.instances.prototype]
    counts[~scene.instance_inverses()[1]] = 0
    ends = np.cumsum(counts)
    sampled = (ends <= cap) & (counts > 0)
    instance_first[sampled] = (ends - counts)[sampled] + len(world.ids)
    total = int(counts[sampled].sum())
    unsampled = _unsampled(scene.instances, counts, sampled, cap)
    if total == 0:
        return dataclasses.replace(empty, unsampled=unsampled)
    ids = np.empty(total, np.int32)
    power = np.empty(total)
    radiance = np.empty((total, 3), np.float32)
    params = np.empty((total, 4), np.float32)
    owners = np.empty(total, np.int32)
    instances = np.empty(total, np.int32)
    to_world = scene.instances.to_world
    by_prototype = scene.instances.rows_of_prototypes(len(ranges))
    for p, (p_ids, per_area, p_radiance, p_params, p_owner, cr, whole) in protos.items():
        rows = by_prototype[p][sampled[by_prototype[p]]]
        if len(rows) == 0:
            continue
        step = max(1, (1 << 20) // (len(p_ids) + sum(len(c) for c in whole.values() if c is not None)))
        for start in range(0, len(rows), step):  # about a million rows (areas) at a time
            chunk = rows[start : start + step]
            linear = to_world[chunk, :3, :3]
            cofactor = np.stack([np.cross(linear[:, :, 1], linear[:, :, 2]), np.cross(linear[:, :, 2], linear[:, :, 0]),
                                 np.cross(linear[:, :, 0], linear[:, :, 1])], axis=2)  # det(A) A^-T: cross of columns
            area = 0.5 * np.linalg.norm(np.einsum("nij,tj->nti", cofactor, cr), axis=2)  # (instances, emitters)
            scale = np.ones_like(area)
            for j, light_crosses in whole.items():
                mine = p_owner == j
                light_area = (area[:, mine] if light_crosses is None else 0.5 * np.linalg.norm(
                    np.einsum("nij,tj->nti", cofactor, light_crosses), axis=2)).sum(axis=1, keepdims=True)
                scale[:, mine] = np.where(light_area > 0.0, 1.0 / np.where(light_area > 0.0, light_area, 1.0), 0.0)
            at = (instance_first[chunk] - len(world.ids))[:, None] + np.arange(len(p_ids))
            ids[at] = p_ids
            power[at] = area * per_area * scale * np.where(sided[p_ids], 2.0, 1.0)
            radiance[at] = (p_radiance[None] * scale[..., None]).astype(np.float32)
            params[at] = p_params
            owners[at] = p_owner
            instances[at] = chunk[:, None]
    return EmitterTriangles(
        ids=np.concatenate([world.ids, ids]),
        power=np.concatenate([world.power, power]),
        radiance=np.concatenate([world.radiance, radiance]),
        params=np.concatenate([world.params, params]),
        owner=np.concatenate([world.owner, owners]),
        instances=np.concatenate([empty.instances, instances]),
        instance_first=instance_first,
        unsampled=unsampled,
    )


def emitter_slots(tris: EmitterTriangles, num_analytic: int, num_triangles: int, sphere_first: np.ndarray,
                  num_geometry: int) -> np.ndarray:
    """``(max(G, 1),)`` int32 ``DeviceSurfaces.emitters`` of the ``G`` geometry ids (triangles, then glowing shapes:
    ``Scene.triangle_materials``'s rows): a world triangle's (glowing shape's) light-table entry, a prototype one's
    place among the entries of its instance (:func:`wrt.light_sampling.hit_emitter`, which adds the instance's first),
    -1 where it emits none. ``tris``: the table's rows after its ``num_analytic`` analytic lights, their first
    ``num_triangles`` triangles, then the glowing shapes, whose instances' first rows (among the shapes') are
    ``sphere_first``. (Made from the device arrays read back, each upload waited on four copies.)"""
    rows = np.arange(len(tris.ids))
    slots = (num_analytic + rows).astype(np.int32)
    drawn = tris.instances >= 0
    triangle = rows < num_triangles
    for mine, first in ((drawn & triangle, tris.instance_first), (drawn & ~triangle, sphere_first + num_triangles)):
        slots[mine] = rows[mine] - first[tris.instances[mine]]
    out = np.full(max(num_geometry, 1), -1, np.int32)
    out[tris.ids] = slots  # (a prototype triangle's rows, one per instance, share one slot)
    return out


class LightTable(NamedTuple):
    """What :func:`build_lights` made of a scene's lights."""

    device_lights: DeviceLights  # the lights on the device
    unsampled: UnsampledEmitters  # the instanced emitters left out past MAX_INSTANCED_EMITTERS
    features: LightFeatures  # the shading kernels' variant they need (wrt.light_features), from the host rows
    emitter_slots: np.ndarray  # (max(G, 1),) int32 DeviceSurfaces.emitters of each geometry id (emitter_slots)
    # (K,) int32 geometry ids of the triangles of noMaterialResponse mesh lights (those whose mesh has no material
    # count too): their surface is wrt.materials.no_response_material, whatever their mesh's material, in scenes read
    # and built in Python alike.
    no_response: np.ndarray


def build_lights(lights: list, scene, material_emission: list, device, glow: np.ndarray | None = None,
                 sampled: SampledEmission | None = None) -> LightTable:
    """Flattens ``lights`` (host light objects) plus the emissive triangles of ``scene`` into :class:`DeviceLights`,
    and says which instanced emitters were left out past :data:`MAX_INSTANCED_EMITTERS`, which features of the
    shading kernels the lights need, each geometry id's emitter slot and which triangles respond to no light
    (:class:`LightTable`, all from the host rows: the Renderer reads nothing back). Radiance is held times
    ``radiance_scale`` (:func:`wrt.radiance_scale.radiance_scale` of the brightest light or glow): the materials'
    emission must be scaled by it too (:func:`wrt.radiance_scale.scaled_materials`), and the image divided by it.

    Args:
        lights: the UsdLux lights (scene lights or :func:`wrt.lights.default_lights`).
        scene: the :class:`wrt.Scene` (for emissive triangles and the scene radius).
        material_emission: per device material (index 0 = default material) a ``(3,)`` emission estimate.
        device: Warp device.
        glow: ``(M,)`` per device material a bound on the radiance it emits (:func:`wrt.radiance_scale.glow_bounds`);
            None: the largest component of its estimate.
        sampled: the emission estimates that replace their material's on the triangles and shapes it holds
            (:func:`wrt.sampled_emission.sampled_emission`), or None.
    """
    if sum(isinstance(light, DomeLight) for light in lights) > 1:
        warnings.warn(_several_domes(lights), stacklevel=user_stacklevel())
    lights = [light for light in lights if not _too_small(light)]
    lower, upper = scene.bounds()
    # The scene's own radius however small (1e-6 for a point): the distant and dome lights' selection weights are
    # their power over a disc of it, against the area lights' own; held at 1e-6, a scene 1e-8 across drew its lights
    # with other odds than the unscaled scene, and the same seed gave another image (pixels 0.2 apart).
    radius = float(np.linalg.norm(np.asarray(upper, np.float64) - lower)) / 2.0 or 1e-6
    h = HostLights(*([] for _ in dataclasses.fields(HostLights)))
    zero = np.zeros(3)
    domes = [light for light in lights if isinstance(light, DomeLight)]
    dome_index, dome = -1, None
    mesh_lights = [light for light in lights if isinstance(light, MeshLight)]
    emitted = {}  # id of a light's texture -> (it, its texels, their mean): see _shared_texels
    textured = {}  # row of h -> the textured light (rect or dome) it holds
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
            if drawn_as_disc(light):
                half = light.half_angle  # up to pi: a disc wider than a hemisphere
                one_minus = 2.0 * math.sin(half / 2.0) ** 2  # 1 - cos(half) without cancellation
                cone = 2.0 * math.pi * one_minus
                _add(h, LIGHT_DISTANT, light.radiance, d, zero, zero, zero, (math.cos(half), cone, one_minus, 0), 0,
                     0.0)
            else:
                _add(h, LIGHT_DISTANT, e, d, zero, zero, zero, (1.0, 0.0, 0, 0), 0, 0.0)
            h.power[-1] = luminance_np(e) * math.pi * radius**2
        elif isinstance(light, SphereLight):
            if light.drawn_as_point:
                i = light.intensity
                _add(h, LIGHT_POINT, i, light.position, zero, zero, zero, (0, 0, 0, 0), 0,
                     4.0 * math.pi * luminance_np(i))
            elif light.ellipsoid() is None:
                L = light.radiance
                # The area times down^2, as the other area lights' (unread: the cone's solid angle stands for it; in
                # world units, past a radius of 5e18, its float32 cast overflowed behind numpy's warning)
                down = length_scale([light.world_radius])
                _add(h, LIGHT_SPHERE, L, light.position, zero, zero, zero,
                     (light.world_radius, 0, light.area * down**2, 0), 0, math.pi * light.area * luminance_np(L))
            else:
                m, L, area = light.ellipsoid(), light.radiance, light.area
                g = abs(float(np.linalg.det(m))) ** (1.0 / 3.0)  # for its pdf (wrt.affine_lights.ellipsoid_pdf)
                down = length_scale(m)
                _add(h, LIGHT_ELLIPSOID, L, light.position, zero, zero, zero, (g, down, area * down**2, 0), 0,
                     math.pi * area * luminance_np(L))
                h.shapes[-1] = m
            _add_shaping(h, light.shaping, light.unit_axis(), emits_behind=True, x=light.x_axis, y=light.y_axis)
        elif isinstance(light, RectLight):
            u, v = light.edges()
            _, _, z, origin = light_axes(light.to_world)
            n = _emitting_normal(u, v, z)
            L = light.radiance
            texels, mean = (None, np.ones(3)) if light.texture is None else _shared_texels(emitted, light.texture)
            textured[len(h.kinds)] = light
            down = length_scale(u, v)
            _add(h, LIGHT_RECT, L, origin, u, v, n, (0, down, light.area * down**2, _right_angled(u, v)), 0,
                 math.pi * light.area * luminance_np(L * mean))
            h.texture[-1] = texels
            _add_shaping(h, light.shaping, primary_axis(light.to_world, n), emits_behind=False,
                         x=light_axes(light.to_world)[0], y=light_axes(light.to_world)[1])
        elif isinstance(light, DiskLight):
            x, y, z, origin = light_axes(light.to_world)
            u, v = x * light.radius, y * light.radius
            # A sheared disk's ellipse, drawn by solid angle through its axes; a round or unsheared one kept as it is
            # (its draws, and so its images, unchanged).
            if np.isfinite(u).all() and np.isfinite(v).all() and not _right_angled(u, v):
                u, v = ellipse_axes(np.stack([u, v], axis=-1)[None])[0].T
            n = _emitting_normal(u, v, z)
            L = light.radiance
            down = length_scale(u, v)
            _add(h, LIGHT_DISK, L, origin, u, v, n, (0, down, light.area * down**2, _right_angled(u, v)), 0,
                 math.pi * light.area * luminance_np(L))
            _add_shaping(h, light.shaping, primary_axis(light.to_world, n), emits_behind=False,
                         x=light_axes(light.to_world)[0], y=light_axes(light.to_world)[1])
        elif isinstance(light, CylinderLight) and light.drawn_as_line:
            axis = light.world_shape()[0]
            i = light.line_intensity  # I_s: its power is pi^2 |axis| I_s, as the tube's pi A L
            _add(h, LIGHT_LINE, i, light_axes(light.to_world)[3], axis, zero, zero, (0, 0, 0, 0), 0,
                 math.pi**2 * float(np.linalg.norm(axis)) * luminance_np(i))
            _add_shaping(h, light.shaping, primary_axis(light.to_world, (0.0, 0.0, -1.0)), emits_behind=True,
                         x=light_axes(light.to_world)[0], y=light_axes(light.to_world)[1])
        elif isinstance(light, CylinderLight):
            axis, r = light.world_shape()
            origin = light_axes(light.to_world)[3]
            L = light.radiance
            m = light.tube()
            down = length_scale(axis, [r]) if m is None else length_scale(m)
            _add(h, LIGHT_CYLINDER if m is None else LIGHT_ELLIPTIC_TUBE, L, origin, axis, zero, zero,
                 (r, down, light.area * down**2, 0), 0, math.pi * light.area * luminance_np(L))
            if m is not None:
                h.shapes[-1] = m
            _add_shaping(h, light.shaping, primary_axis(light.to_world, (0.0, 0.0, -1.0)), emits_behind=True,
                         x=light_axes(light.to_world)[0], y=light_axes(light.to_world)[1])
        else:
            raise TypeError(f"unsupported light {type(light).__name__}")
        h.shadows[-1] = SHADOWS_ON if light.shadows else SHADOWS_OFF
        h.shadow_api[-1] = shadow_api_row(light)
        h.lobe_scale[-1] = np.array([light.diffuse, light.specular], np.float32)
    num_analytic = len(h.kinds)

    # Emissive triangles, then those of mesh lights, which carry their light's shadows and multipliers: appended as
    # columns below (one Python row per triangle took 24 us each, 24 s for a million-triangle emissive ceiling).
    tris = emitter_triangles(scene, material_emission, mesh_lights, sampled=sampled)
    _drop_unbounded(tris, mesh_lights)
    # Glowing analytic spheres, round tubes and other shapes (hulls) after them (wrt.glowing_spheres), within what the
    # cap leaves of instanced entries.
    first_sphere = num_analytic + len(tris.ids)
    lum = np.asarray(material_emission, np.float64).reshape(-1, 3) @ LUMINANCE
    spheres = glowing_spheres(scene, lum, max(0, MAX_INSTANCED_EMITTERS - int((tris.instances >= 0).sum())),
                              None if sampled is None else sampled.luminance(LUMINANCE))
    tris = _with_spheres(tris, spheres)

    # Dome texture (packed with the rect lights' textures) and its sampling distribution.
    row_cdf = np.array([0.0, 1.0], np.float32)
    col_cdf = np.array([0.0, 1.0], np.float32)
    dome_mean = np.zeros(3, np.float32)
    dome_sh = np.zeros((9, 3), np.float32)
    dome_rot = np.eye(3)
    if dome is not None:
        dome_rot = _nearest_rotation(np.asarray(dome.to_world, np.float64)[:3, :3]).T
        dome_mean = np.asarray(dome.color, np.float64)
        texels = None
        if dome.texture is not None:
            # The rect lights' memo: a rect light reading the dome's image shares its texels, uploaded once as
            # device_texture_bytes counts them (they were made apart here, and uploaded twice).
            texels = h.texture[dome_index] = _shared_texels(emitted, dome.texture)[0]
            textured[dome_index] = dome
            row_cdf, col_cdf, mean = _dome_distribution(texels)
            dome_mean = dome_mean * mean  # in float64: a colour of 1e30 times texels of 1e10 passed float32
        dome_sh = irradiance_coefficients(dome.color, texels)
        if num_analytic:
            h.power[dome_index] = 4.0 * math.pi**2 * radius**2 * luminance_np(dome_mean)

    # Every emitted radiance times a power of two that brings the brightest near 1 (wrt.radiance_scale).
    if glow is None:
        glow = np.array([float(np.max(e)) for e in material_emission] or [0.0])
    scale, tri_radiance = _scaled_radiance(h, textured, tris, glow, scene.triangle_materials())
    if dome is not None:
        dome_sh, past = device_coefficients(dome_sh * scale)
        if past:
            warnings.warn(f"dome light {dome.path or '<dome>'} is too bright for Whitted's irradiance in float32 (a "
                          "harmonic past 3.4e38): its dome term is clamped to float32's largest",
                          stacklevel=user_stacklevel())

    n = num_analytic + len(tris.ids)
    pmf, cdf = _selection(np.concatenate([np.asarray(h.power, np.float64), tris.power]))

    e = len(tris.ids)
    owned = tris.owner >= 0
    tri_shadows = np.full(e, SHADOWS_ON, np.int32)
    tri_lobes = np.ones((e, 2), np.float32)
    if mesh_lights:
        modes = np.array([SHADOWS_ON if light.shadows else SHADOWS_OFF for light in mesh_lights], np.int32)
        tri_shadows[owned] = modes[tris.owner[owned]]
        tri_lobes[owned] = np.float32([[light.diffuse, light.specular] for light in mesh_lights])[tris.owner[owned]]

    def arr(values, dtype, width=3, triangles=None):
        """The analytic lights' ``values`` and the triangles' rows below them (``triangles``: None for a column of
        the analytic lights alone, which no triangle reads: a million emissive triangles took 100 MB more)."""
        numpy_type = np.int32 if dtype == wp.int32 else np.float32
        shape = (-1, width) if width > 1 else (-1,)
        rows = np.zeros((0, width) if width > 1 else 0, numpy_type) if triangles is None else triangles
        data = np.concatenate([np.asarray(values, numpy_type).reshape(shape), np.asarray(rows, numpy_type)])
        return wp.array(data if len(data) else np.zeros((1, width) if width > 1 else 1, numpy_type), dtype=dtype,
                        device=device)

    d = DeviceLights()
    d.kinds = arr(h.kinds, wp.int32, 1)  # the rest are LIGHT_TRIANGLE
    d.radiance = arr(h.radiance, wp.vec3, 3, tri_radiance)
    d.radiance_scale = scale
    d.position = arr(h.position, wp.vec3)
    d.axis_u = arr(h.axis_u, wp.vec3)
    d.axis_v = arr(h.axis_v, wp.vec3)
    d.normal = arr(h.normal, wp.vec3)
    tri_params = tris.params.copy()
    tri_params[:, 3] = _emitted_luminance(tris, _TriangleEmission(material_emission, scene.triangle_materials(),
                                                                  sampled))
    d.params = arr(h.params, wp.vec4, 4, tri_params)
    d.prims = arr(h.prims, wp.int32, 1, tris.ids)
    d.instances = arr(np.full(num_analytic, -1), wp.int32, 1, tris.instances)
    first = np.where(tris.instance_first >= 0, tris.instance_first + num_analytic, -1)
    d.instance_emitters = wp.array((first if len(first) else np.full(1, -1)).astype(np.int32), dtype=wp.int32,
                                   device=device)
    d.shaping = arr(h.shaping, wp.vec4, 4)
    d.shaping_axis = arr(h.shaping_axis, wp.vec3)
    d.focus_tint = arr(h.focus_tint, wp.vec3)
    d.ies, d.ies_frame, d.ies_data = _upload_profiles(h.ies, h.ies_frame, num_analytic, device)
    d.lobe_scale = arr(h.lobe_scale, wp.vec2, 2, tri_lobes)
    # Ellipsoids and elliptic tubes: their map from the unit shape and its inverse (analytic lights only).
    shapes = np.asarray(h.shapes, np.float64).reshape(-1, 3, 3) if h.shapes else np.eye(3)[None]
    d.shapes = wp.array(shapes.astype(np.float32), dtype=wp.mat33, device=device)
    d.shape_inverses = wp.array(np.linalg.inv(shapes).astype(np.float32), dtype=wp.mat33, device=device)
    d.pmf = wp.array(pmf.astype(np.float32), dtype=float, device=device)
    d.cdf = wp.array(cdf.astype(np.float32), dtype=float, device=device)
    d.emitter_cdf = wp.array(_emitter_cdf(pmf[num_analytic:n]).astype(np.float32), dtype=float, device=device)
    d.count = n
    d.num_analytic = num_analytic
    d.first_glowing_sphere = first_sphere
    d.glowing_spheres = wp.array((spheres.spheres if len(spheres.ids) else np.zeros((1, 4))).astype(np.float32),
                                 dtype=wp.vec4, device=device)
    d.glowing_axes = wp.array((spheres.axes if len(spheres.ids) else np.zeros((1, 4))).astype(np.float32),
                              dtype=wp.vec4, device=device)
    d.glowing_tapers = wp.array((spheres.tapers if len(spheres.ids) else np.ones(1)).astype(np.float32), dtype=float,
                                device=device)
    hulls = spheres.hulls.reshape(-1, 3, 3) if len(spheres.hulls) else np.tile(np.eye(3), (2, 1, 1))
    d.hull_maps = wp.array(hulls.astype(np.float32), dtype=wp.mat33, device=device)
    # Each instance's first sphere entry (4 bytes an instance), only where some instance has one: read only for the
    # slot of a prototype sphere (light_sampling.hit_emitter), which none has without them.
    first = np.where(spheres.instance_first >= 0, spheres.instance_first + first_sphere, -1)
    first = first if (spheres.instances >= 0).any() else np.full(1, -1)
    d.instance_glowing_spheres = wp.array(first.astype(np.int32), dtype=wp.int32, device=device)
    d.first_shape_id = scene.num_geometry_triangles
    d.dome = dome_index
    d.dome_to_local = wp.mat33(*dome_rot.astype(np.float32).reshape(-1))
    d.dome_textured = 1 if (dome is not None and dome.texture is not None) else 0
    d.dome_row_cdf = wp.array(row_cdf, dtype=float, device=device)
    d.dome_col_cdf = wp.array(col_cdf, dtype=float, device=device)
    d.dome_sh = wp.array(dome_sh, dtype=wp.vec3, device=device)
    d.texture, d.texels = _upload_textures(h.texture, num_analytic, device)
    d.headlight = -1  # set by the renderer, which knows the cameras (set_headlight_directions)
    d.headlight_dirs = wp.zeros(1, dtype=wp.vec3, device=device)
    # Links of the analytic lights in device order (the dome's at dome_index; a second dome is not on the device),
    # then of the mesh lights, whose triangles share their light's column.
    on_device = [light for light in lights if not isinstance(light, (DomeLight, MeshLight)) or light is dome]
    columns = np.concatenate([np.arange(num_analytic), np.where(tris.owner >= 0, num_analytic + tris.owner, -1)])
    links = link_groups(scene, on_device + mesh_lights)
    d.links = upload_links(links, device, columns)
    modes = _shadow_modes(np.concatenate([np.int32(h.shadows).reshape(-1), tri_shadows]), links, columns)
    tinted = [k for k, row in enumerate(h.shadow_api) if row is not None]
    modes[tinted] = SHADOWS_TINTED  # (shadows on: shadow_api_row is None for a light without them)
    # A mesh light's ShadowAPI rows go to each of its triangles, whose entries then need rows too (none otherwise:
    # a triangle's row is kept small).
    mesh_rows = [shadow_api_row(light) for light in mesh_lights]
    mesh_tinted = np.array([row is not None for row in mesh_rows] + [False], bool)  # (a row for owner -1)
    triangles_tinted = np.flatnonzero(mesh_tinted[tris.owner]) if mesh_tinted.any() else np.zeros(0, np.int64)
    modes[num_analytic + triangles_tinted] = SHADOWS_TINTED
    d.shadows = wp.array(modes, dtype=wp.int32, device=device)
    rows = np.zeros((max(n if len(triangles_tinted) else num_analytic, 1), 6), np.float32)
    for k in tinted:
        rows[k] = h.shadow_api[k]
    if len(triangles_tinted):
        owner_rows = np.stack([row if row is not None else np.zeros(6, np.float32) for row in mesh_rows])
        rows[num_analytic + triangles_tinted] = owner_rows[tris.owner[triangles_tinted]]
    d.shadow_api = wp.array(rows[:, :4], dtype=wp.vec4, device=device)
    d.shadow_fade = wp.array(rows[:, 4:], dtype=wp.vec2, device=device)
    d.shadow_api_on = 1 if tinted or len(triangles_tinted) else 0
    # (from the host rows d.params was made of: read back from the device, each upload waited on a copy)
    segment, sky = rays_meet(np.asarray(h.kinds, np.int32), np.asarray(h.params, np.float32).reshape(-1, 4))
    d.segment_lights, d.num_segment_lights = _index_list(segment, device), len(segment)
    d.sky_lights, d.num_sky_lights = _index_list(sky, device), len(sky)
    features = light_features(h.kinds, [row[3] != 0.0 for row in h.shaping], first_sphere < n)
    slots = emitter_slots(tris, num_analytic, first_sphere - num_analytic, spheres.instance_first,
                          len(scene.triangle_materials()))
    return LightTable(d, tris.unsampled, features, slots, tris.ids[tris.params[:, 1] > 0.0])


def _scaled_radiance(h: HostLights, textured: dict, tris: EmitterTriangles, glow: np.ndarray,
                     tri_materials: np.ndarray) -> tuple[float, np.ndarray]:
    """``(scale, triangle radiance)``: the power of two that brings the brightest emitted radiance near 1
    (:func:`wrt.radiance_scale.radiance_scale` of :func:`_brightest`; ``glow`` per device material, ``tri_materials``
    the scene's per triangle), ``h.radiance`` made times it in place, and the triangles' radiance factors times it
    where they do not multiply their material's glow (which is scaled with the materials). The dome's harmonics are
    the caller's to scale."""
    tri_glow = np.where(tris.params[:, 0] > 0.0, glow[tri_materials[tris.ids]], 1.0) if len(tris.ids) \
        else np.zeros(0)
    scale = radiance_scale(_brightest(h, textured, tris.radiance, tri_glow, glow))
    if scale == 1.0:
        return scale, tris.radiance
    h.radiance = np.asarray(h.radiance, np.float64).reshape(-1, 3) * scale  # (a row at a time: 0.3 s for 100k lights)
    return scale, np.where(tris.params[:, :1] > 0.0, tris.radiance, tris.radiance * np.float32(scale))


def _emitted_luminance(tris: EmitterTriangles, emission: _TriangleEmission) -> np.ndarray:
    """``(E,)`` float32: the luminance of the radiance each row of ``tris`` emits (its power over pi, its area and its
    sides), over the largest of them, at least 2^-32: the resampling target of :mod:`wrt.emitter_resampling` reads it
    with a triangle's solid angle. A radiance, not a power: dimensionless, so the same at every scene scale, where
    the power over the area is a length to the -2. The floor keeps every row's weight positive wherever it can light
    a point (a row of no light has none to give; one of little light is only drawn more often than it is worth)."""
    if len(tris.ids) == 0:
        return np.zeros(0, np.float32)
    follows = tris.params[:, :1] > 0.0  # radiance times the material's emission
    rgb = tris.radiance.astype(np.float64) * np.where(follows, emission.rgb(tris.ids), 1.0)
    lum = np.nan_to_num(np.maximum(rgb @ LUMINANCE, 0.0), posinf=FLOAT32_MAX)
    brightest = lum.max()
    return np.maximum(lum / brightest if brightest > 0.0 else lum, 2.0**-32).astype(np.float32)


def _brightest(h: HostLights, textured: dict, tri_radiance: np.ndarray, tri_glow: np.ndarray,
               glow: np.ndarray) -> float:
    """The largest radiance (float64) the lights of ``h`` emit (times their textures' largest texel), the triangles
    of ``tri_radiance`` (``(E, 3)`` factors, times ``tri_glow``: ``(E,)`` their material's glow where they follow it,
    else 1) and any material (``glow``, per device material). Warns, naming the light (``textured``: row of ``h`` ->
    light), where a textured light's radiance passes float32's range, as no image can hold what sees it."""
    brightest = float(np.max(glow)) if len(glow) else 0.0
    if h.radiance:
        largest = {}  # id of a texture -> its largest texel per channel: lamps share one image
        texel = np.ones((len(h.radiance), 3))
        for k in textured:
            texels = h.texture[k]
            if texels is not None:
                if id(texels) not in largest:
                    largest[id(texels)] = texels.reshape(-1, 3).max(axis=0).astype(np.float64)
                texel[k] = largest[id(texels)]
        peaks = (np.abs(np.asarray(h.radiance, np.float64)) * texel).max(axis=1)
        brightest = max(brightest, float(np.max(peaks)))
        for k in (k for k in textured if peaks[k] > FLOAT32_MAX):  # a colour and a texture float32 holds apart
            light = textured[k]
            warnings.warn(f"{type(light).__name__} {light.path or '<light>'}: its radiance "
                          f"({np.max(np.abs(h.radiance[k])):.3g}: intensity * 2^exposure * color) times its texture's "
                          f"texels (up to {np.max(texel[k]):.3g}) reaches {peaks[k]:.3g}, past float32's range "
                          "(3.4e38): no image holds what sees it (its pixels are float32's largest)",
                          stacklevel=user_stacklevel())
    if len(tri_radiance):
        brightest = max(brightest, float(np.max(np.abs(tri_radiance).max(axis=1) * tri_glow)))
    return brightest


def _selection(power: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(pmf, cdf)`` float64 of drawing each of the ``n`` lights of ``power`` (NaN and negative powers as 0): half
    by power, half uniformly; ``pmf`` has ``max(n, 1)`` entries, ``cdf`` ``n + 1`` (``[0, 1]`` for none).

    The cdf lies on the grid of the uniform numbers that draw from it (multiples of 2^-24, wp.randf; float32 holds
    them exactly) and each pmf is the step that draws it, as sample_cdf picks k for the u in ``[cdf[k], cdf[k + 1])``:
    the float32 rounding of the power shares and of their sums would draw lights up to 2.4% more or less often than
    their light is divided by (200,000 emitters; 7.7% at a million), a fixed pattern no sample count removes."""
    n = len(power)
    power = np.maximum(np.nan_to_num(power, nan=0.0), 0.0)
    pmf = np.zeros(max(n, 1))
    if not n:
        return pmf, np.array([0.0, 1.0])
    pmf[:n] = 0.5 / n + (0.5 * power / power.sum() if power.sum() > 0 else 0.5 / n)
    pmf[:n] /= pmf[:n].sum()
    cdf = np.round(np.concatenate([[0.0], np.cumsum(pmf[:n])]) * SELECTION_GRID) / SELECTION_GRID
    cdf[-1] = 1.0
    pmf[:n] = np.diff(cdf)
    return pmf, cdf


def _emitter_cdf(pmf: np.ndarray) -> np.ndarray:
    """The cdf of the triangles' selection ``pmf`` over its total, on the grid of the uniform numbers that draw
    from it (as the lights' cdf, :data:`SELECTION_GRID`; uniform where their pmf all rounded to 0), ``[0, 1]`` for
    none."""
    if len(pmf) == 0:
        return np.array([0.0, 1.0])
    steps = pmf if pmf.sum() > 0.0 else np.ones(len(pmf))
    cdf = np.round(np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum() * SELECTION_GRID) / SELECTION_GRID
    cdf[-1] = 1.0
    return cdf


def rays_meet(kinds: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The indices of the analytic lights of ``kinds`` (``params``: their float32 rows as uploaded) that a ray can
    meet, ascending: the area lights it may pass through, and the dome and the distant lights of a cone (the cone
    as :func:`wrt.light_sampling.distant_in_cone` reads it) it may escape into. Only these can add to a BSDF-sampled
    ray's radiance (:func:`wrt.integrators.emitters.lights_on_segment`, ``environment``)."""
    area = np.isin(kinds, (LIGHT_SPHERE, LIGHT_RECT, LIGHT_DISK, LIGHT_CYLINDER, LIGHT_ELLIPSOID, LIGHT_ELLIPTIC_TUBE))
    sky = (kinds == LIGHT_DOME) | ((kinds == LIGHT_DISTANT) & (params[:, 1] > 0.0))
    return np.flatnonzero(area).astype(np.int32), np.flatnonzero(sky).astype(np.int32)


def _index_list(indices: np.ndarray, device) -> wp.array:
    """``indices`` on the device, one row of -1 (never read) where there are none."""
    return wp.array(indices if len(indices) else np.full(1, -1, np.int32), dtype=wp.int32, device=device)


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
    first = {}  # id of an image -> the light whose row packs it: lights sharing one image share its texels
    for k, texels in enumerate(textures):
        if texels is not None:
            if id(texels) in first:
                info[k] = info[first[id(texels)]]
                continue
            first[id(texels)] = k
            info[k] = (offset, texels.shape[1], texels.shape[0])
            offset += texels.shape[0] * texels.shape[1]
    # Filled in place: a list of the images concatenated held a second copy of them all (a dome's 400 MB at 8k).
    packed = np.ones((offset, 3), np.float32)
    for k in first.values():
        texels = textures[k]
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


def length_scale(*lengths) -> float:
    """The power of two ``down`` that brings the largest magnitude in ``lengths`` (vectors or lists of lengths) into
    [1, 2) (1 when it is 0), kept a normal float32 with its inverse: rect, disk and cylinder lights are sampled in
    their lengths times it (:func:`wrt.light_sampling.light_scales`), their ``params[2]`` the area times ``down^2``."""
    largest = max(float(np.max(np.abs(np.asarray(x, np.float64)))) for x in lengths)
    if not (largest > 0.0 and math.isfinite(largest)):
        return 1.0
    exponent = math.frexp(largest)[1] - 1  # largest in [2^exponent, 2^(exponent + 1))
    return math.ldexp(1.0, -min(max(exponent, -126), 126))


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


# The rows a light without shaping, profile, texture or shape matrix gets: shared by every light, as only stacked
# (0.3 of 2.3 us per light went to making them anew). Read-only: a row is replaced, never edited in place.
_NO_SHAPING, _NO_AXIS = _read_only(np.zeros(4, np.float32)), _read_only(np.zeros(3, np.float32))
_EYE32, _EYE64 = _read_only(np.eye(3, dtype=np.float32)), _read_only(np.eye(3))
_BOTH_LOBES = _read_only(np.ones(2, np.float32))


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
    h.shadow_api.append(None)
    h.shaping.append(_NO_SHAPING)
    h.shaping_axis.append(_NO_AXIS)
    h.focus_tint.append(_NO_AXIS)
    h.ies.append(None)
    h.ies_frame.append(_EYE32)
    h.texture.append(None)
    h.lobe_scale.append(_BOTH_LOBES)
    h.shapes.append(_EYE64)


def _add_shaping(h: HostLights, shaping: Shaping | None, axis, emits_behind: bool, x=(1.0, 0.0, 0.0),
                 y=None) -> None:
    """Gives the light added last ``shaping`` around unit ``axis`` (its IES profile turned by the light's X and Y
    axes ``x``, ``y``: :func:`wrt.light_shaping.ies_frame`; nothing where it changes nothing), and scales its power
    by the share the shaping lets out."""
    params = None if shaping is None else shaping.device_params(emits_behind)
    if params is None and (shaping is None or shaping.ies is None):
        return
    h.power[-1] *= shaping.power_fraction(emits_behind)  # the cone, focus and profile together
    if params is None:  # a profile alone: the cone and focus let everything through
        params = (math.pi, math.pi, 0.0)
    h.shaping[-1] = np.array([*params, 1.0], np.float32)
    h.shaping_axis[-1] = np.asarray(axis, np.float32)
    h.focus_tint[-1] = np.asarray(shaping.focus_tint, np.float32)
    if shaping.ies is not None:
        h.ies[-1] = shaping.ies.device_data(shaping.ies_angle_scale, shaping.ies_scale())
        h.ies_frame[-1] = ies_frame(axis, x, y)


def _upload_profiles(profiles: list, frames: list, count: int, device) -> tuple[wp.array, wp.array, wp.array]:
    """The ``(offset, vertical count, horizontal count)`` of each of ``count`` lights' IES profile (``profiles``:
    :meth:`wrt.ies.IesProfile.device_data` or None; vertical count 0: none), their frames and their data packed
    one after the other (one 0 when there is none)."""
    info = np.zeros((max(count, 1), 3), np.int32)
    packed = [np.zeros(1, np.float32)]
    offset = 1
    shared = {}  # id of a profile's data -> its offset: lights sharing one profile share its data
    for k, found in enumerate(profiles):
        if found is None:
            continue
        data, n_v, n_h = found
        if id(data) not in shared:
            shared[id(data)] = offset
            packed.append(data)
            offset += len(data)
        info[k] = (shared[id(data)], n_v, n_h)
    frame_rows = np.asarray(frames, np.float32).reshape(-1, 3, 3) if frames else np.eye(3, dtype=np.float32)[None]
    return (wp.array(info, dtype=wp.vec3i, device=device), wp.array(frame_rows, dtype=wp.mat33, device=device),
            wp.array(np.concatenate(packed), dtype=float, device=device))


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
    image that :func:`wrt.light_sampling.dome_radiance` looks up.

    Each texel's weight is the luminance of the filtered image averaged over the texel: ``[1/8, 3/4, 1/8]`` of it and
    its neighbours along each axis (longitude wrapping around, latitude clamped at the poles). It is positive wherever
    the filtered image is, so light sampling can draw every lit direction: the texels' own luminance gave a black
    texel next to a bright one no share although filtering lights half of it.
    """
    hgt = texels.shape[0]
    theta = (np.arange(hgt) + 0.5) / hgt * np.pi
    sin_t = np.sin(theta)[:, None]
    # In float64: neighbours near float32's largest value (a Radiance component clamped to it) sum past its range
    # in the filter below, and inf / inf made the CDFs NaN.
    lum = 0.2126 * texels[..., 0].astype(np.float64)  # a channel at a time: no float64 copy of the whole image
    lum += 0.7152 * texels[..., 1]
    lum += 0.0722 * texels[..., 2]
    lum = 0.75 * lum + 0.125 * (np.roll(lum, 1, axis=1) + np.roll(lum, -1, axis=1))
    rows = np.concatenate([lum[:1], lum, lum[-1:]])
    lum = 0.75 * rows[1:-1] + 0.125 * (rows[:-2] + rows[2:])
    # A black image still has directions to draw: a floor relative to the brightest texel (a floor of 1e-8 alone
    # outweighed a dome of texels 1e-20 lit by a colour of 1e20, which was then sampled uniformly, not by its image).
    brightest = float(lum.max())
    f = lum * sin_t + 1e-8 * (brightest if brightest > 0.0 else 1.0) * (sin_t + 1e-6)
    col = np.concatenate([np.zeros((hgt, 1)), np.cumsum(f, axis=1)], axis=1)
    row_sums = col[:, -1]
    row = np.concatenate([[0.0], np.cumsum(row_sums)])
    # Filtering along a row keeps its mean (longitude wraps around); across rows it does not, as sin(theta) weighs
    # the rows unequally: the mean over the sphere weighs each row's mean by the integral of its latitude hat
    # function times sin(theta) over 2 (which sums to 1).
    row_means = texels.mean(axis=1, dtype=np.float64)
    mean = _latitude_hat_weights(hgt) @ row_means / 2.0
    # Sampling reads only ratios of the CDFs: scaled to a total of 1 in float64 they fit float32 whatever the image's
    # brightness (a Radiance dome of exponent byte 255 sums past 3.4e38: its CDFs were inf and its samples wrong).
    total = row[-1]
    return (row / total).astype(np.float32), (col / total).reshape(-1).astype(np.float32), mean.astype(np.float32)


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


def _drop_unbounded(tris: EmitterTriangles, mesh_lights: list) -> None:
    """Makes the triangles of ``tris`` whose radiance float32 cannot hold (a normalized mesh light too small for
    ``color / area`` in an instance; in the world :func:`emitter_triangles` leaves it out) emit nothing, naming their
    lights in a warning: their infinite power made every light's selection probability NaN, with numpy's overflow
    warning alone."""
    bad = ~np.isfinite(tris.radiance).all(axis=1)
    if not bad.any():
        return
    _warn_unbounded([mesh_lights[j] for j in np.unique(tris.owner[bad]) if j >= 0], int(bad.sum()))
    tris.radiance[bad] = 0.0
    tris.power[bad] = 0.0


def _warn_unbounded(lights: list, triangles: int) -> None:
    """Names mesh ``lights`` too small for their radiance to fit in float32, whose ``triangles`` light nothing."""
    names = ", ".join(f"MeshLight {light.path or '<light>'}" for light in lights[:5])
    warnings.warn(f"{names}{' and more' if len(lights) > 5 else ''}: normalized, too small for its radiance "
                  f"(intensity / area) to fit in float32: its {triangles} triangle(s) light nothing",
                  stacklevel=user_stacklevel())


def _several_domes(lights: list) -> str:
    """The warning for ``lights`` holding several dome lights, of which only the first is used: it names that one and
    those left out, each by its path or, built in Python without one, by its place in the list (``scene.lights[k]``):
    a dome without a path was named ``()``."""
    names = [light.path or f"scene.lights[{k}]" for k, light in enumerate(lights) if isinstance(light, DomeLight)]
    left_out = ", ".join(names[1:-1]) + (" and " if len(names) > 2 else "") + names[-1]
    verb = "lights" if len(names) == 2 else "light"
    return f"{len(names)} dome lights: only the first ({names[0]}) is used; {left_out} {verb} nothing"


def _too_small(light) -> bool:
    """Whether ``light`` is a normalized rect or disk light too small for its radiance (``color / area``) to fit in
    float32, named in a warning: it lights nothing, as load_usd skips such a light (wrt.usd_lights); built in Python,
    a disk drew a black image without a word (a sphere is drawn as a point and a tube as a line instead)."""
    if not (isinstance(light, (RectLight, DiskLight)) and light.normalize) or np.isfinite(light.radiance).all():
        return False
    warnings.warn(f"{type(light).__name__} {light.path or '<light>'}: normalized, too small for its radiance "
                  f"(intensity / area {light.area:.3g}) to fit in float32: it lights nothing",
                  stacklevel=user_stacklevel())
    return True


def _shared_texels(memo: dict, texture: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(texels, mean)``: :func:`_emitted_texels` of a light's ``texture`` and their ``(3,)`` float64 mean, made
    once per image object (``memo``, kept over one build): lights that read one file share its image
    (``usd_lights.LightTextures``), and 10,000 instanced lamps packed 10,000 copies of it on the device."""
    key = id(texture)
    if key not in memo:  # the texture is kept in the entry, so that its id names it while the memo lives
        texels = _emitted_texels(texture)
        memo[key] = (texture, texels, texels.reshape(-1, 3).mean(axis=0, dtype=np.float64))
    return memo[key][1], memo[key][2]


def _emitted_texels(texture: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` float32 RGB of a light's texture with negative, NaN and infinite texels made 0."""
    texels = np.ascontiguousarray(texture[..., :3], np.float32)
    return np.nan_to_num(np.maximum(texels, 0.0), nan=0.0, posinf=0.0)
