"""The Renderer's shading upload (``Renderer._upload_shading``) takes each triangle's emitter slot
(``DeviceSurfaces.emitters``) and the triangles of ``noMaterialResponse`` mesh lights from the host rows the light
table is made of (``wrt.light_table.LightTable``), reading nothing back from the device (on a GPU each read back is
a copy and a sync), and gives the slots and materials the scene's own data says: world emitters, emissive triangles
and glowing spheres inside instances, and mesh lights in the world and inside a prototype."""

import warnings

import numpy as np
import warp as wp
from shading_helpers import quad

import wrt
from wrt.light_sampling import DeviceLights
from wrt.lights import DomeLight, MeshLight, RectLight

GLOWING, WHITE = 0, 1  # material indices of the scene below


def moved(x, y, z, scale=1.0):
    m = np.diag([scale, scale, scale, 1.0])
    m[:3, 3] = (x, y, z)
    return m


def lamp_scene() -> wrt.Scene:
    """A floor under analytic lights (a sun, a dome, a rect), a glowing world quad and sphere, a world mesh light,
    and two prototypes (a glowing quad, a mesh light panel, a glowing sphere and box; a glowing quad and sphere)
    drawn by five instances."""
    p = wrt.Prototype("/P", [quad((0, 0, 0), (0.3, 0, 0), (0, 0.2, 0), name="/P/lamp", material=GLOWING),
                             quad((0.5, 0, 0), (0.2, 0, 0), (0, 0.2, 0), name="/P/panel", material=WHITE)],
                      [wrt.Shape("/P/ball", "sphere", moved(0, 0.3, 0, 0.1), material_id=GLOWING),
                       wrt.Shape("/P/box", "box", moved(0.3, 0.3, 0, 0.1), material_id=GLOWING)])
    q = wrt.Prototype("/Q", [quad((0, 0, 0), (0.2, 0, 0), (0, 0.2, 0), name="/Q/lamp", material=GLOWING)],
                      [wrt.Shape("/Q/ball", "sphere", moved(0, 0.3, 0, 0.05), material_id=GLOWING)])
    instances = wrt.Instances.from_transforms([0, 1, 0, 1, 0], np.stack([
        moved(0.3, -0.2, 1.0), moved(-0.5, 0.4, 1.2), moved(-0.3, 0.2, 0.9), moved(0.6, 0.5, 1.1),
        moved(0.0, -0.6, 1.3)]))
    return wrt.Scene(
        meshes=[quad((0, 0, 0), (40, 0, 0), (0, 40, 0), name="/floor", material=WHITE),
                quad((0.8, -0.8, 1.0), (0.2, 0, 0), (0, 0.2, 0), name="/lamp", material=GLOWING),
                quad((-0.9, -0.9, 0.8), (0.3, 0, 0), (0, 0.3, 0), name="/panel", material=WHITE)],
        shapes=[wrt.Shape("/ball", "sphere", moved(-0.2, 0.7, 0.9, 0.1), material_id=GLOWING)],
        prototypes=[p, q], instances=instances,
        materials=[wrt.Material(diffuse_color=0.0, emissive_color=3.0), wrt.Material(diffuse_color=1.0)],
        lights=[wrt.DistantLight(direction=(0.2, 0.1, -1), color=(1.0, 1.0, 1.0)), DomeLight(np.full(3, 0.2)),
                RectLight(moved(0, 0, 2), 0.5, 0.5, np.ones(3, np.float32), path="/Rect"),
                MeshLight("/P/panel", color=np.full(3, 2.0)), MeshLight("/panel", color=np.full(3, 1.5))])


def renderer(scene) -> wrt.Renderer:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.Renderer(scene, width=4, height=4, integrator="whitted")


def test_the_shading_upload_reads_nothing_back_from_the_device(monkeypatch):
    """Every ``wp.array.numpy`` call while a Renderer is made is recorded: none is of an array of its
    ``DeviceLights`` or of the scene's cached triangle materials. Before, the upload read back the lights' kinds,
    prims, instances, instance_emitters, instance_glowing_spheres and params, and the triangles' materials (7)."""
    scene = lamp_scene()
    read = []
    numpy = wp.array.numpy

    def recorded(self):
        read.append(self)  # (kept alive, so that an id names one array)
        return numpy(self)

    monkeypatch.setattr(wp.array, "numpy", recorded)
    made = renderer(scene)
    monkeypatch.undo()
    device = {id(getattr(made.device_lights, name)): name for name in DeviceLights.vars
              if isinstance(getattr(made.device_lights, name), wp.array)}
    device[id(scene._cache[("shading", str(made.device))][2])] = "triangle materials"
    assert [device[id(a)] for a in read if id(a) in device] == []


