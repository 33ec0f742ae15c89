"""Section ``compile``: cold and warm compile time of every registered integrator.

Each integrator runs ``bench.perf.probes compile`` twice in subprocesses sharing one fresh cache root
(``measure.cache_environment``): the first finds numba's and heyoka's disk caches empty (cold: everything it
needs is compiled, nothing is shared with other integrators), the second finds them filled (warm: what a
second ``foucault-bench run`` pays). Reported per integrator: the compile time summed over the models
(first ``solve`` minus a repeated one) and the interpreter's import time of the suite. Figures without a
target; the target on compile-once is in section ``matrices`` (second quick-matrix run ≤ 30 % of the first).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from foucault_bench.bench.perf.measure import Row, cache_environment, run_probe
from foucault_bench.integrators import REGISTRY
from foucault_bench.models import MODELS

SECTION = "compile"


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Cold and warm compile time per integrator; the rows, a detail table and its headers."""
    models = ["linear"] if quick else list(MODELS)
    headers = ["integrator", "models", "cold compile s", "warm compile s", "warm / cold", "import s (warm)", "status"]
    rows, table = [], []
    for name in sorted(REGISTRY):
        with tempfile.TemporaryDirectory(prefix="foucault-perf-compile-") as root:
            environment = cache_environment(Path(root))
            cold = run_probe(["compile", name, *models], environment)
            warm = run_probe(["compile", name, *models], environment)
        cold_s = sum(entry["compile_s"] for entry in cold["models"])
        warm_s = sum(entry["compile_s"] for entry in warm["models"])
        statuses = sorted({entry["status"] for entry in cold["models"] + warm["models"]})
        table.append([name, str(len(models)), f"{cold_s:.2f}", f"{warm_s:.2f}",
                      f"{warm_s / cold_s:.2f}" if cold_s else "–",
                      f"{warm['import_s']:.2f}", ",".join(statuses)])
        rows.append(Row(SECTION, f"{name}: compile cold ({len(models)} model(s))", cold_s, "s",
                        note=f"warm {warm_s:.2f} s, import {warm['import_s']:.2f} s"))
    return rows, table, headers
