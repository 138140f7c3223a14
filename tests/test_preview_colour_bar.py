"""The BVH colour bar's labels, as VTK lays them out, fit the window: none overlaps another or runs past a side.

pyvista's default bar, five ``%.1e`` labels at 18 pixels on 60 % of the width from 35 %, ran the SAH labels together
below about 640 pixels and off the right side below 500. The oracle is VTK's own text measure
(``vtkTextRenderer.GetBoundingBox``) of each label, centred on its tick, ticks evenly along the bar's drawn span."""

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import vtkmodules.vtkRenderingFreeType  # noqa: E402, F401  (the text renderer's FreeType backend)
from vtkmodules.vtkRenderingCore import vtkTextRenderer  # noqa: E402

import wrt  # noqa: E402
from wrt.cli import default_scene_path  # noqa: E402


@pytest.fixture(scope="module")
def room():
    return wrt.load_usd(default_scene_path())


def label_boxes(plotter) -> tuple[np.ndarray, list[str]]:
    """``(n, 2)`` pixel [left, right] of each label of the plotter's colour bar, and the labels' texts."""
    bar = plotter.scalar_bar
    low, high = bar.GetLookupTable().GetRange()
    n = bar.GetNumberOfLabels()
    log = bar.GetLookupTable().GetScale() == 1  # VTK_SCALE_LOG10
    values = np.geomspace(low, high, n) if log else np.linspace(low, high, n)
    texts = [bar.GetLabelFormat() % v for v in values]
    x0 = bar.GetPositionCoordinate().GetComputedDisplayValue(plotter.renderer)[0]
    x1 = bar.GetPosition2Coordinate().GetComputedDisplayValue(plotter.renderer)[0]
    widths = []
    for text in texts:
        box = [0, 0, 0, 0]
        assert vtkTextRenderer.GetInstance().GetBoundingBox(bar.GetLabelTextProperty(), text, box, 72)
        widths.append(box[1] - box[0] + 1)
    centres = np.linspace(x0, x1, n)
    half = 0.5 * np.array(widths, np.float64)
    return np.stack([centres - half, centres + half], axis=1), texts


@pytest.mark.parametrize("size", [(480, 360), (320, 240), (640, 480), (1280, 800)])
@pytest.mark.parametrize("color", ["sah", "depth"])
def test_colour_bar_labels_fit_the_window(room, size, color):
    plotter = wrt.preview(room, bvh_leaves=True, bvh_color=color, window_size=size, show_text=False,
                          show_lights=False)
    try:
        plotter.render()
        boxes, texts = label_boxes(plotter)
        assert len(boxes) >= 2, texts
        assert boxes[0, 0] >= 0 and boxes[-1, 1] <= size[0], (boxes, texts, size)  # within the window
        assert np.all(boxes[1:, 0] > boxes[:-1, 1]), (boxes, texts, size)  # apart from each other
        if size[0] >= 640 and color == "sah":
            assert len(texts) == 5, texts  # a wide window keeps pyvista's five labels
    finally:
        plotter.close()


def test_depth_bar_labels_are_whole_depths_of_the_tree_when_it_spans_many_levels():
    """The depth bar keeps its labels on whole depths, so that each sits on its depth's colour band; past 8 levels it
    took five labels however they fell: leaves from depth 6 to 21 were labelled 6, 10, 14, 17, 21 at 9.75, 13.5 and
    17.25, '17' on the edge of depth 18's band. The oracle: the leaves' depths walked down the tree's arrays."""
    from wrt.trace import get_accelerator

    rng = np.random.default_rng(0)
    # Clusters ever smaller around one point: the tree's leaves lie at many depths.
    centres = np.concatenate([rng.normal(0.0, 2.0**-k, (60, 3)) for k in range(12)])
    points = (centres[:, None, :] + rng.normal(0.0, 1e-4, (len(centres), 3, 3))).reshape(-1, 3).astype(np.float32)
    scene = wrt.Scene.from_triangles(points, np.arange(len(points)).reshape(-1, 3))
    bvh = get_accelerator(scene, "wrt", "sah", "cpu").bvh
    leaf_depths, stack = [], [(0, 0)]
    while stack:
        node, depth = stack.pop()
        if bvh.prim_count[node] > 0:
            leaf_depths.append(depth)
        else:
            stack += [(int(bvh.left_first[node]) + k, depth + 1) for k in (0, 1)]
    assert max(leaf_depths) - min(leaf_depths) + 1 > 8  # the case at hand: more levels than labels
    for size in ((1280, 800), (480, 360)):
        plotter = wrt.preview(scene, bvh_leaves=True, window_size=size, show_text=False, show_lights=False)
        try:
            bar = plotter.scalar_bar
            low, high = bar.GetLookupTable().GetRange()
            values = np.linspace(low, high, bar.GetNumberOfLabels())
        finally:
            plotter.close()
        assert (low, high) == (min(leaf_depths), max(leaf_depths))
        assert len(values) >= 2
        np.testing.assert_array_equal(values, np.round(values), err_msg=f"labels between depths in {size}")
