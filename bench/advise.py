"""``foucault-bench advise``: for one scene and one target error, the cheapest integrator and setting, measured.

The answer comes from the results store: among the stored runs of the scene (every matrix run; the rows of the
scene's physics, ``bench.problems.scene_key``, whatever name they were stored under, so that a name reused with
other physics is never mixed in; the latest row of each integrator and setting), the cheapest ok run whose error
meets the target (``bench.verdicts.pareto``; cost = CPU time where stored, else wall time), its measured cost,
the next two (the cheapest runs of two other integrators meeting it), and which model the scene needs at that
accuracy (from the model-adequacy rows the runner stores for the scene's physics: what a simpler model gets
wrong, or what the scene's model leaves out, compared with the target). Its cost counts are RHS evaluations, or
Taylor steps for the taylor family.

When no stored run meets the target, ``search`` runs a small targeted search and stores its runs like any
matrix run (``bench.run.runner.run_matrix``, a matrix named ``advise-<scene>``): for each integrator of the
default matrix, at most ``MAX_ROUNDS`` runs, all integrators of a round in parallel. A fixed-step method of
order p starts at ``START_KH`` (or k·Δ, the largest step the grid allows) and moves to
kh · (½ target / error)^(1/p), the step its leading error term C·khᵖ predicts for half the target (Hairer,
Nørsett & Wanner, *Solving ODEs I*, §II.3: the global error of an order-p method is O(hᵖ)); once a step meets
the target, the next round tries the geometric mean of it and the coarser step that missed (a bisection in
log kh) to find a cheaper one. An adaptive method starts at tol = target and moves to tol · ½ target / error
(the error of a tolerance-controlled run is roughly proportional to the tolerance; same book, §II.4), with the
same bisection once one meets it. A fixed-step setting whose step count would exceed ``MAX_STEPS`` is not run.
"""

from __future__ import annotations

import json
import math
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.problems.scenes import SCENES, Scene, scene_from_mapping
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.verdicts.pareto import ERROR_METRICS, cheapest_meeting, cost_column, usable_runs

MAX_ROUNDS = 4
"""Runs per integrator in a search, at most."""
START_KH = 0.25
"""First step of a fixed-step search (k·h), unless the scene's grid allows less."""
MAX_STEPS = 20_000_000
"""A fixed-step setting needing more steps than this is left out of a search (tens of seconds per run)."""
SAFETY = 0.5
"""A search aims at this fraction of the target, so that the next run meets it despite higher-order terms."""
TOL_RANGE = (1e-14, 1e-3)
"""Tolerances a search may ask for: double precision ends below 1e-14."""
NEXT = 2
"""Alternatives shown after the recommendation."""
TAYLOR_FAMILY = "taylor"
"""The family whose ``nfev`` counts Taylor steps, not right-hand-side evaluations (``bench.schema`` ``nfev``)."""


@dataclass(frozen=True)
class Target:
    """An error column (``bench.verdicts.pareto.ERROR_METRICS``) and the largest value accepted."""

    metric: str
    value: float


@dataclass
class Advice:
    """The answer, as plain data (``as_dict`` is the ``--json`` output)."""

    scene: Scene
    target: Target
    cost: str
    recommended: dict[str, Any] | None
    alternatives: list[dict[str, Any]]
    model: dict[str, Any]
    stored_runs: int
    meeting: int
    best_reached: dict[str, Any] | None = None
    search: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene.name, "scene_key": scene_key(self.scene), "model": self.scene.model,
            "target": {"metric": self.target.metric, "value": self.target.value},
            "cost_column": self.cost, "recommended": self.recommended, "next": self.alternatives,
            "model_advice": self.model, "stored_runs": self.stored_runs, "runs_meeting_target": self.meeting,
            "best_reached": self.best_reached, "search": self.search, "notes": self.notes,
        }


# --------------------------------------------------------------------------------------------------------------
# input
# --------------------------------------------------------------------------------------------------------------
def parse_target(text: str) -> tuple[Target | None, list[str]]:
    """``METRIC=VALUE`` → a target, or the problems with it."""
    metric, equals, value_text = text.partition("=")
    metric = metric.strip()
    problems = []
    if not equals:
        return None, [f"--target must be METRIC=VALUE (e.g. reference_error=1e-6), got {text!r}"]
    if metric not in ERROR_METRICS:
        problems.append(f"--target: unknown metric {metric!r}; metrics: {', '.join(ERROR_METRICS)}")
    try:
        value = float(value_text)
    except ValueError:
        return None, problems + [f"--target: {value_text.strip()!r} is not a number"]
    if not (math.isfinite(value) and value > 0):
        problems.append(f"--target: the target error must be a finite number > 0, got {value_text.strip()}")
    return (Target(metric, value) if not problems else None), problems


