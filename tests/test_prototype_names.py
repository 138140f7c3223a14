"""Names of what native prototypes hold: USD numbers a stage's prototypes (``/__Prototype_1``, ...) anew at each
opening, in no fixed order, so wrt names a prototype, the meshes, shapes and materials inside it by the instance-proxy
paths of its first instance (the least of their paths, themselves named so when nested), the same at every load."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("pxr")
from pxr import Usd, UsdShade  # noqa: E402

import wrt  # noqa: E402
from wrt.usd_frames import StageFrames  # noqa: E402

TRIANGLE = """
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), ({s}, 0, 0), (0, {s}, 0)]"""


def _instance(name: str, of: str, x: float = 0.0, y: float = 0.0, indent: str = "    ") -> str:
    return (f'{indent}def Xform "{name}" (\n{indent}    instanceable = true\n{indent}    inherits = </{of}>\n'
            f'{indent})\n{indent}{{\n{indent}    double3 xformOp:translate = ({x}, {y}, 0)\n'
            f'{indent}    uniform token[] xformOpOrder = ["xformOp:translate"]\n{indent}}}\n')


# Three prototypes: Rock, Bush (which holds two Leaf instances: nested instancing) and Leaf, whose blade is bound to
# a material inside the prototype. The world names them out of path order (Zrock before Bush...). The trunk lies 1
# below the blades it holds: in their plane, an exact tie goes to the smaller instance, the bush's own trunk.
STAGE = f"""#usda 1.0
class Xform "Leaf"
{{
    def Mesh "Blade" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {{{TRIANGLE.format(s=1)}
        rel material:binding = </Leaf/Looks/Green>
    }}
    def Scope "Looks"
    {{
        def Material "Green"
        {{
            token outputs:surface.connect = </Leaf/Looks/Green/S.outputs:surface>
            def Shader "S"
            {{
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0, 1, 0)
                token outputs:surface
            }}
        }}
    }}
}}
class Xform "Rock"
{{
    def Mesh "Stone"
    {{{TRIANGLE.format(s=2)}
    }}
    def Sphere "Pebble"
    {{
        double radius = 0.25
    }}
}}
class Xform "Bush"
{{
    def Mesh "Trunk"
    {{{TRIANGLE.format(s=3)}
        double3 xformOp:translate = (0, 0, -1)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
{_instance("L1", "Leaf", y=1)}{_instance("L2", "Leaf", y=2)}}}
def Xform "World"
{{
{_instance("Zrock", "Rock", x=-10)}{_instance("BushB", "Bush", x=10)}{_instance("Leaf", "Leaf", x=20)}\
{_instance("Rock", "Rock", x=30)}{_instance("BushA", "Bush", x=40)}}}
"""


@pytest.fixture
def stage_path(tmp_path):
    path = tmp_path / "prototypes.usda"
    path.write_text(STAGE)
    return str(path)


def _load(path, frames=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return frames.load() if frames else wrt.load_usd(path)


def _names(scene) -> tuple:
    """Every name a scene gives what prototypes hold, in the scene's order."""
    return (tuple((p.path, tuple(m.path for m in p.meshes), tuple(s.path for s in p.shapes))
                  for p in scene.prototypes),
            tuple(m.path for m in scene.materials),
            tuple(scene.instances.path(k) for k in range(len(scene.instances))),
            tuple(scene.prim_paths()))


def _strings(value, seen=None):
    """Every str held in ``value``'s attributes, lists, tuples and dicts (numpy arrays of objects too)."""
    seen = set() if seen is None else seen
    if isinstance(value, str):
        yield value
        return
    if id(value) in seen or value is None or isinstance(value, (int, float, bool, bytes)):
        return
    seen.add(id(value))
    if isinstance(value, np.ndarray):
        items = value.ravel().tolist() if value.dtype == object else ()
    elif isinstance(value, dict):
        items = [*value.keys(), *value.values()]
    elif isinstance(value, (list, tuple, set, frozenset)):
        items = value
    elif hasattr(value, "__dict__"):
        items = vars(value).values()
    else:
        items = ()
    for item in items:
        yield from _strings(item, seen)


def _first_instances(stage: Usd.Stage) -> dict:
    """The oracle: per prototype, the least path of the instance prims found walking the stage through instance
    proxies (nested instances at their instance-proxy paths)."""
    first = {}
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)):
        if prim.IsInstance():
            key = prim.GetPrototype().GetPath()
            first[key] = min(first.get(key, str(prim.GetPath())), str(prim.GetPath()))
    return first


def test_prototype_names_are_the_same_at_every_load_and_name_prims_of_the_stage(stage_path):
    """Prototypes, their meshes, shapes and materials are named by the instance-proxy paths of the prototype's first
    instance, as USD's own walk through instance proxies finds them: the same at every load, by ``load_usd`` or a
    kept stage. They were named ``/__Prototype_N/...``, a path no file holds whose N USD changes per opening."""
    scenes = [_load(stage_path) for _ in range(4)]
    frames = StageFrames(stage_path)
    scenes += [_load(stage_path, frames), _load(stage_path, frames)]
    names = {_names(scene) for scene in scenes}
    assert len(names) == 1
    for scene in scenes:
        assert not [s for s in _strings(scene) if "__Prototype" in s]

    scene = scenes[0]
    stage = Usd.Stage.Open(stage_path)
    first = _first_instances(stage)
    # Each prototype is named by its first instance: a prim of the stage whose prototype it is.
    assert sorted(p.path for p in scene.prototypes) == sorted(first.values())
    assert [p.path for p in scene.prototypes] == ["/World/Rock", "/World/BushA", "/World/BushA/L1"]
    for prototype in scene.prototypes:
        instance = stage.GetPrimAtPath(prototype.path)
        assert instance.IsInstance() and first[instance.GetPrototype().GetPath()] == prototype.path
        for part in [*prototype.meshes, *prototype.shapes]:
            proxy = stage.GetPrimAtPath(part.path)
            assert proxy.IsInstanceProxy() and proxy.GetPath().HasPrefix(instance.GetPath())
    # The material inside the Leaf prototype is the one USD binds to every blade (the same prototype prim).
    (material,) = scene.materials
    blade = stage.GetPrimAtPath("/World/Leaf/Blade")
    bound = UsdShade.MaterialBindingAPI(blade).ComputeBoundMaterial()[0].GetPrim()
    named = stage.GetPrimAtPath(material.path)
    assert named.IsInstanceProxy() and named.GetPrimInPrototype() == bound.GetPrimInPrototype()


