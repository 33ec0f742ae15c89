"""``foucault-bench report``: build the report folder (index.html, REPORT.md, figures, tables) from results.

    foucault-bench report [--db PATH] [--matrix-id ID] [--out DIR] [--force] [--studies {stored,recompute,skip}]
                          [--targets ERROR ...] [--static] [--jobs N]

The folder opens in a browser with no server and no network: index.html and REPORT.md hold the same blocks
(``reports.document``); in index.html every chart of the results and studies is interactive (plotly,
``reports.interactive``; plotly.js is written beside it). With ``--static`` each chart also has its static
PNG + SVG files under ``figures/`` (``reports.charts``, matplotlib, for papers), which REPORT.md shows and
index.html links; without it REPORT.md links each chart in index.html. The figures are drawn by ``--jobs``
worker processes (default: one per CPU), in the page's order whatever order they finish in. Tables are embedded and
written under ``tables/`` as CSV, Markdown, LaTeX and HTML. The summary answers which integrator and setting
is cheapest per scene at each target error (``--targets``, default 1e-3 1e-6 1e-9 1e-12), with the Pareto fronts of
every error metric (``bench.verdicts.pareto``). File names made from scene names go through ``file_stem``. The study tables (``bench.studies``) are read from the database
and computed (then stored) when missing, or recomputed with ``--studies recompute``; ``--studies skip`` leaves
their sections out. The seed note's figures (``reports.seed``) are a section of the report.

``build_report`` works from plain data (a DataFrame with the ``bench.schema`` columns), so it is tested on a
small fixture without a database.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.context
import os
import sys
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator

import pandas as pd
from foucault_bench.bench.atomic import replacing_folder
from foucault_bench.bench.errors import InputError
from foucault_bench.bench.history.load import load_history
from foucault_bench.bench.history.revisions import group_revisions
from foucault_bench.bench.problems.scene_key import scene_labels
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.bench.verdicts.pareto import (
    DEFAULT_TARGETS,
    ERROR_METRICS,
    cost_column,
    pareto_front,
)
from foucault_bench.integrators import REGISTRY, STATUS_OK
from foucault_bench.integrators.base import COST_COMPILED, COST_PYTHON_DRIVEN
from foucault_bench.models.parameters import SIDEREAL_EARTH_RATE_RAD_S
from foucault_bench.reports import charts, ensembles, halls, interactive, tables
from foucault_bench.reports.document import (
    Block,
    Figure,
    Heading,
    Paragraph,
    Table,
    literal,
    write_document,
    write_table_files,
)
from foucault_bench.reports.history_page import write_history
from foucault_bench.reports.seed import seed_blocks
from foucault_bench.bench.studies import STUDIES, ensure_studies
from matplotlib.figure import Figure as MplFigure
from tqdm import tqdm

if TYPE_CHECKING:
    from plotly.graph_objects import Figure as PlotlyFigure

FIGURES = "figures"
TABLES = "tables"


@dataclass
class ReportInputs:
    """Everything a report is made of, as plain data.

    Attributes:
        runs: results rows (columns of ``bench.schema``).
        studies: study name (``bench.studies.STUDIES``) → its table; missing names leave their section out.
        adequacy: rows of the ``adequacy`` table (scene, model, simpler_model, precession_rate_diff,
            trajectory_gap, note), possibly empty.
        provenance: label → value lines shown at the top (matrix id, host, commit, ...).
        include_seed: add the seed-revisited section (computes the seed study, a few seconds).
        targets: target reference errors of the matched-accuracy summary.
        interactive: draw the charts of index.html with plotly (else the static PNGs only).
        static: write every chart's PNG and SVG under figures/ (else only those of the charts that are not
            interactive, and of the seed section); REPORT.md shows the static files or links to index.html.
        jobs: worker processes drawing the figures (1: in this process).
        revisions: code revisions whose runs the database holds (``bench.history``); with more than one, the
            report links its history page (``history/history.html``, ``reports.history_page``).
    """

    runs: pd.DataFrame
    studies: dict[str, pd.DataFrame] = field(default_factory=dict)
    adequacy: pd.DataFrame = field(default_factory=pd.DataFrame)
    provenance: dict[str, str] = field(default_factory=dict)
    include_seed: bool = True
    targets: tuple[float, ...] = DEFAULT_TARGETS
    interactive: bool = True
    static: bool = True
    jobs: int = 1
    revisions: int = 1


def file_stem(name: str) -> str:
    """A file-name part for a scene name, the same on every file system and distinct for distinct names.

    Scene names hold letters, digits, ``_``, ``.`` and ``-`` (``bench.problems.scenes.SCENE_NAME_PATTERN``).
    A dot would start a file suffix (``seed_v1.5`` and ``seed_v1.6`` would share ``seed_v1``), and names that
    differ only in case collide on case-insensitive file systems, so ``-`` escapes: ``-`` → ``--``, ``.`` →
    ``-_``, an upper-case letter X → ``-x``. The escape is prefix-free, hence one-to-one; lower-case names
    without dots or dashes (every built-in scene) are unchanged."""
    parts = []
    for character in name:
        if character == "-":
            parts.append("--")
        elif character == ".":
            parts.append("-_")
        elif character.isupper():
            parts.append("-" + character.lower())
        else:
            parts.append(character)
    return "".join(parts)


_PENDING: list[Callable[[], list[Block]]] = []
"""The figures of the report being built, read by the worker processes of ``_Builder.draw_figures`` (which
inherit it by fork: nothing is pickled but the blocks they return)."""


def _draw_pending(position: int) -> tuple[int, list[Block]]:
    return position, _PENDING[position]()


def _fork_context() -> multiprocessing.context.BaseContext | None:
    """The fork start method where the platform has it (worker processes inherit the figures to draw), else
    ``None`` (the figures are drawn in this process)."""
    return multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods() else None


class _Builder:
    """Collects blocks while writing the figures and tables they point to."""

    def __init__(self, folder: Path, progress: bool, interactive: bool, static: bool = True, jobs: int = 1):
        self.folder = folder
        self.blocks: list[Block] = []
        self.interactive = interactive
        self.static = static
        self.progress = progress
        self.jobs = jobs
        self.pending: list[tuple[int, str, Callable[[], list[Block]]]] = []
        """Blocks still to draw, in order: (place in ``blocks``, what it is, the function returning the blocks
        that take that place), drawn by ``draw_figures`` once the total is known."""
        self.first: set[int] = set()
        """Indices in ``pending`` of the long tasks, started before the others so that they do not finish last."""

    def add(self, *blocks: Block) -> None:
        self.blocks.extend(blocks)

    def later(self, what: str, draw: Callable[[], list[Block]], long: bool = False) -> None:
        """Keep a place for the blocks ``draw()`` returns (figures, which ``draw_figures`` draws in parallel);
        ``what`` names them in the progress bar; ``long`` starts them first."""
        if long:
            self.first.add(len(self.pending))
        self.pending.append((len(self.blocks), what, draw))
        self.blocks.append(Paragraph(""))

    def figure(self, name: str, caption: str, draw: Callable[[Path], Path],
               draw_interactive: Callable[[], PlotlyFigure] | None = None, beside: bool = False) -> None:
        """Add a chart to the page; ``draw_figures`` later writes the static chart ``draw(stem)`` under figures/
        (when the report is static) and, when the report is interactive, puts the plotly figure
        ``draw_interactive()`` on the page; ``beside``: to the right of the table just added."""
        static = self.static or not (self.interactive and draw_interactive is not None)
        self.later(name, partial(_render_figure, Figure(f"{FIGURES}/{name}", caption, static=static, beside=beside),
                                 self.folder / FIGURES / name, draw, draw_interactive if self.interactive else None))

    def curves(self, name: str, caption: str, draw: Callable[[pd.DataFrame], MplFigure], table: pd.DataFrame) -> None:
        """A chart of curves drawn with matplotlib (``draw(table)``): saved under figures/, and on the page
        converted to plotly (``interactive.from_matplotlib``)."""
        block = Figure(f"{FIGURES}/{name}", caption, static=self.static or not self.interactive)
        self.later(name, partial(_render_curves, block, self.folder / FIGURES / name, draw, table, self.interactive))

    def draw_figures(self) -> None:
        """Draw the pending figures, on ``jobs`` worker processes when there are several, with a counter that
        knows the total (and so shows an ETA) and names the figure last drawn; blocks keep their order."""
        bar = tqdm(total=len(self.pending), desc="report figures", unit="figure", disable=not self.progress,
                   leave=False)
        context = _fork_context()
        jobs = min(self.jobs, len(self.pending))
        order = sorted(range(len(self.pending)), key=lambda index: index not in self.first)
        _PENDING[:] = [self.pending[index][2] for index in order]
        try:
            if jobs > 1 and context is not None:
                with context.Pool(jobs) as pool:
                    drawn = self._collect(order, pool.imap_unordered(_draw_pending, range(len(order))), bar)
            else:
                drawn = self._collect(order, map(_draw_pending, range(len(order))), bar)
        finally:
            _PENDING.clear()
            bar.close()
        for index in sorted(drawn, key=lambda index: -self.pending[index][0]):
            place = self.pending[index][0]
            self.blocks[place:place + 1] = drawn[index]
        self.pending, self.first = [], set()

    def _collect(self, order: list[int], results: Iterator[tuple[int, list[Block]]],
                 bar: tqdm) -> dict[int, list[Block]]:
        """The blocks of each pending task by its index in ``pending`` (``results``: position in ``order``,
        blocks, in any order), counted on ``bar``."""
        drawn = {}
        for position, blocks in results:
            index = order[position]
            drawn[index] = blocks
            bar.set_postfix_str(self.pending[index][1], refresh=False)
            bar.update()
        return drawn

    def table(self, frame: pd.DataFrame, name: str, title: str, notes: dict[str, str] | None = None,
              collapsible: bool = False) -> None:
        shown = write_table_files(frame, self.folder, f"{TABLES}/{name}", title, tables.COLUMN_FORMATS)
        self.add(Table(title, shown, f"{TABLES}/{name}", tables.notes_for(frame, notes), collapsible))


def _render_figure(block: Figure, stem: Path, draw: Callable[[Path], Path],
                   draw_interactive: Callable[[], PlotlyFigure] | None) -> list[Block]:
    """Draw one chart: its static files when ``block.static``, its plotly figure when ``draw_interactive``."""
    if block.static:
        draw(stem)
    if draw_interactive is not None:
        plot = draw_interactive()
        block.interactive, block.points = plot.to_json(), interactive.drawn_points(plot)
    return [block]


def _render_curves(block: Figure, stem: Path, draw: Callable[[pd.DataFrame], MplFigure], table: pd.DataFrame,
                   on_page: bool) -> list[Block]:
    """Draw one matplotlib chart ``draw(table)``: its static files when ``block.static``, and its plotly
    conversion when ``on_page``."""
    figure = draw(table)
    if block.static:
        charts.save(figure, stem)
    if on_page:
        plot = interactive.from_matplotlib(figure)
        block.interactive, block.points = plot.to_json(), interactive.drawn_points(plot)
    return [block]


# --------------------------------------------------------------------------------------------------------------
# sections
# --------------------------------------------------------------------------------------------------------------
def _cost_words(runs: pd.DataFrame) -> str:
    return ("CPU time (median of the timed repeats)" if cost_column(runs) == "cpu_time_s"
            else "wall time (median of the timed repeats; these results have no CPU time)")


def _overview(builder: _Builder, inputs: ReportInputs) -> None:
    runs = inputs.runs
    counts = runs["status"].value_counts()
    builder.add(Heading("Overview"))
    if inputs.provenance:
        builder.add(Paragraph("; ".join(f"**{k}**: {literal(v)}" for k, v in inputs.provenance.items())))
    builder.add(Paragraph(
        f"{len(runs)} runs: {', '.join(f'{int(counts.get(status, 0))} {status}' for status in tables.STATUSES)}. "
        f"Scenes: {literal(', '.join(sorted(runs['scene'].unique())))}. "
        f"Integrators: {literal(', '.join(sorted(runs['integrator'].unique())))}."))
    if inputs.revisions > 1:
        builder.add(Paragraph(
            f"The database holds runs of {inputs.revisions} code revisions: the history page shows every verdict and "
            "the CPU time of each run by revision, and the changes between consecutive revisions (`foucault-bench "
            "history`):", link=("history", "history/history.html")))
    builder.add(Paragraph(
        "How to read the charts: colour = integrator family (the same in every chart), marker and line pattern = "
        "integrator within its family, solid-type lines = fixed-step sweeps (k·h), dashed-type lines = tolerance "
        f"sweeps. Cost is {_cost_words(runs)}; the bars across a point span the 95 % confidence interval of the median CPU "
        "time (runs with too few timed repeats for one have no bar). The thick grey staircase is the Pareto front: the runs no other run beats on both cost "
        "and error. Runs that diverged (▲) or failed (✕) are drawn above the data at their cost, or at the left "
        "edge when the cost is unknown (static charts: on the top edge); an ok run without a finite positive value "
        "is drawn below the data (▽; static charts: on the bottom edge). In this page, hovering a point shows its "
        "run (integrator, family, setting, error, CPU and wall time, evaluations, steps, status), clicking a legend "
        "entry hides that integrator and clicking 'all <family>' hides the family (double click: show only "
        "that entry); with `--static` the PNG and SVG files for papers are linked under each chart. "
        "Errors are dimensionless: positions relative to the amplitude A, energies relative to the swing's "
        "energy, precession rates relative to Ω_E|sin φ|. Frame x South, y East, z Up; latitude φ north "
        "positive; rates counter-clockwise about up positive (the textbook rate is −Ω_E sin φ)."))
    names = sorted(runs["scene"].unique())
    builder.add(Heading("Scenes", level=3))
    builder.table(tables.scenes_table([SCENES[name] for name in names if name in SCENES], runs), "scenes",
                  "The scenes: place, pendulum, release, grid, model and why", collapsible=True)


def _decisions(builder: _Builder, runs: pd.DataFrame, targets: tuple[float, ...]) -> None:
    builder.add(Heading("Summary at matched accuracy"), Paragraph(
        f"Per scene and target reference error (max |r − r_ref| / A over the output grid), the cheapest run "
        f"of any integrator and setting that meets it, by {_cost_words(runs)}; the runner-up is the cheapest run "
        "of another integrator meeting the same target and the ratio is its cost over the winner's. "
        "`foucault-bench advise` answers the same question for one scene and any target, and runs a small search "
        "when no stored run meets it."))
    builder.table(tables.matched_accuracy(runs, targets), "matched_accuracy",
                  "Cheapest integrator and setting per scene and target, runner-up and cost ratio")
    builder.add(Paragraph(
        f"Per scene and integrator, its cheapest setting reaching {tables.MATCHED_ACCURACY_TARGET:g}, or "
        "'not reached'; the counts show every diverged and failed run."))
    builder.table(tables.per_integrator(runs), "per_integrator",
                  f"Cheapest setting of each integrator reaching reference error ≤ {tables.MATCHED_ACCURACY_TARGET:g}")
    builder.add(Heading("Pareto fronts"), Paragraph(
        "For each scene and error metric, the runs that no other run beats on both cost and error, across "
        "every integrator and setting, cheapest first (bench.verdicts.pareto): read down a scene's rows to "
        "see which integrator is the cheapest way to each accuracy. Below, each family's most accurate run and "
        "how many points of the front it holds."))
    fronts, families = tables.fronts(runs), tables.families(runs)
    for frame, stem, title in ((fronts, "pareto_fronts", "Pareto-efficient runs per scene (reference error)"),
                               (families, "best_of_family", "Best run of each family per scene (reference error)")):
        builder.table(frame[frame["metric"] == "reference_error"] if not frame.empty else frame, stem, title)
        write_table_files(frame, builder.folder, f"{TABLES}/{stem}_all_metrics", f"{title[:title.index(' (')]}, "
                          "every error metric", tables.COLUMN_FORMATS)
    builder.add(Paragraph(
        f"The same for every error metric (energy error and drift, precession-rate error, analytic gap): "
        f"`{TABLES}/pareto_fronts_all_metrics.csv` and `{TABLES}/best_of_family_all_metrics.csv` (also .md, .tex, "
        ".html)."))


def _work_precision(builder: _Builder, runs: pd.DataFrame) -> None:
    builder.add(Heading("Work-precision"), Paragraph(
        "Each verdict against two costs, one line per integrator: time (median of the timed repeats, compile "
        "time excluded; the bar across a point is the 95 % confidence interval of the median CPU time, none where "
        "fewer than 6 repeats were made, or max − min of the repeats for wall time), and the accepted steps, counted "
        "for every family (what one step costs differs: s right-hand-side evaluations for a Runge-Kutta method, "
        "one corrector solve for a multistep method, one order-p Taylor expansion for heyoka). "
        "The energy error is the largest deviation over the run; the energy drift its least-squares trend, "
        "which tells a drifting integrator from one whose error oscillates within a bound. "
        "The precession-rate error is the integrator's own: measured rate against the reference solution's rate "
        "on the same grid. The analytic gap is the distance from the exact solution of the linear model, a model "
        "error for the other models."))
    builder.add(Paragraph(cost_basis_sentences(runs)))
    for scene, scene_runs in runs.groupby("scene", sort=True):
        builder.add(Heading(f"Scene {scene}", level=3))
        for verdict, (title, _) in charts.VERDICT_LABELS.items():
            if not scene_runs[verdict].notna().any() and (scene_runs["status"] == STATUS_OK).any():
                builder.add(Paragraph(f"{scene}: no {title} values in the results ({verdict} is empty)."))
            elif verdict == RECOMMENDATION_METRIC:
                builder.add(Paragraph(f"{scene}: the {title} chart is beside the scene's recommendations "
                                      "at the top of the report."))
            else:
                _work_precision_figure(builder, str(scene), scene_runs, verdict)


def _work_precision_figure(builder: _Builder, scene: str, scene_runs: pd.DataFrame, verdict: str,
                           beside: bool = False) -> None:
    title, label = charts.VERDICT_LABELS[verdict]
    front = pareto_front(scene_runs, verdict)
    builder.figure(f"work_precision_{file_stem(scene)}_{verdict}",
                   f"{scene}: {title} ({label}) against time and accepted steps; "
                   f"{_front_words(scene_runs, verdict, front)}.",
                   partial(charts.work_precision, scene_runs, verdict, front),
                   partial(interactive.work_precision, scene_runs, verdict, front), beside=beside)


RECOMMENDATION_METRIC = "reference_error"
"""The error the recommendations rank by (the matched-accuracy summary's)."""
RECOMMENDATION_COLUMNS = ("scene", "target", "outcome", "integrator", "setting", "error", "runner_up", "ratio")
"""The columns of the matched-accuracy summary a scene's recommendation shows (with the cost column)."""


def _recommendations(builder: _Builder, runs: pd.DataFrame, targets: tuple[float, ...]) -> None:
    """The first section: per scene, the cheapest integrator and setting at each target reference error
    (``tables.matched_accuracy``, the answer `foucault-bench advise` gives from the stored runs), beside the
    scene's work-precision chart of that error."""
    builder.add(Heading("Which method for my scene"), Paragraph(
        f"Per scene and target reference error, the cheapest integrator and setting that meets it (by "
        f"{_cost_words(runs)}), the runner-up integrator and its cost ratio; beside it the scene's reference "
        "error against cost. The full summary, the Pareto fronts and every other chart follow."))
    summary = tables.matched_accuracy(runs, targets)
    cost = cost_column(runs)
    for scene, scene_runs in runs.groupby("scene", sort=True):
        rows = summary[summary["scene"] == scene]
        columns = [*RECOMMENDATION_COLUMNS[:6], cost, *RECOMMENDATION_COLUMNS[6:]]
        builder.table(rows[columns].reset_index(drop=True), f"recommendation_{file_stem(str(scene))}",
                      f"{scene}: recommended method per target reference error")
        if scene_runs[RECOMMENDATION_METRIC].notna().any() or not (scene_runs["status"] == STATUS_OK).any():
            _work_precision_figure(builder, str(scene), scene_runs, RECOMMENDATION_METRIC, beside=True)


def _front_words(scene_runs: pd.DataFrame, verdict: str, front: pd.DataFrame) -> str:
    """What a work-precision caption says of the Pareto front: its size, or why there is none."""
    if not front.empty:
        return f"grey staircase: Pareto front ({len(front)} runs)"
    metric = ERROR_METRICS[verdict]
    models = sorted(model for model in scene_runs["model"].dropna().unique() if not metric.applies(model))
    if models:
        return f"no Pareto front for the {', '.join(models)} model ({metric.why_not})"
    return f"no Pareto front: no ok run has both a cost and a finite {metric.title}"


COST_BASIS_MEANING = {
    COST_COMPILED: "compiled (the whole integration runs in compiled code, no Python call per step or per "
                   "right-hand-side evaluation)",
    COST_PYTHON_DRIVEN: "Python-driven (a Python step loop or Python callbacks drive the library, so the cost "
                        "includes the interpreter's overhead per step or evaluation)",
    None: "not declared by the integrator",
}


def cost_basis_sentences(runs: pd.DataFrame) -> str:
    """One sentence per family saying how its integrators' cost was measured (``Integrator.cost_basis``)."""
    sentences = []
    for family, names in runs.groupby("family", sort=True)["integrator"]:
        by_basis: dict[str | None, list[str]] = {}
        for name in sorted(set(names)):
            integrator = REGISTRY.get(name)
            by_basis.setdefault(getattr(integrator, "cost_basis", None), []).append(name)
        parts = [f"{literal(', '.join(members))}: {literal(str(COST_BASIS_MEANING.get(basis, basis)))}"
                 for basis, members in by_basis.items()]
        sentences.append(f"Family {literal(family)}: " + "; ".join(parts) + ".")
    return "How each cost was measured. " + " ".join(sentences)


def _convergence(builder: _Builder, runs: pd.DataFrame) -> None:
    orders = tables.convergence_orders(runs)
    builder.add(Heading("Convergence"), Paragraph(
        "Reference error against k·h (the step in units of 1/k = √(L/g), the unit of matrices and thresholds) "
        "for the fixed-step integrators, with a dotted reference slope for each declared order. The fitted "
        "order (bench.verdicts.convergence.observed_order: least-squares slope over the finest points of the "
        "longest stretch whose local slopes agree, after dropping saturated errors above 0.1; a round-off floor "
        "and a pre-asymptotic start fall outside that stretch) is in the legend and in the table next to the "
        "declared order."))
    builder.table(orders, "convergence_orders", "Observed and declared orders of convergence")
    for scene, scene_runs in runs.groupby("scene", sort=True):
        if scene_runs["tol"].isna().any():
            scene_orders = tables.orders_by_integrator(orders, scene)
            builder.figure(f"convergence_{file_stem(scene)}",
                           f"{scene}: reference error against k·h, fitted order in the legend.",
                           partial(charts.convergence, scene_runs, scene_orders),
                           partial(interactive.convergence, scene_runs, scene_orders))
    builder.add(Heading("Tolerance against achieved error"), Paragraph(
        "For the adaptive integrators, the reference error reached against the tolerance asked for: a line "
        "below the dotted diagonal delivers more than asked, above it less. Libraries map a tolerance to their "
        "own error control differently (integrators/adaptive.py), so equal tolerances are not equal work."))
    for scene, scene_runs in runs.groupby("scene", sort=True):
        if scene_runs["tol"].notna().any():
            builder.figure(f"tolerance_{file_stem(scene)}",
                           f"{scene}: reference error against requested tolerance (adaptive integrators).",
                           partial(charts.tolerance, scene_runs),
                           partial(interactive.tolerance, scene_runs))


def _studies(builder: _Builder, studies: dict[str, pd.DataFrame]) -> None:
    from foucault_bench.bench.studies import (
        BOUNDED_BELOW_EXPONENT,
        GROWING_ABOVE_EXPONENT,
        energy_trends,
        family_representatives,
        midpoint_precession_law,
        structure_preserving_integrators,
        study_setting_label,
    )

    def span(seconds: float) -> str:
        return f"{seconds / 3600:g} h" if seconds >= 3600 else f"{seconds:g} s"

    energy = studies.get("study_long_time_energy")
    if energy is not None:
        first = energy.iloc[0]
        trends = energy_trends(energy)
        horizon = span(float(trends["early_horizon_s"].iloc[0]))
        end = span(float(first["config_duration_s"]))
        shown = set(zip(trends["integrator"], trends["setting"], strict=True))
        if {"config_kh", "config_tol"} <= set(energy.columns) and shown == {
                (name, study_setting_label(name, first["config_tol"] if REGISTRY[name].adaptive else first["config_kh"]))
                for name in family_representatives().values()}:
            which = ("one representative per integrator family, each family's simplest built-in member by the "
                     "facts it declares (fixed-step before adaptive, then the lowest order, then compiled code; "
                     "bench.studies.family_representatives), the fixed-step ones at "
                     f"kh = {first['config_kh']:g} and the adaptive ones at tol = {first['config_tol']:g}")
        else:
            which = f"{len(trends)} configured runs"
        clauses = []
        for run in trends.itertuples():
            label = f"{run.integrator} ({run.family}, {run.setting})"
            if run.trend == "failed":
                clauses.append(f"{label} failed (its message is in the table below)")
            elif run.trend == "diverged" and pd.isna(run.last_finite_s):
                clauses.append(f"{label} diverged before the first output")
            elif run.trend == "diverged":
                clauses.append(f"{label} diverged after {run.last_finite_s:g} s, its error having reached "
                               f"{run.max_error:.2g}")
            elif pd.isna(run.exponent):
                clauses.append(f"{label}: M = {run.early_max_error:.2g} by {horizon}, {run.max_error:.2g} by "
                               f"{end} (too few outputs after {horizon} to fit a trend)")
            else:
                clauses.append(f"{label} {run.trend}: M = {run.early_max_error:.2g} by {horizon}, "
                               f"{run.max_error:.2g} by {end} (p = {round(run.exponent, 2) + 0.0:.2f})")
        builder.add(Heading("Long-time energy"), Paragraph(
            f"Relative energy error (E − E₀)/E_swing against time over {end}, {which} (study "
            "`study_long_time_energy`, bench.studies.long_time_energy). "
            f"Values below {charts.LOG_FLOOR:g} (exact zeros included) are drawn at {charts.LOG_FLOOR:g}."),
            Paragraph(
            f"What the runs show, with M(t) the largest |error| up to t and its trend the exponent p of "
            f"M ∝ tᵖ fitted from {horizon} to the end (bounded when p < {BOUNDED_BELOW_EXPONENT:g}, growing when "
            f"p > {GROWING_ABOVE_EXPONENT:g}, drifting in between). Per run: " + "; ".join(clauses) + "."))
        builder.curves("study_long_time_energy",
                       "Relative energy error against time (log-log), per integrator family. Thick line: the largest "
                       "error so far (its running maximum), which separates bounded, drifting and growing errors; "
                       "faint line of the same colour: the error at each output time, whose oscillation the "
                       "maximum hides (a symplectic method's error swings within a band every half period).",
                       charts.long_time_energy, energy)
        builder.table(tables.long_time_summary(energy), "study_long_time_energy_summary",
                      "Long-time energy: error after the first hour and at the end")
    roundoff = studies.get("study_long_time_roundoff")
    if roundoff is not None:
        from foucault_bench.reports.roundoff import roundoff_growth

        builder.add(Heading("Long-time round-off"), Paragraph(
            "On the linear model each symmetric scheme's one-step map conserves a quadratic form Q (the energy "
            "for the Gauss-Legendre methods), so its drift is round-off alone (study `study_long_time_roundoff`, "
            "bench.studies.long_time_roundoff; integrators/README.md \"Round-off over long runs\")."))
        builder.curves("study_long_time_roundoff",
                       f"|ΔQ|/Q against steps at kh = {roundoff['kh'].iloc[0]:g}: per integrator the median over "
                       f"{int(roundoff['config_releases'].iloc[0])} random releases (bars: their range) and the "
                       "fitted growth exponent; dashed: ε√n.",
                       roundoff_growth, roundoff)
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
        builder.curves("study_stability", "Energy error against k·h across each fixed-step integrator's stability "
                       "limit, without rotation (solid) and with it (dashed); triangles mark the measured limits.",
                       charts.stability, stability)
        builder.curves("study_stability_rotation_growth",
                       "Growth per step with Earth's rotation: measured one-step growth against the declared law.",
                       charts.rotation_growth, stability)
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
            f"it is {residual:.2g} Ω_E (release-side terms, docs/models/README.md \"Airy precession\")."))
        builder.curves("study_precession_latitude",
                       "Precession rate against latitude; residual from −Ω_E sin φ in units of Ω_E.",
                       charts.precession_latitude, precession)

    azimuth = studies.get("study_release_azimuth")
    if azimuth is not None:
        first = azimuth.iloc[0]
        names = sorted(azimuth["integrator"].unique())
        declared = [name for name in names if name in REGISTRY and REGISTRY[name].describe()["volume_preserving"]]
        if names == sorted(structure_preserving_integrators()):
            members = ("Every built-in fixed-step integrator that declares a volume-preserving one-step map "
                       f"(`volume_preserving`, implied by `symplectic`: {', '.join(names)})")
        elif declared == names:
            members = (f"The integrators {', '.join(names)}, each declaring a volume-preserving one-step map "
                       "(`volume_preserving`)")
        else:
            members = f"The integrators {', '.join(names)}"
        ok = azimuth[azimuth["status"] == STATUS_OK]
        taken = sorted(ok["kh"].unique()) if not ok.empty else sorted(azimuth["kh"].dropna().unique())
        requested = float(first["kh_requested"])
        step = " and ".join(f"{kh:.4g}" for kh in taken) or "–"
        if any(kh != requested for kh in taken):
            step += (f" ({requested:g} requested, shortened so that whole steps fill each "
                     f"{first['config_output_interval_s']:g} s output interval)")
        latitudes = sorted(azimuth["latitude_deg"].unique(), reverse=True)
        text = (f"{members}, at kh = {step} on the {first['config_model']} model, released at azimuths from "
                f"South (0°, a North-South swing) to North, at {', '.join(f'{lat:g}°' for lat in latitudes)} "
                "(study `study_release_azimuth`); the error is the rate's distance from heyoka's at "
                f"tol = {first['config_reference_tol']:g} on the same grid, relative to Ω_E so that latitudes "
                "compare.")
        verlet = ok[ok["integrator"] == "verlet"]
        if not verlet.empty:
            extremes = []
            north_south_worst = True
            for latitude in latitudes:
                sweep = verlet[verlet["latitude_deg"] == latitude].set_index("release_azimuth_deg")["error_earth"]
                worst, best = float(sweep.idxmax()), float(sweep.idxmin())
                north_south_worst &= min(worst, 180.0 - worst) <= 15.0 and abs(best - 90.0) <= 15.0
                extremes.append(f"at {latitude:g}° from {sweep.min():.2g} Ω_E (released at {best:g}°) to "
                                f"{sweep.max():.2g} Ω_E ({worst:g}°)")
            text += " Verlet's error depends on the direction: " + ", ".join(extremes) + "."
            if north_south_worst:
                text += (" A North-South swing feels the horizontal part of ω along its own line, which an "
                         "East-West release (every real scene's) hides.")
        law = midpoint_precession_law(azimuth)
        if not law.empty:
            by_latitude = law.sort_values("latitude_deg", ascending=False).set_index("latitude_deg")
            law_kh = " and ".join(f"{kh * kh / 4:.3g}" for kh in sorted(by_latitude["kh"].unique()))
            text += (" The implicit midpoint rule is slow by (kh)²/4 of the local rate whatever the direction: "
                     "its Cayley map turns each circular mode too slowly, and the precession is their mean. At "
                     f"the step taken (kh)²/4 = {law_kh}, which predicts "
                     + ", ".join(f"{row.law_error_earth:.3g} Ω_E at {lat:g}°" for lat, row in by_latitude.iterrows())
                     + "; measured (median over the azimuths) "
                     + ", ".join(f"{row.measured_error_earth:.3g} Ω_E at {lat:g}°"
                                 for lat, row in by_latitude.iterrows())
                     + ", varying with the azimuth by at most "
                     + f"{100 * by_latitude['azimuth_variation'].max():.2g} %.")
        builder.add(Heading("Precession error against the release direction"), Paragraph(text))
        builder.curves("study_release_azimuth",
                       "Precession-rate error relative to Ω_E against the release azimuth, per latitude.",
                       charts.release_azimuth, azimuth)


