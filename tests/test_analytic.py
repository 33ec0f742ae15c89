"""The closed forms: the seed's approximate solution differs from the exact one by what models/README.md "Closed
forms" derives."""

import numpy as np

from foucault_bench.models import PendulumParameters
from foucault_bench.models.analytic import linear_exact, seed_approximate, seed_gap_bound, textbook_turning_azimuth

PANTHEON = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
SIDEREAL_DAY_S = 86164.0905


def test_seed_gap_is_the_derived_amount_and_not_more() -> None:
    t = np.linspace(0.0, SIDEREAL_DAY_S, 200_001)
    difference = seed_approximate(PANTHEON, t) - linear_exact(PANTHEON, t)
    gap = np.hypot(difference[:, 0], difference[:, 1]) / PANTHEON.amplitude_m
    bound = seed_gap_bound(PANTHEON, t)
    # Terms the leading-order formula neglects: the |cos kt| terms δ·√(δ²/4 + (a/k)²) with δ = (Ω − k)t, and
    # a relative (a/k)² from a/Ω = (a/k)(1 − a²/2k² + …).
    k = PANTHEON.pendulum_frequency_rad_s
    a = PANTHEON.vertical_rate_rad_s
    delta = (np.sqrt(k * k + a * a) - k) * t
    neglected = 1.01 * delta * np.sqrt(delta**2 / 4 + (a / k) ** 2) + (a / k) ** 2 * bound + 1e-15
    assert np.all(np.abs(gap - bound) <= neglected)
    # models/README.md "Closed forms": 3.7e-4 of the amplitude over one day at the Panthéon.
    assert 3.6e-4 < gap.max() < 3.8e-4


def test_turning_points_of_the_exact_solution_lie_on_the_textbook_azimuth() -> None:
    k = PANTHEON.pendulum_frequency_rad_s
    a = PANTHEON.vertical_rate_rad_s
    big_omega = np.sqrt(k * k + a * a)
    t_turn = np.arange(1, 2000) * np.pi / big_omega
    state = linear_exact(PANTHEON, t_turn)
    # at t = nπ/Ω the velocity vanishes and the azimuth is ψ₀ − a t (modulo π: opposite ends of the swing)
    assert np.max(np.hypot(state[:, 2], state[:, 3])) < 1e-12 * k * PANTHEON.amplitude_m * 1e3
    azimuth = np.arctan2(state[:, 1], state[:, 0])
    expected = textbook_turning_azimuth(PANTHEON, t_turn)
    wrapped = np.angle(np.exp(2j * (azimuth - expected))) / 2
    assert np.max(np.abs(wrapped)) < 1e-11
