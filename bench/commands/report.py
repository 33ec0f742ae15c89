"""``foucault-bench report``: build the report folder from a results database (``reports.build``)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from foucault_bench.bench.run.store import DEFAULT_DB  # the store module imports no numerical library

DEFAULT_OUT = Path("results") / "report"
DEFAULT_TARGETS = (1e-3, 1e-6, 1e-9, 1e-12)
"""Target reference errors of the matched-accuracy summary (``reports.build.DEFAULT_TARGETS``, kept equal by
tests/test_cli.py)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", type=Path, default=DEFAULT_DB, help=f"results database (default {DEFAULT_DB})")
    parser.add_argument("--matrix-id", default=None, help="matrix run id or unique prefix (default: the latest)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"report folder (default {DEFAULT_OUT}), replaced whole once the new report is "
                             "complete; an existing folder must be an earlier report or seed folder, or empty")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing --out folder that is not an earlier report (its files are lost)")
    parser.add_argument("--studies", choices=("stored", "recompute", "skip"), default="stored",
                        help="study tables: read from the database and compute missing ones (stored, default), "
                             "recompute all, or leave the study sections out, the seed note's too (skip)")
    parser.add_argument("--targets", type=float, nargs="+", default=list(DEFAULT_TARGETS), metavar="ERROR",
                        help="target reference errors of the matched-accuracy summary (default: "
                             f"{' '.join(f'{t:g}' for t in DEFAULT_TARGETS)})")
    parser.add_argument("--static", action="store_true",
                        help="also write every chart as PNG and SVG under figures/ (for papers; REPORT.md then "
                             "shows them); without it the charts are interactive in index.html only")
    parser.add_argument("--jobs", type=int, default=None,
                        help="worker processes computing the missing studies, drawing the figures and writing the table "
                             "files (default: the number of CPUs)")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.commands.outputs import output_folder
    from foucault_bench.bench.errors import InputError

    problems = [f"--targets: a target error must be a finite number > 0, got {target:g}"
                for target in args.targets if not (math.isfinite(target) and target > 0)]
    if args.jobs is not None and args.jobs < 1:
        problems.append(f"--jobs: the number of worker processes must be ≥ 1, got {args.jobs}")
    if problems:
        raise InputError(problems)
    output_folder(args.out, "--out", force=args.force, inputs={"--db": args.db})
    from foucault_bench.reports.build import write_report

    return write_report(args.db, args.matrix_id, args.out, args.studies, tuple(args.targets), static=args.static,
                        jobs=args.jobs or os.cpu_count() or 1)
