"""Warnings of a preview: each said once, and none in the words of an image the preview does not make."""

import warnings

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from shading_helpers import quad  # noqa: E402

import wrt  # noqa: E402
from wrt.primitives import Shape  # noqa: E402


def previewed_warnings(scene, width: int = 16, height: int = 12, **options) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wrt.preview(scene, width=width, height=height, window_size=(32, 24), show_text=False, **options).close()
    return [str(w.message) for w in caught]


def test_a_camera_that_sees_nothing_is_named_once_and_only_with_the_image():
    """A camera facing away from the one ball (it lies from -11 to -9 along the view: behind the eye). The sample
    rays' renderer and the image's both said 'camera sees nothing ...; the image is background only', twice for
    --rays --image; with --rays alone it spoke of an image the preview does not make. The depths are the ball's,
    10 behind the eye with radius 1."""
    ball = Shape("/ball", "sphere", np.diag([1.0, 1.0, 1.0, 1.0]))
    ball.to_world[2, 3] = 10.0  # the camera looks down -Z from the origin
    scene = wrt.Scene(shapes=[ball])
    cam = wrt.Camera(clipping_range=(1.0, 1e6))
    said = [m for m in previewed_warnings(scene, camera=cam, rays=4, image=True) if "sees nothing" in m]
    assert len(said) == 1, said
    assert "lies from -11 to -9 along its view; the image is background only" in said[0]
    said = previewed_warnings(scene, camera=cam, rays=4)
    assert not [m for m in said if "image" in m], said


def test_a_camera_too_far_for_float32_is_named_once_with_rays_and_the_image():
    """A card 1.5 across a million units from the origin, seen by the camera that frames it: float32 resolves
    distances along its rays only to about 0.2 there (an ulp of 1e6 is 0.0625), and the rays' renderer and the
    image's both said so (the rays on a grid of the film's pixels: on a coarser one the card covers no pixel, and
    nothing is lost)."""
    card = quad((1e6, 1e6, 1e6), (1, 0, 0), (0, 1, 0.5), name="/card")
    said = previewed_warnings(wrt.Scene(meshes=[card]), 40, 30, rays=40 * 30, image=True)
    assert len([m for m in said if "float32 resolves distances" in m]) == 1, said


@pytest.mark.parametrize("options", [{"bvh_depth": 3}, {"bvh_leaves": True}], ids=["depth3", "leaves"])
def test_the_bvh_of_a_stage_with_nothing_to_draw_is_said_to_be_empty_not_drawn_as_leaves(tmp_path, options):
    """A stage with no gprims (USD's own traversal finds none): its BVH has no triangles and no box. With
    bvh_depth 3 the preview warned that the depth was past the deepest leaf and 'the boxes drawn are its leaves', and
    the summary said 'the leaves, 0 boxes'; it says the tree is empty, with no boxes drawn, and warns of nothing but
    the empty view."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "empty.usda"))
    UsdGeom.Xform.Define(stage, "/World")
    stage.Save()
    opened = Usd.Stage.Open(str(tmp_path / "empty.usda"))
    assert not [p for p in opened.Traverse() if p.IsA(UsdGeom.Gprim)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plotter = wrt.preview(str(tmp_path / "empty.usda"), window_size=(320, 240), **options)
    said = [str(w.message) for w in caught]
    assert len(said) == 1 and "nothing to draw" in said[0], said
    text = plotter.actors["summary"].GetText(2).replace("\n  ", " ")
    plotter.close()
    assert "bvh" not in plotter.actors
    line = next(line for line in text.splitlines() if line.startswith("BVH"))
    assert "empty" in line and "no boxes" in line and "leaves" not in line, line
