"""The sample layout of a TIFF file's first image (channels, bits and sample format), read from its header: to name
a TIFF that Pillow cannot decode, and to scale the integer grey Pillow hands over as 32-bit signed numbers (or,
of 12 bits, unscaled). Pillow reads 8- and 16-bit integer colour and grey and 32-bit float grey, but not float colour
(16-, 32- or 64-bit), half or double grey, nor 32-bit integer colour: it calls those an image it cannot identify,
and wrt said no reader it has knew the format of a ``.tif`` it plainly named (TIFF 6.0: an 8-byte header pointing at
the first image file directory, 12-byte entries of tag, type, count and value or offset; BigTIFF: a 16-byte header,
20-byte entries). That directory is read here for every reader of wrt's (:func:`tiff_directory`: the plane files of
``tiff_planes`` too), and its tags whose values lie past the file's end found (:func:`tags_past_end`)."""

from __future__ import annotations

import struct
from typing import NamedTuple

# Little- and big-endian headers -> struct byte order and the file's layout: the struct codes of an offset and of an
# entry count, and the bytes of a directory entry's value field (TIFF 6.0; BigTIFF: 8-byte offsets and counts)
TIFF_MAGIC = {b"II*\0": ("<", "I", "H", 4), b"MM\0*": (">", "I", "H", 4),
              b"II+\0": ("<", "Q", "Q", 8), b"MM\0+": (">", "Q", "Q", 8)}
BYTE, SHORT, LONG, LONG8 = 1, 3, 4, 16  # TIFF field types of unsigned 8-, 16-, 32- and 64-bit values (LONG8: BigTIFF)
UNSIGNED_CODES = {BYTE: "B", SHORT: "H", LONG: "I", LONG8: "Q"}  # their struct codes
# Bytes of one value of each field type: TIFF 6.0's BYTE, ASCII, SHORT, LONG, RATIONAL, SBYTE, UNDEFINED, SSHORT,
# SLONG, SRATIONAL, FLOAT, DOUBLE, IFD (TIFF Technical Note 1) and BigTIFF's LONG8, SLONG8, IFD8
TYPE_BYTES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 13: 4, 16: 8, 17: 8, 18: 8}
BITS_PER_SAMPLE, SAMPLES_PER_PIXEL, SAMPLE_FORMAT = 258, 277, 339  # the tags read (each SHORT values)
PLANAR_CONFIGURATION = 284  # 1: samples of a pixel together, 2: each channel's plane apart
IMAGE_WIDTH, IMAGE_LENGTH, ROWS_PER_STRIP = 256, 257, 278  # the image's size, and the rows of each strip
TILE_WIDTH, TILE_LENGTH = 322, 323  # each tile's size
# Compression values of other writers than TIFF 6.0's, which Pillow has no decoder for, by name (GDAL's LERC, ...)
COMPRESSION_NAMES = {34712: "JPEG 2000", 34887: "LERC", 34892: "lossy JPEG", 50002: "JPEG XL"}
EXTRA_SAMPLES = 338  # what samples past the colour ones hold: 0 unspecified, 1 associated alpha, 2 unassociated
ASSOCIATED_ALPHA, UNASSOCIATED_ALPHA = 1, 2  # ExtraSamples values: alpha the colour is premultiplied by, or not
PHOTOMETRIC = 262  # PhotometricInterpretation: how samples read as colour
# Tags whose values locate the image's data, one per strip or tile (of each plane): (offsets, byte counts)
STRIP_TAGS, TILE_TAGS = (273, 279), (324, 325)
WHITE_IS_ZERO, BLACK_IS_ZERO = 0, 1  # its values of grey: 0 white and the largest value black, or the other way
RGB, YCBCR = 2, 6  # its values of colour of three samples, red, green and blue, or luma and chroma
COMPRESSION = 259  # how strips or tiles are compressed (1: not)
UNSIGNED, SIGNED = 1, 2  # SampleFormat values of integer samples (3: floating-point)
SAMPLE_FORMATS = {UNSIGNED: "unsigned integer", SIGNED: "signed integer", 3: "floating-point"}  # their words
# Tags that say how the samples are stored and read (size, depth, compression, strips and tiles, photometric and
# colour tags, alpha, sample format, JPEG tables): one whose values lie past the file's end makes the file unreadable
# (skipped, its samples would be read by defaults). Other tags (names, dates, resolution, XMP, ICC, GeoTIFF, ...) are
# skipped there, as libtiff, under Storm's TIFF reader, skips them, and named.
PIXEL_TAGS = {256, 257, 258, 259, 262, 266, 273, 277, 278, 279, 284, 317, 320, 322, 323, 324, 325, 338, 339, 347, 513,
              514, 519, 520, 521, 529, 530, 531, 532}
