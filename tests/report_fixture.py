"""A deterministic results database for the report's oracle tests, written through the real results store.

``build_fixture_database(path)`` writes one matrix run whose run specs come from ``parse_matrix`` (real run
keys, scenes, declared integrator facts; ``bench.run.execute.base_row`` for each row's identity) and whose
outcome columns are synthetic but plausible, so that no integrator runs and the file is written in well under a
second:

* four scenes of three models: ``pantheon`` (linear), ``lab_3m`` (spherical), ``seed_2min`` (linear) and the
  inline scene ``planar_lab`` (not a built-in scene: the seed's planar model, which conserves no energy);
* fixed-step integrators (rk4, verlet, explicit_euler; four kh each) whose reference error follows C·(kh)^p at
  the declared order p with a constant C different in every scene, and whose cost grows as 1/kh; the stored
  kh is the step actually taken (the output interval divided into whole steps, as the fixed-step loop does), so
  most are not round numbers;
* adaptive integrators (cvode_adams, dopri5, scipy_lsoda; three tolerances each) whose error follows C·tol^q
  and whose steps grow as tol^(−1/(order+1));
* explicit Euler diverged at its largest kh in every scene (no cost: the run stopped before it was timed) and at
  the next one on pantheon (with cost); scipy_lsoda failed at its tightest tolerance (no cost) and cvode_adams
  at 1e-10 on lab_3m (with cost); messages hold ``|``, ``<`` and ``&``; rk4 at its largest kh on seed_2min is
  ok but has no precession rate (an ok run without a value, drawn on the charts' bottom edge);
* model-adequacy rows whose notes hold ``|``, ``<`` and ``&``.

``tests/conftest.py`` registers its pytest fixtures for every test module: ``fixture_database`` builds the file
once per test session, ``fixture_report`` the report of that database with ``reports.build.build_report``
(studies skipped, no seed section; the slowest fixture of the suite). Under pytest-xdist both are built once for
all the session's workers, in the session's shared temporary folder under a file lock (``built_once``): the
first worker that needs one builds it, a worker that needs it meanwhile waits for it. Helpers and constants are imported with ``from report_fixture import ...``.
"""

from __future__ import annotations

import math
import re
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import unquote

import pytest
from filelock import FileLock

if TYPE_CHECKING:  # imported where used: tests/conftest.py imports this module for every test session
    from foucault_bench.bench.run.matrix import Matrix, RunSpec

FIXED_STEP = ("rk4", "verlet", "explicit_euler")
ADAPTIVE = ("cvode_adams", "dopri5", "scipy_lsoda")
KH_SWEEP = (0.4, 0.2, 0.1, 0.05)
TOL_SWEEP = (1e-6, 1e-8, 1e-10)
INLINE_SCENE = "planar_lab"
SCENE_NAMES = ("pantheon", "lab_3m", "seed_2min", INLINE_SCENE)

SCENE_SCALE = {"pantheon": 3.0, "lab_3m": 0.2, "seed_2min": 0.02, INLINE_SCENE: 0.6}
"""Per scene, the factor of every error constant: charts of different scenes differ."""
SECONDS_PER_EVALUATION = {"pantheon": 2.0e-7, "lab_3m": 3.5e-7, "seed_2min": 1.5e-7, INLINE_SCENE: 2.5e-7}
"""Per scene, the CPU time of one right-hand-side evaluation (the spherical model's is dearer)."""
ERROR_CONSTANT = {"rk4": 0.02, "verlet": 0.5, "explicit_euler": 4.0, "cvode_adams": 40.0, "dopri5": 3.0,
                  "scipy_lsoda": 15.0}
TOLERANCE_EXPONENT = {"cvode_adams": 0.95, "dopri5": 0.9, "scipy_lsoda": 0.85}
ADAPTIVE_ORDER = {"cvode_adams": 6, "dopri5": 5, "scipy_lsoda": 5}
EVALUATIONS_PER_STEP = {"cvode_adams": 1.3, "dopri5": 6.0, "scipy_lsoda": 1.5}
ROUND_OFF = 2e-15
MODEL_ENERGY_DRIFT = 3e-3
"""The planar model's own energy change over the scene (it conserves no energy): what its energy verdicts show."""
ANALYTIC_MODEL_GAP = {"lab_3m": 4e-3, INLINE_SCENE: 9e-3}
"""Distance from the linear model's exact solution where the scene's model is not the linear one."""

