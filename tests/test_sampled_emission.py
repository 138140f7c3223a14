"""The light table's emission estimate of textured emitters read on their triangles (wrt/sampled_emission.py): a
glowing quad whose texture returns its fallback (a UDIM tile without a file, the ``fallback`` wrap outside [0, 1] that
MaterialX's ``constant`` address mode reads) over black texels lights the floor below as the closed form of a uniform
emitter says; triangles are drawn by what their own texture returns; materials that emit nothing get no light
entries; a USD ``Sphere`` gprim and a ``wrt.Shape`` sphere that glow by the fallback light the floor as the same
sphere of constant emission does; a lamp whose glow lies only between the points its emission is read at (a
corner past [0, 1], a missing tile inside the triangle) is sampled too, and lights the floor as the quadrature says."""

import warnings

import numpy as np
import pytest
from shading_helpers import pixel_points, quad, top_down_camera

import wrt
from wrt.materials import Material, TextureInput
from wrt.textures import UDIM_TILES

RADIANCE = 2.0  # the fallback's, each channel
HEIGHT = 1.0  # of the lamp (a unit square centred over the origin) above the floor
BLACK = np.zeros((4, 4, 4), np.float32)  # the texels of every image


def floor_irradiance(x, y, n=200):
    """Irradiance at floor point ``(x, y, 0)`` from the lamp emitting :data:`RADIANCE` uniformly: the midpoint rule
    (``n`` x ``n``, float64) over the square of ``cos cos' / r^2``."""
    s = (np.arange(n) + 0.5) / n - 0.5
    dx, dy = np.meshgrid(s - x, s - y)
    r2 = dx * dx + dy * dy + HEIGHT * HEIGHT
    return RADIANCE * float(np.sum(HEIGHT * HEIGHT / (r2 * r2))) / (n * n)


def lamp_scene(texture: TextureInput | None, st_corner=(0.0, 0.0), **glow) -> wrt.Scene:
    """A white floor (10 x 10) under a double-sided unit lamp at :data:`HEIGHT` whose emissiveColor is ``texture``
    (image 0: :data:`BLACK`; None: none) at ``st`` over ``[0, 1]^2 + st_corner``; ``glow``: more fields of the lamp's
    material."""
    lamp = quad((0, 0, HEIGHT), (1, 0, 0), (0, 1, 0), name="/lamp", material=0)
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32) + np.float32(st_corner)
    lamp.uvs = corners[np.array([[0, 1, 2], [0, 2, 3]])]
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1)
    textures = {} if texture is None else {"emissiveColor": texture}
    lamp_material = Material(path="/Glow", diffuse_color=0.0, textures=textures, **glow)
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    return wrt.Scene(meshes=[floor, lamp], materials=[lamp_material, white], textures=[BLACK])


def udim_table(**tiles) -> np.ndarray:
    """A UDIM table (:attr:`TextureInput.tiles`) of image ``k`` at tile ``1001 + u + 10 v`` for each ``t<tile>=k``."""
    table = np.full(UDIM_TILES, -1, np.int32)
    for name, image in tiles.items():
        table[int(name[1:]) - 1001] = image
    return table


FALLBACK = np.array([RADIANCE, RADIANCE, RADIANCE, 1.0], np.float32)
CASES = {
    # tile 1001 exists (black), the lamp reads tile 1002, which has no file
    "udim tile without a file": (TextureInput(image=0, tiles=udim_table(t1001=0), fallback=FALLBACK), (1.0, 0.0)),
    # MaterialX's constant address mode: the image's default outside [0, 1]
    "fallback wrap outside [0, 1]": (TextureInput(image=0, wrap=("fallback", "fallback"), fallback=FALLBACK),
                                     (2.0, 0.0)),
}


@pytest.mark.parametrize("case", CASES)
def test_a_lamp_that_glows_by_its_fallback_lights_the_floor(case):
    """The lamp's texels are black, but what its texture returns on it is the fallback, :data:`RADIANCE`: under
    ``whitted`` (light samples alone) the floor beside the lamp shows the irradiance of a uniform emitter over pi
    (white Lambertian). The texels' mean, 0, made it no light: not sampled, and the stage, lit by nothing as far as
    wrt could tell, got the default lights instead (a floor of 1.0 where 0.033 is right)."""
    texture, st_corner = CASES[case]
    scene = lamp_scene(texture, st_corner)
    height, res = 3.0, 12
    img = wrt.render(scene, camera=top_down_camera(center=(0, 2.25, 0), height=height), width=res, height=res,
                     spp=8, seed=1, device="cpu").rgb.mean(axis=2)
    # Pixel centres over y in [0.75, 3.75], x in [-1.5, 1.5]: the floor beside the lamp (|y| > 0.5).
    offsets = ((np.arange(res) + 0.5) / res - 0.5) * height
    want = np.array([[floor_irradiance(x, 2.25 - y) for x in offsets] for y in offsets]) / np.pi
    assert img.mean() == pytest.approx(want.mean(), rel=0.02)
    np.testing.assert_allclose(img, want, rtol=0.25)  # each pixel, within the noise of 8 samples


def triangle_pmf(scene) -> np.ndarray:
    """The selection probability of each geometry triangle (0 for those not in the light table)."""
    r = wrt.Renderer(scene, camera=top_down_camera(height=1.0), width=2, height=2, device="cpu")
    lights = r.device_lights
    first, count = lights.num_analytic, lights.count
    pmf = np.zeros(scene.num_geometry_triangles)
    pmf[lights.prims.numpy()[first:count]] = lights.pmf.numpy()[first:count]
    return pmf


