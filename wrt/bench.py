"""Benchmark harness: scenes x accelerators x devices x ray kinds, timed side by side on the same rays.

One *row group* is (scene, device, ray kind): its rays are made once, then every accelerator in the grid traces
that same buffer in the same process, so ratios between rows are honest. Per row the harness records build time,
trace throughput (median, min and max over timed launches after a warm-up, device synchronised, kernel compilation
excluded), hit fraction, tree statistics where the accelerator exposes them (``wrt:`` rows: ``sah_cost``, ``nodes``,
``leaves``, ``node_bytes`` and ``bytes`` of the binary tree, ``layout_nodes`` and ``layout_bytes`` of the layout it
traces, as ``wrt bvh-stats --layout`` gives them), and agreement with ``warp:sah`` on the same rays. Rows go to a
JSON-lines file as soon as they are measured; a failing scene or accelerator becomes an error row and the run goes
on (a scene without triangles, or of zero-area ones only, too); ``resume`` skips rows already in the file, which
must have been measured with the same ray counts and repeats (recorded in ``settings.json`` beside it), and
measures again, with a warning, a row whose triangles and rays (hashed), device hardware, wrt code (a hash of its
source) or Warp version differ from this run's (``IDENTITY_FIELDS``).

Accelerator names: ``wrt:BUILDER`` (wrt's BVH; ``wrt:BUILDER:LAYOUT`` where layouts exist), ``warp:BUILDER``
(``wp.Mesh`` with that ``bvh_constructor``) and ``embree`` (Intel Embree through the ``embreex`` package, CPU only).
Scene names: a file path, ``warp:NAME`` (a USD file shipped with warp-lang), ``asset:ID`` (an entry of the shared
asset manifest, found through ``$WRT_ASSETS`` or ``../shared/assets``) or ``sphere:N`` (a procedural displaced
sphere of about N triangles). USD gprims are measured as triangle meshes (``tessellate_gprims=True``).
A ``sphere:N`` or a ray count too large for the host memory still available is refused with an error naming it
(``SPHERE_TRIANGLE_BYTES``, ``RAY_BYTES``), before anything is allocated.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import platform
import statistics
import sys
import time
import traceback
from pathlib import Path

import numpy as np
import warp as wp

from .bvh import Builder
from .bvh.common import device_name_hint, is_device_name
from .bvh.layout import check_layout
from .bvh.warp_mesh import check_warp_builder
from .compare import compare_hits, off_triangle
from .errors import SceneError, did_you_mean, flag, not_a_file
from .image import failed_write, write_atomically
from .rays import RAY_KINDS, ray_set, shadow_target
from .resources import check_host_memory
from .scene import Scene, has_area
from .strict_json import strict_json
from .trace import (
    WARP_BUILDERS,
    BvhAccelerator,
    HitBuffer,
    Hits,
    WarpMeshAccelerator,
    chunk_count,
    read_hits,
    resolve_device,
    usable_cores,
)
from .usd_stage import USD_SUFFIXES, missing_file  # scene files, which a suite name is not
from .wording import counted

SUITES_DIR = Path(__file__).resolve().parent / "suites"  # the named suites, shipped with the package
REFERENCE = "warp:sah"  # agreement and ratios are measured against this accelerator
ANY_HIT_KINDS = ("shadow",)  # ray kinds traced with the any-hit query
# Host memory bounds checked before a run allocates, about twice what was measured (peak RSS, CPU device): a
# sphere:1e6 scene with its SAH BVH4 traced, 394 bytes per triangle; 2M diffuse rays traced by two accelerators,
# 105 bytes per ray. Requests beyond the memory available get an error naming them instead of being killed midway.
SPHERE_TRIANGLE_BYTES = 800
RAY_BYTES = 400
MAX_REPEATS = 10_000  # timed launches per row


@dataclasses.dataclass
class Grid:
    """What to measure. Every field is a list; ``threads`` entries are ints or ``"all"``."""

    scenes: list
    accels: list
    devices: list = dataclasses.field(default_factory=lambda: ["cpu"])
    rays: list = dataclasses.field(default_factory=lambda: list(RAY_KINDS))
    n_rays: int = 1_000_000
    repeats: int = 10
    threads: list = dataclasses.field(default_factory=lambda: [1])
    scaling: dict | None = None  # {"sizes": [...], "accels": [...], "rays": kind, "n_rays": n}

    @classmethod
    def from_suite(cls, path, overrides: dict | None = None) -> Grid:
        """Reads a suite file (JSON); ``path`` may also name a file in ``wrt/suites`` without ``.json``. Its relative
        scene paths are read from its folder (:func:`_suite_scene_paths`).
        ``overrides`` (grid fields, as ``wrt bench --devices ...`` gives them) replace the suite's values before any
        is checked: a value overridden is never used, so a bad one in the file is not refused.

        Raises:
            ValueError: naming the file and, for a bad value, the key it sits at (``quick.json: accels[1]: ...``).
            GridError: a bad value of ``overrides``, naming its field (not the file).
        """
        overrides = overrides or {}
        path = suite_path(path)
        if path.suffix.lower() in USD_SUFFIXES:  # 'wrt bench scene.usd': it was 'not a JSON suite (Expecting ...)'
            raise ValueError(f"{path} is a scene, not a benchmark suite; measure it with --scenes {path}")
        if not path.exists():
            known = sorted(p.stem for p in SUITES_DIR.glob("*.json")) if SUITES_DIR.exists() else []
            raise FileNotFoundError(f"no benchmark suite {str(path)!r}{did_you_mean(path, known)}; suites in "
                                    f"{SUITES_DIR}: {', '.join(known) or 'none'}")
        if path.is_dir():  # it failed in Python's words, '[Errno 21] Is a directory', naming no suite
            raise IsADirectoryError(f"{path}: a directory, not a benchmark suite (a JSON file)")
        if not path.is_file():  # a named pipe: read_text() waited for a writer, forever; /dev/zero never ends
            raise ValueError(f"{path}: {not_a_file(path)}, not a benchmark suite (a JSON file)")
        try:
            # UTF-8 as JSON is (it was read in the locale's encoding), a byte order mark taken: Windows editors
            # (Notepad, PowerShell's Out-File) start a file with one, and it was 'Unexpected UTF-8 BOM'.
            data = json.loads(path.read_bytes().decode("utf-8-sig"))
        except json.JSONDecodeError as e:
            _refuse_wrt_output(path)
            raise ValueError(f"{path}: not a JSON suite ({e.msg} at line {e.lineno}, column {e.colno})") from None
        except UnicodeDecodeError as e:
            raise ValueError(f"{path}: not UTF-8 JSON text (byte {e.start} is no UTF-8), not a benchmark suite"
                             ) from None
        if not isinstance(data, dict):
            raise ValueError(f"{path.name}: a suite is a JSON object of grid fields, got {type(data).__name__}")
        keys = [f.name for f in dataclasses.fields(cls)] + ["description"]
        unknown = sorted(set(data) - set(keys))
        if unknown:  # a misspelt key would leave its field at the default without a word
            _refuse_wrt_output(path)
            raise ValueError(f"{path.name}: unknown suite keys {unknown}{did_you_mean(unknown[0], keys)}; valid: "
                             f"{', '.join(keys)}")
        required = [f.name for f in dataclasses.fields(cls)
                    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
        data = _whole_counts(data)
        if "scenes" in data and "scenes" not in overrides:  # --scenes are the command line's, read from the current
            data = dict(data, scenes=_suite_scene_paths(data["scenes"], path))  # folder; none: named missing below
        # The values overridden are dropped unchecked: a misspelt device of the suite was refused even when
        # --devices replaced them all.
        data = {**data, **overrides}
        if "devices" in overrides:  # the suite on other devices: what they build of what it gives
            data = _drop_unbuilt(data, path.name, accels="accels" not in overrides)
        missing = [name for name in required if name not in data]
        if missing:
            raise ValueError(f"{path.name}: missing suite keys {missing}")
        data.pop("description", None)
        try:
            return cls(**data).validated()
        except GridError as e:  # it named the value only ('unknown ray kind ...'), not where it sits in the file
            if e.field in overrides or e.also in overrides:  # not the file's alone: the caller names the option
                raise
            raise ValueError(f"{path.name}: {e.where()}") from None
        except ValueError as e:
            raise ValueError(f"{path.name}: {e}") from None
        except MemoryError as e:  # an n_rays past the memory
            if "n_rays" in overrides:  # --n-rays's, not the file's
                raise
            raise MemoryError(f"{path.name}: {e}") from None

    def __post_init__(self):
        # Checked when made, as a suite file is: Grid(devices=["CPU"]) or a misspelt accelerator or ray kind was
        # refused only when run_grid ran it. The fields may still be edited afterwards; run_grid checks them again.
        self._checked()

    def validated(self) -> Grid:
        """This grid with ``threads`` as ints (``"all"``: every core; repeats dropped), after checking every field.

        Raises:
            GridError: naming the field, for a list field that is not a list, a count that is not a positive
                integer, an unknown ray kind, device or accelerator, a ``sphere:N`` that is no size or a bad thread
                count. The same error is raised when a ``Grid`` is made.
        """
        threads, accels, scaling = self._checked()
        # Each name once (accelerators by their canonical names): a repeated scene, accelerator, device or ray kind
        # measured the same rows twice.
        unique = {name: list(dict.fromkeys(getattr(self, name))) for name in ("devices", "rays")}
        scenes = {}  # one scene in two spellings (sphere:100 and sphere:1e2, a.usda and ./a.usda) is one scene too
        for name in self.scenes:
            scenes.setdefault(_scene_key(name), name)
        return dataclasses.replace(self, threads=threads, accels=list(dict.fromkeys(accels)), scaling=scaling,
                                   scenes=list(scenes.values()), **unique)

    def _checked(self) -> tuple[list[int], list[str], dict | None]:
        """The thread counts of ``threads`` (each once), the accelerators' canonical names and ``scaling`` with its
        accelerators' canonical names, after checking every field (see :meth:`validated`)."""
        for name in ("scenes", "accels", "devices", "rays", "threads"):
            value = getattr(self, name)
            if not isinstance(value, (list, tuple)):
                raise GridError(name, f"{name} must be a list, got {value!r}")
        for name in ("scenes", "accels", "devices", "rays"):
            bad = [k for k, v in enumerate(getattr(self, name)) if not isinstance(v, str) or not v.strip()]
            if bad:  # a number or null would stop the whole run with a traceback
                raise GridError(name, f"{name} must be a list of names, got {getattr(self, name)[bad[0]]!r} in it",
                                bad[0])
        for name in ("n_rays", "repeats"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise GridError(name, f"{name} must be a positive integer, got {value!r}")
        if self.repeats > MAX_REPEATS:  # --repeats 100000000 timed launches for days, without a word
            raise GridError("repeats", f"repeats must be at most {MAX_REPEATS:,} (the median of more launches is no "
                            f"steadier), got {self.repeats:,}")
        check_host_memory(self.n_rays * RAY_BYTES, f"n_rays {self.n_rays}")
        for i, name in enumerate(self.devices):  # whether this machine has it is for run_grid (or a Dask worker)
            check_device_name(name, i)
        bad = [i for i, k in enumerate(self.rays) if k not in RAY_KINDS]
        if bad:
            kind = self.rays[bad[0]]
            raise GridError("rays", f"unknown ray kind {kind!r}{did_you_mean(kind, RAY_KINDS)}; valid ray kinds: "
                            f"{', '.join(RAY_KINDS)}", bad[0])
        accels = []
        for i, spec in enumerate(self.accels):  # misspelt here, every row of the accelerator became an error row
            try:
                accels.append(check_accel_spec(spec))
            except ValueError as e:
                raise GridError("accels", str(e), i) from None
        for i, name in enumerate(self.scenes):  # 'sphere:abc' became an error row per group, after the scenes before
            if name.startswith("sphere:"):
                try:
                    sphere_count(name)
                except ValueError as e:
                    raise GridError("scenes", str(e), i) from None
            kind, _, rest = name.partition(":")
            if kind in ("warp", "asset") and not rest.strip():  # an error row per group, 'warp:' as Warp's asset folder
                what = "NAME (a file of Warp's example assets)" if kind == "warp" else "ID (a shared asset's id)"
                raise GridError("scenes", f"{name!r} names no scene; give {kind}:{what}", i)
        if not self.threads:  # every CPU row was dropped: the run 'measured' nothing and exited 0
            raise GridError("threads", "threads must list at least one thread count")
        threads = []
        for i, t in enumerate(self.threads):
            count = (os.cpu_count() or 1) if str(t) == "all" else _positive_count(t)
            if count is None:
                meant = did_you_mean(t, ["all"]) if isinstance(t, str) else ""
                raise GridError("threads", f"threads must be positive integers or 'all', got {t!r}{meant}", i)
            if count not in threads:
                threads.append(count)
        scaling = self.scaling
        if self.scaling is not None:
            try:
                _check_scaling(self.scaling)
            except GridError:
                raise
            except ValueError as e:
                raise GridError("scaling", str(e)) from None
            if "accels" in self.scaling:  # named as the grid's are
                scaling = dict(self.scaling, accels=list(dict.fromkeys(map(check_accel_spec, self.scaling["accels"]))))
            # A sweep group is told from a scene group by its name: one name for both would measure the sweep size
            # with the grid's accelerators and ray count, unmarked, and the scene's group twice.
            both = [f"sphere:{int(float(n))}" for n in self.scaling.get("sizes", [])
                    if f"sphere:{int(float(n))}" in self.scenes]
            if both:
                raise GridError("scaling", f"scaling size {both[0].split(':')[1]} is also the scene {both[0]!r}; drop "
                                "one of them (a sweep row and a scene row of one name cannot be told apart)")
        _check_devices_build(accels, self.devices, "accels")
        if scaling is not None and "accels" in scaling:
            _check_devices_build(self.scaling["accels"], self.devices, "scaling.accels")
        sweep = scaling and scaling.get("sizes") and scaling.get("accels", accels)
        if not self.devices or not (self.scenes and self.rays and accels or sweep):
            empty = [name for name in ("scenes", "accels", "devices", "rays") if not getattr(self, name)]
            raise GridError(empty[0], f"the grid measures nothing: {', '.join(empty)} empty")
        return threads, accels, scaling


# Accelerators that devices of one kind cannot build: (that kind, why, what to do). Their rows on such a device
# failed after the scene had loaded and its rays were made, or, for warp:lbvh, would time the sah tree that Warp
# builds instead under lbvh's name.
DEVICE_LIMITS = {
    "warp:lbvh": ("cpu", "wp.Mesh has no lbvh builder on the CPU (Warp builds its sah tree there, which warp:sah "
                  "measures)", "add a CUDA device, or measure warp:sah"),
    "embree": ("cuda", "Embree runs on the CPU only", "add the cpu device"),
}


def cannot_build(spec: str, device_name: str) -> str | None:
    """Why accelerator ``spec`` (canonical, :func:`check_accel_spec`) has no row on the device named
    ``device_name`` (``cpu``, ``cuda``, ``cuda:N``), or None where it has one."""
    kind, why, _ = DEVICE_LIMITS.get(spec, (None, None, None))
    return why if kind is not None and device_name.partition(":")[0] == kind else None


def _check_devices_build(accels: list, devices: list, field: str) -> None:
    """Raises GridError for an accelerator of ``accels`` that no device of ``devices`` builds (``warp:lbvh`` with the
    cpu alone): refused before any scene loads, naming the accelerator and the devices."""
    for i, spec in enumerate(accels):
        spec = check_accel_spec(spec)
        if devices and all(cannot_build(spec, name) for name in devices):
            raise GridError(field, f"accelerator {spec!r} with devices {', '.join(devices)}: "
                            f"{cannot_build(spec, devices[0])}; {DEVICE_LIMITS[spec][2]}", i, also="devices")


def _drop_unbuilt(data: dict, suite: str, accels: bool = True) -> dict:
    """``data`` (a suite's fields, its devices given in their place) without the suite's accelerators that none of
    those devices builds, each named in a warning: wrt bench gpu --devices cpu measures the gpu suite's other
    accelerators on the CPU, as it did, not its warp:lbvh rows, which failed one by one. ``accels`` False: the
    accelerators were given in the suite's place (--accels), so only its scaling sweep's are the suite's to drop
    (--accels wrt:sah with --devices cpu refused the gpu suite's scaling warp:lbvh)."""
    import warnings

    devices = data.get("devices")
    if not isinstance(devices, list) or not devices or not all(isinstance(d, str) for d in devices):
        return data  # refused as it is by the checks

    def kept(accels, key):
        if not isinstance(accels, list):
            return accels
        left = []
        for spec in accels:
            try:
                reasons = {cannot_build(check_accel_spec(spec), name) for name in devices}
            except (TypeError, ValueError, AttributeError):  # refused by the checks, naming its key
                reasons = {None}
            why = None if None in reasons else reasons.pop()  # why, where no device builds it
            if why:
                warnings.warn(f"{suite}'s {key} {spec} left out on devices {', '.join(devices)}: {why}", stacklevel=4)
            else:
                left.append(spec)
        return left

    if accels:
        data = dict(data, accels=kept(data.get("accels"), "accelerator"))
    if isinstance(data.get("scaling"), dict) and "accels" in data["scaling"]:
        data["scaling"] = dict(data["scaling"], accels=kept(data["scaling"]["accels"], "scaling accelerator"))
    return data


def _whole_count(value):
    """A count a suite writes as a whole number in float form (``1e6``, ``1000.0``: JSON reads both as floats) as the
    int it is, as ``--n-rays 1e6`` reads; anything else as it is, for the checks to refuse (``1000.5`` included)."""
    if isinstance(value, float) and math.isfinite(value) and value == int(value):
        return int(value)
    return value


def _whole_counts(data: dict) -> dict:
    """A suite's ``n_rays``, ``repeats``, each ``threads`` entry and ``scaling.n_rays`` through :func:`_whole_count`
    (its scaling sizes take a whole float already): ``"n_rays": 1e3`` was refused, 'got 1000.0', where ``--n-rays 1e3``
    was taken, and ``"threads": [2.0]`` 'must be positive integers', though README takes a count written so."""
    data = {**data, **{key: _whole_count(data[key]) for key in ("n_rays", "repeats") if key in data}}
    if isinstance(data.get("threads"), list):
        data["threads"] = [_whole_count(t) for t in data["threads"]]
    if isinstance(data.get("scaling"), dict) and "n_rays" in data["scaling"]:
        data["scaling"] = {**data["scaling"], "n_rays": _whole_count(data["scaling"]["n_rays"])}
    return data


def _suite_scene_paths(scenes, suite: Path):
    """The ``scenes`` of the suite file ``suite``, with each relative file path read from the suite's folder, as other
    tools read paths in their files (a path beside it was read from the current folder, so a suite ran from one folder
    only). A path found from the current folder alone, not beside the suite, is kept, with a warning: suites written
    for the old rule still run. Scene kinds (``sphere:N``, ``warp:NAME``, ``asset:ID``, a misspelt kind) and absolute
    paths are kept; anything not a list of names is left for the checks to refuse.

    A path starting with ``~`` is in the user's home folder, as a shell reads it (it was a folder named ``~`` beside
    the suite). A suite given through a symbolic link is read from the folder of the file the link names, where its
    paths were written (they were read from the link's folder, so a suite linked elsewhere lost its scenes); a
    folder linked on the way needs nothing: the file system follows it, ``..`` included."""
    if not isinstance(scenes, list):
        return scenes
    folder = Path(os.path.realpath(suite)).parent if suite.is_symlink() else suite.parent
    read = []
    for name in scenes:
        if isinstance(name, str) and name.startswith("~"):
            name = os.path.expanduser(name)  # ~user that names no user stays as it is, and is read as below
        if not isinstance(name, str) or not name.strip() or Path(name).is_absolute() or folder == Path("."):
            read.append(name)
            continue
        beside = folder / name
        kind, colon, _ = name.partition(":")
        if colon and len(kind) > 1 and kind.isalpha() and not beside.exists():  # a scene kind, as resolve_scene tells
            read.append(name)
        elif not beside.exists() and Path(name).exists():
            import warnings

            warnings.warn(f"{suite.name}: scene {name!r} is not beside the suite ({beside}) but is in the current "
                          "folder, where it is read from; relative scene paths in a suite are read from its folder: "
                          "write it relative to that, or absolute", stacklevel=4)
            read.append(name)
        else:
            read.append(str(beside))
    return read


def check_device_name(name: str, index: int | None = None) -> None:
    """Raises GridError naming ``name`` (entry ``index`` of ``devices``) unless it is a Warp device name, with the
    one meant: ``'CPU'``, ``'Cuda:0'``, ``'gpu'`` (Warp's names are lowercase; ``wp.get_device('CPU')`` fails)."""
    if isinstance(name, str) and is_device_name(name):
        return
    raise GridError("devices", f"unknown device {name!r}{device_name_hint(name)}; devices are cpu, cuda and cuda:N",
                    index)


class GridError(ValueError):
    """A bad field of a :class:`Grid`: ``field`` names it, so that ``wrt bench`` can name the option that set it, and
    ``index`` the entry of a list field (or of ``scaling``'s) that is bad, so that a suite's error names its key."""

    def __init__(self, field: str, message: str, index: int | None = None, also: str | None = None):
        super().__init__(message)
        self.field = field  # the Grid field: "scenes", "accels", ..., or "scaling.accels" for a key of scaling
        self.index = index  # the bad entry of a list, or None
        self.also = also  # the other field of a bad pair ("devices" for an accelerator none of them builds), or None

    def where(self) -> str:
        """The message led by the key it is about, as a suite file spells it: ``accels[1]: accelerator ...``
        (the field's name dropped from the start of the message: ``threads: must list ...``)."""
        key = self.field + ("" if self.index is None else f"[{self.index}]")
        message = str(self)
        for prefix in (f"{self.field.replace('.', ' ')} ", f"{self.field} "):
            message = message.removeprefix(prefix)
        return f"{key}: {message}"


def suite_path(path) -> Path:
    """The file a suite name gives: ``path`` itself, or the file of that name in ``wrt/suites`` (``quick``) where no
    file has that name: a folder of that name (``wrt bench --quick -o quick``, ``-o cpu``) is no suite, and ``wrt
    bench cpu`` run beside one was refused as 'cpu: a directory, not a benchmark suite'."""
    path = Path(path)
    if (not path.exists() or path.is_dir()) and (SUITES_DIR / f"{path}.json").exists():
        return SUITES_DIR / f"{path}.json"
    return path


ACCEL_KINDS = ("wrt", "warp", "embree")  # what an accelerator name starts with


def check_accel_spec(spec: str) -> str:
    """The canonical name of accelerator ``spec`` (``wrt`` -> ``wrt:sah``, ``wrt:sah:binary`` and ``wrt:binned_sah``
    -> ``wrt:sah``, ``warp`` -> ``warp:sah``): rows are named, compared with :data:`REFERENCE`, deduplicated and
    resumed by it. Two spellings of one accelerator were measured twice, and ``warp`` was not taken for the
    reference, so no row of its group was checked. Raises ValueError naming ``spec`` unless it is
    ``wrt[:BUILDER[:LAYOUT]]``, ``warp[:BUILDER]`` or ``embree`` with known names."""
    kind, _, rest = spec.partition(":")
    builder, _, layout = rest.partition(":")
    try:
        _check_no_empty_part(spec)
        if kind == "wrt":
            builder = Builder.from_str(builder or "sah").value
            layout = check_layout(layout or "binary")
            return f"wrt:{builder}" + ("" if layout == "binary" else f":{layout}")
        elif kind == "warp":
            builder = builder or "sah"
            if builder not in WARP_BUILDERS:
                raise ValueError(f"wp.Mesh has no builder {builder!r}{did_you_mean(builder, WARP_BUILDERS)}; its "
                                 f"builders are {', '.join(WARP_BUILDERS)}")
            if layout:
                raise ValueError(f"wp.Mesh has no layouts; use warp:{builder}")
            return f"warp:{builder}"
        elif kind != "embree":
            raise ValueError(f"unknown accelerator kind {kind!r}{did_you_mean(kind, ACCEL_KINDS)}; accelerators are "
                             "wrt:BUILDER[:LAYOUT], warp:BUILDER or embree")
        elif rest:
            raise ValueError("embree takes no builder or layout")
    except ValueError as e:
        raise ValueError(f"accelerator {spec!r}: {e}") from None
    return "embree"


def _check_no_empty_part(spec: str) -> None:
    """Raises ValueError naming the empty part of ``spec`` (``wrt:sah:``, ``warp:``, ``wrt::wide8``), with the name
    meant: an empty builder or layout was read as the default one, so a name cut short measured another tree."""
    parts = spec.split(":")
    if parts[0] not in ACCEL_KINDS or all(parts[1:]):  # an unknown kind is named as such
        return
    kind = parts[0]
    empty = next(i for i, part in enumerate(parts) if i and not part)
    what = {"wrt": ("builder", "layout"), "warp": ("builder",)}.get(kind, ())
    named = what[empty - 1] if empty - 1 < len(what) else "part"
    defaults = {"wrt": ["sah", "binary"], "warp": ["sah"]}.get(kind, [])
    filled = [part or default for part, default in zip(parts[1:], defaults)]
    meant = ":".join([kind, *filled]).removesuffix(":binary")
    raise ValueError(f"the {named} after ':' is empty (did you mean {meant!r}?); accelerators are "
                     "wrt:BUILDER[:LAYOUT], warp:BUILDER or embree")


SCALING_KEYS = ("sizes", "accels", "rays", "n_rays")  # the fields of Grid.scaling


def _check_scaling(scaling) -> None:
    """Raises ValueError naming the key of a bad ``Grid.scaling``: a misspelt key would drop the sweep silently."""
    if not isinstance(scaling, dict):
        raise ValueError(f"scaling must be an object, got {scaling!r}")
    unknown = sorted(set(scaling) - set(SCALING_KEYS))
    if unknown:
        raise ValueError(f"unknown scaling keys {unknown}{did_you_mean(unknown[0], SCALING_KEYS)}; valid: "
                         f"{', '.join(SCALING_KEYS)}")
    sizes = scaling.get("sizes", [])
    if not isinstance(sizes, (list, tuple)) or not all(
        # As sphere_count reads a sphere:N scene: 1000.5 was cut to sphere:1000, and 5 failed as sphere:5 at the run
        isinstance(n, (int, float)) and not isinstance(n, bool) and math.isfinite(n) and n >= 8 and n == int(n)
        for n in sizes
    ):
        raise GridError("scaling.sizes", f"scaling sizes must be a list of triangle counts, whole numbers of 8 or "
                        f"more, got {sizes!r}")
    accels = scaling.get("accels", [])
    if not isinstance(accels, (list, tuple)) or not all(isinstance(a, str) and a.strip() for a in accels):
        raise GridError("scaling.accels", f"scaling accels must be a list of names, got {accels!r}")
    for i, spec in enumerate(accels):  # misspelt, it failed as an error row at every size of the sweep
        try:
            check_accel_spec(spec)
        except ValueError as e:
            raise GridError("scaling.accels", str(e), i) from None
    kind = scaling.get("rays", "incoherent")
    if kind not in RAY_KINDS:
        raise GridError("scaling.rays", f"unknown scaling ray kind {kind!r}{did_you_mean(kind, RAY_KINDS)}; valid "
                        f"ray kinds: {', '.join(RAY_KINDS)}")
    n_rays = scaling.get("n_rays", 1)
    if isinstance(n_rays, bool) or not isinstance(n_rays, int) or n_rays < 1:
        raise GridError("scaling.n_rays", f"scaling n_rays must be a positive integer, got {n_rays!r}")
    check_host_memory(n_rays * RAY_BYTES, f"scaling n_rays {n_rays}")


def _positive_count(value) -> int | None:
    """``value`` as a positive int (from an int, or a string writing a whole number as every integer option reads
    one: ``--threads 2.0`` was refused where a suite's ``"threads": [2.0]`` was taken), else None."""
    if isinstance(value, str):
        from .cli import whole_number

        try:
            value = whole_number(value.strip())
        except OverflowError:  # past 1e300: no thread count
            return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        return None
    return int(value) if value >= 1 else None


def hardware(device) -> dict:
    """CPU model, GPU name and driver, Warp version: printed with every table."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    from . import __version__

    info = {"cpu": cpu, "cpu_cores": os.cpu_count(), "warp": wp.config.version, "wrt": __version__,
            "wrt_source": source_digest(), "gpu": None, "driver": None}
    dev = wp.get_device(device)
    if dev.is_cuda:
        info["gpu"] = dev.name
        driver = wp.get_cuda_driver_version()  # (major, minor) of the CUDA driver API, e.g. (13, 0)
        info["driver"] = "CUDA " + ".".join(map(str, driver)) if isinstance(driver, (tuple, list)) else str(driver)
        info["gpu_driver"] = _nvidia_driver()
    return info


@functools.cache
def source_digest() -> str:
    """A short hash of wrt's own Python files: the version string stays 0.1.0 while the code under it changes, and
    a row measured with other code must not be resumed as this code's."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parent
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:12]


