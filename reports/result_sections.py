"""The report's sections of the results rows: the recommendations (the front page's first screen), the overview
with the scenes, the summary at matched accuracy and the Pareto fronts, the convergence orders, one page per
scene (its work-precision, convergence and tolerance charts and its runs), model adequacy and the page of all
runs. Each section is a function ``section(builder, inputs)`` (``reports.build.SECTIONS``) adding blocks to a
``reports.builder.Builder``; the tables come from ``reports.tables``, the charts from ``reports.charts`` and
``reports.interactive``.
"""

from __future__ import annotations

from functools import partial

import pandas as pd

from foucault_bench.bench.ensembles.summary import single_scene_rows
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.bench.verdicts.pareto import ERROR_METRICS, cost_column, pareto_front
from foucault_bench.integrators import REGISTRY, STATUS_OK
from foucault_bench.integrators.base import COST_COMPILED, COST_PYTHON_DRIVEN
from foucault_bench.reports import charts, interactive, study_charts, tables
from foucault_bench.reports.builder import INDEX, TABLES, Builder, ReportInputs, file_stem, scene_page
from foucault_bench.reports.document import Heading, Paragraph, literal


def _cost_words(runs: pd.DataFrame) -> str:
    return ("CPU time (median of the timed repeats)" if cost_column(runs) == "cpu_time_s"
            else "wall time (median of the timed repeats; these results have no CPU time)")


def overview(builder: Builder, inputs: ReportInputs) -> None:
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
                  "The scenes: place, pendulum, release, grid, model and why", collapsible=True, details="why_model")
    builder.add(Heading("Per scene"), Paragraph(
        "Each scene has its own page: every verdict against cost, the convergence of the fixed-step integrators, "
        "the tolerance reached by the adaptive ones, and the scene's runs."))
    for scene, scene_runs in runs.groupby("scene", sort=True):
        builder.add(Paragraph(f"{literal(str(scene))}: {len(scene_runs)} runs of "
                              f"{scene_runs['integrator'].nunique()} integrators.",
                              link=(f"scene {scene}", scene_page(str(scene)))))


def decisions(builder: Builder, inputs: ReportInputs) -> None:
    """The summary at matched accuracy, the cheapest setting of each integrator and the Pareto fronts (folded
    tables: the first section shows each scene's answer)."""
    runs, targets = inputs.runs, inputs.targets
    builder.add(Heading("Summary at matched accuracy"), Paragraph(
        f"Per scene and target reference error (max |r − r_ref| / A over the output grid), the cheapest run "
        f"of any integrator and setting that meets it, by {_cost_words(runs)}; the runner-up is the cheapest run "
        "of another integrator meeting the same target and the ratio is its cost over the winner's. "
        "`foucault-bench advise` answers the same question for one scene and any target, and runs a small search "
        "when no stored run meets it."))
    builder.table(tables.matched_accuracy(runs, targets), "matched_accuracy",
                  "Cheapest integrator and setting per scene and target, runner-up and cost ratio", collapsible=True)
    builder.add(Paragraph(
        "Per scene and target, every integrator ranked by the cost of its cheapest setting meeting the target, "
        "with its cost over the cheapest one's; the integrators that do not reach it follow with their best error."))
    builder.table(tables.ranked_at_targets(runs, targets), "ranked_at_targets",
                  "Every integrator at matched accuracy: rank and cost ratio per scene and target", collapsible=True)
    builder.add(Paragraph(
        f"Per scene and integrator, its cheapest setting reaching {tables.MATCHED_ACCURACY_TARGET:g}, or "
        "'not reached'; the counts show every diverged and failed run."))
    builder.table(tables.per_integrator(runs), "per_integrator",
                  f"Cheapest setting of each integrator reaching reference error ≤ {tables.MATCHED_ACCURACY_TARGET:g}",
                  collapsible=True)
    builder.add(Heading("Pareto fronts"), Paragraph(
        "For each scene and error metric, the runs that no other run beats on both cost and error, across "
        "every integrator and setting, cheapest first (bench.verdicts.pareto): read down a scene's rows to "
        "see which integrator is the cheapest way to each accuracy. Below, each family's most accurate run and "
        "how many points of the front it holds."))
    fronts, families = tables.fronts(runs), tables.families(runs)
    for frame, stem, title in ((fronts, "pareto_fronts", "Pareto-efficient runs per scene (reference error)"),
                               (families, "best_of_family", "Best run of each family per scene (reference error)")):
        builder.table(frame[frame["metric"] == "reference_error"] if not frame.empty else frame, stem, title,
                      collapsible=True)
        builder.table_files(frame, f"{stem}_all_metrics", f"{title[:title.index(' (')]}, every error metric")
    builder.add(Paragraph(
        f"The same for every error metric (energy error and drift, precession-rate error, analytic gap): "
        f"`{TABLES}/pareto_fronts_all_metrics.csv` and `{TABLES}/best_of_family_all_metrics.csv` (also .md, .tex, "
        ".html)."))


def scene_pages(builder: Builder, inputs: ReportInputs) -> None:
    """One page per scene: each verdict against cost, convergence, tolerance, and the scene's runs."""
    runs = single_scene_rows(inputs.runs)  # an ensemble's members: its own section (reports.ensembles)
    orders = tables.convergence_orders(runs)
    for scene, scene_runs in runs.groupby("scene", sort=True):
        builder.page(scene_page(str(scene)), f"scene {scene}")
        builder.add(Heading(f"Scene {scene}"))
        _scene_work_precision(builder, str(scene), scene_runs)
        _scene_convergence(builder, str(scene), scene_runs, orders)
        builder.table(tables.compact_table(scene_runs), f"runs_{file_stem(str(scene))}",
                      f"{scene}: its runs (main columns)", collapsible=True)


