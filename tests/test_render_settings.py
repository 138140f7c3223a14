"""UsdRender render settings: the stage's camera, resolution, aspect ratio conform policy, data window and purposes,
from Python and ``wrt render``; explicit options win; bad settings are errors naming the file and the prim."""

import warnings

import numpy as np
import pytest
from usda_text import load, preview_material, write

import wrt
from wrt.cli import main
from wrt.rays import camera_rays
from wrt.render import resolve_view

SCENE = """#usda 1.0
(
    {metadata}
)
def Xform "World"
{{
    def Cube "Box"
    {{
        double size = 1
        color3f[] primvars:displayColor = [(0.8, 0.2, 0.2)]
    }}
    def Sphere "Ball"
    {{
        double radius = 0.3
        double3 xformOp:translate = (1, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def Camera "Front"
    {{
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def Camera "Side"
    {{
        float focalLength = 10
        float horizontalAperture = 20
        float verticalAperture = 10
        {side}
    }}
}}
def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        {settings}
    }}
    def RenderSettings "Other"
    {{
        uniform int2 resolution = (24, 24)
    }}
    def RenderProduct "Product"
    {{
        {product}
    }}
}}
"""
SIDE_POSE = """double3 xformOp:translate = (0.5, 0.3, 4)
        uniform token[] xformOpOrder = ["xformOp:translate"]"""
DEFAULT_SETTINGS = """rel camera = </World/Side>
        uniform int2 resolution = (64, 32)"""


def write_stage(tmp_path, settings=DEFAULT_SETTINGS, product="", side=SIDE_POSE,
                metadata='renderSettingsPrimPath = "/Render/Settings"', name="stage.usda"):
    path = tmp_path / name
    path.write_text(SCENE.format(metadata=metadata, settings=settings, product=product, side=side))
    return path


def render_npy(tmp_path, stage, *options, name="out.npy"):
    out = tmp_path / name
    assert main(["render", str(stage), "-o", str(out), "-q", *options]) == 0
    return np.load(out)


def test_cli_follows_the_render_settings_camera_and_resolution(tmp_path):
    """Without --camera, --width and --height, the stage's RenderSettings choose them: a 64x32 image seen from its
    camera (the second of two), the same pixels as naming both. wrt rendered 640x480 from the first camera."""
    stage = write_stage(tmp_path)
    settled = render_npy(tmp_path, stage, name="settled.npy")
    assert settled.shape == (32, 64, 3)
    explicit = render_npy(tmp_path, stage, "--camera", "/World/Side", "--width", "64", "--height", "32",
                          name="explicit.npy")
    np.testing.assert_array_equal(settled, explicit)
    front = render_npy(tmp_path, stage, "--camera", "/World/Front", name="front.npy")
    assert front.shape == (32, 64, 3) and not np.array_equal(front, settled)  # --camera wins over the settings'
    half = render_npy(tmp_path, stage, "--width", "32", name="half.npy")
    assert half.shape == (16, 32, 3)  # one size alone keeps the settings' 2:1 (it rendered 32x32)
    tall = render_npy(tmp_path, stage, "--height", "5", name="tall.npy")
    assert tall.shape == (5, 10, 3)
    wide = render_npy(tmp_path, stage, "--width", "40", "--height", "32", name="wide.npy")
    assert wide.shape == (32, 40, 3)  # both given: another aspect, the film following the conform policy


def test_python_follows_the_render_settings_unless_told_otherwise(tmp_path):
    scene = wrt.load_usd(write_stage(tmp_path))
    settings = scene.render_settings
    assert (settings.path, settings.camera, settings.resolution) == ("/Render/Settings", "/World/Side", (64, 32))
    assert settings.conform_policy == "expandAperture" and settings.pixel_aspect_ratio == 1.0  # the fallbacks
    assert wrt.render(scene).rgb.shape == (32, 64, 3)
    assert wrt.render(scene, width=20, height=10).rgb.shape == (10, 20, 3)
    renderer = wrt.Renderer(scene)
    assert renderer.camera.path == "/World/Side" and renderer.camera.fit == "expandAperture"
    own = wrt.Camera.look_at((0, 0, 5), (0, 0, 0))
    assert wrt.Renderer(scene, camera=own).camera is own  # a Camera object is the caller's, used as it is
    # Another RenderSettings prim, and a stage without any: wrt's defaults.
    assert wrt.load_usd(scene.source, render_settings="/Render/Other").render_settings.resolution == (24, 24)
    plain = wrt.load_usd(write_stage(tmp_path, metadata="", name="plain.usda"))
    assert plain.render_settings is None
    assert wrt.Renderer(plain).camera.path == "/World/Front" and wrt.Renderer(plain).width == 640


def test_the_first_render_product_overrides_what_it_authors(tmp_path):
    settings = DEFAULT_SETTINGS + "\n        rel products = [</Render/Product>]"
    product = ('rel camera = </World/Front>\n        uniform int2 resolution = (16, 8)\n'
               '        token productName = "x.exr"')
    scene = wrt.load_usd(write_stage(tmp_path, settings=settings, product=product))
    s = scene.render_settings
    assert (s.product, s.camera, s.resolution, s.product_name) == ("/Render/Product", "/World/Front", (16, 8), "x.exr")
    assert s.conform_policy == "expandAperture"  # not authored on the product: the settings' value


# Film (width, height) of the Side camera (apertures 20 x 10) per policy, worked out by hand from the schema's words:
# the image aspect is pixelAspectRatio * width / height; expand grows an aperture, crop shrinks one, the adjust
# policies change the one they name, adjustPixelAspectRatio keeps both.
CONFORM_CASES = [
    # (resolution, pixelAspectRatio, policy, film)
    ((30, 30), 1.0, "expandAperture", (20, 20)),
    ((30, 30), 1.0, "cropAperture", (10, 10)),
    ((30, 30), 1.0, "adjustApertureWidth", (10, 10)),
    ((30, 30), 1.0, "adjustApertureHeight", (20, 20)),
    ((30, 30), 1.0, "adjustPixelAspectRatio", (20, 10)),
    ((60, 20), 1.0, "expandAperture", (30, 10)),
    ((60, 20), 1.0, "cropAperture", (20, 20 / 3)),
    ((60, 20), 1.0, "adjustApertureWidth", (30, 10)),
    ((60, 20), 1.0, "adjustApertureHeight", (20, 20 / 3)),
    ((60, 20), 1.0, "adjustPixelAspectRatio", (20, 10)),
    ((40, 20), 0.5, "expandAperture", (20, 20)),  # non-square pixels: an image of aspect 1
    ((40, 20), 0.5, "cropAperture", (10, 10)),
    ((30, 30), 2.0, "cropAperture", (20, 10)),  # pixels twice as wide: the image has the aperture's aspect
]


