"""Flags, choices and numbers of the public Python API outside the render's own: a bool taken by its truth, a name
iterated letter by letter or a number numpy refused in its own words were each mistakes passed on without a word."""

import re

import numpy as np
import pytest
import warp as wp

import wrt
import wrt.rays as rays
from wrt import animation, distributed


@pytest.fixture
def image():
    return wrt.Image(np.zeros((2, 3, 3), np.float32), {"depth": np.ones((2, 3), np.float32)})


@pytest.mark.parametrize("png", ["false", None, 2, np.zeros(1)])
def test_save_aovs_png_is_a_flag(image, tmp_path, png):
    with pytest.raises(TypeError, match="save_aovs: png must be True or False"):
        image.save_aovs(tmp_path, png=png)
    assert not list(tmp_path.iterdir())  # refused before any file is written


@pytest.mark.parametrize("png", [False, 0, np.False_, True, 1, np.True_])
def test_save_aovs_takes_bools_and_0_1(image, tmp_path, png):
    written = image.save_aovs(tmp_path, png=png)
    assert sorted(p.name for p in written) == (["depth.npy", "depth.png"] if png else ["depth.npy"])
    np.testing.assert_array_equal(np.load(tmp_path / "depth.npy"), image.aovs["depth"])


def test_save_aovs_refuses_one_name_as_a_str(image, tmp_path):
    with pytest.raises(TypeError, match=r"names must be a list of AOV names, such as \['depth'\]"):
        image.save_aovs(tmp_path, names="depth")


@pytest.mark.parametrize("save", [lambda img, d: img.save_aovs(d, names=["Depth"]),
                                  lambda img, d: img.save_aov_png("Depth", d / "x.png")])
def test_an_unknown_aov_names_the_one_meant(image, tmp_path, save):
    with pytest.raises(ValueError, match=r"unknown AOV 'Depth' \(did you mean 'depth'\?\); available: depth"):
        save(image, tmp_path)


@pytest.fixture(scope="module")
def floor():
    return wrt.Scene.from_triangles([[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]], [[0, 2, 1], [0, 3, 2]])


@pytest.mark.parametrize("make", [rays.random_rays, rays.incoherent_rays,
                                  lambda scene, n, seed=0: rays.ray_set(scene, "incoherent", n, seed)])
@pytest.mark.parametrize("n, seed, name", [(-1, 0, "n"), (2.5, 0, "n"), (float("nan"), 0, "n"), (True, 0, "n"),
                                           (4, -1, "seed"), (4, 1.5, "seed"), (4, None, "seed")])
def test_ray_sets_name_a_bad_count_or_seed(floor, make, n, seed, name):
    with pytest.raises(ValueError, match=f"{name} must be a non-negative integer"):
        make(floor, n, seed)


def test_ray_sets_take_numpy_ints_and_a_large_seed(floor):
    a = rays.random_rays(floor, np.int64(6), seed=2**40)
    b = rays.random_rays(floor, 6, seed=np.uint64(2**40))
    assert a[0].shape == (6, 3)
    np.testing.assert_array_equal(a[0], b[0])


@pytest.mark.parametrize("kind", rays.RAY_KINDS)
def test_a_ray_set_of_no_rays_is_empty(floor, kind):
    # A shot of about 0 pixels was still 1x1: primary, shadow and diffuse sets of n=0 held one ray.
    for n in (0, np.int64(0)):
        origins, directions = rays.ray_set(floor, kind, n)
        for a in (origins, directions):
            assert a.shape == (0, 3) and a.dtype == np.float32
    assert len(rays.ray_set(floor, kind, 1)[0]) <= 1


@pytest.mark.parametrize("call, meant", [(lambda s: rays.ray_set(s, "Diffuse", 4), "diffuse"),
                                         (lambda s: rays.secondary_rays(s, "Shadow", *_hits(s)), "shadow")])
