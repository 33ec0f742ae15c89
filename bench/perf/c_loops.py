"""The plain C loops of ``loops.c``, compiled at benchmark time and called through ctypes.

``compile_c_loops()`` builds ``loops.c`` with the system C compiler (``$CC`` or ``cc``) into a temporary
directory and returns a ``CLoops`` handle, or raises ``CompilerMissing`` (the perf sections then print a
message and skip the comparison). Flags: ``-O3 -march=native -ffp-contract=off -fno-tree-vectorize``: the
instruction set numba targets (the host CPU); no fused multiply-add contraction (numba contracts none without
fastmath), so the C loop and the numba kernel round every operation the same way and compute the same states;
scalar code, as the brief asks (gcc's SLP vectorizer packs the four state variables into one vector register
and made the linear-model loops 1.3-2.6× slower on the AMD EPYC of bench/PERF.md).
"""

from __future__ import annotations

import ctypes
import importlib.resources
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

C_SOURCE = Path(str(importlib.resources.files("foucault_bench.bench.perf").joinpath("loops.c")))
"""The C loops (package data, found as every data file is: ``importlib.resources``)."""
C_FLAGS = ("-O3", "-march=native", "-ffp-contract=off", "-fno-tree-vectorize", "-fPIC", "-shared")
MODELS = ("linear", "spherical")
COMPOSITION_SCHEMES = ("composition8", "composition10")
"""The longer compositions, whose C loops are their own block at the end of loops.c: sequences of at most 9
sub-steps, as ``integrators.composition.SEQUENCE_SUB_STEPS`` takes them."""
SCHEMES = ("explicit_euler", "symplectic_euler", "rk4", "heun3", "nystrom4", "verlet", "yoshida4", "composition6",
           "boris", "implicit_midpoint", "gauss_legendre4", "gbs4") + COMPOSITION_SCHEMES
WITHOUT_C_REFERENCE: tuple[str, ...] = ()
"""Built-in fixed-step schemes whose loop has no C twin in loops.c yet (``perf`` cannot state their loop overhead):
none today; a new fixed-step scheme goes here until its C loop is written."""

_DOUBLE_P = ctypes.POINTER(ctypes.c_double)
_INT64_P = ctypes.POINTER(ctypes.c_int64)
_PLAIN_ARGS = [_DOUBLE_P, _DOUBLE_P, ctypes.c_double, ctypes.c_int64, ctypes.c_int64, _DOUBLE_P, ctypes.c_double,
               _INT64_P]
_MONITOR_ARGS = _PLAIN_ARGS + [_DOUBLE_P, ctypes.c_int64, _INT64_P, _DOUBLE_P, _DOUBLE_P]


class CompilerMissing(RuntimeError):
    """No working C compiler: the C comparisons are skipped."""


@dataclass(frozen=True)
class CRunResult:
    """What one C loop returned: status (0 ok, 1 diverged), steps done and, when monitored, the streams."""

    status: int
    steps_done: int
    n_turning: int = 0
    max_rel: float = 0.0
    slope: float = 0.0


def _pointer(array: np.ndarray):
    if array.dtype != np.float64 or not array.flags.c_contiguous:
        raise ValueError("C loops take C-contiguous float64 arrays")
    return array.ctypes.data_as(_DOUBLE_P)


class CLoops:
    """The compiled library: one plain and one monitored loop per (model, scheme)."""

    def __init__(self, library_path: Path, compiler: str) -> None:
        self.library = ctypes.CDLL(str(library_path))
        self.compiler = compiler
        self.path = library_path
        for model in MODELS:
            for scheme in SCHEMES:
                self._function(model, scheme, False).argtypes = _PLAIN_ARGS
                self._function(model, scheme, True).argtypes = _MONITOR_ARGS
                self._function(model, scheme, False).restype = ctypes.c_int
                self._function(model, scheme, True).restype = ctypes.c_int

    def _function(self, model: str, scheme: str, monitor: bool):
        return getattr(self.library, f"fb_{model}_{scheme}{'_monitor' if monitor else ''}")

    def run(self, model: str, scheme: str, state0: np.ndarray, p: np.ndarray, h: float, n_steps: int,
            stride: int, out: np.ndarray, radius_bound: float, monitor: bool = False,
            turning: np.ndarray | None = None) -> CRunResult:
        """Run the C loop with the numba kernel's arguments (``integrators.fixed_step.build_kernel``)."""
        if out.shape != (n_steps // stride + 1, 4):
            raise ValueError(f"out must have shape ({n_steps // stride + 1}, 4), got {out.shape}")
        steps_done = ctypes.c_int64(0)
        args = [_pointer(state0), _pointer(p), h, n_steps, stride, _pointer(out), radius_bound,
                ctypes.byref(steps_done)]
        if not monitor:
            status = self._function(model, scheme, False)(*args)
            return CRunResult(status=status, steps_done=steps_done.value)
        turning = np.empty((0, 3)) if turning is None else turning
        n_turning, max_rel, slope = ctypes.c_int64(0), ctypes.c_double(0.0), ctypes.c_double(0.0)
        status = self._function(model, scheme, True)(
            *args, _pointer(turning), turning.shape[0], ctypes.byref(n_turning), ctypes.byref(max_rel),
            ctypes.byref(slope),
        )
        return CRunResult(status=status, steps_done=steps_done.value, n_turning=n_turning.value,
                          max_rel=max_rel.value, slope=slope.value)


def find_compiler() -> str | None:
    """``$CC`` if set, else ``cc``, as a full path; ``None`` if not found."""
    return shutil.which(os.environ.get("CC", "cc"))


def compile_c_loops(directory: Path | None = None) -> CLoops:
    """Compile ``loops.c`` into ``directory`` (a fresh temporary directory by default) and load it."""
    compiler = find_compiler()
    if compiler is None:
        raise CompilerMissing(f"no C compiler found ({os.environ.get('CC', 'cc')!r} is not on PATH)")
    directory = Path(tempfile.mkdtemp(prefix="foucault-perf-")) if directory is None else directory
    library = directory / "fb_loops.so"
    command = [compiler, *C_FLAGS, "-o", str(library), str(C_SOURCE), "-lm"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CompilerMissing(f"{' '.join(command)} failed:\n{done.stderr.strip()}")
    return CLoops(library, compiler)
