"""``foucault-bench run``: run a benchmark matrix and store one row per run (bench.run.runner, bench.run.store).

The matrix is validated completely before anything runs; every problem is reported (exit status 2). The
worker processes start before the matrix is read, so that their imports overlap with the validation.
"""

from __future__ import annotations

import argparse
import sys
import time

from foucault_bench.bench.commands import options
from foucault_bench.bench.commands.outputs import creatable
from foucault_bench.bench.errors import require_extra
from foucault_bench.bench.run.store import DEFAULT_DB  # the store module imports no numerical library
from foucault_bench.bench.validation import built_in_names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--matrix", default="default",
                        help=f"a built-in matrix name ({', '.join(built_in_names('matrices'))}) or a path to a "
                             "matrix TOML file (default: %(default)s)")
    parser.add_argument("--db", default=str(DEFAULT_DB), help="results database (SQLite; default: %(default)s)")
    parser.add_argument("--jobs", type=int, default=None,
                        help="worker processes, one single-threaded worker per core (default, and at most: the "
                             "cores available)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the latest run of the same matrix, skipping the runs already stored")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on a Dask distributed cluster (e.g. tcp://127.0.0.1:8786) instead of local workers "
                             "(needs the 'dask' extra)")
    parser.add_argument("--run-timeout", type=float, metavar="SECONDS",
                        help="per-run time limit, at most 1e6 s: a run past it is stopped and stored with status "
                             "timeout (default: the matrix's [timing] run_timeout_s, else 600 s)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def main(args: argparse.Namespace) -> int:
    if args.scheduler:
        require_extra("distributed", "dask", "--scheduler")
    creatable(args.db, "--db", folder=False)
    jobs = options.jobs(args.jobs)
    started = time.perf_counter()

    from foucault_bench.bench.run.runner import make_executor

    executor = make_executor(jobs, args.scheduler)  # first: workers start while the matrix is validated,
    try:                                            # and a bad address changes nothing
        from foucault_bench.bench.run.matrix import load_matrix, with_run_timeout
        from foucault_bench.bench.run.runner import run_matrix
        from foucault_bench.bench.run.store import ResultsStore
        from foucault_bench.bench.run.summary import summary_text

        matrix = with_run_timeout(load_matrix(args.matrix), args.run_timeout)
        where = f"Dask scheduler {args.scheduler}" if args.scheduler else f"{jobs} worker process(es)"
        print(f"matrix {matrix.name!r} ({matrix.source}): {len(matrix.runs)} runs on {len(matrix.scenes)} "
              f"scene(s), {where}, results in {args.db}", file=sys.stderr)
        store = ResultsStore(args.db)
    except BaseException:
        executor.kill()
        raise
    with store:
        matrix_id = run_matrix(matrix, store, executor=executor, resume=args.resume, progress=not args.no_progress)
        print(summary_text(store.records(matrix_id)))
    print(f"matrix run {matrix_id} finished in {time.perf_counter() - started:.1f} s "
          f"(`foucault-bench results --db {args.db}` lists stored runs)", file=sys.stderr)
    return 0