def resolve_scene(name: str, matrix_file: str | None) -> tuple[Scene | None, list[str]]:
    """A built-in scene, or an inline ``[scene.NAME]`` of ``matrix_file``; or the problems."""
    inline: dict[str, Any] = {}
    if matrix_file is not None:
        path = Path(matrix_file)
        try:
            document = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError) as error:
            return None, [f"--matrix {matrix_file}: cannot read it: {error}"]
        except tomllib.TOMLDecodeError as error:
            return None, [f"--matrix {matrix_file}: not valid TOML: {error}"]
        inline = document.get("scene", {}) if isinstance(document.get("scene", {}), dict) else {}
    if name in inline:
        if not isinstance(inline[name], dict):
            return None, [f"--matrix {matrix_file}: scene.{name} must be a table of scene fields"]
        try:
            return scene_from_mapping(name, inline[name]), []
        except InputError as error:
            return None, [f"--matrix {matrix_file}: scene.{name}: {problem}" for problem in error.problems]
    if name in SCENES:
        return SCENES[name], []
    known = sorted(set(SCENES) | set(inline))
    return None, [f"--scene: unknown scene {name!r}; scenes: {', '.join(known)}"
                  + ("" if matrix_file else " (or define it in a matrix file given with --matrix)")]


def metric_problem(scene: Scene, target: Target) -> str | None:
    """Why ``target.metric`` does not measure an integrator on ``scene`` (None when it does)."""
    from foucault_bench.bench.verdicts.columns import released_from_rest

    definition = ERROR_METRICS[target.metric]
    if not definition.applies(scene.model):
        return f"--target: {target.metric} does not exist for scene {scene.name!r} ({scene.model} model): " \
               f"{definition.why_not}"
    if target.metric == "analytic_gap_exact" and not released_from_rest(scene.params):
        return f"--target: analytic_gap_exact does not exist for scene {scene.name!r}: the exact solution " \
               "assumes a release from rest"
    return None


# --------------------------------------------------------------------------------------------------------------
# the stored runs
# --------------------------------------------------------------------------------------------------------------
def stored_runs(store: ResultsStore, scene: Scene) -> pd.DataFrame:
    """Every stored row of ``scene`` (the same physics: ``bench.problems.scene_key``, whatever its name), the
    latest of each integrator and setting, with the code version of its matrix run."""
    rows = store.frame(all_runs=True)
    rows = rows[rows["scene_key"] == scene_key(scene)]
    versions = store.matrix_runs().set_index("matrix_id")["code_version"]
    rows = rows.assign(code_version=rows["matrix_id"].map(versions))
    setting = [setting_label(kh, tol) for kh, tol in zip(rows["kh"], rows["tol"], strict=True)]
    return rows.assign(_setting=setting).drop_duplicates(["integrator", "_setting"], keep="last") \
               .drop(columns="_setting").reset_index(drop=True)


def same_name_notes(rows: pd.DataFrame, scene: Scene) -> list[str]:
    """What the stored rows named like ``scene`` but of other or unknown physics are (never used)."""
    named = rows[rows["scene"] == scene.name]
    other = named["scene_key"].notna() & (named["scene_key"] != scene_key(scene))
    unknown = named["scene_key"].isna()
    notes = []
    if other.any():
        notes.append(f"{int(other.sum())} stored runs named {scene.name} have other physics "
                     f"({named.loc[other, 'scene_key'].nunique()} other scene(s) of that name): not used")
    if unknown.any():
        notes.append(f"{int(unknown.sum())} stored runs named {scene.name} come from an older database whose "
                     "physics could not be recovered: not used")
    return notes


def _run_record(row: pd.Series, metric: str, cost: str) -> dict[str, Any]:
    """A stored run as the answer shows it: ``integrator`` and ``kh`` or ``tol``, error, costs, provenance."""
    record: dict[str, Any] = {"integrator": row["integrator"], "family": row["family"]}
    record.update({"tol": float(row["tol"])} if pd.notna(row["tol"]) else {"kh": float(row["kh"])})

    def number(column: str) -> float | None:
        value = row.get(column)
        return None if value is None or pd.isna(value) else float(value)

    record.update({metric: number(metric), "cost_s": number(cost), "wall_time_s": number("wall_time_s"),
                   "cpu_time_s": number("cpu_time_s"), "nfev": number("nfev"), "steps": number("steps"),
                   "matrix_id": row["matrix_id"]})
    return record