def _adequacy(builder: _Builder, adequacy: pd.DataFrame) -> None:
    builder.add(Heading("Model adequacy"))
    if adequacy.empty:
        builder.add(Paragraph("The database holds no `adequacy` rows for this matrix run."))
        return
    builder.add(Paragraph(
        "Per scene, what each simpler model gets wrong compared with the scene's model "
        "(bench.verdicts.adequacy.model_adequacy)."))
    builder.curves("model_adequacy",
                   "Model adequacy per scene (log scale). Left panel, 'Precession rate missed': how far the simpler "
                   "model's precession rate is from the richer one's, in units of Ω_E|sin φ|. Right panel, 'Path "
                   "missed': the largest distance between the two models' paths, in units of the amplitude A. "
                   "Filled: measured; hollow: the leading-order expectation where the physics gives one.",
                   charts.adequacy, adequacy)
    builder.table(adequacy, "model_adequacy", "Model adequacy per scene", tables.ADEQUACY_NOTES)


def _all_runs(builder: _Builder, runs: pd.DataFrame) -> None:
    builder.add(Heading("All runs"), Paragraph(
        "One row per run with the main columns, folded in this page: open it and type words to keep the rows "
        "holding all of them (e.g. `lab rk4 ok`); the CSV link has the same rows. The linked files of the "
        "second table hold every column of foucault_bench.bench.schema."))
    builder.table(tables.compact_table(runs), "runs_compact", "All runs (main columns)", collapsible=True)
    full = tables.full_table(runs)
    write_table_files(full, builder.folder, f"{TABLES}/runs_full", "All runs, every column", tables.COLUMN_FORMATS)
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
    builder = _Builder(folder, progress, inputs.interactive, inputs.static, inputs.jobs)
    _recommendations(builder, inputs.runs, inputs.targets)
    _overview(builder, inputs)
    _decisions(builder, inputs.runs, inputs.targets)
    _work_precision(builder, inputs.runs)
    _convergence(builder, inputs.runs)
    _studies(builder, inputs.studies)
    _adequacy(builder, inputs.adequacy)
    halls.add_section(builder, inputs.runs)
    ensembles.add_section(builder, inputs.runs, file_stem)
    if inputs.include_seed:
        builder.later("seed section", partial(seed_blocks, folder, "seed"), long=True)
    _all_runs(builder, inputs.runs)
    builder.draw_figures()
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


