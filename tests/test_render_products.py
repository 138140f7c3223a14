"""UsdRender products: every RenderProduct written at its own camera and resolution, its RenderVars read back with
OpenEXR and Pillow and compared with ``wrt.render``'s image and AOVs; unknown sources, file names a stage must not
steer outside the output folder, ``materialBindingPurposes`` and ``renderingColorSpace``."""

import numpy as np
import OpenEXR
import pytest
from PIL import Image as PilImage
from usda_text import load, write

import wrt
from wrt.cli import main

WORLD = """def Xform "World"
{
    def Cube "Box"
    {
        double size = 1
        color3f[] primvars:displayColor = [(0.8, 0.2, 0.2)]
    }
    def Sphere "Ball"
    {
        double radius = 0.4
        double3 xformOp:translate = (1, 0.3, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Camera "Front"
    {
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Camera "Tilted"
    {
        double3 xformOp:translate = (2, 1, 4)
        float3 xformOp:rotateXYZ = (-10, 25, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    }
}
"""


def var(name: str, source: str, data_type: str = "color3f", source_type: str = "raw") -> str:
    return (f'def RenderVar "{name}"\n{{\n    uniform token dataType = "{data_type}"\n'
            f'    uniform string sourceName = "{source}"\n    uniform token sourceType = "{source_type}"\n}}\n')


def product(name: str, vars_: list, product_name: str | None, extra: str = "") -> str:
    targets = ", ".join(f"</Render/Vars/{v}>" for v in vars_)
    named = f'token productName = "{product_name}"\n' if product_name is not None else ""
    return f'def RenderProduct "{name}"\n{{\n{named}rel orderedVars = [{targets}]\n{extra}}}\n'


VARS = (var("color", "color", "color4f") + var("Ci", "Ci") + var("depth", "cameraDepth", "float")
        + var("N", "Neye", "normal3f") + var("id", "primId", "int") + var("albedo", "albedo")
        + var("P", "P", "point3f") + var("st", "st", "float2", "primvar") + var("lpe", "C<RD>L", source_type="lpe"))


def write_stage(tmp_path, products: str, names: list, settings: str = "", name: str = "shot.usda") -> str:
    targets = ", ".join(f"</Render/{n}>" for n in names)
    body = (WORLD + 'def Scope "Render"\n{\n'
            f'def RenderSettings "Settings"\n{{\nrel camera = </World/Front>\nuniform int2 resolution = (32, 16)\n'
            f'rel products = [{targets}]\n{settings}}}\n'
            + products + 'def Scope "Vars"\n{\n' + VARS + "}\n}\n")
    path = write(tmp_path, body, name)
    text = open(path).read().replace("(\n", '(\n    renderSettingsPrimPath = "/Render/Settings"\n', 1)
    open(path, "w").write(text)
    return path


def read_exr(path) -> dict:
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.array(c.pixels) for name, c in f.channels().items()}


