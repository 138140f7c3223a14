"""Fuzzed USD stages: random and broken topology, values, transforms and composition arcs; subdivision tags
(creases, corners, holes, boundary rules) rendered at a random refine level, tapered ``Cylinder_1``/``Capsule_1``
gprims, shaped lights, UsdPreviewSurface normal maps and UDIM textures, MaterialX standard_surface constants.

Every generated stage must either load and render, or raise ``wrt.SceneError`` whose message names the file and
the prim. No other exception is allowed. ``WRT_FUZZ_EXAMPLES`` raises the example count for longer local runs.
"""

import math
import os
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, find, given, settings
from hypothesis import strategies as st
from PIL import Image as PilImage

import wrt

EXAMPLES = int(os.environ.get("WRT_FUZZ_EXAMPLES", "500"))  # about 60 s on this 2-core machine with a cold kernel cache
INTERPOLATIONS = ["constant", "uniform", "varying", "vertex", "faceVarying", "bogus", ""]
SPECIAL = [0.0, -0.0, 1e-30, 1e30, 1e38, -1e38, math.nan, math.inf, -math.inf, 1e-45]


def number(x: float) -> str:
    """A float as usda text, with nan and inf spelled as the parser wants them."""
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(float(x))


def vec3s(values) -> str:
    return "[" + ", ".join("(" + ", ".join(number(c) for c in v) + ")" for v in values) + "]"


def ints(values) -> str:
    return "[" + ", ".join(str(int(v)) for v in values) + "]"


floats = st.one_of(st.floats(-10, 10, allow_nan=False), st.sampled_from(SPECIAL))
mostly_sane = st.floats(-10, 10, allow_nan=False, allow_infinity=False)


@st.composite
def meshes(draw, name):
    n_points = draw(st.integers(0, 12))
    coord = st.one_of(mostly_sane, mostly_sane, mostly_sane, floats)
    points = draw(st.lists(st.tuples(coord, coord, coord), min_size=n_points, max_size=n_points))
    counts = draw(st.lists(st.one_of(st.integers(3, 6), st.integers(-2, 2)), max_size=6))
    n_indices = sum(max(c, 0) for c in counts) + draw(st.sampled_from([0, 0, 0, -1, 1]))
    indices = draw(st.lists(st.integers(-1, n_points + 1), min_size=max(n_indices, 0), max_size=max(n_indices, 0)))
    lines = [f'def Mesh "{name}"{binding_schema(draw)}', "{"]
    if draw(st.booleans()) or counts:
        lines.append(f"    int[] faceVertexCounts = {ints(counts)}")
        lines.append(f"    int[] faceVertexIndices = {ints(indices)}")
    if draw(st.integers(0, 9)) > 0:
        lines.append(f"    point3f[] points = {vec3s(points)}")
    if draw(st.booleans()):
        lines.append(f'    uniform token orientation = "{draw(st.sampled_from(["leftHanded", "rightHanded"]))}"')
    for attr, type_name in (("normals", "normal3f[]"), ("primvars:displayColor", "color3f[]")):
        if draw(st.booleans()):
            size = draw(st.integers(0, 14))
            values = draw(st.lists(st.tuples(floats, floats, floats), min_size=size, max_size=size))
            interp = draw(st.sampled_from(INTERPOLATIONS))
            meta = f' (interpolation = "{interp}")' if interp else ""
            lines.append(f"    {type_name} {attr} = {vec3s(values)}{meta}")
            if draw(st.integers(0, 3)) == 0:
                lines.append(f"    int[] {attr}:indices = {ints(draw(st.lists(st.integers(-1, 15), max_size=8)))}")
    lines += subdivision_lines(draw, n_points, len(counts))
    lines += st_lines(draw)
    lines += binding_lines(draw)
    lines += transform_lines(draw)
    if draw(st.integers(0, 4)) == 0:
        lines.append(f'    token visibility = "{draw(st.sampled_from(["invisible", "inherited", "bogus"]))}"')
    if draw(st.integers(0, 4)) == 0:
        lines.append(f'    uniform token purpose = "{draw(st.sampled_from(["guide", "proxy", "render", "nonsense"]))}"')
    lines.append("}")
    return "\n".join(lines)


CUBE_POINTS = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
CUBE_FACES = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]


