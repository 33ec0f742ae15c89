"""Verdicts: what one run's output says about the integrator (the verdict columns of ``bench.schema``).

Every verdict is computed from the solution on the scene's output grid, the same grid for every integrator
of a scene, by one procedure for all integrators and for the reference (``bench.problems.reference``), so that the
comparison is fair and the numbers are deterministic (same inputs → same bits on the same machine).

* **Energy** (``energy_verdicts``): the model's energy E (``Model.energy``: the Jacobi integral on the sphere)
  on the grid, as the relative error (E − E₀)/E_swing. The scale E_swing = E₀ − E_rest is the energy of the
  swing above the bob at rest at the bottom (E_rest = E(0, 0, 0, 0)), so that the figure does not depend on
  where the potential's zero lies: for the planar models E_rest = 0 and E_swing = E₀; for the spherical model
  E₀ ≈ −gL while E_swing ≈ gA²/2L, and dividing by |E₀| would make the same error look 2/θ₀² times smaller.
  Reported: max |·|, least-squares slope in t, and the streamed per-step max rescaled to E_swing. For a model
  that conserves no energy (drag, drive, the seed's eqs. 4-5) the energy balance E − E₀ − W, W the work of its
  non-conservative forces along the run, replaces it as the integrator's energy error
  (``bench.verdicts.energy_balance``, column ``energy_balance_max_rel_error``).
* **Precession** (``turning_points_from_grid``, ``precession_rate``): turning points of the swing (maxima of
  the radius) located on a local Hermite interpolant of the grid (positions, velocities, and accelerations
  from the model), their azimuths ψ unwrapped as 2ψ, halved, and fitted by a straight line in t
  (integrators/README.md "Measuring the precession rate"). The rate is compared with −Ω_E sin φ and with the
  reference's rate measured the same way on the same grid.
* **Trajectory**: max over the grid of |r − r_other|/A against the exact linear solution, the seed's
  approximate solution (``models.analytic``) and the reference.
* **Ellipse** (``bench.verdicts.ellipse``): the canonical angular momentum about the vertical and the semi-minor
  axis of the swing's osculating ellipse, against the reference.
* **Convergence** (``observed_order``): the order seen in a sweep of step sizes.

Turning points streamed by some integrators (``Solution.streamed``) are not used for the verdicts: one
measurement on one grid for everyone keeps integrators with and without event detection comparable, and
makes the measurement independent of the code it judges.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from foucault_bench.bench.schema import VERDICT_COLUMNS
from foucault_bench.bench.verdicts.ellipse import ellipse_errors
from foucault_bench.bench.verdicts.energy_balance import energy_balance_max_rel_error
from foucault_bench.bench.problems.turning_points import (
    finite_prefix,
    grid_accelerations,
    least_squares_slope,
    precession_rate,
    rate_scale,
    released_from_rest,
    turning_points_from_grid,
)
from foucault_bench.integrators import STATUS_DIVERGED, STATUS_OK, Solution
from foucault_bench.models import Model, PendulumParameters
from foucault_bench.models.analytic import linear_exact, seed_approximate

if TYPE_CHECKING:  # annotations only
    from foucault_bench.bench.problems.reference import Reference
    from foucault_bench.bench.problems.scenes import Scene

NAN = math.nan

# --- energy ------------------------------------------------------------------------------------------------------


MIN_INTEGRATED_ROWS = 2
"""Rows of the output grid a verdict needs: row 0 is the initial state, given and not integrated, so a run that
diverged before the first output time (a step-0 divergence) has no data: its verdicts are NaN (stored NULL),
never the 0 that comparing the initial state with itself would give."""


def energy_scale(model: Model, params: PendulumParameters) -> tuple[float, float]:
    """(E₀, E_swing) in J/kg: the energy at release and the swing's energy above the bob at rest at the bottom."""
    p = params.parameter_vector()
    energy0 = float(model.numba_energy(*params.initial_state(), p))
    swing = energy0 - float(model.numba_energy(0.0, 0.0, 0.0, 0.0, p))
    return energy0, (swing if swing > 0.0 else abs(energy0) or 1.0)


def energy_verdicts(model: Model, params: PendulumParameters, solution: Solution) -> dict[str, float | None]:
    """Relative energy error (E − E₀)/E_swing on the finite part of the output grid: max, drift, streamed max.

    The drift is the least-squares slope (1/s) of the relative error against t. ``energy_max_rel_error_steps``
    is the streamed per-step max, which the fixed-step loop normalises by the same E_swing; it is ``None`` when
    the integrator does not stream it. For a model that conserves no energy (the seed's eqs. 4-5) the numbers mix the model's own drift with the integrator's (``energy_conserved`` = 0).
    """
    n = finite_prefix(solution.y)
    if n < MIN_INTEGRATED_ROWS:  # only the initial state, which is given, not computed: no data
        n = 0
    energy0, swing = energy_scale(model, params)
    values = model.energy_on_rows(solution.y[:n], params.parameter_vector())
    relative = (values - energy0) / swing
    drift = least_squares_slope(solution.t[:n], relative) if n >= 2 else NAN
    streamed = solution.streamed.energy_max_rel_error if solution.streamed is not None else None
    if solution.steps == 0:  # a max over no step (the loop starts it at 0): no data
        streamed = None if streamed is None else NAN
    return {
        "energy_conserved": int(model.conserves_energy),
        "energy_max_rel_error": float(np.max(np.abs(relative))) if n else NAN,
        "energy_drift_per_s": drift,
        "energy_max_rel_error_steps": None if streamed is None else float(streamed),
    }


