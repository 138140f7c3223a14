"""Instancing on the host: prototypes (geometry drawn only through instances) and the instances that place them.

A :class:`Prototype` holds meshes in its own space, read once however often it is drawn. :class:`Instances` places
prototypes in the world, one 4x4 transform each (and optionally one displayColor each, which colours the prototype
geometry that has none of its own at shading time); nested instancing (a PointInstancer inside a prototype, a
native instance inside a PointInstancer's prototype, ...) is resolved at load time into this single level, as a
top-level acceleration structure over instances expects (:mod:`wrt.tlas`).

Matrices here use the column-vector convention, ``p_world = M @ (p, 1)``: the transpose of USD's ``Gf.Matrix4d``.

Instance order (for USD stages): the world-level instanceable prims and PointInstancers in stage pre-order, a
PointInstancer's instances in index order (``invisibleIds``/``inactiveIds`` left out); instances nested inside
one of them follow it, grouped by the prim inside its prototype that makes them.

Expanded triangle order (the meaning of ``Hits.prim`` and of the rows of ``Scene.triangles()``): the triangles of
the non-instanced meshes first (stage order), then for each instance in instance order the triangles of its
prototype's meshes, in prototype order, transformed to world space. Instances whose transform mirrors
(``det < 0``) get each triangle's corners 1 and 2 swapped, so ``cross(p1 - p0, p2 - p0)`` still points to the
front side (the barycentrics ``u, v`` of a hit on such a row swap accordingly).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

from .assignments import CountsAssignments, mark_checked
from .errors import int32_problem, stray_field
from .ray_batch import host_array
from .unique import sorted_unique

ROW_DTYPE_LIMIT = (1 << 31) - 1  # expanded triangle ids up to this fit int32; larger scenes report int64 ids
# A transform whose |det| is below this fraction of the smaller of its rows' and its columns' lengths' products is
# singular (invert_transforms): rounding leaves ~1e-16 on singular ones; thin or sheared invertible ones keep far
# more (a turned scale (1, 1, 1e-13) keeps 1, a shear of 1e6 keeps 1e-6).
SINGULAR_RELATIVE_DET = 1e-13
# The words of the warnings for instances left out because their transform has no inverse (the USD loader's and a
# Python-built Scene's alike): a zero scale, or a finite scale float32 cannot invert (singular_transforms).
ZERO_SCALE_SKIPPED = "instances with a singular transform (a zero scale) were skipped"
NO_FLOAT32_INVERSE_SKIPPED = ("instances whose transform cannot be inverted reliably in float32 (an extremely large, "
                              "small or uneven scale) were skipped")
# How far the float32 inverse of an instance's (or shape's) linear part L, as the devices hold it, may miss inverting
# it (float32_inverse_errors): rays are taken into local space through that inverse, so its error is that of the
# local coordinates of the instance's own points, relative to its size. Its entries are rounded at the scale of the
# largest (1 / the thinnest scale), which between two turns mixes into every local direction: about 1e-8 over the
# thickness, so a card scaled by 1e-10 between two turns was missed by 1,943 of 1,986 rays (1e-8: 415 of 1,993),
# while one of 1e-14, singular up to rounding, was thickened and drawn. Applying it in float32 rounds as much again
# (float32_product_errors, about 3e-7 over the thickness; counted on sheets, SHEET_WIDTH): at 1e-6 and 3e-7, whose
# inverses float32 holds within 0.02, rays entered the sheet up to 0.3 of its size off and missed it. Beyond the
# tolerance, invert_transforms says no inverse, and thicken_flat_transforms thickens the flat ones as it thickens
# zero scales (at FLAT_THICKNESS the error is at most 4e-4); a thin scale before or after one turn stays as it is.
FLOAT32_INVERSE_TOLERANCE = 2.0**-4
# How far float32 rounds a product of three terms and their sum relative to the terms' magnitudes (three roundings of
# 2^-24): the bound of a local coordinate's error when a ray is taken into an instance's space (float32_product_errors).
FLOAT32_PRODUCT_ROUNDING = 3.0 * 2.0**-24
# The thickness, relative to its largest scale, that thicken_flat_transforms gives an instance flattened by a zero
# scale. Rays move into an instance's space through its float32 inverse, whose rounding grows as one over the
# thickness: at 1e-6, 20 of 148 rays through a squashed instance hit or missed unlike its flattened copy; at 1e-5, 1;
# at 1e-4, none (the sheet's points move by at most 1e-4 of their distance from the instance origin).
FLAT_THICKNESS = 1e-4
# The narrower side, relative to the wider one, of a sheet whose float32 product rounding float32_inverse_errors counts:
# thickened to FLAT_THICKNESS of its wider side, its points move by at most 1% of its narrower one.
SHEET_WIDTH = 100.0 * FLAT_THICKNESS


@dataclasses.dataclass
class Prototype(CountsAssignments):
    """Geometry that is drawn only through instances, in its own (prototype) space.

    Attributes:
        path: prim path of the prototype root (a native prototype's first instance, the least of their paths, as
            USD's ``/__Prototype_N`` changes per opening; or the prim a PointInstancer's ``prototypes`` relationship
            targets), or a made-up name.
        meshes: :class:`wrt.scene.Mesh` list in prototype space, in stage pre-order.
        shapes: :class:`wrt.primitives.Shape` list in prototype space (analytic gprims), in stage pre-order.
    """

    path: str
    meshes: list = dataclasses.field(default_factory=list)
    shapes: list = dataclasses.field(default_factory=list)

    def __post_init__(self):
        from .errors import prim_path

        path = prim_path(self.path, "wrt.Prototype")
        if path is not self.path:
            self.path = path
        mark_checked(self)  # made: a field assigned from now on waits for a build in another thread (EDITS)

    @property
    def num_triangles(self) -> int:
        """Triangles in one copy of the prototype."""
        return sum(len(m.indices) for m in self.meshes)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Prototype-space box ``(lower, upper)`` of the points its triangles use; an inverted box when empty."""
        lower = np.full(3, np.inf)
        upper = np.full(3, -np.inf)
        for m in self.meshes:
            if len(m.indices):
                used = m.points[sorted_unique(m.indices)]  # (np.unique: a hash table, slower here)
                lower = np.minimum(lower, used.min(axis=0))
                upper = np.maximum(upper, used.max(axis=0))
        for s in self.shapes:
            lo, hi = world_boxes(*s.local_bounds(), s.to_world[None])
            lower, upper = np.minimum(lower, lo[0]), np.maximum(upper, hi[0])
        return lower, upper


