"""Cameras: the Python ``Camera`` object and the kernel that turns pixels into rays.

Conventions, stated once:

- A camera looks down its local -Z axis with +Y up and +X to the right, as ``UsdGeom.Camera`` does.
- ``Camera.to_world`` is a ``(4, 4)`` matrix in column-vector convention: ``p_world = to_world @ [p, 1]``.
  (USD's ``Gf.Matrix4d`` is row-vector, so it is transposed on the way in.) Rays are made in camera space and
  moved to world space by the whole matrix, scale, shear and mirroring included, as Hydra's view matrix (its
  inverse) does: the film, the clipping range and the focus distance are camera-space lengths, so a camera
  scaled together with the scene (a units conversion on a common parent) sees the same image.
- Film quantities follow USD: focal length and apertures share one unit (so only their ratios matter for
  perspective framing); that unit is a tenth of a scene unit (``Gf.Camera.APERTURE_UNIT``) for orthographic
  apertures and for the thin lens's aperture, ``focalLength / fStop``.
- ``fit="horizontal"`` (the default) keeps the horizontal aperture and lets the vertical extent follow the image
  aspect (UsdRender's ``adjustApertureHeight``, CameraUtil's ``MatchHorizontally``). usdview does the other: its
  free camera is made from a vertical field of view and always conformed with ``CameraUtilMatchVertically``, as is
  a stage camera unless its viewport is masked or fitted, which is ``fit="vertical"`` (``adjustApertureWidth``).
  ``Camera.look_at`` uses ``fit="vertical"`` so that its ``fov_y_deg`` holds at any aspect. ``fit`` also takes the other
  ``aspectRatioConformPolicy`` tokens of UsdRender (``expandAperture``, ``cropAperture``,
  ``adjustPixelAspectRatio``), applied as ``UsdRenderComputeSpec`` does; the image aspect is
  ``pixel_aspect_ratio * width / height``.
- Image row 0 is the top. Pixel ``(i, j)`` samples film position ``((j + sx) / W, (i + sy) / H)`` where
  ``(sx, sy) = (0.5, 0.5)`` at one sample per pixel.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import warp as wp

from .errors import bottom_row_problem, did_you_mean, prim_path, stray_field
from .floats import TRACED_REACH
from .geometry import stable_length

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile

APERTURE_UNIT = 0.1  # the film unit in scene units, as in Gf.Camera (orthographic apertures, the thin lens)
# UsdRender's aspectRatioConformPolicy tokens; Camera.fit takes them and wrt's two names ("horizontal" is
# adjustApertureHeight and "vertical" adjustApertureWidth under other names).
CONFORM_POLICIES = ("expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight",
                    "adjustPixelAspectRatio")
FITS = ("horizontal", "vertical", *CONFORM_POLICIES)
MAX_CLIPPING_PLANES = 8  # the rows of DeviceCamera's two plane matrices
FLOAT32_MAX = float(np.finfo(np.float32).max)


@wp.struct
class DeviceCamera:
    """Camera data in the form the ray-generation kernel needs."""

    origin: wp.vec3  # eye position, world space
    right: wp.vec3  # camera +X in world space: a column of the camera's transform, its scale included
    up: wp.vec3  # camera +Y in world space, scale included
    forward: wp.vec3  # camera -Z in world space (viewing direction), scale included
    film_width: float  # film extent along right, in focal-length units (perspective) or camera-space units (ortho)
    film_height: float  # film extent along up, same unit
    film_offset: wp.vec2  # film window shift (x, y), same unit
    orthographic: int  # 1 for orthographic projection
    near: float  # clipping range, camera-space depth
    far: float
    # Clipping planes in world space about the eye, one per row (a, b, c, d): points p with (a, b, c) . (p - origin)
    # + d < 0 are cut away. Two fixed matrices rather than an array, so the struct needs no device memory.
    planes_a: wp.mat44  # planes 0-3
    planes_b: wp.mat44  # planes 4-7
    num_planes: int


@wp.func
def film_ray(cam: DeviceCamera, fx: float, fy: float):
    """Origin and direction of the ray through film position ``(fx, fy)`` in [0, 1]^2 (y down), the direction not
    normalised: one unit of it is one unit of camera-space depth."""
    x = (fx - 0.5) * cam.film_width + cam.film_offset[0]
    y = (0.5 - fy) * cam.film_height + cam.film_offset[1]
    if cam.orthographic == 1:
        return cam.origin + x * cam.right + y * cam.up, cam.forward
    return cam.origin, cam.forward + x * cam.right + y * cam.up


@wp.func
def clipped_ray(cam: DeviceCamera, origin: wp.vec3, ray: wp.vec3):
    """``(origin, unit direction, t_min, t_max)`` of a ray whose direction ``ray`` advances one unit of camera-space
    depth per unit: the clipping range becomes distances along the unit direction. The length is
    :func:`stable_length`'s: ``wp.length`` squares the components, so a camera scaled with its scene by 1e20 (or
    1e-20) got an infinite (or zero) length, a zero (or NaN) direction, and rendered nothing."""
    length = stable_length(ray)
    d = ray / length
    t0 = cam.near * length
    t1 = cam.far * length
    for k in range(cam.num_planes):
        plane = cam.planes_a[k % 4]
        if k >= 4:
            plane = cam.planes_b[k - 4]
        # Kept where dot(n, origin + t d) + w >= 0: one end of the interval moves, or all of it goes when the ray
        # runs parallel to the plane on its cut side.
        n = wp.vec3(plane[0], plane[1], plane[2])
        rate = wp.dot(n, d)
        side = wp.dot(n, origin - cam.origin) + plane[3]
        if rate > 0.0:
            t0 = wp.max(t0, -side / rate)
        elif rate < 0.0:
            t1 = wp.min(t1, -side / rate)
        elif side < 0.0:
            t1 = t0
    return origin, d, t0, t1


@wp.func
def camera_ray(cam: DeviceCamera, fx: float, fy: float):
    """Ray through film position ``(fx, fy)`` in [0, 1]^2 (y down). Returns origin, unit direction, t range."""
    origin, ray = film_ray(cam, fx, fy)
    return clipped_ray(cam, origin, ray)


@wp.kernel
def generate_rays_kernel(
    cam: DeviceCamera,
    width: int,
    height: int,
    sample: int,
    seed: int,
    # outputs
    origins: wp.array[wp.vec3],
    directions: wp.array[wp.vec3],
    t_mins: wp.array[float],
    t_maxs: wp.array[float],
):
    """One ray per pixel, row-major from the top-left: through the pixel centre for ``sample == 0``, through a
    uniformly jittered point of the pixel (deterministic in ``seed``, pixel and sample) otherwise."""
    tid = wp.tid()
    i = tid // width
    j = tid - i * width
    sx = float(0.5)
    sy = float(0.5)
    if sample > 0:
        rng = wp.rand_init(seed, tid + sample * width * height)
        sx = wp.randf(rng)
        sy = wp.randf(rng)
    o, d, t0, t1 = camera_ray(cam, (float(j) + sx) / float(width), (float(i) + sy) / float(height))
    origins[tid] = o
    directions[tid] = d
    t_mins[tid] = t0
    t_maxs[tid] = t1


def _normalized(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if not np.isfinite(n) or n == 0.0:
        raise ValueError(f"cannot normalise vector {v.tolist()}")
    return v / n


def _finite(v) -> bool:
    """True for a finite real number; False for NaN, inf, an int past float64's range and anything that is not a
    number (math.isfinite's OverflowError for 10**400 escaped check(), naming no camera)."""
    if isinstance(v, (bool, np.bool_)):  # True was a focal length (or field of view) of 1, without a word
        return False
    try:
        return math.isfinite(v)
    except (TypeError, OverflowError):
        return False


def _show(v) -> str:
    """``v`` for a message: numbers to 6 significant digits (``nan``; a float32 ``20.955`` read from USD is not
    ``20.954999923706055``), anything else as its repr (``'3'``)."""
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v) if isinstance(v, int) else repr(v)


