"""wrt bench batch runs cut short and resumed: what Ctrl-C says, which rows --resume counts as this run's, and scene
files named at the start rather than when the run reaches them."""

import json
import os
import re
import shlex
import warnings
from pathlib import Path

import numpy as np
import pytest

import wrt.bench as bench_module
from wrt.bench import Grid, run_grid
from wrt.cli import main

TINY = ["--accels", "warp:sah,wrt:sah", "--devices", "cpu", "--rays", "primary", "--n-rays", "100", "--repeats", "1",
        "-q"]


def read_rows(out):
    return [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]


def test_ctrl_c_names_the_rows_measured_and_the_command_that_resumes_them(tmp_path, monkeypatch, capsys):
    """After Ctrl-C, wrt bench said only 'wrt: interrupted': not where the rows measured so far were, nor that
    --resume goes on from them. The command it prints now, run as printed, resumes the row and measures the rest."""
    out = tmp_path / "bench out"  # a space: the command printed must quote it
    args = ["bench", "--scenes", "sphere:100", *TINY, "-o", str(out)]
    original, calls = bench_module.time_runs, []

    def interrupted_at_the_second_row(run, repeats):
        calls.append(run)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return original(run, repeats)

    monkeypatch.setattr(bench_module, "time_runs", interrupted_at_the_second_row)
    assert main(args) == 130
    err = capsys.readouterr().err
    assert len(read_rows(out)) == 1
    assert str(out / "rows.jsonl") in err and str(out / "table.md") in err, err
    commands = [line[line.index("wrt bench"):] for line in err.splitlines() if "wrt bench" in line]
    assert len(commands) == 1, err
    words = shlex.split(commands[0])
    assert words[-1] == "--resume" and words[:2] == ["wrt", "bench"]

    monkeypatch.setattr(bench_module, "time_runs", original)
    assert main(words[1:]) == 0
    assert "wrt: 1 row measured, 1 resumed, 0 failed" in capsys.readouterr().err
    assert [row["accel"] for row in read_rows(out)] == ["warp:sah", "wrt:sah"]


def test_resume_does_not_count_rows_outside_its_grid_as_its_own(tmp_path, capsys):
    """--resume kept an earlier run's rows of scenes this run does not measure (right: rows.jsonl keeps them) but
    counted them as this run's 'resumed' rows and put them in its table unmarked; a run whose every row failed then
    exited 1 (some rows measured) where it exits 2 (none were)."""
    assert main(["bench", "--scenes", "sphere:100", *TINY, "-o", str(tmp_path)]) == 0
    earlier = read_rows(tmp_path)
    capsys.readouterr()
    assert main(["bench", "--scenes", "sphere:200", *TINY, "-o", str(tmp_path), "--resume"]) == 0
    summary = [line for line in capsys.readouterr().err.splitlines() if "results in" in line]
    assert len(summary) == 1 and summary[0].startswith("wrt: 2 rows measured, 0 resumed, 0 failed"), summary
    assert "2 rows of an earlier run" in summary[0], summary
    assert read_rows(tmp_path)[:2] == earlier  # kept in rows.jsonl, as documented
    table = (tmp_path / "table.md").read_text().splitlines()
    kept = [line for line in table if line.startswith("| sphere:100 ")]
    new = [line for line in table if line.startswith("| sphere:200 ")]
    assert len(kept) == 2 and len(new) == 2, table
    assert all("earlier run" in line for line in kept) and not any("earlier run" in line for line in new), table

    assert main(["bench", "--scenes", str(tmp_path / "no.usda"), *TINY, "-o", str(tmp_path), "--resume"]) == 2


def test_scene_files_that_cannot_load_are_named_before_the_first_scene_loads(tmp_path, monkeypatch):
    """A misspelt scene path was reported only when the batch reached it, maybe an hour in. Now every scene file that
    is missing, no file or not USD by its extension is named in one warning at the start; each still becomes an error
    row, as does a file that breaks only when loaded, and the other scenes are measured."""
    missing, obj, folder, broken = (tmp_path / name for name in ("missing.usda", "scene.obj", "dir.usda", "bad.usda"))
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    folder.mkdir()
    broken.write_text("#usda 1.0\ndef Mesh (\n")  # a USD file by its name, broken inside: found only when loaded
    scenes = ["sphere:100", str(missing), str(obj), str(folder), str(broken), "warp:nosuch.usd"]
    original, loads = bench_module.resolve_scene, []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")

        def recording(name):  # the warnings raised before this scene loaded
            loads.append([str(w.message) for w in caught])
            return original(name)

        monkeypatch.setattr(bench_module, "resolve_scene", recording)
        grid = Grid(scenes=scenes, accels=["warp:sah"], devices=["cpu"], rays=["primary"], n_rays=100, repeats=1)
        rows = run_grid(grid, tmp_path / "out", progress=False)
    named = [message for message in loads[0] if str(missing) in message]
    assert len(named) == 1, loads[0]
    for bad in (missing, obj, folder, "warp:nosuch.usd"):
        assert str(bad) in named[0], named[0]
    assert str(broken) not in named[0] and "sphere:100" not in named[0]
    failed = {row["scene"] for row in rows if "error" in row}
    assert failed == set(scenes[1:]), rows
    assert [row["scene"] for row in rows if "mrays" in row] == ["sphere:100"]


