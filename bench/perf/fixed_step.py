"""Section ``loops``: the fixed-step loops against the hardware.

For every fixed-step scheme (``c_loops.SCHEMES``) on the linear and the spherical model, the cost per step
of the suite's compiled loop (``FixedStepIntegrator.kernel``, the one ``solve`` runs) with verdicts off
(``monitor=False``) and on (streamed energy error, drift slope and turning points), against the plain scalar C
loop of the same scheme (``loops.c``: the model arithmetic of the suite, the scheme and loop as a C programmer
writes them for speed, e.g. the sphere Verlet's rotation as a precomputed 3×3 matrix, a composition's merged
rotations between its sub-steps). Targets: ≤ 1.05× the
C loop with verdicts off (what the runner times: ``monitor=False``), ≤ 1.5× with verdicts on. The C loop with
the same streaming (``_monitor`` in ``loops.c``) is shown too: it separates what the streaming arithmetic
costs on the hardware from what numba adds.

Before timing, each pair is checked to compute the same states to round-off, and the table says whether they
are bitwise identical (they are with gcc 12 on x86-64; ``tests/test_perf_harness.py`` checks round-off). Setting: the Panthéon pendulum (L = 67 m, 3 m
amplitude, 48.8° N) with k·h = 5·10⁻⁴, so that even explicit Euler stays bounded over every timed run (its
energy grows by (1 + (kh)²) per step); the cost per step does not depend on h. The state is written out every
``STRIDE`` steps, as on a scene's output grid.
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass
from typing import cast

import numpy as np

from foucault_bench.bench.perf.c_loops import MODELS, SCHEMES, CLoops, CompilerMissing, compile_c_loops
from foucault_bench.bench.perf.measure import Row, interleaved, median_ratio
from foucault_bench.integrators import FixedStepIntegrator, get_integrator
from foucault_bench.models import MODELS as MODEL_REGISTRY
from foucault_bench.models import PendulumParameters

SECTION = "loops"
TARGET_OFF = 1.05
TARGET_ON = 1.5
KH = 5.0e-4
STRIDE = 1000
PARAMS = PendulumParameters(length_m=67.0, latitude_deg=48.846, amplitude_m=3.0)
RADIUS_BOUND = 1.0e3 * PARAMS.length_m


@dataclass(frozen=True)
class LoopCost:
    """Median cost per step (ns) of the four loops and the median per-round ratios to the plain C loop."""

    model: str
    scheme: str
    steps: int
    c_ns: float
    c_monitor_ns: float
    numba_ns: float
    numba_monitor_ns: float
    off_ratio: float
    on_ratio: float
    c_monitor_ratio: float
    bitwise: bool


class LoopPair:
    """One (model, scheme): the numba kernel and the C loops with their arguments, for ``n_steps`` steps."""

    def __init__(self, c_loops: CLoops, model: str, scheme: str, n_steps: int) -> None:
        self.c_loops, self.model, self.scheme, self.n_steps = c_loops, model, scheme, n_steps
        self.kernel = cast(FixedStepIntegrator, get_integrator(scheme)).kernel(MODEL_REGISTRY[model])
        self.state0 = PARAMS.initial_state()
        self.p = PARAMS.parameter_vector()
        self.h = KH / PARAMS.pendulum_frequency_rad_s
        self.out = np.full((n_steps // STRIDE + 1, 4), np.nan)
        self.turning = np.empty((int(n_steps * KH / np.pi) + 16, 3))

    def numba(self, monitor: bool) -> tuple:
        return self.kernel(self.state0, self.p, self.h, self.n_steps, STRIDE, self.out, monitor, self.turning,
                           RADIUS_BOUND)

    def c(self, monitor: bool):
        return self.c_loops.run(self.model, self.scheme, self.state0, self.p, self.h, self.n_steps, STRIDE,
                                self.out, RADIUS_BOUND, monitor=monitor, turning=self.turning)

    def check_same_states(self) -> bool:
        """Raise ``AssertionError`` unless both loops, monitored, give the same states and streams to round-off;
        return whether they are bitwise identical (states, turning points, energy error and slope)."""
        status, steps, n_turning, max_rel, slope = self.numba(True)
        numba_out, numba_turning = self.out.copy(), self.turning[:n_turning].copy()
        result = self.c(True)
        assert status == result.status == 0 and steps == result.steps_done == self.n_steps, (status, result)
        scale = np.max(np.abs(numba_out), axis=0)
        assert np.all(np.abs(numba_out - self.out) <= 1e-12 * scale), f"{self.model}/{self.scheme}: states differ"
        assert n_turning == result.n_turning, (n_turning, result.n_turning)
        assert np.allclose(numba_turning, self.turning[:n_turning], rtol=1e-12, atol=0.0)
        assert np.isclose(max_rel, result.max_rel, rtol=1e-9, atol=1e-300)
        assert np.isclose(slope, result.slope, rtol=1e-9, atol=1e-300)
        return (numba_out.tobytes() == self.out.tobytes() and numba_turning.tobytes()
                == self.turning[:n_turning].tobytes() and max_rel == result.max_rel and slope == result.slope)


def steps_for(c_loops: CLoops, model: str, scheme: str, seconds: float, largest: int) -> int:
    """Steps (a multiple of ``STRIDE``) for which the C loop runs about ``seconds``, at most ``largest``."""
    probe = LoopPair(c_loops, model, scheme, 100 * STRIDE)
    probe.c(False)
    durations = interleaved({"c": lambda: probe.c(False)}, 3)["c"]
    per_step = max(min(durations) / probe.n_steps, 1e-10)
    return int(min(largest, max(10 * STRIDE, seconds / per_step)) // STRIDE * STRIDE)


def measure_pair(c_loops: CLoops, model: str, scheme: str, seconds: float, rounds: int) -> LoopCost:
    """Time the four loops of one (model, scheme), interleaved, after checking they agree."""
    n_steps = steps_for(c_loops, model, scheme, seconds, largest=10_000_000)
    pair = LoopPair(c_loops, model, scheme, n_steps)
    bitwise = pair.check_same_states()
    times = interleaved({
        "c": lambda: pair.c(False),
        "c_monitor": lambda: pair.c(True),
        "numba": lambda: pair.numba(False),
        "numba_monitor": lambda: pair.numba(True),
    }, rounds)
    per_step = {name: statistics.median(values) / n_steps * 1e9 for name, values in times.items()}
    return LoopCost(
        model=model, scheme=scheme, steps=n_steps,
        c_ns=per_step["c"], c_monitor_ns=per_step["c_monitor"], numba_ns=per_step["numba"],
        numba_monitor_ns=per_step["numba_monitor"],
        off_ratio=median_ratio(times["numba"], times["c"]),
        on_ratio=median_ratio(times["numba_monitor"], times["c"]),
        c_monitor_ratio=median_ratio(times["c_monitor"], times["c"]), bitwise=bitwise,
    )


def run(quick: bool) -> tuple[list[Row], list[list[str]], list[str]]:
    """Measure every (model, scheme); the target rows, a detail table and its headers."""
    headers = ["model", "scheme", "steps", "C ns/step", "C+verdicts ns/step", "numba off ns/step",
               "numba on ns/step", "off / C", "on / C", "C+verdicts / C", "bitwise"]
    try:
        c_loops = compile_c_loops()
    except CompilerMissing as missing:
        note = f"skipped: {missing}"
        return [Row(SECTION, f"{scheme}/{model}", None, "×", TARGET_OFF, note)
                for model in MODELS for scheme in SCHEMES], [], headers
    seconds, rounds = (0.02, 3) if quick else (0.1, 15)
    rows, table = [], []
    for model in MODELS:
        for scheme in SCHEMES:
            cost = measure_pair(c_loops, model, scheme, seconds, rounds)
            table.append([model, scheme, f"{cost.steps:.0e}", f"{cost.c_ns:.2f}", f"{cost.c_monitor_ns:.2f}",
                          f"{cost.numba_ns:.2f}", f"{cost.numba_monitor_ns:.2f}", f"{cost.off_ratio:.2f}",
                          f"{cost.on_ratio:.2f}", f"{cost.c_monitor_ratio:.2f}", "yes" if cost.bitwise else "no"])
            rows.append(Row(SECTION, f"{scheme}/{model}, verdicts off: numba / C", cost.off_ratio, "×", TARGET_OFF,
                            f"{cost.numba_ns:.1f} vs {cost.c_ns:.1f} ns/step; states "
                            f"{'bitwise identical' if cost.bitwise else 'equal to round-off'}"))
            rows.append(Row(SECTION, f"{scheme}/{model}, verdicts on: numba / C", cost.on_ratio, "×", TARGET_ON,
                            f"{cost.numba_monitor_ns:.1f} ns/step; same streaming in C: "
                            f"{cost.c_monitor_ratio:.2f}×"))
    return rows, table, headers
