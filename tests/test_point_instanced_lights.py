"""UsdLux lights inside PointInstancer prototypes (street lamps, ceiling lamps scattered by an instancer) are one
light per drawn instance, placed by the instance's world transform times the light's transform in its prototype.
The oracle is USD itself: ``ComputeInstanceTransformsAtTime`` and ``ComputeMaskAtTime`` of each instancer and
``UsdGeom.XformCache`` give every light's world transform, and a second stage authors the same lights (their
attributes, schemas and collections copied) as plain prims at those transforms: both stages must load the same light
list and render the same image."""

import dataclasses
import math
import warnings

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

import wrt

T = Usd.TimeCode.Default()


def add_floor(stage, path="/Floor", half=6.0):
    floor = UsdGeom.Mesh.Define(stage, path)
    floor.CreatePointsAttr([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.CreateDisplayColorAttr([(1.0, 1.0, 1.0)])


def new_stage(path):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    add_floor(stage)
    UsdGeom.Mesh.Define(stage, "/Wall")  # a prim the light link leaves out (it draws nothing)
    return stage


def street_lamp(stage, root):
    """A lamp prototype at ``root``: an Xform (its own transform is part of the prototype's) holding a shaped,
    normalized, light-linked RectLight turned about X, and a hidden DiskLight."""
    lamp = UsdGeom.Xform.Define(stage, root)
    lamp.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 0.3))
    lamp.AddRotateZOp().Set(10.0)
    panel = UsdLux.RectLight.Define(stage, f"{root}/Panel")
    panel.CreateWidthAttr(0.4)
    panel.CreateHeightAttr(0.2)
    panel.CreateIntensityAttr(5.0)
    panel.CreateColorAttr(Gf.Vec3f(1.0, 0.8, 0.6))
    panel.CreateNormalizeAttr(True)
    UsdGeom.Xformable(panel).AddTranslateOp().Set(Gf.Vec3d(0.1, 0.0, 0.2))
    UsdGeom.Xformable(panel).AddRotateXOp().Set(20.0)
    shaping = UsdLux.ShapingAPI.Apply(panel.GetPrim())
    shaping.CreateShapingConeAngleAttr(50.0)
    shaping.CreateShapingConeSoftnessAttr(0.3)
    link = UsdLux.LightAPI(panel).GetLightLinkCollectionAPI()
    link.CreateExcludesRel().AddTarget("/Wall")
    hidden = UsdLux.DiskLight.Define(stage, f"{root}/Off")
    hidden.CreateVisibilityAttr(UsdGeom.Tokens.invisible)


def bulb(stage, root):
    """A bulb prototype: a SphereLight that is itself the prototype root."""
    light = UsdLux.SphereLight.Define(stage, root)
    light.CreateRadiusAttr(0.1)
    light.CreateIntensityAttr(40.0)
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 0.5))


def lamps_instancer(stage, path="/Lamps"):
    """A PointInstancer of six lamps (mixed prototypes, one turned and scaled by 1.5, one scaled by 2, one
    invisible, one inactive) over the floor; its prototypes live under it, as DCCs write them."""
    street_lamp(stage, f"{path}/Protos/Street")
    bulb(stage, f"{path}/Protos/Bulb")
    pi = UsdGeom.PointInstancer.Define(stage, path)
    pi.CreatePrototypesRel().SetTargets([Sdf.Path(f"{path}/Protos/Street"), Sdf.Path(f"{path}/Protos/Bulb")])
    pi.CreateProtoIndicesAttr([0, 1, 0, 1, 1, 0])
    pi.CreatePositionsAttr([(-1.5, 0.0, 1.0), (0.0, 0.5, 0.8), (1.5, 0.2, 1.0), (0.7, -1.0, 1.0), (-0.8, -1.2, 0.6),
                            (0.0, 1.5, 1.0)])
    turn = Gf.Rotation(Gf.Vec3d(1, 1, 0).GetNormalized(), 35.0).GetQuat()
    spin = Gf.Rotation(Gf.Vec3d(0, 0, 1), 60.0).GetQuat()
    pi.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), Gf.Quath(1, 0, 0, 0), Gf.Quath(turn), Gf.Quath(1, 0, 0, 0),
                               Gf.Quath(spin), Gf.Quath(1, 0, 0, 0)])
    pi.CreateScalesAttr([(1, 1, 1), (1, 1, 1), (1.5, 1.5, 1.5), (1, 1, 1), (2, 2, 2), (1, 1, 1)])
    pi.CreateInvisibleIdsAttr([3])
    pi.DeactivateId(5)
    UsdGeom.Xformable(pi).AddTranslateOp().Set(Gf.Vec3d(0.1, -0.1, 0.05))
    return pi


