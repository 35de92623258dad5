"""The README is the front door: its commands must be the ones that work."""

import re
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

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
    assert "push examples/*/" in commands[0]
    # the examples go to a demo board of their own, never the user's default board
    demo = re.search(r"drboard (--db \S+) push examples/\*/", commands[0])
    assert demo, commands[0]
    assert f"drboard {demo[1]} pull" in commands[0]
    assert "pytest" in commands[1]


def test_ci_runs_the_readme_test_command_one_step_at_a_time() -> None:
    # One step per line, in order, so that under `set -e` a failed install stops the run: a
    # failure inside an `a && b && c` list does not.
    ci = ROOT.joinpath(".ci", "run").read_text()
    steps = _readme_commands()[1].split(" && ")
    lines = ci.splitlines()
    assert steps[0] in lines
    start = lines.index(steps[0])
    assert lines[start:start + len(steps)] == steps
    assert "set -e" in ci and " && pytest" not in ci


def test_ci_fails_a_test_that_would_skip() -> None:
    ci = ROOT.joinpath(".ci", "run").read_text().splitlines()
    assert "export CI=true" in ci


# ---- every command is documented, in --help and in the README's CLI reference -------------------


def _all_commands(group: click.Group = cli, prefix: str = "drboard") -> Iterator[tuple[str, click.Command]]:
    """Every command and subcommand, as typed: ``drboard pull``, ``drboard board create``."""
    context = click.Context(group)
    for name in group.list_commands(context):
        command = group.get_command(context, name)
        assert command is not None, name
        path = f"{prefix} {name}"
        yield path, command
        if isinstance(command, click.Group):
            yield from _all_commands(command, path)


COMMANDS = dict(_all_commands())


def _cli_reference() -> str:
    text = ROOT.joinpath("README.md").read_text().split("## CLI reference", 1)[1]
    return text.split("\n## ", 1)[0]


class Entry(NamedTuple):
    synopsis: str  # drboard board create ID --title T --track T [options]
    text: str  # what follows it, whitespace collapsed


def _reference_entries() -> dict[str, list[Entry]]:
    """Each command's entries in the CLI reference: from a line opening with the command in bold
    (**`drboard board create ID ...`**) to the next such line or heading."""
    entries: dict[str, list[Entry]] = {}
    for block in re.split(r"\n(?=\*\*`drboard |#)", _cli_reference()):
        opening = re.match(r"\*\*`(drboard [^`]+)`\*\*", block)
        if not opening:
            continue
        words = opening[1].split()
        path = next((" ".join(words[:n]) for n in range(len(words), 1, -1)
                     if " ".join(words[:n]) in COMMANDS), opening[1])
        entries.setdefault(path, []).append(Entry(opening[1], " ".join(block[opening.end():].split())))
    return entries


def _options(command: click.Command) -> list[str]:
    return [name for param in command.params for name in param.opts
            if name.startswith("--") and name != "--help"]


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
def test_every_command_has_its_entry_in_the_cli_reference(path: str) -> None:
    """The entry opens with the command's short help (what `drboard --help` lists) and names
    every option the command takes."""
    entries = _reference_entries().get(path)
    assert entries, f"{path} has no entry (a line opening with **`{path} ...`**) in the CLI reference"
    short_help = COMMANDS[path].get_short_help_str(limit=1_000)
    assert entries[0].text.replace("`", "").startswith(f"— {short_help.replace('`', '')}"), (
        f"the README's entry for {path} should open with its --help: — {short_help}")
    documented = " ".join(part for entry in entries for part in entry)
    missing = [name for name in _options(COMMANDS[path]) if name not in documented]
    assert not missing, f"{path}: {missing} missing from its entry in the README's CLI reference"


def test_every_entry_of_the_cli_reference_is_a_command() -> None:
    assert set(_reference_entries()) <= set(COMMANDS)


def test_the_global_options_are_in_the_cli_reference() -> None:
    global_options = _cli_reference().split("Global options", 1)[1].split("\n\n", 1)[0]
    for name in [*_options(cli), "--version"]:
        assert f"`{name}" in global_options, f"{name} is missing from the README's global options"


def test_the_tests_section_gives_a_fast_unit_test_command() -> None:
    readme = ROOT.joinpath("README.md").read_text()
    tests = readme.split("\n## Tests", 1)[1].split("\n## ", 1)[0]
    assert "pytest tests/unit -q" in tests
    assert "pytest tests/unit -q" in readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
