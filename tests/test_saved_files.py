"""What ``Image.save`` writes, read back by decoders of its own (numpy, OpenEXR, Pillow): ``.npy`` and ``.exr`` hold
the very float32 array, NaN, infinities and extremes included; ``.png`` is 8-bit RGB tagged sRGB of
``rgb * 2^exposure`` through the IEC 61966-2-1 curve, NaN as 0 and +inf as white, as the module docstring states."""

import struct

import numpy as np
import pytest
from PIL import Image as PilImage

import wrt

OpenEXR = pytest.importorskip("OpenEXR")

EXTREMES = [np.nan, np.inf, -np.inf, 3.4e38, -1.0, 0.0, 1e-45, 0.5, 1.0, 2.0, 0.0031308, 0.04]


def image_of(width: int, height: int, seed: int = 0) -> np.ndarray:
    """A ``(height, width, 3)`` float32 image whose first values are :data:`EXTREMES`, the rest random in [0, 1.5)."""
    rgb = np.random.default_rng(seed).uniform(0.0, 1.5, (height, width, 3)).astype(np.float32)
    flat = rgb.reshape(-1)
    count = min(len(EXTREMES), flat.size)
    flat[:count] = np.array(EXTREMES[:count], np.float32)
    return rgb


def srgb8(linear: np.ndarray) -> np.ndarray:
    """8-bit sRGB of linear values in float64 (IEC 61966-2-1), clipped to [0, 1] first, NaN as 0."""
    x = np.clip(np.nan_to_num(np.asarray(linear, np.float64), nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    encoded = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return np.round(encoded * 255.0).astype(np.uint8)


@pytest.mark.parametrize("size", [(1, 1), (3, 1), (1, 5), (7, 5)])
def test_npy_and_exr_hold_the_very_array(tmp_path, size):
    rgb = image_of(*size)
    image = wrt.Image(rgb=rgb)
    saved = np.load(image.save(tmp_path / "x.npy"))
    assert saved.dtype == np.float32 and saved.tobytes() == rgb.tobytes()
    with OpenEXR.File(str(image.save(tmp_path / "x.exr")), separate_channels=True) as f:
        channels = {name: np.array(c.pixels) for name, c in f.channels().items()}
    assert sorted(channels) == ["B", "G", "R"]
    exr = np.stack([channels[c] for c in "RGB"], axis=-1)
    assert exr.dtype == np.float32 and exr.tobytes() == rgb.tobytes()


@pytest.mark.parametrize("exposure", [0.0, 1.5, -150.0, 150.0])
def test_png_is_8_bit_srgb_of_the_exposed_image(tmp_path, exposure):
    rgb = image_of(5, 3, seed=1)
    with PilImage.open(wrt.Image(rgb=rgb).save(tmp_path / "x.png", exposure=exposure)) as png:
        assert png.mode == "RGB" and png.size == (5, 3)
        assert png.info["srgb"] == 0 and png.info["gamma"] == pytest.approx(1 / 2.2, abs=1e-5)
        pixels = np.asarray(png)
    np.testing.assert_array_equal(pixels, srgb8(rgb.astype(np.float64) * 2.0**exposure))
    assert pixels.reshape(-1)[0] == 0  # NaN, at any exposure


@pytest.mark.parametrize("ratio", [1.5e9 + 0.5, 2147483646 + 1 / 3, 1 / (1.5e9 + 0.5), 50000.12345])
def test_png_pixel_aspect_of_a_long_ratio_stays_within_phys_fields(tmp_path, ratio):
    """A pHYs field holds at most 2^31 - 1 (PNG specification, clause 7.1). Past a ratio of 21475 the fraction of
    denominator up to 10^5 wrote a numerator past it (3000000001 for 1.5e9 + 0.5) or failed in ``to_bytes``
    (2147483646.33: OverflowError, no file). Now both fields are within it and say the ratio within 10^-5."""
    from png_chunks import pixel_aspect_ratio, read_chunks

    chunks = read_chunks(str(wrt.Image(rgb=image_of(2, 3), pixel_aspect_ratio=ratio).save(tmp_path / "x.png")))
    (data,) = [data for kind, data, _ in chunks if kind == b"pHYs"]
    assert max(struct.unpack(">II", data[:8])) <= 2**31 - 1
    assert pixel_aspect_ratio(chunks) == pytest.approx(ratio, rel=1e-5)


def test_png_pixel_aspect_of_a_numpy_float32_ratio(tmp_path):
    """``write_srgb_png`` (PNG products, AOV previews) took the ratio to ``fractions.Fraction``, which refuses a numpy
    float32 ("argument should be a string or a Rational instance"): no file. Now its pHYs says it."""
    from png_chunks import pixel_aspect_ratio, read_chunks

    from wrt.image import write_srgb_png

    write_srgb_png(tmp_path / "x.png", np.zeros((3, 2, 3), np.uint8), np.float32(0.4))
    assert pixel_aspect_ratio(read_chunks(str(tmp_path / "x.png"))) == pytest.approx(0.4, rel=1e-5)


@pytest.mark.parametrize("name", ["depth.exr", "depth.png", "depth.EXR", "depth"])
def test_save_aov_writes_only_npy_names(tmp_path, name):
    """``save_aov`` writes NumPy bytes; under ``depth.exr`` (or ``.png``) that was a file OpenEXR (Pillow) cannot
    open, written without a word. Now it is refused naming the file, and nothing is written; ``.npy`` in any case
    holds the very array."""
    depth = image_of(3, 2)[..., 0]
    image = wrt.Image(rgb=image_of(3, 2), aovs={"depth": depth})
    with pytest.raises(ValueError, match=rf"save_aov: cannot write .*{name}: .*\.npy"):
        image.save_aov("depth", tmp_path / name)
    assert not list(tmp_path.iterdir())
    saved = np.load(image.save_aov("depth", tmp_path / "depth.NPY"))
    assert saved.dtype == np.float32 and saved.tobytes() == depth.tobytes()


def test_save_aov_npy_bytes_are_no_exr(tmp_path):
    """The oracle behind the test above: the NumPy bytes ``save_aov`` wrote under an EXR name are no EXR file."""
    np.save(tmp_path / "depth.npy", image_of(3, 2)[..., 0])
    (tmp_path / "depth.npy").rename(tmp_path / "depth.exr")
    with pytest.raises(Exception):
        OpenEXR.File(str(tmp_path / "depth.exr"))


@pytest.mark.parametrize("shape", [(2, 3, 4), (2, 3), (2, 3, 1)])
@pytest.mark.parametrize("name", ["x.png", "x.exr", "x.npy"])
def test_rgb_replaced_by_an_array_of_another_shape_is_refused_at_save(tmp_path, shape, name):
    """``wrt.Image`` refuses an rgb other than ``(H, W, 3)``; one set afterwards was written: ``(2, 3, 4)`` as an RGBA
    PNG whose alpha was sRGB-encoded (0.5 read back by Pillow as 188, not 128) and an RGBA .npy, ``(2, 3)`` failed
    in PIL's or OpenEXR's words. Now save refuses it as the constructor does, writing nothing."""
    image = wrt.Image(rgb=image_of(3, 2))
    image.rgb = np.full(shape, 0.5)
    with pytest.raises(ValueError, match=r"rgb must be a non-empty \(H, W, 3\) array"):
        image.save(tmp_path / name)
    assert not list(tmp_path.iterdir())
    with pytest.raises(ValueError, match=r"rgb must be a non-empty \(H, W, 3\) array"):
        image._repr_png_()


@pytest.mark.parametrize("field, bad, error", [("data", "no", TypeError), ("pixel_aspect_ratio", 0, ValueError),
                                               ("pixel_aspect_ratio", float("nan"), ValueError)])
def test_repr_png_refuses_settings_replaced_as_save_does(tmp_path, field, bad, error):
    """A notebook's picture (``_repr_png_``) of settings set after the image was made: ``data = "no"`` showed linear
    0.5 as 128 where its sRGB is 188 (1.055 * 0.5^(1/2.4) - 0.055, the oracle: the colour :meth:`save` writes for
    data=False), as if data were True; a ratio of 0 failed as 'float division by zero'. Now it refuses them with
    save's error, naming the field."""
    image = wrt.Image(rgb=np.full((2, 3, 3), 0.5, np.float32))
    setattr(image, field, bad)
    with pytest.raises(error, match=field):
        image.save(tmp_path / "x.png")
    setattr(image, field, bad)
    with pytest.raises(error, match=field):
        image._repr_png_()


@pytest.mark.parametrize("ratio, written", [(1e6, True), (1.0000001e6, False), (1e39, False), (1e-6, True),
                                            (9.9e-7, False), (1e-50, False)])
def test_exr_pixel_aspect_ratios_the_header_cannot_state_are_refused_naming_the_file(tmp_path, ratio, written):
    """OpenEXR's header takes pixel aspect ratios in [1e-6, 1e6] (as float32; the oracle: OpenEXR itself, writing a
    file of that header). Past them the save failed in OpenEXR's words, naming the temporary file. Now a ValueError
    names the file asked for; the PNG of the same image is written (its pHYs takes the ratio)."""
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, "pixelAspectRatio": ratio}
    try:
        with OpenEXR.File(header, {"R": np.zeros((2, 3), np.float32)}) as f:
            f.write(str(tmp_path / "oracle.exr"))
        takes = True
    except Exception:
        takes = False
    assert takes == written
    image = wrt.Image(rgb=image_of(3, 2), pixel_aspect_ratio=ratio)
    if written:
        with OpenEXR.File(str(image.save(tmp_path / "x.exr"))) as f:
            assert f.header()["pixelAspectRatio"] == np.float32(ratio)
    else:
        with pytest.raises(ValueError, match=rf"cannot write {tmp_path / 'x.exr'}: pixels .* OpenEXR header takes"):
            image.save(tmp_path / "x.exr")
        assert not (tmp_path / "x.exr").exists()
    image.save(tmp_path / "x.png")
