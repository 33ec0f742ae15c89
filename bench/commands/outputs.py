"""Checks of the paths a command will write (``--db``, ``--csv``, ``--parquet``, ``--junit``, ``--markdown``,
``--out``), made before any work starts, so that a matrix never runs for a file it cannot write and no output
replaces an input or a folder of the user's. Each problem is an ``InputError`` (one line, exit status 2). The
writing itself goes through ``bench.atomic``."""

from __future__ import annotations

import os
from pathlib import Path

from foucault_bench.bench.atomic import MARKER, read_marker, real_path, recover
from foucault_bench.bench.errors import InputError

DATABASE_COMPANIONS = ("-wal", "-shm", "-journal")
"""Files SQLite keeps beside a database (write-ahead log, its shared memory, the rollback journal)."""


SQLITE_HEADER = b"SQLite format 3\x00"
"""The first 16 bytes of every SQLite database file (sqlite.org/fileformat.html, "The Database Header")."""


def _is_database(path: Path) -> bool:
    """Whether ``path`` is a regular file that starts with ``SQLITE_HEADER`` (a pipe or a device is never read)."""
    if not path.is_file():
        return False
    try:
        with path.open("rb") as file:
            return file.read(len(SQLITE_HEADER)) == SQLITE_HEADER
    except OSError:
        return False


def output_file(path: str | Path, option: str) -> Path:
    """A file the command will create or replace: not a folder, in an existing folder it may write to, and never
    a SQLite database or one of the files SQLite keeps beside one (``DATABASE_COMPANIONS``): a results database
    is not an output any command writes as a file."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{option} {path}: is a folder; give a file name")
    if _is_database(path):
        raise InputError(f"{option} {path}: is a SQLite database, which writing it would destroy; give another file")
    for suffix in DATABASE_COMPANIONS:
        database = path.with_name(path.name.removesuffix(suffix))
        if path.name.endswith(suffix) and _is_database(database):
            raise InputError(f"{option} {path}: is SQLite's {suffix} file of the database {database}; give another "
                             "file")
    if path.exists():
        if not os.access(path, os.W_OK):
            raise InputError(f"{option} {path}: the file is not writable")
        return path
    folder = path.parent
    if not folder.exists():
        raise InputError(f"{option} {path}: the folder {folder} does not exist")
    if not folder.is_dir():
        raise InputError(f"{option} {path}: {folder} is not a folder")
    if not os.access(folder, os.W_OK):
        raise InputError(f"{option} {path}: cannot write in the folder {folder}")
    return path


def creatable(path: str | Path, option: str, *, folder: bool) -> Path:
    """A file (``folder`` false) or folder (``folder`` true) the command creates together with any missing
    parent folders: what exists of it must be of that kind, and its nearest existing ancestor a writable
    folder."""
    path = Path(path)
    if path.exists():
        if folder and not path.is_dir():
            raise InputError(f"{option} {path}: exists and is not a folder")
        if not folder and path.is_dir():
            raise InputError(f"{option} {path}: is a folder; give a file name")
        return path
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"{option} {path}: {ancestor} is a file, not a folder")
    if not os.access(ancestor, os.W_OK):
        raise InputError(f"{option} {path}: cannot create folders in {ancestor}")
    return path


def _same_file(first: Path, second: Path) -> bool:
    """One file under two names: hard links and symlinks (``os.path.samefile``) when both exist, else the
    same resolved path."""
    try:
        return os.path.samefile(first, second)
    except OSError:
        return real_path(first) == real_path(second)


def distinct_from_inputs(outputs: dict[str, str | Path | None], inputs: dict[str, str | Path | None], *,
                         databases: tuple[str, ...] = ()) -> None:
    """Refuse an output that is one of the inputs or another output (same file by any name): option → path, a
    ``None`` path is ignored; the inputs named in ``databases`` count with their SQLite companions
    (``DATABASE_COMPANIONS``)."""
    named = [(option, Path(path)) for option, path in inputs.items() if path is not None]
    named += [(f"{option}'s {suffix} file", Path(f"{path}{suffix}")) for option, path in inputs.items()
              if path is not None and option in databases for suffix in DATABASE_COMPANIONS]
    problems = []
    earlier_outputs: list[tuple[str, Path]] = []
    for option, path in ((option, Path(path)) for option, path in outputs.items() if path is not None):
        for other, other_path in named + earlier_outputs:
            if _same_file(path, other_path):
                problems.append(f"{option} {path}: is the same file as {other} {other_path}; writing it would "
                                "destroy that one: give another file")
                break
        earlier_outputs.append((option, path))
    if problems:
        raise InputError(problems)


def _home() -> Path | None:
    try:
        return real_path(Path.home())
    except (KeyError, RuntimeError):  # no HOME and no password entry: no home folder to protect
        return None


def output_folder(path: str | Path, option: str, *, force: bool, inputs: dict[str, str | Path | None]) -> Path:
    """A folder the command replaces whole (``bench.atomic.replacing_folder``), checked before any work: not a
    file nor under one, in a folder it may write to; if it exists and is not empty, it must hold the marker of an
    earlier report or seed (``bench.atomic.MARKER``) unless ``force``; never (even with ``force``) the file
    system's root, the home folder, the current folder or one of its ancestors, or a folder holding an input."""
    path = Path(path)
    creatable(path, option, folder=True)
    target = real_path(path)
    recover(target)  # a build killed while swapping folders left the previous one aside: put it back first
    if target == Path(target.anchor):
        raise InputError(f"{option} {path}: is the root of the file system; give a folder of its own")
    if target == _home():
        raise InputError(f"{option} {path}: is the home folder; give a folder of its own")
    if real_path(Path.cwd()).is_relative_to(target):
        raise InputError(f"{option} {path}: holds the current folder; give a folder of its own")
    for name, input_path in inputs.items():
        if input_path is not None and real_path(input_path).is_relative_to(target):
            raise InputError(f"{option} {path}: holds {name} {input_path}, which replacing the folder would "
                             "delete; give another folder")
    parent = target.parent
    if target.is_dir() and not os.access(parent, os.W_OK):
        raise InputError(f"{option} {path}: cannot replace it, the folder {parent} is not writable")
    try:
        holds_files = target.is_dir() and any(target.iterdir())
    except OSError as error:
        raise InputError(f"{option} {path}: cannot read the folder ({error.strerror or error})") from None
    if holds_files and not force and read_marker(target) is None:
        raise InputError(f"{option} {path}: exists and was not written by foucault-bench report or seed (no "
                         f"{MARKER} file in it); give an empty or new folder, or --force to replace it whole")
    return path
