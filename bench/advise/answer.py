"""The answer of ``advise``: the cheapest stored run meeting the target, the next ones, the model the scene needs
and notes on the rows left out, after a search when no stored run meets it (``bench.advise.search``)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from foucault_bench.bench.advise.model import latest_adequacy_rows, model_advice
from foucault_bench.bench.advise.ranking import cheapest_per_integrator, run_record, same_name_notes, stored_runs
from foucault_bench.bench.advise.search import search
from foucault_bench.bench.advise.target import Target
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.verdicts.nonconservative import advise_note
from foucault_bench.bench.verdicts.pareto import cheapest_meeting, cost_column, usable_runs

NEXT = 2
"""Alternatives shown after the recommendation."""


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
    ensemble: str = ""
    """With ``--worst``: the ensemble answered for (``scene`` is then its recommended worst member)."""

    def as_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene.name, "scene_key": scene_key(self.scene), "model": self.scene.model,
            "target": {"metric": self.target.metric, "value": self.target.value},
            "cost_column": self.cost, "recommended": self.recommended, "next": self.alternatives,
            "model_advice": self.model, "stored_runs": self.stored_runs, "runs_meeting_target": self.meeting,
            "best_reached": self.best_reached, "search": self.search, "notes": self.notes,
            **({"ensemble": self.ensemble} if self.ensemble else {}),
        }


def advise(store: ResultsStore, scene: Scene, target: Target, *, search_jobs: int | None = 1,
           integrators: tuple[str, ...] | None = None, progress: bool = False) -> Advice:
    """The cheapest stored run of ``scene`` meeting ``target`` (after a ``search`` among ``integrators``, default
    those of the default matrix, when none does and ``search_jobs`` is not None)."""
    runs = stored_runs(store, scene)
    search_summary = None
    if not cheapest_per_integrator(runs, target) and search_jobs is not None:
        started = time.perf_counter()
        matrix_ids, planned = search(store, scene, target, runs, jobs=search_jobs, integrators=integrators,
                                     progress=progress)
        runs = stored_runs(store, scene)
        search_summary = {"runs": planned, "matrix_ids": matrix_ids,
                          "seconds": round(time.perf_counter() - started, 1)}
    cost = cost_column(runs) if not runs.empty else "wall_time_s"
    ranked = cheapest_per_integrator(runs, target)
    records = [run_record(row, target.metric, cost) for row in ranked[:1 + NEXT]]
    usable = usable_runs(runs, target.metric, cost) if not runs.empty else runs
    best = None
    if not records and not usable.empty:
        best = run_record(runs.loc[usable["error"].idxmin()], target.metric, cost)
    notes = same_name_notes(store.frame(all_runs=True), scene)
    notes += [note] if (note := advise_note(runs, target.value, target.metric)) else []
    if not runs.empty:
        from foucault_bench.bench.provenance import code_version

        stale = runs["code_version"].notna() & (runs["code_version"] != code_version())
        if stale.any():
            notes.append(f"{int(stale.sum())} of the {len(runs)} stored runs come from another code version "
                         "(their numbers may differ from what this code computes)")
    return Advice(scene, target, cost, records[0] if records else None, records[1:],
                  model_advice(latest_adequacy_rows(store, runs, scene) if not runs.empty else pd.DataFrame(), scene,
                               target),
                  len(runs), len(cheapest_meeting(runs, target.metric, target.value)) if not runs.empty else 0,
                  best, search_summary, notes)
