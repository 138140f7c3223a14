"""``primvars:displayOpacity`` is the opacity of prims drawn with the default material (wrt/usd.py, wrt/materials.py),
as Storm's fallback surface reads it: robotics and simulation stages (Isaac, URDF importers) mark see-through parts
with it. Before, it was not read: such prims were drawn opaque, with a warning.

Every check compares renders of one small stage: a coloured emissive wall behind a lit quad (or gprim, or point)
without a material. With the default material's index of 1, a part of opacity ``a`` shows ``a`` of its opaque
render plus ``1 - a`` of what lies behind it, unbent: the render without the part."""

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, Vt
from test_materials import add_quad, bind, new_stage, preview_material
from usda_text import load_recording_warnings

import wrt

RES = 8
CAMERA = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=2.0)  # sees x, y in [-1, 1]
WALL = (0.2, 0.4, 0.9)  # the wall's emitted radiance
COLOR = (1.0, 0.5, 0.0)  # the part's displayColor
# The x of each pixel column's centre.
COLUMN_X = -1.0 + (np.arange(RES) + 0.5) * 2.0 / RES


def stage_with(tmp_path, part=None, name="opacity.usda"):
    """``(scene, warnings)``: the stage of a wall at z = -1 glowing ``WALL`` (reflecting nothing), a sun along -Z, and
    what ``part(stage)`` adds in front of it, loaded."""
    stage, path = new_stage(tmp_path, name)
    wall = add_quad(stage, "/Wall", center=(0, 0, -1), size=4.0)
    material, _ = preview_material(stage, "/Looks/Wall", diffuseColor=Gf.Vec3f(0.0), emissiveColor=Gf.Vec3f(*WALL),
                                   useSpecularWorkflow=1, specularColor=Gf.Vec3f(0.0), roughness=0.0)
    # A black mirror seen head-on reflects nothing: Schlick's F is F0 = specularColor = 0 at normal incidence (its
    # white F90 shows at grazing views only, and a mirror never reflects the sun).
    bind(wall, material)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")  # travels along its -Z: lights the parts' +Z faces
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(0.0)
    if part is not None:
        part(stage)
    stage.Save()
    return load_recording_warnings(path)


def render(scene):
    """``(RES, RES, 3)`` whitted render of the square [-1, 1]^2 seen from +Z."""
    return wrt.render(scene, camera=CAMERA, width=RES, height=RES, device="cpu").rgb


def quad(stage, path="/Part", faces=1, opacity=None, interpolation=UsdGeom.Tokens.constant):
    """The 2 x 2 quad (``faces`` vertical strips) at z = 0 in ``COLOR`` with ``displayOpacity`` ``opacity``."""
    mesh = add_quad(stage, path, faces=faces)
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([COLOR])
    if opacity is not None:
        mesh.CreateDisplayOpacityPrimvar(interpolation).Set(opacity)
    return mesh


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """``(opaque, empty)``: the quad without displayOpacity, and no quad (the wall alone)."""
    tmp_path = tmp_path_factory.mktemp("references")
    opaque = render(stage_with(tmp_path, quad, "opaque.usda")[0])
    empty = render(stage_with(tmp_path, None, "empty.usda")[0])
    # The two differ in every channel, so a blend of them says how much of each is seen.
    assert np.all(np.abs(opaque - empty) > 0.05), (opaque[0, 0], empty[0, 0])
    np.testing.assert_allclose(empty, np.broadcast_to(WALL, empty.shape), rtol=1e-5)
    return opaque, empty


def test_half_transparent_quad_shows_the_wall_through(tmp_path, references):
    """Opacity 0.5: half the quad's own shading plus half the wall's colour, and no warning (there was one saying
    the quad was drawn opaque)."""
    opaque, empty = references
    scene, messages = stage_with(tmp_path, lambda stage: quad(stage, opacity=[0.5]))
    np.testing.assert_allclose(render(scene), 0.5 * opaque + 0.5 * empty, rtol=1e-4, atol=1e-6)
    assert not [m for m in messages if "displayOpacity" in m], messages


