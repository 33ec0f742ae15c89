"""Family limit ``erk`` (section ``limits``): the compiled Runge-Kutta pairs against scipy's at equal nfev.

``dopri5`` against ``scipy_rk45`` and ``dop853`` against ``scipy_dop853``, each integrator's ``solve`` on the
Panthéon scene (linear model, 1 h, 2.05 s output grid) at tol = ``TOL``, integrating to the output grid: with
``monitor=False`` (the benchmark's timed call, no event function) and, for a second row, with the turning-point
event on. The pairs take the same steps: equal nfev and accepted steps are checked before timing. Timed by the
thread's CPU time in interleaved rounds (``measure.interleaved``); the figure is the median over rounds of
compiled / scipy, target ≤ 1/50 (the compiled pair at least 50× cheaper).

Run alone: ``python -m foucault_bench.bench.perf.erk [--quick]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
from functools import partial

from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.integrators import get_integrator
from foucault_bench.integrators.embedded_rk import scipy_twins

SECTION = "erk"
TOL = 1.0e-8
SCENE = "pantheon"
TARGET = 1.0 / 50.0
PAIRS = scipy_twins()
"""Compiled pair → the scipy integrator it takes the steps of (``integrators.embedded_rk.scipy_twins``)."""


def _problem(quick: bool):
    scene = SCENES[SCENE]
    if quick:  # 10 minutes instead of 1 h
        scene = dataclasses.replace(scene, duration_s=scene.output_interval_s * round(600.0 / scene.output_interval_s))
    return scene.problem()


def measure(quick: bool = False) -> list[Row]:
    """Rows per pair (events off, events on): median over interleaved rounds of CPU(compiled) / CPU(scipy), at
    equal nfev."""
    problem = _problem(quick)
    rounds = 3 if quick else 11
    rows = []
    for compiled_name, scipy_name in PAIRS.items():
        compiled, python_driven = get_integrator(compiled_name), get_integrator(scipy_name)
        for monitor in (False, True):
            mine = compiled.solve(problem, tol=TOL, monitor=monitor)
            theirs = python_driven.solve(problem, tol=TOL, monitor=monitor)
            if (mine.status, mine.nfev, mine.steps) != (theirs.status, theirs.nfev, theirs.steps):
                raise AssertionError(f"{compiled_name} and {scipy_name} took different steps: "
                                     f"nfev {mine.nfev} vs {theirs.nfev}, steps {mine.steps} vs {theirs.steps}")
            times = interleaved({"compiled": partial(compiled.solve, problem, tol=TOL, monitor=monitor),
                                 "scipy": partial(python_driven.solve, problem, tol=TOL, monitor=monitor)}, rounds)
            ratio = median_ratio(times["compiled"], times["scipy"])
            compiled_s, scipy_s = statistics.median(times["compiled"]), statistics.median(times["scipy"])
            what = "with the turning-point event" if monitor else "to the output grid"
            rows.append(Row(SECTION, f"{compiled_name} / {scipy_name}: CPU time at equal nfev, {what}", ratio, "×",
                            TARGET, f"{compiled_s * 1e3:.2f} vs {scipy_s * 1e3:.1f} ms ({1.0 / ratio:.0f}× less), "
                                    f"nfev {mine.nfev}, {SCENE} {problem.t_end_s:g} s, tol {TOL:g}"))
    return rows


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """The section interface of ``bench.perf``: target rows, a detail table and its headers."""
    rows = measure(quick)
    return rows, [row.cells()[1:] for row in rows], ["measurement", "value", "target", "verdict", "note"]


if __name__ == "__main__":
    from foucault_bench.bench.run.timing import limit_threads

    limit_threads()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10 minutes of the scene and 3 rounds")
    for row in measure(parser.parse_args().quick):
        print(" | ".join(row.cells()))
