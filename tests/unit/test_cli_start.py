"""`drboard` loads a command's code only when that command runs, and still lists them all.

How fast it starts is measured by bench/bench_cli.py; these tests check what makes it fast.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner
from drboard_assembler.record import RaceType
from drboard_cli import __version__, choices
from drboard_cli.lazy import LazyGroup
from drboard_cli.main import COMMANDS, cli
from drboard_functions.models.domain import MAX_COOLDOWN_S, TimingMethod

#: What the start of a command that only shows help must not import.
HEAVY = ("pydantic", "drboard_assembler", "drboard_functions", "rich.console", "platformdirs",
         "importlib.metadata")
#: What `drboard pull` on the embedded board has no use for: the export and import (their models
#: and rooms), pushes, organisers' requests, webhooks, the name checks' libraries, the web pages.
NOT_FOR_PULL = ("drboard_cli.transfer", "drboard_functions.models.transfer",
                "drboard_functions.models.requests", "drboard_functions.models.notices",
                "drboard_functions.service.transfer", "drboard_functions.service.pushing",
                "drboard_functions.service.webhooks", "drboard_functions.notify",
                "drboard_functions.web", "drboard_cli.remote", "regex", "disarm", "jinja2",
                "rich.progress", "rich.panel")
EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())


def _modules_loaded_by(*args: str) -> set[str]:
    """The modules a fresh `drboard ARGS` process has imported when it exits."""
    probe = ("import atexit, json, sys\n"
             "atexit.register(lambda: print(json.dumps(sorted(sys.modules)), file=sys.stderr))\n"
             "from drboard_cli.main import cli\n"
             f"cli({list(args)!r}, prog_name='drboard')\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=False,
                          env={**os.environ, "COLUMNS": "80"})
    assert done.returncode == 0, done.stderr
    return set(json.loads(done.stderr.splitlines()[-1]))


@pytest.fixture(scope="module")
def example_board(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An embedded board holding the example runs."""
    db = tmp_path_factory.mktemp("board") / "board.db"
    result = CliRunner().invoke(cli, ["--db", str(db), "push", *map(str, EXAMPLES)])
    assert result.exit_code == 0, result.stderr
    return db


@pytest.mark.parametrize("args", [["--help"], ["--version"], ["pull", "--help"], ["push", "--help"]],
                         ids=" ".join)
def test_help_and_version_import_no_model_nor_other_commands(args: list[str]) -> None:
    loaded = _modules_loaded_by(*args)
    heavy = sorted(m for m in loaded if m.startswith(HEAVY))
    assert not heavy, f"drboard {' '.join(args)} imported {heavy}"
    commands = {m for m in loaded if m.startswith("drboard_cli.commands.")}
    wanted = {COMMANDS[args[0]].location.split(":")[0]} if args[0] in COMMANDS else set()
    assert commands == wanted


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_the_listed_short_help_is_the_commands_own(name: str) -> None:
    command = _load(name)
    assert command.name == name
    assert COMMANDS[name].short_help == command.get_short_help_str(limit=1_000)


@pytest.mark.parametrize("width", [60, 80, 200])
def test_the_command_list_is_what_click_shows_for_the_loaded_commands(width: int) -> None:
    """The group's --help before any command is loaded, against click's own listing of every
    command loaded, at several terminal widths (click shortens each help to fit)."""
    unloaded = LazyGroup("drboard", lazy_commands=COMMANDS, params=cli.params, help=cli.help)
    loaded = click.Group("drboard", params=cli.params, help=cli.help,
                         commands={name: _load(name) for name in COMMANDS})

    def shown(group: click.Group) -> str:
        return group.get_help(click.Context(group, info_name="drboard", terminal_width=width))

    assert shown(unloaded) == shown(loaded)
    assert not unloaded.commands, "listing the commands loaded none"
    assert all(f"\n  {name} " in shown(unloaded) for name in COMMANDS)


def _load(name: str) -> click.Command:
    command = cli.get_command(click.Context(cli), name)
    assert command is not None
    return command


def test_an_unknown_command_is_a_usage_error() -> None:
    result = CliRunner().invoke(cli, ["pul"])
    assert result.exit_code == 2
    assert "No such command 'pul'" in result.stderr


def test_the_written_out_choices_are_the_models() -> None:
    assert tuple(RaceType) == choices.RACE_TYPES
    assert tuple(TimingMethod) == choices.TIMING_METHODS
    assert MAX_COOLDOWN_S == choices.MAX_COOLDOWN_S


def test_version_is_the_installed_distributions() -> None:
    assert __version__ == importlib.metadata.version("drboard")
    result = CliRunner().invoke(cli, ["--version"])
    assert result.stdout == f"drboard, version {__version__}\n"


def test_pull_imports_only_what_the_standings_need(example_board: Path) -> None:
    """The pull reads entries and a board: no export, push, webhook or page code, and the
    Record schema (which the standings never hold) is not built."""
    probe = ("import atexit, json, sys\n"
             "def report():\n"
             "    from drboard_assembler.record import Record\n"
             "    print(json.dumps([sorted(sys.modules), Record.__pydantic_complete__]), file=sys.stderr)\n"
             "atexit.register(report)\n"
             "from drboard_cli.main import cli\n"
             f"cli(['--db', {str(example_board)!r}, 'pull', '--track', 'reInvent2019'],"
             " prog_name='drboard')\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=False,
                          env={**os.environ, "COLUMNS": "80"})
    assert done.returncode == 0, done.stderr
    assert "Blaze" in done.stdout
    modules, record_schema_built = json.loads(done.stderr.splitlines()[-1])
    assert sorted(m for m in modules if m.startswith(NOT_FOR_PULL)) == []
    assert not record_schema_built


def test_a_pull_ends_the_process_once_its_output_is_out(example_board: Path) -> None:
    """Run as the program, `drboard pull` prints everything and exits 0 without the
    interpreter's teardown (an exit hook never runs); the same pull called from code returns."""
    expected = CliRunner().invoke(cli, ["--db", str(example_board), "pull", "--track", "reInvent2019"],
                                  terminal_width=80)
    assert expected.exit_code == 0
    as_program = ("import atexit, sys\n"
                  "atexit.register(lambda: print('teardown', file=sys.stderr))\n"
                  f"sys.argv = ['drboard', '--db', {str(example_board)!r}, 'pull', '--track',"
                  " 'reInvent2019']\n"
                  "from drboard_cli.main import cli\n"
                  "cli(prog_name='drboard')\n")
    done = subprocess.run([sys.executable, "-c", as_program], capture_output=True, text=True,
                          check=False, env={**os.environ, "COLUMNS": "80"})
    assert done.returncode == 0, done.stderr
    assert done.stdout == expected.stdout
    assert "teardown" not in done.stderr


def test_a_pull_that_fails_still_says_why_with_its_exit_code(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "drboard_cli", "--db", str(tmp_path / "empty.db"), "pull",
                           "--track", "reInvent2019"], capture_output=True, text=True, check=False)
    assert done.returncode == 1
    assert "no board 'reInvent2019_track'" in done.stderr
