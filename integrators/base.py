"""The integrator interface: one small base class, a problem, a solution, counters kept by the framework.

How to add an integrator (integrators/README.md "Adding an integrator" has a worked example):

1. Write one module. A built-in goes into ``integrators/methods/NAME.py`` and is found by discovery:
   importing ``foucault_bench.integrators`` imports every module of ``methods`` (``integrators.registry``).
   A plug-in lives in its own package and is advertised under the entry-point group
   ``foucault_bench.integrators`` (or imported with a matrix's ``plugins = [...]`` or ``selftest --plugin``).
2. Subclass ``Integrator`` and implement ``_solve``, or subclass ``FixedStepIntegrator``
   (``integrators.fixed_step``) and implement only ``make_step(model)``, a compiled one-step map.
3. Declare the facts below as class attributes (``name``, ``family``, ``order``, ``stages``, ``adaptive``,
   ``stability_limit_kh``, ``reference``). They are data, not documentation: the tests derive their sweeps
   from them (order → step sizes and the expected slope, stability limit → the stability test), the report
   prints them, and ``register`` refuses a class whose facts are missing or malformed.
4. Decorate the class with ``@register`` (``integrators.registry``).
5. Run ``foucault-bench selftest NAME`` (``--plugin MODULE`` for a plug-in): it checks the declared order on
   every model, the declared stability limit, the counters, and that failures and divergences become rows.
6. A built-in only, required: its **registration line**, a row in integrators/README.md "The integrators"
   with the declared family, order, stages and stability limit (``tests/test_docs.py`` holds the table to the
   registry). An adaptive method's docstrings name its order, stability and tolerance mapping
   (``tests/test_adaptive.py``); they are in the new file. Nothing else is required: both built-in matrices
   sweep ``integrators = "built-in"``, every built-in but the reference (``bench.run.matrix_runs``), so it
   joins the main job and CI's quick matrix by itself, with the shared kh or tol sweep.
7. A built-in, recommended: bounds (``[[bound]]`` entries with their basis) in
   ``bench/thresholds/default.toml``: ``foucault-bench check`` judges the quick matrix that CI runs against
   them, and an integrator without one is judged by nothing (``check`` prints a note naming it; not a
   failure). If the shared sweep does not suit it, its own under ``[override.NAME]`` in
   ``bench/matrices/default.toml``.

The framework then

* validates the setting (a step size in s for fixed-step methods, a tolerance in (0, 1) for adaptive ones),
* turns every exception into a ``failed`` solution with the exception's message, and every non-finite
  state into a ``diverged`` one, so that no run crashes a benchmark matrix,
* fills ``nfev`` from ``stages × steps`` where the integrator does not count evaluations itself (the
  fixed-step and embedded Runge-Kutta loops count theirs: ``integrators.counting``, ``integrators.embedded_rk``),
* silences the C libraries' chatter on stdout/stderr (SUNDIALS prints its warnings there;
  ``silence_native_output``).

The base class follows SciPy's ``scipy/integrate/_ivp/base.py`` (``OdeSolver``): a few declared attributes,
one method to implement, the rest done once by the framework.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
import threading
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar, Iterator, TextIO

import numpy as np

from foucault_bench.models import Model, PendulumParameters

STATUS_OK = "ok"
STATUS_DIVERGED = "diverged"
STATUS_FAILED = "failed"

COST_COMPILED = "compiled"
COST_PYTHON_DRIVEN = "python-driven"
COST_BASES = (COST_COMPILED, COST_PYTHON_DRIVEN)
"""Values of ``Integrator.cost_basis``: how the timed call's cost arises (see there)."""


@dataclass(frozen=True, eq=False)
class Problem:
    """What to integrate: a model, its parameters, and the output times (s) from t = 0 to ``t_out[-1]``."""

    model: Model
    params: PendulumParameters
    t_out: np.ndarray

    def __post_init__(self) -> None:
        t_out = np.asarray(self.t_out, dtype=np.float64)
        if t_out.ndim != 1 or t_out.size < 2:
            raise ValueError("t_out must be a 1-D array of at least two output times (s)")
        if not np.all(np.isfinite(t_out)) or t_out[0] < 0 or np.any(np.diff(t_out) <= 0):
            raise ValueError("t_out must be finite, start at t >= 0 and increase strictly")
        object.__setattr__(self, "t_out", t_out)

    @property
    def t_end_s(self) -> float:
        return float(self.t_out[-1])

    @property
    def parameter_vector(self) -> np.ndarray:
        """``params.parameter_vector()``, computed once per problem (a run's repeats solve one problem); a fresh
        copy on every access, so that no integrator can change what the next one reads."""
        return self._parameter_vector.copy()

    @property
    def initial_state(self) -> np.ndarray:
        """``params.initial_state()``, computed once per problem; a fresh copy on every access."""
        return self._initial_state.copy()

    @functools.cached_property
    def _parameter_vector(self) -> np.ndarray:
        return self.params.parameter_vector()

    @functools.cached_property
    def _initial_state(self) -> np.ndarray:
        return self.params.initial_state()