def test_each_triangle_is_drawn_by_what_its_own_tile_emits():
    """A lamp of two unit squares side by side, st over tiles 1001 (an image of 0.5) and 1002 (no file: the fallback,
    :data:`RADIANCE`): the triangles on the missing tile take 4 times the power share of those on the image, their
    emissions' ratio (each triangle's power is its area times its emission, the four areas equal), the lights being
    drawn half by power share, half uniformly. The material's estimate, the image's mean, drew all four alike."""
    texture = TextureInput(image=0, tiles=udim_table(t1001=0), fallback=FALLBACK)
    lamp = wrt.Mesh("/lamp", np.array([[x, y, 1.0] for y in (0, 1) for x in (0, 1, 2)], np.float64),
                    np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]), [0, 0, 1, 1],
                    uvs=np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]] * 2, np.float32)
                    + np.float32([0, 0, 1, 1])[:, None, None] * np.float32([1, 0]),
                    material_ids=np.zeros(4, np.int32))
    grey = np.full((4, 4, 4), 0.5, np.float32)
    scene = wrt.Scene(meshes=[lamp], materials=[Material(path="/Glow", diffuse_color=0.0,
                                                         textures={"emissiveColor": texture})], textures=[grey])
    pmf = triangle_pmf(scene)
    np.testing.assert_allclose(pmf, 0.5 / 4 + 0.5 * np.array([0.5, 0.5, 2.0, 2.0]) / 5.0, rtol=1e-6)


def test_materials_that_emit_nothing_get_no_light_entries():
    """Beside a lamp of constant emission: a quad whose emission texture is black with a black fallback, even where it
    reads the fallback (st on a tile without a file), and a floor with a diffuse texture only, take no light entries
    (selection probability 0); the lamp takes all of it."""
    dark = TextureInput(image=0, tiles=udim_table(t1001=0))  # the default fallback: black
    meshes = [quad((0, 0, 0), (6, 0, 0), (0, 6, 0), name="/floor", material=0),
              quad((0, 0, 1), (1, 0, 0), (0, 1, 0), name="/dark", material=1),
              quad((2, 0, 1), (1, 0, 0), (0, 1, 0), name="/lamp", material=2)]
    meshes[0].uvs = np.zeros((2, 3, 2), np.float32)
    meshes[1].uvs = np.full((2, 3, 2), 1.5, np.float32)  # tile 1002
    materials = [Material(path="/Floor", textures={"diffuseColor": TextureInput(image=0)}),
                 Material(path="/Dark", textures={"emissiveColor": dark}),
                 Material(path="/Lamp", emissive_color=np.ones(3, np.float32))]
    pmf = triangle_pmf(wrt.Scene(meshes=meshes, materials=materials, textures=[BLACK]))
    np.testing.assert_array_equal(pmf, [0, 0, 0, 0, 0.5, 0.5])


def glowing_bulb_stage(tmp_path, name: str, by_fallback: bool) -> str:
    """A USD stage: a Lambertian floor under a ``Sphere`` gprim (radius 0.2, at height 1) that glows with radiance
    :data:`RADIANCE`: by a plain ``emissiveColor`` or, ``by_fallback``, by the fallback of a UDIM texture whose one
    tile (1002, black) is not the one a gprim reads (st (0, 0): tile 1001, which has no file)."""
    from PIL import Image
    from pxr import Gf, Sdf, UsdGeom, UsdShade
    from test_materials import add_quad, bind, new_stage, preview_material

    stage, path = new_stage(tmp_path, f"{name}.usda")
    bind(add_quad(stage, "/Floor", size=4.0), preview_material(stage, "/Looks/White", diffuseColor=Gf.Vec3f(1),
                                                               useSpecularWorkflow=1, specularColor=Gf.Vec3f(0))[0])
    bulb = UsdGeom.Sphere.Define(stage, "/Bulb")
    bulb.CreateRadiusAttr(0.2)
    bulb.AddTranslateOp().Set(Gf.Vec3d(0, 0, HEIGHT))
    glow = Gf.Vec3f(RADIANCE)
    material, shader = preview_material(stage, "/Looks/Glow", diffuseColor=Gf.Vec3f(0),
                                        **({} if by_fallback else {"emissiveColor": glow}))
    if by_fallback:
        Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(tmp_path / "glow.1002.png")
        tex = UsdShade.Shader.Define(stage, "/Looks/Glow/Image")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./glow.<UDIM>.png")
        tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(RADIANCE, RADIANCE, RADIANCE, 1))
        tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        shader.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    bind(bulb, material)
    stage.Save()
    return path


def test_a_gprim_that_glows_by_its_fallback_is_a_bulb(tmp_path):
    """A ``Sphere`` whose UDIM emission texture gives it its fallback (tile 1001 has no file) is drawn as its
    tessellation and sampled, as a gprim of constant emission is: under ``whitted`` it lights the floor as the same
    sphere with the fallback as its ``emissiveColor`` does. Its texels' mean, 0, left it an analytic shape that no
    light sample reached: the stage got the default lights (a floor of 1.0 for 0.03)."""
    cam = top_down_camera(center=(1.0, 0, 0), height=1.0)
    floors = []
    for by_fallback in (True, False):
        scene = wrt.load_usd(glowing_bulb_stage(tmp_path, f"fallback{by_fallback}", by_fallback))
        floors.append(wrt.render(scene, camera=cam, width=8, height=8, spp=4, seed=1, device="cpu").rgb)
    assert floors[1].mean() > 0.0
    np.testing.assert_allclose(floors[0], floors[1], rtol=1e-5)


def test_an_analytic_sphere_that_glows_by_its_fallback_is_sampled():
    """A ``wrt.Shape`` sphere (radius 0.2, at height 1) whose UDIM emission texture has no file for tile 1001, where a
    shape reads its glow (st (0, 0)), glows by the fallback, :data:`RADIANCE`: under ``whitted`` it lights the floor
    as the same sphere of constant emission does (the same image). Its texels' mean, 0, left it out of the light
    table: the floor stayed black (2e-16 where its mean is 0.028)."""
    from wrt.lights import SphereLight

    far = SphereLight(position=(100, 100, 100), radius=0.1, color=np.full(3, 1e-9))  # no default lights
    lamp = np.diag([0.2, 0.2, 0.2, 1.0])
    lamp[:3, 3] = (0, 0, HEIGHT)
    floors = []
    for glow in (TextureInput(image=0, tiles=udim_table(t1002=0), fallback=FALLBACK), None):
        scene = wrt.Scene(
            meshes=[quad((0, 0, 0), (4, 0, 0), (0, 4, 0), name="/floor", material=0)],
            shapes=[wrt.Shape("/Bulb", "sphere", lamp, material_id=1)],
            materials=[Material(path="/White", diffuse_color=1.0, use_specular_workflow=True),
                       Material(path="/Glow", diffuse_color=0.0, emissive_color=np.zeros(3) if glow else RADIANCE,
                                textures={"emissiveColor": glow} if glow else {})],
            textures=[BLACK], lights=[far])
        floors.append(wrt.render(scene, camera=top_down_camera(center=(1.0, 0, 0), height=1.0), width=4, height=4,
                                 spp=4, seed=1, device="cpu").rgb)
    assert floors[1].mean() > 0.01
    np.testing.assert_allclose(floors[0], floors[1], rtol=1e-5)