@dataclasses.dataclass
class Camera:
    """A camera, perspective or orthographic, with USD's film model.

    Attributes:
        to_world: ``(4, 4)`` float64 camera-to-world matrix, column-vector convention (see module docstring), affine:
            bottom row ``(0, 0, 0, 1)``.
        focal_length: focal length, in the film unit (a perspective camera's is positive; an orthographic camera
            does not use it, any finite number).
        horizontal_aperture: film width, in the film unit.
        vertical_aperture: film height, in the film unit (unused with ``fit="horizontal"``). Either aperture may be 0
            where :attr:`fit` does not read it (the vertical one under ``"horizontal"``, either under
            ``expandAperture``), as USD allows.
        horizontal_aperture_offset: film shift along +X, in the film unit.
        vertical_aperture_offset: film shift along +Y, in the film unit.
        clipping_range: ``(near, far)`` camera-space depth range (scene units for an unscaled camera); an
            orthographic camera's near may be negative, a plane behind the camera, as USD's frustum takes it.
        clipping_planes: ``(K, 4)`` camera-space planes ``(a, b, c, d)``, at most 8; points with
            ``a x + b y + c z + d < 0`` are cut away (``UsdGeom.Camera.clippingPlanes``).
        projection: ``"perspective"`` or ``"orthographic"``.
        fit: how the film follows an image aspect that differs from the apertures' (one of :data:`FITS`):
            ``"horizontal"`` keeps the horizontal aperture, ``"vertical"`` the vertical one; UsdRender's
            ``expandAperture`` grows one aperture so the whole of both fits, ``cropAperture`` shrinks one,
            ``adjustApertureWidth`` / ``adjustApertureHeight`` change that one, and ``adjustPixelAspectRatio``
            keeps both (the pixels take the apertures' aspect).
        pixel_aspect_ratio: width / height of one pixel (UsdRender's ``pixelAspectRatio``); 1: square pixels.
        f_stop: lens f-number, not negative; 0 means a pinhole.
        focus_distance: camera-space depth of the plane in focus, not negative (0: a pinhole).
        exposure_scale: factor on the radiance the camera sees (``path`` and ``whitted`` images), USD's
            ``ComputeLinearExposureScale``: ``2^exposure * exposure:time * exposure:iso / 100 *
            exposure:responsivity / exposure:fStop^2``; 1 with USD's fallbacks.
        path: prim path when read from USD.
    """

    to_world: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(4))
    focal_length: float = 50.0
    horizontal_aperture: float = 20.955
    vertical_aperture: float = 15.2908
    horizontal_aperture_offset: float = 0.0
    vertical_aperture_offset: float = 0.0
    clipping_range: tuple[float, float] = (0.01, 1.0e6)
    clipping_planes: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 4)))
    projection: str = "perspective"
    fit: str = "horizontal"
    pixel_aspect_ratio: float = 1.0
    f_stop: float = 0.0
    focus_distance: float = 0.0
    exposure_scale: float = 1.0
    path: str = ""

    def __post_init__(self):
        self.check()

    def check(self) -> None:
        """Raises ``ValueError`` naming the field that is out of range, and brings ``to_world`` and
        ``clipping_planes`` to float64 arrays. Run on construction and again by :meth:`to_struct`: the fields are
        plain attributes, set after construction too (``wrt.procedural.ring_of_cameras`` shifts film offsets so),
        and a NaN written into ``to_world`` was reported as a singular transform ("a zero scale"), a NaN focal
        length or an inverted clipping range rendered background without a word."""
        stray = stray_field(self)  # cam.fov = 30 (or eye, fov_y_deg, position): kept and read by nothing
        if stray:
            hint = "; for a field of view, Camera.look_at(eye, target, up, fov_y_deg)" if "'fov" in stray else ""
            raise ValueError(f"{self.label()} {stray}{hint}")
        path = prim_path(self.path, "wrt.Camera", optional=True)  # an int was kept, and named in messages
        if path is not self.path:
            self.path = path
        try:
            # Its own dtype first: an array of text ("1.0"), bools or complex values converted to float64 without a
            # word (the imaginary part dropped with only numpy's warning).
            to_world = np.asarray(self.to_world)
            if to_world.dtype.kind not in "iufO":
                raise TypeError
            self.to_world = np.asarray(to_world, dtype=np.float64)
        except (TypeError, ValueError):  # numpy's "could not convert string to float" named no camera
            raise ValueError(f"{self.label()} to_world must be a (4, 4) matrix of numbers, got {self.to_world!r}")
        if self.to_world.size != 16:  # numpy's reshape error named no argument
            raise ValueError(f"{self.label()} to_world must be a (4, 4) matrix, got shape {self.to_world.shape}")
        self.to_world = self.to_world.reshape(4, 4)
        if self.projection not in ("perspective", "orthographic"):
            raise ValueError(f"camera projection must be 'perspective' or 'orthographic', not {self.projection!r}"
                             f"{did_you_mean(self.projection, ('perspective', 'orthographic'))}")
        if self.fit not in FITS:
            raise ValueError(f"camera fit must be one of {', '.join(FITS)}, not {self.fit!r}"
                             f"{did_you_mean(self.fit, FITS)}")
        if not (_finite(self.pixel_aspect_ratio) and self.pixel_aspect_ratio > 0):
            raise ValueError(f"{self.label()} needs a finite positive pixel aspect ratio, got "
                             f"{_show(self.pixel_aspect_ratio)}")
        # Finite as well as positive: an infinite aperture or focal length, or a NaN offset, makes every ray NaN, an
        # image of background only. Non-numbers (a string) count as not finite, so they too get this ValueError.
        # An orthographic film is the apertures alone (USD's frustum takes no focal length): its focal length need
        # only be a number, else a stage's orthographic camera of focalLength 0, which usdview draws, was skipped.
        focal = self.focal_length if self.projection == "perspective" or not _finite(self.focal_length) else 1.0
        apertures = (self.horizontal_aperture, self.vertical_aperture)
        if not (_finite(focal) and focal > 0 and all(_finite(v) and v >= 0 for v in apertures)):  # 0: checked below
            raise ValueError(
                f"{self.label()} needs finite positive focalLength and apertures, got focal_length="
                f"{_show(self.focal_length)}, apertures={_show(self.horizontal_aperture)}x"
                f"{_show(self.vertical_aperture)}"
            )
        # An aperture of 0 (USD takes it: a flat frustum window) is harmless where the fit never reads it: the vertical
        # one under "horizontal" or adjustApertureHeight, either one under expandAperture, which grows it to the image.
        unread = _unread_apertures(self.fit, self.horizontal_aperture, self.vertical_aperture)
        zero = [name for name, v in (("horizontal_aperture", self.horizontal_aperture),
                                     ("vertical_aperture", self.vertical_aperture)) if v == 0 and name not in unread]
        if zero:
            raise ValueError(f"{self.label()} needs a positive {' and '.join(zero)}, which fit {self.fit!r} frames "
                             f"the image with, got {', '.join(f'{name}=0' for name in zero)}")
        lens = {
            "horizontal_aperture_offset": self.horizontal_aperture_offset,
            "vertical_aperture_offset": self.vertical_aperture_offset,
            "f_stop": self.f_stop,
            "focus_distance": self.focus_distance,
        }
        bad = ", ".join(f"{k}={_show(v)}" for k, v in lens.items() if not _finite(v))
        if bad:
            raise ValueError(f"{self.label()} needs finite film offsets, fStop and focusDistance, got {bad}")
        # USD's fStop "defaults to 0.0, which turns off focusing" and focusDistance is a distance: a negative one has
        # no meaning, and rendered as a pinhole without a word. Refused as a negative aperture is.
        negative = ", ".join(f"{k}={_show(v)}" for k, v in lens.items() if k in ("f_stop", "focus_distance") and v < 0)
        if negative:
            raise ValueError(f"{self.label()} needs a non-negative fStop and focusDistance (an fStop of 0 is a "
                             f"pinhole), got {negative}")
        # At most float32's largest: the image is float32, and a larger scale made every lit pixel inf.
        if not (_finite(self.exposure_scale) and 0 <= self.exposure_scale <= FLOAT32_MAX):
            raise ValueError(f"{self.label()} needs a non-negative exposure scale of at most {FLOAT32_MAX:.4g} (from "
                             f"exposure, exposure:time, :iso, :fStop and :responsivity), got "
                             f"{_show(self.exposure_scale)}")
        try:
            shape = np.shape(self.clipping_range)
        except ValueError:  # a ragged list ((0.1, (1, 2))): numpy's "inhomogeneous shape" named no camera
            shape = None
        if shape != (2,):  # "too many values to unpack"
            raise ValueError(f"{self.label()} clipping range must be (near, far), got {self.clipping_range!r}")
        near, far = self.clipping_range
        # An orthographic near plane may lie behind the camera (USD's frustum takes it: the camera sees what lies
        # that far behind its plane); a perspective one cannot, all its rays start at the eye.
        lowest = -math.inf if self.projection == "orthographic" else 0.0
        if not (_finite(near) and (_finite(far) or far == math.inf) and lowest <= near < far):  # ("a", "b"): TypeError
            rule = "near < far" if lowest < 0 else "0 <= near < far"
            raise ValueError(f"{self.label()} clipping range must satisfy {rule}, got {self.clipping_range}")
        if not np.all(np.isfinite(self.to_world)):
            raise ValueError(f"{self.label()} transform is not finite")
        problem = bottom_row_problem(f"{self.label()} to_world", self.to_world)
        if problem:
            raise ValueError(problem)
        try:
            planes = np.asarray(self.clipping_planes, dtype=np.float64)
        except (TypeError, ValueError):  # text, a ragged list: refused below, not with numpy's message
            planes = np.full((1, 4), np.nan)
        if planes.size == 0:
            planes = np.zeros((0, 4))
        if (
            planes.ndim != 2
            or planes.shape[1] != 4
            or not np.all(np.isfinite(planes))
            or not np.all(np.linalg.norm(planes[:, :3], axis=1) > 0.0)
        ):
            raise ValueError(
                f"{self.label()} clipping planes must be finite (a, b, c, d) rows with a non-zero normal "
                f"(a, b, c), got {planes.tolist() if np.all(np.isfinite(planes)) else self.clipping_planes!r}"
            )
        if len(planes) > MAX_CLIPPING_PLANES:
            raise ValueError(
                f"{self.label()} has {len(planes)} clipping planes; at most {MAX_CLIPPING_PLANES} are "
                "supported"
            )
        self.clipping_planes = planes

    def __eq__(self, other) -> bool:
        """Whether ``other`` is a camera of the same field values: numbers by value, whatever holds them
        (:func:`_compared`). The dataclass compared ``to_world`` with numpy's ``==``, whose answer has no truth value:
        ``cam == other`` and ``cam in cameras`` raised ValueError; then :meth:`snapshot`'s bytes and types told a
        ``to_world`` set as a list, or a clipping range given as one, from the equal array or tuple."""
        if other.__class__ is not self.__class__:
            return NotImplemented
        return self._compared() == other._compared()

    def _compared(self) -> tuple:
        strays = tuple(sorted(name for name in vars(self) if name not in CAMERA_FIELDS))  # for check() to refuse
        return (*(_compared(name, self.__dict__.get(name)) for name in CAMERA_FIELDS), strays)

    __hash__ = None  # equal by value, and its fields are set after construction

    def snapshot(self) -> tuple:
        """Every field's value now, numbers as :func:`_compared` gives them (an array's edit in place shows too), for
        telling whether the camera changed since (a kept :class:`wrt.Renderer` follows its cameras so). By value, as
        ``==``: the bytes of each field with its type made ``cam.to_world = cam.to_world.tolist()`` (or a clipping
        range set as a list) a change, which frame_image refused and render() uploaded again."""
        return self._compared()

    def hold_checked_arrays(self) -> None:
        """Makes ``to_world`` and ``clipping_planes`` the float64 arrays :meth:`check` makes of them, where they are
        held otherwise (a list, 16 numbers): for a camera whose numbers are unchanged since a check, so that its
        readers may index them (``to_world[:3, 3]``) as after the upload that a snapshot by value now skips."""
        arrays = (self.to_world, self.clipping_planes)
        if not all(type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 2 for a in arrays) or (
            self.to_world.shape != (4, 4)
        ):
            self.check()

    def depth_extent(self, lower, upper) -> tuple[float, float]:
        """``(nearest, farthest)`` camera-space depth (along the view, the clipping range's measure) of the corners of
        the world box ``lower``-``upper``: every point of the box lies in that range, whatever the camera's
        transform (scale and shear included)."""
        corners = np.array([[(lower, upper)[k >> a & 1][a] for a in range(3)] + [1.0] for k in range(8)], np.float64)
        # + 0.0: a box in the camera's plane lies at -0.0, which messages printed as "-0" (IEEE: -0 + 0 = +0).
        depths = -(np.linalg.inv(np.asarray(self.to_world, np.float64)) @ corners.T)[2] + 0.0
        return float(depths.min()), float(depths.max())

    def label(self) -> str:
        """``camera /Path`` for messages, or just ``camera`` for one built in Python (no double space)."""
        return f"camera {self.path}" if self.path else "camera"

    @classmethod
    def look_at(cls, eye, target, up=(0.0, 1.0, 0.0), fov_y_deg: float = 45.0, **kwargs) -> Camera:
        """A perspective camera at ``eye`` looking at ``target``, with a vertical field of view in degrees (square
        apertures of that angle and ``fit="vertical"``; another ``fit`` keeps the angle on its own axis instead, e.g.
        ``"horizontal"`` across the image's width)."""
        _check_keywords("look_at", kwargs, "fov_y_deg", {"projection": "perspective"})
        if not (_finite(fov_y_deg) and 0.0 < fov_y_deg < 180.0):  # a string failed in the comparison
            raise ValueError(f"fov_y_deg must lie in (0, 180), got {_show(fov_y_deg)}")
        focal_length = kwargs.get("focal_length", 50.0)
        if _finite(focal_length):  # else check() names it: 2.0 * 10**400 (or * "50") raised Python's words alone
            aperture = 2.0 * focal_length * math.tan(math.radians(fov_y_deg) / 2.0)
            kwargs.setdefault("vertical_aperture", aperture)
            kwargs.setdefault("horizontal_aperture", aperture)
        kwargs.setdefault("fit", "vertical")
        return cls(to_world=_look_at_matrix(eye, target, up), **kwargs)

    @classmethod
    def orthographic(cls, eye, target, up=(0.0, 1.0, 0.0), height: float = 2.0, **kwargs) -> Camera:
        """An orthographic camera at ``eye`` looking at ``target`` whose view is ``height`` scene units tall (with
        another ``fit``, that extent lies on its axis: ``"horizontal"``, ``height`` units wide)."""
        _check_keywords("orthographic", kwargs, "height", {"projection": "orthographic"},
                        horizontal_aperture="height", vertical_aperture="height")
        if not (_finite(height) and height > 0):
            raise ValueError(f"orthographic height must be a finite positive number, got {_show(height)}")
        aperture = height / APERTURE_UNIT
        return cls(
            to_world=_look_at_matrix(eye, target, up),
            vertical_aperture=aperture,
            horizontal_aperture=aperture,
            **{"fit": "vertical", **kwargs, "projection": "orthographic"},
        )

    @property
    def eye(self) -> np.ndarray:
        """``(3,)`` world-space position."""
        return self.to_world[:3, 3].copy()

    def film_size(self, width: int, height: int) -> tuple[float, float]:
        """Film ``(width, height)`` in the film unit for an image of ``width x height`` pixels: the apertures with one
        of them changed by :attr:`fit` so that their ratio is the image aspect (``UsdRenderComputeSpec``'s
        ``_ApplyAspectRatioPolicy``), or both as they are for ``adjustPixelAspectRatio``."""
        aspect = self.pixel_aspect_ratio * width / height  # the image's, pixel shape included
        w, h = self.horizontal_aperture, self.vertical_aperture
        fit = self.fit
        if fit in ("expandAperture", "cropAperture"):  # the aperture wider than the image: its height grows (expand)
            fit = "horizontal" if (w > aspect * h) == (fit == "expandAperture") else "vertical"  # (h may be 0)
        if fit in ("horizontal", "adjustApertureHeight"):
            return w, w / aspect
        if fit in ("vertical", "adjustApertureWidth"):
            return h * aspect, h
        return w, h  # adjustPixelAspectRatio

    def image_aspect(self) -> float | None:
        """Width / height in pixels of the image whose film is exactly the apertures (pixels of
        :attr:`pixel_aspect_ratio`), as ``usdrecord --imageWidth`` sizes its image; ``None`` under a :attr:`fit`
        that keeps one aperture only (``look_at``'s ``"vertical"``), where the other does not shape the film."""
        if self.fit in ("horizontal", "vertical", "adjustApertureWidth", "adjustApertureHeight"):
            return None
        if self.horizontal_aperture == 0 or self.vertical_aperture == 0:  # expandAperture grows it to any image
            return None
        return self.horizontal_aperture / self.vertical_aperture / self.pixel_aspect_ratio

    def rendered_pixel_aspect(self, width: int, height: int) -> float:
        """Width / height of one pixel of a ``width x height`` image on the film: :attr:`pixel_aspect_ratio`, except
        under ``adjustPixelAspectRatio``, whose film is the apertures whatever the pixel counts (the shape an EXR's
        ``pixelAspectRatio`` states)."""
        film_w, film_h = self.film_size(width, height)
        return film_w * height / (film_h * width)

    def to_struct(self, width: int, height: int) -> DeviceCamera:
        """The :class:`DeviceCamera` for an image of ``width x height`` pixels."""
        self.check()
        m = self.to_world
        if not abs(np.linalg.det(m[:3, :3])) > 0.0:  # checked here: a stage may hold such a camera unused
            raise ValueError(f"{self.label()} transform is singular (a zero scale), so it has no view")
        # Columns of the linear part, scale included: rays are mapped from camera space as points are.
        right, up, back = (m[:3, k] for k in range(3))
        film_w, film_h = self.film_size(width, height)
        offset = np.array([self.horizontal_aperture_offset, self.vertical_aperture_offset])
        if self.projection == "perspective":
            scale = 1.0 / self.focal_length  # film units -> direction units at unit depth
        else:
            scale = APERTURE_UNIT  # film units -> scene units
        self._check_film_reach(film_w * scale, film_h * scale, offset * scale, width, height)
        s = DeviceCamera()
        s.origin = wp.vec3(*m[:3, 3])
        s.right = wp.vec3(*right)
        s.up = wp.vec3(*up)
        s.forward = wp.vec3(*(-back))
        s.film_width = float(film_w * scale)
        s.film_height = float(film_h * scale)
        s.film_offset = wp.vec2(*(offset * scale))
        s.orthographic = 1 if self.projection == "orthographic" else 0
        s.near = float(self.clipping_range[0])
        s.far = float(self.clipping_range[1])
        # A camera-space plane p maps to p @ inverse(to_world) in world space; taken about the eye (to_world without
        # its translation), as the clipping range is, since far from the world origin a world-space d of 1e6 kept no
        # digits below 0.06 in float32; rescaled to a unit normal so that its distances keep float32 precision
        # whatever the camera's scale.
        about_eye = m.copy()
        about_eye[:3, 3] = 0.0
        planes = self.clipping_planes @ np.linalg.inv(about_eye)
        planes /= np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
        rows = np.zeros((MAX_CLIPPING_PLANES, 4))
        rows[: len(planes)] = planes
        s.planes_a = wp.mat44(*rows[:4].astype(np.float32).reshape(-1))
        s.planes_b = wp.mat44(*rows[4:].astype(np.float32).reshape(-1))
        s.num_planes = len(planes)
        return s

    def _check_film_reach(self, film_w: float, film_h: float, offset: np.ndarray, width: int, height: int) -> None:
        """ValueError naming the fields that make the film where its corner rays leave float32's range (a film 1e60
        focal lengths wide: apertures of 1e30 over a focal length of 1e-30). Those rays (a perspective camera's
        directions, an orthographic one's origins) were NaN, and the image background without a word, where USD's
        frustum casts finite rays. The sizes are :meth:`to_struct`'s (direction or scene units); the corner rays are
        made as the kernel makes them, each term, and the rays themselves within half of float32's range, which
        leaves room for the length the kernel takes (a camera scaled by 1e38 still renders)."""
        m = self.to_world
        half = float(FLOAT32_MAX) / 2.0
        with np.errstate(over="ignore", invalid="ignore"):
            xs = np.array([-0.5, 0.5]) * film_w + offset[0]
            ys = np.array([-0.5, 0.5]) * film_h + offset[1]
            across = (xs[:, None, None] * m[:3, 0] + ys[None, :, None] * m[:3, 1]).reshape(-1, 3)
            base = -m[:3, 2] if self.projection == "perspective" else m[:3, 3]
            terms = np.concatenate([np.abs(xs), np.abs(ys), np.abs(np.outer(xs, m[:3, 0])).ravel(),
                                    np.abs(np.outer(ys, m[:3, 1])).ravel()])
            reach = float(np.abs(base + across).max())
            if terms.max() < half and reach < half:
                self._check_near_reach(np.linalg.norm(base + across, axis=1) if self.projection == "perspective"
                                       else np.linalg.norm(m[:3, 2]))
                return
            reach = max(reach, float(terms.max()))
        unit = "direction units per unit of depth" if self.projection == "perspective" else "scene units"
        raise ValueError(
            f"{self.label()}: its film (with its to_world scale) puts the corner rays of a {width}x{height} image "
            f"{reach:.3g} {unit} off, past float32's range (its rays would be NaN): focal_length="
            f"{_show(self.focal_length)}, horizontal_aperture={_show(self.horizontal_aperture)}, vertical_aperture="
            f"{_show(self.vertical_aperture)}, offsets {_show(self.horizontal_aperture_offset)}, "
            f"{_show(self.vertical_aperture_offset)} (fit {self.fit!r}, pixel_aspect_ratio="
            f"{_show(self.pixel_aspect_ratio)})")


    def _check_near_reach(self, lengths) -> None:
        """ValueError naming the clipping range where the near plane lies past float32's range along a corner ray of
        ``lengths`` (world length per unit of camera depth: the corner directions of a perspective camera, the
        forward axis of an orthographic one): the kernel's ``near * length`` was inf there, and those rays saw
        nothing without a word (a camera scaled by 1e38 whose near plane is at depth 3). Whatever such a ray could
        meet past the near plane lies farther than float32 can count along it, so no clipping range would help."""
        near, far = self.clipping_range
        reach = abs(float(near)) * float(np.max(lengths))
        if reach < FLOAT32_MAX:
            return
        raise ValueError(
            f"{self.label()}: its near plane lies {reach:.3g} scene units along its corner rays, past float32's range "
            f"(those rays would see nothing): clipping_range=({_show(near)}, {_show(far)}) with "
            f"a to_world scale of {np.linalg.norm(self.to_world[:3, 2]):.3g}; scale the camera and the scene down")


