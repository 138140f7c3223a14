"""Errors that wrt raises for bad input, so callers can tell them from bugs, and the checks that raise them."""

import dataclasses
import os
import sys

import numpy as np

from .wording import did_you_mean

_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep  # wrt's own files start with this


def bottom_row_problem(name: str, matrix) -> str | None:
    """Why ``matrix``, a column-vector ``(4, 4)`` transform of which only the top 3x4 is read, is refused, or None:
    a bottom row other than ``(0, 0, 0, 1)``. A ``Gf.Matrix4d`` passed untransposed has its translation there, which
    was dropped without a word (a camera, light or instance at the origin, turned the other way)."""
    bottom = np.asarray(matrix, np.float64)[3]
    if np.abs(bottom - (0.0, 0.0, 0.0, 1.0)).max() <= 1e-6:
        return None
    return (f"{name} has bottom row {bottom.tolist()}; it must be an affine column-vector transform, p_world = "
            "M @ (p, 1), with bottom row (0, 0, 0, 1) (the transpose of a Gf.Matrix4d)")


def not_a_file(path) -> str:
    """What ``path``, which exists and is no regular file, is instead, in the words of the errors that refuse it:
    ``a directory``, ``a pipe or socket`` (reading one waits for a writer, maybe forever) or ``a device``."""
    if os.path.isdir(path):
        return "a directory"
    import stat

    mode = os.stat(path).st_mode
    return "a pipe or socket" if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode) else "a device"


def with_bottom_row(matrix: np.ndarray) -> np.ndarray:
    """``matrix`` as a ``(4, 4)`` column-vector transform where it is its top ``(3, 4)`` (the affine part, as the
    device holds it): the row ``(0, 0, 0, 1)`` added; any other array as it is. Shapes and lights read a ``to_world``
    so; a light refused the ``(3, 4)`` that a shape takes."""
    if matrix.shape != (3, 4):
        return matrix
    return np.concatenate([matrix, np.array([[0.0, 0.0, 0.0, 1.0]], matrix.dtype)])


class SceneError(ValueError):
    """A scene file or its content cannot be used.

    The message always names the file and, where one is involved, the prim path,
    e.g. ``scene.usda: /World/Mesh: faceVertexIndices[12] = 40 is out of range (20 points)``.
    """

    def __init__(self, message: str, *, path: str | None = None, prim: str | None = None):
        self.path = path  # file the problem was found in, if any
        self.prim = prim  # prim path the problem was found at, if any
        self.message = message  # what is wrong, without the file and prim
        parts = [p for p in (path, prim) if p]
        super().__init__(": ".join(parts + [message]))


class TimeRangeWarning(UserWarning):
    """A time code outside the stage's authored ``[startTimeCode, endTimeCode]``: rendered all the same (USD holds
    the values of the nearest time samples), but often a typo. A category of its own, so a frame range warns once for
    all its frames (:func:`wrt.animation.warn_frames_outside_range`) instead of once per frame."""


def user_stacklevel() -> int:
    """The ``stacklevel`` that makes a ``warnings.warn`` called by the caller point at the first line outside wrt (the
    user's ``load_usd(...)``), however deep in wrt the warning is found: a fixed level pointed into wrt's own files
    for the warnings found one call deeper."""
    frame, level = sys._getframe(1), 1
    while frame is not None and (frame.f_code.co_filename.startswith(_PACKAGE) or _dataclass_init(frame)):
        frame, level = frame.f_back, level + 1
    return level


def warn_keyed(message: str, key) -> None:
    """``warnings.warn(message)`` at the user's line (a UserWarning), carrying ``key`` as ``said_once_key`` (None:
    none, as a plain warning): what a Renderer says the warning once by (``Renderer._warn_once``, the far-view
    warnings), its words naming a count or a distance that change from frame to frame. The worker processes of a
    frame run (``wrt render --devices``, ``--dask``) each say it once and send it back with the key, by which their
    parent says it once for all of them (:func:`wrt.animation.render_frame_task`): by its words, each worker's was
    said again."""
    import warnings

    warning = UserWarning(message)
    warning.said_once_key = key
    warnings.warn(warning, stacklevel=user_stacklevel())


def _dataclass_init(frame) -> bool:
    """Whether ``frame`` runs the ``__init__`` that ``dataclasses`` generated for one of wrt's classes (a warning of
    ``wrt.Mesh(...)``'s checks pointed at ``<string>:13``, that code's made-up file, not at the user's line)."""
    code = frame.f_code
    if code.co_name != "__init__" or code.co_filename != "<string>":
        return False
    owner = frame.f_locals.get("self")
    return owner is not None and type(owner).__module__.startswith("wrt.")


_FIELD_NAMES: dict = {}  # dataclass -> frozenset of its field names (stray_field)


