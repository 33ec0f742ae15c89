"""The Dask executor: the runner's tasks on a Dask distributed cluster, each in a worker process it can end.

``DaskExecutor`` (the interface: ``bench.run.executors``): each Dask task runs its work in a worker process of
the Dask worker it lands on (``run_isolated``; one per Dask worker thread, reused), so a run past its time
limit is killed there and the Dask worker is free again at once; a task whose matrix run was given up (the
client went away) kills its worker process within a second. Before any task is sent, every Dask worker's code
version (``bench.run.matrix.code_version``) is compared with the client's; workers running other code are not
used, and each worker process checks its own version again before its first task. The cluster is watched
while the matrix runs: losing the scheduler (noticed as soon as its connection closes; an unresponsive one
after ``SCHEDULER_SILENT_S``) or every usable worker (for ``WORKERS_GONE_S``) stops the matrix with
``bench.errors.RunInterrupted``, and a run whose Dask worker died is not stored (``lost_runs``), so that
``--resume`` completes the matrix.

``distributed`` is imported only when an executor is made (the ``dask`` extra).
"""

from __future__ import annotations

import asyncio
import sys
import threading
import time
import uuid
from typing import Any, Callable, Iterator

from foucault_bench.bench.errors import InputError, RunInterrupted
from foucault_bench.bench.run.executors import ATTEMPTS, outcome_value
from foucault_bench.bench.run.worker import IDLE_EXIT_S, WorkerProcess

DASK_CONNECT_TIMEOUT_S = 10.0
SCHEDULER_SILENT_S = 30.0
WORKERS_GONE_S = 30.0
HEALTH_EVERY_S = 2.0
CODE_CHECK_TIMEOUT_S = 120.0


class CodeMismatch(Exception):
    """A Dask worker's process imports other code than the client."""


def worker_code_version(plugins: tuple[str, ...]) -> str:
    """This process's code version (``bench.run.matrix.code_version``), for the check against the client's."""
    from foucault_bench.bench.run.matrix import code_version

    return code_version(tuple(plugins))


_THREAD = threading.local()


def run_isolated(function: Callable, task: tuple, timeout_s: float | None, on_failure: Callable,
                 expected_code: str, plugins: tuple[str, ...]) -> Any:
    """A Dask task: ``function(*task)`` in this Dask worker thread's worker process (see the module docstring).
    Raises ``CodeMismatch`` if that process runs other code than the client."""
    worker: WorkerProcess | None = getattr(_THREAD, "worker", None)
    stop = _task_released()
    for attempt in range(1, ATTEMPTS + 1):
        if worker is None or not worker.alive() or time.monotonic() - worker.last_used > IDLE_EXIT_S / 2:
            if worker is not None:
                worker.kill()
            worker = _THREAD.worker = WorkerProcess()
            kind, version = worker.call(worker_code_version, (plugins,), CODE_CHECK_TIMEOUT_S, stop)
            worker.code_version = version if kind == "ok" else f"unknown ({kind}: {version})"
        if worker.code_version != expected_code:
            raise CodeMismatch(f"its worker process has code version {worker.code_version}, the client "
                               f"{expected_code}")
        outcome = worker.call(function, task, timeout_s, stop)
        if outcome[0] in ("ok", "error"):
            return outcome_value(task, outcome, on_failure, timeout_s)
        _THREAD.worker = worker = None
        if outcome[0] in ("timeout", "stopped") or attempt == ATTEMPTS:
            return outcome_value(task, outcome, on_failure, timeout_s)
    raise AssertionError("not reached")


def _task_released() -> Callable[[], bool]:
    """A test whether the current Dask task was cancelled or forgotten (its client went away)."""
    try:
        from distributed import get_worker

        dask_worker = get_worker()
        key = dask_worker.get_current_task()
    except (ImportError, ValueError):
        return lambda: False

    def released() -> bool:
        state = dask_worker.state.tasks.get(key)
        return state is None or state.state in ("cancelled", "released", "forgotten")

    return released


