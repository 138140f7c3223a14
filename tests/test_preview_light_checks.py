"""A light whose position or transform was given a NaN or an infinity after it was made (assigned, or written in
place) was outlined by ``wrt.preview`` with non-finite points and counted as drawn, without a word, where a render
refuses the scene naming the light and the field. The preview refuses it in the render's words (the oracle: what
``wrt.render`` raises for the same scene), before any plotter is made."""

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from pyvista.plotting import plotter as pv_plotter  # noqa: E402

import wrt  # noqa: E402
from wrt.lights import RectLight, SphereLight  # noqa: E402


def lit_triangle(light):
    points = np.float32([[-1, -1, -5], [1, -1, -5], [0, 1, -5]])
    return wrt.Scene(meshes=[wrt.Mesh("/T", points, np.array([[0, 1, 2]]), [0])], lights=[light])


def nan_position():
    scene = lit_triangle(SphereLight(np.array([0.0, 0.0, 3.0]), 0.5, np.ones(3), path="/Ball"))
    scene.lights[0].position = np.array([np.nan, 0.0, 3.0])
    return scene


def infinite_transform():
    scene = lit_triangle(RectLight(np.eye(4), 1.0, 1.0, np.ones(3), path="/Panel"))
    to_world = np.eye(4)
    to_world[0, 3] = np.inf
    scene.lights[0].to_world = to_world
    return scene


def nan_written_in_place():
    scene = lit_triangle(RectLight(np.eye(4), 1.0, 1.0, np.ones(3), path="/Panel"))
    scene.lights[0].to_world[1, 3] = np.nan
    return scene


@pytest.mark.parametrize("make", [nan_position, infinite_transform, nan_written_in_place])
def test_a_light_made_non_finite_is_refused_by_the_preview_in_the_renders_words(make):
    with pytest.raises(wrt.SceneError) as refused:
        wrt.render(make(), width=8, height=6)
    words = str(refused.value)
    assert "must be finite numbers" in words and ("/Ball" in words or "/Panel" in words), words
    before = set(pv_plotter._ALL_PLOTTERS)
    with pytest.raises(wrt.SceneError) as previewed:
        wrt.preview(make(), window_size=(32, 24))
    assert str(previewed.value) == words
    assert set(pv_plotter._ALL_PLOTTERS) == before
    plotter = wrt.preview(make(), window_size=(32, 24), show_lights=False)  # its lights are not drawn: no matter
    try:
        assert "lights" not in plotter.actors
    finally:
        plotter.close()
