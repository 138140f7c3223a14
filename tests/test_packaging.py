"""What ``pip install .`` ships: the package data inside the wheel, its metadata, and a source tree that builds the
same wheel on every checkout."""

import importlib
import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_package_sources_hold_no_symbolic_links():
    """A checkout without symbolic links (Git's default on Windows) turns a link into a text file that holds its
    target: the wheel then shipped '../../scenes/default_room.usda' as the default scene (``wrt render``: 'not a
    valid usda layer') and no benchmark suites (``wrt bench --quick``: 'suites in ...: none')."""
    links = [str(p.relative_to(ROOT)) for p in (ROOT / "wrt").rglob("*") if p.is_symlink()]
    assert links == []


class Build(NamedTuple):
    wheel: zipfile.ZipFile  # the wheel pip built
    log: str  # pip's and the build backend's output


@pytest.fixture(scope="module")
def build(tmp_path_factory) -> Build:
    """The wheel ``pip wheel`` builds from a copy of the source tree (a copy: no ``build/`` left over from an
    earlier build can add stale files)."""
    source, dist = tmp_path_factory.mktemp("source"), tmp_path_factory.mktemp("dist")
    for name in ("pyproject.toml", "README.md", "MANIFEST.in", "LICENSE"):
        shutil.copy(ROOT / name, source / name)
    shutil.copytree(ROOT / "wrt", source / "wrt", ignore=shutil.ignore_patterns("__pycache__"))
    result = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-v", "-w", str(dist), str(source)],
                            capture_output=True, text=True, timeout=600)
    log = result.stdout + result.stderr
    if result.returncode != 0 and "No matching distribution found for setuptools" in log:
        pytest.skip("no package index to install the build backend from")
    assert result.returncode == 0, log[-5000:]
    (path,) = dist.glob("wrt-*.whl")
    with zipfile.ZipFile(path) as wheel:
        yield Build(wheel, log)


def test_the_wheel_holds_the_default_scene_and_the_benchmark_suites(build):
    names = set(build.wheel.namelist())
    assert build.wheel.read("wrt/data/default_room.usda").startswith(b"#usda 1.0")
    for suite in ("quick", "cpu", "gpu"):
        assert json.loads(build.wheel.read(f"wrt/suites/{suite}.json"))["scenes"], suite
    sources = {p.relative_to(ROOT).as_posix() for p in (ROOT / "wrt").rglob("*.py")}
    assert sources <= names, sorted(sources - names)
    assert any(name.endswith(".dist-info/licenses/LICENSE") for name in names)  # the licence the metadata names


def test_the_build_backend_warns_of_nothing(build):
    """setuptools warned that a ``license`` table stops building on 2027-02-18; its warnings are errors to come."""
    warnings = [line.strip() for line in build.log.splitlines() if re.search(r"\w+Warning: ", line)]
    assert warnings == []


# A release of each dependency that lacks an API wrt calls, found by installing it: 'wrt render' then ended in an
# AttributeError traceback (usd-core 24.5 also lacks Usd.Stage.GetCompositionErrors; 25.5 and OpenEXR 3.3 work).
TOO_OLD = {
    "usd-core": ("25.2", "pxr.UsdGeom", "Camera.GetExposureFStopAttr"),
    "OpenEXR": ("3.2.3", "OpenEXR", "File"),
}


# The newest release of each dependency that reads files wrong, where wrt has no API to look for: found by installing
# it and running tests/test_texture_files.py. Pillow 12.0 (and 11.3, 11.0, 10.4, 10.0, 9.5) read a 1-bit grey PNG's
# tRNS sample as opaque; 11.0 and 10.4 refused a 16-bit RGB TIFF with a fourth sample; 10.0 and 9.5 raised 'cannot
# use transparency for this mode' on a 16-bit grey PNG with tRNS; 9.5 refused an int8 TIFF. 12.1.0 passes them all.
TOO_EARLY = {"pillow": "12.0.0"}


def _requirement(build, name: str):
    from packaging.requirements import Requirement

    (metadata,) = [n for n in build.wheel.namelist() if n.endswith(".dist-info/METADATA")]
    lines = build.wheel.read(metadata).decode().splitlines()
    requirements = [Requirement(line.split(":", 1)[1]) for line in lines if line.startswith("Requires-Dist:")]
    (requirement,) = [r for r in requirements if r.name == name]
    return requirement


@pytest.mark.parametrize("name", sorted(TOO_OLD))
def test_the_dependency_minimums_leave_out_releases_without_the_apis_wrt_calls(build, name):
    too_old, module, api = TOO_OLD[name]
    assert not _requirement(build, name).specifier.contains(too_old)
    found = importlib.import_module(module)
    for attribute in api.split("."):
        found = getattr(found, attribute)  # present in the release installed here


@pytest.mark.parametrize("name", sorted(TOO_EARLY))
def test_the_dependency_minimums_leave_out_releases_that_read_textures_wrong(build, name):
    assert not _requirement(build, name).specifier.contains(TOO_EARLY[name])
