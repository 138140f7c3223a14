"""Scenes built in Python, as a robotics or simulation user builds them without USD: the inputs such users pass
(images straight from numpy or Pillow, ...), each compared with an analytic answer or refused naming what is
wrong."""

import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import wrt
from tests.gpu_holders import DLPackOnly, wp_array

SQUARE = np.float32([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
SQUARE_UVS = np.float32([[0, 0], [1, 0], [1, 1], [0, 1]])[[[0, 1, 2], [0, 2, 3]]]
# Looking straight down at the square, which fills the middle of the image.
TOP = wrt.Camera.orthographic((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), height=4.0)


def textured_square(texture) -> wrt.Scene:
    """The unit square with ``texture`` (``scene.textures[0]``) as its diffuseColor, st spanning the image."""
    material = wrt.Material("/Textured", textures={"diffuseColor": wrt.TextureInput(0)})
    mesh = wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int32), uvs=SQUARE_UVS,
                    material_ids=np.zeros(2, np.int32), double_sided=True)
    return wrt.Scene(meshes=[mesh], materials=[material], textures=[texture])


def test_an_rgb_texture_built_in_python_is_read_with_alpha_one():
    """``scene.textures`` documents ``(H, W, 4)`` images, but an ``(H, W, 3)`` one is what numpy and Pillow hand a
    user. It was packed as ``3 H W / 4`` RGBA texels: a 4 x 4 image of one colour rendered other colours and
    uninitialised memory without a word. Oracle: the albedo of a texture of one colour is that colour everywhere on
    the square."""
    color = np.float32([0.25, 0.5, 0.75])
    image = wrt.render(textured_square(np.tile(color, (4, 4, 1))), camera=TOP, width=8, height=8,
                       integrator="albedo")
    on_square = image.aovs["coverage"] > 0.5
    assert on_square.sum() == 16
    np.testing.assert_allclose(image.rgb[on_square], np.broadcast_to(color, (16, 3)), atol=1e-3)


@pytest.mark.parametrize("texture, words", [
    (np.zeros((4, 4), np.float32), "(H, W, 3) or (H, W, 4)"),
    (np.zeros((4, 4, 2), np.float32), "(H, W, 3) or (H, W, 4)"),
    (np.zeros((4, 4, 4), np.uint8), "linear float values, got uint8"),
])
def test_a_texture_of_another_shape_or_dtype_is_refused_naming_it(texture, words):
    """A grey image and a two-channel one stopped at a bare numpy reshape error, an 8-bit one at a casting error
    (converted, its 255 would have been 255 times too bright): now a SceneError names ``scene.textures[0]``."""
    with pytest.raises(wrt.SceneError, match=r"scene\.textures\[0\]") as raised:
        wrt.render(textured_square(texture), camera=TOP, width=4, height=4)
    assert words in str(raised.value)


