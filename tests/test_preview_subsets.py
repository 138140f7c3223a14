"""A preview past its budgets of analytic shapes, instances and lights draws a subset spread over the scene, and says
how many of how many it draws. The first ones in order were drawn: a scene written corner first showed one corner.
The oracle is the scene's own box, computed with float64 numpy from the transforms given."""

import importlib

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import wrt  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.lights import SphereLight  # noqa: E402
from wrt.preview_lights import light_glyphs  # noqa: E402
from wrt.primitives import Shape  # noqa: E402
from wrt.scene import Mesh  # noqa: E402

preview_module = importlib.import_module("wrt.preview")  # ``wrt.preview`` itself is the function
EXTENT = 100.0  # the scene spans [0, EXTENT] on every axis; its first CORNER things lie within [0, 1]
CORNER, TOTAL = 300, 1000


def corner_first_places() -> np.ndarray:
    """``(TOTAL, 3)`` float64 places: the first CORNER in the unit cube at the origin, the others all over the scene,
    two of them at its opposite corners (so the scene's box is exactly ``[0, EXTENT]^3`` about the places)."""
    rng = np.random.default_rng(123)
    places = np.concatenate([rng.uniform(0.0, 1.0, (CORNER, 3)), rng.uniform(0.0, EXTENT, (TOTAL - CORNER, 3))])
    places[CORNER], places[-1] = 0.0, EXTENT
    return places


def translations(places) -> np.ndarray:
    matrices = np.tile(np.eye(4), (len(places), 1, 1))
    matrices[:, :3, 3] = places
    return matrices


def shape_scene(instanced: bool) -> wrt.Scene:
    """Unit spheres at the places: as shapes of their own, or as instances of a prototype holding one."""
    places = translations(corner_first_places())
    if not instanced:
        return wrt.Scene(shapes=[Shape(f"/ball{k}", "sphere", m) for k, m in enumerate(places)])
    prototype = Prototype("/P", shapes=[Shape("/P/ball", "sphere", np.eye(4))])
    return wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms(np.zeros(TOTAL, int), places))


def assert_covers(drawn_bounds, lower, upper, slack: float) -> None:
    """pyvista ``bounds`` (xmin, xmax, ymin, ...) reach ``lower`` and ``upper`` to within ``slack``."""
    drawn = np.asarray(drawn_bounds, np.float64).reshape(3, 2)
    assert np.all(drawn[:, 0] <= lower + slack) and np.all(drawn[:, 1] >= upper - slack), (drawn, lower, upper)


@pytest.mark.parametrize("instanced", [False, True], ids=["shapes", "instanced_shapes"])
def test_shapes_past_the_budget_are_drawn_spread_over_the_scene(monkeypatch, instanced):
    """1,000 unit spheres, the first 300 in one unit corner of a scene 100 across, and a budget of 100: the 100
    drawn were the first, all in that corner. The drawn spheres reach the scene's box (the places +- the radius 1,
    to within a fifth of the radius for the tessellation), and the title says how many of how many are drawn."""
    monkeypatch.setattr(preview_module, "SHAPE_BUDGET", 100)
    places = corner_first_places()
    lower, upper = places.min(axis=0) - 1.0, places.max(axis=0) + 1.0
    plotter = wrt.preview(shape_scene(instanced), window_size=(64, 48), show_lights=False)
    try:
        drawn = plotter.actors["shapes"].mapper.dataset
        assert_covers(drawn.bounds, lower, upper, slack=0.2)
        assert "showing 100 of 1,000 analytic shapes" in plotter.title, plotter.title
        one = preview_module.shape_meshes(wrt.Scene(shapes=[Shape("/one", "sphere", np.eye(4))]))
        assert drawn.n_cells == 100 * one.n_cells  # as many spheres as said
    finally:
        plotter.close()


def test_instances_past_the_budget_are_drawn_spread_over_the_scene():
    """1,000 instances of a four-triangle tetrahedron (the first 300 in a unit corner), over four times a budget of 40
    triangles: the ten that fit were the first ten, all in the corner. They reach the scene's box (the tetrahedron's
    corners moved to every place), and the title says how many of how many instances are drawn."""
    tet = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    mesh = Mesh("/P/tet", tet, np.int32([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]), np.arange(4))
    places = corner_first_places()
    scene = wrt.Scene(prototypes=[Prototype("/P", [mesh])],
                      instances=Instances.from_transforms(np.zeros(TOTAL, int), translations(places)))
    corners = (places[:, None, :] + tet[None].astype(np.float64)).reshape(-1, 3)
    plotter = wrt.preview(scene, max_triangles=40, window_size=(64, 48), show_lights=False)
    try:
        drawn = plotter.actors["scene"].mapper.dataset
        assert drawn.n_cells == 40
        assert_covers(drawn.bounds, corners.min(axis=0), corners.max(axis=0), slack=1e-4)
        assert "showing 10 of 1,000 instances, spread evenly" in plotter.title, plotter.title
    finally:
        plotter.close()


