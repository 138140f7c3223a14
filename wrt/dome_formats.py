"""DomeLight texture layouts (UsdLux ``inputs:texture:format``) resampled to the latitude-longitude image that
:mod:`wrt.light_sampling` looks up and importance-samples.

Directions are in the dome's frame (before its transform), in which the lat-long image follows the OpenEXR
convention (+Y pole, longitude 0 = +Z at the image centre, +X left of it). UsdLux names the layouts but not their
orientation; wrt takes the light-probe conventions of Debevec's probe gallery and HDRShop, which put the same
forward direction, +Z, at the centre of every layout, so that a probe converted to lat-long by those tools renders
the same either way:

- ``angular``: the image is a disc (inscribed in the image rectangle) seen from +Z, image right +X and image up
  +Y; a direction at angle ``theta`` from +Z lies at radius ``theta / pi`` (the rim is -Z). For a unit direction
  ``(x, y, z)``: ``(a, b) = (x, y) acos(z) / (pi sqrt(x^2 + y^2))`` in ``[-1, 1]^2``, ``a`` right, ``b`` up.
- ``mirroredBall``: a mirror sphere photographed orthographically from +Z (image right +X, up +Y): the direction
  reflected at radius ``r`` is at ``theta = 2 asin(r)`` from +Z, so ``(a, b) = (x, y) sqrt((1 - z) / 2) /
  sqrt(x^2 + y^2)`` (OpenGL's sphere map).
- ``cubeMapVerticalCross``: six square faces in a 3 x 4 grid, each seen from inside::

        .   +Y   .
        +X  +Z  -X
        .   -Y   .
        .   -Z   .

  The middle row is the horizon seen facing +Z (+X to the left, as in the lat-long image); +Y's lower edge and
  -Y's upper edge meet +Z, and -Z hangs below -Y, upside down (its upper edge meets -Y's lower edge).

``automatic``, the schema's fallback, "tries to determine the layout from the file itself" (UsdLux); the images wrt
reads name no layout, so it is guessed from the image's shape (:func:`automatic_format`): 2:1 is ``latlong``, 3:4
``cubeMapVerticalCross`` and 1:1 ``angular``. A square image could as well be a ``mirroredBall``; ``angular`` wins
because it is the form probes are passed on in: Debevec's light probe gallery distributes them as angular maps (a
mirror-ball photograph is the raw capture they are made from), and Maya's Hydra adapter hands Arnold's ``angular``
skydome format on as ``automatic``. Another shape is read as ``latlong``, as before, with a warning. No renderer
documents a rule: the ANARI Hydra delegate reads ``automatic`` as ``latlong`` whatever the image, and Arnold's USD
reader leaves it to its skydome's own setting. An authored format other than ``automatic`` is used as it is.

The lat-long image gets ``2 N x N`` texels for an ``N``-pixel probe (its larger side) or ``4 F x 2 F`` for faces of
``F`` pixels (the source's resolution at the probe's centre and the faces' centres), each the mean of
:data:`SUPERSAMPLE` ``^2`` nearest-texel lookups of the source: exact in direction, and the total light within a
fraction of a source texel along the edges of bright regions.
"""

from __future__ import annotations

import numpy as np

FORMATS = ("automatic", "latlong", "angular", "mirroredBall", "cubeMapVerticalCross")  # UsdLux's allowed tokens
SUPERSAMPLE = 2  # lookups per lat-long texel along each axis
MAX_LATLONG_HEIGHT = 4096  # rows of the lat-long image at most (8192 x 4096 float32 RGBA is 512 MiB)
ROWS_PER_CHUNK = 64  # lat-long rows resampled at a time (bounds the temporaries)
# Width / height of each layout an ``automatic`` image is matched against, and how far off it may be (a 2049 x 1024
# lat-long is still one).
ASPECTS = {"latlong": 2.0, "angular": 1.0, "cubeMapVerticalCross": 0.75}
ASPECT_TOLERANCE = 0.02


def automatic_format(width: int, height: int) -> str | None:
    """The layout a ``width x height`` image of format ``automatic`` is read as (see the module docstring), or None
    when its shape is none of :data:`ASPECTS`'."""
    aspect = width / max(height, 1)
    for fmt, expected in ASPECTS.items():
        if abs(aspect / expected - 1.0) <= ASPECT_TOLERANCE:
            return fmt
    return None


def fits_layout(fmt: str, width: int, height: int) -> bool:
    """Whether a ``width x height`` image has the shape of layout ``fmt`` (:data:`ASPECTS`; a ``mirroredBall`` is
    square as an ``angular`` map is; ``automatic`` fits any shape it resolves to)."""
    if fmt == "automatic":
        return automatic_format(width, height) is not None
    expected = ASPECTS["angular" if fmt == "mirroredBall" else fmt]
    return abs(width / max(height, 1) / expected - 1.0) <= ASPECT_TOLERANCE


