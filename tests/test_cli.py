"""The ``wrt`` command line: the default render, options, and one-line errors with exit status 2."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import warp as wp
from conftest import warp_assets
from PIL import Image as PilImage

from wrt.cli import main


def run_cli(*args, cwd=None, env=None, timeout=600):
    """Runs ``python -m wrt.cli ARGS`` in a fresh interpreter, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "wrt.cli", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )


def error_lines(stderr: str) -> list[str]:
    """stderr lines that are not Warp's own start-up notices."""
    return [line for line in stderr.splitlines() if line.strip() and not line.startswith("Warp")]


def test_render_with_no_arguments_writes_the_default_scene(tmp_path):
    result = run_cli("render", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    with PilImage.open(tmp_path / "wrt.png") as png:
        assert png.size == (640, 480)
        pixels = np.asarray(png).astype(float)
    assert pixels.std() > 20  # a real picture, not a flat colour
    assert "rendered 640x480" in result.stderr  # a timing line


def test_render_options_and_aovs(tmp_path):
    out, aovs = tmp_path / "bunny.png", tmp_path / "aovs"
    code = main(
        ["render", str(warp_assets("bunny.usd")), "-o", str(out), "--width", "80", "--height", "60"]
        + ["--spp", "2", "--builder", "binned_sah", "--accel", "wrt", "--device", "cpu", "--aov-dir", str(aovs), "-q"]
    )
    assert code == 0
    with PilImage.open(out) as png:
        assert png.size == (80, 60)
    depth, prim = np.load(aovs / "depth.npy"), np.load(aovs / "prim.npy")
    normal = np.load(aovs / "normal.npy")
    assert depth.shape == (60, 80) and prim.shape == (60, 80) and normal.shape == (60, 80, 3)
    assert (prim >= 0).any() and np.isfinite(depth[prim >= 0]).all()


def test_camera_option_and_npy_output(tmp_path):
    out = tmp_path / "room.npy"
    assert main(["render", "--camera", "/World/Camera", "-o", str(out), "--width", "32", "--height", "24", "-q"]) == 0
    assert np.load(out).shape == (24, 32, 3)


def test_help_explains_the_options():
    result = run_cli("render", "--help")
    assert result.returncode == 0
    options = ("--camera", "--width", "--height", "--spp", "--device", "--builder", "--accel", "--time", "--aov-dir")
    for option in options:
        assert option in result.stdout
    assert "image width in pixels; default: the stage's RenderSettings resolution, else 640" in " ".join(
        result.stdout.split())
    assert "default wrt.png (frame_####.png with --frames)" in " ".join(result.stdout.split())  # said wrt.png only
    for command in ("render", "preview", "bench", "bvh-stats"):  # defaults shown only where there is one
        text = run_cli(command, "--help").stdout
        assert "(default: None)" not in text and "(default: False)" not in text, command
        assert "(default: [])" not in text, command  # --variant, --aov: repeatable, none unless given


def test_help_says_what_the_default_time_and_each_commands_options_are(capsys):
    """--time said 'default: the default time' (which USD's Default time code is, and how wrt reads an attribute of
    time samples only there, it did not say); bvh-stats' --render-settings listed the camera, resolution and products,
    which it makes nothing of, not the includedPurposes it follows; preview's --builder said 'BVH builder' alone; and
    --presplit's K was shown as PRESPLIT."""
    from wrt.cli import build_parser

    commands = build_parser()._commands()
    helps = {name: " ".join(commands[name].format_help().split()) for name in ("render", "preview", "bvh-stats")}
    for name, text in helps.items():
        assert "default: USD's default time (each value authored without a time, else its first time sample)" in text, \
            name
    assert "RenderSettings prim whose includedPurposes choose the prims whose triangles are built over" in \
        helps["bvh-stats"] and "products" not in helps["bvh-stats"]
    assert "--presplit K" in helps["bvh-stats"] and "(default: 8)" in helps["bvh-stats"]
    # preview's listed the products too, which it never writes (render's --products does)
    assert "RenderSettings prim to follow (camera, resolution, aspect ratio conform, data window, included and " \
        "material binding purposes); default:" in helps["preview"] and "products" not in helps["preview"]
    assert "material binding purposes, products); default:" in helps["render"]
    said = "BVH builder of the boxes drawn (--bvh-depth, --bvh-leaves), the --rays and the --image"
    assert "".join(said.split()) in "".join(helps["preview"].split())  # argparse breaks lines after a hyphen


def test_the_preview_window_size_help_names_its_unit(capsys):
    """--window said 'window (or PNG) size (default: 1280x800)': sizes of what, it did not say, where --width and
    --height say 'in pixels'."""
    with pytest.raises(SystemExit):
        main(["preview", "--help"])
    assert "window (or PNG) size in pixels, WIDTHxHEIGHT (default: 1280x800)" in " ".join(
        capsys.readouterr().out.split())


@pytest.mark.parametrize("args, message", [
    (["render", "--wdith", "8"], "unrecognized arguments: --wdith (did you mean '--width'?) (see 'wrt render --help')"),
    (["preview", "--bvh-leafs"], "(did you mean '--bvh-leaves'?) (see 'wrt preview --help')"),
    (["bench", "--repaets=3"], "--repaets=3 (did you mean '--repeats'?) (see 'wrt bench --help')"),
    (["render", "--frobnicate"], "unrecognized arguments: --frobnicate (see 'wrt render --help')"),  # nothing close
    # Before the command: 'the following arguments are required: COMMAND', naming neither the option nor the fix.
    (["--frobnicate"], "unrecognized arguments: --frobnicate (see 'wrt --help')"),
    (["--verison"], "unrecognized arguments: --verison (did you mean '--version'?) (see 'wrt --help')"),
    (["--width", "8", "render"], "unrecognized arguments: --width; it is an option of wrt render, wrt preview: give it "
     "after the command (see 'wrt --help')"),
    # The start of a command's option, before the command: the option it starts, to give in full after the command.
    (["--wid", "8", "render"], "unrecognized arguments: --wid; it is an option of wrt render (--width), wrt preview "
     "(--width): give it after the command, in full (see 'wrt --help')"),
    (["--sp=4", "render"], "unrecognized arguments: --sp=4; it is an option of wrt render (--spp): give it after the "
     "command, in full (see 'wrt --help')"),
    # After the command, an option of wrt itself or of another command: 'unrecognized' alone, or a close option of
    # this command that means something else ('--bvh-depth 3 (did you mean '--max-depth'?)').
    (["render", "--version"], "unrecognized arguments: --version; it is an option of wrt itself: give it before the "
     "command (wrt --version) (see 'wrt render --help')"),
    (["render", "x.usda", "--bvh-depth", "3"], "unrecognized arguments: --bvh-depth 3; it is an option of wrt "
     "preview, not of wrt render (see 'wrt render --help')"),
    (["render", "x.usda", "--bvh-dep", "3"], "unrecognized arguments: --bvh-dep 3; it is an option of wrt preview "
     "(--bvh-depth), not of wrt render (see 'wrt render --help')"),
    (["bvh-stats", "x.usda", "--spp=4"], "unrecognized arguments: --spp=4; it is an option of wrt render, not of wrt "
     "bvh-stats (see 'wrt bvh-stats --help')"),
])
def test_an_unknown_option_is_named_by_its_command_with_the_closest_option(capsys, args, message):
    """An unknown option after a command was reported by the top parser: 'see wrt --help', which lists commands, not
    the options of the command the user typed, and no hint at the option meant."""
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: ") and line.endswith(message), line


@pytest.mark.parametrize("args, message", [
    # argparse read '-output x.png' as '-o utput' (a scene x.png; 'cannot write utput' where that was no scene)...
    (["render", "-output", "x.png"], "-output is no option: long options take two dashes (did you mean '--output'?)"),
    # ... '-quiet' as '-q' given a value ("ignored explicit argument 'uiet'"), '-out=b' as '-o ut=b' ...
    (["render", "-quiet"], "-quiet is no option: long options take two dashes (did you mean '--quiet'?)"),
    (["bench", "-out=b"], "-out=b is no option: long options take two dashes (did you mean '--out'?)"),
    # ... and named '-width', '-widht' and '-O' with no hint.
    (["render", "-width", "8"], "-width is no option: long options take two dashes (did you mean '--width'?)"),
    (["render", "-widht", "8"], "unrecognized arguments: -widht (did you mean '--width'?)"),
    (["render", "-O", "x.png"], "unrecognized arguments: -O (did you mean '-o'?)"),
])
def test_a_long_option_given_one_dash_is_named_with_its_two(capsys, args, message):
    """A long option typed with one dash, as many tools spell theirs, is named with the option meant, whatever short
    option argparse would have read its first letter as."""
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: ") and line.endswith(f"{message} (see 'wrt {args[0]} --help')"), line


def test_short_options_with_attached_values_are_still_read():
    """The one-dash check leaves argparse's own short forms alone: '-oout.png', a value after '--'."""
    from wrt.cli import build_parser

    parsed = build_parser().parse_args(["render", "-oout.png", "-q", "--time", "-1e3", "--", "-width.usda"])
    assert (parsed.output, parsed.quiet, parsed.time, parsed.scene) == ("out.png", True, -1000.0, ["-width.usda"])


@pytest.mark.parametrize("args, abbreviation, option", [
    (["preview", "--bvh-dept", "3"], "--bvh-dept", "--bvh-depth"),
    (["render", "--wid", "8"], "--wid", "--width"),
    (["render", "--sp=4"], "--sp=4", "--spp"),
    (["bench", "--scen", "sphere:100"], "--scen", "--scenes"),
    (["bvh-stats", "--lay", "wide"], "--lay", "--layout"),
    (["--vers"], "--vers", "--version"),
])
def test_an_abbreviated_option_is_refused_naming_it_and_the_option_it_starts(capsys, args, abbreviation, option):
    """argparse took a unique start of a long option for it ('--bvh-dept' for '--bvh-depth'): a script's
    abbreviation changed meaning, or stopped working, when an option of the same start was added. Every parser of
    wrt, the subcommands' too, takes options in full."""
    from wrt.cli import build_parser

    parser = build_parser()
    assert not parser.allow_abbrev and not any(p.allow_abbrev for p in parser._commands().values())
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert f"unrecognized arguments: {abbreviation}" in line and f"(did you mean {option!r}?)" in line, line


def test_the_scripts_beside_wrt_refuse_abbreviated_options_too():
    """The scripts of ``benchmarks/`` and ``scenes/`` (``scenes/forest.py --out`` ...) took an abbreviated long option
    for the one it starts, as wrt's own commands did: every ``argparse.ArgumentParser`` they make (read from their
    source with Python's own parser) passes ``allow_abbrev=False``."""
    import ast

    root = Path(__file__).resolve().parents[1]
    loose = []
    for path in sorted([*root.glob("benchmarks/*.py"), *root.glob("scenes/*.py")]):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) == \
                    "ArgumentParser":
                given = {k.arg: k.value for k in node.keywords}
                if not (isinstance(given.get("allow_abbrev"), ast.Constant) and given["allow_abbrev"].value is False):
                    loose.append(f"{path.relative_to(root)}:{node.lineno}")
    assert loose == []


@pytest.mark.parametrize("args, message", [
    (["rendr"], "argument COMMAND: invalid choice: 'rendr' (did you mean 'render'?) (choose from 'render', "),
    (["render", "--builder", "SAH"], "argument --builder: invalid choice: 'SAH' (did you mean 'sah'?) (choose from"),
    (["render", "--integrator", "pth"], "invalid choice: 'pth' (did you mean 'path'?) (choose from 'whitted', "),
    (["render", "--aov", "dpeth"], "invalid choice: 'dpeth' (did you mean 'depth'?)"),
    (["preview", "--bvh-color", "SAH"], "invalid choice: 'SAH' (did you mean 'sah'?)"),
    (["bvh-stats", "x.usda", "--layout", "wide4"], "invalid choice: 'wide4' (did you mean 'wide'?)"),
    (["render", "--integrator", "xyzzy"], "invalid choice: 'xyzzy' (choose from 'whitted', "),  # nothing close
])
def test_a_misspelt_choice_names_the_one_meant(capsys, args, message):
    """argparse listed the choices only, where misspelt options and the library's own names get a did-you-mean."""
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: ") and message in line, line


