"""Renderer.launch_frame / frame_image and their graph replays (Warp records CPU graphs too) after an edit: the frame
equals a fresh render of the edited settings, or frame_image refuses it, saying what changed."""


import dataclasses
import gc
import weakref

import numpy as np
import pytest
import warp as wp

import wrt
from wrt.procedural import ring_of_cameras, sensor_scene

# Warp records graphs on the CPU too; on a CUDA host the same tests run the CUDA graph path.
CUDA = pytest.mark.skipif(not wp.is_cuda_available(), reason="no CUDA device")


@pytest.fixture(params=["cpu", pytest.param("cuda:0", marks=CUDA)])
def device(request) -> str:
    return request.param


def _lens_camera() -> wrt.Camera:
    cam = wrt.Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    cam.f_stop, cam.focus_distance = 1.4, 5.0
    return cam


def _move(cam):
    cam.to_world[0, 3] += 0.5


def _zoom(cam):
    cam.focal_length *= 1.5


def _widen_film(cam):  # a Renderer given the width alone takes the height from the film's aspect
    cam.vertical_aperture *= 0.5


def _refocus(cam):
    cam.focus_distance = 2.0


EDITS = {"to_world": _move, "focal_length": _zoom, "vertical_aperture": _widen_film, "focus_distance": _refocus}


@pytest.mark.parametrize("field", EDITS)
def test_a_camera_edited_after_the_recording_is_refused_until_uploaded(field, device):
    """The graph reads the cameras as last uploaded: a camera moved, zoomed, given a new film (a new image size) or
    refocused after the recording replayed its old view, and frame_image returned it without a word. Now it names
    the edit; once launch_frame() has uploaded the camera, a new recording replays what a fresh render draws."""
    scene, cam = sensor_scene(), _lens_camera()
    height = None if field == "vertical_aperture" else 6
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=height, device=device)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    EDITS[field](cam)
    wp.capture_launch(capture.graph)
    with pytest.raises(RuntimeError, match=rf"^camera \({field}\) changed since the cameras were uploaded"):
        renderer.frame_image()
    renderer.launch_frame(seed=3)  # outside the capture: uploads the camera
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    wp.capture_launch(capture.graph)
    fresh = wrt.render(scene, camera=cam, width=8, height=height, seed=3, device=device)
    np.testing.assert_array_equal(renderer.frame_image().rgb, fresh.rgb)


def test_a_frame_drawn_before_set_cameras_is_refused_until_drawn_again(device):
    """A frame drawn, then set_cameras with as many cameras (uploaded into the arrays a graph reads): frame_image
    returned the old poses, with nothing replayed since. Refused now; a replay draws the new cameras."""
    scene, cams = sensor_scene(), ring_of_cameras(4)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    renderer.set_cameras(cams[2:])
    with pytest.raises(RuntimeError, match=r"drawn \(or its graph replayed\) before the cameras last changed"):
        renderer.frame_image()
    wp.capture_launch(capture.graph)
    expected = wrt.render_batch(scene, cams[2:], 8, 6, seed=3, device=device).rgb.numpy()
    np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)


def test_a_graph_older_than_the_last_recording_keeps_what_it_reads_and_its_frame_is_refused(device):
    """The Renderer kept what the last recorded graph reads until the next recording only: a graph recorded before
    a scene edit and a second recording replayed kernels on the freed BVH and frame buffers (README: "must not be
    replayed"). Each graph now keeps its own for as long as it lives; its replay's frame is refused, the newer
    graph's replay still draws what a fresh render does, and dropping the old graph frees what it kept."""
    scene, cams = sensor_scene(), ring_of_cameras(2)
    renderer = wrt.Renderer(scene, cameras=cams, width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as old:
        renderer.launch_frame(seed=3)
    kept = [weakref.ref(renderer.accel), weakref.ref(renderer.device_scene), weakref.ref(renderer._frame[0])]
    mesh = scene.meshes[0]
    scene.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([0.0, 0.5, 0.0]))
    renderer.launch_frame(seed=3)  # builds the edited scene again
    with wp.ScopedCapture(device=device) as new:
        renderer.launch_frame(seed=3)
    gc.collect()
    assert all(ref() is not None for ref in kept)  # the old graph's BVH, scene and buffers
    wp.capture_launch(old.graph)
    with pytest.raises(RuntimeError, match=r"before the scene changed.*record the frame again"):
        renderer.frame_image()
    wp.capture_launch(new.graph)
    expected = wrt.render_batch(scene, cams, 8, 6, seed=3, device=device).rgb.numpy()
    np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)
    del old
    gc.collect()
    assert all(ref() is None for ref in kept)


