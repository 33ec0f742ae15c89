"""Writing outputs so that a kill or a full disk never leaves a half-written file or folder, nor loses the old one.

A file (``replacing_file``) is written to a temporary file in its own folder (``.NAME.partial-PID-…``), flushed
to disk (fsync) and renamed over the target (``os.replace``: atomic on POSIX): a reader sees the old file or the
new one, whole. A folder (``replacing_folder``: a report, the seed figures) is built in a staging folder beside
the target (``.NAME.building-PID-…``, on the same file system), marked as finished (``MARKER``, written last) and
swapped in by two renames: target → backup (``.NAME.previous-PID-…``), staging → target, then the backup is
removed. Between the two renames (microseconds) the target is missing; a process killed there leaves the backup
and the staging folder whole, and ``recover`` (run before every replacement, and by the command's checks) renames
the backup back. Leftovers carry the writing process's id and are removed once that process has ended, never
before, so concurrent writers never remove each other's files.

A write that fails with ``OSError`` (a full disk, ENOSPC or EDQUOT; a folder made read-only meanwhile) removes
what it wrote and raises ``InputError`` with one line: exit status 2, no traceback, the old output unchanged.
The folders' files are not fsynced one by one: a kill loses nothing, a power cut may.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import stat
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import Iterator

from foucault_bench.bench.errors import InputError

MARKER = ".foucault-bench-report"
"""The file a finished report or seed folder holds: JSON saying which command wrote it (``read_marker``). Only a
folder with it (or an empty one) is replaced without ``--force``."""

_PARTIAL, _BUILDING, _PREVIOUS = "partial", "building", "previous"
"""Kinds of temporary entries beside a target: a file being written, a folder being built, the folder replaced."""


def real_path(path: str | Path) -> Path:
    """``path`` absolute, with every symlink of it resolved (as far as it exists): writing through a symlink
    replaces what it points to, and the symlink stays."""
    return Path(os.path.realpath(os.path.abspath(path)))


def _failure(option: str, path: Path, error: OSError, what: str) -> InputError:
    reason = error.strerror or str(error)
    return InputError(f"{option} {path}: cannot write it ({reason}); {what}")


def _fsync_folder(folder: Path) -> None:
    """Make a rename in ``folder`` durable (POSIX: fsync of the directory); not possible on every system."""
    try:
        descriptor = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)


@contextmanager
def replacing_file(path: str | Path, option: str) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write the new file to (by name: ``frame.to_csv(temporary)``);
    when the block ends, the file is fsynced and renamed over ``path``. An ``OSError`` inside the block or while
    finishing removes the temporary file and raises ``InputError`` naming ``option``; the old file is unchanged.
    The new file keeps the old one's permissions (else the umask's). A ``path`` that exists and is not a regular
    file (``/dev/stdout``, a named pipe) is written directly: a stream cannot be replaced."""
    if Path(path).exists() and not Path(path).is_file():  # a stream (/dev/stdout, a pipe): written as it goes
        try:
            yield Path(path)
        except BrokenPipeError:  # the reader went away: bench.cli ends quietly
            raise
        except OSError as error:
            raise _failure(option, Path(path), error, "what was written so far stays") from None
        return
    target = real_path(path)
    for leftover in _leftovers(target, _PARTIAL):
        leftover.unlink(missing_ok=True)
    temporary = target.parent / _leftover_name(target, _PARTIAL)
    try:
        os.close(os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        if target.exists():
            os.chmod(temporary, stat.S_IMODE(target.stat().st_mode))
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise _failure(option, Path(path), error, "nothing was written") from None
    try:
        yield temporary
        descriptor = os.open(temporary, os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)
        os.replace(temporary, target)
    except OSError as error:
        raise _failure(option, Path(path), error, "any earlier file there is unchanged") from None
    finally:
        temporary.unlink(missing_ok=True)
    _fsync_folder(target.parent)


def write_text_file(path: str | Path, text: str, option: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through ``replacing_file``."""
    with replacing_file(path, option) as temporary:
        temporary.write_text(text, encoding="utf-8")


# --------------------------------------------------------------------------------------------------------------
# folders
# --------------------------------------------------------------------------------------------------------------
def read_marker(folder: Path) -> dict | None:
    """The marker's content when ``folder`` holds a valid one (a JSON object written by ``replacing_folder``),
    else None."""
    try:
        content = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return content if isinstance(content, dict) and content.get("written_by") == "foucault-bench" else None


def _leftover_name(target: Path, kind: str) -> str:
    return f".{target.name}.{kind}-{os.getpid()}-{secrets.token_hex(4)}"


def _leftovers(target: Path, kind: str) -> list[Path]:
    """Leftovers of ``kind`` beside ``target`` (files for ``_PARTIAL``, else folders) whose writing process has
    ended."""
    prefix = f".{target.name}.{kind}-"
    found = []
    try:
        entries = list(target.parent.iterdir())
    except OSError:
        return []
    for entry in entries:
        if not entry.name.startswith(prefix):
            continue
        pid_text = entry.name[len(prefix):].split("-", 1)[0]
        right_kind = entry.is_file() if kind == _PARTIAL else entry.is_dir()
        if pid_text.isdigit() and not _process_alive(int(pid_text)) and right_kind and not entry.is_symlink():
            found.append(entry)
    return sorted(found)


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. EPERM: it exists, owned by someone else
        return True
    return True


def recover(path: str | Path) -> None:
    """Repair what a killed ``replacing_folder`` left beside folder ``path``: a missing target comes back from
    its backup (the previous folder, whole); other backups and unfinished staging folders of ended processes are
    removed. Does nothing when there is nothing to repair (or the folder cannot be written)."""
    target = real_path(path)
    backups = _leftovers(target, _PREVIOUS)
    if backups and not os.path.lexists(target):
        try:
            os.rename(backups.pop(), target)
        except OSError:
            return
    for leftover in backups + _leftovers(target, _BUILDING):
        shutil.rmtree(leftover, ignore_errors=True)


@contextmanager
def replacing_folder(path: str | Path, option: str, command: str) -> Iterator[Path]:
    """Yield an empty staging folder beside folder ``path`` (missing parents are created) to build the new folder
    in; when the block ends, the marker (``MARKER``, naming ``command``) is written into it and it replaces
    ``path`` whole (module docstring). Any exception inside the block removes the staging folder; an ``OSError``
    (full disk, read-only folder) becomes an ``InputError`` naming ``option``. Whether ``path`` may be replaced
    is for the caller to check first (``bench.commands.outputs.output_folder``)."""
    target = real_path(path)
    recover(target)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        staging = target.parent / _leftover_name(target, _BUILDING)
        staging.mkdir()
    except OSError as error:
        raise _failure(option, Path(path), error, "nothing was written") from None
    try:
        yield staging
        (staging / MARKER).write_text(json.dumps(_marker_content(command)) + "\n", encoding="utf-8")
        _swap(staging, target)
    except OSError as error:
        raise _failure(option, Path(path), error, "any earlier folder there is unchanged") from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _marker_content(command: str) -> dict[str, str]:
    from foucault_bench.bench.provenance import package_version

    return {"written_by": "foucault-bench", "command": command, "version": package_version(),
            "written_utc": datetime.now(timezone.utc).isoformat(timespec="seconds")}


def _swap(staging: Path, target: Path) -> None:
    """Rename ``staging`` to ``target``, moving an existing ``target`` aside first and removing it after."""
    backup = None
    if os.path.lexists(target):
        backup = target.parent / _leftover_name(target, _PREVIOUS)
        try:
            os.rename(target, backup)
        except FileNotFoundError:  # another run of the command swapping the same folder at this moment
            backup = None
    try:
        os.rename(staging, target)
    except OSError:
        if backup is not None:
            os.rename(backup, target)
        raise
    _fsync_folder(target.parent)
    if backup is not None:
        shutil.rmtree(backup, ignore_errors=True)
