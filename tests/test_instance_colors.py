"""Per-instance displayColor on PointInstancers: a ``primvars:displayColor`` authored on the instancer (``constant``
or ``uniform`` for all instances, ``vertex``/``varying``/``faceVarying`` one per instance) colours the prototype
meshes and gprims that have no displayColor of their own, read by instance id at shading time (no prototype copy per
colour), with both accelerators and every integrator; masked instances keep their colours, unusable primvars are
named in a warning.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt  # noqa: E402
from usda_text import load, load_strictly  # noqa: E402

import wrt  # noqa: E402

RGB = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
XS = (-2.0, 0.0, 2.0)  # x of the three instances
CAMERA = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=2.0)
WIDTH, HEIGHT = 48, 16  # the view is 6 x 2 units: each instance's quad covers the middle of one third
GREY = 0.5  # the renderer's colour for geometry without displayColor


def flattened_display_color(path) -> np.ndarray:
    """USD's ComputeFlattened of the displayColor on the stage's /PI, float64 ``(N, 3)``: the oracle of the instance
    colours."""
    stage = Usd.Stage.Open(str(path))  # held: its prims are invalid once it is gone
    primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/PI")).GetPrimvar("displayColor")
    return np.asarray(primvar.ComputeFlattened(), np.float64)


def instancer_stage(path, colors=RGB, interpolation="vertex", gprim=False, proto_color=None, indices=None,
                    invisible=(), material=False, n=3, xs=XS):
    """A PointInstancer of ``n`` unit quads (or Cube gprims) facing +Z at x = ``xs``; its prototype lives outside
    it, under an invisible /Protos, so no colour reaches it by inheritance through the instancer."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    protos = UsdGeom.Scope.Define(stage, "/Protos")
    protos.MakeInvisible()
    if gprim:
        proto = UsdGeom.Cube.Define(stage, "/Protos/Shape")
        proto.CreateSizeAttr(1.0)
        proto.AddScaleOp().Set(Gf.Vec3f(1.0, 1.0, 0.01))
    else:
        proto = UsdGeom.Mesh.Define(stage, "/Protos/Shape")
        proto.CreatePointsAttr([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)])
        proto.CreateFaceVertexCountsAttr([4])
        proto.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if proto_color is not None:
        proto.CreateDisplayColorAttr([proto_color])
    if material:  # a UsdPreviewSurface whose diffuseColor is read from displayColor
        mat = UsdShade.Material.Define(stage, "/Looks/FromPrimvar")
        surface = UsdShade.Shader.Define(stage, "/Looks/FromPrimvar/Surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        reader = UsdShade.Shader.Define(stage, "/Looks/FromPrimvar/Reader")
        reader.CreateIdAttr("UsdPrimvarReader_float3")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("displayColor")
        reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            reader.ConnectableAPI(), "result")
        mat.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(proto.GetPrim()).Bind(mat)
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
    pi.CreateProtoIndicesAttr([0] * n)
    pi.CreatePositionsAttr([(x, 0.0, 0.0) for x in xs][:n] if n <= len(xs) else [(0.0, 0.0, 0.0)] * n)
    if invisible:
        pi.CreateInvisibleIdsAttr(list(invisible))
    if colors is not None:
        primvar = UsdGeom.PrimvarsAPI(pi).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                        interpolation)
        primvar.Set(colors)
        if indices is not None:
            primvar.SetIndices(Vt.IntArray(list(indices)))
    stage.GetRootLayer().Save()
    return str(path)


def albedo_at_instances(scene, accel="wrt", integrator="whitted"):
    """``(3, 3)`` albedo AOV (and the image of a quick look) at the centre of each instance's column, from
    sample 0; NaN rows where the pixel sees nothing."""
    img = wrt.render(scene, camera=CAMERA, width=WIDTH, height=HEIGHT, device="cpu", accel=accel,
                     integrator=integrator)
    row = HEIGHT // 2
    cols = [int((x + 3.0) / 6.0 * WIDTH) for x in XS]
    albedo = img.aovs["albedo"][row, cols].astype(np.float64)
    albedo[img.aovs["prim"][row, cols] < 0] = np.nan
    return albedo, img


