"""Glowing analytic spheres and round tubes as lights: the spheres, cylinders, cones and (tapered) capsules of a scene
built in Python (``wrt.Shape``) and those of instances (the spheres of a ``Points`` prim are instances of one, the
joints and straight segments of a ``BasisCurves`` prim instances of a sphere and an open cylinder, or an open cone
where the width changes along the segment), bound to an emissive material, become light-table entries of their own,
with the emission their material shows on them (shapes read their textures at one constant ``st``, so the glow is the
same all over the shape). Spheres are sampled by the cone they subtend as a SphereLight is, cylinders and cones
(side, and caps where capped; a cone is a cylinder whose radius shrinks linearly along its axis, its row's taper the
top radius over the bottom one) and capsules (side and two hemispheres; a tapered capsule's side the cone tangent to
its two spheres, and their zones beyond it) uniformly by area over the part whose front the shading point can see,
mixed with a draw of the side by the angles it subtends (:mod:`wrt.glowing_tubes`): the mixture's density, in closed
form, is the one a ray that hits the shape reads back for MIS.

A shape is sampled so where it emits outwards (``orientation`` rightHanded, or double-sided) and its world transform
keeps it round: a similarity (a rotation times one scale) for spheres and (tapered) capsules, and for a cylinder or cone
one scale across its axis and any along it. Every other glowing shape (boxes, planes, disks; an unevenly scaled sphere,
an ellipsoid; a cylinder squeezed across, an elliptic tube; a shape that glows inwards) is a hull row (``GLOW_HULL``,
:mod:`wrt.glowing_hulls`): drawn in the cone of an ellipsoid around it, the light point its first hit (a plane or disk
as a rect or disk light). Only a shape squashed flat by its transform is left out (:attr:`GlowingSpheres.left_out`
counts them).
The shapes of an instance are sampled all or none, the first instances whose shapes fit in the cap on instanced
emitter entries.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from .primitives import SHAPE_KINDS, Shape, local_boxes, tessellate
from .sampled_emission import SampledEmission

# Largest departure of A^T A from s^2 I, over s^2, for a sphere's world transform (linear part A) to count as a
# similarity: float32 transforms of Points widths round near 1e-7.
SIMILARITY_TOLERANCE = 1e-5

# The shape of a row (GlowingSpheres.axes[:, 3]; wrt.light_sampling reads the same codes).
GLOW_SPHERE = 0  # a sphere, sampled by its cone
GLOW_OPEN_CYLINDER = 1  # the side of a cylinder or cone (centre, bottom radius, half axis, taper), uniformly by area
GLOW_CAPPED_CYLINDER = 2  # its side and both caps, uniformly by area
GLOW_CAPSULE = 3  # the side of radius r between the centres +-axis, and a hemisphere of radius r on each
GLOW_TAPERED_CAPSULE = 4  # spheres of radius r at centre - axis and taper r at centre + axis, and the cone between
# Any other glowing shape (a box, plane or disk; a shape its transform does not keep round; one that glows inwards):
# drawn in the cone of an ellipsoid around it, the light point the shape's first hit along the direction
# (wrt.glowing_hulls); a plane or disk is drawn as a rect or disk light is (wrt.light_sampling.flat_hull). Its row
# holds the ellipsoid's (world centre, largest semi-axis), its axes row (index of its maps in GlowingSpheres.hulls,
# cube root of the map's |det|, 1 for a plane or disk whose edges or radius vectors (the map's first two columns) lie
# at right angles, else 0, code).
GLOW_HULL = 5
ROUND_KINDS = ("sphere", "cylinder", "cone", "capsule", "tapered")  # the wrt.Shape kinds sampled as round shapes
# The canonical shape lies in the ellipsoid of its box's centre and half extents times this: a box's corners at
# sqrt(3), a cylinder's rims (and a capsule's, a plane's corners) at sqrt(2), a sphere and a disk on their own.
HULL_FACTORS = {"box": math.sqrt(3.0), "sphere": 1.0, "disk": 1.0}
HULL_THICKNESS = 1e-3  # a flat shape's (plane, disk) ellipsoid is this share of its width thick
# A plane's edges (a disk's radius vectors) are at right angles where their dot product is at most this share of the
# product of their lengths, as a rect light's must be to be drawn by solid angle (wrt.light_table._right_angled).
RIGHT_ANGLE_TOLERANCE = 1e-6
HULL_SEGMENTS = 16  # the tessellation a hull's area (its selection weight) is summed over; boxes and planes exact


@dataclasses.dataclass
class GlowingSpheres:
    """The sampled glowing spheres of a scene, one row each: the world's, then each sampled instance's consecutive.

    Attributes:
        ids: ``(S,)`` int32 geometry ids of the sphere shapes (``Scene.num_geometry_triangles`` on).
        instances: ``(S,)`` int32 instance that draws the row's prototype sphere, -1: a world shape.
        spheres: ``(S, 4)`` float64 world centre and radius.
        power: ``(S,)`` float64 selection weights: pi times area times the material's glow.
        instance_first: ``(N,)`` int32 each instance's first row, -1 where none is sampled.
        slots: ``(S,)`` int32 each row's place among its instance's rows (0 for world shapes).
        left_out: glowing shapes not sampled (counted once per instance that draws them): those squashed flat by
            their transform, whose ellipsoid cannot be inverted.
        past_cap: glowing shapes of instances past the cap (once per instance).
        axes: ``(S, 4)`` float64 world half axis (from the centre to a cap's centre, or to a capsule's hemisphere's;
            zero for a sphere) and the row's ``GLOW_*`` code; a hull's (index into ``hulls``, cube root of its map's
            ``|det|``, 0, ``GLOW_HULL``), its ``spheres`` row its ellipsoid's centre and largest semi-axis.
        tapers: ``(S,)`` float64 a cone's radius at ``centre + half axis`` over its radius (the row's, at ``centre -
            half axis``), a tapered capsule's spheres' radii's ratio alike, in [0, 1]; 1 for every other row.
        hulls: ``(H, 2, 3, 3)`` float64 each hull row's map from the unit sphere to its world ellipsoid, and the
            inverse.
    """

    ids: np.ndarray
    instances: np.ndarray
    spheres: np.ndarray
    power: np.ndarray
    instance_first: np.ndarray
    slots: np.ndarray
    left_out: int = 0
    past_cap: int = 0
    axes: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 4)))
    tapers: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    hulls: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2, 3, 3)))


def _similar(linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(similar, scale)``: whether each ``(..., 3, 3)`` linear map is a rotation (or mirror) times one scale, and
    that scale."""
    gram = np.einsum("...ji,...jk->...ik", linear, linear)
    s2 = np.trace(gram, axis1=-2, axis2=-1) / 3.0
    off = np.abs(gram - s2[..., None, None] * np.eye(3)).max(axis=(-2, -1))
    return (s2 > 0.0) & np.isfinite(s2) & (off <= SIMILARITY_TOLERANCE * s2), np.sqrt(np.maximum(s2, 0.0))