@pytest.mark.parametrize("resolution, ratio, policy, film", CONFORM_CASES)
def test_conform_policies_give_the_film_the_schema_describes(tmp_path, resolution, ratio, policy, film):
    """Every camera ray of the settings' view against the ray through the same pixel centre of the film worked out
    by hand (camera at the origin looking down -Z, focal length 10)."""
    settings = (f"rel camera = </World/Side>\n        uniform int2 resolution = ({resolution[0]}, {resolution[1]})\n"
                f'        uniform float pixelAspectRatio = {ratio}\n        uniform token aspectRatioConformPolicy = '
                f'"{policy}"')
    scene = wrt.load_usd(write_stage(tmp_path, settings=settings, side=""))
    cam, w, h = resolve_view(scene)
    assert (w, h) == resolution
    _, directions = camera_rays(scene, cam, w, h)
    x = ((np.arange(w) + 0.5) / w - 0.5) * film[0] / 10.0
    y = (0.5 - (np.arange(h) + 0.5) / h) * film[1] / 10.0
    expected = np.stack(np.broadcast_arrays(x[None, :], y[:, None], -1.0), axis=-1).reshape(-1, 3)
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(directions, expected, atol=2e-6)


def test_camera_rays_are_the_rays_of_the_shot(tmp_path):
    """camera_rays (the primary rays of wrt bench) followed no render settings: 320x240 rays from the stage's first
    camera (/World/Front), not the 32x16 the shot renders from /World/Side through its data window. They are the
    render's own rays: each hits what the render's pixel shows, at its depth, and ray_set's primary rays are them."""
    from wrt.rays import ray_set

    window = DEFAULT_SETTINGS + ('\n        uniform token aspectRatioConformPolicy = "cropAperture"'
                                 "\n        uniform float4 dataWindowNDC = (0.25, 0, 0.75, 0.5)")
    scene = wrt.load_usd(write_stage(tmp_path, settings=window))
    origins, directions = camera_rays(scene)
    assert origins.shape == directions.shape == (32 * 16, 3)
    image = wrt.render(scene, device="cpu")
    hits = wrt.trace(scene, origins, directions)
    assert 0.1 < hits.hit.mean() < 1.0  # the box and the sky: a real check of where the rays go
    np.testing.assert_array_equal(image.aovs["prim"].ravel(), hits.prim)
    np.testing.assert_allclose(image.aovs["depth"].ravel()[hits.hit], hits.t[hits.hit], rtol=1e-6)
    np.testing.assert_allclose(origins, np.broadcast_to(scene.cameras["/World/Side"].eye, origins.shape), atol=1e-6)
    # The directions of the Side camera's film (focal length 10, apertures 20 x 10, cropAperture at 64x32: the whole
    # film) through the centres of pixels 16..47 of the bottom 16 rows.
    x = ((np.arange(16, 48) + 0.5) / 64 - 0.5) * 20 / 10
    y = (0.5 - (np.arange(16, 32) + 0.5) / 32) * 10 / 10
    expected = np.stack(np.broadcast_arrays(x[None, :], y[:, None], -1.0), axis=-1).reshape(-1, 3)
    np.testing.assert_allclose(directions, expected / np.linalg.norm(expected, axis=1, keepdims=True), atol=2e-6)
    # Explicit arguments still win; ray_set's primary rays are the shot's at about n rays.
    assert camera_rays(scene, "/World/Front", 8, 6)[0].shape == (8 * 6 // 4, 3)  # Front, cropped to its window
    np.testing.assert_array_equal(ray_set(scene, "primary", 32 * 16)[1], directions)


def test_plain_renders_keep_the_horizontal_aperture():
    """wrt's fit without render settings is UsdRender's adjustApertureHeight."""
    cam = wrt.Camera(horizontal_aperture=20, vertical_aperture=10)
    for size in ((30, 30), (60, 20)):
        assert cam.film_size(*size) == wrt.Camera(horizontal_aperture=20, vertical_aperture=10,
                                                  fit="adjustApertureHeight").film_size(*size)


def test_data_window_renders_the_pixels_inside_it(tmp_path):
    """dataWindowNDC (0.25, 0.5, 0.75, 1) of a 64x32 image: pixel centres from x = 16.5 to 47.5 and the top half of
    the rows (NDC y from the bottom), each rendered where it lies in the full image."""
    full = render_npy(tmp_path, write_stage(tmp_path), name="full.npy")
    window = DEFAULT_SETTINGS + "\n        uniform float4 dataWindowNDC = (0.25, 0.5, 0.75, 1)"
    crop = render_npy(tmp_path, write_stage(tmp_path, settings=window, name="crop.usda"), name="crop.npy")
    assert crop.shape == (16, 32, 3)
    np.testing.assert_allclose(crop, full[:16, 16:48], atol=1e-5)
    # A batch of a stage camera (cropped) and a Camera object (not cropped) would have two image sizes.
    scene = wrt.load_usd(tmp_path / "crop.usda")
    with pytest.raises(ValueError, match="crops the stage's cameras but not wrt.Camera objects"):
        wrt.Renderer(scene, cameras=["/World/Side", wrt.Camera.look_at((0, 0, 5), (0, 0, 0))])
    assert wrt.Renderer(scene, cameras=["/World/Side", "/World/Front"]).width == 32
    # A window between pixel centres holds none: a named error, not an empty image.
    thin = DEFAULT_SETTINGS + "\n        uniform float4 dataWindowNDC = (0.5, 0, 0.505, 1)"
    with pytest.raises(wrt.SceneError, match=r"thin.usda: /Render/Settings: dataWindowNDC .* holds no pixel centre"):
        wrt.render(wrt.load_usd(write_stage(tmp_path, settings=thin, name="thin.usda")))


NO_CAMERA = """#usda 1.0
(
    renderSettingsPrimPath = "/Render/Settings"
)
def Cube "Box"
{{
    double size = 1
    color3f[] primvars:displayColor = [(0.8, 0.2, 0.2)]
}}
def Sphere "Ball"
{{
    double radius = 0.3
    double3 xformOp:translate = (1, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        uniform int2 resolution = (64, 32)
        {window}
    }}
}}
"""


def test_data_window_crops_the_camera_that_frames_a_stage_without_cameras(tmp_path):
    """A stage without cameras is seen by a camera wrt makes to frame it; it took the settings' 64x32 but not their
    data window, rendering all 64x32 pixels where the window (0.25, 0.5, 0.75, 1) holds the top middle 32x16."""
    full = tmp_path / "full.usda"
    full.write_text(NO_CAMERA.format(window=""))
    crop = tmp_path / "crop.usda"
    crop.write_text(NO_CAMERA.format(window="uniform float4 dataWindowNDC = (0.25, 0.5, 0.75, 1)"))
    whole = render_npy(tmp_path, full, name="full.npy")
    assert whole.shape == (32, 64, 3)
    cropped = render_npy(tmp_path, crop, name="crop.npy")
    assert cropped.shape == (16, 32, 3)
    np.testing.assert_allclose(cropped, whole[:16, 16:48], atol=1e-5)
    assert (cropped.max(axis=-1) > 0.05).mean() > 0.1  # the box is in the window: not a blank image that matches


def test_set_cameras_keeps_the_data_window_rule(tmp_path):
    """set_cameras follows the rule of the constructor: under a data window a stage camera (cropped to 32x16) and a
    Camera object (64x32) make images of two sizes, so a renderer of one kind refuses cameras of the other. The
    cropped film was drawn at the renderer's 64x32 (the window's pixels twice over, not the image the stage's
    camera gives), and a Camera object at the cropped 32x16. The refusal said 'give cameras of one kind', though the
    call gave one kind: it names the cameras' size and the renderer's."""
    window = DEFAULT_SETTINGS + "\n        uniform float4 dataWindowNDC = (0.25, 0.5, 0.75, 1)"
    scene = wrt.load_usd(write_stage(tmp_path, settings=window))
    look = wrt.Camera.look_at((0, 0, 5), (0, 0, 0))
    for first, other, sizes in ((look, "/World/Side", ("32x16", "64x32")), ("/World/Side", look, ("64x32", "32x16"))):
        renderer = wrt.Renderer(scene, cameras=[first])
        with pytest.raises(ValueError, match=rf"^set_cameras: these cameras' images are {sizes[0]} but the "
                                             rf"renderer's are {sizes[1]} \(the render settings' dataWindowNDC"):
            renderer.set_cameras([other])
        assert f"{renderer.width}x{renderer.height}" == sizes[1]
    renderer = wrt.Renderer(scene, cameras=["/World/Front"])
    renderer.set_cameras(["/World/Side"])  # stage cameras, one size: as a renderer made with it
    image = renderer.render().image(0).rgb
    np.testing.assert_array_equal(image, wrt.render(scene, camera="/World/Side").rgb)


def test_disable_depth_of_field_makes_stage_cameras_pinholes(tmp_path):
    side = SIDE_POSE + "\n        float fStop = 2\n        float focusDistance = 4"
    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + "\n        uniform bool disableDepthOfField = 1",
                        side=side)
    scene = wrt.load_usd(stage)
    assert scene.cameras["/World/Side"].f_stop == 2
    assert resolve_view(scene)[0].f_stop == 0


