"""Renders the same small scenes on two devices and prints how far apart the images are:

- the cut-out canopy (camera, bounce and shadow rays through holes);
- PointInstancer displayColors (mesh and gprim prototypes);
- gold spheres at three roughnesses (the multiple-scattering lobe);
- spotlights (ShapingAPI cone, softness, focus);
- a normal-mapped quad under a sun and at a grazing view;
- a UDIM-textured plane (three tiles and a missing one);
- tapered Cylinder_1 and Capsule_1 gprims (hits of rays from every side, and images);
- quads coloured by a primvar (one without it: the reader's fallback) and by a MaterialX primvar times a constant;
- Points (spheres) beside varying-width bspline curves (tubes, frustums and joint spheres);
- a textured RectLight, a mirror-ball dome and lights with diffuse and specular multipliers over grey and metal
  spheres;
- light and shadow linking (a floor, a box and a blocker under linked suns, a sphere light and a dome; native
  instances linked part by part);
- a quad whose displayOpacity goes from 0 to 1 across it in front of a glowing wall, and a PointInstancer whose two
  instances have their own displayOpacity (0.25, 0.75);
- a mesh light (MeshLightAPI) over a floor, points and curves under a sheared native instance, and a two-sided
  leaf (a front face and its reversed twin, a material each) seen from both sides;
- ellipsoidal SphereLights and elliptic or oblique CylinderLights over a plane (``wrt.affine_lights``), seen by the
  camera and lighting the plane.

wrt's shade kernels round alike on every device (no FMA contraction), so on a CUDA host the CPU and GPU images are
expected to be equal, but for the last bits of transcendental functions (the spotlights' acos and pow).

Usage: python benchmarks/gpu_feature_parity.py [--width 96] [--devices cpu,cuda:0]
"""

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

import wrt
from wrt.light_links import LinkCollection
from wrt.procedural import displaced_sphere_scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from cut_out_canopy import write_canopy  # noqa: E402
from shading_helpers import quad, top_down_camera  # noqa: E402
from test_affine_lights import lights_and_oracles  # noqa: E402
from test_display_opacity import CAMERA as OPACITY_CAMERA  # noqa: E402
from test_display_opacity import instancer as opacity_instancer  # noqa: E402
from test_display_opacity import opacity_primvar  # noqa: E402
from test_display_opacity import quad as opacity_quad  # noqa: E402
from test_display_opacity import stage_with as opacity_stage  # noqa: E402
from test_instance_colors import CAMERA, HEIGHT, WIDTH, instancer_stage  # noqa: E402
from test_light_linking import SLANT, quad_usda, sun_usda, z_up  # noqa: E402
from test_light_textures import cap_texture, dome_from_usd, textured_rect_light  # noqa: E402
from test_materials import bind, new_stage  # noqa: E402
from test_mesh_lights import PATCH as MESH_LIGHT_PATCH  # noqa: E402
from test_mesh_lights import floor as mesh_light_floor  # noqa: E402
from test_mesh_lights import glowing_material, mesh_light  # noqa: E402
from test_normal_map import normal_mapped_stage, write_normal_map  # noqa: E402
from test_primvar_colors import (  # noqa: E402
    C3,
    F,
    add_temperature,
    geomprop,
    mtlx_base_color_material,
    mtlx_node,
    preview_reader_material,
    two_quads,
)
from test_tapered_gprims import rays_towards, write_stage  # noqa: E402
from test_tubes_under_instances import TRANSFORMS, native_stage  # noqa: E402
from test_twins import leaf as two_sided_leaf  # noqa: E402
from test_twins import two_materials  # noqa: E402
from test_udim import BLUE, GREEN, RED, udim_stage, write_tile  # noqa: E402
from usda_text import floats, fmt, write  # noqa: E402


def compare(name: str, scene, devices: list[str], **kwargs) -> None:
    a, b = (wrt.render(scene, device=device, **kwargs) for device in devices)
    diff = np.abs(a.rgb - b.rgb)
    same_prim = float((a.aovs["prim"] == b.aovs["prim"]).mean())
    albedo = float(np.abs(a.aovs["albedo"] - b.aovs["albedo"]).max())
    coverage = float(np.abs(a.aovs["coverage"] - b.aovs["coverage"]).max())
    print(f"{name}: mean {devices[0]} {a.rgb.mean():.5f} {devices[1]} {b.rgb.mean():.5f}; max |diff| {diff.max():.3g}, "
          f"mean {diff.mean():.3g}; prim equal {same_prim:.4f}; albedo max diff {albedo:.3g}; "
          f"coverage max diff {coverage:.3g}")


