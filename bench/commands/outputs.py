"""Checks of the paths a command will write (``--db``, ``--csv``, ``--parquet``, ``--junit``, ``--out``), made
before any work starts, so that a matrix never runs for a file it cannot write. Each problem is an
``InputError`` (one line, exit status 2)."""

from __future__ import annotations

import os
from pathlib import Path

from foucault_bench.bench.errors import InputError


def output_file(path: str | Path, option: str) -> Path:
    """A file the command will create or replace: not a folder, in an existing folder it may write to."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{option} {path}: is a folder; give a file name")
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
