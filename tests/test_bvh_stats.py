"""BVH statistics (SAH cost, EPO, counts), Warp's own trees read from wp.Mesh, the quality order of the builders,
and the ``wrt bvh-stats`` command."""

import json
import re

import numpy as np
import pytest
from conftest import warp_assets

import wrt
from wrt.bench import Grid, run_grid
from wrt.bvh import Builder, FlatBvh, build_bvh
from wrt.bvh.report import collect_stats, parse_builders
from wrt.bvh.stats import sah_cost
from wrt.bvh.warp_mesh import read_warp_bvh, warp_mesh_bvh
from wrt.cli import main
from wrt.compare import compare_hits
from wrt.rays import random_rays


def two_triangles(gap: float):
    """Two unit right triangles in the z=0 plane, the second shifted by ``1 + gap`` along x."""
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    return np.concatenate([tri, tri + np.float32([1 + gap, 0, 0])]), np.arange(6, dtype=np.int32).reshape(2, 3)


def test_sah_cost_by_hand():
    points, indices = two_triangles(1.0)
    bvh = build_bvh(points, indices, leaf_size=1, device="cpu")
    assert bvh.num_nodes == 3
    # Flat boxes: half area = x * y. Root 3 x 1, leaves 1 x 1: (C_t * 3 + C_i * (1 + 1)) / 3.
    assert sah_cost(bvh, 1.0, 1.0) == pytest.approx((3 + 2) / 3)
    assert sah_cost(bvh, 2.0, 0.5) == pytest.approx((2 * 3 + 0.5 * 2) / 3)
    stats = bvh.stats(2.0, 0.5)
    assert stats["sah_cost"] == pytest.approx((2 * 3 + 0.5 * 2) / 3)
    assert (stats["traversal_cost"], stats["intersection_cost"]) == (2.0, 0.5)


def test_epo_is_zero_without_overlap_and_positive_with_it():
    points, indices = two_triangles(1.0)
    assert build_bvh(points, indices, leaf_size=1, device="cpu").stats()["epo"] == 0.0
    # A small triangle inside the box of a big one: its area lies in the other leaf's box.
    big = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0]], np.float32)
    small = np.array([[2.5, 2.5, 0], [3, 2.5, 0], [2.5, 3, 0]], np.float32) * np.float32([1, 1, 0]) + np.float32(
        [0, 0, 0]
    )
    points = np.concatenate([big, small])
    bvh = build_bvh(points, np.arange(6).reshape(2, 3), leaf_size=1, device="cpu")
    stats = bvh.stats()
    # The small triangle (area 0.125 of 8.125) lies in the big leaf's box: EPO = C_i * 1 * 0.125 / 8.125.
    assert stats["epo"] == pytest.approx(0.125 / 8.125, abs=4 * stats["epo_stderr"] + 1e-3)


@pytest.mark.parametrize("offset", [0.0, 1e6])
def test_epo_of_boxes_that_only_touch_is_zero_far_from_the_origin(offset):
    # A row of right triangles, one per unit cell [k, k + 1] x [0, 1]: leaf boxes touch only along lines, which hold
    # no area, so EPO is exactly 0. At x = 1e6 float32 steps by 1/16 and samples rounded to it fell on the shared
    # faces about one time in 32, counted in the neighbour's box too (EPO 0.1).
    k = np.arange(16.0)[:, None] * np.float64([1, 0, 0]) + np.float64([offset, 0, 0])
    corners = np.stack([k, k + [1, 0, 0], k + [0, 1, 0]], 1)
    points = corners.reshape(-1, 3).astype(np.float32)
    assert np.array_equal(points.astype(np.float64), corners.reshape(-1, 3))  # exact in float32: the oracle holds
    for builder in ("sah", "median", "lbvh"):
        stats = build_bvh(points, np.arange(48, dtype=np.int32).reshape(-1, 3), builder, leaf_size=1).stats()
        assert stats["leaves"] == 16 and stats["epo"] == pytest.approx(0.0, abs=1e-6), builder


