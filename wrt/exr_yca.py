"""Luminance-chroma OpenEXR images (channels ``Y``, ``RY``, ``BY``, optionally ``A``) converted to RGBA as OpenEXR's
``RgbaInputFile`` converts them (``ImfRgbaYca``, ``RgbaInputFile::FromYca``): the format ``RgbaOutputFile`` writes
for ``WRITE_YC``/``WRITE_YCA``, luminance at every pixel and the chroma ``RY = (R - Y) / Y``, ``BY = (B - Y) / Y`` at
one sample per 2 x 2 pixels (those whose x and y are even), which halves a colour image's size.

Steps, each rounded to half floats where ``RgbaInputFile`` stores its ``Rgba`` (half) pixels:

1. The chroma is upsampled to every pixel, first along each sample row, then down each column, with OpenEXR's
   14-tap filter (its ``reconstructChromaHoriz``/``Vert`` weights); samples outside the image repeat the edge
   sample, as ``RgbaInputFile`` pads rows and clamps scan lines.
2. ``R = (RY + 1) Y``, ``B = (BY + 1) Y``, ``G = (Y - wr R - wb B) / wg`` (``YCAtoRGBA``; zero chroma: grey ``Y``),
   with the luminance weights ``w`` of the file's ``chromaticities`` attribute, Rec.709's without one
   (``computeYw``: the Y row of the RGB to XYZ matrix, normalized).
3. Pixels far more saturated than their four diagonal neighbours, the filter's overshoot at sharp colour edges,
   are desaturated towards them, keeping their luminance (``fixSaturation``).

Chroma stored at every pixel (1 x 1 sampling, which ``RgbaInputFile`` refuses to read) is converted pixel by pixel
(step 2 alone); other samplings are refused.
"""

from __future__ import annotations

import numpy as np

# Red, green, blue and white x, y of Rec.709 / sRGB: OpenEXR's default when a file has no chromaticities attribute.
REC709_CHROMATICITIES = (0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290)
# Weights of the chroma samples m - 6 .. m + 7 giving the pixel between samples m and m + 1 (OpenEXR's
# reconstructChromaHoriz / reconstructChromaVert, a half-band filter of 27 taps with every other one zero).
CHROMA_FILTER = np.array([0.002128, -0.007540, 0.019597, -0.043159, 0.087929, -0.186077, 0.627123,
                          0.627123, -0.186077, 0.087929, -0.043159, 0.019597, -0.007540, 0.002128], np.float32)
CHROMA_FILTER_OFFSETS = np.arange(-6, 8)  # sample offsets from m of CHROMA_FILTER's weights


def luminance_weights(chromaticities=None) -> np.ndarray:
    """``(3,)`` float64 weights of R, G and B in Y for the primaries and white point ``chromaticities`` (red, green,
    blue, white x y; None: Rec.709), as OpenEXR's ``computeYw``: the Y row of the RGB to XYZ matrix that maps RGB
    (1, 1, 1) to the white point at Y = 1, divided by its sum.

    Raises:
        ValueError: the primaries are not 8 finite numbers or span no triangle (a singular matrix).
    """
    c = np.asarray(REC709_CHROMATICITIES if chromaticities is None else chromaticities, np.float64).reshape(-1)
    if c.shape != (8,) or not np.all(np.isfinite(c)) or c[7] == 0.0:
        raise ValueError(f"chromaticities {tuple(c)} are not 8 finite numbers with a white y other than 0")
    x, y = c[0:8:2], c[1:8:2]
    primaries = np.stack([x[:3], y[:3], 1.0 - x[:3] - y[:3]])  # columns: each primary's xyz
    white = np.array([x[3], y[3], 1.0 - x[3] - y[3]]) / y[3]  # XYZ of the white point at Y = 1
    try:
        scale = np.linalg.solve(primaries, white)
    except np.linalg.LinAlgError:
        raise ValueError(f"chromaticities {tuple(c)} span no triangle") from None
    weights = scale * y[:3]
    return weights / weights.sum()


def _half(x) -> np.ndarray:
    """``x`` rounded to half floats and back, as ``RgbaInputFile`` stores each step's result."""
    return np.asarray(x, np.float32).astype(np.float16).astype(np.float32)


def _upsample_chroma(samples: np.ndarray, axis: int) -> np.ndarray:
    """``samples`` at twice their count along ``axis``: each sample kept at the even positions, the odd ones
    filtered from the samples around them (:data:`CHROMA_FILTER`, edge samples repeated)."""
    samples = np.moveaxis(samples, axis, 0)
    n = samples.shape[0]
    taps = np.clip(np.arange(n)[:, None] + CHROMA_FILTER_OFFSETS, 0, n - 1)  # (n, 14) sample indices
    between = np.tensordot(CHROMA_FILTER, samples[taps.T], axes=1)  # sum over the taps of weight * sample
    out = np.empty((2 * n,) + samples.shape[1:], np.float32)
    out[0::2], out[1::2] = samples, _half(between)
    return np.moveaxis(out, 0, axis)


