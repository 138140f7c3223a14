"""World transforms of USD prims under wrt's rule for the default time (:mod:`wrt.usd_values`): each transform op
is read at the default time, or at its first time sample when it has samples and no default value.

``UsdGeom.XformCache`` reads every op at one time code. At the default time that loses ops that have only time
samples (a transform animated from frame 1 would sit at the origin), and at ``EarliestTime`` it reads the first
sample of ops that also author a default, which the default time must give (as points, visibility and material
inputs are read). :class:`DefaultTimeXforms` resolves op by op instead where an op is read at its first sample, and
asks an ``XformCache`` at the default time elsewhere (the same matrices there); other times use ``XformCache`` itself.

A malformed ``xformOpOrder`` is read as USD reads it, each bad op the identity and the others kept
(``UsdGeomXformable::GetOrderedXformOps`` and ``XformQuery``, which Hydra's transforms come from): an op whose attribute
does not exist (a typo, an ``!invert!`` of a missing op; USD warns), whose name is no transform op's or whose value is
of a type the op cannot take (a ``string`` translate; USD posts an error and returns the identity, which stopped wrt's
load); ops before a ``!resetXformStack!`` that is not first are dropped (USD drops them without a word). An op
declared with no value (``double3 xformOp:translate`` with neither a default nor time samples) is the identity, as
USD reads it without a word, unless USD leaves it out anyway (next to its own inverse, before a late reset). Each is
named in a warning (:data:`MISSING_OP`, :data:`INVALID_OP`, :data:`OPS_BEFORE_RESET`, :data:`VALUELESS_OP`); the
prims are resolved op by op.
An ``!invert!`` of an op that has no inverse is left out likewise (:data:`SINGULAR_INVERSE`): a singular
``xformOp:transform`` (USD posts an error and takes the identity) and a scale with a zero component (USD gives inf
and NaN, which stopped the load).
"""

from __future__ import annotations

import math

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, Vt

from .usd_clips import clip_roots, under_clips
from .usd_values import HAS_SPLINES, read_time, schema_typed_value

DEFAULT = Usd.TimeCode.Default()
PROJECTIVE = "world transform is projective; its last column was ignored"
MISSING_OP = ("transform ops named in xformOpOrder that do not exist were left out (the identity), as USD leaves them "
              "out")
INVALID_OP = ("transform ops named in xformOpOrder that are no transform op (by name or value type) were left out (the "
              "identity), as USD leaves them out")
VALUELESS_OP = ("transform ops declared with no value (no default, no time samples) were read as the identity, as USD "
                "reads them")
SINGULAR_INVERSE = ("inverted transform ops that have no inverse (a zero scale, a singular matrix) were left out (the "
                    "identity), as USD leaves out a singular !invert!xformOp:transform")
MISTYPED_ORDER = ("xformOpOrder authored with another type than the schema's token[] was read as USD reads it (a "
                  "weaker token[] opinion, else no ops: the identity)")
OPS_BEFORE_RESET = "ops before a !resetXformStack! that is not first in xformOpOrder were ignored, as USD ignores them"
RESET = "!resetXformStack!"  # UsdGeom.XformOpTypes.resetXformStack
INVERT = "!invert!"  # the prefix of an inverted op's name in xformOpOrder
XFORM_OP_ORDER = UsdGeom.Tokens.xformOpOrder
# The ops of one scalar value: the only ones a spline (USD 25.05's attribute splines, of double attributes) can animate.
SCALAR_OPS = frozenset((UsdGeom.XformOp.TypeRotateX, UsdGeom.XformOp.TypeRotateY, UsdGeom.XformOp.TypeRotateZ,
                        UsdGeom.XformOp.TypeTranslateX, UsdGeom.XformOp.TypeTranslateY, UsdGeom.XformOp.TypeTranslateZ,
                        UsdGeom.XformOp.TypeScaleX, UsdGeom.XformOp.TypeScaleY, UsdGeom.XformOp.TypeScaleZ))
SCALE_OPS = frozenset((UsdGeom.XformOp.TypeScale, UsdGeom.XformOp.TypeScaleX, UsdGeom.XformOp.TypeScaleY,
                       UsdGeom.XformOp.TypeScaleZ))