def test_stats_are_consistent(np_rng):
    n = 2000
    centers = np_rng.uniform(-1, 1, (n, 1, 3))
    points = (centers + np_rng.normal(scale=0.05, size=(n, 3, 3))).reshape(-1, 3).astype(np.float32)
    indices = np.arange(3 * n, dtype=np.int32).reshape(-1, 3)
    for builder in [b.value for b in Builder]:
        s = build_bvh(points, indices, builder, device="cpu").stats(epo_samples=4096)
        assert s["builder"] == builder and s["triangles"] == n
        assert s["nodes"] == s["inner_nodes"] + s["leaves"] and s["leaves"] == s["inner_nodes"] + 1
        assert sum(s["leaf_size_histogram"].values()) == s["leaves"]
        assert sum(k * v for k, v in s["leaf_size_histogram"].items()) == n
        assert max(s["leaf_size_histogram"]) <= 8
        assert 0 < s["mean_leaf_depth"] <= s["max_depth"] < 64
        assert s["sah_cost"] > 1.0 and s["epo"] > 0.0 and s["bytes"] == 32 * s["nodes"] + 4 * n
        assert s["build_seconds"] > 0.0


def test_epo_sample_counts_are_checked(capsys):
    """epo_samples=2.5 was truncated to 2, -1 skipped EPO without a word, and 10**9 allocated tens of GB of samples."""
    points = np.eye(3, dtype=np.float32)
    bvh = build_bvh(points, np.array([[0, 1, 2]], np.int32), "sah")
    for bad in (2.5, -1, 1 << 30, True):
        with pytest.raises(ValueError, match="epo_samples"):
            bvh.stats(epo_samples=bad)
    assert bvh.stats(epo_samples=0)["epo"] is None and bvh.stats(epo_samples=np.int64(16))["epo"] == 0.0
    with pytest.raises(SystemExit) as exit_info:  # refused as read, naming the option
        main(["bvh-stats", str(warp_assets("cube.usd")), "--epo-samples", "1000000000"])
    assert exit_info.value.code == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(err) == 1 and "argument --epo-samples: " in err[0]


def test_empty_tree_stats():
    s = FlatBvh.empty().stats()
    assert s["sah_cost"] == 0.0 and s["triangles"] == 0 and s["leaves"] == 0


@pytest.fixture(scope="module")
def bunny():
    scene = wrt.load_usd(warp_assets("bunny.usd"))
    return scene.triangles()


@pytest.mark.parametrize("constructor", ["sah", "median", "cubql"])
def test_warp_trees_read_back_valid_and_trace_like_warp(bunny, constructor):
    points, indices = bunny
    bvh = warp_mesh_bvh(points, indices, constructor)
    bvh.validate()
    assert bvh.builder == f"warp:{constructor}" and bvh.num_prims == len(indices)
    if constructor != "cubql":
        assert bvh.prim_count.max() <= 4  # Warp's default bvh_leaf_size
    # Warp's tree, traversed by wrt's kernels, hits what wp.Mesh hits.
    scene = wrt.Scene.from_triangles(points, indices)
    origins, directions = random_rays(scene, 5000, seed=4)
    import warp as wp

    from wrt.trace import BvhAccelerator

    acc = BvhAccelerator.__new__(BvhAccelerator)
    acc.bvh, acc.device, acc.device_bvh = bvh, wp.get_device("cpu"), bvh.to_device(points, indices, "cpu")
    scene._cache[("accel", "wrt", "sah", "cpu")] = acc
    report = compare_hits(wrt.trace(scene, origins, directions), wrt.trace(scene, origins, directions, accel="warp"))
    assert report["disagreements"] == 0, report


def test_read_warp_bvh_reads_a_mesh_made_elsewhere(bunny):
    import warp as wp

    points, indices = bunny
    mesh = wp.Mesh(wp.array(points, dtype=wp.vec3), wp.array(indices.reshape(-1), dtype=wp.int32), bvh_leaf_size=2)
    bvh = read_warp_bvh(mesh)
    bvh.validate()
    assert bvh.prim_count.max() <= 2


def test_quality_order_on_bunny(bunny):
    points, indices = bunny
    rows = {r["builder"]: r for r in collect_stats(points, indices, "sweep_sah,sah,median,warp:sah", epo_samples=1024)}
    sweep, binned, median = (rows[b]["sah_cost"] for b in ("sweep_sah", "sah", "median"))
    assert sweep <= binned <= median
    assert binned <= 1.03 * sweep
    assert binned <= rows["warp:sah"]["sah_cost"]


