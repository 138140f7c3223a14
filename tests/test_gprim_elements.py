"""The ``elementId`` RenderVar (``Scene.hit_prims``' element) of gprims: 0 on every hit of an analytic gprim, as the
README's AOV table says, whether wrt draws it analytically or as its tessellation (``tessellate_gprims``, which
``--accel warp`` needs, and always for a gprim that glows). Tessellated, it was the triangle hit (up to 8,000 on a
Sphere, 0 to 11 on a Cube), so ``tessellate_gprims`` changed the AOV.

The oracle: each pixel centre's ray of pxr's frustum of the camera, met in float64 with each gprim placed by USD's
own ``ComputeLocalToWorldTransform``; pixels near a silhouette or a cube edge (where the tessellation and the
analytic shape may differ) are left out."""

import json

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade
from test_render_products import add_shot, read_exr, read_header
from usda_text import load

import wrt

WIDTH, HEIGHT = 48, 24
SPHERES = {"/Ball": ((-2.5, 0.0, 0.0), 1.0), "/Lamp": ((2.5, 0.0, 0.0), 0.8)}  # /Lamp emits: always tessellated
BOX = ("/Box", 1.6, (25.0, 35.0, 0.0))  # path, size, rotateXYZ degrees (three faces towards the camera)
MARGIN = 0.1  # of a sphere's radius from its silhouette, or of the cube's half size from a face's edge


