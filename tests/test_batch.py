"""render_batch: many cameras in one launch equal the same cameras rendered one by one."""

import numpy as np
import pytest
import warp as wp

import wrt
from wrt.procedural import ring_of_cameras, sensor_scene


@pytest.mark.parametrize("integrator,spp", [("whitted", 1), ("path", 2), ("depth", 1)])
def test_batch_equals_serial(integrator, spp):
    scene = sensor_scene()
    cams = ring_of_cameras(24)
    batch = wrt.render_batch(scene, cams, 24, 16, integrator=integrator, spp=spp, seed=5, device="cpu")
    rgb, aovs = batch.numpy()
    assert rgb.shape == (24, 16, 24, 3) and aovs["depth"].shape == (24, 16, 24) and aovs["normal"].shape[-1] == 3
    for k in range(0, 24, 5):
        one = wrt.render(scene, camera=cams[k], width=24, height=16, integrator=integrator, spp=spp, seed=5,
                         device="cpu")
        np.testing.assert_array_equal(rgb[k], one.rgb, err_msg=f"camera {k}")
        view = batch.image(k)
        for name in one.aovs:
            np.testing.assert_array_equal(view.aovs[name], one.aovs[name], err_msg=f"camera {k} {name}")
    assert len({float(rgb[k].mean()) for k in range(24)}) > 12  # the views really differ


def test_batch_arrays_are_shared_without_copy():
    batch = wrt.render_batch(sensor_scene(), ring_of_cameras(4), 8, 6, device="cpu")
    if not batch.rgb.device.is_cpu:  # (benchmarks/render_on_cuda.py moves every renderer to a GPU)
        pytest.skip("numpy takes DLPack arrays in CPU memory only")
    view = np.from_dlpack(batch.rgb)  # DLPack: the same memory as the Warp array
    assert view.shape == (4, 6, 8, 3)
    batch.rgb.fill_(wp.vec3(7.0, 7.0, 7.0))
    assert np.all(view == 7.0)


def test_renderer_with_cameras_reuses_the_bvh_for_new_poses():
    scene = sensor_scene()
    cams = ring_of_cameras(10)
    renderer = wrt.Renderer(scene, cameras=cams[:4], width=12, height=10, device="cpu")
    first = renderer.render().rgb.numpy()
    accel = renderer.accel
    renderer.set_cameras(cams[4:10])
    second = renderer.render().rgb.numpy()
    assert renderer.accel is accel and second.shape == (6, 10, 12, 3)
    expected = wrt.render_batch(scene, cams[4:10], 12, 10, device="cpu").rgb.numpy()
    np.testing.assert_array_equal(second, expected)
    assert not np.array_equal(first[0], second[0])


def test_launch_frame_after_set_cameras_with_another_count_renders_the_new_cameras():
    """launch_frame kept the buffers of its first call: after set_cameras with more cameras it wrote past their end
    and frame_image failed to reshape them; with fewer it read past the camera array (a segfault on the CPU)."""
    scene = sensor_scene()
    cams = ring_of_cameras(4)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=16, height=12, device="cpu")
    with pytest.raises(RuntimeError, match=r"frame_image\(\) needs a launch_frame\(\) first"):
        renderer.frame_image()  # a TypeError about unpacking None before
    renderer.launch_frame(seed=1)
    for views in (cams, cams[1:2]):  # more cameras, then fewer
        renderer.set_cameras(views)
        with pytest.raises(RuntimeError, match="needs a launch_frame"):
            renderer.frame_image()  # the buffers of the old count are gone
        renderer.launch_frame(seed=1)
        expected = wrt.render_batch(scene, views, 16, 12, seed=1, device="cpu").rgb.numpy()
        np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)