def latlong_directions(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit directions ``(..., 3)`` of lat-long coordinates ``u, v`` in ``[0, 1]`` (``v = 0`` at the top row)."""
    lon = np.pi * (1.0 - 2.0 * u)
    lat = np.pi * (0.5 - v)
    return np.stack(np.broadcast_arrays(np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)), -1)


def _probe_coords(d: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)`` in ``[-1, 1]`` of directions ``d`` lying at probe ``radius`` along their ``(x, y)`` heading (+X at
    the rim where that heading is undefined, i.e. for -Z)."""
    rho = np.hypot(d[..., 0], d[..., 1])
    safe = np.where(rho > 0.0, rho, 1.0)
    a = np.where(rho > 0.0, d[..., 0] / safe, 1.0) * radius
    b = np.where(rho > 0.0, d[..., 1] / safe, 0.0) * radius
    return a, b


def _cross_coords(d: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates ``(column, row)`` (continuous, from the top-left corner) of directions ``d`` in a vertical
    cross of ``width x height`` pixels."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    # Face of the major axis: (cell column, cell row, a, b) with a right and b up within the cell as laid out.
    faces = [
        (ax >= ay) & (ax >= az) & (x > 0), (0, 1, z, y, ax),  # +X: left of +Z
        (ax >= ay) & (ax >= az) & (x <= 0), (2, 1, -z, y, ax),  # -X: right of +Z
        (ay > ax) & (ay >= az) & (y > 0), (1, 0, -x, -z, ay),  # +Y: above +Z
        (ay > ax) & (ay >= az) & (y <= 0), (1, 2, -x, z, ay),  # -Y: below +Z
        (az > ax) & (az > ay) & (z > 0), (1, 1, -x, y, az),  # +Z: the centre
        (az > ax) & (az > ay) & (z <= 0), (1, 3, -x, -y, az),  # -Z: below -Y, upside down
    ]
    col = np.zeros(x.shape)
    row = np.zeros(x.shape)
    for mask, (cell_col, cell_row, a, b, major) in zip(faces[::2], faces[1::2]):
        major = np.where(major > 0.0, major, 1.0)
        col = np.where(mask, (cell_col + 0.5 * (1.0 + a / major)) * (width / 3.0), col)
        row = np.where(mask, (cell_row + 0.5 * (1.0 - b / major)) * (height / 4.0), row)
    return col, row


def source_pixels(d: np.ndarray, fmt: str, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Integer pixel ``(column, row)`` of a ``width x height`` image in layout ``fmt`` that directions ``d``
    ``(..., 3)`` (unit, dome frame) look up."""
    if fmt == "cubeMapVerticalCross":
        col, row = _cross_coords(d, width, height)
    else:
        z = np.clip(d[..., 2], -1.0, 1.0)
        if fmt == "angular":
            radius = np.arccos(z) / np.pi
        elif fmt == "mirroredBall":
            radius = np.sqrt(np.maximum(0.5 * (1.0 - z), 0.0))
        else:
            raise ValueError(f"unknown dome texture format {fmt!r}; expected one of {', '.join(FORMATS)}")
        a, b = _probe_coords(d, radius)
        col, row = 0.5 * (1.0 + a) * width, 0.5 * (1.0 - b) * height
    return (np.clip(col.astype(np.int64), 0, width - 1), np.clip(row.astype(np.int64), 0, height - 1))


def latlong_height(fmt: str, width: int, height: int) -> int:
    """Rows of the lat-long image a ``width x height`` source in layout ``fmt`` is resampled to."""
    rows = 2 * max(width // 3, height // 4) if fmt == "cubeMapVerticalCross" else max(width, height)
    return int(min(max(rows, 2), MAX_LATLONG_HEIGHT))


def to_latlong(image: np.ndarray, fmt: str) -> np.ndarray:
    """The ``(N, 2N, C)`` lat-long image of ``image`` (``(H, W, C)``, row 0 at the top) laid out as ``fmt``
    (``latlong`` returns it unchanged; ``automatic`` is resolved first: :func:`automatic_format`)."""
    if fmt == "automatic":
        fmt = automatic_format(image.shape[1], image.shape[0]) or "latlong"
    if fmt == "latlong":
        return image
    height, width = image.shape[:2]
    rows = latlong_height(fmt, width, height)
    cols = 2 * rows
    image = np.asarray(image, np.float32)
    out = np.zeros((rows, cols, image.shape[2]), np.float32)
    offsets = (np.arange(SUPERSAMPLE) + 0.5) / SUPERSAMPLE
    for first in range(0, rows, ROWS_PER_CHUNK):
        last = min(first + ROWS_PER_CHUNK, rows)
        for dv in offsets:
            v = (np.arange(first, last)[:, None] + dv) / rows
            for du in offsets:
                col, row = source_pixels(latlong_directions((np.arange(cols)[None, :] + du) / cols, v), fmt, width,
                                         height)
                out[first:last] += image[row, col]
    return out / np.float32(SUPERSAMPLE * SUPERSAMPLE)