def stray_field(obj, internal: tuple = ()) -> str:
    """``""``, or words naming the first attribute of the dataclass ``obj`` that is none of its fields (nor private,
    ``_name``, nor one of ``internal``) and the field meant: a dataclass keeps any attribute, so ``cam.fov = 30``,
    ``material.diffuseColor = ...`` (USD's spelling) or ``mesh.colours = ...`` was kept and read by nothing."""
    cls = type(obj)
    if cls not in _FIELD_NAMES:  # once per class: a mesh is checked at every construction (the loader's too)
        _FIELD_NAMES[cls] = frozenset(f.name for f in dataclasses.fields(cls))
    known = _FIELD_NAMES[cls]
    stray = [name for name in vars(obj) if name not in known and name[:1] != "_" and name not in internal]
    if not stray:
        return ""
    names = [f.name for f in dataclasses.fields(cls)]
    return (f"has no field {stray[0]!r}{did_you_mean(stray[0], names)} (set as an attribute, it is read by nothing); "
            f"its fields: {', '.join(names)}")


def prim_path(value, what: str, *, optional: bool = False) -> str:
    """``value`` as a prim path string: a ``str`` subclass (``np.str_``) or an ``Sdf.Path`` becomes a ``str``, and
    ``None`` an empty one where the path is ``optional`` (a light's). Anything else raises ``TypeError`` naming
    ``what``: an int, bytes or ``pathlib`` path was taken as a mesh's path, and hit paths, light links and messages
    then held that object (``[5]``), or joined it into a string and failed far from the mistake."""
    if type(value) is str:
        return value
    if isinstance(value, str) or (type(value).__name__ == "Path" and type(value).__module__ == "pxr.Sdf"):
        return str(value)
    if optional and value is None:
        return ""
    raise TypeError(f"{what}: path must be a str, a prim path such as '/World/Mesh', got {type(value).__name__} "
                    f"{value!r}")


def flag(value, what: str) -> bool:
    """``value`` as a ``bool``: a numpy bool (``mask[k]``) and the integers 0 and 1 mean what they say. Anything else
    raises ``TypeError`` naming ``what``: ``double_sided="no"`` (or "False", None, an array) was taken by its truth,
    making a mesh double-sided without a word."""
    if type(value) is bool:
        return value
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, (int, np.integer)) and value in (0, 1)):
        return bool(value)
    raise TypeError(f"{what} must be True or False, got {type(value).__name__} {value!r}")


def unit_vector(vector: np.ndarray, length: float) -> np.ndarray:
    """``vector / length`` (``length`` its norm), or ``vector`` itself where it is a unit vector already to rounding
    (a light's direction checked again before a render): a new array at each check made a kept
    :class:`wrt.Renderer` see a changed light, and build again."""
    return vector if abs(length - 1.0) <= 1e-12 else vector / length


def check_flags(obj, *names: str) -> None:
    """Makes fields ``names`` of a light built in Python bools, as :func:`flag` reads a mesh's ``double_sided``:
    ``normalize="false"`` (or "no", None, an array) was taken by its truth, normalizing the light without a word.
    Run after :func:`check_fields`, which makes ``obj.path`` a ``str``.

    Raises:
        TypeError: naming the prim, the type of ``obj`` and the field.
    """
    for name in names:
        value = getattr(obj, name)
        if type(value) is not bool:
            where = f"{obj.path}: " if obj.path else ""
            setattr(obj, name, flag(value, f"{where}{type(obj).__name__} {name}"))


def int32_problem(array: np.ndarray) -> str | None:
    """Why ``array``, ids or indices to be cast to int32, is refused, or None: numbers that are not whole (0.7 was cut
    to 0), or past int32 (2**32 wrapped round to 0), each then naming another material, prototype or face without a
    word; or no numbers at all. Whole floats (``np.zeros(N)``) are taken."""
    if array.dtype.kind not in "biuf":
        return f"must be integers, got dtype {array.dtype}"
    flat = array.reshape(-1)
    if array.dtype.kind == "f":
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(flat != np.round(flat))
        if len(bad):
            return f"must be integers; entry {int(bad[0])} is {flat[bad[0]].item()!r}"
    if array.dtype.kind == "b" or (array.dtype.kind in "iu" and np.can_cast(array.dtype, np.int32)):
        return None  # int32 and smaller (the loader's) need no look
    limits = np.iinfo(np.int32)
    if flat.size == 0 or limits.min <= flat.min() and flat.max() <= limits.max:  # (no index array made when it fits)
        return None
    bad = np.flatnonzero((flat < limits.min) | (flat > limits.max))
    return f"must fit in int32; entry {int(bad[0])} is {flat[bad[0]].item()!r}"


