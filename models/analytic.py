"""Closed-form solutions of the linear planar model (models/README.md "Closed forms"), vectorised over time.

Both are written for a release from rest at amplitude A along azimuth ψ₀ (from x = South towards y = East),
in complex form z = x + iy, with k = √(g/L), a = Ω_E sin φ and Ω = √(k² + a²):

* exact solution of seed eqs. (6)-(7):  z(t) = A e^{iψ₀} e^{−iat} [cos Ωt + i (a/Ω) sin Ωt].
  Derivation: z̈ + 2ia ż + k² z = 0 has the roots −ia ± iΩ (seed §3, with the seed's own algebra); the two
  constants follow from z(0) = A e^{iψ₀}, ż(0) = 0. For ψ₀ = 90° (the seed's release) it is
  z = y₀ e^{−iat}[i cos Ωt − (a/Ω) sin Ωt]. Turning points (t = nπ/Ω) lie exactly on azimuth ψ₀ − at.
* the seed's approximate solution, eqs. (14)-(15):  z(t) = A e^{iψ₀} e^{−iat} cos kt. It drops the
  narrow ellipse (c₄ ≈ c₂ in the seed) and uses k for Ω, so its gap from the exact solution is
  |Δz| ≈ A |sin kt| √((a/k)² + (a²t/2k)²) (models/README.md "Closed forms"; ``seed_gap_bound``).
"""

from __future__ import annotations

import numpy as np

from foucault_bench.models.parameters import PendulumParameters


def _release(params: PendulumParameters) -> complex:
    if params.release_velocity_m_s != (0.0, 0.0):
        raise ValueError("the closed forms assume a release from rest (release_velocity_m_s = (0, 0))")
    x0, y0, _, _ = params.initial_state()
    return complex(x0, y0)


def linear_exact(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """Exact solution of the linear planar model: array (len(t), 4) of (x, y, ẋ, ẏ) in m, m/s."""
    t = np.asarray(t_s, dtype=np.float64)
    k2 = params.gravity_m_s2 / params.length_m
    a = params.vertical_rate_rad_s
    big_omega = np.sqrt(k2 + a * a)
    z0 = _release(params)
    rotation = np.exp(-1j * a * t)
    cos_t = np.cos(big_omega * t)
    sin_t = np.sin(big_omega * t)
    z = z0 * rotation * (cos_t + 1j * (a / big_omega) * sin_t)
    # ż = z0 e^{−iat} [−ia(cos + i(a/Ω) sin) + (−Ω sin + i a cos)] = z0 e^{−iat} (a²/Ω − Ω) sin Ωt
    zdot = z0 * rotation * (a * a / big_omega - big_omega) * sin_t
    return np.column_stack([z.real, z.imag, zdot.real, zdot.imag])


def seed_approximate(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """The seed's approximate solution (eqs. 14-15) and its time derivative: array (len(t), 4)."""
    t = np.asarray(t_s, dtype=np.float64)
    k = params.pendulum_frequency_rad_s
    a = params.vertical_rate_rad_s
    z0 = _release(params)
    rotation = np.exp(-1j * a * t)
    z = z0 * rotation * np.cos(k * t)
    zdot = z0 * rotation * (-1j * a * np.cos(k * t) - k * np.sin(k * t))
    return np.column_stack([z.real, z.imag, zdot.real, zdot.imag])


def seed_gap_bound(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """|z_seed − z_exact| / A to leading order in a/k: |sin kt|·√((a/k)² + (a²t/2k)²) (models/README.md "Closed
    forms")."""
    t = np.asarray(t_s, dtype=np.float64)
    k = params.pendulum_frequency_rad_s
    a = params.vertical_rate_rad_s
    return np.abs(np.sin(k * t)) * np.sqrt((a / k) ** 2 + (a * a * t / (2.0 * k)) ** 2)


def textbook_turning_azimuth(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """Azimuth (rad) of the swing plane at time t for the exact linear solution: ψ₀ − a t."""
    return np.radians(params.release_azimuth_deg) - params.vertical_rate_rad_s * np.asarray(t_s, dtype=np.float64)
