"""`drboard` loads a command's code only when that command runs, and still lists them all.

How fast it starts is measured by bench/bench_cli.py; these tests check what makes it fast.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import subprocess
import sys

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
