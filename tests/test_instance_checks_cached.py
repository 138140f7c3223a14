"""The instance transform checks (``Scene.check_instances``) run once per state of the instance arrays, not at every
trace of an unchanged scene (0.08 s per trace at 1M instances), and still refuse a bad transform put in after an
earlier trace passed them: after ``invalidate()``, or written through a writeable array the transforms view."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

import wrt  # noqa: E402
from wrt.errors import SceneError  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.scene import Mesh  # noqa: E402

ORIGIN, DOWN = np.float32([[0.0, 0.0, 5.0]]), np.float32([[0.0, 0.0, -1.0]])


def scene_of(to_world) -> wrt.Scene:
    """A unit square in z = 0 (two triangles around the origin) instanced at ``to_world``, from /PI."""
    square = Mesh("/P/square", np.float32([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]),
                  np.int32([[0, 1, 2], [0, 2, 3]]), np.int32([0, 0]))
    instances = Instances.from_transforms(np.zeros(len(to_world), np.int32), to_world, name="/PI")
    return wrt.Scene(prototypes=[Prototype("/P", [square])], instances=instances)


def translations(zs) -> np.ndarray:
    """``(n, 4, 4)`` column-vector transforms moving the square to height ``zs[i]`` and 10 units apart in x."""
    m = np.zeros((len(zs), 4, 4))  # owning its memory (np.tile's result is a view of a writeable array)
    m[:] = np.eye(4)
    m[:, 0, 3] = 10.0 * np.arange(len(zs))
    m[:, 2, 3] = zs
    return m


def counting(monkeypatch) -> list:
    """Counts the calls of ``Instances.check_affine`` (each still checks)."""
    calls = []
    check = Instances.check_affine

    def counted(self):
        calls.append(1)
        return check(self)

    monkeypatch.setattr(Instances, "check_affine", counted)
    return calls


def test_the_transform_check_runs_once_for_traces_of_an_unchanged_scene(monkeypatch):
    scene = scene_of(translations([1.0, 2.0]))
    calls = counting(monkeypatch)
    for _ in range(2):
        assert wrt.trace(scene, ORIGIN, DOWN).t[0] == pytest.approx(4.0)  # the oracle: from z = 5 down to z = 1
    assert len(calls) == 1
    scene.invalidate()  # an edit in place may follow: checked again
    assert wrt.trace(scene, ORIGIN, DOWN).t[0] == pytest.approx(4.0)
    assert len(calls) > 1
    before = len(calls)
    scene.instances.to_world = translations([3.0, 2.0])  # replaced: checked again, and traced anew
    assert wrt.trace(scene, ORIGIN, DOWN).t[0] == pytest.approx(2.0)
    assert len(calls) > before
    before = len(calls)
    wrt.trace(scene, ORIGIN, DOWN)
    assert len(calls) == before


def test_a_transform_made_non_affine_after_invalidate_is_refused_at_the_next_trace():
    scene = scene_of(translations([1.0, 2.0]))
    assert wrt.trace(scene, ORIGIN, DOWN).t[0] == pytest.approx(4.0)
    scene.invalidate()
    scene.instances.to_world[1, 3] = (0.0, 0.0, 2.0, 1.0)  # a Gf.Matrix4d's translation, untransposed
    with pytest.raises(SceneError, match=r"/PI\[1\].*instance 1 has bottom row"):
        wrt.trace(scene, ORIGIN, DOWN)


def test_a_write_through_the_array_the_transforms_view_does_not_reach_the_scene():
    """The scene freezes the transforms after a trace, but could not freeze the writeable array they were a view of: a
    write through it changed them without an edit the scene could see (checked at each trace, yet wrt's TLAS kept the
    old placement while accel="warp" drew the new one). Such a view is copied when the instances are checked."""
    base = translations([1.0, 2.0, 3.0])
    scene = scene_of(base[:2])  # a contiguous float64 view of the caller's array
    assert not np.shares_memory(scene.instances.to_world, base)
    for _ in range(2):
        assert wrt.trace(scene, ORIGIN, DOWN).t[0] == pytest.approx(4.0)
    base[1, 3] = (0.0, 0.0, 2.0, 1.0)  # no longer the scene's: its transforms stay affine, as given
    assert wrt.trace(scene, ORIGIN, DOWN).t[0] == pytest.approx(4.0)
