"""The path tracer against an independent float64 numpy path tracer (tests/path_reference.py) in small Lambertian
boxes lit by UsdLux lights read from a stage, several bounces deep: a closed box with a rect light whose lightLink
leaves out the floor and whose ``inputs:diffuse`` is 0.7, and a sphere light whose shadowLink leaves out a floating
panel; an open box under a coloured dome, a soft sun and a disk light with a glowing one-sided panel. The images'
mean radiance per channel agrees within 4 standard errors or 1% (here within 0.7%, 1.4 standard errors; each
light type alone, rect, sphere, disk, glowing quad, soft sun and dome, within 0.6%, under 2, at 2048 spp). And an
open box of white materials of every lobe (Lambert, rough metal, glass, clearcoat) under a white sky shows 1
everywhere, however many bounces its paths take; a plane under a delta sun shows the BSDF the README states, written
out in float64, times the cosine."""

import math

import numpy as np
import pytest
from ggx_albedo_oracle import ggx_albedo, smith_lambda
from path_reference import Face, Light, Sky, render
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
from shading_helpers import quad

import wrt
from wrt.lights import DomeLight
from wrt.materials import Material

WIDTH, HEIGHT = 8, 6
FOCAL, APERTURE = 10.0, (16.0, 12.0)  # the camera's film: tan of the half field of view 0.8 across, 0.6 up
EYE = np.array([0.5, 0.08, 0.5])  # inside the unit box, looking along +Y (USD's -Z turned by rotateX 90)
WALLS = {  # origin, u, v (front u x v, facing inwards), albedo
    "Floor": ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0.7, 0.7, 0.7)),
    "Ceiling": ((0, 0, 1), (0, 1, 0), (1, 0, 0), (0.6, 0.6, 0.6)),
    "Back": ((0, 1, 0), (1, 0, 0), (0, 0, 1), (0.5, 0.5, 0.5)),
    "Front": ((0, 0, 0), (0, 0, 1), (1, 0, 0), (0.4, 0.4, 0.4)),
    "Left": ((0, 0, 0), (0, 1, 0), (0, 0, 1), (0.6, 0.15, 0.1)),
    "Right": ((1, 0, 0), (0, 0, 1), (0, 1, 0), (0.1, 0.5, 0.15)),
}
MAX_DEPTH = 6


def add_face(stage, path, origin, u, v, color=None, double_sided=True):
    o, u, v = (np.asarray(a, float) for a in (origin, u, v))
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in (o, o + u, o + u + v, o + v)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.CreateDoubleSidedAttr(double_sided)
    if color is not None:
        mesh.CreateDisplayColorAttr([Gf.Vec3f(*color)])  # the default material: Lambertian of this albedo
    return mesh