def test_ctrl_c_before_the_first_row_offers_no_resume_of_an_earlier_runs_rows(tmp_path, monkeypatch, capsys):
    """Ctrl-C while the first scene loaded, in a run with another --n-rays, named the earlier run's rows as 'the rows
    measured so far' and offered a --resume that refuses them (they were measured over other ray counts)."""
    assert main(["bench", "--scenes", "sphere:100", *TINY, "-o", str(tmp_path)]) == 0
    capsys.readouterr()

    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr(bench_module, "resolve_scene", interrupted)
    args = ["bench", "--scenes", "sphere:100", *TINY, "--n-rays", "200", "-o", str(tmp_path)]
    assert main(args) == 130
    err = capsys.readouterr().err
    assert "wrt: interrupted" in err and "--resume" not in err, err
    monkeypatch.undo()
    with pytest.raises(ValueError, match="other settings"):  # what the --resume it offered would have met
        run_grid(Grid(scenes=["sphere:100"], accels=["warp:sah"], rays=["primary"], n_rays=200, repeats=1), tmp_path,
                 resume=True, progress=False)


def test_resume_with_other_thread_counts_counts_the_earlier_rows_apart(tmp_path):
    """CPU rows of a thread count this run does not ask for are no rows of its grid: threads 1 rows resumed under
    --threads 2 were counted as this run's resumed rows, and a run without --resume dropped them without a warning."""
    grid = dict(scenes=["sphere:100"], accels=["warp:sah", "wrt:sah"], devices=["cpu"], rays=["primary"], n_rays=100,
                repeats=1)
    run_grid(Grid(**grid, threads=[1]), tmp_path, progress=False)
    rows = run_grid(Grid(**grid, threads=[2]), tmp_path, resume=True, progress=False)
    assert (rows.resumed, rows.earlier) == (0, 2)
    assert sorted(r["threads"] for r in rows) == [1, 1, 2, 2]
    with pytest.warns(UserWarning, match="2 rows of an earlier run measured what this run does not"):
        run_grid(Grid(**grid, threads=[1]), tmp_path, progress=False)  # the threads 2 rows, dropped


def test_resume_with_other_thread_counts_counts_earlier_sweep_rows_apart(tmp_path):
    """A CPU scaling sweep runs at each thread count: its rows of a thread count this run does not ask for are no
    rows of its grid either (they were counted as resumed, as scene rows were before)."""
    grid = dict(scenes=["sphere:100"], accels=["wrt:sah"], devices=["cpu"], rays=["primary"], n_rays=100,
                repeats=1, scaling={"sizes": [200], "accels": ["wrt:sah"]})
    first = run_grid(Grid(**grid, threads=[1]), tmp_path, progress=False)
    assert sum(1 for r in first if r.get("sweep")) == 1
    rows = run_grid(Grid(**grid, threads=[2]), tmp_path, resume=True, progress=False)
    assert (rows.resumed, rows.earlier) == (0, 2)


def test_resume_of_a_scene_that_now_fails_keeps_the_earlier_rows_outside_its_grid(tmp_path):
    """A group that now fails drops the resumed rows it would have measured again, but not the earlier run's rows of
    accelerators this run does not measure: they were dropped from rows.jsonl while the summary said they were kept
    ('0 rows measured, -1 resumed, 1 failed, 1 row of an earlier run kept')."""
    scene = tmp_path / "s.usda"
    scene.write_text('#usda 1.0\ndef Mesh "T"\n{\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n'
                     "    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n}\n")
    out = tmp_path / "out"
    common = ["--scenes", str(scene), "--devices", "cpu", "--rays", "primary", "--n-rays", "100", "--repeats", "1",
              "-q", "-o", str(out)]
    assert main(["bench", "--accels", "wrt:sah,warp:sah", *common]) == 0
    scene.write_text("not a usd file")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["bench", "--accels", "warp:sah", "--resume", *common]) == 2  # its one group failed
    rows = [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]
    assert sorted((r["accel"], "error" in r) for r in rows) == [("*", True), ("wrt:sah", False)]