@pytest.mark.parametrize("args, message", [
    (["render", "--builder", "SAH"], "invalid choice: 'SAH' (did you mean 'sah'?)"),
    (["preview", "--builder", "LBVH"], "invalid choice: 'LBVH' (did you mean 'lbvh'?)"),
    (["bvh-stats", "x.usda", "--builder", "SAH"], "unknown BVH builder 'SAH' (did you mean 'sah'?)"),  # was taken
    (["bvh-stats", "x.usda", "--builder", "ALL"], "unknown BVH builder 'ALL' (did you mean 'all'?)"),  # was taken
    (["bench", "--accels", "wrt:SAH"], "unknown BVH builder 'SAH' (did you mean 'sah'?)"),  # was taken
    (["bench", "--accels", "warp:SAH"], "wp.Mesh has no builder 'SAH' (did you mean 'sah'?)"),
    (["bench", "--accels", "wrt:sah:WIDE"], "unknown BVH layout 'WIDE' (did you mean 'wide'?)"),
    (["bench", "--rays", "Primary"], "unknown ray kind 'Primary' (did you mean 'primary'?)"),
    (["bench", "--threads", "ALL"], "got 'ALL' (did you mean 'all'?)"),  # no hint
    (["bench", "--devices", "CPU"], "unknown device 'CPU' (did you mean 'cpu'?)"),
])
def test_a_name_in_another_case_is_refused_by_every_command_naming_the_one_meant(tmp_path, capsys, args, message):
    """wrt's names are lower case and exact everywhere (README, Command line): 'bvh-stats --builder SAH' and 'bench
    --accels wrt:SAH' were taken where 'render --builder SAH' and 'bench --accels warp:SAH' were refused."""
    try:
        status = main([*args, "-o", str(tmp_path / "out")] if args[0] == "bench" else args)
    except SystemExit as e:  # an argparse type's error
        status = e.code
    assert status == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: ") and message in line, line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, message", [
    (["bench", "--rays", "foo"], "argument --rays: unknown ray kind 'foo'; valid ray kinds: primary, shadow, "),
    (["bench", "--repeats", "10001"], "argument --repeats: must be at most 10,000 "),
    (["bench", "--threads", "0"], "argument --threads: must be positive integers or 'all', got '0'"),
    (["bench", "--accels", "warp:lbvh", "--devices", "cpu"], "arguments --accels and --devices: accelerator "),
    (["bench", "cpu", "--quick"], "give a suite (cpu) or --quick, not both"),
    (["render", "--workers", "2"], "--workers sizes the LocalCluster of --dask without an ADDRESS"),
    (["render", "--builder", "ploc", "--accel", "warp"], "--builder ploc builds wrt's BVH (--accel wrt)"),
    (["render", "--frames", "2:1"], "--frames range '2:1' is empty (END < START)"),
    (["preview", "--bvh-instance", "1"], "--bvh-instance 1 draws an instance's BVH boxes"),
    (["bvh-stats", "x.usda", "--device", "gpu"], "--device gpu: unknown or unavailable device 'gpu' (did you mean "),
])
def test_an_error_about_the_options_given_ends_as_argparses_do_in_every_command(tmp_path, capsys, args, message):
    """The checks made after parsing ('--rays foo', '--repeats 10001', '--threads 0', '--builder ploc --accel warp')
    ended without the '(see 'wrt bench --help')' that argparse's own errors of the same command end with."""
    try:
        status = main([*args, "-o", str(tmp_path / "out")] if args[0] == "bench" else args)
    except SystemExit as e:
        status = e.code
    assert status == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"wrt: error: {message}") and line.endswith(f" (see 'wrt {args[0]} --help')"), line


def test_an_error_about_a_file_has_no_help_ending(tmp_path, capsys):
    """A missing scene or an image format wrt does not write is about the file, which no option's help mends."""
    for args in (["render", str(tmp_path / "none.usda")], ["render", "-o", str(tmp_path / "x.tif")]):
        assert main(args) == 2
        (line,) = error_lines(capsys.readouterr().err)
        assert line.startswith("wrt: error: ") and "--help" not in line, line


@pytest.mark.parametrize(
    "args, needle",
    [
        (["render", "no/such/file.usda"], "file.usda"),
        (["render", "--builder", "octree"], "octree"),
        (["render", "--width", "0"], "positive"),
        (["render", "--device", "cuda:7"], "available devices"),
        (["render", "--camera", "/Nope"], "/Nope"),
        (["render", "-o", "out.gif"], "supported image formats"),
        (["render", "--width", "100000", "--height", "100000"],
         "100000x100000 is 10,000,000,000 pixels; at most 67,108,864 are supported"),  # was '1 x 100000x100000 is'
        (["render", "--exposure", "inf"], "finite"),
        (["render", "--exposure", "2000"], "[-150, 150]"),  # an OverflowError traceback after the render
        (["render", "--time", "nan"], "finite"),
        # Refused before the load (it was, after loading the scene and building its tree).
        (["render", "no/such/file.usda", "--ao-radius", "0"], "argument --ao-radius: must be a positive number, got 0"),
        (["render", "--ao-radius", "-1"], "argument --ao-radius: must be a positive number, got -1"),
        (["render", "--time", "-inf"], "must be a finite number, got -inf"),  # was "expected one argument"
        (["render", "--seed", "2147483648"], "seed must be an integer from 0 to 2147483647"),  # wrapped onto seed 0
        (["render", "--workers", "3"], "--workers sizes the LocalCluster"),  # was ignored
        (["render", "--frames", "1:2", "--time", "0"], "--time cannot be combined with --frames"),  # 0 was ignored
        # Saying what writes every frame's AOVs; an AOV file on an image's path is refused before any frame.
        (["render", "--frames", "1:2", "--aov", "depth"], "--aov cannot be combined with --frames; --aov-dir DIR "
                                                         "writes every frame's AOVs as arrays"),
        (["render", "--frames", "1:2", "-o", "d/depth_##.npy", "--aov-dir", "d"],
         "the AOV file d/depth_01.npy of frame 1 would also be frame 1's image; give the images or the AOV files "
         "other names"),
        (["render", "--frames", "1:2", "--dask", "tcp://h:8786", "--workers", "3"], "--workers sizes"),
        (["render", "--frames", "1:2", "--devices", "cpu,cpu", "--dask"], "--devices or --dask, not both"),
        (["frobnicate"], "frobnicate"),
        # Found before the frames, in load_usd's words: a folder was a failed load at every frame ('frames 1, 2: ...')
        (["render", ".", "--frames", "1:2"], "wrt: error: .: a directory, not a USD file"),
        (["render", "no/such.usda", "--frames", "1:2"], "wrt: error: no/such.usda: file not found"),  # 'no such file'
    ],
)
def test_bad_input_is_one_line_and_exit_status_2(tmp_path, capsys, monkeypatch, args, needle):
    monkeypatch.chdir(tmp_path)  # default outputs (wrt.png, frame_####.png) must not land in the repository
    with pytest.raises(SystemExit) as exit_info:
        small = args[0] == "render" and "--width" not in args
        sys.exit(main(args + ["--width", "8", "--height", "8"] if small else args))
    assert exit_info.value.code == 2
    lines = error_lines(capsys.readouterr().err)
    errors = [line for line in lines if line.startswith("wrt: error:")]
    assert len(errors) == 1 and needle in errors[0]
    assert not any("Traceback" in line for line in lines)


@pytest.mark.skipif(wp.is_cuda_available(), reason="needs a machine without CUDA")
def test_a_cuda_device_without_cuda_is_one_line_not_warps_native_errors(tmp_path):
    """README: bad input prints one line. Without a CUDA driver, --device cuda printed Warp's native 'Warp CUDA error:
    Function cuCtxGetCurrent_f: a suitable driver entry point was not found' (and its error code) before wrt's line."""
    for device in ("cuda", "cuda:0"):
        result = run_cli("render", "--device", device, "--width", "8", "--height", "8", "-q", cwd=tmp_path, timeout=120)
        assert result.returncode == 2
        assert "CUDA error" not in result.stderr, result.stderr
        (line,) = error_lines(result.stderr)
        assert line == (f"wrt: error: --device {device}: unknown or unavailable device '{device}'; available "
                        "devices: cpu (see 'wrt render --help')"), line


def test_a_camera_not_on_the_stage_names_the_file_and_the_prim(tmp_path, capsys):
    """README: errors name the file and the prim. One scene rendered said only "no camera at '/Nope'"; a batch
    added the file."""
    scene = tmp_path / "one.usda"
    scene.write_text('#usda 1.0\ndef Sphere "Ball" {}\n')
    assert main(["render", str(scene), "--camera", "/Nope", "-o", str(tmp_path / "x.png"), "-q"]) == 2
    errors = [line for line in error_lines(capsys.readouterr().err) if line.startswith("wrt: error:")]
    assert len(errors) == 1 and str(scene) in errors[0] and "/Nope" in errors[0], errors


