"""Camera and bounce rays pass through stacks of cut-out holes (``opacity < opacityThreshold``) without using up
bounces: a floor under a canopy of all-hole leaves is lit, and seen, exactly as without the leaves."""

import numpy as np
import pytest
import warp as wp
from shading_helpers import quad, top_down_camera
from test_cut_out_shadows import HOLE, render

import wrt
from wrt.shade import MAX_CULL_PASSES

RED = wrt.Material("/Looks/Red", diffuse_color=np.array([0.8, 0.2, 0.1], np.float32))  # the floor under the leaves
MIRROR = wrt.Material("/Looks/Mirror", metallic=1.0, roughness=0.0, diffuse_color=np.full(3, 0.9, np.float32))
LAMP = wrt.SphereLight(position=np.array([1.5, 0.0, 4.0]), radius=0.6, color=np.full(3, 4.0))
SKY = wrt.DomeLight(color=np.full(3, 0.25))
UNDER_THE_LEAVES = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=0.5)


# The leaves raise the scene's bounding sphere a little, and with it the dome's share of next-event light picks (its
# power is measured over that sphere): a few samples pick the other light, so lamp and dome together match to 1e-4.
SAME_LIGHT = 1e-3


def canopy(layers: int, floor_material: wrt.Material = RED, lights=(LAMP, SKY)) -> wrt.Scene:
    """The floor (material 0) under ``layers`` all-hole 20 x 20 quads (material 1) stacked 0.1 apart from z = 1 up:
    rays from the floor patch at the origin to the lamp at z = 4 and most of the sky cross every one of them."""
    floor = quad((0, 0, 0), (20, 0, 0), (0, 20, 0), name="/floor", material=0)
    leaves = [quad((0, 0, 1 + 0.1 * k), (20, 0, 0), (0, 20, 0), name=f"/leaf{k}", material=1) for k in range(layers)]
    return wrt.Scene(meshes=[floor, *leaves], lights=list(lights), materials=[floor_material, HOLE])


@pytest.mark.parametrize("max_depth", [1, 2])
def test_bounce_rays_through_a_canopy_of_holes_use_no_bounces(max_depth):
    """``path`` at ``max_depth`` 1 and 2 lights the floor under 12 hole layers as without them (passing holes draws
    no random numbers, so the seeded samples are the same). Each hole used up a bounce: a BSDF ray that met the first
    leaf at the last bounce died there, losing its MIS share of the lamp and the whole sky (half as bright)."""
    bare = render(canopy(0), "path", camera=UNDER_THE_LEAVES, max_depth=max_depth)
    assert bare.min() > 0.01
    covered = render(canopy(12), "path", camera=UNDER_THE_LEAVES, max_depth=max_depth)
    np.testing.assert_allclose(covered, bare, rtol=SAME_LIGHT)


def test_a_mirror_sees_the_sky_through_a_canopy_of_holes():
    """``whitted`` at ``max_depth = 1``: a mirror floor reflects the sky through 12 hole layers as it does without
    them; the hole step took a bounce, so the mirror ray died at the first leaf (black)."""
    bare = render(canopy(0, MIRROR, [SKY]), "whitted", camera=UNDER_THE_LEAVES, max_depth=1)
    assert bare.min() > 0.1
    covered = render(canopy(12, MIRROR, [SKY]), "whitted", camera=UNDER_THE_LEAVES, max_depth=1)
    np.testing.assert_allclose(covered, bare, rtol=1e-5)


