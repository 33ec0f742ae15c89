"""Model adequacy: what a scene would get wrong with another model of the hierarchy, measured, not argued.

The models form a hierarchy (models/README.md "The models") that each model declares (``Model.refines``;
``models.simpler_models``, ``models.richer_models``): linear planar (seed eqs. 6-7) < the seed's nonlinear
planar (eqs. 4-5) < the spherical pendulum with the full rotation vector < the same on an anisotropic support;
the anisotropic and the damped linear models refine the linear one, the driven model the damped one. For a
scene, every pair of models in which the scene's model takes part is integrated with the reference integrator on
the scene's grid (each run is a cached ``bench.problems.reference`` of the scene with the model replaced) and
compared, except where the richer model of a pair is its parent at the scene's parameters
(``Model.adds_parameters`` all at their defaults):

* ``precession_rate_diff``: (rate of the simpler model − rate of the richer) / (Ω_E|sin φ|), signed, from the
  turning points as in ``bench.verdicts``;
* ``trajectory_gap``: max over the grid of |r_simpler − r_richer| / A.

Rows where the scene's model is the richer one say what each simpler model gets wrong (the simpler model is
not enough if these exceed what the scene measures); for scenes on a planar model, rows where the scene's
model is the simpler one say what it leaves out compared with the richer models (``scene_model`` tells which
side of the pair the scene is on). Leading-order expectations are given where the physics provides them:
planar vs spherical differ in rate by the Airy term −sign(sin φ)(3/8)θ₀² (models/README.md "Airy precession";
Olsson, Am. J. Phys. 49, 531, 1981) and in swing frequency by the finite-amplitude term k θ₀²/16 (Landau &
Lifshitz, Mechanics, §28, eq. 28.13), which moves the trajectories apart by ≈ 2|sin(½ k θ₀² t / 16)| · A.

``python -m foucault_bench.bench.verdicts.adequacy`` prints the table of the built-in scenes (references from the
cache or computed).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from foucault_bench.bench.problems.reference import Reference, reference_for
from foucault_bench.bench.problems.scenes import Scene
from foucault_bench.bench.verdicts.columns import max_position_gap
from foucault_bench.bench.problems.turning_points import rate_scale
from foucault_bench.models import MODELS, get_model, richer_models, simpler_models
from foucault_bench.models.parameters import airy_fraction


def model_adequacy(scene: Scene) -> list[dict[str, Any]]:
    """One row per pair (richer model, simpler model) of the hierarchy that contains the scene's model.

    Columns: ``scene``, ``model`` (the richer model of the pair: the scene's own model whenever it is the richer
    one), ``simpler_model``, ``scene_model``, ``precession_rate_diff``, ``trajectory_gap``,
    ``expected_rate_diff`` and ``expected_trajectory_gap`` (leading-order theory, NaN where none applies), and
    ``note``. A scene whose model neither refines nor is refined by another gets no rows.
    """
    if scene.model not in MODELS:
        return []
    pairs = [(scene.model, simpler) for simpler in simpler_models(scene.model)]
    pairs += [(richer, scene.model) for richer in richer_models(scene.model)]
    pairs = [(richer, simpler) for richer, simpler in pairs if not get_model(richer).equals_parents_at(scene.params)]
    references = {name: _reference_with_model(scene, name) for pair in pairs for name in pair}
    return [_row(scene, richer, simpler, references[richer], references[simpler]) for richer, simpler in pairs]


def _reference_with_model(scene: Scene, model: str) -> Reference:
    variant = scene if model == scene.model else dataclasses.replace(scene, model=model, name=f"{scene.name}.{model}")
    return reference_for(variant)


def _planar_against_sphere(richer: str, simpler: str) -> bool:
    return get_model(richer).constrained_to_sphere and not get_model(simpler).constrained_to_sphere


def expected_rate_diff(scene: Scene, richer: str, simpler: str) -> float:
    """Leading-order (simpler − richer) rate difference / (Ω_E|sin φ|): the Airy term for planar vs spherical."""
    if _planar_against_sphere(richer, simpler):
        airy = airy_fraction(scene.params.swing_angle_rad)
        return -math.copysign(1.0, scene.params.latitude_deg) * airy if scene.params.latitude_deg else 0.0
    return math.nan


def expected_trajectory_gap(scene: Scene, richer: str, simpler: str) -> float:
    """Leading-order gap / A between a planar model and the spherical one at the end of the scene: the phase
    the finite-amplitude frequency shift k θ₀²/16 accumulates, 2|sin(½ Δφ)| (its max over time while Δφ < π)."""
    if _planar_against_sphere(richer, simpler):
        params = scene.params
        phase = params.pendulum_frequency_rad_s * params.swing_angle_rad**2 / 16.0 * scene.duration_s
        return 2.0 * abs(math.sin(0.5 * phase)) if phase < math.pi else 2.0
    return math.nan


def _row(scene: Scene, richer: str, simpler: str, richer_reference: Reference,
         simpler_reference: Reference) -> dict[str, Any]:
    rate_diff = (simpler_reference.precession_rate_rad_s - richer_reference.precession_rate_rad_s) / rate_scale(
        scene.params)
    gap = max_position_gap(simpler_reference.y, richer_reference.y, scene.params.amplitude_m)
    expected_rate = expected_rate_diff(scene, richer, simpler)
    expected_gap = expected_trajectory_gap(scene, richer, simpler)
    side = "the scene's model" if richer == scene.model else "what the scene's model leaves out"
    note = (f"{simpler} vs {richer} ({side}): precession rate differs by {rate_diff:+.2e} Ω_E|sin φ|, trajectories "
            f"by up to {gap:.2e} A over {scene.duration_s:g} s")
    if math.isfinite(expected_rate):
        note += (f"; leading order: Airy {expected_rate:+.2e} (θ₀ = {scene.params.swing_angle_rad:.3g}), "
                 f"finite-amplitude period {expected_gap:.2e} A")
    elif "seed_planar" in (richer, simpler):
        note += "; the seed's eqs. 4-5 add the vertical-Coriolis tension terms and conserve no energy"
    return {
        "scene": scene.name,
        "model": richer,
        "simpler_model": simpler,
        "scene_model": scene.model,
        "precession_rate_diff": float(rate_diff),
        "trajectory_gap": float(gap),
        "expected_rate_diff": float(expected_rate),
        "expected_trajectory_gap": float(expected_gap),
        "note": note,
    }


def adequacy_table(scenes: list[Scene]) -> list[dict[str, Any]]:
    """``model_adequacy`` rows of several scenes, in order."""
    return [row for scene in scenes for row in model_adequacy(scene)]


if __name__ == "__main__":  # python -m foucault_bench.bench.verdicts.adequacy: the table of the built-in scenes
    from foucault_bench.bench.problems.scenes import SCENES

    for entry in adequacy_table(list(SCENES.values())):
        print(f"{entry['scene']:16s} {entry['simpler_model']:>11s} vs {entry['model']:9s} "
              f"rate {entry['precession_rate_diff']:+.3e} (exp {entry['expected_rate_diff']:+.3e})  "
              f"gap {entry['trajectory_gap']:.3e} (exp {entry['expected_trajectory_gap']:.3e})")
