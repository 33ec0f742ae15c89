"""Section ``adapters``: our adaptive-integrator adapters against the bare libraries.

Each adapter's ``solve`` (as the runner times it: ``monitor=False``, integrate to the output grid, no event)
is timed against the library called directly with the same compiled right-hand side, Jacobian, tolerances
and output grid, set up once outside the timed call as a user would (heyoka: one compiled integrator, reset
before each call). Target: adapter ≤ 1.05× the bare call. Both sides must return the same states (checked);
what remains is the adapter's own work (validation, bookkeeping, silencing the C libraries' output, the step
guards of the scipy adapter, the reset of heyoka's reused integrator).

Also reported for CVODE: the time per right-hand-side evaluation of a whole scikit-sundae solve
(``cvode_*_py``; the compiled ``cvode_*`` are in section ``limits``), the cost of one call of the numba
right-hand side from Python, the same solve's cost per evaluation with a plain-Python oscillator
(scikit-sundae's own per-callback cost), and the effect of the analytic Jacobian (heyoka's symbolic
derivative compiled by numba, ``Model.numba_jacobian_into``) against CVODE's internal difference quotients.

Setting: the 3 m laboratory pendulum of ``bench.problems.scenes`` (spherical model, the physical one) over
``DURATION_S`` with its 0.45 s output grid, tol = ``TOL``. Timed by the thread's CPU time (every library here
computes on the calling thread; ``foucault-bench perf`` caps the BLAS and OpenMP pools at one thread, as the
runner's workers do), in interleaved rounds (``measure.RATIO_ROUNDS``; 3 with ``--quick``).
"""

from __future__ import annotations

import statistics
import time
from dataclasses import replace
from functools import partial
from typing import Any, Callable

import numpy as np

from foucault_bench.bench.perf.measure import RATIO_ROUNDS, Row, interleaved, median_ratio
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.integrators import get_integrator
from foucault_bench.integrators.adaptive import absolute_tolerance, heyoka_tolerance, step_budget
from foucault_bench.integrators.methods.cvode import CvodeAdams, CvodeBdf

SECTION = "adapters"
TARGET = 1.05
OVERHEAD_TARGET_US = 5.0
"""heyoka's adapter: most CPU µs per call over the bare library (issue: 20-55 µs on 0.1 ms solves)."""
TOL = 1.0e-8
DURATION_S = 300.0
SCENE = "lab_3m"


def _scene_problem(quick: bool):
    scene = SCENES[SCENE]
    duration = scene.output_interval_s * round((60.0 if quick else DURATION_S) / scene.output_interval_s)
    return replace(scene, duration_s=duration).problem()


def bare_cvode(problem, method: str, analytic_jacobian: bool = True) -> Callable[[], Any]:
    """scikit-sundae's CVODE with the ``cvode_*_py`` adapter's right-hand side, Jacobian, tolerances and grid."""
    from sksundae.cvode import CVODE

    p = problem.parameter_vector
    rhs_into = problem.model.numba_rhs_into
    jacobian_into = problem.model.numba_jacobian_into

    def rhs(t, y, yp):
        rhs_into(t, y, yp, p)

    def jacobian(t, y, yp, jj):
        jacobian_into(t, y, jj, p)

    tspan = np.union1d([0.0], problem.t_out)
    options = {"method": method, "rtol": TOL, "atol": absolute_tolerance(problem.params, TOL),
               "max_num_steps": step_budget(problem.params, float(np.max(np.diff(tspan))))}
    if analytic_jacobian:
        options["jacfn"] = jacobian
    y0 = problem.initial_state
    return lambda: CVODE(rhs, **options).solve(tspan, y0)


def bare_heyoka(problem) -> Callable[[], Any]:
    """heyoka's taylor_adaptive compiled once; each call resets time and state and propagates the grid."""
    import heyoka

    model = problem.model
    pars = model.heyoka_parameters(problem.parameter_vector)
    integrator = heyoka.taylor_adaptive(model.heyoka_system(), problem.initial_state,
                                        tol=heyoka_tolerance(problem.params, TOL), pars=pars)
    grid = problem.t_out

    def call():
        integrator.time = 0.0
        integrator.state[:] = problem.initial_state
        return integrator.propagate_grid(grid)

    return call