def _visible_below(prim, root):
    """No prim from ``prim`` up to prototype ``root`` (inclusive) is invisible (visibility inside a prototype is
    taken from its root down)."""
    p = prim
    while True:
        img = UsdGeom.Imageable(p)
        if img and img.GetVisibilityAttr().Get(T) == UsdGeom.Tokens.invisible:
            return False
        if p == root:
            return True
        p = p.GetParent()


def usd_placed_lights(stage, instancer, to_world):
    """``[(light prim, (4, 4) row-vector world matrix)]`` of the UsdLux lights in the prototypes of ``instancer``
    (a ``Usd.Prim``) whose own world matrix is ``to_world``: per instance USD's ``ComputeInstanceTransformsAtTime``
    (prototype root's transform included) and ``ComputeMaskAtTime``, per light ``XformCache``'s transform relative
    to the prototype root; instancers nested in prototypes recursively."""
    pi = UsdGeom.PointInstancer(instancer)
    cache = UsdGeom.XformCache(T)
    transforms = pi.ComputeInstanceTransformsAtTime(T, T, UsdGeom.PointInstancer.IncludeProtoXform,
                                                    UsdGeom.PointInstancer.IgnoreMask)
    mask = pi.ComputeMaskAtTime(T) or [True] * len(transforms)
    visible = UsdGeom.Imageable(instancer).ComputeVisibility(T) != UsdGeom.Tokens.invisible
    targets = pi.GetPrototypesRel().GetTargets()
    found = []
    for i, (m, keep) in enumerate(zip(transforms, mask)):
        if not keep:
            continue
        root = stage.GetPrimAtPath(targets[pi.GetProtoIndicesAttr().Get(T)[i]])
        placed = m * to_world
        it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies()))
        for prim in it:
            inside, _ = cache.ComputeRelativeTransform(prim, root)
            if prim.IsA(UsdGeom.PointInstancer):
                found += usd_placed_lights(stage, prim, inside * placed)
                it.PruneChildren()
            elif prim.HasAPI(UsdLux.LightAPI) and visible and _visible_below(prim, root):
                found.append((prim, inside * placed))
    return found


def author_by_hand(path, placed):
    """A stage holding the floor and each of ``placed`` lights copied as a plain prim ``/Hand/L<k>`` (its type,
    applied schemas, authored attributes and relationships) at its world matrix."""
    stage = new_stage(path)
    for k, (source, m) in enumerate(placed):
        prim = stage.DefinePrim(f"/Hand/L{k}", source.GetTypeName())
        for schema in source.GetAppliedSchemas():
            prim.AddAppliedSchema(schema)
        for attr in source.GetAuthoredAttributes():
            if attr.GetName().startswith("xformOp") or attr.GetName() == "visibility":
                continue
            prim.CreateAttribute(attr.GetName(), attr.GetTypeName()).Set(attr.Get(T))
        for rel in source.GetAuthoredRelationships():
            prim.CreateRelationship(rel.GetName()).SetTargets(rel.GetTargets())
        UsdGeom.Xformable(prim).AddTransformOp().Set(m)
    stage.Save()
    return stage


def assert_same_light(a, b):
    """Every field of lights ``a`` and ``b`` but their paths agrees (arrays to 1e-9 of their scale)."""
    assert type(a) is type(b), (a, b)
    for field in dataclasses.fields(a):
        if field.name == "path":
            continue
        x, y = getattr(a, field.name), getattr(b, field.name)
        if dataclasses.is_dataclass(x):
            assert_same_light(x, y)
        elif isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            np.testing.assert_allclose(x, y, rtol=1e-6, atol=1e-9, err_msg=f"{a.path}: {field.name}")
        else:
            assert x == y, (a.path, field.name, x, y)
    if hasattr(a, "radiance"):
        np.testing.assert_allclose(a.radiance, b.radiance, rtol=1e-6, err_msg=a.path)


