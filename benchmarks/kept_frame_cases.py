"""Kept-stage frame loads (``wrt.usd_frames.StageFrames``) of two stages where one thing varies and the rest does
not: ``dome``, a 1024x1024 ``angular`` DomeLight texture on a dome that turns, beside a floor quad (the image was
resampled to lat-long at every frame); ``looks``, 300 quads each bound to its own UsdPreviewSurface material, one of
which is animated (every material was read again at every frame); ``textured``, the same with the static
materials' colour from image files (each was read again at every frame, its image decoded once); ``clipped``,
100 static meshes of 3,200 triangles and a deforming one under value clips (a clip file per frame gives its points),
beside 20 native instances of a static mesh (every mesh under clips, and every prototype's, was read again at every
frame); or any stage file given as the case (a textured asset). Prints the first load and the mean of the 7 later
ones (frames 1..8), and the material and mesh memos' counts.

Usage: python benchmarks/kept_frame_cases.py FOLDER {dome,looks,textured,clipped,STAGE_FILE}
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from wrt.usd_frames import StageFrames

MATERIALS = 300  # quads and materials of ``looks``
CLIPPED_MESHES = 100  # static meshes under the value clips of ``clipped``
CLIPPED_GRID = 40  # quads along each side of its meshes (2 * 40 * 40 = 3,200 triangles)
INSTANCES = 20  # native instances of ``clipped``'s kit
PROBE_SIZE = 1024  # pixels of the angular map's side


def quad(stage, path: str, x: float):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr([(x, 0, 0), (x + 1, 0, 0), (x + 1, 1, 0), (x, 1, 0)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return m


def dome_stage(folder: Path) -> Path:
    from PIL import Image

    rng = np.random.default_rng(1)
    Image.fromarray(rng.integers(0, 255, (PROBE_SIZE, PROBE_SIZE, 3), dtype=np.uint8)).save(folder / "probe.png")
    stage = Usd.Stage.CreateNew(str(folder / "dome.usda"))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(8)
    dome = UsdLux.DomeLight.Define(stage, "/Sky")
    dome.CreateTextureFileAttr(Sdf.AssetPath("probe.png"))
    dome.CreateTextureFormatAttr("angular")
    turn = dome.AddRotateYOp()
    turn.Set(0.0, 1), turn.Set(90.0, 8)
    quad(stage, "/Floor", 0)
    stage.GetRootLayer().Save()
    return folder / "dome.usda"


def textured_stage(folder: Path) -> Path:
    """``looks`` with each static material's diffuseColor read from one of 8 image files (256x256) through a
    UsdUVTexture fed by a UsdPrimvarReader_float2."""
    return looks_stage(folder, textured=True)


def looks_stage(folder: Path, textured: bool = False) -> Path:
    from PIL import Image

    rng = np.random.default_rng(2)
    for k in range(8 if textured else 0):
        Image.fromarray(rng.integers(0, 255, (256, 256, 3), dtype=np.uint8)).save(folder / f"tex{k}.png")
    stage = Usd.Stage.CreateNew(str(folder / ("textured.usda" if textured else "looks.usda")))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(8)
    for k in range(MATERIALS):
        material = UsdShade.Material.Define(stage, f"/Looks/M{k}")
        shader = UsdShade.Shader.Define(stage, f"/Looks/M{k}/Surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        color = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
        shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.3)
        shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.1)
        if k == 0:  # the one animated material
            color.Set(Gf.Vec3f(1, 0, 0), 1), color.Set(Gf.Vec3f(0, 0, 1), 8)
        elif textured:
            reader = UsdShade.Shader.Define(stage, f"/Looks/M{k}/St")
            reader.CreateIdAttr("UsdPrimvarReader_float2")
            reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
            image = UsdShade.Shader.Define(stage, f"/Looks/M{k}/Image")
            image.CreateIdAttr("UsdUVTexture")
            image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(f"./tex{k % 8}.png"))
            image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
            color.ConnectToSource(image.ConnectableAPI(), "rgb")
        else:
            color.Set(Gf.Vec3f(0.5, k / MATERIALS, 0.2))
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(quad(stage, f"/World/Q{k}", 1.1 * k).GetPrim()).Bind(material)
    stage.GetRootLayer().Save()
    return folder / ("textured.usda" if textured else "looks.usda")


def grid_mesh(stage, path: str, z: float = 0.0, points: bool = True):
    """A ``CLIPPED_GRID`` x ``CLIPPED_GRID`` quad grid at height ``z`` (its points left to value clips if not
    ``points``)."""
    n = CLIPPED_GRID
    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).reshape(-1)
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreateFaceVertexCountsAttr([4] * (n * n))
    m.CreateFaceVertexIndicesAttr(np.stack([a, a + n + 1, a + n + 2, a + 1], 1).reshape(-1).tolist())
    if points:
        m.CreatePointsAttr(grid_points(z))
    return m


def grid_points(z: float):
    u = np.linspace(0.0, 1.0, CLIPPED_GRID + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    return np.stack([x, y, z + 0.05 * np.sin(6 * x) * np.cos(4 * y)], -1).reshape(-1, 3).astype(np.float32)


def clipped_stage(folder: Path) -> Path:
    """``CLIPPED_MESHES`` static meshes and ``Deform`` below ``/Cache``, whose value clips (one file per frame) give
    ``Deform``'s points, beside ``INSTANCES`` native instances of a kit holding one static mesh."""
    for k in range(1, 9):
        clip = Usd.Stage.CreateInMemory()
        UsdGeom.Mesh.Define(clip, "/Cache/Deform").CreatePointsAttr().Set(grid_points(0.1 * k), k)
        clip.GetRootLayer().Export(str(folder / f"cache.{k}.usda"))
    stage = Usd.Stage.CreateNew(str(folder / "clipped.usda"))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(8)
    grid_mesh(stage, "/Cache/Deform", points=False)
    for k in range(CLIPPED_MESHES):
        grid_mesh(stage, f"/Cache/S{k}", 0.01 * k)
    api = Usd.ClipsAPI(stage.GetPrimAtPath("/Cache"))
    api.SetClipPrimPath("/Cache")
    api.SetClipTemplateAssetPath("./cache.#.usda")
    api.SetClipTemplateStartTime(1)
    api.SetClipTemplateEndTime(8)
    api.SetClipTemplateStride(1)
    stage.CreateClassPrim("/Kit")
    grid_mesh(stage, "/Kit/Part")
    for k in range(INSTANCES):
        prop = UsdGeom.Xform.Define(stage, f"/Props/P{k}")
        prop.GetPrim().GetReferences().AddInternalReference("/Kit")
        prop.GetPrim().SetInstanceable(True)
        prop.AddTranslateOp().Set(Gf.Vec3d(1.5 * k, 2, 0))
    stage.GetRootLayer().Save()
    return folder / "clipped.usda"


