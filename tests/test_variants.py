"""Variant selections at load time: ``load_usd(variants=...)`` and ``--variant``, on the session layer (the file is
left as it is), through every command that loads a stage and into frame worker processes; bad selections are errors
naming the file, the prim and the choices that exist."""

import warnings

import numpy as np
import pytest

import wrt
from wrt.animation import FrameRenderer, parse_frames, pending_frames
from wrt.cli import main

STAGE = """#usda 1.0
(
    defaultPrim = "World"
)
def Xform "World"
{
    def Xform "Car" (
        variants = {
            string paint = "red"
            string shape = "box"
        }
        prepend variantSets = ["paint", "shape"]
    )
    {
        variantSet "paint" = {
            "red" {
                color3f[] primvars:displayColor = [(0.9, 0.1, 0.1)]
            }
            "blue" {
                color3f[] primvars:displayColor = [(0.1, 0.1, 0.9)]
            }
        }
        variantSet "shape" = {
            "box" {
                def Cube "Body"
                {
                    double size = 1.5
                }
            }
            "ball" {
                def Sphere "Body"
                {
                    double radius = 0.8
                }
            }
        }
    }
    def Camera "Cam"
    {
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"""
SIZE = ["--width", "24", "--height", "16"]


@pytest.fixture
def stage(tmp_path):
    path = tmp_path / "car.usda"
    path.write_text(STAGE)
    return path


def test_variants_switch_colour_and_geometry_on_the_session_layer(stage):
    text = stage.read_text()
    default = wrt.load_usd(stage)
    assert [(s.path, s.kind) for s in default.shapes] == [("/World/Car/Body", "box")]
    np.testing.assert_allclose(default.shapes[0].color, [0.9, 0.1, 0.1])
    blue_ball = wrt.load_usd(stage, variants={"/World/Car": {"paint": "blue", "shape": "ball"}})
    assert [(s.path, s.kind) for s in blue_ball.shapes] == [("/World/Car/Body", "sphere")]
    np.testing.assert_allclose(blue_ball.shapes[0].color, [0.1, 0.1, 0.9])
    assert stage.read_text() == text  # the file is untouched
    assert wrt.load_usd(stage).shapes[0].kind == "box"  # and the next load sees the file's own selection


@pytest.mark.parametrize("variants, message", [
    ({"/World/Bus": {"paint": "red"}}, r"car.usda: no prim at /World/Bus to select variants on \(did you mean "
                                       r"'/World/Car'\?\); prims with variant sets: /World/Car \(paint, shape\)"),
    ({"/World/Car": {"colour": "red"}}, r"car.usda: /World/Car: no variant set 'colour'; its variant sets: paint, "
                                        "shape"),
    ({"/World/Car": {"paint": "green"}}, r"car.usda: /World/Car: variant set 'paint' has no variant 'green'; its "
                                         "variants: blue, red"),
    ({"World/Car": {"paint": "red"}}, r"car.usda: no prim at World/Car"),
])
def test_bad_selections_name_the_file_prim_and_choices(stage, variants, message):
    with pytest.raises(wrt.SceneError, match=message):
        wrt.load_usd(stage, variants=variants)


@pytest.mark.parametrize("selection, meant", [("/World/Car:paint=bleu", "'blue'"), ("/World/Car:pant=red", "'paint'"),
                                              ("/World/Cra:paint=red", "'/World/Car'")])
