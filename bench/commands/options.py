"""Options several commands share, and the validation of their values (bad values: ``InputError``, exit 2)."""

from __future__ import annotations

import sys

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.provenance import available_cores


def jobs(value: int | None) -> int:
    """The ``--jobs`` value to use: the cores available when not given; at least 1; more than the cores available
    is capped to them with a note (runs are single-threaded and CPU-bound: more workers only share the cores)."""
    cores = available_cores()
    if value is None:
        return cores
    if value < 1:
        raise InputError(f"--jobs must be at least 1, got {value}")
    if value > cores:
        print(f"note: --jobs {value} is more than the {cores} core(s) available: using {cores}", file=sys.stderr)
        return cores
    return value
