"""Conformance of one integrator with what it declares: the checks behind ``foucault-bench selftest``.

An integrator declares facts (``integrators.base.Integrator``: order, stages, adaptive, stability limit); this
module measures them, on small problems that take seconds, so that a plug-in author learns in one command
whether the suite will treat the method correctly. Every check returns a ``Check`` (a row), never raises:

1. **order on MODEL**, for every model and every integrator with a declared order p that steps at fixed steps,
   or is an adaptive pair whose main method can (``Integrator.fixed_step_method``: the embedded Runge-Kutta pairs'
   c, A and b at fixed steps, ``integrators.embedded_rk``): the observed order of the final-position error over
   the step sweep of ``bench.gate.order_sweep`` (``measure_order``: its docstring says how the sweep is derived
   from the declared facts and the model's) lies within ``ORDER_TOLERANCE`` of p. A pair whose main method is
   known exactly (``exact_main_method``: ``vern7`` and ``vern9``, whose tableaux keep their published digits, and
   the RKN pair ``fine_rkn5``, in fractions) is stepped in 34-digit arithmetic instead
   (``bench.gate.multiprecision_order``), where the next error terms die out above round-off; ``tsit5`` says
   why its main method cannot be measured (``main_method_unmeasurable``). Adaptive integrators without a
   fixed-step formula are skipped: error against tolerance is no order.
2. **stable below the limit** and **diverges above the limit**, for every declared ``stability_limit_kh``:
   on the undamped oscillator ẍ = −k²x (the linear model with no rotation, where the limit is defined;
   Hairer, Nørsett & Wanner, Solving ODEs I, §IV.2) the energy error reached after ``STABILITY_STEPS`` steps
   at 0.99 × the limit does not grow over as many more (beyond ``ROUND_OFF_GROWTH``), and a run at 1.01 × the
   limit is ``diverged``.
3. **counters**: a short run on the linear model is ``ok`` and reports ``steps`` and the step size (fixed
   step) or the tolerance (adaptive), and ``nfev`` > 0, equal to ``stages × steps`` when ``stages`` is declared
   (a fixed-step scheme's ``nfev`` is its counted evaluations, ``integrators.counting``: a scheme that evaluates
   the right-hand side more or less often than it declares fails here).
   A fixed-step method that declares no ``stages`` (evaluations vary per step) may report no ``nfev``.
4. **turning points**: where the run streams the radius maxima (``Solution.streamed``, optional: the verdicts
   find turning points on the output grid), two per swing period, t = 0 not counted: 8 over
   ``SHORT_RUN_PERIODS`` = 4.25 periods.
5. **divergence is a row**: on a model with a finite-time singularity (``BLOW_UP``) the run returns
   ``diverged`` or ``failed`` with a message and NaN after the stop, without raising.
6. **failure is a row**: on a model whose force raises (``FAILING``) the run returns ``failed`` with the
   error's message, without raising.

``iter_checks`` yields the rows; ``foucault-bench selftest`` (``bench.commands.selftest``) prints one line each:
the label (``ok``: the check held), the check, and a detail that states the measured quantity, the criterion
and whether it held.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator

import numpy as np

from foucault_bench.bench.gate.multiprecision_order import DIGITS, exact_main_method, measure_exact_order
from foucault_bench.bench.gate.order_sweep import measure_order, order_parameters
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_FAILED, STATUS_OK, Integrator, Problem
from foucault_bench.models import MODELS, Model, PendulumParameters
from foucault_bench.models.parameters import P_K2, P_LENGTH

ORDER_TOLERANCE = 0.1
"""|observed − declared order| allowed. The fit over the finest points still carries the next error term,
relatively O(kh) smaller. Measured with ``foucault-bench selftest`` on every built-in integrator and every model
(2026-12-04), the largest |observed − declared| are: dopri5's main method 0.09 (5.06-5.09: like Tsitouras's,
its slopes approach 5 from above down to the sweep's floor), rk4 0.07 (3.93-3.97), composition6, composition10,
dop853's main method, heun3 and nystrom4 0.06, composition8 0.05, gbs4 0.04, vern9 0.03 and vern7 and fine_rkn5
0.01 (the last three stepped in 34 digits), the rest ≤ 0.01; a wrong method is off by a whole order or more
(the mutants of tests/check_mutants.py: 1.9 for 4, 1.0 for 2; tests/test_multiprecision_order.py: a pair
declaring one order more or less). vern7's main method on the drag and drive models, stepped in double, stays
pre-asymptotic down to round-off (7.143), which is why it is stepped in 34 digits
(``bench.gate.multiprecision_order``; integrators/README.md "Verner's pairs (`vern7`, `vern9`)")."""

STABILITY_MARGIN = 0.01
STABILITY_STEPS = 20_000
GROWTH_ALLOWANCE = 1e-6
"""Relative growth of the max energy error allowed between 20,000 and 40,000 steps below the limit."""
ROUND_OFF_GROWTH = 1e-8
"""Absolute growth of the max relative energy error allowed on top: methods that keep the oscillator's energy
to round-off (implicit midpoint, Gauss-Legendre: a quadratic invariant) random-walk by ~1e-9 over 40,000 steps
(their fixed-point iteration stops near round-off), while an unstable mode grows exponentially, to O(1) and
beyond, in as many steps."""

OSCILLATOR = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0, earth_rate_rad_s=0.0)
SHORT_RUN = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
SHORT_RUN_PERIODS = 4.25
SHORT_RUN_KH = 0.1
SHORT_RUN_TOL = 1e-8


@dataclass(frozen=True)
class Check:
    """One conformance check: ``holds`` is True, False, or None when the check does not apply (skipped)."""

    name: str
    holds: bool | None
    detail: str

    @property
    def label(self) -> str:
        return {True: "ok", False: "FAIL", None: "skip"}[self.holds]


# --- models that must fail ------------------------------------------------------------------------------------


def _blow_up_force(m, x, y, z, vx, vy, vz, p):
    """r̈ = +k² r |r|²/L²: repelled ever faster, r → ∞ in finite time (t* ≈ 1.85 (L/A)/k from rest at A)."""
    scale = p[P_K2] * (x * x + y * y) / (p[P_LENGTH] * p[P_LENGTH])
    return scale * x, scale * y, 0.0 * z


def _blow_up_energy(m, x, y, vx, vy, p):
    """½|v|² − k²|r|⁴/(4L²), conserved up to the singularity (J/kg)."""
    r2 = x * x + y * y
    return 0.5 * (vx * vx + vy * vy) - 0.25 * p[P_K2] * r2 * r2 / (p[P_LENGTH] * p[P_LENGTH])


def _failing_force(m, x, y, z, vx, vy, vz, p):
    """Raises on evaluation: at run time in compiled code, at build time over heyoka's expressions."""
    if p[P_LENGTH] > 0.0:
        raise FloatingPointError("deliberate failure of the selftest's failing model")
    return -x, -y, 0.0 * z