def test_default_headlight_follows_each_camera_of_a_batch():
    """On a stage without lights every camera gets a headlight along its own viewing direction (README); in a batch
    (and after set_cameras) the headlight of every view pointed along the first camera, so camera k of the batch
    was not the image a render of camera k alone gives."""
    scene = wrt.Scene.from_triangles([[-20, -20, 0], [20, -20, 0], [20, 20, 0], [-20, 20, 0]], [[0, 1, 2], [0, 2, 3]])
    eyes = [(0.0, 0.0, 5.0), (4.0, 0.0, 3.0), (0.0, -3.0, 4.0), (1.0, 2.0, 2.0)]
    cams = [wrt.Camera.look_at(eye, (0, 0, 0), fov_y_deg=30.0) for eye in eyes]
    batch = wrt.render_batch(scene, cams[:3], 12, 10, device="cpu")
    rgb, aovs = batch.numpy()
    for k, eye in enumerate(eyes[:3]):
        one = wrt.render(scene, camera=cams[k], width=12, height=10, device="cpu")
        np.testing.assert_array_equal(rgb[k], one.rgb, err_msg=f"camera {k}")
        # Grey 0.5 Lambert plane: the headlight's E = 0.8 pi at incidence cos gives 0.5 * 0.8 cos, the dome 0.5 * 0.2.
        cos = eye[2] / np.linalg.norm(eye)
        hit = aovs["prim"][k] >= 0
        assert hit.all()  # the quad fills the view
        np.testing.assert_allclose(rgb[k][hit], 0.5 * 0.8 * cos + 0.1, rtol=1e-5, err_msg=f"camera {k}")
    renderer = wrt.Renderer(scene, cameras=cams[:1], width=12, height=10, device="cpu")
    renderer.set_cameras(cams[3:])
    np.testing.assert_allclose(renderer.render().rgb.numpy()[0], 0.5 * 0.8 * 2.0 / 3.0 + 0.1, rtol=1e-5)


def test_batch_bad_arguments():
    scene = sensor_scene()
    with pytest.raises(ValueError, match="either camera or"):
        wrt.Renderer(scene, camera=ring_of_cameras(1)[0], cameras=ring_of_cameras(2))
    with pytest.raises(ValueError, match="cameras is empty"):  # was "not both", with only one given
        wrt.render_batch(scene, [], 8, 8)
    with pytest.raises(ValueError, match="^2 images of 8192x8192 are 134,217,728 pixels; at most 67,108,864 are "):
        wrt.render_batch(scene, ring_of_cameras(2), 8192, 8192)
    batch = wrt.render_batch(scene, ring_of_cameras(2), 4, 4, device="cpu")
    with pytest.raises(IndexError):
        batch.image(2)
    for k in (1.0, True, "0"):  # Warp's "Invalid index: 1.0", camera 1 for True, a str/int comparison error
        with pytest.raises(TypeError, match="camera index must be an integer"):
            batch.image(k)
    np.testing.assert_array_equal(batch.image(np.int64(-1)).rgb, batch.image(1).rgb)
    # One camera, not in a list: a path was split into characters ("no camera at '/'"), a Camera or None failed
    # with "object is not iterable".
    for lone in ("/World/Camera", ring_of_cameras(1)[0], None, 5):
        with pytest.raises(TypeError, match="cameras must be a list of wrt.Camera or camera prim paths"):
            wrt.render_batch(scene, lone, 8, 8)


def test_batch_on_cuda_equals_serial_on_cuda():
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    scene = sensor_scene()
    cams = ring_of_cameras(1024)
    batch = wrt.render_batch(scene, cams, 64, 64, device="cuda:0")
    rgb, aovs = batch.numpy()
    for k in range(1024):  # every camera, each as a render of its own
        one = wrt.render(scene, camera=cams[k], width=64, height=64, device="cuda:0")
        np.testing.assert_array_equal(rgb[k], one.rgb)
        np.testing.assert_array_equal(aovs["depth"][k], one.aovs["depth"])