def test_an_empty_texture_is_refused_instead_of_killing_the_process():
    """A ``(0, 0, 4)`` texture with the default ``repeat`` wrap divided by zero in the lookup: the process died of
    SIGFPE on the CPU. Run in a child process, so that a crash fails this test only."""
    code = textwrap.dedent("""
        import numpy as np
        import wrt
        from tests.test_python_scenes import TOP, textured_square
        try:
            wrt.render(textured_square(np.zeros((0, 0, 4), np.float32)), camera=TOP, width=4, height=4)
        except wrt.SceneError as e:
            print("refused:", e)
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "refused: scene.textures[0] must be an (H, W, 3) or (H, W, 4) image of at least one texel" in done.stdout


def square_mesh(path: str = "/Proto/Square") -> wrt.Mesh:
    return wrt.Mesh(path, SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int32))


ONE_INSTANCE = dict(instances=wrt.Instances.from_transforms([0], np.eye(4)[None]))


@pytest.mark.parametrize("fields, words", [
    (lambda: dict(prototypes=[wrt.Prototype("/Proto", square_mesh())], **ONE_INSTANCE),
     r"scene\.prototypes\[0\]\.meshes takes a list of wrt\.Mesh, got Mesh"),
    (lambda: dict(prototypes=[wrt.Prototype("/Proto", [SQUARE])], **ONE_INSTANCE),
     r"scene\.prototypes\[0\]\.meshes\[0\] is a ndarray, not a wrt\.Mesh"),
    (lambda: dict(prototypes=[[square_mesh()]], **ONE_INSTANCE),
     r"scene\.prototypes\[0\] is a list, not a wrt\.Prototype"),
    (lambda: dict(prototypes=[wrt.Prototype("/Proto", [square_mesh()])], instances=np.eye(4)[None]),
     r"scene\.instances is a ndarray, not a wrt\.Instances"),
    (lambda: dict(shapes=[square_mesh()]), r"scene\.shapes\[0\] is a Mesh, not a wrt\.Shape"),
    (lambda: dict(materials=[{"diffuse_color": (1, 0, 0)}]), r"scene\.materials\[0\] is a dict, not a wrt\.Material"),
    (lambda: dict(cameras={"/Camera": (0.0, 0.0, 5.0)}), r"scene\.cameras\['/Camera'\] is a tuple, not a wrt\.Camera"),
    (lambda: dict(lights=[wrt.Shaping()]), r"^scene\.lights\[0\] is a Shaping, not a wrt light \(one of "
                                           r"wrt\.DistantLight, wrt\.SphereLight, .*wrt\.MeshLight\)$"),
    (lambda: dict(lights=[None]), r"^scene\.lights\[0\] is a NoneType, not a wrt light"),
])
def test_a_scene_part_of_the_wrong_type_is_refused_naming_it(fields, words):
    """Each of these failed at the scene's construction or its first render with an error naming none of them: an
    ``AttributeError`` ('list' object has no attribute 'meshes', 'numpy.ndarray' object has no attribute
    'check_affine', 'dict' object has no attribute '__dict__', 'tuple' object has no attribute 'to_struct'), "'Mesh'
    object is not iterable", "must be called with a dataclass type or instance" or "unsupported light Shaping"; a
    shape that is no Shape was even taken. Now Scene refuses it at once, naming the entry."""
    with pytest.raises(TypeError, match=words):
        scene = wrt.Scene(meshes=[square_mesh("/Ground")], **fields())
        wrt.render(scene, width=4, height=3)


def test_a_part_replaced_by_one_of_the_wrong_type_is_refused_at_the_next_render():
    """The same check runs again when the scene's parts change, as the mesh list's does."""
    scene = wrt.Scene(meshes=[square_mesh("/Ground")], prototypes=[wrt.Prototype("/Proto", [square_mesh()])],
                      **ONE_INSTANCE)
    wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])
    scene.prototypes[0].meshes.append(SQUARE)
    with pytest.raises(TypeError, match=r"scene\.prototypes\[0\]\.meshes\[1\] is a ndarray, not a wrt\.Mesh"):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])


def test_a_light_appended_of_the_wrong_type_is_refused_at_the_next_render():
    """The same for an entry appended to ``scene.lights`` after a render, by a kept Renderer and a new render alike
    (it failed with 'unsupported light NoneType', naming no entry)."""
    scene = wrt.Scene(meshes=[square_mesh("/Ground")], lights=[wrt.DistantLight((0, 0, -1), (1, 1, 1))])
    renderer = wrt.Renderer(scene, camera=TOP, width=4, height=4)
    renderer.render()
    scene.lights.append(None)
    with pytest.raises(TypeError, match=r"^scene\.lights\[1\] is a NoneType, not a wrt light"):
        renderer.render()
    with pytest.raises(TypeError, match=r"^scene\.lights\[1\] is a NoneType, not a wrt light"):
        wrt.render(scene, camera=TOP, width=4, height=4)


def test_a_mesh_without_face_ids_is_a_face_per_triangle_everywhere():
    """``Mesh(path, points, indices, None)`` is taken and renders, but ``hit_paths`` and ``hit_prims`` then failed with
    numpy's "all the input arrays must have same number of dimensions", and so did a render of a single-sided mesh
    with a coincident reversed twin (a wall's two sides as two meshes). Oracle: the same scene with ``face_ids =
    arange(T)``, each triangle its own face, as ``Scene.from_triangles`` makes it."""
    indices = np.int32([[0, 1, 2], [0, 2, 3]])

    def twins(face_ids) -> wrt.Scene:
        return wrt.Scene(meshes=[wrt.Mesh("/Front", SQUARE, indices, face_ids),
                                 wrt.Mesh("/Back", SQUARE, indices[:, ::-1].copy(), face_ids)])

    camera = wrt.Camera.look_at((0.3, -0.2, 4.0), (0.0, 0.0, 0.0))
    origins, directions = [[0.5, -0.5, 5.0], [-0.5, 0.5, -5.0], [3.0, 3.0, 5.0]], [[0, 0, -1], [0, 0, 1], [0, 0, -1]]
    for face_ids in (None, np.arange(2)):
        scene = twins(face_ids)
        hits = wrt.trace(scene, origins, directions)
        prims, instances = scene.hit_paths(hits)
        # Equal t on both twins goes to the smaller triangle id, the front's; (0.5, -0.5) is in its triangle 0.
        assert prims.tolist() == ["/Front", "/Front", ""] and instances.tolist() == ["", "", ""]
        _, elements = scene.hit_prims(hits.local_prim, hits.instance)
        assert elements.tolist() == [0, 1, -1]
    np.testing.assert_array_equal(wrt.render(twins(None), camera=camera, width=8, height=6).rgb,
                                  wrt.render(twins(np.arange(2)), camera=camera, width=8, height=6).rgb)


BOX_POINTS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
BOX_INDICES = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4], [2, 6, 3], [3, 6, 7],
                        [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_an_instance_flattened_by_a_zero_scale_is_drawn_flat_as_its_baked_mesh_is(accel):
    """An instance built in Python whose transform squashes its box into a plane (z scale 0) vanished without a word
    from every accelerator, though the same box baked flat into a mesh is drawn, and so is a USD instance so scaled
    (the loader gives it a thickness of ``FLAT_THICKNESS`` of its size). Oracle: the box's points times the
    transform, a square at z = 0.3, hit from both sides within that thickness."""
    to_world = np.eye(4)[None].copy()
    to_world[0, 2, 2], to_world[0, 2, 3] = 0.0, 0.3
    prototype = wrt.Prototype("/Box", [wrt.Mesh("/Box/Mesh", BOX_POINTS, BOX_INDICES, None)])
    scene = wrt.Scene(prototypes=[prototype], instances=wrt.Instances.from_transforms([0], to_world))
    origins = [[0.1, 0.2, 5.0], [-0.3, 0.4, -5.0], [0.7, 0.0, 5.0]]
    directions = [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]
    hits = wrt.trace(scene, origins, directions, accel=accel)
    np.testing.assert_allclose(hits.t, [4.7, 5.3, np.inf], atol=1e-3)
    assert hits.instance.tolist() == [0, 0, -1]
    # Flattened after an invalidate() too, the transform edited in place.
    scene.invalidate()
    scene.instances.to_world[0, 2, 3] = -0.2
    np.testing.assert_allclose(wrt.trace(scene, origins, directions, accel=accel).t, [5.2, 4.8, np.inf], atol=1e-3)


def test_a_shape_given_a_row_vector_transform_is_refused_and_a_flat_one_is_drawn_flat():
    """``wrt.Shape`` took a ``Gf.Matrix4d``-style transform (translation in the bottom row) and drew a sheared shape at
    the origin without a word, where instances, lights and cameras refuse one; and a sphere flattened by a zero z
    scale vanished, though the USD loader draws such a gprim thin. Oracle: the unit sphere moved to x = 0.5 and
    squashed flat is the disc of radius 1 there, at z = 0."""
    from wrt.primitives import Shape

    to_world = np.eye(4)
    to_world[0, 3] = 0.5
    with pytest.raises(ValueError, match=r"shape /Ball to_world has bottom row \[0.5, 0.0, 0.0, 1.0\]"):
        Shape("/Ball", "sphere", to_world.T)
    to_world[2, 2] = 0.0
    origins = [[0.5, 0.0, 5.0], [0.5, 0.9, -5.0], [1.4, 0.0, 5.0], [1.6, 0.0, 5.0]]
    directions = [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]]
    hits = wrt.trace(wrt.Scene(shapes=[Shape("/Ball", "sphere", to_world)]), origins, directions)
    np.testing.assert_allclose(hits.t, [5.0, 5.0, 5.0, np.inf], atol=1e-3)


# The square of two triangles with two points no triangle uses: 6 points, as many as the triangles' corners.
SQUARE_AND_TWO = np.concatenate([SQUARE, np.float32([[5, 5, 5], [6, 6, 6]])])


def linear_color(p: np.ndarray) -> np.ndarray:
    return np.stack([0.5 + 0.2 * p[..., 0], 0.5 + 0.3 * p[..., 1], 0.4 + 0.1 * p[..., 2]], -1)


def linear_normal(p: np.ndarray) -> np.ndarray:
    return np.stack([0.3 * p[..., 0], 0.2 * p[..., 1], np.ones(p.shape[:-1])], -1)


def test_per_vertex_normals_and_colors_are_read_per_vertex_when_there_are_as_many_points_as_corners():
    """``(V, 3)`` normals and colours, one per point, were taken for ``(T, 3, 3)`` corners flattened whenever ``V``
    happened to equal ``3T`` (and refused otherwise), so this square drew scrambled colours and normals without a
    word. A row per point is now read per point, with a warning where the corners reading would differ. Oracle:
    colours and normals linear in the position interpolate to that linear function at each pixel's hit point (the
    camera ray meeting z = 0), the normal divided by its length."""
    from wrt.rays import camera_rays

    with pytest.warns(UserWarning) as warned:
        mesh = wrt.Mesh("/Square", SQUARE_AND_TWO, np.int32([[0, 1, 2], [0, 2, 3]]), None, double_sided=True,
                        colors=linear_color(SQUARE_AND_TWO), normals=linear_normal(SQUARE_AND_TWO))
    assert [str(w.message) for w in warned] == [
        f"/Square: {name} of shape (6, 3) have a row per point and per triangle corner (2 triangles): read as one per "
        "point; pass one per corner as (2, 3, 3)" for name in ("normals", "colors")]
    scene = wrt.Scene(meshes=[mesh])
    image = wrt.render(scene, camera=TOP, width=8, height=8, integrator="albedo")
    origins, directions = camera_rays(scene, TOP, 8, 8)
    hit = (origins - origins[:, 2:] / directions[:, 2:] * directions).reshape(8, 8, 3)
    on_square = image.aovs["coverage"] > 0.5
    assert on_square.sum() == 16
    np.testing.assert_allclose(image.rgb[on_square], linear_color(hit)[on_square], atol=1e-5)
    normal = linear_normal(hit)
    np.testing.assert_allclose(image.aovs["normal"][on_square],
                               (normal / np.linalg.norm(normal, axis=-1, keepdims=True))[on_square], atol=1e-5)


def test_per_vertex_uvs_and_opacities_are_gathered_into_corners_and_a_triangle_soup_warns_of_nothing():
    """``(V, 2)`` texture coordinates and ``(V,)`` opacities are one per point as well; for a triangle soup (every
    triangle its own three points, ``indices = arange(3T)``) both readings agree, so nothing is said. Oracle: the
    values indexed by the triangles' corners in numpy."""
    import warnings

    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    uvs, opacities = SQUARE_AND_TWO[:, :2] * 0.5 + 0.5, np.linspace(0.0, 1.0, 6, dtype=np.float32)
    with pytest.warns(UserWarning) as warned:
        mesh = wrt.Mesh("/Square", SQUARE_AND_TWO, indices, None, uvs=uvs, opacities=opacities)
    assert ["opacities of shape (6,)" in str(warned[0].message), "uvs of shape (6, 2)" in str(warned[1].message)] == [
        True, True]
    np.testing.assert_array_equal(mesh.uvs, uvs[indices])
    np.testing.assert_array_equal(mesh.opacities, opacities[indices])
    soup = SQUARE[indices].reshape(-1, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh = wrt.Mesh("/Soup", soup, np.arange(6, dtype=np.int32).reshape(2, 3), None, colors=linear_color(soup))
    np.testing.assert_array_equal(mesh.colors, linear_color(soup).astype(np.float32).reshape(2, 3, 3))
    # Given one per corner, as before, they stay as given.
    corners = linear_color(SQUARE)[indices].astype(np.float32)
    np.testing.assert_array_equal(wrt.Mesh("/Square", SQUARE_AND_TWO, indices, None, colors=corners).colors, corners)
    # One per triangle (face normals) is neither, and the refusal names both shapes taken.
    with pytest.raises(wrt.SceneError, match=r"^/Square: normals must have shape \(2, 3, 3\), one entry per triangle "
                                             r"\(or \(6, 3\), one per point\); got \(2, 3\)"):
        wrt.Mesh("/Square", SQUARE_AND_TWO, indices, None, normals=np.zeros((2, 3)))


def box_instancer(tmp_path, scales, positions):
    """A stage of one PointInstancer placing the box at ``positions``, scaled by ``scales``."""
    from tests.usda_text import fmt, write

    return write(tmp_path, f"""
def PointInstancer "PI"
{{
    rel prototypes = [</PI/Box>]
    int[] protoIndices = {[0] * len(positions)}
    point3f[] positions = {fmt(positions)}
    float3[] scales = {fmt(scales)}
    def Mesh "Box"
    {{
        point3f[] points = {fmt(BOX_POINTS)}
        int[] faceVertexCounts = {[3] * len(BOX_INDICES)}
        int[] faceVertexIndices = {BOX_INDICES.reshape(-1).tolist()}
    }}
}}
""")


def test_an_instance_scaled_to_a_line_or_a_point_warns_as_the_usd_loader_does(tmp_path):
    """Instances built in Python whose transform leaves fewer than two directions (scaled to a line or a point) draw
    nothing, but vanished without the warning that ``load_usd`` gives for the same PointInstancer instances. Oracle:
    the USD twin of the scene (a PointInstancer of the same box and scales) loaded by ``load_usd``: the same reason,
    the same instance indices, and the same hits (the flat one drawn, the others not)."""
    import warnings

    scales = [(1.0, 1.0, 1.0), (1.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)]
    positions = [(3.0 * k, 0.0, 0.0) for k in range(4)]
    stage = box_instancer(tmp_path, scales, positions)
    with warnings.catch_warnings(record=True) as from_usd:
        warnings.simplefilter("always")
        twin = wrt.load_usd(stage)
    to_world = np.stack([np.diag([*s, 1.0]) for s in scales])
    to_world[:, :3, 3] = positions
    prototype = wrt.Prototype("/PI/Box", [wrt.Mesh("/PI/Box", BOX_POINTS, BOX_INDICES, None)])
    with warnings.catch_warnings(record=True) as from_python:
        warnings.simplefilter("always")
        scene = wrt.Scene(prototypes=[prototype], instances=wrt.Instances.from_transforms([0] * 4, to_world, "/PI"))
    usd_lines = [str(w.message) for w in from_usd if "singular" in str(w.message)]
    python_lines = [str(w.message) for w in from_python]
    assert usd_lines == [f"{stage}: instances with a singular transform (a zero scale) were skipped: 2 prim(s): "
                         "/PI[2], /PI[3]"]
    assert python_lines == ["scene: instances with a singular transform (a zero scale) were skipped: 2 prim(s): "
                            "/PI[2], /PI[3]"]
    origins = [[3.0 * k, 0.0, 5.0] for k in range(4)]
    directions = [[0.0, 0.0, -1.0]] * 4
    for accel in ("wrt", "warp"):
        np.testing.assert_allclose(wrt.trace(scene, origins, directions, accel=accel).t,
                                   wrt.trace(twin, origins, directions, accel=accel).t, atol=1e-3)


@pytest.mark.parametrize("path", [5, None, b"/Square", "pathlib"])
def test_a_mesh_path_that_is_no_string_is_refused_naming_the_mesh(path):
    """An int, None, bytes or a ``pathlib`` path was taken as a mesh's path: ``hit_paths`` and ``prim_paths`` then
    handed that object back (``[5]``) and a message joining paths failed with "expected str instance, int found" far
    from the mistake. Refused with a TypeError naming the mesh, at construction and when assigned later."""
    import pathlib

    path = pathlib.PurePosixPath("/Square") if path == "pathlib" else path
    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    with pytest.raises(TypeError, match=r"^wrt\.Mesh of 4 points and 2 triangles: path must be a str, a prim path "
                                        r"such as '/World/Mesh', got "):
        wrt.Mesh(path, SQUARE, indices, None)
    scene = wrt.Scene(meshes=[wrt.Mesh("/Square", SQUARE, indices, None)])
    scene.meshes[0].path = path
    with pytest.raises(TypeError, match=r"wrt\.Mesh of 4 points and 2 triangles: path must be a str"):
        wrt.trace(scene, [0.5, -0.5, 5.0], [0.0, 0.0, -1.0])


def test_an_sdf_path_or_numpy_string_is_taken_as_the_path_it_names():
    """``Sdf.Path`` (what a USD user holds) and ``np.str_`` (a path from a numpy array of names) mean the path they
    name: stored as a ``str``, so hit paths compare and print as strings. Oracle: the plain string."""
    from pxr import Sdf

    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    for path in (Sdf.Path("/World/Square"), np.str_("/World/Square")):
        scene = wrt.Scene(meshes=[wrt.Mesh(path, SQUARE, indices, None)])
        prims, _ = scene.hit_paths(wrt.trace(scene, [0.5, -0.5, 5.0], [0.0, 0.0, -1.0]))
        assert type(scene.meshes[0].path) is str and prims.tolist() == ["/World/Square"]
        assert type(prims[0]) is str


@pytest.mark.parametrize("make, what", [
    (lambda: wrt.primitives.Shape(5, "sphere", np.eye(4)), "wrt.Shape 'sphere'"),
    (lambda: wrt.Prototype(5, [wrt.Mesh("/P/Square", SQUARE, np.int32([[0, 1, 2]]), None)]), "wrt.Prototype"),
    (lambda: wrt.Material(5), "wrt.Material"),
    (lambda: wrt.SphereLight(position=(0, 0, 1), radius=0.1, color=(1, 1, 1), path=5), "wrt.SphereLight"),
    (lambda: wrt.DistantLight((0, 0, -1), (1, 1, 1), path=b"/Sun"), "wrt.DistantLight"),
    (lambda: wrt.Instances.from_transforms([0], np.eye(4)[None], name=5), "wrt.Instances.from_transforms"),
    (lambda: wrt.MeshLight("/Glow", (1, 1, 1), mesh=5), "wrt.MeshLight /Glow mesh"),
])
def test_other_scene_parts_refuse_a_path_that_is_no_string(make, what):
    """The same for shapes, prototypes, materials, lights and instances' names, and a MeshLight's ``mesh`` (5 was
    refused only at the render, as "MeshLight names no mesh of the scene"); a light's path and a MeshLight's ``mesh``
    stay optional."""
    with pytest.raises(TypeError, match=rf"^{re.escape(what)}: path must be a str"):
        make()
    assert wrt.DistantLight((0, 0, -1), (1, 1, 1), path=None).path == ""
    assert wrt.MeshLight("/Glow", (1, 1, 1), mesh=None).mesh_path == "/Glow"


@pytest.mark.parametrize("radius", [0.0, 1e-30])
def test_a_normalized_sphere_light_of_no_size_is_the_point_light_the_usd_loader_makes_of_it(tmp_path, radius):
    """``SphereLight(radius=0, normalize=True)`` built in Python lit nothing (its radiance ``color / area`` is 0 for no
    area, inf past float32 for a tiny one), while ``load_usd`` draws the same UsdLux light as the point light it tends
    to (intensity ``color / 4``). Oracle: the render of the USD twin, and the point light's analytic irradiance at the
    square's centre straight below, ``E = (color / 4) / d^2``, seen as ``albedo E / pi``."""
    from tests.usda_text import fmt, write

    stage = write(tmp_path, f"""
def Mesh "Square"
{{
    point3f[] points = {fmt(SQUARE)}
    int[] faceVertexCounts = [3, 3]
    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
    uniform bool doubleSided = 1
}}
def SphereLight "Light"
{{
    float inputs:radius = {radius!r}
    float inputs:intensity = 10
    bool inputs:normalize = 1
    double3 xformOp:translate = (0, 0, 2)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
""")
    light = wrt.SphereLight((0.0, 0.0, 2.0), radius, (10.0, 10.0, 10.0), normalize=True, path="/Light")
    scene = wrt.Scene(meshes=[wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), None, double_sided=True)],
                      lights=[light])
    camera = wrt.Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    image = wrt.render(scene, camera=camera, width=9, height=9).rgb
    np.testing.assert_allclose(image, wrt.render(wrt.load_usd(stage), camera=camera, width=9, height=9).rgb,
                               rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(image[4, 4], 0.5 * (10.0 / 4.0) / 2.0**2 / np.pi, rtol=1e-3)


@pytest.mark.parametrize("name, ids, words", [
    ("material_ids", np.int64([2**32, 2**32]), r"material_ids must fit in int32; entry 0 is 4294967296"),
    ("material_ids", [0.7, 0.7], r"material_ids must be integers; entry 0 is 0.7"),
    ("material_ids", ["red", "red"], r"material_ids must be integers, got dtype <U3"),
    ("face_ids", np.int64([0, 2**40]), r"face_ids must fit in int32; entry 1 is 1099511627776"),
    ("face_ids", [0.0, np.nan], r"face_ids must be integers; entry 1 is nan"),
])
def test_face_and_material_ids_that_are_no_int32_integers_are_refused(name, ids, words):
    """Material index 2**32 wrapped round to 0 and drew the first material, 0.7 was cut to 0, and a face id of 2**40
    became 0, each without a word (triangle indices were refused so already). Now a SceneError names the mesh, the
    array and the entry; whole floats (``np.zeros(T)``) still mean the integers they hold. Oracle: the material's
    colour where the ids are whole floats."""
    red = wrt.Material("/Red", diffuse_color=(1.0, 0.0, 0.0))
    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    fields = {"face_ids": None, name: ids}
    with pytest.raises(wrt.SceneError, match=rf"^/Square: {words}"):
        wrt.Mesh("/Square", SQUARE, indices, **fields)
    mesh = wrt.Mesh("/Square", SQUARE, indices, np.zeros(2), material_ids=np.zeros(2), double_sided=True)
    image = wrt.render(wrt.Scene(meshes=[mesh], materials=[red]), camera=TOP, width=8, height=8, integrator="albedo")
    np.testing.assert_allclose(image.rgb[image.aovs["coverage"] > 0.5], np.broadcast_to([1.0, 0.0, 0.0], (16, 3)))


def test_eight_bit_colors_are_refused_and_zero_one_integers_taken():
    """``uint8`` colours of 0-255 (a point cloud's or trimesh's vertex colours) were read as linear values up to 255
    times too bright, without a word, on meshes, instances and shapes alike. Refused naming the object; integer
    colours of 0 and 1 (``[(1, 0, 0)]``) are still the colours they say. Oracle: the albedo of a mesh coloured
    ``(1, 0, 0)`` is red."""
    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    vertex_colors = np.full((4, 3), 255, np.uint8)
    words = r"colors must be linear float values, got uint8 values up to 255 \(8-bit colours: divide by 255"
    with pytest.raises(wrt.SceneError, match=rf"^/Square: {words}"):
        wrt.Mesh("/Square", SQUARE, indices, None, colors=vertex_colors)
    with pytest.raises(ValueError, match=rf"^Instances {words}"):
        wrt.Instances.from_transforms([0], np.eye(4)[None], colors=vertex_colors[:1])
    with pytest.raises(ValueError, match=rf"^shape /Ball: {words}"):
        wrt.primitives.Shape("/Ball", "sphere", np.eye(4), color=vertex_colors[0])
    mesh = wrt.Mesh("/Square", SQUARE, indices, None, colors=np.tile([1, 0, 0], (4, 1)), double_sided=True)
    image = wrt.render(wrt.Scene(meshes=[mesh]), camera=TOP, width=8, height=8, integrator="albedo")
    np.testing.assert_allclose(image.rgb[image.aovs["coverage"] > 0.5], np.broadcast_to([1.0, 0.0, 0.0], (16, 3)))


@pytest.mark.parametrize("holder", ["dlpack", "cuda"])
def test_mesh_arrays_on_a_gpu_are_read_as_rays_are(holder):
    """A simulation's points, triangles, normals and colours held on the GPU (a ``wp.array`` on CUDA, a ``torch``
    tensor) failed in ``wrt.Mesh`` with numpy's refusal ("Warp does not support implicit NumPy conversion for arrays
    on device cuda:0"), where ``wrt.trace`` takes such rays; they are copied to the host as rays are. Oracle: the
    same mesh from numpy arrays, and the square's distance below the ray origin."""
    import warp as wp

    if holder == "cuda" and not wp.is_cuda_available():
        pytest.skip("needs CUDA")
    make = DLPackOnly if holder == "dlpack" else (lambda values: wp_array(values, "cuda:0"))
    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    lifted = SQUARE + np.float32([0.0, 0.0, 1.0])
    colors = linear_color(SQUARE).astype(np.float32)
    mesh = wrt.Mesh("/Square", make(lifted), make(indices), make(np.zeros(2, np.int32)), double_sided=True,
                    normals=make(np.tile(np.float32([0, 0, 1]), (4, 1))), colors=make(colors))
    twin = wrt.Mesh("/Square", lifted, indices, np.zeros(2, np.int32), double_sided=True,
                    normals=np.tile(np.float32([0, 0, 1]), (4, 1)), colors=colors)
    for name in ("points", "indices", "face_ids", "normals", "colors"):
        np.testing.assert_array_equal(getattr(mesh, name), getattr(twin, name))
    assert wrt.trace(wrt.Scene(meshes=[mesh]), [0.5, -0.5, 5.0], [0.0, 0.0, -1.0]).t.tolist() == [4.0]
    mesh.points = make(SQUARE)  # a later frame's points, checked at the next trace
    assert wrt.trace(wrt.Scene(meshes=[mesh]), [0.5, -0.5, 5.0], [0.0, 0.0, -1.0]).t.tolist() == [5.0]


def test_instance_prototype_ids_past_int32_or_not_whole_are_refused():
    """``Instances.from_transforms`` cast its prototype ids to int32 first: 2**32 wrapped round to 0 and drew prototype
    0, and 0.7 was cut to 0, without a word (an id of 1 where there is one prototype is refused). Now a ValueError
    names the entry, from the constructor and for ids assigned later."""
    with pytest.raises(ValueError, match=r"^Instances prototype must fit in int32; entry 0 is 4294967296"):
        wrt.Instances.from_transforms(np.int64([2**32]), np.eye(4)[None])
    with pytest.raises(ValueError, match=r"^Instances prototype must be integers; entry 1 is 0.7"):
        wrt.Instances.from_transforms([0.0, 0.7], np.stack([np.eye(4)] * 2))
    scene = wrt.Scene(prototypes=[wrt.Prototype("/Proto", [square_mesh()])], **ONE_INSTANCE)
    scene.instances.prototype = np.int64([2**32])
    with pytest.raises(ValueError, match=r"^Instances prototype must fit in int32"):
        wrt.trace(scene, [0.5, -0.5, 5.0], [0.0, 0.0, -1.0])


@pytest.mark.parametrize("holder", ["dlpack", "cuda"])
def test_instance_transforms_and_colors_on_a_gpu_are_read(holder):
    """A robot's link poses on the GPU (a ``wp.array`` on CUDA, a ``torch`` tensor) as ``Instances.to_world`` (and
    colours, prototype ids) failed with numpy's refusal; they are copied to the host. Oracle: the square lifted by
    each pose's translation, hit at ``5 - z``, and the colours as given."""
    import warp as wp

    if holder == "cuda" and not wp.is_cuda_available():
        pytest.skip("needs CUDA")
    make = DLPackOnly if holder == "dlpack" else (lambda values: wp_array(values, "cuda:0"))
    to_world = np.stack([np.eye(4)] * 2)
    to_world[:, 2, 3] = 1.0, 2.0
    to_world[1, 0, 3] = 4.0
    instances = wrt.Instances.from_transforms(make(np.zeros(2, np.int32)), make(to_world),
                                              colors=make(np.float32([[0.2, 0.4, 0.6], [1.0, 0.0, 0.0]])))
    scene = wrt.Scene(prototypes=[wrt.Prototype("/Proto", [square_mesh()])], instances=instances)
    hits = wrt.trace(scene, [[0.5, -0.5, 5.0], [4.5, -0.5, 5.0]], [0.0, 0.0, -1.0])
    assert hits.t.tolist() == [4.0, 3.0] and hits.instance.tolist() == [0, 1]
    np.testing.assert_array_equal(scene.instances.colors, np.float32([[0.2, 0.4, 0.6], [1.0, 0.0, 0.0]]))
    to_world[:, 2, 3] = 2.0, 1.0  # the next frame's poses
    scene.instances.to_world = make(to_world)
    assert wrt.trace(scene, [[0.5, -0.5, 5.0], [4.5, -0.5, 5.0]], [0.0, 0.0, -1.0]).t.tolist() == [3.0, 4.0]


def test_a_textured_mesh_without_uvs_reads_the_st_fallback_with_the_loaders_warning():
    """A mesh built without ``uvs`` under a textured material read st = (0, 0), whatever its ``TextureInput``'s
    ``st_fallback`` (documented as the st of a mesh without the primvar, which ``load_usd`` fills in, with a
    warning naming the mesh), and said nothing. Oracle: a 2 x 2 texture of four colours read at st_fallback
    (0.75, 0.25), the centre of its bottom-right texel (row 0 is the top), is that texel's colour everywhere."""
    texels = np.float32([[[1, 0, 0, 1], [0, 1, 0, 1]], [[0, 0, 1, 1], [1, 1, 0, 1]]])
    texture = wrt.TextureInput(0, st_fallback=np.float32([0.75, 0.25]))
    material = wrt.Material("/Textured", textures={"diffuseColor": texture})
    mesh = wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), None, material_ids=[0, 0],
                    double_sided=True)
    scene = wrt.Scene(meshes=[mesh], materials=[material], textures=[texels])
    with pytest.warns(UserWarning, match=r"^scene: meshes without the texture coordinates their material reads "
                                         r"\(Mesh\.uvs is None\) show the texture at the primvar reader's fallback "
                                         r"st \(TextureInput\.st_fallback\): 1 prim\(s\): /Square$"):
        image = wrt.render(scene, camera=TOP, width=8, height=8, integrator="albedo")
    np.testing.assert_allclose(image.rgb[image.aovs["coverage"] > 0.5], np.broadcast_to([1.0, 1.0, 0.0], (16, 3)),
                               atol=1e-5)