def _nvidia_driver() -> str | None:
    """The NVIDIA kernel driver version, from nvidia-smi, if it is there."""
    import subprocess

    try:
        out = subprocess.run(
            ["nvidia-smi", "--query-gpu=driver_version", "--format=csv,noheader"], capture_output=True, text=True,
            timeout=20
        )
        return out.stdout.strip().splitlines()[0] if out.returncode == 0 and out.stdout.strip() else None
    except (OSError, subprocess.SubprocessError):
        return None


SCENE_KINDS = ("sphere", "warp", "asset")  # the prefixes of scene names that are no file paths


def resolve_scene(name: str) -> Scene:
    """Loads a scene named as in the module docstring. Gprims (spheres, cubes, ...) are loaded as triangle meshes:
    wp.Mesh and Embree trace triangles only, so every accelerator of a row group then traces the same geometry."""
    from functools import partial

    from .usd import load_usd

    load_usd = partial(load_usd, tessellate_gprims=True)
    if name.startswith("sphere:"):
        from .procedural import displaced_sphere_scene

        return displaced_sphere_scene(sphere_triangles(name))
    if name.startswith("warp:"):
        import warp.examples

        folder, file = Path(warp.examples.get_asset_directory()), name.split(":", 1)[1]
        if not (folder / file).is_file():  # 'warp:bunny' named Warp's folder path alone, not the bunny.usd meant
            examples = sorted(p.name for p in folder.iterdir() if p.suffix.lower() in USD_SUFFIXES)
            raise SceneError(f"no file {file!r} among Warp's example assets{did_you_mean(file, examples)}; its USD "
                             f"files: {', '.join(examples)}", path=name)
        return load_usd(folder / file)
    if name.startswith("asset:"):
        return load_usd(asset_path(name.split(":", 1)[1]))
    kind = name.split(":", 1)[0]
    if ":" in name and len(kind) > 1 and kind.isalpha() and not Path(name).exists():
        # A misspelt kind ('sphree:1000') was reported as a missing file only. A file name may hold a colon, and a
        # one-letter kind is a Windows drive.
        raise SceneError(f"no such file, and {kind!r} is no scene kind{did_you_mean(kind, SCENE_KINDS)}; scenes are "
                         "USD paths, warp:NAME, asset:ID or sphere:N", path=name)
    return load_usd(name)