def test_included_purposes_choose_what_is_drawn(tmp_path):
    """includedPurposes = [guide]: guide prims are drawn with default ones (always drawn), render ones are not."""
    stage = tmp_path / "purposes.usda"
    stage.write_text("""#usda 1.0
(
    renderSettingsPrimPath = "/Render/S"
)
def Cube "Plain" {
}
def Sphere "Guide" {
    uniform token purpose = "guide"
}
def Cone "RenderOnly" {
    uniform token purpose = "render"
}
def Scope "Render" {
    def RenderSettings "S" {
        uniform token[] includedPurposes = ["guide"]
    }
}
""")
    scene = wrt.load_usd(stage)
    assert sorted(s.path for s in scene.shapes) == ["/Guide", "/Plain"]
    assert scene.render_settings.included_purposes == ("default", "guide")




@pytest.mark.parametrize("authored", ['string includedPurposes = "guide"', "asset includedPurposes = @guide@",
                                      'string materialBindingPurposes = "full"', "int[] includedPurposes = [1]"])
def test_purposes_that_are_no_array_of_tokens_raise_a_scene_error_naming_them(tmp_path, authored):
    """``includedPurposes`` and ``materialBindingPurposes`` are ``token[]`` in USD's schema; authored as a ``string``
    the purposes were its letters (``"guide"`` drew no guide prim, without a word), as an ``asset`` the load stopped
    with a TypeError. Like the settings' other values of the wrong type, a SceneError names the file, the prim and
    the attribute."""
    from pxr import Usd

    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + "\n        uniform " + authored)
    name = authored.split()[1]
    opened = Usd.Stage.Open(str(stage))
    definition = opened.GetPrimAtPath("/Render/Settings").GetPrimDefinition()
    assert str(definition.GetSchemaAttributeSpec(name).typeName) == "token[]"  # USD's type, which is not authored
    with pytest.raises(wrt.SceneError, match=rf"stage.usda.*/Render/Settings.*{name} must be an array of tokens"):
        wrt.load_usd(stage)


@pytest.mark.parametrize("name", ["includedPurposes", "materialBindingPurposes"])
def test_purposes_authored_as_a_string_array_raise_a_scene_error_naming_them(tmp_path, name):
    """A ``string[]`` of purposes reads in Python as the same words, but it is not the schema's ``token[]``: USD's
    typed read (``Get<VtTokenArray>``, as UsdImaging reads the settings) fails on it and gives the schema's fallback,
    so ``"guide"`` in it draws no guide prim in USD's renderers. wrt took the words; now a SceneError names it, as
    for the other types that are no token array."""
    from pxr import Sdf, Usd

    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + f'\n        uniform string[] {name} = ["guide"]')
    opened = Usd.Stage.Open(str(stage))
    attr = opened.GetPrimAtPath("/Render/Settings").GetAttribute(name)
    assert list(attr.Get()) == ["guide"]  # what Python's untyped read gives
    assert attr.GetPropertyStack()[0].typeName == Sdf.ValueTypeNames.StringArray  # not the schema's token[]
    with pytest.raises(wrt.SceneError, match=rf"stage.usda.*/Render/Settings.*{name} must be an array of tokens"):
        wrt.load_usd(stage)


