"""The benchmark harness: rows, ratios, error rows, resume, flushing, plots, the CLI."""

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

import wrt
import wrt.bench as bench_module
from wrt.bench import Grid, fit_slope, markdown_table, run_grid
from wrt.cli import main
from wrt.procedural import displaced_sphere
from wrt.rays import RAY_KINDS, ray_set


def tiny_grid(**kwargs):
    options = dict(
        scenes=["sphere:2000"], accels=["warp:sah", "wrt:sah"], rays=["primary", "shadow"], n_rays=3000, repeats=3
    )
    options.update(kwargs)
    return Grid(**options)


TRIANGLES_USDA = ('#usda 1.0\ndef Mesh "M"\n{{\n    int[] faceVertexCounts = {counts}\n'
                  '    int[] faceVertexIndices = {indices}\n'
                  '    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]\n}}\n')


def read_rows(out):
    return [json.loads(line) for line in (out / "rows.jsonl").read_text().splitlines()]


def test_rows_ratios_and_agreement(tmp_path):
    rows = run_grid(tiny_grid(), tmp_path, progress=False)
    assert len(rows) == 4 and not any("error" in r for r in rows)
    assert read_rows(tmp_path) == rows  # every row is on disk
    for r in rows:
        assert r["mrays"] > 0 and r["mrays_min"] <= r["mrays"] <= r["mrays_max"]
        assert r["agreement"] == 1.0  # same rays, same answers as wp.Mesh
        assert r["n_rays"] > 0 and 0.0 <= r["hit_fraction"] <= 1.0
        assert r["cpu"] and r["warp"] == "1.19.0"
    table = (tmp_path / "table.md").read_text()
    assert "x warp:sah" in table and "CPU" in table
    assert (tmp_path / "mrays.png").stat().st_size > 1000


def test_failing_scene_and_accel_become_error_rows_and_the_run_goes_on(tmp_path, monkeypatch):
    built = bench_module.WarpMeshAccelerator

    def failing_median(scene, builder, device):  # a well-formed accelerator that fails only when built
        if builder == "median" and len(scene.triangles()[1]) > 3:  # past the 3-triangle build that compiles kernels
            raise RuntimeError("median build failed")
        return built(scene, builder, device)

    monkeypatch.setattr(bench_module, "WarpMeshAccelerator", failing_median)
    grid = tiny_grid(scenes=["no/such/scene.usda", "sphere:2000"], accels=["warp:sah", "warp:median"], rays=["primary"])
    rows = run_grid(grid, tmp_path, progress=False)
    errors = [r for r in rows if "error" in r]
    assert any("scene.usda" in r["error"] for r in errors)
    assert any(r["accel"] == "warp:median" and "median build failed" in r["error"] for r in errors)
    assert any(r["scene"] == "sphere:2000" and r["accel"] == "warp:sah" and "mrays" in r for r in rows)
    assert "error" in (tmp_path / "table.md").read_text()


def test_a_scene_that_fails_to_load_is_loaded_once(tmp_path, monkeypatch):
    """A scene that failed to load (out of memory, after minutes) was loaded again for every ray kind and device."""
    calls = []

    def out_of_memory(name):
        calls.append(name)
        raise MemoryError(f"{name}: out of host memory")

    monkeypatch.setattr(bench_module, "resolve_scene", out_of_memory)
    rows = run_grid(tiny_grid(scenes=["huge.usda"], rays=["primary", "shadow", "incoherent"]), tmp_path,
                    progress=False)
    assert calls == ["huge.usda"]
    assert [r["error"] for r in rows] == ["MemoryError: huge.usda: out of host memory"] * 3


def test_bad_and_oversized_sphere_sizes_are_refused_or_error_rows_that_name_them(tmp_path, monkeypatch):
    """sphere:N was read with float(): 'abc' failed as "could not convert string to float", 'inf' with an
    OverflowError, and a size beyond the host's memory was generated until the system killed the process. A size
    that is no size is refused before the run; one beyond the memory is an error row (the memory is the loader's)."""
    for name in ("sphere:abc", "sphere:inf", "sphere:4", "sphere:1.00000000000000001e3"):  # (not 1000: a fraction)
        with pytest.raises(ValueError, match=f"{name}: N must be a whole number of triangles"):
            tiny_grid(scenes=["sphere:2000", name]).validated()
    monkeypatch.setattr("wrt.resources.available_host_bytes", lambda: 1 << 30)  # 1 GiB: room for the small sphere
    rows = run_grid(tiny_grid(scenes=["sphere:1e8", "sphere:2000"], accels=["wrt:sah"], rays=["primary"]), tmp_path,
                    progress=False)
    errors = {r["scene"]: r["error"] for r in rows if "error" in r}
    assert "sphere:1e8 needs about" in errors["sphere:1e8"] and "1.0 GiB is available" in errors["sphere:1e8"]
    assert [r["scene"] for r in rows if "mrays" in r] == ["sphere:2000"]  # the run went on to the good scene


def test_ray_counts_beyond_the_host_memory_are_refused_before_the_run(monkeypatch):
    monkeypatch.setattr("wrt.resources.available_host_bytes", lambda: 1 << 30)
    with pytest.raises(MemoryError, match="n_rays 100000000 needs about"):
        tiny_grid(n_rays=100_000_000).validated()
    with pytest.raises(MemoryError, match="scaling n_rays 100000000 needs about"):
        tiny_grid(scaling={"sizes": [1000], "n_rays": 100_000_000}).validated()
    assert tiny_grid(n_rays=100_000).validated().n_rays == 100_000


def test_gprims_are_measured_as_triangles_by_every_accelerator(tmp_path):
    """A UsdGeom.Sphere: wp.Mesh and wrt's BVH refused the analytic shape (error rows), Embree timed an empty scene
    (hit 0 %) and shadow rays failed on an IndexError; now all trace the same tessellated sphere."""
    scene = tmp_path / "ball.usda"
    scene.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 2\n}\n')
    accels = ["warp:sah", "wrt:sah"] + (["embree"] if bench_module._has_embree() else [])
    rows = run_grid(tiny_grid(scenes=[str(scene)], accels=accels, n_rays=2000), tmp_path, progress=False)
    assert len(rows) == 2 * len(accels) and not any("error" in r for r in rows), rows
    for kind in ("primary", "shadow"):
        group = [r for r in rows if r["rays"] == kind]
        assert group[0]["triangles"] > 100 and len({r["triangles"] for r in group}) == 1
        fractions = [r["hit_fraction"] for r in group]
        assert max(fractions) - min(fractions) < 0.01 and all(r["agreement"] > 0.99 for r in group)
    assert [r for r in rows if r["rays"] == "primary"][0]["hit_fraction"] > 0.1  # the framing camera sees the ball


def test_secondary_rays_of_a_scene_the_camera_misses_are_one_clear_error_row(tmp_path):
    """No primary ray hits a triangle behind the camera, so there are no shadow rays: wp.Mesh and wrt rows failed
    with Warp's 'Invalid indexing in slice: 0:0:1' and Embree's row reported 0 Mrays/s as a measurement."""
    scene = tmp_path / "behind.usda"  # the camera looks down -Z from the origin; the triangle is at z = 5
    scene.write_text('#usda 1.0\ndef Camera "Cam"\n{\n}\ndef Mesh "Tri"\n{\n    int[] faceVertexCounts = [3]\n'
                     '    int[] faceVertexIndices = [0, 1, 2]\n'
                     '    point3f[] points = [(0, 0, 5), (1, 0, 5), (0, 1, 5)]\n}\n')
    accels = ["warp:sah", "wrt:sah"] + (["embree"] if bench_module._has_embree() else [])
    rows = run_grid(tiny_grid(scenes=[str(scene)], accels=accels), tmp_path, progress=False)
    primary = [r for r in rows if r["rays"] == "primary"]
    assert len(primary) == len(accels) and all(r["hit_fraction"] == 0.0 and "error" not in r for r in primary)
    shadow = [r for r in rows if r["rays"] == "shadow"]
    assert len(shadow) == 1 and shadow[0]["accel"] == "*", shadow
    assert "no shadow rays" in shadow[0]["error"] and "none of them hit" in shadow[0]["error"]


