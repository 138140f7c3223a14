"""Integrators: energy conservation (white furnace), the Cornell box against stored reference statistics, Whitted
mirrors and glass, ambient occlusion, quick looks, depth of field, determinism across launches and devices."""

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import warp as wp
from shading_helpers import quad, uv_sphere

import wrt
from wrt.bsdf import Surface, lobe_albedos, sample_bsdf
from wrt.lights import DomeLight, RectLight
from wrt.materials import Material
from wrt.microfacet_albedo import GgxAlbedo, ggx_albedo_tables
from wrt.sampling import luminance

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])
REFERENCE = Path(__file__).parent / "data" / "cornell_box_reference.json"


def furnace_scene():
    sphere = uv_sphere(radius=1.0, rings=24, segments=48)  # flat shaded: a convex polyhedron
    sphere.colors = np.ones((len(sphere.indices), 3, 3), np.float32)  # albedo 1 (default Lambertian material)
    return wrt.Scene(meshes=[sphere], lights=[DomeLight(color=np.ones(3, np.float32))])


def test_white_furnace_converges_to_one():
    scene = furnace_scene()
    cam = wrt.Camera.look_at(eye=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=35)
    img = wrt.render(scene, camera=cam, width=32, height=32, spp=16, device="cpu", integrator="path")
    hit = img.aovs["prim"] >= 0
    assert hit.mean() > 0.3
    assert abs(img.rgb[hit].mean() - 1.0) < 0.01  # every absorbed-free bounce returns all of the dome's light
    np.testing.assert_allclose(img.rgb[~hit], 1.0, rtol=1e-6)  # the dome itself


