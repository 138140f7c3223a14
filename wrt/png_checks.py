"""The chunk checks Storm's PNG reader (stb_image) makes before it decodes a file, which Pillow does not make: a
``tRNS`` chunk beside an alpha channel, after the image data, of the wrong length or before the palette, and a
palette image without its ``PLTE`` chunk. stb_image refuses such files ("tRNS with alpha", "Corrupt PNG"), so
Storm draws the texture's fallback; Pillow read them, ignoring the chunk or applying it (the PNG specification,
clause 11.3.2.1, forbids each of them). And the text and ICC profile chunks stb_image skips, taken out before Pillow
(which refuses large compressed ones) sees the file (:func:`without_unread_chunks`)."""

from __future__ import annotations

import struct

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"  # first 8 bytes of every PNG file
KEY_BYTES = {0: 2, 2: 6}  # tRNS length of a grey and of an RGB image: one 16-bit sample per channel
# Chunks wrt does not read and stb_image skips, which Pillow decompresses (and refuses past 1 MB): text (comments,
# XMP, ImageMagick's raw profiles) and the ICC profile (wrt decodes by sRGB and gAMA chunks, as Storm's reader)
UNREAD_CHUNKS = (b"tEXt", b"zTXt", b"iTXt", b"iCCP")


def png_chunk_problem(data: bytes) -> str | None:
    """What makes stb_image refuse the PNG ``data`` before decoding it (see the module docstring), None when nothing
    does (or ``data`` is no PNG; a cut or damaged file is left to the decoder)."""
    if data[:8] != PNG_SIGNATURE:
        return None
    colour_type, palette_entries, seen_image_data, at = None, 0, False, 8
    while at + 8 <= len(data):
        (length,), kind = struct.unpack(">I", data[at : at + 4]), data[at + 4 : at + 8]
        if kind == b"IHDR" and length >= 13:
            colour_type = data[at + 17] if at + 18 <= len(data) else None
        elif kind == b"PLTE":
            palette_entries = length // 3
        elif kind == b"IDAT":
            if colour_type == 3 and not palette_entries:
                return "a palette image without a PLTE chunk"
            seen_image_data = True
        elif kind == b"tRNS":
            if seen_image_data:
                return "a tRNS chunk after the image data"
            if colour_type in (4, 6):
                return f"a tRNS chunk beside an alpha channel (colour type {colour_type})"
            if colour_type == 3 and not palette_entries:
                return "a tRNS chunk before the PLTE chunk"
            if colour_type == 3 and length > palette_entries:
                return f"a tRNS chunk of {length} alpha values for a palette of {palette_entries} colours"
            if colour_type in KEY_BYTES and length != KEY_BYTES[colour_type]:
                image = "a grey" if colour_type == 0 else "an RGB"
                return f"a tRNS chunk of {length} bytes in {image} image (not {KEY_BYTES[colour_type]})"
        elif kind == b"IEND":
            break
        at += 12 + length  # length, type, data, CRC
    return None


def without_unread_chunks(data: bytes) -> bytes:
    """The PNG ``data`` without its text chunks and ICC profile (:data:`UNREAD_CHUNKS`), which stb_image skips and
    wrt does not read; ``data`` itself where it has none or is no PNG. Pillow decompresses each as it opens the file
    and refuses one that expands past 1 MB (``PngImagePlugin.MAX_TEXT_CHUNK``): a texture carrying a large
    compressed XMP packet (an image editor's history, ImageMagick's hex ``Raw profile type xmp``) or a 2 MB ICC
    profile read its fallback, named as "Decompressed data too large". Every chunk carries its own CRC, so the
    others are kept as they are; bytes after a chunk cut short are kept for the decoder to judge."""
    if data[:8] != PNG_SIGNATURE:
        return data
    kept, at, dropped = [data[:8]], 8, False
    while at + 8 <= len(data):
        (length,), kind = struct.unpack(">I", data[at : at + 4]), data[at + 4 : at + 8]
        end = at + 12 + length  # length, type, data, CRC
        if kind in UNREAD_CHUNKS:
            dropped = True
        else:
            kept.append(data[at:end])
        at = end
    kept.append(data[at:])
    return b"".join(kept) if dropped else data