def bare_solve_ivp(problem, method: str) -> Callable[[], Any]:
    """``scipy.integrate.solve_ivp`` with the adapter's right-hand side, Jacobian (LSODA), tolerances and grid."""
    from scipy.integrate import solve_ivp

    model = problem.model
    options = {"jac": model.jacobian} if method == "LSODA" else {}
    atol = absolute_tolerance(problem.params, TOL)
    p = problem.parameter_vector
    return lambda: solve_ivp(model.numba_rhs, (0.0, problem.t_end_s), problem.initial_state, method=method,
                             t_eval=problem.t_out, args=(p,), rtol=TOL, atol=atol, **options)


def _final_state(result: Any) -> np.ndarray:
    """The last output state of a bare library call (CVODE result, heyoka grid outcome, or OdeResult)."""
    if isinstance(result, tuple):  # heyoka propagate_grid: (outcome, min_h, max_h, steps, callback, states)
        return np.asarray(result[-1])[-1]
    y = np.asarray(result.y)
    return y[-1] if y.shape[-1] == 4 else y[:, -1]


BARE: dict[str, Callable] = {
    "cvode_adams_py": lambda problem: bare_cvode(problem, "Adams"),
    "cvode_bdf_py": lambda problem: bare_cvode(problem, "BDF"),
    "heyoka_taylor": bare_heyoka,
    "scipy_dop853": lambda problem: bare_solve_ivp(problem, "DOP853"),
    "scipy_rk45": lambda problem: bare_solve_ivp(problem, "RK45"),
    "scipy_lsoda": lambda problem: bare_solve_ivp(problem, "LSODA"),
}


def rhs_callback_us(problem, calls: int) -> float:
    """CPU µs of one call of the CVODE-style right-hand side from Python (the numba dispatch of a callback)."""
    p = problem.parameter_vector
    rhs_into = problem.model.numba_rhs_into
    y, yp = problem.initial_state.copy(), np.empty(4)
    rhs_into(0.0, y, yp, p)
    start = time.thread_time()
    for _ in range(calls):
        rhs_into(0.0, y, yp, p)
    return (time.thread_time() - start) / calls * 1e6


