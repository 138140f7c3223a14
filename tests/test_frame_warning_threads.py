"""Two FrameRenderers (or render_frames runs) rendering in two threads record each frame's warnings apart
(``animation._frame_warnings``): with ``warnings.catch_warnings``, which swaps the process's hook and filters, two
frames ending in the order they began (A in, B in, A out, B out) left A's recorder as the process's hook for good:
every later warning of the process went into A's finished list and was never shown, and a warning given in A while B
was inside went into B's list."""

import threading
import warnings

from wrt.animation import _frame_warnings

TIMEOUT = 30


def _frame(name: str, entered: threading.Event, go_warn: threading.Event, warned: threading.Event,
           leave: threading.Event, out: dict) -> None:
    try:
        with _frame_warnings(set(), leave_out=()) as raised:
            entered.set()
            assert go_warn.wait(TIMEOUT)
            warnings.warn(f"said in frame {name}", UserWarning)
            warned.set()
            assert leave.wait(TIMEOUT)
            out[name] = [str(w.message) for w in raised]
    except BaseException as e:  # noqa: BLE001 (reported by the test, in its thread)
        out[name] = e


def test_frames_in_two_threads_ending_in_the_order_they_began_leave_warnings_shown_and_apart():
    events = {name: [threading.Event() for _ in range(4)] for name in "AB"}  # entered, go_warn, warned, leave
    out = {}
    with warnings.catch_warnings(record=True) as seen:  # the process's hook the frames must give back
        warnings.simplefilter("always")
        filters, hook = list(warnings.filters), warnings.showwarning
        threads = {name: threading.Thread(target=_frame, args=(name, *events[name], out)) for name in "AB"}
        threads["A"].start()
        assert events["A"][0].wait(TIMEOUT)  # A in
        threads["B"].start()
        assert events["B"][0].wait(TIMEOUT)  # B in
        for name in "AB":  # each warns while both are inside
            events[name][1].set()
            assert events[name][2].wait(TIMEOUT)
        events["A"][3].set()  # A out
        threads["A"].join(TIMEOUT)
        events["B"][3].set()  # B out
        threads["B"].join(TIMEOUT)
        assert not any(t.is_alive() for t in threads.values())
        assert (warnings.filters, warnings.showwarning) == (filters, hook)  # as they were before the frames
        warnings.warn("said after both frames", UserWarning)
    # Oracle: each frame's list holds its own thread's warning alone, and the process shows a later warning (and each
    # frame's warning, passed on once at its end) through the hook it had before.
    assert out == {"A": ["said in frame A"], "B": ["said in frame B"]}
    shown = [str(w.message) for w in seen]
    assert "said after both frames" in shown, shown
    assert sorted(m for m in shown if m.startswith("said in")) == ["said in frame A", "said in frame B"], shown