@st.composite
def cages(draw, name):
    """A valid cube or open box (a few of its quads), so that its subdivision tags, texture coordinates and
    material are what is broken, not its topology."""
    faces = draw(st.lists(st.sampled_from(CUBE_FACES), min_size=1, max_size=6, unique=True))
    jitter = st.floats(-0.3, 0.3)
    points = [tuple(c + draw(jitter) for c in p) for p in CUBE_POINTS] if draw(st.booleans()) else CUBE_POINTS
    lines = [f'def Mesh "{name}"{binding_schema(draw)}', "{",
             f"    int[] faceVertexCounts = {ints([4] * len(faces))}",
             f"    int[] faceVertexIndices = {ints([i for face in faces for i in face])}",
             f"    point3f[] points = {vec3s(points)}"]
    lines += subdivision_lines(draw, len(points), len(faces))
    lines += st_lines(draw)
    lines += binding_lines(draw)
    lines.append("}")
    return "\n".join(lines)


def transform_lines(draw):
    kind = draw(st.sampled_from(["none", "none", "scale", "matrix", "translate"]))
    if kind == "scale":
        s = draw(st.tuples(floats, floats, floats))
        return [f"    double3 xformOp:scale = ({', '.join(number(c) for c in s)})",
                '    uniform token[] xformOpOrder = ["xformOp:scale"]']
    if kind == "translate":
        t = draw(st.tuples(floats, floats, floats))
        return [f"    double3 xformOp:translate = ({', '.join(number(c) for c in t)})",
                '    uniform token[] xformOpOrder = ["xformOp:translate"]']
    if kind == "matrix":
        rows = draw(st.lists(st.tuples(floats, floats, floats, floats), min_size=4, max_size=4))
        if draw(st.booleans()):
            rows = [(1, 0, 0, 0), (0, 0, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)]  # singular
        text = ", ".join("(" + ", ".join(number(c) for c in r) + ")" for r in rows)
        return [f"    matrix4d xformOp:transform = ({text})",
                '    uniform token[] xformOpOrder = ["xformOp:transform"]']
    return []


def floats_text(values) -> str:
    return "[" + ", ".join(number(v) for v in values) + "]"


def maybe_wrong_type(draw, type_name: str) -> str:
    """``type_name`` most of the time, else a type the schema does not declare for the attribute."""
    if draw(st.integers(0, 9)):
        return type_name
    return draw(st.sampled_from(["float", "double", "int", "float[]", "int[]", "double3"]))


def attribute(draw, type_name: str, name: str, text: str) -> str:
    """A usda line declaring ``name`` as ``type_name`` = ``text``, now and then with a wrong type (and a random
    value of that type)."""
    authored = maybe_wrong_type(draw, type_name)
    return f"    {authored} {name} = {text if authored == type_name else value_text(authored, draw)}"


def value_text(type_name: str, draw) -> str:
    """A random value of usda type ``type_name`` (scalars, tuples and arrays of them), special values included."""
    array = type_name.endswith("[]")
    base = type_name.removesuffix("[]")
    width = {"double3": 3, "float3": 3, "color3f": 3, "normal3f": 3, "float2": 2, "texCoord2f": 2, "float4": 4}
    if base == "int":
        element = st.integers(-3, 20).map(str)
    elif base == "bool":
        element = st.sampled_from(["true", "false", "0", "1"])
    elif base in width:
        element = st.lists(floats, min_size=width[base], max_size=width[base]).map(
            lambda v: "(" + ", ".join(number(c) for c in v) + ")")
    else:
        element = floats.map(number)
    if array:
        return "[" + ", ".join(draw(st.lists(element, max_size=6))) + "]"
    return draw(element)