def _plain_energy(m, x, y, vx, vy, p):
    return 0.5 * (vx * vx + vy * vy + x * x + y * y)


BLOW_UP = Model(name="selftest_blow_up", title="selftest: finite-time blow-up", geometry="plane",
                free_force=_blow_up_force, energy=_blow_up_energy, energy_name="½|v|² − k²|r|⁴/(4L²)",
                conserves_energy=True, hamiltonian=True)
FAILING = Model(name="selftest_failing", title="selftest: force raises", geometry="plane",
                free_force=_failing_force, energy=_plain_energy, energy_name="½|v|² + ½|r|²",
                conserves_energy=True, hamiltonian=True)
BLOW_UP_PARAMS = PendulumParameters(length_m=1.0, latitude_deg=45.0, amplitude_m=0.6, earth_rate_rad_s=0.0)


# --- the checks ------------------------------------------------------------------------------------------------


def check_order(integrator: Integrator, model: Model) -> Check:
    name = f"order on {model.name}"
    exact = exact_main_method(integrator)
    stepped = None if exact is not None else integrator.fixed_step_method() if integrator.adaptive else integrator
    if integrator.order is None or (exact is None and stepped is None):
        unmeasurable = getattr(integrator, "main_method_unmeasurable", "")
        why = ("no order declared" if integrator.order is None
               else f"adaptive, main method not measurable here: {unmeasurable}" if unmeasurable
               else "adaptive, with no fixed-step formula: error against tolerance is no order")
        return Check(name, None, why)
    params = order_parameters(model)
    if exact is not None:
        measured = measure_exact_order(exact, model, params)
        how = f" of its main method in {DIGITS}-digit arithmetic"
    else:
        assert stepped is not None  # excluded above
        measured = measure_order(stepped, model, params)
        how = f" of its main method at fixed steps ({stepped.name})" if stepped is not integrator else ""
    holds = bool(abs(measured.order - integrator.order) <= ORDER_TOLERANCE)
    points = ", ".join(f"{error:.1e}" for error in measured.errors[np.isfinite(measured.errors)][-4:])
    example = "".join(f", {key} = {value!r}" for key, value in model.example_parameters.items())
    detail = (f"observed order {measured.order:.2f} of the final-position error{how}, declared {integrator.order}, "
              f"allowed ±{ORDER_TOLERANCE}: {'held' if holds else 'NOT held'}; "
              f"{measured.errors.size} steps down to kh = {measured.step_sizes_s[-1] * params.pendulum_frequency_rad_s:.2g}"
              f"{example}, finest errors {points}" + (f"; {measured.note}" if measured.note else ""))
    return Check(name, holds, detail)