def scene_file_problem(name: str) -> str | None:
    """What keeps the file of scene ``name`` from loading, found without loading it: missing, no file, unreadable or
    not USD by its extension. None for ``sphere:N`` and for a file that may load (one broken inside fails only when
    :func:`resolve_scene` loads it)."""
    if name.startswith("sphere:"):
        return None
    try:
        if name.startswith("warp:"):
            import warp.examples

            path = Path(warp.examples.get_asset_directory()) / name.split(":", 1)[1]
        elif name.startswith("asset:"):
            path = asset_path(name.split(":", 1)[1])
        else:
            path = Path(name)
    except (ValueError, OSError) as e:  # an unknown asset id, or no shared asset folder
        return str(e)
    if not path.exists():
        return missing_file(path)
    if not path.is_file():
        return f"{'a directory' if path.is_dir() else 'a pipe or device'}, not a USD file"
    if not os.access(path, os.R_OK):
        return "not readable (permission denied)"
    if path.suffix.lower() not in USD_SUFFIXES:
        return f"not a USD file by its extension: USD reads {', '.join(USD_SUFFIXES)}"
    return None


def _warn_scene_files(grid: Grid) -> None:
    """Warns at the start, naming each, about the grid's scenes whose files cannot load (:func:`scene_file_problem`):
    a misspelt path was found only when the run reached its scene, maybe an hour in. A warning, not a refusal: the
    other scenes are still measured, and each of these becomes an error row, as before."""
    problems = [f"{name} ({why})" for name in grid.scenes if (why := scene_file_problem(name))]
    if problems:
        import warnings

        they = "it is reached" if len(problems) == 1 else "each is reached"
        warnings.warn(f"{counted(len(problems), 'scene')} will be an error row when {they}: {'; '.join(problems)}",
                      stacklevel=3)


def _scene_key(name: str, cwd: str | None = None) -> str:
    """What a scene name measures: ``sphere:N`` by its triangle count, a file that exists by its resolved path, a
    relative one read from ``cwd`` (the folder a row's run started in; None: the current folder)."""
    if name.startswith("sphere:"):
        return f"sphere:{sphere_count(name)}"
    path = Path(cwd or ".") / name  # an absolute name stays itself
    return str(path.resolve()) if path.exists() else name


def _row_scene_key(row: dict) -> str:
    """:func:`_scene_key` of a row's scene, read from the folder its run started in (``cwd``; rows of runs before
    that field, or whose folder is gone: the current folder), as a render log's rows are: a ``--resume`` from another
    folder measured every scene of a relative path again (a suite's ``bench/a.usda`` is ``a.usda`` from ``bench/``).
    A row's triangles and rays (``inputs``) tell whether the file read from the current folder is the one measured."""
    cwd = row.get("cwd")
    if isinstance(cwd, str) and not os.path.isdir(cwd):  # gone (the project moved): read as rows before the field
        cwd = None
    return _scene_key(row["scene"], cwd)


def sphere_triangles(name: str) -> int:
    """The triangle count ``N`` of a ``sphere:N`` scene name (``1e6`` and ``1000000`` alike), after checking that
    the mesh and its BVH fit in the host memory available."""
    count = sphere_count(name)
    check_host_memory(count * SPHERE_TRIANGLE_BYTES, name)
    return count


def sphere_count(name: str) -> int:
    """The triangle count ``N`` of a ``sphere:N`` scene name; ValueError naming it unless ``N`` is a whole number,
    8 or more (the memory it needs is checked when it is made, on the machine that makes it)."""
    from .cli import whole_number

    text = name.split(":", 1)[1]
    try:
        count = whole_number(text)  # exactly: float() took 1.00000000000000001e3 for 1000
    except OverflowError:
        raise ValueError(f"{name}: N = {text} triangles is past 1e300; no host holds that many (e.g. sphere:1e6)") \
            from None
    if count is None or count < 8:
        raise ValueError(f"{name}: N must be a whole number of triangles, 8 or more (e.g. sphere:1e6), got {text!r}")
    return count


_warned_asset_folders = set()  # WRT_ASSETS folders without a manifest already warned about: once a run, not per asset


def asset_path(asset_id: str) -> Path:
    """Path of a shared asset by manifest id."""
    candidates = [Path(os.environ["WRT_ASSETS"])] if os.environ.get("WRT_ASSETS") else []
    candidates += [Path.cwd().parent / "shared" / "assets", Path(__file__).resolve().parents[2] / "shared" / "assets"]
    candidates = list(dict.fromkeys(candidates))  # run from the repository's root, the last two are one folder
    for k, root in enumerate(candidates):
        manifest = root / "manifest.json"
        if manifest.is_file():
            given = candidates[0] if k and os.environ.get("WRT_ASSETS") else None
            if given is not None and given not in _warned_asset_folders:  # a typo read another folder without a word
                import warnings

                _warned_asset_folders.add(given)
                warnings.warn(f"WRT_ASSETS={given} holds no manifest.json; the shared assets are read from {root}",
                              stacklevel=2)
            entries = manifest_entries(manifest)
            if asset_id not in entries:  # 42 ids in the shared manifest: the one meant, not all of them
                raise ValueError(f"no asset {asset_id!r}{did_you_mean(asset_id, entries)} in {manifest}")
            return root / entries[asset_id]
    # Each folder looked in, WRT_ASSETS's named as such: 'set WRT_ASSETS' was all it said, also where it was set to a
    # folder without the manifest (a typo, or the repository's folder above the assets).
    looked = [f"{root} (WRT_ASSETS)" if k == 0 and os.environ.get("WRT_ASSETS") else str(root)
              for k, root in enumerate(candidates)]
    raise FileNotFoundError(f"asset {asset_id!r}: no shared asset folder found: no manifest.json in "
                            f"{', '.join(looked)}; set WRT_ASSETS to the folder that holds it")


