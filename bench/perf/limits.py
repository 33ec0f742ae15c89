"""Section ``limits``: each integrator family against its own limit, and the cost column against the load.

* **CVODE** (``bench.perf.cvode``): the compiled path's CPU time per right-hand-side evaluation on the
  Panthéon hour at tol 1e-8 (target ≤ 0.6 µs), against the scikit-sundae path with the same steps.
* **Runge-Kutta pairs** (``bench.perf.erk``): ``dopri5`` / ``scipy_rk45`` and ``dop853`` / ``scipy_dop853`` at
  equal nfev (target: the compiled pair ≥ 50× cheaper, ratio ≤ 0.02).
* **heyoka** (``heyoka_limit``): the adapter (``HeyokaTaylor.solve`` as the runner times it, ``monitor=False``)
  against heyoka called directly, one compiled ``taylor_adaptive`` reset before each call, on the Panthéon
  (linear model, 1 h, 668 output points) at tol = 1e-8. Target ≤ 1.05×.
* **cpu_time_s against --jobs** (``jobs_limit``): one matrix run with ``--jobs 1`` and again with ``--jobs 2``
  (``foucault-bench run`` in subprocesses, the user's caches), the stored ``cpu_time_s`` of every run compared
  run by run (``bench.run.compare.compare_runs``). Target: every run of ≥ ``JOBS_MIN_RUN_S`` within 15 %, reported
  as the worst max(r, 1/r) of the ratio r = --jobs 2 / --jobs 1 (target ≤ 1.15). ``--quick`` runs
  ``JOBS_QUICK_MATRIX`` (the Panthéon hour, one heavy setting per integrator of the quick matrix, 10 ms or
  more where the integrator allows; about 40 s both ways); the full section runs the default matrix both ways
  (about 2 × 5 minutes on 2 idle cores).

Timed by the thread's CPU time in interleaved rounds (``bench.perf.measure``), like the other sections.
"""

from __future__ import annotations

import dataclasses
import importlib
import statistics
import sys
import tempfile
from pathlib import Path

from foucault_bench.bench.perf.adapters import bare_heyoka
from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio, run_timed
from foucault_bench.bench.problems.scenes import SCENES

SECTION = "limits"
ADAPTER_TARGET = 1.05
HEYOKA_SCENE = "pantheon"
HEYOKA_TOL = 1.0e-8
JOBS_TARGET = 1.15
JOBS_MIN_RUN_S = 0.010

JOBS_QUICK_MATRIX = """
name = "jobs-check"
description = "one heavy setting per integrator on the Panthéon (runs of 10 ms or more): cpu_time_s against --jobs"
scenes = ["pantheon"]
integrators = [{integrators}]
{overrides}
"""
JOBS_QUICK_SETTINGS = {
    # a setting where one run of the Panthéon hour costs 10 ms or more on the machine of bench/PERF.md (heyoka
    # and dop853 stay below it even at their tightest tolerance: listed as not compared)
    "explicit_euler": "kh = [0.00025]", "symplectic_euler": "kh = [0.00025]",
    "scipy_dop853": "tol = [1e-6]", "scipy_rk45": "tol = [1e-6]", "scipy_lsoda": "tol = [1e-6]",
    "cvode_bdf": "tol = [1e-6]", "heyoka_taylor": "tol = [1e-14]",
    "dopri5": "tol = [1e-13]", "tsit5": "tol = [1e-13]", "dop853": "tol = [1e-13]",
}
JOBS_QUICK_DEFAULT = {False: "kh = [0.0005]", True: "tol = [1e-10]"}
"""Setting of an integrator not in ``JOBS_QUICK_SETTINGS``, by whether it is adaptive."""


def heyoka_limit(quick: bool) -> tuple[Row, list[str]]:
    """heyoka adapter against the bare library on the Panthéon hour: the target row and a detail line."""
    from foucault_bench.integrators import get_integrator

    problem = SCENES[HEYOKA_SCENE].problem()
    integrator = get_integrator("heyoka_taylor")
    adapter = lambda: integrator.solve(problem, tol=HEYOKA_TOL, monitor=False)  # noqa: E731  (as the runner times it)
    bare = bare_heyoka(problem)
    solution, reference = adapter(), bare()
    assert solution.status == "ok" and solution.y.tobytes() == reference[-1].tobytes(), "adapter and bare differ"
    times = interleaved({"adapter": adapter, "bare": bare}, 21 if quick else 61)
    ratio = median_ratio(times["adapter"], times["bare"])
    adapter_ms, bare_ms = (statistics.median(times[name]) * 1e3 for name in ("adapter", "bare"))
    spread = max(times["bare"]) - min(times["bare"])
    row = Row(SECTION, "heyoka_taylor: adapter / bare library", ratio, "×", ADAPTER_TARGET,
              f"{HEYOKA_SCENE} 1 h, tol {HEYOKA_TOL:g}: {adapter_ms:.2f} vs {bare_ms:.2f} ms (bare max − min "
              f"{spread * 1e3:.2f} ms), {solution.steps} steps, states bitwise equal")
    return row, ["heyoka_taylor", f"adapter / bare ({HEYOKA_SCENE}, tol {HEYOKA_TOL:g})", f"{ratio:.3f}",
                 f"{adapter_ms:.2f} ms vs {bare_ms:.2f} ms"]


