"""``foucault-bench seed``: the seed note's figures reproduced and corrected (``reports.seed``)."""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_OUT = Path("results") / "seed"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"output folder (default {DEFAULT_OUT}), replaced whole once the new one is complete; "
                             "an existing folder must be an earlier seed or report folder, or empty")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing --out folder that is not an earlier seed folder (its files are "
                             "lost)")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.bench.commands.outputs import output_folder

    output_folder(args.out, "--out", force=args.force, inputs={})
    from foucault_bench.reports.seed import write_seed

    return write_seed(args.out)