def triangles_irradiance(points: np.ndarray, triangles: list, n: int = 64) -> np.ndarray:
    """Irradiance at floor ``points`` (``(P, 2)``) from flat ``triangles`` (each ``(3, 2)`` corners in the plane at
    :data:`HEIGHT`) emitting :data:`RADIANCE`: the centroid rule (float64) over each triangle cut into ``n * n``
    similar ones, of ``cos cos' / r^2``."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = (i + j) < n  # the n(n+1)/2 upright sub-triangles, then the n(n-1)/2 upside-down ones
    centroids = np.concatenate([np.stack([i[up] + 1 / 3, j[up] + 1 / 3], -1),
                                np.stack([i[(i + j) < n - 1] + 2 / 3, j[(i + j) < n - 1] + 2 / 3], -1)]) / n
    total = np.zeros(len(points))
    for a, b, c in (np.asarray(t, np.float64) for t in triangles):
        q = a + centroids[:, :1] * (b - a) + centroids[:, 1:] * (c - a)  # (n * n, 2)
        u, v = b - a, c - a
        area = abs(u[0] * v[1] - u[1] * v[0]) / 2 / (n * n)
        r2 = ((points[:, None, :] - q[None]) ** 2).sum(-1) + HEIGHT * HEIGHT
        total += area * (HEIGHT * HEIGHT / (r2 * r2)).sum(-1)
    return RADIANCE * total


SIDE = 1.45  # of the corner lamp: every point its glow is read at lies in [0, 1]^2 (the largest, 4/6 of it, is 0.97)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_lamp_whose_glow_none_of_its_points_reads_lights_the_floor(integrator):
    """A lamp triangle of legs :data:`SIDE` whose st is its xy, black texels and a ``fallback`` wrap: it glows by the
    fallback only where st leaves [0, 1] (two corners of legs 0.45), which holds none of the points its emission is
    read at. It lights the floor beside it as the quadrature of those two corners says. It was estimated as no light:
    unsampled, and the stage, lit by nothing as far as wrt could tell, got the default lights (a floor of 1.0 where
    0.018 is right)."""
    lamp = wrt.Mesh("/lamp", np.array([[0, 0, HEIGHT], [SIDE, 0, HEIGHT], [0, SIDE, HEIGHT]]), np.array([[0, 1, 2]]),
                    [0], uvs=np.float32([[[0, 0], [SIDE, 0], [0, SIDE]]]), material_ids=np.zeros(1, np.int32),
                    double_sided=True)
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1)
    glow = Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": TextureInput(
        image=0, wrap=("fallback", "fallback"), fallback=FALLBACK)})
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    scene = wrt.Scene(meshes=[floor, lamp], materials=[glow, white], textures=[BLACK])
    center, height, res = (2.2, 0.0), 1.4, 16
    img = wrt.render(scene, camera=top_down_camera(center=(*center, 0), height=height), width=res, height=res,
                     spp=128, seed=1, integrator=integrator, device="cpu").rgb.mean(axis=2)
    points = pixel_points((*center, 0), height, res, res)[..., :2].reshape(-1, 2)
    leg = SIDE - 1.0
    want = triangles_irradiance(points, [[(1, 0), (SIDE, 0), (1, leg)], [(0, 1), (leg, 1), (0, SIDE)]]) / np.pi
    assert img.mean() == pytest.approx(want.mean(), rel=0.05)


def test_a_triangle_over_a_missing_tile_between_its_points_is_sampled():
    """A triangle whose st runs over tiles 1001, 1002 and 1011 (black images) and, between its corners, tile 1012,
    which has no file: it glows there by the fallback, where none of the points its emission is read at lie. It
    takes a share of the light picks (beside a lamp of constant emission); it had none, and ``whitted`` left its
    light out."""
    texture = TextureInput(image=0, tiles=udim_table(t1001=0, t1002=0, t1011=0), fallback=FALLBACK)
    meshes = [wrt.Mesh("/part", np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1]], np.float64), np.array([[0, 1, 2]]), [0],
                       uvs=np.float32([[[0.5, 0.5], [1.9, 0.5], [0.5, 1.9]]]), material_ids=np.zeros(1, np.int32)),
              quad((3, 0, 1), (1, 0, 0), (0, 1, 0), name="/lamp", material=1)]
    materials = [Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": texture}),
                 Material(path="/Lamp", emissive_color=np.ones(3, np.float32))]
    pmf = triangle_pmf(wrt.Scene(meshes=meshes, materials=materials, textures=[BLACK]))
    assert pmf[0] > 0.0


@pytest.mark.parametrize("case", CASES)
def test_a_cut_out_lamp_that_glows_by_its_fallback_is_the_stages_light(case):
    """A lamp cut out everywhere (opacity 0 under a threshold of 0.5) lights nothing, but it is the light its
    author gave the stage, which then gets no default lights: the floor renders black, as under the same cut-out lamp
    of constant glow (:data:`RADIANCE`). One that glowed only by its texture's fallback (over black texels) was
    not read on its triangles, so the stage counted as unlit and got the default lights (a floor of 1.0)."""
    texture, st_corner = CASES[case]
    cut = {"opacity": 0.0, "opacity_threshold": 0.5}
    camera = top_down_camera(center=(0, 2.25, 0), height=3.0)
    images, lights = [], []
    for scene in (lamp_scene(texture, st_corner, **cut), lamp_scene(None, emissive_color=np.full(3, RADIANCE), **cut)):
        r = wrt.Renderer(scene, camera=camera, width=4, height=4, device="cpu")
        images.append(r.render(spp=2, seed=1).rgb)
        lights.append(r.lights)
    assert lights[1] == () and lights[0] == ()
    np.testing.assert_array_equal(images[0], images[1])
    assert images[1].max() == 0.0


def test_a_lamp_whose_glow_its_triangles_do_not_read_is_the_stages_light_whichever_way_it_glows():
    """Two lamps that glow nowhere on their triangles (st on tile 1001, a black image): one's material glows by its
    fallback (on tiles without a file), the other's by an image of :data:`RADIANCE` on tile 1002. Both are emissive
    materials (:func:`wrt.materials.can_emit`, as the loader reads them), which the README gives no default lights:
    each floor renders black (0 exactly), the stage's own light being none there, and the render says why, naming
    the material. The one that glows by its fallback got the default headlight and dome (a floor of 1.0), the other
    none, without a word. The same lamp read on its glowing tile lights the floor, without the warning."""
    bright = np.full((4, 4, 4), RADIANCE, np.float32)
    by_fallback = lamp_scene(TextureInput(image=0, tiles=udim_table(t1001=0), fallback=FALLBACK))
    by_tile = lamp_scene(TextureInput(image=0, tiles=udim_table(t1001=0, t1002=1)))
    by_tile.textures = [BLACK, bright]
    camera = top_down_camera(center=(0, 2.25, 0), height=3.0)
    for scene in (by_fallback, by_tile):
        r = wrt.Renderer(scene, camera=camera, width=4, height=4, device="cpu")
        assert r.lights == ()
        assert r.render(spp=2, seed=1).rgb.max() == 0.0
        with pytest.warns(UserWarning, match=r"no light: the stage's glowing materials glow nowhere .*: /Glow; "):
            wrt.Renderer(scene, camera=camera, width=4, height=4, device="cpu")
    lit = lamp_scene(TextureInput(image=0, tiles=udim_table(t1001=0, t1002=1)), st_corner=(1.0, 0.0))
    lit.textures = [BLACK, bright]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert wrt.render(lit, camera=camera, width=4, height=4, spp=2, seed=1, device="cpu").rgb.max() > 0.0
    assert not [w for w in caught if "no light" in str(w.message)]


def held_bytes(read) -> int:
    """The bytes of the arrays ``read`` (what :func:`wrt.sampled_emission.sampled_emission` returned) holds."""
    if isinstance(read, np.ndarray):
        return read.nbytes
    return sum(v.nbytes for v in vars(read).values() if isinstance(v, np.ndarray))


def test_only_the_textured_emitters_rows_are_held():
    """A floor of 20,000 triangles that do not glow under a lamp of two triangles with an emission texture of
    constant 2: what the render keeps of the emission read on triangles (with the scene, for its life) is the lamp's
    two rows, each the texture's 2, not a float64 row per triangle of the scene (480 kB here, 24 MB per million
    triangles); the light table draws the two lamp triangles alike, and nothing else."""
    from wrt.render import shading_data
    from wrt.sampled_emission import sampled_emission

    n = 100
    xs = np.linspace(-5.0, 5.0, n + 1)
    gx, gy = np.meshgrid(xs, xs)
    corner = (np.arange(n)[:, None] * (n + 1) + np.arange(n)).ravel()
    floor = wrt.Mesh("/floor", np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1),
                     np.concatenate([np.stack([corner, corner + 1, corner + n + 2], 1),
                                     np.stack([corner, corner + n + 2, corner + n + 1], 1)]),
                     np.arange(2 * n * n), material_ids=np.ones(2 * n * n, np.int32))
    lamp = quad((0, 0, HEIGHT), (1, 0, 0), (0, 1, 0), name="/lamp", material=0)
    lamp.uvs = np.float32([[0, 0], [1, 0], [1, 1], [0, 1]])[np.array([[0, 1, 2], [0, 2, 3]])]
    scene = wrt.Scene(meshes=[floor, lamp], materials=[
        Material(path="/Glow", textures={"emissiveColor": TextureInput(image=0)}), Material(path="/White")],
        textures=[np.full((4, 4, 4), 2.0, np.float32)])
    mats, uvs, _, _, emission, _ = shading_data(scene, "cpu")
    rows = scene.triangle_materials()
    read = sampled_emission(mats, uvs, rows, emission, np.array([False, True, False]), "cpu")
    lamp_rows = np.flatnonzero(rows == 1)
    assert len(lamp_rows) == 2 and held_bytes(read) <= len(lamp_rows) * 4 * 8
    np.testing.assert_allclose(read.over(lamp_rows, np.zeros((2, 3))), 2.0, rtol=1e-6)
    np.testing.assert_array_equal(triangle_pmf(scene)[lamp_rows], [0.5, 0.5])


def two_tile_lamp(material_ids) -> wrt.Mesh:
    """A lamp of two unit squares side by side at :data:`HEIGHT` (two triangles each), st over tiles 1001 and 1002,
    its triangles of device-material ``material_ids`` (less 1: mesh material ids)."""
    lamp = wrt.Mesh("/lamp", np.array([[x - 1.0, y - 0.5, HEIGHT] for y in (0, 1) for x in (0, 1, 2)], np.float64),
                    np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]), [0, 0, 1, 1],
                    uvs=np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]] * 2, np.float32)
                    + np.float32([0, 0, 1, 1])[:, None, None] * np.float32([1, 0]),
                    material_ids=np.asarray(material_ids, np.int32), double_sided=True)
    return lamp


def test_triangles_on_a_black_udim_tile_take_no_light_picks():
    """A lamp whose UDIM emission texture has a black image on tile 1001 and an image of :data:`RADIANCE` on tile
    1002: the triangles on the black tile, which glow nowhere, take no light picks, as the same lamp with those
    triangles not glowing and the others of constant :data:`RADIANCE` (the oracle) gives them; and the floor renders
    as under that lamp. They had the material's mean (half the bright tile's) as their estimate: 0.42 of the picks,
    all wasted (a relative noise per pixel of the floor 4.2 times the oracle's at 4 samples under whitted)."""
    bright = np.full((4, 4, 4), RADIANCE, np.float32)
    texture = TextureInput(image=0, tiles=udim_table(t1001=0, t1002=1))
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1)
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    textured = wrt.Scene(meshes=[floor, two_tile_lamp([0, 0, 0, 0])], textures=[BLACK, bright], materials=[
        Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": texture}), white])
    plain = wrt.Scene(meshes=[floor, two_tile_lamp([2, 2, 0, 0])], materials=[
        Material(path="/Glow", diffuse_color=0.0, emissive_color=np.full(3, RADIANCE)), white,
        Material(path="/Dark", diffuse_color=0.0)])
    np.testing.assert_allclose(triangle_pmf(textured), triangle_pmf(plain), rtol=1e-6, atol=1e-12)
    camera = top_down_camera(center=(0, 2.0, 0), height=2.0)
    images = [wrt.render(scene, camera=camera, width=8, height=8, spp=64, seed=1, device="cpu").rgb
              for scene in (textured, plain)]
    assert images[0].mean() == pytest.approx(images[1].mean(), rel=0.02)


def test_a_triangle_whose_points_lie_on_a_black_tile_but_which_reaches_a_bright_one_is_sampled():
    """A triangle of st legs :data:`SIDE` over tiles 1001 and 1011 (black images), whose corner past s = 1 lies on
    tile 1002 (an image of :data:`RADIANCE`): every point its glow is read at is black, but it glows on that corner,
    so it keeps light picks (beside a lamp of constant emission): the largest mean of its tiles, not 0."""
    bright = np.full((4, 4, 4), RADIANCE, np.float32)
    texture = TextureInput(image=0, tiles=udim_table(t1001=0, t1002=1, t1011=0))
    meshes = [wrt.Mesh("/part", np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1]], np.float64), np.array([[0, 1, 2]]), [0],
                       uvs=np.float32([[[0, 0], [SIDE, 0], [0, SIDE]]]), material_ids=np.zeros(1, np.int32)),
              quad((3, 0, 1), (1, 0, 0), (0, 1, 0), name="/lamp", material=1)]
    materials = [Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": texture}),
                 Material(path="/Lamp", emissive_color=np.ones(3, np.float32))]
    pmf = triangle_pmf(wrt.Scene(meshes=meshes, materials=materials, textures=[BLACK, bright]))
    assert pmf[0] > 0.0


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_cut_out_glowing_card_lights_as_its_opaque_part(integrator):
    """A unit card glowing by an emission texture of :data:`RADIANCE`, cut out on its right half (an opacity mask
    of two texels, 1 and 0, under a threshold of 0.5): its estimate does not read the holes (their draws give
    nothing), but no light comes through them: the floor renders as under a card of the left half alone, of constant
    :data:`RADIANCE`."""
    mask = np.zeros((1, 2, 4), np.float32)
    mask[0, 0] = 1.0
    card = quad((0, 0, HEIGHT), (1, 0, 0), (0, 1, 0), name="/lamp", material=0)
    card.uvs = np.float32([[0, 0], [1, 0], [1, 1], [0, 1]])[np.array([[0, 1, 2], [0, 2, 3]])]
    textures = {"opacity": TextureInput(image=0, channel="r", wrap=("clamp", "clamp")),
                "emissiveColor": TextureInput(image=1)}
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    scenes = [
        wrt.Scene(meshes=[quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1), card],
                  materials=[Material(path="/Card", diffuse_color=0.0, opacity_threshold=0.5, textures=textures),
                             white], textures=[mask, np.full((4, 4, 4), RADIANCE, np.float32)]),
        wrt.Scene(meshes=[quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1),
                          quad((-0.25, 0, HEIGHT), (0.5, 0, 0), (0, 1, 0), name="/lamp", material=0)],
                  materials=[Material(path="/Glow", diffuse_color=0.0, emissive_color=np.full(3, RADIANCE)), white])]
    camera = top_down_camera(center=(0, 2.0, 0), height=2.0)
    images = [wrt.render(scene, camera=camera, width=8, height=8, spp=32, seed=1, integrator=integrator,
                         device="cpu").rgb for scene in scenes]
    assert images[0].mean() == pytest.approx(images[1].mean(), rel=0.03)


