"""UDIM textures (``<UDIM>`` in a UsdUVTexture's ``file``): tile ``1001 + u + 10 v`` covers ``st`` in
``[u, u + 1) x [v, v + 1)``; missing tiles and patterns without files give the texture's fallback; bilinear filtering
stays inside a tile; tiles inside a ``.usdz``; UDIM normal maps."""

import warnings

import numpy as np
import pytest
from PIL import Image as PilImage
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, UsdUtils, Vt

import wrt
from wrt.materials import Material, TextureInput
from wrt.textures import UDIM_TILES

RED, GREEN, BLUE, WHITE, BLACK = (255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255), (0, 0, 0)
FALLBACK = (1.0, 1.0, 0.0, 1.0)  # yellow: the UsdUVTexture's authored fallback


def write_tile(folder, tile, color, size=4, columns=None):
    """A ``size`` x ``size`` PNG ``body.<tile>.png`` in ``color``; ``columns`` maps a column (0 = left) to another
    colour."""
    pixels = np.empty((size, size, 3), np.uint8)
    pixels[:] = color
    for column, other in (columns or {}).items():
        pixels[:, column] = other
    folder.mkdir(parents=True, exist_ok=True)
    PilImage.fromarray(pixels).save(folder / f"body.{tile}.png")


def udim_stage(path, pattern, st_size=(2, 2), wrap=None):
    """A plane in z = 0 facing +Z over x, y in [0, st_size], with ``st = (x, y)``, whose UsdPreviewSurface
    ``/Looks/Skin`` reads ``diffuseColor`` from a UsdUVTexture of file ``pattern`` (fallback :data:`FALLBACK`)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/Plane")
    w, h = st_size
    corners = [(0, 0), (w, 0), (w, h), (0, h)]
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(x, y, 0) for x, y in corners]))
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        Vt.Vec2fArray([Gf.Vec2f(x, y) for x, y in corners]))
    material = UsdShade.Material.Define(stage, "/Looks/Skin")
    surface = UsdShade.Shader.Define(stage, "/Looks/Skin/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    reader = UsdShade.Shader.Define(stage, "/Looks/Skin/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    tex = UsdShade.Shader.Define(stage, "/Looks/Skin/Body")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(pattern)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(FALLBACK)
    if wrap:
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(wrap)
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(wrap)
    tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.Save()
    return str(path)


def albedo(scene, center, height, width_px, height_px):
    """The albedo AOV of an orthographic camera above ``center`` (x, y) whose view is ``height`` units tall."""
    cx, cy = center
    cam = wrt.Camera.orthographic(eye=(cx, cy, 5), target=(cx, cy, 0), height=height)
    return wrt.render(scene, camera=cam, width=width_px, height=height_px, device="cpu", integrator="albedo").aovs[
        "albedo"]


def test_udim_tiles_cover_their_unit_squares_and_missing_tiles_show_the_fallback(tmp_path):
    """st in [0, 2)^2 over tiles 1001 (red, bottom-left), 1002 (green, bottom-right), 1011 (blue, top-left) and
    1012 (no file: the fallback, yellow). The pattern was refused with a warning and the whole plane drawn in the
    fallback."""
    for tile, color in ((1001, RED), (1002, GREEN), (1011, BLUE)):
        write_tile(tmp_path / "textures", tile, color)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a missing tile is no error and no warning
        scene = wrt.load_usd(udim_stage(tmp_path / "udim.usda", "textures/body.<UDIM>.png"))
    out = albedo(scene, center=(1, 1), height=2.0, width_px=8, height_px=8)  # row 0 at the top: v in [1, 2)
    bottom, top, left, right = slice(4, 8), slice(0, 4), slice(0, 4), slice(4, 8)
    for rows, cols, color in ((bottom, left, (1, 0, 0)), (bottom, right, (0, 1, 0)), (top, left, (0, 0, 1)),
                              (top, right, FALLBACK[:3])):
        np.testing.assert_allclose(out[rows, cols], np.broadcast_to(color, (4, 4, 3)), atol=1e-3, err_msg=str(color))


def test_a_missing_tile_reads_the_fallback_through_scale_and_bias(tmp_path):
    """Where a tile has no file, the fallback stands in for its texels, and ``scale`` and ``bias`` apply to it as to
    every texel (MaterialX's UsdUVTexture graph: the image's default, times scale, plus bias); it was shown as it is.
    Tile 1001 (red) is there, 1002 (the right half of a plane over st in [0, 2) x [0, 1)) is not."""
    write_tile(tmp_path / "textures", 1001, RED)
    path = udim_stage(tmp_path / "scaled.usda", "textures/body.<UDIM>.png", st_size=(2, 1))
    stage = Usd.Stage.Open(path)
    tex = UsdShade.Shader.Get(stage, "/Looks/Skin/Body")
    scale, bias = (0.5, 0.25, 0.5, 1.0), (0.25, 0.5, 0.25, 0.0)
    tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*scale))
    tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*bias))
    stage.Save()
    out = albedo(wrt.load_usd(path), center=(1, 0.5), height=1.0, width_px=4, height_px=2)
    red = np.array([1.0, 0.0, 0.0]) * scale[:3] + bias[:3]  # (0.75, 0.5, 0.25)
    missing = np.array(FALLBACK[:3]) * scale[:3] + bias[:3]  # (0.75, 0.75, 0.25)
    np.testing.assert_allclose(out[:, :2], np.broadcast_to(red, (2, 2, 3)), atol=1e-3)
    np.testing.assert_allclose(out[:, 2:], np.broadcast_to(missing, (2, 2, 3)), atol=1e-6)


@pytest.mark.parametrize("wrap", ["repeat", "mirror", "black"])
def test_bilinear_lookups_stay_inside_their_tile(tmp_path, wrap):
    """Within a texel of the seam between tiles 1001 and 1002, each side shows its own tile's edge texels: no mix
    of the neighbour tile's colour, and the authored wrap mode does not reach across the tile (1001's left column is
    white and 1002's right column black, which ``repeat`` within a tile would blend in at the seam)."""
    write_tile(tmp_path / "textures", 1001, RED, columns={0: WHITE})
    write_tile(tmp_path / "textures", 1002, GREEN, columns={3: BLACK})
    scene = wrt.load_usd(udim_stage(tmp_path / "seam.usda", "textures/body.<UDIM>.png", st_size=(2, 1), wrap=wrap))
    # 8 pixels over s in [0.9, 1.1] at t = 0.5: centres 0.0125 to 0.0875 away from the seam, past the texel centres
    # (0.125 from it), where filtering reaches the next texel.
    out = albedo(scene, center=(1.0, 0.5), height=0.025, width_px=8, height_px=1)[0]
    np.testing.assert_allclose(out[:4], np.broadcast_to([1, 0, 0], (4, 3)), atol=1e-3)
    np.testing.assert_allclose(out[4:], np.broadcast_to([0, 1, 0], (4, 3)), atol=1e-3)


