"""An OpenEXR writer in plain Python, independent of the OpenEXR package, for tests of EXR files that package does
not write: subsampled channels (luminance-chroma images, ``RY``/``BY`` at one sample per 2 x 2 pixels) and a
``chromaticities`` header attribute. Single-part scanline files, uncompressed, half samples, the data window at the
origin (OpenEXR file layout: magic number, version, header attributes, line offset table, one chunk per line)."""

import struct

import numpy as np

MAGIC = b"\x76\x2f\x31\x01"  # the first four bytes of every OpenEXR file
HALF = 1  # pixel type of a channel list entry: 0 UINT, 1 HALF, 2 FLOAT


def _attribute(name: str, kind: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def half_exr(width: int, height: int, channels: dict, sampling: dict | None = None, chromaticities=None) -> bytes:
    """The bytes of an EXR of half ``channels`` (name -> ``(height / ys, width / xs)`` samples; ``sampling``: name
    -> ``(xs, ys)``, 1 x 1 where not given), with ``chromaticities`` (red, green, blue, white x y: 8 numbers) in the
    header when given. A subsampled channel holds the pixels whose x and y are multiples of its sampling."""
    sampling = sampling or {}
    names = sorted(channels)  # the channel list, and each line's samples, go in name order
    chlist = b"".join(name.encode() + b"\0" + struct.pack("<iB3xii", HALF, 0, *sampling.get(name, (1, 1)))
                      for name in names) + b"\0"
    window = struct.pack("<4i", 0, 0, width - 1, height - 1)
    header = (_attribute("channels", "chlist", chlist) + _attribute("compression", "compression", b"\0")
              + _attribute("dataWindow", "box2i", window) + _attribute("displayWindow", "box2i", window)
              + _attribute("lineOrder", "lineOrder", b"\0")
              + _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + _attribute("screenWindowCenter", "v2f", struct.pack("<2f", 0.0, 0.0))
              + _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)))
    if chromaticities is not None:
        header += _attribute("chromaticities", "chromaticities", struct.pack("<8f", *chromaticities))
    header += b"\0"
    lines = []
    for y in range(height):
        data = b""
        for name in names:
            xs, ys = sampling.get(name, (1, 1))
            if y % ys == 0:
                data += np.asarray(channels[name], "<f2")[y // ys, : width // xs].tobytes()
        lines.append(struct.pack("<ii", y, len(data)) + data)
    start = len(MAGIC) + 4 + len(header) + 8 * height  # the first line follows the offset table
    offsets = np.cumsum([start] + [len(line) for line in lines[:-1]]).astype("<u8").tobytes()
    return MAGIC + struct.pack("<i", 2) + header + offsets + b"".join(lines)
