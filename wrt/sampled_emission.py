"""The emission each triangle (and analytic shape) of a textured emitter shows, read at points of the triangle (at
the shape's one ``st``) by the render's own lookup (:func:`wrt.materials.eval_emission`), for the light table's choice
of which triangles and shapes to sample and how often (:mod:`wrt.light_table`, :mod:`wrt.glowing_spheres`).

A material's emission estimate (:func:`wrt.materials.emission_estimate`) is the mean of its texture's texels, which
misses what the lookup returns besides them: a UDIM texture's fallback on a tile without a file (or outside the
tiles), a MaterialX image's ``default`` outside [0, 1] under the ``constant`` address mode, any texture's fallback at
non-finite texture coordinates. A texture of black texels whose fallback glows was estimated as no light: its
triangles were never sampled (``whitted`` left what they light black, and a stage lit by them alone got the default
lights), and ``path`` found their light only through the rays that happened to hit them. Each such triangle takes
the larger of its material's estimate and the mean emission at :data:`BARYCENTRIC_POINTS`, so that the estimate and
the render cannot disagree on where the glow is, and no triangle is estimated below its material's mean (of a UDIM
texture, below the largest mean of the tiles under it, :func:`tiles_glow`: a triangle on a black tile glows nowhere,
and took as many draws as one on a bright tile; of one image, not held at its mean where every texel the lookup
reads on the triangle lies in a block in which none glows, :func:`reads_no_glow`: a triangle over the black part of
an image took draws that found no light). Points can
all miss a glow that only part of a triangle shows (a corner past [0, 1] along a ``constant`` address mode, a missing
UDIM tile between the points): a triangle on which the lookup can return its fallback at all takes at least a fifth
of the fallback's emission (:func:`may_read_fallback`), so that no light is left with no chance of being sampled (such
a lamp was no light: ``whitted`` left what it lit black, and a stage lit by it alone got the default lights).
A glow cut out by an opacity image is read on its triangles too: one all in its holes (every texel it reads there
under the threshold, :func:`opaque_blocks`) emits nothing, and took draws that found no light.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import warp as wp

from .errors import user_stacklevel
from .materials import CHANNELS, SLOT_EMISSIVE, SLOT_OPACITY, DeviceMaterials, eval_emission, select_channel
from .textures import (
    UDIM_COLUMNS,
    UDIM_ROWS,
    UDIM_TILES,
    WRAP_BLACK,
    WRAP_FALLBACK,
    WRAP_MIRROR,
    WRAP_REPEAT,
    image_scale,
)

# The same rounding on every device, as the light table it feeds (see wrt/shade.py); no adjoint code to compile.
wp.set_module_options({"fuse_fp": False, "enable_backward": False})

# Points read on each triangle (barycentric weights of corners 0, 1, 2): the centroid and one towards each corner.
BARYCENTRIC_POINTS = np.array([[1, 1, 1], [4, 1, 1], [1, 4, 1], [1, 1, 4]], np.float64) / np.array([[3], [6], [6], [6]])


@wp.func
def st_box(mats: DeviceMaterials, b: int, st0: wp.vec2, st1: wp.vec2, st2: wp.vec2):
    """``(lo, hi, finite)``: the box of the texture coordinates ``st0, st1, st2`` after binding ``b``'s transform,
    and whether every corner is finite (a sum past float32 counts as not: conservative)."""
    xf = mats.tex_transform[b]
    p0 = xf * wp.vec3(st0[0], st0[1], 1.0)
    p1 = xf * wp.vec3(st1[0], st1[1], 1.0)
    p2 = xf * wp.vec3(st2[0], st2[1], 1.0)
    lo = wp.vec2(wp.min(wp.min(p0[0], p1[0]), p2[0]), wp.min(wp.min(p0[1], p1[1]), p2[1]))
    hi = wp.vec2(wp.max(wp.max(p0[0], p1[0]), p2[0]), wp.max(wp.max(p0[1], p1[1]), p2[1]))
    return lo, hi, wp.isfinite(p0[0] + p0[1] + p1[0] + p1[1] + p2[0] + p2[1])


@wp.func
def tile_span(lo: wp.vec2, hi: wp.vec2):
    """``(u0, v0, u1, v1)``: the UDIM tiles (columns ``u0..u1``, rows ``v0..v1``) whose inside the box ``lo, hi``
    meets, the box inside the 10 x 10 tiles: a box edge on a tile's edge (st of a tile's corners) reads no
    further."""
    u0, v0 = int(wp.floor(lo[0])), int(wp.floor(lo[1]))
    u1 = wp.min(wp.max(u0, int(wp.ceil(hi[0])) - 1), UDIM_COLUMNS - 1)
    v1 = wp.min(wp.max(v0, int(wp.ceil(hi[1])) - 1), UDIM_ROWS - 1)
    return wp.vec4i(u0, v0, u1, v1)


@wp.func
def leaves_unit_square(mats: DeviceMaterials, b: int, lo: wp.vec2, hi: wp.vec2, mode: int):
    """Whether the box ``lo, hi`` of binding ``b``'s (transformed) texture coordinates leaves [0, 1] along an axis
    whose wrap mode is ``mode`` (``fallback``: its lookup returns the fallback there, ``black``: the texel 0); the
    unit interval holds a triangle where it holds its corners."""
    wrap = mats.tex_wrap[b]
    s_out = wrap[0] == mode and (lo[0] < 0.0 or hi[0] > 1.0)
    t_out = wrap[1] == mode and (lo[1] < 0.0 or hi[1] > 1.0)
    return s_out or t_out


@wp.func
def may_read_fallback(mats: DeviceMaterials, b: int, st0: wp.vec2, st1: wp.vec2, st2: wp.vec2):
    """Whether texture binding ``b`` can return its fallback somewhere on the triangle of texture coordinates
    ``st0, st1, st2``, where :func:`wrt.materials.lookup_binding` returns it: a corner not finite (nor then is any
    point), the image missing, a ``fallback`` wrap with a corner outside [0, 1] along its axis (the unit interval
    holds the triangle where it holds its corners), a UDIM tile without a file (or none: outside the tiles) under the
    box of the corners. Conservative: the box holds every tile the triangle reads, maybe more."""
    if b < 0:  # a constant: no texture, no fallback
        return False
    lo, hi, finite = st_box(mats, b, st0, st1, st2)
    if not finite:
        return True
    table = mats.tex_tiles[b]
    if table < 0:
        return mats.tex_image[b] < 0 or leaves_unit_square(mats, b, lo, hi, WRAP_FALLBACK)
    if lo[0] < 0.0 or lo[1] < 0.0 or hi[0] > float(UDIM_COLUMNS) or hi[1] > float(UDIM_ROWS):
        return True
    span = tile_span(lo, hi)
    for v in range(span[1], span[3] + 1):
        for u in range(span[0], span[2] + 1):
            if mats.tile_images[table + u + UDIM_COLUMNS * v] < 0:
                return True
    return False


@wp.func
def tiles_glow(mats: DeviceMaterials, b: int, st0: wp.vec2, st1: wp.vec2, st2: wp.vec2,
               tile_glow: wp.array[wp.vec3], row: int):
    """The largest of ``tile_glow[row + tile]`` (each UDIM tile's mean emission) over the tiles of binding ``b``
    with a file under the box of the triangle's texture coordinates ``st0, st1, st2`` (0 for none: where it reads no
    tile, its points and :func:`may_read_fallback` tell its glow)."""
    glow = wp.vec3(0.0)
    lo, hi, finite = st_box(mats, b, st0, st1, st2)
    if not finite or hi[0] < 0.0 or hi[1] < 0.0 or lo[0] >= float(UDIM_COLUMNS) or lo[1] >= float(UDIM_ROWS):
        return glow
    low = wp.vec2(wp.max(lo[0], 0.0), wp.max(lo[1], 0.0))
    span = tile_span(low, wp.vec2(wp.min(hi[0], float(UDIM_COLUMNS)), wp.min(hi[1], float(UDIM_ROWS))))
    table = mats.tex_tiles[b]
    for v in range(span[1], span[3] + 1):
        for u in range(span[0], span[2] + 1):
            tile = u + UDIM_COLUMNS * v
            if mats.tile_images[table + tile] >= 0:
                g = tile_glow[row + tile]
                glow = wp.vec3(wp.max(glow[0], g[0]), wp.max(glow[1], g[1]), wp.max(glow[2], g[2]))
    return glow


# Blocks per side, at most, of the map of where an emission image glows (glow_blocks): 256 x 256 int32 counts, 264 kB.
GLOW_BLOCKS = 256


@wp.func
def texel_span(lo: float, hi: float, n: int, wrap: int):
    """``(i0, i1)``: the texels ``[i0, i1]`` (of ``n`` along an axis) that a lookup reads at coordinates in ``[lo,
    hi]`` (texels ``x = c n - 0.5`` and the next: bilinear filtering, which holds the nearest texel too), after
    ``wrap``: all ``n`` where ``repeat`` or ``mirror`` wraps them at all, else clamped (``clamp``, ``black`` and
    ``fallback``, whose values outside the image are none of its texels)."""
    i0 = int(wp.floor(wp.clamp(lo * float(n) - 0.5, -1.0e8, 1.0e8)))
    i1 = int(wp.floor(wp.clamp(hi * float(n) - 0.5, -1.0e8, 1.0e8))) + 1
    if wrap == WRAP_REPEAT or wrap == WRAP_MIRROR:
        if i0 < 0 or i1 > n - 1:
            return 0, n - 1
        return i0, i1
    return wp.clamp(i0, 0, n - 1), wp.clamp(i1, 0, n - 1)


@wp.func
def reads_no_glow(mats: DeviceMaterials, b: int, st0: wp.vec2, st1: wp.vec2, st2: wp.vec2,
                  counts: wp.array[wp.int32], row: int, block: int):
    """Whether every texel of binding ``b``'s image that a lookup reads on the triangle of texture coordinates
    ``st0, st1, st2`` (the texels under the box of its corners, one more on each side) lies in a block of ``block``
    x ``block`` texels without one that glows: ``counts[row:]`` is the image's summed-area table of its blocks that
    hold one (:func:`glow_blocks`). False where a corner is not finite. Its fallback is :func:`may_read_fallback`'s."""
    lo, hi, finite = st_box(mats, b, st0, st1, st2)
    if not finite:
        return False
    size = mats.image_sizes[mats.tex_image[b]]
    wrap = mats.tex_wrap[b]
    x0, x1 = texel_span(lo[0], hi[0], size[0], wrap[0])
    y0, y1 = texel_span(1.0 - hi[1], 1.0 - lo[1], size[1], wrap[1])  # rows from the top
    w = (size[0] + block - 1) // block + 1  # a row of the table
    bx0, bx1, by0, by1 = x0 // block, x1 // block + 1, y0 // block, y1 // block + 1
    return (counts[row + by1 * w + bx1] - counts[row + by0 * w + bx1] - counts[row + by1 * w + bx0]
            + counts[row + by0 * w + bx0]) == 0


