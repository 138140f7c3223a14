"""wrt bench and wrt bvh-stats on input nobody tested: misspelt names, empty scenes, odd output folders, a run
interrupted or without matplotlib, and the size columns of rows traced in another layout."""

import json
import math
import os
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import wrt.bench as bench_module
from wrt.bench import Grid, GridError, run_grid
from wrt.bvh.report import parse_builders
from wrt.cli import main


def small_grid(**kwargs):
    options = dict(scenes=["sphere:2000"], accels=["wrt:sah"], rays=["primary"], n_rays=2000, repeats=2)
    options.update(kwargs)
    return Grid(**options)


def write_suite(tmp_path, **fields):
    path = tmp_path / "suite.json"
    path.write_text(json.dumps(dict({"scenes": ["sphere:2000"], "accels": ["wrt:sah"]}, **fields)))
    return path


@pytest.mark.parametrize("fields, message", [
    ({"n_ray": 100}, "unknown suite keys ['n_ray'] (did you mean 'n_rays'?)"),
    ({"rays": ["primry"]}, "unknown ray kind 'primry' (did you mean 'primary'?)"),
    ({"accels": ["embre"]}, "accelerator 'embre': unknown accelerator kind 'embre' (did you mean 'embree'?)"),
    ({"accels": ["warp:sha"]}, "accelerator 'warp:sha': wp.Mesh has no builder 'sha' (did you mean 'sah'?)"),
    ({"scaling": {"size": [1000]}}, "unknown scaling keys ['size'] (did you mean 'sizes'?)"),
    ({"scaling": {"sizes": [1000], "rays": "incoherant"}}, "unknown scaling ray kind 'incoherant' (did you mean"),
])
def test_misspelt_suite_names_get_a_did_you_mean(tmp_path, fields, message):
    """A misspelt key, ray kind or accelerator was refused with the list of valid names only."""
    with pytest.raises(ValueError) as error:
        Grid.from_suite(write_suite(tmp_path, **fields))
    assert message in str(error.value)


def test_misspelt_suite_name_and_warp_builder_of_bvh_stats_get_a_did_you_mean():
    with pytest.raises(FileNotFoundError, match="no benchmark suite 'qiuck' \\(did you mean 'quick'\\?\\)"):
        Grid.from_suite("qiuck")
    with pytest.raises(ValueError, match="unknown Warp builder 'warp:sha' \\(did you mean 'warp:sah'\\?\\)"):
        parse_builders("warp:sha")


def test_scaling_accelerators_are_checked_before_the_run():
    """A misspelt accelerator of the scaling sweep was found only when the sweep ran, as an error row per size."""
    with pytest.raises(ValueError, match="accelerator 'wrt:sha': unknown BVH builder 'sha'"):
        small_grid(scenes=[], scaling={"sizes": [1000], "accels": ["wrt:sha"]}).validated()


def test_an_unknown_scene_kind_is_named_with_a_did_you_mean(tmp_path):
    """'sphree:2000' was reported as 'file not found' only; a real file whose name holds a colon still loads."""
    rows = run_grid(small_grid(scenes=["sphree:2000"]), tmp_path / "out", progress=False)
    assert "'sphree' is no scene kind (did you mean 'sphere'?)" in rows[0]["error"]
    colon = tmp_path / "a:b.usda"
    colon.write_text('#usda 1.0\ndef Sphere "S"\n{\n}\n')
    rows = run_grid(small_grid(scenes=[str(colon)]), tmp_path / "out", progress=False)
    assert "mrays" in rows[0], rows[0].get("error")


def test_a_warp_example_named_without_its_extension_is_named_with_the_files_there_are(tmp_path):
    """'warp:bunny' (Warp's example is bunny.usd) was 'SceneError: /.../site-packages/warp/examples/assets/bunny:
    file not found', naming neither the file meant nor the examples there are, where 'asset:ID' names the one meant."""
    import warp.examples

    usd_files = sorted(p.name for p in Path(warp.examples.get_asset_directory()).iterdir() if p.suffix == ".usd")
    rows = run_grid(small_grid(scenes=["warp:bunny", "sphere:2000"]), tmp_path / "out", progress=False)
    error = rows[0]["error"]
    assert rows[0]["scene"] == "warp:bunny" and "(did you mean 'bunny.usd'?)" in error, error
    assert all(name in error for name in usd_files), error
    assert "mrays" in rows[1]  # the run went on


def test_a_scene_without_triangles_is_an_error_row(tmp_path):
    """An empty stage was 'measured': rows of 0 triangles, 0 % hits and 100 % agreement, at some Mrays/s."""
    empty = tmp_path / "empty.usda"
    empty.write_text("#usda 1.0\n")
    rows = run_grid(small_grid(scenes=[str(empty), "sphere:2000"], accels=["warp:sah", "wrt:sah"]),
                    tmp_path / "out", progress=False)
    errors = [r for r in rows if "error" in r]
    assert len(errors) == 1 and errors[0]["scene"] == str(empty) and "no triangles" in errors[0]["error"]
    assert [r["scene"] for r in rows if "mrays" in r] == ["sphere:2000"] * 2  # the run went on


def test_layout_rows_report_the_size_of_the_layout_they_trace(tmp_path):
    """A wrt:sah:wide8 row gave the binary tree's nodes and bytes, so every layout looked the same size."""
    rows = run_grid(small_grid(accels=["wrt:sah", "wrt:sah:wide8"]), tmp_path, progress=False)
    binary, wide8 = rows
    assert binary["layout"] == "binary" and binary["layout_nodes"] == binary["nodes"]
    assert binary["layout_bytes"] == binary["bytes"]
    assert wide8["layout"] == "wide8" and wide8["nodes"] == binary["nodes"]  # the same binary tree underneath
    assert wide8["layout_nodes"] < binary["nodes"] / 4  # eight children per node, not two
    assert 0 < wide8["layout_bytes"] < binary["bytes"]


def test_plots_skipped_without_matplotlib_say_so(tmp_path, monkeypatch):
    """Without matplotlib (the bench extra not installed) no plot was written and nothing said why."""
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    with pytest.warns(UserWarning, match="plots skipped: matplotlib is not installed"):
        run_grid(small_grid(), tmp_path, progress=False)
    assert (tmp_path / "table.md").exists() and not (tmp_path / "mrays.png").exists()