def test_face_varying_display_color_is_one_per_instance(tmp_path):
    """faceVarying on an instancer is one value per instance, as vertex and varying are (UsdGeomPointInstancer's
    primvar rules; Hydra makes it an instance primvar): it was ignored with a warning, all instances grey. The
    oracle is USD's flattened primvar."""
    path = instancer_stage(tmp_path / "pi.usda", interpolation="faceVarying")
    flattened = flattened_display_color(path)
    scene = load_strictly(path)
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, flattened, atol=1e-6)


@pytest.mark.parametrize("accel", ["wrt", "warp"])
@pytest.mark.parametrize("gprim", [False, True])
def test_vertex_display_color_colours_each_instance(tmp_path, accel, gprim):
    """Each instance shows its own colour in the albedo AOV; before, all three were the prototype's grey 0.5."""
    scene = load(instancer_stage(tmp_path / "pi.usda", gprim=gprim), tessellate_gprims=8 if accel == "warp" else False)
    assert len(scene.prototypes) == 1  # one prototype, not one copy per colour
    albedo, _ = albedo_at_instances(scene, accel)
    np.testing.assert_allclose(albedo, RGB, atol=1e-6)


def test_invisible_ids_keep_the_colours_of_the_remaining_instances(tmp_path):
    """With the middle instance hidden, the others keep red and blue (not the first two colours)."""
    scene = load(instancer_stage(tmp_path / "pi.usda", invisible=[1]))
    assert len(scene.instances) == 2
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo[[0, 2]], [RGB[0], RGB[2]], atol=1e-6)
    assert np.isnan(albedo[1]).all()


@pytest.mark.parametrize("gprim", [False, True])
def test_a_prototype_with_its_own_display_color_keeps_it(tmp_path, gprim):
    """A prototype's own displayColor wins over the instancer's, as in Hydra."""
    scene = load(instancer_stage(tmp_path / "pi.usda", gprim=gprim, proto_color=(1.0, 1.0, 0.0)))
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, [(1.0, 1.0, 0.0)] * 3, atol=1e-6)


def test_constant_display_color_colours_every_instance(tmp_path):
    """A constant displayColor on the instancer (its prototypes elsewhere, so not inherited) colours all."""
    scene = load(instancer_stage(tmp_path / "pi.usda", colors=[(0.2, 0.4, 0.8)], interpolation="constant"))
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, [(0.2, 0.4, 0.8)] * 3, atol=1e-6)


def move_prototypes_beneath_the_instancer(path):
    """Moves the prototype of an ``instancer_stage`` at ``path`` from /Protos to /PI/Protos, beneath the instancer,
    where a constant primvar of the instancer reaches it by inheritance."""
    stage = Usd.Stage.Open(path)
    Sdf.CopySpec(stage.GetRootLayer(), "/Protos", stage.GetRootLayer(), "/PI/Protos")
    stage.RemovePrim("/Protos")
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")).GetPrototypesRel().SetTargets(["/PI/Protos/Shape"])
    stage.GetRootLayer().Save()


@pytest.mark.parametrize("beneath", [False, True])
def test_uniform_display_color_colours_every_instance_as_constant_does(tmp_path, beneath):
    """UsdGeomPointInstancer's primvar rules: a ``constant`` or ``uniform`` primvar on the instancer applies its
    entire value to each instance (Hydra's instancer data source makes both constant). A uniform displayColor was
    ignored with a warning, every instance grey. The oracle is USD's flattened value."""
    path = instancer_stage(tmp_path / "pi.usda", colors=[(0.2, 0.4, 0.8)], interpolation="uniform")
    if beneath:  # the prototype under the instancer, where a constant one would reach it by inheritance
        move_prototypes_beneath_the_instancer(path)
    flattened = flattened_display_color(path)
    scene = load_strictly(path)
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, np.repeat(flattened, 3, axis=0), atol=1e-6)


