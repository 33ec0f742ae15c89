"""``advise --worst``: for an ensemble and a target error, the cheapest integrator and setting whose worst member
meets the target, from the stored member rows (``bench.ensembles.summary``).

The rows: every stored row of the ensemble's members (by each member's physics, ``bench.problems.scene_key``),
the latest of each member, integrator and setting. Per integrator and setting, the worst member is the one with
the largest error (``bench.ensembles.summary.worst_rows``); only settings for which every member has an ok row
with a value count, since a missing member could be the worst. Among those worst-member rows the cheapest
meeting the target is recommended (``bench.verdicts.pareto.cheapest_meeting``, its cost the worst member's run's),
with the next two of other integrators; the model advice is that of the recommended worst member. No search
runs: an ensemble is many references (run its matrix first).
"""

from __future__ import annotations

import pandas as pd

from foucault_bench.bench.advise.answer import NEXT, Advice
from foucault_bench.bench.advise.model import latest_adequacy_rows, model_advice
from foucault_bench.bench.advise.ranking import run_record
from foucault_bench.bench.advise.target import Target
from foucault_bench.bench.ensembles.summary import ensemble_summary, worst_rows
from foucault_bench.bench.problems.scene import Scene
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.verdicts.pareto import cheapest_meeting, cost_column, usable_runs


def member_runs(store: ResultsStore, members: tuple[Scene, ...]) -> pd.DataFrame:
    """The latest stored row of each member (by physics), integrator and setting asked for."""
    rows = store.frame(all_runs=True)
    keys = {scene_key(member) for member in members}
    rows = rows[rows["scene_key"].isin(keys) & rows["ensemble_setting"].notna()]
    return rows.drop_duplicates(["scene_key", "integrator", "ensemble_setting"], keep="last").reset_index(drop=True)


def complete_worst_rows(rows: pd.DataFrame, metric: str, member_count: int) -> tuple[pd.DataFrame, int]:
    """The worst-member row of each integrator and setting whose ``member_count`` members all have an ok row
    with a finite ``metric``; and how many settings were left out for a missing member."""
    ok = rows[rows["status"] == "ok"]
    summary = ensemble_summary(ok, metric)
    complete = summary[(summary["members"] == member_count) & (summary["missing"] == 0)]
    worst = worst_rows(ok, metric)
    chosen = set(zip(complete["integrator"], complete["setting"], strict=True))
    keep = [(integrator, setting) in chosen
            for integrator, setting in zip(worst["integrator"], worst["ensemble_setting"], strict=True)]
    return worst[keep], len(summary) - len(complete)


def advise_worst(store: ResultsStore, ensemble: str, members: tuple[Scene, ...], target: Target) -> Advice:
    """The cheapest integrator and setting whose worst member of ``ensemble`` meets ``target`` (module
    docstring); ``Advice.scene`` is the recommended setting's worst member (the first member without one)."""
    rows = member_runs(store, members)
    worst, incomplete = complete_worst_rows(rows, target.metric, len(members)) if not rows.empty else (rows, 0)
    cost = cost_column(worst) if not worst.empty else "wall_time_s"
    met = cheapest_meeting(worst, target.metric, target.value).drop_duplicates("integrator") \
        if not worst.empty else worst
    ranked = [worst.loc[index] for index in met.index][:1 + NEXT]
    records = [{**run_record(row, target.metric, cost), "worst_member": row["scene"]} for row in ranked]
    by_key = {scene_key(member): member for member in members}
    scene = by_key[ranked[0]["scene_key"]] if ranked else members[0]
    best = None
    usable = usable_runs(worst, target.metric, cost) if not worst.empty else worst
    if not records and not usable.empty:
        row = worst.loc[usable["error"].idxmin()]
        best = {**run_record(row, target.metric, cost), "worst_member": row["scene"]}
    notes = [f"ensemble {ensemble}: {len(members)} members; each setting ranked by its worst member "
             f"({len(worst)} settings with every member stored)"]
    if incomplete:
        notes.append(f"{incomplete} settings left out: a member has no ok row with {target.metric}")
    scene_rows = rows[rows["scene_key"] == scene_key(scene)]
    adequacy = latest_adequacy_rows(store, scene_rows, scene) if not scene_rows.empty else pd.DataFrame()
    return Advice(scene, target, cost, records[0] if records else None, records[1:],
                  model_advice(adequacy, scene, target), len(rows), len(met), best, None, notes, ensemble)
