"""The runner: the quick matrix end to end, diverged and failed runs kept as rows, a dying worker survived,
and a killed matrix resumed without losing or duplicating a row."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.run.matrix import load_matrix
from foucault_bench.bench.provenance import code_version
from foucault_bench.bench.run.executors import WORKER_DIED
from foucault_bench.bench.run.runner import run_matrix
from foucault_bench.bench.schema import COLUMN_NAMES
from foucault_bench.bench.run.store import ResultsStore
from foucault_bench.integrators import unregister

PLUGIN = '''
"""Test-only integrators that fail in three ways (registered when imported)."""
import os
from typing import ClassVar

from foucault_bench.integrators import register
from foucault_bench.integrators.adaptive import AdaptiveIntegrator


class _Base(AdaptiveIntegrator):
    family: ClassVar[str] = "test"
    order: ClassVar[None] = None
    reference: ClassVar[str] = "tests/test_runner.py"


@register
class RaisesInSolve(_Base):
    """The library raises: the framework's solve turns it into a failed solution."""
    name: ClassVar[str] = "test_raises"

    def _solve(self, problem, *, step_s, tol, monitor):
        raise RuntimeError("deliberate failure inside the library")


@register
class BrokenInterface(_Base):
    """solve itself raises (outside the framework's guard): the runner must catch it."""
    name: ClassVar[str] = "test_broken"

    def solve(self, problem, **settings):
        raise TypeError("deliberately broken integrator interface")

    def _solve(self, problem, *, step_s, tol, monitor):
        raise AssertionError("not reached")


@register
class KillsItsWorker(_Base):
    """Ends its process like a segfault in native code would."""
    name: ClassVar[str] = "test_kills_worker"

    def _solve(self, problem, *, step_s, tol, monitor):
        os._exit(3)
