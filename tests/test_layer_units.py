"""Layers a stage composes whose linear units differ from the stage's: USD converts none of them (UsdGeom, "Encoding
Stage Linear Units": it is the assembler's job), so wrt draws them as authored and names the layers whose units
differ. A layer that authors no ``metersPerUnit`` is in USD's fallback, centimetres (``GetStageMetersPerUnit`` of it
opened alone), unless it is a sublayer, which shares the units of the layer stack it belongs to."""

from __future__ import annotations

import warnings

import pytest

pytest.importorskip("pxr")
from pxr import Usd, UsdGeom, UsdShade, UsdSkel  # noqa: E402

from wrt.usd import load_usd  # noqa: E402

MESH = """def Mesh "{name}"
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}}
"""


def write(tmp_path, name: str, body: str, meta: str = "", axis: str | None = "Y") -> str:
    """A layer of ``body`` and metadata ``meta``, of ``upAxis`` ``axis`` (None: none authored)."""
    path = tmp_path / name
    up = "" if axis is None else f'upAxis = "{axis}"'
    path.write_text(f'#usda 1.0\n(\n    {up}\n    {meta}\n)\n{body}\n')
    return str(path)


def unit_warnings(path, key: str = "metersPerUnit") -> list[str]:
    """The messages of the layer warnings about ``key`` (``metersPerUnit`` or ``upAxis``) that loading gives."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_usd(path)
    return [str(w.message) for w in caught if f": {key} = " in str(w.message)]


def units_alone(path) -> float:
    """The oracle: the metersPerUnit USD gives the layer opened as a stage of its own."""
    return UsdGeom.GetStageMetersPerUnit(Usd.Stage.Open(path))


def axis_alone(path) -> str:
    """The oracle: the upAxis USD gives the layer opened as a stage of its own."""
    return UsdGeom.GetStageUpAxis(Usd.Stage.Open(path))


def test_a_referenced_layer_without_meters_per_unit_in_a_metre_stage_is_named(tmp_path):
    """A centimetre asset (no metersPerUnit: USD's fallback 0.01) referenced into a metre stage is drawn 100 times too
    big, as USD composes it; wrt named only the layers that author another value, so this was silent."""
    asset = write(tmp_path, "chair.usda", MESH.format(name="Chair"))
    stage = write(tmp_path, "scene.usda", 'def "Chair" (\n    prepend references = @./chair.usda@</Chair>\n)\n{\n}\n',
                  "metersPerUnit = 1")
    assert units_alone(asset) == 0.01 and not UsdGeom.LinearUnitsAre(units_alone(stage), units_alone(asset))
    (message,) = unit_warnings(stage)
    assert message.startswith("scene.usda: metersPerUnit = 1, but 1 layer(s) it composes author another "
                              "(chair.usda: none authored, so USD's fallback 0.01)"), message


def test_layers_that_share_the_stage_units_are_not_named(tmp_path):
    """No warning where the units agree: a sublayer of the root (the stage's own layer stack) and a referenced asset's
    sublayer without metersPerUnit take the units of their layer stack's root; a referenced layer without one in a
    stage without one is in centimetres as the stage is."""
    write(tmp_path, "shot_anim.usda", MESH.format(name="Anim"))
    write(tmp_path, "geo.usda", MESH.format(name="Lamp"))
    asset = write(tmp_path, "lamp.usda", "", "metersPerUnit = 1\n    subLayers = [@./geo.usda@]")
    stage = write(tmp_path, "scene.usda", 'def "Lamp" (\n    prepend references = @./lamp.usda@</Lamp>\n)\n{\n}\n',
                  "metersPerUnit = 1\n    subLayers = [@./shot_anim.usda@]")
    assert UsdGeom.LinearUnitsAre(units_alone(stage), units_alone(asset))
    assert unit_warnings(stage) == []
    write(tmp_path, "chair.usda", MESH.format(name="Chair"))
    plain = write(tmp_path, "plain.usda", 'def "Chair" (\n    prepend references = @./chair.usda@</Chair>\n)\n{\n}\n')
    assert unit_warnings(plain) == []


def test_value_clips_without_meters_per_unit_are_not_named(tmp_path):
    """Value clips (and their manifest) hold time samples of the stage's own prims, in its units; USD lists them
    among the layers it uses (``GetUsedLayers``), but they are no assets of their own units."""
    samples = "{ 1: [(0, 0, 0), (1, 0, 0), (0, 1, 0)] }"
    write(tmp_path, "clip1.usda", f'over "M"\n{{\n    point3f[] points.timeSamples = {samples}\n}}')
    write(tmp_path, "manifest.usda", 'over "M"\n{\n    point3f[] points\n}')
    clips = ('clips = {\n        dictionary default = {\n            asset[] assetPaths = [@./clip1.usda@]\n'
             '            asset manifestAssetPath = @./manifest.usda@\n            string primPath = "/M"\n'
             '            double2[] active = [(1, 0)]\n        }\n    }')
    stage = write(tmp_path, "scene.usda", f'def Mesh "M" (\n    {clips}\n)\n{{\n    int[] faceVertexCounts = [3]\n'
                  '    int[] faceVertexIndices = [0, 1, 2]\n}\n', "metersPerUnit = 1\n    startTimeCode = 1\n"
                  "    endTimeCode = 1")
    opened = Usd.Stage.Open(stage)
    assert opened.GetAttributeAtPath("/M.points").Get(1) is not None
    assert {"clip1.usda", "manifest.usda"} <= {layer.identifier.rsplit("/", 1)[-1] for layer in opened.GetUsedLayers()}
    assert unit_warnings(stage) == []


@pytest.mark.parametrize("arc", ["references", "payload"])
def test_a_referenced_layer_without_up_axis_in_a_z_up_stage_is_named(tmp_path, arc):
    """A Y-up asset (no upAxis: USD's fallback Y) referenced or loaded as a payload into a Z-up stage is drawn on its
    side, as USD composes it (it turns nothing); wrt named only the layers that author another axis, so this was
    silent. Named as the metersPerUnit warning names a layer without units."""
    asset = write(tmp_path, "chair.usda", MESH.format(name="Chair"), axis=None)
    stage = write(tmp_path, "scene.usda", f'def "Chair" (\n    prepend {arc} = @./chair.usda@</Chair>\n)\n{{\n}}\n',
                  axis="Z")
    assert axis_alone(asset) == UsdGeom.GetFallbackUpAxis() == "Y" and axis_alone(stage) == "Z"
    (message,) = unit_warnings(stage, "upAxis")
    assert message.startswith("scene.usda: upAxis = Z, but 1 layer(s) it composes author another "
                              "(chair.usda: none authored, so USD's fallback Y)"), message


def test_layers_that_share_the_stage_axis_are_not_named(tmp_path):
    """No upAxis warning where the axes agree: sublayers without one (of the root, and of a referenced Z-up asset)
    take their layer stack's axis, value clips without one hold the stage's prims, and a referenced layer without one
    in a stage without one is Y-up as the stage is."""
    write(tmp_path, "shot_anim.usda", MESH.format(name="Anim"), axis=None)
    write(tmp_path, "geo.usda", MESH.format(name="Lamp"), axis=None)
    asset = write(tmp_path, "lamp.usda", "", "subLayers = [@./geo.usda@]", axis="Z")
    samples = "{ 1: [(0, 0, 0), (1, 0, 0), (0, 1, 0)] }"
    write(tmp_path, "clip1.usda", f'over "M"\n{{\n    point3f[] points.timeSamples = {samples}\n}}', axis=None)
    clips = ('clips = {\n        dictionary default = {\n            asset[] assetPaths = [@./clip1.usda@]\n'
             '            string primPath = "/M"\n            double2[] active = [(1, 0)]\n        }\n    }')
    body = (f'def Mesh "M" (\n    {clips}\n)\n{{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
            '[0, 1, 2]\n}\ndef "Lamp" (\n    prepend references = @./lamp.usda@</Lamp>\n)\n{\n}\n')
    stage = write(tmp_path, "scene.usda", body, "subLayers = [@./shot_anim.usda@]\n    startTimeCode = 1\n"
                  "    endTimeCode = 1", axis="Z")
    assert axis_alone(stage) == axis_alone(asset) == "Z"
    assert unit_warnings(stage, "upAxis") == []
    write(tmp_path, "chair.usda", MESH.format(name="Chair"), axis=None)
    plain = write(tmp_path, "plain.usda", 'def "Chair" (\n    prepend references = @./chair.usda@</Chair>\n)\n{\n}\n',
                  axis=None)
    assert unit_warnings(plain, "upAxis") == []


LOOKS = """def Scope "Looks"
{
    def Material "Red"
    {
        token outputs:surface.connect = </Looks/Red/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface
        }
    }
}
"""


def referencing(tmp_path, name: str, arcs: str, meta: str = "metersPerUnit = 1") -> str:
    """A stage ``name`` whose prim ``/Chair`` references ``arcs`` (a reference list's entries)."""
    return write(tmp_path, name, f'def "Chair" (\n    prepend references = [{arcs}]\n)\n{{\n}}\n', meta)


def test_layers_that_hold_nothing_sized_are_not_named(tmp_path):
    """A material library (materials and shaders only) and a looks layer (material bindings and colours over an
    asset's prims) hold no length: their units change nothing drawn, so a centimetre one (none authored) in a metre
    stage is not named; both were."""
    lib = write(tmp_path, "lib.usda", LOOKS)
    looks = write(tmp_path, "looks.usda", 'over "Chair"\n{\n    over "Seat" (\n        prepend apiSchemas = '
                  '["MaterialBindingAPI"]\n    )\n    {\n        rel material:binding = </Chair/Red>\n'
                  '        color3f[] primvars:displayColor = [(1, 0, 0)]\n    }\n}\n')
    geo = write(tmp_path, "geo.usda", 'def Xform "Chair"\n{\n' + MESH.format(name="Seat") + "}\n",
                "metersPerUnit = 1")
    stage = referencing(tmp_path, "scene.usda", "@./geo.usda@</Chair>, @./looks.usda@</Chair>, @./lib.usda@</Looks>")
    for layer in (lib, looks):  # the oracle: nothing of either, opened alone, is placed in space or has a size
        assert units_alone(layer) == 0.01
        alone = Usd.Stage.Open(layer)
        assert not any(prim.IsA(UsdGeom.Xformable) for prim in alone.TraverseAll())
    opened = Usd.Stage.Open(stage)
    assert UsdGeom.LinearUnitsAre(units_alone(geo), units_alone(stage))  # the geometry is in the stage's units
    assert UsdGeom.Mesh(opened.GetPrimAtPath("/Chair/Seat")).GetPointsAttr().Get()[1] == (1, 0, 0)
    assert opened.GetPrimAtPath("/Chair/Red").IsA(UsdShade.Material)
    assert unit_warnings(stage) == []


@pytest.mark.parametrize("sized", ["light", "sublayer"])
def test_layers_whose_prims_are_sized_are_still_named(tmp_path, sized):
    """A referenced rect light is sized in its layer's units (its width and height; USD converts none), and an
    asset's root layer whose geometry is in its sublayer gives that geometry its units: each is named, without
    metersPerUnit, in a metre stage."""
    if sized == "light":
        write(tmp_path, "asset.usda", 'def RectLight "Chair"\n{\n    float inputs:width = 30\n}\n' + LOOKS)
    else:
        write(tmp_path, "geo.usda", 'def Xform "Chair"\n{\n' + MESH.format(name="Seat") + "}\n")
        write(tmp_path, "asset.usda", "", "subLayers = [@./geo.usda@]")
    stage = referencing(tmp_path, "scene.usda", "@./asset.usda@</Chair>")
    assert units_alone(str(tmp_path / "asset.usda")) == 0.01
    (message,) = unit_warnings(stage)
    assert "(asset.usda: none authored, so USD's fallback 0.01)" in message, message


def test_a_layer_of_blend_shapes_is_sized(tmp_path):
    """A layer holding only blend shapes (a BlendShape's ``offsets`` move points by lengths in its units, and
    ``normalOffsets`` turn with its axis; USD converts neither) is named, without metersPerUnit or upAxis, in a
    metre Z-up stage. BlendShape is not an Xformable, so the layer counted as holding nothing sized and was not."""
    shapes = write(tmp_path, "shapes.usda", 'def "Chair"\n{\n    def BlendShape "Smile"\n    {\n'
                   '        uniform vector3f[] offsets = [(0, 2, 0)]\n'
                   '        uniform vector3f[] normalOffsets = [(0, 0, 1)]\n'
                   '        uniform int[] pointIndices = [1]\n    }\n}\n', axis=None)
    stage = write(tmp_path, "scene.usda", 'def "Chair" (\n    prepend references = @./shapes.usda@</Chair>\n)\n'
                  '{\n}\n', "metersPerUnit = 1", axis="Z")
    # The oracle: USD's schema says the offsets are vectors (a length and a direction), in the layer's units.
    opened = Usd.Stage.Open(stage)
    shape = UsdSkel.BlendShape(opened.GetPrimAtPath("/Chair/Smile"))
    assert shape and shape.GetOffsetsAttr().GetTypeName().role == "Vector"
    assert shape.GetNormalOffsetsAttr().GetTypeName().role == "Vector"
    assert not shape.GetPrim().IsA(UsdGeom.Xformable)
    assert units_alone(shapes) == 0.01 and axis_alone(shapes) == "Y"
    (message,) = unit_warnings(stage)
    assert "(shapes.usda: none authored, so USD's fallback 0.01)" in message, message
    (message,) = unit_warnings(stage, "upAxis")
    assert "(shapes.usda: none authored, so USD's fallback Y)" in message, message


def test_a_layer_of_normals_is_named_for_its_axis_not_its_units(tmp_path):
    """A layer that authors only ``primvars:normals`` over an asset's mesh holds directions: they turn with its axis
    (a Y-up layer's normals are on their side in a Z-up stage) but have no length. It is named in the upAxis warning
    (it was not: primvars counted as holding nothing placed in space) and not in the metersPerUnit one."""
    geo = write(tmp_path, "geo.usda", 'def Xform "Chair"\n{\n' + MESH.format(name="Seat") + "}\n",
                "metersPerUnit = 1", axis="Z")
    normals = write(tmp_path, "normals.usda", 'over "Chair"\n{\n    over "Seat"\n    {\n'
                    '        normal3f[] primvars:normals = [(0, 1, 0)] (\n'
                    '            interpolation = "constant"\n        )\n    }\n}\n', axis=None)
    stage = write(tmp_path, "scene.usda", 'def "Chair" (\n    prepend references = [@./normals.usda@</Chair>, '
                  '@./geo.usda@</Chair>]\n)\n{\n}\n', "metersPerUnit = 1", axis="Z")
    # The oracle: USD composes the primvar as the mesh's normals (role Normal: a direction), the layer alone Y-up.
    opened = Usd.Stage.Open(stage)
    mesh = opened.GetPrimAtPath("/Chair/Seat")
    primvar = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("normals")
    assert primvar.GetTypeName().role == "Normal" and tuple(primvar.Get()[0]) == (0, 1, 0)
    assert axis_alone(normals) == "Y" and axis_alone(geo) == "Z" and units_alone(normals) == 0.01
    (message,) = unit_warnings(stage, "upAxis")
    assert "(normals.usda: none authored, so USD's fallback Y)" in message and "geo.usda" not in message, message
    assert unit_warnings(stage) == []


def test_a_layer_of_mesh_normals_is_named_for_its_axis_not_its_units(tmp_path):
    """The same for the mesh's own ``normals`` attribute (UsdGeom.PointBased, no primvar): a direction without
    length, so it is named for its upAxis alone. It was named for its metersPerUnit too, as any attribute outside
    ``primvars:`` counted as a length."""
    geo = write(tmp_path, "geo.usda", 'def Xform "Chair"\n{\n' + MESH.format(name="Seat") + "}\n",
                "metersPerUnit = 1", axis="Z")
    normals = write(tmp_path, "normals.usda", 'over "Chair"\n{\n    over "Seat"\n    {\n'
                    '        normal3f[] normals = [(0, 1, 0)]\n    }\n}\n', axis=None)
    stage = write(tmp_path, "scene.usda", 'def "Chair" (\n    prepend references = [@./normals.usda@</Chair>, '
                  '@./geo.usda@</Chair>]\n)\n{\n}\n', "metersPerUnit = 1", axis="Z")
    # The oracle: USD composes the attribute as the mesh's normals (role Normal: a direction), the layer alone Y-up
    # and in centimetres.
    opened = Usd.Stage.Open(stage)
    attr = UsdGeom.Mesh(opened.GetPrimAtPath("/Chair/Seat")).GetNormalsAttr()
    assert attr.GetTypeName().role == "Normal" and tuple(attr.Get()[0]) == (0, 1, 0)
    assert axis_alone(normals) == "Y" and units_alone(normals) == 0.01 and units_alone(geo) == units_alone(stage) == 1
    (message,) = unit_warnings(stage, "upAxis")
    assert "(normals.usda: none authored, so USD's fallback Y)" in message, message
    assert unit_warnings(stage) == []
