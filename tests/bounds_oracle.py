"""USD's ``BBoxCache`` as an oracle for what ``wrt.load_usd`` draws: which prims, and where.

:func:`usd_bounds` walks the stage as Hydra populates it (active, loaded, defined, non-abstract prims, through
instance proxies; a PointInstancer's descendants are drawn only through it) and keeps each visible gprim of purpose
``default`` or ``render``, and each visible PointInstancer, with ``BBoxCache.ComputeWorldBound(...)
.ComputeAlignedRange()`` (extents computed from the prims' own attributes, ``useExtentsHint=False``).

:func:`wrt_bounds` groups every rendered triangle and shape of a :class:`wrt.Scene` loaded with
``tessellate_gprims`` by the prim that owns it: a PointInstancer's (or a Points or curves prim's) instances by that
prim, everything else by the path :meth:`wrt.Scene.prim_paths` names it by (a native instance's part by its
instance-proxy path). :func:`compare` says where the two disagree.
"""

from __future__ import annotations

import math

import numpy as np
from pxr import Tf, Usd, UsdGeom

from wrt.instancing import FLAT_THICKNESS

DRAWN_PURPOSES = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)
# Prim types drawn as shapes: their extents must hold wrt's triangles and be tight to them.
TIGHT_TYPES = (UsdGeom.Mesh, UsdGeom.Cube, UsdGeom.Sphere, UsdGeom.Cylinder, UsdGeom.Cone, UsdGeom.Capsule,
               UsdGeom.Plane)


def usd_bounds(stage: Usd.Stage, time: Usd.TimeCode) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, bool]]:
    """``{path: (lower, upper, to_world, tight, pad)}`` of the prims USD shows at ``time``: the box of ``BBoxCache``'s
    ``GfBBox3d`` (float64, in the space its ``(4, 4)`` ``to_world`` matrix, row vectors as USD's, maps to the world),
    whether the drawn surface must reach the box on every side (False for curves, points, NURBS and instancers,
    whose surface may lie well inside it) and how far past it wrt may draw (:func:`round_pad`). A PointInstancer's
    instances are ``/PI[i]``. Prims whose box is empty are left out (no points); ``None`` where USD gives no
    usable box (see :func:`add`)."""
    cache = UsdGeom.BBoxCache(time, list(DRAWN_PURPOSES), useExtentsHint=False)
    out = {}
    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    for prim in it:
        if prim.IsPseudoRoot():
            continue
        if prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()  # its prototypes are drawn only through it (UsdImaging culls its children)
            if shown(prim, time):
                out.update(instance_bounds(cache, UsdGeom.PointInstancer(prim), time))
        elif prim.IsA(UsdGeom.Gprim) and shown(prim, time):
            bound = cache.ComputeWorldBound(prim)
            tight = any(prim.IsA(t) for t in TIGHT_TYPES)
            add(out, str(prim.GetPath()), bound, tight, round_pad(prim, time, bound))
    return out


def instancer_paths(stage: Usd.Stage) -> set[str]:
    """The paths of every PointInstancer of ``stage`` (instance proxies too), whose instances :func:`wrt_points`
    keeps apart as ``/PI[i]``."""
    everything = Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate))
    return {str(p.GetPath()) for p in everything if p.IsA(UsdGeom.PointInstancer)}


def shown(prim: Usd.Prim, time: Usd.TimeCode) -> bool:
    imageable = UsdGeom.Imageable(prim)
    return (imageable.ComputeVisibility(time) != UsdGeom.Tokens.invisible
            and imageable.ComputePurpose() in DRAWN_PURPOSES)


def round_pad(prim: Usd.Prim, time: Usd.TimeCode, bound) -> float:
    """How far past its USD box (in the box's units) a Points or curves prim may be drawn: USD's widths are in the
    prim's space (a sphere becomes an ellipsoid under a non-uniform transform) where wrt keeps spheres and tubes round,
    of the widths scaled by ``|M (1, 1, 1)| / sqrt(3)`` (README); tubes of cubic curves may bulge 5% of a radius.
    A loose bound: it lets the check see a prim drawn in the wrong place, not widths a little off."""
    if not (prim.IsA(UsdGeom.Points) or prim.IsA(UsdGeom.Curves)):
        return 0.0
    widths = prim.GetAttribute("widths").Get(time)
    half = 0.5 * max([float(w) for w in widths] if widths else [1.0])
    linear = np.array(bound.GetMatrix())[:3, :3]
    try:
        inverse_norm = float(np.linalg.norm(np.linalg.inv(linear), 2))
    except np.linalg.LinAlgError:
        return math.inf
    world_radius = half * float(np.linalg.norm(np.ones(3) @ linear)) / math.sqrt(3.0)
    # (sqrt(3): the corners of an analytic sphere's or tube piece's canonical box, which wrt_points reads)
    return 1.05 * math.sqrt(3.0) * world_radius * inverse_norm + half


