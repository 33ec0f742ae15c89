"""Behaviour of the ``foucault-bench perf`` harness (bench/perf): never its timings.

* the plain C loops (``bench/perf/loops.c``) compute the same states and verdict streams as the numba kernels
  they are compared with, to round-off, for every scheme on both models;
* the subprocess probes return numbers (memory, compile);
* target rows are formatted with the right verdict;
* the deterministic numba cache key of ``models.jit`` is the same in two processes and tells models apart, and
  loops compiled in different processes, loaded together from the cache, still compute the C loops' states.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from foucault_bench.bench.perf.c_loops import MODELS, SCHEMES, WITHOUT_C_REFERENCE, CompilerMissing, compile_c_loops
from foucault_bench.bench.perf.fixed_step import KH, LoopPair
from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio, run_probe
from foucault_bench.integrators import get_integrator
from foucault_bench.integrators.fixed_step import FixedStepIntegrator
from foucault_bench.integrators.registry import built_in_names


@pytest.fixture(scope="module")
def c_loops(tmp_path_factory):
    try:
        return compile_c_loops(tmp_path_factory.mktemp("c_loops"))
    except CompilerMissing as missing:
        pytest.skip(str(missing))


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_c_loop_computes_the_numba_kernel_states(c_loops, model: str, scheme: str) -> None:
    pair = LoopPair(c_loops, model, scheme, n_steps=20_000)  # 20 000 steps at k·h = 5e-4: past a turning point
    pair.check_same_states()
    status, steps, n_turning, max_rel, slope = pair.numba(True)
    assert n_turning >= 1 and max_rel > 0.0
    plain = pair.c(False)
    assert plain.status == 0 and plain.steps_done == 20_000


def test_every_built_in_fixed_step_scheme_has_a_c_reference() -> None:
    """Each built-in fixed-step scheme has a C loop in loops.c, or is listed as one without (a known gap, printed
    by perf)."""
    fixed_step = {name for name in built_in_names() if isinstance(get_integrator(name), FixedStepIntegrator)}
    assert fixed_step == set(SCHEMES) | set(WITHOUT_C_REFERENCE)
    assert not set(SCHEMES) & set(WITHOUT_C_REFERENCE)


@pytest.mark.parametrize(("scheme", "kh"), [
    ("explicit_euler", 1.0),  # energy grows by 1 + (kh)² = 2 per step and soon leaves the bound
    ("gauss_legendre4", 4.0),  # beyond the fixed-point solve's limit 2√3: the first step returns NaN
])
def test_c_loop_reports_divergence_like_the_kernel(c_loops, scheme: str, kh: float) -> None:
    pair = LoopPair(c_loops, "linear", scheme, n_steps=10_000)
    pair.h *= kh / KH
    kernel_status, kernel_steps, *_ = pair.numba(False)
    result = pair.c(False)
    assert kernel_status == result.status == 1
    assert kernel_steps == result.steps_done < 10_000


def test_memory_probe_returns_numbers() -> None:
    result = run_probe(["memory", "rk4", "linear", "20000", "2000"])
    assert result["status"] == "ok" and result["steps"] == 20_000
    assert 0 < result["before_mb"] <= result["peak_mb"] < 10_000
    assert result["turning_points"] > 0


def test_compile_probe_returns_numbers() -> None:
    result = run_probe(["compile", "symplectic_euler", "linear"])
    (entry,) = result["models"]
    assert entry["status"] == "ok" and entry["first_s"] >= entry["compile_s"] >= 0.0 and result["import_s"] > 0


@pytest.mark.parametrize(("value", "target", "verdict"), [(1.1, 1.2, "met"), (1.3, 1.2, "missed"),
                                                          (0.5, None, "info"), (None, 1.2, "skipped")])
def test_target_row_verdict_and_cells(value, target, verdict) -> None:
    row = Row("loops", "rk4/linear, verdicts off: numba / C", value, "×", target, "note")
    assert row.verdict == verdict
    cells = row.cells()
    assert cells[0] == "loops" and cells[4] == verdict and cells[5] == "note"
    assert cells[2] == ("–" if value is None else f"{value:.3g} ×")
    assert cells[3] == ("–" if target is None else f"≤ {target:.3g} ×")


def test_interleaved_times_every_contender_in_alternating_order_and_ratios_are_per_round() -> None:
    """A fake clock that each call of ``a`` advances by 4 ms and of ``b`` by 10 ms: after a warm-up and a
    sizing call each, every turn is a batch lasting ``round_min_s`` (20 ms: 5 calls of a, 2 of b), the rounds
    alternate the order, and each round's figure is the batch's median cost per call."""
    called: list[str] = []
    clock = [0.0]
    cost_s = {"a": 0.004, "b": 0.01}

    def contender(name: str):
        def call() -> None:
            called.append(name)
            clock[0] += cost_s[name]
        return call

    times = interleaved({name: contender(name) for name in "ab"}, rounds=4, clock=lambda: clock[0], round_min_s=0.02)
    assert [len(times["a"]), len(times["b"])] == [4, 4]
    forward, backward = "a" * 5 + "b" * 2, "b" * 2 + "a" * 5
    assert "".join(called) == "aabb" + forward + backward + forward + backward  # warm-ups, then alternating rounds
    assert times["a"] == pytest.approx([0.004] * 4) and times["b"] == pytest.approx([0.01] * 4)
    assert median_ratio([2.0, 4.0, 9.0], [1.0, 1.0, 3.0]) == 3.0


KEY_SCRIPT = """
import numpy as np
from foucault_bench.models import MODELS
from foucault_bench.models.jit import _FingerprintCache
from numba.core.registry import cpu_target
codegen = cpu_target.target_context.codegen()
for name in ("linear", "spherical"):
    dispatcher = MODELS[name].numba_acceleration
    print(_FingerprintCache(dispatcher.py_func)._index_key((), codegen)[2])