def test_blocked_settings_values_are_the_schemas_fallbacks(tmp_path):
    """A value block (``= None``) on the settings is no value: the schema's fallback, as USD's prim definition gives
    it, as where nothing is authored; on a product, the settings' value, which it does not override. A blocked
    resolution or data window stopped the load with a bare TypeError ('NoneType' object is not iterable), a blocked
    pixelAspectRatio likewise, a blocked conform policy was the policy 'None', and a blocked includedPurposes hid
    render-purpose prims."""
    from pxr import Usd

    blocked = ("uniform int2 resolution = None", "uniform float pixelAspectRatio = None",
               "uniform token aspectRatioConformPolicy = None", "uniform float4 dataWindowNDC = None",
               "uniform bool disableDepthOfField = None", "uniform token[] includedPurposes = None")
    settings = "rel camera = </World/Side>\n        " + "\n        ".join(blocked)
    product = "uniform int2 resolution = None\n        uniform float pixelAspectRatio = 2"
    stage = write_stage(tmp_path, settings=settings + "\n        rel products = </Render/Product>", product=product)
    opened = Usd.Stage.Open(str(stage))
    definition = opened.GetPrimAtPath("/Render/Settings").GetPrimDefinition()
    fallback = {name: definition.GetAttributeFallbackValue(name) for name in (
        "resolution", "pixelAspectRatio", "aspectRatioConformPolicy", "dataWindowNDC", "disableDepthOfField",
        "includedPurposes")}
    got = wrt.load_usd(stage).render_settings
    assert got.product == "/Render/Product"
    assert got.resolution == tuple(fallback["resolution"])
    assert got.pixel_aspect_ratio == 2.0  # the product's own
    assert got.conform_policy == fallback["aspectRatioConformPolicy"]
    assert got.data_window == tuple(fallback["dataWindowNDC"])
    assert got.disable_depth_of_field is fallback["disableDepthOfField"]
    assert set(got.included_purposes) == {"default", *fallback["includedPurposes"]}
    view = write_stage(tmp_path, settings=settings, name="plain.usda")
    assert wrt.load_usd(view).render_settings.pixel_aspect_ratio == fallback["pixelAspectRatio"]

BAD_SETTINGS = [
    ("rel camera = </World/Box>", r"camera relationship targets /World/Box, which is a Cube"),
    ("rel camera = </World/Nothing>", r"camera relationship targets /World/Nothing, which is no prim"),
    ("uniform int2 resolution = (0, 32)", r"resolution 0x32 must be positive"),
    ("uniform int2 resolution = (64, -2)", r"resolution 64x-2 must be positive"),
    ("uniform float pixelAspectRatio = nan", r"pixelAspectRatio must be a finite positive"),
    ('uniform token aspectRatioConformPolicy = "stretch"', r"aspectRatioConformPolicy 'stretch' is none of"),
    ("uniform float4 dataWindowNDC = (0.5, 0, 0.2, 1)", r"dataWindowNDC \(0.5, 0, 0.2, 1\) must be finite"),
    # Values of another type than the schema's stopped the load with Python's "too many values to unpack" (a string
    # resolution), "'int' object is not iterable", "must be real number, not str" or "tuple index out of range".
    ('uniform string resolution = "64x32"', r"resolution must be 2 numbers, got '64x32'"),
    ("uniform int resolution = 64", r"resolution must be 2 numbers, got 64"),
    ('uniform string pixelAspectRatio = "wide"', r"pixelAspectRatio must be 1 number, got 'wide'"),
    ("uniform float2 dataWindowNDC = (0, 1)", r"dataWindowNDC must be 4 numbers"),
]


@pytest.mark.parametrize("settings, message", BAD_SETTINGS)
def test_bad_settings_are_errors_naming_the_file_and_prim(tmp_path, settings, message):
    stage = write_stage(tmp_path, settings=settings)
    with pytest.raises(wrt.SceneError, match=r"stage.usda: /Render/Settings: " + message):
        wrt.load_usd(stage)


def test_a_bad_product_value_names_the_product(tmp_path):
    settings = DEFAULT_SETTINGS + "\n        rel products = [</Render/Product>]"
    stage = write_stage(tmp_path, settings=settings, product="uniform int2 resolution = (0, 0)")
    # Left out naming it, as any product that cannot be read (test_render_products); the settings' own values stay.
    with pytest.warns(UserWarning, match=r"stage.usda: /Render/Product: resolution 0x0 must be positive; this "
                      "RenderProduct is left out"):
        scene = wrt.load_usd(stage)
    assert scene.render_settings.products == () and scene.render_settings.product == ""


# Values authored with another type than the schema's: Python's Get hands them back, and wrt rendered them as
# authored, but UsdRenderComputeSpec reads each with Get<T> of the schema's type (GfVec2i resolution, float
# pixelAspectRatio, TfToken aspectRatioConformPolicy, GfVec4f dataWindowNDC, bool disableDepthOfField), which passes
# them over for the schema's fallback: usdview's and RenderMan's image is another.
MISTYPED_SETTINGS = [
    ("uniform float2 resolution = (64, 32)", r"float2 resolution = \(64, 32\), not the schema's int2"),
    ("uniform double pixelAspectRatio = 2", r"double pixelAspectRatio = 2.0, not the schema's float"),
    ('uniform string aspectRatioConformPolicy = "cropAperture"',
     r"string aspectRatioConformPolicy = 'cropAperture', not the schema's token"),
    ("uniform double4 dataWindowNDC = (0, 0, 0.5, 1)", r"double4 dataWindowNDC = \(0, 0, 0.5, 1\), not the schema's "
                                                       r"float4"),
    ("uniform int disableDepthOfField = 1", r"int disableDepthOfField = 1, not the schema's bool"),
]


@pytest.mark.parametrize("authored, words", MISTYPED_SETTINGS)
def test_a_settings_value_of_another_type_than_the_schemas_is_an_error_and_a_products_leaves_it_out(tmp_path,
                                                                                                  authored, words):
    """The schema's type for each attribute is USD's own (``UsdRender.Settings`` attribute ``GetTypeName``); on the
    settings prim the value is an error naming the file, the prim, the type and the value, as the README says of a
    value of another type than the schema's; on a product it leaves the product out with a warning naming it."""
    from pxr import Sdf, Usd, UsdRender

    kind, name = authored.split()[1:3]
    memory = Usd.Stage.CreateInMemory()
    schema_type = UsdRender.Settings.Define(memory, "/S").GetPrim().GetAttribute(name).GetTypeName()
    assert words.endswith(str(schema_type)) and schema_type != Sdf.ValueTypeNames.Find(kind)
    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS.replace("uniform int2 resolution = (64, 32)", "")
                        + f"\n        {authored}")
    with pytest.raises(wrt.SceneError, match=rf"stage.usda: /Render/Settings: {words}: UsdRenderComputeSpec passes"):
        wrt.load_usd(stage)
    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + "\n        rel products = [</Render/Product>]",
                        product=authored, name="product.usda")
    with pytest.warns(UserWarning, match=rf"product.usda: /Render/Product: {words}: .*; this RenderProduct is left "):
        scene = wrt.load_usd(stage)
    assert scene.render_settings.products == () and scene.render_settings.resolution == (64, 32)


