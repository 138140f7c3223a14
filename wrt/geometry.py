"""Device math shared by every traversal: the watertight ray-triangle test and the robust ray-box test.

- Triangles: Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection", JCGT 2013. The ray is sheared so it
  runs along +Z; the three 2D edge functions are then evaluated with the same operands for an edge shared by two
  triangles, so a ray can never slip between them. Each is a compensated difference of products
  (``difference_of_products``: about an ulp of its value, exactly antisymmetric, so shared edges still agree), as
  ``wp.Mesh``'s test computes them, so slivers get their t and barycentrics to float32 precision too. Edge functions
  that come out exactly zero are recomputed in double precision, as the paper prescribes. The test is two-sided.
- Boxes: the slab test with the far distance scaled up by ``1 + 2 * gamma(3)`` (Ize, "Robust BVH Ray Traversal",
  JCGT 2013), so rounding can never cull a box that the ray touches.

Barycentrics follow wrt's contract: ``hit = (1 - u - v) * p0 + u * p1 + v * p2``.
"""

import warp as wp

from .floats import largest_magnitude, unit_scales

# A box's exit is widened by 2*gamma(3) of its magnitude (Ize's robust traversal scales it by 1 + 2*gamma(3)), towards
# +t whatever its sign: scaling a negative exit (rays with t_min < 0) moved it towards -inf and shrank the box, so a
# flat box (a ground quad) behind the origin was always missed. Choosing the scale by the exit's sign cost the BVH4
# and BVH8 traversals 2-5% and 6-17% on an H100; adding |exit| * slack costs them 0-5% and 0-4% (GPU_NOTES.md, row 68).
ROBUST_FAR_SLACK = wp.constant(2.0 * 3.0 * 5.9604645e-08 / (1.0 - 3.0 * 5.9604645e-08))  # 2*gamma(3)
ENTRY_SLACK = wp.constant(9.5367431640625e-07)  # 2^-20: intersect_ray_box rounds entries down by this
FLAT_INVERSE = wp.constant(1.0e38)  # safe_inverse of a zero (or subnormal) direction component


@wp.struct
class ShearedRay:
    """Per-ray constants of the watertight test, computed once per ray instead of once per triangle."""

    origin: wp.vec3  # ray origin, world space
    kx: int  # axis mapped to x after the permutation
    ky: int  # axis mapped to y
    kz: int  # axis of largest |direction| component, mapped to z
    sx: float  # shear constants: x' = x - sx * z, y' = y - sy * z, z' = sz * z
    sy: float
    sz: float


@wp.func
def axis_component(v: wp.vec3, k: int):
    """``v[k]`` for a runtime axis ``k`` in 0..2, picked with two selects: on CUDA, indexing a vector by a runtime
    value puts it in local memory (a store per component and a load), which cost 9 stores and 9 loads per
    triangle test."""
    return wp.where(k == 0, v[0], wp.where(k == 1, v[1], v[2]))


@wp.func
def make_sheared_ray(origin: wp.vec3, direction: wp.vec3):
    """Precomputes the permutation and shear of the watertight test for one ray."""
    ax = wp.abs(direction[0])
    ay = wp.abs(direction[1])
    az = wp.abs(direction[2])
    kz = int(2)
    if ax > ay and ax > az:
        kz = 0
    elif ay > az:
        kz = 1
    kx = kz + 1
    if kx == 3:
        kx = 0
    ky = kx + 1
    if ky == 3:
        ky = 0
    dz = axis_component(direction, kz)
    # Swap x and y when the dominant component is negative, so the winding of the triangle is preserved.
    if dz < 0.0:
        tmp = kx
        kx = ky
        ky = tmp
    r = ShearedRay()
    r.origin = origin
    r.kx = kx
    r.ky = ky
    r.kz = kz
    r.sx = axis_component(direction, kx) / dz
    r.sy = axis_component(direction, ky) / dz
    r.sz = 1.0 / dz
    return r


