"""CI's entry point (.ci/run) ends with the status of its steps: its exit trap, which stops the static checks
that run beside the tests, must neither turn a green run red nor a red one green.

The trap is taken from the script itself and run under the script's own shell options, after the checks ended by
themselves (the green run: nothing is left to stop, so ``pkill`` finds no process) and while they still run (a step
failed: they are stopped, and the step's status stays the run's)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CI_RUN = (ROOT / ".ci" / "run").read_text(encoding="utf-8")

pytestmark = pytest.mark.skipif(shutil.which("bash") is None or shutil.which("pkill") is None,
                                reason="needs bash and pkill, as .ci/run does")


def _script_lines(prefix: str) -> list[str]:
    return [line for line in CI_RUN.splitlines() if line.startswith(prefix)]


def _run_with_ci_trap(checks_command: str, last_step: str) -> subprocess.CompletedProcess[str]:
    """Run the script's options and exit trap around a stand-in for the checks (``lint_pid``) and a last step."""
    (options,) = _script_lines("set -")
    (trap,) = _script_lines("trap ")
    script = "\n".join([options, f"{checks_command} &", "lint_pid=$!", trap, last_step, "echo $lint_pid"])
    # a stand-in left running would hold the output pipe open until the timeout
    return subprocess.run(["bash", "-c", script], capture_output=True, text=True, timeout=60, check=False)


def test_a_green_run_stays_green_when_the_checks_ended_by_themselves() -> None:
    done = _run_with_ci_trap("true", 'wait "$lint_pid"')
    assert done.returncode == 0, done.stderr


def test_a_failing_step_keeps_its_status_and_the_checks_are_stopped() -> None:
    failed = _run_with_ci_trap("sleep 300", "exit 3")  # stopped, or the run times out
    assert failed.returncode == 3, failed.stderr
    assert failed.stdout == ""  # the script ended at the failing step
