"""The wheel built from the repository: one top-level package, ``foucault_bench``, holding every file of the
four package folders (sources and the data files commands read: matrices, scenes, thresholds, loops.c, the docs that
generated output and ``--help`` cite)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_FOLDERS = ("bench", "models", "integrators", "reports")
"""Repository folders installed as ``foucault_bench.<folder>`` (pyproject.toml ``package-dir``)."""
SKIPPED = ("__pycache__", ".pyc")


def _source_files() -> set[str]:
    """Every file of the package folders as the wheel should hold it (``foucault_bench/<folder>/...``)."""
    found = set()
    for folder in PACKAGE_FOLDERS:
        for path in (ROOT / folder).rglob("*"):
            relative = path.relative_to(ROOT).as_posix()
            if path.is_file() and not any(part in relative for part in SKIPPED):
                found.add(f"foucault_bench/{relative}")
    return found


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    """``pip wheel --no-deps`` of a copy of the repository (the build writes build/ and egg-info in its tree)."""
    if not (ROOT / "pyproject.toml").is_file():
        pytest.skip("not run from a source checkout")
    scratch = tmp_path_factory.mktemp("wheel")
    source = scratch / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".git", ".venv*", "results", "build", "*.egg-info", "__pycache__", ".pytest_cache", "*.sqlite"))
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(scratch / "dist"),
                            str(source)], capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stderr[-2000:]
    (path,) = (scratch / "dist").glob("foucault_bench-*.whl")
    return zipfile.ZipFile(path)


def test_the_wheel_holds_one_top_level_package_and_its_metadata(wheel):
    top_level = {name.split("/", 1)[0] for name in wheel.namelist()}
    (dist_info,) = [name for name in top_level if name.endswith(".dist-info")]
    assert top_level == {"foucault_bench", dist_info}
    assert wheel.read(f"{dist_info}/top_level.txt").decode().split() == ["foucault_bench"]


def test_the_wheel_holds_every_file_of_the_package_folders(wheel):
    shipped = {name for name in wheel.namelist() if name.startswith("foucault_bench/")}
    missing = sorted(_source_files() - shipped)
    assert not missing, f"not in the wheel (add them to pyproject.toml package-data or packages): {missing}"
    for data_file in ("bench/perf/loops.c", "bench/matrices/quick.toml", "bench/scenes/builtin.toml",
                      "bench/thresholds/default.toml"):
        assert f"foucault_bench/{data_file}" in shipped


def test_the_wheel_holds_every_built_in_scene_file_as_it_is(wheel):
    """Every ``bench/scenes/*.toml`` (each read at import as built-in scenes, a file added later included) ships
    byte for byte, so an installed package has the scenes of the checkout."""
    scene_files = sorted((ROOT / "bench" / "scenes").glob("*.toml"))
    assert scene_files, "bench/scenes/ holds no scene file"
    for path in scene_files:
        assert wheel.read(f"foucault_bench/bench/scenes/{path.name}") == path.read_bytes(), path.name