MIN_NORMAL_BIG_T = wp.constant(1.0e-30)  # below this, big_t may have lost bits to subnormals
MIN_EDGE = wp.constant(1.0e-30)  # float32 edge functions are trusted with a magnitude in [MIN_EDGE, MAX_EDGE]
MAX_EDGE = wp.constant(1.0e30)
# Powers of two that bring any float64 edge function of float32 inputs (1e-90 to 1e77) outside that range back into
# float32's normal range: 2^-200 and 2^200.
EDGE_DOWNSCALE = wp.constant(2.0**-200)
EDGE_UPSCALE = wp.constant(2.0**200)


@wp.func
def edge_in_range(e: float):
    """Whether a float32 edge function can be used as it is: not 0 (a ray through a shared edge: the float64 value
    decides its side, so neighbouring triangles agree), not subnormal or near it, not huge, inf or NaN."""
    size = wp.abs(e)
    return size >= MIN_EDGE and size <= MAX_EDGE


@wp.func
def exact_edge_functions(ax: float, ay: float, bx: float, by: float, cx: float, cy: float):
    """The three edge functions in float64 (a product of two float32 values is exact there, and float64's range
    holds it), scaled by a common power of two when the largest lies outside ``[MIN_EDGE, MAX_EDGE]``. Only their
    signs and ratios are used, and a power-of-two scale commutes with rounding."""
    e0 = wp.float64(cx) * wp.float64(by) - wp.float64(cy) * wp.float64(bx)
    e1 = wp.float64(ax) * wp.float64(cy) - wp.float64(ay) * wp.float64(cx)
    e2 = wp.float64(bx) * wp.float64(ay) - wp.float64(by) * wp.float64(ax)
    largest = wp.max(wp.max(wp.abs(e0), wp.abs(e1)), wp.abs(e2))
    scale = wp.float64(1.0)
    if largest > wp.float64(MAX_EDGE):
        scale = wp.float64(EDGE_DOWNSCALE)
    elif largest < wp.float64(MIN_EDGE):
        scale = wp.float64(EDGE_UPSCALE)
    return float(e0 * scale), float(e1 * scale), float(e2 * scale)


@wp.func
def symmetric_sum(x: float, y: float, z: float):
    """``x + y + z`` summed smallest magnitude first: the same bits in any order of the three, and the negated bits
    for the negated three, so a triangle and its twin with the corners rotated or reversed get the same ``t``."""
    if wp.abs(x) > wp.abs(y):
        x, y = y, x
    if wp.abs(y) > wp.abs(z):
        y, z = z, y
    if wp.abs(x) > wp.abs(y):
        x, y = y, x
    return (x + y) + z


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    return fmaf(a, b, c);
#else
    return __builtin_fmaf(a, b, c);
