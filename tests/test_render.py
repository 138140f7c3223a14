"""render(): image layout, AOVs, shading, determinism and agreement between accelerators."""

import dataclasses
import os
import warnings

import numpy as np
import pytest
import warp as wp
from conftest import warp_assets
from pxr import Usd

import wrt
from wrt.cli import default_scene_path
from wrt.lights import DomeLight
from wrt.materials import TextureInput
from wrt.rays import camera_rays
from wrt.shade import BACKGROUND


@pytest.fixture(scope="module")
def room():
    return wrt.load_usd(default_scene_path())


def test_image_and_aov_layout(room):
    img = wrt.render(room, width=96, height=64, device="cpu")
    assert img.rgb.shape == (64, 96, 3) and img.rgb.dtype == np.float32
    assert img.aovs["depth"].shape == (64, 96) and img.aovs["depth"].dtype == np.float32
    assert img.aovs["normal"].shape == (64, 96, 3) and img.aovs["normal"].dtype == np.float32
    assert img.aovs["prim"].shape == (64, 96) and img.aovs["prim"].dtype == np.int32
    hit = img.aovs["prim"] >= 0
    assert 0.5 < hit.mean() < 1.0  # the room fills most of the view, the sky shows above
    np.testing.assert_allclose(np.linalg.norm(img.aovs["normal"][hit], axis=-1), 1.0, atol=1e-5)
    assert np.isinf(img.aovs["depth"][~hit]).all() and np.isfinite(img.aovs["depth"][hit]).all()


def test_aovs_match_trace_of_the_same_camera_rays(room):
    img = wrt.render(room, width=80, height=60, device="cpu")
    origins, directions = camera_rays(room, width=80, height=60)
    hits = wrt.trace(room, origins, directions)
    np.testing.assert_array_equal(img.aovs["prim"].ravel(), hits.prim)
    hit = hits.hit
    np.testing.assert_allclose(img.aovs["depth"].ravel()[hit], hits.t[hit], rtol=1e-6)


def test_normals_face_the_camera(room):
    img = wrt.render(room, width=64, height=48, device="cpu")
    _, directions = camera_rays(room, width=64, height=48)
    normals = img.aovs["normal"].reshape(-1, 3)
    hit = img.aovs["prim"].ravel() >= 0
    assert np.all(np.einsum("ij,ij->i", normals[hit], directions[hit]) <= 1e-6)


def test_wrt_and_warp_accelerators_render_the_same_image(room):
    a = wrt.render(room, width=120, height=90, device="cpu", accel="wrt")
    b = wrt.render(room, width=120, height=90, device="cpu", accel="warp")
    same_prim = a.aovs["prim"] == b.aovs["prim"]
    assert same_prim.mean() > 0.999
    close = np.all(np.abs(a.rgb - b.rgb) < 1e-4, axis=-1)
    assert close.mean() > 0.995  # pixels can differ only where shadow rays graze an edge


def test_renders_are_deterministic(room):
    a = wrt.render(room, width=48, height=32, spp=3, seed=5, device="cpu")
    b = wrt.render(room, width=48, height=32, spp=3, seed=5, device="cpu")
    c = wrt.render(room, width=48, height=32, spp=3, seed=6, device="cpu")
    np.testing.assert_array_equal(a.rgb, b.rgb)
    assert not np.array_equal(a.rgb, c.rgb)  # the jitter depends on the seed


def test_shadows_darken_the_floor_under_an_occluder():
    floor = [[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]]
    blocker = [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]]
    scene = wrt.Scene.from_triangles(floor + blocker, [[0, 2, 1], [0, 3, 2], [4, 6, 5], [4, 7, 6]])
    scene.lights.append(wrt.DistantLight(direction=np.array([0.0, -1.0, 0.0]), color=np.full(3, np.pi)))
    cam = wrt.Camera.look_at(eye=(0, 3, 8), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=60)
    img = wrt.render(scene, camera=cam, width=100, height=80, device="cpu")
    prims = img.aovs["prim"]
    floor_px = (prims == 0) | (prims == 1)
    luminance = img.rgb.mean(axis=-1)
    # Lit floor: albedo 0.5 * E/pi * cos 0 = 0.5; shadowed: 0 (the stage has a light, so no default dome).
    values = luminance[floor_px]
    shadowed, lit = np.isclose(values, 0.0, atol=1e-5), np.isclose(values, 0.5, atol=1e-5)
    assert np.all(shadowed | lit)
    assert shadowed.sum() > 50 and lit.sum() > 500


def test_smooth_normals_are_interpolated():
    points = [[-1, -1, 0], [1, -1, 0], [0, 1, 0]]
    corner_normals = np.array([[[-0.6, 0, 0.8], [0.6, 0, 0.8], [0, 0, 1]]], np.float32)
    mesh = wrt.Mesh("/tri", points, [[0, 1, 2]], [0], normals=corner_normals)
    scene = wrt.Scene(meshes=[mesh])
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)
    img = wrt.render(scene, camera=cam, width=64, height=64, device="cpu")
    normals = img.aovs["normal"]
    left, right = normals[40, 20], normals[40, 43]
    assert left[0] < -0.1 and right[0] > 0.1  # the normal turns across the flat triangle
    np.testing.assert_allclose(np.linalg.norm(normals[img.aovs["prim"] >= 0], axis=-1), 1.0, atol=1e-5)


def test_empty_stage_renders_background_with_a_warning(tmp_path):
    path = tmp_path / "empty.usda"
    Usd.Stage.CreateNew(str(path)).Save()
    scene = wrt.load_usd(path)
    with pytest.warns(UserWarning, match="nothing to render"):
        img = wrt.render(scene, width=16, height=8, device="cpu")
    np.testing.assert_allclose(img.rgb, np.broadcast_to(np.array(BACKGROUND, np.float32), (8, 16, 3)))
    assert (img.aovs["prim"] == -1).all()