def test_incoherent_rays_of_a_flat_scene_leave_its_plane(tmp_path):
    """In a flat scene's box every incoherent ray started on the surface, where a hit at t = 0 or a miss is rounding:
    wrt:sah agreed with warp:sah on 88.4 % of the rays of a quad."""
    scene = tmp_path / "quad.usda"
    scene.write_text(TRIANGLES_USDA.format(counts="[3, 3]", indices="[0, 1, 2, 0, 2, 3]"))
    origins, _ = ray_set(bench_module.resolve_scene(str(scene)), "incoherent", 500, seed=1)
    assert (origins[:, 2] != 0).all() and origins[:, 2].min() < 0 < origins[:, 2].max()
    rows = run_grid(tiny_grid(scenes=[str(scene)], rays=["incoherent"], n_rays=500, repeats=1), tmp_path,
                    progress=False)
    assert [r["agreement"] for r in rows] == [1.0, 1.0] and 0 < rows[0]["hit_fraction"] < 1


def test_resume_skips_measured_rows(tmp_path):
    run_grid(tiny_grid(rays=["primary"]), tmp_path, progress=False)
    before = read_rows(tmp_path)
    rows = run_grid(tiny_grid(rays=["primary", "shadow"]), tmp_path, resume=True, progress=False)
    after = read_rows(tmp_path)
    assert after[: len(before)] == before  # kept, not re-measured
    assert len(after) == len(before) + 2 and len(rows) == len(after)


def test_resume_without_rows_to_resume_says_so_naming_the_file(tmp_path, capsys):
    """--resume into a folder without rows.jsonl (a misspelt -o) measured every row again without a word, where
    wrt render --resume names the log it did not find."""
    out = tmp_path / "bench-ouy"
    args = ["bench", "--scenes", "sphere:100", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
            "--n-rays", "100", "--repeats", "1", "-q", "-o", str(out), "--resume"]
    assert main(args) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "nothing to resume" in line]
    assert len(warned) == 1 and warned[0].startswith("wrt: warning:") and str(out / "rows.jsonl") in warned[0], warned
    assert main(args) == 0  # now there are rows: resumed without a warning
    assert not [line for line in capsys.readouterr().err.splitlines() if "nothing to resume" in line]


def test_the_summary_names_an_output_folder_given_with_a_slash_once(tmp_path, capsys):
    """'-o out/' was summed up as 'results in out//'."""
    out = f"{tmp_path}/out/"
    assert main(["bench", "--scenes", "sphere:100", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
                 "--n-rays", "100", "--repeats", "1", "-q", "-o", out]) == 0
    summary = [line for line in capsys.readouterr().err.splitlines() if "results in" in line]
    assert summary == [f"wrt: 1 row measured, 0 resumed, 0 failed; results in {tmp_path}/out/"], summary


def test_an_error_row_printed_as_it_comes_names_its_device(tmp_path, capsys):
    """The line printed as an error row came said 'scene / accel / rays' only: with several devices it did not say
    which one failed, where the summary's line names it ('scene / accel / device / rays'); and it went to stdout,
    away from the run's other messages on stderr."""
    assert main(["bench", "--scenes", "no/such.usda", "--accels", "wrt:sah", "--devices", "cpu", "--rays", "primary",
                 "--n-rays", "100", "--repeats", "1", "-o", str(tmp_path)]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines()
             if "no/such.usda" in line and not line.startswith("wrt: warning:")]  # named at the start too
    assert len(lines) == 2, lines  # as the row came (on stdout, it was), and in the summary
    assert all("no/such.usda / * / cpu / primary: " in line for line in lines), lines


def test_resume_refuses_rows_measured_with_other_ray_counts(tmp_path):
    """Resuming with another n_rays kept the old rows beside new ones over other rays, and the table compared them."""
    run_grid(tiny_grid(accels=["warp:sah"], rays=["primary"]), tmp_path, progress=False)
    before = read_rows(tmp_path)
    # Named as the user set it, once: not also as 'scaling_n_rays', the sweep's count that follows --n-rays.
    with pytest.raises(ValueError, match="other settings \\(--n-rays 3000 -> 6000\\); resume with"):
        run_grid(tiny_grid(rays=["primary"], n_rays=6000), tmp_path, resume=True, progress=False)
    assert read_rows(tmp_path) == before  # nothing measured, nothing lost
    rows = run_grid(tiny_grid(rays=["primary"]), tmp_path, resume=True, progress=False)  # the same settings resume
    assert rows[0] == before[0] and len(rows) == 2


def test_resume_refuses_rows_measured_with_other_repeats(tmp_path):
    """--repeats was no part of what resume compared: rows timed over 3 launches were kept silently beside rows
    timed over 1, and the table put their medians side by side."""
    run_grid(tiny_grid(accels=["warp:sah"], rays=["primary"]), tmp_path, progress=False)  # repeats=3
    before = read_rows(tmp_path)
    with pytest.raises(ValueError, match="other settings \\(--repeats 3 -> 1\\)"):
        run_grid(tiny_grid(rays=["primary"], repeats=1), tmp_path, resume=True, progress=False)
    assert read_rows(tmp_path) == before  # nothing measured, nothing lost


def test_resume_measures_agreement_when_the_reference_rows_are_done(tmp_path):
    run_grid(tiny_grid(accels=["warp:sah"], rays=["primary"]), tmp_path, progress=False)
    rows = run_grid(tiny_grid(rays=["primary"]), tmp_path, resume=True, progress=False)
    assert [r["accel"] for r in rows] == ["warp:sah", "wrt:sah"]
    assert rows[1]["agreement"] == 1.0  # was None: the reference's answer was never computed on resume


def test_resume_checks_the_rows_it_kept_unchecked_once_the_reference_is_measured(tmp_path):
    """wrt:sah measured alone, then resumed with warp:sah added: the wrt:sah row was kept unchecked, and the table
    and the command line said 'no warp:sah answer in the group (it failed or was not run)' beside the group's
    warp:sah row. A kept row measured without the reference answer is measured again when the run has one; a row
    checked before is still kept."""
    grid = dict(scenes=["sphere:200"], rays=["primary"], n_rays=300, repeats=1)
    run_grid(tiny_grid(accels=["wrt:sah"], **grid), tmp_path, progress=False)
    with pytest.warns(UserWarning, match="measured again, as it was not checked against warp:sah"):
        rows = run_grid(tiny_grid(**grid), tmp_path, resume=True, progress=False)
    assert rows.resumed == 0 and [(r["accel"], r["agreement"]) for r in rows] == [("warp:sah", 1.0), ("wrt:sah", 1.0)]
    assert "unchecked" not in (tmp_path / "table.md").read_text()
    rows = run_grid(tiny_grid(**grid), tmp_path, resume=True, progress=False)
    assert rows.resumed == 2 and all(r["agreement"] == 1.0 for r in rows)


def test_resume_drops_error_rows_that_now_succeed_and_a_cut_last_line(tmp_path):
    scene = tmp_path / "late.usda"
    run_grid(tiny_grid(scenes=[str(scene)], rays=["primary"]), tmp_path, progress=False)
    assert all("error" in r for r in read_rows(tmp_path))
    scene.write_text(
        '#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
        "    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n"
    )
    with open(tmp_path / "rows.jsonl", "a") as f:
        f.write('{"scene": "sphere:2000", "accel": "wrt:sah", "dev')  # a write cut short by an interruption
    with pytest.warns(UserWarning, match="line 2 was cut short"):
        rows = run_grid(tiny_grid(scenes=[str(scene)], rays=["primary"]), tmp_path, resume=True, progress=False)
    assert len(rows) == 2 and not any("error" in r for r in rows)
    assert read_rows(tmp_path) == rows


def test_resume_measures_again_the_rows_of_a_changed_or_broken_scene(tmp_path):
    """--resume checked the ray count only: rows of a scene file since edited (two triangles, now one) were kept as
    measured, beside new rows of the new file; a scene that no longer loads kept its old rows beside its error."""
    scene = tmp_path / "quad.usda"
    scene.write_text(TRIANGLES_USDA.format(counts="[3, 3]", indices="[0, 1, 2, 0, 2, 3]"))
    grid = tiny_grid(scenes=[str(scene), "sphere:200"], rays=["incoherent"], n_rays=500, repeats=1)
    out = tmp_path / "out"
    run_grid(grid, out, progress=False)
    kept = [r for r in read_rows(out) if r["scene"] == "sphere:200"]
    scene.write_text(TRIANGLES_USDA.format(counts="[3]", indices="[0, 1, 2]"))
    with pytest.warns(UserWarning, match="quad.usda / cpu / incoherent: rows of the resumed run measured again, as "
                                         "its triangles or rays changed"):
        rows = run_grid(grid, out, resume=True, progress=False)
    assert rows[:2] == kept and len(rows) == 4 and read_rows(out) == rows  # the sphere's rows were not re-measured
    assert [r["triangles"] for r in rows[2:]] == [1, 1]
    scene.unlink()
    with pytest.warns(UserWarning, match="quad.usda / cpu / incoherent: .* measured again, as the group now fails"):
        rows = run_grid(grid, out, resume=True, progress=False)
    assert rows[:2] == kept and [r["accel"] for r in rows[2:]] == ["*"] and read_rows(out) == rows