def load(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(path))
    return scene, [str(w.message) for w in caught]


def top_down_image(scene):
    cam = wrt.Camera.orthographic(eye=(0, 0, 0.05), target=(0, 0, 0), up=(0, 1, 0), height=5.0)
    return wrt.render(scene, camera=cam, width=24, height=24, spp=32, seed=5, device="cpu",
                      integrator="whitted").rgb


def test_lights_in_point_instancer_prototypes_are_the_lights_usd_places_by_hand(tmp_path):
    stage = new_stage(tmp_path / "instanced.usda")
    lamps = lamps_instancer(stage)
    stage.Save()
    placed = usd_placed_lights(stage, lamps.GetPrim(), UsdGeom.XformCache(T).GetLocalToWorldTransform(lamps.GetPrim()))
    # Instances 0, 2 (turned and scaled) street lamps, 1 and 4 (scaled) bulbs; 3 is invisible, 5 inactive.
    assert [str(p.GetPath()) for p, _ in placed] == ["/Lamps/Protos/Street/Panel", "/Lamps/Protos/Bulb",
                                                      "/Lamps/Protos/Street/Panel", "/Lamps/Protos/Bulb"]
    author_by_hand(tmp_path / "by_hand.usda", placed)
    instanced, messages = load(tmp_path / "instanced.usda")
    assert not [m for m in messages if "Lamps" in m], messages
    by_hand, _ = load(tmp_path / "by_hand.usda")
    assert len(instanced.lights) == len(by_hand.lights) == 4
    for a, b in zip(instanced.lights, by_hand.lights):
        assert_same_light(a, b)
    assert [light.path for light in instanced.lights] == ["/Lamps/Protos/Street/Panel[0]", "/Lamps/Protos/Bulb[1]",
                                                          "/Lamps/Protos/Street/Panel[2]", "/Lamps/Protos/Bulb[4]"]
    # The scaled bulb: radius 0.1 * 2 in the world; the turned lamp's panel 1.5 times as wide and high.
    assert math.isclose(instanced.lights[3].world_radius, 0.2, rel_tol=1e-3)  # a quath is off unit length
    np.testing.assert_allclose(np.linalg.norm(instanced.lights[2].edges(), axis=1), [0.6, 0.3], rtol=1e-3)
    image = top_down_image(instanced)
    assert image.mean() > 0.01
    np.testing.assert_allclose(image, top_down_image(by_hand), rtol=1e-4, atol=1e-6)


