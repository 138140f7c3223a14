"""A preview that fails leaves nothing behind: pyvista keeps every plotter not yet closed in its registry
(``pyvista.plotting.plotter._ALL_PLOTTERS``), so one that ``wrt.preview`` made and then abandoned to an error kept
its window and the meshes drawn so far for the rest of the session, one more per failed call. And an image that the
renderer refuses for its size is refused before the scene is drawn, as ``wrt preview --image`` refuses it."""

import importlib

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from pyvista.plotting import plotter as pv_plotter  # noqa: E402

import wrt  # noqa: E402

preview_module = importlib.import_module("wrt.preview")  # wrt.preview is the function


def triangle_scene():
    points = np.float32([[-1, -1, -5], [1, -1, -5], [0, 1, -5]])
    return wrt.Scene(meshes=[wrt.Mesh("/T", points, np.array([[0, 1, 2]]), [0])])


def open_plotters() -> set:
    return set(pv_plotter._ALL_PLOTTERS)


def test_an_image_too_large_to_render_is_refused_before_drawing_and_leaves_no_plotter(monkeypatch):
    """200000 x 200000 pixels: the render refused it after the plotter was made and the scene drawn, and the plotter
    stayed in pyvista's registry (three failed calls, three plotters)."""
    before = open_plotters()
    monkeypatch.setattr(preview_module, "_add_scene", lambda *a, **k: pytest.fail("the scene was drawn first"))
    with pytest.raises(ValueError, match=r"200000x200000 is 40,000,000,000 pixels; at most"):
        wrt.preview(triangle_scene(), image=True, width=200000, height=200000, window_size=(32, 24))
    assert open_plotters() == before


class Interrupted(Exception):
    """Stands in for whatever stops a preview part-way: an interrupt, a render or trace error."""


def test_a_preview_that_fails_part_way_closes_its_plotter(monkeypatch):
    def fail(*args, **kwargs):
        raise Interrupted

    before = open_plotters()
    monkeypatch.setattr(preview_module, "_sample_ray_ranges", fail)  # after the scene and the image are drawn
    with pytest.raises(Interrupted):
        wrt.preview(triangle_scene(), rays=4, window_size=(32, 24), show_text=False)
    assert open_plotters() == before
    monkeypatch.undo()
    plotter = wrt.preview(triangle_scene(), rays=4, window_size=(32, 24), show_text=False)  # one that works stays
    try:
        assert open_plotters() - before == {plotter._id_name}
    finally:
        plotter.close()