'''

PLUGIN_INTEGRATORS = ("test_raises", "test_broken", "test_kills_worker")


def write(path: Path, text: str) -> Path:
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


@pytest.fixture
def failing_plugin(tmp_path, monkeypatch):
    """An importable plug-in module (spawned workers inherit sys.path) removed again after the test."""
    module_name = f"failing_integrators_{os.getpid()}"
    write(tmp_path / f"{module_name}.py", PLUGIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield module_name
    for name in PLUGIN_INTEGRATORS:
        unregister(name)
    sys.modules.pop(module_name, None)


def test_quick_matrix_runs_end_to_end(tmp_path, capsys):
    database = tmp_path / "quick.sqlite"
    assert cli_main(["run", "--matrix", "quick", "--db", str(database), "--jobs", "2", "--no-progress"]) == 0
    summary = capsys.readouterr().out
    matrix = load_matrix("quick")
    with ResultsStore(database) as store:
        rows = store.frame()
        adequacy = store.adequacy()
        provenance = store.matrix_runs().iloc[-1]
    assert provenance["status"] == "finished" and provenance["rows_stored"] == len(matrix.runs)
    assert sorted(rows["run_key"]) == sorted(run.run_key for run in matrix.runs)
    assert set(adequacy["scene"]) == {scene.name for scene in matrix.scenes}
    for scene in matrix.scenes:
        for integrator in {run.integrator for run in matrix.runs}:
            assert any(scene.name in line and f" {integrator} " in f"{line} " for line in summary.splitlines())
    assert set(rows["status"]) <= {"ok", "diverged"}, rows.loc[rows["status"] == "failed", "message"].tolist()
    ok = rows[rows["status"] == "ok"]
    assert ok["reference_error"].notna().all() and ok["energy_max_rel_error"].notna().all()
    assert (ok["wall_time_s"] > 0).all() and (ok["repeats"] >= 1).all() and (ok["peak_rss_mb"] > 0).all()
    assert (ok["cpu_time_s"] > 0).all() and (ok["cpu_time_spread_s"] >= 0).all()
    _check_stored_precision(ok)
    # the per-step energy error comes from the untimed monitored call, for the fixed-step loops only
    fixed = ok["kh"].notna()
    assert ok.loc[fixed, "energy_max_rel_error_steps"].notna().all()
    assert ok.loc[~fixed, "energy_max_rel_error_steps"].isna().all()
    # every integrator of a scene on the scene's own output grid (no run stores its steps)
    grid_points = {scene.name: scene.n_intervals + 1 for scene in matrix.scenes}
    assert (rows["n_out"] == rows["scene"].map(grid_points)).all()
    # convergence: every integrator's reference error falls as its step or tolerance shrinks, down to its
    # round-off: a run whose error is below ε per right-hand-side evaluation (the worst case of the rounding
    # accumulated over its evaluations, each one rounding the state at most once per sum) has no truncation error
    # left to fall (composition10 on the 90-s scene: 3.5e-12 at kh 0.2, 5.7e4 evaluations, floor 1.3e-11)
    # (the implicit schemes store no evaluation count: no floor for them)
    above_round_off = ok[ok["reference_error"] > np.finfo(float).eps * ok["nfev"].fillna(0.0)]
    for (scene, integrator), group in above_round_off.groupby(["scene", "integrator"]):
        setting = "kh" if group["kh"].notna().all() else "tol"
        errors = group.sort_values(setting)["reference_error"].to_numpy()
        assert np.all(np.diff(errors) > 0), (scene, integrator, errors)
    below = sorted(set(ok["integrator"]) - set(above_round_off["integrator"]))
    assert set(below) <= {"composition8", "composition10", "vern9"}, below  # the orders ≥ 8 on a 90-s scene


def _check_stored_precision(ok) -> None:
    """Every timed row's cost figures recomputed from its stored repeats (``cpu_time_repeats_s``): their count,
    median and spread, and the precision from scipy's binomial order-statistic interval; and a positive
    machine calibration (timed beside each run's repeats)."""
    import json
    import statistics

    from scipy.stats import binom

    for _, row in ok.iterrows():
        repeats_s = json.loads(row["cpu_time_repeats_s"])
        assert len(repeats_s) == row["repeats"]
        assert statistics.median(repeats_s) == row["cpu_time_s"]
        assert max(repeats_s) - min(repeats_s) == row["cpu_time_spread_s"]
        ordered, count = sorted(repeats_s), len(repeats_s)
        covering = [k for k in range(1, count // 2 + 1) if 1 - 2 * binom.cdf(k - 1, count, 0.5) >= 0.95]
        if not covering:
            assert pd.isna(row["cpu_time_ci95_rel"])
        else:
            k = max(covering)
            expected = (ordered[count - k] - ordered[k - 1]) / (2 * statistics.median(repeats_s))
            assert row["cpu_time_ci95_rel"] == pytest.approx(expected, rel=1e-12)
        assert row["calibration_cpu_s"] > 0


def test_rows_carry_their_cost_precision_repeats_and_calibration(tmp_path):
    """Runs of a short scene under the default timing protocol: every stored figure recomputed from the stored
    repeats (``_check_stored_precision``), each with the calibration timed beside its own repeats."""
    matrix_path = write(tmp_path / "precision.toml", """
        scenes = ["seed_2min"]
        integrators = ["rk4", "scipy_rk45"]
        kh = [0.2, 0.05]
        tol = [1e-6]
        """)
    matrix = load_matrix(matrix_path)
    with ResultsStore(tmp_path / "precision.sqlite") as store:
        run_matrix(matrix, store, jobs=1, progress=False)
        rows = store.frame()
    ok = rows[rows["status"] == "ok"]
    assert len(ok) == len(matrix.runs) == 3
    _check_stored_precision(ok)


def test_each_compiled_function_is_built_by_one_run_before_the_others(tmp_path):
    """``compile_first``: one run per integrator and model (and per tolerance for heyoka, which compiles per ε),
    the cheapest of its group (coarsest setting, shortest scene), and every run exactly once over both groups."""
    from foucault_bench.bench.run.runner import compile_first

    matrix = load_matrix(write(tmp_path / "compile.toml", """
        scenes = ["seed_2min", "lab_3m", "lab_3m_ns"]
        integrators = ["rk4", "heyoka_taylor", "cvode_bdf"]
        kh = [0.2, 0.1]
        tol = [1e-6, 1e-8]
        """))
    firsts, rest = compile_first(sorted(matrix.runs, key=lambda spec: spec.run_key))
    assert sorted(spec.run_key for spec in firsts + rest) == sorted(spec.run_key for spec in matrix.runs)
    groups: dict[tuple, list] = {}
    for spec in matrix.runs:
        key = (spec.integrator, spec.scene.model, spec.tol if spec.integrator == "heyoka_taylor" else None)
        groups.setdefault(key, []).append(spec)
    assert len(firsts) == len(groups) == len({(spec.integrator, spec.scene.model, spec.tol
                                               if spec.integrator == "heyoka_taylor" else None) for spec in firsts})
    for spec in firsts:
        key = (spec.integrator, spec.scene.model, spec.tol if spec.integrator == "heyoka_taylor" else None)
        shortest = min(other.scene.duration_s for other in groups[key])
        coarsest = max((other.kh or other.tol) for other in groups[key] if other.scene.duration_s == shortest)
        assert (spec.scene.duration_s, spec.kh or spec.tol) == (shortest, coarsest), key


def test_diverging_and_failing_runs_are_rows_and_the_others_finish(tmp_path, failing_plugin):
    matrix_path = write(tmp_path / "failing.toml", f"""
        plugins = ["{failing_plugin}"]
        integrators = ["explicit_euler", "rk4", "test_raises", "test_broken", "test_kills_worker"]
        [scene.paris_10min]
        base = "pantheon"
        duration_s = 600.0
        [override.explicit_euler]
        kh = [0.7]
        [override.rk4]
        kh = [0.1, 0.05]
        [override.test_raises]
        tol = [1e-6]
        [override.test_broken]
        tol = [1e-6]
        [override.test_kills_worker]
        tol = [1e-6]
        [timing]
        min_repeats = 1
        min_total_s = 0.0
        """)
    matrix = load_matrix(matrix_path)
    with ResultsStore(tmp_path / "failing.sqlite") as store:
        run_matrix(matrix, store, jobs=2, progress=False)
        rows = store.frame().set_index("integrator")
    assert len(rows) == len(matrix.runs) == 6
    euler = rows.loc["explicit_euler"]
    assert euler["status"] == "diverged" and "diverged after" in euler["message"]
    assert euler["energy_max_rel_error"] > 1.0  # verdicts up to the divergence
    assert rows.loc["test_raises", "status"] == "failed"
    assert "deliberate failure inside the library" in rows.loc["test_raises", "message"]
    assert rows.loc["test_broken", "status"] == "failed"
    assert rows.loc["test_broken", "message"].startswith("solve: TypeError: deliberately broken")
    assert rows.loc["test_kills_worker", "status"] == "failed"
    assert rows.loc["test_kills_worker", "message"] == WORKER_DIED
    rk4 = rows.loc[["rk4"]]
    assert (rk4["status"] == "ok").all() and rk4["reference_error"].notna().all()


def _stored_rows(database: Path) -> int:
    try:
        with sqlite3.connect(database, timeout=5.0) as connection:
            return connection.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.OperationalError:  # not created yet
        return 0


def test_resume_after_a_killed_run_loses_and_duplicates_nothing(tmp_path):
    matrix_path = write(tmp_path / "resume.toml", """
        scenes = ["seed_2min"]
        integrators = ["rk4", "verlet"]
        kh = [0.2, 0.15, 0.1, 0.07, 0.05, 0.035, 0.025, 0.018, 0.0125, 0.009]
        [timing]
        min_repeats = 3
        min_total_s = 0.3
        max_repeats = 100000
        """)  # every run repeats for 0.3 s of CPU time, so that the matrix is still running when it is killed
    database = tmp_path / "resume.sqlite"
    sources_before = code_version.__wrapped__()
    command = [sys.executable, "-m", "foucault_bench.bench.cli", "run", "--matrix", str(matrix_path), "--db", str(database),
               "--jobs", "1", "--no-progress"]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    try:
        deadline = time.monotonic() + 120.0
        while _stored_rows(database) < 3 and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the runner and its worker, like a power cut
        process.wait(timeout=30)
    if code_version.__wrapped__() != sources_before:  # only in a tree being edited, never in CI
        pytest.skip("the package's sources changed while the test ran: a resume rightly starts afresh")
    matrix = load_matrix(matrix_path)
    with ResultsStore(database) as store:
        before = store.frame()
        assert 3 <= len(before) < len(matrix.runs), "the run must be killed part-way"
        assert store.matrix_runs()["status"].tolist() == ["running"]
        run_matrix(matrix, store, jobs=1, resume=True, progress=False)
        after = store.frame()
        runs = store.matrix_runs()
    assert len(runs) == 1 and runs["status"].iloc[0] == "finished"
    assert sorted(after["run_key"]) == sorted(run.run_key for run in matrix.runs)  # every row, once
    kept = after.set_index("run_key").loc[before["run_key"], list(COLUMN_NAMES[1:])]
    original = before.set_index("run_key")[list(COLUMN_NAMES[1:])]
    assert kept.equals(original)  # finished rows untouched, bit for bit (cost columns included)
    assert (after["status"] == "ok").all()