def test_a_misspelt_variant_set_or_prim_names_the_one_meant(stage, tmp_path, capsys, selection, meant):
    """The errors listed the variants, sets or prims there are, but named none as the one meant, as --camera, --builder
    and the other misspelt names of the command line do."""
    assert main(["render", str(stage), "-o", str(tmp_path / "x.npy"), "-q", *SIZE, "--variant", selection]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error:")]
    assert len(errors) == 1 and f"(did you mean {meant}?)" in errors[0], errors
    assert not (tmp_path / "x.npy").exists()


def test_cli_variant_renders_the_selection(stage, tmp_path, capsys):
    def render(*options, name):
        assert main(["render", str(stage), "-o", str(tmp_path / name), "-q", *SIZE, *options]) == 0
        return np.load(tmp_path / name)

    red = render(name="red.npy")
    blue = render("--variant", "/World/Car:paint=blue", name="blue.npy")
    assert blue[8, 12, 2] > blue[8, 12, 0] and red[8, 12, 0] > red[8, 12, 2]  # the centre pixel's colour
    ball = render("--variant", "/World/Car:shape=ball", "--variant", "/World/Car:paint=blue", name="ball.npy")
    assert not np.array_equal(ball, blue)
    expected = wrt.render(wrt.load_usd(stage, variants={"/World/Car": {"paint": "blue", "shape": "ball"}}),
                          width=24, height=16)
    np.testing.assert_array_equal(ball, expected.rgb)
    capsys.readouterr()
    command = ["render", str(stage), "-o", str(tmp_path / "x.npy"), "-q", *SIZE, "--variant"]
    with pytest.raises(SystemExit) as usage:  # refused by the parser, before anything is loaded
        main([*command, "/World/Car:paint"])
    assert usage.value.code == 2
    assert "argument --variant: '/World/Car:paint' is not PRIM:SET=VARIANT" in capsys.readouterr().err
    assert main([*command, "/World/Car:paint=gold"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("wrt: error: ") and "variant set 'paint' has no variant 'gold'" in err[-1]


def test_frames_in_worker_processes_see_the_selection(stage, tmp_path):
    """--frames with --devices renders in spawned worker processes: each loads the stage itself, with the variants
    of the command line."""
    out = tmp_path / "f_#.npy"
    assert main(["render", str(stage), "--frames", "1:2", "--devices", "cpu,cpu", "-o", str(out), "-q", *SIZE,
                 "--variant", "/World/Car:shape=ball"]) == 0
    serial = FrameRenderer(stage, width=24, height=16, variants={"/World/Car": {"shape": "ball"}})
    plain = FrameRenderer(stage, width=24, height=16)
    for frame, file in pending_frames(parse_frames("1:2"), out, resume=False):
        image = np.load(file)
        np.testing.assert_array_equal(image, serial.render(frame).rgb)
        assert not np.array_equal(image, plain.render(frame).rgb)


def test_other_commands_take_variants(stage, tmp_path, capsys):
    assert main(["bvh-stats", str(stage), "--json", "--variant", "/World/Car:shape=ball"]) == 0
    ball = capsys.readouterr().out
    assert main(["bvh-stats", str(stage), "--json"]) == 0
    assert capsys.readouterr().out != ball  # a tessellated sphere, not a cube
    code = main(["preview", str(stage), "-o", str(tmp_path / "p.png"), "-q", "--variant", "/World/Car:paint=nope"])
    assert code == 2 and "variant set 'paint' has no variant 'nope'" in capsys.readouterr().err


def test_a_prim_inside_a_native_instance_is_refused_by_name(tmp_path):
    """USD refuses to author on an instance proxy: a Tf.ErrorException escaped load_usd with C++ file and line."""
    stage = tmp_path / "instanced.usda"
    stage.write_text('''#usda 1.0
def Xform "Proto"
{
    def Xform "Body" (
        variants = {
            string look = "a"
        }
        prepend variantSets = ["look"]
    )
    {
        variantSet "look" = {
            "a" {
                def Cube "G" {
                }
            }
            "b" {
                def Sphere "G" {
                }
            }
        }
    }
}
def Xform "Inst" (
    instanceable = true
    prepend references = </Proto>
)
{
}
''')
    with pytest.raises(wrt.SceneError, match=r"instanced.usda: /Inst/Body: is inside a native instance"):
        wrt.load_usd(stage, variants={"/Inst/Body": {"look": "b"}})
    kinds = [shape.kind for shape in wrt.load_usd(stage, variants={"/Proto/Body": {"look": "b"}}).prototypes[0].shapes]
    assert kinds == ["sphere"]  # selected where the instance brings it from


def test_an_authored_selection_of_no_variant_is_named(stage):
    """A file whose selection names no variant of its set (a typo, a variant renamed upstream) composes none of the
    set's variants, as USD does, with no composition error: wrt drew the car without its body and said at most
    'nothing to render', naming neither the prim nor the selection. Now a warning names both and the variants."""
    stage.write_text(STAGE.replace('string shape = "box"', 'string shape = "Box"'))
    from pxr import Usd
    assert not Usd.Stage.Open(str(stage)).GetPrimAtPath("/World/Car/Body")  # USD's oracle: nothing composed
    with pytest.warns(UserWarning, match=r"car.usda: variant selections that name no variant of their set: USD "
                                         r"composes none of the set's variants: 1 prim\(s\) \(shape = 'Box', its "
                                         r"variants: ball, box: 1\): /World/Car") as caught:
        scene = wrt.load_usd(stage)
    assert scene.shapes == [] and len(caught) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a valid selection, or one made by load_usd, warns about nothing
        wrt.load_usd(stage, variants={"/World/Car": {"shape": "ball"}})
