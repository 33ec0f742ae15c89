"""The compiled embedded Runge-Kutta driver against scipy: ``dopri5`` and ``dop853`` take the steps of
``scipy_rk45`` and ``scipy_dop853`` (same accepted steps, same right-hand-side evaluations) on every built-in
scene, and give the same output states and turning points to round-off.

Runs are short (``SHORT_INTERVALS`` output intervals of each scene, 2-3 swings) except the Panthéon at tol 1e-8,
run in full (1 h). The full check over every scene and every default-matrix tolerance (dopri5: 1e-4…1e-10,
dop853: 1e-4…1e-12) is in integrators/README.md ("Compiled embedded Runge-Kutta pairs").
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.integrators import Solution, get_integrator

PAIRS = {"dopri5": "scipy_rk45", "dop853": "scipy_dop853"}
SHORT_INTERVALS = 20
TOLERANCES = (1e-4, 1e-8, 1e-12)
OUTPUT_RTOL = {"dopri5": 1e-14, "dop853": 1e-12}
"""|Δy| / max|y| between the two runs' output states: both evaluate the same dense-output polynomials of the
same steps, arranged differently (measured on the full scenes: ≤ 1.5e-15 for dopri5, ≤ 3.7e-13 for dop853,
whose degree-7 polynomial has coefficients up to a few hundred); margin ≥ 3."""


@functools.cache
def run(name: str, scene_name: str, tol: float, full: bool = False) -> Solution:
    scene = SCENES[scene_name]
    if not full:
        scene = dataclasses.replace(scene, duration_s=SHORT_INTERVALS * scene.output_interval_s)
    return get_integrator(name).solve(scene.problem(), tol=tol)


def assert_same_steps(mine: Solution, theirs: Solution, name: str) -> None:
    assert mine.status == theirs.status == "ok", (mine.message, theirs.message)
    assert (mine.nfev, mine.steps) == (theirs.nfev, theirs.steps)
    scale = np.max(np.abs(theirs.y))
    assert np.max(np.abs(mine.y - theirs.y)) <= OUTPUT_RTOL[name] * scale
    found, expected = mine.streamed.turning_points, theirs.streamed.turning_points
    assert found.shape == expected.shape
    assert np.max(np.abs(found - expected), initial=0.0) <= OUTPUT_RTOL[name] * max(scale, found[:, 0].max(initial=1.0))


@pytest.mark.parametrize("tol", TOLERANCES)
@pytest.mark.parametrize("scene_name", sorted(SCENES))
@pytest.mark.parametrize("name", sorted(PAIRS))
def test_same_steps_as_scipy_on_every_built_in_scene(name: str, scene_name: str, tol: float) -> None:
    assert_same_steps(run(name, scene_name, tol), run(PAIRS[name], scene_name, tol), name)


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_exactly_the_same_steps_as_scipy_on_the_full_pantheon(name: str) -> None:
    assert_same_steps(run(name, "pantheon", 1e-8, True), run(PAIRS[name], "pantheon", 1e-8, True), name)


@pytest.mark.parametrize("name", ["dopri5", "tsit5", "dop853"])
def test_counters_add_up(name: str) -> None:
    """nfev = 2 (f(t₀, y₀) and the initial-step probe) + s per attempt (+ DOP853's 3 dense-output stages per
    step holding an output time or a turning point)."""
    solution = run(name, "lab_3m", 1e-8)
    tableau = type(get_integrator(name)).tableau
    attempts = solution.steps + solution.rejected_steps
    base = 2 + tableau.stages * attempts
    if tableau.extra_stages == 0:
        assert solution.nfev == base
    else:
        dense_steps = (solution.nfev - base) / tableau.extra_stages
        assert dense_steps == int(dense_steps) and SHORT_INTERVALS <= dense_steps <= solution.steps


def test_rejections_are_counted_as_scipy_makes_them() -> None:
    """scipy's RK45 makes (nfev − 2)/6 attempts; those not accepted are its rejections (3 on the 3 m Airy
    pendulum at tol 1e-4: a finite swing of θ₀ = 0.15 rad)."""
    mine, theirs = run("dopri5", "airy_3m", 1e-4), run("scipy_rk45", "airy_3m", 1e-4)
    assert mine.rejected_steps == (theirs.nfev - 2) // 6 - theirs.steps >= 1


@pytest.mark.parametrize("name", ["dopri5", "dop853", "tsit5"])
def test_declares_a_compiled_cost_basis(name: str) -> None:
    assert get_integrator(name).cost_basis == "compiled"


def _numpy_sums_like_the_driver() -> bool:
    """Whether numpy's matrix-vector product sums in the order the driver reproduces (OpenBLAS's x86-64 dgemv_n:
    blocks of four as two fused multiply-add chains), probed on random data with exact fused multiply-adds."""
    from fractions import Fraction

    def fma(x: float, y: float, z: float) -> float:
        return float(Fraction(x) * Fraction(y) + Fraction(z))

    rng = np.random.default_rng(0)
    for n_terms in (4, 7, 13):
        k, w = rng.standard_normal((n_terms, 4)), rng.standard_normal(n_terms)
        for component in range(4):
            total, j = 0.0, 0
            for _ in range(n_terms // 4):
                even = fma(k[j + 2, component], w[j + 2], k[j, component] * w[j])
                odd = fma(k[j + 3, component], w[j + 3], k[j + 1, component] * w[j + 1])
                total, j = total + (even + odd), j + 4
            if n_terms % 4 >= 2:
                total, j = total + (k[j, component] * w[j] + k[j + 1, component] * w[j + 1]), j + 2
            if n_terms % 2:
                total += k[j, component] * w[j]
            if total != np.dot(k.T, w)[component]:
                return False
    return True


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_every_step_is_bitwise_scipys(name: str) -> None:
    """The final state of a run is the last step's y_new, which depends on every earlier step: equal bit for bit
    to scipy's solver stepped to the same end (where numpy's BLAS sums as the driver does)."""
    if not _numpy_sums_like_the_driver():
        pytest.skip("numpy's BLAS sums matrix-vector products in another order: steps agree to round-off only")
    from scipy.integrate import DOP853, RK45

    from foucault_bench.integrators.adaptive import absolute_tolerance

    scene = dataclasses.replace(SCENES["lab_3m"], duration_s=SHORT_INTERVALS * SCENES["lab_3m"].output_interval_s)
    problem = scene.problem()
    mine = get_integrator(name).solve(problem, tol=1e-8, monitor=False)
    solver_class = {"dopri5": RK45, "dop853": DOP853}[name]
    solver = solver_class(lambda t, y: problem.model.numba_rhs(t, y, problem.parameter_vector), 0.0,
                          problem.initial_state, problem.t_end_s, rtol=1e-8,
                          atol=absolute_tolerance(problem.params, 1e-8))
    steps = 0
    while solver.status == "running":
        solver.step()
        steps += 1
    assert steps == mine.steps
    np.testing.assert_array_equal(mine.y[-1], solver.y)