def furnace_means(material: Material, integrator="path", spp=16):
    """Mean RGB of the pixels of a sphere of ``material`` lit only by a white dome of radiance 1, seen by an
    orthographic camera: its pixels' viewing cosines ``mu`` are distributed as ``2 mu dmu``."""
    sphere = uv_sphere(radius=1.0, rings=48, segments=96, material=0, smooth=True)
    scene = wrt.Scene(meshes=[sphere], materials=[material], lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.orthographic(eye=(0, 0, 4), target=(0, 0, 0), height=2.2)
    img = wrt.render(scene, camera=cam, width=48, height=48, spp=spp, device="cpu", integrator=integrator)
    return img.rgb[img.aovs["prim"] >= 0].mean(axis=0)


@pytest.mark.parametrize("roughness", [0.2, 0.5, 0.8, 1.0])
def test_rough_white_metal_in_a_white_furnace_reflects_all_the_light(roughness):
    """A white metal (diffuseColor 1, metallic 1) under a white dome shows the dome (as Cycles' multiscatter GGX
    does): the single-scattering GGX lobe lost the light that bounces between microfacets, and the sphere read
    0.99, 0.89, 0.61 and 0.41 at roughness 0.2, 0.5, 0.8 and 1 (Whitted: 1)."""
    means = furnace_means(Material(diffuse_color=1.0, metallic=1.0, roughness=roughness))
    np.testing.assert_allclose(means, 1.0, atol=0.02)


def test_rough_coloured_metal_in_a_white_furnace_stays_below_its_smooth_value():
    """A gold-coloured metal (diffuseColor 1, 0.78, 0.34) at roughness 0.8: its white channel reflects all the light;
    the others reflect less than the smooth metal of that colour, gold at every angle (F0 = F90 = diffuseColor), as
    every extra bounce between microfacets keeps only part of the light, and darker channels lose more. Whitted,
    which lights a rough metal's lobe from the dome by its albedo, agrees with the path tracer. Single scattering
    only, the path tracer showed 0.61, 0.48, 0.22 and Whitted the smooth metal's 1, 0.79, 0.38."""
    gold = (1.0, 0.78, 0.34)
    rough = furnace_means(Material(diffuse_color=gold, metallic=1.0, roughness=0.8))
    smooth = furnace_means(Material(diffuse_color=gold, metallic=1.0, roughness=0.0), spp=4)
    # A metal's F90 is its diffuseColor (UsdPreviewSurface specification, Storm): Schlick's F is gold at every angle,
    # so a mirror in the furnace shows gold; the rim pixels also see the dome beside the sphere (about 1% of them).
    gold_f = np.asarray(gold)
    assert np.all(smooth >= gold_f - 1e-3) and np.all(smooth <= gold_f + 0.015 * (1.0 - gold_f)), smooth
    assert rough[0] == pytest.approx(1.0, abs=0.02)
    assert (rough[1:] < smooth[1:]).all()
    kept = rough / smooth
    assert kept[0] > kept[1] > kept[2] > 0.6, kept
    whitted = furnace_means(Material(diffuse_color=gold, metallic=1.0, roughness=0.8), integrator="whitted")
    np.testing.assert_allclose(whitted, rough, rtol=0.02)


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_a_coarse_smooth_shaded_mirror_sphere_in_a_white_furnace_shows_the_dome_everywhere(integrator):
    """A white mirror (metallic 1, roughness 0: F = 1) on a sphere of 8 x 16 facets with interpolated normals, under a
    white dome of radiance 1, shows 1 at every pixel. Near the silhouette the interpolated normal leans away from
    the viewer or sends the mirror ray into the surface (a normal map's was already turned back): those pixels were
    black, 174 of 2596 below 0.9 for the path tracer."""
    sphere = uv_sphere(radius=1.0, rings=8, segments=16, material=0, smooth=True)
    material = Material(diffuse_color=1.0, metallic=1.0, roughness=0.0)
    scene = wrt.Scene(meshes=[sphere], materials=[material], lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.orthographic(eye=(0, 0, 4), target=(0, 0, 0), height=2.2)
    img = wrt.render(scene, camera=cam, width=48, height=48, spp=2, device="cpu", integrator=integrator)
    hit = img.aovs["prim"] >= 0
    assert hit.mean() > 0.5
    np.testing.assert_allclose(img.rgb[hit], 1.0, atol=1e-4)


def cornell_wall_means(scene, img) -> dict:
    """Mean linear RGB of the back, left and right walls (pixels whose camera ray hits that mesh)."""
    offsets = np.cumsum([0] + [len(m.indices) for m in scene.meshes])
    out = {}
    for name in ("back_wall", "left_wall", "right_wall"):
        k = next(i for i, m in enumerate(scene.meshes) if m.path.endswith("/" + name))
        mask = (img.aovs["prim"] >= offsets[k]) & (img.aovs["prim"] < offsets[k + 1])
        out[name] = img.rgb[mask].mean(axis=0).tolist()
    return out


def test_cornell_box_matches_the_reference_render(assets):
    ref = json.loads(REFERENCE.read_text())
    scene = wrt.load_usd(assets("cornell_box"))
    settings = ref["settings"]
    img = wrt.render(
        scene,
        width=settings["width"],
        height=settings["height"],
        spp=64,
        seed=7,
        device="cpu",
        integrator="path",
        max_depth=settings["max_depth"],
    )
    means = cornell_wall_means(scene, img)
    for wall, expected in ref["wall_means"].items():
        np.testing.assert_allclose(means[wall], expected, rtol=0.05, err_msg=wall)


def mirror_scene():
    mirror = Material(diffuse_color=1.0, metallic=1.0, roughness=0.0)
    red = Material(diffuse_color=0.0, emissive_color=(1.0, 0.0, 0.0))
    green = Material(diffuse_color=0.0, emissive_color=(0.0, 1.0, 0.0))
    sphere = uv_sphere(radius=1.0, material=0, smooth=True)
    behind_camera = quad((0, 0, 8), (40, 0, 0), (0, -40, 0), name="/red", material=1)  # faces -Z
    floor = quad((0, -3, 0), (40, 0, 0), (0, 0, -40), name="/green", material=2)  # faces +Y
    return wrt.Scene(meshes=[sphere, behind_camera, floor], materials=[mirror, red, green])


def test_whitted_mirror_sphere_reflects_the_wall_behind_the_camera():
    scene = mirror_scene()
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)
    # 16 samples: the red wall is a glossy dielectric that reflects the green floor's light, 0.015 in green (path,
    # max_depth 2); at 1 sample its mean over the centre came out above 0.02 for a quarter of the seeds.
    img = wrt.render(scene, camera=cam, width=64, height=64, spp=16, device="cpu", integrator="whitted")
    sphere = img.aovs["prim"] < len(scene.meshes[0].indices)
    sphere &= img.aovs["prim"] >= 0
    rows, cols = np.nonzero(sphere)
    cy, cx = rows.mean(), cols.mean()
    radius = np.sqrt(sphere.sum() / np.pi)
    yy, xx = np.mgrid[:64, :64]
    centre = sphere & ((yy - cy) ** 2 + (xx - cx) ** 2 < (0.15 * radius) ** 2)  # reflects rays back past the camera
    bottom = sphere & (yy > cy + 0.75 * radius)
    assert centre.sum() >= 4 and bottom.sum() > 5
    np.testing.assert_allclose(img.rgb[centre].mean(axis=0), [1.0, 0.0, 0.0], atol=0.02)  # F = 1 for a white metal
    g = img.rgb[bottom].mean(axis=0)
    assert g[1] > 0.8 and g[0] < 0.2  # the floor below shows in the sphere's lower rim


def glass_scene(opacity=0.0):
    glass = Material(diffuse_color=1.0, opacity=opacity, ior=1.5, roughness=0.0)
    red = Material(diffuse_color=0.0, emissive_color=(1.0, 0.0, 0.0))
    blue = Material(diffuse_color=0.0, emissive_color=(0.0, 0.0, 1.0))
    sphere = uv_sphere(radius=1.0, material=0, smooth=True)
    top = quad((0, 10, -6), (40, 0, 0), (0, 20, 0), name="/top", material=1)  # faces +Z, towards the camera
    bottom = quad((0, -10, -6), (40, 0, 0), (0, 20, 0), name="/bottom", material=2)
    return wrt.Scene(meshes=[sphere, top, bottom], materials=[glass, red, blue])


def test_whitted_glass_sphere_inverts_the_image_behind_it():
    scene = glass_scene()
    cam = wrt.Camera.look_at(eye=(0, 0, 6), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=25)
    img = wrt.render(scene, camera=cam, width=64, height=64, spp=16, device="cpu", integrator="whitted")
    sphere = (img.aovs["prim"] >= 0) & (img.aovs["prim"] < len(scene.meshes[0].indices))
    rows, cols = np.nonzero(sphere)
    cy, cx, radius = rows.mean(), cols.mean(), np.sqrt(sphere.sum() / np.pi)
    yy, xx = np.mgrid[:64, :64]
    inner = sphere & ((yy - cy) ** 2 + (xx - cx) ** 2 < (0.6 * radius) ** 2)
    upper, lower = inner & (yy < cy - 0.15 * radius), inner & (yy > cy + 0.15 * radius)
    up, low = img.rgb[upper].mean(axis=0), img.rgb[lower].mean(axis=0)
    assert up[2] > 0.7 and up[0] < 0.1  # the upper half of the ball shows the blue lower backdrop
    assert low[0] > 0.7 and low[2] < 0.1  # and the lower half the red upper one
    outside_top = ~sphere & (yy < cy - 1.2 * radius)
    outside_bottom = ~sphere & (yy > cy + 1.2 * radius)
    assert img.rgb[outside_top][:, 0].min() > 0.99 and img.rgb[outside_bottom][:, 2].min() > 0.99


def test_path_tracer_agrees_with_whitted_on_direct_light():
    """Two integrators, one answer: a diffuse plane under a delta distant light (no indirect light possible)."""
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (4, 0, 0), (0, 4, 0))])
    scene.lights.append(wrt.DistantLight(direction=np.array([0.3, 0.0, -1.0]) / np.hypot(0.3, 1.0),
                                         color=np.full(3, 2.0)))
    cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), height=1.0)
    a = wrt.render(scene, camera=cam, width=8, height=8, spp=4, device="cpu", integrator="path")
    b = wrt.render(scene, camera=cam, width=8, height=8, device="cpu", integrator="whitted")
    np.testing.assert_allclose(a.rgb, b.rgb, rtol=1e-5)
    np.testing.assert_allclose(b.rgb, 0.5 * 2.0 / np.hypot(0.3, 1.0) / np.pi, rtol=1e-5)