def write_report(db: Path, matrix_id: str | None, out: Path, studies: str = "stored",
                 targets: tuple[float, ...] = DEFAULT_TARGETS, static: bool = False, jobs: int = 1) -> int:
    """``foucault-bench report``: the report of matrix run ``matrix_id`` (``None``: the latest) of database
    ``db`` written to folder ``out``; ``studies`` is ``stored``, ``recompute`` or ``skip``; ``static`` writes
    every chart's PNG and SVG; ``jobs`` worker processes draw the figures. Exit status 0.

    The report is built in a staging folder beside ``out`` and swapped in whole once complete
    (``bench.atomic.replacing_folder``; the command checks ``out`` first): a kill or a full disk leaves the
    previous report. Study tables are computed and stored when missing (all of them with ``recompute``); when
    ``db`` cannot be written they are computed for this report only, with a note saying so."""
    started = time.perf_counter()
    with ResultsStore(db, create=False) as store:
        matrix_id = store.resolve_matrix_id(matrix_id)
        runs = store.frame(matrix_id)
        if runs.empty:
            raise InputError(f"matrix run {matrix_id} in {db} has no stored runs")
        runs = runs.assign(scene=scene_labels(runs))  # a name with two physics is two scenes, never merged
        adequacy = store.adequacy(matrix_id)
        if not adequacy.empty:
            adequacy = adequacy.assign(scene=scene_labels(adequacy, runs))
        study_tables = {} if studies == "skip" else _study_tables(store, db, recompute=studies == "recompute")
        revisions = len(group_revisions(store.matrix_runs(), source=str(db)))
        inputs = ReportInputs(runs=runs, studies=study_tables, adequacy=adequacy,
                              provenance={"database": str(db), **_provenance(store, matrix_id)},
                              targets=targets, static=static, jobs=jobs, revisions=revisions)
    with replacing_folder(out, "--out", "report") as staging:
        build_report(inputs, staging, progress=True)
        if revisions > 1:
            (staging / "history").mkdir()
            write_history(load_history(db, repository=Path.cwd()), staging / "history")
    print(f"report written: {out / 'index.html'} and {out / 'REPORT.md'} ({len(runs)} runs, "
          f"{', '.join(STUDIES) if study_tables else 'no studies'}; {time.perf_counter() - started:.1f} s)")
    return 0


def _study_tables(store: ResultsStore, db: Path, recompute: bool) -> dict[str, pd.DataFrame]:
    """``ensure_studies`` on ``store``, storing what it computes only when the database can be written (the
    file and its folder, where SQLite keeps its journal); else a note names the tables computed for this report
    only."""
    writable = os.access(db, os.W_OK) and os.access(Path(db).resolve().parent, os.W_OK)
    if not writable:
        missing = list(STUDIES) if recompute else [name for name in STUDIES if not _stored(store, name)]
        if missing:
            print(f"note: {db} is read-only: the study tables {', '.join(missing)} are computed for this report "
                  "and not stored", file=sys.stderr)
    return ensure_studies(store, recompute=recompute, store_computed=writable)


def _stored(store: ResultsStore, name: str) -> bool:
    try:
        return not store.read_table(name).empty
    except KeyError:
        return False


__all__ = ["ReportInputs", "build_report", "write_report"]