@pytest.mark.parametrize("side", [4, 3])
def test_a_udim_tile_of_rgb_texels_is_estimated_by_its_texels(side):
    """A triangle on UDIM tile 1001, whose image is built in Python as ``(H, W, 3)`` (``side`` x ``side``), black but
    for one texel of ``side * side`` at st ``(0, 1)``, which none of the points its glow is read at reaches: its
    estimate is the tile's mean, 1 per channel, as a lamp triangle of constant glow 1 beside it, so the two take
    the same share of the light picks (half uniform, half by power: 0.5 each, computed by hand). The tile's mean was
    taken of the raw ``(H, W, 3)`` array read as RGBA rows: channels mixed (4/3 here for a 4 x 4 image: 0.536 of the
    picks), or a ``ValueError`` (cannot reshape) that stopped every render of a 3 x 3 one."""
    texels = np.zeros((side, side, 3), np.float32)
    texels[0, 0] = side * side  # row 0 is the top of the image: t near 1
    triangle = np.array([[0, 1, 2]])
    corners = np.array([[0, 0, HEIGHT], [1, 0, HEIGHT], [1, 1, HEIGHT]], np.float64)
    meshes = [wrt.Mesh("/part", corners, triangle, [0], uvs=np.float32([[[0, 0], [1, 0], [1, 1]]]),
                       material_ids=np.zeros(1, np.int32)),
              wrt.Mesh("/lamp", corners + [3, 0, 0], triangle, [0], material_ids=np.ones(1, np.int32))]
    materials = [Material(path="/Glow", diffuse_color=0.0,
                          textures={"emissiveColor": TextureInput(image=0, tiles=udim_table(t1001=0))}),
                 Material(path="/Lamp", emissive_color=np.ones(3, np.float32))]
    pmf = triangle_pmf(wrt.Scene(meshes=meshes, materials=materials, textures=[texels]))
    np.testing.assert_allclose(pmf, [0.5, 0.5], rtol=1e-6)