def main() -> None:
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--width", type=int, default=96, help="width of the canopy images")
    parser.add_argument("--devices", default="cpu,cuda:0", help="the two devices to compare")
    parser.add_argument("--out", type=Path, default=Path("/tmp"), help="folder for the generated stages")
    args = parser.parse_args()
    devices = args.devices.split(",")
    warnings.simplefilter("ignore")

    canopy_path = args.out / "parity_canopy.usda"
    write_canopy(canopy_path, 3000, 12, 0)
    canopy = wrt.load_usd(canopy_path)
    for integrator in ("whitted", "path", "ao"):
        compare(f"canopy {integrator}", canopy, devices, width=args.width, height=64, integrator=integrator, spp=4,
                max_depth=3)
    for gprim in (False, True):
        scene = wrt.load_usd(instancer_stage(args.out / f"parity_instancer_{gprim}.usda", gprim=gprim))
        compare(f"instancer colours gprim={gprim}", scene, devices, camera=CAMERA, width=WIDTH, height=HEIGHT,
                integrator="path", spp=4)
    for roughness in (0.05, 0.5, 1.0):
        scene = displaced_sphere_scene(20000)
        scene.materials = [wrt.Material(diffuse_color=(1.0, 0.78, 0.34), metallic=1.0, roughness=roughness)]
        for mesh in scene.meshes:
            mesh.material_ids = np.zeros(len(mesh.indices), np.int32)
        compare(f"gold sphere roughness {roughness}", scene, devices, width=64, height=64, integrator="path", spp=8,
                max_depth=4)
    spots = [
        wrt.SphereLight(position=(-0.6, 0, 1), radius=0.05, color=(300, 300, 300), path="/Cone",
                        shaping=wrt.Shaping(cone_angle=30.0, cone_softness=0.3)),
        wrt.SphereLight(position=(0.6, 0, 1), radius=0.05, color=(300, 200, 100), path="/Focus",
                        shaping=wrt.Shaping(cone_angle=60.0, focus=4.0, focus_tint=np.float32([0.1, 0.2, 0.3]))),
    ]
    plane = wrt.Scene(meshes=[quad((0, 0, 0), (8, 0, 0), (0, 8, 0), name="/plane")], lights=spots)
    for integrator in ("whitted", "path"):
        compare(f"spotlights {integrator}", plane, devices, camera=top_down_camera(height=3.0), width=48, height=48,
                integrator=integrator, spp=8, max_depth=2)
    tilt = np.float32([np.sin(0.5), 0.0, np.cos(0.5)])
    bumpy = wrt.load_usd(normal_mapped_stage(args.out, write_normal_map(args.out / "parity_tilt.png", tilt)))
    bumpy.lights = [wrt.DistantLight(direction=(0.3, -0.2, -1.0), color=(2, 2, 2), path="/Sun")]
    for eye in ((0, 0, 5), (0, -5, 0.3)):
        for integrator in ("whitted", "path"):
            cam = wrt.Camera.look_at(eye, (0, 0, 0), (0, 1, 0) if eye[2] > 1 else (0, 0, 1), 40.0)
            compare(f"normal map {integrator} eye {eye}", bumpy, devices, camera=cam, width=48, height=48,
                    integrator=integrator, spp=8, max_depth=3)
    for tile, color in ((1001, RED), (1002, GREEN), (1011, BLUE)):  # 1012 missing: the fallback
        write_tile(args.out / "parity_udim", tile, color, size=8, columns={0: (255, 255, 255)})
    udim = wrt.load_usd(udim_stage(args.out / "parity_udim.usda", "parity_udim/body.<UDIM>.png"))
    cam = wrt.Camera.orthographic(eye=(1, 1, 5), target=(1, 1, 0), height=2.2)
    compare("udim tiles", udim, devices, camera=cam, width=48, height=48, integrator="path", spp=4)
    for type_name in ("Cylinder_1", "Capsule_1"):
        path = write_stage(args.out / f"parity_{type_name}.usda", type_name, 1.5, 0.9, 0.4, axis="Y")
        scene = wrt.load_usd(path)
        origins, directions = rays_towards(path)
        a, b = (wrt.trace(scene, origins, directions, device=device) for device in devices)
        print(f"{type_name} trace: prim equal {float((a.prim == b.prim).mean()):.4f}, t max |diff| "
              f"{float(np.nanmax(np.abs(np.where(a.prim >= 0, a.t - b.t, 0.0)))):.3g}")
        cam = wrt.Camera.look_at((1, 3, 9), (1, -2, 3), (0, 1, 0), 40.0)
        compare(f"{type_name} path", scene, devices, camera=cam, width=48, height=48, integrator="path", spp=4)

    stage, path = new_stage(args.out, "parity_primvar.usda")
    heated, bare = two_quads(stage, "/Heated", x=-1.0), two_quads(stage, "/Bare", x=1.0)
    scaled = two_quads(stage, "/Scaled")
    for mesh in (heated, scaled):
        add_temperature(mesh, "vertex")
    scaled.AddTranslateOp().Set((0.0, 2.0, 0.0))
    reader = preview_reader_material(stage, "/Looks/Heat", fallback=(0.25, 0.5, 0.75))
    bind(heated, reader)
    bind(bare, reader)

    def half_of_primvar(stage, graph):
        return mtlx_node(stage, f"{graph}/Half", "ND_multiply_color3FA", in1=(C3, geomprop()(stage, graph)),
                         in2=(F, 0.5))
    bind(scaled, mtlx_base_color_material(stage, "/Looks/Half", half_of_primvar))
    stage.Save()
    cam = wrt.Camera.look_at((0, -3, 6), (0, 0.5, 0), (0, 1, 0), 50.0)
    for integrator in ("whitted", "path"):
        compare(f"primvar colours {integrator}", wrt.load_usd(path), devices, camera=cam, width=48, height=48,
                integrator=integrator, spp=4)

    points_and_curves(args.out / "parity_points_curves.usda", devices)
    textured_and_split_lights(args.out, devices)
    linked_lights(args.out, devices)
    mesh_lights_and_round_instances(args.out, devices)
    affine_lights(devices)
    see_through, _ = opacity_stage(args.out, lambda stage: opacity_quad(stage, opacity=[0.0, 1.0, 0.0, 1.0],
                                                                        interpolation="vertex"))
    instanced, _ = opacity_stage(args.out, lambda stage: opacity_primvar(opacity_instancer(stage), [0.25, 0.75],
                                                                         "vertex"), "parity_opacity_instances.usda")
    for integrator in ("whitted", "path"):
        for name, scene in (("displayOpacity", see_through), ("instance displayOpacity", instanced)):
            compare(f"{name} {integrator}", scene, devices, camera=OPACITY_CAMERA, width=32, height=32,
                    integrator=integrator, spp=8, max_depth=3)


