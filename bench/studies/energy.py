"""The long-time energy study: relative energy error against time for one representative per integrator family
(``family_representatives``); ``energy_trends`` says from the table which errors stay bounded, drift or grow."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from foucault_bench.integrators import (
    STATUS_DIVERGED,
    STATUS_OK,
    Problem,
)
from foucault_bench.integrators.registry import REGISTRY
from foucault_bench.models import PendulumParameters, get_model
from foucault_bench.bench.studies.common import (
    family_of, family_representatives, progress_over, relative_energy_error, solve_with_setting,
    study_setting_label, with_config_columns,
)


@dataclass(frozen=True)
class LongTimeEnergyConfig:
    """One pendulum integrated for a long time by one representative per family.

    ``runs`` pairs an integrator name with its setting (k·h for fixed-step, tolerance for adaptive); ``None``
    (the default) runs ``family_representatives()``, the fixed-step ones at k·h = ``kh`` and the adaptive ones
    at tolerance ``tol``. Default: the Panthéon (L = 67 m, φ = 48.846°, A = 3 m) on the spherical model for
    6 h (1317 swings).
    """

    model: str = "spherical"
    length_m: float = 67.0
    latitude_deg: float = 48.846
    amplitude_m: float = 3.0
    duration_s: float = 21600.0
    n_out: int = 4001
    kh: float = 0.05
    tol: float = 1e-12
    runs: tuple[tuple[str, float], ...] | None = None

    def chosen_runs(self) -> tuple[tuple[str, float], ...]:
        """``runs``, or one representative per family at ``kh`` or ``tol``."""
        if self.runs is not None:
            return self.runs
        return tuple((name, self.tol if REGISTRY[name].adaptive else self.kh)
                     for name in family_representatives().values())


def long_time_energy(config: LongTimeEnergyConfig = LongTimeEnergyConfig(), progress: bool = True) -> pd.DataFrame:
    """Relative energy error (E − E₀)/E_swing (``relative_energy_error``) on a uniform output grid (t > 0) for
    each run of ``config.chosen_runs()``.

    Columns: integrator, family, setting, status, message, t_s, energy_rel_error, plus the config's scalars.
    Rows after a divergence carry NaN errors; a failed run keeps one row per output time, all NaN.
    """
    model = get_model(config.model)
    params = PendulumParameters(length_m=config.length_m, latitude_deg=config.latitude_deg,
                                amplitude_m=config.amplitude_m)
    t_out = np.linspace(0.0, config.duration_s, config.n_out)
    problem = Problem(model=model, params=params, t_out=t_out)
    frames = []
    for name, setting in progress_over(list(config.chosen_runs()), "long-time energy", progress):
        solution = solve_with_setting(name, problem, setting)
        frames.append(pd.DataFrame({
            "integrator": name,
            "family": family_of(name),
            "setting": study_setting_label(name, setting),
            "status": solution.status,
            "message": solution.message,
            "t_s": t_out[1:],
            "energy_rel_error": relative_energy_error(model, params, solution.y)[1:],
        }))
    frame = pd.concat(frames, ignore_index=True)
    return with_config_columns(frame, config, exclude=("runs",))


def long_time_energy_parts(config: LongTimeEnergyConfig) -> list[LongTimeEnergyConfig]:
    """One config per run of ``config.chosen_runs()``: their tables, one after another, are ``config``'s (each run
    is its own rows, and ``runs`` is not a column)."""
    return [replace(config, runs=(run,)) for run in config.chosen_runs()]


BOUNDED_BELOW_EXPONENT = 0.25
"""An energy error whose running maximum grows slower than t^0.25 counts as bounded: nearer to a filled band's
t⁰ than to the t^0.5 of a random walk of round-off errors (Brouwer 1937), the slowest drift."""
GROWING_ABOVE_EXPONENT = 2.0
"""Faster than t² counts as growing (a linear drift is t¹; an exponential growth steepens without bound)."""


def early_horizon_s(duration_s: float) -> float:
    """The "first hour" of ``energy_trends``: 1 h, or half the run when it is shorter than 2 h."""
    return min(3600.0, duration_s / 2.0)


def energy_trends(energy: pd.DataFrame) -> pd.DataFrame:
    """Per run of a ``long_time_energy`` table: how its relative energy error behaves.

    M(t) is the largest |error| up to t. Columns: integrator, family, setting, status; early_horizon_s
    (``early_horizon_s`` of the run's duration); early_max_error M(early_horizon_s); max_error M at the last
    finite output (NaN when there is none); last_finite_s that time; exponent p of a least-squares fit
    log M = p log t + c over the finite outputs from early_horizon_s on (M floored at the double-precision unit
    round-off; NaN with fewer than two such outputs); trend: ``diverged`` or ``failed`` after the status,
    else ``bounded`` (p < ``BOUNDED_BELOW_EXPONENT``), ``growing`` (p > ``GROWING_ABOVE_EXPONENT``) or
    ``drifting``."""
    rows = []
    horizon_s = early_horizon_s(float(energy["config_duration_s"].iloc[0]))
    for (integrator, setting), run in energy.groupby(["integrator", "setting"], sort=False):
        run = run.sort_values("t_s")
        error = run["energy_rel_error"].abs().to_numpy(dtype=float)
        t_s = run["t_s"].to_numpy(dtype=float)
        finite = np.isfinite(error)
        running_max = np.maximum.accumulate(np.maximum(error[finite], np.finfo(float).eps))
        times = t_s[finite]
        late = times >= horizon_s
        exponent = (float(np.polyfit(np.log(times[late]), np.log(running_max[late]), 1)[0])
                    if np.count_nonzero(late) >= 2 else math.nan)
        status = run["status"].iloc[0]
        if status != STATUS_OK:
            trend = "diverged" if status == STATUS_DIVERGED else "failed"
        elif exponent < BOUNDED_BELOW_EXPONENT:
            trend = "bounded"
        elif exponent > GROWING_ABOVE_EXPONENT:
            trend = "growing"
        else:
            trend = "drifting"
        early = error[finite & (t_s <= horizon_s)]
        rows.append({
            "integrator": integrator, "family": run["family"].iloc[0], "setting": setting, "status": status,
            "early_horizon_s": horizon_s,
            "early_max_error": float(early.max()) if early.size else math.nan,
            "max_error": float(error[finite].max()) if finite.any() else math.nan,
            "last_finite_s": float(times[-1]) if times.size else math.nan,
            "exponent": exponent,
            "trend": trend,
        })
    return pd.DataFrame(rows)