def subdivision_lines(draw, n_points, n_faces):
    """Catmull-Clark tags, often broken: indices out of range, lengths that do not add up, special sharpnesses,
    holes out of range, unknown tokens and wrong types."""
    lines = []
    if draw(st.integers(0, 3)) == 0:
        scheme = draw(st.sampled_from(["catmullClark", "none", "bilinear", "loop", "bogus"]))
        lines.append(f'    uniform token subdivisionScheme = "{scheme}"')
    sharpness = st.one_of(st.floats(0, 12), st.sampled_from(SPECIAL + [-1.0, 10.0]))
    vertex = st.integers(-1, n_points + 1)
    if draw(st.booleans()):
        lengths = draw(st.lists(st.integers(-1, 4), max_size=3))
        count = sum(max(n, 0) for n in lengths) + draw(st.sampled_from([0, 0, 0, -1, 1]))
        indices = draw(st.lists(vertex, min_size=max(count, 0), max_size=max(count, 0)))
        sharps = draw(st.lists(sharpness, min_size=len(lengths), max_size=len(lengths) + 1))
        if draw(st.integers(0, 5)) == 0:  # one sharpness per crease edge, which USD also allows
            sharps = draw(st.lists(sharpness, min_size=max(count - len(lengths), 0), max_size=max(count, 0)))
        lines += [attribute(draw, "int[]", "creaseIndices", ints(indices)),
                  attribute(draw, "int[]", "creaseLengths", ints(lengths)),
                  attribute(draw, "float[]", "creaseSharpnesses", floats_text(sharps))]
    if draw(st.booleans()):
        corners = draw(st.lists(vertex, max_size=3))
        sharps = draw(st.lists(sharpness, min_size=max(len(corners) - 1, 0), max_size=len(corners) + 1))
        lines += [attribute(draw, "int[]", "cornerIndices", ints(corners)),
                  attribute(draw, "float[]", "cornerSharpnesses", floats_text(sharps))]
    if draw(st.integers(0, 2)) == 0:
        rule = draw(st.sampled_from(["edgeAndCorner", "edgeOnly", "none", "bogus"]))
        lines.append(f'    token interpolateBoundary = "{rule}"')
    if draw(st.integers(0, 2)) == 0:
        rule = draw(st.sampled_from(["cornersPlus1", "none", "all", "boundaries", "bogus"]))
        lines.append(f'    token faceVaryingLinearInterpolation = "{rule}"')
    if draw(st.integers(0, 2)) == 0:
        holes = draw(st.lists(st.integers(-1, n_faces + 1), max_size=3))
        lines.append(attribute(draw, "int[]", "holeIndices", ints(holes)))
    return lines


def st_lines(draw):
    """Texture coordinates over several UDIM tiles (and special values) for the textures of the materials."""
    if draw(st.integers(0, 2)):
        return []
    size = draw(st.integers(0, 14))
    coord = st.one_of(st.floats(-1, 12, allow_nan=False), st.floats(-1, 12, allow_nan=False), floats)
    values = draw(st.lists(st.tuples(coord, coord), min_size=size, max_size=size))
    interp = draw(st.sampled_from(INTERPOLATIONS))
    meta = f' (interpolation = "{interp}")' if interp else ""
    text = "[" + ", ".join(f"({number(u)}, {number(v)})" for u, v in values) + "]"
    return [f"    texCoord2f[] primvars:st = {text}{meta}"]


LOOKS = ["/World/Looks/L0", "/World/Looks/L1", "/World/Looks/L2", "/World/Looks/Nope", "/World"]


def binding_schema(draw) -> str:
    return "" if draw(st.integers(0, 4)) == 0 else ' (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)'


def binding_lines(draw):
    if draw(st.integers(0, 2)) == 0:
        return []
    return [f"    rel material:binding = <{draw(st.sampled_from(LOOKS))}>"]


@st.composite
def tapered_gprims(draw, name):
    """``Cylinder_1`` and ``Capsule_1`` with random, special or mistyped radii, height and axis."""
    type_name = draw(st.sampled_from(["Cylinder_1", "Capsule_1", "Cylinder", "Capsule"]))
    size = st.one_of(st.floats(0, 3), st.floats(0, 3), st.sampled_from(SPECIAL + [-1.0]))
    lines = [f'def {type_name} "{name}"{binding_schema(draw)}', "{"]
    for attr in ("radiusTop", "radiusBottom", "radius", "height"):
        if draw(st.integers(0, 3)):
            lines.append(attribute(draw, "double", attr, number(draw(size))))
    if draw(st.booleans()):
        lines.append(f'    uniform token axis = "{draw(st.sampled_from(["X", "Y", "Z", "W", ""]))}"')
    lines += binding_lines(draw)
    lines += transform_lines(draw)
    lines.append("}")
    return "\n".join(lines)


SHAPING_INPUTS = {"shaping:cone:angle": "float", "shaping:cone:softness": "float", "shaping:focus": "float",
                  "shaping:focusTint": "color3f"}
LIGHT_INPUTS = {"SphereLight": {"radius": "float"}, "DiskLight": {"radius": "float"},
                "RectLight": {"width": "float", "height": "float"},
                "CylinderLight": {"radius": "float", "length": "float"}, "DistantLight": {"angle": "float"}}


