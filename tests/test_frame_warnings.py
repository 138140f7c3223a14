"""A Renderer kept for a loop of frames (a simulation's thousands of steps, a progressive viewer) says each warning of
its images once: the counts in the words changed from frame to frame, so Python's filter (which shows a message once)
let every frame repeat the line, and a 1000-frame run gave 1000 near-identical lines on stderr. The counts stay
exact in ``Renderer.dropped_samples`` at every frame."""

import os
import warnings

import numpy as np
from test_warning_lines import _blinding_scene, _overexposed_scene

import wrt

FRAMES = 5
OPTIONS = {"width": 8, "height": 8, "device": "cpu", "integrator": "path"}


def _said(caught, part: str) -> list[str]:
    return [str(w.message) for w in caught if part in str(w.message)]


def test_a_loop_of_renders_warns_of_dropped_samples_once_and_counts_every_frame():
    scene, cam = _blinding_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # A fresh Renderer per frame: the count each frame must give, with nothing said before it.
        expected = [wrt.Renderer(scene, camera=cam, **OPTIONS) for _ in range(FRAMES)]
        for k, fresh in enumerate(expected):
            fresh.render(spp=2, seed=k)
    assert all(fresh.dropped_samples > 0 for fresh in expected)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer = wrt.Renderer(scene, camera=cam, **OPTIONS)
        counts = []
        for k in range(FRAMES):
            renderer.render(spp=2, seed=k)
            counts.append(renderer.dropped_samples)
    assert counts == [fresh.dropped_samples for fresh in expected]
    said = _said(caught, "were not finite")
    assert len(said) == 1, said
    assert f" {counts[0]} sample(s) were not finite" in said[0] and "Renderer.dropped_samples counts" in said[0]


