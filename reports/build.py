"""``foucault-bench report``: build the report folder (index.html, REPORT.md, figures, tables) from results.

    foucault-bench report [--db PATH] [--matrix-id ID] [--out DIR] [--studies {stored,recompute,skip}]

The folder opens in a browser with no server: index.html and REPORT.md hold the same blocks
(``reports.document``), figures are PNG + SVG files under ``figures/``, tables are embedded and written under
``tables/`` as CSV, Markdown, LaTeX and HTML. The study tables (``reports.studies``) are read from the database
and computed (then stored) when missing, or recomputed with ``--studies recompute``; ``--studies skip`` leaves
their sections out. The seed note's figures (``reports.seed``) are a section of the report.

``build_report`` works from plain data (a DataFrame with the ``bench.schema`` columns), so it is tested on a
small fixture without a database.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pandas as pd
from tqdm import tqdm

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.reports.studies import STUDIES, ensure_studies
from foucault_bench.integrators import STATUS_OK
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S
from foucault_bench.reports import charts, tables
from foucault_bench.reports.document import Block, Figure, Heading, Paragraph, Table, write_document, write_table_files
from foucault_bench.reports.seed import seed_blocks

FIGURES = "figures"
TABLES = "tables"


@dataclass
class ReportInputs:
    """Everything a report is made of, as plain data.

    Attributes:
        runs: results rows (columns of ``bench.schema``).
        studies: study name (``reports.studies.STUDIES``) → its table; missing names leave their section out.
        adequacy: rows of the ``adequacy`` table (scene, model, simpler_model, precession_rate_diff,
            trajectory_gap, note), possibly empty.
        provenance: label → value lines shown at the top (matrix id, host, commit, ...).
        include_seed: add the seed-revisited section (computes the seed study, a few seconds).
    """

    runs: pd.DataFrame
    studies: dict[str, pd.DataFrame] = field(default_factory=dict)
    adequacy: pd.DataFrame = field(default_factory=pd.DataFrame)
    provenance: dict[str, str] = field(default_factory=dict)
    include_seed: bool = True


class _Builder:
    """Collects blocks while writing the figures and tables they point to."""

    def __init__(self, folder: Path, progress: bool):
        self.folder = folder
        self.blocks: list[Block] = []
        self.progress = tqdm(desc="report figures", unit="figure", disable=not progress, leave=False)

    def add(self, *blocks: Block) -> None:
        self.blocks.extend(blocks)

    def figure(self, draw: Callable[..., Path], name: str, caption: str, *data: object) -> None:
        draw(*data, self.folder / FIGURES / name)
        self.progress.update()
        self.add(Figure(f"{FIGURES}/{name}", caption))

    def table(self, frame: pd.DataFrame, name: str, title: str, notes: dict[str, str] | None = None) -> None:
        shown = write_table_files(frame, self.folder, f"{TABLES}/{name}", title, tables.INTEGER_COLUMNS)
        self.add(Table(title, shown, f"{TABLES}/{name}", tables.notes_for(frame, notes)))


# --------------------------------------------------------------------------------------------------------------
# sections
# --------------------------------------------------------------------------------------------------------------
def _overview(builder: _Builder, inputs: ReportInputs) -> None:
    runs = inputs.runs
    counts = runs["status"].value_counts()
    builder.add(Heading("Overview"))
    if inputs.provenance:
        builder.add(Paragraph("; ".join(f"**{k}**: {v}" for k, v in inputs.provenance.items())))
    builder.add(Paragraph(
        f"{len(runs)} runs: {', '.join(f'{int(counts.get(status, 0))} {status}' for status in tables.STATUSES)}. "
        f"Scenes: {', '.join(sorted(runs['scene'].unique()))}. "
        f"Integrators: {', '.join(sorted(runs['integrator'].unique()))}."))
    builder.add(Paragraph(
        "How to read the charts: colour = integrator family (the same in every chart), marker and line pattern = "
        "integrator within its family, solid-type lines = fixed-step sweeps (k·h), dashed-type lines = tolerance "
        "sweeps. Runs that diverged (▲) or "
        "failed (✕) are drawn on the top edge of the axes at their cost (left edge when the cost is unknown); "
        "an ok run without a finite positive value is drawn on the bottom edge (▽). Errors are dimensionless: "
        "positions relative to the amplitude A, energies relative to the swing's energy, precession rates "
        "relative to Ω_E|sin φ|. Frame x South, y East, z Up; latitude φ north positive; rates "
        "counter-clockwise about up positive (the textbook rate is −Ω_E sin φ)."))


def _summary_tables(builder: _Builder, runs: pd.DataFrame) -> None:
    builder.add(Heading("Summary at matched accuracy"), Paragraph(
        f"For each scene and integrator, the cheapest setting (least median wall time) whose reference error "
        f"reaches {tables.MATCHED_ACCURACY_TARGET:g} (max |r − r_ref| / A over the output grid), its cost, or "
        "'not reached'. The counts show every diverged and failed run."))
    builder.table(tables.matched_accuracy(runs), "matched_accuracy",
                  f"Cheapest setting reaching reference error ≤ {tables.MATCHED_ACCURACY_TARGET:g}")
    builder.add(Heading("Shootout"), Paragraph(
        "Per scene, integrators ranked by their best efficiency 1 / (reference error × wall time) over their "
        "settings (higher is better; wall time is the median of the timed repeats, compile time excluded). "
        "Integrators with no ok run are listed last with their counts."))
    builder.table(tables.shootout(runs), "shootout", "Shootout: efficiency ranking per scene")


def _work_precision(builder: _Builder, runs: pd.DataFrame) -> None:
    builder.add(Heading("Work-precision"), Paragraph(
        "Each verdict against the two costs, wall time and right-hand-side evaluations, one line per integrator. "
        "The energy error is the largest deviation over the run; the energy drift its least-squares trend, "
        "which tells a drifting integrator from one whose error oscillates within a bound. "
        "The precession-rate error is the integrator's own: measured rate against the reference solution's rate "
        "on the same grid. The analytic gap is the distance from the exact solution of the linear model, a model "
        "error for the other models."))
    for scene, scene_runs in runs.groupby("scene", sort=True):
        builder.add(Heading(f"Scene {scene}", level=3))
        for verdict, (title, label) in charts.VERDICT_LABELS.items():
            if not scene_runs[verdict].notna().any() and (scene_runs["status"] == STATUS_OK).any():
                builder.add(Paragraph(f"{scene}: no {title} values in the results ({verdict} is empty)."))
                continue
            builder.figure(charts.work_precision, f"work_precision_{scene}_{verdict}",
                           f"{scene}: {title} ({label}) against wall time and right-hand-side evaluations.",
                           scene_runs, verdict)


def _convergence(builder: _Builder, runs: pd.DataFrame) -> None:
    orders = tables.convergence_orders(runs)
    builder.add(Heading("Convergence"), Paragraph(
        "Reference error against step size for the fixed-step integrators; the fitted order "
        "(bench.verdicts.convergence.observed_order: least-squares slope over the finest steps, after dropping saturated "
        "errors above 0.1 and round-off-dominated points) is in the legend and in the table next to the "
        "declared order."))
    builder.table(orders, "convergence_orders", "Observed and declared orders of convergence")
    for scene, scene_runs in runs.groupby("scene", sort=True):
        if scene_runs["tol"].isna().any():
            builder.figure(charts.convergence, f"convergence_{scene}",
                           f"{scene}: reference error against step size, fitted order in the legend.",
                           scene_runs, tables.orders_by_integrator(orders, scene))


def _studies(builder: _Builder, studies: dict[str, pd.DataFrame]) -> None:
    energy = studies.get("study_long_time_energy")
    if energy is not None:
        first = energy.iloc[0]
        builder.add(Heading("Long-time energy"), Paragraph(
            f"Relative energy error (E − E₀)/E_swing against time over {first['config_duration_s'] / 3600:g} h, "
            "one representative per family (study `study_long_time_energy`, reports.studies.long_time_energy). "
            "Expected: explicit Euler grows as (1 + (kh)²)ⁿ until it diverges, RK4 drifts linearly, Verlet stays "
            "bounded near (kh)²/4, CVODE and heyoka stay near round-off at tight tolerances. "
            f"Values below {charts.LOG_FLOOR:g} (exact zeros included) are drawn at {charts.LOG_FLOOR:g}."))
        builder.figure(charts.long_time_energy, "study_long_time_energy",
                       "Relative energy error against time (log-log), per integrator family.", energy)
        builder.table(tables.long_time_summary(energy), "study_long_time_energy_summary",
                      "Long-time energy: error after the first hour and at the end")
    stability = studies.get("study_stability")
    if stability is not None:
        builder.add(Heading("Stability"), Paragraph(
            f"Every fixed-step integrator on the linear model at each k·h, without Earth's rotation and with it "
            f"(study `study_stability`): the max relative energy error over a run of "
            f"{int(stability['config_steps'].iloc[0])} steps, and the growth per step of the scheme's own one-step "
            "map (max |λ| − 1), from which the measured limit is bisected. The dashed line is the limit each "
            "integrator declares on the undamped oscillator (`stability_limit_kh`); a method whose declared limit "
            "holds only without rotation declares its growth law with rotation, drawn against the measurement "
            "in the second chart. At exactly kh = 2 Verlet's and symplectic Euler's oscillator matrices have the "
            "double eigenvalue −1: the amplitude grows linearly rather than exponentially, which is why the "
            "curves dip or end there."))
        builder.figure(charts.stability, "study_stability",
                       "Energy error against k·h across each fixed-step integrator's stability limit, without "
                       "rotation (solid) and with it (dashed); triangles mark the measured limits.", stability)
        builder.figure(charts.rotation_growth, "study_stability_rotation_growth",
                       "Growth per step with Earth's rotation: measured one-step growth against the declared law.",
                       stability)
        builder.table(tables.stability_summary(stability), "study_stability_summary",
                      "Stability: declared and measured limits, first divergence, growth with rotation")
    precession = studies.get("study_precession_latitude")
    if precession is not None:
        residual = (precession["rate_rad_s"] - precession["airy_rate_rad_s"]).abs().max() / SIDEREAL_EARTH_RATE_RAD_S
        first = precession.iloc[0]
        builder.add(Heading("Precession against latitude"), Paragraph(
            f"Measured precession rate at {len(precession)} latitudes ({first['config_model']} model, one heyoka "
            "Taylor batch integrator, one batch element per latitude; study `study_precession_latitude`) against "
            "the textbook −Ω_E sin φ. The residual follows the Airy correction (3/8)θ₀² of the finite swing "
            f"(θ₀ = A/L = {first['config_amplitude_m'] / first['config_length_m']:.3g}); the largest distance from "
            f"it is {residual:.2g} Ω_E (release-side terms, PHYSICS.md 'Airy precession')."))
        builder.figure(charts.precession_latitude, "study_precession_latitude",
                       "Precession rate against latitude; residual from −Ω_E sin φ in units of Ω_E.", precession)

    azimuth = studies.get("study_release_azimuth")
    if azimuth is not None:
        first = azimuth.iloc[0]
        builder.add(Heading("Precession error against the release direction"), Paragraph(
            f"Each structure-preserving integrator at kh = {first['kh']:g} on the {first['config_model']} model, "
            f"released at azimuths from South (0°, a North-South swing) to North, at "
            f"{', '.join(f'{lat:g}°' for lat in sorted(azimuth['latitude_deg'].unique(), reverse=True))} "
            "(study `study_release_azimuth`); the error is the rate's distance from heyoka's at "
            f"tol = {first['config_reference_tol']:g} on the same grid, relative to Ω_E so that latitudes compare. "
            "Verlet's error depends on the direction: a North-South swing feels the horizontal part of ω along "
            "its own line, which an East-West release (every real scene's) hides. The implicit midpoint rule is "
            "isotropic but slow by (kh)²/4 of the local rate: its Cayley map shortens both circular modes' "
            "frequencies, and their difference is the precession."))
        builder.figure(charts.release_azimuth, "study_release_azimuth",
                       "Precession-rate error relative to Ω_E against the release azimuth, per latitude.", azimuth)


def _adequacy(builder: _Builder, adequacy: pd.DataFrame) -> None:
    builder.add(Heading("Model adequacy"))
    if adequacy.empty:
        builder.add(Paragraph("The database holds no `adequacy` rows for this matrix run."))
        return
    builder.add(Paragraph(
        "Per scene, what each simpler model gets wrong compared with the scene's model "
        "(bench.problems.adequacy.model_adequacy)."))
    builder.figure(charts.adequacy, "model_adequacy", "Model adequacy per scene (log scale).", adequacy)
    builder.table(adequacy, "model_adequacy", "Model adequacy per scene", tables.ADEQUACY_NOTES)


def _all_runs(builder: _Builder, runs: pd.DataFrame) -> None:
    builder.add(Heading("All runs"), Paragraph(
        "One row per run with the main columns; the linked files of the second table hold every column of "
        "foucault_bench.bench.schema."))
    builder.table(tables.compact_table(runs), "runs_compact", "All runs (main columns)")
    full = tables.full_table(runs)
    write_table_files(full, builder.folder, f"{TABLES}/runs_full", "All runs, every column", tables.INTEGER_COLUMNS)
    builder.add(Paragraph(f"Every column: `{TABLES}/runs_full.csv`, `.md`, `.tex`, `.html`."))


def build_report(inputs: ReportInputs, folder: Path, title: str = "foucault-bench report",
                 progress: bool = False) -> tuple[Path, Path]:
    """Write the report folder from plain data; return the paths of index.html and REPORT.md. ``progress``
    shows a counter of the figures drawn (on stderr)."""
    missing = [name for name in COLUMN_NAMES if name not in inputs.runs.columns]
    if missing:
        raise InputError(f"results lack the columns {', '.join(missing)} (see bench/schema.py)")
    if inputs.runs.empty:
        raise InputError("no runs to report on")
    builder = _Builder(folder, progress)
    _overview(builder, inputs)
    _summary_tables(builder, inputs.runs)
    _work_precision(builder, inputs.runs)
    _convergence(builder, inputs.runs)
    _studies(builder, inputs.studies)
    _adequacy(builder, inputs.adequacy)
    if inputs.include_seed:
        builder.add(*seed_blocks(folder, "seed"))
    _all_runs(builder, inputs.runs)
    builder.progress.close()
    return write_document(folder, title, builder.blocks)


# --------------------------------------------------------------------------------------------------------------
# the command (its options: bench.commands.report)
# --------------------------------------------------------------------------------------------------------------
def _provenance(store: ResultsStore, matrix_id: str) -> dict[str, str]:
    runs = store.matrix_runs()
    row = runs[runs["matrix_id"] == matrix_id]
    if row.empty:
        return {"matrix id": matrix_id}
    record = row.iloc[0]
    labels = {"matrix_id": "matrix id", "matrix_name": "matrix", "status": "status", "started_utc": "started (UTC)",
              "finished_utc": "finished (UTC)", "git_commit": "git commit", "code_version": "code version",
              "host": "host", "cpu_model": "CPU", "jobs": "jobs"}
    return {label: str(record[key]) for key, label in labels.items() if key in record and pd.notna(record[key])}


def write_report(db: Path, matrix_id: str | None, out: Path, studies: str = "stored") -> int:
    """``foucault-bench report``: the report of matrix run ``matrix_id`` (``None``: the latest) of database
    ``db`` written to folder ``out``; ``studies`` is ``stored``, ``recompute`` or ``skip``. Exit status 0."""
    started = time.perf_counter()
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is not a folder")
    with ResultsStore(db, create=False) as store:
        matrix_id = store.resolve_matrix_id(matrix_id)
        runs = store.frame(matrix_id)
        if runs.empty:
            raise InputError(f"matrix run {matrix_id} in {db} has no stored runs")
        study_tables = {} if studies == "skip" else ensure_studies(store, recompute=studies == "recompute")
        inputs = ReportInputs(runs=runs, studies=study_tables, adequacy=store.adequacy(matrix_id),
                              provenance={"database": str(db), **_provenance(store, matrix_id)})
    html_path, markdown_path = build_report(inputs, out, progress=True)
    print(f"report written: {html_path} and {markdown_path} ({len(runs)} runs, "
          f"{', '.join(STUDIES) if study_tables else 'no studies'}; {time.perf_counter() - started:.1f} s)")
    return 0


__all__ = ["ReportInputs", "build_report", "write_report"]
