"""One plane of a TIFF stored plane by plane (``PlanarConfiguration`` 2) as a TIFF file of its own, a one-sample grey
image, so that Pillow decodes a 16-bit colour TIFF's planes at full depth: its libtiff decoder unpacks each separate
plane to 8 bits (it picks the band unpackers itself, whatever raw mode it is given), so such a texture kept the high
byte of each sample. Every 8- or 16-bit grey or RGB TIFF stored plane by plane is read so: Pillow decoded a grey + alpha
one's alpha plane into no band, opened no 16-bit one, and knew no raw mode for uncompressed 8-bit RGB of premultiplied
alpha, or of more samples past it. The plane's file holds the original's directory, made that of one sample, with the
values it points at and the plane's strips or tiles (compressed or not, with any predictor, which works on each plane
alone) copied after it, nothing else of the original (TIFF 6.0: an 8-byte header, 12-byte entries of tag, type, count
and value or offset; BigTIFF: 16 and 20 bytes). It was the original's bytes with a directory appended: a copy of the
whole file per plane, and a strip cut short by the file's end read the appended directory as samples."""

from __future__ import annotations

import struct

from .tiff_checks import (
    BITS_PER_SAMPLE,
    BLACK_IS_ZERO,
    COMPRESSION,
    EXTRA_SAMPLES,
    IMAGE_LENGTH,
    IMAGE_WIDTH,
    LONG,
    LONG8,
    PHOTOMETRIC,
    PIXEL_TAGS,
    PLANAR_CONFIGURATION,
    SAMPLE_FORMAT,
    SAMPLES_PER_PIXEL,
    SHORT,
    STRIP_TAGS,
    TILE_TAGS,
    TYPE_BYTES,
    piece_grid,
    piece_problem,
    tags_past_end,
    tiff_directory,
)

NO_COMPRESSION, OLD_JPEG = 1, 6  # Compression values: none, and TIFF 6.0's old JPEG (whose tables lie at offsets)
# Tags of several samples (MinSampleValue, MaxSampleValue, ExtraSamples, SMin/SMaxSampleValue) or of colour alone
# (ColorMap, TransferFunction, YCbCr and ReferenceBlackWhite), left out of a grey plane's directory
PER_SAMPLE_TAGS = {280, 281, EXTRA_SAMPLES, 340, 341, 320, 301, 529, 530, 531, 532}
# Tags whose values are offsets of other parts of the file (FreeOffsets and FreeByteCounts, SubIFDs, old JPEG's
# JPEGInterchangeFormat(Length) and tables, the Exif, GPS and Interoperability directories), and field types of such
# offsets (IFD, IFD8): none is a plane's, and none is copied, so they are left out of its directory
OFFSET_TAGS = {288, 289, 330, 513, 514, 519, 520, 521, 34665, 34853, 40965}
OFFSET_TYPES = {13, 18}


class PlaneError(ValueError):
    """A TIFF stored plane by plane whose strips or tiles are not as its header says (cut short by the file's end,
    short of their rows, of no data, too few or too many, of no stated size where compressed) or whose samples differ
    in depth: the words say which."""


