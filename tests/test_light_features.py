"""The shading kernels' variants per light features (wrt.light_features): which variant a scene's lights need, and
that a kept Renderer whose scene gains a kind of light launches a variant that draws it. (That the variants leave
out their features' code: ``test_inlined_copies.py``.)"""

import threading
import warnings

import numpy as np
import pytest
from test_glowing_spheres import PATCH, RES, closed_form, floor_mesh, materials, sphere_shape

import wrt
from wrt import light_sampling, light_table
from wrt.ies import IesProfile
from wrt.integrators import path, whitted
from wrt.light_features import ALL_FEATURES, NO_FEATURES, SHAPE_LIGHT_KINDS, LightFeatures
from wrt.light_shaping import Shaping
from wrt.light_table import build_lights
from wrt.lights import CylinderLight, DiskLight, DomeLight, MeshLight, RectLight, SphereLight
from wrt.materials import emission_estimates


def test_the_shape_light_kinds_are_the_device_codes():
    codes = (light_sampling.LIGHT_CYLINDER, light_sampling.LIGHT_ELLIPSOID, light_sampling.LIGHT_ELLIPTIC_TUBE,
             light_sampling.LIGHT_LINE)
    assert SHAPE_LIGHT_KINDS == tuple(int(c) for c in codes)


WHITE = np.ones(3, np.float32)
ABOVE = np.array([0.0, 0.0, 2.0])
UP = np.eye(4)  # (a rect light and a cylinder light at the origin: where they are does not matter here)
SPOT = SphereLight(ABOVE, 0.1, WHITE, path="/Spot", shaping=Shaping(cone_angle=30.0))


def features_of(lights=(), shapes=()) -> LightFeatures:
    """The features a Renderer picks for a floor lit by ``lights`` and glowing ``shapes`` (none: the default
    lights)."""
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=list(shapes), lights=list(lights), materials=materials())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.Renderer(scene, width=4, height=4, integrator="whitted")._light_features


@pytest.mark.parametrize("lights, shapes, expected", [
    ((), (), NO_FEATURES),  # the default lights
    ((RectLight(UP, 1.0, 1.0, WHITE, path="/Rect"),), (), NO_FEATURES),
    ((SphereLight(ABOVE, 0.1, WHITE, path="/Ball"),), (), NO_FEATURES),
    ((CylinderLight(UP, 1.0, 0.1, WHITE, path="/Tube"),), (), LightFeatures(shape_lights=True, shaping=False)),
    ((), (sphere_shape((0, 0, 1), 0.2),), LightFeatures(shape_lights=True, shaping=False)),
    ((SPOT,), (), LightFeatures(shape_lights=False, shaping=True)),
    ((SPOT,), (sphere_shape((0, 0, 1), 0.2),), ALL_FEATURES),
], ids=["default", "rect", "sphere", "cylinder", "glowing-sphere", "shaped", "both"])
def test_a_renderer_picks_the_features_its_lights_need(lights, shapes, expected):
    assert features_of(lights, shapes) == expected



def moved(x, y, z, linear=np.eye(3)):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, (x, y, z)
    return m


def lamp_shape(kind, centre):
    """A glowing (material 1) analytic shape of ``kind`` 0.2 across at ``centre``."""
    return wrt.Shape(f"/Glow_{kind}", kind, moved(*centre, np.diag([0.2, 0.2, 0.2])), material_id=1)


LAMP = wrt.Mesh("/Lamp", np.array([(0, 0, 1), (0.3, 0, 1), (0, 0.3, 1)], np.float32), np.array([[0, 2, 1]]),
                np.array([0]), material_ids=np.zeros(1, np.int32))  # white: it glows only as a MeshLight