def test_a_recorded_frame_replays_with_the_cameras_set_since():
    """README: set_cameras every simulation step, and a frame recorded once as a CUDA graph and replayed. set_cameras
    made new camera (and headlight) arrays, so the replayed graph still read the recorded ones: the old poses."""
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    scene = sensor_scene()
    scene.lights = []  # the default headlight then turns with each camera too
    cams = ring_of_cameras(4)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=32, height=24, device="cuda:0")
    renderer.launch_frame(seed=3)  # allocates the buffers before the capture
    with wp.ScopedCapture(device="cuda:0") as capture:
        renderer.launch_frame(seed=3)
    renderer.set_cameras(cams[2:])
    wp.capture_launch(capture.graph)
    wp.capture_launch(capture.graph)  # the coverage counts are zeroed inside the graph: replays do not add up
    frame = renderer.frame_image()
    expected = wrt.render_batch(scene, cams[2:], 32, 24, seed=3, device="cuda:0")
    np.testing.assert_array_equal(frame.rgb.numpy(), expected.rgb.numpy())
    coverage = frame.aovs["coverage"].numpy()
    np.testing.assert_array_equal(coverage, expected.aovs["coverage"].numpy())
    assert 0 < coverage.mean() < 1  # the sensor scene shows both geometry and background


def test_a_scene_edit_is_refused_inside_a_capture_and_followed_outside_it():
    """A rebuild (new BVH, uploads) cannot be recorded into a CUDA graph: launch_frame inside a capture after a scene
    edit says what to do instead; outside a capture it builds again and draws the edited scene."""
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    import dataclasses

    scene = sensor_scene()
    cams = ring_of_cameras(2)
    renderer = wrt.Renderer(scene, cameras=cams, width=32, height=24, device="cuda:0")
    renderer.launch_frame(seed=3)
    mesh = scene.meshes[0]
    scene.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([0.0, 0.5, 0.0]))
    with pytest.raises(RuntimeError, match=r"call launch_frame\(\) once outside the capture"):
        with wp.ScopedCapture(device="cuda:0"):
            renderer.launch_frame(seed=3)
    renderer.launch_frame(seed=3)
    expected = wrt.render_batch(scene, cams, 32, 24, seed=3, device="cuda:0").rgb.numpy()
    np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)


def test_a_camera_edited_after_it_was_made_is_checked_and_named_by_its_index():
    """Camera fields are plain attributes (ring_of_cameras sets film offsets after construction) and were checked on
    construction only: a NaN written into a camera's transform was refused as "singular (a zero scale)" without
    saying which camera of the batch, and a NaN focal length or an inverted clipping range rendered background."""
    scene = sensor_scene()
    cams = ring_of_cameras(3)
    nan_pose, nan_focal, inverted = (wrt.Camera.look_at((0, 2, 5), (0, 0, 0)) for _ in range(3))
    nan_pose.to_world[0, 3] = np.nan
    nan_focal.focal_length = float("nan")
    inverted.clipping_range = (5.0, 1.0)
    for bad, problem in ((nan_pose, "transform is not finite"), (nan_focal, "finite positive focalLength"),
                         (inverted, "near < far")):
        with pytest.raises(ValueError, match=rf"^cameras\[2\] of 4: camera .*{problem}"):
            wrt.render_batch(scene, [*cams[:2], bad, cams[2]], 8, 6, device="cpu")
        with pytest.raises(ValueError, match=rf"^camera .*{problem}"):  # one camera: no index to name
            wrt.render(scene, camera=bad, width=8, height=6, device="cpu")
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device="cpu")
    with pytest.raises(ValueError, match=r"^cameras\[1\] of 2: camera transform is not finite"):
        renderer.set_cameras([cams[2], nan_pose])
    # The refused list left the renderer as it was: it still draws its two cameras.
    np.testing.assert_array_equal(renderer.render().image(1).rgb,
                                  wrt.render(scene, camera=cams[1], width=8, height=6, device="cpu").rgb)


