"""The two compiled forms of each model agree: numba's right-hand side and heyoka's expressions (both built
from the model's one source, models/base.py), and heyoka's symbolic Jacobian matches the numba right-hand side.

Samples: 1,200 random states per model, positions uniform in a disc of radius L/2 (well inside the sphere),
velocities uniform in a square of half-side k·L/2 (the pendulum's speed scale), and parameters varying every
field of ``PendulumParameters`` (the list is derived from the dataclass, so a new field is varied without
editing this file): the fields with a sampler in ``SAMPLERS`` as drawn there (several latitudes in both
hemispheres, equator, poles; two lengths; Earth's gravity and the Moon's; centrifugal on and off; Earth's rate
and a fast rotation Ω = 0.2 k that makes every rotation term of order one, so a wrong sign or factor in any
term shows far above round-off), every other field half the time at its default and half the time at an
example value that a model declares for it (``Model.example_parameters``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import heyoka
import numpy as np
import pytest

from foucault_bench.models import MODELS, Model, PendulumParameters
from foucault_bench.models.parameters import P_K2, P_LENGTH, PARAMETER_COUNT, PARAMETER_VECTOR_NAMES

N_SAMPLES = 1200
LATITUDES_DEG = (-90.0, -48.846, -10.0, 0.0, 30.0, 48.846, 90.0)
LENGTHS_M = (3.0, 67.0)
GRAVITIES_M_S2 = (9.81, 1.62)
RHS_AGREEMENT = 1.0e-14
"""Relative to each component's scale (max |component| over the sample): a few ulps of reordered arithmetic."""

SAMPLERS: dict[str, Callable[[np.random.Generator, dict], Any]] = {
    "length_m": lambda rng, drawn: LENGTHS_M[rng.integers(len(LENGTHS_M))],
    "latitude_deg": lambda rng, drawn: LATITUDES_DEG[rng.integers(len(LATITUDES_DEG))],
    "amplitude_m": lambda rng, drawn: 0.5 * drawn["length_m"],
    "gravity_m_s2": lambda rng, drawn: GRAVITIES_M_S2[rng.integers(len(GRAVITIES_M_S2))],
    "earth_rate_rad_s": lambda rng, drawn: (0.2 * np.sqrt(drawn["gravity_m_s2"] / drawn["length_m"])
                                            if rng.random() < 0.5 else 7.2921159e-5),
    "release_azimuth_deg": lambda rng, drawn: float(rng.uniform(0.0, 360.0)),
    "release_velocity_m_s": lambda rng, drawn: tuple(float(v) for v in rng.uniform(-0.1, 0.1, 2)),
    "centrifugal": lambda rng, drawn: bool(rng.random() < 0.5),
}
"""How the built-in fields are drawn, in field order (each may read the fields drawn before it)."""


def field_choices() -> dict[str, tuple]:
    """For each field without a sampler: its default and every example value a model declares for it."""
    choices = {}
    for spec in dataclasses.fields(PendulumParameters):
        if spec.name not in SAMPLERS:
            examples = {model.example_parameters[spec.name] for model in MODELS.values()
                        if spec.name in model.example_parameters}
            choices[spec.name] = (spec.default, *sorted(examples, key=repr))
    return choices


def random_parameters(rng: np.random.Generator) -> PendulumParameters:
    drawn: dict = {}
    choices = field_choices()
    for spec in dataclasses.fields(PendulumParameters):
        if spec.name in SAMPLERS:
            drawn[spec.name] = SAMPLERS[spec.name](rng, drawn)
        else:
            drawn[spec.name] = choices[spec.name][rng.integers(len(choices[spec.name]))]
    return PendulumParameters(**drawn)