def test_a_stage_whose_triangles_all_have_zero_area_is_warned_of_as_nothing_to_render(tmp_path):
    """Triangles with collinear or repeated corners cannot be hit: the image was background without a word, while
    wrt bench refused the same scene. The warning names the file and the triangle count (from USD's face counts)."""
    from pxr import UsdGeom

    path = tmp_path / "flat.usda"
    stage = Usd.Stage.CreateNew(str(path))
    line = UsdGeom.Mesh.Define(stage, "/Line")  # a quad whose corners lie on one line
    line.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)])
    line.CreateFaceVertexCountsAttr([4])
    line.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    dot = UsdGeom.Mesh.Define(stage, "/Dot")  # two triangles whose corners repeat
    dot.CreatePointsAttr([(0, 1, 0), (0, 1, 0), (1, 1, 1)])
    dot.CreateFaceVertexCountsAttr([3, 3])
    dot.CreateFaceVertexIndicesAttr([0, 1, 2, 2, 2, 0])
    stage.Save()
    triangles = sum(n - 2 for prim in stage.Traverse() for n in UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get())
    scene = wrt.load_usd(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        img = wrt.render(scene, width=16, height=8, device="cpu")
    said = [str(w.message) for w in caught if "nothing to render" in str(w.message)]
    assert len(said) == 1, [str(w.message) for w in caught]
    assert "flat.usda" in said[0] and f"{triangles} triangles all have zero area" in said[0], said
    assert (img.aovs["prim"] == -1).all()


def test_stage_without_camera_is_framed(tmp_path):
    scene = wrt.load_usd(warp_assets("bunny.usd"))
    assert not scene.cameras
    img = wrt.render(scene, width=64, height=48, device="cpu")
    hit = img.aovs["prim"] >= 0
    assert 0.05 < hit.mean() < 0.9
    rows, cols = np.nonzero(hit)
    assert rows.min() > 0 and rows.max() < 47 and cols.min() > 0 and cols.max() < 63  # fully in view


def test_camera_by_path_and_bad_camera(tmp_path):
    scene = wrt.load_usd(default_scene_path())
    img = wrt.render(scene, camera="/World/Camera", width=32, height=24, device="cpu")
    assert (img.aovs["prim"] >= 0).any()
    with pytest.raises(ValueError, match="/World/Camera"):
        wrt.render(scene, camera="/World/Nope", width=32, height=24, device="cpu")
    # Errors name the file and the prim: the message named the prim only (a batch added the file, one scene did not).
    with pytest.raises(wrt.SceneError) as error:
        wrt.render(scene, camera="/World/Nope", width=32, height=24, device="cpu")
    assert (error.value.path, error.value.prim) == (str(default_scene_path()), "/World/Nope")
    assert str(error.value).startswith(f"{default_scene_path()}: ") and "no camera at '/World/Nope'" in str(error.value)


def test_a_camera_path_naming_a_prim_of_another_type_says_its_type(tmp_path):
    """wrt.render(camera='/World/Box'), a Cube, said 'no camera at' as for a path where nothing is; it names the
    prim's type as USD gives it, and a Camera the scene does not hold (here: inactive) is said to be one."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "s.usda"))
    UsdGeom.Cube.Define(stage, "/World/Box")
    UsdGeom.Camera.Define(stage, "/World/Cam").AddTranslateOp().Set((0.0, 0.0, 10.0))
    UsdGeom.Camera.Define(stage, "/World/Off").GetPrim().SetActive(False)
    stage.GetRootLayer().Save()
    scene = wrt.load_usd(tmp_path / "s.usda")
    with pytest.raises(wrt.SceneError) as error:
        wrt.render(scene, camera="/World/Box", width=8, height=6, device="cpu")
    kind = stage.GetPrimAtPath("/World/Box").GetTypeName()
    assert f"'/World/Box' is a {kind}, not a camera; cameras in the scene: /World/Cam" in str(error.value)
    assert error.value.prim == "/World/Box"
    with pytest.raises(wrt.SceneError, match="the Camera at '/World/Off' is not among the scene's cameras"):
        wrt.render(scene, camera="/World/Off", width=8, height=6, device="cpu")


@pytest.mark.parametrize("clipping, outside", [
    ((1e30, 1e31), True), ((11.0, 100.0), True), ((0.01, 4.0), True),  # beyond the scene, or the scene beyond far
    ((7.0, 100.0), False), ((0.01, 6.0), False), ((0.01, 1e6), False),  # partly or wholly inside: no word
])
def test_a_clipping_range_that_holds_no_part_of_the_scene_is_warned_of(clipping, outside):
    """A camera clipping range of (1e30, 1e31) rendered background without a word. Two quads face the camera 5 and
    10 units ahead (the scene's extent along the view, by construction): a range holding none of 5 to 10 is warned
    of, naming the camera, its range and that extent; a scene partly inside it never is."""
    import warnings

    from shading_helpers import quad

    scene = wrt.Scene(meshes=[quad((0, 0, 0), (1, 0, 0), (0, 1, 0), name="/a"),
                              quad((0.5, 0, -5), (3, 0, 0), (0, 3, 0), name="/b")])
    cam = wrt.Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), fov_y_deg=40, clipping_range=clipping, path="/Cam")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = wrt.render(scene, camera=cam, width=8, height=6, device="cpu", integrator="depth")
    said = [str(w.message) for w in caught if "sees nothing" in str(w.message)]
    assert (image.aovs["prim"] >= 0).any() != outside  # the oracle of 'nothing seen': the render itself
    if outside:
        assert said == [f"scene: camera /Cam sees nothing: its clipping range ({clipping[0]:g}, {clipping[1]:g}) "
                        "holds no part of the scene, which lies from 5 to 10 along its view; the image is background "
                        "only"], said
    else:
        assert said == []


def _sees_nothing(run) -> list[str]:
    """The 'sees nothing' warnings that ``run()`` gives, each as often as it is shown."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run()
    return [str(w.message) for w in caught if "sees nothing" in str(w.message)]


def test_a_camera_that_sees_nothing_is_warned_of_once_by_every_way_of_rendering(tmp_path):
    """Only a new Renderer warned of a camera whose clipping range holds none of the scene: one given by
    set_cameras, or edited since, drew background without a word; render_batch of one camera twice and every frame
    of a frame run (a Renderer each) said it again. Each way now says it once; the oracle of 'nothing seen' is the
    render itself."""
    import dataclasses

    from shading_helpers import quad

    from wrt.animation import pending_frames, render_frames

    scene = wrt.Scene(meshes=[quad((0, 0, 0), (1, 0, 0), (0, 1, 0), name="/a")])
    seeing = wrt.Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), fov_y_deg=40, path="/Cam")
    blind = wrt.Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), fov_y_deg=40, clipping_range=(100.0, 200.0),
                               path="/Blind")
    renderer = wrt.Renderer(scene, camera=seeing, width=8, height=6, device="cpu")
    assert _sees_nothing(renderer.render) == []
    said = _sees_nothing(lambda: [renderer.set_cameras([blind]), renderer.set_cameras([blind]), renderer.render()])
    assert len(said) == 1 and said[0].startswith("scene: camera /Blind sees nothing: its clipping range (100, 200)")
    assert (renderer.render().image(0).aovs["prim"] == -1).all()
    kept = wrt.Renderer(scene, camera=seeing, width=8, height=6, device="cpu")
    seeing.clipping_range = (100.0, 200.0)  # edited after the Renderer took it
    assert len(_sees_nothing(lambda: [kept.render(), kept.render()])) == 1
    assert len(_sees_nothing(lambda: wrt.render_batch(scene, [blind, blind], 8, 6, device="cpu"))) == 1
    near_only = wrt.Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), clipping_range=(0.01, 50.0))
    moved = wrt.Renderer(scene, camera=near_only, width=8, height=6, device="cpu")
    mesh = scene.meshes[0]
    scene.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([0.0, 0.0, -500.0]))  # past far
    said = _sees_nothing(moved.render)
    assert len(said) == 1 and "lies from 505 to 505" in said[0], said
    path = tmp_path / "blind.usda"
    path.write_text('#usda 1.0\ndef Cube "Box"\n{\n    double size = 1\n}\ndef Camera "Cam"\n{\n'
                    '    float2 clippingRange = (1000, 2000)\n    double3 xformOp:translate = (0, 0, 5)\n'
                    '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n')
    jobs = pending_frames([1.0, 2.0], tmp_path / "f_#.npy", resume=False)
    said = _sees_nothing(lambda: render_frames(path, jobs, width=8, height=6))
    assert len(said) == 1 and "camera /Cam sees nothing: its clipping range (1000, 2000)" in said[0]
    frame = np.load(tmp_path / "f_2.npy")
    assert (frame == frame[0, 0]).all()  # background only: one colour


def test_a_framed_camera_that_follows_a_moved_scene_is_not_warned_of(tmp_path):
    """A Renderer without a camera frames the scene; after an edit that moves the scene, render() frames it again
    and draws it, yet the rebuild warned with the old framing camera that it 'sees nothing'. The oracle of 'seen' is
    the render itself: the moved quad's pixels hit it."""
    import dataclasses

    from shading_helpers import quad

    scene = wrt.Scene(meshes=[quad((0, 0, 0), (1, 0, 0), (0, 1, 0), name="/a")])
    renderer = wrt.Renderer(scene, width=8, height=6, device="cpu")
    renderer.render()
    mesh = scene.meshes[0]
    scene.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([0.0, 0.0, 500.0]))
    images = []
    assert _sees_nothing(lambda: images.append(renderer.render())) == []
    assert (images[0].aovs["prim"] >= 0).any()


def test_camera_lists_and_scene_type_get_errors_that_say_what_is_wrong(room):
    """A path given where a list of cameras belongs was read one character at a time ("no camera at '/'"); one
    argument alone was told "not both"; a path as the scene failed with an AttributeError from deep inside."""
    renderer = wrt.Renderer(room, width=4, height=4, device="cpu")
    for cameras, message in (("/World/Camera", "cameras must be a list of cameras"), ([], "cameras is empty")):
        with pytest.raises(ValueError, match=message):
            renderer.set_cameras(cameras)
        with pytest.raises(ValueError, match=message):
            wrt.Renderer(room, width=4, height=4, device="cpu", cameras=cameras)
    with pytest.raises(ValueError, match="either camera or cameras, not both"):
        wrt.Renderer(room, width=4, height=4, device="cpu", camera="/World/Camera", cameras=["/World/Camera"])
    for scene in (None, "scene.usda"):
        with pytest.raises(TypeError, match="scene must be a wrt.Scene"):
            wrt.render(scene, width=4, height=4)
        with pytest.raises(TypeError, match="scene must be a wrt.Scene"):
            wrt.trace(scene, [[0, 0, 5]], [[0, 0, -1]])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"width": 0}, "width"),
        ({"height": -3}, "height"),
        ({"spp": 0}, "spp"),
        ({"width": True}, "width must be a positive integer"),  # a bool is an int to Python, not a size
        ({"spp": True}, "spp must be a positive integer"),
        ({"builder": "bogus"}, "valid builders"),
        ({"accel": "optix"}, "valid accelerators"),
        ({"device": "cuda:9"}, "available devices"),
        ({"width": 100_000, "height": 100_000}, "pixels"),
        # Seeds are 31-bit: 0.5 was truncated to seed 0 and 2^31 or -2^31 wrapped onto seed 0, silently.
        ({"seed": 0.5}, "seed must be an integer from 0 to 2147483647"),
        ({"seed": 2**31}, "seed must be an integer from 0 to 2147483647"),
        ({"seed": -2**31}, "seed must be an integer from 0 to 2147483647"),
        ({"seed": True}, "seed must be an integer"),
    ],
)
def test_bad_render_options_raise_value_error(kwargs, message):
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    options = {"width": 8, "height": 8, "device": "cpu", **kwargs}
    with pytest.raises(ValueError, match=message):
        wrt.render(scene, **options)


@pytest.mark.parametrize(
    "kwargs, suggestion",
    [
        ({"integrator": "pth"}, "unknown integrator 'pth' (did you mean 'path'?); valid integrators: whitted"),
        ({"integrator": "Whitted"}, "(did you mean 'whitted'?)"),
        ({"accel": "Warp"}, "unknown accelerator 'Warp' (did you mean 'warp'?); valid accelerators: wrt, warp"),
        ({"builder": "lbhv"}, "unknown BVH builder 'lbhv' (did you mean 'lbvh'?); valid builders: sah"),
        ({"accel": "warp", "builder": "cubq"}, "wp.Mesh has no builder 'cubq' (did you mean 'cubql'?)"),
    ],
)
def test_a_mistyped_option_name_suggests_the_valid_one(kwargs, suggestion):
    """Only the list of valid names was given; a typo now names the one it was probably meant to be."""
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError) as info:
        wrt.render(scene, width=8, height=8, device="cpu", **kwargs)
    assert suggestion in str(info.value)
    with pytest.raises(ValueError, match=r"unknown BVH layout 'wide_8' \(did you mean 'wide8'\?\)"):
        wrt.trace(scene, [0, 0, 1], [0, 0, -1], layout="wide_8")
    with pytest.raises(ValueError, match=r"unknown integrator 'octree'; valid"):  # nothing close: no guess
        wrt.render(scene, width=8, height=8, device="cpu", integrator="octree")


@pytest.mark.parametrize("function", [wrt.render, wrt.trace, wrt.Renderer.render])
def test_help_describes_every_argument(function):
    """``help(wrt.render)`` said only "See Renderer for the arguments", where spp, seed, batch and progress were not
    either; every parameter is now in the function's own Args section."""
    import inspect

    doc = inspect.getdoc(function)
    args = doc[doc.index("Args:"):]
    missing = [name for name in inspect.signature(function).parameters
               if name != "self" and f"\n    {name}: " not in args]
    assert not missing


