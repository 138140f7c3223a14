"""UsdLux light linking (``collection:lightLink``: the prims a light lights) and shadow linking
(``collection:shadowLink``: the prims that cast its shadows), for the path and whitted integrators: membership as USD's
collection query decides it, per drawn mesh, gprim or instance part (:mod:`wrt.light_links`)."""

import warnings

import numpy as np
import pytest
import warp as wp
from pxr import Sdf, Usd, UsdGeom, UsdLux
from shading_helpers import quad
from usda_text import write

import wrt
from wrt.errors import SceneError
from wrt.light_links import LinkCollection

INTEGRATORS = ["path", "whitted"]
DOWN = np.array([0.0, 0.0, -1.0])
TOP = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=4.0)  # x, y in [-2, 2]


def render(scene, integrator, camera=TOP, spp=4, max_depth=1):
    """Radiance of ``scene`` (direct light only), 8 pixels high, 64 wide for :data:`ROW` and 8 for other cameras."""
    width = 64 if camera is ROW else 8
    return wrt.render(scene, camera=camera, width=width, height=8, spp=spp, device="cpu", integrator=integrator,
                      max_depth=max_depth).rgb


def load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path)


def floor_and_box(lights):
    """A floor (``/World/Ground/Floor``, z = 0; the left half of :data:`TOP`) and a raised double-sided box top
    (``/World/Box``, z = 0.5, x > 0.25; the right columns)."""
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/World/Ground/Floor")
    box = quad((1.5, 0, 0.5), (2.5, 0, 0), (0, 5, 0), name="/World/Box")
    return wrt.Scene(meshes=[floor, box], lights=list(lights))


FLOOR_PX = (slice(None), slice(0, 3))  # x < -0.5: floor only
BOX_PX = (slice(None), slice(6, 8))  # x > 1: the box


def test_membership_is_usds(tmp_path):
    """``LinkCollection.includes`` agrees with ``UsdCollectionMembershipQuery.IsPathIncluded`` on includes, excludes
    below includes, includes below excludes, ``explicitOnly``, ``includeRoot`` and a missing target."""
    stage = Usd.Stage.CreateInMemory()
    paths = ["/W", "/W/A", "/W/A/B", "/W/A/B/C", "/W/A/B/C/D", "/W/E", "/Other", "/Missing/x"]
    cases = [
        (False, "expandPrims", ["/W/A", "/W/A/B/C", "/Missing"], ["/W/A/B"]),
        (True, "expandPrims", [], ["/W/A"]),
        (False, "explicitOnly", ["/W/A", "/W/A/B/C"], ["/W/A/B"]),
        (True, "explicitOnly", ["/W/A/B/C"], ["/W"]),
        (False, "expandPrimsAndProperties", ["/W"], ["/W/A/B/C/D"]),
        (False, "expandPrims", [], []),
    ]
    for k, (root, rule, includes, excludes) in enumerate(cases):
        light = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, f"/L{k}"))
        collection = light.GetLightLinkCollectionAPI()
        collection.CreateIncludeRootAttr(root)
        collection.CreateExpansionRuleAttr(rule)
        for path in includes:
            collection.CreateIncludesRel().AddTarget(path)
        for path in excludes:
            collection.CreateExcludesRel().AddTarget(path)
        query = collection.ComputeMembershipQuery()
        ours = LinkCollection({str(p): str(r) for p, r in query.GetAsPathExpansionRuleMap().items()})
        for path in paths:
            assert ours.includes(path) == query.IsPathIncluded(Sdf.Path(path)), (k, path)