def test_ambient_occlusion():
    floor = quad((0, 0, 0), (20, 0, 0), (0, 20, 0), name="/floor")
    wall = quad((0, 0.05, 1), (20, 0, 0), (0, 0, 2), name="/wall")  # a wall standing on the floor along y = 0.05
    scene = wrt.Scene(meshes=[floor, wall])
    cam = wrt.Camera.orthographic(eye=(0, -1, 5), target=(0, -1, 0), up=(0, 1, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=16, height=16, spp=64, device="cpu", integrator="ao", ao_radius=0.5)
    v = img.rgb[..., 0]
    np.testing.assert_allclose(img.rgb[..., 1], v)
    assert v[:, :].min() >= 0.0 and v.max() <= 1.0
    near_wall, far = v[0].mean(), v[-1].mean()  # image top is +y: next to the wall
    assert far > 0.97 and near_wall < 0.8


@pytest.mark.parametrize("integrator", ["normals", "depth", "albedo"])
def test_quick_looks(integrator):
    from wrt.cli import default_scene_path

    scene = wrt.load_usd(default_scene_path())
    img = wrt.render(scene, width=32, height=24, device="cpu", integrator=integrator)
    hit = img.aovs["prim"] >= 0
    assert img.rgb.shape == (24, 32, 3) and np.isfinite(img.rgb).all()
    if integrator == "normals":
        np.testing.assert_allclose(img.rgb[hit], 0.5 * (img.aovs["normal"][hit] + 1), rtol=1e-6)
    elif integrator == "albedo":
        np.testing.assert_allclose(img.rgb, img.aovs["albedo"])
    else:
        assert img.rgb.max() == pytest.approx(1.0) and (img.rgb[~hit] == 0).all()


def test_splitting_samples_across_launches_gives_the_same_image():
    scene = glass_scene(opacity=0.5)
    scene.lights.append(DomeLight(color=np.full(3, 0.5, np.float32)))
    cam = wrt.Camera.look_at(eye=(0, 0, 6), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=25)
    renderer = wrt.Renderer(scene, camera=cam, width=16, height=16, device="cpu", integrator="path")
    a = renderer.render(spp=6, seed=3, batch=6)
    b = renderer.render(spp=6, seed=3, batch=4)
    c = renderer.render(spp=6, seed=3, batch=1)
    np.testing.assert_array_equal(a.rgb, b.rgb)
    np.testing.assert_array_equal(a.rgb, c.rgb)
    assert not np.array_equal(a.rgb, renderer.render(spp=6, seed=4).rgb)
    # Progressive: 2 + 4 samples in two calls are the 6-sample image.
    renderer.render(spp=2, seed=3)
    d = renderer.render(spp=4, seed=3, resume=True)
    np.testing.assert_array_equal(a.rgb, d.rgb)
    np.testing.assert_array_equal(a.aovs["prim"], d.aovs["prim"])


def test_depth_of_field_blurs_only_out_of_focus_objects():
    # Two bright bars: one in the focus plane, one far behind it.
    white = Material(diffuse_color=0.0, emissive_color=1.0)
    near = quad((0, 0, 0), (0.2, 0, 0), (0, 2, 0), name="/near", material=0)
    far = quad((5.0, 0, -8), (1.0, 0, 0), (0, 6, 0), name="/far", material=0)
    scene = wrt.Scene(meshes=[near, far], materials=[white], meters_per_unit=0.01)  # 50 mm = 5 units
    sharp = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), fov_y_deg=30)
    lens = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), fov_y_deg=30, f_stop=2.0, focus_distance=5.0)
    a = wrt.render(scene, camera=sharp, width=64, height=16, spp=64, device="cpu", integrator="path")
    b = wrt.render(scene, camera=lens, width=64, height=16, spp=64, device="cpu", integrator="path")
    row_a, row_b = a.rgb[8, :, 0], b.rgb[8, :, 0]
    near_cols = slice(29, 35)
    np.testing.assert_allclose(row_b[near_cols].sum(), row_a[near_cols].sum(), rtol=0.1)  # in focus: unchanged
    far_a, far_b = row_a[35:], row_b[35:]
    assert far_b.sum() == pytest.approx(far_a.sum(), rel=0.15)  # the far bar's light is spread, not lost
    assert (far_b > 0.05).sum() > 2 * (far_a > 0.05).sum()  # over more columns
    assert far_b.max() < 0.6 * far_a.max()


def test_a_thin_lens_blurs_a_point_into_the_circle_of_confusion_in_tenths_of_a_scene_unit():
    """USD gives ``focalLength`` in tenths of a scene unit whatever ``metersPerUnit`` is: a 50 film-unit lens at
    f/4 has an aperture 1.25 units wide. A glowing square at depth 10, focused at 5, spreads on the focus plane into
    its own footprint (half its width there) blurred by a uniform disk of radius ``(A / 2) (10 - 5) / 10``: x
    variances ``w^2 / 12`` and ``R^2 / 4`` add. wrt read the focal length as millimetres through ``metersPerUnit``,
    so on a metre stage the lens was 100 times too narrow."""
    glow = Material(diffuse_color=0.0, emissive_color=1.0)
    dot = quad((-0.2, -0.2, -5.0), (0.4, 0, 0), (0, 0.4, 0), name="/dot", material=0)
    size = 64
    lens = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), fov_y_deg=30, f_stop=4.0, focus_distance=5.0)
    images = [wrt.render(wrt.Scene(meshes=[dot], materials=[glow], meters_per_unit=meters), camera=lens, width=size,
                         height=size, spp=256, device="cpu", integrator="path", max_depth=1).rgb[..., 0]
              for meters in (1.0, 0.01)]
    np.testing.assert_array_equal(images[0], images[1])
    weight = images[0] / images[0].sum()
    columns = np.arange(size) + 0.5
    x_mean = (weight.sum(axis=0) * columns).sum()
    pixel = 2.0 * 5.0 * math.tan(math.radians(15.0)) / size  # on the focus plane
    footprint = 0.4 * 5.0 / 10.0 / pixel
    x_var = (weight.sum(axis=0) * (columns - x_mean) ** 2).sum() - (footprint**2 + 1.0) / 12.0  # less the pixel
    aperture = 50.0 * 0.1 / 4.0
    radius = aperture / 2.0 * (10.0 - 5.0) / 10.0 / pixel
    assert 2.0 * math.sqrt(x_var) == pytest.approx(radius, rel=0.05)


def _disk_share_beyond(a: np.ndarray, radius: float) -> np.ndarray:
    """The share of a uniform disk of ``radius`` about 0 where ``x > a`` (float64)."""
    a = np.clip(a / radius, -1.0, 1.0)
    return (np.arccos(a) - a * np.sqrt(1.0 - a * a)) / np.pi


