"""Textures: reading images (Pillow, OpenEXR, luminance-chroma EXRs in ``exr_yca.py``, Radiance ``.hdr`` in
``radiance_hdr.py``) into linear RGBA, and bilinear lookups with UsdUVTexture's wrap modes.

Conventions, stated once:

- Images are kept as ``(H, W, 4)`` float32 linear RGBA, row 0 at the top; on the device they are packed into one
  ``wp.vec4h`` (half float) array with per-image offsets, each channel of an image divided by a power of two that
  brings its largest finite texel within float16's range where it lies outside ``[2^-10, 65504]`` (:func:`image_scale`;
  an HDR's sun of 1e6 was clamped to 65504, and an image of texels below 6e-8 read 0), lookups multiplied by it.
- Texture coordinates follow USD: ``st = (0, 0)`` is the bottom-left corner of the image, ``(1, 1)`` the top-right.
  Texel centres sit at half-integer positions; lookups are bilinear (no mip-mapping), or of the one texel whose
  square holds ``st`` for the ``closest`` filter (:data:`FILTER_MODES`).
- ``sourceColorSpace``: ``"sRGB"`` decodes RGB with the sRGB transfer function (alpha stays linear), ``"gamma g"``
  (MaterialX's ``g22_rec709`` and kin) with ``max(x, 0)^g`` (:func:`decode_curve`); ``"raw"`` keeps values;
  ``"auto"`` follows a PNG's ``gAMA``/``sRGB`` chunk (:func:`tagged_srgb`, which says where Storm reads them
  otherwise), else means sRGB for 8-bit RGB/RGBA images
  and 16-bit RGB/RGBA PNGs (Hydra's stb_image reader hands PNGs over as 8-bit samples) and raw for everything else
  (grey, grey + alpha, 16-bit TIFFs, float, Radiance ``.hdr``), as Hydra's image readers decide. Missing channels
  read as grey ``L`` -> ``(L, L, L)`` and alpha 1 (0 at a grey PNG's tRNS sample and at an RGB PNG's tRNS colour),
  as UsdUVTexture reads them; a MaterialX image node takes a file's channels in order instead
  (:func:`materialx_texels`). 16-bit PNGs and RGB(A) TIFFs keep all 16 bits (Pillow alone reduces colour ones to 8),
  TIFFs stored plane by plane too. Colour premultiplied by alpha (a TIFF's ``ExtraSamples`` 1) is divided by it
  here, in float32, and so is grey: every texture holds straight colour, as PNGs do.
- ``"<transfer> in <primaries>"`` (:data:`PRIMARIES_SEPARATOR`; a MaterialX image's ``acescg`` is ``raw in
  lin_ap1_scene``): decoded by ``<transfer>``, then its colour converted from the linear space of USD colour space
  ``<primaries>`` to linear Rec.709 (:func:`convert_primaries`), once per image at load: lookups are linear in the
  texels, so converting before filtering is exact. The colour converted is the one the texture reads (MaterialX
  transforms the image node's output): :func:`read_image` converts where the file's colour lies in places 0 to 2,
  :func:`materialx_texels` and :func:`preview_texels` the texels they lay out of other files. Other images get no
  gamut conversion (UsdUVTexture's ``sourceColorSpace`` names no primaries).
- UDIM textures (``<UDIM>`` in the file name) are separate images, one per tile: tile ``1001 + u + 10 v`` covers
  ``st`` in ``[u, u + 1) x [v, v + 1)`` for ``u, v`` in 0..9 (1001..1100, the tiles ``UsdShade.UdimUtils``
  resolves); :func:`udim_tile` finds the tile of a coordinate.
"""

from __future__ import annotations

import contextlib
import io
import math
import struct
import sys
import threading
import warnings

import numpy as np
import warp as wp

from .exr_yca import yca_rgba
from .png_checks import png_chunk_problem, without_unread_chunks
from .tiff_checks import (
    ASSOCIATED_ALPHA,
    BITS_PER_SAMPLE,
    BLACK_IS_ZERO,
    COMPRESSION,
    COMPRESSION_NAMES,
    EXTRA_SAMPLES,
    PHOTOMETRIC,
    PIXEL_TAGS,
    PLANAR_CONFIGURATION,
    RGB,
    SAMPLE_FORMAT,
    SAMPLES_PER_PIXEL,
    SIGNED,
    TIFF_MAGIC,
    UNASSOCIATED_ALPHA,
    UNSIGNED,
    WHITE_IS_ZERO,
    piece_problem,
    tags_past_end,
    tiff_directory,
    tiff_first_values,
    tiff_sample_layout,
    tiff_samples,
    with_byte_numbers_as_shorts,
    with_value,
    without_tags,
)
from .tiff_planes import tiff_plane

# UsdUVTexture wrapS/wrapT tokens, and "fallback": MaterialX's "constant" address mode, the image node's default
WRAP_MODES = {"repeat": 0, "mirror": 1, "clamp": 2, "black": 3, "fallback": 4}
WRAP_REPEAT = wp.constant(0)
WRAP_MIRROR = wp.constant(1)
WRAP_CLAMP = wp.constant(2)
WRAP_BLACK = wp.constant(3)
WRAP_FALLBACK = wp.constant(4)  # the texture's fallback outside [0, 1] (its binding's, see wrt.materials)
# Texture filters: bilinear between texel centres, or the one texel under st (MaterialX's filtertype "closest")
FILTER_MODES = {"linear": 0, "closest": 1}
FILTER_CLOSEST = wp.constant(1)
HALF_MAX = 65504.0  # largest finite float16: brighter texels are clamped to it
# Images whose largest finite texel lies in [SMALLEST_UNSCALED, HALF_MAX] are stored as they are; others divided by
# a power of two (image_scale) that brings it into [2^14, 2^15): float16 keeps its 11 bits down to 2^-14.
SMALLEST_UNSCALED = 2.0**-10
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"  # first 8 bytes of every PNG file
BIG_ENDIAN_BIGTIFF = b"MM\x00+"  # first 4 bytes of a big-endian BigTIFF (version 43)
PACK_TEXELS = 1 << 20  # texels converted to float16 at a time by pack_images
MAX_TEXELS = 2**31  # texels of all a scene's images together: offsets into them are int32 (pack_images)
# Pillow raw modes of 16-bit samples it reduces to 8 bits: colour (PNG big-endian, TIFF either) and PNG grey + alpha
# (and TIFF colour decoded by libtiff, in the machine's byte order: ;16N; RGBX: a fourth sample of no stated meaning;
# RGBa: colour premultiplied by alpha, ExtraSamples 1, which Pillow divides by alpha at 8 bits)
SIXTEEN_BIT_RAWMODES = tuple(f"{mode};16{order}" for mode in ("RGB", "RGBA", "RGBX", "RGBa")
                             for order in "BLN") + ("LA;16B",)
OTHER_BYTE = {"B": "L", "L": "B", "N": "B" if sys.byteorder == "little" else "L"}  # raw mode order -> the other byte's
# Pillow raw modes of a TIFF's grey samples over 8 bits that name the file's byte order -> the machine's (N), for a
# file libtiff decodes: libtiff hands samples over in the machine's order, and Pillow renames only the ;16B and ;16L
# of colour and unsigned grey (TiffImagePlugin: "libtiff always returns the bytes in native order")
EXIF_ORIENTATION = 0x0112  # the EXIF (and TIFF) tag of the turn or mirroring a viewer applies
IMAGE_WIDTH, IMAGE_LENGTH = 256, 257  # the TIFF tags of the stored width and height
LIBTIFF_NATIVE_RAWMODES = {"I;16S": "I;16NS", "I;16BS": "I;16NS", "I;32S": "I;32NS", "I;32BS": "I;32NS",
                           "F;32F": "F;32NF", "F;32BF": "F;32NF"}
# The channel an EXR channel's name (after its layer's ".", lower case) stands for: the single letters and the words
# Hydra's EXR reader matches (its strIsComponent); Y is luminance.
EXR_CHANNEL_ROLES = {"r": "R", "red": "R", "g": "G", "green": "G", "b": "B", "blue": "B", "a": "A", "alpha": "A",
                     "y": "Y"}
EXR_CHROMA_ROLES = {"ry": "RY", "by": "BY"}  # the chroma beside Y of a luminance-chroma EXR (OpenEXR's RgbaYca)
GAMMA_PREFIX = "gamma "  # wrt's colour space "gamma <g>": samples decoded to linear as max(x, 0)^g (decode_curve)
PRIMARIES_SEPARATOR = " in "  # "<transfer> in <USD colour space>": decoded, then converted from its primaries
UDIM_FIRST = 1001  # number of the UDIM tile at st in [0, 1)^2
UDIM_COLUMNS = wp.constant(10)  # UDIM tiles per row (u = 0..9)
UDIM_ROWS = wp.constant(10)  # rows of UDIM tiles read (v = 0..9)
UDIM_TILES = 100  # UDIM_COLUMNS * UDIM_ROWS: tiles UDIM_FIRST .. UDIM_FIRST + 99
# Where a decoded image holds its file's channels, in the file's order (read_image): RGBA places 0 to 3.
GREY_CHANNELS = (0,)  # one channel, read (c, c, c, 1)
GREY_ALPHA_CHANNELS = (0, 3)  # two, grey and alpha, read (c, c, c, a)
COLOUR_CHANNELS = (0, 1, 2, 3)  # colour in its places (an RGB file's alpha 1)


class TextureError(ValueError):
    """An image file cannot be read."""


class TextureWarning(UserWarning):
    """Something the read of an image file went on past (a warning of Pillow's, a PNG gamma that is not decoded): its
    message names the file; ``words`` says what without the file's name, for the readers that name the file and the
    shader or light reading it (:func:`read_image`'s ``warn``)."""

    def __init__(self, message: str, words: str):
        super().__init__(message)
        self.words = words  # the message without the file's name


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """The inverse sRGB transfer function (IEC 61966-2-1), negatives on its linear segment, as MaterialX's
    ``srgb_texture`` transform takes them: the power's base is ``max(x + 0.055, 0)``, as there, so that the power
    taken of every number before the choice does not warn of an invalid value for a negative one."""
    x = np.asarray(x, np.float32)
    return np.where(x <= 0.04045, x / 12.92, np.power(np.maximum(x + 0.055, 0.0) / 1.055, 2.4)).astype(np.float32)


