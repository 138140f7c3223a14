"""TIFFs stored plane by plane (PlanarConfiguration 2) read as textures one plane at a time (``wrt.tiff_planes``):
files whose strips are not as their header says (cut short, too few or too many, of differing depths, compressed
without byte counts) or of a compression Pillow does not know (pixel by pixel too) are named, never read from bytes
that are not the plane's; planes of LZW and JPEG strips, of uncompressed tiles and with a damaged tag read as
written. Files written byte by byte here (``tiff_files``), samples checked in float64 (Pillow's decode of the same
JPEG strips for JPEG)."""

import io
import re
import struct
import warnings
import zlib

import numpy as np
import pytest
from PIL import Image as PilImage
from tiff_files import BYTE, LONG, SHORT, TILES, UNDEFINED, tiff_file

from wrt.textures import TextureError, load_image


def planar_tags(samples, rows=2, compression=1, bits=None, more=()):
    """The tags of an RGB(A) or grey (+ alpha) TIFF of ``samples`` (``(H, W, C)``) stored plane by plane in strips of
    ``rows`` rows (``bits``: BitsPerSample where not the dtype's), unassociated alpha past the colour."""
    h, w, c = samples.shape
    colour = 1 if c <= 2 else 3
    tags = {256: (LONG, [w]), 257: (LONG, [h]), 258: (SHORT, bits or [samples.dtype.itemsize * 8] * c),
            259: (SHORT, [compression]), 262: (SHORT, [1 if colour == 1 else 2]), 277: (SHORT, [c]),
            278: (LONG, [rows]), 284: (SHORT, [2])}
    if c > colour:
        tags[338] = (SHORT, [2])
    tags.update(dict(more))
    return tags


def strips(samples, rows=2, compress=bytes):
    """Each plane's strips of ``rows`` rows, plane after plane, little-endian, each through ``compress``."""
    return [compress(samples[r : r + rows, :, k].astype("<" + samples.dtype.str[1:]).tobytes())
            for k in range(samples.shape[2]) for r in range(0, samples.shape[0], rows)]


def expected(samples, full):
    """``(H, W, 4)`` float64 RGBA of RGB(A) ``samples`` over ``full``, alpha 1 where there is none."""
    rgba = np.ones(samples.shape[:2] + (4,))
    rgba[..., : samples.shape[2]] = samples / full
    return rgba


def read(tmp_path, data, name="p.tif"):
    path = tmp_path / name
    path.write_bytes(data)
    return load_image(str(path), "raw")


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("cut", [3, 14])
def test_a_planar_tiff_cut_short_in_its_last_strip_is_named_as_cut(tmp_path, dtype, cut):
    """A TIFF stored plane by plane whose file ends inside its last strips (a download cut off): each plane was read
    from a copy of the file with a directory appended, so the cut strip read the directory's bytes as samples
    (alpha off by 0.62 of 8 bits, 7.6e-4 of 16 bits) without a word. Now it is named as cut short, as Pillow names a
    cut file of pixels stored together; the whole file reads its samples (float64)."""
    samples = np.random.default_rng(61).integers(0, np.iinfo(dtype).max + 1, (5, 6, 4)).astype(dtype)
    data = tiff_file(planar_tags(samples), strips(samples))
    np.testing.assert_allclose(read(tmp_path, data), expected(samples, np.iinfo(dtype).max), atol=1e-7)
    strip = 11 if cut == 3 else 10  # (the last plane's strips are 9 to 11, the last of one row)
    with pytest.raises(TextureError, match=rf"p\.tif: strip {strip} \(bytes .*\) lies past the file's end "
                                           rf"\({len(data) - cut} bytes\): the file is cut short"):
        read(tmp_path, data[:-cut])


@pytest.mark.parametrize("written_rows, kept", [(1, 20), (3, 8)], ids=["more-strips", "fewer-strips"])
def test_a_planar_tiff_of_more_or_fewer_strips_than_its_size_makes_is_named(tmp_path, written_rows, kept):
    """Strips that are not as many as the image's size and RowsPerStrip make (5 rows in strips of 2: 3 a plane, 12
    for 4 planes): 20 strips of one row each under RowsPerStrip 2, or 8 of 3 rows, were split into planes of 5 or 2
    strips and laid over each other or left rows unread (off by 0.92); now named."""
    samples = np.random.default_rng(62).integers(0, 65536, (5, 6, 4)).astype(np.uint16)
    data = tiff_file(planar_tags(samples), strips(samples, written_rows)[:kept])
    with pytest.raises(TextureError, match=rf"it has {kept} strips, where 4 planes of 6 x 5 pixels in strips of "
                                           r"6 x 2 make 3 a plane"):
        read(tmp_path, data)