def _recorded_plots(monkeypatch) -> dict:
    """The figures that wrt bench's plots are drawn on, by file name, as they are saved."""
    import matplotlib

    matplotlib.use("Agg")
    figures, save = {}, bench_module._save_plot

    def record(fig, path):
        figures[path.name] = fig
        save(fig, path)

    monkeypatch.setattr(bench_module, "_save_plot", record)
    return figures


def _hollow(artist) -> bool:
    """Whether a bar (a patch) or a scatter point (a collection) is drawn without a fill."""
    face = artist.get_facecolor()
    face = np.asarray(face, float).reshape(-1, 4)
    return len(face) == 0 or bool((face[:, 3] == 0).all())


def test_an_earlier_runs_rows_are_marked_in_the_plots_and_counted_apart_by_the_agreement_warnings(
        tmp_path, monkeypatch, capsys):
    """--resume keeps an earlier run's rows of scenes this run does not measure, and the table marks them '(earlier
    run)'; the plots drew them as this run's, and the agreement warnings counted them with this run's ('2 rows not
    checked'). Their bars and points are hollow now, with a legend entry, and the warnings say which rows are the
    earlier run's. Oracle: which scene each run measured (sphere:100 the earlier, sphere:200 this one)."""
    figures = _recorded_plots(monkeypatch)
    common = [*TINY[2:], "-o", str(tmp_path)]  # no warp:sah: every row is unchecked
    assert main(["bench", "--scenes", "sphere:100", "--accels", "wrt:sah,wrt:median", *common]) == 0
    rows = read_rows(tmp_path)
    for row in rows:  # the earlier run's wrt:median answered 3 rays otherwise than warp:sah
        if row["accel"] == "wrt:median":
            row.update(agreement=1 - 3 / row["n_rays"], disagreements=3)
    (tmp_path / "rows.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows))
    capsys.readouterr()
    assert main(["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", *common, "--resume"]) == 0
    err = capsys.readouterr().err
    unchecked = [line for line in err.splitlines() if "not checked against" in line]
    assert unchecked == ["wrt: warning: 2 rows not checked against warp:sah (it failed or was not run in their group); "
                         "1 of them is a row of an earlier run (kept by --resume; not in this grid)"], err
    differ = [line for line in err.splitlines() if "answered otherwise" in line]
    assert len(differ) == 1 and differ[0].startswith("wrt: warning: sphere:100 / wrt:median / cpu / primary: 3 of")
    assert differ[0].endswith("; a row of an earlier run (kept by --resume; not in this grid)"), differ

    ax = figures["mrays.png"].axes[0]
    groups = [label.get_text().split("\n")[0] for label in ax.get_xticklabels()]
    drawn = {(container.get_label(), groups[k]): _hollow(bar)
             for container in ax.containers for k, bar in enumerate(container) if bar.get_height() > 0}
    assert drawn == {("wrt:median x1", "sphere:100"): True, ("wrt:sah x1", "sphere:100"): True,
                     ("wrt:sah x1", "sphere:200"): False}
    legend = {text.get_text(): _hollow(handle) for text, handle in zip(ax.get_legend().get_texts(),
                                                                       ax.get_legend().legend_handles)}
    assert legend == {"wrt:median x1": False, "wrt:sah x1": False, bench_module.EARLIER_LABEL: True}

    ax = figures["build_vs_quality.png"].axes[0]
    points = {text.get_text(): _hollow(point) for text, point in zip(ax.texts, ax.collections, strict=True)}
    assert points == {"wrt:sah sphere:100 (earlier run)": True, "wrt:median sphere:100 (earlier run)": True,
                      "wrt:sah sphere:200": False}
    assert bench_module.EARLIER_LABEL in [text.get_text() for text in ax.get_legend().get_texts()]


def test_an_earlier_runs_scaling_sweep_is_a_line_of_its_own(tmp_path, monkeypatch):
    """A sweep resumed at another thread count (the earlier run's rows kept, outside this grid) was drawn in one line
    with this run's, whose points are those of the line's fewest threads: the plot showed the earlier run's sweep as
    this run's. Each is a line of its own now, the earlier one dashed with hollow points and named so."""
    figures = _recorded_plots(monkeypatch)
    grid = dict(scenes=["sphere:100"], accels=["wrt:sah"], devices=["cpu"], rays=["primary"], n_rays=100,
                repeats=1, scaling={"sizes": [200], "accels": ["wrt:sah"]})
    run_grid(Grid(**grid, threads=[1]), tmp_path, progress=False)
    rows = run_grid(Grid(**grid, threads=[2]), tmp_path, resume=True, progress=False)
    sweep = {r["threads"]: r for r in rows if r.get("sweep")}
    assert sorted(sweep) == [1, 2]
    build_axes = figures["scaling.png"].axes[0]
    lines = {re.split(r" (no )?slope", line.get_label())[0]: line for line in build_axes.get_lines()}
    assert sorted(lines) == ["wrt:sah", "wrt:sah x1 (earlier run)"], list(lines)
    assert list(lines["wrt:sah"].get_ydata()) == [sweep[2]["build_ms"]]
    assert list(lines["wrt:sah x1 (earlier run)"].get_ydata()) == [sweep[1]["build_ms"]]
    assert lines["wrt:sah x1 (earlier run)"].get_markerfacecolor() == "none"
    assert lines["wrt:sah"].get_markerfacecolor() != "none"


QUAD = """#usda 1.0
def Mesh "Quad"
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
}
"""


def test_a_resume_from_another_folder_finds_the_rows_of_a_suites_scenes(tmp_path, monkeypatch, capsys):
    """A suite's scene beside it is 'bench/quad.usda' run from tmp/ and 'quad.usda' run from bench/: a --resume from
    there took the row of 'bench/quad.usda', read from bench/ (no such file), for another scene's, measured the scene
    again and kept the earlier row as one outside its grid. Rows now record the folder their run started in (cwd), as
    a render log's do, and a relative scene path is read from there. The oracle: the file the row was measured on,
    the same path from either folder (os.path.samefile); a resume measures nothing and keeps the row as it was."""
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "quad.usda").write_text(QUAD)
    (tmp_path / "bench" / "suite.json").write_text(json.dumps(
        {"scenes": ["quad.usda"], "accels": ["wrt:sah"], "devices": ["cpu"], "rays": ["primary"], "n_rays": 100,
         "repeats": 1}))
    monkeypatch.chdir(tmp_path)
    assert main(["bench", "bench/suite.json", "-q", "-o", "out"]) == 0
    first = read_rows(tmp_path / "out")
    assert len(first) == 1 and os.path.samefile(first[0]["scene"], tmp_path / "bench" / "quad.usda"), first
    capsys.readouterr()
    monkeypatch.chdir(tmp_path / "bench")
    assert main(["bench", "suite.json", "-q", "-o", "../out", "--resume"]) == 0
    summary = [line for line in capsys.readouterr().err.splitlines() if "results in" in line]
    assert len(summary) == 1 and summary[0].startswith("wrt: 0 rows measured, 1 resumed, 0 failed"), summary
    again = read_rows(tmp_path / "out")
    assert len(again) == 1 and os.path.samefile(Path(again[0]["cwd"]) / again[0]["scene"],
                                                tmp_path / "bench" / "quad.usda"), again
    assert {k: v for k, v in again[0].items() if k not in ("scene", "cwd")} == \
        {k: v for k, v in first[0].items() if k not in ("scene", "cwd")}
    # And back: the row as this run named it (quad.usda from bench/) is found from tmp/ too.
    capsys.readouterr()
    monkeypatch.chdir(tmp_path)
    assert main(["bench", "bench/suite.json", "-q", "-o", "out", "--resume"]) == 0
    summary = [line for line in capsys.readouterr().err.splitlines() if "results in" in line]
    assert summary[0].startswith("wrt: 0 rows measured, 1 resumed, 0 failed"), summary