def test_every_colour_sample_of_a_thin_lens_samples_the_lens():
    """Sample 0 went through the lens centre (as the AOVs' ray does): every render blended a sharp pinhole image
    into the blur at weight 1 / spp, so renders of 2 samples averaged over seeds showed an edge half sharp. A glowing
    half-plane x < 0 at distance 10, focused at 5: the ray from lens point (l_x, l_y) through the focus-plane point
    p hits the half-plane at x = 2 p - l_x, so a pixel's expected radiance is the share of the lens disk where
    l_x > 2 p, averaged over the pixel (float64). The AOVs still come from the ray through both centres: sharp."""
    glow = Material(diffuse_color=0.0, emissive_color=1.0)
    plane = quad((-10.0, 0.0, -5.0), (20.0, 0, 0), (0, 40.0, 0), name="/plane", material=0)
    scene = wrt.Scene(meshes=[plane], materials=[glow], meters_per_unit=0.01)
    lens = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), fov_y_deg=30, f_stop=2.0, focus_distance=5.0)
    width, height, seeds = 64, 32, 16
    renderer = wrt.Renderer(scene, camera=lens, width=width, height=height, device="cpu", integrator="path",
                            max_depth=1)
    images = [renderer.render(spp=2, seed=seed) for seed in range(seeds)]
    mean = np.mean([image.rgb[..., 0] for image in images], axis=(0, 1))  # rows alike: the edge is vertical

    half_width = 5.0 * math.tan(math.radians(15.0)) * width / height  # of the view, on the focus plane
    radius = 50.0 * 0.1 / 2.0 / 2.0  # focal length 50 tenths of a unit at f/2
    steps = (np.arange(200) + 0.5) / 200  # across each pixel
    p = (-1.0 + 2.0 * (np.arange(width)[:, None] + steps[None, :]) / width) * half_width
    expected = _disk_share_beyond(2.0 * p, radius).mean(axis=1)
    assert expected.min() < 0.01 and expected.max() > 0.99 and ((expected > 0.1) & (expected < 0.9)).sum() > 8
    np.testing.assert_allclose(mean, expected, atol=0.06)  # 1024 samples a column: sigma <= 0.016
    centres = (-1.0 + 2.0 * (np.arange(width) + 0.5) / width) * half_width
    assert (images[0].aovs["prim"][0] >= 0).tolist() == (centres < 0).tolist()  # the AOVs' ray: no blur


def test_thin_lens_rays_of_a_sheared_offset_camera_meet_in_focus_within_their_pixel():
    """The colour rays behind a thin lens (f/2.8, focused at depth 4) of a camera under a sheared, unevenly scaled and
    mirrored transform, with film offsets and pixels 1.7 times as wide as tall, taken to camera space by the inverse of
    the camera's transform (float64): each starts on the lens disk in the film plane, of radius ``focalLength / fStop
    / 2`` in tenths of a unit, spread uniformly over it (mean 0, variance ``R^2 / 4`` per axis), and crosses depth 4
    inside its own pixel's footprint there, the film worked out by hand for ``expandAperture`` (36 x 24 grown to the
    image's aspect 1.7 * 5 / 3 at its height)."""
    from wrt.shade import FIRST_SPREAD, start_paths_kernel

    m = np.eye(4)
    m[:3, :3] = [[1.5, 0.3, 0.1], [0.2, -0.8, -0.4], [0.0, 0.5, 2.0]]
    m[:3, 3] = [3.0, -2.0, 7.0]
    focal, f_stop, focus, offsets = 35.0, 2.8, 4.0, (5.0, -3.0)
    cam = wrt.Camera(to_world=m, focal_length=focal, horizontal_aperture=36.0, vertical_aperture=24.0,
                     horizontal_aperture_offset=offsets[0], vertical_aperture_offset=offsets[1], f_stop=f_stop,
                     focus_distance=focus, fit="expandAperture", pixel_aspect_ratio=1.7, clipping_range=(0.5, 100.0))
    width, height, samples = 5, 3, 2000
    renderer = wrt.Renderer(wrt.Scene.from_triangles([[0, 0, -50], [1, 0, -50], [0, 1, -50]], [[0, 1, 2]]),
                            camera=cam, width=width, height=height, device="cpu", integrator="path")
    n = width * height * samples
    kinds = (wp.vec3, wp.vec3, float, float, wp.uint32, wp.vec3, wp.vec3, wp.int32, float, wp.vec3, wp.int32)
    device = renderer.device  # the renderer's own: a CUDA host's test plugin moves it (benchmarks/render_on_cuda.py)
    outputs = [wp.empty(n, dtype=kind, device=device) for kind in kinds]  # start_paths_kernel's outputs, in order
    wp.launch(start_paths_kernel, n, inputs=[renderer._cams, renderer._lenses, width, height, 0, 7, FIRST_SPREAD],
              outputs=outputs, device=device)
    o, d, t_min = (a.numpy().astype(np.float64) for a in outputs[:3])
    to_camera = np.linalg.inv(m)
    o = (o - m[:3, 3]) @ to_camera[:3, :3].T
    d = d @ to_camera[:3, :3].T

    radius = focal * 0.1 / f_stop / 2.0
    np.testing.assert_allclose(o[:, 2], 0.0, atol=1e-5)
    assert np.hypot(o[:, 0], o[:, 1]).max() <= radius * (1 + 1e-5)
    np.testing.assert_allclose(o[:, :2].mean(axis=0), 0.0, atol=0.02)  # sigma of a mean: 0.003
    np.testing.assert_allclose(o[:, :2].var(axis=0), radius**2 / 4, rtol=0.05)
    np.testing.assert_allclose((o + t_min[:, None] * d)[:, 2], -0.5, rtol=1e-5)  # starts at the near plane

    film_h = 24.0
    film_w = film_h * 1.7 * width / height  # wider than 36: the width grows
    at_focus = o + (-focus - o[:, 2:]) / d[:, 2:] * d  # where each ray crosses depth 4, as film units below
    x, y = (at_focus[:, k] / focus * focal - offsets[k] for k in (0, 1))
    pixel = np.arange(n) % (width * height)
    i, j = pixel // width, pixel % width
    slack = 1e-4 * film_w
    assert np.all((x >= (j / width - 0.5) * film_w - slack) & (x <= ((j + 1) / width - 0.5) * film_w + slack))
    assert np.all((y <= (0.5 - i / height) * film_h + slack) & (y >= (0.5 - (i + 1) / height) * film_h - slack))


@pytest.mark.parametrize("device", DEVICES)
def test_path_tracer_is_deterministic_and_device_independent(device):
    scene = mirror_scene()
    scene.lights.append(DomeLight(color=np.full(3, 0.3, np.float32)))
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)
    kwargs = {"camera": cam, "width": 24, "height": 24, "spp": 4, "seed": 11, "integrator": "path"}
    a = wrt.render(scene, device=device, **kwargs)
    b = wrt.render(scene, device=device, **kwargs)
    np.testing.assert_array_equal(a.rgb, b.rgb)
    if device != "cpu":
        # Bit for bit: trace and shading modules compile without FMA contraction, and sin/cos use + - * only, so
        # every operation rounds the same on both devices (measured on an H200: 0 pixels differ, max |diff| 0).
        ref = wrt.render(scene, device="cpu", **kwargs)
        np.testing.assert_array_equal(a.rgb, ref.rgb)