def test_membership_passes_over_an_explicit_only_ancestor(tmp_path):
    """A lightLink holding every prim but ``/W/E`` that includes another collection of ``explicitOnly`` rule on
    ``/W/A``: the map gets ``/W/A: explicitOnly`` under ``/: expandPrims``, and USD's query passes over that ancestor
    (``/W/A/B`` stays a member, by the root). wrt left ``/W/A/B`` out (unlit) before; ``/`` itself is no prim."""
    stage = Usd.Stage.CreateInMemory()
    for path in ["/W/A/B/C", "/W/E"]:
        stage.DefinePrim(path, "Xform")
    chosen = Usd.CollectionAPI.Apply(stage.GetPrimAtPath("/W"), "chosen")
    chosen.CreateIncludeRootAttr(False)
    chosen.CreateExpansionRuleAttr("explicitOnly")
    chosen.CreateIncludesRel().AddTarget("/W/A")
    collection = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, "/L")).GetLightLinkCollectionAPI()
    collection.CreateIncludesRel().AddTarget(chosen.GetCollectionPath())
    collection.CreateExcludesRel().AddTarget("/W/E")
    query = collection.ComputeMembershipQuery()
    ours = wrt.light_links.read_collection(collection, "light linking", None)
    assert ours.rules["/W/A"] == "explicitOnly"
    for path in ["/", "/W", "/W/A", "/W/A/B", "/W/A/B/C", "/W/E", "/W/E/x", "/Other"]:
        assert ours.includes(path) == query.IsPathIncluded(Sdf.Path(path)), path
    assert ours.includes("/W/A/B/C") and not ours.includes("/W/E")


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_light_excluding_a_parent_xform_leaves_the_floor_to_the_other_light(integrator):
    """A red and a green sun; the red one's lightLink excludes the floor's parent Xform: the floor carries green only
    (the render without the red sun, red exactly 0), the box both colours. Before, both lit the floor."""
    red = wrt.DistantLight(direction=DOWN, color=np.array([2.0, 0, 0]),
                           light_link=LinkCollection.excluding("/World/Ground"))
    green = wrt.DistantLight(direction=DOWN, color=np.array([0, 2.0, 0]))
    both = render(floor_and_box([red, green]), integrator, spp=32)
    alone = render(floor_and_box([green]), integrator, spp=32)
    np.testing.assert_array_equal(both[FLOOR_PX][..., 0], 0.0)
    rtol = 0.1 if integrator == "path" else 1e-6  # path picks one light per sample: equal within noise
    np.testing.assert_allclose(both[FLOOR_PX].mean(), alone[FLOOR_PX].mean(), rtol=rtol)
    assert both[BOX_PX][..., 0].min() > 0.1 and both[BOX_PX][..., 1].min() > 0.1


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_unlinked_area_light_and_dome_reach_the_floor_by_no_path(integrator):
    """A rect light above and a dome, both linked to the box only: the floor is black, though light sampling picks
    them and BSDF-sampled rays from the floor hit them (MIS; whitted's dome term), while the box is lit and the
    camera still sees the dome. Before, the floor was lit by both."""
    only_box = LinkCollection.only("/World/Box")
    above = np.eye(4)
    above[2, 3] = 3.0  # at z = 3, emitting down its -Z
    rect = wrt.RectLight(to_world=above, width=4.0, height=4.0, color=np.full(3, 2.0), light_link=only_box)
    dome = wrt.DomeLight(color=np.full(3, 0.5, np.float32), light_link=only_box)
    below_rect = wrt.Camera.orthographic(eye=(0, 0, 2.5), target=(0, 0, 0), up=(0, 1, 0), height=4.0)
    rgb = render(floor_and_box([rect, dome]), integrator, camera=below_rect, spp=16)
    np.testing.assert_array_equal(rgb[FLOOR_PX], 0.0)
    assert rgb[BOX_PX].min() > 0.05
    sky = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 6), up=(0, 1, 0), height=0.1)  # up, past the rect
    np.testing.assert_allclose(render(floor_and_box([dome]), integrator, camera=sky, spp=1), 0.5)


SLANT = np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)  # a sun at 45 degrees: the blocker's shadow moves +1 in x
UNDER = wrt.Camera.orthographic(eye=(-1, 0, 0.5), target=(-1, 0, 0), up=(0, 1, 0), height=1.6)  # below the blocker


