"""The local executor: the runner's tasks in worker processes on this machine, each one ended at its time limit.

``LocalExecutor`` (the interface: ``bench.run.executors``): ``jobs`` worker processes (each single-threaded,
``bench.run.timing.limit_threads``), one task each at a time, started as soon as the executor is made (their
first task, ``warm_up``, imports the numerical libraries while the main process validates the matrix). A
task's time limit counts from its worker's start notice (``bench.run.worker.STARTED``), so a replacement
worker's start-up is not the run's time. A worker whose task passes its time limit is killed and replaced; a
worker that dies is replaced and its task retried once in a fresh worker (``ATTEMPTS``).
"""

from __future__ import annotations

import collections
import multiprocessing.connection
import os
import signal
import time
from typing import Any, Callable, Iterator, cast

from foucault_bench.bench.run.executors import ATTEMPTS, outcome_value
from foucault_bench.bench.run.worker import STARTED, WorkerProcess, warm_up


class LocalExecutor:
    """``jobs`` worker processes on this machine (see the module docstring)."""

    scheduler = None

    def __init__(self, jobs: int):
        self.jobs = jobs
        self.idle: list[WorkerProcess] = []
        self.busy: dict[WorkerProcess, tuple[tuple, int]] = {}
        self.warming: list[WorkerProcess] = []
        for _ in range(jobs):  # start now: each imports the numerical libraries while the matrix is validated
            worker = WorkerProcess()
            if worker.submit(warm_up, ()):
                self.warming.append(worker)

    def check_code(self, matrix: Any) -> None:
        """Local workers import the same files as this process: nothing to check."""

    def _worker(self) -> WorkerProcess:
        while self.warming:
            worker = self.warming.pop()
            if worker.receive() is not None:  # the warm-up's outcome; an import error shows again in the task
                return worker
            worker.kill()
        while self.idle:
            worker = self.idle.pop()
            if worker.alive():
                return worker
            worker.kill()
        return WorkerProcess()

    def map_unordered(self, function: Callable, tasks: list[tuple], on_failure: Callable,
                      timeout_s: float | None) -> Iterator[tuple[tuple, Any]]:
        waiting = collections.deque((task, 1) for task in tasks)
        while waiting or self.busy:
            while waiting and len(self.busy) < self.jobs:
                task, attempt = waiting.popleft()
                worker = self._worker()
                if not worker.submit(function, task):
                    worker.kill()
                    waiting.appendleft((task, attempt))
                    continue
                self.busy[worker] = (task, attempt)
            next_deadline = min(worker.deadline(timeout_s) for worker in self.busy)
            wait_s = None if next_deadline == float("inf") else max(0.0, next_deadline - time.monotonic())
            busy: list[Any] = list(self.busy)  # WorkerProcess objects: wait() takes anything with a fileno()
            for worker in cast("list[WorkerProcess]", multiprocessing.connection.wait(busy, timeout=wait_s)):
                outcome = worker.next_message()
                if outcome is not None and outcome[0] == STARTED:  # its time limit counts from now
                    continue
                task, attempt = self.busy.pop(worker)
                if outcome is None:
                    worker.kill()
                    if attempt < ATTEMPTS:
                        waiting.appendleft((task, attempt + 1))
                        continue
                    outcome = ("died", None)
                else:
                    self.idle.append(worker)
                yield task, outcome_value(task, outcome, on_failure, timeout_s)
            now = time.monotonic()
            for worker, (task, _) in list(self.busy.items()):
                if worker.deadline(timeout_s) <= now:
                    del self.busy[worker]
                    worker.kill()
                    yield task, outcome_value(task, ("timeout", None), on_failure, timeout_s)

    def close(self) -> None:
        """Let idle workers exit; kill any still busy."""
        self.kill()

    def kill_now(self) -> None:
        """SIGKILL to every worker, nothing else: safe in a signal handler that interrupted ``kill``."""
        for worker in [*self.busy, *self.idle, *self.warming]:
            try:
                os.kill(worker.pid, signal.SIGKILL)
            except OSError:
                pass

    def kill(self) -> None:
        """End every worker now (SIGKILL to busy ones, end-of-file to idle ones)."""
        for worker in list(self.busy):
            worker.kill()
        self.busy.clear()
        for worker in self.warming:
            worker.kill()
        self.warming.clear()
        for worker in self.idle:
            worker.close()
        self.idle.clear()
