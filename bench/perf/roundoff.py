"""Section ``roundoff``: round-off growth over 10⁸ steps and what compensated summation costs.

The long-time round-off study (``bench.studies.long_time_roundoff``) at its full size: the invariant quadratic
form of each symmetric scheme on the linear model at kh 0.5 (Panthéon pendulum) followed over 10⁴-10⁸ steps from
``RELEASES`` random releases, the fitted growth exponent (target ≤ ``TARGET_EXPONENT``: Brouwer's ½ with the
margin of a fit to a random walk) and constant; for the schemes that advance by an increment (the Gauss-Legendre
methods) the same with plain sums, the comparison before and after compensated summation. Then the cost of the
compensated sum: each such scheme's loop with it against the same loop with plain sums, in interleaved rounds
(``measure.interleaved``), target ≤ ``TARGET_COST`` (Hairer, McLachlan & Razakarivony, BIT 48, 231 (2008), use
it where it is cheap). Minutes at most on one core; ``--quick`` stops at 10⁶ steps.
"""

from __future__ import annotations

import dataclasses
from functools import partial
from typing import Callable, cast

import numpy as np

from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio
from foucault_bench.bench.studies.long_time_roundoff import ROUNDOFF_INTEGRATORS, RoundoffConfig, loop, roundoff_growth
from foucault_bench.integrators import FixedStepIntegrator, get_integrator
from foucault_bench.models import MODELS, PendulumParameters

SECTION = "roundoff"
TARGET_EXPONENT = 0.6
TARGET_COST = 1.10
RELEASES = 3
COST_STEPS = 200_000


def _compensated_schemes() -> list[str]:
    return [name for name in ROUNDOFF_INTEGRATORS
            if cast(FixedStepIntegrator, get_integrator(name)).make_increment(MODELS["linear"]) is not None]


def _cost_ratio(name: str, rounds: int) -> tuple[float, float, float]:
    """Median per-round time ratio compensated / plain of ``COST_STEPS`` steps at kh 0.5, and the two medians (ns)."""
    integrator = cast(FixedStepIntegrator, get_integrator(name))
    params = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
    h = 0.5 / params.pendulum_frequency_rad_s
    out = np.empty((COST_STEPS // 1000 + 1, 4))
    args = (params.initial_state(), params.parameter_vector(), h, COST_STEPS, 1000, out, False, np.empty((0, 3)), 1e6)
    calls: dict[str, Callable[[], object]] = {"compensated": partial(loop(integrator, True), *args),
                                              "plain": partial(loop(integrator, False), *args)}
    times = interleaved(calls, rounds)
    return (median_ratio(times["compensated"], times["plain"]),
            float(np.median(times["compensated"])) / COST_STEPS * 1e9, float(np.median(times["plain"])) / COST_STEPS * 1e9)


def run(quick: bool) -> tuple[list[Row], list[list], list[str]]:
    config = (RoundoffConfig(releases=RELEASES, min_decade=3, max_decade=6, stride=100) if quick
              else RoundoffConfig(releases=RELEASES, min_decade=4, max_decade=8, stride=1000))
    frames = [roundoff_growth(config),
              roundoff_growth(dataclasses.replace(config, integrators=tuple(_compensated_schemes()), compensated=False))]
    decades = range(config.min_decade, config.max_decade + 1)
    headers = ["integrator", "summation", *[f"|ΔQ|/Q at 1e{d}" for d in decades], "exponent", "constant (ε)"]
    table, rows = [], []
    for frame in frames:
        for name, group in frame.groupby("integrator", sort=False):
            summation = "compensated" if group["compensated"].iloc[0] and name in _compensated_schemes() else "plain"
            exponent, constant = float(group["exponent"].iloc[0]), float(group["constant"].iloc[0])
            table.append([name, summation, *[f"{value:.2e}" for value in group["drift_rms"]], f"{exponent:.2f}",
                          f"{constant:.2g}"])
            rows.append(Row(SECTION, f"{name} ({summation} sums): growth exponent of |ΔQ|, 1e{config.min_decade}-"
                            f"1e{config.max_decade} steps", exponent, "", TARGET_EXPONENT,
                            f"median over {RELEASES} releases, kh 0.5; constant {constant:.2g} ε"))
    for name in _compensated_schemes():
        ratio, compensated_ns, plain_ns = _cost_ratio(name, 3 if quick else 9)
        rows.append(Row(SECTION, f"{name}: compensated / plain sums, loop time", ratio, "×", TARGET_COST,
                        f"{compensated_ns:.0f} vs {plain_ns:.0f} ns/step at kh 0.5"))
    return rows, table, headers
