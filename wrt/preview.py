"""Previews with pyvista: the scene, its lights, the camera frustum, BVH boxes and sample camera rays in one 3D view.

A preview shows what wrt will trace before any GPU time is spent: the meshes as ``Scene`` holds them (world
space, one colour per triangle from its material or ``displayColor``), the outlines of its lights
(:mod:`wrt.preview_lights`), the frustum of the render camera, the BVH's boxes
at one depth or its leaves, and a few camera rays from the eye to their closest hits (through :mod:`wrt.trace`, as
the renderer casts its AOV rays, through the pixel and lens centres; the colour samples of an image of several
samples, sample 0 included, are spread over the pixel and the lens). Optionally the wrt-rendered image hangs on the
frustum's image plane.

pyvista is optional (``pip install 'wrt[preview]'``) and imported only inside the functions that need it, so
``import wrt`` stays light. On Linux without an X display, plotting is off-screen: :func:`offscreen_backend`
probes VTK's EGL and OSMesa windows in a subprocess (a missing OpenGL library makes VTK crash, not raise)
and raises :class:`PreviewUnavailable` with the packages to install when neither works.

What is drawn, in the frustum's terms (see :mod:`wrt.camera` for the film conventions):

- The frustum runs from the eye to a *display far plane*: the camera's far clipping plane, pulled in to the
  deepest corner of the scene's bounding box (far planes are often 1e6 units away). Rays that miss end there, or
  where a camera clipping plane (``clippingPlanes``) cuts them first.
- The *near plane* rectangle is the near clipping plane, where camera rays start (none where it is at the eye).
  Rays are drawn from the eye, or from that plane where it lies behind an orthographic camera.
- The *image plane* rectangle sits at 80 % of the depth of the nearest sample hit (or of the scene's nearest
  corner), where the ``image=True`` quad is drawn; behind an orthographic camera, at 120 % of that negative depth,
  so in front of the hit there too.
- BVH boxes are either the *cut at depth K* (every node at depth ``K`` plus the leaves above it, so every
  triangle reference lies in exactly one shown box) or all leaves. A triangle has one reference, or, where the
  ``sah`` builder pre-split it, several, each for the piece of it inside its leaf's box: no shown box need hold the
  whole of such a triangle. They are coloured by node depth or by their *SAH cost share*
  ``A(n) N(n) / sum_m A(m) N(m)`` over the shown boxes ``m``, where ``A`` is the box surface area and ``N`` the
  number of triangle references below the node: the part of the SAH traversal cost (MacDonald and Booth,
  "Heuristics for ray tracing using space subdivision", 1990) that the box would carry were the cut the leaves.
  A scene with instances or analytic shapes is traced through a two-level BVH; its top level (TLAS) is drawn,
  whose entries are the instances, the shapes and one for all non-instanced meshes together, up to
  ``TLAS_LEAF_SIZE`` (2) per leaf.
- Scenes above ``max_triangles`` are simplified for display by vertex clustering (Rossignac and Borrel,
  "Multi-resolution 3D approximations for rendering complex scenes", 1993); analytic shapes (at most
  ``SHAPE_BUDGET``) get coarser circles, down to ``MIN_SHAPE_SEGMENTS`` segments, to stay within it too. The window
  title says so. Shapes past ``SHAPE_BUDGET`` and instances past ``EXPAND_FACTOR`` times the budget are cut to an
  even subset spread over the scene (:mod:`wrt.preview_subsets`), not to the first ones, and the title says how
  many of how many are drawn.
"""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import warp as wp

from .bvh import Builder, FlatBvh, convert_layout
from .bvh.layout import check_layout
from .bvh.wide import WIDE_WIDTHS
from .camera import Camera, generate_rays_kernel
from .errors import did_you_mean, flag
from .far_views import shown_across_renderers
from .hidden_hits import CullScratch, intersect_visible
from .image import to_srgb8
from .instancing import expand_instance_triangles
from .options import BVH_COLORINGS, MAX_RAYS, TRIANGLE_BUDGET
from .preview_blas import instance_blas, instance_row
from .preview_lights import light_glyphs
from .preview_subsets import even_rows, rows_within, spread_rows
from .preview_wide import WideBoxes, check_drawn_layout, wide_boxes
from .render import Renderer, check_asked_pixels, check_lights, render, resolve_view
from .scene import Scene, contents_summary
from .tlas import TLAS_LEAF_SIZE
from .trace import HitBuffer, check_finite_transforms, get_accelerator, resolve_device
from .wording import counted, counted_of

EXPAND_FACTOR = 4  # instanced scenes above EXPAND_FACTOR * budget show only instances within the budget, spread
INSTANCE_BLOCK_BUDGET = 10_000  # most instance blocks to_pyvista makes: each costs about a millisecond of pyvista
# bookkeeping, so the 2M one-triangle instances the triangle budget lets in took over half an hour
SHAPE_SEGMENTS = 24  # analytic shapes are drawn tessellated with this many segments per circle
MIN_SHAPE_SEGMENTS = 6  # coarsest circles of analytic shapes, drawn so to keep within the triangle budget
SHAPE_BUDGET = 20_000  # most analytic shapes drawn; more are cut to a subset spread over the scene
CENTRE_CHUNK = 1 << 16  # instanced shapes whose centres are found at once, when choosing that subset
MAX_CLUSTER_GRID = 4096  # finest clustering grid, cells along the longest side of the scene box
CLUSTER_STEPS = 10  # most clusterings tried while searching the grid for the triangle budget
NORMAL_CHUNK = 1 << 20  # triangles whose float64 corners are gathered at once (72 MB)
BOX_BUDGET = 50_000  # most BVH boxes drawn; more are subsampled evenly in node order
BAR_WIDTH = 0.6  # colour bar length, a fraction of the window's width (pyvista's default)
BAR_FONT_SIZES = (18, 16, 14, 12, 10)  # colour bar label sizes tried, pixels (18 is pyvista's default)
BAR_CHARACTER_EM = 0.6  # width of a label character in ems: Arial's digits and 'e' are 0.556, '.' and '-' less
BAR_LABEL_GAP = 0.25  # least space between two colour bar labels, a fraction of a label's width
MAX_WINDOW = 16384  # largest window side, pixels: OpenGL's usual framebuffer limit (Mesa's); beyond it VTK draws
# nothing or aborts allocating the picture
TEXT_PIXELS_PER_CHARACTER = 4  # summary lines are wrapped to the window's width over this many pixels a character:
# at 3 (VTK's smallest font is about 3 wide) the longest lines ran past the window's right side, cut off there
MIN_TEXT_COLUMNS = 20  # ... and to no fewer characters a line
IMAGE_PLANE_FRACTION = 0.8  # image plane depth, as a fraction of the nearest sample hit's depth
GREY = 0.5  # linear albedo shown for meshes without displayColor (the renderer's default)
BACKGROUND = "white"
DEPTH_COLORS = ["#440154", "#3b528b", "#21918c", "#5ec962", "#b5c900"]  # viridis without its pale yellow end
SAH_COLORS = ["#0d0887", "#7e03a8", "#cc4778", "#f89540", "#e0a800"]  # plasma, likewise, so all boxes show on white
FRUSTUM_COLOR = "crimson"
LIGHT_COLOR = "#d4a000"  # a dark gold, which shows on white
HIT_COLOR = "darkorange"
MISS_COLOR = "steelblue"
INSTALL_HINT = (
    "install Mesa's EGL (apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri) or OSMesa (apt-get install "
    "libosmesa6), or run under xvfb-run"
)

_PROBE = """
import vtkmodules.vtkRenderingOpenGL2
from vtkmodules.vtkRenderingCore import vtkRenderWindow, vtkRenderer
window = vtkRenderWindow()
window.SetOffScreenRendering(1)
window.SetSize(8, 8)
window.AddRenderer(vtkRenderer())
window.Render()
print(window.GetClassName())
"""  # renders one tiny frame; run in a subprocess because a missing GL library crashes VTK
_backend = None  # VTK window class found by offscreen_backend(), cached per process


class PreviewUnavailable(RuntimeError):
    """pyvista is missing, or VTK has no way to draw on this machine."""


def import_pyvista():
    """``pyvista``, or :class:`PreviewUnavailable` saying how to install it."""
    try:
        import pyvista
    except ImportError as e:
        raise PreviewUnavailable(f"previews need pyvista ({e}): pip install 'wrt[preview]'") from None
    return pyvista


def has_display() -> bool:
    """Whether an interactive window can open: on Linux, an X server answers at ``$DISPLAY``; elsewhere, True."""
    if not sys.platform.startswith("linux"):
        return True
    if not os.environ.get("DISPLAY"):
        return False
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("X11") or "libX11.so.6"
    try:
        xlib = ctypes.CDLL(name)
    except OSError:
        return False
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = xlib.XOpenDisplay(None)
    if not display:
        return False
    xlib.XCloseDisplay(display)
    return True


def _no_display_reason() -> str:
    """Why :func:`has_display` is False, in the user's terms."""
    display = os.environ.get("DISPLAY")
    return f"no X server answers at DISPLAY={display}" if display else "DISPLAY is not set"


