"""The command line itself: light to start, every command's options in bench.commands, extras named when missing."""

from __future__ import annotations

import subprocess
import sys

import pytest

from foucault_bench.bench.cli import main as cli_main
from foucault_bench.bench.commands import COMMANDS

HEAVY_MODULES = ("numpy", "pandas", "matplotlib", "plotly", "scipy", "numba", "heyoka", "sksundae", "distributed",
                 "foucault_bench.integrators", "foucault_bench.models")


def test_any_command_help_imports_no_numerical_library():
    """Building each command's parser and writing its help (what ``--help`` does) loads argparse and the command
    modules only: ``simulate --help`` listed the registered integrators and models, which imported numpy, numba
    and scipy (1.1-1.6 s instead of 0.25 s)."""
    code = (
        "import contextlib, io, sys\n"
        "from foucault_bench.bench.cli import main\n"
        "from foucault_bench.bench.commands import COMMANDS\n"
        "for name in COMMANDS:\n"
        "    with contextlib.redirect_stdout(io.StringIO()) as out, contextlib.suppress(SystemExit):\n"
        "        main([name, '--help'])\n"
        "    assert f'foucault-bench {name}' in out.getvalue()\n"
        f"print(' '.join(sorted(name for name in {HEAVY_MODULES!r} if name in sys.modules)))\n"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert loaded == []


def test_the_run_command_starts_its_workers_before_importing_a_numerical_library():
    """``run`` creates its executor (workers start and import) before reading the matrix: the modules it
    needs for that, the runner and the store, import no numerical library themselves."""
    code = (
        "import sys\n"
        "import foucault_bench.bench.run.runner, foucault_bench.bench.run.store\n"
        f"print(' '.join(sorted(name for name in {HEAVY_MODULES!r} if name in sys.modules)))\n"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert loaded == []


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli_main([command, "--help"])
    assert exit_info.value.code == 0
    assert f"foucault-bench {command}" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "module", "extra"), [
    (["run", "--matrix", "quick", "--scheduler", "tcp://127.0.0.1:1"], "distributed", "dask"),
    (["results", "--parquet", "rows.parquet"], "pyarrow", "parquet"),
])
def test_an_option_without_its_extra_is_one_line_naming_the_extra(argv, module, extra, monkeypatch, tmp_path,
                                                                   capsys):
    monkeypatch.setitem(sys.modules, module, None)  # as if not installed: find_spec gives None, import fails
    monkeypatch.chdir(tmp_path)
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"pip install 'foucault-bench[{extra}]'" in err[0], err
    assert not (tmp_path / "results").exists()  # refused before anything was written


def test_the_report_command_and_the_report_share_their_default_targets():
    from foucault_bench.bench.commands.report import DEFAULT_TARGETS as command_targets
    from foucault_bench.bench.verdicts.pareto import DEFAULT_TARGETS as report_targets

    assert command_targets == report_targets
