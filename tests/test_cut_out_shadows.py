"""Shadow rays pass through the holes of cut-out materials (``opacity < opacityThreshold``): a leaf quad with an
alpha mask shadows only where its mask is opaque, in every integrator and with both accelerators."""

import numpy as np
import pytest
import warp as wp
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade
from shading_helpers import quad, top_down_camera
from test_materials import add_quad, bind, new_stage, preview_material, textured_stage, write_png

import wrt
from wrt.hidden_hits import CullScratch, occluded_through_holes
from wrt.primitives import Shape
from wrt.shade import MAX_CULL_PASSES, MAX_SHADOW_HOLE_PASSES

SUN = wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 2.0))  # straight down
HOLE = wrt.Material("/Looks/Hole", opacity=0.0, opacity_threshold=0.5)  # a hole everywhere
SOLID = wrt.Material("/Looks/Solid", opacity=1.0, opacity_threshold=0.5)  # the same cut-out, opaque everywhere
FLOOR = quad((0, 0, 0), (20, 0, 0), (0, 20, 0), name="/floor")  # the z = 0 plane, grey, facing +Z


def render(scene, integrator, accel="wrt", camera=None, **options):
    """Radiance ``(H, W, 3)`` of 8 x 8 pixels, 4 samples, seen by ``camera`` (default: the floor patch around the
    origin); every pixel must see a surface."""
    camera = camera or top_down_camera(height=0.5)
    options.setdefault("max_depth", 1 if integrator == "path" else None)
    img = wrt.render(scene, camera=camera, width=8, height=8, spp=4, seed=3, device="cpu", accel=accel,
                     integrator=integrator, **options)
    assert (img.aovs["prim"] >= 0).all()
    return img.rgb


@pytest.mark.parametrize("accel", ["wrt", "warp"])
@pytest.mark.parametrize("integrator", ["whitted", "path", "ao"])
def test_a_cut_out_quad_of_holes_casts_no_shadow(integrator, accel):
    """The floor under a quad that is all hole is lit exactly as without the quad; before, shadow rays stopped at
    the quad (whitted and path rendered 0 under it, ao 0.75 instead of 1)."""
    leaf = quad((0, 0, 1), (2, 0, 0), (0, 2, 0), name="/leaf", material=0)  # camera rays pass its holes
    options = {"ao_radius": 4.0} if integrator == "ao" else {}
    lights = [] if integrator == "ao" else [SUN]
    bare = render(wrt.Scene(meshes=[FLOOR], lights=lights), integrator, accel, **options)
    assert bare.min() > 0.1
    with_holes = render(wrt.Scene(meshes=[FLOOR, leaf], lights=lights, materials=[HOLE]), integrator, accel,
                        **options)
    np.testing.assert_allclose(with_holes, bare, rtol=1e-5)
    if integrator != "ao":  # the same quad made opaque still shadows (camera rays would stop on it in ao)
        solid = wrt.Scene(meshes=[FLOOR, leaf], lights=lights, materials=[SOLID])
        camera = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
        np.testing.assert_array_equal(render(solid, integrator, accel, camera=camera), 0.0)


def test_launch_frame_passes_holes_with_a_fixed_pass_count():
    """The frame a CUDA graph records (no host reads) passes shadow rays through holes too."""
    leaf = quad((0, 0, 1), (2, 0, 0), (0, 2, 0), name="/leaf", material=0)
    scene = wrt.Scene(meshes=[FLOOR, leaf], lights=[SUN], materials=[HOLE])
    renderer = wrt.Renderer(scene, camera=top_down_camera(height=0.5), width=4, height=4, device="cpu")
    renderer.launch_frame()
    np.testing.assert_allclose(renderer.frame_image().rgb, 0.5 * 2.0 / np.pi, rtol=1e-5)  # albedo * E / pi


