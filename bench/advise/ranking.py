"""The stored runs ``advise`` answers from: the rows of the scene's physics, the latest of each integrator and
setting, and the cheapest of each integrator meeting the target (``bench.verdicts.pareto``)."""

from __future__ import annotations

from typing import Any

import pandas as pd

from foucault_bench.bench.advise.target import Target
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.bench.schema import setting_label
from foucault_bench.bench.verdicts.pareto import cheapest_meeting


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


def run_record(row: pd.Series, metric: str, cost: str) -> dict[str, Any]:
    """A stored run as the answer shows it: ``integrator`` and ``kh`` or ``tol``, error, costs, provenance."""
    record: dict[str, Any] = {"integrator": row["integrator"], "family": row["family"]}
    record.update({"tol": float(row["tol"])} if pd.notna(row["tol"]) else {"kh": float(row["kh"])})

    def number(column: str) -> float | None:
        value = row.get(column)
        return None if value is None or pd.isna(value) else float(value)

    record.update({metric: number(metric), "cost_s": number(cost), "wall_time_s": number("wall_time_s"),
                   "cpu_time_s": number("cpu_time_s"), "nfev": number("nfev"), "steps": number("steps"),
                   "matrix_id": row["matrix_id"]})
    members = number("batch_members")
    if members is not None:  # an ensemble member timed in a batch: its costs are an equal share of the batch's
        record["batch_members"] = int(members)
    return record


def cheapest_per_integrator(rows: pd.DataFrame, target: Target) -> list[pd.Series]:
    """The cheapest meeting run of each integrator, cheapest first (as full rows)."""
    if rows.empty:
        return []
    met = cheapest_meeting(rows, target.metric, target.value).drop_duplicates("integrator")
    return [rows.loc[index] for index in met.index]
