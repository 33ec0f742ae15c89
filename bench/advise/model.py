"""Which model a scene needs at a target error, from the model-adequacy rows stored for its physics
(``bench.verdicts.adequacy``): what a simpler model gets wrong, or what the scene's model leaves out."""

from __future__ import annotations

from typing import Any

import pandas as pd

from foucault_bench.bench.advise.target import Target
from foucault_bench.bench.problems.scene_key import scene_key
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.run.store import ResultsStore


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


def latest_adequacy_rows(store: ResultsStore, runs: pd.DataFrame, scene: Scene) -> pd.DataFrame:
    """The scene's adequacy rows (same physics, ``scene_key``) of the latest of its matrix runs that stored
    some."""
    key = scene_key(scene)
    for matrix_id in reversed(list(dict.fromkeys(runs["matrix_id"]))):
        rows = store.adequacy(matrix_id)
        if not rows.empty and "scene_key" in rows.columns and (rows["scene_key"] == key).any():
            return rows[rows["scene_key"] == key]
    return pd.DataFrame()
