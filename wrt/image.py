"""Image: the rendered picture (linear RGB, top row first) plus its AOVs, and writing them to disk."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) on linear values, clipped to [0, 1]."""
    x = np.clip(np.nan_to_num(x, nan=0.0), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def to_srgb8(rgb: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """``(H, W, 3)`` linear float -> ``(H, W, 3)`` uint8 sRGB, scaled by ``2**exposure`` first."""
    return np.round(linear_to_srgb(np.asarray(rgb, np.float32) * 2.0**exposure) * 255.0).astype(np.uint8)


@dataclasses.dataclass
class Image:
    """A rendered image.

    Attributes:
        rgb: ``(H, W, 3)`` float32 linear radiance; row 0 is the top of the image.
        aovs: named per-pixel outputs: ``"depth"`` ``(H, W)`` float32 distance along the primary ray (``inf`` on
            a miss), ``"normal"`` ``(H, W, 3)`` float32 world-space shading normal, ``"prim"`` ``(H, W)`` int32
            triangle id (-1 on a miss), ``"albedo"`` ``(H, W, 3)`` float32.
    """

    rgb: np.ndarray
    aovs: dict = dataclasses.field(default_factory=dict)

    @property
    def width(self) -> int:
        """Pixels per row."""
        return self.rgb.shape[1]

    @property
    def height(self) -> int:
        """Rows."""
        return self.rgb.shape[0]

    def save(self, path, exposure: float = 0.0) -> Path:
        """Writes the colour image: ``.png`` as 8-bit sRGB, ``.npy`` as raw linear float32.

        Raises:
            ValueError: for any other extension.
        """
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix == ".png":
            from PIL import Image as PilImage

            path.parent.mkdir(parents=True, exist_ok=True)
            PilImage.fromarray(to_srgb8(self.rgb, exposure), mode="RGB").save(path)
        elif suffix == ".npy":
            path.parent.mkdir(parents=True, exist_ok=True)
            np.save(path, self.rgb.astype(np.float32))
        else:
            raise ValueError(f"cannot write {path.name}: supported image formats are .png and .npy")
        return path

    def save_aovs(self, directory) -> list[Path]:
        """Writes every AOV as ``DIRECTORY/NAME.npy``; returns the paths."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        paths = []
        for name, value in self.aovs.items():
            paths.append(directory / f"{name}.npy")
            np.save(paths[-1], value)
        return paths