def _box_and_cameras(tmp_path, n_cameras: int) -> Path:
    """A stage of a Cube at /Box and ``n_cameras`` cameras /Cam0, /Cam1, ..."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "box.usda"))
    UsdGeom.Cube.Define(stage, "/Box")
    for i in range(n_cameras):
        UsdGeom.Camera.Define(stage, f"/Cam{i}").AddTranslateOp().Set((0.0, 0.0, 10.0 + i))
    stage.GetRootLayer().Save()
    return tmp_path / "box.usda"


def test_a_camera_path_naming_another_prim_says_what_prim_it_is_and_lists_a_few_cameras(tmp_path, capsys):
    """'--camera /Box', a Cube, said "no camera at '/Box'" as for a path where nothing is: it now says what the
    stage holds there (USD's type name) and lists the first cameras, not all of a stage's thousands."""
    from pxr import Usd

    scene = _box_and_cameras(tmp_path, 9)
    stage = Usd.Stage.Open(str(scene))
    kind = stage.GetPrimAtPath("/Box").GetTypeName()
    assert main(["render", str(scene), "--camera", "/Box", "-o", str(tmp_path / "x.png"), "-q"]) == 2
    (error,) = [line for line in error_lines(capsys.readouterr().err) if line.startswith("wrt: error:")]
    assert f"'/Box' is a {kind}, not a camera; cameras in the scene: /Cam0, /Cam1, /Cam2, /Cam3, /Cam4, /Cam5 and 3 " \
        "more" in error, error
    assert str(scene) in error


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_scene_that_is_a_pipe_or_a_folder_is_a_one_line_error_not_a_hang(tmp_path):
    """README: bad input prints one line and exits 2. A named pipe given as the scene (``wrt render <(...)``, or a
    FIFO left in place of a file) made USD wait for a writer: the render hung; a folder got USD's 'Cannot determine
    file format'."""
    os.mkfifo(tmp_path / "pipe.usda")
    (tmp_path / "folder.usda").mkdir()
    for name, needle in (("pipe.usda", "pipe.usda: a pipe or device, not a USD file"),
                         ("folder.usda", "folder.usda: a directory, not a USD file")):
        try:
            result = run_cli("render", name, "--width", "8", "--height", "8", cwd=tmp_path, timeout=60)
        except subprocess.TimeoutExpired:
            pytest.fail(f"wrt render {name} hung")
        errors = [line for line in error_lines(result.stderr) if line.startswith("wrt: error:")]
        assert result.returncode == 2 and len(errors) == 1 and needle in errors[0], result.stderr


@pytest.mark.parametrize("scenes", [["no/such/a.usda"], ["no/such/a.usda", "no/such/b.usda"]])
def test_a_logged_or_batch_render_that_renders_nothing_exits_with_status_2(tmp_path, capsys, scenes):
    """README: bad input exits with status 2; a batch in which some scenes failed, 1 (the others were rendered). A
    batch in which every scene failed, and one missing scene with ``--log``, exited 1 where the same scene alone
    exits 2, and where ``--frames`` exits 2 when no frame could be rendered. The log still names each failure."""
    log = tmp_path / "log.jsonl"
    code = main(["render", *scenes, "-o", str(tmp_path / "{stem}.png"), "--log", str(log), "-q"])
    assert code == 2
    rows = [line for line in log.read_text().splitlines() if line]
    assert len(rows) == len(scenes) and all('"status": "error"' in row for row in rows)
    errors = [line for line in error_lines(capsys.readouterr().err) if line.startswith("wrt: error:")]
    assert [name in " ".join(errors) for name in ("a.usda", "b.usda")[: len(scenes)]] == [True] * len(scenes)


def test_a_batch_goes_on_past_a_scene_that_fails_inside_wrt(tmp_path, capsys, monkeypatch):
    """README: in a batch a failing scene is logged and the rest go on. A scene that failed with an error other than
    the input errors wrt expects (an IndexError of a bug in a loader) stopped the batch with a traceback, leaving the
    scenes after it unrendered and unlogged; wrt bench turns any such error into an error row."""
    import wrt

    scenes = []
    for name in ("a", "bug", "c"):
        scenes.append(tmp_path / f"{name}.usda")
        scenes[-1].write_text('#usda 1.0\ndef Sphere "Ball" {}\n')
    load = wrt.load_usd

    def load_with_a_bug(path, **kwargs):
        if Path(path).stem == "bug":
            raise IndexError("index 7 is out of bounds for axis 0 with size 3")
        return load(path, **kwargs)

    monkeypatch.setattr(wrt, "load_usd", load_with_a_bug)
    out = tmp_path / "out"
    code = main(["render", *map(str, scenes), "-o", f"{out}/", "--width", "8", "--height", "6", "-q"])
    assert code == 1
    rows = [json.loads(line) for line in (out / "render-log.jsonl").read_text().splitlines()]
    assert [(Path(r["scene"]).stem, r["status"]) for r in rows] == [("a", "ok"), ("bug", "error"), ("c", "ok")]
    assert rows[1]["error"] == "IndexError: index 7 is out of bounds for axis 0 with size 3"
    assert sorted(p.name for p in out.glob("*.png")) == ["a.png", "c.png"]
    err = capsys.readouterr().err
    assert "bug.usda: IndexError: index 7 is out of bounds" in err and "1 of 3 scenes failed: bug.usda" in err


def test_a_kernel_cache_that_cannot_be_made_is_named_with_what_to_do(tmp_path):
    """Warp makes its kernel cache when it starts; in a missing or read-only home that failed with the bare OS error,
    'wrt: error: [Errno 2] No such file or directory: '/home/x'', which says neither what nor why."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    env = {**os.environ, "WARP_CACHE_PATH": str(blocker / "cache")}
    result = run_cli("render", "--width", "8", "--height", "8", cwd=tmp_path, env=env)
    assert result.returncode == 2
    (line,) = error_lines(result.stderr)[-1:]
    assert line.startswith("wrt: error:") and "kernel cache" in line and "set WARP_CACHE_PATH" in line, line
    assert not (tmp_path / "wrt.png").exists()


def test_output_problems_are_one_line_errors_found_before_rendering(tmp_path, capsys):
    """An unwritable format fails before the scene is even loaded; an output path under a regular file (an OS error
    other than a missing file) or an image or log path that is a directory is one line and exit status 2 as well,
    for render, preview and bench, before any scene is loaded."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    folder = tmp_path / "a_folder.png"  # a directory where the image or log must go: found after the render before
    folder.mkdir()
    small = ["--width", "8", "--height", "8"]
    two = [str(warp_assets("bunny.usd")), str(warp_assets("cube.usd"))]
    cases = [
        (["render", *small, "-o", str(folder)], "a_folder.png: it is a directory"),
        (["render", *two, *small, "-o", str(tmp_path / "imgs"), "--log", str(folder)], "it is a directory"),
        (["render", *small, "-o", str(tmp_path / "ok.png"), "--log", str(blocker / "log.jsonl")], "a_file"),
        # The log where the images' folder goes (not there yet) or where an image goes: both would fail only at the
        # first log row, after a render.
        (["render", *two, *small, "-o", str(tmp_path / "imgs"), "--log", str(tmp_path / "imgs")], "a file name of its"),
        (["render", *small, "-o", str(tmp_path / "ok.png"), "--log", str(tmp_path / "ok.png")], "a file name of its"),
        (["render", *small, "--frames", "0:1", "-o", str(tmp_path / "fr/f_#.png"), "--log", str(tmp_path / "fr")],
         "a file name of its"),
        (["preview", "-o", str(folder)], "a_folder.png: it is a directory"),
        (["preview", "-o", str(blocker / "p.png")], "a_file"),
        (["render", "--width", "8", "--height", "8", "-o", str(tmp_path / "out.xyz")], "supported image formats"),
        (["render", "--width", "8", "--height", "8", "-o", str(blocker / "x.png")], "a_file"),
        (["render", "--width", "8", "--height", "8", "-o", str(tmp_path / "ok.png"), "--aov-dir", str(blocker)],
         "a_file"),
        (["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--rays", "primary", "-q", "-o", str(blocker)],
         "a_file"),
    ]
    for args, needle in cases:
        assert main(args) == 2, args
        lines = error_lines(capsys.readouterr().err)
        errors = [line for line in lines if line.startswith("wrt: error:")]
        assert len(errors) == 1 and needle in errors[0], lines
        assert not any("Traceback" in line or "loaded" in line for line in lines), lines
    assert not (tmp_path / "out.xyz").exists() and not (tmp_path / "imgs").exists()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, where no one creates files")
@pytest.mark.parametrize("output", ["/proc/x.png", "/proc/x.exr", "/proc/sub/x.npy", "/proc/x_#.png"])
def test_output_in_a_folder_that_takes_no_files_is_one_line_error_before_rendering(output, capsys):
    """A folder that takes no files (no write permission; /proc even for root) was found only when the image was
    saved, after the render: a .png or .npy error named the temporary file beside the target
    ('/proc/.x.png.<pid>.0.partial.png'), and a .exr one was a traceback (OpenEXR's RuntimeError). The reason was
    the OS's for a file made there, 'No such file or directory', of a folder that is there."""
    frames = ["--frames", "0:1"] if "#" in output else []
    assert main(["render", "--width", "8", "--height", "8", "-o", output, *frames]) == 2
    lines = error_lines(capsys.readouterr().err)
    errors = [line for line in lines if line.startswith("wrt: error:")]
    assert errors == [f"wrt: error: cannot write into {Path(output).parent}: /proc takes no new files (its file "
                      "system makes no files)"], lines
    assert not any("partial" in line or "loaded" in line or "Traceback" in line for line in lines), lines


def test_broken_usd_file_names_file_in_one_line(tmp_path):
    bad = tmp_path / "broken.usda"
    bad.write_bytes(b"#usda 1.0\n(\n this is not usd {{{\n")
    result = run_cli("render", str(bad), "-o", str(tmp_path / "x.png"))
    assert result.returncode == 2
    lines = error_lines(result.stderr)
    assert len(lines) == 1 and "broken.usda" in lines[0] and "Traceback" not in result.stderr


def test_accel_warp_renders_a_stage_with_gprims_as_triangle_meshes(tmp_path):
    """``--accel warp`` stopped on any stage with a gprim, telling the user to pass ``tessellate_gprims=True``, a
    Python option the command line does not have."""
    import wrt

    scene = tmp_path / "gprims.usda"
    scene.write_text('#usda 1.0\n(\n    upAxis = "Y"\n)\ndef Xform "World"\n{\n    def Sphere "Ball"\n    {\n'
                     '        double radius = 1\n    }\n    def Cube "Box"\n    {\n        double size = 1\n'
                     '        double3 xformOp:translate = (2.5, 0, 0)\n'
                     '        uniform token[] xformOpOrder = ["xformOp:translate"]\n    }\n}\n')
    out = tmp_path / "warp.npy"
    assert main(["render", str(scene), "--accel", "warp", "-o", str(out), "--width", "40", "--height", "30",
                 "-q"]) == 0
    expected = wrt.render(wrt.load_usd(scene, tessellate_gprims=True), accel="warp", width=40, height=30)
    np.testing.assert_array_equal(np.load(out), expected.rgb)
    assert expected.aovs["prim"].max() >= 0  # the gprims are in the picture
    frames = tmp_path / "f_#.npy"
    assert main(["render", str(scene), "--accel", "warp", "--frames", "1:1", "-o", str(frames), "--width", "40",
                 "--height", "30", "-q"]) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "f_1.npy"), expected.rgb)


