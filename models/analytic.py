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


# --- drag and an anisotropic support (models/README.md "Drag and drive", "Anisotropic support") ---------------


def _only(params: PendulumParameters, model: str, allowed: tuple[str, ...]) -> None:
    """``ValueError`` unless every effect field outside ``allowed`` is at its default (no effect)."""
    effects = {"support_anisotropy": 0.0, "drag_linear_per_s": 0.0, "drag_quadratic_per_m": 0.0,
               "drive_gain_per_s": 0.0}
    active = [name for name, default in effects.items() if name not in allowed and getattr(params, name) != default]
    if active:
        raise ValueError(f"the closed form of the {model} model holds without {', '.join(active)}")


def damped_linear_exact(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """Exact solution of the linear model with linear drag γ (``damped_linear`` at c = 0): array (len(t), 4).

    With z = x + iy the equations are z̈ + (γ + 2ia) ż + k² z = 0, with the roots −b ± iW of
    λ² + 2bλ + k² = 0, b = γ/2 + ia, W = √(k² − b²) (complex, principal root). With z(0) = A e^{iψ₀}, ż(0) = 0:

        z(t) = z₀ e^{−bt} [cos Wt + (b/W) sin Wt],     ż(t) = −z₀ (k²/W) e^{−bt} sin Wt

    At γ = 0 it is ``linear_exact`` (b = ia, W = Ω). The swing decays as e^{−γt/2} while its plane turns at
    exactly −a: the drag, along the velocity, adds no torque about the vertical beyond the decay of the
    ellipse (Landau & Lifshitz, Mechanics, §25, for the damped oscillator).
    """
    _only(params, "damped linear", ("drag_linear_per_s",))
    t = np.asarray(t_s, dtype=np.float64)
    k2 = params.gravity_m_s2 / params.length_m
    b = 0.5 * params.drag_linear_per_s + 1j * params.vertical_rate_rad_s
    w = np.sqrt(complex(k2) - b * b)
    z0 = _release(params)
    decay = np.exp(-b * t)
    z = z0 * decay * (np.cos(w * t) + (b / w) * np.sin(w * t))
    zdot = -z0 * (k2 / w) * decay * np.sin(w * t)
    return np.column_stack([z.real, z.imag, zdot.real, zdot.imag])


def anisotropic_linear_matrix(params: PendulumParameters) -> np.ndarray:
    """The constant 4×4 matrix of the ``anisotropic_linear`` model, d(x, y, ẋ, ẏ)/dt = M (x, y, ẋ, ẏ)."""
    k2 = params.gravity_m_s2 / params.length_m
    a = params.vertical_rate_rad_s
    epsilon = params.support_anisotropy
    double_axis = np.radians(2.0 * params.anisotropy_axis_deg)
    c2, s2 = np.cos(double_axis), np.sin(double_axis)
    isotropic = 1.0 + 0.25 * epsilon * epsilon
    stiffness = k2 * np.array([[isotropic + epsilon * c2, epsilon * s2], [epsilon * s2, isotropic - epsilon * c2]])
    coriolis = np.array([[0.0, 2.0 * a], [-2.0 * a, 0.0]])
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-stiffness, coriolis]])


EXACT_DIGITS = 34
"""Decimal digits of the arithmetic ``anisotropic_linear_exact`` works in (binary128's 34)."""


