"""Compares wrt's camera AOVs of an :mod:`aov_stages` stage with the oracle, pixel by pixel."""

from __future__ import annotations

import warnings
from collections import Counter

import numpy as np
from aov_stages import HEIGHT, WIDTH, camera_view, write_stage
from pxr import Usd

import wrt


def wrt_view(path: str, camera: str, width: int, height: int, **render_options) -> dict:
    """wrt's ``prim`` / ``instance`` paths, face, ``depth`` and ``geometric_normal`` of each pixel."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = wrt.load_usd(path)
    options = {"integrator": "albedo", "device": "cpu", **render_options}
    img = wrt.render(scene, camera=camera, width=width, height=height, **options)
    prim, instance = img.aovs["prim"].reshape(-1), img.aovs["instance"].reshape(-1)
    geometry, split_instance = scene.split_ids(np.maximum(prim, 0))  # the prim AOV is Hits.prim: instances expanded
    geometry[prim < 0] = -1
    assert (split_instance[prim >= 0] == instance[prim >= 0]).all(), "the prim and instance AOVs disagree"
    ids, faces = scene.hit_prims(geometry, instance)
    paths = np.array([*scene.prim_paths(), ""], object)[ids]
    names = np.array([scene.instances.path(int(i)) if i >= 0 else "" for i in instance], object)
    return {"hit": (prim >= 0).reshape(height, width), "prim": paths.reshape(height, width),
            "instance": names.reshape(height, width), "face": np.where(prim >= 0, faces, -1).reshape(height, width),
            "depth": img.aovs["depth"].astype(np.float64), "z": img.aovs["z"].astype(np.float64),
            "normal": img.aovs["geometric_normal"].astype(np.float64)}


def compare_stage(folder, seed: int, width: int = WIDTH, height: int = HEIGHT, **render_options):
    """``(disagreements, one line per pixel; counts of the pixels compared)`` for stage ``seed``, rendered with
    ``render_options`` (``wrt.render`` keywords) besides the albedo integrator on the cpu. The counts: ``compared``,
    ``hit`` (see something), ``culled`` (through the back of a single-sided face), ``flipped`` (see a leftHanded or
    mirrored face), ``native`` and ``point_instancer`` (see an instance of either kind), ``orthographic``."""
    path = str(folder / f"aov{seed}.usda")
    camera = write_stage(path, seed)
    expected = camera_view(Usd.Stage.Open(path), camera, width, height)
    got = wrt_view(path, camera, width, height, **render_options)
    valid = expected["valid"]
    lines = []
    for i, j in zip(*np.nonzero(valid)):
        e = {k: expected[k][i, j] for k in ("hit", "prim", "instance", "face", "depth", "z", "normal")}
        g = {k: got[k][i, j] for k in ("hit", "prim", "instance", "face", "depth", "z", "normal")}
        problems = [k for k in ("hit", "prim", "instance", "face") if e[k] != g[k]]
        if e["hit"] and not problems:
            problems += [k for k in ("depth", "z") if not np.isclose(g[k], e[k], rtol=1e-4, atol=1e-5)]
            if np.dot(g["normal"], e["normal"]) < 0.9999:
                problems.append("normal")
        if problems:
            shown = ", ".join(f"{k}: wrt {g[k]!r} USD {e[k]!r}" for k in problems)
            lines.append(f"seed {seed} pixel ({i}, {j}): {shown}")
    seen = valid & expected["hit"]
    instance = expected["instance"][seen]
    counts = Counter(compared=int(valid.sum()), hit=int(seen.sum()), culled=int((seen & expected["culled"]).sum()),
                     flipped=int((seen & expected["flipped"]).sum()),
                     native=sum(1 for name in instance if name and not name.endswith("]")),
                     point_instancer=sum(1 for name in instance if name.endswith("]")))
    counts["orthographic"] = counts["hit"] if expected["orthographic"] else 0
    return lines, counts
