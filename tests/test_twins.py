"""Coincident single-sided faces of opposite winding (the two-sided leaf: a front face and a reversed back face at
one place, a material each): each side shows its own face, and the camera ray never falls through the pair
(``wrt.twins``, ``wrt.shade.cull_hidden_hits_kernel``)."""

import dataclasses

import numpy as np
import pytest

import wrt
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh
from wrt.twins import find_twins

CORNERS = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
FRONT = [[0, 1, 2], [0, 2, 3]]  # normal +z
BACK = [[0, 2, 1], [0, 3, 2]]  # normal -z: the same two triangles reversed
RED, BLUE = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
SIDES = {"+z": ((0.1, 0.2, 4.0), "front"), "-z": ((0.1, 0.2, -4.0), "back")}  # eye, the side it sees


def corner_normals(tris, side: str) -> np.ndarray:
    """``(T, 3, 3)`` shading normal per corner, tilted by the corner's position, so a hit's normal tells where on the
    quad it is (a twin's barycentrics mapped through the wrong corners would show another normal)."""
    tilted = np.concatenate([0.3 * CORNERS[:, :2], np.full((4, 1), 1.0 if side == "front" else -1.0)], axis=1)
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    return tilted[np.asarray(tris)].astype(np.float32)


def leaf(order: str, path: str = "/Leaf") -> tuple[Mesh, dict]:
    """The two-sided leaf (front face red, back face blue) and the geometry ids of each side."""
    tris = FRONT + BACK if order == "front_first" else BACK + FRONT
    ids = {"front": [0, 1], "back": [2, 3]} if order == "front_first" else {"front": [2, 3], "back": [0, 1]}
    materials, normals = np.zeros(4, np.int32), np.zeros((4, 3, 3), np.float32)
    materials[ids["back"]] = 1
    normals[ids["front"]], normals[ids["back"]] = corner_normals(FRONT, "front"), corner_normals(BACK, "back")
    return Mesh(path, CORNERS, np.array(tris), np.arange(4), normals=normals, material_ids=materials), ids


def side_only(side: str) -> Mesh:
    """The oracle: one side's face alone, double-sided, with that side's normals and material."""
    tris = FRONT if side == "front" else BACK
    return Mesh("/Side", CORNERS, np.array(tris), np.arange(2), normals=corner_normals(tris, side),
                material_ids=np.full(2, 0 if side == "front" else 1, np.int32), double_sided=True)


def two_materials() -> list:
    """The front's material (red) and the back's (blue)."""
    return [wrt.Material(path="/Front", diffuse_color=RED), wrt.Material(path="/Back", diffuse_color=BLUE)]


def render(scene, eye, accel="wrt"):
    return wrt.render(scene, camera=wrt.Camera.look_at(eye, (0, 0, 0)), width=8, height=8, accel=accel).aovs


@pytest.mark.parametrize("accel", ["wrt", "warp"])
@pytest.mark.parametrize("order", ["front_first", "back_first"])
@pytest.mark.parametrize("view", SIDES)
def test_each_side_sees_its_own_face(order, view, accel):
    """Seen from either side, in either triangle order, the leaf shows that side's face where its oracle (that face
    alone) does: the same depth and normal, that side's prims and material. The back face first
    made the front face vanish from +z (the cull re-traced past both): depth 7.04 (the wall behind) for 4.02."""
    eye, side = SIDES[view]
    wall_z = -3.0 if view == "+z" else 3.0
    wall = Mesh("/Wall", np.array([[-5, -5, wall_z], [5, -5, wall_z], [5, 5, wall_z], [-5, 5, wall_z]], np.float32),
                [[0, 1, 2], [0, 2, 3]], [0, 0], double_sided=True)
    mesh, ids = leaf(order)
    scene = wrt.Scene(meshes=[mesh, wall], materials=two_materials())
    got = render(scene, eye, accel)
    want = render(wrt.Scene(meshes=[side_only(side), wall], materials=two_materials()), eye, accel)
    on_leaf = (want["prim"] >= 0) & (want["prim"] < 2)  # the wall is prims 2, 3
    assert on_leaf.sum() >= 12
    np.testing.assert_allclose(got["depth"][on_leaf], want["depth"][on_leaf], rtol=1e-6)
    np.testing.assert_allclose(got["normal"][on_leaf], want["normal"][on_leaf], atol=1e-6)
    np.testing.assert_array_equal(got["prim"][on_leaf], np.array(ids[side])[want["prim"][on_leaf]])
    assert (got["material"][on_leaf] == (0 if side == "front" else 1)).all()
    colour = RED if side == "front" else BLUE
    np.testing.assert_allclose(got["albedo"][on_leaf], np.broadcast_to(colour, want["albedo"][on_leaf].shape))


