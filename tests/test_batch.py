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


def test_batch_bad_arguments():
    scene = sensor_scene()
    with pytest.raises(ValueError, match="either camera or"):
        wrt.Renderer(scene, camera=ring_of_cameras(1)[0], cameras=ring_of_cameras(2))
    with pytest.raises(ValueError, match="cameras is empty"):  # was "not both", with only one given
        wrt.render_batch(scene, [], 8, 8)
    with pytest.raises(ValueError, match="pixels"):
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