def shadow_scene(lights, blocker=True):
    """A floor and, at z = 1 over x in [-3, -1], a blocker whose shadow under :data:`SLANT` covers all of
    :data:`UNDER`'s view (the camera is below the blocker, which it does not see)."""
    meshes = [quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/Floor")]
    if blocker:
        meshes.append(quad((-2, 0, 1), (2, 0, 0), (0, 4, 0), name="/Blocker"))
    return wrt.Scene(meshes=meshes, lights=list(lights))


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_blocker_left_out_of_shadow_link_casts_no_shadow_of_that_light(integrator):
    """Red and green suns along :data:`SLANT`; the blocker is left out of the red one's shadowLink: under it the
    floor's red equals the render without the blocker, while the green sun's shadow stays (0). Before, both
    were shadowed (red 0)."""
    red = wrt.DistantLight(direction=SLANT, color=np.array([2.0, 0, 0]),
                           shadow_link=LinkCollection.excluding("/Blocker"))
    green = wrt.DistantLight(direction=SLANT, color=np.array([0, 2.0, 0]))
    linked = render(shadow_scene([red, green]), integrator, camera=UNDER, spp=32)
    open_sky = render(shadow_scene([red], blocker=False), integrator, camera=UNDER, spp=32)
    np.testing.assert_array_equal(linked[..., 1], 0.0)
    assert open_sky[..., 0].min() > 0.1
    rtol = 0.1 if integrator == "path" else 1e-6  # path picks one light per sample: equal within noise
    np.testing.assert_allclose(linked[..., 0].mean(), open_sky[..., 0].mean(), rtol=rtol)


def quad_usda(name, x, z=0.0, half=0.4, indent=""):
    """USDA text of a square mesh ``name`` of half size ``half`` centred at ``(x, 0, z)``, facing +Z."""
    pts = [(x - half, -half, z), (x + half, -half, z), (x + half, half, z), (x - half, half, z)]
    return (f'{indent}def Mesh "{name}"\n{indent}{{\n{indent}    point3f[] points = {pts}\n'
            f'{indent}    int[] faceVertexCounts = [4]\n{indent}    int[] faceVertexIndices = [0, 1, 2, 3]\n'
            f'{indent}    uniform bool doubleSided = 1\n{indent}}}\n')


def sun_usda(name, color, link="", shadow=""):
    """USDA text of a sun straight down (-Z) of illuminance 2 in ``color``, with ``link`` and ``shadow`` lines of
    its lightLink and shadowLink collections (``rel collection:lightLink:excludes = </X>``, ...)."""
    return (f'def DistantLight "{name}" (\n    prepend apiSchemas = ["CollectionAPI:lightLink", '
            f'"CollectionAPI:shadowLink"]\n)\n{{\n    color3f inputs:color = {color}\n    float inputs:intensity = 2\n'
            f'    float inputs:angle = 0\n    {link}\n    {shadow}\n}}\n')


def z_up(tmp_path, body):
    path = write(tmp_path, body)
    with open(path) as f:
        text = f.read().replace('upAxis = "Y"', 'upAxis = "Z"')
    with open(path, "w") as f:
        f.write(text)
    return path


def red_and_green(tmp_path, body, red_link, camera=TOP, integrator="whitted"):
    """Red and green radiance of the stage ``body`` under a green sun and a red sun whose lightLink lines are
    ``red_link``; loading gives no warning about linking."""
    path = z_up(tmp_path, body + sun_usda("Red", (1, 0, 0), red_link) + sun_usda("Green", (0, 1, 0)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    assert not [w for w in caught if "link" in str(w.message)], [str(w.message) for w in caught]
    return render(scene, integrator, camera=camera)


ROW = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=1.0)  # x in [-4, 4] at 64x8


def lit_red(rgb, xs):
    """Whether the red sun lights the object at each x of ``xs`` in a 64 x 8 render of :data:`ROW`."""
    cols = [int((x + 4.0) / 8.0 * 64) for x in xs]
    return [bool(rgb[4, c, 0] > 0.1) for c in cols]


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_usd_collections_parent_xform_expansion_rule_and_missing_target(tmp_path, integrator):
    """Read from USD: ``excludes`` of a parent Xform; ``includeRoot = 0`` with an include of a missing prim (USD's
    query holds nothing that exists: the red sun lights nothing); ``expansionRule = explicitOnly`` including the
    parent of a mesh (not the mesh itself, as USD decides). The green sun always lights everything."""
    body = 'def Xform "World"\n{\n    def Xform "Group"\n    {\n' + quad_usda("A", -1.0, indent="        ") + \
        "    }\n" + quad_usda("B", 1.0, indent="    ") + "}\n"
    wide = dict(camera=ROW, integrator=integrator)
    rgb = red_and_green(tmp_path, body, "rel collection:lightLink:excludes = </World/Group>", **wide)
    assert lit_red(rgb, [-1.0, 1.0]) == [False, True]
    assert (rgb[4, [24, 40], 1] > 0.1).all()  # green everywhere
    missing = "uniform bool collection:lightLink:includeRoot = 0\n    rel collection:lightLink:includes = </Nowhere>"
    assert lit_red(red_and_green(tmp_path, body, missing, **wide), [-1.0, 1.0]) == [False, False]
    explicit = ('uniform bool collection:lightLink:includeRoot = 0\n    uniform token '
                'collection:lightLink:expansionRule = "explicitOnly"\n    rel collection:lightLink:includes = '
                '[</World/Group>, </World/B>]')
    assert lit_red(red_and_green(tmp_path, body, explicit, **wide), [-1.0, 1.0]) == [False, True]


def test_native_and_point_instances_take_their_proxy_and_prototype_paths(tmp_path):
    """Native instances are linked by their instance-proxy paths: one excluded whole, one part of another excluded
    (``/World/I1/geo/Right``: the parts of that instance differ), a third lit; PointInstancer instances by their
    prototypes' paths under the instancer (``/World/PI/Protos/B`` excluded: both its instances dark)."""
    inner = " " * 8
    proto = ('def Xform "Proto"\n{\n    def Xform "geo"\n    {\n' + quad_usda("Left", -0.25, half=0.2, indent=inner)
             + quad_usda("Right", 0.25, half=0.2, indent=inner) + "    }\n}\n")
    instances = "".join(
        f'    def "I{k}" (\n        instanceable = true\n        prepend references = </Proto>\n    )\n    {{\n'
        f'        double3 xformOp:translate = ({x}, 0, 0)\n        uniform token[] xformOpOrder = ["xformOp:translate"]'
        f'\n    }}\n' for k, x in enumerate([-3.0, -2.0, -1.0]))
    instancer = ('    def PointInstancer "PI"\n    {\n'
                 '        rel prototypes = [</World/PI/Protos/A>, </World/PI/Protos/B>]\n'
                 '        int[] protoIndices = [0, 1, 0, 1]\n        point3f[] positions = [(0.5, 0, 0), (1.5, 0, 0), '
                 '(2.5, 0, 0), (3.5, 0, 0)]\n        def Xform "Protos"\n        {\n'
                 + quad_usda("A", 0.0, half=0.3, indent="            ") + quad_usda("B", 0.0, half=0.3,
                                                                                    indent="            ")
                 + "        }\n    }\n")
    body = proto + 'def Xform "World"\n{\n' + instances + instancer + "}\n"
    link = "rel collection:lightLink:excludes = [</World/I0>, </World/I1/geo/Right>, </World/PI/Protos/B>]"
    rgb = red_and_green(tmp_path, body, link, camera=ROW)
    xs = [-3.25, -2.75, -2.25, -1.75, -1.25, -0.75, 0.5, 1.5, 2.5, 3.5]
    assert lit_red(rgb, xs) == [False, False, True, False, True, True, True, False, True, False]
    assert (rgb[4, [int((x + 4.0) * 8) for x in xs], 1] > 0.1).all()  # green lights every one


def test_usd_shadow_link_excluding_a_blocker(tmp_path):
    """Read from USD: the red sun's shadowLink excludes ``/World/Blocker``: the floor under it is red (as without
    the blocker) and green's shadow stays."""
    body = ('def Xform "World"\n{\n' + quad_usda("Floor", 0.0, half=20.0, indent="    ")
            + quad_usda("Blocker", 0.0, z=1.0, half=2.0, indent="    ") + "}\n")
    under = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=1.0)
    path = z_up(tmp_path, body + sun_usda("Red", (1, 0, 0), shadow="rel collection:shadowLink:excludes = "
                                          "</World/Blocker>") + sun_usda("Green", (0, 1, 0)))
    rgb = render(load(path), "whitted", camera=under)
    np.testing.assert_allclose(rgb[..., 0], 0.5 * 2.0 / np.pi, rtol=1e-5)  # albedo 0.5, E = 2, straight down
    np.testing.assert_array_equal(rgb[..., 1], 0.0)


def test_bad_link_values_are_refused_naming_the_light():
    """A rule USD has not got, a relative path, a path with a trailing or doubled ``/``, and a light_link that is
    not a LinkCollection."""
    with pytest.raises(SceneError, match="expandEverything"):
        LinkCollection({"/World": "expandEverything"})
    with pytest.raises(SceneError, match="absolute"):
        LinkCollection({"World": "expandPrims"})
    for path in ("/World/Ground/", "/World//Ground"):  # matched no prim: the exclusion was dropped without a word
        with pytest.raises(SceneError, match=f"'{path}' has an empty path component"):
            LinkCollection.excluding(path)
    sun = wrt.DistantLight(direction=DOWN, color=np.ones(3), path="/Sun", light_link=["/World"])
    with pytest.raises(SceneError, match="/Sun.*light_link must be a wrt.LinkCollection"):
        render(floor_and_box([sun]), "whitted")


EXPRESSIONS = [  # (light, lightLink expression, shadowLink expression or None)
    ("A", "//Floor", None),
    ("B", "/World//* - /World/Box", "//{isa:Mesh}"),
    ("C", "%/World/A:lightLink + //Ball", "/World/I//"),  # a reference to A's collection
    ("D", "/World/I/geo/Right + /World/PI/Protos/B", None),  # an instance proxy's part; a point prototype
    ("E", "//{isa:Cube} - /World/Missing", "/World/Grp//*"),
]


def expression_stage(tmp_path) -> str:
    """A stage of a floor mesh, a cube, a sphere in a group, a native instance of two quads and a PointInstancer of
    two prototypes, with sphere lights linked by the membership expressions of :data:`EXPRESSIONS`."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "expr.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    body = ('def Xform "Proto"\n{\n    def Xform "geo"\n    {\n' + quad_usda("Left", -0.25, half=0.2, indent=" " * 8)
            + quad_usda("Right", 0.25, half=0.2, indent=" " * 8) + "    }\n}\n")
    stage.GetRootLayer().ImportFromString(f"#usda 1.0\n{body}")
    UsdGeom.Xform.Define(stage, "/World")
    floor = UsdGeom.Mesh.Define(stage, "/World/Floor")
    floor.CreatePointsAttr([(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdGeom.Cube.Define(stage, "/World/Box")
    UsdGeom.Sphere.Define(stage, "/World/Grp/Ball")
    instance = stage.DefinePrim("/World/I")
    instance.GetReferences().AddInternalReference("/Proto")
    instance.SetInstanceable(True)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    for name in ("A", "B"):
        UsdGeom.Sphere.Define(stage, f"/World/PI/Protos/{name}")
        instancer.CreatePrototypesRel().AddTarget(f"/World/PI/Protos/{name}")
    instancer.CreateProtoIndicesAttr([0, 1, 1])
    instancer.CreatePositionsAttr([(3, 0, 0), (4, 0, 0), (5, 0, 0)])
    for name, light_expression, shadow_expression in EXPRESSIONS:
        light = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, f"/World/{name}"))
        for collection, expression in ((light.GetLightLinkCollectionAPI(), light_expression),
                                       (light.GetShadowLinkCollectionAPI(), shadow_expression)):
            if expression is not None:
                collection.CreateIncludeRootAttr(False)
                collection.CreateMembershipExpressionAttr(Sdf.PathExpression(expression))
    stage.Save()
    return str(tmp_path / "expr.usda")


def test_expression_collections_are_usds_answer_for_every_drawn_path(tmp_path):
    """Light and shadow links in expression mode (``membershipExpression``): for every path wrt draws (instance
    proxies and point prototypes included) the loaded collection includes it exactly when USD's own query of the
    collection does, for path patterns, differences, predicates (``{isa:Mesh}``) and ``%`` references to another
    collection; nothing is warned about. Before, these lights were warned about and linked every prim."""
    path = expression_stage(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    assert not [w for w in caught if "link" in str(w.message)], [str(w.message) for w in caught]
    drawn = wrt.light_links.drawn_paths(scene)
    assert {"/World/Floor", "/World/I/geo/Left", "/World/I/geo/Right", "/World/PI/Protos/B"} <= set(drawn)
    stage = Usd.Stage.Open(path)
    lights = {light.path: light for light in scene.lights}
    for name, _, shadow_expression in EXPRESSIONS:
        api = UsdLux.LightAPI(stage.GetPrimAtPath(f"/World/{name}"))
        for ours, collection in ((lights[f"/World/{name}"].light_link, api.GetLightLinkCollectionAPI()),
                                 (lights[f"/World/{name}"].shadow_link, api.GetShadowLinkCollectionAPI())):
            query = collection.ComputeMembershipQuery()
            usd = [p for p in drawn if query.IsPathIncluded(Sdf.Path(p))]
            assert [p for p in drawn if ours is None or ours.includes(p)] == usd, (name, usd)
    assert [p for p in drawn if lights["/World/A"].light_link.includes(p)] == ["/World/Floor"]
    assert lights["/World/A"].shadow_link is None  # no expression: every prim


def test_expression_links_light_and_shadow_in_a_render(tmp_path):
    """A red sun whose lightLink is the expression ``/World/B`` lights B, not A (before: both); one whose shadowLink
    is ``//Floor`` is not shadowed by the blocker above the floor (before: shadowed, red 0)."""
    body = 'def Xform "World"\n{\n' + quad_usda("A", -1.0, indent="    ") + quad_usda("B", 1.0, indent="    ") + "}\n"
    expression = ('uniform bool collection:lightLink:includeRoot = 0\n    pathExpression '
                  'collection:lightLink:membershipExpression = "/World/B"')
    assert lit_red(red_and_green(tmp_path, body, expression, camera=ROW), [-1.0, 1.0]) == [False, True]
    body = ('def Xform "World"\n{\n' + quad_usda("Floor", 0.0, half=20.0, indent="    ")
            + quad_usda("Blocker", 0.0, z=1.0, half=2.0, indent="    ") + "}\n")
    shadow = ('uniform bool collection:shadowLink:includeRoot = 0\n    pathExpression '
              'collection:shadowLink:membershipExpression = "//Floor"')
    path = z_up(tmp_path, body + sun_usda("Red", (1, 0, 0), shadow=shadow) + sun_usda("Green", (0, 1, 0)))
    under = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=1.0)
    rgb = render(load(path), "whitted", camera=under)
    np.testing.assert_allclose(rgb[..., 0], 0.5 * 2.0 / np.pi, rtol=1e-5)  # albedo 0.5, E = 2, straight down
    np.testing.assert_array_equal(rgb[..., 1], 0.0)