def half_lamp_irradiance(points: np.ndarray, radiance: float, n: int = 400) -> np.ndarray:
    """Irradiance at floor ``points`` (``(P, 2)``) from the right half of :func:`two_tile_lamp` (x in [0, 1], y in
    [-0.5, 0.5], at :data:`HEIGHT`) emitting ``radiance``: the midpoint rule (float64) of ``cos cos' / r^2``."""
    s = (np.arange(n) + 0.5) / n
    x, y = (c.ravel() for c in np.meshgrid(s, s - 0.5))
    r2 = (x[None] - points[:, :1]) ** 2 + (y[None] - points[:, 1:]) ** 2 + HEIGHT * HEIGHT
    return radiance * (HEIGHT * HEIGHT / (r2 * r2)).sum(axis=1) / (n * n)


@pytest.mark.parametrize("dark", ["black udim tile", "material without glow"])
def test_an_instanced_normalized_mesh_light_is_divided_by_its_whole_area(dark):
    """A normalized mesh light (``materialGlowTintsLight``, colour 4) on :func:`two_tile_lamp` (area 2), drawn by one
    instance of a prototype, whose left half does not glow (its triangles on a black UDIM tile, or of a material
    without glow): its right half has radiance 4 / 2, its whole area's, and lights the floor as the quadrature says
    (within 3% at 16 samples under whitted), as the same lamp in the world does. An instance divided the colour by
    the area of the triangles that glow alone: twice as bright (reached by textured lamps once the triangles on a
    black tile took an estimate of 0 and left the light table)."""
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    if dark == "black udim tile":
        glow = Material(path="/Glow", diffuse_color=0.0, textures={
            "emissiveColor": TextureInput(image=0, tiles=udim_table(t1001=0, t1002=1))})
        ids = [0, 0, 0, 0]
    else:
        glow = Material(path="/Glow", diffuse_color=0.0, emissive_color=np.ones(3, np.float32))
        ids = [2, 2, 0, 0]
    lamp = two_tile_lamp(ids)
    light = wrt.MeshLight("/lamp", color=np.full(3, 4.0), normalize=True, material_sync="materialGlowTintsLight")
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1)
    shared = dict(materials=[glow, white, Material(path="/Dark", diffuse_color=0.0)], lights=[light],
                  textures=[BLACK, np.ones((4, 4, 4), np.float32)])
    scenes = [wrt.Scene(meshes=[floor], prototypes=[wrt.Prototype("/P", [lamp])],
                        instances=wrt.Instances.from_transforms(np.zeros(1), np.eye(4)[None]), **shared),
              wrt.Scene(meshes=[floor, lamp], **shared)]
    center, height, res = (0.0, 2.0, 0.0), 2.0, 8
    images = [wrt.render(scene, camera=top_down_camera(center=center, height=height), width=res, height=res, spp=16,
                         seed=1, device="cpu").rgb.mean(axis=2) for scene in scenes]
    points = pixel_points(center, height, res, res)[..., :2].reshape(-1, 2)
    want = half_lamp_irradiance(points, 4.0 / 2.0).mean() / np.pi
    assert images[0].mean() == pytest.approx(want, rel=0.03)
    assert images[1].mean() == pytest.approx(want, rel=0.03)