@pytest.mark.parametrize("authored, words", [
    ('string productName = "beauty.exr"', "string productName = 'beauty.exr', not the schema's token"),
    ('uniform string productType = "raster"', "string productType = 'raster', not the schema's token"),
    ("uniform int dataType = 3", "RenderVar /Render/Product/V: int dataType = 3, not the schema's token"),
    ('uniform token sourceName = "depth"', "RenderVar /Render/Product/V: token sourceName = 'depth', not the "
                                           "schema's string"),
    ('uniform string sourceType = "raw"', "RenderVar /Render/Product/V: string sourceType = 'raw', not the schema's "
                                          "token"),
])
def test_a_product_name_type_or_render_var_of_another_type_than_the_schemas_leaves_the_product_out(tmp_path,
                                                                                                   authored, words):
    """productName, productType and a RenderVar's sourceName, sourceType and dataType of another type than the
    schema's (USD's own: the ``UsdRender.Product`` and ``UsdRender.Var`` attribute's ``GetTypeName``) were read as
    authored (a ``string productName`` named the file, an ``int dataType`` was '3'), where UsdRenderComputeSpec's
    typed reads pass them over. Now the product is left out with a warning naming it, the RenderVar, the attribute,
    its type and value, as for the product's other values."""
    from pxr import Sdf, Usd, UsdRender

    kind, name = authored.removeprefix("uniform ").split()[:2]
    memory = Usd.Stage.CreateInMemory()
    schema = UsdRender.Var.Define(memory, "/V") if "RenderVar" in words else UsdRender.Product.Define(memory, "/P")
    schema_type = schema.GetPrim().GetAttribute(name).GetTypeName()
    assert words.endswith(str(schema_type)) and schema_type != Sdf.ValueTypeNames.Find(kind)
    var = 'def RenderVar "V"\n        {\n            %s\n        }' % authored
    product = (f"rel orderedVars = </Render/Product/V>\n        {var}" if "RenderVar" in words else authored)
    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + "\n        rel products = [</Render/Product>]",
                        product=product)
    with pytest.warns(UserWarning, match=rf"stage.usda: /Render/Product: {words}: UsdRenderComputeSpec passes .*; "
                      "this RenderProduct is left out"):
        scene = wrt.load_usd(stage)
    assert scene.render_settings.products == ()


def test_a_bad_settings_camera_is_one_error_naming_the_settings_though_a_product_takes_it(tmp_path):
    """The settings' own camera was checked in each product that took it: every such product was left out with a
    warning naming the settings prim as the product ('/Render/Settings: camera relationship targets /World/Box ...;
    this RenderProduct is left out'), and then the load failed with the same words. It is one error, as the settings'
    other values are."""
    settings = "rel camera = </World/Box>\n        rel products = [</Render/Product>]"
    stage = write_stage(tmp_path, settings=settings, product="uniform int2 resolution = (16, 8)")
    with warnings.catch_warnings(record=True) as said, pytest.raises(
            wrt.SceneError, match=r"stage.usda: /Render/Settings: camera relationship targets /World/Box, which is a "
                                  r"Cube, not a Camera"):
        warnings.simplefilter("always")
        wrt.load_usd(stage)
    assert [str(w.message) for w in said] == []


