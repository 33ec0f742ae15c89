"""How the runner measures cost: the timing protocol, peak memory, and one thread per worker process.

This module imports only the standard library at load time, so that a freshly spawned worker can set the
thread-count environment variables *before* numpy, numba or heyoka are imported (OpenBLAS and numba read
them once, at import).

Timing protocol (``time_repeated``), the same for every integrator (defaults: ``TimingPolicy``, at least
3 repeats and 0.5 s, at most 20, a single repeat after a warm-up over 1 s):

1. one warm-up call; its result is the one the verdicts are computed from;
2. timed repeats of the identical call until at least ``min_repeats`` repeats *and* ``min_total_s`` seconds
   of repeats are done, stopping at ``max_repeats`` (whatever ``min_repeats`` is: with ``min_repeats = 1`` a
   fast run is still repeated until ``min_total_s`` is spent); when the warm-up call alone took longer than
   ``single_repeat_over_s`` a single timed repeat is made (a run that long is already a stable figure, and
   three repeats of the slowest library runs would take most of the default matrix's budget). Both
   decisions count CPU time (below), so that the number of repeats does not depend on the machine's load;
   with a single repeat the spread is 0 (nothing to compare it with);
3. the cost figures are the median of the repeats and their spread (max − min), each for two clocks, and
   the compile time ``warm-up − median`` in wall time (JIT compilation or numba cache load; clipped at 0
   because a warm-up that compiles nothing can be faster than the median on a noisy machine).

Two clocks are read around every timed call:

* **CPU time** (``time.thread_time``: the CPU time of the calling thread, system and user; Python docs,
  ``time.thread_time``, CLOCK_THREAD_CPUTIME_ID on Linux). It counts only the time the thread computed, not
  the time it waited for a core, so it does not depend on the machine's load or on how many runs share the
  cores (``--jobs``). Every integrator computes on the calling thread (the worker's native thread pools are
  capped at one thread, ``limit_threads``), which is what makes this the run's whole cost; on a Dask worker
  that runs tasks in threads it is still that task's own thread. This is the cost the reports use.
* **Wall time** (``time.perf_counter``: the highest-resolution monotonic clock): what a user waits for,
  CPU time plus waiting; it grows when the machine is loaded.
"""

from __future__ import annotations

import os
import resource
import statistics
import sys
import time
from dataclasses import dataclass
from typing import Callable, TypeVar

THREAD_ENVIRONMENT: dict[str, str] = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "BLIS_NUM_THREADS": "1",
    "VECLIB_MAXIMUM_THREADS": "1",
    "NUMEXPR_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}
"""Environment that caps every native thread pool a worker may load at one thread (numba: its docs,
"Environment variables", NUMBA_NUM_THREADS; OpenBLAS/OpenMP/MKL: their documented variables)."""

Result = TypeVar("Result")


@dataclass(frozen=True)
class TimingPolicy:
    """How many timed repeats to make (see the module docstring for the protocol)."""

    min_repeats: int = 3
    min_total_s: float = 0.5
    max_repeats: int = 20
    single_repeat_over_s: float = 1.0

    def problems(self) -> list[str]:
        """Every inconsistency in the policy, one message each (empty when valid)."""
        found = []
        if not 1 <= self.min_repeats <= self.max_repeats:
            found.append(f"timing: need 1 <= min_repeats <= max_repeats, got {self.min_repeats} and {self.max_repeats}")
        if not self.min_total_s >= 0:
            found.append(f"timing: min_total_s must be >= 0 s, got {self.min_total_s!r}")
        if not self.single_repeat_over_s > 0:
            found.append(f"timing: single_repeat_over_s must be > 0 s, got {self.single_repeat_over_s!r}")
        return found


@dataclass(frozen=True)
class Timing:
    """Cost of one run: median and spread (max − min) of the timed repeats in wall time and in the thread's CPU
    time (s), their count, and the compile time (s, wall)."""

    median_s: float
    spread_s: float
    cpu_median_s: float
    cpu_spread_s: float
    repeats: int
    compile_s: float


def time_repeated(call: Callable[[], Result], policy: TimingPolicy,
                  accept: Callable[[Result], bool] = lambda result: True, *,
                  wall_clock: Callable[[], float] = time.perf_counter,
                  cpu_clock: Callable[[], float] = time.thread_time) -> tuple[Result, Result, Timing | None]:
    """Run ``call`` by the protocol of the module docstring.

    Returns the warm-up result, the last repeat's result (the warm-up's when no repeat was made) and the
    timing; when ``accept(warm-up result)`` is false (a failed or diverged run) no repeat is made and the
    timing is ``None``. ``wall_clock`` and ``cpu_clock`` are the two clocks (seconds; a test passes fakes).
    """
    start, cpu_start = wall_clock(), cpu_clock()
    first = call()
    warm_up_cpu_s = cpu_clock() - cpu_start
    warm_up_s = wall_clock() - start
    if not accept(first):
        return first, first, None
    single = warm_up_cpu_s > policy.single_repeat_over_s
    durations: list[float] = []
    cpu_durations: list[float] = []
    last = first

    def more_wanted() -> bool:
        if single:
            return not durations
        if len(durations) < policy.min_repeats:
            return True
        return sum(cpu_durations) < policy.min_total_s and len(durations) < policy.max_repeats

    while more_wanted():
        start, cpu_start = wall_clock(), cpu_clock()
        last = call()
        cpu_durations.append(cpu_clock() - cpu_start)
        durations.append(wall_clock() - start)
    median = statistics.median(durations)
    return first, last, Timing(
        median_s=median,
        spread_s=max(durations) - min(durations),
        cpu_median_s=statistics.median(cpu_durations),
        cpu_spread_s=max(cpu_durations) - min(cpu_durations),
        repeats=len(durations),
        compile_s=max(0.0, warm_up_s - median),
    )


def peak_rss_mb() -> float:
    """Peak resident set size of this process so far, MB (getrusage(2): ru_maxrss is KiB on Linux, bytes on
    macOS)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024.0 * 1024.0) if sys.platform == "darwin" else peak / 1024.0


def limit_threads() -> None:
    """Make this process single-threaded in every native library: set ``THREAD_ENVIRONMENT`` (effective for
    libraries not imported yet) and, for those already imported, numba's ``set_num_threads(1)`` and
    heyoka's ``set_nthreads(1)`` (its TBB pool used by parallel modes and ensemble propagation).

    Used as the worker-process initializer, before the worker imports anything heavy, and again at the start
    of every task (a Dask worker has imported numba before it runs the first task). Once numba is imported its
    variable is left alone: numba re-reads its environment and refuses a changed thread count after its
    thread pool started.
    """
    numba_imported = "numba" in sys.modules
    os.environ.update({name: value for name, value in THREAD_ENVIRONMENT.items()
                       if not (numba_imported and name == "NUMBA_NUM_THREADS")})
    if numba_imported:
        sys.modules["numba"].set_num_threads(1)
    if "heyoka" in sys.modules:
        sys.modules["heyoka"].set_nthreads(1)