# --- trajectory gaps ---------------------------------------------------------------------------------------------


def max_position_gap(y: np.ndarray, other: np.ndarray, amplitude_m: float) -> float:
    """max over rows of |r − r_other| / A (positions are the first two columns); NaN unless a row after the
    initial state is finite (``MIN_INTEGRATED_ROWS``)."""
    n = min(finite_prefix(y), finite_prefix(other))
    if n < MIN_INTEGRATED_ROWS:
        return NAN
    gap = np.hypot(y[:n, 0] - other[:n, 0], y[:n, 1] - other[:n, 1])
    return float(np.max(gap)) / amplitude_m


# --- all verdicts of one run -------------------------------------------------------------------------------------


VERDICT_KEYS = ("energy_conserved", "precession_rate_rad_s", *VERDICT_COLUMNS)
"""Every verdict of one run: the schema's accuracy columns plus the model fact and the measured rate."""


def rate_errors(prefix: str, error_rad_s: float, params: PendulumParameters) -> dict[str, float]:
    """A precession-rate error three ways: relative to the local rate Ω_E|sin φ| (``prefix``; it grows without
    bound towards the equator, where the rate vanishes), in rad/s, and relative to Ω_E (``_earth``: the one that
    compares across latitudes; NaN without rotation)."""
    earth = params.earth_rate_rad_s
    return {
        prefix: error_rad_s / rate_scale(params),
        f"{prefix}_rad_s": error_rad_s,
        f"{prefix}_earth": error_rad_s / earth if earth > 0 else NAN,
    }


def compute_verdicts(scene: "Scene", solution: Solution, reference: "Reference | None") -> dict[str, Any]:
    """The verdict columns of ``bench.schema`` for one run (plus ``precession_rate_stderr_rad_s`` and
    ``turning_points``, the count used for the rate).

    * failed run: only ``energy_conserved`` (a property of the model); everything else NaN;
    * diverged run: energy and trajectory gaps over the grid up to the last finite row (lower bounds of what
      the run did), precession NaN (the swing near a divergence is no longer a pendulum's); every verdict NaN
      when no row after the initial state is finite, and the streamed energy error NaN when no step was taken
      (``MIN_INTEGRATED_ROWS``: no data, not a perfect score);
    * ``analytic_gap_*`` only for a planar model released from rest: the closed forms assume the release, and
      for the spherical model the gap would measure the model (its finite-amplitude period), not the run;
      for the seed's eqs. 4-5, ``analytic_gap_seed`` is the comparison the seed itself makes (its §4);
    * ``reference_error`` and ``precession_rate_ref_error`` only with a reference on the same grid.
    """
    model = scene.model_object
    params = scene.params
    verdicts: dict[str, Any] = dict.fromkeys(VERDICT_KEYS, NAN)
    verdicts.update(energy_conserved=int(model.conserves_energy), energy_max_rel_error_steps=None,
                    precession_rate_stderr_rad_s=NAN, turning_points=0)
    if solution.status not in (STATUS_OK, STATUS_DIVERGED):
        return verdicts
    t, y = np.asarray(solution.t, dtype=np.float64), np.asarray(solution.y, dtype=np.float64)
    if reference is not None and (reference.t.shape != t.shape or not np.array_equal(reference.t, t)):
        raise ValueError(f"scene {scene.name}: the solution's output grid differs from the reference's")
    verdicts.update(energy_verdicts(model, params, solution))
    amplitude = params.amplitude_m
    if released_from_rest(params) and not model.constrained_to_sphere:
        verdicts["analytic_gap_exact"] = max_position_gap(y, linear_exact(params, t), amplitude)
        verdicts["analytic_gap_seed"] = max_position_gap(y, seed_approximate(params, t), amplitude)
    if reference is not None:
        verdicts["reference_error"] = max_position_gap(y, reference.y, amplitude)
        verdicts.update(ellipse_errors(params, y, reference.y))
    if not model.conserves_energy:
        verdicts["energy_balance_max_rel_error"] = energy_balance_max_rel_error(model, params, t, y,
                                                                                 *energy_scale(model, params))
    if solution.status == STATUS_OK:
        points = turning_points_from_grid(t, y, grid_accelerations(model, params, y), released_from_rest(params))
        rate, stderr = precession_rate(points)
        verdicts.update(precession_rate_rad_s=rate, precession_rate_stderr_rad_s=stderr,
                        turning_points=int(points.shape[0]))
        verdicts.update(rate_errors("precession_rate_error", abs(rate - params.textbook_precession_rate_rad_s),
                                    params))
        if reference is not None:
            verdicts.update(rate_errors("precession_rate_ref_error", abs(rate - reference.precession_rate_rad_s),
                                        params))
    return verdicts