def test_python_dash_m_wrt_runs_the_command_line(tmp_path):
    """``python -m wrt`` said "No module named wrt.__main__"; only ``python -m wrt.cli`` worked."""
    result = subprocess.run([sys.executable, "-m", "wrt", "render", "-o", str(tmp_path / "room.npy"), "--width", "8",
                             "--height", "6", "-q"], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert np.load(tmp_path / "room.npy").shape == (6, 8, 3)
    bad = subprocess.run([sys.executable, "-m", "wrt", "render", "--width", "0"], capture_output=True, text=True,
                         timeout=600)
    assert bad.returncode == 2 and error_lines(bad.stderr)[-1].startswith("wrt: error: argument --width")


def test_output_ending_in_a_slash_is_a_folder(tmp_path):
    """``-o renders/`` wrote an image file named ``renders``: Path() drops the trailing slash."""
    from wrt.cli import default_scene_path

    folder = tmp_path / "renders"
    assert main(["render", "-o", f"{folder}/", "--width", "8", "--height", "6", "-q"]) == 0
    assert folder.is_dir()
    with PilImage.open(folder / "default_room.png") as png:
        assert png.size == (8, 6)
    # With --frames too (it was the pattern "renders_####", refused for having no image suffix).
    assert main(["render", str(default_scene_path()), "--frames", "2:2", "-o", f"{folder}/", "--width", "8",
                 "--height", "6", "-q"]) == 0
    with PilImage.open(folder / "default_room_0002.png") as png:
        assert png.size == (8, 6)


@pytest.mark.parametrize("frames", [[], ["--frames", "1:1"]])
def test_output_naming_an_existing_folder_without_a_slash_says_so(tmp_path, capsys, frames):
    """``-o renders`` where the folder ``renders`` exists (the slash forgotten) said "cannot write renders:
    supported image formats are .png, .exr, .npy" (``renders_0001`` with --frames), as if the format were wrong."""
    folder = tmp_path / "renders"
    folder.mkdir()
    assert main(["render", "-o", str(folder), "--width", "8", "--height", "6", "-q", *frames]) == 2
    errors = [line for line in error_lines(capsys.readouterr().err) if line.startswith("wrt: error:")]
    assert len(errors) == 1 and f"{folder}: it is a directory" in errors[0] and f"-o {folder}/" in errors[0], errors
    assert list(folder.iterdir()) == []


def test_a_frame_number_no_file_name_can_spell_is_refused_before_any_render(tmp_path, capsys, monkeypatch):
    """``--frames 1e300`` is finite, so it was taken: the frame was loaded and rendered, and only the write of its
    311-character file name failed ('File name too long'). Now one line, exit 2, and nothing rendered."""
    from wrt.animation import FrameRenderer

    def no_render(*args, **kwargs):
        raise AssertionError("the frame was rendered")

    monkeypatch.setattr(FrameRenderer, "render", no_render)
    out = tmp_path / "out"
    assert main(["render", "--frames", "1e300", "-o", f"{out}/f_####.png", "--width", "4", "--height", "4",
                 "-q"]) == 2
    errors = [line for line in error_lines(capsys.readouterr().err) if line.startswith("wrt: error:")]
    # Named by the option typed (it was 'frame_output: frame 1e+300: ...', a function of the library).
    assert errors == ["wrt: error: --frames '1e300': frames must lie within +-999,999,999,999 (a file name spells a "
                      "frame to 12 significant digits) (see 'wrt render --help')"], errors
    assert not out.exists()


def test_interrupted_render_saves_the_samples_it_has(tmp_path, monkeypatch, capsys):
    """Ctrl-C during a long ``wrt render`` saved nothing. The image of the samples finished so far is written, and
    it is the image a render with that many samples gives; the exit status stays 130."""
    import importlib

    import wrt
    from wrt.cli import default_scene_path

    render_module = importlib.import_module("wrt.render")  # ``wrt.render`` is also the function

    width, height = 8, 6
    monkeypatch.setattr(render_module, "MAX_PATHS_PER_LAUNCH", width * height)  # one sample per launch
    real_start = render_module.Renderer._start_and_trace
    launches = []

    def interrupt_on_the_third_launch(self, *args, **kwargs):
        launches.append(1)
        if len(launches) == 3:
            raise KeyboardInterrupt
        return real_start(self, *args, **kwargs)

    monkeypatch.setattr(render_module.Renderer, "_start_and_trace", interrupt_on_the_third_launch)
    out = tmp_path / "partial.npy"
    args = ["render", "-o", str(out), "--width", str(width), "--height", str(height), "--integrator", "path",
            "--spp", "16", "--seed", "3"]
    assert main([*args, "-q"]) == 130  # said with -q too: the file under the final name holds two samples only
    assert f"wrt: warning: interrupted after 2 of 16 spp: wrote {out}, the image of those samples only" in \
        capsys.readouterr().err.splitlines()
    monkeypatch.setattr(render_module.Renderer, "_start_and_trace", real_start)
    scene = wrt.load_usd(default_scene_path())
    two = wrt.Renderer(scene, width=width, height=height, integrator="path").render(spp=2, seed=3)
    np.testing.assert_allclose(np.load(out), two.rgb, rtol=1e-5, atol=1e-6)


def test_a_render_interrupted_in_its_first_launch_says_no_image_was_written(tmp_path, monkeypatch, capsys):
    """A render of few samples is one launch (as many samples per pixel as fit in MAX_PATHS_PER_LAUNCH paths): Ctrl-C
    in it had no samples to save and stopped with 'wrt: interrupted' alone, where README promises the image of the
    samples done so far after Ctrl-C. It says that none was written."""
    import importlib

    render_module = importlib.import_module("wrt.render")  # ``wrt.render`` is also the function

    def interrupt(self, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(render_module.Renderer, "_start_and_trace", interrupt)
    out = tmp_path / "partial.png"
    assert main(["render", "-o", str(out), "--width", "8", "--height", "6", "--spp", "2", "-q"]) == 130
    assert f"wrt: warning: interrupted before the first launch of samples finished: {out} was not written" in \
        capsys.readouterr().err.splitlines()
    assert not out.exists()


def test_negative_values_in_exponent_form_are_values_not_options(tmp_path):
    """Before Python 3.13 argparse took ``--time -1e3`` for an option and refused it: "expected one argument"."""
    out = tmp_path / "t.npy"
    assert main(["render", "--time", "-1e3", "-o", str(out), "--width", "4", "--height", "3", "-q"]) == 0
    assert np.load(out).shape == (3, 4, 3)


GPRIM_STAGE = """#usda 1.0
def Sphere "Ball"
{
    double radius = 1
}
def Cube "Box"
{
    double3 xformOp:translate = (3, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def test_render_progress_line_counts_shapes_and_instances(tmp_path, capsys):
    """A stage of two gprims was announced as 'loaded ...: 0 triangles in 0 meshes', and instanced scenes by
    their non-instanced meshes alone, as if the rest had not loaded."""
    from wrt.cli import loaded_summary
    from wrt.procedural import sensor_scene

    path = tmp_path / "gprims.usda"
    path.write_text(GPRIM_STAGE)
    assert main(["render", str(path), "-o", str(tmp_path / "g.png"), "--width", "8", "--height", "6"]) == 0
    assert "loaded gprims.usda: 2 analytic shapes (" in capsys.readouterr().err  # no "0 triangles in 0 meshes"
    stats = sensor_scene().stats()
    line = loaded_summary("s", stats)
    assert f"{stats['instances']:,} instances of {stats['prototypes']:,} prototype" in line
    forest = {"meshes": 0, "rendered_triangles": 2_472_000, "instances": 1000, "prototypes": 5, "rendered_shapes": 0}
    assert loaded_summary("f", forest) == "loaded f: 2,472,000 triangles in 1,000 instances of 5 prototypes"
    empty = {**forest, "rendered_triangles": 0, "instances": 0}
    assert loaded_summary("e", empty) == "loaded e: 0 triangles in 0 meshes"
    assert f"{stats['rendered_shapes']:,} analytic shapes" in line


def test_load_warnings_under_the_frames_progress_bar_get_lines_of_their_own(tmp_path, capsys, monkeypatch):
    """A stage that warns when loaded, rendered with --frames: the warning was printed after the bar's "wrt frames:
    0%|...|" without a line break, so a terminal showed it glued to the bar. Each warning must be the visible text
    of its own line (what is left after the last carriage return)."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)  # the bar is drawn on a terminal only
    stage = tmp_path / "warns.usda"
    stage.write_text('#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 2\n)\n'
                     'def Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n'
                     '    color3f[] primvars:displayColor = [(nan, 0, 0)]\n}\n')
    assert main(["render", str(stage), "--frames", "1:2", "--width", "8", "--height", "6",
                 "-o", str(tmp_path / "f_####.png")]) == 0
    err = capsys.readouterr().err
    assert "wrt frames" in err  # the bar was drawn
    visible = [line.rsplit("\r", 1)[-1] for line in err.split("\n")]
    warned = [line for line in visible if "wrt: warning:" in line]
    assert warned and all(line.startswith("wrt: warning:") for line in warned), warned


def test_progress_bars_are_drawn_on_a_terminal_only(tmp_path, capsys, monkeypatch):
    """A single render drew its bar only when stderr was a terminal, but --frames and wrt bench drew theirs into a
    log file too, a line per redraw. Under capsys stderr is no terminal: no bar; made to say it is one: the bars."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    frames = ["render", str(stage), "--frames", "1:2", "--width", "8", "--height", "6", "-o", str(tmp_path / "f_#.npy")]
    bench = ["bench", "--scenes", "sphere:200", "--accels", "warp:sah", "--rays", "primary", "--n-rays", "300",
             "--repeats", "1", "-o", str(tmp_path / "bench")]
    for argv, bar in ((frames, "wrt frames"), (bench, "wrt bench")):
        assert main(argv) == 0
        err = capsys.readouterr().err
        assert bar not in err and "\r" not in err, err
    assert main([*frames[:3], "1:1", *frames[4:]]) == 0
    assert "wrt: rendered 1 frame on cpu" in capsys.readouterr().err  # "rendered 1 frames"
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    for argv, bar in ((frames, "wrt frames"), (bench, "wrt bench")):
        assert main(argv) == 0
        assert bar in capsys.readouterr().err


def test_integrator_options_the_integrator_does_not_use_are_warned_about(tmp_path, capsys):
    """--ao-radius without --integrator ao, and --max-depth with an integrator that does not bounce, rendered the image
    they would give without the option, without a word."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    cases = ((["--ao-radius", "0.01"], "--ao-radius applies to --integrator ao only; whitted does not use it"),
             (["--integrator", "ao", "--ao-radius", "0.01"], None),
             (["--integrator", "normals", "--max-depth", "0"], "--max-depth applies to --integrator path and whitted "
              "only; normals does not use it"),
             (["--integrator", "normals"], None),
             (["--max-depth", "0"], None))  # whitted: no mirrors at depth 0
    images = []
    for i, (options, warning) in enumerate(cases):
        output = tmp_path / f"{i}.npy"
        assert main(["render", str(stage), "--width", "8", "--height", "6", "-q", "-o", str(output), *options]) == 0
        warned = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: warning:")]
        assert warned == ([f"wrt: warning: {warning}"] if warning else []), options
        images.append(np.load(output))
    whitted = tmp_path / "whitted.npy"
    assert main(["render", str(stage), "--width", "8", "--height", "6", "-q", "-o", str(whitted)]) == 0
    np.testing.assert_array_equal(images[0], np.load(whitted))  # what the warnings say: the option changed nothing
    np.testing.assert_array_equal(images[2], images[3])


@pytest.mark.parametrize("integrator", ["normals", "depth", "albedo"])
def test_spp_given_to_a_quick_look_is_warned_about_and_not_reported_as_rendered(tmp_path, capsys, integrator):
    """The quick looks draw one sample per pixel whatever --spp says, yet --integrator normals --spp 16 said
    'rendered 8x6 at 16 spp (normals)' without a word about the 15 samples never drawn. It is now named in a warning,
    as --max-depth is, and the line says the one sample drawn; the image is that of --spp 1."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    images = []
    for spp in ("16", "1"):
        output = tmp_path / f"{spp}.npy"
        assert main(["render", str(stage), "--width", "8", "--height", "6", "-o", str(output),
                     "--integrator", integrator, "--spp", spp]) == 0
        lines = capsys.readouterr().err.splitlines()
        warned = [line for line in lines if line.startswith("wrt: warning:")]
        assert warned == ([f"wrt: warning: --spp applies to --integrator whitted, path and ao only; {integrator} "
                           "draws one sample per pixel, through its centre"] if spp == "16" else []), warned
        assert any(line.startswith(f"wrt: rendered 8x6 at 1 spp ({integrator})") for line in lines), lines
        images.append(np.load(output))
    np.testing.assert_array_equal(images[0], images[1])


@pytest.mark.parametrize("frames", [False, True])
def test_a_log_ending_in_a_slash_is_refused_as_a_folder(tmp_path, capsys, frames):
    """-o out/ names a folder, but --log logs/ wrote the rows into a file called 'logs' ('log in logs'), where a later
    -o logs/ could not make its folder. It is refused before anything renders, with the file name meant."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    output = str(tmp_path / ("f_#.png" if frames else "x.png"))
    with pytest.raises(SystemExit) as exit_info:
        main(["render", str(stage), "-o", output, "--width", "8", "--height", "6", "--log", f"{tmp_path}/logs/"]
             + ["--frames", "1:2"] * frames)
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"wrt: error: argument --log: {tmp_path}/logs/ names a folder; give the log a file name, "
                           f"e.g. {tmp_path}/logs/render-log.jsonl"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tri.usda"]


def test_an_output_placeholder_other_than_stem_is_warned_about(tmp_path, capsys):
    """{stem} is -o's one placeholder; a misspelt one ('{steam}', '{Stem}') was written into the file name as it is,
    '{steam}.png', without a word."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    small = ["--width", "8", "--height", "6", "-q"]
    for pattern, warned in (("{steam}.png", "{steam}"), ("{stem}.png", None), ("{stem}_{Stem}.png", "{Stem}")):
        assert main(["render", str(stage), *small, "-o", str(tmp_path / pattern)]) == 0
        lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: warning:")]
        if warned is None:
            assert lines == [], pattern
        else:
            assert len(lines) == 1 and f"{warned} is no placeholder" in lines[0] and "{stem}" in lines[0], lines
        assert (tmp_path / pattern.replace("{stem}", "tri")).is_file()  # as the warning says: kept as it is
    other = tmp_path / "other.usda"
    other.write_text(stage.read_text())
    with pytest.raises(SystemExit) as exit_info:
        sys.exit(main(["render", str(stage), str(other), *small, "-o", str(tmp_path / "out" / "{name}.png")]))
    assert exit_info.value.code == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert "{name} is no placeholder" in lines[0] and "names one image for 2 scenes" in lines[1], lines


def test_an_aov_given_twice_is_written_and_logged_once(tmp_path, capsys):
    """--aov depth --aov depth wrote out.depth.png twice ('wrote out.depth.png' two lines) and logged aov
    ['depth', 'depth'], so a --resume with --aov depth, the same files, rendered the scene again ('options changed
    ... --aov depth,depth -> depth'). Each AOV is taken once, in the order first given."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    out, log = tmp_path / "out.png", tmp_path / "log.jsonl"
    common = ["render", str(stage), "-o", str(out), "--log", str(log), "--width", "8", "--height", "6"]
    assert main([*common, "--aov", "depth", "--aov", "cost", "--aov", "depth"]) == 0
    wrote = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: wrote")]
    assert wrote == [f"wrt: wrote {out}", f"wrt: wrote {tmp_path / 'out.depth.png'}",
                     f"wrt: wrote {tmp_path / 'out.cost.png'}"], wrote
    (row,) = [json.loads(line) for line in log.read_text().splitlines()]
    assert row["aov"] == ["depth", "cost"] and row["status"] == "ok"
    assert main([*common, "--aov", "depth", "--aov", "cost", "--resume"]) == 0
    assert "skipped tri.usda" in capsys.readouterr().err
    assert json.loads(log.read_text().splitlines()[-1])["status"] == "skipped"


@pytest.mark.parametrize("command", ["render", "preview"])
def test_an_image_name_given_as_a_scene_is_refused_pointing_at_dash_o(tmp_path, capsys, monkeypatch, command):
    """'wrt render scene.usda out.png' rendered scene.usda to scene.png, not out.png, then failed on out.png as a
    scene ('file not found', or 'USD cannot open this file' where an earlier out.png exists), status 1."""
    monkeypatch.chdir(tmp_path)
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    scenes = [str(stage), "out.png"] if command == "render" else ["out.png"]
    with pytest.raises(SystemExit) as exit_info:
        sys.exit(main([command, *scenes, "--width", "8", "--height", "6", "-q"]))
    assert exit_info.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "out.png" in errors[0] and "-o out.png" in errors[0], errors
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tri.usda"]  # nothing rendered
    if command == "render":  # an image that exists ('wrt render scenes/*' took in a thumbnail): the batch goes on
        (tmp_path / "thumb.png").write_bytes(b"\x89PNG\r\n\x1a\n")
        assert main([command, str(stage), "thumb.png", "-o", "out/", "--width", "8", "--height", "6", "-q"]) == 1
        assert (tmp_path / "out" / "tri.png").is_file()


@pytest.mark.parametrize("frames", [False, True])
def test_exposure_with_a_linear_output_is_warned_about(tmp_path, capsys, frames):
    """--exposure scales PNGs only: with .exr or .npy output it did nothing, without a word."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    extra = ["--width", "8", "--height", "6"] + (["--frames", "1:1"] if frames else [])
    mark = "_#" if frames else ""
    for name, exposure, warns in (("a.png", "2", False), ("b.npy", "2", True), ("c.npy", "0", False)):
        stem, suffix = name.split(".")
        output = tmp_path / f"{stem}{mark}.{suffix}"
        assert main(["render", str(stage), *extra, "--exposure", exposure, "-o", str(output)]) == 0
        warned = [line for line in capsys.readouterr().err.splitlines() if "--exposure applies to .png" in line]
        assert len(warned) == warns, (name, warned)
    written = {stem: np.load(tmp_path / f"{stem}{'_1' if frames else ''}.npy") for stem in "bc"}
    np.testing.assert_array_equal(written["b"], written["c"])  # what the warning says: written unscaled


def test_counts_of_a_single_scene_frame_or_row_read_in_the_singular(tmp_path, capsys):
    """A run of one scene, frame or bench row said '1 of 1 scenes rendered', '1 of 1 frames failed', '1 rows
    measured'; the counts of several keep 'N of M'."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 2\n)\ndef Mesh "M"\n{\n'
                     '    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points.timeSamples = {1: [(0, 0, 0), (1, 0, 0), (0, 1, 0)],\n'
                     '                                    2: [(nan, 0, 0), (1, 0, 0), (0, 1, 0)]}\n}\n')
    small = ["--width", "8", "--height", "6", "-q"]
    assert main(["render", str(stage), "--time", "1", "--log", str(tmp_path / "a.jsonl"), "-o",
                 str(tmp_path / "a.npy"), "--width", "8", "--height", "6"]) == 0
    err = capsys.readouterr().err
    assert "wrt: 1 scene rendered; log in" in err and " of 1 " not in err, err
    assert main(["render", str(tmp_path / "missing.usda"), "--log", str(tmp_path / "b.jsonl"), *small]) == 2
    assert "wrt: 1 scene failed: missing.usda" in capsys.readouterr().err
    assert main(["render", str(stage), str(tmp_path / "missing.usda"), "-o", str(tmp_path / "two/"), *small]) == 1
    assert "wrt: 1 of 2 scenes failed: missing.usda" in capsys.readouterr().err
    frames = ["render", str(stage), "-o", str(tmp_path / "f_#.npy"), *small, "--frames"]
    assert main([*frames, "2"]) == 2  # NaN points at time 2
    assert "wrt: 1 frame failed" in capsys.readouterr().err
    assert main([*frames, "1:2"]) == 1
    assert "wrt: 1 of 2 frames failed" in capsys.readouterr().err
    assert main([arg for arg in frames if arg != "-q"] + ["1", "--resume"]) == 0
    assert "wrt: --resume: 1 frame already on disk" in capsys.readouterr().err
    assert main(["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--rays", "primary", "--n-rays", "300",
                 "--repeats", "1", "-o", str(tmp_path / "bench"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "wrt: 1 row measured, 0 resumed, 0 failed;" in err
    assert "wrt: warning: 1 row not checked against warp:sah" in err


@pytest.mark.parametrize("value", ["lots", "-4G", "0"])
def test_a_bad_max_memory_is_refused_before_any_scene_loads_naming_the_option(tmp_path, capsys, value):
    """--max-memory was read after each scene's load: 'cannot read memory size' without the option's name, once per
    scene of a batch, and 0 refused every render as needing more than '0 B'."""
    with pytest.raises(SystemExit) as exit_info:
        main(["render", "-o", str(tmp_path / "x.png"), "--max-memory", value])
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: argument --max-memory: "), line
    assert not (tmp_path / "x.png").exists()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, where no one creates files")
def test_a_bench_output_folder_that_cannot_be_made_is_named(capsys):
    """wrt bench -o /proc/b said only '[Errno 2] No such file or directory: '/proc/b'', as render's -o says what
    stands in the way."""
    assert main(["bench", "--scenes", "sphere:200", "--accels", "wrt:sah", "--rays", "primary", "-q", "-o",
                 "/proc/wrt-bench"]) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: cannot write into /proc/wrt-bench: /proc takes no new files"), line


def test_every_option_that_takes_a_value_says_its_default():
    """wrt bench's --scenes, --n-rays, --repeats (...) and render's --workers said nothing of what a run uses without
    them (the suite's values; a worker per GPU or core). An option whose absence means 'off' (--frames, --aov) needs
    none; every other one shows its default, or its help says it."""
    import argparse

    from wrt.cli import build_parser

    off_when_absent = {"--variant", "--frames", "--dask", "--aov-dir", "--products", "--aov", "--bvh-depth",
                      "--bvh-instance", "--output"}
    commands = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)).choices
    silent = []
    for name, command in commands.items():
        for action in command._actions:
            if not action.option_strings or action.nargs == 0 or action.option_strings[-1] in off_when_absent:
                continue
            shown = not (action.default is None or action.default is False or action.default == [])
            if not shown and "default" not in (action.help or ""):
                silent.append(f"{name} {action.option_strings[-1]}")
    assert silent == []


@pytest.mark.parametrize("frames", [[], ["--frames", "1:2"]])
def test_a_log_at_a_scene_file_is_refused_and_the_scene_left_as_it_was(tmp_path, capsys, frames):
    """--log naming the scene rendered appended its JSON rows to the USD file: the stage was broken for good (and
    --frames failed every later frame reading it)."""
    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    before = stage.read_bytes()
    assert main(["render", str(stage), "--log", str(stage), "-o", str(tmp_path / "f_#.npy"), "--width", "8",
                 "--height", "6", "-q", *frames]) == 2
    # Without --frames, -o f_#.npy is also warned about (a # is a frame number with --frames only).
    (line,) = [line for line in error_lines(capsys.readouterr().err) if line.startswith("wrt: error")]
    assert line.startswith("wrt: error: --log") and "tri.usda" in line and "scene" in line, line
    assert stage.read_bytes() == before


@pytest.mark.parametrize("command, option", [("render", o) for o in ("-o", "--log", "--aov-dir", "--products",
                                                                       "--frames", "--devices")] + [("preview", "-o")])
def test_an_empty_value_is_refused_naming_the_option(tmp_path, capsys, command, option):
    """An empty value ('--frames ""' from an unset shell variable) was taken as no option: --frames "" rendered one
    image to the file 'f_#.png', -o "" wrote wrt.png, --products "" wrote into the current folder; wrt preview -o ""
    said 'cannot write : previews are written as .png'."""
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--width", "8", "--height", "6", "-q", option, ""])
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"wrt: error: argument {option}") and "empty" in line, line


@pytest.mark.parametrize("command", [["render", "a.usda", "b.usda", "-o", "out/"], ["render", "a.usda"],
                                     ["preview", "a.usda", "-o", "p.png"], ["bvh-stats", "a.usda"],
                                     ["render", "a.usda", "--frames", "1:2", "-o", "out/f_#.png", "--devices", "cpu"]])
def test_a_bad_device_is_one_error_before_any_scene_loads(tmp_path, capsys, command):
    """--device gpu was looked up only once a scene had loaded: each scene of a batch loaded, then failed as if it
    were the scene's fault ('a.usda: unknown or unavailable device'), and the log listed every scene as failed. The
    error names the option (it named only the value; bvh-stats and --frames --devices, only after the load)."""
    option = "--devices" if "--devices" in command else "--device"
    if option == "--devices":
        command = command[:-1]  # its value is the bad one
    stage = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
             '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(stage)
    argv = [str(tmp_path / a) if a.endswith((".usda", "/", ".png")) else a for a in command]
    size = [] if command[0] == "bvh-stats" else ["--width", "8", "--height", "6"]
    assert main([*argv, *(["gpu"] if option == "--devices" else ["--device", "gpu"]), *size]) == 2
    (line,) = error_lines(capsys.readouterr().err)  # no 'loaded' line
    # 'gpu' names the one meant, as wrt bench --devices gpu does.
    assert line == (f"wrt: error: {option} gpu: unknown or unavailable device 'gpu' (did you mean 'cuda'?); available "
                    f"devices: {', '.join(d.alias for d in wp.get_devices())} (see 'wrt {command[0]} --help')"), line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", [["render", "a.usda", "b.usda", "-o", "out/"], ["render", "a.usda"],
                                     ["preview", "a.usda", "-o", "p.png"],
                                     ["render", "a.usda", "--frames", "1:2", "-o", "out/f_#.png"]])
