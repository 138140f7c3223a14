"""Light values near float32's range: domes whose colour and texture multiply far from 1, light and camera exposures,
radiance near float32's largest. The oracle is the same scene with its values scaled by powers of two into range (the
image scaled back: exact in float32), or float64 numpy of the expected radiance."""

import numpy as np
import pytest
from shading_helpers import quad

import wrt

# A dome of two bright bands on black (texels of 10), as test_light_textures' furnace dome
FURNACE_DOME = np.zeros((4, 8, 3), np.float32)
FURNACE_DOME[0, ::2] = 10.0
FURNACE_DOME[2] = 10.0


def dome_lit_plane(dome, width=4, spp=16, integrator="path"):
    """``(H, W, 3)`` radiance of a grey plane facing +Y under ``dome`` (direct light), seen from above."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    img = wrt.render(wrt.Scene(meshes=[plane], lights=[dome]), camera=cam, width=width, height=width, spp=spp,
                     device="cpu", integrator=integrator, max_depth=1)
    return img.rgb


def test_a_dim_texture_under_a_bright_dome_colour_is_sampled_as_its_image():
    """A dome of colour 2^100 whose texels are 2^-100 of the furnace dome's is the same light: its image, drawn with
    the same seed, is the same. The sampling distribution's floor of 1e-8 outweighed texels of 1e-29, and the dome
    was sampled uniformly instead of by its image (1.391 against 1.419)."""
    reference = dome_lit_plane(wrt.DomeLight(color=np.ones(3, np.float32), texture=FURNACE_DOME))
    scaled = wrt.DomeLight(color=np.full(3, 2.0**100, np.float32), texture=FURNACE_DOME * np.float32(2.0**-100))
    np.testing.assert_allclose(dome_lit_plane(scaled), reference, rtol=1e-6)


def test_a_dome_near_float32s_largest_lights_a_plane_as_numpy_says():
    """A grey plane under a constant dome of 3e38 shows 0.5 * 3e38, which float32 holds: every path sample divides the
    dome's radiance by a cosine pdf (past 3.4e38) and the pixel sums samples, so all were dropped and the image was
    black. A camera exposure of 2^-100 scales it exactly; a batch of two cameras gives each the same."""
    radiance = 3e38
    dome = wrt.DomeLight(color=np.full(3, radiance, np.float32), path="/Dome")
    expected = 0.5 * np.float64(np.float32(radiance))  # albedo times the dome (float64)
    for integrator in ("path", "whitted"):
        np.testing.assert_allclose(dome_lit_plane(dome, spp=4, integrator=integrator), expected, rtol=1e-6)
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cams = [wrt.Camera.orthographic(eye=(x, 3, 0), target=(x, 0, 0), up=(0, 0, -1), height=0.5) for x in (0, 1)]
    cams[1].exposure_scale = 2.0**-100
    batch = wrt.render_batch(wrt.Scene(meshes=[plane], lights=[dome]), cams, 4, 4, spp=4, device="cpu",
                             integrator="path", max_depth=1)
    np.testing.assert_allclose(batch.rgb.numpy()[0], expected, rtol=1e-6)
    np.testing.assert_allclose(batch.rgb.numpy()[1], expected * 2.0**-100, rtol=1e-6)


def test_an_emissive_surface_near_float32s_largest_is_seen_as_it_glows():
    """A quad glowing 2e38 (which float32 holds) seen over 4 samples: their sum passed 3.4e38 and was dropped, and the
    pixel was black."""
    glow = wrt.Material(path="/Glow", emissive_color=np.full(3, 2e38, np.float32))
    mesh = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/quad", material=0)
    cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    img = wrt.render(wrt.Scene(meshes=[mesh], materials=[glow]), camera=cam, width=4, height=4, spp=4, device="cpu",
                     integrator="path", max_depth=1)
    np.testing.assert_allclose(img.rgb, np.float64(np.float32(2e38)), rtol=1e-6)


def test_pixels_past_float32_after_the_camera_exposure_are_its_largest_with_a_warning():
    """A dome of 1e38 over a grey plane, through a camera exposure of 2^10: the plane's 5e37 times 1024 is past
    float32's range. Its pixels are float32's largest, with a warning (inf reached the image, and its PNG's tone
    mapping); those of a dimmer camera (exposure 2^-10) are numpy's. So they are through an exposure of 1e30 of a dome
    of 1e10, whose batch mean the device takes."""
    dome = wrt.DomeLight(color=np.full(3, 1e38, np.float32), path="/Dome")
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cams = [wrt.Camera.orthographic(eye=(x, 3, 0), target=(x, 0, 0), up=(0, 0, -1), height=0.5) for x in (0, 1)]
    cams[0].exposure_scale, cams[1].exposure_scale = 2.0**10, 2.0**-10
    scene = wrt.Scene(meshes=[plane], lights=[dome])
    largest = np.finfo(np.float32).max
    with pytest.warns(UserWarning, match=r"16 pixel\(s\) of radiance times the camera's exposure past float32's range "
                                         r"were clamped to its largest"):
        img = wrt.render(scene, camera=cams[0], width=4, height=4, spp=2, device="cpu", integrator="path", max_depth=1)
    assert np.all(img.rgb == largest)
    with pytest.warns(UserWarning, match=r"16 pixel\(s\) of radiance .* were clamped"):
        batch = wrt.render_batch(scene, cams, 4, 4, spp=2, device="cpu", integrator="path", max_depth=1).rgb.numpy()
    assert np.all(batch[0] == largest)
    np.testing.assert_allclose(batch[1], 0.5 * np.float64(np.float32(1e38)) * 2.0**-10, rtol=1e-6)
    # A dome of 1e10, held unscaled, through an exposure of 1e30: the device's mean of the batch clamps
    cams[0].exposure_scale = 1e30
    scene.lights = [wrt.DomeLight(color=np.full(3, 1e10, np.float32), path="/Dome")]
    with pytest.warns(UserWarning, match=r"16 pixel\(s\) of radiance .* were clamped"):
        batch = wrt.render_batch(scene, cams, 4, 4, spp=2, device="cpu", integrator="path", max_depth=1).rgb.numpy()
    assert np.all(batch[0] == largest)
    np.testing.assert_allclose(batch[1], 0.5e10 * 2.0**-10, rtol=1e-6)


def emission_texture_image(texture: np.ndarray, factor: float, spp: int) -> np.ndarray:
    """The rgb a camera sees of a quad glowing with ``texture`` (RGBA) times ``factor`` (its emissiveColor)."""
    binding = wrt.TextureInput(image=0, scale=np.float32([factor, factor, factor, 1.0]))
    glow = wrt.Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": binding})
    mesh = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/quad", material=0)
    mesh.uvs = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], np.float32)
    cam = wrt.Camera.orthographic(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    return wrt.render(wrt.Scene(meshes=[mesh], materials=[glow], textures=[texture]), camera=cam, width=2, height=2,
                      spp=spp, device="cpu", integrator="path", max_depth=1).rgb


@pytest.mark.parametrize("texel, factor", [(1e6, 1.0), (3e38, 1.0), (1e-9, 1e9)])
def test_an_emission_texture_past_float16s_range_glows_as_its_texels_say(texel, factor):
    """An emissive quad of a texture of ``texel`` everywhere (times ``factor``, its UsdUVTexture scale), seen by the
    camera, shows ``texel * factor`` (float64): material texels are float16 on the device, and an HDR's sun of 1e6
    was clamped to 65504, one of 1e-9 read 0. Each image is now stored divided by a power of two (and the glow of
    3e38 over 4 samples held scaled: wrt.radiance_scale)."""
    texture = np.full((2, 2, 4), np.float32(texel), np.float32)
    expected = np.float64(np.float32(texel)) * np.float64(np.float32(factor))
    np.testing.assert_allclose(emission_texture_image(texture, factor, 4), expected, rtol=1e-3)  # float16: 11 bits


def test_a_camera_exposure_below_float32s_range_scales_the_image_in_float64():
    """A dome of 2^64 (held unscaled) through a camera exposure of 2^-150, which float32 cannot hold (it rounds to
    0): the plane's 2^63 times it is 2^-87, which float32 holds. The image was black."""
    dome = wrt.DomeLight(color=np.full(3, 2.0**64, np.float32), path="/Dome")
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    cam.exposure_scale = 2.0**-150
    img = wrt.render(wrt.Scene(meshes=[plane], lights=[dome]), camera=cam, width=2, height=2, spp=2, device="cpu",
                     integrator="path", max_depth=1)
    np.testing.assert_allclose(img.rgb, 2.0**-87, rtol=1e-6)


