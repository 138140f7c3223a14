"""Writes that fail as on a full disk: every write wrt makes under a temporary name is sent to ``/dev/full``, whose
writes fail with ``ENOSPC`` as a full file system's do (Linux null(4)); and a read-only file system (last test).
The error names the file asked for and says why; no file is left under the final name nor under a temporary one;
a batch logs each failed scene."""

import builtins
import errno
import json
import os
from pathlib import Path

import numpy as np
import pytest

import wrt
from wrt.cli import main

pytestmark = pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")

STAGE = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
         '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
SIZE = ["--width", "8", "--height", "6"]


@pytest.fixture
def full_disk(monkeypatch):
    """Opening a temporary file of ``write_atomically`` (``.NAME.partial.EXT``) for writing opens ``/dev/full``."""
    real_open = builtins.open

    def open_full(file, mode="r", *args, **kwargs):
        if isinstance(file, (str, os.PathLike)) and ".partial" in os.fspath(file) and any(c in mode for c in "wa+"):
            return real_open("/dev/full", mode, *args, **kwargs)
        return real_open(file, mode, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", open_full)


def files_in(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.is_file())


@pytest.mark.parametrize("name", ["x.npy", "x.png"])
def test_image_save_on_a_full_disk_names_the_file(tmp_path, full_disk, name):
    image = wrt.Image(rgb=np.random.default_rng(123).uniform(0, 1, (40, 50, 3)).astype(np.float32))
    with pytest.raises(OSError) as caught:
        image.save(tmp_path / name)
    # Both said '[Errno 28] No space left on device', naming no file.
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(tmp_path / name), caught.value
    assert files_in(tmp_path) == []


@pytest.fixture
def file_size_limit():
    """``file_size_limit(n)``: files of this process cannot grow past ``n`` bytes (RLIMIT_FSIZE, writes past it fail
    with EFBIG, SIGXFSZ ignored), as a disk that fills in the middle of a write: the first bytes are written."""
    resource = pytest.importorskip("resource")
    import signal

    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    yield lambda size: resource.setrlimit(resource.RLIMIT_FSIZE, (size, hard))
    resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    signal.signal(signal.SIGXFSZ, handler)


def test_npy_cut_short_says_why(tmp_path, file_size_limit):
    """np.save to an open file wrote with C's fwrite, whose failure part way read '6000 requested and 1218 written'
    (seen as '12288 requested and 2016 written' on a full 8 KiB tmpfs), without the cause or the file."""
    image = wrt.Image(rgb=np.zeros((40, 50, 3), np.float32))
    file_size_limit(5000)
    with pytest.raises(OSError) as caught:
        image.save(tmp_path / "x.npy")
    assert caught.value.errno == errno.EFBIG and caught.value.filename == str(tmp_path / "x.npy"), caught.value
    assert files_in(tmp_path) == []


def test_aov_save_on_a_full_disk_names_the_file(tmp_path, full_disk):
    image = wrt.Image(rgb=np.zeros((4, 5, 3), np.float32), aovs={"depth": np.ones((4, 5), np.float32)})
    with pytest.raises(OSError) as caught:
        image.save_aov("depth", tmp_path / "depth.npy")
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(tmp_path / "depth.npy")
    assert files_in(tmp_path) == []


def test_exr_write_failing_as_openexr_says_is_an_os_error_naming_the_file(tmp_path, monkeypatch):
    """OpenEXR raises RuntimeError, naming the temporary file, for a full disk (seen on an 8 KiB tmpfs:
    'Failed to write pixel data to image file "...partial.exr". No space left on device.'), which was a traceback."""
    OpenEXR = pytest.importorskip("OpenEXR")

    class FullFile(OpenEXR.File):
        def write(self, path):
            raise RuntimeError(f'Failed to write pixel data to image file "{path}". No space left on device.')

    monkeypatch.setattr(OpenEXR, "File", FullFile)
    with pytest.raises(OSError) as caught:
        wrt.Image(rgb=np.zeros((4, 5, 3), np.float32)).save(tmp_path / "x.exr")
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(tmp_path / "x.exr")
    assert files_in(tmp_path) == []


def test_render_on_a_full_disk_says_which_file(tmp_path, full_disk, capsys):
    scene = tmp_path / "a.usda"
    scene.write_text(STAGE)
    out = tmp_path / "out"
    assert main(["render", str(scene), "-o", str(out / "a.npy"), *SIZE]) == 2
    err = capsys.readouterr().err
    assert f"wrt: error: {out / 'a.npy'}: no space left on device" in err, err
    assert "Traceback" not in err and files_in(out) == []


def test_batch_on_a_full_disk_logs_each_failed_scene(tmp_path, full_disk, capsys):
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(STAGE)
    out = tmp_path / "out"
    argv = ["render", str(tmp_path / "a.usda"), str(tmp_path / "b.usda"), "-o", f"{out}/{{stem}}.npy", *SIZE]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    rows = [json.loads(line) for line in (out / "render-log.jsonl").read_text().splitlines()]
    assert [r["status"] for r in rows] == ["error", "error"]
    for row, stem in zip(rows, "ab"):
        assert row["error"] == f"OSError: {out / stem}.npy: no space left on device", row
    assert files_in(out) == ["render-log.jsonl"]


@pytest.mark.parametrize("devices", [[], ["--devices", "cpu,cpu"]], ids=["one-device", "two-workers"])
def test_frames_run_past_a_full_disk_logs_the_frame_and_goes_on(tmp_path, monkeypatch, capsys, devices):
    """The disk fills at frame 2's write: frame 2 gets an error row naming its file and the cause, and frames 1 and 3
    are written, status 1 (some frames rendered), as a batch of scenes goes on past a scene whose write failed
    (test_batch_on_a_full_disk_logs_each_failed_scene, the oracle of the row's words). The run stopped there, status
    2, frame 3 never rendered."""
    real_open = builtins.open

    def open_full(file, mode="r", *args, **kwargs):
        full = isinstance(file, (str, os.PathLike)) and ".f_2.npy." in os.fspath(file) and "w" in mode
        return real_open("/dev/full" if full else file, mode, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", open_full)
    real_path_open = Path.open  # Path.write_bytes, which writes the frames that workers send back

    def path_open_full(self, mode="r", *args, **kwargs):
        return real_path_open(Path("/dev/full") if ".f_2.npy." in self.name and "w" in mode else self, mode, *args,
                              **kwargs)

    monkeypatch.setattr(Path, "open", path_open_full)
    scene, out, log = tmp_path / "a.usda", tmp_path / "out", tmp_path / "log.jsonl"
    scene.write_text(STAGE)
    argv = ["render", str(scene), "--frames", "1:3", "-o", f"{out}/f_#.npy", "--log", str(log), *SIZE, *devices]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert f"wrt: error: frame 2: {scene}: {out / 'f_2.npy'}: no space left on device" in err, err  # as a batch says it
    assert "wrt: 1 of 3 frames failed" in err and "Traceback" not in err, err
    rows = {r["frame"]: r for r in map(json.loads, log.read_text().splitlines())}
    assert sorted(rows) == [1.0, 2.0, 3.0], rows
    assert rows[2.0]["status"] == "error", rows
    assert rows[2.0]["error"] == f"OSError: {out / 'f_2.npy'}: no space left on device"
    assert rows[2.0]["device"] == "cpu", rows  # the device that drew it, as the README says an error row names it
    assert rows[1.0]["status"] == rows[3.0]["status"] == "ok", rows
    assert files_in(out) == ["f_1.npy", "f_3.npy"]


def test_ctrl_c_with_a_full_disk_still_stops_the_batch(tmp_path, full_disk, ctrl_c_after, capsys):
    """Ctrl-C during a.usda, whose image of the samples so far cannot be written: the OSError of that write took the
    place of the interrupt, and the batch logged an error and rendered b.usda."""
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(STAGE)
    ctrl_c_after("a.usda")
    out = tmp_path / "out"
    argv = ["render", str(tmp_path / "a.usda"), str(tmp_path / "b.usda"), "-o", f"{out}/", *SIZE]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "wrt: interrupted" in err and f"was not written: {out / 'a.png'}: no space left on device" in err, err
    rows = [json.loads(line) for line in (out / "render-log.jsonl").read_text().splitlines()]
    assert [(Path(r["scene"]).name, r["status"]) for r in rows] == [("a.usda", "interrupted")], rows
    assert files_in(out) == ["render-log.jsonl"]


def test_log_row_on_a_full_disk_names_the_log(tmp_path, monkeypatch):
    from wrt.render_log import append_row

    real_open = builtins.open
    log = tmp_path / "log.jsonl"
    monkeypatch.setattr(builtins, "open", lambda file, *a, **k: real_open("/dev/full" if file == log else file, *a,
                                                                         **k))
    with pytest.raises(OSError) as caught:
        append_row(log, '{"status": "ok"}')
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(log)


def test_save_on_a_read_only_file_system_names_the_file(tmp_path, monkeypatch):
    """On a read-only file system (seen on a tmpfs remounted ro) opening the temporary file fails with EROFS, and so
    does the unlink of that missing file in the cleanup, whose error named the temporary file instead of x.png."""
    from pathlib import Path

    real_open, real_unlink = Path.open, Path.unlink

    def refuse(method):
        def refused(self, *args, **kwargs):
            if self.parent == tmp_path:
                raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))
            return method(self, *args, **kwargs)
        return refused

    monkeypatch.setattr(Path, "open", refuse(real_open))
    monkeypatch.setattr(Path, "unlink", refuse(real_unlink))
    with pytest.raises(OSError) as caught:
        wrt.Image(rgb=np.zeros((4, 5, 3), np.float32)).save(tmp_path / "x.png")
    assert caught.value.errno == errno.EROFS and caught.value.filename == str(tmp_path / "x.png"), caught.value
