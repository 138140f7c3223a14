"""Monte Carlo sampling helpers shared by the integrators: random numbers, frames and warps of the unit square.

Every function is a ``@wp.func`` and deterministic in its inputs, so a path draws the same numbers on ``cpu``
and ``cuda``. Random numbers come from Warp's PCG generator (``wp.rand_init`` / ``wp.randf``); a path's state
is seeded from the hashed ``(seed, sample)`` and then its pixel (``wrt.shade.path_rng``) and carried between kernels
in a ``uint32`` array.

Warps follow Pharr, Jakob and Humphreys, *Physically Based Rendering* (4th ed.), chapter A.5: cosine-weighted
hemisphere via Shirley and Chiu's concentric disk mapping, uniform cones and spheres. The orthonormal basis is
Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017.
"""

import warp as wp

PI = wp.constant(3.14159265358979)
INV_PI = wp.constant(0.31830988618379)
ONE_MINUS_EPSILON = wp.constant(0.99999994)  # largest float32 below 1
TWO_OVER_PI = wp.constant(0.636619772367581)
PIO2_HI = wp.constant(1.5703125)  # pi / 2 = PIO2_HI + PIO2_MID + PIO2_LO; k * PIO2_HI is exact for |k| < 2^16
PIO2_MID = wp.constant(4.837512969970703125e-4)
PIO2_LO = wp.constant(7.54978995489188216e-8)


@wp.func
def rand01(state: wp.uint32):
    """A uniform float in ``[0, 1)`` and the advanced generator state."""
    x = wp.randf(state)  # advances ``state`` in place
    return wp.min(x, ONE_MINUS_EPSILON), state


@wp.func
def sin_cos(x: float):
    """``(sin x, cos x)`` from ``+ - *`` only, so every device gives the same bits (CUDA's and the CPU's ``sinf``
    and ``cosf`` differ in the last bit, enough to send a path elsewhere). Cody-Waite reduction to
    ``[-pi/4, pi/4]`` and the Cephes ``sinf``/``cosf`` polynomials: within 2 ulp for ``|x| <= 20`` (tested; the
    warps here pass ``[-pi/4, 2 pi]``)."""
    k = wp.floor(x * TWO_OVER_PI + 0.5)
    r = ((x - k * PIO2_HI) - k * PIO2_MID) - k * PIO2_LO
    z = r * r
    s = r + r * z * ((-1.9515295891e-4 * z + 8.3321608736e-3) * z - 1.6666654611e-1)
    c = 1.0 - 0.5 * z + z * z * ((2.443315711809948e-5 * z - 1.388731625493765e-3) * z + 4.166664568298827e-2)
    quadrant = int(k) & 3  # x = r + quadrant * pi / 2 (mod 2 pi)
    if quadrant == 1:
        return c, -s
    if quadrant == 2:
        return -s, -c
    if quadrant == 3:
        return -c, s
    return s, c


@wp.func
def luminance(c: wp.vec3):
    """Rec. 709 luminance of a linear RGB colour."""
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


@wp.func
def max_component(c: wp.vec3):
    """Largest of the three components."""
    return wp.max(c[0], wp.max(c[1], c[2]))