# Those of them whose values are SHORT or LONG numbers (TIFF 6.0: all but JPEGTables, YCbCrCoefficients and
# ReferenceBlackWhite), which libtiff reads of BYTE values too; Pillow (as tifffile) takes a BYTE entry's values for
# bytes, not numbers, and opens no file of such a size, depth, compression, photometric, sample count or strip height
NUMBER_TAGS = PIXEL_TAGS - {347, 529, 532}


def tiff_samples(data: bytes) -> tuple[int, int, int] | None:
    """``(channels, bits, sample format)`` of the TIFF (or BigTIFF) file ``data``'s first image, from the first value
    of its ``SamplesPerPixel``, ``BitsPerSample`` and ``SampleFormat`` tags (the TIFF defaults 1, 1 and 1, unsigned
    integer, where a tag is missing); None for data that is no TIFF or whose directory is cut short. A BigTIFF (a
    large GDAL elevation map) was no TIFF here: Pillow reads one, and its 16-bit signed grey read over its own
    largest sample."""
    tags = tiff_first_values(data, (BITS_PER_SAMPLE, SAMPLES_PER_PIXEL, SAMPLE_FORMAT))
    if tags is None:
        return None
    return tags.get(SAMPLES_PER_PIXEL, 1), tags.get(BITS_PER_SAMPLE, 1), tags.get(SAMPLE_FORMAT, 1)


def tiff_first_values(data: bytes, wanted: tuple[int, ...]) -> dict[int, int] | None:
    """The first value of each tag of ``wanted`` the TIFF (or BigTIFF) file ``data``'s first image directory holds
    as unsigned integers (SHORT, as TIFF 6.0 gives the layout tags, or LONG or LONG8, which libtiff reads for them
    too: a LONG PlanarConfiguration of 16-bit planes was taken for its default, 1, and the planes read as samples
    together, 0.84 off; tags missing, or of another type, are left out); None for data that is no TIFF or whose
    directory is cut short."""
    directory = tiff_directory(data)
    if directory is None:
        return None
    tags = {}
    try:
        for tag in wanted:
            values = directory.values(tag)
            if values:
                tags[tag] = values[0]
    except struct.error:
        return None
    return tags