def test_png_is_8bit_srgb(tmp_path, room):
    from PIL import Image as PilImage

    img = wrt.render(room, width=40, height=30, device="cpu")
    path = img.save(tmp_path / "x.png")
    with PilImage.open(path) as png:
        assert png.size == (40, 30) and png.mode == "RGB"
        data = np.asarray(png)
    expected = np.where(img.rgb <= 0.0031308, 12.92 * img.rgb, 1.055 * np.clip(img.rgb, 0, 1) ** (1 / 2.4) - 0.055)
    np.testing.assert_allclose(data / 255.0, np.clip(expected, 0, 1), atol=0.5 / 255 + 1e-6)
    with pytest.raises(ValueError, match="supported image formats"):
        img.save(tmp_path / "x.tiff")


def srgb8_float64(linear: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 in float64 on values clipped to [0, 1], rounded to 8 bits: the oracle of PNG pixels."""
    x = np.clip(np.asarray(linear, np.float64), 0.0, 1.0)
    return np.round(255.0 * np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055))


def test_png_is_tagged_srgb_and_decodes_to_the_srgb_pixels(tmp_path):
    """The PNG held sRGB-encoded pixels with no sRGB chunk, so a viewer that colour-manages untagged files could
    read them as another space. It carries sRGB (perceptual), gAMA and cHRM as the PNG specification recommends,
    with right CRCs, and its image data, decoded without Pillow, holds the float64 sRGB of the linear values. The
    AOV previews and the notebook's PNG are tagged too."""
    from png_chunks import decode_pixels, read_chunks, srgb_chunks_problems

    rng = np.random.default_rng(123)
    rgb = rng.uniform(-0.1, 1.1, (5, 7, 3)).astype(np.float32)
    rgb[0, :3] = [[0.0, 0.002, 0.0031308], [0.004, 0.5, 1.0], [0.01, 0.2, 0.9]]  # both sides of the linear toe
    img = wrt.Image(rgb=rgb, aovs={"albedo": rgb, "prim": np.arange(35, dtype=np.int32).reshape(5, 7)})
    chunks = read_chunks(img.save(tmp_path / "x.png"))
    assert srgb_chunks_problems(chunks) == []
    np.testing.assert_array_equal(decode_pixels(chunks), srgb8_float64(rgb))
    assert srgb_chunks_problems(read_chunks(img._repr_png_())) == []
    for name in img.aovs:
        assert srgb_chunks_problems(read_chunks(img.save_aov_png(name, tmp_path / f"{name}.png"))) == []


def test_an_image_shows_itself_in_a_notebook_as_its_png(tmp_path, room):
    """Jupyter showed ``Image(rgb=array([[[...`` and every AOV array; it shows the sRGB picture now."""
    import io

    from PIL import Image as PilImage

    img = wrt.render(room, width=40, height=30, device="cpu")
    with PilImage.open(io.BytesIO(img._repr_png_())) as png:
        shown = np.asarray(png)
    with PilImage.open(img.save(tmp_path / "x.png")) as png:
        np.testing.assert_array_equal(shown, np.asarray(png))
    assert repr(img) == "Image(40x30, aovs: " + ", ".join(img.aovs) + ")"


def test_a_renderer_prints_what_it_draws(room):
    """A cell ending in a Renderer showed '<wrt.render.Renderer object at 0x...>'; it names the scene, the size, the
    camera (or how many), the integrator and the device, as the stage and the arguments give them."""
    renderer = wrt.Renderer(room, width=40, height=30, integrator="normals", device="cpu")
    camera = next(iter(room.cameras))  # the stage's first camera: the default scene has no render settings
    assert repr(renderer) == (f"Renderer({room.source!r}, 40x30, camera {camera}, integrator='normals', "
                              "device='cpu')")
    renderer.set_cameras([wrt.Camera.look_at((0, 1, 5), (0, 0, 0))] * 2)
    assert repr(renderer) == f"Renderer({room.source!r}, 40x30, 2 cameras, integrator='normals', device='cpu')"


def test_images_compare_by_their_arrays_identity_as_batch_images_do():
    """Image's dataclass == compared its arrays with numpy's ==, whose answer has no truth value: comparing an image
    with another of equal arrays, and ``image in images``, raised ValueError. Images are equal where they hold the
    very same arrays and settings, as BatchImage's wp.arrays compare (identity), and never raise."""
    z = np.zeros((2, 3, 3), np.float32)
    depth = np.ones((2, 3), np.float32)
    image = wrt.Image(rgb=z, aovs={"depth": depth})
    assert image == wrt.Image(rgb=z, aovs={"depth": depth})
    assert wrt.Image(rgb=z, aovs={}) != wrt.Image(rgb=z.copy(), aovs={})
    assert image != wrt.Image(rgb=z, aovs={"depth": depth.copy()})
    assert image != wrt.Image(rgb=z, aovs={})
    assert image != wrt.Image(rgb=z, aovs={"depth": depth}, data=True)
    assert image != wrt.Image(rgb=z, aovs={"depth": depth}, window=(4, 4, 1, 1))
    others = [wrt.Image(rgb=z.copy(), aovs={"depth": depth.copy()}), image]
    assert image in others and others.index(image) == 1
    assert image != "image"
    batch = wrt.BatchImage(rgb=wp.zeros((1, 2, 3), dtype=wp.vec3, device="cpu"), aovs={}, scene=wrt.Scene())
    assert batch != wrt.BatchImage(rgb=wp.zeros((1, 2, 3), dtype=wp.vec3, device="cpu"), aovs={}, scene=batch.scene)


def test_npy_is_written_at_the_path_given_whatever_the_case_of_its_suffix(tmp_path, room):
    """np.save(path) appended ".npy" to "x.NPY", so the path returned (and the one --resume looks for) did not
    exist."""
    img = wrt.render(room, width=8, height=6, device="cpu")
    for name in ("x.npy", "y.NPY"):
        path = img.save(tmp_path / name)
        assert path == tmp_path / name
        np.testing.assert_array_equal(np.load(path), img.rgb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.npy", "y.NPY"]


def test_save_onto_a_directory_names_the_directory(tmp_path):
    """The error named the temporary file written beside the target (``.d.png.<pid>.partial.png``)."""
    (tmp_path / "d.png").mkdir()
    with pytest.raises(IsADirectoryError, match=r"d\.png: it is a directory"):
        wrt.Image(rgb=np.zeros((2, 2, 3), np.float32)).save(tmp_path / "d.png")
    assert [p.name for p in tmp_path.iterdir()] == ["d.png"]


@pytest.mark.parametrize("path, error, message", [
    ("shots", IsADirectoryError, r"shots: it is a directory"),  # was 'supported image formats are .png, ...'
    ("", ValueError, r"image path '' is empty"),  # was 'cannot write : supported image formats are ...'
    (5, TypeError, r"image path must be a str or os.PathLike, got int 5"),  # was pathlib's, naming no argument
    ("notes.txt/x.png", NotADirectoryError, r"x\.png: .*notes\.txt is a file, not a directory"),  # '[Errno 17]'
    ("notes.txt/a/x.exr", NotADirectoryError, r"x\.exr: .*notes\.txt is a file, not a directory"),
])
def test_save_to_a_path_that_cannot_be_an_image_names_what_is_wrong(tmp_path, monkeypatch, path, error, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "shots").mkdir()
    (tmp_path / "notes.txt").write_text("a file")
    with pytest.raises(error, match=message):
        wrt.Image(rgb=np.zeros((2, 2, 3), np.float32)).save(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "shots"]
    assert not any((tmp_path / "shots").iterdir())


def test_an_aov_png_onto_a_folder_names_the_folder_not_the_temporary_file(tmp_path):
    """The rename of the written file failed: '[Errno 21] Is a directory: '.d.png.<pid>.0.partial.png' -> 'd.png''."""
    (tmp_path / "d.png").mkdir()
    image = wrt.Image(rgb=np.zeros((2, 2, 3), np.float32), aovs={"depth": np.ones((2, 2), np.float32)})
    with pytest.raises(IsADirectoryError, match=r"^cannot write .*d\.png: it is a directory$"):
        image.save_aov_png("depth", tmp_path / "d.png")
    assert [p.name for p in tmp_path.iterdir()] == ["d.png"]


@pytest.mark.parametrize("name", ["d.exr", "d.npy", "d.jpg", "depth"])
def test_save_aov_png_under_another_extension_is_refused(tmp_path, name):
    """save_aov_png("depth", "d.exr") wrote PNG bytes into d.exr (an EXR reader then failed on it, or a .jpg viewer
    guessed), without a word. It names the file and says the preview is a PNG; nothing is written."""
    image = wrt.Image(rgb=np.zeros((2, 2, 3), np.float32), aovs={"depth": np.ones((2, 2), np.float32)})
    with pytest.raises(ValueError, match=rf"^save_aov_png: cannot write {name}: .*\.png"):
        image.save_aov_png("depth", tmp_path / name)
    assert not list(tmp_path.iterdir())
    written = image.save_aov_png("depth", tmp_path / "d.PNG")  # any case of .png, as save takes it
    assert written.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_save_aovs_into_an_empty_directory_name_is_refused(tmp_path, monkeypatch):
    """save_aovs('') wrote the AOVs into the current folder (Path('') is '.'), without a word."""
    monkeypatch.chdir(tmp_path)
    image = wrt.Image(rgb=np.zeros((2, 2, 3), np.float32), aovs={"depth": np.ones((2, 2), np.float32)})
    with pytest.raises(ValueError, match=r"save_aovs: directory '' is empty"):
        image.save_aovs("")
    assert not list(tmp_path.iterdir())


def test_save_aovs_under_a_file_names_the_file_in_the_way(tmp_path):
    """The folder's mkdir said '[Errno 17] File exists: ...', as if the AOVs were there already."""
    (tmp_path / "notes.txt").write_text("a file")
    image = wrt.Image(rgb=np.zeros((2, 2, 3), np.float32), aovs={"depth": np.ones((2, 2), np.float32)})
    with pytest.raises(NotADirectoryError, match=r"aovs: .*notes\.txt is a file, not a directory"):
        image.save_aovs(tmp_path / "notes.txt" / "aovs")


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, where no one creates files")
@pytest.mark.parametrize("suffix", [".png", ".exr", ".npy"])
def test_save_into_a_folder_that_takes_no_files_names_the_target(suffix):
    """The error named the temporary file beside the target ('/proc/.x.png.<pid>.0.partial.png'), and for .exr it
    was OpenEXR's RuntimeError, not an OSError."""
    with pytest.raises(OSError) as error:
        wrt.Image(rgb=np.zeros((2, 2, 3), np.float32)).save(f"/proc/x{suffix}")
    assert f"/proc/x{suffix}" in str(error.value) and "partial" not in str(error.value)


@pytest.mark.parametrize("suffix", [".png", ".exr", ".npy"])
def test_save_takes_a_file_name_near_the_length_limit(tmp_path, suffix):
    """The temporary file beside the target was named ``.NAME.<pid>.partial.SUFFIX``: a name of 240 bytes, which
    the file system takes, became one over its 255-byte limit, and the save failed with 'File name too long'
    naming that temporary file."""
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    name = "a" * (limit - len(suffix)) + suffix  # the longest name the file system takes
    (tmp_path / name).touch()  # it does
    (tmp_path / name).unlink()
    rgb = np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3) / 20.0
    path = wrt.Image(rgb=rgb).save(tmp_path / name)
    assert path == tmp_path / name
    assert [p.name for p in tmp_path.iterdir()] == [name]  # and no temporary file is left beside it
    if suffix == ".npy":
        np.testing.assert_array_equal(np.load(path), rgb)


@pytest.mark.parametrize("rgb", [np.zeros((4, 5), np.float32), np.zeros((4, 5, 1), np.float32),
                                 np.zeros((4, 5, 4), np.float32), np.zeros((0, 5, 3), np.float32),
                                 np.zeros((4, 5, 3), bool), np.full((4, 5, 3), "0.5"), None],
                         ids=["2d", "one channel", "rgba", "empty", "bool", "text", "none"])
def test_an_image_of_no_rgb_picture_is_refused_when_made(tmp_path, rgb):
    """wrt.Image's rgb is an (H, W, 3) picture, but anything was taken: a (4, 5) array failed at save with PIL's
    'Invalid mode for data type', an empty one wrote a broken EXR's temporary file, an RGBA one was written as an
    RGBA PNG with its alpha sRGB-encoded and as an RGB EXR. Refused now, naming rgb and what it got."""
    with pytest.raises(ValueError, match=r"^wrt.Image: rgb must be a non-empty \(H, W, 3\) array of real numbers"):
        wrt.Image(rgb=rgb)


def test_an_image_of_nested_lists_or_float64_is_float32():
    """A list of rows was kept as a list: repr, .width and save('.exr') raised AttributeError ('list' object has no
    attribute 'shape'); rgb is documented float32, and a float64 array is held as float32 (what save writes)."""
    rows = [[[0.25, 0.5, 1.0], [0.0, 2.0, 0.125]]]
    for given in (rows, np.array(rows, np.float64)):
        img = wrt.Image(rgb=given)
        assert (img.width, img.height) == (2, 1) and img.rgb.dtype == np.float32
        np.testing.assert_array_equal(img.rgb, np.array(rows, np.float64))  # these values are exact in float32


@pytest.mark.parametrize("exposure", [float("nan"), float("inf"), -np.inf, "1", None, True, 1024, -1e6, 151])
def test_save_refuses_an_exposure_that_is_not_a_finite_number(tmp_path, exposure):
    """NaN wrote a black PNG and inf a white one without a word (the CLI checks --exposure; Python did not); 1024
    raised an OverflowError."""
    img = wrt.Image(rgb=np.full((3, 7, 3), 0.25, np.float32))
    with pytest.raises(ValueError, match="exposure must be a finite number"):
        img.save(tmp_path / "x.png", exposure=exposure)
    assert not (tmp_path / "x.png").exists()
    img.save(tmp_path / "x.png", exposure=np.float32(1.0))  # numpy scalars are numbers
    from PIL import Image as PilImage

    with PilImage.open(tmp_path / "x.png") as png:
        assert png.size == (7, 3)
        np.testing.assert_array_equal(np.asarray(png), 188)  # sRGB of 0.5: 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
    img.rgb[0, 0] = 3e38  # the largest exposure on the largest float32: white, with no overflow warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img.save(tmp_path / "x.png", exposure=150)
    with PilImage.open(tmp_path / "x.png") as png:
        np.testing.assert_array_equal(np.asarray(png), 255)


@pytest.mark.parametrize("integrator", ["path", "whitted", "ao"])
def test_launch_frame_without_host_reads_equals_a_one_sample_render(integrator):
    from wrt.procedural import ring_of_cameras, sensor_scene

    scene = sensor_scene()  # single-sided boxes: back-face culling runs its fixed passes
    cams = ring_of_cameras(3)
    renderer = wrt.Renderer(scene, camera=cams[0], width=40, height=30, integrator=integrator, device="cpu")
    expected = renderer.render(spp=1, seed=9)
    for _ in range(2):  # the second launch reuses every buffer, as a replayed CUDA graph does
        renderer.launch_frame(seed=9)
        frame = renderer.frame_image()
        np.testing.assert_array_equal(frame.rgb, expected.rgb)
        for name in expected.aovs:
            np.testing.assert_array_equal(frame.aovs[name], expected.aovs[name], err_msg=name)
    batch = wrt.Renderer(scene, cameras=cams, width=40, height=30, integrator=integrator, device="cpu")
    batch.launch_frame(seed=9)
    np.testing.assert_array_equal(batch.frame_image().rgb.numpy()[0], expected.rgb)


SCALED_ROOM = """#usda 1.0
(
    defaultPrim = "Root"
    metersPerUnit = 1
    upAxis = "Y"
)
def Xform "Root"
{{
    double3 xformOp:scale = ({s!r}, {s!r}, {s!r})
    uniform token[] xformOpOrder = ["xformOp:scale"]
    def "World" (references = @{room}@</World>)
    {{
    }}
}}
"""


@pytest.mark.parametrize("device", ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else []))
@pytest.mark.parametrize("integrator", ["whitted", "ao", "path"])
def test_a_room_scaled_down_keeps_its_contact_shadows(integrator, device, tmp_path):
    """The default room (its camera and lights too) scaled by 2^-14 and 2^-24 renders the image of the unscaled
    room, bit for bit. The self-intersection offset near the origin was a fixed 1/65536, 15% of a room scaled by 1e-4:
    the shadows where the objects meet the floor were lost (141 pixels of 19,200 at 2^-14, 3,098 at 2^-20); then the
    power of two above each surface's size, at most 1, so bounced rays of the unscaled room started a few ulps apart
    (path-traced pixels 2.3e-4 off). The offsets now follow the surfaces alone, which a power of two scales exactly."""
    images = []
    for s in (1.0, 2.0**-14, 2.0**-24):
        path = tmp_path / f"room_{len(images)}.usda"
        path.write_text(SCALED_ROOM.format(s=s, room=default_scene_path().resolve().as_posix()))
        images.append(wrt.render(wrt.load_usd(path), width=64, height=48, integrator=integrator, device=device).rgb)
    np.testing.assert_array_equal(images[1], images[2])
    np.testing.assert_array_equal(images[1], images[0])