def eye_normals(stage_path: str, camera: str, normals: np.ndarray) -> np.ndarray:
    """World normals in the camera's space by pxr's own view matrix (the oracle of the Neye channel)."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.Open(stage_path)
    view = UsdGeom.Xformable(stage.GetPrimAtPath(camera)).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    view = view.GetInverse()
    out = np.array([view.TransformDir(Gf.Vec3d(*map(float, n))) for n in normals.reshape(-1, 3)])
    return out.reshape(normals.shape)


def test_every_product_is_written_at_its_own_view_and_agrees_with_render(tmp_path):
    """A beauty PNG at the settings' camera and 32x16 and an EXR of beauty and AOVs at another camera and 20x10: the
    files have those sizes and channels, and every channel is what wrt.render gives for that view. wrt wrote no
    file (productName was never read) and rendered only the first product's view."""
    products = (product("Beauty", ["color"], "../../beauty.png")
                + product("Aovs", ["Ci", "depth", "N", "id", "albedo", "color"], "/somewhere/else/aovs.exr",
                          'rel camera = </World/Tilted>\nuniform int2 resolution = (20, 10)\n'))
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"])
    scene = load(stage)
    assert [(p.product, p.camera, p.resolution) for p in scene.render_settings.products] == [
        ("/Render/Beauty", "/World/Front", (32, 16)), ("/Render/Aovs", "/World/Tilted", (20, 10))]
    out = tmp_path / "out"
    written = wrt.render_products(scene, out, device="cpu")
    assert written == {"/Render/Beauty": out / "beauty.png", "/Render/Aovs": out / "aovs.exr"}
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == ["aovs.exr", "beauty.png", "shot.usda"]

    front = wrt.render(scene, device="cpu")  # the first product's view
    assert front.rgb.shape == (16, 32, 3)
    front.save(tmp_path / "front.png")
    beauty = np.asarray(PilImage.open(out / "beauty.png"))
    assert beauty.shape == (16, 32, 4)  # color4f: RGBA, alpha the camera ray's coverage
    np.testing.assert_array_equal(beauty[..., :3], np.asarray(PilImage.open(tmp_path / "front.png")))
    np.testing.assert_array_equal(beauty[..., 3], np.where(front.aovs["prim"] >= 0, 255, 0))
    assert 0 < (beauty[..., 3] > 0).mean() < 1

    tilted = wrt.render(scene, camera="/World/Tilted", width=20, height=10, device="cpu")
    exr = read_exr(out / "aovs.exr")
    assert sorted(exr) == sorted(["R", "G", "B", "depth", "N.X", "N.Y", "N.Z", "id", "albedo.R", "albedo.G",
                                  "albedo.B", "color.R", "color.G", "color.B", "color.A"])
    assert all(c.shape == (10, 20) and c.dtype == np.float32 for c in exr.values())
    rgb = np.stack([exr[c] for c in "RGB"], axis=-1)
    np.testing.assert_array_equal(rgb, tilted.rgb)  # Ci, the first beauty, in the default layer
    np.testing.assert_array_equal(np.stack([exr[f"color.{c}"] for c in "RGB"], -1), tilted.rgb)
    np.testing.assert_array_equal(exr["color.A"], tilted.aovs["prim"] >= 0)
    np.testing.assert_array_equal(exr["depth"], tilted.aovs["z"])  # cameraDepth: along the view axis, inf on a miss
    np.testing.assert_array_equal(exr["id"], tilted.aovs["prim"])
    np.testing.assert_array_equal(np.stack([exr[f"albedo.{c}"] for c in "RGB"], -1), tilted.aovs["albedo"])
    hit = tilted.aovs["prim"] >= 0
    assert 0 < hit.mean() < 1 and len(np.unique(exr["id"][hit])) >= 2  # both shapes seen, and the background
    neye = np.stack([exr[f"N.{c}"] for c in "XYZ"], axis=-1)
    np.testing.assert_allclose(neye, eye_normals(stage, "/World/Tilted", tilted.aovs["normal"]), atol=1e-5)
    assert np.all(neye[hit][:, 2] > 0)  # facing the camera, which looks down -Z


def test_unknown_sources_are_left_out_with_a_warning_naming_the_render_var(tmp_path):
    """A raw source wrt has not (P), a primvar and an LPE other than the beauty: one warning each, naming the
    RenderVar; the product keeps what wrt has, and a product left with nothing is skipped, named."""
    products = (product("Mixed", ["P", "depth", "st", "lpe"], "mixed.exr")
                + product("Nothing", ["P"], "nothing.exr"))
    scene = load(write_stage(tmp_path, products, ["Mixed", "Nothing"]))
    with pytest.warns(UserWarning) as record:
        written = wrt.render_products(scene, tmp_path / "out", device="cpu")
    messages = [str(w.message) for w in record]
    for path, source in (("/Render/Vars/P", "raw 'P'"), ("/Render/Vars/st", "primvar 'st'"),
                         ("/Render/Vars/lpe", "lpe 'C<RD>L'")):
        assert sum(f"RenderVar {path} ({source}) has no wrt output and is left out" in m for m in messages) >= 1
    assert any("/Render/Nothing has no RenderVar wrt can write; it is skipped" in m for m in messages)
    assert list(written) == ["/Render/Mixed"]
    assert sorted(read_exr(written["/Render/Mixed"])) == ["depth"]


