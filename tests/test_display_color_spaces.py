"""The colour space of ``primvars:displayColor``: its own ``colorSpace`` metadata, else ``UsdColorSpaceAPI`` on the
prim that holds it or an ancestor (USD's ``UsdColorSpaceAPI::ComputeColorSpaceName``), else linear Rec.709. What
is drawn (the albedo AOV of the default material, which is displayColor) is the colour USD's own conversion to
linear Rec.709 gives (``Gf.ColorSpace.ConvertRGBSpan``), on a mesh, a gprim, Points, a PointInstancer's instances and
a native instance's prototype that inherits its colour."""

import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt
from test_materials import add_quad

import wrt

COLOR = (0.6, 0.5, 0.4)
SPACES = ["srgb_rec709_scene", "lin_ap1_scene", "g22_rec709_scene", "lin_rec709_scene"]
KINDS = ["mesh", "sphere", "points", "instancer", "native instance"]


def usd_linear_rec709(space: str, rgb) -> np.ndarray:
    """``rgb`` in colour space ``space`` as linear Rec.709, converted in place by USD (``ConvertRGBSpan``, which
    converts from the space it is called on to its argument, the ``to`` of colorSpace.cpp)."""
    span = Vt.FloatArray(list(rgb))
    Gf.ColorSpace(space).ConvertRGBSpan(Gf.ColorSpace(Gf.ColorSpaceNames.LinearRec709), span)
    return np.array(span, np.float64)


def colored(stage, kind: str) -> Usd.Attribute:
    """A white-lit thing of kind ``kind`` under ``/World/Group`` that covers the origin seen from +Z, coloured by a
    constant ``displayColor`` of :data:`COLOR`; returns that primvar's attribute (the PointInstancer's, or the native
    instance's, which its prototype's quad inherits)."""
    path = "/World/Group/Thing"
    if kind == "mesh":
        gprim = add_quad(stage, path, size=4.0)
    elif kind == "sphere":
        gprim = UsdGeom.Sphere.Define(stage, path)
        gprim.CreateRadiusAttr(2.0)
    elif kind == "points":
        gprim = UsdGeom.Points.Define(stage, path)
        gprim.CreatePointsAttr([(0.0, 0.0, 0.0)])
        gprim.CreateWidthsAttr([4.0])
    elif kind == "instancer":
        gprim = UsdGeom.PointInstancer.Define(stage, path)
        add_quad(stage, f"{path}/Prototypes/Quad", size=4.0)
        gprim.CreatePrototypesRel().SetTargets([f"{path}/Prototypes/Quad"])
        gprim.CreateProtoIndicesAttr([0])
        gprim.CreatePositionsAttr([(0.0, 0.0, 0.0)])
    else:
        stage.CreateClassPrim("/Proto")  # not drawn itself
        add_quad(stage, "/Proto/Quad", size=4.0)
        gprim = UsdGeom.Xform.Define(stage, path)
        gprim.GetPrim().GetReferences().AddInternalReference("/Proto")
        gprim.GetPrim().SetInstanceable(True)
    primvar = UsdGeom.PrimvarsAPI(gprim).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                      UsdGeom.Tokens.constant)
    primvar.Set([Gf.Vec3f(*COLOR)])
    return primvar.GetAttr()


def display_stage(tmp_path, kind: str, space: str, where: str) -> str:
    """:func:`colored` with its displayColor in colour space ``space``: the attribute's own (``own``) or through
    ``UsdColorSpaceAPI`` on ``/World`` (``ancestor``)."""
    path = str(tmp_path / "display.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    world = UsdGeom.Xform.Define(stage, "/World").GetPrim()
    attr = colored(stage, kind)
    if where == "own":
        attr.SetColorSpace(space)
    else:
        Usd.ColorSpaceAPI.Apply(world).CreateColorSpaceNameAttr(space)
    stage.Save()
    if Gf.ColorSpace.IsValid(space):  # USD's own resolution gives displayColor that space
        assert Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None) == space
    return path