def test_a_batch_frame_image_keeps_its_aovs_when_the_next_frame_is_drawn(device):
    """frame_image's BatchImage had views of the frame's AOV buffers (its rgb a new array): the next frame (a graph's
    replay, a launch_frame) rewrote the AOVs of an image already returned, whose depth then was another frame's."""
    scene, cams = sensor_scene(), ring_of_cameras(4)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    first = renderer.frame_image()
    renderer.set_cameras(cams[2:])
    renderer.launch_frame(seed=3)
    expected = wrt.render_batch(scene, cams[:2], 8, 6, seed=3, device=device)
    for name in ("depth", "prim", "normal", "coverage"):
        np.testing.assert_array_equal(first.aovs[name].numpy(), expected.aovs[name].numpy())
    np.testing.assert_array_equal(first.rgb.numpy(), expected.rgb.numpy())


def test_a_frame_image_of_one_camera_keeps_its_aovs_when_the_next_frame_is_drawn(device):
    """The one-camera Image of frame_image took its AOVs with ``wp.array.numpy()``, a view of the frame's buffers on
    the CPU: the next frame (a launch_frame, a graph's replay) rewrote the depth, prim and normals of an image already
    returned, which then were another view's. Oracle: a fresh render of the first view."""
    scene, cam = sensor_scene(), ring_of_cameras(1)[0]
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    first = renderer.frame_image()
    expected = wrt.render(scene, camera=cam, width=8, height=6, seed=3, device=device)
    cam.to_world[0, 3] += 1.5
    renderer.launch_frame(seed=3)
    for name in ("depth", "prim", "normal", "coverage"):
        np.testing.assert_array_equal(first.aovs[name], expected.aovs[name])
    np.testing.assert_array_equal(first.rgb, expected.rgb)


def test_set_cameras_inside_a_capture_is_refused(device):
    """set_cameras inside a capture recorded its uploads: every replay copied the poses given then (from an array
    freed since) over the cameras set later, and drew those. Refused; the renderer keeps its cameras, and a graph
    recorded without it replays the cameras set outside."""
    scene, cams = sensor_scene(), ring_of_cameras(6)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    with pytest.raises(RuntimeError, match=r"set_cameras\(\) cannot be recorded in a graph"):
        with wp.ScopedCapture(device=device):
            renderer.set_cameras(cams[2:4])
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    renderer.set_cameras(cams[4:6])
    wp.capture_launch(capture.graph)
    expected = wrt.render_batch(scene, cams[4:6], 8, 6, seed=3, device=device).rgb.numpy()
    np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)


