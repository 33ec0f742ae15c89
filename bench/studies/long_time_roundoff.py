"""The long-time round-off study: how the invariant quadratic form of a stable linear one-step map drifts.

On the linear model every fixed-step scheme of the suite is a linear map M of the state (``bench.verdicts.stability``
measures it on the scheme's own compiled step). A stable M with eigenvalues on the unit circle conserves the
quadratic forms Q with MᵀQM = Q (the discrete Lyapunov or Stein equation with zero right-hand side; Lancaster &
Tismenetsky, *The Theory of Matrices*, 2nd ed., §13.2): in exact arithmetic Q(yₙ) = Q(y₀) for ever, so every
change of Q along a computed trajectory is round-off. For the Gauss–Legendre methods the linear model's energy is
one of these forms (Cooper 1987; Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., Thm. IV.2.2).
When M has two distinct eigenvalue pairs (Earth's rotation splits the swing into two circular modes) the
solutions form a two-dimensional space; the study takes the one nearest the oscillator's energy
k²|r|² + |v|² (least squares over the null space of X ↦ MᵀXM − X on symmetric X, by an SVD).

Round-off errors of size ε per step that are independent from step to step make Q perform a random walk,
|ΔQ|/Q ≈ C ε nᵅ with α = ½ (Brouwer, Astron. J. 46, 149 (1937); Hairer, McLachlan & Razakarivony, BIT 48, 231
(2008), §2); a systematic error per step (rounded coefficients that break the invariance, a solve stopped short of
its fixed point) gives α = 1. ``roundoff_growth`` runs each scheme from several releases with random swing
phase and azimuth, takes the root mean square of ΔQ/Q₀ over each window (n/√10, n] ending at a power of ten, the
median over the releases (robust to one lucky or unlucky walk), and fits log|ΔQ| = log C + α log n by least
squares (``fit_growth``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Callable, cast

import numpy as np
import pandas as pd

from foucault_bench.bench.studies.common import progress_over, with_config_columns
from foucault_bench.bench.verdicts.stability import step_matrix
from foucault_bench.integrators import FixedStepIntegrator, get_integrator
from foucault_bench.integrators.fixed_step import build_kernel
from foucault_bench.models import MODELS, PendulumParameters

ROUNDOFF_INTEGRATORS = ("verlet", "yoshida4", "composition6", "composition8", "composition10", "implicit_midpoint",
                        "gauss_legendre4")
"""The schemes whose invariant form the study follows: the symmetric, symplectic ones (Verlet, its compositions of
orders 4 to 10, the Gauss–Legendre methods)."""
BROUWER_EXPONENT = 0.5
NULL_SPACE_TOLERANCE = 1e-10
"""Singular values of X ↦ MᵀXM − X (on ``rotation_invariant_forms``) below this span the invariant forms:
round-off in M leaves ~1e-15, the forms not conserved are moved by O((kh)²) ≥ 1e-4 for kh ≥ 0.01."""


@dataclass(frozen=True)
class RoundoffConfig:
    """The linear model at k·h = ``kh`` (Panthéon pendulum), ``releases`` random releases (seeded), runs of
    10^``max_decade`` steps sampled every ``stride`` steps, windows ending at 10^``min_decade`` … 10^``max_decade``."""

    integrators: tuple[str, ...] = ROUNDOFF_INTEGRATORS
    kh: float = 0.5
    length_m: float = 67.0
    latitude_deg: float = 48.846
    amplitude_m: float = 3.0
    releases: int = 5
    min_decade: int = 3
    max_decade: int = 6
    stride: int = 100
    seed: int = 2008
    compensated: bool = True
    """False: the schemes that advance by an increment (``FixedStepIntegrator.make_increment``) run in the loop
    with plain sums instead of compensated ones (the comparison of ``perf``'s ``roundoff`` section)."""


def rotation_invariant_forms() -> tuple[np.ndarray, ...]:
    """The quadratic forms on the scaled state (x, y, u, w) = (x, y, ẋ/k, ẏ/k) that a turn of the plane (r and v
    turned together) leaves unchanged: |r|², |v|², r·v and (r×v)_z. The linear model is isotropic, so its
    one-step maps commute with those turns and their invariant forms lie in this span."""
    forms = [np.zeros((4, 4)) for _ in range(4)]
    forms[0][[0, 1], [0, 1]] = 1.0
    forms[1][[2, 3], [2, 3]] = 1.0
    forms[2][[0, 1, 2, 3], [2, 3, 0, 1]] = 0.5
    forms[3][[0, 3, 1, 2], [3, 0, 2, 1]] = (0.5, 0.5, -0.5, -0.5)
    return tuple(forms)


def invariant_form(matrix: np.ndarray) -> np.ndarray:
    """The Q with MᵀQM = Q in the span of ``rotation_invariant_forms`` nearest (Frobenius) to the identity (the
    oscillator's energy on the scaled state), normalised to trace 4. Within that span the equation is well
    conditioned: the forms it does not conserve are moved by O(kh) a step, whereas among all symmetric matrices the
    two circular modes' forms differ by only a·h ≈ 1e-4 kh, and round-off in M would mix them by ε/(a·h)."""
    basis = rotation_invariant_forms()
    operator = np.column_stack([(matrix.T @ unit @ matrix - unit).ravel() for unit in basis])
    _, singular, vt = np.linalg.svd(operator)
    null = vt[singular < NULL_SPACE_TOLERANCE * max(singular[0], 1.0)]
    if null.shape[0] == 0:
        raise ValueError("the one-step map conserves no quadratic form (not stable, or not on the unit circle)")
    forms = [sum(c * unit for c, unit in zip(row, basis, strict=True)) for row in null]
    gram = np.array([[np.sum(a * b) for b in forms] for a in forms])
    weights = np.linalg.solve(gram, np.array([np.trace(form) for form in forms]))
    q = sum(w * form for w, form in zip(weights, forms, strict=True))
    return cast(np.ndarray, q * (4.0 / np.trace(q)))


def scaled_step_matrix(integrator: FixedStepIntegrator, params: PendulumParameters, h: float) -> np.ndarray:
    """The one-step matrix on the scaled state (x, y, ẋ/k, ẏ/k), in which the oscillator's energy is |·|²."""
    scale = np.diag([1.0, 1.0, params.pendulum_frequency_rad_s, params.pendulum_frequency_rad_s])
    return cast(np.ndarray, np.linalg.solve(scale, step_matrix(integrator, params, h) @ scale))


def releases(config: RoundoffConfig, params: PendulumParameters) -> np.ndarray:
    """``config.releases`` states of amplitude A: random swing phase θ and azimuth ψ (seeded),
    r = A cos θ (cos ψ, sin ψ), v = −kA sin θ (cos ψ, sin ψ)."""
    rng = np.random.default_rng(config.seed)
    theta, psi = rng.uniform(0.0, 2.0 * np.pi, (2, config.releases))
    amplitude, k = params.amplitude_m, params.pendulum_frequency_rad_s
    return np.column_stack([amplitude * np.cos(theta) * np.cos(psi), amplitude * np.cos(theta) * np.sin(psi),
                            -k * amplitude * np.sin(theta) * np.cos(psi), -k * amplitude * np.sin(theta) * np.sin(psi)])


@functools.lru_cache(maxsize=None)
def plain_kernel(integrator: FixedStepIntegrator) -> Callable:
    """The scheme's fixed-step loop on the linear model with plain sums for the state update."""
    model = MODELS["linear"]
    step, setup = integrator.loop_step(model)
    return build_kernel(step, model.numba_energy, setup=setup)


def loop(integrator: FixedStepIntegrator, compensated: bool) -> Callable:
    """The compiled loop the suite runs (``compensated``) or ``plain_kernel``."""
    return integrator.kernel(MODELS["linear"]) if compensated else plain_kernel(integrator)


def form_drift(integrator: FixedStepIntegrator, params: PendulumParameters, h: float, state0: np.ndarray,
               n_steps: int, stride: int, q: np.ndarray, compensated: bool = True) -> np.ndarray:
    """ΔQ/Q₀ every ``stride`` steps of the scheme's compiled loop (``monitor`` off) from ``state0``."""
    out = np.full((n_steps // stride + 1, 4), np.nan)
    status, steps_done, *_ = loop(integrator, compensated)(
        state0, params.parameter_vector(), h, n_steps, stride, out, False, np.empty((0, 3)), 1e3 * params.length_m)
    if status != 0 or steps_done != n_steps:
        raise RuntimeError(f"{integrator.name} stopped after {steps_done} of {n_steps} steps")
    k = params.pendulum_frequency_rad_s
    scaled = out * np.array([1.0, 1.0, 1.0 / k, 1.0 / k])
    values = np.einsum("ni,ij,nj->n", scaled, q, scaled)
    return cast(np.ndarray, values / values[0] - 1.0)


def fit_growth(steps: np.ndarray, drift: np.ndarray) -> tuple[float, float]:
    """(α, C) of the least-squares fit log₁₀|ΔQ| = log₁₀(C ε) + α log₁₀ n (ε the double-precision epsilon)."""
    slope, intercept = np.polyfit(np.log10(steps), np.log10(drift), 1)
    return float(slope), float(10.0**intercept / np.finfo(np.float64).eps)


def roundoff_growth(config: RoundoffConfig = RoundoffConfig(), progress: bool = False) -> pd.DataFrame:
    """One row per (integrator, decade): family, kh, compensated (the config's), steps (10^decade), drift_rms (median over the releases of the RMS of
    ΔQ/Q₀ over the window (n/√10, n]), drift_min and drift_max (over the releases), and the integrator's fitted
    exponent and constant (``fit_growth`` over all its decades), repeated on its rows; plus the config's other
    scalars as ``config_<field>`` columns."""
    params = PendulumParameters(length_m=config.length_m, latitude_deg=config.latitude_deg,
                                amplitude_m=config.amplitude_m)
    h = config.kh / params.pendulum_frequency_rad_s
    n_steps = 10**config.max_decade
    decades = np.arange(config.min_decade, config.max_decade + 1)
    steps_at = np.arange(n_steps // config.stride + 1) * config.stride
    rows = []
    for name in progress_over(list(config.integrators), "long-time round-off", progress):
        integrator = cast(FixedStepIntegrator, get_integrator(name))
        q = invariant_form(scaled_step_matrix(integrator, params, h))
        per_release = np.array([[math.sqrt(float(np.mean(drift[(steps_at > 10.0 ** (d - 0.5)) & (steps_at <= 10**d)] ** 2)))
                                 for d in decades]
                                for drift in (form_drift(integrator, params, h, state0, n_steps, config.stride, q,
                                                         config.compensated)
                                              for state0 in releases(config, params))])
        rms = np.median(per_release, axis=0)
        exponent, constant = fit_growth(10.0**decades, rms)
        rows += [{"integrator": name, "family": integrator.family, "kh": config.kh, "compensated": config.compensated, "steps": int(10**d), "drift_rms": rms[i],
                  "drift_min": per_release[:, i].min(), "drift_max": per_release[:, i].max(),
                  "exponent": exponent, "constant": constant} for i, d in enumerate(decades)]
    return with_config_columns(pd.DataFrame(rows), config, exclude=("integrators", "kh", "compensated"))


def roundoff_growth_parts(config: RoundoffConfig) -> list[RoundoffConfig]:
    """One config per integrator of ``config.integrators``: their tables, one after another, are ``config``'s (each
    integrator is its own rows, from the same seeded releases, and ``integrators`` is not a column)."""
    return [replace(config, integrators=(name,)) for name in config.integrators]