def nested_stage(path):
    """Lights nested every way the geometry is: ``/Rows`` instances a row whose own PointInstancer ``Posts`` places
    posts holding a native instance of ``/Assets/Lamp`` (a SphereLight) and a DiskLight; ``/Kit`` and ``/Kit2`` are
    native instances of a kit holding a PointInstancer of RectLights."""
    stage = new_stage(path)
    stage.CreateClassPrim("/Assets")
    bulb(stage, "/Assets/Lamp/Bulb")
    posts = UsdGeom.PointInstancer.Define(stage, "/Rows/Protos/Row/Posts")
    UsdGeom.Xformable(stage.GetPrimAtPath("/Rows/Protos/Row")).AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.1))
    lamp = stage.DefinePrim("/Rows/Protos/Row/Posts/Protos/Post/Lamp", "Xform")
    lamp.GetReferences().AddInternalReference("/Assets/Lamp")
    lamp.SetInstanceable(True)
    UsdGeom.Xformable(lamp).AddTranslateOp().Set(Gf.Vec3d(0, 0, 1.0))
    glow = UsdLux.DiskLight.Define(stage, "/Rows/Protos/Row/Posts/Protos/Post/Glow")
    glow.CreateRadiusAttr(0.15)
    glow.CreateIntensityAttr(8.0)
    UsdGeom.Xformable(glow).AddTranslateOp().Set(Gf.Vec3d(0.2, 0, 0.9))
    UsdGeom.Xformable(glow).AddRotateYOp().Set(25.0)
    posts.CreatePrototypesRel().SetTargets([Sdf.Path("/Rows/Protos/Row/Posts/Protos/Post")])
    posts.CreateProtoIndicesAttr([0, 0, 0])
    posts.CreatePositionsAttr([(-1, 0, 0), (0, 0, 0), (1, 0, 0)])
    posts.CreateInvisibleIdsAttr([1])
    rows = UsdGeom.PointInstancer.Define(stage, "/Rows")
    rows.CreatePrototypesRel().SetTargets([Sdf.Path("/Rows/Protos/Row")])
    rows.CreateProtoIndicesAttr([0, 0])
    rows.CreatePositionsAttr([(0, -1, 0), (0.5, 1.0, 0.2)])
    rows.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), Gf.Quath(Gf.Rotation(Gf.Vec3d(0, 0, 1), 90).GetQuat())])
    rows.CreateScalesAttr([(1, 1, 1), (1.5, 1.5, 1.5)])
    kit = UsdGeom.PointInstancer.Define(stage, "/Assets/Kit/Lamps")
    street_lamp(stage, "/Assets/Kit/Lamps/Proto")
    kit.CreatePrototypesRel().SetTargets([Sdf.Path("/Assets/Kit/Lamps/Proto")])
    kit.CreateProtoIndicesAttr([0, 0])
    kit.CreatePositionsAttr([(0, 0, 1), (0, 0.8, 1)])
    for name, x in (("/Kit", 2.5), ("/Kit2", -2.5)):
        prim = stage.DefinePrim(name, "Xform")
        prim.GetReferences().AddInternalReference("/Assets/Kit")
        prim.SetInstanceable(True)
        UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
    stage.Save()
    return stage


def test_lights_of_nested_instancers_and_native_instances_in_prototypes_are_placed_as_usd_places_them(tmp_path):
    stage = nested_stage(tmp_path / "nested.usda")
    cache = UsdGeom.XformCache(T)
    placed = []
    for path in ("/Rows", "/Kit/Lamps", "/Kit2/Lamps"):  # the kits' instancers are instance proxies
        instancer = stage.GetPrimAtPath(path)
        placed += usd_placed_lights(stage, instancer, cache.GetLocalToWorldTransform(instancer))
    assert len(placed) == 2 * 2 * 2 + 2 * 2  # 2 rows of 2 visible posts of 2 lights; 2 kits of 2 lamps
    author_by_hand(tmp_path / "by_hand.usda", placed)
    instanced, messages = load(tmp_path / "nested.usda")
    assert not [m for m in messages if "PointInstancer" in m], messages
    by_hand, _ = load(tmp_path / "by_hand.usda")
    key = {"Bulb": 0, "Glow": 1, "Panel": 2}
    for light in instanced.lights:  # matched by USD's placement order, which differs from the instance order
        light.order = (key[light.path.split("[")[0].rsplit("/", 1)[1]], light.path)
    ordered = sorted(instanced.lights, key=lambda light: light.order)
    hand = {kind: [light for (prim, _), light in zip(placed, by_hand.lights) if prim.GetName() == kind]
            for kind in key}
    for a, b in zip(ordered, hand["Bulb"] + hand["Glow"] + hand["Panel"], strict=True):
        assert_same_light(a, b)
    paths = [light.path for light in instanced.lights]
    # In stage order of the world-level instancers and instances, then in instance order, outer instancer first.
    assert paths[:8] == [f"/Rows/Protos/Row/Posts/Protos/Post/{name}[{i}][{j}]" for i in (0, 1) for j in (0, 2)
                         for name in ("Lamp/Bulb", "Glow")]
    assert paths[8:] == ["/Kit/Lamps/Proto/Panel[0]", "/Kit/Lamps/Proto/Panel[1]", "/Kit2/Lamps/Proto/Panel[0]",
                         "/Kit2/Lamps/Proto/Panel[1]"]