def box_stage(path, ceiling):
    """A Z-up stage of the box's walls (without its ceiling when ``ceiling`` is false) and the camera, and the
    reference's faces for them."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    faces = []
    for name, (o, u, v, albedo) in WALLS.items():
        if ceiling or name != "Ceiling":
            add_face(stage, f"/World/{name}", o, u, v, albedo)
            faces.append(Face(o, u, v, albedo))
    cam = UsdGeom.Camera.Define(stage, "/Camera")
    cam.CreateFocalLengthAttr(FOCAL)
    cam.CreateHorizontalApertureAttr(APERTURE[0])
    cam.CreateVerticalApertureAttr(APERTURE[1])
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.001, 100.0))
    ops = UsdGeom.Xformable(cam)
    ops.AddTranslateOp().Set(Gf.Vec3d(*EYE))
    ops.AddRotateXOp().Set(90.0)
    return stage, faces


def camera_directions(per_pixel, rng):
    """Unit directions ``(H, W, per_pixel, 3)`` of rays through points spread uniformly over each pixel."""
    i, j = np.arange(HEIGHT)[:, None, None], np.arange(WIDTH)[None, :, None]
    x = ((j + rng.random((HEIGHT, WIDTH, per_pixel))) / WIDTH - 0.5) * APERTURE[0]
    y = (0.5 - (i + rng.random((HEIGHT, WIDTH, per_pixel))) / HEIGHT) * APERTURE[1]
    d = np.stack([x, np.full_like(x, FOCAL), y], -1)  # camera +X is world +X, its up +Z, its view +Y
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def assert_matches_reference(path, faces, lights, skies, seeds=8, spp=128, per_pixel=800):
    """The image's mean radiance per channel, rendered by ``seeds`` renders of ``spp`` samples, matches the
    reference's of ``per_pixel`` paths per pixel within 4 standard errors (the two estimates' combined) or 1%."""
    scene = wrt.load_usd(str(path))
    got = np.array([wrt.render(scene, width=WIDTH, height=HEIGHT, spp=spp, seed=seed, device="cpu",
                               integrator="path", max_depth=MAX_DEPTH).rgb.mean((0, 1)) for seed in range(seeds)])
    rng = np.random.default_rng(5)
    directions = camera_directions(per_pixel, rng).reshape(-1, 3)
    samples = render(faces, lights, skies, EYE, directions, MAX_DEPTH, rng)
    ref = samples.reshape(HEIGHT * WIDTH, per_pixel, 3).mean(0)  # image means of independent samples of each pixel
    se = np.hypot(got.std(0, ddof=1) / math.sqrt(seeds), ref.std(0, ddof=1) / math.sqrt(per_pixel))
    off = np.abs(got.mean(0) - ref.mean(0))
    assert (off <= np.maximum(4 * se, 0.01 * ref.mean(0))).all(), (got.mean(0), ref.mean(0), se)


def test_a_closed_box_with_linked_lights_matches_the_reference(tmp_path):
    """A rect light under the ceiling lights every wall but the floor (its lightLink excludes it; the floor still
    reflects what the walls send it), at 0.7 of its radiance through its diffuse multiplier; a sphere light's shadow
    rays pass the floating panel its shadowLink leaves out, which still scatters the rays that bounce off it and
    blocks the rect light."""
    stage, faces = box_stage(tmp_path / "box.usda", ceiling=True)
    panel = ((0.35, 0.4, 0.6), (0.3, 0, 0), (0, 0.25, 0), (0.5, 0.5, 0.5))
    add_face(stage, "/World/Panel", *panel)
    faces.append(Face(*panel))
    rect = UsdLux.RectLight.Define(stage, "/Lights/Rect")
    rect.CreateWidthAttr(0.4)
    rect.CreateHeightAttr(0.3)
    rect.CreateIntensityAttr(5.0)
    rect.CreateDiffuseAttr(0.7)
    UsdGeom.Xformable(rect).AddTranslateOp().Set(Gf.Vec3d(0.5, 0.55, 0.97))  # emitting down, along its -Z
    UsdLux.LightAPI(rect).GetLightLinkCollectionAPI().CreateExcludesRel().AddTarget("/World/Floor")
    bulb = UsdLux.SphereLight.Define(stage, "/Lights/Bulb")
    bulb.CreateRadiusAttr(0.08)
    bulb.CreateIntensityAttr(12.0)
    bulb.CreateExposureAttr(1.0)
    bulb.CreateColorAttr(Gf.Vec3f(1.0, 0.8, 0.6))
    UsdGeom.Xformable(bulb).AddTranslateOp().Set(Gf.Vec3d(0.3, 0.45, 0.85))  # out of view
    UsdLux.LightAPI(bulb).GetShadowLinkCollectionAPI().CreateExcludesRel().AddTarget("/World/Panel")
    stage.Save()
    floor, panel_face = list(WALLS).index("Floor"), len(faces) - 1
    lights = [Light("rect", (5.0, 5.0, 5.0), (0.5, 0.55, 0.97), width=0.4, height=0.3, diffuse=0.7, unlit=(floor,)),
              Light("sphere", (24.0, 19.2, 14.4), (0.3, 0.45, 0.85), radius=0.08, no_shadow=(panel_face,))]
    assert_matches_reference(tmp_path / "box.usda", faces, lights, [])


def test_an_open_box_under_a_dome_a_soft_sun_a_disk_light_and_a_glowing_panel_matches_the_reference(tmp_path):
    """No ceiling: a blue-white dome and a sun of 10 degrees tilted towards -X light the box through its top; a disk
    light faces the back wall and a one-sided glowing panel (a black metal UsdPreviewSurface of emissiveColor 6,
    reflecting nothing) on the wall behind the camera faces into the box."""
    stage, faces = box_stage(tmp_path / "box.usda", ceiling=False)
    dome = UsdLux.DomeLight.Define(stage, "/Lights/Dome")
    dome.CreateIntensityAttr(0.5)
    dome.CreateColorAttr(Gf.Vec3f(0.5, 0.7, 1.0))
    sun = UsdLux.DistantLight.Define(stage, "/Lights/Sun")
    sun.CreateIntensityAttr(150.0)
    sun.CreateAngleAttr(10.0)
    UsdGeom.Xformable(sun).AddRotateYOp().Set(-25.0)  # its +Z, towards the sun, leans to -X
    disk = UsdLux.DiskLight.Define(stage, "/Lights/Disk")
    disk.CreateRadiusAttr(0.12)
    disk.CreateIntensityAttr(10.0)
    ops = UsdGeom.Xformable(disk)
    ops.AddTranslateOp().Set(Gf.Vec3d(0.7, 0.2, 0.3))
    ops.AddRotateXOp().Set(90.0)  # its -Z, the emitting side, turned to +Y
    glow = ((0.2, 0.01, 0.6), (0, 0, 0.25), (0.3, 0, 0))  # behind the camera; u x v along +Y: into the box
    mesh = add_face(stage, "/World/Glow", *glow, double_sided=False)
    shader = UsdShade.Shader.Define(stage, "/Looks/Glow/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(1.0)  # F0 = F90 = diffuseColor = 0: no reflection
    shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(6, 6, 6))
    look = UsdShade.Material.Define(stage, "/Looks/Glow")
    look.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(look)
    stage.Save()
    faces.append(Face(*glow, albedo=(0, 0, 0), emission=(6, 6, 6)))
    a = math.radians(-25.0)
    lights = [Light("disk", (10.0, 10.0, 10.0), (0.7, 0.2, 0.3), radius=0.12, y_axis=(0, 0, 1), normal=(0, 1, 0))]
    skies = [Sky((0.25, 0.35, 0.5)), Sky((150.0, 150.0, 150.0), axis=(math.sin(a), 0.0, math.cos(a)),
                                         half_angle=math.radians(5.0))]
    assert_matches_reference(tmp_path / "box.usda", faces, lights, skies)


WHITE = np.ones(3, np.float32)
WHITE_LOBES = [Material(diffuse_color=WHITE, specular_edge=0.0, ior=1.0),  # Lambert alone
               Material(diffuse_color=WHITE, metallic=1.0, roughness=0.4),
               Material(diffuse_color=WHITE, opacity=0.0, roughness=0.0),  # clear glass
               Material(diffuse_color=WHITE, clearcoat=1.0, clearcoat_roughness=0.2, roughness=0.6)]


@pytest.mark.parametrize("sky", ["dome", "sun360"])
def test_an_open_box_of_white_materials_of_every_lobe_in_a_white_furnace_shows_one(sky):
    """Every surface returns all the light it receives, so every path ends in the sky's radiance 1: multiple
    importance sampling of the lights (a dome, or a DistantLight whose 360 degree disc is the whole sky) and of every
    lobe, bounce after bounce, must add up to 1. Measured: 1.0001 +- 0.0014 (dome) at 4096 spp."""
    walls = [((0.5, 0.5, 0), (1, 0, 0), (0, 1, 0)), ((0.5, 1, 0.5), (1, 0, 0), (0, 0, 1)),
             ((0.5, 0, 0.5), (1, 0, 0), (0, 0, 1)), ((0, 0.5, 0.5), (0, 1, 0), (0, 0, 1)),
             ((1, 0.5, 0.5), (0, 1, 0), (0, 0, 1))]
    meshes = [quad(c, u, v, name=f"/wall{i}", material=i % len(WHITE_LOBES)) for i, (c, u, v) in enumerate(walls)]
    light = (DomeLight(color=WHITE) if sky == "dome" else
             wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=WHITE, angle=360.0))
    scene = wrt.Scene(meshes=meshes, materials=WHITE_LOBES, lights=[light])
    cam = wrt.Camera.look_at(eye=(0.5, 0.1, 0.45), target=(0.5, 1.0, 0.6), up=(0, 0, 1), fov_y_deg=70)
    img = wrt.render(scene, camera=cam, width=WIDTH, height=HEIGHT, spp=1024, device="cpu", integrator="path",
                     max_depth=64)
    pixels = img.rgb.mean(-1).ravel()
    se = pixels.std(ddof=1) / math.sqrt(pixels.size)  # pixel to pixel: noise, and any bias varying over the image
    assert abs(pixels.mean() - 1.0) <= max(4 * se, 0.01), (pixels.mean(), se)
    np.testing.assert_allclose(img.rgb, 1.0, atol=0.1)


def albedo(alpha, mu):
    """The oracle's ``(E, B)`` at 48 nodes (within 4e-8 of 200 here)."""
    return ggx_albedo(alpha, mu, 48)


