"""A plug-in for the cost-noise measurement (``bench.perf.cost_noise``): rk4 made 10 % slower in CPU time.

Importing it replaces the registered ``rk4`` by a subclass whose ``solve`` burns ``SLOWDOWN`` of the CPU time
the solve itself took (a busy loop on the thread's CPU clock, after the solve), and appends
``bench.perf.cost_noise.MARKER`` to the solution's message, so that the stored rows show the slowed code
reached the worker processes. Every number rk4 computes is unchanged. Used only as a matrix's ``plugins``
entry by the measurement.
"""

from __future__ import annotations

import time

from foucault_bench.bench.perf.cost_noise import MARKER
from foucault_bench.integrators import REGISTRY, Solution
from foucault_bench.integrators.methods.rk4 import RK4

SLOWDOWN = 0.10


class SlowedRK4(RK4):
    """rk4 with ``SLOWDOWN`` more CPU time per solve (module docstring)."""

    def solve(self, problem, **settings) -> Solution:
        start_s = time.thread_time()
        solution = super().solve(problem, **settings)
        until_s = time.thread_time() + SLOWDOWN * (time.thread_time() - start_s)
        while time.thread_time() < until_s:
            pass
        solution.message = "; ".join(filter(None, [solution.message, MARKER]))
        return solution


REGISTRY["rk4"] = SlowedRK4()