class TiffDirectory(NamedTuple):
    """The first image file directory of a TIFF (or BigTIFF) file: its entries as stored, read where a reader asks
    (:meth:`values`), and the file's layout (:data:`TIFF_MAGIC`)."""

    data: bytes  # the whole file
    order: str  # struct byte order
    offset: str  # struct code of an offset
    counter: str  # struct code of the directory's entry count
    inline: int  # bytes of an entry's value field
    entries: dict  # tag -> (field type, count of values, value field bytes)
    places: dict  # tag -> where its entry lies in the file

    def where(self, tag: int) -> tuple[bytes, int]:
        """``(source, position)`` of the values of entry ``tag``: its value field where they fit in it, else the
        file and the offset the field holds (TIFF 6.0)."""
        kind, n, field = self.entries[tag]
        if n * TYPE_BYTES.get(kind, 1) <= self.inline:
            return field, 0
        return self.data, struct.unpack(self.order + self.offset, field)[0]

    def values(self, tag: int) -> list[int]:
        """The values of entry ``tag`` of unsigned integer type (BYTE, SHORT, LONG or LONG8); none for a missing entry
        or another type. Raises ``struct.error`` for values past the file's end."""
        kind, n, _ = self.entries.get(tag, (None, 0, b""))
        if kind not in UNSIGNED_CODES:
            return []
        return list(struct.unpack_from(f"{self.order}{n}{UNSIGNED_CODES[kind]}", *self.where(tag)))

    def first(self, tag: int, default: int) -> int:
        """The first of :meth:`values` of ``tag``, ``default`` where it has none (an unset tag's TIFF default)."""
        values = self.values(tag)
        return values[0] if values else default


def tiff_directory(data: bytes) -> TiffDirectory | None:
    """The first image file directory of the TIFF (or BigTIFF) file ``data``; None for data that is no TIFF or whose
    directory is cut short."""
    layout = TIFF_MAGIC.get(data[:4])
    if layout is None:
        return None
    order, offset, counter, inline = layout
    entry = struct.Struct(f"{order}HH{offset}{inline}s")  # tag, type, count, value or offset
    entries, places = {}, {}
    try:
        (at,) = struct.unpack_from(order + offset, data, 4 if offset == "I" else 8)
        if at >= len(data):  # cut short (a BigTIFF's offset past 2^63: struct's OverflowError, not its error)
            return None
        (count,) = struct.unpack_from(order + counter, data, at)
        first = at + struct.calcsize(order + counter)
        for k in range(count):
            tag, kind, n, field = entry.unpack_from(data, first + entry.size * k)
            entries[tag], places[tag] = (kind, n, field), first + entry.size * k
    except struct.error:
        return None
    return TiffDirectory(data, order, offset, counter, inline, entries, places)


def tags_past_end(directory: TiffDirectory) -> list[int]:
    """The tags of ``directory`` whose values lie past its file's end, wholly or in part (a damaged file), of the
    field types whose size is known."""
    past = []
    for tag, (kind, n, field) in directory.entries.items():
        if kind in TYPE_BYTES and n * TYPE_BYTES[kind] > directory.inline:
            (at,) = struct.unpack(directory.order + directory.offset, field)
            if at + n * TYPE_BYTES[kind] > len(directory.data):
                past.append(tag)
    return past


def with_value(directory: TiffDirectory, tag: int, value: int) -> bytes:
    """``directory``'s file with the first value of its entry ``tag`` (of an unsigned integer type, in the entry's
    field) set to ``value``, of the entry's type (a SHORT written over a big-endian LONG's high half made 1 65536)."""
    field = directory.places[tag] + 4 + struct.calcsize(directory.order + directory.offset)  # past tag, type, count
    packed = struct.pack(directory.order + UNSIGNED_CODES[directory.entries[tag][0]], value)
    data = memoryview(directory.data)  # (one copy of the file: the join's)
    return b"".join((data[:field], packed, data[field + len(packed) :]))


