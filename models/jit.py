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

**Compiled once per machine.** Processes that need the same function at the same time (the workers of
``pytest -n auto`` or of ``foucault-bench run``) would each compile it: the disk cache only helps a process
that starts compiling after another has saved. So every compilation takes an exclusive ``fcntl.flock`` on a
file named after the cache key (``<cache entry>.lock`` beside the entry) around numba's compile-or-load: the
first process compiles and saves, the others wait and then load its entry. The operating system releases the
lock when its holder exits or dies, so a killed process never leaves the others waiting. A compilation
nested in another (a loop type-inferring the step it calls) takes its own key's lock while its caller holds
one: callers lock before callees, and no compiled function calls its callers, so no two processes can wait
for each other; a key this process already holds (recursion) is not locked again.

heyoka's integrators are built under the same kind of lock
(``integrators/methods/heyoka_taylor.py``).

**Log.** With ``FOUCAULT_BENCH_JIT_LOG=FILE`` set, every compilation and cache load appends one
tab-separated line to FILE (``log_build``): process id, Unix time at the end, ``compiled`` or ``loaded``
(``built`` for heyoka, whose disk cache does not say which), seconds waited for the key's lock (wall), CPU
seconds of this function alone and with the functions compiled inside it, the function's qualified name (its
fingerprint is the suffix) and the signature. bench/PERF.md "Compile once per machine: the tests' cold
start" shows how it was used.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import threading
import time
import types
from typing import Callable, Iterator, overload

from numba.core import sigutils
from numba.core.caching import FunctionCache, IndexDataCacheFile
from numba.core.compiler_lock import global_compiler_lock
from numba.core.dispatcher import Dispatcher
from numba.core.extending import _Intrinsic
from numba.core.registry import CPUDispatcher
from numba.core.serialize import dumps
from numba.extending import register_jitable

JIT_OPTIONS: dict[str, str] = {"error_model": "numpy"}
"""numba options of every compiled function of the suite (see the module docstring)."""

LOG_ENVIRONMENT_VARIABLE = "FOUCAULT_BENCH_JIT_LOG"
"""Names the file every compilation and cache load is logged to (module docstring, "Log")."""

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

    def entry_name(self, key) -> str:
        """The name of the key's files without their suffix (``.nbc``: its data; ``.lock``: its lock)."""
        return f"{self._index_name[:-len('.nbi')]}.{hashlib.sha256(repr(key).encode()).hexdigest()[:16]}"

    def save(self, key, data):
        data_name = f"{self.entry_name(key)}.nbc"
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

    def entry_lock_path(self, sig, codegen) -> str:
        """The lock file of ``sig``'s cache entry (module docstring, "Compiled once per machine")."""
        self._impl.locator.ensure_cache_path()
        return os.path.join(self._cache_path, f"{self._cache_file.entry_name(self._index_key(sig, codegen))}.lock")


_locks = threading.local()
"""``held``: the lock files this thread holds (``built_once``)."""


@contextlib.contextmanager
def built_once(lock_path: Callable[[], str | None]) -> Iterator[float]:
    """Hold the exclusive ``fcntl.flock`` of the file ``lock_path()`` while building something that other
    processes may build at the same time into a shared disk cache, so that one builds it and the others load
    it (module docstring, "Compiled once per machine"); yields the seconds waited for the lock. A lock this
    thread holds already is not taken again; nothing is locked where ``lock_path()`` is None (no shared cache)
    or the file cannot be created (``OSError``)."""
    held = _locks.__dict__.setdefault("held", set())
    try:
        path = lock_path()
        lock = None if path is None or path in held else open(path, "a")
    except OSError:
        lock = None
    if lock is None:
        yield 0.0
        return
    with lock:
        requested_s = time.perf_counter()
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed, or by the system if we die
        held.add(path)
        try:
            yield time.perf_counter() - requested_s
        finally:
            held.discard(path)


