"""The log rows of a frame run (``render_frames``, over ``--devices`` and on Dask): each frame's row lists every
warning that frame gave, however often the run said it before, and the rows of a run cut short by Ctrl-C name each
job (a frame's file), not each frame."""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from wrt.animation import pending_frames, render_frames

SIZE = {"width": 8, "height": 6}
WHERE = ["serial", "two devices", "dask"]
FRAMES = (1.0, 2.0, 3.0, 4.0)


def blind_at_frames_2_and_3(tmp_path) -> Path:
    """A unit ball at the origin and a camera that moves past its far clip at frames 2 and 3."""
    path = tmp_path / "blind.usda"
    path.write_text("""#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 4
)
def Sphere "Ball"
{
}
def Camera "Cam"
{
    double3 xformOp:translate.timeSamples = { 1: (0, 0, 6), 2: (0, 0, 2000000), 3: (0, 0, 2000000), 4: (0, 0, 6) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
""")
    return path


def blind_frames(path) -> set:
    """Oracle, from USD's own API: the frames whose camera clipping range holds no point of the ball (radius 1 at
    the origin, seen along the camera's -z from its place on the z axis)."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/Cam"))
    blind = set()
    for frame in FRAMES:
        eye = camera.ComputeLocalToWorldTransform(frame).Transform(Gf.Vec3d(0, 0, 0))
        near, far = camera.GetClippingRangeAttr().Get(frame)
        assert eye[0] == eye[1] == 0.0
        if eye[2] - 1.0 > far or eye[2] + 1.0 < near:
            blind.add(frame)
    return blind


def run(where, path, jobs, **options) -> list[dict]:
    if where == "dask":
        pytest.importorskip("distributed")
        from wrt.animation import render_frames_on_dask

        return render_frames_on_dask(path, jobs, n_workers=1, **options)
    return render_frames(path, jobs, devices=["cpu"] if where == "serial" else ["cpu", "cpu"], **options)


@pytest.mark.parametrize("where", WHERE)
def test_every_row_lists_a_warning_the_run_said_at_an_earlier_frame(tmp_path, where):
    """A camera that sees nothing at frames 2 and 3: said once on screen, it was in frame 2's row alone (the
    Renderers of a run share what was said, so frame 3's never raised it). Each row lists it where its frame gave
    it; the parallel runs' rows list what the serial run's do."""
    path = blind_at_frames_2_and_3(tmp_path)
    blind = blind_frames(path)
    assert blind == {2.0, 3.0}
    jobs = pending_frames(FRAMES, tmp_path / where / "f_#.npy", resume=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = run(where, path, jobs, **SIZE)
    assert len([w for w in caught if "sees nothing" in str(w.message)]) == 1  # still said once on screen
    by_frame = {row["frame"]: row for row in rows}
    assert sorted(by_frame) == list(FRAMES) and not any("error" in row for row in rows)
    for frame, row in by_frame.items():
        said = [m for m in row["warnings"] if "sees nothing" in m and "/Cam" in m]
        assert len(said) == (frame in blind), (frame, row["warnings"])
    if where != "serial":
        with warnings.catch_warnings(record=True):  # rows list the warnings the caller's filters show
            warnings.simplefilter("always")
            serial = run("serial", path, pending_frames(FRAMES, tmp_path / "serial" / "f_#.npy", resume=False), **SIZE)
        assert {r["frame"]: r["warnings"] for r in rows} == {r["frame"]: r["warnings"] for r in serial}
        for frame in FRAMES:
            name = f"f_{frame:g}.npy"
            np.testing.assert_array_equal(np.load(tmp_path / where / name), np.load(tmp_path / "serial" / name))


def one_frame_as_png_and_npy(tmp_path) -> tuple[Path, list]:
    path = blind_at_frames_2_and_3(tmp_path)
    return path, [(1.0, tmp_path / "out" / "f_1.png"), (1.0, tmp_path / "out" / "f_1.npy")]


def check_ctrl_c_rows(rows, jobs) -> None:
    """The job written has its row; the other, cut short, has an interrupted row naming its file (a serial run
    cut short there gives it one: test_animation's ctrl-C tests)."""
    written = [file for _, file in jobs if file.exists()]
    assert len(written) == 1, written
    (cut,) = [file for _, file in jobs if not file.exists()]
    assert sorted((row["output"], row.get("status", "ok")) for row in rows) == sorted(
        [(str(written[0]), "ok"), (str(cut), "interrupted")]), rows


def test_ctrl_c_over_two_devices_logs_the_job_of_a_frame_cut_short_beside_its_written_twin(tmp_path, monkeypatch):
    """Frame 1 asked for as .png and as .npy, Ctrl-C as the first of them is written: the interrupted rows were
    matched by frame, so the other job, handed to a worker and never written, got no row (its frame was logged)."""
    from wrt import animation

    frame_writer = animation._frame_writer

    def ctrl_c_after_the_first_write(rows, *args):  # args: the AOV pattern
        write = frame_writer(rows, *args)

        def cut(result, file):
            write(result, file)
            raise KeyboardInterrupt  # as Ctrl-C right after the first image was written

        return cut

    monkeypatch.setattr(animation, "_frame_writer", ctrl_c_after_the_first_write)
    path, jobs = one_frame_as_png_and_npy(tmp_path)
    with pytest.raises(KeyboardInterrupt):
        render_frames(path, jobs, devices=["cpu", "cpu"], log=tmp_path / "log.jsonl", **SIZE)
    rows = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    check_ctrl_c_rows(rows, jobs)


def test_ctrl_c_on_dask_logs_the_job_of_a_frame_cut_short_beside_its_written_twin(tmp_path, monkeypatch):
    """As over devices, on Dask: run_tasks hands on_interrupt the jobs cut short (the one being written and one a
    worker had finished); the job not written got no row, as its frame had one. run_tasks is played here by its
    contract (wrt.distributed.run_tasks), the tasks run in this process by render_frame_task itself."""
    import wrt.distributed
    from wrt import animation

    def run_tasks(task, tasks, *, on_result, on_interrupt, **kwargs):
        results = [task(job) for job in tasks]
        on_result(tasks[0], results[0])
        on_interrupt(tasks)  # Ctrl-C while the second result waits to be handed over
        raise KeyboardInterrupt

    monkeypatch.setattr(wrt.distributed, "run_tasks", run_tasks)
    monkeypatch.setattr(animation, "_WORKER_RENDERERS", {})
    path, jobs = one_frame_as_png_and_npy(tmp_path)
    with pytest.raises(KeyboardInterrupt):
        animation.render_frames_on_dask(path, jobs, log=tmp_path / "log.jsonl", **SIZE)
    rows = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    check_ctrl_c_rows(rows, jobs)


def test_a_worker_frames_row_lists_the_warning_of_its_save_as_the_serial_rows_do(tmp_path, monkeypatch):
    """A normals image saved as PNG with an exposure warns that exposure does not scale it. The worker task saved
    the image after its warnings were recorded: the warning went to the worker's own stderr (past the client's
    filters and its once per run) and was missing from the frame's row, which the serial run's lists. The task is
    run here as a worker runs it; the oracle is the serial run's row."""
    from wrt import animation

    monkeypatch.setattr(animation, "_WORKER_RENDERERS", {})
    path = blind_at_frames_2_and_3(tmp_path)
    options = dict(SIZE, integrator="normals")
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        (serial,) = render_frames(path, [(1.0, tmp_path / "serial.png")], exposure=1.0, **options)
        job = animation._task(str(path), 1.0, tmp_path / "worker.png", 1, 0, 1.0, options)
        result = animation.render_frame_task(job)
    assert any("exposure does not scale this image" in m for m in serial["warnings"]), serial["warnings"]
    rows = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        animation._frame_writer(rows)(result, tmp_path / "worker.png")
    assert [row["warnings"] for row in rows] == [serial["warnings"]]
    assert [str(w.message) for w in caught] == serial["warnings"]  # said by the client, in its filters
    assert (tmp_path / "worker.png").read_bytes() == (tmp_path / "serial.png").read_bytes()


def test_ctrl_c_while_a_frame_is_written_still_logs_the_image_it_wrote(tmp_path, monkeypatch):
    """Ctrl-C landing between a worker frame's image write and its log row (a user, or a test, reacting to the image
    appearing) left the image on disk logged as interrupted. Now the Ctrl-C is raised once both are written."""
    import os
    import signal
    import threading

    from wrt import animation

    def write_then_ctrl_c(path, write):
        Path(path).write_bytes(b"image")
        os.kill(os.getpid(), signal.SIGINT)  # delivered at once to this (main) thread's handler

    monkeypatch.setattr(animation, "write_atomically", write_then_ctrl_c)
    rows = []
    write = animation._frame_writer(rows)
    # Python's own Ctrl-C, whatever an earlier test in this process left: in the full suite (xdist) it failed with
    # 'DID NOT RAISE', alone and after every test file of this stop it passed.
    assert threading.current_thread() is threading.main_thread()
    outer = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            write({"row": {"frame": 3.0, "status": "ok"}, "data": b"image"}, tmp_path / "f_3.npy")
    finally:
        signal.signal(signal.SIGINT, outer)
    assert (tmp_path / "f_3.npy").is_file()
    assert [(row["frame"], row["status"], row["output"]) for row in rows] == [(3.0, "ok", str(tmp_path / "f_3.npy"))]


def test_a_frame_whose_error_stops_a_dask_run_has_its_error_row(tmp_path, monkeypatch):
    """A frame whose task raised what is no bad input at its time (no memory left on its worker) is raised once the
    other frames finish, as run_tasks' contract says (wrt.distributed.run_tasks, played here, the tasks run in this
    process), but the log said nothing of it, only that frame 1 had finished; over devices such a frame has its error
    row (_log_stopping_frame). The oracle: the frame and its file as given, and the error raised."""
    import wrt.distributed
    from wrt import animation

    def run_tasks(task, tasks, *, on_result, on_error, **kwargs):
        on_result(tasks[0], task(tasks[0]))
        on_error(tasks[1], MemoryError("no memory left for frame 2"))

    monkeypatch.setattr(wrt.distributed, "run_tasks", run_tasks)
    monkeypatch.setattr(animation, "_WORKER_RENDERERS", {})
    path = blind_at_frames_2_and_3(tmp_path)
    jobs = [(1.0, tmp_path / "f_1.npy"), (2.0, tmp_path / "f_2.npy")]
    with pytest.raises(MemoryError, match="frame 2"):
        animation.render_frames_on_dask(path, jobs, log=tmp_path / "log.jsonl", **SIZE)
    rows = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    assert [(row["frame"], row["output"], row.get("error")) for row in rows] == [
        (1.0, str(jobs[0][1]), None), (2.0, str(jobs[1][1]), "MemoryError: no memory left for frame 2")], rows
