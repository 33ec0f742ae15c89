"""SUNDIALS CVODE driven from compiled code: the shared libraries of scikit-sundae's wheel through ctypes,
right-hand side and Jacobian as numba ``cfunc`` callbacks, and a numba-compiled output loop.

**Libraries.** scikit-sundae's wheels bundle SUNDIALS as shared libraries next to the package
(``scikit_sundae.libs/`` on Linux and Windows, ``sksundae/.dylibs/`` on macOS). Two are used:
``sundials_core`` (context, generic vector/matrix/solver operations) and ``sundials_cvode``, which also
carries SUNDIALS' serial N_Vector, dense SUNMatrix and dense SUNLinearSolver modules (SUNDIALS user guide,
"Using SUNDIALS": each package library includes the serial and dense modules). The C types come from the
configuration scikit-sundae was compiled against (``sksundae._cy_common.config``): ``sunrealtype`` must be
double and ``sunindextype`` is declared with the width it names (``int`` = 32 bits in scikit-sundae 1.2).
``load_sundials`` raises ``SundialsUnavailable``, naming what is missing, when a library, a symbol or a
matching configuration is not found; ``Integrator.solve`` turns that into a ``failed`` row.

**Callbacks.** CVODE calls C functions with the signatures of ``CVRhsFn`` and ``CVLsJacFn`` (SUNDIALS CVODE
user guide, "User-supplied functions"). Each is a numba ``cfunc`` wrapping the model's compiled
``numba_rhs_into`` / ``numba_jacobian_into``: the state is read through ``N_VGetArrayPointer_Serial``, the
dense Jacobian written column-major through ``SUNDenseMatrix_Data`` (entry (i, j) at ``data[j·N + i]``), and
the parameter vector arrives as CVODE's ``user_data`` pointer. No Python runs during a solve.

**Output loop.** ``cvode_output_loop`` (numba, ``nogil``) calls ``CVode`` in ``CV_NORMAL`` mode once per
output time and copies the state, which lives in a numpy array the output N_Vector wraps (``N_VMake_Serial``).
Setup and teardown (about 25 ctypes calls) happen once per solve in Python, outside the loop.

numba binds the ctypes functions' addresses into the machine code, so the callbacks and the loop are
compiled once per process (not stored in numba's disk cache); ``Model.numba_rhs_into`` and
``Model.numba_jacobian_into`` themselves come from the disk cache.
"""

from __future__ import annotations

import ctypes
import functools
import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from foucault_bench.models import Model
from foucault_bench.models.jit import JIT_OPTIONS
from foucault_bench.models.parameters import PARAMETER_COUNT

STATE_SIZE = 4
SUNDIALS_MAJOR_VERSION = 7
LIBRARIES = ("sundials_core", "sundials_cvode")
CV_ADAMS, CV_BDF = 1, 2
CV_NORMAL = 1
SUN_COMM_NULL = 0
INDEX_TYPES = {"int": ctypes.c_int32, "int32_t": ctypes.c_int32, "long int": ctypes.c_int64,
               "long long int": ctypes.c_int64, "int64_t": ctypes.c_int64}
"""C spellings of ``sunindextype`` in SUNDIALS' configuration → ctypes type of that width."""

COUNTERS = ("CVodeGetNumSteps", "CVodeGetNumRhsEvals", "CVodeGetNumLinRhsEvals", "CVodeGetNumJacEvals",
            "CVodeGetNumErrTestFails", "CVodeGetNumNonlinSolvConvFails")
"""CVODE's optional outputs (``long int``) read after a solve (CVODE user guide, "Optional output functions")."""

