"""``foucault-bench seed``: the seed note's figures reproduced and corrected (``reports.seed``)."""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_OUT = Path("results") / "seed"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")


def main(args: argparse.Namespace) -> int:
    from foucault_bench.reports.seed import write_seed

    return write_seed(args.out)
