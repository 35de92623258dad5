"""The README is the front door: its commands must be the ones that work."""

import re
from collections.abc import Iterator
from pathlib import Path

import click
import pytest
from click.testing import CliRunner
from drboard_cli.main import cli

ROOT = Path(__file__).parents[2]


def _readme_commands() -> list[str]:
    quick_start = ROOT.joinpath("README.md").read_text().split("## Quick start", 1)[1]
    quick_start = quick_start.split("\n## ", 1)[0]
    return re.findall(r"```sh\n(.+?)\n```", quick_start)


def test_quick_start_has_exactly_two_commands() -> None:
    commands = _readme_commands()
    assert len(commands) == 2
    assert "drboard push examples/*/" in commands[0]
    assert "pytest" in commands[1]


def test_ci_runs_the_readme_test_command() -> None:
    ci = ROOT.joinpath(".ci", "run").read_text()
    assert _readme_commands()[1] in ci.splitlines()


# ---- every command is documented, in --help and in the README's CLI reference -------------------


def _all_commands(group: click.Group = cli, prefix: str = "drboard") -> Iterator[tuple[str, click.Command]]:
    """Every command and subcommand, as typed: ``drboard pull``, ``drboard board create``."""
    for name, command in sorted(group.commands.items()):
        path = f"{prefix} {name}"
        yield path, command
        if isinstance(command, click.Group):
            yield from _all_commands(command, path)


COMMANDS = dict(_all_commands())


def _cli_reference() -> str:
    text = ROOT.joinpath("README.md").read_text().split("## CLI reference", 1)[1]
    return text.split("\n## ", 1)[0]


def test_the_board_commands_are_all_there() -> None:
    assert {"drboard board create", "drboard board update", "drboard board close",
            "drboard board delete", "drboard board restore", "drboard boards", "drboard status",
            "drboard history", "drboard export", "drboard import"} <= set(COMMANDS)


@pytest.mark.parametrize("path", sorted(COMMANDS))
def test_every_command_has_a_help_text(path: str) -> None:
    command = COMMANDS[path]
    assert command.help and command.get_short_help_str(limit=200).strip(), path
    undocumented = [p.name for p in command.params
                    if isinstance(p, click.Option) and not p.hidden and not p.help]
    assert not undocumented, f"{path}: options without help: {undocumented}"
    result = CliRunner().invoke(cli, [*path.split()[1:], "--help"])
    assert result.exit_code == 0 and "Usage:" in result.stdout


@pytest.mark.parametrize("path", sorted(COMMANDS))
def test_every_command_is_in_the_cli_reference(path: str) -> None:
    reference = _cli_reference()
    assert f"`{path}" in reference, f"{path} is missing from the README's CLI reference"
    for option in COMMANDS[path].params:
        for name in option.opts:
            if name.startswith("--") and name != "--help":
                assert name in reference, f"{path} {name} is missing from the README's CLI reference"