def offscreen_backend() -> str:
    """Makes sure VTK can render off-screen here and returns the VTK window class it will use.

    With a display (or off Linux) VTK's default window works. Without one, the EGL and then the OSMesa window
    are tried in a subprocess (``$VTK_DEFAULT_OPENGL_WINDOW`` alone when the user set it); the first that
    renders is exported in ``$VTK_DEFAULT_OPENGL_WINDOW`` for this process. The answer is cached.

    Raises:
        PreviewUnavailable: no backend renders; the message names the packages to install.
    """
    global _backend
    if _backend is not None:
        return _backend
    if has_display():
        _backend = "default"
        return _backend
    chosen = os.environ.get("VTK_DEFAULT_OPENGL_WINDOW")
    candidates = [chosen] if chosen else ["vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"]
    failures = []
    for candidate in candidates:
        env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW=candidate)
        try:
            run = subprocess.run(
                [sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=120, check=False
            )
        except (OSError, subprocess.TimeoutExpired) as e:
            failures.append(f"{candidate}: {e}")
            continue
        if run.returncode == 0 and run.stdout.strip():
            os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = candidate
            _backend = candidate
            return _backend
        failures.append(f"{candidate}: exit status {run.returncode}")
    if chosen:  # the user's choice alone was tried: it, not the machine, may be what fails
        raise PreviewUnavailable(f"no display, and VTK_DEFAULT_OPENGL_WINDOW={chosen} (set in the environment) does "
                                 f"not render ({failures[0]}); unset it to let wrt try EGL and OSMesa, or "
                                 f"{INSTALL_HINT}")
    raise PreviewUnavailable(f"no display and no off-screen OpenGL for VTK ({'; '.join(failures)}); {INSTALL_HINT}")


def display_colors(own, material_ids, tints, materials) -> np.ndarray:
    """``(N, 3)`` float32 linear display colour of N triangles or shapes, as the renderer picks their diffuse colour.

    One bound to a material (``0 <= material_ids < len(materials)``) shows the material's constant ``diffuse_color``
    (a texture's fallback, for textured ones); otherwise (or where the material reads the colour primvar) its own
    colour (``displayColor`` or that primvar, times the material's ``color_primvar_scale``), else its instance's
    (times that scale too); the material's constant (the primvar reader's fallback) or the renderer's grey for those
    with neither.

    Args:
        own: ``(N, 3)`` linear colour of each, NaN where it has none.
        material_ids: ``(N,)`` int index into ``materials``, -1 for the default material.
        tints: ``(N, 3)`` linear colour of each one's instance (``Instances.colors``), NaN where none.
        materials: ``Scene.materials``.
    """
    table = np.array([np.asarray(m.diffuse_color, np.float32).reshape(3) for m in materials] or np.zeros((0, 3)))
    scales = np.array([np.asarray(getattr(m, "color_primvar_scale", np.ones(3)), np.float32).reshape(3)
                       for m in materials] or np.zeros((0, 3)))
    from_primvar = np.array([bool(getattr(m, "diffuse_from_display_color", False)) for m in materials], bool)
    ids = np.asarray(material_ids, np.int64)
    color = np.where(np.isnan(own[:, :1]), tints, own).astype(np.float32)  # its own colour, else its instance's
    uncolored = np.isnan(color[:, 0])
    bound = (ids >= 0) & (ids < len(table))
    reads = bound.copy()
    reads[bound] = from_primvar[ids[bound]]
    linear = np.where(uncolored[:, None], np.float32(GREY), color)
    scaled = reads & ~uncolored
    linear[scaled] *= scales[ids[scaled]]
    constant = bound & ~scaled  # the material's colour, or its primvar reader's fallback
    linear[constant] = table[ids[constant]]
    return linear


def triangle_colors(scene: Scene) -> np.ndarray:
    """``(T, 3)`` uint8 sRGB display colour of every triangle, in triangle order (``Scene.triangles()`` rows, instances
    expanded): the mean of its three corner colours, its material's or its instance's (see :func:`display_colors`).
    """
    meshes = scene._geometry_meshes() if hasattr(scene, "_geometry_meshes") else scene.meshes
    own = [m.colors.mean(axis=1) if m.colors is not None else np.full((len(m.indices), 3), np.nan, np.float32)
           for m in meshes]
    ids = [m.material_ids if getattr(m, "material_ids", None) is not None else np.full(len(m.indices), -1)
           for m in meshes]
    own = np.concatenate(own) if own else np.zeros((0, 3), np.float32)
    ids = np.concatenate(ids) if ids else np.zeros(0, np.int64)
    materials = getattr(scene, "materials", None) or []
    # Converted once per geometry triangle, then copied to its instances' rows: converting every expanded row took
    # most of a preview of a scene of many instances (4.5 s of 19 at 2.5M triangles). display_colors and to_srgb8
    # work row by row, so the copies are the colours a per-row conversion gives.
    srgb = _run_colors(own, ids, materials)
    tints = getattr(getattr(scene, "instances", None), "colors", ())
    if not len(tints) or not len(own):
        return _expand_rows(scene, srgb)
    geometry = own[: getattr(scene, "num_geometry_triangles", len(own))]
    prim, instance = _expanded_ids(scene)
    colors = srgb[prim]
    # An instance's colour shows only on its triangles without a colour of their own: those are converted again.
    tinted = np.flatnonzero(instance >= 0)
    tinted = tinted[np.isnan(geometry[prim[tinted], 0]) & ~np.isnan(tints[instance[tinted], 0])]
    if len(tinted):
        rows = prim[tinted]
        colors[tinted] = to_srgb8(display_colors(own[rows], ids[rows], tints[instance[tinted]], materials))
    return colors


def _run_colors(own, material_ids, materials) -> np.ndarray:
    """``(N, 3)`` uint8 sRGB of :func:`display_colors` (no instance colours), converted once per run of equal rows
    (same colour, NaN alike, and material): a mesh's triangles mostly share one colour, and converting each of the
    4M triangles of a scene of one colour took a second. Row by row as the conversion is, the result is the same."""
    if not len(own):
        return to_srgb8(display_colors(own, material_ids, own.copy(), materials))
    same = material_ids[1:] == material_ids[:-1]
    same &= ((own[1:] == own[:-1]) | (np.isnan(own[1:]) & np.isnan(own[:-1]))).all(axis=1)
    starts = np.flatnonzero(np.concatenate([[True], ~same]))
    first = own[starts]
    converted = to_srgb8(display_colors(first, material_ids[starts], np.full_like(first, np.nan), materials))
    return np.repeat(converted, np.diff(np.append(starts, len(own))), axis=0)


def _expand_rows(scene: Scene, values: np.ndarray) -> np.ndarray:
    """Per-triangle ``values`` in geometry order -> in ``Scene.triangles()`` order (instances expanded)."""
    values = values[: getattr(scene, "num_geometry_triangles", len(values))]  # analytic shapes are not triangles
    if not len(getattr(scene, "instances", ())):
        # The rows are the non-instanced triangles: prototypes without instances (none fit the budget) draw nothing.
        return values[: getattr(scene, "num_flat_triangles", len(values))]
    return values[_expanded_ids(scene)[0]]


def _expanded_ids(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """``(geometry id, instance)`` of each row of ``Scene.triangles()`` (instances expanded)."""
    return scene.split_ids(np.arange(scene.stats()["rendered_triangles"], dtype=np.int64))


def world_triangles(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """``Scene.triangles()`` with float64 points: the non-instanced meshes' float32 points (as wrt traces them), then
    the instances' moved in float64. wrt traces an instance in its prototype's space, so it keeps its shape far from
    the origin, where the float32 of ``Scene.triangles()`` (a step of 1 at 1e7) drew a triangle of 0.6 as a line."""
    points, indices = scene.triangles()
    if not len(scene.instances):
        return points, indices
    flat = sum(len(m.points) for m in scene.meshes)
    moved, _ = expand_instance_triangles(scene.prototypes, scene.instances, scene.instance_inverses()[1], np.float64)
    return np.concatenate([points[:flat].astype(np.float64), moved]), indices


def _instances_within(scene: Scene, max_triangles: int) -> int:
    """How many instances, taken in order, fit in ``max_triangles`` together with the non-instanced meshes."""
    if not len(scene.instances):
        return 0
    offsets = scene.instance_offsets()
    return int(np.searchsorted(offsets[1:], max_triangles, side="right"))


def _first_instances(scene: Scene, n: int) -> Scene:
    """``scene`` with only its first ``n`` instances (for drawing)."""
    return dataclasses.replace(scene, instances=scene.instances.take(slice(0, n)))


def to_pyvista(scene, max_triangles: int = TRIANGLE_BUDGET, max_instances: int | None = None):
    """The scene's meshes as a ``pyvista.MultiBlock``: one ``PolyData`` block per non-instanced mesh, named by prim
    path, then one block per instance (its prototype's meshes merged, moved to world space), named by the instance's
    path (``/instancer[index]`` for a PointInstancer's).

    Every block carries all of its mesh's points (world space) and one triangle cell per triangle (none for a mesh
    of points alone or an instance of a prototype of analytic shapes alone: its cell arrays are empty), so the
    points, cells and blocks add up to ``Scene.stats()``'s ``points``, ``rendered_triangles`` and ``meshes`` plus
    ``instances``. Cell arrays: ``"color"`` ``(T, 3)`` uint8 sRGB (see :func:`triangle_colors`), ``"prim"`` triangle
    id (the row of ``Scene.triangles()``, as in ``Hits.prim``) and ``"face_id"`` int32 source face
    (``Mesh.elements``: 0 on a tessellated gprim, as its ``elementId``). Instances are added in order while the total
    stays within ``max_triangles`` and they number at most ``max_instances``; the others are left out, a warning
    says how many and which budget, and the MultiBlock's ``field_data["instances_left_out"]`` counts them. Analytic
    shapes (spheres, cubes, ... and those of prototypes) are not among the blocks: :func:`shape_meshes` tessellates
    them.

    Args:
        scene: a :class:`wrt.Scene`, or a USD file to load.
        max_triangles: triangle budget for the instance blocks.
        max_instances: most instance blocks (``None``: ``INSTANCE_BLOCK_BUDGET``).
    """
    pv = import_pyvista()
    scene = _as_scene(scene)
    max_instances = INSTANCE_BLOCK_BUDGET if max_instances is None else max_instances
    for label, value, least in (("max_triangles", max_triangles, 1), ("max_instances", max_instances, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            kind = "positive" if least else "non-negative"
            raise ValueError(f"{label} must be a {kind} integer, got {value!r}")  # -3 left every instance out unsaid
    shown = min(_instances_within(scene, max_triangles), max_instances)
    drawn = _first_instances(scene, shown) if shown < len(scene.instances) else scene
    colors = triangle_colors(drawn)
    blocks = pv.MultiBlock()
    names = set()  # block names so far: MultiBlock.keys() asks VTK for every name, which made the loop quadratic

    def add(poly, name: str, k: int) -> None:
        name = name if name not in names else f"{name}#{k}"  # two prims of one path (made in Python): both kept
        names.add(name)
        blocks.append(poly, name)

    first = 0
    # Blocks get copies of the scene's arrays: pyvista wraps an array without copying, and an edit of a block (a
    # block.points[:, 1] += 3) wrote into the scene's read-only arrays or its cached triangles, behind its caches.
    for k, mesh in enumerate(scene.meshes):
        n = len(mesh.indices)
        poly = _triangles_block(pv, mesh.points.copy(), mesh.indices, {
            "color": colors[first : first + n],
            "prim": np.arange(first, first + n, dtype=np.int32),
            "face_id": mesh.elements().copy(),
        })
        poly.field_data["path"] = [mesh.path]
        add(poly, mesh.path, k)
        first += n
    if shown:
        points, indices = world_triangles(drawn)
        offsets = drawn.instance_offsets()
        local = [np.concatenate([m.points for m in p.meshes] or [np.zeros((0, 3), np.float32)]).astype(np.float64)
                 for p in drawn.prototypes]
        with_triangles = [any(len(m.indices) for m in p.meshes) for p in drawn.prototypes]
        # The expansion holds the points of prototypes with triangles only (expand_instance_triangles): counted so, an
        # instance of a prototype of points alone took the next instance's points, and every later block was shifted.
        vertex = np.cumsum([0] + [len(local[p]) if with_triangles[p] else 0 for p in drawn.instances.prototype])
        vertex += sum(len(m.points) for m in scene.meshes)
        for i in range(shown):
            a, b = int(offsets[i]), int(offsets[i + 1])
            k = drawn.instances.prototype[i]
            proto = drawn.prototypes[k]
            if with_triangles[k]:
                moved = points[vertex[i] : vertex[i + 1]].copy()
            else:  # its points, moved here
                to_world = drawn.instances.to_world[i]
                moved = local[k] @ to_world[:3, :3].T + to_world[:3, 3]
            poly = _triangles_block(pv, moved, indices[a:b] - vertex[i], {
                "color": colors[a:b],
                "prim": np.arange(a, b, dtype=np.int64 if b > np.iinfo(np.int32).max else np.int32),
                "face_id": np.concatenate([m.elements() for m in proto.meshes] or [np.zeros(0, np.int32)]),
            })
            path = drawn.instances.path(i)
            poly.field_data["path"] = [path]
            add(poly, path, i)
    left_out = len(scene.instances) - shown
    blocks.field_data["instances_left_out"] = [left_out]
    if left_out:  # only counted in field_data, the blocks looked like the whole scene
        limits = [f"max_triangles={max_triangles:,}"] if shown == _instances_within(scene, max_triangles) else []
        limits += [f"max_instances={max_instances:,}"] if shown == max_instances else []
        warnings.warn(f"{scene.source or 'scene'}: to_pyvista left out "
                      f"{counted_of(left_out, len(scene.instances), 'instance')} (the first {shown:,} in order fill "
                      f"{' and '.join(limits)}); pass a larger max_triangles or max_instances to include them",
                      stacklevel=2)
    return blocks


def _triangles_block(pv, points, triangles, cell_arrays: dict):
    """A ``PolyData`` of ``points`` and one cell per row of ``triangles`` with ``cell_arrays`` (name -> one value per
    triangle). A mesh without triangles (points only, or a prototype of analytic shapes alone) has no cells but still
    every array, empty: ``PolyData(points)`` would add a vertex cell per point, and pyvista refuses empty arrays."""
    if len(triangles):
        poly = pv.PolyData.from_regular_faces(points, triangles)
    else:
        poly = pv.PolyData()
        poly.points = points.reshape(-1, 3)
    for name, values in cell_arrays.items():
        if len(triangles):
            poly.cell_data[name] = values
        else:  # through VTK, which takes an empty array
            poly.GetCellData().AddArray(pv.convert_array(np.ascontiguousarray(values), name=name))
    return poly


def cluster_vertices(points, indices, colors, max_triangles: int):
    """Simplifies a triangle soup to at most ``max_triangles`` by vertex clustering.

    Points are snapped to the mean of their cell in a uniform grid, triangles whose corners fall into fewer than
    three cells are dropped, and duplicates (the same cells in the same cyclic order) are removed (Rossignac and
    Borrel 1993); a triangle that the snap turned over is wound back to face as its source did. The grid resolution is
    searched (geometric bisection from a guess based on surface area) for a result between 70 % and 100 % of the
    budget, in at most ``CLUSTER_STEPS`` clusterings; the finest grid that fits wins.

    Args:
        points: ``(V, 3)`` float32 or float64, world space.
        indices: ``(T, 3)`` int32.
        colors: ``(T, C)`` per-triangle values that follow their triangle.
        max_triangles: triangle budget.

    Returns:
        ``(points, indices, colors)`` of the simplified soup, points float64.
    """
    points = np.asarray(points, np.float64)
    indices = np.asarray(indices, np.int64)
    used = np.flatnonzero(np.bincount(indices.reshape(-1), minlength=len(points)))
    used_points = points[used]  # gathered once, not four times per clustering
    lower = used_points.min(axis=0)
    # A floor for a box of no size (one point) alone: one of 1e-30 under every box made the grid of a mesh 2^-110
    # units across (7.7e-34) 100 times coarser (158 triangles kept of a budget of 1000, 712 at any other scale).
    extent = float((used_points.max(axis=0) - lower).max())
    extent = extent if extent > 0.0 else 1.0
    from_lower = used_points - lower

    def cluster(resolution: int):
        """``(cluster of each used point, number of clusters, source triangles' clusters, rows of the triangles of
        three clusters, their keys)``: a triangle is kept where its key comes first (:func:`first_rows`)."""
        cells = np.minimum(from_lower * (resolution / extent), resolution - 1).astype(np.int64)
        keys = (cells[:, 0] * (resolution + 1) + cells[:, 1]) * (resolution + 1) + cells[:, 2]
        clusters, ids = cluster_ids(keys, (resolution + 1) ** 3)
        remap = np.zeros(len(points), np.int64)
        remap[used] = ids
        tris = remap[indices]
        keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
        # Drop duplicates: the same three clusters in the same cyclic order (triangle_keys).
        candidates = np.flatnonzero(keep)
        keys = triangle_keys(tris[candidates], clusters)
        return ids, clusters, tris, candidates, keys

    def distinct(keys) -> int:
        """How many distinct ``keys`` there are: a sort of the values alone, about a third of the stable argsort
        that finding the first of each takes (:func:`first_rows`), which only a grid that fits needs."""
        if keys.ndim == 2:
            return len(np.unique(keys, axis=0))
        ordered = np.sort(keys)
        return int(len(ordered) > 0) + int(np.count_nonzero(ordered[1:] != ordered[:-1]))

    def first_rows(candidates, keys):
        """The ``candidates`` whose key comes first among equal ones, ascending (a mask, not a sort, puts them in
        order)."""
        first = np.unique(keys, axis=0 if keys.ndim == 2 else None, return_index=True)[1]
        chosen = np.zeros(len(candidates), bool)
        chosen[first] = True
        return candidates[chosen]

    def placed(ids, clusters: int, tris, rows):
        """The soup that :func:`cluster` chose ``rows`` of: done for the grid picked alone, not for each one tried
        (it took a third of the search)."""
        # Place each cluster at the mean of its points.
        sums = np.stack([np.bincount(ids, used_points[:, k], minlength=clusters) for k in range(3)], axis=1)
        centres = sums / np.bincount(ids, minlength=clusters)[:, None]  # float64: far from the origin too
        # Keep each triangle facing as its source did: snapping the corners turns some over (0.5 % of a sphere's),
        # and those of a single-sided surface are drawn culled from the side they face.
        kept = tris[rows]
        moved = centres[kept]
        facing = np.cross(moved[:, 1] - moved[:, 0], moved[:, 2] - moved[:, 0])
        turned = np.einsum("ij,ij->i", facing, normals[rows]) < 0
        kept[turned] = kept[turned][:, [0, 2, 1]]
        # Two of the same clusters, in opposite orders, facing one way now (a surface folded over by the snap, one of
        # them wound back): the first of them is kept.
        once = first_rows(np.arange(len(rows)), triangle_keys(kept, clusters))
        return centres, kept[once].astype(np.int32), np.asarray(colors)[rows[once]]

    # First guess: a surface of area A cut into cells of side h keeps about 2 A / h^2 triangles. Normals and area are
    # taken of the points scaled by a power of two into a box of side about 1 (exact: the same signs and ratios).
    unit = math.ldexp(1.0, -math.frexp(extent)[1])
    normals = source_normals(points, indices, unit)
    area = 0.5 * float(np.sqrt(np.einsum("ij,ij->i", normals, normals)).sum(dtype=np.float64))
    resolution = int(np.clip(extent * unit * math.sqrt(max_triangles / max(2.0 * area, 1e-30)), 2, MAX_CLUSTER_GRID))
    fits, too_fine = None, None  # (resolution, result) of the finest grid that fits; coarsest one that does not
    for _ in range(CLUSTER_STEPS):
        ids, clusters, tris, candidates, keys = cluster(resolution)
        # The rows kept are found only for a grid that may be the finest that fits; the others' duplicates are counted.
        finest = fits is None or resolution > fits[0]
        n = len(keys) if finest and len(keys) <= max_triangles else distinct(keys)
        if n <= max_triangles and finest:
            rows = first_rows(candidates, keys)
            n = len(rows)
            fits = (resolution, (ids, clusters, tris, rows))
        if n <= max_triangles:
            if n >= 0.7 * max_triangles or resolution >= MAX_CLUSTER_GRID:
                break
        elif too_fine is None or resolution < too_fine:
            too_fine = resolution
        # Next resolution: bisect (geometrically) a bracket, else step by the square-root rule.
        if fits is not None and too_fine is not None:
            following = int(math.sqrt(fits[0] * too_fine))
            if following in (fits[0], too_fine):
                break
        else:
            step = math.sqrt(max_triangles / max(n, 1))
            step = min(0.95 * step, 0.8) if n > max_triangles else max(min(step, 4.0), 1.25)
            following = int(np.clip(resolution * step, 2, MAX_CLUSTER_GRID))
            if following == resolution:
                break
        resolution = following
    if fits is None or len(fits[1][3]) == 0:
        # Even a 2x2x2 grid is over the budget, or the only grids that fit collapse every triangle (a budget of a
        # few triangles): keep every k-th source triangle instead.
        keep = np.linspace(0, len(indices) - 1, min(max_triangles, len(indices))).astype(np.int64)
        return points, indices[keep].astype(np.int32), np.asarray(colors)[keep]
    return placed(*fits[1])


def cluster_ids(keys: np.ndarray, bound: int) -> tuple[int, np.ndarray]:
    """``(number of distinct keys, (N,) int64 rank of each of the N keys among them)``, as ``np.unique(keys,
    return_inverse=True)`` gives them, for int64 ``keys`` in ``[0, bound)``. Where each key and its row fit in 63 bits
    together, one sort of the values packed so takes the place of np.unique's argsort: 0.16 s, not 0.39 s, for the
    2M points of a clustering of 4M triangles."""
    shift = max(1, (len(keys) - 1).bit_length())
    if not len(keys) or (bound - 1).bit_length() + shift > 63:
        uniq, ids = np.unique(keys, return_inverse=True)
        return len(uniq), ids.reshape(-1)
    ordered = np.sort((keys << shift) | np.arange(len(keys), dtype=np.int64))
    sorted_keys = ordered >> shift
    new = np.empty(len(keys), bool)
    new[0] = True
    np.not_equal(sorted_keys[1:], sorted_keys[:-1], out=new[1:])
    ids = np.empty(len(keys), np.int64)
    ids[ordered & ((1 << shift) - 1)] = np.cumsum(new) - 1
    return int(np.count_nonzero(new)), ids


def triangle_keys(tris: np.ndarray, clusters: int) -> np.ndarray:
    """One key per row of ``tris`` (``(T, 3)`` int64 cluster ids, each below ``clusters``), equal for the same three
    ids in the same cyclic order: an int64 (the three sorted and the order's parity packed) below 2^21 clusters, else
    a row of four. The two sides of a thin sheet (a card of two single-sided faces back to back, wound opposite ways)
    snap to the same three clusters: keyed in any order, the first side alone was kept, and from the other side,
    culled, the card vanished. Sorted by min, max and what is left: a row-wise np.sort of three columns took as long
    as the unique after it."""
    tris = np.asarray(tris, np.int64)
    smallest, largest = tris.min(axis=1), tris.max(axis=1)
    middle = tris.sum(axis=1) - smallest - largest
    a, b, c = tris.T
    odd = ((a > b).astype(np.int64) + (a > c) + (b > c)) & 1  # 1 where the order is an odd permutation of the sorted
    if clusters < (1 << 21):
        return (odd << 63) | (smallest << 42) | (middle << 21) | largest
    return np.column_stack([odd, smallest, middle, largest])


def source_normals(points: np.ndarray, indices: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """``(T, 3)`` float32 ``(b - a) x (c - a)`` of each triangle of the points times ``scale`` (a power of two, so
    exact), its edges taken in float64 (a chunk at a time). From float32 corners, the 0.1-unit triangles of an
    instance 1e7 from the origin (drawn from float64 points) lay on a 1-unit grid: their normals were noise, and the
    snapped triangles wound back by them faced any way, 5 % of a simplified ball's inwards, culled. A ``scale`` that
    brings the points into a box of side about 1 keeps the float32 products finite and normal: unscaled, a bunny
    1e21 units tall had normals of inf (numpy's 'overflow encountered in cast') and one 1e-21 tall of 0, and 2 and 6
    of its 372 simplified triangles were left turned over."""
    normals = np.empty((len(indices), 3), np.float32)
    for a in range(0, len(indices), NORMAL_CHUNK):
        corners = points[indices[a : a + NORMAL_CHUNK]].astype(np.float64) * scale
        normals[a : a + NORMAL_CHUNK] = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return normals


def subtree_prim_counts(bvh: FlatBvh, depths: np.ndarray | None = None) -> np.ndarray:
    """``(M,)`` int64 number of triangle references (slots) below every node (its own for a leaf)."""
    depths = bvh.depths() if depths is None else depths
    counts = bvh.prim_count.astype(np.int64)
    # Sum children into parents, deepest level first.
    for d in range(int(depths.max(initial=0)), -1, -1):
        inner = np.flatnonzero((depths == d) & (bvh.prim_count == 0))
        if bvh.num_prims and len(inner):
            children = bvh.left_first[inner]
            counts[inner] = counts[children] + counts[children + 1]
    return counts


def select_bvh_nodes(bvh: FlatBvh | WideBoxes, depth: int | None = None, leaves: bool = False) -> np.ndarray:
    """Node ids to draw: the cut at ``depth`` (nodes at that depth plus shallower leaves) or, with ``leaves``,
    every leaf. Either way every triangle reference (slot) lies in exactly one selected node."""
    if bvh.num_prims == 0:
        return np.zeros(0, np.int64)
    depths = bvh.depths()
    is_leaf = bvh.prim_count > 0
    if leaves:
        return np.flatnonzero(is_leaf)
    if depth is None or depth < 0:
        raise ValueError(f"BVH depth must be a non-negative integer, got {depth!r}")
    return np.flatnonzero((depths == depth) | (is_leaf & (depths < depth)))


def bvh_boxes(bvh: FlatBvh | WideBoxes, nodes, color: str = "depth", max_boxes: int = BOX_BUDGET):
    """Wireframe boxes of the BVH nodes ``nodes``, as one ``pyvista.PolyData`` of 12 line cells per box.

    Args:
        bvh: the tree, or a wide one's boxes (:func:`wrt.preview_wide.wide_boxes`).
        nodes: ``(K,)`` int node ids, e.g. from :func:`select_bvh_nodes`.
        color: ``"depth"`` (cell array ``"depth"``) or ``"sah"`` (cell array ``"sah_share"``, see module
            docstring); the SAH share is computed over all of ``nodes``, before any subsampling.
        max_boxes: above this many nodes, an evenly spaced subset in node order is drawn.

    Returns:
        The ``PolyData``; its ``field_data["boxes_total"]`` is ``len(nodes)``.
    """
    pv = import_pyvista()
    if color not in BVH_COLORINGS:
        raise ValueError(f"unknown BVH colouring {color!r}; valid: {', '.join(BVH_COLORINGS)}")
    nodes = np.asarray(nodes, np.int64)
    total = len(nodes)
    depths = bvh.depths()
    if color == "sah":
        # In float64: a box wider than float32 holds (from -2e38 to 2e38) was inf wide, its share inf / inf = NaN.
        extent = np.maximum(bvh.uppers[nodes].astype(np.float64) - bvh.lowers[nodes], 0.0)
        area = extent[:, 0] * extent[:, 1] + extent[:, 1] * extent[:, 2] + extent[:, 2] * extent[:, 0]
        below = subtree_prim_counts(bvh, depths) if isinstance(bvh, FlatBvh) else bvh.refs_below  # WideBoxes
        cost = area * below[nodes]
        values = cost / max(float(cost.sum()), 1e-300)
        name = "sah_share"
    else:
        values = depths[nodes].astype(np.float64)
        name = "depth"
    if total > max_boxes:
        pick = even_rows(total, max_boxes)
        nodes, values = nodes[pick], values[pick]
    # Corner c of a box has coordinate bits (x, y, z) = (c & 1, c & 2, c & 4); edges join corners one bit apart.
    # Each coordinate is the tree's own bound (lo + bit * (hi - lo) rounded hi off by an ulp in float32).
    bits = np.array([[(c >> 0) & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)], bool)
    lo, hi = bvh.lowers[nodes][:, None, :], bvh.uppers[nodes][:, None, :]
    corners = np.where(bits[None], hi, lo).reshape(-1, 3)
    edges = np.array([(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1], np.int64)
    base = (np.arange(len(nodes), dtype=np.int64) * 8)[:, None, None]
    segments = (base + edges[None]).reshape(-1, 2)
    lines = np.hstack([np.full((len(segments), 1), 2, np.int64), segments]).ravel()
    poly = pv.PolyData(corners, lines=lines) if len(nodes) else pv.PolyData()
    if len(nodes):
        poly.cell_data[name] = np.repeat(values, len(edges))
    poly.field_data["boxes_total"] = [total]
    return poly


def frustum_corners(cam: Camera, width: int, height: int, depth: float) -> np.ndarray:
    """``(4, 3)`` world-space corners of the film rectangle at ``depth`` along the view direction, in the
    order top-left, top-right, bottom-right, bottom-left (as seen through the camera)."""
    s = cam.to_struct(width, height)
    eye, right, up, forward = (np.array(v, np.float64) for v in (s.origin, s.right, s.up, s.forward))
    offset = np.array(s.film_offset, np.float64)
    xs = np.array([-0.5, 0.5, 0.5, -0.5]) * s.film_width + offset[0]
    ys = np.array([0.5, 0.5, -0.5, -0.5]) * s.film_height + offset[1]
    across = xs[:, None] * right + ys[:, None] * up
    depth = depth / np.linalg.norm(forward)  # camera-space depth: forward carries the camera's scale
    if s.orthographic:
        return eye + across + depth * forward
    return eye + depth * (forward + across)


def camera_frame(cam: Camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The eye and the unit view direction of ``cam``, ``(3,)`` float64 each, world space."""
    s = cam.to_struct(width, height)
    forward = np.array(s.forward, np.float64)
    return np.array(s.origin, np.float64), forward / np.linalg.norm(forward)


def view_depths(cam: Camera, width: int, height: int, vectors) -> np.ndarray:
    """``(N,)`` float64 depth that each of ``vectors`` (``(N, 3)``, world space, from the eye) advances: camera-space
    depth times the world length of the camera's z axis, the depth :func:`frustum_corners` takes. It is the length
    along the unit view direction where the camera's axes are square to it; under a shear (a camera below a parent
    scaled along another axis) the planes of equal depth, the renderer's clipping planes among them, are tilted."""
    s = cam.to_struct(width, height)
    right, up, forward = (np.array(v, np.float64) for v in (s.right, s.up, s.forward))
    camera_space = np.linalg.solve(np.column_stack([right, up, forward]), np.asarray(vectors, np.float64).T)
    return camera_space[2] * np.linalg.norm(forward)


def sample_rays(scene: Scene, cam: Camera, width: int, height: int, n: int, builder="sah", device="cpu"):
    """``n`` camera rays through an even grid of the ``width x height`` film, traced as the renderer traces
    its AOV rays (same kernel, same ``[near, far]`` range, same accelerator; the colour samples of an image of several
    samples are spread over the pixel, and behind a thin lens over the lens).

    Returns:
        ``origins`` ``(n, 3)``, unit ``directions`` ``(n, 3)`` (float32, world space), ``t`` ``(n,)`` float32
        hit distance (``inf`` on a miss).
    """
    return _sample_ray_ranges(scene, cam, width, height, n, builder, device)[:3]


def _sample_ray_ranges(scene: Scene, cam: Camera, width: int, height: int, n: int, builder, device):
    """:func:`sample_rays`' ``origins, directions, t`` and each ray's traced range ``t_mins, t_maxs`` ``(n,)``
    float32: the clipping range along it, narrowed by the camera's clipping planes."""
    gw = max(1, round(math.sqrt(n * width / height)))
    gh = max(1, math.ceil(n / gw))
    device = resolve_device(device)
    total = gw * gh
    out = [wp.empty(total, dtype=wp.vec3, device=device) for _ in range(2)]
    out += [wp.empty(total, dtype=float, device=device) for _ in range(2)]
    # The film size comes from the width x height camera; only the sampling grid is gw x gh.
    inputs = [cam.to_struct(width, height), gw, gh, 0, 0]
    wp.launch(generate_rays_kernel, total, inputs=inputs, outputs=out, device=device)
    hits = HitBuffer(total, device)
    # The renderer's own accelerator and culling: rays pass back faces of single-sided meshes and cut-out holes. Its
    # film is the ray grid: none of its pixels are drawn, and one of width x height was refused above the renderer's
    # pixel limit (a 10000x10000 film for 48 rays), where the film is only an aspect here.
    # Its 'nothing to render ...' and 'camera sees nothing ...', each ending 'the image is background only', spoke of
    # an image never made (the preview's image=True render says them of its own).
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*nothing to render", category=UserWarning)
        warnings.filterwarnings("ignore", message=".* sees nothing: ", category=UserWarning)
        renderer = Renderer(scene, camera=cam, width=gw, height=gh, device=device, builder=builder,
                            integrator="depth")
    scratch = CullScratch(total, device, renderer.nothing_to_cull, renderer.no_holes)
    intersect_visible(renderer.accel, renderer.surfaces, renderer.materials, renderer.device_scene, out, hits, scratch)
    pick = np.round(np.linspace(0, total - 1, n)).astype(np.int64)
    return tuple(a.numpy()[pick] for a in (out[0], out[1], hits.t, out[2], out[3]))


def preview(
    scene,
    *,
    camera=None,
    bvh_depth: int | None = None,
    bvh_leaves: bool = False,
    bvh_color: str = "depth",
    rays: int = 0,
    image: bool = False,
    width: int | None = None,
    height: int | None = None,
    builder: str = "sah",
    device="cpu",
    window_size=(1280, 800),
    max_triangles: int = TRIANGLE_BUDGET,
    max_boxes: int = BOX_BUDGET,
    off_screen: bool | None = None,
    show_text: bool = True,
    show_lights: bool = True,
    bvh_instance: int | str | None = None,
    bvh_layout: str = "binary",
):
    """A ``pyvista.Plotter`` showing the scene, the camera frustum with its near clipping plane, the scene's lights
    and, on request, BVH boxes, rays and the image.

    Nothing is shown yet: call ``.show()`` (a window, or inline in a notebook) or ``.screenshot(path)``.

    Args:
        scene: a :class:`wrt.Scene`, or a USD file to load.
        camera: the camera, as for :func:`wrt.render` (``None``: the render settings' camera, else the stage's
            first camera, else one framing it; see :func:`wrt.render.resolve_view`).
        bvh_depth: draw the BVH cut at this depth (see module docstring); past the tree's deepest leaf the cut is
            its leaves, which a warning and the summary say.
        bvh_leaves: draw every BVH leaf instead.
        bvh_color: ``"depth"`` or ``"sah"`` (SAH cost share), the colouring of the boxes.
        rays: number of sample camera rays to draw.
        image: render the scene with wrt and show the picture on the frustum's image plane.
        width: image width in pixels (``None``: the render settings', else 640); the frustum, rays and image use
            this film aspect.
        height: image height in pixels (``None``: the render settings', else 480).
        builder: BVH builder for the boxes, the rays and the image. The boxes are those of the tree
            :func:`wrt.trace` builds: ``wrt.build_bvh(*scene.triangles(), builder)``, with ``presplit=6`` for
            ``sah`` (the TLAS's in a scene with instances or analytic shapes).
        device: Warp device for building, tracing and rendering.
        window_size: ``(width, height)`` of the preview window in pixels.
        max_triangles: above this many triangles the scene is simplified for display (the title says so).
        max_boxes: above this many BVH boxes an even subset is drawn (the text says so).
        off_screen: render off-screen; ``None`` means off-screen when there is no display or ``pyvista.OFF_SCREEN``.
            ``False`` (a window) without a display raises :class:`PreviewUnavailable`.
        show_text: write a summary in the top-left corner of the view.
        show_lights: draw the outlines of the scene's lights (see :mod:`wrt.preview_lights`).
        bvh_instance: with ``bvh_depth`` or ``bvh_leaves``, draw the boxes of this instance's own BVH (its
            prototype's BLAS, placed by its transform; :mod:`wrt.preview_blas`) instead of the TLAS: its index in
            ``scene.instances`` or its path (``/instancer[index]`` for a PointInstancer's).
        bvh_layout: the layout whose boxes ``bvh_depth`` and ``bvh_leaves`` draw, as :func:`wrt.trace` names them:
            ``binary`` or ``compact`` (the same binary tree), ``wide`` (BVH4) or ``wide8`` (BVH8), collapsed from
            the binary tree as the trace collapses it (:mod:`wrt.preview_wide`). Only ``binary`` for a scene with
            instances or analytic shapes: its two-level BVH is traced by no other layout (``compact`` and the wide
            ones trace its instances flattened and refuse its shapes).

    Raises:
        PreviewUnavailable: pyvista is missing, VTK cannot render on this machine, or ``off_screen=False`` asks for
            a window where there is no display.
        ValueError: bad arguments (unknown camera, builder, layout or colouring, both ``bvh_depth`` and
            ``bvh_leaves``, a ``bvh_layout`` but binary drawn for a scene with instances or analytic shapes).
    """
    pv = import_pyvista()
    # By their truth, image="false" rendered the scene, show_text="false" wrote the summary and off_screen="false"
    # opened no window.
    bvh_leaves, image, show_text, show_lights = (
        flag(value, label) for value, label in
        ((bvh_leaves, "bvh_leaves"), (image, "image"), (show_text, "show_text"), (show_lights, "show_lights")))
    off_screen = None if off_screen is None else flag(off_screen, "off_screen")
    # A window without a display: VTK warned 'bad X server connection', and the plotter drew nothing.
    if off_screen is not None and not off_screen and not has_display():
        raise PreviewUnavailable(f"off_screen=False asks for a window, and there is no display ({_no_display_reason()})"
                                 ": pass off_screen=True (or None, off-screen without a display) and save the view "
                                 "with .screenshot('preview.png'), as wrt preview does, or run under xvfb-run")
    if bvh_depth is not None and bvh_leaves:
        raise ValueError("give bvh_depth or bvh_leaves, not both")
    if bvh_instance is not None and bvh_depth is None and not bvh_leaves:
        raise ValueError(f"bvh_instance={bvh_instance!r} draws an instance's BVH boxes: give bvh_depth or bvh_leaves "
                         "too")
    if bvh_depth is not None and (
        isinstance(bvh_depth, bool) or not isinstance(bvh_depth, (int, np.integer)) or bvh_depth < 0
    ):
        raise ValueError(f"bvh_depth must be a non-negative integer, got {bvh_depth!r}")
    for label, value in (("max_triangles", max_triangles), ("max_boxes", max_boxes)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
            raise ValueError(f"{label} must be a positive integer, got {value!r}")
    if bvh_color not in BVH_COLORINGS:
        raise ValueError(f"unknown BVH colouring {bvh_color!r}{did_you_mean(bvh_color, BVH_COLORINGS)}; valid: "
                         f"{', '.join(BVH_COLORINGS)}")
    if isinstance(rays, bool) or not isinstance(rays, (int, np.integer)) or not 0 <= rays <= MAX_RAYS:
        raise ValueError(f"rays must be an integer from 0 to {MAX_RAYS:,}, got {rays!r}")
    for label, value in (("width", width), ("height", height)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0):
            raise ValueError(f"{label} must be a positive integer, got {value!r}")  # True too, as wrt.render says
    check_window_size(window_size)
    Builder.from_str(builder)  # checked now, not only when boxes, rays or the image need the tree
    check_layout(bvh_layout)
    if bvh_depth is None and not bvh_leaves:  # said as wrt preview says it of its flags: a choice with no effect
        for label, value, default in (("bvh_color", bvh_color, "depth"), ("bvh_layout", bvh_layout, "binary")):
            if value != default:
                warnings.warn(f"{label}={value!r} only affects the BVH boxes, and none are drawn without bvh_depth or "
                              "bvh_leaves", stacklevel=2)
    device = resolve_device(device)
    scene = _as_scene(scene)
    if bvh_depth is not None or bvh_leaves:  # the layout of the boxes drawn; without any it picks nothing
        check_drawn_layout(scene, bvh_layout)  # before any work
    instance = None if bvh_instance is None else instance_row(scene, bvh_instance)  # refused before any work
    if show_lights:  # as a render checks them: a NaN assigned to a light's position or transform was drawn as NaN
        check_lights(scene.lights)  # points without a word, where a render refuses it naming the light
    stats = scene.stats()
    if not stats["rendered_triangles"] and not stats.get("rendered_shapes", 0):  # an empty view, else unexplained
        alone = "the camera and the lights" if scene.lights and show_lights else "the camera"
        warnings.warn(f"{scene.source or 'scene'}: nothing to draw (no triangles or analytic shapes): the preview "
                      f"shows {alone} alone", stacklevel=2)
    asked = (width, height)
    cam, width, height = resolve_view(scene, camera, width, height)
    if image:  # refused now, as the CLI refuses it, not after the scene is drawn and its tree built
        check_asked_pixels(scene, width, height, 1, asked)
    if off_screen is None:
        off_screen = bool(pv.OFF_SCREEN) or not has_display()
    if off_screen:
        offscreen_backend()

    name = Path(scene.source).name if scene.source else "scene"
    title = f"wrt preview: {name}, {contents_summary(scene.stats())}"
    plotter = pv.Plotter(off_screen=off_screen, window_size=list(window_size), title=title)
    # A preview that fails part-way (a render refused, an interrupt) closes its plotter: pyvista keeps every open
    # plotter in a registry, which held the failed one's window and the meshes drawn so far for the session.
    try:
        plotter.set_background(BACKGROUND)
        lines = [title.removeprefix("wrt preview: ")]  # the summary text

        note = _add_scene(pv, plotter, scene, max_triangles)
        if note:
            title += f", {note}"
            lines.append(note)
        # Trace the sample rays before drawing the frustum: their hits place the image plane.
        lower, upper = (np.asarray(b, np.float64) for b in scene.bounds())
        eye, forward = camera_frame(cam, width, height)
        # The image first, then the rays, whose renderer shares the warnings said (the far-view ones, a camera that sees
        # nothing): each was said by both, and the image's words are those of the image it makes.
        with shown_across_renderers(set()):
            picture = render(scene, camera=cam, width=width, height=height, device=device, builder=builder) if image \
                else None
            ray_data = _sample_ray_ranges(scene, cam, width, height, rays, builder, device) if rays else None
        far, image_depth = _display_depths(cam, width, height, lower, upper, ray_data)
        diagonal = _scene_diagonal(lower, upper)
        # A perspective frustum narrows to its apex at the eye: a dot larger than a fifth of the image plane's depth
        # would hide it. An orthographic one does not, and its image plane may lie at or behind the eye (a near plane
        # behind it), where that cap made the radius negative and the dot vanished.
        eye_radius = 0.01 * diagonal if cam.projection == "orthographic" else min(0.01 * diagonal, 0.2 * image_depth)
        _add_frustum(pv, plotter, cam, width, height, far, image_depth, eye_radius=eye_radius)
        if show_lights and scene.lights:
            glyphs, light_note = light_glyphs(scene.lights, lower, upper)
            if glyphs is not None:
                plotter.add_mesh(glyphs, color=LIGHT_COLOR, line_width=2, name="lights")
            lines.append(light_note)
        label = cam.path or ("(given)" if isinstance(camera, Camera) else "(framing the scene)")
        lines.append(f"camera {label}: {cam.projection}, film {width}x{height}")
        if bvh_depth is not None or bvh_leaves:
            accel = get_accelerator(scene, "wrt", builder, device)
            bvh, to_world = (accel.bvh, None) if instance is None else instance_blas(accel, scene, instance)
            if bvh_layout in WIDE_WIDTHS:  # collapsed from the binary tree, as wrt.trace collapses it
                bvh = wide_boxes(convert_layout(bvh, bvh_layout))
            summary, capped = _add_bvh(plotter, bvh, bvh_depth, bvh_color, max_boxes, window_size[0], to_world)
            if capped:  # in the title too, as the simplification is: wrt preview prints it, and show_text may be off
                title += f", {capped}"
            if instance is not None:
                prototype = scene.prototypes[scene.instances.prototype[instance]].path
                lines.append(f"BLAS ({builder}) of instance {scene.instances.path(instance)} (prototype {prototype}, "
                             f"placed by the instance's transform) {summary}")
            elif hasattr(accel, "tlas"):  # instances or analytic shapes: a two-level BVH, whose top level is drawn
                # A leaf holds up to TLAS_LEAF_SIZE entries: 'a leaf per instance or shape' promised more boxes than
                # drawn.
                lines.append(f"TLAS ({builder}) {summary} ({tlas_entries(scene, accel.num_entries)}; up to "
                             f"{TLAS_LEAF_SIZE} per leaf)")
            elif bvh_layout in WIDE_WIDTHS:
                lines.append(f"BVH{WIDE_WIDTHS[bvh_layout]} ({builder}, layout {bvh_layout}) {summary}")
            else:
                lines.append(f"BVH ({builder}) {summary}")
        if ray_data is not None:
            lines.append(_add_rays(pv, plotter, *ray_data, view_depths(cam, width, height, ray_data[1]), far))
        if image:
            quad = pv.PolyData(frustum_corners(cam, width, height, image_depth), faces=[4, 0, 1, 2, 3])
            quad.active_texture_coordinates = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # row 0 on top
            plotter.add_mesh(quad, texture=pv.Texture(to_srgb8(picture.rgb)), lighting=False, name="image")
            lines.append("image: wrt render on the image plane")

        # Look at everything from above, behind and beside the camera, so the frustum is seen from outside.
        up = np.array([0.0, 0.0, 1.0]) if scene.up_axis == "Z" else np.array([0.0, 1.0, 0.0])
        side = np.cross(forward, up)
        if np.linalg.norm(side) < 1e-6:  # camera looks straight up or down
            side = np.cross(forward, np.roll(up, 1))
        side /= np.linalg.norm(side)
        view = 0.3 * side + 1.1 * up - 0.9 * forward
        focus = 0.5 * (lower + upper)
        plotter.camera_position = [focus + view * diagonal, focus, up]
        plotter.reset_camera()
        plotter.title = title
        if show_text:
            # VTK's corner text shrinks to fit the window and, where a line is too wide even at its smallest font (about
            # 2.2 pixels a character), draws nothing at all: a 180-character TLAS line took the whole text out of a
            # 320-pixel-wide window. Lines are wrapped to fit with room to spare.
            chars = max(MIN_TEXT_COLUMNS, window_size[0] // TEXT_PIXELS_PER_CHARACTER)
            wrapped = (textwrap.fill(line, chars, subsequent_indent="  ", break_on_hyphens=False) for line in lines)
            text = "\n".join(wrapped)
            plotter.add_text(text, position="upper_left", font_size=9, color="black", name="summary")
    except BaseException:
        plotter.close()
        raise
    return plotter


def tlas_entries(scene: Scene, total: int) -> str:
    """What the ``total`` entries of ``scene``'s TLAS are, counted: one per instance traced in a BLAS (of a prototype
    with triangles and a transform that inverts), one per analytic shape (an instanced one once per instance) and one
    for all the non-instanced meshes where there are any; then how many instances the trace leaves out (a transform
    that does not invert). 'An instance or shape each, one for the other meshes' was said of every TLAS: three
    instances alone read as two and a mesh entry."""
    meshes = 1 if scene.num_flat_triangles else 0
    with_triangles = scene.prototype_ranges()[:, 1] > 0 if len(scene.prototypes) else np.zeros(0, bool)
    traced = scene.instance_inverses()[1]
    instances = int((with_triangles[scene.instances.prototype] & traced).sum()) if len(scene.instances) else 0
    shapes = total - meshes - instances  # the rest: shape entries (a degenerate shape's is left out of the tree)
    parts = [counted(instances, "instance")] if instances else []
    parts += [counted(shapes, "analytic shape")] if shapes else []
    parts += ["1 for the non-instanced meshes"] if meshes else []
    # Instances whose transform does not invert (a zero scale) have no entry: a TLAS of only such read 'empty (no
    # triangles or analytic shapes) ... 0 entries: none' of a scene whose title counts their triangles.
    left_out = int((~traced).sum()) if len(scene.instances) else 0
    skipped = f"; {counted(left_out, 'instance')} left out of the trace, their transforms singular" if left_out else ""
    return f"{counted(total, 'entry', 'entries')}: {', '.join(parts) or 'none'}{skipped}"


def check_window_size(window_size) -> None:
    """Raises ValueError unless ``window_size`` is ``(width, height)``, two integers in ``[1, MAX_WINDOW]``."""
    sides = list(window_size) if isinstance(window_size, (tuple, list)) else []
    if len(sides) != 2 or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in sides):
        raise ValueError(f"window_size must be (width, height) in pixels, got {window_size!r}")
    if not all(1 <= v <= MAX_WINDOW for v in sides):
        raise ValueError(f"window size must be 1 to {MAX_WINDOW} pixels per side (OpenGL's usual largest "
                         f"framebuffer), got {sides[0]}x{sides[1]}")


def _add_scene(pv, plotter, scene: Scene, max_triangles: int) -> str:
    """Draws the meshes, simplified above ``max_triangles``; returns a note saying so, or ``""``.

    Back faces of single-sided meshes and shapes are culled, as they are invisible to a single-sided renderer: seen
    from outside a room, its walls vanish and show the inside.
    """
    note = ""
    all_shapes = shape_count(scene)  # before any cut of the instances: of 40 shapes, 5 of the 8 kept read '5 of 8'
    if len(scene.instances) and scene.stats()["rendered_triangles"] > EXPAND_FACTOR * max_triangles:
        # Too many to flatten for display: those that fit in the budget, spread over the scene (the first ones filled
        # one corner of a PointInstancer written row by row).
        offsets = scene.instance_offsets()
        rows = rows_within(scene.instances.to_world[:, :3, 3], np.diff(offsets), int(offsets[0]), max_triangles)
        note = f"showing {len(rows):,} of {len(scene.instances):,} instances"
        note += ", spread evenly" if 0 < len(rows) < len(scene.instances) else ""
        scene = dataclasses.replace(scene, instances=scene.instances.take(rows))
    points, indices = world_triangles(scene)
    sided = _expand_rows(scene, scene.triangle_double_sided().astype(np.uint8))
    attributes = np.column_stack([triangle_colors(scene), sided])
    if len(indices) > max_triangles:
        points, indices, attributes = cluster_vertices(points, indices, attributes, max_triangles)
        # After a cut of the instances, the triangles left: the note says both (the second replaced the first).
        kept = f"{len(indices):,} of {'the ' if note else ''}{scene.stats()['rendered_triangles']:,} triangles"
        note = (f"{note} and {kept} left" if note else f"showing {kept}") + " (simplified for display)"
    _add_sided(pv, plotter, points, indices, attributes[:, :3], attributes[:, 3], "scene")
    shapes = shape_meshes(scene, max_shapes=SHAPE_BUDGET, max_triangles=max_triangles)
    if shapes is not None:
        _add_sided(pv, plotter, shapes.points, shapes.regular_faces, shapes.cell_data["color"],
                   shapes.cell_data["double_sided"], "shapes")
        # A Points prim of a million spheres was cut to the budget unsaid.
        drawn = int(shapes.field_data["shapes_drawn"][0])
        cut = f"showing {drawn:,} of {all_shapes:,} analytic shapes, spread evenly" if drawn < all_shapes else ""
        segments = int(shapes.field_data["segments"][0])
        if segments < SHAPE_SEGMENTS:
            cut = f"{cut + ',' if cut else 'analytic shapes'} with {segments} segments per circle"
        note = ", ".join(filter(None, [note, cut]))
    return note


def _add_sided(pv, plotter, points, indices, colors, double_sided, label: str) -> None:
    """Draws triangles with their ``colors``: those of single-sided surfaces as ``label`` with back faces culled, the
    others as ``label_double_sided``."""
    for sided, name in ((0, label), (1, f"{label}_double_sided")):
        rows = double_sided == sided
        if rows.any():
            mesh = pv.PolyData.from_regular_faces(points, indices[rows])
            mesh.cell_data["color"] = colors[rows]
            culling = None if sided else "back"
            plotter.add_mesh(mesh, scalars="color", rgb=True, show_scalar_bar=False, culling=culling, name=name)


def shape_count(scene: Scene) -> int:
    """How many analytic shapes :func:`shape_meshes` draws of ``scene`` within every budget: its own, then those of
    each instance's prototype."""
    per_prototype = np.array([len(p.shapes) for p in scene.prototypes] or [0], np.int64)
    instanced = int(per_prototype[scene.instances.prototype].sum()) if len(scene.instances) else 0
    return len(scene.shapes) + instanced


def shape_meshes(scene: Scene, segments: int = SHAPE_SEGMENTS, max_shapes: int = SHAPE_BUDGET,
                 max_triangles: int | None = None):
    """The scene's analytic shapes (non-instanced, then each instance's) tessellated for display as one
    ``pyvista.PolyData``, or None without shapes; at most ``max_shapes`` are drawn (above that, an even subset spread
    over the scene: :func:`wrt.preview_subsets.spread_rows` of their centres), with ``segments`` per circle, or
    fewer (down to ``MIN_SHAPE_SEGMENTS``) where that makes more than ``max_triangles`` triangles. Cell arrays:
    ``"color"`` uint8 sRGB (see :func:`display_colors`) and ``"double_sided"`` uint8, the shape's ``doubleSided``;
    ``field_data["segments"]`` holds the segments used, ``field_data["shapes_drawn"]`` and ``["shapes_total"]`` how
    many of how many shapes are drawn."""
    from .primitives import tessellate

    none = np.full(3, np.nan, np.float32)
    own_shapes = list(getattr(scene, "shapes", []))
    instances = getattr(scene, "instances", ())
    tints = getattr(instances, "colors", ())
    prototypes = getattr(scene, "prototypes", [])
    # Every (instance, shape of its prototype) pair, in instance order, as index arrays: no Python step per instance.
    per_prototype = np.array([len(getattr(p, "shapes", [])) for p in prototypes] or [0], np.int64)
    owners = np.flatnonzero(per_prototype[instances.prototype] > 0) if len(instances) else np.zeros(0, np.int64)
    counts = per_prototype[instances.prototype[owners]] if len(owners) else np.zeros(0, np.int64)
    pair_instance = np.repeat(owners, counts)
    pair_shape = np.arange(len(pair_instance)) - np.repeat(np.cumsum(counts) - counts, counts)
    total = len(own_shapes) + len(pair_instance)
    if not total:
        return None
    picked = np.arange(total)
    if total > max_shapes:
        # The first max_shapes filled one corner of a Points prim written row by row: an even subset over the scene.
        centres = [np.array([s.to_world[:3, 3] for s in own_shapes]).reshape(-1, 3)]
        if len(pair_instance):
            local = [np.array([s.to_world[:3, 3] for s in getattr(p, "shapes", [])]).reshape(-1, 3)
                     for p in prototypes]
            offsets = np.concatenate([[0], np.cumsum(per_prototype)])[:len(prototypes)]
            table = np.concatenate(local).astype(np.float64)
            # In chunks: the (N, 4, 4) copies of a million instances' matrices at once took 128 MB.
            for a in range(0, len(pair_instance), CENTRE_CHUNK):
                owner, shape = pair_instance[a : a + CENTRE_CHUNK], pair_shape[a : a + CENTRE_CHUNK]
                m = instances.to_world[owner]
                where = table[offsets[instances.prototype[owner]] + shape]
                centres.append(np.einsum("nij,nj->ni", m[:, :3, :3], where) + m[:, :3, 3])
        picked = spread_rows(np.concatenate(centres), max_shapes)
    placed = []  # (shape, to_world, instance colour)
    for r in picked:
        if r < len(own_shapes):
            placed.append((own_shapes[r], np.eye(4), none))
        else:
            i, j = pair_instance[r - len(own_shapes)], pair_shape[r - len(own_shapes)]
            tint = tints[i] if len(tints) else none
            placed.append((prototypes[instances.prototype[i]].shapes[j], instances.to_world[i], tint))
    own = np.array([none if s.color is None else s.color for s, _, _ in placed], np.float32)
    ids = np.array([getattr(s, "material_id", -1) for s, _, _ in placed], np.int64)
    colors = to_srgb8(display_colors(own, ids, np.array([t for _, _, t in placed]), scene.materials or []))
    pv = import_pyvista()
    # Each distinct (kind, params) is tessellated once, in canonical space, and its copies are placed with numpy (as
    # tessellate places one: points through the matrix, winding flipped where it mirrors): a tessellate call per
    # shape took 20 s for the 20,000 spheres drawn of a Points prim.
    matrices = np.array([to_world @ s.to_world for s, to_world, _ in placed])
    groups = {}  # (kind, params) -> rows of placed
    for k, (shape, _, _) in enumerate(placed):
        groups.setdefault((shape.kind, shape.params.tobytes()), []).append(k)

    def canonical(rows, n: int):
        """Points and triangles of the shape of ``rows`` at ``n`` segments, in its canonical space."""
        first = placed[rows[0]][0]
        return tessellate(type(first)(first.path, first.kind, np.eye(4), first.params), n)[:2]

    # Coarser circles while the copies would make more than max_triangles (20,000 spheres of 24 segments are 10.6M
    # triangles, where the meshes are simplified to 2M): the count of each kind is one tessellation away.
    tessellations = {rows[0]: canonical(rows, segments) for rows in groups.values()}
    for n in range(segments - 2, MIN_SHAPE_SEGMENTS - 1, -2):
        if max_triangles is None or sum(len(r) * len(tessellations[r[0]][1]) for r in groups.values()) <= max_triangles:
            break
        segments = n
        tessellations = {rows[0]: canonical(rows, n) for rows in groups.values()}
    points, faces, cells, base = [], [], [], 0
    for rows in groups.values():
        pts, tris = tessellations[rows[0]]
        m = matrices[rows]
        points.append((np.einsum("gij,vj->gvi", m[:, :3, :3], pts) + m[:, None, :3, 3]).reshape(-1, 3))
        copies = np.broadcast_to(tris, (len(rows), *tris.shape)).copy()
        mirrored = np.linalg.det(m[:, :3, :3]) < 0
        copies[mirrored] = copies[mirrored][:, :, [0, 2, 1]]
        faces.append((copies + base + len(pts) * np.arange(len(rows))[:, None, None]).reshape(-1, 3))
        cells.append(np.repeat(rows, len(tris)))
        base += len(rows) * len(pts)
    # float64 points, as placed: in float32 a ball of radius 0.5 at 1e7 from the origin (an ulp is 1 there) was drawn
    # as a flat bar, where the renderer, which intersects shapes in their own space, draws it round.
    mesh = pv.PolyData.from_regular_faces(np.concatenate(points), np.concatenate(faces))
    cells = np.concatenate(cells)
    mesh.cell_data["color"] = colors[cells]
    mesh.cell_data["double_sided"] = np.array([s.double_sided for s, _, _ in placed], np.uint8)[cells]
    mesh.field_data["segments"] = [segments]
    mesh.field_data["shapes_drawn"] = [len(placed)]
    mesh.field_data["shapes_total"] = [total]
    return mesh


def _add_frustum(pv, plotter, cam: Camera, width, height, far: float, image_depth: float, eye_radius: float):
    """Draws the frustum (eye to the far rectangle), the image-plane rectangle, the near clipping plane's rectangle
    (where the near plane is not at the eye: in front of it, or behind an orthographic camera, which sees from
    there) and a dot at the eye."""
    frame = np.concatenate([frustum_corners(cam, width, height, d) for d in (0.0, far, image_depth)])
    segments = [(k, 4 + k) for k in range(4)] + [(4 + k, 4 + (k + 1) % 4) for k in range(4)]
    segments += [(8 + k, 8 + (k + 1) % 4) for k in range(4)]
    if cam.projection == "orthographic":  # the depth-0 corners are distinct: close the box
        segments += [(k, (k + 1) % 4) for k in range(4)]
    lines = np.hstack([np.full((len(segments), 1), 2), np.array(segments)]).ravel()
    plotter.add_mesh(pv.PolyData(frame, lines=lines), color=FRUSTUM_COLOR, line_width=2, name="frustum")
    near = clipping_depths(cam)[0]
    # Rays start there: what lies nearer the eye is clipped away, or, behind an orthographic camera (a negative near,
    # as USD's frustum takes it), what lies between it and the eye is seen too, which the box from the eye leaves out.
    if near != 0.0:
        outline = np.hstack([[5], np.arange(4), [0]])
        rectangle = pv.PolyData(frustum_corners(cam, width, height, near), lines=outline)
        plotter.add_mesh(rectangle, color=FRUSTUM_COLOR, line_width=1, name="near_plane")
    eye, _ = camera_frame(cam, width, height)
    dot = pv.Sphere(radius=eye_radius)
    dot.points = dot.points.astype(np.float64) + eye  # pyvista's float32 centre put the dot on a 1-unit grid at 1e7
    plotter.add_mesh(dot, color=FRUSTUM_COLOR, name="eye")


def _add_bvh(plotter, bvh: FlatBvh | WideBoxes, depth, color: str, max_boxes: int, window_width: int = 1280,
             to_world=None) -> tuple[str, str]:
    """Draws the BVH cut at ``depth`` (every leaf when ``None``), its colour bar fitted to a window ``window_width``
    pixels wide, its boxes' corners moved by ``to_world`` (``(4, 4)``, from the tree's space: an instance's BLAS);
    returns a summary for the text and a note for the title when only a subset of the boxes is drawn (else ``""``)."""
    from matplotlib.colors import LinearSegmentedColormap

    if not bvh.num_prims:  # a scene with nothing to draw: 'past the deepest leaf ... the leaves, 0 boxes' said before
        return f"{counted(bvh.num_nodes, 'node')}: empty (no triangles or analytic shapes traced), no boxes", ""
    nodes = select_bvh_nodes(bvh, depth, leaves=depth is None)
    boxes = bvh_boxes(bvh, nodes, color, max_boxes)
    shown = boxes.n_cells // 12
    if to_world is not None and shown:  # float64, as an instance's triangles are drawn (world_triangles)
        m = np.asarray(to_world, np.float64)
        boxes.points = np.asarray(boxes.points, np.float64) @ m[:3, :3].T + m[:3, 3]
    if shown:
        scalars = "sah_share" if color == "sah" else "depth"
        values = boxes.cell_data[scalars]
        low, high = float(values.min()), float(values.max())
        if color == "depth":
            levels = int(high - low) + 1
            clim = [low, high] if levels > 1 else [low - 0.5, low + 0.5]
            # Only counts whose labels fall on whole depths, (levels - 1) steps split evenly, however many levels:
            # five labels over depths 6 to 21 put '17' at 17.25, on the edge of depth 18's band. Two (the ends) always
            # do; one level draws no bar (show_scalar_bar below), and is given two labels all the same.
            counts = [k for k in range(min(levels, 8), 1, -1) if (levels - 1) % (k - 1) == 0] or [2]
            bar = fit_scalar_bar("BVH node depth", ["%.0f"], clim, counts, window_width)
            cmap = LinearSegmentedColormap.from_list("wrt_depth", DEPTH_COLORS)
            style = {"cmap": cmap, "n_colors": levels, "show_scalar_bar": levels > 1}
        else:
            clim = [low, high] if high > low else [0.5 * low, 2.0 * low]
            bar = fit_scalar_bar("SAH cost share", ["%.1e", "%.0e"], clim, [5, 4, 3, 2], window_width)
            style = {"cmap": LinearSegmentedColormap.from_list("wrt_sah", SAH_COLORS), "log_scale": clim[0] > 0}
        plotter.add_mesh(boxes, scalars=scalars, clim=clim, line_width=2, scalar_bar_args=bar, name="bvh", **style)
    levels = int(bvh.depths().max(initial=0))
    what = "leaves" if depth is None else f"cut at depth {depth}"
    if depth is not None and depth > levels:  # drawn as the leaves, which looked like a cut that deep
        what += f", past the deepest leaf (depth {levels}): the leaves"
        warnings.warn(f"BVH depth {depth} is past the tree's deepest leaf (depth {levels}): the boxes drawn are its "
                      "leaves", stacklevel=3)
    count = counted(len(nodes), "box", "boxes") if shown == len(nodes) else f"{shown:,} of {len(nodes):,} boxes"
    capped = f"showing {shown:,} of {len(nodes):,} BVH boxes" if shown < len(nodes) else ""
    return f"{counted(bvh.num_nodes, 'node')}, depth {levels}: {what}, {count}", capped


def fit_scalar_bar(title: str, formats: list[str], clim, counts: list[int], window_width: int) -> dict:
    """``scalar_bar_args`` for a horizontal colour bar, centred, whose labels fit a window ``window_width`` pixels
    wide: neither overlapping each other nor running past the window's sides. pyvista's bar, five ``%.1e`` labels at
    18 pixels on 60 % of the width from 35 %, ran them together below about 640 pixels and off the right side below
    500. Tried in order: the earlier of ``formats``, at least three labels, the larger font (``BAR_FONT_SIZES``),
    more of ``counts`` labels; where none fits (a thumbnail), the last of these."""
    left = 0.5 * (1.0 - BAR_WIDTH)  # the end labels stick out half their width on either side
    bar_pixels, margin = BAR_WIDTH * window_width, left * window_width

    def fits(fmt: str, font: int, n: int) -> bool:
        label = max(len(fmt % v) for v in clim) * font * BAR_CHARACTER_EM
        return label * (1.0 + BAR_LABEL_GAP) <= bar_pixels / (n - 1) and label / 2 + 2 <= margin

    candidates = sorted(((f, font, n) for f in formats for font in BAR_FONT_SIZES for n in counts),
                        key=lambda c: (formats.index(c[0]), c[2] < 3, -c[1], -c[2]))
    fmt, font, n = next((c for c in candidates if fits(*c)), candidates[-1])
    return {"title": title, "fmt": fmt, "n_labels": n, "label_font_size": font, "title_font_size": font,
            "width": BAR_WIDTH, "position_x": left}


def _add_rays(pv, plotter, origins, directions, t, t_mins, t_maxs, depth_rates, far: float) -> str:
    """Draws rays from their origin (or from their start ``t_mins`` where that lies behind it: an orthographic
    camera's near plane behind the camera) to their hit (with a dot) or, on a miss, to the end of their traced range
    ``t_maxs`` (a clipping plane that cuts them), at most the display far plane, ``far`` deep (``depth_rates``: the
    :func:`view_depths` of the directions)."""
    origins, directions, t, t_mins, t_maxs = (np.asarray(a, np.float64) for a in (origins, directions, t, t_mins,
                                                                                   t_maxs))
    hit = np.isfinite(t)
    # Camera rays advance in depth (Camera.to_struct keeps their directions finite), however slowly: a clamp of the
    # rate to 1e-6 stopped the corner rays of a lens wider than 179.9998 degrees near the eye, off the far rectangle.
    with np.errstate(divide="ignore"):
        t_far = np.where(depth_rates > 0.0, far / depth_rates, 0.0)
    # The stretch the renderer traces: a miss drawn on to the far plane past a clipping plane ran through surfaces
    # the render does not see, and a hit behind the camera's plane was drawn from that plane back to it.
    t_start = np.minimum(t_mins, 0.0)
    t_end = np.maximum(np.where(hit, t, np.minimum(t_maxs, t_far)), t_start)
    ends = origins + t_end[:, None] * directions
    origins = origins + t_start[:, None] * directions
    for mask, color, label in ((hit, HIT_COLOR, "rays_hit"), (~hit, MISS_COLOR, "rays_miss")):
        k = int(mask.sum())
        if k:
            segments = np.stack([np.full(k, 2), np.arange(k), np.arange(k) + k], axis=1).ravel()
            rays = pv.PolyData(np.concatenate([origins[mask], ends[mask]]), lines=segments)
            plotter.add_mesh(rays, color=color, line_width=1, name=label)
    if hit.any():
        dots = pv.PolyData(ends[hit])
        plotter.add_mesh(dots, color=HIT_COLOR, point_size=8, render_points_as_spheres=True, name="hits")
    return f"rays: {len(t)} ({int(hit.sum())} hit, {int((~hit).sum())} miss)"


def _as_scene(scene) -> Scene:
    """``scene``, or the USD file it names loaded, checked as the renderer checks it: an instance or shape whose
    transform holds a NaN or lies past float32's range was drawn with NaN points (or a block of them made) without a
    word, where a trace or render refuses the scene naming it (:func:`wrt.trace.check_finite_transforms`)."""
    if isinstance(scene, Scene):
        # As a trace or render does: the triangles, colours and bounds drawn are read from the scene's caches, which
        # otherwise still held a mesh replaced since (while the BVH boxes, through get_accelerator, were new).
        scene.drop_stale_caches()
    elif isinstance(scene, (str, os.PathLike)):
        from .usd import load_usd

        scene = load_usd(scene)
    else:
        raise TypeError(f"scene must be a wrt.Scene or a USD file path, not {type(scene).__name__}")
    check_finite_transforms(scene)
    return scene


def clipping_depths(cam: Camera) -> tuple[float, float]:
    """The near and far clipping planes' depths (:func:`view_depths`). The clipping range is camera-space depth: a
    camera scaled with its scene (a units change on a parent) clips at its near and far times that scale, as the
    renderer's rays do."""
    depth_scale = float(np.linalg.norm(cam.to_world[:3, 2]))  # world length of one unit of camera-space depth
    near, far = (float(v) * depth_scale for v in cam.clipping_range)
    return near, far


def _scene_diagonal(lower, upper) -> float:
    """The length of the scene box's diagonal, which sizes the eye dot, the view and the frustum of a camera facing
    away; 1e-6 for a box of no size (a point). A floor of 1e-6 under every box grew the eye dot against a scene
    smaller than that: to a quarter of one 1e-9 across, a ball over the frustum's apex."""
    diagonal = float(np.linalg.norm(np.asarray(upper, np.float64) - np.asarray(lower, np.float64)))
    return diagonal if diagonal > 0.0 else 1e-6


def _display_depths(cam: Camera, width: int, height: int, lower, upper, ray_data) -> tuple[float, float]:
    """Depths (:func:`view_depths`) of the display far plane and of the image plane."""
    eye, _ = camera_frame(cam, width, height)
    near, far = clipping_depths(cam)
    corners = np.stack(np.meshgrid(*zip(lower, upper), indexing="ij"), axis=-1).reshape(-1, 3)
    depths = view_depths(cam, width, height, corners - eye)
    diagonal = _scene_diagonal(lower, upper)
    deepest = float(depths.max()) if depths.max() > near else near + diagonal  # scene behind the camera
    display_far = min(far, deepest)
    nearest = None
    if ray_data is not None:
        origins, directions, t = ray_data[:3]
        hit = np.isfinite(t)
        if hit.any():
            ends = origins[hit] + t[hit, None] * directions[hit]
            nearest = float(np.min(view_depths(cam, width, height, ends - eye)))
    if nearest is None and depths.min() > near:
        nearest = float(depths.min())
    if nearest is None or nearest <= near:
        nearest = 0.3 * display_far
    # In front of the nearest hit, a fraction of its depth from the eye; behind an orthographic camera (a negative
    # near plane) that fraction of a negative depth lay past the hit, inside what the image pictures.
    image_depth = min(max(nearest - (1.0 - IMAGE_PLANE_FRACTION) * abs(nearest), near), display_far)
    return display_far, image_depth