PROFILE = IesProfile([0.0, 45.0, 90.0], [0.0], [[10.0, 6.0, 1.0]])
CONE = Shaping(cone_angle=30.0)
# Each kind of light (and of shaping) a scene can list, with the features its kind says it needs: cylinder, line,
# ellipsoid and elliptic tube lights and glowing shapes are drawn through the shapes' code, a cone, focus or IES
# profile that changes what a light emits is shaping (a rect light's 90-degree cone cuts nothing off: none).
EVERY_KIND = {
    "point": ([SphereLight(ABOVE, 0.1, WHITE, path="/P", treat_as_point=True)], [], NO_FEATURES),
    "sphere": ([SphereLight(ABOVE, 0.1, WHITE, path="/S")], [], NO_FEATURES),
    "ellipsoid": ([SphereLight(ABOVE, 0.1, WHITE, path="/E", frame=np.diag([1.0, 2.0, 0.5]))], [],
                  LightFeatures(shape_lights=True, shaping=False)),
    "rect": ([RectLight(moved(0, 0, 2), 1.0, 1.0, WHITE, path="/R")], [], NO_FEATURES),
    "disk": ([DiskLight(moved(0, 0, 2), 0.3, WHITE, path="/D")], [], NO_FEATURES),
    "cylinder": ([CylinderLight(moved(0, 0, 2), 1.0, 0.1, WHITE, path="/C")], [],
                 LightFeatures(shape_lights=True, shaping=False)),
    "elliptic-tube": ([CylinderLight(moved(0, 0, 2, np.diag([1.0, 2.0, 0.5])), 1.0, 0.1, WHITE, path="/T")], [],
                      LightFeatures(shape_lights=True, shaping=False)),
    "line": ([CylinderLight(moved(0, 0, 2), 1.0, 0.1, WHITE, path="/L", treat_as_line=True)], [],
             LightFeatures(shape_lights=True, shaping=False)),
    "distant": ([wrt.DistantLight(np.array([0.0, 0.0, -1.0]), WHITE, path="/Sun")], [], NO_FEATURES),
    "sun-disc": ([wrt.DistantLight(np.array([0.0, 0.0, -1.0]), WHITE, path="/Sun", angle=5.0)], [], NO_FEATURES),
    "dome": ([DomeLight(WHITE, path="/Dome")], [], NO_FEATURES),
    "mesh-light": ([MeshLight("/Lamp", WHITE)], [], NO_FEATURES),
    "glowing-sphere": ([], [lamp_shape("sphere", (0, 0, 1))], LightFeatures(shape_lights=True, shaping=False)),
    "glowing-cylinder": ([], [lamp_shape("cylinder", (0, 0, 1))], LightFeatures(shape_lights=True, shaping=False)),
    "glowing-box": ([], [lamp_shape("box", (0, 0, 1))], LightFeatures(shape_lights=True, shaping=False)),
    "cone": ([SPOT], [], LightFeatures(shape_lights=False, shaping=True)),
    "focus": ([DiskLight(moved(0, 0, 2), 0.3, WHITE, path="/D", shaping=Shaping(focus=3.0))], [],
              LightFeatures(shape_lights=False, shaping=True)),
    "ies": ([RectLight(moved(0, 0, 2), 1.0, 1.0, WHITE, path="/R", shaping=Shaping(ies=PROFILE))], [],
            LightFeatures(shape_lights=False, shaping=True)),
    "ies-point": ([SphereLight(ABOVE, 0.1, WHITE, path="/P", treat_as_point=True, shaping=Shaping(ies=PROFILE))], [],
                  LightFeatures(shape_lights=False, shaping=True)),
    "cone-cutting-nothing": ([RectLight(moved(0, 0, 2), 1.0, 1.0, WHITE, path="/R", shaping=Shaping())], [],
                             NO_FEATURES),
    "shaped-cylinder": ([CylinderLight(moved(0, 0, 2), 1.0, 0.1, WHITE, path="/C", shaping=CONE)], [], ALL_FEATURES),
    "shaped-line": ([CylinderLight(moved(0, 0, 2), 1.0, 0.1, WHITE, path="/L", treat_as_line=True, shaping=CONE)],
                    [], ALL_FEATURES),
    "sphere-after-glow": ([SphereLight(ABOVE, 0.1, WHITE, path="/S")], [lamp_shape("sphere", (0, 0, 1))],
                          LightFeatures(shape_lights=True, shaping=False)),
}


def read_back_features(lights) -> LightFeatures:
    """The features of the uploaded ``lights`` (``DeviceLights``) read back from the arrays the kernels read, as the
    Renderer took them before the upload's host rows gave them: the analytic lights' kinds and shaping rows, and
    whether glowing shape entries follow the triangles."""
    n = lights.num_analytic
    drawn_as_shapes = [int(light_sampling.LIGHT_CYLINDER), int(light_sampling.LIGHT_ELLIPSOID),
                       int(light_sampling.LIGHT_ELLIPTIC_TUBE), int(light_sampling.LIGHT_LINE)]
    shape_lights = lights.first_glowing_sphere < lights.count or np.isin(lights.kinds.numpy()[:n],
                                                                         drawn_as_shapes).any()
    return LightFeatures(shape_lights=bool(shape_lights), shaping=bool((lights.shaping.numpy()[:n, 3] != 0.0).any()))


@pytest.mark.parametrize("kind", sorted(EVERY_KIND))
def test_the_features_taken_from_the_host_rows_are_those_the_uploaded_lights_need(kind):
    """build_lights gives the features from the rows it uploads (no read back from the device): for every kind of
    light and shaping, the same as read back from the uploaded arrays, and as the scene's list of lights says."""
    lights, shapes, expected = EVERY_KIND[kind]
    scene = wrt.Scene(meshes=[floor_mesh(), LAMP], shapes=shapes, lights=lights, materials=materials())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = build_lights(list(lights), scene, emission_estimates(scene.materials, []), "cpu")
    assert table.features == read_back_features(table.device_lights) == expected


def test_the_features_of_every_kind_at_once_are_all_of_them():
    lights = [light for kind_lights, _, _ in EVERY_KIND.values() for light in kind_lights]
    shapes = [shape for _, kind_shapes, _ in EVERY_KIND.values() for shape in kind_shapes]
    scene = wrt.Scene(meshes=[floor_mesh(), LAMP], shapes=shapes, lights=lights, materials=materials())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = build_lights(lights, scene, emission_estimates(scene.materials, []), "cpu")
    assert table.features == read_back_features(table.device_lights) == ALL_FEATURES