def test_a_bad_thread_count_in_the_environment_is_one_error_before_any_scene_loads(tmp_path, capsys, monkeypatch,
                                                                                  command):
    """WRT_THREADS=0 was read at the first launch: each scene of a batch loaded and built its BVH, then failed as if
    it were the scene's fault ('a.usda: the WRT_THREADS environment variable must be ...'), and the log listed
    every scene as failed, as a bad --device did. It is one error before any load now."""
    monkeypatch.setenv("WRT_THREADS", "0")
    stage = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
             '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(stage)
    monkeypatch.chdir(tmp_path)
    assert main([*command, "--width", "8", "--height", "6"]) == 2
    (line,) = error_lines(capsys.readouterr().err)  # no 'loaded' line
    assert line == "wrt: error: the WRT_THREADS environment variable must be a positive integer or 'all', got '0'", \
        line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usda", "b.usda"]


@pytest.mark.parametrize("device", ["CPU", "cpu:0", "cpuu"])
def test_a_misspelt_device_names_the_one_meant(tmp_path, capsys, device):
    """--device CPU said 'unknown or unavailable device' and listed the devices, where --devices of wrt bench says
    '(did you mean 'cpu'?)'."""
    assert main(["render", "no/such.usda", "--device", device, "-o", str(tmp_path / "x.png")]) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert f"unknown or unavailable device {device!r} (did you mean 'cpu'?)" in line, line


def test_an_interrupted_batch_logs_the_scene_cut_short(tmp_path, ctrl_c_after):
    """Ctrl-C in a batch kept the rows of the scenes done but wrote none for the scene cut short, whose image (the
    samples done so far) then looked like a finished one; its row now says it was interrupted."""
    ctrl_c_after("b.usda")
    stage = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
             '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    scenes = []
    for name in ("a.usda", "b.usda", "c.usda"):
        scenes.append(tmp_path / name)
        scenes[-1].write_text(stage)
    out = tmp_path / "out"
    assert main(["render", *map(str, scenes), "-o", f"{out}/", "--width", "8", "--height", "6", "-q"]) == 130
    rows = [json.loads(line) for line in (out / "render-log.jsonl").read_text().splitlines()]
    assert [(Path(r["scene"]).name, r["status"]) for r in rows] == [("a.usda", "ok"), ("b.usda", "interrupted")]
    assert sorted(p.name for p in out.glob("*.png")) == ["a.png", "b.png"]


