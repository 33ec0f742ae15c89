"""Worker processes that never outlive their parent: ``die_with_parent``, called first in a worker (the run's
workers, ``bench.run.worker``; the report's and the studies' fork pools, ``worker_pool``, as the pool
initializer).

A parent killed from outside (``SIGKILL``, the OOM killer) cannot stop its workers, and a worker left running
goes on with its task: a report's worker would write a chart or a table into the staging folder that the next
build has already removed, recreating it as a half-written leftover beside the report. So each worker ends
itself:

* on Linux the kernel kills it when the thread that started it ends (``prctl(PR_SET_PDEATHSIG, SIGKILL)``,
  prctl(2)): whoever starts workers does it from a thread that lives as long as the process (the main thread,
  or the run's ``_SPAWNER``);
* everywhere, a watchdog thread ends it within ``PARENT_POLL_S`` once its parent pid changes (the watchdog needs
  the GIL, so it is the fallback where prctl does not exist, or where the parent died before prctl took effect).

**Pools stopped without killing.** The report's and the studies' pools are
``concurrent.futures.ProcessPoolExecutor``. ``multiprocessing.Pool`` was used before and hung: its
``terminate()`` kills the workers and then waits on locks it shares with them (a worker killed while sending a
result holds the result queue's lock for ever; CPython issues #96062 and #78178). The executor's threads never
take the locks its workers take on the result queue, and it never replaces a worker: one that dies breaks the
pool, whose unfinished tasks then end with ``BrokenProcessPool``, and the executor ends the other workers with
SIGTERM. ``stop_pools`` stops pools without killing anything: every task not yet started is cancelled, those under
way end, and nothing a worker writes comes after it returns. The workers ignore SIGINT (``_start_pool_worker``):
a Ctrl-C reaches the whole process group, and the pools' owner, interrupted, stops them so; a second Ctrl-C while
it waits kills them.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import multiprocessing
import multiprocessing.context
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

PARENT_POLL_S = 0.5
PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent(parent_pid: int) -> None:
    """Arrange for this process to end when its parent, ``parent_pid``, does (see the module docstring); ends it
    at once if that parent is already gone."""
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)
    threading.Thread(target=watch, name="parent-watchdog", daemon=True).start()


def worker_pool(context: multiprocessing.context.BaseContext, jobs: int) -> concurrent.futures.ProcessPoolExecutor:
    """``jobs`` worker processes of ``context`` that end with this process (``die_with_parent``), started here:
    call it from a thread that lives as long as the process (the main thread). Stop it with ``stop_pools``.

    With the fork context the executor forks its workers in the first ``submit``, then starts the thread that
    will stop them; a Ctrl-C between the two would leave workers that nothing stops and that the interpreter
    waits for at exit. So the first task, a no-op, is submitted here with Ctrl-C held back until it returns."""
    pool = concurrent.futures.ProcessPoolExecutor(jobs, mp_context=context, initializer=_start_pool_worker,
                                                  initargs=(os.getpid(),))
    with _ctrl_c_held_back():
        pool.submit(int)
    return pool


@contextlib.contextmanager
def _ctrl_c_held_back() -> Iterator[None]:
    """A SIGINT received inside the block is delivered when it ends (in the main thread; elsewhere, as it comes)."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is None:
        yield  # signal handlers are set in the main thread only; None: a handler not set from Python
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received:
            signal.raise_signal(signal.SIGINT)


def _start_pool_worker(parent_pid: int) -> None:
    """A ``worker_pool`` process's first act: ``die_with_parent``, and SIGINT ignored, as the run's workers do
    (``bench.run.worker``): a Ctrl-C in a terminal reaches the whole process group, and the pool's owner,
    interrupted, stops its workers itself (``stop_pools``), with no traceback from a worker interrupted while it
    waited for a task. SIGTERM keeps its default: it is how the executor ends the workers of a broken pool."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def outcome(future: concurrent.futures.Future) -> Any:
    """What a finished, not cancelled task gave: its result, or the exception it raised (``BrokenProcessPool``
    when its pool broke), for a done-callback to pass on to the thread that waits for it."""
    error = future.exception()
    return future.result() if error is None else error


CANCELLED_SEEN_S = 0.1
"""How long ``stop_pools``, interrupted, lets the pools' threads take note of the cancelled tasks (they are woken
for it at once) before it kills the workers."""

PoolTasks = tuple[concurrent.futures.ProcessPoolExecutor, list[concurrent.futures.Future]]
"""A pool and the futures of the tasks submitted to it."""


def stop_pools(pools: list[PoolTasks]) -> None:
    """Stop ``pools`` (module docstring): first every task not yet started is cancelled, in every pool (nothing
    here waits), then each pool's tasks under way are waited for (a running task is not interrupted) and the pool
    is shut down, its workers ended. Interrupted while it waits (a second Ctrl-C), it kills this process's worker
    processes (``multiprocessing.active_children``: the pools' workers) and lets the interrupt go on."""
    under_way = [[future for future in futures if not future.cancel()] for _, futures in pools]
    try:
        for (pool, _), running in zip(pools, under_way, strict=True):
            concurrent.futures.wait(running)  # not the cancelled: wait() counts them done only once the executor
            pool.shutdown(wait=True, cancel_futures=True)  # has seen them, which a shut-down one may never do
    except BaseException:  # a second Ctrl-C: the workers end now
        for pool, _ in pools:  # first each pool's thread drops the cancelled tasks: if it saw its workers die
            pool.shutdown(wait=False, cancel_futures=True)  # first, it would fail on them (Python 3.11)
        with contextlib.suppress(KeyboardInterrupt):
            time.sleep(CANCELLED_SEEN_S)
        for child in multiprocessing.active_children():
            child.kill()
        raise