@pytest.mark.parametrize("opacity, seen", [(0.0, "empty"), (1.0, "opaque")])
def test_opacity_zero_and_one(tmp_path, references, opacity, seen):
    """Opacity 0 is the wall alone; 1 the opaque quad."""
    opaque, empty = references
    scene, _ = stage_with(tmp_path, lambda stage: quad(stage, opacity=[opacity]))
    np.testing.assert_allclose(render(scene), {"empty": empty, "opaque": opaque}[seen], rtol=1e-5, atol=1e-6)


def test_per_vertex_opacity_varies_across_the_face(tmp_path, references):
    """``vertex`` opacity 0 on the left edge and 1 on the right one: each column shows ``a`` of the quad and
    ``1 - a`` of the wall, ``a = (x + 1) / 2`` at its centre."""
    opaque, empty = references
    # add_quad's points: bottom-left, bottom-right, top-left, top-right.
    scene, _ = stage_with(tmp_path, lambda stage: quad(stage, opacity=[0.0, 1.0, 0.0, 1.0],
                                                       interpolation=UsdGeom.Tokens.vertex))
    a = ((COLUMN_X + 1.0) / 2.0)[None, :, None]
    np.testing.assert_allclose(render(scene), a * opaque + (1.0 - a) * empty, rtol=1e-4, atol=1e-5)


def test_uniform_and_indexed_face_varying_opacity(tmp_path, references):
    """Two faces (left and right halves): ``uniform`` 0.25 and 0.75, and the same as an indexed ``faceVarying``
    primvar (two values, an index per face-vertex)."""
    opaque, empty = references
    a = np.where(COLUMN_X < 0.0, 0.25, 0.75)[None, :, None]
    expected = a * opaque + (1.0 - a) * empty

    def uniform(stage):
        quad(stage, faces=2, opacity=[0.25, 0.75], interpolation=UsdGeom.Tokens.uniform)

    def indexed(stage):
        mesh = quad(stage, faces=2)
        primvar = mesh.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.faceVarying)
        primvar.Set([0.75, 0.25])
        primvar.SetIndices(Vt.IntArray([1, 1, 1, 1, 0, 0, 0, 0]))

    for part in (uniform, indexed):
        scene, _ = stage_with(tmp_path, part, f"{part.__name__}.usda")
        np.testing.assert_allclose(render(scene), expected, rtol=1e-4, atol=1e-6, err_msg=part.__name__)


def test_inherited_opacity_and_materials(tmp_path, references):
    """A constant displayOpacity on a parent Xform applies to the quad below it (USD's primvar inheritance); a quad
    bound to a material keeps the material's own opacity (1), as in Storm."""
    opaque, empty = references

    def inherited(stage):
        group = UsdGeom.Xform.Define(stage, "/Group")
        UsdGeom.PrimvarsAPI(group).CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray,
                                                 UsdGeom.Tokens.constant).Set([0.5])
        quad(stage, "/Group/Part")

    scene, _ = stage_with(tmp_path, inherited, "inherited.usda")
    np.testing.assert_allclose(render(scene), 0.5 * opaque + 0.5 * empty, rtol=1e-4, atol=1e-6)

    def dressed(stage, opacity):
        mesh = quad(stage, opacity=opacity)
        material, _ = preview_material(stage, "/Looks/Red", diffuseColor=Gf.Vec3f(1.0, 0.0, 0.0))
        bind(mesh, material)

    see_through, _ = stage_with(tmp_path, lambda stage: dressed(stage, [0.25]), "dressed.usda")
    plain, _ = stage_with(tmp_path, lambda stage: dressed(stage, None), "plain.usda")
    np.testing.assert_array_equal(render(see_through), render(plain))


