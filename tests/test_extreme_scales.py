"""Renders of scenes scaled by 1e-30 to 1e30 with their cameras: shading must not depend on the scene's size. Each
float32 product of two lengths (a cross product of edges, a squared length) over- or underflows at such scales."""

import numpy as np
import pytest

import wrt

SCALES = [1.0e-30, 1.0e-25, 1.0e20, 1.0e30]


def scaled_camera(scale: float) -> wrt.Camera:
    """A camera at the origin looking down -Z, scaled with the scene."""
    return wrt.Camera(to_world=np.diag([scale, scale, scale, 1.0]), focal_length=50.0, horizontal_aperture=36.0)


def quad(path: str, corners, scale: float, double_sided=True) -> wrt.Mesh:
    points = (np.asarray(corners, np.float64) * scale).astype(np.float32)
    return wrt.Mesh(path, points, [[0, 1, 2], [0, 2, 3]], np.zeros(2, np.int32), double_sided=double_sided)


@pytest.mark.parametrize("scale", SCALES)
def test_a_tilted_quad_has_its_plane_normal_at_any_scale(scale):
    """A quad tilted about X, filling the view: every pixel's geometric normal is the plane's (float64), facing the
    camera. Its float32 cross product of edges overflowed at 1e20 (a NaN normal) and vanished at 1e-25 (the
    normal of a degenerate triangle, facing the ray: off by up to 0.4)."""
    corners = [[-100, -100, -5], [100, -100, -5], [100, 100, -25], [-100, 100, -25]]
    scene = wrt.Scene(meshes=[quad("/quad", corners, scale)])
    img = wrt.render(scene, camera=scaled_camera(scale), width=12, height=8, device="cpu", integrator="normals")
    assert (img.aovs["prim"] >= 0).all()
    p = np.asarray(corners, np.float64)
    normal = np.cross(p[1] - p[0], p[2] - p[0])
    normal /= np.linalg.norm(normal)
    normal *= np.sign(normal[2])  # towards the camera at +Z
    np.testing.assert_allclose(img.aovs["geometric_normal"].reshape(-1, 3), np.tile(normal, (96, 1)), atol=1e-5)


@pytest.mark.parametrize("scale", SCALES)
def test_a_single_sided_quad_seen_from_behind_is_culled_at_any_scale(scale):
    """A tilted single-sided quad facing away from the camera, in front of a double-sided one: the camera sees the
    far quad through it. The back-face test's float32 cross product of edges was NaN at 1e20 and 0 at 1e-25, and
    the near quad's back was drawn."""
    near = [[-100, -100, -4], [-100, 100, -6], [100, 100, -8], [100, -100, -6]]  # tilted, clockwise seen from +Z
    far = [[-100, -100, -20], [100, -100, -20], [100, 100, -20], [-100, 100, -20]]
    scene = wrt.Scene(meshes=[quad("/near", near, scale, double_sided=False), quad("/far", far, scale)])
    img = wrt.render(scene, camera=scaled_camera(scale), width=12, height=8, device="cpu", integrator="normals")
    np.testing.assert_array_equal(img.aovs["prim"] // 2, 1)  # triangles 2 and 3: the far quad