def test_a_resume_without_settings_json_measures_rows_of_other_repeats_again(tmp_path, capsys):
    """settings.json says the repeats of every row in rows.jsonl; without it (deleted, or rows.jsonl copied alone) a
    --resume with --repeats 1 kept a row timed over 3 launches as its own, and then wrote settings.json saying every
    row was timed over 1. Each row now records its repeats, and one of other repeats is measured again, named in the
    warning. The oracle: the repeats given to each run."""
    argv = ["bench", "--scenes", "sphere:100", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
            "--n-rays", "100", "-q", "-o", str(tmp_path)]
    assert main([*argv, "--repeats", "3"]) == 0
    first = read_rows(tmp_path)
    (tmp_path / "settings.json").unlink()
    capsys.readouterr()
    assert main([*argv, "--repeats", "1", "--resume"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert "wrt: warning: sphere:100 / cpu / primary: rows of the resumed run measured again, as repeats 3 -> 1" in err
    summary = [line for line in err if "results in" in line]
    assert summary[0].startswith("wrt: 1 row measured, 0 resumed, 0 failed"), summary
    assert [row["repeats"] for row in first] == [3] and [row["repeats"] for row in read_rows(tmp_path)] == [1]
    assert json.loads((tmp_path / "settings.json").read_text())["repeats"] == 1


def test_rows_written_before_repeats_were_recorded_resume_by_their_settings_json(tmp_path, capsys):
    """Rows of a run before rows recorded their repeats have none; their settings.json says the repeats of every row
    in the file. A --resume with those repeats measured each row again ('repeats None -> 3', 1 measured, 0 resumed).
    The oracle: the repeats settings.json was written with, the same as this run's."""
    argv = ["bench", "--scenes", "sphere:100", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
            "--n-rays", "100", "--repeats", "3", "-q", "-o", str(tmp_path)]
    assert main(argv) == 0
    old = [{k: v for k, v in row.items() if k not in ("repeats", "cwd")} for row in read_rows(tmp_path)]
    (tmp_path / "rows.jsonl").write_text("".join(json.dumps(row) + "\n" for row in old))
    assert json.loads((tmp_path / "settings.json").read_text())["repeats"] == 3
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    err = capsys.readouterr().err.splitlines()
    summary = [line for line in err if "results in" in line]
    assert summary[0].startswith("wrt: 0 rows measured, 1 resumed, 0 failed"), err


def bench_project_run(project: Path, monkeypatch) -> Path:
    """``project`` holding ``bench/quad.usda`` and ``bench/suite.json`` (one row), benchmarked from there into
    ``out`` (the current folder left there)."""
    (project / "bench").mkdir(parents=True)
    (project / "bench" / "quad.usda").write_text(QUAD)
    (project / "bench" / "suite.json").write_text(json.dumps(
        {"scenes": ["quad.usda"], "accels": ["wrt:sah"], "devices": ["cpu"], "rays": ["primary"], "n_rays": 100,
         "repeats": 1}))
    monkeypatch.chdir(project)
    assert main(["bench", "bench/suite.json", "-q", "-o", "out"]) == 0
    return project


def resumed_summary(capsys) -> list[str]:
    """The summary lines of ``wrt bench bench/suite.json -o out --resume`` run in the current folder."""
    capsys.readouterr()
    assert main(["bench", "bench/suite.json", "-q", "-o", "out", "--resume"]) == 0
    return [line for line in capsys.readouterr().err.splitlines() if "results in" in line]


def test_a_resume_in_a_moved_folder_finds_the_rows_of_its_scenes(tmp_path, monkeypatch, capsys):
    """Rows read relative scene paths from the folder their run started in (cwd); once that folder is gone (the
    project moved, proj/ renamed proj2/), none of them was found and every scene was measured again (1 measured, 0
    resumed), where rows written before cwd was recorded resumed, read from the current folder. The oracle: the
    same scene file and settings, so the same triangles and rays (the row's inputs hash), which the row keeps."""
    project = bench_project_run(tmp_path / "proj", monkeypatch)
    first = read_rows(project / "out")
    monkeypatch.chdir(tmp_path)
    project.rename(tmp_path / "proj2")
    monkeypatch.chdir(tmp_path / "proj2")
    summary = resumed_summary(capsys)
    assert summary[0].startswith("wrt: 0 rows measured, 1 resumed, 0 failed"), summary
    assert [row["inputs"] for row in read_rows(tmp_path / "proj2" / "out")] == [first[0]["inputs"]]


def test_a_resume_in_a_copied_folder_measures_its_own_scenes(tmp_path, monkeypatch, capsys):
    """proj/ copied to proj2/, its rows resumed there: a row's relative scene bench/quad.usda, read from proj/ where
    its run started, is another file than proj2's, yet it was spelt as this grid's scene, so the row counted as an
    earlier run's outside this grid and still stood for proj2's scene: '0 rows measured, 0 resumed', no row of it.
    The oracle: proj2/bench/quad.usda is a file no run measured, so this run measures it (1 measured)."""
    import shutil

    project = bench_project_run(tmp_path / "proj", monkeypatch)
    shutil.copytree(project, tmp_path / "proj2")
    monkeypatch.chdir(tmp_path / "proj2")
    summary = resumed_summary(capsys)
    assert summary[0].startswith("wrt: 1 row measured, 0 resumed, 0 failed"), summary
    rows = read_rows(tmp_path / "proj2" / "out")
    assert sorted(os.path.realpath(Path(row["cwd"]) / row["scene"]) for row in rows) == \
        sorted(os.path.realpath(p / "bench" / "quad.usda") for p in (project, tmp_path / "proj2")), rows
