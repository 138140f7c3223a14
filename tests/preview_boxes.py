"""What a preview's BVH boxes are, read back from its pyvista plotter (the preview tests' oracles compare them)."""

import numpy as np


def box_data(plotter, values: str) -> tuple[np.ndarray, np.ndarray]:
    """``(corners, per_box)``: the 8 corners of each BVH box ``plotter`` draws (``(B, 8, 3)`` float64) and the cell
    data ``values`` of each (``depth``, ``sah_share``: 12 cells, its edges, a box); the plotter is closed."""
    try:
        boxes = plotter.actors["bvh"].mapper.dataset
        return np.asarray(boxes.points, np.float64).reshape(-1, 8, 3), np.asarray(boxes.cell_data[values])[::12]
    finally:
        plotter.close()