def lit_room(k: int, integrator: str) -> np.ndarray:
    """``(H, W, 3)`` float64 image of a white floor lit by every kind of emitter, each emitting ``2^k`` times its own
    radiance: a dome, a textured rect light (seen by the camera), a mesh light tinting its material's glow, one of
    ``noMaterialResponse`` and a plain emissive quad."""
    up = 2.0**k
    tinted = wrt.Material(path="/Tinted", diffuse_color=0.0, emissive_color=np.full(3, 0.8 * up, np.float32))
    glow = wrt.Material(path="/Glow", diffuse_color=0.0, emissive_color=np.float32([0.5, 0.4, 0.3]) * np.float32(up))
    white = wrt.Material(path="/White", diffuse_color=0.8)
    meshes = [quad((0, 0, 0), (8, 0, 0), (0, 8, 0), name="/floor", material=2, double_sided=False),
              quad((-1.5, 0, 1), (1, 0, 0), (0, -1, 0), name="/tinted", material=0, double_sided=False),
              quad((1.5, 0, 1), (1, 0, 0), (0, -1, 0), name="/plain", material=1, double_sided=False),
              quad((0, 1.5, 1), (1, 0, 0), (0, -1, 0), name="/response", double_sided=False)]
    panel = np.eye(4)
    panel[:3, 3] = (0, -1.5, 1.5)
    texture = np.linspace(0.25, 1.0, 2 * 4 * 3, dtype=np.float32).reshape(2, 4, 3)
    lights = [wrt.DomeLight(color=np.full(3, 0.3 * up, np.float32), path="/Dome"),
              wrt.RectLight(to_world=panel, width=1.0, height=0.5, color=np.full(3, 1.5 * up, np.float32),
                            texture=texture, path="/Panel"),
              wrt.MeshLight(path="/tinted", color=np.full(3, 1.2, np.float32), material_sync="materialGlowTintsLight"),
              wrt.MeshLight(path="/response", color=np.full(3, up, np.float32), material_sync="noMaterialResponse")]
    scene = wrt.Scene(meshes=meshes, materials=[tinted, glow, white], lights=lights)
    cam = wrt.Camera.look_at((0, -6, 5), (0, 0, 0.5), fov_y_deg=50)
    img = wrt.render(scene, camera=cam, width=12, height=8, spp=4, device="cpu", integrator=integrator, max_depth=2)
    return img.rgb.astype(np.float64)