def test_shapes_of_instances_cut_to_the_budget_are_counted_of_the_whole_scene(monkeypatch):
    """40 instances of a prototype of a triangle and a ball, over four times a budget of 8 triangles: the 8 that fit
    hold 8 balls, of which a shape budget of 5 draws 5, and the title said 'showing 5 of 8 analytic shapes' of a scene
    of 40 (the shapes of the kept instances alone were counted). The total is the scene's: one ball per instance."""
    monkeypatch.setattr(preview_module, "SHAPE_BUDGET", 5)
    triangle = Mesh("/P/tri", np.float32([[0, 0, 0], [0.5, 0, 0], [0, 0.5, 0]]), np.int32([[0, 1, 2]]), [0])
    prototype = Prototype("/P", [triangle], [Shape("/P/ball", "sphere", np.diag([0.2, 0.2, 0.2, 1.0]))])
    n = 40
    scene = wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms(
        np.zeros(n, int), translations(np.column_stack([np.arange(n), np.zeros(n), np.zeros(n)]))))
    plotter = wrt.preview(scene, max_triangles=8, window_size=(64, 48), show_lights=False)
    try:
        assert f"showing 8 of {n} instances, spread evenly" in plotter.title, plotter.title
        assert f"showing 5 of {n} analytic shapes" in plotter.title, plotter.title
    finally:
        plotter.close()


def test_lights_past_the_budget_are_drawn_spread_over_the_scene():
    """1,000 point lights along x, the first 300 within one unit of the origin, the others out to 100, and a budget
    of 10: the ten drawn were the first. The drawn ones run the row's length, and the note counts the others."""
    xs = np.concatenate([np.linspace(0.0, 1.0, CORNER), np.linspace(1.5, EXTENT, TOTAL - CORNER)])
    lights = [SphereLight(position=(x, 0.0, 0.0), radius=0.0, color=(1.0, 1.0, 1.0)) for x in xs]
    glyphs, note = light_glyphs(lights, (0.0, -1.0, -1.0), (EXTENT, 1.0, 1.0), max_lights=10)
    drawn = np.unique(glyphs.cell_data["light"])
    assert len(drawn) == 10 and "10 drawn, 990 left out" in note, note
    assert glyphs.bounds[0] <= xs.min() + 1e-6 and glyphs.bounds[1] >= xs.max() - 1e-6, (glyphs.bounds, xs[-1])


def reference_spread_rows(centres, budget: int) -> np.ndarray:
    """spread_rows' definition in plain Python sets: the rows furthest along each axis, then an even stride through the
    others (row k of m others taken at (k (m - 1)) // (budget - 1), as even_rows takes them)."""
    centres = np.asarray(centres, np.float64)
    total = len(centres)
    if budget >= total:
        return list(range(total))
    if budget <= 0:
        return []
    extremes = sorted({int(r) for r in list(centres.argmin(axis=0)) + list(centres.argmax(axis=0))})
    if len(extremes) >= budget:
        return sorted(extremes[:budget])
    rest = [r for r in range(total) if r not in set(extremes)]
    left = budget - len(extremes)
    taken = [0] if left == 1 else [k * (len(rest) - 1) // (left - 1) for k in range(left)]
    return sorted(extremes + [rest[k] for k in taken])


@pytest.mark.parametrize("total", [1, 2, 7, 50, 1000])
def test_spread_rows_matches_its_definition(total):
    """Every budget from 0 to past the count, on random places and on places whose extremes fall on the first and
    last rows and next to each other: the rows are those of the definition in plain Python."""
    from wrt.preview_subsets import spread_rows

    rng = np.random.default_rng(total)
    grid = np.zeros((total, 3))
    grid[:, 0] = np.arange(total)
    grid[:, 1] = np.arange(total) % 3
    for centres in (rng.normal(size=(total, 3)), grid):
        for budget in sorted({0, 1, 2, 3, 5, 6, 7, total // 2, total - 1, total, total + 3}):
            got = spread_rows(centres, budget)
            assert got.dtype == np.int64
            assert got.tolist() == reference_spread_rows(centres, budget), (total, budget)


def test_rows_within_a_million_instances_does_no_set_operation_over_all_of_them(monkeypatch):
    """A preview of a million-instance PointInstancer past its budget spent over a minute in rows_within: each of its
    twenty bisection steps ran np.setdiff1d and np.union1d over all million rows (a hash of a million ints each).
    The subset it picks is the definition's, found without them."""
    from wrt.preview_subsets import rows_within

    rng = np.random.default_rng(7)
    centres = rng.uniform(0.0, 100.0, (1_000_000, 3))
    sizes = np.full(len(centres), 12, np.int64)

    def refused(*args, **kwargs):
        raise AssertionError("a set operation over every instance")

    monkeypatch.setattr(np, "setdiff1d", refused)
    monkeypatch.setattr(np, "union1d", refused)
    rows = rows_within(centres, sizes, 0, 12 * 1000)
    monkeypatch.undo()
    assert len(rows) == 1000
    extremes = set(np.concatenate([centres.argmin(axis=0), centres.argmax(axis=0)]).tolist())
    assert extremes <= set(rows.tolist())
    rest = np.setdiff1d(np.arange(len(centres)), list(extremes))
    expected = np.union1d(list(extremes), rest[np.arange(1000 - len(extremes)) * (len(rest) - 1)
                                                // (1000 - len(extremes) - 1)])
    assert rows.tolist() == expected.tolist()
