"""Image: the rendered picture (linear RGB, top row first) plus its AOVs, and writing them to disk.

Formats: ``.exr`` linear HDR (OpenEXR, 32-bit float), ``.npy`` raw linear float32, ``.png`` 8-bit sRGB after
``2^exposure`` scaling and clipping to [0, 1] (no other tone curve; NaN is written as 0, +inf as 1), tagged as sRGB
(sRGB, gAMA and cHRM chunks). AOVs are written as ``.npy`` and, for a quick look, as PNG previews
(:func:`aov_preview`): the traversal cost as a heat map of nodes visited and triangles tested, normals as
``0.5 (n + 1)``, depths as grey levels over the farthest one, ids as random colours, coverage as an alpha matte.
"""

from __future__ import annotations

import dataclasses
import errno
import importlib.util
import itertools
import math
import os
import warnings
from pathlib import Path

import numpy as np

from .errors import did_you_mean, flag, not_a_file
from .options import MAX_EXPOSURE

IMAGE_FORMATS = (".png", ".exr", ".npy")  # extensions Image.save writes
# The sRGB chunk (rendering intent 0, perceptual) and the gAMA and cHRM values the PNG specification (11.3.3.5)
# recommends beside it for decoders that do not read sRGB: gamma 1/2.2 and the Rec.709 primaries with D65 white, all
# in units of 1e-5. Without them a viewer that colour-manages untagged PNGs may take the pixels for another space.
SRGB_PNG_CHUNKS = (
    (b"sRGB", bytes([0])),
    (b"gAMA", (45455).to_bytes(4, "big")),
    (b"cHRM", b"".join(v.to_bytes(4, "big") for v in (31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000))),
)
HEAT_STOPS = np.array(  # black -> blue -> magenta -> orange -> yellow -> white, sRGB (an inferno-like ramp)
    [[0, 0, 0], [40, 11, 84], [159, 42, 99], [238, 110, 28], [250, 200, 40], [252, 255, 164]], np.float64
) / 255.0


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) on linear values, clipped to [0, 1]."""
    x = np.clip(np.nan_to_num(x, nan=0.0), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


# Said where an exposure is given for a data image (Image.data), whose PNG it leaves unscaled.
DATA_EXPOSURE_WARNING = ("{what} does not scale {image}: it is data (a normals or depth quick look), which a PNG "
                         "stores as it is, not as colour")


def check_exposure(exposure) -> float:
    """``exposure`` as a float when it is a number of stops in [-MAX_EXPOSURE, MAX_EXPOSURE], else ValueError (NaN
    gave a black PNG and inf a white one without a word; 1024 an OverflowError after the render)."""
    if isinstance(exposure, bool) or not isinstance(exposure, (int, float, np.integer, np.floating)) or not (
        math.isfinite(exposure) and abs(exposure) <= MAX_EXPOSURE
    ):
        raise ValueError(f"exposure must be a finite number of stops in [-{MAX_EXPOSURE:g}, {MAX_EXPOSURE:g}], "
                         f"got {exposure!r}")
    return float(exposure)


def to_srgb8(rgb: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """``(H, W, 3)`` linear float -> ``(H, W, 3)`` uint8 sRGB, scaled by ``2**exposure`` first (in float64, where
    any float32 radiance times 2^150 is finite)."""
    scaled = np.asarray(rgb, np.float64) * 2.0 ** check_exposure(exposure)
    return np.round(linear_to_srgb(scaled) * 255.0).astype(np.uint8)


def data_to_8bit(values: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` data in [0, 1] (a normal map's ``0.5 (n + 1)``) -> uint8 ``round(255 v)``, not sRGB-encoded:
    normal maps are stored so (clipped to [0, 1]; NaN written as 0)."""
    values = np.clip(np.nan_to_num(np.asarray(values, np.float64), nan=0.0), 0.0, 1.0)
    return np.round(values * 255.0).astype(np.uint8)


BEHIND_GREY = 0.1  # grey of the nearest hit where some hit lies behind the camera's plane (misses stay 0)