def _finite_op(op: UsdGeom.XformOp, time: Usd.TimeCode) -> bool:
    """Whether ``op``'s transform at ``time`` is finite (False for one USD cannot compute)."""
    try:
        local = op.GetOpTransform(time)
    except Tf.ErrorException:
        return False
    return all(map(math.isfinite, (x for row in local for x in row)))


def _singular_inverse(op: UsdGeom.XformOp, time: Usd.TimeCode) -> bool:
    """Whether ``op``, which USD could not compute, is an inverted op whose own transform is fine: a singular matrix
    (or scale), rather than a value of the wrong type."""
    return op.IsInverseOp() and _finite_op(UsdGeom.XformOp(op.GetAttr(), False), time)


def affine_part(m: np.ndarray, warn) -> np.ndarray:
    """``m``, a ``(4, 4)`` row-vector world transform (a ``Gf.Matrix4d`` as numpy reads it), with its last column set
    to ``(0, 0, 0, 1)``: meshes, gprims, curves, instances, cameras and lights are drawn by their affine part.
    A column ``(0, 0, 0, w)``, ``w > 0``, is a weight, not a projection: ``m / w`` is returned without a word.
    ``warn(PROJECTIVE)`` is called when the column was not close to that. ``m`` itself is left as it is."""
    column = m[:, 3]
    # The exact column first: np.allclose took a twentieth of load_usd for 40k small meshes.
    if column.tolist() == [0.0, 0.0, 0.0, 1.0]:
        return m
    if column[0] == column[1] == column[2] == 0.0 and math.isfinite(column[3]) and column[3] > 0.0:
        # (0, 0, 0, w) projects nothing: it is m / w in homogeneous coordinates, as USD transforms points
        # (Gf.Matrix4d.Transform divides by w) and Hydra's divide draws them, so ``m * 2`` is m; its last column
        # dropped, the prim was drawn w times as large and as far from the origin, named as projective.
        return m / column[3]
    if not np.allclose(column, (0.0, 0.0, 0.0, 1.0)):
        warn(PROJECTIVE)
    affine = m.copy()
    affine[:, 3] = (0.0, 0.0, 0.0, 1.0)
    return affine


def divide_weights(to_world: np.ndarray) -> np.ndarray:
    """``to_world``, ``(N, 4, 4)`` column-vector transforms, with each one whose bottom row is ``(0, 0, 0, w)``,
    ``w > 0``, divided by ``w`` in place (:func:`affine_part`'s rule for a stack of instances); returned."""
    bottom = to_world[:, 3]
    weight = bottom[:, 3]
    weighted = (bottom[:, :3] == 0.0).all(axis=1) & np.isfinite(weight) & (weight > 0.0) & (weight != 1.0)
    if weighted.any():
        to_world[weighted] /= weight[weighted, None, None]
    return to_world


def xform_cache(time: Usd.TimeCode, stage: Usd.Stage | None = None, warn=None, memo=None):
    """An object with ``UsdGeom.XformCache``'s ``GetLocalToWorldTransform`` and ``ComputeRelativeTransform`` at
    ``time`` under wrt's rule for the default time, for the prims of ``stage``; ``warn(reason, prim, op name)`` is
    called for each malformed op a transform asked for meets (see the module docstring). ``memo``: a
    :class:`wrt.usd_placement_memo.PlacementMemo` of the kept stage, whose transforms are given again and kept."""
    return DefaultTimeXforms(stage, warn, memo) if time.IsDefault() else Xforms(time, warn=warn, memo=memo)


