"""wrt bench batch runs cut short and resumed: what Ctrl-C says, which rows --resume counts as this run's, and scene
files named at the start rather than when the run reaches them."""

import json
import shlex

import wrt.bench as bench_module
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