@pytest.mark.parametrize("interpolation", ["constant", "uniform"])
@pytest.mark.parametrize("beneath", [False, True])
def test_a_constant_display_color_of_several_values_gives_every_instance_its_first(tmp_path, interpolation, beneath):
    """A constant (or uniform) displayColor of several values on the instancer (what a primvar authored without an
    interpolation reads as) applies its whole value to each instance, which a prototype's gprim reads as its first,
    with a warning, as UsdImaging reads a constant displayColor: so it did beneath the instancer, by inheritance, but
    where the prototypes lie elsewhere it was ignored (every instance grey). The oracle is USD's flattened value."""
    path = instancer_stage(tmp_path / "pi.usda", colors=RGB, interpolation=interpolation)
    if beneath:
        move_prototypes_beneath_the_instancer(path)
    flattened = flattened_display_color(path)
    with pytest.warns(UserWarning, match=r"constant primvars holding several values were read as their first value"):
        scene = wrt.load_usd(path)
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, [flattened[0]] * 3, atol=1e-6)


@pytest.mark.parametrize("interpolation, indices", [("vertex", None), ("vertex", [2, 0, 1]), ("constant", None)])
def test_a_display_color_of_element_size_two_gives_each_instance_the_first_of_its_element(tmp_path, interpolation,
                                                                                          indices):
    """UsdGeomPointInstancer's primvar rules: of a per-instance primvar of elementSize ``k`` the ``k`` values of each
    element go to one instance (its constant value there, of which a prototype's gprim reads the first, with a
    warning); a constant one's whole value goes to every instance. It was ignored with a warning, every instance
    grey. The oracle is USD's flattened primvar, whose indices pick whole elements."""
    colors = RGB + [(1.0, 1.0, 0.0), (0.0, 1.0, 1.0), (1.0, 0.0, 1.0)] if interpolation == "vertex" else RGB[:2]
    path = instancer_stage(tmp_path / "pi.usda", colors=colors, interpolation=interpolation, indices=indices)
    stage = Usd.Stage.Open(path)
    primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/PI")).GetPrimvar("displayColor")
    primvar.SetElementSize(2)
    stage.Save()
    flattened = np.asarray(primvar.ComputeFlattened(), np.float64).reshape(-1, 2, 3)
    expected = flattened[:, 0] if interpolation == "vertex" else np.repeat(flattened[:, 0], 3, axis=0)
    with pytest.warns(UserWarning, match=r"constant primvars holding several values were read as their first value"):
        scene = wrt.load_usd(path)
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, expected, atol=1e-6)


@pytest.mark.parametrize("interpolation", ["constant", "vertex"])
def test_a_non_constant_primvar_inside_a_prototype_beneath_the_instancer_blocks_its_constant_colour(tmp_path,
                                                                                                     interpolation):
    """A prototype beneath the instancer inherits the instancer's constant displayColor, and USD's inheritance stops
    at a non-constant displayColor on a prim between (FindPrimvarWithInheritance on the mesh finds none); Hydra makes
    only the instancer's non-constant primvars instance primvars ("inherited primvars don't vary per-instance, so we
    let the prototypes pick them up"), which apply to prototype meshes without a displayColor. The constant colour
    went past the blocker as an instance colour: the quads were drawn red, not in the default grey."""
    path = instancer_stage(tmp_path / "pi.usda", colors=RGB[:2] if interpolation == "vertex" else RGB[:1],
                           interpolation=interpolation, n=2)
    stage = Usd.Stage.Open(path)
    group = UsdGeom.Xform.Define(stage, "/PI/Protos/P").GetPrim()
    Sdf.CopySpec(stage.GetRootLayer(), "/Protos/Shape", stage.GetRootLayer(), "/PI/Protos/P/Shape")
    UsdGeom.PrimvarsAPI(group).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                             UsdGeom.Tokens.uniform).Set([(1.0, 0.0, 1.0)])
    UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")).GetPrototypesRel().SetTargets([group.GetPath()])
    stage.GetRootLayer().Save()
    stage = Usd.Stage.Open(path)
    assert not UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/PI/Protos/P/Shape")).FindPrimvarWithInheritance(
        "displayColor")
    albedo, _ = albedo_at_instances(load(path))
    expected = RGB[:2] if interpolation == "vertex" else [(GREY,) * 3] * 2
    np.testing.assert_allclose(albedo[:2], expected, atol=1e-6)


