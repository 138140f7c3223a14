"""Render settings read at the render's time (``load_usd(time=...)``, a ``--frames`` frame), as
``Usd.Attribute.Get(time)`` reads them; the default time reads a value of time samples only at its first, as wrt reads
every attribute. They were read at the default time only: a time-sampled ``resolution`` gave the schema's 2048x1080."""

import sys

import numpy as np
from pxr import Usd, UsdRender

import wrt
from wrt.cli import main

STAGE = """#usda 1.0
(
    renderSettingsPrimPath = "/Render/Settings"
    startTimeCode = 1
    endTimeCode = 2
)
def Cube "Box"
{
    double size = 1
}
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Scope "Render"
{
    def RenderSettings "Settings"
    {
        rel camera = </Cam>
        uniform int2 resolution.timeSamples = {1: (12, 6), 2: (8, 10)}
        uniform float4 dataWindowNDC.timeSamples = {1: (0, 0, 1, 1), 2: (0, 0, 0.5, 1)}
        rel products = </Render/Product>
    }
    def RenderProduct "Product"
    {
        token productName.timeSamples = {1: "beauty.0001.exr", 2: "beauty.0002.exr"}
        uniform float pixelAspectRatio.timeSamples = {1: 1, 2: 2}
    }
}
"""


def usd_values(path, time):
    """``(resolution, dataWindowNDC, productName, pixelAspectRatio)`` as USD reads them at ``time``."""
    stage = Usd.Stage.Open(str(path))
    settings = UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings"))
    product = UsdRender.Product(stage.GetPrimAtPath("/Render/Product"))
    return (tuple(settings.GetResolutionAttr().Get(time)), tuple(settings.GetDataWindowNDCAttr().Get(time)),
            product.GetProductNameAttr().Get(time), product.GetPixelAspectRatioAttr().Get(time))


def test_settings_are_read_at_the_load_time(tmp_path):
    path = tmp_path / "shot.usda"
    path.write_text(STAGE)
    for time, usd_time in ((1, 1), (2, 2), (1.5, 1.5), (None, Usd.TimeCode.EarliestTime())):
        settings = wrt.load_usd(path, time=time).render_settings
        resolution, window, name, ratio = usd_values(path, usd_time)
        assert settings.resolution == resolution, time
        np.testing.assert_allclose(settings.data_window, window)
        assert settings.product_name == name and settings.pixel_aspect_ratio == ratio, time
    assert wrt.load_usd(path, time=2).render_settings.resolution == (8, 10)  # not the schema's 2048x1080


def test_frames_render_each_frame_at_its_settings(tmp_path):
    path = tmp_path / "shot.usda"
    path.write_text(STAGE)
    assert main(["render", str(path), "--frames", "1:2", "-o", str(tmp_path / "f_#.npy"), "-q"]) == 0
    for frame in (1, 2):
        (width, height), window = usd_values(path, frame)[:2]
        shown = round(width * (window[2] - window[0])), round(height * (window[3] - window[1]))
        assert np.load(tmp_path / f"f_{frame}.npy").shape == (shown[1], shown[0], 3)