def test_udim_pattern_without_files_warns_once_naming_material_and_pattern(tmp_path):
    """No tile file at all: one warning naming the material and the pattern; the fallback everywhere."""
    path = udim_stage(tmp_path / "none.usda", "textures/nothing.<UDIM>.png")
    with pytest.warns(UserWarning) as record:
        scene = wrt.load_usd(path)
    messages = [str(w.message) for w in record if "nothing.<UDIM>.png" in str(w.message)]
    assert len(messages) == 1 and "material /Looks/Skin" in messages[0], messages
    assert scene.materials[0].textures == {}
    np.testing.assert_allclose(scene.materials[0].diffuse_color, FALLBACK[:3])
    np.testing.assert_allclose(albedo(scene, (1, 1), 2.0, 4, 4), np.broadcast_to(FALLBACK[:3], (4, 4, 3)), atol=1e-6)


def test_udim_paths_resolve_against_the_layer_that_authored_them(tmp_path):
    """A shot whose sublayer ``asset/asset.usda`` names ``textures/body.<UDIM>.png`` reads the tiles in
    ``asset/textures``, not next to the shot."""
    write_tile(tmp_path / "asset" / "textures", 1001, RED)
    udim_stage(tmp_path / "asset" / "asset.usda", "textures/body.<UDIM>.png", st_size=(1, 1))
    shot = Usd.Stage.CreateNew(str(tmp_path / "shot.usda"))
    shot.GetRootLayer().subLayerPaths.append("asset/asset.usda")
    shot.Save()
    out = albedo(wrt.load_usd(str(tmp_path / "shot.usda")), center=(0.5, 0.5), height=1.0, width_px=2, height_px=2)
    np.testing.assert_allclose(out, np.broadcast_to([1, 0, 0], (2, 2, 3)), atol=1e-3)