def _ranked(rows: pd.DataFrame, target: Target) -> list[pd.Series]:
    """The cheapest meeting run of each integrator, cheapest first (as full rows)."""
    if rows.empty:
        return []
    met = cheapest_meeting(rows, target.metric, target.value).drop_duplicates("integrator")
    return [rows.loc[index] for index in met.index]


# --------------------------------------------------------------------------------------------------------------
# the model
# --------------------------------------------------------------------------------------------------------------
def model_advice(adequacy: pd.DataFrame, scene: Scene, target: Target) -> dict[str, Any]:
    """Which model the scene needs at the target, from its model-adequacy rows (``bench.verdicts.adequacy``):
    the precession-rate difference for a precession target, the trajectory gap otherwise, compared with the
    target."""
    quantity, unit = (("precession_rate_diff", "Ω_E|sin φ|") if target.metric.startswith("precession")
                      else ("trajectory_gap", "A"))
    if adequacy.empty:
        return {"needed": scene.model, "text": "no model-adequacy rows stored for this scene"}
    if "scene_key" not in adequacy.columns:  # rows of no known physics
        return {"needed": scene.model, "text": "no model-adequacy rows stored for this scene's physics"}
    rows = adequacy[adequacy["scene_key"] == scene_key(scene)]
    simpler = rows[rows["model"] == scene.model]  # what each simpler model gets wrong
    richer = rows[rows["simpler_model"] == scene.model]  # what the scene's model leaves out
    what = "precession rate" if quantity == "precession_rate_diff" else "trajectory"
    for row in sorted(richer.itertuples(), key=lambda row: -_model_rank(row.model)):
        gap = abs(float(getattr(row, quantity)))
        if gap > target.value:
            return {"needed": row.model, "text": f"{row.model} is needed: the scene's {scene.model} model leaves "
                    f"out {gap:.2g} {unit} of the {what} (> {target.value:g}); the runs measure the {scene.model} "
                    "model's solution, not the pendulum's"}
    enough = scene.model
    details = []
    for row in sorted(simpler.itertuples(), key=lambda row: _model_rank(row.simpler_model)):
        gap = abs(float(getattr(row, quantity)))
        details.append(f"the {row.simpler_model} model would be off by {gap:.2g} {unit} in the {what}")
        if gap <= target.value and _model_rank(row.simpler_model) < _model_rank(enough):
            enough = row.simpler_model
    leaves_out = [f"the {row.model} model changes the {what} by {abs(float(getattr(row, quantity))):.2g} {unit}"
                  for row in richer.itertuples()]
    if not (leaves_out or details):
        return {"needed": enough, "text": f"{scene.model} (no simpler or richer model to compare with)"}
    verdict = "is needed" if enough == scene.model and details else "is enough"
    text = f"{enough} {verdict} at {target.value:g}: " + "; ".join(leaves_out + details)
    return {"needed": enough, "text": text}


def _model_rank(model: str) -> int:
    """Place of a model in ``models.MODELS``, simplest first (by the hierarchy ``Model.refines`` declares)."""
    from foucault_bench.models import MODELS

    order = list(MODELS)
    return order.index(model) if model in order else len(order)


def _adequacy_rows(store: ResultsStore, runs: pd.DataFrame, scene: Scene) -> pd.DataFrame:
    """The scene's adequacy rows (same physics, ``scene_key``) of the latest of its matrix runs that stored
    some."""
    key = scene_key(scene)
    for matrix_id in reversed(list(dict.fromkeys(runs["matrix_id"]))):
        rows = store.adequacy(matrix_id)
        if not rows.empty and "scene_key" in rows.columns and (rows["scene_key"] == key).any():
            return rows[rows["scene_key"] == key]
    return pd.DataFrame()