def test_a_mistyped_ray_kind_names_the_one_meant(floor, call, meant):
    with pytest.raises(ValueError, match=rf"ray kind '\w+' \(did you mean '{meant}'\?\)"):
        call(floor)


def _hits(scene):
    origins = np.array([[0.0, 3.0, 0.0]], np.float32)
    directions = np.array([[0.0, -1.0, 0.0]], np.float32)
    return origins, directions, wrt.trace(scene, origins, directions)


def test_secondary_rays_take_rays_as_trace_does_and_name_a_mismatch(floor):
    """Lists failed in numpy's words ('only integer scalar arrays can be converted'), rays of another count than the
    hits as 'boolean index did not match', and ``hits.t`` given for the hits as an AttributeError on 'prim'."""
    origins = np.array([[0.0, 3.0, 0.0], [1.0, 3.0, 1.0], [9.0, 3.0, 9.0]], np.float32)
    directions = np.array([[0.0, -1.0, 0.0], [0.0, -2.0, 0.0], [0.0, -1.0, 0.0]], np.float32)
    hits = wrt.trace(floor, origins, directions)
    for kind in ("shadow", "diffuse"):
        expected = rays.secondary_rays(floor, kind, origins, directions, hits, seed=3)
        # The floor (y = 0) is hit below the two first origins; the third misses.
        np.testing.assert_allclose(expected[0][:, [0, 2]], [[0.0, 0.0], [1.0, 1.0]])
        assert np.all(expected[0][:, 1] > 0.0) and np.all(expected[0][:, 1] < 1e-3)
        for given in ((origins.tolist(), directions.tolist()), (wp.array(origins, dtype=wp.vec3), directions)):
            got = rays.secondary_rays(floor, kind, *given, hits, seed=3)
            for a, b in zip(got, expected):
                np.testing.assert_array_equal(a, b)
    one = wrt.trace(floor, origins[0], directions)  # one origin for every direction, as trace takes it
    got = rays.secondary_rays(floor, "shadow", origins[0], directions, one)
    for a, b in zip(got, rays.secondary_rays(floor, "shadow", np.repeat(origins[:1], 3, axis=0), directions, one)):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match=r"secondary_rays: origins must be the \(N, 3\) rays the hits came from, "
                                         r"N = 3; got shape \(2, 3\)"):
        rays.secondary_rays(floor, "shadow", origins[:2], directions[:2], hits)
    with pytest.raises(TypeError, match="secondary_rays: hits must be the Hits of wrt.trace"):
        rays.secondary_rays(floor, "shadow", origins, directions, hits.t)


def test_diffuse_rays_name_a_bad_seed(floor):
    with pytest.raises(ValueError, match="seed must be a non-negative integer, got -1"):
        rays.secondary_rays(floor, "diffuse", *_hits(floor), seed=-1)


@pytest.mark.parametrize("side", [0, -2, 2.5, float("nan"), True])
def test_camera_rays_name_a_bad_image_side(floor, side):
    cam = wrt.Camera.look_at(eye=(0, 3, 8), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=60)
    with pytest.raises(ValueError, match="width must be a positive integer"):
        rays.camera_rays(floor, cam, width=side, height=4)


SHOT = """#usda 1.0
(
    renderSettingsPrimPath = "/Render/Settings"
)
def Sphere "Ball"
{
}
def Scope "Render"
{
    def RenderSettings "Settings"
    {
        uniform int2 resolution = (32, 16)
    }
    def RenderSettings "Other"
    {
        uniform int2 resolution = (12, 12)
    }
}
"""


@pytest.fixture(scope="module")
def shot(tmp_path_factory):
    path = tmp_path_factory.mktemp("shot") / "shot.usda"
    path.write_text(SHOT)
    return path


@pytest.mark.parametrize("settings", [3, b"/Render/Other", ["/Render/Other"]])
def test_load_usd_names_render_settings_that_are_no_path(shot, settings):
    with pytest.raises(TypeError, match="load_usd: render_settings: path must be a str"):
        wrt.load_usd(shot, render_settings=settings)


