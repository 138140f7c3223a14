"""Authored normals on a subdivision mesh. USD: ``normals`` "should not be authored on any Mesh that is subdivided,
since the subdivision algorithm will define its own normals" (UsdGeomPointBased), and UsdImaging hands them to Hydra
for ``subdivisionScheme = "none"`` meshes only (UsdImagingMeshAdapter: "Only populate normals for polygonal
meshes"), so Storm shades a ``catmullClark`` (the fallback), ``loop`` or ``bilinear`` mesh as if it had none, at every
refine level. Expected shading normals come from the geometry: an octahedron's smooth cage normals are its unit
points."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

from wrt.usd import load_usd  # noqa: E402

OCTAHEDRON = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], np.float64)
FACES = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
AUTHORED = (1.0, 0.0, 0.0)  # one normal for every point: not the surface's


def fmt(values) -> str:
    return "[" + ", ".join(str(tuple(v)) for v in values) + "]"


def octahedron_stage(tmp_path, scheme: str | None, normals: bool = True) -> str:
    """A Mesh ``/Octa`` (faces wound outward) of ``subdivisionScheme`` ``scheme`` (None: not authored) with vertex
    normals ``AUTHORED`` (or none)."""
    lines = [f"int[] faceVertexCounts = {[3] * len(FACES)}",
             f"int[] faceVertexIndices = {[i for face in FACES for i in face]}",
             f"point3f[] points = {fmt(OCTAHEDRON.tolist())}"]
    if scheme is not None:
        lines.append(f'uniform token subdivisionScheme = "{scheme}"')
    if normals:
        lines.append(f'normal3f[] normals = {fmt([AUTHORED] * len(OCTAHEDRON))} (interpolation = "vertex")')
    body = "\n    ".join(lines)
    path = tmp_path / f"octa_{scheme}_{normals}.usda"
    path.write_text(f'#usda 1.0\n(\n    upAxis = "Y"\n)\ndef Mesh "Octa"\n{{\n    {body}\n}}\n')
    return str(path)


def load(path, refine_level=0):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_usd(path, refine_level=refine_level)
    (mesh,) = scene.meshes
    return mesh, [str(w.message) for w in caught]


def test_the_octahedron_faces_outward():
    a, b, c = (OCTAHEDRON[list(face)] for face in zip(*FACES))
    assert (np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) > 0).all()


@pytest.mark.parametrize("scheme", [None, "catmullClark", "loop", "bilinear"])
def test_authored_normals_of_an_unrefined_subdivision_mesh_are_ignored_with_a_warning(tmp_path, scheme):
    """At refine level 0 wrt shaded such a mesh with its authored normals (an exporter's hard-edged normals on a mesh
    left at the default catmullClark looked faceted, smooth in usdview): now catmullClark and loop meshes get their
    cage's smooth normals, bilinear ones their face normals, as without normals, and the prim is named."""
    path = octahedron_stage(tmp_path, scheme)
    stage = Usd.Stage.Open(path)
    mesh_schema = UsdGeom.Mesh(stage.GetPrimAtPath("/Octa"))
    assert mesh_schema.GetNormalsAttr().HasAuthoredValue()
    assert mesh_schema.GetSubdivisionSchemeAttr().Get() == (scheme or "catmullClark")  # USD's fallback
    mesh, messages = load(path)
    if scheme == "bilinear":
        assert mesh.normals is None  # face normals
    else:
        np.testing.assert_allclose(mesh.normals, mesh.points[mesh.indices], atol=1e-6)  # unit points
    named = [m for m in messages if "normals" in m and "/Octa" in m]
    assert len(named) == 1 and f"subdivisionScheme {scheme or 'catmullClark'}" in named[0], messages


@pytest.mark.parametrize("scheme", ["catmullClark", "loop", "bilinear"])
def test_authored_normals_of_a_refined_subdivision_mesh_are_named_too(tmp_path, scheme):
    """Refined, the surface makes its own normals: the same as without authored normals; they were ignored
    silently."""
    mesh, messages = load(octahedron_stage(tmp_path, scheme), refine_level=1)
    plain, _ = load(octahedron_stage(tmp_path, scheme, normals=False), refine_level=1)
    np.testing.assert_array_equal(mesh.points, plain.points)
    if plain.normals is None:
        assert mesh.normals is None
    else:
        np.testing.assert_allclose(mesh.normals, plain.normals, atol=0)
    assert len([m for m in messages if "normals" in m and "/Octa" in m]) == 1, messages


def test_authored_normals_of_a_polygonal_mesh_are_read(tmp_path):
    mesh, messages = load(octahedron_stage(tmp_path, "none"))
    np.testing.assert_allclose(mesh.normals, np.broadcast_to(AUTHORED, mesh.normals.shape), atol=1e-7)
    assert messages == []


@pytest.mark.parametrize("line", ["normal3f[] normals = []",
                                  'normal3f[] primvars:normals = [] (interpolation = "vertex")'])
def test_empty_authored_normals_of_a_subdivision_mesh_are_not_named(tmp_path, line):
    """An exporter's ``normals = []`` on a catmullClark mesh authors no normal: nothing is ignored, so no warning (it
    said the authored normals were ignored); the mesh is shaded with its cage's smooth normals as without them."""
    path = octahedron_stage(tmp_path, "catmullClark", normals=False)
    text = open(path).read()
    with open(path, "w") as f:
        f.write(text[:text.rindex("}")] + f"    {line}\n}}\n")
    stage = Usd.Stage.Open(path)  # the oracle: USD reads an authored value that holds no normal
    attribute = stage.GetPrimAtPath("/Octa").GetAttribute(line.split()[1])
    assert attribute.HasAuthoredValue() and len(attribute.Get()) == 0
    mesh, messages = load(path)
    np.testing.assert_allclose(mesh.normals, mesh.points[mesh.indices], atol=1e-6)  # unit points
    assert messages == []
