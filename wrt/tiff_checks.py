"""The sample layout of a TIFF file's first image (channels, bits and sample format), read from its header: to name
a TIFF that Pillow cannot decode, and to scale the integer grey Pillow hands over as 32-bit signed numbers. Pillow
reads 8- and 16-bit integer colour and grey and 32-bit float grey, but not float colour (16-, 32- or 64-bit), half or
double grey, nor 32-bit integer colour: it calls those an image it cannot identify, and wrt said no reader it has
knew the format of a ``.tif`` it plainly named (TIFF 6.0: an 8-byte header pointing at the first image file
directory, 12-byte entries of tag, type, count and value or offset)."""

from __future__ import annotations

import struct

TIFF_MAGIC = {b"II*\0": "<", b"MM\0*": ">"}  # little- and big-endian TIFF headers -> struct byte order
SHORT = 3  # TIFF field type of unsigned 16-bit values
BITS_PER_SAMPLE, SAMPLES_PER_PIXEL, SAMPLE_FORMAT = 258, 277, 339  # the tags read (each SHORT values)
UNSIGNED, SIGNED = 1, 2  # SampleFormat values of integer samples (3: floating-point)
SAMPLE_FORMATS = {UNSIGNED: "unsigned integer", SIGNED: "signed integer", 3: "floating-point"}  # their words


def tiff_samples(data: bytes) -> tuple[int, int, int] | None:
    """``(channels, bits, sample format)`` of the TIFF file ``data``'s first image, from its ``SamplesPerPixel``,
    ``BitsPerSample`` and ``SampleFormat`` tags (the TIFF defaults 1, 1 and 1, unsigned integer, where a tag is
    missing); None for data that is no TIFF or whose directory is cut short."""
    order = TIFF_MAGIC.get(data[:4])
    if order is None:
        return None
    tags = {}
    try:
        (directory,) = struct.unpack(order + "I", data[4:8])
        (count,) = struct.unpack(order + "H", data[directory : directory + 2])
        for k in range(count):
            start = directory + 2 + 12 * k
            tag, kind, n, field = struct.unpack(order + "HHI4s", data[start : start + 12])
            if tag in (BITS_PER_SAMPLE, SAMPLES_PER_PIXEL, SAMPLE_FORMAT) and kind == SHORT and n > 0:
                if n > 2:  # values past the entry's 4 bytes lie at the offset it holds
                    (offset,) = struct.unpack(order + "I", field)
                    field = data[offset : offset + 2 * n]
                tags[tag] = struct.unpack(order + f"{n}H", field[: 2 * n])
    except struct.error:
        return None
    return tags.get(SAMPLES_PER_PIXEL, (1,))[0], tags.get(BITS_PER_SAMPLE, (1,))[0], tags.get(SAMPLE_FORMAT, (1,))[0]


def tiff_sample_layout(data: bytes) -> str | None:
    """Words for :func:`tiff_samples` of ``data`` (``3 channels of 32-bit floating-point samples``); None where that
    is None."""
    samples = tiff_samples(data)
    if samples is None:
        return None
    channels, bits, kind = samples
    return (f"{channels} channel{'' if channels == 1 else 's'} of {bits}-bit "
            f"{SAMPLE_FORMATS.get(kind, 'undefined')} samples")
