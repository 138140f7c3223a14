"""Seeded random stages built through composition and time (:mod:`composed_stages`: sublayers, references and payloads
with layer offsets, variants, inherits, nested native instances, PointInstancers, animated transforms, points,
visibility and topology, purposes, layers of different ``timeCodesPerSecond``) show, loaded by ``wrt.load_usd``, the
world-space triangles USD's own API computes for them, as multisets, at times before, between, on and after their
samples; and with ``time=None`` the ones USD computes at the time wrt's default-time rule stands for.

``WRT_COMPOSED_STAGES`` raises the number of stages for longer local runs (300 take about a minute a test).
"""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest
from composed_stages import unmatched, usd_triangles, write_stage
from pxr import Usd

import wrt

STAGES = int(os.environ.get("WRT_COMPOSED_STAGES", "40"))
TIMES = (-7.0, 0.0, 1.0, 1.7, 2.0, 4.3, 11.0, 30.0)  # stage times: before, on, between and after the samples
EXACT = 2e-5  # per coordinate, relative to 1 + the triangle's largest |x|: float32 points through float64 transforms


def world_triangles(path, **kwargs) -> np.ndarray:
    """``(T, 3, 3)`` float64 triangles of the stage at ``path`` as ``wrt.load_usd`` reads it, instances expanded."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # composition, time range and unsupported-feature warnings are not the point
        scene = wrt.load_usd(path, **kwargs)
    points, indices = scene.triangles()
    return np.asarray(points, np.float64)[indices]


def differences(path: str, times, read_time) -> tuple[list[str], int]:
    """Where wrt's triangles of the stage at ``path`` differ from USD's, one line per time of ``times`` (``load_usd``
    times) that USD reads at ``read_time(time)``, and how many triangles USD found in all."""
    stage = Usd.Stage.Open(path)
    found, count = [], 0
    for time in times:
        expected, _ = usd_triangles(stage, read_time(time))
        count += len(expected)
        got = world_triangles(path, time=time)
        extra, missing = unmatched(got, expected, EXACT)
        if extra or missing:
            found.append(f"{path} at time {time}: wrt {len(got)} triangles, USD {len(expected)}; "
                         f"{len(extra)} of wrt's and {len(missing)} of USD's unmatched")
    return found, count


def test_random_composed_stages_show_the_triangles_usd_computes(tmp_path):
    """USD's answer at each time: ``XformCache``, ``ComputeVisibility``, ``ComputePurpose``, points ``Get`` (moved by
    velocities as ``ComputePointsAtTime``), ``ComputeInstanceTransformsAtTime`` and ``ComputeMaskAtTime``."""
    found, triangles = [], 0
    for seed in range(STAGES):
        folder = tmp_path / f"stage{seed}"
        folder.mkdir()
        path = write_stage(str(folder), seed)
        lines, count = differences(path, TIMES, lambda t: t)
        found += lines
        triangles += count
    assert triangles > 10 * len(TIMES) * STAGES  # the stages show something
    assert not found, "\n".join(found)


@pytest.mark.parametrize("defaults", ["never", "always"])
def test_time_none_reads_the_first_sample_of_attributes_that_have_only_samples(tmp_path, defaults):
    """``time=None``: where no animated attribute authors a default, every one is read at its first sample, as USD
    reads them all at ``EarliestTime`` (the mask of a still invisibleIds over ids or protoIndices that have only
    samples hid nothing: 12 of 300 stages); where every one authors a default, USD's default time is read."""
    read_time = Usd.TimeCode.EarliestTime if defaults == "never" else Usd.TimeCode.Default
    found, triangles = [], 0
    for seed in range(2 * STAGES):
        folder = tmp_path / f"stage{seed}"
        folder.mkdir()
        path = write_stage(str(folder), seed, defaults)
        lines, count = differences(path, [None], lambda _: read_time())
        found += lines
        triangles += count
    assert triangles > 10 * STAGES
    assert not found, "\n".join(found)


ASSET = """#usda 1.0
(
    defaultPrim = "Asset"
)

def Xform "Asset"
{
    def PointInstancer "Parts"
    {
        uniform token purpose = "%s"
        point3f[] positions = [(0, 0, 0), (3, 0, 0)]
        int[] protoIndices = [0, 0]
        rel prototypes = </Asset/Library/Part>
    }

    over "Library"
    {
        def Mesh "Part"
        {
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }
    }
}
"""


def test_prototypes_beside_a_point_instancer_take_the_purpose_a_native_instance_authors(tmp_path):
    """A PointInstancer's prototypes kept beside it (not under it), authoring no purpose, take the purpose their own
    ancestors author, as ``ComputePurposeInfo`` computes it, and else the instancer's. Where the nearest ancestor
    authoring one is a native instance (or above it), USD computes it through the instance proxies: an instance of
    ``purpose = "default"`` draws the prototypes of a guide instancer inside it, as the same asset referenced without
    instancing draws them; an instance of ``purpose = "proxy"`` hides those of a default one. wrt read them inside the
    shared prototype, where no ancestor authors a purpose, and took the instancer's (found by seeds 261 and 375 of
    :func:`write_stage`: two triangles missing at every time)."""
    for purpose in ("guide", "default"):
        (tmp_path / f"{purpose}.usda").write_text(ASSET % purpose)
    # The guide asset one level further down, as an instance inside the instance's prototype.
    (tmp_path / "nested.usda").write_text('#usda 1.0\n(\n    defaultPrim = "Wrap"\n)\n\ndef Xform "Wrap"\n{\n'
                                          '    def Xform "Inner" (\n        instanceable = true\n'
                                          '        prepend references = @./guide.usda@\n    )\n    {\n    }\n}\n')
    root = tmp_path / "root.usda"
    prims = []
    for k, (name, asset, instanceable, purpose) in enumerate((
            ("GuideInstanced", "guide", True, "default"), ("GuideReferenced", "guide", False, "default"),
            ("GuideBare", "guide", True, None), ("DefaultProxy", "default", True, "proxy"),
            ("DefaultBare", "default", True, None), ("GuideRender", "guide", True, "render"),
            ("GuideNested", "nested", True, "default"))):
        own = f'\n    uniform token purpose = "{purpose}"' if purpose else ""
        place = (f'\n    double3 xformOp:translate = (0, {10 * k}, 0)'
                 '\n    uniform token[] xformOpOrder = ["xformOp:translate"]')
        prims.append(f'def Xform "{name}" (\n    instanceable = {str(instanceable).lower()}\n'
                     f'    prepend references = @./{asset}.usda@\n)\n{{{own}{place}\n}}\n')
    root.write_text("#usda 1.0\n\n" + "\n".join(prims))
    stage = Usd.Stage.Open(str(root))
    expected, _ = usd_triangles(stage, Usd.TimeCode.Default())
    got = world_triangles(str(root))
    assert len(expected) == 2 * 5  # two instances of one triangle under each of the five drawn (apart)
    extra, missing = unmatched(got, expected, EXACT)
    assert (len(got), extra, missing) == (len(expected), [], [])