def test_load_usd_takes_render_settings_as_an_sdf_path(shot):
    from pxr import Sdf

    scene = wrt.load_usd(shot, render_settings=Sdf.Path("/Render/Other"))
    assert scene.render_settings.path == "/Render/Other" and scene.render_settings.resolution == (12, 12)


def test_load_usd_takes_a_numpy_bool_for_tessellate_gprims(shot):
    meshes, same = (wrt.load_usd(shot, tessellate_gprims=flag) for flag in (np.True_, True))
    assert len(meshes.shapes) == 0 and meshes.num_geometry_triangles == same.num_geometry_triangles > 0
    assert len(wrt.load_usd(shot, tessellate_gprims=np.False_).shapes) == 1  # the analytic sphere


def test_pending_frames_resume_is_a_flag(tmp_path):
    pattern = str(tmp_path / "f_#.npy")
    (tmp_path / "f_1.npy").write_bytes(b"x")  # frame 1 written by an earlier run
    with pytest.raises(TypeError, match="pending_frames: resume must be True or False"):
        animation.pending_frames([1.0, 2.0], pattern, "false")
    assert [f for f, _ in animation.pending_frames([1.0, 2.0], pattern, np.True_)] == [2.0]
    assert [f for f, _ in animation.pending_frames([1.0, 2.0], pattern, 0)] == [1.0, 2.0]


@pytest.mark.parametrize("jobs, error, match", [
    # Each failed in Python's words, naming no job: 'cannot unpack non-iterable int object', "too many values to
    # unpack (expected 2)", "'<' not supported between instances of 'str' and 'float'"; a .jpg after its render.
    ([1.0, 2.0], TypeError, r"render_frames: jobs\[0\] must be a \(frame, file\) pair, as pending_frames makes"),
    ({1.0: "f.npy"}, TypeError, r"jobs must be a list of \(frame, file\) pairs.*list\(jobs.items\(\)\)"),
    (["f.npy"], TypeError, r"jobs\[0\] must be a \(frame, file\) pair"),
    ([(1.0, "f.npy", 2)], TypeError, r"jobs\[0\] must be a \(frame, file\) pair"),
    ([(1.0, "f.npy"), ("2", "g.npy")], TypeError, r"jobs\[1\]: the frame must be a number \(a time code\), got str"),
    ([(1.0, "f.npy"), (2.0, "g.jpg")], ValueError, "cannot write g.jpg: supported image formats are"),
    ([(1.0, 5)], TypeError, "image path must be a str or os.PathLike, got int 5"),
    # Frame 1.0 was rendered and written, then the load of NaN or inf stopped the run naming no job.
    ([(1.0, "f.npy"), (float("nan"), "g.npy")], ValueError, r"jobs\[1\]: the frame must be a finite number.*nan"),
    ([(1.0, "f.npy"), (np.float32(-np.inf), "g.npy")], ValueError, r"jobs\[1\]: the frame must be a finite number"),
    ([(10**400, "f.npy")], ValueError, r"jobs\[0\]: the frame must be a finite number"),
    # Frame 2 replaced frame 1 in f.npy without a word.
    ([(1.0, "f.npy"), (2.0, "./f.npy")], ValueError, r"jobs\[1\] \(frame 2.0\) writes f.npy, as jobs\[0\]"),
])
def test_render_frames_checks_its_jobs_before_a_frame(shot, tmp_path, monkeypatch, jobs, error, match):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(error, match=match):
        animation.render_frames(shot, jobs)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("run, option, match", [
    # Each failed at the first frame's render, after its load: "Renderer.__init__() got an unexpected keyword argument
    # 'widht'" naming neither the call nor the option meant, and device= as "got multiple values for keyword argument".
    ("serial", dict(widht=4), r"render_frames has no option 'widht' \(did you mean 'width'\?\); options: devices,"),
    ("serial", dict(device="cpu"), r"render_frames has no option 'device' \(did you mean 'devices'\?\)"),
    ("dask", dict(devices=["cpu"]), r"render_frames_on_dask has no option 'devices'"),
    ("frames", dict(tesselate_gprims=True), r"FrameRenderer has no option 'tesselate_gprims' \(did you mean "
                                            r"'tessellate_gprims'\?\)"),
])
def test_frame_renderers_name_an_unknown_option_before_a_frame(shot, tmp_path, monkeypatch, run, option, match):
    def no_load(*args, **kwargs):
        raise AssertionError("a frame was loaded before the options were checked")

    monkeypatch.setattr(animation, "warn_frames_outside_range", no_load)
    calls = {"serial": lambda: animation.render_frames(shot, [(1.0, tmp_path / "f.npy")], **option),
             "dask": lambda: animation.render_frames_on_dask(shot, [(1.0, tmp_path / "f.npy")], **option),
             "frames": lambda: animation.FrameRenderer(shot, **option)}
    with pytest.raises(TypeError, match=match):
        calls[run]()
    assert not list(tmp_path.iterdir())