def test_a_misspelt_render_settings_path_names_the_one_meant(tmp_path, capsys):
    """The error listed the RenderSettings prims of the stage but named none as the one meant, as --camera does."""
    stage = write_stage(tmp_path)
    assert main(["render", str(stage), "--render-settings", "/Render/Setings", "-o", str(tmp_path / "x.png")]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error:")]
    assert len(errors) == 1 and "(did you mean '/Render/Settings'?)" in errors[0], errors


def test_render_settings_that_are_not_a_settings_prim_are_named(tmp_path, capsys):
    stage = write_stage(tmp_path)
    with pytest.raises(wrt.SceneError, match=r"stage.usda: /World/Box is a Cube, not a RenderSettings prim; "
                       r"RenderSettings prims in the stage: /Render/Settings, /Render/Other"):
        wrt.load_usd(stage, render_settings="/World/Box")
    # A stale renderSettingsPrimPath (the settings were deleted or renamed) is named in a warning; the stage loads with
    # wrt's defaults instead of failing for settings nobody asked for.
    stale = write_stage(tmp_path, metadata='renderSettingsPrimPath = "/Render/Gone"', name="gone.usda")
    with pytest.warns(UserWarning, match=r"gone.usda: /Render/Gone \(the stage's renderSettingsPrimPath\) is nothing, "
                      r"not a RenderSettings prim; RenderSettings prims in the stage: /Render/Settings, /Render/Other; "
                      "it is ignored"):
        scene = wrt.load_usd(stale)
    assert scene.render_settings is None
    assert wrt.render(scene, device="cpu").rgb.shape == (480, 640, 3)  # wrt's default size
    assert main(["render", str(stage), "--render-settings", "/World", "-o", str(tmp_path / "x.png"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("wrt: error: ") and "stage.usda: /World is a Xform, not a RenderSettings" in err[-1]


def test_rendering_color_space_other_than_linear_rec709_is_warned_about(tmp_path):
    """wrt renders in linear Rec.709 and converts nothing: another renderingColorSpace is said once, at load."""
    space = '\n        uniform token renderingColorSpace = "lin_ap1_scene"'
    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + space)
    with pytest.warns(UserWarning, match=r"stage.usda: /Render/Settings: renderingColorSpace 'lin_ap1_scene' is not "
                      r"linear Rec.709 \(lin_rec709_scene\), which wrt renders in; colours are not converted"):
        assert wrt.load_usd(stage).render_settings.rendering_color_space == "lin_ap1_scene"
    linear = write_stage(tmp_path, settings=DEFAULT_SETTINGS + '\n        uniform token renderingColorSpace = '
                         '"lin_rec709_scene"', name="linear.usda")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wrt.load_usd(linear)


BINDINGS = """def Xform "W" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding:preview = </Green>
    def Mesh "Q" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        rel material:binding = </Red>
        rel material:binding:full = </Blue>
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-2, -1, 0), (-0.2, -1, 0), (-0.2, 1, 0), (-2, 1, 0)]
    }
    def Mesh "P" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        rel material:binding = </Red>
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0.2, -1, 0), (2, -1, 0), (2, 1, 0), (0.2, 1, 0)]
    }
    def Camera "Cam"
    {
        double3 xformOp:translate = (0, 0, 6)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def RenderSettings "S"
{
    rel camera = </W/Cam>
    uniform int2 resolution = (24, 12)
    %s
}
"""
RED, GREEN, BLUE, GREY = (0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.1, 0.1, 0.9), "default"


@pytest.mark.parametrize("purposes, q, p", [
    (None, BLUE, RED),  # not authored: full (falling back to all-purpose)
    ('["preview", ""]', GREEN, GREEN),  # preview bindings win, the one inherited from /W too
    ('["", "full"]', RED, RED),
    ('["full", "preview"]', BLUE, GREEN),  # P has no full binding of its own: its turn passes to preview
    ('["full"]', BLUE, GREY),  # all-purpose bindings not listed: P is unbound
])
def test_material_binding_purposes_choose_the_material_drawn(tmp_path, purposes, q, p):
    materials = "".join(preview_material(c).replace('"M"', f'"{n}"').replace("</M/", f"</{n}/")
                        for n, c in (("Red", RED), ("Green", GREEN), ("Blue", BLUE)))
    settings = f"uniform token[] materialBindingPurposes = {purposes}" if purposes else ""
    stage = write(tmp_path, BINDINGS % settings + materials)
    scene = load(stage, render_settings="/S")
    image = wrt.render(scene, integrator="albedo", device="cpu")
    prim = image.aovs["prim"]
    for triangles, expected in (((0, 1), q), ((2, 3), p)):
        albedo = image.aovs["albedo"][np.isin(prim, triangles)]
        assert len(albedo) > 10
        if expected == GREY:
            assert all(not np.allclose(albedo, c, atol=1e-6) for c in (RED, GREEN, BLUE))
        else:
            np.testing.assert_allclose(albedo, np.broadcast_to(expected, albedo.shape), atol=1e-6)


def exr_float_attribute(path, name: str) -> float:
    """The ``float`` header attribute ``name`` of an OpenEXR file, parsed from its bytes (OpenEXR file layout: magic
    and version, then ``name\\0type\\0size value`` attributes up to an empty name)."""
    import struct

    data, at = open(path, "rb").read(), 8
    while data[at] != 0:
        end = data.index(b"\0", at)
        key, kind_end = data[at:end].decode(), data.index(b"\0", end + 1)
        (size,) = struct.unpack_from("<i", data, kind_end + 1)
        if key == name:
            assert data[end + 1:kind_end] == b"float"
            return struct.unpack_from("<f", data, kind_end + 5)[0]
        at = kind_end + 5 + size
    raise KeyError(name)


@pytest.mark.parametrize("policy", ["expandAperture", "adjustPixelAspectRatio"])
def test_exr_images_say_the_shape_of_their_pixels(tmp_path, policy):
    """``wrt render -o x.exr`` and ``Image.save`` of a stage whose settings render non-square pixels wrote
    ``pixelAspectRatio`` 1, so a compositor showed the image squashed; EXR products said it right. Now the header
    holds the rendered pixels' shape: the authored ratio, or under ``adjustPixelAspectRatio`` the apertures' aspect
    over the resolution's (the film is the apertures), as UsdRenderComputeSpec gives it. A PNG says it in its pHYs
    chunk (unit 0: the aspect alone, pixels per unit along y over x), which it lacked: viewers showed it stretched.
    Read by Pillow and by the plain-Python reader of png_chunks."""
    from pxr import Usd, UsdGeom

    settings = ("rel camera = </World/Side>\n        uniform int2 resolution = (64, 48)\n"
                "        uniform float pixelAspectRatio = 2\n"
                f'        uniform token aspectRatioConformPolicy = "{policy}"')
    stage = write_stage(tmp_path, settings=settings)
    opened = Usd.Stage.Open(str(stage))
    side = UsdGeom.Camera(opened.GetPrimAtPath("/World/Side")).GetCamera(Usd.TimeCode.Default())
    expected = 2.0 if policy == "expandAperture" else side.horizontalAperture / side.verticalAperture / (64 / 48)
    assert main(["render", str(stage), "-o", str(tmp_path / "cli.exr"), "-q"]) == 0
    assert exr_float_attribute(tmp_path / "cli.exr", "pixelAspectRatio") == pytest.approx(expected, rel=1e-6)
    image = wrt.render(wrt.load_usd(stage), width=16, height=12)
    image.save(tmp_path / "python.exr")
    assert exr_float_attribute(tmp_path / "python.exr", "pixelAspectRatio") == pytest.approx(expected, rel=1e-6)
    image.save(tmp_path / "python.png")
    assert png_pixel_aspect_ratio(tmp_path / "python.png") == pytest.approx(expected, rel=1e-5)


def png_pixel_aspect_ratio(path) -> float | None:
    """The width / height of a PNG's pixels by its pHYs chunk (None without one), as png_chunks reads it and as
    Pillow does (its ``aspect``: pixels per unit along x and y)."""
    from PIL import Image as PilImage
    from png_chunks import pixel_aspect_ratio, read_chunks

    ratio = pixel_aspect_ratio(read_chunks(str(path)))
    aspect = PilImage.open(path).info.get("aspect")
    assert (aspect is None) == (ratio is None) and (aspect is None or aspect[1] / aspect[0] == ratio), aspect
    return ratio


BAD_PYTHON_SETTINGS = [
    # Each failed only at the render, in Python's words: "float division by zero", "not enough values to unpack",
    # "Array shapes must be non-negative", "cannot convert float NaN to integer", or rendered a cut or 1-pixel image.
    (dict(resolution=(0, 10)), wrt.SceneError, r"resolution 0x10 must be positive"),
    (dict(resolution=(-5, 5)), wrt.SceneError, r"resolution -5x5 must be positive"),
    (dict(resolution=(64,)), wrt.SceneError, r"resolution must be 2 numbers, got \(64,\)"),
    (dict(resolution=(64, 48, 3)), wrt.SceneError, r"resolution must be 2 numbers, got \(64, 48, 3\)"),
    (dict(resolution=(True, 12)), wrt.SceneError, r"resolution must be 2 numbers, got \(True, 12\)"),
    (dict(resolution=(16.5, 12)), wrt.SceneError, r"resolution 16.5x12 must be whole numbers of pixels"),
    (dict(resolution=(float("nan"), 12)), wrt.SceneError, r"resolution nanx12 must be positive"),
    (dict(resolution="16x12"), wrt.SceneError, r"resolution must be 2 numbers, got '16x12'"),
    (dict(pixel_aspect_ratio=0), wrt.SceneError, r"pixel_aspect_ratio must be a finite positive number, got 0"),
    (dict(conform_policy="expandApperture"), wrt.SceneError,
     r"conform_policy 'expandApperture' is none of .* \(did you mean 'expandAperture'\?\)"),
    (dict(data_window=(0, 0, 1)), wrt.SceneError, r"data_window must be 4 numbers, got \(0, 0, 1\)"),
    (dict(data_window=(0, 0, np.inf, 1)), wrt.SceneError, r"data_window \(0, 0, inf, 1\) must be finite"),
    (dict(camera=5), TypeError, r"camera: path must be a str.*got int 5"),
    (dict(camera=" "), wrt.SceneError, r"camera is an empty path"),
    (dict(disable_depth_of_field="no"), TypeError, r"disable_depth_of_field must be True or False, got str 'no'"),
    (dict(included_purposes="render"), TypeError, r"included_purposes must be a tuple \(or list\) of str, got str"),
    (dict(products=[1]), TypeError, r"products must be a tuple \(or list\) of RenderSettings"),
    (dict(product_type=3), TypeError, r"product_type must be a str, got int 3"),
]


@pytest.mark.parametrize("fields, error, message", BAD_PYTHON_SETTINGS)
def test_bad_settings_made_in_python_are_refused_when_made_naming_the_field(fields, error, message):
    from wrt.render_settings import RenderSettings

    with pytest.raises(error, match=r"RenderSettings '/Render': " + message):
        RenderSettings(path="/Render", **fields)


def test_settings_made_in_python_keep_their_valid_values_as_plain_numbers():
    """Numpy numbers and whole floats are taken (as a stage's float2 resolution is), as the Python numbers."""
    from wrt.render_settings import RenderSettings

    settings = RenderSettings(path="/Render", resolution=(np.int64(16), 12.0), pixel_aspect_ratio=np.float32(2.0),
                              data_window=np.array([0.25, 0.0, 0.75, 0.5]), disable_depth_of_field=np.bool_(True),
                              included_purposes=["default", "proxy"])
    assert settings.resolution == (16, 12) and all(type(v) is int for v in settings.resolution)
    assert settings.pixel_aspect_ratio == 2.0 and type(settings.pixel_aspect_ratio) is float
    assert settings.data_window == (0.25, 0.0, 0.75, 0.5) and settings.disable_depth_of_field is True
    assert settings.included_purposes == ("default", "proxy")


def test_a_settings_camera_wrt_does_not_read_is_named_without_a_stray_colon():
    """Settings made in Python have no source file: the message began ': /Render: camera ...'."""
    from wrt.render_settings import RenderSettings

    scene = wrt.Scene.from_triangles(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]]))
    scene.render_settings = RenderSettings(path="/Render", camera="/Nope", resolution=(8, 6))
    with pytest.raises(wrt.SceneError, match=r"^/Render: camera /Nope is not among the cameras wrt reads: none$"):
        resolve_view(scene)