def test_nested_native_instance_parts_are_named_by_their_proxy_paths(tmp_path):
    """A native instance inside another's prototype: its part is named ``/World/Outer/Inner/geo/Left`` (the path
    USD gives the instance proxy), so a collection of that path links it."""
    body = ('class Xform "Leaf"\n{\n    def Xform "geo"\n    {\n' + quad_usda("Left", 0.0, indent="        ")
            + '    }\n}\nclass Xform "Branch"\n{\n    def "Inner" (\n        instanceable = true\n'
            '        prepend references = </Leaf>\n    )\n    {\n    }\n}\n'
            'def Xform "World"\n{\n    def "Outer" (\n        instanceable = true\n        prepend references = '
            '</Branch>\n    )\n    {\n    }\n}\n')
    scene = load(z_up(tmp_path, body))
    (i,) = range(len(scene.instances))
    proxy = scene.instances.roots[scene.instances.root[i]]
    prototype = scene.prototypes[scene.instances.prototype[i]]
    assert wrt.light_links.part_path(prototype.meshes[0].path, prototype.path, proxy) == "/World/Outer/Inner/geo/Left"


def test_a_recorded_frame_follows_shadow_links():
    """A frame recorded as a CUDA graph (launch_frame: the shadow passes past unlinked blockers launched without
    reading back) and replayed gives the floor under a blocker left out of the red sun's shadowLink the red of an
    open sky, and keeps the green sun's shadow."""
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    red = wrt.DistantLight(direction=SLANT, color=np.array([2.0, 0, 0]),
                           shadow_link=LinkCollection.excluding("/Blocker"))
    green = wrt.DistantLight(direction=SLANT, color=np.array([0, 2.0, 0]))
    renderer = wrt.Renderer(shadow_scene([red, green]), camera=UNDER, width=8, height=8, device="cuda:0")
    renderer.launch_frame()  # allocates the buffers before the capture
    with wp.ScopedCapture(device="cuda:0") as capture:
        renderer.launch_frame()
    wp.capture_launch(capture.graph)
    rgb = renderer.frame_image().rgb
    open_sky = render(shadow_scene([red], blocker=False), "whitted", camera=UNDER, spp=1)
    np.testing.assert_array_equal(rgb[..., 1], 0.0)
    np.testing.assert_allclose(rgb[..., 0], open_sky[..., 0], rtol=1e-5)