def test_gprim_and_points_opacity(tmp_path):
    """A ``Plane`` gprim and a ``Points`` sphere of displayOpacity 0.5 (constant; the gprim's through tessellation
    too). The plane shows half of its opaque render and half the wall. A ray through the sphere's middle crosses it
    twice: half the front's own shading, then half of what the back passes on; the back, inside, is lit through
    the front only, which blocks shadow rays (glass in wrt), so it adds nothing of its own: 1/4 of the wall."""
    def plane(opacity):
        def build(stage):
            gprim = UsdGeom.Plane.Define(stage, "/Part")
            gprim.CreateWidthAttr(2.0)
            gprim.CreateLengthAttr(2.0)
            gprim.CreateDisplayColorPrimvar().Set([COLOR])
            if opacity is not None:
                gprim.CreateDisplayOpacityPrimvar().Set([opacity])
        return build

    def points(opacity):
        def build(stage):
            particles = UsdGeom.Points.Define(stage, "/Part")
            particles.CreatePointsAttr([(0.0, 0.0, 0.0)])
            particles.CreateWidthsAttr([1.6])
            particles.CreateDisplayColorPrimvar().Set([COLOR])
            if opacity is not None:
                particles.CreateDisplayOpacityPrimvar().Set([opacity])
        return build

    empty = render(stage_with(tmp_path, None, "empty.usda")[0])
    for segments in (False, 64):
        def load(build, name):
            stage_with(tmp_path, build, name)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return render(wrt.load_usd(str(tmp_path / name), tessellate_gprims=segments))

        opaque, half = load(plane(None), "plane1.usda"), load(plane(0.5), "plane.usda")
        np.testing.assert_allclose(half, 0.5 * opaque + 0.5 * empty, rtol=1e-4, atol=1e-6)
        opaque, half = load(points(None), "points1.usda"), load(points(0.5), "points.usda")
        middle = (RES // 2 - 1, RES // 2)  # a pixel near the centre, well inside the sphere
        np.testing.assert_allclose(half[middle], 0.5 * opaque[middle] + 0.25 * empty[middle], rtol=1e-3, atol=1e-5)
        assert np.all(half[0, 0] == empty[0, 0])  # the corner misses the sphere


def test_bad_values_are_clamped_with_a_warning(tmp_path, references):
    """NaN reads as 1 (opaque, the schema's fallback) and values outside [0, 1] are clamped, each named in a
    warning: -0.5 shows the wall alone, 1.5 the opaque quad."""
    opaque, empty = references
    for values, expected in (([float("nan")], opaque), ([-0.5], empty), ([1.5], opaque)):
        scene, messages = stage_with(tmp_path, lambda stage: quad(stage, opacity=values), "bad.usda")
        np.testing.assert_allclose(render(scene), expected, rtol=1e-5, atol=1e-6)
        named = [m for m in messages if "displayOpacity" in m and "/Part" in m]
        assert len(named) == 1, messages


def test_python_meshes_take_opacities():
    """``Mesh.opacities`` (one row of three corners per triangle) is checked like the other per-triangle arrays."""
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    mesh = wrt.Mesh("/T", points, np.array([[0, 1, 2]]), np.zeros(1, np.int32), opacities=[[0.5, 0.5, 0.5]])
    assert mesh.opacities.shape == (1, 3) and "opacities" in repr(mesh)
    with pytest.raises(wrt.SceneError, match="opacities must have shape"):
        wrt.Mesh("/T", points, np.array([[0, 1, 2]]), np.zeros(1, np.int32), opacities=[0.5, 0.5])


def test_points_and_curves_take_an_opacity_per_point_or_curve(tmp_path):
    """A ``vertex`` displayOpacity on Points (0.2, 0.6) is one per sphere, as their displayColor is: the render
    equals, on each side, that of the same points in the one opacity of that side, with no warning; ``uniform`` on
    linear BasisCurves (0.3, 0.9, 1.5 clamped to 1 with a warning) is one per curve, every piece of it. Tet meshes
    and NURBS patches still take one opacity, the mean. Before, the points were drawn in their mean, 0.4, with a
    warning, and the curves in theirs."""
    def points(opacity, interpolation=UsdGeom.Tokens.constant):
        def build(stage):
            particles = UsdGeom.Points.Define(stage, "/Part")
            particles.CreatePointsAttr([(-0.5, 0.0, 0.0), (0.5, 0.0, 0.0)])
            particles.CreateWidthsAttr([0.8, 0.8])
            particles.CreateDisplayColorPrimvar().Set([COLOR])
            particles.CreateDisplayOpacityPrimvar(interpolation).Set(opacity)
            tets = UsdGeom.TetMesh.Define(stage, "/Tets")
            tets.CreatePointsAttr([(2, 2, 0), (3, 2, 0), (2, 3, 0), (2, 2, 1)])  # out of view
            tets.CreateTetVertexIndicesAttr([Gf.Vec4i(0, 1, 2, 3)])
            tets.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.vertex).Set([0.25, 0.25, 0.75, 0.75])
        return build

    scene, messages = stage_with(tmp_path, points([0.2, 0.6], UsdGeom.Tokens.vertex), "per_point.usda")
    np.testing.assert_allclose(scene.instances.opacities, [0.2, 0.6], rtol=1e-6)
    named = [m for m in messages if "mean of their displayOpacity" in m]
    assert len(named) == 1 and "/Tets" in named[0] and "/Part" not in named[0], messages
    tet_mesh = [m for m in scene.meshes if m.path == "/Tets"][0]
    np.testing.assert_allclose(tet_mesh.opacities, 0.5)
    left = render(stage_with(tmp_path, points([0.2]), "left.usda")[0])
    right = render(stage_with(tmp_path, points([0.6]), "right.usda")[0])
    expected = np.where((COLUMN_X < 0.0)[None, :, None], left, right)
    np.testing.assert_allclose(render(scene), expected, rtol=1e-4, atol=1e-6)

    def curves(stage):
        lines = UsdGeom.BasisCurves.Define(stage, "/Curves")
        lines.CreateTypeAttr(UsdGeom.Tokens.linear)
        lines.CreateCurveVertexCountsAttr([3, 2, 2])
        lines.CreatePointsAttr([(-1, 0, 0), (0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0), (2, 0, 0), (2, 1, 0)])
        lines.CreateWidthsAttr([0.1])
        lines.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        lines.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.uniform).Set([0.3, 0.9, 1.5])

    scene, messages = stage_with(tmp_path, curves, "curves.usda")
    curve = scene.instances.index
    assert set(curve) == {0, 1, 2} and len(curve) > 3  # spheres and tube pieces of each curve
    np.testing.assert_allclose(scene.instances.opacities, np.array([0.3, 0.9, 1.0])[curve], rtol=1e-6)
    assert len([m for m in messages if "outside [0, 1] were clamped" in m and "/Curves" in m]) == 1, messages