def _saturation(rgb: np.ndarray) -> np.ndarray:
    """``1 - min / max`` of each pixel's R, G, B (0 where max is not above 0), OpenEXR's ``saturation``."""
    high, low = rgb.max(axis=-1), rgb.min(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(high > 0.0, 1.0 - low / high, 0.0).astype(np.float32)


def _fix_saturation(rows: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """OpenEXR's ``fixSaturation`` of the ``(H, W, 3)`` image inside ``rows`` (``(H + 2, W, 3)``: one row more
    above and below): a pixel whose saturation ``s`` passes both the mean ``m`` of its four diagonal neighbours'
    (edge pixels repeated sideways) and ``1 - (1 - m) / 4`` is desaturated to the latter, its luminance kept."""
    s = _saturation(rows)
    padded = np.concatenate([s[:, :1], s, s[:, -1:]], axis=1)
    mean = 0.25 * (padded[:-2, :-2] + padded[:-2, 2:] + padded[2:, :-2] + padded[2:, 2:])
    mean = np.minimum(np.float32(1.0), mean)
    rgb, s = rows[1:-1], s[1:-1]
    limit = np.minimum(np.float32(1.0), 1.0 - (1.0 - mean) * np.float32(0.25))
    fix = (s > mean) & (s > limit)
    if not np.any(fix):
        return rgb
    w = weights.astype(np.float32)
    px, f = rgb[fix], (limit[fix] / s[fix])[:, None]
    high = px.max(axis=-1, keepdims=True)
    out = _half(np.maximum(high - (high - px) * f, 0.0))
    y_in, y_out = px @ w, out @ w
    keep = np.where(y_out > 0.0, y_in / np.where(y_out > 0.0, y_out, 1.0), 1.0)
    rgb = rgb.copy()
    rgb[fix] = _half(out * keep[:, None])
    return rgb


def _yc_to_rgb(y: np.ndarray, ry: np.ndarray, by: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(..., 3)`` RGB of luminance and chroma (OpenEXR's ``YCAtoRGBA``; zero chroma gives grey ``Y`` exactly)."""
    w = weights.astype(np.float32)
    r, b = (ry + 1.0) * y, (by + 1.0) * y
    g = (y - r * w[0] - b * w[2]) / w[1]
    rgb = np.stack([r, g, b], axis=-1)
    grey = (ry == 0.0) & (by == 0.0)
    rgb[grey] = y[grey][:, None]
    return _half(rgb)


def yca_rgba(y: np.ndarray, ry: np.ndarray | None, by: np.ndarray | None, alpha: np.ndarray | None,
             chromaticities=None) -> np.ndarray:
    """``(H, W, 4)`` float32 RGBA of a luminance-chroma image, as ``RgbaInputFile`` reads it (module docstring).

    Args:
        y: ``(H, W)`` luminance.
        ry, by: chroma, ``(H, W)`` or ``(H / 2, W / 2)`` (one sample per 2 x 2 pixels, ``H`` and ``W`` even); a
            missing one is 0, as ``RgbaInputFile`` fills it.
        alpha: ``(H, W)``, or None for 1.
        chromaticities: the file's ``chromaticities`` attribute (8 numbers), None for Rec.709.

    Raises:
        ValueError: chroma of another size, or ``chromaticities`` that give no luminance weights.
    """
    weights = luminance_weights(chromaticities)
    y = _half(y)
    h, w = y.shape
    present = [c for c in (ry, by) if c is not None]
    shapes = {c.shape for c in present}
    subsampled = h % 2 == 0 and w % 2 == 0 and shapes == {(h // 2, w // 2)}
    if shapes and not subsampled and shapes != {(h, w)}:
        sizes = ", ".join(f"{c.shape[1]}x{c.shape[0]}" for c in present)
        raise ValueError(f"chroma RY, BY of {sizes} pixels beside luminance of {w}x{h}: only chroma at every "
                         "pixel or at one per 2 x 2 pixels is read")
    like = present[0] if present else y
    ry, by = (_half(np.zeros(like.shape) if c is None else c) for c in (ry, by))
    if not subsampled:
        rgb = _yc_to_rgb(y, ry, by, weights)
    else:
        # Rows -1 and H beside the image, for the saturation fix: as RgbaInputFile's clamped scan lines give them
        # (row -1: row 0's luminance, chroma filtered as for an odd row; row H: row H - 2 whole).
        sample_rows = [_upsample_chroma(c, axis=1) for c in (ry, by)]  # (H / 2, W): along each sample row
        chroma = [_upsample_chroma(c, axis=0) for c in sample_rows]
        above = [_half(np.tensordot(CHROMA_FILTER, c[np.clip(CHROMA_FILTER_OFFSETS - 1, 0, len(c) - 1)], axes=1))
                 for c in sample_rows]
        ys = np.concatenate([y[:1], y, y[-2:-1]])
        cs = [np.concatenate([a[None], c, c[-2:-1]]) for a, c in zip(above, chroma)]
        rgb = _fix_saturation(_yc_to_rgb(ys, cs[0], cs[1], weights), weights)
    rgba = np.empty((h, w, 4), np.float32)
    rgba[..., :3] = rgb
    rgba[..., 3] = 1.0 if alpha is None else _half(alpha)
    return rgba