def oblique_stage(tmp_path, png):
    """The textured quad of ``textured_stage`` (z = 0, x and s over [-1, 1] and [0, 1]) as a cut-out by its alpha
    over a floor at z = -1, as a scene lit by a sun travelling +X and down by (2, 0, -1): the quad's shadow falls on
    x in [1, 3], where the camera sees the floor (``x - 2`` is the quad point each floor point looks at)."""
    path = textured_stage(tmp_path, png, wrap="clamp", channel="a", input_name="opacity")
    stage = Usd.Stage.Open(path)
    UsdGeom.Mesh(stage.GetPrimAtPath("/Quad")).CreateDoubleSidedAttr(True)
    shader = UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/Surface"))
    shader.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    add_quad(stage, "/Floor", center=(0, 0, -1), size=10.0)
    stage.Save()
    scene = wrt.load_usd(path)
    scene.lights = [wrt.DistantLight(direction=np.array([2.0, 0.0, -1.0]), color=np.full(3, 2.0))]
    return scene


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_textured_alpha_mask_shadows_only_where_it_is_opaque(tmp_path, integrator):
    """Holes in the left half of the quad (s < 0.5): its shadow on the floor covers only the right half's."""
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 3] = [[0, 255], [0, 255]]  # alpha 0 left, 1 right; bilinear: below the threshold where s < 0.5
    scene = oblique_stage(tmp_path, write_png(tmp_path / "mask.png", rgba))
    camera = wrt.Camera.orthographic(eye=(2, 0, 5), target=(2, 0, -1), up=(0, 1, 0), height=2.0)  # x in [1, 3]
    rgb = render(scene, integrator, camera=camera)
    lit = 0.5 * 2.0 / np.sqrt(5.0) / np.pi  # albedo * E cos / pi, cos = 1 / sqrt(5)
    np.testing.assert_allclose(rgb[:, :4], lit, rtol=1e-4)  # floor x in [1, 2]: under the holes
    np.testing.assert_array_equal(rgb[:, 4:], 0.0)  # floor x in [2, 3]: under the opaque half


def layered_scene(layers: int) -> wrt.Scene:
    """The floor, the sun coming down at 45 degrees from -X, and ``layers`` all-hole quads stacked 0.1 apart over
    x in [-9.5, -0.5] at heights 1 to 4: every shadow ray from the floor patch at the origin crosses all of them,
    and no camera ray (straight down onto the patch) crosses any."""
    leaves = [quad((-5, 0, 1 + 0.1 * k), (9, 0, 0), (0, 4, 0), name=f"/leaf{k}", material=0) for k in range(layers)]
    sun = wrt.DistantLight(direction=np.array([1.0, 0.0, -1.0]), color=np.full(3, 2.0))
    return wrt.Scene(meshes=[FLOOR, *leaves], lights=[sun], materials=[HOLE])


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_shadow_rays_pass_a_stack_of_holes_up_to_the_documented_limit(accel):
    """A canopy stacks many leaves: shadow rays pass up to ``MAX_SHADOW_HOLE_PASSES - 1`` holes (as many as camera
    and bounce rays, ``MAX_CULL_PASSES``); one in a hole after the last pass stays blocked, as documented."""
    assert MAX_CULL_PASSES == MAX_SHADOW_HOLE_PASSES - 1
    lit = 0.5 * 2.0 / np.sqrt(2.0) / np.pi
    for integrator in ("whitted", "path"):
        rgb = render(layered_scene(MAX_SHADOW_HOLE_PASSES - 1), integrator, accel)
        np.testing.assert_allclose(rgb, lit, rtol=1e-4)
    np.testing.assert_array_equal(render(layered_scene(MAX_SHADOW_HOLE_PASSES), "whitted", accel), 0.0)


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_a_fixed_pass_count_decides_one_hole_fewer(accel):
    """``passes=k`` (a CUDA-graph frame: no host reads) runs exactly ``k`` closest-hit passes: a ray through three
    holes is decided (unblocked) by the fourth; ``None`` stops by itself."""
    renderer = wrt.Renderer(layered_scene(3), width=1, height=1, device="cpu", accel=accel)
    device = renderer.device  # (cuda:0 under -p render_on_cuda, which CPU arrays here made an illegal memory access)
    rays = [wp.array([[0.0, 0.0, 1e-4]], dtype=wp.vec3, device=device),
            wp.array([[-1.0, 0.0, 1.0]], dtype=wp.vec3, device=device),
            wp.zeros(1, dtype=float, device=device), wp.full(1, np.inf, dtype=float, device=device)]
    for passes, blocked in ((0, 1), (3, 1), (4, 0), (None, 0)):
        out = wp.zeros(1, dtype=wp.int32, device=device)
        scratch = CullScratch(1, device, nothing_to_cull=False, no_holes=False)
        occluded_through_holes(renderer.accel, renderer.surfaces, renderer.materials, rays, out, scratch, passes)
        assert out.numpy()[0] == blocked, passes