@pytest.mark.parametrize("order", ["front_first", "back_first"])
def test_instanced_leaf_shows_each_side(order):
    """Copies of the leaf placed by instancing (one turned upside down) show each side's face too: the twins are
    found among the prototype's triangles, in prototype space."""
    mesh, ids = leaf(order, "/P/Leaf")
    to_world = np.tile(np.eye(4), (2, 1, 1))
    to_world[0, 0, 3], to_world[1, 0, 3] = -1.5, 1.5
    to_world[1, :3, :3] = np.diag([1.0, -1.0, -1.0])  # turned half round x: its back faces +z
    scene = wrt.Scene(prototypes=[Prototype("/P", [mesh])], instances=Instances.from_transforms([0, 0], to_world),
                      materials=two_materials())
    for eye, left, right in (((0, 0, 6.0), "front", "back"), ((0, 0, -6.0), "back", "front")):
        got = render(scene, eye)
        hit = got["prim"] >= 0
        assert np.isfinite(got["depth"][hit]).all() and hit.sum() > 10
        for instance, side in enumerate((left, right)):
            mine = hit & (got["instance"] == instance)
            assert mine.any()
            assert np.isin(got["prim"][mine] - 4 * instance, ids[side]).all()  # the prim AOV counts drawn triangles
            assert (got["material"][mine] == (0 if side == "front" else 1)).all()


def test_find_twins():
    """Twins: the same corner positions in the reversed order (any rotation, own vertices or shared), in one space;
    a double-sided partner of either winding; never a same-winding copy, a degenerate triangle or another space."""
    shifted = np.concatenate([CORNERS, CORNERS])  # vertices 4..7 repeat 0..3
    tris = [[0, 1, 2], [5, 4, 6], [1, 2, 0], [2, 1, 0]]  # 1 and 3 reverse 0 (and 2, its rotation)
    np.testing.assert_array_equal(find_twins(shifted, tris, [-1] * 4, [False] * 4), [1, 0, 1, 0])
    assert find_twins(CORNERS, FRONT + BACK, [-1, -1, 0, 0], [False] * 4) is None
    assert find_twins(CORNERS, FRONT + FRONT, [-1] * 4, [False] * 4) is None
    np.testing.assert_array_equal(find_twins(CORNERS, FRONT + FRONT, [-1] * 4, [False, False, True, True]),
                                  [2, 3, -1, -1])
    assert find_twins(CORNERS, [[0, 1, 1], [1, 1, 0]], [-1] * 2, [False] * 2) is None
    assert find_twins(CORNERS, FRONT + BACK, [-1] * 4, [True] * 4) is None  # nothing culled: nothing to find


@pytest.mark.parametrize("integrator", ["whitted", "path"])
@pytest.mark.parametrize("order", ["front_first", "back_first"])
def test_mirror_shows_the_side_it_faces(order, integrator):
    """A bounce ray (here off a mirror) meeting the leaf from behind its front face sees the back face, in either
    triangle order, as the back face alone shows: the tie rule reporting the front face showed its unlit back (the
    red face glows on its front only), black for blue."""
    big = 4.0 * CORNERS
    mirror = Mesh("/Mirror", np.array([[3, -5, -5], [3, 5, -5], [3, 5, 5], [3, -5, 5]], np.float32),
                  [[0, 2, 1], [0, 3, 2]], [0, 0], material_ids=np.full(2, 2, np.int32), double_sided=True)
    materials = [wrt.Material(path="/Front", diffuse_color=(0, 0, 0), emissive_color=RED),
                 wrt.Material(path="/Back", diffuse_color=(0, 0, 0), emissive_color=BLUE),
                 wrt.Material(path="/Mirror", diffuse_color=(1, 1, 1), metallic=1.0, roughness=0.0)]
    camera = wrt.Camera.look_at((2, 0, -3), (3, 0, -1.5))  # its rays reach the leaf's back (z < 0) off the mirror
    rgb = {}
    for name, m in (("leaf", leaf(order)[0]), ("back alone", side_only("back"))):
        scene = wrt.Scene(meshes=[dataclasses.replace(m, points=big), mirror], materials=materials)
        rgb[name] = wrt.render(scene, camera=camera, width=8, height=8, integrator=integrator, spp=2).rgb
    assert (rgb["back alone"][..., 2] > 0.5).sum() >= 16  # the mirror shows the blue face on many pixels
    np.testing.assert_allclose(rgb["leaf"], rgb["back alone"], atol=1e-6)