CAMERA_FIELDS = tuple(f.name for f in dataclasses.fields(Camera))  # in order; Camera.snapshot reads them all


def _compared(name: str, value):
    """The value of the :class:`Camera` field ``name`` as ``==`` compares it: numbers (a scalar, or an array, list
    or tuple of them) as their float64 values, in the shape :meth:`Camera.check` gives them (16 numbers a ``(4, 4)``
    ``to_world``, no clipping planes ``(0, 4)``) and with -0.0 as 0.0; text as it is; anything else (a ragged list)
    equal to nothing, so that check() names it."""
    if value is None or isinstance(value, (str, bytes)):  # "50" is no focal length, though numpy reads it as one
        return value
    try:
        if type(value) is float or type(value) is int:  # most fields: a fifth of the time of numpy's asarray
            return (), (np.float64(value) + 0.0).tobytes()
        values = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int past float64's range
        return object()
    if name == "to_world" and values.size == 16:
        values = values.reshape(4, 4)
    elif name == "clipping_planes" and values.size == 0:
        values = values.reshape(0, 4)
    return values.shape, (values + 0.0).tobytes()


def _unread_apertures(fit: str, horizontal, vertical) -> tuple[str, ...]:
    """The apertures (field names) that :meth:`Camera.film_size` never reads under ``fit``, whatever the image: an
    aperture of 0 is harmless there. ``expandAperture`` grows the one that is narrower than the image, so it reads
    only the other when one is 0."""
    if fit in ("horizontal", "adjustApertureHeight") or (fit == "expandAperture" and vertical == 0):
        return ("vertical_aperture",)
    if fit in ("vertical", "adjustApertureWidth") or (fit == "expandAperture" and horizontal == 0):
        return ("horizontal_aperture",)
    return ()


