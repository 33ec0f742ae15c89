"""Temporary git repositories for the tests of bisect and the paired cost gate: ``git`` runs a git command with a
fixed identity and no user configuration, ``one_commit_repository`` makes a repository holding one commit."""

from __future__ import annotations

import subprocess
from pathlib import Path

IDENTITY = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
            "GIT_COMMITTER_EMAIL": "t@t", "PATH": "/usr/bin:/bin"}


def git(repository: Path, *arguments: str) -> str:
    """``git ARGUMENTS`` in ``repository``; its standard output, stripped."""
    return subprocess.run(["git", *arguments], cwd=repository, check=True, capture_output=True, text=True,
                          env=IDENTITY).stdout.strip()


def one_commit_repository(folder: Path) -> Path:
    """``folder`` made a git repository with one commit of one file."""
    folder.mkdir()
    git(folder, "init", "-q")
    (folder / "f").write_text("x", encoding="utf-8")
    git(folder, "add", "-A")
    git(folder, "commit", "-q", "-m", "one")
    return folder