def _probe_scheduler(address: str, timeout_s: float) -> Any:
    """Parse ``address``, check the TLS settings it needs, and ask it for its identity within ``timeout_s``;
    return the ``distributed.security.Security`` to connect with. ``InputError`` (one line) otherwise."""
    from distributed.comm import connect, parse_address
    from distributed.core import send_recv
    from distributed.security import Security

    where = f"--scheduler {address!r}"
    try:
        scheme, _ = parse_address(address)
        from distributed.comm.registry import get_backend

        get_backend(scheme)
    except (ValueError, TypeError) as error:
        raise InputError(f"{where}: not a Dask scheduler address: {error}") from None
    security = Security()
    arguments = security.get_connection_args("client")
    if scheme in ("tls", "wss") and arguments.get("ssl_context") is None:
        raise InputError(f"{where}: a {scheme}:// address needs TLS settings (the Dask configuration's "
                         "distributed.comm.tls.ca-file and distributed.comm.tls.client.cert/key)")

    async def identity() -> Any:
        comm = await connect(address, timeout=timeout_s, **arguments)
        try:
            return await send_recv(comm, op="identity")
        finally:
            comm.abort()

    async def bounded() -> Any:
        return await asyncio.wait_for(identity(), timeout_s)

    try:
        reply = asyncio.run(bounded())
    except (asyncio.TimeoutError, TimeoutError):
        raise InputError(f"{where}: cannot connect to the Dask scheduler: no answer within {timeout_s:g} s") from None
    except ValueError as error:  # an address distributed cannot resolve
        raise InputError(f"{where}: not a Dask scheduler address: {error}") from None
    except Exception as error:  # refused, reset, garbage: whatever it is, it is not a usable scheduler
        raise InputError(f"{where}: cannot connect to the Dask scheduler: "
                         f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise InputError(f"{where}: the service there is not a Dask scheduler")
    return security


class DaskExecutor:
    """The same work on a Dask distributed cluster (see the module docstring)."""

    jobs = None

    def __init__(self, address: str):
        from distributed import Client

        security = _probe_scheduler(address, DASK_CONNECT_TIMEOUT_S)
        try:
            self.client = Client(address, timeout=f"{DASK_CONNECT_TIMEOUT_S}s", set_as_default=False,
                                 security=security)
        except Exception as error:
            raise InputError(f"--scheduler {address!r}: cannot connect to the Dask scheduler: {error}") from None
        self.scheduler = address
        self.workers: list[str] = []
        self.code = ""
        self.plugins: tuple[str, ...] = ()
        self.lost_runs = 0

    def check_code(self, matrix: Any) -> None:
        """Use only the workers whose code version equals the client's; ``InputError`` if there is none."""
        from foucault_bench.bench.run.matrix import code_version

        self.plugins = matrix.plugins
        self.code = code_version(matrix.plugins)
        try:
            self.client.wait_for_workers(1, timeout=DASK_CONNECT_TIMEOUT_S)
        except Exception:
            raise InputError(f"--scheduler {self.scheduler!r}: no Dask worker joined within "
                             f"{DASK_CONNECT_TIMEOUT_S:g} s") from None
        versions = self.client.run(worker_code_version, self.plugins, on_error="return")
        self.workers = sorted(address for address, version in versions.items() if version == self.code)
        for address, version in sorted(versions.items()):
            if version != self.code:
                found = version if isinstance(version, str) else f"{type(version).__name__}: {version}"
                print(f"note: Dask worker {address} is not used: it runs other code ({found}; this client: "
                      f"{self.code})", file=sys.stderr)
        if not self.workers:
            raise InputError(f"--scheduler {self.scheduler!r}: no Dask worker runs this client's code (code "
                             f"version {self.code}); install the same foucault-bench and plug-ins on the workers")

    def map_unordered(self, function: Callable, tasks: list[tuple], on_failure: Callable,
                      timeout_s: float | None) -> Iterator[tuple[tuple, Any]]:
        from distributed import as_completed

        prefix = f"{getattr(function, '__name__', 'task')}-{uuid.uuid4().hex[:8]}"
        futures = {
            self.client.submit(run_isolated, function, task, timeout_s, on_failure, self.code, self.plugins,
                               key=f"{prefix}-{index}", pure=False, priority=len(tasks) - index,
                               workers=self.workers, allow_other_workers=False): task
            for index, task in enumerate(tasks)
        }
        pending = as_completed(futures, loop=self.client.loop)
        watch = _ClusterWatch(self)
        left = len(futures)
        while left:
            batch = pending.next_batch(block=False)
            if not batch:
                watch.check()
                time.sleep(0.2)
                continue
            for future in batch:
                task = futures[future]
                if future.status == "finished":
                    try:
                        value = future.result(timeout=HEALTH_EVERY_S)
                    except TimeoutError:  # its result was on a worker that died: Dask computes it again
                        pending.add(future)
                        watch.check()
                        continue
                    yield task, value
                elif future.status == "error":
                    error = future.exception()
                    if isinstance(error, CodeMismatch):
                        raise RunInterrupted(f"a Dask worker runs other code than this client: {error}")
                    self.lost_runs += 1
                    print(f"note: a run was lost with its Dask worker ({type(error).__name__}: {error}); "
                          "it is not stored", file=sys.stderr)
                elif future.status == "cancelled":  # the client cancels every future when it loses the scheduler
                    watch.check(lost=True)
                else:  # lost with its worker: Dask computes it again once a usable worker can take it
                    pending.add(future)
                    watch.check()
                    time.sleep(0.2)
                    continue
                left -= 1
                del futures[future]
                future.release()

    def close(self) -> None:
        self.client.close(timeout=DASK_CONNECT_TIMEOUT_S)

    def kill_now(self) -> None:
        """Nothing to do before the process exits: the scheduler forgets the runs of a client that is gone."""

    def kill(self) -> None:
        try:
            self.client.close(timeout=2)
        except Exception:  # closing a client whose scheduler is gone: nothing left to end
            pass


class _ClusterWatch:
    """Raises ``RunInterrupted`` when the scheduler or every usable worker is gone (see the module docstring)."""

    def __init__(self, executor: DaskExecutor):
        self.executor = executor
        self.last_check = 0.0
        self.last_answer = time.monotonic()
        self.last_worker = time.monotonic()

    def check(self, lost: bool = False) -> None:
        client = self.executor.client
        where = f"the Dask scheduler at {self.executor.scheduler}"
        if client.status != "running":
            raise RunInterrupted(f"lost the connection to {where} (`--resume` continues the matrix)")
        if lost:
            raise RunInterrupted(f"{where} cancelled the runs (`--resume` continues the matrix)")
        now = time.monotonic()
        if now - self.last_check < HEALTH_EVERY_S:
            return
        self.last_check = now
        try:
            identity = client.sync(client.scheduler.identity, callback_timeout=HEALTH_EVERY_S)
        except Exception:  # a scheduler that does not answer: given a grace period
            if now - self.last_answer > SCHEDULER_SILENT_S:
                raise RunInterrupted(f"{where} has not answered for {SCHEDULER_SILENT_S:g} s") from None
            return
        self.last_answer = now
        if set(identity.get("workers", {})) & set(self.executor.workers):
            self.last_worker = now
        elif now - self.last_worker > WORKERS_GONE_S:
            raise RunInterrupted(f"every usable Dask worker of {where} has been gone for {WORKERS_GONE_S:g} s "
                                 "(`--resume` continues the matrix)")