def test_hits_keep_their_instance_proxy_paths_and_material(stage_path):
    """A ray down onto each blade is named by that blade's instance-proxy path (hit_paths), and its material is the
    blade's bound one, whatever the prototypes are called."""
    scene = _load(stage_path)
    stage = Usd.Stage.Open(stage_path)
    blades = ["/World/BushB/L1/Blade", "/World/BushB/L2/Blade", "/World/Leaf/Blade", "/World/BushA/L1/Blade",
              "/World/BushA/L2/Blade"]
    from pxr import UsdGeom

    cache = UsdGeom.XformCache()
    origins = []
    for path in blades:
        centre = cache.GetLocalToWorldTransform(stage.GetPrimAtPath(path)).Transform((0.25, 0.25, 0.0))
        origins.append((centre[0], centre[1], 5.0))
    directions = np.tile([0.0, 0.0, -1.0], (len(blades), 1))
    hits = wrt.trace(scene, np.array(origins, np.float32), directions.astype(np.float32))
    prims, _ = scene.hit_paths(hits)
    assert list(prims) == blades
    (material,) = scene.materials
    bound = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(blades[0])).ComputeBoundMaterial()[0].GetPrim()
    assert stage.GetPrimAtPath(material.path).GetPrimInPrototype() == bound.GetPrimInPrototype()


# Leaf is instanced only inside two other prototypes: its first instance is a nested one either way.
NESTED_ONLY = f"""#usda 1.0
class Xform "Leaf"
{{
    def Mesh "Blade"
    {{{TRIANGLE.format(s=1)}
        uniform token orientation = "leftHandd"
    }}
}}
class Xform "BushX"
{{
{_instance("L", "Leaf")}}}
class Xform "BushY"
{{
    def Mesh "Trunk"
    {{{TRIANGLE.format(s=3)}
    }}
{_instance("L", "Leaf")}}}
def Xform "World"
{{
{_instance("B", "BushX", x=10)}{_instance("A", "BushY", x=20)}}}
"""


def test_a_prototype_instanced_only_inside_others_is_named_by_their_names_not_their_numbers(tmp_path):
    """The first instance of a prototype whose instances all lie in other prototypes is chosen by the names those
    have (``/World/A/L`` before ``/World/B/L``), in the scene and in warnings: it was chosen by USD's numbering
    (``/__Prototype_1/L`` before ``/__Prototype_2/L``), so a warning named ``/World/B/L/Blade`` at some loads."""
    path = tmp_path / "nested.usda"
    path.write_text(NESTED_ONLY)
    for _ in range(6):
        with pytest.warns(UserWarning, match=r"orientation") as caught:
            scene = wrt.load_usd(path)
        (warning,) = [str(w.message) for w in caught if "orientation" in str(w.message)]
        assert warning.endswith(": /World/A/L/Blade (and in 1 other instance)")
        leaf = next(p for p in scene.prototypes if p.meshes[0].path.endswith("/Blade"))
        assert leaf.path == "/World/A/L" and leaf.meshes[0].path == "/World/A/L/Blade"


def test_warnings_of_a_material_inside_a_prototype_name_it_under_the_first_instance(tmp_path):
    """A material inside a native prototype (the Leaf's Green, in nested instances too) whose shader has a dangling
    connection and a colour space wrt does not know: the warnings named the material, the shader and the connection
    target by prototype path (``material /__Prototype_2/Looks/Green: /__Prototype_2/Looks/Green/S's emissiveColor
    ...``, ``diffuseColor -> /__Prototype_2/Looks/Green/Gone.outputs:rgb``), a name USD makes up per opening that no
    file holds, beside the shader itself named ``/World/BushA/L1/Looks/Green/S``; they name all three under the
    prototype's first instance. Oracle: USD's walk through instance proxies (``_first_instances``)."""
    old = "color3f inputs:diffuseColor = (0, 1, 0)"
    assert STAGE.count(old) == 1
    path = tmp_path / "looks.usda"
    path.write_text(STAGE.replace(old, old + "\n                color3f inputs:diffuseColor.connect = "
                                  "</Leaf/Looks/Green/Gone.outputs:rgb>\n                color3f "
                                  'inputs:emissiveColor = (0.1, 0.2, 0.3) (colorSpace = "weird_space")'))
    stage = Usd.Stage.Open(str(path))
    leaf = stage.GetPrimAtPath("/World/Leaf").GetPrototype().GetPath()
    green = _first_instances(stage)[leaf] + "/Looks/Green"
    assert green == "/World/BushA/L1/Looks/Green"
    for _ in range(3):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            wrt.load_usd(path)
        said = [str(w.message) for w in caught]
        assert any(f"(diffuseColor -> {green}/Gone.outputs:rgb: 1): {green}/S" in s for s in said), said
        assert any(f"material {green}: {green}/S's emissiveColor colour space 'weird_space'" in s for s in said), said
        assert not [s for s in said if "__Prototype" in s], said