def _check_keywords(method: str, kwargs: dict, own: str, fixed: dict | None = None, **set_from: str) -> None:
    """TypeError for a keyword that is no :class:`Camera` field, from ``method``'s point of view: ``fov=60`` was
    reported as ``Camera.__init__() got an unexpected keyword argument``, which the caller never called. ``fixed``
    maps a field to the one value ``method`` makes (``projection``: any other is a ValueError, not silently another
    camera); ``set_from`` names the fields ``method`` works out itself and the argument they come from, so passing
    one is a TypeError saying so, not Python's "got multiple values for keyword argument"."""
    set_from = {"to_world": "eye, target and up", **set_from}
    fields = [f.name for f in dataclasses.fields(Camera) if f.name not in set_from]
    for name, value in kwargs.items():
        if name in set_from:
            raise TypeError(f"Camera.{method}() works {name} out from {set_from[name]}; set {name} on the camera "
                            "it returns instead")
        if name not in fields:
            raise TypeError(f"Camera.{method}() got an unexpected keyword argument {name!r}"
                            f"{did_you_mean(name, [own, *fields])}")
        if fixed and name in fixed and not (isinstance(value, str) and value == fixed[name]):
            other = "Camera.orthographic" if fixed[name] == "perspective" else "Camera.look_at"
            projections = ("perspective", "orthographic")  # a hint for a misspelt one; a right one is not echoed
            meant = did_you_mean(value, projections) if isinstance(value, str) and value not in projections else ""
            raise ValueError(f"Camera.{method}() makes {fixed[name]} cameras only, not {name}={value!r}{meant}: use "
                             f"{other}() or Camera()")