def tiff_plane(data: bytes, plane: int) -> bytes | None:
    """The TIFF (or BigTIFF) file ``data``, whose first image is stored plane by plane, with plane ``plane`` (0 for
    its first sample) as its one image, a one-sample grey image of the same size, bits, sample format, compression and
    predictor; None where ``data`` is no such TIFF or its directory is cut short.

    Raises:
        PlaneError: a strip or tile lies past the file's end (the last ones of a file cut off mid-way: they read
            the bytes after the file's end, the directory appended to it, as samples), holds no data or fewer bytes
            than its rows fill (:func:`wrt.tiff_checks.piece_problem`); there are not as many of them as the image's
            size makes (they were laid out over each other); a compressed one has no byte count (libtiff refuses
            it); the samples differ in depth (BitsPerSample: each plane was decoded as of the first's depth) or
            sample format; or the values of one of :data:`wrt.tiff_checks.PIXEL_TAGS` lie past the file's end.
    """
    directory = tiff_directory(data)
    if directory is None:
        return None
    entries = directory.entries
    located = TILE_TAGS if TILE_TAGS[0] in entries else STRIP_TAGS
    try:
        samples = directory.first(SAMPLES_PER_PIXEL, 1)
        planar = directory.first(PLANAR_CONFIGURATION, 1)
        starts, sizes = directory.values(located[0]), directory.values(located[1])
        bits = directory.values(BITS_PER_SAMPLE) or [1]
        sample_formats = directory.values(SAMPLE_FORMAT) or [1]
        width, height = directory.first(IMAGE_WIDTH, 0), directory.first(IMAGE_LENGTH, 0)
        compression = directory.first(COMPRESSION, NO_COMPRESSION)
        # (a tile's pixels across and rows, or a strip's, and how many the size makes a plane; 0 for an empty size)
        across, rows, made = piece_grid(directory, "tile" if located == TILE_TAGS else "strip") or (0, 0, 0)
    except struct.error:
        return None
    if planar != 2 or not 0 <= plane < samples or len(sizes) not in (0, len(starts)) or len(starts) % samples:
        return None
    for name, values, words in (("BitsPerSample", bits, "depth"), ("SampleFormat", sample_formats, "sample format")):
        if len(set(values[:samples])) > 1:  # (libtiff reads no such file either)
            raise PlaneError(f"its samples differ in {words} ({name} {', '.join(map(str, values))}), which wrt does "
                             "not read")
    problem = piece_problem(directory)
    if problem is not None:
        raise PlaneError(problem)
    damaged = [tag for tag in tags_past_end(directory) if tag in PIXEL_TAGS]
    if damaged:
        raise PlaneError(f"its TIFF tag {damaged[0]}'s values lie past the file's end: the file is damaged or cut "
                         "short")
    if compression == OLD_JPEG:
        raise PlaneError("its planes are of old-style JPEG compression (Compression 6), whose tables lie at offsets "
                         "wrt does not carry over to a plane")
    per_plane = len(starts) // samples
    if per_plane != made:
        kind = "tile" if located == TILE_TAGS else "strip"
        raise PlaneError(f"it has {len(starts)} {kind}s, where {samples} planes of {width} x {height} pixels in "
                         f"{kind}s of {across} x {rows} make {made} a plane")
    part = slice(plane * per_plane, (plane + 1) * per_plane)
    extents = _extents(per_plane, sizes[part], compression, located == TILE_TAGS, height, across, rows, bits[0])
    return _plane_file(directory, located, bits[0], sample_formats[0], starts[part], extents)