def points_and_curves(path: Path, devices: list[str]) -> None:
    """Points of random widths and colours beside bspline curves of varying widths: every hit is an instance of an
    analytic sphere, cylinder or cone frustum in the TLAS."""
    rng = np.random.default_rng(7)
    n = 400
    centres, widths, colors = rng.uniform(-3, 3, (n, 3)), rng.uniform(0.05, 0.3, n), rng.uniform(0.1, 0.9, (n, 3))
    walk = np.cumsum(rng.normal(0, 0.4, (8 * 12, 3)), axis=0).reshape(8, 12, 3) - [0, 0, 1]
    path.write_text(
        f'#usda 1.0\n(\n    upAxis = "Y"\n)\ndef Points "P"\n{{\n    point3f[] points = {fmt(centres)}\n'
        f'    float[] widths = {floats(widths)} (interpolation = "vertex")\n'
        f'    color3f[] primvars:displayColor = {fmt(colors)} (interpolation = "vertex")\n}}\n'
        f'def BasisCurves "C"\n{{\n    uniform token type = "cubic"\n    uniform token basis = "bspline"\n'
        f'    int[] curveVertexCounts = {[12] * 8}\n    point3f[] points = {fmt(walk.reshape(-1, 3))}\n'
        f'    float[] widths = {floats(np.linspace(0.3, 0.05, walk.size // 3))} (interpolation = "vertex")\n}}\n')
    scene = wrt.load_usd(path)
    origins = np.column_stack([rng.uniform(-4, 4, (20000, 2)), np.full(20000, 9.0)]).astype(np.float32)
    directions = (rng.uniform(-3, 3, (20000, 3)) - origins).astype(np.float32)
    a, b = (wrt.trace(scene, origins, directions, device=device) for device in devices)
    print(f"points and curves trace: hit {float((a.prim >= 0).mean()):.3f}, prim equal "
          f"{float((a.prim == b.prim).mean()):.4f}, instance equal {float((a.instance == b.instance).mean()):.4f}, "
          f"t max |diff| {float(np.nanmax(np.abs(np.where(a.prim >= 0, a.t - b.t, 0.0)))):.3g}")
    cam = wrt.Camera.look_at((0, 2, 10), (0, 0, 0), (0, 1, 0), 45.0)
    for integrator in ("whitted", "path"):
        compare(f"points and curves {integrator}", scene, devices, camera=cam, width=64, height=64,
                integrator=integrator, spp=4)