def test_resume_measures_again_rows_of_other_hardware_or_versions(tmp_path):
    """Rows measured under another Warp version or on another CPU were kept by --resume and compared with new ones."""
    run_grid(tiny_grid(rays=["primary"]), tmp_path, progress=False)
    first, second = read_rows(tmp_path)
    (tmp_path / "rows.jsonl").write_text(json.dumps(first) + "\n"
                                         + json.dumps(dict(second, warp="1.18.0", cpu="Another CPU")) + "\n")
    with pytest.warns(UserWarning, match=f"measured again, as warp 1.18.0 -> {wrt.bench.wp.config.version}, cpu "
                                         f"Another CPU -> "):
        rows = run_grid(tiny_grid(rays=["primary"]), tmp_path, resume=True, progress=False)
    assert rows[0] == first and rows[1]["warp"] == wrt.bench.wp.config.version and rows[1]["cpu"] == first["cpu"]
    assert read_rows(tmp_path) == rows and rows[1]["agreement"] == 1.0


def test_resume_measures_again_rows_of_other_wrt_code(tmp_path):
    """wrt's version string stays 0.1.0 while its code changes: rows measured with other code (another hash of the
    package's source) are measured again, and each table names the source it was measured with."""
    run_grid(tiny_grid(rays=["primary"]), tmp_path, progress=False)
    first, second = read_rows(tmp_path)
    assert first["wrt_source"] == wrt.bench.source_digest() and len(first["wrt_source"]) == 12
    (tmp_path / "rows.jsonl").write_text(json.dumps(dict(first, wrt_source="0123456789ab")) + "\n"
                                         + json.dumps(second) + "\n")
    with pytest.warns(UserWarning, match="measured again, as wrt_source 0123456789ab -> "):
        rows = run_grid(tiny_grid(rays=["primary"]), tmp_path, resume=True, progress=False)
    assert rows[0] == second and rows[1]["wrt_source"] == first["wrt_source"]
    assert f"(source {first['wrt_source']})" in (tmp_path / "table.md").read_text()


@pytest.mark.parametrize("line", ['{"scene": "sphere:2000", "accel": "wrt:sah"}', "5", "[1]"])
def test_resume_names_a_line_that_is_not_a_row(tmp_path, line):
    """JSON that is not a row stopped the resumed run with a KeyError traceback or "argument of type 'int' is not
    iterable"; it is now an error naming the file and the line, and the file is left as it was."""
    rows = tmp_path / "rows.jsonl"
    rows.write_text(line + "\n")
    with pytest.raises(ValueError, match="rows.jsonl: line 1 is not a benchmark row"):
        run_grid(tiny_grid(rays=["primary"]), tmp_path, resume=True, progress=False)
    assert rows.read_text().startswith(line)


