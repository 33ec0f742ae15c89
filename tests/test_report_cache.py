"""The report's figure cache (``reports.figure_cache``): a build of the same report reuses the figures of the
previous one whose inputs did not change. Built from the fixture database (``report_fixture``), whose report
(``fixture_report``) is the previous build: a second build of the same rows draws nothing and writes the same
pages byte for byte; after one run's row changes, a third build draws exactly the charts that show that run, found
independently of the cache in the second build's pages (each chart's hover data names its runs)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.schema import setting_label
from foucault_bench.reports.build import ReportInputs, build_report
from foucault_bench.reports.figure_cache import BUILD_LOG, CACHE_FOLDER
from report_fixture import report_pages
from test_report_oracle_charts import page_charts


def _inputs(database: Path, runs: pd.DataFrame | None = None) -> ReportInputs:
    """The inputs ``report_fixture.build_fixture_report`` builds its report from (``runs``: in place of the
    database's rows)."""
    with ResultsStore(database, create=False) as store:
        stored, adequacy = store.frame(), store.adequacy()
    return ReportInputs(runs=stored if runs is None else runs, adequacy=adequacy,
                        provenance={"database": database.name}, jobs=2)


def _log(folder: Path) -> dict[str, list[str]]:
    return json.loads((folder / CACHE_FOLDER / BUILD_LOG).read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def rebuilt(fixture_database: Path, fixture_report: Path, tmp_path_factory) -> Path:
    """The fixture report built again from the same rows, in a new folder, with the fixture report as previous."""
    folder = tmp_path_factory.mktemp("rebuilt")
    build_report(_inputs(fixture_database), folder, previous=fixture_report)
    return folder


def test_a_second_build_of_unchanged_data_draws_nothing_and_writes_the_same_pages(fixture_report: Path,
                                                                                  rebuilt: Path) -> None:
    log = _log(rebuilt)
    assert log["drawn"] == [] and sorted(log["reused"]) == sorted(_log(fixture_report)["drawn"])
    assert len(log["reused"]) >= 20  # every chart of four scenes, adequacy: the check above ran on something
    pages = report_pages(fixture_report)
    assert [page.name for page in report_pages(rebuilt)] == [page.name for page in pages]
    for page in [*pages, fixture_report / "REPORT.md"]:
        assert (rebuilt / page.name).read_bytes() == page.read_bytes(), page.name
    static = sorted(path.relative_to(fixture_report) for path in (fixture_report / "figures").iterdir())
    assert static and sorted(path.relative_to(rebuilt) for path in (rebuilt / "figures").iterdir()) == static
    for name in static:  # the reused figures' PNG and SVG files came along
        assert (rebuilt / name).read_bytes() == (fixture_report / name).read_bytes(), name


def test_a_changed_row_redraws_exactly_the_charts_showing_that_run(fixture_database: Path, rebuilt: Path,
                                                                   tmp_path: Path) -> None:
    inputs = _inputs(fixture_database)
    runs = inputs.runs.copy()
    ok_fixed = runs[(runs["scene"] == "pantheon") & (runs["status"] == "ok") & runs["tol"].isna()
                    & runs["reference_error"].notna()]
    changed = ok_fixed.index[len(ok_fixed) // 2]
    runs.loc[changed, "reference_error"] *= 1.5
    run = runs.loc[changed]
    build_report(_inputs(fixture_database, runs), tmp_path, previous=rebuilt)
    # the oracle: the charts of the previous build whose points include this run (its scene's charts whose
    # hover data names its integrator and setting)
    setting = setting_label(run["kh"], run["tol"])
    showing = {stem.split("/")[-1] for stem, chart in page_charts(rebuilt).items()
               if chart.title.startswith(f"{run['scene']}:")
               and any(row[0] == run["integrator"] and row[2] == setting
                       for trace in chart.traces() for row in trace.get("customdata") or [])}
    assert {"convergence_pantheon", "work_precision_pantheon_reference_error"} <= showing
    assert "tolerance_pantheon" not in showing  # a fixed-step run: not on the adaptive integrators' chart
    log = _log(tmp_path)
    assert set(log["drawn"]) == showing
    assert len(log["drawn"]) + len(log["reused"]) == len(_log(rebuilt)["reused"])


def test_one_process_and_worker_processes_write_the_same_report(fixture_database: Path, tmp_path: Path) -> None:
    """With two jobs a report's charts and table files are made by worker processes, some while the sections are
    still being computed (``Builder.flush``); with one job everything is drawn and written in this process. On two
    of the fixture's scenes (of different models, one with diverged runs), both builds, nothing reused, write every
    page, ``REPORT.md`` and table file the same byte for byte."""
    with ResultsStore(fixture_database, create=False) as store:
        stored = store.frame()
    chosen = ["lab_3m", "pantheon"]
    runs = stored[stored["scene"].isin(chosen)]
    assert runs["model"].nunique() == 2 and (runs["status"] == "diverged").any()
    folders = {}
    for jobs in (2, 1):
        inputs = _inputs(fixture_database, runs)
        inputs.adequacy = inputs.adequacy[inputs.adequacy["scene"].isin(chosen)]
        inputs.jobs, inputs.static = jobs, False  # interactive charts only: the static files are drawn alike
        folders[jobs] = tmp_path / f"jobs_{jobs}"
        build_report(inputs, folders[jobs], previous=tmp_path / "none")
        assert _log(folders[jobs])["reused"] == [] and _log(folders[jobs])["drawn"]
    tables = sorted(path.relative_to(folders[2]) for path in (folders[2] / "tables").iterdir())
    assert sorted(path.relative_to(folders[1]) for path in (folders[1] / "tables").iterdir()) == tables
    expected = [*(page.relative_to(folders[2]) for page in report_pages(folders[2])), Path("REPORT.md"), *tables]
    assert len(expected) > 20
    for name in expected:
        assert (folders[1] / name).read_bytes() == (folders[2] / name).read_bytes(), name


def test_python_and_pyarrow_strings_write_the_same_report(fixture_database: Path, tmp_path: Path) -> None:
    """``foucault-bench report`` reads the results with pandas' text columns as Python strings (``write_report``:
    ``mode.string_storage``, for speed); pyarrow's strings, pandas' default, hold the same values. The whole fixture
    (four scenes of three models, one inline, failed and diverged runs, texts with ``|``, ``<`` and ``&``) built from
    each, nothing reused, writes every page, ``REPORT.md`` and table file the same byte for byte."""
    folders = {}
    for storage in ("pyarrow", "python"):
        with pd.option_context("mode.string_storage", storage):
            inputs = _inputs(fixture_database)
            assert inputs.runs["integrator"].array.dtype.storage == storage
            inputs.jobs, inputs.static = 2, False
            folders[storage] = tmp_path / storage
            build_report(inputs, folders[storage], previous=tmp_path / "none")
    tables = sorted(path.relative_to(folders["python"]) for path in (folders["python"] / "tables").iterdir())
    expected = [*(page.relative_to(folders["python"]) for page in report_pages(folders["python"])), Path("REPORT.md"),
                *tables]
    assert len(expected) > 20
    for name in expected:
        assert (folders["pyarrow"] / name).read_bytes() == (folders["python"] / name).read_bytes(), name