def oscillator_run(integrator: Integrator, kh: float, n_steps: int, params: PendulumParameters = OSCILLATOR):
    """``n_steps`` steps of k·h = ``kh`` on the linear model (the undamped oscillator when Ω_E = 0)."""
    h = kh / params.pendulum_frequency_rad_s
    problem = Problem(MODELS["linear"], params, np.array([0.0, n_steps * h]))
    return integrator.solve(problem, step_s=h)


LARGE_ENERGY_ERROR = 0.5
"""A max relative energy error from here up is called large in the verdict line (see ``stability_verdict``)."""


def stability_verdict(kh: float, first: float, second: float) -> tuple[bool, str]:
    """Whether the max relative energy error ``second`` after 2 × ``STABILITY_STEPS`` steps at k·h = ``kh`` did not
    grow beyond ``first`` (after ``STABILITY_STEPS``) × (1 + ``GROWTH_ALLOWANCE``) + ``ROUND_OFF_GROWTH``, and the
    line saying what was measured, the criterion and whether it held. Bounded is stable, however large: just
    below its limit a stable method's energy error is of order one or more (measured: RK4 damps the swing away,
    error 1.000; Verlet 0.98, symplectic Euler 99, both oscillating), and what marks instability is growth."""
    allowed = first * (1 + GROWTH_ALLOWANCE) + ROUND_OFF_GROWTH
    holds = bool(second <= allowed)
    line = (f"kh = {kh:.4g}: max relative energy error {first:.3e} after {STABILITY_STEPS} steps, {second:.3e} "
            f"after {2 * STABILITY_STEPS}; bounded if the second ≤ {allowed:.3e} (the first + "
            f"{GROWTH_ALLOWANCE:g} of it + {ROUND_OFF_GROWTH:g}): {'held' if holds else 'NOT held, it grew'}")
    if holds and first >= LARGE_ENERGY_ERROR:
        line += " (large but not growing: bounded, as a stable method is this close to its limit)"
    return holds, line


def check_stability(integrator: Integrator) -> list[Check]:
    limit = integrator.stability_limit_kh
    if limit is None:
        return [Check("stability limit", None, "no stability limit declared")]
    below_kh, above_kh = limit * (1 - STABILITY_MARGIN), limit * (1 + STABILITY_MARGIN)
    below = oscillator_run(integrator, below_kh, STABILITY_STEPS)
    longer = oscillator_run(integrator, below_kh, 2 * STABILITY_STEPS)
    if below.status != STATUS_OK or longer.status != STATUS_OK:
        stable = Check("stable below the limit", False,
                       f"kh = {below_kh:.4g}: status {below.status}/{longer.status} ({below.message or longer.message})")
    else:
        stable = Check("stable below the limit", *stability_verdict(below_kh, below.streamed.energy_max_rel_error,
                                                                     longer.streamed.energy_max_rel_error))
    above = oscillator_run(integrator, above_kh, STABILITY_STEPS)
    diverged = above.status == STATUS_DIVERGED
    diverges = Check("diverges above the limit", diverged,
                     f"kh = {above_kh:.4g}: status {above.status} after {STABILITY_STEPS} steps, expected "
                     f"{STATUS_DIVERGED}: {'held' if diverged else 'NOT held'}"
                     + (f" ({above.message})" if above.message else ""))
    return [stable, diverges]


def _setting(integrator: Integrator, params: PendulumParameters) -> dict:
    """A moderate setting: ``SHORT_RUN_TOL``, or kh = ``SHORT_RUN_KH`` (at most half the stability limit)."""
    if integrator.adaptive:
        return {"tol": SHORT_RUN_TOL}
    limit = integrator.stability_limit_kh
    kh = SHORT_RUN_KH if limit is None else min(SHORT_RUN_KH, 0.5 * limit)
    return {"step_s": kh / params.pendulum_frequency_rad_s}


