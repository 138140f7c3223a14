"""Fields of lights and shapes built in Python, checked as a mesh's are: a value of the wrong kind is refused naming
the object and the field (when made, and when assigned later at the next render or trace), and the forms a mesh's
arrays may take (a ``wp.array``, an array behind DLPack, a ``(3, 4)`` affine transform) are read."""

import numpy as np
import pytest

import wrt
from tests.gpu_holders import DLPackOnly, wp_array

# Looking straight down at the origin.
TOP = wrt.Camera.orthographic((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), height=4.0)
WHITE = np.ones(3, np.float32)


def make_light(kind: str, **fields):
    """A light of each kind at path ``/L``, placed above the origin (area lights facing down)."""
    up = np.eye(4)
    up[2, 3] = 3.0
    makers = {
        "distant": lambda: wrt.DistantLight(np.float64([0.0, 0.0, -1.0]), WHITE, path="/L", **fields),
        "sphere": lambda: wrt.SphereLight(np.float64([0.0, 0.0, 3.0]), 0.5, WHITE, path="/L", **fields),
        "rect": lambda: wrt.RectLight(up, 2.0, 2.0, WHITE, path="/L", **fields),
        "disk": lambda: wrt.DiskLight(up, 1.0, WHITE, path="/L", **fields),
        "cylinder": lambda: wrt.CylinderLight(up, 2.0, 0.5, WHITE, path="/L", **fields),
        "mesh": lambda: wrt.MeshLight("/L", WHITE, **fields),
        "dome": lambda: wrt.DomeLight(WHITE, path="/L", **fields),
    }
    return makers[kind]()


FLAGS = [(kind, name) for kind in ("distant", "sphere", "rect", "disk", "cylinder", "mesh") for name in
         ("normalize", "shadows")] + [("sphere", "treat_as_point"), ("dome", "shadows")]
LIGHT_CLASSES = {"distant": "DistantLight", "sphere": "SphereLight", "rect": "RectLight", "disk": "DiskLight",
                 "cylinder": "CylinderLight", "mesh": "MeshLight", "dome": "DomeLight"}


@pytest.mark.parametrize("kind, name", FLAGS)
@pytest.mark.parametrize("value", ["false", None, np.array([True, False]), 2])
def test_a_light_flag_that_is_no_bool_is_refused_naming_the_light(kind, name, value):
    """``normalize="false"`` (any string, None, a mask) was taken by its truth: the light normalized (or its shadows
    kept) without a word, where a mesh's ``double_sided`` is refused. Refused naming the light and the field."""
    words = rf"^/L: {LIGHT_CLASSES[kind]} {name} must be True or False, got "
    with pytest.raises(TypeError, match=words):
        make_light(kind, **{name: value})


@pytest.mark.parametrize("value", [np.bool_(True), 1, np.bool_(False), 0])
def test_a_light_flag_given_as_a_numpy_bool_or_zero_one_is_the_bool_it_says(value):
    """A numpy bool (``mask[k]``) and 0 and 1 mean what they say. Oracle: a 2 x 4 rect light of colour 1 has radiance
    1 / 8 normalized and 1 otherwise."""
    light = wrt.RectLight(np.eye(4), 2.0, 4.0, WHITE, normalize=value, shadows=value)
    assert type(light.normalize) is bool and type(light.shadows) is bool
    assert light.normalize == light.shadows == bool(value)
    np.testing.assert_allclose(light.radiance, np.full(3, 1.0 / 8.0 if value else 1.0), rtol=1e-6)


def test_a_light_flag_assigned_later_is_checked_at_the_next_render_as_a_meshs_is():
    """A field assigned after construction is checked at the next render (a kept Renderer's too), as a mesh's
    ``double_sided`` is at the next trace: ``light.normalize = "false"`` normalized the light without a word."""
    ball = wrt.primitives.Shape("/Ball", "sphere", np.eye(4), double_sided=True)
    light = make_light("sphere")
    scene = wrt.Scene(shapes=[ball], lights=[light])
    renderer = wrt.Renderer(scene, camera=TOP, width=4, height=4)
    renderer.render()
    light.normalize = "false"
    with pytest.raises(TypeError, match=r"^/L: SphereLight normalize must be True or False, got str 'false'"):
        renderer.render()
    with pytest.raises(TypeError, match=r"^/L: SphereLight normalize must be True or False"):
        wrt.render(scene, camera=TOP, width=4, height=4)
    light.normalize = np.bool_(False)
    wrt.render(scene, camera=TOP, width=4, height=4)
    assert light.normalize is False