def holds_round_prims(prim: Usd.Prim) -> bool:
    """Whether ``prim``'s subtree (through instances) holds a Points or curves prim (see :func:`round_pad`)."""
    subtree = Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate))
    return any(p.IsA(UsdGeom.Points) or p.IsA(UsdGeom.Curves) for p in subtree)


def add(out: dict, key: str, bound, tight: bool, pad: float = 0.0) -> None:
    """Adds ``bound`` (a ``GfBBox3d``) unless it is empty; ``None`` when it is not finite: BBoxCache's answer through
    a zero scale that is inverted on the way (a reset or nested instancer below it) is NaN or 1e39, no oracle."""
    box = bound.GetRange()
    if not (np.all(np.isfinite(bound.GetMatrix())) and np.all(np.abs(bound.ComputeAlignedRange().GetMin()) < 1e30)
            and np.all(np.abs(bound.ComputeAlignedRange().GetMax()) < 1e30)):
        out[key] = None
    elif not box.IsEmpty():
        out[key] = (np.array(box.GetMin()), np.array(box.GetMax()), np.array(bound.GetMatrix()), tight, pad)


def instance_bounds(cache, pi: UsdGeom.PointInstancer, time: Usd.TimeCode) -> dict:
    """``{"/PI[i]": box}`` of each instance drawn (``ComputePointInstanceWorldBounds``; the instancer's own
    ``ComputeWorldBound`` counts prototype prims of any purpose), left out: inactive (``ComputeMaskAtTime``) and
    invisible ids. Not tight: a prototype's box is the aligned box of its parts' boxes."""
    indices = pi.GetProtoIndicesAttr().Get(time) or []
    n = len(indices)
    mask = pi.ComputeMaskAtTime(time) or [True] * n
    ids = pi.GetIdsAttr().Get(time)
    ids = list(ids) if ids is not None and len(ids) == n else list(range(n))
    invisible = set(pi.GetInvisibleIdsAttr().Get(time) or [])
    # Instances of an inactive prototype (or one under an inactive prim: no prim at all) are drawn nowhere, as Hydra
    # draws them (and wrt, with a warning); BBoxCache bounds an inactive one all the same.
    stage = pi.GetPrim().GetStage()
    targets = pi.GetPrototypesRel().GetForwardedTargets()
    live = [bool(stage.GetPrimAtPath(t)) and stage.GetPrimAtPath(t).IsActive() for t in targets]
    # Round spheres and tubes under an instance's non-uniform transform: no box to hold them (round_pad)
    unknown = [live[k] and holds_round_prims(stage.GetPrimAtPath(t)) for k, t in enumerate(targets)]
    drawn = [i for i in range(n) if mask[i] and ids[i] not in invisible and 0 <= indices[i] < len(live)
             and live[indices[i]]]
    out = {}
    try:
        bounds = cache.ComputePointInstanceWorldBounds(pi, drawn)
    except Tf.ErrorException:  # a prototype it cannot bound (one inactive, nested deeper): no oracle for these
        return {f"{pi.GetPath()}[{i}]": None for i in drawn}
    for i, bound in zip(drawn, bounds):
        add(out, f"{pi.GetPath()}[{i}]", bound, False)
        if unknown[indices[i]]:
            out[f"{pi.GetPath()}[{i}]"] = None
    return out


def owners(scene, instancers) -> tuple[list[str], np.ndarray, np.ndarray]:
    """``(names, owner of each rendered triangle, owner of each rendered shape)``: indices into ``names``."""
    paths = scene.prim_paths()
    points, indices = scene.triangles()
    n_tris = len(indices)
    n_shapes = scene.stats()["rendered_shapes"]
    rows = np.arange(n_tris + n_shapes, dtype=np.int64)
    geometry, instance = scene.split_ids(rows)
    prim_ids, _ = scene.hit_prims(geometry, instance)
    names = list(paths)
    # A PointInstancer's instance is its own owner; a Points or curves prim's spheres and tubes belong to it.
    source_names = {}
    owner = prim_ids.copy()
    for i in np.unique(instance[instance >= 0]):
        if scene.instances.index[i] >= 0:
            name = scene.instances.source_path(int(i))
            if name in instancers:
                name = scene.instances.path(int(i))
            if name not in source_names:
                source_names[name] = len(names)
                names.append(name)
            owner[instance == i] = source_names[name]
    return names, owner[:n_tris], owner[n_tris:]