DIVERGED_MESSAGE = "diverged at t < 120 s: |r| > 10 L & the state is not finite"
FAILED_MESSAGE = "solve: ODEintWarning | excess work done <mxstep> & tolerance too tight"
FAILED_WITH_COST_MESSAGE = "verdicts: CVodeError flag -4 | convergence test failed <t = 811 s> & h < hmin"

MATRIX_DOCUMENT = {
    "name": "report_fixture",
    "description": "fixture of the report's oracle tests: three models, an inline scene, fixed & adaptive",
    "scenes": ["pantheon", "lab_3m", "seed_2min"],
    "scene": {INLINE_SCENE: {"base": "seed_2min", "model": "seed_planar", "latitude_deg": 60.0,
                             "title": "Lab bench | planar model <seed eqs. 4-5> & 60° N"}},
    "integrators": [*FIXED_STEP, *ADAPTIVE],
    "kh": list(KH_SWEEP),
    "tol": list(TOL_SWEEP),
}


def fixture_matrix() -> "Matrix":
    """The fixture's matrix, validated by the real parser."""
    from foucault_bench.bench.run.matrix import parse_matrix

    return parse_matrix(MATRIX_DOCUMENT, source="report_fixture", default_name="report_fixture")


def _taken_step_s(spec: "RunSpec") -> float:
    """The step the fixed-step loop takes: the output interval divided into whole steps no longer than asked."""
    interval = spec.scene.output_interval_s
    return interval / math.ceil(interval / spec.step_s * (1.0 - 1e-12))


