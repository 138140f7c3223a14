"""The README's examples run as written, so the documentation cannot rot silently.

Every fenced ```` ```python ```` block of ``README.md`` runs in a fresh interpreter, as a reader pasting it would,
with this checkout first on ``PYTHONPATH``, in a temporary folder that holds small stand-ins for the files the
examples name: ``scene.usda`` (the bundled room), ``car.usda`` (a ``/World/Car`` with a ``paint`` variant set) and
``shot.usda`` (the room with a ``/Render/Preview`` RenderSettings of 32x24 pixels and two RenderProducts). Every file
a block writes with ``.save("NAME")`` must exist afterwards, every folder it hands ``render_products`` must hold
a file, and it must print no warning (a reader would take one for a fault).

A block that cannot run here (it needs a CUDA GPU, torch or a large asset) is marked in the README by an HTML comment
on the line just before its fence, which GitHub and PyPI do not show; the text after ``no-test:`` is the reason the
test is skipped with::

    <!-- no-test: needs a CUDA GPU (device="cuda:0") and torch -->
    ```python

The command lines of the ``bash`` blocks are checked without running them: each ``wrt ...`` line is parsed by
``wrt``'s own argument parser (a renamed or removed option, subcommand or choice fails), and each ``python SCRIPT
--option`` line names a script of this repository whose source spells that option. Options written in backticks in
the prose are checked the same way: each is an option of some ``wrt`` subcommand, or of the repository script the
README says takes it. The repository files the README names (``wrt/tlas.py``, ``benchmarks/RESULTS.md``,
``docs/*.png``) exist, and every ``wrt.``-dotted name in backticks (``wrt.rays.camera_rays``,
``wrt.shade.MAX_CULL_PASSES``) imports. Links to ``#headings`` lead to a heading, and the log fields the README lists
are those of the rows ``wrt render`` writes.
"""

import argparse
import glob
import importlib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import pytest

from wrt.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
NO_TEST = re.compile(r"<!--\s*no-test:\s*(?P<reason>.*?)\s*-->")
# Options of the repository's own scripts that the README's prose names in backticks (the scripts' bash lines are
# checked against their sources directly).
SCRIPT_OPTIONS = {"--trees": "scenes/forest.py", "--tree-triangles": "scenes/forest.py",
                  "--features": "benchmarks/cuda_compile_time.py"}


class Block(NamedTuple):
    language: str  # the fence's info string: python, bash, or "" for a plain block
    line: int  # 1-based line of the opening fence in README.md
    code: str  # the lines between the fences
    skip: str | None  # the reason of a no-test marker on the line before the fence, else None


def readme_blocks(text: str) -> list[Block]:
    """The fenced code blocks of ``text`` in order, with their no-test markers."""
    blocks, lines, i = [], text.splitlines(), 0
    while i < len(lines):
        if not lines[i].startswith("```"):
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
        marker = NO_TEST.fullmatch(lines[i - 1].strip()) if i > 0 else None
        blocks.append(Block(lines[i][3:].strip(), i + 1, "\n".join(lines[i + 1:end]) + "\n",
                            marker["reason"] if marker else None))
        i = end + 1
    return blocks


BLOCKS = readme_blocks(README.read_text(encoding="utf-8"))
PYTHON_BLOCKS = [b for b in BLOCKS if b.language == "python"]
SHELL_BLOCKS = [b for b in BLOCKS if b.language in ("bash", "sh", "shell")]

CAR_USDA = """#usda 1.0
(
    metersPerUnit = 1
    upAxis = "Y"
)
def Xform "World"
{
    def Xform "Car" (
        variants = {
            string paint = "blue"
            string wheels = "stock"
        }
        prepend variantSets = ["paint", "wheels"]
    )
    {
        variantSet "paint" = {
            "blue" {
                def Cube "Body"
                {
                    color3f[] primvars:displayColor = [(0, 0, 1)]
                }
            }
            "red" {
                def Cube "Body"
                {
                    color3f[] primvars:displayColor = [(1, 0, 0)]
                }
            }
        }
        variantSet "wheels" = {
            "sport" {
                def Sphere "Wheel"
                {
                    double radius = 0.3
                }
            }
            "stock" {
            }
        }
    }
}
"""