def half_lit_lamp(s_ranges, material_ids) -> wrt.Mesh:
    """A lamp of two unit squares side by side at :data:`HEIGHT` (two triangles each), the first's ``s`` over
    ``s_ranges[0]``, the second's over ``s_ranges[1]`` (``t`` over [0, 1]), of device-material ``material_ids``."""
    uvs = []
    for s0, s1 in s_ranges:
        corners = np.float32([[s0, 0], [s1, 0], [s1, 1], [s0, 1]])
        uvs += [corners[[0, 1, 2]], corners[[0, 2, 3]]]
    return wrt.Mesh("/lamp", np.array([[x - 1.0, y - 0.5, HEIGHT] for y in (0, 1) for x in (0, 1, 2)], np.float64),
                    np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]), [0, 0, 1, 1], uvs=np.stack(uvs),
                    material_ids=np.asarray(material_ids, np.int32), double_sided=True)


# 4 rows of 16 texels: columns 0-7 black, 8-15 of RADIANCE (alpha 1)
HALF_LIT = np.concatenate([np.zeros((4, 8, 4), np.float32), np.full((4, 8, 4), RADIANCE, np.float32)], axis=1)
HALF_LIT[..., 3] = 1.0


def test_triangles_over_the_black_texels_of_an_emission_image_take_no_light_picks():
    """A lamp whose emission image is black on its left half and :data:`RADIANCE` on its right (clamped), the first
    square's ``s`` over [0, 0.25] (columns 0-4 read, bilinear: all black), the second's over [0.75, 1]: the first's
    triangles, which glow nowhere, take no light picks, as the same lamp with them of a material without glow (the
    oracle) gives them, and the floor renders as under it. They had the image's mean as their estimate (half the
    picks, all wasted)."""
    texture = TextureInput(image=0, wrap=("clamp", "clamp"))
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1)
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    glow = Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": texture})
    ranges = [(0.0, 0.25), (0.75, 1.0)]
    textured = wrt.Scene(meshes=[floor, half_lit_lamp(ranges, [0, 0, 0, 0])], textures=[HALF_LIT],
                         materials=[glow, white])
    plain = wrt.Scene(meshes=[floor, half_lit_lamp(ranges, [2, 2, 0, 0])], textures=[HALF_LIT],
                      materials=[glow, white, Material(path="/Dark", diffuse_color=0.0)])
    np.testing.assert_allclose(triangle_pmf(textured), triangle_pmf(plain), rtol=1e-6, atol=1e-12)
    camera = top_down_camera(center=(0, 2.0, 0), height=2.0)
    images = [wrt.render(scene, camera=camera, width=8, height=8, spp=16, seed=1, device="cpu").rgb
              for scene in (textured, plain)]
    assert images[1].mean() > 0.0
    np.testing.assert_allclose(images[0], images[1], rtol=1e-6)


@pytest.mark.parametrize("case", ["reaches a bright texel by filtering", "wraps onto the bright texels"])
def test_a_triangle_whose_filtered_texels_glow_keeps_its_light_picks(case):
    """The lamp of the test above, its first square's ``s`` over [0.25, 0.5] (clamped: bilinear filtering near
    s = 0.5 mixes in column 8, which glows) or over [0, 0.25] under ``repeat`` (filtering near s = 0 mixes in column
    15 across the seam): its triangles glow there, so they keep light picks."""
    wrap, ranges = {"reaches a bright texel by filtering": ("clamp", [(0.25, 0.5), (0.75, 1.0)]),
                    "wraps onto the bright texels": ("repeat", [(0.0, 0.25), (0.75, 1.0)])}[case]
    texture = TextureInput(image=0, wrap=(wrap, wrap))
    glow = Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": texture})
    pmf = triangle_pmf(wrt.Scene(meshes=[half_lit_lamp(ranges, [0, 0, 0, 0])], textures=[HALF_LIT], materials=[glow]))
    assert (pmf > 0.0).all(), pmf