def decode_curve(color_space: str):
    """The function that decodes colour samples in wrt's colour space ``color_space`` to linear float32: ``sRGB``
    :func:`srgb_to_linear`, ``gamma <g>`` ``max(x, 0)^g`` (MaterialX's ``g22_rec709``, ``g18_rec709``, ... as its
    colour transforms decode them); None for ``raw`` (and ``auto``, which :func:`read_image` settles first)."""
    if color_space == "sRGB":
        return srgb_to_linear
    if color_space.startswith(GAMMA_PREFIX):
        gamma = float(color_space[len(GAMMA_PREFIX):])
        return lambda x: np.power(np.maximum(np.asarray(x, np.float32), 0.0), gamma, dtype=np.float32)
    return None


def split_color_space(color_space: str) -> tuple[str, str | None]:
    """``(transfer, primaries)`` of wrt's colour space ``color_space``: the transfer function :func:`decode_curve`
    takes, and the USD colour space whose primaries its colour is converted from (:func:`convert_primaries`), None
    for Rec.709's (no ``" in "``)."""
    transfer, _, primaries = color_space.partition(PRIMARIES_SEPARATOR)
    return transfer, primaries or None


def convert_primaries(rgba: np.ndarray, primaries: str | None) -> np.ndarray:
    """``rgba`` (``(H, W, 4)`` float32, converted in place and returned), its colour linear in the primaries of USD
    colour space ``primaries``, with its colour in linear Rec.709: times :func:`wrt.color_spaces.gamut_matrix`
    (``Gf.ColorSpace``'s, as ``Gf.ColorSpace.Convert`` converts), in float64, in slices of rows of about
    :data:`PACK_TEXELS` texels (no image-sized temporaries); alpha kept. Nothing for None. Colours outside Rec.709's
    gamut get negative channels, as USD's conversion gives them."""
    if primaries is None:
        return rgba
    from .color_spaces import gamut_matrix  # it imports decode_curve from here

    matrix = gamut_matrix(primaries).T
    rows = max(1, PACK_TEXELS // max(rgba.shape[1], 1))
    with np.errstate(over="ignore", invalid="ignore"):  # past float32: inf, named where the texels are packed
        for start in range(0, rgba.shape[0], rows):
            part = rgba[start : start + rows, :, :3]
            part[...] = part.astype(np.float64) @ matrix
    return rgba


def read_asset_bytes(resolved_path: str) -> bytes:
    """The bytes of a resolved USD asset path, including files packed inside ``.usdz`` archives."""
    import os

    from pxr import Ar

    if os.path.isdir(resolved_path):
        raise TextureError(f"cannot open {resolved_path}: it is a folder")
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved_path))
    if asset is None:
        raise TextureError(f"cannot open {resolved_path}")
    buffer = asset.GetBuffer()  # None for an empty file
    return b"" if buffer is None else bytes(buffer)


def load_image(resolved_path: str, color_space: str = "auto", warn=None) -> np.ndarray:
    """Reads an image into ``(H, W, 4)`` float32 linear RGBA (see the module docstring for ``color_space``;
    ``warn``: :func:`read_image`'s).

    Raises:
        TextureError: the file is missing or no reader understands it.
    """
    return read_image(resolved_path, color_space, warn)[0]


def read_image(resolved_path: str, color_space: str = "auto", warn=None) -> tuple[np.ndarray, tuple[int, ...]]:
    """:func:`load_image`'s pixels and the RGBA places of the file's channels, in the file's order: grey
    :data:`GREY_CHANNELS`, grey + alpha :data:`GREY_ALPHA_CHANNELS` (an EXR of two channels too, ``R G`` read as
    grey + alpha), colour :data:`COLOUR_CHANNELS` (an EXR's colour channels where it has them: ``R G A`` is
    ``(0, 1, 3)``). :func:`materialx_texels` lays them out as a MaterialX image node reads them.

    ``warn``: called with the ``words`` of each :class:`TextureWarning` about the file (once each), where a reader
    names the file and what reads it; None: each is warned, naming the file. Pillow's own warnings (of a damaged
    tag, corrupt EXIF data) are among them: they named no file."""
    try:
        data = read_asset_bytes(resolved_path)
    except TextureError:
        raise
    except Exception as e:  # noqa: BLE001 - Ar raises Tf errors of various kinds
        raise TextureError(f"cannot open {resolved_path}: {e}") from None
    if not data:  # Pillow's words for it were "cannot identify image file <_io.BytesIO object at 0x...>"
        raise TextureError(f"cannot read image {resolved_path}: the file is empty")
    from .radiance_hdr import is_radiance, read_radiance  # it imports TextureError from here

    name = resolved_path.lower().rstrip("]")
    if is_radiance(data, name):
        rgba, channels, auto_srgb = read_radiance(data, resolved_path), COLOUR_CHANNELS, False
    elif name.endswith(".exr") or data[:4] == b"\x76\x2f\x31\x01":
        (rgba, channels), auto_srgb = _read_exr(data, resolved_path), False
    else:
        with _warnings_told(resolved_path, warn):
            rgba, channels, auto_srgb = _read_pillow(data, resolved_path, color_space == "auto")
    transfer, primaries = split_color_space(color_space)
    decode = decode_curve(("sRGB" if auto_srgb else "raw") if color_space == "auto" else transfer)
    if rgba.dtype == np.uint8:
        pixels = _decode_8bit(rgba, decode)
    else:
        if decode is not None:
            rgba[..., :3] = decode(rgba[..., :3])
        pixels = np.ascontiguousarray(rgba, dtype=np.float32)
    # Colour in its places is the colour both layouts read; the others convert the colour they lay out.
    return (convert_primaries(pixels, primaries) if reads_in_place(channels) else pixels), channels


def reads_in_place(channels: tuple[int, ...]) -> bool:
    """Whether a MaterialX image node reads a file whose channels lie at RGBA places ``channels`` (:func:`read_image`)
    as they are decoded: colour in its places, alpha (1 where the file has none) fourth."""
    return tuple(channels[:3]) == (0, 1, 2)


def materialx_texels(pixels: np.ndarray, channels: tuple[int, ...], decode=None, primaries=None) -> np.ndarray:
    """``pixels`` (:func:`read_image`'s, the file's channels at RGBA places ``channels``) as a MaterialX image node
    reads its file: the file's channels first, in its order, 0 past them but for a fourth of 1, as the Standard
    Nodes specification has it and MaterialX's GLSL, MSL and OSL implementations sample (MaterialX pull requests
    2985 and 3073): grey ``(c, 0, 0, 1)``, grey + alpha ``(c, a, 0, 1)``, an EXR's ``R G`` ``(R, G, 0, 1)``.
    UsdUVTexture reads grey as ``(c, c, c)`` and two channels as grey + alpha (the UsdPreviewSurface specification's
    rule).
    ``pixels`` itself where they lie so already (colour in its places). ``decode``: the :func:`decode_curve` the
    ``pixels`` were decoded by (:func:`read_image` decodes places 0 to 2, not alpha), and MaterialX's colour
    transform, applied to the node's output, decodes all of its colour channels: a file's alpha laid into r, g or b
    is decoded there too. ``primaries``: the USD colour space whose primaries that output is converted from
    (:func:`convert_primaries`, as :func:`read_image` converted ``pixels`` that lie in place); a grey file's
    ``(c, 0, 0)`` is converted as the colour it is, as MaterialX's transform takes it."""
    if reads_in_place(channels):
        return pixels
    texels = np.zeros(pixels.shape, np.float32)
    texels[..., 3] = 1.0
    for k, place in enumerate(channels):
        texels[..., k] = decode(pixels[..., place]) if decode is not None and k < 3 <= place else pixels[..., place]
    return convert_primaries(texels, primaries)


def preview_texels(pixels: np.ndarray, channels: tuple[int, ...], primaries=None) -> np.ndarray:
    """``pixels`` (:func:`read_image`'s) as UsdUVTexture reads them (grey ``(c, c, c)``, colour channels in their
    places, a missing one 0) with that colour converted from the primaries of USD colour space ``primaries``
    (:func:`convert_primaries`): ``pixels`` itself where :func:`read_image` converted them (colour in its places) or
    there is nothing to convert, else a converted copy."""
    if primaries is None or reads_in_place(channels):
        return pixels
    return convert_primaries(np.array(pixels, np.float32, order="C"), primaries)


def _decode_8bit(rgba: np.ndarray, decode=None) -> np.ndarray:
    """``(H, W, 4)`` float32 linear RGBA of ``(H, W, 4)`` uint8 samples (colour decoded by ``decode``, a
    :func:`decode_curve`, where given), looked up in 256-entry tables of the values ``sample / 255`` (and ``decode``
    of them) take: the same numbers as converting the whole image in float32, without its image-sized temporaries (an
    8k x 8k texture took 3.7 GB and 9 s to read into its 1 GB of texels)."""
    linear = np.arange(256, dtype=np.float32) / 255.0
    tables = (linear if decode is None else decode(linear),) * 3 + (linear,)
    out = np.empty(rgba.shape, np.float32)
    for c, table in enumerate(tables):
        out[..., c] = table[rgba[..., c]]
    return out


def png_bit_depth(data: bytes) -> int:
    """Bits per sample of a PNG file's bytes (its ``IHDR`` header), 0 for any other format."""
    if len(data) > 25 and data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR":
        return data[24]
    return 0


def _read_pillow(data: bytes, name: str, auto: bool = False) -> tuple[np.ndarray, tuple[int, ...], bool]:
    """The image as ``(H, W, 4)`` RGBA samples, the places of its channels (:func:`read_image`) and whether
    ``auto`` reads it as sRGB: as the file's colour space metadata says (:func:`tagged_srgb`), else for 8-bit
    colour. ``auto``: the file is read as ``auto``, so a PNG gamma that says neither is named in a warning."""
    rgba, channels, is_8bit_color, tagged = _read_pillow_samples(data, name, auto)
    return rgba, channels, is_8bit_color if tagged is None else tagged