@pytest.mark.parametrize("call", ["render", "frame_image", "image_so_far"])
def test_a_call_that_reads_back_is_refused_inside_a_capture(call, device):
    """render() inside a capture recorded its launches and read back buffers they had not written: an image of
    garbage (a mean of 5e32 on the CPU); frame_image()'s and image_so_far()'s coverage kernels were only recorded,
    their coverage garbage. Each is refused naming the call; afterwards the renderer draws as a fresh one."""
    scene = sensor_scene()
    cam = wrt.Camera.look_at((0.0, 1.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device=device)
    renderer.render(seed=1)
    renderer.launch_frame(seed=1)
    with pytest.raises(RuntimeError, match=rf"^{call}\(\) cannot be recorded in a graph"):
        with wp.ScopedCapture(device=device):
            getattr(renderer, call)()
    fresh = wrt.render(scene, camera=cam, width=8, height=6, seed=1, device=device)
    for image in (renderer.render(seed=1), renderer.frame_image(), renderer.image_so_far()):
        np.testing.assert_array_equal(image.rgb, fresh.rgb)
        np.testing.assert_array_equal(image.aovs["coverage"], fresh.aovs["coverage"])


def test_a_batch_camera_edited_after_the_frame_is_named_by_its_index(device):
    """In a batch the refusal names the edited camera by its index (each camera made in Python is just "camera")."""
    scene, cams = sensor_scene(), ring_of_cameras(2)
    renderer = wrt.Renderer(scene, cameras=cams, width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    cams[1].focal_length *= 2.0
    cams[1].exposure_scale = 2.0
    with pytest.raises(RuntimeError, match=r"^cameras\[1\] of 2 \(focal_length, exposure_scale\) changed since"):
        renderer.frame_image()
    renderer.launch_frame(seed=3)
    expected = wrt.render_batch(scene, cams, 8, 6, seed=3, device=device).rgb.numpy()
    np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)


def test_a_scene_camera_replaced_or_removed_after_the_frame_is_named_by_its_path(device):
    """A renderer of a camera path names it in the refusal: replaced in scene.cameras, or gone from it (that was
    called "the camera wrt frames the scene with", a camera the renderer never drew)."""
    scene = sensor_scene()
    cam = wrt.Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    cam.path = "/Cam"
    scene.cameras["/Cam"] = cam
    renderer = wrt.Renderer(scene, camera="/Cam", width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    scene.cameras["/Cam"] = dataclasses.replace(cam, focal_length=80.0)
    with pytest.raises(RuntimeError, match=r"^camera /Cam \(replaced\) changed since the cameras were uploaded"):
        renderer.frame_image()
    del scene.cameras["/Cam"]
    with pytest.raises(RuntimeError, match=r"^camera /Cam \(gone from scene.cameras\) changed since"):
        renderer.frame_image()


@pytest.mark.parametrize("given", ["Sdf.Path", "render settings"])
def test_a_scene_camera_given_by_sdf_path_or_settings_and_removed_is_named_by_its_path(given):
    """A camera given as an Sdf.Path (camera= takes one), or chosen by the render settings (camera=None), and then
    taken out of scene.cameras was called "the camera wrt frames the scene with" in frame_image's refusal: a camera
    the renderer never drew. It is named by its path, as a str path is."""
    from pxr import Sdf

    from wrt.render_settings import RenderSettings

    scene = sensor_scene()
    cam = wrt.Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    cam.path = "/Cam"
    scene.cameras["/Cam"] = cam
    if given == "render settings":
        scene.render_settings = RenderSettings(path="/Render", camera="/Cam", resolution=(8, 6))
    renderer = wrt.Renderer(scene, camera=Sdf.Path("/Cam") if given == "Sdf.Path" else None, width=8, height=6,
                            device="cpu")
    renderer.launch_frame(seed=3)
    del scene.cameras["/Cam"]
    with pytest.raises(RuntimeError, match=r"^camera /Cam \(gone from scene.cameras\) changed since"):
        renderer.frame_image()


def test_frame_image_counts_the_frames_dropped_samples(device):
    """Non-finite samples (here past float32's range under a dome of 1e38 times a texture of 1e38) are counted in
    dropped_samples, which frame_image left at the last render()'s count, of other samples; the frame's own count was
    never reset, so it grew with every frame and replay. frame_image now gives the frame's count, a fresh one-sample
    render's."""
    from wrt.lights import DomeLight

    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    scene = wrt.Scene.from_triangles(quad, [[0, 1, 2], [0, 2, 3]])
    scene.lights = [DomeLight(color=np.full(3, 1e38, np.float32), texture=np.full((2, 4, 3), 1e38, np.float32))]
    cam = wrt.Camera.look_at((0, 0, 4), (0, 0, 0), fov_y_deg=60)
    options = {"camera": cam, "width": 8, "height": 8, "integrator": "path", "device": device}
    fresh = wrt.Renderer(scene, **options)
    fresh.render(spp=1, seed=3)
    assert fresh.dropped_samples > 0
    renderer = wrt.Renderer(scene, **options)
    renderer.render(spp=8, seed=3)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    for _ in range(2):
        wp.capture_launch(capture.graph)
        renderer.frame_image()
        assert renderer.dropped_samples == fresh.dropped_samples


def test_a_graph_keeps_the_arrays_of_the_structs_it_reads(device):
    """A graph kept the Renderer's attributes, not the arrays inside its Warp structs: set_cameras with another camera
    count gave DeviceLights a new headlight array (a scene without lights is lit by a headlight per camera), and the
    old one, which the older graph reads, was freed on CUDA. The graph keeps it for as long as it lives."""
    scene, cams = sensor_scene(), ring_of_cameras(3)
    scene.lights = []
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as old:
        renderer.launch_frame(seed=3)
    headlight = weakref.ref(renderer.device_lights.headlight_dirs)
    renderer.set_cameras(cams)
    renderer.launch_frame(seed=3)
    assert renderer.device_lights.headlight_dirs is not headlight()  # three cameras: a new array
    gc.collect()
    assert headlight() is not None
    del old
    gc.collect()
    assert headlight() is None


def _two_prototype_scene() -> wrt.Scene:
    """sensor_scene whose instances alternate between its box and a second, flatter box prototype."""
    scene = sensor_scene()
    box = scene.prototypes[0]
    flat = [dataclasses.replace(m, points=m.points * np.float32([1.5, 0.3, 1.5])) for m in box.meshes]
    scene.prototypes = [box, wrt.Prototype(path="/flat", meshes=flat)]
    kinds = np.arange(len(scene.instances), dtype=np.int32) % 2
    scene.instances = wrt.Instances.from_transforms(kinds, scene.instances.to_world)
    return scene


@pytest.mark.parametrize("cameras", [1, 2])
def test_a_frame_image_keeps_its_prim_ids_after_the_instances_are_edited_in_place(cameras):
    """frame_image expands prim ids by the instances' prototype ids of the scene drawn: an edit in place after it
    returned (invalidate, then each instance given the other prototype) must not reach the image, nor a batch's views,
    which it expands later. Oracle: a fresh render of the unedited scene."""
    scene, cams = _two_prototype_scene(), ring_of_cameras(cameras)
    if cameras == 1:
        renderer = wrt.Renderer(scene, camera=cams[0], width=12, height=9, device="cpu")
    else:
        renderer = wrt.Renderer(scene, cameras=cams, width=12, height=9, device="cpu")
    renderer.launch_frame(seed=2)
    frame = renderer.frame_image()
    scene.invalidate()
    scene.instances.prototype[:] = 1 - scene.instances.prototype
    views = [frame] if cameras == 1 else [frame.image(k) for k in range(cameras)]
    unedited = _two_prototype_scene()
    for k, view in enumerate(views):
        one = wrt.render(unedited, camera=cams[k], width=12, height=9, seed=2, device="cpu")
        assert len(np.unique(unedited.instances.prototype[one.aovs["instance"][one.aovs["instance"] >= 0]])) == 2
        for name in ("prim", "instance"):
            np.testing.assert_array_equal(view.aovs[name], one.aovs[name], err_msg=f"camera {k} {name}")


@pytest.mark.parametrize("cameras", [1, 2])
def test_image_so_far_keeps_its_prim_ids_after_the_instances_are_edited_in_place(cameras):
    """render() keeps the ids of the scene it drew with its sums, for image_so_far(): an edit in place of the
    instances' prototype ids after it (invalidate, then each instance given the other prototype) must not reach them,
    though the image render() returned is expanded at once. Oracle: a fresh render of the unedited scene."""
    scene, cams = _two_prototype_scene(), ring_of_cameras(cameras)
    views = {"camera": cams[0]} if cameras == 1 else {"cameras": cams}
    renderer = wrt.Renderer(scene, **views, width=12, height=9, device="cpu")
    renderer.render(spp=1, seed=2)
    scene.invalidate()
    scene.instances.prototype[:] = 1 - scene.instances.prototype
    late = renderer.image_so_far()
    unedited = _two_prototype_scene()
    for k, view in enumerate([late] if cameras == 1 else [late.image(k) for k in range(cameras)]):
        one = wrt.render(unedited, camera=cams[k], width=12, height=9, seed=2, device="cpu")
        assert len(np.unique(unedited.instances.prototype[one.aovs["instance"][one.aovs["instance"] >= 0]])) == 2
        np.testing.assert_array_equal(view.aovs["prim"], one.aovs["prim"], err_msg=f"camera {k}")


def test_the_ids_a_render_keeps_hold_no_more_memory_than_the_instances_prototype_ids():
    """Each render() copies the instances' prototype ids (what its ids are expanded by, kept for image_so_far()):
    widened to int64, that copy was twice the int32 array, 40 MB a frame at 5M instances where 20 MB keep the same
    ids."""
    scene = _two_prototype_scene()
    rows = scene.id_rows()
    assert rows.prototype is not scene.instances.prototype
    np.testing.assert_array_equal(rows.prototype, scene.instances.prototype)
    assert rows.prototype.nbytes <= scene.instances.prototype.nbytes


def test_frames_keep_working_past_two_to_the_31_camera_uploads_and_frame_buffers():
    """A simulation calls set_cameras every step, and a scene edited in place every step makes new frame buffers:
    both are numbered on the device in an int32, and past 2^31 - 1 of them the device's number wrapped negative while
    the renderer's Python count did not, so every frame_image from then on raised that the frame was drawn before the
    cameras (or the scene) last changed. The counts start near the limit here, as 2^31 steps cannot run in a test;
    oracle: a fresh renderer's frame of the same camera."""
    scene, cams = sensor_scene(), ring_of_cameras(2)
    renderer = wrt.Renderer(scene, camera=cams[0], width=6, height=4, device="cpu")
    renderer._camera_uploads = renderer._frames_made = 2**31 - 2
    for k in range(4):
        renderer.set_cameras([cams[k % 2]])
        scene.invalidate()  # rebuilt at the next frame: new frame buffers, numbered anew
        renderer.launch_frame(seed=k)
        fresh = wrt.Renderer(scene, cameras=[cams[k % 2]], width=6, height=4, device="cpu")
        fresh.launch_frame(seed=k)
        np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), fresh.frame_image().rgb.numpy(),
                                      err_msg=f"step {k}")