def eight_bit_colors(value) -> str | None:
    """Why colours ``value`` are refused, or None: integers above 1 (an ``(N, 3)`` ``uint8`` array of 0-255 from an
    image or point cloud), which were read as linear values up to 255 times too bright, without a word. Integers
    of 0 and 1 (``[(1, 0, 0)]``) mean what they say."""
    array = np.asarray(value)
    if array.dtype.kind not in "iu" or array.size == 0 or array.max() <= 1:
        return None
    return (f"colors must be linear float values, got {array.dtype} values up to {array.max().item()} (8-bit colours: "
            "divide by 255 and convert sRGB to linear)")


FLOAT32_ROUNDS_TO_INF = 2.0**128 - 2.0**103  # the smallest magnitude float32 rounds to infinity (max + half an ulp)


def check_fields(obj, *fields: tuple) -> None:
    """Checks and converts fields of a light or material built in Python, in its ``__post_init__``: NaN, inf or a
    negative size there rendered a black image without a word, and an array of a wrong shape failed deep in Warp.

    Args:
        obj: a dataclass with a ``path`` (the prim path, or empty).
        fields: ``(name, shape, minimum, dtype)`` each: field ``name`` must hold finite numbers of ``shape``, none
            below ``minimum`` (None: no bound); it is replaced by them as ``dtype`` (a plain float for shape ``()``).
            Finite means finite in float32 too, which is what the device reads.

    Raises:
        SceneError: naming the prim, the type of ``obj`` and the field.
    """
    path = prim_path(obj.path, f"wrt.{type(obj).__name__}", optional=True)
    if path is not obj.path:
        obj.path = path
    for name, shape, minimum, dtype in fields:
        value = getattr(obj, name)
        if shape == () and type(value) is float and abs(value) < FLOAT32_ROUNDS_TO_INF:
            # The common case without numpy's per-call cost (a sixth of reading a UsdLux light): a float that
            # stays finite in float32 (NaN compares False), kept as it is, as float(numbers) below keeps it.
            if minimum is None or value >= minimum:
                continue
        if type(value) is np.ndarray and value.shape == shape and value.dtype.kind == "f" and 0 < value.size <= 16:
            # A small float array (a light's position, colour, axis), likewise without numpy's checks: its values
            # as Python floats, each finite in float32 and not below the minimum, and the array as ``dtype``, as
            # the path below makes it (float32 and float64 both pass through float64 unchanged).
            values = value.tolist() if value.ndim == 1 else value.ravel().tolist()
            if all(abs(v) < FLOAT32_ROUNDS_TO_INF and (minimum is None or v >= minimum) for v in values):
                # The copy made at the first check is the object's own, kept when it is checked again (as a second
                # Renderer or wrt.render of the scene does): a copy at each check made a kept Renderer see a new
                # light, and build again. The caller's array (or a row of it) stays theirs. The record is an
                # attribute per field, not one dict: shallow copies (a PointInstancer's lamps) shared the dict, and
                # each lamp's check took another's entry, copying its arrays at every check again.
                key = f"_own_{name}"
                if obj.__dict__.get(key) is not value or value.dtype != dtype:
                    obj.__dict__[key] = value.astype(dtype)
                    setattr(obj, name, obj.__dict__[key])
                continue
        need = "a finite number" if shape == () else f"finite numbers of shape {shape}"
        need += " (or its top (3, 4))" if shape == (4, 4) else ""
        need += "" if minimum is None else f" >= {minimum:g}"
        from .ray_batch import host_array  # here, not at the top: it imports Warp

        try:
            # On a GPU (a CUDA wp.array, a torch tensor) copied to the host, as a mesh's arrays are: numpy refused the
            # first, naming no light, and read the second as no numbers.
            numbers = np.asarray(host_array(f"{type(obj).__name__} {name}", value))
        except ValueError:  # a ragged list, or an object DLPack cannot read either
            numbers = None
        if numbers is not None:  # None, strings and other objects are not numbers (None would read as NaN)
            numbers = numbers.astype(np.float64) if numbers.dtype.kind in "biuf" else None
        if numbers is not None and shape == (4, 4):  # a transform: its top (3, 4) as a shape's is read
            numbers = with_bottom_row(numbers)
        if numbers is not None and numbers.size == int(np.prod(shape)):
            numbers = numbers.reshape(shape)
            with np.errstate(over="ignore"):
                finite = np.all(np.isfinite(numbers.astype(np.float32)))
            if finite and (minimum is None or np.all(numbers >= minimum)):
                if shape == ():
                    setattr(obj, name, float(numbers))
                    continue
                # A new array, the object's own as the copy above is: kept by later checks, and by shallow copies
                # of the light (2**18 copies of one sun each copied its direction at its first check).
                obj.__dict__[f"_own_{name}"] = numbers.astype(dtype)
                setattr(obj, name, obj.__dict__[f"_own_{name}"])
                continue
            value = numbers.tolist()
        raise SceneError(f"{type(obj).__name__} {name} must be {need}, got {value!r}", prim=obj.path or None)