_INDEX_SUFFIX = re.compile(r"\[(?:0|[1-9][0-9]*)\]")  # a PointInstancer index as Instances.path writes it


def _check_real_numbers(name: str, array: np.ndarray) -> None:
    """Raises ``ValueError`` naming the field unless ``array`` (an :class:`Instances` transform, colour or opacity
    array) holds real numbers, as a mesh's arrays and a shape's must: text (``"1.0"``) and bools were converted to
    floats, complex values lost their imaginary part with only numpy's warning, each without a word naming the
    field. An object array may hold numbers (a list of numpy scalars), not None, text or bools."""
    if array.dtype.kind in "iuf":
        return
    if array.dtype.kind == "O" and all(isinstance(x, (int, float, np.integer, np.floating))
                                       and not isinstance(x, (bool, np.bool_)) for x in array.reshape(-1)):
        return
    raise ValueError(f"Instances {name} must be real numbers, got dtype {array.dtype}")


@dataclasses.dataclass
class Instances(CountsAssignments):
    """Placements of prototypes in the world.

    Attributes:
        prototype: ``(N,)`` int32 index into ``Scene.prototypes``.
        to_world: ``(N, 4, 4)`` float64 prototype-to-world affine transform (column vectors,
            ``p_world = M @ (p, 1)``, bottom row ``(0, 0, 0, 1)``; see :meth:`check_affine`).
        source: ``(N,)`` int32 index into ``sources``: the prim that names each instance, the one a user selects it
            by in usdview: the prim that made it, at its instance-proxy path when it is nested in native instances
            (``/Outer/Inner``); an instance nested inside a PointInstancer's prototype reports the instancer's
            instance it is part of (the prototype is one prim for all of them).
        index: ``(N,)`` int32 position in that PointInstancer's arrays, -1 for a native instance; for the spheres and
            tube pieces of a ``Points`` or ``BasisCurves`` prim (:mod:`wrt.usd_tubes`), the point or curve drawn.
        sources: prim paths of the PointInstancers, instanceable prims, Points and BasisCurves that name the
            instances.
        colors: ``(N, 3)`` float32 linear colour of each instance (a PointInstancer's ``displayColor`` primvar, or
            the colour primvar its prototypes' materials read), NaN rows for instances without one; ``(0, 3)`` when no
            instance has one. It colours the prototype meshes and shapes that have no colours of their own
            (``Mesh.colors`` / ``Shape.color`` None), read at shading time by instance id, so a million colours cost
            12 bytes each, not a copy of the prototype each.
        roots: instance-proxy paths where instances' prototype roots lie (:mod:`wrt.light_links` names each drawn
            part by it: ``/World/Instance/geo/mesh`` for part ``/World/First/geo/mesh``); empty: parts keep their
            own paths.
        root: ``(N,)`` int32 index into ``roots`` of each instance (-1: its parts keep their own paths), or empty.
        opacities: ``(N,)`` float32 ``displayOpacity`` of each instance in [0, 1] (a PointInstancer's primvar, one a
            native instance or its ancestor hands down, a point's or curve's own), NaN for instances without one;
            ``(0,)`` when no instance has one. It is the opacity of the prototype meshes and shapes drawn with the
            default material that have none of their own, read at shading time by instance id, as :attr:`colors`.
        elements: ``(N,)`` int32 the point (``Points``) or curve (curves prims) that each sphere or tube piece of
            such a prim draws, -1 for other instances (``Scene.hit_prims``' element; the same as :attr:`index`
            unless the prim lies in a PointInstancer's prototype); ``(0,)`` when no instance draws one.
    """

    prototype: np.ndarray
    to_world: np.ndarray
    source: np.ndarray
    index: np.ndarray
    sources: list = dataclasses.field(default_factory=list)
    colors: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3), np.float32))
    roots: list = dataclasses.field(default_factory=list)
    root: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))
    opacities: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.float32))
    elements: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))

    def __post_init__(self):
        self.check()

    def check(self) -> None:
        """Converts the arrays to the dtypes and shapes of the attributes above and checks their lengths against each
        other; the constructor calls it, and the scene again before its next trace or render once a field was
        assigned (``instances.to_world = ...``: one of another length raised a bare ``IndexError`` from deep inside
        the build) or after ``Scene.invalidate()``. An array that already has its dtype and shape is kept (the same
        object: the caches compare objects), but for a view of a caller's writeable array, which is copied
        (:func:`wrt.scene.writes_stoppable`).

        Raises:
            ValueError: naming the field, or an attribute that is none (``instances.transforms = ...``).
        """
        from .scene import writes_stoppable  # (wrt.scene imports this module)

        stray = stray_field(self)  # instances.transforms = poses: kept and read by nothing, the old poses drawn
        if stray:
            raise ValueError(f"Instances {stray}")
        for name, dtype, shape in (("prototype", np.int32, (-1,)), ("to_world", np.float64, (-1, 4, 4)),
                                   ("source", np.int32, (-1,)), ("index", np.int32, (-1,)), ("root", np.int32, (-1,)),
                                   ("elements", np.int32, (-1,))):
            value = getattr(self, name)
            # A view of the caller's writeable array (poses[:n] of a simulation's stack) is copied: Scene.freeze made
            # the view alone read-only, and the caller's edit of the stack moved the instances under the cached TLAS
            # while accel="warp", flattening them anew, drew them moved.
            if not (isinstance(value, np.ndarray) and value.dtype == dtype and value.ndim == len(shape)
                    and value.shape[1:] == shape[1:] and value.flags.c_contiguous and writes_stoppable(value)):
                value = np.asarray(host_array(f"Instances {name}", value))
                if dtype == np.int32 and (problem := int32_problem(value)):
                    raise ValueError(f"Instances {name} {problem}")
                if dtype == np.float64:
                    _check_real_numbers("to_world", value)
                try:
                    converted = np.ascontiguousarray(value, dtype=dtype).reshape(shape)
                    setattr(self, name, converted if writes_stoppable(converted) else converted.copy())
                except (TypeError, ValueError) as e:
                    raise ValueError(f"Instances {name} must be {'(N, 4, 4)' if name == 'to_world' else '(N,)'} "
                                     f"numbers: {e}") from None
        n = len(self.prototype)
        if len(self.elements) not in (0, n):
            raise ValueError(f"Instances elements must hold one entry per instance ({n}), or none; got "
                             f"{len(self.elements)}")
        for name in ("to_world", "source", "index"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"Instances arrays must all have one entry per instance: {name} has "
                                 f"{len(getattr(self, name))}, prototype {n}")
        self.check_sources()
        # -1 or a row of roots: light_links keys each (prototype, root) pair as one int64, where -2 read as another
        # prototype's instance under the last root (and an index past roots as the next prototype's).
        if len(self.roots) and (len(self.root) != n or np.any((self.root < -1) | (self.root >= len(self.roots)))):
            raise ValueError(f"Instances root must hold one index into roots ({len(self.roots)}), or -1 for none, per "
                             f"instance ({n})")
        self.check_colors()
        self.check_opacities()
        self.check_affine()
        mark_checked(self)

    def check_sources(self) -> None:
        """Raises ``TypeError`` naming the entry unless :attr:`sources` and :attr:`roots` are lists of prim path strings
        (:func:`wrt.errors.prim_path`: an ``Sdf.Path`` or ``np.str_`` becomes its ``str``, a tuple a list): built
        directly, ``sources=[5]`` was taken and ``hit_paths`` handed back 5, and ``sources="/PI"`` named each
        instance by a letter of it, each without a word. Raises ``ValueError`` for a :attr:`source` outside them."""
        from .errors import prim_path

        for name in ("sources", "roots"):
            paths = getattr(self, name)
            if isinstance(paths, tuple):
                paths = list(paths)
            if not isinstance(paths, list):
                raise TypeError(f"Instances {name} takes a list of prim paths, got {type(paths).__name__} {paths!r}")
            if not all(type(path) is str for path in paths):
                paths = [prim_path(path, f"Instances {name}[{k}]") for k, path in enumerate(paths)]
            if paths is not getattr(self, name):  # only a real change: each assignment counts as a scene edit
                setattr(self, name, paths)
        # Each instance's entry of sources (-1 read the last, one past the end raised a bare IndexError from hit_paths).
        bad = np.flatnonzero((self.source < 0) | (self.source >= len(self.sources))) if self.sources else ()
        if len(bad):
            raise ValueError(f"Instances source must hold an index into sources ({len(self.sources)}) per instance; "
                             f"entry {int(bad[0])} is {int(self.source[bad[0]])}")

    def check_colors(self) -> None:
        """Raises ``ValueError`` unless :attr:`colors` has one row per instance (or none: empty or None) and no
        infinite value (NaN means no colour; inf would shade as inf); stores it as float32. Also run before each
        trace and render, for colours assigned after construction: the shading kernels colour only the instances
        the array reaches, so a short array would leave the rest grey without a word."""
        from .errors import eight_bit_colors

        colors = self.colors if self.colors is None else host_array("Instances colors", self.colors)
        if colors is not None:
            _check_real_numbers("colors", np.asarray(colors))
        if problem := eight_bit_colors(colors):
            raise ValueError(f"Instances {problem}")
        if colors is None or np.size(colors) == 0:  # None, as from_transforms takes it: no colours
            colors = np.zeros((0, 3), np.float32) if np.shape(colors) != (0, 3) else colors
        colors = np.ascontiguousarray(colors, dtype=np.float32)
        if colors is not self.colors:  # only a real change: each assignment counts as a scene edit (assignments.py)
            self.colors = colors
        if colors.ndim != 2 or colors.shape[1] != 3 or len(colors) not in (0, len(self)):
            raise ValueError(f"Instances colors must be (N, 3), one row per instance ({len(self)}), or empty; got "
                             f"{colors.shape}")
        bad = np.flatnonzero(np.isinf(colors).any(axis=1))
        if len(bad):
            raise ValueError(f"Instances colors must be finite (NaN: no colour); row {bad[0]} is not")

    def check_opacities(self) -> None:
        """Raises ``ValueError`` unless :attr:`opacities` has one value per instance (or none: empty or None), each
        in [0, 1] or NaN (none); stores it as float32 (on the host, as the colours). Run before each trace and render
        too, as :meth:`check_colors`."""
        opacities = self.opacities if self.opacities is None else host_array("Instances opacities", self.opacities)
        if opacities is not None:
            _check_real_numbers("opacities", np.asarray(opacities))
        if opacities is None or np.size(opacities) == 0:
            opacities = np.zeros(0, np.float32) if np.shape(opacities) != (0,) else opacities
        opacities = np.ascontiguousarray(opacities, dtype=np.float32)
        if opacities is not self.opacities:  # only a real change (see check_colors)
            self.opacities = opacities
        if opacities.ndim != 1 or len(opacities) not in (0, len(self)):
            raise ValueError(f"Instances opacities must be (N,), one per instance ({len(self)}), or empty; got "
                             f"{opacities.shape}")
        bad = np.flatnonzero((opacities < 0.0) | (opacities > 1.0))  # NaN compares false: no opacity
        if len(bad):
            raise ValueError(f"Instances opacities must be in [0, 1] (NaN: none); opacities[{bad[0]}] = "
                             f"{opacities[bad[0]]:g}")

    def check_affine(self) -> None:
        """Raises :class:`SceneError` naming the first instance whose transform's bottom row is not ``(0, 0, 0, 1)``.
        Only the top 3x4 of each matrix is used: one in USD's row-vector convention (a ``Gf.Matrix4d``, the
        transpose) has its translation in the bottom row, which was dropped without a word."""
        from .errors import SceneError, bottom_row_problem

        bad = np.flatnonzero(np.abs(self.to_world[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(axis=1, initial=0.0) > 1e-6)
        if len(bad):  # found for all instances at once; the message from the shared check
            i = int(bad[0])
            raise SceneError(bottom_row_problem(f"instance {i}", self.to_world[i]), prim=self.path(i))

    @classmethod
    def empty(cls) -> Instances:
        """No instances."""
        return cls(np.zeros(0, np.int32), np.zeros((0, 4, 4)), np.zeros(0, np.int32), np.zeros(0, np.int32), [])

    @classmethod
    def from_transforms(cls, prototype, to_world, name: str = "/instances", colors=None) -> Instances:
        """Instances made in Python: ``prototype`` ``(N,)`` int, ``to_world`` ``(N, 4, 4)`` (column vectors) and
        optionally ``colors`` ``(N, 3)`` (see the class docstring)."""
        from .errors import prim_path

        prototype = np.asarray(host_array("Instances prototype", prototype))
        if problem := int32_problem(prototype):  # before the cast: 2**32 drew prototype 0
            raise ValueError(f"Instances prototype {problem}")
        prototype = prototype.astype(np.int32).reshape(-1)
        n = len(prototype)
        name = prim_path(name, "wrt.Instances.from_transforms")
        return cls(prototype, to_world, np.zeros(n, np.int32), np.arange(n, dtype=np.int32), [name], colors)

    def take(self, rows) -> Instances:
        """The instances at ``rows`` (an index array or a boolean mask), every per-instance array alike."""
        colors = self.colors[rows] if len(self.colors) else self.colors
        root = self.root[rows] if len(self.roots) else self.root
        opacities = self.opacities[rows] if len(self.opacities) else self.opacities
        elements = self.elements[rows] if len(self.elements) else self.elements
        return Instances(self.prototype[rows], self.to_world[rows], self.source[rows], self.index[rows],
                         self.sources, colors, self.roots, root, opacities, elements)

    def __len__(self) -> int:
        return len(self.prototype)

    def __repr__(self) -> str:
        # The dataclass repr printed every source path (one per instanceable prim: 400 KB for 20,000 of them) and
        # every transform; this says what it holds, as Scene and Mesh do.
        from .wording import counted

        held = [name for name in ("colors", "opacities", "roots", "elements") if len(getattr(self, name))]
        return (f"Instances({counted(len(self), 'instance')} of "
                f"{counted(len(np.unique(self.prototype)), 'prototype')}, {counted(len(self.sources), 'source')}"
                f"{''.join(f', {name}' for name in held)})")

    def path(self, i: int) -> str:
        """A name for instance ``i``: its source prim path, plus ``[index]`` for a PointInstancer's instance."""
        name = self.source_path(i)
        return f"{name}[{self.index[i]}]" if self.index[i] >= 0 else name

    def rows_named(self, name: str) -> np.ndarray:
        """``(K,)`` int64 rows ``i``, increasing, whose :meth:`path` is ``name``, matched against the sources and the
        indices: making every row's path to compare took 1.5 s for a PointInstancer of 1M instances."""
        sources = self.sources or ["/instances"]
        source = self.source if self.sources else np.zeros(len(self), np.int32)
        plain, indexed = [], {}  # sources named ``name``; index -> sources named ``name`` less ``[index]``
        for s, path in enumerate(sources):
            rest = name[len(path):] if name.startswith(path) else None
            if rest == "":
                plain.append(s)
            elif rest is not None and _INDEX_SUFFIX.fullmatch(rest):  # "[7]" as path() writes it, not "[07]"
                indexed.setdefault(int(rest[1:-1]), []).append(s)
        match = np.isin(source, plain) & (self.index < 0)
        for index, these in indexed.items():
            match |= np.isin(source, these) & (self.index == index)
        return np.flatnonzero(match)

    def source_path(self, i: int) -> str:
        """The path of instance ``i``'s source prim (the PointInstancer, instanceable prim, Points or curves prim
        that makes it), ``/instances`` when there are no sources."""
        return self.sources[self.source[i]] if self.sources else "/instances"

    def rows_of_prototypes(self, n_prototypes: int) -> list[np.ndarray]:
        """``[rows of prototype p for p in range(n_prototypes)]``: the instances of each prototype, in increasing
        order, as ``np.flatnonzero(prototype == p)`` gives them, from one stable sort: a scan of every instance per
        prototype took minutes for thousands of prototypes with millions of instances."""
        return group_rows(self.prototype, n_prototypes)

    @property
    def mirrored(self) -> np.ndarray:
        """``(N,)`` bool: the transform flips orientation (``det < 0``)."""
        return np.linalg.det(self.to_world[:, :3, :3]) < 0.0 if len(self) else np.zeros(0, bool)

    def mirrored_rows(self, rows: np.ndarray) -> np.ndarray:
        """:attr:`mirrored` of instances ``rows`` (``(K,)`` int) alone, each distinct one's determinant taken once:
        the hits of every ``wrt.trace`` call took all of them, 0.4 s a call for 1M instances however few rays."""
        distinct, inverse = np.unique(rows, return_inverse=True)
        if not len(distinct):
            return np.zeros(0, bool)
        return (np.linalg.det(self.to_world[distinct, :3, :3]) < 0.0)[inverse.reshape(-1)]


def group_rows(keys: np.ndarray, n_groups: int) -> list[np.ndarray]:
    """``[np.flatnonzero(keys == g) for g in range(n_groups)]`` from one stable sort instead of a scan per group."""
    order = np.argsort(keys, kind="stable")
    starts = np.searchsorted(keys[order], np.arange(n_groups + 1))
    return [order[starts[g] : starts[g + 1]] for g in range(n_groups)]


EXPAND_POINTS = 1 << 20  # points moved at a time by expand_instance_triangles
INVERT_ROWS = 1 << 16  # transforms inverted at a time by invert_transforms


def transform_points(points: np.ndarray, to_world: np.ndarray) -> np.ndarray:
    """``(V, 3)`` points through one ``(4, 4)`` column-vector transform, in float64."""
    return np.asarray(points, np.float64) @ to_world[:3, :3].T + to_world[:3, 3]


def world_boxes(lower: np.ndarray, upper: np.ndarray, to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World boxes of a prototype box ``(lower, upper)`` (``(3,)``, or ``(N, 3)``: one box per transform) under
    ``(N, 4, 4)`` transforms: the boxes of its 8 moved corners, computed per axis as
    ``t + sum_k min/max(M[:, k] lower_k, M[:, k] upper_k)`` (Arvo 1990)."""
    linear = to_world[:, :3, :3]
    a = linear * np.asarray(lower)[..., None, :]
    b = linear * np.asarray(upper)[..., None, :]
    lo = np.minimum(a, b).sum(axis=2) + to_world[:, :3, 3]
    hi = np.maximum(a, b).sum(axis=2) + to_world[:, :3, 3]
    return lo, hi


def invert_transforms(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(world_to_local (N, 3, 4) float64, ok (N,) bool)``: the affine inverses; ``ok`` is False (and the row zero)
    where the linear part is singular or the inverse is not finite in float32, as the devices hold it (a zero scale,
    or one of 1e-45: its float64 inverse is finite, but a float32 one sent every ray to inf and the instance
    vanished without the warning singular ones get), or where that float32 inverse does not invert it to within
    :data:`FLOAT32_INVERSE_TOLERANCE` (a scale of 1e-10 between two turns: see there)."""
    if len(to_world) <= INVERT_ROWS:
        return _invert_block(to_world)
    # Each row is inverted on its own: in blocks, the temporaries (some 560 bytes per row) stay small. At once they
    # took 560 MB more for a PointInstancer of 1M instances, at the load's peak.
    world_to_local, ok = np.empty((len(to_world), 3, 4)), np.empty(len(to_world), bool)
    for start in range(0, len(to_world), INVERT_ROWS):
        block = slice(start, start + INVERT_ROWS)
        world_to_local[block], ok[block] = _invert_block(to_world[block])
    return world_to_local, ok


def _invert_block(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`invert_transforms` of one block of rows."""
    linear = to_world[:, :3, :3]
    # The inverse is the adjugate over the determinant, both from the rows' cross products: numpy's batched LAPACK
    # inv and det took 2.6 s for a million instances (points of a UsdGeom.Points prim, PointInstancer instances).
    rows = linear[:, 0], linear[:, 1], linear[:, 2]
    with np.errstate(over="ignore", invalid="ignore"):
        adjugate = np.stack([np.cross(rows[1], rows[2]), np.cross(rows[2], rows[0]), np.cross(rows[0], rows[1])], 2)
        det = (rows[0] * adjugate[:, :, 0]).sum(axis=1)
    scale = np.abs(linear).reshape(len(linear), -1).max(axis=1) if len(linear) else np.zeros(0)
    ok = np.isfinite(det) & (np.abs(det) > 1e-30 * np.maximum(scale, 1e-30) ** 3) & (scale > 0)
    # Singular up to rounding: a zero scale composed with a turn (a squashed PointInstancer instance holding a
    # nested instance) leaves a determinant of ~1e-16 of Hadamard's bound (the product of the rows' or of the
    # columns' lengths), not 0, and its flattened triangles drew as a sheet the two-level traversal could not enter.
    with np.errstate(over="ignore", invalid="ignore"):
        bound = np.minimum(np.prod(np.linalg.norm(linear, axis=2), axis=1),
                           np.prod(np.linalg.norm(linear, axis=1), axis=1))
        ok &= np.abs(det) > SINGULAR_RELATIVE_DET * bound
    out = np.zeros((len(to_world), 3, 4))
    if ok.any():
        inv = adjugate[ok] / det[ok, None, None]
        out[ok, :, :3] = inv
        out[ok, :, 3] = -np.einsum("nij,nj->ni", inv, to_world[ok, :3, 3])
        with np.errstate(over="ignore", invalid="ignore"):
            good = np.isfinite(out[ok].astype(np.float32)).reshape(int(ok.sum()), -1).all(axis=1)
            good &= float32_inverse_errors(out[ok, :, :3], linear[ok]) <= FLOAT32_INVERSE_TOLERANCE
        bad = np.flatnonzero(ok)[~good]
        ok[bad] = False
        out[bad] = 0.0
    return out, ok


def float32_inverse_errors(inverse: np.ndarray, linear: np.ndarray) -> np.ndarray:
    """``(N,)`` how far the float32 rounding of each ``(N, 3, 3)`` float64 ``inverse`` misses inverting its
    ``linear`` part, and how far applying it in float32 can miss, in the local directions that matter (see
    :data:`FLOAT32_INVERSE_TOLERANCE`): the largest entry of ``P (inverse32 @ linear - I) P``, ``P`` the projection off
    the local direction that ``linear`` shrinks most, plus :func:`float32_product_errors`. Along that direction the
    error is harmless: a ray that meets the squashed instance runs nearly along it in local space, so there it only
    moves a hit along its ray (a scale of 1e-10 after a turn errs by 600 there, and rays hit it as exactly as an
    unturned one); it is looked at (an SVD) only where the whole error is too large."""
    with np.errstate(over="ignore", invalid="ignore"):
        error = inverse.astype(np.float32).astype(np.float64) @ linear - np.eye(3)
        product = FLOAT32_PRODUCT_ROUNDING * np.abs(inverse) @ np.abs(linear)
        largest = np.abs(error).max(axis=(1, 2)) + product.max(axis=(1, 2)) if len(error) else np.zeros(0)
        rows = np.flatnonzero(~(largest <= FLOAT32_INVERSE_TOLERANCE) & np.isfinite(linear).all(axis=(1, 2)))
        if len(rows):
            _, scales, vt = np.linalg.svd(linear[rows])
            thin = vt[:, 2]  # the right singular vector of the smallest scale
            off = np.eye(3) - thin[:, :, None] * thin[:, None, :]
            # The product's rounding counts on sheets only, which thicken_flat_transforms thickens by at most 1% of
            # their narrower side: a ribbon (1, 1e-3, 1e-6) thickened so lost 204 of 3,089 rays (2 as it is), and a
            # needle (1, 1e-6, 1e-6), which nothing thickens, would be skipped (25 of 3,069 lost as it is).
            sheet = scales[:, 1] >= SHEET_WIDTH * scales[:, 0]
            largest[rows] = np.abs(off @ error[rows] @ off).max(axis=(1, 2)) + np.where(
                sheet, float32_product_errors(product[rows], off), 0.0)
    return largest


def float32_product_errors(product: np.ndarray, off: np.ndarray) -> np.ndarray:
    """``(N,)`` the largest error off the thin local direction (``off``, ``(N, 3, 3)``: the projection off it) that
    rounding can leave in the float32 product of an instance's inverse and a world point one local unit from its
    origin, given ``product`` ``(N, 3, 3)``, the bound of that rounding on local coordinate ``i`` of local unit point
    ``k`` (:data:`FLOAT32_PRODUCT_ROUNDING` times ``|inverse| @ |linear|``): each coordinate rounds either way, so
    every sign pattern is tried (the error is a vector in that box). Between two turns the inverse's entries of
    1 / squash meet in sums that cancel to the point's local coordinates, and their rounding lands across the sheet:
    a sheet of 3e-7 whose inverse float32 holds within 0.02 was entered up to 0.3 of its size off, and rays aimed
    a third inside its triangles missed it. After one turn it stays along the thin direction, which ``off`` drops."""
    signs = np.array([(1, 1, 1), (1, 1, -1), (1, -1, 1), (1, -1, -1)], np.float64)
    box = signs[None, :, :, None] * product[:, None]  # (N, sign, local coordinate, local point)
    return np.abs(off[:, None] @ box).max(axis=(1, 2, 3))


def singular_transforms(to_world: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: the ``(N, 4, 4)`` transforms whose linear part is singular up to rounding (a zero scale, maybe
    composed with a turn), judged on it divided by its largest entry, so that a finite scale however large, small or
    uneven (3e38, 1, 1) is not: :func:`invert_transforms` refuses those too (no float32 inverse), and the warnings
    name the two apart (a warning calling (3e38, 1, 1) "a zero scale" sent the user looking for a zero)."""
    linear = to_world[:, :3, :3].astype(np.float64)
    scale = np.abs(linear).reshape(len(linear), -1).max(axis=1) if len(linear) else np.zeros(0)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        unit = linear / np.where(scale > 0, scale, 1.0)[:, None, None]
        det = np.linalg.det(unit) if len(unit) else np.zeros(0)
        bound = np.minimum(np.prod(np.linalg.norm(unit, axis=2), axis=1), np.prod(np.linalg.norm(unit, axis=1), axis=1))
        return np.isfinite(scale) & ~(np.abs(det) > SINGULAR_RELATIVE_DET * bound)


def unplaceable(to_world: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: the ``(N, 4, 4)`` transforms that place nothing a trace can reach: a NaN or inf anywhere, or a
    translation that float32 cannot hold (the devices place an instance's origin in float32, :func:`device_transforms`:
    past 3.4e38 it is inf). Accelerators refuse scenes with such instances (``wrt.trace.check_finite_transforms``)."""
    with np.errstate(over="ignore", invalid="ignore"):
        placed = np.isfinite(to_world[:, :3, 3].astype(np.float32)).all(axis=1)
    return ~(np.isfinite(to_world).all(axis=(1, 2)) & placed)


def device_transforms(world_to_local: np.ndarray, to_world: np.ndarray) -> np.ndarray:
    """``(N, 3, 4)`` float32 ``[A | c]`` of :mod:`wrt.transforms` for the device: ``A`` the linear part of
    ``world_to_local`` (:func:`invert_transforms`' rows), ``c`` the translation of ``to_world`` ``(N, 4, 4)`` (where the
    local origin lies in the world); rows of zeros (singular transforms) stay zero."""
    out = np.zeros((len(to_world), 3, 4), np.float32)
    out[:, :, :3] = world_to_local[:, :, :3]
    drawn = np.any(world_to_local[:, :, :3] != 0, axis=(1, 2))
    out[drawn, :, 3] = to_world[drawn, :3, 3]
    return out


def thicken_flat_transforms(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(to_world with flat ones thickened, thickened (N,) bool)``: the ``(N, 4, 4)`` column-vector transforms that
    :func:`invert_transforms` finds singular but that keep two directions (a zero scale on one axis, a mesh squashed
    into a plane, which USD and Storm draw flat) given a thickness of :data:`FLAT_THICKNESS` times their largest
    scale along the direction they lost, with the sign that makes the determinant positive (Storm flips the winding
    only for a negative one: the front of a flat instance is the side its world winding gives). The two-level BVH
    then takes rays into their space as into a thin instance's; the points move by at most ``FLAT_THICKNESS`` of
    their distance from the instance origin. Transforms that keep fewer than two directions draw nothing of area
    and stay as they are (singular)."""
    thickened = np.zeros(len(to_world), bool)
    if len(to_world) == 0:
        return to_world, thickened
    _, ok = invert_transforms(to_world)
    rows = np.flatnonzero(~ok & np.isfinite(to_world[:, :3, :3]).reshape(len(to_world), -1).all(axis=1))
    if len(rows) == 0:
        return to_world, thickened
    u, s, vt = np.linalg.svd(to_world[rows, :3, :3])
    flat = s[:, 1] > FLAT_THICKNESS * s[:, 0]
    if not flat.any():
        return to_world, thickened
    rows, u, s, vt = rows[flat], u[flat], s[flat], vt[flat]
    s[:, 2] = FLAT_THICKNESS * s[:, 0] * np.sign(np.linalg.det(u) * np.linalg.det(vt))
    out = to_world.copy()
    out[rows, :3, :3] = (u * s[:, None, :]) @ vt
    _, now = invert_transforms(out[rows])
    thickened[rows[now]] = True
    out[rows[~now]] = to_world[rows[~now]]
    return out, thickened


def expand_instance_triangles(
    prototypes: list, instances: Instances, invertible: np.ndarray | None = None, dtype=np.float32
) -> tuple[np.ndarray, np.ndarray]:
    """World-space triangles of every instance, in the documented expanded order (see module docstring).

    An instance whose transform is singular (``invert_transforms``: a zero scale) is invisible, as the two-level
    traversal, which cannot take its ray into prototype space, leaves it out: its triangles keep their rows but are
    collapsed onto the instance's origin, zero-area, so no layout and no ``wp.Mesh`` hits them.

    Args:
        invertible: ``(N,)`` bool, the instances whose transform ``invert_transforms`` can invert, when the caller
            has it already (``Scene.instance_inverses``); computed here otherwise.
        dtype: of the points; float64 keeps the shape of instances far from the origin (the preview draws them so).

    Returns:
        ``points`` ``(V, 3)`` ``dtype`` and ``indices`` ``(T, 3)`` int64 into them.
    """
    local = []
    for p in prototypes:
        offsets = np.cumsum([0] + [len(m.points) for m in p.meshes])
        pts = np.concatenate([m.points for m in p.meshes] or [np.zeros((0, 3), np.float32)]).astype(np.float64)
        idx = np.concatenate([m.indices + o for m, o in zip(p.meshes, offsets)] or [np.zeros((0, 3), np.int32)])
        local.append((pts, idx.astype(np.int64)))
    # Each instance's block of points and triangles, in instance order; prototypes without triangles add none.
    n_points = np.array([len(pts) if len(idx) else 0 for pts, idx in local] or [0], np.int64)
    n_tris = np.array([len(idx) for _, idx in local] or [0], np.int64)
    point_counts, tri_counts = n_points[instances.prototype], n_tris[instances.prototype]
    point_bases, tri_bases = np.cumsum(point_counts) - point_counts, np.cumsum(tri_counts) - tri_counts
    points = np.empty((int(point_counts.sum()), 3), dtype)
    indices = np.empty((int(tri_counts.sum()), 3), np.int64)
    mirrored = instances.mirrored
    if invertible is None:
        _, invertible = invert_transforms(instances.to_world)
    # Vectorised over the instances of each prototype, in slices of about EXPAND_POINTS points: a Python loop over
    # instances took 8 s for 1M PointInstancer instances. The per-instance products are those of transform_points.
    for (pts, idx), rows in zip(local, instances.rows_of_prototypes(len(local))):
        if len(idx) == 0:
            continue
        step = max(1, EXPAND_POINTS // max(len(pts), 1))
        for start in range(0, len(rows), step):
            chunk = rows[start : start + step]
            to_world = instances.to_world[chunk]
            to_world[~invertible[chunk], :3, :3] = 0.0  # collapsed: every point at the instance's origin
            moved = pts[None] @ to_world[:, :3, :3].transpose(0, 2, 1) + to_world[:, None, :3, 3]
            points[point_bases[chunk][:, None] + np.arange(len(pts))] = moved
            corners = np.where(mirrored[chunk][:, None, None], idx[None][..., [0, 2, 1]], idx[None])
            indices[tri_bases[chunk][:, None] + np.arange(len(idx))] = corners + point_bases[chunk][:, None, None]
    return points, indices


__all__ = ["Instances", "Prototype", "expand_instance_triangles", "invert_transforms", "world_boxes"]