def test_cameras_as_a_tuple_or_a_generator_render_as_the_list_does():
    """render_batch took a generator of cameras, Renderer(cameras=...) and set_cameras refused it ("must be a list");
    a dict's keys were read as prim paths ("no camera at 'front'"); an entry of no camera kind was not named."""
    scene = sensor_scene()
    cams = ring_of_cameras(5)
    expected = wrt.render_batch(scene, cams[:3], 8, 6, device="cpu").rgb.numpy()
    renderer = wrt.Renderer(scene, cameras=(c for c in cams[:3]), width=8, height=6, device="cpu")
    np.testing.assert_array_equal(renderer.render().rgb.numpy(), expected)
    renderer.set_cameras(c for c in cams[3:])
    np.testing.assert_array_equal(renderer.render().rgb.numpy(),
                                  wrt.render_batch(scene, tuple(cams[3:]), 8, 6, device="cpu").rgb.numpy())
    with pytest.raises(ValueError, match="cameras is empty"):
        renderer.set_cameras(c for c in [])
    with pytest.raises(ValueError, match="cameras must be a list of cameras"):
        renderer.set_cameras({"front": cams[0]})
    with pytest.raises(TypeError, match="cameras must be a list of wrt.Camera"):
        wrt.render_batch(scene, {"front": cams[0]}, 8, 6, device="cpu")
    with pytest.raises(TypeError, match=r"^cameras\[1\] of 2: camera must be a wrt.Camera"):
        renderer.set_cameras([cams[0], 5])


def test_a_camera_changed_after_upload_is_uploaded_again_at_the_next_render():
    """A Renderer read a camera's pose and lens at upload but its exposure_scale at every render: scaling a camera
    after upload brightened the next image, and a NaN set there (after the camera's check) made it NaN silently.
    Now every field is followed at the next render, as a new Renderer takes it, and a NaN is refused, naming the
    camera."""
    scene = sensor_scene()
    cams = [wrt.Camera.look_at((0, 2, 5), (0, 0, 0)) for _ in range(2)]
    renderer = wrt.Renderer(scene, cameras=cams, width=8, height=6, device="cpu")
    before = renderer.render(seed=1).rgb.numpy()
    assert before.mean() > 0.0
    cams[1].exposure_scale = float("nan")
    cams[0].exposure_scale = 4.0
    with pytest.raises(ValueError, match=r"^cameras\[1\] of 2: camera needs a non-negative exposure scale"):
        renderer.render(seed=1)
    cams[1].exposure_scale = 2.0
    after = renderer.render(seed=1).rgb.numpy()
    np.testing.assert_allclose(after[0], 4.0 * before[0], rtol=1e-6)
    np.testing.assert_allclose(after[1], 2.0 * before[1], rtol=1e-6)


def test_a_misspelt_aov_name_lists_the_names_there_are():
    """``img.aovs["dpth"]`` was a plain KeyError saying ``'dpth'``; it names the AOVs the image has (the batch's too),
    and the names that are there still read as a dict's."""
    scene = sensor_scene()
    one = wrt.render(scene, camera=ring_of_cameras(1)[0], width=8, height=6, device="cpu")
    batch = wrt.render_batch(scene, ring_of_cameras(2), 8, 6, device="cpu")
    for aovs in (one.aovs, batch.aovs, batch.image(1).aovs):
        with pytest.raises(KeyError, match=r"no AOV 'dpth'.*; this image has: .*\bdepth\b"):
            aovs["dpth"]
        assert "dpth" not in aovs and aovs.get("dpth") is None and aovs["depth"] is dict.__getitem__(aovs, "depth")


@pytest.mark.parametrize("name, meant", [("dpth", "depth"), ("Normal", "normal"), ("geometric-normal",
                                                                                   "geometric_normal")])
def test_a_misspelt_aov_name_names_the_one_meant(name, meant):
    """The KeyError listed the AOVs there are but named none as the one meant, as the misspelt names of the
    command line (--aov dept: 'did you mean 'depth'?') and of wrt.render's arguments do."""
    image = wrt.render(sensor_scene(), camera=ring_of_cameras(1)[0], width=8, height=6, device="cpu")
    with pytest.raises(KeyError, match=rf"no AOV '{name}' \(did you mean '{meant}'\?\); this image has: "):
        image.aovs[name]