CVODE_FLAGS = {
    -1: ("CV_TOO_MUCH_WORK", "took max_num_steps internal steps without reaching the next output time"),
    -2: ("CV_TOO_MUCH_ACC", "the requested accuracy cannot be reached (tolerance too small for double precision)"),
    -3: ("CV_ERR_FAILURE", "the error test failed repeatedly or with |h| = hmin"),
    -4: ("CV_CONV_FAILURE", "the corrector iteration failed to converge repeatedly or with |h| = hmin"),
    -5: ("CV_LINIT_FAIL", "the linear solver's initialisation failed"),
    -6: ("CV_LSETUP_FAIL", "the linear solver's setup failed"),
    -7: ("CV_LSOLVE_FAIL", "the linear solver's solve failed"),
    -8: ("CV_RHSFUNC_FAIL", "the right-hand side failed unrecoverably"),
    -9: ("CV_FIRST_RHSFUNC_ERR", "the right-hand side failed at the first call"),
    -10: ("CV_REPTD_RHSFUNC_ERR", "the right-hand side failed recoverably, repeatedly"),
    -11: ("CV_UNREC_RHSFUNC_ERR", "the right-hand side failed recoverably, without recovery"),
    -16: ("CV_NLS_FAIL", "the nonlinear solver failed"),
    -20: ("CV_MEM_FAIL", "a memory allocation failed"),
    -22: ("CV_ILL_INPUT", "an input to CVode was illegal"),
    -27: ("CV_TOO_CLOSE", "the output time is too close to the initial time"),
    -28: ("CV_VECTOROP_ERR", "a vector operation failed"),
}
"""CVODE's negative return flags: name and meaning (SUNDIALS ``cvode.h`` and CVODE user guide, "CVode" return
values)."""


class SundialsUnavailable(RuntimeError):
    """The SUNDIALS libraries cannot be used; the message names what is missing."""


def default_library_directories() -> list[Path]:
    """Where scikit-sundae's wheel puts its bundled SUNDIALS libraries (auditwheel/delvewheel, delocate)."""
    spec = importlib.util.find_spec("sksundae")
    if spec is None or spec.origin is None:
        return []
    package = Path(spec.origin).parent
    return [package.parent / "scikit_sundae.libs", package / ".dylibs"]


def find_library(name: str, directories: list[Path]) -> Path:
    """The shared library ``name`` (e.g. ``sundials_cvode``) in the first of ``directories`` that has it;
    wheel repair tools add a hash to the file name (``libsundials_cvode-cf29dc23.so.7.9.0``)."""
    for directory in directories:
        for pattern in (f"lib{name}-*.so*", f"lib{name}.so*", f"lib{name}*.dylib", f"{name}*.dll",
                        f"lib{name}*.dll"):
            matches = sorted(directory.glob(pattern))
            if matches:
                return matches[0]
    searched = ", ".join(str(d) for d in directories) or "(scikit-sundae is not installed)"
    raise SundialsUnavailable(f"SUNDIALS library {name!r} not found in {searched}: the compiled CVODE path needs "
                              "the shared libraries shipped in scikit-sundae's wheel "
                              "(pip install 'scikit-sundae>=1.2')")


def sundials_configuration() -> dict[str, str]:
    """The SUNDIALS configuration scikit-sundae was compiled against (version, real and index types)."""
    try:
        from sksundae._cy_common import config
    except ImportError as exc:
        raise SundialsUnavailable(f"cannot read scikit-sundae's SUNDIALS configuration: {exc}") from None
    return dict(config)


@dataclass(frozen=True, eq=False)
class Sundials:
    """The loaded SUNDIALS functions, with their C prototypes (SUNDIALS 7 API)."""

    directory: Path
    version: str
    index_type: type
    functions: dict[str, Callable]

    def __getattr__(self, name: str) -> Callable:
        try:
            return self.functions[name]
        except KeyError:
            raise AttributeError(name) from None