def warp_cuda(values):
    """``values`` as a ``wp.array`` on the GPU (the test skips without one), which numpy refuses to read."""
    import warp as wp

    if not wp.is_cuda_available():
        pytest.skip("needs CUDA")
    return wp.array(np.ascontiguousarray(values), device="cuda:0")


@pytest.mark.parametrize("holder", ["numpy", "list", "warp", "dlpack", "cuda"])
@pytest.mark.parametrize("kind", ["rect", "disk", "cylinder", "dome"])
def test_a_light_transform_without_its_bottom_row_is_read_as_a_shapes_is(kind, holder):
    """A light's ``(3, 4)`` affine ``to_world`` (the device's own layout, which a shape takes) was refused ("must be
    finite numbers of shape (4, 4)"); it gets the row ``(0, 0, 0, 1)``, in any holder a ``(4, 4)`` may come in.
    Oracle: the same light made from the whole matrix, and its area from the scales (2 and 3 on X and Y)."""
    m = np.diag([2.0, 3.0, 1.0, 1.0])
    m[:3, 3] = 1.0, -2.0, 3.0
    top = {"numpy": lambda a: a, "list": lambda a: a.tolist(), "warp": wp_array, "dlpack": DLPackOnly,
           "cuda": warp_cuda}[holder](m[:3])
    light = make_light(kind)
    light.to_world = top
    light.__post_init__()
    np.testing.assert_array_equal(light.to_world, m)
    assert light.to_world.dtype == np.float64
    areas = {"rect": 2.0 * 2.0 * 6.0, "disk": np.pi * 6.0}
    if kind in areas:
        np.testing.assert_allclose(light.area, areas[kind], rtol=1e-12)


@pytest.mark.parametrize("value", [np.eye(4)[:, :3], np.eye(3), np.zeros((2, 3, 4))])
def test_a_light_transform_of_another_shape_is_still_refused_naming_the_light(value):
    """A ``(4, 3)`` (row-vector affine), ``(3, 3)`` or stacked transform stays refused, naming the light."""
    with pytest.raises(wrt.SceneError, match=r"^/L: RectLight to_world must be finite numbers of shape \(4, 4\) \(or "
                                             r"its top \(3, 4\)\), got "):
        wrt.RectLight(value, 1.0, 1.0, WHITE, path="/L")


@pytest.mark.parametrize("holder", ["warp", "dlpack", "cuda"])
def test_shape_params_color_and_opacity_on_a_gpu_are_read_as_a_meshs_arrays_are(holder):
    """A shape's params, colour and opacity held as a GPU array (a ``wp.array`` on CUDA, a torch tensor: here a CPU
    array behind DLPack only) failed with numpy's refusal ("can't convert cuda:0 device type tensor to numpy"),
    naming no shape, where a mesh's arrays are copied to the host. Oracle: the same shape from numpy arrays, and the
    colour the albedo integrator shows on it."""
    make = {"warp": wp_array, "dlpack": DLPackOnly, "cuda": warp_cuda}[holder]
    color = np.float32([0.25, 0.5, 1.0])
    ball = wrt.primitives.Shape("/Ball", "capsule", np.eye(4), params=make(np.float32([0.5, 0.0, 0.0, 1.0])),
                                color=make(color), opacity=make(np.float32([1.0])), double_sided=True)
    twin = wrt.primitives.Shape("/Ball", "capsule", np.eye(4), params=np.float32([0.5, 0.0, 0.0, 1.0]), color=color,
                                opacity=1.0, double_sided=True)
    for name in ("params", "color"):
        np.testing.assert_array_equal(getattr(ball, name), getattr(twin, name))
        assert getattr(ball, name).dtype == np.float32
    assert ball.opacity == 1.0
    image = wrt.render(wrt.Scene(shapes=[ball]), camera=TOP, width=8, height=8, integrator="albedo")
    covered = image.aovs["coverage"] > 0.5
    assert covered.sum() > 0
    np.testing.assert_allclose(image.rgb[covered], np.broadcast_to(color, (int(covered.sum()), 3)), rtol=1e-6)