def depth_grey(depth: np.ndarray) -> np.ndarray:
    """``(H, W)`` distances -> ``(H, W)`` grey levels in [0, 1]: the distance over the farthest finite one (near
    dark, far white, in proportion), and 0 where there is none (a miss: ``inf`` or NaN). Where some distance is
    negative (a hit behind the plane of an orthographic camera whose near clip is negative), the hits run in
    proportion from :data:`BEHIND_GREY` at the nearest to white at the farthest: clipped to 0, those behind were
    drawn black as misses. Depth as a picture is data, as a normal map is: the ``depth`` integrator's ``rgb`` and
    the ``depth`` and ``z`` AOVs' previews, both stored as ``round(255 v)`` (:func:`data_to_8bit`), not
    sRGB-encoded."""
    depth = np.asarray(depth, np.float64)
    finite = np.isfinite(depth)
    if not finite.any():
        return np.zeros(depth.shape)
    near, far = float(depth[finite].min()), float(depth[finite].max())
    if near < 0.0:
        span = far - near
        ramp = (np.where(finite, depth, near) - near) / span if span > 0.0 else np.ones(depth.shape)
        return np.where(finite, BEHIND_GREY + (1.0 - BEHIND_GREY) * ramp, 0.0)
    return np.clip(np.where(finite, depth, 0.0) / (far if far > 0.0 else 1.0), 0.0, 1.0)