# --------------------------------------------------------------------------------------------------------------
# the answer
# --------------------------------------------------------------------------------------------------------------
def advise(store: ResultsStore, scene: Scene, target: Target, *, search_jobs: int | None = 1,
           integrators: tuple[str, ...] | None = None, progress: bool = False) -> Advice:
    """The cheapest stored run of ``scene`` meeting ``target`` (after a ``search`` among ``integrators``, default
    those of the default matrix, when none does and ``search_jobs`` is not None)."""
    runs = stored_runs(store, scene)
    search_summary = None
    if not _ranked(runs, target) and search_jobs is not None:
        started = time.perf_counter()
        matrix_ids, planned = search(store, scene, target, runs, jobs=search_jobs, integrators=integrators,
                                     progress=progress)
        runs = stored_runs(store, scene)
        search_summary = {"runs": planned, "matrix_ids": matrix_ids,
                          "seconds": round(time.perf_counter() - started, 1)}
    cost = cost_column(runs) if not runs.empty else "wall_time_s"
    ranked = _ranked(runs, target)
    records = [_run_record(row, target.metric, cost) for row in ranked[:1 + NEXT]]
    usable = usable_runs(runs, target.metric, cost) if not runs.empty else runs
    best = None
    if not records and not usable.empty:
        best = _run_record(runs.loc[usable["error"].idxmin()], target.metric, cost)
    notes = same_name_notes(store.frame(all_runs=True), scene)
    if not runs.empty:
        from foucault_bench.bench.provenance import code_version

        stale = runs["code_version"].notna() & (runs["code_version"] != code_version())
        if stale.any():
            notes.append(f"{int(stale.sum())} of the {len(runs)} stored runs come from another code version "
                         "(their numbers may differ from what this code computes)")
    return Advice(scene, target, cost, records[0] if records else None, records[1:],
                  model_advice(_adequacy_rows(store, runs, scene) if not runs.empty else pd.DataFrame(), scene,
                               target),
                  len(runs), len(cheapest_meeting(runs, target.metric, target.value)) if not runs.empty else 0,
                  best, search_summary, notes)


# --------------------------------------------------------------------------------------------------------------
# the search
# --------------------------------------------------------------------------------------------------------------
@dataclass
class _Probe:
    """One integrator's search: the settings tried and what they gave."""

    integrator: str
    adaptive: bool
    order: int | None
    tried: dict[float, float] = field(default_factory=dict)  # setting → error (inf: not ok)
    done: bool = False

    def next_setting(self, target: float, largest_kh: float, steps_per_kh: float) -> float | None:
        """The next kh or tol to run (None: stop). ``steps_per_kh``: steps of the scene at kh = 1."""
        if self.done:
            return None
        if not self.tried:
            first = min(max(target, TOL_RANGE[0]), TOL_RANGE[1]) if self.adaptive else min(START_KH, largest_kh)
            return self._allowed(first, steps_per_kh)
        meeting = {s: e for s, e in self.tried.items() if e <= target}
        missing = {s: e for s, e in self.tried.items() if e > target}
        if meeting:  # bisect (in log) between the cheapest meeting setting and the next coarser miss
            best = max(meeting)
            coarser = [s for s in missing if s > best]
            if not coarser:  # nothing coarser tried: the coarser setting the error model predicts
                ratio = SAFETY * target / max(meeting[best], 1e-300)
                proposal = best * (ratio if self.adaptive else ratio ** (1.0 / (self.order or 1)))
                proposal = min(proposal, TOL_RANGE[1] if self.adaptive else largest_kh)
                return proposal if proposal > 1.5 * best and proposal not in self.tried else None
            middle = math.sqrt(best * min(coarser))
            if middle in self.tried or min(coarser) / best < 1.5:
                return None
            return self._allowed(middle, steps_per_kh)
        last = min(self.tried)  # the finest setting tried so far
        error = self.tried[last]
        if not math.isfinite(error):
            proposal = last / 4.0
        elif self.adaptive:
            proposal = last * SAFETY * target / error
        else:
            proposal = last * (SAFETY * target / error) ** (1.0 / (self.order or 1))
        proposal = min(proposal, last / 1.5)
        if self.adaptive:
            proposal = max(proposal, TOL_RANGE[0])
            if proposal >= last:
                return None
        return self._allowed(proposal, steps_per_kh)

    def _allowed(self, setting: float, steps_per_kh: float) -> float | None:
        if not self.adaptive and steps_per_kh / setting > MAX_STEPS:
            return None
        return setting