def test_indexed_display_color_is_flattened(tmp_path):
    """An indexed primvar gives each instance ``values[indices[i]]``, as ComputeFlattened does."""
    path = instancer_stage(tmp_path / "pi.usda", colors=RGB[:2], indices=[1, 0, 1])
    flattened = flattened_display_color(path)
    assert len(flattened) == 3
    albedo, _ = albedo_at_instances(load(path))
    np.testing.assert_allclose(albedo, flattened, atol=1e-6)


@pytest.mark.parametrize(
    "colors, interpolation, detail",
    [
        (RGB[:2], "vertex", r"vertex with 2 values, expected 3 \(one per instance\)"),
        (RGB + RGB[:1], "varying", r"varying with 4 values, expected 3"),
        ([], "uniform", r"uniform with 0 values, expected 1"),
        ([], "constant", r"constant with 0 values, expected 1"),
    ],
)
def test_an_unusable_display_color_warns_naming_the_instancer_and_is_ignored(tmp_path, colors, interpolation,
                                                                             detail):
    path = instancer_stage(tmp_path / "pi.usda", colors=colors, interpolation=interpolation)
    with pytest.warns(UserWarning, match=rf"PointInstancer displayColor.*{detail}.*/PI"):
        scene = wrt.load_usd(path)
    assert len(scene.instances.colors) == 0
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, GREY, atol=1e-6)


def test_a_material_reading_display_color_picks_the_instance_colour(tmp_path):
    """A UsdPreviewSurface whose diffuseColor comes from UsdPrimvarReader_float3 of displayColor shows each
    instance's colour."""
    scene = load(instancer_stage(tmp_path / "pi.usda", material=True))
    assert scene.materials and scene.materials[0].diffuse_from_display_color
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, RGB, atol=1e-6)


@pytest.mark.parametrize("integrator", ["albedo", "whitted", "path"])
def test_integrators_see_the_instance_colours(tmp_path, integrator):
    """The albedo quick look is the AOV; whitted and path, under a white dome, return each instance's colour as
    the hue of its radiance (a Lambertian of that albedo), none of it grey."""
    scene = load(instancer_stage(tmp_path / "pi.usda"))
    scene.lights = [wrt.DomeLight(color=np.ones(3, np.float32))] if integrator != "albedo" else []
    albedo, img = albedo_at_instances(scene, integrator=integrator)
    row = HEIGHT // 2
    rgb = img.rgb[row, [int((x + 3.0) / 6.0 * WIDTH) for x in XS]]
    if integrator == "albedo":
        np.testing.assert_allclose(rgb, RGB, atol=1e-6)
    else:  # only the instance's own channel is lit
        assert np.all(rgb[np.eye(3, dtype=bool)] > 0.1)
        np.testing.assert_allclose(rgb[~np.eye(3, dtype=bool)], 0.0, atol=1e-6)


