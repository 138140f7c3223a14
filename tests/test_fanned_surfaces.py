"""Surfaces fanned into slivers (a disc or a cylinder's cap cut into 2000 thin triangles around its centre) render as
the same surfaces cut coarsely: rays leaving a sliver do not meet it again (shadow acne), and camera rays re-traced
past culled back faces and cut-out holes of slivers see what a float64 ray caster sees.

A sliver's watertight test rounds its edge functions at the scale of its long edges squared and divides them by twice
its area, so the ``t`` it reports errs by about float32 epsilon times the triangle's aspect (longest edge squared
over twice its area: 318 for a disc cut into 2000 triangles): a ray leaving the surface can meet its own triangle
again at a small positive ``t``."""

import numpy as np
import pytest

import wrt

ALBEDO = 0.5  # the default material's grey (README: displayColor, grey 0.5 without one)
HOLE = wrt.Material("/Looks/Hole", opacity=0.0, opacity_threshold=0.5)
# A rotation that tilts the disc off every axis: a plane across an axis gets its t from the plane's distance exactly.
TILT = (np.array([[1, 0, 0], [0, np.cos(0.4), -np.sin(0.4)], [0, np.sin(0.4), np.cos(0.4)]])
        @ np.array([[np.cos(0.3), 0, np.sin(0.3)], [0, 1, 0], [-np.sin(0.3), 0, np.cos(0.3)]]))


def fanned_disc(radius, segments, u=(1, 0, 0), v=(0, 1, 0), name="/disc", **kwargs) -> wrt.Mesh:
    """A disc of ``radius`` about the origin in the plane of unit vectors ``u, v`` (front: ``u x v``), cut into
    ``segments`` triangles around its centre."""
    angles = 2 * np.pi * np.arange(segments) / segments
    rim = radius * (np.cos(angles)[:, None] * np.asarray(u, float) + np.sin(angles)[:, None] * np.asarray(v, float))
    k = np.arange(segments)
    indices = np.stack([np.zeros(segments, int), 1 + k, 1 + (k + 1) % segments], -1)
    return wrt.Mesh(name, np.vstack([np.zeros(3), rim]), indices, k, **kwargs)


def sunlit_disc(segments, radius, instanced):
    """The tilted disc under a sun 40 degrees above it, flattened or as an instance that squashes it (a non-uniform
    scale: its world triangles are not its prototype's shapes); and the disc's world front normal and the direction
    to the sun."""
    u, v = TILT @ [1, 0, 0], TILT @ [0, 1, 0]
    linear = np.diag([1.0, 0.25, 1.0]) if instanced else np.eye(3)  # prototype to world
    normal = np.linalg.solve(linear.T, np.cross(u, v))
    normal /= np.linalg.norm(normal)
    tangent = linear @ u / np.linalg.norm(linear @ u)
    to_sun = np.cos(0.7) * tangent + np.sin(0.7) * normal
    sun = wrt.DistantLight(direction=-to_sun, color=np.ones(3))
    if not instanced:
        disc = fanned_disc(radius, segments, u, v, double_sided=True)
        return wrt.Scene(meshes=[disc], lights=[sun]), normal, to_sun
    proto = wrt.Prototype("/Proto", [fanned_disc(radius, segments, u, v, name="/Proto/disc", double_sided=True)])
    to_world = np.eye(4)
    to_world[:3, :3] = linear
    instances = wrt.Instances(np.zeros(1, np.int32), to_world[None], np.zeros(1, np.int32), np.full(1, -1), ["/I"])
    return wrt.Scene(meshes=[], prototypes=[proto], instances=instances, lights=[sun]), normal, to_sun


def tangent_of(normal):
    """A unit vector across ``normal`` (a camera's up)."""
    t = np.cross(normal, [0.0, 0.0, 1.0])
    return t / np.linalg.norm(t)


@pytest.mark.parametrize("instanced", [False, True], ids=["flat", "instanced"])
@pytest.mark.parametrize("radius", [1e-3, 1e4])
@pytest.mark.parametrize("integrator", ["whitted", "path", "ao"])
def test_a_disc_fanned_into_slivers_does_not_shadow_itself(integrator, radius, instanced):
    """A lone disc of 2000 slivers under a sun is lit evenly: ``albedo E cos / pi`` in ``whitted`` and in ``path``
    (direct light only), ambient occlusion 1 (nothing lies above it). Shadow and AO rays started at the surface met
    their own sliver at a small positive t: 3-7% of the pixels were black (AO 0.5 to 0.9), from discs of 1e-3 to
    1e4, flattened or instanced."""
    scene, normal, to_sun = sunlit_disc(2000, radius, instanced)
    camera = wrt.Camera.orthographic(eye=3 * radius * normal, target=(0, 0, 0), up=tangent_of(normal),
                                     height=0.5 * radius, clipping_range=(0.0, 10 * radius))
    img = wrt.render(scene, camera=camera, width=32, height=32, spp=1, device="cpu", integrator=integrator,
                     max_depth=1)
    assert (img.aovs["prim"] >= 0).all()
    lit = 1.0 if integrator == "ao" else ALBEDO * np.dot(normal, to_sun) / np.pi
    np.testing.assert_allclose(img.rgb, lit, rtol=1e-4)