def test_a_mesh_light_in_a_point_instancer_prototype_lights_as_the_meshes_placed_by_hand(tmp_path):
    """A mesh light (MeshLightAPI, normalized) in a PointInstancer's prototype stays geometry that emits, as inside
    native instances: one MeshLight whose triangles are sampled in each drawn instance, each divided by its own world
    area. It lights the floor as the same meshes authored by hand at USD's world transforms (three lights)."""
    stage = new_stage(tmp_path / "instanced.usda")
    panel = UsdGeom.Mesh.Define(stage, "/Lamps/Protos/Panel/Glow")
    panel.CreatePointsAttr([(-0.3, -0.3, 0), (-0.3, 0.3, 0), (0.3, 0.3, 0), (0.3, -0.3, 0)])  # front: -Z
    panel.CreateFaceVertexCountsAttr([4])
    panel.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    panel.AddTranslateOp().Set(Gf.Vec3d(0, 0, 1.0))
    light = UsdLux.MeshLightAPI.Apply(panel.GetPrim())
    UsdLux.LightAPI(light).CreateIntensityAttr(6.0)
    UsdLux.LightAPI(light).CreateNormalizeAttr(True)
    pi = UsdGeom.PointInstancer.Define(stage, "/Lamps")
    pi.CreatePrototypesRel().SetTargets([Sdf.Path("/Lamps/Protos/Panel")])
    pi.CreateProtoIndicesAttr([0, 0, 0, 0])
    pi.CreatePositionsAttr([(-1.2, 0, 0), (0, 0.3, 0.2), (1.2, 0, 0), (0, -1.3, 0)])
    tilt = Gf.Quath(Gf.Rotation(Gf.Vec3d(1, 0, 0), 20).GetQuat())
    pi.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), tilt, Gf.Quath(1, 0, 0, 0), Gf.Quath(1, 0, 0, 0)])
    pi.CreateScalesAttr([(1, 1, 1), (1, 1, 1), (2, 1, 1), (1, 1, 1)])
    pi.CreateInvisibleIdsAttr([3])
    stage.Save()
    placed = usd_placed_lights(stage, pi.GetPrim(), Gf.Matrix4d(1))
    assert len(placed) == 3
    author_by_hand(tmp_path / "by_hand.usda", placed)
    instanced, messages = load(tmp_path / "instanced.usda")
    assert not [m for m in messages if "Lamps" in m], messages
    by_hand, _ = load(tmp_path / "by_hand.usda")
    assert [type(light).__name__ for light in instanced.lights] == ["MeshLight"]
    assert len(by_hand.lights) == 3
    images = [top_down_image(scene).mean(axis=-1) for scene in (instanced, by_hand)]
    assert images[1].mean() > 0.01
    assert abs(images[0].mean() / images[1].mean() - 1) < 0.03, (images[0].mean(), images[1].mean())


def test_lights_follow_the_instancers_visibility_and_their_prototypes_from_the_root_down(tmp_path):
    """The lamps of an invisible instancer, or of one under an invisible prim, are no lights; the scope holding the
    prototypes may be invisible (visibility inside a prototype is taken from its root down, as for geometry).
    Purpose hides no light, in the world or in an instancer's prototype: a guide instancer's lamps light as a guide
    light in the world does."""
    stage = new_stage(tmp_path / "shown.usda")
    UsdGeom.Xform.Define(stage, "/Off")
    for path in ("/Shown", "/Hidden", "/Off/Lamps", "/Guide"):
        pi = UsdGeom.PointInstancer.Define(stage, path)
        UsdGeom.Scope.Define(stage, f"{path}/Protos")
        bulb(stage, f"{path}/Protos/Bulb")
        pi.CreatePrototypesRel().SetTargets([Sdf.Path(f"{path}/Protos/Bulb")])
        pi.CreateProtoIndicesAttr([0])
        pi.CreatePositionsAttr([(0, 0, 1)])
        UsdGeom.Imageable(stage.GetPrimAtPath(f"{path}/Protos")).CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    UsdGeom.Imageable(stage.GetPrimAtPath("/Hidden")).CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    UsdGeom.Imageable(stage.GetPrimAtPath("/Off")).CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    UsdGeom.Imageable(stage.GetPrimAtPath("/Guide")).CreatePurposeAttr(UsdGeom.Tokens.guide)
    guide_light = UsdLux.SphereLight.Define(stage, "/GuideLight")
    guide_light.CreatePurposeAttr(UsdGeom.Tokens.guide)
    stage.Save()
    scene, _ = load(tmp_path / "shown.usda")
    assert sorted(light.path for light in scene.lights) == ["/Guide/Protos/Bulb[0]", "/GuideLight",
                                                            "/Shown/Protos/Bulb[0]"]


