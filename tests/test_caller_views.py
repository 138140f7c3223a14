"""A wrt.Mesh's arrays given as views of the caller's writeable arrays: the scene holds its own copy, so the caller's
later edits of those arrays reach neither the mesh nor its traces. Scene.freeze makes the scene's arrays read-only,
but only the view: its base stayed writeable, and an edit through it changed the mesh under the cached BVH. Oracle:
float64 ray casting against the triangle as given, and the values given."""

import numpy as np

import wrt

TRIANGLE = np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]])
INDICES = np.int32([[0, 1, 2]])
ORIGIN, DIRECTION = np.float32([[0, 0, 5]]), np.float32([[0, 0, -1]])


def test_points_assigned_as_a_view_are_copied():
    scene = wrt.Scene.from_triangles(TRIANGLE, INDICES)
    wide = np.zeros((3, 6), np.float32)
    wide[:, :3] = TRIANGLE
    scene.meshes[0].points = wide[:, :3]  # float32 (V, 3): its dtype and shape, a view of the caller's array
    assert wrt.trace(scene, ORIGIN, DIRECTION).t[0] == 5.0  # float64: 5 - 0 along -z
    wide[:, 2] += 2.0  # the caller's edit of their own array, after the scene was traced
    np.testing.assert_array_equal(scene.meshes[0].points, TRIANGLE)  # was TRIANGLE moved by 2, traced at t = 5
    assert wrt.trace(scene, ORIGIN, DIRECTION).t[0] == 5.0


def test_per_triangle_arrays_given_as_their_dtype_are_copied():
    normals = np.zeros((1, 3, 3), np.float32)
    normals[..., 2] = 1.0
    material_ids = np.zeros(1, np.int32)
    mesh = wrt.Mesh("/m", TRIANGLE, INDICES, normals=normals, material_ids=material_ids)
    scene = wrt.Scene(meshes=[mesh], materials=[wrt.Material(path="/Red", diffuse_color=(0.8, 0.1, 0.1))])
    wrt.trace(scene, ORIGIN, DIRECTION)  # freezes the scene's arrays
    normals[..., 2] = np.nan  # the caller's arrays stay theirs: these edits were the mesh's, unchecked
    material_ids[0] = 7  # no material 7: read past scene.materials at the next render
    np.testing.assert_array_equal(mesh.normals, np.float32([[[0, 0, 1]] * 3]))
    np.testing.assert_array_equal(mesh.material_ids, [0])


def test_instance_transforms_given_as_a_view_are_copied():
    from wrt.instancing import Instances, Prototype

    poses = np.stack([np.eye(4)] * 2)  # a simulation's stack; the scene is given its first row
    instances = Instances(np.zeros(1, np.int32), poses[:1], np.zeros(1, np.int32), np.full(1, -1, np.int32),
                          sources=["/I"])
    scene = wrt.Scene(prototypes=[Prototype("/P", [wrt.Mesh("/P/m", TRIANGLE, INDICES)])], instances=instances)
    assert wrt.trace(scene, ORIGIN, DIRECTION).t[0] == 5.0
    poses[0, 2, 3] = 2.0  # the caller's edit of their stack: wrt's TLAS kept t = 5, accel="warp" drew t = 3
    np.testing.assert_array_equal(instances.to_world, np.eye(4)[None])
    assert wrt.trace(scene, ORIGIN, DIRECTION).t[0] == 5.0
    assert wrt.trace(scene, ORIGIN, DIRECTION, accel="warp").t[0] == 5.0


def test_texture_given_as_a_view_is_copied():
    atlas = np.full((2, 2, 2, 4), 0.5, np.float32)  # the caller's atlas; the scene is given its first image
    material = wrt.Material(path="/T", textures={"diffuseColor": wrt.TextureInput(image=0)})
    mesh = wrt.Mesh("/m", TRIANGLE * 2, INDICES, material_ids=np.zeros(1, np.int32),
                    uvs=np.full((1, 3, 2), 0.5, np.float32), double_sided=True)
    scene = wrt.Scene(meshes=[mesh], materials=[material], textures=[atlas[0]])
    camera = wrt.Camera.look_at((0, 0, 5), (0, 0, 0), fov_y_deg=40)

    def albedo():
        return wrt.render(scene, camera=camera, width=8, height=6, device="cpu").aovs["albedo"][3, 4]

    np.testing.assert_allclose(albedo(), 0.5)
    atlas[0] = 1.0  # the caller's edit: the packed texture kept 0.5 while scene.textures[0] held 1.0
    np.testing.assert_array_equal(scene.textures[0], 0.5)
    scene.invalidate()  # the scene's own image, drawn as given
    np.testing.assert_allclose(albedo(), 0.5)