@pytest.mark.parametrize("scale", [1e-12, 1.0, 1e10, 1e12])
def test_shading_does_not_depend_on_scene_scale(scale):
    """A quad facing the camera, with the camera and its clipping range scaled with it, shows the same colour at any
    scale: the geometric normal (a cross product, ~ scale^2) is normalised without overflow or underflow."""
    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64) * scale
    scene = wrt.Scene.from_triangles(quad.astype(np.float32), [[0, 1, 2], [0, 2, 3]])
    cam = wrt.Camera.look_at((0, 0, 4 * scale), (0, 0, 0), fov_y_deg=30, clipping_range=(0.01 * scale, 100 * scale))
    img = wrt.render(scene, camera=cam, width=8, height=8)
    assert img.aovs["prim"][4, 4] >= 0
    np.testing.assert_allclose(img.rgb[4, 4], 0.5, rtol=1e-4)


def test_samples_whose_sum_overflows_are_dropped_not_written():
    """A dome of 1e38 over a texture of 1e38 (each finite in float32, their product 1e76 is not, nor any scaling of it
    into range: wrt.radiance_scale) gives samples or per-pixel sums past float32's range, which reached the EXR as
    inf; such samples are now left out and counted as non-finite ones are, with a warning (the count alone darkened
    the image without a word), and pixels whose mean passes float32's range are its largest."""
    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    scene = wrt.Scene.from_triangles(quad, [[0, 1, 2], [0, 2, 3]])
    scene.lights = [DomeLight(color=np.full(3, 1e38, np.float32), texture=np.full((2, 4, 3), 1e38, np.float32))]
    cam = wrt.Camera.look_at((0, 0, 4), (0, 0, 0), fov_y_deg=60)
    with pytest.warns(UserWarning, match="past float32's range"):
        renderer = wrt.Renderer(scene, camera=cam, width=8, height=8, integrator="path")
    with pytest.warns(UserWarning, match=r"sample\(s\) were not finite, or passed float32's range .* left out"):
        img = renderer.render(spp=8)
    assert np.isfinite(img.rgb).all()
    assert renderer.dropped_samples > 0