def test_a_batch_into_a_folder_per_scene_logs_in_the_folder_that_holds_them_all(tmp_path, monkeypatch):
    """'-o out/{stem}/' writes out/a/a.png and out/b/b.png; the batch log went into out/a, the first scene's folder,
    where a user looking for the batch's log (README: out/render-log.jsonl) does not find it."""
    stage = ('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
             '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    for name in ("a.usda", "b.usda"):
        (tmp_path / name).write_text(stage)
    monkeypatch.chdir(tmp_path)
    assert main(["render", "a.usda", "b.usda", "-o", "out/{stem}/", "--width", "8", "--height", "6", "-q"]) == 0
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*.png")) == ["out/a/a.png", "out/b/b.png"]
    assert [p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("render-log.jsonl")] == [
        "out/render-log.jsonl"]
    rows = [json.loads(line) for line in (tmp_path / "out" / "render-log.jsonl").read_text().splitlines()]
    assert [(r["scene"], r["status"]) for r in rows] == [("a.usda", "ok"), ("b.usda", "ok")]


def test_version_option_prints_the_versions_of_wrt_and_warp(capsys):
    """``wrt --version`` said "the following arguments are required: COMMAND" with exit status 2."""
    import re

    pyproject = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text(encoding="utf-8")
    version = re.search(r'^version = "([^"]+)"', pyproject, re.MULTILINE).group(1)
    with pytest.raises(SystemExit) as exit_info:  # '--vers' is refused as every abbreviation is
        main(["--version"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"wrt {version} ") and f"warp-lang {wp.config.version}" in out, out


def test_a_scene_given_twice_is_named_as_such(tmp_path, capsys, monkeypatch):
    """'wrt render a.usda ./a.usda' said 'a.usda and ./a.usda would both write out/a.png ... rename one': renaming
    the one file would not help; it is given twice."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    monkeypatch.chdir(tmp_path)
    assert main(["render", "a.usda", str(tmp_path / "a.usda"), "-o", "out/", "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert errors == [f"wrt: error: {tmp_path / 'a.usda'} is given twice (as a.usda and {tmp_path / 'a.usda'}); "
                      "give each scene once"]
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, message", [
    (["render", "-o", "{dir}/.png"], "cannot write .png: the file name is an extension alone; give a name before it, "
                                     "e.g. {dir}/image.png"),  # was 'supported image formats are .png, ...'
    (["render", "--frames", "1:2", "-o", "{dir}/.EXR"], "cannot write .EXR: the file name is an extension alone"),
    (["render", "-o", "{dir}/x.png "], "cannot write '{dir}/x.png ': supported image formats are .png, .exr, .npy"),
    # A file with no image extension is named by the path given: 'cannot write null' for /dev/null named no folder.
    (["render", "-o", "{dir}/renders/null"], "cannot write {dir}/renders/null: the file name has no extension (e.g. "
                                             "null.png); supported image formats are .png, .exr, .npy"),
    # A name without an extension is told so: it was told only the formats, as if its extension were a wrong one.
    (["render", "-o", "{dir}/out"], "cannot write {dir}/out: the file name has no extension (e.g. out.png); "
                                    "supported image formats are .png, .exr, .npy"),
    (["render", "--frames", "1:2", "-o", "{dir}/out"], "cannot write {dir}/out_0001: the file name has no extension"),
    # A name ending in a dot: it was told 'e.g. out..png', a name of no extension either.
    (["render", "-o", "{dir}/out."], "cannot write {dir}/out.: the file name has no extension (e.g. out.png); "),
    (["preview", "-o", "{dir}/out."], "cannot write {dir}/out.: the file name has no extension (e.g. out.png); "),
    (["render", "-o", "{dir}/out.tif"], "cannot write {dir}/out.tif: supported image formats are .png, .exr, .npy"),
    (["preview", "-o", "{dir}/.png"], "cannot write .png: the file name is an extension alone"),  # 'written as .png'
    # Named as render names it: 'cannot write out: previews are written as .png' read as a wrong extension.
    (["preview", "-o", "{dir}/out"], "cannot write {dir}/out: the file name has no extension (e.g. out.png); "
                                     "previews are written as .png"),
    (["preview", "-o", "{dir}/out.jpg"], "cannot write {dir}/out.jpg: previews are written as .png"),
    # A folder not yet made: 'cannot write views: previews are written as .png', its / dropped; one that exists said
    # 'it is a directory'.
    (["preview", "-o", "{dir}/views/"], "cannot write {dir}/views/: it names a folder; give the preview a .png file "
                                        "name, e.g. {dir}/views/preview.png"),
])
def test_an_output_name_without_an_image_extension_says_what_is_wrong(tmp_path, capsys, args, message):
    (tmp_path / "a.usda").write_text("#usda 1.0\n")  # refused before it is read
    args = [a.replace("{dir}", str(tmp_path)) for a in args]
    assert main([args[0], str(tmp_path / "a.usda"), *args[1:], "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(errors) == 1 and errors[0].startswith("wrt: error: " + message.replace("{dir}", str(tmp_path))), errors
    assert list(tmp_path.iterdir()) == [tmp_path / "a.usda"]


@pytest.mark.parametrize("content", [b"my notes\n", b"\x89PNG\r\n\x1a\n\x00\x00"])
def test_a_log_that_is_another_file_is_refused_before_a_render(tmp_path, capsys, content):
    """--log naming notes or an image appended JSON rows to it; only a later --resume said it was no log."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    log = tmp_path / "notes.txt"
    log.write_bytes(content)
    args = ["render", str(tmp_path / "a.usda"), "-o", str(tmp_path / "out") + "/", "--log", str(log), "-q"]
    assert main(args) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert errors == [f"wrt: error: --log {log}: line 1 is not a JSON row, so the file is no log of wrt's; rows are "
                      "appended to a log: give a new file, or the log of an earlier wrt render (see 'wrt render "
                      "--help')"], errors
    assert log.read_bytes() == content and not (tmp_path / "out").exists()
    log.write_text("\n" + json.dumps({"run": "r", "scene": "x.usda", "status": "ok"}) + "\n")  # a log: appended to
    assert main(args) == 0 and len(log.read_text().split("\n")) == 4  # "", the row before, the new one, ""


def test_warp_lbvh_on_the_cpu_is_said_once_in_wrts_words_and_renders_warps_sah_tree(tmp_path, capfd):
    """--accel warp --builder lbvh on the CPU printed Warp's own 'LBVH constructor is not available for a CPU tree',
    naming no option, and the progress line said 'built warp BVH (lbvh)' of the sah tree that Warp built."""
    size = ["--width", "16", "--height", "12", "--accel", "warp", "--device", "cpu"]
    assert main(["render", "-o", str(tmp_path / "asked.npy"), *size, "--builder", "lbvh"]) == 0
    err = capfd.readouterr().err
    assert "LBVH constructor" not in err, err
    said = [line for line in err.splitlines() if line.startswith("wrt: warning")]
    assert said == ["wrt: warning: --builder lbvh with --accel warp: wp.Mesh has no lbvh builder on the CPU (--device "
                    "cpu), so it builds its sah tree, which finds the same hits"], said
    assert "built warp BVH (sah) on cpu" in err
    assert main(["render", "-o", str(tmp_path / "sah.npy"), *size, "--builder", "sah", "-q"]) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "asked.npy"), np.load(tmp_path / "sah.npy"))


def test_warps_lbvh_fallback_names_the_devices_option_that_chose_the_cpus():
    import argparse

    from wrt.cli import _check_builder

    args = argparse.Namespace(accel="warp", builder="lbvh", device="cpu", devices="cpu,cpu", dask=None)
    with pytest.warns(UserWarning, match=r"on the CPU \(--devices cpu,cpu\), so it builds its sah tree"):
        _check_builder(args)


def test_the_api_says_warps_lbvh_fallback_on_the_cpu_in_its_own_words(capfd):
    import wrt
    from wrt.cli import default_scene_path

    scene = wrt.load_usd(default_scene_path())
    with pytest.warns(UserWarning, match="accel='warp' with builder='lbvh': wp.Mesh has no lbvh builder on the CPU") \
            as caught:
        renderer = wrt.Renderer(scene, width=4, height=3, accel="warp", builder="lbvh", device="cpu")
    assert [w.filename for w in caught if "builder='lbvh'" in str(w.message)] == [__file__]  # the caller's line
    renderer.render()
    assert "LBVH constructor" not in capfd.readouterr().err


@pytest.mark.parametrize("accel, builder, message", [
    ("warp", "ploc", "--builder ploc builds wrt's BVH (--accel wrt); --accel warp builds Warp's wp.Mesh, whose "
                     "builders are sah, median, lbvh, cubql"),
    ("wrt", "cubql", "--builder cubql builds Warp's wp.Mesh (--accel warp); wrt's BVH (--accel wrt, the default) is "
                     "built by sah, sweep_sah, median, middle, lbvh, ploc"),
])
def test_a_builder_the_accelerator_has_not_is_refused_before_the_load(tmp_path, capsys, accel, builder, message):
    """--accel warp --builder ploc loaded the scene, then failed in the library's words ('valid builders for
    accel='warp': (...)'); cubql, a wp.Mesh builder, was no choice of --builder at all."""
    scene = tmp_path / "a.usda"
    scene.write_text("#usda 1.0\n")
    assert main(["render", str(scene), "-o", str(tmp_path / "a.png"), "--accel", accel, "--builder", builder]) == 2
    err = capsys.readouterr().err.splitlines()
    assert [line for line in err if line.startswith("wrt: ")] == [f"wrt: error: {message} (see 'wrt render --help')"], \
        err
    assert sorted(tmp_path.iterdir()) == [scene]


def test_warp_cubql_renders_what_warp_sah_renders(tmp_path):
    size = ["--width", "16", "--height", "12", "--accel", "warp", "-q"]
    for builder in ("cubql", "sah"):
        assert main(["render", "-o", str(tmp_path / f"{builder}.npy"), *size, "--builder", builder]) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "cubql.npy"), np.load(tmp_path / "sah.npy"))


def test_a_frame_pattern_without_frames_is_warned_about(tmp_path, capsys):
    """-o out/frame_####.png without --frames rendered one image into a file named 'frame_####.png' without a word."""
    scene = tmp_path / "a.usda"
    scene.write_text('#usda 1.0\ndef Sphere "S" {}\n')
    output = tmp_path / "frame_####.png"
    assert main(["render", str(scene), "-o", str(output), "--width", "4", "--height", "3", "-q"]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: warning")]
    assert warned == [f"wrt: warning: -o {output}: a run of # is the frame number with --frames only; without it one "
                      "image is rendered, its file name keeping the # as they are"], warned
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usda", "frame_####.png"]


@pytest.mark.parametrize("name", ["out.png", "frames/f.EXR", "depth.npy"])
def test_a_log_named_as_an_image_is_refused(tmp_path, capsys, name):
    """--log out.png (-o and --log swapped) wrote the JSON rows into a new file named out.png."""
    scene = tmp_path / "a.usda"
    scene.write_text("#usda 1.0\n")
    log = tmp_path / name
    assert main(["render", str(scene), "-o", str(tmp_path / "a.png"), "--log", str(log), "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert errors == [f"wrt: error: --log {log} names an image; the log is JSON lines: give it a file name of its "
                      "own, e.g. --log render-log.jsonl, and the image with -o (see 'wrt render --help')"], errors
    assert sorted(tmp_path.iterdir()) == [scene]


def test_a_log_that_is_wrt_bench_rows_is_refused_naming_what_it_holds(tmp_path, capsys):
    """--log bench-out/rows.jsonl (a JSON-lines file, as a log is) took wrt bench's timings for a render log: the
    render appended its rows there, and the next 'wrt bench --resume' stopped at them as no benchmark rows;
    --resume read it as a log naming no image and rendered everything."""
    bench = tmp_path / "bench-out"
    assert main(["bench", "--scenes", "sphere:100", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
                 "--n-rays", "16", "--repeats", "1", "--threads", "1", "-o", str(bench), "-q"]) == 0
    rows = bench / "rows.jsonl"
    before = rows.read_bytes()
    first = json.loads(before.splitlines()[0])
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    capsys.readouterr()
    for resume in ([], ["--resume"]):
        args = ["render", str(tmp_path / "a.usda"), "-o", str(tmp_path / "out") + "/", "--log", str(rows), *resume]
        assert main([*args, "-q"]) == 2
        errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
        assert errors == [f"wrt: error: --log {rows}: line 1 is a row of wrt bench (sphere:100 / {first['accel']} / "
                          "primary rays), so the file holds benchmark timings, not a render log; rows are appended to "
                          "a log: give a new file, or the log of an earlier wrt render (see 'wrt render --help')"], \
            errors
        assert rows.read_bytes() == before and not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, message", [
    (["render", ""], "argument scene: is empty"),  # was '.: a directory, not a USD file'
    (["render", "{dir}/a.usda", " "], "argument scene: is empty"),
    (["preview", "", "-o", "{dir}/p.png"], "argument scene: is empty"),  # showed the bundled room, status 0
    (["bvh-stats", ""], "argument scene: is empty"),  # was 'file not found', naming no file
    (["bench", ""], "argument suite: is empty"),
    (["render", "{dir}/a.usda", "--camera", ""], "argument --camera: is empty"),
    (["render", "{dir}/a.usda", "--render-settings", ""], "argument --render-settings: is empty"),  # ' is nothing'
    # "--device : unknown or unavailable device ''", after the option with nothing between it and the colon.
    (["render", "{dir}/a.usda", "--device", ""], "argument --device: is empty"),
    (["preview", "{dir}/a.usda", "--device", " "], "argument --device: is empty"),
    (["bvh-stats", "{dir}/a.usda", "--device", ""], "argument --device: is empty"),
])
def test_an_empty_scene_or_prim_path_is_named_as_empty(tmp_path, capsys, args, message):
    """An unset shell variable ('wrt preview "$SCENE"') gives an empty argument: it was read as the current folder, a
    prim path '', or no scene at all."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    with pytest.raises(SystemExit) as exit_info:
        main([a.replace("{dir}", str(tmp_path)) for a in args])
    assert exit_info.value.code == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"wrt: error: {message} (see 'wrt {args[0]} --help')"), line
    assert sorted(tmp_path.iterdir()) == [tmp_path / "a.usda"]


def test_a_log_that_is_a_pipe_is_refused_and_dev_null_taken(tmp_path, capsys):
    """A FIFO as --log failed after the first scene's render ('File or stream is not seekable'); the check of a log's
    first line must not block on reading one. /dev/null keeps no log, as before."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    fifo = tmp_path / "log.fifo"
    os.mkfifo(fifo)
    args = ["render", str(tmp_path / "a.usda"), "-o", str(tmp_path / "out") + "/", "-q", "--width", "4", "--height",
            "4"]
    assert main([*args, "--log", str(fifo)]) == 2
    assert error_lines(capsys.readouterr().err) == [f"wrt: error: --log {fifo}: a pipe or socket, not a file (see "
                                                    "'wrt render --help')"]
    assert not (tmp_path / "out").exists()
    assert main([*args, "--log", os.devnull]) == 0 and (tmp_path / "out" / "a.png").is_file()


