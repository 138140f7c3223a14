"""The JSON-lines log of ``wrt render`` (a batch of scenes, or ``--frames``) and what ``--resume`` reads from it.

Every row names the run that wrote it (``run``, ``run_started_at``): logs are appended to across runs, and
``pandas.read_json(log, lines=True).groupby("run")`` splits them again. A row also holds what decided its image
(:data:`OPTION_FIELDS`, the scene file's modification time, the device) and the modification time of the image it
wrote, so that ``--resume`` skips an image only when the last row about it says it was finished, with the options
asked now, and the file on disk is still the one that row wrote. Rows of older wrt versions lack those fields: their
images are rendered again.
"""

from __future__ import annotations

import json
import os
import secrets
import time
from pathlib import Path

from .image import failed_write

# Row fields that decide an image, as the command line gave them (None: the stage's or wrt's default). A row whose
# values differ from the run's, or that lacks one, is rendered again. Left out: --builder changes no colour (closest
# hits break ties by triangle id) but does change the cost AOV, so it is in; --max-memory, --quiet, --log are not.
OPTION_FIELDS = ("width", "height", "camera", "spp", "seed", "integrator", "max_depth", "ao_radius", "exposure",
                 "builder", "accel", "time", "refine_level", "variant", "render_settings", "aov", "aov_dir")
OK_STATUSES = ("ok", "skipped")  # a row of a finished image: rendered by its run, or one run before it


def new_run() -> dict:
    """The fields naming this run in each of its rows: ``run``, an id that sorts by start time,
    ``run_started_at``, the start as ISO 8601 UTC (pandas reads ``*_at`` columns as dates), and ``cwd``, the folder
    that the row's relative paths (as typed) are relative to."""
    now = time.time()
    stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime(now))
    started = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(now)) + f".{int(now % 1 * 1e6):06d}Z"
    return {"run": f"{stamp}-{secrets.token_hex(3)}", "run_started_at": started, "cwd": os.getcwd()}


def mtime_ns(path) -> int | None:
    """``path``'s modification time in nanoseconds, or None where there is no such file."""
    try:
        return os.stat(path).st_mtime_ns
    except OSError:
        return None


def device_kind(device) -> str:
    """``cpu`` or ``cuda``: the images of ``cuda:0`` and ``cuda:1`` are the same, a CPU's may differ in the last
    bits (the same seed gives the same image on the same device)."""
    return "cpu" if str(device).startswith("cpu") else "cuda"