@wp.kernel
def sample_emission_kernel(mats: DeviceMaterials, uvs: wp.array2d[wp.vec2], ids: wp.array[wp.int32],
                           materials: wp.array[wp.int32], weights: wp.array[wp.vec3], tile_glow: wp.array[wp.vec3],
                           tile_rows: wp.array[wp.int32], glow_counts: wp.array[wp.int32],
                           glow_rows: wp.array[wp.vec2i], hole_counts: wp.array[wp.int32],
                           hole_rows: wp.array[wp.vec2i],
                           # outputs
                           emission: wp.array[wp.vec3], dark: wp.array[wp.int32]):
    """``emission[i]``: the mean emission of material ``materials[i]`` on triangle ``ids[i]`` at the barycentric
    points ``weights``, each component clamped to 0 first (a component below 0 adds no light); at least the
    fallback's emission over ``len(weights) + 1`` where the texture may return its fallback on the triangle
    (:func:`may_read_fallback`): a glow that no point read lies between them, on less of the triangle than one
    point's share, as far as they tell; for a material of a UDIM emission texture, at least the largest mean
    emission of its tiles under the triangle (:func:`tiles_glow`; ``tile_rows[m]``: material ``m``'s first row of
    ``tile_glow``, -1 for one of another texture), for the same reason. ``dark[i]``: 1 where the texels the
    triangle reads glow nowhere (:func:`reads_no_glow`; ``glow_rows[m]``: material ``m``'s first row of
    ``glow_counts`` and its block size, -1 for none), so that the material's mean is not its estimate; and with
    ``emission[i]`` 0 where every texel of its opacity texture read on the triangle cuts a hole (``hole_rows``,
    ``hole_counts``: :func:`opaque_blocks`), and the texture returns no fallback there, nor the texel 0 of a
    ``black`` wrap mode that reads opaque: it emits nothing."""
    i = wp.tid()
    t = ids[i]
    m = materials[i]
    n = weights.shape[0]
    b = mats.slots[m, SLOT_EMISSIVE]
    fallback = may_read_fallback(mats, b, uvs[t, 0], uvs[t, 1], uvs[t, 2])
    total = wp.vec3(0.0)
    least = wp.vec3(0.0)
    if tile_rows[m] >= 0:
        least = tiles_glow(mats, b, uvs[t, 0], uvs[t, 1], uvs[t, 2], tile_glow, tile_rows[m])
    # Each point, then the fallback (what every lookup at a NaN st returns): one lookup compiled, not one per read
    # (the loop's bound is read at run time).
    for j in range(n + 1):
        st = wp.vec2(wp.nan, wp.nan)
        if j < n:
            w = weights[j]
            st = w[0] * uvs[t, 0] + w[1] * uvs[t, 1] + w[2] * uvs[t, 2]
        elif not fallback:
            break
        e = eval_emission(mats, m, st)
        e = wp.vec3(wp.max(e[0], 0.0), wp.max(e[1], 0.0), wp.max(e[2], 0.0))
        if j < n:
            total += e
        else:
            e = e / float(n + 1)
            least = wp.vec3(wp.max(least[0], e[0]), wp.max(least[1], e[1]), wp.max(least[2], e[2]))
    mean = total / float(n)
    emission[i] = wp.vec3(wp.max(mean[0], least[0]), wp.max(mean[1], least[1]), wp.max(mean[2], least[2]))
    glow_row = glow_rows[m]
    if glow_row[0] >= 0 and reads_no_glow(mats, b, uvs[t, 0], uvs[t, 1], uvs[t, 2], glow_counts, glow_row[0],
                                          glow_row[1]):
        dark[i] = 1
    hole_row = hole_rows[m]
    if hole_row[0] >= 0:
        o = mats.slots[m, SLOT_OPACITY]
        # Outside [0, 1] a ``black`` wrap reads the texel 0, scaled and biased: the bias, which an inverted opacity
        # (scale -1, bias 1) reads opaque; a triangle reaching there shows its glow whatever the texels under it.
        black = select_channel(mats.tex_bias[o], mats.tex_channel[o])[0]
        black_hole = wp.clamp(black, 0.0, 1.0) < mats.params[m, 3]  # as wrt.materials.cut_out compares
        lo, hi, finite = st_box(mats, o, uvs[t, 0], uvs[t, 1], uvs[t, 2])
        opaque_border = not black_hole and leaves_unit_square(mats, o, lo, hi, WRAP_BLACK)
        if not may_read_fallback(mats, o, uvs[t, 0], uvs[t, 1], uvs[t, 2]) and not opaque_border and reads_no_glow(
                mats, o, uvs[t, 0], uvs[t, 1], uvs[t, 2], hole_counts, hole_row[0], hole_row[1]):
            emission[i] = wp.vec3(0.0)
            dark[i] = 1


