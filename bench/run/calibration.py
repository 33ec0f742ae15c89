"""Machine-speed calibration: the CPU time of one fixed compiled loop, timed in the worker process itself.

A run's CPU time depends on the machine (clock rate, micro-architecture, a shared virtual machine's
neighbours). Every row stores ``calibration_cpu_s``, the median CPU time of ``CALIBRATION_REPEATS`` calls of a
fixed numba-compiled loop timed once in the same worker process (at its
warm-up, ``bench.run.worker.warm_up``, or at its first run), so that costs from two
machines (or two sessions of one) can be put on one scale: ``cpu_time_s / calibration_cpu_s``.

The loop (``_calibration_loop``) is a serial chain of ``CALIBRATION_ITERATIONS`` floating-point multiply-adds,
each depending on the one before (no vectorisation, no reassociation: numba compiles without fast-math), on
values that stay normal numbers (no subnormal slow path): its time is the core's floating-point latency times
the iterations, about 10 ms on a 3 GHz core. It is compiled once per machine (numba's disk cache).
"""

from __future__ import annotations

import functools
import statistics
import time

CALIBRATION_ITERATIONS = 5_000_000
CALIBRATION_REPEATS = 5


@functools.cache
def _compiled_loop():
    from numba import njit

    @njit(cache=True, nogil=True)
    def _calibration_loop(iterations: int) -> float:
        value = 0.5
        for _ in range(iterations):
            value = value * 0.999999 + 1.0e-6  # a contraction towards 1: stays in [0.5, 1]
        return value

    return _calibration_loop


@functools.cache
def calibration_cpu_s() -> float:
    """Median CPU time (s, this thread: ``time.thread_time``) of the calibration loop in this process; computed
    once per process (first call: compile or cache load, then the timed calls)."""
    loop = _compiled_loop()
    loop(1)  # compile or load from the cache, untimed
    durations = []
    for _ in range(CALIBRATION_REPEATS):
        start = time.thread_time()
        loop(CALIBRATION_ITERATIONS)
        durations.append(time.thread_time() - start)
    return statistics.median(durations)
