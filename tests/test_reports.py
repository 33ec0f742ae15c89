"""The report builder (reports.build, reports.tables, reports.charts, reports.document) on a small results
fixture: every file is written, every table has a row per integrator, failed and diverged runs keep their
status, the derived numbers (matched accuracy, efficiency, fitted order) follow from the fixture's values."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.bench.verdicts.pareto import pareto_front
from foucault_bench.bench.studies import (
    LongTimeEnergyConfig,
    PrecessionLatitudeConfig,
    RoundoffConfig,
    StabilitySweepConfig,
    long_time_energy,
    precession_vs_latitude,
    roundoff_growth,
    stability_sweep,
)
from foucault_bench.reports import tables
from foucault_bench.reports.build import ReportInputs, build_report
from report_fixture import report_html, report_pages
from foucault_bench.bench.verdicts.pareto import DEFAULT_TARGETS

FIXED_STEP_ORDERS = {"rk4": 4, "verlet": 2, "explicit_euler": 1}
FAMILIES = {"rk4": "runge-kutta", "verlet": "verlet", "explicit_euler": "euler", "cvode_adams": "multistep",
            "heyoka_taylor": "taylor", "scipy_lsoda": "multistep"}
KH_SWEEP = (0.4, 0.2, 0.1, 0.05)
SCENES = ("lab", "pantheon")
FAILED_MESSAGE = "ValueError: fixture failure"
DIVERGED_MESSAGE = "diverged after 10 of 100 steps"


def _row(scene: str, integrator: str, **values: object) -> dict[str, object]:
    row: dict[str, object] = dict.fromkeys(COLUMN_NAMES, np.nan)
    row.update(run_key=f"{scene}-{integrator}-{values.get('kh', values.get('tol'))}", matrix_id="fixture",
               scene=scene, model="linear", integrator=integrator, family=FAMILIES[integrator], status="ok",
               message="", duration_s=60.0, n_out=601)
    row.update(values)
    error = row.get("reference_error")
    if row["status"] == "ok" and isinstance(error, float) and math.isfinite(error):
        row.update(energy_max_rel_error=0.1 * error)
        if scene == "lab":
            row.update(energy_drift_per_s=-1e-3 * error)  # the other scene has no precession or analytic verdicts: their charts are skipped
            row.update(precession_rate_ref_error=0.5 * error, precession_rate_error=0.5 * error + 1e-4,
                       analytic_gap_exact=error + 1e-7)
    return row


def results_fixture() -> pd.DataFrame:
    """Two scenes; fixed-step sweeps with error = 1e-2·hᵖ (explicit Euler diverged at the largest step),
    CVODE with one failed tolerance, heyoka, and scipy_lsoda that only failed."""
    rows = []
    for scene in SCENES:
        for integrator, order in FIXED_STEP_ORDERS.items():
            for kh in KH_SWEEP:
                step = 0.5 * kh
                if integrator == "explicit_euler" and kh == KH_SWEEP[0]:
                    rows.append(_row(scene, integrator, kh=kh, step_s=step, status="diverged",
                                     message=DIVERGED_MESSAGE, wall_time_s=1e-4, nfev=10))
                    continue
                rows.append(_row(scene, integrator, kh=kh, step_s=step, reference_error=1e-2 * step**order,
                                 wall_time_s=1e-3 / kh, nfev=int(1000 / kh)))
        for tol, wall in ((1e-6, 2e-3), (1e-9, 4e-3), (1e-12, np.nan)):
            if math.isnan(wall):
                rows.append(_row(scene, "cvode_adams", tol=tol, status="failed", message=FAILED_MESSAGE))
            else:
                rows.append(_row(scene, "cvode_adams", tol=tol, reference_error=10 * tol, wall_time_s=wall,
                                 nfev=int(-100 * math.log10(tol))))
        for tol, wall in ((1e-9, 1e-3), (1e-15, 2e-3)):
            rows.append(_row(scene, "heyoka_taylor", tol=tol, reference_error=tol, wall_time_s=wall, nfev=50))
        rows.append(_row(scene, "scipy_lsoda", tol=1e-8, status="failed", message=FAILED_MESSAGE))
    return pd.DataFrame(rows, columns=list(COLUMN_NAMES))


def adequacy_fixture() -> pd.DataFrame:
    return pd.DataFrame([
        {"scene": scene, "model": "spherical", "simpler_model": simpler, "scene_model": "spherical",
         "precession_rate_diff": diff, "trajectory_gap": gap, "expected_rate_diff": -7.5e-4,
         "expected_trajectory_gap": np.nan, "note": "fixture"}
        for scene in SCENES for simpler, diff, gap in (("linear", 7.5e-4, 1e-2), ("seed_planar", 8e-4, np.nan))
    ])


@pytest.fixture(scope="module")
def small_studies() -> dict[str, pd.DataFrame]:
    """The real study functions at tiny sizes: the report reads exactly the frames they produce."""
    return {
        "study_long_time_energy": long_time_energy(LongTimeEnergyConfig(
            duration_s=600.0, n_out=201, runs=(("explicit_euler", 0.2), ("verlet", 0.2), ("no_such_integrator", 0.1))),
            progress=False),
        "study_stability": stability_sweep(StabilitySweepConfig(steps=200, kh=(0.5, 2.5, 3.5)), progress=False),
        "study_precession_latitude": precession_vs_latitude(PrecessionLatitudeConfig(
            duration_s=300.0, n_latitudes=5, amplitude_m=1.0), progress=False),
        "study_long_time_roundoff": roundoff_growth(RoundoffConfig(integrators=("verlet", "implicit_midpoint"),
                                                                   max_decade=4, releases=2)),
    }


@pytest.fixture(scope="module")
def report(tmp_path_factory, small_studies) -> Path:
    folder = tmp_path_factory.mktemp("report")
    build_report(ReportInputs(runs=results_fixture(), studies=small_studies, adequacy=adequacy_fixture(),
                              provenance={"matrix id": "fixture"}), folder)
    return folder


def test_report_writes_every_file_it_links(report: Path) -> None:
    html = report_html(report)
    markdown = (report / "REPORT.md").read_text(encoding="utf-8")
    html_links = set(re.findall(r"(?:src|href)='([^'#]+)'", html))
    markdown_links = set(re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", markdown))
    pages = {page.name for page in report_pages(report)}
    assert html_links == markdown_links | {"plotly.min.js"} | pages  # same content, and the pages' bar
    assert {"index.html", "runs.html", "studies.html", "scene_lab.html", "scene_pantheon.html"} <= pages
    assert html.count("<script src='plotly.min.js'") == len(pages) - 1  # one file for all (runs.html: no chart)
    assert "cdn" not in html.lower() and "https://" not in html  # opens offline
    for link in html_links:
        assert (report / link).is_file(), link
    figures = {link for link in html_links if link.endswith(".png")}
    for figure in figures:
        assert (report / figure).with_suffix(".svg").is_file()
    expected_figures = {f"figures/work_precision_lab_{verdict}.png" for verdict in
                        ("reference_error", "energy_max_rel_error", "energy_drift_per_s", "precession_rate_ref_error",
                         "analytic_gap_exact")}
    expected_figures |= {f"figures/work_precision_pantheon_{verdict}.png"
                         for verdict in ("reference_error", "energy_max_rel_error")}
    expected_figures |= {f"figures/{kind}_{scene}.png" for scene in SCENES for kind in ("convergence", "tolerance")}
    expected_figures |= {"figures/study_long_time_energy.png", "figures/study_stability.png",
                         "figures/study_precession_latitude.png", "figures/model_adequacy.png"}
    assert expected_figures <= figures
    assert not any("work_precision_pantheon_analytic" in figure for figure in figures)
    assert "pantheon: no analytic gap values" in html
    for stem in ("matched_accuracy", "per_integrator", "pareto_fronts", "best_of_family", "scenes",
                 "convergence_orders", "runs_compact", "runs_full", "model_adequacy"):
        for suffix in ("csv", "md", "tex", "html"):
            assert (report / "tables" / f"{stem}.{suffix}").stat().st_size > 0, (stem, suffix)
    assert "\\begin{longtable}" in (report / "tables" / "per_integrator.tex").read_text(encoding="ascii")



def test_reports_readme_lists_the_report_s_sections_in_their_order(report: Path) -> None:
    """The table of what the report contains, in order (reports/README.md, section `foucault-bench report`): every
    top-level section of ``REPORT.md`` has a row, and the rows of the sections this report has come in the
    report's order (a scene's page is the row "Scene NAME"; "Per scene", the links to those pages, belongs to the
    Overview's row)."""
    readme = (Path(__file__).resolve().parents[1] / "reports" / "README.md").read_text(encoding="utf-8")
    table = readme[readme.index("| section | what | from |"):].split("\n\n")[0].splitlines()[2:]
    documented = [row.split("|")[1].strip() for row in table]
    headings = [line[3:] for line in (report / "REPORT.md").read_text(encoding="utf-8").splitlines()
                if line.startswith("## ")]
    named = ["Scene NAME (one page per scene)" if heading.startswith("Scene ") else
             "Overview" if heading == "Per scene" else heading for heading in headings]
    in_order = [name for index, name in enumerate(named) if index == 0 or name != named[index - 1]]
    assert set(in_order) <= set(documented), f"sections without a row: {sorted(set(in_order) - set(documented))}"
    assert [name for name in documented if name in in_order] == in_order