def poison(arrays) -> None:
    """Fills device buffers with what reused GPU memory may hold: NaN floats and nonsense integers."""
    for a in arrays:
        a.fill_(0xDEADBEEF if a.dtype == wp.uint32 else -123456 if a.dtype in (wp.int32, wp.vec2i) else float("nan"))


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("integrator", ["path", "whitted", "ao"])
def test_path_buffers_are_written_before_they_are_read(integrator, device):
    """Wavefront buffers are ``wp.empty``: garbage left in them from earlier launches must change nothing, and no
    ray handed to the accelerator (finished paths included) may be left unwritten."""
    scene = mirror_scene()  # single-sided sphere: back-face culling runs too
    sun = wrt.DistantLight(direction=np.array([0.3, -1.0, -0.5]) / np.sqrt(1.34), color=np.ones(3), angle=5.0)
    scene.lights += [DomeLight(color=np.full(3, 0.3, np.float32)), sun]
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)
    kwargs = {"camera": cam, "width": 16, "height": 16, "device": device, "integrator": integrator}
    clean = wrt.Renderer(scene, **kwargs).render(spp=2, seed=5)
    renderer = wrt.Renderer(scene, **kwargs)
    renderer.render(spp=2, seed=5)  # allocates the buffers
    w = renderer._wavefront
    h, s = w.hits, w.scratch
    # shadow_t_mins and hits.instance are never written: they are initialised at allocation (0 and -1).
    poison([getattr(w, name) for name in w.FIELDS] + [h.t, h.u, h.v, h.prim, h.cost])
    poison([s.t_mins, s.t_maxs, s.hits.t, s.hits.u, s.hits.v, s.hits.prim, s.hits.cost])
    b = w.batch  # whitted's shadow rays of several lights per path (the sun and the glowing triangles here)
    batched = [] if b is None else [b.origins, b.dirs, b.t_maxs, b.lights, b.blocked, b.contribution]
    if b is not None:
        poison(batched + [b.scratch.t_mins, b.scratch.t_maxs, b.scratch.hits.t, b.scratch.hits.prim])
    img = renderer.render(spp=2, seed=5)
    np.testing.assert_array_equal(img.rgb, clean.rgb)
    for name in ("prim", "normal", "depth"):
        np.testing.assert_array_equal(img.aovs[name], clean.aovs[name])
    shadows = ["shadow_origins", "shadow_dirs", "shadow_t_maxs"] if b is None else []
    for name in ["origins", "directions", "t_mins", "t_maxs"] + shadows:
        assert not np.isnan(getattr(w, name).numpy()).any(), name
    for array in batched[:3]:
        assert not np.isnan(array.numpy()).any()


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_both_accelerators_serve_the_path_tracer(accel):
    scene = furnace_scene()
    cam = wrt.Camera.look_at(eye=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=35)
    img = wrt.render(scene, camera=cam, width=16, height=16, spp=4, device="cpu", integrator="path", accel=accel)
    hit = img.aovs["prim"] >= 0
    assert abs(img.rgb[hit].mean() - 1.0) < 0.02


def test_bad_integrator_options():
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="valid integrators"):
        wrt.render(scene, width=4, height=4, device="cpu", integrator="radiosity")
    # 2^32 + 2 wrapped onto 2 in the kernels' 32-bit argument, 2^31 onto a negative depth (a black image); True
    # meant 1.
    for depth in (-1, 1025, 2**32 + 2, 2**31, True):
        with pytest.raises(ValueError, match="max_depth must be an integer from 0 to 1024"):
            wrt.render(scene, width=4, height=4, device="cpu", integrator="path", max_depth=depth)
    for radius in (0.0, True):
        with pytest.raises(ValueError, match="ao_radius"):
            wrt.render(scene, width=4, height=4, device="cpu", integrator="ao", ao_radius=radius)
    for batch in (0, True):
        with pytest.raises(ValueError, match="batch"):
            wrt.render(scene, width=4, height=4, device="cpu", batch=batch)


def specular_albedo(f0, roughness, n=400, f90=1.0):
    """Directional albedo at normal view of a single-scattering GGX lobe of Schlick reflectance ``f0`` (grazing
    reflectance ``f90``: 1 as UsdPreviewSurface has for a dielectric and the specular workflow), by midpoint
    quadrature over the hemisphere."""
    theta = (np.arange(n) + 0.5) / n * (np.pi / 2)
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * (2 * np.pi)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    wi = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    wo = np.array([0.0, 0.0, 1.0])
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    cos_i, cos_h, cos_vh = wi[..., 2], h[..., 2], h @ wo
    fresnel = f0 + (f90 - f0) * (1 - cos_vh) ** 5
    a = max(roughness**2, 4e-4)
    d = a * a / (np.pi * (cos_h**2 * (a * a - 1) + 1) ** 2)

    def lam(c):
        return 0.5 * (np.sqrt(1 + a * a * (1 - c * c) / (c * c)) - 1)

    g = 1 / (1 + lam(1.0) + lam(cos_i))
    weights = np.sin(t) * (np.pi / 2 / n) * (2 * np.pi / (2 * n))
    return float((fresnel * d * g / 4 * weights).sum())


@pytest.mark.parametrize("base, metallic, roughness", [(1.0, 1.0, 0.5), (1.0, 1.0, 0.2), (0.6, 0.0, 0.3)])
def test_rough_surfaces_under_a_constant_dome_match_their_albedo(base, metallic, roughness):
    """Light sampling, GGX sampling and their MIS weights must add up to the BSDF's albedo (an unbiasedness check).
    A white metal reflects all the light (its GGX lobe plus the multiple-scattering lobe that returns what the GGX
    lobe loses); a dielectric of diffuse albedo ``rho`` reflects its specular lobe's albedo ``S`` and ``rho (1 - S)``
    below it (its multiple scattering, at F0 = 0.04, adds less than 1e-4)."""
    material = Material(diffuse_color=base, metallic=metallic, roughness=roughness)
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), material=0)
    scene = wrt.Scene(meshes=[plane], materials=[material], lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=16, height=16, spp=32, device="cpu", integrator="path", max_depth=1)
    if metallic == 1.0:
        expected = base
    else:
        spec = specular_albedo(((1 - 1.5) / (1 + 1.5)) ** 2, roughness)
        expected = spec + (1 - spec) * base
    assert img.rgb.mean() == pytest.approx(expected, rel=0.015)