def test_product_names_stay_in_the_output_folder(tmp_path):
    """productName is reduced to its last component: '../../x.png', an absolute path and a Windows path all land in
    OUTDIR; a second product of one name gets _2; no productName: the prim's name; a .png of several channels
    becomes .exr (said); a name without an extension gets one."""
    products = (product("A", ["color"], "../../x.png") + product("B", ["color"], "/tmp/elsewhere/x.png")
                + product("C", ["color"], None) + product("D", ["color", "depth"], "aovs.png")
                + product("E", ["depth"], "C:\\\\render\\\\shot.0001") + product("F", ["color"], ".."))
    scene = load(write_stage(tmp_path, products, list("ABCDEF")))
    out = tmp_path / "deep" / "out"
    with pytest.warns(UserWarning) as record:
        written = wrt.render_products(scene, out, device="cpu")
    assert {k: v.name for k, v in written.items()} == {
        "/Render/A": "x.png", "/Render/B": "x_2.png", "/Render/C": "C.png", "/Render/D": "aovs.exr",
        "/Render/E": "shot.0001.exr", "/Render/F": "F.png"}
    assert all(p.parent == out for p in written.values())
    files = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert files == sorted([f"deep/out/{p.name}" for p in written.values()] + ["shot.usda"])
    messages = " | ".join(str(w.message) for w in record)
    assert "/Render/B writes x.png, as an earlier product does; written as x_2.png" in messages
    assert "/Render/D productName 'aovs.png': wrt writes several channels as EXR; written as aovs.exr" in messages


def test_stage_without_products_is_an_error(tmp_path):
    scene = load(write_stage(tmp_path, "", []))
    with pytest.raises(ValueError, match=r"shot.usda: /Render/Settings has no RenderProduct to write"):
        wrt.render_products(scene, tmp_path / "out")


def test_render_var_targets_that_are_not_render_vars_are_named(tmp_path):
    products = product("A", ["color"], "a.png").replace("</Render/Vars/color>",
                                                         "</Render/Vars/color>, </World/Box>")
    with pytest.warns(UserWarning, match=r"shot.usda: /Render/A: orderedVars targets /World/Box, which is a Cube, "
                      r"not a RenderVar; it is left out"):
        scene = wrt.load_usd(write_stage(tmp_path, products, ["A"]))
    assert [v.path for v in scene.render_settings.render_vars] == ["/Render/Vars/color"]


def test_cli_products(tmp_path, capsys):
    products = product("Beauty", ["color"], "beauty.png") + product("Aovs", ["depth", "id"], "aovs.exr")
    stage = write_stage(tmp_path, products, ["Beauty", "Aovs"])
    assert main(["render", stage, "--products", str(tmp_path / "out"), "-q"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["aovs.exr", "beauty.png"]
    assert PilImage.open(tmp_path / "out" / "beauty.png").size == (32, 16)
    assert main(["render", stage, "--products", str(tmp_path / "o2"), "--width", "8", "-o", "x.png"]) == 2
    assert "wrt: error: -o, --width cannot be combined with --products" in capsys.readouterr().err
    # One image of a stage of several products says where the others are.
    assert main(["render", stage, "-o", str(tmp_path / "one.png"), "-q"]) == 0
    assert ("wrt: warning: shot.usda: /Render/Settings has 2 RenderProducts; this image is the first's, "
            "/Render/Beauty (--products DIR writes them all)") in capsys.readouterr().err
