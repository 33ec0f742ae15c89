"""One writer per matrix run: an advisory lock held while a process writes rows under a matrix id.

The lock is a POSIX record lock (``fcntl.lockf``, fcntl(2) F_SETLK) on one byte of a lock file next to the
database (``DATABASE.lock``), at an offset derived from the matrix id, so that any number of matrix runs of one
database can be locked independently. The kernel releases it when the process ends, however it ends
(``kill -9`` included): a lock is never left stale. Where ``fcntl`` does not exist (Windows) nothing is locked.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

LOCK_SPACE = 2**31 - 1
"""Byte offsets used for locks (a matrix id's offset is its SHA-256 modulo this)."""


class MatrixRunLocked(Exception):
    """Another process is writing to this matrix run."""


_HELD: dict[str, tuple[int, set[int]]] = {}
"""Per lock file: this process's one descriptor and the offsets it holds. POSIX record locks belong to the
process (a second lock of the same byte by the same process succeeds, and closing any descriptor of the file
drops all of them), so the process keeps one descriptor per file and refuses a second lock itself."""


class MatrixRunLock:
    """Exclusive lock on one matrix run of the database at ``database`` (see the module docstring)."""

    def __init__(self, database: Path, matrix_id: str):
        self.path = str(Path(f"{database}.lock").resolve())
        self.offset = int.from_bytes(hashlib.sha256(matrix_id.encode()).digest()[:8], "big") % LOCK_SPACE
        self.held = False

    def acquire(self) -> None:
        """Take the lock at once or raise ``MatrixRunLocked``."""
        if fcntl is None:
            return
        if self.path not in _HELD:
            _HELD[self.path] = (os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644), set())
        descriptor, offsets = _HELD[self.path]
        if self.offset in offsets:
            raise MatrixRunLocked()
        try:
            fcntl.lockf(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB, 1, self.offset)
        except OSError:
            self._forget_file_if_unused()
            raise MatrixRunLocked() from None
        offsets.add(self.offset)
        self.held = True

    def release(self) -> None:
        if not self.held:
            return
        descriptor, offsets = _HELD[self.path]
        fcntl.lockf(descriptor, fcntl.LOCK_UN, 1, self.offset)
        offsets.discard(self.offset)
        self.held = False
        self._forget_file_if_unused()

    def _forget_file_if_unused(self) -> None:
        descriptor, offsets = _HELD[self.path]
        if not offsets:
            os.close(descriptor)
            del _HELD[self.path]