def _outcome(spec: "RunSpec") -> dict[str, object]:
    """The synthetic outcome columns of one run."""
    from foucault_bench.integrators import REGISTRY

    scene, name = spec.scene, spec.integrator
    scale = SCENE_SCALE[scene.name]
    k = scene.params.pendulum_frequency_rad_s
    integrator = REGISTRY[name]
    conserves = scene.model != "seed_planar"
    row: dict[str, object] = {"family": integrator.family, "status": "ok", "n_out": scene.n_intervals + 1,
                              "energy_conserved": int(conserves)}
    if spec.kh is not None:
        step_s = _taken_step_s(spec)
        kh = step_s * k
        steps = round(scene.duration_s / step_s)
        evaluations = steps * integrator.stages
        error = ERROR_CONSTANT[name] * scale * kh ** integrator.order
        energy = 0.25 * kh**2 * scale if name == "verlet" else 0.3 * error
        drift = (1e-3 * energy if name == "verlet" else energy) / scene.duration_s
        row.update(step_s=step_s, kh=kh, steps=steps, nfev=evaluations, rejected_steps=None)
    else:
        order = ADAPTIVE_ORDER[name]
        steps = round(scene.duration_s * k * 2.0 * spec.tol ** (-1.0 / (order + 1)))
        evaluations = round(steps * EVALUATIONS_PER_STEP[name])
        error = ERROR_CONSTANT[name] * scale * spec.tol ** TOLERANCE_EXPONENT[name]
        energy, drift = 0.5 * error, 0.1 * error / scene.duration_s
        row.update(steps=steps, nfev=evaluations, rejected_steps=steps // 20,
                   njev=steps // 50 if integrator.family == "multistep" else None)
    error = max(min(error, 2.0), ROUND_OFF * math.sqrt(steps))
    if not conserves:  # the model's own energy change dominates whatever the integrator does
        energy, drift = MODEL_ENERGY_DRIFT + energy, MODEL_ENERGY_DRIFT / scene.duration_s + drift
    cpu_s = evaluations * SECONDS_PER_EVALUATION[scene.name] + 2e-4
    row.update(
        reference_error=error, energy_max_rel_error=energy, energy_drift_per_s=drift,
        energy_max_rel_error_steps=1.05 * energy if spec.kh is not None else None,
        precession_rate_ref_error=0.7 * error, precession_rate_ref_error_earth=0.7 * error * 0.75,
        precession_rate_ref_error_rad_s=0.7 * error * 5.5e-5,
        precession_rate_error=0.7 * error + 2e-3 * scale, precession_rate_error_earth=(0.7 * error + 2e-3) * 0.75,
        precession_rate_error_rad_s=(0.7 * error + 2e-3) * 5.5e-5, precession_rate_rad_s=-5.49e-5,
        analytic_gap_exact=error + ANALYTIC_MODEL_GAP.get(scene.name, 1e-9),
        analytic_gap_seed=error + 1e-3,
        cpu_time_s=cpu_s, cpu_time_spread_s=0.04 * cpu_s, wall_time_s=1.1 * cpu_s, wall_time_spread_s=0.08 * cpu_s,
        repeats=3, compile_time_s=0.15, peak_rss_mb=210.0 + len(name),
    )
    if steps % 3:  # a stated precision (2-6 %, the timing protocol's ≥ 6 repeats); none for the other runs
        row.update(repeats=8, cpu_time_ci95_rel=0.02 * (1 + steps % 3), calibration_cpu_s=0.01)
    return row


def _unhappy(spec: "RunSpec", row: dict[str, object]) -> dict[str, object]:
    """The diverged and failed runs (see the module docstring); ``row`` unchanged for every other run."""
    no_cost = dict.fromkeys(("cpu_time_s", "cpu_time_spread_s", "wall_time_s", "wall_time_spread_s", "repeats",
                             "compile_time_s", "cpu_time_ci95_rel", "calibration_cpu_s"))
    no_verdicts = dict.fromkeys(("reference_error", "energy_max_rel_error", "energy_drift_per_s",
                                 "energy_max_rel_error_steps", "precession_rate_rad_s", "precession_rate_ref_error",
                                 "precession_rate_ref_error_earth", "precession_rate_ref_error_rad_s",
                                 "precession_rate_error", "precession_rate_error_earth", "precession_rate_error_rad_s",
                                 "analytic_gap_exact", "analytic_gap_seed"))
    scene = spec.scene.name
    if spec.integrator == "rk4" and spec.kh == KH_SWEEP[0] and scene == "seed_2min":  # ok, but no rate measured
        return {**row, "precession_rate_rad_s": None, "precession_rate_ref_error": None,
                "precession_rate_ref_error_earth": None, "precession_rate_ref_error_rad_s": None,
                "precession_rate_error": None, "precession_rate_error_earth": None, "precession_rate_error_rad_s": None}
    if spec.integrator == "explicit_euler" and spec.kh == KH_SWEEP[0]:
        return {**row, **no_cost, "status": "diverged", "message": DIVERGED_MESSAGE, "reference_error": None,
                "energy_max_rel_error": 1e3, "precession_rate_ref_error": None}
    if spec.integrator == "explicit_euler" and spec.kh == KH_SWEEP[1] and scene == "pantheon":
        return {**row, "status": "diverged", "message": DIVERGED_MESSAGE, "reference_error": None,
                "energy_max_rel_error": 5e2, "precession_rate_ref_error": None}
    if spec.integrator == "scipy_lsoda" and spec.tol == TOL_SWEEP[-1]:
        counters = dict.fromkeys(("nfev", "njev", "steps", "rejected_steps"))  # the solve raised: nothing counted
        return {**row, **no_cost, **no_verdicts, **counters, "status": "failed", "message": FAILED_MESSAGE}
    if spec.integrator == "cvode_adams" and spec.tol == TOL_SWEEP[-1] and scene == "lab_3m":
        return {**row, **no_verdicts, "status": "failed", "message": FAILED_WITH_COST_MESSAGE}
    return row


def fixture_rows(matrix_id: str) -> list[dict[str, object]]:
    """Every row of the fixture's matrix run ``matrix_id``, in matrix order."""
    from foucault_bench.bench.run.execute import base_row

    return [_unhappy(spec, {**base_row(spec, matrix_id), **_outcome(spec)}) for spec in fixture_matrix().runs]


def fixture_adequacy() -> dict[str, list[dict[str, object]]]:
    """Model-adequacy rows per scene (their notes hold ``|``, ``<`` and ``&``)."""
    def row(scene: str, model: str, simpler: str, rate: float, gap: float, expected: float) -> dict[str, object]:
        return {"scene": scene, "model": model, "simpler_model": simpler, "scene_model": model,
                "precession_rate_diff": rate, "trajectory_gap": gap, "expected_rate_diff": expected,
                "expected_trajectory_gap": math.nan,
                "note": f"{simpler} vs {model}: rate differs by {rate:+.2e} Ω_E|sin φ| & paths by < {gap:.0e} A"}

    return {"lab_3m": [row("lab_3m", "spherical", "linear", 7.4e-4, 1.2e-2, 7.5e-4),
                       row("lab_3m", "spherical", "seed_planar", 8.1e-4, 3.0e-2, math.nan)],
            "pantheon": [row("pantheon", "linear", "seed_planar", 2.0e-5, 4.0e-4, math.nan)]}


def build_fixture_database(path: Path) -> Path:
    """Write the fixture database at ``path`` (a new file) through ``ResultsStore``; return ``path``."""
    from foucault_bench.bench.run.store import ResultsStore

    path = Path(path)
    if path.exists():
        raise FileExistsError(f"{path} exists: the fixture writes a new database")
    matrix = fixture_matrix()
    with ResultsStore(path) as store:
        matrix_id, _ = store.start_matrix_run(matrix, jobs=1, scheduler=None, resume=False)
        for row in fixture_rows(matrix_id):
            store.write_run(row)
        for scene, rows in fixture_adequacy().items():
            store.write_adequacy(matrix_id, scene, rows)
        store.finish_matrix_run(matrix_id)
    return path


def build_fixture_report(database: Path, folder: Path) -> Path:
    """The report of the fixture database in ``folder`` (``reports.build.build_report``; no studies, no seed
    section; static files too, which the chart oracles compare; figures drawn by two worker processes);
    returns ``folder``."""
    from foucault_bench.bench.run.store import ResultsStore
    from foucault_bench.reports.build import ReportInputs, build_report

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with ResultsStore(database, create=False) as store:
        runs = store.frame()
        adequacy = store.adequacy()
    build_report(ReportInputs(runs=runs, adequacy=adequacy, provenance={"database": database.name},
                              jobs=2), folder)
    return folder


def report_pages(folder: Path) -> list[Path]:
    """The HTML pages of the report in ``folder``: index.html and every page its bar of pages links, in order."""
    index = Path(folder) / "index.html"
    bar = re.search(r"<ul class='pages'>(.*?)</ul>", index.read_text(encoding="utf-8"), re.S)
    linked = re.findall(r"<a href='([^']+)'>", bar.group(1)) if bar else []
    return [index, *(Path(folder) / unquote(name) for name in linked)]


def report_html(folder: Path) -> str:
    """Every HTML page of the report in ``folder`` (``report_pages``), one after another."""
    return "\n".join(page.read_text(encoding="utf-8") for page in report_pages(folder))


def built_once(request: pytest.FixtureRequest, name: str, build: Callable[[Path], object]) -> Path:
    """``build(path)`` run once per test session for ``path`` = ``name`` in the session's temporary folder, which
    pytest-xdist's workers share (the parent of each worker's own base folder, as pytest-xdist's documentation
    recommends); the first worker to ask builds it under a file lock, the others wait for it and reuse it. A build
    that raised leaves no completion marker: the next worker that asks starts it again from nothing."""
    root = request.getfixturevalue("tmp_path_factory").getbasetemp()
    if hasattr(request.config, "workerinput"):  # a pytest-xdist worker (not a pytest run by a test on one)
        root = root.parent
    path, done = root / name, root / f"{name}.done"
    with FileLock(root / f"{name}.lock"):
        if not done.exists():
            if path.is_dir():
                shutil.rmtree(path)
            path.unlink(missing_ok=True)
            build(path)
            done.touch()
    return path


@pytest.fixture(scope="session")
def fixture_database(request: pytest.FixtureRequest) -> Path:
    """The fixture database (``build_fixture_database``), built once per test session."""
    return built_once(request, "fixture.sqlite", build_fixture_database)


@pytest.fixture(scope="session")
def fixture_report(fixture_database: Path, request: pytest.FixtureRequest) -> Path:
    """The report folder of the fixture database (``build_fixture_report``), built once per test session."""
    return built_once(request, "report-fixture-report",
                      lambda folder: build_fixture_report(fixture_database, folder))