def test_nested_instancers_take_the_nearest_colour(tmp_path):
    """A PointInstancer (two instances, red and green) of a prototype holding a coloured instancer (blue) and a
    bare quad: the inner quads are blue in both outer instances, the bare quads take their outer instance's colour."""
    path = tmp_path / "nested.usda"
    path.write_text("""#usda 1.0
(
    upAxis = "Y"
)
def Scope "Protos" (
)
{
    token visibility = "invisible"
    def Mesh "Quad"
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)]
    }
    def Xform "Group"
    {
        def PointInstancer "Inner"
        {
            rel prototypes = </Protos/Quad>
            int[] protoIndices = [0]
            point3f[] positions = [(0, 0.6, 0)]
            color3f[] primvars:displayColor = [(0, 0, 1)] (
                interpolation = "vertex"
            )
        }
        def Mesh "Bare"
        {
            int[] faceVertexCounts = [4]
            int[] faceVertexIndices = [0, 1, 2, 3]
            point3f[] points = [(-0.5, -1.1, 0), (0.5, -1.1, 0), (0.5, -0.1, 0), (-0.5, -0.1, 0)]
        }
    }
}
def PointInstancer "Outer"
{
    rel prototypes = </Protos/Group>
    int[] protoIndices = [0, 0]
    point3f[] positions = [(-2, 0, 0), (2, 0, 0)]
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)] (
        interpolation = "vertex"
    )
}
""")
    scene = load(path)
    camera = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=4.0)
    img = wrt.render(scene, camera=camera, width=24, height=16, device="cpu", integrator="albedo")
    at = {(x, y): img.rgb[int((2.0 - y) / 4.0 * 16), int((x + 3.0) / 6.0 * 24)] for x in (-2, 2) for y in (0.6, -0.6)}
    np.testing.assert_allclose(at[-2, 0.6], (0, 0, 1), atol=1e-6)  # the inner quad (y 0.1 .. 1.1)
    np.testing.assert_allclose(at[2, 0.6], (0, 0, 1), atol=1e-6)
    np.testing.assert_allclose(at[-2, -0.6], (1, 0, 0), atol=1e-6)  # the bare quad (y -1.1 .. -0.1)
    np.testing.assert_allclose(at[2, -0.6], (0, 1, 0), atol=1e-6)


def test_many_distinct_colours_make_no_prototype_copies(tmp_path):
    """100k instances in 100k distinct colours load as one prototype of 2 triangles plus a 12-byte colour each, and
    the albedo AOV over a 10 x 10 block of them shows each one's own colour."""
    n, per_row = 100_000, 400
    rng = np.random.default_rng(123)
    colors = rng.random((n, 3)).astype(np.float32)
    q, r = np.divmod(np.arange(n), per_row)
    stage = Usd.Stage.CreateNew(str(tmp_path / "many.usdc"))
    UsdGeom.Scope.Define(stage, "/Protos").MakeInvisible()
    quad = UsdGeom.Mesh.Define(stage, "/Protos/Quad")
    quad.CreatePointsAttr([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)])
    quad.CreateFaceVertexCountsAttr([4])
    quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    pi.CreatePrototypesRel().SetTargets([quad.GetPath()])
    pi.CreateProtoIndicesAttr(Vt.IntArray(n, 0))
    positions = np.column_stack([2.0 * q, 2.0 * r, np.zeros(n)]).astype(np.float32)  # 2 units apart
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(positions))
    UsdGeom.PrimvarsAPI(pi).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "vertex").Set(
        Vt.Vec3fArray.FromNumpy(colors))
    stage.GetRootLayer().Save()

    scene = load(tmp_path / "many.usdc")
    stats = scene.stats()
    assert (stats["prototypes"], stats["prototype_meshes"], stats["unique_triangles"]) == (1, 1, 2)
    assert stats["instances"] == n
    assert scene.instances.colors.shape == (n, 3) and scene.instances.colors.dtype == np.float32

    # The block q in [100, 110), r in [200, 210), one pixel (2 x 2 units) centred on each instance.
    camera = wrt.Camera.orthographic(eye=(209, 409, 5), target=(209, 409, 0), up=(0, 1, 0), height=20.0)
    img = wrt.render(scene, camera=camera, width=10, height=10, device="cpu", integrator="albedo")
    rows, cols = np.mgrid[0:10, 0:10]
    expected = colors[(100 + cols) * per_row + 209 - rows]  # row 0 is the top: the largest r
    np.testing.assert_allclose(img.aovs["albedo"], expected, atol=1e-6)


