"""Measurement tools shared by the perf sections: target rows, interleaved timing, subprocess probes, the machine.

Timing conventions (the developers' guide: warm-up excluded, repeats, median, compile time reported apart):

* ``interleaved`` calls each contender once untimed (warm-up: compilation, caches), then runs rounds in which
  every contender has one turn, in forward order in even rounds and reverse order in odd ones (so that
  running first or second favours nobody). A turn is a batch of calls lasting about ``ROUND_MIN_S``, each
  timed, and the batch's median is the contender's figure for the round: one call of 0.1 ms is at the mercy
  of a single interruption or cache flush by the neighbour's work, the median of 200 is not (a round of single
  calls made the heyoka adapter's ratio 1.21× in one run and 1.55× in the next). A ratio is taken within each
  round and the median of the per-round ratios is reported, so that a change of machine load between rounds
  (which moves both contenders of a round together) cancels out.
* Compute-bound code on one thread (loops, adapters) is timed with the thread's CPU time
  (``time.thread_time``): on a shared machine it leaves out the time the thread waits for a core, which
  wall-clock time would add at random. Whole commands (matrix runs) and multi-threaded work are timed by wall
  clock, which is what a user waits for.
* Cold and warm compilation run in subprocesses (``run_probe``), cold with fresh cache directories
  (``cache_environment``).
"""

from __future__ import annotations

import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

VERDICT_MET = "met"
VERDICT_MISSED = "missed"
VERDICT_INFO = "info"
VERDICT_SKIPPED = "skipped"
ROUND_MIN_S = 0.02
"""Length of one contender's batch in a round: 20 ms, long against the scheduler's interruptions of the
thread (a few ms at most on a loaded machine), short enough for tens of rounds per second."""
MAX_BATCH = 1000
RATIO_ROUNDS = 41
"""Rounds for a ratio that should repeat within ± 3 % from one run of ``foucault-bench perf`` to the next:
measured twice in two processes, 41 rounds of batched sub-millisecond calls repeated within ± 1.3 % and 15
rounds did not (bench/PERF.md "The perf harness's ratios run twice")."""


@dataclass(frozen=True)
class Row:
    """One line of the perf summary: a measured figure, its target (an upper bound) and the verdict.

    Attributes:
        section: the section that measured it (``foucault-bench perf --only SECTION``).
        name: what was measured.
        value: the figure, ``None`` when it could not be measured (``note`` says why).
        unit: unit of ``value`` and ``target`` (``"×"`` for ratios).
        target: the largest acceptable value; ``None`` for a figure reported without a target.
        note: how it was measured, or why it was skipped.
    """

    section: str
    name: str
    value: float | None
    unit: str
    target: float | None = None
    note: str = ""

    @property
    def verdict(self) -> str:
        if self.value is None:
            return VERDICT_SKIPPED
        if self.target is None:
            return VERDICT_INFO
        return VERDICT_MET if self.value <= self.target else VERDICT_MISSED

    def cells(self) -> list[str]:
        """The row as table cells: section, measurement, value, target, verdict, note."""
        value = "–" if self.value is None else f"{format_number(self.value)} {self.unit}".strip()
        target = "–" if self.target is None else f"≤ {format_number(self.target)} {self.unit}".strip()
        return [self.section, self.name, value, target, self.verdict, self.note]


ROW_HEADERS = ["section", "measurement", "value", "target", "verdict", "note"]


def format_number(value: float) -> str:
    """Three significant digits, without exponent for the usual range of timings and ratios."""
    if value == 0 or 1e-3 <= abs(value) < 1e5:
        return f"{value:.3g}" if abs(value) < 100 else f"{value:.0f}"
    return f"{value:.2e}"


def interleaved(calls: dict[str, Callable[[], Any]], rounds: int, clock: Callable[[], float] = time.thread_time,
                round_min_s: float = ROUND_MIN_S) -> dict[str, list[float]]:
    """Per-round cost (s per call) of each contender over ``rounds`` interleaved rounds (alternating order),
    after one untimed warm-up each: in every round each contender's turn is a batch of calls lasting about
    ``round_min_s`` (the batch size from a second untimed call, at most ``MAX_BATCH``), each call timed, and
    the batch's median is the round's figure (module docstring)."""
    batch: dict[str, int] = {}
    for name, call in calls.items():
        call()
        start = clock()
        call()
        batch[name] = max(1, min(MAX_BATCH, math.ceil(round_min_s / max(clock() - start, 1e-9))))
    durations: dict[str, list[float]] = {name: [] for name in calls}
    for round_number in range(rounds):
        order = list(calls.items())
        for name, call in order if round_number % 2 == 0 else reversed(order):
            batch_s = []
            for _ in range(batch[name]):
                start = clock()
                call()
                batch_s.append(clock() - start)
            durations[name].append(statistics.median(batch_s))
    return durations


def median_ratio(numerator: list[float], denominator: list[float]) -> float:
    """Median over rounds of the per-round ratio numerator/denominator (see the module docstring)."""
    return statistics.median(a / b for a, b in zip(numerator, denominator, strict=True))


def cache_environment(root: Path) -> dict[str, str]:
    """Environment variables pointing every compilation cache the suite uses into ``root``: numba's
    (NUMBA_CACHE_DIR), heyoka's (XDG_CACHE_HOME/heyoka, the default of ``llvm_state.get_diskcache_path``) and
    the reference solutions' (FOUCAULT_BENCH_CACHE, ``bench.problems.reference``). A fresh ``root`` gives a cold start."""
    return {
        "NUMBA_CACHE_DIR": str(root / "numba"),
        "XDG_CACHE_HOME": str(root / "xdg"),
        "FOUCAULT_BENCH_CACHE": str(root / "foucault-bench"),
    }


def run_probe(arguments: list[str], environment: dict[str, str] | None = None, timeout_s: float = 900.0) -> Any:
    """Run ``python -m bench.perf.probes ARGUMENTS`` in a fresh interpreter (with ``environment`` added to this
    one's) and return the JSON it prints on its last line of stdout."""
    command = [sys.executable, "-m", "foucault_bench.bench.perf.probes", *arguments]
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                          env={**os.environ, **(environment or {})})
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr.strip()[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def run_timed(command: list[str], environment: dict[str, str] | None = None,
              timeout_s: float = 3600.0) -> tuple[float, subprocess.CompletedProcess]:
    """Run ``command`` to completion; its wall time (s) and the completed process (output captured)."""
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                          env={**os.environ, **(environment or {})})
    return time.perf_counter() - start, done


def machine_description() -> dict[str, str]:
    """CPU model, core count, load average and library versions, for the report header."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    from importlib.metadata import version

    libraries = ", ".join(f"{name} {version(name)}" for name in ("numpy", "numba", "scipy", "heyoka", "scikit-sundae"))
    load = ", ".join(f"{value:.2f}" for value in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    return {
        "cpu": model,
        "cores": str(os.cpu_count()),
        "load average (1, 5, 15 min)": load,
        "python": platform.python_version(),
        "libraries": libraries,
    }