# 4 rows of 16 texels: columns 0-7 holes (opacity 0), 8-15 opaque (1)
HALF_OPAQUE = np.concatenate([np.zeros((4, 8, 4), np.float32), np.ones((4, 8, 4), np.float32)], axis=1)


@pytest.mark.parametrize("glow", ["constant", "textured"])
def test_triangles_all_in_holes_of_a_cut_out_glow_take_no_light_picks(glow):
    """A glowing card cut out by an opacity image (threshold 0.5, clamped) whose left half is holes, its first
    square's ``s`` over [0, 0.25] (columns 0-4 read: all holes), the second's over [0.75, 1]; its glow constant
    (:data:`RADIANCE`) or an image of it. The first's triangles, which emit nothing (rays pass them, light samples
    there skip them), take no light picks, as the same card with them of a material without glow gives them (the
    oracle), and the floor renders as under it. They took half the picks, all wasted."""
    emission = ({"emissive_color": np.full(3, RADIANCE, np.float32)} if glow == "constant"
                else {"textures": {"emissiveColor": TextureInput(image=1)}})
    cut = Material(path="/Card", diffuse_color=0.0, opacity_threshold=0.5, **emission)
    cut.textures = {**cut.textures, "opacity": TextureInput(image=0, channel="r", wrap=("clamp", "clamp"))}
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor", material=1)
    white = Material(path="/White", diffuse_color=1.0, use_specular_workflow=True)  # Lambertian: no specular
    ranges = [(0.0, 0.25), (0.75, 1.0)]
    textures = [HALF_OPAQUE, np.full((4, 4, 4), RADIANCE, np.float32)]
    holed = wrt.Scene(meshes=[floor, half_lit_lamp(ranges, [0, 0, 0, 0])], textures=textures, materials=[cut, white])
    plain = wrt.Scene(meshes=[floor, half_lit_lamp(ranges, [2, 2, 0, 0])], textures=textures,
                      materials=[cut, white, Material(path="/Dark", diffuse_color=0.0)])
    np.testing.assert_allclose(triangle_pmf(holed), triangle_pmf(plain), rtol=1e-6, atol=1e-12)
    camera = top_down_camera(center=(0, 2.0, 0), height=2.0)
    images = [wrt.render(scene, camera=camera, width=8, height=8, spp=16, seed=1, device="cpu").rgb
              for scene in (holed, plain)]
    assert images[1].mean() > 0.0
    np.testing.assert_allclose(images[0], images[1], rtol=1e-6)


def test_a_cut_out_glow_whose_tiny_opacity_texels_read_opaque_on_the_device_keeps_its_light_picks():
    """A glowing card cut out by an opacity image scaled by 1e4 (threshold 1.1e-3), its left half of texels 1.05e-7:
    the device stores them as float16 subnormals, 1.19e-7 (np.float16, the oracle), read 1.19e-3, opaque. The host's
    slack for the float16 rounding was relative alone (2^-9 of the value, plus 2^-20), far under a subnormal's step
    (6e-8 x 1e4): it took them for holes, and the left triangles, which glow, took no light picks. They take as
    many as the same card not cut out."""
    texel, scale, threshold = 1.05e-7, 1.0e4, 1.1e-3
    assert float(np.float16(np.float32(texel))) * scale >= threshold  # the device reads them opaque
    opacity = np.concatenate([np.full((4, 8, 4), texel, np.float32), np.ones((4, 8, 4), np.float32)], axis=1)
    scales = np.float32([scale, 1.0, 1.0, 1.0])
    ranges = [(0.0, 0.25), (0.75, 1.0)]

    def card(cut: bool) -> wrt.Scene:
        glow = Material(path="/Card", diffuse_color=0.0, emissive_color=np.full(3, RADIANCE, np.float32),
                        opacity_threshold=threshold if cut else 0.0,
                        textures={"opacity": TextureInput(image=0, channel="r", wrap=("clamp", "clamp"), scale=scales)})
        return wrt.Scene(meshes=[half_lit_lamp(ranges, [0, 0, 0, 0])], textures=[opacity], materials=[glow])

    np.testing.assert_allclose(triangle_pmf(card(True)), triangle_pmf(card(False)), rtol=1e-6)


def test_a_cut_out_glow_whose_black_wrap_reads_opaque_outside_its_image_keeps_its_light_picks():
    """A glowing card cut out by an inverted opacity image (scale -1, bias 1, threshold 0.5) of texels 1, wrap
    ``black``: inside [0, 1] it reads 1 * -1 + 1 = 0, holes; outside, ``black`` gives the texel 0 (UsdUVTexture's
    wrap mode, before scale and bias), read 0 * -1 + 1 = 1, opaque. The first square's ``s`` over [-1, 0] lies
    outside: its triangles glow, and take the picks of the same square of the glow not cut out (the oracle; the
    second square, over [0.25, 0.75], all holes, of a material without glow there). The texels alone, all holes,
    gave them none."""
    opacity = np.ones((4, 4, 4), np.float32)
    texture = TextureInput(image=0, channel="r", wrap=("black", "black"), scale=np.float32([-1, 1, 1, 1]),
                           bias=np.float32([1, 0, 0, 0]))

    def card(threshold: float) -> Material:
        return Material(path="/Card", diffuse_color=0.0, emissive_color=np.full(3, RADIANCE, np.float32),
                        opacity_threshold=threshold, textures={"opacity": texture})

    assert 0.0 * -1.0 + 1.0 >= 0.5  # the black texel, scaled and biased: opaque
    ranges = [(-1.0, 0.0), (0.25, 0.75)]
    cut = wrt.Scene(meshes=[half_lit_lamp(ranges, [0, 0, 0, 0])], textures=[opacity], materials=[card(0.5)])
    plain = wrt.Scene(meshes=[half_lit_lamp(ranges, [0, 0, 1, 1])], textures=[opacity],
                      materials=[card(0.0), Material(path="/Dark", diffuse_color=0.0)])
    pmf = triangle_pmf(cut)
    assert (pmf[:2] > 0.0).all(), pmf
    np.testing.assert_allclose(pmf, triangle_pmf(plain), rtol=1e-6, atol=1e-12)