def _candidates(shapes: list, glows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(indices, kinds)``: the glowing ``shapes`` (``glows`` their luminance) and their ``(K, 12)``
    float64 rows: ``(GLOW_* code, capsule's H, taper)`` (a cone is a cylinder of taper rho, a tapered capsule's rho,
    every other shape's 1; ``GLOW_HULL`` for boxes, planes, disks and shapes that glow inwards), the shape's
    ``SHAPE_KINDS`` code and ``params[0:2]``, and the centre and semi-axes of the canonical ellipsoid around it
    (:data:`HULL_FACTORS`; a flat shape's third semi-axis 0)."""
    take = np.flatnonzero(glows > 0.0)  # (a loop over a million shapes that do not glow took 0.5 s)
    kinds = np.zeros((len(take), 12))
    kinds[:, 2] = 1.0
    if not len(take):
        return take, kinds
    lowers, uppers = local_boxes([shapes[k] for k in take])
    kinds[:, 6:9] = 0.5 * (lowers + uppers)
    for row, k in enumerate(take):
        shape = shapes[k]
        kinds[row, 3:6] = SHAPE_KINDS[shape.kind], shape.params[0], shape.params[1]
        kinds[row, 9:12] = 0.5 * (uppers[row] - lowers[row]) * HULL_FACTORS.get(shape.kind, math.sqrt(2.0))
        if shape.kind not in ROUND_KINDS or not (shape.params[3] >= 0.0 or shape.double_sided):
            kinds[row, 0] = GLOW_HULL
        elif shape.kind in ("cylinder", "cone"):
            kinds[row, 0] = GLOW_CAPPED_CYLINDER if shape.params[0] > 0.0 else GLOW_OPEN_CYLINDER
            if shape.kind == "cone":
                kinds[row, 2] = float(shape.params[1])
        elif shape.kind == "capsule":
            kinds[row, :2] = GLOW_CAPSULE, float(shape.params[0])
        elif shape.kind == "tapered":
            kinds[row, :3] = GLOW_TAPERED_CAPSULE, float(shape.params[0]), float(shape.params[1])
    return take, kinds


def _placed(to_world: np.ndarray, kinds: np.ndarray, areas: bool = True) -> tuple:
    """``(ok, rows, axes, (maps, areas))`` of canonical shapes ``kinds`` (``(S, 12)``, :func:`_candidates`) under
    ``(..., S, 4, 4)`` world transforms: whether each can be sampled, its world ``(centre, radius)`` and ``(half axis,
    code)`` rows (``(..., S, 4)``), and the ellipsoid maps and areas (:func:`_hulls`; the areas 0 without
    ``areas``) of the rows drawn as hulls, in row order, which their axes rows index. A round shape stays round in
    the world (see the module docstring); one its transform does not keep round becomes a hull."""
    linear = to_world[..., :3, :3]
    code = np.broadcast_to(kinds[..., 0], linear.shape[:-2])
    similar, scale = _similar(linear)
    # A cylinder (or cone): its canonical X and Y columns orthogonal, of one length (its radius), and orthogonal to Z.
    gram = np.einsum("...ji,...jk->...ik", linear, linear)
    r2 = 0.5 * (gram[..., 0, 0] + gram[..., 1, 1])
    h2 = gram[..., 2, 2]
    across = np.maximum(np.abs(gram[..., 0, 0] - gram[..., 1, 1]), np.abs(gram[..., 0, 1]))
    along = np.maximum(np.abs(gram[..., 0, 2]), np.abs(gram[..., 1, 2]))
    cylinder = (code == GLOW_OPEN_CYLINDER) | (code == GLOW_CAPPED_CYLINDER)
    with np.errstate(invalid="ignore", over="ignore"):
        round_tube = ((r2 > 0.0) & (h2 > 0.0) & np.isfinite(r2) & np.isfinite(h2)
                      & (across <= SIMILARITY_TOLERANCE * r2) & (along <= SIMILARITY_TOLERANCE * np.sqrt(r2 * h2)))
    hull = (code == GLOW_HULL) | ~np.where(cylinder, round_tube, similar)
    radius = np.where(cylinder, np.sqrt(np.maximum(r2, 0.0)), scale)
    # The half axis: a cylinder's canonical Z column (a cone's, towards its narrow top), a capsule's times H (its
    # hemispheres' centres; a tapered capsule's spheres'), a sphere's 0.
    capsule = np.isin(code, (GLOW_CAPSULE, GLOW_TAPERED_CAPSULE))
    factor = np.where(cylinder, 1.0, np.where(capsule, kinds[..., 1], 0.0))
    axis = linear[..., :, 2] * factor[..., None]
    rows = np.concatenate([to_world[..., :3, 3], radius[..., None]], axis=-1)
    axes = np.concatenate([axis, code[..., None]], axis=-1)
    columns = np.broadcast_to(np.arange(len(kinds)), linear.shape[:-2])[hull]  # each hull row's shape
    maps, hull_areas, fine, centres, radii, roots, square = _hulls(linear[hull], to_world[..., :3, 3][hull], kinds,
                                                                   columns, areas)
    rows[hull] = np.concatenate([centres, radii[:, None]], axis=1)
    axes[hull] = np.stack([np.arange(len(maps)), roots, square, np.full(len(maps), GLOW_HULL)], axis=1)
    ok = np.ones(linear.shape[:-2], bool)
    ok[hull] = fine
    return ok, rows, axes, (maps, hull_areas)


def ellipse_axes(radii: np.ndarray) -> np.ndarray:
    """``(N, 3, 2)`` float64 axes at right angles of the ellipses ``{a u + b v : a^2 + b^2 <= 1}`` whose radius vectors
    ``u, v`` are the columns of ``radii`` (a disk under a shearing or uneven map): the same ellipses, with ``u x v`` on
    the same side, which a draw by solid angle through the rectangle around the ellipse needs."""
    # {M x : |x| <= 1} for M = [u v] = U S V^T is {U S y : |y| <= 1}: the columns of U S, the second turned where
    # V^T mirrors.
    u, s, vt = np.linalg.svd(radii, full_matrices=False)
    axes = u * s[:, None, :]
    axes[:, :, 1] *= np.sign(np.linalg.det(vt))[:, None]
    return axes


def _hulls(linear: np.ndarray, origin: np.ndarray, kinds: np.ndarray, columns: np.ndarray, areas: bool) -> tuple:
    """``(maps, areas, fine, centres, radii, roots, square)`` of ``H`` shapes drawn as hulls (``(H, 3, 3)`` linear
    parts and ``(H, 3)`` origins of their world transforms, ``columns`` their rows of :func:`_candidates`' ``kinds``):
    ``(H, 2, 3, 3)`` float64 maps from the unit sphere to the world ellipsoid around each shape and their inverses,
    the shapes' world areas (0 without ``areas``), whether the map can be inverted in float32 (a shape squashed flat
    cannot), the ellipsoids' world centres, largest semi-axes and the cube roots of the maps' ``|det|``, and 1 for a
    plane or disk whose map's first two columns (a plane's half edges times sqrt(2), a disk's radius vectors) lie at
    right angles (to :data:`RIGHT_ANGLE_TOLERANCE`), which a draw by solid angle needs, else 0. A plane's or
    disk's ellipsoid is :data:`HULL_THICKNESS` of its width thick along its normal; a disk's radius vectors are its
    ellipse's axes (a sheared disk is an ellipse whose axes lie at right angles: the same ellipsoid)."""
    from .affine_lights import FLAT_RATIO  # (affine_lights imports this module through wrt.glowing_tubes)

    m = linear * kinds[columns, None, 9:12]
    flat = np.isin(kinds[columns, 3], (SHAPE_KINDS["plane"], SHAPE_KINDS["disk"]))
    square = np.zeros(len(m))
    if flat.any():
        disk = np.flatnonzero((kinds[columns, 3] == SHAPE_KINDS["disk"]) & np.isfinite(m).all(axis=(1, 2)))
        if len(disk):
            m[disk, :, :2] = ellipse_axes(m[disk, :, :2])
        normal = np.cross(m[flat, :, 0], m[flat, :, 1])
        width = np.maximum(np.linalg.norm(m[flat, :, 0], axis=1), np.linalg.norm(m[flat, :, 1], axis=1))
        with np.errstate(invalid="ignore", divide="ignore"):
            m[flat, :, 2] = normal * (HULL_THICKNESS * width / np.linalg.norm(normal, axis=1))[:, None]
    finite = np.isfinite(m).all(axis=(1, 2))
    sizes = np.zeros((len(m), 3))
    if finite.any():
        sizes[finite] = np.linalg.svd(m[finite], compute_uv=False)
    fine = finite & (sizes[:, 2] > FLAT_RATIO * sizes[:, 0]) & (sizes[:, 0] < np.finfo(np.float32).max)
    inverses = np.zeros_like(m)
    inverses[fine] = np.linalg.inv(m[fine])
    centres = origin + np.einsum("nij,nj->ni", linear, kinds[columns, 6:9])
    roots = np.cbrt(np.abs(np.where(fine, np.linalg.det(np.where(fine[:, None, None], m, 0.0)), 0.0)))
    world_areas = _hull_areas(linear, kinds, columns) if areas else np.zeros(len(m))
    edges = m[flat, :, :2]
    lengths = np.linalg.norm(edges[:, :, 0], axis=1) * np.linalg.norm(edges[:, :, 1], axis=1)
    with np.errstate(invalid="ignore", over="ignore"):
        dots = np.abs(np.einsum("ni,ni->n", edges[:, :, 0], edges[:, :, 1]))
        square[flat] = (lengths > 0.0) & (dots <= RIGHT_ANGLE_TOLERANCE * lengths)
    return np.stack([m, inverses], axis=1), world_areas, fine, centres, sizes[:, 0], roots, square


@functools.lru_cache(maxsize=64)
def _facets(kind: str, p0: float, p1: float) -> np.ndarray:
    """``(F, 3)`` float64 area vectors (normal times area) of the canonical shape's tessellation
    (:data:`HULL_SEGMENTS`)."""
    points, triangles, _ = tessellate(Shape("/hull", kind, np.eye(4), params=np.array([p0, p1, 0.0, 1.0])),
                                      HULL_SEGMENTS)
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return 0.5 * np.cross(b - a, c - a)


def _hull_areas(linear: np.ndarray, kinds: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``(H,)`` world areas of canonical shapes ``kinds[columns]`` (:func:`_candidates` rows) under ``linear`` maps:
    their tessellations' facets, each area vector ``v`` taken to ``|cof(L) v| = sqrt(v^T G v)`` with ``G = cof(L)^T
    cof(L)``, one matrix product for all rows and facets (exact for boxes and planes): a product per row and facet
    took 28 s for 200,000 instanced boxes and spheres."""
    cofactor = np.stack([np.cross(linear[:, :, 1], linear[:, :, 2]), np.cross(linear[:, :, 2], linear[:, :, 0]),
                         np.cross(linear[:, :, 0], linear[:, :, 1])], axis=-1)
    gram = np.einsum("nki,nkj->nij", cofactor, cofactor)
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    terms = np.stack([gram[:, i, j] * (1.0 if i == j else 2.0) for i, j in pairs], axis=1)
    names = {code: name for name, code in SHAPE_KINDS.items()}
    areas = np.zeros(len(linear))
    keys, key_of_shape = np.unique(kinds[:, 3:6], axis=0, return_inverse=True)  # (S rows, not H: a sort of H took 1 s)
    key_of_row = key_of_shape.reshape(-1)[columns]
    for k, key in enumerate(keys):
        rows = np.flatnonzero(key_of_row == k)
        facets = _facets(names[int(key[0])], float(key[1]), float(key[2]))
        products = np.stack([facets[:, i] * facets[:, j] for i, j in pairs], axis=1)
        for chunk in np.array_split(rows, 1 + len(rows) * len(facets) // 4_000_000):
            areas[chunk] = np.sqrt(np.maximum(terms[chunk] @ products.T, 0.0)).sum(axis=1)
    return areas


def _areas(spheres: np.ndarray, axes: np.ndarray, tapers: np.ndarray) -> np.ndarray:
    """``(S,)`` float64 surface areas of the rows (:func:`_placed`, ``tapers`` their tapers), in closed form."""
    r = spheres[:, 3]
    top = r * tapers
    h = np.linalg.norm(axes[:, :3], axis=1)
    code = axes[:, 3]
    side = math.pi * (r + top) * np.hypot(2.0 * h, r - top)  # a frustum's: pi (r1 + r2) times its slant length
    caps = math.pi * (r * r + top * top)
    # A tapered capsule: the cone tangent to its spheres at latitude asin((r - top) / 2 h), radii cos times theirs
    # and its length shorter by (r - top) sin, and the spheres' zones below and above.
    with np.errstate(invalid="ignore", divide="ignore"):
        sin_lat = np.clip((r - top) / (2.0 * h), 0.0, 1.0)
    cos_lat = np.sqrt(1.0 - sin_lat * sin_lat)
    cone = math.pi * (r + top) * cos_lat * np.hypot(np.maximum(2.0 * h - (r - top) * sin_lat, 0.0), (r - top) * cos_lat)
    zones = 2.0 * math.pi * (r * r * (1.0 + sin_lat) + top * top * (1.0 - sin_lat))
    return np.select([code == GLOW_OPEN_CYLINDER, code == GLOW_CAPPED_CYLINDER, code == GLOW_CAPSULE,
                      code == GLOW_TAPERED_CAPSULE],
                     [side, side + caps, side + 4.0 * math.pi * r * r, cone + zones], 4.0 * math.pi * r * r)


def glowing_spheres(scene, glow: np.ndarray, cap: int, read: SampledEmission | None = None) -> GlowingSpheres:
    """The :class:`GlowingSpheres` of ``scene`` (``glow``: per device material the luminance of its emission
    estimate; ``read``, where given, that of the rows of ``scene.triangle_materials()`` it holds instead: a
    textured glow read at the shape's ``st``, :meth:`wrt.sampled_emission.SampledEmission.luminance`), at most ``cap``
    rows of instances."""
    materials = scene.triangle_materials()

    def glow_of(rows):
        return glow[materials[rows]] if read is None else read.over(rows, glow[materials[rows]])

    first_shape = scene.num_geometry_triangles
    ids, insts, spheres, axes, tapers, slots = [], [], [], [], [], []
    maps, hull_areas = [], []  # the hull rows' (wrt.glowing_hulls), which their axes rows index from 0 on
    left_out = 0

    def add_hulls(shape_axes, hulls, shape_tapers):
        """Numbers the hull rows of ``shape_axes`` after those added before and keeps their maps and areas; the
        rows' tapers (``shape_tapers``, a hull's 1)."""
        hull = shape_axes[..., 3] == GLOW_HULL
        shape_axes[hull, 0] += sum(len(m) for m in maps)
        maps.append(hulls[0])
        hull_areas.append(hulls[1])
        return np.where(hull, 1.0, shape_tapers)

    world = list(scene.shapes)
    take, kinds = _candidates(world, glow_of(np.arange(first_shape, first_shape + len(world))))
    if len(take):
        to_world = np.stack([np.asarray(world[k].to_world, np.float64) for k in take])
        ok, rows, shape_axes, hulls = _placed(to_world, kinds)
        shape_tapers = add_hulls(shape_axes, hulls, kinds[:, 2])
        left_out += int((~ok).sum())
        take = take[ok]
        ids.append(first_shape + take)
        insts.append(np.full(len(take), -1))
        spheres.append(rows[ok])
        axes.append(shape_axes[ok])
        tapers.append(shape_tapers[ok])
        slots.append(np.zeros(len(take), np.int64))

    n = len(scene.instances)
    instance_first = np.full(n, -1, np.int32)
    past_cap = 0
    if n:
        ranges = scene.prototype_shape_ranges()
        per_proto = {}  # prototype -> (geometry ids of its glowing shapes, their local transforms, kinds)
        for p, proto in enumerate(scene.prototypes):
            shapes = list(getattr(proto, "shapes", []))
            if not shapes:
                continue
            first = int(ranges[p, 0])
            take, kinds = _candidates(shapes, glow_of(np.arange(first, first + len(shapes))))
            if len(take):
                local = np.stack([np.asarray(shapes[k].to_world, np.float64) for k in take])
                per_proto[p] = (first + take, local, kinds)
        by_prototype = scene.instances.rows_of_prototypes(len(ranges)) if per_proto else []
        visible = scene.instance_inverses()[1]
        counts = np.zeros(n, np.int64)
        usable = np.zeros(n, bool)
        to_world = scene.instances.to_world
        for p, (p_ids, local, kinds) in per_proto.items():
            rows = by_prototype[p][visible[by_prototype[p]]]
            if not len(rows):
                continue
            m = np.einsum("nij,sjk->nsik", to_world[rows].astype(np.float64), local)  # (instances, shapes, 4, 4)
            ok = _placed(m, kinds, areas=False)[0].all(axis=1)
            left_out += len(p_ids) * int((~ok).sum())
            counts[rows[ok]] = len(p_ids)
            usable[rows[ok]] = True
        ends = np.cumsum(counts)
        sampled = usable & (ends <= cap)
        past_cap = int(counts[usable & ~sampled].sum())
        start = sum(len(i) for i in ids)
        instance_first[sampled] = (ends - counts)[sampled] + start
        for p, (p_ids, local, kinds) in per_proto.items():
            rows = by_prototype[p][sampled[by_prototype[p]]]
            if not len(rows):
                continue
            order = np.argsort(instance_first[rows], kind="stable")
            rows = rows[order]
            m = np.einsum("nij,sjk->nsik", to_world[rows].astype(np.float64), local)  # (instances, shapes, 4, 4)
            _, placed, shape_axes, hulls = _placed(m, kinds)
            shape_tapers = add_hulls(shape_axes, hulls, kinds[:, 2])
            ids.append(np.tile(p_ids, len(rows)))
            insts.append(np.repeat(rows, len(p_ids)))
            spheres.append(placed.reshape(-1, 4))
            axes.append(shape_axes.reshape(-1, 4))
            tapers.append(shape_tapers.reshape(-1))
            slots.append(np.tile(np.arange(len(p_ids)), len(rows)))
    if not ids:
        empty = np.zeros(0, np.int32)
        return GlowingSpheres(empty, empty, np.zeros((0, 4)), np.zeros(0), instance_first, empty, left_out, past_cap)
    ids_all = np.concatenate(ids).astype(np.int32)
    insts_all = np.concatenate(insts).astype(np.int32)
    spheres_all = np.concatenate(spheres)
    axes_all = np.concatenate(axes)
    tapers_all = np.concatenate(tapers)
    slots_all = np.concatenate(slots).astype(np.int32)
    # Rows in entry order: world shapes, then instances by their first row (the prototypes were visited apart).
    firsts = np.concatenate([instance_first, [-1]]).astype(np.int64)  # (a row for world shapes: instance -1)
    key = firsts[insts_all]
    order = np.lexsort((slots_all, key))
    ids_all, insts_all, slots_all = ids_all[order], insts_all[order], slots_all[order]
    spheres_all, axes_all, tapers_all = spheres_all[order], axes_all[order], tapers_all[order]
    # The hull rows' maps in row order (those of rows left out dropped), numbered again.
    hull = axes_all[:, 3] == GLOW_HULL
    used = axes_all[hull, 0].astype(np.int64)
    hull_maps = np.concatenate(maps)[used] if maps else np.zeros((0, 2, 3, 3))
    areas = _areas(spheres_all, axes_all, tapers_all)
    if maps:
        areas[hull] = np.concatenate(hull_areas)[used]
    axes_all[hull, 0] = np.arange(len(used))
    power = math.pi * areas * glow_of(ids_all)
    return GlowingSpheres(ids_all, insts_all, spheres_all, power, instance_first, slots_all, left_out, past_cap,
                          axes_all, tapers_all, hull_maps)