@wp.func
def basis_x(n: wp.vec3):
    """First tangent of the orthonormal basis around unit ``n`` (Duff et al. 2017)."""
    sign = wp.where(n[2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return wp.vec3(1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0])


@wp.func
def basis_y(n: wp.vec3):
    """Second tangent of the orthonormal basis around unit ``n`` (Duff et al. 2017)."""
    sign = wp.where(n[2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return wp.vec3(b, sign + n[1] * n[1] * a, -n[1])


@wp.func
def to_world(v: wp.vec3, n: wp.vec3):
    """``v`` given in the frame ``(basis_x(n), basis_y(n), n)``, expressed in world space."""
    return v[0] * basis_x(n) + v[1] * basis_y(n) + v[2] * n


@wp.func
def to_local(v: wp.vec3, n: wp.vec3):
    """World-space ``v`` in the frame ``(basis_x(n), basis_y(n), n)``."""
    return wp.vec3(wp.dot(v, basis_x(n)), wp.dot(v, basis_y(n)), wp.dot(v, n))


@wp.func
def sample_concentric_disk(u1: float, u2: float):
    """Uniform point on the unit disk (Shirley and Chiu 1997)."""
    a = 2.0 * u1 - 1.0
    b = 2.0 * u2 - 1.0
    if a == 0.0 and b == 0.0:
        return wp.vec2(0.0, 0.0)
    r = float(0.0)
    theta = float(0.0)
    if wp.abs(a) > wp.abs(b):
        r = a
        theta = (PI / 4.0) * (b / a)
    else:
        r = b
        theta = PI / 2.0 - (PI / 4.0) * (a / b)
    s, c = sin_cos(theta)
    return wp.vec2(r * c, r * s)


@wp.func
def sample_cosine_hemisphere(u1: float, u2: float):
    """Cosine-weighted direction about +Z (pdf ``cos(theta) / pi``)."""
    d = sample_concentric_disk(u1, u2)
    z = wp.sqrt(wp.max(0.0, 1.0 - d[0] * d[0] - d[1] * d[1]))
    return wp.vec3(d[0], d[1], z)


@wp.func
def direction_at_cos(z: float, u: float):
    """The direction about +Z of polar cosine ``z`` and azimuth ``2 pi u``."""
    r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
    s, c = sin_cos(2.0 * PI * u)
    return wp.vec3(r * c, r * s, z)


@wp.func
def sample_uniform_sphere(u1: float, u2: float):
    """Uniform direction on the unit sphere (pdf ``1 / (4 pi)``)."""
    return direction_at_cos(1.0 - 2.0 * u1, u2)


@wp.func
def sample_uniform_cone(u1: float, u2: float, one_minus_cos_max: float):
    """Uniform direction in the cone of half-angle ``acos(1 - one_minus_cos_max)`` about +Z (pdf
    ``1 / (2 pi one_minus_cos_max)``). The cone is given by ``1 - cos`` because a small one (the sun, 0.53 degrees
    across) has a cosine that float32 rounds by up to 25% of its distance from 1."""
    one_minus = u1 * one_minus_cos_max
    sin_t = wp.sqrt(wp.max(0.0, one_minus * (2.0 - one_minus)))
    s, c = sin_cos(2.0 * PI * u2)
    return wp.vec3(sin_t * c, sin_t * s, 1.0 - one_minus)


@wp.func
def power_heuristic(pdf_a: float, pdf_b: float):
    """Veach's power heuristic (beta = 2) weight of strategy ``a`` against ``b``, one sample each."""
    a = pdf_a * pdf_a
    b = pdf_b * pdf_b
    if a + b <= 0.0:
        return 0.0
    if wp.isinf(a):
        return 1.0
    return a / (a + b)


@wp.func
def floor_index(data: wp.array[float], start: int, count: int, x: float):
    """The ``i`` in ``[0, count - 2]`` with ``data[start + i] <= x < data[start + i + 1]`` where ``x`` lies in the
    ascending ``data[start : start + count]`` (the nearest end interval outside them), by bisection."""
    lo = int(0)
    hi = count - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if data[start + mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@wp.func
def sample_cdf(cdf: wp.array[float], start: int, count: int, u: float):
    """Index ``k`` in ``[0, count)`` with ``cdf[start + k] <= target < cdf[start + k + 1]`` by binary search, where
    ``target = cdf[start] + u * (cdf[start + count] - cdf[start])``.

    ``cdf[start .. start + count]`` holds ``count + 1`` non-decreasing values.
    """
    target = cdf[start] + u * (cdf[start + count] - cdf[start])
    lo = floor_index(cdf, start, count + 1, target)
    # Skip zero-width entries (a sample must never land on a zero-probability bin).
    while lo < count - 1 and cdf[start + lo + 1] <= cdf[start + lo]:
        lo += 1
    return lo


@wp.func
def cdf_remainder(cdf: wp.array[float], start: int, count: int, k: int, u: float):
    """Where in ``[0, 1]`` the target of :func:`sample_cdf` (same ``cdf``, ``start``, ``count``, ``u``) fell inside
    the entry ``k`` it returned: uniform there, for placing the sample inside its bin."""
    target = cdf[start] + u * (cdf[start + count] - cdf[start])
    lo = cdf[start + k]
    return wp.clamp((target - lo) / wp.max(cdf[start + k + 1] - lo, 1.0e-30), 0.0, 1.0)
