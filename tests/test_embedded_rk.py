"""The compiled embedded Runge-Kutta driver against scipy: ``dopri5`` and ``dop853`` take the steps of
``scipy_rk45`` and ``scipy_dop853`` (same accepted steps, same right-hand-side evaluations) on every built-in
scene, and give the same output states and turning points bit for bit, compared with scipy run where numpy's
BLAS sums its small matrix products in the order the driver reproduces (probed here). OpenBLAS picks its kernel
by CPU: its Haswell and Zen kernels sum that way, its SkylakeX kernel (chosen where it detects AVX-512) sums the
stage combinations in another order; on such a machine scipy's side runs in a child process told to use a
kernel that does (``OPENBLAS_CORETYPE``). Where no kernel can be chosen (another BLAS), states are compared to
round-off (``round_off_bound``).

Runs are short (``SHORT_INTERVALS`` output intervals of each scene, 2-3 swings) except the Panthéon at tol 1e-8,
run in full (1 h). The full check over every scene and every default-matrix tolerance is described in
integrators/README.md ("Compiled embedded Runge-Kutta pairs").

Every compiled pair (those without a scipy twin too: ``tsit5``, Verner's ``vern7`` and ``vern9``) is also
checked for its counters and cost basis, ``vern9`` for why the selftest measures its main method's order in 34
digits and not in double (its local slopes approach 9 from above down to double's round-off), and ``vern7`` for
the order of its interpolant; the order of the pairs' main methods is the selftest's (tests/test_selftest.py,
tests/test_multiprecision_order.py).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import subprocess
import sys
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.models import MODELS
from foucault_bench.integrators import REGISTRY, Solution, built_in_names, get_integrator
from foucault_bench.integrators.embedded_rk import EmbeddedRungeKutta, scipy_twins

PAIRS = scipy_twins()
COMPILED = sorted(name for name in built_in_names() if isinstance(REGISTRY[name], EmbeddedRungeKutta))
"""Every built-in compiled pair (with or without a scipy twin)."""
"""Compiled pair → scipy integrator taking the same steps, from the pairs' declarations (``steps_of``)."""
SHORT_INTERVALS = 20
TOLERANCES = (1e-4, 1e-8, 1e-12)
FULL_RUN = ("pantheon", 1e-8)
OPENBLAS_KERNELS_SUMMING_LIKE_THE_DRIVER = ("Haswell", "Zen")
"""x86-64 kernels of OpenBLAS (values of ``OPENBLAS_CORETYPE``) whose small products sum as the driver does."""
ROUND_OFF_FACTOR = 10.0
"""``round_off_bound``'s constant. Measured, numpy on OpenBLAS's SkylakeX kernel against the driver (AMD EPYC Zen 4,
every pair of this file): |Δy| / max|y| reaches 1.2 ε × steps × Σ|dense coefficients| (dop853, airy_3m, tol 1e-4:
1.2e-11 after 12 steps of k·h ≈ 1.4), 0.4-1.1 on the other 3 m scenes at tol 1e-4 (the largest steps), 0.02 or
less everywhere else; so 10 leaves a margin of 8."""


def _fma(x: float, y: float, z: float) -> float:
    return float(Fraction(x) * Fraction(y) + Fraction(z))