def manifest_entries(manifest: Path) -> dict[str, str]:
    """``{id: path}`` of the asset manifest ``manifest`` (``{"assets": [{"id": ..., "path": ...}, ...]}``).

    Raises:
        ValueError: naming the file and what is wrong with it: not UTF-8 JSON, no ``assets`` list, an entry without
            a text ``id`` or ``path`` (Python's words, 'Expecting value: line 1 column 1 (char 0)' or a KeyError
            'assets', named no file).
    """
    try:
        data = json.loads(manifest.read_bytes().decode("utf-8-sig"))  # a byte order mark taken, as in a suite
    except json.JSONDecodeError as e:
        raise ValueError(f"{manifest}: not a JSON manifest ({e.msg} at line {e.lineno}, column {e.colno})") from None
    except UnicodeDecodeError as e:
        raise ValueError(f"{manifest}: not UTF-8 JSON text (byte {e.start} is no UTF-8)") from None
    assets = data.get("assets") if isinstance(data, dict) else None
    if not isinstance(assets, list):
        raise ValueError(f'{manifest}: must be a JSON object with an "assets" list of {{"id": ..., "path": ...}} '
                         "entries")
    for k, entry in enumerate(assets):
        if not (isinstance(entry, dict) and all(isinstance(entry.get(key), str) for key in ("id", "path"))):
            raise ValueError(f'{manifest}: assets[{k}] must be an object with text "id" and "path", got '
                             f"{json.dumps(entry)[:80]}")
    return {entry["id"]: entry["path"] for entry in assets}


class _Subject:
    """One accelerator prepared for timing: ``run()`` traces the prepared rays once, synchronously."""

    def __init__(self, spec: str, scene: Scene, device, threads: int):
        self.spec, self.device, self.threads, self.scene = spec, device, threads, scene
        kind, _, rest = spec.partition(":")
        self.stats = {}
        if kind == "embree":
            if not device.is_cpu:
                raise ValueError("embree runs on the CPU only")
            try:
                from embreex import rtcore_scene
                from embreex.mesh_construction import TriangleMesh
            except ImportError as e:
                raise ImportError("embree needs the optional package embreex: pip install 'wrt[bench]'") from e
            points, indices = scene.triangles()
            start = time.perf_counter()
            self.embree = rtcore_scene.EmbreeScene()
            TriangleMesh(self.embree, points, indices)
            self.embree.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))  # Embree builds lazily
            self.build_seconds = time.perf_counter() - start
        elif kind in ("wrt", "warp"):
            builder, _, layout = rest.partition(":")
            builder = builder or "sah"

            def build(target: Scene):
                if kind == "wrt":
                    return BvhAccelerator(target, Builder.from_str(builder).value, device, layout or "binary")
                if layout:
                    raise ValueError(f"{spec}: wp.Mesh has no layouts")
                check_warp_builder(builder, device)  # a warp:lbvh row on the CPU would time wp.Mesh(sah)
                return WarpMeshAccelerator(target, builder, device)

            build(Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]] * 3, np.arange(9).reshape(3, 3)))  # compile
            wp.synchronize_device(device)
            start = time.perf_counter()
            self.accel = build(scene)  # built directly, never from the scene's cache: every row times a real build
            wp.synchronize_device(device)
            self.build_seconds = time.perf_counter() - start
            bvh = getattr(self.accel, "bvh", None)
            if bvh is not None and hasattr(bvh, "stats"):
                stats = bvh.stats(epo_samples=0)
                self.stats = {k: stats[k] for k in ("sah_cost", "node_bytes", "bytes", "nodes", "leaves") if k in stats}
                # Those are the binary tree's; a compact or wide row traces a conversion of it, of other size (as
                # wrt bvh-stats --layout reports it).
                nodes, size = self.accel.layout_size
                self.stats.update(layout=self.accel.layout, layout_nodes=nodes, layout_bytes=size)
        else:
            raise ValueError(f"unknown accelerator {spec!r}; use wrt:BUILDER[:LAYOUT], warp:BUILDER or embree")

    def prepare(self, origins: np.ndarray, directions: np.ndarray, any_hit: bool):
        self.any_hit, n = any_hit, len(origins)
        if hasattr(self, "embree"):
            self.host = (origins, directions)
            return
        dev = self.device
        self.rays = [
            wp.array(origins, dtype=wp.vec3, device=dev),
            wp.array(directions, dtype=wp.vec3, device=dev),
            wp.zeros(n, dtype=float, device=dev),
            wp.full(n, np.inf, dtype=float, device=dev),
        ]
        self.hits = HitBuffer(n, dev)
        self.blocked = wp.zeros(n, dtype=wp.int32, device=dev)

    def run(self):
        if hasattr(self, "embree"):
            query = "OCCLUDED" if self.any_hit else "INTERSECT"
            self.result = self.embree.run(*self.host, query=query, output=None if self.any_hit else 1)
            return
        if self.any_hit:
            self.accel.occluded(*self.rays, self.blocked, threads=self.threads)
        else:
            self.accel.intersect(*self.rays, self.hits, threads=self.threads, costs=False)  # as renders trace bounces
        wp.synchronize_device(self.device)

    def answer(self):
        """``Hits`` (closest hit) or a bool array (any hit) of the last run, on the host."""
        if hasattr(self, "embree"):
            if self.any_hit:
                return np.asarray(self.result) == 0  # embreex: 0 = occluded, -1 = not
            r = self.result
            prim = r["primID"].astype(np.int32)
            t = np.where(prim >= 0, r["tfar"], np.inf).astype(np.float32)
            zeros = np.zeros_like(prim)
            return Hits(t, r["u"], r["v"], prim, zeros, zeros)
        if self.any_hit:
            return self.blocked.numpy().astype(bool)
        # The hits of the last timed launch, as it left them: traced again with the kernels that count costs (which
        # no row reports), the answer checked was another kernel's than the one timed. Read as wrt.trace reads them:
        # prims as rows of Scene.triangles(), as Embree's are (the buffer holds an instance's prototype triangles).
        hits = read_hits(self.scene, self.hits)
        return dataclasses.replace(hits, t=hits.t.copy(), u=hits.u.copy(), v=hits.v.copy(), prim=hits.prim.copy())


def _has_embree() -> bool:
    try:
        import embreex  # noqa: F401
    except ImportError:
        return False
    return True


def time_runs(run, repeats: int) -> list[float]:
    """Wall seconds of ``repeats`` synchronous runs after one warm-up run."""
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return times


ROW_KEY_FIELDS = ("scene", "accel", "device", "rays", "threads")  # what identifies a row


def row_key(row: dict) -> tuple:
    """What identifies a row, for ``resume``."""
    return tuple(row[name] for name in ROW_KEY_FIELDS)


# What a row was measured on, beyond its key: ``resume`` keeps a row only when all of these are the same now. ``inputs``
# hashes the triangles and rays traced (a changed scene file or a layer it references, another camera, ray count or
# ray generation); ``repeats`` is the timed launches its median is of (settings.json says it for the whole file, and
# a resume without that file kept rows of other repeats as this run's); the rest is hardware() of the row's device.
IDENTITY_FIELDS = ("inputs", "repeats", "wrt", "wrt_source", "warp", "cpu", "cpu_cores", "gpu", "driver", "gpu_driver")


def identity_changes(before: dict, now: dict) -> list[str]:
    """What differs between the identities of two rows of one key, in words (empty when they match)."""
    changes = []
    for name in IDENTITY_FIELDS:
        if before.get(name) != now.get(name):
            changes.append("its triangles or rays changed" if name == "inputs" else
                           f"{name} {before.get(name)} -> {now.get(name)}")
    return changes


def _resumed_row_stands(before: dict | None, now: dict, checkable: bool) -> bool:
    """Whether ``before``, a resumed row of the key of ``now`` (a row about to be measured, with its hardware),
    stands for it, so that ``resume`` skips ``now``: measured on what ``now`` would be (:func:`identity_changes`),
    and checked against :data:`REFERENCE` unless ``now``'s group has no answer of it either (``checkable`` False):
    kept unchecked, it read 'no warp:sah answer in the group' beside the group's warp:sah row."""
    return (before is not None and not identity_changes(before, now)
            and (before.get("agreement") is not None or now["accel"] == REFERENCE or not checkable))


def inputs_digest(*arrays: np.ndarray) -> str:
    """A short hash of the bytes of ``arrays`` (the triangles and rays of a row group)."""
    import hashlib

    digest = hashlib.blake2b(digest_size=8)
    for array in arrays:
        array = np.ascontiguousarray(array)
        digest.update(f"{array.dtype.str}{array.shape}".encode())
        digest.update(array.data)
    return digest.hexdigest()


def _agreement(answer, reference, triangles, origins, directions, scale) -> dict:
    """``agreement`` (fraction of rays answered as ``reference`` answers them) and ``disagreements`` (rays answered
    otherwise, edge ties of closest hits left out: see :mod:`wrt.compare`; ``triangles``: ``(points, indices)``)."""
    if reference is None:
        return {"agreement": None}
    if isinstance(answer, np.ndarray):  # any hit: blocked or not
        return {"agreement": float(np.mean(answer == reference)), "disagreements": int(np.sum(answer != reference))}
    # A hit off its own triangle is no tie, whatever barycentrics it reports (u = v = 0, a vertex, made any wrong
    # hit one).
    wrong = (off_triangle(answer, *triangles, origins, directions, scale)
             | off_triangle(reference, *triangles, origins, directions, scale))
    found = compare_hits(answer, reference, directions=directions, scale=scale, wrong=wrong)
    return {"agreement": found["agreement"], "disagreements": found["disagreements"]}


def measure_group(scene_name, scene, device, kind, grid: Grid, accels, thread_counts, emit, skip) -> None:
    """Measures every (accel, threads) row of one (scene, device, ray kind) group and hands each row to ``emit``,
    but for those ``skip(row, checkable)`` says a resumed row stands for (``checkable``: whether the group measures
    :data:`REFERENCE`; see :func:`_resumed_row_stands`)."""
    triangles = scene.stats()["rendered_triangles"]
    if not triangles:  # rows of an empty stage timed rays that meet nothing: 0 % hits, 100 % agreement, any Mrays/s
        raise ValueError("the scene has no triangles to trace (no meshes, gprims, points or curves are rendered)")
    points, indices = scene.triangles()
    if not has_area(points, indices):  # as an empty stage: rays that can meet nothing, '0 % hits' at any Mrays/s
        raise ValueError(f"the scene's {triangles} triangles all have zero area (collinear or repeated corners): "
                         "no ray can hit one")
    origins, directions = ray_set(scene, kind, grid.n_rays, seed=1)
    if not len(origins):  # no row can time zero rays (Warp fails on the empty slice; Embree "ran" at 0 Mrays/s)
        raise ValueError(f"no {kind} rays: they start where primary rays hit, and none of them hit the scene")
    any_hit = kind in ANY_HIT_KINDS
    scale = float(np.abs(points).max()) if len(points) else 0.0
    base = {"scene": scene_name, "triangles": triangles, "device": str(device), "rays": kind}
    base.update(n_rays=int(len(origins)), inputs=inputs_digest(points, indices, origins, directions),
                repeats=grid.repeats)
    if kind == "shadow":  # one light, named: a scene lit by others must not look measured towards them
        light = shadow_target(scene)[1]
        base.update(shadow_light=light, lights_not_aimed_at=len(scene.lights) - (light != "default sun"))
    reference = None
    ordered = sorted(accels, key=lambda a: a != REFERENCE)  # the reference first, so others can be compared
    rows = [dict(base, accel=spec, threads=threads)
            for spec in ordered if not cannot_build(spec, str(device))  # said once by run_grid
            for threads in (thread_counts if device.is_cpu and spec != "embree" else [1])]  # embreex: one thread
    pending = [row for row in rows if not skip(row, REFERENCE in accels)]
    if REFERENCE in accels and pending and pending[0]["accel"] != REFERENCE:
        # Resumed with the reference rows done: its answer is still needed for the others' agreement.
        try:
            subject = _Subject(REFERENCE, scene, device, 1)
            subject.prepare(origins, directions, any_hit)
            subject.run()
            reference = subject.answer()
        except Exception:  # noqa: BLE001 - its rows recorded the error the first time; agreement stays empty
            pass
    for row in pending:
        spec, threads = row["accel"], row["threads"]
        try:
            subject = _Subject(spec, scene, device, threads)
            subject.prepare(origins, directions, any_hit)
            times = time_runs(subject.run, grid.repeats)
            answer = subject.answer()
            if spec == REFERENCE and reference is None:
                reference = answer
            hit = answer if any_hit else answer.prim >= 0
            # The median of the launches' rates: the rate of the median time, with an even count of launches, was
            # the harmonic mean of the middle two rates.
            rates = [len(origins) / t / 1e6 if t != 0 else math.inf for t in times]
            # threads stays as asked (a suite of a larger machine runs here too); this is what ran at once.
            ran = min(chunk_count(len(origins), threads), usable_cores()) if hasattr(subject, "accel") else 1
            row.update(
                threads_effective=ran,
                build_ms=1000.0 * subject.build_seconds,
                mrays=statistics.median(rates),
                mrays_min=min(rates),
                mrays_max=max(rates),
                hit_fraction=float(np.mean(hit)) if len(hit) else 0.0,
                **_agreement(answer, reference, (points, indices), origins, directions, scale),
                **subject.stats,
            )
        except Exception as e:  # noqa: BLE001 - one failing accelerator must not stop the grid
            row["error"] = f"{type(e).__name__}: {e}".splitlines()[0]
            row["traceback"] = traceback.format_exc(limit=3)
        emit(row)