def test_instances_whose_parts_fall_in_the_same_groups_share_one_run():
    """3000 instances (each its own proxy root, as native instances are) of a two-part prototype, the right part of
    every third one excluded from one of three suns: each instance's parts get the groups its paths call for, and the
    per-part groups take one run per distinct combination (3 runs of 2), not one per instance (6000 entries; building
    them was quadratic in the instances: 38 s for 20,000)."""
    proto = wrt.Prototype("/Proto", [quad((-0.25, 0, 0), (0.4, 0, 0), (0, 0.4, 0), name="/Proto/geo/L"),
                                     quad((0.25, 0, 0), (0.4, 0, 0), (0, 0.4, 0), name="/Proto/geo/R")])
    n, suns = 3000, 3
    to_world = np.tile(np.eye(4), (n, 1, 1))
    to_world[:, 0, 3] = np.arange(n)
    roots = [f"/World/I{k}" for k in range(n)]
    instances = wrt.Instances(np.zeros(n, np.int32), to_world, np.arange(n), np.full(n, -1), roots, roots=roots,
                              root=np.arange(n))
    lights = [wrt.DistantLight(direction=DOWN, color=np.ones(3), path=f"/Sun{j}", light_link=LinkCollection.excluding(
        *[f"/World/I{k}/geo/R" for k in range(j, n, suns)])) for j in range(suns)]
    scene = wrt.Scene(meshes=[], prototypes=[proto], instances=instances, lights=lights)
    links = wrt.light_links.link_groups(scene, lights)
    assert len(links.part_groups) == 2 * suns  # one run per sun that darkens the right part
    for k in range(n):
        own = links.instance_groups[k]
        assert own < 0
        left, right = links.part_groups[-1 - own:][:2]
        np.testing.assert_array_equal(links.masks[left] & wrt.light_links.LIT, [1, 1, 1])
        darkened_by = k % suns
        np.testing.assert_array_equal(links.masks[right] & wrt.light_links.LIT, [int(j != darkened_by) for j in
                                                                                 range(suns)])