def test_a_device_refused_leaves_no_output_folder_behind(tmp_path, capsys):
    """wrt bench --devices cuda:7 on a machine without it made the output folder (bench-out/), then stopped at the
    device: an empty folder was left where none had been."""
    out = tmp_path / "new" / "bench-out"
    assert main(["bench", "--scenes", "sphere:100", "--devices", "cuda:99", "-o", str(out), "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(errors) == 1, errors
    assert errors[0].startswith("wrt: error: argument --devices: unknown or unavailable device 'cuda:99'"), errors
    assert list(tmp_path.iterdir()) == []


def test_resume_names_a_row_of_a_render_log_as_such(tmp_path):
    """A render's log row in rows.jsonl (wrt render --log OUT/rows.jsonl) was named only as 'not a benchmark row';
    it is named as a render log's, with the image it names."""
    scene = tmp_path / "a.usda"
    scene.write_text("#usda 1.0\n")
    log = tmp_path / "rows.jsonl"
    assert main(["render", str(scene), "-o", str(tmp_path / "a.png"), "--width", "4", "--height", "3", "--log",
                 str(log), "-q"]) == 0
    text = log.read_text()
    with pytest.raises(ValueError, match=f"rows.jsonl: line 1 is a row of a wrt render log \\(image "
                                         f"{re.escape(str(tmp_path / 'a.png'))}\\), not a benchmark row"):
        run_grid(tiny_grid(rays=["primary"]), tmp_path, resume=True, progress=False)
    assert log.read_text() == text


@pytest.mark.parametrize(
    "field, needle",
    [
        (dict(scenes="sphere:2000"), "scenes: must be a list"),
        (dict(n_rays=-5), "n_rays: must be a positive integer"),
        (dict(repeats=0), "repeats: must be a positive integer"),
        (dict(threads=[1, "abc"]), r"threads\[1\]: must be positive integers"),
        (dict(rays=["primary", "sideways"]), r"rays\[1\]: unknown ray kind"),
        (dict(scenes=[2000]), r"scenes\[0\]: must be a list of names, got 2000"),  # was an AttributeError traceback
        (dict(accels=["wrt:sah", None]), r"accels\[1\]: must be a list of names, got None"),
        (dict(accels=[]), "accels: the grid measures nothing: accels empty"),  # was 0 rows and exit status 0
        # A misspelt accelerator became an error row for every scene, ray kind and device, at run time.
        (dict(accels=["wrt:sah", "foo"]), r"accels\[1\]: accelerator 'foo': unknown accelerator kind 'foo'; "
                                          "accelerators"),
        (dict(accels=["wrt:octree"]), r"accels\[0\]: accelerator 'wrt:octree': unknown BVH builder 'octree'"),
        (dict(accels=["wrt:sah:wide9"]), r"accels\[0\]: accelerator 'wrt:sah:wide9': unknown BVH layout 'wide9'"),
        (dict(accels=["warp:ploc"]), r"accels\[0\]: accelerator 'warp:ploc': wp.Mesh has no builder 'ploc'; its"),
        (dict(rays=[], devices=[]), "devices: the grid measures nothing: devices, rays empty"),
        (dict(scenes=["sphere:2000", "sphere:abc"]), r"scenes\[1\]: sphere:abc: N must be a whole number"),
        # The scaling sweep's fields were not checked: a misspelt key dropped the sweep without a word, a string of
        # sizes was read digit by digit, and a bad ray kind or count failed on every sweep row.
        (dict(scaling={"size": [1000]}), r"scaling: unknown scaling keys \['size'\]"),
        (dict(scaling={"sizes": "1000"}), "scaling.sizes: must be a list"),
        (dict(scaling={"sizes": [1000, None]}), "scaling.sizes: must be a list"),
        (dict(scaling={"sizes": [1000.5]}), "scaling.sizes: must be a list of triangle counts, whole numbers of 8"),
        (dict(scaling={"sizes": [5]}), "scaling.sizes: must be a list of triangle counts, whole numbers of 8"),
        (dict(scaling={"sizes": [1000], "accels": "wrt:sah"}), "scaling.accels: must be a list"),
        (dict(scaling={"sizes": [1000], "accels": ["wrt:sah", "wrt:sha"]}),
         r"scaling.accels\[1\]: accelerator 'wrt:sha': unknown BVH builder 'sha'"),
        (dict(scaling={"sizes": [1000], "rays": "sideways"}), "scaling.rays: unknown scaling ray kind 'sideways'"),
        (dict(scaling={"sizes": [1000], "n_rays": -5}), "scaling.n_rays: must be a positive integer"),
        # sphere:2000 as a scene and a sweep size: its sweep group ran as a second scene group, unmarked.
        (dict(scaling={"sizes": [1000, 2e3]}), "scaling: size 2000 is also the scene 'sphere:2000'"),
    ],
)
def test_bad_grid_fields_are_named(tmp_path, field, needle):
    """A suite's bad value is refused naming the file and the key it sits at, the entry of a list too: the messages
    named the value only ('suite.json: accelerator 'foo': ...'), which a long suite leaves the reader to search."""
    suite = tmp_path / "suite.json"
    suite.write_text(json.dumps({**dict(scenes=["sphere:2000"], accels=["wrt:sah"], rays=["primary"]), **field}))
    with pytest.raises(ValueError, match=f"suite.json: {needle}"):
        Grid.from_suite(suite)


@pytest.mark.parametrize(
    "text, needle",
    [
        ('{"scenes": ["sphere:2000"],', "suite.json: not a JSON suite"),  # was json's message alone
        ("[1, 2]", "suite.json: a suite is a JSON object"),  # was 'unknown suite keys [1, 2]'
        ("null", "suite.json: a suite is a JSON object"),  # was TypeError: 'NoneType' object is not iterable
        ('{"scenes": ["sphere:2000"]}', r"suite.json: missing suite keys \['accels'\]"),  # was Grid.__init__()'s
        # Named as the missing accels are: it became 'scenes: must be a list, got None' when the suite's relative
        # scene paths came to be read from its folder
        ('{"accels": ["wrt:sah"]}', r"suite.json: missing suite keys \['scenes'\]"),
    ],
)
def test_broken_suite_files_are_named(tmp_path, text, needle):
    suite = tmp_path / "suite.json"
    suite.write_text(text)
    with pytest.raises(ValueError, match=needle):
        Grid.from_suite(suite)


def test_thread_counts_are_ints_without_repeats():
    """``"all"`` is every core and "1" is 1: ``--threads 1,1`` wrote the same rows twice."""
    expected = list(dict.fromkeys([1, os.cpu_count() or 1]))
    assert tiny_grid(threads=[1, "1", "all", "all"]).validated().threads == expected


def test_repeated_names_are_measured_once(tmp_path):
    """--accels wrt:sah,wrt:sah (or a scene, device or ray kind twice) measured and wrote the same rows twice."""
    grid = tiny_grid(scenes=["sphere:200", "sphere:200"], accels=["wrt:sah", "warp:sah", "wrt:sah"],
                     devices=["cpu", "cpu"], rays=["primary", "primary"], n_rays=300, repeats=1)
    rows = run_grid(grid, tmp_path, progress=False)
    assert [r["accel"] for r in rows] == ["warp:sah", "wrt:sah"] and len(read_rows(tmp_path)) == 2
    sweep = dict(sizes=[300, 3e2, 300.0], accels=["wrt:sah"], n_rays=300)  # one sphere, written three ways
    rows = run_grid(tiny_grid(scenes=[], scaling=sweep), tmp_path / "sweep", progress=False)
    assert [(r["scene"], r["accel"], r.get("sweep")) for r in rows] == [("sphere:300", "wrt:sah", True)]


def test_interrupted_run_keeps_finished_rows(tmp_path, monkeypatch):
    import wrt.bench as bench

    calls = {"n": 0}
    original = bench.time_runs

    def flaky(run, repeats):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return original(run, repeats)

    monkeypatch.setattr(bench, "time_runs", flaky)
    with pytest.raises(KeyboardInterrupt):
        run_grid(tiny_grid(), tmp_path, progress=False)
    rows = read_rows(tmp_path)
    assert len(rows) == 2
    table = (tmp_path / "table.md").read_text()  # the table of the finished rows too, not only rows.jsonl
    assert all(row["accel"] in table for row in rows)


def test_a_run_that_stops_before_its_first_row_leaves_the_earlier_results(tmp_path, monkeypatch):
    """A misspelt device (the run stops "before any row", status 2), an unreachable Dask scheduler or Ctrl-C while
    the first scene loaded deleted the earlier run's rows.jsonl, rewrote its settings.json and emptied its table.md."""
    run_grid(tiny_grid(rays=["primary"], n_rays=300, repeats=1), tmp_path, progress=False)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert len(read_rows(tmp_path)) == 2
    with pytest.raises(ValueError, match=r"unknown device 'cpuu' \(did you mean 'cpu'\?\)"):
        run_grid(tiny_grid(devices=["cpu", "cpuu"], n_rays=600), tmp_path, progress=False)

    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr(bench_module, "resolve_scene", interrupted)
    for resume in (False, True):
        with pytest.raises(KeyboardInterrupt):
            run_grid(tiny_grid(rays=["primary", "shadow"], n_rays=300, repeats=1), tmp_path, resume=resume,
                     progress=False)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


@pytest.mark.parametrize("name", ["table.md", "settings.json", "mrays.png"])
def test_a_summary_file_cut_short_leaves_the_earlier_one_whole(tmp_path, monkeypatch, name):
    """table.md, settings.json and the plots were written in place: a Ctrl-C (or a full disk) while one was being
    written left a truncated file where the earlier run's whole one had been (a table cut mid-row, a PNG no viewer
    opens, settings that --resume silently took for none)."""
    import matplotlib.figure
    from PIL import Image as PilImage

    grid = tiny_grid(accels=["wrt:sah"], rays=["primary"], n_rays=300, repeats=1)
    run_grid(grid, tmp_path, progress=False)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name != "rows.jsonl"}
    assert name in before

    def cut_short(path):  # the file half written when the interruption comes
        path = Path(path)
        if path.parent == tmp_path and name in path.name:
            path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
            raise KeyboardInterrupt

    write_text, savefig = Path.write_text, matplotlib.figure.Figure.savefig
    monkeypatch.setattr(Path, "write_text", lambda self, *a, **k: (write_text(self, *a, **k), cut_short(self))[0])
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig",
                        lambda fig, path, *a, **k: (savefig(fig, path, *a, **k), cut_short(path))[0])
    with pytest.raises(KeyboardInterrupt):
        run_grid(grid, tmp_path, progress=False)
    left = set(before) | {"rows.jsonl"}
    if name in bench_module.PLOT_FILES:  # the earlier run's plots, whole, are not kept beside this run's rows either
        left -= set(bench_module.PLOT_FILES)
    else:
        assert (tmp_path / name).read_bytes() == before[name]
        PilImage.open(tmp_path / "mrays.png").load()
    assert {p.name for p in tmp_path.iterdir()} == left  # no temporary file left behind
    assert (tmp_path / "table.md").read_text().rstrip().endswith(")")  # the hardware line under the table


def test_ray_kinds():
    scene = wrt.Scene.from_triangles(*displaced_sphere(5000))
    for kind in RAY_KINDS:
        origins, directions = ray_set(scene, kind, 4000, seed=2)
        assert origins.shape == directions.shape and origins.shape[1] == 3 and len(origins) > 0
        assert np.isfinite(origins).all() and np.isfinite(directions).all()
    # Diffuse rays leave the surface into the hemisphere of the normal: a convex-ish sphere mostly lets them escape.
    origins, directions = ray_set(scene, "diffuse", 4000, seed=2)
    assert wrt.trace(scene, origins, directions).hit.mean() < 0.5
    with pytest.raises(ValueError, match="valid ray kinds"):
        ray_set(scene, "specular", 10)


@pytest.mark.parametrize("mirror", [1.0, -1.0])
def test_secondary_rays_leave_analytic_shapes_along_their_normals(mirror):
    """Shadow and diffuse rays start at the hits of primary rays: on an analytic shape (an ellipsoid, a sphere placed
    by a non-uniform instance transform, mirrored or not) ``ray_set`` read the hit's row as a triangle's and failed
    with an IndexError. The ellipsoid's normal is checked against its implicit surface's gradient, in float64."""
    semi = np.array([2.0, 1.0, 0.5])  # semi-axes of the ellipsoid (x^2/a^2 + y^2/b^2 + z^2/c^2 = 1)
    centre = np.array([0.3, -0.2, 0.1])
    to_world = np.eye(4)
    to_world[:3, :3] = np.diag(semi * [mirror, 1.0, 1.0])
    to_world[:3, 3] = centre
    proto = wrt.Prototype("/Ball", shapes=[wrt.Shape("/Ball/sphere", "sphere", np.eye(4), double_sided=True)])
    floor = wrt.Mesh("/floor", np.array([[-3, -2, -3], [3, -2, -3], [3, -2, 3], [-3, -2, 3]], np.float32),
                     np.array([[0, 1, 2], [0, 2, 3]]), np.arange(2), double_sided=True)
    scene = wrt.Scene(meshes=[floor], prototypes=[proto],
                      instances=wrt.Instances.from_transforms([0], to_world[None]))
    for kind in ("shadow", "diffuse"):
        origins, directions = ray_set(scene, kind, 3000, seed=2)
        local = (origins.astype(np.float64) - centre) / semi
        on_ball = np.abs(np.linalg.norm(local, axis=1) - 1) < 1e-2
        assert on_ball.sum() > 100, kind
        gradient = local[on_ball] / semi  # outward normal of the ellipsoid
        # Rays leave from outside the ellipsoid (the camera sees its outside), into the outer half-space.
        assert (np.linalg.norm(local[on_ball], axis=1) > 1).all(), kind
        if kind == "diffuse":
            assert (np.einsum("ij,ij->i", gradient, directions[on_ball]) > 0).all()


