"""Flags, choices and numbers of the public Python API outside the render's own: a bool taken by its truth, a name
iterated letter by letter or a number numpy refused in its own words were each mistakes passed on without a word."""

import numpy as np
import pytest

import wrt


@pytest.fixture
def image():
    return wrt.Image(np.zeros((2, 3, 3), np.float32), {"depth": np.ones((2, 3), np.float32)})


@pytest.mark.parametrize("png", ["false", None, 2, np.zeros(1)])
def test_save_aovs_png_is_a_flag(image, tmp_path, png):
    with pytest.raises(TypeError, match="save_aovs: png must be True or False"):
        image.save_aovs(tmp_path, png=png)
    assert not list(tmp_path.iterdir())  # refused before any file is written


@pytest.mark.parametrize("png", [False, 0, np.False_, True, 1, np.True_])
def test_save_aovs_takes_bools_and_0_1(image, tmp_path, png):
    written = image.save_aovs(tmp_path, png=png)
    assert sorted(p.name for p in written) == (["depth.npy", "depth.png"] if png else ["depth.npy"])
    np.testing.assert_array_equal(np.load(tmp_path / "depth.npy"), image.aovs["depth"])


def test_save_aovs_refuses_one_name_as_a_str(image, tmp_path):
    with pytest.raises(TypeError, match=r"names must be a list of AOV names, such as \['depth'\]"):
        image.save_aovs(tmp_path, names="depth")


@pytest.mark.parametrize("save", [lambda img, d: img.save_aovs(d, names=["Depth"]),
                                  lambda img, d: img.save_aov_png("Depth", d / "x.png")])
def test_an_unknown_aov_names_the_one_meant(image, tmp_path, save):
    with pytest.raises(ValueError, match=r"unknown AOV 'Depth' \(did you mean 'depth'\?\); available: depth"):
        save(image, tmp_path)