def test_shadow_rays_past_more_unlinked_blockers_than_the_passes_warn():
    """A canopy of leaves left out of the sun's shadowLink: through ``MAX_SHADOW_HOLE_PASSES - 1`` of them the floor
    is lit as under an open sky, without a warning; through ``MAX_SHADOW_HOLE_PASSES`` it stays shadowed (the
    documented limit) and the render says so. Before, the shadow came without a word."""
    from wrt.shade import MAX_SHADOW_HOLE_PASSES

    def canopy(layers):
        leaves = [quad((0, 0, 1 + 0.05 * k), (4, 0, 0), (0, 4, 0), name=f"/Canopy/L{k}") for k in range(layers)]
        sun = wrt.DistantLight(direction=DOWN, color=np.full(3, 2.0), shadow_link=LinkCollection.excluding("/Canopy"))
        return wrt.Scene(meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/Floor"), *leaves], lights=[sun])

    under = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(render(canopy(MAX_SHADOW_HOLE_PASSES - 1), "whitted", camera=under), 0.5 * 2 / np.pi,
                                   rtol=1e-5)
    with pytest.warns(UserWarning, match=f"some shadow rays still met .* shadowLink, after {MAX_SHADOW_HOLE_PASSES} "
                      "passes; they count as blocked"):
        np.testing.assert_array_equal(render(canopy(MAX_SHADOW_HOLE_PASSES), "whitted", camera=under), 0.0)


def test_link_rules_cannot_change_under_a_kept_renderer():
    """A collection's rules are a read-only copy, so a change in place (which a kept Renderer, comparing the lights'
    objects, did not see: it went on lighting the floor red, 0.318, where a fresh render gave 0) is refused, and a
    new collection is seen; the dict given stays the caller's; collections pickle (scenes travel to workers)."""
    import pickle

    given = {"/": "expandPrims", "/Elsewhere": "exclude"}
    sun = wrt.DistantLight(direction=DOWN, color=np.array([2.0, 0, 0]), light_link=LinkCollection(given))
    given["/World/Ground"] = "exclude"
    scene = floor_and_box([sun])
    renderer = wrt.Renderer(scene, camera=TOP, width=8, height=8, device="cpu")
    assert renderer.render().rgb[FLOOR_PX][..., 0].min() > 0.1
    with pytest.raises(TypeError):
        sun.light_link.rules["/World/Ground"] = "exclude"
    sun.light_link = LinkCollection.excluding("/World/Ground")
    np.testing.assert_array_equal(renderer.render().rgb[FLOOR_PX][..., 0], 0.0)
    copy = pickle.loads(pickle.dumps(sun.light_link))
    assert dict(copy.rules) == dict(sun.light_link.rules) and not copy.includes("/World/Ground/Floor")


def random_collections(stage, rng, count: int, targets: list) -> list:
    """``count`` SphereLights under ``/L`` whose light and shadow links include and exclude random ``targets`` with
    random expansion rules and includeRoot (a quarter left at UsdLux's fallback: every prim)."""
    lights = []
    for k in range(count):
        api = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, f"/L/S{k}"))
        for collection in (api.GetLightLinkCollectionAPI(), api.GetShadowLinkCollectionAPI()):
            if rng.random() < 0.25:
                continue
            collection.CreateIncludeRootAttr(bool(rng.random() < 0.3))
            collection.CreateExpansionRuleAttr(str(rng.choice(["expandPrims", "explicitOnly",
                                                               "expandPrimsAndProperties"])))
            for rel in (collection.CreateIncludesRel(), collection.CreateExcludesRel()):
                rel.SetTargets([Sdf.Path(p) for p in rng.choice(targets, rng.integers(0, 4), replace=False)])
        lights.append(api)
    return lights