def _run_group(group, grid: Grid, thread_counts, emit, skip, loaded: dict) -> None:
    """Measures one (scene, device, ray kind) group, scaling sweeps included; a broken scene becomes an error row."""
    scene_name, device, kind = group
    scaling = grid.scaling or {}
    is_scaling = scene_name.startswith("sphere:") and scene_name not in grid.scenes
    accels = scaling.get("accels", grid.accels) if is_scaling else grid.accels
    local = dataclasses.replace(grid, n_rays=int(scaling.get("n_rays", grid.n_rays))) if is_scaling else grid
    try:
        if scene_name not in loaded:
            loaded.clear()  # keep one scene in memory at a time
            try:
                loaded[scene_name] = resolve_scene(scene_name)
            except Exception as e:
                # Kept, so its other groups fail at once: a scene that runs out of memory was loaded again, for
                # minutes, once per ray kind and device.
                loaded[scene_name] = e.with_traceback(None)
                raise
        scene = loaded[scene_name]
        if isinstance(scene, Exception):
            raise scene
        sink = (lambda row: emit(dict(row, sweep=True))) if is_scaling else emit
        measure_group(scene_name, scene, device, kind, local, accels, thread_counts, sink, skip)
    except Exception as e:  # noqa: BLE001 - a broken scene becomes one error row
        emit(_group_error_row(scene_name, device, kind, e))


def _group_error_row(scene_name, device, kind, error: Exception) -> dict:
    """The row of a whole group that could not be measured."""
    return {"scene": scene_name, "accel": "*", "device": str(device), "rays": kind, "threads": None,
            "error": f"{type(error).__name__}: {error}".splitlines()[0]}


_worker_scenes = {}  # the scene a Dask worker process loaded last, kept for its next group


def _run_group_task(task) -> list[dict]:
    """One row group on a Dask worker (see ``wrt.distributed``); returns its rows with the worker's hardware.

    A CUDA group runs on the worker's own GPU (``worker_device()``); its rows keep the grid's device name, so that
    tables and ``resume`` line up.
    """
    from .distributed import send_partial, worker_device

    (scene_name, device_name, kind), grid, thread_counts, done = task  # done: row key -> identity fields, agreement
    device = resolve_device(worker_device() if device_name.startswith("cuda") else device_name)
    if device_name.startswith("cuda") and not device.is_cuda:  # worker_device() is the CPU without a GPU
        raise ValueError(f"{device_name}: no CUDA device on the Dask worker at {platform.node()}")
    info, rows = hardware(device), []

    def collect(row):
        rows.append(dict(row, device=device_name, **info))
        send_partial(rows[-1])  # kept by the client when a Ctrl-C there cuts this group short

    def skip(row, checkable):
        return _resumed_row_stands(done.get(row_key(dict(row, device=device_name))), dict(row, **info), checkable)

    _run_group((scene_name, device, kind), grid, thread_counts, collect, skip, _worker_scenes)
    return rows


SETTINGS_FILE = "settings.json"  # beside rows.jsonl: the ray counts and repeats its rows were measured with


def _resume_settings(grid: Grid, before: dict | None = None) -> dict:
    """The settings that decide how a row is measured: which rays it times, and over how many timed launches (a
    median of 3 is noisier than one of 20). A resumed row measured under others would sit in the table as if it
    were measured like the new rows, so ``resume`` refuses them. A grid without a sweep keeps the sweep's ray count
    of the earlier run resumed (``before``, its settings), whose sweep rows stay."""
    settings = {"n_rays": grid.n_rays, "scaling_n_rays": int((grid.scaling or {}).get("n_rays", grid.n_rays)),
                "repeats": grid.repeats}
    if not _has_sweep(grid) and isinstance(before, dict) and isinstance(before.get("scaling_n_rays"), int):
        settings["scaling_n_rays"] = before["scaling_n_rays"]
    return settings


def _has_sweep(grid: Grid) -> bool:
    """Whether ``grid`` measures a scaling sweep (``wrt bench SUITE --scenes ...`` leaves the suite's out)."""
    return bool((grid.scaling or {}).get("sizes"))


def _read_settings(path: Path) -> dict:
    """The settings recorded in ``path`` (``SETTINGS_FILE``); ``{}`` where there are none or they do not read."""
    try:
        before = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return before if isinstance(before, dict) else {}


# How a user sets each of _resume_settings: the options of wrt bench, and the sweep's own key in a suite file.
_SETTING_NAMES = {"n_rays": "--n-rays", "repeats": "--repeats", "scaling_n_rays": "the suite's scaling n_rays"}


def _check_resumed_settings(path: Path, grid: Grid, sweep_rows: bool = True) -> dict:
    """The settings the rows to resume were measured with (``path``, their ``SETTINGS_FILE``: :func:`_read_settings`);
    raises ValueError where they are other ray counts or repeats (none, or one without a setting, from an older run:
    nothing to compare for it). The sweep's ray count is compared only where the rows hold sweep rows
    (``sweep_rows``): a run without its sweep (``--scenes``) records one it measured nothing with, and the whole
    suite's resume was refused for it."""
    before = _read_settings(path)
    now = _resume_settings(grid, before)
    differ = [k for k in now if before.get(k, now[k]) != now[k] and (sweep_rows or k != "scaling_n_rays")]
    follows = before.get("scaling_n_rays") == before.get("n_rays") and now["scaling_n_rays"] == now["n_rays"]
    if "scaling_n_rays" in differ and follows:  # a sweep without its own n_rays follows --n-rays: one change, once
        differ.remove("scaling_n_rays")
    changed = [f"{_SETTING_NAMES[k]} {before[k]} -> {now[k]}" for k in differ]
    if changed:
        raise ValueError(f"{path.parent}: its rows were measured with other settings ({', '.join(changed)}); "
                         "resume with the same settings, or run without --resume to start over")
    return before


def _refuse_wrt_output(path: Path) -> None:
    """Raises ValueError when ``path``, given as a suite and read as none, is a file that wrt writes: the rows of a
    bench (``rows.jsonl``), its ``settings.json``, or a render log. 'wrt bench bench-out/rows.jsonl' was 'not a JSON
    suite (Extra data at line 2 ...)', and settings.json had 'unknown suite keys ['scaling_n_rays'] (did you mean
    'scaling'?)', as if a suite had a misspelt key."""
    from .render_log import is_bench_row

    try:
        with open(path, encoding="utf-8") as f:
            first = json.loads(f.readline())
    except (OSError, ValueError):
        return
    if not isinstance(first, dict):
        return
    folder = f"; to keep its folder's rows, add -o {path.parent} --resume"
    if set(first) == set(_SETTING_NAMES):
        what = f"the {SETTINGS_FILE} of a wrt bench output folder (the ray counts and repeats of its rows)"
    elif is_bench_row(first):
        what = "rows that wrt bench measured (its OUT/rows.jsonl)"
    elif isinstance(first.get("output"), str):
        what, folder = "rows of a wrt render log", ""
    else:
        return
    suites = [p.stem for p in sorted(SUITES_DIR.glob("*.json"))] if SUITES_DIR.exists() else []
    suites.append("a JSON file of grid fields")
    raise ValueError(f"{path}: {what}, not a benchmark suite; give a suite ({', '.join(suites)}){folder}")


def _resumed_rows(jsonl: Path) -> list[dict]:
    """The measured rows of an earlier run, for ``resume`` (``jsonl`` gets just those once the run has a row).
    Error rows are dropped, as their rows run again; so is a last line cut short by an interruption.

    Raises:
        ValueError: naming the file and line, for a damaged line other than the last.
    """
    try:
        text = jsonl.read_text(encoding="utf-8")
    except UnicodeDecodeError as e:  # 'utf-8' codec can't decode byte 0xcd in position 1, naming no file
        line = jsonl.read_bytes()[: e.start].count(b"\n") + 1
        raise ValueError(f"{jsonl}: line {line} is not UTF-8 text, so the file holds no benchmark rows; remove it, "
                         "or run without --resume to start over") from None
    lines = [line for line in text.splitlines() if line.strip()]
    rows = []
    for number, line in enumerate(lines, 1):
        try:
            row = json.loads(line)
        except json.JSONDecodeError as e:
            if number == len(lines):
                import warnings

                warnings.warn(f"{jsonl}: line {number} was cut short (an interrupted run?); its row runs again")
                break
            raise ValueError(f"{jsonl}: line {number} is not a JSON row ({e.msg}); remove it to resume") from None
        if isinstance(row, dict) and isinstance(row.get("output"), str):  # every row of wrt render's logs names one
            raise ValueError(f"{jsonl}: line {number} is a row of a wrt render log (image {row['output']}), not a "
                             "benchmark row; remove it to resume")
        if not isinstance(row, dict) or ("error" not in row and any(name not in row for name in ROW_KEY_FIELDS)):
            raise ValueError(f"{jsonl}: line {number} is not a benchmark row (an object with "
                             f"{', '.join(ROW_KEY_FIELDS)}); remove it to resume")
        if "error" not in row:
            rows.append(_row_from_json(row))
    return _canonical_rows(rows)


def _canonical_rows(rows: list[dict]) -> list[dict]:
    """``rows`` with their accelerators by canonical name (:func:`check_accel_spec`), the last of each key kept:
    rows of a run before names were made canonical ('wrt', 'warp') are resumed as this run's 'wrt:sah' and
    'warp:sah' rows, not kept beside them."""
    kept = {}
    for row in rows:
        try:
            row = dict(row, accel=check_accel_spec(row["accel"]))
        except (TypeError, ValueError, AttributeError):  # a name no longer known: kept as it is, and never matched
            pass
        kept.pop(row_key(row), None)  # the later row of a key, in its place in the file
        kept[row_key(row)] = row
    return list(kept.values())


def _as_grid_scenes(rows: list[dict], scenes: list[str]) -> list[dict]:
    """``rows`` (resumed) with each scene row named as ``scenes`` spell its scene (:func:`_scene_key`), the last of
    each key kept: a run measures one scene in two spellings once, and rows resumed under the other spelling were
    kept beside this run's rows of the same measurement, each row twice in the table. Sweep rows keep their names."""
    spelling = {_scene_key(name): name for name in scenes}
    kept = {}
    for row in rows:
        if not row.get("sweep") and isinstance(row.get("scene"), str):
            try:
                key = _row_scene_key(row)
            except (ValueError, OSError):  # a name no longer read (sphere:abc): kept as it is, never matched
                key = None
            if key in spelling:  # named as this run names it, from the folder it runs in
                row = dict(row, scene=spelling[key], cwd=os.getcwd())
            elif key is not None and row["scene"] in spelling.values() and isinstance(row.get("cwd"), str):
                # Spelt as a scene of this grid but another file from its run's folder (a copy of the project): named
                # by that path, or it stood for this grid's scene as an earlier run's row outside it, measured by none.
                row = dict(row, scene=str(Path(row["cwd"]) / row["scene"]))
        kept.pop(row_key(row), None)  # the later row of a key, in its place in the file
        kept[row_key(row)] = row
    return list(kept.values())


def _write_rows(jsonl: Path, rows: list[dict]) -> None:
    """Replaces ``jsonl`` with ``rows`` in one step: an interruption leaves the old file or the new one, and no
    temporary file (``rows.jsonl.tmp`` stayed when the replace failed or was interrupted)."""
    text = "".join(strict_json(r) + "\n" for r in rows)
    write_atomically(jsonl, lambda target: target.write_text(text))


# Measured numbers of a row: NaN or infinite ones are written as null and read back as NaN.
MEASURED_FLOATS = ("build_ms", "mrays", "mrays_min", "mrays_max", "hit_fraction", "sah_cost")