@pytest.mark.parametrize("k", [126, -100])
@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_every_emitter_times_2_to_126_renders_the_image_times_2_to_126(integrator, k):
    """Rendering is linear in what lights and surfaces emit: every emitter of a scene times 2^126 (its brightest
    radiance 1.3e38, which float32 holds, as it holds the image) gives the image times 2^126, bit for bit in float32
    (a power of two). Its path samples and sums passed float32's range and were dropped. So does 2^-100, which is
    held scaled up."""
    reference = lit_room(0, integrator)
    assert reference.min() > 0.0
    np.testing.assert_array_equal(lit_room(k, integrator), reference * 2.0**k)


@pytest.mark.parametrize("texel, factor", [(1e-9, 1e9), (2.0**-30, 2.0**30)])
def test_a_dim_emission_texture_of_alpha_1_glows_as_its_texels_say(texel, factor):
    """An RGB file reads alpha 1 (wrt.textures.read_image): its dim colour of ``texel`` under a UsdUVTexture scale of
    ``factor`` glows ``texel * factor`` (float64), as the image of alpha ``texel`` does. The image's power of two was
    taken over its alpha too, which held it at 1, and the colour read 0 in float16."""
    texture = np.ones((2, 2, 4), np.float32)
    texture[..., :3] = np.float32(texel)
    np.testing.assert_allclose(emission_texture_image(texture, factor, 1),
                               np.float64(np.float32(texel)) * np.float64(np.float32(factor)), rtol=1e-3)