def _pinhole_and_lens_renders(device: str):
    """A kept Renderer of a pinhole camera, and that camera, to be given depth of field later."""
    cam = wrt.Camera.look_at((0.0, 0.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    return wrt.Renderer(sensor_scene(), camera=cam, width=32, height=24, device=device), cam


def test_a_frame_drawn_before_the_camera_got_depth_of_field_is_refused():
    """launch_frame fixes, in what a CUDA graph records, whether sample 0 samples the lens. A graph recorded for a
    pinhole camera and replayed after the camera got f_stop and focus_distance (uploaded by a render) drew sharp
    frames without a word. frame_image now refuses such a frame (here the CPU's frame drawn before, which a replay
    leaves as it is), and a new launch_frame draws the blur: one lens sample, as a one-sample render gives."""
    renderer, cam = _pinhole_and_lens_renders("cpu")
    renderer.launch_frame(seed=3)
    cam.f_stop, cam.focus_distance = 1.4, 2.0
    renderer.render(seed=3)  # uploads the lens into the arrays a recorded graph reads
    with pytest.raises(RuntimeError, match=r"depth of field.*record the frame again"):
        renderer.frame_image()
    renderer.launch_frame(seed=3)
    expected = wrt.render(renderer.scene, camera=cam, width=32, height=24, seed=3, device="cpu")
    np.testing.assert_array_equal(renderer.frame_image().rgb, expected.rgb)


@pytest.mark.parametrize("device", ["cpu", "cuda:0"])
def test_a_graph_recorded_before_the_camera_got_depth_of_field_is_refused_after_a_replay(device):
    """The same with a recorded graph (Warp records CPU graphs too): its replay after the lens was uploaded drew the
    pinhole image; a new recording replays the blur a one-sample render gives."""
    if device != "cpu" and not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    renderer, cam = _pinhole_and_lens_renders(device)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    cam.f_stop, cam.focus_distance = 1.4, 2.0
    renderer.launch_frame(seed=3)  # outside the capture: uploads the lens, draws it
    drawn = renderer.frame_image().rgb
    wp.capture_launch(capture.graph)  # the old recording: sample 0 through the lens centre
    with pytest.raises(RuntimeError, match="record the frame again"):
        renderer.frame_image()
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    wp.capture_launch(capture.graph)
    expected = wrt.render(renderer.scene, camera=cam, width=32, height=24, seed=3, device=device).rgb
    np.testing.assert_array_equal(renderer.frame_image().rgb, expected)
    np.testing.assert_array_equal(drawn, expected)


@pytest.mark.parametrize("device", ["cpu", "cuda:0"])
def test_a_graph_recorded_before_a_scene_edit_is_refused_after_its_replay_and_its_buffers_kept(device):
    """A scene edit's rebuild (at the next launch_frame outside a capture) dropped the BVH, device scene and frame
    buffers a recorded graph holds raw pointers to: a CUDA replay launched kernels on freed memory, and frame_image
    then read the new buffers, the last frame drawn outside the graph, without a word. The recorded graph keeps its
    objects for as long as it lives (``tests/test_recorded_frames.py`` keeps an older graph past a new recording),
    frame_image refuses the old graph's frame, and a new recording replays the edited scene as a fresh render
    draws it."""
    if device != "cpu" and not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    import dataclasses
    import gc
    import weakref

    scene = sensor_scene()
    cams = ring_of_cameras(2)
    renderer = wrt.Renderer(scene, cameras=cams, width=32, height=24, device=device)
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    recorded = [weakref.ref(renderer.accel), weakref.ref(renderer.device_scene), weakref.ref(renderer._frame[0])]
    mesh = scene.meshes[0]
    scene.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([0.0, 0.5, 0.0]))
    renderer.launch_frame(seed=3)  # outside the capture: builds the edited scene again
    gc.collect()
    assert all(ref() is not None for ref in recorded)  # what the old graph reads is still there
    wp.capture_launch(capture.graph)
    with pytest.raises(RuntimeError, match=r"before the scene changed.*record the frame again"):
        renderer.frame_image()
    with wp.ScopedCapture(device=device) as capture:
        renderer.launch_frame(seed=3)
    wp.capture_launch(capture.graph)
    expected = wrt.render_batch(scene, cams, 32, 24, seed=3, device=device).rgb.numpy()
    np.testing.assert_array_equal(renderer.frame_image().rgb.numpy(), expected)
    gc.collect()
    assert all(ref() is None for ref in recorded)  # released with the old graph, which `capture` no longer holds


def test_a_graph_replayed_after_a_scene_edit_with_no_launch_since_is_refused():
    """Replayed right after the edit (no launch_frame outside the capture to build again), the graph drew the old
    scene with the arrays it was recorded with, and frame_image returned that image as the frame: now refused."""
    import dataclasses

    scene = sensor_scene()
    renderer = wrt.Renderer(scene, cameras=ring_of_cameras(2), width=32, height=24, device="cpu")
    renderer.launch_frame(seed=3)
    with wp.ScopedCapture(device="cpu") as capture:
        renderer.launch_frame(seed=3)
    mesh = scene.meshes[0]
    scene.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([0.0, 0.5, 0.0]))
    wp.capture_launch(capture.graph)
    with pytest.raises(RuntimeError, match=r"before the scene changed.*record the frame again"):
        renderer.frame_image()