@wp.kernel
def bsdf_albedo_kernel(
    roughness: float,
    tables: GgxAlbedo,
    cos_o: wp.array[float],
    u: wp.array2d[float],
    # outputs
    albedo: wp.array[float],
):
    """Monte Carlo directional albedo of a white dielectric (ior 1.5) for a viewer at ``cos_o[i]``: the mean of
    ``sample_bsdf``'s weights (f cos / pdf) over the rows of ``u``."""
    i = wp.tid()
    s = Surface()
    s.base_color = wp.vec3(1.0)
    s.roughness = roughness
    s.opacity = 1.0
    s.ior = 1.5
    s.clearcoat_roughness = 0.01
    s.clearcoat_ior = 1.5
    s.specular_edge = 1.0  # UsdPreviewSurface's white F90
    n = wp.vec3(0.0, 0.0, 1.0)
    wo = wp.vec3(wp.sqrt(1.0 - cos_o[i] * cos_o[i]), 0.0, cos_o[i])
    lobes = lobe_albedos(s, tables, cos_o[i])
    total = float(0.0)
    for k in range(u.shape[0]):
        b = sample_bsdf(s, tables, lobes, n, n, wo, 1, u[k, 0], u[k, 1], u[k, 2], u[k, 3])
        total += luminance(b.weight)
    albedo[i] = total / float(u.shape[0])


@pytest.mark.parametrize("roughness", [0.05, 0.2, 0.5])
def test_a_white_surface_never_reflects_more_than_it_receives(roughness, np_rng):
    """White diffuse under the default specular lobe (ior 1.5) reflects at most all the light, at every viewing
    angle. With the diffuse share taken at the half vector, roughness 0.2 reflected 1.44x at cos 0.1."""
    cos_o = np.array([1.0, 0.5, 0.2, 0.1, 0.05], np.float32)
    albedo = wp.empty(len(cos_o), dtype=float, device="cpu")
    u = wp.array(np_rng.random((200_000, 4)).astype(np.float32), dtype=float, device="cpu")
    cos_array = wp.array(cos_o, dtype=float, device="cpu")  # not the default device: a GPU's, where there is one
    wp.launch(bsdf_albedo_kernel, len(cos_o), inputs=[roughness, ggx_albedo_tables("cpu"), cos_array, u],
              outputs=[albedo], device="cpu")
    got = albedo.numpy()
    assert (got <= 1.01).all(), dict(zip(cos_o.tolist(), got.tolist()))
    assert got[0] > 0.97  # at normal incidence nearly nothing is lost


def rect_lit_floor(material: Material):
    """A 100 x 100 floor of ``material`` at z = 0 under a 6 x 6 RectLight of radiance 1 at z = 2 facing down."""
    floor = quad((0, 0, 0), (100, 0, 0), (0, 100, 0), material=0)  # faces +Z
    to_world = np.eye(4)
    to_world[2, 3] = 2.0  # local -Z (the emitting side) looks down at the floor
    light = RectLight(to_world=to_world, width=6.0, height=6.0, color=np.ones(3, np.float32))
    return wrt.Scene(meshes=[floor], materials=[material], lights=[light])


@pytest.mark.parametrize("roughness", [0.3, 0.6])
def test_whitted_lights_a_rough_metal_once(roughness):
    """A white rough metal under a large area light: Whitted agrees with the path tracer and stays below the
    light's radiance. It added a mirror reflection of the light to the GGX highlight it had already sampled:
    2.02 against the path tracer's 0.98 at roughness 0.3."""
    scene = rect_lit_floor(Material(diffuse_color=1.0, metallic=1.0, roughness=roughness))
    cam = wrt.Camera.look_at(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=10)
    # Whitted samples the light by area only, which is noisy for a glossy lobe: 2048 samples keep it within 5%.
    whitted = wrt.render(scene, camera=cam, width=4, height=4, spp=2048, integrator="whitted").rgb.mean()
    path = wrt.render(scene, camera=cam, width=4, height=4, spp=2048, integrator="path").rgb.mean()
    assert whitted < 1.1
    assert abs(whitted - path) < 0.1 * path


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("ior", [1.5, 0.5])
def test_a_clear_pane_shows_the_sky_behind_it_unchanged(integrator, ior):
    """An open surface of opacity 0 (a window without thickness) under a dome of radiance 1 shows 1: the 1 / eta^2
    of entering the glass was applied at its one crossing and never undone (0.47 at ior 1.5, 3.67 at 0.5)."""
    pane = quad((0, 0, 0), (100, 0, 0), (0, 100, 0), material=0)
    scene = wrt.Scene(meshes=[pane], materials=[Material(opacity=0.0, ior=ior)],
                      lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30)
    img = wrt.render(scene, camera=cam, width=8, height=8, spp=16, integrator=integrator)
    assert (img.aovs["prim"] >= 0).all()
    np.testing.assert_allclose(img.rgb, 1.0, atol=0.02)


def pane_view(integrator, pane_material):
    """Red linear channel ``(32, 32)`` of a red emitter (a 1.2 x 1.2 square of radiance 1 at z = -3, facing +Z) seen
    by an orthographic camera looking down -Z through a pane at z = 0 tilted 45 degrees about the y axis (none
    where ``pane_material`` is None), with nothing else in the scene."""
    emitter = quad((0, 0, -3), (1.2, 0, 0), (0, 1.2, 0), name="/emitter", material=0)
    red = Material(diffuse_color=0.0, emissive_color=(1.0, 0.0, 0.0))
    meshes, materials = [emitter], [red]
    if pane_material is not None:
        c = np.cos(np.radians(45.0))
        meshes.append(quad((0, 0, 0), (20 * c, 0, -20 * c), (0, 20, 0), name="/pane", material=1))
        materials.append(pane_material)
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=3.0)
    img = wrt.render(wrt.Scene(meshes=meshes, materials=materials), camera=cam, width=32, height=32, spp=16,
                     device="cpu", integrator=integrator)
    return img.rgb[..., 0]