def tagged_srgb(img) -> bool | None:
    """Whether a PNG's colour space chunks mark it sRGB (an ``sRGB`` chunk, or ``gAMA`` within 0.1 of 1/2.2) or
    linear (``gAMA`` within 0.1 of 1); None without such a chunk or for other formats. ``img``: the file opened by
    Pillow, which parses the chunks before the image data when it opens it (the file is read once).

    UsdUVTexture's ``auto`` checks the file's colour space metadata before it guesses from the sample type, and
    Hydra's PNG reader (stb_image, patched to return ``gAMA``) decides with the same tolerances: colour written with
    ``gAMA`` 1 was decoded as sRGB. Storm differs in two ways, where wrt keeps to the specification's "if metadata
    is indicative of sRGB, mark texture as sRGB": its reader reads no ``sRGB`` chunk (``gAMA`` alone, which decides
    here too where both are present and it is one of the two), so a grey PNG with an ``sRGB`` chunk and no ``gAMA``
    is raw to it; and it refuses a one- or two-channel texture marked sRGB (hdSt's textureUtils: "One and two channel
    srgb texture formats not supported by Storm") and draws the fallback, where wrt decodes the grey by the sRGB
    curve (an 8-bit grey roughness map saved with ``gAMA`` 0.45455, as image editors write it, reads 0.21 for 128)."""
    if img.format != "PNG":
        return None
    gamma = img.info.get("gamma")
    if isinstance(gamma, (int, float)) and abs(gamma - 1.0 / 2.2) < 0.1:
        return True
    if isinstance(gamma, (int, float)) and abs(gamma - 1.0) < 0.1:
        return False
    return True if "srgb" in img.info else None


def _warn_unread_gamma(name: str, gamma: float) -> None:
    """Names a PNG whose ``gAMA`` (``gamma``) is neither sRGB's nor linear, which ``auto`` does not decode: its
    samples are then read by the guess from their type, as Storm's reader reads them after its own warning
    ("Unsupported gamma encoding"). A map saved with gamma 1/1.8 was read so without a word."""
    words = (f"gAMA {gamma:.5g} is neither sRGB's 1/2.2 nor linear 1 (within 0.1, as Storm's reader reads it) and is "
             "not decoded; sourceColorSpace auto reads the file as for no gamma (sRGB for 8-bit colour, else as "
             "stored), as Storm does; author sourceColorSpace to say which")
    _texture_warning(TextureWarning(f"PNG {name}: {words}", f"PNG {words}"), stacklevel=4)


# Warnings given while textures are read (_warnings_told): the readers inside, the hook put in place by the first in
# and taken away by the last out, and the record of each thread reading (thread id -> warnings). Each read kept its
# own (warnings.catch_warnings): reads in two threads ending in the order they began left the first's recorder as the
# process's hook for good, every later warning of the process recorded into it and never shown. No filter is added:
# filters are the process's, so one added for a read ("always" for Pillow's and wrt's texture warnings) overrode the
# user's in every thread while any read ran (a TextureWarning the user made an error was shown, not raised), and
# Pillow's warnings, told again as TextureWarnings from wrt, escaped the user's filters by Pillow's module or words.
_WARNING_CAPTURE = {"lock": threading.Lock(), "readers": 0, "hook": None, "records": {}}


def _from_pillow(filename: str) -> bool:
    """Whether a warning given at ``filename`` is Pillow's (given in one of its modules)."""
    return "PIL" in filename.replace("\\", "/").split("/")


def _record_warning(message, category, filename, lineno, file=None, line=None):
    """``warnings.showwarning`` while textures are read: Pillow's warning given in a thread reading one (past the
    user's filters) is recorded for that read; any other is shown by the hook there was before, as it would have
    been."""
    record = _WARNING_CAPTURE["records"].get(threading.get_ident())
    if record is None or not _from_pillow(filename):
        _WARNING_CAPTURE["hook"](message, category, filename, lineno, file, line)
    else:
        record.append(warnings.WarningMessage(message, category, filename, lineno, file, line))


def _texture_warning(message: TextureWarning, stacklevel: int) -> None:
    """Warns ``message`` (``stacklevel``: :func:`warnings.warn`'s, from the caller), recorded for the read of this
    thread where there is one, to be told by :func:`_tell` (through the user's filters, or the reader's ``warn``)."""
    record = _WARNING_CAPTURE["records"].get(threading.get_ident())
    if record is None:
        warnings.warn(message, stacklevel=stacklevel + 1)
    else:
        record.append(warnings.WarningMessage(message, type(message), __file__, 0))


def _forget_pillows_warnings() -> None:
    """Empties the registries of Pillow's modules (where Python notes a warning given, not to give it again from the
    same place under the ``default`` action): a warning Pillow gave for an earlier file is given for this one too."""
    for module_name, module in list(sys.modules.items()):
        if module_name == "PIL" or module_name.startswith("PIL."):
            registry = getattr(module, "__warningregistry__", None)
            if isinstance(registry, dict):
                registry.clear()


@contextlib.contextmanager
def _warnings_told(name: str, warn=None):
    """Tells the warnings of Pillow (given from its modules, as the user's filters let them through) and the
    :class:`TextureWarning` ones given while file ``name`` is read in this thread, once each, through ``warn``
    (:func:`read_image`'s), else as warnings naming the file; others are shown as they are given. Pillow's name no
    file ("Tag data larger than file. Skipping tag 270"), and a 16-bit file, which Pillow opens once per byte, gave
    each two or three times."""
    capture, ident = _WARNING_CAPTURE, threading.get_ident()
    with capture["lock"]:
        if not capture["readers"]:
            # (the recorder itself where a catch_warnings of another thread, entered while a read ran and left after
            # it, put it back: passing warnings on to it recursed without end; the hook kept before is kept)
            if warnings.showwarning is not _record_warning:
                capture["hook"] = warnings.showwarning
            warnings.showwarning = _record_warning
        capture["readers"] += 1
        outer = capture["records"].get(ident)  # (a read inside a read of this thread: its own record)
        capture["records"][ident] = caught = []
        _forget_pillows_warnings()
    try:
        yield
    finally:
        with capture["lock"]:
            if outer is None:
                del capture["records"][ident]
            else:
                capture["records"][ident] = outer
            capture["readers"] -= 1
            if not capture["readers"] and warnings.showwarning is _record_warning:
                # (a hook another thread put in place while the reads ran, as logging.captureWarnings does, stays:
                # the hook of before was put back over it, and later warnings went past it)
                warnings.showwarning = capture["hook"]
        _tell(name, caught, warn)


def _tell(name: str, caught: list, warn=None) -> None:
    """:func:`_warnings_told`'s telling of the warnings ``caught`` while file ``name`` was read."""
    told = set()
    for w in caught:
        ours = isinstance(w.message, TextureWarning)
        words = w.message.words if ours else f"Pillow warned while reading it: {w.message}"
        if words in told:
            continue
        told.add(words)
        if warn is not None:
            warn(words)
        else:
            warnings.warn(w.message if ours else TextureWarning(f"image {name}: {words}", words), stacklevel=5)


# Pillow's decompression-bomb limit, lifted while textures are read (_pillow_size_limit_lifted): the readers inside
# and the limit to put back when the last of them is done
_PILLOW_LIFT = {"lock": threading.Lock(), "readers": 0, "limit": None}


@contextlib.contextmanager
def _pillow_size_limit_lifted():
    """Pillow's decompression-bomb limit (``PIL.Image.MAX_IMAGE_PIXELS``) lifted while a texture is read with it, and
    put back after. Pillow refused images of more than 179 million pixels (a 16k x 16k texture read its fallback,
    named with words of a "decompression bomb DOS attack") and warned of them past 89 million (a 16k x 8k panorama):
    Storm's readers take them, and wrt reads the whole image anyway (:func:`pack_images` refuses more than 2^31
    texels). The limit is Pillow's module state: an image another thread opens with Pillow meanwhile goes without it
    too. Reads in several threads share one lift (:data:`_PILLOW_LIFT`): the first in keeps the limit and the last out
    puts it back. Each kept its own, so where the first out was the first in, the second put back the None it found
    and the limit stayed lifted for good."""
    from PIL import Image as PilImage

    with _PILLOW_LIFT["lock"]:
        if not _PILLOW_LIFT["readers"]:
            _PILLOW_LIFT["limit"] = PilImage.MAX_IMAGE_PIXELS
            PilImage.MAX_IMAGE_PIXELS = None
        _PILLOW_LIFT["readers"] += 1
    try:
        yield
    finally:
        with _PILLOW_LIFT["lock"]:
            _PILLOW_LIFT["readers"] -= 1
            if not _PILLOW_LIFT["readers"]:
                PilImage.MAX_IMAGE_PIXELS = _PILLOW_LIFT["limit"]


