"""Output names longer than the file system takes are refused before any scene is loaded, also where the output
folder does not exist yet (the write failed after the render: the file system can say 'file name too long' only once
the folder is there). Oracle: the file system itself, creating a file of that name."""

import errno
import os

import pytest

from wrt.cli import main

STAGE = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
SIZE = ["--width", "8", "--height", "6"]


def too_long(folder, name: str) -> bool:
    """Whether the file system refuses a file ``name`` in ``folder``, as it says when one is created."""
    try:
        (folder / name).touch()
    except OSError as e:
        return e.errno == errno.ENAMETOOLONG
    (folder / name).unlink()
    return False


@pytest.fixture
def scenes(tmp_path):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    short, long = tmp_path / "a.usda", tmp_path / f"{'s' * (limit - len('.usda'))}.usda"
    for scene in (short, long):
        scene.write_text(STAGE)
    return short, long, limit


def test_batch_with_a_name_too_long_is_refused_before_any_render(tmp_path, scenes, capsys):
    short, long, _ = scenes
    out = tmp_path / "out"  # not there yet
    assert too_long(tmp_path, f"{long.stem}_rendered.png") and not too_long(tmp_path, f"{long.stem}.png")
    assert main(["render", str(short), str(long), "-o", f"{out}/{{stem}}_rendered.png", *SIZE]) == 2
    err = capsys.readouterr().err
    assert "wrt: loaded" not in err and not out.exists(), err
    assert f"wrt: error: {out / long.stem}_rendered.png: file name too long" in err, err


def test_aov_preview_name_too_long_is_refused_before_the_render(tmp_path, scenes, capsys):
    _, long, _ = scenes
    out = tmp_path / "out"
    assert too_long(tmp_path, f"{long.stem}.depth.png")
    assert main(["render", str(long), "-o", f"{out}/", "--aov", "depth", *SIZE]) == 2
    err = capsys.readouterr().err
    assert "wrt: loaded" not in err and f"wrt: error: {out / long.stem}.depth.png: file name too long" in err, err
    assert main(["render", str(long), "-o", f"{out}/", *SIZE]) == 0  # its image's name fits: written
    assert [p.name for p in out.iterdir()] == [f"{long.stem}.png"]