def test_a_planar_tiff_of_samples_of_differing_depth_is_named(tmp_path):
    """16-bit colour with an 8-bit alpha plane (BitsPerSample 16, 16, 16, 8): every plane was decoded at the first
    sample's depth, so alpha read two 8-bit samples as one (off by 0.96). libtiff reads no such file either; it is
    named."""
    samples = np.random.default_rng(63).integers(0, 65536, (5, 6, 4)).astype(np.uint16)
    alpha = (samples[..., 3:] >> 8).astype(np.uint8)
    chunks = strips(samples[..., :3]) + strips(alpha)
    with pytest.raises(TextureError, match=r"its samples differ in depth \(BitsPerSample 16, 16, 16, 8\)"):
        read(tmp_path, tiff_file(planar_tags(samples, bits=[16, 16, 16, 8]), chunks))


def test_a_compressed_planar_tiff_without_byte_counts_is_named(tmp_path):
    """Deflated strips without StripByteCounts (which TIFF 6.0 requires; libtiff infers them for uncompressed strips
    alone): the read failed as "decoder error -2" beside libtiff's words on stderr; now named."""
    samples = np.random.default_rng(64).integers(0, 65536, (5, 6, 3)).astype(np.uint16)
    data = tiff_file(planar_tags(samples, compression=8), strips(samples, compress=zlib.compress), byte_counts=False)
    with pytest.raises(TextureError, match=r"its strips are compressed \(Compression 8\) and it has no byte counts"):
        read(tmp_path, data)


def pillow_strip(rows, compression):
    """The one strip of grey ``rows`` as Pillow's libtiff writer compresses it, and its JPEGTables where it has
    them."""
    buffer = io.BytesIO()
    PilImage.fromarray(rows).save(buffer, "TIFF", compression=compression)
    img = PilImage.open(io.BytesIO(buffer.getvalue()))
    ((start,), (size,)) = img.tag_v2[273], img.tag_v2[279]
    return buffer.getvalue()[start : start + size], img.tag_v2.get(347)


@pytest.mark.parametrize("compression, code", [("tiff_lzw", 5), ("jpeg", 7)])
def test_planes_of_lzw_and_jpeg_strips_read_their_samples(tmp_path, compression, code):
    """Planes of LZW strips (16-bit) and of JPEG strips (8-bit, their tables in JPEGTables, a value past its entry
    the plane's directory carries over) read their samples: LZW as written (float64), JPEG as Pillow decodes each
    plane's strips as a grey TIFF of its own."""
    dtype = np.uint16 if code == 5 else np.uint8
    samples = np.random.default_rng(65).integers(0, np.iinfo(dtype).max + 1, (16, 8, 3)).astype(dtype)
    parts = [pillow_strip(np.ascontiguousarray(samples[r : r + 8, :, k]), compression)
             for k in range(3) for r in (0, 8)]
    more = {} if code == 5 else {347: (UNDEFINED, parts[0][1])}
    image = read(tmp_path, tiff_file(planar_tags(samples, 8, code, more=more), [p[0] for p in parts]))
    if code == 5:
        np.testing.assert_allclose(image, expected(samples, 65535.0), atol=1e-7)
        return
    for k in range(3):
        grey = tiff_file(planar_tags(samples[..., :1], 8, code, more=more), [p[0] for p in parts[2 * k : 2 * k + 2]])
        decoded = np.asarray(PilImage.open(io.BytesIO(grey)), np.float64) / 255.0
        np.testing.assert_allclose(image[..., k], decoded, atol=1e-7)
    assert np.abs(image[..., :3] - samples / 255.0).max() < 0.2  # (JPEG: near the samples written)


