"""`drboard`: push DeepRacer runs to a leaderboard and see the standings.

Exit codes: 0 success, 2 bad input (a file, a flag, a record the board refuses), 1 failure.

Each command lives in a module of ``drboard_cli.commands``, imported only when the command runs
or shows its help; this module holds what every command shares and stays light to import.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import cache, cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from . import __version__
from .lazy import LazyCommand, LazyGroup

if TYPE_CHECKING:
    from rich.console import Console

    from .target import BoardClient

BAD_INPUT = 2
FAILURE = 1

#: The domain errors that are bad input (exit 2): a file, a record or a board setting refused, a
#: board id taken, a board that cannot change. Named, so that nothing is imported to start.
BAD_INPUT_ERRORS = frozenset({"InvalidSubmission", "SubmissionTooLarge", "BoardMismatch",
                              "InvalidQuery", "BoardExists", "BoardLocked", "UnreadableBody",
                              "UnsupportedBody", "SeasonExists", "SeasonLocked"})
#: The domain errors that are failures (exit 1): nothing found, a closed board, a used-up
#: submission limit, a cooldown, a refusal, the board unreachable or too busy to answer.
FAILURE_ERRORS = frozenset({"BoardNotFound", "RacerNotFound", "WebhookNotFound", "TooSoon", "BoardClosed",
                            "DesignsPrivate", "SubmissionLimitReached", "NotAuthorized",
                            "CopiedRun", "BoardUnreachable", "StoreError", "StoreBusy",
                            "StoreUnavailable", "StoreFailed", "SeasonNotFound", "NotQualified"})


@cache
def out() -> Console:
    """Standard output (rich finds the stream at each print, so tests may swap it). Control
    characters in what it prints are escaped (see :mod:`.terminal`)."""
    from .terminal import console

    return console()


@cache
def err() -> Console:
    from .terminal import console

    return console(stderr=True)


def write_text(text: str, output: Path | None) -> None:
    """A command's text output: to the ``-o`` file when given, else to standard output."""
    if output:
        output.write_text(text, "utf-8")
    else:
        click.echo(text, nl=False)


BoardOpener = Callable[[Path], "BoardClient"]


class Context:
    """Which board the commands talk to: ``--endpoint`` (or DRBOARD_ENDPOINT), else ``--db``,
    else the endpoint saved by ``drboard configure``, else the embedded board, opened by
    ``open_local`` (tests give one on a fixed clock). Worked out when a command first asks."""

    def __init__(self, db: Path | None, endpoint: str | None,
                 open_local: BoardOpener | None = None) -> None:
        self._open_local = open_local
        self.explicit_db = db
        self._endpoint = endpoint
        self._board: BoardClient | None = None

    @cached_property
    def db(self) -> Path:
        if self.explicit_db:
            return self.explicit_db
        from . import config

        return config.default_db_path()

    @cached_property
    def endpoint(self) -> str | None:
        if self._endpoint or self.explicit_db:
            return self._endpoint
        from . import config

        saved = config.load_settings().get("endpoint")
        return str(saved) if saved else None

    @property
    def board(self) -> BoardClient:
        if self._board is None:
            if self.endpoint:
                from .remote import HttpBoard

                self._board = HttpBoard(str(self.endpoint))
            else:
                self._board = self.open_local(self.db)
        return self._board

    @property
    def place(self) -> str:
        """Where the board a push goes to is, in the words a racer checks after it: an event's
        board by its address (``at URL``), the board on this computer by its file."""
        if self.endpoint:
            return f"at {self.endpoint}"
        return f"on this computer ({self.db})"

    @property
    def embedded_file(self) -> Path | None:
        """The embedded board's file when the commands talk to it as drboard opens it (no
        endpoint, no opener given by a test): what is kept beside the board may then be read
        from the file itself."""
        return None if self.endpoint or self._open_local is not None else self.db

    @property
    def open_local(self) -> BoardOpener:
        if self._open_local is None:
            from .target import local_board

            return local_board
        return self._open_local


pass_context = click.make_pass_decorator(Context)


def fail(message: str, code: int) -> None:
    """One line on standard error, then exit with ``code``. Printed with click, not rich: an
    error answers without loading rich's console."""
    from .terminal import printable

    click.echo(f"{click.style('error:', fg='red', bold=True)} {printable(' '.join(message.split()))}",
               err=True)
    sys.exit(code)


@contextmanager
def edge() -> Iterator[None]:
    """Map domain errors to one message and an exit code: the CLI's only error handling.

    Bad input (2): a file, a record or a board setting refused, a board id taken, a board that
    cannot change. Failure (1): anything else, e.g. a closed board, a used-up submission limit or
    a cooldown (whose message says when to retry), nothing found, the board unreachable.
    """
    try:
        yield
    except click.ClickException:
        raise
    except Exception as error:
        answer = error_answer(error)
        if answer is None:
            raise
        fail(*answer)


def error_answer(error: Exception) -> tuple[str, int] | None:
    """The message and exit code for an error the CLI expects, else None (a bug: it propagates)."""
    from drboard_functions.errors import DomainError

    if isinstance(error, DomainError):
        return error.message, domain_exit_code(type(error))
    if isinstance(error, OSError):
        return f"{error.filename or ''} {error.strerror or error}".strip(), FAILURE
    from drboard_assembler.errors import AssemblyError

    from .transfer import BadExportFile

    if isinstance(error, AssemblyError | BadExportFile):
        return str(error), BAD_INPUT
    return None