def _as_list(field):
    return lambda cam: setattr(cam, field, np.asarray(getattr(cam, field)).tolist())


SAME_NUMBERS = {
    "to_world list": _as_list("to_world"),
    "to_world 16 numbers": lambda cam: setattr(cam, "to_world", cam.to_world.ravel().tolist()),
    "clipping_range list": _as_list("clipping_range"),
    "clipping_planes list": _as_list("clipping_planes"),
    "focal_length float64": lambda cam: setattr(cam, "focal_length", np.float64(cam.focal_length)),
}


@pytest.mark.parametrize("edit", SAME_NUMBERS)
def test_a_camera_field_set_to_the_same_numbers_is_no_change(edit, device):
    """``cam.to_world = cam.to_world.tolist()`` (or a clipping range as a list, a focal length as np.float64) holds
    the numbers the renderer uploaded: frame_image refused the frame as drawn with a changed camera, and render()
    uploaded the camera again, after which the frame was refused as drawn before the cameras last changed. Oracle:
    the fields' numbers in float64 numpy are the same; the frame equals a fresh render; a list to_world is still
    made the (4, 4) array that check() makes of it."""
    scene, cam = sensor_scene(), _lens_camera()
    cam.clipping_range = (0.5, 100.0)
    before = {name: np.asarray(getattr(cam, name), np.float64) for name in wrt.camera.CAMERA_FIELDS
              if name not in ("path", "projection", "fit")}
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    fresh = wrt.render(scene, camera=cam, width=8, height=6, seed=3, device=device)  # before: a render checks cam
    SAME_NUMBERS[edit](cam)
    for name, numbers in before.items():  # the oracle: no number changed
        assert np.array_equal(np.asarray(getattr(cam, name), np.float64).reshape(numbers.shape), numbers), name
    np.testing.assert_array_equal(renderer.frame_image().rgb, fresh.rgb)
    renderer.render(seed=3)
    np.testing.assert_array_equal(renderer.frame_image().rgb, fresh.rgb)  # the frame's upload is still the last
    assert type(cam.to_world) is np.ndarray and np.array_equal(cam.to_world, before["to_world"])
    assert type(cam.clipping_planes) is np.ndarray and cam.clipping_planes.shape == (0, 4)