@pytest.mark.skipif(not os.path.isdir("/dev/fd"), reason="/dev/fd names a process's open files on Linux and macOS")
def test_a_log_that_is_a_stream_is_refused_as_such_before_a_render(tmp_path, capsys):
    """--log /dev/stdout into a pipe was refused as 'cannot write into /proc/PID/fd: ... takes no new files' (the
    path it resolves to), on a terminal as 'cannot write into /dev/pts: ... takes no new files': the folder of a
    file that exists was checked for new files (so a user's --log /dev/null failed on /dev too)."""
    pty = pytest.importorskip("pty")
    (tmp_path / "a.usda").write_text("#usda 1.0\n")
    args = ["render", str(tmp_path / "a.usda"), "-o", str(tmp_path / "out") + "/", "-q", "--width", "4", "--height",
            "4"]
    read, write = os.pipe()
    terminal, other_end = pty.openpty()
    try:
        pipe, tty = f"/dev/fd/{write}", os.ttyname(other_end)
        for log, what in ((pipe, "a pipe or socket, not a file"),
                          (tty, "a terminal or another stream that rows cannot be appended to, not a file")):
            assert main([*args, "--log", log]) == 2
            ending = " (see 'wrt render --help')"
            assert error_lines(capsys.readouterr().err) == [f"wrt: error: --log {log}: {what}{ending}"]
            assert not (tmp_path / "out").exists()
    finally:
        for fd in (read, write, terminal, other_end):
            os.close(fd)


