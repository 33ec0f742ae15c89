"""How the runner measures cost: the timing protocol, peak memory, and one thread per worker process.

This module imports only the standard library at load time, so that a freshly spawned worker can set the
thread-count environment variables *before* numpy, numba or heyoka are imported (OpenBLAS and numba read
them once, at import).

Timing protocol (``time_repeated``), the same for every integrator; it repeats a run until its cost is known
to a stated precision (defaults: ``TimingPolicy``):

1. one warm-up call; its result is the one the verdicts are computed from; or, when the caller gives a
   ``warm_up`` (1b; the runner does): that short call instead (the runner's: the same run over the scene's
   first output interval, which compiles or loads every function the run calls: numba's, CVODE's and
   heyoka's code is compiled per function and argument types, not per length of run), and the first timed
   repeat's result is the one the verdicts are computed from. A run then costs its repeats plus a fraction of
   one output interval, not one more whole run: runs longer than the cap on time (below), which are timed
   once, cost half as much;
2. timed repeats of the identical call. After each repeat the protocol stops as soon as

   * the 95 % confidence interval of the median CPU time is within ± ``target_ci95_rel`` (3 %) of the median
     (``median_ci95_rel``) and at least ``min_repeats`` repeats and ``min_total_s`` seconds of them are done, or
   * ``max_repeats`` repeats are done (the cap on repeats), or
   * the repeats' CPU time reached ``max_total_s`` (the cap on time; it overrides ``min_repeats``: a run that
     long is measured by one or a few repeats, and their precision is stored as not established when they are
     fewer than ``CI_MIN_REPEATS``), but never before ``min_total_s``.

   Every decision counts CPU time (below), so that the number of repeats does not depend on the machine's
   load. Runs whose repeats agree stop at the floor; short runs with a wider spread get more repeats;
3. the cost figures are the median of the repeats, their spread (max − min) and, for CPU time, the relative
   half-width of the 95 % confidence interval of the median (``None`` below ``CI_MIN_REPEATS`` repeats) and the
   repeats' CPU times themselves (what a rank test between two runs needs); the compile time is
   ``warm-up − median`` in CPU time (JIT compilation or a disk-cache load; clipped at 0 because a warm-up that
   compiles nothing can be faster than the median), or with a ``warm_up`` call (1b) that call's CPU time
   (compilation or cache load, plus one output interval's integration). CPU time, not wall time: on a loaded machine the warm-up's
   wall time is mostly waiting for a core (seen: 59 s of "compile" over 4 runs at load average 21).
4. a calibration (optional, ``calibrate``: the runner's is ``bench.run.calibration``), a fixed compiled
   workload timed in chunks between the repeats: after the first repeat and after each later one while the
   chunks have cost less than ``calibration_share`` of the repeats. The run's cost relative to it is measured
   under the same load as the run, which is what comparing two runs needs (``bench.history.changes``).

**The confidence interval** (``median_ci95``) is the distribution-free order-statistic interval of the median:
for n sorted repeats x₍₁₎ ≤ … ≤ x₍ₙ₎ it is [x₍ₖ₎, x₍ₙ₊₁₋ₖ₎] with the largest k such that
2 · P(B ≤ k − 1) ≤ 0.05, B ~ Binomial(n, ½); its coverage 1 − 2 · P(B ≤ k − 1) ≥ 95 % holds for any continuous
distribution of the repeats (W. J. Conover, *Practical Nonparametric Statistics*, 3rd ed., Wiley 1999,
§3.2, "confidence interval for a quantile"; the same interval as ``scipy.stats.quantile_test(...).confidence_interval``
with p = ½). It exists from n = 6 repeats on (``CI_MIN_REPEATS``: with 5, [x₍₁₎, x₍₅₎] covers only
1 − 2/32 = 93.75 %). Its relative half-width is (x₍ₙ₊₁₋ₖ₎ − x₍ₖ₎) / (2 · median). The repeats of one run are
taken as independent draws of its cost (no trend); a machine whose speed drifts during a run breaks that
assumption, which is why the repeats are stored with the row.

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

import math
import os
import resource
import statistics
import sys
import time
from dataclasses import dataclass
from typing import Callable, Sequence, TypeVar

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

CI_LEVEL = 0.95
"""Confidence level of the interval of the median (``median_ci95``)."""
CI_MIN_REPEATS = 6
"""The fewest repeats whose order-statistic interval [min, max] covers the median with ≥ 95 %: 1 − 2 · 2⁻⁶."""

Result = TypeVar("Result")


@dataclass(frozen=True)
class TimingPolicy:
    """How many timed repeats to make (see the module docstring for the protocol)."""

    min_repeats: int = CI_MIN_REPEATS
    max_repeats: int = 40
    target_ci95_rel: float = 0.03
    min_total_s: float = 0.0
    max_total_s: float = 0.1

    def problems(self) -> list[str]:
        """Every inconsistency in the policy, one message each (empty when valid)."""
        found = []
        if not 1 <= self.min_repeats <= self.max_repeats:
            found.append(f"timing: need 1 <= min_repeats <= max_repeats, got {self.min_repeats} and {self.max_repeats}")
        if not self.target_ci95_rel > 0:
            found.append(f"timing: target_ci95_rel must be > 0, got {self.target_ci95_rel!r}")
        if not self.min_total_s >= 0:
            found.append(f"timing: min_total_s must be >= 0 s, got {self.min_total_s!r}")
        if not self.max_total_s > 0:
            found.append(f"timing: max_total_s must be > 0 s, got {self.max_total_s!r}")
        return found


@dataclass(frozen=True)
class Timing:
    """Cost of one run: median and spread (max − min) of the timed repeats in wall time and in the thread's CPU
    time (s), the relative half-width of the 95 % CI of the CPU median (``None`` when not established), the
    repeats' CPU times (s), their count, and the compile time (s, CPU)."""

    median_s: float
    spread_s: float
    cpu_median_s: float
    cpu_spread_s: float
    cpu_ci95_rel: float | None
    cpu_repeats_s: tuple[float, ...]
    repeats: int
    compile_s: float
    calibration_chunks_s: tuple[float, ...] = ()


