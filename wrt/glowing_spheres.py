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

A shape is sampled where it emits outwards (``orientation`` rightHanded, or double-sided) and its world transform
keeps it round: a similarity (a rotation times one scale) for spheres and (tapered) capsules, and for a cylinder or
cone one scale across its axis and any along it (an unevenly scaled sphere is an ellipsoid, a cylinder squeezed
across an elliptic tube: they stay unsampled); the shapes of an instance are sampled all or none, the first instances
whose shapes fit in the cap on instanced emitter entries. Boxes and other glowing shapes are not sampled
(:attr:`GlowingSpheres.left_out` counts them).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

# Largest departure of A^T A from s^2 I, over s^2, for a sphere's world transform (linear part A) to count as a
# similarity: float32 transforms of Points widths round near 1e-7.
SIMILARITY_TOLERANCE = 1e-5

# The shape of a row (GlowingSpheres.axes[:, 3]; wrt.light_sampling reads the same codes).
GLOW_SPHERE = 0  # a sphere, sampled by its cone
GLOW_OPEN_CYLINDER = 1  # the side of a cylinder or cone (centre, bottom radius, half axis, taper), uniformly by area
GLOW_CAPPED_CYLINDER = 2  # its side and both caps, uniformly by area
GLOW_CAPSULE = 3  # the side of radius r between the centres +-axis, and a hemisphere of radius r on each
GLOW_TAPERED_CAPSULE = 4  # spheres of radius r at centre - axis and taper r at centre + axis, and the cone between
SAMPLED_KINDS = ("sphere", "cylinder", "cone", "capsule", "tapered")  # the wrt.Shape kinds that may be sampled


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
        left_out: glowing shapes not sampled (counted once per instance that draws them): boxes and other kinds,
            shapes that emit inwards or are scaled unevenly.
        past_cap: glowing shapes of instances past the cap (once per instance).
        axes: ``(S, 4)`` float64 world half axis (from the centre to a cap's centre, or to a capsule's hemisphere's;
            zero for a sphere) and the row's ``GLOW_*`` code.
        tapers: ``(S,)`` float64 a cone's radius at ``centre + half axis`` over its radius (the row's, at ``centre -
            half axis``), a tapered capsule's spheres' radii's ratio alike, in [0, 1]; 1 for every other row.
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


