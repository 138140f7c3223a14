"""Edits of a wrt.Scene between traces and renders, each compared with the same call on a freshly built scene (the
oracle: the edited scene's parts rebuilt through their constructors), or refused naming the object and field."""

import dataclasses
import warnings

import numpy as np
import pytest
import warp as wp

import wrt
from wrt.instancing import Instances, Prototype
from wrt.materials import TextureInput
from wrt.primitives import Shape

CAMERA = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
OPTIONS = dict(camera=CAMERA, width=16, height=12, device="cpu")
SQUARE = np.float32([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])


def square(path: str, material: int = -1, offset=(0.0, 0.0, 0.0)) -> wrt.Mesh:
    return wrt.Mesh(path, SQUARE + np.float32(offset), np.int32([[0, 1, 2], [0, 2, 3]]), np.zeros(2, np.int32),
                    material_ids=np.full(2, material, np.int32))


def red_square() -> wrt.Scene:
    red = wrt.Material(path="/Red", diffuse_color=(0.8, 0.1, 0.1))
    return wrt.Scene(meshes=[square("/Square", 0)], materials=[red],
                     lights=[wrt.DistantLight(direction=np.array([0.0, 0.0, -1.0]), color=np.full(3, 2.0, np.float32))])


def instanced_squares() -> wrt.Scene:
    """Two small squares drawn through instances of one prototype, side by side above a ground square."""
    to_world = np.stack([np.diag([0.4, 0.4, 0.4, 1.0])] * 2)
    to_world[:, :3, 3] = [(-0.5, 0.0, 0.5), (0.5, 0.0, 0.5)]
    return wrt.Scene(meshes=[square("/Ground")], prototypes=[Prototype("/Proto", meshes=[square("/Proto/Square")])],
                     instances=Instances.from_transforms([0, 0], to_world))


def test_an_array_edited_in_place_after_invalidate_is_checked_as_an_assigned_one_is():
    """``invalidate()`` then an edit in place: a NaN written into a material's colour rendered its triangles black,
    by a kept Renderer and by a new render, without a word (the same NaN assigned is refused), and an index out of
    range written into a mesh's indices raised the BVH build's error, which names no mesh. The next trace or render
    after ``invalidate()`` checks every mesh, material, shape and the instances again, as their constructors do."""
    scene = red_square()
    renderer = wrt.Renderer(scene, **OPTIONS)
    first = renderer.render().rgb
    assert first[..., 0].max() > 0.5

    scene.invalidate()
    scene.materials[0].diffuse_color[0] = np.nan
    message = r"^/Red: Material diffuse_color must be finite"
    with pytest.raises(wrt.SceneError, match=message):
        renderer.render()
    with pytest.raises(wrt.SceneError, match=message):
        wrt.render(scene, **OPTIONS)
    scene.materials[0].diffuse_color[0] = 0.8  # mended in place: no new invalidate() needed, it was not rendered
    np.testing.assert_array_equal(renderer.render().rgb, first)

    scene.invalidate()
    scene.meshes[0].indices[1, 2] = 4  # one past the square's 4 points
    ray = (np.float32([[-0.5, 0.5, 1.0]]), np.float32([[0.0, 0.0, -1.0]]))
    with pytest.raises(wrt.SceneError, match=r"^/Square: triangle indices must lie in \[0, 4\); triangle 1"):
        wrt.trace(scene, *ray)
    with pytest.raises(wrt.SceneError, match=r"^/Square: triangle indices"):
        renderer.render()
    scene.meshes[0].indices[1, 2] = 3
    assert wrt.trace(scene, *ray).prim.tolist() == [1]
    np.testing.assert_array_equal(renderer.render().rgb, first)


def test_instance_arrays_assigned_anew_are_checked_and_converted_as_the_constructor_does():
    """``instances.to_world = ...`` of another length than ``prototype`` raised a bare ``IndexError`` ('boolean
    index did not match indexed array') from deep inside the build, and ``instances.prototype = [0, 0]`` (a list,
    which the constructor takes) a ``TypeError`` ('<' not supported). Both are checked before the next trace or
    render as the constructor checks them: the wrong length refused naming the field, the list converted and traced
    as a freshly made scene traces it."""
    scene = instanced_squares()
    origins = np.float32([[-0.5, 0.0, 2.0], [0.5, 0.0, 2.0], [0.5, 0.8, 2.0]])
    directions = np.float32([[0.0, 0.0, -1.0]] * 3)
    assert wrt.trace(scene, origins, directions).instance.tolist() == [0, 1, -1]

    good = scene.instances.to_world
    scene.instances.to_world = good[:1].copy()
    with pytest.raises(ValueError, match="^Instances arrays must all have one entry per instance: to_world has 1, "
                                         "prototype 2"):
        wrt.trace(scene, origins, directions)
    with pytest.raises(ValueError, match="to_world has 1, prototype 2"):
        wrt.render(scene, **OPTIONS)

    moved = good.copy()
    moved[1, 1, 3] = 0.8  # the second square up over the third ray
    scene.instances.to_world = moved.tolist()
    scene.instances.prototype = [0, 0]
    hits = wrt.trace(scene, origins, directions)
    fresh = wrt.Scene(meshes=[square("/Ground")], prototypes=[Prototype("/Proto", meshes=[square("/Proto/Square")])],
                      instances=Instances.from_transforms([0, 0], moved))
    expected = wrt.trace(fresh, origins, directions)
    assert hits.instance.tolist() == expected.instance.tolist() == [0, -1, 1]
    np.testing.assert_array_equal(hits.t, expected.t)
    np.testing.assert_array_equal(wrt.render(scene, **OPTIONS).rgb, wrt.render(fresh, **OPTIONS).rgb)
    assert scene.instances.prototype.dtype == np.int32 and scene.instances.to_world.dtype == np.float64


