"""Fine's general RKN 5(4) pair (``integrators.rkn``, ``integrators.methods.fine_rkn5``): the local error of its
solution and of its estimate fall with the orders it declares on the linear model turning fast (a
velocity-dependent Coriolis force: the case a special RKN method cannot take), the adaptive run follows the
tolerance against the closed form, and a malformed pair is refused."""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np
import pytest

from foucault_bench.integrators import STATUS_FAILED, STATUS_OK, Problem, get_integrator
from foucault_bench.integrators.methods.fine_rkn5 import PAIR, FineRkn5
from foucault_bench.models import MODELS, PendulumParameters
from foucault_bench.models.analytic import linear_exact

FAST = PendulumParameters(length_m=3.0, latitude_deg=40.0, amplitude_m=0.3, earth_rate_rad_s=0.2 * math.sqrt(9.81 / 3.0))


def one_step(params, h):
    """One step from the release state in Python (the formulas of ``integrators.rkn``): (solution, estimate)."""
    model, p = MODELS["linear"], tuple(params.parameter_vector())
    c, abar, a, bbar, b, ebar, e = PAIR.arrays()
    r, v = params.initial_state()[:2], params.initial_state()[2:]
    k = []
    for i in range(PAIR.stages):
        position = r + c[i] * h * v + h * h * sum((abar[i, j] * k[j] for j in range(i)), np.zeros(2))
        velocity = v + h * sum((a[i, j] * k[j] for j in range(i)), np.zeros(2))
        k.append(np.array(model.acceleration(math, *position, *velocity, p)))
    new = np.concatenate([r + h * v + h * h * sum(bbar[j] * k[j] for j in range(PAIR.stages)),
                          v + h * sum(b[j] * k[j] for j in range(PAIR.stages))])
    estimate = np.concatenate([h * h * sum(ebar[j] * k[j] for j in range(PAIR.stages)),
                               h * sum(e[j] * k[j] for j in range(PAIR.stages))])
    return new, estimate


def test_local_errors_have_the_declared_orders() -> None:
    """Local errors over one step h, fitted per component over kh = 0.2, 0.1, 0.05: the lowest order among the
    velocity components is p + 1 (the positions' is at least that: O(h^(p+2)) in x here), and the estimate's
    lowest is q + 1."""
    k = FAST.pendulum_frequency_rad_s
    steps = np.array([0.2, 0.1, 0.05]) / k
    errors, estimates = [], []
    for h in steps:
        new, estimate = one_step(FAST, h)
        errors.append(np.abs(new - linear_exact(FAST, np.array([0.0, h]))[-1]))
        estimates.append(np.abs(estimate))
    slopes = np.polyfit(np.log(steps), np.log(np.array(errors)), 1)[0]
    estimate_slopes = np.polyfit(np.log(steps), np.log(np.array(estimates)), 1)[0]
    assert abs(slopes[2:].min() - (PAIR.order + 1)) < 0.15 and slopes[:2].min() > PAIR.order + 0.8, slopes
    assert abs(estimate_slopes.min() - (PAIR.error_order + 1)) < 0.15, estimate_slopes


def test_the_pair_is_first_same_as_last_and_a_broken_pair_is_refused() -> None:
    assert PAIR.first_same_as_last and PAIR.stages == 7
    broken = list(PAIR.velocity_weights)
    broken[0] += Fraction(1, 1000)
    with pytest.raises(ValueError, match="Σb"):
        dataclasses.replace(PAIR, velocity_weights=tuple(broken))


def test_the_adaptive_run_follows_the_tolerance() -> None:
    params = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
    t_out = np.linspace(0.0, 5.0 * params.small_swing_period_s, 41)
    exact = linear_exact(params, t_out)
    integrator = get_integrator("fine_rkn5")
    errors = []
    for tol in (1e-6, 1e-9, 1e-12):
        solution = integrator.solve(Problem(MODELS["linear"], params, t_out), tol=tol)
        assert solution.status == STATUS_OK, solution.message
        assert solution.nfev == 1 + 6 * (solution.steps + solution.rejected_steps)
        errors.append(float(np.abs(solution.y[:, :2] - exact[:, :2]).max() / 3.0))
        assert errors[-1] < 100 * tol
    assert errors[0] > errors[1] > errors[2]
    failed = FineRkn5(max_steps=3).solve(Problem(MODELS["linear"], params, t_out), tol=1e-9)
    assert failed.status == STATUS_FAILED and np.all(np.isnan(failed.y[-1]))