@pytest.mark.parametrize("scale", [(1.0, 0.0, 0.0), (0.0, 0.0, 0.0)])
def test_a_shape_scaled_to_a_line_or_a_point_warns_and_draws_what_its_usd_twin_draws(tmp_path, scale):
    """A ``Shape`` whose ``to_world`` scales it to a line or a point vanished without a word, while ``load_usd`` names
    such a gprim in a warning (and draws its tessellation, of no area). Oracle: the USD twin's hits, none."""
    from tests.usda_text import write
    from wrt.primitives import Shape

    stage = write(tmp_path, f"""
def Sphere "Ball"
{{
    float3 xformOp:scale = {tuple(scale)}
    uniform token[] xformOpOrder = ["xformOp:scale"]
}}
""")
    with pytest.warns(UserWarning, match=r"Ball"):
        twin = wrt.load_usd(stage)
    with pytest.warns(UserWarning, match=r"^scene: shapes whose to_world scales them to a line or a point \(a "
                                         r"singular transform\) draw nothing of any area, as load_usd's tessellation "
                                         r"of such a gprim: 1 prim\(s\): /Ball$"):
        scene = wrt.Scene(shapes=[Shape("/Ball", "sphere", np.diag([*scale, 1.0]))])
    origins = np.float32([[0, 0, 5], [0.5, 0, 5], [5, 0, 0], [0.3, 5, 0]])
    directions = np.float32([[0, 0, -1], [0, 0, -1], [-1, 0, 0], [0, -1, 0]])
    hits = wrt.trace(scene, origins, directions)
    np.testing.assert_array_equal(hits.t, wrt.trace(twin, origins, directions, accel="warp").t)
    assert np.isinf(hits.t).all()
    # A shape appended later is named at the next trace, once.
    scene.shapes.append(Shape("/Rod", "cylinder", np.diag([*scale, 1.0])))
    with pytest.warns(UserWarning, match=r"1 prim\(s\): /Rod$"):
        wrt.trace(scene, origins, directions)