def test_collections_decide_every_path_at_once_as_usd_does_one_by_one():
    """``LinkCollection.includes_each`` (a collection's rules applied to all drawn paths at once) answers for each
    path as USD's ``IsPathIncluded`` does, for random includes, excludes, expansion rules and includeRoot over a
    tree with missing targets, and as ``includes`` does for ``/`` and the empty path."""
    from wrt.light_links import LinkCollection, PathIndex, read_collection

    rng = np.random.default_rng(5)
    stage = Usd.Stage.CreateInMemory()
    prims = ["/W", "/W/A", "/W/A/B", "/W/A/B/C", "/W/A/B/C/D", "/W/A/E", "/W/F", "/W/F/G", "/Other", "/Other/H"]
    for path in prims:
        UsdGeom.Xform.Define(stage, path)
    targets = prims + ["/Missing", "/W/A/Missing"]
    lights = random_collections(stage, rng, 60, targets)
    paths = prims + ["/Missing/x", "/W/A/B/C/D/deeper", "/W/A/B/C/D"]  # a repeat, and paths below no prim
    index, checked = PathIndex(paths + ["/", ""]), 0
    for api in lights:
        for collection in (api.GetLightLinkCollectionAPI(), api.GetShadowLinkCollectionAPI()):
            ours = read_collection(collection, "light linking", None)
            if ours is None:  # every prim: USD's query says so for each path
                assert all(collection.ComputeMembershipQuery().IsPathIncluded(Sdf.Path(p)) for p in paths)
                continue
            if not isinstance(ours, LinkCollection):  # no includes nor excludes: an (empty) expression, not rules
                continue
            checked += 1
            query = collection.ComputeMembershipQuery()
            found = ours.includes_each(index)
            assert found.tolist()[:len(paths)] == [query.IsPathIncluded(Sdf.Path(p)) for p in paths], dict(ours.rules)
            assert found.tolist()[len(paths):] == [ours.includes("/"), ours.includes("")] == [False, False]
    assert checked > 50


def test_link_groups_give_every_drawn_geometry_usds_membership(tmp_path):
    """Each drawn geometry's link group (meshes, gprims, native instance parts at their proxy paths, point
    prototypes) holds, for each light, the LIT and CASTS_SHADOW bits of USD's own query of its collections at the
    path it is drawn at: expression collections and random rule-based ones."""
    from wrt.light_links import CASTS_SHADOW, LIT, drawn_ids, link_groups

    path = expression_stage(tmp_path)
    stage = Usd.Stage.Open(path)
    UsdGeom.Mesh.Define(stage, "/World/Grp/Sheet")
    targets = ["/World", "/World/Floor", "/World/Grp", "/World/I", "/World/I/geo", "/World/I/geo/Left",
               "/World/PI/Protos/B", "/World/PI", "/World/Box", "/World/Missing"]
    random_collections(stage, np.random.default_rng(9), 40, targets)
    stage.Save()
    scene = load(path)
    links = link_groups(scene, scene.lights)
    paths, world, starts, parts = drawn_ids(scene)
    triangles = np.cumsum([0] + [len(m.indices) for m in scene.meshes])[:-1]
    total = sum(len(m.indices) for m in scene.meshes) + sum(len(m.indices) for p in scene.prototypes
                                                            for m in p.meshes)
    drawn = list(zip(world, [links.geometry_groups[t] for t in triangles]
                     + [links.geometry_groups[total + j] for j in range(len(scene.shapes))]))
    for i, start in enumerate(starts):
        own = links.instance_groups[i]
        proto = scene.prototypes[scene.instances.prototype[i]]
        for k in range(len(proto.meshes) + len(proto.shapes)):
            drawn.append((parts[start + k], own if own >= 0 else links.part_groups[-1 - own + k]))
    queries = []
    for light in scene.lights:
        api = UsdLux.LightAPI(stage.GetPrimAtPath(light.path))
        queries.append((api.GetLightLinkCollectionAPI().ComputeMembershipQuery(),
                        api.GetShadowLinkCollectionAPI().ComputeMembershipQuery()))
    assert len(drawn) > 8 and len(queries) == 45
    for at, group in drawn:
        sdf = Sdf.Path(paths[at])
        expected = [(LIT if lit.IsPathIncluded(sdf) else 0) | (CASTS_SHADOW if shadow.IsPathIncluded(sdf) else 0)
                    for lit, shadow in queries]
        assert links.masks[group].tolist() == expected, paths[at]