@st.composite
def shaped_lights(draw, name):
    """Lights with ShapingAPI inputs: random, special and mistyped cone angle, softness, focus and tint."""
    kind = draw(st.sampled_from(sorted(LIGHT_INPUTS)))
    schemas = "" if draw(st.integers(0, 4)) == 0 else ' (\n    prepend apiSchemas = ["ShapingAPI"]\n)'
    lines = [f'def {kind} "{name}"{schemas}', "{"]
    inputs = {"intensity": "float", "color": "color3f", **LIGHT_INPUTS[kind], **SHAPING_INPUTS}
    for attr, type_name in inputs.items():
        if draw(st.integers(0, 2)):
            lines.append(attribute(draw, type_name, f"inputs:{attr}", value_text(type_name, draw)))
    lines += transform_lines(draw)
    lines.append("}")
    return "\n".join(lines)


TEXTURE_FILES = ["./tiny.png", "./no_such_map.png", "./tile.<UDIM>.png", "./no_tiles.<UDIM>.png", "./tile.1001.png",
                 "", "./tile.<UVTILE>.png"]
STANDARD_SURFACE_INPUTS = {
    "base": "float", "base_color": "color3f", "metalness": "float", "specular": "float", "specular_color": "color3f",
    "specular_roughness": "float", "specular_IOR": "float", "coat": "float", "coat_roughness": "float",
    "coat_IOR": "float", "emission": "float", "emission_color": "color3f", "opacity": "color3f",
    "transmission": "float", "transmission_color": "color3f", "thin_walled": "bool"}


@st.composite
def looks(draw, name):
    """A UsdPreviewSurface whose normal (and maybe diffuse colour) comes from a UsdUVTexture of a tiny PNG, a
    missing file or a UDIM pattern, or a MaterialX standard_surface with random constant inputs."""
    path = f"/World/Looks/{name}"
    if draw(st.booleans()):
        lines = [f'def Material "{name}"', "{", f"    token outputs:mtlx:surface.connect = <{path}/S.outputs:out>",
                 'def Shader "S"', "{", '    uniform token info:id = "ND_standard_surface_surfaceshader"']
        for attr, type_name in STANDARD_SURFACE_INPUTS.items():
            if draw(st.booleans()):
                lines.append(attribute(draw, type_name, f"inputs:{attr}", value_text(type_name, draw)))
        return "\n".join(lines + ["    token outputs:out", "}", "}"])
    lines = [f'def Material "{name}"', "{", f"    token outputs:surface.connect = <{path}/S.outputs:surface>",
             'def Shader "S"', "{", '    uniform token info:id = "UsdPreviewSurface"']
    if draw(st.integers(0, 4)):
        lines.append(f"    normal3f inputs:normal.connect = <{path}/N.outputs:{draw(st.sampled_from(['rgb', 'r']))}>")
    else:
        lines.append(attribute(draw, "normal3f", "inputs:normal", value_text("normal3f", draw)))
    if draw(st.booleans()):
        lines.append(f"    color3f inputs:diffuseColor.connect = <{path}/N.outputs:rgb>")
    lines += ["    token outputs:surface", "}", 'def Shader "N"', "{", '    uniform token info:id = "UsdUVTexture"',
              f"    asset inputs:file = @{draw(st.sampled_from(TEXTURE_FILES))}@",
              f"    float2 inputs:st.connect = <{path}/R.outputs:result>"]
    for attr in ("scale", "bias", "fallback"):
        if draw(st.booleans()):
            lines.append(attribute(draw, "float4", f"inputs:{attr}", value_text("float4", draw)))
    if draw(st.booleans()):
        lines.append(f'    token inputs:sourceColorSpace = "{draw(st.sampled_from(["raw", "sRGB", "auto", "x"]))}"')
    lines += ["    float3 outputs:rgb", "    float outputs:r", "}", 'def Shader "R"', "{",
              '    uniform token info:id = "UsdPrimvarReader_float2"',
              f'    token inputs:varname = "{draw(st.sampled_from(["st", "st", "uv"]))}"', "    float2 outputs:result",
              "}"]
    return "\n".join(lines + ["}"])