def ggx_average_albedo(alpha):
    """``E_avg = 2 int E(mu) mu dmu`` of a white GGX lobe, by Gauss-Legendre quadrature of the oracle's ``E``."""
    t, w = np.polynomial.legendre.leggauss(24)
    mu = 0.5 * (t + 1.0)
    return float(sum(wk * albedo(alpha, m)[0] * m for m, wk in zip(mu, w)))


def ggx_lobe(alpha, f0, f90, wo, wi):
    """``D G2 F / (4 cos_o cos_i)``: GGX, height-correlated Smith, Schlick's Fresnel at the half vector."""
    h = (wo + wi) / np.linalg.norm(wo + wi)
    d = alpha**2 / (np.pi * (h[2] ** 2 * (alpha**2 - 1.0) + 1.0) ** 2)
    g2 = 1.0 / (1.0 + smith_lambda(wo[2], alpha) + smith_lambda(wi[2], alpha))
    return (f0 + (f90 - f0) * (1.0 - wo @ h) ** 5) * d * g2 / (4.0 * wo[2] * wi[2])


def preview_surface_bsdf(wo, wi, base, metallic, roughness, clearcoat=0.0, clearcoat_roughness=0.01, ior=1.5,
                         specular=None, opacity=1.0):
    """The BSDF README's Shading section states (local frame, normal +Z), in float64: Lambert under GGX under a
    clearcoat, ``F0 = mix(((1-ior)/(1+ior))^2, diffuseColor, metallic)``, ``F90 = mix(1, diffuseColor, metallic)``
    (with ``specular``, the specular workflow: ``F0 = specularColor``, ``F90`` white, the diffuse lobe
    ``diffuseColor`` whole), the clearcoat's ``F0`` of the same ``ior``, Kulla and Conty's multiple-scattering lobe,
    each layer keeping what the lobes above do not reflect at ``wo``; ``opacity`` of it where the rest is glass."""
    base = np.asarray(base, float)
    r0 = ((1.0 - ior) / (1.0 + ior)) ** 2
    f0, f90 = r0 + (base - r0) * metallic, 1.0 + (base - 1.0) * metallic
    if specular is not None:
        f0, f90, metallic = np.asarray(specular, float), np.ones(3), 0.0
    alpha = roughness**2
    (e_o, b_o), (e_i, _), e_avg = albedo(alpha, wo[2]), albedo(alpha, wi[2]), ggx_average_albedo(alpha)
    f_avg = f0 + (f90 - f0) / 21.0
    f_ms = f_avg**2 * e_avg / (1.0 - f_avg * (1.0 - e_avg))
    spec_albedo = f0 * e_o + (f90 - f0) * b_o + f_ms * (1.0 - e_o)
    f = ((1.0 - spec_albedo) * base * (1.0 - metallic) / np.pi + ggx_lobe(alpha, f0, f90, wo, wi)
         + f_ms * (1.0 - e_o) * (1.0 - e_i) / (np.pi * (1.0 - e_avg)))
    if clearcoat > 0.0:
        coat_e, coat_b = albedo(clearcoat_roughness**2, wo[2])
        kept = 1.0 - clearcoat * (r0 * coat_e + (1.0 - r0) * coat_b)
        f = kept * f + clearcoat * ggx_lobe(clearcoat_roughness**2, r0, 1.0, wo, wi)
    return f * opacity