def test_line_lights_in_a_point_instancer_prototype_are_the_lights_usd_places_by_hand(tmp_path):
    """A normalized CylinderLight with ``treatAsLine`` in a prototype, placed turned and scaled (one instance
    unevenly across its axis: an elliptic tube's line), is each instance's line light as read on its own."""
    stage = new_stage(tmp_path / "instanced.usda")
    tube = UsdLux.CylinderLight.Define(stage, "/Tubes/Protos/Tube")
    tube.CreateLengthAttr(1.5)
    tube.CreateRadiusAttr(0.1)
    tube.CreateIntensityAttr(6.0)
    tube.CreateNormalizeAttr(True)
    tube.CreateTreatAsLineAttr(True)
    pi = UsdGeom.PointInstancer.Define(stage, "/Tubes")
    pi.CreatePrototypesRel().SetTargets([Sdf.Path("/Tubes/Protos/Tube")])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(-1.0, 0.0, 1.0), (0.5, 0.5, 0.8), (1.0, -1.0, 1.2)])
    turn = Gf.Rotation(Gf.Vec3d(0, 0, 1), 50.0).GetQuat()
    pi.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), Gf.Quath(turn), Gf.Quath(1, 0, 0, 0)])
    pi.CreateScalesAttr([(1, 1, 1), (2, 2, 2), (1, 3, 1)])
    stage.Save()
    placed = usd_placed_lights(stage, pi.GetPrim(), UsdGeom.XformCache(T).GetLocalToWorldTransform(pi.GetPrim()))
    author_by_hand(tmp_path / "by_hand.usda", placed)
    instanced, messages = load(tmp_path / "instanced.usda")
    assert not [m for m in messages if "Tubes" in m], messages
    by_hand, _ = load(tmp_path / "by_hand.usda")
    assert len(instanced.lights) == len(by_hand.lights) == 3
    for a, b in zip(instanced.lights, by_hand.lights):
        assert a.treat_as_line
        assert_same_light(a, b)
        np.testing.assert_allclose(a.line_intensity, b.line_intensity, rtol=1e-6)
    image = top_down_image(instanced)
    assert image.mean() > 0.01
    np.testing.assert_allclose(image, top_down_image(by_hand), rtol=1e-4, atol=1e-6)


def test_lights_of_one_prototype_placed_by_two_instancers_are_named_by_their_instancer(tmp_path):
    """Two PointInstancers place one bulb prototype that lies outside both: each light's name says which instancer's
    instance it is (both first instances were ``/Protos/Bulb[0]``, warnings and ``scene.lights`` alike), found by
    position from USD's own ``ComputeInstanceTransformsAtTime``; a light beneath its instancer keeps ``[k]``."""
    stage = new_stage(tmp_path / "two.usda")
    UsdGeom.Scope.Define(stage, "/Protos").CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    bulb(stage, "/Protos/Bulb")
    for path, positions in (("/Left", [(-2, 0, 1), (-2, 1, 1)]), ("/Right", [(2, 0, 1)])):
        pi = UsdGeom.PointInstancer.Define(stage, path)
        pi.CreatePrototypesRel().SetTargets([Sdf.Path("/Protos/Bulb")])
        pi.CreateProtoIndicesAttr([0] * len(positions))
        pi.CreatePositionsAttr(positions)
    stage.Save()
    expected = {}
    for path in ("/Left", "/Right"):
        instancer = stage.GetPrimAtPath(path)
        for k, (_, m) in enumerate(usd_placed_lights(stage, instancer, Gf.Matrix4d(1.0))):
            expected[tuple(np.round(np.array(m)[3, :3], 6))] = (path, k)
    scene, messages = load(tmp_path / "two.usda")
    assert len(scene.lights) == len(expected) == 3, messages
    names = [light.path for light in scene.lights]
    assert len(set(names)) == 3, names
    for light in scene.lights:
        instancer, k = expected[tuple(np.round(light.position.astype(np.float64), 6))]
        assert light.path == f"/Protos/Bulb[{instancer}[{k}]]", (light.path, instancer, k)
