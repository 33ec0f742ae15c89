"""Oracle tests of the report's first section, "Which method for my scene": per scene, the recommended
integrator and setting at each target reference error, recomputed here from the fixture database's rows
(independently of ``bench.verdicts.pareto``), and the scene's work-precision chart of the reference error placed
beside its table (the chart's points are checked by ``test_report_oracle_charts``)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.verdicts.pareto import DEFAULT_TARGETS
from test_report_oracle_tables import _database_rows, _number, _renderings


EMPTY = "–"
"""How both renderings show an empty cell."""


def _file_stem(scene: str) -> str:
    """The fixture's scene names are lower case with no dots or dashes: the report's file stem is the name."""
    assert re.fullmatch(r"[a-z0-9_]+", scene), scene
    return scene


def _expected(rows: pd.DataFrame, target: float) -> tuple[str, str, float, float, str, float]:
    """(integrator, setting, error, cost, runner-up, ratio) of the cheapest ok run with a finite CPU time > 0
    and |reference error| ≤ ``target``; the runner-up is the cheapest such run of another integrator; an empty
    cell (shown "–") where there is none."""
    error, cost = rows["reference_error"].abs(), rows["cpu_time_s"]
    met = rows[(rows["status"] == "ok") & np.isfinite(error) & np.isfinite(cost) & (cost > 0) & (error <= target)]
    if met.empty:
        return EMPTY, EMPTY, np.nan, np.nan, EMPTY, np.nan
    met = met.assign(abs_error=met["reference_error"].abs()).sort_values(["cpu_time_s", "abs_error"])
    best = met.iloc[0]
    others = met[met["integrator"] != best["integrator"]]
    runner_up, ratio = (EMPTY, np.nan) if others.empty else (
        others.iloc[0]["integrator"], others.iloc[0]["cpu_time_s"] / best["cpu_time_s"])
    return (best["integrator"], setting_label(best["kh"], best["tol"]), best["abs_error"], best["cpu_time_s"],
            runner_up, ratio)


def _approx(cell: str, value: float) -> bool:
    shown = _number(cell)
    return (np.isnan(shown) and np.isnan(value)) or shown == pytest.approx(value, rel=5e-3)


def test_each_scene_s_recommendation_is_the_cheapest_run_meeting_each_target(fixture_report: Path,
                                                                            fixture_database: Path) -> None:
    runs = _database_rows(fixture_database)
    page, markdown = _renderings(fixture_report)
    reached = 0
    for scene in sorted(runs["scene"].unique()):
        title = f"{scene}: recommended method per target reference error"
        for rendering in (page, markdown):
            table = rendering.table(title)
            assert [float(cell) for cell in table["target"]] == sorted(DEFAULT_TARGETS, reverse=True), scene
            for row in table.itertuples(index=False):
                integrator, setting, error, cost, runner_up, ratio = _expected(
                    runs[runs["scene"] == scene], float(row.target))
                assert row.outcome == ("reached" if integrator != EMPTY else "not reached"), (scene, row)
                assert (row.integrator, row.setting, row.runner_up) == (integrator, setting, runner_up), (scene, row)
                assert _approx(row.error, error) and _approx(row.cpu_time_s, cost) and _approx(row.ratio, ratio)
                reached += integrator != EMPTY
    assert reached > 0  # the fixture has targets that are met, and (see below) some that are not
    assert any(row.outcome == "not reached" for scene in runs["scene"].unique()
               for row in page.table(f"{scene}: recommended method per target reference error").itertuples())


def test_the_first_section_puts_each_scene_s_chart_beside_its_recommendation(fixture_report: Path,
                                                                             fixture_database: Path) -> None:
    runs = _database_rows(fixture_database)
    html = (fixture_report / "index.html").read_text(encoding="utf-8")
    first_section = html[html.index("<h2"):html.index("<h2", html.index("<h2") + 1)]
    assert ">Which method for my scene</h2>" in first_section
    pairs = re.findall(r"<div class='side-by-side'><div class='side-table'><p><strong>([^<]+)</strong>.*?"
                       r"<div class='side-chart'><figure id='[^']+' data-stem='([^']+)'>", first_section, re.S)
    assert pairs == [(f"{scene}: recommended method per target reference error",
                      f"figures/work_precision_{_file_stem(scene)}_reference_error")
                     for scene in sorted(runs["scene"].unique())]
    assert html.count("data-stem='figures/work_precision_") == len(set(re.findall(
        r"data-stem='(figures/work_precision_[^']+)'", html)))  # each chart once on the page
