"""Comma-separated option values: an empty entry is refused, naming the option, before anything loads."""

import pytest

from wrt.cli import main

BENCH = ["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary", "-q"]


@pytest.mark.parametrize("argv, option, value", [
    (BENCH, "--scenes", "sphere:200,"),
    (BENCH, "--scenes", "sphere:200,,sphere:300"),
    (BENCH, "--accels", "wrt:sah,"),
    (BENCH, "--accels", "wrt:sah, ,warp:sah"),
    (BENCH, "--devices", ",cpu"),
    (BENCH, "--rays", "primary,,shadow"),
    (BENCH, "--threads", "1,"),
    (["render", "--frames", "1:2"], "--devices", "cpu,"),
    (["bvh-stats", "scene.usda"], "--builder", "sah,,lbvh"),
])
def test_an_empty_entry_in_a_comma_list_is_refused_naming_the_option(tmp_path, monkeypatch, capsys, argv, option,
                                                                     value):
    """'--accels wrt:sah,' (or 'a,,b') was read as if the empty entry were not there, a name left out without a word.
    The oracle: the entry numbers of str.split(',') whose text is blank."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main([*argv, option, value])
    assert stop.value.code == 2
    entries = value.split(",")
    empty = next(k for k, entry in enumerate(entries) if not entry.strip())
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert lines == [f"wrt: error: argument {option}: entry {empty + 1} of {len(entries)} is empty (a comma too "
                     f"many?), got {value!r} (see 'wrt {argv[0]} --help')"], lines
    assert not (tmp_path / "bench-out").exists()