def test_progressive_render_interrupted_midway_resumes_from_the_samples_it_finished(room):
    """Ctrl-C during a resumed render: the sums already held the finished launches' samples while the sample count
    was only updated at the end, so the next ``resume=True`` came out about 25% too bright. The count now follows
    the sums, and finishing the interrupted render gives exactly the image of one uninterrupted render."""
    reference = wrt.Renderer(room, width=24, height=16, integrator="path").render(spp=8, seed=3).rgb
    renderer = wrt.Renderer(room, width=24, height=16, integrator="path")
    renderer.render(spp=2, seed=3)
    launch = renderer._start_and_trace
    launches = []

    def interrupted_at_third(*args, **kwargs):
        launches.append(1)
        if len(launches) == 3:
            raise KeyboardInterrupt
        return launch(*args, **kwargs)

    renderer._start_and_trace = interrupted_at_third
    with pytest.raises(KeyboardInterrupt):
        renderer.render(spp=4, seed=3, batch=1, resume=True)
    renderer._start_and_trace = launch
    # 2 samples, then 2 launches of 1 sample before the interrupt: 4 to go for 8.
    image = renderer.render(spp=4, seed=3, resume=True)
    np.testing.assert_array_equal(image.rgb, reference)


def test_resume_that_cannot_add_to_the_previous_samples_says_it_starts_over():
    """``resume=True`` after a render of another seed, or after the scene was edited (its rebuild drops the sums),
    started over from no samples without a word: a caller adding samples took the image for their sum. It warns;
    a first render, or a resume that adds, warns nothing."""
    import dataclasses
    import warnings

    room = wrt.load_usd(default_scene_path())  # edited below: not the module's shared scene
    renderer = wrt.Renderer(room, width=8, height=6, integrator="path")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        renderer.render(spp=1, seed=1, resume=True)  # nothing before it: nothing to say
        renderer.render(spp=1, seed=1, resume=True)  # adds
    with pytest.warns(UserWarning, match=r"resume=True starts over from no samples: seed 2 is not the previous"):
        fresh = renderer.render(spp=1, seed=2, resume=True)
    np.testing.assert_array_equal(fresh.rgb, wrt.Renderer(room, width=8, height=6, integrator="path").render(
        spp=1, seed=2).rgb)
    room.meshes[0] = dataclasses.replace(room.meshes[0])
    with pytest.warns(UserWarning, match=r"starts over from no samples: the scene changed since the previous render"):
        renderer.render(spp=1, seed=2, resume=True)


@pytest.mark.parametrize("name", ["resume", "progress"])
@pytest.mark.parametrize("value", ["false", "no", None, 2])
def test_render_flags_that_are_no_bool_are_refused_naming_them(name, value):
    """``Renderer.render(resume="false")`` (a string, None, 2) was taken by its truth: "false" added the samples to
    the previous render's and returned their mean, without a word. Refused as a mesh's ``double_sided`` is; a numpy
    bool and 0 and 1 mean what they say. Oracle: ``resume=np.bool_(False)`` gives the image of a fresh renderer."""
    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    camera = wrt.Camera.look_at((0.3, 0.3, 3), (0.3, 0.3, 0))
    renderer = wrt.Renderer(scene, camera=camera, width=8, height=6, integrator="path", device="cpu")
    renderer.render(spp=1, seed=0)
    with pytest.raises(TypeError, match=rf"^{name} must be True or False, got "):
        renderer.render(spp=1, seed=0, **{name: value})
    if name == "progress":  # wrt.render passes it on
        with pytest.raises(TypeError, match=r"^progress must be True or False, got "):
            wrt.render(scene, camera=camera, width=8, height=6, device="cpu", progress=value)
    again = renderer.render(spp=1, seed=1, resume=np.bool_(False)).rgb
    fresh = wrt.Renderer(scene, camera=camera, width=8, height=6, integrator="path", device="cpu")
    np.testing.assert_array_equal(again, fresh.render(spp=1, seed=1).rgb)


@pytest.mark.parametrize("value", ["false", None])
def test_camera_rays_t_range_that_is_no_bool_is_refused(value):
    """``camera_rays(..., t_range="false")`` returned four arrays where the caller unpacked two ("too many values to
    unpack", naming nothing). Refused naming it."""
    from wrt.rays import camera_rays

    scene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(TypeError, match=r"^camera_rays: t_range must be True or False, got "):
        camera_rays(scene, width=4, height=4, t_range=value)
    assert len(camera_rays(scene, width=4, height=4, t_range=0)) == 2


def test_a_kept_renderer_follows_a_replaced_mesh_an_in_place_edit_and_a_new_light():
    """A kept Renderer drew the geometry and lights it was built with after the scene changed, though the README
    says a replaced mesh is noticed at the next render. It builds again when the scene changed, and only then."""
    import dataclasses

    quad = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    camera = wrt.Camera.look_at((0, 0, 4), (0, 0, 0))
    renderer = wrt.Renderer(quad, camera=camera, width=16, height=12, integrator="normals", device="cpu")
    first = renderer.render()
    assert (first.aovs["prim"] >= 0).sum() > 20
    accel = renderer.accel
    renderer.render()
    assert renderer.accel is accel  # nothing changed: nothing built again

    mesh = quad.meshes[0]
    quad.meshes[0] = dataclasses.replace(mesh, points=mesh.points + np.float32([100, 0, 0]))  # out of view
    moved = renderer.render()
    assert (moved.aovs["prim"] == -1).all()
    np.testing.assert_array_equal(moved.rgb, wrt.render(quad, camera=camera, width=16, height=12,
                                                         integrator="normals", device="cpu").rgb)
    quad.invalidate()  # before an edit in place: the rendered arrays are read-only until then
    quad.meshes[0].points -= np.float32([100, 0, 0])  # back
    np.testing.assert_array_equal(renderer.render().aovs["prim"], first.aovs["prim"])

    lit = wrt.Renderer(quad, camera=camera, width=16, height=12, device="cpu")  # whitted, default lights
    headlit = lit.render().rgb
    quad.lights.append(wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 3.0)))
    sunlit = lit.render().rgb
    assert not np.allclose(sunlit, headlit)
    np.testing.assert_array_equal(sunlit, wrt.render(quad, camera=camera, width=16, height=12, device="cpu").rgb)


def test_material_and_light_fields_assigned_after_construction_are_checked_before_the_next_render():
    """The constructors refuse NaN colours and negative sizes, but a field assigned later (a simulation step's
    ``light.color = ...``) was not checked: a NaN diffuse colour rendered its triangles black, a NaN light colour or
    a negative radius lit nothing, each without a word. A kept Renderer and a fresh render refuse them, naming the
    prim and the field; a good value assigned is converted as the constructor converts it and built once."""
    quad = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    quad.materials.append(wrt.Material(path="/Red", diffuse_color=(1.0, 0.0, 0.0)))
    quad.meshes[0].material_ids = np.zeros(2, np.int32)
    quad.lights.append(wrt.SphereLight(position=(0, 0, 2), radius=0.1, color=(30, 30, 30), path="/Bulb"))
    camera = wrt.Camera.look_at((0, 0, 4), (0, 0, 0))
    renderer = wrt.Renderer(quad, camera=camera, width=16, height=12, device="cpu")
    lit = renderer.render().rgb
    for obj, field, bad, message in (
        (quad.materials[0], "diffuse_color", (np.nan, 0.0, 0.0), "^/Red: Material diffuse_color must be finite"),
        (quad.lights[0], "color", (np.nan, 1.0, 1.0), "^/Bulb: SphereLight color must be finite"),
        (quad.lights[0], "radius", -1.0, r"^/Bulb: SphereLight radius must be a finite number >= 0"),
    ):
        good = getattr(obj, field)
        setattr(obj, field, bad)
        with pytest.raises(wrt.SceneError, match=message):
            renderer.render()
        with pytest.raises(wrt.SceneError, match=message):
            wrt.render(quad, camera=camera, width=16, height=12, device="cpu")
        setattr(obj, field, good)
        np.testing.assert_array_equal(renderer.render().rgb, lit)
    quad.lights[0].color = [15, 15, 15]  # a list, as the constructor takes it
    half = renderer.render().rgb
    assert isinstance(quad.lights[0].color, np.ndarray) and 0 < half.max() < lit.max()
    accel = renderer.accel
    renderer.render()
    assert renderer.accel is accel  # the converted colour is the one recorded: nothing to build again


def test_two_scenes_drawing_one_mesh_keep_it_read_only_until_both_are_invalidated():
    """Two scenes drawing the same mesh object: the first render froze its points, the second scene found them
    read-only already and did not hold them, so the first scene's ``invalidate()`` gave write access back, an edit in
    place went through, and the second scene went on tracing the old points (t = 4 where the moved quad is at 3)
    without a word. The points stay read-only until every scene holding them is invalidated; then both follow."""
    import copy

    first = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    second = wrt.Scene(meshes=list(first.meshes))
    ray = ([0.0, 0.0, 4.0], [0.0, 0.0, -1.0])
    assert wrt.trace(first, *ray).t[0] == 4.0 and wrt.trace(second, *ray).t[0] == 4.0
    first.invalidate()
    with pytest.raises(ValueError, match="read-only"):  # the second scene's caches are made from them
        first.meshes[0].points[:, 2] += 1.0
    second.invalidate()
    first.meshes[0].points[:, 2] += 1.0
    assert wrt.trace(second, *ray).t[0] == 3.0 == wrt.trace(copy.deepcopy(second), *ray).t[0]
    assert wrt.trace(first, *ray).t[0] == 3.0


