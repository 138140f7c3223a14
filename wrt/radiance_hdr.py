"""Radiance ``.hdr`` (RGBE) images read into ``(H, W, 4)`` float32 linear RGBA: the format most HDRI domes ship in
(Poly Haven, sIBL sets, Omniverse and Blender exports), which Pillow cannot read. Numpy, and one Warp kernel
on the CPU for the run-length packets.

The format, from its public description (G. Ward, "Real Pixels", Graphics Gems II, 1991; the Radiance reference
manual's "Radiance File Formats"):

- A text header: a first line ``#?RADIANCE`` (``#?RGBE``, or ``#?`` and another program's name), then variables
  ``NAME=value`` and comments, ended by an empty line (lines may end with ``\\r\\n``, as Windows tools write
  them). ``FORMAT`` is ``32-bit_rle_rgbe`` (the default) or ``32-bit_rle_xyze``; ``EXPOSURE=e`` and
  ``COLORCORR=r g b`` are multipliers already applied to the pixels, cumulative over repeated lines.
  ``PRIMARIES``, ``GAMMA``, ``PIXASPECT``, ``VIEW`` and the others are ignored.
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
- The brightest exponent byte, 255, is a number like the others: up to ``255 / 256 * 2^127`` (1.7e38), which
  float32 holds. An ``EXPOSURE`` or ``COLORCORR`` below 1, or the XYZ to RGB conversion, can take such a
  component past float32's range: it is clamped to float32's largest value (3.4e38), with a warning naming the
  file and how many components, rather than made inf (which a light reads as 0: a black sun) or NaN.
- ``EXPOSURE`` and ``COLORCORR`` are divided out, as Radiance defines them, so the image holds the radiance before
  they were applied (``pfilt -e 2`` doubles the pixels and writes ``EXPOSURE=2``). Readers that ignore them
  (stb_image) show such a file brighter or darker by that factor.
- XYZE pixels are converted to linear Rec.709 RGB with the equal-energy white Radiance's colours use, so XYZ
  ``(1, 1, 1)`` reads as RGB ``(1, 1, 1)``. RGB pixels keep their values whatever ``PRIMARIES`` says (no gamut
  conversion, as for EXR). Alpha is 1.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass

import numpy as np
import warp as wp

from .textures import TextureError

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile

MAGIC = b"#?"  # every Radiance file's first line starts with it
SUFFIXES = (".hdr", ".pic", ".rgbe")  # file names read as Radiance images whatever their first bytes
RLE_MIN_LENGTH = 8  # shortest scanline that may use the adaptive run-length form
RLE_MAX_LENGTH = 0x7FFF  # longest: its length must fit in 15 bits
MAX_PIXELS = 2**31  # larger images cannot be packed into the device's texel array (pack_images)
CHUNK_BYTES = 1 << 21  # RGBE bytes decoded and converted to float at a time (bounds the float temporaries)
RESOLUTION = re.compile(rb"([-+])([XY]) +(\d+) +([-+])([XY]) +(\d+)")
EXPONENT_SCALE = np.where(np.arange(256) > 0, np.ldexp(1.0, np.arange(256) - 136), 0.0).astype(np.float32)  # by E
REC709_XY = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06))  # chromaticities of the Rec.709 / sRGB primaries
HEADER_END = re.compile(rb"\n\r?\n")  # the empty line after the header; Windows tools end lines with \r\n
FLOAT32_MAX = float(np.finfo(np.float32).max)  # a component past it is clamped to it (see the module docstring)
MAX_WINDOW = 2**31 - 1  # bytes one decode_adaptive_scanlines_kernel launch reads (int32 offsets)

# Faults decode_adaptive_scanlines_kernel reports, status[2]
LENGTH_DIFFERS = wp.constant(1)  # a scanline's run-length header gives another length (status[3])
FILE_ENDS = wp.constant(2)  # the data ends inside a scanline
RUN_PASSES_END = wp.constant(3)  # a packet of component status[3] passes the end of the line


@wp.kernel
def decode_adaptive_scanlines_kernel(data: wp.array(dtype=wp.uint8), count: int, length: int,
                                     # outputs
                                     planes: wp.array3d(dtype=wp.uint8), status: wp.array(dtype=int)):
    """Decodes up to ``count`` consecutive adaptive run-length scanlines of ``length`` pixels from the start of
    ``data`` into ``planes[line, component]``, in one thread: each packet header says where the next one is, so
    the walk is sequential (in Python it took 20 s for a file of 50 million short packets). Stops at the first
    scanline that does not start with an adaptive header (the caller reads it flat or old-style) or at a fault.
    ``status``: scanlines decoded, the byte after them, the fault (0: none) and its detail."""
    size = data.shape[0]
    at = int(0)
    line = int(0)
    fault = int(0)
    detail = int(0)
    while line < count and fault == 0:
        if at + 3 >= size:
            break
        if int(data[at]) != 2 or int(data[at + 1]) != 2 or int(data[at + 2]) >= 128:
            break
        stored = int(data[at + 2]) * 256 + int(data[at + 3])
        if stored != length:
            fault = LENGTH_DIFFERS
            detail = stored
            break
        at += 4
        component = int(0)
        while component < 4 and fault == 0:
            filled = int(0)
            while filled < length and fault == 0:
                if at >= size:
                    fault = FILE_ENDS
                    break
                code = int(data[at])
                run = code > 128
                n = code
                if run:
                    n = code - 128
                if filled + n > length:
                    fault = RUN_PASSES_END
                    detail = component
                elif run:
                    if at + 1 >= size:
                        fault = FILE_ENDS
                    else:
                        value = data[at + 1]
                        for k in range(n):
                            planes[line, component, filled + k] = value
                        at += 2
                elif at + n >= size:
                    fault = FILE_ENDS
                else:
                    for k in range(n):
                        planes[line, component, filled + k] = data[at + 1 + k]
                    at += n + 1
                filled += n
            component += 1
        if fault == 0:
            line += 1
    status[0] = line
    status[1] = at
    status[2] = fault
    status[3] = detail


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
    columns of the image, so the only image-sized arrays are ``data`` and the result. Adaptive run-length
    scanlines are decoded by a sequential Warp kernel on the CPU (:func:`decode_adaptive_scanlines_kernel`): a
    2048 x 4096 file of one packet per pixel and component (33 million) reads in 0.7 s, 12 s in a Python walk.

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
    clamped = 0  # components past float32's range, clamped to its largest value
    for first in range(0, count, rows):
        n, i = min(rows, count - first), 0
        while i < n:
            if adaptive:  # this scanline and those after it that are adaptive run-length ones
                done, at = _decode_adaptive(pixels, at, planes[i:n], (name, first + i, count))
                i += done
            if i < n:
                at = _read_old_rle(pixels, at, planes[i], (name, first + i, count))
                i += 1
        clamped += _to_float(planes[:n], header, target[first : first + n])
    if clamped:
        warnings.warn(f"Radiance HDR {name}: {clamped} pixel component{'s' if clamped > 1 else ''} past float32's "
                      f"range (3.4e38, after EXPOSURE, COLORCORR or the XYZ conversion) clamped to it", stacklevel=3)
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
    found = HEADER_END.search(data)
    if found is None:
        raise TextureError(f"{subject}: the header does not end (no empty line before the resolution line)")
    end, start = found.start(), found.end()  # the header's last line break; the resolution line
    xyz, scale = False, np.ones(3, np.float64)
    for line in data[:end].decode("latin-1").split("\n")[1:]:
        key, _, value = line.partition("=")
        if key == "FORMAT":
            if value.strip() not in ("32-bit_rle_rgbe", "32-bit_rle_xyze"):
                raise TextureError(f"{subject}: FORMAT={value.strip()} is neither 32-bit_rle_rgbe nor 32-bit_rle_xyze")
            xyz = value.strip() == "32-bit_rle_xyze"
        elif key in ("EXPOSURE", "COLORCORR"):
            scale /= _multipliers(key, value, 1 if key == "EXPOSURE" else 3, subject)
    line_end = data.find(b"\n", start)
    match = RESOLUTION.fullmatch(data[start:line_end].strip()) if line_end >= 0 else None
    if match is None or match[2] == match[5]:
        shown = data[start : start + 40].split(b"\n")[0].strip().decode("latin-1")
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


def _to_float(planes: np.ndarray, header: RadianceHeader, out: np.ndarray) -> int:
    """Writes the linear RGBA of ``(N, 4, L)`` uint8 RGBE planes into ``out`` (``(N, L, 4)`` float32); returns how
    many components passed float32's range and were clamped to it.

    Called chunk by chunk, so that a header promising more pixels than the file holds fails before the image's
    memory (reserved, not yet touched) is written."""
    out[..., 3] = 1.0
    if header.xyz:
        # In float64: a bright X, Y and Z overflow float32 in the matrix product, to inf or to inf - inf = NaN.
        scale = np.ldexp(1.0, planes[:, 3].astype(np.int64) - 136) * (planes[:, 3] > 0)
        matrix = xyz_to_rec709() * header.scale[None, :].astype(np.float64)
        rgb = (planes[:, :3].transpose(0, 2, 1) * scale[..., None]) @ matrix.T
        past = np.abs(rgb) > FLOAT32_MAX
        out[..., :3] = np.clip(rgb, -FLOAT32_MAX, FLOAT32_MAX)
        return int(past.sum())
    scale = EXPONENT_SCALE[planes[:, 3]]
    for c in range(3):
        np.multiply(planes[:, c], scale, out=out[..., c])
        if header.scale[c] != 1.0:
            with np.errstate(over="ignore"):
                out[..., c] *= header.scale[c]
    if header.scale.max() <= 1.0:  # every component is at most 255 / 256 * 2^127
        return 0
    past = np.isinf(out[..., :3])
    out[..., :3][past] = FLOAT32_MAX
    return int(past.sum())


def _decode_adaptive(pixels: np.ndarray, at: int, planes: np.ndarray, where) -> tuple[int, int]:
    """Decodes the adaptive run-length scanlines that start at byte ``at`` of ``pixels``, at most one per row of
    ``planes`` (``(N, 4, L)`` uint8), with :func:`decode_adaptive_scanlines_kernel` on the CPU; returns how many
    there were and the byte after them. ``where``: (file name, index of the first one, scanlines in all)."""
    window = pixels[at : at + MAX_WINDOW]
    status = wp.zeros(4, dtype=int, device="cpu")
    wp.launch(decode_adaptive_scanlines_kernel, dim=1, device="cpu",
              inputs=[wp.array(window, dtype=wp.uint8, device="cpu", copy=False), len(planes), planes.shape[2]],
              outputs=[wp.array(planes, dtype=wp.uint8, device="cpu", copy=False), status])
    done, end, fault, detail = (int(v) for v in status.numpy())
    name, line, count = where
    where = (name, line + done, count)
    if fault == LENGTH_DIFFERS:
        _fail(where, f"its run-length header gives {detail} pixels, the resolution line {planes.shape[2]}")
    if fault == FILE_ENDS:
        _fail(where, "the file ends inside it")
    if fault == RUN_PASSES_END:
        _fail(where, f"a run of component {'RGBE'[detail]} passes the end of the line ({planes.shape[2]} pixels)")
    return done, at + end


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