def test_png_figures_are_real_images(report: Path) -> None:
    from matplotlib.image import imread

    image = imread(report / "figures" / "work_precision_lab_reference_error.png")
    assert image.shape[0] > 300 and image.shape[1] > 600
    assert np.std(image) > 0.01  # not a blank canvas


def test_every_table_has_a_row_per_integrator_and_scene() -> None:
    runs = results_fixture()
    present = set(zip(runs["scene"], runs["integrator"], strict=True))
    for table in (tables.per_integrator(runs), tables.convergence_orders(runs)):
        assert set(zip(table["scene"], table["integrator"], strict=True)) == present
        assert len(table) == len(present)
    assert len(tables.compact_table(runs)) == len(tables.full_table(runs)) == len(runs)
    assert list(tables.full_table(runs).columns) == list(COLUMN_NAMES)


def test_failed_and_diverged_runs_appear_with_their_status(report: Path) -> None:
    runs = results_fixture()
    summary = tables.per_integrator(runs).set_index(["scene", "integrator"])
    only_failed = summary.loc[("lab", "scipy_lsoda")]
    assert only_failed["outcome"] == "no ok run (failed)"
    assert (only_failed["failed"], only_failed["ok"]) == (1, 0)
    assert only_failed["note"] == FAILED_MESSAGE
    assert summary.loc[("lab", "cvode_adams"), "failed"] == 1
    assert summary.loc[("lab", "explicit_euler"), "diverged"] == 1
    assert summary.loc[("lab", "explicit_euler"), "note"] == DIVERGED_MESSAGE
    compact = pd.read_csv(report / "tables" / "runs_compact.csv")
    failed = compact[compact["integrator"] == "scipy_lsoda"]
    assert set(failed["status"]) == {"failed"} and set(failed["message"]) == {FAILED_MESSAGE}
    assert (compact["status"] == "diverged").sum() == len(SCENES)
    markdown = (report / "REPORT.md").read_text(encoding="utf-8")
    assert "no ok run (failed)" in markdown and FAILED_MESSAGE in markdown


