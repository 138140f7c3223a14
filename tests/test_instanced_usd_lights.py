"""UsdLux lights inside native instances (a lamp asset referenced as ``instanceable``, as DCCs write set dressing)
are lights of their own in each instance, at the instance-proxy paths UsdLux's ``ComputeLightList`` reports, placed
by each instance's transform (nested instances too, hidden instances and hidden lights left out); they light a white
floor as the numerical integral over each sphere says (tests/light_oracle.py). Cameras inside PointInstancer
prototypes, which UsdGeom cannot name by a path, are skipped with a warning."""

import math
import warnings

import numpy as np
from light_oracle import irradiance, sphere, trs
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

import wrt

RADIUS = 0.1  # of the lamp's SphereLight, at (0, 0, 1) in the lamp
INTENSITY = 3.0


def lamp_stage(path):
    """A floor, a lamp ``/Protos/Lamp`` (a SphereLight and a hidden RectLight, under a class), instances ``/A``
    (scaled by 2), ``/B`` and ``/Hidden`` (invisible) of it, and ``/Set`` instancing ``/Protos/Pair``, which holds an
    instance of the lamp (nested). Returns the stage and the lamps' world transforms by instance-proxy light path."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-40, -40, 0), (40, -40, 0), (40, 40, 0), (-40, 40, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    floor.CreateDisplayColorAttr([(1.0, 1.0, 1.0)])
    stage.CreateClassPrim("/Protos")  # abstract: drawn only through the instances
    light = UsdLux.SphereLight.Define(stage, "/Protos/Lamp/Light")
    light.CreateRadiusAttr(RADIUS)
    light.CreateIntensityAttr(INTENSITY)
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 0, 1))
    UsdLux.RectLight.Define(stage, "/Protos/Lamp/Hidden").CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    inner = stage.DefinePrim("/Protos/Pair/Inner", "Xform")
    inner.GetReferences().AddInternalReference("/Protos/Lamp")
    inner.SetInstanceable(True)
    UsdGeom.Xformable(inner).AddTranslateOp().Set(Gf.Vec3d(0, 0.5, 0))
    places = {"/A": trs((-1.0, 0.2, 0.0), (0, 0, 30), (2, 2, 2)), "/B": trs((0.8, -0.3, 0.2)),
              "/Hidden": trs((0, 0, -0.5)), "/Set": trs((0.2, 0.4, 0.0))}
    for name, m in places.items():
        prim = stage.DefinePrim(name, "Xform")
        prim.GetReferences().AddInternalReference("/Protos/Pair" if name == "/Set" else "/Protos/Lamp")
        prim.SetInstanceable(True)
        UsdGeom.Xformable(prim).AddTransformOp().Set(Gf.Matrix4d(*m.T.ravel()))
    UsdGeom.Imageable(stage.GetPrimAtPath("/Hidden")).CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    stage.Save()
    up = trs((0, 0, 1.0))
    lamps = {"/A/Light": places["/A"] @ up, "/B/Light": places["/B"] @ up,
             "/Set/Inner/Light": places["/Set"] @ trs((0, 0.5, 0)) @ up}
    return stage, lamps


def test_lights_in_native_instances_are_one_light_each_at_the_paths_usdlux_lists(tmp_path):
    stage, lamps = lamp_stage(tmp_path / "lamps.usda")
    listed = UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(UsdLux.LightListAPI.ComputeModeIgnoreCache)
    # USD lists every light (the hidden ones too); wrt draws the visible ones.
    assert {"/A/Light", "/B/Light", "/Set/Inner/Light"} <= {str(p) for p in listed}
    scene = wrt.load_usd(str(tmp_path / "lamps.usda"))
    lights = {light.path: light for light in scene.lights}
    assert set(lights) == set(lamps)
    for path, m in lamps.items():  # USD's own world transform of the instance proxy
        proxy = stage.GetPrimAtPath(path)
        assert proxy.IsInstanceProxy()
        world = np.array(UsdGeom.Xformable(proxy).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
        np.testing.assert_allclose(world, m, atol=1e-9)
        np.testing.assert_allclose(lights[path].position, m[:3, 3], atol=1e-9)
        np.testing.assert_allclose(lights[path].world_radius, RADIUS * np.linalg.norm(m[:3, 0]), rtol=1e-6)


def test_lights_in_native_instances_light_the_floor_as_the_integral_over_each(tmp_path):
    _, lamps = lamp_stage(tmp_path / "lamps.usda")
    scene = wrt.load_usd(str(tmp_path / "lamps.usda"))
    elements = [sphere(m, RADIUS, n=60) for m in lamps.values()]
    for centre in (np.array([-1.0, 0.2, 0.0]), np.array([0.5, 0.2, 0.0])):
        t = (np.arange(4) + 0.5) / 4 * 0.2 - 0.1
        gx, gy = np.meshgrid(centre[0] + t, centre[1] + t)
        points = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], -1)
        expected = sum(irradiance(points, e) for e in elements).mean() * INTENSITY / math.pi
        cam = wrt.Camera.orthographic(eye=centre + (0, 0, 0.02), target=centre, up=(0, 1, 0), height=0.2)
        img = wrt.render(scene, camera=cam, width=8, height=8, spp=64, seed=3, device="cpu", integrator="whitted")
        np.testing.assert_allclose(img.rgb.reshape(-1, 3).mean(0), expected, rtol=0.02)


def test_cameras_in_point_instancer_prototypes_are_skipped_with_a_warning(tmp_path):
    """A camera inside a PointInstancer's prototype (which UsdGeom gives no path per instance) is skipped with a
    warning naming it; the light beside it is one light per instance (tests/test_point_instanced_lights.py)."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "pi.usda"))
    instancer = UsdGeom.PointInstancer.Define(stage, "/Lamps")
    UsdLux.SphereLight.Define(stage, "/Lamps/Proto/Light")
    UsdGeom.Camera.Define(stage, "/Lamps/Proto/Cam")
    instancer.CreatePrototypesRel().SetTargets([Sdf.Path("/Lamps/Proto")])
    instancer.CreateProtoIndicesAttr([0, 0])
    instancer.CreatePositionsAttr([(0, 0, 0), (1, 0, 0)])
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(str(tmp_path / "pi.usda"))
    assert not scene.cameras
    assert [light.path for light in scene.lights] == ["/Lamps/Proto/Light[0]", "/Lamps/Proto/Light[1]"]
    messages = [str(w.message) for w in caught]
    assert any("cameras inside PointInstancer prototypes" in m and "/Lamps/Proto/Cam" in m for m in messages)
    assert not any("/Lamps/Proto/Light" in m for m in messages), messages