def random_sample(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """States (N, 4) and parameter vectors (N, PARAMETER_COUNT) drawn as in the module docstring."""
    rng = np.random.default_rng(seed)
    states = np.empty((N_SAMPLES, 4))
    pars = np.empty((N_SAMPLES, PARAMETER_COUNT))
    for i in range(N_SAMPLES):
        params = random_parameters(rng)
        length, k = params.length_m, params.pendulum_frequency_rad_s
        radius = 0.5 * length * np.sqrt(rng.random())
        angle = 2.0 * np.pi * rng.random()
        states[i] = (radius * np.cos(angle), radius * np.sin(angle), *(0.5 * k * length * rng.uniform(-1, 1, 2)))
        pars[i] = params.parameter_vector()
    return states, pars


def test_the_sample_varies_every_field_and_every_parameter_slot() -> None:
    """Every field of ``PendulumParameters`` takes two values or more over the sample (a new field needs a model
    that declares an example value for it, ``Model.example_parameters``), and so does every slot of the
    parameter vector (omega_y is 0 by the frame's convention and is the one exception)."""
    rng = np.random.default_rng(1)
    drawn = [random_parameters(rng) for _ in range(200)]
    for spec in dataclasses.fields(PendulumParameters):
        values = {repr(getattr(params, spec.name)) for params in drawn}
        assert len(values) >= 2, (f"{spec.name} is never varied: declare an example value for it in the "
                                  "example_parameters of the model that reads it")
    _, pars = random_sample(seed=1)
    for slot_name, column in zip(PARAMETER_VECTOR_NAMES, pars.T, strict=True):
        if slot_name != "omega_y":
            assert np.unique(column).size >= 2, slot_name


def heyoka_rhs(model: Model):
    system = model.heyoka_system()
    return heyoka.cfunc([rhs for _, rhs in system], vars=[variable for variable, _ in system])


@pytest.mark.parametrize("model", MODELS.values(), ids=MODELS.keys())
def test_numba_and_heyoka_right_hand_sides_agree(model: Model) -> None:
    states, pars = random_sample(seed=1)
    numba_values = np.array([model.numba_rhs(0.0, state, p) for state, p in zip(states, pars, strict=True)])
    heyoka_values = heyoka_rhs(model)(states.T.copy(), pars=model.heyoka_parameters(pars).T.copy()).T
    scale = np.max(np.abs(numba_values), axis=0)
    assert np.all(scale > 0.0)
    worst = np.max(np.abs(heyoka_values - numba_values) / scale, axis=0)
    assert np.all(worst <= RHS_AGREEMENT), f"relative disagreement per component {worst}"


@pytest.mark.parametrize("model", MODELS.values(), ids=MODELS.keys())
def test_symbolic_jacobian_matches_central_differences_of_the_numba_rhs(model: Model) -> None:
    """∂f/∂y_j from ``Model.jacobian_into`` vs the 4th-order central difference of the numba RHS with step
    δ = 1e-3 × (L, L, kL, kL) of each sample: the state varies on the scales L and kL, so the truncation is
    ~(δ/L)⁴ ≈ 1e-12 and the round-off ~ε/1e-3 ≈ 2e-13 of the scale; agreement to 1e-9 of each column's scale
    leaves a margin of 1000 and still catches any wrong term (the rotation terms are O(1) in the fast samples)."""
    states, pars = random_sample(seed=2)
    weights = {-2: 1.0 / 12.0, -1: -8.0 / 12.0, 1: 8.0 / 12.0, 2: -1.0 / 12.0}
    worst = 0.0
    analytic = np.empty((4, 4))
    for state, p in zip(states[:200], pars[:200], strict=True):
        length, k = p[P_LENGTH], np.sqrt(p[P_K2])
        step = 1.0e-3 * np.array([length, length, k * length, k * length])
        model.jacobian_into(0.0, state, analytic, p)
        numeric = np.empty((4, 4))
        for j in range(4):
            shifted = [model.numba_rhs(0.0, state + m * step[j] * np.eye(4)[j], p) for m in weights]
            numeric[:, j] = sum(w * f for w, f in zip(weights.values(), shifted, strict=True)) / step[j]
        column_scale = np.maximum(np.max(np.abs(numeric), axis=0), 1e-300)
        worst = max(worst, float(np.max(np.abs(analytic - numeric) / column_scale)))
    assert worst <= 1.0e-9


@pytest.mark.parametrize("model", MODELS.values(), ids=MODELS.keys())
def test_numba_jacobian_is_the_symbolic_jacobian(model: Model) -> None:
    """``Model.numba_jacobian_into`` (the same derivatives rewritten by sympy and compiled by numba, for CVODE's
    compiled callback) writes every entry, into any memory layout, and agrees with ``Model.jacobian_into`` to
    round-off: ``RHS_AGREEMENT`` of each column's scale over the sample (measured: 0, 2.2e-16 and 6.6e-16 of
    it on the linear, seed-planar and spherical models)."""
    states, pars = random_sample(seed=3)
    symbolic = np.empty((4, 4))
    worst = 0.0
    for state, p in zip(states, pars, strict=True):
        model.jacobian_into(0.0, state, symbolic, p)
        for layout in ("C", "F"):
            compiled = np.full((4, 4), np.nan, order=layout)
            model.numba_jacobian_into(0.0, state, compiled, p)
            assert np.all(np.isfinite(compiled))
            column_scale = np.maximum(np.max(np.abs(symbolic), axis=0), 1e-300)
            worst = max(worst, float(np.max(np.abs(compiled - symbolic) / column_scale)))
    assert worst <= RHS_AGREEMENT, worst