def test_matched_accuracy_takes_the_cheapest_setting_that_reaches_the_target() -> None:
    runs = results_fixture()
    summary = tables.per_integrator(runs, target=1e-6).set_index(["scene", "integrator"])
    # rk4: error 1e-2·(kh/2)⁴ ≤ 1e-6 for kh ≤ 0.2 (6.25e-7·... ) and wall time 1e-3/kh: the largest such kh wins
    rk4_ok = runs[(runs["integrator"] == "rk4") & (runs["scene"] == "lab") & (runs["reference_error"] <= 1e-6)]
    cheapest = rk4_ok.loc[rk4_ok["wall_time_s"].idxmin()]
    row = summary.loc[("lab", "rk4")]
    assert row["outcome"] == "reached"
    assert row["wall_time_s"] == cheapest["wall_time_s"] and row["reference_error"] == cheapest["reference_error"]
    # explicit Euler's best error is 1e-2 × 0.025 = 2.5e-4 > 1e-6
    assert summary.loc[("lab", "explicit_euler"), "outcome"] == "not reached"
    assert summary.loc[("lab", "explicit_euler"), "reference_error"] == pytest.approx(1e-2 * 0.025)


def test_matched_accuracy_summary_names_winner_runner_up_and_ratio(report: Path) -> None:
    runs = results_fixture()
    summary = tables.matched_accuracy(runs, (1e-3, 1e-6, 1e-9)).set_index(["scene", "target"])
    lab = runs[(runs["scene"] == "lab") & (runs["status"] == "ok")]
    for target in (1e-3, 1e-6, 1e-9):
        met = lab[lab["reference_error"] <= target].sort_values("wall_time_s")
        row = summary.loc[("lab", target)]
        assert (row["integrator"], row["wall_time_s"]) == (met["integrator"].iloc[0], met["wall_time_s"].iloc[0])
        others = met[met["integrator"] != row["integrator"]]
        if others.empty:
            assert pd.isna(row["runner_up"]) and pd.isna(row["ratio"])
            continue
        assert row["runner_up"] == others["integrator"].iloc[0]
        assert row["ratio"] == pytest.approx(others["wall_time_s"].iloc[0] / met["wall_time_s"].iloc[0])
    shown = pd.read_csv(report / "tables" / "matched_accuracy.csv")
    assert set(shown["target"]) == set(DEFAULT_TARGETS)