class Xforms:
    """Transforms at ``time``: from a ``UsdGeom.XformCache`` (C++) below prims whose ops it reads as wrt does, op by
    op in Python (memoised per prim) below the others: a malformed ``xformOpOrder`` (whose bad op the cache leaves out
    without a word, or raises for), or at the default time an op read at its first time sample.

    Each prim a transform is asked for, and its ancestors, is looked at once: its ``xformOpOrder`` against the ops USD
    finds for it (one C++ call). An op of the wrong value type passes that look; the cache raises for it, and the prims
    up its chain are then resolved op by op.
    """

    def __init__(self, time: Usd.TimeCode, stage: Usd.Stage | None = None, warn=None, memo=None):
        self._time = time
        self._memo = memo  # a wrt.usd_placement_memo.PlacementMemo: transforms that cannot vary, or None
        self._warn = warn if warn is not None else lambda reason, prim, op: None
        self._cache = UsdGeom.XformCache(time)  # exact where no prim up the chain is resolved op by op
        # No layer of the stage holds a time sample (a still robot fleet): every op reads its default, asked once for
        # the stage (in C++, and without the stage time queries that hang usd-core at timeCodesPerSecond = 0) rather
        # than op by op for each prim, but for the scalar ops that hold a spline (ListAllTimeSamples lists no knots).
        # At other times than the default the cache reads every op as wrt does. Value clips are no used layer until
        # USD reads a value of theirs (with a manifest, it opens none before): below a prim that authors clips the ops
        # are asked all the same (_under_clips), or an op whose only samples are the clips' read as the identity.
        self._still = not time.IsDefault() or (
            stage is not None and not any(layer.ListAllTimeSamples() for layer in stage.GetUsedLayers()))
        self._by_op = {Sdf.Path.absoluteRootPath: False}  # prim path -> the prim or an ancestor is read op by op
        self._clip_roots = None  # wrt.usd_clips.clip_roots of the stage, found when first asked (_under_clips)
        self._world = {}  # prim path -> row-vector local-to-world Gf.Matrix4d, for prims where _by_op is True

    def _op_time(self, attr: Usd.Attribute) -> Usd.TimeCode:
        """The time ``attr``, an op, is read at: the default time's rule (:func:`read_time`), else ``time``."""
        return read_time(attr, DEFAULT) if self._time.IsDefault() else self._time

    def _local(self, prim: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:
        """``prim``'s local transform and whether it resets the transform stack, as
        ``UsdGeomXformable::GetLocalTransformation`` computes it from its ``XformQuery``: the ops after the last
        ``!resetXformStack!``, an op next to its own inverse left out with it, each malformed op left out (the
        identity) and named to ``warn``."""
        if not prim.IsA(UsdGeom.Xformable):
            return Gf.Matrix4d(1.0), False
        attr = UsdGeom.Xformable(prim).GetXformOpOrderAttr()
        order = attr.Get()
        if order is not None and not isinstance(order, Vt.TokenArray):  # a string[] (an empty one too): USD's typed
            # read passes it over
            order, wrong = schema_typed_value(attr, DEFAULT)
            self._warn(MISTYPED_ORDER, prim, wrong)
        order = [str(name) for name in order or []]
        resets = RESET in order
        if resets:
            last = len(order) - 1 - order[::-1].index(RESET)
            for name in order[:last]:
                if name != RESET:
                    self._warn(OPS_BEFORE_RESET, prim, name)
            order = order[last + 1:]
        named = [(name, self._op(prim, name)) for name in order]
        named = [(name, op) for name, op in named if op is not None]  # as USD's list of ops, the bad ones left out
        m = Gf.Matrix4d(1.0)
        i = 0
        while i < len(named):  # row vectors: the first op is applied first
            name, op = named[i]
            if i + 1 < len(named) and named[i + 1][1].GetAttr() == op.GetAttr() and \
                    named[i + 1][1].IsInverseOp() != op.IsInverseOp():
                i += 2  # an op and its inverse side by side: skipped, exactly the identity (as USD skips them)
                continue
            if not op.GetAttr().HasValue():  # GetOpTransform's identity, which USD gives without a word
                self._warn(VALUELESS_OP, prim, name)
                i += 1
                continue
            try:
                local = op.GetOpTransform(self._op_time(op.GetAttr()))
            except Tf.ErrorException:  # a value the op cannot take: USD posts an error and returns the identity
                self._warn(SINGULAR_INVERSE if _singular_inverse(op, self._op_time(op.GetAttr())) else INVALID_OP,
                           prim, name)
            else:
                # An inverted scale with a zero component: USD gives inf and NaN (the cache's world transform too),
                # which stopped the load; left out as a singular inverted matrix is.
                if op.IsInverseOp() and not all(map(math.isfinite, (x for row in local for x in row))):
                    self._warn(SINGULAR_INVERSE, prim, name)
                else:
                    m = local * m
            i += 1
        return m, resets

    def _op(self, prim: Usd.Prim, name: str) -> UsdGeom.XformOp | None:
        """The op ``name`` of ``prim``'s ``xformOpOrder`` (``!invert!`` prefixed or not), or None, named to ``warn``,
        where it has no attribute (USD leaves it out) or its name is no transform op's (USD returns the identity)."""
        inverse = name.startswith(INVERT)
        attr = prim.GetAttribute(name[len(INVERT):] if inverse else name) if name else Usd.Attribute()
        if not attr:
            self._warn(MISSING_OP, prim, str(name))
            return None
        try:
            op = UsdGeom.XformOp(attr, inverse)
        except Tf.ErrorException:  # a name outside xformOp: (TF_CODING_ERROR from the op's constructor)
            op = None
        if not op or op.GetOpType() == UsdGeom.XformOp.TypeInvalid:
            self._warn(INVALID_OP, prim, str(name))
            return None
        return op

    def _own_ops_by_op(self, prim: Usd.Prim) -> bool:
        """Whether ``prim``'s own ops must be read op by op: its ``xformOpOrder`` names an op USD leaves out, has one
        whose name is no transform op's or a ``!resetXformStack!`` after an op, an op with no value, or (at the default
        time) an op is read at its first time sample. Two C++ calls for a well-formed prim, and one per op (about 10 us;
        this runs for every prim placed and each ancestor, once): an attribute's existence asked token by token
        (``HasAttribute``) took longer."""
        order = prim.GetAttribute(XFORM_OP_ORDER).Get()
        if not order:
            return False
        if not isinstance(order, Vt.TokenArray):  # a string[], which names no op to USD: _local reads it as USD does
            return True
        # Not asked whether prim is Xformable: one that is not (an xformOpOrder on a Scope, which USD ignores) and
        # is malformed is only resolved op by op, as the identity (_local).
        try:
            ops = UsdGeom.Xformable(prim).GetOrderedXformOps()  # without the ops whose attribute is missing (USD warns)
        except Tf.ErrorException:  # a name that is no transform op's
            return True
        if len(ops) != len(order) - (order[0] == RESET):  # an op left out, or ops dropped before a late reset
            return True
        # Each op asked in one pass, its attribute fetched once (each of these makes the prim resolved op by op):
        # - declared with no value: named where it applies;
        # - an inverted scale of a zero component, which has no inverse: the cache's transform is not finite (_local
        #   leaves the op out). Only inverted scales are asked (rare; pivots are inverted translates);
        # - at the default time, read at its first time sample, as read_time decides (Xformable.GetTimeSamples would be
        #   faster, but hangs usd-core on stages with timeCodesPerSecond = 0, and does not see spline-valued ops).
        #   Where no layer holds a time sample, only a scalar op holding a spline (which has no default) can be.
        at_default = self._time.IsDefault()
        for op in ops:
            attr = op.GetAttr()
            if not attr.HasValue():
                return True
            if op.IsInverseOp() and op.GetOpType() in SCALE_OPS and not _finite_op(op, self._op_time(attr)):
                return True
            if not at_default or (self._still and not self._under_clips(prim) and
                                  not (HAS_SPLINES and op.GetOpType() in SCALAR_OPS and attr.HasSpline())):
                continue
            if not read_time(attr, DEFAULT).IsDefault():
                return True
        return False

    def _under_clips(self, prim: Usd.Prim) -> bool:
        """Whether clips may give ``prim`` values (:func:`wrt.usd_clips.under_clips`), whose time samples are in no
        layer of ``GetUsedLayers`` until USD opens the clips to read a value."""
        if self._clip_roots is None:
            self._clip_roots = clip_roots(prim.GetStage())
        return under_clips(prim, self._clip_roots)

    def _resolved_by_op(self, prim: Usd.Prim) -> bool:
        """Whether ``prim`` or an ancestor is resolved op by op (memoised, walked without recursion: hierarchies can be
        deeper than Python's stack). Every prim of the chain is looked at, so each malformed one is found."""
        chain = []  # (prim, path) up to the first one already known (the pseudo-root is)
        path = prim.GetPath()
        found = self._by_op.get(path)
        while found is None:
            chain.append((prim, path))
            prim = prim.GetParent()
            path = prim.GetPath()
            found = self._by_op.get(path)
        for q, path in reversed(chain):
            found = self._own_ops_by_op(q) or found
            self._by_op[path] = found
        return found

    def _by_op_after_error(self, prim: Usd.Prim):
        """Marks ``prim`` and its ancestors to be resolved op by op: the cache raised for an op up the chain (a value
        the op cannot take, which only reading it finds)."""
        while not prim.IsPseudoRoot():
            self._by_op[prim.GetPath()] = True
            prim = prim.GetParent()

    def GetLocalToWorldTransform(self, prim: Usd.Prim) -> Gf.Matrix4d:  # noqa: N802 (XformCache's name)
        return self._cached(prim, None)[0]

    def _cached(self, prim: Usd.Prim, ancestor: Usd.Prim | None) -> tuple[Gf.Matrix4d, bool]:
        """``prim``'s transform to ``ancestor``'s space (None: the world's) and whether a reset is between them: the
        memo's, else the cache's where no prim up the chain is resolved op by op (kept in the memo), else op by op."""
        kept = None if self._memo is None else self._memo.transform(self._time, prim, ancestor)
        if kept is not None:
            return kept
        if not self._resolved_by_op(prim):
            try:
                found = (self._cache.GetLocalToWorldTransform(prim), False) if ancestor is None else \
                    self._cache.ComputeRelativeTransform(prim, ancestor)
            except Tf.ErrorException:
                self._by_op_after_error(prim)
            else:
                if self._memo is not None:
                    self._memo.keep_transform(self._time, prim, ancestor, *found)
                return found
        return (self._world_by_op(prim), False) if ancestor is None else self._relative_by_op(prim, ancestor)

    def _world_by_op(self, prim: Usd.Prim) -> Gf.Matrix4d:
        """``prim``'s world transform, the prims up its chain resolved op by op from the cache's."""
        key = prim.GetPath()
        if key not in self._world:
            chain = []  # prims up to the first one whose world transform is known, or has no op-by-op prim up its chain
            p = prim
            while p and not p.IsPseudoRoot() and p.GetPath() not in self._world and self._resolved_by_op(p):
                chain.append(p)
                p = p.GetParent()
            known = self._world.get(p.GetPath())
            world = known if known is not None else self._cache.GetLocalToWorldTransform(p)
            for q in reversed(chain):
                local, resets = self._local(q)
                world = local if resets else local * world
                self._world[q.GetPath()] = world
        return self._world[key]

    def ComputeRelativeTransform(self, prim: Usd.Prim, ancestor: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:  # noqa: N802
        """``prim``'s transform to ``ancestor``'s space; with a resetXformStack between them, to the world's (and
        True), as ``XformCache.ComputeRelativeTransform``."""
        return self._cached(prim, ancestor)

    def _relative_by_op(self, prim: Usd.Prim, ancestor: Usd.Prim) -> tuple[Gf.Matrix4d, bool]:
        """:meth:`ComputeRelativeTransform`, every prim up to ``ancestor`` resolved op by op."""
        m = Gf.Matrix4d(1.0)
        p = prim
        while p and p != ancestor and not p.IsPseudoRoot():
            local, resets = self._local(p)
            m = m * local
            if resets:
                return m, True
            p = p.GetParent()
        return m, False


class DefaultTimeXforms(Xforms):
    """Transforms at the default time, each op read at :func:`wrt.usd_values.read_time` (memoised per prim).

    Below prims none of whose ops is read at a time sample (most prims of most stages: no samples, or a default beside
    them) every op reads its default value, so ``XformCache`` at the default time gives the same matrices, from C++;
    on a stage with no time sample at all that holds for every prim. Resolving each prim's ops in Python was a
    quarter of the load of 100k native instances.
    """

    def __init__(self, stage: Usd.Stage | None = None, warn=None, memo=None):
        super().__init__(DEFAULT, stage, warn, memo)