def test_an_edit_in_place_after_a_render_is_refused_until_invalidate():
    """``mesh.points[:, 0] += 100`` after a render, then a render again, drew the quad where it was (the BVH and
    device copies kept the old points), and a kept Renderer went on lighting with a light's colour set to 0 in place:
    a notebook showed the stale image without a word. Arrays of the rendered scene and its lights are read-only until
    ``invalidate()``, which gives write access back; the edits are then drawn."""
    import pickle

    quad = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    quad.lights = [wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 2.0, np.float32))]
    renderer = wrt.Renderer(quad, camera=wrt.Camera.look_at((0, 0, 4), (0, 0, 0)), width=16, height=12, device="cpu")
    first = renderer.render()
    assert (first.aovs["prim"] >= 0).sum() > 20 and first.rgb[6, 8].min() > 0.1
    with pytest.raises(ValueError, match="read-only"):
        quad.meshes[0].points[:, 0] += 100
    with pytest.raises(ValueError, match="read-only"):
        quad.lights[0].color[:] = 0.0
    np.testing.assert_array_equal(renderer.render().rgb, first.rgb)  # nothing was changed

    quad.invalidate()
    quad.lights[0].color[:] = 0.0
    assert (renderer.render().rgb == 0).all()  # the kept renderer sees the edited light
    quad.invalidate()
    quad.meshes[0].points[:, 0] += 100  # out of view
    assert (renderer.render().aovs["prim"] == -1).all()
    with pytest.raises(ValueError, match="read-only"):  # read-only again once rendered
        quad.meshes[0].points[:, 0] -= 100

    fresh = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[0, 1, 2]])
    fresh.bounds()  # read-only from here on; the scene still travels to worker processes, as before
    copy = pickle.loads(pickle.dumps(fresh))
    assert not fresh.meshes[0].points.flags.writeable and copy.meshes[0].points.flags.writeable
    # A traced scene pickles too (its cache held Warp structs, which do not), and its copy traces the same.
    ray = (np.float32([[0.5, -0.5, 1.0]]), np.float32([[0.0, 0.0, -1.0]]))
    traced = wrt.trace(fresh, *ray, device="cpu")
    np.testing.assert_array_equal(wrt.trace(pickle.loads(pickle.dumps(fresh)), *ray, device="cpu").t, traced.t)
    assert traced.prim[0] == 0
    assert copy.bounds()[1].tolist() == [1, 1, 0] and not copy.meshes[0].points.flags.writeable


def test_a_loaded_stage_with_instances_is_editable_in_place_until_rendered(tmp_path):
    """The loader caches the instances' inverses, and that made every array of a stage with instances read-only
    right after the load (``mesh.points[:, 1] += 1`` before any render raised "read-only", on a stage without
    instances it did not). Only the instance transforms, which the cache is made from, are read-only after the
    load; an edit of a mesh in place is drawn, and the scene is read-only once rendered."""
    from usda_text import load, write

    tri = "point3f[] points = [(-1, -1, 0), (1, -1, 0), (0, 1, 0)]\n    int[] faceVertexCounts = [3]\n" \
          "    int[] faceVertexIndices = [0, 1, 2]"
    copies = "".join(f'def Xform "Copy{k}" (\n    instanceable = true\n    prepend references = </Source>\n)\n{{\n'
                     f'    double3 xformOp:translate = (0, 0, {-k})\n'
                     '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n' for k in range(2))
    path = write(tmp_path, f'def Mesh "Ground"\n{{\n    {tri}\n}}\nclass Xform "Source"\n{{\n'
                 f'    def Mesh "Tri"\n    {{\n        {tri}\n    }}\n}}\n{copies}')
    scene = load(path)
    assert len(scene.instances) == 2
    scene.meshes[0].points[:, 1] += 10.0  # the ground out of the way, before any render
    scene.prototypes[0].meshes[0].points[:, 0] += 5.0  # the instanced triangle to x = 5
    with pytest.raises(ValueError, match="read-only"):  # its inverse is cached: an edit would go unseen
        scene.instances.to_world[0, 0, 3] = 1.0
    hits = wrt.trace(scene, [(0, 0, 5), (5, 0, 5)], [(0, 0, -1), (0, 0, -1)])
    assert hits.prim.tolist() == [-1, 1]  # the ground moved away, the instance's triangle moved under x = 5
    with pytest.raises(ValueError, match="read-only"):  # read-only once traced
        scene.meshes[0].points[:, 1] -= 10.0


def test_a_material_or_light_given_a_new_value_is_drawn_with_it():
    """Giving a material a new colour (``material.diffuse_color = ...``) left the scene's uploaded materials as they
    were, so even a new ``wrt.render`` of the scene drew the old colour; a kept Renderer also kept a light's old
    colour. Both are now noticed, as replacing a mesh array is."""
    import dataclasses

    quad = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    quad.meshes[0] = dataclasses.replace(quad.meshes[0], material_ids=np.zeros(2, np.int32))
    quad.materials = [wrt.Material(path="/Grey", diffuse_color=np.full(3, 0.5, np.float32))]
    quad.lights = [wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 2.0, np.float32))]
    options = dict(camera=wrt.Camera.look_at((0, 0, 4), (0, 0, 0)), width=16, height=12, device="cpu")

    def uncached():  # the same parts in a new Scene, which has no caches yet
        return wrt.render(dataclasses.replace(quad), **options).rgb

    kept = wrt.Renderer(quad, **options)
    grey = kept.render().rgb
    quad.materials[0].diffuse_color = np.array([1.0, 0.0, 0.0], np.float32)
    red = uncached()
    assert red[6, 8, 0] > 1.5 * grey[6, 8, 0] and red[6, 8, 1] < grey[6, 8, 1]
    np.testing.assert_array_equal(wrt.render(quad, **options).rgb, red)
    np.testing.assert_array_equal(kept.render().rgb, red)
    quad.lights[0].color = np.full(3, 0.5, np.float32)
    dim = uncached()
    assert dim[6, 8, 0] < red[6, 8, 0]
    np.testing.assert_array_equal(kept.render().rgb, dim)