@pytest.mark.parametrize("edit", ["mesh added", "instances dropped"])
def test_a_batch_view_keeps_the_prim_ids_of_the_scene_it_drew_after_the_scene_is_edited(edit):
    """BatchImage.image(k) turned geometry ids into rows of Scene.triangles() when called, by the scene as it was
    then: a mesh added after the render (a robot spawning an object between steps) shifted every instance's rows,
    and instances dropped raised an IndexError or named other triangles. The view is the image a render of the
    unedited scene gives."""
    scene, cams = sensor_scene(), ring_of_cameras(3)
    batch = wrt.render_batch(scene, cams, 12, 9, seed=2, device="cpu")
    if edit == "mesh added":
        triangle = wrt.Scene.from_triangles(np.float32([[5, 5, 5], [6, 5, 5], [5, 6, 5]]), np.int32([[0, 1, 2]]))
        scene.meshes = [*triangle.meshes, *scene.meshes]
    else:
        scene.instances = wrt.Instances.from_transforms(np.zeros(1, np.int32), scene.instances.to_world[-1:])
    unedited = sensor_scene()
    for k in range(len(cams)):
        one = wrt.render(unedited, camera=cams[k], width=12, height=9, seed=2, device="cpu")
        view = batch.image(k)
        assert (one.aovs["instance"] >= 0).any()  # some pixels see an instance, whose rows the edit moved
        for name in ("prim", "instance"):
            np.testing.assert_array_equal(view.aovs[name], one.aovs[name], err_msg=f"camera {k} {name}")


def test_batch_numpy_gives_copies_on_every_device():
    """BatchImage.numpy() says it gives host copies; on the CPU Warp's numpy() is a view, so scaling the returned
    rgb in place (or writing into an AOV) rewrote the batch itself, and batch.image(k) then showed the edit, where a
    CUDA batch's stayed as rendered."""
    scene, cams = sensor_scene(), ring_of_cameras(2)
    batch = wrt.render_batch(scene, cams, 8, 6, seed=1, device="cpu")
    rgb, aovs = batch.numpy()
    rgb *= 0.0
    aovs["depth"][:] = -1.0
    one = wrt.render(scene, camera=cams[1], width=8, height=6, seed=1, device="cpu")
    view = batch.image(1)
    np.testing.assert_array_equal(view.rgb, one.rgb)
    np.testing.assert_array_equal(view.aovs["depth"], one.aovs["depth"])
    view.rgb[:] = 5.0  # an image(k) is a host image of its own likewise
    view.aovs["normal"][:] = 0.0
    again = batch.image(1)
    np.testing.assert_array_equal(again.rgb, one.rgb)
    np.testing.assert_array_equal(again.aovs["normal"], one.aovs["normal"])