def red_centroid(red):
    """``(row, column)`` of the centre of the pixels brighter than 0.3."""
    rows, cols = np.nonzero(red > 0.3)
    return np.array([rows.mean(), cols.mean()])


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_thin_walled_pane_leaves_what_is_behind_it_in_place(integrator):
    """A clear thin-walled pane (opacity 0, ior 1.5, ``thin_walled``) tilted 45 degrees in front of an emitter: the
    emitter keeps its place in the image (the two faces of a sheet bend a ray back: it leaves undeflected) and shows
    ``1 - R'`` of its radiance, ``R' = 2R / (1 + R)`` with ``R`` the float64 Fresnel reflectance at 45 degrees. The
    same pane as a solid's boundary refracts every ray by 17 degrees into the glass, which it never leaves: the
    emitter moves by about 0.9 units (10 pixels)."""
    bare = pane_view(integrator, None)
    thin = pane_view(integrator, Material(opacity=0.0, ior=1.5, roughness=0.0, thin_walled=True))
    solid = pane_view(integrator, Material(opacity=0.0, ior=1.5, roughness=0.0))
    assert np.abs(red_centroid(thin) - red_centroid(bare)).max() < 0.25
    assert np.abs(red_centroid(solid) - red_centroid(bare)).max() > 5.0
    cos_i, eta = np.cos(np.radians(45.0)), 1.5
    cos_t = np.sqrt(1.0 - (1.0 - cos_i**2) / eta**2)
    r_s, r_p = (cos_i - eta * cos_t) / (cos_i + eta * cos_t), (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r = 0.5 * (r_s**2 + r_p**2)
    inside = bare > 0.999  # pixels wholly on the emitter
    assert inside.sum() > 64
    assert thin[inside].mean() == pytest.approx(1.0 - 2.0 * r / (1.0 + r), abs=0.04)


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("ior", [1.5, 2.4])
def test_a_thin_walled_glass_sphere_in_a_white_furnace_shows_the_dome(integrator, ior):
    """A clear thin-walled sphere under a white dome of radiance 1 shows 1: the sheet reflects ``R'`` and passes
    ``1 - R'``, absorbing nothing, however often the light bounces inside the ball."""
    means = furnace_means(Material(opacity=0.0, ior=ior, roughness=0.0, thin_walled=True), integrator=integrator)
    np.testing.assert_allclose(means, 1.0, atol=0.02)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_pane_whose_bent_normal_turns_the_refraction_back_reflects_all_the_light(integrator):
    """A clear pane (opacity 0, ior 1.5) at z = 0 whose authored normal leans 46 degrees from its face, seen from
    below at 83 degrees from the face normal: leaving the glass about that normal, Snell's law gives a direction below
    the pane again, which cannot cross it, so all the light is reflected: the pane shows the red emitter below it
    (radiance 1, as large as the view needs) and nothing of the green one above. The refracted ray started above the
    pane and re-crossed it there: a third of the light came through the pane from the green emitter."""
    tilt, view = np.radians(46.0), np.radians(83.0)
    pane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), material=0)  # faces +Z
    pane.normals = np.tile(np.array([np.sin(tilt), 0.0, np.cos(tilt)], np.float32), (2, 3, 1))
    below = quad((0, 0, -3), (2e4, 0, 0), (0, 2e4, 0), name="/below", material=1)
    above = quad((0, 0, 3), (2e4, 0, 0), (0, -2e4, 0), name="/above", material=2)
    glass = Material(opacity=0.0, ior=1.5, roughness=0.0)
    black = {"diffuse_color": 0.0, "use_specular_workflow": True, "specular_color": 0.0, "specular_edge": 0.0}
    red, green = (Material(emissive_color=c, **black) for c in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)))
    scene = wrt.Scene(meshes=[pane, below, above], materials=[glass, red, green])
    d = np.array([np.sin(view), 0.0, np.cos(view)])  # the view direction, up through the pane
    cam = wrt.Camera.orthographic(eye=-2.0 * d, target=(0, 0, 0), up=(0, 0, 1), height=0.2)
    img = wrt.render(scene, camera=cam, width=4, height=4, spp=8, device="cpu", integrator=integrator)
    assert (img.aovs["prim"] == 0).any() and (img.aovs["prim"] <= 1).all()  # the pane, seen from below
    np.testing.assert_allclose(img.rgb.reshape(-1, 3), [[1.0, 0.0, 0.0]] * 16, atol=1e-5)


@pytest.mark.parametrize("roughness", [0.0, 0.4])
def test_whitted_reflects_the_dome_in_a_specular_workflow_mirror(roughness):
    """useSpecularWorkflow = 1 with specularColor 1 (a mirror, as Maya and usdzconvert write metals) under a dome of
    radiance 1: Whitted agrees with the path tracer. It weighted the mirror ray and the dome's specular term by
    ``metallic``, which the specular workflow does not use: the mirror was black (0.0 against the path tracer's 1.0)."""
    material = Material(diffuse_color=0.0, use_specular_workflow=True, specular_color=1.0, roughness=roughness)
    plane = quad((0, 0, 0), (100, 0, 0), (0, 100, 0), material=0)
    scene = wrt.Scene(meshes=[plane], materials=[material], lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=20)
    whitted = wrt.render(scene, camera=cam, width=4, height=4, spp=4, device="cpu", integrator="whitted").rgb
    path = wrt.render(scene, camera=cam, width=4, height=4, spp=64, device="cpu", integrator="path").rgb
    assert whitted.max() <= 1.0 + 1e-6
    assert whitted.mean() == pytest.approx(path.mean(), rel=0.05)


def whitted_dome_expectations():
    """``(inputs, expected)``: UsdPreviewSurface inputs (metallic workflow, ior 1.5: a dielectric's F0 0.04 and F90
    1) and what they reflect at normal view of a uniform white dome, from float64 quadrature of the GGX lobes
    (:func:`specular_albedo`) or Schlick's F at normal incidence, F0, for a mirror. A metal's multiple scattering adds
    below 0.002 at roughness 0.3 (1 - E = 0.009)."""
    plastic = specular_albedo(0.04, 0.3)
    f0 = 0.5 * 0.04 + 0.5 * 0.6  # half metal: mix(0.04, diffuseColor, metallic); F90 mix(1, diffuseColor, metallic)
    half_metal = specular_albedo(f0, 0.3, f90=0.5 + 0.5 * 0.6)
    coat, below = specular_albedo(0.04, 0.1), specular_albedo(0.04, 0.4)
    colour = np.array([0.9, 0.5, 0.2])
    f0_colour = 0.5 * 0.04 + 0.5 * colour
    return [
        ({"diffuse_color": 0.0, "roughness": 0.3}, plastic),
        ({"diffuse_color": 0.6, "roughness": 0.0}, 0.04 + 0.96 * 0.6),
        ({"diffuse_color": 0.6, "metallic": 0.5, "roughness": 0.3}, half_metal + (1 - half_metal) * 0.5 * 0.6),
        ({"diffuse_color": 0.5, "roughness": 0.4, "clearcoat": 1.0, "clearcoat_roughness": 0.1},
         coat + (1 - coat) * (below + (1 - below) * 0.5)),
        ({"diffuse_color": 0.5, "roughness": 0.4, "clearcoat": 1.0, "clearcoat_roughness": 0.0},
         0.04 + 0.96 * (below + (1 - below) * 0.5)),
        ({"diffuse_color": tuple(colour), "metallic": 0.5, "roughness": 0.0},
         f0_colour + (1 - f0_colour) * 0.5 * colour),
    ]


