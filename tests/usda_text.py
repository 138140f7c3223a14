"""Small USDA stages written from text in tests: the layer, numbers as USDA arrays, and loading or tracing them
without the warnings a test does not look at."""

import warnings

import numpy as np

import wrt


def write(tmp_path, body: str, name: str = "scene.usda") -> str:
    """A Y-up layer ``name`` in ``tmp_path`` holding ``body``; its path."""
    path = tmp_path / name
    path.write_text(f'#usda 1.0\n(\n    upAxis = "Y"\n)\n{body}\n')
    return str(path)


def fmt(rows) -> str:
    """Rows of numbers as a USDA tuple array, ``[(0.5, 1.0, 2.0), ...]`` (integers stay integers)."""
    return "[" + ", ".join("(" + ", ".join(f"{v!r}" for v in np.asarray(row).tolist()) + ")" for row in rows) + "]"


def floats(values) -> str:
    """Numbers as a USDA float array."""
    return "[" + ", ".join(f"{float(v)!r}" for v in values) + "]"


def preview_material(color) -> str:
    """USDA text of a UsdPreviewSurface material ``/M`` of diffuse ``color``, to bind with
    ``rel material:binding = </M>``."""
    r, g, b = (float(c) for c in color)
    return ('def Material "M"\n{\n    token outputs:surface.connect = </M/S.outputs:surface>\n'
            '    def Shader "S"\n    {\n        uniform token info:id = "UsdPreviewSurface"\n'
            f'        color3f inputs:diffuseColor = ({r!r}, {g!r}, {b!r})\n        token outputs:surface\n    }}\n}}\n')


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path, **kwargs)


def load_strictly(path, **kwargs):
    """The stage at ``path`` loaded, any warning of the load raised as an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return wrt.load_usd(path, **kwargs)


def load_recording_warnings(path, **kwargs):
    """``(scene, messages)``: the stage at ``path`` loaded, and every warning the load gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path, **kwargs)
    return scene, [str(w.message) for w in caught]


def trace(scene, origins, directions):
    return wrt.trace(scene, np.asarray(origins, np.float32), np.asarray(directions, np.float32))


# A quad drawn beside a broken prim in the tests that skip one: what the rest of the stage draws.
GOOD_QUAD = ('def Mesh "Good"\n{\n    int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n'
             "    point3f[] points = [(-3, -3, -1), (3, -3, -1), (3, 3, -1), (-3, 3, -1)]\n}\n")


def assert_skipped_as_if_removed(path: str, prim: str, message: str):
    """Loads the stage at ``path`` and checks that ``prim`` was skipped with one warning naming the file, the prim and
    ``message`` (a regular expression), and that the rest traces exactly as the stage with ``prim`` removed through
    USD's own API does (the same hits, array-equal, on a 9 x 9 grid of rays down -z over ``[-4, 4]^2``)."""
    import re

    from pxr import Usd

    scene, messages = load_recording_warnings(path)
    (said,) = [m for m in messages if "prims of invalid topology or values were skipped" in m]
    assert said.startswith(f"{path}: ") and said.endswith(f": {prim}") and re.search(message, said), said
    stage = Usd.Stage.Open(path)
    assert stage.RemovePrim(prim)
    without = path[: -len(".usda")] + "_without.usda"
    stage.Export(without)
    oracle = load(without)
    xy = np.stack(np.meshgrid(np.linspace(-4, 4, 9), np.linspace(-4, 4, 9)), axis=-1).reshape(-1, 2)
    origins = np.concatenate([xy, np.full((len(xy), 1), 10.0)], axis=1)
    down = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    got, want = trace(scene, origins, down), trace(oracle, origins, down)
    assert np.isfinite(want.t).any()  # the rest of the stage is there to see
    np.testing.assert_array_equal(got.t, want.t)
    np.testing.assert_array_equal(got.prim, want.prim)