def test_exposure_help_states_the_range_the_option_accepts(capsys):
    """--exposure refused values beyond +-150 stops, a range its help did not give."""
    import re

    from wrt.cli import build_parser

    parser = build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args(["render", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    low, high = map(float, re.search(r"--exposure EXPOSURE .*?from (-?[\d.]+) to (-?[\d.]+)\)", help_text).groups())
    for value in (low, high):
        assert parser.parse_args(["render", "--exposure", repr(value)]).exposure == value
    for value in (low - 1, high + 1):
        with pytest.raises(SystemExit):
            parser.parse_args(["render", "--exposure", repr(value)])
    capsys.readouterr()


def test_exposure_help_names_the_integrators_whose_images_it_leaves_as_they_are(capsys):
    """--exposure said 'PNG only' and nothing more, while a PNG of the normals or depth integrator is written without
    it (their images are data; the run warns only once the option is given)."""
    import re

    from wrt.cli import build_parser
    from wrt.render import DATA_INTEGRATORS

    with pytest.raises(SystemExit):
        build_parser().parse_args(["render", "--help"])
    help_text = re.search(r"--exposure EXPOSURE (.*?) --aov", " ".join(capsys.readouterr().out.split())).group(1)
    assert "integrator" in help_text and all(name in help_text for name in DATA_INTEGRATORS), help_text


@pytest.mark.parametrize("option", ["-o", "--aov-dir", "--log"])
def test_an_os_error_names_the_path_first_without_python_s_errno(tmp_path, capsys, monkeypatch, option):
    """A name longer than the file system takes (255 bytes) read '[Errno 36] File name too long: ...': Python's
    wording, the path last; now the path first, as wrt's own errors name it."""
    monkeypatch.chdir(tmp_path)
    name = "a" * 300 + (".png" if option == "-o" else "")
    assert main(["render", "--width", "8", "--height", "6", "-q", option, name]) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith("wrt: error: ") and line.endswith(f"{name}: file name too long"), line
    assert not list(tmp_path.iterdir())


def test_an_os_error_about_a_file_descriptor_is_worded_naming_the_descriptor(capsys, monkeypatch):
    """An OS error of a file descriptor (``os.stat(fd)`` of a closed one: ``filename`` is the int) raised TypeError
    in ``error_line`` (``os.fsdecode(int)``) and in the kernel-cache hint (``Path(int)``): a traceback in place of
    the one line. Python's own strerror is the oracle of the wording."""
    import errno

    import wrt.cli

    fd = os.open(os.devnull, os.O_RDONLY)
    os.close(fd)
    with pytest.raises(OSError) as raised:
        os.stat(fd)
    assert raised.value.filename == fd
    monkeypatch.setattr(wrt.cli, "build_parser", lambda: FailingParser(raised.value))
    assert main([]) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line == f"wrt: error: file descriptor {fd}: {os.strerror(errno.EBADF).lower()}", line
    missing = Path(wp.config.kernel_cache_dir or "/") / "missing"  # named by bytes: Path(bytes) raised TypeError
    with pytest.raises(OSError) as raised:
        os.stat(os.fsencode(missing))
    assert main([]) == 2
    (line,) = error_lines(capsys.readouterr().err)
    assert line.startswith(f"wrt: error: {missing}: {os.strerror(errno.ENOENT).lower()}"), line


class FailingParser:
    """A parser whose command raises ``error``."""

    def __init__(self, error: Exception):
        self.error = error

    def parse_args(self, argv):
        def run(args):
            raise self.error

        return type("Args", (), {"run": staticmethod(run)})()


def test_a_reader_that_closes_stdout_ends_the_run_quietly(tmp_path):
    """'wrt bvh-stats scene.usda | head -1': the reader gone, the run said 'wrt: error: [Errno 32] Broken pipe' with
    status 2, the status of bad input. Now nothing is said and the status is a SIGPIPE's, 141, as other tools give."""
    scene = tmp_path / "box.usda"
    scene.write_text('#usda 1.0\ndef Cube "Box"\n{\n}\n')
    process = subprocess.Popen([sys.executable, "-m", "wrt.cli", "bvh-stats", str(scene)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    process.stdout.close()  # before the table is printed: the load and the build come first
    stderr = process.stderr.read()
    assert process.wait(timeout=600) == 141, stderr
    assert error_lines(stderr) == []


def test_a_double_dash_before_the_command_ends_the_options_as_python_3_13_reads_it(capsys):
    """``wrt -- render`` said "invalid choice: '--'": ``--`` ends the options, and Python 3.13's argparse drops the
    one before a subcommand (gh-53780), so it parses as ``wrt render``; the ``--`` after the command is the command's
    (a scene named ``-s.usda``). A ``--`` with no command after it is named."""
    from wrt.cli import build_parser

    def parsed(argv):
        return vars(build_parser().parse_args(argv))

    assert parsed(["--", "render", "--width", "8"]) == parsed(["render", "--width", "8"])
    assert parsed(["--", "render", "--", "-s.usda"])["scene"] == parsed(["render", "--", "-s.usda"])["scene"]
    for argv, after in ((["--"], "nothing"), (["--", "--version"], "'--version'")):
        with pytest.raises(SystemExit) as exited:
            build_parser().parse_args(argv)
        assert exited.value.code == 2
        (line,) = error_lines(capsys.readouterr().err)
        assert line.startswith(f"wrt: error: '--' ends the options: a COMMAND (render, preview, bench, bvh-stats) "
                               f"must follow it, got {after}"), line


def test_an_image_too_large_names_the_render_settings_that_sized_it(tmp_path, capsys):
    """A stage's RenderSettings resolution past the pixel limit was refused (before any allocation) as
    "2147483647x2 is ... pixels", which with -q did not say where that size came from: the settings are named now
    (the prim path as USD reads it), with the option where one side was given."""
    from pxr import Gf, Usd, UsdRender

    path = tmp_path / "huge.usda"
    stage = Usd.Stage.CreateNew(str(path))
    stage.DefinePrim("/Ball", "Sphere")
    settings = UsdRender.Settings.Define(stage, "/Render/Huge")
    settings.CreateResolutionAttr(Gf.Vec2i(2**31 - 1, 2))
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Huge")
    stage.Save()
    prim = str(UsdRender.Settings.GetStageRenderSettings(Usd.Stage.Open(str(path))).GetPath())
    for options, source in (([], f"resolution of {prim}"), (["--height", "4"], f"--height 4, aspect of {prim}")):
        assert main(["render", str(path), "-q", "-o", str(tmp_path / "x.png"), *options]) == 2
        (line,) = error_lines(capsys.readouterr().err)
        height = int(options[1]) if options else 2
        width = (2**31 - 1) * height // 2
        ending = " (see 'wrt render --help')" if options else ""  # the error names --height
        assert line == f"wrt: error: {source}: {width}x{height} is {width * height:,} pixels; at most {2**26:,} are " \
                       f"supported{ending}", line
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("text, value", [("1e5", 100_000), ("2E6", 2_000_000), ("1.5e1", 15), ("300", 300)])
def test_integer_options_take_whole_numbers_in_exponent_notation(text, value):
    """``wrt bench --n-rays 1e5`` was refused as 'not an integer' while ``--scenes sphere:1e6`` is taken: whole
    numbers in exponent notation are integers now; fractions, overflows and words still are not."""
    from wrt.cli import build_parser

    assert build_parser().parse_args(["bench", "--n-rays", text]).n_rays == value


@pytest.mark.parametrize("option", [["bench", "--n-rays"], ["render", "--spp"], ["render", "--seed"],
                                    ["render", "--refine-level"], ["render", "--max-depth"],
                                    ["preview", "--bvh-depth"], ["preview", "--bvh-instance"]])
@pytest.mark.parametrize("text", ["2.0", "2.", "0.2e1", "2"])
def test_integer_options_take_whole_numbers_written_with_a_zero_fraction(option, text):
    """``--n-rays 1000.0`` was refused as 'not an integer' where a suite's ``"n_rays": 1000.0`` was taken, and
    ``--seed`` and ``--refine-level`` refused even ``1e3`` (``--bvh-instance 2.0`` was a path): every integer option
    reads a whole number in decimal, as ``decimal.Decimal`` (the oracle) does."""
    from decimal import Decimal

    from wrt.cli import build_parser

    dest = option[1].lstrip("-").replace("-", "_")
    assert getattr(build_parser().parse_args([*option, text]), dest) == int(Decimal(text))


@pytest.mark.parametrize("text, size", [("64.0x48", (64, 48)), ("6.4e1x4.8E1", (64, 48)), ("64x48", (64, 48))])
def test_the_preview_window_size_takes_whole_numbers_as_the_integer_options_do(text, size, capsys):
    """``--window 64.0x48`` was refused as 'not WIDTHxHEIGHT' where ``--width 64.0`` is taken; fractions and words
    still are refused (the oracle: decimal.Decimal's reading of each side)."""
    from decimal import Decimal

    from wrt.cli import build_parser

    assert build_parser().parse_args(["preview", "--window", text]).window == size
    assert size == tuple(int(Decimal(side)) for side in text.lower().split("x"))
    for bad in ("64.5x48", "64x", "x48", "64x48x3", "nanx48", "1e400x48"):
        with pytest.raises(SystemExit):
            build_parser().parse_args(["preview", "--window", bad])
        assert f"'{bad}' is not WIDTHxHEIGHT" in capsys.readouterr().err


def test_a_builder_named_as_wrt_bench_names_warps_tree_is_told_the_options_that_build_it(capsys):
    """``wrt render --builder warp:sah`` (wrt bench's and bvh-stats' name of wp.Mesh's tree) was refused listing the
    choices alone; the error now says how render asks for that tree (README: ``--accel warp`` picks wp.Mesh,
    ``--builder`` its builder). wrt preview, which draws wrt's trees alone and has no --accel, gives no such hint."""
    from wrt.cli import build_parser

    for command, hint in (("render", True), ("preview", False)):
        with pytest.raises(SystemExit):
            build_parser().parse_args([command, "--builder", "warp:sah"])
        (line,) = error_lines(capsys.readouterr().err)
        assert ("invalid choice: 'warp:sah' (Warp's wp.Mesh tree is --accel warp --builder sah)" in line) == hint, line
    assert build_parser().parse_args(["render", "--accel", "warp", "--builder", "sah"]).builder == "sah"


@pytest.mark.parametrize("text", ["12345678901234567e0", "123456789012345678900e-2", "9007199254740993E0"])
def test_integer_options_in_exponent_notation_are_read_exactly(text):
    """A float rounded a whole number of more than 16 digits (``12345678901234567e0`` to ...568). The oracle:
    Python's exact rational reading of the text."""
    from fractions import Fraction

    from wrt.cli import build_parser

    exact = Fraction(text.lower())
    assert exact.denominator == 1
    assert build_parser().parse_args(["bench", "--n-rays", text]).n_rays == exact.numerator


@pytest.mark.parametrize("text", ["2.5", "2.5e0", "1e-400", "nan", "inf", "1e", "e5", "five", "1.00000000000000001e0",
                                  "1000000000000000.1e0"])
def test_integer_options_refuse_what_is_no_whole_number(text, capsys):
    """A fraction that a float rounds to a whole number (``1.00000000000000001e0``: 1) is still a fraction."""
    from wrt.cli import build_parser

    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["bench", "--n-rays", text])
    assert exit_.value.code == 2
    assert f"{text!r} is not an integer" in capsys.readouterr().err


@pytest.mark.parametrize("option, text, message", [
    (["bench", "--n-rays"], "1e301", "must be a positive integer, at most 1e300, got 1e301"),
    (["bench", "--n-rays"], "2.5e400", "must be a positive integer, at most 1e300, got 2.5e400"),
    (["render", "scene.usda", "--spp"], "1e301", "must be an integer from 1 to 2^31 - 1, got 1e301"),
    (["render", "scene.usda", "--spp"], "-1e999999999", "must be an integer from 1 to 2^31 - 1, got -1e999999999"),
])
def test_integer_options_refuse_whole_numbers_past_1e300_as_too_large(option, text, message, capsys):
    """``1e301`` is a whole number (the oracle: its digits and exponent as written, no fraction digit and more than
    301 digits before the point), refused by the option's range (its bound, or the 1e300 past which no number is
    made an int: ``1e999999999`` would take minutes) rather than as 'not an integer', which it was."""
    import re

    from wrt.cli import build_parser

    digits, fraction, exponent = re.fullmatch(r"-?(\d+)\.?(\d*)e(\d+)", text).groups()
    assert len(fraction) <= int(exponent) and len(digits) + int(exponent) > 301
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args([*option[:-1], f"{option[-1]}={text}"])  # '=': argparse takes '-1e9' for an option
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "not an integer" not in err, err


@pytest.mark.parametrize("text", ["0e400", "-0E999", "0.0e-5"])
def test_zero_with_any_exponent_is_zero(text, capsys):
    """``0e400`` is 0 (the oracle: Python's exact rational reading of it): a non-negative option takes it, a positive
    one refuses it as 0. Both called it 'not an integer', as its exponent is past 300."""
    from fractions import Fraction

    from wrt.cli import build_parser

    assert Fraction(text) == 0
    assert build_parser().parse_args(["preview", "--bvh-depth", text]).bvh_depth == 0
    with pytest.raises(SystemExit):
        build_parser().parse_args(["bench", "--n-rays", text])
    assert "must be a positive integer, got 0" in capsys.readouterr().err


@pytest.mark.parametrize("text, message", [
    ("1e99999999999999999999", "must be a positive integer, at most 1e300, got 1e99999999999999999999"),
    ("0e99999999999999999999", "must be a positive integer, got 0"),
    ("-0.0E+99999999999999999999", "must be a positive integer, got 0"),
    ("1e-99999999999999999999", "'1e-99999999999999999999' is not an integer"),
])
def test_integer_options_read_exponents_past_what_decimal_reads(text, message, capsys):
    """An exponent past 999,999,999,999,999,999 (decimal.Decimal's limit) made the number 'not an integer' whatever
    it was: ``1e99999999999999999999`` is a whole number past 1e300, ``0e99999999999999999999`` is 0 (as ``0e400``
    is), and ``1e-99999999999999999999`` a fraction. The oracle: the mantissa and exponent as written (Fraction of
    the mantissa; the exponent's sign), as Fraction of the whole text would take 10^(10^20)."""
    import re
    from fractions import Fraction

    from wrt.cli import build_parser

    mantissa, exponent = re.fullmatch(r"(-?[\d.]+)e([+-]?\d+)", text.lower()).groups()
    zero, positive = Fraction(mantissa) == 0, int(exponent) > 0
    assert message.endswith("got 0") == zero and ("at most 1e300" in message) == (positive and not zero)
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["bench", f"--n-rays={text}"])
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err
    if zero:
        assert build_parser().parse_args(["preview", "--bvh-depth", text]).bvh_depth == 0


def test_help_texts_name_the_defaults_the_library_uses(capsys):
    """Defaults that argparse cannot show (the option's own default is None: chosen later), and the AOV files
    --aov-dir writes, are written into the help: they name the library's values, read here from the code that
    applies them, not copies of them."""
    import inspect
    import re

    from wrt.bvh.build import build_bvh_device
    from wrt.cli import build_parser
    from wrt.render import DEFAULT_MAX_DEPTH

    def help_of(command):
        with pytest.raises(SystemExit):
            build_parser().parse_args([command, "--help"])
        return " ".join(capsys.readouterr().out.split())

    render = help_of("render")
    from wrt.render import AOV_NAMES

    assert f"every AOV ({', '.join(AOV_NAMES)}) as NAME.npy" in render  # the files --aov-dir writes: Image.aovs' keys
    depths = re.search(r"--max-depth MAX_DEPTH bounces per path; default (.*?) --", render).group(1)
    assert dict((name, int(depth)) for depth, name in re.findall(r"(\d+) \((\w+)\)", depths)) == DEFAULT_MAX_DEPTH
    built = inspect.signature(build_bvh_device).parameters
    stats = help_of("bvh-stats")
    assert f"wrt's most triangles per leaf (default: {built['leaf_size'].default})" in stats
    assert f"SAH bins per axis for sah (default: {built['bins'].default})" in stats


def test_ao_radius_help_says_what_the_default_measures(capsys):
    """--ao-radius said 'a tenth of the scene's size': the renderer takes a tenth of its box's diagonal (a 3 x 4 x 12
    box: 1.3), not of a side or of the largest extent."""
    import wrt
    from wrt.cli import build_parser

    with pytest.raises(SystemExit):
        build_parser().parse_args(["render", "--help"])
    assert "default a tenth of the diagonal of the scene's box" in " ".join(capsys.readouterr().out.split())
    corners = np.array([[0, 0, 0], [3, 0, 0], [3, 4, 12]], np.float32)  # a triangle whose box is 3 x 4 x 12
    scene = wrt.Scene.from_triangles(corners, np.array([[0, 1, 2]], np.int32))
    renderer = wrt.Renderer(scene, integrator="ao", width=4, height=4, device="cpu")
    assert renderer.ao_radius == pytest.approx(0.1 * np.sqrt(3.0**2 + 4.0**2 + 12.0**2))


@pytest.mark.parametrize("output", ["/dev/null", "{dir}/pipe.png"])
def test_an_output_that_is_a_device_or_a_pipe_is_refused_naming_it(tmp_path, capsys, output):
    """-o /dev/null said 'cannot write null: supported image formats are ...', naming neither the path nor what is
    wrong; a pipe named x.png would have been replaced by a regular file (wrt writes beside it, then renames)."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")  # refused before it is read
    output = output.replace("{dir}", str(tmp_path))
    if output.endswith("pipe.png"):
        os.mkfifo(output)
    kind = "a device" if output == "/dev/null" else "a pipe or socket"
    assert main(["render", str(tmp_path / "a.usda"), "-o", output, "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert errors == [f"wrt: error: cannot write {output}: it is {kind}, not an image file (the image is written "
                      "beside it and renamed over it); give a file name ending .png, .exr or .npy"], errors
    assert Path(output).exists() and not Path(output).is_file()


@pytest.mark.parametrize("args, folder, file", [
    (["-o", "{dir}/shot.png", "--aov-dir", "{dir}/shot.png"], "shot.png", "shot.png/depth.npy"),
    (["-o", "{dir}/shot.png", "--aov", "depth", "--aov-dir", "{dir}/shot.depth.png/arrays"], "shot.depth.png",
     "shot.depth.png/arrays/depth.npy"),
])
def test_an_aov_folder_at_a_file_the_run_writes_is_refused_before_a_render(tmp_path, capsys, args, folder, file):
    """``-o out/shot.png --aov-dir out/shot.png``: the image was rendered and written, then save_aovs failed on the
    folder the image had taken ('save_aovs: directory ... is a file'), naming neither option."""
    (tmp_path / "a.usda").write_text("#usda 1.0\n")  # refused before it is read
    args = [a.replace("{dir}", str(tmp_path)) for a in args]
    assert main(["render", str(tmp_path / "a.usda"), *args, "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(errors) == 1, errors
    assert f"cannot write {tmp_path / file}" in errors[0] and f"into {tmp_path / folder}: that is " in errors[0]
    assert "give -o and --aov-dir other names" in errors[0], errors
    assert list(tmp_path.iterdir()) == [tmp_path / "a.usda"]


BEHIND_THE_CAMERA = """#usda 1.0
def Mesh "M"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
def Camera "C"
{
    double3 xformOp:translate = (0, 0, -5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def test_a_warning_made_an_error_is_said_as_an_error_not_a_traceback(tmp_path, capsys):
    """Under Python's warning filters that make warnings errors (python -W error), a render stopped with a traceback
    (status 1), and a batch printed one for the scene as for a fault in wrt. They are said as wrt's errors, as --frames
    says them (an error row, no traceback): one line, status 2 (the option's warning) or 1 (one of two scenes). The
    oracle: the warning's own words, as they are said without the filter."""
    import warnings

    scene, seen = tmp_path / "cam.usda", tmp_path / "tri.usda"
    scene.write_text(BEHIND_THE_CAMERA)
    seen.write_text(BEHIND_THE_CAMERA.replace("(0, 0, -5)", "(0, 0, 5)"))
    size = ["--width", "4", "--height", "4"]
    assert main(["render", str(scene), "-o", str(tmp_path / "w.png"), *size, "-q"]) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "sees nothing" in line]
    assert len(said) == 1 and said[0].startswith(f"wrt: warning: {scene}: camera /C sees nothing"), said
    words = said[0].removeprefix("wrt: warning: ")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["render", str(seen), "-o", str(tmp_path / "x.png"), "--ao-radius", "1", *size]) == 2
        err = capsys.readouterr().err
        assert error_lines(err) == ["wrt: error: --ao-radius applies to --integrator ao only; whitted does not use it "
                                    "(see 'wrt render --help')"] and "Traceback" not in err, err
        out = tmp_path / "out"
        assert main(["render", str(seen), str(scene), "-o", f"{out}/", *size, "-q"]) == 1
        err = capsys.readouterr().err
    assert "Traceback" not in err and f"wrt: error: {words}" in err.splitlines(), err
    rows = [json.loads(line) for line in (out / "render-log.jsonl").read_text().splitlines()]
    assert [(r["status"], r.get("error")) for r in rows] == [("ok", None), ("error", f"UserWarning: {words}")], rows


@pytest.mark.parametrize("given", [["--devices", "cpu"], ["--dask"]], ids=["devices", "dask"])
def test_a_device_given_with_devices_or_dask_is_refused_not_dropped(tmp_path, capsys, given):
    """--device with --devices (or --dask), which choose the devices the frames render on, was dropped without a
    word: --devices cpu --device cuda:0 rendered on the CPU, and did not even say that cuda:0 is missing here. Both
    are refused before any frame, naming the two options, as --devices with --dask is."""
    scene = tmp_path / "a.usda"
    scene.write_text(BEHIND_THE_CAMERA)
    out = tmp_path / "out"
    argv = ["render", str(scene), "--frames", "1:1", "-o", f"{out}/f_#.png", "--width", "4", "--height", "4", "-q"]
    assert main([*argv, "--device", "cuda:0", *given]) == 2
    other = given[0]
    assert error_lines(capsys.readouterr().err) == [f"wrt: error: give --device or {other}, not both: {other} chooses "
                                                    "the devices the frames render on (see 'wrt render --help')"]
    assert not out.exists()
