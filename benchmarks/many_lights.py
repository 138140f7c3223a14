"""Scenes with many UsdLux lights: load time and whitted render time.

Writes two stages under a temporary folder: ``instanced``, a PointInstancer of ``--lights`` lamps over a floor (each
lamp a prototype holding a SphereLight and a RectLight textured by one small PNG: one light of each per instance), and
``plain``, the same number of SphereLights authored one by one, and ``linked``, ``--linked`` SphereLights each with
a light- or shadow-link collection over as many meshes (:func:`write_linked`; its link groups timed too). Times
``wrt.load_usd`` of each and a ``whitted``
render of each (a small image, ``--spp`` samples, after a warm-up render that compiles the kernels), wall-clock and
this process's CPU time (steadier on a shared machine), and counts the render's kernel launches.

Usage: python benchmarks/many_lights.py [--lights 10000] [--linked 2000] [--size 32] [--spp 1] [--device cpu]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import warp as wp
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

import wrt
from wrt.image import write_srgb_png
from wrt.light_links import link_groups


def _floor(stage, half: float) -> None:
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])


def _grid(n: int) -> np.ndarray:
    """``(n, 3)`` positions on a square grid 1 unit apart, 1.5 above the floor, centred on the origin."""
    side = int(np.ceil(np.sqrt(n)))
    k = np.arange(n)
    return np.stack([k % side - side / 2, k // side - side / 2, np.full(n, 1.5)], axis=1).astype(np.float64)


def write_instanced(path: Path, n: int, texture: Path) -> None:
    """A PointInstancer of ``n`` lamps: each lamp a SphereLight and a RectLight textured by ``texture``."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    _floor(stage, float(np.sqrt(n)))
    lamp = UsdGeom.Xform.Define(stage, "/Lamps/Protos/Lamp")
    bulb = UsdLux.SphereLight.Define(stage, "/Lamps/Protos/Lamp/Bulb")
    bulb.CreateRadiusAttr(0.05)
    bulb.CreateIntensityAttr(20.0)
    panel = UsdLux.RectLight.Define(stage, "/Lamps/Protos/Lamp/Panel")
    panel.CreateWidthAttr(0.3)
    panel.CreateHeightAttr(0.2)
    panel.CreateIntensityAttr(5.0)
    panel.CreateTextureFileAttr(Sdf.AssetPath(texture.name))
    UsdGeom.Xformable(panel).AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 0.2))
    pi = UsdGeom.PointInstancer.Define(stage, "/Lamps")
    pi.CreatePrototypesRel().SetTargets([lamp.GetPath()])
    pi.CreateProtoIndicesAttr(np.zeros(n, np.int32))
    pi.CreatePositionsAttr(_grid(n))
    stage.GetRootLayer().Save()


