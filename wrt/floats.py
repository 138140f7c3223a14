"""Float32 bit patterns, and exact scaling by powers of two.

Multiplying by a power of two changes only a float's exponent, so it is exact (away from overflow and
subnormals) and commutes with rounding: a ray whose direction is scaled by ``2^k`` gets the same hits with every
``t`` scaled by ``2^-k``, bit for bit. Kernels use that to bring directions of any length to a length near 1
before the tests whose constants assume it (``unit_scales``).
"""

import warp as wp

FLOAT32_MAX = wp.constant(3.4028234663852886e38)  # the largest finite float32
TRACED_REACH = 2.0**126  # Scene.warn_past_traced_reach: coordinates beyond it can overflow the triangle test


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    return __float_as_int(x);
#else
    int r;
    memcpy(&r, &x, sizeof(r));
    return r;
#endif
""")
def float_bits(x: float) -> int:
    """The int32 with the bits of ``x``."""


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    return __int_as_float(x);
#else
    float r;
    memcpy(&r, &x, sizeof(r));
    return r;
#endif
""")
def int_bits_as_float(x: int) -> float:
    """The float32 with the bits of ``x`` (never used as a number: it may be a NaN pattern)."""


@wp.func
def largest_magnitude(v: wp.vec3):
    """``max(|v[0]|, |v[1]|, |v[2]|)``."""
    return wp.max(wp.max(wp.abs(v[0]), wp.abs(v[1])), wp.abs(v[2]))


@wp.func
def power_scales(x: float):
    """``(down, up)``: the power of two ``down`` that brings ``|x|`` into ``[1, 2)``, and ``up = 1 / down``. The
    exponent is clamped so that both are normal floats: zero stays zero, an infinite or NaN ``x`` stays so."""
    e = wp.clamp((float_bits(x) >> 23) & 255, 1, 253)  # the biased exponent
    return int_bits_as_float((254 - e) << 23), int_bits_as_float(e << 23)  # 2^(127 - e), 2^(e - 127)


@wp.func
def unit_scales(v: wp.vec3):
    """``power_scales`` of ``v``'s largest component: ``v * down`` has its largest component in ``[1, 2)``."""
    return power_scales(largest_magnitude(v))


@wp.func
def next_up(x: float):
    """The smallest float32 above ``x`` (``2^-149`` above 0 and -0; ``x`` itself for inf and NaN)."""
    bits = float_bits(x)
    y = x
    if x == 0.0:
        y = int_bits_as_float(1)
    elif x > 0.0 and x < FLOAT32_MAX:
        y = int_bits_as_float(bits + 1)
    elif x < 0.0 and x > -wp.inf:
        y = int_bits_as_float(bits - 1)  # a negative float's magnitude shrinks as its bits (sign set) count down
    return y


@wp.func
def scaled_limit(limit: float, down: float, up: float):
    """``limit * up`` for a ray scaled by ``(down, up)`` (``unit_scales``), rounded up where it is not exact (below
    float32's normal range; up to inf past its largest value), so that a float32 ``t`` of the scaled ray compares
    with it (``t >= t_min``, ``t < t_max``) as ``t * down`` does with ``limit``. To the nearest, a ``t_min`` of
    2^-149 scaled by 2^-10 became 0, and kept hits at ``t = 0``."""
    scaled = limit * up
    if scaled * down < limit:  # exact when up < 1, where products can round below the normal range
        scaled = next_up(scaled)
    return scaled