def test_a_texture_added_to_a_material_later_is_checked_naming_the_material():
    """A texture added to ``material.textures`` after construction is no assignment: one on an input that is not
    texturable (``"diffuse_color"`` for ``"diffuseColor"``) failed the render with ``tuple.index(x): x not in
    tuple``, a channel or wrap mode of another name with a bare ``KeyError``. Each is refused naming the material and
    what is wrong; a good one is drawn as in a scene made with it."""
    scene = red_square()
    wrt.render(scene, **OPTIONS)
    scene.textures.append(np.broadcast_to(np.float32([0.0, 0.0, 1.0, 1.0]), (2, 2, 4)).copy())
    material = scene.materials[0]
    material.textures["diffuse_color"] = TextureInput(image=0)
    with pytest.raises(ValueError, match=r"^material /Red: textures on unknown inputs \['diffuse_color'\]"):
        wrt.render(scene, **OPTIONS)
    del material.textures["diffuse_color"]
    material.textures["diffuseColor"] = TextureInput(image=0, channel="x")
    with pytest.raises(ValueError, match=r"^material /Red: diffuseColor: channel must be one of r, g, b, a, rgb"):
        wrt.render(scene, **OPTIONS)
    material.textures["diffuseColor"] = TextureInput(image=0, wrap=("repeat", "wrap"))
    with pytest.raises(ValueError, match=r"^material /Red: diffuseColor: wrap must be \(wrapS, wrapT\)"):
        wrt.render(scene, **OPTIONS)
    material.textures["diffuseColor"] = TextureInput(image=0)
    blue = wrt.render(scene, **OPTIONS).rgb
    fresh = red_square()
    fresh.textures = [scene.textures[0].copy()]
    fresh.materials = [wrt.Material(path="/Red", diffuse_color=(0.8, 0.1, 0.1),
                                    textures={"diffuseColor": TextureInput(image=0)})]
    np.testing.assert_array_equal(blue, wrt.render(fresh, **OPTIONS).rgb)
    assert blue[..., 2].max() > 5.0 * blue[..., 0].max() > 0.0  # white only in the specular reflection


def test_a_kept_ao_renderer_measures_its_default_radius_on_the_scene_as_edited():
    """``ao_radius`` defaults to a tenth of the scene's diagonal; a kept Renderer measured it once, so after a mesh
    was added far away (the diagonal 20 times longer) it went on with the old radius while a fresh render used the
    new one: two images of one scene. It measures again whenever it builds again; a radius given stays."""
    scene = red_square()
    scene.meshes.append(square("/Roof", offset=(1.5, 0.0, 1.0)))  # 1 above the square's right half
    options = dict(OPTIONS, integrator="ao")
    kept = wrt.Renderer(scene, **options)
    given = wrt.Renderer(scene, ao_radius=0.5, **options)
    first = kept.render(spp=4).rgb
    scene.meshes.append(square("/Far", offset=(40.0, 0.0, 0.0)))
    fresh = wrt.Scene(meshes=[square("/Square", 0), square("/Roof", offset=(1.5, 0.0, 1.0)),
                              square("/Far", offset=(40.0, 0.0, 0.0))], materials=list(scene.materials))
    occluded = kept.render(spp=4).rgb
    np.testing.assert_array_equal(occluded, wrt.render(fresh, spp=4, **options).rgb)
    assert occluded.min() < 0.9 * first.min()  # the roof now darkens the square under it
    np.testing.assert_array_equal(given.render(spp=4).rgb, wrt.render(fresh, spp=4, ao_radius=0.5, **options).rgb)
    assert kept.ao_radius == pytest.approx(0.1 * np.linalg.norm([42.0, 2.0, 1.0]), rel=1e-6)