def piece_problem(directory: TiffDirectory) -> str | None:
    """Words for the first strip or tile of ``directory``'s image that holds no data (offset 0, or a byte count of
    0: a sparse file's missing one, as GDAL writes them), that, uncompressed, holds fewer bytes than its rows fill
    (TIFF 6.0: each row of whole bytes; a tile whole, the last strip the rows left), or whose bytes (those its rows
    fill, uncompressed; its byte count, compressed) run past the file's end. libtiff refuses to read all three
    ("Invalid strip byte count 0", "Not enough data for scanline", "Read error on strip"); Pillow, which reads the
    bytes the rows fill from the offset whatever the count says, read the file's header or the next strip's bytes as
    samples, and named a cut compressed file as a decoding failure; or that its strips or tiles are not as many as
    its size makes (:func:`count_problem`). None where there is none; the rows are not counted where the strips are
    not as many as the size makes (more, compressed), the planes differ in depth (both named where they are
    read) or the colour is YCbCr (subsampled). Raises ``struct.error`` for values past the file's end."""
    located = TILE_TAGS if TILE_TAGS[0] in directory.entries else STRIP_TAGS
    kind = "tile" if located == TILE_TAGS else "strip"
    starts, sizes = directory.values(located[0]), directory.values(located[1])
    for k, start in enumerate(starts):
        size = sizes[k] if k < len(sizes) else None
        if start == 0 or size == 0:
            return (f"{kind} {k} has no data (offset {start}{'' if size is None else f', byte count {size}'}: a "
                    "sparse file's missing strip or tile, which libtiff does not read either)")
    uncompressed = directory.first(COMPRESSION, 1) == 1
    count = count_problem(directory, kind, len(starts), uncompressed)
    if count is not None:
        return count
    needs = _bytes_filled(directory, kind, len(starts)) if uncompressed else None
    for k, start in enumerate(starts):
        size = sizes[k] if len(sizes) == len(starts) else None  # (none: inferred, uncompressed)
        if needs is not None and size is not None and size < needs[k]:
            return (f"{kind} {k} holds {size} bytes, where its rows need {needs[k]} (uncompressed): its byte count "
                    "is short, or the file damaged (libtiff does not read it either)")
        end = start + (needs[k] if needs is not None else size if size is not None else 0)
        if end > len(directory.data):
            return (f"{kind} {k} (bytes {start} to {end}) lies past the file's end ({len(directory.data)} bytes): the "
                    "file is cut short")
    return None


