"""The answer of ``advise`` as text (a few lines) or as JSON (``Advice.as_dict``)."""

from __future__ import annotations

import json
from typing import Any

from foucault_bench.bench.advise.answer import Advice
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.schema import setting_label

TAYLOR_FAMILY = "taylor"
"""The family whose ``nfev`` counts Taylor steps, not right-hand-side evaluations (``bench.schema`` ``nfev``)."""


def _cost_text(record: dict[str, Any], cost: str) -> str:
    """``CPU time 1.2 ms, 4000 RHS evaluations``; for the taylor family (heyoka), whose ``nfev`` counts Taylor
    steps (``bench.schema``), ``…, 300 Taylor steps``; for a run timed in an ensemble's batch
    (``batch_members``), ``CPU time 1.2 ms (1/37 of its batch's), …``."""
    kind = "CPU time" if cost == "cpu_time_s" else "wall time"
    share = f" (1/{record['batch_members']} of its batch's)" if record.get("batch_members") else ""
    counted = "Taylor steps" if record.get("family") == TAYLOR_FAMILY else "RHS evaluations"
    evaluations = f", {record['nfev']:.0f} {counted}" if record.get("nfev") is not None else ""
    return f"{kind} {record['cost_s'] * 1e3:.3g} ms{share}{evaluations}"


def _run_text(record: dict[str, Any], metric: str, cost: str) -> str:
    setting = setting_label(record.get("kh"), record.get("tol"))
    worst = f" (worst member {record['worst_member']})" if record.get("worst_member") else ""
    return f"{record['integrator']} {setting}{worst}: {metric} {record[metric]:.3g}, {_cost_text(record, cost)}"


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
    lines.append(f"from {advice.stored_runs} stored runs of {advice.ensemble or advice.scene.name}; "
                 f"{advice.meeting} meet the target")
    lines += [f"note: {note}" for note in advice.notes]
    return "\n".join(lines)


def render_json(advice: Advice) -> str:
    return json.dumps(advice.as_dict(), ensure_ascii=False)