@st.composite
def stages(draw):
    parts = ["#usda 1.0", f'(\n    upAxis = "{draw(st.sampled_from(["Y", "Z", "X"]))}"\n)']
    body = [draw(meshes(f"M{i}")) for i in range(draw(st.integers(0, 3)))]
    body += [draw(cages(f"C{i}")) for i in range(draw(st.integers(0, 2)))]
    body += [draw(tapered_gprims(f"G{i}")) for i in range(draw(st.integers(0, 2)))]
    body += [draw(shaped_lights(f"Light{i}")) for i in range(draw(st.integers(0, 2)))]
    n_looks = draw(st.integers(0, 3))
    if n_looks:
        body.append('def Scope "Looks"\n{\n' + "\n".join(draw(looks(f"L{i}")) for i in range(n_looks)) + "\n}")
    arcs = draw(st.lists(st.sampled_from(["cycle", "missing_ref", "missing_payload", "self_ref", "instance"]),
                         max_size=2))
    if "cycle" in arcs:
        body += ['def Xform "CycA" (\n    references = </CycB>\n)\n{\n}',
                 'def Xform "CycB" (\n    references = </CycA>\n)\n{\n}']
    if "missing_ref" in arcs:
        body.append('def Xform "Ref" (\n    references = @./no_such_file.usda@\n)\n{\n}')
    if "missing_payload" in arcs:
        body.append('def Xform "Pay" (\n    payload = @./no_such_payload.usda@</X>\n)\n{\n}')
    if "self_ref" in arcs:
        body.append('def Xform "Self" (\n    references = @./stage.usda@\n)\n{\n}')
    if "instance" in arcs and body:
        body.append('def Xform "Inst" (\n    instanceable = true\n    references = </World>\n)\n{\n}')
    world_transform = transform_lines(draw) if draw(st.integers(0, 2)) == 0 else []  # a broken one hides the rest
    world = ['def Xform "World"', "{"] + world_transform + ["\n".join(body), "}"]
    return "\n".join(parts + world) + "\n"


@settings(
    max_examples=EXAMPLES,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture],
)
@given(text=stages(), refine_level=st.integers(0, 2), tessellate=st.sampled_from([False, False, False, True, 5]))
def test_fuzzed_stage_loads_and_renders_or_raises_scene_error(tmp_path, text, refine_level, tessellate):
    write_textures(tmp_path)
    path = tmp_path / "stage.usda"
    path.write_text(text)
    try:
        scene = wrt.load_usd(path, refine_level=refine_level, tessellate_gprims=tessellate)
    except wrt.SceneError as e:
        assert "stage.usda" in str(e)
        assert e.prim is None or re.search(r"/\w+", str(e))  # names the prim when there is one
        return
    points, indices = scene.triangles()
    assert np.isfinite(points[indices.ravel()]).all()
    if len(indices) or scene.shapes:
        img = wrt.render(scene, width=6, height=4, device="cpu")
        assert np.isfinite(img.rgb).all()


def write_textures(folder):
    """The tiny PNGs the looks name: ``tiny.png`` and the UDIM tiles 1001 and 1012 of ``tile.<UDIM>.png``."""
    if (folder / "tiny.png").exists():
        return
    rng = np.random.default_rng(0)
    for name in ("tiny.png", "tile.1001.png", "tile.1012.png"):
        PilImage.fromarray(rng.integers(0, 256, (2, 3, 3), dtype=np.uint8)).save(folder / name)


BROKEN_CASES = {
    "nan": "nan",
    "inf": "inf",
    "negative count": r"faceVertexCounts = \[[^\]]*-\d",
    "bad interpolation": 'interpolation = "bogus"',
    "cycle": "CycA",
    "missing ref": "no_such_file",
    "missing payload": "no_such_payload",
    "singular": r"\(0\.0, 0\.0, 0\.0, 0\.0\)",
    "zero scale": r"xformOp:scale = \(0\.0",
    "nan crease": r"creaseSharpnesses = \[[^\]]*nan",
    "mistyped crease": r"(float|double)(\[\])? creaseIndices",
    "hole out of range": r"holeIndices = \[[^\]]*-1",
    "tapered": r"def (Cylinder_1|Capsule_1)",
    "negative radius": r"radiusTop = -",
    "shaping special": r"shaping:[a-zA-Z:]+ = -?(nan|inf)",
    "normal map": r"inputs:normal.connect",
    "udim": "<UDIM>",
    "mtlx inf": r"float inputs:(base|metalness|coat|emission) = -?inf",
}


@pytest.mark.parametrize("case", BROKEN_CASES)
def test_fuzzer_generates_the_broken_cases_it_claims(case):
    # The strategy must reach every broken case. Each is searched for on its own: one shared sample of a fixed size
    # missed a different rare case from one environment to the next.
    settings_ = settings(max_examples=2000, derandomize=True, deadline=None, database=None, phases=[Phase.generate])
    text = find(stages(), lambda text: re.search(BROKEN_CASES[case], text) is not None, settings=settings_)
    assert re.search(BROKEN_CASES[case], text)