def test_a_recorded_frame_passes_holes():
    """A frame recorded as a CUDA graph (launch_frame: every shadow pass launched, nothing read back) and replayed
    lights the floor through the most holes a shadow ray passes."""
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    renderer = wrt.Renderer(layered_scene(MAX_SHADOW_HOLE_PASSES - 1), camera=top_down_camera(height=0.5), width=8,
                            height=8, device="cuda:0")
    renderer.launch_frame()  # allocates the buffers before the capture
    with wp.ScopedCapture(device="cuda:0") as capture:
        renderer.launch_frame()
    wp.capture_launch(capture.graph)
    np.testing.assert_allclose(renderer.frame_image().rgb, 0.5 * 2.0 / np.sqrt(2.0) / np.pi, rtol=1e-4)


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_instanced_cut_outs_pass_shadow_rays(tmp_path, accel):
    """Point-instanced leaf quads (material looked up through the prototype triangle) cast no shadow where they are
    holes; the same instancer with an opaque material does."""
    results = {}
    for opacity in (0.0, 1.0):
        stage, path = new_stage(tmp_path, f"instanced{opacity}.usda")
        add_quad(stage, "/Floor", center=(0, 0, 0), size=20.0)
        instancer = UsdGeom.PointInstancer.Define(stage, "/Leaves")
        leaf = add_quad(stage, "/Leaves/Proto/Leaf", size=2.0, double_sided=True)
        material, _ = preview_material(stage, "/Looks/Leaf", opacity=opacity, opacityThreshold=0.5)
        bind(leaf, material)
        instancer.CreatePrototypesRel().SetTargets([Sdf.Path("/Leaves/Proto")])
        instancer.CreateProtoIndicesAttr([0, 0])
        # Two leaves, each crossed by every shadow ray from the floor patch at x in [0.25, 0.75].
        instancer.CreatePositionsAttr([Gf.Vec3f(-1, 0, 1), Gf.Vec3f(-1.5, 0, 1.5)])
        stage.Save()
        scene = wrt.load_usd(path)
        assert len(scene.instances) == 2
        scene.lights = [wrt.DistantLight(direction=np.array([1.0, 0.0, -1.0]), color=np.full(3, 2.0))]
        results[opacity] = render(scene, "whitted", accel, camera=top_down_camera(center=(0.5, 0, 0), height=0.5))
    np.testing.assert_allclose(results[0.0], 0.5 * 2.0 / np.sqrt(2.0) / np.pi, rtol=1e-4)
    np.testing.assert_array_equal(results[1.0], 0.0)


def test_analytic_cut_out_shapes_pass_shadow_rays():
    """A cut-out sphere gprim over the floor: its holes let the sun through, in the path tracer too."""
    to_world = np.diag([0.5, 0.5, 0.5, 1.0])
    to_world[:3, 3] = (0, 0, 2)
    ball = Shape("/ball", "sphere", to_world, material_id=0)
    for material, expected in ((HOLE, 0.5 * 2.0 / np.pi), (SOLID, 0.0)):
        scene = wrt.Scene(meshes=[FLOOR], shapes=[ball], lights=[SUN], materials=[material])
        for integrator in ("whitted", "path"):
            camera = wrt.Camera.orthographic(eye=(0, 0, 1), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
            np.testing.assert_allclose(render(scene, integrator, camera=camera), expected, rtol=1e-5, atol=0)


def test_glass_still_blocks_shadow_rays():
    """Glass (opacity < 1 without a threshold) is not a hole: light reaches the floor only through refraction,
    which next-event estimation cannot sample."""
    glass = wrt.Material("/Looks/Glass", opacity=0.0)
    pane = quad((0, 0, 1), (2, 0, 0), (0, 2, 0), name="/pane", material=0)
    scene = wrt.Scene(meshes=[FLOOR, pane], lights=[SUN], materials=[glass])
    camera = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    np.testing.assert_array_equal(render(scene, "whitted", camera=camera), 0.0)


def test_path_tracing_weights_lights_seen_through_holes_from_the_scattering_point():
    """Under a sphere light behind an all-hole quad, the path tracer's floor is exactly the floor without the quad
    (hole passes draw no random numbers). BSDF rays through the hole went on from the hole's point, so the light's
    pdf in their MIS weight was measured from there, not from the floor as next-event estimation measures it: 28%
    too bright (before shadow rays passed holes: 70% too dark)."""
    light = wrt.SphereLight(position=np.array([0.0, 0.0, 2.0]), radius=0.8, color=np.full(3, 1.0))
    leaf = quad((0, 0, 1), (4, 0, 0), (0, 4, 0), name="/leaf", material=0)
    camera = wrt.Camera.orthographic(eye=(0, 0, 0.5), target=(0, 0, 0), up=(0, 1, 0), height=0.5)
    bare, with_holes = (render(wrt.Scene(meshes=meshes, lights=[light], materials=[HOLE]), "path", camera=camera,
                               max_depth=3) for meshes in ([FLOOR], [FLOOR, leaf]))
    assert bare.min() > 0.01
    np.testing.assert_allclose(with_holes, bare, rtol=1e-5)