def _similar(linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(similar, scale)``: whether each ``(..., 3, 3)`` linear map is a rotation (or mirror) times one scale, and
    that scale."""
    gram = np.einsum("...ji,...jk->...ik", linear, linear)
    s2 = np.trace(gram, axis1=-2, axis2=-1) / 3.0
    off = np.abs(gram - s2[..., None, None] * np.eye(3)).max(axis=(-2, -1))
    return (s2 > 0.0) & np.isfinite(s2) & (off <= SIMILARITY_TOLERANCE * s2), np.sqrt(np.maximum(s2, 0.0))


def _candidates(shapes: list, materials: np.ndarray, glow: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """``(indices, kinds, others)``: the glowing ``shapes`` (``materials`` their device materials) that may be
    sampled: spheres, cylinders, cones and (tapered) capsules that emit outwards; their ``(K, 3)`` float64
    ``(GLOW_* code, capsule's H, taper)`` (a cone is a cylinder of taper rho, a tapered capsule's rho, every other
    shape's 1); and how many other glowing
    shapes there are."""
    glowing = np.flatnonzero(glow[materials] > 0.0)  # (a loop over a million shapes that do not glow took 0.5 s)
    take = [k for k in glowing
            if shapes[k].kind in SAMPLED_KINDS and (shapes[k].params[3] >= 0.0 or shapes[k].double_sided)]
    kinds = np.zeros((len(take), 3))
    kinds[:, 2] = 1.0
    for row, k in enumerate(take):
        shape = shapes[k]
        if shape.kind in ("cylinder", "cone"):
            kinds[row, 0] = GLOW_CAPPED_CYLINDER if shape.params[0] > 0.0 else GLOW_OPEN_CYLINDER
            if shape.kind == "cone":
                kinds[row, 2] = float(shape.params[1])
        elif shape.kind == "capsule":
            kinds[row, :2] = GLOW_CAPSULE, float(shape.params[0])
        elif shape.kind == "tapered":
            kinds[row] = GLOW_TAPERED_CAPSULE, float(shape.params[0]), float(shape.params[1])
    return np.asarray(take, np.int64), kinds, len(glowing) - len(take)


def _placed(to_world: np.ndarray, kinds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(round, rows, axes)`` of canonical shapes ``kinds`` (``(..., 3)``, :func:`_candidates`) under ``(..., 4, 4)``
    world transforms: whether each stays round in the world (see the module docstring), its world ``(centre,
    radius)`` and ``(half axis, code)`` rows (``(..., 4)``)."""
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
    ok = np.where(cylinder, round_tube, similar)
    radius = np.where(cylinder, np.sqrt(np.maximum(r2, 0.0)), scale)
    # The half axis: a cylinder's canonical Z column (a cone's, towards its narrow top), a capsule's times H (its
    # hemispheres' centres; a tapered capsule's spheres'), a sphere's 0.
    capsule = np.isin(code, (GLOW_CAPSULE, GLOW_TAPERED_CAPSULE))
    factor = np.where(cylinder, 1.0, np.where(capsule, kinds[..., 1], 0.0))
    axis = linear[..., :, 2] * factor[..., None]
    rows = np.concatenate([to_world[..., :3, 3], radius[..., None]], axis=-1)
    return ok, rows, np.concatenate([axis, code[..., None]], axis=-1)


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


def glowing_spheres(scene, glow: np.ndarray, cap: int) -> GlowingSpheres:
    """The :class:`GlowingSpheres` of ``scene`` (``glow``: per device material the luminance of its emission
    estimate), at most ``cap`` rows of instances."""
    materials = scene.triangle_materials()
    first_shape = scene.num_geometry_triangles
    ids, insts, spheres, axes, tapers, slots = [], [], [], [], [], []
    left_out = 0
    world = list(scene.shapes)
    take, kinds, others = _candidates(world, materials[first_shape : first_shape + len(world)], glow)
    left_out += others
    if len(take):
        to_world = np.stack([np.asarray(world[k].to_world, np.float64) for k in take])
        ok, rows, shape_axes = _placed(to_world, kinds)
        left_out += int((~ok).sum())
        take = take[ok]
        ids.append(first_shape + take)
        insts.append(np.full(len(take), -1))
        spheres.append(rows[ok])
        axes.append(shape_axes[ok])
        tapers.append(kinds[ok, 2])
        slots.append(np.zeros(len(take), np.int64))

    n = len(scene.instances)
    instance_first = np.full(n, -1, np.int32)
    past_cap = 0
    if n:
        ranges = scene.prototype_shape_ranges()
        per_proto = {}  # prototype -> (geometry ids of its candidate shapes, their local transforms, kinds, others)
        for p, proto in enumerate(scene.prototypes):
            shapes = list(getattr(proto, "shapes", []))
            if not shapes:
                continue
            first = int(ranges[p, 0])
            take, kinds, others = _candidates(shapes, materials[first : first + len(shapes)], glow)
            if len(take) or others:
                local = np.stack([np.asarray(shapes[k].to_world, np.float64) for k in take]) if len(take) else None
                per_proto[p] = (first + take, local, kinds, others)
        by_prototype = scene.instances.rows_of_prototypes(len(ranges)) if per_proto else []
        visible = scene.instance_inverses()[1]
        counts = np.zeros(n, np.int64)
        usable = np.zeros(n, bool)
        to_world = scene.instances.to_world
        for p, (p_ids, local, kinds, others) in per_proto.items():
            rows = by_prototype[p][visible[by_prototype[p]]]
            left_out += others * len(rows)
            if local is None or not len(rows):
                continue
            m = np.einsum("nij,sjk->nsik", to_world[rows].astype(np.float64), local)  # (instances, shapes, 4, 4)
            ok = _placed(m, kinds)[0].all(axis=1)
            left_out += len(p_ids) * int((~ok).sum())
            counts[rows[ok]] = len(p_ids)
            usable[rows[ok]] = True
        ends = np.cumsum(counts)
        sampled = usable & (ends <= cap)
        past_cap = int(counts[usable & ~sampled].sum())
        start = sum(len(i) for i in ids)
        instance_first[sampled] = (ends - counts)[sampled] + start
        for p, (p_ids, local, kinds, _) in per_proto.items():
            rows = by_prototype[p][sampled[by_prototype[p]]]
            if local is None or not len(rows):
                continue
            order = np.argsort(instance_first[rows], kind="stable")
            rows = rows[order]
            m = np.einsum("nij,sjk->nsik", to_world[rows].astype(np.float64), local)  # (instances, shapes, 4, 4)
            _, placed, shape_axes = _placed(m, kinds)
            ids.append(np.tile(p_ids, len(rows)))
            insts.append(np.repeat(rows, len(p_ids)))
            spheres.append(placed.reshape(-1, 4))
            axes.append(shape_axes.reshape(-1, 4))
            tapers.append(np.tile(kinds[:, 2], len(rows)))
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
    power = math.pi * _areas(spheres_all, axes_all, tapers_all) * glow[materials[ids_all]]
    return GlowingSpheres(ids_all, insts_all, spheres_all, power, instance_first, slots_all, left_out, past_cap,
                          axes_all, tapers_all)
