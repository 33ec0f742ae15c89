"""Machine-speed calibration: the CPU time of one fixed compiled loop, timed beside each run's repeats.

A run's CPU time depends on the machine (clock rate, micro-architecture, a shared virtual machine's
neighbours, what the other core is doing to the shared caches at that moment). Every timed row stores
``calibration_cpu_s``: the CPU time of ``CALIBRATION_ITERATIONS`` iterations of a fixed numba-compiled loop,
measured in chunks of ``CHUNK_ITERATIONS`` interleaved with the run's own timed repeats
(``bench.run.timing.time_repeated``: one after the first repeat, then one after a repeat while the chunks
have cost less than a tenth of the repeats), as the median chunk scaled to the whole loop. ``cpu_time_s / calibration_cpu_s`` is then the run's cost in units of the loop, measured under
the same conditions as the run itself, so that the machine's speed and its slow drifts under load cancel
(what ``bench.history.changes`` compares). Before, one calibration was timed per worker process: it did not
follow the load of each run (bench/PERF.md "Cost changes across revisions").

The loop (``_calibration_loop``) is a serial chain of multiply-adds, each depending on the one before (no
vectorisation, no reassociation: numba compiles without fast-math), on values that stay normal numbers (no
subnormal slow path): its time is the core's floating-point latency times the iterations, about 10 ms for
``CALIBRATION_ITERATIONS`` on a 3 GHz core, 1 ms per chunk. It is compiled once per machine (numba's disk
cache) and loaded by the worker's warm-up (``warm_calibration``), never inside a timed run.
"""

from __future__ import annotations

import functools
import statistics
import time
from typing import Sequence

CALIBRATION_ITERATIONS = 5_000_000
"""The loop's length that ``calibration_cpu_s`` is expressed in (the same scale as the rows stored before)."""
CHUNK_ITERATIONS = 500_000
"""One calibration chunk: about 1 ms, a tenth of the scale."""


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


def warm_calibration() -> None:
    """Compile the loop or load it from numba's cache (the worker's warm-up), untimed."""
    _compiled_loop()(1)


def calibration_chunk_cpu_s() -> float:
    """CPU time (s, this thread: ``time.thread_time``) of one chunk of the loop (``CHUNK_ITERATIONS``)."""
    loop = _compiled_loop()
    loop(1)  # loaded already after the warm-up; a no-op call keeps a cold first call out of the timing
    start = time.thread_time()
    loop(CHUNK_ITERATIONS)
    return time.thread_time() - start


def scaled_calibration_s(chunks_s: Sequence[float]) -> float:
    """The median of a run's chunk times (s) expressed for the whole loop (``CALIBRATION_ITERATIONS``)."""
    return statistics.median(chunks_s) * (CALIBRATION_ITERATIONS / CHUNK_ITERATIONS)
