"""Mesh topology inputs that went wrong without a word: materialBind subsets listing faces the mesh has not got or
sharing faces, an unknown ``subdivisionScheme`` token, and authored normals that are zero or not finite."""

import numpy as np
import pytest

pytest.importorskip("pxr")

from usda_text import fmt, load, load_recording_warnings, write  # noqa: E402

# Three unit quads in a row along x, in the z = 0 plane.
POINTS = [(x, y, 0.0) for x in range(4) for y in (0, 1)]
QUADS = [[0, 2, 3, 1], [2, 4, 5, 3], [4, 6, 7, 5]]


def material(name, color) -> str:
    r, g, b = color
    return (f'def Material "{name}"\n{{\n    token outputs:surface.connect = </{name}/S.outputs:surface>\n'
            f'    def Shader "S"\n    {{\n        uniform token info:id = "UsdPreviewSurface"\n'
            f"        color3f inputs:diffuseColor = ({r}, {g}, {b})\n        token outputs:surface\n    }}\n}}\n")


def subset(name, indices, bound) -> str:
    return (f'    def GeomSubset "{name}" (\n        prepend apiSchemas = ["MaterialBindingAPI"]\n    )\n    {{\n'
            '        uniform token elementType = "face"\n        uniform token familyName = "materialBind"\n'
            f"        int[] indices = {list(indices)}\n        rel material:binding = </{bound}>\n    }}\n")


def mesh(extra="", name="Grid", scheme="none", points=POINTS, quads=QUADS) -> str:
    return (f'def Mesh "{name}" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{{\n'
            f"    point3f[] points = {fmt(points)}\n    int[] faceVertexCounts = {[len(q) for q in quads]}\n"
            f"    int[] faceVertexIndices = {[i for q in quads for i in q]}\n"
            f'    uniform token subdivisionScheme = "{scheme}"\n{extra}}}\n')


def materials_of_faces(scene):
    """Material name of each source face of the first mesh."""
    m = scene.meshes[0]
    names = [mat.path.rsplit("/", 1)[-1] for mat in scene.materials]
    by_face = {}
    for face, k in zip(m.face_ids.tolist(), m.material_ids.tolist()):
        by_face.setdefault(face, set()).add(names[k] if k >= 0 else None)
    return {face: found.pop() for face, found in by_face.items() if len(found) == 1}


def test_subset_indices_that_are_not_faces_are_warned_about_naming_mesh_and_subset(tmp_path):
    body = mesh(subset("Red", [1, 7, -1], "Red")) + material("Red", (1, 0, 0))
    scene, messages = load_recording_warnings(write(tmp_path, body))
    assert materials_of_faces(scene) == {0: None, 1: "Red", 2: None}  # the face it has keeps its material
    found = [m for m in messages if "not faces of the mesh" in m]
    assert found and "/Grid/Red" in found[0] and "2 of 3" in found[0] and "for 3 faces" in found[0], messages


def test_subsets_sharing_faces_are_warned_about_and_the_last_one_wins(tmp_path):
    body = (mesh(subset("Red", [0, 1], "Red") + subset("Blue", [1, 2], "Blue"))
            + material("Red", (1, 0, 0)) + material("Blue", (0, 0, 1)))
    scene, messages = load_recording_warnings(write(tmp_path, body))
    assert materials_of_faces(scene) == {0: "Red", 1: "Blue", 2: "Blue"}
    found = [m for m in messages if "share faces" in m]
    assert found and "/Grid/Blue" in found[0] and "1 face(s) also in Red" in found[0], messages


def test_subsets_sharing_faces_with_one_material_need_no_warning(tmp_path):
    body = mesh(subset("A", [0, 1], "Red") + subset("B", [1, 2], "Red")) + material("Red", (1, 0, 0))
    scene, messages = load_recording_warnings(write(tmp_path, body))
    assert materials_of_faces(scene) == {0: "Red", 1: "Red", 2: "Red"}
    assert not [m for m in messages if "share faces" in m]


# A bent strip (a roof): smooth normals differ from face normals at the ridge.
ROOF = [(x, y, z) for x, z in ((0.0, 0.0), (1.0, 0.5), (2.0, 0.0)) for y in (0.0, 1.0)]
ROOF_QUADS = [[0, 2, 3, 1], [2, 4, 5, 3]]


@pytest.mark.parametrize("refine_level", [0, 1])
def test_an_unknown_subdivision_scheme_is_warned_about_and_read_as_catmull_clark(tmp_path, refine_level):
    typo = load_recording_warnings(write(tmp_path, mesh(scheme="catmull-clark", points=ROOF, quads=ROOF_QUADS),
                                         "typo.usda"), refine_level=refine_level)
    scene, messages = typo
    reference = load(write(tmp_path, mesh(scheme="catmullClark", points=ROOF, quads=ROOF_QUADS), "cc.usda"),
                     refine_level=refine_level)
    got, want = scene.meshes[0], reference.meshes[0]
    assert want.normals is not None
    np.testing.assert_array_equal(got.indices, want.indices)
    np.testing.assert_allclose(got.points, want.points)
    np.testing.assert_allclose(got.normals, want.normals)
    found = [m for m in messages if "subdivisionScheme" in m]
    assert found and "/Grid" in found[0] and "'catmull-clark'" in found[0], messages


@pytest.mark.parametrize("left_handed", [False, True])
@pytest.mark.parametrize("bad", [(0.0, 0.0, 0.0), (float("nan"), 0.0, 1.0), (float("inf"), 0.0, 0.0)])
def test_zero_or_non_finite_normals_fall_back_to_the_face_normal_with_a_warning(tmp_path, bad, left_handed):
    # One triangle tilted out of the z = 0 plane, vertex normals tilted three ways; point 1's is bad.
    points = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.5)]
    normals = [(0.3, 0.0, 1.0), bad, (0.0, 0.3, 1.0)]
    bad_text = "(" + ", ".join("nan" if np.isnan(v) else "inf" if np.isinf(v) else repr(v) for v in bad) + ")"
    normals_text = fmt(normals[:1]).rstrip("]") + ", " + bad_text + ", " + fmt(normals[2:]).lstrip("[")
    orientation = '    uniform token orientation = "leftHanded"\n' if left_handed else ""
    body = (f'def Mesh "Tri"\n{{\n    point3f[] points = {fmt(points)}\n    int[] faceVertexCounts = [3]\n'
            "    int[] faceVertexIndices = [0, 1, 2]\n    uniform token subdivisionScheme = \"none\"\n"
            f'    normal3f[] normals = {normals_text} (interpolation = "vertex")\n{orientation}}}\n')
    scene, messages = load_recording_warnings(write(tmp_path, body))
    m = scene.meshes[0]
    p = m.points[m.indices[0]].astype(np.float64)
    face = np.cross(p[1] - p[0], p[2] - p[0])  # the front side, whatever the orientation (wrt.scene.Mesh)
    face /= np.linalg.norm(face)
    at = {int(v): k for k, v in enumerate(m.indices[0])}  # point -> corner of the baked triangle
    np.testing.assert_allclose(m.normals[0, at[1]], face, atol=1e-6)
    for point in (0, 2):
        want = np.asarray(normals[point]) / np.linalg.norm(normals[point])
        np.testing.assert_allclose(m.normals[0, at[point]], want, atol=1e-6)
    found = [msg for msg in messages if "zero or not finite" in msg]
    assert found and "/Tri" in found[0] and "1 of 3" in found[0], messages