def test_an_interrupted_run_leaves_no_plots_of_an_earlier_run(tmp_path, monkeypatch):
    """Ctrl-C wrote table.md from the rows measured so far but kept an earlier run's plots beside it."""
    assert len(bench_module.plot(sweep_rows(), tmp_path)) == len(bench_module.PLOT_FILES)
    earlier = {name: (tmp_path / name).read_bytes() for name in bench_module.PLOT_FILES}
    measure, calls = bench_module.measure_group, []

    def interrupted(*args):
        calls.append(args)
        if len(calls) == 2:
            raise KeyboardInterrupt
        measure(*args)

    monkeypatch.setattr(bench_module, "measure_group", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_grid(small_grid(rays=["primary", "incoherent"]), tmp_path, progress=False)
    rows = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert [r["rays"] for r in rows] == ["primary"]
    assert "| primary |" in (tmp_path / "table.md").read_text()
    for name in bench_module.PLOT_FILES:
        assert not (tmp_path / name).exists() or (tmp_path / name).read_bytes() != earlier[name]


def test_a_summary_interrupted_while_plotting_leaves_no_plot_of_an_earlier_run(tmp_path, monkeypatch):
    """Ctrl-C while the summary drew its plots (seconds, at the end of every run, and again under the first Ctrl-C's
    summary) left the plots not drawn yet as an earlier run wrote them, beside this run's table: scaling.png of a
    sweep this run does not measure. The plots this run did not write are removed, as at the end of a whole run."""
    assert len(bench_module.plot(sweep_rows(), tmp_path)) == len(bench_module.PLOT_FILES)
    save = bench_module._save_plot

    def interrupted(fig, path):
        if path.name != "mrays.png":
            raise KeyboardInterrupt
        save(fig, path)

    monkeypatch.setattr(bench_module, "_save_plot", interrupted)
    rows = [dict(r, scene="sphere:5000", sweep=False) for r in sweep_rows()[:1]]
    with pytest.raises(KeyboardInterrupt):
        bench_module.write_summary(rows, tmp_path)
    assert "sphere:5000" in (tmp_path / "table.md").read_text()
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["mrays.png"]


def sweep_rows():
    """Rows that give every plot: a scaling sweep of two sizes with SAH costs."""
    return [dict(scene=f"sphere:{n}", triangles=n, device="cpu", rays="incoherent", accel="wrt:sah", threads=1,
                 build_ms=n / 1e3, mrays=2.0, mrays_min=1.0, mrays_max=3.0, hit_fraction=0.5, sah_cost=1.5, sweep=True)
            for n in (10_000, 100_000)]


FAILED_RUN = [{"scene": "a", "accel": "*", "device": "cpu", "rays": "primary", "threads": None, "error": "no file"}]


def test_a_run_without_plots_keeps_files_wrt_did_not_write(tmp_path):
    """A run with no rows for a plot deleted any file of that name in -o DIR, the user's own ones too."""
    from PIL import Image

    Image.new("RGB", (4, 4)).save(tmp_path / "mrays.png")  # the user's own PNG
    (tmp_path / "build_vs_quality.png").write_bytes(b"my notes")
    (tmp_path / "scaling.png").write_bytes(b"")
    before = {name: (tmp_path / name).read_bytes() for name in bench_module.PLOT_FILES}
    with pytest.warns(UserWarning) as caught:
        bench_module.write_summary(FAILED_RUN, tmp_path)
    assert {name: (tmp_path / name).read_bytes() for name in bench_module.PLOT_FILES} == before
    for name in bench_module.PLOT_FILES:
        assert any(f"{tmp_path / name} left as is" in str(w.message) for w in caught)


def test_a_run_without_plots_removes_the_stale_plots_wrt_wrote(tmp_path, recwarn):
    """An earlier run's plots, which wrt marks in a PNG text chunk, are removed: they would show its numbers."""
    from PIL import Image

    for path in bench_module.plot(sweep_rows(), tmp_path):
        with Image.open(path) as image:  # Pillow reads the mark, not wrt's own chunk walk
            assert image.text.get(bench_module.PLOT_MARK[0]) == bench_module.PLOT_MARK[1]
    bench_module.write_summary(FAILED_RUN, tmp_path)
    assert not any((tmp_path / name).exists() for name in bench_module.PLOT_FILES)
    assert not [w for w in recwarn if "left as is" in str(w.message)]


@pytest.mark.parametrize("out, message", [("", "the output folder is empty"), ("file", "is a file, not a folder")])
def test_an_output_folder_that_cannot_be_one_is_refused(tmp_path, monkeypatch, capsys, out, message):
    """-o '' wrote into the current folder and said 'results in /'; -o FILE failed with '[Errno 17] File exists'."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("not a folder")
    assert main(["bench", "--scenes", "sphere:2000", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "100",
                 "-q", "-o", out]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "rows.jsonl").exists()


@pytest.mark.parametrize("name, goes", [("rows.jsonl", "the rows go"), ("table.md", "table.md goes"),
                                        ("mrays.png", "mrays.png goes"), ("settings.json", "settings.json goes")])
def test_an_output_file_that_is_a_folder_is_refused_before_any_row_is_measured(tmp_path, monkeypatch, name, goes):
    """OUT/rows.jsonl a folder: the run measured its first row, then failed to write it, saying '[Errno 21] Is a
    directory: 'OUT/rows.jsonl.tmp' -> 'OUT/rows.jsonl''. OUT/table.md or a plot's name a folder: every row was
    measured, then the run stopped with 'cannot write OUT/table.md: it is a directory', without its summary."""
    (tmp_path / name).mkdir()
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: pytest.fail("a scene was loaded"))
    with pytest.raises(ValueError, match=f"{re.escape(name)}', where {goes}, is a folder"):
        run_grid(small_grid(), tmp_path, progress=False)


def test_resuming_a_rows_file_that_is_not_text_names_the_file_and_line(tmp_path, capsys):
    """Bytes that are no UTF-8 in rows.jsonl stopped --resume with "'utf-8' codec can't decode byte 0xff in
    position 40", naming neither the file nor the line."""
    (tmp_path / "rows.jsonl").write_bytes(b'{"scene": "sphere:2000"}\n{"accel": "\xff\xfe"}\n')
    assert main(["bench", "--scenes", "sphere:2000", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "100",
                 "-q", "--resume", "-o", str(tmp_path)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert err == [f"wrt: error: {tmp_path / 'rows.jsonl'}: line 2 is not UTF-8 text, so the file holds no benchmark "
                   "rows; remove it, or run without --resume to start over"]


def test_an_absurd_sphere_size_gets_a_short_message(tmp_path):
    """sphere:1e99 was refused with a 90-digit number of TiB."""
    rows = run_grid(small_grid(scenes=["sphere:1e99"]), tmp_path, progress=False)
    assert "sphere:1e99 needs about 7.28e+89 TiB of host memory" in rows[0]["error"]


def test_bvh_stats_presplit_gives_the_sah_cost_of_the_tree_bench_traces(tmp_path, capsys):
    """wrt:sah rows trace a tree built with pre-splits (as renders do) and bvh-stats built none, so the two SAH
    costs of one scene of slivers differed with nothing to make them agree."""
    from pxr import Usd, UsdGeom

    path = str(tmp_path / "slivers.usda")
    stage = Usd.Stage.CreateNew(path)
    mesh = UsdGeom.Mesh.Define(stage, "/Slivers")
    points = []
    for k in range(40):  # long thin triangles along the box diagonal: their boxes overlap a lot unless split
        points += [(k * 0.1, 0, 0), (k * 0.1 + 10, 10, 10), (k * 0.1 + 10, 10.05, 10)]
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr([3] * 40)
    mesh.CreateFaceVertexIndicesAttr(list(range(120)))
    stage.Save()
    row = run_grid(small_grid(scenes=[path]), tmp_path / "out", progress=False)[0]
    costs = {}
    for presplit in ("0", "6"):
        assert main(["bvh-stats", path, "--json", "--presplit", presplit]) == 0
        out = capsys.readouterr().out
        costs[presplit] = json.loads(out[out.index("[\n"):])[0]["sah_cost"]  # after Warp's banner, if it printed
    assert costs["6"] < costs["0"]  # the scene does exercise the pre-splits
    assert row["sah_cost"] == pytest.approx(costs["6"])


@pytest.mark.parametrize("option, value, message", [
    ("--threads", "0", "argument --threads: must be positive integers or 'all', got '0'"),
    ("--threads", "", "argument --threads: names nothing"),  # measured no CPU row and exited 0
    ("--accels", "foo", "argument --accels: accelerator 'foo': unknown accelerator kind 'foo'"),
    ("--accels", "wrt:nosuch", "argument --accels: accelerator 'wrt:nosuch': unknown BVH builder 'nosuch'"),
    # An empty part after a colon was read as the default builder or layout: a name cut short measured another tree.
    ("--accels", "wrt:sah:", "argument --accels: accelerator 'wrt:sah:': the layout after ':' is empty (did you mean "
     "'wrt:sah'?)"),
    ("--accels", "wrt:lbvh:", "accelerator 'wrt:lbvh:': the layout after ':' is empty (did you mean 'wrt:lbvh'?)"),
    ("--accels", "warp:", "argument --accels: accelerator 'warp:': the builder after ':' is empty (did you mean "
     "'warp:sah'?)"),
    ("--accels", "wrt::wide8", "accelerator 'wrt::wide8': the builder after ':' is empty (did you mean "
     "'wrt:sah:wide8'?)"),
    ("--accels", "embree:", "accelerator 'embree:': the part after ':' is empty (did you mean 'embree'?)"),
    ("--rays", "foo", "argument --rays: unknown ray kind 'foo'"),
    ("--scenes", "", "argument --scenes: names nothing"),
    ("--scenes", "sphere:200,sphere:0", "argument --scenes: sphere:0: N must be a whole number of triangles"),
    ("--scenes", "sphere:abc", "argument --scenes: sphere:abc: N must be a whole number of triangles"),
    # A whole number, too large: it was called no whole number.
    ("--scenes", "sphere:1e301", "argument --scenes: sphere:1e301: N = 1e301 triangles is past 1e300; no host holds"),
    # An error row per group: 'warp:' loaded Warp's asset folder ('a directory, not a USD file'), 'asset:' no ''.
    ("--scenes", "sphere:200,warp:", "argument --scenes: 'warp:' names no scene; give warp:NAME (a file of Warp's"),
    ("--scenes", "asset: ", "argument --scenes: 'asset:' names no scene; give asset:ID (a shared asset's id)"),
    ("--devices", "cpuu", "argument --devices: unknown device 'cpuu' (did you mean 'cpu'?)"),
    # 100,000,000 timed launches per row: a run of days, without a word.
    ("--repeats", "100000000", "argument --repeats: must be at most 10,000 (the median of more launches is no "
     "steadier), got 100,000,000"),
])
def test_bad_bench_options_are_named_before_any_scene_loads(tmp_path, monkeypatch, capsys, option, value, message):
    """These errors named only the value ('unknown ray kind 'foo'') or a field ('threads must be ...'), not the option
    typed; sphere:0 and sphere:abc became error rows once the scenes before them had run, and --threads '' ran no
    CPU row at all and exited 0."""
    loaded = []
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: loaded.append(name))
    argv = ["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "100", "-q",
            "-o", str(tmp_path / "out"), option, value]
    try:
        code = main(argv)
    except SystemExit as e:  # argparse's own refusals
        code = e.code
    assert code == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(err) == 1 and message in err[0], err
    assert loaded == [] and not (tmp_path / "out" / "rows.jsonl").exists()


def test_repeats_help_states_the_cap_the_option_is_checked_against(tmp_path, capsys):
    """--repeats above 10,000 is refused (Grid.validated), a cap its help did not give."""
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    cap = int(re.search(r"--repeats REPEATS .*?at most ([\d,]+)", help_text).group(1).replace(",", ""))
    assert small_grid(repeats=cap).validated().repeats == cap
    with pytest.raises(GridError, match=f"at most {cap:,}"):
        small_grid(repeats=cap + 1).validated()


def test_an_empty_thread_list_in_a_suite_is_refused(tmp_path):
    with pytest.raises(ValueError, match="suite.json: threads: must list at least one thread count"):
        Grid.from_suite(write_suite(tmp_path, threads=[]))


def test_agreement_checks_the_hits_of_the_kernel_that_was_timed(tmp_path, monkeypatch):
    """wrt rows were timed with the kernels that count no costs, then traced once more with the counting kernels for
    the agreement check: a wrong answer of the timed kernel was never compared with wp.Mesh's."""
    from wrt.trace import BvhAccelerator

    intersect = BvhAccelerator._intersect

    def timed_kernel_loses_hits(self, origins, directions, t_mins, t_maxs, hits, costs):
        intersect(self, origins, directions, t_mins, t_maxs, hits, costs)
        if not costs:
            prim = hits.prim.numpy()  # a view of the CPU buffer
            prim[np.flatnonzero(prim >= 0)[:7]] = -1

    monkeypatch.setattr(BvhAccelerator, "_intersect", timed_kernel_loses_hits)
    rows = run_grid(small_grid(scenes=["sphere:200"], accels=["warp:sah", "wrt:sah"], n_rays=300, repeats=1),
                    tmp_path, progress=False)
    assert [(r["accel"], r["disagreements"]) for r in rows] == [("warp:sah", 0), ("wrt:sah", 7)]


@pytest.mark.parametrize("wrong", ["false hit", "hit moved", "other triangle"])
def test_a_wrong_hit_on_an_edge_of_its_triangle_is_a_disagreement_not_a_tie(tmp_path, monkeypatch, wrong):
    """Edge ties were judged by the barycentrics each answer reports: a wrong hit reported at u = v = 0 (a vertex, as
    a buffer cleared to zeros reads) counted as a tie, so 7 false hits, or 7 hits 1.5 times too far, were no
    disagreement: the row showed 97.667 % agreement with no '(7 differ)' and the CLI warned of nothing."""
    answer = bench_module._Subject.answer

    def wrong_on_a_vertex(subject):
        hits = answer(subject)
        if subject.spec == "wrt:sah":
            if wrong == "false hit":
                rays = np.flatnonzero(hits.prim < 0)[:7]  # rays that meet nothing: report triangle 0 at t = 1
                hits.prim[rays], hits.t[rays] = 0, 1.0
            elif wrong == "hit moved":
                rays = np.flatnonzero(hits.prim >= 0)[:7]
                hits.t[rays] *= 1.5
            else:  # the right distance, a triangle on the far side of the sphere: the row agreed (100.000 %)
                rays = np.flatnonzero(hits.prim >= 0)[:7]
                points, indices = subject.scene.triangles()
                hit_points = subject.rays[0].numpy()[rays] + hits.t[rays, None] * subject.rays[1].numpy()[rays]
                far = np.argmax(points[indices].mean(1) @ -hit_points.mean(0))
                assert np.linalg.norm(points[indices[far]].mean(0) - hit_points, axis=1).min() > 0.5  # far indeed
                hits.prim[rays] = far
                return hits
            hits.u[rays], hits.v[rays] = 0.0, 0.0
        return hits

    monkeypatch.setattr(bench_module._Subject, "answer", wrong_on_a_vertex)
    rows = run_grid(small_grid(scenes=["sphere:200"], accels=["warp:sah", "wrt:sah"], n_rays=300, repeats=1),
                    tmp_path, progress=False)
    assert [(r["accel"], r["disagreements"]) for r in rows] == [("warp:sah", 0), ("wrt:sah", 7)]
    assert "(7 differ)" in (tmp_path / "table.md").read_text()


MIRRORED_INSTANCES_USDA = """#usda 1.0
class "Proto"
{
    def Mesh "M"
    {
        int[] faceVertexCounts = [3, 3]
        int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0.5), (0, 1, 0)]
    }
}
def Xform "A" (inherits = </Proto>
    instanceable = true)
{
    double3 xformOp:translate = (2, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "Mirrored" (inherits = </Proto>
    instanceable = true)
{
    double3 xformOp:scale = (-1, 1, 1)
    uniform token[] xformOpOrder = ["xformOp:scale"]
}
"""


@pytest.mark.parametrize("accel", ["warp:sah", "wrt:sah"])
def test_hits_checked_for_agreement_lie_on_the_triangles_they_name(tmp_path, accel):
    """The hits a row is checked with name rows of Scene.triangles() with their barycentrics, so that a hit can be
    told from one off its own triangle; those of instances named the prototype's triangle, in its corner order."""
    path = tmp_path / "instances.usda"
    path.write_text(MIRRORED_INSTANCES_USDA)
    scene = bench_module.resolve_scene(str(path))
    origins, directions = bench_module.ray_set(scene, "incoherent", 2000, seed=1)
    subject = bench_module._Subject(accel, scene, bench_module.resolve_device("cpu"), 1)
    subject.prepare(origins, directions, any_hit=False)
    subject.run()
    hits = subject.answer()
    points, indices = scene.triangles()
    h = hits.prim >= 0
    assert set(hits.prim[h]) == {0, 1, 2, 3}  # both instances hit
    corners = points[indices[hits.prim[h]]].astype(np.float64)
    u, v = hits.u[h, None].astype(np.float64), hits.v[h, None].astype(np.float64)
    on_triangle = (1 - u - v) * corners[:, 0] + u * corners[:, 1] + v * corners[:, 2]
    along = origins[h].astype(np.float64) + hits.t[h, None] * directions[h].astype(np.float64)
    np.testing.assert_allclose(on_triangle, along, atol=1e-5)


def test_the_rate_reported_is_the_median_of_the_rates_of_the_timed_launches(tmp_path, monkeypatch):
    """Mrays/s was the ray count over the median time: with an even number of launches (10 in every suite) that is
    the harmonic mean of the middle two rates, not the median rate the table and plot say they show."""
    times = [1.0, 3.0, 2.0, 10.0]
    monkeypatch.setattr(bench_module, "time_runs", lambda run, repeats: [run(), times][1])
    row = run_grid(small_grid(scenes=["sphere:200"], n_rays=300, repeats=4), tmp_path, progress=False)[0]
    rates = row["n_rays"] / np.array(times) / 1e6
    assert row["mrays"] == pytest.approx(np.median(rates), rel=1e-12)
    assert (row["mrays_min"], row["mrays_max"]) == pytest.approx((rates.min(), rates.max()), rel=1e-12)


def test_a_scene_of_degenerate_triangles_only_is_an_error_row_and_the_run_goes_on(tmp_path, capsys):
    """A mesh whose triangles all have zero area (collinear corners) was 'measured' as the empty stage was: rows of
    0 % hits and 100 % agreement at some Mrays/s, and the run ended with status 0, nothing said failed."""
    degenerate = tmp_path / "degenerate.usda"
    degenerate.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3, 3]\n'
                          '    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]\n'
                          '    point3f[] points = [(0, 0, 0), (1, 1, 1), (2, 2, 2), (3, 3, 3)]\n}\n')
    out = tmp_path / "out"
    code = main(["bench", "--scenes", f"sphere:200,{degenerate},sphere:300", "--accels", "warp:sah,wrt:sah",
                 "--rays", "incoherent", "--n-rays", "300", "--repeats", "1", "-q", "-o", str(out)])
    assert code == 1
    rows = [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]
    assert [(r["scene"].rsplit("/", 1)[-1], r["accel"], "mrays" in r) for r in rows] == [
        ("sphere:200", "warp:sah", True), ("sphere:200", "wrt:sah", True), ("degenerate.usda", "*", False),
        ("sphere:300", "warp:sah", True), ("sphere:300", "wrt:sah", True)]
    assert "2 triangles all have zero area" in rows[2]["error"]
    assert "1 failed" in capsys.readouterr().err