SHOT_USDA = """#usda 1.0
(
    metersPerUnit = 1
    renderSettingsPrimPath = "/Render/Final"
    upAxis = "Y"
)
def Xform "Room" (
    references = @scene.usda@</World>
)
{
}
def Scope "Render"
{
    def RenderSettings "Final"
    {
        rel camera = </Room/Camera>
        uniform int2 resolution = (48, 36)
        rel products = </Render/Final/beauty>
        def RenderProduct "beauty"
        {
            uniform token productName = "final.png"
        }
    }
    def RenderSettings "Preview"
    {
        rel camera = </Room/Camera>
        uniform int2 resolution = (32, 24)
        rel products = [</Render/Preview/beauty>, </Render/Preview/aovs>]
        def RenderProduct "beauty"
        {
            uniform token productName = "beauty.png"
        }
        def RenderProduct "aovs"
        {
            uniform token productName = "aovs.exr"
            rel orderedVars = [</Render/Vars/color>, </Render/Vars/depth>]
        }
    }
    def Scope "Vars"
    {
        def RenderVar "color"
        {
            uniform string sourceName = "color"
        }
        def RenderVar "depth"
        {
            uniform string sourceName = "depth"
        }
    }
}
"""


def write_stand_ins(folder: Path) -> None:
    """The small files the README's examples name, in ``folder``."""
    shutil.copy(ROOT / "wrt" / "data" / "default_room.usda", folder / "scene.usda")
    (folder / "car.usda").write_text(CAR_USDA)
    (folder / "shot.usda").write_text(SHOT_USDA)


def test_the_readme_has_python_examples_that_run_and_every_marker_sits_on_a_python_fence():
    """A parser that found no block, or markers that skip everything, would make the test below pass on nothing; a
    marker that is not on the line just before a fence (a blank line between) would be ignored without a word."""
    assert [b for b in PYTHON_BLOCKS if b.skip is None], "no README python block is run"
    lines = README.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, 1):
        if line.lstrip().startswith("<!--") and "no-test" in line:  # a marker, not the prose that explains it
            assert NO_TEST.fullmatch(line.strip()), f"README.md:{number}: write the marker as <!-- no-test: REASON -->"
            assert lines[number].startswith("```python"), f"README.md:{number}: the marker must sit on a python fence"
    assert all(b.skip for b in PYTHON_BLOCKS if b.skip is not None), "a no-test marker needs a reason"