def write_plain(path: Path, n: int) -> None:
    """``n`` SphereLights authored one by one, on the same grid."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    _floor(stage, float(np.sqrt(n)))
    for k, p in enumerate(_grid(n)):
        light = UsdLux.SphereLight.Define(stage, f"/Lights/L{k}")
        light.CreateRadiusAttr(0.05)
        light.CreateIntensityAttr(20.0)
        UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(*p))
    stage.GetRootLayer().Save()


def write_linked(path: Path, n: int, meshes: int) -> None:
    """``meshes`` one-quad meshes in groups of 100 and ``n`` SphereLights each carrying a light-link collection: a
    third include two groups and exclude a mesh, a third link by a membership expression (a group less one mesh),
    a third shadow-link by an expression of the meshes of one group (``{isa:Mesh}``)."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    _floor(stage, float(np.sqrt(meshes)))
    groups = max(1, meshes // 100)
    for k, p in enumerate(_grid(meshes)):
        quad = UsdGeom.Mesh.Define(stage, f"/Geo/G{k % groups}/M{k}")
        quad.CreatePointsAttr([(-0.3, -0.3, 0), (0.3, -0.3, 0), (0.3, 0.3, 0), (-0.3, 0.3, 0)])
        quad.CreateFaceVertexCountsAttr([4])
        quad.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        UsdGeom.Xformable(quad).AddTranslateOp().Set(Gf.Vec3d(p[0], p[1], 0.5))
    for k, p in enumerate(_grid(n)):
        light = UsdLux.SphereLight.Define(stage, f"/Lights/L{k}")
        light.CreateRadiusAttr(0.05)
        light.CreateIntensityAttr(20.0)
        UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(p[0], p[1], 3.0))
        api = UsdLux.LightAPI(light)
        g, m = k % groups, (7 * k) % meshes
        if k % 3 == 0:
            link = api.GetLightLinkCollectionAPI()
            link.CreateIncludesRel().SetTargets([Sdf.Path(f"/Geo/G{g}"), Sdf.Path(f"/Geo/G{(g + 1) % groups}")])
            link.CreateExcludesRel().SetTargets([Sdf.Path(f"/Geo/G{m % groups}/M{m}")])
        elif k % 3 == 1:
            link = api.GetLightLinkCollectionAPI()
            link.CreateIncludeRootAttr(False)
            link.CreateMembershipExpressionAttr(Sdf.PathExpression(f"/Geo/G{g}/* - /Geo/G{m % groups}/M{m}"))
        else:
            link = api.GetShadowLinkCollectionAPI()
            link.CreateIncludeRootAttr(False)
            link.CreateMembershipExpressionAttr(Sdf.PathExpression(f"/Geo/G{g}//{{isa:Mesh}}"))
    stage.GetRootLayer().Save()


def timed(fn):
    """``(wall seconds, CPU seconds of this process, fn())``."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - wall, time.process_time() - cpu, out


class LaunchCounter:
    """Counts ``wp.launch`` calls while active."""

    def __init__(self):
        self.count, self.launch = 0, wp.launch

    def __enter__(self):
        def counted(*args, **kwargs):
            self.count += 1
            return self.launch(*args, **kwargs)

        wp.launch = counted
        return self

    def __exit__(self, *exc):
        wp.launch = self.launch


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--lights", type=int, default=10000, help="lamps (instances, or plain SphereLights)")
    parser.add_argument("--linked", type=int, default=2000, help="linked lights, and meshes they link")
    parser.add_argument("--size", type=int, default=32, help="image width and height")
    parser.add_argument("--spp", type=int, default=1, help="samples per pixel")
    parser.add_argument("--device", default=None, help="Override the default Warp device")
    parser.add_argument("--skip-render", action="store_true", help="time the loads only")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder, wp.ScopedDevice(args.device):
        folder = Path(folder)
        texture = folder / "glow.png"
        rng = np.random.default_rng(123)
        write_srgb_png(texture, rng.integers(50, 256, (16, 16, 3)).astype(np.uint8))
        write_instanced(folder / "instanced.usda", args.lights, texture)
        write_plain(folder / "plain.usdc", args.lights)
        write_linked(folder / "linked.usdc", args.linked, args.linked)
        for name in ("instanced.usda", "plain.usdc", "linked.usdc"):
            wall, cpu, scene = timed(lambda: wrt.load_usd(folder / name))
            n = len(scene.lights)
            print(f"{name}: load {wall:.2f} s wall, {cpu:.2f} s CPU for {n} lights "
                  f"({1e3 * cpu / n:.3f} ms CPU a light)")
            if name == "linked.usdc":
                wall, cpu, _ = timed(lambda: link_groups(scene, scene.lights))
                print(f"{name}: link groups {wall:.2f} s wall, {cpu:.2f} s CPU")
            if args.skip_render:
                continue
            camera = wrt.Camera.look_at((0.0, -3.0, 6.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), fov_y_deg=60.0)
            renderer = wrt.Renderer(scene, camera=camera, width=args.size, height=args.size)
            renderer.render(spp=1)  # compiles the kernels
            wp.synchronize_device()
            with LaunchCounter() as launches:
                wall, cpu, _ = timed(lambda: (renderer.render(spp=args.spp), wp.synchronize_device()))
            print(f"{name}: whitted render {args.size}x{args.size} {args.spp} spp: {wall:.2f} s wall, {cpu:.2f} s CPU, "
                  f"{launches.count} launches")

if __name__ == "__main__":
    main()