def test_a_progressive_loop_warns_of_its_first_image_and_of_its_first_resumed_one_only():
    scene, cam = _blinding_scene()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer = wrt.Renderer(scene, camera=cam, **OPTIONS)
        renderer.render(spp=2, seed=1)
        for _ in range(FRAMES):
            renderer.render(spp=2, seed=1, resume=True)
    said = _said(caught, "were not finite")
    assert len(said) == 2, said
    assert "resumed renders included" not in said[0] and "of the image's 4 sample(s) per pixel, resumed" in said[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = wrt.Renderer(scene, camera=cam, **OPTIONS)
        whole.render(spp=2 * (FRAMES + 1), seed=1)
    assert renderer.dropped_samples == whole.dropped_samples > 0


def test_a_loop_of_frames_warns_of_dropped_samples_once_and_counts_every_frame():
    scene, cam = _blinding_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = []
        for k in range(FRAMES):
            fresh = wrt.Renderer(scene, camera=cam, **OPTIONS)
            fresh.render(spp=1, seed=k)
            expected.append(fresh.dropped_samples)
    assert all(expected)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer = wrt.Renderer(scene, camera=cam, **OPTIONS)
        counts = []
        for k in range(FRAMES):
            renderer.launch_frame(seed=k)
            renderer.frame_image()
            counts.append(renderer.dropped_samples)
    assert counts == expected
    assert len(_said(caught, "were not finite")) == 1


def test_a_loop_of_renders_and_batches_warns_of_clamped_pixels_once():
    scene, cam = _overexposed_scene()
    for cameras in (None, [cam, cam]):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            views = {"camera": cam} if cameras is None else {"cameras": cameras}
            renderer = wrt.Renderer(scene, **views, **dict(OPTIONS, width=4, height=4, max_depth=1))
            for k in range(FRAMES):
                image = renderer.render(spp=2, seed=k)
                rgb = image.rgb if cameras is None else image.rgb.numpy()
                assert np.all(rgb == np.finfo(np.float32).max)
        said = _said(caught, "were clamped to its largest")
        assert len(said) == 1, said
        assert said[0].startswith(f"scene: {16 * (1 if cameras is None else 2)} pixel(s)")


def test_a_warning_made_an_error_is_raised_at_every_frame():
    """A filter that makes the warning an error fails each frame that drops samples, not the first one alone."""
    scene, cam = _blinding_scene()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        renderer = wrt.Renderer(scene, camera=cam, **OPTIONS)
        warnings.filterwarnings("error", message=".*were not finite")
        for k in range(3):
            try:
                renderer.render(spp=2, seed=k)
            except UserWarning as e:
                assert "were not finite" in str(e)
            else:
                raise AssertionError(f"frame {k} dropped {renderer.dropped_samples} samples without raising")


OVEREXPOSED_USDA = """#usda 1.0
(
    endTimeCode = 4
    startTimeCode = 1
    upAxis = "Y"
)
def Cube "Box"
{
    double size = 100
    double3 xformOp:translate.timeSamples = {1: (0, -50, 0), 4: (0.5, -50, 0)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def DomeLight "Dome"
{
    float inputs:intensity = 1e38
}
def Camera "Cam"
{
    float exposure = 10
    float2 clippingRange = (0.1, 100)
    double3 xformOp:translate = (0, 3, 0)
    double3 xformOp:rotateXYZ = (-90, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}
"""


def test_the_frames_of_a_frame_renderer_warn_of_clamped_pixels_once(tmp_path):
    """FrameRenderer makes a Renderer per frame; they share what was said, as they do the far-view warnings."""
    from wrt.animation import FrameRenderer

    path = tmp_path / "overexposed.usda"
    path.write_text(OVEREXPOSED_USDA)
    renderer = FrameRenderer(path, camera="/Cam", width=4, height=4, device="cpu", integrator="path", max_depth=1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for frame in range(1, 5):
            assert np.all(renderer.render(frame, spp=2, seed=frame).rgb == np.finfo(np.float32).max)
    said = _said(caught, "were clamped to its largest")
    assert len(said) == 1, said


BLIND_USDA = """#usda 1.0
(
    endTimeCode = 4
    startTimeCode = 1
    upAxis = "Y"
)
def Cube "Box"
{
    double3 xformOp:translate.timeSamples = {1: (0, 0, -50), 4: (0, 0, -60)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Cam"
{
    float2 clippingRange = (0.1, 10)
}
"""


def test_a_camera_that_sees_nothing_at_every_frame_of_a_frame_renderer_is_warned_of_once(tmp_path):
    """The box moves away from a camera whose far plane (10) is nearer than it (50 to 60): the warning names the
    box's extent along the view, new at each frame, and FrameRenderer's Renderer of each frame said it again."""
    from wrt.animation import FrameRenderer

    path = tmp_path / "blind.usda"
    path.write_text(BLIND_USDA)
    renderer = FrameRenderer(path, camera="/Cam", width=4, height=4, device="cpu")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for frame in range(1, 5):
            assert (renderer.render(frame).aovs["prim"] == -1).all()
    said = _said(caught, "sees nothing")
    assert len(said) == 1 and "lies from 49 to 51 along its view" in said[0], said


BLINDING_USDA = """#usda 1.0
(
    endTimeCode = 4
    startTimeCode = 1
    upAxis = "Y"
)
def Cube "Box"
{
    double3 xformOp:translate.timeSamples = {1: (0, 0, 0), 4: (0.5, 0, 0)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def DomeLight "Dome"
{
    float inputs:intensity = 1e38
    asset inputs:texture:file = @sky.tif@
}
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 4)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def test_a_frame_renderer_logs_each_frames_dropped_samples(tmp_path):
    """Said once over the frames, the dropped-sample warning no longer gives each frame's count, and a FrameRenderer's
    per-frame Renderer (with its dropped_samples) is not the caller's: each log row has the frame's count. A dome of
    1e38 over a float TIFF of 1e38 drops samples; oracle: a Renderer of the stage loaded at that frame."""
    from PIL import Image as PilImage

    from wrt.animation import FrameRenderer

    PilImage.fromarray(np.full((2, 4), 1e38, np.float32), mode="F").save(tmp_path / "sky.tif")
    path = tmp_path / "blinding.usda"
    path.write_text(BLINDING_USDA)
    options = {"width": 6, "height": 6, "device": "cpu", "integrator": "path"}
    renderer = FrameRenderer(path, camera="/Cam", **options)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for frame in (1, 2, 3):
            renderer.render(frame, spp=2, seed=frame)
    said = _said(caught, "were not finite")
    assert len(said) == 1, said
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for row in renderer.log:
            fresh = wrt.Renderer(wrt.load_usd(path, time=row["frame"]), camera="/Cam", **options)
            fresh.render(spp=2, seed=int(row["frame"]))
            assert row["dropped_samples"] == fresh.dropped_samples > 0


def test_a_loop_that_resumes_with_a_new_seed_each_frame_is_told_once_that_it_starts_over():
    """resume=True adds samples of the same seed only: a loop passing the frame number as the seed starts over at
    every frame, and the warning naming both seeds (new words each frame) was said at every frame. Each image is
    still a fresh render's of its seed."""
    scene, cam = _overexposed_scene()
    options = dict(OPTIONS, integrator="whitted", width=4, height=4)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer = wrt.Renderer(scene, camera=cam, **options)
        for k in range(FRAMES):
            image = renderer.render(spp=2, seed=k, resume=True)
    said = _said(caught, "starts over from no samples")
    assert len(said) == 1 and "seed 1 is not the previous render's (0)" in said[0], said
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fresh = wrt.Renderer(scene, camera=cam, **options).render(spp=2, seed=FRAMES - 1)
    np.testing.assert_array_equal(image.rgb, fresh.rgb)


def test_a_loop_of_wrt_render_calls_warns_once_per_scene(tmp_path):
    """wrt.render() makes a Renderer per call, and a Renderer says each warning once: a loop calling it per frame (a
    new seed, or the stage loaded at each frame's time) gave the dropped-sample warning at every frame, its count new
    each time. Said once per scene now (a stage by its file); another scene, or another stage file, is warned of
    again. Oracle that every call dropped samples: a Renderer of the same call, warnings ignored."""
    from PIL import Image as PilImage

    PilImage.fromarray(np.full((2, 4), 1e38, np.float32), mode="F").save(tmp_path / "sky.tif")
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(BLINDING_USDA)
    python_scenes = [_blinding_scene() for _ in range(2)]
    loops = [([scene] * FRAMES, {"camera": cam}) for scene, cam in python_scenes]  # one scene, then another
    times = np.linspace(1, 4, FRAMES)  # a stage loaded at each frame's time, then another stage file
    loops += [([wrt.load_usd(tmp_path / name, time=t) for t in times], {"camera": "/Cam"}) for name in ("a.usda",
                                                                                                       "b.usda")]
    for scenes, view in loops:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for k, scene in enumerate(scenes):
                fresh = wrt.Renderer(scene, **view, **OPTIONS)
                fresh.render(spp=2, seed=k)
                assert fresh.dropped_samples > 0
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for k, scene in enumerate(scenes):
                wrt.render(scene, spp=2, seed=k, **view, **OPTIONS)
        said = _said(caught, "were not finite")
        assert len(said) == 1, said
        assert said[0].startswith(f"{scenes[0].source}: " if scenes[0].source else "scene: "), said


def test_the_frames_of_two_worker_processes_warn_of_dropped_samples_once(tmp_path, monkeypatch):
    """A frame run over several devices (wrt render --devices, --dask) keeps a FrameRenderer per worker process, each
    saying the dropped-sample warning once, in words of its own frame (its count); the parent said each worker's by
    its words, so N workers gave it N times. It says it once now, by the key the Renderers say it once by. First two
    workers' tasks run here as a worker runs them (a FrameRenderer each), then a run on two CPU worker processes."""
    import os

    from PIL import Image as PilImage

    from wrt import animation

    PilImage.fromarray(np.full((2, 4), 1e38, np.float32), mode="F").save(tmp_path / "sky.tif")
    path = tmp_path / "blinding.usda"
    path.write_text(BLINDING_USDA)
    options = {"camera": "/Cam", "width": 6, "height": 6, "integrator": "path"}
    jobs = [(float(frame), tmp_path / f"f_{frame}.npy") for frame in (1, 2, 3, 4)]
    results = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for frame, file in jobs[:2]:  # frame 1 on one worker, frame 2 on another
            monkeypatch.setattr(animation, "_WORKER_RENDERERS", {})
            job = animation._task(os.fspath(path), frame, file, 2, 0, 0.0, options)
            results.append(animation.render_frame_task(job))
    sent = [[message for message, _, _ in result["warnings"] if "were not finite" in message] for result in results]
    assert [len(each) for each in sent] == [1, 1], sent  # each worker said it
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        write = animation._frame_writer(rows := [])
        for result, (_, file) in zip(results, jobs):
            write(result, file)
    assert len(_said(caught, "were not finite")) == 1
    assert [row["frame"] for row in rows] == [1.0, 2.0] and all(file.is_file() for _, file in jobs[:2])

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = animation.render_frames(path, jobs, devices=["cpu", "cpu"], spp=2, **options)
    assert sorted(row["frame"] for row in rows) == [1.0, 2.0, 3.0, 4.0]
    assert all(row["dropped_samples"] > 0 for row in rows), rows
    assert len(_said(caught, "were not finite")) == 1


def test_wrt_render_keeps_one_set_of_said_warnings_per_stage_file_however_often_it_is_edited(tmp_path):
    """A stage file written anew at each frame (a pipeline exporting it, then calling wrt.render) is warned of again
    after each edit, as before; the warnings said for its earlier versions were kept besides, one set per
    modification time, growing with every frame though no later call could reach them. One set per file now."""
    from PIL import Image as PilImage

    from wrt import far_views

    PilImage.fromarray(np.full((2, 4), 1e38, np.float32), mode="F").save(tmp_path / "sky.tif")
    path = tmp_path / "edited.usda"
    path.write_text(BLINDING_USDA)
    for k in range(3):
        os.utime(path, ns=(10**18 + k, 10**18 + k))  # written again: a new modification time
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            wrt.render(wrt.load_usd(path), camera="/Cam", spp=2, seed=k, **OPTIONS)
        assert len(_said(caught, "were not finite")) == 1  # each version warned of
    kept = [key for key in far_views._SCENES_SHOWN if os.fspath(path) in str(key)]
    assert len(kept) == 1, kept