def test_fitted_orders_recover_the_fixture_orders() -> None:
    orders = tables.convergence_orders(results_fixture()).set_index(["scene", "integrator"])
    for integrator, order in FIXED_STEP_ORDERS.items():
        assert orders.loc[("lab", integrator), "fitted_order"] == pytest.approx(order, abs=1e-9)
        assert orders.loc[("lab", integrator), "declared_order"] == order
    assert orders.loc[("lab", "heyoka_taylor"), "kind"] == "adaptive"
    assert math.isnan(orders.loc[("lab", "heyoka_taylor"), "fitted_order"])


def test_report_refuses_results_without_the_schema_columns(tmp_path: Path) -> None:
    from foucault_bench.bench.errors import InputError

    with pytest.raises(InputError, match="reference_error"):
        build_report(ReportInputs(runs=results_fixture().drop(columns=["reference_error"])),
                     tmp_path)


def test_report_command_reads_the_results_database(tmp_path: Path) -> None:
    from foucault_bench.bench.cli import main as cli_main
    from foucault_bench.bench.run.matrix import Matrix
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.run.timing import TimingPolicy

    database = tmp_path / "results.sqlite"
    matrix = Matrix(name="fixture", description="report test", source="tests/test_reports.py", scenes=(), runs=(),
                    plugins=(), timing=TimingPolicy())
    with ResultsStore(database) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        runs = results_fixture()
        runs = runs[(runs["scene"] == "lab") & runs["integrator"].isin(["rk4", "scipy_lsoda"])]
        for row in runs.to_dict("records"):
            store.write_run({**row, "matrix_id": matrix_id})
        store.write_adequacy(matrix_id, "lab", adequacy_fixture().query("scene == 'lab'").drop(columns="scene")
                             .to_dict("records"))
        store.finish_matrix_run(matrix_id)
    out = tmp_path / "report"
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip"]) == 0
    markdown = (out / "REPORT.md").read_text(encoding="utf-8")
    assert matrix_id in markdown and "no ok run (failed)" in markdown
    compact = pd.read_csv(out / "tables" / "runs_compact.csv")
    assert len(compact) == len(runs) and set(compact["integrator"]) == {"rk4", "scipy_lsoda"}
    # without --static: no static files, and REPORT.md links each chart to its figure in index.html
    assert not list(out.glob("figures/*"))
    html = report_html(out)
    linked = re.findall(r"\(interactive chart in \[([^]]+)\]\(\1#([^)]+)\)", markdown)
    figure_ids = re.findall(r"<figure id='([^']+)'[^>]*><div class='chart'", html)
    assert [figure for _, figure in linked] == figure_ids and ("index.html", "figure-model_adequacy") in linked
    for page, figure in linked:  # each link names the page holding that chart
        assert f"<figure id='{figure}'" in (out / page).read_text(encoding="utf-8"), (page, figure)
    assert "(static:" not in html
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip", "--static",
                     "--jobs", "1"]) == 0
    static = (out / "REPORT.md").read_text(encoding="utf-8")
    shown = re.findall(r"!\[[^]]*\]\((figures/[^)]+)\.png\)", static)
    assert [f"figure-{stem.split('/')[-1]}" for stem in shown] == figure_ids
    assert all((out / f"{stem}.png").is_file() and (out / f"{stem}.svg").is_file() for stem in shown)