def _scene_work_precision(builder: Builder, scene: str, scene_runs: pd.DataFrame) -> None:
    builder.add(Heading("Work-precision", level=3), Paragraph(
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
    builder.add(Paragraph(cost_basis_sentences(scene_runs)))
    for verdict, (title, _) in charts.VERDICT_LABELS.items():
        if not scene_runs[verdict].notna().any() and (scene_runs["status"] == STATUS_OK).any():
            builder.add(Paragraph(f"{literal(scene)}: no {title} values in the results ({verdict} is empty)."))
        elif verdict == RECOMMENDATION_METRIC:
            builder.add(Paragraph(f"{literal(scene)}: the {title} chart is beside the scene's recommendations "
                                  "on the front page.", link=("front page", INDEX)))
        else:
            _work_precision_figure(builder, scene, scene_runs, verdict)


def _work_precision_figure(builder: Builder, scene: str, scene_runs: pd.DataFrame, verdict: str,
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


def recommendations(builder: Builder, inputs: ReportInputs) -> None:
    """The first section: per scene, the cheapest integrator and setting at each target reference error
    (``tables.matched_accuracy``, the answer `foucault-bench advise` gives from the stored runs), beside the
    scene's work-precision chart of that error."""
    runs, targets = inputs.runs, inputs.targets
    builder.add(Heading("Which method for my scene"), Paragraph(
        f"Per scene and target reference error, the cheapest integrator and setting that meets it (by "
        f"{_cost_words(runs)}), the runner-up integrator and its cost ratio; beside it the scene's reference "
        "error against cost. The full summary, the Pareto fronts and every other chart follow. An ensemble's "
        "members are shown together in the section Ensembles (`foucault-bench advise --worst` recommends for its "
        "worst member)."))
    summary = tables.matched_accuracy(runs, targets)
    cost = cost_column(runs)
    for scene, scene_runs in single_scene_rows(runs).groupby("scene", sort=True):
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


def convergence_orders(builder: Builder, inputs: ReportInputs) -> None:
    """The observed and declared orders of every scene's fixed-step integrators (their charts: the scene pages)."""
    builder.add(Heading("Convergence"), Paragraph(
        "Reference error against k·h (the step in units of 1/k = √(L/g), the unit of matrices and thresholds) "
        "for the fixed-step integrators, with a dotted reference slope for each declared order, on each scene's "
        "page. The fitted order (bench.verdicts.convergence.observed_order: least-squares slope over the finest "
        "points of the longest stretch whose local slopes agree, after dropping saturated errors above 0.1; a "
        "round-off floor and a pre-asymptotic start fall outside that stretch) is in the legend and in the table "
        "next to the declared order."))
    builder.table(tables.convergence_orders(inputs.runs), "convergence_orders",
                  "Observed and declared orders of convergence", collapsible=True)


def _scene_convergence(builder: Builder, scene: str, scene_runs: pd.DataFrame, orders: pd.DataFrame) -> None:
    fixed, adaptive = scene_runs[scene_runs["tol"].isna()], scene_runs[scene_runs["tol"].notna()]
    if not fixed.empty:
        scene_orders = tables.orders_by_integrator(orders, scene)
        builder.add(Heading("Convergence", level=3))
        builder.figure(f"convergence_{file_stem(scene)}",
                       f"{scene}: reference error against k·h, fitted order in the legend.",
                       partial(charts.convergence, fixed, scene_orders),
                       partial(interactive.convergence, fixed, scene_orders))
    if not adaptive.empty:
        builder.add(Heading("Tolerance against achieved error", level=3), Paragraph(
            "For the adaptive integrators, the reference error reached against the tolerance asked for: a line "
            "below the dotted diagonal delivers more than asked, above it less. Libraries map a tolerance to their "
            "own error control differently (integrators/adaptive.py), so equal tolerances are not equal work."))
        builder.figure(f"tolerance_{file_stem(scene)}",
                       f"{scene}: reference error against requested tolerance (adaptive integrators).",
                       partial(charts.tolerance, adaptive), partial(interactive.tolerance, adaptive))


def adequacy(builder: Builder, inputs: ReportInputs) -> None:
    adequacy = inputs.adequacy
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
                   study_charts.adequacy, adequacy)
    builder.table(adequacy, "model_adequacy", "Model adequacy per scene", tables.ADEQUACY_NOTES)


def all_runs(builder: Builder, inputs: ReportInputs) -> None:
    """The page of every run (a folded, filterable table) and the files of every column."""
    runs = inputs.runs
    builder.page("runs.html", "all runs")
    builder.add(Heading("All runs"), Paragraph(
        "One row per run with the main columns, folded in this page: open it and type words to keep the rows "
        "holding all of them (e.g. `lab rk4 ok`); the CSV link has the same rows. The linked files of the "
        "second table hold every column of foucault_bench.bench.schema."))
    builder.table(tables.compact_table(runs), "runs_compact", "All runs (main columns)", collapsible=True)
    full = tables.full_table(runs)
    builder.table_files(full, "runs_full", "All runs, every column")
    builder.add(Paragraph(f"Every column: `{TABLES}/runs_full.csv`, `.md`, `.tex`, `.html`."))