def test_a_plane_of_uncompressed_tiles_cut_at_the_edges_reads_its_samples(tmp_path):
    """Uncompressed tiles of 16 x 16 over a 20 x 18 image, padded past its edges (TIFF 6.0 section 15), plane by
    plane: each tile is copied whole into its plane's file."""
    samples = np.random.default_rng(66).integers(0, 65536, (20, 18, 4)).astype(np.uint16)
    tiles = []
    for k in range(4):
        for y in (0, 16):
            for x in (0, 16):
                padded = np.zeros((16, 16), "<u2")
                part = samples[y : y + 16, x : x + 16, k]
                padded[: part.shape[0], : part.shape[1]] = part
                tiles.append(padded.tobytes())
    tags = planar_tags(samples, more={322: (SHORT, [16]), 323: (SHORT, [16])})
    del tags[278]
    data = tiff_file(tags, tiles, located=TILES)
    np.testing.assert_allclose(read(tmp_path, data), expected(samples, 65535.0), atol=1e-7)
    with pytest.raises(TextureError, match=r"tile 15 \(bytes .*\) lies past .* cut short"):
        read(tmp_path, data[:-1])


def test_a_damaged_tag_of_a_planar_tiff_is_warned_of_once(tmp_path):
    """An ImageDescription whose 5000 bytes lie past the file's end is skipped, named once for the file (Pillow warned
    of it once a plane, told once), and the samples read as written."""
    samples = np.random.default_rng(67).integers(0, 256, (3, 4, 3)).astype(np.uint8)
    data = bytearray(tiff_file(planar_tags(samples, more={270: (2, b"x" * 5000)}), strips(samples)))
    (count,) = struct.unpack_from("<H", data, 8)
    (entry,) = [10 + 12 * k for k in range(count) if struct.unpack_from("<H", data, 10 + 12 * k)[0] == 270]
    struct.pack_into("<I", data, entry + 8, 1 << 30)  # its values' offset, past the file's end
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = read(tmp_path, bytes(data))
    assert [str(w.message).split(": ", 1)[1] for w in caught] == [
        "TIFF tag 270's values lie past the file's end (a damaged file); the tag is skipped"]
    np.testing.assert_allclose(image, expected(samples, 255.0), atol=1e-7)


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("compression, words", [(34887, "Compression 34887 (LERC)"), (99, "Compression 99")])
def test_a_tiff_of_a_compression_pillow_does_not_know_is_named_by_it(tmp_path, planar, compression, words):
    """A TIFF of a compression Pillow has no decoder for (LERC, as GDAL writes elevation maps; an unknown number),
    pixel by pixel or plane by plane: it was named as "a TIFF of 3 channels of 8-bit unsigned integer samples, which
    Pillow does not decode; an EXR holds such samples", samples wrt reads in any other TIFF. It is named by its
    compression now."""
    samples = np.zeros((2, 3, 3), np.uint8)
    chunks = strips(samples) if planar else [samples[r : r + 2].tobytes() for r in (0,)]
    tags = planar_tags(samples, compression=compression, more={284: (SHORT, [2 if planar else 1])})
    with pytest.raises(TextureError, match=rf"p\.tif: a TIFF of {re.escape(words)}, which Pillow \(wrt's TIFF "
                                           r"reader\) does not decode; save it uncompressed, or with LZW, deflate"):
        read(tmp_path, tiff_file(tags, chunks))


