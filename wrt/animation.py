"""Animated stages rendered frame by frame, reusing the acceleration structure wherever the geometry allows.

Every frame reads the stage at its time code (:func:`wrt.load_usd` with ``time=``), so transforms, points,
cameras, lights and materials all follow their time samples. What the BVH does between two frames depends on what
changed (:func:`classify_change`):

========== =================================================== ===========================================
change     what moved                                          accelerator
========== =================================================== ===========================================
``static`` nothing that is traced                              reused as it is
``tlas``   instance or analytic-shape transforms only          TLAS rebuilt, every BLAS reused
``refit``  mesh vertices (same triangles)                      boxes refitted bottom-up (:mod:`wrt.bvh.refit`)
``build``  first frame, or the topology changed                built from scratch
========== =================================================== ===========================================

A refitted tree is correct but slows down as vertices drift from where the builder grouped them. The policy: refit
while the refitted tree's SAH cost stays within :data:`REFIT_SAH_LIMIT` of the cost it had when built, else
rebuild; tree by tree, so a two-level accelerator rebuilds only the BLASes past the limit (:func:`follow`). The
limit is a fixed number (not a timing), so the same frames always give the same trees and the same images;
``benchmarks/RESULTS.md`` records the refit and rebuild times it was chosen from.

Closest hits break exact ``t`` ties by the smaller triangle id, so a refitted and a rebuilt tree give the same
image.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import re
import threading
import time as _time
import warnings
from decimal import Decimal, InvalidOperation
from fractions import Fraction
from pathlib import Path

import numpy as np

from .errors import SceneError, TimeRangeWarning, flag
from .far_views import shown_across_renderers
from .image import write_atomically

REFIT_SAH_LIMIT = 1.2  # rebuild once refitting has made the tree's SAH cost 20% worse than when it was built
MAX_FRAMES = 1_000_000  # most frames one --frames range may give (a typo such as 1:1e9 would fill the memory)
FRAME_DIGITS = 12  # significant digits of a frame time, in parse_frames and in file names
MAX_EXACT_EXPONENT = 400  # decimal exponents read exactly; a double spans 1e-324 to 1e308
MAX_NAME_BYTES = 255  # longest file name (one path component) of Linux, macOS and Windows file systems

FRAME_PATTERN = re.compile(r"#+")


def parse_frames(text: str) -> list[float]:
    """Frame times of ``START:END[:STEP]`` (END included) or a single ``FRAME``.

    Raises:
        ValueError: for anything else, an empty range, a non-positive step, more than :data:`MAX_FRAMES` frames or a
            step too small to tell frames apart at :data:`FRAME_DIGITS` significant digits.
    """
    parts = str(text).split(":")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"--frames must be START:END[:STEP] or FRAME, got {text!r}") from None
    if len(values) == 1:
        values = [values[0], values[0]]
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise ValueError(f"--frames must be START:END[:STEP] or FRAME, got {text!r}")
    start, end, step = values[0], values[1], values[2] if len(values) == 3 else 1.0
    if step <= 0:
        raise ValueError(f"--frames step must be positive, got {step:g}")
    if end < start:
        raise ValueError(f"--frames range {text!r} is empty (END < START)")
    steps = (end - start) / step + 1e-9
    if not steps < MAX_FRAMES:  # infinite too: a subnormal step, or END - START past float64
        if not math.isfinite(steps):
            many = f"more than {MAX_FRAMES:,}"
        elif steps < 2**53:  # a float counts frames exactly up to here
            many = f"{int(math.floor(steps)) + 1:,}"
        else:  # its digits past the 16th are float noise: '1:2:1e-300' spelt out 300 of them
            many = f"about {steps:.3g}"
        raise ValueError(f"--frames {text!r} gives {many} frames; at most {MAX_FRAMES:,} in one run")
    if max(abs(start), abs(end)) >= 10.0**FRAME_DIGITS:  # frame_output refuses them too, naming itself, not --frames
        raise ValueError(f"--frames {text!r}: frames must lie within +-{10**FRAME_DIGITS - 1:,} (a file name spells a "
                         f"frame to {FRAME_DIGITS} significant digits)")
    count = int(math.floor(steps)) + 1
    frames = _exact_frames(parts, count, end, step)
    if len(set(map(_round_frame, frames))) < len(frames):
        raise ValueError(f"--frames step {step:g} is too small: frames differ only past {FRAME_DIGITS} digits")
    return frames


def _exact_frames(parts: list[str], count: int, end: float, step: float) -> list[float]:
    """The ``count`` frames ``START + k * STEP`` of ``parts`` (their text), each the double nearest the exact decimal
    sum (integer arithmetic over a common denominator), one within 1e-9 steps of END taken as END. Binary steps do
    not add up (0.2 + 6 * 0.3 is 1.9999999999999998), and rounding them to 12 digits missed time codes authored at
    thirds (0.333333333333 is not 1/3, USD's 0.3333333333333333: a sample there was a subframe late)."""
    start_q, step_q = (_decimal(text) for text in (parts[0], parts[2] if len(parts) == 3 else "1"))
    denominator = start_q.denominator * step_q.denominator // math.gcd(start_q.denominator, step_q.denominator)
    a = start_q.numerator * (denominator // start_q.denominator)
    b = step_q.numerator * (denominator // step_q.denominator)
    frames = [(a + k * b) / denominator for k in range(count)]  # int / int: correctly rounded
    return [end if abs(frame - end) <= 1e-9 * step else frame for frame in frames]


def _decimal(text: str) -> Fraction:
    """``text`` (a finite number float() reads) as the exact decimal it spells, or as the double float() reads for
    a decimal exponent past any double's (``1e-999999999`` is 0.0): Fraction would build a power of ten of that many
    digits (a billion: the run hung)."""
    spelt = text.strip().replace("_", "")
    try:
        exponent = Decimal(spelt).as_tuple().exponent
    except InvalidOperation:
        exponent = None
    if not isinstance(exponent, int) or abs(exponent) > MAX_EXACT_EXPONENT:
        return Fraction(float(text))
    return Fraction(spelt)


def _round_frame(frame: float) -> float:
    return float(f"{frame:.{FRAME_DIGITS}g}")


def frame_output(pattern, frame: float, stem: str | None = None) -> Path:
    """The file of ``frame``: the last run of ``#`` in ``pattern`` becomes the frame number zero-padded to its
    length (``out/frame_####.png`` -> ``out/frame_0012.png``); a pattern without ``#`` gets ``_####`` before its
    suffix. With ``stem``, ``{stem}`` in ``pattern`` becomes it once the frame is numbered, so a ``#`` in a scene's
    name (``shot#1.usda``) stays as it is. Fractional frames keep their fraction to :data:`FRAME_DIGITS` significant
    digits (``frame_0012.5.png``), so the frames of :func:`parse_frames` get files of their own.

    Raises:
        ValueError: for a ``frame`` that is not a finite number (NaN and inf were named ``frame_0nan.png``), one of
            more than :data:`FRAME_DIGITS` digits before the point, which 12 significant digits would name as another
            frame (1234567890123 as ``frame_1234567890120.png``; 1e300 had a 300-digit name), or one whose file name
            would be longer than :data:`MAX_NAME_BYTES`, or a folder's where the # are there (1e-300: the write
            failed after the render).
    """
    try:
        finite = not isinstance(frame, (bool, np.bool_, str, bytes)) and math.isfinite(float(frame))
    except (TypeError, ValueError):
        finite = False
    if not finite:
        raise ValueError(f"frame_output: frame must be a finite number, got {frame!r}")
    pattern = str(pattern)
    if "#" not in pattern:
        p = Path(pattern)
        pattern = str(p.with_name(f"{p.stem}_####{p.suffix}"))
    run = list(FRAME_PATTERN.finditer(pattern))[-1]
    # 12.5 -> "12.5", 3.0000000000000004 -> "3", 1.0000005 -> "1.0000005" (not "1.000001", the next frame's name)
    if _round_frame(abs(frame)) >= 10.0**FRAME_DIGITS:
        raise ValueError(f"frame_output: frame {frame!r}: more than {FRAME_DIGITS} digits before the point; a file "
                         f"name spells a frame to {FRAME_DIGITS} significant digits, so frames must lie within "
                         f"+-{10**FRAME_DIGITS - 1:,}")
    digits = np.format_float_positional(_round_frame(abs(frame)), trim="-")
    whole, _, fraction = digits.partition(".")
    number = ("-" if frame < 0 and digits != "0" else "") + whole.zfill(len(run.group()))
    if fraction:
        number += "." + fraction
    path = pattern[: run.start()] + number + pattern[run.end() :]
    path = Path(path if stem is None else path.replace("{stem}", stem))
    # Every part of the path: the number lands in a folder's name where the last run of # is there (shot_####/a.png).
    part = max(path.parts, key=lambda name: len(os.fsencode(name)))
    if len(os.fsencode(part)) > MAX_NAME_BYTES:
        raise ValueError(f"frame_output: frame {frame!r}: the name {part[:40]}... in its path is "
                         f"{len(os.fsencode(part))} bytes long, past the {MAX_NAME_BYTES} a file system takes for a "
                         "file or folder")
    return path


def _digest(*arrays) -> str:
    h = hashlib.sha1()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def topology_key(scene) -> str:
    """What must not change for a BVH to be refitted or its TLAS rebuilt: triangles, vertex counts per mesh, the
    prototype of every instance and the kinds of the analytic shapes. Cached on the scene: each frame's key is
    compared twice, once against the frame before and once against the next."""
    if ("topology",) not in scene._cache:
        _, indices = scene.geometry()
        counts = [len(m.points) for m in scene.meshes] + [len(m.points) for p in scene.prototypes for m in p.meshes]
        kinds = " ".join([s.kind for s in scene.shapes] + [s.kind for p in scene.prototypes for s in p.shapes])
        kinds = np.frombuffer(kinds.encode(), np.uint8)
        scene._cache[("topology",)] = _digest(indices, np.asarray(counts, np.int64), scene.instances.prototype, kinds)
    return scene._cache[("topology",)]


def classify_change(previous, scene) -> str:
    """``"build"``, ``"refit"``, ``"tlas"`` or ``"static"``: what the accelerator of ``previous`` must do to serve
    ``scene`` (see the module docstring)."""
    if previous is None or topology_key(previous) != topology_key(scene):
        return "build"
    if not np.array_equal(previous.geometry()[0], scene.geometry()[0]):
        return "refit"
    same_shapes = all(np.array_equal(a, b) for a, b in zip(_shape_state(previous), _shape_state(scene)))
    if not np.array_equal(previous.instances.to_world, scene.instances.to_world) or not same_shapes:
        return "tlas"
    return "static"


def _shape_state(scene) -> list:
    """Transform and parameters of every analytic shape, world-space ones first."""
    shapes = list(scene.shapes) + [s for p in scene.prototypes for s in p.shapes]
    return [a for s in shapes for a in (s.to_world, s.params)]


def tree_costs(accel) -> list[float]:
    """SAH cost of each tree of ``accel``: every BLAS of a two-level accelerator, the one tree of a flattened one
    (0 for an accelerator whose tree wrt does not keep, ``wp.Mesh``'s)."""
    from .bvh.stats import sah_cost

    trees = getattr(accel, "blas", None) or [getattr(accel, "bvh", None)]
    return [0.0 if t is None else float(sah_cost(t)) for t in trees]


def _past_limit(cost: float, built: float) -> bool:
    # Built over zero area (a grow-in from a scale of 0), any cost above 0 is past the limit: the tree of one
    # point is no tree for the grown mesh, and refitting it forever cost 3x the nodes of a fresh build.
    return cost > REFIT_SAH_LIMIT * built


def follow(accel, scene, change: str) -> tuple[str, int]:
    """Brings ``accel`` (built for an earlier frame) to ``scene`` for a ``change`` of :func:`classify_change` other
    than ``"build"``. Returns ``("static" | "tlas" | "refit", trees rebuilt)``, or ``("build", 0)`` when it cannot
    follow (the caller builds anew).

    The refit limit holds tree by tree: each BLAS of a two-level accelerator is built anew once its own cost passes
    :data:`REFIT_SAH_LIMIT` times its cost when built, and the others stay refitted. Summed over the trees, a small
    mesh that deforms wildly hid behind a large static one's cost (and when the sum did pass, the static tree was
    rebuilt with it)."""
    from .bvh.stats import sah_cost
    from .tlas import InstancedAccelerator

    if change == "static":
        return "static", 0
    built = getattr(accel, "built_sah", None)
    if isinstance(accel, InstancedAccelerator):
        if change == "refit" and built is None:
            return "build", 0
        try:
            rebuilt = accel.update(scene, refit_blas=change == "refit",
                                   rebuild=lambda b, tree: _past_limit(sah_cost(tree), built[b]))
        except ValueError:  # a prototype gained or lost all its instances, or an instance crossed 2^100
            return "build", 0
        for b in rebuilt:
            built[b] = float(sah_cost(accel.blas[b]))
        return change, len(rebuilt)
    if not hasattr(accel, "refit"):
        return "build", 0
    accel.refit(scene)  # one flattened tree: instance motion moves its vertices too
    if built is None or any(map(_past_limit, tree_costs(accel), built)):
        return "build", 0
    return "refit", 0


# The wrt.Renderer options a FrameRenderer passes on (its camera is its own, read at each frame's time), and its
# own wrt.load_usd ones. The frames of render_frames take their device from its devices, not from an option.
RENDERER_OPTIONS = ("width", "height", "device", "builder", "accel", "integrator", "max_depth", "ao_radius")
LOAD_OPTIONS = ("camera", "tessellate_gprims", "refine_level", "variants", "render_settings")
FRAME_OPTIONS = tuple(name for name in LOAD_OPTIONS + RENDERER_OPTIONS if name != "device")
# render_frames' own arguments, and render_frames_on_dask's
FRAMES_OWN = ("devices", "spp", "seed", "exposure", "progress", "log", "log_row", "on_row", "aov_pattern")
DASK_OWN = ("address", "n_workers", "spp", "seed", "exposure", "progress", "log", "log_row", "on_row", "aov_pattern",
            "task")


def check_frame_options(options: dict, what: str, valid: tuple) -> None:
    """Raises ``TypeError`` naming the first of ``options`` not in ``valid`` and the name meant: a typo
    (``widht=8``) failed at the first frame's render, after its load, as 'Renderer.__init__() got an unexpected
    keyword argument', and ``render_frames(device=...)`` as 'got multiple values for keyword argument'."""
    from .errors import did_you_mean

    unknown = [name for name in options if name not in valid]
    if unknown:
        raise TypeError(f"{what} has no option {unknown[0]!r}{did_you_mean(unknown[0], valid)}; options: "
                        f"{', '.join(valid)}")


class FrameRenderer:
    """Renders time samples of one stage, keeping the accelerator from frame to frame.

    Args:
        path: the USD file.
        camera: camera prim path (read at every frame's time), a :class:`wrt.Camera`, or ``None``.
        tessellate_gprims, refine_level, variants, render_settings: :func:`wrt.load_usd` options, applied to every
            frame (in worker processes too: they travel with the frame's task).
        **options: :class:`wrt.Renderer` options (``width``, ``height``, ``device``, ``builder``, ``accel``,
            ``integrator``, ``max_depth``, ``ao_radius``).

    Attributes:
        log: one dict per rendered frame: ``frame``, ``change`` (what the BVH did), ``rebuilt_trees`` (trees built
            anew: all of them on a ``build``, those past the refit limit on a ``refit``), ``load_ms``, ``update_ms``
            (build, refit or TLAS rebuild), ``render_ms``, ``dropped_samples`` (the frame's samples left out as not
            finite: :attr:`wrt.Renderer.dropped_samples`; their warning is said once over the frames),
            ``image_size`` (``[width, height]``), ``drawn_camera`` (``camera /Path``: :func:`warn_mixed_sizes`) and
            ``view`` (on a stage with render settings, where the camera and size came from:
            :func:`wrt.render.view_summary`; else None).
        last_warnings: the ``warnings.WarningMessage`` of every warning the last frame rendered (or tried) gave, in
            order, those said at an earlier frame and so not shown again included.
    """

    def __init__(self, path, *, camera=None, tessellate_gprims=False, refine_level=0, variants=None,
                 render_settings=None, **options):
        check_frame_options(options, "FrameRenderer", LOAD_OPTIONS + RENDERER_OPTIONS)
        self.path = os.fspath(path)
        self.camera = camera
        self.load_options = {"tessellate_gprims": tessellate_gprims, "refine_level": refine_level,
                             "variants": variants, "render_settings": render_settings}
        self.options = options
        self.log = []
        self._scene = None
        self._frames = None  # the StageFrames that loads every frame: the stage and unchanged meshes kept
        # Warnings said once over the frames (said_as): far-view ones name the camera's distance, a camera that sees
        # nothing the scene's extent, each image's its own counts, so every frame said them again.
        self._said_once = set()
        self.last_warnings = []  # every warning of the last frame, those said at earlier frames too

    def render(self, frame: float, spp: int = 1, seed: int = 0, file=None):
        """The :class:`wrt.Image` of time code ``frame``. Each warning is said once over the frames; every one the
        frame gave, said before or not, is in :attr:`last_warnings` (for its log row: a camera that sees nothing at
        frames 2 and 3 was in frame 2's row alone, as the frames' Renderers shared what was said).

        ``file``, when given, is where the image will be saved: an ``.exr`` whose header cannot state the frame's
        pixel aspect raises ValueError naming it before the render (:meth:`wrt.Image.save` refused it only after)."""
        with _frame_warnings(self._said_once, leave_out=()) as raised:
            self.last_warnings = raised  # the list the frame's warnings are recorded in
            return self._render(frame, spp, seed, file)

    def _render(self, frame: float, spp: int, seed: int, file=None):
        from .render import Renderer, view_summary
        from .usd_frames import StageFrames

        start = _time.perf_counter()
        if self._frames is None:
            self._frames = StageFrames(self.path, **self.load_options)
        scene = self._frames.load(frame)
        loaded = _time.perf_counter()
        settings = scene.render_settings
        if settings is not None and len(settings.products) > 1 and self.camera is None:
            # As a still render says (wrt render): the frames drew the first product's view without a word.
            warnings.warn(f"{os.path.basename(self.path)}: {settings.path} has {len(settings.products)} "
                          f"RenderProducts; each frame is the first's, {settings.product} (--products DIR --time T "
                          "writes them all at one time)", stacklevel=3)
        _check_first_camera(scene, self.camera, frame)
        # Forgotten until this frame is done: following refits the accelerators in place, so after a frame that
        # failed past this point (a camera missing at its time, out of memory) they hold its vertices, not the last
        # good frame's, and a later frame equal to that one was drawn with them as 'static'.
        previous, self._scene = self._scene, None
        change = classify_change(previous, scene)
        rebuilt = 0  # trees built anew
        if change != "build":
            scene.drop_stale_caches()  # settles the new scene's record first, so the accelerators moved in stay
            accels = {k: v for k, v in previous._cache.items() if k[0] == "accel"}
            for key, accel in accels.items():
                done, count = follow(accel, scene, change)
                if done == "build":
                    change = "build"
                    break
                scene._cache[key] = accel
                change, rebuilt = done, rebuilt + count
            if change == "build":
                for key in accels:
                    scene._cache.pop(key, None)
        # A Renderer of its own for what was said: each warning that applies to this frame is given (once), for its
        # log row; render() says each once over the frames.
        with shown_across_renderers(set()):
            renderer = Renderer(scene, camera=self.camera, **self.options)
        if change == "build":
            renderer.accel.built_sah = tree_costs(renderer.accel)
            rebuilt = len(renderer.accel.built_sah)
        updated = _time.perf_counter()
        if file is not None and os.fspath(file).lower().endswith(".exr"):
            from .image import check_exr_pixel_aspect

            check_exr_pixel_aspect(renderer.camera.rendered_pixel_aspect(renderer.width, renderer.height), file)
        image = renderer.render(spp=spp, seed=seed)
        self._scene = scene
        self.log.append(
            {
                "frame": frame,
                "change": change,
                "rebuilt_trees": rebuilt,
                "load_ms": 1e3 * (loaded - start),
                "update_ms": 1e3 * (updated - loaded),
                "render_ms": renderer.timers["render"][0],
                # The frame's own count: its warning is said once over the frames (Renderer._warn_once).
                "dropped_samples": renderer.dropped_samples,
                # The frame's size and camera: one side given, a camera's time-sampled aperture sizes each frame
                # anew (warn_mixed_sizes).
                # Named apart from the options' width, height and camera in --log rows (as given, null: the default),
                # which --resume compares.
                "image_size": [image.width, image.height],
                "drawn_camera": _camera_label(scene, self.camera),
                # Where the camera and size came from, as a still render's progress line says it (None: no render
                # settings): wrt render says each view of its frames once.
                "view": None if settings is None else view_summary(
                    settings, renderer.camera, image.width, image.height, self.camera, self.options.get("width"),
                    self.options.get("height")),
            }
        )
        return image


def _check_first_camera(scene, camera, frame: float) -> None:
    """SceneError naming the camera, the frame and why, where ``camera`` is None, the render settings name none and
    the stage's first camera, which draws the frames, cannot be used at this frame's time (a zero focal length, a
    transform that is not finite: ``Scene.skipped_cameras``) and is animated (one bad at every time draws no frame,
    and the next camera draws them all, as it draws a still render). The frame was drawn from the next camera, or
    from one wrt frames the scene with, under a warning that only said the camera was skipped: a view unlike the other
    frames', found when the animation is watched. Refused, the frame gets an error row and no file, as a frame whose
    named camera is bad at its time does; the other frames go on."""
    first = getattr(scene, "_first_camera_skipped", None)
    settings = scene.render_settings
    if camera is None and first is not None and (settings is None or settings.camera is None):
        raise SceneError(f"the stage's first camera, which draws the frames, cannot be used at frame {frame:g}: "
                         f"{scene.skipped_cameras[first]}; the frame is not drawn from another view (camera= or "
                         "--camera chooses one for every frame)", path=scene.source, prim=first)


def _camera_label(scene, camera) -> str:
    """``camera /Path`` of the stage camera a frame was drawn through, or words for the one wrt frames a scene with."""
    from .render import camera_source

    source = camera_source(scene, camera)
    return source.label() if source is not None else "the camera wrt frames the scene with"


def warn_mixed_sizes(path, rows) -> None:
    """One warning where the frames of a run have images of different sizes (one side given, the other from a camera
    aperture that is time-sampled): each frame is the image a fresh render of its time gives, as documented, but a
    sequence of mixed sizes does not play or encode as one, and nothing said so. Names the camera and each size with
    its first frame."""
    first = {}
    for row in sorted((row for row in rows if "image_size" in row), key=lambda row: row["frame"]):
        first.setdefault(tuple(row["image_size"]), row)
    if len(first) > 1:
        cameras = " and ".join(dict.fromkeys(row["drawn_camera"] for row in first.values()))
        sizes = ", ".join(f"{w}x{h} from frame {row['frame']:g}" for (w, h), row in first.items())
        # On a stage with render settings the size is theirs (the camera's aperture plays no part): it said the
        # camera's aspect for a time-sampled resolution or dataWindowNDC.
        cause = ("each frame takes its render settings' resolution and dataWindowNDC at its time" if
                 any(row.get("view") for row in first.values()) else
                 f"the size not given follows {cameras}'s aperture aspect at each frame")
        warnings.warn(f"{os.path.basename(path)}: the frames have {len(first)} image sizes ({sizes}): {cause}; give "
                      "both --width and --height (or width and height) for one size", UserWarning, stacklevel=3)


def warn_frames_outside_range(path, frames) -> None:
    """One :class:`wrt.errors.TimeRangeWarning` naming the ``frames`` outside the stage's authored time range and the
    range. Every frame's load warned about its own time, so 1000 frames past the end were 1000 lines; the renders of
    a frame range leave those out (:func:`_frame_warnings`)."""
    from .usd_stage import outside_range, stage_time_range

    found = stage_time_range(path)
    if found is None:
        return
    frames = sorted(frames)
    if found[0] > found[1]:  # a reversed range holds no time: every frame once (each was counted on both sides)
        spans = [frames] if frames else []
    else:
        spans = [side for side in ([f for f in frames if f < found[0]], [f for f in frames if f > found[1]]) if side]
    n = sum(map(len, spans))
    if n:
        named = " and ".join(f"{s[0]:g}" if len(s) == 1 else f"{s[0]:g} to {s[-1]:g}" for s in spans)
        what = f"frame {named} is" if n == 1 else f"frames {named} ({n} of {len(frames)}) are"
        warnings.warn(f"{os.path.basename(path)}: {what} {outside_range(*found)}", TimeRangeWarning, stacklevel=3)


# Frames recording their warnings (_frame_warnings), over all threads: how many are inside, the filters and hook the
# first in found (put back by the last out), and each thread's frames (thread id -> [(its list, leave_out), ...], a
# nested frame last). Each frame had its own warnings.catch_warnings, which swaps the process's hook and filters: two
# frames in two threads ending in the order they began (A in, B in, A out, B out) left A's recorder as the process's
# hook for good, every later warning of the process recorded into A's finished list and never shown, and a warning A
# gave while B was inside went into B's list. The recorder passes a warning of a thread with no frame inside on to the
# hook there was before, so one put back late (by a catch_warnings of another thread) loses nothing.
_FRAME_CAPTURE = {"lock": threading.Lock(), "inside": 0, "filters": None, "hook": None, "records": {}}


def _record_frame_warning(message, category, filename, lineno, file=None, line=None):
    """``warnings.showwarning`` while frames render: a warning given in a thread rendering one is recorded in its
    innermost frame's list, unless one of its frames leaves its class out; any other is shown by the hook there was
    before, as it would have been."""
    records = _FRAME_CAPTURE["records"].get(threading.get_ident())
    if not records:
        _FRAME_CAPTURE["hook"](message, category, filename, lineno, file, line)
    elif not any(issubclass(category, left) for _, leave_out in records for left in leave_out):
        records[-1][0].append(warnings.WarningMessage(message, category, filename, lineno, file, line))


def _every_time_filters() -> None:
    """Makes the process's filters that show a warning now and then (``default``, ``module``, ``once``, and the
    default action where no filter matches) show it every time, for each frame to record it."""
    now_and_then = ("default", "module", "once")
    warnings.filters[:] = [("always" if f[0] in now_and_then else f[0], *f[1:]) for f in warnings.filters]
    last = warnings.defaultaction  # for a warning no filter matches
    warnings.simplefilter("always" if last in now_and_then else last, append=True)


@contextlib.contextmanager
def _frame_warnings(shown: set, leave_out=(TimeRangeWarning,)):
    """Leaves out the warnings of the classes ``leave_out`` inside (by default the :class:`TimeRangeWarning` of each
    frame's load: the run gave one for all of them) and gives each other warning once per run, what it is said by
    (:func:`said_as`) kept in ``shown``: every frame makes a new Renderer, whose warnings (a camera that sees
    nothing, no light) came again at every frame, as the multi-device run does not.

    The caller's filters still decide inside, only those that show a warning now and then showing it every time (to
    be recorded): one they make an error raises where it is given, failing the frame. Under an "always" filter for
    all, a user's ``-W error`` raised it after the frame, its file written, from here, ending the run. Frames in
    several threads each record their own thread's warnings (:data:`_FRAME_CAPTURE`); while any is inside, the
    filters are the every-time ones for every thread.

    Yields the list the frame's warnings are recorded in (complete once the block is left), for its log row: all of
    them, those said before included."""
    capture, ident, raised = _FRAME_CAPTURE, threading.get_ident(), []
    with capture["lock"]:
        if not capture["inside"]:
            capture["filters"] = list(warnings.filters)
            _every_time_filters()
            if warnings.showwarning is not _record_frame_warning:
                capture["hook"] = warnings.showwarning
            warnings.showwarning = _record_frame_warning
        capture["inside"] += 1
        capture["records"].setdefault(ident, []).append((raised, tuple(leave_out)))
    try:
        yield raised
    finally:
        with capture["lock"]:
            records = capture["records"][ident]
            records.pop()
            if not records:
                del capture["records"][ident]
            capture["inside"] -= 1
            if not capture["inside"]:
                warnings.filters[:] = capture["filters"]
                # The registries' "said already" marks, made under the others, go (as catch_warnings does; Python's
                # own, private: left where a later Python lacks it, where only marks of "always" filters, none, remain)
                mutated = getattr(warnings, "_filters_mutated", None)
                if callable(mutated):
                    mutated()
                if warnings.showwarning is _record_frame_warning:
                    # (a hook another thread put in place meanwhile, as logging.captureWarnings does, stays)
                    warnings.showwarning = capture["hook"]
        for w in raised:
            said = said_as(str(w.message), w.category, getattr(w.message, "said_once_key", None))
            if said not in shown:
                shown.add(said)
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)


def said_as(message: str, category, key) -> tuple:
    """What a run says a warning once by: its ``key`` where it has one (``said_once_key`` of
    :func:`wrt.errors.warn_keyed`: its words name a frame's own counts or distances), else its words and
    ``category``."""
    return ("key", key) if key is not None else ("words", message, category)


def frame_warnings(messages) -> list[str]:
    """The ``warnings`` of a frame's log row: each message the frame raised, once, in order. On screen a warning is
    said once per run, without its frame (a camera skipped at frame 6 alone, NaN instances at frame 7: nothing said
    which frame); the rows say which frames gave it."""
    return list(dict.fromkeys(messages))


def pending_frames(frames, output, resume: bool, stem: str | None = None, aov_pattern=None) -> list[tuple[float, Path]]:
    """``(frame, file)`` of every frame to render (``stem`` as :func:`frame_output` takes it); with ``resume``,
    frames whose file exists and is not empty are left out (files are written whole or not at all:
    :func:`wrt.image.write_atomically`), and their AOV files too where ``aov_pattern`` names them
    (:func:`aov_files`)."""
    resume = flag(resume, "pending_frames: resume")  # by its truth, "false" left out the frames already written

    def written(p: Path) -> bool:
        return p.is_file() and p.stat().st_size > 0

    def done(f, p: Path) -> bool:
        aovs = aov_files(aov_pattern, f).values() if aov_pattern is not None else ()
        return written(p) and all(map(written, aovs))

    jobs = [(f, frame_output(output, f, stem)) for f in frames]
    return [(f, p) for f, p in jobs if not (resume and done(f, p))]


def check_jobs(jobs) -> list[tuple]:
    """``jobs`` of :func:`render_frames` as a list of ``(frame, Path)``, checked before a frame is rendered.

    Raises:
        TypeError: naming the job that is no ``(frame number, file path)`` pair; a generator or a dict failed in
            ``len()`` or unpacking ('cannot unpack non-iterable int object'), a text frame in a comparison.
        ValueError: a file whose format :meth:`wrt.Image.save` cannot write, found only at the first frame's save; a
            frame that is NaN or infinite, which stopped the run at its load (``time must be a finite time code``)
            naming no job, after the frames before it; a file given twice, whose later frame's image replaced the
            earlier's without a word. A frame may be given twice (its ``.png`` and its ``.npy``): each job writes
            its own file.
    """
    from collections.abc import Mapping

    from .image import check_image_path

    if isinstance(jobs, (str, bytes, os.PathLike, Mapping)) or not hasattr(jobs, "__iter__"):
        hint = " (a dict: list(jobs.items()))" if isinstance(jobs, Mapping) else ""
        raise TypeError(f"render_frames: jobs must be a list of (frame, file) pairs, as pending_frames makes them"
                        f"{hint}, got {type(jobs).__name__}")
    checked = []
    for k, job in enumerate(jobs):
        if isinstance(job, (str, bytes)) or not hasattr(job, "__len__") or len(job) != 2:
            raise TypeError(f"render_frames: jobs[{k}] must be a (frame, file) pair, as pending_frames makes them, "
                            f"got {job!r}")
        frame, file = job
        if isinstance(frame, (bool, np.bool_)) or not isinstance(frame, (int, float, np.integer, np.floating)):
            raise TypeError(f"render_frames: jobs[{k}]: the frame must be a number (a time code), got "
                            f"{type(frame).__name__} {frame!r}")
        try:
            finite = math.isfinite(frame)
        except OverflowError:  # an int past float's range
            finite = False
        if not finite:  # no time code: the frames before it were rendered, then the load stopped the run
            raise ValueError(f"render_frames: jobs[{k}]: the frame must be a finite number (a time code), got "
                             f"{frame!r}")
        checked.append((frame, check_image_path(file)))
    files = {}
    for k, (frame, file) in enumerate(checked):
        j = files.setdefault(file.resolve(), k)
        if j != k:
            raise ValueError(f"render_frames: jobs[{k}] (frame {frame!r}) writes {file}, as jobs[{j}] (frame "
                             f"{checked[j][0]!r}) does; give each job a file of its own")
    return checked


def aov_files(pattern, frame: float) -> dict[str, Path]:
    """``{AOV name: file}`` of the AOV arrays of ``frame``: ``{name}`` in ``pattern`` becomes each name of
    :data:`wrt.render.AOV_NAMES`, its last run of ``#`` the frame number (:func:`frame_output`), e.g.
    ``aovs/{name}_####.npy`` -> ``aovs/depth_0012.npy``."""
    from .render import AOV_NAMES

    return {name: frame_output(str(pattern).replace("{name}", name), frame) for name in AOV_NAMES}


def check_aov_pattern(pattern, jobs: list) -> None:
    """ValueError unless ``pattern`` (see :func:`aov_files`) names ``.npy`` files with ``{name}``, and the AOV files
    of ``jobs`` (:func:`check_jobs`'s) are no image's and no other frame's (a frame's two jobs write the same ones)."""
    if not isinstance(pattern, (str, os.PathLike)) or "{name}" not in os.fspath(pattern) or \
            Path(os.fspath(pattern)).suffix.lower() != ".npy":
        raise ValueError(f"render_frames: aov_pattern must be a .npy file name with {{name}} (the AOV) and a run of "
                         f"# (the frame number), e.g. 'aovs/{{name}}_####.npy', got {pattern!r}")
    images = {file.resolve(): frame for frame, file in jobs}
    owner = {}
    for frame, _ in jobs:
        for file in aov_files(pattern, frame).values():
            key = file.resolve()
            if owner.setdefault(key, frame) != frame or key in images:
                other = f"frame {images[key]:g}'s image" if key in images else f"an AOV file of frame {owner[key]:g}"
                raise ValueError(f"the AOV file {file} of frame {frame:g} would also be {other}; give the images or "
                                 "the AOV files other names")


def _written_aovs(image, pattern, frame: float) -> list[str]:
    """Writes ``image``'s AOV arrays of ``frame`` (:func:`aov_files`); their paths."""
    return [str(image.save_aov(name, file)) for name, file in aov_files(pattern, frame).items()]


def render_frames(path, jobs, *, devices=("cpu",), spp=1, seed=0, exposure=0.0, progress=False, log=None,
                  log_row=None, on_row=None, aov_pattern=None, **options) -> list[dict]:
    """Renders ``jobs`` (``(frame, file)`` pairs, see :func:`pending_frames`) and writes each image as it is done.

    With one device the frames are rendered here, in order, by one :class:`FrameRenderer`. With several, each
    device gets a worker process of its own (Python threads would share one interpreter lock for the host-side
    work, and Warp's current device is global to a process); a worker takes the next frame whenever it is free and
    sends back the encoded file, which is written here. A frame's image does not depend on where it was rendered.

    Args:
        path: the USD file.
        jobs: ``(frame, file)`` pairs (a list or any iterable); the file suffix picks the format (``.png``,
            ``.exr``, ``.npy``). A job that is no such pair, or a format that cannot be written, raises before any
            frame is rendered (:func:`check_jobs`).
        devices: Warp devices to spread the frames over.
        spp: samples per pixel.
        seed: seed of every random decision (the same for every frame).
        exposure: PNG exposure (see :meth:`wrt.Image.save`).
        progress: show a progress bar.
        log: a JSON-lines file each row is appended to as its frame finishes (see :class:`LogRows`), or None.
        log_row: what of a row is written to ``log`` (see :class:`LogRows`).
        on_row: called with each row as its frame finishes (``wrt render`` says the first frame's view then, not
            once every frame is drawn), or None.
        aov_pattern: also write every AOV of each frame as a ``.npy`` array (:meth:`wrt.Image.save_aov`) to this
            pattern's file (:func:`aov_files`: ``{name}`` the AOV, the last run of ``#`` the frame number), or None.
        **options: :class:`FrameRenderer` options.

    Returns:
        The log rows of every frame (see :attr:`FrameRenderer.log`) with ``device``, ``output``, ``aov_files`` (none
        without ``aov_pattern``), ``seconds``
        (render and encode), ``finished_at`` (``time.time()``) and ``warnings`` (:func:`frame_warnings`), in the
        order the frames finished. A frame whose
        stage is bad at its time (a :class:`wrt.SceneError`: NaN points, an invalid camera) or whose file cannot be
        written (an OSError: a full disk) gets an error row (:func:`frame_error_row`) and no file, and the other
        frames go on, as the scenes of a ``wrt render`` batch do; other errors (bad options, no memory left, Ctrl-C)
        stop the run.
    """
    from tqdm import tqdm

    from .image import check_exposure

    check_exposure(exposure)  # before the first frame, not at its save
    progress = flag(progress, "render_frames: progress")  # by its truth, "false" showed the bar
    from .bvh.common import resolve_device

    if isinstance(devices, str) or not len(devices):  # "cuda:0" was read as devices 'c', 'u', ...; () as 0 workers
        raise ValueError(f"render_frames: devices must be a non-empty list of Warp devices, such as "
                         f"{[devices or 'cpu']!r}, got {devices!r}")
    for device in devices:  # a bad name failed only in a spawned worker, seconds later, under a started progress bar
        resolve_device(device)
    check_frame_options(options, "render_frames", FRAMES_OWN + FRAME_OPTIONS)
    path = os.fspath(path)
    jobs = check_jobs(jobs)
    if aov_pattern is not None:
        check_aov_pattern(aov_pattern, jobs)
    warn_frames_outside_range(path, [frame for frame, _ in jobs])
    rows = LogRows(log, log_row, on_row)
    with tqdm(total=len(jobs), unit="frame", desc="wrt frames", disable=not progress) as bar:
        if len(devices) == 1:
            renderer = FrameRenderer(path, device=devices[0], **options)
            shown = set()
            for frame, file in jobs:
                start = _time.perf_counter()
                try:
                    with _frame_warnings(shown) as raised:
                        image = renderer.render(frame, spp=spp, seed=seed, file=file)
                        written = image.save(file, exposure=exposure)
                        aovs = [] if aov_pattern is None else _written_aovs(image, aov_pattern, frame)
                except (SceneError, Warning) as e:  # a Warning: one the caller's filters make an error
                    rows.append(frame_error_row(frame, file, e, str(devices[0])))
                except OSError as e:  # a full disk at its write: the frame's error, as a batch of scenes logs one
                    rows.append(frame_write_error_row(frame, file, e, str(devices[0])))
                except KeyboardInterrupt:  # as a batch of scenes logs the scene cut short; the frame wrote no file
                    rows.append(frame_interrupted_row(frame, file, str(devices[0]), _time.perf_counter() - start))
                    raise
                except Exception as e:
                    _log_stopping_frame(rows, frame, file, e, str(devices[0]))
                    raise
                else:
                    said = [*renderer.last_warnings, *raised]  # the frame's, and its save's
                    row = dict(renderer.log[-1], device=str(devices[0]), output=str(written), aov_files=aovs,
                               warnings=frame_warnings(str(w.message) for w in said))
                    rows.append(dict(row, seconds=_time.perf_counter() - start, finished_at=_time.time()))
                bar.update(1)
            return rows
        import concurrent.futures
        import multiprocessing

        with _children_ignore_ctrl_c():
            claims = multiprocessing.get_context("spawn").Manager().Queue()
        for device in devices:
            claims.put(str(device))
        write = _frame_writer(rows, aov_pattern)
        pool = concurrent.futures.ProcessPoolExecutor(
            len(devices), mp_context=multiprocessing.get_context("spawn"), initializer=_claim_device, initargs=(claims,)
        )
        futures = {}
        try:
            with _children_ignore_ctrl_c():  # the workers start at the submits
                futures = {pool.submit(render_frame_task, _task(path, frame, file, spp, seed, exposure, options,
                                                                aov_pattern is not None)):
                           (frame, file) for frame, file in jobs}
            for future in concurrent.futures.as_completed(futures):
                result = {}  # the frame sent back: its row names the worker's device, which an OSError does not
                try:
                    result = future.result()
                    write(result, futures[future][1])
                except SceneError as e:
                    rows.append(frame_error_row(*futures[future], e, getattr(e, "device", None)))
                except OSError as e:  # its write failed (a full disk): as in a serial run, the others go on
                    device = getattr(e, "device", None) or result.get("row", {}).get("device")
                    rows.append(frame_write_error_row(*futures[future], e, device))
                except Exception as e:
                    _log_stopping_frame(rows, *futures[future], e)
                    raise
                bar.update(1)
        except BaseException as e:
            # Ctrl-C or a failing frame: the frames written so far stay. Leaving the pool with shutdown(wait=True)
            # rendered every queued frame first and threw the images away.
            # Handed to a worker (ProcessPoolExecutor marks those in its call queue for the next free workers, up to
            # the workers + 1, running too) or sent back: those not written were cut short.
            started = [futures[f] for f in futures if f.running() or f.done()]
            _stop_pool(pool)
            if isinstance(e, KeyboardInterrupt):
                logged = _logged_jobs(rows)
                for frame, file in sorted(job for job in started if (float(job[0]), str(job[1])) not in logged):
                    rows.append(frame_interrupted_row(frame, file))
            raise
        pool.shutdown()
    return rows


class LogRows(list):
    """The log rows of a frame run, each also appended to the JSON-lines file ``log`` (when not None) the moment it
    is added, in strict JSON: an interrupted run (Ctrl-C, a frame that stops it) keeps the rows of every frame that
    finished, where rows written at the end were lost with the run. ``log_row``, when given, makes the row written
    of the row added (``wrt render`` adds its run, options and the image's modification time: see
    :mod:`wrt.render_log`). ``on_row``, when given, is called with each row added, after its log line."""

    def __init__(self, log=None, log_row=None, on_row=None):
        super().__init__()
        self.log = None if log is None else Path(log)
        self.log_row = log_row
        self.on_row = on_row
        if self.log is not None:
            from .image import check_folder_path
            from .render_log import check_appendable

            # Before the first frame, as wrt render checks --log: a folder, or a file that is no log, failed only at
            # the first row, after that frame was rendered and written ('[Errno 21] Is a directory').
            if self.log.is_dir():
                raise IsADirectoryError(f"log {self.log}: a directory; give the log a file name, e.g. "
                                        f"{self.log / 'frames.jsonl'}")
            check_appendable(self.log, "log")
            # A file where its folder goes: refused naming the log, not in mkdir's words ('File exists: notes.txt').
            check_folder_path(self.log.parent, f"log {self.log}: its folder")
            self.log.parent.mkdir(parents=True, exist_ok=True)

    def append(self, row: dict) -> None:
        super().append(row)
        if self.log is not None:
            from .render_log import append_row
            from .strict_json import strict_json

            append_row(self.log, strict_json(row if self.log_row is None else self.log_row(row)))
        if self.on_row is not None:
            self.on_row(row)


def _log_stopping_frame(rows: LogRows, frame: float, file, error: Exception, device: str | None = None) -> None:
    """Adds the error row of a frame whose error stops the run (no memory left, a fault in wrt): the log said nothing
    of it, only that the frames before had finished. Where the row cannot be written either, the frame's own error
    is the one that goes on."""
    row = frame_write_error_row(frame, file, error, device) if isinstance(error, OSError) else \
        frame_error_row(frame, file, error, device)
    with contextlib.suppress(Exception):
        rows.append(row)


def frame_write_error_row(frame: float, file, error: OSError, device: str | None = None) -> dict:
    """:func:`frame_error_row` of an OSError (its image's write failed: a full disk), its ``error`` read as a batch of
    scenes' rows read it (``OSError: out/f_2.npy: no space left on device``)."""
    row = frame_error_row(frame, file, error, device)
    if error.strerror and error.filename is not None:
        row["error"] = f"{type(error).__name__}: {error.filename}: {error.strerror[:1].lower()}{error.strerror[1:]}"
    return row


def frame_error_row(frame: float, file, error: Exception, device: str | None = None) -> dict:
    """The log row of a frame that failed: ``frame``, ``output`` (the file it did not write), ``error``
    (``"SceneError: "``, or the class of a warning the caller's filters made an error or of an error that stopped
    the run, and the first line of the message, as the rows of a batch of scenes), ``device`` (where it ran, as
    rendered frames' rows name it; left out when unknown) and ``finished_at``."""
    kind = "SceneError" if isinstance(error, SceneError) else type(error).__name__
    row = {"frame": float(frame), "output": str(file), "error": f"{kind}: {str(error).splitlines()[0]}"}
    if device is not None:
        row["device"] = str(device)
    return dict(row, finished_at=_time.time())


def frame_interrupted_row(frame: float, file, device: str | None = None, seconds: float | None = None) -> dict:
    """The log row of a frame that Ctrl-C cut short: ``frame``, ``output`` (the file it did not write), ``status``
    ``"interrupted"`` (as the row of a scene a batch was rendering), ``device`` and ``seconds`` where known, and
    ``finished_at``. ``--resume`` renders such a frame again."""
    row = {"frame": float(frame), "output": str(file), "status": "interrupted"}
    if device is not None:
        row["device"] = str(device)
    if seconds is not None:
        row["seconds"] = seconds
    return dict(row, finished_at=_time.time())


def _logged_jobs(rows: list) -> set:
    """``(frame, file)`` of each job ``rows`` has a row of: by job, as a frame may have two (a .png and a .npy of
    it), and one of them written left the other, cut short, without a row."""
    return {(float(row["frame"]), str(row["output"])) for row in rows}


@contextlib.contextmanager
def _children_ignore_ctrl_c():
    """Processes started inside start with Ctrl-C ignored: an ignored signal stays ignored across exec, and Python
    then installs no KeyboardInterrupt handler. A worker (or the Manager's server) hit by the terminal's SIGINT while
    still importing, before :func:`_claim_device` ignores it, printed a traceback of its own. The parent ignores it
    too meanwhile: the submits and the Manager's start take milliseconds."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():  # signal.signal works in the main thread only
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _stop_pool(pool) -> None:
    """Cancels the frames ``pool`` has not started and ends its workers at once, mid-frame."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)  # returns at once: no worker is left to finish a frame


def _frame_writer(rows: list, aov_pattern=None):
    """``write(result, file)`` for results of :func:`render_frame_task`: writes the encoded image to ``file``, its
    job's, and its AOV arrays where ``aov_pattern`` names them (:func:`aov_files`), and appends the frame's log row,
    with ``output`` and ``aov_files``, to ``rows`` (an error row for a frame that failed). By
    its job, not its frame: two jobs of one frame (a .png and an .exr of it) were both written to the last one's
    file, the other never written, where a serial run writes both."""
    said = set()  # the warnings shown: by what a Renderer says each once by (its key), else by their words

    def write(result: dict, file) -> None:
        row, file = result["row"], Path(file)
        if "error" in result:  # the frame's stage is bad at its time (render_frame_task)
            rows.append(frame_error_row(row["frame"], file, result["error"], row.get("device")))
            return
        try:
            for message, category, key in result.get("warnings", ()):
                # Shown here once, however many workers and frames raised it, in its own class: all came back as
                # UserWarning, which the caller's filters of another class (ignore, error) then missed. By its key
                # where it has one: each worker's Renderers say it once, in words of their own frame (a count, a
                # distance), so N workers showed it N times.
                as_said = said_as(message, category, key)
                if as_said not in said:
                    warnings.warn(message, warning_class(category), stacklevel=2)
                    said.add(as_said)  # after: one the caller's filters make an error fails each frame that gives it
        except Warning as e:  # the caller's filters make it an error: the frame failed, as in a serial run
            rows.append(frame_error_row(row["frame"], file, e, row.get("device")))
            return
        done = dict(row, output=str(file), warnings=frame_warnings(w[0] for w in result.get("warnings", ())))
        aovs = {} if aov_pattern is None else aov_files(aov_pattern, row["frame"])
        with _ctrl_c_held():  # a Ctrl-C between the two left a written image logged as interrupted
            write_atomically(file, lambda partial: partial.write_bytes(result["data"]))
            for name, data in result.get("aovs", {}).items():
                write_atomically(aovs[name], lambda partial, data=data: partial.write_bytes(data))
            done["aov_files"] = [str(aovs[name]) for name in result.get("aovs", {})]
            rows.append(done)

    return write


@contextlib.contextmanager
def _ctrl_c_held():
    """Ctrl-C (SIGINT) held back inside and handed to the handler it had on leaving (KeyboardInterrupt, as a rule),
    where this is the main thread: a frame's image and its log row are written together or not at all. Ctrl-C sent
    the moment an image appeared (as a user watching the folder does) landed between the two: the image stayed, its
    row said interrupted. (A Python-level handler: blocking the signal in this thread alone lets another thread of
    the process take it.)"""
    import signal
    import threading

    previous = signal.getsignal(signal.SIGINT) if threading.current_thread() is threading.main_thread() else None
    if not callable(previous):  # not the main thread, or Ctrl-C ignored or left to the system
        yield
        return
    held = []
    signal.signal(signal.SIGINT, lambda signum, frame: held.append(frame))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if held:
            previous(signal.SIGINT, held[0])


_PROCESS_DEVICE = None  # the device a worker process of render_frames claimed


def _claim_device(claims) -> None:
    """Initializer of a :func:`render_frames` worker process: takes a device, and leaves Ctrl-C to the parent (the
    terminal sends it to every process of the group; the parent ends the workers itself, without a traceback from
    each of them)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import threading

    from tqdm import tqdm

    tqdm.set_lock(threading.RLock())  # not tqdm's default semaphore, which an ended worker would leave behind
    global _PROCESS_DEVICE
    _PROCESS_DEVICE = claims.get()


def _task(path, frame, file, spp, seed, exposure, options, aovs: bool = False) -> dict:
    return {"path": path, "frame": float(frame), "file": os.fspath(file), "suffix": Path(file).suffix.lower(),
            "spp": spp, "seed": seed, "exposure": exposure, "options": options, "aovs": aovs}


_WORKER_RENDERERS: dict = {}  # FrameRenderers kept by a Dask worker process, so its frames share a BVH


def render_frame_task(job: dict) -> dict:
    """One frame on a Dask worker (see :mod:`wrt.distributed`): renders it on the worker's own device with a
    :class:`FrameRenderer` the worker keeps between tasks, and returns the encoded image file, so the client writes
    exactly the bytes a serial run writes.

    Args:
        job: ``path``, ``frame``, ``file`` (written by the client), ``suffix`` (``.png``, ``.exr``, ``.npy``), ``spp``,
            ``seed``, ``exposure``, ``options`` (:class:`FrameRenderer` options without ``device``) and ``aovs``
            (whether to send the AOV arrays back too).

    Returns:
        ``{"data": file bytes, "aovs": {AOV name: .npy file bytes} (with the job's aovs), "row": the frame's log row
        with "device" and "seconds" (render and encode),
        "warnings": ``(message, "module:ClassName", key)`` of each warning the frame raised, ``key`` what the
        Renderer says it once by (:func:`wrt.errors.warn_keyed`) or None}``: the client shows each once over all its
        workers, in its own class (:func:`warning_class`), where each worker printed them to its own log in Python's
        format, glued to the client's progress bar. For a frame whose stage is bad at its time, ``{"error": the
        wrt.SceneError (its ``device`` set), "row": {"frame", "device"}}``: returned, not raised, as the frame is
        reported in one line and an error row; raised, Dask's worker logged it as "Compute Failed" with its whole
        traceback, on the client's terminal for a LocalCluster.
    """
    import tempfile

    from .distributed import worker_device

    device = _PROCESS_DEVICE or worker_device()
    key = (job["path"], device, repr(sorted(job["options"].items())))
    start = _time.perf_counter()
    with warnings.catch_warnings(record=True) as raised:
        warnings.simplefilter("always")
        warnings.simplefilter("ignore", TimeRangeWarning)  # the client warned once for every frame of the run
        if key not in _WORKER_RENDERERS:
            _WORKER_RENDERERS[key] = FrameRenderer(job["path"], device=device, **job["options"])
        renderer = _WORKER_RENDERERS[key]
        try:
            # The client's file: an EXR refused by Image.save below named the temporary one.
            image = renderer.render(job["frame"], spp=job["spp"], seed=job["seed"], file=job["file"])
        except SceneError as e:
            e.device = device  # for the frame's error row, written by the client (it travels with the pickled error)
            return {"error": e, "row": {"frame": job["frame"], "device": device}}
        # Its save's warnings are the frame's too (the serial run's row lists them): saved past the recording, they
        # went to the worker's own stderr, past the client's filters, and were missing from the row.
        with tempfile.TemporaryDirectory() as tmp:
            written = image.save(Path(tmp) / f"frame{job['suffix']}", exposure=job["exposure"])
            data = Path(written).read_bytes()
            # The bytes a serial run writes (Image.save_aov's), written by the client.
            aovs = {name: image.save_aov(name, Path(tmp) / f"{name}.npy").read_bytes()
                    for name in image.aovs} if job.get("aovs") else {}
    row = dict(renderer.log[-1], device=device, seconds=_time.perf_counter() - start, finished_at=_time.time())
    named = ((str(w.message), f"{w.category.__module__}:{w.category.__qualname__}",
              getattr(w.message, "said_once_key", None)) for w in [*renderer.last_warnings, *raised])
    return {"data": data, "aovs": aovs, "row": row, "warnings": list(dict.fromkeys(named))}


def warning_class(name: str) -> type[Warning]:
    """The warning class ``module:qualname`` names (a worker's frame sends its warnings' classes so, in words: a
    class the client cannot import would have failed the whole result's unpickling); ``UserWarning`` where there is
    no such warning class."""
    import importlib

    module, _, qualname = name.partition(":")
    try:
        found = importlib.import_module(module)
        for part in qualname.split("."):
            found = getattr(found, part)
    except (ImportError, AttributeError, ValueError):
        return UserWarning
    return found if isinstance(found, type) and issubclass(found, Warning) else UserWarning


def render_frames_on_dask(path, jobs, *, address=None, n_workers=None, spp=1, seed=0, exposure=0.0, progress=False,
                          log=None, log_row=None, on_row=None, aov_pattern=None, task=render_frame_task,
                          **options) -> list[dict]:
    """:func:`render_frames` on a Dask cluster (``address``, or a ``LocalCluster`` of ``n_workers``): every frame is
    one task (``task``, :func:`render_frame_task` or a wrapper of it), each image is written here the moment it
    arrives (its AOV arrays too with ``aov_pattern``, as :func:`render_frames` writes them), and a frame whose worker
    died is rerun elsewhere. Returns the log rows, with ``output``, in arrival order (each also appended to ``log`` as
    it arrives, when given, and handed to ``on_row``); a frame whose stage is bad at its time has an error row, as in
    :func:`render_frames`, and any other error (a frame whose workers kept dying too) is raised once every frame has
    finished, its frame's error row logged as it comes back."""
    from .distributed import run_tasks
    from .image import check_exposure

    check_exposure(exposure)
    check_frame_options(options, "render_frames_on_dask", DASK_OWN + FRAME_OPTIONS)
    path = os.fspath(path)
    jobs = check_jobs(jobs)
    if aov_pattern is not None:
        check_aov_pattern(aov_pattern, jobs)
    warn_frames_outside_range(path, [frame for frame, _ in jobs])
    tasks = [_task(path, frame, file, spp, seed, exposure, options, aov_pattern is not None) for frame, file in jobs]
    rows = LogRows(log, log_row, on_row)
    write = _frame_writer(rows, aov_pattern)
    others = []

    def failed(job, error):
        if isinstance(error, SceneError):
            rows.append(frame_error_row(job["frame"], job["file"], error, getattr(error, "device", None)))
        else:  # raised once the others finish; its row now, as over devices: the log said nothing of the frame
            _log_stopping_frame(rows, job["frame"], job["file"], error, getattr(error, "device", None))
            others.append(error)

    def arrived(job, result):
        try:
            write(result, job["file"])
        except OSError as e:  # its write failed (a full disk): the frame's error, as in render_frames
            rows.append(frame_write_error_row(job["frame"], job["file"], e, result.get("row", {}).get("device")))

    def interrupted(cut_short):  # Ctrl-C: rows for the frames on a worker or sent back and not written, as --devices
        logged = _logged_jobs(rows)
        for job in sorted(cut_short, key=lambda job: (job["frame"], job["file"])):
            if (job["frame"], str(job["file"])) not in logged:
                rows.append(frame_interrupted_row(job["frame"], job["file"]))

    run_tasks(task, tasks, address=address, n_workers=n_workers,
              on_result=arrived, on_error=failed, on_interrupt=interrupted,
              progress=progress, desc="wrt frames")
    if others:
        raise others[0]
    return rows


__all__ = [
    "REFIT_SAH_LIMIT",
    "FrameRenderer",
    "LogRows",
    "aov_files",
    "classify_change",
    "frame_error_row",
    "frame_interrupted_row",
    "frame_output",
    "parse_frames",
    "pending_frames",
    "render_frame_task",
    "render_frames",
    "render_frames_on_dask",
    "topology_key",
    "warn_frames_outside_range",
    "warn_mixed_sizes",
]