def rendered_albedo(path):
    """The albedo at the centre of a small top-down orthographic render of the stage at ``path``, and the load's
    warnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    camera = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), height=1.0)
    albedo = wrt.render(scene, camera=camera, width=2, height=2, device="cpu").aovs["albedo"]
    return np.asarray(albedo, np.float64).reshape(-1, 3).mean(axis=0), [str(w.message) for w in caught]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("space", SPACES)
def test_a_display_color_is_drawn_in_its_own_colour_space(tmp_path, kind, space):
    """(0.6, 0.5, 0.4) in ``srgb_rec709_scene`` is drawn as sRGB's decode of each channel, in ``lin_ap1_scene``
    (ACEScg) as its Rec.709 conversion, ...: USD's. Every one was drawn as linear Rec.709."""
    albedo, messages = rendered_albedo(display_stage(tmp_path, kind, space, "own"))
    assert not messages, messages
    np.testing.assert_allclose(albedo, usd_linear_rec709(space, COLOR), rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize("kind", ["mesh", "points"])
def test_a_display_color_takes_the_colour_space_of_usd_colour_space_api_above_it(tmp_path, kind):
    albedo, messages = rendered_albedo(display_stage(tmp_path, kind, "srgb_rec709_scene", "ancestor"))
    assert not messages, messages
    np.testing.assert_allclose(albedo, usd_linear_rec709("srgb_rec709_scene", COLOR), rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize("where", ["own", "ancestor"])
def test_a_display_color_in_an_unknown_colour_space_is_named_and_drawn_as_linear(tmp_path, where):
    """A colour space USD does not know is read as linear Rec.709, with a warning naming the prim, displayColor
    and the space (and the prim that carries an inherited one)."""
    albedo, messages = rendered_albedo(display_stage(tmp_path, "mesh", "bogus_space", where))
    named = [m for m in messages if "'bogus_space'" in m and "primvars:displayColor" in m and "/World/Group/Thing" in m]
    assert len(named) == 1, messages
    if where == "ancestor":
        assert "UsdColorSpaceAPI on /World" in named[0]
    np.testing.assert_allclose(albedo, COLOR, rtol=1e-3)


def test_a_display_colors_empty_colour_space_of_its_own_is_not_inherited_through(tmp_path):
    """``colorSpace = ""`` authored on displayColor under an ``srgb_rec709_scene`` ``/World``: USD's resolution
    (ComputeColorSpaceName) stops at the attribute's own, empty, one (linear Rec.709); it was drawn as sRGB."""
    path = display_stage(tmp_path, "mesh", "srgb_rec709_scene", "ancestor")
    stage = Usd.Stage.Open(path)
    attr = stage.GetPrimAtPath("/World/Group/Thing").GetAttribute("primvars:displayColor")
    attr.SetColorSpace("")
    stage.Save()
    resolved = Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None) or Gf.ColorSpaceNames.LinearRec709
    albedo, messages = rendered_albedo(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo, usd_linear_rec709(resolved, COLOR), rtol=1e-3, atol=1e-4)


def instanced_asset_stage(tmp_path, where: str) -> tuple[str, list]:
    """Instanceable references ``/World/Group/Thing`` (and ``/World/Other/Thing``) to an asset ``/Proto`` whose quad
    has its own displayColor of :data:`COLOR`, no ``colorSpace``; ``srgb_rec709_scene`` through ``UsdColorSpaceAPI``
    on ``/World`` (``above``), on the asset's root ``/Proto`` (``asset``), on ``/World/Group`` alone (``one``, the
    other instance under none), or there with ``lin_ap1_scene`` on ``/World/Other`` (``two``). Returns the path and
    the colour spaces USD resolves for the displayColor of the quad of each instance proxy (ComputeColorSpaceName)."""
    path = str(tmp_path / "instanced.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    world = UsdGeom.Xform.Define(stage, "/World").GetPrim()
    stage.CreateClassPrim("/Proto")
    quad = add_quad(stage, "/Proto/Quad", size=4.0)
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                            UsdGeom.Tokens.constant).Set([Gf.Vec3f(*COLOR)])
    holder = {"above": world, "asset": stage.GetPrimAtPath("/Proto")}.get(where)
    for group in ("/World/Group", "/World/Other"):
        instance = UsdGeom.Xform.Define(stage, f"{group}/Thing")
        instance.GetPrim().GetReferences().AddInternalReference("/Proto")
        instance.GetPrim().SetInstanceable(True)
        if group == "/World/Other":
            instance.AddTranslateOp().Set(Gf.Vec3d(100.0, 0.0, 0.0))  # out of the render's view
    if holder is None:
        holder = UsdGeom.Xform.Define(stage, "/World/Group").GetPrim()
    Usd.ColorSpaceAPI.Apply(holder).CreateColorSpaceNameAttr("srgb_rec709_scene")
    if where == "two":
        Usd.ColorSpaceAPI.Apply(stage.GetPrimAtPath("/World/Other")).CreateColorSpaceNameAttr("lin_ap1_scene")
    stage.Save()
    proxies = [stage.GetPrimAtPath(f"{group}/Thing/Quad").GetAttribute("primvars:displayColor")
               for group in ("/World/Group", "/World/Other")]
    return path, [str(Usd.ColorSpaceAPI.ComputeColorSpaceName(attr, None)) for attr in proxies]


@pytest.mark.parametrize("where", ["above", "asset"])
def test_a_native_prototypes_colour_takes_the_colour_space_its_instances_inherit(tmp_path, where):
    """USD resolves the colour of an instance proxy's quad (ComputeColorSpaceName walks up through the instance to
    its ancestors; the prototype's root carries no opinion of the instance, not even the asset root's
    ``colorSpace:name``) to ``srgb_rec709_scene``, as for the asset referenced plainly; wrt read the prototype's quad,
    whose walk ended at the prototype's root, as linear Rec.709."""
    path, resolved = instanced_asset_stage(tmp_path, where)
    assert resolved == ["srgb_rec709_scene"] * 2
    albedo, messages = rendered_albedo(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo, usd_linear_rec709("srgb_rec709_scene", COLOR), rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize("where", ["one", "two"])
def test_a_native_prototype_whose_instances_inherit_different_colour_spaces_is_named(tmp_path, where):
    """One prototype, one instance under ``srgb_rec709_scene`` and one under none or ``lin_ap1_scene`` (USD resolves
    their proxies apart): its colours are read once for both, as linear, with a warning naming the prims that carry
    the spaces. With a space above every instance the load raised StopIteration (the words sought one under none)."""
    path, resolved = instanced_asset_stage(tmp_path, where)
    assert resolved == ["srgb_rec709_scene", "" if where == "one" else "lin_ap1_scene"]
    albedo, messages = rendered_albedo(path)
    named = [m for m in messages if "primvars:displayColor" in m and "/World/Group" in m
             and (where == "one" or "/World/Other" in m)]
    assert len(named) == 1, messages
    np.testing.assert_allclose(albedo, COLOR, rtol=1e-3)


@pytest.mark.parametrize("kind", ["mesh", "sphere", "points"])
def test_a_display_color_past_float32_after_its_conversion_is_named_and_drawn_grey(tmp_path, kind):
    """ACEScg red 3e38 (a float32) in ``lin_ap1_scene`` is 5.1e38 in linear Rec.709, past float32 (USD's own
    conversion, in float32, gives no finite red): it is named and drawn grey 0.5, as a non-finite displayColor is.
    The conversion kept it finite in float64, past the readers' checks: a gprim's or Points prim's load failed (a
    shape's colour must be finite), and a mesh's cast warned numpy's "overflow encountered in cast"."""
    big = (3e38, 0.0, 0.0)
    assert not np.isfinite(usd_linear_rec709("lin_ap1_scene", big)).all()
    path = str(tmp_path / "big.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    attr = colored(stage, kind)
    attr.Set([Gf.Vec3f(*big)])
    attr.SetColorSpace("lin_ap1_scene")
    stage.Save()
    albedo, messages = rendered_albedo(path)
    assert len(messages) == 1 and "displayColor" in messages[0] and "/World/Group/Thing" in messages[0], messages
    np.testing.assert_allclose(albedo, 0.5, rtol=1e-6)


def test_a_nested_native_prototypes_colour_takes_the_colour_space_of_the_asset_that_instances_it(tmp_path):
    """An instanced asset ``/Inner`` (a quad with its own displayColor, no colorSpace) instanced inside another
    instanced asset ``/Outer`` whose root carries ``g22_rec709_scene`` through ``UsdColorSpaceAPI``: the walk from
    the inner prototype's quad goes through its instance inside the outer prototype, then the outer prototype's
    instance, as USD resolves the doubly proxied quad (``ComputeColorSpaceName``). Guard for the prototype walk."""
    path = str(tmp_path / "nested.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/World")
    stage.CreateClassPrim("/Inner")
    quad = add_quad(stage, "/Inner/Quad", size=4.0)
    UsdGeom.PrimvarsAPI(quad).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                            UsdGeom.Tokens.constant).Set([Gf.Vec3f(*COLOR)])
    outer = stage.CreateClassPrim("/Outer")
    Usd.ColorSpaceAPI.Apply(outer).CreateColorSpaceNameAttr("g22_rec709_scene")
    for instance, asset in (("/Outer/In", "/Inner"), ("/World/Thing", "/Outer")):
        prim = UsdGeom.Xform.Define(stage, instance).GetPrim()
        prim.GetReferences().AddInternalReference(asset)
        prim.SetInstanceable(True)
    stage.Save()
    proxy = stage.GetPrimAtPath("/World/Thing/In/Quad").GetAttribute("primvars:displayColor")
    assert Usd.ColorSpaceAPI.ComputeColorSpaceName(proxy, None) == "g22_rec709_scene"
    albedo, messages = rendered_albedo(path)
    assert not messages, messages
    np.testing.assert_allclose(albedo, usd_linear_rec709("g22_rec709_scene", COLOR), rtol=1e-3, atol=1e-4)


def prototypes_stage(path: str, space: str, count: int = 3) -> str:
    """``count`` instanced assets ``/Proto<k>``, each of two quads with their own displayColor (no ``colorSpace``),
    each instanced twice under groups carrying ``space`` through ``UsdColorSpaceAPI``: every quad's colour is read
    in the space its instances inherit. The colours lie inside Rec.709's gamut from ACEScg (no negative channel once
    converted, which is named in a warning)."""
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/World")
    for k in range(count):
        stage.CreateClassPrim(f"/Proto{k}")
        for q in range(2):
            quad = add_quad(stage, f"/Proto{k}/Quad{q}", center=(q * 3.0, 0.0, 0.0))
            UsdGeom.PrimvarsAPI(quad).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                    UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.1 * q + 0.5, 0.5, 0.4)])
        for j in range(2):
            group = UsdGeom.Xform.Define(stage, f"/World/Group{k}_{j}").GetPrim()
            Usd.ColorSpaceAPI.Apply(group).CreateColorSpaceNameAttr(space)
            instance = UsdGeom.Xform.Define(stage, f"/World/Group{k}_{j}/Thing")
            instance.GetPrim().GetReferences().AddInternalReference(f"/Proto{k}")
            instance.GetPrim().SetInstanceable(True)
            instance.AddTranslateOp().Set(Gf.Vec3d(10.0 * k, 10.0 * j, 0.0))
    stage.Save()
    return path