def gprim_stage(tmp_path) -> str:
    """A Sphere, a rotated Cube and a Sphere bound to a material that emits, seen by ``/Cam``, with one RenderProduct
    of the ``elementId``, ``primId`` and colour RenderVars."""
    path = str(tmp_path / "gprims.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    for name, (centre, radius) in SPHERES.items():
        sphere = UsdGeom.Sphere.Define(stage, name)
        sphere.CreateRadiusAttr(radius)
        sphere.AddTranslateOp().Set(Gf.Vec3d(*centre))
    box = UsdGeom.Cube.Define(stage, BOX[0])
    box.CreateSizeAttr(BOX[1])
    box.AddRotateXYZOp().Set(Gf.Vec3f(*BOX[2]))
    glow = UsdShade.Material.Define(stage, "/Glow")
    surface = UsdShade.Shader.Define(stage, "/Glow/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(2.0, 2.0, 2.0))
    glow.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    lamp = stage.GetPrimAtPath("/Lamp")
    UsdShade.MaterialBindingAPI.Apply(lamp).Bind(glow)
    cam = UsdGeom.Camera.Define(stage, "/Cam")
    cam.CreateFocalLengthAttr(25.0)
    cam.CreateHorizontalApertureAttr(40.0)
    cam.CreateVerticalApertureAttr(20.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.5, 10.0))
    add_shot(stage, "/Cam", WIDTH, HEIGHT, "shot.exr", {"elementId": ("elementId", None),
                                                        "primId": ("primId", None), "color": ("color", None)})
    stage.Save()
    return path


def expected_prims(path: str) -> tuple[np.ndarray, np.ndarray]:
    """``(prims, clear)``, ``(HEIGHT, WIDTH)``: the path of the gprim each pixel centre's ray meets first ("" on a
    miss), and whether the pixel is at least MARGIN from every silhouette and cube edge."""
    stage = Usd.Stage.Open(path)
    time = Usd.TimeCode.Default()
    frustum = UsdGeom.Camera(stage.GetPrimAtPath("/Cam")).GetCamera(time).frustum
    to_box = UsdGeom.Xformable(stage.GetPrimAtPath(BOX[0])).ComputeLocalToWorldTransform(time).GetInverse()
    half = BOX[1] / 2.0
    prims = np.full((HEIGHT, WIDTH), "", object)
    clear = np.zeros((HEIGHT, WIDTH), bool)
    for i in range(HEIGHT):
        for j in range(WIDTH):
            ray = frustum.ComputePickRay(Gf.Vec2d(2 * (j + 0.5) / WIDTH - 1, 1 - 2 * (i + 0.5) / HEIGHT))
            o, d = np.array(ray.startPoint), np.array(ray.direction)
            d /= np.linalg.norm(d)
            found, near_edge = [], False  # (t, path), and a silhouette or edge within MARGIN
            for name, (centre, radius) in SPHERES.items():
                b = np.dot(o - centre, d)
                off_axis = np.linalg.norm(o - centre - b * d)  # the ray's distance from the centre
                near_edge |= abs(off_axis - radius) < MARGIN * radius
                if off_axis < radius:
                    found.append((-b - np.sqrt(radius**2 - off_axis**2), name))
            lo = np.array(to_box.Transform(Gf.Vec3d(*o)))  # the box's own space: rigid, so t is the same
            ld = np.array(to_box.TransformDir(Gf.Vec3d(*d)))
            with np.errstate(divide="ignore", invalid="ignore"):
                t0, t1 = (-half - lo) / ld, (half - lo) / ld
            t_in, t_out = np.nanmax(np.minimum(t0, t1)), np.nanmin(np.maximum(t0, t1))
            if t_in < t_out:
                p = lo + t_in * ld
                face_axis = int(np.argmax(np.minimum(t0, t1)))
                near_edge |= min(half - abs(p[k]) for k in range(3) if k != face_axis) < MARGIN * half
                found.append((t_in, BOX[0]))
            if found:
                prims[i, j] = min(found)[1]
            clear[i, j] = not near_edge
    return prims, clear


@pytest.mark.parametrize("tessellate,accel", [(False, "wrt"), (True, "wrt"), (True, "warp")])
def test_element_id_of_a_gprim_is_0_drawn_analytically_or_tessellated(tmp_path, tessellate, accel):
    path = gprim_stage(tmp_path)
    scene = load(path, tessellate_gprims=tessellate)
    assert len(scene.meshes) == (3 if tessellate else 1)  # the glowing /Lamp is a mesh either way
    written = wrt.render_products(scene, tmp_path / "out", device="cpu", accel=accel)
    exr, header = read_exr(written["/Render/Shot"]), read_header(written["/Render/Shot"])
    want, clear = expected_prims(path)
    paths = json.loads(header["primId/paths"])
    named = np.array([paths.get(str(int(k)), "") for k in exr["primId"].ravel()], object).reshape(want.shape)
    assert {p for p in want[clear]} == {"", "/Ball", "/Lamp", "/Box"}
    np.testing.assert_array_equal(named[clear], want[clear])
    np.testing.assert_array_equal(exr["elementId"][clear], np.where(want[clear] == "", -1, 0))
    hit = exr["primId"] >= 0
    np.testing.assert_array_equal(exr["elementId"][hit], 0)  # near the silhouettes too


def test_a_python_mesh_marked_as_a_tessellated_gprim_has_element_0_and_the_mark_must_be_a_bool():
    """``Mesh.tessellated_gprim`` (set by the loader) names element 0 on every triangle of a mesh built in Python
    too, where its ``face_ids`` number the triangles; like ``double_sided`` it is a bool, ``"no"`` a ``TypeError``
    naming the mesh and field, not taken by its truth."""
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    indices = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    marked = wrt.Mesh("/Gprim", points, indices, np.arange(2, dtype=np.int32), tessellated_gprim=True)
    plain = wrt.Mesh("/Plain", points + [3, 0, 0], indices, np.arange(2, dtype=np.int32))
    scene = wrt.Scene(meshes=[marked, plain])
    origins = np.array([[0.7, 0.3, 1], [0.3, 0.7, 1], [3.7, 0.3, 1], [3.3, 0.7, 1]], np.float32)
    hits = wrt.trace(scene, origins, np.array([0, 0, -1], np.float32))
    prims, elements = scene.hit_prims(hits.local_prim, hits.instance)
    assert [scene.prim_paths()[k] for k in prims] == ["/Gprim", "/Gprim", "/Plain", "/Plain"]
    assert elements.tolist() == [0, 0, 0, 1]  # the plain mesh's faces as its face_ids say
    with pytest.raises(TypeError, match="/Gprim: tessellated_gprim must be True or False"):
        wrt.Mesh("/Gprim", points, indices, None, tessellated_gprim="no")


def test_the_preview_names_a_tessellated_gprim_face_0_as_the_element_id(tmp_path):
    """``to_pyvista``'s ``face_id`` (the source face) of a gprim drawn as triangles, on its own or in a native
    instance, is 0 as the analytic gprim's element is (USD gives a Sphere no faces): it numbered the triangles."""
    pytest.importorskip("pyvista")
    from wrt.preview import to_pyvista

    path = tmp_path / "balls.usda"
    path.write_text('#usda 1.0\n\ndef Xform "Proto"\n{\n    def Sphere "Ball"\n    {\n        double radius = 0.5\n'
                    '    }\n}\n\ndef Sphere "Lone"\n{\n    double radius = 0.5\n}\n\n'
                    'def Xform "Copy" (\n    instanceable = true\n    prepend references = </Proto>\n)\n{\n'
                    '    double3 xformOp:translate = (3, 0, 0)\n'
                    '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n')
    scene = load(str(path), tessellate_gprims=True)
    blocks = to_pyvista(scene)
    faces = {name: blocks[name].cell_data["face_id"] for name in blocks.keys()}
    assert len(faces) >= 3 and all(len(f) for f in faces.values()), faces
    for name, face in faces.items():
        np.testing.assert_array_equal(face, 0, err_msg=name)
