"""A PNG reader in plain Python and zlib, independent of Pillow, for tests of the files wrt writes: the chunks with
their CRCs checked, and the pixels of an 8-bit, non-interlaced RGB or RGBA image (PNG specification, clauses 5, 9
and 11)."""

import struct
import zlib

import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"  # the first eight bytes of every PNG


def read_chunks(source) -> list[tuple[bytes, bytes, bool]]:
    """``(type, data, crc_ok)`` of every chunk of a PNG, ``source`` its bytes or its path, in file order."""
    raw = source if isinstance(source, bytes) else open(source, "rb").read()
    assert raw[:8] == SIGNATURE
    chunks, at = [], 8
    while at < len(raw):
        (length,) = struct.unpack(">I", raw[at:at + 4])
        kind, data = raw[at + 4:at + 8], raw[at + 8:at + 8 + length]
        (crc,) = struct.unpack(">I", raw[at + 8 + length:at + 12 + length])
        chunks.append((kind, data, zlib.crc32(kind + data) == crc))  # the CRC covers type and data
        at += 12 + length
    return chunks


def _paeth(a: int, b: int, c: int) -> int:
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def decode_pixels(chunks) -> np.ndarray:
    """``(H, W, C)`` uint8 samples of the IDAT data, unfiltered row by row (filter types 0 to 4)."""
    header = next(data for kind, data, _ in chunks if kind == b"IHDR")
    width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", header)
    assert depth == 8 and colour in (2, 6) and interlace == 0, "only 8-bit RGB(A), not interlaced"
    channels = 3 if colour == 2 else 4
    stream = zlib.decompress(b"".join(data for kind, data, _ in chunks if kind == b"IDAT"))
    stride = width * channels
    assert len(stream) == height * (stride + 1)
    rows, previous = [], bytearray(stride)
    for y in range(height):
        kind, line = stream[y * (stride + 1)], bytearray(stream[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b, c = previous[i], previous[i - channels] if i >= channels else 0
            predictor = (0, a, b, (a + b) // 2, _paeth(a, b, c))[kind]
            line[i] = (line[i] + predictor) & 0xFF
        rows.append(bytes(line))
        previous = line
    return np.frombuffer(b"".join(rows), np.uint8).reshape(height, width, channels)


def srgb_chunks_problems(chunks) -> list[str]:
    """What keeps ``chunks`` from being an sRGB-tagged PNG as the PNG specification (11.3.3.5) asks: an sRGB chunk of
    one byte, perceptual intent, with the gAMA and cHRM values it prescribes for decoders that ignore sRGB, all
    before the image data, every CRC right. Empty when there is nothing."""
    problems = [f"{kind!r}: bad CRC" for kind, _, ok in chunks if not ok]
    kinds = [kind for kind, _, _ in chunks]
    expected = {
        b"sRGB": bytes([0]),  # rendering intent 0: perceptual
        b"gAMA": struct.pack(">I", 45455),  # 1 / 2.2 in units of 1e-5
        b"cHRM": struct.pack(">8I", 31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000),  # D65, Rec.709
    }
    for kind, data in expected.items():
        if kinds.count(kind) != 1:
            problems.append(f"{kind!r} appears {kinds.count(kind)} times")
            continue
        if dict((k, d) for k, d, _ in chunks)[kind] != data:
            problems.append(f"{kind!r} holds other values")
        if kinds.index(kind) > kinds.index(b"IDAT"):
            problems.append(f"{kind!r} comes after the image data")
    return problems


def chunk(kind: bytes, data: bytes) -> bytes:
    """One PNG chunk: length, type, data and the CRC of type and data (PNG specification, clause 5.3)."""
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def rgb_png(samples: np.ndarray, transparent=None) -> bytes:
    """An RGB PNG (colour type 2) of ``(H, W, 3)`` samples, 8-bit for uint8 and 16-bit for uint16, unfiltered and not
    interlaced; ``transparent``: the RGB of a tRNS chunk (three 16-bit values, the colour key), or None."""
    samples = np.asarray(samples)
    h, w, _ = samples.shape
    depth = 16 if samples.dtype == np.uint16 else 8
    rows = samples.astype(">u2" if depth == 16 else np.uint8).reshape(h, -1).view(np.uint8)
    stream = b"".join(b"\0" + row.tobytes() for row in rows)  # filter type 0 before every row
    data = SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, 2, 0, 0, 0))
    if transparent is not None:
        data += chunk(b"tRNS", struct.pack(">3H", *transparent))
    return data + chunk(b"IDAT", zlib.compress(stream)) + chunk(b"IEND", b"")


def pixel_aspect_ratio(chunks) -> float | None:
    """The width / height of a pixel that the pHYs chunk of ``chunks`` gives (PNG specification 11.3.5.3: pixels
    per unit along x, along y, then the unit; one pixel is ``1 / x`` wide and ``1 / y`` tall), None without one. It
    must come once, before the image data, of unit 0 (the aspect alone: a unit of metres would give a print size)."""
    kinds = [kind for kind, _, _ in chunks]
    if b"pHYs" not in kinds:
        return None
    ((data, crc_ok),) = [(data, ok) for kind, data, ok in chunks if kind == b"pHYs"]
    assert crc_ok and len(data) == 9 and data[8] == 0 and kinds.index(b"pHYs") < kinds.index(b"IDAT")
    x, y = struct.unpack(">II", data[:8])
    return y / x