@pytest.mark.parametrize("integrator", ["path", "whitted"])
@pytest.mark.parametrize("kind", sorted(EVERY_KIND))
def test_the_variant_of_a_scene_draws_what_the_kernels_of_every_feature_draw(kind, integrator, monkeypatch):
    """The kernels of the features a scene's lights need (a variant that leaves the other draws out) give the image
    of the kernels of every feature, forced through light_table.light_features (ALL_FEATURES serves any scene): the
    same draws of the same numbers, bit for bit, so no draw of the scene's lights was left out or changed."""
    lights, shapes, expected = EVERY_KIND[kind]
    cam = wrt.Camera.look_at(eye=(0, -4, 3), target=(0, 0, 0.7), up=(0, 0, 1), fov_y_deg=50)

    def draw():
        scene = wrt.Scene(meshes=[floor_mesh(), LAMP], shapes=shapes, lights=lights, materials=materials())
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            renderer = wrt.Renderer(scene, camera=cam, width=6, height=6, integrator=integrator)
            return renderer.render(spp=2, seed=11).rgb, renderer._light_features

    image, features = draw()
    monkeypatch.setattr(light_table, "light_features", lambda *_: ALL_FEATURES)
    every, forced = draw()
    assert (features, forced) == (expected, ALL_FEATURES)
    assert image.max() > 0.0
    np.testing.assert_array_equal(image, every)

def test_a_kept_renderer_draws_a_glowing_sphere_added_after_its_first_render():
    """The scene is first lit by the default lights (no feature), then a glowing sphere is added: whitted lights the
    floor by sampling it, which a variant without shape lights would not (the floor stayed black), so the floor
    matches the closed form of a uniform spherical emitter."""
    scene = wrt.Scene(meshes=[floor_mesh()], materials=materials())
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.05), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    renderer = wrt.Renderer(scene, camera=cam, width=RES, height=RES, integrator="whitted")
    renderer.render(spp=1, seed=3)
    centre, r = (0.2, -0.1, 1.0), 0.2
    scene.shapes.append(sphere_shape(centre, r))
    rendered = renderer.render(spp=256, seed=3).rgb.mean(axis=-1)
    expected = closed_form([(centre, r)])
    assert np.abs(rendered / expected - 1).max() < 0.06, rendered / expected


# An integrator's factories of variant kernels, whose caches a fresh process starts without.
FACTORIES = {
    "path": (path._made_path_kernels, path.shade_path_kernel_for, path.add_unoccluded_kernel_for),
    "whitted": (whitted._made_whitted_kernels, whitted.shade_whitted_kernel_for, whitted.whitted_lights_kernel_for,
                whitted.continue_whitted_kernel_for, whitted.add_unoccluded_lights_kernel_for),
}


@pytest.mark.parametrize("integrator", sorted(FACTORIES))
def test_threads_asking_for_a_new_variant_at_once_all_render_it(integrator):
    """Four threads render a scene whose variant no render has made yet (the factories' caches cleared, as in a
    fresh process), at once: each made the variant's kernels itself, and a kernel registered while another thread
    loaded the module missed its hash, so that Warp's launch raised AttributeError (tid_extent_limit_candidate) in
    4 trials of 5, and in every later render of that variant (path and whitted alike).
    Each thread's image is the one drawn alone."""
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere_shape((0, 0, 1), 0.2)], materials=materials())
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.05), target=(0, 0, 0), up=(0, 1, 0), height=PATCH)
    renderers = [wrt.Renderer(scene, camera=cam, width=RES, height=RES, integrator=integrator) for _ in range(4)]
    alone = renderers[0].render(spp=2, seed=3).rgb
    for _ in range(5):  # (a race: before the lock, 1 in 5 trials passed)
        for factory in FACTORIES[integrator]:
            factory.cache_clear()
        images, errors = [None] * len(renderers), []

        def draw(i):
            try:
                images[i] = renderers[i].render(spp=2, seed=3).rgb
            except Exception as e:  # (raised in the thread: kept for the assert)
                errors.append(repr(e))

        threads = [threading.Thread(target=draw, args=(i,)) for i in range(len(renderers))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert errors == []
        for image in images:
            np.testing.assert_array_equal(image, alone)


def test_cuda_compile_time_refuses_a_feature_name_it_does_not_know():
    """benchmarks/cuda_compile_time.py --features names variants by LightFeatures' fields: a misspelt one
    (``shape_light``) set no field and timed the variant without any feature, as if ``none`` had been asked for."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "cuda_compile_time", Path(__file__).resolve().parents[1] / "benchmarks" / "cuda_compile_time.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.parse_features("shape_lights+shaping") == ALL_FEATURES
    assert script.parse_features("shaping") == LightFeatures(shape_lights=False, shaping=True)
    with pytest.raises(ValueError, match="shape_light'.*shape_lights, shaping"):
        script.parse_features("shape_light")
