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

**A pool's replacement workers get the watchdog only.** ``multiprocessing.Pool`` replaces a worker that died
(a crash in a task) from its worker-handler thread, and that thread ends in ``Pool.terminate()``. With prctl the
kernel would then kill the replacement, possibly while it waits for a task holding the pool's task-queue lock;
``terminate()`` takes that lock and would wait for it forever (CPython issues #96062 and #78178: a pool worker
killed holding the lock). So prctl is set only in a worker forked by the thread that made the pool
(``forking_thread``).
"""

from __future__ import annotations

import multiprocessing.context
import multiprocessing.pool
import os
import signal
import sys
import threading
import time

PARENT_POLL_S = 0.5
PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent(parent_pid: int, forking_thread: int | None = None) -> None:
    """Arrange for this process to end when its parent, ``parent_pid``, does (see the module docstring); ends it
    at once if that parent is already gone. ``forking_thread``: the ``threading.get_ident()`` of the parent's
    thread that lives as long as the parent; a worker forked by another thread (a pool's replacement worker)
    gets the watchdog only (module docstring). A forked child's only thread keeps the ident of the thread that
    forked it."""
    if sys.platform.startswith("linux") and forking_thread in (None, threading.get_ident()):
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


def worker_pool(context: multiprocessing.context.BaseContext, jobs: int) -> multiprocessing.pool.Pool:
    """``jobs`` worker processes of ``context`` that end with this process (``die_with_parent``); create it from a
    thread that lives as long as the process (the main thread)."""
    return context.Pool(jobs, initializer=die_with_parent, initargs=(os.getpid(), threading.get_ident()))
