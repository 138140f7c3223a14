"""Points no face uses: USD renderers ignore them, so an unused NaN or infinite point neither stops the load nor
changes the image or the bounds (with a warning naming the prim and how many), while one a face uses still raises,
naming the file, the prim and the point."""

import numpy as np
import pytest

pytest.importorskip("pxr")

from usda_text import fmt, load_recording_warnings, write  # noqa: E402

import wrt  # noqa: E402

QUADS = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0), (2.0, 0.0, 0.0), (2.0, 1.0, 0.0)]
FACES = [0, 1, 2, 3, 1, 4, 5, 2]


def mesh_usda(points, scheme="none", extra="") -> str:
    return (f'def Mesh "Grid"\n{{\n    point3f[] points = {fmt(points)}\n'
            f"    int[] faceVertexCounts = [4, 4]\n    int[] faceVertexIndices = {FACES}\n"
            f'    uniform token subdivisionScheme = "{scheme}"\n{extra}}}\n')


def usd_used_points(path):
    """The points the faces use, as USD's own UsdGeom.Mesh reads them (the oracle), and all the points."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(path)  # (held: a prim of a stage let go is invalid)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Grid"))
    points = np.asarray(mesh.GetPointsAttr().Get(), np.float64)
    return points[np.unique(np.asarray(mesh.GetFaceVertexIndicesAttr().Get()))], points


def assert_same_image(scene, clean):
    """The default camera's image of ``scene`` is that of ``clean`` (the mesh without the point), pixel for pixel."""
    image, expected = (wrt.render(s, width=24, height=16, device="cpu") for s in (scene, clean))
    assert (expected.aovs["prim"] >= 0).sum() > 50
    np.testing.assert_array_equal(image.rgb, expected.rgb)
    np.testing.assert_array_equal(image.aovs["depth"], expected.aovs["depth"])


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
@pytest.mark.parametrize("where", [0, 3, 7])  # before, between and after the used points
def test_an_unused_point_that_is_not_finite_is_ignored_with_a_warning(tmp_path, bad, where):
    points = list(QUADS)
    points.insert(where, (1.5, bad, 0.0))
    faces_shift = [i + (i >= where) for i in FACES]
    body = mesh_usda(points).replace(str(FACES), str(faces_shift))
    path = write(tmp_path, body)
    scene, messages = load_recording_warnings(path)
    found = [m for m in messages if "/Grid" in m and "not finite" in m]
    assert len(found) == 1 and "1 of 7 points" in found[0], messages
    used, _ = usd_used_points(path)
    lower, upper = scene.bounds()
    np.testing.assert_array_equal(lower, used.min(axis=0).astype(np.float32))
    np.testing.assert_array_equal(upper, used.max(axis=0).astype(np.float32))
    # The image is that of the mesh without the point (default camera: framed by the bounds).
    clean = wrt.load_usd(write(tmp_path, mesh_usda(QUADS), name="clean.usda"))
    assert_same_image(scene, clean)


@pytest.mark.parametrize("scheme", ["none", "catmullClark"])
def test_a_used_point_that_is_not_finite_still_stops_the_load_naming_file_prim_and_point(tmp_path, scheme):
    points = list(QUADS)
    points[4] = (2.0, float("nan"), 0.0)
    path = write(tmp_path, mesh_usda(points, scheme))
    with pytest.raises(wrt.SceneError, match=r"points\[4\] = \(2\.0, nan, 0\.0\) is not finite") as caught:
        wrt.load_usd(path)
    assert "/Grid" in str(caught.value) and "scene.usda" in str(caught.value)


def test_an_unused_nan_point_of_a_subdivision_mesh_changes_nothing(tmp_path):
    points = [*QUADS, (float("nan"), 0.0, 0.0)]
    scene, messages = load_recording_warnings(write(tmp_path, mesh_usda(points, "catmullClark")))
    assert [m for m in messages if "/Grid" in m and "not finite" in m]
    clean, _ = load_recording_warnings(write(tmp_path, mesh_usda(QUADS, "catmullClark"), name="clean.usda"))
    np.testing.assert_array_equal(scene.bounds()[0], clean.bounds()[0])
    np.testing.assert_array_equal(scene.bounds()[1], clean.bounds()[1])
    assert_same_image(scene, clean)


@pytest.mark.parametrize("unused", [(50.0, 60.0, 70.0), (1.5, float("nan"), 0.0)])
def test_unused_points_stay_out_of_the_bounds_and_the_tree(tmp_path, unused):
    """A guard (this held before for finite points): a point no face uses, far off or NaN, is in neither the scene's
    bounds (which frame the default camera) nor the BVH's root box; both are the box of the points USD's faces use."""
    from wrt.bvh.build import build_bvh

    path = write(tmp_path, mesh_usda([*QUADS, unused]))
    scene, _ = load_recording_warnings(path)
    used, _ = usd_used_points(path)
    tree = build_bvh(*scene.triangles())
    for lower, upper in (scene.bounds(), (tree.lowers[0], tree.uppers[0])):
        np.testing.assert_array_equal(lower, used.min(axis=0).astype(np.float32))
        np.testing.assert_array_equal(upper, used.max(axis=0).astype(np.float32))


def test_a_mesh_of_no_faces_whose_points_are_not_finite_loads_with_a_warning(tmp_path):
    """A mesh with points, one infinite, and only a face of no corners (the fuzzer's find) stopped the load with an
    IndexError from the code that moves unused points onto a used one, where it has none. It draws nothing, as USD's
    renderers draw it: the scene holds no triangle of it, and its point is named in the warning."""
    body = ('def Mesh "Grid"\n{\n    point3f[] points = [(0, 0, 0), (inf, 0, 0), (1, 1, 0)]\n'
            "    int[] faceVertexCounts = [0]\n    int[] faceVertexIndices = []\n}\n")
    scene, messages = load_recording_warnings(write(tmp_path, body))
    assert any("/Grid" in m and "not finite" in m and "1 of 3 points" in m for m in messages), messages
    assert len(scene.triangles()[1]) == 0