def test_python_shapes_take_an_opacity():
    """``Shape.opacity`` is a number in [0, 1] or None; NaN, which means "none" on the device, is refused."""
    shape = wrt.primitives.Shape("/S", "sphere", np.eye(4), opacity=0.25)
    assert shape.opacity == 0.25
    for bad in (float("nan"), 1.5):
        with pytest.raises(ValueError, match="opacity must be in"):
            wrt.primitives.Shape("/S", "sphere", np.eye(4), opacity=bad)


def opacity_primvar(prim, values, interpolation=UsdGeom.Tokens.constant):
    """``primvars:displayOpacity`` ``values`` on ``prim`` (any prim: an Xform, an instance, a PointInstancer)."""
    UsdGeom.PrimvarsAPI(prim).CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray,
                                            interpolation).Set(values)


def test_native_instance_hands_its_opacity_to_the_prototype(tmp_path, references):
    """A constant displayOpacity on a native instance (0.5) or on an Xform above it (0.25) is the opacity of its
    prototype's quad, which has none (primvars inherit through instance proxies), with no warning. Before, it was
    not seen from inside the prototype: the quad was drawn opaque (the render equalled ``opaque``)."""
    opaque, empty = references
    for opacity, holder in ((0.5, "/Part"), (0.25, "/Group")):
        def build(stage):
            quad(stage, "/Proto/Quad")
            stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)
            UsdGeom.Xform.Define(stage, "/Group")
            instance = stage.DefinePrim("/Group/Part" if holder == "/Group" else "/Part")
            instance.GetReferences().AddInternalReference("/Proto")
            instance.SetInstanceable(True)
            opacity_primvar(stage.GetPrimAtPath(holder), [opacity])

        scene, messages = stage_with(tmp_path, build, f"native{opacity}.usda")
        assert len(scene.instances) == 1
        np.testing.assert_allclose(render(scene), opacity * opaque + (1 - opacity) * empty, rtol=1e-4, atol=1e-6)
        assert not [m for m in messages if "displayOpacity" in m], messages