def anisotropic_linear_exact(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """Exact solution of the ``anisotropic_linear`` model: y(t) = V e^{Λt} V⁻¹ y(0), array (len(t), 4).

    The model is linear with constant coefficients (``anisotropic_linear_matrix`` M); M = V Λ V⁻¹ with the
    eigenvalues ±iω₁, ±iω₂ (its two elliptical normal modes). The eigendecomposition and the modes' phases are
    computed in ``EXACT_DIGITS``-digit arithmetic (mpmath, Johansson et al., mpmath.org), then rounded once: in
    double precision the phase ω t of a mode computed from a rounded ω drifts by about ω t times round-off
    (1e-12 of the amplitude at kt ≈ 2500, measured), above the reference's own error. Any release.
    """
    import mpmath

    _only(params, "anisotropic linear", ("support_anisotropy",))
    with mpmath.workdps(EXACT_DIGITS):
        matrix = mpmath.matrix(anisotropic_linear_matrix(params).tolist())
        eigenvalues, vectors = mpmath.eig(matrix)
        modes = mpmath.lu_solve(vectors, mpmath.matrix(params.initial_state().tolist()))
        weighted = [[vectors[row, j] * modes[j] for j in range(4)] for row in range(4)]
        rows = []
        for time in np.asarray(t_s, dtype=np.float64):
            phases = [mpmath.exp(eigenvalues[j] * mpmath.mpf(float(time))) for j in range(4)]
            rows.append([float(mpmath.re(mpmath.fsum(weighted[row][j] * phases[j] for j in range(4))))
                         for row in range(4)])
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


def anisotropy_coupling_rad_s(params: PendulumParameters) -> float:
    """δ = kε/2 (rad/s): half the split k(1 + ε/2) − k(1 − ε/2) of the support's two swing frequencies."""
    return 0.5 * params.pendulum_frequency_rad_s * params.support_anisotropy


def anisotropic_swing_azimuth_rad(params: PendulumParameters, t_s: np.ndarray) -> np.ndarray:
    """Azimuth ψ(t) (rad, unwrapped) of the major axis of the swing of the ``anisotropic_linear`` model released
    from rest at azimuth ψ₀, averaged over the fast swing to first order in ε and a/k.

    Derivation. In complex form z = x + iy the model reads z̈ + 2ia ż + k²(1 + ε²/4) z + k²ε e^{2iβ} z̄ = 0
    (R(2β) r is e^{2iβ} z̄). Write the swing as two counter-rotating circular motions with slowly varying
    amplitudes, z = u(t) e^{ikt} + w̄(t) e^{−ikt}; put it in, drop ü, ẅ (second order in the slow rates) and
    ε² and average over the fast phase (the terms e^{±2ikt} average out): with δ = kε/2,

        u̇ = i(−a u + δ e^{2iβ} w),     ẇ = i(δ e^{−2iβ} u + a w)

    a two-level system with the Hermitian matrix H = −a σ_z + δ (cos 2β σ_x − sin 2β σ_y) (χ̇ = iHχ,
    χ = (u, w)). The swing's major axis lies at ψ = (arg u − arg w)/2, its semi-axes are |u| ± |w|, so the
    Bloch vector S = χ†σχ (S_x + iS_y = 2ūw, S_z = |u|² − |w|²) holds the swing: azimuth −2ψ, height the
    ellipticity. S turns rigidly about h = (−δ cos 2β, δ sin 2β, a) at the rate 2μ, μ = √(a² + δ²) (right-handed
    about h). A release from rest (ż(0) = 0: u = w to leading order) puts S on the equator at azimuth −2ψ₀.
    Hence ψ(t) = −½ arg S(t), with S(t) the rotation of S(0) about h by the angle 2μt (Rodrigues' formula),
    unwrapped continuously. Assumptions: ε ≪ 1 and a ≪ k (the averaging), a release from rest.

    Consequences (``anisotropic_precession_rate_rad_s``): at δ = 0, ψ = ψ₀ − at (the textbook rate); the plane's
    rate at the release is −a whatever ε and β (the anisotropy turns the plane only through the ellipticity it
    builds); S's circle winds round the poles, and the plane keeps turning, iff |S(0)·h| < |a|, i.e.
    |δ cos 2(β − ψ₀)| < |a|: otherwise the plane only rocks about a fixed direction (it "locks": its mean rate is
    zero; Salva & Salva, arXiv:2502.12230, observe precession that stops entirely).
    """
    t = np.asarray(t_s, dtype=np.float64)
    a = params.vertical_rate_rad_s
    delta = anisotropy_coupling_rad_s(params)
    double_axis = np.radians(2.0 * params.anisotropy_axis_deg)
    axis = np.array([-delta * np.cos(double_axis), delta * np.sin(double_axis), a])
    mu = float(np.hypot(a, delta))
    psi0 = np.radians(params.release_azimuth_deg)
    start = np.array([np.cos(-2.0 * psi0), np.sin(-2.0 * psi0), 0.0])
    if mu == 0.0:
        return np.full(t.shape, psi0)
    n = axis / mu
    angle = 2.0 * mu * t[:, None]
    rotated = (start * np.cos(angle) + np.cross(n, start) * np.sin(angle)
               + n * np.dot(n, start) * (1.0 - np.cos(angle)))
    bloch_azimuth = np.unwrap(np.arctan2(rotated[:, 1], rotated[:, 0]))
    return -0.5 * bloch_azimuth


def anisotropic_precession_rate_rad_s(params: PendulumParameters) -> float:
    """Mean precession rate (rad/s, counter-clockwise about up positive) of the ``anisotropic_linear`` model
    released from rest, over whole turns of the slow motion (``anisotropic_swing_azimuth_rad``, same
    assumptions): −sign(a)·√(a² + δ²) with δ = kε/2 while the plane keeps turning, |δ cos 2(β − ψ₀)| < |a|, and
    0 when it locks. The support's anisotropy speeds the mean rate up, by δ²/2a to second order in δ/a, and
    its effect on a rate measured over part of a turn depends on β − ψ₀ (the instantaneous rate oscillates
    about the mean with the plane's direction, as Guelph's 8-9 h period shows)."""
    a = params.vertical_rate_rad_s
    delta = anisotropy_coupling_rad_s(params)
    locked = abs(delta * np.cos(np.radians(2.0 * (params.anisotropy_axis_deg - params.release_azimuth_deg)))) >= abs(a)
    return 0.0 if locked else -float(np.sign(a)) * float(np.hypot(a, delta))
