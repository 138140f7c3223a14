"""Glowing analytic spheres as lights: the spheres of a scene built in Python (``wrt.Shape``) and those of
instances (the spheres of a ``Points`` prim are instances of one), bound to an emissive material, become light-table
entries of their own, sampled by the cone they subtend as a SphereLight is (:mod:`wrt.light_sampling`), with the
emission their material shows on them (shapes read their textures at one constant ``st``, so the glow is the same
all over the sphere).

A sphere is sampled where it emits outwards (``orientation`` rightHanded, or double-sided) and its world transform
is a similarity (a rotation times one scale: an unevenly scaled sphere is an ellipsoid, which stays unsampled); the
spheres of an instance are sampled all or none, the first instances whose spheres fit in the cap on instanced
emitter entries. Tubes and other glowing shapes are not sampled (:attr:`GlowingSpheres.left_out` counts them).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

# Largest departure of A^T A from s^2 I, over s^2, for a sphere's world transform (linear part A) to count as a
# similarity: float32 transforms of Points widths round near 1e-7.
SIMILARITY_TOLERANCE = 1e-5


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
        left_out: glowing shapes not sampled (counted once per instance that draws them): tubes and other kinds,
            spheres that emit inwards or are scaled unevenly.
        past_cap: glowing spheres of instances past the cap (once per instance).
    """

    ids: np.ndarray
    instances: np.ndarray
    spheres: np.ndarray
    power: np.ndarray
    instance_first: np.ndarray
    slots: np.ndarray
    left_out: int = 0
    past_cap: int = 0


def _similar(linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(similar, scale)``: whether each ``(..., 3, 3)`` linear map is a rotation (or mirror) times one scale, and
    that scale."""
    gram = np.einsum("...ji,...jk->...ik", linear, linear)
    s2 = np.trace(gram, axis1=-2, axis2=-1) / 3.0
    off = np.abs(gram - s2[..., None, None] * np.eye(3)).max(axis=(-2, -1))
    return (s2 > 0.0) & np.isfinite(s2) & (off <= SIMILARITY_TOLERANCE * s2), np.sqrt(np.maximum(s2, 0.0))


def _candidates(shapes: list, materials: np.ndarray, glow: np.ndarray) -> tuple[np.ndarray, int]:
    """``(indices, others)``: the glowing ``shapes`` (``materials`` their device materials) that may be sampled:
    spheres that emit outwards; and how many other glowing shapes there are."""
    glowing = np.flatnonzero(glow[materials] > 0.0)  # (a loop over a million shapes that do not glow took 0.5 s)
    take = [k for k in glowing if shapes[k].kind == "sphere" and (shapes[k].params[3] >= 0.0 or shapes[k].double_sided)]
    return np.asarray(take, np.int64), len(glowing) - len(take)


def glowing_spheres(scene, glow: np.ndarray, cap: int) -> GlowingSpheres:
    """The :class:`GlowingSpheres` of ``scene`` (``glow``: per device material the luminance of its emission
    estimate), at most ``cap`` rows of instances."""
    materials = scene.triangle_materials()
    first_shape = scene.num_geometry_triangles
    ids, insts, spheres, slots = [], [], [], []
    left_out = 0
    world = list(scene.shapes)
    take, others = _candidates(world, materials[first_shape : first_shape + len(world)], glow)
    left_out += others
    if len(take):
        to_world = np.stack([np.asarray(world[k].to_world, np.float64) for k in take])
        similar, scale = _similar(to_world[:, :3, :3])
        left_out += int((~similar).sum())
        take, to_world, scale = take[similar], to_world[similar], scale[similar]
        ids.append(first_shape + take)
        insts.append(np.full(len(take), -1))
        spheres.append(np.concatenate([to_world[:, :3, 3], scale[:, None]], axis=1))
        slots.append(np.zeros(len(take), np.int64))

    n = len(scene.instances)
    instance_first = np.full(n, -1, np.int32)
    past_cap = 0
    if n:
        ranges = scene.prototype_shape_ranges()
        per_proto = {}  # prototype -> (geometry ids of its candidate spheres, their local transforms)
        for p, proto in enumerate(scene.prototypes):
            shapes = list(getattr(proto, "shapes", []))
            if not shapes:
                continue
            first = int(ranges[p, 0])
            take, others = _candidates(shapes, materials[first : first + len(shapes)], glow)
            if len(take) or others:
                local = np.stack([np.asarray(shapes[k].to_world, np.float64) for k in take]) if len(take) else None
                per_proto[p] = (first + take, local, others)
        by_prototype = scene.instances.rows_of_prototypes(len(ranges)) if per_proto else []
        visible = scene.instance_inverses()[1]
        counts = np.zeros(n, np.int64)
        usable = np.zeros(n, bool)
        to_world = scene.instances.to_world
        for p, (p_ids, local, others) in per_proto.items():
            rows = by_prototype[p][visible[by_prototype[p]]]
            left_out += others * len(rows)
            if local is None or not len(rows):
                continue
            linear = np.einsum("nij,sjk->nsik", to_world[rows, :3, :3].astype(np.float64), local[:, :3, :3])
            ok = _similar(linear)[0].all(axis=1)
            left_out += len(p_ids) * int((~ok).sum())
            counts[rows[ok]] = len(p_ids)
            usable[rows[ok]] = True
        ends = np.cumsum(counts)
        sampled = usable & (ends <= cap)
        past_cap = int(counts[usable & ~sampled].sum())
        start = sum(len(i) for i in ids)
        instance_first[sampled] = (ends - counts)[sampled] + start
        for p, (p_ids, local, _) in per_proto.items():
            rows = by_prototype[p][sampled[by_prototype[p]]]
            if local is None or not len(rows):
                continue
            m = np.einsum("nij,sjk->nsik", to_world[rows].astype(np.float64), local)  # (instances, spheres, 4, 4)
            scale = _similar(m[..., :3, :3])[1]
            order = np.argsort(instance_first[rows], kind="stable")
            rows, m, scale = rows[order], m[order], scale[order]
            ids.append(np.tile(p_ids, len(rows)))
            insts.append(np.repeat(rows, len(p_ids)))
            spheres.append(np.concatenate([m[..., :3, 3], scale[..., None]], axis=2).reshape(-1, 4))
            slots.append(np.tile(np.arange(len(p_ids)), len(rows)))
    if not ids:
        empty = np.zeros(0, np.int32)
        return GlowingSpheres(empty, empty, np.zeros((0, 4)), np.zeros(0), instance_first, empty, left_out, past_cap)
    ids_all = np.concatenate(ids).astype(np.int32)
    insts_all = np.concatenate(insts).astype(np.int32)
    spheres_all = np.concatenate(spheres)
    slots_all = np.concatenate(slots).astype(np.int32)
    # Rows in entry order: world shapes, then instances by their first row (the prototypes were visited apart).
    firsts = np.concatenate([instance_first, [-1]]).astype(np.int64)  # (a row for world shapes: instance -1)
    key = firsts[insts_all]
    order = np.lexsort((slots_all, key))
    ids_all, insts_all, spheres_all, slots_all = ids_all[order], insts_all[order], spheres_all[order], slots_all[order]
    radius = spheres_all[:, 3]
    power = math.pi * 4.0 * math.pi * radius * radius * glow[materials[ids_all]]
    return GlowingSpheres(ids_all, insts_all, spheres_all, power, instance_first, slots_all, left_out, past_cap)