@pytest.mark.parametrize("inputs, expected", whitted_dome_expectations(),
                         ids=["plastic", "smooth_plastic", "half_metal", "coat", "smooth_coat", "smooth_half_metal"])
def test_whitted_reflects_a_white_dome_by_the_whole_bsdf_albedo(inputs, expected):
    """A plane of UsdPreviewSurface under a uniform white dome, seen straight down: Whitted shows the BSDF's
    directional albedo, as the path tracer converges to (a dielectric's specular lobe, a half metal, a clearcoat, a
    smooth one's mirror ray). Its dome term took the diffuse albedo whole and the rough lobe times ``metallic``, and a
    smooth lobe's mirror ray was weighted by ``metallic`` too: a black plastic showed 0 (0.040), the half metal
    0.459 (0.522), a clearcoat none of its reflection, a smooth white-ish plastic 0.6 (0.616)."""
    plane = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), material=0)
    scene = wrt.Scene(meshes=[plane], materials=[Material(**inputs)],
                      lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), height=1.0)
    img = wrt.render(scene, camera=cam, width=4, height=4, spp=2, device="cpu", integrator="whitted")
    np.testing.assert_allclose(img.rgb.reshape(-1, 3).mean(axis=0), np.broadcast_to(expected, 3), rtol=0.01)


@pytest.mark.parametrize("integrator, spp", [("whitted", 4), ("path", 128)])
def test_a_specular_colour_above_one_leaves_the_diffuse_lobe_black_not_negative(integrator, spp):
    """useSpecularWorkflow with specularColor 1.5 over diffuseColor 0.8 (roughness 0.5) under a dome of radiance 1,
    seen from above: the specular lobe reflects more than all the light, so nothing is left to the diffuse lobe, and
    the surface shows the lobe's single-scattering albedo (float64 quadrature, F0 1.5) plus the multiple-scattering
    lobe's ``1 - E`` (its Fresnel colour is 1 once F0 reaches 1). The diffuse lobe got ``1 - albedo`` < 0 of the
    light, which subtracted: Whitted showed 1.09 and the path tracer 1.01 against 1.46."""
    material = Material(diffuse_color=0.8, use_specular_workflow=True, specular_color=1.5, roughness=0.5)
    plane = quad((0, 0, 0), (100, 0, 0), (0, 100, 0), material=0)
    scene = wrt.Scene(meshes=[plane], materials=[material], lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=20)
    img = wrt.render(scene, camera=cam, width=4, height=4, spp=spp, device="cpu", integrator=integrator, max_depth=1)
    expected = specular_albedo(1.5, 0.5) + 1.0 - specular_albedo(1.0, 0.5)
    assert img.rgb.mean() == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("integrator, spp", [("whitted", 4), ("path", 16)])
def test_a_negative_specular_colour_reflects_as_zero_not_negative_light(integrator, spp):
    """useSpecularWorkflow with specularColor (-0.5, 0.3, 0.3) under a dome of radiance 1: a reflectance below 0 has
    no meaning, and the diffuse colour's negative values are already read as 0; the specular one was used as it was,
    a negative F0, and the path tracer made pixels of -0.3 red. Oracle: no pixel is negative, and the image is that
    of specularColor (0, 0.3, 0.3), the same samples."""
    def image(specular):
        material = Material(diffuse_color=0.5, use_specular_workflow=True, specular_color=specular, roughness=0.3)
        plane = quad((0, 0, 0), (100, 0, 0), (0, 100, 0), material=0)
        scene = wrt.Scene(meshes=[plane], materials=[material], lights=[DomeLight(color=np.ones(3, np.float32))])
        cam = wrt.Camera.look_at(eye=(0, 1, 3), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=20)
        return wrt.render(scene, camera=cam, width=4, height=4, spp=spp, device="cpu", integrator=integrator).rgb

    negative = image((-0.5, 0.3, 0.3))
    assert negative.min() >= 0.0
    np.testing.assert_array_equal(negative, image((0.0, 0.3, 0.3)))


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_a_coarse_mirror_sphere_whose_normal_map_has_no_frame_shows_the_dome_everywhere(integrator):
    """The sphere above with a normal map but no texture coordinates (no ``st`` area: the map gives no tilt, the
    interpolated normal is kept) is the plain mirror sphere: 1 at every pixel under the white dome. The map's
    fallbacks returned the interpolated normal as it was, leaning away near the silhouette: 66 of 1460 pixels were
    below 0.9."""
    sphere = uv_sphere(radius=1.0, rings=8, segments=16, material=0, smooth=True)
    up = np.ones((2, 2, 4), np.float32)  # the tangent-space normal (0, 0, 1) stored as (n + 1) / 2
    up[..., :2] = 0.5
    normal_map = wrt.TextureInput(image=0, scale=np.array([2, 2, 2, 1], np.float32),
                                  bias=np.array([-1, -1, -1, 0], np.float32))
    material = Material(diffuse_color=1.0, metallic=1.0, roughness=0.0, textures={"normal": normal_map})
    scene = wrt.Scene(meshes=[sphere], materials=[material], textures=[up],
                      lights=[DomeLight(color=np.ones(3, np.float32))])
    cam = wrt.Camera.orthographic(eye=(0, 0, 4), target=(0, 0, 0), height=2.2)
    img = wrt.render(scene, camera=cam, width=48, height=48, spp=2, device="cpu", integrator=integrator)
    hit = img.aovs["prim"] >= 0
    assert hit.mean() > 0.5
    np.testing.assert_allclose(img.rgb[hit], 1.0, atol=1e-4)


@pytest.mark.parametrize("lens", [
    dict(f_stop=1e-40, focus_distance=5.0),  # USD's float fStop of 1e-40: a lens 2.5e40 units wide
    dict(f_stop=2.0, focus_distance=1e-40),  # a lens 1.25 wide focused 1e-40 ahead: rays 1e40 steep
])
def test_a_thin_lens_past_float32s_range_is_refused_naming_the_camera_and_fields(lens):
    """The thin lens's radius ``focalLength / fStop / 2`` (tenths of a unit) and the slope its rays take to the focus
    plane, ``radius / focusDistance``, went past float32's range: the lens samples' rays were NaN, and the image was
    background with numpy's 'overflow encountered in cast', which named no camera. It is refused, naming the camera
    and its fStop and focusDistance."""
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (4, 0, 0), (0, 4, 0))])
    cam = wrt.Camera.look_at((0, 0, 5), (0, 0, 0), path="/Lens", **lens)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # numpy's overflow is no answer
        with pytest.raises(ValueError, match=r"camera /Lens: its thin lens .* past float32's range .*f_stop="
                                             r".*focus_distance="):
            wrt.render(scene, camera=cam, width=4, height=3, spp=2, device="cpu")