def test_up_axis_in_lower_case_is_taken_and_another_axis_refused():
    """``Scene(up_axis="z")`` was taken for Y-up without a word (the default camera and sun the wrong way up), and
    ``"X"``, which no USD stage's ``upAxis`` can be, likewise. Oracle: the render of the same scene with ``"Z"``."""
    def scene(up_axis) -> wrt.Scene:
        return wrt.Scene(meshes=[square_mesh("/Ground")], up_axis=up_axis)

    np.testing.assert_array_equal(wrt.render(scene("z"), width=6, height=4).rgb,
                                  wrt.render(scene("Z"), width=6, height=4).rgb)
    with pytest.raises(ValueError, match=r"^Scene up_axis must be 'Y' or 'Z' \(a USD stage's upAxis\), got 'X'"):
        scene("X")
    later = scene("Y")
    later.up_axis = "x"
    with pytest.raises(ValueError, match=r"got 'x'"):
        wrt.render(later, width=6, height=4)


def test_camera_paths_are_strings():
    """A camera under an int key was taken, and ``render(camera=...)`` looks cameras up by path string; an
    ``Sdf.Path`` key becomes its string."""
    from pxr import Sdf

    camera = wrt.Camera.look_at((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    with pytest.raises(TypeError, match=r"^scene\.cameras\[5\]: path must be a str"):
        wrt.Scene(meshes=[square_mesh("/Ground")], cameras={5: camera})
    scene = wrt.Scene(meshes=[square_mesh("/Ground")], cameras={Sdf.Path("/Cam"): camera})
    assert list(scene.cameras) == ["/Cam"] and type(list(scene.cameras)[0]) is str
    np.testing.assert_array_equal(wrt.render(scene, camera="/Cam", width=4, height=4).rgb,
                                  wrt.render(scene, camera=camera, width=4, height=4).rgb)


def test_a_warning_of_a_constructor_points_at_the_callers_line():
    """A warning raised by the checks of ``wrt.Mesh(...)`` pointed at ``<string>:13``, the made-up file of the
    ``__init__`` that ``dataclasses`` generates, not at the line that made the mesh."""
    with pytest.warns(UserWarning, match="colors of shape") as warned:
        wrt.Mesh("/Square", SQUARE_AND_TWO, np.int32([[0, 1, 2], [0, 2, 3]]), None, colors=SQUARE_AND_TWO)
    assert warned[0].filename == __file__


@pytest.mark.parametrize("name, value, words", [
    ("normals", np.ones((4, 3), complex), r"normals must be real numbers, got dtype complex128"),
    ("normals", np.full((4, 3), "1"), r"normals must be real numbers, got dtype <U1"),
    ("colors", np.ones((4, 3), bool), r"colors must be real numbers, got dtype bool"),
    ("colors", np.array([[None] * 3] * 4, object), r"colors must be real numbers, got dtype object"),
    ("uvs", [[0, 0], [1]], r"uvs must be an array of numbers: "),
])
def test_corner_arrays_that_are_no_real_numbers_are_refused_as_points_are(name, value, words):
    """Points of complex, text, bool or object dtype were refused naming the mesh, but normals, colours and texture
    coordinates took them: complex values lost their imaginary part with only numpy's warning, "1" and True were read
    as 1, None as NaN (no colour), and a ragged list failed with numpy's message naming no mesh. Oracle: the
    points' refusal of the same dtypes."""
    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    if not isinstance(value, list):
        with pytest.raises(wrt.SceneError, match=rf"^/Square: points must be real numbers, got dtype {value.dtype}"):
            wrt.Mesh("/Square", value.reshape(-1)[:12].reshape(4, 3), indices, None)
    with pytest.raises(wrt.SceneError, match=rf"^/Square: {words}"):
        wrt.Mesh("/Square", SQUARE, indices, None, **{name: value})


@pytest.mark.parametrize("name, value", [
    ("normals", np.stack([np.tile(np.float32([0, 0, 1]), (2, 1))] * 3)),  # (3, T, 3): stacked corner by corner
    ("uvs", np.zeros((2, 2, 3), np.float32)),  # (T, 2, 3): u and v rows, transposed
])
def test_per_triangle_arrays_of_the_right_size_in_another_layout_are_refused(name, value):
    """Any array of ``T * 9`` numbers was reshaped into ``(T, 3, 3)``: normals stacked corner by corner, ``(3, T,
    3)``, and transposed texture coordinates, ``(T, 2, 3)``, became other triangles' values without a word. Only the
    attribute's own shape and its flattenings are taken (``(T, 9)``, ``(3T, 3)``, ``(9T,)``). Oracle: the shapes
    given."""
    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    with pytest.raises(wrt.SceneError, match=rf"^/Square: {name} must have shape \(2, 3, [23]\), one entry per "
                                             rf"triangle .*; got {re.escape(str(value.shape))}"):
        wrt.Mesh("/Square", SQUARE, indices, None, **{name: value})
    flat = {"normals": (2, 9), "uvs": (12,)}[name]
    mesh = wrt.Mesh("/Square", SQUARE, indices, None, **{name: np.ascontiguousarray(value).reshape(flat)})
    assert getattr(mesh, name).shape == (2, 3, {"normals": 3, "uvs": 2}[name])


# Looking straight up at the square, whose front (its winding's) faces +Z: a single-sided one is culled from here.
BELOW = wrt.Camera.orthographic((0.0, 0.0, -5.0), (0.0, 0.0, 0.0), height=4.0)


@pytest.mark.parametrize("value", ["no", "False", np.array([True, False]), None, 2])
def test_double_sided_that_is_no_bool_is_refused_naming_the_mesh_or_shape(value):
    """``Mesh(double_sided="no")`` (any string, a mask, None...) was taken by its truth: "no" and "False" made the
    mesh double-sided without a word, and an array failed deep in the scene naming no mesh. Refused naming the mesh
    or shape, when made and when assigned later."""
    from wrt.primitives import Shape

    indices = np.int32([[0, 1, 2], [0, 2, 3]])
    with pytest.raises(TypeError, match=r"^/Square: double_sided must be True or False, got "):
        wrt.Mesh("/Square", SQUARE, indices, None, double_sided=value)
    with pytest.raises(TypeError, match=r"^shape /Ball: double_sided must be True or False, got "):
        Shape("/Ball", "sphere", np.eye(4), double_sided=value)
    mesh = wrt.Mesh("/Square", SQUARE, indices, None)
    scene = wrt.Scene(meshes=[mesh])
    mesh.double_sided = value
    with pytest.raises(TypeError, match=r"^/Square: double_sided must be True or False"):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])