#endif
""")
def fused_multiply_add(a: float, b: float, c: float) -> float:
    """``a * b + c`` rounded once (IEEE fma: the same bits on every device; one instruction on GPUs and on CPUs with
    FMA, which LLVM's intrinsic uses)."""


@wp.func
def difference_of_products(a: float, b: float, c: float, d: float):
    """``a * b - c * d`` to about an ulp of the result: the rounded products' difference plus the difference of their
    rounding errors, which fma gives exactly. Plain float32 rounds each product at its own scale, which swamps the
    difference where they nearly cancel: on a sliver (a needle 2e4 x 2, products about 1e8 summing to 4e4) that put
    t off by a median 4e-6 of itself, wp.Mesh's compensated test (Kahan's) 6e-8. Unlike Kahan's form it is exactly
    antisymmetric: ``difference_of_products(c, d, a, b)`` is its negation bit for bit, as the plain form's was, so two
    triangles sharing an edge (which evaluate it with the roles swapped) still agree on the ray's side of it (the
    watertightness rests on that, not on the sign being exact), and a twin with its corners reversed gets the same
    weights. Overflowing products give NaN and tiny ones a value below ``MIN_EDGE``: the float64 fallback takes both."""
    p = a * b
    q = c * d
    return (p - q) + (fused_multiply_add(a, b, -p) - fused_multiply_add(c, d, -q))


@wp.func
def intersect_ray_triangle(ray: ShearedRay, p0: wp.vec3, p1: wp.vec3, p2: wp.vec3):
    """Watertight, two-sided ray-triangle test.

    Returns:
        ``(hit, t, u, v)``: ``t`` in units of the ray direction's length; valid only when ``hit`` and ``t >= 0``
        is not checked here (the caller clips against its own ``[t_min, t_max)``).
    """
    a = p0 - ray.origin
    b = p1 - ray.origin
    c = p2 - ray.origin
    az = axis_component(a, ray.kz)
    bz = axis_component(b, ray.kz)
    cz = axis_component(c, ray.kz)
    ax = axis_component(a, ray.kx)
    ay = axis_component(a, ray.ky)
    bx = axis_component(b, ray.kx)
    by = axis_component(b, ray.ky)
    cx = axis_component(c, ray.kx)
    cy = axis_component(c, ray.ky)
    # A triangle in a plane kx = const or ky = const (a floor seen at a grazing angle, any triangle on its box's
    # face) gets that plane's distance as t, the same bits for every triangle in the plane, as one across the major
    # axis does below: big_t / det put overlapping decals an ulp apart, and came up to 29% off a close origin's t,
    # where a t_max one ulp past that t culled the box. NaN: no such plane. Divided here, where it is rare, so that
    # only one value stays live through the edge functions (GPU_NOTES row 77).
    plane_t = float(wp.nan)
    if ax == bx and ax == cx:
        plane_t = ax / ray.sx
    elif ay == by and ay == cy:
        plane_t = ay / ray.sy
    ax = ax - ray.sx * az
    ay = ay - ray.sy * az
    bx = bx - ray.sx * bz
    by = by - ray.sy * bz
    cx = cx - ray.sx * cz
    cy = cy - ray.sy * cz
    # Scaled barycentric weights of p0, p1, p2 (2D edge functions).
    e0 = difference_of_products(cx, by, cy, bx)
    e1 = difference_of_products(ax, cy, ay, cx)
    e2 = difference_of_products(bx, ay, by, ax)
    if not (edge_in_range(e0) and edge_in_range(e1) and edge_in_range(e2)):
        e0, e1, e2 = exact_edge_functions(ax, ay, bx, by, cx, cy)
    hit = True
    if (e0 < 0.0 or e1 < 0.0 or e2 < 0.0) and (e0 > 0.0 or e1 > 0.0 or e2 > 0.0):
        hit = False
    if e0 == 0.0 and e1 == 0.0 and e2 == 0.0:  # (of one sign, they sum to 0 only if all are 0)
        hit = False
    t = float(0.0)
    u = float(0.0)
    v = float(0.0)
    if hit:
        # Summed smallest magnitude first: a twin with its corners rotated or reversed gets the same bits.
        det = symmetric_sum(e0, e1, e2)
        big_t = symmetric_sum(e0 * (ray.sz * az), e1 * (ray.sz * bz), e2 * (ray.sz * cz))
        inv_det = 1.0 / det
        t = big_t * inv_det
        u = e1 * inv_det
        v = e2 * inv_det
        if not wp.isfinite(t) or wp.abs(big_t) < MIN_NORMAL_BIG_T:
            # big_t grows as a coordinate cubed: it overflows beyond about 7e12 and turns subnormal below about
            # 1e-13; the barycentric weights stay near 1, so t is taken from them there.
            t = ray.sz * symmetric_sum((e0 * inv_det) * az, u * bz, v * cz)
        if az == bz and az == cz:
            # A triangle in a plane across the ray's major axis (a floor seen from above): t is that plane's
            # distance, the same bits for every triangle in the plane. From big_t / det it came out an ulp apart
            # from one triangle to the next, so of coplanar overlapping triangles the larger id could win the tie.
            t = ray.sz * az
        elif not wp.isnan(plane_t):
            t = plane_t * ray.sz  # (its plane / d_x, with d_x = sx / sz)
    return hit, t, u, v


@wp.func
def stable_length(v: wp.vec3):
    """``|v|`` where ``wp.length`` would lose it: its squares overflow for components above about 1.8e19 and turn
    subnormal below about 1e-19 (a triangle's cross product is an edge length squared, so edges of 1e10 or 1e-10
    get there). Outside ``[1e-18, 1e18]`` the vector is divided by its largest component first; inside, the result
    is ``wp.length``'s, bit for bit."""
    length = wp.length(v)
    if not (length > 1.0e-18 and length < 1.0e18):
        largest = largest_magnitude(v)
        if largest > 0.0 and wp.isfinite(largest):
            length = largest * wp.length(v / largest)
    return length


# Below this largest component of face_normal's float32 cross product (of edges scaled into [1, 2)), the edges from
# the first corner are within about 1.8 degrees of parallel and the normal comes from float64 (needle_normal).
NEEDLE_NORMAL = wp.constant(2.0**-5)


@wp.func
def needle_normal(a: wp.vec3, b: wp.vec3, c: wp.vec3, down_b: float, down_c: float):
    """``face_normal`` in float64: the edges of float32 corners are exact there (their products too), so the
    normal is the corners' own to float32's rounding of the result, however thin the triangle."""
    ab = (wp.vec3d(b) - wp.vec3d(a)) * wp.float64(down_b)
    ac = (wp.vec3d(c) - wp.vec3d(a)) * wp.float64(down_c)
    n = wp.cross(ab, ac)
    return wp.vec3(wp.float32(n[0]), wp.float32(n[1]), wp.float32(n[2]))


@wp.func
def face_normal(a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """``cross(b - a, c - a)`` (not normalised) with each edge first scaled by the power of two that brings its
    largest component into ``[1, 2)``: the same direction, and the same bits once normalised, where nothing over-
    or underflows, but the products cannot: in a scene scaled by 1e20 the cross product (an edge length squared)
    was inf or NaN, by 1e-30 it was 0, and surfaces were shaded with a NaN normal or one facing the ray.

    Where the two edges are nearly parallel (a needle; the cross product below ``NEEDLE_NORMAL``) it is taken in
    float64 (``needle_normal``): in float32 the rounding of ``b - a`` and of the products, an epsilon of the edges'
    lengths, turned the normal by about epsilon times the aspect, a tenth of a radian on a 1e6 x 1 strip (lit 0.6 to
    2 times as bright as its plane under a low sun), up to any direction at 1e7."""
    ab = b - a
    ac = c - a
    down_b, _ = unit_scales(ab)
    down_c, _ = unit_scales(ac)
    n = wp.cross(ab * down_b, ac * down_c)
    if largest_magnitude(n) < NEEDLE_NORMAL:
        n = needle_normal(a, b, c, down_b, down_c)
    return n


@wp.func
def safe_inverse(direction: wp.vec3):
    """Component-wise ``1 / direction`` with zeros (and components whose inverse would overflow) replaced by a huge
    finite value of the right sign, so the slab test never computes ``0 * inf``. Components down to 1e-38 keep
    their exact inverse: a direction need not be unit length, and one of length 1e-30 must still hit."""
    inv = wp.vec3()
    for k in range(3):
        d = direction[k]
        if wp.abs(d) < 1.0e-38:
            inv[k] = wp.copysign(FLAT_INVERSE, d)
        else:
            inv[k] = 1.0 / d
    return inv


_FINITE_MIN = """
#if defined(__CUDA_ARCH__)
    return fminf(a, b);
#else
    return a <= b ? a : b;
#endif
"""
_FINITE_MAX = _FINITE_MIN.replace("fminf", "fmaxf").replace("<=", ">=")


@wp.func_native(_FINITE_MIN)
def finite_min(a: float, b: float) -> float:
    """``wp.min`` for operands that are never NaN. On the CPU ``wp.min`` returns the non-NaN operand when one is
    NaN, which costs two compares and two selects; a compare and a select (one ``minss``) do here. CUDA's ``fminf``
    is one instruction already."""


@wp.func_native(_FINITE_MAX)
def finite_max(a: float, b: float) -> float:
    """``wp.max`` for operands that are never NaN (see ``finite_min``)."""


# Rays in a box face plane. A zero direction component (safe_inverse's FLAT_INVERSE) keeps the ray in a plane of
# constant coordinate; in a box's face plane, bound - origin is exactly 0, so that slab shrank to t = 0 and the box
# was culled: holes at seams between tiles or instances under axis-aligned rays. Such slabs are widened by moving
# the origin per plane once per ray (``box_origins``: up for lower planes, down for upper ones), so boxes within a
# hair of the ray's plane count as touched (never a new miss) and nothing is added per box test. The slab then ends
# at the margin times FLAT_INVERSE, so the margin is at least 2^-124 of the distances the tree's points and the
# origin lie at, over the direction's length (``flat_margin``): 4.7 times any t at which the ray can meet the tree.
# A fixed 1e-18 ended the slab at t = 1e20: rays along an edge in a box face plane missed beyond it (a wall at 1e20,
# or a unit one seen from 1e20 away, or through an instance scaled by 2^66, whose local direction is 2^-66 long).
# CUDA does the same (GPU_NOTES row 94): its slack of 1e20 of t per box test ended the slab there too, and a flat
# slab made infinite per box test when it holds the ray's plane cost the BVH4 closest hit 12-17% on the H100 (a
# compare and a select per slab and child, each waiting on the box's loads); the two origins cost it 1-8%.
_ORIGIN_SHIFT = """
    float a = o < 0.0f ? -o : o;
    float margin = a * 2.384185791015625e-07f;  // 2^-22: at least two ulps of o
    margin = margin > least ? margin : least;
    return (d < 1.0e-38f && d > -1.0e-38f) ? sign * margin : 0.0f;
"""
FLAT_MARGIN_SCALE = wp.constant(2.0**-124)  # times FLAT_INVERSE (1e38): 4.7, over twice sqrt(3) (see flat_margin)
FLAT_MARGIN_LEAST = wp.constant(1.0e-18)
FLAT_MARGIN_MOST = wp.constant(2.0**100)  # far beyond any t float32 holds; keeps o + margin finite


@wp.func_native(_ORIGIN_SHIFT)
def origin_shift(o: float, d: float, least: float, sign: float) -> float:
    """``sign`` times a margin (two ulps of ``o``, at least ``least``) where the direction component ``d`` is zero (as
    ``safe_inverse`` sees it), else 0 (see the comment above)."""


@wp.func
def box_reach(lower: wp.vec3, upper: wp.vec3):
    """The largest ``|coordinate|`` of a box: how far from the origin the points inside it reach."""
    return wp.max(largest_magnitude(lower), largest_magnitude(upper))


@wp.func
def flat_margin(origin: wp.vec3, direction: wp.vec3, reach: float):
    """The least margin ``box_origins`` moves a ray off its flat planes by: ``FLAT_MARGIN_SCALE`` of
    ``max(|origin|, reach) / |direction|`` (largest components; ``reach``: of the tree's root box, ``box_reach``),
    at least ``FLAT_MARGIN_LEAST``. A point ``p`` of the tree meets the ray at ``|t| <= sqrt(3) (|p| + |origin|) /
    |direction|``, at most twice ``sqrt(3)`` of that ratio, and the flat slab ends at the margin times FLAT_INVERSE,
    4.7 of it. Of the tree's size, the margin is 2^-124 where the direction is near unit length (the flat traversals
    scale it so), more only in an instance's space, where it may be as short as 2^-100."""
    m = wp.max(largest_magnitude(origin), reach) * FLAT_MARGIN_SCALE
    return wp.min(wp.max(m / largest_magnitude(direction), FLAT_MARGIN_LEAST), FLAT_MARGIN_MOST)


@wp.func
def box_origins(origin: wp.vec3, direction: wp.vec3, reach: float):
    """The origins that ``intersect_ray_box`` measures a box's lower and upper planes from: ``origin`` moved up and
    down by a margin along the axes that ``direction`` does not move along (see the comment above), for a
    tree whose root box reaches ``reach`` (``box_reach``) from the origin. Only for rays that can hit
    (``ray_can_hit``: a finite origin, a direction not zero)."""
    least = flat_margin(origin, direction, reach)
    up = wp.vec3(origin_shift(origin[0], direction[0], least, -1.0), origin_shift(origin[1], direction[1], least, -1.0),
                 origin_shift(origin[2], direction[2], least, -1.0))
    down = wp.vec3(origin_shift(origin[0], direction[0], least, 1.0), origin_shift(origin[1], direction[1], least, 1.0),
                   origin_shift(origin[2], direction[2], least, 1.0))
    return origin - up, origin - down


@wp.func
def intersect_ray_box(
    origin_lower: wp.vec3,
    origin_upper: wp.vec3,
    inv_dir: wp.vec3,
    lower: wp.vec3,
    upper: wp.vec3,
    t_min: float,
    t_max: float,
):
    """Robust slab test of the ray with inverse direction ``inv_dir`` from ``box_origins``. Returns the entry
    distance, or ``+inf`` when the ray misses ``[t_min, t_max]``.

    No operand is NaN: every traversal first rejects rays with a non-finite origin or direction
    (``ray_can_hit``), ``safe_inverse`` keeps ``inv_dir`` finite and non-zero, and boxes come from finite vertices.
    """
    t0 = wp.cw_mul(lower - origin_lower, inv_dir)
    t1 = wp.cw_mul(upper - origin_upper, inv_dir)
    lo_x = finite_min(t0[0], t1[0])
    lo_y = finite_min(t0[1], t1[1])
    lo_z = finite_min(t0[2], t1[2])
    hi_x = finite_max(t0[0], t1[0])
    hi_y = finite_max(t0[1], t1[1])
    hi_z = finite_max(t0[2], t1[2])
    near = finite_max(finite_max(lo_x, lo_y), finite_max(lo_z, t_min))
    far = finite_min(finite_min(hi_x, hi_y), finite_min(hi_z, t_max))
    result = wp.inf
    if near <= far + wp.abs(far) * ROBUST_FAR_SLACK:
        # Rounded down by a few ulps: traversals cull a box entered beyond the best hit (or t_max), and the
        # watertight test's t of a triangle on the box's face can come out a little below the computed entry;
        # culling at the exact entry lost such hits (coplanar overlaps broke the tie rule; t_max just above a hit).
        result = near - wp.abs(near) * ENTRY_SLACK
    return result


@wp.func
def ray_is_valid(direction: wp.vec3):
    """False for zero, NaN or infinite directions, which can hit nothing."""
    nonzero = direction[0] != 0.0 or direction[1] != 0.0 or direction[2] != 0.0
    return nonzero and wp.isfinite(direction)


@wp.func
def ray_can_hit(origin: wp.vec3, direction: wp.vec3, t_min: float, t_max: float):
    """False for rays that can hit nothing: an empty or NaN range ``[t_min, t_max)`` (finished paths trace with
    ``t_max = 0``), a NaN or infinite origin, or an invalid direction. Every traversal (all layouts, the TLAS and
    each BLAS it enters) returns a miss for them before visiting any node: a NaN origin makes every slab test pass
    (``min``/``max`` drop NaNs), so traversal would visit the whole tree."""
    return t_max > t_min and wp.isfinite(origin) and ray_is_valid(direction)


# Offsets per unit of HitPoint.err and of HitPoint.reach (powers of two, so that a scene scaled by a power of two
# keeps its bits). A hit point is summed from terms as large as err (its rounding is a few float32 epsilons of err:
# pbrt's bound for a triangle is gamma(7) = 3.5 epsilons); 2^-20 is 8 epsilons. The triangle and shape tests measure a
# ray's origin against corners (or a shape's centre) up to reach away, after subtracting the origin (a rounding
# relative to that distance), so they tell its side of the surface only to about 2.4e-7 * reach (a floor 1000 across
# near the origin: origins closer than that were reported on it); 2^-20 is four times that.
ERROR_OFFSET = wp.constant(9.5367431640625e-07)
REACH_OFFSET = wp.constant(9.5367431640625e-07)
# 2^-21 of the largest coordinate a point is summed from (HitPoint.err; at least two ulps of the point): how far an
# origin is pulled into its triangle.
INNER_PULL = wp.constant(4.76837158203125e-07)


@wp.func
def offset_ray_origin(p: wp.vec3, n: wp.vec3, reach: float, err: wp.vec3, inner: wp.vec3):
    """Moves a hit point off its surface along ``n`` just far enough that a ray started there cannot hit the same
    surface again: past the hit point's own rounding and past what the intersection tests can resolve (after pbrt's
    ``OffsetRayOrigin``, Pharr et al., "Physically Based Rendering", 4th ed., 6.8.6).

    ``err`` bounds, per axis, the magnitude of the terms that ``p``'s coordinate was summed from (the corners'
    coordinates, or an instance's or shape's translation): its rounding error is a few float32 epsilons of it, which
    can far exceed the ULPs of ``p`` itself where a large surface passes near the origin (a tilted ground quad of
    1e4, the ground sphere of radius 1000 centred at ``(0, -1000, 0)``). The offset along ``n`` is at least
    ``ERROR_OFFSET * dot(|n|, err)``, the error projected on the normal. An axis-aligned plane has no error across
    itself (``err`` 0 along its normal), but the intersection tests round at the scale of the distances they
    measure from the origin: the offset is also at least ``REACH_OFFSET * reach`` (1e-3 on a floor 1000 across).

    Both bounds follow the surface's own size and position, not a fixed count of the point's ULPs: the 256 ULPs of
    Wächter and Binder ("A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, 2019), used
    before, are 3e-5 of the distance from the world origin, 2 units on a floor at 7e4, so a scene far from the origin
    lost every shadow smaller than that and lit surfaces through the gap. Each coordinate along which ``n`` is not 0
    moves by at least one ULP towards ``n``'s side, so the point never stays where it was.

    ``inner`` is a point inside the surface (a triangle's centroid; ``p`` itself for analytic shapes): ``p`` is first
    pulled towards it by ``INNER_PULL`` of ``err``'s largest component (at most half way). A point on an edge that the
    triangle shares with another surface (a wall's bottom edge on the floor) lies in that surface's plane too, and
    the offset along ``n`` alone left it there: rays into the floor started on it and passed (a room far from the
    origin, where many hit points round onto its edges, was lit by the sun outside along its corners)."""
    to_inner = inner - p
    distance = stable_length(to_inner)
    if distance > 0.0:
        p = p + wp.min(INNER_PULL * largest_magnitude(err) / distance, 0.5) * to_inner
    least = wp.max(ERROR_OFFSET * wp.dot(wp.vec3(wp.abs(n[0]), wp.abs(n[1]), wp.abs(n[2])), err), REACH_OFFSET * reach)
    result = wp.vec3()
    for k in range(3):
        step = least * n[k]
        moved = p[k] + step
        if moved == p[k] and step != 0.0:
            # The step is below half an ULP of p[k] (p[k] is not 0 here): take the neighbouring float on n's side.
            bits = wp.cast(p[k], wp.int32)
            if (p[k] < 0.0) == (step < 0.0):
                bits += 1
            else:
                bits -= 1
            moved = wp.cast(bits, wp.float32)
        result[k] = moved
    return result
