"""Subprocess probes of ``foucault-bench perf``: each runs in a fresh interpreter and prints one line of JSON.

    python -m bench.perf.probes compile INTEGRATOR MODEL [MODEL ...]
    python -m bench.perf.probes memory INTEGRATOR MODEL STEPS SPAN_KH

``compile``: the time to import the integrators, then per model the first ``solve`` of a short problem (JIT
compilation or loading from the caches, plus one run) and the median of three more (the run alone); compile
time = first − median. Which caches are cold is decided by the caller's environment
(``bench.perf.measure.cache_environment``).

``memory``: peak resident memory (getrusage ru_maxrss) after importing and compiling, and after one
fixed-step run of STEPS steps with streaming verdicts (``monitor=True``) over SPAN_KH / k seconds with an
output grid of ``MEMORY_OUTPUTS`` rows: called with the same span, only the step count changes between calls.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from typing import TYPE_CHECKING, Any, cast

if TYPE_CHECKING:
    from foucault_bench.integrators import FixedStepIntegrator, StreamedMetrics

MEMORY_OUTPUTS = 1000

PROBE_TOLERANCE = 1.0e-8


def _probe_parameters():
    from foucault_bench.models import PendulumParameters

    return PendulumParameters(length_m=3.0, latitude_deg=48.846, amplitude_m=0.3)


def compile_probe(integrator_name: str, model_names: list[str]) -> dict:
    started = time.perf_counter()
    import numpy as np

    from foucault_bench.integrators import Problem, get_integrator
    from foucault_bench.integrators.methods.heyoka_taylor import REFERENCE_TOLERANCE
    from foucault_bench.models import MODELS

    import_s = time.perf_counter() - started
    integrator = get_integrator(integrator_name)
    params = _probe_parameters()
    period = params.small_swing_period_s
    if integrator.adaptive:
        setting: dict[str, Any] = {
            "tol": REFERENCE_TOLERANCE if integrator_name == "heyoka_taylor_quad" else PROBE_TOLERANCE}
    else:
        setting = {"step_s": period / 64}
    results = []
    for model_name in model_names:
        problem = Problem(MODELS[model_name], params, np.linspace(0.0, 2.0 * period, 17))
        start = time.perf_counter()
        solution = integrator.solve(problem, **setting)
        first_s = time.perf_counter() - start
        runs = []
        for _ in range(3):
            start = time.perf_counter()
            integrator.solve(problem, **setting)
            runs.append(time.perf_counter() - start)
        run_s = statistics.median(runs)
        results.append({"model": model_name, "status": solution.status, "message": solution.message,
                        "first_s": first_s, "run_s": run_s, "compile_s": max(0.0, first_s - run_s)})
    return {"integrator": integrator_name, "import_s": import_s, "models": results}


def memory_probe(integrator_name: str, model_name: str, steps: int, span_kh: float) -> dict:
    import numpy as np

    from foucault_bench.bench.run.timing import peak_rss_mb
    from foucault_bench.integrators import Problem, get_integrator
    from foucault_bench.models import MODELS

    params = _probe_parameters()
    span = span_kh / params.pendulum_frequency_rad_s
    problem = Problem(MODELS[model_name], params, np.linspace(0.0, span, MEMORY_OUTPUTS + 1))
    integrator = cast("FixedStepIntegrator", get_integrator(integrator_name))
    integrator.compile(problem.model)
    before_mb = peak_rss_mb()
    start = time.perf_counter()
    solution = integrator.solve(problem, step_s=span / steps, monitor=True)
    run_s = time.perf_counter() - start
    return {"integrator": integrator_name, "model": model_name, "steps": solution.steps, "status": solution.status,
            "turning_points": len(cast("StreamedMetrics", solution.streamed).turning_points), "before_mb": before_mb,
            "peak_mb": peak_rss_mb(), "run_s": run_s}


def main(argv: list[str]) -> int:
    kind, arguments = argv[0], argv[1:]
    if kind == "compile":
        result = compile_probe(arguments[0], arguments[1:])
    elif kind == "memory":
        result = memory_probe(arguments[0], arguments[1], int(float(arguments[2])), float(arguments[3]))
    else:
        raise SystemExit(f"unknown probe {kind!r}: compile or memory")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