@pytest.mark.parametrize("block", PYTHON_BLOCKS, ids=[f"README.md:{b.line}" for b in PYTHON_BLOCKS])
def test_readme_python_block_runs(block, tmp_path):
    if block.skip:
        pytest.skip(block.skip)
    write_stand_ins(tmp_path)
    (tmp_path / "example.py").write_text(block.code)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    result = subprocess.run([sys.executable, "example.py"], cwd=tmp_path, env=env, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, f"README.md:{block.line}: the example fails:\n{result.stderr[-3000:]}"
    warned = [line for line in result.stderr.splitlines() if "Warning" in line and not line.startswith("Warp")]
    assert warned == [], f"README.md:{block.line}: the example warns"  # a reader would take it for a fault
    for name in re.findall(r"\.save\(\s*\"([^\"]+)\"", block.code):
        assert (tmp_path / name).is_file(), f"README.md:{block.line}: .save({name!r}) wrote nothing"
    for folder in re.findall(r"render_products\(\s*\w+\s*,\s*\"([^\"]+)\"", block.code):
        assert any((tmp_path / folder).iterdir()), f"README.md:{block.line}: render_products wrote nothing"


def command_lines(block: Block) -> list[list[str]]:
    """The commands of a shell block, one argument list each: comments dropped (a ``#`` after a space: ``####``
    in a file name stays), ``&&`` chains split."""
    commands = []
    for line in block.code.splitlines():
        line = re.sub(r"(^|\s)#.*$", "", line).strip()
        for command in filter(None, (part.strip() for part in line.split("&&"))):
            commands.append(shlex.split(command))
    return commands


WRT_COMMANDS = [(b.line, args) for b in SHELL_BLOCKS for args in command_lines(b) if args[0] == "wrt"]
SCRIPT_COMMANDS = [(b.line, args) for b in SHELL_BLOCKS for args in command_lines(b)
                   if args[0] in ("python", "python3") and args[1].endswith(".py")]


@pytest.mark.parametrize("line, args", WRT_COMMANDS, ids=[" ".join(a)[:60] for _, a in WRT_COMMANDS])
def test_readme_wrt_command_line_parses(line, args):
    """The options, subcommands and choices exist; files are not read (a parse runs no command)."""
    if "--help" in args:
        args = [a for a in args if a != "--help"]
    try:
        build_parser().parse_args(args[1:])
    except SystemExit as e:
        pytest.fail(f"README.md block at line {line}: {' '.join(args)!r} does not parse (exit status {e.code})")


# The README's `wrt render` lines that run here, on the stand-ins (a GPU, Dask, --help or the forest left out), at a
# small size: a size given is cut to SMALL, none given is SMALL (but on shot.usda, whose RenderSettings give it), and
# samples per pixel to 2; and its `wrt bvh-stats` lines as written (a second or two on the room).
RUNNABLE_COMMANDS = [(line, args) for line, args in WRT_COMMANDS if args[1] in ("render", "bvh-stats")
                     and not {"--help", "--dask", "--devices"} & set(args)
                     and "forest.usdc" not in args]  # written by scenes/forest.py before it, a minute's work
SMALL = {"--width": "16", "--height": "12"}


def small_render(args: list[str]) -> list[str]:
    """``args`` (from ``render`` on) at a small size and few samples per pixel."""
    args = [SMALL.get(before, "2" if before == "--spp" else arg) for before, arg in zip([None, *args], args)]
    if not {"--products", *SMALL} & set(args) and "shot.usda" not in args:
        args += [option for pair in SMALL.items() for option in pair]
    return args + ["-q"]


@pytest.mark.parametrize("line, args", RUNNABLE_COMMANDS, ids=[" ".join(a)[:60] for _, a in RUNNABLE_COMMANDS])
def test_readme_wrt_command_runs(line, args, tmp_path, monkeypatch):
    """Each runs as a reader typing it into a folder of the files it names would: parsing alone let a line name a
    camera the stand-in scene (the bundled room) has not, `--camera /World/Cam` for its /World/Camera."""
    from wrt.cli import main

    write_stand_ins(tmp_path)
    shutil.copy(tmp_path / "scene.usda", tmp_path / "scene.usd")
    for stem in "abc":
        shutil.copy(tmp_path / "scene.usda", tmp_path / f"{stem}.usd")
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "animated.usda").write_text(ANIMATED_USDA)
    monkeypatch.chdir(tmp_path)
    command = small_render(args[1:]) if args[1] == "render" else args[1:]
    assert main(command) == 0, f"README.md block at line {line}: {' '.join(args)!r} fails"
    if "-o" in args and "{stem}" not in args[args.index("-o") + 1] and "#" not in args[args.index("-o") + 1]:
        assert (tmp_path / args[args.index("-o") + 1]).is_file()


@pytest.mark.parametrize("line, args", SCRIPT_COMMANDS, ids=[" ".join(a)[:60] for _, a in SCRIPT_COMMANDS])
def test_readme_script_command_line_names_a_script_and_its_options(line, args):
    script = ROOT / args[1]
    assert script.is_file(), f"README.md block at line {line}: no script {args[1]}"
    source = script.read_text(encoding="utf-8")
    for option in (a.split("=")[0] for a in args[2:] if a.startswith("--")):
        assert f'"{option}"' in source, f"README.md block at line {line}: {args[1]} has no option {option}"


