"""IES light profiles (ANSI/IES LM-63 1995, 2002 and 2019, type C photometry): the file parser and the profile as
the table the shading kernels sample (``UsdLux.ShapingAPI`` ``shaping:ies:file``). A lamp's tilt is ignored, with a
warning naming the file: ``TILT=INCLUDE`` data (the lamp-to-luminaire geometry, the tilt angles and their multiplying
factors) is read past, and the file a ``TILT=<file>`` names is not read, as Cycles and hdEmbree use the candela table
alone (the factors only dim a lamp tilted from the position it was measured in).

A profile gives the luminous intensity (candela) by vertical angle (0 along the light's primary axis, its -Z; 180
straight back) and horizontal angle (0 along the light's +X, 90 along its +Y). Between the angles of the file it is
bilinear; horizontal ranges follow LM-63's symmetries: one angle (the same in every plane), 0-90 (one quadrant,
mirrored into the other three), 0-180 (mirrored about the 0-180 plane), 90-270 (mirrored about that plane) and 0-360
(files that stop short of 360, which is 0 again, close the circle from their last angle back to 0).
Directions outside the vertical range of the file (above the horizon of a 0-90 profile) get nothing. The values are
the file's candela times its candela multiplier and ballast factor (and the ballast-lamp photometric factor of the
files before LM-63-2002, which later versions replaced by fields that are no factor).
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings

import numpy as np
import warp as wp

from .sampling import floor_index

ANGLE_TOLERANCE = 1e-3  # degrees: an angle this close to 0, 90, 180, 270 or 360 counts as it
# An IES profile spread over more than this many degrees of vertical angle covers the sphere, otherwise a hemisphere:
# its normalization divides by its mean intensity over that (OpenUSD's hdEmbree, which also follows Karma and RIS).
SPHERE_SPAN = 90.0 + math.degrees(0.1)
PHOTOMETRIC_TYPE_C = 1
PI_F = wp.constant(math.pi)


@wp.func
def ies_factor(data: wp.array[float], info: wp.vec3i, frame: wp.mat33, w: wp.vec3):
    """The factor of an IES profile on the radiance its light emits along unit world ``w``: ``info`` is its
    ``(offset, vertical count, horizontal count)`` in ``data``, which holds at the offset its angle scale, its
    vertical and horizontal angles (radians, ascending; the horizontal over the whole circle) and its candela
    values (times its normalization), horizontal row by row; ``frame``'s rows are the light's unit X and Y axes and
    its primary axis (-Z) in the world (:mod:`wrt.ies`)."""
    local = frame * w
    theta = wp.acos(wp.clamp(local[2], -1.0, 1.0))
    scale = data[info[0]]
    if scale > 0.0:  # UsdLux shaping:ies:angleScale: about theta = 0 when positive, about pi when negative
        theta = theta / scale
    elif scale < 0.0:
        theta = (theta - PI_F) / (-scale) + PI_F
    n_v = info[1]
    n_h = info[2]
    v_at = info[0] + 1
    h_at = v_at + n_v
    c_at = h_at + n_h
    if theta < data[v_at] or theta > data[v_at + n_v - 1]:
        return 0.0  # outside the profile's vertical range: no light
    i = floor_index(data, v_at, n_v, theta)
    v0 = data[v_at + i]
    tv = wp.clamp((theta - v0) / wp.max(data[v_at + i + 1] - v0, 1e-30), 0.0, 1.0)
    row_a = int(0)
    row_b = int(0)
    th = float(0.0)
    if n_h > 1:
        phi = wp.atan2(local[1], local[0])
        if phi < 0.0:
            phi = phi + 2.0 * PI_F
        first = data[h_at]
        last = data[h_at + n_h - 1]
        if phi < first or phi >= last:  # between the last angle and the first, round the circle
            if phi < first:
                phi = phi + 2.0 * PI_F
            row_a = n_h - 1
            th = wp.clamp((phi - last) / wp.max(first + 2.0 * PI_F - last, 1e-30), 0.0, 1.0)
        else:
            row_a = floor_index(data, h_at, n_h, phi)
            row_b = row_a + 1
            h0 = data[h_at + row_a]
            th = wp.clamp((phi - h0) / wp.max(data[h_at + row_b] - h0, 1e-30), 0.0, 1.0)
    a = (1.0 - tv) * data[c_at + row_a * n_v + i] + tv * data[c_at + row_a * n_v + i + 1]
    b = (1.0 - tv) * data[c_at + row_b * n_v + i] + tv * data[c_at + row_b * n_v + i + 1]
    return (1.0 - th) * a + th * b


class IesError(ValueError):
    """An IES file that cannot be read as a profile; the message names the file and, where it can, the line."""


@dataclasses.dataclass
class IesProfile:
    """An IES profile as its file gives it.

    Attributes:
        vertical: ``(V,)`` float64 vertical angles in degrees, ascending, within [0, 180].
        horizontal: ``(H,)`` float64 horizontal angles in degrees, ascending (one of LM-63's ranges; see the module).
        candela: ``(H, V)`` float64 intensities (candela, times the file's factors), ``candela[h, v]`` at
            ``horizontal[h]``, ``vertical[v]``.
        path: the file it came from ("" for one built in Python).
    """

    vertical: np.ndarray
    horizontal: np.ndarray
    candela: np.ndarray
    path: str = ""

    def __post_init__(self):
        self.vertical = np.asarray(self.vertical, np.float64).reshape(-1)
        self.horizontal = np.asarray(self.horizontal, np.float64).reshape(-1)
        where = self.path or "IES profile"
        self.candela = np.asarray(self.candela, np.float64)
        if self.candela.size != len(self.horizontal) * len(self.vertical):
            raise IesError(f"{where}: candela must hold {len(self.horizontal)} x {len(self.vertical)} values "
                           f"(horizontal x vertical angles), got shape {self.candela.shape}")
        self.candela = self.candela.reshape(len(self.horizontal), len(self.vertical))
        _check_angles(where, "vertical", self.vertical, 0.0, 180.0)
        if len(self.vertical) < 2:
            raise IesError(f"{where}: a profile needs at least 2 vertical angles, got 1")
        _check_angles(where, "horizontal", self.horizontal, 0.0, 360.0)
        if not np.all(np.isfinite(self.candela)) or np.any(self.candela < 0.0):
            raise IesError(f"{where}: candela values must be finite and not negative")
        if _horizontal_range(self.horizontal) is None:
            raise IesError(f"{where}: horizontal angles {self.horizontal[0]:g}-{self.horizontal[-1]:g} are none of "
                           "LM-63's ranges (a single angle, 0-90, 0-180, 90-270, 0-360)")

    def full_circle(self) -> tuple[np.ndarray, np.ndarray]:
        """``(horizontal, candela)`` spread over the whole circle by the file's symmetry: ``horizontal`` ascending
        from 0 to 360 in degrees (one angle for a profile the same in every plane), ``candela`` ``(H', V)``."""
        h, c = self.horizontal, self.candela
        kind = _horizontal_range(h)
        if kind == "single":
            return np.zeros(1), c[:1].copy()
        if kind == "quadrant":  # 0-90: mirror about the 90 plane, then about the 0-180 plane
            h, c = np.concatenate([h, 180.0 - h[-2::-1]]), np.concatenate([c, c[-2::-1]])
            kind = "half"
        if kind == "half":  # 0-180: mirror about the 0-180 plane
            return np.concatenate([h, 360.0 - h[-2::-1]]), np.concatenate([c, c[-2::-1]])
        if kind == "back":  # 90-270: mirror about the 90-270 plane (phi -> 180 - phi, the 0-90 and 270-360 parts)
            tol = ANGLE_TOLERANCE
            before = (h > 90.0 + tol) & (h <= 180.0 + tol)
            after = (h >= 180.0 - tol) & (h < 270.0 - tol)
            h_full = np.concatenate([180.0 - h[before][::-1], h, 540.0 - h[after][::-1]])
            c_full = np.concatenate([c[before][::-1], c, c[after][::-1]])
            return _merged(h_full, c_full)
        return h.copy(), c.copy()

    def total_intensity(self) -> float:
        """The bilinear profile's intensity integrated over the sphere (candela times steradians: its luminous flux
        in lumens); worked out once per profile while its arrays stay the same (the lamps of a PointInstancer share
        one)."""
        key = self._arrays_key()
        memo = self.__dict__.get("_total")
        if memo is None or memo[0] != key:
            self.__dict__["_total"] = (key, self._integrated())
        return self.__dict__["_total"][1]

    def _arrays_key(self) -> bytes:
        return self.vertical.tobytes() + b"|" + self.horizontal.tobytes() + b"|" + self.candela.tobytes()

    def ring_means(self, theta: np.ndarray) -> np.ndarray:
        """The profile's intensity averaged over the horizontal circle at vertical angles ``theta`` (radians), 0
        outside its vertical range: linear between its vertical angles, as the bilinear profile's ring mean is."""
        vertical = np.radians(self.vertical)
        theta = np.asarray(theta, np.float64)
        inside = (theta >= vertical[0]) & (theta <= vertical[-1])
        return np.where(inside, np.interp(theta, vertical, self._rings()), 0.0)

    def _rings(self) -> np.ndarray:
        h, c = self.full_circle()
        return np.array([_ring_mean(h, c[:, v]) for v in range(len(self.vertical))])

    def _integrated(self) -> float:
        theta = np.radians(self.vertical)
        rings = self._rings()
        # Within each vertical interval the bilinear profile's ring mean is linear in theta, r(t) = a + b t: the
        # integral of r(t) sin(t) has the closed form -a cos(t) + b (sin(t) - t cos(t)).
        t0, t1 = theta[:-1], theta[1:]
        b = (rings[1:] - rings[:-1]) / np.where(t1 > t0, t1 - t0, 1.0)
        a = rings[:-1] - b * t0

        def antiderivative(t):
            return -a * np.cos(t) + b * (np.sin(t) - t * np.cos(t))

        return 2.0 * math.pi * float(np.sum(antiderivative(t1) - antiderivative(t0)))

    def mean_intensity(self) -> float:
        """The profile's intensity averaged over the sphere (vertical span over :data:`SPHERE_SPAN` degrees) or the
        hemisphere it covers: what ``shaping:ies:normalize`` divides by (OpenUSD's hdEmbree does so too)."""
        span = self.vertical[-1] - self.vertical[0]
        return self.total_intensity() / (4.0 * math.pi if span > SPHERE_SPAN else 2.0 * math.pi)

    def device_data(self, angle_scale: float, scale: float) -> tuple[np.ndarray, int, int]:
        """``(data, V, H')``: ``data`` ``(1 + V + H' + H' V,)`` float32 as :func:`ies_factor` reads it:
        ``angle_scale``, the vertical and the horizontal angles (``H'`` over the whole circle) in radians, and the
        candela values times ``scale``. Made once per profile and arguments: the lamps of a PointInstancer that share
        a profile share its data."""
        made = self.__dict__.setdefault("_device", {})
        key = (float(angle_scale), float(scale), self._arrays_key())
        if key not in made:
            h, c = self.full_circle()
            data = np.concatenate([[angle_scale], np.radians(self.vertical), np.radians(h), (c * scale).reshape(-1)])
            made.clear()  # a profile edited in place keeps one entry, its latest
            made[key] = (data.astype(np.float32), len(self.vertical), len(h))
        return made[key]


def _ring_mean(h: np.ndarray, values: np.ndarray) -> float:
    """Mean over the circle of the piecewise linear function of horizontal angle ``h`` (degrees, 0 to 360, or one
    angle: a constant) with ``values``."""
    if len(h) == 1:
        return float(values[0])
    h = np.concatenate([h, [h[0] + 360.0]])  # the circle closes from the last angle to the first
    values = np.concatenate([values, [values[0]]])
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(h)) / 360.0)


def _merged(h: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``h`` with the angles that repeat (within :data:`ANGLE_TOLERANCE`) kept once, and their rows of ``c``."""
    keep = np.concatenate([[True], np.diff(h) > ANGLE_TOLERANCE])
    return h[keep], c[keep]


def _horizontal_range(h: np.ndarray) -> str | None:
    """Which of LM-63's horizontal ranges ``h`` covers ("single", "quadrant", "half", "back", "full"), or None."""

    def near(a, b):
        return abs(a - b) <= ANGLE_TOLERANCE

    if len(h) == 1:
        return "single"
    if near(h[0], 0.0) and near(h[-1], 90.0):
        return "quadrant"
    if near(h[0], 0.0) and near(h[-1], 180.0):
        return "half"
    if near(h[0], 90.0) and near(h[-1], 270.0):
        return "back"
    if near(h[0], 0.0) and h[-1] > 180.0 + ANGLE_TOLERANCE:  # 0-360, or files that leave out 360 (the same as 0)
        return "full"
    return None


def _check_angles(where: str, name: str, angles: np.ndarray, low: float, high: float) -> None:
    if len(angles) == 0:
        raise IesError(f"{where}: no {name} angles")
    if not np.all(np.isfinite(angles)) or angles.min() < low - ANGLE_TOLERANCE or angles.max() > high + ANGLE_TOLERANCE:
        raise IesError(f"{where}: {name} angles must lie in [{low:g}, {high:g}] degrees, got "
                       f"{angles.min():g} to {angles.max():g}")
    if np.any(np.diff(angles) <= 0.0):
        raise IesError(f"{where}: {name} angles must be ascending")


def read_ies(path: str) -> IesProfile:
    """The profile of the IES file at ``path``.

    Raises:
        IesError: naming the file (and the line) of a file that cannot be read or is no LM-63 type C profile.

    Warns:
        UserWarning: naming the file, where it has lamp tilt data (``TILT=INCLUDE`` or ``TILT=<file>``): the tilt is
            ignored.
    """
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise IesError(f"{path}: cannot be read ({e.strerror or e})") from None
    return parse_ies(data.decode("latin-1"), path)


def parse_ies(text: str, path: str = "<IES>") -> IesProfile:
    """The profile of IES file text ``text`` (``path`` names it in errors).

    Raises:
        IesError: naming ``path`` and the line of what is wrong.

    Warns:
        UserWarning: naming ``path`` and the TILT line, where the file has lamp tilt data: the tilt is ignored.
    """
    # CR, LF and CRLF end lines; str.splitlines also breaks at U+0085, which Latin-1 reads from the Windows-1252
    # ellipsis of a keyword line, and the lines named in errors came one late.
    lines = re.split(r"\r\n|\r|\n", text)
    # "TILT=" and not just "TILT": the free text lines of LM-63-1986 files before it may begin with the word Tilted.
    tilt = next((k for k, line in enumerate(lines) if re.match(r"\s*TILT\s*=", line, re.IGNORECASE)), None)
    if tilt is None:
        raise IesError(f"{path}: no TILT= line; not an IES LM-63 file")
    value = lines[tilt].split("=", 1)[1].strip()
    if not value:
        raise IesError(f"{path}:{tilt + 1}: TILT= names nothing (NONE, INCLUDE or a tilt file)")
    header = lines[0].strip().upper() if lines else ""
    numbers = _Numbers(path, lines, tilt + 1)
    if value.upper() != "NONE":
        _skip_tilt(numbers, value, tilt + 1)
    numbers.take(2, "number of lamps and lumens per lamp")
    multiplier = numbers.take(1, "candela multiplier")[0]
    n_v, n_h = (numbers.count("number of vertical angles"), numbers.count("number of horizontal angles"))
    photometric, line = numbers.take(1, "photometric type")[0], numbers.line
    if int(photometric) != PHOTOMETRIC_TYPE_C or photometric != int(photometric):
        kind = {2: "B", 3: "A"}.get(int(photometric), f"{photometric:g}")
        raise IesError(f"{path}:{line}: photometric type {kind} is not supported (only type C, 1)")
    numbers.take(4, "units type, width, length and height")
    ballast, second = numbers.take(3, "ballast factor, ballast-lamp factor and input watts")[:2]
    factor = multiplier * ballast
    if not re.search(r"LM-63-(2002|2019)", header):  # LM-63-1995 and before: a ballast-lamp photometric factor
        factor *= second
    vertical = numbers.take(n_v, f"{n_v} vertical angles")
    horizontal = numbers.take(n_h, f"{n_h} horizontal angles")
    candela = numbers.take(n_v * n_h, f"{n_v * n_h} candela values ({n_h} horizontal x {n_v} vertical)")
    try:
        return IesProfile(vertical, horizontal, np.asarray(candela).reshape(n_h, n_v) * factor, path)
    except IesError as e:
        raise IesError(str(e)) from None


def _skip_tilt(numbers: "_Numbers", value: str, line: int) -> None:
    """Read past the lamp tilt data of a ``TILT=INCLUDE`` file (LM-63: the lamp-to-luminaire geometry, the number
    of tilt angles, the angles and their multiplying factors, before the photometric data) and warn, naming the file,
    that the tilt is ignored; a ``TILT=<file>`` file holds none of it here. The factors only dim a lamp tilted from
    the position it was measured in, as Cycles and hdEmbree also read the candela table alone."""
    if value.upper() == "INCLUDE":
        numbers.take(1, "lamp-to-luminaire geometry of the TILT=INCLUDE data")
        pairs = numbers.take(1, "number of tilt angles of the TILT=INCLUDE data")[0]
        if pairs != int(pairs) or pairs < 0:
            raise IesError(f"{numbers.path}:{numbers.line}: the number of tilt angles must be a whole number of at "
                           f"least 0, got {pairs:g}")
        numbers.take(int(pairs), f"{int(pairs)} tilt angles")
        numbers.take(int(pairs), f"{int(pairs)} tilt multiplying factors")
        skipped = "its tilt angles and multiplying factors are read past"
    else:
        skipped = "the tilt file is not read"
    warnings.warn(f"{numbers.path}:{line}: TILT={value}: the lamp tilt is ignored ({skipped}); the candela table is "
                  "used as with TILT=NONE", stacklevel=3)


class _Numbers:
    """The numbers after a file's TILT line, read in order with the line each came from."""

    def __init__(self, path: str, lines: list, first: int):
        self.path = path
        self.tokens = []  # (text, 1-based line)
        for k in range(first, len(lines)):
            self.tokens.extend((t, k + 1) for t in lines[k].replace(",", " ").split())
        self.at = 0
        self.line = first + 1

    def take(self, n: int, what: str) -> list:
        if self.at + n > len(self.tokens):
            found = len(self.tokens) - self.at
            last = self.tokens[-1][1] if self.tokens else self.line
            raise IesError(f"{self.path}:{last}: the file ends early: expected {what}, found {found} number(s)")
        values = []
        for text, line in self.tokens[self.at:self.at + n]:
            self.line = line
            try:
                value = float(text)
            except ValueError:
                raise IesError(f"{self.path}:{line}: {text!r} is not a number (reading {what})") from None
            if not math.isfinite(value):
                raise IesError(f"{self.path}:{line}: {text!r} is not a finite number (reading {what})")
            values.append(value)
        self.at += n
        return values

    def count(self, what: str) -> int:
        value = self.take(1, what)[0]
        if value != int(value) or value < 1:
            raise IesError(f"{self.path}:{self.line}: {what} must be a whole number of at least 1, got {value:g}")
        return int(value)