def wrt_points(scene, instancers=frozenset()) -> dict[str, np.ndarray]:
    """``{owner path: (K, 3) float64 world points}``: the corners of what ``scene`` draws of each owner (see the
    module docstring): its triangles' corners and the corners of its analytic shapes' canonical boxes."""
    names, tri_owner, shape_owner = owners(scene, instancers)
    points, indices = scene.triangles()
    corners = [points[indices].astype(np.float64).reshape(-1, 3)]
    owner = [np.repeat(tri_owner, 3)]
    if len(shape_owner):
        corners.append(rendered_shape_corners(scene).reshape(-1, 3))
        owner.append(np.repeat(shape_owner, 8))
    corners = np.concatenate(corners)
    owner = np.concatenate(owner)
    order = np.argsort(owner, kind="stable")
    split = np.searchsorted(owner[order], np.arange(len(names) + 1))
    return {name: corners[order[split[k]:split[k + 1]]] for k, name in enumerate(names) if split[k + 1] > split[k]}


def rendered_shape_corners(scene) -> np.ndarray:
    """``(S, 8, 3)`` world corners of each rendered analytic shape's canonical box, in ``Hits.prim`` order (the
    non-instanced shapes, then each instance's)."""
    transforms = [s.to_world for s in scene.shapes]
    boxes = [s.local_bounds() for s in scene.shapes]
    inst = scene.instances
    for i in range(len(inst)):
        for s in scene.prototypes[inst.prototype[i]].shapes:
            transforms.append(inst.to_world[i] @ s.to_world)
            boxes.append(s.local_bounds())
    out = np.zeros((len(boxes), 8, 3))
    for k, ((lo, hi), m) in enumerate(zip(boxes, transforms)):
        cube = np.array([[hi[0] if a else lo[0], hi[1] if b else lo[1], hi[2] if c else lo[2], 1.0]
                         for a in (0, 1) for b in (0, 1) for c in (0, 1)])
        out[k] = (cube @ m.T)[:, :3]
    return out


def compare(usd: dict, drawn: dict, *, slack: float = 0.0) -> list[str]:
    """The disagreements between :func:`usd_bounds` and :func:`wrt_points`, as lines; empty when none.

    A box must hold what wrt draws of its prim, within float32 rounding of the world coordinates; a ``tight`` one
    must also be reached by it on every side, within that rounding plus ``slack`` times the box's size (the
    tessellation error of analytic gprims). Both are checked in the box's own space where its matrix can be
    inverted (a prim's extent in its local space), else on its world-aligned range."""
    problems = []
    for path in sorted(set(usd) - set(drawn)):
        if usd[path] is not None:
            problems.append(f"{path}: USD shows it, wrt draws nothing")
    for path in sorted(set(drawn) - set(usd)):
        problems.append(f"{path}: wrt draws it, USD does not show it")
    for path in sorted(set(usd) & set(drawn)):
        if usd[path] is None:
            continue
        lo, hi, to_world, tight, pad = usd[path]
        world = drawn[path]
        reach = float(np.abs(world).max()) + float(np.abs(to_world[3, :3]).max())
        linear = to_world[:3, :3]
        det = abs(np.linalg.det(linear))
        norm = float(np.abs(linear).max())
        if det > 1e-9 * norm ** 3:
            local = (world - to_world[3, :3]) @ np.linalg.inv(linear)
            # float32 rounding of world points, seen in local units
            tol = 1e-5 * reach * float(np.abs(np.linalg.inv(linear)).max()) + 1e-6 * float(np.max(hi - lo))
        else:
            corners = np.array([[hi[0] if a else lo[0], hi[1] if b else lo[1], hi[2] if c else lo[2], 1.0]
                                for a in (0, 1) for b in (0, 1) for c in (0, 1)]) @ to_world
            lo, hi, local, tight = corners[:, :3].min(axis=0), corners[:, :3].max(axis=0), world, False
            # wrt draws an instance flattened by a zero scale FLAT_THICKNESS of its largest scale thick (README): its
            # points move off the plane by that times their prototype-space distance from the instance's origin
            tol = 1e-5 * reach + 3 * FLAT_THICKNESS * max(float(np.max(hi - lo)), reach)
        tol += 1e-12 + pad
        size = float(np.max(hi - lo))
        wlo, whi = local.min(axis=0), local.max(axis=0)
        if not (np.all(wlo >= lo - tol) and np.all(whi <= hi + tol)):
            problems.append(f"{path}: drawn {fmt(wlo, whi)} outside USD's {fmt(lo, hi)}")
        elif tight and not (np.all(wlo <= lo + tol + slack * size) and np.all(whi >= hi - tol - slack * size)):
            problems.append(f"{path}: drawn {fmt(wlo, whi)} short of USD's {fmt(lo, hi)}")
    return problems


def fmt(lo, hi) -> str:
    return "[" + ", ".join(f"{a:.6g}" for a in lo) + " .. " + ", ".join(f"{b:.6g}" for b in hi) + "]"


def tessellation_slack(segments: int) -> float:
    """Relative shortfall of a tessellated gprim's box: a chord's sagitta over its circle, ``1 - cos(pi / n)``,
    twice over for a sphere's two angles."""
    return 2.0 * (1.0 - math.cos(math.pi / segments)) + 1e-9