def test_a_batch_cameras_exposure_below_float32s_normal_range_scales_its_image_in_float64():
    """A batch of cameras through an exposure of 2^-150 and one of 3e-41, which float32 cannot hold (0, and a
    subnormal of a few bits), over a plane under a dome of 2^64 (held unscaled): their images are the plane's 2^63
    times them (float64), as a render of each camera alone gives. The batch's mean took the factors in float32:
    black, and 2% off."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cams = [wrt.Camera.orthographic(eye=(x, 3, 0), target=(x, 0, 0), up=(0, 0, -1), height=0.5) for x in (0, 1)]
    cams[0].exposure_scale, cams[1].exposure_scale = 2.0**-150, 3e-41
    dome = wrt.DomeLight(color=np.full(3, 2.0**64, np.float32), path="/Dome")
    batch = wrt.render_batch(wrt.Scene(meshes=[plane], lights=[dome]), cams, 2, 2, spp=2, device="cpu",
                             integrator="path", max_depth=1).rgb.numpy()
    np.testing.assert_allclose(batch[0], 2.0**-87, rtol=1e-6)
    np.testing.assert_allclose(batch[1], 2.0**63 * 3e-41, rtol=1e-6)


def test_a_normalized_sun_disc_too_small_for_its_radiance_lights_as_a_delta_light_of_its_illuminance():
    """A normalized distant light of 1e9 lux, 1e-13 degrees across: its disc's radiance (1e9 / 2.4e-30) passes
    float32's range, so it is the delta light of its illuminance, as a smaller disc is (SMALLEST_SUN_DISC), and lights
    a grey plane facing it 0.5 / pi * 1e9 (float64). The renderer raised a KeyError naming no light (the warning of
    textured lights past float32 looked the sun up among them), and without it drew an infinite radiance."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    sun = wrt.DistantLight(direction=np.float32([0, -1, 0]), color=np.full(3, 1e9, np.float32), angle=1e-13,
                           normalize=True, path="/Sun")
    assert not np.isfinite(sun.radiance).any()
    img = wrt.render(wrt.Scene(meshes=[plane], lights=[sun]), camera=cam, width=2, height=2, spp=2, device="cpu",
                     integrator="path", max_depth=1)
    np.testing.assert_allclose(img.rgb, 0.5 / np.pi * np.float64(np.float32(1e9)), rtol=1e-6)


@pytest.mark.parametrize("kind", ["rect", "disk"])
def test_a_normalized_area_light_too_small_for_its_radiance_is_named_in_a_warning(kind):
    """A normalized rect or disk light 1e-20 across built in Python: its radiance (colour / area, 1e40) passes
    float32's range. It is named in a warning and lights nothing, as load_usd skips such a light with one; the disk
    drew a black image without a word, the rect was said to pass float32 by its texture's texels (it has none)."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    down = np.eye(4)
    down[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]  # local -Z (the emitting side) along world -Y
    down[1, 3] = 1.0
    color = np.ones(3, np.float32)
    if kind == "rect":
        light = wrt.RectLight(to_world=down, width=1e-20, height=1e-20, color=color, normalize=True, path="/Tiny")
    else:
        light = wrt.DiskLight(to_world=down, radius=1e-20, color=color, normalize=True, path="/Tiny")
    assert not np.isfinite(light.radiance).any()
    dome = wrt.DomeLight(color=color, path="/Dome")
    with pytest.warns(UserWarning, match=r"/Tiny: normalized, too small for its radiance .* to fit in float32") as got:
        img = wrt.render(wrt.Scene(meshes=[plane], lights=[light, dome]), camera=cam, width=2, height=2, spp=2,
                         device="cpu", integrator="path", max_depth=1)
    assert [w.filename for w in got if "/Tiny" in str(w.message)] == [__file__]  # the caller's line, not wrt's
    # the grey plane under the dome alone: 0.5 (float64), as the scene without the light draws it
    reference = wrt.render(wrt.Scene(meshes=[plane], lights=[dome]), camera=cam, width=2, height=2, spp=2,
                           device="cpu", integrator="path", max_depth=1)
    np.testing.assert_allclose(img.rgb, 0.5, rtol=1e-6)
    np.testing.assert_array_equal(img.rgb, reference.rgb)


def test_a_normalized_mesh_light_too_small_for_its_radiance_is_named_in_a_warning():
    """A normalized mesh light on a quad 1e-20 across built in Python: its radiance (colour / area, 1e40) passes
    float32's range. It is named in a warning and lights nothing; its infinite power made the lights' selection
    probabilities NaN, and a grey plane under a dome of 1 came out 0.525 (numpy's overflow warning alone)."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    tiny = quad((0, 1, 0), (1e-20, 0, 0), (0, 0, 1e-20), name="/tiny")
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    lights = [wrt.DomeLight(color=np.ones(3, np.float32), path="/Dome"),
              wrt.MeshLight(path="/tiny", color=np.ones(3, np.float32), normalize=True,
                            material_sync="noMaterialResponse")]
    with pytest.warns(UserWarning, match=r"MeshLight /tiny: normalized, too small for its radiance") as got:
        img = wrt.render(wrt.Scene(meshes=[plane, tiny], lights=lights), camera=cam, width=2, height=2, spp=2,
                         device="cpu", integrator="path", max_depth=1)
    assert [w.filename for w in got if "/tiny" in str(w.message)] == [__file__]  # the caller's line, not wrt's
    np.testing.assert_allclose(img.rgb, 0.5, rtol=1e-6)  # the grey plane under the dome alone (float64)
