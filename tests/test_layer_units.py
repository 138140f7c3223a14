"""Layers a stage composes whose linear units differ from the stage's: USD converts none of them (UsdGeom, "Encoding
Stage Linear Units": it is the assembler's job), so wrt draws them as authored and names the layers whose units
differ. A layer that authors no ``metersPerUnit`` is in USD's fallback, centimetres (``GetStageMetersPerUnit`` of it
opened alone), unless it is a sublayer, which shares the units of the layer stack it belongs to."""

from __future__ import annotations

import warnings

import pytest

pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

from wrt.usd import load_usd  # noqa: E402

MESH = """def Mesh "{name}"
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}}
"""


def write(tmp_path, name: str, body: str, meta: str = "") -> str:
    path = tmp_path / name
    path.write_text(f'#usda 1.0\n(\n    upAxis = "Y"\n    {meta}\n)\n{body}\n')
    return str(path)


def unit_warnings(path) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_usd(path)
    return [str(w.message) for w in caught if "metersPerUnit" in str(w.message)]


def units_alone(path) -> float:
    """The oracle: the metersPerUnit USD gives the layer opened as a stage of its own."""
    return UsdGeom.GetStageMetersPerUnit(Usd.Stage.Open(path))


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