def domain_exit_code(kind: type[Exception]) -> int:
    """A domain error's exit code: its own, else its nearest listed base's; one listed nowhere
    (added later) is a failure, and a unit test names it."""
    for base in kind.__mro__:
        if base.__name__ in BAD_INPUT_ERRORS:
            return BAD_INPUT
        if base.__name__ in FAILURE_ERRORS:
            return FAILURE
    return FAILURE


class Drboard(LazyGroup):
    """The `drboard` group, which knows whether it runs as the program (:meth:`main` called
    without arguments: its own command line) or is called by code (tests, another program)."""

    runs_as_program = False

    def main(self, args: Sequence[str] | None = None, *rest: Any, **options: Any) -> Any:
        self.runs_as_program = args is None
        return super().main(args, *rest, **options)


def finish(code: int = 0) -> None:
    """The command is done and has written everything: when drboard runs as the program, flush
    standard output and error and end the process at once with ``code``, without the
    interpreter's teardown (freeing every module and object, which takes longer than a pull's
    own answer). Only for commands that own no background thread and no file still being
    written. Called from code, it returns and click ends the command as usual."""
    if not cli.runs_as_program:
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except OSError:  # e.g. a closed pipe: as Python itself ends when it cannot flush its output
        code = code or 120
    os._exit(code)


def _at(module: str, *commands: tuple[str, str, str]) -> dict[str, LazyCommand]:
    """Commands of ``drboard_cli.commands.<module>``: (name, function, short help) each."""
    return {name: LazyCommand(f"drboard_cli.commands.{module}:{function}", short_help)
            for name, function, short_help in commands}


#: Every command, imported when it runs. The short help is the first sentence of the command's
#: help, which `drboard --help` lists (a unit test holds the two equal).
COMMANDS: dict[str, LazyCommand] = {
    **_at("runs",
          ("assemble", "assemble_command", "Read a run folder (or a .tar.gz of one) into a record."),
          ("push", "push", "Assemble each run folder and submit it to the board.")),
    **_at("standings",
          ("pull", "pull", "Show a board's standings: rank, time, gap to the leader and each "
                           "model's design."),
          ("boards", "boards", "List the boards: track, timing, status, window and racers."),
          ("compare", "compare", "Two to four racers' designs side by side, the facts they "
                                 "differ on marked ≠."),
          ("insights", "insights", "What the board's fastest models share against the field."),
          ("history", "history", "A racer's submissions on every board, oldest first."),
          ("show", "show", "How a racer's best model was built: hyperparameters, action space, "
                           "laps, training."),
          ("status", "status", "Where a racer stands on each board they pushed to."),
          ("card", "card", "Save a racer's result card, a PNG to share (or its SVG source).")),
    **_at("organisers",
          ("board", "board_group", "Organisers: create, update, close, delete and restore named "
                                   "boards, and moderate any board."),
          ("audit", "audit", "Every accepted push and every organiser action on BOARD: who, when, "
                             "what (organisers)."),
          ("export", "export_command", "Write a board as JSON lines: a backup, or a move to "
                                       "another board."),
          ("import", "import_command", "Load a `drboard export` file into this board; importing "
                                       "twice changes nothing.")),
    **_at("seasons",
          ("season", "season_group", "Organisers: make a season out of boards, with points, "
                                     "best-of, weights and a final.")),
    **_at("aliases",
          ("aliases", "aliases_group", "Organisers: reserve racers' aliases, give one to a "
                                      "sign-in, release one."),
          ("invite", "invite", "Invite racers to a deployed board: a user each, their alias kept "
                               "for them.")),
    **_at("account",
          ("alias", "alias", "Claim NAME as the racer alias you push as, or show the one you hold."),
          ("configure", "configure", "Choose the board the commands talk to, and save it in your "
                                     "user config folder."),
          ("login", "login", "Sign in to a deployed board, as a racer or an organiser."),
          ("logout", "logout", "Forget your sign-in to the board (and revoke it, on a deployed "
                               "board)."),
          ("whoami", "whoami", "Who the board takes you for: your sign-in, whether you organise, "
                               "and your racer alias."),
          ("join", "join", "Sign in to a `drboard serve` board with the join code its organiser "
                           "shows.")),
    **_at("hosting",
          ("serve", "serve", "Host the board over HTTP with the cloud board's own API, e.g. on an "
                             "event laptop."),
          ("joins", "joins", "Organisers: the join code of `drboard serve` and the racers who "
                             "joined with it.")),
}


@click.group(cls=Drboard, lazy_commands=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(version=__version__, prog_name="drboard")
@click.option("--db", type=click.Path(dir_okay=False, path_type=Path), envvar="DRBOARD_DB",
              help="The embedded board's SQLite file (default: in your user data folder). "
                   "Env: DRBOARD_DB.")
@click.option("--endpoint", envvar="DRBOARD_ENDPOINT", metavar="URL",
              help="A deployed board's API URL, or a `drboard serve` on your network. "
                   "Env: DRBOARD_ENDPOINT. Default: the one `drboard configure` saved, if any.")
@click.pass_context
def cli(ctx: click.Context, db: Path | None, endpoint: str | None) -> None:
    """drboard: a leaderboard for AWS DeepRacer racers.

    Push your run folders, see the standings and how the fast models were built.
    """
    # `obj` may be given (as tests do): a function that opens the embedded board.
    ctx.obj = Context(db, endpoint, ctx.obj if callable(ctx.obj) else None)


def interrupt(signum: int, frame: Any) -> None:
    """A SIGTERM handler: stop as Ctrl-C does."""
    raise KeyboardInterrupt


def main() -> None:  # pragma: no cover
    cli()
