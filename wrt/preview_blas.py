"""One instance's own BVH for :func:`wrt.preview`: the boxes of the bottom-level BVH (BLAS) it is traced in, placed in
the world by its transform.

A scene with instances is traced through a two-level BVH (:mod:`wrt.tlas`), whose top level the preview draws by
default: a box per instance or two, nothing of the trees inside them. Here the BLAS of the chosen instance's
prototype (built once in prototype space, or scaled by ``2^k`` for an instance of :func:`wrt.tlas.instance_exponents`
``k``, and about its box's centre ``m`` where :func:`wrt.tlas.blas_centres` says so) has its nodes' corners moved by
``to_world @ diag(2^-k)``, placed at the BLAS's origin (:func:`wrt.tlas.blas_origins`): the boxes are then the
parallelepipeds the instance's rays meet, seen in the world.
"""

from __future__ import annotations

import numpy as np

from .bvh import FlatBvh
from .errors import did_you_mean
from .tlas import blas_centres, blas_origins, blas_parts, instance_exponents

SUGGESTION_LIMIT = 10_000  # most instance paths searched for a close one to name in the error (difflib is quadratic)


# How instance_row's messages name the options: wrt.preview's keywords, or the CLI's flags (wrt preview).
PYTHON_NAMES = {"choice": "bvh_instance={!r}", "boxes": "bvh_depth or bvh_leaves"}
CLI_NAMES = {"choice": "--bvh-instance {}", "boxes": "--bvh-depth K or --bvh-leaves"}


def instance_row(scene, instance, names: dict = PYTHON_NAMES) -> int:
    """The row of ``scene.instances`` that ``instance`` names: its index (an int), or its path
    (:meth:`wrt.instancing.Instances.path`, ``/instancer[index]`` for a PointInstancer's). ``names``: how errors name
    the options (:data:`PYTHON_NAMES`, or :data:`CLI_NAMES` for the command line's flags).

    Raises:
        ValueError: no such instance, a path that several instances share (those of a PointInstancer nested in
            another's prototype), an instance with no BLAS (of a prototype without triangles, or a transform that
            cannot be inverted), or the scene has none.
    """
    instances = scene.instances
    choice = names["choice"].format(instance)
    if not len(instances):
        raise ValueError(f"{choice}: {scene.source or 'the scene'} has no instances; its BVH is drawn with "
                         f"{names['boxes']} alone")
    if isinstance(instance, (int, np.integer)) and not isinstance(instance, bool):
        if not 0 <= instance < len(instances):
            raise ValueError(f"{choice}: the scene has {len(instances):,} instances, 0 to {len(instances) - 1:,}")
        return _with_blas(scene, int(instance), choice, names)
    if isinstance(instance, str):
        rows = instances.rows_named(instance).tolist()
        if len(rows) == 1:
            return _with_blas(scene, rows[0], choice, names)
        if rows:  # a nested PointInstancer's instances go by the outer instance's path: the first was taken unsaid
            shown = ", ".join(map(str, rows[:6])) + (", ..." if len(rows) > 6 else "")
            raise ValueError(f"{choice} names {len(rows):,} instances ({shown}): give one's index")
        paths = [instances.path(i) for i in range(len(instances))] if len(instances) <= SUGGESTION_LIMIT else []
        hint = did_you_mean(instance, paths) if paths else ""
        raise ValueError(f"{choice} names no instance{hint}; give an index 0 to {len(instances) - 1:,} or a path "
                         f"such as {instances.path(0)!r}")
    raise ValueError(f"{choice}: give an instance index or path, got {type(instance).__name__}")


def _with_blas(scene, row: int, choice: str, names: dict) -> int:
    """``row``, where instance ``row`` is traced in a BLAS (its prototype holds triangles and its transform inverts);
    else ValueError naming ``choice`` and an instance that has one. :func:`instance_blas` found out only after the
    scene was drawn and the whole accelerator built, in words that named no option."""
    instances = scene.instances
    with_triangles = scene.prototype_ranges()[:, 1] > 0
    traced = scene.instance_inverses()[1]
    if with_triangles[instances.prototype[row]] and traced[row]:
        return row
    prototype = scene.prototypes[instances.prototype[row]].path
    why = ("has a transform that cannot be inverted: it is left out of the trace" if with_triangles[
        instances.prototype[row]] else f"is of prototype {prototype}, which holds no triangles (analytic shapes are "
        "TLAS entries of their own, drawn by the TLAS boxes)")
    others = np.flatnonzero(with_triangles[instances.prototype] & traced)
    hint = (f"give one of the {len(others):,} that have one, such as {instances.path(int(others[0]))!r} (index "
            f"{int(others[0])})" if len(others) else f"no instance has one: draw the TLAS with {names['boxes']} alone")
    raise ValueError(f"{choice}: instance {row} ({instances.path(row)}) {why}, and has no BLAS; {hint}")


def instance_blas(accel, scene, row: int) -> tuple[FlatBvh, np.ndarray]:
    """The BLAS that instance ``row`` is traced in (a host tree of ``accel.blas``, an
    :class:`wrt.tlas.InstancedAccelerator` built for ``scene``) and ``(4, 4)`` float64 from its space to the world.

    Raises:
        ValueError: the instance has no BLAS: its prototype holds no triangles (analytic shapes are TLAS entries of
            their own), or its transform cannot be inverted (it is left out of the trace).
    """
    instances = scene.instances
    prototype = int(instances.prototype[row])
    name = f"instance {row} ({instances.path(row)}) of prototype {scene.prototypes[prototype].path}"
    if not scene.instance_inverses()[1][row]:
        raise ValueError(f"{name} has a transform that cannot be inverted: it is left out of the trace, and has no "
                         "BLAS")
    exponent = int(instance_exponents(scene)[row])
    # accel.blas holds one tree per blas_parts entry, in that order: part p + 1 is prototype p at exponent k.
    for b, (part, _, _, k) in enumerate(blas_parts(scene)):
        if part == prototype + 1 and k == exponent:
            to_world = np.asarray(instances.to_world[row], np.float64) @ np.diag([2.0**-exponent] * 3 + [1.0])
            centre = blas_centres(scene)[prototype]
            if centre.any():  # built about its centre: placed where the trace places it (wrt.tlas.blas_origins)
                origin, rest = blas_origins(instances.to_world[row][None], centre[None])
                to_world[:3, 3] = origin[0].astype(np.float64) + rest[0]
            return accel.blas[b], to_world
    raise ValueError(f"{name} has no BLAS: its prototype holds no triangles (analytic shapes are TLAS entries of "
                     "their own, drawn by the TLAS boxes)")
