"""What an executor is: the interface the runner hands its tasks to, and what a task that gave no result yields.

Two executors implement it: ``bench.run.local_executor.LocalExecutor`` (worker processes on this machine) and
``bench.run.dask_executor.DaskExecutor`` (a Dask distributed cluster); ``bench.run.runner.make_executor``
chooses one. Both offer ``map_unordered(function, tasks, on_failure, timeout_s)``, which yields
``(task, function(*task))`` as results arrive, or ``(task, on_failure(*task, status=..., reason=...))`` for a
task that did not give a result: its worker died twice (``WORKER_DIED``) or it passed ``timeout_s``
(status ``timeout``). Every task runs in a ``bench.run.worker.WorkerProcess``, so that it can be ended.
"""

from __future__ import annotations

from typing import Any, Callable, Iterator, Protocol, cast

from foucault_bench.bench.schema import STATUS_TIMEOUT

WORKER_DIED = "the worker process died during this run (crash in native code or killed, e.g. out of memory)"
STATUS_FAILED = "failed"
ATTEMPTS = 2
"""A task whose worker dies is tried at most this many times, each time in a fresh worker."""


class Executor(Protocol):
    """Where the runner's tasks run (see the module docstring)."""

    @property
    def jobs(self) -> int | None:
        """Local worker processes; ``None`` on a Dask cluster."""

    @property
    def scheduler(self) -> str | None:
        """The Dask scheduler's address; ``None`` for local workers."""

    def check_code(self, matrix: Any) -> None:
        """Refuse (``InputError``) to run where the workers would run other code than this process."""

    def map_unordered(self, function: Callable, tasks: list[tuple], on_failure: Callable,
                      timeout_s: float | None) -> Iterator[tuple[tuple, Any]]:
        """``(task, value)`` per task as each finishes (see the module docstring)."""

    def close(self) -> None:
        """The matrix run finished: release the workers."""

    def kill(self) -> None:
        """The matrix run was interrupted: end every worker now."""

    def kill_now(self) -> None:
        """Only what is safe in a signal handler that interrupted ``kill``."""


def timeout_message(timeout_s: float) -> str:
    return (f"stopped at the per-run time limit of {timeout_s:g} s "
            "(raise it with --run-timeout or run_timeout_s under [timing])")


def outcome_value(task: tuple, outcome: tuple[str, Any], on_failure: Callable, timeout_s: float | None) -> Any:
    """The value a finished task yields (its result, or ``on_failure``'s for an error or a timeout)."""
    kind, value = outcome
    if kind == "ok":
        return value
    if kind == "timeout":
        return on_failure(*task, status=STATUS_TIMEOUT, reason=timeout_message(cast(float, timeout_s)))
    if kind == "died":
        return on_failure(*task, status=STATUS_FAILED, reason=WORKER_DIED)
    return on_failure(*task, status=STATUS_FAILED, reason=f"worker: {value}")