def median_ci95(samples: Sequence[float]) -> tuple[float, float] | None:
    """The distribution-free 95 % confidence interval of the median of ``samples`` (the module docstring:
    order statistics, Conover 1999 §3.2), or ``None`` for fewer than ``CI_MIN_REPEATS`` samples."""
    n = len(samples)
    if n < CI_MIN_REPEATS:
        return None
    from scipy.stats import binom

    alpha_half = (1.0 - CI_LEVEL) / 2.0
    # k: the largest with P(B <= k - 1) <= alpha/2, B ~ Binomial(n, 1/2), for the interval [x_(k), x_(n+1-k)]
    # (1-based); scipy's binomial distribution, so that thousands of repeats of a fast run do not overflow 2**n
    k = int(binom.ppf(alpha_half, n, 0.5))
    while k > 0 and binom.cdf(k - 1, n, 0.5) > alpha_half:
        k -= 1
    while binom.cdf(k, n, 0.5) <= alpha_half:
        k += 1
    ordered = sorted(samples)
    return ordered[k - 1], ordered[n - k]


def median_ci95_rel(samples: Sequence[float]) -> float | None:
    """Relative half-width (upper − lower) / (2 · median) of ``median_ci95`` (``None`` where it does not exist,
    ``inf`` for a zero median with a nonzero width)."""
    interval = median_ci95(samples)
    if interval is None:
        return None
    width = interval[1] - interval[0]
    median = statistics.median(samples)
    return width / (2.0 * median) if median > 0 else (0.0 if width == 0 else math.inf)


def time_repeated(call: Callable[[], Result], policy: TimingPolicy,
                  accept: Callable[[Result], bool] = lambda result: True, *,
                  wall_clock: Callable[[], float] = time.perf_counter,
                  cpu_clock: Callable[[], float] = time.thread_time,
                  calibrate: Callable[[], float] | None = None,
                  calibration_share: float = 0.1,
                  warm_up: Callable[[], object] | None = None) -> tuple[Result, Result, Timing | None]:
    """Run ``call`` by the protocol of the module docstring.

    Returns the first result (the warm-up's, or with ``warm_up`` the first repeat's), the last repeat's result
    (the first when no repeat was made) and the timing; when ``accept(first result)`` is false (a failed or
    diverged run) no further repeat is made and the timing is ``None``. ``wall_clock`` and ``cpu_clock`` are
    the two clocks (seconds; a test passes fakes). ``calibrate`` (optional) times one chunk of a fixed workload
    and returns its CPU time: it is called after the first repeat and after every later one while the chunks
    so far cost less than ``calibration_share`` of the repeats (module docstring, rule 4); it never counts in
    the repeats. ``warm_up`` (optional, rule 1b): a short call that compiles or loads what ``call`` runs, made
    instead of the warm-up call.
    """
    cpu_start = cpu_clock()
    first: Result | None = None
    if warm_up is None:
        first = call()
        warm_up_cpu_s = cpu_clock() - cpu_start
        if not accept(first):
            return first, first, None
    else:
        warm_up()
        warm_up_cpu_s = cpu_clock() - cpu_start
    durations: list[float] = []
    cpu_durations: list[float] = []
    chunks: list[float] = []
    while True:
        start, cpu_start = wall_clock(), cpu_clock()
        last = call()
        cpu_durations.append(cpu_clock() - cpu_start)
        durations.append(wall_clock() - start)
        if first is None:  # with ``warm_up``: the first repeat's result is the run's
            first = last
            if not accept(first):
                return first, first, None
        if calibrate is not None and (not chunks or math.fsum(chunks) < calibration_share * math.fsum(cpu_durations)):
            chunks.append(calibrate())
        if stop_repeating(cpu_durations, policy):
            break
    cpu_median_s = statistics.median(cpu_durations)
    assert first is not None  # set by the warm-up or the first repeat
    return first, last, Timing(
        median_s=statistics.median(durations),
        spread_s=max(durations) - min(durations),
        cpu_median_s=cpu_median_s,
        cpu_spread_s=max(cpu_durations) - min(cpu_durations),
        cpu_ci95_rel=median_ci95_rel(cpu_durations),
        cpu_repeats_s=tuple(cpu_durations),
        repeats=len(durations),
        compile_s=warm_up_cpu_s if warm_up is not None else max(0.0, warm_up_cpu_s - cpu_median_s),
        calibration_chunks_s=tuple(chunks),
    )


def stop_repeating(cpu_durations_s: Sequence[float], policy: TimingPolicy) -> bool:
    """Whether the repeats so far (their CPU times, s) end the timing (the module docstring's rule 2)."""
    count, total_s = len(cpu_durations_s), math.fsum(cpu_durations_s)
    if total_s < policy.min_total_s:
        return count >= policy.max_repeats
    if count >= policy.max_repeats or total_s >= policy.max_total_s:
        return True
    if count < policy.min_repeats:
        return False
    precision = median_ci95_rel(cpu_durations_s)
    return precision is not None and precision <= policy.target_ci95_rel


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
