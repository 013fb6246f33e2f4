"""The CLI's shape (one home per command): one parser with a subparser per command, each command a module with
``add_args(parser)``, ``run(args)`` and ``main(argv=None)``, registered by one line in ``COMMANDS``."""

from __future__ import annotations

import importlib
import subprocess
import sys
import types

import pytest

import imutherm
from imutherm import ConvergenceError, InputError
from imutherm.cli import COMMANDS, MODULES, build_parser, main


def test_top_level_help_lists_every_command_with_its_help(capsys):
    assert main(["--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())  # argparse wraps the help lines
    assert out.startswith("usage: imutherm")
    for name, text in COMMANDS.items():
        assert f"{name} {' '.join(text.split())}" in out, name
    assert main([]) == 0
    assert " ".join(capsys.readouterr().out.split()) == out


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_command_module_has_the_three_functions(name):
    module = importlib.import_module(f"imutherm.cli.{MODULES.get(name, name)}")   # import: import_board
    for func in ("add_args", "run", "main"):
        assert callable(getattr(module, func, None)), f"imutherm.cli.{name}.{func}"


@pytest.mark.parametrize("name", list(COMMANDS))
def test_command_help_is_the_same_through_imutherm_and_the_module(name, capsys):
    module = importlib.import_module(f"imutherm.cli.{MODULES.get(name, name)}")
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    via_top = capsys.readouterr().out
    with pytest.raises(SystemExit):
        module.main(["--help"])
    assert capsys.readouterr().out == via_top
    assert via_top.startswith(f"usage: imutherm {name}")
    assert "``" not in via_top and ":mod:`" not in via_top  # docstring markup stripped
    assert "--out" in via_top


def test_help_imports_no_command_module():
    code = ("import sys; from imutherm.cli import build_parser; build_parser().format_help(); "
            "print(sorted(m for m in sys.modules if m.startswith('imutherm.cli.') and m != 'imutherm.cli._common'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.fixture
def fake_command(monkeypatch):
    """A command registered the way a new one is: its module, and one line in COMMANDS."""
    module = types.ModuleType("imutherm.cli.fake")
    module.__doc__ = "``imutherm fake``: a command of the test."
    calls = []

    def add_args(parser):
        parser.add_argument("--fail", choices=("input", "convergence", "interrupt"), default=None)
        parser.add_argument("--n", type=int, default=1)

    def run(args):
        calls.append(args.n)
        if args.fail == "input":
            raise InputError("--n: bad")
        if args.fail == "convergence":
            raise ConvergenceError("diverged")
        if args.fail == "interrupt":
            raise KeyboardInterrupt
        return 0

    module.add_args, module.run = add_args, run
    monkeypatch.setitem(sys.modules, "imutherm.cli.fake", module)
    monkeypatch.setitem(COMMANDS, "fake", "a command of the test")
    return calls


def test_a_registered_command_is_parsed_run_and_guarded(fake_command, capsys):
    assert main(["fake", "--n", "7"]) == 0 and fake_command == [7]
    assert "fake" in build_parser().format_help() and "a command of the test" in build_parser().format_help()
    assert main(["fake", "--fail", "input"]) == 2
    assert capsys.readouterr().err.strip() == "imutherm fake: error: --n: bad"
    assert main(["fake", "--fail", "convergence"]) == 3
    assert capsys.readouterr().err.strip() == "imutherm fake: not converged: diverged"
    assert main(["fake", "--fail", "interrupt"]) == 130
    assert capsys.readouterr().err.strip() == "imutherm fake: interrupted"
    with pytest.raises(SystemExit) as exc:  # argparse's own refusal, as before
        main(["fake", "--n", "x"])
    assert exc.value.code == 2
    assert "imutherm fake: error: argument --n" in capsys.readouterr().err


def test_version_through_the_console_script_module():
    out = subprocess.run([sys.executable, "-m", "imutherm.cli", "--version"], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == f"imutherm {imutherm.__version__}"


def _write_marker(path):
    path.write_text("done")


def _fail(path):
    raise OSError(f"cannot write {path}")


def test_in_background_runs_beside_the_caller_and_reports_a_failure(tmp_path):
    """The helper ``imutherm compare`` writes the schemes' files with while it draws the report."""
    from imutherm.cli._common import in_background

    wait = in_background(_write_marker, tmp_path / "a.txt")
    wait()
    assert (tmp_path / "a.txt").read_text() == "done"
    wait = in_background(_fail, tmp_path / "b.txt")
    with pytest.raises(OSError, match="_fail failed in its process"):
        wait()
