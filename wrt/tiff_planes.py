"""One plane of a TIFF stored plane by plane (``PlanarConfiguration`` 2) as a TIFF file of its own, a one-sample grey
image, so that Pillow decodes a 16-bit colour TIFF's planes at full depth: its libtiff decoder unpacks each separate
plane to 8 bits (it picks the band unpackers itself, whatever raw mode it is given), so such a texture kept the high
byte of each sample. Every 8- or 16-bit grey or RGB TIFF stored plane by plane is read so: Pillow decoded a grey + alpha
one's alpha plane into no band, opened no 16-bit one, and knew no raw mode for uncompressed 8-bit RGB of premultiplied
alpha, or of more samples past it. The plane's file is the original's bytes with a new image file directory appended and
the header pointed at it (TIFF 6.0: an 8-byte header, 12-byte entries of tag, type, count and value or offset; BigTIFF:
16 and 20 bytes): its strips or tiles (compressed or not, with any predictor, which works on each plane alone) are those
of the plane, its other tags the original's; the tags of every sample are made those of one."""

from __future__ import annotations

import struct

from .tiff_checks import (
    BITS_PER_SAMPLE,
    BLACK_IS_ZERO,
    EXTRA_SAMPLES,
    PHOTOMETRIC,
    PLANAR_CONFIGURATION,
    SAMPLE_FORMAT,
    SAMPLES_PER_PIXEL,
    SHORT,
    TIFF_MAGIC,
)

LONG, LONG8 = 4, 16  # TIFF field types of unsigned 32- and 64-bit values (LONG8: BigTIFF)
TYPE_BYTES = {SHORT: 2, LONG: 4, LONG8: 8}  # bytes of the types an offset or byte count is stored in
# Tags whose values locate the image's data, one per strip or tile of each plane: (offsets, byte counts)
STRIP_TAGS, TILE_TAGS = (273, 279), (324, 325)
# Tags of several samples (MinSampleValue, MaxSampleValue, ExtraSamples, SMin/SMaxSampleValue) or of colour alone
# (ColorMap, TransferFunction, YCbCr and ReferenceBlackWhite), left out of a grey plane's directory
PER_SAMPLE_TAGS = {280, 281, EXTRA_SAMPLES, 340, 341, 320, 301, 529, 530, 531, 532}


def tiff_plane(data: bytes, plane: int) -> bytes | None:
    """The TIFF (or BigTIFF) file ``data``, whose first image is stored plane by plane, with plane ``plane`` (0 for
    its first sample) as that first image, a one-sample grey image of the same size, bits, sample format,
    compression and predictor; None where ``data`` is no such TIFF or its directory is cut short."""
    layout = TIFF_MAGIC.get(data[:4])
    if layout is None:
        return None
    order, offset, counter, inline = layout
    entry = struct.Struct(f"{order}HH{offset}{inline}s")  # tag, type, count, value or offset
    try:
        (directory,) = struct.unpack_from(order + offset, data, 4 if offset == "I" else 8)
        (count,) = struct.unpack_from(order + counter, data, directory)
        first = directory + struct.calcsize(order + counter)
        entries = {}
        for k in range(count):
            tag, kind, n, field = entry.unpack_from(data, first + entry.size * k)
            entries[tag] = (kind, n, field)
        samples = _first_value(data, order, offset, inline, entries.get(SAMPLES_PER_PIXEL), 1)
        planar = _first_value(data, order, offset, inline, entries.get(PLANAR_CONFIGURATION), 1)
        located = TILE_TAGS if TILE_TAGS[0] in entries else STRIP_TAGS
        starts, sizes = (_values(data, order, offset, inline, entries.get(tag)) for tag in located)
        bits = _first_value(data, order, offset, inline, entries.get(BITS_PER_SAMPLE), 1)
        sample_format = _first_value(data, order, offset, inline, entries.get(SAMPLE_FORMAT), 1)
    except struct.error:
        return None
    # (no byte counts: a plane's directory has none either, and they are inferred from the plane's size as
    # libtiff and Pillow infer them from a file's)
    if planar != 2 or not 0 <= plane < samples or len(sizes) not in (0, len(starts)) or len(starts) % samples:
        return None
    per_plane = len(starts) // samples
    wide = offset == "Q"  # BigTIFF: offsets and counts as LONG8
    value_type, value_code = (LONG8, "Q") if wide else (LONG, "I")
    tail = bytearray(data)
    tail += bytes(-len(tail) % 8)  # the arrays and directory start on a word boundary

    def value_field(kind: int, code: str, values: list[int]) -> tuple[int, int, bytes]:
        """``(type, count, field)`` of ``values``: in the field where they fit, else appended to ``tail``."""
        packed = struct.pack(order + code * len(values), *values)
        if len(packed) > inline:
            at = len(tail)
            tail.extend(packed + bytes(-len(packed) % 8))
            packed = struct.pack(order + offset, at)
        return kind, len(values), packed.ljust(inline, b"\0")

    new = {tag: value for tag, value in entries.items() if tag not in PER_SAMPLE_TAGS}
    for tag, value in ((BITS_PER_SAMPLE, bits), (SAMPLES_PER_PIXEL, 1), (PHOTOMETRIC, BLACK_IS_ZERO),
                       (PLANAR_CONFIGURATION, 1)):
        new[tag] = value_field(SHORT, "H", [value])
    if SAMPLE_FORMAT in entries:
        new[SAMPLE_FORMAT] = value_field(SHORT, "H", [sample_format])
    part = slice(plane * per_plane, (plane + 1) * per_plane)
    new[located[0]] = value_field(value_type, value_code, starts[part])
    if sizes:
        new[located[1]] = value_field(value_type, value_code, sizes[part])
    else:
        new.pop(located[1], None)
    at = len(tail)
    tail += struct.pack(order + counter, len(new))
    for tag in sorted(new):  # TIFF 6.0: entries in ascending order of tag
        tail += entry.pack(tag, *new[tag])
    tail += struct.pack(order + offset, 0)  # no next image
    struct.pack_into(order + offset, tail, 4 if offset == "I" else 8, at)
    return bytes(tail)


def _values(data: bytes, order: str, offset: str, inline: int, found) -> list[int]:
    """The unsigned values of a directory entry ``found`` (``(type, count, field)``, SHORT, LONG or LONG8); none
    for a missing entry or another type."""
    if found is None or found[0] not in TYPE_BYTES:
        return []
    kind, n, field = found
    code = {SHORT: "H", LONG: "I", LONG8: "Q"}[kind]
    source, at = (field, 0) if n * TYPE_BYTES[kind] <= inline else (data, struct.unpack(order + offset, field)[0])
    return list(struct.unpack_from(f"{order}{n}{code}", source, at))


def _first_value(data: bytes, order: str, offset: str, inline: int, found, default: int) -> int:
    """The first of :func:`_values` of ``found``, ``default`` where it has none (an unset tag's TIFF default)."""
    values = _values(data, order, offset, inline, found)
    return values[0] if values else default
