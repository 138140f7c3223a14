"""The preview's sample rays drawn over the stretch the renderer traces: from where a ray starts (an orthographic
camera's near plane behind it) to its hit, or to where its range ends (a clipping plane, else the far rectangle);
and the image plane and eye dot of such a camera. Oracles: the analytic planes of these axis-aligned scenes."""

import numpy as np
import pytest
from shading_helpers import quad

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import wrt  # noqa: E402


def drawn(plotter, actor: str) -> np.ndarray:
    return np.asarray(plotter.actors[actor].mapper.dataset.points, np.float64)


def test_missing_rays_end_at_the_clipping_plane_that_cuts_them():
    """A camera clipping plane cutting away what lies deeper than 3 (``UsdGeom.Camera.clippingPlanes``) ends every
    ray there: the renderer sees nothing past it. The preview drew those rays on to the far rectangle, 20 deep,
    through the card at depth 6 that the render does not show."""
    card = quad((0, 0, -6), (4, 0, 0), (0, 4, 0), name="/card")
    back = quad((0, 0, -20), (100, 0, 0), (0, 100, 0), name="/back")
    cam = wrt.Camera(clipping_planes=np.array([[0.0, 0.0, 1.0, 3.0]]))  # kept where z + 3 >= 0: depth <= 3
    plotter = wrt.preview(wrt.Scene(meshes=[card, back]), camera=cam, rays=9, width=30, height=30,
                          window_size=(32, 24), show_text=False)
    try:
        assert "rays_hit" not in plotter.actors
        origins, ends = drawn(plotter, "rays_miss").reshape(2, -1, 3)
        far = drawn(plotter, "frustum")[4:8]
    finally:
        plotter.close()
    assert len(ends) == 9
    np.testing.assert_allclose(far[:, 2], -20.0)  # the far rectangle: the deepest corner, unchanged
    np.testing.assert_allclose(origins, 0.0, atol=1e-12)  # from the eye
    np.testing.assert_allclose(ends[:, 2], -3.0, rtol=1e-5)  # on the clipping plane z = -3


ORTHO_BEHIND = wrt.Camera(projection="orthographic", horizontal_aperture=100.0, vertical_aperture=100.0,
                          clipping_range=(-5.0, 100.0))  # a 10 x 10 film at z = 0 seeing from z = 5 down to -100


def test_rays_of_an_orthographic_camera_seeing_behind_it_run_from_its_near_plane():
    """An orthographic camera of clippingRange (-5, 100) traces its rays from 5 behind its plane. A card 2 behind the
    plane is hit there; the hit rays were drawn from the camera's plane back to the card (a stretch they never
    travel), and the misses from that plane only. Both run from the near plane, z = 5, now."""
    card = quad((0, 0, 2), (4, 0, 0), (0, 4, 0), name="/card")  # hit 3 after the rays start, 2 behind the plane
    plotter = wrt.preview(wrt.Scene(meshes=[card]), camera=ORTHO_BEHIND, rays=25, width=30, height=30,
                          window_size=(32, 24), show_text=False)
    try:
        hit_starts, hit_ends = drawn(plotter, "rays_hit").reshape(2, -1, 3)
        miss_starts, miss_ends = drawn(plotter, "rays_miss").reshape(2, -1, 3)
    finally:
        plotter.close()
    assert len(hit_ends) > 2 and len(miss_ends) > 2
    np.testing.assert_allclose(hit_ends[:, 2], 2.0, rtol=1e-6)
    np.testing.assert_allclose(hit_starts[:, 2], 5.0, rtol=1e-6)
    np.testing.assert_allclose(miss_starts[:, 2], 5.0, rtol=1e-6)
    np.testing.assert_allclose(np.abs(hit_starts[:, :2]), np.abs(hit_ends[:, :2]), atol=1e-6)  # straight down


def test_image_plane_and_eye_of_an_orthographic_camera_seeing_behind_it():
    """Under that camera the nearest hit lies at depth -2: the image plane went to 80 % of it, -1.6, past the hit
    (inside what it pictures), and the eye dot, sized by that depth, got a negative radius and vanished. The image
    plane lies between the near plane and the nearest hit, and the dot is drawn round the eye."""
    card = quad((0, 0, 2), (4, 0, 0), (0, 4, 0), name="/card")
    floor = quad((0, 0, -10), (40, 0, 0), (0, 40, 0), name="/floor")
    plotter = wrt.preview(wrt.Scene(meshes=[card, floor]), camera=ORTHO_BEHIND, rays=25, width=30, height=30,
                          window_size=(32, 24), show_text=False)
    try:
        image_plane = drawn(plotter, "frustum")[8:12]
        eye = plotter.actors["eye"].mapper.dataset
    finally:
        plotter.close()
    assert np.ptp(image_plane[:, 2]) == 0.0
    assert 2.0 < image_plane[0, 2] <= 5.0, image_plane[0, 2]  # z = -depth: between the card and the near plane
    radius = 0.5 * (eye.bounds[1] - eye.bounds[0])
    assert radius > 0.0
    np.testing.assert_allclose(eye.center, 0.0, atol=1e-6 + radius * 1e-3)


@pytest.mark.parametrize("size", [1.0, 1e-4, 1e-7, 1e-9])
def test_the_eye_dot_keeps_its_size_in_proportion_to_a_tiny_scene(size):
    """The eye dot is a hundredth of the scene's diagonal, seen by the camera that frames it: the diagonal was
    floored at 1e-6, so below that size the dot grew against the scene, to a quarter of it at 1e-9, a ball over the
    frustum's apex. Oracle: the diagonal of the two triangles' box, from their points in float64."""
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]]) * size
    scene = wrt.Scene(meshes=[wrt.Mesh("/m", points.astype(np.float32), np.array([[0, 1, 2], [1, 3, 2]]), [0, 1])])
    plotter = wrt.preview(scene, window_size=(32, 24), show_text=False)
    try:
        eye = plotter.actors["eye"].mapper.dataset
    finally:
        plotter.close()
    corners = points.astype(np.float32).astype(np.float64)
    diagonal = np.linalg.norm(corners.max(axis=0) - corners.min(axis=0))
    radius = 0.5 * (eye.bounds[1] - eye.bounds[0])
    np.testing.assert_allclose(radius / diagonal, 0.01, rtol=0.02)
