"""Section ``batch``: an ensemble's members run as one batch (``integrators.batch``) against one by one.

* **RK4 ensemble** (target ≤ ``RK4_TARGET``×): ``RK4_MEMBERS`` members of the Panthéon scene (linear model,
  1 h, 2 s output grid) released at azimuths spread over 0°-180°, RK4 at kh = ``KH``, verdicts off (what the
  runner times). The batch's compiled loop over members (``fixed_step_member_loop``, all arrays allocated
  before) against ``RK4_MEMBERS`` × one member's compiled loop (``FixedStepIntegrator.kernel``, the loop body
  the batch repeats); also shown: the whole ``solve_batch`` (arrays, solutions) against ``RK4_MEMBERS``
  calls of ``rk4.solve``. Thread CPU time, interleaved rounds, median of per-round ratios
  (``bench.perf.measure``).
* **References in batch mode** (target ≥ ``REFERENCE_TARGET``× faster, shown as one-by-one time over batch
  time): the quadruple-precision references of ``REFERENCE_MEMBERS`` members of the 3 m pendulum released at
  azimuths over 0°-180° (shortened to ``REFERENCE_DURATION_S``), computed into fresh cache directories by
  ``bench.problems.reference.references_for`` (threads: heyoka has no real128 batch mode) and by
  ``reference_for`` one after another; wall clock, since the batch uses every core. And heyoka's double-precision
  batch mode (``integrators.batch_heyoka``, SIMD lanes) on ``TAYLOR_MEMBERS`` such members at tol = ``TAYLOR_TOL``, the
  double-precision work a reference-quality run does, against ``heyoka_taylor.solve`` one by one (thread CPU
  time).
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from dataclasses import replace
from functools import partial
from typing import cast

import numpy as np

from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio
from foucault_bench.bench.problems.scenes import SCENES, Scene
from foucault_bench.integrators import FixedStepIntegrator, get_integrator
from foucault_bench.integrators.batch import fixed_step_arrays, fixed_step_member_loop, solve_batch

SECTION = "batch"
RK4_TARGET = 1.1
REFERENCE_TARGET = 3.0
KH = 0.1
RK4_MEMBERS = 1000
REFERENCE_MEMBERS = 8
REFERENCE_DURATION_S = 180.0
TAYLOR_MEMBERS = 64
TAYLOR_TOL = 1.0e-15


def azimuth_members(scene: Scene, count: int) -> list[Scene]:
    """``count`` copies of ``scene`` released at azimuths evenly spread over [0°, 180°)."""
    return [replace(scene, params=replace(scene.params, release_azimuth_deg=float(azimuth)))
            for azimuth in np.linspace(0.0, 180.0, count, endpoint=False)]


def rk4_ensemble(quick: bool) -> tuple[list[Row], list[list[str]]]:
    """The RK4 figure: batch loop against the members' loop bodies, and the whole batch against ``solve``."""
    count = RK4_MEMBERS // 10 if quick else RK4_MEMBERS
    scene = SCENES["pantheon"]
    problems = [member.problem() for member in azimuth_members(scene, count)]
    integrator = cast(FixedStepIntegrator, get_integrator("rk4"))
    step_s = KH / scene.params.pendulum_frequency_rad_s
    arguments = fixed_step_arrays(integrator, problems, [step_s] * count, False)
    member_loop = fixed_step_member_loop(integrator.kernel(problems[0].model))
    kernel = integrator.kernel(problems[0].model)
    states0, parameter_vectors, h, n_steps, stride, out, _, turning, radius_bound, _ = arguments

    def bodies() -> None:
        for m in range(count):
            kernel(states0[m], parameter_vectors[m], h[m], n_steps[m], stride[m], out[m], False, turning[m],
                   radius_bound[m])

    rounds = 3 if quick else 7
    loops = interleaved({"batch": partial(member_loop, *arguments), "bodies": bodies}, rounds)
    ratio = median_ratio(loops["batch"], loops["bodies"])
    solves = interleaved({"batch": partial(solve_batch, integrator, problems, step_s=step_s, monitor=False),
                          "solve": lambda: [integrator.solve(p, step_s=step_s, monitor=False) for p in problems]},
                         rounds)
    steps = int(n_steps.sum())
    per_step_ns = statistics.median(loops["batch"]) / steps * 1e9
    rows = [
        Row(SECTION, f"RK4 ensemble, {count} members, kh {KH:g}, Panthéon: batch loop / {count} loop bodies", ratio,
            "×", RK4_TARGET, f"{statistics.median(loops['batch']):.3f} vs {statistics.median(loops['bodies']):.3f} s "
                             f"CPU, {per_step_ns:.1f} ns per member-step"),
        Row(SECTION, f"RK4 ensemble, {count} members: solve_batch / {count} × rk4.solve",
            median_ratio(solves["batch"], solves["solve"]), "×",
            note=f"{statistics.median(solves['batch']):.3f} vs {statistics.median(solves['solve']):.3f} s CPU"),
    ]
    table = [["rk4 loops", str(count), f"{statistics.median(loops['batch']):.3f}",
              f"{statistics.median(loops['bodies']):.3f}", f"{ratio:.3f}"],
             ["rk4 solve", str(count), f"{statistics.median(solves['batch']):.3f}",
              f"{statistics.median(solves['solve']):.3f}", f"{median_ratio(solves['batch'], solves['solve']):.3f}"]]
    return rows, table