def test_frames_say_each_view_once_as_a_still_render_does(tmp_path, capsys):
    """A still render says 'view: camera ... (render settings), WxH (resolution of ...)'; --frames said nothing of
    the camera or size. Now each view is said once, with its frames where they differ (the sizes from USD's own
    resolution and dataWindowNDC at each time), and the warning about mixed sizes names the render settings, not the
    camera's aperture, which plays no part here. Frames of one view are one line, the still render's."""
    path = tmp_path / "shot.usda"
    path.write_text(STAGE)
    out = str(tmp_path / "f_#.npy")
    assert main(["render", str(path), "--frames", "1:2", "-o", out, "--integrator", "normals"]) == 0
    err = capsys.readouterr().err
    expected = []  # the first frame's view as it finishes, as a still render says it; then each with its frames
    for frame in (1, 2):
        (width, height), window = usd_values(path, frame)[:2]
        shown = round(width * (window[2] - window[0])), round(height * (window[3] - window[1]))
        inside = "" if shown == (width, height) else \
            f", {shown[0]}x{shown[1]} inside the dataWindowNDC of /Render/Product"
        expected.append(f"wrt: view: camera /Cam (render settings), {width}x{height} (resolution of /Render/Product)"
                        f"{inside} (frame {frame})")
    expected.insert(0, expected[0].removesuffix(" (frame 1)"))
    assert [line for line in err.splitlines() if line.startswith("wrt: view:")] == expected, err
    said = [line for line in err.splitlines() if "image sizes" in line]
    assert len(said) == 1 and "render settings' resolution and dataWindowNDC" in said[0] and "aperture" not in said[0]
    still = tmp_path / "still.usda"
    still.write_text(STAGE.replace(".timeSamples = {1: (12, 6), 2: (8, 10)}", " = (12, 6)")
                     .replace(".timeSamples = {1: (0, 0, 1, 1), 2: (0, 0, 0.5, 1)}", " = (0, 0, 1, 1)"))
    views = []
    for options in ([], ["--frames", "1:2", "-o", out]):
        assert main(["render", str(still), "-o", str(tmp_path / "s.npy"), "--integrator", "normals", *options]) == 0
        views.append([line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: view:")])
    assert len(views[1]) == 1 and views[0] == views[1], views


def test_frames_say_the_first_view_as_its_frame_finishes_and_a_resume_that_skips_every_frame_says_it(
        tmp_path, capsys, monkeypatch):
    """--frames said its views once every frame was drawn (a wrong camera was seen hours into a long run), and a
    --resume that skipped every frame said none. The first frame's view now comes before the second frame is drawn,
    and a resume says the views of the frames it skips, from their rows of the log: the lines the first run ended
    with."""
    from wrt.animation import FrameRenderer

    path = tmp_path / "shot.usda"
    path.write_text(STAGE)
    render = FrameRenderer.render

    def marked(self, frame, **kwargs):
        print(f"drawing frame {frame:g}", file=sys.stderr, flush=True)
        return render(self, frame, **kwargs)

    monkeypatch.setattr(FrameRenderer, "render", marked)
    argv = ["render", str(path), "--frames", "1:2", "-o", str(tmp_path / "f_#.npy"), "--integrator", "normals",
            "--log", str(tmp_path / "log.jsonl")]
    assert main(argv) == 0
    lines = capsys.readouterr().err.splitlines()
    (width, height), window = usd_values(path, 1)[:2]
    assert tuple(window) == (0, 0, 1, 1)
    first = f"wrt: view: camera /Cam (render settings), {width}x{height} (resolution of /Render/Product)"
    assert lines.index(first) < lines.index("drawing frame 2"), lines
    ended = [line for line in lines[lines.index("drawing frame 2"):] if line.startswith("wrt: view:")]
    assert len(ended) == 2 and ended[0] == f"{first} (frame 1)", ended
    assert main([*argv, "--resume"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert not any(line.startswith("drawing") for line in lines), lines  # every frame skipped
    assert [line for line in lines if line.startswith("wrt: view:")] == ended, lines


def test_a_second_resume_that_skips_every_frame_says_their_views_too(tmp_path, capsys):
    """A --resume that skips every frame says their views from their rows of the log; but the rows it adds for the
    frames it skipped carried no view, and the next --resume reads those (the last row of each image): it said no
    view. The oracle: the view lines of the run that drew the frames, said again by every resume."""
    path = tmp_path / "shot.usda"
    path.write_text(STAGE)
    argv = ["render", str(path), "--frames", "1:2", "-o", str(tmp_path / "f_#.npy"), "--integrator", "normals",
            "--log", str(tmp_path / "log.jsonl")]
    assert main(argv) == 0
    drawn = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: view:")]
    assert len(drawn) == 3  # the first frame's view as it finished, then both with their frames
    for _ in range(2):
        assert main([*argv, "--resume"]) == 0
        lines = capsys.readouterr().err.splitlines()
        assert any("skipped 2 of 2 frames" in line for line in lines), lines
        assert [line for line in lines if line.startswith("wrt: view:")] == drawn[1:], lines


def test_the_first_frames_view_said_under_a_running_progress_bar_gets_a_line_of_its_own(tmp_path, capsys,
                                                                                        monkeypatch):
    """The first frame's view is said as it finishes, while the frames' progress bar (drawn on a terminal) is still
    running: it was printed after the bar's text on the bar's line ('wrt frames:  50%|...| 1/2 [...]wrt: view: ...'),
    where a warning goes through tqdm, above the bar. The oracle: what the terminal shows of a line is the text after
    its last carriage return."""
    from wrt import cli

    monkeypatch.setattr(cli._Progress, "bar", property(lambda self: True))  # as on a terminal
    path = tmp_path / "shot.usda"
    path.write_text(STAGE)
    assert main(["render", str(path), "--frames", "1:2", "-o", str(tmp_path / "f_#.npy"), "--integrator",
                 "normals"]) == 0
    err = capsys.readouterr().err
    assert "wrt frames" in err  # the bar was drawn
    shown = [line.split("\r")[-1] for line in err.split("\n") if "view:" in line]
    assert shown and all(line.startswith("wrt: view: camera /Cam") for line in shown), shown


def test_a_resume_without_a_log_that_skips_every_frame_says_their_views_are_not_known(tmp_path, capsys):
    """--frames --resume without --log skips the frames whose image is on disk, whatever drew them: no row records
    their views, and a run that skipped every frame said no view at all, as if the stage had no render settings. It
    says their views are not known, naming the frames; a stage without render settings (no view to say) says none.
    The oracle: the stage's renderSettingsPrimPath as USD reads it."""
    path, plain = tmp_path / "shot.usda", tmp_path / "plain.usda"
    path.write_text(STAGE)
    plain.write_text(STAGE.replace('    renderSettingsPrimPath = "/Render/Settings"\n', ""))
    for scene, has_settings in ((path, True), (plain, False)):
        assert bool(Usd.Stage.Open(str(scene)).GetMetadata("renderSettingsPrimPath")) == has_settings
        argv = ["render", str(scene), "--frames", "1:2", "-o", str(tmp_path / f"{scene.stem}_#.npy"), "--integrator",
                "normals"]
        assert main(argv) == 0
        drawn = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: view:")]
        assert bool(drawn) == has_settings, drawn
        assert main([*argv, "--resume"]) == 0
        lines = capsys.readouterr().err.splitlines()
        assert any("2 of 2 frames already on disk" in line for line in lines), lines
        views = [line for line in lines if line.startswith("wrt: view:")]
        expected = ["wrt: view: not known for frames 1, 2, skipped as on disk: --resume without --log keeps no record "
                    "of how they were drawn (with --log FILE, their rows say their views)"]
        assert views == (expected if has_settings else []), lines
