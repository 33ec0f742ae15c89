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

**Pools that never wait on their workers' locks.** The report's and the studies' pools are
``concurrent.futures.ProcessPoolExecutor``. ``multiprocessing.Pool`` was used before and hung: its
``terminate()`` kills the workers and then waits for them on locks they share with the pool's threads (a worker
killed while sending a result holds the result queue's lock for ever, one killed while waiting for a task the task
queue's: CPython issues #96062 and #78178). The executor's own threads only read what its workers write, and it
never replaces a worker: one that dies breaks the pool, whose unfinished tasks then end with ``BrokenProcessPool``.
``stop_pool`` stops one without killing anything: the tasks not yet started are cancelled, the running ones end,
and nothing a worker writes comes after it returns.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing.context
import os
import signal
import sys
import threading
import time

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
    """``jobs`` worker processes of ``context`` that end with this process (``die_with_parent``). With the fork
    context the executor starts them all at the first ``submit``: submit from a thread that lives as long as the
    process (the main thread). Stop it with ``stop_pool``."""
    return concurrent.futures.ProcessPoolExecutor(jobs, mp_context=context, initializer=_start_pool_worker,
                                                  initargs=(os.getpid(),))


def _start_pool_worker(parent_pid: int) -> None:
    """A ``worker_pool`` process's first act: ``die_with_parent``, and SIGINT and SIGTERM ignored, as the run's
    workers do (``bench.run.worker``): a Ctrl-C in a terminal reaches the whole process group, and the pool's
    owner, interrupted, stops its workers itself (``stop_pool``: the tasks under way end, the others are
    cancelled), with no traceback from a worker interrupted while it waited for a task."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def stop_pool(pool: concurrent.futures.ProcessPoolExecutor, futures: list[concurrent.futures.Future]) -> None:
    """Stop ``pool`` (module docstring): cancel those of its ``futures`` not yet started, wait for the others to
    end (a running task is not interrupted), then shut it down."""
    for future in futures:
        future.cancel()
    concurrent.futures.wait(futures)
    pool.shutdown(wait=True, cancel_futures=True)