def quick_jobs_matrix() -> str:
    """The ``--quick`` matrix of the jobs comparison: the quick matrix's integrators, one heavy setting each."""
    from foucault_bench.bench.run.matrix import load_matrix
    from foucault_bench.integrators import get_integrator

    integrators = list(dict.fromkeys(spec.integrator for spec in load_matrix("quick").runs))
    overrides = "\n".join(
        f"[override.{name}]\n"
        f"{JOBS_QUICK_SETTINGS.get(name, JOBS_QUICK_DEFAULT[bool(get_integrator(name).adaptive)])}"
        for name in integrators)
    return JOBS_QUICK_MATRIX.format(integrators=", ".join(f'"{name}"' for name in integrators), overrides=overrides)


def run_with_jobs(matrix: str, jobs: int, db: Path) -> float:
    """``foucault-bench run --matrix MATRIX --jobs JOBS`` into ``db``; its wall time (s)."""
    command = [sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", matrix, "--db", str(db),
               "--jobs", str(jobs), "--no-progress"]
    wall_s, done = run_timed(command)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr.strip()[-2000:]}")
    return wall_s


def jobs_limit(quick: bool) -> tuple[list[Row], list[list[str]]]:
    """The matrix at --jobs 1 and --jobs 2 (``compare_jobs``)."""
    from foucault_bench.bench.run.store import ResultsStore

    with tempfile.TemporaryDirectory(prefix="foucault-perf-jobs-") as directory:
        root = Path(directory)
        matrix: Path | str = "default"
        if quick:
            matrix = root / "jobs-check.toml"
            matrix.write_text(quick_jobs_matrix(), encoding="utf-8")
        walls, frames = {}, {}
        for jobs in (1, 2):
            walls[jobs] = run_with_jobs(str(matrix), jobs, root / f"jobs{jobs}.sqlite")
            with ResultsStore(root / f"jobs{jobs}.sqlite", create=False) as store:
                frames[jobs] = store.frame()
    return compare_jobs(frames[1], frames[2], walls, "jobs-check matrix" if quick else "default matrix")


def compare_jobs(one, two, walls: dict[int, float], name: str) -> tuple[list[Row], list[list[str]]]:
    """Target row for cpu_time_s (runs of ``JOBS_MIN_RUN_S`` or more at --jobs 1), info row for wall_time_s,
    detail lines per integrator, from the stored rows of the same matrix at --jobs 1 (``one``) and 2 (``two``)."""
    from foucault_bench.bench.run.compare import compare_runs

    mismatches, costs, _ = compare_runs(one, two)
    ratios = costs["cpu_time_s_ratio_b_over_a"]
    walls_ratio = costs["wall_time_s_ratio_b_over_a"]
    long_enough = _cpu_by_run(one, costs) >= JOBS_MIN_RUN_S
    selected = ratios[long_enough].dropna()
    if selected.empty:
        return [Row(SECTION, "cpu_time_s: --jobs 2 / --jobs 1", None, "×", JOBS_TARGET,
                    f"skipped: no run of {name} took ≥ {JOBS_MIN_RUN_S * 1e3:.0f} ms")], []
    worst = float(max(selected.max(), 1.0 / selected.min()))
    note = (f"{name}: {len(selected)} runs ≥ {JOBS_MIN_RUN_S * 1e3:.0f} ms, ratio median "
            f"{selected.median():.3f}, range {selected.min():.3f}-{selected.max():.3f}; matrix wall "
            f"{walls[1]:.0f} s vs {walls[2]:.0f} s; accuracy columns "
            f"{'bitwise equal' if mismatches.empty else f'differ in {len(mismatches)} cells'}")
    rows = [Row(SECTION, "cpu_time_s: --jobs 2 / --jobs 1 (worst run, max(r, 1/r))", worst, "×", JOBS_TARGET, note),
            Row(SECTION, "wall_time_s: --jobs 2 / --jobs 1 (median run)", float(walls_ratio[long_enough].median()),
                "×", note="wall time includes waiting for a core: not the cost column")]
    short = costs[~long_enough].groupby("integrator").size()
    table = [[integrator, f"runs below {JOBS_MIN_RUN_S * 1e3:.0f} ms at --jobs 1 (not compared)", str(count), ""]
             for integrator, count in short.items()]
    for integrator, group in costs[long_enough].groupby("integrator"):
        values = group["cpu_time_s_ratio_b_over_a"]
        table.append([integrator, f"cpu_time_s --jobs 2 / --jobs 1 ({len(values)} runs ≥ 10 ms)",
                      f"{values.median():.3f}", f"range {values.min():.3f}-{values.max():.3f}; wall "
                      f"{group['wall_time_s_ratio_b_over_a'].median():.2f}"])
    return rows, table


def _cpu_by_run(frame, costs):
    """cpu_time_s at --jobs 1 of each compared run, aligned with ``costs``."""
    from foucault_bench.bench.run.compare import run_identity

    by_run = frame.assign(run=run_identity(frame)).set_index("run")["cpu_time_s"]
    return costs["run"].map(by_run).astype(float)


FAMILY_SECTIONS = ("foucault_bench.bench.perf.cvode", "foucault_bench.bench.perf.erk")
"""Modules measuring a family against its limit (each ``run(quick)`` like a section): compiled CVODE per
right-hand-side evaluation, the compiled Runge-Kutta pairs against scipy's at equal nfev."""


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Every family against its limit; the target rows, a detail table and its headers."""
    headers = ["family", "measurement", "value", "detail"]
    rows, table = [], []
    for module in FAMILY_SECTIONS:
        family_rows, _, _ = importlib.import_module(module).run(quick)
        for row in family_rows:
            rows.append(dataclasses.replace(row, section=SECTION))
            table.append([module.rsplit(".", 1)[-1], row.name, row.cells()[2], row.note])
    row, line = heyoka_limit(quick)
    rows.append(row)
    table.append(line)
    jobs_rows, jobs_table = jobs_limit(quick)
    return rows + jobs_rows, table + jobs_table, headers
