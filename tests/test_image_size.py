"""The image size of a render without render settings: where one side is given, the other keeps the camera's aspect
(its apertures', else the 4:3 of wrt's 640x480 default), as ``usdrecord --imageWidth`` does, in ``wrt render`` and
``wrt.render`` alike; a side alone gave a stretched image (``--width 100``: 100x480)."""

import numpy as np
from pxr import Usd, UsdGeom
from usda_text import load, write

import wrt
from wrt.cli import main
from wrt.render import resolve_view

BODY = """def Cube "Box"
{
    double size = 1
}
def Camera "Wide"
{
    float horizontalAperture = 30
    float verticalAperture = 10
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Plain"
{
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def aperture_aspect(path: str, prim: str) -> float:
    """Horizontal over vertical aperture of the camera at ``prim``, as USD reads it (fallbacks included)."""
    stage = Usd.Stage.Open(path)  # held: a prim of a stage let go is invalid
    camera = UsdGeom.Camera(stage.GetPrimAtPath(prim))
    return camera.GetHorizontalApertureAttr().Get() / camera.GetVerticalApertureAttr().Get()


def test_one_side_keeps_the_stage_cameras_aspect(tmp_path):
    path = write(tmp_path, BODY)
    scene = load(path)
    assert scene.render_settings is None
    for prim in ("/Wide", "/Plain"):  # 3:1, and USD's fallback apertures
        aspect = aperture_aspect(path, prim)
        assert resolve_view(scene, prim, 100, None)[1:] == (100, round(100 / aspect))
        assert resolve_view(scene, prim, None, 20)[1:] == (round(20 * aspect), 20)
        assert resolve_view(scene, prim, 1, None)[1:] == (1, 1)  # at least 1
    assert resolve_view(scene, "/Wide")[1:] == (640, 480)  # neither given: wrt's default
    assert resolve_view(scene, "/Wide", 50, 40)[1:] == (50, 40)  # both given: as given
    assert wrt.render(scene, camera="/Wide", width=30, device="cpu").rgb.shape == (10, 30, 3)
    renderer = wrt.Renderer(scene, cameras=["/Wide", "/Plain"], width=30, device="cpu")
    assert (renderer.width, renderer.height) == (30, 10)  # one size for the batch: the first camera's aspect
    renderer.set_cameras(["/Plain"])
    assert (renderer.width, renderer.height) == (30, 10)


def test_one_side_keeps_4_3_for_cameras_of_one_aperture(tmp_path):
    """A camera wrt makes to frame a stage without cameras, and ``Camera.look_at``, keep one aperture (the other does
    not shape the film): the other side is 4:3, wrt's default aspect."""
    scene = load(write(tmp_path, 'def Cube "Box"\n{\n    double size = 1\n}\n'))
    assert resolve_view(scene, None, 100, None)[1:] == (100, 75)
    assert resolve_view(scene, None, None, 30)[1:] == (40, 30)
    own = wrt.Camera.look_at((0, 0, 5), (0, 0, 0))
    assert resolve_view(scene, own, 8, None)[1:] == (8, 6)


def test_cli_width_alone_keeps_the_cameras_aspect(tmp_path):
    path = write(tmp_path, BODY)
    out = tmp_path / "wide.npy"
    assert main(["render", path, "--camera", "/Wide", "--width", "30", "-o", str(out), "-q"]) == 0
    aspect = aperture_aspect(path, "/Wide")
    assert np.load(out).shape == (round(30 / aspect), 30, 3)