def test_udim_tiles_inside_a_usdz_package(tmp_path):
    """Tiles packed into a ``.usdz`` next to the layer that names them resolve inside the package."""
    folder = tmp_path / "src"
    write_tile(folder / "textures", 1001, RED)
    write_tile(folder / "textures", 1002, GREEN)
    layer = udim_stage(folder / "asset.usda", "textures/body.<UDIM>.png", st_size=(2, 1))
    package = str(tmp_path / "asset.usdz")
    assert UsdUtils.CreateNewUsdzPackage(layer, package)
    for tile in folder.glob("textures/*.png"):
        tile.unlink()  # only the package's copies remain
    out = albedo(wrt.load_usd(package), center=(1, 0.5), height=1.0, width_px=4, height_px=2)
    np.testing.assert_allclose(out[:, :2], np.broadcast_to([1, 0, 0], (2, 2, 3)), atol=1e-3)
    np.testing.assert_allclose(out[:, 2:], np.broadcast_to([0, 1, 0], (2, 2, 3)), atol=1e-3)


def test_udim_normal_map(tmp_path):
    """A normal map of two tiles (float textures, scale 2, bias -1) tilts the left half of a quad with st over
    [0, 2) x [0, 1) by tile 1001's normal and the right half by tile 1002's; st on a missing tile keeps the surface
    normal (the fallback (0.5, 0.5, 1), scaled and biased as every texel, is the flat normal)."""
    stored = {1001: np.array([0.25, 0.0, 0.75]), 1002: np.array([0.0, -0.25, 0.75])}  # (n + 1) / 2 exact in halves
    normals = {tile: n / np.linalg.norm(n) for tile, n in stored.items()}
    textures, tiles = [], np.full(UDIM_TILES, -1, np.int32)
    for tile, normal in stored.items():
        tiles[tile - 1001] = len(textures)
        texel = np.ones((2, 2, 4), np.float32)
        texel[..., :3] = (normal + 1.0) / 2.0
        textures.append(texel)
    bias = np.array([-1, -1, -1, 0], np.float32)
    normal_map = TextureInput(image=0, scale=np.array([2, 2, 2, 1], np.float32), bias=bias, tiles=tiles,
                              fallback=np.array([0.5, 0.5, 1.0, 1.0], np.float32))
    material = Material(path="/bumpy", diffuse_color=np.full(3, 0.8, np.float32), textures={"normal": normal_map})
    points = np.array([[0, 0, 0], [3, 0, 0], [3, 1, 0], [0, 1, 0]], np.float64)  # st = (x, y): 1003 has no file
    indices = np.array([[0, 1, 2], [0, 2, 3]])
    quad = wrt.Mesh("/quad", points, indices, [0, 0], uvs=points[indices, :2], material_ids=[0, 0])
    scene = wrt.Scene(meshes=[quad], materials=[material], textures=textures)
    cam = wrt.Camera.orthographic(eye=(1.5, 0.5, 5), target=(1.5, 0.5, 0), height=1.0)
    out = wrt.render(scene, camera=cam, width=6, height=2, device="cpu", integrator="normals").aovs["normal"]
    np.testing.assert_allclose(out[:, :2], np.broadcast_to(normals[1001], (2, 2, 3)), atol=1e-5)
    np.testing.assert_allclose(out[:, 2:4], np.broadcast_to(normals[1002], (2, 2, 3)), atol=1e-5)
    np.testing.assert_allclose(out[:, 4:], np.broadcast_to([0, 0, 1], (2, 2, 3)), atol=1e-6)


@pytest.mark.parametrize("tiles, message", [
    (np.zeros(10, np.int32), "UDIM tiles must be 100 integers"),
    (np.full(UDIM_TILES, 3, np.int32), "UDIM tile 1001 uses texture 3"),
])
def test_bad_udim_tables_are_refused(tiles, message):
    """A table of the wrong length or naming images the scene lacks is refused, naming the material input."""
    material = Material(path="/m", textures={"diffuseColor": TextureInput(image=0, tiles=tiles)})
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
    mesh = wrt.Mesh("/tri", points, np.array([[0, 1, 2]]), [0], uvs=np.zeros((1, 3, 2)), material_ids=[0])
    scene = wrt.Scene(meshes=[mesh], materials=[material], textures=[np.ones((1, 1, 4), np.float32)])
    with pytest.raises(ValueError, match=f"material /m: diffuseColor: {message}"):
        wrt.render(scene, width=2, height=2, device="cpu", integrator="albedo")