REAL_CHANGES = {
    "to_world": lambda cam: setattr(cam, "to_world", (cam.to_world + np.eye(4)[0] * 1e-9).tolist()),
    "clipping_range": lambda cam: setattr(cam, "clipping_range", [[cam.clipping_range[0], cam.clipping_range[1]]]),
    "focal_length": lambda cam: setattr(cam, "focal_length", np.float64("nan")),
}


@pytest.mark.parametrize("field", REAL_CHANGES)
def test_a_camera_field_of_other_numbers_or_shape_is_still_a_change(field, device):
    """The other side of the test above: one number different (by 1e-9, as a list), a clipping range of another
    shape, a NaN focal length are changes, named by frame_image (render refuses the last two)."""
    scene, cam = sensor_scene(), _lens_camera()
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device=device)
    renderer.launch_frame(seed=3)
    REAL_CHANGES[field](cam)
    with pytest.raises(RuntimeError, match=rf"^camera \({field}\) changed since the cameras were uploaded"):
        renderer.frame_image()
    if field == "to_world":
        renderer.launch_frame(seed=3)
        fresh = wrt.render(scene, camera=cam, width=8, height=6, seed=3, device=device)
        np.testing.assert_array_equal(renderer.frame_image().rgb, fresh.rgb)
    else:
        with pytest.raises(ValueError, match=field.replace("_", " ") if field == "clipping_range" else "focalLength"):
            renderer.render(seed=3)