@dataclass
class StreamedMetrics:
    """Verdict ingredients computed during the run, without storing the steps.

    Attributes:
        turning_points: array (n, 3) of (t in s, x in m, y in m) at each maximum of the radius (t > 0).
        energy_max_rel_error: max over all steps of |E(t) − E(0)| / (E(0) − E_rest) (E from ``Model.energy``,
            E_rest its value for the bob at rest at the bottom; |E(0)| if that difference is not positive);
            ``None`` where the integrator does not stream it (adaptive libraries).
        energy_drift_per_s: least-squares slope (1/s) of the same relative error against t over all steps;
            ``None`` where not streamed.
    """

    turning_points: np.ndarray
    energy_max_rel_error: float | None = None
    energy_drift_per_s: float | None = None


@dataclass
class Solution:
    """The state on the output grid plus counters, status and message.

    ``y`` has shape (len(t), 4) with columns (x, y, ẋ, ẏ) in m and m/s; rows after a divergence or failure are
    NaN. Counters are ``None`` where the integrator or library does not report them.
    """

    t: np.ndarray
    y: np.ndarray
    status: str = STATUS_OK
    message: str = ""
    nfev: int | None = None
    njev: int | None = None
    steps: int | None = None
    rejected_steps: int | None = None
    step_size_s: float | None = None
    tolerance: float | None = None
    streamed: StreamedMetrics | None = None
    extra: dict = field(default_factory=dict)

    @classmethod
    def failure(cls, t: np.ndarray, message: str, status: str = STATUS_FAILED) -> "Solution":
        return cls(t=t, y=np.full((t.size, 4), np.nan), status=status, message=message)