@dataclasses.dataclass(frozen=True)
class SampledEmission:
    """The emission estimates read on the rows of textured emitters (:func:`sampled_emission`), kept for those rows
    alone: every other row's estimate is its material's. A dense ``(T, 3)`` float64 array over every row took 24 MB
    per million triangles of a scene with one small textured lamp, and as much again in each of its temporaries.

    Attributes:
        ids: ``(K,)`` int64, ascending: the rows (of ``tri_materials``, geometry triangles then analytic shapes) of
            the materials whose emission is read on them.
        values: ``(K, 3)`` float64 their emission estimate (of :meth:`luminance`: ``(K,)``, its luminance).
    """

    ids: np.ndarray
    values: np.ndarray

    def over(self, rows: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``values`` (``(N, ...)``, per row of ``rows``: their material's) with each row among :attr:`ids` given its
        own of :attr:`values`, in a copy."""
        rows = np.asarray(rows)
        out = np.array(values, copy=True)
        if len(self.ids) == 0 or len(rows) == 0:
            return out
        at = np.minimum(np.searchsorted(self.ids, rows), len(self.ids) - 1)
        hit = self.ids[at] == rows
        out[hit] = self.values[at[hit]]
        return out

    def luminance(self, weights: np.ndarray) -> SampledEmission:
        """The same rows, each with its estimate's luminance of ``weights`` (``(3,)``, per channel)."""
        return SampledEmission(self.ids, self.values @ weights)

    def without(self, dropped: np.ndarray, tri_materials: np.ndarray) -> SampledEmission:
        """This, less the rows whose device material (``tri_materials``, ``(T,)``) is marked in ``dropped`` (``(M,)``
        bool)."""
        keep = ~np.asarray(dropped, bool)[np.asarray(tri_materials)[self.ids]]
        return SampledEmission(self.ids[keep], self.values[keep])


def block_maps(materials: list, images: list[np.ndarray], textured: np.ndarray,
               holed: np.ndarray) -> tuple[list, list]:
    """``(glow_maps, hole_maps)`` for :func:`sampled_emission`: per device material (``[default] + materials``)
    :func:`glow_blocks` of one marked in ``textured`` (``(M,)`` bool), :func:`opaque_blocks` of one marked in
    ``holed``, else None. A table is made once per image and what it is made of, and shared (one object, packed
    once): materials of one image each made their own (0.59 s per 4k image, per material)."""
    memo = {}
    glow = [None] + [glow_blocks(m, images, memo) if t else None for m, t in zip(materials, textured[1:])]
    holes = [None] + [opaque_blocks(m, images, memo) if h else None for m, h in zip(materials, holed[1:])]
    return glow, holes


def shared(memo: dict | None, key: tuple, make):
    """``memo[key]``, made by ``make()`` where absent (every time without a ``memo``)."""
    if memo is None:
        return make()
    if key not in memo:
        memo[key] = make()
    return memo[key]


def glow_blocks(mat, textures: list[np.ndarray], memo: dict | None = None) -> tuple[np.ndarray, int] | None:
    """``(counts, block)`` for ``mat``'s emission texture of one image (of ``textures``, the scene's RGBA float32
    images): the summed-area table (``(rows + 1, columns + 1)`` int32) of its blocks of ``block`` x ``block`` texels
    (at most :data:`GLOW_BLOCKS` per side) that hold a texel it reads as glowing (a channel it reads times its scale
    above 0, or not a number), for :func:`reads_no_glow`. None for a UDIM texture, a missing image, or a bias in a
    channel it reads (the device's half-float texel, rounded, could then glow where this one does not). ``memo``:
    tables already made (:func:`block_maps`), of the image, the channels read and their scales' signs alone."""
    tex = mat.textures.get("emissiveColor")
    if tex is None or tex.tiles is not None or not 0 <= tex.image < len(textures):
        return None
    channels = [0, 1, 2] if CHANNELS[tex.channel] == 4 else [CHANNELS[tex.channel]]
    scale, bias = np.asarray(tex.scale, np.float64), np.asarray(tex.bias, np.float64)
    if np.any(bias[channels] != 0.0):
        return None
    signs = tuple(float(np.sign(scale[c])) for c in channels)  # (NaN for a NaN scale: never equal, not shared)

    def make():
        image = textures[tex.image]
        glows = np.zeros(image.shape[:2], bool)
        for c, sign in zip(channels, signs):  # one channel at a time: a float64 copy of a 4k image took 400 MB
            texel = image[..., c]
            glows |= np.isnan(texel) | (texel > 0.0 if sign > 0.0 else texel < 0.0 if sign < 0.0 else False)
        return block_counts(glows)

    return shared(memo, ("glow", tex.image, tuple(channels), signs), make)


def opaque_blocks(mat, textures: list[np.ndarray], memo: dict | None = None) -> tuple[np.ndarray, int] | None:
    """``(counts, block)`` for ``mat``'s opacity texture of one image where it cuts holes (``opacity_threshold``
    above 0): :func:`block_counts` of the texels it may read as opaque (at least the threshold, within the rounding
    of the device's half-float texels, or not a number), so that a triangle all in holes, which emits nothing, is
    found by :func:`reads_no_glow`. None for a UDIM texture, a missing image or no threshold. ``memo``: tables
    already made (:func:`block_maps`), of the image, the channel read, its scale and bias and the threshold."""
    tex = mat.textures.get("opacity")
    threshold = float(np.float32(mat.opacity_threshold))  # as the device compares
    if tex is None or tex.tiles is not None or not threshold > 0.0 or not 0 <= tex.image < len(textures):
        return None
    c = CHANNELS[tex.channel] % 4  # a scalar input reads the first component: red of rgb
    scale, bias = float(tex.scale[c]), float(tex.bias[c])
    return shared(memo, ("opaque", tex.image, c, scale, bias, threshold),
                  lambda: _opaque_counts(textures[tex.image], c, scale, bias, threshold))


def _opaque_counts(image: np.ndarray, c: int, scale: float, bias: float, threshold: float) -> tuple[np.ndarray, int]:
    """:func:`block_counts` of the texels of channel ``c`` of ``image`` that may read as opaque, ``texel * scale +
    bias`` at least ``threshold`` (:func:`opaque_blocks`)."""
    texel = image[..., c].astype(np.float64)
    scaled = texel * scale
    # The slack holds the half-float rounding of the texel and the float32 rounding of the sum; for a half-float
    # subnormal (below 2^-14 of its image's power of two) the rounding is absolute, half a step of 2^-24: a texel of
    # 1.05e-7 is stored as 1.19e-7, which a scale of 1e4 read as opaque over a threshold of 1.1e-3 that the relative
    # slack alone took for a hole (the glow's triangles there took no light picks).
    subnormal_step = abs(scale) * float(image_scale(image)[c]) * 2.0**-24
    slack = np.abs(scaled) * 2.0**-9 + subnormal_step + 2.0**-20
    return block_counts(~(scaled + bias + slack < threshold))


def block_counts(marked: np.ndarray) -> tuple[np.ndarray, int]:
    """``(counts, block)``: the summed-area table (``(rows + 1, columns + 1)`` int32) of the blocks of ``block`` x
    ``block`` texels (at most :data:`GLOW_BLOCKS` per side) of ``marked`` (``(H, W)`` bool) that hold a marked one."""
    h, w = marked.shape
    block = max(1, -(-max(h, w) // GLOW_BLOCKS))
    rows, columns = -(-h // block), -(-w // block)
    padded = np.zeros((rows * block, columns * block), bool)
    padded[:h, :w] = marked
    counts = np.zeros((rows + 1, columns + 1), np.int32)
    counts[1:, 1:] = padded.reshape(rows, block, columns, block).any(axis=(1, 3)).cumsum(0).cumsum(1)
    return counts, block


def sampled_emission(mats: DeviceMaterials, uvs: wp.array2d[wp.vec2], tri_materials: np.ndarray,
                     estimates: np.ndarray, sampled: np.ndarray, device,
                     tile_estimates: list | None = None, glow_maps: list | None = None,
                     hole_maps: list | None = None) -> SampledEmission | None:
    """The emission estimate of each row of a material marked in ``sampled`` (``tri_materials``: the geometry's
    triangles then one row per analytic shape): the largest of the mean emission at :data:`BARYCENTRIC_POINTS`, a
    fifth of a fallback it may read and its material's estimate, or for a material given ``tile_estimates``, the
    largest estimate of the tiles under it instead (:func:`sample_emission_kernel`; a shape's three corners are its
    one ``st``, where the render reads its glow); None where no row is of a ``sampled`` material.

    A row's estimate is positive wherever it may glow, so that it can be drawn: its points can all miss a glow
    between them. A material's mean held each triangle of a UDIM set on a black tile (whose lookups are all 0) as
    high as those on the bright ones, which then had as many draws wasted; its own tiles' mean holds it at 0.

    Args:
        mats: the scene's device materials (:func:`wrt.materials.upload_materials`).
        uvs: ``(T, 3)`` texture coordinates per corner on ``device`` (:meth:`wrt.Scene.corner_uvs`).
        tri_materials: ``(T,)`` int device material of each row.
        estimates: ``(M, 3)`` emission estimate per device material (:func:`wrt.materials.emission_estimates`).
        sampled: ``(M,)`` bool, the materials whose emission is read on their triangles (those with an emission
            texture, and glows cut out by an opacity texture).
        device: the Warp device of ``mats`` and ``uvs``.
        tile_estimates: per device material None, or for one of a UDIM emission texture ``(UDIM_TILES, 3)`` each
            tile's estimate (:func:`wrt.materials.tile_emission_estimates`); None: none.
        glow_maps: per device material None, or :func:`glow_blocks` of its emission image: a triangle whose texels
            glow nowhere is not held at its material's estimate; None: none.
        hole_maps: per device material None, or :func:`opaque_blocks` of its opacity image: a triangle all in holes
            is estimated at 0; None: none.
    """
    sampled = np.asarray(sampled, bool)
    if not sampled.any():  # (no per-triangle gather: most scenes have no textured emitter)
        return None
    tri_materials = np.asarray(tri_materials)
    ids = np.flatnonzero(sampled[tri_materials])
    if len(ids) == 0:
        return None
    materials = tri_materials[ids]
    tiles = [None] * len(sampled) if tile_estimates is None else list(tile_estimates)
    tiled = np.array([t is not None for t in tiles])
    tile_rows = np.where(tiled, np.cumsum(tiled) - 1, -1) * UDIM_TILES
    tile_glow = np.concatenate([t for t in tiles if t is not None] or [np.zeros((1, 3))]).astype(np.float32)
    glow_counts, glow_rows = _packed_maps(glow_maps, len(sampled), "emission")
    hole_counts, hole_rows = _packed_maps(hole_maps, len(sampled), "opacity")
    read = wp.empty(len(ids), dtype=wp.vec3, device=device)
    dark = wp.zeros(len(ids), dtype=wp.int32, device=device)
    wp.launch(sample_emission_kernel, dim=len(ids), device=device,
              inputs=[mats, uvs, wp.array(ids.astype(np.int32), dtype=wp.int32, device=device),
                      wp.array(materials.astype(np.int32), dtype=wp.int32, device=device),
                      wp.array(BARYCENTRIC_POINTS.astype(np.float32), dtype=wp.vec3, device=device),
                      wp.array(tile_glow, dtype=wp.vec3, device=device),
                      wp.array(tile_rows.astype(np.int32), dtype=wp.int32, device=device),
                      wp.array(glow_counts, dtype=wp.int32, device=device),
                      wp.array(glow_rows, dtype=wp.vec2i, device=device),
                      wp.array(hole_counts, dtype=wp.int32, device=device),
                      wp.array(hole_rows, dtype=wp.vec2i, device=device)],
              outputs=[read, dark])
    # A sum past float32's range (texels near 65504 times a huge scale) as the largest float.
    mean = np.nan_to_num(read.numpy(), nan=0.0, posinf=np.finfo(np.float32).max)
    least = np.where(tiled[materials, None] | (dark.numpy()[:, None] == 1), 0.0,
                     np.asarray(estimates, np.float64).reshape(-1, 3)[materials])
    return SampledEmission(ids.astype(np.int64), np.maximum(least, mean))


# Entries, at most, of the tables packed into one array (_packed_maps): the device indexes them in int32, and a Warp
# array holds no more. A table holds at most (GLOW_BLOCKS + 1)^2 = 66,049: 32,513 images of 256 texels a side or
# more (or one image under as many opacity thresholds), 8.6 GB of tables.
MAX_PACKED_ENTRIES = 2**31 - 1


def _packed_maps(maps: list | None, count: int, what: str = "block") -> tuple[np.ndarray, np.ndarray]:
    """``(counts, rows)``: the tables of ``maps`` (per device material None or ``(counts, block)``; None: none of
    ``count``) one after another (int32), each table once however many materials share it (:func:`block_maps`), and
    per material ``(first row, block)`` (int32, -1 for none). Tables past :data:`MAX_PACKED_ENTRIES` are left out,
    with a warning naming how many (``what``: their kind): their materials' rows are -1, drawn by the material's
    estimate as without a table (unbiased, noisier); their int32 offsets wrapped, negative (no table) or onto
    another's."""
    maps = [None] * count if maps is None else list(maps)
    first, tables, end, dropped = {}, [], 0, set()
    for g in maps:
        if g is None or id(g[0]) in first or id(g[0]) in dropped:
            continue
        if end + g[0].size > MAX_PACKED_ENTRIES:
            dropped.add(id(g[0]))
            continue
        first[id(g[0])] = end
        tables.append(g[0])
        end += g[0].size
    if dropped:
        warnings.warn(f"{len(first) + len(dropped)} {what} tables of textured glows hold more than "
                      f"{MAX_PACKED_ENTRIES} entries, the most one array holds: {len(dropped)} left out (their "
                      "materials' triangles are drawn by the material's estimate: unbiased, noisier)",
                      stacklevel=user_stacklevel())
    rows = np.array([(first.get(id(g[0]), -1), g[1]) if g is not None else (-1, 1) for g in maps], np.int64)
    rows = rows.reshape(-1, 2).astype(np.int32)
    return np.concatenate([t.ravel() for t in tables] or [np.zeros(1, np.int32)]), rows