def test_an_instanceable_light_prim_is_a_light(tmp_path):
    """A light prim that is itself an instance (a SphereLight referencing a bulb asset, marked ``instanceable``,
    in the world and inside another prototype) keeps its own light: USD lists it, and it was dropped without a
    word (its prototype holds only its children)."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "bulbs.usda"))
    stage.CreateClassPrim("/Protos")
    bulb = UsdLux.SphereLight.Define(stage, "/Protos/Bulb")
    bulb.CreateIntensityAttr(5.0)
    UsdGeom.Xform.Define(stage, "/Protos/Bulb/Child")
    holder = UsdGeom.Xform.Define(stage, "/Protos/Holder")
    holder.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    for path, translate in (("/A", (1, 0, 2)), ("/Protos/Holder/Inner", (0, 0, 3)), ("/H", (-1, 0, 0))):
        prim = UsdLux.SphereLight.Define(stage, path).GetPrim() if path != "/H" else stage.DefinePrim(path, "Xform")
        prim.GetReferences().AddInternalReference("/Protos/Holder" if path == "/H" else "/Protos/Bulb")
        prim.SetInstanceable(True)
        UsdGeom.Xformable(prim).AddTranslateOp(opSuffix="place").Set(Gf.Vec3d(*translate))
    # An instanceable mesh light of guide purpose is not drawn, so it is no light either.
    panel = UsdGeom.Mesh.Define(stage, "/Protos/Panel")
    UsdLux.MeshLightAPI.Apply(panel.GetPrim())
    UsdGeom.Xform.Define(stage, "/Protos/Panel/Child")
    guide = UsdGeom.Mesh.Define(stage, "/Guide")
    guide.GetPrim().GetReferences().AddInternalReference("/Protos/Panel")
    guide.GetPrim().SetInstanceable(True)
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    stage.Save()
    listed = UsdLux.LightListAPI(stage.GetPseudoRoot()).ComputeLightList(UsdLux.LightListAPI.ComputeModeIgnoreCache)
    assert {str(p) for p in listed} >= {"/A", "/H/Inner"}
    scene = wrt.load_usd(str(tmp_path / "bulbs.usda"))
    lights = {light.path: light for light in scene.lights}
    assert set(lights) == {"/A", "/H/Inner"}
    for path, light in lights.items():
        world = UsdGeom.Xformable(stage.GetPrimAtPath(path)).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        np.testing.assert_allclose(light.position, np.array(world.ExtractTranslation()), atol=1e-9)
        np.testing.assert_allclose(light.color, 5.0)
