"""The results table: one row per run (scene × integrator × setting), its columns, types and units.

This is the contract between the runner (which writes rows), the results store (SQLite), the reports and the
threshold checks. Every column is documented here once; the column table of bench/README.md "Results table" is
generated from ``COLUMNS`` (``python -m foucault_bench.bench.schema``; ``tests/test_docs.py`` keeps them equal).
Errors are dimensionless unless a unit is given.

Each row also carries the integrator's declared facts (``DECLARED_FACTS``: family, order, stages, adaptive,
stability limit) as they were when the run was made, so that reading results never needs the integrator's
code (a plug-in need not be installed to report on its runs).

``SCHEMA_VERSION`` numbers this contract; the results store records it in the database and migrates or refuses
a database written under another version (``bench.run.store``). Bump it when a column is added, removed or
changes meaning, and say in ``MIGRATIONS`` what an older database lacks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Column:
    name: str
    sql_type: str  # TEXT, REAL, INTEGER
    unit: str
    description: str


COLUMNS: tuple[Column, ...] = (
    # identity and setting
    Column("run_key", "TEXT", "", "hash of scene, integrator, setting and code version; --resume skips stored keys"),
    Column("matrix_id", "TEXT", "", "id of the matrix run that produced the row (provenance table)"),
    Column("scene", "TEXT", "", "scene name (chosen by a matrix file: two scenes may share one)"),
    Column("scene_key", "TEXT", "", "hash of the scene's physics (model, every pendulum parameter and the release, duration, output grid; bench.problems.scene_key): rows of one name and two keys are two scenes; NULL for rows of an older database whose physics could not be recovered"),
    Column("ensemble", "TEXT", "", "the ensemble the scene is a member of (bench.problems.ensemble); NULL for a scene of its own"),
    Column("ensemble_member", "TEXT", "", "the member's swept fields and values, a JSON object in the ensemble's order ({\"latitude_deg\": -90.0}); NULL outside an ensemble"),
    Column("ensemble_setting", "TEXT", "", "the setting as the matrix asked for it (kh=0.05, tol=1e-06), shared by the members of one setting (a fixed-step run's kh column holds the step taken, which depends on the member's length and output grid); NULL outside an ensemble"),
    Column("model", "TEXT", "", "model name (registry key, models.MODELS)"),
    Column("integrator", "TEXT", "", "integrator name (registry key)"),
    Column("family", "TEXT", "", "integrator family (colours, thresholds)"),
    Column("declared_order", "INTEGER", "", "order of accuracy the integrator declares (NULL where it varies)"),
    Column("stages", "INTEGER", "", "declared right-hand-side evaluations per step (NULL for adaptive ones)"),
    Column("adaptive", "INTEGER", "", "1 if the integrator is driven by a tolerance, 0 if by a step size"),
    Column("stability_limit_kh", "REAL", "", "declared largest stable k·h on ẍ = −k²x (NULL if none)"),
    Column("step_s", "REAL", "s", "effective fixed step (NULL for adaptive runs)"),
    Column("kh", "REAL", "", "k·h, the step in units of 1/k = √(L/g) (NULL for adaptive runs)"),
    Column("tol", "REAL", "", "tolerance (NULL for fixed-step runs)"),
    Column("duration_s", "REAL", "s", "integrated time span"),
    Column("n_out", "INTEGER", "", "points on the output grid (the same for every integrator of a scene)"),
    # outcome
    Column("status", "TEXT", "", "ok / diverged / failed / timeout (see RUN_STATUSES)"),
    Column("message", "TEXT", "", "why a run diverged, failed or timed out (empty when ok)"),
    # verdicts
    Column("energy_conserved", "INTEGER", "", "1 if the model conserves its energy (Jacobi) exactly, else 0"),
    Column("energy_max_rel_error", "REAL", "", "max over the output grid of |E − E₀|/(E₀ − E_rest), E_rest = energy of the bob at rest at the bottom"),
    Column("energy_drift_per_s", "REAL", "1/s", "least-squares slope of (E − E₀)/(E₀ − E_rest) against t"),
    Column("energy_max_rel_error_steps", "REAL", "", "the same max over every step (streamed; fixed-step runs of a matrix with step_energy = true)"),
    Column("precession_rate_rad_s", "REAL", "rad/s", "measured swing-plane rate, counter-clockwise about up positive"),
    Column("precession_rate_error", "REAL", "", "|rate − (−Ω_E sin φ)| / (Ω_E |sin φ|) (÷ Ω_E at the equator): relative to the local rate, large near the equator"),
    Column("precession_rate_error_rad_s", "REAL", "rad/s", "|rate − (−Ω_E sin φ)|"),
    Column("precession_rate_error_earth", "REAL", "", "|rate − (−Ω_E sin φ)| / Ω_E: comparable across latitudes (charts and thresholds use it)"),
    Column("precession_rate_ref_error", "REAL", "", "|rate − reference rate| / (Ω_E |sin φ|), the integrator's own error, relative to the local rate"),
    Column("precession_rate_ref_error_rad_s", "REAL", "rad/s", "|rate − reference rate|"),
    Column("precession_rate_ref_error_earth", "REAL", "", "|rate − reference rate| / Ω_E: comparable across latitudes (charts and thresholds use it)"),
    Column("analytic_gap_exact", "REAL", "", "max |r − r_exact linear| / A over the output grid"),
    Column("analytic_gap_seed", "REAL", "", "max |r − r_seed eqs. 14-15| / A over the output grid"),
    Column("reference_error", "REAL", "", "max |r − r_reference| / A over the output grid (real128 heyoka reference)"),
    Column("energy_balance_max_rel_error", "REAL", "", "models that conserve no energy only (NULL otherwise): max over the output grid of |E − E₀ − W|/(E₀ − E_rest), W the work of drag and drive integrated along the run (bench/verdicts/energy_balance.py)"),
    Column("canonical_angular_momentum_ref_error", "REAL", "", "max |ℓ_c − ℓ_c,ref| / (k A²) over the output grid, ℓ_c = xẏ − yẋ + Ω_E sin φ (x² + y²) the canonical angular momentum about the vertical (bench/verdicts/ellipse.py)"),
    Column("semi_minor_axis_ref_error", "REAL", "", "max |b_e − b_e,ref| / A over the output grid, b_e the semi-minor axis of the osculating small-swing ellipse (bench/verdicts/ellipse.py)"),
    # cost
    Column("cpu_time_s", "REAL", "s", "median CPU time of the worker thread over the timed repeats (compile excluded): the cost the charts and tables use, independent of machine load and --jobs"),
    Column("cpu_time_spread_s", "REAL", "s", "max − min of the timed repeats' CPU times (0 with a single repeat: a run whose first repeat alone reached the protocol's max_total_s)"),
    Column("wall_time_s", "REAL", "s", "median wall time of the timed repeats (compile excluded): what a user waits, grows when runs share a core"),
    Column("wall_time_spread_s", "REAL", "s", "max − min of the timed repeats' wall times"),
    Column("repeats", "INTEGER", "", "timed repeats after the warm-up"),
    Column("compile_time_s", "REAL", "s", "CPU time of the warm-up call over the scene's first output interval (JIT compile or cache load; before 2026-12-02 first-call CPU time minus the median CPU time; wall time in databases of schema version 3 and older)"),
    Column("nfev", "INTEGER", "", "right-hand-side evaluations; for the taylor family (heyoka) the Taylor steps instead, each an order-p expansion costing about p evaluations: not comparable with other families' counts"),
    Column("njev", "INTEGER", "", "Jacobian evaluations where reported"),
    Column("steps", "INTEGER", "", "accepted steps (the charts' second cost axis, counted for every family; one step = s RHS evaluations for Runge-Kutta, one order-p Taylor expansion for heyoka)"),
    Column("rejected_steps", "INTEGER", "", "rejected steps where the library reports them"),
    Column("peak_rss_mb", "REAL", "MB", "peak resident memory of the worker after the run"),
    Column("cpu_time_ci95_rel", "REAL", "", "relative half-width of the distribution-free 95 % confidence interval of the median CPU time (order statistics, bench.run.timing.median_ci95): the stated precision of cpu_time_s; NULL with fewer than 6 timed repeats (no such interval exists) and in rows of an older database"),
    Column("cpu_time_repeats_s", "TEXT", "s", "the timed repeats' CPU times, a JSON list of seconds in the order they were measured (what a rank test between two runs needs)"),
    Column("calibration_cpu_s", "REAL", "s", "CPU time of a fixed compiled loop (bench.run.calibration) timed in the worker process that made the run: divide cpu_time_s by it to compare runs of two machines"),
    Column("batch_members", "INTEGER", "", "ensemble members run and timed together as one batch (bench.run.ensemble_jobs): the row's cpu_time_s, wall_time_s, their spreads, cpu_time_repeats_s and compile_time_s are the batch's divided by this count, an equal share (repeats and cpu_time_ci95_rel are the batch's); NULL for a run timed alone"),
)

COLUMN_NAMES: tuple[str, ...] = tuple(column.name for column in COLUMNS)
STATUS_TIMEOUT = "timeout"
RUN_STATUSES: tuple[str, ...] = ("ok", "diverged", "failed", STATUS_TIMEOUT)
"""Every value of the ``status`` column: ok; diverged (the state became non-finite; verdicts up to the
divergence); failed (an error, with the reason in ``message``); timeout (stopped at the per-run time limit,
``run_timeout_s``, given in ``message``)."""
VERDICT_COLUMNS: tuple[str, ...] = (
    "energy_max_rel_error",
    "energy_drift_per_s",
    "energy_max_rel_error_steps",
    "precession_rate_error",
    "precession_rate_error_rad_s",
    "precession_rate_error_earth",
    "precession_rate_ref_error",
    "precession_rate_ref_error_rad_s",
    "precession_rate_ref_error_earth",
    "analytic_gap_exact",
    "analytic_gap_seed",
    "reference_error",
    "energy_balance_max_rel_error",
    "canonical_angular_momentum_ref_error",
    "semi_minor_axis_ref_error",
)
"""Accuracy columns: deterministic, identical bit for bit for the same matrix on the same machine."""
OPTIONAL_VERDICT_COLUMNS: dict[str, str] = {
    "energy_max_rel_error_steps": "streamed by the fixed-step loops only, in matrices with step_energy = true",
}
"""Verdict columns a matrix may leave out (``step_energy = false``, ``bench.run.matrix``) → where they are
computed. Comparisons of two runs (``results --compare``, ``history``, ``check --baseline``) compare them only
where both rows hold a value: NULL on one side is the matrix's choice, not a change of the code."""

