"""Section ``memory``: peak resident memory of long fixed-step runs with streaming verdicts.

RK4 on the linear model with ``monitor=True`` over the same span (10⁶/k, about 1.6·10⁵ swing periods) and
output grid (``probes.memory_probe``) with 10⁷ and 10⁸ steps (k·h = 0.1 and 0.01; quick: 10⁶ and 10⁷ steps
over a 10× shorter span), each in its own subprocess, which reports getrusage's peak resident set size after
importing and compiling and after the run. Target: peak ≤ 300 MB, and the same for both step counts (the loop
keeps its state in scalars, streams the metrics and writes only the output grid and the turning points, two
per swing period whatever the step).
"""

from __future__ import annotations

from foucault_bench.bench.perf.measure import Row, run_probe

SECTION = "memory"
TARGET_MB = 300.0
TARGET_GROWTH_MB = 10.0
"""Allowance for allocator noise in 'the same for both step counts' (the buffers do not depend on it)."""
INTEGRATOR = "rk4"
MODEL = "linear"


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Peak RSS at two step counts; the rows, a detail table and its headers."""
    step_counts = (10**6, 10**7) if quick else (10**7, 10**8)
    span_kh = 0.1 * step_counts[0]
    headers = ["steps", "status", "RSS after import+compile MB", "peak RSS MB", "run s", "turning points"]
    rows, table, peaks = [], [], []
    for steps in step_counts:
        result = run_probe(["memory", INTEGRATOR, MODEL, str(steps), str(span_kh)])
        peaks.append(result["peak_mb"])
        table.append([f"{result['steps']:.0e}", result["status"], f"{result['before_mb']:.0f}",
                      f"{result['peak_mb']:.0f}", f"{result['run_s']:.2f}", result["turning_points"]])
        rows.append(Row(SECTION, f"{INTEGRATOR}/{MODEL}, {steps:.0e} steps, verdicts on: peak RSS", result["peak_mb"],
                        "MB", TARGET_MB, f"{result['before_mb']:.0f} MB before the run; {result['run_s']:.1f} s"))
    rows.append(Row(SECTION, f"peak RSS growth from {step_counts[0]:.0e} to {step_counts[1]:.0e} steps",
                    peaks[1] - peaks[0], "MB", TARGET_GROWTH_MB, "independent of the step count"))
    return rows, table, headers
