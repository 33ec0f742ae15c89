"""Counted right-hand-side evaluations of a fixed-step scheme's compiled step.

A fixed-step step ``(x, y, vx, vy, h, p)`` evaluates the model through its compiled pieces. To count those
evaluations instead of trusting a declaration, the step is built once more (``make_step``) on a copy of the model
whose force-evaluating pieces count each call: ``numba_acceleration`` (the right-hand side, a Runge-Kutta stage),
``numba_kick`` (a Verlet kick: the position-only force) and ``numba_free_force`` (the force itself, where a scheme
calls it directly, as Boris does). One call of any of them is one evaluation; what they call inside is not counted
again. The counter is an extra last slot of the parameter vector, passed to the pieces as an array (every piece
reads the parameters it needs by index and passes ``p`` on), and the counting step is called over a few steps from
Python (a compiled loop around it would be one more compilation per scheme and model: 0.55 s of CPU each, measured
over a cold test suite). The timed loop (``integrators.fixed_step.build_kernel``) is not touched: counting costs nothing there.
"""

from __future__ import annotations

import copy
from typing import Callable

import numpy as np

from foucault_bench.models import Model
from foucault_bench.models.jit import jit
from foucault_bench.models.parameters import PARAMETER_COUNT

COUNTED_PIECES = ("numba_acceleration", "numba_kick", "numba_free_force")
"""The model's compiled pieces whose calls are right-hand-side evaluations."""

COUNTER_SLOT = PARAMETER_COUNT
"""Index of the counter in the parameter array the counting step receives."""


def _counting(piece: Callable) -> Callable:
    """``piece`` with one more evaluation added to ``p[COUNTER_SLOT]`` (``p``: its last argument) per call."""

    @jit
    def counted(*arguments):
        parameters = arguments[-1]
        parameters[COUNTER_SLOT] += 1.0
        return piece(*arguments)

    return counted


def counting_model(model: Model) -> Model:
    """A copy of ``model`` whose force-evaluating pieces (``COUNTED_PIECES``) count their calls."""
    counted = copy.copy(model)
    for name in COUNTED_PIECES:
        vars(counted)[name] = _counting(getattr(model, name))  # the cached properties of the copy, overridden
    return counted


def evaluations_per_step(make_step: Callable[[Model], Callable], model: Model, state: np.ndarray,
                         parameter_vector: np.ndarray, h: float, n_steps: int) -> float:
    """Right-hand-side evaluations per step of the step ``make_step(model)``, counted over ``n_steps`` steps of size
    ``h`` from ``state`` (a float: an implicit scheme's count may vary from step to step)."""
    parameters = np.append(np.asarray(parameter_vector, dtype=np.float64), 0.0)
    x, y, vx, vy = (float(value) for value in state)
    step = make_step(counting_model(model))
    for _ in range(n_steps):  # from Python: only the step is compiled, not a loop around it as well
        x, y, vx, vy = step(x, y, vx, vy, h, parameters)
    return float(parameters[COUNTER_SLOT]) / n_steps