def test_a_kept_renderer_follows_new_instance_colours(tmp_path):
    """Giving ``scene.instances.colors`` a new array is a scene edit: a kept Renderer builds again and shows it."""
    scene = load(instancer_stage(tmp_path / "pi.usda"))
    renderer = wrt.Renderer(scene, camera=CAMERA, width=WIDTH, height=HEIGHT, device="cpu", integrator="albedo")
    generation = scene.cache_generation
    scene.instances.colors = np.array(RGB[::-1], np.float32)
    rgb = renderer.render().rgb[HEIGHT // 2, [int((x + 3.0) / 6.0 * WIDTH) for x in XS]]
    assert scene.cache_generation != generation
    np.testing.assert_allclose(rgb, RGB[::-1], atol=1e-6)


def test_scenes_without_instance_colours_upload_no_colour_array(tmp_path):
    """An instancer without displayColor keeps the colour array empty and the device arrays one entry long."""
    scene = load(instancer_stage(tmp_path / "pi.usda", colors=None))
    assert scene.instances.colors.shape == (0, 3)
    device_scene = scene.to_device("cpu")
    assert device_scene.num_instance_colors == 0
    assert device_scene.instance_colors.shape == (1,) and device_scene.takes_instance_color.shape == (1,)
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, GREY, atol=1e-6)


def test_python_instances_take_colours(np_rng):
    """Scenes built in Python pass colours to ``Instances.from_transforms``; NaN leaves an instance uncoloured, a
    wrong row count or an inf is refused."""
    quad = wrt.scene.Mesh("/Q", np.array([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)],
                                         np.float32), np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int32),
                          double_sided=True)
    to_world = np.tile(np.eye(4), (3, 1, 1))
    to_world[:, 0, 3] = XS
    colors = np.array([RGB[0], (np.nan, np.nan, np.nan), RGB[2]], np.float32)
    instances = wrt.instancing.Instances.from_transforms([0, 0, 0], to_world, colors=colors)
    scene = wrt.Scene(prototypes=[wrt.instancing.Prototype("/P", [quad])], instances=instances)
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, [RGB[0], (GREY,) * 3, RGB[2]], atol=1e-6)
    with pytest.raises(ValueError, match="one row per instance"):
        wrt.instancing.Instances.from_transforms([0, 0, 0], to_world, colors=colors[:2])
    with pytest.raises(ValueError, match="finite"):
        wrt.instancing.Instances.from_transforms([0, 0, 0], to_world, colors=np.full((3, 3), np.inf))
    scene.instances.colors = colors[:2]  # assigned later: refused by the next trace or render, not drawn uncoloured
    with pytest.raises(ValueError, match="one row per instance"):
        albedo_at_instances(scene)
    scene.instances.colors = None  # no colours, as from_transforms(colors=None) gives; it was refused as shape ()
    albedo, _ = albedo_at_instances(scene)
    np.testing.assert_allclose(albedo, np.full((3, 3), GREY), atol=1e-6)


def test_preview_shows_the_instance_colours(tmp_path):
    """``triangle_colors`` (what ``wrt preview`` draws) gives each instance's triangles its colour."""
    from wrt.image import to_srgb8
    from wrt.preview import triangle_colors

    scene = load(instancer_stage(tmp_path / "pi.usda", invisible=[1]))
    np.testing.assert_array_equal(triangle_colors(scene), np.repeat(to_srgb8(np.array([RGB[0], RGB[2]])), 2, axis=0))


@pytest.mark.parametrize("moving", [False, True])
def test_time_sampled_colours_are_read_as_compute_flattened_reads_them(tmp_path, moving):
    """Time-sampled colours are interpolated between samples, as ``ComputeFlattened`` gives them at that time, also
    where velocities move the instances: USD's velocity path holds positions, orientations, scales and protoIndices
    at their earlier sample (``ComputeInstanceTransformsAtTime``), not primvars, and a mesh's colours beside velocity
    moved points are interpolated too. wrt held the instancer's, drawing the sample at 0 at time 4."""
    path = instancer_stage(tmp_path / "pi.usda")
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    primvar = UsdGeom.PrimvarsAPI(pi).GetPrimvar("displayColor")
    primvar.GetAttr().Clear()
    primvar.Set(RGB, 0.0)
    primvar.Set(RGB[::-1], 10.0)
    if moving:  # velocities at the positions' samples: USD holds the instance transforms at their earlier sample
        positions = [Gf.Vec3f(x, 0.0, 0.0) for x in XS]
        pi.GetPositionsAttr().Set(positions, 0.0)
        pi.GetPositionsAttr().Set(positions, 10.0)
        pi.CreateVelocitiesAttr().Set([Gf.Vec3f(0.0)] * 3, 0.0)
        pi.GetVelocitiesAttr().Set([Gf.Vec3f(0.0)] * 3, 10.0)
    stage.GetRootLayer().Save()
    expected = np.asarray(primvar.ComputeFlattened(Usd.TimeCode(4.0)), np.float64)
    assert not np.allclose(expected, RGB)  # a real blend
    albedo, _ = albedo_at_instances(load(path, time=4.0))
    np.testing.assert_allclose(albedo, expected, atol=1e-6)


