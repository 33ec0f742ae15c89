"""The order sweep of ``foucault-bench selftest`` (``bench.gate.conformance``, check 1): the observed order of an
integrator's final-position error over a sequence of fixed steps on one model.

The sweep runs at the model's declared ``example_parameters`` (``order_parameters``), so a model that adds a parameter is checked where that
parameter acts, not only where it equals its parent model, released on the ellipse the model declares
(``Model.order_sweep_ellipse``: the drag and drive models, whose forces have complex singularities close to
the real axis on a planar swing). The sweep is derived from the declared facts (``sweep_for``): it starts at
kh = min(½ stability limit, ``START_KH``). Up to order ``HALVING_MAX_ORDER`` it halves kh until the error falls
below ``MAX_ERROR`` and then keeps ``points_needed(p)`` more points (enough to span ``SPAN_DECADES`` decades of
error at order p), stopping early at the round-off floor ``FLOOR_ERROR`` (a first point within one halving of
that floor starts again at twice the step, up to ½ the stability limit). Above that order one halving lowers
the error by 2.4-3 decades, the whole usable range holds three or four halvings, and the terms after the
leading one still tilt their slope (the order-10 composition was observed at 9.53 on seed_planar with
halvings): the sweep divides kh by 10^(1/p) (a decade of error per point) from a start at up to ½ the
stability limit (``UNDECLARED_LIMIT_START_KH`` when none is declared) where the first error is within
``MIN_POINTS`` − 1 steps of the floor, down to ``HIGH_ORDER_FLOOR_ERROR`` or the run's own round-off
(``ROUND_OFF_PER_EVALUATION`` × its evaluations), or until the error stops falling; that last point is not
fitted. ``bench.verdicts.convergence.observed_order`` fits the slope on the finest points (the
same rule the report and the gate use; for the high-order sweeps with local slopes agreeing within
``HIGH_ORDER_AGREEMENT``, ``fit_order``). The sweep runs with Earth's rotation sped up to
``ROTATION_OVER_SWING`` × k: at the real rate (Ω_E/k ≈ 1e-5) an error term proportional to Ω h, such as an
explicit Coriolis kick in a Verlet scheme, stays below the (kh)² term at every measurable step and a wrong
order would go unseen. References: the closed form for the linear model (``models.analytic``), heyoka's
Taylor method at ``REFERENCE_TOL`` for the others (errors ~1e-15 of the amplitude, far below ``FLOOR_ERROR``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from foucault_bench.bench.verdicts.convergence import observed_order
from foucault_bench.integrators import STATUS_OK, Integrator, Problem, get_integrator
from foucault_bench.models import MODELS, Model, PendulumParameters
from foucault_bench.models.analytic import linear_exact

START_KH = 0.5
MAX_ERROR = 0.1
"""Errors (of the final position, in units of the amplitude) above this are not asymptotic yet."""
FLOOR_ERROR = 1e-10
"""Below this, accumulated round-off (~1e-16 per step) starts to show: the sweep stops (orders up to
``HALVING_MAX_ORDER``)."""
HALVING_MAX_ORDER = 6
HIGH_ORDER_FLOOR_ERROR = 1e-13
"""The floor of the sweep above order ``HALVING_MAX_ORDER``: their runs take tens to hundreds of steps, and the
references are good to ~1e-15. A run's own round-off can lie higher (RATTLE on the sphere: 1-2e-13 after a
thousand sub-steps of the order-8 composition), so a point whose error is below ``ROUND_OFF_PER_EVALUATION``
times its counted evaluations (ε per evaluation, growing linearly: the pessimistic bound) ends the sweep too and
is not fitted."""
ROUND_OFF_PER_EVALUATION = 2.220446049250313e-16
HIGH_ORDER_AGREEMENT = 0.05
"""The fit of a high-order sweep (``fit_order``) keeps a point only where the local slopes agree within 5 % of their
median (the report's rule allows 10 %: ``bench.verdicts.convergence.observed_order``). At order 10, 10 % is a whole
order: composition10 on the sphere ended at 6.2e-13, 2.2× its ε·nfev bound, with a local slope of 10.68 after
9.96, 9.98 and 9.93, and that point, inside 10 %, tilted the fit to 10.115; at 5 % it is left out and the fit is
9.963. Measured 2026-12-03: every other high-order sweep of the built-in methods (composition8, composition10, the
main methods of dop853 and vern7, on every model) gives the same order to three decimals at 5 % as at 10 %."""
UNDECLARED_LIMIT_START_KH = 1.0
"""The coarsest first step of a high-order sweep for a method that declares no stability limit (the main methods
of the embedded pairs): 6 steps per period, inside the imaginary-axis stability interval of every built-in pair."""
SPAN_DECADES = 2.0
MIN_POINTS = 5
MAX_RUN_STEPS = 4_000_000
"""A sweep needing more steps in one run than this reports the order check as failed (too slow to converge)."""
ORDER_PERIODS = 1.125
"""Sweep duration: kt = 2.25π, neither a turning point nor a zero crossing, where a phase (resp. amplitude)
error would be hidden and a higher order observed."""
ROTATION_OVER_SWING = 0.2
REFERENCE_INTEGRATOR = "heyoka_taylor"
REFERENCE_TOL = 1e-15

ORDER_PARAMS = PendulumParameters(length_m=3.0, latitude_deg=40.44, amplitude_m=0.3,
                                  earth_rate_rad_s=ROTATION_OVER_SWING * math.sqrt(9.81 / 3.0))


@dataclass(frozen=True)
class OrderMeasurement:
    """A step sweep: step sizes (s), final-position errors (units of the amplitude) and the fitted order."""

    step_sizes_s: np.ndarray
    errors: np.ndarray
    order: float
    note: str = ""


@dataclass(frozen=True)
class Sweep:
    """How the order sweep steps: kh is divided by ``ratio`` from one run to the next until ``points_needed``
    errors lie below ``MAX_ERROR`` or, with ``to_floor``, until the round-off floor ``floor`` (final-position
    error, units of the amplitude), whichever ends the sweep later; the first kh is doubled (up to ½ the
    stability limit) while the first error lies within ``room`` steps of that floor."""

    ratio: float
    floor: float
    room: int
    to_floor: bool


HALVING = Sweep(ratio=2.0, floor=FLOOR_ERROR, room=1, to_floor=False)


def sweep_for(order: int) -> Sweep:
    """``HALVING`` up to order ``HALVING_MAX_ORDER``; above, steps of 10^(1/p) (about one decade of error per
    point, 5-6 points between a first error near 1e-7 and the floor) down to ``HIGH_ORDER_FLOOR_ERROR``, and
    the error stops being measured where it no longer falls (module docstring)."""
    if order <= HALVING_MAX_ORDER:
        return HALVING
    return Sweep(ratio=10.0 ** (1.0 / order), floor=HIGH_ORDER_FLOOR_ERROR, room=MIN_POINTS - 1, to_floor=True)


def points_needed(order: int) -> int:
    """Sweep points below ``MAX_ERROR``: enough steps of the sweep's ratio to span ``SPAN_DECADES`` decades at
    order p."""
    return max(MIN_POINTS, math.ceil(SPAN_DECADES / (order * math.log10(sweep_for(order).ratio))) + 1)


def reference_final_state(model: Model, params: PendulumParameters, duration_s: float) -> np.ndarray:
    """The exact final state for the linear model, heyoka's Taylor method at ``REFERENCE_TOL`` otherwise."""
    if model is MODELS.get("linear"):
        return linear_exact(params, np.array([duration_s]))[0]
    problem = Problem(model, params, np.array([0.0, duration_s]))
    solution = get_integrator(REFERENCE_INTEGRATOR).solve(problem, tol=REFERENCE_TOL, monitor=False)
    if solution.status != STATUS_OK:
        raise RuntimeError(f"the reference run failed: {solution.message}")
    return solution.y[-1]


def order_parameters(model: Model) -> PendulumParameters:
    """The parameters of the order sweep on ``model``: ``ORDER_PARAMS`` with the model's declared
    ``example_parameters`` applied, so that what the model adds to its parents acts in the sweep, released on the
    ellipse the model declares (``Model.order_sweep_ellipse``: a sideways speed b/a · kA, at right angles to the
    release direction; from rest by default)."""
    params = model.with_example_parameters(ORDER_PARAMS)
    if not model.order_sweep_ellipse:
        return params
    speed = model.order_sweep_ellipse * params.pendulum_frequency_rad_s * params.amplitude_m
    sideways = math.radians(params.release_azimuth_deg + 90.0)
    return dataclasses.replace(params, release_velocity_m_s=(speed * math.cos(sideways), speed * math.sin(sideways)))


def measure_order(integrator: Integrator, model: Model, params: PendulumParameters | None = None,
                  periods: float = ORDER_PERIODS) -> OrderMeasurement:
    """Observed order of ``integrator`` on ``model`` over a step sweep derived from its declared facts (see the
    module docstring, check 1), at ``params`` (default: ``order_parameters(model)``)."""
    params = order_parameters(model) if params is None else params
    duration = periods * params.small_swing_period_s
    k = params.pendulum_frequency_rad_s
    reference = reference_final_state(model, params, duration)
    problem = Problem(model, params, np.array([0.0, duration]))
    limit = integrator.stability_limit_kh
    order = cast(int, integrator.order)  # check_order runs for a declared order only
    sweep = sweep_for(order)
    kh = min(START_KH, 0.5 * limit) if limit else START_KH
    coarsest = 0.5 * limit if limit else (UNDECLARED_LIMIT_START_KH if sweep.to_floor else kh)
    wanted = points_needed(order)
    steps: list[float] = []
    errors: list[float] = []
    note = ""
    while sweep.to_floor or sum(error <= MAX_ERROR for error in errors) < wanted:
        n_steps = math.ceil(k * duration / kh)
        if n_steps > MAX_RUN_STEPS:
            note = f"stopped at {MAX_RUN_STEPS} steps per run"
            break
        solution = integrator.solve(problem, step_s=duration / n_steps, monitor=False)
        error = math.inf
        if solution.status == STATUS_OK:
            error = float(np.hypot(*(solution.y[-1, :2] - reference[:2])) / params.amplitude_m)
        steps.append(duration / n_steps)
        errors.append(error)
        if len(errors) == 1 and error < sweep.floor * sweep.ratio ** (order * sweep.room) and 2 * kh <= coarsest:
            steps.clear()  # a high order: the next points would reach the floor, so start coarser
            errors.clear()
            kh *= 2.0
            continue
        stalled = sweep.to_floor and len(errors) > 1 and error >= errors[-2]
        below_round_off = sweep.to_floor and error < ROUND_OFF_PER_EVALUATION * (solution.nfev or 0)
        if error < sweep.floor or stalled or below_round_off:
            if sweep.to_floor:  # within ~100 × round-off, or round-off already: it would tilt the fit by its noise
                steps.pop()
                errors.pop()
            break
        kh /= sweep.ratio
    h, e = np.array(steps), np.array(errors)
    return OrderMeasurement(h, e, fit_order(sweep, steps, errors), note)


def fit_order(sweep: Sweep, steps: list[float], errors: list[float]) -> float:
    """The observed order of a sweep's points: ``observed_order``, with ``HIGH_ORDER_AGREEMENT`` for the sweeps
    that run to the round-off floor."""
    if sweep.to_floor:
        return observed_order(steps, errors, agreement=HIGH_ORDER_AGREEMENT)
    return observed_order(steps, errors)