def textured_and_split_lights(folder: Path, devices: list[str]) -> None:
    """A RectLight textured in four colours (diffuse 0.5), a sphere light seen only through specular lobes (diffuse
    0, specular 0.25) and a mirror-ball dome over a floor with a grey and a rough metal sphere."""
    rect = textured_rect_light(folder, intensity=4.0)
    rect.diffuse = 0.5
    dome = dome_from_usd(folder, cap_texture(folder, "mirroredBall", (0.3, 0.4, 1.0)), "mirroredBall")
    spot = wrt.SphereLight(position=(1.5, -1.0, 2.0), radius=0.2, color=(40, 40, 40), path="/Spec", diffuse=0.0,
                           specular=0.25)
    spheres = displaced_sphere_scene(4000)
    metal = wrt.Material(diffuse_color=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.3)
    meshes = [quad((0, 0, -1), (8, 0, 0), (0, 8, 0), name="/floor")]
    for k, mesh in enumerate(spheres.meshes):
        for x, material in ((-0.7, None), (0.7, 0)):
            meshes.append(wrt.Mesh(points=mesh.points * 0.5 + np.float32([x, 0, -0.3]), indices=mesh.indices,
                                   face_ids=mesh.face_ids, path=f"/ball{k}_{x}",
                                   material_ids=None if material is None else np.zeros(len(mesh.indices), np.int32)))
    scene = wrt.Scene(meshes=meshes, lights=[rect, dome, spot], materials=[metal])
    cam = wrt.Camera.look_at((0, -4, 2.5), (0, 0, -0.5), (0, 0, 1), 45.0)
    for integrator in ("whitted", "path"):
        compare(f"textured and split lights {integrator}", scene, devices, camera=cam, width=48, height=48,
                integrator=integrator, spp=8, max_depth=3)