def _prototypes(index: type) -> dict[str, tuple]:
    """name → (restype, argtypes) of every function used; pointers are ``c_void_p`` except where numba reads
    through them (``POINTER(c_double)``) or calls the function with addresses held as pointer-sized integers
    (``c_ssize_t``: the calling conventions pass both in the same registers)."""
    void_p, double, c_int, c_long = ctypes.c_void_p, ctypes.c_double, ctypes.c_int, ctypes.c_long
    address = ctypes.c_ssize_t
    return {
        "SUNContext_Create": (c_int, [c_int, ctypes.POINTER(void_p)]),
        "SUNContext_Free": (c_int, [ctypes.POINTER(void_p)]),
        "N_VMake_Serial": (void_p, [index, void_p, void_p]),
        "N_VGetArrayPointer_Serial": (ctypes.POINTER(double), [void_p]),
        "N_VDestroy": (None, [void_p]),
        "SUNDenseMatrix": (void_p, [index, index, void_p]),
        "SUNDenseMatrix_Data": (ctypes.POINTER(double), [void_p]),
        "SUNMatDestroy": (None, [void_p]),
        "SUNLinSol_Dense": (void_p, [void_p, void_p, void_p]),
        "SUNLinSolFree": (c_int, [void_p]),
        "CVodeCreate": (void_p, [c_int, void_p]),
        "CVodeInit": (c_int, [void_p, void_p, double, void_p]),
        "CVodeSVtolerances": (c_int, [void_p, double, void_p]),
        "CVodeSetLinearSolver": (c_int, [void_p, void_p, void_p]),
        "CVodeSetJacFn": (c_int, [void_p, void_p]),
        "CVodeSetUserData": (c_int, [void_p, void_p]),
        "CVodeSetMaxNumSteps": (c_int, [void_p, c_long]),
        "CVodeSetMaxOrd": (c_int, [void_p, c_int]),
        "CVodeSetMaxNonlinIters": (c_int, [void_p, c_int]),
        "CVodeSetMaxConvFails": (c_int, [void_p, c_int]),
        "CVodeSetInitStep": (c_int, [void_p, double]),
        "CVodeSetMinStep": (c_int, [void_p, double]),
        "CVodeSetMaxStep": (c_int, [void_p, double]),
        "CVodeSetStopTime": (c_int, [void_p, double]),
        "CVode": (c_int, [address, double, address, address, c_int]),
        "CVodeFree": (None, [ctypes.POINTER(void_p)]),
        **{name: (c_int, [void_p, ctypes.POINTER(c_long)]) for name in COUNTERS},
    }


@functools.cache
def load_sundials(directory: str | None = None) -> Sundials:
    """Load the SUNDIALS libraries from ``directory`` (default: scikit-sundae's wheel) and declare the C
    prototypes; ``SundialsUnavailable`` names the missing library, symbol or configuration."""
    config = sundials_configuration()
    version = config.get("SUNDIALS_VERSION", "?")
    if not version.startswith(f"{SUNDIALS_MAJOR_VERSION}."):
        raise SundialsUnavailable(f"SUNDIALS {version} found; the compiled CVODE path uses the SUNDIALS "
                                  f"{SUNDIALS_MAJOR_VERSION}.x API")
    if config.get("SUNDIALS_FLOAT_TYPE") != "double":
        raise SundialsUnavailable(f"SUNDIALS built with sunrealtype = {config.get('SUNDIALS_FLOAT_TYPE')!r}; "
                                  "the compiled CVODE path needs double")
    index = INDEX_TYPES.get(config.get("SUNDIALS_INT_TYPE", ""))
    if index is None:
        raise SundialsUnavailable(f"unknown sunindextype {config.get('SUNDIALS_INT_TYPE')!r} in scikit-sundae's "
                                  "SUNDIALS configuration")
    directories = [Path(directory)] if directory is not None else default_library_directories()
    libraries = []
    for name in LIBRARIES:
        path = find_library(name, directories)
        try:
            libraries.append(ctypes.CDLL(str(path)))
        except OSError as exc:
            raise SundialsUnavailable(f"cannot load SUNDIALS library {path}: {exc}") from None
    functions = {}
    for name, (restype, argtypes) in _prototypes(index).items():
        function = next((getattr(library, name) for library in libraries if hasattr(library, name)), None)
        if function is None:
            raise SundialsUnavailable(f"symbol {name!r} not found in {', '.join(LIBRARIES)} ({directories[0]})")
        function.restype, function.argtypes = restype, argtypes
        functions[name] = function
    return Sundials(directory=path.parent, version=version, index_type=index, functions=functions)


# --- compiled callbacks and output loop ----------------------------------------------------------------------

