"""``wrt render --resume`` of a batch of scenes and of ``--frames``, and the run fields of the log rows: what is
skipped, what is rendered again and why, and what the log says afterwards."""

import json
import os
from pathlib import Path

import pytest

import wrt
from wrt.cli import main

STAGE = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
SIZE = ["--width", "8", "--height", "6"]


def rows_of(log: Path) -> list[dict]:
    return [json.loads(line) for line in log.read_text().splitlines() if line.strip()]


@pytest.fixture
def batch(tmp_path):
    scenes = []
    for name in ("a.usda", "b.usda", "c.usda"):
        scenes.append(tmp_path / name)
        scenes[-1].write_text(STAGE)
    out = tmp_path / "out"
    return [*map(str, scenes), "-o", f"{out}/", *SIZE], out


def test_resume_skips_the_finished_scenes_and_logs_them_as_skipped(batch, capsys):
    argv, out = batch
    assert main(["render", *argv]) == 0
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.png")}
    capsys.readouterr()
    assert main(["render", *argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert err.count("--resume: skipped") == 3 and "0 of 3 scenes rendered, 3 skipped" in err, err
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.png")} == stamps  # not written again
    rows = rows_of(out / "render-log.jsonl")
    first, second = rows[:3], rows[3:]
    assert len({r["run"] for r in first}) == 1 and len({r["run"] for r in second}) == 1
    assert first[0]["run"] != second[0]["run"] and all("run_started_at" in r for r in rows)
    assert [r["status"] for r in second] == ["skipped"] * 3
    assert all(r["resumed_from"] == first[0]["run"] for r in second)
    capsys.readouterr()
    assert main(["render", *argv, "--resume"]) == 0  # skipped rows resume as the rows they copy
    assert "3 skipped" in capsys.readouterr().err
    assert all(r["resumed_from"] == first[0]["run"] for r in rows_of(out / "render-log.jsonl")[6:])


def test_resume_renders_again_what_changed_failed_or_went_missing(batch, tmp_path, capsys):
    argv, out = batch
    (tmp_path / "c.usda").write_text("#usda 1.0\ndef Mesh (\n")  # broken: an error row
    assert main(["render", *argv]) == 1
    (tmp_path / "c.usda").write_text(STAGE)
    (out / "b.png").unlink()
    capsys.readouterr()
    assert main(["render", *argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "skipped a.usda" in err and "rendering b.usda again" in err and "rendering c.usda again" in err, err
    assert "2 of 3 scenes rendered, 1 skipped" in err
    assert [r["status"] for r in rows_of(out / "render-log.jsonl")[3:]] == ["skipped", "ok", "ok"]
    capsys.readouterr()
    assert main(["render", *argv, "--resume", "--spp", "2"]) == 0  # another option: every image again
    err = capsys.readouterr().err
    assert "3 of 3 scenes rendered, 0 skipped" in err and "--spp 1 -> 2" in err, err


def test_resume_renders_an_image_written_again_since_its_row_or_whose_scene_changed(batch, tmp_path, capsys):
    argv, out = batch
    assert main(["render", *argv]) == 0
    # A quick look at a without a log (--spp 1 again here, but nothing says so) replaces its image.
    assert main(["render", str(tmp_path / "a.usda"), "-o", str(out / "a.png"), *SIZE, "-q"]) == 0
    os.utime(out / "a.png", ns=(1, 1))
    os.utime(tmp_path / "b.usda", ns=(2, 2))  # an edited scene
    capsys.readouterr()
    assert main(["render", *argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "rendering a.usda again" in err and "written again" in err, err
    assert "rendering b.usda again: b.usda changed" in err and "skipped c.usda" in err, err


def test_resume_renders_the_scene_an_interrupted_batch_cut_short(batch, tmp_path, monkeypatch, capsys, ctrl_c_after):
    argv, out = batch
    render = wrt.Renderer.render
    ctrl_c_after("b.usda")
    assert main(["render", *argv]) == 130
    assert (out / "b.png").exists()  # the samples so far
    monkeypatch.setattr(wrt.Renderer, "render", render)
    capsys.readouterr()
    assert main(["render", *argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "skipped a.usda" in err and "rendering b.usda again: its last row" in err and "says interrupted" in err
    assert [(Path(r["scene"]).name, r["status"]) for r in rows_of(out / "render-log.jsonl")[2:]] == [
        ("a.usda", "skipped"), ("b.usda", "ok"), ("c.usda", "ok")]


def test_resume_renders_again_the_rows_of_an_older_wrt_and_reads_past_a_cut_row(batch, capsys):
    argv, out = batch
    out.mkdir()
    old = [{"scene": argv[i], "output": str(out / f"{n}.png"), "status": "ok", "seconds": 0.1}
           for i, n in enumerate("abc")]
    (out / "render-log.jsonl").write_text("".join(json.dumps(r) + "\n" for r in old) + '{"scene": "a.us')
    for name in "abc":
        (out / f"{name}.png").write_bytes(b"old")
    assert main(["render", *argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "3 of 3 scenes rendered" in err and "recorded no options" in err, err
    lines = (out / "render-log.jsonl").read_text().splitlines()
    assert lines[3] == '{"scene": "a.us'  # the new rows start on a line of their own
    assert [json.loads(line)["status"] for line in lines[4:]] == ["ok"] * 3


@pytest.mark.parametrize("text, line", [("not a log\n", 1), ('{"a": 1}\n[1, 2]\n', 2)])
def test_resume_refuses_a_log_that_is_no_log_naming_the_option(batch, capsys, text, line):
    argv, out = batch
    out.mkdir()
    (out / "notes.txt").write_text(text)
    assert main(["render", *argv, "--resume", "--log", str(out / "notes.txt")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"wrt: error: --log {out / 'notes.txt'}: line {line} is not a JSON row"), err
    assert not list(out.glob("*.png")) and (out / "notes.txt").read_text() == text


def test_resume_of_one_scene_needs_a_log(tmp_path, capsys):
    (tmp_path / "a.usda").write_text(STAGE)
    assert main(["render", str(tmp_path / "a.usda"), "-o", str(tmp_path / "a.png"), "--resume"]) == 2
    (line,) = [x for x in capsys.readouterr().err.splitlines() if x.startswith("wrt:")]
    assert "--resume reads the log of an earlier run; give it with --log FILE" in line
    assert not (tmp_path / "a.png").exists()


def test_frames_resume_from_the_log_skips_finished_frames_only(tmp_path, capsys):
    scene = tmp_path / "moving.usda"
    scene.write_text('#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 3\n)\ndef Xform "X"\n{\n'
                     '    double3 xformOp:translate.timeSamples = {1: (0, 0, 0), 3: (0.2, 0, 0)}\n'
                     '    uniform token[] xformOpOrder = ["xformOp:translate"]\n' + STAGE.split("\n", 1)[1].replace(
                         "def Mesh", "    def Mesh") + "}\n")
    log, pattern = tmp_path / "frames.jsonl", str(tmp_path / "f_#.png")
    argv = ["render", str(scene), "--frames", "1:3", "-o", pattern, "--log", str(log), *SIZE]
    assert main(argv) == 0
    first = rows_of(log)
    assert [(r["frame"], r["status"]) for r in first] == [(1, "ok"), (2, "ok"), (3, "ok")]
    assert all(r["scene"] == str(scene) and r["spp"] == 1 and r["run"] == first[0]["run"] for r in first)
    (tmp_path / "f_2.png").unlink()
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "skipped 2 of 3 frames" in err and "rendering frame 2 again: " in err and "rendered 1 frame" in err, err
    second = rows_of(log)[3:]
    assert sorted((r["frame"], r["status"]) for r in second) == [(1, "skipped"), (2, "ok"), (3, "skipped")]
    assert len({r["run"] for r in second}) == 1 and second[0]["run"] != first[0]["run"]
    capsys.readouterr()
    assert main([*argv, "--resume", "--seed", "1"]) == 0
    err = capsys.readouterr().err
    assert "rendering frame 1, frame 2, frame 3 again: options changed" in err and "rendered 3 frames" in err, err


def test_resume_from_another_folder_finds_the_files_a_run_named_by_relative_paths(tmp_path, monkeypatch, capsys):
    """Rows hold the paths as typed: a batch run with relative paths and resumed from another folder (the same files
    named from there) matched no row and rendered everything again. Relative paths are taken from the folder the
    row's run started in (``cwd``)."""
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(STAGE)
    monkeypatch.chdir(tmp_path)
    assert main(["render", "a.usda", "b.usda", "-o", "out/", *SIZE]) == 0
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    capsys.readouterr()
    assert main(["render", "../a.usda", "../b.usda", "-o", "../out/", *SIZE, "--resume"]) == 0
    assert "0 of 2 scenes rendered, 2 skipped" in capsys.readouterr().err
    assert [r["cwd"] for r in rows_of(tmp_path / "out" / "render-log.jsonl")] == [str(tmp_path)] * 2 + [
        str(tmp_path / "sub")] * 2


def test_resume_of_a_folder_per_scene_batch_reads_the_log_an_earlier_wrt_wrote_in_the_first_folder(tmp_path,
                                                                                                    capsys):
    """wrt before b7c6abd wrote the log of '-o out/{stem}/' into out/a/; a resume looked in out/ only, found nothing
    and rendered every scene again without a word. It now reads (and extends) the older log, saying so; where there
    is no log at all, it says where it looked."""
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(STAGE)
    argv = ["render", str(tmp_path / "a.usda"), str(tmp_path / "b.usda"), "-o", f"{tmp_path}/out/{{stem}}/", *SIZE]
    out = tmp_path / "out"
    assert main(argv) == 0
    older = out / "a" / "render-log.jsonl"
    (out / "render-log.jsonl").rename(older)  # where the earlier wrt left it
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob("*.png")}
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert f"reading and extending {older}" in err and "0 of 2 scenes rendered, 2 skipped" in err, err
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*.png")} == stamps  # not written again
    assert [r["status"] for r in rows_of(older)] == ["ok", "ok", "skipped", "skipped"]
    older.unlink()
    assert main([*argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert f"--resume: no log at {out / 'render-log.jsonl'}" in err and "2 of 2 scenes rendered" in err, err


def test_resume_from_another_folder_compares_the_aov_folder_named_not_its_spelling(tmp_path, monkeypatch, capsys):
    """--aov-dir was compared as typed: resumed from another folder, 'aovs' (another folder from there) skipped the
    scenes, their AOV files never written where asked, and '../first/aovs' (the same folder) rendered them again
    ('options changed: --aov-dir aovs -> ../first/aovs'). The skipped rows also carried the AOV files as the first
    run spelt them, relative to its folder, so the next resume found them missing. The oracle: the files on disk."""
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(STAGE)
    for folder in ("first", "second"):
        (tmp_path / folder).mkdir()
    argv = ["render", "../a.usda", "../b.usda", "-o", "../out/", *SIZE]
    monkeypatch.chdir(tmp_path / "first")
    assert main([*argv, "--aov-dir", "aovs"]) == 0
    written = sorted(p.relative_to(tmp_path / "first") for p in (tmp_path / "first" / "aovs").rglob("*.npy"))
    assert written and {p.parts[1] for p in written} == {"a", "b"}, written
    monkeypatch.chdir(tmp_path / "second")
    for _ in range(2):  # the same folder, named from here: skipped, and so by the next resume, from its rows
        capsys.readouterr()
        assert main([*argv, "--aov-dir", "../first/aovs", "--resume"]) == 0
        assert "0 of 2 scenes rendered, 2 skipped" in capsys.readouterr().err
    capsys.readouterr()
    assert main([*argv, "--aov-dir", "aovs", "--resume"]) == 0  # another folder: rendered, its AOVs written there
    err = capsys.readouterr().err
    assert "2 of 2 scenes rendered, 0 skipped" in err, err
    assert f"--aov-dir {tmp_path / 'first' / 'aovs'} -> {tmp_path / 'second' / 'aovs'}" in err, err
    assert sorted(p.relative_to(tmp_path / "second") for p in (tmp_path / "second" / "aovs").rglob("*.npy")) == written


def test_a_frames_resume_whose_one_frame_left_fails_exits_as_a_batch_resume_does(tmp_path, capsys):
    """A --frames --resume that skips the finished frames and fails at the one left exited 2 ('none rendered', bad
    input), where a batch resume that skips the finished scenes and fails at the one left exits 1: the batch counts
    the scenes it skipped among those asked, the frames run counted only the frames it drew. The oracle: the batch's
    status for the same case (README: 1 where some failed, 2 where none could be rendered)."""
    from pxr import Usd, UsdGeom

    good, bad = tmp_path / "good.usda", tmp_path / "bad.usda"
    good.write_text(STAGE)
    bad.write_text(STAGE.replace("(1, 0, 0)", "(nan, 0, 0)"))
    batch = ["render", str(good), str(bad), "-o", f"{tmp_path / 'out'}/", *SIZE, "-q"]
    assert main(batch) == 1
    assert main([*batch, "--resume"]) == 1  # good.usda skipped, bad.usda failed again
    capsys.readouterr()
    path = tmp_path / "shot.usda"
    stage = Usd.Stage.CreateNew(str(path))
    points = UsdGeom.Mesh.Define(stage, "/M").CreatePointsAttr()
    for time, x in ((1, 1.0), (2, float("nan"))):
        points.Set([(0, 0, 0), (x, 0, 0), (0, 1, 0)], time)
    UsdGeom.Mesh(stage.GetPrimAtPath("/M")).CreateFaceVertexCountsAttr([3])
    UsdGeom.Mesh(stage.GetPrimAtPath("/M")).CreateFaceVertexIndicesAttr([0, 1, 2])
    stage.Save()
    frames = ["render", str(path), "--frames", "1:2", "-o", str(tmp_path / "f_#.npy"), "--log",
              str(tmp_path / "log.jsonl"), *SIZE, "-q"]
    assert main(frames) == 1
    assert main([*frames, "--resume"]) == 1  # frame 1 skipped, frame 2 failed again
    assert "wrt: 1 of 2 frames failed" in capsys.readouterr().err.splitlines()