def png_aspect_chunk(pixel_aspect_ratio: float) -> tuple[bytes, bytes] | None:
    """The PNG ``pHYs`` chunk (specification 11.3.5.3) of pixels ``pixel_aspect_ratio`` times as wide as they are
    tall: pixels per unit along x and y in the inverse ratio, unit 0 (unknown: the aspect alone), the ratio as the
    nearest fraction of denominator up to 10^5, fewer past 21475 so that its numerator stays within the field (within
    10^-5 of it); None for square pixels, square without the chunk."""
    from fractions import Fraction

    pixel_aspect_ratio = float(pixel_aspect_ratio)  # Fraction takes no numpy float32, which a Camera may hold
    wide = pixel_aspect_ratio >= 1.0
    largest = 2**31 - 1  # the fields' largest value (clause 7.1)
    long_side = min(pixel_aspect_ratio if wide else 1.0 / pixel_aspect_ratio, largest)  # at least 1
    # Denominators that keep the numerator within the field: past 21475, 10^5 of them let it overflow (2147483646.3
    # failed in to_bytes, 1.5e9 + 0.5 wrote 3000000001).
    ratio = Fraction(long_side).limit_denominator(max(1, min(100_000, largest // math.ceil(long_side) - 1)))
    if ratio == 1:
        return None
    many, few = ratio.numerator, ratio.denominator  # pixels per unit along the short side of a pixel, the long one
    x, y = (few, many) if wide else (many, few)
    return b"pHYs", x.to_bytes(4, "big") + y.to_bytes(4, "big") + bytes([0])


def write_srgb_png(target, pixels: np.ndarray, pixel_aspect_ratio: float = 1.0) -> None:
    """Writes ``(H, W, 3)`` or ``(H, W, 4)`` uint8 sRGB-encoded ``pixels`` (alpha straight, not encoded) as a PNG
    tagged sRGB (:data:`SRGB_PNG_CHUNKS`) to ``target``, a path or a binary file object, with the shape of its
    pixels (:func:`png_aspect_chunk`) where they are not square: without it a viewer showed an image of pixels twice
    as wide as tall squashed to half its width."""
    import io

    from PIL import Image as PilImage
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for chunk_type, data in SRGB_PNG_CHUNKS:
        info.add(chunk_type, data)  # Pillow writes these before the image data, where the specification puts them
    image = PilImage.fromarray(np.ascontiguousarray(pixels, np.uint8), mode="RGBA" if pixels.shape[-1] == 4 else "RGB")
    aspect = png_aspect_chunk(pixel_aspect_ratio)
    if aspect is None:
        image.save(target, format="PNG", pnginfo=info)
        return
    # Pillow writes no pHYs of pnginfo's, and its own (``dpi``) is in metres, a print size: put ours in.
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", pnginfo=info)
    png = with_png_chunk(buffer.getvalue(), *aspect)
    if hasattr(target, "write"):
        target.write(png)
    else:
        with open(target, "wb") as f:
            f.write(png)


def with_png_chunk(png: bytes, kind: bytes, data: bytes) -> bytes:
    """The bytes of ``png`` with a chunk of type ``kind`` holding ``data`` before its first IDAT chunk (where the
    specification puts pHYs), its CRC over type and data (clause 5.3)."""
    import zlib

    at = 8  # past the signature: a chunk is its length, type, data and CRC
    while png[at + 4:at + 8] != b"IDAT":
        at += 12 + int.from_bytes(png[at:at + 4], "big")
    chunk = len(data).to_bytes(4, "big") + kind + data + zlib.crc32(kind + data).to_bytes(4, "big")
    return png[:at] + chunk + png[at:]


def heat_map(values: np.ndarray, vmax: float | None = None) -> np.ndarray:
    """``(H, W)`` non-negative values -> ``(H, W, 3)`` uint8 colours, 0 black and ``vmax`` (default: the maximum)
    white-yellow."""
    v = np.asarray(values, np.float64)
    top = float(vmax if vmax is not None else (v.max() if v.size else 1.0)) or 1.0
    x = np.clip(v / top, 0.0, 1.0) * (len(HEAT_STOPS) - 1)
    k = np.minimum(x.astype(int), len(HEAT_STOPS) - 2)
    f = (x - k)[..., None]
    rgb = HEAT_STOPS[k] * (1.0 - f) + HEAT_STOPS[k + 1] * f
    return np.round(rgb * 255.0).astype(np.uint8)


def _id_colors(ids: np.ndarray) -> np.ndarray:
    """Distinct pseudo-random colours per integer id; -1 (nothing) is black."""
    ids = np.asarray(ids, np.int64)
    h = (ids * 2654435761) & 0xFFFFFFFF
    rgb = np.stack([(h >> 16) & 255, (h >> 8) & 255, h & 255], axis=-1).astype(np.uint8) // 2 + 64
    rgb[ids < 0] = 0
    return rgb


def _labelled_panels(panels: list[tuple[np.ndarray, str]]) -> np.ndarray:
    """Side-by-side uint8 images with a caption strip under each."""
    from PIL import Image as PilImage
    from PIL import ImageDraw

    h, w = panels[0][0].shape[:2]
    strip = 14
    canvas = PilImage.new("RGB", (w * len(panels) + 4 * (len(panels) - 1), h + strip), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    for k, (img, label) in enumerate(panels):
        x = k * (w + 4)
        canvas.paste(PilImage.fromarray(img, mode="RGB"), (x, 0))
        draw.text((x + 2, h + 1), label, fill=(0, 0, 0))
    return np.asarray(canvas)


def aov_preview(name: str, value: np.ndarray) -> np.ndarray:
    """A viewable ``(H, W, 3)`` uint8 picture of AOV ``name``.

    ``cost`` becomes two heat maps side by side (nodes visited | triangles tested), each scaled to its maximum,
    which its caption states; normals map to ``0.5 (n + 1)``; depths to grey (:func:`depth_grey`, as the ``depth``
    integrator's image); ids to random colours; albedo to sRGB.
    """
    value = np.asarray(value)
    if name == "cost":
        nodes, tris = value[..., 0], value[..., 1]
        return _labelled_panels(
            [
                (heat_map(nodes), f"nodes visited (max {int(nodes.max()) if nodes.size else 0})"),
                (heat_map(tris), f"triangles tested (max {int(tris.max()) if tris.size else 0})"),
            ]
        )
    if value.ndim == 3 and value.shape[-1] == 3:
        if "normal" in name:
            return data_to_8bit(0.5 * (value + 1.0)) * (np.abs(value).sum(-1, keepdims=True) > 0).astype(np.uint8)
        return to_srgb8(value)
    if value.dtype.kind in "iu":
        return _id_colors(value)
    if name == "coverage":  # a share in [0, 1]: 0 black and 1 white, as alpha mattes show
        return np.round(np.repeat(np.clip(value, 0.0, 1.0)[..., None], 3, axis=-1) * 255).astype(np.uint8)
    return data_to_8bit(np.repeat(depth_grey(value)[..., None], 3, axis=-1))  # depth and z: as the depth integrator


_PARTIAL_COUNTER = itertools.count()  # numbers the temporary files of write_atomically


def make_folder(folder: Path, written: Path) -> None:
    """Makes ``folder`` and its parents, for the file ``written``; a file where one of them must go raises
    NotADirectoryError naming both ('[Errno 17] File exists', naming the file in the way only, read as if the image
    existed)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        in_way = next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), folder)
        raise NotADirectoryError(f"cannot write {written}: {in_way} is a file, not a directory") from None


def check_folder_path(directory, what: str) -> Path:
    """``directory`` as a Path of a folder to write files into; ``what`` names the argument in the error.

    Raises:
        TypeError: for anything but a ``str`` or ``os.PathLike`` (pathlib's message named no argument).
        ValueError: for an empty or blank one: ``Path("")`` is the current folder, which took the files without a word.
        NotADirectoryError: a file stands where the folder or one of its parents must go.
    """
    if not isinstance(directory, (str, os.PathLike)):
        raise TypeError(f"{what} must be a folder path (str or os.PathLike), got {type(directory).__name__} "
                        f"{directory!r}")
    if not str(directory).strip():
        raise ValueError(f"{what} {str(directory)!r} is empty; name a folder ('.' for the current one)")
    directory = Path(directory)
    # A file where the folder must go: refused now, not at the first write, after the work (render_products).
    in_way = next((p for p in (directory, *directory.parents) if p.exists() and not p.is_dir()), None)
    if in_way is not None:
        raise NotADirectoryError(f"{what} {directory}: {in_way} is a file, not a directory")
    return directory


def write_atomically(path: Path, write) -> None:
    """Calls ``write(file)`` on a temporary file beside ``path``, then renames it to ``path``: a run killed while
    writing leaves no truncated image where ``--resume`` would take it for a finished one."""
    make_folder(path.parent, path)
    if path.is_dir():  # else the rename fails after the write, naming the temporary file
        raise IsADirectoryError(f"cannot write {path}: it is a directory")
    # The temporary name keeps at most 100 bytes of the final one: a name near the file system's limit (255 bytes)
    # is valid for the image but was too long with the prefix and suffix added. Process id and a counter keep
    # temporary names apart.
    stem = os.fsencode(path.name)[:100].decode(errors="ignore")
    partial = path.with_name(f".{stem}.{os.getpid()}.{next(_PARTIAL_COUNTER)}.partial{path.suffix}")
    try:
        # Created here first, so that a folder that takes no files fails as an OSError naming the file asked for,
        # not the temporary one (nor OpenEXR's RuntimeError, which EXR's writer gave).
        try:
            partial.open("wb").close()
        except OSError as e:
            raise type(e)(e.errno, e.strerror, str(path)) from None
        try:
            write(partial)
            os.replace(partial, path)
        except OSError as e:  # a full disk said '[Errno 28] No space left on device', naming no file
            raise failed_write(e, path) from None
    finally:
        try:
            partial.unlink(missing_ok=True)
        except OSError:  # a read-only file system refuses the unlink of a missing file too (EROFS), which replaced
            pass  # the error naming the file asked for with one naming the temporary file


def failed_write(error: OSError, path: Path) -> OSError:
    """``error``, raised while writing ``path`` (or its temporary file), as an OSError naming ``path``: the errors
    of a write or a close carry no file name, and one raised at the temporary file named that instead."""
    if error.errno is None:
        return OSError(f"cannot write {path}: {error}")
    return OSError(error.errno, error.strerror, str(path))


def write_npy(target: Path, array: np.ndarray) -> None:
    """Writes ``array`` as the ``.npy`` file ``target``. Through Python's file writes, piece by piece: ``np.save``
    to an open file writes with C's fwrite, whose failure on a full disk reads '12288 requested and 2016 written',
    without the cause."""

    class Writes:  # not a file object to numpy, which then writes the data in pieces through write()
        def __init__(self, file):
            self.write = file.write

    with open(target, "wb") as f:  # np.save(path) appends ".npy" to a name ending in ".NPY" or a temporary name
        np.save(Writes(f), array)


def exr_windows(window: tuple[int, int, int, int] | None, width: int, height: int) -> dict:
    """The EXR header's ``displayWindow`` and ``dataWindow`` of a ``width x height`` image placed in its shot by
    ``window`` (:attr:`Image.window`: the shot's width and height, the image's top-left pixel in it; ``None``: the
    image is the whole shot), so that a compositor places a crop where it lies in the shot. One rule for
    :meth:`Image.save` and the render products (:func:`wrt.render_products.exr_windows`)."""
    full_w, full_h, x0, y0 = (width, height, 0, 0) if window is None else window
    return {"displayWindow": (np.array([0, 0], np.int32), np.array([full_w - 1, full_h - 1], np.int32)),
            "dataWindow": (np.array([x0, y0], np.int32), np.array([x0 + width - 1, y0 + height - 1], np.int32))}


# The pixel aspect ratios an OpenEXR header may state (its sanity check, on the ratio as a 32-bit float): past them the
# write failed as 'Invalid pixel aspect ratio in image header', naming the temporary file.
EXR_PIXEL_ASPECTS = (np.float32(1e-6), np.float32(1e6))


def check_exr_pixel_aspect(ratio: float, path) -> None:
    """ValueError naming ``path`` when an EXR header cannot state the pixel aspect ``ratio`` (:data:`EXR_PIXEL_ASPECTS`;
    a PNG's pHYs chunk can)."""
    low, high = EXR_PIXEL_ASPECTS
    with np.errstate(over="ignore"):  # 1e39 is inf as a float32: refused, as it is
        stated = np.float32(ratio)
    if not low <= stated <= high:
        raise ValueError(f"cannot write {path}: pixels {float(ratio):g} times as wide as tall are outside the pixel "
                         f"aspect ratios an OpenEXR header takes, [{low:g}, {high:g}]; write a .png or .npy")


def write_exr(path: Path, channels: dict[str, np.ndarray], attributes: dict | None = None) -> None:
    """Writes float32 ``(H, W)`` channels (e.g. ``{"R": r, "G": g, "B": b}``) to an OpenEXR file, with the header
    ``attributes`` (as the OpenEXR package takes them: ``{"dataWindow": (min, max), "id/paths": "..."}``)."""
    try:
        import OpenEXR
    except ImportError:
        raise ValueError(f"cannot write {path.name}: EXR output needs the OpenEXR package "
                         "(pip install OpenEXR)") from None
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **(attributes or {})}
    data = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}
    try:
        with OpenEXR.File(header, data) as f:
            f.write(str(path))
    except RuntimeError as e:  # OpenEXR's one error type, for a full disk too: 'Failed to write ... No space left'
        raise _exr_os_error(e, path) from None


def _exr_os_error(error: RuntimeError, path: Path) -> OSError:
    """OpenEXR's ``RuntimeError`` for a failed write as an OSError of the cause its message ends with (a full disk:
    ``ENOSPC``), so that callers treat it as the other failed writes; its own words where it names no such cause."""
    message = str(error)
    code = next((code for code in sorted(errno.errorcode) if os.strerror(code) in message), None)
    return OSError(message) if code is None else OSError(code, os.strerror(code), str(path))


def check_not_extension_alone(path) -> Path:
    """``path`` as a Path; ValueError when its name is an image extension alone (``-o .png``): that is a hidden file
    without an extension, to Python and to viewers, and was refused as 'cannot write .png: supported image formats
    are .png, ...'."""
    path = Path(path)
    if path.name.lower() in IMAGE_FORMATS:
        raise ValueError(f"cannot write {path.name}: the file name is an extension alone; give a name before it, "
                         f"e.g. {path.with_name('image' + path.name)}")
    return path


def no_extension_words(path) -> str:
    """What an error says of ``path`` (a Path) where its name has no extension, with a name that has one: a name
    ending in a dot (``x.``) was told 'e.g. x..png'."""
    return f"the file name has no extension (e.g. {path.name.rstrip('.')}.png); "


def check_image_path(path) -> Path:
    """``path`` as a Path if :meth:`Image.save` can write its format; callers check before a long render.

    Raises:
        ValueError: for an extension other than ``IMAGE_FORMATS``, or ``.exr`` without the OpenEXR package.
    """
    if not isinstance(path, (str, os.PathLike)):  # pathlib said only 'expected str, bytes or os.PathLike object'
        raise TypeError(f"image path must be a str or os.PathLike, got {type(path).__name__} {path!r}")
    if not str(path).strip():  # Path("") is the current folder: 'cannot write : supported image formats are ...'
        raise ValueError(f"image path {str(path)!r} is empty; give a file name such as image.png")
    if Path(path).is_dir():  # before the extension: a folder was refused as 'supported image formats are ...'
        raise IsADirectoryError(f"cannot write {path}: it is a directory")
    if os.path.exists(path) and not os.path.isfile(path):  # -o /dev/null said 'cannot write null: ... formats'
        raise ValueError(f"cannot write {path}: it is {not_a_file(path)}, not an image file (the image is written "
                         f"beside it and renamed over it); give a file name ending {', '.join(IMAGE_FORMATS[:-1])} or "
                         f"{IMAGE_FORMATS[-1]}")
    given, path = str(path), check_not_extension_alone(path)
    suffix = path.suffix.lower()
    if suffix not in IMAGE_FORMATS:  # the path as given: the name alone ('null') did not say which file
        shown = given if given == given.strip() else repr(given)  # 'x.png ': a space typed after it
        # A name without one ('-o out') was told only the formats, as if its extension were a wrong one.
        missing = "" if suffix else no_extension_words(path)
        raise ValueError(f"cannot write {shown}: {missing}supported image formats are {', '.join(IMAGE_FORMATS)}")
    if suffix == ".exr" and importlib.util.find_spec("OpenEXR") is None:
        raise ValueError(f"cannot write {path.name}: EXR output needs the OpenEXR package (pip install OpenEXR)")
    return path


def checked_rgb(rgb) -> np.ndarray:
    """``rgb`` as the float32 ``(H, W, 3)`` array :attr:`Image.rgb` is (a list of rows, a float64 array converted);
    ValueError for anything else. Taken as given, a ``(H, W)`` array failed only at save, in PIL's words ('Invalid
    mode for data type'), a list had no ``shape``, and an ``(H, W, 4)`` one was saved with its alpha sRGB-encoded."""
    try:
        array = np.asarray(rgb)
    except (TypeError, ValueError):  # a ragged list
        array = None
    if array is None or array.dtype.kind not in "fiu" or array.ndim != 3 or array.shape[-1] != 3 or not array.size:
        got = (f"{array.dtype} array of shape {array.shape}" if array is not None and array.dtype != object
               else type(rgb).__name__)
        raise ValueError(f"wrt.Image: rgb must be a non-empty (H, W, 3) array of real numbers (linear radiance), "
                         f"got {got}")
    return array.astype(np.float32, copy=False)


class Aovs(dict):
    """AOV name -> array: a name it lacks (a typo, ``"dpth"``) is a KeyError that names the closest and lists the names
    it has; a plain dict's said only ``'dpth'``."""

    def __missing__(self, name):
        raise KeyError(f"no AOV {name!r}{did_you_mean(name, self)}; this image has: {', '.join(self) or 'none'}")


@dataclasses.dataclass
class Image:
    """A rendered image.

    Attributes:
        rgb: ``(H, W, 3)`` float32 linear radiance (``path``, ``whitted``) or the quick look of the integrator;
            row 0 is the top of the image.
        aovs: per-pixel data of the camera ray through each pixel centre and the lens centre (the AOV ray, not a
            colour sample of an image of several samples), all ``(H, W, ...)``:

            - ``"depth"`` float32 distance along the ray (``inf`` on a miss; negative for a hit behind the plane of
              an orthographic camera whose near clip is negative);
            - ``"z"`` float32 depth: distance along the viewing axis, scene units (``inf`` on a miss; negative
              likewise);
            - ``"normal"`` ``(H, W, 3)`` float32 world-space shading normal, flipped to the camera's side with the
              face normal, and near silhouettes turned towards it just enough that the camera's mirror direction
              stays above the surface; 0 on a miss);
            - ``"geometric_normal"`` ``(H, W, 3)`` float32 world-space face normal, facing the camera (0 on a miss);
            - ``"albedo"`` ``(H, W, 3)`` float32 diffuseColor (textured) of the hit material (0 on a miss);
            - ``"prim"`` int32 id of the triangle or analytic shape hit, as ``Hits.prim`` (a row of
              ``Scene.triangles()``; a shape's id comes after them), -1 on a miss;
            - ``"instance"`` int32 index into ``Scene.instances``; -1 on a miss or on non-instanced geometry;
            - ``"material"`` int32 index into ``Scene.materials`` (-1 on a miss, for the default material and on
              mesh lights of ``noMaterialResponse``, whose surface has none);
            - ``"cost"`` ``(H, W, 2)`` int32 BVH nodes visited and triangles tested by the ray (0 for
              ``accel="warp"``), including re-traces past culled back faces and cut-out holes;
            - ``"coverage"`` float32 share of the pixel's samples (all of them, not the AOV ray alone) whose camera
              ray hit something: the alpha of the antialiased ``rgb``, whose misses add the background.
        pixel_aspect_ratio: width / height of one pixel on the film (UsdRender's ``pixelAspectRatio``; not 1 under
            render settings of non-square pixels), which ``.exr`` files state in their header.
        window: ``(width, height, x0, y0)`` of the shot this image is a crop of (the render settings'
            ``dataWindowNDC``) and the image's top-left pixel in it, rows from the top; ``None``: the whole shot.
            ``.exr`` files write it as their ``displayWindow`` and ``dataWindow``, as EXR render products do.
        data: ``rgb`` holds data, not colour: the ``normals`` integrator's ``0.5 (n + 1)`` or the ``depth``
            integrator's :func:`depth_grey`, which a ``.png`` stores as it is (``round(255 v)``, neither
            sRGB-encoded nor scaled by ``exposure``), as normal maps are stored and as the ``normal``, ``depth`` and
            ``z`` AOVs' previews are.
    """

    rgb: np.ndarray
    aovs: dict = dataclasses.field(default_factory=Aovs)
    pixel_aspect_ratio: float = 1.0  # width / height of one pixel on the film, written into the EXR header
    window: tuple[int, int, int, int] | None = None  # (shot width, height, x0, y0): where a crop lies, EXR's windows
    data: bool = False  # rgb is data, not colour (the normals and depth quick looks): a PNG stores it as it is

    def __post_init__(self):
        self.rgb = checked_rgb(self.rgb)
        self.aovs = Aovs(self.aovs)
        self._check_settings()

    def _check_settings(self) -> None:
        """Makes :attr:`pixel_aspect_ratio` a float, :attr:`window` a tuple of ints and :attr:`data` a bool, or raises
        naming the field: a NaN or negative ratio failed the EXR write in OpenEXR's words, naming the temporary file;
        a fractional x0 was cut to an int, placing the crop elsewhere in its shot; ``data="no"`` stored the colour as
        data by its truth."""
        ratio = self.pixel_aspect_ratio
        if isinstance(ratio, (bool, np.bool_)) or not isinstance(ratio, (int, float, np.integer, np.floating)) or not (
            math.isfinite(ratio) and ratio > 0
        ):
            raise ValueError(f"wrt.Image: pixel_aspect_ratio must be a finite positive number (the width / height "
                             f"of one pixel), got {ratio!r}")
        self.pixel_aspect_ratio = float(ratio)
        window = self.window
        if window is not None:
            ints = (not isinstance(window, (str, bytes)) and hasattr(window, "__len__") and len(window) == 4
                    and all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in window))
            if not ints or min(window[:2]) < 1:
                raise ValueError(f"wrt.Image: window must be None or (shot width, shot height, x0, y0) integers, the "
                                 f"shot at least 1x1, got {window!r}")
            self.window = tuple(int(v) for v in window)
        self.data = flag(self.data, "wrt.Image: data")

    def __eq__(self, other) -> bool:
        """Whether ``other`` is an Image of the same arrays (the very objects, as :class:`wrt.BatchImage`'s
        ``wp.array`` fields compare) and the same settings. The dataclass compared the arrays with numpy's ``==``,
        whose answer has no truth value: ``image == copy`` and ``image in images`` raised ValueError."""
        if other.__class__ is not self.__class__:
            return NotImplemented
        same_aovs = self.aovs.keys() == other.aovs.keys() and all(a is other.aovs[k] for k, a in self.aovs.items())
        settings = (self.pixel_aspect_ratio, self.window, self.data)
        return self.rgb is other.rgb and same_aovs and settings == (other.pixel_aspect_ratio, other.window, other.data)

    @property
    def width(self) -> int:
        """Pixels per row."""
        return self.rgb.shape[1]

    @property
    def height(self) -> int:
        """Rows."""
        return self.rgb.shape[0]

    def __repr__(self) -> str:
        # The dataclass repr printed every AOV array: a screenful of numbers where a notebook shows the picture.
        aovs = ", ".join(self.aovs) or "none"
        return f"Image({self.width}x{self.height}, aovs: {aovs})"

    def _repr_png_(self) -> bytes:
        """The image as Jupyter and IPython show it: the 8-bit sRGB PNG :meth:`save` writes (exposure 0)."""
        import io

        buffer = io.BytesIO()
        self.rgb = checked_rgb(self.rgb)  # replaced after the image was made, as save checks it
        self._check_settings()  # so are these: data="no" was shown as data by its truth, a ratio of 0 divided by 0
        self._write_png(buffer, 0.0)
        return buffer.getvalue()

    def _write_png(self, target, exposure: float) -> None:
        """The 8-bit sRGB PNG of ``rgb * 2**exposure`` into ``target``, a path or a binary file object."""
        # A normal map's values are what a reader takes back, so no transfer curve may change them.
        write_srgb_png(target, data_to_8bit(self.rgb) if self.data else to_srgb8(self.rgb, exposure),
                       self.pixel_aspect_ratio)

    def save(self, path, exposure: float = 0.0) -> Path:
        """Writes the colour image: ``.exr`` linear HDR float32, ``.npy`` raw linear float32, ``.png`` 8-bit sRGB
        of ``rgb * 2**exposure`` clipped to [0, 1] (``exposure`` applies to PNG only, and not to a :attr:`data`
        image, whose PNG stores its values as they are: a warning says so).

        Raises:
            ValueError: for any other extension, ``.exr`` without the OpenEXR package, or an ``exposure`` that
                :func:`check_exposure` refuses.
            IsADirectoryError: ``path`` is a directory.
        """
        path = check_image_path(path)  # a directory too: else the error would name the temporary file beside it
        exposure = check_exposure(exposure)
        self._check_settings()  # set after the image was made, too
        # So is rgb: an (H, W, 4) array replaced it in a PNG of RGBA, its alpha sRGB-encoded (0.5 as 188), and an
        # (H, W) one failed in PIL's words ('Invalid mode for data type').
        self.rgb = checked_rgb(self.rgb)
        suffix = path.suffix.lower()
        if suffix == ".exr":
            check_exr_pixel_aspect(self.pixel_aspect_ratio, path)
        if exposure != 0.0 and self.data and suffix == ".png":  # else a brighter PNG asked for came out the same
            warnings.warn(DATA_EXPOSURE_WARNING.format(what="exposure", image="this image"), stacklevel=2)

        def write(target: Path) -> None:
            if suffix == ".png":
                self._write_png(target, exposure)
            elif suffix == ".exr":
                rgb = np.asarray(self.rgb, np.float32)
                write_exr(target, {"R": rgb[..., 0], "G": rgb[..., 1], "B": rgb[..., 2]},
                          {**exr_windows(self.window, self.width, self.height),
                           "pixelAspectRatio": float(self.pixel_aspect_ratio)})
            else:
                write_npy(target, self.rgb.astype(np.float32))

        write_atomically(path, write)
        return path

    def save_aovs(self, directory, names=None, png: bool = False) -> list[Path]:
        """Writes AOVs as ``DIRECTORY/NAME.npy`` (and ``NAME.png`` previews with ``png``, see :func:`aov_preview`);
        ``names`` selects some (default: all). Returns the paths written."""
        png = flag(png, "save_aovs: png")  # by its truth, png="false" wrote the PNG previews too
        if isinstance(names, str):  # list("depth") asked for AOVs 'd', 'e', 'p', 't', 'h'
            raise TypeError(f"save_aovs: names must be a list of AOV names, such as [{names!r}], got str {names!r}")
        names = list(self.aovs) if names is None else list(names)
        for name in names:
            self._check_aov(name)
        directory = check_folder_path(directory, "save_aovs: directory")
        make_folder(directory, directory)
        paths = []
        for name in names:
            paths.append(self.save_aov(name, directory / f"{name}.npy"))
            if png:
                paths.append(self.save_aov_png(name, directory / f"{name}.png"))
        return paths

    def save_aov(self, name: str, path) -> Path:
        """Writes AOV ``name`` as the ``.npy`` array ``path`` (whole or not at all); returns the path. ``path`` must end
        in ``.npy`` (a ``ValueError`` otherwise: ``depth.exr`` got NumPy bytes under an EXR name, which no EXR reader
        opens; a preview: :meth:`save_aov_png`)."""
        path = self._aov_path(name, path, "save_aov")
        if path.suffix.lower() != ".npy":
            raise ValueError(f"save_aov: cannot write {path}: the AOV's values are a NumPy array, so name it .npy (a "
                             f"picture of them: save_aov_png, as .png)")
        write_atomically(path, lambda target: write_npy(target, self.aovs[name]))
        return path

    def _aov_path(self, name, path, method: str) -> Path:
        """``path`` as a Path for ``method`` (``save_aov``, ``save_aov_png``) to write AOV ``name`` to, both checked
        (:meth:`_check_aov`, a str or os.PathLike, not an extension alone); its suffix is the method's to check."""
        self._check_aov(name)
        if not isinstance(path, (str, os.PathLike)):  # pathlib said only 'expected str, bytes or os.PathLike object'
            raise TypeError(f"{method}: path must be a str or os.PathLike, got {type(path).__name__} {path!r}")
        return check_not_extension_alone(path)

    def _check_aov(self, name) -> None:
        """Raises ``ValueError`` unless ``name`` is one of :attr:`aovs`, with the name meant where one is close."""
        if not isinstance(name, str) or name not in self.aovs:
            raise ValueError(f"unknown AOV {name!r}{did_you_mean(name, self.aovs)}; available: {', '.join(self.aovs)}")

    def save_aov_png(self, name: str, path) -> Path:
        """Writes the :func:`aov_preview` of AOV ``name`` as a PNG; ``path`` must end in ``.png`` (a ``ValueError``
        otherwise: ``d.exr`` got PNG bytes under an EXR name; the values themselves: :meth:`save_aovs`)."""
        path = self._aov_path(name, path, "save_aov_png")
        if path.suffix.lower() != ".png":
            raise ValueError(f"save_aov_png: cannot write {path.name}: the preview is a PNG, so name it .png (the "
                             f"AOV's values: save_aovs, as .npy)")
        preview = aov_preview(name, self.aovs[name])  # display colours, meant to be shown as they are: sRGB
        write_atomically(path, lambda target: write_srgb_png(target, preview, self.pixel_aspect_ratio))
        return path