def prototype_colors(scene) -> list:
    """``(prototype path, mesh path, colours)`` of every prototype mesh of ``scene``, for comparing loads."""
    return [(p.path, m.path, m.colors) for p in scene.prototypes for m in p.meshes]


def test_two_loads_at_once_in_threads_keep_their_own_prototype_colour_spaces(tmp_path, monkeypatch):
    """The colour spaces of native prototypes were kept in one module-global dict, emptied at the end of each load:
    a load ending in one thread (Dask's threaded workers) while another ran in a second thread emptied the other's,
    which then walked its prototypes' instances again (and read a KeyError where the two ran truly in parallel).
    The loads are interleaved deterministically: the first pauses after its first colour, the second runs whole, the
    first goes on. Oracle: each Scene equals its serial load, and each load walks each instance of the stage's
    prototypes once (USD's Stage.GetPrototypes and Prim.GetInstances)."""
    import threading

    from wrt import color_spaces, usd_mesh_primvars

    paths = [prototypes_stage(str(tmp_path / f"{space}.usda"), space) for space in ("srgb_rec709_scene", SPACES[1])]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        serial = [prototype_colors(wrt.load_usd(path)) for path in paths]
    stages = [Usd.Stage.Open(path) for path in paths]  # held: a prototype of a stage freed has expired
    instances = [sum(len(p.GetInstances()) for p in stage.GetPrototypes()) for stage in stages]
    assert instances == [6, 6]

    walks, walk = {}, color_spaces._prim_space

    def counted_walk(prim, api):
        if prim.IsInstance():
            walks[threading.get_ident()] = walks.get(threading.get_ident(), 0) + 1
        return walk(prim, api)

    first_paused, second_done, read = threading.Event(), threading.Event(), usd_mesh_primvars.linear_colors

    def pausing_read(*args):
        values = read(*args)
        if threading.current_thread().name == "first" and not first_paused.is_set():
            first_paused.set()
            assert second_done.wait(60)
        return values

    monkeypatch.setattr(color_spaces, "_prim_space", counted_walk)
    monkeypatch.setattr(usd_mesh_primvars, "linear_colors", pausing_read)
    results, counts = {}, {}

    def load(name, path, after=None):
        if after is not None:
            assert after.wait(60)
        try:
            results[name] = prototype_colors(wrt.load_usd(path))
        except Exception as error:  # a KeyError: asserted below, with the thread's name
            results[name] = error
        counts[name] = walks.get(threading.get_ident(), 0)
        if name == "second":
            second_done.set()

    threads = [threading.Thread(target=load, name="first", args=("first", paths[0])),
               threading.Thread(target=load, name="second", args=("second", paths[1], first_paused))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(120)
    assert first_paused.is_set() and second_done.is_set()
    for name, expected in zip(("first", "second"), serial):
        got = results[name]
        assert not isinstance(got, Exception), (name, got)
        assert [(p, m) for p, m, _ in got] == [(p, m) for p, m, _ in expected], name
        for (_, mesh, colors), (_, _, want) in zip(got, expected):
            np.testing.assert_array_equal(colors, want, err_msg=f"{name} {mesh}")
    assert counts == {"first": instances[0], "second": instances[1]}


@pytest.mark.parametrize("kind", KINDS)
def test_a_negative_display_color_is_named_and_clamped_to_0(tmp_path, kind):
    """A displayColor with a channel below 0 (an exporter's mistake) is drawn with that channel 0, as it was, but no
    longer without a word: the warning names the prim that holds it (the instancer, the native instance)."""
    path = str(tmp_path / "negative.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    colored(stage, kind).Set([Gf.Vec3f(-0.5, 0.5, 0.4)])
    stage.Save()
    albedo, messages = rendered_albedo(path)
    named = [m for m in messages if "negative" in m and "displayColor" in m and "/World/Group/Thing" in m]
    assert len(named) == 1, messages
    np.testing.assert_allclose(albedo, (0.0, 0.5, 0.4), rtol=1e-3, atol=1e-4)


def test_a_display_color_outside_rec709s_gamut_is_named_and_clamped_to_0(tmp_path):
    """ACEScg's red is outside Rec.709's gamut: USD's conversion gives it negative green and blue, drawn as 0, named
    as a light's colour is."""
    path = display_stage(tmp_path, "mesh", "lin_ap1_scene", "own")
    stage = Usd.Stage.Open(path)
    stage.GetPrimAtPath("/World/Group/Thing").GetAttribute("primvars:displayColor").Set([Gf.Vec3f(1.0, 0.0, 0.0)])
    stage.Save()
    converted = usd_linear_rec709("lin_ap1_scene", (1.0, 0.0, 0.0))
    assert converted[1] < 0.0 and converted[2] < 0.0  # USD's own answer: outside Rec.709's gamut
    albedo, messages = rendered_albedo(path)
    named = [m for m in messages if "negative" in m and "gamut" in m and "displayColor" in m and "/World/Group" in m]
    assert len(named) == 1, messages
    np.testing.assert_allclose(albedo, np.maximum(converted, 0.0), rtol=1e-3, atol=1e-4)