def _row_from_json(row: dict) -> dict:
    """A row read from ``rows.jsonl``: the null of a measured number is NaN again (``agreement`` stays None: it
    means unchecked)."""
    return dict(row, **{k: math.nan for k in MEASURED_FLOATS if k in row and row[k] is None})


def _replace_resumed(row: dict, resumed: dict, rows: list[dict], warned: set, outside: set) -> bool:
    """Drops from ``rows`` (and ``resumed``, row key -> row) the resumed rows that the new ``row`` measures again:
    the one of its key, measured on other inputs, hardware or versions, or every row of its group when the whole
    group now fails, but for the rows of keys in ``outside`` (of the earlier run, outside this grid: not measured
    again, they stay, as the summary says; a failing scene dropped them). Warns once per group; returns whether a
    row was dropped."""
    group = (row["scene"], row["device"], row["rays"])
    stale = [key for key in resumed if key == row_key(row) or (
        row["accel"] == "*" and key not in outside
        and (resumed[key]["scene"], resumed[key]["device"], resumed[key]["rays"]) == group)]
    if not stale:
        return False
    if group not in warned:
        import warnings

        warned.add(group)
        before = resumed[stale[0]]
        why = (["the group now fails"] if row["accel"] == "*"
               else identity_changes(before, row) or [f"it was not checked against {REFERENCE}"])
        warnings.warn(f"{' / '.join(map(str, group))}: rows of the resumed run measured again, as {', '.join(why)}")
    for key in stale:
        rows.remove(resumed.pop(key))
    return True


class Rows(list):
    """The rows of a run, as a list; ``resumed``: how many of them ``resume`` kept from the earlier run, unmeasured
    (they come first), of this run's grid; ``earlier``: how many more it kept that this grid does not measure (other
    scenes, accelerators, devices, ray kinds or thread counts), which are no part of this run's count, and
    ``earlier_keys`` their row keys (:func:`row_key`), which the table and plots mark."""

    def __init__(self, rows=(), resumed: int = 0, earlier: int = 0, earlier_keys=frozenset()):
        super().__init__(rows)
        self.resumed = resumed
        self.earlier = earlier
        self.earlier_keys = frozenset(earlier_keys)


def run_grid(
    grid: Grid, out: Path | None = None, resume: bool = False, progress: bool = True, dask: str | bool | None = None
) -> Rows:
    """Runs the whole grid; returns the rows (also appended to ``out/rows.jsonl`` as they come), resumed ones first.

    ``dask``: None runs every group here, in turn; True (or ``""``) sends the groups to a new ``LocalCluster`` and
    an address (``tcp://host:8786``) to that scheduler (``wrt.distributed.run_tasks``), a group per task, each
    group's rows written as it arrives. A group whose workers keep dying becomes an error row; its resumed rows stay.
    """
    from tqdm import tqdm

    # By their truth, resume="false" kept the earlier run's rows and progress="false" showed the bar.
    resume, progress = flag(resume, "run_grid: resume"), flag(progress, "run_grid: progress")
    if isinstance(dask, str) and not dask.strip():  # '' (--dask "$ADDR", unset) ran here, without Dask or a word
        dask = True  # a LocalCluster, as run_tasks and wrt render --dask take an empty address
    if dask is not None and not isinstance(dask, str):  # dask=2 was taken as the address of a scheduler
        try:
            dask = flag(dask, "run_grid: dask")
        except TypeError:
            raise TypeError(f"run_grid: dask must be None, True or False, or a scheduler address str, got "
                            f"{type(dask).__name__} {dask!r}") from None
    rows, resumed, warned = [], {}, set()  # resumed: row key -> a row of the earlier run, kept until measured again
    cwd = os.getcwd()  # the folder the rows' relative scene paths are read from
    earlier_settings = None  # the settings of the rows resumed (SETTINGS_FILE)
    jsonl = None
    if out is not None:
        if not str(out).strip():  # Path("") is the current folder
            raise ValueError("the output folder is empty; name one (wrt bench -o FOLDER)")
        out = Path(out)
        files = [p for p in (out, *out.parents) if p.exists() and not p.is_dir()]
        if files:  # mkdir said only '[Errno 17] File exists'
            raise ValueError(f"output folder {str(out)!r}: {str(files[0])!r} is a file, not a folder")
        # Found only when the first row was written, after it was measured, or, for the table and the plots, once
        # every row was: the run stopped with that error, without its summary, and exited 2.
        for name in ("rows.jsonl", SETTINGS_FILE, "table.md", *PLOT_FILES):
            if (out / name).is_dir():
                what = "the rows go" if name == "rows.jsonl" else f"{name} goes"
                raise ValueError(f"output folder {str(out)!r}: {str(out / name)!r}, where {what}, is a folder")
        _refuse_files_not_written_by_bench(out, rows=not resume)
        jsonl = out / "rows.jsonl"
        if resume and jsonl.exists():
            rows = _resumed_rows(jsonl)
            earlier_settings = _check_resumed_settings(out / SETTINGS_FILE, grid,
                                                       sweep_rows=any(r.get("sweep") for r in rows))
            if "repeats" in earlier_settings:  # rows of runs before rows recorded theirs: the file's, as it says
                rows = [r if "repeats" in r else dict(r, repeats=earlier_settings["repeats"]) for r in rows]
            resumed = {row_key(r): r for r in rows}
        elif resume:  # said: a misspelt output folder measured every row again without a word
            import warnings

            warnings.warn(f"nothing to resume: no rows at {jsonl}; every row is measured")
    begun = False  # whether out/ holds this run's results yet

    grid = grid.validated()
    if jsonl is not None and not resume and jsonl.is_file():
        _warn_rows_dropped(jsonl, grid)
    if resumed:  # an earlier run's rows of a scene spelt otherwise now (sphere:1e3 for sphere:1000) are this run's
        rows = _as_grid_scenes(rows, grid.scenes)
        resumed = {row_key(r): r for r in rows}
    devices, unavailable = _resolve_devices(grid.devices) if not dask else (grid.devices, {})  # dask: on the worker
    missing = [a for a in grid.accels if a == "embree" and not _has_embree()]
    if missing:  # after the checks: a misspelt device was refused under this warning
        import warnings

        why = "the optional package embreex is not installed (pip install 'wrt[bench]')"
        warnings.warn(f"embree rows skipped: {why}")
        try:
            grid = dataclasses.replace(grid, accels=[a for a in grid.accels if a not in missing]).validated()
        except GridError as e:  # embree alone: 'accels empty' named no reason, as embree was given
            raise GridError(e.field, f"{e}: embree cannot run, {why}", e.index) from None
    if out is not None:  # made once the run can start: a misspelt device, or embree alone, left an empty folder
        out.mkdir(parents=True, exist_ok=True)
    _warn_rows_not_built(grid)
    if not isinstance(dask, str):  # a remote scheduler's workers read the scene files, not this machine
        _warn_scene_files(grid)
    # Rows of the earlier run this grid does not measure: kept in rows.jsonl (that is what --resume is for), but
    # neither counted as this run's resumed rows nor shown in its table as if it had measured them.
    outside = {key for key, row in resumed.items() if not _in_grid(row, grid)}
    thread_counts = grid.threads
    groups = [(s, d, k) for s in grid.scenes for d in devices for k in grid.rays]
    scaling = grid.scaling or {}
    sizes = dict.fromkeys(f"sphere:{int(float(n))}" for n in scaling.get("sizes", []))  # 1e3 and 1000: one group
    groups += [(name, d, scaling.get("rays", "incoherent")) for name in sizes for d in devices]
    # With dask, each row has its worker's hardware.
    info = {} if dask else {str(d): hardware(d) for d in devices if str(d) not in unavailable}

    def skip(row, checkable):
        return _resumed_row_stands(resumed.get(row_key(row)), dict(row, **info.get(row["device"], {})), checkable)

    def begin():
        """Replaces the earlier run's files with this run's, once it has a row (or ends): a run that stops before,
        at a misspelt device, an unreachable Dask scheduler or Ctrl-C while a scene loads, leaves them as they were."""
        nonlocal begun
        if out is not None and not begun:
            _write_rows(jsonl, rows)  # the resumed rows, or none
            settings = strict_json(_resume_settings(grid, earlier_settings)) + "\n"
            write_atomically(out / SETTINGS_FILE, lambda target: target.write_text(settings))
        begun = True

    def emit(row, replaces: bool = True):  # replaces: the row drops the resumed rows it measures again
        begin()
        row.update(info.get(row["device"], {}), cwd=cwd)  # cwd: what the row's scene path is relative to
        if replaces and _replace_resumed(row, resumed, rows, warned, outside) and jsonl is not None:
            _write_rows(jsonl, rows)
        rows.append(row)
        if jsonl is not None:
            try:
                with open(jsonl, "a") as f:  # one row per write, flushed: an interrupted run loses nothing
                    f.write(strict_json(row) + "\n")
                    f.flush()
            except OSError as e:  # a full disk: named, as the other writes of the run are
                raise failed_write(e, jsonl) from None
        if "error" in row:
            # The device too, as the summary names it; on stderr, under the bar, with the run's other messages.
            tqdm.write(f"wrt bench: {row['scene']} / {row['accel']} / {row['device']} / {row['rays']}: {row['error']}",
                       file=sys.stderr)

    try:
        if dask:
            from .distributed import run_tasks

            def lost(task, e):  # the group's workers kept dying, or its device does not exist there
                # Nothing measured the group's resumed rows again, so they stay, as a missing device's do.
                emit(_group_error_row(*task[0], e), replaces=False)

            done = {key: {name: r.get(name) for name in (*IDENTITY_FIELDS, "agreement")} for key, r in resumed.items()}
            tasks = [((s, str(d), k), grid, thread_counts, done) for s, d, k in groups]
            def keep(group_rows):
                for row in group_rows:
                    emit(row)

            # on_partial: the rows a worker had finished of a group cut short (Ctrl-C, or workers that kept dying), as
            # a plain run keeps those before a Ctrl-C or a group's error row.
            run_tasks(_run_group_task, tasks, address=None if dask is True else dask, progress=progress,
                      desc="wrt bench", on_result=lambda task, group_rows: keep(group_rows), on_error=lost,
                      on_partial=lambda task, group_rows: keep(group_rows))
            order = {task[0]: i for i, task in enumerate(tasks)}
            first = len(resumed)  # the resumed rows not measured again come first
            rows[first:] = sorted(rows[first:],
                                  key=lambda r: order.get((r["scene"], r["device"], r["rays"]), 0))  # grid order
        else:
            bar = tqdm(total=len(groups), desc="wrt bench", unit="group", disable=not progress)
            loaded = {}
            for group in groups:
                bar.set_postfix_str(" ".join(map(str, group)))
                if str(group[1]) in unavailable:  # its rows of the resumed run stay: nothing measured them again
                    emit(_group_error_row(*group, unavailable[str(group[1])]), replaces=False)
                else:
                    _run_group(group, grid, thread_counts, emit, skip, loaded)
                bar.update()
            bar.close()
    except KeyboardInterrupt:  # rows.jsonl has every finished row; the table and plots show them too
        if out is not None and begun:
            write_summary(rows, out, outside)
        raise
    begin()
    if out is not None:
        write_summary(rows, out, outside)
    return Rows(rows, resumed=len(resumed) - len(outside), earlier=len(outside), earlier_keys=outside)


def _warn_rows_dropped(jsonl: Path, grid: Grid) -> None:
    """Warns, naming a few, about the measured rows in ``jsonl`` (an earlier run's) that ``grid`` does not measure
    again, which a run without ``resume`` drops: wrt bench --quick after wrt bench cpu, both into bench-out, replaced
    the cpu suite's rows without a word."""
    import warnings

    earlier = []
    for line in jsonl.read_text(encoding="utf-8", errors="replace").splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:  # cut short, or no row: nothing measured to lose
            continue
        named = (isinstance(row, dict) and all(isinstance(row.get(k), str) for k in ROW_KEY_FIELDS[:4])
                 and all(k in row for k in ROW_KEY_FIELDS))  # a row without threads is no row wrt wrote
        if named and "error" not in row:
            earlier.append(row)
    dropped = [row for row in _canonical_rows(earlier) if not _in_grid(row, grid)]
    if dropped:
        named = "; ".join(" / ".join(row[k] for k in ROW_KEY_FIELDS[:4]) for row in dropped[:3])
        more = f" and {len(dropped) - 3} more" if len(dropped) > 3 else ""
        they, them = ("it is", "it") if len(dropped) == 1 else ("they are", "them")
        warnings.warn(f"{jsonl.parent}: {counted(len(dropped), 'row')} of an earlier run measured what this run does "
                      f"not ({named}{more}); {they} dropped when this run writes its first row (resume keeps {them}: "
                      "wrt bench --resume)", stacklevel=3)