def test_render_frames_takes_jobs_from_a_generator(shot, tmp_path):
    """A generator of jobs failed in ``len()`` ('object of type 'generator' has no len()')."""
    rows = animation.render_frames(shot, ((f, tmp_path / f"f{f:g}.npy") for f in (1.0, 2.0)), width=4, height=3)
    assert sorted(row["frame"] for row in rows) == [1.0, 2.0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f1.npy", "f2.npy"]


@pytest.mark.parametrize("option, error, match", [
    (dict(progress="false"), TypeError, "render_frames: progress must be True or False"),
    (dict(devices="cpu"), ValueError, r"devices must be a non-empty list of Warp devices, such as \['cpu'\]"),
    (dict(devices=()), ValueError, "devices must be a non-empty list"),
])
def test_render_frames_checks_its_options_before_a_frame(shot, tmp_path, option, error, match):
    with pytest.raises(error, match=match):
        animation.render_frames(shot, [(1.0, tmp_path / "f.npy")], **option)
    assert not (tmp_path / "f.npy").exists()


@pytest.mark.parametrize("option, error, match", [
    (dict(progress="false"), TypeError, "progress must be True or False"),
    (dict(n_workers=0), ValueError, "n_workers must be a positive integer or None, got 0"),
    (dict(n_workers=-1), ValueError, "n_workers must be a positive integer or None"),
    (dict(n_workers=1.5), ValueError, "n_workers must be a positive integer or None"),
    (dict(address=8786), TypeError, "address must be a scheduler address str"),
])
def test_run_tasks_checks_its_options_before_starting_a_cluster(monkeypatch, option, error, match):
    def no_cluster(*args):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(distributed, "connect", no_cluster)
    with pytest.raises(error, match=match):
        distributed.run_tasks(abs, [1], **option)


@pytest.mark.parametrize("option", [dict(resume="false"), dict(progress="no"), dict(resume=None), dict(dask=2),
                                    dict(dask=[])])
def test_run_grid_flags_are_bools(tmp_path, option):
    from wrt.bench import Grid, run_grid

    with pytest.raises(TypeError, match="run_grid: (resume|progress|dask) must be"):
        run_grid(Grid(scenes=["sphere:20"], accels=["wrt:sah"], rays=["primary"], n_rays=10), tmp_path / "out",
                 **option)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["bvh_leaves", "image", "show_text", "show_lights", "off_screen"])
@pytest.mark.parametrize("value", ["false", 2])
def test_preview_flags_are_bools(floor, name, value):
    with pytest.raises(TypeError, match=f"{name} must be True or False"):
        wrt.preview(floor, **{name: value})


