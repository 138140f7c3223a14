"""Shared pytest fixtures: where the test assets are.

Real scenes come from two places: the USD files shipped with warp-lang (``warp.examples``) and the shared
asset folder described by ``manifest.json`` (``$WRT_ASSETS``, else ``<repo>/../shared/assets``). Tests that
need an asset that is not there are skipped, not failed.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True
# The probe kernels that test files define call the renderer's device functions (light sampling, BSDFs), and no test
# differentiates them: without their adjoints the 19 such modules compile in 133 s, not 336 s, on a cold kernel cache
# on the 2-core VM (test_affine_lights 11 s, not 66 s). wrt's own kernel modules set this option themselves
# (tests/test_cpu_compile_options.py).
wp.config.enable_backward = False

WARP_USD_ASSETS = ("bunny.usd", "bear.usd", "rocks.usd", "nonuniform.usd", "sphere.usd", "cube.usd")


def assets_dir() -> Path:
    """The shared asset folder (it may not exist)."""
    env = os.environ.get("WRT_ASSETS")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "shared" / "assets"


def manifest() -> dict:
    """``id -> entry`` of the shared asset manifest; empty when the folder is absent."""
    path = assets_dir() / "manifest.json"
    if not path.is_file():
        return {}
    with open(path) as f:
        return {entry["id"]: entry for entry in json.load(f)["assets"]}


def warp_assets(name: str | None = None):
    """The warp-lang example asset folder, or the file ``name`` in it."""
    import warp.examples

    root = Path(warp.examples.get_asset_directory())
    return root if name is None else root / name


@pytest.fixture
def assets():
    """A function ``asset(id) -> Path`` for a manifest entry; skips the test when it is not available."""
    entries = manifest()

    def asset(asset_id: str) -> Path:
        if asset_id not in entries:
            pytest.skip(f"asset {asset_id!r} not available (set WRT_ASSETS to the shared asset folder)")
        path = assets_dir() / entries[asset_id]["path"]
        if not path.exists():
            pytest.skip(f"asset file {path} is missing")
        return path

    asset.manifest = entries  # the full entries, e.g. asset.manifest[id]["triangles_rendered"]
    return asset


@pytest.fixture
def np_rng():
    """A fixed-seed numpy generator, fresh for each test."""
    return np.random.default_rng(123)


@pytest.fixture
def ctrl_c_after(monkeypatch):
    """``ctrl_c_after("b.usda")``: ``wrt.Renderer.render`` raises KeyboardInterrupt (Ctrl-C) once the scene of that
    file has its samples, so a partial image is written before the interrupt, as in a batch cut short."""
    import wrt

    render = wrt.Renderer.render

    def interrupt(name: str) -> None:
        def interrupted(self, *args, **kwargs):
            image = render(self, *args, **kwargs)
            if self.scene.source.endswith(name):
                raise KeyboardInterrupt
            return image

        monkeypatch.setattr(wrt.Renderer, "render", interrupted)

    return interrupt
