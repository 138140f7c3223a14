"""Image files read as textures (``wrt.textures.load_image``), checked against the samples written here: formats
and sample layouts Pillow reads in ways that need help (16-bit TIFF colour, transparency chunks of grey and RGB PNGs),
colour space chunks ``auto`` follows, EXIF orientation (ignored), EXR channel subsets and names, and damaged files
or files of no colour channel (a warning and the fallback)."""

import re
import struct
import threading
import warnings
import zlib

import numpy as np
import pytest
from PIL import Image as PilImage
from PIL import PngImagePlugin
from png_chunks import chunk as png_chunk
from png_chunks import rgb_png
from png_files import png
from test_materials import textured_stage
from tiff_files import LONG, SHORT, tiff_file

import wrt
from wrt.textures import PNG_SIGNATURE, TextureError, load_image


def write_tiff(path, samples, byte_order="<", rows_per_strip=1, sample_format=None, deflate=False, planar=False,
               extra_sample=2, orientation=None, photometric=None, byte_counts=True):
    """A grey, grey + alpha, RGB or RGBA TIFF (``samples`` ``(H, W, 1, 2, 3 or 4)``, of their dtype's bits: uint16
    for integers) written here byte by byte (``byte_order`` ``"<"``: ``II``, ``">"``: ``MM``), one strip per
    ``rows_per_strip`` rows, so the reader has to join several strips; ``sample_format``: its ``SampleFormat`` tag
    where given (2: signed integers, 3: floats). Uncompressed, or with ``deflate`` each strip zlib-compressed
    (Compression 8, as libtiff writes it); ``planar``: each channel's strips apart, one plane after another
    (PlanarConfiguration 2); ``extra_sample``: the ExtraSamples value of the second sample of grey or the fourth of
    colour (1: associated alpha, premultiplied colour), or a pair: the values of two samples past grey or colour
    (three samples of grey, five of colour); ``orientation``: its Orientation tag where given; ``photometric``: its
    PhotometricInterpretation (else 1, BlackIsZero grey, or 2, RGB); ``byte_counts``: False leaves StripByteCounts out
    (TIFF 6.0 requires it; libtiff and Pillow infer it for uncompressed strips)."""
    samples = np.asarray(samples)
    samples = samples.astype(np.uint16) if samples.dtype == np.int64 else samples
    h, w, c = samples.shape
    bits = samples.dtype.itemsize * 8
    sample_type = byte_order + samples.dtype.str[1:]
    planes = [samples[..., k : k + 1] for k in range(c)] if planar else [samples]
    strips = [plane[r : r + rows_per_strip].astype(sample_type).tobytes() for plane in planes
              for r in range(0, h, rows_per_strip)]
    strips = [zlib.compress(strip) for strip in strips] if deflate else strips
    n_strips = len(strips)
    photometric = photometric if photometric is not None else 1 if c <= 2 else 2
    extras = tuple(extra_sample) if isinstance(extra_sample, tuple) else (extra_sample,)
    has_extra = c > (1 if photometric in (0, 1) else 3)  # samples past grey or colour: ExtraSamples says what
    tags = 10 + has_extra + (sample_format is not None) + (orientation is not None) - (not byte_counts)
    bits_at = 8 + 2 + tags * 12 + 4  # after the one IFD: bits per sample, strip offsets, strip byte counts, pixels
    offsets_at = bits_at + 2 * c
    counts_at = offsets_at + 4 * n_strips
    pixels_at = counts_at + 4 * n_strips

    def entry(tag, kind, count, value):  # kind 3: SHORT, 4: LONG; value: inline, or an offset where count says so
        if kind == 3 and count == 1:
            return struct.pack(byte_order + "HHIHH", tag, kind, count, value, 0)
        return struct.pack(byte_order + "HHII", tag, kind, count, value)

    one_offset = pixels_at if n_strips == 1 else offsets_at
    one_count = len(strips[0]) if n_strips == 1 else counts_at
    # BitsPerSample: in the entry where its values fit in 4 bytes (one or two SHORTs), else where bits_at says
    bits_entry = (struct.pack(byte_order + "HHIHH", 258, 3, 2, bits, bits) if c == 2
                  else entry(258, 3, c, bits if c == 1 else bits_at))
    ifd = [entry(256, 4, 1, w), entry(257, 4, 1, h), bits_entry, entry(259, 3, 1, 8 if deflate else 1),
           entry(262, 3, 1, photometric),
           entry(273, 4, n_strips, one_offset), entry(277, 3, 1, c),
           entry(278, 4, 1, rows_per_strip), entry(279, 4, n_strips, one_count), entry(284, 3, 1, 2 if planar else 1)]
    if not byte_counts:
        ifd = [e for e in ifd if struct.unpack(byte_order + "H", e[:2])[0] != 279]
    if has_extra:  # 2: unassociated alpha, 0: a sample of no stated meaning; two values fit in the entry
        ifd.append(struct.pack(byte_order + "HHI2H", 338, 3, 2, *extras) if len(extras) == 2
                   else entry(338, 3, 1, extras[0]))
    if sample_format is not None:
        ifd.append(entry(339, 3, 1, sample_format))
    if orientation is not None:
        ifd.append(entry(274, 3, 1, orientation))
    ifd.sort(key=lambda e: struct.unpack(byte_order + "H", e[:2]))
    starts = np.cumsum([pixels_at] + [len(s) for s in strips[:-1]])
    body = struct.pack(byte_order + "H" * c, *([bits] * c))
    body += struct.pack(byte_order + "I" * n_strips, *starts) + struct.pack(byte_order + "I" * n_strips,
                                                                            *map(len, strips))
    head = (b"II*\0" if byte_order == "<" else b"MM\0*") + struct.pack(byte_order + "I", 8)
    data = head + struct.pack(byte_order + "H", tags) + b"".join(ifd) + struct.pack(byte_order + "I", 0) + body
    path.write_bytes(data + b"".join(strips))
    return str(path)


@pytest.mark.parametrize("dtype, sample_format, full, values", [
    (np.int8, 2, 127.0, [[0, 100, 127], [-1, -30, -128]]),
    (np.int16, 2, 32767.0, [[0, 1000, 20000], [7, -300, -32768]]),
    (np.uint32, None, 4294967295.0, [[0, 1000, 70000], [7, 5, 4_000_000_000]]),
])
def test_integer_grey_tiffs_read_over_their_sample_types_largest_value(tmp_path, dtype, sample_format, full, values):
    """A grey TIFF of 16-bit signed or 32-bit unsigned samples (which Pillow opens as 32-bit signed integers) reads
    each sample over its type's largest value, as Pillow scales 8- and 16-bit ones and OpenImageIO converts integer
    samples to float. They were divided by the image's own largest sample, so the same value read differently in
    each file, and a 32-bit sample past 2^31, which Pillow wraps negative, read -4214. Signed 8-bit samples, which
    Pillow hands over as unsigned bytes, read -1 as 1.0 and -128 as 0.5."""
    samples = np.array(values, dtype)[..., None]
    image = load_image(write_tiff(tmp_path / "grey.tif", samples, sample_format=sample_format), "auto")
    np.testing.assert_allclose(image[..., 0], samples[..., 0] / full, rtol=1e-6)
    np.testing.assert_array_equal(image[..., 1], image[..., 0])
    np.testing.assert_array_equal(image[..., 3], 1.0)


@pytest.mark.parametrize("dtype, sample_format, full", [(np.int8, 2, 127.0), (np.int16, 2, 32767.0),
                                                        (np.int32, 2, 2**31 - 1), (np.float32, 3, 1.0)])