def piece_grid(directory: TiffDirectory, kind: str) -> tuple[int, int, int] | None:
    """``(across, rows, per plane)``: the pixels across and the rows of each strip or tile (``kind``) of
    ``directory``'s image, and how many of them its size makes a plane (TIFF 6.0: StripsPerImage, TilesPerImage);
    None for an empty size."""
    width, height = directory.first(IMAGE_WIDTH, 0), directory.first(IMAGE_LENGTH, 0)
    # (RowsPerStrip's default is 2^32 - 1: the whole image)
    across, rows = ((directory.first(TILE_WIDTH, 0), directory.first(TILE_LENGTH, 0)) if kind == "tile"
                    else (width, min(directory.first(ROWS_PER_STRIP, 2**32 - 1), height)))
    if min(across, rows) <= 0:
        return None
    return across, rows, -(-height // rows) * (-(-width // across) if kind == "tile" else 1)


def count_problem(directory: TiffDirectory, kind: str, pieces: int, uncompressed: bool) -> str | None:
    """Words for ``pieces`` strips or tiles (``kind``) of ``directory``'s image, its samples of a pixel together,
    where its size makes more (libtiff refuses the file: 'Invalid strip byte count 0'; Pillow, uncompressed, read the
    rows past them as 0) or, ``uncompressed``, fewer (Pillow laid the ones past them over the first rows; libtiff,
    which decodes compressed ones, leaves them); None where they are as many, or its planes lie apart (each plane's
    are counted as it is read, :func:`wrt.tiff_planes.tiff_plane`)."""
    grid = piece_grid(directory, kind)
    if grid is None or pieces == 0 or (directory.first(PLANAR_CONFIGURATION, 1) == 2
                                       and directory.first(SAMPLES_PER_PIXEL, 1) > 1):
        return None  # (none at all: an old-style JPEG's data lies where JPEGInterchangeFormat says)
    across, rows, made = grid
    if pieces == made or (pieces > made and not uncompressed):
        return None
    why = ("libtiff does not read such a file either" if pieces < made
           else "Pillow lays the ones past them over its first rows")
    width, height = directory.first(IMAGE_WIDTH, 0), directory.first(IMAGE_LENGTH, 0)
    return (f"it has {pieces} {kind}{'' if pieces == 1 else 's'}, where {width} x {height} pixels in {kind}s of "
            f"{across} x {rows} make {made}: the file is damaged ({why})")


def _bytes_filled(directory: TiffDirectory, kind: str, pieces: int) -> list[int] | None:
    """The bytes each of the ``pieces`` uncompressed strips or tiles (``kind``) of ``directory``'s image fill, in the
    order its offsets list them; None where they are not counted (:func:`piece_problem`)."""
    height = directory.first(IMAGE_LENGTH, 0)
    samples, bits = directory.first(SAMPLES_PER_PIXEL, 1), directory.values(BITS_PER_SAMPLE) or [1]
    planar = directory.first(PLANAR_CONFIGURATION, 1) == 2
    grid = piece_grid(directory, kind)
    if grid is None or directory.first(PHOTOMETRIC, 1) == YCBCR or (planar and len(set(bits[:samples])) > 1):
        return None
    across, rows, per_plane = grid
    if pieces != per_plane * (samples if planar else 1):
        return None
    pixel_bits = bits[0] if planar else bits[0] * samples if len(bits) == 1 else sum(bits[:samples])
    row_bytes = -(-across * pixel_bits // 8)
    return [(rows if kind == "tile" else min(rows, height - (k % per_plane) * rows)) * row_bytes
            for k in range(pieces)]


def with_byte_numbers_as_shorts(data: bytes) -> bytes:
    """The TIFF (or BigTIFF) file ``data`` with the BYTE entries of :data:`NUMBER_TAGS` in its first image directory
    made SHORT entries of the same values (put past the file's end where they no longer fit in the entry), as libtiff
    reads them; ``data`` itself where it has none, is no TIFF, or its directory or their values are cut short (named
    where it is read: :func:`wrt.textures._refuse_damaged_tiff`). Pillow opened no file of a BYTE size, BitsPerSample,
    Compression, PhotometricInterpretation, SamplesPerPixel or RowsPerStrip, and wrt named it as of samples Pillow
    does not decode."""
    directory = tiff_directory(data)
    tags = [] if directory is None else [tag for tag in sorted(NUMBER_TAGS)
                                         if directory.entries.get(tag, (None,))[0] == BYTE]
    if not tags:
        return data
    out = bytearray(data)
    for tag in tags:
        try:
            values = directory.values(tag)
        except struct.error:
            return data
        packed = struct.pack(f"{directory.order}{len(values)}H", *values)
        if len(packed) > directory.inline:
            out += bytes(len(out) % 2)  # (values start on a word boundary)
            field = struct.pack(directory.order + directory.offset, len(out))
            out += packed
        else:
            field = packed.ljust(directory.inline, b"\0")
        at = directory.places[tag]
        struct.pack_into(directory.order + "H", out, at + 2, SHORT)  # (past the tag; the count stays)
        at += 4 + struct.calcsize(directory.order + directory.offset)  # (past tag, type and count: the value field)
        out[at : at + directory.inline] = field
    return bytes(out)


def without_tags(directory: TiffDirectory, tags) -> bytes:
    """``directory``'s file with the entries of ``tags`` given field type 0, which no TIFF reader knows: Pillow and
    libtiff skip such an entry."""
    data = bytearray(directory.data)
    for tag in tags:
        struct.pack_into(directory.order + "H", data, directory.places[tag] + 2, 0)
    return bytes(data)


def tiff_sample_layout(data: bytes) -> str | None:
    """Words for :func:`tiff_samples` of ``data`` (``3 channels of 32-bit floating-point samples``); None where that
    is None."""
    samples = tiff_samples(data)
    if samples is None:
        return None
    channels, bits, kind = samples
    return (f"{channels} channel{'' if channels == 1 else 's'} of {bits}-bit "
            f"{SAMPLE_FORMATS.get(kind, 'undefined')} samples")