class Integrator(ABC):
    """Base class of every integrator.

    Class attributes each integrator declares (checked by ``register``, read by tests, selftest and reports):
        name: registry key, an identifier, e.g. ``"rk4"``.
        family: grouping for colours and thresholds, e.g. ``"runge-kutta"``; a new family is allowed.
        order: classical order of accuracy p (global error ∝ hᵖ), a positive integer; ``None`` where it varies
            (variable-order multistep, Taylor). For a fixed-step method the tests and ``selftest`` measure it.
        stages: right-hand-side evaluations per step for fixed-step schemes, on the linear model (on a model
            with a velocity-dependent force other than Coriolis a splitting method evaluates more). A
            ``FixedStepIntegrator`` counts its evaluations and reports ``nfev`` = count × steps
            (``integrators.counting``); ``selftest`` fails a scheme whose count on the linear model is not
            ``stages``. Other integrators get ``nfev = stages × steps`` from it unless they count. ``None`` for
            adaptive ones, and for a fixed-step scheme whose evaluations vary per step (an implicit method
            iterated to convergence), which then reports its own ``nfev`` or none.
        adaptive: ``True`` if driven by a tolerance, ``False`` if by a step size.
        stability_limit_kh: largest stable k·h on the undamped oscillator ẍ = −k²x (no rotation), for
            fixed-step methods; ``None`` if unstable for every h > 0 (explicit Euler) or not applicable
            (adaptive). The tests and ``selftest`` check bounded just below and diverged just above it.
        symplectic: the one-step map is symplectic in the canonical variables (r, p = v + ω×r) of a Hamiltonian
            model (checked on the linear model by the test suite: Mᵀ J M = J).
        volume_preserving: the one-step map preserves phase-space volume (det M = 1); implied by ``symplectic``.
        conserves_quadratic_invariants: every quadratic invariant of the system is an exact invariant of the
            one-step map (symplectic Runge–Kutta methods; Hairer, Lubich & Wanner, Thm. IV.2.2), e.g. the linear
            model's energy, kept to round-off.
        cost_basis: how the measured cost arises: ``"compiled"`` when the whole integration runs in compiled
            code (no Python call per step or per right-hand-side evaluation), ``"python-driven"`` when a Python
            loop or Python callbacks drive the library (the cost then includes the interpreter's overhead per
            step or evaluation); ``None`` where an integrator does not declare it. The report says it per
            integrator next to the cost charts.
        streams_step_metrics: ``True`` if ``solve(monitor=True)`` streams verdict ingredients that the output
            grid cannot give (``StreamedMetrics.energy_max_rel_error`` over every step). The runner times
            ``monitor=False`` calls for every integrator, so that the timed work is the same for all (integrate
            to the output grid), and makes one extra untimed ``monitor=True`` call only where this is ``True``
            (and the matrix keeps ``step_energy = true``, its default).
        silence_native_output: ``solve`` redirects the process's stdout and stderr while the integrator runs
            (``quiet_native_output``: a few µs per call), for libraries that print (SUNDIALS); ``False`` for
            one that reports only through return values.
        reference: where the method is described (book section or paper).

    ``rotation_growth_per_step`` says what rotation does to a method whose ``stability_limit_kh`` holds only
    without it.
    """

    name: ClassVar[str]
    family: ClassVar[str]
    order: ClassVar[int | None]
    stages: ClassVar[int | None] = None
    adaptive: ClassVar[bool]
    stability_limit_kh: ClassVar[float | None] = None
    symplectic: ClassVar[bool] = False
    volume_preserving: ClassVar[bool] = False
    conserves_quadratic_invariants: ClassVar[bool] = False
    reference: ClassVar[str]
    cost_basis: ClassVar[str | None] = None
    streams_step_metrics: ClassVar[bool] = False
    silence_native_output: ClassVar[bool] = True
    reports_non_finite_states: ClassVar[bool] = False
    """The library stops with a failure status at a non-finite state (heyoka's ``err_nf_state``), so a run
    that finishes ``ok`` needs no scan of its states for NaN (``finish``)."""

    def rotation_growth_per_step(self, kh: float, rate_ratio: float) -> float | None:
        """Per-step growth factor |λ|max of the amplitude on the linear model turning at the vertical rate
        a = ``rate_ratio``·k, for a method that is unstable at every h once the frame rotates; ``None`` (the
        default) where rotation only moves the stability limit by O(a/k)."""
        return None

    def fixed_step_method(self) -> "Integrator | None":
        """The same formula at fixed steps, for an adaptive method whose order is a property of its formula (the
        main method of an embedded pair; ``bench.gate.conformance`` measures its order that way), or ``None``
        (the default: no such formula, e.g. a variable-order method)."""
        return None

    def solve(self, problem: Problem, *, step_s: float | None = None, tol: float | None = None,
              monitor: bool = True) -> Solution:
        """Integrate ``problem``; never raises for a run that fails, only for a malformed request.

        Args:
            problem: model, parameters and output grid.
            step_s: step size in s (fixed-step integrators only).
            tol: relative (and scaled absolute) tolerance in (0, 1) (adaptive integrators only).
            monitor: compute streamed metrics (energy extrema, turning points) where the integrator can.
        """
        self.validate_setting(step_s=step_s, tol=tol)
        self.validate_problem(problem, step_s=step_s)
        try:
            if self.silence_native_output:
                with quiet_native_output():
                    solution = self._solve(problem, step_s=step_s, tol=tol, monitor=monitor)
            else:  # no context manager: a 0.1-ms heyoka solve notices its 0.6 µs
                solution = self._solve(problem, step_s=step_s, tol=tol, monitor=monitor)
        except Exception as exc:  # any library or numerical failure becomes a row, not a crash
            return Solution.failure(problem.t_out, f"{type(exc).__name__}: {exc}")
        return self.finish(solution, step_s=step_s, tol=tol)

    def finish(self, solution: Solution, *, step_s: float | None, tol: float | None) -> Solution:
        """What ``solve`` adds to ``_solve``'s solution (also applied to each member of a batch,
        ``integrators.batch``): a non-finite state marks it diverged, ``nfev`` from the declared stages when
        the scheme did not count it, the step and tolerance of the setting."""
        if solution.status == STATUS_OK and not self.reports_non_finite_states and not np.isfinite(solution.y).all():
            solution.status = STATUS_DIVERGED
            solution.message = solution.message or "state became non-finite"
        if solution.nfev is None and self.stages is not None and solution.steps is not None:
            solution.nfev = self.stages * solution.steps
        solution.step_size_s = solution.step_size_s if solution.step_size_s is not None else step_s
        solution.tolerance = tol
        return solution

    def validate_setting(self, *, step_s: float | None, tol: float | None) -> None:
        """Raise ``ValueError`` for a setting this integrator cannot take."""
        if self.adaptive:
            if step_s is not None:
                raise ValueError(f"{self.name} is adaptive: give a tolerance, not a step size")
            if tol is None or not (isinstance(tol, (int, float)) and 0.0 < tol < 1.0):
                raise ValueError(f"{self.name}: tolerance must lie in (0, 1), got {tol!r}")
        else:
            if tol is not None:
                raise ValueError(f"{self.name} is a fixed-step method: give a step size, not a tolerance")
            if step_s is None or not (isinstance(step_s, (int, float)) and math.isfinite(step_s) and step_s > 0):
                raise ValueError(f"{self.name}: step size must be a finite number > 0 s, got {step_s!r}")

    def validate_problem(self, problem: Problem, *, step_s: float | None) -> None:
        """Raise ``ValueError`` for a problem this integrator cannot take (e.g. an output grid it cannot hit)."""

    @abstractmethod
    def _solve(self, problem: Problem, *, step_s: float | None, tol: float | None, monitor: bool) -> Solution:
        """Integrate; may raise (the framework turns exceptions into ``failed`` solutions)."""

    def describe(self) -> dict:
        """The declared facts of this integrator as plain data."""
        return {
            "name": self.name,
            "family": self.family,
            "order": self.order,
            "stages": self.stages,
            "adaptive": self.adaptive,
            "stability_limit_kh": self.stability_limit_kh,
            "symplectic": self.symplectic,
            "volume_preserving": self.volume_preserving or self.symplectic,
            "conserves_quadratic_invariants": self.conserves_quadratic_invariants,
            "unstable_with_rotation": self.rotation_growth_per_step(1.0, 1e-4) is not None,
            "reference": self.reference,
            "cost_basis": self.cost_basis,
        }