def with_values_past_the_end(data, tag):
    """TIFF ``data`` (little-endian) with the values of its entry ``tag`` pointed past the file's end."""
    data = bytearray(data)
    (count,) = struct.unpack_from("<H", data, 8)
    (entry,) = [10 + 12 * k for k in range(count) if struct.unpack_from("<H", data, 10 + 12 * k)[0] == tag]
    struct.pack_into("<I", data, entry + 8, 1 << 30)
    return bytes(data)


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_tiff_whose_description_lies_past_its_end_reads_its_samples(tmp_path, planar, dtype):
    """An ImageDescription of 50 bytes whose offset points past the file's end (a damaged file): Pillow opens no such
    file (its read of the tag fails, "Truncated File Read"), and wrt named it "a TIFF of 3 channels of 8-bit unsigned
    integer samples, which Pillow does not decode; an EXR holds such samples"; libtiff, under Storm's reader, skips
    the tag. Now the tag is skipped and named, and the samples read as written (float64)."""
    samples = np.random.default_rng(68).integers(0, np.iinfo(dtype).max + 1, (3, 4, 3)).astype(dtype)
    tags = planar_tags(samples, more={270: (2, b"x" * 50), 284: (SHORT, [2 if planar else 1])})
    chunks = strips(samples) if planar else [samples[r : r + 2].astype("<" + samples.dtype.str[1:]).tobytes()
                                             for r in (0, 2)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = read(tmp_path, with_values_past_the_end(tiff_file(tags, chunks), 270))
    np.testing.assert_allclose(image, expected(samples, np.iinfo(dtype).max), atol=1e-7)
    told = [str(w.message).split(": ", 1)[1] for w in caught]
    assert "TIFF tag 270's values lie past the file's end (a damaged file); the tag is skipped" in told, told


@pytest.mark.parametrize("planar", [False, True])
def test_a_tiff_whose_sample_format_lies_past_its_end_is_named(tmp_path, planar):
    """A tag that says how to read the samples (SampleFormat, three values past the entry) pointed past the file's
    end is not skipped (the samples would be read as of another type): the file is named as damaged. It was named as
    samples Pillow does not decode, or of a format no reader of wrt's knows."""
    samples = np.zeros((2, 3, 3), np.uint8)
    tags = planar_tags(samples, more={339: (SHORT, [1, 1, 1]), 284: (SHORT, [2 if planar else 1])})
    chunks = strips(samples) if planar else [samples.tobytes()]
    with pytest.raises(TextureError, match=r"p\.tif: its TIFF tag 339's values lie past the file's end: the file is "
                                           "damaged or cut short"):
        read(tmp_path, with_values_past_the_end(tiff_file(tags, chunks), 339))


@pytest.mark.parametrize("planar", [False, True])
def test_a_tiff_whose_compressed_strip_is_damaged_says_what_libtiff_could_not_do(tmp_path, planar):
    """Deflated strips whose last is damaged (its last 8 bytes, the stream's end and check, zeroed), pixel by pixel or
    plane by plane: the read failed as "decoder error -2", Pillow's words for any failure of its libtiff decoder; the
    words now say what failed and what it means, Pillow's kept."""
    samples = np.random.default_rng(69).integers(0, 256, (4, 5, 3)).astype(np.uint8)
    chunks = (strips(samples, compress=zlib.compress) if planar
              else [zlib.compress(samples[r : r + 2].tobytes()) for r in (0, 2)])
    chunks[-1] = chunks[-1][:-8] + bytes(8)
    tags = planar_tags(samples, compression=8, more={284: (SHORT, [2 if planar else 1])})
    with pytest.raises(TextureError, match=r"p\.tif: libtiff could not decode its compressed strips or tiles "
                                           r"\(Pillow's decoder error -2: decoding error\): their data is damaged, "
                                           "cut short or of a kind libtiff does not read"):
        read(tmp_path, tiff_file(tags, chunks))


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("compression", [1, 8])
def test_a_tiff_of_a_strip_of_no_data_is_named(tmp_path, planar, compression):
    """A strip of offset 0 and byte count 0 (as GDAL writes a sparse file's missing strips and tiles): uncompressed,
    Pillow read the file's header as its samples (off by 0.98 pixel by pixel, 0.84 plane by plane, no word);
    compressed, libtiff refused it ("Invalid strip byte count 0"), told as a decoding failure. It is named."""
    samples = np.random.default_rng(70).integers(0, 65536, (4, 6, 3)).astype(np.uint16)
    chunks = (strips(samples, compress=zlib.compress if compression == 8 else bytes) if planar
              else [(zlib.compress if compression == 8 else bytes)(samples[r : r + 2].astype("<u2").tobytes())
                    for r in (0, 2)])
    tags = planar_tags(samples, compression=compression, more={284: (SHORT, [2 if planar else 1])})
    data = bytearray(tiff_file(tags, chunks))
    (count,) = struct.unpack_from("<H", data, 8)
    for k in range(count):  # the first strip's offset and byte count: 0
        tag, _, n, at = struct.unpack_from("<HHII", data, 10 + 12 * k)
        if tag in (273, 279):
            struct.pack_into("<I", data, at if n > 1 else 10 + 12 * k + 8, 0)
    with pytest.raises(TextureError, match=r"p\.tif: strip 0 has no data \(offset 0, byte count 0: a sparse "
                                           r"file's missing strip or tile, which libtiff does not read either\)"):
        read(tmp_path, bytes(data))


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_an_uncompressed_tiff_whose_byte_counts_are_short_is_named(tmp_path, planar, dtype):
    """Uncompressed strips whose StripByteCounts are short of the bytes their rows fill (here each a row short, the
    strips laid one after another as counted): Pillow, which reads the bytes the rows fill whatever the count says,
    read the next strip's bytes into each (off by 0.86) without a word; libtiff refuses such a strip ("Not enough
    data for scanline"). It is named; the same samples with their full counts read as written (float64)."""
    samples = np.random.default_rng(71).integers(0, np.iinfo(dtype).max + 1, (5, 6, 3)).astype(dtype)
    tags = planar_tags(samples, rows=2, more={284: (SHORT, [2 if planar else 1])})
    row = (1 if planar else 3) * 6 * samples.dtype.itemsize
    chunks = strips(samples) if planar else [samples[r : r + 2].astype("<" + samples.dtype.str[1:]).tobytes()
                                             for r in (0, 2, 4)]
    np.testing.assert_allclose(read(tmp_path, tiff_file(tags, chunks)), expected(samples, np.iinfo(dtype).max),
                               atol=1e-7)
    with pytest.raises(TextureError, match=rf"p\.tif: strip 0 holds {row} bytes, where its rows need {2 * row} "
                                           r"\(uncompressed\): its byte count is short"):
        read(tmp_path, tiff_file(tags, [chunk[:-row] if len(chunk) > row else chunk for chunk in chunks]))


@pytest.mark.parametrize("planar", [False, True])
def test_an_uncompressed_tiff_without_byte_counts_cut_short_is_named(tmp_path, planar):
    """Uncompressed strips without StripByteCounts (their sizes inferred from their rows, as libtiff infers them) in a
    file cut inside its last strip: named as cut short, as with counts."""
    samples = np.random.default_rng(72).integers(0, 65536, (5, 6, 3)).astype(np.uint16)
    tags = planar_tags(samples, more={284: (SHORT, [2 if planar else 1])})
    chunks = strips(samples) if planar else [samples[r : r + 2].astype("<u2").tobytes() for r in (0, 2, 4)]
    data = tiff_file(tags, chunks, byte_counts=False)
    np.testing.assert_allclose(read(tmp_path, data), expected(samples, 65535.0), atol=1e-7)
    last = len(chunks) - 1
    with pytest.raises(TextureError, match=rf"strip {last} \(bytes .*\) lies past the file's end \({len(data) - 5} "
                                           r"bytes\): the file is cut short"):
        read(tmp_path, data[:-5])


def big_tiff(entries, directory_at=16):
    """A little-endian BigTIFF (16-byte header: II, 43, 8, 0, the first directory's 8-byte offset) written byte by
    byte: its directory of ``entries`` (tag, type, count, 8-byte value field) at 16, pointed at by ``directory_at``,
    then 8 bytes of samples."""
    directory = struct.pack("<Q", len(entries)) + b"".join(struct.pack("<HHQ8s", *e) for e in entries) + bytes(8)
    return b"II+\0" + struct.pack("<HHQ", 8, 0, directory_at) + directory + bytes(8)


def test_a_bigtiff_whose_directory_offset_is_past_2_63_is_named(tmp_path):
    """A BigTIFF whose 8-byte offset of its first directory is 2^63 or more (damaged bytes): Python's struct took it
    for no memory address (OverflowError: 'Python int too large to convert to C ssize_t'), which escaped the texture
    reader as itself. It lies past the file's end, as an offset of 2^40 does: the file is named as damaged (Pillow's
    words were 'Unable to seek to frame', of 2^40 that no reader knew its format)."""
    entries = [(256, 3, 1, struct.pack("<H6x", 2)), (257, 3, 1, struct.pack("<H6x", 1)),
               (258, 3, 1, struct.pack("<H6x", 8)), (259, 3, 1, struct.pack("<H6x", 1)),
               (262, 3, 1, struct.pack("<H6x", 1)), (273, 16, 1, struct.pack("<Q", 16 + 8 + 20 * 8 + 8)),
               (277, 3, 1, struct.pack("<H6x", 1)), (279, 16, 1, struct.pack("<Q", 2))]
    path = tmp_path / "big.tif"
    path.write_bytes(big_tiff(entries))
    np.testing.assert_array_equal(load_image(str(path), "raw")[0, :, 3], 1.0)  # (the file, its offset whole, reads)
    for far in (2**40, 2**63 + 16, 2**64 - 1):
        path.write_bytes(big_tiff(entries, far))
        with pytest.raises(TextureError, match="big.tif: its TIFF image file directory lies past the file's end"):
            load_image(str(path), "raw")


def grey_strips_tiff(kept: int, compression: int = 1, extra: bool = False, tiled: bool = False) -> tuple:
    """``(grey, data)``: 4 x 3 8-bit grey (rows 5, 25, 45, ...) as a TIFF written byte by byte of one-row strips (or
    16 x 16 tiles, two down), the first ``kept`` of those its size makes (one more, of zeros, with ``extra``), deflated
    for ``compression`` 8."""
    grey = (np.arange(12).reshape(4, 3) * 20 + 5).astype(np.uint8)
    tags = {256: (SHORT, [3]), 257: (SHORT, [4 if not tiled else 20]), 258: (SHORT, [8]), 259: (SHORT, [compression]),
            262: (SHORT, [1]), 277: (SHORT, [1])}
    if tiled:
        grey = np.resize(grey, (20, 3))
        padded = np.zeros((32, 16), np.uint8)
        padded[:20, :3] = grey
        pieces = [padded[r : r + 16].tobytes() for r in (0, 16)]
        tags.update({322: (SHORT, [16]), 323: (SHORT, [16])})
    else:
        pieces = [grey[r].tobytes() for r in range(4)]
        tags[278] = (SHORT, [1])
    pieces = (pieces + [bytes(len(pieces[0]))] if extra else pieces)[: kept + extra]
    pieces = [zlib.compress(p) for p in pieces] if compression == 8 else pieces
    return grey, tiff_file(tags, pieces, located=TILES if tiled else (273, 279))


@pytest.mark.parametrize("kept, compression, tiled", [(2, 1, False), (3, 1, False), (2, 8, False), (1, 1, True)],
                         ids=["two-strips", "three-strips", "two-deflated-strips", "one-tile"])
def test_a_tiff_of_fewer_strips_than_its_size_makes_is_named(tmp_path, kept, compression, tiled):
    """A TIFF of its pixels' samples together whose strips (tiles) are fewer than its size and RowsPerStrip (tile
    size) make: uncompressed, Pillow read the rows past them as 0 without a word ([[5, 25, 45], [65, 85, 105], [0, 0,
    0], [0, 0, 0]] of two strips of four); deflated, libtiff refused it ('Invalid strip byte count 0'), which was
    told as a decoding failure. Named, as a plane's are; all of them read as written."""
    grey, data = grey_strips_tiff(4 if not tiled else 2, compression, tiled=tiled)
    np.testing.assert_allclose(read(tmp_path, data)[..., 0], grey / 255.0, atol=1e-7)
    kind, made, size = ("tile", 2, "3 x 20 pixels in tiles of 16 x 16") if tiled else (
        "strip", 4, "3 x 4 pixels in strips of 3 x 1")
    with pytest.raises(TextureError, match=rf"p\.tif: it has {kept} {kind}s?, where {size} make {made}"):
        read(tmp_path, grey_strips_tiff(kept, compression, tiled=tiled)[1])


@pytest.mark.parametrize("compression", [1, 8])
def test_a_tiff_of_more_strips_than_its_size_makes_reads_its_rows(tmp_path, compression):
    """One strip more than the size makes (of zeros): libtiff reads the strips the size makes and leaves the others
    (so it read deflated); Pillow, uncompressed, laid the extra one over the first row ([0, 0, 0] where [5, 25, 45])
    without a word. Uncompressed it is named (deflated, it reads as written)."""
    grey, data = grey_strips_tiff(4, compression, extra=True)
    if compression == 8:
        np.testing.assert_allclose(read(tmp_path, data)[..., 0], grey / 255.0, atol=1e-7)
    else:
        with pytest.raises(TextureError, match=r"p\.tif: it has 5 strips, where 3 x 4 pixels in strips of 3 x 1 "
                                               r"make 4"):
            read(tmp_path, data)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("tag, kind", [(284, LONG), (258, LONG), (262, LONG), (284, BYTE)],
                         ids=["planar", "bits", "photometric", "planar-byte"])
def test_a_tiff_whose_layout_tags_are_longs_reads_as_of_shorts(tmp_path, byte_order, tag, kind):
    """TIFF 6.0 gives PlanarConfiguration, BitsPerSample and PhotometricInterpretation SHORT values; libtiff (under
    Storm's OpenImageIO) reads them of LONG or BYTE ones too. wrt's header reader took only SHORT ones: 16-bit RGB
    stored plane by plane, of a LONG (or BYTE) PlanarConfiguration or a LONG BitsPerSample, went to Pillow as if of its
    samples together (off by 0.84, without a word); 16-bit WhiteIsZero grey of a LONG PhotometricInterpretation read
    uninverted. They read as the same file of SHORT values does (the samples written, float64; WhiteIsZero: 1 -
    sample / 65535)."""
    samples = np.random.default_rng(71).integers(0, 65536, (2, 3, 3)).astype(np.uint16)
    grey = tag == 262
    channels = 1 if grey else 3
    tags = {256: (SHORT, [3]), 257: (SHORT, [2]), 258: (SHORT, [16] * channels), 259: (SHORT, [1]),
            262: (SHORT, [0 if grey else 2]), 277: (SHORT, [channels]), 278: (SHORT, [2]), 284: (SHORT, [2])}
    tags[tag] = (kind, tags[tag][1])
    planes = [samples[..., k].astype(byte_order + "u2").tobytes() for k in range(channels)]
    image = read(tmp_path, tiff_file(tags, planes, byte_order=byte_order))
    want = 1.0 - samples[..., :1] / 65535.0 if grey else samples / 65535.0
    np.testing.assert_allclose(image[..., :3], np.broadcast_to(want, (2, 3, 3)), atol=1e-7)


@pytest.mark.parametrize("byte_order", ["<", ">"])
@pytest.mark.parametrize("tag", [256, 257, 258, 259, 262, 277, 278, "white"],
                         ids=["width", "height", "bits", "compression", "photometric", "samples", "rows", "white"])
def test_a_tiff_of_its_samples_together_whose_layout_tags_are_bytes_reads_as_of_shorts(tmp_path, byte_order, tag):
    """libtiff (under Storm's OpenImageIO) reads the size, BitsPerSample, Compression, PhotometricInterpretation,
    SamplesPerPixel and RowsPerStrip of BYTE values as of SHORT ones; Pillow (as tifffile) takes a BYTE entry's values
    for bytes and opens no such file, which was refused in false words ('3 channels of 8-bit unsigned integer
    samples, which Pillow (wrt's TIFF reader) does not decode'). 8-bit RGB of its samples together (BitsPerSample's
    three BYTEs made SHORTs past the entry) and 16-bit WhiteIsZero grey of a BYTE PhotometricInterpretation read as
    the samples written (float64; WhiteIsZero: 1 - sample / 65535), as the same file of SHORT values does."""
    white = tag == "white"
    samples = np.random.default_rng(72).integers(0, 65536 if white else 256, (2, 3, 1 if white else 3))
    channels, bits = (1, 16) if white else (3, 8)
    tags = {256: (SHORT, [3]), 257: (SHORT, [2]), 258: (SHORT, [bits] * channels), 259: (SHORT, [1]),
            262: (SHORT, [0 if white else 2]), 277: (SHORT, [channels]), 278: (SHORT, [2])}
    stored = samples.astype(byte_order + ("u2" if white else "u1")).tobytes()
    want = 1.0 - samples / 65535.0 if white else samples / 255.0
    shorts = read(tmp_path, tiff_file(tags, [stored], byte_order=byte_order), "shorts.tif")
    np.testing.assert_allclose(shorts[..., :3], np.broadcast_to(want, (2, 3, 3)), atol=1e-7)  # (as Pillow reads it)
    tags[262 if white else tag] = (BYTE, tags[262 if white else tag][1])
    image = read(tmp_path, tiff_file(tags, [stored], byte_order=byte_order))
    np.testing.assert_allclose(image[..., :3], np.broadcast_to(want, (2, 3, 3)), atol=1e-7)
