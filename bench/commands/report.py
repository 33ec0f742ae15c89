"""``foucault-bench report``: build the report folder from a results database (``reports.build``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from foucault_bench.bench.run.store import DEFAULT_DB  # the store module imports no numerical library

DEFAULT_OUT = Path("results") / "report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", type=Path, default=DEFAULT_DB, help=f"results database (default {DEFAULT_DB})")
    parser.add_argument("--matrix-id", default=None, help="matrix run id or unique prefix (default: the latest)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"report folder (default {DEFAULT_OUT})")
    parser.add_argument("--studies", choices=("stored", "recompute", "skip"), default="stored",
                        help="study tables: read from the database and compute missing ones (stored, default), "
                             "recompute all, or leave the study sections out (skip)")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.reports.build import write_report

    return write_report(args.db, args.matrix_id, args.out, args.studies)