def _in_grid(row: dict, grid: Grid) -> bool:
    """Whether ``grid`` (validated) measures the row's scene (or sweep size), accelerator, device, ray kind and, for
    a CPU row, thread count."""
    scaling = grid.scaling or {}
    # A CPU row of a thread count the grid does not ask for (threads 4 after 1,all on 2 cores) is not its row either,
    # a sweep's (run at each thread count) as a scene's.
    threads = not str(row["device"]).startswith("cpu") or row["accel"] == "embree" or row.get("threads") in grid.threads
    if row.get("sweep"):
        sizes = {f"sphere:{int(float(n))}" for n in scaling.get("sizes", [])}
        return (row["scene"] in sizes and row["accel"] in scaling.get("accels", grid.accels) and threads
                and row["rays"] == scaling.get("rays", "incoherent") and row["device"] in _device_names(grid))
    try:
        scene = _row_scene_key(row)
    except (ValueError, OSError):  # a name no longer read: not this grid's
        return False
    return (scene in {_scene_key(name) for name in grid.scenes} and row["accel"] in grid.accels
            and row["rays"] in grid.rays and row["device"] in _device_names(grid) and threads)


def _device_names(grid: Grid) -> set:
    """The names rows give the grid's devices: as listed, and ``cuda`` as ``cuda:0`` (``str(wp.get_device("cuda"))``
    names the current CUDA device, cuda:0 unless set otherwise)."""
    return set(grid.devices) | {"cuda:0" for name in grid.devices if name == "cuda"}


def _warn_rows_not_built(grid: Grid) -> None:
    """Warns once per accelerator and device that it cannot build (warp:lbvh on the cpu of a cpu,cuda:0 grid): its
    rows there are left out, where they were failed rows (after the scene had loaded) that made the run exit 1."""
    import warnings

    accels = dict.fromkeys([*grid.accels, *(grid.scaling or {}).get("accels", [])])
    for spec in accels:
        for name in grid.devices:
            why = cannot_build(spec, name)
            if why:
                warnings.warn(f"{spec} has no rows on {name}: {why}", stacklevel=3)


def _resolve_devices(names: list[str]) -> tuple[list, dict]:
    """The Warp devices of ``names``, each once (``cuda`` and ``cuda:0`` are one device, whose rows are named
    ``cuda:0``: its groups were measured twice), with a CUDA device this machine does not have kept by name in the
    second value (name -> the error naming it), so that the other devices' rows still run and its own become error
    rows.

    Raises:
        GridError: for a name that is no device (a misspelling), or when no device named is available.
    """
    devices, unavailable = [], {}
    for i, name in enumerate(names):
        try:
            device = resolve_device(name)
            if str(device) not in map(str, devices):
                devices.append(device)
        except ValueError as e:
            if not (name == "cuda" or name.startswith("cuda:") and name[5:].isdigit()):
                raise GridError("devices", str(e), i) from None
            # 'cuda' is cuda:0 missing too (as _device_names reads it): one group of error rows, not one per name.
            key = "cuda:0" if name == "cuda" else name
            if key not in unavailable:
                devices.append(key)
                unavailable[key] = e
    if all(str(device) in unavailable for device in devices):
        raise GridError("devices", str(next(iter(unavailable.values()))))
    return devices, unavailable


TABLE_HEAD = "| scene | tris | device | rays | accel |"  # how every table.md wrt bench wrote starts (markdown_table)


def _written_by_bench(path: Path) -> bool:
    """Whether ``path`` (``table.md``, ``settings.json`` or a plot of an output folder) is a file that wrt bench
    wrote, or empty: one a run may replace. A table starts with :data:`TABLE_HEAD`, the settings are a JSON object
    of :data:`_SETTING_NAMES` (an older run's, of fewer), a plot holds :data:`PLOT_MARK`."""
    try:
        if path.stat().st_size == 0:
            return True
        if path.name in PLOT_FILES:
            return written_by_wrt(path)
        with open(path, "rb") as f:
            data = f.read(64 * 1024)
        if path.name == "table.md":  # its head only: 64 KiB of a longer table may end inside a scene name's character
            return data.startswith(TABLE_HEAD.encode())
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    try:
        settings = json.loads(text)
    except json.JSONDecodeError:
        return False
    return isinstance(settings, dict) and bool(settings) and set(settings) <= set(_SETTING_NAMES)


def _rows_written_by_bench(path: Path) -> bool:
    """Whether ``path`` (``rows.jsonl``) is empty or starts with a row of wrt bench (:func:`is_bench_row`, an error
    row too), or with the start of one that a stopped run cut short. Its first line alone is read: a user's file of
    that name may be large."""
    from .render_log import is_bench_row

    try:
        if path.stat().st_size == 0:
            return True
        with open(path, "rb") as f:
            first = f.readline(1 << 20)
    except OSError:
        return False
    try:
        row = json.loads(first)
    except ValueError:  # no JSON (or no UTF-8): a row cut short is the file's only, unended line
        return first.startswith(b'{"scene": ') and not first.endswith(b"\n")
    return isinstance(row, dict) and is_bench_row(row)


def _refuse_files_not_written_by_bench(out: Path, rows: bool = True) -> None:
    """Raises ValueError, before anything is measured, naming a ``table.md``, ``settings.json`` or plot in ``out``
    that wrt bench did not write (:func:`_written_by_bench`): the run replaced the user's own files of those names
    (``-o .`` in a project folder) without a word. So is a ``rows.jsonl`` of other rows (:func:`_rows_written_by_bench`)
    where ``rows`` (a run that is no resume: a resume reads it, naming what it holds, and replaces nothing)."""
    if rows and (out / "rows.jsonl").is_file() and not _rows_written_by_bench(out / "rows.jsonl"):
        raise ValueError(f"output folder {str(out)!r}: {str(out / 'rows.jsonl')!r} was not written by wrt bench (it "
                         "holds no bench rows), and this run would replace it; move it, or give another output folder "
                         "(-o)")
    for name in ("table.md", SETTINGS_FILE, *PLOT_FILES):
        path = out / name
        if path.is_file() and not _written_by_bench(path) and not (name in PLOT_FILES and _unmarked_bench_plot(path)):
            raise ValueError(f"output folder {str(out)!r}: {str(path)!r} was not written by wrt bench, and this run "
                             f"would replace it; move it, or give another output folder (-o)")


def write_summary(rows: list[dict], out: Path, earlier=()) -> None:
    """Writes ``out/table.md`` and the plots of ``rows``, and removes the plots of an earlier run that they have no
    rows for: only those wrt wrote (:func:`written_by_wrt`), another file of that name is kept with a warning.
    ``earlier``: the row keys of rows an earlier run measured that this run's grid does not, marked in the table and
    the plots."""
    table = markdown_table(rows, earlier)
    write_atomically(out / "table.md", lambda target: target.write_text(table))
    before = {name: file_state(out / name) for name in PLOT_FILES}
    try:
        plot(rows, out, earlier)
    except ImportError:
        import warnings

        warnings.warn("plots skipped: matplotlib is not installed (pip install 'wrt[bench]')")
    finally:  # also when stopped (Ctrl-C) before a plot was drawn: it stayed as an earlier run wrote it
        for name in PLOT_FILES:  # a plot this run has not written must not show an earlier run's numbers
            path, now = out / name, file_state(out / name)
            if now is None or now != before[name]:  # none, or written just now
                continue
            if written_by_wrt(path):
                path.unlink()
            else:  # the user's own file of that name (or a plot edited since): never removed
                import warnings

                warnings.warn(f"{path} left as is: this run has no rows for it and wrt did not write it (stale?)")


def file_state(path: Path) -> tuple | None:
    """What tells a file rewritten (renamed into place) or appended to from the one that was there: its inode, size
    and time; None where there is none."""
    try:
        stat = path.stat()
    except OSError:
        return None
    return stat.st_ino, stat.st_size, stat.st_mtime_ns


def _ratio(row, rows, accel) -> float | None:
    """``row``'s rate over that of ``accel`` in its group: NaN (shown as n/a) where that row failed or measured
    nothing, None (a blank cell) where ``accel`` was not run on the same triangles and rays (``inputs``): an earlier
    run's row kept by ``resume`` from before the scene was edited gave a ratio of two workloads."""
    for other in rows:
        if other.get("accel") == accel and row_key(other)[2:] == row_key(row)[2:] and other["scene"] == row["scene"]:
            if None not in (other.get("inputs"), row.get("inputs")) and other["inputs"] != row["inputs"]:
                continue
            return row["mrays"] / other["mrays"] if other.get("mrays") else math.nan
    return None