@functools.cache
def numpy_sums_like_the_driver() -> bool:
    """Whether numpy's small matrix products sum as the driver does (integrators/embedded_rk.py): a matrix
    times a vector from a transposed (column-major) matrix in blocks of four as two fused multiply-add chains,
    4 × 4 times a vector as (q₀p₀ + q₂p₂) + (q₁p₁ + q₃p₃), a matrix times a matrix as one fused chain in order.
    Probed on random data with exact fused multiply-adds."""
    rng = np.random.default_rng(0)
    for n_terms in (4, 7, 13):
        k, w = rng.standard_normal((n_terms, 4)), rng.standard_normal(n_terms)
        for column in range(4):
            total, j = 0.0, 0
            for _ in range(n_terms // 4):
                even = _fma(k[j + 2, column], w[j + 2], k[j, column] * w[j])
                odd = _fma(k[j + 3, column], w[j + 3], k[j + 1, column] * w[j + 1])
                total, j = total + (even + odd), j + 4
            if n_terms % 4 >= 2:
                total, j = total + (k[j, column] * w[j] + k[j + 1, column] * w[j + 1]), j + 2
            if n_terms % 2:
                total += k[j, column] * w[j]
            if total != np.dot(k.T, w)[column]:
                return False
    q, p, m = rng.standard_normal((4, 4)), rng.standard_normal(4), rng.standard_normal((4, 3))
    for row in range(4):
        if (q[row, 0] * p[0] + q[row, 2] * p[2]) + (q[row, 1] * p[1] + q[row, 3] * p[3]) != np.dot(q, p)[row]:
            return False
        for column in range(3):
            total = 0.0
            for j in range(4):
                total = _fma(q[row, j], m[j, column], total)
            if total != np.dot(q, m)[row, column]:
                return False
    return True


@functools.cache
def run(name: str, scene_name: str, tol: float, full: bool = False) -> Solution:
    scene = SCENES[scene_name]
    if not full:
        scene = dataclasses.replace(scene, duration_s=SHORT_INTERVALS * scene.output_interval_s)
    return get_integrator(name).solve(scene.problem(), tol=tol)


SCIPY_RUNS = tuple((scipy_name, scene_name, tol, False) for scipy_name in PAIRS.values() for scene_name in SCENES
                   for tol in TOLERANCES) + tuple((scipy_name, *FULL_RUN, True) for scipy_name in PAIRS.values())
"""The scipy runs this file compares with (arguments of ``run``)."""


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What the comparison looks at in a run."""

    status: str
    nfev: int
    steps: int
    y: np.ndarray
    turning_points: np.ndarray

    @classmethod
    def of(cls, solution: Solution) -> "Outcome":
        return cls(solution.status, solution.nfev, solution.steps, solution.y, solution.streamed.turning_points)


def save_scipy_outcomes(path: str) -> None:
    """Run ``SCIPY_RUNS`` and save their outcomes to ``path`` (.npz), in a child process of
    ``scipy_outcomes_summing_like_the_driver``; exit 3 if numpy here does not sum like the driver."""
    if not numpy_sums_like_the_driver():
        sys.exit(3)
    arrays = {}
    for index, key in enumerate(SCIPY_RUNS):
        outcome = Outcome.of(run(*key))
        for field in dataclasses.fields(Outcome):
            arrays[f"{index}.{field.name}"] = np.asarray(getattr(outcome, field.name))
    np.savez(path, **arrays)


@functools.cache
def scipy_outcomes_summing_like_the_driver() -> dict[tuple, Outcome] | None:
    """scipy's outcomes of ``SCIPY_RUNS`` where numpy sums like the driver: in this process if it does, else in a
    child process with OpenBLAS told to use a kernel that does; ``None`` where no such kernel can be chosen."""
    if numpy_sums_like_the_driver():
        return {key: Outcome.of(run(*key)) for key in SCIPY_RUNS}
    tests = str(Path(__file__).parent)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "scipy.npz")
        for kernel in OPENBLAS_KERNELS_SUMMING_LIKE_THE_DRIVER:
            child = subprocess.run(
                [sys.executable, "-c", f"import sys; sys.path.insert(0, {tests!r}); "
                 f"import test_embedded_rk; test_embedded_rk.save_scipy_outcomes({path!r})"],
                env={**os.environ, "OPENBLAS_CORETYPE": kernel}, capture_output=True, text=True, check=False)
            if child.returncode == 0:
                with np.load(path) as saved:
                    return {key: Outcome(*(saved[f"{index}.{field.name}"][()] for field in dataclasses.fields(Outcome)))
                            for index, key in enumerate(SCIPY_RUNS)}
            assert child.returncode == 3, child.stderr
    return None


def round_off_bound(name: str, steps: int) -> float:
    """|Δy| / max|y| allowed between the driver and scipy where their sums are ordered differently:
    ``ROUND_OFF_FACTOR`` ε per accepted step times the dense output's coefficient mass Σ|dᵢⱼ| (67 for RK45's P,
    3673 for DOP853's D): an output value is a polynomial in θ whose coefficients are sums of stage derivatives
    with those weights, and each step passes its rounding on to the next."""
    tableau = type(get_integrator(name)).tableau
    dense = tableau.dense_hairer if tableau.dense_hairer is not None else tableau.dense_weights
    return ROUND_OFF_FACTOR * np.finfo(float).eps * steps * float(np.abs(np.array(dense)).sum())


def assert_same_steps(name: str, scene_name: str, tol: float, full: bool = False) -> None:
    """``name`` against its scipy pair on one scene: equal counts, and equal bits (or round-off, see above)."""
    mine, key = run(name, scene_name, tol, full), (PAIRS[name], scene_name, tol, full)
    exact = scipy_outcomes_summing_like_the_driver()
    theirs = exact[key] if exact is not None else Outcome.of(run(*key))
    assert mine.status == theirs.status == "ok", mine.message
    assert (mine.nfev, mine.steps) == (theirs.nfev, theirs.steps)
    found, expected = mine.streamed.turning_points, theirs.turning_points
    if exact is not None:
        np.testing.assert_array_equal(mine.y, theirs.y)
        np.testing.assert_array_equal(found, expected)
    else:
        scale, bound = np.max(np.abs(theirs.y)), round_off_bound(name, mine.steps)
        assert np.max(np.abs(mine.y - theirs.y)) <= bound * scale
        assert found.shape == expected.shape
        assert np.max(np.abs(found - expected), initial=0.0) <= bound * max(scale, expected[-1, 0])


@pytest.mark.parametrize("tol", TOLERANCES)
@pytest.mark.parametrize("scene_name", sorted(SCENES))
@pytest.mark.parametrize("name", sorted(PAIRS))
def test_same_steps_as_scipy_on_every_built_in_scene(name: str, scene_name: str, tol: float) -> None:
    assert_same_steps(name, scene_name, tol)


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_exactly_the_same_steps_as_scipy_on_the_full_pantheon(name: str) -> None:
    assert_same_steps(name, *FULL_RUN, full=True)


@pytest.mark.parametrize("name", COMPILED)
def test_counters_add_up(name: str) -> None:
    """nfev = 2 (f(t₀, y₀) and the initial-step probe) + s per attempt (+ DOP853's 3 dense-output stages per
    step holding an output time or a turning point, as Verner's interpolants' 5 and 9)."""
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


@pytest.mark.parametrize("name", COMPILED)
def test_declares_a_compiled_cost_basis(name: str) -> None:
    assert get_integrator(name).cost_basis == "compiled"


def test_the_compiled_pairs_are_the_registered_ones() -> None:
    assert COMPILED == ["dop853", "dopri5", "tsit5", "vern7", "vern9"]


def test_vern7_s_interpolant_is_order_6_and_not_7() -> None:
    """Verner's first-posted interpolant of the 7(6) pair meets every condition of order 6 and not all of order 7
    (integrators/methods/vern7.py): declaring 7 is refused, naming order-7 trees of the dense output."""
    tableau = type(get_integrator("vern7")).tableau
    assert tableau.dense_order == 6
    with pytest.raises(ValueError, match=r"dense output, θ\^\d: order condition of the tree .* \(order 7\)"):
        dataclasses.replace(tableau, dense_order=7)
    assert dataclasses.replace(type(get_integrator("vern9")).tableau, dense_order=9).dense_order == 9


VERN9_STEPS = (8, 10, 12, 14, 16, 18, 20, 23, 26, 29, 32, 36)
"""Steps of one run over the selftest's order duration: kh from 0.88 to 0.20, errors 5e-8 … 3e-14 on the linear
model (its closed form is the reference), where vern9's main method is still above round-off."""


def test_vern9s_main_method_approaches_order_9_from_above_down_to_round_off() -> None:
    """Why the selftest steps vern9's main method in 34 digits (``bench.gate.multiprecision_order``) and not in
    double: with the steps really taken (duration / n), the local slopes of its final-position error in double fall
    steadily from above 10 towards 9 and are still above 9 where the error reaches 3e-14 (9.10 there with plain sums
    in the fixed-step loop, 9.099 with the compensated ones): order 9, as declared, approached from above (never
    below 8.9, so not 8), yet no fit above double's round-off comes within 0.1 of it."""
    from foucault_bench.bench.gate.order_sweep import ORDER_PERIODS, order_parameters, reference_final_state
    from foucault_bench.integrators import Problem

    main = get_integrator("vern9").fixed_step_method()
    assert main is not None and main.order == 9 and main.stages == 16
    params = order_parameters(MODELS["linear"])
    duration_s = ORDER_PERIODS * params.small_swing_period_s
    reference = reference_final_state(MODELS["linear"], params, duration_s)
    problem = Problem(MODELS["linear"], params, np.array([0.0, duration_s]))
    errors = [float(np.hypot(*(main.solve(problem, step_s=duration_s / n, monitor=False).y[-1, :2] - reference[:2])))
              / params.amplitude_m for n in VERN9_STEPS]
    slopes = np.diff(np.log(errors)) / np.diff(np.log(VERN9_STEPS)) * -1.0
    assert errors[-1] > 1e-14 and slopes[0] > 10.0 and slopes[-1] > 9.0 and np.all(slopes > 8.9), (errors, slopes)
    assert np.all(slopes > 8.9) and np.all(np.diff(slopes) < 0.02), slopes


def test_the_pairs_are_derived_from_the_declarations() -> None:
    assert PAIRS == {"dop853": "scipy_dop853", "dopri5": "scipy_rk45"}  # today's declarations (dopri5.py, dop853.py)
    assert "tsit5" not in PAIRS  # Tsitouras's pair is no scipy solver's


def test_a_pair_declaring_another_tableau_s_steps_is_refused() -> None:
    from scipy.integrate import RK45

    from foucault_bench.integrators.methods.tsit5 import Tsit5

    with pytest.raises(TypeError, match="differs from scipy"):
        type("WrongTwin", (Tsit5,), {"name": "wrong_twin", "steps_of": RK45})


def test_the_perf_section_times_only_pairs_that_take_the_same_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    from foucault_bench.bench.perf import erk

    monkeypatch.setattr(erk, "PAIRS", {"tsit5": "scipy_rk45"})
    with pytest.raises(AssertionError, match="different steps"):
        erk.measure(quick=True)


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_a_failing_run_fails_where_scipy_fails(name: str) -> None:
    """The finite-time blow-up of tests/test_adaptive.py: the step size collapses at the same step, after the same
    evaluations, with scipy's message."""
    from test_adaptive import BLOW_UP, BLOW_UP_SCENE

    from foucault_bench.integrators import Problem

    problem = Problem(BLOW_UP, BLOW_UP_SCENE, np.linspace(0.0, 3.0, 31))
    mine, theirs = get_integrator(name).solve(problem, tol=1e-8), get_integrator(PAIRS[name]).solve(problem, tol=1e-8)
    assert mine.status == theirs.status == "failed"
    assert (mine.nfev, mine.steps) == (theirs.nfev, theirs.steps)
    assert "Required step size is less than spacing between numbers" in mine.message
    np.testing.assert_array_equal(np.isnan(mine.y), np.isnan(theirs.y))