def test_a_mesh_named_by_a_relative_path_is_lit_as_the_root_rule_says():
    """A Scene built in Python may name its meshes by relative paths; the walk up from one never reached '/', so a
    linked light hung the render (and ``includes``). Only the root's rule can take such a path in (every rule is an
    absolute path)."""
    assert LinkCollection.excluding("/World").includes("World/Floor")
    assert not LinkCollection.only("/World").includes("World/Floor")
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="World/Floor")
    linked = [LinkCollection.only("/World"), LinkCollection.excluding("/World")]
    lit = []
    for link in linked:
        sun = wrt.DistantLight(direction=DOWN, color=np.array([2.0, 0, 0]), light_link=link)
        lit.append(render(wrt.Scene(meshes=[floor], lights=[sun]), "whitted", camera=TOP)[FLOOR_PX][..., 0].max())
    assert lit[0] == 0.0 and lit[1] > 0.1


def test_an_expansion_rule_usd_does_not_define_is_read_as_usds_query_reads_it(tmp_path):
    """A ``bogus`` expansionRule (UsdCollectionAPI allows the token, USD's query takes it as expandPrims) stopped the
    whole load with LinkCollection's SceneError, which named no file; it is warned about and membership is USD's."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "rule.usda"))
    for path in ("/W/A/Child", "/W/B"):
        UsdGeom.Mesh.Define(stage, path)  # (no faces: the membership is what is checked)
    light = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, "/W/L"))
    collection = light.GetLightLinkCollectionAPI()
    collection.CreateIncludeRootAttr(False)
    collection.CreateExpansionRuleAttr("bogus")
    collection.CreateIncludesRel().AddTarget("/W/A")
    stage.Save()
    with pytest.warns(UserWarning, match=r"rule\.usda: light linking collections with an expansionRule USD does not "
                                         r"define .*'bogus'.*: /W/L"):
        scene = wrt.load_usd(tmp_path / "rule.usda")
    query = collection.ComputeMembershipQuery()
    for path in ("/W/A", "/W/A/Child", "/W/B", "/W"):
        assert scene.lights[0].light_link.includes(path) == query.IsPathIncluded(Sdf.Path(path)), path


@pytest.mark.parametrize("authored", ["nothing", "include_root_off", "expansion_rule", "excludes", "shadow_only"])
def test_a_lights_collections_hold_the_prims_usds_query_includes_whatever_is_authored(tmp_path, authored):
    """A light's light and shadow link collections hold, of the stage's prims, those USD's own membership query
    includes, whatever part of the collection is authored (nothing at all: every prim, read without asking the
    query; ``includeRoot`` off alone: none; an expansion rule alone; an exclude; the shadow collection alone)."""
    from pxr import Usd, UsdGeom, UsdLux

    stage = Usd.Stage.CreateNew(str(tmp_path / "links.usda"))
    for k, path in enumerate(("/Quad", "/Other", "/Other/Child")):  # drawn: expressions resolve against them
        mesh = UsdGeom.Mesh.Define(stage, path)
        mesh.CreatePointsAttr([(k, 0, 0), (k + 1, 0, 0), (k, 1, 0)])
        mesh.CreateFaceVertexCountsAttr([3])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    light = UsdLux.LightAPI(UsdLux.SphereLight.Define(stage, "/Lamp"))
    link, shadow = light.GetLightLinkCollectionAPI(), light.GetShadowLinkCollectionAPI()
    if authored == "include_root_off":
        link.CreateIncludeRootAttr(False)
    elif authored == "expansion_rule":
        link.CreateExpansionRuleAttr("explicitOnly")
    elif authored == "excludes":
        link.CreateExcludesRel().AddTarget("/Other")
    elif authored == "shadow_only":
        shadow.CreateIncludeRootAttr(False)
        shadow.CreateIncludesRel().AddTarget("/Quad")
    stage.Save()
    lamp = {lt.path: lt for lt in wrt.load_usd(str(tmp_path / "links.usda")).lights}["/Lamp"]
    for collection, read in ((link, lamp.light_link), (shadow, lamp.shadow_link)):
        query = collection.ComputeMembershipQuery()
        for path in ("/Quad", "/Other", "/Other/Child"):
            expected = query.IsPathIncluded(path)
            assert (read is None or read.includes(path)) == expected, (collection.GetName(), path, expected)