def log_build(outcome: str, waited_s: float, own_cpu_s: float, total_cpu_s: float, name: str, signature: str) -> None:
    """One line of the log named by ``FOUCAULT_BENCH_JIT_LOG`` (module docstring, "Log"), if it is set."""
    log = os.environ.get(LOG_ENVIRONMENT_VARIABLE)
    if log:
        with open(log, "a") as file:  # one short append: the lines of concurrent processes do not interleave
            file.write(f"{os.getpid()}\t{time.time():.3f}\t{outcome}\t{waited_s:.3f}\t{own_cpu_s:.3f}\t"
                       f"{total_cpu_s:.3f}\t{name}\t{signature}\n")


_nested_cpu_s = [0.0]
"""CPU seconds of the compilations nested in the one under way (for the log's "this function alone")."""


class _SharedDispatcher(CPUDispatcher):
    """numba's CPU dispatcher whose compilations hold their cache entry's lock (``built_once``) and are logged when ``FOUCAULT_BENCH_JIT_LOG`` is set."""

    def enable_caching(self) -> None:
        self._cache = _FingerprintCache(self.py_func)

    def compile(self, sig):
        with global_compiler_lock:
            args, _ = sigutils.normalize_signature(sig)
            if tuple(args) in self.overloads or not isinstance(self._cache, _FingerprintCache):
                return super().compile(sig)  # compiled in this process already, or not cached (a copy unpickled)
            cache = self._cache
            with built_once(lambda: cache.entry_lock_path(sig, self.targetctx.codegen())) as waited_s:
                hits, outer_nested_s, started_s = self._cache_hits[sig], _nested_cpu_s[0], time.process_time()
                _nested_cpu_s[0] = 0.0
                try:
                    entry = super().compile(sig)
                finally:
                    total_s = time.process_time() - started_s
                    own_s = total_s - _nested_cpu_s[0]
                    _nested_cpu_s[0] = outer_nested_s + total_s
            log_build("loaded" if self._cache_hits[sig] > hits else "compiled", waited_s, own_s, total_s,
                      self.py_func.__qualname__, str(args))
            return entry


@overload
def jit(fn: Callable, **options) -> Dispatcher: ...


@overload
def jit(fn: None = None, **options) -> Callable[[Callable], Dispatcher]: ...


def jit(fn: Callable | None = None, **options) -> Dispatcher | Callable[[Callable], Dispatcher]:
    """Compile ``fn`` with numba (nopython, ``JIT_OPTIONS`` plus ``options``), cached on disk under a
    deterministic key. Use as ``@jit`` or ``@jit(inline="always")``.

    numba compiles a copy of ``fn`` whose qualified name ends in its fingerprint: numba names the machine code
    (and each function's environment) after the qualified name and a per-process counter and resolves them by
    name, so two closures of the same source (RK4's loop on two models, the right-hand sides of two models)
    compiled in different processes would otherwise load under one symbol name into a third process.
    """
    if fn is None:
        return lambda function: jit(function, **options)
    digest = hashlib.sha256(f"{_fingerprint(fn, set())}{sorted(options.items())}".encode()).hexdigest()[:16]
    unique = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__)
    unique.__qualname__ = f"{fn.__qualname__}_{digest}"
    unique.__module__, unique.__doc__, unique.__kwdefaults__ = fn.__module__, fn.__doc__, fn.__kwdefaults__
    # what njit(**JIT_OPTIONS, **options, cache=True) builds, with our dispatcher
    dispatcher = _SharedDispatcher(py_func=unique, locals={},
                                   targetoptions={**JIT_OPTIONS, **options, "nopython": True, "boundscheck": None})
    dispatcher.enable_caching()
    return dispatcher


def jitable(fn: Callable) -> Callable:
    """``numba.extending.register_jitable`` with ``JIT_OPTIONS``: a plain Python function that compiled code
    may call (compiled into its caller)."""
    return register_jitable(**JIT_OPTIONS)(fn)