@functools.cache
def compiled_callbacks(library: Sundials, model: Model) -> tuple:
    """The ``CVRhsFn`` and ``CVLsJacFn`` callbacks of ``model`` as numba ``cfunc`` objects (CVODE gets their
    ``address``; the cache keeps them, and so their machine code, alive). ``user_data`` points to the
    parameter vector."""
    from numba import carray, cfunc, types

    rhs_into, jacobian_into = model.numba_rhs_into, model.numba_jacobian_into
    data = library.N_VGetArrayPointer_Serial
    dense = library.SUNDenseMatrix_Data
    n, n_p = STATE_SIZE, PARAMETER_COUNT
    void_p = types.voidptr

    @cfunc(types.intc(types.double, void_p, void_p, void_p), **JIT_OPTIONS)
    def rhs(t, y, ydot, user_data):
        rhs_into(t, carray(data(y), n), carray(data(ydot), n), carray(user_data, n_p, np.float64))
        return 0

    @cfunc(types.intc(types.double, void_p, void_p, void_p, void_p, void_p, void_p, void_p), **JIT_OPTIONS)
    def jacobian(t, y, fy, matrix, user_data, tmp1, tmp2, tmp3):
        columns = carray(dense(matrix), (n, n))  # column-major: columns[j, i] is entry (i, j)
        jacobian_into(t, carray(data(y), n), columns.T, carray(user_data, n_p, np.float64))
        return 0

    return rhs, jacobian


@functools.cache
def cvode_output_loop(library: Sundials) -> Callable:
    """njit ``(mem, y_vector, t_return, t_span, y_work, y_out) -> (flag, rows)``: ``CVode`` to each of
    ``t_span[1:]`` in turn, copying the state (``y_work``, wrapped by the N_Vector at address ``y_vector``) into
    ``y_out``; stops at the first negative flag. ``t_return`` is the address of a double that receives the
    time CVODE reached. Element-wise copies: numba compiles them in a fifth of the time of slice assignments."""
    from numba import njit

    cvode = library.CVode

    @njit(nogil=True, **JIT_OPTIONS)
    def loop(mem, y_vector, t_return, t_span, y_work, y_out):
        for j in range(y_work.size):
            y_out[0, j] = y_work[j]
        for row in range(1, t_span.size):
            flag = cvode(mem, t_span[row], y_vector, t_return, CV_NORMAL)
            if flag < 0:
                return flag, row
            for j in range(y_work.size):
                y_out[row, j] = y_work[j]
        return 0, t_span.size

    return loop


# --- one solve -------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class CvodeSettings:
    """Everything that defines a CVODE run; the compiled and the scikit-sundae paths take the same values.

    ``first_step``, ``min_step`` and ``max_step`` = 0 and the nonlinear-iteration limits are CVODE's defaults,
    which scikit-sundae also sets explicitly (``sksundae.cvode.CVODE``); ``t_span[-1]`` is the stop time.
    """

    method: str  # "Adams" or "BDF"
    max_order: int
    rtol: float
    atol: np.ndarray
    max_num_steps: int
    t_span: np.ndarray
    initial_state: np.ndarray
    analytic_jacobian: bool
    max_nonlin_iters: int = 3
    max_conv_fails: int = 10
    first_step: float = 0.0
    min_step: float = 0.0
    max_step: float = 0.0


@dataclass
class CvodeRun:
    """What a compiled solve returns: states at ``t_span`` (NaN rows after a failure), CVODE's flag (the last
    one: negative for a failure, ``CVODE_FLAGS``), the time reached and CVODE's counters (``COUNTERS``)."""

    y: np.ndarray
    flag: int
    t_reached: float
    counters: dict[str, int]


def _check(flag: int, call: str) -> None:
    if flag < 0:
        raise RuntimeError(f"{call} returned {flag}")


def _created(pointer: int | None, call: str) -> int:
    if not pointer:
        raise MemoryError(f"{call} returned NULL")
    return pointer