def test_instancer_opacities_beside_velocities_are_read_as_compute_flattened_reads_them(tmp_path):
    """``displayOpacity`` on an instancer moved by velocities, sampled 0.2, 0.4 at 0 and 0.6, 0.8 at 10: at time 5
    USD's ``ComputeFlattened`` gives 0.4, 0.6, and so does wrt (it held 0.2, 0.4, the sample at 0)."""
    path = instancer_stage(tmp_path / "pi.usda")
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    positions = [Gf.Vec3f(x, 0.0, 0.0) for x in XS]
    for time in (0.0, 10.0):
        pi.GetPositionsAttr().Set(positions, time)
        pi.CreateVelocitiesAttr().Set([Gf.Vec3f(0.0)] * 3, time)
    primvar = UsdGeom.PrimvarsAPI(pi).CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray,
                                                    UsdGeom.Tokens.vertex)
    primvar.Set([0.2, 0.4, 0.6], 0.0)
    primvar.Set([0.6, 0.8, 1.0], 10.0)
    stage.GetRootLayer().Save()
    scene = load(path, time=5.0)
    expected = np.asarray(primvar.ComputeFlattened(Usd.TimeCode(5.0)), np.float64)
    np.testing.assert_allclose(expected, [0.4, 0.6, 0.8], atol=1e-6)  # a real blend
    np.testing.assert_allclose(scene.instances.opacities[np.argsort(scene.instances.index)], expected, atol=1e-6)


def test_instancers_without_colours_and_native_instances_stay_uncoloured(tmp_path):
    """Beside a coloured instancer, an instancer without displayColor and a native instance of the same quad keep
    the grey of a prototype without colour (their rows of ``Instances.colors`` are NaN)."""
    path = instancer_stage(tmp_path / "pi.usda")
    stage = Usd.Stage.Open(path)
    plain = UsdGeom.PointInstancer.Define(stage, "/Plain")
    plain.CreatePrototypesRel().SetTargets(["/Protos/Shape"])
    plain.CreateProtoIndicesAttr([0, 0, 0])
    plain.CreatePositionsAttr([(x, 1.5, 0.0) for x in XS])
    lib = stage.CreateClassPrim("/Lib")
    lib.GetReferences().AddInternalReference("/Protos")  # the invisible Scope holding the quad
    native = UsdGeom.Xform.Define(stage, "/Native")
    native.GetPrim().GetReferences().AddInternalReference("/Lib")
    native.GetPrim().SetInstanceable(True)
    UsdGeom.Imageable(native.GetPrim()).CreateVisibilityAttr().Set(UsdGeom.Tokens.inherited)  # visible here
    native.AddTranslateOp().Set((0.0, -1.5, 0.0))
    stage.GetRootLayer().Save()
    scene = load(path)
    assert len(scene.instances) == 7
    camera = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=6.0)
    img = wrt.render(scene, camera=camera, width=36, height=36, device="cpu", integrator="albedo")
    at = {(x, y): img.rgb[int((3.0 - y) / 6.0 * 36), int((x + 3.0) / 6.0 * 36)] for x in XS for y in (1.5, 0, -1.5)}
    for k, x in enumerate(XS):
        np.testing.assert_allclose(at[x, 0], RGB[k], atol=1e-6)
        np.testing.assert_allclose(at[x, 1.5], GREY, atol=1e-6)
    np.testing.assert_allclose(at[0, -1.5], GREY, atol=1e-6)


