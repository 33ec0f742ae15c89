"""Worker processes the runner can end: one task at a time, a time limit per task, gone when their parent goes.

A worker is ``python -m foucault_bench.bench.run.worker PARENT_PID``, a plain subprocess (no
``multiprocessing``: no resource-tracker process, no shared semaphores) that reads pickled tasks
``(function, args)`` from its stdin and writes one pickled outcome per task to a private copy of its stdout:

* ``("started", None)`` once it has read the task and imported what unpickling it needs, before calling it:
  the parent counts a task's time limit from this notice, so a worker's start-up (imports, cache loads, seconds
  on a loaded machine) never counts as the run's time,
* ``("ok", value)`` when ``function(*args)`` returned,
* ``("error", reason)`` when it raised anything, ``BaseException`` included (``SystemExit``,
  ``KeyboardInterrupt`` raised by a plug-in), or when its value could not be pickled.

The parent (``WorkerProcess``) sees a worker that died (a segfault in native code, ``os._exit``, the OOM
killer) as end-of-file, and ends a worker whose task is past its time limit with ``SIGKILL``, the only way to
stop a compiled loop that holds the GIL. A worker never outlives its parent:

* ``bench.parent_death.die_with_parent``: on Linux the kernel kills it when the thread that started it ends
  (workers are started from one long-lived thread, ``_SPAWNER``, so that this is the process's life), and
  everywhere a watchdog thread ends it once its parent pid changes;
* an idle worker ends at end-of-file on stdin or after ``IDLE_EXIT_S`` without a task.

Workers ignore SIGINT and SIGTERM: a Ctrl-C in a terminal reaches the whole process group, and a run
interrupted that way must not be stored as a failed row; the parent ends its workers itself.

Plug-in output: the worker's file descriptor 1 is pointed at stderr, so a ``print`` in a plug-in (or a native
library writing to stdout) cannot corrupt the task channel.
"""

from __future__ import annotations

import concurrent.futures
import os
import pickle
import select
import signal
import subprocess
import sys
import time
import traceback
from typing import Any, Callable

from foucault_bench.bench.parent_death import die_with_parent

IDLE_EXIT_S = 60.0
CLOSE_GRACE_S = 5.0
STARTED = "started"
"""The kind of the notice a worker sends when it begins a task (see the module docstring)."""
START_ALLOWANCE_S = 300.0
"""How long a worker may take from receiving a task to its start notice (importing the task's modules) before
the task counts as timed out: far above a start-up on a loaded 2-core machine (seconds), so only a stuck worker
reaches it."""

WORKER_MODULES = (
    "heyoka",  # the reference integrator's library: imported before any timed call, never counted as compile time
    "foucault_bench.integrators",
    "foucault_bench.bench.problems.reference",
    "foucault_bench.bench.verdicts.adequacy",
    "foucault_bench.bench.verdicts.columns",
)
"""What a worker imports to run (``warm_up``, its first task, while the main process validates the matrix; it also
loads the calibration loop then)."""

_SPAWNER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="foucault-bench-spawner")
"""Starts every worker: its thread lives as long as the process, which is what ``die_with_parent``'s prctl watches."""


def write_message(descriptor: int, value: Any) -> None:
    """Send ``value`` as one message: its pickle's length (8 bytes, big-endian), then the pickle."""
    payload = pickle.dumps(value)
    data = memoryview(len(payload).to_bytes(8, "big") + payload)
    while data:
        data = data[os.write(descriptor, data):]


def read_message(descriptor: int) -> Any:
    """The next message (``write_message``); ``EOFError`` if the pipe closes first. Reads exactly one message,
    so that ``select`` on the descriptor still tells whether another one is waiting."""
    size = int.from_bytes(_read_exactly(descriptor, 8), "big")
    return pickle.loads(_read_exactly(descriptor, size))


def _read_exactly(descriptor: int, size: int) -> bytes:
    chunks, left = [], size
    while left:
        chunk = os.read(descriptor, min(left, 1 << 20))
        if not chunk:
            raise EOFError("the pipe closed")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def describe(error: BaseException) -> str:
    """``Type: message (file:line)`` of the innermost frame, short enough for a table cell."""
    frames = traceback.extract_tb(error.__traceback__)
    where = f" ({frames[-1].filename.rsplit('/', 1)[-1]}:{frames[-1].lineno})" if frames else ""
    return f"{type(error).__name__}: {error}{where}"


def warm_up() -> None:
    """Import ``WORKER_MODULES`` and load the machine-speed calibration's loop (``bench.run.calibration``)."""
    import importlib

    from foucault_bench.bench.run.calibration import warm_calibration

    for module_name in WORKER_MODULES:
        importlib.import_module(module_name)
    warm_calibration()


