"""Options several commands share, and the validation of their values (bad values: ``InputError``, exit 2)."""

from __future__ import annotations

import os

from foucault_bench.bench.errors import InputError


def default_jobs() -> int:
    """The cores this process may use (its CPU affinity where the platform has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def jobs(value: int | None) -> int:
    """The ``--jobs`` value to use: the cores available when not given; at least 1."""
    chosen = default_jobs() if value is None else value
    if chosen < 1:
        raise InputError(f"--jobs must be at least 1, got {chosen}")
    return chosen