def main() -> None:
    cases = {"dome": dome_stage, "looks": looks_stage, "textured": textured_stage, "clipped": clipped_stage}
    # Without arguments it stopped with a traceback (IndexError), and a misspelt case was loaded as a stage file.
    parser = argparse.ArgumentParser(description="Kept-stage frame loads of a stage where one thing varies.",
                                     allow_abbrev=False)
    parser.add_argument("folder", type=Path, help="folder the case's stage (and its files) is written into")
    parser.add_argument("case", help=f"{', '.join(cases)}, or a stage file to load")
    args = parser.parse_args()
    folder, case = args.folder, args.case
    if case not in cases and not Path(case).is_file():
        parser.error(f"case {case!r} is none of {', '.join(cases)}, and no stage file")
    warnings.simplefilter("ignore")
    folder.mkdir(parents=True, exist_ok=True)
    frames = StageFrames(cases[case](folder) if case in cases else Path(case))
    seconds = []
    for t in range(1, 9):
        start = time.perf_counter()
        frames.load(t)
        seconds.append(time.perf_counter() - start)
    later = [s * 1e3 for s in seconds[1:]]
    print(f"{case}: first {seconds[0] * 1e3:.0f} ms, later frames mean {statistics.mean(later):.0f} ms "
          f"(min {min(later):.0f}, max {max(later):.0f}), "
          f"materials {getattr(frames.material_memo, 'counts', 'none kept')}, "
          f"meshes {getattr(frames.memo, 'counts', 'none kept')}")


if __name__ == "__main__":
    main()