def test_quality_order_on_turbineblade(assets):
    scene = wrt.load_usd(assets("turbineblade_199k"))
    points, indices = scene.triangles()
    costs = {b: build_bvh(points, indices, b, device="cpu").stats()["sah_cost"] for b in ("sweep_sah", "sah", "median")}
    warp_cost = warp_mesh_bvh(points, indices, "sah").stats()["sah_cost"]
    assert costs["sweep_sah"] <= costs["sah"] <= costs["median"]
    assert costs["sah"] <= 1.03 * costs["sweep_sah"]
    assert costs["sah"] <= warp_cost


def test_parse_builders():
    assert parse_builders("binned_sah, warp:sah") == ["sah", "warp:sah"]
    assert parse_builders(["all"]) == [b.value for b in Builder]
    with pytest.raises(ValueError, match="valid Warp builders"):
        parse_builders("warp:kd")
    with pytest.raises(ValueError, match="valid builders"):
        parse_builders("kd")


@pytest.mark.parametrize("name, meant", [("wrt:sah", "sah"), ("wrt:lbvh", "lbvh"), ("wrt:binned_sah", "binned_sah")])
def test_a_builder_named_as_wrt_bench_names_an_accelerator_is_told_the_builder_of_wrt_meant(name, meant):
    """``--builder wrt:sah`` (wrt bench's name of wrt's accelerator, README: ``wrt:BUILDER``) was told 'did you mean
    warp:sah', Warp's tree, not the wrt builder it names; the hint now names that builder, which parse_builders
    takes."""
    with pytest.raises(ValueError) as error:
        parse_builders(name)
    assert f"(did you mean {meant!r}? " in str(error.value) and "warp:" not in str(error.value).split(";")[0]
    assert parse_builders(meant) == [Builder.from_str(meant).value]