def instancer(stage, proto_opacity=None, root_opacity=None):
    """A PointInstancer ``/PI`` of two instances of a 1 x 2 strip of the quad's colour (``/PI/Protos/Strip/Mesh``)
    at x = -0.5 and 0.5, together covering the quad; ``proto_opacity``: the strip mesh's own displayOpacity,
    ``root_opacity``: one on the prototype root Xform."""
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    root = UsdGeom.Xform.Define(stage, "/PI/Protos/Strip")
    mesh = add_quad(stage, "/PI/Protos/Strip/Mesh", size=1.0)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(x, y, 0) for y in (-1, 1) for x in (-0.5, 0.5)]))
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([COLOR])
    if proto_opacity is not None:
        mesh.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.constant).Set([proto_opacity])
    if root_opacity is not None:
        opacity_primvar(root.GetPrim(), [root_opacity])
    pi.CreatePrototypesRel().AddTarget("/PI/Protos/Strip")
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(-0.5, 0, 0), (0.5, 0, 0)])
    return pi


def test_point_instancer_opacity_per_instance_and_on_the_prototype(tmp_path, references):
    """A PointInstancer's ``vertex`` displayOpacity (0.25, 0.75; indexed the second time) is each instance's: the
    left half shows a quarter of the quad, the right three quarters, with no warning. A prototype mesh's own
    opacity (1) wins over it, as its own displayColor wins; one on the prototype's root Xform (0.5) applies by
    inheritance. Before, the per-instance values were ignored: both halves opaque."""
    opaque, empty = references
    a = np.where(COLUMN_X < 0.0, 0.25, 0.75)[None, :, None]

    def per_instance(stage):
        opacity_primvar(instancer(stage), [0.25, 0.75], UsdGeom.Tokens.vertex)

    def indexed(stage):
        primvar = UsdGeom.PrimvarsAPI(instancer(stage)).CreatePrimvar(
            "displayOpacity", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
        primvar.Set([0.75, 0.25])
        primvar.SetIndices(Vt.IntArray([1, 0]))

    for build in (per_instance, indexed):
        scene, messages = stage_with(tmp_path, build, f"{build.__name__}.usda")
        np.testing.assert_allclose(render(scene), a * opaque + (1 - a) * empty, rtol=1e-4, atol=1e-6,
                                   err_msg=build.__name__)
        assert not [m for m in messages if "displayOpacity" in m], messages
        np.testing.assert_array_equal(scene.instances.opacities, [0.25, 0.75])

    def own_wins(stage):
        opacity_primvar(instancer(stage, proto_opacity=1.0), [0.25, 0.75], UsdGeom.Tokens.vertex)

    scene, _ = stage_with(tmp_path, own_wins, "own.usda")
    np.testing.assert_allclose(render(scene), opaque, rtol=1e-4, atol=1e-6)
    scene, _ = stage_with(tmp_path, lambda stage: instancer(stage, root_opacity=0.5), "root.usda")
    np.testing.assert_allclose(render(scene), 0.5 * opaque + 0.5 * empty, rtol=1e-4, atol=1e-6)


def test_point_instancer_uniform_opacity_is_every_instances(tmp_path, references):
    """A ``uniform`` displayOpacity on the instancer applies its entire value to each instance, as a ``constant`` one
    does (UsdGeomPointInstancer's primvar rules): it was ignored with a warning, both strips opaque."""
    opaque, empty = references
    scene, messages = stage_with(
        tmp_path, lambda stage: opacity_primvar(instancer(stage), [0.25], UsdGeom.Tokens.uniform))
    assert not [m for m in messages if "displayOpacity" in m], messages
    np.testing.assert_allclose(render(scene), 0.25 * opaque + 0.75 * empty, rtol=1e-4, atol=1e-6)


def test_point_instancer_opacity_of_the_wrong_length_is_named(tmp_path, references):
    """Three values for two instances: ignored (the strips opaque) with a warning naming the instancer and what was
    expected."""
    opaque, _ = references
    scene, messages = stage_with(
        tmp_path, lambda stage: opacity_primvar(instancer(stage), [0.25, 0.75, 0.5], UsdGeom.Tokens.vertex))
    np.testing.assert_allclose(render(scene), opaque, rtol=1e-4, atol=1e-6)
    named = [m for m in messages if "displayOpacity of the wrong length" in m]
    assert len(named) == 1 and "/PI" in named[0] and "expected 2" in named[0], messages


def test_python_instances_take_opacities():
    """``Instances.opacities`` is one value in [0, 1] (or NaN: none) per instance, or empty."""
    instances = wrt.instancing.Instances.from_transforms([0, 0], np.broadcast_to(np.eye(4), (2, 4, 4)))
    assert instances.opacities.shape == (0,)
    instances.opacities = [0.5, np.nan]
    instances.check_opacities()
    assert instances.opacities.dtype == np.float32 and instances.take([1]).opacities.shape == (1,)
    for bad, match in (([0.5], "one per instance"), ([0.5, 1.5], r"opacities\[1\] = 1.5")):
        instances.opacities = bad
        with pytest.raises(ValueError, match=match):
            instances.check_opacities()


@pytest.mark.parametrize("interpolation", ["vertex", "constant"])
def test_a_non_constant_opacity_inside_a_point_instancer_prototype_blocks_only_what_it_blocks_for_colour(
        tmp_path, references, interpolation):
    """A non-constant displayOpacity (and displayColor) on the prototype's root Xform blocks inheritance:
    FindPrimvarWithInheritance on the strip finds neither. The instancer's ``vertex`` values are Hydra's instance
    primvars, which reach prototype prims without their own past it: its colours colour the strips (they did), and
    its opacities (0.25, 0.75) are the strips' now, as the colours are; the blocker forced them opaque. A
    ``constant`` one on the instancer reaches its prototypes beneath it by inheritance only (Hydra makes no instance
    primvar of it), which the blocker stops: opaque, and the strips' colour their own."""
    opaque, empty = references
    colors = [(0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]

    def build(stage):
        pi = instancer(stage)
        mesh = stage.GetPrimAtPath("/PI/Protos/Strip/Mesh")
        UsdGeom.PrimvarsAPI(mesh).RemovePrimvar("displayColor")  # the instancer's colour may reach it
        root = stage.GetPrimAtPath("/PI/Protos/Strip")
        opacity_primvar(root, [0.1], UsdGeom.Tokens.uniform)  # uniform on an Xform: blocks inheritance
        UsdGeom.PrimvarsAPI(root).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                UsdGeom.Tokens.uniform).Set([(1.0, 0.0, 1.0)])
        count = 2 if interpolation == "vertex" else 1
        opacity_primvar(pi, [0.25, 0.75][:count], interpolation)
        UsdGeom.PrimvarsAPI(pi).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                              interpolation).Set(colors[:count])
        strip = UsdGeom.PrimvarsAPI(mesh)
        assert not strip.FindPrimvarWithInheritance("displayOpacity")  # USD: the strip has none
        assert not strip.FindPrimvarWithInheritance("displayColor")

    scene, messages = stage_with(tmp_path, build, f"blocked_{interpolation}.usda")
    assert not [m for m in messages if "display" in m], messages
    (proto,) = scene.prototypes
    if interpolation == "vertex":
        # As the colour path: the instances' values apply to the strips, which carry none of their own.
        np.testing.assert_allclose(scene.instances.colors, colors)
        np.testing.assert_allclose(scene.instances.opacities, [0.25, 0.75])
        assert all(mesh.opacities is None for mesh in proto.meshes)
        a = np.where(COLUMN_X < 0.0, 0.25, 0.75)[None, :, None]
        own = render(stage_with(tmp_path, lambda stage: build_opaque(stage, colors), "blocked_opaque.usda")[0])
        np.testing.assert_allclose(render(scene), a * own + (1 - a) * empty, rtol=1e-4, atol=1e-6)
    else:
        # Neither is an instance value: the strips are opaque and grey, as without either.
        assert np.isnan(scene.instances.colors).all() and np.isnan(scene.instances.opacities).all()
        grey = render(stage_with(tmp_path, lambda stage: build_opaque(stage, None), "grey_opaque.usda")[0])
        np.testing.assert_allclose(render(scene), grey, rtol=1e-4, atol=1e-6)