DECLARED_FACTS: dict[str, str] = {
    "family": "family",
    "declared_order": "order",
    "stages": "stages",
    "adaptive": "adaptive",
    "stability_limit_kh": "stability_limit_kh",
}
"""Results column → the ``integrators.Integrator`` class attribute it stores."""

SCHEMA_VERSION = 6
"""Version of ``COLUMNS`` (stored as the database's ``PRAGMA user_version``)."""
SCENE_KEY_MIGRATION = (
    "runs and adequacy rows lack scene_key: added, and filled for the old rows of a built-in scene (or its "
    "-azψ variant) where a row's run key proves the row was made with that scene's present physics; NULL where "
    "it cannot be proved (inline scenes, changed built-in scenes): such rows are a scene of unknown physics, "
    "shown as 'name [unknown physics]' beside a name's known keys, never used by advise, and matched by "
    "results --compare only with rows of unknown physics"
)
TIMING_MIGRATION = (
    "runs lack the timing protocol's precision, repeats and machine calibration (cpu_time_ci95_rel, "
    "cpu_time_repeats_s, calibration_cpu_s): added as NULL columns, unknown for the old rows; their "
    "compile_time_s is wall time (CPU time from version 4 on)"
)
VERDICTS_OF_REAL_PENDULUMS_MIGRATION = (
    "runs lack energy_balance_max_rel_error (the energy balance of models that conserve no energy), "
    "canonical_angular_momentum_ref_error and semi_minor_axis_ref_error (the swing's ellipse against the "
    "reference): added as NULL columns, unknown for the old rows"
)
ENSEMBLE_MIGRATION = (
    "runs lack ensemble, ensemble_member and ensemble_setting (which ensemble a row's scene is a member of, its "
    "swept values and the setting asked for): "
    "added as NULL columns, right for the old rows, none of which belonged to an ensemble"
)
BATCH_MIGRATION = (
    "runs lack batch_members (the members of an ensemble's batch a row's cost is a share of): added as a NULL "
    "column, right for the old rows, each of which was timed alone"
)
MIGRATIONS: dict[int, str] = {
    1: "runs lack the declared integrator facts (declared_order, stages, adaptive, stability_limit_kh) and the "
       "precession errors in rad/s and relative to Ω_E (precession_rate_error_rad_s, _earth, "
       "precession_rate_ref_error_rad_s, _earth): added as NULL columns, unknown for the old rows; and, as for "
       "version 2, " + SCENE_KEY_MIGRATION + "; and " + VERDICTS_OF_REAL_PENDULUMS_MIGRATION + "; and "
       + TIMING_MIGRATION + "; and " + ENSEMBLE_MIGRATION + "; and " + BATCH_MIGRATION,
    2: SCENE_KEY_MIGRATION + "; and " + VERDICTS_OF_REAL_PENDULUMS_MIGRATION + "; and " + TIMING_MIGRATION
       + "; and " + ENSEMBLE_MIGRATION + "; and " + BATCH_MIGRATION,
    3: VERDICTS_OF_REAL_PENDULUMS_MIGRATION + "; and " + TIMING_MIGRATION + "; and " + ENSEMBLE_MIGRATION
       + "; and " + BATCH_MIGRATION,
    4: ENSEMBLE_MIGRATION + "; and " + BATCH_MIGRATION,
    5: BATCH_MIGRATION,
}
"""Older schema version → what a database written under it lacks (the store adds the missing columns)."""


def declared_facts(integrator: Any) -> dict[str, Any]:
    """The integrator's declared facts as results-column values (``DECLARED_FACTS``; a bool as 0/1)."""
    facts = {column: getattr(integrator, attribute, None) for column, attribute in DECLARED_FACTS.items()}
    facts["adaptive"] = None if facts["adaptive"] is None else int(bool(facts["adaptive"]))
    return facts


def setting_label(kh: float | None, tol: float | None) -> str:
    """``tol=1e-08`` for an adaptive run, ``kh=0.125`` for a fixed-step one (missing values are None or NaN)."""
    return f"tol={tol:g}" if is_present(tol) else f"kh={kh:.4g}"


def is_present(value: Any) -> bool:
    """Not None, not NaN (pandas' NA reads as missing too)."""
    try:
        return value is not None and not math.isnan(value)
    except TypeError:
        return False


def markdown_table() -> str:
    """The column table of bench/README.md "Results table" (``|`` in a description escaped for Markdown)."""
    lines = ["| column | unit | meaning |", "|---|---|---|"]
    lines += [f"| `{c.name}` | {c.unit or '–'} | {c.description.replace('|', chr(92) + '|')} |" for c in COLUMNS]
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown_table())
