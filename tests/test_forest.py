"""The lecture's forest, small enough for a CPU: scenes/forest.py writes 1,000 instanced trees of 10,000 triangles
(1e7 rendered triangles) that load as one prototype, render with sun shadows, cost at most 128 bytes of device
memory per tree, and (at a tiny size) agree with wp.Mesh ray by ray on the flattened triangles.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True
pytest.importorskip("pxr")

import wrt  # noqa: E402
from wrt.rays import camera_rays, random_rays  # noqa: E402
from wrt.trace import get_accelerator  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scenes"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import forest  # noqa: E402
from test_instancing import check_agreement  # noqa: E402


@pytest.fixture(scope="module")
def small_forest(tmp_path_factory):
    path = tmp_path_factory.mktemp("forest") / "forest.usdc"
    info = forest.write_forest(path, n_trees=1000, tree_triangles=10_000, seed=3)
    return info, wrt.load_usd(path)


def test_forest_loads_as_one_prototype_and_many_instances(small_forest):
    info, scene = small_forest
    stats = scene.stats()
    assert info["tree_triangles"] == 10_000
    assert stats["rendered_triangles"] == info["rendered_triangles"] == 1000 * 10_000 + 2
    assert stats["unique_triangles"] == 10_000 + 2 and stats["instances"] == 1000 and stats["prototypes"] == 1
    assert len(scene.cameras) == 1 and len(scene.lights) == 2


def test_forest_renders_with_shadows_without_flattening(small_forest):
    _, scene = small_forest
    img = wrt.render(scene, width=128, height=72)
    hit = img.aovs["prim"] >= 0
    assert hit.mean() > 0.4 and len(np.unique(img.aovs["instance"][hit])) > 50
    assert ("triangles",) not in scene._cache
    # Ground points seen by the camera: some lie in the trees' shadows, some in the sun.
    origins, directions = camera_rays(scene, width=128, height=72)
    hits = wrt.trace(scene, origins, directions)
    ground = hits.prim < 2  # the ground quad's two triangles come first
    ground &= hits.hit
    points = origins[ground] + hits.t[ground, None] * directions[ground] + [0, 1e-3, 0]
    to_sun = -scene.lights[0].direction.astype(np.float32)
    shadowed = wrt.occluded(scene, points.astype(np.float32), np.tile(to_sun, (len(points), 1)))
    assert ground.sum() > 100 and 0.05 < shadowed.mean() < 0.95
    # The renderer agrees: shadowed ground is darker than sunlit ground.
    rgb = img.rgb.reshape(-1, 3)[ground.reshape(-1)]
    assert rgb[shadowed].mean() < 0.5 * rgb[~shadowed].mean()


def test_forest_memory_is_unique_geometry_plus_at_most_128_bytes_per_tree(small_forest):
    _, scene = small_forest
    sizes = get_accelerator(scene).device_bytes()
    assert sizes["tlas"] <= 128 * len(scene.instances) + 4096, sizes
    assert sizes["blas"] < 100 * scene.stats()["unique_triangles"], sizes  # not the 1e7 rendered ones


def test_each_tree_adds_at_most_120_tlas_bytes(tmp_path):
    """README: at most 120 bytes per instance and about 0.5 KB per prototype. ``forest_gpu.py --small`` reported 126
    bytes per instance: all TLAS bytes divided by 200 trees, the fixed part included. Measured as the growth from
    40 to 120 trees, then the fixed part as what is left."""
    tlas = {}
    for trees in (40, 120):
        forest.write_forest(tmp_path / f"f{trees}.usda", n_trees=trees, tree_triangles=200, seed=2)
        scene = wrt.load_usd(tmp_path / f"f{trees}.usda")
        assert len(scene.instances) == trees and len(scene.prototypes) == 1
        tlas[trees] = get_accelerator(scene).device_bytes()["tlas"]
    assert (tlas[120] - tlas[40]) / 80 <= 120, tlas
    assert tlas[40] - 120 * 40 <= 2 * 1024, tlas  # the fixed part, two BLASes: the tree and the ground


def test_tiny_forest_agrees_with_wp_mesh(tmp_path):
    path = tmp_path / "tiny.usda"
    forest.write_forest(path, n_trees=30, tree_triangles=600, seed=1)
    scene = wrt.load_usd(path)
    o1, d1 = camera_rays(scene, width=160, height=90)
    o2, d2 = random_rays(scene, 20_000, seed=4)
    check_agreement(scene, np.concatenate([o1, o2]), np.concatenate([d1, d2]))


def test_gpu_benchmark_script_runs_small_on_the_cpu():
    # A fresh process, with a time limit: inside a long test session this render once stalled in the TLAS any-hit
    # kernel (cause not found yet, see benchmarks/GPU_NOTES.md); a stall must fail the test, not block the suite.
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "benchmarks" / "forest_gpu.py"
    result = subprocess.run(
        [sys.executable, str(script), "--small", "--frames", "1"], capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "| rendered triangles | 1,000,002 |" in out and "| frame ms (median; min) |" in out


def test_flattening_too_many_instances_is_refused_before_it_starts(tmp_path, monkeypatch, capsys):
    """Scene.triangles() (``wrt bvh-stats``, the flattened layouts) expanded every instance before checking that
    the points fit int32 indices, and never checked the host memory: ``wrt bvh-stats`` of a 5e9-triangle forest ran
    for minutes, taking all the memory, before it failed."""
    import wrt.resources
    import wrt.scene as scene_module
    from wrt.cli import main

    path = tmp_path / "forest.usda"
    forest.write_forest(path, n_trees=20, tree_triangles=200, seed=1)
    scene = wrt.load_usd(path)
    rendered = scene.stats()["rendered_triangles"]

    def expand(*args):
        raise AssertionError("the instances were expanded before the check")

    monkeypatch.setattr(scene_module, "expand_instance_triangles", expand)
    monkeypatch.setattr(wrt.resources, "available_host_bytes", lambda: 10_000)
    with pytest.raises(MemoryError, match=f"flattening 20 instances into {rendered} triangles"):
        scene.triangles()
    assert main(["bvh-stats", str(path)]) == 2
    assert "flattening 20 instances" in capsys.readouterr().err
    monkeypatch.setattr(wrt.resources, "available_host_bytes", lambda: None)
    monkeypatch.setattr(scene_module, "ROW_DTYPE_LIMIT", 1000)
    with pytest.raises(ValueError, match="points are too many to flatten"):
        scene.triangles()
    monkeypatch.undo()
    assert len(scene.triangles()[1]) == rendered


@pytest.mark.parametrize(
    "args, message",
    [
        (["--trees", "-5"], "argument --trees: must be at least 1"),  # was a traceback: math domain error
        (["--tree-triangles", "0"], "argument --tree-triangles: must be at least 258"),  # was 258 without a word
        (["{tmp}/file.usdc/forest.usdc"], "is not a folder"),  # was USD's 'Unable to open ... for write'
    ],
)
def test_forest_script_refuses_bad_arguments_in_one_line(tmp_path, args, message):
    import subprocess

    (tmp_path / "file.usdc").write_text("")
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    output = [] if args[0].endswith(".usdc") else [str(tmp_path / "forest.usdc")]
    result = subprocess.run([sys.executable, str(ROOT / "scenes" / "forest.py"), *output, *args], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr, result.stderr
    assert not (tmp_path / "forest.usdc").exists()