def expected_surfaces(scene) -> tuple[np.ndarray, np.ndarray]:
    """``(slots, materials)`` per geometry id from the scene's own lists: a world emitter's light-table entry (the
    analytic lights but the mesh lights; then the plain emissive triangles, each mesh light's triangles, every
    instance's prototype emitters, the glowing shapes), a prototype emitter's place among its prototype's (triangles
    by geometry id, then shapes), -1 for none; the device material, the last for a mesh light's triangles."""
    meshes = list(scene.meshes) + [m for p in scene.prototypes for m in p.meshes]  # geometry order
    shapes = list(scene.shapes) + [s for p in scene.prototypes for s in p.shapes]
    prototype_of = [None] * len(scene.meshes) + [k for k, p in enumerate(scene.prototypes) for _ in p.meshes]
    shape_prototype = [None] * len(scene.shapes) + [k for k, p in enumerate(scene.prototypes) for _ in p.shapes]
    lit_meshes = [light.mesh_path for light in scene.lights if isinstance(light, MeshLight)]
    glowing = [m.emissive_color is not None and np.max(m.emissive_color) > 0.0 for m in scene.materials]
    analytic = sum(not isinstance(light, MeshLight) for light in scene.lights)
    tris, materials, plain, lit = [], [], [], {path: [] for path in lit_meshes}
    for mesh, proto in zip(meshes, prototype_of):
        for material in mesh.material_ids:
            g = len(tris)
            tris.append(proto)
            materials.append(len(scene.materials) + 1 if mesh.path in lit else material + 1)
            if proto is None and mesh.path in lit:
                lit[mesh.path].append(g)
            elif proto is None and glowing[material]:
                plain.append(g)
    slots = np.full(len(tris) + len(shapes), -1)
    for entry, g in enumerate(plain + [g for path in lit_meshes for g in lit[path]]):
        slots[g] = analytic + entry
    world_rows = analytic + len(plain) + sum(map(len, lit.values()))
    emits = [g for g in range(len(tris)) if tris[g] is not None and (glowing[materials[g] - 1]
                                                                     if materials[g] <= len(scene.materials) else True)]
    per_prototype = [[g for g in emits if tris[g] == k] for k in range(len(scene.prototypes))]
    for rows in per_prototype:
        slots[rows] = np.arange(len(rows))
    first_shape = world_rows + sum(len(per_prototype[k]) for k in scene.instances.prototype)
    world_shapes = [k for k, s in enumerate(shapes) if shape_prototype[k] is None and glowing[s.material_id]]
    slots[len(tris) + np.array(world_shapes, int)] = first_shape + np.arange(len(world_shapes))
    for k in range(len(scene.prototypes)):
        mine = [j for j, s in enumerate(shapes) if shape_prototype[j] == k and glowing[s.material_id]]
        slots[len(tris) + np.array(mine, int)] = np.arange(len(mine))
    materials += [s.material_id + 1 for s in shapes]
    return slots, np.array(materials)


def test_the_emitter_slots_and_no_response_materials_are_those_the_scene_says():
    """The uploaded ``DeviceSurfaces.emitters`` and materials equal those worked out from the scene's meshes,
    shapes, materials, lights and instances (:func:`expected_surfaces`), and each instance's entry at its first plus
    a prototype emitter's slot is that emitter in that instance (what ``light_sampling.hit_emitter`` reads); whitted
    draws each analytic light but the dome."""
    scene = lamp_scene()
    made = renderer(scene)
    slots, materials = expected_surfaces(scene)
    assert (slots >= 0).sum() == 14 and (materials == len(scene.materials) + 1).sum() == 4  # (the scene is as meant)
    np.testing.assert_array_equal(made.surfaces.emitters.numpy(), slots)
    np.testing.assert_array_equal(made.surfaces.materials.numpy(), materials)
    d = made.device_lights
    prims, instances = d.prims.numpy(), d.instances.numpy()
    firsts = {"tri": d.instance_emitters.numpy(), "shape": d.instance_glowing_spheres.numpy()}
    num_triangles = scene.num_geometry_triangles
    for i, proto in enumerate(scene.instances.prototype):
        first_tri, count = scene.prototype_ranges()[proto]
        first_shape, shapes = scene.prototype_shape_ranges()[proto]
        for g in list(range(first_tri, first_tri + count)) + list(range(first_shape, first_shape + shapes)):
            if slots[g] >= 0:
                entry = firsts["tri" if g < num_triangles else "shape"][i] + slots[g]
                assert (prims[entry], instances[entry]) == (g, i)
    assert made._whitted_groups[:2] == [(0, 1), (2, 1)]  # the sun and the rect light; not the dome (1)