def search(store: ResultsStore, scene: Scene, target: Target, runs: pd.DataFrame, *, jobs: int = 1,
           integrators: tuple[str, ...] | None = None, progress: bool = False) -> tuple[list[str], int]:
    """Run the targeted search (module docstring) with ``integrators`` (default: those of the default matrix);
    return the matrix ids it stored and how many runs it made."""
    from foucault_bench.bench.run.matrix import Matrix, RunSpec, code_version, load_matrix
    from foucault_bench.bench.run.runner import make_executor, run_matrix
    from foucault_bench.bench.run.timing import TimingPolicy
    from foucault_bench.integrators import REGISTRY

    names = integrators or list(dict.fromkeys(spec.integrator for spec in load_matrix("default").runs))
    probes = [_Probe(name, bool(REGISTRY[name].adaptive), REGISTRY[name].order) for name in names if name in REGISTRY]
    for probe in probes:  # what the store already says about each integrator
        for row in runs[runs["integrator"] == probe.integrator].itertuples():
            setting = row.tol if probe.adaptive else row.kh
            if pd.notna(setting):
                value = abs(getattr(row, target.metric))
                probe.tried[float(setting)] = value if row.status == "ok" and np.isfinite(value) else math.inf
    k = scene.params.pendulum_frequency_rad_s
    largest_kh = k * scene.output_interval_s
    steps_per_kh = k * scene.duration_s
    matrix_ids, planned = [], 0
    timing, code = TimingPolicy(), code_version()
    for round_number in range(MAX_ROUNDS):
        specs = []
        for probe in probes:
            setting = probe.next_setting(target.value, largest_kh, steps_per_kh)
            if setting is None:
                probe.done = True
                continue
            specs.append(RunSpec(scene=scene, integrator=probe.integrator, kh=None if probe.adaptive else setting,
                                 tol=setting if probe.adaptive else None, plugins=(), timing=timing,
                                 code_version=code))
        if not specs:
            break
        matrix = Matrix(name=f"advise-{scene.name}", description=f"advise search for {target.metric} <= "
                        f"{target.value:g}, round {round_number + 1}", source="foucault-bench advise",
                        scenes=(scene,), runs=tuple(specs), plugins=(), timing=timing)
        matrix_id = run_matrix(matrix, store, executor=make_executor(jobs), progress=progress)
        matrix_ids.append(matrix_id)
        planned += len(specs)
        rows = store.frame(matrix_id)
        for spec, probe in ((spec, next(p for p in probes if p.integrator == spec.integrator)) for spec in specs):
            row = rows[(rows["integrator"] == spec.integrator)].iloc[-1]
            value = abs(float(row[target.metric])) if pd.notna(row[target.metric]) else math.inf
            setting = cast(float, spec.tol if probe.adaptive else spec.kh)
            probe.tried[setting] = value if row["status"] == "ok" else math.inf
    return matrix_ids, planned


# --------------------------------------------------------------------------------------------------------------
# text
# --------------------------------------------------------------------------------------------------------------
def _cost_text(record: dict[str, Any], cost: str) -> str:
    """``CPU time 1.2 ms, 4000 RHS evaluations``; for the taylor family (heyoka), whose ``nfev`` counts Taylor
    steps (``bench.schema``), ``…, 300 Taylor steps``."""
    kind = "CPU time" if cost == "cpu_time_s" else "wall time"
    counted = "Taylor steps" if record.get("family") == TAYLOR_FAMILY else "RHS evaluations"
    evaluations = f", {record['nfev']:.0f} {counted}" if record.get("nfev") is not None else ""
    return f"{kind} {record['cost_s'] * 1e3:.3g} ms{evaluations}"


def _run_text(record: dict[str, Any], metric: str, cost: str) -> str:
    setting = setting_label(record.get("kh"), record.get("tol"))
    return f"{record['integrator']} {setting}: {metric} {record[metric]:.3g}, {_cost_text(record, cost)}"


def render_text(advice: Advice) -> str:
    """The answer as a few lines of text."""
    target = advice.target
    lines = [f"scene {advice.scene.name} ({advice.scene.model} model, physics key {scene_key(advice.scene)}), "
             f"target {target.metric} <= {target.value:g}"]
    if advice.search:
        lines.append(f"no stored run met the target: searched with {advice.search['runs']} runs in "
                     f"{advice.search['seconds']:g} s (stored as matrix runs {', '.join(advice.search['matrix_ids'])})")
    if advice.recommended is None:
        best = advice.best_reached
        lines.append("no run meets the target" + (f"; the best reached: {_run_text(best, target.metric, advice.cost)}"
                                                  if best else ""))
    else:
        lines.append(f"recommended: {_run_text(advice.recommended, target.metric, advice.cost)}")
        for index, record in enumerate(advice.alternatives):
            ratio = record["cost_s"] / advice.recommended["cost_s"]
            lines.append(f"{'next:' if index == 0 else '':12s} {_run_text(record, target.metric, advice.cost)} "
                         f"({ratio:.3g}× the cost)")
    lines.append(f"model: {advice.model['text']}")
    lines.append(f"from {advice.stored_runs} stored runs of {advice.scene.name}; {advice.meeting} meet the target")
    lines += [f"note: {note}" for note in advice.notes]
    return "\n".join(lines)


def render_json(advice: Advice) -> str:
    return json.dumps(advice.as_dict(), ensure_ascii=False)