@pytest.mark.parametrize("name, value, need", [
    ("params", "abcd", "4 finite numbers"), ("params", [1.0, 0.0, 0.0], "4 finite numbers"),
    ("params", np.array([1, 0, 0, 1], complex), "4 finite numbers"), ("params", [True, False, False, True],
                                                                       "4 finite numbers"),
    ("color", "red", "3 finite numbers or None"), ("color", [True, False, False], "3 finite numbers or None"),
    ("color", np.ones((2, 3)), "3 finite numbers or None"),
    ("opacity", "0.5", r"a number in \[0, 1\] or None"), ("opacity", True, r"a number in \[0, 1\] or None"),
    ("opacity", [0.5, 0.5], r"a number in \[0, 1\] or None"),
    ("st", "ab", "2 finite numbers or None"), ("st", [0.5, 0.5, 0.5], "2 finite numbers or None"),
    ("st", [np.nan, 0.5], "2 finite numbers or None"),
])
def test_shape_params_color_or_opacity_that_are_no_real_numbers_are_refused_naming_the_shape(name, value, need):
    """Text, bools, complex values or a wrong count failed with numpy's message naming no shape (``could not convert
    string to float``, ``cannot reshape array of size 3``), or were taken: ``opacity="0.5"`` and ``True`` as numbers,
    bools as 0 and 1, complex values with their imaginary part dropped. Refused naming the shape, as a mesh's colours
    are, when made and when assigned later."""
    with pytest.raises(ValueError, match=rf"^shape /Ball: {name} must be {need}, got "):
        wrt.primitives.Shape("/Ball", "sphere", np.eye(4), **{name: value})
    ball = wrt.primitives.Shape("/Ball", "sphere", np.eye(4))
    scene = wrt.Scene(shapes=[ball])
    setattr(ball, name, value)
    with pytest.raises(ValueError, match=rf"^shape /Ball: {name} must be {need}, got "):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])


@pytest.mark.parametrize("kind, params, words", [
    ("capsule", (-0.5, 0.0, 0.0, 1.0), r"params\[0\] \(H, .*\) of a capsule must be >= 0, got -0\.5"),
    ("tapered", (0.0, 0.5, 0.0, 1.0), r"params\[0\] \(H, .*\) of a tapered capsule must be > 0, got 0\.0"),
    ("cone", (1.0, 2.0, 0.0, 1.0), r"params\[1\] \(rho, the top radius\) of a cone must be in \[0, 1\], got 2\.0"),
    ("cone", (1.0, -1.0, 0.0, 1.0), r"params\[1\] \(rho, the top radius\) of a cone must be in \[0, 1\], got -1\.0"),
    ("tapered", (1.0, 1.5, 0.0, 1.0), r"params\[1\] \(rho, .*\) of a tapered must be in \[0, 1\], got 1\.5"),
])
def test_shape_params_outside_their_kinds_range_are_refused_naming_the_shape(kind, params, words):
    """A capsule of negative height, a tapered capsule of none or a cone widening past its base (``rho = 2``: cut off
    at its canonical box ``[-1, 1]^3``: a ray straight down at x = 1.5 missed its top cap of radius 2) were taken
    without a word. Refused naming the shape, when made and when assigned later."""
    with pytest.raises(ValueError, match=rf"^shape /S: {words}"):
        wrt.primitives.Shape("/S", kind, np.eye(4), params=params)
    shape = wrt.primitives.Shape("/S", kind, np.eye(4), params=(1.0, 0.5, 0.0, 1.0))
    scene = wrt.Scene(shapes=[shape])
    shape.params = params
    with pytest.raises(ValueError, match=rf"^shape /S: {words}"):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])


@pytest.mark.parametrize("kind, params, t", [
    ("capsule", (0.0, 0.0, 0.0, 1.0), 4.0), ("cone", (1.0, 1.0, 0.0, 1.0), 4.0), ("cone", (1.0, 0.0, 0.0, 1.0), 4.5),
    ("tapered", (1.0, 1.0, 0.0, 1.0), 4.0),
])
def test_shape_params_at_the_ends_of_their_range_are_taken(kind, params, t):
    """The ends of the ranges stay: a capsule of ``H = 0`` (a sphere), a cone of ``rho = 1`` (a cylinder) or 0 (an
    apex), a tapered capsule of ``rho = 1`` (a capsule). Oracle: the radius at z = 0 seen by a ray from x = 5 (1, and
    0.5 halfway up a cone to its apex)."""
    scene = wrt.Scene(shapes=[wrt.primitives.Shape("/S", kind, np.eye(4), params=params)])
    np.testing.assert_allclose(wrt.trace(scene, [5.0, 0.0, 0.0], [-1.0, 0.0, 0.0]).t, [t], rtol=1e-6)


@pytest.mark.parametrize("kind", ["rect", "dome"])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int64, bool])
def test_a_light_texture_of_integer_samples_is_refused_as_a_scene_texture_is(kind, dtype):
    """A dome or rect light's ``texture`` of 8-bit samples (``uint8`` 0-255, an image straight from Pillow) was cast to
    float and lit the scene 255 times too brightly without a word, where ``scene.textures`` refuses integer samples.
    Refused naming the light; float textures of any width are taken, as float32."""
    texture = np.full((2, 4, 3), 128).astype(dtype)
    with pytest.raises(wrt.SceneError, match=rf"^/L: {LIGHT_CLASSES[kind]} texture must hold linear float values, "
                                             rf"got {np.dtype(dtype)} \(an 8-bit image"):
        make_light(kind, texture=texture)
    light = make_light(kind, texture=np.full((2, 4, 3), 0.5, np.float64))
    assert light.texture.dtype == np.float32
    np.testing.assert_array_equal(light.texture, np.full((2, 4, 3), 0.5))