def _point(name: str, value) -> np.ndarray:
    """``value`` as a ``(3,)`` float64 vector of finite numbers, else ValueError naming ``name``: a NaN eye or a
    2-vector was reported as "cannot normalise vector" or "up is parallel to the viewing direction"."""
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"look_at: {name} must be 3 finite numbers, got {value!r}")
    return v


def _look_at_matrix(eye, target, up) -> np.ndarray:
    eye, target, up = _point("eye", eye), _point("target", target), _point("up", up)
    if np.array_equal(eye, target):
        raise ValueError(f"look_at: eye and target are the same point {eye.tolist()}, so there is no view direction")
    back = _normalized(eye - target)
    # up is a direction: brought to a largest component of 1 (a norm underflows for 1e-200), so that the test for
    # one along the view is of its angle, not its length (an up of (0, 1e-13, 0) was refused as parallel).
    largest = np.abs(up).max()
    right = np.cross(up / largest if largest > 0.0 else up, back)
    if np.linalg.norm(right) < 1e-12:
        raise ValueError(f"look_at: up {up.tolist()} is zero or parallel to the viewing direction "
                         f"{(0.0 - back).tolist()}; pass another up")
    right = _normalized(right)
    true_up = np.cross(back, right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, true_up, back, eye
    return m


def frame_scene(lower, upper, up_axis: str = "Y", fov_y_deg: float = 40.0) -> Camera:
    """A perspective camera that sees the whole box ``[lower, upper]``, in an image of any aspect (``fov_y_deg`` is
    the narrower of its two fields of view), from the front and above (a box of no size
    as one 1e-6 across), and everything behind it: its far clipping plane is at infinity. A box of any other size
    fills the view: its radius was taken as at least 1e-6, and a scene scaled by 1e-20 was a dot in the middle of
    the image. The eye stays within :data:`wrt.floats.TRACED_REACH` (2^126, 8.5e37) of the origin on every axis,
    nearer the box (along the same view) where it would not, with a warning: the view of a box reaching 2e38 was
    8.5e38 away, past float32's range, so the camera's float32 eye was infinite and its frustum and rays NaN."""
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    center = (lower + upper) / 2.0
    radius = float(np.linalg.norm(upper - lower)) / 2.0 or 1e-6
    distance = radius / math.sin(math.radians(fov_y_deg) / 2.0)
    if up_axis == "Z":
        up, view = np.array([0.0, 0.0, 1.0]), np.array([0.4, -1.0, 0.5])
    else:
        up, view = np.array([0.0, 1.0, 0.0]), np.array([0.4, 0.5, 1.0])
    # Turned from its offset, placed at the eye after: a box far from the origin (1e30) rounds the eye's offset
    # away along some axes, and eye - center turned the view to look straight down (or refused it as along up).
    offset = _normalized(view) * distance
    eye = center + offset
    if (np.abs(eye) > TRACED_REACH).any():  # (NaN: as before)
        eye = nearest_eye_within_reach(center, offset)
        warnings.warn(f"frame_scene: the camera that frames the box {lower.tolist()} to {upper.tolist()} whole would "
                      f"sit at {(center + offset).tolist()}, past {TRACED_REACH:.3g} (2^126), beyond which its rays "
                      f"are not finite in float32 or overflow the triangle test: it is placed at {eye.tolist()} "
                      "instead and may not see all of the scene", stacklevel=2)
        offset = eye - np.asarray(center)
        if not offset.any():
            raise ValueError(f"frame_scene: the box {lower.tolist()} to {upper.tolist()} lies past {TRACED_REACH:.3g} "
                             "(2^126), where no camera can be placed to see it; pass a camera")
        distance = float(np.linalg.norm(offset))
    # No far plane: the box bounds the geometry, not the lights, and an area light behind it (a backdrop, or any
    # light of a stage of lights alone, framed as the unit cube) was hidden by a far plane just past the box.
    # expandAperture keeps the whole square field of view in the image whatever its aspect (the vertical one alone,
    # look_at's fit, cut a portrait image's scene at its sides); a landscape image gets the same view.
    camera = Camera.look_at(offset, (0.0, 0.0, 0.0), up, fov_y_deg, clipping_range=(distance * 1e-4, math.inf),
                            fit="expandAperture")
    camera.to_world[:3, 3] = eye
    return camera


def nearest_eye_within_reach(center: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """``center + s * offset`` for the largest ``s`` in ``[0, 1]`` whose coordinates are all within
    :data:`~wrt.floats.TRACED_REACH` (where the triangle test's differences from the eye stay in float32's range),
    ``center`` clipped to it taken for ``center`` where that is past it (float64, ``(3,)`` each)."""
    center = np.clip(center, -TRACED_REACH, TRACED_REACH)
    room = TRACED_REACH - np.sign(offset) * center  # how far each axis may move the way the offset points
    moving = offset != 0.0
    scale = min(1.0, float(np.min(room[moving] / np.abs(offset[moving]), initial=1.0)))
    return center + scale * offset
