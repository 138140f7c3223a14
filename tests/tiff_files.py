"""TIFF files written byte by byte from the TIFF 6.0 specification (an 8-byte header, one image file directory of
12-byte entries of tag, type, count and value or offset, in ascending order of tag; values past 4 bytes, then the
strips or tiles, after it), of any tags: for the layouts the texture tests need a file of its own for (several strips
a plane, tiles, missing or short byte counts, cut files, odd tags)."""

import struct

BYTE, SHORT, LONG, ASCII, UNDEFINED = 1, 3, 4, 2, 7  # TIFF field types written here
CODES = {SHORT: "H", LONG: "I"}  # their struct codes (BYTE, ASCII and UNDEFINED values are bytes)
STRIPS, TILES = (273, 279), (324, 325)  # the tags of strip (tile) offsets and byte counts


def tiff_file(tags, chunks, byte_order="<", located=STRIPS, byte_counts=True):
    """The bytes of a TIFF of ``tags`` (tag -> ``(type, values)``: SHORT or LONG numbers, or ASCII / UNDEFINED
    bytes) and ``chunks`` (the strips or tiles, as stored, in the order their offsets list them): ``located``'s
    offsets and byte counts (LONG) are written here, the counts left out where ``byte_counts`` is False."""
    tags = dict(tags)
    tags[located[0]] = (LONG, [0] * len(chunks))  # (placeholders: the same sizes as the values written below)
    if byte_counts:
        tags[located[1]] = (LONG, [len(c) for c in chunks])
    directory_size = 2 + 12 * len(tags) + 4
    out_of_line, at = {}, 8 + directory_size  # tag -> where its values lie, past the directory
    for tag, (kind, values) in sorted(tags.items()):
        size = len(_packed(byte_order, kind, values))
        if size > 4:
            out_of_line[tag], at = at, at + size + size % 2  # (values start on a word boundary)
    starts = []
    for chunk in chunks:
        starts.append(at)
        at += len(chunk)
    tags[located[0]] = (LONG, starts)
    head = (b"II*\0" if byte_order == "<" else b"MM\0*") + struct.pack(byte_order + "I", 8)
    directory, values = struct.pack(byte_order + "H", len(tags)), b""
    for tag, (kind, v) in sorted(tags.items()):
        packed = _packed(byte_order, kind, v)
        count = len(v)
        if tag in out_of_line:
            directory += struct.pack(byte_order + "HHII", tag, kind, count, out_of_line[tag])
            values += packed + bytes(len(packed) % 2)
        else:
            directory += struct.pack(byte_order + "HHI", tag, kind, count) + packed.ljust(4, b"\0")
    return head + directory + bytes(4) + values + b"".join(chunks)


def _packed(byte_order, kind, values):
    """The bytes of ``values`` of TIFF field type ``kind``."""
    if kind in CODES:
        return struct.pack(byte_order + CODES[kind] * len(values), *values)
    return bytes(values)
