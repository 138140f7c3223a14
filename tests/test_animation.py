"""Animated stages: frame ranges, refit, TLAS-only rebuilds, and frames equal to fresh renders."""

import importlib.util
import json
import math
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import warp as wp

import wrt
from wrt.animation import FrameRenderer, classify_change, frame_output, parse_frames, pending_frames, render_frames
from wrt.bvh import build_bvh
from wrt.bvh.refit import Refitter
from wrt.trace import get_accelerator

ROOT = Path(__file__).resolve().parent.parent
SIZE = {"width": 48, "height": 36}


@pytest.fixture(scope="module")
def animated(tmp_path_factory) -> Path:
    spec = importlib.util.spec_from_file_location("make_animated_scene", ROOT / "scenes" / "make_animated_scene.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.write(tmp_path_factory.mktemp("anim") / "animated.usda")


@pytest.mark.parametrize("script", ["make_animated_scene.py", "make_mostly_static_scene.py"])
def test_the_scene_scripts_take_help_and_refuse_a_name_that_is_no_usd_file(tmp_path, script):
    """'python scenes/make_animated_scene.py --help' (the README's first animation command, asked about) took --help
    for the file to write: USD's 'Failed verification: fileFormat' traceback; 'out.png' failed so too. --help shows
    the usage and writes nothing; a name USD cannot write is one line naming it, status 2."""
    run = [sys.executable, str(ROOT / "scenes" / script)]
    shown = subprocess.run([*run, "--help"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert shown.returncode == 0 and shown.stdout.startswith("usage: "), shown.stderr
    refused = subprocess.run([*run, str(tmp_path / "out.png")], cwd=tmp_path, capture_output=True, text=True,
                             timeout=120)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr, refused.stderr
    assert refused.stderr.strip().splitlines()[-1].endswith(f"{tmp_path / 'out.png'}: give a USD file name (.usda, "
                                                            ".usdc or .usd)"), refused.stderr
    assert list(tmp_path.iterdir()) == []


def test_parse_frames():
    assert parse_frames("1:4") == [1.0, 2.0, 3.0, 4.0]
    assert parse_frames("1:10:4") == [1.0, 5.0, 9.0]
    assert parse_frames("2:3:0.5") == [2.0, 2.5, 3.0]
    assert parse_frames("7") == [7.0]
    # Binary steps do not add up exactly (0.2 + 6 * 0.3 = 1.9999999999999998): END is still END.
    assert parse_frames("0.2:2:0.3")[-1] == 2.0 and parse_frames("0.1:3:0.1")[-1] == 3.0
    for bad in ("a:b", "4:1", "1:4:0", "1:2:3:4", "1:nan"):
        with pytest.raises(ValueError, match="--frames"):
            parse_frames(bad)
    for bad in ("1e300", "-1e12", "999999999999:1000000000000"):  # 10^12: 13 digits, past a 12-digit file name
        with pytest.raises(ValueError, match=rf"--frames '{bad}': frames must lie within \+-999,999,999,999"):
            parse_frames(bad)
    assert parse_frames("999999999999")[0] == 999_999_999_999.0


@pytest.mark.parametrize("frame", [float("nan"), float("inf"), -float("inf"), np.float32("nan"), "3", None, True])
def test_frame_output_refuses_a_frame_that_is_no_finite_number(frame):
    # NaN and inf were written into the name (frame_0nan.png, frame_-0inf.png); "3" failed in Python's words.
    with pytest.raises(ValueError, match=r"frame_output: frame must be a finite number, got "):
        frame_output("out/frame_####.png", frame)
    assert frame_output("out/frame_####.png", np.float32(2.5)) == Path("out/frame_0002.5.png")


def test_frames_of_a_third_step_are_the_time_codes_of_samples_authored_at_thirds(tmp_path):
    """``--frames 0:1:0.3333333333333333`` gives the time codes 1/3 and 2/3 that a stage authors its subframe samples
    at (Python's ``1 / 3``, written as ``0.3333333333333333``): rounded to 12 digits (0.333333333333, before the
    sample), a visibility switched off at 1/3 was still on in that frame, one subframe late. Decimal steps stay
    exact (0.2 + 6 * 0.3 is 2). Oracle: ``UsdGeom.Imageable.ComputeVisibility`` at each frame's time code."""
    from pxr import Usd, UsdGeom

    frames = parse_frames("0:1:0.3333333333333333")
    path = tmp_path / "thirds.usda"
    stage = Usd.Stage.CreateNew(str(path))
    tri = UsdGeom.Mesh.Define(stage, "/Tri")
    tri.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    tri.CreateFaceVertexCountsAttr([3])
    tri.CreateFaceVertexIndicesAttr([0, 1, 2])
    seen = tri.CreateVisibilityAttr()
    for k, token in enumerate(["inherited", "invisible", "inherited", "invisible"]):
        seen.Set(token, k / 3)
    stage.Save()
    assert len(frames) == 4 and frames[-1] == 1.0
    drawn = [bool(wrt.load_usd(path, time=frame).meshes) for frame in frames]
    expected = [UsdGeom.Imageable(tri).ComputeVisibility(Usd.TimeCode(frame)) != "invisible" for frame in frames]
    assert drawn == expected == [True, False, True, False]
    assert parse_frames("0.2:2:0.3")[-2:] == [1.7, 2.0] and parse_frames("0.1:0.3:0.1") == [0.1, 0.2, 0.3]


def test_frame_output_patterns():
    assert frame_output("out/frame_####.png", 12) == Path("out/frame_0012.png")
    assert frame_output("f#.exr", 123) == Path("f123.exr")
    assert frame_output("movie.png", 3) == Path("movie_0003.png")
    assert frame_output("f_##.png", 2.5) == Path("f_02.5.png")
    assert frame_output("f_####.png", 3.0000000000000004) == Path("f_0003.png")
    assert frame_output("f_####.png", -0.5) == Path("f_-0000.5.png")
    assert frame_output("f_####.png", -1.5) == Path("f_-0001.5.png")
    assert frame_output("f_####.png", -3) == Path("f_-0003.png")


@pytest.mark.parametrize("frame, message", [
    (1e300, "more than 12 digits before the point"),  # a 311-character name: the write failed after the render
    (-1e300, "more than 12 digits before the point"),
    (1234567890123.0, "more than 12 digits before the point"),  # was named f_1234567890120.png, another frame
    (1e-300, "bytes long"),  # 0000.000...0001: past the 255 bytes of a file name
])
def test_frame_output_refuses_a_frame_its_file_name_cannot_spell(frame, message):
    with pytest.raises(ValueError, match=re.escape(f"frame_output: frame {frame!r}: ") + ".*" + message):
        frame_output("out/f_####.png", frame)


def test_frame_output_refuses_a_folder_its_frame_number_makes_too_long(tmp_path):
    """A pattern whose last run of # names the folder (shot_####/img.png): the number lands in the folder's name,
    which a file system refuses past 255 bytes as it refuses a file's; only the last part of the path was measured,
    so 1e-300 was named and failed at the write, after its render. Oracle: making the folder fails."""
    pattern = str(tmp_path / "shot_####" / "img.png")
    long_folder = Path(pattern.replace("####", np.format_float_positional(1e-300).zfill(4))).parent
    with pytest.raises(OSError):
        long_folder.mkdir()
    with pytest.raises(ValueError, match=re.escape("frame_output: frame 1e-300: ") + ".*bytes long"):
        frame_output(pattern, 1e-300)
    assert frame_output(pattern, 12.5) == tmp_path / "shot_0012.5" / "img.png"


@pytest.mark.parametrize("frame", [999999999999.0, -999999999999.0, 123456.5, 1e-20, 0.0])
def test_frame_output_names_the_largest_and_smallest_frames_it_takes_exactly(frame):
    """Oracle: the number in the name, read back by float(), is the frame."""
    name = frame_output("out/f_####.png", frame).stem.removeprefix("f_")
    assert float(name) == frame, name


def test_every_frame_gets_its_own_file_and_runaway_ranges_are_refused():
    """Frames closer than 1e-6 shared a file name (1.0000005 and 1.000001 were both f_0001.000001.png: one image
    overwrote the other) and 1.9999999 was named 2; a range of 1e9 frames was built in memory (a hang)."""
    frames = parse_frames("1:1.000003:0.0000005")
    files = [frame_output("f_####.png", f) for f in frames]
    assert len(set(files)) == len(frames) == 7
    assert [float(p.stem.removeprefix("f_")) for p in files] == frames  # each name is its frame's time
    assert frame_output("f_####.png", 1.9999999) == Path("f_0001.9999999.png")
    with pytest.raises(ValueError, match="1,000,000,001 frames"):
        parse_frames("0:1e9")
    with pytest.raises(ValueError, match="too small"):
        parse_frames("1:1.000000000001:1e-13")  # frames equal at 12 digits would render one time many times


@pytest.mark.parametrize(("text", "frames"), [("1e-999999999:1", [0.0, 1.0]), ("0e999999999:2", [0.0, 1.0, 2.0])])
def test_frames_spelt_with_huge_decimal_exponents_read_as_float_reads_them(text, frames):
    """A decimal exponent of a billion reads as the double float() gives: the exact decimal was built as a Fraction
    of a billion-digit power of ten, and the run hung."""
    assert parse_frames(text) == frames


@pytest.mark.parametrize("text", ["1:5:1e-320", "-1e308:1e308", "0:1e308:1e-308"])
def test_frames_whose_count_passes_float_range_are_refused_naming_the_option(text):
    """A range whose frame count is past float64 (a subnormal step, or END - START overflowing) raised a bare
    OverflowError 'cannot convert float infinity to integer' (a traceback from wrt render --frames)."""
    with pytest.raises(ValueError, match=r"--frames .* gives more than 1,000,000 frames"):
        parse_frames(text)


@pytest.mark.parametrize("text", ["1:2:1e-300", "0:1e200"])
def test_a_frame_count_past_float_precision_is_said_in_a_few_digits(text):
    """'1:2:1e-300' was refused as giving '999,999,999,999,999,903,803,069,...' frames, 300 digits of which all
    past the 16th are float noise. The oracle: the exact count (END - START) / STEP + 1 in Fraction arithmetic."""
    from fractions import Fraction

    start, end, *step = (Fraction(part) for part in text.split(":"))
    exact = (end - start) / (step[0] if step else 1) + 1
    with pytest.raises(ValueError) as error:
        parse_frames(text)
    said = re.fullmatch(r"--frames '.*' gives about (\S+) frames; at most 1,000,000 in one run", str(error.value))
    assert said, error.value
    assert abs(Fraction(said.group(1)) / exact - 1) < Fraction(1, 100)


def test_refit_gives_the_boxes_of_the_moved_triangles(np_rng):
    points = np_rng.uniform(-1, 1, (600, 3)).astype(np.float32)
    indices = np_rng.integers(0, 600, (400, 3)).astype(np.int32)
    bvh = build_bvh(points, indices, "sah", device="cpu")
    refitter = Refitter(bvh, bvh.to_device(points, indices, "cpu"), "cpu")
    moved = (points * 2.0 + np_rng.normal(0, 0.3, points.shape)).astype(np.float32)
    tree = refitter.refit(moved, indices)
    tree.validate()
    leaf = np.flatnonzero(tree.prim_count > 0)
    for node in leaf[:50]:
        first, count = tree.left_first[node], tree.prim_count[node]
        corners = moved[indices[tree.prim_ids[first : first + count]]].reshape(-1, 3)
        np.testing.assert_array_equal(tree.lowers[node], corners.min(axis=0))
        np.testing.assert_array_equal(tree.uppers[node], corners.max(axis=0))
    np.testing.assert_array_equal(tree.lowers[0], moved[indices].reshape(-1, 3).min(axis=0))


def test_refit_gives_every_node_the_box_of_its_triangles_from_levels_in_one_upload(np_rng):
    """Every node's refitted box, inner ones too, is the box of the moved triangles under it (brute force over the
    tree); the refitter's levels (deepest first, each its nodes ascending) are views of one upload: an upload per
    level made a refitter of a small tree cost a millisecond, most of an update of thousands of prototypes."""
    points = np_rng.uniform(-1, 1, (300, 3)).astype(np.float32)
    indices = np_rng.integers(0, 300, (500, 3)).astype(np.int32)
    bvh = build_bvh(points, indices, "sah", device="cpu", leaf_size=2)
    refitter = Refitter(bvh, bvh.to_device(points, indices, "cpu"), "cpu")
    depth = bvh.depths()
    want = [np.flatnonzero(depth == k) for k in range(int(depth.max()), -1, -1)]
    assert [level.numpy().tolist() for level in refitter.levels] == [w.tolist() for w in want]
    sizes = np.cumsum([0] + [len(w) for w in want])
    assert [level.ptr for level in refitter.levels] == [refitter.levels[0].ptr + 4 * int(k) for k in sizes[:-1]]
    moved = (points[::-1] * 3.0 + 0.5).astype(np.float32)
    tree = refitter.refit(moved, indices)

    def slots(node):  # the slots under a node
        first, count = int(tree.left_first[node]), int(tree.prim_count[node])
        return list(range(first, first + count)) if count else slots(first) + slots(first + 1)

    for node in range(tree.num_nodes):
        corners = moved[indices[tree.prim_ids[slots(node)]]].reshape(-1, 3)
        np.testing.assert_array_equal(tree.lowers[node], corners.min(axis=0))
        np.testing.assert_array_equal(tree.uppers[node], corners.max(axis=0))


def test_refit_rejects_nan_vertices_and_other_topologies_and_keeps_the_tree(np_rng):
    points = np_rng.uniform(-1, 1, (60, 3)).astype(np.float32)
    indices = np_rng.integers(0, 60, (40, 3)).astype(np.int32)
    bvh = build_bvh(points, indices, "sah", device="cpu")
    refitter = Refitter(bvh, bvh.to_device(points, indices, "cpu"), "cpu")
    before = bvh.lowers.copy(), bvh.uppers.copy()
    nan_points = points.copy()
    nan_points[indices[7, 1]] = [np.nan, 0.0, 0.0]
    with pytest.raises(ValueError, match=r"finite in float32 \(found NaN or inf, .*\); triangle 7 uses one"):
        refitter.refit(nan_points, indices)
    with pytest.raises(ValueError, match="40 triangles"):
        refitter.refit(points, indices[:-1])
    with pytest.raises(ValueError, match="indices must lie in"):
        refitter.refit(points[:10], indices)
    np.testing.assert_array_equal(bvh.lowers, before[0])
    np.testing.assert_array_equal(bvh.uppers, before[1])
    unused, spare = points.copy(), np.setdiff1d(np.arange(60), indices)
    assert len(spare) > 0
    unused[spare] = np.nan  # vertices no triangle uses may be anything, as in a build
    refitter.refit(unused, indices).validate()


def test_refit_to_float64_vertices_past_float32_names_the_range_without_numpys_warning(np_rng):
    """A refit to float64 vertices past float32's 3.4e38 is refused naming that range, as a build of them is, and
    without numpy's "overflow encountered in cast" RuntimeWarning, which the build drops (8296e7e) but the refit's
    cast let through (an error where warnings are errors, in place of the message)."""
    import warnings

    points = np_rng.uniform(-1, 1, (60, 3)).astype(np.float32)
    indices = np_rng.integers(0, 60, (40, 3)).astype(np.int32)
    bvh = build_bvh(points, indices, "sah", device="cpu")
    refitter = Refitter(bvh, bvh.to_device(points, indices, "cpu"), "cpu")
    far = points.astype(np.float64)
    far[indices[0, 2]] = [1e39, 0.0, 0.0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"a value past float32's 3.4e38\); triangle 0 uses one"):
            refitter.refit(far, indices)


def test_refitted_accelerator_traces_like_wp_mesh(np_rng):
    from wrt.procedural import displaced_sphere

    points, indices = displaced_sphere(4000)
    scene = wrt.Scene.from_triangles(points, indices)
    accel = get_accelerator(scene, "wrt", "sah", "cpu")
    moved = wrt.Scene.from_triangles((np.asarray(points) * [1.5, 0.7, 1.0]).astype(np.float32), indices)
    assert classify_change(scene, moved) == "refit"
    accel.refit(moved)
    moved._cache[("accel", "wrt", "sah", "cpu")] = accel
    origins = np_rng.uniform(-3, 3, (3000, 3)).astype(np.float32)
    directions = (np_rng.uniform(-1, 1, (3000, 3)) - origins * 0.3).astype(np.float32)
    ours = wrt.trace(moved, origins, directions, accel="wrt", device="cpu")
    fresh = wrt.Scene.from_triangles(*moved.triangles())
    warp = wrt.trace(fresh, origins, directions, accel="warp", device="cpu")
    assert ours.hit.sum() > 500
    np.testing.assert_array_equal(ours.hit, warp.hit)
    np.testing.assert_allclose(ours.t[ours.hit], warp.t[warp.hit], rtol=1e-5)


@pytest.mark.parametrize("layout", ["compact", "wide8"])
def test_refit_of_a_flattened_layout_follows_instances_that_turn_mirrored(np_rng, layout):
    """Layouts other than binary trace instanced scenes flattened, and hits are mapped back to prototype triangles
    with each instance's mirroring; a refit into a frame where an instance is mirrored kept the first frame's
    flags, so u and v came back swapped on that instance's triangles."""
    from wrt.instancing import Instances, Prototype
    from wrt.scene import Mesh

    grid = np.stack(np.meshgrid(np.linspace(-1, 1, 6), np.linspace(-1, 1, 6)), -1).reshape(-1, 2)
    points = np.column_stack([grid, np.zeros(36)]).astype(np.float32)
    quads = np.array([(j * 6 + i, j * 6 + i + 1, j * 6 + i + 7, j * 6 + i + 6) for j in range(5) for i in range(5)])
    indices = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    prototype = Prototype("/P", [Mesh("/P/M", points, indices, np.arange(len(indices)))])

    def frame(z_scale):
        to_world = np.tile(np.eye(4), (3, 1, 1))
        to_world[:, 0, 3] = (-3, 0, 3)
        to_world[1, 2, 2] = z_scale  # the middle instance mirrored when negative
        return wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms([0, 0, 0], to_world))

    first, mirrored = frame(1.0), frame(-1.0)
    accel = get_accelerator(first, "wrt", "sah", "cpu", layout=layout)
    assert classify_change(first, mirrored) == "tlas"
    accel.refit(mirrored)  # what wrt.animation.follow does with a flattened tree when instances move
    mirrored._cache[("accel", "wrt", "sah", "cpu", layout)] = accel
    origins = np.column_stack([np_rng.uniform(-4, 4, 500), np_rng.uniform(-1, 1, 500), np.full(500, 5.0)])
    directions = np.tile([0.0, 0.0, -1.0], (500, 1))
    ours = wrt.trace(mirrored, origins, directions, layout=layout)
    fresh = wrt.trace(frame(-1.0), origins, directions, layout=layout)
    assert (ours.instance == 1).sum() > 50
    np.testing.assert_array_equal(ours.prim, fresh.prim)
    np.testing.assert_allclose(ours.u, fresh.u, atol=1e-6)
    np.testing.assert_allclose(ours.v, fresh.v, atol=1e-6)


def test_frames_follow_the_stage_and_equal_fresh_renders(animated):
    renderer = FrameRenderer(animated, **SIZE)
    for frame in range(1, 9):
        image = renderer.render(frame)
        fresh = wrt.render(wrt.load_usd(animated, time=frame), **SIZE)
        np.testing.assert_array_equal(image.rgb, fresh.rgb, err_msg=f"frame {frame}")
        np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"], err_msg=f"frame {frame}")
    changes = [row["change"] for row in renderer.log]
    assert changes == ["build", "refit", "tlas", "tlas", "tlas", "static", "static", "static"]
    assert not np.array_equal(renderer.render(1).rgb, renderer.render(8).rgb)  # the camera did move


def quad_grid(n: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(n+1)^2 x 3`` and quads ``(n^2, 4)`` of a slightly curved sheet over [-1.5, 1.5]^2."""
    u = np.linspace(-1.5, 1.5, n + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    points = np.stack([x, y, 0.1 * x * y], -1).reshape(-1, 3).astype(np.float32)
    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).reshape(-1)
    return points, np.stack([a, a + n + 1, a + n + 2, a + 1], 1).astype(np.int32)


def topology_stage(path):
    """Topology that changes with time: a sheet whose quads are cut along the other diagonal (the same triangle count,
    other triangles) and then reversed, holes that move, and a PointInstancer whose instances swap prototypes and
    hide by id."""
    from pxr import Sdf, Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set((0, 0, 6))
    points, quads = quad_grid()
    sheet = UsdGeom.Mesh.Define(stage, "/Sheet")
    sheet.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    counts, indices, holes = (sheet.CreateFaceVertexCountsAttr(), sheet.CreateFaceVertexIndicesAttr(),
                              sheet.CreateHoleIndicesAttr())
    for t, faces, hole in ((1, quads, []), (2, np.roll(quads, 1, axis=1), [4]), (3, quads[::-1], [0, 8])):
        counts.Set(Vt.IntArray([4] * len(faces)), t)
        indices.Set(Vt.IntArray.FromNumpy(faces.reshape(-1)), t)
        holes.Set(Vt.IntArray(hole), t)
    instancer = UsdGeom.PointInstancer.Define(stage, "/PI")
    box = UsdGeom.Mesh.Define(stage, "/PI/Box/M")
    box.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points * 0.15 + np.float32([0, 0, 0.5])))
    box.CreateFaceVertexCountsAttr(Vt.IntArray([4] * len(quads)))
    box.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.reshape(-1)))
    UsdGeom.Sphere.Define(stage, "/PI/Ball/S").CreateRadiusAttr(0.25)
    instancer.CreatePrototypesRel().SetTargets([Sdf.Path("/PI/Box"), Sdf.Path("/PI/Ball")])
    instancer.CreatePositionsAttr([(-1, -1, 0), (1, -1, 0), (-1, 1, 0), (1, 1, 0)])
    instancer.CreateIdsAttr([10, 11, 12, 13])
    proto_indices, hidden = instancer.CreateProtoIndicesAttr(), instancer.CreateInvisibleIdsAttr()
    for t, drawn, ids in ((1, [0, 1, 0, 1], []), (2, [1, 0, 1, 0], [11]), (3, [1, 0, 1, 0], [10, 13])):
        proto_indices.Set(drawn, t)
        hidden.Set(ids, t)
    stage.Save()


def motion_stage(path):
    """Everything but topology moves: native instances of a prototype whose mesh deforms and whose sphere grows, a
    sphere and a cube of animated size, the camera's focal length and clipping range, a material's colour."""
    from pxr import Sdf, Usd, UsdGeom, UsdShade, Vt

    stage = Usd.Stage.CreateNew(str(path))
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    camera.AddTranslateOp().Set((0, 0, 6))
    focal, clipping = camera.CreateFocalLengthAttr(), camera.CreateClippingRangeAttr()
    focal.Set(30.0, 1), focal.Set(45.0, 3)
    clipping.Set((0.1, 100), 1), clipping.Set((5.5, 100), 3)  # cuts the instances' near sides at frame 3
    points, quads = quad_grid()
    stage.DefinePrim("/Protos/A", "Xform")
    mesh = UsdGeom.Mesh.Define(stage, "/Protos/A/M")
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([4] * len(quads)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.reshape(-1)))
    mesh.CreatePointsAttr().Set(Vt.Vec3fArray.FromNumpy(points * 0.3), 1)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points * np.float32([0.4, 0.2, 1]) + np.float32([0, 0, 0.6])), 2)
    ball = UsdGeom.Sphere.Define(stage, "/Protos/A/S")
    ball.AddTranslateOp().Set((0, 0, 0.3))
    ball.CreateRadiusAttr().Set(0.1, 1), ball.GetRadiusAttr().Set(0.3, 3)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierClass)
    for k in range(2):
        instance = UsdGeom.Xform.Define(stage, f"/I{k}")
        instance.GetPrim().GetReferences().AddInternalReference("/Protos/A")
        instance.GetPrim().SetInstanceable(True)
        instance.AddTranslateOp().Set((-1.0 + 2.0 * k, 0.0, 0.0))
    sphere, cube = UsdGeom.Sphere.Define(stage, "/Sphere"), UsdGeom.Cube.Define(stage, "/Cube")
    sphere.AddTranslateOp().Set((0, 1.2, 0)), cube.AddTranslateOp().Set((0, -1.2, 0))
    sphere.CreateRadiusAttr().Set(0.2, 2), sphere.GetRadiusAttr().Set(0.5, 3)
    cube.CreateSizeAttr().Set(0.3, 2), cube.GetSizeAttr().Set(0.6, 3)
    material = UsdShade.Material.Define(stage, "/Mat")
    shader = UsdShade.Shader.Define(stage, "/Mat/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    color = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    color.Set((1, 0, 0), 1), color.Set((0, 0, 1), 3)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(sphere.GetPrim()).Bind(material)
    stage.Save()


@pytest.mark.parametrize("write_stage", [topology_stage, motion_stage])
def test_frames_equal_fresh_renders_in_every_aov(tmp_path, write_stage):
    """Frames at fractional times and going back, on stages that change topology (other triangles of the same count,
    holes, instances that swap prototypes or hide) or move everything else: colour and every AOV of each frame equal
    a fresh render of its time, bit for bit, whether the BVH was built, refitted, only its TLAS rebuilt or reused.
    ``cost`` is left out: a refitted tree visits other nodes than a fresh one (audit: passed before)."""
    path = tmp_path / "stage.usda"
    write_stage(path)
    renderer = FrameRenderer(path, **SIZE)
    pictures = set()
    for frame in (1, 1.5, 2, 2.5, 3, 3.5, 2, 1):  # 3.5: past the last samples, as frame 3
        image = renderer.render(frame)
        fresh = wrt.render(wrt.load_usd(path, time=frame), **SIZE)
        pictures.add(fresh.rgb.tobytes())
        np.testing.assert_array_equal(image.rgb, fresh.rgb, err_msg=f"frame {frame}")
        assert set(image.aovs) == set(fresh.aovs)
        for name in set(fresh.aovs) - {"cost"}:
            np.testing.assert_array_equal(image.aovs[name], fresh.aovs[name], err_msg=f"frame {frame}: {name}")
    assert len(pictures) >= 3  # the stage does change
    changes = {row["change"] for row in renderer.log[1:]}
    assert changes == ({"build", "static"} if write_stage is topology_stage else {"refit", "tlas", "static"})


def test_wp_mesh_accelerator_refits_too(animated):
    renderer = FrameRenderer(animated, accel="warp", tessellate_gprims=True, **SIZE)
    for frame in (1, 2, 3):
        image = renderer.render(frame)
        fresh = wrt.render(wrt.load_usd(animated, time=frame, tessellate_gprims=True), accel="warp", **SIZE)
        np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
    assert [row["change"] for row in renderer.log] == ["build", "refit", "refit"]


@pytest.mark.parametrize("accel", ["wrt", "warp"])
def test_frames_of_coincident_meshes_equal_fresh_renders(tmp_path, np_rng, accel):
    """Two meshes with the same moving triangles, one red and one green: every hit is a tie at exactly equal t, and
    the frame after a refit shows the same mesh a fresh render shows. wp.Mesh.refit kept its old tree, whose visiting
    order decides ties, so a refitted frame under accel="warp" differed at a third of the pixels."""
    from pxr import Gf, Usd, UsdGeom, Vt

    path = str(tmp_path / "twins.usda")
    stage = Usd.Stage.CreateNew(path)
    n = 200
    frames = {t: (np_rng.random((3 * n, 3)) * [4, 4, 1]).astype(np.float32) for t in (1.0, 2.0)}
    for name, color in (("A", (1, 0, 0)), ("B", (0, 1, 0))):
        mesh = UsdGeom.Mesh.Define(stage, f"/{name}")
        mesh.CreateDisplayColorPrimvar().Set([Gf.Vec3f(*color)])
        mesh.CreateFaceVertexCountsAttr([3] * n)
        mesh.CreateFaceVertexIndicesAttr(list(range(3 * n)))
        for t, points in frames.items():
            mesh.CreatePointsAttr().Set(Vt.Vec3fArray.FromNumpy(points), t)
    stage.Save()
    camera = wrt.Camera.look_at((2, 2, 8), (2, 2, 0), (0, 1, 0), 40)
    renderer = FrameRenderer(path, camera=camera, accel=accel, **SIZE)
    renderer.render(1.0)
    image = renderer.render(2.0)
    fresh = wrt.render(wrt.load_usd(path, time=2.0), camera=camera, accel=accel, **SIZE)
    assert (image.aovs["prim"] >= 0).mean() > 0.3
    np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
    np.testing.assert_array_equal(image.rgb, fresh.rgb)


def test_topology_change_and_scrambled_vertices_rebuild(tmp_path, np_rng):
    from pxr import Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(tmp_path / "topo.usda"))
    mesh = UsdGeom.Mesh.Define(stage, "/M")
    grid = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0), indexing="ij"), -1).reshape(-1, 2)
    flat = np.concatenate([grid, np.zeros((100, 1))], axis=1).astype(np.float32)
    scrambled = flat[np_rng.permutation(100)]  # same triangles, vertices thrown across the sheet
    tris = np.array([[a, a + 1, a + 10] for a in range(89) if a % 10 != 9], np.int32)
    mesh.CreatePointsAttr().Set(Vt.Vec3fArray.FromNumpy(flat), 1)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(scrambled), 2)
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(flat), 3)
    counts = mesh.CreateFaceVertexCountsAttr()
    index_attr = mesh.CreateFaceVertexIndicesAttr()
    for t, n in ((1, len(tris)), (3, len(tris) - 5)):
        counts.Set(Vt.IntArray([3] * n), t)
        index_attr.Set(Vt.IntArray.FromNumpy(tris[:n].reshape(-1)), t)
    stage.GetRootLayer().Save()
    renderer = FrameRenderer(tmp_path / "topo.usda", **SIZE)
    for frame in (1, 2, 3):
        image = renderer.render(frame)
        fresh = wrt.render(wrt.load_usd(tmp_path / "topo.usda", time=frame), **SIZE)
        np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
    # Frame 2 refits into a tree far worse than a fresh build (rebuild); frame 3 has fewer faces (rebuild).
    assert [row["change"] for row in renderer.log] == ["build", "build", "build"]


def test_a_mesh_that_grows_from_a_point_gets_a_tree_of_its_grown_shape(tmp_path):
    """A grow-in (a scale from 0): the tree of frame 1 is built over one point, whose SAH cost is 0, and the 20% rule
    compared the refitted cost with it only when it was above 0, so every later frame refitted that tree: at full
    size it visited 3 times the nodes and tested 7 times the triangles of a fresh build, for the rest of the shot."""
    from pxr import Usd, UsdGeom, Vt

    from wrt.animation import REFIT_SAH_LIMIT
    from wrt.bvh.stats import sah_cost
    from wrt.procedural import displaced_sphere

    path = str(tmp_path / "grow.usda")
    stage = Usd.Stage.CreateNew(path)
    mesh = UsdGeom.Mesh.Define(stage, "/Ball")
    points, indices = displaced_sphere(2000)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    mesh.CreateFaceVertexCountsAttr([3] * len(indices))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(indices, np.int32).reshape(-1)))
    scale = mesh.AddScaleOp()
    scale.Set((0, 0, 0), 1)
    scale.Set((1, 1, 1), 3)
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set((0, 0, 4))
    stage.Save()
    renderer = FrameRenderer(path, device="cpu", **SIZE)
    for frame in (1, 2, 3):
        image = renderer.render(frame)
        fresh_scene = wrt.load_usd(path, time=frame)
        fresh = wrt.render(fresh_scene, device="cpu", **SIZE)
        np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
    traced = _traced_accelerator(renderer)
    built = get_accelerator(fresh_scene, "wrt", "sah", "cpu")  # a tree built for frame 3's triangles
    assert sah_cost(built.bvh) > 0
    assert sah_cost(traced.bvh) <= REFIT_SAH_LIMIT * sah_cost(built.bvh)


def test_a_frame_that_fails_after_its_refit_leaves_no_stale_tree(tmp_path, monkeypatch):
    """A frame that failed once its BVH had been refitted (here out of memory in the render) left the tree holding
    its vertices: the next frame, equal to the frame before the failure, was classified 'static' against that one
    and drawn with the failed frame's triangles (138 of 1728 pixels saw other triangles than a fresh render)."""
    from pxr import Usd, UsdGeom

    path = str(tmp_path / "fails.usda")
    stage = Usd.Stage.CreateNew(path)
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    square = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    for t, points in ((1, square), (2, [(-2, -1, 0), (1, -1, 0), (1, 2, 0), (-1, 1, 0)]), (3, square)):
        mesh.CreatePointsAttr().Set(points, t)
    stage.Save()
    camera = wrt.Camera.look_at((0, 0, 6), (0, 0, 0), (0, 1, 0), 50)
    renderer = FrameRenderer(path, camera=camera, **SIZE)
    renderer.render(1)
    render = wrt.Renderer.render

    def out_of_memory(self, *args, **kwargs):
        raise RuntimeError("Failed to allocate 1 GiB")

    monkeypatch.setattr(wrt.Renderer, "render", out_of_memory)
    with pytest.raises(RuntimeError, match="allocate"):
        renderer.render(2)
    monkeypatch.setattr(wrt.Renderer, "render", render)
    image = renderer.render(3)
    fresh = wrt.render(wrt.load_usd(path, time=3), camera=camera, **SIZE)
    np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
    np.testing.assert_array_equal(image.rgb, fresh.rgb)
    assert [row["change"] for row in renderer.log] == ["build", "build"]


def nan_at_frame_2(tmp_path) -> Path:
    """A quad whose points hold a NaN at time 2 only (and move between the other frames)."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "nan_at_2.usda"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    points = mesh.CreatePointsAttr()
    points.Set([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 1)
    points.Set([(-1, -1, 0), (float("nan"), -1, 0), (1, 1, 0), (-1, 1, 0)], 2)
    points.Set([(-1, -1, 0.5), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 3)
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set((0, 0, 6))
    stage.Save()
    return path


@pytest.mark.parametrize("where", ["serial", "two devices", "dask"])
def test_a_bad_frame_is_an_error_row_naming_it_and_the_other_frames_render(tmp_path, where):
    """A frame whose stage is bad at its time (NaN points) ended the run at that frame, serially with an error
    naming the prim but not the frame, and over two devices dropping the frame the other worker was rendering; the
    frames after it were never rendered, and on Dask they were but the run still raised, so no log was written."""
    path = nan_at_frame_2(tmp_path)
    jobs = pending_frames(parse_frames("1:3"), tmp_path / "out" / "f_#.npy", resume=False)
    if where == "dask":
        pytest.importorskip("distributed")
        from wrt.animation import render_frames_on_dask

        rows = render_frames_on_dask(path, jobs, n_workers=1, **SIZE)
    else:
        rows = render_frames(path, jobs, devices=["cpu"] if where == "serial" else ["cpu", "cpu"], **SIZE)
    assert sorted(row["frame"] for row in rows) == [1.0, 2.0, 3.0]
    failed = [row for row in rows if "error" in row]
    assert len(failed) == 1 and failed[0]["frame"] == 2.0 and failed[0]["output"] == str(jobs[1][1])
    assert failed[0]["device"] == "cpu"  # where it ran, as the rendered frames' rows say (it named none)
    assert failed[0]["error"].startswith("SceneError: ") and "/Quad: points[1]" in failed[0]["error"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["f_1.npy", "f_3.npy"]
    for frame in (1, 3):
        fresh = wrt.render(wrt.load_usd(path, time=frame), **SIZE)
        np.testing.assert_array_equal(np.load(tmp_path / "out" / f"f_{frame}.npy"), fresh.rgb)


def test_a_bad_frame_on_dask_is_one_line_not_a_workers_traceback(tmp_path, capfd):
    """A frame whose stage is bad at its time raised out of the Dask task, and the LocalCluster's worker logged it on
    the user's terminal as 'distributed.worker - ERROR - Compute Failed' with the whole wrt traceback, beside wrt's
    own one-line report of the frame. The frame is still an error row; the worker logs nothing."""
    pytest.importorskip("distributed")
    from pxr import Usd, UsdGeom

    from wrt.animation import render_frames_on_dask

    path = nan_at_frame_2(tmp_path)
    stage = Usd.Stage.Open(str(path))
    points = UsdGeom.Mesh(stage.GetPrimAtPath("/Quad")).GetPointsAttr()
    bad = [t for t in (1.0, 2.0, 3.0) if not np.isfinite(np.array(points.Get(t), np.float64)).all()]
    jobs = pending_frames([1.0, 2.0, 3.0], tmp_path / "out" / "f_#.npy", resume=False)
    rows = render_frames_on_dask(path, jobs, n_workers=1, **SIZE)
    failed = [row for row in rows if "error" in row]
    assert [row["frame"] for row in failed] == bad == [2.0]
    assert failed[0]["error"].startswith("SceneError: ") and failed[0]["device"] == "cpu"
    err = capfd.readouterr().err
    assert "Compute Failed" not in err and "Traceback" not in err, err[-2000:]


@pytest.mark.parametrize("where", ["serial", "two devices", "dask"])
def test_frames_outside_the_time_range_warn_once_naming_them(tmp_path, where):
    """--frames 0:8 of a stage authored over [1, 3] warned once per frame outside it (6 warnings here, 1000 for a
    long range past the end); one warning names those frames and the stage's range, from every kind of run."""
    path = tmp_path / "short.usda"
    path.write_text("""#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 3
)
def Sphere "Ball"
{
    double3 xformOp:translate.timeSamples = { 1: (0, 0, 0), 3: (1, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
""")
    jobs = pending_frames(parse_frames("0:8"), tmp_path / "out" / "f_#.npy", resume=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if where == "dask":
            pytest.importorskip("distributed")
            from wrt.animation import render_frames_on_dask

            rows = render_frames_on_dask(path, jobs, n_workers=1, **SIZE)
        else:
            rows = render_frames(path, jobs, devices=["cpu"] if where == "serial" else ["cpu", "cpu"], **SIZE)
    assert sorted(row["frame"] for row in rows) == list(range(9)) and not any("error" in row for row in rows)
    about_time = [str(w.message) for w in caught if "time range" in str(w.message)]
    assert about_time == ["short.usda: frames 0 and 4 to 8 (6 of 9) are outside the stage's time range [1, 3]; USD "
                          "holds the values of the nearest time samples"]
    with pytest.warns(UserWarning, match=r"short.usda: frame 9 is outside the stage's time range \[1, 3\]"):
        render_frames(path, pending_frames([9.0], tmp_path / "g_#.npy", resume=False), **SIZE)


@pytest.mark.parametrize("where", ["serial", "two devices"])
def test_each_frames_log_row_names_the_warnings_of_that_frame(tmp_path, where):
    """An instancer whose position is NaN at frame 2 alone: its instance is skipped with a warning, said once per run
    and naming no frame, so nothing told which frame of a long run lost it. Each row lists its frame's warnings:
    those of the frames USD gives a non-finite position at, and only those."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "nan_instance.usda"
    path.write_text("""#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 3
)
def PointInstancer "PI"
{
    point3f[] positions.timeSamples = {
        1: [(0, 0, 0), (2, 0, 0)], 2: [(0, 0, 0), (nan, 0, 0)], 3: [(0, 0, 0), (2, 0, 0)] }
    int[] protoIndices = [0, 0]
    rel prototypes = </PI/Protos/Ball>
    def Scope "Protos"
    {
        def Sphere "Ball"
        {
        }
    }
}
def Camera "Cam"
{
    double3 xformOp:translate = (1, 0, 8)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
""")
    stage = Usd.Stage.Open(str(path))
    positions = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI")).GetPositionsAttr()
    bad = {t for t in (1.0, 2.0, 3.0) if not np.isfinite(np.array(positions.Get(t), np.float64)).all()}
    assert bad == {2.0}
    jobs = pending_frames([1.0, 2.0, 3.0], tmp_path / "out" / "f_#.npy", resume=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = render_frames(path, jobs, devices=["cpu"] if where == "serial" else ["cpu", "cpu"], **SIZE)
    said = [str(w.message) for w in caught if "non-finite" in str(w.message)]
    assert len(said) == 1, said  # still said once on screen
    by_frame = {row["frame"]: row for row in rows}
    assert sorted(by_frame) == [1.0, 2.0, 3.0] and not any("error" in row for row in rows)
    for frame, row in by_frame.items():
        named = [m for m in row["warnings"] if "non-finite" in m and "/PI" in m]
        assert len(named) == (frame in bad), (frame, row["warnings"])


def blind_at_frame_2(tmp_path) -> Path:
    """A ball and a camera that moves past its far clip at frame 2 only: that frame warns that it sees nothing."""
    path = tmp_path / "blind.usda"
    path.write_text("""#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 3
)
def Sphere "Ball"
{
}
def Camera "Cam"
{
    double3 xformOp:translate.timeSamples = { 1: (0, 0, 6), 2: (0, 0, 2000000), 3: (0, 0, 6) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
""")
    return path


@pytest.mark.parametrize("where", ["serial", "two devices"])
def test_a_warning_the_callers_filters_make_an_error_fails_its_frame(tmp_path, where):
    """Under the caller's warnings-as-errors (``-W error``), a frame's warning was recorded under an 'always' filter,
    the frame written, and the warning raised after it, ending the run: frame 2 wrote its file and frame 3 never
    rendered. It is that frame's error row now, as under those filters a render of that frame alone raises it."""
    path = blind_at_frame_2(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(UserWarning) as alone:
            wrt.render(wrt.load_usd(path, time=2), **SIZE)
        jobs = pending_frames(parse_frames("1:3"), tmp_path / "out" / "f_#.npy", resume=False)
        rows = render_frames(path, jobs, devices=["cpu"] if where == "serial" else ["cpu", "cpu"], **SIZE)
    assert sorted(row["frame"] for row in rows) == [1.0, 2.0, 3.0]
    failed = [row for row in rows if "error" in row]
    assert len(failed) == 1 and failed[0]["frame"] == 2.0 and failed[0]["output"] == str(jobs[1][1])
    assert failed[0]["error"] == f"UserWarning: {str(alone.value).splitlines()[0]}"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["f_1.npy", "f_3.npy"]
    for frame in (1, 3):
        fresh = wrt.render(wrt.load_usd(path, time=frame), **SIZE)
        np.testing.assert_array_equal(np.load(tmp_path / "out" / f"f_{frame}.npy"), fresh.rgb)


def test_a_frame_warning_keeps_its_category_over_devices(tmp_path, monkeypatch):
    """A worker's warning reaches the client's filters with its own category, as in a serial run: the client gave
    every one as a UserWarning, so ``-W error::RuntimeWarning`` failed the frame serially and not over devices (and
    a filter ignoring a category did not silence it). The worker's task is run here, in-process; the oracle is the
    serial run's row under the same filter."""
    from wrt.animation import _frame_writer, _task, render_frame_task

    original = FrameRenderer.render

    def render(self, frame, **kwargs):
        image = original(self, frame, **kwargs)
        warnings.warn(f"frame {frame:g} drew a NaN", RuntimeWarning)  # as numpy's, a warning of its own category
        return image

    monkeypatch.setattr(FrameRenderer, "render", render)
    path = blind_at_frame_2(tmp_path)
    jobs = pending_frames([1.0], tmp_path / "out" / "f_#.npy", resume=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        serial = render_frames(path, jobs, devices=["cpu"], **SIZE)
        result = render_frame_task(_task(str(path), 1.0, jobs[0][1], 1, 0, 0.0, SIZE))
        rows = []
        _frame_writer(rows)(result, jobs[0][1])
    assert serial[0]["error"] == "RuntimeWarning: frame 1 drew a NaN"
    assert [row.get("error") for row in rows] == [serial[0]["error"]]
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())


def test_cli_frames_name_the_frames_that_failed_and_exit_1(tmp_path, capsys):
    from wrt.cli import main

    path = nan_at_frame_2(tmp_path)
    log = tmp_path / "log.jsonl"
    argv = ["render", str(path), "--frames", "1:3", "-o", str(tmp_path / "f_#.png"), "--log", str(log), "-q"]
    assert main(argv + ["--width", "16", "--height", "12"]) == 1
    err = capsys.readouterr().err
    assert "wrt: error: frame 2: " in err and "/Quad: points[1] = (nan, -1.0, 0.0) is not finite" in err
    assert "1 of 3 frames failed" in err
    assert sorted(p.name for p in tmp_path.glob("f_*.png")) == ["f_1.png", "f_3.png"]
    assert ["error" in row for row in map(json.loads, log.read_text().splitlines())] == [False, True, False]
    broken = tmp_path / "broken.usda"
    broken.write_text("not USD")
    assert main(["render", str(broken), "--frames", "1:3", "-o", str(tmp_path / "b_#.png"), "-q"]) == 2  # none
    err = capsys.readouterr().err
    assert err.count("USD cannot open this file") == 1 and "wrt: error: frames 1, 2, 3: " in err


def test_cli_frames_log_is_strict_json(animated, tmp_path, monkeypatch):
    """A frame row with a NaN or infinite number (a timer without a value) is written with null: Python's json wrote
    bare NaN and Infinity, which jq and JSON.parse refuse for the whole log."""
    import wrt.animation
    from wrt.cli import main

    def rows_with_non_finite_numbers(path, jobs, log=None, **kwargs):
        rows = wrt.animation.LogRows(log)
        for frame, file in jobs:
            rows.append({"frame": frame, "output": str(file), "change": "build", "load_ms": math.inf,
                         "update_ms": -math.inf, "render_ms": np.float64("nan")})
        return rows

    monkeypatch.setattr(wrt.animation, "render_frames", rows_with_non_finite_numbers)
    log = tmp_path / "log.jsonl"
    assert main(["render", str(animated), "--frames", "1:2", "-o", str(tmp_path / "f_#.png"), "--log", str(log),
                 "-q", "--width", "8", "--height", "6"]) == 0

    def refuse(name):
        raise ValueError(f"{name} is not JSON")

    rows = [json.loads(line, parse_constant=refuse) for line in log.read_text().splitlines()]
    assert [(r["frame"], r["load_ms"], r["update_ms"], r["render_ms"]) for r in rows] == [(1.0, None, None, None),
                                                                                         (2.0, None, None, None)]


def test_cli_frames_log_keeps_the_rows_of_the_frames_finished_before_ctrl_c(animated, tmp_path, monkeypatch, capsys):
    """README: an interrupted run keeps what it has. The --frames log was written once every frame was done, so
    Ctrl-C at frame 3 of 3 left the images of frames 1 and 2 and no log at all (a batch of scenes flushes a row per
    scene). The frame cut short has a row too, ``interrupted``, as a batch's scene cut short has (it had none)."""
    from wrt.cli import main

    render = FrameRenderer.render

    def interrupted_at_frame_3(self, frame, **kwargs):
        if frame == 3:
            raise KeyboardInterrupt
        return render(self, frame, **kwargs)

    monkeypatch.setattr(FrameRenderer, "render", interrupted_at_frame_3)
    log = tmp_path / "logs" / "log.jsonl"
    assert main(["render", str(animated), "--frames", "1:3", "-o", str(tmp_path / "f_#.npy"), "--log", str(log),
                 "-q", "--width", "8", "--height", "6"]) == 130
    assert "wrt: interrupted" in capsys.readouterr().err
    rows = [json.loads(line) for line in log.read_text().splitlines()]
    assert [(r["frame"], Path(r["output"]).name, r["status"]) for r in rows] == [
        (1.0, "f_1.npy", "ok"), (2.0, "f_2.npy", "ok"), (3.0, "f_3.npy", "interrupted")]
    assert len({r["run"] for r in rows}) == 1 and rows[2]["device"] == "cpu" and "output_mtime_ns" not in rows[2]
    assert sorted(p.name for p in tmp_path.glob("f_*.npy")) == ["f_1.npy", "f_2.npy"]
    # --resume renders only the frame cut short, as it does the scene a batch cut short.
    monkeypatch.setattr(FrameRenderer, "render", render)
    assert main(["render", str(animated), "--frames", "1:3", "-o", str(tmp_path / "f_#.npy"), "--log", str(log),
                 "-q", "--width", "8", "--height", "6", "--resume"]) == 0
    rows = [json.loads(line) for line in log.read_text().splitlines()][3:]
    assert sorted((r["frame"], r["status"]) for r in rows) == [(1.0, "skipped"), (2.0, "skipped"), (3.0, "ok")]


def test_render_frames_refuses_an_unknown_device_before_starting_workers(animated, tmp_path, monkeypatch):
    """--devices cpu,cuda:7 on a machine without that GPU: the name was only checked in a spawned worker, which
    failed seconds later under a started progress bar; now it is a ValueError before any process starts."""
    import concurrent.futures

    def no_pool(*args, **kwargs):
        raise AssertionError("a worker pool was started for a device that does not exist")

    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", no_pool)
    jobs = pending_frames(parse_frames("1:2"), tmp_path / "f_##.npy", resume=False)
    with pytest.raises(ValueError, match="available devices"):
        render_frames(animated, jobs, devices=["cpu", "nodevice:7"], **SIZE)
    assert not list(tmp_path.glob("f_*.npy"))


def test_render_frames_on_two_devices_writes_every_frame(animated, tmp_path, capfd):
    jobs = pending_frames(parse_frames("1:6"), tmp_path / "f_##.npy", resume=False)
    rows = render_frames(animated, jobs, devices=["cpu", "cpu"], **SIZE)
    assert sorted(row["frame"] for row in rows) == [1, 2, 3, 4, 5, 6]
    worker_output = capfd.readouterr()  # the workers write to the same file descriptors
    assert "initialized" not in worker_output.out + worker_output.err  # Warp's banner, once per worker
    assert "Module wrt." not in worker_output.out + worker_output.err  # and a line per kernel module loaded
    serial = FrameRenderer(animated, **SIZE)
    for frame in range(1, 7):
        np.testing.assert_array_equal(np.load(tmp_path / f"f_{frame:02d}.npy"), serial.render(frame).rgb)
    assert pending_frames(parse_frames("1:8"), tmp_path / "f_##.npy", resume=True) == [
        (7.0, tmp_path / "f_07.npy"),
        (8.0, tmp_path / "f_08.npy"),
    ]


def test_aov_dir_with_frames_writes_each_frames_aovs_numbered_as_the_images(animated, tmp_path):
    """--aov-dir was refused with --frames. It writes DIR/NAME_##.npy per frame now, numbered as -o numbers the images
    (two #: _01), each equal to the AOV of a fresh render of its time (cost left out: a refitted tree visits other
    nodes), and the log rows name the files."""
    from wrt.cli import main
    from wrt.render import AOV_NAMES

    size = {"width": 16, "height": 12}
    argv = ["render", str(animated), "--frames", "1:2", "-o", str(tmp_path / "f_##.npy"), "--aov-dir",
            str(tmp_path / "aovs"), "--width", "16", "--height", "12", "-q"]
    logged = ["--log", str(tmp_path / "log.jsonl")]
    assert main(argv + logged) == 0
    assert sorted(p.name for p in (tmp_path / "aovs").iterdir()) == sorted(f"{n}_0{f}.npy" for n in AOV_NAMES
                                                                          for f in (1, 2))
    rows = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    for frame in (1, 2):
        fresh = wrt.render(wrt.load_usd(animated, time=frame), **size)
        for name in set(AOV_NAMES) - {"cost"}:
            np.testing.assert_array_equal(np.load(tmp_path / "aovs" / f"{name}_0{frame}.npy"), fresh.aovs[name])
        row = next(row for row in rows if row["frame"] == frame)
        assert sorted(row["aov_files"]) == sorted(str(tmp_path / "aovs" / f"{n}_0{frame}.npy") for n in AOV_NAMES)
    # --resume renders a frame whose AOV file is gone again, by the log (after a run that skipped every frame, whose
    # rows carry the files) or, without one, by the files on disk.
    assert main(argv + logged + ["--resume"]) == 0
    for gone, options in (("depth_02.npy", logged + ["--resume"]), ("z_01.npy", ["--resume"])):
        (tmp_path / "aovs" / gone).unlink()
        assert main(argv + options) == 0 and (tmp_path / "aovs" / gone).is_file(), gone


def test_aov_dir_numbers_frames_as_the_images_when_the_scene_name_holds_a_hash(animated, tmp_path):
    """-o renders/{stem}.png of shot#1.usda numbers the images shot#1_0001.png (a # in the scene's name is no frame
    placeholder), but --aov-dir took the stem's # as the run to number with: depth_1.npy, not depth_0001.npy as its
    help says ('numbered as the images'). The oracle is the images' own numbers, read from the files written."""
    from wrt.cli import main
    from wrt.render import AOV_NAMES

    scene = tmp_path / "shot#1.usda"
    scene.write_bytes(animated.read_bytes())
    argv = ["render", str(scene), "--frames", "1:2", "-o", str(tmp_path / "renders" / "{stem}.npy"), "--aov-dir",
            str(tmp_path / "aovs"), "--width", "8", "--height", "6", "-q"]
    assert main(argv) == 0
    images = sorted(p.name for p in (tmp_path / "renders").iterdir())
    assert images == ["shot#1_0001.npy", "shot#1_0002.npy"]
    numbers = [name.removeprefix("shot#1_").removesuffix(".npy") for name in images]
    assert sorted(p.name for p in (tmp_path / "aovs").iterdir()) == sorted(f"{n}_{k}.npy" for n in AOV_NAMES
                                                                          for k in numbers)


def test_two_jobs_of_one_frame_on_two_devices_write_both_files(animated, tmp_path):
    """A frame asked for as .npy and as .png: the workers' results were matched to files by frame, so both went to the
    last job's file (f_1.png never written, the rows naming f_1.npy twice), where a serial run writes each."""
    from PIL import Image as PilImage

    from wrt.animation import aov_files

    jobs = [(1.0, tmp_path / "f_1.png"), (1.0, tmp_path / "f_1.npy")]
    aov_pattern = tmp_path / "aovs" / "{name}_#.npy"  # the AOVs come back from the workers too, written here
    rows = render_frames(animated, jobs, devices=["cpu", "cpu"], aov_pattern=aov_pattern, **SIZE)
    assert sorted(row["output"] for row in rows) == sorted(str(file) for _, file in jobs)
    serial = FrameRenderer(animated, **SIZE).render(1.0)
    np.testing.assert_array_equal(np.load(tmp_path / "f_1.npy"), serial.rgb)
    files = aov_files(aov_pattern, 1.0)
    assert all(sorted(row["aov_files"]) == sorted(map(str, files.values())) for row in rows), rows
    for name, file in files.items():
        np.testing.assert_array_equal(np.load(file), serial.aovs[name], err_msg=name)
    with PilImage.open(tmp_path / "f_1.png") as png:
        assert png.format == "PNG" and png.size == (SIZE["width"], SIZE["height"])


def test_worker_warnings_reach_the_caller_once(tmp_path):
    """A stage that warns when loaded, its frames spread over two worker processes: each worker printed the warning
    to its own stderr in Python's format (across the progress bar); now the caller gets it as a warning, once."""
    stage = tmp_path / "warns.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n'
                     '    color3f[] primvars:displayColor = [(nan, 0, 0)]\n}\n')
    jobs = pending_frames(parse_frames("1:4"), tmp_path / "f_#.npy", resume=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        render_frames(stage, jobs, devices=["cpu", "cpu"], **SIZE)
    messages = [str(w.message) for w in caught if "displayColor" in str(w.message)]
    assert len(messages) == 1 and "/M" in messages[0]


def test_a_worker_frames_warning_reaches_the_caller_in_its_own_class(tmp_path, monkeypatch):
    """The frames of several devices (or of a Dask cluster) sent their warnings back as words and the caller warned
    each as a UserWarning: a filter of the warning's own class (``-W error::RuntimeWarning``) caught it in a run on
    one device only. The worker's task, run here as a worker runs it, now hands each back in its class, as the run
    on one device shows it."""
    from wrt import animation

    stage = tmp_path / "tri.usda"
    stage.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    render = FrameRenderer.render

    def render_with_a_runtime_warning(self, *args, **kwargs):
        warnings.warn("a frame's own RuntimeWarning", RuntimeWarning)
        return render(self, *args, **kwargs)

    monkeypatch.setattr(FrameRenderer, "render", render_with_a_runtime_warning)
    monkeypatch.setattr(animation, "_WORKER_RENDERERS", {})
    size = {"width": 8, "height": 6}
    shown = {}
    for run in ("serial", "worker"):
        file = tmp_path / f"{run}_1.npy"
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if run == "serial":
                render_frames(stage, [(1.0, file)], **size)
            else:
                job = animation._task(os.fspath(stage), 1.0, file, 1, 0, 0.0, size)
                animation._frame_writer([])(animation.render_frame_task(job), file)
        shown[run] = [w.category for w in caught if "own RuntimeWarning" in str(w.message)]
    assert shown["serial"] == [RuntimeWarning]
    assert shown["worker"] == shown["serial"]


def sigint_is_ignored(answers):
    import signal

    answers.put(signal.getsignal(signal.SIGINT) == signal.SIG_IGN)


def test_frame_workers_start_with_ctrl_c_ignored():
    """The terminal's Ctrl-C reaches every process of the group: a worker still importing, before its initializer
    ignores it, printed a KeyboardInterrupt traceback (the Ctrl-C test below, 2 runs in 6 on a loaded machine).
    Processes started inside _children_ignore_ctrl_c start with it ignored; the parent's handler comes back after."""
    import multiprocessing
    import signal

    from wrt.animation import _children_ignore_ctrl_c

    context = multiprocessing.get_context("spawn")
    answers = context.Queue()
    # As in a terminal: a shell that starts pytest in the background (CI scripts do) hands it SIGINT ignored, and
    # every child would inherit that.
    outer = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        for ignored in (True, False):
            if ignored:
                with _children_ignore_ctrl_c():
                    child = context.Process(target=sigint_is_ignored, args=(answers,))
                    child.start()
            else:
                child = context.Process(target=sigint_is_ignored, args=(answers,))
                child.start()
            child.join(60)
            assert answers.get(timeout=60) is ignored
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, outer)


def test_cli_frames_on_dask_log_the_frames_ctrl_c_cut_short(animated, tmp_path, monkeypatch, capsys):
    """--frames --dask wrote no interrupted rows at Ctrl-C, where the plain and --devices runs do: the log said
    nothing of the frame being written, nor of those a worker was rendering. Frames still queued get no row."""
    pytest.importorskip("distributed")
    from wrt import animation
    from wrt.cli import main

    frame_writer = animation._frame_writer

    def interrupted_at_frame_2(rows, *args):  # args: the AOV pattern
        write = frame_writer(rows, *args)

        def cut(result, file):
            if result["row"]["frame"] == 2.0:
                raise KeyboardInterrupt  # as Ctrl-C while the frame is written
            write(result, file)

        return cut

    monkeypatch.setattr(animation, "_frame_writer", interrupted_at_frame_2)
    log = tmp_path / "log.jsonl"
    assert main(["render", str(animated), "--frames", "1:8", "--dask", "--workers", "1", "-o",
                 str(tmp_path / "f_#.npy"), "--log", str(log), "-q", "--width", "8", "--height", "6"]) == 130
    assert "wrt: interrupted" in capsys.readouterr().err
    rows = [json.loads(line) for line in log.read_text().splitlines()]
    written = {float(p.stem[2:]) for p in tmp_path.glob("f_*.npy")}
    assert {r["frame"] for r in rows if r["status"] == "ok"} == written
    cut = [r["frame"] for r in rows if r["status"] == "interrupted"]
    assert 2.0 in cut and not written & set(cut) and len(rows) == len(written) + len(cut), rows
    # The frame being written, the one the worker was rendering and one it sent back meanwhile at most: one worker
    # holds one task at a time, so the frames queued behind them were not started.
    assert len(cut) <= 3 and len(rows) < 8, rows


def test_ctrl_c_stops_frames_on_two_devices_at_once_and_keeps_the_written_ones(animated, tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) during ``--frames --devices`` left the
    process pool with shutdown(wait=True): every queued frame was rendered first, and their images thrown away. The
    log says which frames were cut short (it had no row for them)."""
    import signal
    import time

    out = tmp_path / "frames" / "f_#.npy"
    cmd = [sys.executable, "-m", "wrt.cli", "render", str(animated), "--frames", "1:8:0.004", "--devices", "cpu,cpu",
           "-o", str(out), "--width", "16", "--height", "12", "-q",
           "--log", str(tmp_path / "log.jsonl")]  # 1751 frames: minutes of work
    with open(tmp_path / "stderr.txt", "w") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        try:
            deadline = time.monotonic() + 120
            while len(list(out.parent.glob("*.npy"))) < 3 and proc.poll() is None and time.monotonic() < deadline:
                time.sleep(0.1)
            assert proc.poll() is None, "the run ended before it could be interrupted"
            os.killpg(proc.pid, signal.SIGINT)
            sent = time.monotonic()
            status = proc.wait(timeout=30)
            assert time.monotonic() - sent < 15
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    stderr = (tmp_path / "stderr.txt").read_text()
    assert status == 130 and "wrt: interrupted" in stderr and "Traceback" not in stderr, stderr
    assert "leaked" not in stderr, stderr  # no semaphores left behind by the ended workers
    written = sorted(out.parent.iterdir())
    assert 3 <= len(written) < 1751 and all(p.suffix == ".npy" for p in written)  # no partial files
    frames = {float(p.stem[2:]) for p in written}
    serial = FrameRenderer(animated, width=16, height=12)
    for path in written[:2]:  # complete images
        np.testing.assert_array_equal(np.load(path), serial.render(float(path.stem[2:])).rgb)
    assert len(frames) == len(written)
    rows = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    assert {r["frame"] for r in rows if r["status"] == "ok"} == frames
    # Cut short: a frame in each worker, those in the pool's call queue for the next free one (ProcessPoolExecutor
    # marks the workers + EXTRA_QUEUED_CALLS there running), and one per worker sent back but not yet written. (A
    # bound of 2 + 1 + 2 failed once under load with 6: the queue holds 3.)
    from concurrent.futures.process import EXTRA_QUEUED_CALLS

    workers = 2
    most = workers + (workers + EXTRA_QUEUED_CALLS) + workers
    cut = [r["frame"] for r in rows if r["status"] == "interrupted"]
    assert 1 <= len(cut) <= most and not frames & set(cut) and len(rows) == len(frames) + len(cut), rows


def test_cli_frames_and_resume(animated, tmp_path):
    cmd = [sys.executable, "-m", "wrt.cli", "render", str(animated), "--width", "32", "--height", "24"]
    out = tmp_path / "frames" / "{stem}_###.png"  # {stem} is the scene's name, as for still images
    done = subprocess.run(cmd + ["--frames", "1:8:3", "-o", str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    names = [f"{animated.stem}_{k:03d}.png" for k in (1, 4, 7)]
    assert sorted(p.name for p in out.parent.iterdir()) == names
    assert "1 build" in done.stderr
    (out.parent / names[1]).unlink()
    (out.parent / names[2]).write_bytes(b"")  # what a run killed while writing could leave
    again = subprocess.run(cmd + ["--frames", "1:8:3", "-o", str(out), "--resume"], capture_output=True, text=True,
                           timeout=300)
    assert again.returncode == 0, again.stderr
    assert "1 of 3 frames already on disk" in again.stderr and "rendered 2 frames" in again.stderr
    assert sorted(p.name for p in out.parent.iterdir()) == names  # no partial files left beside them
    assert (out.parent / names[2]).stat().st_size > 0
    bad = subprocess.run(cmd + ["--frames", "9:1"], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "empty" in bad.stderr
    mixed = subprocess.run(cmd + ["--frames", "1:2", "--time", "3"], capture_output=True, text=True, timeout=300)
    assert mixed.returncode == 2 and "--time cannot be combined with --frames" in mixed.stderr


@pytest.mark.parametrize(
    "output, devices, message",
    [
        ("f_#.jpg", "cpu", "f_1.jpg: supported image formats"),  # the path as given, named
        ("{scene}/f_#.png", "cpu", "is a file, not a directory"),
        ("f_#.png", ",", "argument --devices: names nothing, got ','"),
    ],
)
def test_cli_frames_bad_output_or_devices_fail_before_any_frame(animated, tmp_path, capsys, monkeypatch, output,
                                                                 devices, message):
    """An output that cannot be written failed only after frame 1 was loaded and rendered (a folder under a file
    said '[Errno 17] File exists'), and an empty --devices said 'max_workers must be greater than 0'."""
    from wrt.cli import main

    def no_render(*args, **kwargs):
        raise AssertionError("a frame was rendered before the output was checked")

    monkeypatch.setattr(FrameRenderer, "render", no_render)
    out = str(tmp_path / output.format(scene=animated))
    try:  # (argparse refuses a list of no device itself: it exits)
        status = main(["render", str(animated), "--frames", "1:2", "-o", out, "--devices", devices, "-q"])
    except SystemExit as stop:
        status = stop.code
    assert status == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(
    "asset_id", ["spinning_pyramids", "usdz_animated_cube", "usdz_interpolation_test", "teapot_scene_1000"]
)
def test_shared_animated_assets_render_as_frames(assets, asset_id):
    from pxr import Usd

    path = assets(asset_id)
    stage = Usd.Stage.Open(str(path))
    first, last = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    frames = [first, (first + last) / 2, last]
    renderer = FrameRenderer(path, **SIZE)
    for frame in frames:
        image = renderer.render(frame)
        fresh = wrt.render(wrt.load_usd(path, time=frame), **SIZE)
        np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
        np.testing.assert_array_equal(image.rgb, fresh.rgb)
    assert renderer.log[0]["change"] == "build"
    assert all(row["change"] != "build" for row in renderer.log[1:])


def test_frames_on_cuda(animated):
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    renderer = FrameRenderer(animated, device="cuda:0", **SIZE)
    cpu = FrameRenderer(animated, device="cpu", **SIZE)
    for frame in (1, 2, 3, 6, 7):
        g, c = renderer.render(frame), cpu.render(frame)
        assert np.mean(g.aovs["prim"] == c.aovs["prim"]) > 0.999
    assert [row["change"] for row in renderer.log] == ["build", "refit", "tlas", "tlas", "static"]



def die_once_on_frame_3(job):
    """A frame task whose worker process dies the first time it meets frame 3 (the marker file remembers)."""
    from wrt.animation import render_frame_task

    marker = Path(os.environ["WRT_TEST_MARKER"])
    if job["frame"] == 3 and not marker.exists():
        marker.write_text("killed")
        os._exit(1)
    return render_frame_task(job)


def test_dask_local_cluster_frames_match_serial_and_survive_a_killed_worker(animated, tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    from wrt.animation import render_frames_on_dask

    frames = parse_frames("1:8")
    serial = tmp_path / "serial" / "f_#.png"
    render_frames(animated, pending_frames(frames, serial, False), **SIZE)
    monkeypatch.setenv("WRT_TEST_MARKER", str(tmp_path / "killed"))  # the workers inherit it
    dask = tmp_path / "dask" / "f_#.png"
    rows = render_frames_on_dask(animated, pending_frames(frames, dask, False), n_workers=2, task=die_once_on_frame_3,
                                 **SIZE)
    assert (tmp_path / "killed").exists()  # a worker did die on frame 3, and its frame was rerun
    assert sorted(row["frame"] for row in rows) == frames
    for frame in range(1, 9):
        assert (dask.parent / f"f_{frame}.png").read_bytes() == (serial.parent / f"f_{frame}.png").read_bytes()


def big_static_and_small_scrambled_stage(path) -> None:
    """Two native instances: a static 20,000-triangle ball and a soup of 16 small triangles, sorted along x at time 1
    and dealt to each other's places at time 2 (the same shapes, other triangles where: a fresh tree is as good as
    the first, a refitted one's leaves span the soup)."""
    from pxr import Sdf, Usd, UsdGeom, Vt

    from wrt.procedural import displaced_sphere

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set((0, 0, 8))

    def mesh(prim_path, triangles):
        m = UsdGeom.Mesh.Define(stage, prim_path)
        m.CreateFaceVertexCountsAttr([3] * len(triangles))
        m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(triangles, np.int32).reshape(-1)))
        return m.CreatePointsAttr()

    points, indices = displaced_sphere(20000)
    mesh("/Protos/Big/M", indices).Set(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    rng = np.random.default_rng(1)
    centers = np.sort(rng.uniform(-1, 1, (16, 3)), axis=0)
    corners = rng.normal(0, 0.05, (16, 3, 3))
    soup = mesh("/Protos/Small/M", np.arange(48).reshape(-1, 3))
    for t, placed in ((1, centers), (2, centers[rng.permutation(16)])):
        soup.Set(Vt.Vec3fArray.FromNumpy((placed[:, None] + corners).reshape(-1, 3).astype(np.float32)), t)
    stage.GetPrimAtPath("/Protos").SetSpecifier(Sdf.SpecifierClass)
    for name, x in (("Big", -1.5), ("Small", 1.5)):
        instance = UsdGeom.Xform.Define(stage, f"/{name}")
        instance.GetPrim().GetReferences().AddInternalReference(f"/Protos/{name}")
        instance.GetPrim().SetInstanceable(True)
        instance.AddTranslateOp().Set((x, 0, 0))
    stage.Save()


def _traced_accelerator(renderer):
    """The binary-layout sah accelerator a FrameRenderer's scene holds: keyed by the device it rendered on, which a
    CUDA host's test plugin moves to cuda:0 (benchmarks/render_on_cuda.py)."""
    (accel,) = [a for key, a in renderer._scene._cache.items() if key[:3] == ("accel", "wrt", "sah") and len(key) == 4]
    return accel


def test_refit_or_rebuild_is_decided_per_tree(tmp_path):
    """The 20% rule summed the SAH costs of every BLAS: a small mesh whose refitted tree cost 3.4 times a fresh
    one's hid behind a large static mesh's cost, and was traced refitted for the rest of the shot; where
    the sum did pass the limit, the static tree was rebuilt with it. Each tree now is held to its own cost."""
    from wrt.animation import REFIT_SAH_LIMIT
    from wrt.bvh.stats import sah_cost

    path = tmp_path / "two_trees.usda"
    big_static_and_small_scrambled_stage(path)
    renderer = FrameRenderer(path, device="cpu", **SIZE)
    renderer.render(1)
    first_trees = list(_traced_accelerator(renderer).blas)
    image = renderer.render(2)
    fresh_scene = wrt.load_usd(path, time=2)
    fresh = wrt.render(fresh_scene, device="cpu", **SIZE)
    np.testing.assert_array_equal(image.aovs["prim"], fresh.aovs["prim"])
    np.testing.assert_array_equal(image.rgb, fresh.rgb)
    traced = _traced_accelerator(renderer).blas
    built = get_accelerator(fresh_scene, "wrt", "sah", "cpu").blas
    assert [b.num_prims for b in traced] == [b.num_prims for b in built] and traced[1].num_prims == 16
    for ours, fresh_tree in zip(traced, built):
        assert sah_cost(ours) <= REFIT_SAH_LIMIT * sah_cost(fresh_tree)
    assert traced[0] is first_trees[0]  # the static ball's tree is kept, not rebuilt with the soup's
    assert renderer.log[1]["change"] == "refit" and renderer.log[1]["rebuilt_trees"] == 1


def everything_sampled_stage(path) -> None:
    """Time samples on every kind of thing a frame reads, over [1, 3]: a mesh's points, an xform's translate and
    rotation, a visibility, PointInstancer positions, the camera's transform and focal length, a sphere light's
    intensity, colour and radius, and a value that is sampled on some prims and static (or a default beside samples)
    on others (sphere radii, displayColor)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, Vt

    stage = Usd.Stage.CreateNew(str(path))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    move = camera.AddTranslateOp()
    move.Set((0, 0, 7), 1), move.Set((0.5, 0.3, 6), 3)
    camera.CreateFocalLengthAttr().Set(35.0, 1), camera.GetFocalLengthAttr().Set(45.0, 3)
    points, quads = quad_grid(4)
    sheet = UsdGeom.Mesh.Define(stage, "/Sheet")
    sheet.CreateFaceVertexCountsAttr(Vt.IntArray([4] * len(quads)))
    sheet.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(quads.reshape(-1)))
    for t, bend in ((1, 0.0), (2, 0.6), (3, -0.4)):
        bent = points + np.float32([0, 0, 1]) * bend * points[:, :1] ** 2
        sheet.CreatePointsAttr().Set(Vt.Vec3fArray.FromNumpy(bent.astype(np.float32)), t)
    sheet.AddTranslateOp().Set((0, 0, -1))
    color = sheet.CreateDisplayColorPrimvar()
    color.Set([Gf.Vec3f(0.8, 0.8, 0.8)])  # a default beside samples: the samples win at every time
    color.Set([Gf.Vec3f(0.9, 0.2, 0.2)], 1), color.Set([Gf.Vec3f(0.2, 0.9, 0.2)], 3)
    spinner = UsdGeom.Xform.Define(stage, "/Spinner")
    slide, turn = spinner.AddTranslateOp(), spinner.AddRotateXYZOp()
    slide.Set((-1, 0, 0), 1), slide.Set((1, 0.5, 0), 3)
    turn.Set((0, 0, 0), 1), turn.Set((30, 60, 90), 3)
    UsdGeom.Cube.Define(stage, "/Spinner/Box").CreateSizeAttr(0.5)
    for name, x, radius in (("Sampled", -1.2, {1: 0.2, 3: 0.45}), ("Static", 1.2, 0.3)):
        ball = UsdGeom.Sphere.Define(stage, f"/{name}")
        ball.AddTranslateOp().Set((x, 1.0, 0.3))
        if isinstance(radius, dict):
            for t, r in radius.items():
                ball.CreateRadiusAttr().Set(r, t)
        else:
            ball.CreateRadiusAttr(radius)
        ball.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.2, 0.3, 0.9)])
    blinker = UsdGeom.Sphere.Define(stage, "/Blinker")
    blinker.AddTranslateOp().Set((0, -1.1, 0.3))
    blinker.CreateRadiusAttr(0.25)
    blinker.CreateVisibilityAttr().Set(UsdGeom.Tokens.inherited, 1)
    blinker.GetVisibilityAttr().Set(UsdGeom.Tokens.invisible, 2)  # tokens are held: hidden from 2 on
    blinker.GetVisibilityAttr().Set(UsdGeom.Tokens.inherited, 3)
    instancer = UsdGeom.PointInstancer.Define(stage, "/PI")
    UsdGeom.Sphere.Define(stage, "/PI/Ball").CreateRadiusAttr(0.12)
    instancer.CreatePrototypesRel().SetTargets([Sdf.Path("/PI/Ball")])
    instancer.CreateProtoIndicesAttr([0, 0, 0])
    instancer.CreatePositionsAttr().Set([(-1.5, -1.5, 0), (0, -1.5, 0), (1.5, -1.5, 0)], 1)
    instancer.GetPositionsAttr().Set([(-1.5, -0.5, 0.5), (0, -1.8, 0), (1.5, 1.5, 0.2)], 3)
    light = UsdLux.SphereLight.Define(stage, "/Bulb")
    light.AddTranslateOp().Set((0, 2, 3))
    light.CreateIntensityAttr().Set(20.0, 1), light.GetIntensityAttr().Set(60.0, 3)
    light.CreateColorAttr().Set((1, 1, 1), 1), light.GetColorAttr().Set((1, 0.5, 0.2), 3)
    light.CreateRadiusAttr().Set(0.1, 1), light.GetRadiusAttr().Set(0.6, 3)
    UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(1.5)  # static beside the animated light
    stage.Save()


def test_frames_of_a_stage_sampled_everywhere_equal_fresh_loads(tmp_path):
    """Frames that follow the last one (refit, TLAS update) against fresh loads: colour and every AOV of
    each frame equal a render of a fresh load_usd at its time, between samples, before and past the authored range
    and going back, and the frames do differ."""
    path = tmp_path / "sampled.usda"
    everything_sampled_stage(path)
    renderer = FrameRenderer(path, integrator="whitted", **SIZE)
    pictures = set()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wrt.errors.TimeRangeWarning)
        for frame in (1, 1.5, 2, 2.75, 3, 4, 0, 2):
            image = renderer.render(frame)
            fresh = wrt.render(wrt.load_usd(path, time=frame), integrator="whitted", **SIZE)
            pictures.add(fresh.rgb.tobytes())
            np.testing.assert_array_equal(image.rgb, fresh.rgb, err_msg=f"frame {frame}")
            for name in set(fresh.aovs) - {"cost"}:
                np.testing.assert_array_equal(image.aovs[name], fresh.aovs[name], err_msg=f"frame {frame}: {name}")
    assert len(pictures) >= 5
    assert {row["change"] for row in renderer.log[1:]} <= {"refit", "tlas", "static", "build"}


def test_a_frame_renderer_sees_the_file_edited_between_its_frames(tmp_path):
    """A Dask worker keeps its FrameRenderer from one run to the next, so a file saved in between by someone else
    (here a referenced layer) must be read again, as a fresh load reads it (a guard for any caching of stages)."""
    import os

    ball = tmp_path / "ball.usda"
    shot = tmp_path / "shot.usda"

    def write_ball(radius):
        ball.write_text(f'#usda 1.0\n(\n    defaultPrim = "Ball"\n)\n'
                        f'def Sphere "Ball"\n{{\n    double radius = {radius}\n}}\n')

    write_ball(0.5)
    shot.write_text('#usda 1.0\ndef Camera "Cam"\n{\n    double3 xformOp:translate = (0, 0, 5)\n'
                    '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
                    'def "Ball" (\n    references = @./ball.usda@\n)\n{\n}\n')
    renderer = FrameRenderer(shot, **SIZE)
    before = renderer.render(1)
    write_ball(1.2)
    stamp = ball.stat().st_mtime_ns + 2_000_000_000  # a later time stamp, however coarse the file system's clock
    os.utime(ball, ns=(stamp, stamp))
    after = renderer.render(1)
    fresh = wrt.render(wrt.load_usd(shot, time=1), **SIZE)
    np.testing.assert_array_equal(after.rgb, fresh.rgb)
    assert (after.aovs["prim"] >= 0).sum() > (before.aovs["prim"] >= 0).sum()


@pytest.mark.parametrize(
    "metadata",
    ["startFrame = 1\n    endFrame = 3",  # the deprecated keys USD still reads
     "startTimeCode = 2\n    startFrame = 7\n    endTimeCode = 3",
     "startTimeCode = 1\n    endFrame = 3",  # mixed: USD says no authored range
     "startTimeCode = 1\n    endTimeCode = 3"],
)
def test_frames_outside_the_range_are_those_usd_puts_outside(tmp_path, metadata):
    """The --frames warning read startTimeCode and endTimeCode from the root layer alone: a stage authoring its range
    as startFrame and endFrame (USD reads them when the time codes are missing) got no warning for frames past it,
    where load_usd(time=...) did warn, asking the stage."""
    from pxr import Usd

    from wrt.animation import warn_frames_outside_range

    path = tmp_path / "range.usda"
    path.write_text(f"#usda 1.0\n(\n    {metadata}\n)\ndef Sphere \"Ball\"\n{{\n}}\n")
    stage = Usd.Stage.Open(str(path))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_frames_outside_range(path, [0.0, 2.0, 9.0])
    messages = [str(w.message) for w in caught]
    if stage.HasAuthoredTimeCodeRange():
        start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
        assert messages == [f"range.usda: frames 0 and 9 (2 of 3) are outside the stage's time range [{start:g}, "
                            f"{end:g}]; USD holds the values of the nearest time samples"]
    else:
        assert messages == []


def test_frames_of_a_reversed_time_range_are_each_named_once_as_outside_it(tmp_path):
    """A stage whose startTimeCode is after its endTimeCode ([8, 1]) holds no time, and the --frames warning counted
    each frame on both sides of it: 'frames 0 to 6 and 3 to 9 (6 of 4)'. Each frame is named once, and the words say
    the range is reversed (not that USD holds the nearest samples, which it does not between two samples)."""
    from pxr import Usd

    from wrt.animation import warn_frames_outside_range

    path = tmp_path / "reversed.usda"
    path.write_text('#usda 1.0\n(\n    startTimeCode = 8\n    endTimeCode = 1\n)\ndef Sphere "Ball"\n{\n}\n')
    stage = Usd.Stage.Open(str(path))
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    frames = [0.0, 3.0, 6.0, 9.0]
    outside = [f for f in frames if not start <= f <= end]  # USD's range holds none of them
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_frames_outside_range(path, frames)
        wrt.load_usd(path, time=5.0)
    messages = [str(w.message) for w in caught if "time range" in str(w.message)]
    assert len(messages) == 2, messages
    assert messages[0].startswith(f"reversed.usda: frames 0 to 9 ({len(outside)} of {len(frames)}) are outside the "
                                  f"stage's time range [{start:g}, {end:g}], which is reversed")
    assert messages[1].startswith(f"reversed.usda: time 5 is outside the stage's time range [{start:g}, {end:g}], "
                                  "which is reversed")
    assert not any("nearest time samples" in m for m in messages)


def far_camera_stage(tmp_path) -> str:
    """A unit sphere seen by ``/Far``, which flies from 1e8 to 3e8 from it (frames 1 to 3) through a lens whose view
    is 0.2 units wide at 1e8: far enough for both far-view warnings (the scene too far for float32 depths, the shape
    for its hit points) at every frame, each naming the camera's distance of that frame."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "far.usda"))
    UsdGeom.Sphere.Define(stage, "/Ball")
    camera = UsdGeom.Camera.Define(stage, "/Far")
    camera.CreateFocalLengthAttr(1e10)
    camera.CreateHorizontalApertureAttr(20.0)
    camera.CreateVerticalApertureAttr(15.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(1.0, 1e9))
    move = camera.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
    for frame in (1, 2, 3):
        move.Set(Gf.Vec3d(0.0, 0.0, 1e8 * frame), frame)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    stage.GetRootLayer().Save()
    return str(tmp_path / "far.usda")


def test_a_far_camera_flying_through_the_frames_of_a_run_is_warned_of_once(tmp_path):
    """render_frames gives each warning once per run (a new Renderer each frame); the far-view warnings name the
    camera's distance, which changes every frame, so both were said again at every frame. The oracle: one Renderer
    following the same camera by set_cameras says each once (test_extreme_scales)."""
    path = far_camera_stage(tmp_path)
    jobs = pending_frames(parse_frames("1:3"), tmp_path / "out" / "f_#.npy", resume=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = render_frames(path, jobs, devices=["cpu"], camera="/Far", width=4, height=3, integrator="normals")
    assert all("error" not in row for row in rows), rows
    said = [str(w.message) for w in caught if "/Far" in str(w.message) and "float32" in str(w.message)]
    assert sum("is so far from the scene" in m for m in said) == 1, said
    assert sum("sees analytic shapes from so far" in m for m in said) == 1, said


def test_cli_frames_of_mixed_sizes_from_a_time_sampled_aperture_warn_once_naming_the_camera(tmp_path, capsys):
    """--width alone takes the height from the camera's aperture aspect at each frame (each frame is the image a fresh
    render of its time gives); an aperture that is time-sampled gave frames of different sizes in one sequence
    without a word. One warning names the camera and each size; the sizes are checked against USD's apertures."""
    from pxr import Usd, UsdGeom

    from wrt.cli import main

    path = tmp_path / "zoom.usda"
    stage = Usd.Stage.CreateNew(str(path))
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(8)
    UsdGeom.Sphere.Define(stage, "/Ball")
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    UsdGeom.XformCommonAPI(camera).SetTranslate((0, 0, 10))
    camera.CreateVerticalApertureAttr(15.0)
    aperture = camera.CreateHorizontalApertureAttr()
    aperture.Set(20.0, 1)
    aperture.Set(40.0, 8)
    stage.Save()
    width = 40
    heights = [round(width * camera.GetVerticalApertureAttr().Get(t) / aperture.Get(t)) for t in (1, 8)]
    assert heights[0] != heights[1]
    argv = ["render", str(path), "--frames", "1:8:7", "-o", str(tmp_path / "f_#.npy"), "-q", "--width", str(width)]
    assert main(argv + ["--device", "cpu", "--spp", "1"]) == 0
    assert [np.load(tmp_path / f"f_{t}.npy").shape[:2] for t in (1, 8)] == [(h, width) for h in heights]
    err = capsys.readouterr().err
    said = [line for line in err.splitlines() if "image sizes" in line]
    assert len(said) == 1, err
    assert "zoom.usda" in said[0] and "camera /Cam" in said[0], said
    assert f"{width}x{heights[0]} from frame 1" in said[0] and f"{width}x{heights[1]} from frame 8" in said[0], said


@pytest.mark.parametrize(
    "output, names",
    [
        ("{stem}.png", ["shot#1_0001.png", "shot#1_0002.png"]),  # no # of its own: _#### before the suffix
        ("{stem}_##.png", ["shot#1_01.png", "shot#1_02.png"]),
        ("f_##/{stem}.png", ["f_01/shot#1.png", "f_02/shot#1.png"]),  # the pattern's last run of #, in a folder
        ("out/", ["out/shot#1_0001.png", "out/shot#1_0002.png"]),  # a folder: {stem}_####.png in it
    ],
)
def test_cli_frames_number_only_the_patterns_own_hashes(animated, tmp_path, monkeypatch, output, names):
    """A scene named shot#1.usda with -o {stem}.png wrote shot11.png, shot12.png: {stem} was put in before the
    frames were numbered, so the scene name's # became the frame number. The README: -o's last run of # is the
    frame number, {stem} the scene file name without extension, as it is."""
    import shutil

    import wrt.animation
    from wrt.cli import main

    scene = tmp_path / "shot#1.usda"
    shutil.copy(animated, scene)
    given = []

    def record_jobs(path, jobs, **kwargs):
        given.extend(file for _, file in jobs)
        return []

    monkeypatch.setattr(wrt.animation, "render_frames", record_jobs)
    monkeypatch.chdir(tmp_path)
    assert main(["render", str(scene), "--frames", "1:2", "-o", output, "-q"]) == 0
    assert [str(file) for file in given] == [str(Path(name)) for name in names]


CAMERA_BAD_AT_2 = """#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 3
    upAxis = "Y"
)
def Cube "Box"
{
}
def Camera "Cam"
{
    float focalLength.timeSamples = { 1: 50, 2: FOCAL, 3: 50 }
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Other"
{
    double3 xformOp:translate = (5, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


@pytest.mark.parametrize("bad, why", [
    ({"FOCAL": "0"}, "camera needs finite positive focalLength"),
    ({"FOCAL": "nan"}, "camera needs finite positive focalLength"),
    ({"float focalLength.timeSamples = { 1: 50, 2: FOCAL, 3: 50 }":
      "float focalLength.spline = {\n        1: 50,\n        2: 0,\n        3: 50,\n    }"},
     "camera needs finite positive focalLength"),
    ({"FOCAL": "50", "double3 xformOp:translate = (0, 0, 10)":
      "double3 xformOp:translate.timeSamples = { 1: (0, 0, 10), 2: (nan, 0, 10), 3: (0, 0, 10) }"}, "not finite"),
])
def test_a_first_camera_bad_at_one_frame_refuses_that_frame_naming_the_camera_and_the_frame(tmp_path, bad, why):
    """The stage's first camera, whose focal length USD's own GetCamera reads as 0 or NaN (or whose transform
    XformCache gives as not finite) at frame 2 alone: frame 2 was drawn from /Other under a warning that only said
    /Cam was skipped, one view unlike the rest of the animation. It is refused with an error naming the camera, the
    frame and why; frames 1 and 3 are drawn from /Cam."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "cam.usda"
    text = CAMERA_BAD_AT_2
    for old, new in bad.items():
        assert old in text
        text = text.replace(old, new)
    path.write_text(text)
    stage = Usd.Stage.Open(str(path))
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/Cam"))
    assert [np.isfinite(np.array(camera.GetCamera(t).transform)).all() and camera.GetCamera(t).focalLength > 0
            for t in (1.0, 2.0, 3.0)] == [True, False, True]
    renderer = FrameRenderer(path, width=8, height=6, device="cpu")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the load's word that the camera was skipped
        renderer.render(1.0)
        with pytest.raises(wrt.SceneError, match=r"/Cam: the stage's first camera, which draws the frames, cannot be "
                                                 rf"used at frame 2: .*{why}.*; the frame is not drawn from another"):
            renderer.render(2.0)
        renderer.render(3.0)
    assert [row["drawn_camera"] for row in renderer.log] == ["camera /Cam", "camera /Cam"]
    # Given by path, the other camera draws every frame, frame 2 too.
    other = FrameRenderer(path, camera="/Other", width=8, height=6, device="cpu")
    with pytest.warns(UserWarning, match="cameras wrt cannot use were skipped"):
        other.render(2.0)
    assert other.log[-1]["drawn_camera"] == "camera /Other"


MOVING = "double3 xformOp:translate.timeSamples = { 1: (0, 0, 10), 3: (1, 0, 10) }"


@pytest.mark.parametrize("moved", [
    {},
    {"double3 xformOp:translate = (0, 0, 10)": MOVING},
    {'def Camera "Cam"\n{': f'def Xform "Rig"\n{{\n{MOVING}\nuniform token[] xformOpOrder = ["xformOp:translate"]\n'
                            'def Camera "Cam"\n{', '}\ndef Camera "Other"': '}\n}\ndef Camera "Other"'},
    {"float focalLength = 0": "float focalLength = 0\n    float focusDistance.timeSamples = { 1: 5, 3: 8 }"},
    {"float focalLength = 0": "float focalLength.timeSamples = { 1: 0, 3: 0 }"},
    {'def Camera "Cam"\n{': 'def Xform "Rig"\n{\ndouble xformOp:rotateY.spline = {\n1: 0,\n3: 30,\n}\n'
                            'uniform token[] xformOpOrder = ["xformOp:rotateY"]\ndef Camera "Cam"\n{',
     '}\ndef Camera "Other"': '}\n}\ndef Camera "Other"',
     "float focalLength = 0": "float focalLength = 0\n    float focusDistance.timeSamples = { 1: 5, 3: 8 }"},
], ids=["still", "moving", "moving-parent", "rack-focus", "zero-samples", "rack-focus-spline-rig"])
def test_a_first_camera_bad_at_every_time_leaves_the_frames_to_the_next_camera(tmp_path, moved):
    """A first camera that is bad whatever the time (an unanimated zero focal length) is skipped for every frame
    alike, as for a still render: the frames are drawn from the next camera, with the load's warning. So is one
    whose transform or parent's moves (USD's GetCamera reads its focal length 0 at every frame): it was taken for a
    camera animated into its zero focal length, and every frame was refused. So is one whose focusDistance is
    animated beside it (a rack focus), or whose focal length is 0 at every sample: every frame was refused too; so
    was a rack focus under a rig animated by a spline (which has no samples to read the camera again at, and
    cannot make a focal length 0)."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "cam.usda"
    text = CAMERA_BAD_AT_2.replace("float focalLength.timeSamples = { 1: 50, 2: FOCAL, 3: 50 }",
                                   "float focalLength = 0")
    for old, new in moved.items():
        assert old in text
        text = text.replace(old, new)
    path.write_text(text)
    stage = Usd.Stage.Open(str(path))
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/Rig/Cam" if "Rig" in text else "/Cam"))
    assert [camera.GetCamera(t).focalLength for t in (1.0, 2.0, 3.0)] == [0.0, 0.0, 0.0]
    renderer = FrameRenderer(path, width=8, height=6, device="cpu")
    with pytest.warns(UserWarning, match="cameras wrt cannot use were skipped"):
        renderer.render(2.0)
    assert renderer.log[-1]["drawn_camera"] == "camera /Other"


@pytest.mark.parametrize("bad", ["focal", "transform"])
def test_a_first_camera_bad_at_one_frame_under_an_op_of_no_known_type_refuses_that_frame_alone(tmp_path, bad):
    """A rig whose xformOpOrder names an op of no known type (``xformOp:foo``, read as the identity with a warning)
    above the stage's first camera, unusable at frame 2 (a focal length 0, or the rig's translate NaN): asking
    whether the camera varies went through ``UsdGeom.Xformable``, which raises for that op, and the frame's load
    failed as "cannot read this prim" instead of naming the camera and why; a still render of such a camera bad at
    every time failed likewise. Oracle: USD's attribute values (GetCamera itself raises for the op)."""
    from pxr import Tf, Usd, UsdGeom

    focal = "float focalLength.timeSamples = { 1: 50, 2: 0, 3: 50 }" if bad == "focal" else "float focalLength = 50"
    nan = "2: (0, 0, 10), " if bad == "focal" else "2: (nan, 0, 10), "
    path = tmp_path / "cam.usda"
    path.write_text(f"""#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 3
)
def Cube "Box"
{{
}}
def Xform "Rig"
{{
    double3 xformOp:translate.timeSamples = {{ 1: (0, 0, 10), {nan}3: (0, 0, 10) }}
    double3 xformOp:foo = (0, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:foo"]
    def Camera "Cam"
    {{
        {focal}
    }}
}}
def Camera "Other"
{{
    double3 xformOp:translate = (5, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
""")
    stage = Usd.Stage.Open(str(path))
    with pytest.raises(Tf.ErrorException, match="Invalid xform opType token 'foo'"):
        UsdGeom.Xformable(stage.GetPrimAtPath("/Rig")).TransformMightBeTimeVarying()
    focals = [stage.GetPrimAtPath("/Rig/Cam").GetAttribute("focalLength").Get(t) for t in (1.0, 2.0, 3.0)]
    moves = [np.isfinite(stage.GetPrimAtPath("/Rig").GetAttribute("xformOp:translate").Get(t)).all()
             for t in (1.0, 2.0, 3.0)]
    assert [f > 0 and m for f, m in zip(focals, moves)] == [True, False, True]
    renderer = FrameRenderer(path, width=8, height=6, device="cpu")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the load's words on xformOp:foo and the skipped camera
        renderer.render(1.0)
        with pytest.raises(wrt.SceneError, match=r"/Rig/Cam: the stage's first camera, which draws the frames, "
                                                 r"cannot be used at frame 2"):
            renderer.render(2.0)
        renderer.render(3.0)
    assert [row["drawn_camera"] for row in renderer.log] == ["camera /Rig/Cam", "camera /Rig/Cam"]
    if bad == "focal":  # bad at every time beside an animated focusDistance: a still render draws the next camera
        still = tmp_path / "still.usda"  # (another file: the stage above keeps this one's layer open)
        still.write_text(path.read_text().replace(focal, "float focalLength = 0\n        "
                                                  "float focusDistance.timeSamples = { 1: 5, 3: 8 }"))
        with pytest.warns(UserWarning, match="cameras wrt cannot use were skipped"):
            scene = wrt.load_usd(still)
        assert list(scene.cameras) == ["/Other"]


def test_an_exr_frame_whose_pixel_aspect_its_header_cannot_state_is_refused_before_the_render(tmp_path, monkeypatch):
    """A stage whose pixelAspectRatio is 1e7 (past the [1e-6, 1e6] an OpenEXR header takes; the oracle: OpenEXR
    refusing a header stating it): render_frames to .exr rendered frame 1, then failed at its save; a worker's task
    named its temporary file. Now each refuses before any render, naming the file asked for."""
    import OpenEXR

    from wrt.animation import _task, render_frame_task

    with pytest.raises(Exception):
        with OpenEXR.File({"type": OpenEXR.scanlineimage, "pixelAspectRatio": 1e7},
                          {"R": np.zeros((2, 2), np.float32)}) as f:
            f.write(str(tmp_path / "oracle.exr"))
    path = tmp_path / "wide_pixels.usda"
    path.write_text("""#usda 1.0
(
    renderSettingsPrimPath = "/Render/S"
    startTimeCode = 1
    endTimeCode = 2
)
def Sphere "Ball" {}
def Camera "Cam" {
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Scope "Render" {
    def RenderSettings "S" {
        rel camera = </Cam>
        uniform int2 resolution = (8, 8)
        uniform float pixelAspectRatio = 1e7
    }
}
""")
    renders = []
    monkeypatch.setattr(wrt.Renderer, "render", lambda self, **kwargs: renders.append(kwargs))
    file = tmp_path / "f_1.exr"
    with pytest.raises(ValueError, match=rf"cannot write {re.escape(str(file))}: pixels 1e\+07 times as wide"):
        render_frames(path, [(1.0, file), (2.0, tmp_path / "f_2.exr")], devices=["cpu"])
    with pytest.raises(ValueError, match=rf"cannot write {re.escape(str(file))}: pixels 1e\+07 times as wide"):
        render_frame_task(_task(str(path), 1.0, file, 1, 0, 0.0, {}))
    assert renders == [] and not list(tmp_path.glob("f_*"))


def test_a_log_that_is_a_folder_or_no_log_is_refused_before_the_first_frame(tmp_path, monkeypatch):
    """render_frames(log=FOLDER) rendered and wrote frame 1, then stopped in Python's words ('[Errno 21] Is a
    directory'); a file of notes got rows appended. Both are refused before any render, naming the log."""
    path = tmp_path / "tri.usda"
    path.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
                    '[0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    renders = []
    monkeypatch.setattr(wrt.Renderer, "render", lambda self, **kwargs: renders.append(kwargs))
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    (tmp_path / "logs").mkdir()
    jobs = [(1.0, tmp_path / "f_1.png")]
    with pytest.raises(IsADirectoryError, match=rf"log {re.escape(str(tmp_path / 'logs'))}: a directory"):
        render_frames(path, jobs, log=tmp_path / "logs", width=4, height=3)
    with pytest.raises(ValueError, match=rf"log {re.escape(str(notes))}: line 1 is not a JSON row"):
        render_frames(path, jobs, log=notes, width=4, height=3)
    assert renders == [] and not (tmp_path / "f_1.png").exists() and notes.read_text() == "my notes\n"
    # A log whose folder is a file: refused in Python's words alone ('[Errno 17] File exists: ...notes.txt'), which
    # named neither the log nor what was wrong with it.
    for log in (notes / "frames.jsonl", notes / "sub" / "frames.jsonl"):
        with pytest.raises(NotADirectoryError, match=rf"log {re.escape(str(log))}: .*{re.escape(str(notes))} is a "
                                                      "file, not a directory"):
            render_frames(path, jobs, log=log, width=4, height=3)
    assert renders == [] and notes.read_text() == "my notes\n"