def run_cvode(library: Sundials, model: Model, settings: CvodeSettings, parameters: np.ndarray) -> CvodeRun:
    """One CVODE solve with compiled callbacks: create, configure as ``settings`` says, loop, read counters,
    free (also when a call fails)."""
    rhs, jacobian = compiled_callbacks(library, model)
    loop = cvode_output_loop(library)
    lib, void_p = library, ctypes.c_void_p
    parameters = np.ascontiguousarray(parameters, dtype=np.float64)
    y_work = np.array(settings.initial_state, dtype=np.float64)
    atol = np.array(settings.atol, dtype=np.float64)
    t_return = np.zeros(1)
    y_out = np.full((settings.t_span.size, STATE_SIZE), np.nan)
    context, mem = void_p(), void_p()
    y_vector = atol_vector = matrix = solver = None
    try:
        _check(lib.SUNContext_Create(SUN_COMM_NULL, ctypes.byref(context)), "SUNContext_Create")
        y_vector = _created(lib.N_VMake_Serial(STATE_SIZE, y_work.ctypes.data, context), "N_VMake_Serial")
        atol_vector = _created(lib.N_VMake_Serial(STATE_SIZE, atol.ctypes.data, context), "N_VMake_Serial")
        mem.value = _created(lib.CVodeCreate(CV_ADAMS if settings.method == "Adams" else CV_BDF, context),
                             "CVodeCreate")
        _check(lib.CVodeSetUserData(mem, parameters.ctypes.data), "CVodeSetUserData")
        _check(lib.CVodeInit(mem, rhs.address, float(settings.t_span[0]), y_vector), "CVodeInit")
        _check(lib.CVodeSVtolerances(mem, settings.rtol, atol_vector), "CVodeSVtolerances")
        matrix = _created(lib.SUNDenseMatrix(STATE_SIZE, STATE_SIZE, context), "SUNDenseMatrix")
        solver = _created(lib.SUNLinSol_Dense(y_vector, matrix, context), "SUNLinSol_Dense")
        _check(lib.CVodeSetLinearSolver(mem, solver, matrix), "CVodeSetLinearSolver")
        if settings.analytic_jacobian:
            _check(lib.CVodeSetJacFn(mem, jacobian.address), "CVodeSetJacFn")
        _check(lib.CVodeSetMaxNonlinIters(mem, settings.max_nonlin_iters), "CVodeSetMaxNonlinIters")
        _check(lib.CVodeSetMaxConvFails(mem, settings.max_conv_fails), "CVodeSetMaxConvFails")
        _check(lib.CVodeSetInitStep(mem, settings.first_step), "CVodeSetInitStep")
        _check(lib.CVodeSetMinStep(mem, settings.min_step), "CVodeSetMinStep")
        _check(lib.CVodeSetMaxStep(mem, settings.max_step), "CVodeSetMaxStep")
        _check(lib.CVodeSetMaxOrd(mem, settings.max_order), "CVodeSetMaxOrd")
        _check(lib.CVodeSetMaxNumSteps(mem, settings.max_num_steps), "CVodeSetMaxNumSteps")
        _check(lib.CVodeSetStopTime(mem, float(settings.t_span[-1])), "CVodeSetStopTime")

        flag, rows = loop(mem.value, y_vector, t_return.ctypes.data, settings.t_span, y_work, y_out)

        counters = {}
        for name in COUNTERS:
            value = ctypes.c_long()
            _check(lib.functions[name](mem, ctypes.byref(value)), name)
            counters[name] = int(value.value)
        t_reached = float(t_return[0]) if rows > 1 or flag < 0 else float(settings.t_span[0])
        return CvodeRun(y=y_out, flag=int(flag), t_reached=t_reached, counters=counters)
    finally:
        if mem.value:
            lib.CVodeFree(ctypes.byref(mem))
        if solver:
            lib.SUNLinSolFree(solver)
        if matrix:
            lib.SUNMatDestroy(matrix)
        for vector in (y_vector, atol_vector):
            if vector:
                lib.N_VDestroy(vector)
        if context.value:
            lib.SUNContext_Free(ctypes.byref(context))
