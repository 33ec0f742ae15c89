"""Section ``sweeps``: a latitude sweep with heyoka, scalar integrator in a loop against batch mode and ensembles.

The sweep: ``N_PENDULUMS`` copies of the 3 m laboratory pendulum (spherical model) at latitudes spread over
0°-90°, each integrated over ``DURATION_S`` (quick: 300 s) at tol = ``TOL`` (heyoka's ε by
``integrators.adaptive.heyoka_tolerance``). Contenders, each compiled once before timing (compile times shown
apart):

* ``scalar loop``: one ``taylor_adaptive``, reset and propagated once per latitude (what a Python loop over
  the suite's ``heyoka_taylor`` adapter does, without its bookkeeping);
* ``batch``: ``taylor_adaptive_batch`` with ``heyoka.recommended_simd_size()`` lanes (SIMD: one latitude per
  lane), one propagation per group of lanes;
* ``ensemble`` and ``ensemble of batches``: ``heyoka.ensemble_propagate_until`` / ``_batch`` on all cores
  (threads, one copy of the integrator each).

Throughput = pendulum-steps per second: Taylor steps summed over the pendulums (a batch step advances every
lane by one step of its own size) / wall time. Figures without a target (the brief sets none): they show what
a sweep gains from SIMD lanes and from the second core. Wall clock, interleaved rounds, median.
"""

from __future__ import annotations

import os
import statistics
import time

import numpy as np

from foucault_bench.bench.perf.measure import Row, interleaved
from foucault_bench.integrators.adaptive import heyoka_tolerance
from foucault_bench.models import MODELS, PendulumParameters

SECTION = "sweeps"
N_PENDULUMS = 64
DURATION_S = 3600.0
TOL = 1.0e-12
MODEL = "spherical"


def sweep_parameters() -> list[PendulumParameters]:
    return [PendulumParameters(length_m=3.0, latitude_deg=float(latitude), amplitude_m=0.3)
            for latitude in np.linspace(0.0, 90.0, N_PENDULUMS)]


class Sweep:
    """The compiled integrators and the per-contender propagation calls for one sweep."""

    def __init__(self, duration_s: float) -> None:
        import heyoka

        self.heyoka = heyoka
        self.duration_s = duration_s
        self.params = sweep_parameters()
        model = MODELS[MODEL]
        system = model.heyoka_system()
        self.states = np.array([p.initial_state() for p in self.params])
        self.pars = model.heyoka_parameters(np.array([p.parameter_vector() for p in self.params]))
        self.lanes = heyoka.recommended_simd_size()
        tol = heyoka_tolerance(self.params[0], TOL)  # the same for every latitude (same swing)
        start = time.perf_counter()
        self.scalar = heyoka.taylor_adaptive(system, self.states[0], tol=tol, pars=self.pars[0])
        self.scalar_compile_s = time.perf_counter() - start
        start = time.perf_counter()
        self.batch = heyoka.taylor_adaptive_batch(system, self.states[: self.lanes].T.copy(), tol=tol,
                                                  pars=self.pars[: self.lanes].T.copy())
        self.batch_compile_s = time.perf_counter() - start
        self.workers = os.cpu_count() or 1

    def scalar_loop(self) -> tuple[int, np.ndarray]:
        steps, finals = 0, np.empty_like(self.states)
        for i in range(N_PENDULUMS):
            self.scalar.time = 0.0
            self.scalar.state[:] = self.states[i]
            self.scalar.pars[:] = self.pars[i]
            steps += self.scalar.propagate_until(self.duration_s)[3]
            finals[i] = self.scalar.state
        return steps, finals

    def batch_loop(self) -> tuple[int, np.ndarray]:
        steps, finals = 0, np.empty_like(self.states)
        for first in range(0, N_PENDULUMS, self.lanes):
            lanes = slice(first, first + self.lanes)
            self.batch.set_time(np.zeros(self.lanes))
            self.batch.state[:] = self.states[lanes].T
            self.batch.pars[:] = self.pars[lanes].T
            self.batch.propagate_until(np.full(self.lanes, self.duration_s))
            steps += sum(result[3] for result in self.batch.propagate_res)
            finals[lanes] = self.batch.state.T
        return steps, finals

    def ensemble(self) -> tuple[int, np.ndarray]:
        def setup(integrator, i):
            integrator.time = 0.0
            integrator.state[:] = self.states[i]
            integrator.pars[:] = self.pars[i]
            return integrator

        results = self.heyoka.ensemble_propagate_until(self.scalar, self.duration_s, N_PENDULUMS, setup,
                                                       max_workers=self.workers)
        return sum(result[4] for result in results), np.array([result[0].state for result in results])

    def ensemble_batch(self) -> tuple[int, np.ndarray]:
        def setup(integrator, i):
            lanes = slice(i * self.lanes, (i + 1) * self.lanes)
            integrator.set_time(np.zeros(self.lanes))
            integrator.state[:] = self.states[lanes].T
            integrator.pars[:] = self.pars[lanes].T
            return integrator

        results = self.heyoka.ensemble_propagate_until_batch(self.batch, self.duration_s, N_PENDULUMS // self.lanes,
                                                             setup, max_workers=self.workers)
        steps = sum(sum(lane[3] for lane in result[0].propagate_res) for result in results)
        return steps, np.concatenate([result[0].state.T for result in results])


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Time the four ways through the sweep; the rows, a detail table and its headers."""
    sweep = Sweep(300.0 if quick else DURATION_S)
    contenders = {"scalar loop": sweep.scalar_loop, f"batch ({sweep.lanes} lanes)": sweep.batch_loop,
                  f"ensemble ({sweep.workers} threads)": sweep.ensemble,
                  f"ensemble of batches ({sweep.workers} threads)": sweep.ensemble_batch}
    outcomes = {name: call() for name, call in contenders.items()}
    reference = outcomes["scalar loop"][1]
    for name, (_, finals) in outcomes.items():
        assert np.allclose(finals, reference, rtol=0.0, atol=1e-6), f"{name}: final states differ from the scalar loop"
    times = interleaved(contenders, 3 if quick else 5, clock=time.perf_counter)
    scalar_s = statistics.median(times["scalar loop"])
    headers = ["contender", "wall s", "pendulum-steps", "pendulum-steps / s", "speed-up over scalar loop"]
    rows, table = [], []
    for name, durations in times.items():
        wall_s = statistics.median(durations)
        steps = outcomes[name][0]
        table.append([name, f"{wall_s:.3f}", str(steps), f"{steps / wall_s:.3g}", f"{scalar_s / wall_s:.2f}"])
        if name != "scalar loop":
            rows.append(Row(SECTION, f"{N_PENDULUMS}-latitude sweep: {name} / scalar loop, throughput",
                            (steps / wall_s) / (outcomes["scalar loop"][0] / scalar_s), "×",
                            note=f"{steps / wall_s:.3g} pendulum-steps/s"))
    rows.append(Row(SECTION, "scalar loop throughput", outcomes["scalar loop"][0] / scalar_s, "steps/s",
                    note=f"building (heyoka's disk cache as found): scalar {sweep.scalar_compile_s:.2f} s, "
                         f"batch {sweep.batch_compile_s:.2f} s"))
    return rows, table, headers