def test_the_python_pixel_limit_error_names_the_render_settings_that_sized_the_image():
    """A scene whose render settings ask for 2147483647x2 pixels: ``wrt.render`` and ``Renderer`` refused it as
    "2147483647x2 is ... pixels", not saying that the size came from ``scene.render_settings`` (the CLI names them);
    the settings are named now, with the side given where one was, and a size given whole is the caller's own; a
    Renderer whose settings are replaced by such ones says so too."""
    from wrt.render_settings import RenderSettings

    quad = wrt.Mesh("/quad", np.array([[-1, -1, -5], [1, -1, -5], [1, 1, -5], [-1, 1, -5]], np.float32),
                    [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32))
    huge = RenderSettings(path="/Render/Huge", resolution=(2**31 - 1, 2))
    scene = wrt.Scene(meshes=[quad], render_settings=huge)
    limit = "pixels; at most 67,108,864 are supported"
    with pytest.raises(ValueError, match=f"^resolution of scene.render_settings /Render/Huge: 2147483647x2 is "
                                         f"4,294,967,294 {limit}$"):
        wrt.render(scene, device="cpu")
    with pytest.raises(ValueError, match=f"^height=4, aspect of scene.render_settings /Render/Huge: 4294967294x4 "
                                         f"is 17,179,869,176 {limit}$"):
        wrt.Renderer(scene, height=4, device="cpu")
    with pytest.raises(ValueError, match=f"^100000x100000 is 10,000,000,000 {limit}$"):
        wrt.Renderer(scene, width=100000, height=100000, device="cpu")
    scene = wrt.Scene(meshes=[quad], render_settings=RenderSettings(path="/Render/Small", resolution=(8, 6)))
    renderer = wrt.Renderer(scene, device="cpu")
    scene.render_settings = huge
    with pytest.raises(ValueError, match="^resolution of scene.render_settings /Render/Huge: 2147483647x2 is "):
        renderer.render()