def check_counters_and_turning_points(integrator: Integrator) -> list[Check]:
    grid = np.linspace(0.0, SHORT_RUN_PERIODS * SHORT_RUN.small_swing_period_s, round(8 * SHORT_RUN_PERIODS) + 1)
    solution = integrator.solve(Problem(MODELS["linear"], SHORT_RUN, grid), **_setting(integrator, SHORT_RUN))
    if solution.status != STATUS_OK:
        failed = f"status {solution.status}: {solution.message}"
        return [Check("counters", False, failed), Check("turning points", False, failed)]
    problems = []
    nfev_optional = not integrator.adaptive and integrator.stages is None
    if not (isinstance(solution.nfev, int) and solution.nfev > 0) and not (nfev_optional and solution.nfev is None):
        problems.append(f"nfev = {solution.nfev!r}")
    if not integrator.adaptive:
        if not (isinstance(solution.steps, int) and solution.steps > 0):
            problems.append(f"steps = {solution.steps!r}")
        elif integrator.stages is not None and solution.nfev != integrator.stages * solution.steps:
            problems.append(f"nfev = {solution.nfev} ≠ stages × steps = {integrator.stages} × {solution.steps}")
        if not (solution.step_size_s and solution.step_size_s > 0):
            problems.append(f"step_size_s = {solution.step_size_s!r}")
    elif solution.tolerance != SHORT_RUN_TOL:
        problems.append(f"tolerance = {solution.tolerance!r}")
    counters = ", ".join(f"{name} = {getattr(solution, name)}" for name in ("nfev", "njev", "steps", "rejected_steps"))
    counter_check = Check("counters", not problems, "; ".join(problems) if problems else counters)
    expected = math.floor(2 * SHORT_RUN_PERIODS)
    if solution.streamed is None:
        turning = Check("turning points", None, "none streamed (optional: the verdicts use the output grid)")
    else:
        found = len(solution.streamed.turning_points)
        turning = Check("turning points", found == expected,
                        f"{found} streamed over {SHORT_RUN_PERIODS} periods, expected {expected}")
    return [counter_check, turning]


def check_bad_runs_are_rows(integrator: Integrator) -> list[Check]:
    checks = []
    for name, model, accepted in (("divergence is a row", BLOW_UP, (STATUS_DIVERGED, STATUS_FAILED)),
                                  ("failure is a row", FAILING, (STATUS_FAILED,))):
        grid = np.linspace(0.0, BLOW_UP_PARAMS.small_swing_period_s, 9)
        solution = integrator.solve(Problem(model, BLOW_UP_PARAMS, grid), **_setting(integrator, BLOW_UP_PARAMS))
        nan_tail = bool(np.all(np.isnan(solution.y[-1])))
        holds = solution.status in accepted and bool(solution.message) and nan_tail
        message = solution.message.splitlines()[0] if solution.message else "no message"
        checks.append(Check(name, holds, f"{model.title}: status {solution.status}, last row "
                                         f"{'NaN' if nan_tail else 'finite'}; {message}"))
    return checks


def _guarded(name: str, check: Callable[[], Check | list[Check]]) -> list[Check]:
    """Run one check; an exception escaping the integrator is itself a failed check (runs must be rows)."""
    try:
        result = check()
    except Exception as error:  # the point of the check: report it, do not crash
        return [Check(name, False, f"raised {type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}")]
    return result if isinstance(result, list) else [result]


def iter_checks(integrator: Integrator, models: Iterable[Model] | None = None) -> Iterator[Check]:
    """Every conformance check of ``integrator`` (module docstring), in order, as each completes; the order
    checks on ``models`` (default: every model of ``MODELS``)."""
    for model in MODELS.values() if models is None else models:
        yield from _guarded(f"order on {model.name}", functools.partial(check_order, integrator, model))
    yield from _guarded("stability limit", lambda: check_stability(integrator))
    yield from _guarded("counters", lambda: check_counters_and_turning_points(integrator))
    yield from _guarded("bad runs are rows", lambda: check_bad_runs_are_rows(integrator))


def run_checks(integrator: Integrator, models: Iterable[Model] | None = None) -> list[Check]:
    """``iter_checks`` as a list."""
    return list(iter_checks(integrator, models))