def _read_pillow_samples(data: bytes, name: str, auto: bool = False) -> tuple[np.ndarray, tuple[int, ...], bool,
                                                                             bool | None]:
    """The samples and their channels' places as :func:`_read_pillow` gives them, whether they are 8-bit colour,
    and :func:`tagged_srgb` (``auto``: :func:`_read_pillow`'s)."""
    from PIL import Image as PilImage

    problem = png_chunk_problem(data)
    if problem:
        raise TextureError(f"cannot read image {name}: {problem}, which Storm's PNG reader (stb_image) refuses")
    data = without_unread_chunks(data)
    if data[:4] == BIG_ENDIAN_BIGTIFF:  # (before Pillow, whose misreading of it warned of "Corrupt EXIF data" too)
        raise TextureError(f"cannot read image {name}: a big-endian BigTIFF, which Pillow (wrt's TIFF reader) does not "
                           "open (it reads its header as a classic TIFF's); save it in little-endian (Intel) byte "
                           "order, or as EXR")
    _refuse_damaged_tiff(data, name)
    data = with_byte_numbers_as_shorts(data)  # (libtiff reads them so; Pillow opens no file of some)
    try:
        with _pillow_size_limit_lifted():
            _refuse_undefined_alpha(data, name)
            planar = _planar_layout(data)
            if planar is not None:  # (read before Pillow opens it, which it does not for some; TIFFs are not PNGs)
                return *_read_planes(data, name, *planar), planar[:2] == (8, 3), None
            grey_plane = _grey_plane_alone(data)
            if grey_plane is not None:  # (its grey: one sample, read as such below)
                return _read_pillow_samples(grey_plane, name, auto)
            white = _white_is_zero_bits(data)
            if white is not None:  # (read as BlackIsZero, which Pillow opens, and inverted here)
                rgba, channels, colour, tagged = _read_pillow_samples(
                    with_value(tiff_directory(data), PHOTOMETRIC, BLACK_IS_ZERO), name, auto)
                return _inverted_grey(rgba, white), channels, colour, tagged
            img = PilImage.open(io.BytesIO(data))
            _refuse_oversized(img, name)
            _tiff_decoded_as_stored(img)
            tagged = tagged_srgb(img)  # before load(), which goes on to the chunks after the image data
            if auto and tagged is None and isinstance(img.info.get("gamma"), (int, float)):
                _warn_unread_gamma(name, img.info["gamma"])
            rawmode = _sixteen_bit_rawmode(img)
            if rawmode is not None:
                # 16-bit colour (or grey + alpha) PNG or TIFF: Pillow would keep the high byte only. Hydra reads PNGs
                # with stb_image, as 8-bit samples whatever their depth, so auto takes 16-bit RGB(A) PNGs for sRGB as
                # 8-bit ones; TIFFs go through OpenImageIO, whose 16-bit samples are linear.
                key = img.info.get("transparency") if rawmode == "RGB;16B" else None  # a 16-bit RGB PNG's tRNS
                return *_read_16bit(data, rawmode, key), img.format == "PNG" and rawmode != "LA;16B", tagged
            premultiplied = {_tile_rawmode(tile) for tile in img.tile}
            if premultiplied in ({"RGBa"}, {"RGBaX"}, {"RGBaXX"}):
                # 8-bit colour premultiplied by alpha (a TIFF's ExtraSamples 1; X: a sample of no stated meaning past
                # alpha): Pillow's RGBa, RGBaX and RGBaXX unpackers divide it by alpha truncating (100 over 201 read
                # 126/255 for 126.87/255, 3.4e-3 off); decoded as stored (RGBA, RGBAX, RGBAXX) and divided here in
                # float32, as 8-bit grey (La), 16-bit colour and planes are
                stored = premultiplied.pop().replace("RGBa", "RGBA")
                img.tile = [tile._replace(args=(stored, *tile[3][1:])) for tile in img.tile]
                img.load()
                samples = np.asarray(img, dtype=np.float32)
                return _colour_rgba(samples, True, 255.0), COLOUR_CHANNELS, True, tagged
            img.load()
    except PilImage.UnidentifiedImageError:  # its words name a BytesIO object at a memory address
        from PIL.TiffImagePlugin import COMPRESSION_INFO

        directory = tiff_directory(data)
        damaged = [] if directory is None else tags_past_end(directory)
        if damaged:  # (none of PIXEL_TAGS, refused above: Pillow opens no TIFF with some tags past its end)
            _warn_skipped_tags(name, damaged)
            return _read_pillow_samples(without_tags(directory, damaged), name, auto)

        compression = (tiff_first_values(data, (COMPRESSION,)) or {}).get(COMPRESSION, 1)
        if compression not in COMPRESSION_INFO:  # (Pillow's decoders by Compression value; 1 for other formats)
            known = f" ({COMPRESSION_NAMES[compression]})" if compression in COMPRESSION_NAMES else ""
            raise TextureError(f"cannot read image {name}: a TIFF of Compression {compression}{known}, which Pillow "
                               "(wrt's TIFF reader) does not decode; save it uncompressed, or with LZW, deflate or "
                               "ZSTD compression, or as EXR") from None
        layout = tiff_sample_layout(data)  # a TIFF of samples Pillow does not decode (float colour, ...)
        if layout is not None:
            raise TextureError(f"cannot read image {name}: a TIFF of {layout}, which Pillow (wrt's TIFF reader) does "
                               "not decode; an EXR holds such samples") from None
        raise TextureError(f"cannot read image {name}: no image reader wrt has (Pillow, OpenEXR, Radiance) knows its "
                           "format") from None
    except TextureError:
        raise
    except Exception as e:  # noqa: BLE001 - Pillow raises many kinds
        raise TextureError(f"cannot read image {name}: {_pillows_words(e)}") from None
    mode = img.mode
    if mode in ("I;16", "I;16B", "I;16L", "I"):
        # Older Pillow versions open 16-bit grey PNGs as mode "I".
        if mode.startswith("I;16") or png_bit_depth(data) == 16:
            # Pillow holds a 12-bit TIFF's samples as they are (raw mode I;12) in this 16-bit mode: they read over
            # 4095, as OpenImageIO scales them to full range (over 65535 a white of 4095 read 0.06)
            samples = tiff_samples(data)
            bits = samples[1] if samples is not None and 1 < samples[1] < 16 else 16
            full, grey = float((1 << bits) - 1), np.asarray(img, dtype=np.float32)
        else:
            full, grey = _integer_grey(data, img)
        return *_grey_rgba(grey / full, _transparent_sample_alpha(img, grey)), False, tagged
    if mode == "F":
        return *_grey_rgba(np.asarray(img, dtype=np.float32), None), False, tagged
    if mode == "La":
        # 8-bit grey premultiplied by alpha (a TIFF's ExtraSamples 1), which Pillow converts to nothing asked of it
        # here: the load of a whole stage failed ('conversion from La to L not supported'). Made straight as 8-bit
        # RGBa colour (above) and 16-bit colour (_colour_rgba) are
        return *_grey_alpha_rgba(np.asarray(img, dtype=np.float32), True, 255.0), False, tagged
    if mode == "L" and tiff_samples(data) == (1, 8, SIGNED):
        # Pillow hands a TIFF's signed bytes over unsigned (-1 read 1.0): they read over 127, as _integer_grey's
        grey = np.asarray(img).view(np.int8).astype(np.float32)
        return *_grey_rgba(grey / 127.0, None), False, tagged
    transparent, depth = img.info.get("transparency"), png_bit_depth(data)
    if mode == "L" and isinstance(transparent, int) and depth in (2, 4):
        # Pillow keeps a 2- or 4-bit grey PNG's tRNS sample as stored but scales the pixels to 8 bits, so its LA
        # conversion made no pixel transparent; stb_image scales the sample too (stbi__depth_scale_table).
        grey = np.asarray(img, dtype=np.float32)
        alpha = _transparent_sample_alpha(img, grey, 255 // (2**depth - 1))
        return *_grey_rgba(grey / 255.0, alpha), False, tagged
    if mode in ("1", "L", "LA"):  # "1": a 1-bit grey PNG, one grey channel as "L" has
        arr = np.asarray(img.convert("LA"), dtype=np.float32) / 255.0
        # Pillow's LA conversion turns a grey PNG's transparent sample (its tRNS chunk) into alpha 0.
        alpha = arr[..., 1] if mode == "LA" or "transparency" in img.info else None
        return *_grey_rgba(arr[..., 0], alpha), False, tagged
    arr = np.asarray(img.convert("RGBA"), dtype=np.uint8)  # scaled to [0, 1] by load_image (_decode_8bit)
    if img.format == "BMP" and mode == "RGB":
        alpha = bmp_fourth_byte_alpha(data, arr.shape[:2])
        if alpha is not None:
            arr = arr.copy()
            arr[..., 3] = alpha
    return arr, COLOUR_CHANNELS, True, tagged  # 8-bit colour: deeper colour samples were read at full depth above


def _white_is_zero_bits(data: bytes) -> int | None:
    """Bits of the samples of file ``data`` where it is a TIFF of WhiteIsZero unsigned grey (TIFF 6.0: 0 is white,
    the largest value black) that Pillow reads only as BlackIsZero grey (then inverted: :func:`_inverted_grey`): of 12
    or 16 bits, or of 8 bits and more than one sample; None for any other file. Pillow inverts 8-bit grey alone (raw
    mode ``L;I``): it handed 16-bit grey over as stored (white read black, a quarter grey 0.25 for 0.75), and opened
    no 12-bit, big-endian 16-bit or 8-bit grey + alpha one (named as samples "an EXR holds")."""
    tags = tiff_first_values(data, (PHOTOMETRIC, SAMPLES_PER_PIXEL, BITS_PER_SAMPLE, SAMPLE_FORMAT))
    if tags is None or tags.get(PHOTOMETRIC) != WHITE_IS_ZERO or tags.get(SAMPLE_FORMAT, UNSIGNED) != UNSIGNED:
        return None
    bits = tags.get(BITS_PER_SAMPLE, 1)
    return bits if bits in (12, 16) or (bits == 8 and tags.get(SAMPLES_PER_PIXEL, 1) > 1) else None


def _inverted_grey(rgba: np.ndarray, bits: int) -> np.ndarray:
    """``rgba`` (float32 grey of ``bits``-bit samples over their largest value, in places 0 to 2) with its grey
    inverted in place, of the whole samples: ``(full - sample) / full``, one rounding in float32 as the samples were
    divided."""
    full = np.float32((1 << bits) - 1)
    rgba[..., :3] = (full - np.rint(rgba[..., :3] * full)) / full
    return rgba


def _refuse_damaged_tiff(data: bytes, name: str) -> None:
    """Refuses a TIFF (file ``data``, named ``name``) whose image file directory lies past its end or is cut short
    (a BigTIFF's offset of 2^63 or more escaped as struct's OverflowError), with a tag of
    :data:`wrt.tiff_checks.PIXEL_TAGS` whose values lie past its end (a damaged or cut file), or a strip or tile of
    no data or, uncompressed, of fewer bytes than its rows fill (:func:`wrt.tiff_checks.piece_problem`), before
    Pillow, which skipped some such tags with a warning and read the samples by the tag's default (SampleFormat: as
    unsigned integers), refused others in words of samples it does not decode, and read an uncompressed file's header,
    or the next strip's bytes, as samples."""
    directory = tiff_directory(data)
    if directory is None:
        if data[:4] in TIFF_MAGIC:  # (Pillow's words: 'Unable to seek to frame', or none it knows the format)
            raise TextureError(f"cannot read image {name}: its TIFF image file directory lies past the file's end or "
                               "is cut short: the file is damaged or cut short")
        return
    damaged = [tag for tag in tags_past_end(directory) if tag in PIXEL_TAGS]
    if damaged:
        raise TextureError(f"cannot read image {name}: its TIFF tag {damaged[0]}'s values lie past the file's end: "
                           "the file is damaged or cut short")
    problem = piece_problem(directory)
    if problem is not None:
        raise TextureError(f"cannot read image {name}: {problem}")


def _pillows_words(error: Exception) -> str:
    """Words for an ``error`` Pillow raised reading an image: its own, but for a failure of its libtiff decoder,
    which Pillow words "decoder error -2" whatever failed (a damaged or cut deflate stream, JPEG data libtiff refuses,
    ...): that is said, Pillow's words kept."""
    from PIL.ImageFile import ERRORS

    words = str(error) or type(error).__name__
    code = words.removeprefix("decoder error ")
    if code == words or not code.lstrip("-").isdigit():  # (TiffImagePlugin's words, of libtiff's decoder alone)
        return words
    return (f"libtiff could not decode its compressed strips or tiles (Pillow's {words}: "
            f"{ERRORS.get(int(code), 'a failure')}): their data is damaged, cut short or of a kind libtiff does not "
            "read, or too large")


def _warn_skipped_tags(name: str, tags: list[int]) -> None:
    """Names the tags of a TIFF (file ``name``) whose values lie past its end and are skipped (none of
    :data:`wrt.tiff_checks.PIXEL_TAGS`, as libtiff skips them): Pillow refused such a file where their sizes fit in it
    (pixel by pixel: as samples it does not decode, "an EXR holds such samples"; plane by plane too)."""
    for tag in tags:
        words = f"TIFF tag {tag}'s values lie past the file's end (a damaged file); the tag is skipped"
        _texture_warning(TextureWarning(f"image {name}: {words}", words), stacklevel=6)


def _refuse_undefined_alpha(data: bytes, name: str) -> None:
    """Refuses a TIFF (file ``data``, named ``name``) of WhiteIsZero grey premultiplied by alpha
    (``PhotometricInterpretation`` 0, ``ExtraSamples`` 1), which TIFF 6.0 leaves undefined (associated alpha is
    defined for colour stored as intensity, 0 black): Pillow opens no such file, and wrt named it as samples Pillow does
    not decode that an EXR holds, as if of a kind of number, not of a meaning no reader agrees on."""
    tags = tiff_first_values(data, (SAMPLES_PER_PIXEL, PHOTOMETRIC, EXTRA_SAMPLES))
    if tags is not None and tags.get(PHOTOMETRIC) == WHITE_IS_ZERO and tags.get(SAMPLES_PER_PIXEL, 1) > 1 and (
            tags.get(EXTRA_SAMPLES) == ASSOCIATED_ALPHA):
        raise TextureError(f"cannot read image {name}: a TIFF of WhiteIsZero grey (PhotometricInterpretation 0) "
                           "premultiplied by alpha (ExtraSamples 1), which TIFF 6.0 leaves undefined; save it as "
                           "BlackIsZero grey (1), or with unassociated alpha (ExtraSamples 2)")


def _refuse_oversized(img, name: str) -> None:
    """Refuses image ``img`` (opened by Pillow, not yet decoded; file ``name``) of more texels than wrt's textures
    hold together, from its header's size, before Pillow, whose own limit is lifted, allocates it: a damaged size
    (60000 x 60000, 10.8 GB of 8-bit RGB) was decoded before pack_images refused it, or ran out of memory."""
    if img.width * img.height >= MAX_TEXELS:
        raise TextureError(f"cannot read image {name}: it is {img.width} x {img.height} pixels, more than the 2^31 "
                           "texels wrt's textures hold together")


def _integer_grey(data: bytes, img) -> tuple[float, np.ndarray]:
    """``(full, samples)`` of the grey image Pillow opened as 32-bit integers (mode ``I``) from file ``data``:
    ``samples`` (float32) over ``full`` read it in [0, 1] (signed ones in [-1, 1]), the largest value of its sample
    type, as Pillow scales 8- and 16-bit samples and OpenImageIO, Storm's TIFF reader, converts integer samples to
    float. A TIFF's 32-bit unsigned samples, which Pillow holds as signed, are taken as unsigned. The grey was divided
    by the image's own largest value: a 16-bit signed map read its values over whatever its brightest was, and a
    32-bit unsigned one of a value past 2^31 read -4214. Another file of this mode keeps that division."""
    samples = tiff_samples(data)
    if samples is None or samples[2] not in (UNSIGNED, SIGNED) or not 1 < samples[1] <= 32:
        grey = np.asarray(img, dtype=np.float32)
        return max(1.0, float(np.max(grey))), grey
    bits = samples[1]
    if samples[2] == UNSIGNED:
        grey = np.asarray(img).astype(np.int64) % (1 << 32)  # Pillow's int32 of a value past 2^31 wraps negative
        return float((1 << bits) - 1), grey.astype(np.float32)
    return float((1 << (bits - 1)) - 1), np.asarray(img, dtype=np.float32)


def bmp_fourth_byte_alpha(data: bytes, shape: tuple[int, int]) -> np.ndarray | None:
    """``(H, W)`` uint8 alpha of a 32-bit uncompressed (``BI_RGB``) BMP: each pixel's fourth byte, as Storm's
    stb_image reader takes it (``stbi__bmp_set_mask_defaults``: alpha mask 0xff000000), all 255 where every one is
    0 (an unused byte, as stb_image reads it); None for other BMPs. Pillow reads the byte as padding, so the
    cut-outs of a 32-bit BMP were opaque."""
    if len(data) < 34 or data[:2] != b"BM":
        return None
    (offset,) = struct.unpack("<I", data[10:14])  # where the pixels start
    header, width, height, _, bits, compression = struct.unpack("<IiiHHI", data[14:34])  # BITMAPINFOHEADER
    rows = abs(height)
    if header < 40 or bits != 32 or compression != 0 or (rows, width) != tuple(shape):
        return None
    if len(data) < offset + rows * width * 4:
        return None
    alpha = np.frombuffer(data, np.uint8, count=rows * width * 4, offset=offset).reshape(rows, width, 4)[..., 3]
    alpha = alpha[::-1] if height > 0 else alpha  # positive height: the bottom row first
    return alpha if alpha.any() else np.full(shape, 255, np.uint8)


def _tiff_decoded_as_stored(img) -> None:
    """Sets TIFF ``img`` (opened by Pillow) to decode its samples as the file stores them.

    Its ``Orientation`` (an EXIF tag, or XMP's) is ignored, as Storm's reader (OpenImageIO's ``read_image``) and wrt
    for a JPEG's EXIF ignore it: Pillow turned the pixels by it as it loaded them, so a TIFF of orientation 3 was
    drawn upside down and mirrored. And the decoder tiles are set right where Pillow's are wrong. libtiff decodes a
    compressed TIFF (LZW, deflate, ...) and hands its samples over in the machine's byte order, where Pillow unpacks
    a big-endian file's signed or float grey in the file's (:data:`LIBTIFF_NATIVE_RAWMODES`): a deflate-compressed
    big-endian grey of signed 16-bit samples read 0.19 for 0.03, of floats 1e34 for 0.5. A compressed 16-bit
    colour TIFF's raw mode is ``RGB;16N`` (or ``RGBA;16N``), one of :data:`SIXTEEN_BIT_RAWMODES`: it was read at 8
    bits, and as sRGB under ``auto`` (0.5 read 0.216). (A grey or RGB TIFF of several samples stored plane by plane
    is read plane by plane instead, before Pillow opens it: :func:`_read_planes`.)"""
    if img.format != "TIFF" or not img.tile:
        return
    if img.tag_v2.get(PLANAR_CONFIGURATION, 1) == 2 and img.tag_v2.get(SAMPLES_PER_PIXEL, 1) == 1:
        # One sample per pixel is stored alike plane by plane or not (TIFF 6.0: the tag is then irrelevant), but
        # Pillow unpacked an uncompressed one by the first letter of its raw mode: 16-bit grey failed ('unknown raw
        # mode'), signed 16-bit read 6.5e4 off, big-endian floats 2e38: its tiles are made again as of a plane
        img.tag_v2[PLANAR_CONFIGURATION] = 1
        img._setup()  # (what Pillow runs for each frame it seeks to, from the tags)
    img.getexif().pop(EXIF_ORIENTATION, None)  # what load_end's exif_transpose reads (Pillow keeps this one)
    # Pillow 11+ gives an image of orientation 5 to 8 (a quarter turn) its turned size at open: decoded into it as
    # stored, a 16-bit grey one failed (SystemError: tile cannot extend outside image)
    img._size = (img.tag_v2[IMAGE_WIDTH], img.tag_v2[IMAGE_LENGTH])
    tile = img.tile[0]
    native = LIBTIFF_NATIVE_RAWMODES.get(_tile_rawmode(tile)) if getattr(img, "use_load_libtiff", False) else None
    if native is not None:
        img.tile = [tile._replace(args=(native, *tile[3][1:]))]


def _tile_rawmode(tile) -> str:
    """The raw mode (Pillow's unpacking of the file's samples) of one decoder tile: its arguments, or their first."""
    return tile[3] if isinstance(tile[3], str) else tile[3][0]


def _sixteen_bit_rawmode(img) -> str | None:
    """The raw mode shared by every tile (TIFF strip) of ``img`` when it is one of :data:`SIXTEEN_BIT_RAWMODES`."""
    rawmodes = {_tile_rawmode(tile) for tile in img.tile}
    return rawmodes.pop() if len(rawmodes) == 1 and rawmodes <= set(SIXTEEN_BIT_RAWMODES) else None


def _read_16bit(data: bytes, rawmode: str, colour_key=None) -> tuple[np.ndarray, tuple[int, ...]]:
    """``(H, W, 4)`` float32 RGBA of a 16-bit RGB, RGBA (PNG or TIFF) or grey + alpha (PNG) image at full
    precision (``rawmode``: one of :data:`SIXTEEN_BIT_RAWMODES`), and the places of its channels
    (:func:`read_image`). ``colour_key``: an RGB PNG's tRNS chunk, three 16-bit samples; pixels of exactly that
    colour read alpha 0 (else 1), as the PNG specification defines it and Storm's stb_image reader computes it
    (``stbi__compute_transparency16``, on the 16-bit samples before it keeps 8 bits of them). Pillow takes no
    notice of it at this depth: a cut-out stored that way had no holes.

    Pillow unpacks these samples to 8 bits (the high byte). Its decoder is run again with the raw mode of the other
    byte order, which takes the other byte of every sample (grey + alpha, 4 bytes per pixel, as 8-bit RGBA: every
    byte), so the file's compression and PNG filtering are undone by Pillow both times. A 16-bit RGB TIFF was read
    as 8 bits and then decoded as sRGB under ``auto``: 0.5 came out as 0.216.
    """
    from PIL import Image as PilImage

    def decode(mode):
        img = PilImage.open(io.BytesIO(data))
        _tiff_decoded_as_stored(img)
        # (each tile a named _Tile: the TIFF reader reads its fields by name)
        img.tile = [tile._replace(args=mode if isinstance(tile[3], str) else (mode, *tile[3][1:])) for tile in img.tile]
        img.load()
        return np.asarray(img, dtype=np.float32)

    if rawmode == "LA;16B":
        b = decode("RGBA")  # bytes: grey high, grey low, alpha high, alpha low
        return _grey_rgba((b[..., 0] * 256 + b[..., 1]) / 65535.0, (b[..., 2] * 256 + b[..., 3]) / 65535.0)
    premultiplied = rawmode.startswith("RGBa")
    if premultiplied:  # the samples as stored, divided by alpha below at full precision
        rawmode = "RGBA" + rawmode[4:]
    high = decode(rawmode)
    low = decode(rawmode[:-1] + OTHER_BYTE[rawmode[-1]])
    samples = high * 256 + low  # whole numbers, exact in float32
    rgba = _colour_rgba(samples, premultiplied)  # (an RGBX TIFF opens as RGB: its fourth sample is no alpha)
    if isinstance(colour_key, tuple) and len(colour_key) == 3:
        rgba[..., 3] = np.any(samples != np.asarray(colour_key, np.float32), axis=-1)
    return rgba, COLOUR_CHANNELS


def _planar_layout(data: bytes) -> tuple[int, int, int, bool] | None:
    """``(bits, colour samples, ExtraSamples value, whether WhiteIsZero)`` of file ``data`` where it is a TIFF of more
    than one sample stored plane by plane (``PlanarConfiguration`` 2) of 8- or 16-bit unsigned integers, grey
    (``PhotometricInterpretation`` 0 or 1: 1 colour sample) or RGB (2: 3); None for any other file. The value is that of
    the first sample past the colour ones (0 where there is none: no alpha; 2, unassociated alpha, where the tag is
    missing; samples past it are not read). :func:`_read_planes` reads each plane alone: Pillow keeps the high byte of
    16-bit colour planes, decoded a compressed 8-bit grey + alpha file's alpha plane into no band, and knew no raw mode
    for uncompressed 8-bit planar RGBA of ExtraSamples 1, nor for 5 samples, and opens no 16-bit grey + alpha, nor an
    uncompressed 8-bit RGB + an unspecified sample, nor a grey one of more than two samples."""
    tags = tiff_first_values(data, (SAMPLES_PER_PIXEL, PLANAR_CONFIGURATION, BITS_PER_SAMPLE, SAMPLE_FORMAT,
                                    EXTRA_SAMPLES, PHOTOMETRIC))
    if tags is None or tags.get(PLANAR_CONFIGURATION, 1) != 2 or tags.get(SAMPLE_FORMAT, UNSIGNED) != UNSIGNED:
        return None
    samples, bits, photometric = tags.get(SAMPLES_PER_PIXEL, 1), tags.get(BITS_PER_SAMPLE, 1), tags.get(PHOTOMETRIC)
    colour = {WHITE_IS_ZERO: 1, BLACK_IS_ZERO: 1, RGB: 3}.get(photometric)
    if colour is None or bits not in (8, 16) or samples < max(colour, 2):
        return None
    # (no ExtraSamples: the sample past the colour is alpha, as Pillow opens RGB of four samples pixel by pixel RGBA)
    extra = tags.get(EXTRA_SAMPLES, UNASSOCIATED_ALPHA) if samples > colour else 0
    return bits, colour, extra if extra in (ASSOCIATED_ALPHA, UNASSOCIATED_ALPHA) else 0, photometric == WHITE_IS_ZERO


def _grey_plane_alone(data: bytes) -> bytes | None:
    """The first plane of file ``data`` as a TIFF of its own (:func:`wrt.tiff_planes.tiff_plane`) where it is a TIFF
    of grey (BlackIsZero or WhiteIsZero) stored plane by plane whose samples past the grey are all of no stated
    meaning (``ExtraSamples`` 0) that :func:`_planar_layout` leaves (signed, float or 32-bit samples): the grey, of the
    file's PhotometricInterpretation, which reads as one sample of such grey does. Uncompressed, Pillow knew no raw
    mode for it ('unknown raw mode for given image mode', the whole reason given; WhiteIsZero float grey still so
    where BlackIsZero alone was taken); compressed, it read the first plane. None for any other file."""
    directory = tiff_directory(data)
    if directory is None:
        return None
    try:
        extras = directory.values(EXTRA_SAMPLES)  # (missing: alpha, as _planar_layout takes it)
        photometric = directory.first(PHOTOMETRIC, -1)
        grey = (directory.first(PLANAR_CONFIGURATION, 1) == 2 and photometric in (WHITE_IS_ZERO, BLACK_IS_ZERO)
                and directory.first(SAMPLES_PER_PIXEL, 1) > 1 and extras and not any(extras))
    except struct.error:  # (values past the end: refused before, _refuse_damaged_tiff)
        return None
    plane = tiff_plane(data, 0) if grey else None
    if plane is None or photometric == BLACK_IS_ZERO:
        return plane
    # (a plane file is BlackIsZero: its WhiteIsZero grey would read uninverted, signed grey read where one sample of
    # it is refused)
    return with_value(tiff_directory(plane), PHOTOMETRIC, WHITE_IS_ZERO)


def _read_planes(data: bytes, name: str, bits: int, colour: int, extra: int, white_is_zero: bool
                 ) -> tuple[np.ndarray, tuple[int, ...]]:
    """``(H, W, 4)`` float32 RGBA of a TIFF stored plane by plane (file ``data``, named ``name`` in an error;
    ``bits``, ``colour``, ``extra`` and ``white_is_zero``: :func:`_planar_layout`) at full precision, and the places of
    its channels (:func:`read_image`): samples over ``2^bits - 1``, grey inverted where ``white_is_zero`` (TIFF
    6.0), colour divided by alpha where it is premultiplied (``extra`` 1; 0 where alpha is 0, at most 1), as Pillow
    makes 8-bit ``RGBa`` and ``La`` straight, but of the stored whole numbers; a sample of no stated meaning
    (``extra`` 0) is not read, as Pillow ignores it where the samples of a pixel lie together. Each plane is decoded
    alone, as a grey TIFF of its own (:func:`wrt.tiff_planes.tiff_plane`), which Pillow (and libtiff, compressed)
    reads at full depth."""
    alpha = extra != 0
    samples = _plane_samples(data, name, colour + alpha)
    full = np.float32((1 << bits) - 1)
    if white_is_zero:
        samples[..., 0] = full - samples[..., 0]
    if colour == 1:
        return _grey_alpha_rgba(samples, extra == ASSOCIATED_ALPHA, full)
    return _colour_rgba(samples, extra == ASSOCIATED_ALPHA, full), COLOUR_CHANNELS


def _plane_samples(data: bytes, name: str, planes: int) -> np.ndarray:
    """``(H, W, planes)`` float32 samples (whole numbers, exact in float32) of the first ``planes`` planes of a TIFF
    stored plane by plane (file ``data``, named ``name`` in an error), each decoded alone as a grey TIFF of its own
    (:func:`wrt.tiff_planes.tiff_plane`), which Pillow (and libtiff, compressed) reads at full depth."""
    from PIL import Image as PilImage

    # (left out of each plane's file; none is of PIXEL_TAGS: _refuse_damaged_tiff)
    _warn_skipped_tags(name, tags_past_end(tiff_directory(data)))
    samples = None
    for k in range(planes):
        plane = tiff_plane(data, k)
        if plane is None:
            raise TextureError(f"cannot read image {name}: its planes are not laid out as its header says "
                               "(PlanarConfiguration 2)")
        img = PilImage.open(io.BytesIO(plane))
        _refuse_oversized(img, name)
        _tiff_decoded_as_stored(img)
        img.load()
        if samples is None:
            samples = np.empty((img.height, img.width, planes), np.float32)
        samples[..., k] = np.asarray(img, dtype=np.float32)
    return samples


def _colour_rgba(samples: np.ndarray, premultiplied: bool = False, full: float = 65535.0) -> np.ndarray:
    """``(H, W, 4)`` float32 RGBA of ``(H, W, 3 or 4)`` colour ``samples`` (whole numbers, as float32; 16-bit, or
    of another depth where ``full``, their largest value, says so), alpha 1 for three. ``premultiplied``: colour
    stored times alpha (a TIFF's ``ExtraSamples`` 1) is divided by it, 0 where alpha is 0 and at most 1, as Pillow
    unpremultiplies 8-bit samples (its ``RGBa`` raw mode), so every texture wrt reads holds straight colour: ``c / a``
    of the stored whole numbers, one rounding in float32. 16-bit ones were divided at 8 bits, the high bytes of
    both."""
    rgba = np.ones(samples.shape[:2] + (4,), np.float32)
    rgba[..., : samples.shape[2]] = samples / np.float32(full)
    if premultiplied:
        rgba[..., :3] = _straight(samples[..., :3], samples[..., 3:])
    return rgba


def _grey_alpha_rgba(samples: np.ndarray, premultiplied: bool, full: float) -> tuple[np.ndarray, tuple[int, ...]]:
    """:func:`_grey_rgba` of ``(H, W, 1 or 2)`` grey (and alpha) ``samples`` (whole numbers, as float32, of largest
    value ``full``): grey divided by alpha where ``premultiplied``, as :func:`_colour_rgba` divides colour."""
    full = np.float32(full)
    alpha = samples[..., 1] / full if samples.shape[2] > 1 else None
    grey = _straight(samples[..., :1], samples[..., 1:])[..., 0] if premultiplied else samples[..., 0] / full
    return _grey_rgba(grey, alpha)


def _straight(colour: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Float32 ``colour`` (``(H, W, C)`` whole numbers) stored premultiplied by ``alpha`` (``(H, W, 1)``, of the same
    scale) made straight: ``colour / alpha``, one rounding in float32, at most 1, 0 where alpha is 0, as Pillow
    unpremultiplies 8-bit samples (its ``RGBa`` raw mode)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(alpha > 0, np.minimum(colour / alpha, np.float32(1.0)), np.float32(0)).astype(np.float32)


def _transparent_sample_alpha(img, grey: np.ndarray, scale: int = 1) -> np.ndarray | None:
    """Alpha of a 16-bit (or 2- or 4-bit) grey PNG with a transparent sample value (its tRNS chunk): 0 where
    ``grey`` (the samples as read, ``scale`` times those of the file) equals it, else 1, as the PNG specification
    defines it (libpng's tRNS-to-alpha, Pillow's LA conversion of 8-bit grey); None without one. It was read as
    opaque, so a cut-out stored that way had no holes."""
    transparent = img.info.get("transparency")
    if not isinstance(transparent, int):
        return None
    return (grey != transparent * scale).astype(np.float32)


def _grey_rgba(grey: np.ndarray, alpha: np.ndarray | None) -> tuple[np.ndarray, tuple[int, ...]]:
    """``(H, W, 4)`` float32 ``(grey, grey, grey, alpha or 1)`` and the places of the file's channels."""
    rgba = np.empty(grey.shape + (4,), np.float32)
    rgba[..., 0] = rgba[..., 1] = rgba[..., 2] = grey
    rgba[..., 3] = 1.0 if alpha is None else alpha
    return rgba, GREY_CHANNELS if alpha is None else GREY_ALPHA_CHANNELS


def _read_exr(data: bytes, name: str) -> tuple[np.ndarray, tuple[int, ...]]:
    try:
        import OpenEXR
    except ImportError:
        raise TextureError(f"reading {name} needs the OpenEXR package: pip install OpenEXR") from None
    import tempfile

    with tempfile.NamedTemporaryFile(suffix=".exr") as tmp:  # OpenEXR.File reads from a path
        tmp.write(data)
        tmp.flush()
        try:
            with OpenEXR.File(tmp.name, separate_channels=True) as f:
                channels = {k: np.asarray(v.pixels) for k, v in f.channels().items()}  # uint32, float16 or 32
                chromaticities = f.header().get("chromaticities")
        except Exception as e:  # noqa: BLE001
            raise TextureError(f"cannot read EXR {name}: {e}") from None
    return exr_rgba(channels, name, chromaticities)


def exr_rgba(channels: dict[str, np.ndarray], name: str, chromaticities=None) -> tuple[np.ndarray, tuple[int, ...]]:
    """``(H, W, 4)`` float32 RGBA of an EXR's channels (full name -> ``(H, W)`` samples), and the RGBA places of
    those read in their order (:func:`read_image`). Channels are mapped by the last part of each name (after its
    layer's ``.``), single letters or words in any case (:data:`EXR_CHANNEL_ROLES`), as Hydra's EXR reader matches
    them: the unnamed layer's channels, else those of the one layer that has any.

    The channels so read, in R G B A order (``Y`` only without colour), are the texture's channels as the
    UsdPreviewSurface specification counts them for UsdUVTexture's outputs (as wrt reads a grey or grey + alpha PNG):

    - one (``R``, ``G``, ``B``, ``Y`` or ``A``): grey ``(c, c, c, 1)``;
    - two (``R G``, ``R A``, ``Y A``, ...): the first grey, the second alpha: ``R G`` is ``(R, R, R, G)``;
    - three or four: ``R``, ``G``, ``B`` each in its place, a missing one 0, alpha ``A`` or 1 (OpenEXR's RGBA
      interface).

    Hydra's reader differs for two channels (Storm samples ``R G`` as ``(R, G, 0, 1)``) and ``A`` alone (written
    outside the pixel's texel). ``Y`` with chroma ``RY``/``BY`` beside it (a luminance-chroma file, full-size or one
    sample per 2 x 2 pixels) is RGB as OpenEXR's ``RgbaInputFile`` reconstructs it (:func:`wrt.exr_yca.yca_rgba`),
    the luminance weights from ``chromaticities`` (the file's attribute, 8 numbers; None: Rec.709); Storm reads such
    files grey.

    Other channels (``Z``, other layers' beside the unnamed one) are ignored, of any sample type.

    Raises:
        TextureError: no channel maps to one of these, several layers do and none is unnamed, the mapped
            channels differ in size (subsampled ones other than 2 x 2 chroma), or one of them holds 32-bit
            unsigned integers (``UINT``: ids or counts, not light; an id of 4e9 was read as that much light).
            Hydra's reader gives such a file black, or fails: its EXR reader takes the file's sample type from its
            first channel and converts ``UINT`` to neither half nor float, so Storm draws the fallback of an
            all-``UINT`` file.
    """
    layers: dict[str, dict[str, np.ndarray]] = {}
    chroma_layers: dict[str, dict[str, np.ndarray]] = {}  # RY, BY: read only beside Y and no R, G, B
    full_names: dict[tuple[str, str], str] = {}  # (layer, role) -> the channel's name in the file
    for full_name, samples in channels.items():
        layer, _, last = full_name.rpartition(".")
        role = EXR_CHANNEL_ROLES.get(last.lower())
        chroma_role = EXR_CHROMA_ROLES.get(last.lower())
        if role is not None:
            layers.setdefault(layer, {})[role] = samples
        if chroma_role is not None:
            chroma_layers.setdefault(layer, {})[chroma_role] = samples
        if role or chroma_role:
            full_names[layer, role or chroma_role] = full_name
    found = ", ".join(sorted(channels)) or "none"
    if not layers:
        raise TextureError(f"EXR {name} has no R, G, B, Y or A channel (found {found})")
    if "" not in layers and len(layers) > 1:
        raise TextureError(f"EXR {name} has colour channels in several layers ({', '.join(sorted(layers))}) and "
                           "none without a layer name; which one is the image is not known")
    image_layer = "" if "" in layers else next(iter(layers))
    mapped = layers[image_layer]
    if len({v.shape for v in mapped.values()}) > 1:
        sizes = ", ".join(f"{k} {v.shape[1]}x{v.shape[0]}" for k, v in sorted(mapped.items()))
        raise TextureError(f"EXR {name}: its channels differ in size ({sizes}); subsampled channels are not read")
    colour = [c for c in "RGB" if c in mapped]
    chroma = chroma_layers.get(image_layer, {}) if "Y" in mapped and not colour else {}
    integer = sorted(full_names[image_layer, k] for k, v in (mapped | chroma).items() if v.dtype.kind in "iu")
    if integer:
        raise TextureError(f"EXR {name}: channel {', '.join(integer)} holds unsigned integers (UINT: ids or "
                           "counts), which Storm does not read as colour")
    if chroma:
        mapped = {k: np.asarray(v, np.float32) for k, v in mapped.items()}
        try:
            return yca_rgba(mapped["Y"], chroma.get("RY"), chroma.get("BY"), mapped.get("A"),
                            chromaticities), COLOUR_CHANNELS
        except ValueError as e:
            raise TextureError(f"EXR {name}: {e}") from None
    # The channels read, in R G B A order (Y only without colour), are the texture's channels as the specification
    # counts them; Z and other layers' channels beside them do not count.
    read = (colour or [c for c in "Y" if c in mapped]) + [c for c in "A" if c in mapped]
    if len(read) <= 2:  # grey, alpha the second channel or 1
        return _grey_rgba(mapped[read[0]], mapped[read[1]] if len(read) == 2 else None)
    # Each channel cast into its place as it is copied there (float16 to float32 is exact, float64 rounds as astype
    # does): a float32 copy of each first cost a fifth of loading a scene of 2k textures.
    rgba = np.zeros(next(iter(mapped.values())).shape + (4,), np.float32)
    for k, c in enumerate("RGB"):
        if c in mapped:
            rgba[..., k] = mapped[c]
    rgba[..., 3] = mapped.get("A", 1.0)
    return rgba, tuple("RGBA".index(c) for c in read)


def scene_images(textures: list) -> list[np.ndarray]:
    """``Scene.textures`` as ``(H, W, 4)`` float32 images for :func:`pack_images`: an ``(H, W, 3)`` image gets alpha
    1, other float dtypes are cast, images already so are kept (the same objects).

    Raises:
        SceneError: naming ``scene.textures[k]``, for any other shape, an empty image or samples that are not floats.
            Unchecked, images built in Python went wrong in every way: an ``(H, W, 3)`` one was packed as
            ``3 H W / 4`` texels (another image, its last quarter uninitialised memory, without a word, or a bare
            reshape error), an 8-bit one stopped at a numpy casting error, and an empty one killed the process
            with a division by zero in the lookup's ``repeat`` wrap.
    """
    from .errors import SceneError

    images = []
    for k, texture in enumerate(textures):
        image = np.asarray(texture)
        if image.ndim != 3 or image.shape[2] not in (3, 4) or image.size == 0:
            raise SceneError(f"scene.textures[{k}] must be an (H, W, 3) or (H, W, 4) image of at least one texel, got "
                             f"shape {image.shape}")
        if image.dtype.kind != "f":
            raise SceneError(f"scene.textures[{k}] must hold linear float values, got {image.dtype} (an 8-bit image: "
                             f"wrt.textures.load_image reads files into linear float32 RGBA)")
        if image.shape[2] == 3:
            image = np.concatenate([image, np.ones(image.shape[:2] + (1,), image.dtype)], axis=2)
        images.append(image.astype(np.float32, copy=False))
    return images


def largest_finite(image: np.ndarray) -> np.ndarray:
    """``(C,)`` float64 largest magnitude of each channel's finite values of ``(..., C)`` ``image`` (0 for none): its
    largest and smallest where all are finite (two passes, no temporaries), else in slices of :data:`PACK_TEXELS`
    texels (no image-sized temporaries)."""
    flat = np.asarray(image).reshape(-1, np.shape(image)[-1])
    if len(flat) == 0:
        return np.zeros(flat.shape[1])
    high, low = flat.max(axis=0).astype(np.float64), flat.min(axis=0).astype(np.float64)
    if np.isfinite(high).all() and np.isfinite(low).all():
        return np.maximum(np.maximum(high, -low), 0.0)
    largest = np.zeros(flat.shape[1])
    for start in range(0, len(flat), PACK_TEXELS):
        part = np.abs(flat[start : start + PACK_TEXELS])
        largest = np.maximum(largest, np.where(np.isfinite(part), part, 0.0).max(axis=0))
    return largest


def image_scale(image: np.ndarray) -> np.ndarray:
    """``(4,)`` the powers of two the device stores the channels of ``(H, W, 4)`` ``image`` divided by (and multiplies
    its lookups by): per channel, 1 where its largest finite magnitude is 0 or lies in ``[SMALLEST_UNSCALED,
    HALF_MAX]``; else the one that brings it into ``[2^14, 2^15)``, a normal float32. An HDR's sun of 1e6 was clamped
    to 65504 (with a warning), and an image of texels below float16's smallest, 6e-8, read 0 (without one). Each
    channel has its own: an RGB file's alpha of 1 held a dim colour's power of two at 1 (it read 0), and a bright
    one's stored alpha below float16's smallest."""
    scales = np.ones(np.shape(image)[-1])
    for c, largest in enumerate(largest_finite(image)):
        if not (largest == 0.0 or SMALLEST_UNSCALED <= largest <= HALF_MAX):
            exponent = math.frexp(largest)[1] - 1  # largest in [2^exponent, 2^(exponent + 1))
            scales[c] = math.ldexp(1.0, min(max(exponent - 14, -126), 127))
    return scales


def stored_texels(texels: np.ndarray, scale=1.0) -> np.ndarray:
    """``texels`` (``(N, 4)``, a new float array) as the device stores them for an image of :func:`image_scale`
    ``scale`` (per channel): NaN as 0, the rest divided by ``scale`` and clamped to float16's finite range,
    +-:data:`HALF_MAX` (an infinite texel is the largest stored); times ``scale`` they are what lookups read."""
    part = np.nan_to_num(texels, nan=0.0, posinf=np.inf, neginf=-np.inf)
    if np.any(np.asarray(scale) != 1.0):
        part /= np.asarray(scale, np.float32)
    return np.clip(part, -HALF_MAX, HALF_MAX, out=part)


def pack_images(images: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Concatenates ``(H, W, 4)`` images into one texel array.

    Returns:
        ``texels`` ``(N, 4)`` float16 (at least one texel), ``offsets`` ``(K,)`` int32 first texel of each image,
        ``sizes`` ``(K, 2)`` int32 ``(width, height)`` and ``scales`` ``(K, 4)`` float32: each image's channels are
        stored divided by its :func:`image_scale`.
    """
    offsets, sizes, total = [], [], 0
    for img in images:
        h, w = img.shape[:2]
        offsets.append(total)
        sizes.append((w, h))
        total += w * h
    if total >= MAX_TEXELS:
        raise ValueError(f"textures hold {total} texels; at most 2^31 are supported")
    # Filled in slices of at most PACK_TEXELS texels: whole-image float32 temporaries took 2 GB more than the
    # result for one 8k x 8k texture.
    texels = np.empty((max(total, 1), 4), np.float16)
    if not total:
        texels[:] = 0.0
    scales = [image_scale(img) for img in images]
    for img, offset, scale in zip(images, offsets, scales):
        flat = img.reshape(-1, 4)
        for start in range(0, len(flat), PACK_TEXELS):
            part = stored_texels(flat[start : start + PACK_TEXELS], scale)
            texels[offset + start : offset + start + len(part)] = part
    offsets = np.asarray(offsets or [0], np.int32)
    sizes = np.asarray(sizes or [(1, 1)], np.int32).reshape(-1, 2)
    return texels, offsets, sizes, np.asarray(scales or [np.ones(4)], np.float32).reshape(-1, 4)


@wp.func
def wrap_coord(x: int, n: int, mode: int):
    """Texel index ``x`` wrapped into ``[0, n)``; ``black`` and ``fallback`` clamp, as their lookups have already
    given black or the fallback outside the image."""
    if mode == WRAP_CLAMP or mode == WRAP_BLACK or mode == WRAP_FALLBACK:
        return wp.clamp(x, 0, n - 1)
    if mode == WRAP_MIRROR:
        period = 2 * n
        m = x % period
        if m < 0:
            m += period
        if m >= n:
            m = period - 1 - m
        return m
    m = x % n
    if m < 0:
        m += n
    return m


@wp.func
def udim_tile(st: wp.vec2):
    """Index ``u + 10 v`` (tile number minus ``UDIM_FIRST``) of the UDIM tile holding ``st``; -1 outside the 10 x 10
    tiles (or for a coordinate that is not finite)."""
    if not (wp.isfinite(st[0]) and wp.isfinite(st[1])):
        return -1
    if st[0] < 0.0 or st[1] < 0.0 or st[0] >= float(UDIM_COLUMNS) or st[1] >= float(UDIM_ROWS):
        return -1
    return int(wp.floor(st[0])) + UDIM_COLUMNS * int(wp.floor(st[1]))


@wp.func
def fetch_texel(texels: wp.array[wp.vec4h], offset: int, size: wp.vec2i, x: int, y: int, wrap: wp.vec2i):
    """One texel (``y`` = row from the top) after wrapping."""
    xi = wrap_coord(x, size[0], wrap[0])
    yi = wrap_coord(y, size[1], wrap[1])
    return wp.vec4(texels[offset + yi * size[0] + xi])


@wp.func
def outside_unit(c: float, mode: int):
    """True where wrap mode ``mode`` makes texture coordinate ``c`` black: ``black`` outside [0, 1]."""
    return mode == WRAP_BLACK and (c < 0.0 or c > 1.0)


@wp.func
def outside_to_fallback(st: wp.vec2, wrap: wp.vec2i):
    """True where wrap modes ``wrap`` make ``st`` read the texture's fallback: ``fallback`` outside [0, 1]."""
    s_out = wrap[0] == WRAP_FALLBACK and (st[0] < 0.0 or st[0] > 1.0)
    t_out = wrap[1] == WRAP_FALLBACK and (st[1] < 0.0 or st[1] > 1.0)
    return s_out or t_out


@wp.func
def sample_image(texels: wp.array[wp.vec4h], offset: int, size: wp.vec2i, st: wp.vec2, wrap: wp.vec2i):
    """Bilinear lookup at texture coordinate ``st`` (USD convention: ``t = 0`` is the bottom row).

    ``black`` gives transparent black outside the unit square, as the specification says, and the image inside it,
    filtered there as ``clamp`` filters it: mixing a black border into the outer half texel darkened every edge of
    the image, a quarter of a 2 x 2 one, now that ``black`` is what an unauthored wrap mode reads as."""
    if outside_unit(st[0], wrap[0]) or outside_unit(st[1], wrap[1]):
        return wp.vec4(0.0)
    x = st[0] * float(size[0]) - 0.5
    y = (1.0 - st[1]) * float(size[1]) - 0.5
    if not (wp.isfinite(x) and wp.isfinite(y)):
        return wp.vec4(0.0)
    # Keep the integer part in range before converting (huge coordinates would overflow int).
    x = wp.clamp(x, -1.0e8, 1.0e8)
    y = wp.clamp(y, -1.0e8, 1.0e8)
    x0f = wp.floor(x)
    y0f = wp.floor(y)
    fx = x - x0f
    fy = y - y0f
    x0 = int(x0f)
    y0 = int(y0f)
    # Wrap each column and row once (four wraps, not one per coordinate of each of the four texels: a texture lookup
    # is compiled into every kernel once per input that can be textured).
    xa = wrap_coord(x0, size[0], wrap[0])
    xb = wrap_coord(x0 + 1, size[0], wrap[0])
    ya = offset + wrap_coord(y0, size[1], wrap[1]) * size[0]
    yb = offset + wrap_coord(y0 + 1, size[1], wrap[1]) * size[0]
    c00 = wp.vec4(texels[ya + xa])
    c10 = wp.vec4(texels[ya + xb])
    c01 = wp.vec4(texels[yb + xa])
    c11 = wp.vec4(texels[yb + xb])
    return (c00 * (1.0 - fx) + c10 * fx) * (1.0 - fy) + (c01 * (1.0 - fx) + c11 * fx) * fy


@wp.func
def nearest_texel(texels: wp.array[wp.vec4h], offset: int, size: wp.vec2i, st: wp.vec2, wrap: wp.vec2i):
    """The texel whose square holds texture coordinate ``st`` (column ``floor(s w)``, row ``floor((1 - t) h)`` from
    the top, wrapped), as GL's nearest filter and MaterialX's ``filtertype`` ``closest`` read it; ``black`` gives
    transparent black outside the unit square, as :func:`sample_image` does."""
    if outside_unit(st[0], wrap[0]) or outside_unit(st[1], wrap[1]):
        return wp.vec4(0.0)
    x = st[0] * float(size[0])
    y = (1.0 - st[1]) * float(size[1])
    if not (wp.isfinite(x) and wp.isfinite(y)):
        return wp.vec4(0.0)
    x = wp.clamp(x, -1.0e8, 1.0e8)  # huge coordinates would overflow int
    y = wp.clamp(y, -1.0e8, 1.0e8)
    return fetch_texel(texels, offset, size, int(wp.floor(x)), int(wp.floor(y)), wrap)
