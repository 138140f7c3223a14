"""Tasks on a Dask cluster (``wrt.distributed``): serial results, nothing lost to a killed worker, bench --dask."""

import faulthandler
import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from wrt import bench, distributed
from wrt.bench import Grid, run_grid
from wrt.cli import main
from wrt.distributed import DaskUnavailable, run_tasks

pytest.importorskip("distributed")  # wrt.distributed itself imports dask only when it runs tasks

HANG_SECONDS = 180  # a test still running after this dumps every thread's stack and ends the session
TIMING_KEYS = {"build_ms", "mrays", "mrays_min", "mrays_max", "traceback"}


@pytest.fixture(autouse=True)
def no_hangs():
    faulthandler.dump_traceback_later(HANG_SECONDS, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


def cube_and_pid(x):
    return x**3, os.getpid()


def die_on_first_attempt(item):
    """Kills its worker process the first time it sees item 2 (the marker file remembers), then works."""
    marker, x = item
    if x == 2 and not Path(marker).exists():
        Path(marker).write_text("killed")
        os._exit(1)
    return x**3


def always_die_on_two(item):
    """Kills its worker every time it runs item 2, counting the attempts in a file."""
    attempts, x = item
    if x == 2:
        with open(attempts, "a") as f:
            f.write("x")
        os._exit(1)
    return x


RUN_GROUP_TASK = bench._run_group_task  # the real one, for kill_on_primary_rays on a worker


def kill_on_primary_rays(task):
    """Kills its worker on every group of primary rays, as a worker lost to the OOM killer; runs the others."""
    if task[0][2] == "primary":
        os._exit(1)
    return RUN_GROUP_TASK(task)


def fail_on_three(x):
    if x == 3:
        raise ValueError("three is not allowed")
    return x


def test_local_cluster_results_match_serial():
    items = list(range(8))
    arrived = []
    assert run_tasks(cube_and_pid, items, n_workers=2, on_result=lambda i, r: arrived.append((i, r)),
                     timeout=60, progress=False) is None
    assert sorted((i, r[0]) for i, r in arrived) == [(i, i**3) for i in items]
    assert os.getpid() not in {r[1] for _, r in arrived}  # every task ran in a worker process


def test_killed_worker_loses_nothing(tmp_path):
    marker = tmp_path / "killed"
    items = [(str(marker), x) for x in range(8)]
    arrived = {}
    run_tasks(die_on_first_attempt, items, n_workers=2, on_result=lambda i, r: arrived.setdefault(i[1], r),
              timeout=60, progress=False)
    assert marker.exists()  # a worker did die on item 2
    assert arrived == {x: x**3 for x in range(8)}


def test_a_task_that_keeps_killing_workers_is_reported_after_its_retries(tmp_path):
    attempts = tmp_path / "attempts"
    arrived, errors = [], []
    run_tasks(always_die_on_two, [(str(attempts), x) for x in range(4)], n_workers=2, retries=1,
              on_result=lambda i, r: arrived.append(r), on_error=lambda i, e: errors.append((i[1], e)),
              timeout=60, progress=False)
    assert sorted(arrived) == [0, 1, 3]
    assert [(x, type(e).__name__) for x, e in errors] == [(2, "KilledWorker")]
    assert attempts.read_text() == "xx"  # the first run and one retry


def test_task_errors_reach_on_error_or_are_raised_after_the_rest():
    errors, arrived = [], []
    results = run_tasks(fail_on_three, range(6), n_workers=1, on_error=lambda i, e: errors.append((i, e)),
                        timeout=60, progress=False)
    assert results == [0, 1, 2, None, 4, 5]  # without on_result: returned in item order
    assert [(i, type(e)) for i, e in errors] == [(3, ValueError)]
    with pytest.raises(ValueError, match="three"):
        run_tasks(fail_on_three, range(6), n_workers=1, on_result=lambda i, r: arrived.append(r), timeout=60,
                  progress=False)
    assert sorted(arrived) == [0, 1, 2, 4, 5]  # the others still arrived before the error


class _ClientCutWhileSubmitting:
    """A Dask client whose map is cut short by Ctrl-C, as a run stopped while its tasks are still being sent."""

    closed = False

    def map(self, fn, items, pure=True):
        raise KeyboardInterrupt

    def close(self):
        self.closed = True


def test_ctrl_c_while_the_tasks_are_sent_stays_a_ctrl_c(monkeypatch):
    """Ctrl-C before any task was handed back (inside client.map) reaches the caller as KeyboardInterrupt, with no
    item cut short; the handler read the futures, not yet made, and raised UnboundLocalError in its place."""
    client = _ClientCutWhileSubmitting()
    monkeypatch.setattr(distributed, "connect", lambda *args: (client, None))
    cut_short = []
    with pytest.raises(KeyboardInterrupt):
        run_tasks(cube_and_pid, [1, 2], on_result=lambda i, r: None, on_interrupt=cut_short.append, progress=False)
    assert cut_short == [[]] and client.closed


def test_unreachable_scheduler_is_named(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(distributed, "CONNECT_TIMEOUT", 1.0)
    with pytest.raises(DaskUnavailable, match="tcp://127.0.0.1:9"):
        run_tasks(cube_and_pid, [1], address="tcp://127.0.0.1:9", progress=False)
    earlier = '{"scene": "sphere:100", "accel": "wrt:sah", "device": "cpu", "rays": "primary"}\n'  # a bench row
    (tmp_path / "rows.jsonl").write_text(earlier)
    assert main(["bench", "--dask", "tcp://127.0.0.1:9", "--scenes", "sphere:500", "-o", str(tmp_path), "-q"]) == 1
    assert "wrt: error: cannot reach a Dask scheduler at 'tcp://127.0.0.1:9'" in capsys.readouterr().err
    assert (tmp_path / "rows.jsonl").read_text() == earlier  # was deleted before connecting


def test_missing_dask_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(DaskUnavailable, match=r"pip install 'wrt\[dask\]'"):
        run_tasks(cube_and_pid, [1], progress=False)


def test_worker_device_outside_a_worker(monkeypatch):
    monkeypatch.setenv(distributed.DEVICE_ENV, "cuda:3")
    assert distributed.worker_device() == "cuda:3"
    monkeypatch.delenv(distributed.DEVICE_ENV)
    assert distributed.worker_device() in ("cpu", "cuda:0")


HOLD_ENV = "WRT_TEST_HOLD"  # a file: hold_second_row() writes it, then waits while it exists


def hold_second_row(task):
    """A bench group on a Dask worker whose second row's launches wait (at most a minute) until the test removes the
    file ``$WRT_TEST_HOLD``, written when the first row is finished."""
    hold, original, calls = Path(os.environ[HOLD_ENV]), bench.time_runs, []

    def held(run, repeats):
        calls.append(1)
        if len(calls) == 2:
            hold.write_text("first row finished")
            deadline = time.monotonic() + 60
            while hold.exists() and time.monotonic() < deadline:
                time.sleep(0.05)
        return original(run, repeats)

    bench.time_runs = held  # in the worker's own process
    return RUN_GROUP_TASK(task)


def die_at_second_row(task):
    """A bench group on a Dask worker whose worker dies (as to the OOM killer) a moment into the group's second row,
    the first one finished and sent."""
    original, calls = bench.time_runs, []

    def dying(run, repeats):
        calls.append(1)
        if len(calls) == 2:
            time.sleep(1.0)  # the first row's event leaves with the worker's next batch
            os._exit(1)
        return original(run, repeats)

    bench.time_runs = dying  # in the worker's own process
    return RUN_GROUP_TASK(task)


def comparable(rows):
    return sorted(json.dumps({k: v for k, v in r.items() if k not in TIMING_KEYS}, sort_keys=True) for r in rows)


def test_bench_dask_writes_the_serial_rows_and_resumes(tmp_path, monkeypatch):
    # The missing scene gives error rows beside the measured ones.
    grid = dict(scenes=["sphere:2000", "no/such/scene.usda"], accels=["warp:sah", "wrt:sah"],
                rays=["primary", "shadow"], n_rays=3000, repeats=2)
    serial = run_grid(Grid(**grid), tmp_path / "serial", progress=False)
    assert any("error" in r for r in serial) and any("mrays" in r for r in serial)
    # Resume from the measured primary rows; the cluster measures the rest, error rows included.
    out = tmp_path / "dask"
    out.mkdir()
    kept = [r for r in serial if r["rays"] == "primary" and "error" not in r]
    (out / "rows.jsonl").write_text("".join(json.dumps(r) + "\n" for r in kept))
    monkeypatch.setattr(distributed, "default_workers", lambda: 2)
    argv = ["bench", "--scenes", ",".join(grid["scenes"]), "--accels", ",".join(grid["accels"]), "--rays",
            "primary,shadow", "--n-rays", "3000", "--repeats", "2", "-o", str(out), "--resume", "--dask", "-q"]
    assert main(argv) == 1  # the error rows
    rows = [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]
    assert rows[: len(kept)] == kept  # not measured again
    assert comparable(rows) == comparable(serial)


def test_bench_dask_keeps_resumed_rows_of_a_group_whose_workers_die(tmp_path, monkeypatch):
    """A group whose workers kept dying became an error row that dropped every row --resume had kept for the group
    from rows.jsonl ("measured again, as the group now fails"), though nothing had measured them again."""
    grid = Grid(scenes=["sphere:200"], accels=["warp:sah", "wrt:sah"], rays=["primary"], n_rays=300, repeats=1)
    kept = run_grid(grid, tmp_path, progress=False)
    monkeypatch.setattr(bench, "_run_group_task", kill_on_primary_rays)
    monkeypatch.setattr(distributed, "default_workers", lambda: 2)
    rows = run_grid(Grid(**dict(vars(grid), rays=["primary", "shadow"])), tmp_path, progress=False, resume=True,
                    dask=True)
    assert rows[:2] == kept and rows.resumed == 2
    assert [(r["rays"], r["accel"], "mrays" in r) for r in rows[2:]] == [
        ("primary", "*", False), ("shadow", "warp:sah", True), ("shadow", "wrt:sah", True)]
    assert "KilledWorker" in rows[2]["error"]
    written = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert written[:2] == kept and sorted(map(json.dumps, written)) == sorted(map(json.dumps, rows))


@pytest.mark.skipif(bench.wp.get_cuda_device_count() > 0, reason="the workers here have a GPU")
def test_bench_dask_cuda_rows_fail_on_workers_without_a_gpu(tmp_path, monkeypatch):
    """On workers without a GPU, worker_device() is 'cpu', and the cuda:0 group ran there: rows labelled cuda:0 that
    timed the CPU again. It is now an error row naming the device, as without --dask."""
    monkeypatch.setattr(distributed, "default_workers", lambda: 1)
    grid = Grid(scenes=["sphere:200"], accels=["wrt:sah"], devices=["cpu", "cuda:0"], rays=["primary"], n_rays=300,
                repeats=1)
    rows = run_grid(grid, tmp_path, progress=False, dask=True)
    assert [(r["device"], r["accel"], "mrays" in r) for r in rows] == [("cpu", "wrt:sah", True), ("cuda:0", "*", False)]
    assert "cuda:0" in rows[1]["error"] and "no CUDA device" in rows[1]["error"]


def test_a_malformed_scheduler_address_is_named_with_dask_s_reason(tmp_path, capsys):
    """'--dask 8786' failed at once, in Dask's 'missing port number', yet was reported as 'cannot reach a Dask
    scheduler at '8786' within 30 s (ValueError)', with exit status 1 (the environment) for a typing mistake."""
    with pytest.raises(ValueError, match="Dask scheduler address '8786': missing port number"):
        run_tasks(cube_and_pid, [1], address="8786", progress=False)
    assert main(["bench", "--dask", "8786", "--scenes", "sphere:500", "-o", str(tmp_path), "-q"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert err == ["wrt: error: Dask scheduler address '8786': missing port number in address '8786'; give one such "
                   "as 'tcp://host:8786'"]


def test_bench_dask_ctrl_c_keeps_the_rows_written_as_a_plain_run_does(tmp_path, monkeypatch):
    """Ctrl-C in bench --dask (simulated while the second group's rows are written, on one worker) keeps the rows
    already in rows.jsonl and their table, as the plain run interrupted at the same row does; neither writes a row
    for the group cut short (bench rows have no status), and --resume measures only what is missing."""
    grid = Grid(scenes=["sphere:200"], accels=["warp:sah", "wrt:sah"], rays=["primary", "shadow"], n_rays=300,
                repeats=1)
    replace_resumed = bench._replace_resumed

    def ctrl_c_at_shadow_rows(row, *args):
        if row["rays"] == "shadow":
            raise KeyboardInterrupt
        return replace_resumed(row, *args)

    monkeypatch.setattr(bench, "_replace_resumed", ctrl_c_at_shadow_rows)
    monkeypatch.setattr(distributed, "default_workers", lambda: 1)
    written = {}
    for name, dask in (("plain", None), ("dask", True)):
        with pytest.raises(KeyboardInterrupt):
            run_grid(grid, tmp_path / name, progress=False, dask=dask)
        written[name] = [json.loads(line) for line in (tmp_path / name / "rows.jsonl").read_text().splitlines()]
        table = (tmp_path / name / "table.md").read_text()
        assert all(f"| {r['accel']} |" in table for r in written[name]), table
    assert [(r["rays"], r["accel"]) for r in written["dask"]] == [("primary", "warp:sah"), ("primary", "wrt:sah")]
    assert comparable(written["dask"]) == comparable(written["plain"])
    monkeypatch.setattr(bench, "_replace_resumed", replace_resumed)
    rows = run_grid(grid, tmp_path / "dask", progress=False, resume=True, dask=True)
    assert rows.resumed == 2 and rows[:2] == written["dask"]
    assert [(r["rays"], r["accel"]) for r in rows[2:]] == [("shadow", "warp:sah"), ("shadow", "wrt:sah")]


def test_bench_dask_ctrl_c_keeps_the_finished_rows_of_a_group_cut_short(tmp_path, monkeypatch):
    """Ctrl-C in bench --dask while a worker measured a group's second row lost the group's first row, finished on
    the worker, since a group's rows came back only with the whole group; a plain run interrupted at the same row
    keeps it. The Ctrl-C is simulated as a real one is delivered (the main thread's SIGINT handler), once the worker
    has finished the first row."""
    grid = Grid(scenes=["sphere:200"], accels=["warp:sah", "wrt:sah"], rays=["primary"], n_rays=300, repeats=1)
    time_runs = bench.time_runs
    calls = []

    def ctrl_c_at_second_row(run, repeats):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return time_runs(run, repeats)

    monkeypatch.setattr(bench, "time_runs", ctrl_c_at_second_row)
    with pytest.raises(KeyboardInterrupt):
        run_grid(grid, tmp_path / "plain", progress=False)
    monkeypatch.setattr(bench, "time_runs", time_runs)
    hold = tmp_path / "hold"
    monkeypatch.setenv(HOLD_ENV, str(hold))
    monkeypatch.setattr(bench, "_run_group_task", hold_second_row)
    monkeypatch.setattr(distributed, "default_workers", lambda: 1)

    def press_ctrl_c():
        # The worker compiles the trace kernels first: minutes on a busy 2-core machine with an empty Warp cache (CI).
        deadline = time.monotonic() + 600
        while not hold.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(2.0)  # the first row, sent by the worker when it finished, reaches this process meanwhile
        # A real SIGINT, as a terminal sends it: it wakes the main thread from a blocking wait, where
        # _thread.interrupt_main() only sets a flag that waits for the main thread's next bytecode.
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5.0)  # the worker holds its second row until the interrupted run has stopped
        hold.unlink(missing_ok=True)  # the worker may go on: the run has stopped

    # Python's own handler, as in a terminal: a shell that starts pytest in the background hands it SIGINT ignored
    # (CI scripts do; this test then failed there only), and the simulated Ctrl-C would be ignored with it.
    outer = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        presser = threading.Thread(target=press_ctrl_c, daemon=True)
        presser.start()
        with pytest.raises(KeyboardInterrupt):
            run_grid(grid, tmp_path / "dask", progress=False, dask=True)
        presser.join()
    finally:
        signal.signal(signal.SIGINT, outer)
    written = {}
    for name in ("plain", "dask"):
        jsonl = tmp_path / name / "rows.jsonl"
        written[name] = [json.loads(line) for line in jsonl.read_text().splitlines()] if jsonl.exists() else []
    assert [(r["rays"], r["accel"], "mrays" in r) for r in written["plain"]] == [("primary", "warp:sah", True)]
    assert comparable(written["dask"]) == comparable(written["plain"])
    assert "| warp:sah |" in (tmp_path / "dask" / "table.md").read_text()


def test_bench_dask_keeps_the_rows_a_worker_finished_before_it_died(tmp_path, monkeypatch):
    """A group whose workers kept dying in its second row became one error row: the first row, measured and sent
    by each attempt, was lost. It is kept (once, of the last attempt), beside the group's error row."""
    grid = Grid(scenes=["sphere:200"], accels=["warp:sah", "wrt:sah"], rays=["primary"], n_rays=300, repeats=1)
    monkeypatch.setattr(bench, "_run_group_task", die_at_second_row)
    monkeypatch.setattr(distributed, "default_workers", lambda: 1)
    rows = run_grid(grid, tmp_path, progress=False, dask=True)
    written = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert sorted(map(json.dumps, written)) == sorted(map(json.dumps, rows))
    assert [(r["accel"], "mrays" in r) for r in rows] == [("warp:sah", True), ("*", False)]
    assert "KilledWorker" in rows[1]["error"]