def linked_lights(folder: Path, devices: list[str]) -> None:
    """Light and shadow linking: a red sun whose shadows skip the blocker, a green sun that does not light the box,
    a sphere light that lights only the box and a dome that does not light the floor; then native and
    instances linked part by part."""
    floor = quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/World/Ground/Floor")
    box = quad((1.5, 0, 0.5), (2.5, 0, 0), (0, 5, 0), name="/World/Box")
    blocker = quad((-2, 0, 1), (2, 0, 0), (0, 4, 0), name="/Blocker")
    lights = [
        wrt.DistantLight(direction=SLANT, color=np.array([2.0, 0, 0]),
                         shadow_link=LinkCollection.excluding("/Blocker")),
        wrt.DistantLight(direction=(0.2, 0.1, -1.0), color=np.array([0, 2.0, 0]),
                         light_link=LinkCollection.excluding("/World/Box")),
        wrt.SphereLight(position=(2, 0, 2), radius=0.2, color=(0, 0, 30), path="/Blue",
                        light_link=LinkCollection.only("/World/Box")),
        wrt.DomeLight(color=np.array([0.2, 0.2, 0.2]), light_link=LinkCollection.excluding("/World/Ground")),
    ]
    scene = wrt.Scene(meshes=[floor, box, blocker], lights=lights)
    cam = wrt.Camera.look_at((0, -6, 4), (0, 0, 0), (0, 0, 1), 50.0)
    for integrator in ("whitted", "path"):
        compare(f"linked lights {integrator}", scene, devices, camera=cam, width=48, height=48,
                integrator=integrator, spp=8, max_depth=3)
    proto = ('def Xform "Proto"\n{\n    def Xform "geo"\n    {\n' + quad_usda("Left", -0.25, half=0.2, indent=" " * 8)
             + quad_usda("Right", 0.25, half=0.2, indent=" " * 8) + "    }\n}\n")
    instances = "".join(
        f'    def "I{k}" (\n        instanceable = true\n        prepend references = </Proto>\n    )\n    {{\n'
        f'        double3 xformOp:translate = ({x}, 0, 0)\n        uniform token[] xformOpOrder = ["xformOp:translate"]'
        f'\n    }}\n' for k, x in enumerate([-1.0, 0.0, 1.0]))
    red = sun_usda("Red", (1, 0, 0), "rel collection:lightLink:excludes = [</World/I0>, </World/I1/geo/Right>]")
    path = z_up(folder, proto + 'def Xform "World"\n{\n' + instances + "}\n" + red + sun_usda("Green", (0, 1, 0)))
    cam = wrt.Camera.orthographic(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), height=1.0)
    for integrator in ("whitted", "path"):
        compare(f"linked instance parts {integrator}", wrt.load_usd(path), devices, camera=cam, width=64, height=16,
                integrator=integrator, spp=4)


def mesh_lights_and_round_instances(folder: Path, devices: list[str]) -> None:
    """A MeshLightAPI square over a floor, bare and tinting a glowing material; points and curves instanced under a
    shear, placed round in the TLAS; a two-sided leaf in both triangle orders, seen from both sides."""
    header = '#usda 1.0\n(\n    upAxis = "Z"\n)\n'
    tinting = mesh_light(material="/Glow", intensity=3.0) + glowing_material((1, 0.5, 0.25))
    for name, prims in (("bare", mesh_light(intensity=3.0)), ("tinting a glow", tinting)):
        path = folder / "parity_mesh_light.usda"
        path.write_text(header + mesh_light_floor() + prims)
        scene = wrt.load_usd(path)
        for integrator in ("whitted", "path"):
            compare(f"mesh light {name} {integrator}", scene, devices,
                    camera=top_down_camera(height=4 * MESH_LIGHT_PATCH), width=32, height=32,
                    integrator=integrator, spp=8, max_depth=2)
    path = write(folder, native_stage(TRANSFORMS["shear"], True), "parity_round_instances.usda")
    cam = wrt.Camera.look_at((0.5, 0.0, 7.0), (0.5, 0.0, 0.0), fov_y_deg=60.0)
    compare("points and curves under a sheared instance", wrt.load_usd(path), devices, camera=cam, width=48,
            height=48, integrator="path", spp=4)
    for order in ("front_first", "back_first"):  # a culled back face takes its coincident front twin
        leaf, _ = two_sided_leaf(order)
        scene = wrt.Scene(meshes=[leaf], materials=two_materials())
        for z in (4.0, -4.0):
            compare(f"two-sided leaf {order} from z {z}", scene, devices,
                    camera=wrt.Camera.look_at((0.1, 0.2, z), (0, 0, 0)), width=16, height=16, integrator="path", spp=4)


def affine_lights(devices: list[str]) -> None:
    """Each light of ``test_affine_lights`` over a plane, seen from above at an angle: the light itself (camera rays
    and MIS) and its light on the plane."""
    floor = quad((0, 0, -1.0), (6, 0, 0), (0, 6, 0), name="/floor")
    cam = wrt.Camera.look_at((1.5, -4.0, 4.0), (0, 0, 0), (0, 0, 1), 50.0)
    for name, (light, _) in lights_and_oracles().items():
        scene = wrt.Scene(meshes=[floor], lights=[light])
        for integrator in ("whitted", "path"):
            compare(f"{name} {integrator}", scene, devices, camera=cam, width=48, height=48, integrator=integrator,
                    spp=8, max_depth=2)


if __name__ == "__main__":
    main()