def test_displaced_sphere_is_closed_and_sized():
    points, indices = displaced_sphere(100_000)
    assert 0.9e5 < len(indices) < 1.1e5
    edges = np.sort(np.concatenate([indices[:, [0, 1]], indices[:, [1, 2]], indices[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()  # closed 2-manifold


def test_fit_slope():
    n = np.array([1e3, 1e4, 1e5])
    assert fit_slope(n, 3 * n**1.1) == pytest.approx(1.1)
    assert np.isnan(fit_slope(n, n, x_min=1e5)) and np.isnan(fit_slope(n, n, x_min=1e6))  # no line through < 2


@pytest.mark.parametrize("sizes", [[1000, 5000], [1000, 100_000]])
def test_scaling_plot_of_sizes_below_the_slope_range(tmp_path, sizes):
    """A sweep with no size from 1e4 up ended the run with numpy's 'expected non-empty vector for x' and one size
    there gave a slope fitted through one point (polyfit's 'poorly conditioned'); the plot now says 'no slope'."""
    rows = [dict(scene=f"sphere:{n}", triangles=n, device="cpu", rays="incoherent", accel="wrt:sah", threads=1,
                 build_ms=n / 1e3, mrays=2.0, mrays_min=1.0, mrays_max=3.0, hit_fraction=0.5, sweep=True)
            for n in sizes]
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*poorly conditioned")
        paths = bench_module.plot(rows, tmp_path)
    assert tmp_path / "scaling.png" in paths and (tmp_path / "scaling.png").stat().st_size > 1000


@pytest.mark.filterwarnings("ignore:No artists with labels")  # the bars and lines are recorded, not drawn
def test_plots_keep_devices_apart_and_give_each_scaling_line_its_own_thread_count(tmp_path, monkeypatch):
    """The bars were keyed by (accel, threads) only, so with two devices each bar showed the first device's rows and
    the other's never appeared; the scaling lines mixed devices, and took the smallest thread count of all sweep rows,
    so an accelerator measured only at other counts (wrt:sah at 2 threads beside embree's 1) had no points and the
    run ended in 'not enough values to unpack'."""
    import matplotlib.axes

    bars, lines = {}, []
    monkeypatch.setattr(matplotlib.axes.Axes, "bar", lambda ax, x, values, width, label: bars.update({
        label: list(values)}))
    monkeypatch.setattr(matplotlib.axes.Axes, "loglog", lambda ax, x, y, style, label: lines.append((label, list(y))))

    def row(scene, device, accel, threads, mrays, **extra):
        n = int(scene.split(":")[1])
        return dict(scene=scene, triangles=n, device=device, rays="incoherent", accel=accel, threads=threads,
                    build_ms=n / 1e3, mrays=mrays, mrays_min=mrays, mrays_max=mrays, hit_fraction=0.5, **extra)

    rows = [row("sphere:5000", "cpu", "wrt:sah", 1, 1.0), row("sphere:5000", "cuda:0", "wrt:sah", 1, 50.0)]
    bench_module.plot(rows, tmp_path)
    assert bars == {"wrt:sah cpu x1": [1.0], "wrt:sah cuda:0 x1": [50.0]}

    sizes = [1e4, 1e5]
    sweep = [row(f"sphere:{int(n)}", "cpu", "wrt:sah", t, m, sweep=True)
             for n in sizes for t, m in ((2, 4.0), (4, 8.0))]
    sweep += [row(f"sphere:{int(n)}", "cpu", "embree", 1, 10.0, sweep=True) for n in sizes]
    sweep += [row(f"sphere:{int(n)}", "cuda:0", "wrt:sah", 1, 100.0, sweep=True) for n in sizes]
    assert tmp_path / "scaling.png" in bench_module.plot(sweep, tmp_path)
    ns_per_ray = {label.split(" slope")[0]: y for label, y in lines[1::2]}  # build ms, then ns per ray, per line
    assert ns_per_ray == {"embree cpu": [1e3 / 10.0] * 2, "wrt:sah cpu": [1e3 / 4.0] * 2,  # wrt:sah at its fewest, 2
                          "wrt:sah cuda:0": [1e3 / 100.0] * 2}


def test_plots_of_an_earlier_run_do_not_stay_beside_rows_that_have_none(tmp_path):
    """A run into a folder that held an earlier run's plots left them there when it drew none (every row failed, or
    no sweep this time), so mrays.png showed numbers that table.md no longer had."""
    earlier = [dict(scene=f"sphere:{n}", triangles=n, device="cpu", rays="incoherent", accel="wrt:sah", threads=1,
                    build_ms=n / 1e3, mrays=2.0, mrays_min=1.0, mrays_max=3.0, hit_fraction=0.5, sah_cost=1.5,
                    sweep=True) for n in (10_000, 100_000)]
    assert len(bench_module.plot(earlier, tmp_path)) == 3  # an earlier run's plots, as wrt wrote them
    rows = run_grid(tiny_grid(scenes=["no/such/scene.usda"], rays=["primary"]), tmp_path, progress=False)
    assert all("error" in r for r in rows)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rows.jsonl", "settings.json", "table.md"]


def test_no_build_vs_quality_plot_without_a_tree_to_plot(tmp_path):
    """Rows of wp.Mesh (or Embree) alone have no SAH cost: build_vs_quality.png was drawn as empty axes."""
    run_grid(tiny_grid(accels=["warp:sah"], rays=["primary"], n_rays=300, repeats=1), tmp_path, progress=False)
    assert (tmp_path / "mrays.png").read_bytes().startswith(b"\x89PNG")
    assert not (tmp_path / "build_vs_quality.png").exists()


def plotted_figures(monkeypatch, rows, out) -> dict:
    """The figures ``plot`` draws for ``rows``, by file name, kept open (``plt.close`` skipped) to be inspected."""
    import matplotlib.figure
    import matplotlib.pyplot as plt

    figures, save = [], matplotlib.figure.Figure.savefig

    def savefig(fig, path, **options):  # path: a temporary file, renamed to the plot's name once written
        figures.append(fig)
        save(fig, path, **options)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    monkeypatch.setattr(plt, "close", lambda fig=None: None)
    paths = bench_module.plot(rows, out)
    return dict(zip([path.name for path in paths], figures, strict=True))


def tree_row(accel, build_ms, sah_cost, rays="primary", threads=1, scene="sphere:1000"):
    return dict(scene=scene, triangles=930, device="cpu", rays=rays, accel=accel, threads=threads, build_ms=build_ms,
                mrays=5.0, mrays_min=4.0, mrays_max=6.0, hit_fraction=0.2, sah_cost=sah_cost)


def test_every_plot_is_a_png_whose_axes_are_all_named(tmp_path, monkeypatch):
    """mrays.png named its y axis only: the groups of bars under it had no axis label saying what they were."""
    import matplotlib.pyplot as plt
    from PIL import Image as PilImage

    rows = [tree_row(accel, ms, cost, scene=f"sphere:{n}") | {"triangles": n, "sweep": True}
            for accel, cost in (("wrt:sah", 23.5), ("wrt:lbvh", 30.1)) for n, ms in ((1000, 2.0), (8000, 15.0))]
    figures = plotted_figures(monkeypatch, rows, tmp_path)
    try:
        assert sorted(figures) == ["build_vs_quality.png", "mrays.png", "scaling.png"]
        for name, fig in figures.items():
            for ax in fig.axes:
                assert ax.get_xlabel().strip() and ax.get_ylabel().strip(), (name, ax.get_xlabel(), ax.get_ylabel())
            with PilImage.open(tmp_path / name) as image:
                image.verify()  # a whole PNG file, not just its signature
    finally:
        monkeypatch.undo()
        plt.close("all")


@pytest.mark.parametrize("times", [(2.1, 2.2, 2.45, 2.34, 2.5, 2.83), (84, 88, 98, 94, 100, 113),
                                   (8e3, 9e3, 9.5e3, 1e4, 1.1e4, 1.2e4), (0.4, 3, 40, 700, 9e3, 3e4)])
def test_build_axis_labels_of_builds_within_a_decade_do_not_overlap(tmp_path, monkeypatch, times):
    """Builds between 2.1 and 2.8 ms (one small scene, every row) put matplotlib's log axis in its mode that labels
    every minor tick in scientific notation: '2.1x10^0', '2.2x10^0', ... drawn over each other, unreadable."""
    import matplotlib.pyplot as plt

    rows = [tree_row("wrt:sah", ms, 23.5) for ms in times[:3]]
    rows += [tree_row("wrt:median", ms, 41.4) for ms in times[3:]]
    fig = plotted_figures(monkeypatch, rows, tmp_path)["build_vs_quality.png"]
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        axis = fig.axes[0].xaxis
        labels = [t for t in axis.get_majorticklabels() + axis.get_minorticklabels()
                  if t.get_visible() and t.get_text() and fig.axes[0].get_xlim()[0] <= t.get_position()[0]
                  <= fig.axes[0].get_xlim()[1]]
        assert len(labels) >= 2  # the axis has numbers to read
        boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
        for left, right in zip(boxes, boxes[1:]):
            assert left.x1 <= right.x0, [t.get_text() for t in labels]
    finally:
        monkeypatch.undo()  # pyplot's own close again
        plt.close("all")


def test_build_vs_quality_draws_each_tree_once(tmp_path, monkeypatch):
    """Every row builds its tree again, so one tree measured with two ray kinds at two thread counts was four points
    with four identical labels printed over one another ('wrt:sah sphere:1000wrt:sah sph...'). Each tree (accelerator,
    scene, device) is one point, at the median of its build times, with one label."""
    import statistics

    import matplotlib.pyplot as plt

    builds = {("wrt:sah", "sphere:1000"): [2.1, 2.2, 2.45, 2.7], ("wrt:median", "sphere:1000"): [2.3, 2.5, 2.6, 2.8],
              ("wrt:sah", "sphere:5000"): [9.0, 9.5, 9.1, 9.4]}
    rows = [tree_row(accel, ms, 23.5 if accel == "wrt:sah" else 41.4, rays=rays, threads=threads, scene=scene)
            for (accel, scene), times in builds.items()
            for ms, (rays, threads) in zip(times, [("primary", 1), ("primary", 2), ("shadow", 1), ("shadow", 2)])]
    fig = plotted_figures(monkeypatch, rows, tmp_path)["build_vs_quality.png"]
    try:
        ax = fig.axes[0]
        points = np.concatenate([c.get_offsets() for c in ax.collections])
        labels = {t.get_text(): t.xy for t in ax.texts}
    finally:
        monkeypatch.undo()
        plt.close("all")
    assert len(points) == len(builds)
    assert sorted(labels) == sorted(f"{accel} {scene}" for accel, scene in builds)
    for (accel, scene), times in builds.items():
        assert labels[f"{accel} {scene}"] == pytest.approx((statistics.median(times), 23.5 if accel == "wrt:sah"
                                                            else 41.4))


def test_build_vs_quality_names_scene_files_as_the_rate_plot_does(tmp_path, monkeypatch):
    """Scenes given as absolute paths labelled each point with the whole path, and tight_layout made room for those
    labels by squeezing the axes to a sliver at the left of the figure, the labels of its points printed over one
    another (checked with two files of a 60-character folder). Points are labelled with the file's name, as the bars
    of mrays.png are, in full where two scenes share it, and the axes keep most of the figure's width."""
    import matplotlib.pyplot as plt

    folder = "/a/rather/long/folder/of/benchmark/scenes/for/the/build/plot"
    scenes = [f"{folder}/kitchen_interior.usda", f"{folder}/teapot.usda", f"{folder}/v2/teapot.usda", "sphere:1000"]
    rows = [tree_row(accel, 2.0 * (1 + k), 20.0 + k, scene=scene) for k, scene in enumerate(scenes)
            for accel in ("wrt:sah", "wrt:lbvh")]
    fig = plotted_figures(monkeypatch, rows, tmp_path)["build_vs_quality.png"]
    try:
        labels = sorted(t.get_text() for t in fig.axes[0].texts)
        width = fig.axes[0].get_position().width
    finally:
        monkeypatch.undo()
        plt.close("all")
    names = ["kitchen_interior.usda", scenes[1], scenes[2], "sphere:1000"]
    assert labels == sorted(f"{accel} {name}" for name in names for accel in ("wrt:sah", "wrt:lbvh"))
    assert width > 0.5, width


def test_mrays_plot_group_labels_of_scene_files_do_not_overlap(tmp_path, monkeypatch):
    """Scenes given as file paths labelled each group of bars with the whole path, '/tmp/pv_scratch/nested.usda'
    under a group 1.2 inches wide: the labels of neighbouring groups were printed over one another. Each group is
    labelled with its file's name where that names one scene (the full path where two share a name), and the figure
    is wide enough for them."""
    import matplotlib.pyplot as plt

    folder = "/a/rather/long/folder/of/benchmark/scenes"
    scenes = [f"{folder}/{name}.usda" for name in ("instanced_forest", "kitchen_interior", "teapot")]
    scenes += [f"{folder}/v2/teapot.usda", "sphere:1000"]  # two teapot.usda: told apart by their folders
    scenes += ["warp:examples/bunny.usd"]  # named as the table names it, 'warp:' and all
    rows = [tree_row(accel, 2.0, 20.0, rays=kind, scene=scene) for scene in scenes for kind in ("primary", "shadow")
            for accel in ("warp:sah", "wrt:sah")]
    fig = plotted_figures(monkeypatch, rows, tmp_path)["mrays.png"]
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        labels = [t for t in fig.axes[0].get_xticklabels() if t.get_text()]
        texts = [t.get_text() for t in labels]
        boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
    finally:
        monkeypatch.undo()
        plt.close("all")
    assert len(set(texts)) == len(texts) == 2 * len(scenes)
    for name in ("instanced_forest.usda", "kitchen_interior.usda", "sphere:1000", "warp:examples/bunny.usd"):
        assert sum(text.startswith(name + "\n") for text in texts) == 2, texts
    assert sum(text.startswith(scenes[2] + "\n") for text in texts) == 2, texts  # teapot.usda, named in full
    assert sum(text.startswith(scenes[3] + "\n") for text in texts) == 2, texts
    for left, right in zip(boxes, boxes[1:]):
        assert left.x1 <= right.x0, texts


def test_mrays_plot_orders_the_bars_of_an_accelerator_by_thread_count(tmp_path, monkeypatch):
    """The series were sorted by their text, "('wrt:sah', 'cpu', 16)" before "('wrt:sah', 'cpu', 2)": the bars and
    the legend of --threads 1,2,16 read x1, x16, x2."""
    import matplotlib.pyplot as plt

    rows = [dict(tree_row(accel, 2.0, 20.0, threads=threads), mrays=float(threads))
            for accel in ("warp:sah", "wrt:sah") for threads in (1, 2, 16)]
    fig = plotted_figures(monkeypatch, rows, tmp_path)["mrays.png"]
    try:
        legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    finally:
        monkeypatch.undo()
        plt.close("all")
    assert legend == [f"{accel} x{threads}" for accel in ("warp:sah", "wrt:sah") for threads in (1, 2, 16)]


def test_markdown_table_names_hardware():
    rows = [{"scene": "s", "triangles": 1, "device": "cpu", "rays": "primary", "accel": "warp:sah", "threads": 1,
             "build_ms": 1.0, "mrays": 2.0, "mrays_min": 1.0, "mrays_max": 3.0, "hit_fraction": 0.5, "agreement": 1.0,
             "cpu": "Some CPU", "cpu_cores": 2, "gpu": None, "driver": None, "warp": "1.19.0", "wrt": "0.1.0",
             "wrt_source": "abc"}]
    table = markdown_table(rows)
    assert "Some CPU" in table and "| 1.00 |" in table
    # A CPU row's line named its GPU and driver as None; a GPU row names them.
    (line,) = [line for line in table.splitlines() if line.startswith("- cpu:")]
    assert line.startswith("- cpu: CPU Some CPU (2 cores), Warp 1.19.0") and "None" not in line, line
    gpu = dict(rows[0], device="cuda:0", gpu="Some GPU", driver="CUDA 13.0", gpu_driver="580.1")
    (line,) = [line for line in markdown_table([gpu]).splitlines() if line.startswith("- cuda:0:")]
    assert "GPU Some GPU, driver 580.1 (CUDA 13.0), Warp 1.19.0" in line, line


def test_a_disagreement_with_warp_is_reported_in_the_table_and_by_the_cli(tmp_path, monkeypatch, capsys):
    """A row whose hits differed from wp.Mesh's showed only its agreement (99.000), with no word on stderr: a wrong
    answer read as a speed-up. Rows of a group without warp:sah showed an empty agreement cell."""
    answer = bench_module._Subject.answer

    def wrong(subject):
        hits = answer(subject)
        if subject.spec == "wrt:sah":
            hits.prim[np.flatnonzero(hits.prim >= 0)[:7]] = -1  # 7 hits lost
        return hits

    monkeypatch.setattr(bench_module._Subject, "answer", wrong)
    argv = ["bench", "--scenes", "sphere:200", "--rays", "primary", "--n-rays", "300", "--repeats", "1", "-q"]
    assert main(argv + ["--accels", "warp:sah,wrt:sah", "-o", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "warning: sphere:200 / wrt:sah / cpu / primary: 7 of 300 rays answered otherwise than by warp:sah" in err
    assert "(7 differ) |" in (tmp_path / "a" / "table.md").read_text()
    assert main(argv + ["--accels", "wrt:sah", "-o", str(tmp_path / "b")]) == 0
    assert "warning: 1 row not checked against warp:sah" in capsys.readouterr().err
    assert "| unchecked |" in (tmp_path / "b" / "table.md").read_text()


def test_markdown_table_cells_line_up_with_the_header():
    """A '|' in a scene path or an error message split its cell, so the row's columns slid under the wrong headers;
    a group's error row showed 'None' threads."""
    good = {"scene": "a|b.usda", "triangles": 1, "device": "cpu", "rays": "primary", "accel": "wrt:sah", "threads": 1,
            "build_ms": 1.0, "mrays": float("nan"), "mrays_min": 1.0, "mrays_max": float("inf"), "hit_fraction": 0.5,
            "agreement": 1.0, "disagreements": 0}
    error = {"scene": "x|y.usda", "accel": "*", "device": "cpu", "rays": "primary", "threads": None,
             "error": "SceneError: x|y.usda: bad"}
    lines = markdown_table([good, error]).splitlines()
    columns = lambda line: line.replace("\\|", "").count("|")  # noqa: E731
    assert [columns(line) for line in lines[:4]] == [14] * 4
    assert "None" not in lines[3] and "a\\|b.usda" in lines[2]


def test_a_row_that_measured_nothing_is_strict_json_and_reads_n_a(tmp_path, monkeypatch):
    """A NaN rate went to rows.jsonl as a bare NaN, which is no JSON (jq and JSON.parse reject the file), and to
    table.md as 'nan'; an infinite one failed the plots on their log axes ('Data cannot be log-scaled')."""
    monkeypatch.setattr(bench_module, "time_runs", lambda run, repeats: [run(), [math.nan] * repeats][1])  # bad timer
    run_grid(tiny_grid(rays=["primary"], n_rays=300, repeats=1), tmp_path, progress=False)

    def no_constants(name):
        raise ValueError(f"{name} is no JSON")

    written = [json.loads(line, parse_constant=no_constants) for line in (tmp_path / "rows.jsonl").read_text().split(
        "\n") if line]
    assert [(r["accel"], r["mrays"], r["mrays_max"], r["build_ms"] > 0) for r in written] == [
        ("warp:sah", None, None, True), ("wrt:sah", None, None, True)]
    rows = run_grid(tiny_grid(rays=["primary", "shadow"], n_rays=300, repeats=1), tmp_path, resume=True,
                    progress=False)
    assert len(rows) == 4 and all(math.isnan(r["mrays"]) for r in rows)  # null read back as NaN by --resume
    assert all(r["agreement"] == 1.0 for r in rows)  # a null that means unchecked is not read as NaN
    table = (tmp_path / "table.md").read_text()
    assert not re.search(r"\b(nan|inf)\b", table, re.IGNORECASE) and "| n/a (n/a-n/a) |" in table
    sweep = [dict(scene=f"sphere:{n}", triangles=n, device="cpu", rays="incoherent", accel="wrt:sah", threads=1,
                  build_ms=1.0, mrays=mrays, mrays_min=1.0, mrays_max=mrays, hit_fraction=0.5, sah_cost=sah, sweep=True)
             for n, mrays, sah in ((1000, 2.0, 1.5), (10_000, math.inf, math.nan), (100_000, math.nan, math.inf))]
    assert sorted(p.name for p in bench_module.plot(sweep, tmp_path)) == ["build_vs_quality.png", "mrays.png",
                                                                         "scaling.png"]


def test_cli_bench_suite_and_quick_conflict(tmp_path, capsys):
    """wrt bench cpu --quick ran the quick suite and dropped the one named without a word."""
    assert main(["bench", "cpu", "--quick", "-o", str(tmp_path / "out")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: error")]
    assert len(err) == 1 and "give a suite (cpu) or --quick, not both" in err[0]
    assert not (tmp_path / "out").exists()


def test_cli_bench_exit_status_summarises_failures(tmp_path, capsys):
    code = main(["bench", "--scenes", "sphere:1500,missing.usda", "--accels", "warp:sah", "--rays", "primary",
                 "--n-rays", "2000", "--repeats", "2", "-o", str(tmp_path), "-q"])
    assert code == 1
    err = capsys.readouterr().err
    assert "1 failed" in err and "missing.usda" in err
    assert main(["bench", "--rays", "sideways", "-o", str(tmp_path), "-q"]) == 2


def test_cli_bench_counts_resumed_rows_apart_from_measured_ones(tmp_path, capsys):
    """A resumed run said '4 rows measured' when it had measured 2 and kept 2 of the earlier run."""
    argv = ["bench", "--scenes", "sphere:200,missing.usda", "--accels", "warp:sah,wrt:sah", "--n-rays", "300",
            "--repeats", "1", "-o", str(tmp_path), "-q", "--rays"]
    assert main(argv + ["primary"]) == 1
    assert "wrt: 2 rows measured, 0 resumed, 1 failed;" in capsys.readouterr().err
    assert main(argv + ["primary,shadow", "--resume"]) == 1
    assert "wrt: 2 rows measured, 2 resumed, 2 failed;" in capsys.readouterr().err


def test_a_cuda_device_this_machine_lacks_fails_its_rows_and_the_others_run(tmp_path, capsys):
    """--devices cpu,cuda:99 stopped the whole run before any row with 'unknown or unavailable device'."""
    code = main(["bench", "--scenes", "sphere:200", "--accels", "warp:sah", "--rays", "primary", "--devices",
                 "cpu,cuda:99", "--n-rays", "300", "--repeats", "1", "-o", str(tmp_path), "-q"])
    assert code == 1
    rows = read_rows(tmp_path)
    assert [(r["device"], "mrays" in r) for r in rows] == [("cpu", True), ("cuda:99", False)]
    assert "unknown or unavailable device 'cuda:99'" in rows[1]["error"]
    assert "failed: sphere:200 / * / cuda:99 / primary: ValueError: unknown or unavailable device 'cuda:99'" in (
        capsys.readouterr().err)
    with pytest.raises(ValueError, match="unknown or unavailable device 'cuda:99'"):  # nothing to run at all
        run_grid(tiny_grid(devices=["cuda:99"]), tmp_path, progress=False)
    with pytest.raises(ValueError, match=r"unknown device 'cpuu' \(did you mean 'cpu'\?\)"):  # a misspelt name
        run_grid(tiny_grid(devices=["cpu", "cpuu"]), tmp_path, progress=False)


def test_resume_keeps_the_rows_of_a_cuda_device_missing_now(tmp_path):
    """Resumed on a machine whose GPU is missing now (a driver down, CUDA_VISIBLE_DEVICES unset), the GPU's error
    rows deleted every row it had measured before from rows.jsonl ("measured again, as the group now fails"), though
    nothing measured them again; they stay, beside the error row naming the device."""
    run_grid(tiny_grid(rays=["primary"], n_rays=300, repeats=1), tmp_path, progress=False)
    measured = [dict(r, device="cuda:99", gpu="A GPU") for r in read_rows(tmp_path)]  # as if measured on a GPU
    (tmp_path / "rows.jsonl").write_text("".join(json.dumps(r) + "\n" for r in measured))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "measured again" warning: nothing is
        rows = run_grid(tiny_grid(rays=["primary"], n_rays=300, repeats=1, devices=["cpu", "cuda:99"]), tmp_path,
                        resume=True, progress=False)
    assert rows[:2] == measured and read_rows(tmp_path) == rows
    assert [(r["device"], r["accel"]) for r in rows[2:]] == [("cpu", "warp:sah"), ("cpu", "wrt:sah"), ("cuda:99", "*")]


@pytest.mark.parametrize(
    "script, args, message",
    [
        ("quality.py", ["--builders", "sah,foo"], "unknown BVH builder 'foo'"),
        ("tree_shape_cpu.py", ["--settings", "8:x"], "'8:x' is not LEAF_SIZE:RATIO"),
        ("refit_vs_rebuild.py", ["--triangles", "0"], "must be a positive integer, got 0"),
        ("batch_throughput.py", ["--cameras", "2.5"], "'2.5' is not an integer"),
        # Both ended in a traceback after the scene was built.
        ("batch_throughput.py", ["--integrators", "whitted", "foo"], "--integrators: unknown integrator 'foo'"),
        ("batch_throughput.py", ["--device", "cuda:99"], "--device: unknown or unavailable device 'cuda:99'"),
    ],
)
def test_benchmark_scripts_refuse_bad_arguments_in_one_line(script, args, message):
    """They ended in tracebacks (or, for zero cameras, a misleading 'not both') after loading scenes."""
    path = Path(__file__).resolve().parents[1] / "benchmarks" / script
    done = subprocess.run([sys.executable, str(path), *args], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize("script, error", [
    ("gpu_tlas_ab.py", "gpu_tlas_ab.py: error: BASELINE='' names no folder holding wrt_old"),
    ("kept_frame_cases.py", "kept_frame_cases.py: error: the following arguments are required: folder, case"),
])
def test_benchmark_scripts_given_nothing_print_their_usage_and_exit_with_status_2(script, error):
    """Without BASELINE gpu_tlas_ab.py stopped with a traceback, 'KeyError: 'BASELINE'', and kept_frame_cases.py
    without arguments with 'IndexError: list index out of range'. Both are argparse's usage and error lines now."""
    path = Path(__file__).resolve().parents[1] / "benchmarks" / script
    env = {k: v for k, v in os.environ.items() if k != "BASELINE"}
    done = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=60, env=env)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert lines[0].startswith(f"usage: {script} ") and lines[1].startswith(error), lines


def test_shadow_rays_aim_at_the_first_distant_light_whatever_comes_before_it():
    scene = wrt.Scene.from_triangles(*displaced_sphere(5000))
    sun = np.array([0.0, 0.6, -0.8])  # the direction the light travels
    scene.lights = [wrt.SphereLight(position=(0.0, 5.0, 0.0), radius=0.5, color=(1.0, 1.0, 1.0)),
                    wrt.DistantLight(direction=sun, color=(1.0, 1.0, 1.0))]
    _, directions = ray_set(scene, "shadow", 2000, seed=3)
    np.testing.assert_allclose(directions, np.broadcast_to(-sun, directions.shape), atol=1e-6)


def test_default_sun_of_a_z_up_scene_is_the_y_up_sun_turned_as_the_scene_is():
    """The same world content written Z-up (turned a quarter about +X, (x, y, z) -> (x, -z, y)) must get the same
    shadow rays turned alike; the Z-up sun swapped y and z, a mirror image, so it lit the scene from the other side."""
    points, indices = displaced_sphere(2000)
    y_up = wrt.Scene.from_triangles(points, indices)
    z_up = wrt.Scene.from_triangles(np.stack([points[:, 0], -points[:, 2], points[:, 1]], axis=1), indices)
    z_up.up_axis = "Z"
    _, y_dirs = ray_set(y_up, "shadow", 500, seed=3)
    _, z_dirs = ray_set(z_up, "shadow", 500, seed=3)
    np.testing.assert_allclose(z_dirs[0], [y_dirs[0][0], -y_dirs[0][2], y_dirs[0][1]], atol=1e-6)


@pytest.mark.parametrize("size", [1e-3, 1.0, 1e3])
def test_shadow_rays_of_a_scene_in_any_unit_start_under_a_slab_just_above_the_floor(size):
    """A floor with a slab 1% of the scene's size above it, as the same part written in metres or millimetres: every
    shadow ray from the floor (primary rays cast down from between the two) must hit the slab. The offset off the
    surface was 1e-4 (1 + |p|) scene units, so at a size of 1e-3 the rays started 10% of the scene above the floor,
    past the slab, and all missed it."""
    from wrt.rays import secondary_rays

    corners = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float64)
    quad = np.array([[0, 2, 1], [0, 3, 2]])  # facing +Y
    floor = wrt.Mesh("/floor", (corners * size).astype(np.float32), quad, np.arange(2), double_sided=True)
    slab = wrt.Mesh("/slab", ((corners * [50, 0, 50] + [0, 0.01, 0]) * size).astype(np.float32), quad, np.arange(2),
                    double_sided=True)
    scene = wrt.Scene(meshes=[floor, slab])
    rng = np.random.default_rng(123)
    origins = np.c_[rng.uniform(-0.5, 0.5, 200), np.full(200, 0.005), rng.uniform(-0.5, 0.5, 200)] * size
    origins = origins.astype(np.float32)
    directions = np.tile(np.float32([0.0, -1.0, 0.0]), (200, 1))
    hits = wrt.trace(scene, origins, directions)
    assert (hits.prim >= 0).all() and (hits.prim < 2).all()  # the floor's two triangles
    shadow_origins, shadow_directions = secondary_rays(scene, "shadow", origins, directions, hits)
    shadow = wrt.trace(scene, shadow_origins, shadow_directions)
    np.testing.assert_array_equal(shadow.prim >= 2, True)  # the slab's triangles


def test_shadow_rows_name_the_light_their_rays_aim_at_and_the_lights_they_leave_out(tmp_path):
    """Shadow rays aim at the scene's first DistantLight (else a default sun), whatever other lights it has; nothing
    in the rows or the table said so, so a scene lit by a sphere and a rect light looked measured towards them. The
    rows now name it (``shadow_light``: the light's prim path, or ``default sun``) and count the lights left out
    (``lights_not_aimed_at``), and the table says it under the rows. Oracle: the stage's lights as USD lists them,
    and the direction of /Sun's -Z axis from ``UsdGeom.XformCache``."""
    from pxr import Gf, Usd, UsdGeom

    lit = tmp_path / "lit.usda"
    lit.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 2\n}\n'
                   'def SphereLight "Lamp"\n{\n    double3 xformOp:translate = (0, 5, 0)\n'
                   '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
                   'def RectLight "Panel"\n{\n    double3 xformOp:translate = (0, 0, 5)\n'
                   '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
                   'def DistantLight "Sun"\n{\n    float3 xformOp:rotateXYZ = (-60, 20, 0)\n'
                   '    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]\n}\n')
    unlit = tmp_path / "unlit.usda"
    unlit.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 2\n}\n'
                     'def SphereLight "Lamp"\n{\n    double3 xformOp:translate = (0, 5, 0)\n'
                     '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n')
    rows = run_grid(tiny_grid(scenes=[str(lit), str(unlit)], accels=["wrt:sah"], rays=["primary", "shadow"],
                              n_rays=1000, repeats=1), tmp_path / "out", progress=False)
    shadow = {Path(r["scene"]).name: r for r in rows if r["rays"] == "shadow"}
    assert (shadow["lit.usda"]["shadow_light"], shadow["lit.usda"]["lights_not_aimed_at"]) == ("/Sun", 2)
    assert (shadow["unlit.usda"]["shadow_light"], shadow["unlit.usda"]["lights_not_aimed_at"]) == ("default sun", 1)
    assert all("shadow_light" not in r for r in rows if r["rays"] == "primary")
    table = (tmp_path / "out" / "table.md").read_text()
    assert f"- shadow rays of {lit}: towards /Sun (2 other lights not aimed at)" in table, table
    assert f"- shadow rays of {unlit}: towards the default sun (1 other light not aimed at)" in table, table
    stage = Usd.Stage.Open(str(lit))
    to_world = UsdGeom.XformCache().GetLocalToWorldTransform(stage.GetPrimAtPath("/Sun"))
    toward = -np.array(to_world.TransformDir(Gf.Vec3d(0, 0, -1)))
    _, directions = ray_set(bench_module.resolve_scene(str(lit)), "shadow", 500, seed=1)
    np.testing.assert_allclose(directions, np.broadcast_to(toward / np.linalg.norm(toward), directions.shape),
                               atol=1e-6)