"""


def test_jit_cache_key_is_the_same_in_every_process_and_differs_between_models() -> None:
    keys = [subprocess.run([sys.executable, "-c", KEY_SCRIPT], capture_output=True, text=True, check=True)
            .stdout.split() for _ in range(2)]
    assert keys[0] == keys[1]  # numba's own key (a pickle of the closure cells) differs in every process
    assert keys[0][0] != keys[0][1]  # the same closure code over different model sources
    assert np.all([len(key) == 64 for key in keys[0]])


COMPILE_SCRIPT = """
import sys
from foucault_bench.integrators import get_integrator
from foucault_bench.models import MODELS
scheme, model = sys.argv[1].split("/")
get_integrator(scheme).compile(MODELS[model])
"""

CHECK_SCRIPT = """
import sys
from foucault_bench.bench.perf.c_loops import compile_c_loops
from foucault_bench.bench.perf.fixed_step import LoopPair
from foucault_bench.integrators import get_integrator
from foucault_bench.models import MODELS
c_loops = compile_c_loops()
for pair in sys.argv[1:]:
    scheme, model = pair.split("/")
    LoopPair(c_loops, model, scheme, 20_000).check_same_states()
    assert sum(get_integrator(scheme).kernel(MODELS[model]).stats.cache_hits.values()) == 1, pair
"""


def test_loops_compiled_in_different_processes_load_together_correctly(c_loops, tmp_path) -> None:
    # The same closure source (RK4's loop) over two models, each compiled in its own process: loaded into a
    # third process from the cache they must not be confused (numba names machine code after the function).
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    pairs = ["rk4/linear", "rk4/spherical"]
    for pair in pairs:
        subprocess.run([sys.executable, "-c", COMPILE_SCRIPT, pair], env=environment, check=True)
    subprocess.run([sys.executable, "-c", CHECK_SCRIPT, *pairs], env=environment, check=True)


def test_cache_entries_are_stored_in_files_named_after_their_keys(tmp_path) -> None:
    from foucault_bench.models.jit import _KeyedDataCacheFile

    cache_file = _KeyedDataCacheFile(cache_path=str(tmp_path), filename_base="f-1.py311", source_stamp=(1.0, 2))
    cache_file.save(("sig a", "cpu"), "code a")
    cache_file.save(("sig b", "cpu"), "code b")
    assert cache_file.load(("sig a", "cpu")) == "code a" and cache_file.load(("sig b", "cpu")) == "code b"
    assert len(list(tmp_path.glob("f-1.py311.*.nbc"))) == 2  # one file per key, whatever the save order


def test_jobs_check_matrix_is_valid_and_covers_the_quick_matrix(tmp_path) -> None:
    from foucault_bench.bench.perf.limits import quick_jobs_matrix
    from foucault_bench.bench.run.matrix import load_matrix

    path = tmp_path / "jobs-check.toml"
    path.write_text(quick_jobs_matrix(), encoding="utf-8")
    matrix = load_matrix(path)
    covered = {spec.integrator for spec in matrix.runs}
    assert covered == {spec.integrator for spec in load_matrix("quick").runs}
    assert len(matrix.runs) == len(covered)  # one heavy setting each