def _extents(pieces: int, sizes, compression: int, tiled: bool, height: int, across: int, rows: int,
             bits: int) -> list[int]:
    """Bytes of each of a plane's ``pieces`` strips or tiles (``tiled``; their byte counts ``sizes``, none where the
    file has none; ``across`` x ``rows`` pixels of ``bits`` each, of an image ``height`` rows high): uncompressed,
    those its pixels fill (TIFF 6.0: a tile is whole, padded past the image's edge; the last strip holds the rows
    left), as Pillow reads them whatever the count says and libtiff infers a missing count; compressed, the count.
    (Strips of no data, short of their rows or past the file's end: :func:`wrt.tiff_checks.piece_problem`.)"""
    if compression == NO_COMPRESSION:
        row_bytes = -(-across * bits // 8)  # (each row starts on a byte)
        return [(rows if tiled else min(rows, height - k * rows)) * row_bytes for k in range(pieces)]
    if not sizes:
        raise PlaneError(f"its strips are compressed (Compression {compression}) and it has no byte counts "
                         "(StripByteCounts or TileByteCounts, which TIFF 6.0 requires and libtiff needs to read them)")
    return list(sizes)


def _plane_file(directory, located, bits: int, sample_format: int, starts, extents) -> bytes:
    """The plane's file (:func:`tiff_plane`): the header, the directory of ``directory``'s entries made those of one
    sample, the values they point at, and the plane's strips or tiles (``starts``, ``extents`` bytes each) copied from
    ``directory``'s file. A tag whose values lie past the file's end (:func:`wrt.tiff_checks.tags_past_end`, none of
    :data:`wrt.tiff_checks.PIXEL_TAGS`) is left out, as libtiff skips it: pointed past the plane's end, Pillow
    counted its size against the file's and took every later tag's values for past the end too, the strips' offsets
    among them."""
    data, order, offset, counter, inline = directory[:5]
    wide = offset == "Q"  # BigTIFF: offsets and counts as LONG8
    value_type, value_code = (LONG8, "Q") if wide else (LONG, "I")
    fields = {tag: found for tag, found in directory.entries.items()
              if tag not in PER_SAMPLE_TAGS | OFFSET_TAGS and found[0] not in OFFSET_TYPES and found[0] in TYPE_BYTES}
    values = {}  # tag -> the bytes of its values past its field
    for tag, (kind, n, field) in fields.items():
        if n * TYPE_BYTES[kind] > inline:
            (at,) = struct.unpack(order + offset, field)
            values[tag] = data[at : at + n * TYPE_BYTES[kind]]
    for tag in tags_past_end(directory):
        fields.pop(tag, None)
        values.pop(tag, None)
    for tag, value in ((BITS_PER_SAMPLE, bits), (SAMPLES_PER_PIXEL, 1), (PHOTOMETRIC, BLACK_IS_ZERO),
                       (PLANAR_CONFIGURATION, 1)):
        fields[tag] = (SHORT, 1, struct.pack(order + "H", value).ljust(inline, b"\0"))
        values.pop(tag, None)
    if SAMPLE_FORMAT in fields:
        fields[SAMPLE_FORMAT] = (SHORT, 1, struct.pack(order + "H", sample_format).ljust(inline, b"\0"))
        values.pop(SAMPLE_FORMAT, None)
    for tag, numbers in ((located[0], [0] * len(starts)), (located[1], extents)):  # (the offsets are set below)
        packed = struct.pack(f"{order}{len(numbers)}{value_code}", *numbers)
        fields[tag] = (value_type, len(numbers), packed.ljust(inline, b"\0")[:inline])
        values.pop(tag, None)
        if len(packed) > inline:
            values[tag] = packed
    header = 8 if offset == "I" else 16
    entry = struct.Struct(f"{order}HH{offset}{inline}s")  # tag, type, count, value or offset
    at = header + struct.calcsize(order + counter) + entry.size * len(fields) + struct.calcsize(order + offset)
    places = {}
    for tag in sorted(values):
        at += at % 2  # (values start on a word boundary)
        places[tag], at = at, at + len(values[tag])
    pieces = []
    for extent in extents:
        pieces.append(at)
        at += extent
    end = at
    offsets = struct.pack(f"{order}{len(pieces)}{value_code}", *pieces)
    if located[0] in values:
        values[located[0]] = offsets
    else:
        fields[located[0]] = (value_type, len(pieces), offsets.ljust(inline, b"\0"))
    out = bytearray(end)
    out[:4] = data[:4]
    struct.pack_into(order + offset, out, header - struct.calcsize(order + offset), header)
    if offset == "Q":
        struct.pack_into(order + "HH", out, 4, 8, 0)  # BigTIFF: the bytes of an offset, and a reserved 0
    struct.pack_into(order + counter, out, header, len(fields))
    at = header + struct.calcsize(order + counter)
    for tag in sorted(fields):  # TIFF 6.0: entries in ascending order of tag (the next directory's offset: 0)
        kind, n, field = fields[tag]
        if tag in values:
            field = struct.pack(order + offset, places[tag]).ljust(inline, b"\0")
        entry.pack_into(out, at, tag, kind, n, field)
        at += entry.size
    for tag, place in places.items():
        out[place : place + len(values[tag])] = values[tag]
    for start, extent, place in zip(starts, extents, pieces):
        out[place : place + extent] = data[start : start + extent]
    return bytes(out)
