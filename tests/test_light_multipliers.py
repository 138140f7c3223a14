"""UsdLux ``inputs:diffuse`` and ``inputs:specular``: each light's multipliers on what surfaces reflect of it through
their diffuse and their specular lobes (light sampling, rays that scattered into the light, Whitted's dome term and
mirror rays); camera rays see lights unscaled. Expectations are closed forms of the lights' radiometry."""

import math

import numpy as np
import pytest
from pxr import UsdLux
from shading_helpers import quad, top_down_camera

import wrt
from wrt.lights import DomeLight, SphereLight
from wrt.materials import Material

ALBEDO = 0.5  # the default material's grey (Lambertian): radiance = ALBEDO * E / pi
INTEGRATORS = ["path", "whitted"]


def render(lights, integrator, materials=None, camera=None, spp=16, size=4):
    """Radiance ``(H, W, 3)`` of a large floor z = 0 (material 0 when ``materials`` is given, else the default
    grey) lit by ``lights``, seen from above (direct light only for ``path``)."""
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor", material=None if materials is None else 0)
    scene = wrt.Scene(meshes=[floor], lights=list(lights), materials=materials or [])
    depth = 1 if integrator == "path" else 2
    img = wrt.render(scene, camera=camera or top_down_camera(height=0.2), width=size, height=size, spp=spp,
                     device="cpu", integrator=integrator, max_depth=depth)
    return img.rgb


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_diffuse_multiplier_scales_light_on_a_lambertian_floor(integrator):
    """A delta sun of illuminance 2 at 60 degrees: the grey floor shows ``ALBEDO * diffuse * 2 cos(60) / pi``;
    ``specular`` changes nothing on a Lambertian surface. The multipliers were ignored (0.159 for every value)."""
    direction = np.array([math.sin(math.radians(60)), 0.0, -math.cos(math.radians(60))])
    for diffuse, specular in [(1.0, 0.0), (0.5, 1.0), (0.0, 1.0)]:
        sun = wrt.DistantLight(direction=direction, color=np.full(3, 2.0), diffuse=diffuse, specular=specular)
        expected = ALBEDO * diffuse * 2.0 * 0.5 / math.pi
        np.testing.assert_allclose(render([sun], integrator, spp=1), expected, rtol=1e-4, atol=1e-7)


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_zero_diffuse_lights_leave_a_lambertian_floor_black(integrator):
    """A sphere light (sampled, and hit by BSDF-sampled rays under MIS) and a white dome (the same, and Whitted's
    dome term) with ``diffuse = 0`` light the grey floor not at all, while the camera still sees the dome at its
    radiance; with ``diffuse = 1`` the dome alone gives ``ALBEDO``."""
    sphere = SphereLight(position=np.array([1.2, 0.0, 1.0]), radius=0.5, color=np.full(3, 5.0), diffuse=0.0)  # unseen
    dome = DomeLight(color=np.ones(3, np.float32), diffuse=0.0)
    np.testing.assert_array_equal(render([sphere, dome], integrator), 0.0)
    lit = DomeLight(color=np.ones(3, np.float32))
    assert render([lit], integrator, spp=64).mean() == pytest.approx(ALBEDO, rel=0.03)
    sky = wrt.Camera.orthographic(eye=(0, 0, 1), target=(0, 0, 2), up=(0, 1, 0), height=0.2)  # looking up
    np.testing.assert_allclose(render([sphere, dome], integrator, camera=sky, spp=1), 1.0)


MIRROR = Material(diffuse_color=np.ones(3, np.float32), metallic=1.0, roughness=0.0)  # a white mirror: F = 1
ROUGH_METAL = Material(diffuse_color=np.ones(3, np.float32), metallic=1.0, roughness=0.4)


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_zero_specular_light_is_not_seen_in_a_mirror(integrator):
    """A white mirror floor under a sphere light of radiance 3: the camera sees the light in the mirror at 3 (F = 1
    for a white metal), and not at all with ``specular = 0``; ``diffuse = 0`` changes nothing on a metal."""
    camera = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=0.2)  # under it

    def seen(diffuse, specular):
        light = SphereLight(position=np.array([0.0, 0.0, 2.0]), radius=0.5, color=np.full(3, 3.0), diffuse=diffuse,
                            specular=specular)
        return render([light], integrator, materials=[MIRROR], camera=camera, spp=1)

    np.testing.assert_allclose(seen(0.0, 1.0), 3.0, rtol=1e-5)
    np.testing.assert_array_equal(seen(1.0, 0.0), 0.0)


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_specular_multiplier_scales_a_rough_metal_highlight(integrator):
    """A rough white metal under a sun: ``specular = 0.5`` halves the highlight, 0 removes it; ``diffuse`` has no
    effect (a metal has no diffuse lobe)."""
    sun = dict(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 2.0))
    full = render([wrt.DistantLight(**sun)], integrator, materials=[ROUGH_METAL], spp=1)
    assert full.mean() > 0.1
    half = render([wrt.DistantLight(**sun, specular=0.5, diffuse=0.0)], integrator, materials=[ROUGH_METAL], spp=1)
    np.testing.assert_allclose(half, 0.5 * full, rtol=1e-5)
    off = render([wrt.DistantLight(**sun, specular=0.0)], integrator, materials=[ROUGH_METAL], spp=1)
    np.testing.assert_array_equal(off, 0.0)


def test_usd_multipliers_are_read_and_bad_ones_reported(tmp_path):
    """``inputs:diffuse`` and ``inputs:specular`` are read; a negative one is clamped to 0 and a NaN one skips its
    light, each with a warning naming the prim."""
    from pxr import Usd

    stage = Usd.Stage.CreateNew(str(tmp_path / "lights.usda"))
    UsdLux.SphereLight.Define(stage, "/Half").CreateDiffuseAttr(0.5)
    UsdLux.SphereLight.Define(stage, "/Shiny").CreateSpecularAttr(3.0)
    UsdLux.SphereLight.Define(stage, "/Negative").CreateSpecularAttr(-1.0)
    UsdLux.SphereLight.Define(stage, "/Broken").CreateDiffuseAttr(float("nan"))
    stage.Save()
    with pytest.warns(UserWarning) as caught:
        scene = wrt.load_usd(tmp_path / "lights.usda")
    found = {light.path: (light.diffuse, light.specular) for light in scene.lights}
    assert found == {"/Half": (0.5, 1.0), "/Shiny": (1.0, 3.0), "/Negative": (1.0, 0.0)}
    messages = [str(w.message) for w in caught]
    assert any("clamped to 0" in m and "/Negative" in m for m in messages), messages
    assert any("not a finite number" in m and "/Broken" in m for m in messages), messages