def markdown_table(rows: list[dict], earlier=()) -> str:
    """The rows as a markdown table with ratios to ``warp:sah`` and to Embree, plus the hardware. An agreement below
    edge ties is marked with the number of rays that differ; a row with no ``warp:sah`` answer to check is marked
    ``unchecked``; a row whose key is in ``earlier`` (kept by ``resume``, outside this run's grid) ``(earlier run)``
    after its scene."""
    head = (f"{TABLE_HEAD} threads | build ms | Mrays/s (min-max) | hit % | agree % "
            "| x warp:sah | x embree | SAH |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    cell = lambda x: "" if x is None else str(x).replace("|", "\\|")  # noqa: E731 - a '|' would split the cell
    fmt = lambda x, spec: "" if x is None else format(x, spec) if math.isfinite(x) else "n/a"  # noqa: E731
    notes = set()
    for r in rows:
        scene = cell(r["scene"])
        if earlier and row_key(r) in earlier:
            scene += " (earlier run)"
            notes.add("- (earlier run): a row of an earlier run in this folder that wrt bench --resume kept; this "
                      "run's grid does not measure it")
        start = f"| {scene} | {cell(r.get('triangles'))} | {r['device']} | {r['rays']} | {r['accel']} | "
        if "error" in r:
            lines.append(f"{start}{cell(r.get('threads'))} | error: {cell(r['error'])} | | | | | | |")
            continue
        ratio_w, ratio_e = _ratio(r, rows, REFERENCE), _ratio(r, rows, "embree")
        agree = fmt(None if r.get("agreement") is None else 100 * r["agreement"], ".3f")
        if r.get("disagreements"):
            agree += f" ({r['disagreements']} differ)"
            notes.add(f"- (N differ): N rays answered otherwise than by {REFERENCE}, edge ties left out: a wrong "
                      f"answer of this row or of {REFERENCE}")
        elif r.get("agreement") is None and r["accel"] != REFERENCE:
            agree = "unchecked"
            notes.add(f"- unchecked: no {REFERENCE} answer in the group to compare with (it failed or was not run)")
        ran = r.get("threads_effective")
        threads = f"{r['threads']} ({ran} ran)" if ran is not None and ran != r["threads"] else str(r["threads"])
        lines.append(
            f"{start}{threads} | {fmt(r['build_ms'], '.1f')} | {fmt(r['mrays'], '.2f')} "
            f"({fmt(r['mrays_min'], '.2f')}-{fmt(r['mrays_max'], '.2f')}) | {fmt(100 * r['hit_fraction'], '.1f')} | "
            f"{agree} | {fmt(ratio_w, '.2f')} | {fmt(ratio_e, '.2f')} | {fmt(r.get('sah_cost'), '.2f')} |"
        )
    for r in rows:
        if r.get("shadow_light") is not None:
            target = "the default sun" if r["shadow_light"] == "default sun" else r["shadow_light"]
            others = counted(r.get("lights_not_aimed_at", 0), "other light")
            notes.add(f"- shadow rays of {r['scene']}: towards {target} ({others} not aimed at)")
    hardware_lines = sorted({f"- {r['device']}: CPU {r.get('cpu')} ({r.get('cpu_cores')} cores), {_gpu_text(r)}Warp "
                             f"{r.get('warp')}, wrt {r.get('wrt')} (source {r.get('wrt_source')})"
                             for r in rows if "cpu" in r})
    return "\n".join(lines + [""] + sorted(notes) + hardware_lines) + "\n"


def _gpu_text(row: dict) -> str:
    """``GPU <name>, driver <version> (<CUDA version>), `` of a row measured on a GPU, else nothing: a CPU row's line
    read 'GPU None, driver None (None)'."""
    if not row.get("gpu"):
        return ""
    return f"GPU {row['gpu']}, driver {row.get('gpu_driver') or 'unknown'} ({row.get('driver')}), "


SLOPE_FROM = 1e4  # scaling slopes are fitted from this many triangles up, so fixed costs do not dominate


def fit_slope(x, y, x_min: float = 0.0) -> float:
    """Least-squares slope of ``log y`` against ``log x``, over the points with ``x >= x_min``; NaN when fewer than
    two distinct ``x`` are left (a sweep of small sizes only), as no line is defined by them."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = x >= x_min
    if len(np.unique(x[keep])) < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])


def _slope_label(x, y) -> str:
    slope = fit_slope(x, y, SLOPE_FROM)
    return f"slope {slope:.2f}" if math.isfinite(slope) else f"no slope (fewer than 2 sizes >= {SLOPE_FROM:g})"


PLOT_FILES = ("mrays.png", "build_vs_quality.png", "scaling.png")  # what plot() may write
PLOT_MARK = ("wrt-bench", "plot")  # a PNG tEXt chunk (key, text) in each plot: it tells wrt's plots from the user's


def written_by_wrt(path: Path) -> bool:
    """Whether ``path`` is a PNG that :func:`plot` wrote: one holding the ``PLOT_MARK`` text chunk. Anything else
    (another image, a file that is no PNG or cannot be read) is not."""
    return b"\0".join(part.encode("latin-1") for part in PLOT_MARK) in _png_texts(path)


def _png_texts(path: Path) -> list[bytes]:
    """The ``tEXt`` chunks (``key\\0text``) of the PNG ``path``; none for a file that is no PNG or cannot be read."""
    try:
        data = path.read_bytes()
    except OSError:
        return []
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return []
    texts, at = [], 8
    while at + 8 <= len(data):  # chunks: 4-byte big-endian length, 4-byte type, data, 4-byte CRC
        length, kind = int.from_bytes(data[at:at + 4], "big"), data[at + 4:at + 8]
        if kind == b"tEXt":
            texts.append(data[at + 8:at + 8 + length])
        if kind == b"IEND":
            break
        at += 12 + length
    return texts


def _unmarked_bench_plot(path: Path) -> bool:
    """Whether ``path`` is a plot of wrt bench from before plots were marked (:data:`PLOT_MARK`, 2026-11-24): a PNG
    that matplotlib wrote, beside the table.md that wrt bench wrote with it. Such a folder (the default bench-out of
    every earlier run) was refused as the user's ('mrays.png was not written by wrt bench')."""
    table = path.parent / "table.md"
    return (any(text.startswith(b"Software\0Matplotlib") for text in _png_texts(path))
            and table.is_file() and table.stat().st_size > 0 and _written_by_bench(table))


def _plottable(*values) -> bool:
    """Whether every value is a positive finite number, as a log axis needs: a NaN or infinite point (a row that
    measured nothing) failed the whole plot ("Data cannot be log-scaled"), and is left out instead."""
    return all(v is not None and math.isfinite(v) and v > 0 for v in values)


def _plot_scene_names(scenes: list[str]) -> list[str]:
    """How a plot names each of ``scenes``: a scene file by its file name (the table names it in full), unless
    another scene of the plot has that name too; ``sphere:N``, ``warp:NAME`` and ``asset:ID`` as they are."""
    short = [scene if scene.partition(":")[0] in SCENE_KINDS else Path(scene).name or scene for scene in scenes]
    owners = {}
    for scene, name in zip(scenes, short):
        owners.setdefault(name, set()).add(scene)
    return [name if len(owners[name]) == 1 else scene for scene, name in zip(scenes, short)]


def _save_plot(fig, path: Path) -> None:
    """Writes ``fig`` to ``path`` whole or not at all (an interruption leaves the earlier plot), then closes it."""
    import matplotlib.pyplot as plt

    try:
        write_atomically(path, lambda target: fig.savefig(target, format="png", dpi=110, metadata=dict([PLOT_MARK])))
    finally:
        plt.close(fig)


EARLIER_LABEL = "earlier run (kept by --resume; not in this grid)"  # the legend entry of earlier rows' hollow marks


def _hollow(artist, colour, hatch: str | None = None) -> None:
    """Draws ``artist`` (a bar, a scatter point) of an earlier run's row as an outline in ``colour``."""
    artist.set_facecolor("none")
    artist.set_edgecolor(colour)
    if hatch:
        artist.set_hatch(hatch)


def plot(rows: list[dict], out: Path, earlier=()) -> list[Path]:
    """Writes ``mrays.png``, ``build_vs_quality.png`` and, for scaling rows, ``scaling.png``; returns the paths.
    Rows of several devices get a bar (and a scaling line) per device. Rows whose key is in ``earlier`` (of an
    earlier run, kept by ``resume``, outside this run's grid) are drawn hollow (bars, points) or dashed with hollow
    points (scaling lines), with a legend entry saying so, as the table marks them: drawn as this run's, they read as
    measured now."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    is_earlier = (lambda r: row_key(r) in earlier) if earlier else (lambda r: False)  # noqa: E731
    good = [r for r in rows if "error" not in r]
    paths = []
    if good:
        # Failed rows and groups keep their place, marked: drawn as no bar, they read as a rate of 0 or as not run.
        labels = sorted({(r["scene"], r["rays"]) for r in rows})
        several = len({r["device"] for r in rows}) > 1
        # By accelerator, device, then thread count as a number (as text, x16 came between x1 and x2).
        series = sorted({(r["accel"], r["device"], r["threads"]) for r in rows if r["accel"] != "*"},
                        key=lambda s: (str(s[0]), str(s[1]), s[2] if isinstance(s[2], int) else -1))
        texts = [f"{name}\n{kind}" for name, kind in zip(_plot_scene_names([s for s, _ in labels]),
                                                         (k for _, k in labels))]
        # Each group as wide as its longest label (about 0.07 inch per character at font size 7): whole paths under
        # groups of 1.2 inches were printed over their neighbours'.
        group = max([1.2] + [0.07 * len(line) for text in texts for line in text.splitlines()])
        fig, ax = plt.subplots(figsize=(max(6, group * len(labels)), 4))
        width = 0.8 / max(len(series), 1)
        centres = np.arange(len(labels)) + 0.4 - width / 2
        colours, marked = [], False  # each series' colour, for a legend whose bars of earlier rows are hollow
        for i, (accel, device, threads) in enumerate(series):
            found = [next((r for r in rows if (r["scene"], r["rays"]) == lab
                           and (r["accel"], r["device"], r["threads"]) == (accel, device, threads)), None)
                     for lab in labels]
            failed = [r is not None and ("error" in r or not _plottable(r["mrays"])) for r in found]
            values = [0 if r is None or bad else r["mrays"] for r, bad in zip(found, failed)]
            name = f"{accel} {device}" if several else accel
            bars = ax.bar(np.arange(len(labels)) + i * width, values, width, label=f"{name} x{threads}")
            if earlier:
                colours.append((bars.get_label(), bars.patches[0].get_facecolor()))  # before any bar is hollow
                for k in [k for k, r in enumerate(found) if r is not None and is_earlier(r)]:
                    _hollow(bars.patches[k], colours[-1][1], "///")
                    marked = True
            for k in np.flatnonzero(failed):
                ax.text(k + i * width, 0, "n/a", ha="center", va="bottom", rotation=90, fontsize=6)
        for k, (scene, kind) in enumerate(labels):
            if any(r["accel"] == "*" and (r["scene"], r["rays"]) == (scene, kind) for r in rows):
                ax.text(centres[k], 0, "failed", ha="center", va="bottom", rotation=90, fontsize=6)
        ax.set_xticks(centres, texts, fontsize=7)
        ax.set_xlabel("scene, ray kind")  # the only axis of the three plots that was not named
        ax.set_ylabel("Mrays/s (median)")
        if marked:  # a series' entry took the look of its first bar, hollow where that is an earlier row
            from matplotlib.patches import Patch

            ax.legend(handles=[Patch(facecolor=colour, label=label) for label, colour in colours]
                      + [Patch(facecolor="none", edgecolor="0.3", hatch="///", label=EARLIER_LABEL)], fontsize=7)
        else:
            ax.legend(fontsize=7)
        fig.tight_layout()
        paths.append(out / "mrays.png")
        _save_plot(fig, paths[-1])

    # wrt: rows only: wp.Mesh and Embree give no SAH cost.
    with_sah = [r for r in good
                if r.get("sah_cost") is not None and math.isfinite(r["sah_cost"]) and _plottable(r["build_ms"])]
    if with_sah:
        fig, ax = plt.subplots(figsize=(5, 4))
        # Each row builds its tree again: one point per tree, at the median of its builds, not one per ray kind and
        # thread count, whose identical labels were printed over one another.
        # An earlier run's builds (kept by resume, outside this grid) are a hollow point of their own.
        trees = {}
        for r in with_sah:
            trees.setdefault((r["accel"], r["scene"], r["device"], is_earlier(r)), []).append(r)
        several = len({device for _, _, device, _ in trees}) > 1
        # Scene files by their file names, as mrays.png names them: whole paths made tight_layout squeeze the axes
        # to a sliver to fit them. Labels stay out of the layout, each running from its point towards the middle of
        # the build axis (log scale), so that one of the slowest builds does not run past the figure.
        scenes = sorted({scene for _, scene, _, _ in trees})
        names = dict(zip(scenes, _plot_scene_names(scenes)))
        medians = {key: (statistics.median(r["build_ms"] for r in builds),
                         statistics.median(r["sah_cost"] for r in builds)) for key, builds in trees.items()}
        middle = math.sqrt(min(x for x, _ in medians.values()) * max(x for x, _ in medians.values()))
        for (accel, scene, device, before), at in medians.items():
            point = ax.scatter(*at)
            if before:
                _hollow(point, point.get_facecolor()[0])
            label = ax.annotate(f"{accel} {names[scene]}" + (f" {device}" if several else "")
                                + (" (earlier run)" if before else ""), at, fontsize=6,
                                ha="right" if at[0] > middle else "left")
            label.set_in_layout(False)
        if any(before for *_, before in trees):
            from matplotlib.lines import Line2D

            ax.legend(handles=[Line2D([], [], marker="o", linestyle="", color="0.3", label="this run"),
                               Line2D([], [], marker="o", linestyle="", color="0.3", markerfacecolor="none",
                                      label=EARLIER_LABEL)], fontsize=6)
        ax.set_xlabel("build ms")
        ax.set_ylabel("SAH cost")
        ax.set_xscale("log")
        # Plain numbers ('2.5', '100'): builds within a decade of each other (one small scene) made matplotlib label
        # every minor tick as '2.1x10^0', '2.2x10^0', ..., drawn over one another.
        from matplotlib.ticker import LogFormatter

        ax.xaxis.set_major_formatter(LogFormatter(labelOnlyBase=False))
        ax.xaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False))
        fig.tight_layout()
        paths.append(out / "build_vs_quality.png")
        _save_plot(fig, paths[-1])

    scaling = [r for r in good if r.get("sweep") and _plottable(r["build_ms"], r["mrays"])]
    if scaling:
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 4))
        several = len({r["device"] for r in scaling}) > 1
        # An earlier run's sweep (kept by resume, outside this grid: other thread counts) is a dashed line of hollow
        # points of its own: in one line with this run's, its fewer threads took the line's points.
        for accel, device, before in sorted({(r["accel"], r["device"], is_earlier(r)) for r in scaling}):
            line = [r for r in scaling if (r["accel"], r["device"], is_earlier(r)) == (accel, device, before)]
            fewest = min(r["threads"] for r in line)  # one point per size: the line's smallest thread count
            pts = sorted((r["triangles"], r["build_ms"], 1e3 / r["mrays"]) for r in line if r["threads"] == fewest)
            n, build, ns_per_ray = zip(*pts)
            name = f"{accel} {device}" if several else accel
            if before:
                name += f" x{fewest} (earlier run)"
            for axes, y in ((a1, build), (a2, ns_per_ray)):
                drawn = axes.loglog(n, y, "o--" if before else "o-", label=f"{name} {_slope_label(n, y)}")
                if before:
                    drawn[0].set_markerfacecolor("none")
        a1.set_xlabel("triangles"), a1.set_ylabel("build ms"), a1.legend(fontsize=7)
        a2.set_xlabel("triangles"), a2.set_ylabel("ns per ray"), a2.legend(fontsize=7)
        fig.tight_layout()
        paths.append(out / "scaling.png")
        _save_plot(fig, paths[-1])
    return paths