def build_opaque(stage, colors):
    """The instancer of :func:`instancer`, its strips without displayColor, coloured per instance by ``colors`` (or
    not at all: the default grey) and opaque."""
    pi = instancer(stage)
    UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/PI/Protos/Strip/Mesh")).RemovePrimvar("displayColor")
    if colors is not None:
        UsdGeom.PrimvarsAPI(pi).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                              UsdGeom.Tokens.vertex).Set(colors)


NESTED_QUAD = """int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)]"""


def _nested_mixed_stage(variant: str) -> str:
    """A native instance ``/N1`` (red, opacity 0.3) of an assembly holding a PointInstancer whose prototype holds a
    mesh ``M`` and a native instance ``N2`` of a kit holding a mesh ``M``, both under ``X``: the instancer colours its
    instance blue (``pi_colour``), or ``X`` authors uniform displayColor and displayOpacity (``blocked``)."""
    pi = 'color3f[] primvars:displayColor = [(0, 0, 1)] (interpolation = "vertex")' if variant == "pi_colour" else ""
    blockers = ('color3f[] primvars:displayColor = [(1, 0, 1)] (interpolation = "uniform")\n'
                '                    float[] primvars:displayOpacity = [0.1] (interpolation = "uniform")'
                if variant == "blocked" else "")
    return f"""#usda 1.0
def Xform "Kit"
{{
    def Mesh "M"
    {{
        {NESTED_QUAD}
    }}
}}
def Xform "Assembly"
{{
    def PointInstancer "PI"
    {{
        rel prototypes = </Assembly/PI/Protos/PP>
        int[] protoIndices = [0]
        point3f[] positions = [(0, 0, 0)]
        {pi}
        def Scope "Protos"
        {{
            def Xform "PP"
            {{
                def Xform "X"
                {{
                    {blockers}
                    def Mesh "M"
                    {{
                        {NESTED_QUAD}
                    }}
                    def Xform "N2" (
                        instanceable = true
                        references = </Kit>
                    )
                    {{
                    }}
                }}
            }}
        }}
    }}
}}
def Xform "N1" (
    instanceable = true
    references = </Assembly>
)
{{
    color3f[] primvars:displayColor = [(1, 0, 0)]
    float[] primvars:displayOpacity = [0.3]
}}
"""