def test_takes_instance_color_walks_no_mesh_once_uploaded_and_follows_new_colours(monkeypatch):
    """Which geometry ids take their instance's colour was summed over every mesh per upload (70-145 ms for 40k
    meshes); it is read off the corner colours the upload caches, and follows a mesh's replaced colours."""
    points = np.array([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], np.float32)
    plain = wrt.scene.Mesh("/P/Plain", points, np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int32))
    own = np.full((2, 3, 3), 0.25, np.float32)
    own[0] = np.nan  # its first triangle has no colour of its own there
    painted = wrt.scene.Mesh("/P/Painted", points, np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int32),
                             colors=own)
    instances = wrt.instancing.Instances.from_transforms([0], np.eye(4)[None], colors=np.array([RGB[0]], np.float32))
    scene = wrt.Scene(prototypes=[wrt.instancing.Prototype("/P", [plain, painted])], instances=instances)
    scene.drop_stale_caches()
    scene.to_device("cpu")
    with monkeypatch.context() as patch:
        patch.setattr(wrt.Scene, "_geometry_meshes", lambda self: pytest.fail("walked every mesh"))
        assert scene.takes_instance_color().tolist() == [True, True, True, False]
    painted.colors = None
    scene.drop_stale_caches()
    assert scene.takes_instance_color().tolist() == [True, True, True, True]


NATIVE_COLOURS = {
    "nan": 'color3f[] primvars:displayColor = [(nan, 0, 0)]',
    "float3": 'float[] primvars:displayColor = [1, 0, 0]',
    "float2": 'float[] primvars:displayColor = [1, 0]',
    "single": 'color3f primvars:displayColor = (1, 0, 0)',
    "empty": 'color3f[] primvars:displayColor = []',
    "several": 'color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)]',
}


@pytest.mark.parametrize("kind", NATIVE_COLOURS)
def test_a_native_instances_unusable_colour_is_read_as_a_plain_references_with_a_warning(tmp_path, kind):
    """A constant displayColor on a native instance that its prototype's mesh inherits is checked as the mesh checks
    it when the reference is not instanceable (USD composes the same value either way): not an array of 3-vectors
    (three numbers or a single colour3f were taken as a colour) or empty, dropped; several values, the first;
    non-finite, grey 0.5; each with the plain mesh's warning, naming the instance (it said nothing). Oracle: the
    same stage with instanceable = false, rendered."""
    def stage_text(instanceable):
        return ('#usda 1.0\n(\n    upAxis = "Z"\n)\ndef Xform "Lib"\n{\n    def Mesh "Tri"\n    {\n'
                '        point3f[] points = [(-1, -1, 0), (1, -1, 0), (0, 1, 0)]\n'
                '        int[] faceVertexCounts = [3]\n'
                '        int[] faceVertexIndices = [0, 1, 2]\n    }\n}\n'
                f'def Xform "A" (\n    instanceable = {instanceable}\n    references = </Lib>\n)\n{{\n'
                f'    {NATIVE_COLOURS[kind]} (interpolation = "constant")\n}}\n'
                f'def Xform "B" (\n    instanceable = {instanceable}\n    references = </Lib>\n)\n{{\n'
                '    double3 xformOp:translate = (3, 0, 0)\n'
                '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n')
    images, reasons = [], []
    for instanceable in ("true", "false"):
        path = tmp_path / f"{instanceable}.usda"
        path.write_text(stage_text(instanceable))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = wrt.load_usd(str(path))
        reasons.append(sorted(str(w.message).split(": ")[1] for w in caught if "displayColor" in str(w.message)))
        assert (len(scene.instances) > 0) == (instanceable == "true")
        camera = wrt.Camera.orthographic(eye=(1.5, 0, 5), target=(1.5, 0, 0), height=3.0)
        images.append(wrt.render(scene, camera=camera, width=12, height=6, device="cpu", integrator="albedo").rgb)
    np.testing.assert_array_equal(images[0], images[1])
    assert reasons[0] == reasons[1] and reasons[0], reasons