@pytest.mark.parametrize("value", [np.bool_(True), np.bool_(False), 1, 0])
def test_double_sided_as_a_numpy_bool_or_zero_one_is_the_bool_it_says(value):
    """A numpy bool (``mask[k]``) and the integers 0 and 1 mean what they say. Oracle: seen from behind, the square
    covers its 16 pixels when double-sided and none when back-face culled."""
    mesh = wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), None, double_sided=value)
    assert type(mesh.double_sided) is bool and mesh.double_sided == bool(value)
    image = wrt.render(wrt.Scene(meshes=[mesh]), camera=BELOW, width=8, height=8, integrator="albedo")
    assert image.aovs["coverage"].sum() == (16.0 if value else 0.0)


@pytest.mark.parametrize("value, words", [
    (0.7, r"0\.7"), (2**32, r"4294967296"), (np.int64(-2**40), r"np.int64\(-1099511627776\)"), ("0", r"'0'"),
    ([0], r"\[0\]"),
])
def test_a_shape_material_id_that_is_no_int32_integer_is_refused(value, words):
    """``Shape.material_id`` went into an int32 array at render time: 0.7 was cut to material 0, 2**32 wrapped round
    to material 0, each without a word. Refused naming the shape, as a mesh's material_ids are, when made and when
    assigned later; a whole float is the integer it holds. Oracle: the material's colour (albedo) on the sphere."""
    from wrt.primitives import Shape

    with pytest.raises(ValueError, match=rf"^shape /Ball: material_id must be an int32 integer .*, got {words}$"):
        Shape("/Ball", "sphere", np.eye(4), material_id=value)
    red = wrt.Material("/Red", diffuse_color=(1.0, 0.0, 0.0))
    ball = Shape("/Ball", "sphere", np.eye(4), material_id=0.0, double_sided=True)
    assert type(ball.material_id) is int and ball.material_id == 0
    image = wrt.render(wrt.Scene(shapes=[ball], materials=[red]), camera=TOP, width=8, height=8, integrator="albedo")
    covered = image.aovs["coverage"] > 0.5
    assert covered.sum() > 0
    np.testing.assert_allclose(image.rgb[covered], np.broadcast_to([1.0, 0.0, 0.0], (int(covered.sum()), 3)))
    scene = wrt.Scene(shapes=[ball], materials=[red])
    ball.material_id = value
    with pytest.raises(ValueError, match=r"^shape /Ball: material_id must be an int32 integer"):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])


