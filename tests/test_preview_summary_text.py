"""The summary text of a preview is seen in the picture, whatever its window: VTK's corner text shrinks to fit and,
where a line is too wide even at its smallest font, draws nothing at all."""

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import wrt  # noqa: E402
from wrt.primitives import Shape  # noqa: E402


@pytest.mark.parametrize("width, source", [(320, None), (1280, "/x/" + "a long file name of words " * 25 + ".usda")],
                         ids=["320px", "1280px_long_name"])
def test_a_long_summary_line_is_still_drawn_in_a_small_window(width, source):
    """Two analytic shapes drawn with a BVH depth past the tree's: the TLAS line runs to about 180 characters, and in
    a 320 x 240 window the whole summary vanished (a picture without text, said nowhere). The pixels the summary
    changes are compared with the same view drawn without it. None of them is in the window's last column: lines
    wrapped at a width of 3 pixels a character ran past the right side and were cut off there (a 100-character line
    at 320 pixels, the title of a 650-character file name at 1280)."""
    shapes = [Shape(f"/ball{x}", "sphere", np.diag([0.5, 0.5, 0.5, 1.0])) for x in range(2)]
    shapes[1].to_world[0, 3] = 3.0
    scene = wrt.Scene(shapes=shapes, source=source)
    pictures, texts = [], []
    for show_text in (True, False):
        with pytest.warns(UserWarning, match="past the tree's deepest leaf"):
            plotter = wrt.preview(scene, bvh_depth=5, window_size=(width, 240), show_text=show_text)
        try:
            pictures.append(plotter.screenshot())
            if show_text:
                texts.append(plotter.actors["summary"].GetText(2))
        finally:
            plotter.close()
    words = " ".join(texts[0].split())
    assert "past the deepest leaf (depth 1): the leaves, 2 boxes (2 entries" in words, texts[0]
    changed = np.any(pictures[0] != pictures[1], axis=-1)
    assert changed[: 240 // 2, : 320 // 2].sum() > 200, "the summary text was not drawn"
    assert not changed[:, -1].any(), "the summary text runs past the window's right side"