def test_a_render_with_nothing_changed_does_not_walk_every_field_of_the_scene(monkeypatch):
    """Every render (and launch_frame) of a kept Renderer walked every field of every mesh to look for changes:
    70 ms per render of a 16x12 image on a scene of 20k meshes, against 2 ms before the walk. With no object
    replaced and no field assigned since the last check, the walk is skipped; any such change still rebuilds."""
    import dataclasses

    quad = wrt.Scene.from_triangles([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    quad.meshes[0] = dataclasses.replace(quad.meshes[0], material_ids=np.zeros(2, np.int32))
    quad.materials = [wrt.Material(path="/Grey", diffuse_color=np.full(3, 0.5, np.float32))]
    renderer = wrt.Renderer(quad, camera=wrt.Camera.look_at((0, 0, 4), (0, 0, 0)), width=16, height=12,
                            device="cpu")
    grey = renderer.render().rgb
    walks = []
    parts = wrt.Scene._parts
    monkeypatch.setattr(wrt.Scene, "_parts", lambda scene: walks.append(1) or parts(scene))
    renderer.render()
    renderer.render()
    assert walks == []

    generation = quad.cache_generation
    quad.materials[0].diffuse_color = np.array([1.0, 0.0, 0.0], np.float32)  # a field assigned
    red = renderer.render().rgb
    assert walks and quad.cache_generation != generation and red[6, 8, 1] < grey[6, 8, 1]
    quad.materials[0].textures["diffuseColor"] = TextureInput(image=0)  # a dict entry
    generation = quad.cache_generation
    quad.drop_stale_caches()
    assert quad.cache_generation != generation
    generation = quad.cache_generation
    quad.meshes.append(dataclasses.replace(quad.meshes[0]))  # a list grown in place
    quad.drop_stale_caches()
    assert quad.cache_generation != generation
    generation = quad.cache_generation
    quad.meshes[1] = dataclasses.replace(quad.meshes[0])  # an element replaced in place
    quad.drop_stale_caches()
    assert quad.cache_generation != generation
    generation, count = quad.cache_generation, len(walks)
    quad.meshes[1].double_sided = quad.meshes[1].double_sided  # assigned an equal value: walked, nothing dropped
    quad.drop_stale_caches()
    assert quad.cache_generation == generation and len(walks) == count + 1


def test_a_library_render_prints_nothing_unless_asked():
    """A first ``wrt.render`` in a fresh process printed Warp's start-up banner ("Warp 1.19.0 initialized: ...") and a
    "Module wrt.trace ... load on device 'cpu'" line per kernel module, 14 lines in a notebook cell. Importing wrt
    raises Warp's default log level to warnings (which still show); a level the user set first is kept."""
    import subprocess
    import sys

    render = ("import warp as wp\nimport wrt\nscene = wrt.Scene.from_triangles([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "
              "[[0, 1, 2]])\nwrt.render(scene, width=4, height=4, device='cpu')\nprint(wp.config.log_level)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    quiet = subprocess.run([sys.executable, "-c", render], capture_output=True, text=True, env=env, check=True)
    assert quiet.stdout.strip() == str(wp.LOG_WARNING)
    assert "initialized" not in quiet.stdout + quiet.stderr and " load on device" not in quiet.stdout + quiet.stderr
    asked = subprocess.run([sys.executable, "-c", "import warp as wp\nwp.config.log_level = wp.LOG_DEBUG\n" + render],
                           capture_output=True, text=True, env=env, check=True)
    assert asked.stdout.strip().splitlines()[-1] == str(wp.LOG_DEBUG) and " load on device" in asked.stdout


def test_coverage_counts_every_sample_however_the_render_is_run():
    """The coverage AOV is the share of a pixel's samples whose camera ray hit something: the pixel centre's hit at
    1 spp; at 128 spp the share of the pixel a quad covers (3/4 of column 10, 1/4 of column 13: worked out from the
    film); the same counts whether the samples come in one launch, in launches of 3, resumed (3 + 5) or as a batch
    of cameras; launch_frame's frame is one sample, counted again each frame."""
    # Film 36 x 18 at focal length 50: at z = -10 the 20 columns are 0.36 wide, column j spans x from -3.6 + 0.36 j.
    points = [[0.09, -100, -10], [1.17, -100, -10], [1.17, 100, -10], [0.09, 100, -10]]
    scene = wrt.Scene.from_triangles(points, [[0, 1, 2], [0, 2, 3]])
    cam = wrt.Camera(focal_length=50.0, horizontal_aperture=36.0, vertical_aperture=18.0)
    renderer = wrt.Renderer(scene, camera=cam, width=20, height=10, device="cpu")
    one = renderer.render(spp=1)
    np.testing.assert_array_equal(one.aovs["coverage"], one.aovs["prim"] >= 0)
    share = np.zeros(20)
    share[10:14] = [0.75, 1.0, 1.0, 0.25]
    many = renderer.render(spp=128)
    assert many.aovs["coverage"].dtype == np.float32 and many.aovs["coverage"].shape == (10, 20)
    np.testing.assert_allclose(many.aovs["coverage"], np.broadcast_to(share, (10, 20)), atol=0.15)
    whole = share % 1 == 0  # columns wholly inside or outside the quad
    np.testing.assert_array_equal(many.aovs["coverage"][:, whole], np.broadcast_to(share[whole], (10, whole.sum())))

    full = renderer.render(spp=8)
    assert ((full.aovs["coverage"] > 0) & (full.aovs["coverage"] < 1)).sum() >= 10
    np.testing.assert_array_equal(renderer.render(spp=8, batch=3).aovs["coverage"], full.aovs["coverage"])
    renderer.render(spp=3)
    np.testing.assert_array_equal(renderer.render(spp=5, resume=True).aovs["coverage"], full.aovs["coverage"])
    batch = wrt.render_batch(scene, [cam, cam], 20, 10, spp=8, device="cpu")
    for k in range(2):
        np.testing.assert_array_equal(batch.image(k).aovs["coverage"], full.aovs["coverage"])
    renderer.launch_frame()
    renderer.launch_frame()
    np.testing.assert_array_equal(renderer.frame_image().aovs["coverage"], one.aovs["coverage"])


LIGHTS_ONLY = """#usda 1.0
def Camera "Cam"
{
    float2 clippingRange = (0.1, 100)
}
"""


@pytest.mark.parametrize("light, seen", [
    ('def DomeLight "Dome"\n{\n    color3f inputs:color = (0.2, 0.4, 0.6)\n}\n', (0.2, 0.4, 0.6)),
    ('def SphereLight "Bulb"\n{\n    float inputs:radius = 2\n    bool inputs:normalize = 1\n'
     '    color3f inputs:color = (1, 0.5, 0.25)\n    float inputs:intensity = 50\n'
     '    double3 xformOp:translate = (0, 0, -10)\n    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n',
     np.array([1.0, 0.5, 0.25]) * 50 / (4 * np.pi * 2.0**2)),
])
def test_a_stage_of_lights_a_camera_sees_renders_them_without_nothing_to_render(tmp_path, light, seen):
    """A stage whose only prims are a dome, or an area light in view, is not "nothing to render": the camera sees
    them (an HDRI or a light preview). The warning said the image was background only. The centre pixel shows the
    light's radiance (the dome's colour; a normalized sphere light's ``intensity * color / (4 pi r^2)``)."""
    path = tmp_path / "lights.usda"
    path.write_text(LIGHTS_ONLY + light)
    scene = wrt.load_usd(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = wrt.render(scene, width=9, height=9, device="cpu")
    np.testing.assert_allclose(img.rgb[4, 4], seen, rtol=1e-4)


@pytest.mark.parametrize("light, integrator, why", [
    ('def SphereLight "Point"\n{\n    bool treatAsPoint = 1\n}\n', "whitted", "no light a camera ray sees"),
    ('def DistantLight "Sun"\n{\n    float inputs:angle = 0\n}\n', "path", "no light a camera ray sees"),
    ('def DomeLight "Dome"\n{\n}\n', "normals", "the normals integrator shows no light"),
])
def test_a_stage_of_lights_no_camera_ray_sees_warns_nothing_to_render(tmp_path, light, integrator, why):
    """Point lights and delta distant lights light surfaces only, and the integrators that read no light show none:
    with no geometry, such a stage still renders background only, with the warning saying why."""
    path = tmp_path / "lights.usda"
    path.write_text(LIGHTS_ONLY + light)
    scene = wrt.load_usd(path)
    assert scene.lights
    with pytest.warns(UserWarning, match=rf"lights\.usda: nothing to render \(no triangles, and {why}\)"):
        img = wrt.render(scene, width=4, height=4, device="cpu", integrator=integrator)
    assert (img.aovs["prim"] == -1).all()


def test_default_lights_show_a_white_lambertian_surface_as_one(tmp_path):
    """README: under the default lights (headlight E = 0.8 pi, dome of radiance 0.2) an unoccluded white Lambertian
    surface facing the camera is 0.8 + 0.2 = 1.0 under whitted; a white UsdPreviewSurface (ior 1.5, roughness 0.5,
    as USD's schema falls back to) adds its specular lobe, so it shows more than 1."""
    from wrt.materials import Material

    camera = wrt.Camera.look_at((0, 0, 5), (0, 0, 0), fov_y_deg=30.0)
    shown = []
    for extra in (dict(specular_edge=0.0, ior=1.0), {}):
        corners = [[-20, -20, 0], [20, -20, 0], [20, 20, 0], [-20, 20, 0]]
        quad = wrt.Scene.from_triangles(corners, [[0, 1, 2], [0, 2, 3]])
        quad.materials = [Material(diffuse_color=np.ones(3, np.float32), **extra)]
        quad.meshes[0].material_ids = np.zeros(2, np.int32)
        image = wrt.render(quad, camera=camera, width=8, height=8, device="cpu")
        shown.append(float(image.rgb[3:5, 3:5].mean()))
    # Analytic: albedo 1 / pi times the headlight's E = 0.8 pi (along the view, which faces the quad) and the
    # dome's 0.2 pi over the open hemisphere.
    assert shown[0] == pytest.approx(0.8 + 0.2, rel=1e-4)
    assert shown[1] > shown[0] + 0.05


@pytest.mark.parametrize("name", ["camera", "cameras", "device", "batched"])
def test_a_renderer_camera_or_device_assigned_is_refused_naming_what_to_do(name):
    """Renderer.camera, .cameras, .device and .batched were plain attributes: renderer.camera = other_camera (a new
    pose each step) drew the old camera without a word, renderer.cameras = a longer list read the image sums past
    their end into a BatchImage of the new count, and .device or .batched assigned launched on or read back from the
    wrong buffers. An assignment is refused, naming set_cameras (or a new Renderer); the renderer still draws what a
    fresh render of its cameras does."""
    from wrt.procedural import ring_of_cameras, sensor_scene

    scene, cams = sensor_scene(), ring_of_cameras(3)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device="cpu")
    renderer.render()
    value = {"camera": cams[2], "cameras": cams, "device": "cpu", "batched": False}[name]
    with pytest.raises(AttributeError, match=rf"^Renderer\.{name} cannot be assigned .*"
                                             rf"{'set_cameras' if name.startswith('camera') else 'new wrt.Renderer'}"):
        setattr(renderer, name, value)
    batch = renderer.render(seed=1)
    assert len(batch) == 2 and renderer.camera is cams[0] and renderer.cameras == tuple(cams[:2])
    for k in range(2):
        fresh = wrt.render(scene, camera=cams[k], width=8, height=6, device="cpu", seed=1)
        np.testing.assert_array_equal(batch.image(k).rgb, fresh.rgb)


def test_a_renderers_cameras_cannot_be_changed_as_a_list():
    """Renderer.cameras was the list it drew from: renderer.cameras.append(camera) made a BatchImage of three cameras
    out of sums of two (read past their end), and renderer.cameras[0] = other labelled the old view with the new
    camera's pixel aspect. It is a tuple: set_cameras changes the cameras."""
    from wrt.procedural import ring_of_cameras, sensor_scene

    scene, cams = sensor_scene(), ring_of_cameras(3)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=6, device="cpu")
    assert isinstance(renderer.cameras, tuple)
    with pytest.raises((AttributeError, TypeError)):
        renderer.cameras.append(cams[2])
    assert len(renderer.render()) == 2
    renderer.set_cameras(cams)
    assert renderer.cameras == tuple(cams) and len(renderer.render()) == 3


def test_a_renderer_given_another_scene_refuses_it_naming_a_new_renderer():
    """Renderer.scene was a plain attribute: renderer.scene = other_scene (a new simulation step's scene) kept the old
    scene's BVH, device data and lights where the edit counts of the two scenes matched, and drew the old scene, and
    otherwise crashed with an IndexError in the rebuild. The assignment is refused, saying to make a new Renderer
    (edits of the scene itself are followed); the renderer still draws its own scene as a fresh render does."""
    from wrt.procedural import sensor_scene

    scene, other = sensor_scene(), sensor_scene(boxes=2, spheres=1)
    cam = wrt.Camera.look_at((0.0, 1.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device="cpu")
    renderer.render()
    with pytest.raises(AttributeError, match=r"^Renderer\.scene cannot be assigned .*make a new wrt\.Renderer"):
        renderer.scene = other
    assert renderer.scene is scene
    fresh = wrt.render(scene, camera=cam, width=8, height=6, device="cpu", seed=1)
    np.testing.assert_array_equal(renderer.render(seed=1).rgb, fresh.rgb)


@pytest.mark.parametrize("name,value", [("integrator", "pth"), ("integrator", "ao"), ("max_depth", -1),
                                        ("ao_radius", float("nan")), ("width", 4), ("height", 3)])
def test_a_renderer_setting_assigned_after_construction_is_refused_naming_a_new_renderer(name, value):
    """Renderer's settings were plain attributes, baked into its buffers, camera structs and recorded graphs:
    ``integrator = "pth"`` drew black, ``max_depth = -1`` read past a buffer, ``ao_radius = nan`` drew white and
    ``width = 4`` drew the 8-pixel-wide camera's rays into a 4-pixel image, each without a word. An assignment is
    refused, saying to make a new Renderer, and the renderer still draws what a fresh one of its settings does."""
    from wrt.procedural import sensor_scene

    scene = sensor_scene()
    cam = wrt.Camera.look_at((0.0, 1.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device="cpu", integrator="ao")
    with pytest.raises(AttributeError, match=rf"^Renderer\.{name} cannot be assigned .*make a new wrt\.Renderer"):
        setattr(renderer, name, value)
    fresh = wrt.Renderer(scene, camera=cam, width=8, height=6, device="cpu", integrator="ao")
    assert getattr(renderer, name) == getattr(fresh, name)
    np.testing.assert_array_equal(renderer.render(seed=1).rgb, fresh.render(seed=1).rgb)


def test_timers_hold_the_last_render_and_build_only():
    """A Renderer kept for thousands of frames (a robot's camera loop): ``timers`` appended one entry per render()
    and per rebuild, growing without bound. Each stage now holds its last measurement, which lies within the wall
    time of the call that made it."""
    import time

    from wrt.procedural import sensor_scene

    scene = sensor_scene()
    renderer = wrt.Renderer(scene, width=8, height=8, device="cpu")
    for seed in range(5):
        start = time.perf_counter()
        renderer.render(spp=1, seed=seed)
        wall_ms = 1e3 * (time.perf_counter() - start)
        assert len(renderer.timers["render"]) == 1
        assert 0.0 < renderer.timers["render"][0] <= wall_ms
    scene.invalidate()  # the next render builds again
    renderer.render(spp=1)
    assert len(renderer.timers["build"]) == 1 and renderer.timers["build"][0] > 0.0


def test_a_renderers_lights_cannot_be_changed_there_but_scene_lights_are_followed():
    """Renderer.lights was the list built from scene.lights (or the default lights): renderer.lights.append(light)
    and renderer.lights = [...] drew nothing new, without a word. It is a tuple, refused when assigned, naming
    scene.lights, whose edits the next render follows as a fresh render draws them."""
    from wrt.procedural import sensor_scene

    scene = sensor_scene()
    cam = wrt.Camera.look_at((0.0, 1.0, 6.0), (0.0, 0.0, 0.0), fov_y_deg=40.0)
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device="cpu")
    bulb = wrt.SphereLight(position=(0, 2, 2), radius=0.1, color=(30, 30, 30), path="/Bulb")
    assert renderer.lights == tuple(scene.lights)
    with pytest.raises((AttributeError, TypeError)):
        renderer.lights.append(bulb)
    with pytest.raises(AttributeError, match=r"^Renderer\.lights cannot be assigned .*scene\.lights"):
        renderer.lights = [*scene.lights, bulb]
    scene.lights.append(bulb)
    image = renderer.render(seed=1)
    assert renderer.lights == tuple(scene.lights)
    np.testing.assert_array_equal(image.rgb, wrt.render(scene, camera=cam, width=8, height=6, device="cpu",
                                                        seed=1).rgb)


def test_a_blind_camera_moving_every_step_is_warned_of_once_and_nothing_grows():
    """A camera whose clipping range holds none of the scene, moved each step of a long loop (set_cameras, or its
    pose edited): the 'sees nothing' warning was keyed by its whole message, which names the scene's extent along
    the view, so every new pose warned again and added a key to the Renderer's set, without bound. It is said once
    per camera and clipping range; the render itself is the oracle of 'nothing seen'."""
    from shading_helpers import quad

    scene = wrt.Scene(meshes=[quad((0, 0, 0), (1, 0, 0), (0, 1, 0), name="/a")])

    def blind(z):
        return wrt.Camera.look_at((0.0, 0.0, z), (0.0, 0.0, 0.0), fov_y_deg=40, clipping_range=(100.0, 200.0))

    renderer = wrt.Renderer(scene, camera=blind(5.0), width=8, height=6, device="cpu")
    edited = blind(5.0)
    kept = wrt.Renderer(scene, camera=edited, width=8, height=6, device="cpu")

    def steps():
        for step in range(1, 30):
            renderer.set_cameras([blind(5.0 + 0.5 * step)])
            edited.to_world[2, 3] = 5.0 + 0.5 * step
            kept.render()

    assert len(_sees_nothing(steps)) == 0  # both warned when made
    assert (renderer.render().image(0).aovs["prim"] == -1).all() and (kept.render().aovs["prim"] == -1).all()
    for each in (renderer, kept):
        assert len([key for key in each._said_once if key[0] == "clipped away"]) == 1


def _container_sizes(renderer) -> dict:
    """The length of each list, dict, set or tuple among the renderer's attributes (and of each list in a dict)."""
    sizes = {}
    for name, value in vars(renderer).items():
        if isinstance(value, (list, dict, set, tuple)):
            sizes[name] = len(value)
        if isinstance(value, dict):
            sizes.update({(name, key): len(item) for key, item in value.items() if isinstance(item, list)})
    return sizes


def test_a_long_loop_of_renders_and_frames_grows_no_container_and_builds_no_kernel():
    """A robot's loop keeps one Renderer for thousands of frames: render() and launch_frame() after set_cameras
    (poses moved each step) must leave every container the renderer holds the size it was after the first frames
    (timers grew by one entry a render), and load no Warp module again (a kernel made per call compiles anew)."""
    from warp._src import context as warp_context

    from wrt.procedural import ring_of_cameras, sensor_scene

    scene, cams = sensor_scene(), ring_of_cameras(4)
    renderer = wrt.Renderer(scene, cameras=cams[:2], width=8, height=8, device="cpu")

    def step(k):
        renderer.render(spp=1, seed=k)
        moved = [dataclasses.replace(cam, to_world=cam.to_world.copy()) for cam in cams[2 * (k % 2):][:2]]
        moved[0].to_world[0, 3] += 0.01 * k
        renderer.set_cameras(moved)
        renderer.launch_frame(seed=k)
        return renderer.frame_image()

    for k in range(2):
        step(k)
    sizes = _container_sizes(renderer)
    loaded = sum(len(module.execs) for module in warp_context.user_modules.values())
    for k in range(2, 22):
        frame = step(k)
    assert _container_sizes(renderer) == sizes
    assert sum(len(module.execs) for module in warp_context.user_modules.values()) == loaded
    np.testing.assert_array_equal(frame.rgb.numpy(), renderer.render(spp=1, seed=21).rgb.numpy())


def test_a_resumed_render_counts_and_names_the_dropped_samples_of_its_whole_image():
    """With ``resume=True`` the image is that of one render of all the samples, and so is the count of those left
    out: ``dropped_samples`` equals a single render's of the total (it was already, while the docs said 'of the last
    render'), and the warning now names the samples per pixel it counts over, so the warnings of successive resumes
    no longer read as new drops to add up."""
    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    scene = wrt.Scene.from_triangles(quad, [[0, 1, 2], [0, 2, 3]])
    scene.lights = [DomeLight(color=np.full(3, 1e38, np.float32), texture=np.full((2, 4, 3), 1e38, np.float32))]
    cam = wrt.Camera.look_at((0, 0, 4), (0, 0, 0), fov_y_deg=60)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = wrt.Renderer(scene, camera=cam, width=4, height=4, integrator="path")
        whole.render(spp=8, seed=2)
        resumed = wrt.Renderer(scene, camera=cam, width=4, height=4, integrator="path")
        resumed.render(spp=3, seed=2)
    assert whole.dropped_samples > 0
    with pytest.warns(UserWarning, match=rf"{whole.dropped_samples} sample\(s\) .* of the image's 8 sample\(s\) per "
                                         r"pixel, resumed renders included"):
        resumed.render(spp=5, seed=2, resume=True)
    assert resumed.dropped_samples == whole.dropped_samples


@pytest.mark.parametrize("options, said", [
    ({"ao_radius": 0.01}, "ao_radius applies to integrator 'ao' only; 'whitted' does not use it"),
    ({"integrator": "normals", "max_depth": 0}, "max_depth applies to integrator 'path' and 'whitted' only; "
                                                "'normals' does not use it"),
    ({"integrator": "ao", "ao_radius": 0.01}, None),
    ({"max_depth": 0}, None),
])
def test_integrator_options_the_integrator_does_not_use_are_warned_about_as_the_cli_warns(options, said):
    """``wrt.render(scene, ao_radius=0.01)`` (whitted) drew the image without it, without a word, where ``wrt render
    --ao-radius`` warns; the oracle that the option is unused: the image equals the one rendered without it."""
    triangle = wrt.Mesh("/T", np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), np.zeros(1, int))
    scene = wrt.Scene(meshes=[triangle])
    size = {"width": 8, "height": 6}
    with warnings.catch_warnings(record=True) as raised:
        warnings.simplefilter("always")
        image = wrt.render(scene, **size, **options)
    words = [str(w.message) for w in raised if "applies to integrator" in str(w.message)]
    assert words == ([] if said is None else [said])
    if said is not None:
        unused = next(name for name in ("ao_radius", "max_depth") if name in options)
        without = {k: v for k, v in options.items() if k != unused}
        np.testing.assert_array_equal(image.rgb, wrt.render(scene, **size, **without).rgb)


@pytest.mark.parametrize("integrator", ["normals", "depth", "albedo"])
def test_spp_given_to_a_quick_look_is_warned_about_as_the_cli_warns(integrator):
    """``wrt.render(scene, integrator="normals", spp=16)`` drew one sample per pixel without a word, where ``wrt
    render --spp 16`` warns; the oracle that the samples were not drawn: the image equals the one of spp=1."""
    triangle = wrt.Mesh("/T", np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), np.zeros(1, int))
    scene = wrt.Scene(meshes=[triangle])
    size = {"width": 8, "height": 6, "integrator": integrator}
    with warnings.catch_warnings(record=True) as raised:
        warnings.simplefilter("always")
        image = wrt.render(scene, spp=16, **size)
    assert [str(w.message) for w in raised if "spp applies" in str(w.message)] == [
        f"spp applies to integrator 'whitted', 'path' and 'ao' only; {integrator!r} draws one sample per pixel, "
        "through its centre"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        one = wrt.render(scene, spp=1, **size)
    np.testing.assert_array_equal(image.rgb, one.rgb)
