"""Radiance ``.hdr`` (RGBE) images read into ``(H, W, 4)`` float32 linear RGBA: the format most HDRI domes ship in
(Poly Haven, sIBL sets, Omniverse and Blender exports), which Pillow cannot read. Numpy only.

The format, from its public description (G. Ward, "Real Pixels", Graphics Gems II, 1991; the Radiance reference
manual's "Radiance File Formats"):

- A text header: a first line ``#?RADIANCE`` (``#?RGBE``, or ``#?`` and another program's name), then variables
  ``NAME=value`` and comments, ended by an empty line. ``FORMAT`` is ``32-bit_rle_rgbe`` (the default) or
  ``32-bit_rle_xyze``; ``EXPOSURE=e`` and ``COLORCORR=r g b`` are multipliers already applied to the pixels,
  cumulative over repeated lines. ``PRIMARIES``, ``GAMMA``, ``PIXASPECT``, ``VIEW`` and the others are ignored.
- A resolution line of two axes, the slow (scanline) one first: ``-Y H +X W`` is the standard order, scanlines from
  the top down, each from left to right. ``+Y`` runs bottom up, ``-X`` right to left, and ``+X W -Y H`` etc. store
  columns as scanlines; all eight orders are flipped or transposed here to row 0 at the top.
- Scanlines of 4-byte pixels, mantissas R, G, B and a shared exponent E, each scanline stored flat; in the old
  run-length form (a pixel ``(1, 1, 1, n)`` repeats the pixel before it ``n << s`` times, ``s`` growing by 8 over
  consecutive such pixels); or, for scanlines of 8 to 32767 pixels, in the adaptive form: bytes ``2, 2, L >> 8,
  L & 255``, then each of the four components in turn as packets, a byte ``c > 128`` and one byte repeated
  ``c - 128`` times, or a byte ``c <= 128`` and ``c`` bytes as they are.

Choices:

- A component is ``m / 256 * 2^(E - 128)``, and 0 where ``E = 0``, as Walter's ``rgbe.c``, stb_image (Hydra's
  reader) and OpenImageIO decode it: a component stored as 0 stays 0, so a pure red sun stays red. Radiance itself
  adds half a step, ``(m + 0.5) / 256 * 2^(E - 128)``; the two differ by at most 1/256 of a pixel's brightest
  component.
- ``EXPOSURE`` and ``COLORCORR`` are divided out, as Radiance defines them, so the image holds the radiance before
  they were applied (``pfilt -e 2`` doubles the pixels and writes ``EXPOSURE=2``). Readers that ignore them
  (stb_image) show such a file brighter or darker by that factor.
- XYZE pixels are converted to linear Rec.709 RGB with the equal-energy white Radiance's colours use, so XYZ
  ``(1, 1, 1)`` reads as RGB ``(1, 1, 1)``. RGB pixels keep their values whatever ``PRIMARIES`` says (no gamut
  conversion, as for EXR). Alpha is 1.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from .textures import TextureError

MAGIC = b"#?"  # every Radiance file's first line starts with it
SUFFIXES = (".hdr", ".pic", ".rgbe")  # file names read as Radiance images whatever their first bytes
RLE_MIN_LENGTH = 8  # shortest scanline that may use the adaptive run-length form
RLE_MAX_LENGTH = 0x7FFF  # longest: its length must fit in 15 bits
MAX_PIXELS = 2**31  # larger images cannot be packed into the device's texel array (pack_images)
CHUNK_BYTES = 1 << 21  # RGBE bytes decoded and converted to float at a time (bounds the float temporaries)
RESOLUTION = re.compile(rb"([-+])([XY]) +(\d+) +([-+])([XY]) +(\d+)")
EXPONENT_SCALE = np.where(np.arange(256) > 0, np.ldexp(1.0, np.arange(256) - 136), 0.0).astype(np.float32)  # by E
REC709_XY = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06))  # chromaticities of the Rec.709 / sRGB primaries


@dataclass
class RadianceHeader:
    """What the header and resolution line say about the pixel data."""

    xyz: bool  # FORMAT=32-bit_rle_xyze
    scale: np.ndarray  # (3,) float32: 1 / (EXPOSURE * COLORCORR) per component
    height: int  # image rows
    width: int  # image columns
    y_major: bool  # scanlines are rows (else columns)
    flip_scanlines: bool  # scanlines run bottom up (rows) or right to left (columns)
    flip_pixels: bool  # pixels within a scanline run right to left (rows) or bottom up (columns)
    offset: int  # first byte of the pixel data

    @property
    def scanlines(self) -> int:
        return self.height if self.y_major else self.width

    @property
    def length(self) -> int:
        """Pixels per scanline."""
        return self.width if self.y_major else self.height


def is_radiance(data: bytes, name: str) -> bool:
    """Whether ``data`` (the file ``name``) is read as a Radiance image: by its first line or its name."""
    return data[:2] == MAGIC or name.lower().endswith(SUFFIXES)


def read_radiance(data: bytes, name: str) -> np.ndarray:
    """``(H, W, 4)`` float32 linear RGBA of a Radiance image's bytes (see the module docstring).

    Scanlines are decoded a chunk at a time into component planes, then converted to float into their rows or
    columns of the image, so the only image-sized arrays are ``data`` and the result. The time goes mostly to a
    Python walk over the run-length packet headers (:func:`_find_packets`): an 8k x 4k photograph has about 1.4
    million of them (about 3 s in all, flat files 1 s), a file of short runs and literals up to 50 million (20 s).

    Raises:
        TextureError: naming ``name`` and what is wrong (header, resolution line, or the scanline where the data
            is short or a run passes the end of the line).
    """
    header = parse_header(data, name)
    try:
        rgba = np.empty((header.height, header.width, 4), np.float32)
    except MemoryError:
        gb = header.height * header.width * 16 / 2**30
        raise TextureError(f"{_subject(name)}: {header.width} x {header.height} needs {gb:.1f} GB") from None
    # Scanline i lands in ``target[i]``: a row or column of the image, flipped as the resolution line says.
    target = rgba if header.y_major else rgba.transpose(1, 0, 2)
    if header.flip_scanlines:
        target = target[::-1]
    if header.flip_pixels:
        target = target[:, ::-1]
    pixels = np.frombuffer(data, np.uint8)
    count, length = header.scanlines, header.length
    rows = max(1, CHUNK_BYTES // (4 * length))
    planes = np.empty((min(rows, count), 4, length), np.uint8)  # a chunk of scanlines, R, G, B, E planes each
    adaptive = RLE_MIN_LENGTH <= length <= RLE_MAX_LENGTH  # other lengths are always flat or old run-length
    at = header.offset
    for first in range(0, count, rows):
        n, chunk_start = min(rows, count - first), at
        packed, heads, skipped = [], [], []  # adaptive lines, their packets' headers, bytes that are not packets
        for i in range(n):
            where = (name, first + i, count)
            if adaptive and data[at : at + 2] == b"\x02\x02" and len(data) > at + 3 and data[at + 2] < 128:
                stored = data[at + 2] << 8 | data[at + 3]
                if stored != length:
                    _fail(where, f"its run-length header gives {stored} pixels, the resolution line {length}")
                skipped.append((at, at + 4))
                at = _find_packets(data, at + 4, length, heads, where)
                packed.append(i)
            else:
                line_start, at = at, _read_old_rle(pixels, at, planes[i], where)
                skipped.append((line_start, at))
        if packed:
            planes[packed] = _expand_packets(pixels, chunk_start, at, heads, skipped).reshape(-1, 4, length)
        _to_float(planes[:n], header, target[first : first + n])
    return rgba


def parse_header(data: bytes, name: str) -> RadianceHeader:
    """The header and resolution line of a Radiance image's bytes.

    Raises:
        TextureError: not a Radiance file, no end of header, an unknown ``FORMAT``, an ``EXPOSURE`` or
            ``COLORCORR`` that is not a positive number, or a resolution line that is not two axes and sizes.
    """
    subject = _subject(name)
    if data[:2] != MAGIC:
        raise TextureError(f"{subject}: not a Radiance HDR file (it does not start with a #?RADIANCE line)")
    end = data.find(b"\n\n")
    if end < 0:
        raise TextureError(f"{subject}: the header does not end (no empty line before the resolution line)")
    xyz, scale = False, np.ones(3, np.float64)
    for line in data[:end].decode("latin-1").split("\n")[1:]:
        key, _, value = line.partition("=")
        if key == "FORMAT":
            if value.strip() not in ("32-bit_rle_rgbe", "32-bit_rle_xyze"):
                raise TextureError(f"{subject}: FORMAT={value.strip()} is neither 32-bit_rle_rgbe nor 32-bit_rle_xyze")
            xyz = value.strip() == "32-bit_rle_xyze"
        elif key in ("EXPOSURE", "COLORCORR"):
            scale /= _multipliers(key, value, 1 if key == "EXPOSURE" else 3, subject)
    line_end = data.find(b"\n", end + 2)
    match = RESOLUTION.fullmatch(data[end + 2 : line_end].strip()) if line_end >= 0 else None
    if match is None or match[2] == match[5]:
        shown = data[end + 2 : end + 2 + 40].split(b"\n")[0].decode("latin-1")
        raise TextureError(f"{subject}: resolution line {shown!r} is not like '-Y 512 +X 1024'")
    sign1, axis1, size1, sign2, axis2, size2 = (g.decode() for g in match.groups())
    y_major = axis1 == "Y"
    height, width = (int(size1), int(size2)) if y_major else (int(size2), int(size1))
    if not 0 < height * width <= MAX_PIXELS:
        raise TextureError(f"{subject}: size {width} x {height} is empty or larger than 2^31 pixels")
    # Radiance's Y points up: "-Y" scans rows top down, "+Y" bottom up; "+X" scans left to right.
    flips = [(sign == "+") == (axis == "Y") for sign, axis in ((sign1, axis1), (sign2, axis2))]
    return RadianceHeader(xyz, scale.astype(np.float32), height, width, y_major, flips[0], flips[1], line_end + 1)


def _multipliers(key: str, value: str, n: int, subject: str) -> np.ndarray:
    """The ``n`` positive numbers of an ``EXPOSURE`` or ``COLORCORR`` line."""
    try:
        numbers = np.array([float(v) for v in value.split()], np.float64)
    except ValueError:
        numbers = np.array([])
    if len(numbers) != n or not np.all(np.isfinite(numbers) & (numbers > 0)):
        raise TextureError(f"{subject}: {key}={value.strip()} is not {n} positive number{'s' if n > 1 else ''}")
    return numbers


def xyz_to_rec709() -> np.ndarray:
    """``(3, 3)`` matrix from CIE XYZ to linear RGB of the Rec.709 primaries, white at equal energy (XYZ = 1)."""
    primaries = np.array([[x / y, 1.0, (1.0 - x - y) / y] for x, y in REC709_XY]).T  # columns: XYZ of R, G, B
    rgb_to_xyz = primaries * np.linalg.solve(primaries, np.ones(3))  # each primary scaled so R + G + B = white
    return np.linalg.inv(rgb_to_xyz)


def _to_float(planes: np.ndarray, header: RadianceHeader, out: np.ndarray):
    """Writes the linear RGBA of ``(N, 4, L)`` uint8 RGBE planes into ``out`` (``(N, L, 4)`` float32).

    Called chunk by chunk, so that a header promising more pixels than the file holds fails before the image's
    memory (reserved, not yet touched) is written."""
    out[..., 3] = 1.0
    scale = EXPONENT_SCALE[planes[:, 3]]
    if header.xyz:
        matrix = xyz_to_rec709() * header.scale[None, :]
        out[..., :3] = (planes[:, :3].transpose(0, 2, 1) * scale[..., None]) @ matrix.T.astype(np.float32)
        return
    for c in range(3):
        np.multiply(planes[:, c], scale, out=out[..., c])
        if header.scale[c] != 1.0:
            out[..., c] *= header.scale[c]


def _find_packets(data: bytes, at: int, length: int, heads: list, where) -> int:
    """Appends to ``heads`` the byte offsets of the packet headers of one adaptive run-length scanline of
    ``length`` pixels whose first packet is at byte ``at``, the four components one after the other, and returns
    the byte after the scanline. Each header says where the next one is, so this is a walk in Python."""
    append = heads.append
    for component in "RGBE":
        filled = 0
        try:
            while filled < length:
                code = data[at]
                append(at)
                if code > 128:
                    filled += code - 128
                    at += 2
                else:
                    filled += code
                    at += code + 1
        except IndexError:
            _fail(where, "the file ends inside it")
        if filled > length:
            _fail(where, f"a run of component {component} passes the end of the line ({length} pixels)")
    if at > len(data):
        _fail(where, "the file ends inside it")
    return at


def _expand_packets(pixels: np.ndarray, start: int, stop: int, heads: list, skipped: list) -> np.ndarray:
    """The bytes that the packets in ``pixels[start:stop]`` with headers at ``heads`` decode to, one after the
    other (a header ``c > 128`` repeats the byte after it ``c - 128`` times, ``c <= 128`` takes the ``c`` bytes
    after it), leaving out the byte ranges ``skipped`` (``(first, end)`` pairs). Offsets are into ``pixels``."""
    stream = pixels[start:stop]
    repeats = np.ones(len(stream), np.intp)  # how often each byte of the stream is output
    for first, end in skipped:
        repeats[first - start : end - start] = 0
    heads = np.array(heads, np.intp) - start
    codes = stream[heads]
    repeats[heads] = 0
    runs = codes > 128
    repeats[heads[runs] + 1] = codes[runs] - 128
    return np.repeat(stream, repeats)


def _read_old_rle(pixels: np.ndarray, at: int, planes: np.ndarray, where) -> int:
    """Decodes one flat or old-style run-length scanline starting at byte ``at`` into ``planes`` (``(4, L)``
    uint8) and returns the byte after it. Whole stretches between run markers are copied at once."""
    out = planes.T  # (L, 4): pixel by pixel
    length, filled, shift = len(out), 0, 0
    while filled < length:
        # At least the rest of the line, unless markers of 0 pixels (a count's low byte) hold it back.
        window = pixels[at : at + 4 * (length - filled)]
        window = window[: len(window) // 4 * 4].reshape(-1, 4)
        if not len(window):
            _fail(where, "the file ends inside it")
        markers = np.flatnonzero((window[:, 0] == 1) & (window[:, 1] == 1) & (window[:, 2] == 1))
        used = 0  # pixels of the window read
        for marker in list(markers) + [len(window)]:
            take = min(marker - used, length - filled)
            out[filled : filled + take] = window[used : used + take]
            filled, used = filled + take, used + take
            if take:
                shift = 0
            if filled == length or marker == len(window):
                break
            if not filled:
                _fail(where, "it starts with a run-length marker (1, 1, 1, n), which has no pixel to repeat")
            run = int(window[marker, 3]) << shift
            if filled + run > length:
                _fail(where, f"a run of {run} pixels passes the end of the line ({length} pixels)")
            out[filled : filled + run] = out[filled - 1]
            filled, used, shift = filled + run, used + 1, shift + 8
        at += 4 * used
    return at


def _subject(name: str) -> str:
    return f"cannot read Radiance HDR {name}"


def _fail(where, what: str):
    name, line, count = where
    raise TextureError(f"{_subject(name)}: scanline {line + 1} of {count}: {what}")
