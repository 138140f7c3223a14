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