def test_a_data_window_that_overscans_past_the_pixel_limit_is_named_as_its_cause(tmp_path, capsys):
    """A dataWindowNDC of (-1000, -1000, 1000, 1000) makes a 64x32 shot a 128000x64000 image: ``wrt render`` and
    ``wrt.render`` refused it naming the resolution (or the sizes given) alone, though those are small, and
    ``camera_rays`` failed in Warp's words ('Array shapes must not exceed the maximum representable value of a
    signed 32-bit integer') naming nothing; below 2^31 rays it allocated them without bound. Each names the data
    window now."""
    from wrt.render_settings import RenderSettings

    limit = "128000x64000 is 8,192,000,000 pixels; at most 67,108,864 are supported"
    settings = RenderSettings(path="/Render/Wide", resolution=(64, 32), data_window=(-1000.0, -1000.0, 1000.0, 1000.0))
    scene = wrt.Scene.from_triangles([[-1, -1, -5], [1, -1, -5], [1, 1, -5]], [[0, 1, 2]])
    scene.render_settings = settings
    cause = "resolution and dataWindowNDC of scene.render_settings /Render/Wide"
    for call in (lambda: wrt.render(scene, device="cpu"), lambda: camera_rays(scene)):
        with pytest.raises(ValueError, match=f"^{cause}: {limit}$"):
            call()
    with pytest.raises(ValueError, match=f"^width=64 height=32, dataWindowNDC of scene.render_settings /Render/Wide: "
                                         f"{limit}$"):
        camera_rays(scene, width=64, height=32)
    stage = write_stage(tmp_path, settings=DEFAULT_SETTINGS + "\n        uniform float4 dataWindowNDC = (-1000, -1000, "
                                                              "1000, 1000)")
    assert main(["render", str(stage), "-o", str(tmp_path / "x.png"), "-q"]) != 0
    said = capsys.readouterr().err.splitlines()[-1]
    assert said == f"wrt: error: resolution and dataWindowNDC of /Render/Settings: {limit}"


@pytest.mark.parametrize("batched", [False, True])
def test_an_edit_of_the_view_a_renderer_resolved_is_named_not_drawn_silently(tmp_path, batched):
    """renderer.camera under render settings is a view wrt made of the stage camera (the settings' film), and for a
    stage without cameras one wrt frames the scene with: neither is a camera the Renderer follows, so an edit of it
    (renderer.camera.focal_length = ...) drew the old view without a word. A warning names it and its fields; the
    image is the one a fresh render of the scene draws. An edit in place of a to_world the view shares with its stage
    camera edits that camera, and is drawn as a fresh render of the edited scene draws it (no warning)."""
    scene = wrt.load_usd(write_stage(tmp_path))
    kept = wrt.Renderer(scene, cameras=[None], device="cpu") if batched else wrt.Renderer(scene, device="cpu")
    kept.render()
    view = kept.cameras[0]
    view.focal_length *= 2.0
    name = r"renderer\.cameras\[0\]" if batched else r"renderer\.camera"
    with pytest.warns(UserWarning, match=rf"^{name} \(focal_length\) edited, but that is the view the Renderer "
                                         "resolved, not a camera it follows: the edit is not drawn"):
        image = kept.render(seed=1)
    image = image.image(0) if batched else image
    np.testing.assert_array_equal(image.rgb, wrt.render(scene, device="cpu", seed=1).rgb)
    kept.cameras[0].to_world[0, 3] += 0.5  # the stage camera's own matrix: followed
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = kept.render(seed=1)
    image = image.image(0) if batched else image
    assert scene.cameras["/World/Side"].to_world[0, 3] == 1.0
    np.testing.assert_array_equal(image.rgb, wrt.render(scene, device="cpu", seed=1).rgb)


def test_an_edit_of_the_camera_wrt_frames_the_scene_with_is_named_not_drawn_silently():
    """Renderer(scene) of a scene without cameras draws it from a camera wrt makes: renderer.camera moved did not
    move the view, without a word. A warning names it; the image is a fresh render's of the scene."""
    from wrt.procedural import sensor_scene

    scene = sensor_scene()
    kept = wrt.Renderer(scene, width=12, height=9, device="cpu")
    kept.render()
    kept.camera.to_world[1, 3] += 1.0
    with pytest.warns(UserWarning, match=r"^renderer\.camera \(to_world\) edited"):
        image = kept.render(seed=1)
    np.testing.assert_array_equal(image.rgb, wrt.render(scene, width=12, height=9, device="cpu", seed=1).rgb)


UNREAD_CAMERAS = """
def Xform "World"
{
    def Cube "Box"
    {
    }
    def Camera "Front"
    {
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Camera "Off" (
        active = false
    )
    {
    }
    def Xform "Gone" (
        active = false
    )
    {
        def Camera "Cam"
        {
        }
    }
    def PointInstancer "Scatter"
    {
        rel prototypes = </World/Scatter/Protos/Cam>
        int[] protoIndices = [0]
        point3f[] positions = [(0, 0, 0)]
        def Scope "Protos"
        {
            def Camera "Cam"
            {
            }
        }
    }
}
def RenderSettings "Settings"
{
    rel camera = <CAMERA>
    uniform int2 resolution = (8, 6)
}
"""


@pytest.mark.parametrize("camera, why", [
    ("/World/Off", "it is inactive"),
    ("/World/Scatter/Protos/Cam", "it is inside PointInstancer /World/Scatter"),
])
def test_a_settings_camera_wrt_does_not_read_is_named_with_the_reason(tmp_path, camera, why):
    """Render settings whose camera is inactive, under an inactive prim or in a PointInstancer's prototypes (which
    USD's own ``UsdGeom.Camera`` reads: the oracle that it is one) failed with 'is not among the cameras wrt reads',
    saying nothing of why; the error names the settings prim, the camera and the reason. A render by the path says
    the same."""
    from pxr import Usd, UsdGeom

    path = write(tmp_path, UNREAD_CAMERAS.replace("CAMERA", camera))
    assert Usd.Stage.Open(path).GetPrimAtPath(camera).IsA(UsdGeom.Camera)
    scene = load(path, render_settings="/Settings")
    assert list(scene.cameras) == ["/World/Front"]
    with pytest.raises(wrt.SceneError, match=rf"/Settings renders camera {camera}, which wrt cannot use: "
                                             rf"the Camera at {camera} is not read: {why}"):
        resolve_view(scene)
    with pytest.raises(wrt.SceneError, match=rf"{why}"):
        wrt.render(scene, camera=camera, width=8, height=6, device="cpu")


def test_a_settings_camera_under_an_inactive_prim_is_named_with_it(tmp_path):
    """A camera under an inactive prim is no prim to USD (the settings' load fails, as for any missing camera); the
    error says which ancestor made it so."""
    from pxr import Usd

    path = write(tmp_path, UNREAD_CAMERAS.replace("CAMERA", "/World/Gone/Cam"))
    assert not Usd.Stage.Open(path).GetPrimAtPath("/World/Gone/Cam")
    with pytest.raises(wrt.SceneError, match=r"/Settings: camera relationship targets /World/Gone/Cam, which is no "
                                             r"prim \(it is under /World/Gone, which is inactive\), not a Camera"):
        load(path, render_settings="/Settings")