def shared_image_scene(images: list[np.ndarray]) -> wrt.Scene:
    """A lamp of two squares (two triangles each, ``s`` over [0, 0.25] and [0.75, 1]) per material: two glows of
    image ``images[0]`` (:data:`HALF_LIT`, scales 1 and 2, clamped: the same texels glow) and two constant glows cut
    out by image ``images[-1]`` (threshold 0.5, clamped); a scene of four copies of the image gives each its own."""
    clamp = ("clamp", "clamp")
    scales = [np.float32([1, 1, 1, 1]), np.float32([2, 2, 2, 1])]
    glows = [Material(path=f"/Glow{k}", diffuse_color=0.0,
                      textures={"emissiveColor": TextureInput(image=k % len(images), wrap=clamp, scale=scales[k])})
             for k in range(2)]
    cuts = [Material(path=f"/Card{k}", diffuse_color=0.0, emissive_color=np.full(3, RADIANCE, np.float32),
                     opacity_threshold=0.5,
                     textures={"opacity": TextureInput(image=(k + 2) % len(images), channel="r", wrap=clamp)})
            for k in range(2)]
    lamps = [half_lit_lamp([(0.0, 0.25), (0.75, 1.0)], [m] * 4) for m in range(4)]
    for k, lamp in enumerate(lamps):
        lamp.path = f"/lamp{k}"
        lamp.points = lamp.points + np.float64([0, 2 * k, 0])
    return wrt.Scene(meshes=lamps, materials=glows + cuts, textures=images)


def test_materials_sharing_an_image_share_its_block_table(monkeypatch):
    """Two glows of one emission image (scales 1 and 2: the same texels glow) and two cut-outs of one opacity image
    (the same threshold, channel, scale and bias) make one table each (block_counts called twice, not four times),
    shared; the light picks are those of the same scene whose materials each read their own copy of the image
    (four tables, the oracle). Each of a 4k image took 0.59 s, per material."""
    from wrt import sampled_emission as se

    calls = []

    def counted(marked):
        calls.append(marked.shape)
        return block_counts(marked)

    block_counts = se.block_counts
    monkeypatch.setattr(se, "block_counts", counted)
    pmf_shared = triangle_pmf(shared_image_scene([HALF_LIT]))
    assert len(calls) == 2
    del calls[:]
    pmf_own = triangle_pmf(shared_image_scene([HALF_LIT, HALF_LIT.copy(), HALF_LIT.copy(), HALF_LIT.copy()]))
    assert len(calls) == 4
    np.testing.assert_array_equal(pmf_shared, pmf_own)
    assert (pmf_shared.reshape(4, 4)[:, :2] == 0.0).all() and (pmf_shared.reshape(4, 4)[:, 2:] > 0.0).all()


class FakeTable:
    """A summed-area table said to hold ``size`` entries, holding one (a real one's size, without the gigabytes)."""

    def __init__(self, size: int):
        self.size = size

    def ravel(self) -> np.ndarray:
        return np.zeros(1, np.int32)


def test_block_tables_past_int32_offsets_are_left_out_with_a_warning():
    """Tables of the largest size, (256 + 1)^2 = 66,049 entries: 32,513 fit in the 2^31 - 1 entries an int32 offset
    (and a Warp array) reaches, offsets k * 66,049 (Python integers, the oracle); the 32,514th ends past it and the
    32,520th begins past it (its int32 offset wrapped to -2,147,119,865 before). Those past are left out (row -1:
    their materials drawn by their estimate) with a warning naming the count; a table shared by two materials is
    packed once, at one offset."""
    from wrt.sampled_emission import _packed_maps

    size, fit, count = 257 * 257, (2**31 - 1) // (257 * 257), 32520
    assert fit == 32513
    maps = [None] + [(FakeTable(size), 2) for _ in range(count)]
    with pytest.warns(UserWarning, match=f"{count} block tables .* {count - fit} left out"):
        counts, rows = _packed_maps(maps, len(maps))
    assert rows.dtype == np.int32 and rows.shape == (count + 1, 2)
    np.testing.assert_array_equal(rows[1 : fit + 1, 0], np.arange(fit, dtype=np.int64) * size)
    assert (rows[fit + 1 :, 0] == -1).all() and rows[0, 0] == -1
    shared = (np.arange(6, dtype=np.int32).reshape(2, 3), 4)
    counts, rows = _packed_maps([None, shared, None, shared], 4)
    np.testing.assert_array_equal(counts, np.arange(6))
    np.testing.assert_array_equal(rows, [[-1, 1], [0, 4], [-1, 1], [0, 4]])


@pytest.mark.parametrize("fallback_wrap", [False, True])
def test_an_emission_texture_read_as_rgba_glows_as_read_as_rgb(fallback_wrap):
    """An emission texture of channel ``rgba`` (a UsdUVTexture output TextureInput.check accepts, read as ``rgb`` by
    the device: CHANNELS) gives the light picks it gives as ``rgb`` (the oracle), its texels glowing or, outside [0, 1]
    of a ``fallback`` wrap, its fallback. The estimate and the fallback's glow indexed the fourth-plus-one channel: the
    render failed with IndexError ('index 4 is out of bounds')."""
    wrap = ("fallback", "fallback") if fallback_wrap else ("clamp", "clamp")
    ranges = [(0.0, 0.25), (1.5, 2.0)] if fallback_wrap else [(0.0, 0.25), (0.75, 1.0)]
    pmfs = []
    for channel in ("rgb", "rgba"):
        texture = TextureInput(image=0, channel=channel, wrap=wrap, fallback=FALLBACK)
        glow = Material(path="/Glow", diffuse_color=0.0, textures={"emissiveColor": texture})
        pmfs.append(triangle_pmf(wrt.Scene(meshes=[half_lit_lamp(ranges, [0, 0, 0, 0])], textures=[HALF_LIT],
                                           materials=[glow])))
    assert pmfs[0].sum() > 0.0
    np.testing.assert_array_equal(pmfs[1], pmfs[0])