_quiet_lock = threading.Lock()
_quiet_users = 0
_quiet_saved: list = []  # the Python streams and (fd, saved copy) pairs, restored by the last thread out


@contextlib.contextmanager
def quiet_native_output() -> Iterator[None]:
    """Silence everything printed for the duration, so that native libraries (SUNDIALS warnings, printed by C
    code or by a binding's Python error handler) do not write over the terminal or a progress bar: the
    process's stdout and stderr file descriptors (1 and 2, where C code writes whatever ``sys.stdout`` is) go
    to /dev/null, and so do ``sys.stdout`` and ``sys.stderr``. Python-level writes are flushed first; the
    descriptors are left alone when they are not open.

    Thread-safe: the descriptors and ``sys.stdout`` belong to the process, so when several threads solve at
    once (a Dask worker running tasks in threads) the first one in redirects them and the last one out
    restores them."""
    global _quiet_users
    with _quiet_lock:
        if _quiet_users == 0:
            for stream in {sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__}:
                if stream is not None:
                    stream.flush()
            sink = _devnull()
            streams = (sys.stdout, sys.stderr)
            sys.stdout = sys.stderr = sink
            try:
                for fd in (1, 2):
                    os.fstat(fd)
                descriptors = [(fd, os.dup(fd)) for fd in (1, 2)]
            except OSError:  # descriptors not open: only the Python streams are redirected
                descriptors = []
            for fd, _ in descriptors:
                os.dup2(sink.fileno(), fd)
            _quiet_saved[:] = [streams, descriptors]
        _quiet_users += 1
    try:
        yield
    finally:
        with _quiet_lock:
            _quiet_users -= 1
            if _quiet_users == 0:
                (sys.stdout, sys.stderr), descriptors = _quiet_saved
                for fd, saved in descriptors:
                    os.dup2(saved, fd)
                    os.close(saved)
                _quiet_saved.clear()


@functools.cache
def _devnull() -> TextIO:
    """/dev/null opened once per process for writing (``quiet_native_output`` runs around every solve)."""
    return open(os.devnull, "w")  # kept open for the life of the process
