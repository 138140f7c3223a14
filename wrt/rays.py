"""Ray sets for testing and benchmarking: camera rays and random rays through a scene's bounds.

All functions return ``(origins, directions)`` as ``(N, 3)`` float32 numpy arrays and are deterministic in
their ``seed``; :func:`camera_rays` also returns the camera's ``t`` range on request.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .camera import generate_rays_kernel
from .errors import did_you_mean, flag
from .primitives import SHAPE_KINDS, shape_surface
from .ray_batch import host_array
from .render import check_asked_pixels, check_sides, resolve_view
from .scene import DistantLight, Scene
from .traced_in import check_traced_in

wp.set_module_options({"enable_backward": False})  # nothing differentiates these kernels: no adjoint code to compile


@wp.kernel
def shape_normals_kernel(
    kinds: wp.array[wp.int32],
    params: wp.array[wp.vec4],
    points: wp.array[wp.vec3],
    # outputs
    normals: wp.array[wp.vec3],
):
    """Unit normals, canonical space, of analytic shapes (``primitives.SHAPE_*``, their ``params``) at hit points
    given in their canonical space: the normals the renderer shades with (``primitives.shape_surface``)."""
    i = wp.tid()
    surface, normal = shape_surface(kinds[i], params[i], points[i])
    normals[i] = normal


def camera_rays(scene: Scene, camera=None, width: int | None = None, height: int | None = None, *,
                t_range: bool = False) -> tuple[np.ndarray, ...]:
    """One ray through the centre of each pixel of the image :func:`wrt.render` makes of ``scene`` with these
    arguments, row-major from the top-left, exactly as the renderer casts its AOV rays (through the pixel and lens
    centres; the colour samples of an image of several samples are spread over the pixel and the lens): the stage's
    render settings choose what is not given (camera, resolution, conform policy, data window: see
    :func:`wrt.render.resolve_view`), so there are fewer than ``width * height`` rays under a data window.

    The renderer keeps only hits inside the camera's clipping range and clipping planes. With ``t_range`` the
    ``(N,)`` float32 ``t_mins, t_maxs`` of that interval come after the rays, so that
    ``wrt.trace(scene, o, d, t_min=t_mins, t_max=t_maxs)`` finds the hits the render sees (``t_maxs <= t_mins``
    where a clipping plane cuts the whole ray); without it the rays alone, which hit what the camera clips."""
    t_range = flag(t_range, "camera_rays: t_range")  # "false" gave four arrays where two were unpacked
    check_sides(width, height)  # width=0 gave no rays, 1.5 failed in Python's words ('float' object is not iterable)
    asked = (width, height)
    cam, width, height = resolve_view(scene, camera, width, height)
    # As a render's: past 2^31 rays Warp's "Array shapes must not exceed ..." named nothing, and below it a
    # dataWindowNDC's overscan (or a huge size given) allocated rays without bound.
    check_asked_pixels(scene, width, height, 1, asked)
    n = width * height
    out = [wp.empty(n, dtype=wp.vec3, device="cpu") for _ in range(2)]
    out += [wp.empty(n, dtype=float, device="cpu") for _ in range(2)]
    wp.launch(generate_rays_kernel, n, inputs=[cam.to_struct(width, height), width, height, 0, 0], outputs=out,
              device="cpu")
    rays = tuple(a.numpy() for a in out)
    return rays if t_range else rays[:2]


def check_count(n, seed) -> tuple[int, int]:
    """``(n, seed)`` of a ray set as ints: ``n`` rays and the ``seed`` of its generator, each a non-negative
    integer. A float, a negative number or NaN failed in numpy's words, naming neither ('negative dimensions are
    not allowed', 'SeedSequence expects int')."""
    for name, value in (("n", n), ("seed", seed)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
    return int(n), int(seed)


def random_rays(scene: Scene, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` incoherent rays: half start outside the scene box and aim at random points inside it (most hit),
    half start at random points inside the box with uniformly random unit directions."""
    n, seed = check_count(n, seed)
    rng = np.random.default_rng(seed)
    lower, upper = (np.asarray(b, np.float64) for b in scene.bounds())
    extent = np.maximum(upper - lower, 1e-6 * max(float(np.abs(upper - lower).max()), 1e-30))
    n_aimed = n // 2
    origins_out = rng.uniform(lower - extent, upper + extent, (n_aimed, 3))
    targets = rng.uniform(lower, upper, (n_aimed, 3))
    origins_in = rng.uniform(lower, upper, (n - n_aimed, 3))
    directions_in = rng.normal(size=(n - n_aimed, 3))
    directions_in /= np.linalg.norm(directions_in, axis=1, keepdims=True)
    origins = np.concatenate([origins_out, origins_in]).astype(np.float32)
    directions = np.concatenate([targets - origins_out, directions_in]).astype(np.float32)
    return origins, directions


RAY_KINDS = ("primary", "shadow", "diffuse", "incoherent")  # ray sets of the benchmark grid
DEFAULT_SUN = np.array([0.35, 0.85, 0.4]) / np.linalg.norm([0.35, 0.85, 0.4])  # direction to the light, Y-up


def incoherent_rays(scene: Scene, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` rays from uniformly random points of the scene box in uniformly random unit directions. The box of a
    flat scene is thickened by a tenth of its size along its flat axes: inside the flat box every ray started on the
    surface, where hitting it at ``t = 0`` or missing it is rounding (``wp.Mesh`` and wrt differed on 12 % of them)."""
    n, seed = check_count(n, seed)
    rng = np.random.default_rng(seed)
    lower, upper = (np.asarray(b, np.float64) for b in scene.bounds())
    size = float((upper - lower).max())
    pad = np.where(upper - lower < 1e-3 * size, 0.1 * size, 0.0)
    lower, upper = lower - pad, upper + pad
    origins = rng.uniform(lower, upper, (n, 3))
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return origins.astype(np.float32), directions.astype(np.float32)


def _shape_normals(scene: Scene, points: np.ndarray, prims: np.ndarray, instances: np.ndarray) -> np.ndarray:
    """World-space normals (not unit) at world ``points`` ``(N, 3)`` float64 on analytic shapes: geometry ids
    ``prims`` (rows of ``Scene.geometry()`` past its triangles) in ``instances`` (-1: none). Each point goes into its
    shape's canonical space through the float64 inverse of its transform (the instance's times the shape's), and the
    canonical normal comes back through that inverse's transpose."""
    shapes = scene._geometry_shapes()
    which = prims - scene.num_geometry_triangles
    to_world = np.array([shapes[k].to_world for k in which], np.float64).reshape(-1, 4, 4)
    placed = instances >= 0
    to_world[placed] = scene.instances.to_world[instances[placed]] @ to_world[placed]
    to_local = np.linalg.inv(to_world[:, :3, :3])
    local = np.einsum("nij,nj->ni", to_local, points - to_world[:, :3, 3])
    kinds = np.array([SHAPE_KINDS[shapes[k].kind] for k in which], np.int32)
    params = np.array([shapes[k].params for k in which], np.float32).reshape(-1, 4)
    normals = wp.empty(len(which), dtype=wp.vec3, device="cpu")
    wp.launch(shape_normals_kernel, len(which), inputs=[kinds, params, local.astype(np.float32)],
              outputs=[normals], device="cpu")
    return np.einsum("nji,nj->ni", to_local, normals.numpy().astype(np.float64))


def _surface_points(scene: Scene, origins, directions, hits):
    """World-space hit points and unit geometric normals (facing the incoming ray) of the rays that hit: a
    triangle's face normal, an analytic shape's surface normal."""
    points, indices = scene.triangles()
    h = hits.prim >= 0
    position = origins[h].astype(np.float64) + hits.t[h, None].astype(np.float64) * directions[h]
    # Rows past the triangles are analytic shapes (Hits.prim): they have no corners to take a face normal from.
    triangle = hits.prim[h] < len(indices)
    normal = np.empty_like(position)
    p0, p1, p2 = (points[indices[hits.prim[h][triangle], k]].astype(np.float64) for k in range(3))
    normal[triangle] = np.cross(p1 - p0, p2 - p0)
    normal[~triangle] = _shape_normals(scene, position[~triangle], hits.local_prim[h][~triangle],
                                       hits.instance[h][~triangle])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.where(length > 0, normal / np.where(length > 0, length, 1.0), -directions[h])
    facing = np.einsum("ij,ij->i", normal, directions[h]) > 0
    normal[facing] *= -1
    # Offset along the normal so secondary rays leave the surface: relative to the hit's coordinates and to the
    # length of the ray that found it (the float32 t errs by its share of that), so that the scene in any unit gets
    # the same rays. An absolute 1e-4 (1 + |p|) lifted them a tenth of a millimetre-sized scene off its surface.
    reach = np.abs(position).max(axis=1) + hits.t[h].astype(np.float64) * np.linalg.norm(directions[h], axis=1)
    position += normal * (1e-4 * reach[:, None])
    return position, normal


def shadow_target(scene: Scene) -> tuple[np.ndarray, str]:
    """``(direction, name)`` of what shadow rays aim at: the unit float64 direction towards the first
    :class:`DistantLight` of ``scene.lights`` (the centre of its disc, whatever its angle or shadow flag) and its prim
    path (``DistantLight N`` for one without), else :data:`DEFAULT_SUN` turned to the scene's up axis and ``default
    sun``. Every other light (sphere, rect, disk, ... and later distant ones) is left out: shadow rays keep one
    direction and no end, the workload every bench result so far was measured on."""
    suns = [(k, light) for k, light in enumerate(scene.lights) if isinstance(light, DistantLight)]
    if suns:
        k, sun = suns[0]
        to_light = -np.asarray(sun.direction, np.float64)
        return to_light / np.linalg.norm(to_light), sun.path or f"DistantLight {k}"
    # Y-up to Z-up is the quarter turn about +X that takes +Y to +Z ((x, y, z) -> (x, -z, y)), the turn
    # frame_scene makes too; swapping y and z mirrored it to the side of the scene away from the camera.
    to_light = DEFAULT_SUN if scene.up_axis != "Z" else DEFAULT_SUN[[0, 2, 1]] * (1.0, -1.0, 1.0)
    return to_light / np.linalg.norm(to_light), "default sun"


def _traced_rays(origins, directions, hits) -> tuple[np.ndarray, np.ndarray]:
    """``origins`` and ``directions`` as the float64 ``(N, 3)`` rays ``hits`` (:class:`wrt.Hits` of N rays) came from,
    taken as :func:`wrt.trace` takes them (lists, ``wp.array``s; one ray for all of them). Lists failed in numpy's
    words ('only integer scalar arrays can be converted'), rays of another count as 'boolean index did not match',
    and ``hits.t`` given for the hits as "'numpy.ndarray' object has no attribute 'prim'"."""
    if not all(hasattr(hits, name) for name in ("t", "prim", "local_prim", "instance")):
        raise TypeError(f"secondary_rays: hits must be the Hits of wrt.trace(scene, origins, directions), got "
                        f"{type(hits).__name__}")
    n = len(hits.t)
    rays = []
    for name, values in (("origins", origins), ("directions", directions)):
        array = np.asarray(host_array(name, values))
        if array.dtype.kind not in "fiu":
            raise ValueError(f"secondary_rays: {name} must hold real numbers, got dtype {array.dtype}")
        array = array.astype(np.float64, copy=False)
        if array.shape in ((3,), (1, 3)):
            array = np.broadcast_to(array.reshape(1, 3), (n, 3))
        if array.shape != (n, 3):
            raise ValueError(f"secondary_rays: {name} must be the (N, 3) rays the hits came from, N = {n:,}; got "
                             f"shape {array.shape}")
        rays.append(array)
    return rays[0], rays[1]


def secondary_rays(scene: Scene, kind: str, origins, directions, hits, seed: int = 0):
    """Shadow rays (towards :func:`shadow_target`: the scene's first distant light, else :data:`DEFAULT_SUN` rotated
    to the up axis; other lights are not aimed at) or cosine-weighted diffuse bounce rays from the hits of a primary
    ray set."""
    if kind not in ("shadow", "diffuse"):
        raise ValueError(f"unknown secondary ray kind {kind!r}{did_you_mean(kind, ('shadow', 'diffuse'))}; valid: "
                         "shadow, diffuse")
    seed = check_count(0, seed)[1]
    origins, directions = _traced_rays(origins, directions, hits)
    # Their rows index scene.triangles(): another scene's, or this one's before an edit, started rays on other
    # triangles' planes without a word.
    check_traced_in(scene, hits, "secondary_rays")
    position, normal = _surface_points(scene, origins, directions, hits)
    if kind == "shadow":
        out = np.broadcast_to(shadow_target(scene)[0], position.shape)
    elif kind == "diffuse":
        rng = np.random.default_rng(seed)
        # Cosine-weighted: a uniform point on the unit sphere added to the normal (Malley-equivalent).
        sphere = rng.normal(size=position.shape)
        sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
        out = normal + sphere
        out /= np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-12)
    return position.astype(np.float32), np.ascontiguousarray(out, dtype=np.float32)


def _shot_size(scene: Scene, n: int) -> tuple[int, int]:
    """``(width, height)`` of an image of about ``n`` camera rays in the aspect of the stage's render settings (4:3
    without them), counting only the pixels of their data window (:meth:`RenderSettings.crop`)."""
    settings = scene.render_settings
    aspect, pixels = 4.0 / 3.0, float(n)
    if settings is not None:
        xmin, ymin, xmax, ymax = settings.data_window
        aspect = settings.resolution[0] / settings.resolution[1]
        pixels = n / ((xmax - xmin) * (ymax - ymin))
    width = max(int(round(np.sqrt(pixels * aspect))), 1)
    return width, max(int(pixels // width), 1)


def ray_set(scene: Scene, kind: str, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """About ``n`` rays of one benchmark kind (see :data:`RAY_KINDS`). Primary rays are :func:`camera_rays` of the
    stage's shot (its render settings' camera, aspect and data window) at about ``n`` pixels. Shadow and diffuse rays
    start at the hits of those primary rays, so there are as many of them as primary rays hit.
    ``n = 0`` gives no rays of any kind."""
    if kind not in RAY_KINDS:
        raise ValueError(f"unknown ray kind {kind!r}{did_you_mean(kind, RAY_KINDS)}; valid ray kinds: "
                         f"{', '.join(RAY_KINDS)}")
    n, seed = check_count(n, seed)  # n=-1 failed in math's words (a square root of a negative pixel count)
    if n == 0:  # the shot of about 0 pixels is still 1x1: n=0 gave one primary ray (and its secondary ray)
        return np.empty((0, 3), np.float32), np.empty((0, 3), np.float32)
    if kind == "incoherent":
        return incoherent_rays(scene, n, seed)
    width, height = _shot_size(scene, n)
    origins, directions = camera_rays(scene, width=width, height=height)
    if kind == "primary":
        return origins, directions
    from .trace import trace

    hits = trace(scene, origins, directions)
    return secondary_rays(scene, kind, origins, directions, hits, seed)