def test_report_command_without_a_database_is_a_clear_error(tmp_path: Path, capsys) -> None:
    from foucault_bench.bench.cli import main as cli_main

    assert cli_main(["report", "--db", str(tmp_path / "missing.sqlite"), "--out", str(tmp_path / "r")]) == 2
    assert "no results database" in capsys.readouterr().err


def test_a_scene_where_every_run_failed_still_draws_and_tabulates(tmp_path: Path) -> None:
    from foucault_bench.reports import charts

    runs = results_fixture()
    failed = runs[(runs["scene"] == "lab") & (runs["integrator"] == "scipy_lsoda")]
    stem = charts.work_precision(failed, "reference_error", pareto_front(failed), tmp_path / "all_failed")
    assert stem.with_suffix(".png").stat().st_size > 0 and stem.with_suffix(".svg").stat().st_size > 0
    summary = tables.per_integrator(failed)
    assert list(summary["outcome"]) == ["no ok run (failed)"] and list(summary["failed"]) == [1]
    assert list(tables.matched_accuracy(failed)["outcome"]) == ["not reached"] * len(DEFAULT_TARGETS)


def test_the_report_says_how_each_family_s_cost_was_measured() -> None:
    from foucault_bench.reports.result_sections import cost_basis_sentences

    runs = pd.DataFrame({"family": ["runge-kutta", "runge-kutta", "multistep"],
                         "integrator": ["dopri5", "scipy_rk45", "cvode_bdf_py"]})
    text = cost_basis_sentences(runs)
    assert "Family runge-kutta: dopri5: compiled" in text and "scipy_rk45: Python-driven" in text
    assert "Family multistep: cvode_bdf_py: Python-driven" in text


def test_a_database_where_every_run_timed_out_is_reported_and_advised_on(tmp_path: Path, capsys) -> None:
    """Every run of the matrix timed out, so every verdict column is NULL in the database: the report says so
    (each integrator's row counts its timeouts) and ``advise`` says no run meets the target (exit status 1),
    instead of a traceback (the columns once came back as Python ``None`` objects, and ``abs`` of one raised)."""
    from foucault_bench.bench.cli import main as cli_main
    from foucault_bench.bench.problems.scene_key import scene_key
    from foucault_bench.bench.problems.scenes import SCENES
    from foucault_bench.bench.run.matrix import Matrix
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.bench.run.timing import TimingPolicy

    scene = SCENES["seed_2min"]
    database = tmp_path / "timeouts.sqlite"
    matrix = Matrix(name="timeouts", description="", source="test", scenes=(), runs=(), plugins=(),
                    timing=TimingPolicy())
    with ResultsStore(database) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for number, (integrator, family, kh, tol) in enumerate((("rk4", "runge-kutta", 0.1, None),
                                                                ("dopri5", "runge-kutta", None, 1e-8))):
            row = dict.fromkeys(COLUMN_NAMES)
            row.update(run_key=f"k{number}", matrix_id=matrix_id, scene=scene.name, scene_key=scene_key(scene),
                       model=scene.model, integrator=integrator, family=family, kh=kh, tol=tol,
                       duration_s=scene.duration_s, n_out=scene.n_intervals + 1, status="timeout",
                       message="run timed out after 1e-06 s (--run-timeout)")
            store.write_run(row)
        store.finish_matrix_run(matrix_id)
    assert cli_main(["advise", "--db", str(database), "--scene", scene.name, "--target", "reference_error=1e-3",
                     "--no-search"]) == 1  # the exit status of "no run meets the target"
    answer = capsys.readouterr().out
    assert "no run meets the target" in answer and "from 2 stored runs of seed_2min; 0 meet the target" in answer
    out = tmp_path / "report"
    assert cli_main(["report", "--db", str(database), "--out", str(out), "--studies", "skip"]) == 0
    per_integrator = pd.read_csv(out / "tables" / "per_integrator.csv")
    assert sorted(per_integrator["integrator"]) == ["dopri5", "rk4"]
    assert set(per_integrator["timeout"]) == {1}, per_integrator