@pytest.mark.parametrize("kind, words", [
    ("Sphere", r"'Sphere' \(did you mean 'sphere'\?\)"), (["sphere"], r"\['sphere'\]"), (None, "None"),
])
def test_an_unknown_shape_kind_is_refused_naming_the_shape(kind, words):
    """An unknown kind was refused naming no shape ("unknown shape kind 'Sphere'"), and a list failed with Python's
    "unhashable type: 'list'"; refused naming the shape, with the kind meant where one is close."""
    with pytest.raises(ValueError, match=rf"^shape /S: unknown shape kind {words}; valid kinds: sphere, box, "):
        wrt.primitives.Shape("/S", kind, np.eye(4))


@pytest.mark.parametrize("name", ["intensity", "exposure", "colorTemperature"])
def test_a_usdlux_input_that_is_no_light_field_is_refused_at_the_next_render(name):
    """``light.intensity = 2`` (or ``exposure``, UsdLux's names; wrt folds them into ``color``) was kept as an
    attribute no render reads: the light shone on as before without a word. The next render refuses it naming the
    light and the attribute."""
    ball = wrt.primitives.Shape("/Ball", "sphere", np.eye(4), double_sided=True)
    light = make_light("rect")
    scene = wrt.Scene(shapes=[ball], lights=[light])
    wrt.render(scene, camera=TOP, width=4, height=4)
    setattr(light, name, 2.0)
    with pytest.raises(wrt.SceneError, match=rf"^/L: RectLight has no field {name}: its color is UsdLux's intensity "):
        wrt.render(scene, camera=TOP, width=4, height=4)


def test_a_shape_whose_box_is_past_float32_is_refused_naming_it():
    """A sphere of radius 1e39 built in Python failed at the trace with "triangle vertices must be finite (found NaN
    or inf); triangle 0 uses one", and a render without a camera with "look_at: eye must be 3 finite numbers", naming
    no shape (``load_usd`` refuses such a gprim, and a mesh such points). Refused naming the shape, in the world and in
    a prototype, by a trace, a render and ``Scene.bounds()``; a radius of 1e30 stays. Oracle: a ray from 3e30 meets
    that sphere at t = 2e30."""
    def ball(radius: float) -> wrt.primitives.Shape:
        return wrt.primitives.Shape("/Ball", "sphere", np.diag([radius, radius, radius, 1.0]))

    words = (r"^shape /Ball: its box, \[-1e\+39, -1e\+39, -1e\+39\] to \[1e\+39, 1e\+39, 1e\+39\], is past "
             r"float32's range")
    with pytest.raises(ValueError, match=words):
        wrt.trace(wrt.Scene(shapes=[ball(1e39)]), [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])
    with pytest.raises(ValueError, match=words):
        wrt.render(wrt.Scene(shapes=[ball(1e39)]), width=4, height=4)
    with pytest.raises(ValueError, match=words):
        wrt.Scene(shapes=[ball(1e39)]).bounds()
    prototype = wrt.Prototype("/P", [], shapes=[ball(1e39)])
    scene = wrt.Scene(prototypes=[prototype], instances=wrt.Instances.from_transforms([0], np.eye(4)[None]))
    with pytest.raises(ValueError, match=words):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])
    hits = wrt.trace(wrt.Scene(shapes=[ball(1e30)]), [0.0, 0.0, 3e30], [0.0, 0.0, -1.0])
    np.testing.assert_allclose(hits.t, [2e30], rtol=1e-6)


def test_a_usdlux_input_given_since_a_kept_renderer_was_built_is_refused_at_its_next_render():
    """A kept Renderer follows its lights by their fields, and ``light.exposure = 2`` adds none: its next render
    went on without a word, where a new render refuses it. It refuses it too, naming the light and the attribute."""
    ball = wrt.primitives.Shape("/Ball", "sphere", np.eye(4), double_sided=True)
    light = make_light("rect")
    renderer = wrt.Renderer(wrt.Scene(shapes=[ball], lights=[light]), camera=TOP, width=4, height=4)
    renderer.render()
    light.exposure = 2.0
    with pytest.raises(wrt.SceneError, match=r"^/L: RectLight has no field exposure: its color is UsdLux's "):
        renderer.render()
