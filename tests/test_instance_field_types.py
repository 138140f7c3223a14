"""Instances' transforms, colours and opacities that are not real numbers raise ValueError naming the field, as a
mesh's arrays and a shape's do: text ("1.0") and bools were converted to floats, and complex values lost their
imaginary part with only numpy's warning, each placing or colouring instances without a word. Oracle: README's
contract for arrays built in Python, and float64 ray casting for the arrays still taken."""

import warnings

import numpy as np
import pytest

import wrt
from wrt.instancing import Instances, Prototype

TRIANGLE = np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]])
IDENTITY = np.eye(4)[None]


def instances(to_world=IDENTITY, **kwargs) -> Instances:
    return Instances(np.zeros(1, np.int32), to_world, np.zeros(1, np.int32), np.full(1, -1, np.int32),
                     sources=["/I"], **kwargs)


@pytest.mark.parametrize("to_world", [IDENTITY.astype(str), IDENTITY.astype(bool), IDENTITY.astype(complex)],
                         ids=["text", "bool", "complex"])
def test_transforms_not_real_numbers_raise(to_world):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy's ComplexWarning, before the fix
        with pytest.raises(ValueError, match="Instances to_world must be real numbers"):
            instances(to_world)


@pytest.mark.parametrize("field, value", [("colors", np.full((1, 3), "0.5")), ("colors", np.ones((1, 3), bool)),
                                          ("opacities", np.full(1, "0.5")), ("opacities", np.ones(1, bool))])
def test_colours_and_opacities_not_real_numbers_raise(field, value):
    with pytest.raises(ValueError, match=f"Instances {field} must be real numbers"):
        instances(**{field: value})


def test_numbers_in_an_object_array_are_taken():
    scene = wrt.Scene(prototypes=[Prototype("/P", [wrt.Mesh("/P/m", TRIANGLE, np.int32([[0, 1, 2]]))])],
                      instances=instances(IDENTITY.astype(object)))
    hits = wrt.trace(scene, np.float32([0, 0, 5]), np.float32([0, 0, -1]))
    assert hits.t[0] == 5.0  # float64: the plane z = 0 is 5 below the origin
