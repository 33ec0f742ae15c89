"""Options several commands share, and the validation of their values (bad values: ``InputError``, exit 2)."""

from __future__ import annotations

from foucault_bench.bench.errors import InputError
from foucault_bench.bench.run.provenance import available_cores


def jobs(value: int | None) -> int:
    """The ``--jobs`` value to use: the cores available when not given; at least 1."""
    chosen = available_cores() if value is None else value
    if chosen < 1:
        raise InputError(f"--jobs must be at least 1, got {chosen}")
    return chosen
