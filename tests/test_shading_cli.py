"""``wrt render`` options of the shading work: --integrator, --max-depth, --exposure, --aov, EXR output."""

import numpy as np
import pytest
from PIL import Image as PilImage

from wrt.cli import main


def test_path_integrator_exr_and_cost_heat_map(tmp_path):
    out = tmp_path / "room.exr"
    code = main(
        ["render", "-o", str(out), "--width", "40", "--height", "30", "--integrator", "path", "--spp", "2"]
        + ["--max-depth", "3", "--aov", "cost", "--aov", "normal", "--aov-dir", str(tmp_path / "aovs"), "-q"]
    )
    assert code == 0
    import OpenEXR

    with OpenEXR.File(str(out)) as f:
        rgb = f.channels()["RGB"].pixels
    assert rgb.shape == (30, 40, 3) and rgb.dtype == np.float32 and rgb.max() > 0.0
    with PilImage.open(tmp_path / "room.cost.png") as png:
        assert png.size[0] > 2 * 40 and png.mode == "RGB"  # two panels: nodes visited | triangles tested
    with PilImage.open(tmp_path / "room.normal.png") as png:
        assert png.size == (40, 30)
    for name in ("depth", "z", "normal", "geometric_normal", "albedo", "prim", "instance", "material", "cost",
                 "coverage"):
        assert (tmp_path / "aovs" / f"{name}.npy").exists(), name
    cost = np.load(tmp_path / "aovs" / "cost.npy")
    assert cost.shape == (30, 40, 2) and cost[..., 0].max() > 0


def test_exposure_brightens_the_png(tmp_path):
    args = ["render", "--width", "24", "--height", "18", "-q", "--integrator", "albedo"]
    assert main(args + ["-o", str(tmp_path / "a.png")]) == 0
    assert main(args + ["-o", str(tmp_path / "b.png"), "--exposure", "1"]) == 0
    with PilImage.open(tmp_path / "a.png") as a, PilImage.open(tmp_path / "b.png") as b:
        assert np.asarray(b).astype(int).sum() > np.asarray(a).astype(int).sum()


@pytest.mark.parametrize("args, needle", [(["--integrator", "radiosity"], "radiosity"), (["--aov", "nope"], "nope")])
def test_bad_shading_options(tmp_path, capsys, args, needle):
    with pytest.raises(SystemExit) as exit_info:
        main(["render", "--width", "8", "--height", "8", "-o", str(tmp_path / "x.png")] + args)
    assert exit_info.value.code == 2 and needle in capsys.readouterr().err