def _references_wall_s(members: list[Scene], batch: bool) -> float:
    """Wall time of computing the members' references into a fresh cache directory."""
    from foucault_bench.bench.problems import reference

    previous = os.environ.get(reference.CACHE_ENVIRONMENT_VARIABLE)
    with tempfile.TemporaryDirectory() as directory:
        os.environ[reference.CACHE_ENVIRONMENT_VARIABLE] = directory
        try:
            start = time.perf_counter()
            if batch:
                reference.references_for(members)
            else:
                for member in members:
                    reference.reference_for(member)
            return time.perf_counter() - start
        finally:
            if previous is None:
                del os.environ[reference.CACHE_ENVIRONMENT_VARIABLE]
            else:
                os.environ[reference.CACHE_ENVIRONMENT_VARIABLE] = previous


def references(quick: bool) -> tuple[list[Row], list[list[str]]]:
    """The reference figures: quad references with ``references_for`` and heyoka's double batch mode."""
    count = REFERENCE_MEMBERS // 2 if quick else REFERENCE_MEMBERS
    duration_s = 45.0 if quick else REFERENCE_DURATION_S
    members = azimuth_members(replace(SCENES["lab_3m"], duration_s=duration_s), count)
    _references_wall_s(members[:1], batch=False)  # warm-up: heyoka's compiled integrator loaded once
    one_s = _references_wall_s(members, batch=False)
    batch_s = _references_wall_s(members, batch=True)
    taylor_count = TAYLOR_MEMBERS // 4 if quick else TAYLOR_MEMBERS
    problems = [member.problem() for member in azimuth_members(replace(SCENES["lab_3m"], duration_s=duration_s),
                                                                 taylor_count)]
    taylor = get_integrator("heyoka_taylor")
    times = interleaved({"batch": partial(solve_batch, taylor, problems, tol=TAYLOR_TOL, monitor=False),
                         "solve": lambda: [taylor.solve(p, tol=TAYLOR_TOL, monitor=False) for p in problems]},
                        3 if quick else 7)
    speedup = median_ratio(times["solve"], times["batch"])
    rows = [
        Row(SECTION, f"quad references of {count} members ({duration_s:g} s of lab_3m): batch time / one by one",
            batch_s / one_s, "×", 1.0 / REFERENCE_TARGET,
            f"{batch_s:.2f} vs {one_s:.2f} s wall on {os.cpu_count()} cores (threads: no real128 batch mode), "
            f"speed-up {one_s / batch_s:.2f}"),
        Row(SECTION, f"heyoka_taylor tol {TAYLOR_TOL:g}, {taylor_count} members: batch mode time / one by one",
            1.0 / speedup, "×", 1.0 / REFERENCE_TARGET,
            f"speed-up {speedup:.2f} ({statistics.median(times['batch']) * 1e3:.1f} vs "
            f"{statistics.median(times['solve']) * 1e3:.1f} ms CPU)"),
    ]
    table = [["quad references", str(count), f"{batch_s:.3f}", f"{one_s:.3f}", f"{batch_s / one_s:.3f}"],
             ["heyoka_taylor batch mode", str(taylor_count), f"{statistics.median(times['batch']):.3f}",
              f"{statistics.median(times['solve']):.3f}", f"{1.0 / speedup:.3f}"]]
    return rows, table


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Both batch figures; the target rows, a detail table and its headers."""
    rk4_rows, rk4_table = rk4_ensemble(quick)
    reference_rows, reference_table = references(quick)
    headers = ["what", "members", "batch s", "one by one s", "batch / one by one"]
    return rk4_rows + reference_rows, rk4_table + reference_table, headers
