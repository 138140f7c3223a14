"""PNG files written byte by byte for the texture reader's tests, of every colour type, bit depth and interlacing
the PNG specification allows, with the pixels known to the test (PNG specification, clauses 7 to 11; Adam7
interlacing, clause 8.2): what Pillow cannot write (interlaced files, 16-bit grey + alpha, tRNS chunks beside
alpha, low bit depths with transparency), with no decoder in the loop."""

import struct
import zlib

import numpy as np
from png_chunks import SIGNATURE, chunk

CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # samples per pixel of each colour type (3: palette indices)
# Adam7 passes: (first row, first column, row step, column step)
ADAM7 = [(0, 0, 8, 8), (0, 4, 8, 8), (4, 0, 8, 4), (0, 2, 4, 4), (2, 0, 4, 2), (0, 1, 2, 2), (1, 0, 2, 1)]


def _rows(samples: np.ndarray, depth: int) -> bytes:
    """The filtered (filter type 0) scanlines of ``(h, w, c)`` samples packed at ``depth`` bits."""
    h, w, c = samples.shape
    out = b""
    for row in samples.reshape(h, w * c):
        if depth == 16:
            data = row.astype(">u2").tobytes()
        elif depth == 8:
            data = row.astype(np.uint8).tobytes()
        else:  # 1, 2 or 4 bits: the leftmost sample in the high bits, the last byte padded
            per_byte = 8 // depth
            padded = np.zeros(-(-len(row) // per_byte) * per_byte, np.uint8)
            padded[: len(row)] = row
            shifts = depth * np.arange(per_byte - 1, -1, -1)
            data = (padded.reshape(-1, per_byte) << shifts).sum(axis=1).astype(np.uint8).tobytes()
        out += b"\0" + data
    return out


def png(samples, colour_type: int, depth: int, interlaced=False, palette=None, trns=None, extra=(),
        trns_after_idat=False) -> bytes:
    """A PNG of ``samples`` (``(H, W, C)`` or ``(H, W)``, whole numbers below ``2**depth``; palette indices for
    colour type 3), with a ``PLTE`` of ``palette`` (``(N, 3)``), a ``tRNS`` chunk of the bytes ``trns``, and
    ``extra`` ``(type, data)`` chunks before the image data; Adam7-interlaced when ``interlaced``."""
    samples = np.asarray(samples)
    if samples.ndim == 2:
        samples = samples[..., None]
    h, w, c = samples.shape
    assert c == CHANNELS[colour_type]
    if interlaced:
        stream = b"".join(_rows(samples[y0::dy, x0::dx], depth) for y0, x0, dy, dx in ADAM7
                          if samples[y0::dy, x0::dx].size)  # an empty pass has no scanlines
    else:
        stream = _rows(samples, depth)
    data = SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour_type, 0, 0, int(interlaced)))
    if palette is not None:
        data += chunk(b"PLTE", np.asarray(palette, np.uint8).tobytes())
    for kind, payload in extra:
        data += chunk(kind, payload)
    if trns is not None and not trns_after_idat:
        data += chunk(b"tRNS", trns)
    data += chunk(b"IDAT", zlib.compress(stream))
    if trns is not None and trns_after_idat:
        data += chunk(b"tRNS", trns)
    return data + chunk(b"IEND", b"")