@pytest.mark.parametrize("deflate", [False, True])
def test_grey_of_a_sample_of_no_stated_meaning_stored_plane_by_plane_reads_its_grey(tmp_path, dtype, sample_format,
                                                                                    full, deflate):
    """Signed 8-, 16- or 32-bit or float grey with a second sample of no stated meaning (ExtraSamples 0), stored
    plane by plane: its grey is its first plane, read as a TIFF of its own, as one sample of such grey reads (over its
    type's largest value; the samples written, float64). Uncompressed, Pillow knew no raw mode for 16 and 32 bits:
    the texture failed with its bare words ('unknown raw mode for given image mode'); deflated, Pillow read the first
    plane, of signed bytes as unsigned ones (-1 read 1.0, -100 0.61: 156 / 255), without a word."""
    rng = np.random.default_rng(3)
    grey = (rng.random((3, 4)) * 2 - 1) * (1 if dtype == np.float32 else full)
    samples = np.stack([grey, np.full_like(grey, 9)], axis=2).astype(dtype)
    path = write_tiff(tmp_path / "g.tif", samples, rows_per_strip=2, sample_format=sample_format, deflate=deflate,
                      planar=True, extra_sample=0)
    image = load_image(path, "raw")
    np.testing.assert_allclose(image[..., :3], np.repeat(samples[..., :1] / full, 3, axis=2), rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(image[..., 3], 1.0)


@pytest.mark.parametrize("deflate", [False, True])
def test_white_is_zero_float_grey_of_a_sample_of_no_stated_meaning_stored_plane_by_plane_reads_its_grey(tmp_path,
                                                                                                        deflate):
    """WhiteIsZero float grey with a second sample of no stated meaning (ExtraSamples 0), stored plane by plane, reads
    its grey plane as one sample of WhiteIsZero float grey reads (Pillow, the oracle, hands that over as stored: the
    samples written, float64), as the BlackIsZero one does. Uncompressed, only BlackIsZero grey was read by its plane:
    the texture failed with Pillow's bare words ('unknown raw mode for given image mode'); deflated, it read."""
    grey = np.float32([[0.25, -0.5, 2.0], [0.0, 1.0, 0.75]])
    alone = write_tiff(tmp_path / "alone.tif", grey[..., None], rows_per_strip=2, sample_format=3, photometric=0)
    with PilImage.open(alone) as img:
        np.testing.assert_array_equal(np.asarray(img, np.float64), grey)  # (the oracle: one sample, as stored)
    samples = np.stack([grey, np.full_like(grey, 9)], axis=2)
    path = write_tiff(tmp_path / "g.tif", samples, rows_per_strip=2, sample_format=3, deflate=deflate, planar=True,
                      extra_sample=0, photometric=0)
    image = load_image(path, "raw")
    np.testing.assert_array_equal(image[..., :3], np.repeat(grey[..., None], 3, axis=2).astype(np.float64))
    np.testing.assert_array_equal(image[..., 3], 1.0)
    # Signed WhiteIsZero grey so stored is refused, named, as one sample of it is: its plane is not read as BlackIsZero.
    signed = np.stack([np.int16([[5, -7, 0], [1, 2, 3]]), np.full((2, 3), 9, np.int16)], axis=2)
    signed_path = write_tiff(tmp_path / "s.tif", signed, rows_per_strip=2, sample_format=2, deflate=deflate,
                             planar=True, extra_sample=0, photometric=0)
    with pytest.raises(TextureError, match="16-bit signed integer samples, which Pillow"):
        load_image(signed_path, "raw")


TWELVE_BIT_GREY = np.array([[0, 4095, 7], [2048, 1000, 4094]])


def twelve_bit_grey_tiff(path, grey: np.ndarray, photometric: int):
    """Writes ``grey`` as a one-strip 12-bit grey TIFF of PhotometricInterpretation ``photometric`` (1: BlackIsZero,
    0: WhiteIsZero), each row's samples packed 12 bits at a time, most significant bit first (TIFF 6.0); returns
    ``path``."""
    rows = b""
    for row in grey:
        bits = "".join(f"{v:012b}" for v in row)
        bits += "0" * (-len(bits) % 8)  # each row starts on a byte
        rows += int(bits, 2).to_bytes(len(bits) // 8, "big")
    tags = [(256, 4, grey.shape[1]), (257, 4, grey.shape[0]), (258, 3, 12), (259, 3, 1), (262, 3, photometric),
            (273, 4, 8 + 2 + 12 * 9 + 4), (277, 3, 1), (278, 4, grey.shape[0]), (279, 4, len(rows))]
    entries = b"".join(struct.pack("<HHI", tag, kind, 1) + struct.pack("<I" if kind == 4 else "<Hxx", value)
                       for tag, kind, value in tags)
    path.write_bytes(b"II*\0" + struct.pack("<IH", 8, len(tags)) + entries + bytes(4) + rows)
    return path


def test_a_12_bit_grey_tiff_reads_over_4095(tmp_path):
    """Pillow opens a 12-bit grey TIFF as 16-bit grey and keeps its samples as they are (raw mode ``I;12``): they
    were read over 65535, white (4095) as 0.06. Now over 4095, as OpenImageIO scales them to full range. The file is
    written here, each row's samples packed 12 bits at a time, most significant bit first (TIFF 6.0)."""
    path = twelve_bit_grey_tiff(tmp_path / "grey12.tif", TWELVE_BIT_GREY, photometric=1)
    np.testing.assert_allclose(load_image(str(path), "raw")[..., 0], TWELVE_BIT_GREY / 4095.0, rtol=1e-6)


def test_an_image_of_more_texels_than_textures_hold_is_refused_before_it_is_decoded(tmp_path, monkeypatch):
    """Pillow's decompression-bomb limit is lifted for textures, so a PNG whose header claims 46341 x 46341 pixels
    (past the 2^31 texels ``pack_images`` holds; a damaged width reads so) was decoded first, into gigabytes that
    ran the process out of memory (60000 x 60000: an error of no words after 11 s under a 4 GB limit). It is refused
    from its header, named with its size. Pillow's decoding is replaced by an error here, so that the test would
    allocate nothing where the file reached it."""
    from PIL import ImageFile

    def decoded(self):
        raise RuntimeError("decoded")

    monkeypatch.setattr(ImageFile.ImageFile, "load", decoded)
    side = 46341  # side * side >= 2^31
    path = tmp_path / "huge.png"
    header = struct.pack(">IIBBBBB", side, side, 8, 2, 0, 0, 0)  # 8-bit RGB
    path.write_bytes(PNG_SIGNATURE + png_chunk(b"IHDR", header)
                     + png_chunk(b"IDAT", zlib.compress(bytes(1 + 3 * side))) + png_chunk(b"IEND", b""))
    with pytest.raises(TextureError, match=f"huge.png: it is {side} x {side} pixels, more than the 2\\^31 texels"):
        load_image(str(path), "raw")


def write_bigtiff(path, grey, byte_order="<"):
    """An uncompressed one-strip BigTIFF (8-byte offsets and counts, 20-byte directory entries) of ``grey``
    (``(H, W)`` integers of their dtype's bits), signed where its dtype is, in ``byte_order``; ``path`` as a
    string."""
    h, w = grey.shape
    pixels = grey.astype(byte_order + grey.dtype.str[1:]).tobytes()
    tags = [(256, 4, w), (257, 4, h), (258, 3, grey.dtype.itemsize * 8), (259, 3, 1), (262, 3, 1), (273, 16, None),
            (277, 3, 1), (278, 4, h), (279, 16, len(pixels)), (339, 3, 2 if grey.dtype.kind == "i" else 1)]
    pixels_at = 16 + 8 + 20 * len(tags) + 8  # after the header, the entry count, the entries and the next offset
    entries = b"".join(struct.pack(byte_order + "HHQ", tag, kind, 1)
                       + struct.pack(byte_order + {3: "H", 4: "I", 16: "Q"}[kind], pixels_at if value is None
                                     else value).ljust(8, b"\0") for tag, kind, value in tags)
    head = (b"II" if byte_order == "<" else b"MM") + struct.pack(byte_order + "HHHQ", 43, 8, 0, 16)
    path.write_bytes(head + struct.pack(byte_order + "Q", len(tags)) + entries + bytes(8) + pixels)
    return str(path)


def test_an_integer_grey_bigtiff_reads_over_its_sample_types_largest_value(tmp_path):
    """A BigTIFF (GDAL writes large elevation maps so) was no TIFF to wrt's header reader, though Pillow reads it: its
    16-bit signed grey was divided by the image's own largest sample (1000 read 0.05 where the largest was 20000).
    Now over 32767, as a TIFF's, as OpenImageIO converts it."""
    grey = np.array([[0, 1000, 20000], [7, -300, -32768]], np.int16)
    image = load_image(write_bigtiff(tmp_path / "grey.tif", grey), "raw")
    np.testing.assert_allclose(image[..., 0], grey / 32767.0, rtol=1e-6)


def test_a_big_endian_bigtiff_is_named_as_one_pillow_does_not_open(tmp_path):
    """Pillow opens no big-endian BigTIFF (it takes its header, ``MM`` then version 43, for a classic TIFF's), of
    any samples: the warning said Pillow does not decode its samples ("a TIFF of 1 channel of 16-bit unsigned
    integer samples", which wrt reads in any other TIFF), beside Pillow's "Corrupt EXIF data", a warning of its
    misreading of the header. Now it says what Pillow does not open, and what to do, alone. The same image
    little-endian reads its samples."""
    grey = np.array([[0, 1000, 20000], [7, 300, 65535]], np.uint16)
    with pytest.raises(TextureError, match="a big-endian BigTIFF, which Pillow .* does not open") as refused:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            load_image(write_bigtiff(tmp_path / "big.tif", grey, ">"), "raw")
    assert "samples" not in str(refused.value), refused.value
    # Refused before Pillow opens it: its misreading of the header warned of "Corrupt EXIF data" beside the refusal
    assert [str(w.message) for w in caught] == []
    image = load_image(write_bigtiff(tmp_path / "little.tif", grey, "<"), "raw")
    np.testing.assert_allclose(image[..., 0], grey / 65535.0, rtol=1e-6)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("channels", [3, 4])
def test_16_bit_tiff_textures_are_linear_at_full_precision(tmp_path, byte_order, channels):
    """16-bit RGB(A) TIFFs: Pillow keeps only the high byte, and the 8-bit result was decoded as sRGB under
    sourceColorSpace auto (16-bit data is linear, as for 16-bit PNGs): 0.5 came out as 0.216."""
    samples = np.random.default_rng(7).integers(0, 65536, (3, 5, channels))
    samples[0, 0, :] = 0x8001  # 0.50001 linear; its high byte alone would be 0.502, or 0.216 after sRGB decoding
    image = load_image(write_tiff(tmp_path / "c.tif", samples, byte_order), "auto")
    expected = np.ones((3, 5, 4))
    expected[..., :channels] = samples / 65535.0
    np.testing.assert_allclose(image, expected, atol=1e-7)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("channels", [3, 4])
def test_compressed_16_bit_tiff_textures_are_linear_at_full_precision(tmp_path, byte_order, channels):
    """A compressed TIFF (deflate here; LZW alike) is decoded by libtiff, which hands its 16-bit samples over in the
    machine's byte order (Pillow's raw mode ``RGB;16N``): wrt did not know that raw mode, so Pillow kept the high
    byte and ``auto`` decoded the 8 bits as sRGB: 0.5 read 0.216, as an uncompressed file did before."""
    samples = np.random.default_rng(8).integers(0, 65536, (3, 5, channels))
    samples[0, 0, :] = 0x8001
    image = load_image(write_tiff(tmp_path / "c.tif", samples, byte_order, deflate=True), "auto")
    expected = np.ones((3, 5, 4))
    expected[..., :channels] = samples / 65535.0
    np.testing.assert_allclose(image, expected, atol=1e-7)


@pytest.mark.parametrize("deflate", [False, True])
def test_a_16_bit_rgb_tiff_with_an_unnamed_fourth_sample_is_linear_at_full_precision(tmp_path, deflate):
    """A 16-bit TIFF of four samples whose fourth has no stated meaning (ExtraSamples 0) is RGB to Pillow (raw mode
    ``RGBX;16L``), which kept the high byte: ``auto`` decoded the 8 bits as sRGB, 0.5 read 0.216. Its colour reads
    at full precision and linear, as a 16-bit RGB TIFF's; alpha 1, as for RGB."""
    samples = np.random.default_rng(10).integers(0, 65536, (3, 5, 4))
    samples[0, 0, :] = 0x8001
    image = load_image(write_tiff(tmp_path / "x.tif", samples, deflate=deflate, extra_sample=0), "auto")
    np.testing.assert_allclose(image[..., :3], samples[..., :3] / 65535.0, atol=1e-7)
    np.testing.assert_array_equal(image[..., 3], 1.0)


@pytest.mark.parametrize("dtype, sample_format, full", [(np.int16, 2, 32767.0), (np.int32, 2, 2147483647.0),
                                                         (np.float32, 3, 1.0)])
def test_compressed_big_endian_grey_tiffs_read_their_samples(tmp_path, dtype, sample_format, full):
    """libtiff hands a compressed big-endian file's samples over in the machine's byte order, and Pillow unpacked its
    signed and float grey in the file's: deflated, 1000 of 16 bits read -6141 (over 32767: -0.19), a float 0.5 read
    1e34."""
    grey = np.array([[0, 1000, 20000], [7, -300, -32768]], np.float64)
    samples = (grey / 32767.0 if dtype == np.float32 else grey).astype(dtype)[..., None]
    image = load_image(write_tiff(tmp_path / "g.tif", samples, ">", sample_format=sample_format, deflate=True), "raw")
    np.testing.assert_allclose(image[..., 0], samples[..., 0] / full, rtol=1e-6)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("deflate", [False, True])
@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("byte_order", ["<", ">"])
def test_a_white_is_zero_grey_tiff_reads_inverted(tmp_path, dtype, deflate, planar, byte_order):
    """A grey TIFF of PhotometricInterpretation 0 (WhiteIsZero) images 0 as white and its largest value as black
    (TIFF 6.0). Pillow inverts 8-bit samples so (raw mode ``L;I``), but handed 16-bit ones over as stored: white read
    black, a quarter grey 0.25 for 0.75, raw, deflated and tagged plane by plane alike; and it opens no big-endian
    16-bit one, which was named as samples "an EXR holds". Oracle: 1 - samples / full of the samples written here,
    in float64 (``planar``: one sample, PlanarConfiguration 2, read as 1)."""
    full = np.iinfo(dtype).max
    samples = np.random.default_rng(17).integers(0, full + 1, (3, 4, 1)).astype(dtype)
    samples[0, :3, 0] = (0, full // 4, full)
    path = write_tiff(tmp_path / "w.tif", samples, byte_order, rows_per_strip=2, deflate=deflate, planar=planar,
                      photometric=0)
    image = load_image(path, "auto")
    np.testing.assert_allclose(image[..., :3], np.repeat(1.0 - samples / float(full), 3, -1), atol=1e-7)
    np.testing.assert_array_equal(image[..., 3], 1.0)


def straight_colour(samples):
    """``(H, W, 4)`` float64 RGBA of 16-bit RGBA ``samples`` whose colour is premultiplied by alpha: colour over
    alpha (0 where alpha is 0, at most 1, as Pillow divides 8-bit ones), alpha over 65535."""
    samples = np.asarray(samples, np.float64)
    alpha = samples[..., 3:]
    with np.errstate(divide="ignore", invalid="ignore"):
        colour = np.where(alpha > 0, np.minimum(samples[..., :3] / alpha, 1.0), 0.0)
    return np.concatenate([colour, alpha / 65535.0], axis=-1)


def premultiplied_samples(rng, shape):
    """16-bit RGBA samples of colour premultiplied by alpha (rounded down, as stored), with alpha 0, 1 and 65535
    and a colour over its alpha (which straight colour clamps to 1) among them."""
    alpha = rng.integers(0, 65536, shape)
    alpha.flat[:3] = (0, 1, 65535)
    colour = rng.integers(0, 65536, shape + (3,)) * alpha[..., None] // 65535
    colour.flat[3 * 4 : 3 * 4 + 3] = (40000, 20, 65535)
    alpha.flat[4] = 30000  # red 40000 and blue 65535 over an alpha of 30000: read 1
    return np.concatenate([colour, alpha[..., None]], axis=-1)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("deflate", [False, True])
def test_a_16_bit_tiff_of_premultiplied_alpha_reads_straight_colour_at_full_precision(tmp_path, byte_order, deflate):
    """A 16-bit RGBA TIFF whose colour is premultiplied by alpha (ExtraSamples 1; Pillow's raw mode ``RGBa;16``)
    reads as its 8-bit kin does (Pillow divides colour by alpha at 8 bits) but at full precision: colour over alpha
    of the samples written here by the TIFF 6.0 layout, in float64. Pillow divided their high bytes: 0.03 off."""
    samples = premultiplied_samples(np.random.default_rng(41), (3, 5))
    path = write_tiff(tmp_path / "a.tif", samples, byte_order, deflate=deflate, extra_sample=1)
    np.testing.assert_allclose(load_image(path, "auto"), straight_colour(samples), rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("deflate", [False, True])
@pytest.mark.parametrize("past", [0, 1, 2])
def test_an_8_bit_tiff_of_premultiplied_alpha_reads_colour_over_alpha_unrounded(tmp_path, deflate, past):
    """An 8-bit RGBA TIFF of premultiplied colour (ExtraSamples 1, pixel by pixel): Pillow's ``RGBa`` unpacker
    divides by alpha truncating to 8 bits (100 over 201 read 126/255, not 126.87/255: 3.4e-3 off); its colour reads
    over its alpha in float32 now, as 8-bit grey, 16-bit colour and planes do, and is sRGB under ``auto`` as 8-bit
    colour is. ``past``: samples of no stated meaning past alpha (ExtraSamples 1, 0 and 1, 0, 0; Pillow's ``RGBaX``
    and ``RGBaXX`` unpackers, which truncated alike: 3.8e-3 off after the fix of ``RGBa``). Oracle: colour over alpha
    of the samples written here, in float64."""
    rng = np.random.default_rng(65)
    alpha = rng.integers(0, 256, (3, 5, 1))
    samples = np.concatenate([rng.integers(0, 256, (3, 5, 3)) * alpha // 255, alpha], axis=-1)
    samples[0, 0] = (100, 50, 0, 201)
    samples[0, 1, 3] = 0
    written = np.concatenate([samples, rng.integers(0, 256, (3, 5, past))], axis=-1).astype(np.uint8)
    c = written.shape[2]
    tags = {256: (LONG, [5]), 257: (LONG, [3]), 258: (SHORT, [8] * c), 259: (SHORT, [8 if deflate else 1]),
            262: (SHORT, [2]), 277: (SHORT, [c]), 278: (LONG, [2]), 284: (SHORT, [1]), 338: (SHORT, [1] + [0] * past)}
    strips = [written[r : r + 2].tobytes() for r in (0, 2)]
    path = tmp_path / "a8.tif"
    path.write_bytes(tiff_file(tags, [zlib.compress(strip) for strip in strips] if deflate else strips))
    path = str(path)
    alpha = samples[..., 3:].astype(np.float64)
    colour = np.where(alpha > 0, np.minimum(samples[..., :3] / np.maximum(alpha, 1.0), 1.0), 0.0)
    expected = np.concatenate([colour, alpha / 255.0], axis=-1)
    np.testing.assert_allclose(load_image(path, "raw"), expected, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(load_image(path, "auto")[..., :3], srgb_decoded(colour, 1.0), rtol=1e-5, atol=1e-6)


def straight_grey(samples, full):
    """``(H, W, 2)`` float64 grey and alpha of grey + alpha ``samples`` (whole numbers over ``full``) whose grey is
    premultiplied by alpha (ExtraSamples 1): grey over alpha (0 where alpha is 0, at most 1), alpha over ``full``."""
    samples = np.asarray(samples, np.float64)
    alpha = samples[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        grey = np.where(alpha > 0, np.minimum(samples[..., 0] / alpha, 1.0), 0.0)
    return np.stack([grey, alpha / full], axis=-1)


def premultiplied_grey(rng, shape, full):
    """Grey + alpha samples ``shape + (2,)`` of grey premultiplied by alpha (rounded down, as stored), with alpha 0,
    1 and ``full`` among them and a grey over its alpha (which straight grey clamps to 1)."""
    alpha = rng.integers(0, full + 1, shape)
    alpha.flat[:3] = (0, 1, full)
    grey = rng.integers(0, full + 1, shape) * alpha // full
    grey.flat[:3] = (0, 1, full // 3)
    grey.flat[3], alpha.flat[3] = full // 2, full // 4  # over its alpha: reads 1
    return np.stack([grey, alpha], axis=-1).astype(np.uint8 if full == 255 else np.uint16)


@pytest.mark.parametrize("deflate", [False, True])
def test_an_8_bit_grey_tiff_of_premultiplied_alpha_reads_straight_grey(tmp_path, deflate):
    """Pillow opens an 8-bit grey TIFF of associated alpha (ExtraSamples 1, grey premultiplied by alpha) as mode
    ``La``, which it converts to nothing wrt asks for: load_image raised a bare ValueError naming no file, and the
    load of a stage with such a texture failed as a whole ('/Quad: cannot read this prim (conversion from La to L
    not supported)'). Its grey reads over its alpha (float64 oracle from the samples written here), as 8-bit RGBa
    colour does, and the stage loads without a word."""
    samples = premultiplied_grey(np.random.default_rng(15), (3, 5), 255)
    path = write_tiff(tmp_path / "la.tif", samples, deflate=deflate, extra_sample=1)
    image = load_image(path, "auto")
    expected = straight_grey(samples, 255.0)
    np.testing.assert_allclose(image[..., :3], np.repeat(expected[..., :1], 3, -1), rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(image[..., 3], expected[..., 1], atol=1e-7)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wrt.load_usd(textured_stage(tmp_path, path))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("deflate", [False, True])
@pytest.mark.parametrize("extra_sample", [2, 1, 0])
def test_a_grey_and_alpha_tiff_stored_plane_by_plane_reads_its_samples(tmp_path, dtype, byte_order, deflate,
                                                                       extra_sample):
    """A grey + alpha TIFF stored plane by plane (PlanarConfiguration 2), two strips to a plane: Pillow decoded a
    compressed 8-bit one's alpha plane into no band (alpha 0: the texture drawn fully transparent without a word),
    knew no raw mode for an uncompressed one, and opens no 16-bit one. Each plane is read alone now
    (``tiff_plane``), as 16-bit colour planes are: grey and alpha over the type's largest value, grey premultiplied
    by alpha (ExtraSamples 1) divided by it, and a second sample of no stated meaning (0) ignored, as when the
    samples of a pixel lie together. Oracle: the samples written here, in float64."""
    full = np.iinfo(dtype).max
    samples = premultiplied_grey(np.random.default_rng(16), (3, 5), full)
    samples[0, 4] = (full // 7, 0)  # alpha 0 under unassociated alpha and under none
    path = write_tiff(tmp_path / "pla.tif", samples, byte_order, rows_per_strip=2, deflate=deflate, planar=True,
                      extra_sample=extra_sample)
    image = load_image(path, "auto")
    grey, alpha = samples[..., 0] / float(full), samples[..., 1] / float(full)
    if extra_sample == 1:
        grey, alpha = np.moveaxis(straight_grey(samples, float(full)), -1, 0)
    elif extra_sample == 0:
        alpha = np.ones_like(grey)
    np.testing.assert_allclose(image, np.stack([grey, grey, grey, alpha], axis=-1), rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("deflate", [False, True])
@pytest.mark.parametrize("extra_sample", [2, 0])
def test_a_white_is_zero_grey_and_alpha_tiff_pixel_by_pixel_reads_inverted_grey(tmp_path, byte_order, deflate,
                                                                                 extra_sample):
    """8-bit grey + a second sample of WhiteIsZero (PhotometricInterpretation 0) stored pixel by pixel, the second
    unassociated alpha (ExtraSamples 2) or of no stated meaning (0): Pillow has no mode for it, and it was named as "a
    TIFF of 2 channels of 8-bit unsigned integer samples, which Pillow does not decode; an EXR holds such samples",
    where plane by plane it was read. Now its grey reads inverted (TIFF 6.0), its alpha as stored (1 for a sample of
    no stated meaning). Oracle: the samples written here, in float64."""
    samples = np.random.default_rng(19).integers(0, 256, (3, 5, 2)).astype(np.uint8)
    path = write_tiff(tmp_path / "wla.tif", samples, byte_order, rows_per_strip=2, deflate=deflate, photometric=0,
                      extra_sample=extra_sample)
    image = load_image(path, "auto")
    np.testing.assert_allclose(image[..., :3], np.repeat(1.0 - samples[..., :1] / 255.0, 3, -1), atol=1e-7)
    np.testing.assert_allclose(image[..., 3], samples[..., 1] / 255.0 if extra_sample == 2 else 1.0, atol=1e-7)


def test_a_12_bit_white_is_zero_grey_tiff_reads_inverted_over_4095(tmp_path):
    """A 12-bit grey TIFF of WhiteIsZero: Pillow opens none (it reads 12-bit BlackIsZero grey as 16-bit), named as
    samples it does not decode; now its grey reads ``1 - sample / 4095`` (float64 of the samples written here, each
    row packed 12 bits at a time, most significant bit first)."""
    path = twelve_bit_grey_tiff(tmp_path / "white12.tif", TWELVE_BIT_GREY, photometric=0)
    np.testing.assert_allclose(load_image(str(path), "raw")[..., 0], 1.0 - TWELVE_BIT_GREY / 4095.0, atol=1e-7)


def test_a_white_is_zero_grey_and_alpha_tiff_stored_plane_by_plane_reads_inverted_grey(tmp_path):
    """Grey + unassociated alpha of WhiteIsZero (PhotometricInterpretation 0) stored plane by plane: its grey reads
    inverted (TIFF 6.0), its alpha as stored; each plane is read as a grey TIFF of its own, of BlackIsZero."""
    samples = np.random.default_rng(18).integers(0, 65536, (3, 4, 2)).astype(np.uint16)
    path = write_tiff(tmp_path / "wla.tif", samples, deflate=True, planar=True, photometric=0)
    image = load_image(path, "raw")
    np.testing.assert_allclose(image[..., 0], 1.0 - samples[..., 0] / 65535.0, atol=1e-7)
    np.testing.assert_allclose(image[..., 3], samples[..., 1] / 65535.0, atol=1e-7)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("deflate", [False, True])
@pytest.mark.parametrize("channels, extra_sample", [(3, None), (4, 2), (4, 1), (4, 0)])
def test_a_16_bit_tiff_stored_plane_by_plane_is_linear_at_full_precision(tmp_path, byte_order, deflate, channels,
                                                                          extra_sample):
    """A 16-bit RGB(A) TIFF stored plane by plane (PlanarConfiguration 2), two strips to a plane: Pillow unpacked
    each uncompressed plane as 8-bit samples (0.5 read 0.0003), and its libtiff decoder, which wrt then used, keeps
    the high byte of each plane's samples whatever raw mode it is given (0x1234 read 0x1212). Each plane is read
    alone now, at full depth; premultiplied colour (ExtraSamples 1) divided by alpha, and a fourth sample of no
    stated meaning (0) ignored, as when the samples of a pixel lie together."""
    rng = np.random.default_rng(9)
    samples = (premultiplied_samples(rng, (3, 5)) if extra_sample == 1
               else rng.integers(0, 65536, (3, 5, channels)))
    samples[0, 1, :3] = 0x1234
    path = write_tiff(tmp_path / "p.tif", samples, byte_order, rows_per_strip=2, deflate=deflate, planar=True,
                      extra_sample=extra_sample)
    expected = np.ones((3, 5, 4))
    expected[..., :channels] = samples / 65535.0
    if extra_sample == 1:
        expected = straight_colour(samples)
    elif extra_sample == 0:
        expected[..., 3] = 1.0
    np.testing.assert_allclose(load_image(path, "auto"), expected, rtol=1e-7, atol=1e-7)


def write_tiled_planar_tiff(path, samples, tile=16):
    """A little-endian 16-bit RGBA TIFF of ``samples`` (``(H, W, 4)`` uint16) in deflated ``tile`` x ``tile`` tiles
    (TIFF 6.0 section 15: TileWidth, TileLength, TileOffsets, TileByteCounts; tiles past the image's edge padded),
    plane by plane: every tile of red, then of green, ..."""
    h, w, c = samples.shape
    tiles = []
    for k in range(c):
        for y in range(0, h, tile):
            for x in range(0, w, tile):
                padded = np.zeros((tile, tile), "<u2")
                part = samples[y : y + tile, x : x + tile, k]
                padded[: part.shape[0], : part.shape[1]] = part
                tiles.append(zlib.compress(padded.tobytes()))
    n = len(tiles)
    tags = [(256, 4, 1, w), (257, 4, 1, h), (258, 3, c, "bits"), (259, 3, 1, 8), (262, 3, 1, 2), (277, 3, 1, c),
            (284, 3, 1, 2), (322, 3, 1, tile), (323, 3, 1, tile), (324, 4, n, "offsets"), (325, 4, n, "counts"),
            (338, 3, 1, 2)]
    bits_at = 8 + 2 + 12 * len(tags) + 4  # after the header and the one directory
    at = {"bits": bits_at, "offsets": bits_at + 2 * c, "counts": bits_at + 2 * c + 4 * n}
    pixels_at = at["counts"] + 4 * n
    starts = np.cumsum([pixels_at] + [len(t) for t in tiles[:-1]])
    entries = b"".join(struct.pack("<HHI", tag, kind, count) + (struct.pack("<I", at[value]) if isinstance(value, str)
                       else struct.pack("<HH" if kind == 3 else "<I", value, *([0] if kind == 3 else [])))
                       for tag, kind, count, value in tags)
    data = b"II*\0" + struct.pack("<IH", 8, len(tags)) + entries + bytes(4) + struct.pack(f"<{c}H", *[16] * c)
    data += struct.pack(f"<{n}I", *starts) + struct.pack(f"<{n}I", *map(len, tiles)) + b"".join(tiles)
    path.write_bytes(data)
    return str(path)


def test_a_tiled_16_bit_tiff_stored_plane_by_plane_is_read_at_full_precision(tmp_path):
    """A tiled TIFF stored plane by plane (2 x 2 deflated tiles of 16 x 16 per plane, cut at the edges): each plane's
    tiles are read as a TIFF of its own, at full depth (it kept the high byte of each sample)."""
    samples = np.random.default_rng(47).integers(0, 65536, (20, 18, 4)).astype(np.uint16)
    image = load_image(write_tiled_planar_tiff(tmp_path / "tiled.tif", samples), "raw")
    np.testing.assert_allclose(image, samples / 65535.0, rtol=1e-7, atol=1e-7)


def planar_expected(samples, colour, extra, full):
    """``(H, W, 4)`` float64 RGBA of samples stored plane by plane: ``colour`` grey (1) or RGB (3) samples, then
    alpha where ``extra`` (the first ExtraSamples value) is 1 (colour premultiplied by it: colour over alpha, 0 where
    alpha is 0, at most 1) or 2, else none read; samples past those not read. Each over ``full``."""
    samples = np.asarray(samples, np.float64)
    expected = np.ones(samples.shape[:2] + (4,))
    expected[..., :3] = samples[..., :colour] / full
    if extra in (1, 2):
        alpha = samples[..., colour : colour + 1]
        expected[..., 3:] = alpha / full
        if extra == 1:
            with np.errstate(divide="ignore", invalid="ignore"):
                expected[..., :3] = np.where(alpha > 0, np.minimum(samples[..., :colour] / alpha, 1.0), 0.0)
    return expected


@pytest.mark.parametrize("deflate", [False, True])
@pytest.mark.parametrize("extra_sample", [0, 1, 2])
def test_an_8_bit_rgba_tiff_stored_plane_by_plane_reads_its_samples(tmp_path, deflate, extra_sample):
    """8-bit RGB + a fourth sample stored plane by plane, two strips to a plane: uncompressed, Pillow opens none of
    ExtraSamples 0 (named as samples it does not decode, which an EXR holds) and knows no raw mode for associated
    alpha (ExtraSamples 1: 'unknown raw mode for given image mode', a bare message); deflated, it divides
    premultiplied colour at 8 bits (off by up to 3.9e-3). Each plane is read alone now (``tiff_plane``), as 16-bit
    and grey + alpha planes are: colour over alpha in float32, a fourth sample of no stated meaning not read.
    Oracle: the samples written here, in float64."""
    rng = np.random.default_rng(61)
    samples = rng.integers(0, 256, (3, 5, 4))
    if extra_sample == 1:
        samples[..., :3] = samples[..., :3] * samples[..., 3:] // 255  # premultiplied, rounded down as stored
    samples[0, 0, 3] = 0
    path = write_tiff(tmp_path / "p8.tif", samples.astype(np.uint8), rows_per_strip=2, deflate=deflate, planar=True,
                      extra_sample=extra_sample)
    np.testing.assert_allclose(load_image(path, "raw"), planar_expected(samples, 3, extra_sample, 255.0),
                               rtol=1e-6, atol=1e-7)
    # 8-bit colour is sRGB under auto, as Pillow's read of such a file took it (and Hydra's rule)
    auto = load_image(path, "auto")
    np.testing.assert_allclose(auto[..., :3], srgb_decoded(load_image(path, "raw")[..., :3], 1.0), atol=1e-6)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("colour, photometric", [(1, 1), (3, 2)])
def test_a_tiff_stored_plane_by_plane_of_two_samples_past_its_colour_reads_alpha(tmp_path, dtype, byte_order,
                                                                                  colour, photometric):
    """Grey or RGB stored plane by plane with two samples more (ExtraSamples 2, 0: alpha, then one of no stated
    meaning, as a render's extra pass is saved): Pillow opened no grey one nor a 16-bit one (named as samples it
    does not decode), and knew no raw mode for 8-bit RGB ('unknown raw mode for given image mode'). Alpha is read,
    the sample past it not. Oracle: the samples written here, in float64."""
    full = np.iinfo(dtype).max
    samples = np.random.default_rng(62).integers(0, full + 1, (3, 4, colour + 2))
    path = write_tiff(tmp_path / "x.tif", samples.astype(dtype), byte_order, rows_per_strip=2, planar=True,
                      extra_sample=(2, 0), photometric=photometric)
    np.testing.assert_allclose(load_image(path, "raw"), planar_expected(samples, colour, 2, float(full)),
                               rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("planar", [False, True])
def test_the_fourth_sample_of_rgb_without_extra_samples_is_alpha_plane_by_plane_too(tmp_path, dtype, planar):
    """RGB of four samples without an ExtraSamples tag (TIFF 6.0 asks for one; some writers leave it out): Pillow
    opens it pixel by pixel as RGBA, the fourth sample alpha; plane by plane it is read so too (read as no alpha, all
    1, while planes were first read alike whatever their samples). Oracle: the samples written here, in float64."""
    full = np.iinfo(dtype).max
    samples = np.random.default_rng(66).integers(0, full + 1, (3, 4, 4))
    path = tmp_path / "noextra.tif"
    write_tiff(path, samples.astype(dtype), rows_per_strip=2, planar=planar)
    data = bytearray(path.read_bytes())
    (count,) = struct.unpack_from("<H", data, 8)
    for k in range(count):  # the ExtraSamples entry, the last, made one of a private tag (65000), unread
        if struct.unpack_from("<H", data, 10 + 12 * k)[0] == 338:
            struct.pack_into("<H", data, 10 + 12 * k, 65000)
    path.write_bytes(bytes(data))
    np.testing.assert_allclose(load_image(str(path), "raw"), samples / float(full), rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_tiff_stored_plane_by_plane_without_strip_byte_counts_is_read(tmp_path, dtype):
    """An uncompressed RGB TIFF stored plane by plane, one strip a plane, without StripByteCounts (required by TIFF
    6.0, left out by some writers; libtiff and Pillow infer it): Pillow reads an 8-bit one, but a 16-bit one, read
    plane by plane, was refused ('its planes are not laid out as its header says'). Each plane's TIFF is left
    without byte counts too. Oracle: the samples written here."""
    full = np.iinfo(dtype).max
    samples = np.random.default_rng(63).integers(0, full + 1, (3, 4, 3))
    path = write_tiff(tmp_path / "n.tif", samples.astype(dtype), rows_per_strip=3, planar=True, byte_counts=False)
    np.testing.assert_allclose(load_image(path, "raw")[..., :3], samples / float(full), rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_white_is_zero_grey_of_premultiplied_alpha_is_named_as_undefined(tmp_path, planar, dtype):
    """WhiteIsZero grey premultiplied by alpha (PhotometricInterpretation 0, ExtraSamples 1), which TIFF 6.0 leaves
    undefined and Pillow opens in no layout: it was named as samples Pillow does not decode ('a TIFF of 2 channels
    of 8-bit unsigned integer samples ... an EXR holds such samples'), as if a kind of number were the matter."""
    samples = np.random.default_rng(64).integers(0, 200, (2, 3, 2)).astype(dtype)
    path = write_tiff(tmp_path / "wz.tif", samples, planar=planar, extra_sample=1, photometric=0)
    with pytest.raises(TextureError, match=r"wz\.tif: a TIFF of WhiteIsZero grey .*premultiplied by alpha "
                       r"\(ExtraSamples 1\), which TIFF 6\.0 leaves undefined"):
        load_image(path, "raw")


def test_a_planar_tiff_whose_bits_per_sample_lie_past_its_end_has_no_plane():
    """``tiff_plane`` answers None for a directory cut short, as its docstring says: here the BitsPerSample array
    (three SHORTs, stored at an offset) points a megabyte past the end of a 146-byte file (it raised struct.error)."""
    from wrt.tiff_planes import tiff_plane

    tags = [(256, 3, 1, 2), (257, 3, 1, 2), (258, 3, 3, 10**6), (259, 3, 1, 1), (262, 3, 1, 2), (273, 4, 3, 122),
            (277, 3, 1, 3), (279, 4, 3, 134), (284, 3, 1, 2)]
    entries = b"".join(struct.pack("<HHI", tag, kind, count) + (struct.pack("<HH", value, 0) if count == 1
                                                                else struct.pack("<I", value))
                       for tag, kind, count, value in tags)
    data = b"II*\0" + struct.pack("<IH", 8, len(tags)) + entries + bytes(4)
    data += struct.pack("<3I", 0, 0, 0) + struct.pack("<3I", 8, 8, 8)  # strip offsets at 122, byte counts at 134
    assert len(data) == 146
    assert tiff_plane(data, 0) is None


@pytest.mark.parametrize("dtype, sample_format, byte_order, full", [
    (np.uint16, None, "<", 65535.0), (np.int16, 2, "<", 32767.0), (np.float32, 3, ">", 1.0),
    (np.int32, 2, ">", 2**31 - 1)])
def test_a_grey_tiff_tagged_plane_by_plane_reads_its_samples(tmp_path, dtype, sample_format, byte_order, full):
    """A one-sample TIFF tagged PlanarConfiguration 2 is stored as one tagged 1 (TIFF 6.0: the tag is then
    irrelevant), and libtiff reads it so; Pillow unpacked it by the first letter of its raw mode: 16-bit grey failed
    ('unknown raw mode for given image mode'), signed 16-bit read 6.5e4 off, big-endian floats 2e38 off."""
    rng = np.random.default_rng(13)
    samples = (rng.random((3, 4, 1)) * (1 if dtype == np.float32 else full)).astype(dtype)
    path = write_tiff(tmp_path / "g.tif", samples, byte_order, rows_per_strip=2, sample_format=sample_format,
                      planar=True)
    np.testing.assert_allclose(load_image(path, "raw")[..., 0], samples[..., 0] / full, atol=1e-6)


@pytest.mark.parametrize("dtype, deflate, orientation, channels, planar", [
    (np.uint8, False, 3, 3, False), (np.uint16, False, 3, 3, False), (np.uint16, True, 3, 3, False),
    (np.uint8, False, 6, 3, False), (np.uint16, False, 6, 3, False), (np.uint16, True, 8, 3, False),
    (np.uint16, False, 5, 1, False), (np.uint16, False, 3, 3, True), (np.uint16, True, 6, 3, True)])
def test_tiff_orientation_is_ignored(tmp_path, dtype, deflate, orientation, channels, planar):
    """Storm's TIFF reader (OpenImageIO's read_image) hands the pixels over as stored, whatever the file's
    Orientation tag, as Storm's JPEG reader ignores EXIF orientation (test_jpeg_exif_orientation_is_ignored). Pillow
    turned the pixels by it as it loaded them: orientation 3 (a half turn) drew the texture upside down and
    mirrored, 8-bit, 16-bit and compressed alike. A quarter turn (5 to 8) Pillow 10+ gives the turned size at open:
    a 16-bit one decoded as stored into it failed (SystemError: tile cannot extend outside image)."""
    full = np.iinfo(dtype).max
    samples = np.random.default_rng(11).integers(0, full, (3, 4, channels)).astype(dtype)
    image = load_image(write_tiff(tmp_path / "o.tif", samples, deflate=deflate, orientation=orientation,
                                  planar=planar), "raw")  # (planar: each plane read as a TIFF of its own)
    np.testing.assert_allclose(image[..., :3], np.broadcast_to(samples / full, (3, 4, 3)), atol=1e-7)


@pytest.mark.parametrize("bits", [8, 16])
def test_a_grey_png_transparent_sample_reads_as_alpha_zero(tmp_path, bits):
    """A grey PNG whose tRNS chunk names one sample value transparent (the PNG specification: alpha 0 there, 1
    elsewhere); it was read as opaque everywhere."""
    full = 2**bits - 1
    samples = np.array([[0, full // 2 + 1, full], [full // 2 + 1, 7, 0]], np.uint8 if bits == 8 else np.uint16)
    path = tmp_path / f"grey{bits}.png"
    PilImage.fromarray(samples).save(path, transparency=full // 2 + 1)
    assert b"tRNS" in path.read_bytes()
    image = load_image(str(path), "auto")
    np.testing.assert_allclose(image[..., :3], np.repeat(samples[..., None] / full, 3, axis=2), atol=1e-7)
    np.testing.assert_array_equal(image[..., 3], samples != full // 2 + 1)


def test_jpeg_exif_orientation_is_ignored(tmp_path):
    """Storm's reader (stb_image) never reads a JPEG's EXIF orientation, so texels stay in stored order: the image
    is not turned for orientation 6 (which viewers rotate 90 degrees clockwise)."""
    stored = np.repeat(np.repeat(np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]]), 8, 0), 8, 1)
    exif = PilImage.Exif()
    exif[0x0112] = 6  # Orientation
    path = tmp_path / "turned.jpg"
    PilImage.fromarray(stored.astype(np.uint8)).save(path, exif=exif, quality=100, subsampling=0)
    assert PilImage.open(path).getexif()[0x0112] == 6
    image = load_image(str(path), "raw")
    assert image.shape == (16, 16, 4)
    np.testing.assert_allclose(image[4:12:7, 4:12:7, :3], stored[4:12:7, 4:12:7] / 255.0, atol=0.02)


def write_png_with_chunks(path, samples, chunks):
    """An 8-bit PNG with extra ancillary chunks (``(name, data)``: ``gAMA``, ``sRGB``) before its pixels."""
    info = PngImagePlugin.PngInfo()
    for chunk, data in chunks:
        info.add(chunk, data)
    PilImage.fromarray(np.asarray(samples, np.uint8)).save(path, pnginfo=info)
    assert all(chunk in path.read_bytes() for chunk, _ in chunks)
    return str(path)


def srgb_decoded(samples, full=255.0):
    """The sRGB transfer function inverted in float64 (IEC 61966-2-1), of samples whose largest value is ``full``
    (8-bit samples by default)."""
    x = np.asarray(samples, np.float64) / full
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


GAMMA_SRGB = (b"gAMA", struct.pack(">I", 45455))  # 1 / 2.2 in units of 1e-5
GAMMA_LINEAR = (b"gAMA", struct.pack(">I", 100000))
SRGB_CHUNK = (b"sRGB", b"\0")  # perceptual intent


@pytest.mark.parametrize(
    "samples, chunks, srgb",
    [
        ([[0, 128, 255]], [GAMMA_SRGB], True),  # grey tagged 1/2.2: sRGB
        ([[[200, 128, 3]]], [GAMMA_LINEAR], False),  # colour tagged linear: raw
        ([[0, 128, 255]], [SRGB_CHUNK], True),  # grey with an sRGB chunk: sRGB (Storm reads no sRGB chunk: raw)
        ([[0, 128, 255]], [(b"gAMA", struct.pack(">I", 22000))], False),  # another gamma: grey stays raw
        ([[[200, 128, 3]]], [SRGB_CHUNK, GAMMA_LINEAR], False),  # both: gAMA decides, as in Storm
        ([[0, 128, 255]], [SRGB_CHUNK, (b"gAMA", struct.pack(">I", 80000))], True),  # gAMA 0.8, unread: the chunk
    ],
    ids=["grey_gamma_1/2.2", "colour_gamma_1", "grey_srgb_chunk", "grey_gamma_0.22", "colour_srgb_chunk_gamma_1",
         "grey_srgb_chunk_gamma_0.8"],
)
@pytest.mark.filterwarnings("ignore:PNG .*is neither sRGB's:UserWarning")  # gAMA 0.22: its own test's
def test_auto_follows_a_png_colour_space_chunk(tmp_path, samples, chunks, srgb):
    """UsdUVTexture's ``auto`` reads colour space metadata first (gAMA near 1/2.2 or an sRGB chunk: sRGB, gAMA near
    1: raw, with the tolerance of Hydra's PNG reader, which decides by gAMA alone where there is one it knows);
    only without it do 8-bit colour images read as sRGB. ``raw`` and ``sRGB`` authored on the shader still win."""
    path = write_png_with_chunks(tmp_path / "tagged.png", samples, chunks)
    samples = np.asarray(samples, np.float64)
    grey = samples.ndim == 2
    rgb = np.repeat(samples[..., None], 3, axis=2) if grey else samples
    expected = srgb_decoded(rgb) if srgb else rgb / 255.0
    np.testing.assert_allclose(load_image(path, "auto")[..., :3], expected, atol=1e-6)
    np.testing.assert_allclose(load_image(path, "raw")[..., :3], rgb / 255.0, atol=1e-6)
    np.testing.assert_allclose(load_image(path, "sRGB")[..., :3], srgb_decoded(rgb), atol=1e-6)


@pytest.mark.parametrize("gamma", [22000, 55556])
def test_a_png_gamma_auto_does_not_decode_is_named(tmp_path, gamma):
    """A ``gAMA`` neither near 1/2.2 nor near 1 (0.22; 1/1.8, just past the tolerance) is decoded by no transfer
    function: ``auto`` reads the file as if it had none (grey: as stored), as Storm's reader does after its
    "Unsupported gamma encoding" warning. wrt gave none; the file and the gamma are named now, under ``auto`` only
    (``raw`` and ``sRGB`` say what the file is)."""
    path = write_png_with_chunks(tmp_path / "odd.png", [[0, 128, 255]], [(b"gAMA", struct.pack(">I", gamma))])
    with pytest.warns(UserWarning, match=rf"odd\.png: gAMA {gamma / 1e5:.5g} is neither sRGB's 1/2\.2 nor linear 1"):
        image = load_image(path, "auto")
    np.testing.assert_allclose(image[0, :, 0], np.array([0, 128, 255]) / 255.0, atol=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_image(path, "raw")
        load_image(path, "sRGB")


def damaged_files(tmp_path):
    """Files a reader starts on and cannot finish: cut PNG and JPEG pixel data, an EXR of a header's first bytes,
    an empty file, text named ``.png``."""
    rng = np.random.default_rng(3)
    png, jpg = tmp_path / "whole.png", tmp_path / "whole.jpg"
    PilImage.fromarray(rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)).save(png)
    PilImage.fromarray(rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)).save(jpg)
    return {
        "cut.png": png.read_bytes()[: png.stat().st_size // 2],
        "cut.jpg": jpg.read_bytes()[:400],
        "header.exr": b"\x76\x2f\x31\x01" + bytes(20),
        "empty.png": b"",
        "text.png": b"not an image",
    }


@pytest.mark.parametrize("bits", [8, 16])
def test_an_rgb_png_colour_key_reads_as_alpha_zero(tmp_path, bits):
    """An RGB PNG whose tRNS chunk names one colour transparent (a colour key: alpha 0 where all three samples
    equal it, 1 elsewhere, as the PNG specification and Storm's stb_image reader, ``stbi__compute_transparency16``
    on the 16-bit samples, have it). The file is written chunk by chunk here. A 16-bit one was read as opaque
    everywhere (Pillow keeps the key but applies it to 8-bit images only)."""
    full = 2**bits - 1
    key = (full // 3, full // 2, full - 2)
    near = (key[0], key[1], key[2] + 1)  # one step off in blue only: the same high byte at 16 bits
    samples = np.array([[key, near, (0, 0, 0)], [(full, full, full), key, (key[2], key[1], key[0])]],
                       np.uint8 if bits == 8 else np.uint16)
    path = tmp_path / f"keyed{bits}.png"
    path.write_bytes(rgb_png(samples, key))
    image = load_image(str(path), "raw")
    np.testing.assert_allclose(image[..., :3], samples / full, atol=1e-7)
    np.testing.assert_array_equal(image[..., 3], np.any(samples != key, axis=-1))


@pytest.mark.parametrize("name", ["cut.png", "cut.jpg", "header.exr", "empty.png", "text.png"])
def test_a_damaged_texture_warns_naming_the_file_and_reads_the_fallback(tmp_path, name):
    (tmp_path / name).write_bytes(damaged_files(tmp_path)[name])
    path = textured_stage(tmp_path, str(tmp_path / name))
    with pytest.warns(UserWarning, match=name.replace(".", r"\.")):
        scene = wrt.load_usd(path)
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


def write_exr(path, channels):
    """A scanline EXR of ``channels`` (name -> ``(H, W)`` samples, float32 or float16), written by OpenEXR."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {k: np.ascontiguousarray(v) for k, v in channels.items()}) as f:
        f.write(str(path))
    return str(path)


# Channel sets and the RGBA each reads as, the letters naming the channels written, by the UsdPreviewSurface
# specification's rule for a texture's channel count (UsdUVTexture's outputs): the channels wrt reads (R, G, B, A,
# or Y without colour; others such as Z are ignored) taken in R G B A order, one channel is grey with alpha 1, two
# are grey (the first) and alpha (the second), three or four sit in their places (a missing colour channel 0,
# alpha 1 without A, as OpenEXR's RGBA interface fills them).
EXR_CHANNEL_SETS = {
    "R G": ({"R": "R", "G": "G"}, ("R", "R", "R", "G")),
    "R G B": ({"R": "R", "G": "G", "B": "B"}, ("R", "G", "B", 1)),
    "R G B A Z": ({"R": "R", "G": "G", "B": "B", "A": "A", "Z": "Z"}, ("R", "G", "B", "A")),
    "R G A": ({"R": "R", "G": "G", "A": "A"}, ("R", "G", 0, "A")),
    "R A": ({"R": "R", "A": "A"}, ("R", "R", "R", "A")),
    "B G": ({"B": "B", "G": "G"}, ("G", "G", "G", "B")),
    "G A Z": ({"G": "G", "A": "A", "Z": "Z"}, ("G", "G", "G", "A")),
    "Y": ({"Y": "Y"}, ("Y", "Y", "Y", 1)),
    "Y A": ({"Y": "Y", "A": "A"}, ("Y", "Y", "Y", "A")),
    "A": ({"A": "A"}, ("A", "A", "A", 1)),
    "R only": ({"R": "R"}, ("R", "R", "R", 1)),
    "R Z": ({"R": "R", "Z": "Z"}, ("R", "R", "R", 1)),  # Z is no channel wrt reads: one channel, grey
    "words": ({"red": "R", "Green": "G", "BLUE": "B", "alpha": "A"}, ("R", "G", "B", "A")),
    "lower case": ({"r": "R", "g": "G", "b": "B"}, ("R", "G", "B", 1)),
    "layer R G": ({"diffuse.R": "R", "diffuse.G": "G", "Z": "Z"}, ("R", "R", "R", "G")),
    "unnamed layer first": ({"R": "R", "G": "G", "B": "B", "spec.R": "Z", "spec.G": "Z", "spec.B": "Z"},
                            ("R", "G", "B", 1)),
}


@pytest.mark.parametrize("half", [False, True], ids=["float", "half"])
@pytest.mark.parametrize("case", list(EXR_CHANNEL_SETS))
def test_exr_channel_subsets_map_by_the_specifications_channel_count_rule(tmp_path, case, half):
    """EXRs of part of R, G, B, A, or of luminance, or with the channels named as words, in lower case or in a
    layer: R G (a two-channel map), R A and names such as ``red`` were refused as having no RGB or Y channels. Two
    channels were read in their places (R G as ``(R, G, 0, 1)``, R A as ``(R, 0, 0, A)``) where the specification
    reads any two-channel texture as grey and alpha, as wrt reads a grey + alpha PNG; an alpha-only file as
    ``(0, 0, 0, A)`` and R beside an ignored Z as ``(R, 0, 0, 1)`` where a one-channel texture is grey, alpha 1."""
    names, expected_letters = EXR_CHANNEL_SETS[case]
    rng = np.random.default_rng(11)
    values = {letter: rng.random((3, 5)).astype(np.float16 if half else np.float32) for letter in "RGBAYZ"}
    path = write_exr(tmp_path / "subset.exr", {name: values[letter] for name, letter in names.items()})
    expected = np.stack([values[e].astype(np.float64) if isinstance(e, str) else np.full((3, 5), float(e))
                         for e in expected_letters], axis=-1)
    np.testing.assert_array_equal(load_image(path, "auto"), expected)


@pytest.mark.parametrize("case", ["depth only", "two layers"])
def test_an_exr_of_no_colour_channel_warns_naming_the_file_and_reads_the_fallback(tmp_path, case):
    """A channel named neither R, G, B, Y nor A (Hydra's reader leaves it black), or colour in two layers and none
    unnamed: which is the image is not known, so the material says so and takes the texture's fallback. A lone Z
    channel was drawn as grey."""
    ones = np.ones((2, 2), np.float32)
    channels = {"Z": ones} if case == "depth only" else {f"{layer}.{c}": ones for layer in ("a", "b") for c in "RGB"}
    path = write_exr(tmp_path / "odd.exr", channels)
    with pytest.warns(UserWarning, match=r"odd\.exr.*(no R, G, B, Y or A channel|several layers)"):
        scene = wrt.load_usd(textured_stage(tmp_path, path))
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


@pytest.mark.parametrize("uint_channels", ["R", "RGB"])
def test_an_exr_of_uint_colour_warns_naming_the_file_and_channel_and_reads_the_fallback(tmp_path, uint_channels):
    """R, G, B, A or Y of type UINT (an id or count map) is refused: Storm's EXR reader converts UINT to neither half
    nor float and draws the texture's fallback for a file of them (one whose first channel is UINT); wrt read the
    ids as light (4e9 clipped to 65504)."""
    ids = np.array([[7, 4_000_000_000], [0, 1]], np.uint32)
    channels = {c: ids if c in uint_channels else np.ones((2, 2), np.float32) for c in "RGB"}
    path = write_exr(tmp_path / "ids.exr", channels)
    with pytest.warns(UserWarning, match=rf"ids\.exr: channel {', '.join(sorted(uint_channels))} holds unsigned"):
        scene = wrt.load_usd(textured_stage(tmp_path, path))
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


def test_texels_float16_cannot_hold_are_named_in_a_warning(tmp_path):
    """The device keeps material texels as float16 (each image scaled by a power of two, so an HDR's 1e6 sun fits): a
    NaN texel is read as 0 and an infinite one is clamped; this happened without a word."""
    pytest.importorskip("OpenEXR")
    red = np.ones((2, 3), np.float32)
    red[0, 0], red[0, 1], red[1, 2] = np.nan, 1e6, -np.inf
    path = write_exr(tmp_path / "hot.exr", {"R": red, "G": np.ones((2, 3), np.float32), "B": red})
    nan = 2 * int(np.isnan(red).sum())  # R and B
    infinite = 2 * int(np.isinf(red).sum())
    counts = rf"\({nan} NaN, {infinite} infinite of 24 values: 1\)"
    with pytest.warns(UserWarning, match=rf"texture .*hot\.exr: texels that are NaN or infinite were changed "
                                         rf".*{counts}: /Looks/Tex/Image"):
        wrt.load_usd(textured_stage(tmp_path, path))


def test_an_exr_uint_channel_beside_colour_is_ignored(tmp_path):
    """A UINT channel that is no colour (an ``id`` beside float R, G, B) is ignored as other channels are."""
    rgb = np.random.default_rng(5).random((2, 3, 3)).astype(np.float32)
    channels = {c: rgb[..., k] for k, c in enumerate("RGB")} | {"id": np.arange(6, dtype=np.uint32).reshape(2, 3)}
    image = load_image(write_exr(tmp_path / "beauty.exr", channels), "auto")
    np.testing.assert_array_equal(image, np.concatenate([rgb, np.ones((2, 3, 1), np.float32)], axis=-1))


# Luminance weights of R, G, B as published: Rec.709 (SMPTE RP 177 from its primaries and D65) and ACES AP1
# (ACEScg; ACES TB-2014-004), for files without and with a chromaticities attribute.
LUMINANCE_WEIGHTS = {"rec709": (None, (0.212639, 0.715169, 0.072192)),
                     "ap1": ((0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767),
                             (0.2722287168, 0.6740817658, 0.0536895174))}


def luminance_chroma(rgb, weights):
    """Y, RY = (R - Y) / Y and BY = (B - Y) / Y of ``(H, W, 3)`` float64 RGB (OpenEXR's luminance-chroma
    channels)."""
    y = rgb @ np.asarray(weights)
    return y, (rgb[..., 0] - y) / y, (rgb[..., 2] - y) / y


def yc_exr(tmp_path, rgb, weights, chromaticities, subsampled, alpha=None):
    """An EXR of ``rgb`` as Y, RY, BY (and A), written byte by byte; the chroma at every pixel, or at the even x and
    y only (2 x 2 sampling, as OpenEXR's RgbaOutputFile writes WRITE_YC files)."""
    from exr_bytes import half_exr

    h, w, _ = rgb.shape
    y, ry, by = luminance_chroma(rgb, weights)
    step = 2 if subsampled else 1
    channels = {"Y": y, "RY": ry[::step, ::step], "BY": by[::step, ::step]} | ({} if alpha is None else {"A": alpha})
    sampling = {"RY": (step, step), "BY": (step, step)}
    path = tmp_path / "yc.exr"
    path.write_bytes(half_exr(w, h, channels, sampling, chromaticities))
    return str(path)


@pytest.mark.parametrize("subsampled", [True, False], ids=["2x2", "full"])
@pytest.mark.parametrize("primaries", list(LUMINANCE_WEIGHTS))
def test_a_luminance_chroma_exr_reads_as_its_rgb(tmp_path, primaries, subsampled):
    """Y, RY, BY (+ A) EXRs read as the colour they were made of, the luminance weights from the file's
    chromaticities (Rec.709 without them), as OpenEXR's RgbaInputFile reads them; one hue at many brightnesses, so
    the subsampled chroma is whole. They read grey (Y alone)."""
    pytest.importorskip("OpenEXR")
    chromaticities, weights = LUMINANCE_WEIGHTS[primaries]
    rng = np.random.default_rng(17)
    rgb = rng.uniform(0.05, 4.0, (6, 10, 1)) * np.array([0.9, 0.35, 0.1])
    alpha = rng.random((6, 10))
    image = load_image(yc_exr(tmp_path, rgb, weights, chromaticities, subsampled, alpha), "auto")
    np.testing.assert_allclose(image[..., :3], rgb, rtol=3e-3)  # half floats: 2^-11 per rounding, a few of them
    np.testing.assert_allclose(image[..., 3], alpha, atol=5e-4)


def test_a_luminance_chroma_exr_of_any_colours_at_every_pixel_reads_as_its_rgb(tmp_path):
    """Chroma stored at every pixel (which RgbaInputFile refuses) is converted pixel by pixel: any colours."""
    pytest.importorskip("OpenEXR")
    rgb = np.random.default_rng(19).uniform(0.05, 2.0, (5, 7, 3))
    image = load_image(yc_exr(tmp_path, rgb, LUMINANCE_WEIGHTS["rec709"][1], None, False), "auto")
    # A component far below Y comes from RY or BY near -1: half precision of the chroma, relative to Y.
    np.testing.assert_allclose(image[..., :3], rgb, rtol=3e-3, atol=2e-3)
    np.testing.assert_array_equal(image[..., 3], 1.0)


def test_subsampled_chroma_is_interpolated_between_its_samples(tmp_path):
    """2 x 2 subsampled chroma varying linearly across the image is rebuilt at the pixels between samples (OpenEXR's
    symmetric filter, whose weights sum to 1, keeps a linear ramp away from the edges), under luminance that
    changes at every pixel; nearest-sample chroma would be a step off."""
    pytest.importorskip("OpenEXR")
    h = w = 40
    yy, xx = np.mgrid[0:h, 0:w] / 40.0
    ry, by = 0.6 * xx - 0.3 + 0.2 * yy, 0.5 * yy - 0.4 + 0.1 * xx  # chroma ramps (saturation well under 0.75)
    luma = np.random.default_rng(23).uniform(0.2, 1.5, (h, w))
    wr, wg, wb = LUMINANCE_WEIGHTS["rec709"][1]
    r, b = (ry + 1) * luma, (by + 1) * luma
    rgb = np.stack([r, (luma - wr * r - wb * b) / wg, b], axis=-1)
    image = load_image(yc_exr(tmp_path, rgb, (wr, wg, wb), None, True), "auto")
    inner = (slice(14, h - 16), slice(14, w - 16))  # 7 samples from every edge: the filter's taps all inside
    np.testing.assert_allclose(image[inner][..., :3], rgb[inner], rtol=3e-3)
    assert np.all(np.isfinite(image)) and image[..., :3].min() > 0.0


def test_an_exr_of_chroma_sampled_otherwise_warns_naming_the_file_and_reads_the_fallback(tmp_path):
    """RY, BY at one sample per 4 x 4 pixels (RgbaInputFile reads 2 x 2 only): the file is named in a warning and
    the fallback drawn; it was read grey without a word."""
    from exr_bytes import half_exr

    path = tmp_path / "yc4.exr"
    chroma = np.full((2, 2), 0.25)
    path.write_bytes(half_exr(8, 8, {"Y": np.ones((8, 8)), "RY": chroma, "BY": -chroma}, {"RY": (4, 4), "BY": (4, 4)}))
    with pytest.warns(UserWarning, match=r"yc4\.exr.*chroma RY, BY"):
        scene = wrt.load_usd(textured_stage(tmp_path, str(path)))
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


# PNG layouts: (colour type, bit depth, interlaced, transparency), read against the samples written byte by byte.
PNG_LAYOUTS = [(0, d, False, False) for d in (1, 2, 4, 8, 16)] + [(0, d, False, True) for d in (1, 2, 4, 8, 16)] + [
    (3, d, False, t) for d in (1, 2, 4, 8) for t in (False, True)] + [
    (c, d, i, False) for c in (0, 2, 4, 6) for d in (8, 16) for i in (False, True)] + [(3, 4, True, True)]


@pytest.mark.parametrize("colour_type, depth, interlaced, transparent", PNG_LAYOUTS,
                         ids=[f"type{c}-{d}bit{'-adam7' * i}{'-tRNS' * t}" for c, d, i, t in PNG_LAYOUTS])
def test_pngs_of_every_colour_type_depth_and_interlacing_read_their_samples(tmp_path, colour_type, depth,
                                                                             interlaced, transparent):
    """Grey, RGB, palette (with tRNS alpha), grey + alpha and RGBA PNGs at every bit depth the specification allows
    them, Adam7-interlaced or not, grey ones with a transparent sample (tRNS), read as the samples written (scaled
    to [0, 1] by 2^depth - 1; a palette's entries / 255). A 2- or 4-bit grey PNG's transparent sample made no pixel
    transparent (Pillow compares the unscaled sample with the scaled pixels; stb_image scales it).

    Under ``auto`` (no colour space chunk) RGB, RGBA and palette PNGs of every depth read sRGB-decoded, alpha not,
    and grey and grey + alpha ones (with a tRNS sample too) as stored: Hydra's PNG reader (Hio_StbImage) decodes
    where stb_image reports 3 or 4 channels of bytes, which it does for every colour PNG (it hands 16-bit ones over
    as 8-bit samples and expands palettes to RGB, RGBA with tRNS) and for no grey one (1 channel, 2 with tRNS)."""
    rng = np.random.default_rng(29)
    full = 2**depth - 1
    h, w = 7, 11  # Adam7 passes of several sizes, and partial bytes at low depths
    expected = np.ones((h, w, 4))
    extra = {}
    if colour_type == 3:
        palette, alpha = rng.integers(0, 256, (full + 1, 3)), rng.integers(0, 256, full + 1)
        samples = rng.integers(0, full + 1, (h, w))
        expected[..., :3] = palette[samples] / 255.0
        extra = {"palette": palette}
        if transparent:
            extra["trns"] = alpha[: max(1, full)].astype(np.uint8).tobytes()  # fewer entries than colours: 255
            expected[..., 3] = np.concatenate([alpha[: max(1, full)], [255] * (full + 1 - max(1, full))])[samples] / 255
    else:
        channels = {0: 1, 2: 3, 4: 2, 6: 4}[colour_type]
        samples = rng.integers(0, full + 1, (h, w, channels))
        colour = samples[..., : 3 if channels >= 3 else 1] / full
        expected[..., :3] = colour
        if channels in (2, 4):
            expected[..., 3] = samples[..., -1] / full
        if transparent:
            key = int(samples[0, 0, 0])
            extra["trns"] = struct.pack(">H", key)
            expected[..., 3] = samples[..., 0] != key
    path = tmp_path / "layout.png"
    path.write_bytes(png(samples, colour_type, depth, interlaced, **extra))
    np.testing.assert_allclose(load_image(str(path), "raw"), expected, atol=1e-6)
    if colour_type in (2, 3, 6):
        expected[..., :3] = srgb_decoded(expected[..., :3], 1.0)
    np.testing.assert_allclose(load_image(str(path), "auto"), expected, atol=2e-6)


def refused_pngs():
    """PNGs stb_image (Storm's PNG reader) refuses before decoding, which Pillow reads: tRNS beside alpha, after
    the image data, of the wrong length or before the palette, and a palette image without a palette."""
    rng = np.random.default_rng(31)
    rgba, grey = rng.integers(0, 256, (3, 4, 4)), rng.integers(0, 256, (3, 4))
    index, palette = rng.integers(0, 4, (3, 4)), rng.integers(0, 256, (4, 3))
    key = struct.pack(">3H", *rgba[0, 0, :3])
    return {
        "rgba_trns": (png(rgba, 6, 8, trns=key), "beside an alpha channel"),
        "rgba16_trns": (png(rgba * 257, 6, 16, trns=key), "beside an alpha channel"),
        "grey_alpha_trns": (png(rgba[..., :2], 4, 8, trns=key[:2]), "beside an alpha channel"),
        "trns_after_idat": (png(rgba[..., :3], 2, 8, trns=key, trns_after_idat=True), "after the image data"),
        "grey_trns_length": (png(grey, 0, 8, trns=key), "6 bytes in a grey image"),
        "palette_trns_length": (png(index, 3, 8, palette=palette, trns=bytes(6)), "6 alpha values for a palette"),
        "palette_trns_first": (png(index, 3, 8, trns=bytes(2), extra=()), "before the PLTE chunk"),
        "no_palette": (png(index, 3, 8), "without a PLTE chunk"),
    }


@pytest.mark.parametrize("name", list(refused_pngs()))
def test_a_png_stb_image_refuses_warns_naming_the_file_and_reads_the_fallback(tmp_path, name):
    """Such a file is named in a warning with its fault and the texture's fallback drawn, as Storm draws it (its
    stb_image reader fails on it: "tRNS with alpha", "Corrupt PNG"). Pillow read them, ignoring the tRNS chunk (or
    applying one after the image data) or reading palette indices as grey."""
    data, fault = refused_pngs()[name]
    (tmp_path / f"{name}.png").write_bytes(data)
    with pytest.warns(UserWarning, match=rf"{name}\.png: .*{fault}"):
        scene = wrt.load_usd(textured_stage(tmp_path, str(tmp_path / f"{name}.png")))
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, 0.0)  # UsdUVTexture's fallback is black


@pytest.mark.parametrize("top_down", [False, True], ids=["bottom-up", "top-down"])
@pytest.mark.parametrize("alpha_used", [True, False], ids=["alpha", "all-zero"])
def test_a_32_bit_bmp_reads_its_fourth_byte_as_alpha(tmp_path, top_down, alpha_used):
    """A 32-bit uncompressed BMP (BI_RGB, BGRA bytes), written byte by byte, reads its fourth byte as alpha, as
    Storm's stb_image reader does, and opaque where that byte is 0 everywhere (stb_image takes it for unused then).
    Pillow reads it as padding, so the cut-out was opaque."""
    rng = np.random.default_rng(37)
    h, w = 3, 5
    rgba = rng.integers(0, 256, (h, w, 4))
    if not alpha_used:
        rgba[..., 3] = 0
    stored = rgba[..., [2, 1, 0, 3]] if top_down else rgba[::-1, :, [2, 1, 0, 3]]  # BGRA, bottom row first
    pixels = stored.astype(np.uint8).tobytes()
    info = struct.pack("<IiiHHIIiiII", 40, w, -h if top_down else h, 1, 32, 0, len(pixels), 2835, 2835, 0, 0)
    path = tmp_path / "cutout.bmp"
    path.write_bytes(b"BM" + struct.pack("<IHHI", 54 + len(pixels), 0, 0, 54) + info + pixels)
    expected = rgba / 255.0
    if not alpha_used:
        expected[..., 3] = 1.0
    np.testing.assert_allclose(load_image(str(path), "raw"), expected, atol=1e-6)


@pytest.mark.parametrize("make, says", [
    (lambda path: path.write_bytes(b""), "the file is empty"),
    (lambda path: path.write_text("not an image"), "no image reader wrt has (Pillow, OpenEXR, Radiance) knows"),
    (lambda path: path.mkdir(), "it is a folder"),
    # Half floats, which Pillow does not decode (it named no format, as for text): Storm's reader takes them.
    (lambda path: write_tiff(path, np.full((2, 3, 3), 0.5, np.float16).view(np.uint16), sample_format=3),
     "a TIFF of 3 channels of 16-bit floating-point samples, which Pillow"),
])
def test_an_unreadable_texture_s_warning_says_what_is_wrong_in_plain_words(tmp_path, make, says):
    """The warning for a texture that cannot be read names the file and says why, in words a user can act on.
    An empty file said "cannot convert 'NoneType' object to bytes", a file of no image format "cannot identify image
    file <_io.BytesIO object at 0x7f...>" (a memory address, different at each load) and a folder said "cannot
    open" its path twice."""
    make(tmp_path / "odd.png")
    path = textured_stage(tmp_path, str(tmp_path / "odd.png"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.load_usd(path)
    (message,) = [str(w.message) for w in caught if "odd.png" in str(w.message)]
    assert says in message, message
    assert not re.search(r"NoneType|BytesIO|0x[0-9a-f]{6}", message), message
    assert message.count("cannot open") <= 1, message


@pytest.mark.parametrize("colour_type, depth", [(2, 8), (2, 16)])
def test_a_texture_past_pillows_decompression_bomb_limit_is_read(tmp_path, monkeypatch, colour_type, depth):
    """Pillow refuses an image of more than twice ``PIL.Image.MAX_IMAGE_PIXELS`` (179 million pixels by default: a
    16k x 16k texture) and warns of one past it; a 7 x 11 PNG against a limit of 10 stands in for one. It was read as
    the fallback, named as a "decompression bomb DOS attack"; Storm's readers take such textures. Now read as the
    samples written, without a word, and the caller's limit is put back."""
    monkeypatch.setattr(PilImage, "MAX_IMAGE_PIXELS", 10)
    samples = np.random.default_rng(31).integers(0, 2**depth, (7, 11, 3))
    path = tmp_path / "large.png"
    path.write_bytes(png(samples, colour_type, depth))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pixels = load_image(str(path), "raw")
    np.testing.assert_allclose(pixels[..., :3], samples / (2**depth - 1), atol=1e-6)
    assert PilImage.MAX_IMAGE_PIXELS == 10


def test_textures_read_in_two_threads_put_pillows_limit_back(tmp_path, monkeypatch):
    """Two threads read textures, the first done while the second is still inside Pillow (its open held until then):
    each kept the limit it found, so the second put back the None the first had set, and Pillow's decompression-bomb
    check stayed off for good. Now the limit the caller had is back after both (and the warning hook and filters),
    and both read their samples."""
    monkeypatch.setattr(PilImage, "MAX_IMAGE_PIXELS", 10)
    samples = np.random.default_rng(32).integers(0, 256, (7, 11, 3))
    path = tmp_path / "large.png"
    path.write_bytes(png(samples, 2, 8))
    opened, read = PilImage.open, {}
    first_in, second_in, first_done = threading.Event(), threading.Event(), threading.Event()

    def open_in_turn(*args, **kwargs):  # the first reader waits inside for the second, the second for its end
        if threading.current_thread().name == "first":
            first_in.set()
            second_in.wait(10)
        else:
            second_in.set()
            first_done.wait(10)
        return opened(*args, **kwargs)

    def reader():
        name = threading.current_thread().name
        if name == "second":
            first_in.wait(10)
        read[name] = load_image(str(path), "raw")
        if name == "first":
            first_done.set()

    monkeypatch.setattr(PilImage, "open", open_in_turn)
    hook, filters = warnings.showwarning, list(warnings.filters)
    threads = [threading.Thread(target=reader, name=name) for name in ("first", "second")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(30)
    assert PilImage.MAX_IMAGE_PIXELS == 10
    # The warning hook and filters the reads put in place for Pillow's warnings are taken away as the limit is: a
    # hook kept by each read would leave the first's recorder in place, every later warning recorded, never shown.
    assert warnings.showwarning is hook and warnings.filters == filters
    for name in ("first", "second"):
        np.testing.assert_allclose(read[name][..., :3], samples / 255, atol=1e-6)


@pytest.mark.parametrize("depth, kind, payload", [
    (8, b"zTXt", b"XML:com.adobe.xmp\0\0" + zlib.compress(b"<x:xmpmeta/>" * 250_000)),
    (16, b"zTXt", b"XML:com.adobe.xmp\0\0" + zlib.compress(b"<x:xmpmeta/>" * 250_000)),
    (8, b"iCCP", b"printer\0\0" + zlib.compress(b"LUT" * 700_000)),
], ids=["xmp-8bit", "xmp-16bit", "icc-8bit"])
def test_a_png_whose_text_or_icc_chunk_expands_past_a_megabyte_is_read(tmp_path, depth, kind, payload):
    """A PNG carrying a compressed text chunk (an XMP packet of 3 MB, as image editors' histories grow, in ``zTXt``)
    or a 2 MB ICC profile reads its samples: Pillow refuses a chunk that expands past 1 MB
    (``PngImagePlugin.MAX_TEXT_CHUNK``), so the texture read its fallback, named as "Decompressed data too large";
    stb_image skips both. The chunks around it are still read: ``gAMA`` 1 makes ``auto`` read the colour as stored."""
    samples = np.random.default_rng(37).integers(0, 2**depth, (3, 4, 3))
    path = tmp_path / "tagged.png"
    path.write_bytes(png(samples, 2, depth, extra=[(b"gAMA", struct.pack(">I", 100_000)), (kind, payload)]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pixels = load_image(str(path), "auto")
    np.testing.assert_allclose(pixels[..., :3], samples / (2**depth - 1), atol=1e-6)


def with_a_tag_past_the_end(path):
    """TIFF ``path`` (little-endian, as :func:`write_tiff` writes it) given an ImageDescription (tag 270, 5000 ASCII
    bytes) whose offset points past the file's end: its one directory copied to the end with the entry added
    (TIFF 6.0: entries in ascending order of tag) and the header pointed at the copy. Pillow skips the tag and warns,
    naming no file ("Tag data larger than file. Skipping tag 270")."""
    data = bytearray(open(path, "rb").read())
    (directory,) = struct.unpack_from("<I", data, 4)
    (count,) = struct.unpack_from("<H", data, directory)
    entries = [bytes(data[directory + 2 + 12 * k : directory + 14 + 12 * k]) for k in range(count)]
    entries.append(struct.pack("<HHII", 270, 2, 5000, 1 << 30))
    entries.sort(key=lambda e: struct.unpack("<H", e[:2]))
    at = len(data) + len(data) % 2  # a directory starts on a word boundary
    data += bytes(at - len(data)) + struct.pack("<H", len(entries)) + b"".join(entries) + bytes(4)
    struct.pack_into("<I", data, 4, at)
    open(path, "wb").write(bytes(data))
    return path


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_pillows_warning_on_a_texture_names_the_file_and_the_shader_once(tmp_path, dtype):
    """Pillow's warnings while it opens a texture ("Tag data larger than file. Skipping tag 270" of a damaged TIFF
    tag) named no file, and none the shader reading it; a 16-bit TIFF, opened once per byte, gave it three times.
    Now one warning names the file and the shader, with Pillow's words, and the samples read as written."""
    samples = np.random.default_rng(43).integers(0, np.iinfo(dtype).max, (2, 3, 3)).astype(dtype)
    tif = with_a_tag_past_the_end(write_tiff(tmp_path / "tagged.tif", samples, rows_per_strip=2))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(textured_stage(tmp_path, tif, color_space="raw"))
    messages = [str(w.message) for w in caught]
    (message,) = [m for m in messages if "Skipping tag 270" in m]
    assert "tagged.tif: Pillow warned while reading it: Tag data larger than file" in message, message
    assert message.endswith("/Looks/Tex/Image"), message
    np.testing.assert_allclose(scene.textures[0][..., :3], samples / np.iinfo(dtype).max, atol=1e-6)
    with pytest.warns(wrt.textures.TextureWarning, match=r"image .*tagged\.tif: Pillow warned") as direct:
        load_image(tif, "raw")
    assert len([w for w in direct if "Skipping tag 270" in str(w.message)]) == 1


def test_pillows_warning_on_a_light_texture_names_the_file_and_the_light(tmp_path):
    """A light's texture alike: the warning names the file and the light."""
    samples = np.full((2, 4, 3), 200, np.uint8)
    with_a_tag_past_the_end(write_tiff(tmp_path / "sky.tif", samples, rows_per_strip=2))
    (tmp_path / "dome.usda").write_text('#usda 1.0\ndef DomeLight "Dome"\n{\n'
                                        '    asset inputs:texture:file = @sky.tif@\n}\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.load_usd(tmp_path / "dome.usda")
    (message,) = [str(w.message) for w in caught if "Skipping tag 270" in str(w.message)]
    assert "sky.tif: Pillow warned while reading it" in message and message.endswith(": /Dome"), message


def test_an_undecoded_png_gamma_names_the_shader_too(tmp_path):
    """wrt's own warning of a PNG ``gAMA`` that ``auto`` does not decode named the file alone; read by a shader it
    names the shader too, as the other warnings of a texture file do."""
    path = write_png_with_chunks(tmp_path / "odd.png", [[0, 128, 255]], [(b"gAMA", struct.pack(">I", 22000))])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.load_usd(textured_stage(tmp_path, path))
    (message,) = [str(w.message) for w in caught if "gAMA" in str(w.message)]
    assert "odd.png: PNG gAMA 0.22 is neither sRGB's" in message and message.endswith("/Looks/Tex/Image"), message


@pytest.mark.parametrize("user_filter", [{"message": "Tag data larger than file"}, {"module": "PIL"}],
                         ids=["by-words", "by-module"])
def test_a_users_filter_of_pillows_warnings_holds_while_a_texture_is_read(tmp_path, user_filter):
    """A warning of Pillow's the user filtered out (by its words or Pillow's module, as one silences "Possibly
    corrupt EXIF data") stays out while a texture is read. The read put an "always" filter for Pillow's module ahead
    of the user's and told the warning again as a TextureWarning of wrt's, past a filter by Pillow's words or
    module: it was shown after all, by load_image and by a shader reading the file."""
    tif = with_a_tag_past_the_end(write_tiff(tmp_path / "tagged.tif", np.full((2, 3, 3), 9, np.uint8),
                                                rows_per_strip=2))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", **user_filter)
        users = list(warnings.filters)
        load_image(tif, "raw")
        wrt.load_usd(textured_stage(tmp_path, tif, color_space="raw"))
        assert warnings.filters == users
    assert not [str(w.message) for w in caught if "Skipping tag 270" in str(w.message)]


@pytest.mark.parametrize("raised, caught", [(TextureError, TextureError), (MemoryError, TextureError),
                                            (KeyboardInterrupt, KeyboardInterrupt)])
def test_a_read_that_raises_inside_pillow_puts_the_warning_hook_back(tmp_path, monkeypatch, raised, caught):
    """A read that ends in an exception inside Pillow (a damaged file, memory running out, Ctrl-C), after Pillow
    warned: the warning hook and filters are the user's again and no read is left counted, so later warnings are
    shown; Pillow's warning given before is told, naming the file; an interrupt is not taken for a bad file. (Checked
    by this review; it held.)"""
    import wrt.textures as textures

    path = write_tiff(tmp_path / "x.tif", np.full((2, 2, 3), 7, np.uint8))

    def load_and_raise(self):
        warnings.warn_explicit("a warning of Pillow's", UserWarning, PilImage.__file__, 1)
        raise raised("inside Pillow")

    monkeypatch.setattr(PilImage.Image, "load", load_and_raise)
    hook, filters = warnings.showwarning, list(warnings.filters)
    with warnings.catch_warnings(record=True) as told:
        warnings.simplefilter("always")
        recorder = warnings.showwarning
        with pytest.raises(caught):
            load_image(path, "raw")
        assert warnings.showwarning is recorder
    assert warnings.showwarning is hook and warnings.filters == filters
    assert textures._WARNING_CAPTURE["readers"] == 0 and textures._WARNING_CAPTURE["records"] == {}
    assert [str(w.message) for w in told] == [f"image {path}: Pillow warned while reading it: a warning of Pillow's"]


def test_the_users_filters_hold_in_another_thread_while_a_texture_is_read(tmp_path, monkeypatch):
    """While one thread reads a texture, another thread's warnings go through the user's filters: the read put
    "always" filters (for TextureWarning and Pillow's module) ahead of the process's, so a TextureWarning the user
    made an error was shown instead, in every thread, while any texture was read."""
    tif = write_tiff(tmp_path / "plain.tif", np.full((2, 3, 3), 9, np.uint8))
    inside, release, opened = threading.Event(), threading.Event(), PilImage.open

    def open_slowly(*args, **kwargs):  # the reading thread waits inside the read until the main thread has warned
        if threading.current_thread().name == "reader":
            inside.set()
            release.wait(10)
        return opened(*args, **kwargs)

    monkeypatch.setattr(PilImage, "open", open_slowly)
    with warnings.catch_warnings():
        warnings.simplefilter("error", wrt.textures.TextureWarning)
        users = list(warnings.filters)
        reader = threading.Thread(target=load_image, args=(str(tif), "raw"), name="reader")
        reader.start()
        try:
            assert inside.wait(10)
            assert warnings.filters == users
            with pytest.raises(wrt.textures.TextureWarning):
                warnings.warn(wrt.textures.TextureWarning("of another texture", "of another texture"))
        finally:
            release.set()
            reader.join(30)


def test_pillows_warning_is_told_for_each_read_under_the_default_action(tmp_path):
    """Under Python's ``default`` action (a warning once per place), Pillow's warning on a file is told by each read
    of it, for each shader and light that reads it: Python's note that Pillow gave it is forgotten as a read begins."""
    tif = with_a_tag_past_the_end(write_tiff(tmp_path / "tagged.tif", np.full((2, 3, 3), 9, np.uint8),
                                                rows_per_strip=2))
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        for _ in range(2):
            told = []
            load_image(tif, "raw", told.append)
            assert told == ["Pillow warned while reading it: Tag data larger than file. Skipping tag 270"]


def test_a_catch_warnings_of_another_thread_around_a_read_end_leaves_warnings_shown(tmp_path, monkeypatch):
    """``warnings.catch_warnings`` in one thread, entered while another reads a texture and left after that read
    ends, puts back the read's recorder as the process's hook (Python's catch_warnings is not thread-safe). The next
    read took that recorder for the hook to pass other warnings on to: a warning given in another thread while it ran
    called the recorder without end (RecursionError). Now the hook kept from before is passed on to, and put back."""
    tif = write_tiff(tmp_path / "plain.tif", np.full((2, 3, 3), 9, np.uint8))
    opened = PilImage.open
    gates = {}

    def open_slowly(*args, **kwargs):  # a thread named "reader..." waits inside the read until told to go on
        gate = gates.get(threading.current_thread().name)
        if gate is not None:
            gate[0].set()
            gate[1].wait(10)
        return opened(*args, **kwargs)

    def read_while(name, during):  # a read in thread ``name`` runs while ``during()`` runs here
        gates[name] = (threading.Event(), threading.Event())
        reader = threading.Thread(target=load_image, args=(str(tif), "raw"), name=name)
        reader.start()
        try:
            assert gates[name][0].wait(10)
            during(gates[name][1], reader)
        finally:
            gates[name][1].set()
            reader.join(30)

    def another_threads_catch_warnings(release, reader):
        with warnings.catch_warnings():
            release.set()
            reader.join(30)

    monkeypatch.setattr(PilImage, "open", open_slowly)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hook = warnings.showwarning
        read_while("reader 1", another_threads_catch_warnings)
        read_while("reader 2", lambda release, reader: warnings.warn("another thread's warning", UserWarning))
        assert warnings.showwarning is hook
    assert [str(w.message) for w in caught] == ["another thread's warning"]


def test_a_warning_hook_put_in_place_while_a_texture_is_read_is_kept_after_the_read(tmp_path, monkeypatch):
    """A warning hook put in place while another thread reads a texture (``logging.captureWarnings(True)`` as a
    program sets up its logging, a test tool's recorder) stays the process's hook after the read: the read's end put
    back the hook it had found as it began, so every later warning went past the new hook (printed, not logged).
    Oracle: Python's warnings machinery, a warning given after the read reaching the hook put in place."""
    tif = write_tiff(tmp_path / "plain.tif", np.full((2, 3, 3), 9, np.uint8))
    inside, release, opened = threading.Event(), threading.Event(), PilImage.open

    def open_slowly(*args, **kwargs):  # the reading thread waits inside the read until the hook is in place
        if threading.current_thread().name == "reader":
            inside.set()
            release.wait(10)
        return opened(*args, **kwargs)

    shown = []

    def users_hook(message, category, filename, lineno, file=None, line=None):
        shown.append(str(message))

    monkeypatch.setattr(PilImage, "open", open_slowly)
    with warnings.catch_warnings():  # (puts the hook of before back as it ends)
        warnings.simplefilter("always")
        reader = threading.Thread(target=load_image, args=(str(tif), "raw"), name="reader")
        reader.start()
        try:
            assert inside.wait(10)
            warnings.showwarning = users_hook
        finally:
            release.set()
            reader.join(30)
        assert warnings.showwarning is users_hook
        warnings.warn("a warning after the read", UserWarning)
    assert shown == ["a warning after the read"]