def read_rows(log: Path, option: str = "--log") -> list[dict]:
    """The rows of the JSON-lines ``log`` (none where it does not exist). A line that starts as a row but is cut
    short (a run killed while writing it) is left out; any other line that is not a JSON object is a ValueError
    naming ``option``, the file and the line: it is not a log of wrt's."""
    if not log.exists():
        return []
    rows = []
    with open(log, encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                row = json.loads(line)
            except json.JSONDecodeError as e:
                if line.lstrip().startswith("{"):
                    continue  # cut short: the image it was about is rendered again
                raise ValueError(f"{option} {log}: line {number} is not a JSON row ({e.msg}); give the log of an "
                                 "earlier wrt render, or another file") from None
            if not isinstance(row, dict):
                raise ValueError(f"{option} {log}: line {number} is not a JSON row (a {type(row).__name__}); give "
                                 "the log of an earlier wrt render, or another file")
            rows.append(row)
    return rows


def check_appendable(log: Path, option: str = "--log") -> None:
    """Raises ValueError naming ``option`` when ``log`` is a file whose first line is no JSON row (notes, an image):
    rows were appended to whatever file ``--log`` named, and only a later ``--resume`` refused it as no log."""
    if log.is_fifo() or log.is_socket():  # no file to append rows to: 'File or stream is not seekable' at the first
        from .errors import not_a_file

        raise ValueError(f"{option} {log}: {not_a_file(log)}, not a file")
    if log.exists() and not log.is_file() and not log.is_dir() and not _seekable(log):
        raise ValueError(f"{option} {log}: a terminal or another stream that rows cannot be appended to, not a file")
    if not log.is_file():  # made by the run, or a device such as /dev/null (no log kept)
        return
    try:
        with open(log, "rb") as f:
            head, number = b"", 0
            while not head.strip() and (chunk := f.readline(1 << 16)):  # the first line that is not blank
                head, number = chunk, number + 1
    except OSError:
        return  # unreadable: the first row's write names the problem
    if head.strip() and not head.lstrip().startswith(b"{"):
        raise ValueError(f"{option} {log}: line {number} is not a JSON row, so the file is no log of wrt's; rows are "
                         "appended to a log: give a new file, or the log of an earlier wrt render")
    try:
        row = json.loads(head)
    except ValueError:  # cut short (a killed run), or a line past the length read: the rows after it decide
        return
    if isinstance(row, dict) and is_bench_row(row):  # wrt bench's rows.jsonl: its --resume refused the render rows
        raise ValueError(f"{option} {log}: line {number} is a row of wrt bench ({row.get('scene')} / "
                         f"{row.get('accel')} / {row.get('rays')} rays), so the file holds benchmark timings, not a "
                         "render log; rows are appended to a log: give a new file, or the log of an earlier wrt render")


def is_bench_row(row: dict) -> bool:
    """Whether ``row`` is one of ``wrt bench`` (its ``rows.jsonl``): it names an accelerator and a ray kind, and no
    image, which every row of a render log names (``output``)."""
    return "output" not in row and all(name in row for name in ("scene", "accel", "device", "rays"))


def _seekable(device: Path) -> bool:
    """Whether ``device`` (no regular file) can be opened as :func:`append_row` opens a log, which seeks to its end:
    /dev/null can, a terminal (/dev/stdout on one) cannot ('File or stream is not seekable' at the first row).
    Opened without blocking and without becoming the controlling terminal."""
    try:
        fd = os.open(device, os.O_WRONLY | os.O_APPEND | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError:
        return True  # not opened: the first row's write names the problem, as for an unreadable file
    try:
        os.lseek(fd, 0, os.SEEK_END)
        return not os.isatty(fd)
    except OSError:
        return False
    finally:
        os.close(fd)


def append_row(log: Path, line: str) -> None:
    """Appends ``line`` to ``log`` as a line of its own, also after a last line cut short by a killed run."""
    try:
        with open(log, "a+b") as f:
            if f.tell() > 0:
                f.seek(-1, os.SEEK_END)
                if f.read(1) != b"\n":
                    f.write(b"\n")
            f.write(line.encode() + b"\n")
    except OSError as e:  # a full disk raised at the close: '[Errno 28] No space left on device', naming no file
        raise failed_write(e, log) from None


def skipped_fields(before: dict) -> dict:
    """The fields of this run's row for an image ``--resume`` skips, carried from ``before``, the row that said it
    was finished: ``status`` skipped, the run that rendered it (``resumed_from``), its device and image time."""
    return {"status": "skipped", "resumed_from": before.get("resumed_from", before["run"]), "device": before["device"],
            "output_mtime_ns": before["output_mtime_ns"]}


def _row_path(row: dict, path) -> Path:
    """``path`` of ``row`` (its scene, image or an AOV file) as an absolute path: a relative one is taken from the
    folder its run started in, so ``--resume`` from another folder finds the same files (rows of runs before the
    ``cwd`` field: from the current folder)."""
    return (Path(row.get("cwd", ".")) / path).resolve()


class ResumeIndex:
    """The last row of ``rows`` about each image file, and whether ``--resume`` may skip that image."""

    def __init__(self, rows: list[dict]):
        self.last = {}
        for row in rows:
            if isinstance(row.get("output"), str):
                self.last[_row_path(row, row["output"])] = row

    def finished(self, scene, output, options: dict, kinds) -> tuple[dict | None, str]:
        """``(row, "")`` when ``output`` is an image finished with ``options`` on a device of ``kinds`` (a set of
        :func:`device_kind`, or None for any), from ``scene`` as it is now; else ``(None, why)`` (``""`` where no
        row names it)."""
        row = self.last.get(Path(output).resolve())
        if row is None:
            return None, ""
        run = f"run {row['run']}" if "run" in row else "an earlier run"
        status = row.get("status", "error" if "error" in row else None)
        if status not in OK_STATUSES:
            return None, f"its last row ({run}) says {status or 'nothing of its status'}"
        if "scene" in row and _row_path(row, row["scene"]) != Path(scene).resolve():
            return None, f"{run} wrote it from {row.get('scene')}"
        if "run" not in row or "scene_mtime_ns" not in row:
            return None, f"{run} recorded no options (an older wrt)"
        changed = [name for name in OPTION_FIELDS if name in options and not _same_option(row, name, options[name])]
        if changed:
            said = ", ".join(f"--{n.replace('_', '-')} {_shown(row.get(n), row, n)} -> {_shown(options[n], {}, n)}"
                             for n in changed)
            return None, f"options changed since {run}: {said}"
        if row["scene_mtime_ns"] != mtime_ns(scene):
            return None, f"{Path(scene).name} changed since {run}"
        if kinds is not None and device_kind(row.get("device")) not in kinds:
            return None, f"{run} rendered it on {row.get('device')}"
        for file in row.get("aov_files", []):
            if mtime_ns(_row_path(row, file)) is None:
                return None, f"{file} of {run} is missing"
        stamp = mtime_ns(output)
        if stamp is None:
            return None, f"{output} of {run} is missing"
        if stamp != row.get("output_mtime_ns"):
            return None, f"{output} was written again after {run}"
        return row, ""


def _same_option(row: dict, name: str, value) -> bool:
    """Whether ``row`` was rendered with option ``name`` at ``value`` (this run's, as given). A folder (``aov_dir``)
    is compared as the folder it names, read from the folder each run started in: ``--aov-dir aovs`` resumed from
    another folder names another folder (its AOV files were not written there, and the scene was skipped), and
    ``../first/aovs`` from there the same one (the scene was rendered again)."""
    before = row.get(name)
    if name == "aov_dir" and isinstance(before, str) and isinstance(value, str):
        return _row_path(row, before) == Path(value).resolve()
    return before == value


def carried_files(before: dict, name: str = "aov_files") -> list[str]:
    """The files of ``before`` (a row ``--resume`` skips the image of) under ``name``, as this run's row names them:
    a relative path is relative to the folder a row's run started in (``cwd``), and this run may have started in
    another, so it is spelt from this run's folder (absolute ones stay): carried as they were, the next resume looked
    for them beside this run's folder, and rendered the image again."""
    files = []
    for file in before.get(name, []):
        files.append(file if os.path.isabs(file) else os.path.relpath(_row_path(before, file)))
    return files


def _shown(value, row: dict | None = None, name: str = "") -> str:
    """An option value as a user typed it: None is the default, lists are the repeated option's values; a folder
    (``aov_dir``) as the one it names from the folder ``row``'s run started in (this run's: ``{}``)."""
    if name == "aov_dir" and isinstance(value, str):
        return str(_row_path(row or {}, value))
    if value is None:
        return "(default)"
    if isinstance(value, list):
        return ",".join(map(str, value)) or "(none)"
    return str(value)


__all__ = ["OPTION_FIELDS", "ResumeIndex", "append_row", "carried_files", "check_appendable", "device_kind",
           "is_bench_row", "mtime_ns", "new_run", "read_rows", "skipped_fields"]
