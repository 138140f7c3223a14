"""Fields of lights and shapes built in Python, checked as a mesh's are: a value of the wrong kind is refused naming
the object and the field (when made, and when assigned later at the next render or trace), and the forms a mesh's
arrays may take (a ``wp.array``, an array behind DLPack, a ``(3, 4)`` affine transform) are read."""

import numpy as np
import pytest

import wrt

# Looking straight down at the origin.
TOP = wrt.Camera.orthographic((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), height=4.0)
WHITE = np.ones(3, np.float32)


def make_light(kind: str, **fields):
    """A light of each kind at path ``/L``, placed above the origin (area lights facing down)."""
    up = np.eye(4)
    up[2, 3] = 3.0
    makers = {
        "distant": lambda: wrt.DistantLight(np.float64([0.0, 0.0, -1.0]), WHITE, path="/L", **fields),
        "sphere": lambda: wrt.SphereLight(np.float64([0.0, 0.0, 3.0]), 0.5, WHITE, path="/L", **fields),
        "rect": lambda: wrt.RectLight(up, 2.0, 2.0, WHITE, path="/L", **fields),
        "disk": lambda: wrt.DiskLight(up, 1.0, WHITE, path="/L", **fields),
        "cylinder": lambda: wrt.CylinderLight(up, 2.0, 0.5, WHITE, path="/L", **fields),
        "mesh": lambda: wrt.MeshLight("/L", WHITE, **fields),
        "dome": lambda: wrt.DomeLight(WHITE, path="/L", **fields),
    }
    return makers[kind]()


FLAGS = [(kind, name) for kind in ("distant", "sphere", "rect", "disk", "cylinder", "mesh") for name in
         ("normalize", "shadows")] + [("sphere", "treat_as_point"), ("dome", "shadows")]
LIGHT_CLASSES = {"distant": "DistantLight", "sphere": "SphereLight", "rect": "RectLight", "disk": "DiskLight",
                 "cylinder": "CylinderLight", "mesh": "MeshLight", "dome": "DomeLight"}


@pytest.mark.parametrize("kind, name", FLAGS)
@pytest.mark.parametrize("value", ["false", None, np.array([True, False]), 2])
def test_a_light_flag_that_is_no_bool_is_refused_naming_the_light(kind, name, value):
    """``normalize="false"`` (any string, None, a mask) was taken by its truth: the light normalized (or its shadows
    kept) without a word, where a mesh's ``double_sided`` is refused. Refused naming the light and the field."""
    words = rf"^/L: {LIGHT_CLASSES[kind]} {name} must be True or False, got "
    with pytest.raises(TypeError, match=words):
        make_light(kind, **{name: value})


@pytest.mark.parametrize("value", [np.bool_(True), 1, np.bool_(False), 0])
def test_a_light_flag_given_as_a_numpy_bool_or_zero_one_is_the_bool_it_says(value):
    """A numpy bool (``mask[k]``) and 0 and 1 mean what they say. Oracle: a 2 x 4 rect light of colour 1 has radiance
    1 / 8 normalized and 1 otherwise."""
    light = wrt.RectLight(np.eye(4), 2.0, 4.0, WHITE, normalize=value, shadows=value)
    assert type(light.normalize) is bool and type(light.shadows) is bool
    assert light.normalize == light.shadows == bool(value)
    np.testing.assert_allclose(light.radiance, np.full(3, 1.0 / 8.0 if value else 1.0), rtol=1e-6)


def test_a_light_flag_assigned_later_is_checked_at_the_next_render_as_a_meshs_is():
    """A field assigned after construction is checked at the next render (a kept Renderer's too), as a mesh's
    ``double_sided`` is at the next trace: ``light.normalize = "false"`` normalized the light without a word."""
    ball = wrt.primitives.Shape("/Ball", "sphere", np.eye(4), double_sided=True)
    light = make_light("sphere")
    scene = wrt.Scene(shapes=[ball], lights=[light])
    renderer = wrt.Renderer(scene, camera=TOP, width=4, height=4)
    renderer.render()
    light.normalize = "false"
    with pytest.raises(TypeError, match=r"^/L: SphereLight normalize must be True or False, got str 'false'"):
        renderer.render()
    with pytest.raises(TypeError, match=r"^/L: SphereLight normalize must be True or False"):
        wrt.render(scene, camera=TOP, width=4, height=4)
    light.normalize = np.bool_(False)
    wrt.render(scene, camera=TOP, width=4, height=4)
    assert light.normalize is False