def test_cli_bvh_stats_table_and_json(capsys):
    path = str(warp_assets("bunny.usd"))
    assert (
        main(
            [
                "bvh-stats",
                path,
                "--builder",
                "sah,lbvh",
                "--builder",
                "warp:sah",
                "--layout",
                "wide",
                "--epo-samples",
                "512",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "| builder | build s | SAH cost | EPO |" in out
    assert "| sah |" in out and "| lbvh |" in out and "| warp:sah |" in out
    assert main(["bvh-stats", path, "--json", "--leaf-size", "2", "--epo-samples", "512"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows[0]["builder"] == "sah" and max(map(int, rows[0]["leaf_size_histogram"])) <= 2


def test_cli_bvh_stats_table_shows_the_chosen_layouts_node_count(capsys):
    """--layout promises the node count and bytes of that layout, but the table showed the binary tree's node count
    for every layout (bunny, sah: 14327 nodes for binary, wide and wide8 alike; wide8 has 1441)."""
    path = str(warp_assets("bunny.usd"))
    counts = {}
    for layout in ("binary", "wide8"):
        assert main(["bvh-stats", path, "--layout", layout, "--json", "--epo-samples", "64"]) == 0
        counts[layout] = json.loads(capsys.readouterr().out)[0]["layout_nodes"]
        assert main(["bvh-stats", path, "--layout", layout, "--epo-samples", "64"]) == 0
        header, _, row = capsys.readouterr().out.splitlines()[1:4]
        cells = dict(zip([c.strip() for c in header.split("|")], [c.strip() for c in row.split("|")]))
        assert cells["layout"] == layout and cells["layout nodes"] == str(counts[layout])
    assert counts["wide8"] < counts["binary"] / 4  # the two columns really differ


@pytest.mark.parametrize(
    "args,needle",
    [
        (["--builder", "kdtree"], "valid builders"),
        (["--builder", "warp:kd"], "valid Warp builders"),
        (["--bins", "1"], "argument --bins: must be an integer from 2 to"),
        (["--layout", "bvh16"], "invalid choice"),
        (["--device", "tpu"], "available devices"),
        (["--traversal-cost", "inf"], "argument --traversal-cost: must be a finite number"),
        (["--builder", "warp:sah", "--traversal-cost", "-5"], "argument --traversal-cost: must be a number at least 0"),
        (["--builder", "warp:sah", "--intersection-cost", "nan"], "argument --intersection-cost: must be a finite"),
    ],
)
def test_cli_bvh_stats_bad_input_is_one_line_and_exit_2(capsys, args, needle):
    with pytest.raises(SystemExit) as e:
        import sys

        sys.exit(main(["bvh-stats", str(warp_assets("bunny.usd")), *args]))
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err


def test_a_warp_leaf_size_past_a_c_int_is_refused_not_a_crash(tmp_path):
    """Warp reads bvh_leaf_size as a C int: --warp-leaf-size 2147483648 ended the process with a segmentation fault
    (run in a subprocess, so that the crash fails this test and not the test session)."""
    import subprocess
    import sys

    args = ["bvh-stats", str(warp_assets("cube.usd")), "--builder", "warp:sah", "--warp-leaf-size", "2147483648"]
    result = subprocess.run([sys.executable, "-m", "wrt", *args], capture_output=True, text=True, timeout=300)
    err = [line for line in result.stderr.splitlines() if line.startswith("wrt")]
    assert result.returncode == 2 and err == ["wrt: error: argument --warp-leaf-size: must be an integer from 1 to "
                                              "2147483647, got 2147483648 (see 'wrt bvh-stats --help')"], result
    script = ("from wrt.bvh.warp_mesh import warp_mesh_bvh\nimport numpy as np\n"
              "warp_mesh_bvh(np.eye(3, dtype=np.float32), np.array([[0, 1, 2]], np.int32), leaf_size=2**31)")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 1 and "ValueError: Warp's bvh_leaf_size must be an integer from 1 to 2147483647, " \
        "got 2147483648" in result.stderr, result


def test_cli_bvh_stats_missing_file(capsys, tmp_path):
    assert main(["bvh-stats", str(tmp_path / "missing.usd")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing.usd" in err[0]


def test_warp_lbvh_on_the_cpu_is_refused_not_relabelled(capsys, tmp_path):
    """wp.Mesh builds its sah tree for lbvh on the CPU (with a warning only): bvh-stats printed that tree as
    warp:lbvh and bench timed it under that name."""
    assert main(["bvh-stats", str(warp_assets("cube.usd")), "--builder", "warp:lbvh"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(err) == 1 and "no lbvh builder on the CPU" in err[0]
    with pytest.raises(ValueError, match="accelerator 'warp:lbvh' with devices cpu: wp.Mesh has no lbvh builder on"):
        run_grid(Grid(scenes=["sphere:200"], accels=["warp:lbvh", "warp:sah"], rays=["primary"], n_rays=300,
                      repeats=1), tmp_path, progress=False)


def test_cli_bvh_stats_of_a_scene_without_triangles(capsys, tmp_path):
    """Warp's trees over no triangles failed with a traceback blaming the native layout ('layout differs from
    warp-lang 1.19's'); they are empty trees, as wrt's are."""
    path = tmp_path / "empty.usda"
    path.write_text('#usda 1.0\ndef Xform "World"\n{\n}\n')
    assert main(["bvh-stats", str(path), "--json", "--builder", "sah,warp:sah,warp:cubql", "--layout", "wide"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["builder"] for r in rows] == ["sah", "warp:sah", "warp:cubql"]
    for r in rows:
        assert r["triangles"] == 0 and r["leaves"] == 0 and r["sah_cost"] == 0.0 and r["leaf_size_histogram"] == {}


def test_cli_bvh_stats_json_is_strict_for_a_scene_without_area(capsys, tmp_path):
    """Zero-area triangles have no EPO (NaN): ``--json`` writes null there, which strict parsers accept."""
    path = tmp_path / "flat.usda"
    path.write_text(
        '#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3, 3]\n'
        "    int[] faceVertexIndices = [0, 1, 2, 0, 2, 1]\n"
        "    point3f[] points = [(0, 0, 0), (1, 1, 1), (2, 2, 2)]\n}\n"
    )
    assert main(["bvh-stats", str(path), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert rows[0]["epo"] is None
    # The table reads n/a there too: it printed 'nan' (an EPO of a number that is not one).
    assert main(["bvh-stats", str(path)]) == 0
    row = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| sah |")][0]
    assert row.split("|")[4].strip() == "n/a" and "nan" not in row


def test_quality_script_json_is_strict_for_a_scene_without_area(monkeypatch, tmp_path):
    """benchmarks/quality.py --json writes the rows bvh-stats --json does; it wrote their NaN EPO as bare NaN."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "quality", Path(__file__).resolve().parents[1] / "benchmarks" / "quality.py")
    quality = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(quality)
    flat = np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2]], np.float32), np.array([[0, 1, 2], [0, 2, 1]], np.int32)
    monkeypatch.setattr(quality, "load_scene", lambda name: flat)
    out = tmp_path / "quality.json"
    assert quality.main(["--scenes", "flat", "--builders", "sah", "--no-speed", "--json", str(out)]) == 0
    results = json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert results["quality"][0]["rows"][0]["epo"] is None


def test_cli_bvh_stats_counts_gprims_as_triangles(tmp_path, capsys):
    """A stage of gprims (spheres, cubes) reported 0 triangles and an empty tree: gprims load as analytic shapes,
    which are in no BVH over triangles. They are measured as triangle meshes now, as wrt bench measures them."""
    import json

    import wrt

    scene = tmp_path / "gprims.usda"
    scene.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 1\n}\n'
                     'def Cube "Box"\n{\n    double size = 1\n}\n')
    assert main(["bvh-stats", str(scene), "--json", "--epo-samples", "64"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    expected = len(wrt.load_usd(scene, tessellate_gprims=True).triangles()[1])
    assert row["triangles"] == expected > 0 and sum(row["leaf_size_histogram"].values()) == row["leaves"] > 0


@pytest.mark.parametrize("costs", [(-1.0, 1.0), (float("nan"), 1.0), (1.0, 0.0), (1.0, float("inf"))])
def test_stats_refuse_cost_constants_that_build_bvh_refuses(costs):
    """``stats(traversal_cost=-1)`` returned a negative SAH cost (-19 for the bunny) and NaN gave NaN, where
    ``build_bvh`` and ``wrt bvh-stats`` refuse such constants."""
    points = np.eye(3, dtype=np.float32)
    bvh = build_bvh(points, np.array([[0, 1, 2]], np.int32), "sah")
    with pytest.raises(ValueError, match="traversal_cost must be finite"):
        bvh.stats(*costs)


@pytest.mark.parametrize(
    "option, value, words",
    [
        ("--presplit", "-1", "must be an integer from 0 to 6, got -1"),
        ("--presplit", "99", "must be an integer from 0 to 6, got 99"),
        ("--bins", "1", "must be an integer from 2 to 64, got 1"),
        ("--leaf-size", "100000", "must be an integer from 1 to 65536, got 100000"),
        ("--epo-samples", "1000000000000", "got 1000000000000"),
        ("--traversal-cost", "-1", "must be a number at least 0, got -1"),
        ("--traversal-cost", "nan", "must be a finite number, got nan"),
        ("--intersection-cost", "0", "must be a positive number, got 0"),
        ("--time", "inf", "must be a finite number, got inf"),
        ("--builder", "foo", "unknown BVH builder 'foo'"),
        ("--builder", "warp:foo", "unknown Warp builder 'warp:foo'"),
        ("--builder", ",", "names nothing, got ','"),
    ],
)
def test_cli_bad_values_are_named_by_their_option_before_the_scene_loads(tmp_path, capsys, option, value, words):
    """The errors named the Python argument ('presplit must lie in [0, 6] ...', 'traversal_cost must be finite') or
    no option at all ('unknown BVH builder'), and came after the scene had loaded."""
    from wrt.cli import main

    with pytest.raises(SystemExit) as exit_info:  # the scene does not exist: a load would say so instead
        main(["bvh-stats", str(tmp_path / "missing.usda"), option, value])
    assert exit_info.value.code == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt")]
    assert len(lines) == 1 and lines[0].startswith(f"wrt: error: argument {option}: ") and words in lines[0], lines


@pytest.mark.parametrize("builder, option, value", [
    ("median", "--bins", "4"),  # binned SAH only
    ("lbvh", "--bins", "4"),
    ("warp:sah", "--leaf-size", "2"),  # wrt's builders only
    ("sah", "--warp-leaf-size", "2"),  # wp.Mesh's trees only
])
def test_cli_bvh_stats_names_an_option_no_builder_uses(capsys, builder, option, value):
    """--bins with no sah builder (or a leaf size for the other library's trees) was ignored without a word."""
    path = str(warp_assets("cube.usd"))
    common = ["bvh-stats", path, "--builder", builder, "--json", "--epo-samples", "64"]
    assert main(common) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main(common + [option, value]) == 0
    out, err = capsys.readouterr()
    warning = f"wrt: warning: {option} is ignored: only .* uses? it, and the builders here are {builder}\n"
    assert re.search(warning, err)
    assert json.loads(out)[0]["nodes"] == plain[0]["nodes"]  # the tree is indeed the same


def test_cli_bvh_stats_options_a_builder_uses_are_not_warned_about(capsys):
    path = str(warp_assets("cube.usd"))
    assert main(["bvh-stats", path, "--builder", "sah,warp:sah", "--bins", "4", "--leaf-size", "2",
                 "--warp-leaf-size", "2", "--json", "--epo-samples", "64"]) == 0
    assert "is ignored" not in capsys.readouterr().err


@pytest.mark.parametrize("name,meant", [("wrp:sah", "warp:sah"), ("Warp-sah", "warp:sah"), ("al", "all")])
def test_a_misspelt_builder_names_the_one_meant_among_every_name_the_option_takes(capsys, name, meant):
    """--builder takes wrt's builders, 'all' and warp:NAME, but a misspelling was matched against wrt's builders
    only: 'wrp:sah' was answered '(did you mean 'sweep_sah'?)', a builder the user did not mean."""
    import sys

    with pytest.raises(SystemExit) as e:
        sys.exit(main(["bvh-stats", str(warp_assets("cube.usd")), "--builder", name]))
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"(did you mean '{meant}'?)" in err[0] and repr(name) in err[0], err
    assert "warp:sah" in err[0].split("(did you mean")[1] and "all" in err[0].split(";")[-1]  # the names it takes


def test_the_table_heading_counts_one_triangle_in_the_singular(capsys, tmp_path):
    """The heading said '1 triangles', where the render's lines say '1 triangle'."""
    path = tmp_path / "one.usda"
    path.write_text('#usda 1.0\ndef Mesh "Tri"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
                    '[0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    assert main(["bvh-stats", str(path), "--epo-samples", "64"]) == 0
    assert capsys.readouterr().out.splitlines()[0].startswith(f"{path}: 1 triangle; SAH/EPO")


def test_bvh_stats_help_says_when_presplit_trees_have_no_epo(tmp_path, capsys):
    """``--help`` said ``--presplit`` gives "no EPO for trees so built", but the table leaves EPO out only where the
    pre-splits split a triangle (one in several leaves): on the bundled room ``--presplit 6`` splits nothing and EPO
    is printed. The help now says so. Oracle: whether ``build_bvh`` with those pre-splits holds more references
    than triangles."""
    from wrt.cli import default_scene_path

    long_diagonal = tmp_path / "diagonal.usda"
    long_diagonal.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3, 3]\n'
                             '    int[] faceVertexIndices = [0, 1, 2, 3, 4, 5]\n'
                             '    point3f[] points = [(0, 0, 0), (10, 10, 10), (10.1, 10, 10), (5, 5, 0), (0, 0, 1), '
                             '(1, 1, 2)]\n}\n')
    for path in (default_scene_path(), long_diagonal):
        points, indices = wrt.load_usd(str(path)).triangles()
        split = build_bvh(points, indices, "sah", presplit=6, device="cpu").num_prims != len(indices)
        assert main(["bvh-stats", str(path), "--builder", "sah", "--presplit", "6", "--epo-samples", "64"]) == 0
        row = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("| sah |"))
        epo = row.split("|")[4].strip()
        assert (epo == "n/a") == split, (path, row)
        assert split == (path == long_diagonal)  # one tree of each kind
    with pytest.raises(SystemExit):
        main(["bvh-stats", "--help"])
    said = " ".join(capsys.readouterr().out.split())
    assert "no EPO for trees so built" not in said
    assert "EPO is n/a for a tree whose pre-splits split a triangle" in said, said