def unit(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


@pytest.mark.parametrize("inputs", [
    dict(base=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.4),  # gold
    dict(base=(0.8, 0.3, 0.1), metallic=0.0, roughness=0.3),
    dict(base=(0.2, 0.5, 0.9), metallic=0.0, roughness=0.6, clearcoat=1.0, clearcoat_roughness=0.1),
    dict(base=(0.9, 0.6, 0.9), metallic=0.5, roughness=0.15)])
def test_a_plane_under_a_delta_sun_shows_the_documented_bsdf_times_the_cosine(inputs):
    """With a delta DistantLight of illuminance 1 (sampled alone, weight 1) and ``max_depth = 1`` a plane's radiance
    is exactly ``f(wo, wi) cos_i``: the path tracer's BSDF, layering and multiple scattering included, against the
    stated model written out in float64 with the albedos from an independent quadrature (tests/ggx_albedo_oracle.py).
    Measured: within 1e-3 in every direction (wrt reads ``E`` from tables)."""
    material = Material(diffuse_color=np.array(inputs["base"], np.float32), metallic=inputs["metallic"],
                        roughness=inputs["roughness"], clearcoat=inputs.get("clearcoat", 0.0),
                        clearcoat_roughness=inputs.get("clearcoat_roughness", 0.01))
    plane = quad((0, 0, 0), (400, 0, 0), (0, 400, 0), material=0)
    for view, light in [((30, 0), (30, 180)), ((30, 0), (50, 180)), ((60, 0), (20, 90)), ((10, 0), (70, 200)),
                        ((75, 0), (75, 180))]:
        wo, wi = unit(*view), unit(*light)
        sun = wrt.DistantLight(direction=-wi, color=np.ones(3, np.float32))
        scene = wrt.Scene(meshes=[plane], materials=[material], lights=[sun])
        cam = wrt.Camera.orthographic(eye=3 * wo, target=(0, 0, 0), up=(0, 0, 1), height=0.1)
        got = wrt.render(scene, camera=cam, width=2, height=2, spp=1, device="cpu", integrator="path",
                         max_depth=1).rgb.mean((0, 1))
        np.testing.assert_allclose(got, preview_surface_bsdf(wo, wi, **inputs) * wi[2], rtol=3e-3,
                                   err_msg=f"view {view}, light {light}")


def preview_surface_plane(path, inputs: dict, wi):
    """Writes a stage at ``path``: a 400-unit plane through the origin facing +Z bound to a UsdPreviewSurface of
    ``inputs`` (name -> (type, value)), under a delta DistantLight of intensity 1 arriving along ``-wi``."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    mesh = UsdGeom.Mesh.Define(stage, "/Plane")
    mesh.CreatePointsAttr([(-200, -200, 0), (200, -200, 0), (200, 200, 0), (-200, 200, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    shader = UsdShade.Shader.Define(stage, "/Looks/M/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, (value_type, value) in inputs.items():
        shader.CreateInput(name, value_type).Set(value)
    look = UsdShade.Material.Define(stage, "/Looks/M")
    look.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(look)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(1.0)
    sun.CreateAngleAttr(0.0)
    axis = np.cross((0.0, 0.0, 1.0), wi)  # turns the light's +Z (towards it) onto wi
    angle = math.degrees(math.atan2(np.linalg.norm(axis), wi[2]))
    turn = Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(*(axis / np.linalg.norm(axis))), angle))
    UsdGeom.Xformable(sun).AddTransformOp().Set(turn)
    stage.Save()


T = Sdf.ValueTypeNames


@pytest.mark.parametrize("inputs, model", [
    ({"useSpecularWorkflow": (T.Int, 1), "specularColor": (T.Color3f, Gf.Vec3f(0.3, 0.2, 0.1)),
      "diffuseColor": (T.Color3f, Gf.Vec3f(0.5, 0.4, 0.2)), "roughness": (T.Float, 0.4)},
     dict(base=(0.5, 0.4, 0.2), metallic=0.0, roughness=0.4, specular=(0.3, 0.2, 0.1))),
    ({"diffuseColor": (T.Color3f, Gf.Vec3f(0.2, 0.6, 0.3)), "roughness": (T.Float, 0.5), "ior": (T.Float, 0.7),
      "clearcoat": (T.Float, 0.6), "clearcoatRoughness": (T.Float, 0.3)},
     dict(base=(0.2, 0.6, 0.3), metallic=0.0, roughness=0.5, ior=0.7, clearcoat=0.6, clearcoat_roughness=0.3)),
    ({"diffuseColor": (T.Color3f, Gf.Vec3f(0.7, 0.5, 0.3)), "roughness": (T.Float, 0.3), "metallic": (T.Float, 0.5),
      "opacity": (T.Float, 0.6), "ior": (T.Float, 2.2)},
     dict(base=(0.7, 0.5, 0.3), metallic=0.5, roughness=0.3, opacity=0.6, ior=2.2)),
])
def test_preview_surfaces_read_from_a_stage_show_the_documented_bsdf_in_both_integrators(tmp_path, inputs, model):
    """UsdPreviewSurface inputs authored on a stage (the specular workflow's ``useSpecularWorkflow`` and
    ``specularColor``; an ``ior`` below 1, which the clearcoat's ``F0`` follows; ``opacity`` below 1 over a half
    metal) read by ``load_usd`` and rendered by ``path`` and ``whitted`` with ``max_depth = 1`` under a delta sun of
    illuminance 1: ``f(wo, wi) cos_i`` of the README's model written out in float64 (:func:`preview_surface_bsdf`)."""
    for view, light in [((30, 0), (30, 180)), ((60, 0), (20, 90)), ((75, 0), (75, 180)), ((10, 0), (70, 200))]:
        wo, wi = unit(*view), unit(*light)
        preview_surface_plane(tmp_path / "plane.usda", inputs, wi)
        scene = wrt.load_usd(tmp_path / "plane.usda")
        cam = wrt.Camera.orthographic(eye=3 * wo, target=(0, 0, 0), up=(0, 0, 1), height=0.1)
        expected = preview_surface_bsdf(wo, wi, **model) * wi[2]
        for integrator in ("path", "whitted"):
            got = wrt.render(scene, camera=cam, width=2, height=2, spp=1, device="cpu", integrator=integrator,
                             max_depth=1).rgb.mean((0, 1))
            np.testing.assert_allclose(got, expected, rtol=3e-3, err_msg=f"{integrator}: view {view}, light {light}")
