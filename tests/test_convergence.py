"""The convergence fit (bench.verdicts.convergence.observed_order) on a real clean sweep and on sweeps with a
pre-asymptotic start and a round-off floor, and the CI gate's min_order bound on the real sweep."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.gate.evaluate import evaluate
from foucault_bench.bench.gate.thresholds import parse_thresholds
from foucault_bench.bench.problems.reference import reference_for
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.verdicts.columns import compute_verdicts
from foucault_bench.bench.verdicts.convergence import observed_order
from foucault_bench.integrators import get_integrator


def default_matrix_sweep(scene_name: str, integrator_name: str) -> pd.DataFrame:
    """The default matrix's runs of one integrator on one scene, solved and judged as the runner does (without
    the timing repeats): step, status and reference error per run."""
    specs = [spec for spec in load_matrix("default").runs
             if spec.scene.name == scene_name and spec.integrator == integrator_name]
    integrator = get_integrator(integrator_name)
    rows = []
    for spec in specs:
        solution = integrator.solve(spec.scene.problem(), step_s=spec.step_s, tol=None, monitor=True)
        verdicts = compute_verdicts(spec.scene, solution, reference_for(spec.scene))
        rows.append({"scene": scene_name, "integrator": integrator_name, "model": spec.scene.model,
                     "family": integrator.family, "status": solution.status, "kh": spec.kh, "tol": np.nan,
                     "step_s": solution.step_size_s, "reference_error": verdicts["reference_error"],
                     "message": solution.message})
    return pd.DataFrame(rows)


def test_rk4_on_airy_3m_is_fitted_and_passes_a_min_order_gate() -> None:
    sweep = default_matrix_sweep("airy_3m", "rk4")
    assert len(sweep) == 9 and (sweep["status"] == "ok").all()
    errors = sweep["reference_error"].to_numpy(float)
    steps = sweep["step_s"].to_numpy(float)
    # the sweep of the issue: a steep start at the coarse end, then an error that falls by six decades
    assert np.log10(errors[errors <= 0.1].max() / errors.min()) > 6
    order = observed_order(steps, errors)
    assert order == pytest.approx(4.0, abs=0.25)  # fourth order; the finest steps are still approaching 4
    thresholds = parse_thresholds({"matrix": "default", "bound": [{
        "scene": "airy_3m", "integrator": "rk4", "column": "reference_error", "min_order": 3.5,
        "basis": "theory: RK4 is fourth order"}]})
    (outcome,) = evaluate(thresholds, sweep)
    assert outcome.passed, outcome


def steep_start_then_order(h: np.ndarray, order: int) -> np.ndarray:
    """C hᵖ with a higher-order term that dominates at the coarse steps (local slopes from p + 2 down to p)."""
    return h**order * (1.0 + (h / 0.05) ** 2)


@pytest.mark.parametrize("order", [1, 2, 4])
def test_a_steep_pre_asymptotic_start_is_not_taken_for_round_off(order: int) -> None:
    h = 0.4 * 2.0 ** -np.arange(0, 10)
    assert observed_order(h, steep_start_then_order(h, order)) == pytest.approx(order, abs=0.1)


@pytest.mark.parametrize("order", [1, 2, 4])
def test_points_on_a_flat_round_off_floor_are_dropped(order: int) -> None:
    h = 0.4 * 2.0 ** -np.arange(0, 16)
    rng = np.random.default_rng(order)
    floor = 1e-13 * (1.0 + 0.5 * rng.random(h.size))  # flat, noisy
    errors = steep_start_then_order(h, order) + floor
    assert observed_order(h, errors) == pytest.approx(order, abs=0.1)


def test_a_sweep_entirely_on_the_floor_or_growing_has_no_order() -> None:
    h = 0.1 * 2.0 ** -np.arange(0, 8)
    assert np.isnan(observed_order(h, 1e-14 * h**-0.5))  # round-off grows as h shrinks
    assert np.isnan(observed_order(h, np.full(h.size, 3e-15)))  # flat