@pytest.mark.parametrize("holder", ["dlpack", "cuda", "3x4"])
def test_a_shape_transform_on_a_gpu_or_without_its_bottom_row_is_read(holder):
    """A shape's ``to_world`` as a ``wp.array`` on CUDA or a GPU tensor failed with numpy's refusal, naming no shape,
    and a ``(3, 4)`` affine matrix (the device's own layout, without the bottom row) with numpy's "cannot reshape
    array of size 12 into shape (4,4)". The first two are copied to the host as a mesh's arrays are, and the row
    ``(0, 0, 0, 1)`` is added to the third. Oracle: the unit sphere moved to z = 1 is hit at 5 - 1 - 1 = 3."""
    import warp as wp

    from wrt.primitives import Shape

    if holder == "cuda" and not wp.is_cuda_available():
        pytest.skip("needs CUDA")
    to_world = np.eye(4)
    to_world[2, 3] = 1.0
    given = {"dlpack": DLPackOnly, "cuda": lambda values: wp_array(values, "cuda:0"),
             "3x4": lambda values: values[:3]}[holder](to_world)
    ball = Shape("/Ball", "sphere", given)
    np.testing.assert_array_equal(ball.to_world, to_world)
    np.testing.assert_allclose(wrt.trace(wrt.Scene(shapes=[ball]), [0.0, 0.0, 5.0], [0.0, 0.0, -1.0]).t, [3.0],
                               rtol=1e-6)


@pytest.mark.parametrize("value", [np.eye(4)[:, :3], np.eye(3), np.zeros((2, 4, 4)), [["a"] * 4] * 4])
def test_a_shape_transform_of_another_shape_is_refused_naming_the_shape(value):
    """A ``(4, 3)`` (a row-vector affine matrix), ``(3, 3)`` or stacked transform failed with numpy's reshape or
    conversion message, naming no shape."""
    from wrt.primitives import Shape

    with pytest.raises(ValueError, match=r"^shape /Ball: to_world must be a \(4, 4\) .* its top \(3, 4\), got "):
        Shape("/Ball", "sphere", value)


@pytest.mark.parametrize("holder", ["dlpack", "cuda"])
def test_light_arrays_on_a_gpu_are_read(holder):
    """A light's position, direction, colour, transform or texture on the GPU (a ``wp.array`` on CUDA, a torch tensor)
    failed with numpy's refusal, or was refused as no numbers ("must be finite numbers of shape (3,), got
    <DLPackOnly ...>", "texture must be an (H, W, 3) or (H, W, 4) array of numbers"); they are copied to the host as a
    mesh's arrays are. Oracle: the same lights made from numpy arrays."""
    import warp as wp

    if holder == "cuda" and not wp.is_cuda_available():
        pytest.skip("needs CUDA")
    make = DLPackOnly if holder == "dlpack" else (lambda values: wp_array(values, "cuda:0"))
    to_world = np.eye(4)
    to_world[:3, 3] = 1.0, 2.0, 3.0
    color, texture = np.float32([1.0, 0.5, 0.25]), np.full((2, 4, 3), 0.5, np.float32)
    pairs = [
        (wrt.DistantLight(make(np.float32([0.0, 0.0, -2.0])), make(color)),
         wrt.DistantLight(np.float32([0.0, 0.0, -2.0]), color)),
        (wrt.SphereLight(make(np.float64([1.0, 2.0, 3.0])), 0.5, make(color), axis=make(np.float64([0.0, 1.0, 0.0]))),
         wrt.SphereLight(np.float64([1.0, 2.0, 3.0]), 0.5, color, axis=np.float64([0.0, 1.0, 0.0]))),
        (wrt.RectLight(make(to_world), 1.0, 2.0, make(color), texture=make(texture)),
         wrt.RectLight(to_world, 1.0, 2.0, color, texture=texture)),
        (wrt.DomeLight(make(color), to_world=make(np.eye(4)), texture=make(texture)),
         wrt.DomeLight(color, to_world=np.eye(4), texture=texture)),
    ]
    for light, twin in pairs:
        for name in ("direction", "position", "axis", "color", "to_world", "texture"):
            if hasattr(twin, name):
                np.testing.assert_array_equal(getattr(light, name), getattr(twin, name), err_msg=name)


