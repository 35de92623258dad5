"""A click group that imports a command's code only when that command runs (or shows its help),
so that every command starts about as fast as Python with click itself."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any, NamedTuple

import click


class LazyCommand(NamedTuple):
    """Where a command is defined (``module:attribute``) and its short help, which the group's
    --help lists without importing the module (a unit test holds it equal to the command's)."""

    location: str
    short_help: str


class LazyGroup(click.Group):
    def __init__(self, *args: Any, lazy_commands: Mapping[str, LazyCommand], **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lazy_commands = dict(lazy_commands)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy_commands})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self.lazy_commands and cmd_name not in self.commands:
            self.add_command(self._load(cmd_name), cmd_name)
        return super().get_command(ctx, cmd_name)

    def _load(self, name: str) -> click.Command:
        module_name, attribute = self.lazy_commands[name].location.split(":")
        command = getattr(importlib.import_module(module_name), attribute)
        if not isinstance(command, click.Command):
            raise TypeError(f"{self.lazy_commands[name].location} is not a click command")
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """As click lists the commands, but from the stored short help of those not loaded."""
        shown = [name for name in self.list_commands(ctx) if not self._hidden(ctx, name)]
        if not shown:
            return
        limit = formatter.width - 6 - max(len(name) for name in shown)
        rows = [(name, self._short_help(ctx, name, limit)) for name in shown]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def _hidden(self, ctx: click.Context, name: str) -> bool:
        if name in self.lazy_commands and name not in self.commands:
            return False
        command = self.get_command(ctx, name)
        return command is None or command.hidden

    def _short_help(self, ctx: click.Context, name: str, limit: int) -> str:
        if name in self.lazy_commands and name not in self.commands:
            # Shortened to the width exactly as click shortens a loaded command's help.
            stand_in = click.Command(name, help=self.lazy_commands[name].short_help)
            return stand_in.get_short_help_str(limit)
        command = self.get_command(ctx, name)
        assert command is not None
        return command.get_short_help_str(limit)