def test_a_bench_run_in_which_every_row_failed_exits_2_as_a_render_batch_none_of_whose_scenes_rendered(tmp_path,
                                                                                                      capsys):
    """README: a render batch in which none could be rendered exits with status 2 (some failed: 1, as bench does);
    a bench run whose every row failed exited 1, as if some had been measured."""
    degenerate = tmp_path / "degenerate.usda"
    degenerate.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                          '    int[] faceVertexIndices = [0, 1, 2]\n'
                          '    point3f[] points = [(0, 0, 0), (1, 1, 1), (2, 2, 2)]\n}\n')
    argv = ["bench", "--scenes", f"{degenerate},{tmp_path / 'missing.usda'}", "--accels", "wrt:sah", "--rays",
            "incoherent", "--n-rays", "100", "--repeats", "1", "-q", "-o", str(tmp_path / "out")]
    assert main(argv) == 2
    assert "0 rows measured, 0 resumed, 2 failed" in capsys.readouterr().err


def test_the_rate_plot_marks_failed_rows_and_groups_n_a(tmp_path, monkeypatch):
    """A failed row, and a row that measured nothing (NaN), were drawn as no bar, as a row never run is, and a group
    that failed whole was not on the plot at all: nothing told a failure from a rate of 0."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    figures = []  # in the order of the paths plot returns: each is saved to a temporary name first
    monkeypatch.setattr(Figure, "savefig", lambda fig, path, **kwargs: figures.append(fig))

    def row(scene, accel, mrays):
        return dict(scene=scene, triangles=10, device="cpu", rays="primary", accel=accel, threads=1, build_ms=1.0,
                    mrays=mrays, mrays_min=mrays, mrays_max=mrays, hit_fraction=0.5, agreement=1.0)

    rows = [row("a", "warp:sah", 2.0), row("a", "wrt:sah", 3.0), row("b", "warp:sah", 4.0),
            {"scene": "b", "accel": "wrt:sah", "device": "cpu", "rays": "primary", "threads": 1, "error": "boom"},
            row("c", "warp:sah", math.nan), row("c", "wrt:sah", 1.0),
            {"scene": "d", "accel": "*", "device": "cpu", "rays": "primary", "threads": None, "error": "no file"}]
    drawn = dict(zip([path.name for path in bench_module.plot(rows, tmp_path)], figures, strict=True))
    ax = drawn["mrays.png"].axes[0]
    groups = [label.get_text().split("\n")[0] for label in ax.get_xticklabels()]
    assert groups == ["a", "b", "c", "d"]
    bars = {(container.get_label(), groups[k]): bar.get_height()
            for container in ax.containers for k, bar in enumerate(container)}
    assert bars == {("warp:sah x1", "a"): 2.0, ("wrt:sah x1", "a"): 3.0, ("warp:sah x1", "b"): 4.0,
                    ("wrt:sah x1", "b"): 0, ("warp:sah x1", "c"): 0, ("wrt:sah x1", "c"): 1.0,
                    ("warp:sah x1", "d"): 0, ("wrt:sah x1", "d"): 0}
    ticks = ax.get_xticks()
    marks = sorted((int(round(text.get_position()[0] - ticks[0])), text.get_text()) for text in ax.texts)
    assert marks == [(1, "n/a"), (2, "n/a"), (3, "failed")]  # b's wrt:sah, c's warp:sah, all of d


def test_the_ratio_to_a_reference_row_that_failed_reads_n_a_not_blank():
    """The 'x warp:sah' cell was blank where warp:sah failed in the group, as where it was never run: a failed
    reference looked like one not asked for. n/a where it failed; blank where it is not in the run."""
    def row(scene, accel, mrays):
        return dict(scene=scene, triangles=10, device="cpu", rays="primary", accel=accel, threads=1, build_ms=1.0,
                    mrays=mrays, mrays_min=mrays, mrays_max=mrays, hit_fraction=0.5, agreement=1.0)

    failed = {"scene": "a", "accel": "warp:sah", "device": "cpu", "rays": "primary", "threads": 1, "error": "boom"}
    rows = [failed, row("a", "wrt:sah", 3.0), row("b", "warp:sah", 2.0), row("b", "wrt:sah", 3.0),
            row("c", "wrt:sah", 5.0)]
    cells = {line.split("|")[1].strip(): line.split("|")[11].strip()
             for line in bench_module.markdown_table(rows).splitlines() if "| wrt:sah |" in line}
    assert cells == {"a": "n/a", "b": "1.50", "c": ""}


def test_no_ratio_to_a_reference_row_measured_on_other_triangles_or_rays():
    """wrt:sah and warp:sah measured, the scene edited, then --resume --accels wrt:sah: the new wrt:sah row (9.9 %
    hits) got 'x warp:sah 1.03' from the earlier run's warp:sah row, kept outside the grid and measured on the old
    triangles (33.9 % hits): a ratio of two workloads. Rows are compared only on the same inputs (blank otherwise,
    as where the reference was not run)."""
    def row(accel, mrays, inputs):
        return dict(scene="a", triangles=10, device="cpu", rays="primary", accel=accel, threads=1, build_ms=1.0,
                    mrays=mrays, mrays_min=mrays, mrays_max=mrays, hit_fraction=0.5, inputs=inputs)

    for reference, ratio in ((row("warp:sah", 2.0, "old"), ""), (row("warp:sah", 2.0, "new"), "1.50")):
        table = bench_module.markdown_table([reference, row("wrt:sah", 3.0, "new")])
        (line,) = [line for line in table.splitlines() if "| wrt:sah |" in line]
        assert line.split("|")[11].strip() == ratio, line


def test_a_bad_device_of_a_suite_is_named_with_the_file_and_key(tmp_path, monkeypatch, capsys):
    """Devices are checked when the run starts, after the suite is read: a misspelt one was refused as 'unknown or
    unavailable device' alone, naming neither the suite file nor the key."""
    loaded = []
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: loaded.append(name))
    suite = write_suite(tmp_path, devices=["cpu", "cpuu"], rays=["primary"], n_rays=100)
    assert main(["bench", str(suite), "-q", "-o", str(tmp_path / "out")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(err) == 1 and "suite.json: devices[1]: unknown device 'cpuu' (did you mean 'cpu'?)" in err[0], err
    assert loaded == []


def test_devices_given_on_the_command_line_replace_a_suite_s_misspelt_ones_unchecked(tmp_path, monkeypatch):
    """--devices replaces the suite's devices, yet a misspelt one in the file ('cpuu') stopped the run: the suite was
    checked in full before the options replaced its values."""
    asked = []
    real = bench_module.run_grid

    def run_grid(grid, *args, **kwargs):
        asked.append(grid.devices)
        return real(grid, *args, **kwargs)

    monkeypatch.setattr(bench_module, "run_grid", run_grid)
    suite = write_suite(tmp_path, devices=["cpuu"], rays=["primary"], n_rays=100, repeats=1)
    assert main(["bench", str(suite), "--devices", "cpu", "-q", "-o", str(tmp_path / "out")]) == 0
    assert asked == [["cpu"]]
    rows = [json.loads(line) for line in (tmp_path / "out" / "rows.jsonl").read_text().splitlines()]
    assert {r["device"] for r in rows} == {"cpu"} and all("error" not in r for r in rows)


def test_a_bad_device_given_on_the_command_line_over_a_suite_names_the_option(tmp_path, capsys):
    suite = write_suite(tmp_path, devices=["cpuu"], rays=["primary"], n_rays=100)
    assert main(["bench", str(suite), "--devices", "CPU", "-q", "-o", str(tmp_path / "out")]) == 2
    assert "argument --devices: unknown device 'CPU' (did you mean 'cpu'?)" in capsys.readouterr().err


@pytest.mark.parametrize("fields, message", [
    (dict(devices=["CPU"]), r"devices\[0\]: unknown device 'CPU' \(did you mean 'cpu'\?\)"),
    (dict(devices=["cpu", "Cuda:1"]), r"devices\[1\]: unknown device 'Cuda:1' \(did you mean 'cuda:1'\?\)"),
    (dict(devices=["gpu"]), r"devices\[0\]: unknown device 'gpu' \(did you mean 'cuda'\?\)"),
    (dict(devices=["cuda:x"]), r"devices\[0\]: unknown device 'cuda:x'.*; devices are cpu, cuda and cuda:N"),
    (dict(accels=["wrt:sha"]), r"accels\[0\]: accelerator 'wrt:sha': unknown BVH builder 'sha' \(did you mean 'sah'"),
    (dict(rays=["Primary"]), r"rays\[0\]: unknown ray kind 'Primary' \(did you mean 'primary'\?\)"),
    (dict(repeats=10_001), r"repeats: must be at most 10,000 .*, got 10,001"),
])
def test_a_grid_is_refused_when_made_naming_the_bad_value(fields, message):
    """Grid(devices=["CPU"]) was taken and refused only by run_grid, a misspelt accelerator or ray kind too."""
    with pytest.raises(GridError) as error:
        small_grid(**fields)
    assert re.search(message, error.value.where()), error.value.where()


def test_a_grid_takes_every_warp_device_name_without_looking_for_the_device():
    # Whether this machine has the GPU is for run_grid (or the Dask worker that runs the rows) to find.
    assert small_grid(devices=["cpu", "cuda", "cuda:0", "cuda:7"]).devices == ["cpu", "cuda", "cuda:0", "cuda:7"]


@pytest.mark.parametrize("strict", [False, True])
def test_strict_bench_exits_1_when_a_row_disagrees_with_wp_mesh(tmp_path, monkeypatch, capsys, strict):
    """A row that answered rays otherwise than ``warp:sah`` (the independent wp.Mesh answer; here 7 of wrt's hits
    dropped) was a warning line only, with exit status 0: a scripted run could not tell. ``--strict`` makes it
    status 1, as a failed row is, with an error line; without it the warning and status 0 stay."""
    answer = bench_module._Subject.answer

    def loses_hits(subject):
        hits = answer(subject)
        if subject.spec == "wrt:sah":
            hits.prim[np.flatnonzero(hits.prim >= 0)[:7]] = -1
        return hits

    monkeypatch.setattr(bench_module._Subject, "answer", loses_hits)
    argv = ["bench", "--scenes", "sphere:200", "--accels", "warp:sah,wrt:sah", "--rays", "primary", "--n-rays", "300",
            "--repeats", "1", "-q", "-o", str(tmp_path / "out")]
    code = main(argv + ["--strict"] * strict)
    err = capsys.readouterr().err
    assert code == (1 if strict else 0)
    kind = "error" if strict else "warning"
    assert f"wrt: {kind}: sphere:200 / wrt:sah / cpu / primary: 7 of 300 rays answered otherwise than by warp:sah" \
        in err, err


def test_spellings_of_one_accelerator_are_one_row_checked_against_warp_sah(tmp_path):
    """'wrt', 'wrt:sah', 'wrt:sah:binary' and 'wrt:binned_sah' are one tree: each was measured as a row of its own;
    and 'warp' (warp:sah) was not taken for the reference, so every row of its group was 'unchecked'."""
    grid = small_grid(accels=["warp", "wrt", "wrt:sah:binary", "wrt:binned_sah", "wrt:sah:wide"],
                      scaling={"sizes": [1000], "accels": ["wrt", "wrt:sah"]}).validated()
    assert grid.accels == ["warp:sah", "wrt:sah", "wrt:sah:wide"]
    assert grid.scaling["accels"] == ["wrt:sah"]
    rows = run_grid(small_grid(accels=["warp", "wrt", "wrt:sah:binary"]), tmp_path, progress=False)
    assert sorted(r["accel"] for r in rows) == ["warp:sah", "wrt:sah"]
    assert all(r["agreement"] == 1.0 for r in rows), rows


@pytest.mark.parametrize("name, message", [
    ("folder", "folder: a directory, not a benchmark suite (a JSON file)"),  # was '[Errno 21] Is a directory: ...'
    ("scene.usda", "scene.usda is a scene, not a benchmark suite; measure it with --scenes "),  # 'not a JSON suite'
    ("missing.usdc", "missing.usdc is a scene, not a benchmark suite; measure it with --scenes "),
])
def test_a_suite_argument_that_is_a_folder_or_a_scene_says_so(tmp_path, capsys, name, message):
    (tmp_path / "folder").mkdir()
    (tmp_path / "scene.usda").write_text("#usda 1.0\n")
    assert main(["bench", str(tmp_path / name), "-o", str(tmp_path / "out")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(err) == 1 and err[0].startswith("wrt: error: ") and message in err[0], err
    assert not (tmp_path / "out").exists()


def test_a_suite_argument_that_is_a_file_wrt_wrote_names_what_it_holds(tmp_path, capsys):
    """'wrt bench bench-out/rows.jsonl' said 'not a JSON suite (Extra data at line 2, column 1)', and its
    settings.json 'unknown suite keys ['scaling_n_rays'] (did you mean 'scaling'?)', as if a suite had a typo."""
    out = tmp_path / "bench-out"
    assert main(["bench", "--scenes", "sphere:100", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
                 "--n-rays", "16", "--repeats", "1", "--threads", "1", "-o", str(out), "-q"]) == 0
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    log = tmp_path / "log.jsonl"
    assert main(["render", str(tmp_path / "a.usda"), "-o", str(tmp_path / "a.png"), "--width", "4", "--height", "3",
                 "--log", str(log), "-q"]) == 0
    capsys.readouterr()
    names = sorted(p.stem for p in bench_module.SUITES_DIR.glob("*.json"))  # cpu, gpu, quick
    suites = f"give a suite ({', '.join([*names, 'a JSON file of grid fields'])})"
    for given, what, hint in (
        (out / "rows.jsonl", "rows that wrt bench measured (its OUT/rows.jsonl)", f"; to keep its folder's rows, add "
                                                                                  f"-o {out} --resume"),
        (out / "settings.json", "the settings.json of a wrt bench output folder (the ray counts and repeats of its "
                                "rows)", f"; to keep its folder's rows, add -o {out} --resume"),
        (log, "rows of a wrt render log", ""),
    ):
        before = given.read_bytes()
        assert main(["bench", str(given), "-o", str(tmp_path / "new")]) == 2
        err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
        assert err == [f"wrt: error: {given}: {what}, not a benchmark suite; {suites}{hint}"], err
        assert given.read_bytes() == before and not (tmp_path / "new").exists()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_suite_that_is_a_named_pipe_is_a_one_line_error_not_a_hang(tmp_path):
    """A FIFO given as the suite file made read_text() wait for a writer that never came: wrt bench hung. It is
    refused as --log refuses one, naming the path; the process must end on its own (a fresh interpreter)."""
    import subprocess

    fifo = tmp_path / "suite.json"
    os.mkfifo(fifo)
    try:
        done = subprocess.run([sys.executable, "-m", "wrt.cli", "bench", str(fifo), "-o", str(tmp_path / "out")],
                              capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("wrt bench on a named pipe hung")
    errors = [line for line in done.stderr.splitlines() if line.startswith("wrt:")]
    assert done.returncode == 2 and errors == [f"wrt: error: {fifo}: a pipe or socket, not a benchmark suite (a JSON "
                                               "file)"], done.stderr
    assert not (tmp_path / "out").exists()


def test_one_scene_in_two_spellings_is_measured_once(tmp_path, monkeypatch):
    """sphere:100 and sphere:1e2, a.usda and ./a.usda (and its absolute path) were each measured as scenes of their
    own: the same rows twice, where a name repeated as typed is measured once."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    monkeypatch.chdir(tmp_path)
    scenes = ["sphere:100", "a.usda", "sphere:1e2", "./a.usda", str(tmp_path / "a.usda"), "missing.usda"]
    assert small_grid(scenes=scenes).validated().scenes == ["sphere:100", "a.usda", "missing.usda"]


def test_rows_of_an_earlier_run_under_other_spellings_are_resumed_by_canonical_name(tmp_path):
    """Rows an earlier run measured as 'wrt' and 'warp' (named as typed, before names were made canonical) were kept
    beside this run's 'wrt:sah' and 'warp:sah' rows of the same measurement: each row twice in the table."""
    grid = small_grid(accels=["warp:sah", "wrt:sah"])
    run_grid(grid, tmp_path, progress=False)
    jsonl = tmp_path / "rows.jsonl"
    old = [dict(row, accel=row["accel"].split(":")[0]) for row in map(json.loads, jsonl.read_text().splitlines())]
    jsonl.write_text("".join(json.dumps(row) + "\n" for row in old))
    rows = run_grid(grid, tmp_path, resume=True, progress=False)
    assert rows.resumed == 2 and sorted(r["accel"] for r in rows) == ["warp:sah", "wrt:sah"], rows
    assert [r["mrays"] for r in rows] == [r["mrays"] for r in old]  # not measured again


def test_a_misspelt_asset_id_names_the_one_meant(tmp_path, monkeypatch):
    """'asset:chess_sets' said only "no asset 'chess_sets' in .../manifest.json", among dozens of ids."""
    (tmp_path / "manifest.json").write_text(json.dumps({"assets": [{"id": "chess_set", "path": "chess.usda"},
                                                                   {"id": "fancy_teapot", "path": "teapot.usda"}]}))
    monkeypatch.setenv("WRT_ASSETS", str(tmp_path))
    with pytest.raises(ValueError, match=r"no asset 'chess_sets' \(did you mean 'chess_set'\?\) in "):
        bench_module.asset_path("chess_sets")
    assert bench_module.asset_path("chess_set") == tmp_path / "chess.usda"


@pytest.mark.parametrize("content, message", [
    (b'{"assets": [{"id": "a", "path": "a.usda"},]}', "not a JSON manifest (Expecting value at line 1, column 43)"),
    (b"\xff\xfe{}", "not UTF-8 JSON text (byte 0 is no UTF-8)"),
    (b'[{"id": "a", "path": "a.usda"}]', 'must be a JSON object with an "assets" list'),
    (b'{"assets": {"a": "a.usda"}}', 'must be a JSON object with an "assets" list'),
    (b'{"assets": [{"id": "a", "path": "a.usda"}, {"id": "b"}]}', 'assets[1] must be an object with text "id" and '
                                                                  '"path", got {"id": "b"}'),
])
def test_a_malformed_manifest_is_named_with_what_is_wrong(tmp_path, monkeypatch, content, message):
    """A manifest.json that is no JSON failed with Python's words alone ('Expecting value: line 1 column 42 (char
    41)'), one without an assets list or an entry without a path with a bare KeyError ('assets', 'path'): none named
    the file. The position is json's own (the oracle: json.loads of the same text)."""
    (tmp_path / "manifest.json").write_bytes(content)
    monkeypatch.setenv("WRT_ASSETS", str(tmp_path))
    if message.startswith("not a JSON manifest"):  # as a suite file's error words it
        with pytest.raises(json.JSONDecodeError) as error:
            json.loads(content)
        assert message.endswith(f"({error.value.msg} at line {error.value.lineno}, column {error.value.colno})")
    with pytest.raises(ValueError) as error:
        bench_module.asset_path("a")
    assert str(error.value).startswith(f"{tmp_path / 'manifest.json'}: {message}"), str(error.value)


def test_quick_suite_duration_is_stated_alike_in_help_suite_and_readme(capsys):
    """--help said 'about a minute' and wrt/suites/quick.json 'under 2 minutes' for the same run."""
    from wrt.cli import build_parser

    with pytest.raises(SystemExit):
        build_parser().parse_args(["bench", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    duration = re.search(r"--quick run the small 'quick' suite \(([^,)]+ on a CPU)", help_text).group(1)
    suite = json.loads((Path(bench_module.__file__).parent / "suites" / "quick.json").read_text())
    assert suite["description"].endswith(f"; {duration}")
    readme = (Path(bench_module.__file__).parents[1] / "README.md").read_text()
    assert re.search(rf"wrt bench --quick .*# .*{duration}\n", readme)


def test_a_thread_count_past_the_cores_is_kept_as_asked_and_its_effective_count_recorded(tmp_path, monkeypatch):
    """``threads: [64]`` on a 2-core machine was recorded as 64 threads, as if 64 ran: the row now also says how many
    ran at once, ``threads_effective``: the worker threads the launch was split over (seen on the thread pool the
    trace made), at most the cores this process may run on (its CPU affinity). The count asked stays in ``threads``
    (a suite written for a larger machine still runs here)."""
    import concurrent.futures
    import importlib

    trace_module = importlib.import_module("wrt.trace")  # ``wrt.trace`` is also the function

    pools = []

    class Pool(concurrent.futures.ThreadPoolExecutor):
        def __init__(self, workers, *args, **kwargs):
            pools.append(workers)
            super().__init__(workers, *args, **kwargs)

    monkeypatch.setattr(trace_module, "ThreadPoolExecutor", Pool)
    rays = 3 * trace_module.MIN_RAYS_PER_THREAD  # three pieces of the smallest size split off
    (row,) = run_grid(small_grid(rays=["incoherent"], n_rays=rays, threads=[64], repeats=1), tmp_path, progress=False)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert pools and set(pools) == {3}, pools
    assert row["threads"] == 64 and row["threads_effective"] == min(3, cores), row
    table = (tmp_path / "table.md").read_text()
    assert f"| 64 ({min(3, cores)} ran) |" in table, table


def test_rows_of_an_earlier_run_under_another_spelling_of_a_scene_are_resumed_as_this_runs(tmp_path):
    """A run measures one scene in two spellings once (sphere:2e3 and sphere:2000); resumed under the other spelling,
    the earlier run's rows were kept beside this run's new rows of the same measurement, each row twice."""
    run_grid(small_grid(scenes=["sphere:2e3"]), tmp_path, progress=False)
    old = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    rows = run_grid(small_grid(scenes=["sphere:2000"]), tmp_path, resume=True, progress=False)
    assert rows.resumed == 1 and [r["scene"] for r in rows] == ["sphere:2000"], list(rows)
    assert [r["mrays"] for r in rows] == [r["mrays"] for r in old]  # not measured again


def test_an_empty_dask_address_starts_a_local_cluster_as_render_s_does(tmp_path, monkeypatch, capsys):
    """'wrt bench --dask "$ADDR"' with ADDR unset ran every group here, without Dask and without a word; wrt render
    --dask and run_tasks take an empty address for a LocalCluster."""
    from wrt import distributed
    from wrt.distributed import DaskUnavailable

    asked = []

    def run_tasks(fn, tasks, address=None, **kwargs):
        asked.append(address)
        raise DaskUnavailable("no cluster in this test")

    monkeypatch.setattr(distributed, "run_tasks", run_tasks)
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: pytest.fail("a group ran here"))
    argv = ["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "100", "-q",
            "-o", str(tmp_path / "out"), "--dask", ""]
    assert main(argv) == 1
    assert asked == [None]
    assert "wrt: error: no cluster in this test" in capsys.readouterr().err


@pytest.mark.parametrize("options, message", [
    (["--accels", "warp:sah,warp:lbvh", "--devices", "cpu"], "arguments --accels and --devices: accelerator "
     "'warp:lbvh' with devices cpu: wp.Mesh has no lbvh builder on the CPU (Warp builds its sah tree there, which "
     "warp:sah measures); add a CUDA device, or measure warp:sah"),
    (["--accels", "embree", "--devices", "cuda:0"], "arguments --accels and --devices: accelerator 'embree' with "
     "devices cuda:0: Embree runs on the CPU only; add the cpu device"),
    (["--accels", "warp:lbvh", "{suite}"], "argument --accels, with suite.json's devices: "
     "accelerator 'warp:lbvh' with devices cpu: wp.Mesh has no lbvh builder on the CPU"),
])
def test_an_accelerator_that_no_device_of_the_run_builds_is_refused_naming_both_options(tmp_path, monkeypatch, capsys,
                                                                                      options, message):
    """--accels warp:lbvh --devices cpu loaded every scene and made its rays, then failed each warp:lbvh row, while
    wrt render --accel warp --builder lbvh on the CPU says so at once; Embree on a CUDA device likewise."""
    loaded = []
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: loaded.append(name))
    suite = write_suite(tmp_path, devices=["cpu"])
    argv = ["bench", "--scenes", "sphere:200", "--rays", "primary", "--n-rays", "100", "-q", "-o",
            str(tmp_path / "out"), *[str(suite) if o == "{suite}" else o for o in options]]
    assert main(argv) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(err) == 1 and err[0].startswith(f"wrt: error: {message}"), err
    assert loaded == [] and not (tmp_path / "out").exists()
    with pytest.raises(GridError, match="accelerator 'warp:lbvh' with devices cpu: wp.Mesh has no lbvh builder"):
        small_grid(accels=["warp:sah"], devices=["cpu"], scaling={"sizes": [1000], "accels": ["warp:lbvh"]})


def test_rows_an_accelerator_cannot_build_on_one_device_of_a_run_are_left_out_with_a_warning(tmp_path):
    """warp:lbvh in a cpu,cuda:0 run: its cpu rows failed (the run exited 1) after the scene had loaded."""
    grid = small_grid(accels=["warp:sah", "warp:lbvh"], devices=["cpu", "cuda:0"])
    with pytest.warns(UserWarning, match="warp:lbvh has no rows on cpu: wp.Mesh has no lbvh builder on the CPU"):
        rows = run_grid(grid, tmp_path, progress=False)
    on_cpu = [(r["accel"], "error" in r) for r in rows if r["device"] == "cpu"]
    assert on_cpu == [("warp:sah", False)]


def test_a_ray_count_past_the_host_memory_names_the_option_typed(tmp_path, monkeypatch, capsys):
    """--n-rays 1e12 said 'n_rays 1000000000000 needs about ...', the Python name, where every other bad option of
    wrt bench is named as typed; the Python API keeps its MemoryError naming n_rays."""
    monkeypatch.setattr("wrt.resources.available_host_bytes", lambda: 1 << 30)
    loaded = []
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: loaded.append(name))
    argv = ["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "-q", "-o", str(tmp_path / "out")]
    assert main([*argv, "--n-rays", "1e12"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    expected_bytes = 10**12 * bench_module.RAY_BYTES / 2**40  # TiB, as the message rounds them
    assert err == [f"wrt: error: argument --n-rays: 1,000,000,000,000 rays need about {expected_bytes:.1f} TiB of "
                   "host memory, 1.0 GiB is available (see 'wrt bench --help')"], err
    assert loaded == [] and not (tmp_path / "out").exists()
    with pytest.raises(MemoryError, match="^n_rays 1000000000000 needs about"):
        small_grid(n_rays=10**12)


def test_a_misspelt_scene_file_is_an_error_row_naming_the_file_meant(tmp_path, capsys):
    """A scene path with a typo ('goood.usda' beside good.usda) was an error row 'file not found' at its turn in the
    batch, naming no file meant, where warp:NAME, asset:ID and a misspelt kind get a did-you-mean; the batch goes on."""
    good = tmp_path / "good.usda"
    good.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
                    '[0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    (tmp_path / "notes.txt").write_text("not a scene")  # only USD files are offered
    rows = run_grid(small_grid(scenes=[str(tmp_path / "goood.usda"), str(good), str(tmp_path / "note.usda")],
                               n_rays=200, repeats=1), tmp_path / "out", progress=False)
    errors = {Path(r["scene"]).name: r["error"] for r in rows if "error" in r}
    assert errors == {"goood.usda": f"SceneError: {tmp_path / 'goood.usda'}: file not found (did you mean "
                                    "'good.usda'?)",
                      "note.usda": f"SceneError: {tmp_path / 'note.usda'}: file not found"}
    assert [Path(r["scene"]).name for r in rows if "mrays" in r] == ["good.usda"]
    assert main(["render", str(tmp_path / "goood.usda"), "-o", str(tmp_path / "x.png"), "-q"]) == 2
    assert f"{tmp_path / 'goood.usda'}: file not found (did you mean 'good.usda'?)" in capsys.readouterr().err


def test_a_run_into_a_folder_of_another_suite_s_rows_says_which_it_drops(tmp_path):
    """wrt bench --quick after wrt bench cpu (both -o bench-out by default) replaced the cpu suite's rows with its own
    without a word; rows this run measures again are replaced silently, as before."""
    out = tmp_path / "bench-out"
    run_grid(small_grid(scenes=["sphere:200", "sphere:300"], n_rays=200, repeats=1), out, progress=False)
    other = small_grid(scenes=["sphere:300", "sphere:400"], n_rays=200, repeats=1)
    with pytest.warns(UserWarning) as said:
        run_grid(other, out, progress=False)
    dropped = [str(w.message) for w in said if "earlier run" in str(w.message)]
    assert dropped == [f"{out}: 1 row of an earlier run measured what this run does not (sphere:200 / wrt:sah / cpu / "
                       "primary); it is dropped when this run writes its first row (resume keeps it: wrt bench "
                       "--resume)"], dropped
    assert {r["scene"] for r in map(json.loads, (out / "rows.jsonl").read_text().splitlines())} == {
        "sphere:300", "sphere:400"}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same grid again: its rows are measured again, nothing is lost
        run_grid(other, out, progress=False)


def test_a_suite_run_on_devices_that_cannot_build_one_of_its_accelerators_leaves_it_out_with_a_warning(tmp_path,
                                                                                                      capsys):
    """wrt bench gpu --devices cpu failed each of the gpu suite's warp:lbvh rows, and wrt bench --devices cuda:0 each
    of the quick suite's embree rows; the suite's other accelerators are measured, as before."""
    suite = write_suite(tmp_path, scenes=["sphere:200"], accels=["warp:sah", "warp:lbvh"], devices=["cuda:0"],
                        scaling={"sizes": [300], "accels": ["warp:lbvh", "wrt:sah"]})
    argv = ["bench", str(suite), "--devices", "cpu", "--rays", "primary", "--n-rays", "200", "--repeats", "1", "-q",
            "-o", str(tmp_path / "out")]
    assert main(argv) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "left out" in line]
    assert said == [
        "wrt: warning: suite.json's accelerator warp:lbvh left out on devices cpu: wp.Mesh has no lbvh builder on the "
        "CPU (Warp builds its sah tree there, which warp:sah measures)",
        "wrt: warning: suite.json's scaling accelerator warp:lbvh left out on devices cpu: wp.Mesh has no lbvh builder "
        "on the CPU (Warp builds its sah tree there, which warp:sah measures)"]
    rows = [json.loads(line) for line in (tmp_path / "out" / "rows.jsonl").read_text().splitlines()]
    assert sorted((r["scene"], r["accel"]) for r in rows) == [("sphere:200", "warp:sah"), ("sphere:300", "wrt:sah")]
    assert not any("error" in r for r in rows)


def test_a_suite_on_other_devices_with_accels_given_leaves_out_only_its_scaling_accelerators_they_cannot_build(
        tmp_path, capsys):
    """--accels replaces the suite's accelerators, not its scaling sweep's: wrt bench gpu --devices cpu --accels
    wrt:sah was refused for the gpu suite's scaling warp:lbvh, which the same run without --accels left out."""
    suite = write_suite(tmp_path, scenes=["sphere:200"], accels=["warp:lbvh"], devices=["cuda:0"],
                        scaling={"sizes": [300], "accels": ["warp:lbvh", "wrt:sah"]})
    argv = ["bench", str(suite), "--devices", "cpu", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "200",
            "--repeats", "1", "-q", "-o", str(tmp_path / "out")]
    assert main(argv) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "left out" in line]
    assert len(said) == 1 and "scaling accelerator warp:lbvh left out on devices cpu" in said[0]
    rows = [json.loads(line) for line in (tmp_path / "out" / "rows.jsonl").read_text().splitlines()]
    assert sorted((r["scene"], r["accel"]) for r in rows) == [("sphere:200", "wrt:sah"), ("sphere:300", "wrt:sah")]


def test_a_row_without_a_thread_count_in_the_output_folder_is_no_row_of_an_earlier_run(tmp_path):
    """A rows.jsonl line naming scene, accelerator, device and rays but no threads (not a row wrt wrote) stopped a
    run into that folder with KeyError: 'threads' while it looked for earlier rows the run would drop."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "rows.jsonl").write_text(json.dumps({"scene": "sphere:100", "accel": "wrt:sah", "device": "cpu",
                                                "rays": "shadow", "mrays": 1.0}) + "\n")
    argv = ["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
            "--n-rays", "200", "--repeats", "1", "-q", "-o", str(out)]
    assert main(argv) == 0
    rows = [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]
    assert [(r["scene"], r["accel"], "mrays" in r) for r in rows] == [("sphere:200", "wrt:sah", True)]


def test_an_asset_folder_without_a_manifest_warns_once_naming_the_folder_read_instead(tmp_path, monkeypatch):
    """WRT_ASSETS set to a folder without manifest.json (a typo) read ../shared/assets without a word where that
    held one: now one warning names both folders, however many assets are read."""
    shared = tmp_path / "shared" / "assets"
    shared.mkdir(parents=True)
    (shared / "manifest.json").write_text(json.dumps({"assets": [{"id": "chess_set", "path": "chess.usda"},
                                                                 {"id": "teapot", "path": "teapot.usda"}]}))
    monkeypatch.setenv("WRT_ASSETS", str(tmp_path / "asets"))
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")  # ../shared/assets: the folder read instead
    monkeypatch.setattr(bench_module, "_warned_asset_folders", set())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        paths = [bench_module.asset_path(asset) for asset in ("chess_set", "teapot", "chess_set")]
    assert [p.resolve() for p in paths] == [shared.resolve() / n for n in ("chess.usda", "teapot.usda", "chess.usda")]
    assert [str(w.message) for w in caught] == [
        f"WRT_ASSETS={tmp_path / 'asets'} holds no manifest.json; the shared assets are read from {paths[0].parent}"]


def test_an_asset_folder_without_a_manifest_is_named(tmp_path, monkeypatch):
    """WRT_ASSETS set to a folder without manifest.json said 'no shared asset folder found (set WRT_ASSETS)', as if
    it were not set: now each folder looked in is named, WRT_ASSETS's first."""
    monkeypatch.setenv("WRT_ASSETS", str(tmp_path / "asets"))
    monkeypatch.chdir(tmp_path)  # ../shared/assets from here holds nothing either
    monkeypatch.setattr(bench_module, "__file__", str(tmp_path / "a" / "wrt" / "bench.py"))  # nor beside the package
    with pytest.raises(FileNotFoundError) as error:
        bench_module.asset_path("chess_set")
    assert str(error.value) == (
        f"asset 'chess_set': no shared asset folder found: no manifest.json in {tmp_path / 'asets'} (WRT_ASSETS), "
        f"{tmp_path.parent / 'shared' / 'assets'}, {tmp_path / 'shared' / 'assets'}; set WRT_ASSETS to the folder "
        "that holds it")


def test_an_asset_folder_looked_in_twice_is_named_once(tmp_path, monkeypatch):
    """Run from the repository's root, ../shared/assets is the folder beside the package: the message named it
    twice."""
    monkeypatch.delenv("WRT_ASSETS", raising=False)
    (tmp_path / "repo").mkdir()
    monkeypatch.chdir(tmp_path / "repo")
    monkeypatch.setattr(bench_module, "__file__", str(tmp_path / "repo" / "wrt" / "bench.py"))
    with pytest.raises(FileNotFoundError) as error:
        bench_module.asset_path("chess_set")
    assert str(error.value) == (f"asset 'chess_set': no shared asset folder found: no manifest.json in "
                                f"{tmp_path / 'shared' / 'assets'}; set WRT_ASSETS to the folder that holds it")


def test_embree_alone_without_embreex_is_refused_naming_why_and_leaves_no_output_folder(tmp_path, monkeypatch,
                                                                                          capsys):
    """wrt bench --accels embree without the embreex package said 'the grid measures nothing: accels empty' (embree
    was given) and left the output folder it had just made behind, empty."""
    monkeypatch.setattr(bench_module, "_has_embree", lambda: False)
    out = tmp_path / "new" / "bench-out"
    assert main(["bench", "--scenes", "sphere:100", "--accels", "embree", "-o", str(out), "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(errors) == 1 and "argument --accels:" in errors[0] and "embreex" in errors[0], errors
    assert list(tmp_path.iterdir()) == []


def test_a_scene_file_whose_name_holds_a_comma_is_one_scene(tmp_path, monkeypatch):
    """--scenes is comma-separated: 'a,b.usda' was read as the scenes 'a' and 'b.usda', two error rows ('file not
    found'), and the file could not be measured at all. Pieces that name a file together are one scene."""
    from wrt.cli import build_parser

    monkeypatch.chdir(tmp_path)
    for name in ("a,b.usda", "c.usda"):
        Path(name).write_text("#usda 1.0\n")
    parse = lambda text: build_parser().parse_args(["bench", "--scenes", text]).scenes  # noqa: E731
    assert parse("a,b.usda") == ["a,b.usda"]
    assert parse("c.usda, a,b.usda,sphere:100") == ["c.usda", "a,b.usda", "sphere:100"]
    assert parse(f"{tmp_path / 'a,b.usda'},c.usda") == [str(tmp_path / "a,b.usda"), "c.usda"]
    assert parse("x.usda,y.usda") == ["x.usda", "y.usda"]  # no such files: the list as written
    with pytest.raises(SystemExit):  # a comma too many: refused (tests/test_cli_lists.py), not dropped
        parse("x.usda,y.usda,")
    Path("a").mkdir()  # a folder 'a' is no scene: it split the name, into 'a' and 'b.usda'
    assert parse("a,b.usda") == ["a,b.usda"]
    many = [f"sphere:{1000 + k}" for k in range(30)]  # joined, a name past 255 bytes: 'File name too long' raised
    assert parse(",".join(many)) == many
    Path("a").rmdir()
    Path("a").write_text("#usda 1.0\n")  # 'a' is a file too: the list is read as written
    assert parse("a,b.usda") == ["a", "b.usda"]


def test_two_names_of_one_cuda_device_are_measured_once(monkeypatch):
    """--devices cuda,cuda:0: both name the current CUDA device (cuda:0), whose rows are named 'cuda:0'; every group
    of the device was measured twice, each row twice in rows.jsonl and the table under one key."""
    import warp as wp

    class Gpu:  # what wp.get_device gives for both names on a machine with one GPU
        def __str__(self):
            return "cuda:0"

    gpu = Gpu()
    monkeypatch.setattr(bench_module, "resolve_device", lambda name: gpu if name.startswith("cuda") else
                        wp.get_device(name))
    devices, unavailable = bench_module._resolve_devices(["cuda", "cpu", "cuda:0"])
    assert [str(d) for d in devices] == ["cuda:0", "cpu"] and unavailable == {}


def test_two_names_of_one_missing_cuda_device_give_one_error_row(monkeypatch):
    """--devices cuda,cuda:0 on a machine without that GPU: both names got a group of error rows ('2 failed' for one
    device), where a machine that has it measures the device once, as 'cuda:0'. Still refused when no device named
    is there at all."""
    import warp as wp

    def no_gpu(name):  # what wp.get_device says on a machine without CUDA
        if name.startswith("cuda"):
            raise ValueError(f"unknown or unavailable device {name!r}; available devices: cpu")
        return wp.get_device(name)

    monkeypatch.setattr(bench_module, "resolve_device", no_gpu)
    devices, unavailable = bench_module._resolve_devices(["cuda", "cpu", "cuda:0"])
    assert [str(d) for d in devices] == ["cuda:0", "cpu"] and list(unavailable) == ["cuda:0"]
    with pytest.raises(bench_module.GridError, match="unavailable device 'cuda'"):
        bench_module._resolve_devices(["cuda", "cuda:0"])

@pytest.mark.parametrize("stop", [PermissionError(1, "Operation not permitted"), KeyboardInterrupt()])
def test_rows_rewritten_but_not_put_in_place_leave_no_temporary_file(tmp_path, monkeypatch, stop):
    """A rows.jsonl that could not be replaced (an immutable file), or a Ctrl-C as it was, left rows.jsonl.tmp
    beside it, in the folder of results, for good; the rows that were there stay."""
    jsonl = tmp_path / "rows.jsonl"
    jsonl.write_text('{"scene": "a"}\n')

    def fail(*args):
        raise stop

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(type(stop)):
        bench_module._write_rows(jsonl, [{"scene": "b"}])
    assert [p.name for p in tmp_path.iterdir()] == ["rows.jsonl"] and jsonl.read_text() == '{"scene": "a"}\n'


@pytest.mark.parametrize("suite", sorted(p.stem for p in bench_module.SUITES_DIR.glob("*.json")))
def test_every_group_of_a_shipped_suite_is_checked_against_the_reference(suite):
    """Each bundled suite runs the reference (warp:sah) beside the grid's and the scaling sweep's accelerators, so that
    every row it measures is checked ray by ray against wp.Mesh: the GPU suite's sweep ran without it, and every
    complete ``wrt bench gpu`` ended warning that 15 rows were not checked."""
    data = json.loads((bench_module.SUITES_DIR / f"{suite}.json").read_text())
    assert bench_module.REFERENCE in data["accels"]
    if "scaling" in data:
        assert bench_module.REFERENCE in data["scaling"].get("accels", data["accels"])


@pytest.mark.parametrize("name, content", [
    ("table.md", b"# My results\n\n| a | b |\n"),  # the user's own notes
    ("settings.json", b'{"editor.tabSize": 4}\n'),  # another tool's settings, -o . in a project folder
    ("mrays.png", None),  # an image wrt did not draw
    ("scaling.png", b"not even a PNG"),
    ("rows.jsonl", b'{"id": 1, "label": "cat"}\n{"id": 2, "label": "dog"}\n'),  # a data set of the user's
])
def test_a_file_of_the_users_named_as_a_bench_output_is_refused_and_kept(tmp_path, monkeypatch, capsys, name, content):
    """-o DIR replaced the user's own table.md, settings.json or plot-named files in DIR without a word; now the run
    stops before loading anything, naming the file, which is left as it was."""
    from PIL import Image

    path = tmp_path / name
    if content is None:
        Image.new("RGB", (4, 4), (200, 10, 10)).save(path)
    else:
        path.write_bytes(content)
    before = path.read_bytes()
    monkeypatch.setattr(bench_module, "resolve_scene", lambda name: pytest.fail("a scene was loaded"))
    with pytest.raises(ValueError, match=f"{re.escape(repr(str(path)))} was not written by wrt bench"):
        run_grid(small_grid(), tmp_path, progress=False)
    assert main(["bench", "--scenes", "sphere:2000", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "100",
                 "-q", "-o", str(tmp_path)]) == 2
    assert "was not written by wrt bench" in capsys.readouterr().err
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # no rows.jsonl either


def test_a_bench_folder_of_an_earlier_run_is_written_over(tmp_path):
    """The files an earlier run wrote (table, settings, marked plots) and empty files are the bench's to replace."""
    run_grid(small_grid(), tmp_path, progress=False)
    bench_module.plot(sweep_rows(), tmp_path)  # every plot, marked
    (tmp_path / "table.md").write_text((tmp_path / "table.md").read_text() + "\nmy note under the table\n")
    (tmp_path / "scaling.png").write_bytes(b"")
    rows = run_grid(small_grid(), tmp_path, progress=False)
    assert len(rows) == 1 and "error" not in rows[0]
    assert "my note" not in (tmp_path / "table.md").read_text()


@pytest.mark.parametrize("text", [
    '{"scene": "sphere:2000", "accel": "wrt:sah", "dev',  # the first row, cut short by a stopped run
    '{"scene": "no.usda", "accel": "*", "device": "cpu", "rays": "primary", "threads": null, "error": "gone"}\n',
])
def test_a_rows_file_of_a_stopped_or_failed_bench_run_is_the_benchs_to_replace(tmp_path, text):
    """rows.jsonl is refused where it holds no bench rows (a user's file of that name was replaced); a bench run's
    first row cut short, or its error rows, are still the bench's."""
    (tmp_path / "rows.jsonl").write_text(text)
    rows = run_grid(small_grid(), tmp_path, progress=False)
    assert [json.loads(line) for line in (tmp_path / "rows.jsonl").open()] == json.loads(json.dumps(rows))


def test_a_long_table_of_scenes_named_in_other_scripts_is_the_benchs_to_replace(tmp_path):
    """A table.md of more than 64 KiB whose first 64 KiB end inside a multi-byte character (a scene named in
    Chinese, Greek, ...) was taken for the user's file, 'not written by wrt bench', and the run refused: only its
    start was read, then decoded as a whole. The oracle: the table is markdown_table's text, written as a run does."""
    rows = [dict(sweep_rows()[0], scene=f"\u573a\u666f_{i}.usda", sweep=False) for i in range(600)]
    for pad in range(200):  # a name a byte longer moves the cut, until it lands inside a 3-byte character
        rows[0]["scene"] = "x" * pad + "\u573a\u666f.usda"
        data = bench_module.markdown_table(rows).encode("utf-8")
        if len(data) > 64 * 1024 and 0x80 <= data[64 * 1024] < 0xC0:  # a continuation byte: the cut splits a character
            break
    else:
        pytest.fail("no table whose first 64 KiB end inside a character")
    (tmp_path / "table.md").write_bytes(data)
    rows = run_grid(small_grid(), tmp_path, progress=False)
    assert len(rows) == 1 and "error" not in rows[0]
    assert "\u573a" not in (tmp_path / "table.md").read_text(encoding="utf-8")  # replaced by this run's table


def test_a_bench_folder_of_a_wrt_from_before_plots_were_marked_is_written_over(tmp_path):
    """wrt bench before 2026-11-24 (82f30896) saved its plots unmarked (``fig.savefig(path, dpi=110)``): the next
    run into that folder (bench-out, the default) was refused, 'mrays.png was not written by wrt bench'. Such a plot
    beside the folder's bench table is the bench's; the same plot beside no bench table is still the user's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def old_plot(path):  # as the plots of that version were saved
        fig, ax = plt.subplots()
        ax.plot([1, 2], [3, 4])
        fig.savefig(path, dpi=110)
        plt.close(fig)

    run_grid(small_grid(), tmp_path, progress=False)  # its table.md, as every version wrote it
    old_plot(tmp_path / "mrays.png")
    assert not bench_module.written_by_wrt(tmp_path / "mrays.png")
    rows = run_grid(small_grid(), tmp_path, progress=False)
    assert len(rows) == 1 and "error" not in rows[0]
    assert bench_module.written_by_wrt(tmp_path / "mrays.png")  # this run's plot in its place
    alone = tmp_path / "alone"
    alone.mkdir()
    old_plot(alone / "mrays.png")
    with pytest.raises(ValueError, match="mrays.png' was not written by wrt bench"):
        run_grid(small_grid(), alone, progress=False)


def test_scenes_named_are_all_that_is_measured_not_the_suites_scaling_sweep(tmp_path, capsys):
    """wrt bench cpu --scenes x measured the suite's scaling sweep too (five spheres up to 1e7 triangles in the cpu
    suite), where the user named the scenes wanted. A resume of a run with the sweep is not refused for the sweep's
    ray count either, and its sweep rows stay for a later resume of the whole suite."""
    suite = write_suite(tmp_path, scenes=["sphere:200"], rays=["primary"], n_rays=200, repeats=1,
                        scaling={"sizes": [300], "accels": ["wrt:sah"], "n_rays": 100})
    out = tmp_path / "out"

    def rows() -> list:
        return sorted((r["scene"], bool(r.get("sweep"))) for r in map(json.loads, (out / "rows.jsonl").open()))

    assert main(["bench", str(suite), "-q", "-o", str(out)]) == 0  # the suite alone: its sweep is measured
    assert rows() == [("sphere:200", False), ("sphere:300", True)]
    assert main(["bench", str(suite), "--scenes", "sphere:250", "-q", "-o", str(tmp_path / "named")]) == 0
    named = [json.loads(line) for line in (tmp_path / "named" / "rows.jsonl").open()]
    assert [(r["scene"], r.get("sweep")) for r in named] == [("sphere:250", None)]
    capsys.readouterr()
    assert main(["bench", str(suite), "--scenes", "sphere:250", "--resume", "-q", "-o", str(out)]) == 0
    assert "1 row measured, 0 resumed, 0 failed, 2 rows of an earlier run kept" in capsys.readouterr().err
    assert rows() == [("sphere:200", False), ("sphere:250", False), ("sphere:300", True)]
    assert main(["bench", str(suite), "--resume", "-q", "-o", str(out)]) == 0  # the whole suite again: all kept
    assert "0 rows measured, 2 resumed" in capsys.readouterr().err


def test_a_whole_suite_resume_of_a_run_of_scenes_named_is_not_refused_for_the_sweep_it_never_measured(tmp_path,
                                                                                                       capsys):
    """wrt bench SUITE --scenes x -o out, then wrt bench SUITE -o out --resume (the rest of the suite) was refused:
    'the suite's scaling n_rays 200 -> 100', as the first run, measuring no sweep, recorded the sweep's ray count as
    --n-rays'. The rows on disk (no sweep row) are the oracle: nothing was measured with the sweep's count. A
    resume of real sweep rows with another sweep count is still refused."""
    suite = write_suite(tmp_path, scenes=["sphere:200"], rays=["primary"], n_rays=200, repeats=1,
                        scaling={"sizes": [300], "accels": ["wrt:sah"], "n_rays": 100})
    out = tmp_path / "out"

    def rows() -> list:
        return sorted((r["scene"], bool(r.get("sweep"))) for r in map(json.loads, (out / "rows.jsonl").open()))

    assert main(["bench", str(suite), "--scenes", "sphere:250", "-q", "-o", str(out)]) == 0
    assert rows() == [("sphere:250", False)]  # no sweep row: the sweep's ray count measured nothing
    capsys.readouterr()
    assert main(["bench", str(suite), "--resume", "-q", "-o", str(out)]) == 0, capsys.readouterr().err
    assert "2 rows measured, 0 resumed, 0 failed, 1 row of an earlier run kept" in capsys.readouterr().err
    assert rows() == [("sphere:200", False), ("sphere:250", False), ("sphere:300", True)]
    assert json.loads((out / "settings.json").read_text())["scaling_n_rays"] == 100
    other = write_suite(tmp_path, scenes=["sphere:200"], rays=["primary"], n_rays=200, repeats=1,
                        scaling={"sizes": [300], "accels": ["wrt:sah"], "n_rays": 50})
    assert main(["bench", str(other), "--resume", "-q", "-o", str(out)]) == 2  # sweep rows of 100 rays are there
    assert "the suite's scaling n_rays 100 -> 50" in capsys.readouterr().err


TWO_TRIANGLES = """#usda 1.0
def Mesh "Quad"
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
}
"""


def test_relative_scene_paths_of_a_suite_are_read_from_its_folder(tmp_path, monkeypatch):
    """A suite's relative scene paths were read from the current folder: a suite beside its scenes ran only from
    that folder, elsewhere each scene was an error row. They are read from the suite's folder now; a path that only
    the current folder holds is still read from there, with a warning; absolute paths and scene kinds stay."""
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "quad.usda").write_text(TWO_TRIANGLES)
    (tmp_path / "bench").mkdir()
    (tmp_path / "work" / "deep").mkdir(parents=True)  # where ../scenes is no folder
    absolute = tmp_path / "scenes" / "abs.usda"
    absolute.write_text(TWO_TRIANGLES)
    suite = tmp_path / "bench" / "suite.json"
    suite.write_text(json.dumps({"scenes": ["../scenes/quad.usda", str(absolute), "sphere:300"],
                                 "accels": ["wrt:sah"], "rays": ["primary"], "n_rays": 200, "repeats": 1}))
    monkeypatch.chdir(tmp_path / "work" / "deep")
    grid = Grid.from_suite(str(suite))
    assert Path(grid.scenes[0]).resolve() == (tmp_path / "scenes" / "quad.usda").resolve()
    assert grid.scenes[1:] == [str(absolute), "sphere:300"]
    rows = run_grid(grid, tmp_path / "out", progress=False)
    assert [(r.get("error"), r["triangles"]) for r in rows[:2]] == [(None, 2), (None, 2)]  # the quads on disk
    assert [r["scene"] for r in rows] == grid.scenes and "error" not in rows[2]
    # A suite written for the old rule: its path is found from the current folder only.
    monkeypatch.chdir(tmp_path)
    old = tmp_path / "bench" / "old.json"
    old.write_text(json.dumps({"scenes": ["scenes/quad.usda"], "accels": ["wrt:sah"]}))
    with pytest.warns(UserWarning, match=r"old.json: scene 'scenes/quad.usda' is not beside the suite .*current fo"):
        assert Grid.from_suite(str(old)).scenes == ["scenes/quad.usda"]
    # --scenes are the command line's: read from the current folder.
    assert Grid.from_suite(str(old), overrides={"scenes": ["scenes/quad.usda"]}).scenes == ["scenes/quad.usda"]


def test_a_suite_name_is_the_shipped_suite_beside_a_folder_of_that_name(tmp_path, monkeypatch):
    """'wrt bench cpu' run beside a folder named cpu (an earlier 'wrt bench --quick -o cpu') was refused as 'cpu: a
    directory, not a benchmark suite': a folder is no suite, so the name is the shipped suite's. The oracle: the
    shipped suite file read as JSON; a file of that name is still read as the suite it is."""
    monkeypatch.chdir(tmp_path)
    for name in ("quick", "cpu"):
        (tmp_path / name).mkdir()
        shipped = json.loads((bench_module.SUITES_DIR / f"{name}.json").read_text(encoding="utf-8"))
        grid = Grid.from_suite(name)
        assert grid.scenes == shipped["scenes"] and grid.accels == [bench_module.check_accel_spec(a)
                                                                    for a in shipped["accels"]], name
    (tmp_path / "mine").write_text(json.dumps({"scenes": ["sphere:300"], "accels": ["wrt:sah"]}))
    assert Grid.from_suite("mine").scenes == ["sphere:300"]


def test_a_suite_given_through_a_symbolic_link_reads_its_scenes_from_the_file_it_names(tmp_path, monkeypatch):
    """A suite linked into another folder (ln -s ~/bench/suite.json here.json) read its relative scene paths from the
    link's folder: its own scenes were missing there, or another file of that name was measured in their place.
    They are read from the folder of the file the link names, as the suite's author wrote them. The oracle: the file
    system's own reading of the path beside the real file (os.path.realpath)."""
    real = tmp_path / "real"
    (real / "scenes").mkdir(parents=True)
    (real / "bench").mkdir()
    (real / "scenes" / "quad.usda").write_text(TWO_TRIANGLES)
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "quad.usda").write_text(TWO_TRIANGLES.replace("-1, -1, 0", "-2, -2, 0"))  # beside the link
    suite = real / "bench" / "suite.json"
    suite.write_text(json.dumps({"scenes": ["../scenes/quad.usda"], "accels": ["wrt:sah"]}))
    (tmp_path / "links").mkdir()
    link = tmp_path / "links" / "suite.json"
    link.symlink_to(Path("..") / "real" / "bench" / "suite.json")  # a relative link, as ln -s makes them
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    expected = Path(os.path.realpath(real / "scenes" / "quad.usda"))
    for given in (link, Path("..") / "links" / "suite.json"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no 'not beside the suite' warning either
            scenes = Grid.from_suite(str(given)).scenes
        assert [Path(os.path.realpath(name)) for name in scenes] == [expected], scenes
    assert Grid.from_suite(str(suite)).scenes == [str(real / "bench" / "../scenes/quad.usda")]  # the file itself


def test_a_suite_scene_path_starting_with_a_tilde_is_in_the_home_folder(tmp_path, monkeypatch):
    """'~/models/quad.usda' in a suite was read as a folder named '~' beside the suite (an error row: no such file);
    a shell reads it in the home folder, as os.path.expanduser does (the oracle)."""
    home = tmp_path / "home"
    (home / "models").mkdir(parents=True)
    (home / "models" / "quad.usda").write_text(TWO_TRIANGLES)
    monkeypatch.setenv("HOME", str(home))
    (tmp_path / "bench").mkdir()
    suite = tmp_path / "bench" / "suite.json"
    suite.write_text(json.dumps({"scenes": ["~/models/quad.usda", "~nosuchuser1234/a.usda"], "accels": ["wrt:sah"]}))
    monkeypatch.chdir(tmp_path)
    scenes = Grid.from_suite(str(suite)).scenes
    assert scenes[0] == os.path.expanduser("~/models/quad.usda") == str(home / "models" / "quad.usda"), scenes
    assert scenes[1] == str(suite.parent / "~nosuchuser1234/a.usda")  # no such user: a name beside the suite
    assert bench_module.scene_file_problem(scenes[0]) is None


def test_the_shipped_suites_name_the_same_scenes_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for path in sorted(bench_module.SUITES_DIR.glob("*.json")):
        written = json.loads(path.read_text(encoding="utf-8"))["scenes"]
        assert Grid.from_suite(path.stem).scenes == written, path.name


def test_a_suite_and_an_asset_manifest_starting_with_a_byte_order_mark_are_read(tmp_path, monkeypatch):
    """A suite or manifest.json saved by a Windows editor (Notepad, PowerShell's Out-File) starts with the UTF-8 byte
    order mark: the suite was 'not a JSON suite (Unexpected UTF-8 BOM ...)', the manifest 'not a JSON manifest'. Each
    reads as the same file without it (the oracle)."""
    fields = {"scenes": ["sphere:300", "asset:quad"], "accels": ["wrt:sah"], "rays": ["primary"], "n_rays": 100}
    text = json.dumps(fields)
    (tmp_path / "plain.json").write_text(text, encoding="utf-8")
    (tmp_path / "marked.json").write_text(text, encoding="utf-8-sig")
    assert (tmp_path / "marked.json").read_bytes()[:3] == b"\xef\xbb\xbf"
    assert Grid.from_suite(str(tmp_path / "marked.json")) == Grid.from_suite(str(tmp_path / "plain.json"))
    manifest = json.dumps({"assets": [{"id": "quad", "path": "quad.usda"}]})
    for encoding in ("utf-8", "utf-8-sig"):
        (tmp_path / "manifest.json").write_text(manifest, encoding=encoding)
        monkeypatch.setenv("WRT_ASSETS", str(tmp_path))
        assert bench_module.asset_path("quad") == tmp_path / "quad.usda"
    latin = b'{"scenes": ["caf\xe9.usda"], "accels": ["wrt:sah"]}'  # Latin-1, as a non-UTF-8 editor saves it
    (tmp_path / "latin.json").write_bytes(latin)
    with pytest.raises(ValueError, match=rf"latin.json: not UTF-8 JSON text \(byte {latin.index(0xE9)} is no UTF-8\)"):
        Grid.from_suite(str(tmp_path / "latin.json"))


@pytest.mark.parametrize("written", ["1e3", "1000.0", "1000", "1E3"])
def test_a_suite_count_written_as_a_whole_float_is_taken_as_n_rays_1e3_is(tmp_path, written):
    """'"n_rays": 1e3' in a suite was refused ('got 1000.0': JSON reads it as a float) where '--n-rays 1e3' was taken,
    and '--n-rays 1000.0' was refused where the suite's 1000.0 was taken; both are the int the text writes,
    decimal.Decimal(written) being the oracle."""
    from decimal import Decimal

    from wrt.cli import build_parser

    suite = tmp_path / "suite.json"
    suite.write_text(f'{{"scenes": ["sphere:200"], "accels": ["wrt:sah"], "n_rays": {written}, "repeats": {written},'
                     f' "scaling": {{"sizes": [100], "accels": ["wrt:sah"], "n_rays": {written}}}}}')
    grid = Grid.from_suite(str(suite))
    expected = int(Decimal(written))
    for value in (grid.n_rays, grid.repeats, grid.scaling["n_rays"]):
        assert type(value) is int and value == expected, grid
    assert build_parser().parse_args(["bench", "--n-rays", written]).n_rays == expected  # '1000.0' was refused here


@pytest.mark.parametrize("key", ["n_rays", "repeats", "scaling.n_rays"])
def test_a_suite_count_with_a_fraction_is_still_refused_as_n_rays_1000_5_is(tmp_path, capsys, key):
    fields = {"scenes": ["sphere:200"], "accels": ["wrt:sah"], "scaling": {"sizes": [100], "accels": ["wrt:sah"]}}
    if key == "scaling.n_rays":
        fields["scaling"]["n_rays"] = 1000.5
    else:
        fields[key] = 1000.5
    suite = tmp_path / "suite.json"
    suite.write_text(json.dumps(fields))
    with pytest.raises(ValueError, match=rf"suite\.json: {re.escape(key)}: .*must be a positive integer, got 1000\.5"):
        Grid.from_suite(str(suite))
    with pytest.raises(SystemExit):
        main(["bench", "--n-rays", "1000.5"])
    assert "argument --n-rays: '1000.5' is not an integer" in capsys.readouterr().err


@pytest.mark.parametrize("written", ["3e0", "3.0", "3"])
def test_a_suite_thread_count_written_as_a_whole_float_is_taken_as_the_other_counts_are(tmp_path, written):
    """README takes a suite's count written '1e6' or '1000.0'; '"threads": [3.0]' was refused ('must be positive
    integers or 'all', got 3.0') where n_rays and repeats written so were taken. decimal.Decimal is the oracle; 2.5 is
    still refused, naming its entry."""
    from decimal import Decimal

    suite = tmp_path / "suite.json"
    suite.write_text(f'{{"scenes": ["sphere:200"], "accels": ["wrt:sah"], "threads": [1, {written}]}}')
    threads = Grid.from_suite(str(suite)).validated().threads
    assert threads == [1, int(Decimal(written))] and all(type(t) is int for t in threads)
    # --threads gives strings: '3.0' was refused ('must be positive integers') where the suite's 3.0 was taken
    threads = Grid.from_suite(str(suite), {"threads": ["1", written]}).validated().threads
    assert threads == [1, int(Decimal(written))] and all(type(t) is int for t in threads)
    suite.write_text('{"scenes": ["sphere:200"], "accels": ["wrt:sah"], "threads": [1, 2.5]}')
    with pytest.raises(ValueError, match=r"suite\.json: threads\[1\]: .*got 2\.5"):
        Grid.from_suite(str(suite)).validated()