def test_instance_sources_that_are_no_strings_are_refused_naming_them():
    """``Instances(..., sources=[5])`` built directly was taken, and ``hit_paths`` handed back 5 (a ``pathlib`` path,
    bytes likewise), as a mesh's path was before it was checked, and ``sources="/PI"`` named every instance "/". Refused
    with a TypeError naming the entry, when made and when assigned later; an ``Sdf.Path`` becomes the str it names. A
    ``source`` index outside ``sources`` is refused too."""
    from pxr import Sdf

    def instances(sources) -> wrt.Instances:
        return wrt.Instances(np.zeros(1, np.int32), np.eye(4)[None], np.zeros(1, np.int32), np.zeros(1, np.int32),
                             sources)

    with pytest.raises(TypeError, match=r"^Instances sources\[0\]: path must be a str"):
        instances([5])
    named = instances([Sdf.Path("/PI")])
    assert named.sources == ["/PI"] and type(named.sources[0]) is str
    scene = wrt.Scene(prototypes=[wrt.Prototype("/Proto", [square_mesh()])], instances=named)
    assert wrt.trace(scene, [0.5, -0.5, 5.0], [0.0, 0.0, -1.0]).instance.tolist() == [0]
    assert scene.instances.path(0) == "/PI[0]"
    scene.instances.sources = [b"/PI"]
    with pytest.raises(TypeError, match=r"^Instances sources\[0\]: path must be a str"):
        wrt.trace(scene, [0.5, -0.5, 5.0], [0.0, 0.0, -1.0])
    with pytest.raises(TypeError, match=r"^Instances sources takes a list of prim paths, got str '/PI'"):
        instances("/PI")
    for source in (1, -1):  # past the one source: a bare IndexError from hit_paths, or the last source
        with pytest.raises(ValueError, match=rf"^Instances source must hold an index into sources \(1\) per "
                                             rf"instance; entry 0 is {source}"):
            wrt.Instances(np.zeros(1, np.int32), np.eye(4)[None], np.int32([source]), np.zeros(1, np.int32), ["/PI"])


@pytest.mark.parametrize("value", [0, -1.0, "m", float("nan"), float("inf"), None, True])
def test_meters_per_unit_that_is_no_positive_finite_number_is_refused(value):
    """``Scene(meters_per_unit=...)`` took 0, -1, "m" and NaN without a word, values no USD stage's metersPerUnit can
    hold (``load_usd`` replaces them with centimetres and a warning). Refused, when made and when assigned later; a
    numpy float is the float it holds."""
    with pytest.raises(ValueError, match=r"^Scene meters_per_unit must be a finite number above 1e-30"):
        wrt.Scene(meshes=[square_mesh("/Ground")], meters_per_unit=value)
    scene = wrt.Scene(meshes=[square_mesh("/Ground")], meters_per_unit=np.float32(0.5))
    assert type(scene.meters_per_unit) is float and scene.meters_per_unit == 0.5
    scene.meters_per_unit = value
    with pytest.raises(ValueError, match=r"^Scene meters_per_unit must be a finite number above 1e-30"):
        wrt.trace(scene, [0.0, 0.0, 5.0], [0.0, 0.0, -1.0])


def test_instance_opacities_on_a_gpu_are_read():
    """``Instances.opacities`` on the GPU failed with numpy's refusal (a torch tensor: "can't convert cuda:0 device
    type tensor to numpy"), naming no instances, where the other instance arrays are copied to the host. Oracle: the
    opacities as given."""
    instances = wrt.Instances.from_transforms([0, 0], np.stack([np.eye(4)] * 2))
    instances.opacities = DLPackOnly(np.float32([0.25, 1.0]))
    instances.check()
    np.testing.assert_array_equal(instances.opacities, np.float32([0.25, 1.0]))


def test_eight_bit_material_colors_are_refused_and_emission_taken():
    """A material's reflectances given as ``uint8`` 0-255 (``Material(diffuse_color=np.uint8([255, 0, 0]))``) were
    read as albedos up to 255 (the surface 255 times too bright), without a word, while the same colours on a mesh,
    shape or instances were refused. Refused naming the material and field, before the conversion of one number to
    three; integers of 0 and 1 still mean what they say, and an integer emission is a radiance, which may exceed 1.
    Oracle: the albedo of a material of diffuse ``(1, 0, 0)`` is red."""
    words = r"colors must be linear float values, got uint8 values up to 255 \(8-bit colours"
    for name in ("diffuse_color", "specular_color"):
        with pytest.raises(wrt.SceneError, match=rf"/Red: {name} {words}"):
            wrt.Material("/Red", **{name: np.uint8([255, 0, 0])})
    with pytest.raises(wrt.SceneError, match=rf"/Red: diffuse_color {words}"):
        wrt.Material("/Red", diffuse_color=np.uint8(255))  # one number for three channels
    red = wrt.Material("/Red", diffuse_color=[1, 0, 0], emissive_color=[10, 10, 10])
    np.testing.assert_array_equal(red.emissive_color, [10.0, 10.0, 10.0])
    red.emissive_color = np.zeros(3, np.float32)
    mesh = wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), None, material_ids=np.zeros(2, np.int32),
                    double_sided=True)
    scene = wrt.Scene(meshes=[mesh], materials=[red])
    image = wrt.render(scene, camera=TOP, width=8, height=8, integrator="albedo")
    np.testing.assert_allclose(image.rgb[image.aovs["coverage"] > 0.5], np.broadcast_to([1.0, 0.0, 0.0], (16, 3)))
    red.diffuse_color = np.uint8([255, 0, 0])  # assigned later: checked before the next render
    with pytest.raises(wrt.SceneError, match=rf"/Red: diffuse_color {words}"):
        wrt.render(scene, camera=TOP, width=8, height=8, integrator="albedo")


@pytest.mark.parametrize("name", ["thin_walled", "use_specular_workflow", "diffuse_from_display_color"])
@pytest.mark.parametrize("value", ["false", "no", None, 2, np.array([True])])
def test_material_flags_that_are_no_bool_are_refused_naming_the_material(name, value):
    """``Material(thin_walled="false")`` (a string, None, 2, an array) was taken by its truth: "false" made the glass
    a thin sheet, or the material specular-workflow, without a word. Refused naming the material and field, when made
    and when assigned later, as a mesh's ``double_sided`` is."""
    with pytest.raises(TypeError, match=rf"^material /Glass: {name} must be True or False, got "):
        wrt.Material("/Glass", **{name: value})
    glass = wrt.Material("/Glass", opacity=0.0)
    mesh = wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]), None, material_ids=np.zeros(2, np.int32))
    scene = wrt.Scene(meshes=[mesh], materials=[glass])
    setattr(glass, name, value)
    with pytest.raises(TypeError, match=rf"^material /Glass: {name} must be True or False"):
        wrt.render(scene, camera=TOP, width=4, height=4)


