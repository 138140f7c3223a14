"""Warnings that wrt gives inside a render point at the caller's line (their stacklevel), whichever way the render
is called: a fixed stacklevel pointed into wrt's own files (render.py, light_table.py) for the calls one frame deeper
or shallower, so ``-W error::UserWarning:mymodule`` filters and the shown line missed the user's code."""

import warnings

import numpy as np
import pytest
from shading_helpers import quad

import wrt


def _blinding_scene() -> tuple:
    """A dome of 1e38 over a texture of 1e38 (their product past float32: named when the lights are built) over a
    quad: path samples past float32's range are dropped (warned at each render or frame)."""
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (2, 0, 0), (0, 2, 0), name="/quad")])
    scene.lights = [wrt.DomeLight(color=np.full(3, 1e38, np.float32), texture=np.full((2, 4, 3), 1e38, np.float32))]
    return scene, wrt.Camera.look_at((0, 0, 4), (0, 0, 0), fov_y_deg=60)


def _overexposed_scene() -> tuple:
    """A dome of 1e38 over a grey plane through a camera exposure of 2^10: its pixels are clamped (warned)."""
    plane = quad((0, 0, 0), (100, 0, 0), (0, 0, -100), name="/plane", double_sided=False)
    cam = wrt.Camera.orthographic(eye=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), height=0.5)
    cam.exposure_scale = 2.0**10
    return wrt.Scene(meshes=[plane], lights=[wrt.DomeLight(color=np.full(3, 1e38, np.float32))]), cam


def _renderer_render(scene, cam, **options):
    return wrt.Renderer(scene, camera=cam, **options).render(spp=2)


def _frame(scene, cam, **options):
    renderer = wrt.Renderer(scene, camera=cam, **options)
    renderer.launch_frame(seed=1)
    return renderer.frame_image()


CALLS = {
    "wrt.render": lambda scene, cam, **options: wrt.render(scene, camera=cam, spp=2, **options),
    "Renderer.render": _renderer_render,
    "frame_image": _frame,
    "render_batch": lambda scene, cam, **options: wrt.render_batch(scene, [cam, cam], spp=2, **options),
}
EXPECTED = {
    "blinding": ("its radiance", "sample(s) were not finite"),
    "overexposed": ("pixel(s) of radiance times the camera's exposure",),
}


@pytest.mark.parametrize("call", CALLS)
@pytest.mark.parametrize("scene_kind", EXPECTED)
def test_render_warnings_point_at_the_callers_line(call, scene_kind):
    scene, cam = _blinding_scene() if scene_kind == "blinding" else _overexposed_scene()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        CALLS[call](scene, cam, width=4, height=4, device="cpu", integrator="path", max_depth=1)
    said = {str(w.message): w.filename for w in caught}
    for part in EXPECTED[scene_kind]:
        if call == "frame_image" and part.startswith("sample"):
            continue  # one sample a pixel: none of the frame's is dropped
        assert any(part in message for message in said), (part, list(said))
    assert {message: filename for message, filename in said.items() if filename != __file__} == {}


@pytest.mark.parametrize("call", ["wrt.render", "Renderer.render"])
def test_an_empty_scenes_warning_points_at_the_callers_line(call):
    cam = wrt.Camera.look_at((0, 0, 4), (0, 0, 0), fov_y_deg=60)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        CALLS[call](wrt.Scene(), cam, width=4, height=4, device="cpu")
    said = {str(w.message): w.filename for w in caught}
    assert any("nothing to render" in message for message in said), list(said)
    assert {message: filename for message, filename in said.items() if filename != __file__} == {}


def _two_domes(cam, **options):
    scene = wrt.Scene(meshes=[quad((0, 0, 0), (2, 0, 0), (0, 2, 0), name="/quad")],
                      lights=[wrt.DomeLight(color=np.ones(3, np.float32), path=f"/Dome{k}") for k in range(2)])
    return wrt.render(scene, camera=cam, **options)


def _resume_after_set_cameras(cam, **options):
    renderer = wrt.Renderer(_overexposed_scene()[0], camera=cam, **options)
    renderer.render(spp=1)
    renderer.set_cameras([cam])
    return renderer.render(spp=1, resume=True)


@pytest.mark.parametrize("run, part", [(_two_domes, "dome lights: only the first"),
                                       (_resume_after_set_cameras, "resume=True starts over")])
def test_light_and_resume_warnings_point_at_the_callers_line(run, part):
    cam = wrt.Camera.look_at((0, 0, 4), (0, 0, 0), fov_y_deg=60)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run(cam, width=4, height=4, device="cpu", integrator="path", max_depth=1)
    said = {str(w.message): w.filename for w in caught}
    assert any(part in message for message in said), list(said)
    assert {message: filename for message, filename in said.items() if filename != __file__} == {}
