"""Paths given on the command line: ``~`` is the home folder in every option that takes one, as a shell reads it."""

import json
import os

import numpy as np
import pytest
from PIL import Image as PilImage

from wrt.cli import build_parser, main


@pytest.fixture
def home(tmp_path, monkeypatch):
    """A home folder of its own (``HOME``) and a current folder beside it, where no folder ``~`` must appear."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    return home


def test_a_render_writes_its_image_log_and_aovs_under_a_tilde_in_the_home_folder(home, tmp_path):
    """'--log=~/r.jsonl', a quoted '~/a.png' or a name from a script (no shell expands those) wrote into a folder
    named '~' in the current one; os.path.expanduser, with HOME set here, is the oracle."""
    argv = ["render", "-o", "~/a.png", "--log=~/r.jsonl", "--aov-dir=~/aovs", "--width", "8", "--height", "6", "-q"]
    assert main(argv) == 0
    with PilImage.open(home / "a.png") as png:
        assert png.size == (8, 6)
    assert np.load(home / "aovs" / "depth.npy").shape == (6, 8)
    (row,) = [json.loads(line) for line in (home / "r.jsonl").read_text().splitlines()]
    assert row["status"] == "ok" and row["output"] == str(home / "a.png"), row
    assert not (tmp_path / "work" / "~").exists()


def test_bench_reads_a_tilde_after_a_comma_in_scenes_and_in_its_output_folder(home, tmp_path, capsys):
    """After a comma ('--scenes a.usda,~/b.usda') no shell expands '~': the scene was looked for in a folder '~'."""
    argv = ["bench", "--scenes", "~/a.usda,~/b.usda", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
            "-q", "-o", "~/out"]
    assert main(argv) == 2  # neither scene is there: every row fails, naming the file looked for
    rows = [json.loads(line) for line in (home / "out" / "rows.jsonl").read_text().splitlines()]
    assert sorted(row["scene"] for row in rows) == [str(home / "a.usda"), str(home / "b.usda")], rows
    assert not (tmp_path / "work" / "~").exists()


@pytest.mark.parametrize("argv, key", [
    (["render", "~/s.usda"], "scene"),
    (["render", "--products", "~/products"], "products"),
    (["preview", "~/s.usda"], "scene"),
    (["preview", "-o", "~/p.png"], "output"),
    (["bvh-stats", "~/s.usda"], "scene"),
    (["bench", "~/suite.json"], "suite"),
])
def test_every_other_path_option_reads_a_tilde_as_the_home_folder(home, argv, key):
    value = getattr(build_parser().parse_args(argv), key)
    assert (value[0] if isinstance(value, list) else value) == os.path.join(home, argv[-1].removeprefix("~/"))
