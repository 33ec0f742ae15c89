"""File names and anchors made from scene names (reports.build.file_stem): unique and safe for every valid
scene name, so scenes like ``seed_v1.5`` and ``seed_v1.6`` never overwrite each other's figures."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pandas as pd

from foucault_bench.bench.problems.scenes import SCENE_NAME_PATTERN, SCENES
from foucault_bench.reports.build import ReportInputs, build_report, file_stem
from report_fixture import report_html, report_pages
from test_reports import results_fixture

SAFE = re.compile(r"^[a-z0-9_-]+$")


def test_file_stems_are_safe_and_one_to_one() -> None:
    alphabet = "aZ0_.-"
    names = ["".join(letters) for size in range(1, 5) for letters in itertools.product(alphabet, repeat=size)]
    names += ["seed_v1.5", "seed_v1.6", "seed_v1_5", "Lab", "lab", "a.b.c", "a-_b", "a._b"]
    assert all(SCENE_NAME_PATTERN.match(name) for name in names)
    stems = [file_stem(name) for name in names]
    assert all(SAFE.match(stem) for stem in stems)  # no dot (suffix), no upper case (case-insensitive disks)
    assert len(set(stems)) == len(set(names))
    assert all(file_stem(name) == name for name in SCENES)  # built-in scenes keep their names


def test_scenes_with_dots_get_their_own_figures_and_links(tmp_path: Path) -> None:
    runs = results_fixture()
    runs = runs[runs["integrator"].isin(["rk4", "heyoka_taylor"])]
    runs = runs.assign(**{column: float("nan") for column in ("energy_max_rel_error", "energy_drift_per_s",
                                                             "precession_rate_ref_error", "analytic_gap_exact")})
    renamed = []
    for name in ("seed_v1.5", "seed_v1.6", "seed_v1_5"):
        part = runs[runs["scene"] == "lab"].copy()
        part["scene"] = name
        renamed.append(part)
    build_report(ReportInputs(runs=pd.concat(renamed, ignore_index=True), interactive=False),
                 tmp_path)
    html = report_html(tmp_path)
    figures = sorted(set(re.findall(r"src='(figures/[^']+\.png)'", html)))
    for link in figures:
        assert (tmp_path / link).is_file(), link
    for name in ("seed_v1.5", "seed_v1.6", "seed_v1_5"):
        assert f"figures/convergence_{file_stem(name)}.png" in figures
    assert len(list((tmp_path / "figures").glob("convergence_*.png"))) == 3
    for page in report_pages(tmp_path):  # an anchor is unique in its page
        anchors = re.findall(r"id='([^']+)'", page.read_text(encoding="utf-8"))
        assert len(anchors) == len(set(anchors)), page


def test_report_targets_must_be_positive(tmp_path: Path, capsys) -> None:
    from foucault_bench.bench.cli import main as cli_main

    assert cli_main(["report", "--db", str(tmp_path / "none.sqlite"), "--out", str(tmp_path / "r"),
                     "--targets", "1e-6", "0", "-1"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2 and all("--targets" in line for line in lines)