class WorkerProcess:
    """One worker subprocess, seen from its parent."""

    def __init__(self) -> None:
        command = [sys.executable, "-m", "foucault_bench.bench.run.worker", str(os.getpid())]
        self.process = _SPAWNER.submit(
            subprocess.Popen, command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0,
            close_fds=True).result()
        self.last_used = time.monotonic()
        self.started_at: float | None = None
        """When the task sent last began (its start notice), ``None`` until then."""
        self.code_version: str | None = None  # set by whoever checks it (bench.run.dask_executor.run_isolated)
        self._send(list(sys.path))  # the worker imports the same modules (what multiprocessing's spawn does)

    @property
    def pid(self) -> int:
        return self.process.pid

    def fileno(self) -> int:
        """The outcome channel, for ``multiprocessing.connection.wait`` or ``select``."""
        assert self.process.stdout is not None  # a pipe (__init__)
        return self.process.stdout.fileno()

    def alive(self) -> bool:
        return self.process.poll() is None

    def submit(self, function: Callable, args: tuple) -> bool:
        """Send a task; ``False`` if the worker is gone (nothing was sent)."""
        if not self._send((function, args)):
            return False
        self.last_used = time.monotonic()
        self.started_at = None
        return True

    def deadline(self, timeout_s: float | None) -> float:
        """When the task sent last passes its time limit: ``timeout_s`` after its start notice, or, until that
        notice, ``START_ALLOWANCE_S`` more after it was sent (``inf`` without a limit)."""
        if timeout_s is None:
            return float("inf")
        if self.started_at is None:
            return self.last_used + START_ALLOWANCE_S + timeout_s
        return self.started_at + timeout_s

    def _send(self, value: Any) -> bool:
        assert self.process.stdin is not None  # a pipe (__init__)
        try:
            write_message(self.process.stdin.fileno(), value)
        except (OSError, ValueError):  # a closed pipe: the worker is gone
            return False
        return True

    def next_message(self) -> tuple[str, Any] | None:
        """The worker's next message (blocks until it is complete): the start notice (``STARTED``, which also
        sets ``started_at``) or the task's outcome; ``None`` if the worker died."""
        try:
            message = read_message(self.fileno())
        except Exception:  # end-of-file or a truncated message: the worker died mid-task
            return None
        self.last_used = time.monotonic()
        if message[0] == STARTED:
            self.started_at = self.last_used
        return message

    def receive(self) -> tuple[str, Any] | None:
        """The outcome of the task sent last (blocks until it is complete, past its start notice); ``None`` if
        the worker died."""
        while (message := self.next_message()) is not None and message[0] == STARTED:
            pass
        return message

    def call(self, function: Callable, args: tuple, timeout_s: float | None,
             stop: Callable[[], bool] = lambda: False) -> tuple[str, Any]:
        """Run one task and wait for it: ``("ok", value)``, ``("error", reason)``, ``("died", None)``,
        ``("timeout", None)`` or ``("stopped", None)`` when ``stop()`` became true (polled every second).
        The worker is killed on a timeout or a stop."""
        if not self.submit(function, args):
            return "died", None
        while True:
            wait_s = min(1.0, max(0.0, self.deadline(timeout_s) - time.monotonic()))
            ready, _, _ = select.select([self], [], [], wait_s)
            if ready:
                message = self.next_message()
                if message is None:
                    return "died", None
                if message[0] != STARTED:
                    return message
                continue
            if time.monotonic() >= self.deadline(timeout_s):
                self.kill()
                return "timeout", None
            if stop():
                self.kill()
                return "stopped", None

    def kill(self) -> None:
        """End the worker at once (SIGKILL) and reap it."""
        if self.alive():
            self.process.kill()
        self.process.wait()
        self._close_pipes()

    def close(self) -> None:
        """Let an idle worker exit (end-of-file on its stdin), killing it if it has not within a few seconds."""
        assert self.process.stdin is not None  # a pipe (__init__)
        try:
            self.process.stdin.close()
        except OSError:
            pass
        try:
            self.process.wait(timeout=CLOSE_GRACE_S)
        except subprocess.TimeoutExpired:
            self.kill()
        self._close_pipes()

    def _close_pipes(self) -> None:
        for pipe in filter(None, (self.process.stdin, self.process.stdout)):
            try:
                pipe.close()
            except OSError:
                pass


# --- the worker side ------------------------------------------------------------------------------------------


def main(parent_pid: int) -> None:
    """Serve tasks from stdin until end-of-file (see the module docstring)."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    from foucault_bench.bench.run.timing import limit_threads  # standard library only: before numpy

    limit_threads()
    tasks, outcomes = os.dup(0), os.dup(1)
    os.dup2(2, 1)  # stdout writes (plug-ins, native libraries) go to stderr, not into the channel
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    sys.path[:] = read_message(tasks)  # the parent's (WorkerProcess.__init__)
    while True:
        ready, _, _ = select.select([tasks], [], [], IDLE_EXIT_S)
        if not ready:
            break
        try:
            function, args = read_message(tasks)
        except EOFError:
            break
        write_message(outcomes, (STARTED, None))
        try:
            outcome: tuple[str, Any] = ("ok", function(*args))
        except BaseException as error:  # noqa: BLE001 - whatever a task raises is its outcome, never the worker's end
            outcome = ("error", describe(error))
        try:
            write_message(outcomes, outcome)
        except BaseException as error:  # noqa: BLE001 - an unpicklable value is the task's fault too
            write_message(outcomes, ("error", f"the result could not be sent back: {describe(error)}"))
    # Every outcome is written: end without tearing down the numerical libraries (0.5-1.2 s per worker,
    # bench/PERF.md "Start-up"), time the parent would spend waiting for its workers to end.
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    main(int(sys.argv[1]))