def _looks_in(scene, source: str) -> dict:
    """``{"direct" or "nested": (colour or None, opacity or None)}`` of the meshes drawn by the instances of the
    world-level ``source``: the mesh's own value, else its instance's (NaN: none)."""
    inst, found = scene.instances, {}
    for r in range(len(inst)):
        if inst.path(r).split("[")[0].split("/")[1] != source.strip("/"):
            continue
        for mesh in scene.prototypes[inst.prototype[r]].meshes:
            color = mesh.colors[0, 0] if mesh.colors is not None else np.full(3, np.nan)
            if np.isnan(color).any() and len(inst.colors):
                color = inst.colors[r]
            opacity = mesh.opacities[0, 0] if mesh.opacities is not None else np.nan
            if np.isnan(opacity) and len(inst.opacities):
                opacity = inst.opacities[r]
            found["direct" if "/X/M" in mesh.path else "nested"] = (
                None if np.isnan(color).any() else tuple(np.round(color, 6).tolist()),
                None if np.isnan(opacity) or opacity >= 1.0 else round(float(opacity), 6))
    return found


@pytest.mark.parametrize("variant", ["pi_colour", "blocked"])
def test_a_native_instance_in_a_point_instancer_prototype_in_a_native_instance_takes_colour_and_opacity_alike(
        tmp_path, variant):
    """Nested mixed instancing: a mesh of a native instance ``N2`` inside a PointInstancer's prototype inside a native
    instance ``N1`` takes the colour and opacity that a mesh beside ``N2`` takes, whose proxies' walks are the same
    above them; the opacity is the one FindPrimvarWithInheritance finds on the proxy (the oracle), none where it finds
    none. ``N1``'s red reached the kit's mesh past the instancer's blue instance colour and past a uniform colour
    that blocks it (its opacity followed the walk: 0.3, and blue, or 0.3 past the blocker)."""
    path = tmp_path / f"nested_{variant}.usda"
    path.write_text(_nested_mixed_stage(variant))
    scene, _ = load_recording_warnings(path)
    looks = _looks_in(scene, "/N1")
    stage = Usd.Stage.Open(str(path))
    for name, proxy in (("direct", "/N1/PI/Protos/PP/X/M"), ("nested", "/N1/PI/Protos/PP/X/N2/M")):
        found = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath(proxy)).FindPrimvarWithInheritance("displayOpacity")
        assert looks[name][1] == (round(float(found.Get()[0]), 6) if found else None), (name, looks)
    assert looks["nested"] == looks["direct"], looks
    assert looks["direct"][0] == ((0.0, 0.0, 1.0) if variant == "pi_colour" else None), looks
