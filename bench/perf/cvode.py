"""Family limit ``cvode`` (section ``limits``): compiled CVODE against the same CVODE driven by scikit-sundae.

For each method (Adams, BDF) the compiled path (``cvode_adams``, ``cvode_bdf``: numba ``cfunc`` right-hand side
and Jacobian, compiled output loop) and the Python-driven path (``cvode_adams_py``, ``cvode_bdf_py``:
scikit-sundae calling Python callbacks) solve the same problem with the same settings; both must take the same
steps (equal ``nfev``, ``njev``) to bitwise-equal states, checked before timing, so the ratio is the cost of
the binding alone. Reported per solve and per right-hand-side evaluation (whole ``Integrator.solve`` CPU
time / ``nfev``, setup and teardown included). Target: the compiled path at ≤ ``TARGET_US_PER_RHS`` µs per
evaluation (issue "Fair cost": the right-hand side itself costs a few ns, CVODE's own work per evaluation
dominates).

Setting: the Panthéon scene (linear model, 1 h, output every 2 s), tol = ``TOL``. Timed by the thread's CPU
time in interleaved rounds, medians (``bench.perf.measure.interleaved``).
"""

from __future__ import annotations

import statistics
from functools import partial

from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio
from foucault_bench.bench.problems.scenes import SCENES
from foucault_bench.integrators import get_integrator

SECTION = "cvode"
SCENE = "pantheon"
TOL = 1.0e-8
TARGET_US_PER_RHS = 0.6
METHODS = ("adams", "bdf")
HEADERS = ["method", "nfev", "njev", "steps", "rejected", "compiled ms", "scikit-sundae ms", "compiled µs / nfev",
           "scikit-sundae µs / nfev", "scikit-sundae / compiled"]


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Time both CVODE paths per method; the target rows, a detail table and its headers."""
    problem = SCENES[SCENE].problem()
    rounds = 5 if quick else 21
    rows, table = [], []
    for method in METHODS:
        compiled, python = get_integrator(f"cvode_{method}"), get_integrator(f"cvode_{method}_py")
        fast, slow = compiled.solve(problem, tol=TOL), python.solve(problem, tol=TOL)
        same = (fast.status == slow.status == "ok" and (fast.nfev, fast.njev) == (slow.nfev, slow.njev)
                and fast.y.tobytes() == slow.y.tobytes())
        if not same:
            rows.append(Row(SECTION, f"cvode_{method}: compiled vs scikit-sundae", None, "µs",
                            note=f"paths disagree (nfev {fast.nfev} vs {slow.nfev}; {fast.message or slow.message})"))
            continue
        times = interleaved({"compiled": partial(compiled.solve, problem, tol=TOL),
                             "python": partial(python.solve, problem, tol=TOL)}, rounds)
        compiled_s, python_s = statistics.median(times["compiled"]), statistics.median(times["python"])
        ratio = median_ratio(times["python"], times["compiled"])
        assert fast.nfev is not None  # CVODE counts its evaluations
        per_rhs_compiled, per_rhs_python = compiled_s / fast.nfev * 1e6, python_s / fast.nfev * 1e6
        table.append([method, str(fast.nfev), str(fast.njev), str(fast.steps), str(fast.rejected_steps),
                      f"{compiled_s * 1e3:.2f}", f"{python_s * 1e3:.1f}", f"{per_rhs_compiled:.3f}",
                      f"{per_rhs_python:.2f}", f"{ratio:.1f}"])
        rows.append(Row(SECTION, f"cvode_{method}: CPU time per RHS evaluation (compiled callbacks)", per_rhs_compiled,
                        "µs", TARGET_US_PER_RHS,
                        f"{compiled_s * 1e3:.2f} ms per solve, nfev = {fast.nfev}, {SCENE} 1 h, tol {TOL:g}"))
        rows.append(Row(SECTION, f"cvode_{method}_py: CPU time per RHS evaluation (scikit-sundae, Python callbacks)",
                        per_rhs_python, "µs", note=f"{python_s * 1e3:.1f} ms per solve, same steps"))
        rows.append(Row(SECTION, f"cvode_{method}_py / cvode_{method}: CPU time, same steps and states", ratio, "×",
                        note="median of per-round ratios"))
    return rows, table, HEADERS
