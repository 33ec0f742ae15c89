"""How the suite compiles with numba: ``jit`` for every compiled function of the models and the fixed-step
integrators, ``jitable`` for the small helpers they inline.

``jit(fn)`` is ``numba.njit(error_model="numpy")(fn)`` with numba's on-disk cache under a deterministic key.

**Why not ``njit(cache=True)``.** The suite derives its compiled functions from one source by closures: the
model's acceleration closes over its compiled force, a scheme's step over the acceleration, the fixed-step
loop over the step and the energy. numba keys a cached closure by a pickle of its cells, and a compiled
function pickles with a random per-process UUID, so in a new process the key never matches: every process
recompiled every loop from scratch and appended one more entry to the cache index (numba issue #6264; measured
on the 11 fixed-step loops: 24 s in a process with a warm cache against 28 s cold, bench/PERF.md). Here the
key is a fingerprint of the code instead: for every function reached through closure cells and globals, its
module, qualified name, bytecode, constants, names and numba options, and the values of the scalar globals it
reads (numba freezes those into the machine code). The fingerprint also covers callees in other files, whose
edits numba's own key (the source file's timestamp) does not see. Two more changes make the reuse safe: each
compiled function is named after its fingerprint (``jit``), and each cache entry is stored in a file named
after its key (``_KeyedDataCacheFile``), so that processes compiling at the same time cannot swap entries.

**Why ``error_model="numpy"``.** With numba's default ("python") every float division checks its divisor and
may raise ZeroDivisionError. Those raise paths stop numba from removing the reference counting of the
parameter array around each call and keep LLVM from inlining the models into the loops: the spherical model's
steps ran 1.5-1.7× slower than the same arithmetic in C (bench/PERF.md). With "numpy" a division by zero gives
an infinity or NaN, which the fixed-step loop reports as a divergence, and every finite result is bitwise the
same.
"""

from __future__ import annotations

import hashlib
import types
from typing import Callable, cast

from numba import njit
from numba.core.caching import FunctionCache, IndexDataCacheFile
from numba.core.dispatcher import Dispatcher
from numba.core.extending import _Intrinsic
from numba.core.serialize import dumps
from numba.extending import register_jitable

JIT_OPTIONS: dict[str, str] = {"error_model": "numpy"}
"""numba options of every compiled function of the suite (see the module docstring)."""

_SCALARS = (bool, int, float, complex, str, bytes, type(None))


def _code_fingerprint(code: types.CodeType) -> str:
    constants = ",".join(_code_fingerprint(c) if isinstance(c, types.CodeType) else repr(c) for c in code.co_consts)
    return f"{code.co_code.hex()}|{constants}|{code.co_names}"


def _fingerprint(value: object, seen: set[int]) -> str:
    """A description of ``value`` that is the same in every process and changes with anything numba compiles."""
    if isinstance(value, Dispatcher):
        return f"jit{sorted(value.targetoptions.items())}:{_fingerprint(value.py_func, seen)}"
    if isinstance(value, _Intrinsic):  # numba.extending.intrinsic: pickles with a per-process UUID too
        return f"intrinsic:{_fingerprint(value._defn, seen)}"
    if isinstance(value, types.FunctionType):
        name = f"{value.__module__}.{value.__qualname__}"
        if id(value) in seen:
            return f"function {name} (above)"
        seen.add(id(value))
        cells = [_fingerprint(cell.cell_contents, seen) for cell in value.__closure__ or ()]
        scope = value.__globals__
        read = [f"{n}={_fingerprint(scope[n], seen)}" for n in value.__code__.co_names if n in scope]
        return f"function {name}[{_code_fingerprint(value.__code__)}]cells{cells}globals{read}"
    if isinstance(value, types.ModuleType):
        return f"module {value.__name__}"
    if isinstance(value, _SCALARS):
        return f"{type(value).__name__} {value!r}"
    if isinstance(value, tuple):
        return f"tuple({','.join(_fingerprint(item, seen) for item in value)})"
    if isinstance(value, type):
        return f"type {value.__module__}.{value.__qualname__}"
    return f"pickle {hashlib.sha256(dumps(value)).hexdigest()}"  # numba's own key for anything else


class _KeyedDataCacheFile(IndexDataCacheFile):
    """numba's index and data files, with each data file named after its key.

    numba names a new data file by the first number its copy of the index does not use yet, so two processes
    saving different entries at the same time can write to the same file, and the index can then point a key
    to another key's machine code (the workers of ``foucault-bench run`` compile at the same time, into one
    cache). Named after the key, a data file only ever holds that key's code; writing the data before the
    index, a lost index update only costs a recompilation.
    """

    def save(self, key, data):
        data_name = f"{self._index_name[:-len('.nbi')]}.{hashlib.sha256(repr(key).encode()).hexdigest()[:16]}.nbc"
        self._save_data(data_name, data)
        overloads = self._load_index()
        overloads[key] = data_name
        self._save_index(overloads)


class _FingerprintCache(FunctionCache):
    """numba's per-function disk cache, keyed by the fingerprint of the function instead of its cell pickle,
    with one data file per key (``_KeyedDataCacheFile``)."""

    def __init__(self, py_func: Callable) -> None:
        super().__init__(py_func)
        self._cache_file = _KeyedDataCacheFile(cache_path=self._cache_path, filename_base=self._impl.filename_base,
                                               source_stamp=self._impl.locator.get_source_stamp())

    def _index_key(self, sig, codegen):
        fingerprint = _fingerprint(self._py_func, set())
        return sig, codegen.magic_tuple(), hashlib.sha256(fingerprint.encode()).hexdigest()


def jit(fn: Callable | None = None, **options) -> Dispatcher | Callable[[Callable], Dispatcher]:
    """Compile ``fn`` with numba (nopython, ``JIT_OPTIONS`` plus ``options``), cached on disk under a
    deterministic key. Use as ``@jit`` or ``@jit(inline="always")``.

    numba compiles a copy of ``fn`` whose qualified name ends in its fingerprint: numba names the machine code
    (and each function's environment) after the qualified name and a per-process counter and resolves them by
    name, so two closures of the same source (RK4's loop on two models, the right-hand sides of two models)
    compiled in different processes would otherwise load under one symbol name into a third process.
    """
    if fn is None:
        return lambda function: cast(Dispatcher, jit(function, **options))
    digest = hashlib.sha256(f"{_fingerprint(fn, set())}{sorted(options.items())}".encode()).hexdigest()[:16]
    unique = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__)
    unique.__qualname__ = f"{fn.__qualname__}_{digest}"
    unique.__module__, unique.__doc__, unique.__kwdefaults__ = fn.__module__, fn.__doc__, fn.__kwdefaults__
    dispatcher = njit(**JIT_OPTIONS, **options)(unique)
    dispatcher._cache = _FingerprintCache(dispatcher.py_func)  # what njit(cache=True) does, with our key
    return dispatcher


def jitable(fn: Callable) -> Callable:
    """``numba.extending.register_jitable`` with ``JIT_OPTIONS``: a plain Python function that compiled code
    may call (compiled into its caller)."""
    return register_jitable(**JIT_OPTIONS)(fn)
