"""Errors the command line reports without a traceback (exit status 2), and the check for optional extras."""

from __future__ import annotations

import sqlite3
import sys


class InputError(Exception):
    """Bad user input (matrix, thresholds, arguments): one message per problem, nothing has run yet."""

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__("\n".join(self.problems))


class RunInterrupted(Exception):
    """A matrix run stopped for a reason outside any run (its Dask cluster went away): the matrix run is stored
    as ``interrupted``, the message says why, and ``--resume`` completes it. Exit status 75 (EX_TEMPFAIL,
    sysexits.h: a temporary failure, try again)."""

    exit_status = 75


def is_full_disk(error: BaseException) -> bool:
    """``error`` says the disk (or the user's quota) is full: ``OSError`` ENOSPC or EDQUOT, or SQLite's
    SQLITE_FULL ("database or disk is full")."""
    import errno
    import sqlite3

    if isinstance(error, OSError):
        return error.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC))
    return isinstance(error, sqlite3.Error) and getattr(error, "sqlite_errorcode", None) == sqlite3.SQLITE_FULL


def database_error_types() -> tuple[type[BaseException], ...]:
    """The errors of reading or writing an SQLite file: ``sqlite3.DatabaseError`` (a damaged file, a full disk,
    a locked or read-only database), and pandas' ``DatabaseError``, which ``read_sql_query`` raises from one,
    once pandas is loaded (nothing here imports it)."""
    pandas_errors = sys.modules.get("pandas.errors")
    pandas_error = getattr(pandas_errors, "DatabaseError", None)
    return (sqlite3.DatabaseError,) + ((pandas_error,) if pandas_error is not None else ())


def require_extra(module: str, extra: str, feature: str) -> None:
    """Raise ``InputError`` naming the package extra that provides ``module`` when it is not installed, e.g.
    ``--scheduler needs the 'dask' extra: pip install 'foucault-bench[dask]'``."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise InputError(f"{feature} needs the {extra!r} extra: pip install 'foucault-bench[{extra}]'")