def test_preview_names_the_bvh_colouring_meant(floor):
    with pytest.raises(ValueError, match=r"unknown BVH colouring 'SAH' \(did you mean 'sah'\?\)"):
        wrt.preview(floor, bvh_color="SAH")
    with pytest.raises(ValueError, match="give bvh_depth or bvh_leaves, not both"):
        wrt.preview(floor, bvh_depth=1, bvh_leaves=np.True_)  # a numpy bool means what it says


@pytest.mark.parametrize("projection, meant", [("Orthographic", "orthographic"), ("ortho", "orthographic"),
                                               ("persp", "perspective")])
def test_a_mistyped_camera_projection_names_the_one_meant(projection, meant):
    with pytest.raises(ValueError, match=rf"not projection='{projection}' \(did you mean '{meant}'\?\)"):
        wrt.Camera.look_at((0, 3, 8), (0, 0, 0), projection=projection)


@pytest.mark.parametrize("field, meant", [(dict(channel="RGB"), "rgb"), (dict(channel="RGBA"), "rgba"),
                                          (dict(wrap=("Repeat", "clamp")), "repeat"),
                                          (dict(wrap=("repeat", "mirrored")), "mirror")])
def test_a_mistyped_texture_channel_or_wrap_names_the_one_meant(field, meant):
    texture = wrt.TextureInput(image=0, **field)
    with pytest.raises(ValueError, match=rf"\(did you mean '{meant}'\?\)"):
        wrt.Material(path="/M", textures={"diffuseColor": texture})


def test_a_camera_is_named_by_str_or_sdf_path_and_a_typo_names_the_one_meant(shot):
    from pxr import Sdf, Usd, UsdGeom

    stage = Usd.Stage.Open(str(shot))
    UsdGeom.Camera.Define(stage, "/World/Cam").AddTranslateOp().Set((0, 0, 10))
    stage.GetRootLayer().Export(str(shot.with_name("cam.usda")))
    scene = wrt.load_usd(shot.with_name("cam.usda"))
    camera = wrt.Renderer(scene, camera=Sdf.Path("/World/Cam")).camera
    assert camera.path == "/World/Cam" and camera.to_world[2, 3] == 10.0  # the stage's camera, as UsdGeom placed it
    with pytest.raises(wrt.SceneError, match=r"no camera at '/World/cam' \(did you mean '/World/Cam'\?\)"):
        wrt.Renderer(scene, camera="/World/cam")


@pytest.mark.parametrize("option, meant", [("max_leaf_size", "leaf_size"), ("pre_split", "presplit"),
                                           ("bin", "bins")])
def test_build_bvh_names_an_unknown_option_and_the_one_meant(floor, option, meant):
    with pytest.raises(TypeError, match=rf"build_bvh has no option '{option}' \(did you mean '{meant}'\?\)"):
        wrt.build_bvh(*floor.triangles(), "sah", **{option: 4})


@pytest.mark.parametrize("argument, value, error", [
    ("time", "1", TypeError), ("time", float("nan"), ValueError), ("render_settings", 3, TypeError),
    ("variants", ["/World"], TypeError), ("variants", {"/World": "red"}, TypeError),
    ("tessellate_gprims", 2, ValueError), ("tessellate_gprims", "yes", ValueError), ("refine_level", 9, ValueError),
])
def test_load_usd_documents_the_error_each_bad_argument_raises(argument, value, error):
    """``load_usd``'s docstring named only ``time`` under TypeError and ValueError, while a ``render_settings`` that
    is no prim path and ``variants`` of the wrong shape raise TypeError, and an out-of-range ``tessellate_gprims`` or
    ``refine_level`` ValueError."""
    from wrt.cli import default_scene_path

    with pytest.raises(error, match=argument):
        wrt.load_usd(default_scene_path(), **{argument: value})
    raises = wrt.load_usd.__doc__.split("Raises:", 1)[1].split("Warns:", 1)[0]
    (entry,) = [part for part in re.split(r"\n\s+(?=\w+(?:\.\w+)*: )", raises) if part.strip().startswith(
        f"{error.__name__}:")]
    assert f"``{argument}``" in entry