def wrt_options() -> set[str]:
    """Every long option of ``wrt`` (``--version``) and of every ``wrt`` subcommand."""
    parser = build_parser()
    (subparsers,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    parsers = [parser, *subparsers.choices.values()]
    return {s for p in parsers for a in p._actions for s in a.option_strings}


def test_options_named_in_the_readme_prose_exist():
    text = re.sub(r"^```.*?^```", "", README.read_text(encoding="utf-8"), flags=re.S | re.M)  # prose only
    named = {o for span in re.findall(r"`([^`\n]+)`", text) for o in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", span)}
    known = wrt_options()
    for option, script in SCRIPT_OPTIONS.items():
        assert f'"{option}"' in (ROOT / script).read_text(encoding="utf-8"), f"{script} has no option {option}"
    assert named - known - set(SCRIPT_OPTIONS) == set()


# Files a README command writes (ignored by git), so a fresh clone has them only after that command has run.
GENERATED = {"scenes/animated.usda"}  # scenes/make_animated_scene.py


def test_files_named_in_the_readme_exist():
    text = README.read_text(encoding="utf-8")
    named = {p.rstrip(".,)") for p in re.findall(r"(?<![\w./-])((?:wrt|benchmarks|scenes|tests|docs)/[\w./*-]+)", text)}
    assert GENERATED <= named
    assert {p for p in named - GENERATED if not glob.glob(str(ROOT / p))} == set()


def resolves(name: str) -> bool:
    """Whether the dotted ``wrt....`` name is an attribute or submodule chain of the package."""
    obj, module = importlib.import_module("wrt"), "wrt"
    for part in name.split(".")[1:]:
        module = f"{module}.{part}"
        if hasattr(obj, part):
            obj = getattr(obj, part)
            continue
        try:
            obj = importlib.import_module(module)
        except ImportError:
            return False
    return True


def test_wrt_names_in_the_readme_resolve():
    spans = re.findall(r"`([^`\n]+)`", README.read_text(encoding="utf-8"))
    names = {n for span in spans for n in re.findall(r"(?<![\w/.])wrt(?:\.[A-Za-z_]\w*)+", span)}
    assert len(names) > 10  # the pattern finds them
    assert {n for n in names if not resolves(n)} == set()


def github_anchor(heading: str) -> str:
    """The fragment GitHub gives a Markdown heading: lower case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_links_within_the_readme_name_its_headings():
    """A ``[text](#fragment)`` link whose heading was renamed or removed leads nowhere on GitHub, without a word."""
    text = re.sub(r"^```.*?^```", "", README.read_text(encoding="utf-8"), flags=re.S | re.M)
    anchors = {github_anchor(h) for h in re.findall(r"^#+ (.+)$", text, flags=re.M)}
    links = re.findall(r"\]\(#([^)\s]+)\)", text)
    assert len(links) > 5  # the pattern finds them, links broken across lines included
    assert sorted({link for link in links if link not in anchors}) == []


ANIMATED_USDA = """#usda 1.0
(
    endTimeCode = 2
    startTimeCode = 1
)
def Cube "Box"
{
    double3 xformOp:translate.timeSamples = {1: (0, 0, 0), 2: (0.5, 0, 0)}
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def readme_log_fields() -> tuple[set, set, set]:
    """The log fields the README lists: those of every row, those frame rows add and those frame rows lack."""
    text = " ".join(README.read_text(encoding="utf-8").split())
    rows = text.split("Each row has ", 1)[1].split(" Rows of older", 1)[0]
    every, frames = rows.split("; frame rows add ", 1)
    added, lacked = (frames.split(", and have no ", 1) + [""])[:2]

    def names(part: str) -> set:
        return set(re.findall(r"`([a-z_]+)`", part))

    statuses = names(every.split("`status` (", 1)[1].split(")", 1)[0])  # ok, error with error, ...
    options_note = {"null"}  # "as given: `null` is the stage's or wrt's default"

    def drop_notes(part: str) -> str:  # "(a frame's time is its `frame`; ...)" names no field
        return re.sub(r"\([^()]*\)", "", part)

    return names(every) - statuses - options_note, names(drop_notes(added)), names(drop_notes(lacked))


def test_log_rows_hold_the_fields_the_readme_lists(tmp_path, capsys):
    """Frame rows had ``rebuilt_trees``, and no ``time``, ``aov`` or ``aov_dir``, while the README listed the same
    options for them as for a scene's row."""
    from wrt.cli import default_scene_path, main

    every, added, lacked = readme_log_fields()
    assert {"run", "scene", "width", "output_mtime_ns", "aov_files"} <= every and "frame" in added  # parsed
    size = ["--width", "4", "--height", "3", "-q"]
    assert main(["render", str(default_scene_path()), "-o", str(tmp_path / "one.png"), "--log",
                 str(tmp_path / "one.jsonl"), *size]) == 0
    (scene_row,) = [json.loads(line) for line in (tmp_path / "one.jsonl").read_text().splitlines()]
    assert set(scene_row) == every
    (tmp_path / "animated.usda").write_text(ANIMATED_USDA)
    assert main(["render", str(tmp_path / "animated.usda"), "--frames", "1:2", "-o", str(tmp_path / "f_#.png"),
                 "--log", str(tmp_path / "frames.jsonl"), *size]) == 0
    frame_rows = [json.loads(line) for line in (tmp_path / "frames.jsonl").read_text().splitlines()]
    assert [set(row) for row in frame_rows] == [every - lacked | added] * 2
