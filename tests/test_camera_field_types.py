"""A wrt.Camera's numbers must be real numbers: a to_world of text ("1.0"), bools or complex values was converted to
float64 without a word (the imaginary part dropped with only numpy's warning), and True was a focal length, an
aperture or a field of view of 1. Each raises ValueError naming the field. Oracle: the camera's own contract
("to_world must be a (4, 4) matrix of numbers", finite positive focal length), and numpy's dtype kinds."""

import warnings

import numpy as np
import pytest

import wrt

PLACED = np.eye(4)
PLACED[2, 3] = 5.0


@pytest.mark.parametrize("dtype", [str, bool, complex])
def test_to_world_not_real_numbers_raises(dtype):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy's ComplexWarning, before the fix
        with pytest.raises(ValueError, match="to_world must be a \\(4, 4\\) matrix of numbers"):
            wrt.Camera(to_world=PLACED.astype(dtype))


@pytest.mark.parametrize("field, named", [("focal_length", "focal_length=True"), ("horizontal_aperture", "Truex"),
                                          ("vertical_aperture", "xTrue"), ("f_stop", "f_stop=True")])
def test_a_bool_is_no_camera_number(field, named):
    with pytest.raises(ValueError, match=named):
        wrt.Camera(to_world=PLACED, **{field: True})


def test_a_bool_is_no_field_of_view():
    with pytest.raises(ValueError, match="fov_y_deg"):
        wrt.Camera.look_at((0, 0, 5), (0, 0, 0), fov_y_deg=True)


def test_numbers_are_taken():
    camera = wrt.Camera(to_world=PLACED.astype(object).tolist(), focal_length=35)  # lists and ints, as before
    np.testing.assert_array_equal(camera.to_world, PLACED)