def seen_through(scene: wrt.Scene) -> None:
    """Asserts the AOVs of ``scene`` seen from 5 above the floor are the red floor's, as if no leaf were there."""
    img = wrt.render(scene, camera=top_down_camera(height=0.5), width=8, height=8, device="cpu",
                     integrator="albedo")
    np.testing.assert_array_equal(img.aovs["prim"] // 2, 0)  # the floor's two triangles, no leaf
    np.testing.assert_allclose(img.aovs["albedo"], np.broadcast_to(RED.diffuse_color, (8, 8, 3)))
    np.testing.assert_allclose(img.aovs["depth"], 5.0, rtol=1e-6)
    np.testing.assert_allclose(img.aovs["normal"], np.broadcast_to([0, 0, 1], (8, 8, 3)), atol=1e-6)


def test_camera_rays_pass_twenty_hole_layers():
    """The AOVs of pixels behind 20 leaves of holes show the floor; camera rays gave up after 8 re-traces and the
    AOVs showed the ninth leaf (its grey default albedo, depth 2.9 instead of 5)."""
    seen_through(canopy(20))
    camera = top_down_camera(height=0.5)
    for integrator in ("path", "whitted"):
        bare = render(canopy(0), integrator, camera=camera, max_depth=2)
        np.testing.assert_allclose(render(canopy(20), integrator, camera=camera, max_depth=2), bare, rtol=SAME_LIGHT)


def test_camera_rays_pass_holes_up_to_the_documented_limit():
    """A camera ray passes ``MAX_CULL_PASSES`` holes; one still in a hole after them ends its path (black, as a
    shadow ray in a hole after its last pass is blocked)."""
    seen_through(canopy(MAX_CULL_PASSES, lights=[SKY]))
    for integrator in ("path", "whitted"):
        rgb = render(canopy(MAX_CULL_PASSES + 1, lights=[SKY]), integrator, camera=top_down_camera(height=0.5),
                     max_depth=2)
        np.testing.assert_array_equal(rgb, 0.0)


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_launch_frame_passes_hole_stacks_as_render_does(accel):
    """The frame a CUDA graph records (fixed pass counts, no host reads) of a floor seen through 20 hole layers and
    lit through them is the image ``render`` gives (sample 0 of the same seed), and its AOVs are the floor's; it
    culled camera rays twice only, so they stopped at the third leaf and the path ran out of bounces there (black)."""
    camera = top_down_camera(height=0.5)
    options = {"camera": camera, "width": 8, "height": 8, "device": "cpu", "accel": accel, "integrator": "path",
               "max_depth": 2}
    rendered = wrt.render(canopy(20), seed=5, **options)
    assert rendered.rgb.min() > 0.01
    renderer = wrt.Renderer(canopy(20), **options)
    renderer.launch_frame(seed=5)
    frame = renderer.frame_image()
    np.testing.assert_allclose(frame.rgb, rendered.rgb, rtol=1e-6)
    for name in ("prim", "albedo", "depth"):
        np.testing.assert_array_equal(frame.aovs[name], rendered.aovs[name])
    np.testing.assert_array_equal(frame.aovs["prim"] // 2, 0)


def test_a_recorded_frame_passes_hole_stacks():
    """The same frame recorded as a CUDA graph and replayed: camera and bounce rays pass the 20 layers."""
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    options = {"camera": top_down_camera(height=0.5), "width": 8, "height": 8, "device": "cuda:0",
               "integrator": "path", "max_depth": 2}
    rendered = wrt.render(canopy(20), seed=5, **options)
    renderer = wrt.Renderer(canopy(20), **options)
    renderer.launch_frame(seed=5)  # allocates the buffers before the capture
    with wp.ScopedCapture(device="cuda:0") as capture:
        renderer.launch_frame(seed=5)
    wp.capture_launch(capture.graph)
    frame = renderer.frame_image()
    np.testing.assert_allclose(frame.rgb, rendered.rgb, rtol=1e-6)
    np.testing.assert_array_equal(frame.aovs["prim"] // 2, 0)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_an_emissive_cut_out_emits_only_where_it_is_opaque(integrator):
    """A glowing quad above the floor lights it where its cut-out is opaque, and not at all where it is all hole:
    camera and bounce rays pass such a quad, so it shows no light, but next-event estimation sampled points in its
    holes and lit the floor with them (a mean of 0.50 whitted, 0.46 path, against 0)."""
    glow = {"emissive_color": np.full(3, 5.0, np.float32), "opacity_threshold": 0.5}
    lamp = quad((0, 0, 1), (1, 0, 0), (0, 1, 0), name="/lamp", material=1)
    for opacity, lit in ((1.0, True), (0.0, False)):
        scene = wrt.Scene(meshes=[quad((0, 0, 0), (20, 0, 0), (0, 20, 0), name="/floor", material=0), lamp],
                          materials=[RED, wrt.Material("/Looks/Glow", opacity=opacity, **glow)])
        rgb = render(scene, integrator, max_depth=2)
        assert (rgb.min() > 0.01) if lit else not rgb.any(), (opacity, rgb.mean())