@pytest.mark.parametrize("kwargs, error, words", [
    ({"thin_walled": "false"}, TypeError, "thin_walled must be True or False"),
    ({"color_primvar": 5}, TypeError, "color_primvar must be a str"),
    ({"diffuse_color": np.uint8([200, 0, 0])}, wrt.SceneError, "diffuse_color colors must be linear float values"),
    ({"textures": {"diffuseColor": wrt.TextureInput(image=0, scale=(1.0, 1.0))}}, ValueError,
     "diffuseColor: scale must be 1, 3 or 4 finite numbers"),
])
def test_a_material_without_a_path_is_named_as_a_wrt_material(kwargs, error, words):
    """A material made in Python without a path (its default) was named "material : thin_walled ..." (an empty path
    before the colon), and its 8-bit colours not at all: "diffuse_color colors must be ...". Named ``Material``, as its
    other fields' messages ("Material opacity must be ...") and lights without a path ("SphereLight ...") are."""
    with pytest.raises(error, match=rf"^Material {words}"):
        wrt.Material(**kwargs)


@pytest.mark.parametrize("value", [np.bool_(True), np.bool_(False), 1, 0])
def test_material_flags_as_numpy_bools_or_zero_one_are_the_bools_they_say(value):
    """A numpy bool and the integers 0 and 1 mean what they say, stored as a ``bool``."""
    material = wrt.Material("/Glass", thin_walled=value, use_specular_workflow=value)
    assert material.thin_walled is bool(value) and material.use_specular_workflow is bool(value)


@pytest.mark.parametrize("kwargs, error, words", [
    ({"color_primvar": 5}, TypeError, r"color_primvar must be a str, .* got int 5"),
    ({"textures": None}, TypeError, r"textures must be a dict of input name -> TextureInput, got NoneType"),
    ({"textures": {"diffuseColor": 0}}, TypeError, r"textures\['diffuseColor'\] must be a wrt.TextureInput, got int"),
])
def test_a_material_color_primvar_or_textures_of_another_type_is_refused(kwargs, error, words):
    """A ``color_primvar`` that is no name was kept and matched no primvar, without a word; ``textures=None`` failed
    with "'NoneType' object is not iterable", and an image index where a TextureInput belongs at the upload on a
    missing attribute. Refused naming the material."""
    with pytest.raises(error, match=rf"^material /M: {words}"):
        wrt.Material("/M", **kwargs)


@pytest.mark.parametrize("field, value, words", [
    ("image", 0.7, r"image must be an integer, an index into scene\.textures, got 0\.7"),
    ("image", "0", r"image must be an integer, an index into scene\.textures, got '0'"),
    ("scale", (np.nan, 1.0, 1.0, 1.0), r"scale must be 1, 3 or 4 finite numbers"),
    ("scale", (1.0, 1.0), r"scale must be 1, 3 or 4 finite numbers"),
    ("bias", (np.inf, 0.0, 0.0, 0.0), r"bias must be 1, 3 or 4 finite numbers"),
    ("transform", np.eye(2), r"transform must be a \(3, 3\) matrix of finite numbers"),
    ("transform", np.full((3, 3), np.nan), r"transform must be a \(3, 3\) matrix of finite numbers"),
    ("st_fallback", (np.nan, 0.0), r"st_fallback must be 2 finite numbers"),
    ("uv_set", 3, r"uv_set must be a str"),
    ("filter", "nearest", r"filter must be one of linear, closest, got 'nearest'"),
])
def test_texture_input_fields_of_a_wrong_type_shape_or_value_are_refused_naming_the_material(field, value, words):
    """A TextureInput built in Python went unchecked: a NaN ``scale``, ``bias`` or ``transform`` rendered the texture
    black without a word, an ``image`` of 0.7 read image 0, and a ``scale`` of two numbers or a ``(2, 2)`` transform
    failed at the upload with numpy's "could not broadcast". Refused naming the material and input, when the
    material is made and when the field is assigned later, before the next render."""
    error = TypeError if field == "uv_set" else ValueError
    with pytest.raises(error, match=rf"^material /Textured: diffuseColor: {words}"):
        wrt.Material("/Textured", textures={"diffuseColor": wrt.TextureInput(**{"image": 0, field: value})})
    scene = textured_square(np.ones((2, 2, 4), np.float32))
    wrt.render(scene, camera=TOP, width=4, height=4, integrator="albedo")
    setattr(scene.materials[0].textures["diffuseColor"], field, value)
    with pytest.raises(error, match=rf"^material /Textured: diffuseColor: {words}"):
        wrt.render(scene, camera=TOP, width=4, height=4, integrator="albedo")


def test_a_texture_scale_of_one_or_three_numbers_is_read_as_a_usd_one_is():
    """``scale`` and ``bias`` of one number serve all four channels and of three take the default alpha, as the USD
    reader reads a float3 authored for the float4 (:func:`wrt.materials.four_components`); three failed at the upload
    with numpy's broadcast message. Oracle: the albedo of a grey 0.5 texture is ``0.5 * scale + bias``."""
    texture = wrt.TextureInput(0, scale=(0.5, 1.0, 1.5), bias=0.125)
    scene = textured_square(np.full((2, 2, 4), 0.5, np.float32))
    scene.materials[0].textures["diffuseColor"] = texture
    image = wrt.render(scene, camera=TOP, width=8, height=8, integrator="albedo")
    np.testing.assert_array_equal(texture.scale, np.float32([0.5, 1.0, 1.5, 1.0]))
    np.testing.assert_array_equal(texture.bias, np.float32([0.125] * 4))
    on_square = image.aovs["coverage"] > 0.5
    np.testing.assert_allclose(image.rgb[on_square], np.broadcast_to([0.375, 0.625, 0.875], (16, 3)), atol=1e-3)


def test_a_texture_image_given_as_a_zero_d_array_is_read_as_its_index():
    """``image=np.array(1)`` (a 0-d array: ``np.asarray`` of an index, a reduction's result) is one integer, and was
    read as one before TextureInput's fields were checked; the check refused it as no integer. Oracle: the albedo is
    the texel of scene.textures[1]."""
    scene = textured_square(np.full((2, 2, 4), 0.5, np.float32))
    scene.textures.append(np.broadcast_to(np.float32([0.25, 0.5, 0.75, 1.0]), (2, 2, 4)).copy())
    scene.materials[0].textures["diffuseColor"] = wrt.TextureInput(np.array(1))
    image = wrt.render(scene, camera=TOP, width=8, height=8, integrator="albedo")
    on_square = image.aovs["coverage"] > 0.5
    np.testing.assert_allclose(image.rgb[on_square], np.broadcast_to([0.25, 0.5, 0.75], (16, 3)), atol=1e-3)


def test_instances_of_a_scale_float32_cannot_invert_are_not_called_zero_scaled(tmp_path):
    """A PointInstancer instance scaled (3e38, 1, 1), finite and of a nonzero determinant (USD's own Gf.Matrix4d says
    so), is skipped as float32 cannot invert it reliably; the warning called it "a singular transform (a zero scale)",
    sending the user looking for a zero. One of a true zero scale (0, 0, 0) is still named a zero scale. The USD loader
    and a Python-built Scene word it alike."""
    import warnings

    from pxr import Gf

    scales = [(1.0, 1.0, 1.0), (3e38, 1.0, 1.0), (0.0, 0.0, 0.0)]
    assert [Gf.Matrix4d(Gf.Vec4d(*s, 1.0)).GetDeterminant() != 0 for s in scales] == [True, True, False]
    positions = [(3.0 * k, 0.0, 0.0) for k in range(3)]
    stage = box_instancer(tmp_path, scales, positions)
    with warnings.catch_warnings(record=True) as from_usd:
        warnings.simplefilter("always")
        wrt.load_usd(stage)
    to_world = np.stack([np.diag([*s, 1.0]) for s in scales])
    to_world[:, :3, 3] = positions
    prototype = wrt.Prototype("/PI/Box", [wrt.Mesh("/PI/Box", BOX_POINTS, BOX_INDICES, None)])
    with warnings.catch_warnings(record=True) as from_python:
        warnings.simplefilter("always")
        wrt.Scene(prototypes=[prototype], instances=wrt.Instances.from_transforms([0] * 3, to_world, "/PI"))
    for caught in (from_usd, from_python):
        lines = [str(w.message) for w in caught if "skipped" in str(w.message)]
        uneven = [line for line in lines if "/PI[1]" in line]
        zero = [line for line in lines if "/PI[2]" in line]
        assert len(uneven) == 1 and "zero" not in uneven[0] and "float32" in uneven[0], lines
        assert len(zero) == 1 and "a zero scale" in zero[0] and "/PI[1]" not in zero[0], lines
        assert not any("/PI[0]" in line for line in lines), lines