def cvode_floor_us(problem) -> float:
    """CPU µs per right-hand-side evaluation of CVODE (Adams, same tolerances and grid) on the harmonic oscillator
    written in plain Python: what scikit-sundae's callback machinery costs whatever the right-hand side."""
    from sksundae.cvode import CVODE

    k2 = problem.params.pendulum_frequency_rad_s ** 2

    def oscillator(t, y, yp):
        yp[0], yp[1], yp[2], yp[3] = y[2], y[3], -k2 * y[0], -k2 * y[1]

    tspan = np.union1d([0.0], problem.t_out)
    solver_options = {"method": "Adams", "rtol": TOL, "atol": absolute_tolerance(problem.params, TOL),
                      "max_num_steps": step_budget(problem.params, float(np.max(np.diff(tspan))))}
    CVODE(oscillator, **solver_options).solve(tspan, problem.initial_state)
    start = time.thread_time()
    result = CVODE(oscillator, **solver_options).solve(tspan, problem.initial_state)
    return (time.thread_time() - start) / result.nfev * 1e6


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Time every adapter against its bare library; the target rows, a detail table and its headers."""
    problem = _scene_problem(quick)
    rounds = 3 if quick else RATIO_ROUNDS
    headers = ["integrator", "adapter s", "bare s", "adapter / bare", "nfev", "bare µs / nfev"]
    rows, table = [], []
    for name, make_bare in BARE.items():
        integrator = get_integrator(name)
        adapter = partial(integrator.solve, problem, tol=TOL, monitor=False)  # as the runner times it
        bare = make_bare(problem)
        solution, reference = adapter(), bare()
        difference = np.max(np.abs(solution.y[-1] - _final_state(reference)))
        assert solution.status == "ok" and difference <= 1e-12 * np.max(np.abs(solution.y)), (name, difference)
        times = interleaved({"adapter": adapter, "bare": bare}, rounds)
        ratio = median_ratio(times["adapter"], times["bare"])
        bare_s = statistics.median(times["bare"])
        per_rhs = bare_s / solution.nfev * 1e6 if solution.nfev else float("nan")
        table.append([name, f"{statistics.median(times['adapter']):.4f}", f"{bare_s:.4f}", f"{ratio:.3f}",
                      str(solution.nfev), f"{per_rhs:.2f}"])
        rows.append(Row(SECTION, f"{name}: adapter / bare library", ratio, "×", TARGET,
                        f"{statistics.median(times['adapter']) * 1e3:.1f} vs {bare_s * 1e3:.1f} ms"))
        if name.startswith("cvode"):
            rows.append(Row(SECTION, f"{name}: CPU time per RHS evaluation (whole solve / nfev)", per_rhs, "µs",
                            note=f"nfev = {solution.nfev}"))
    rows.append(Row(SECTION, "CVODE RHS callback: one Python → numba call", rhs_callback_us(problem, 20_000), "µs",
                    note="numba_rhs_into called from Python as CVODE calls it"))
    rows.append(Row(SECTION, "CVODE floor: per evaluation of a plain-Python oscillator RHS", cvode_floor_us(problem),
                    "µs", note="scikit-sundae's per-callback cost (arrays wrapped around CVODE's vectors)"))
    rows.append(heyoka_overhead(problem, 300 if quick else 3000))
    rows.extend(jacobian_effect(problem, rounds))
    return rows, table, headers


def heyoka_overhead(problem, rounds: int) -> Row:
    """CPU µs the heyoka adapter adds per call to bare heyoka's reset and propagation, from ``rounds``
    interleaved pairs of calls: the difference of the two lower deciles (on a busy machine every call is
    slowed by the other processes' use of the caches, more the more memory it touches; the fastest tenth of
    3000 calls is the cost with the least of that, and a tenth rather than the minimum keeps one lucky call
    from deciding). The median of the paired differences is in the note: it carries the load."""
    integrator = get_integrator("heyoka_taylor")
    times = interleaved({"adapter": partial(integrator.solve, problem, tol=TOL, monitor=False),
                         "bare": bare_heyoka(problem)}, rounds)
    decile = {name: statistics.quantiles(durations, n=10)[0] for name, durations in times.items()}
    overhead_us = (decile["adapter"] - decile["bare"]) * 1e6
    median_us = statistics.median(a - b for a, b in zip(times["adapter"], times["bare"], strict=True)) * 1e6
    return Row(SECTION, "heyoka_taylor: adapter overhead per call (lower deciles)", overhead_us, "µs",
               OVERHEAD_TARGET_US, f"{rounds} paired calls, bare {decile['bare'] * 1e6:.0f} µs ({problem.t_out.size} "
               f"output times); median of paired differences {median_us:.1f} µs")


def jacobian_effect(problem, rounds: int) -> list[Row]:
    """CVODE with the analytic Jacobian against CVODE's difference quotients: time ratio, nfev and njev."""
    rows = []
    for cls in (CvodeAdams, CvodeBdf):
        analytic, quotients = cls(analytic_jacobian=True), cls(analytic_jacobian=False)
        with_jac, without = analytic.solve(problem, tol=TOL, monitor=False), quotients.solve(problem, tol=TOL, monitor=False)
        times = interleaved({"analytic": partial(analytic.solve, problem, tol=TOL, monitor=False),
                             "quotients": partial(quotients.solve, problem, tol=TOL, monitor=False)}, rounds)
        rows.append(Row(SECTION, f"{cls.name}: analytic Jacobian / difference quotients (time)",
                        median_ratio(times["analytic"], times["quotients"]), "×",
                        note=f"nfev {with_jac.nfev} vs {without.nfev} (incl. 4 per quotient Jacobian), "
                             f"njev {with_jac.njev} vs {without.njev}"))
    return rows