def test_a_list_of_the_scene_given_something_else_is_refused_naming_the_list():
    """``scene.meshes.append(points)`` (not a ``wrt.Mesh``) failed the next trace with "'numpy.ndarray' object has no
    attribute '__dict__'"; it is refused as the constructor refuses it, naming the list and the entry."""
    scene = red_square()
    wrt.trace(scene, [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    scene.meshes.append(SQUARE)
    with pytest.raises(TypeError, match=r"^scene\.meshes\[1\] is a ndarray, not a wrt.Mesh"):
        wrt.trace(scene, [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])


def test_an_infinite_colour_or_an_opacity_outside_0_1_is_refused_naming_the_mesh_or_shape():
    """``mesh.colors`` with an infinite value made every sample there non-finite, dropped, so the mesh was drawn
    black; ``mesh.opacities`` of 2 or -1 were clamped by the shading; a shape's infinite ``color`` likewise. The
    loader replaces such values with a warning, and instance colours and a shape's opacity are refused; these are
    refused too, when made and when assigned or edited in place, naming the mesh or shape and the field (NaN still
    means none)."""
    scene = red_square()
    first = wrt.render(scene, **OPTIONS).rgb
    mesh = scene.meshes[0]
    mesh.colors = np.full((2, 3, 3), np.inf, np.float32)
    with pytest.raises(wrt.SceneError, match=r"^/Square: colors must be finite \(NaN: none\); triangle 0 has"):
        wrt.render(scene, **OPTIONS)
    mesh.colors = np.full((2, 3, 3), np.nan, np.float32)  # none: the material's colour
    np.testing.assert_array_equal(wrt.render(scene, **OPTIONS).rgb, first)
    scene.invalidate()
    mesh.colors[1, 2, 0] = -np.inf
    with pytest.raises(wrt.SceneError, match=r"^/Square: colors must be finite \(NaN: none\); triangle 1 has"):
        wrt.render(scene, **OPTIONS)
    mesh.colors = None
    mesh.opacities = np.float32([[1.0, 1.0, 1.0], [0.5, 2.0, 0.5]])
    with pytest.raises(wrt.SceneError, match=r"^/Square: opacities must be in \[0, 1\] \(NaN: none\); triangle 1"):
        wrt.trace(scene, [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    with pytest.raises(wrt.SceneError, match=r"^/Bad: opacities must be in \[0, 1\]"):
        wrt.Mesh("/Bad", SQUARE, [[0, 1, 2]], [0], opacities=[[-1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"^shape /Ball: color must be 3 finite numbers or None"):
        Shape("/Ball", "sphere", np.eye(4), color=(np.inf, 0.0, 0.0))


def test_normals_that_are_not_finite_are_refused_naming_the_mesh_and_triangle():
    """A NaN or infinite ``mesh.normals`` corner made the interpolated shading normal NaN: the triangle was shaded
    with its face normal, or a NaN normal, without a word (the loader replaces such authored normals with the face
    normal and warns; NaN points are refused here). Refused when made and when assigned, as points are; zero rows
    still mean none (the face normal)."""
    up = np.zeros((2, 3, 3), np.float32)
    up[..., 2] = 1.0
    bad = up.copy()
    bad[1, 2] = [np.nan, 0.0, 1.0]
    with pytest.raises(wrt.SceneError, match=r"^/Bad: normals must be finite \(zero rows: none\); triangle 1 has"):
        wrt.Mesh("/Bad", SQUARE, [[0, 1, 2], [0, 2, 3]], [0, 0], normals=bad)
    scene = red_square()
    ray = (np.float32([[-0.5, 0.5, 1.0]]), np.float32([[0.0, 0.0, -1.0]]))
    assert wrt.trace(scene, *ray).prim.tolist() == [1]
    scene.meshes[0].normals = np.zeros((2, 3, 3), np.float32)  # none: accepted
    assert wrt.trace(scene, *ray).prim.tolist() == [1]
    up[0, 0, 0] = np.inf
    scene.meshes[0].normals = up
    with pytest.raises(wrt.SceneError, match=r"^/Square: normals must be finite \(zero rows: none\); triangle 0"):
        wrt.trace(scene, *ray)


@pytest.mark.parametrize("kind,params", [("capsule", (np.nan, 0.0, 0.0, 1.0)), ("cylinder", (np.nan, 0.0, 0.0, 1.0)),
                                         ("tapered", (1.0, np.inf, 0.0, 1.0))])
def test_shape_params_that_are_not_finite_are_refused_naming_the_shape(kind, params):
    """A capsule of NaN height or a tapered cylinder of infinite top radius was missed by every ray, and a cylinder
    with NaN for its caps lost them, without a word; such params are refused when made and when assigned."""
    ray = (np.float32([[0.0, 0.1, 5.0]]), np.float32([[0.0, 0.0, -1.0]]))
    with pytest.raises(ValueError, match=r"^shape /S: params must be 4 finite numbers"):
        Shape("/S", kind, np.eye(4), params=params)
    scene = wrt.Scene(shapes=[Shape("/S", kind, np.eye(4))])
    assert wrt.trace(scene, *ray).prim[0] == 0
    scene.shapes[0].params = params
    with pytest.raises(ValueError, match=r"shape /S: params must be 4 finite numbers"):
        wrt.trace(scene, *ray)


def test_a_light_edited_in_place_after_invalidate_is_checked_by_a_kept_renderer_as_by_a_new_render():
    """``invalidate()`` makes the lights' arrays writeable too; a NaN written into a light's colour then drew a kept
    Renderer's image black without a word, where a new render refuses it naming the light's field. Mended in place,
    the kept Renderer draws the first image again."""
    scene = red_square()
    renderer = wrt.Renderer(scene, **OPTIONS)
    first = renderer.render().rgb
    assert first[..., 0].max() > 0.5

    scene.invalidate()
    scene.lights[0].color[0] = np.nan
    message = r"DistantLight color must be finite"
    with pytest.raises(wrt.SceneError, match=message):
        renderer.render()
    with pytest.raises(wrt.SceneError, match=message):
        wrt.render(scene, **OPTIONS)
    scene.lights[0].color[0] = 2.0
    np.testing.assert_array_equal(renderer.render().rgb, first)


def _stage_like_scene() -> wrt.Scene:
    """The red square with a stage camera at /Cam (as load_usd gives it) and a second one at /Side."""
    scene = red_square()
    scene.cameras = {"/Cam": wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60, path="/Cam"),
                     "/Side": wrt.Camera.look_at((3.0, 0.5, 3.0), (0.0, 0.0, 0.0), fov_y_deg=40, path="/Side")}
    return scene


@pytest.mark.parametrize("edit", ["assigned", "in_place", "stage_field", "stage_replaced", "framed"])
def test_a_kept_renderer_draws_a_camera_edited_since_as_a_new_renderer_does(edit):
    """A camera given a new pose, a stage camera changed or replaced in ``scene.cameras``, and (where no camera is
    given on a stage without cameras) the camera wrt frames the edited scene with: a kept Renderer read its cameras
    once, when made, and went on drawing the old view without a word."""
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    moved = wrt.Camera.look_at((-2.0, 1.0, 4.0), (0.2, 0.0, 0.0), fov_y_deg=50)
    scene = _stage_like_scene() if edit.startswith("stage") else red_square()
    given = {"assigned": camera, "in_place": camera, "framed": None}.get(edit, "/Cam")
    renderer = wrt.Renderer(scene, camera=given, width=16, height=12, device="cpu")
    first = renderer.render().rgb
    if edit in ("assigned", "stage_field"):
        (camera if edit == "assigned" else scene.cameras["/Cam"]).to_world = moved.to_world.copy()
    elif edit == "in_place":
        camera.to_world[:] = moved.to_world
    elif edit == "stage_replaced":
        scene.cameras["/Cam"] = scene.cameras["/Side"]
    else:
        scene.meshes.append(square("/Far", 0, offset=(6.0, 0.0, -3.0)))
    kept = renderer.render().rgb  # before a new Renderer is made: making one rebuilt the kept one's scene data
    fresh = wrt.Renderer(scene, camera=given, width=16, height=12, device="cpu").render().rgb
    assert not np.array_equal(fresh, first)  # the edit shows
    np.testing.assert_array_equal(kept, fresh)


def test_a_camera_made_bad_since_the_renderer_was_built_is_refused_at_its_render():
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    renderer = wrt.Renderer(red_square(), camera=camera, width=16, height=12, device="cpu")
    renderer.render()
    camera.to_world[0, 3] = np.nan
    with pytest.raises(ValueError, match="camera transform is not finite"):
        renderer.render()
    scene = _stage_like_scene()
    renderer = wrt.Renderer(scene, camera="/Cam", width=16, height=12, device="cpu")
    del scene.cameras["/Cam"]
    with pytest.raises(wrt.SceneError, match=r"no camera at '/Cam'"):
        renderer.render()



@pytest.mark.parametrize("field, ragged", [("to_world", [[1, 0, 0, 0], [0, 1, 0]]),
                                           ("clipping_planes", [[0, 0, 1, 0], [1, 0]])])
def test_a_camera_given_a_ragged_list_since_is_refused_as_a_new_renderer_refuses_it(field, ragged):
    """A ragged list set on a camera a kept Renderer draws: a new Renderer names the camera and field, the kept one
    failed in numpy's words ('setting an array element with a sequence'), from the record of the camera's fields
    it compares at each render."""
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    scene = red_square()
    renderer = wrt.Renderer(scene, camera=camera, width=8, height=6, device="cpu")
    renderer.render()
    setattr(camera, field, ragged)
    with pytest.raises(ValueError) as fresh:
        wrt.Renderer(scene, camera=camera, width=8, height=6, device="cpu")
    assert field.replace("_", " ").split()[-1] in str(fresh.value) and "sequence" not in str(fresh.value)
    with pytest.raises(ValueError) as kept:
        renderer.render()
    assert str(kept.value) == str(fresh.value)

def _every_kind_of_light(colours: np.ndarray) -> list:
    from wrt.lights import CylinderLight, DiskLight, DomeLight, MeshLight, RectLight, SphereLight

    over = np.eye(4)
    over[:3, 3] = (0.0, 0.0, 3.0)
    link = wrt.LinkCollection.only("/Square")
    return [
        wrt.DistantLight(direction=np.array([0.2, 0.3, -1.0]), color=np.full(3, 1.5), light_link=link,
                         shadow_link=link),
        SphereLight(position=np.array([0.0, 0.5, 2.0]), radius=0.2, color=np.ones(3), frame=np.diag([1.0, 2.0, 1.0]),
                    axis=np.array([0.0, 0.0, -2.0]), shaping=wrt.Shaping(cone_angle=60.0, focus_tint=np.ones(3))),
        RectLight(to_world=over, width=0.5, height=0.4, color=np.ones(3), texture=np.ones((2, 2, 3))),
        DiskLight(to_world=over, radius=0.3, color=[1.0, 0.5, 0.5]),
        CylinderLight(to_world=over, length=0.5, radius=0.1, color=colours[1]),  # a view of the caller's array
        MeshLight(path="/Square", color=np.full(3, 0.1)),
        DomeLight(color=np.full(3, 0.05), texture=np.ones((4, 8, 3), np.float32)),
    ]


def test_another_renderer_of_the_scene_does_not_make_a_kept_one_build_again_but_a_light_edit_does(monkeypatch):
    """A second Renderer (or wrt.render) of the same scene checks its lights again, and the checks gave each light new
    arrays of the values it held (its colour, transform, axis as a copy, its link collections as new ones): a kept
    Renderer then saw changed lights and built its tree and shading data again at its next render, seconds on a big
    scene. Checking an unchanged light changes nothing now, while a colour replaced or edited in place after
    invalidate() is still drawn, as a fresh render draws it (the oracle)."""
    builds = []
    build = wrt.Renderer._build
    monkeypatch.setattr(wrt.Renderer, "_build", lambda self: (builds.append(self), build(self))[1])
    colours = np.ones((2, 3), np.float32)
    scene = wrt.Scene(meshes=[square("/Square")], lights=_every_kind_of_light(colours))
    options = dict(OPTIONS, integrator="path")
    kept = wrt.Renderer(scene, **options)
    first = kept.render().rgb
    wrt.Renderer(scene, **options)
    wrt.render(scene, **options)
    np.testing.assert_array_equal(kept.render().rgb, first)
    assert builds.count(kept) == 1

    sun = scene.lights[0]
    sun.color = np.full(3, 4.0)  # replaced
    np.testing.assert_array_equal(kept.render().rgb, wrt.render(scene, **options).rgb)
    assert builds.count(kept) == 2
    scene.invalidate()
    scene.lights[3].color[:] = 0.0  # edited in place
    np.testing.assert_array_equal(kept.render().rgb, wrt.render(scene, **options).rgb)
    assert builds.count(kept) == 3
    colours[1] = 5.0  # the caller's array a light's colour was a row of: no light's field, nothing drawn changes
    np.testing.assert_array_equal(kept.render().rgb, wrt.render(scene, **options).rgb)


def test_lamps_of_a_point_instancer_do_not_make_a_kept_renderer_build_again(tmp_path, monkeypatch):
    """The lamps a PointInstancer places are shallow copies of one read light (usd_placed_lights), each given arrays
    of its own: the record of the arrays a check made was one dict the copies shared, so each lamp's check took
    another's entry for its own, copied its colour again, and a second Renderer of the scene made a kept one build
    again at its next render, as before 10184b2 for every light. The oracle: the image of a fresh render."""
    from pxr import Gf, Usd, UsdGeom, UsdLux

    path = str(tmp_path / "lamps.usda")
    stage = Usd.Stage.CreateNew(path)
    floor = UsdGeom.Mesh.Define(stage, "/Floor")
    floor.CreatePointsAttr([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    UsdLux.SphereLight.Define(stage, "/PI/Lamp").CreateRadiusAttr(0.1)
    pi.CreatePrototypesRel().SetTargets(["/PI/Lamp"])
    pi.CreateProtoIndicesAttr([0] * 3)
    pi.CreatePositionsAttr([Gf.Vec3f(k - 1.0, 0.0, 1.0) for k in range(3)])
    stage.Save()
    scene = wrt.load_usd(path)
    assert len(scene.lights) == 3

    builds = []
    build = wrt.Renderer._build
    monkeypatch.setattr(wrt.Renderer, "_build", lambda self: (builds.append(self), build(self))[1])
    kept = wrt.Renderer(scene, **OPTIONS)
    first = kept.render().rgb
    np.testing.assert_array_equal(wrt.render(scene, **OPTIONS).rgb, first)
    np.testing.assert_array_equal(kept.render().rgb, first)
    assert builds.count(kept) == 1


def test_a_kept_renderer_follows_the_image_size_a_camera_edit_gives_a_new_renderer():
    """Given one side only, the other follows the camera's aspect (its apertures under ``expandAperture``): after the
    apertures changed, a kept Renderer drew the old size (the new film stretched onto it), where a new one makes the
    size of the new aspect. ``render`` and ``launch_frame`` both take the new size."""
    camera = wrt.Camera(to_world=CAMERA.to_world.copy(), fit="expandAperture", horizontal_aperture=20.0,
                        vertical_aperture=15.0)
    scene = red_square()
    renderer = wrt.Renderer(scene, camera=camera, width=16, device="cpu")
    renderer.render()
    renderer.launch_frame()
    camera.vertical_aperture = 10.0  # 2:1 now, so 16x8
    kept = renderer.render().rgb
    renderer.launch_frame()
    fresh = wrt.Renderer(scene, camera=camera, width=16, device="cpu")
    assert kept.shape == (8, 16, 3)  # 16 / (20 / 10)
    np.testing.assert_array_equal(kept, fresh.render().rgb)
    fresh.launch_frame()
    np.testing.assert_array_equal(renderer.frame_image().rgb, fresh.frame_image().rgb)


@pytest.mark.parametrize("field", [("data_window", (0.0, 0.0, 0.5, 0.5)), ("resolution", (20, 12)),
                                   ("camera", "/Side")])
def test_a_kept_renderer_follows_render_settings_replaced_since(field):
    """The render settings (frozen, so replaced) choose the camera, the image size and the data window: a kept
    Renderer followed a new camera there but drew the old data window and resolution without a word."""
    from wrt.render_settings import RenderSettings

    scene = _stage_like_scene()
    scene.render_settings = RenderSettings(path="/Render", camera="/Cam", resolution=(16, 12),
                                           data_window=(0.25, 0.0, 0.75, 0.5))
    renderer = wrt.Renderer(scene, device="cpu")
    first = renderer.render()
    scene.render_settings = dataclasses.replace(scene.render_settings, **dict([field]))
    kept = renderer.render()
    fresh = wrt.Renderer(scene, device="cpu").render()
    assert (fresh.window, fresh.rgb.shape) != (first.window, first.rgb.shape) or field[0] == "camera"
    assert kept.window == fresh.window
    np.testing.assert_array_equal(kept.rgb, fresh.rgb)


def test_render_settings_made_with_arrays_render_and_are_followed_as_tuples_are():
    """Settings made in Python with numpy arrays (cameras take them): the data window's test against the full one
    and a kept Renderer's check for replaced settings raised numpy's "truth value of an array is ambiguous"."""
    from wrt.render_settings import RenderSettings

    scene = _stage_like_scene()
    scene.render_settings = RenderSettings(path="/Render", camera="/Cam", resolution=np.array([16, 12]),
                                           data_window=np.array([0.25, 0.0, 0.75, 0.5]))
    renderer = wrt.Renderer(scene, device="cpu")
    first = renderer.render()
    scene.render_settings = dataclasses.replace(scene.render_settings, resolution=np.array([20, 12]))
    kept = renderer.render()
    scene.render_settings = RenderSettings(path="/Render", camera="/Cam", resolution=(20, 12),
                                           data_window=(0.25, 0.0, 0.75, 0.5))
    fresh = wrt.Renderer(scene, device="cpu").render()
    assert first.rgb.shape == (6, 8, 3) and fresh.rgb.shape == (6, 10, 3)  # half of each side's pixel centres
    assert kept.window == fresh.window
    np.testing.assert_array_equal(kept.rgb, fresh.rgb)


@pytest.mark.parametrize("field", [("product_name", "b.exr"), ("product", "/Render/Other"),
                                   ("rendering_color_space", "lin_rec709_scene")])
def test_render_settings_replaced_with_the_same_view_keep_resume_sums(field):
    """Settings replaced by others that differ in what chooses no image (a product's name or path) dropped
    resume=True's sums with a warning that a camera changed; they are kept, and the image is a new Renderer's of
    all the samples."""
    from wrt.render_settings import RenderSettings

    scene = _stage_like_scene()
    scene.render_settings = RenderSettings(path="/Render", camera="/Cam", resolution=(16, 12), product_name="a.exr",
                                           product="/Render/Product")
    options = dict(device="cpu", integrator="path")
    renderer = wrt.Renderer(scene, **options)
    renderer.render(spp=2, seed=3)
    scene.render_settings = dataclasses.replace(scene.render_settings, **dict([field]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "starts over" warning
        kept = renderer.render(spp=4, seed=3, resume=True)
    fresh = wrt.Renderer(scene, **options).render(spp=6, seed=3)
    np.testing.assert_array_equal(kept.rgb, fresh.rgb)


def test_set_cameras_after_render_settings_were_replaced_renders_as_a_new_renderer():
    """set_cameras framed stage cameras at the settings' new resolution but held the old one, and refused them with
    the message for a mix of camera kinds under a data window (there was none)."""
    from wrt.render_settings import RenderSettings

    scene = _stage_like_scene()
    scene.render_settings = RenderSettings(path="/Render", camera="/Cam", resolution=(16, 12))
    renderer = wrt.Renderer(scene, device="cpu")
    renderer.render()
    scene.render_settings = dataclasses.replace(scene.render_settings, resolution=(20, 12))
    renderer.set_cameras(["/Side"])
    kept = renderer.render()
    fresh = wrt.Renderer(scene, cameras=["/Side"], device="cpu").render()
    assert fresh.image(0).rgb.shape == (12, 20, 3)
    np.testing.assert_array_equal(kept.image(0).rgb, fresh.image(0).rgb)


def test_resume_after_a_camera_edit_or_set_cameras_starts_over_and_says_why():
    """The sums of the old view are dropped (no old samples mixed in: the image is a new render's), and resume's
    warning named a scene change after a camera edit, and said nothing after set_cameras."""
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    scene = red_square()
    options = dict(width=8, height=6, device="cpu", integrator="path")
    renderer = wrt.Renderer(scene, camera=camera, **options)
    renderer.render(spp=2)
    camera.to_world[:3, 3] = (1.0, 1.0, 4.0)
    with pytest.warns(UserWarning, match=r"starts over from no samples: a camera changed since the previous render"):
        kept = renderer.render(spp=2, resume=True).rgb
    np.testing.assert_array_equal(kept, wrt.Renderer(scene, camera=camera, **options).render(spp=2).rgb)
    renderer.set_cameras([camera])
    with pytest.warns(UserWarning, match=r"starts over from no samples: set_cameras was called since the previous"):
        renderer.render(spp=2, resume=True)


@pytest.mark.parametrize("steps", ["set_cameras, scene edit", "scene edit, launch_frame, scene edit",
                                   "camera edit, launch_frame, scene edit"])
def test_resume_warns_after_sums_dropped_and_a_scene_edit_before_the_next_render(steps):
    """The sums of the last render, dropped by a set_cameras, a camera edit or a scene edit followed by a
    launch_frame, stay dropped through a later scene edit: the build for that edit forgot they had been (it saw no
    sums left to drop) and resume=True started over without a word. The image is still a new render's."""
    camera = wrt.Camera.look_at((0.3, -0.4, 5.0), (0.0, 0.0, 0.0), fov_y_deg=60)
    scene = red_square()
    options = dict(width=8, height=6, device="cpu", integrator="path")
    renderer = wrt.Renderer(scene, camera=camera, **options)
    renderer.render(spp=2)
    if steps.startswith("set_cameras"):
        renderer.set_cameras([camera])
    elif steps.startswith("camera edit"):
        camera.focal_length *= 1.25
        renderer.launch_frame()
    else:
        scene.meshes = [*scene.meshes, square("/Right", 0, (3.0, 0.0, 0.0))]
        renderer.launch_frame()
    scene.meshes = [*scene.meshes, square("/Left", 0, (-3.0, 0.0, 0.0))]
    with pytest.warns(UserWarning, match=r"resume=True starts over from no samples: .* since the previous render"):
        kept = renderer.render(spp=2, resume=True).rgb
    fresh = wrt.Renderer(scene, camera=camera, **options)
    if steps.startswith("set_cameras"):
        fresh.set_cameras([camera])
    expected = fresh.render(spp=2).rgb
    host = [a.numpy() if isinstance(a, wp.array) else a for a in (kept, expected)]  # a batch's rgb: a device array
    np.testing.assert_array_equal(host[0].reshape(host[1].shape), host[1])


def test_a_kept_renderer_frames_the_scene_along_an_up_axis_set_since():
    """Without a camera wrt frames the scene along its upAxis (Z-up from -Y): after ``scene.up_axis = "Z"`` a new
    Renderer frames the scene so, while a kept one went on drawing the Y-up view (the axis is a plain field of the
    scene, no edit of its parts)."""
    scene = red_square()
    renderer = wrt.Renderer(scene, width=16, height=12, device="cpu")
    renderer.render()
    scene.up_axis = "Z"
    kept = renderer.render().rgb
    np.testing.assert_array_equal(kept, wrt.Renderer(scene, width=16, height=12, device="cpu").render().rgb)


def test_a_kept_renderer_follows_dark_lights_set_since_as_a_new_renderer_does():
    """``scene.dark_lights`` (the stage's lights that give none) decides whether a scene without lights gets the
    default lights: a kept Renderer read it only when something else changed, so after the last light was listed as
    hidden it kept the default lights a new Renderer leaves out, and after the list was emptied it drew black where a
    new Renderer draws the default lights."""
    scene = wrt.Scene(meshes=[square("/Square")])
    kept = wrt.Renderer(scene, **OPTIONS)
    lit = kept.render(spp=1).rgb
    assert lit.max() > 0.0
    for dark in (["/Lamp"], []):
        scene.dark_lights = dark
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "scene: no light: the stage's lights give none")
            expected = wrt.Renderer(scene, **OPTIONS).render(spp=1).rgb
            np.testing.assert_array_equal(kept.render(spp=1).rgb, expected)
        assert (expected.max() == 0.0) == bool(dark)


@pytest.mark.parametrize("batched", [False, True])
def test_image_so_far_after_a_scene_edit_keeps_the_prim_ids_of_the_scene_it_drew(batched):
    """image_so_far() gives the mean of the last render's samples, of the scene as it was then, but expanded the
    prim ids by the scene as edited since: a mesh added in front of the others shifted every row of the image it
    returned. Its ids are those of a render of the unedited scene."""
    from wrt.procedural import ring_of_cameras, sensor_scene

    scene, cam = sensor_scene(), ring_of_cameras(2)[0]
    renderer = wrt.Renderer(scene, cameras=[cam], width=12, height=9, device="cpu") if batched else wrt.Renderer(
        scene, camera=cam, width=12, height=9, device="cpu")
    renderer.render(seed=2)
    triangle = wrt.Scene.from_triangles(np.float32([[5, 5, 5], [6, 5, 5], [5, 6, 5]]), np.int32([[0, 1, 2]]))
    scene.meshes = [*triangle.meshes, *scene.meshes]
    unedited = wrt.render(sensor_scene(), camera=cam, width=12, height=9, seed=2, device="cpu")
    late = renderer.image_so_far()
    late = late.image(0) if batched else late
    assert (unedited.aovs["prim"] >= 0).any()
    np.testing.assert_array_equal(late.aovs["prim"], unedited.aovs["prim"])
    np.testing.assert_array_equal(late.rgb, unedited.rgb)


def test_an_image_edited_in_place_leaves_the_resumed_render_as_a_fresh_one():
    """On the CPU an Image's AOVs were views of the renderer's buffers, which resume=True and image_so_far() read
    again (the AOVs are drawn once): an image's depth scaled in place came back in the next resumed image. Each
    image holds its own, as on CUDA, and the resumed render is a fresh render of all the samples."""
    from wrt.procedural import ring_of_cameras, sensor_scene

    scene, cam = sensor_scene(), ring_of_cameras(2)[0]
    renderer = wrt.Renderer(scene, camera=cam, width=8, height=6, device="cpu", integrator="path")
    first = renderer.render(spp=2, seed=1)
    for name in first.aovs:
        first.aovs[name][...] = -1
    resumed = renderer.render(spp=2, seed=1, resume=True)
    fresh = wrt.render(scene, camera=cam, width=8, height=6, device="cpu", integrator="path", spp=4, seed=1)
    for image in (resumed, renderer.image_so_far()):
        for name in fresh.aovs:
            np.testing.assert_array_equal(image.aovs[name], fresh.aovs[name], err_msg=name)


def test_a_batch_edited_in_place_leaves_the_resumed_render_as_a_fresh_one():
    """A BatchImage's AOVs were the renderer's buffers themselves, which resume=True and image_so_far() read again
    (the AOVs are drawn once): a batch's depth scaled in place (through ``wp.to_torch``, or the CPU's ``numpy()``
    view) came back in the next resumed batch, and the two batches shared their arrays. Each batch holds its own, as
    an Image does, and the resumed render is a fresh render of all the samples (the oracle: render_batch of 4)."""
    from wrt.procedural import ring_of_cameras, sensor_scene

    scene, cams = sensor_scene(), ring_of_cameras(2)
    renderer = wrt.Renderer(scene, cameras=cams, width=8, height=6, device="cpu", integrator="path")
    first = renderer.render(spp=2, seed=1)
    for array in first.aovs.values():
        array.numpy()[...] = -1  # a view of the CPU array: an edit in place, as a torch tensor of it makes
    resumed = renderer.render(spp=2, seed=1, resume=True)
    fresh = wrt.render_batch(scene, cams, 8, 6, device="cpu", integrator="path", spp=4, seed=1)
    expected = fresh.numpy()[1]
    for batch in (resumed, renderer.image_so_far()):
        _, aovs = batch.numpy()
        for name in expected:
            np.testing.assert_array_equal(aovs[name], expected[name], err_msg=name)


@pytest.mark.parametrize("edit, error, match", [
    # Each was kept by its dataclass and read by nothing: the image came out as before, without a word.
    (lambda s: setattr(s.materials[0], "diffuseColor", (0.1, 0.8, 0.1)), wrt.SceneError,
     r"/Red: has no field 'diffuseColor' \(did you mean 'diffuse_color'\?\) \(set as an attribute, it is read by "
     r"nothing\); its fields: path, diffuse_color,"),
    (lambda s: setattr(s.meshes[0], "colours", np.ones((4, 3))), wrt.SceneError,
     r"/Square: wrt.Mesh has no field 'colours' \(did you mean 'colors'\?\)"),
    (lambda s: setattr(s.lights[0], "angel", 5.0), wrt.SceneError,
     r"DistantLight has no field 'angel' \(did you mean 'angle'\?\)"),
    (lambda s: s.shapes.append(Shape("/Ball", "sphere", np.eye(4))) or setattr(s.shapes[0], "radius", 2.0),
     ValueError, r"shape /Ball: has no field 'radius'"),
    (lambda s: setattr(s, "light", []), ValueError, r"scene has no field 'light' \(did you mean 'lights'\?\)"),
    (lambda s: setattr(s.instances, "transforms", np.eye(4)[None]), ValueError,
     r"Instances has no field 'transforms' \(set as an attribute, it is read by nothing\); its fields: prototype, "
     r"to_world,"),
])
def test_an_attribute_that_is_no_field_is_refused_at_the_render(edit, error, match):
    scene = red_square()
    scene.prototypes.append(Prototype("/Proto", meshes=[square("/Proto/Square", offset=(0.0, 0.0, -3.0))]))
    scene.instances = Instances.from_transforms([0], np.eye(4)[None])
    wrt.render(scene, **OPTIONS)
    edit(scene)
    with pytest.raises(error, match=match):
        wrt.render(scene, **OPTIONS)


def test_a_mesh_of_triangles_alone_takes_each_triangle_as_its_face():
    """``face_ids`` is documented as optional (None: each triangle a face of its own), yet ``wrt.Mesh(path, points,
    indices)`` raised "missing 1 required positional argument: 'face_ids'"."""
    mesh = wrt.Mesh("/Square", SQUARE, np.int32([[0, 1, 2], [0, 2, 3]]))
    assert mesh.face_ids is None
    np.testing.assert_array_equal(mesh.triangle_faces(), [0, 1])
    scene = wrt.Scene(meshes=[mesh])
    hits = wrt.trace(scene, [[0.5, -0.5, 1.0], [-0.5, 0.5, 1.0]], [0.0, 0.0, -1.0])
    np.testing.assert_array_equal(hits.prim, [0, 1])  # (0.5, -0.5) lies in (0, 1, 2), (-0.5, 0.5) in (0, 2, 3)
    np.testing.assert_array_equal(scene.hit_prims(hits.local_prim, hits.instance)[1], [0, 1])  # each its own face
