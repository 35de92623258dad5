"""`drboard`: push DeepRacer runs to a leaderboard and see the standings.

Exit codes: 0 success, 2 bad input (a file, a flag, a record the board refuses), 1 failure.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, TypeVar

import click
from drboard_assembler import AssemblyError, Overrides, Record, assemble
from drboard_assembler.record import RaceType
from drboard_functions import display
from drboard_functions import errors as domain
from drboard_functions.models import MAX_COOLDOWN_S, TimingMethod
from rich.console import Console

from . import board_options, config, render, tokens, transfer
from .target import BoardClient, local_board

FORMATS = ("table", "json", "csv", "markdown")
AUDIT_PAGE = 500
BAD_INPUT = 2
FAILURE = 1

_BAD_INPUT_ERRORS = (domain.InvalidSubmission, domain.SubmissionTooLarge, domain.BoardMismatch,
                     domain.InvalidQuery, domain.BoardExists, domain.BoardLocked)
FORMAT_HELP = "table for people, json for scripts (the README documents its fields)."

T = TypeVar("T")

out = Console(highlight=False)
err = Console(stderr=True, highlight=False)


BoardOpener = Callable[[Path], BoardClient]


class Context:
    """Which board the commands talk to: ``--endpoint`` (or DRBOARD_ENDPOINT), else ``--db``,
    else the endpoint saved by ``drboard configure``, else the embedded board, opened by
    ``open_local`` (tests give one on a fixed clock)."""

    def __init__(self, db: Path | None, endpoint: str | None,
                 open_local: BoardOpener = local_board) -> None:
        self.open_local = open_local
        self.explicit_db = db
        self.db = db or config.default_db_path()
        self.endpoint = endpoint or (None if db else config.load_settings().get("endpoint"))
        self._board: BoardClient | None = None

    @property
    def board(self) -> BoardClient:
        if self._board is None:
            if self.endpoint:
                from .remote import HttpBoard

                self._board = HttpBoard(str(self.endpoint))
            else:
                self._board = self.open_local(self.db)
        return self._board


pass_context = click.make_pass_decorator(Context)


def fail(message: str, code: int) -> None:
    err.print(f"[bold red]error:[/] {message}", soft_wrap=True, markup=True, highlight=False)
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
    except (AssemblyError, transfer.BadExportFile) as error:
        fail(_escape(str(error)), BAD_INPUT)
    except _BAD_INPUT_ERRORS as error:
        fail(_escape(error.message), BAD_INPUT)
    except domain.DomainError as error:
        fail(_escape(error.message), FAILURE)
    except OSError as error:
        fail(_escape(f"{error.filename or ''} {error.strerror or error}".strip()), FAILURE)


def _escape(text: str) -> str:
    from rich.markup import escape

    return escape(text)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="drboard")
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
    ctx.obj = Context(db, endpoint, ctx.obj if callable(ctx.obj) else local_board)


# ---- assemble ----------------------------------------------------------------------------


def overrides_options(command: Callable[..., Any]) -> Callable[..., Any]:
    for option in reversed([
        click.option("--track", help="The track (WORLD_NAME, alias or display name), when the "
                                     "files do not say or say otherwise."),
        click.option("--custom-track", is_flag=True,
                     help="Take --track exactly as the name of a track of your own."),
        click.option("--racer", help="Your racer alias, when the files do not say or say otherwise."),
        click.option("--model", help="The model name (default: from the files, else the folder)."),
        click.option("--race-type", type=click.Choice([t.value for t in RaceType],
                                                      case_sensitive=False),
                     help="The race type, when the files do not say or say otherwise (a run "
                          "with parameters that leave it out is a time trial)."),
    ]):
        command = option(command)
    return command


def _overrides(track: str | None, custom_track: bool, racer: str | None,
               model: str | None, race_type: str | None) -> Overrides:
    if custom_track and not track:
        raise click.UsageError("--custom-track needs --track NAME")
    return Overrides(track=track, racer=racer, model=model, custom_track=custom_track,
                     race_type=race_type)


@cli.command(name="assemble")
@click.argument("path", type=click.Path(exists=True, path_type=Path))
@overrides_options
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Save the record to this file instead of printing it.")
def assemble_command(path: Path, track: str | None, custom_track: bool, racer: str | None,
                     model: str | None, race_type: str | None, output: Path | None) -> None:
    """Read a run folder (or a .tar.gz of one) into a record. Nothing is sent.

    PATH holds the model's files as DeepRacer-for-Cloud, DeepRacer on AWS or the old console
    wrote them: model_metadata.json, hyperparameters.json, the params YAML files and the
    training and evaluation metrics.
    """
    with edge():
        record = assemble(path, _overrides(track, custom_track, racer, model, race_type))
        text = record.model_dump_json(indent=2) + "\n"
        if output:
            output.write_text(text, "utf-8")
            err.print(f"Saved the record of {record.racer} on {record.track} to {output}")
        else:
            click.echo(text, nl=False)


# ---- push --------------------------------------------------------------------------------


@cli.command()
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@overrides_options
@click.option("--board", "board_id", help="Push to this board (default: the track's board).")
@click.option("--dry-run", is_flag=True, help="Assemble and check, but send nothing.")
@click.option("--watch", is_flag=True,
              help="PATH is a training folder: keep watching it and push each evaluation as it "
                   "finishes, one submission per evaluation metrics file, until Ctrl-C.")
@click.option("--interval", type=click.FloatRange(min=0.1), default=10.0, show_default=True,
              metavar="SECONDS", help="With --watch: how often to look for new evaluations.")
@click.option("--only-new", is_flag=True,
              help="With --watch: leave out the evaluations already in the folder when the watch "
                   "starts.")
@pass_context
def push(ctx: Context, paths: tuple[Path, ...], track: str | None, custom_track: bool,
         racer: str | None, model: str | None, race_type: str | None, board_id: str | None,
         dry_run: bool, watch: bool, interval: float, only_new: bool) -> None:
    """Assemble each run folder and submit it to the board.

    Every path is read and checked first: if one is bad, nothing is pushed. Prints each run's
    rank and whether it is a new best. Pushing the same run twice changes nothing.

    With --watch, PATH is a folder a training writes to: every evaluation in it (unless
    --only-new) and every new one is pushed on its own once complete, i.e. once its metrics file
    holds every lap its parameters ask for (NUMBER_OF_TRIALS) or, when they do not say, nothing
    has written to it for a minute. The board's cooldown is waited out and an unreachable board
    retried; an evaluation the board refuses is reported and skipped. Ctrl-C stops.
    """
    with edge():
        overrides = _overrides(track, custom_track, racer, model, race_type)
        if watch:
            _watch(ctx, paths, overrides, board_id, interval, only_new, dry_run)
            return
        interval_given = click.get_current_context().get_parameter_source("interval")
        if only_new or interval_given is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError("--interval and --only-new go with --watch")
        records = [assemble(path, overrides) for path in paths]
        if dry_run:
            for path, record in zip(paths, records, strict=True):
                _print_dry_run(path, record)
            return
        for record in records:
            receipt = ctx.board.push(record, board_id)
            out.print(render.receipt_line(receipt), soft_wrap=True)
        config.save_settings(racer=records[-1].racer)


def _watch(ctx: Context, paths: tuple[Path, ...], overrides: Overrides, board_id: str | None,
           interval_s: float, only_new: bool, dry_run: bool) -> None:
    from .watch import PushedEvaluations, Watcher

    if len(paths) != 1:
        raise click.UsageError("--watch takes one training folder")
    if dry_run:
        raise click.UsageError("--watch and --dry-run do not go together")
    if not paths[0].is_dir():
        raise click.UsageError(f"--watch needs a training folder; {paths[0]} is not a folder")
    target = ctx.endpoint or str(ctx.db.resolve())
    memory = PushedEvaluations(config.watch_memory_path(), f"{target} {board_id or ''}".strip())
    watcher = Watcher(paths[0], ctx.board, overrides, board_id, console=out,
                      interval_s=interval_s, only_new=only_new, memory=memory)
    previous = signal.signal(signal.SIGTERM, _interrupt)  # stop as Ctrl-C does
    try:
        watcher.run()
    finally:
        signal.signal(signal.SIGTERM, previous)
        if watcher.summary.last_racer:
            config.save_settings(racer=watcher.summary.last_racer)


def _print_dry_run(path: Path, record: Record) -> None:
    best = min((run.best_lap_ms for run in record.evaluations if run.best_lap_ms), default=None)
    done = max(run.best_completion_pct for run in record.evaluations)
    result = display.seconds(best) if best else f"{display.percent(done)} done"
    out.print(f"{path}: {record.racer} · {record.model_name} · {record.track} · "
              f"{len(record.evaluations)} evaluation runs · best {result} · not sent (dry run)",
              soft_wrap=True)


# ---- pull and boards ---------------------------------------------------------------------


def _board_id(track: str | None, board: str | None) -> str:
    from drboard_functions.service import board_for_track

    if bool(track) == bool(board):
        raise click.UsageError("give one of --track or --board")
    return board if board else board_for_track(track or "")


@cli.command()
@click.option("--track", help="The track whose default board to show (any of its names).")
@click.option("--board", help="The board id to show.")
@click.option("--top", type=click.IntRange(1, 100_000), default=25, show_default=True,
              help="How many entries.")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="table", show_default=True,
              help="table for people; json, csv or markdown for scripts and posts.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write to this file instead of the terminal.")
@pass_context
def pull(ctx: Context, track: str | None, board: str | None, top: int, fmt: str,
         output: Path | None) -> None:
    """Show a board's standings: rank, time, gap to the leader and each model's design."""
    with edge():
        page = _collect(ctx.board, _board_id(track, board), top)
        _emit(page, fmt, output)


def _collect(client: BoardClient, board_id: str, top: int) -> Any:
    from drboard_functions.models import MAX_PAGE

    page = client.board_page(board_id, min(top, MAX_PAGE), None)
    entries = list(page.entries)
    cursor = page.next_cursor
    while cursor and len(entries) < top:
        more = client.board_page(board_id, min(top - len(entries), MAX_PAGE), cursor)
        entries.extend(more.entries)
        cursor = more.next_cursor
    return page.model_copy(update={"entries": entries, "next_cursor": cursor})


def _emit(page: Any, fmt: str, output: Path | None) -> None:
    if fmt == "table":
        if output:
            with output.open("w", encoding="utf-8") as handle:
                render.plain_console(handle).print(render.board_table(page))
        elif page.entries:
            out.print(render.board_table(page, out.width))
        else:
            out.print(f"{page.board.title}: no entries yet.")
        return
    text = {"json": render.board_json, "csv": render.board_csv,
            "markdown": render.board_markdown}[fmt](page)
    if output:
        output.write_text(text, "utf-8")
    else:
        click.echo(text, nl=False)


@cli.command()
@click.option("--status", "wanted", type=click.Choice(["open", "upcoming", "closed"], case_sensitive=False),
              help="Only the boards that are open, not open yet, or closed.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def boards(ctx: Context, wanted: str | None, fmt: str) -> None:
    """List the boards: track, timing, status, window and racers."""
    with edge():
        found = [b for b in ctx.board.boards() if not wanted or b.status.value == wanted.upper()]
        if fmt == "json":
            click.echo(render.write_json([b.model_dump(mode="json") for b in found]), nl=False)
        elif found:
            out.print(render.boards_table(found, out.width))
        elif wanted:
            out.print(f"No {wanted.lower()} boards.")
        else:
            out.print("No boards yet: push a run with `drboard push PATH`.")


# ---- racers ------------------------------------------------------------------------------


def _racer(racer: str | None) -> str:
    racer = racer or config.load_settings().get("racer")
    if not racer:
        raise click.UsageError("give --racer (no racer has pushed from this machine yet)")
    return str(racer)


@cli.command()
@click.argument("racers", nargs=-1, required=True)
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def compare(ctx: Context, racers: tuple[str, ...], track: str | None, board: str | None,
            fmt: str) -> None:
    """Two to four racers' designs side by side, the facts they differ on marked ≠.

    Algorithm, action space, speeds, steering, sensors, network, hyperparameters and training,
    each racer's best model on the board.
    """
    with edge():
        if not 2 <= len(racers) <= 4:
            raise click.UsageError("give two to four racers")
        comparison = ctx.board.compare(_board_id(track, board), list(racers))
        if fmt == "json":
            click.echo(comparison.model_dump_json(indent=2))
        else:
            out.print(render.comparison_table(comparison))


@cli.command()
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@click.option("--top", type=click.IntRange(1, 20), default=5, show_default=True,
              help="How many of the fastest qualified models make the top.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def insights(ctx: Context, track: str | None, board: str | None, top: int, fmt: str) -> None:
    """What the board's fastest models share against the field.

    For each design fact, the top models' most common choice (and how many made it) or their
    median, beside the field's (the board's first 100 entries).
    """
    with edge():
        found = ctx.board.insights(_board_id(track, board), top)
        if fmt == "json":
            click.echo(found.model_dump_json(indent=2))
        else:
            out.print(render.insights_table(found))


@cli.command()
@click.option("--racer", envvar="DRBOARD_RACER",
              help="The racer (default: the last racer who pushed from this machine). "
                   "Env: DRBOARD_RACER.")
@click.option("--track", help="Only this track's default board.")
@click.option("--board", help="Only this board.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def history(ctx: Context, racer: str | None, track: str | None, board: str | None,
            fmt: str) -> None:
    """A racer's submissions on every board, oldest first.

    ★ marks each board's counted submission, the racer's best there.
    """
    with edge():
        name = _racer(racer)
        board_id = _board_id(track, board) if (track or board) else None
        items = ctx.board.history(name, board_id)
        if fmt == "json":
            click.echo(render.write_json([i.model_dump(mode="json") for i in items]), nl=False)
        elif items:
            out.print(render.history_table(name, items))
        else:
            out.print(f"No submissions by {name} yet.")


@cli.command()
@click.argument("racer")
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def show(ctx: Context, racer: str, track: str | None, board: str | None, fmt: str) -> None:
    """How a racer's best model was built: hyperparameters, action space, laps, training."""
    with edge():
        view = ctx.board.racer(_board_id(track, board), racer)
        if fmt == "json":
            click.echo(view.model_dump_json(indent=2))
        else:
            out.print(render.racer_panel(view))


@cli.command()
@click.option("--racer", envvar="DRBOARD_RACER",
              help="The racer (default: the last racer who pushed from this machine). "
                   "Env: DRBOARD_RACER.")
@click.option("--track", help="Only this track's default board.")
@click.option("--board", help="Only this board.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def status(ctx: Context, racer: str | None, track: str | None, board: str | None, fmt: str) -> None:
    """Where a racer stands on each board they pushed to.

    For each board: the latest submission and its result, the rank and gap to the leader of the
    racer's best, the submissions used (of the board's maximum) and when the next one is allowed.
    """
    with edge():
        name = _racer(racer)
        board_id = _board_id(track, board) if (track or board) else None
        summary = ctx.board.status(name, board_id)
        if fmt == "json":
            click.echo(summary.model_dump_json(indent=2))
        else:
            out.print(render.status_table(summary))


# ---- organisers: board management --------------------------------------------------------


@cli.group(name="board")
def board_group() -> None:
    """Organisers: create, update, close, delete and restore named boards.

    A named board has its own track, timing method, window and per-racer limits; racers push to
    it with `drboard push PATH --board ID`. On a deployed board these calls are signed with your
    AWS credentials and need an IAM policy allowing them; reading stays public.
    """


def _setting_options(update: bool) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """The options create and update share; in an update, `none` clears a time or a limit."""
    clear = " `none` clears it." if update else ""
    options = [
        click.option("--title", required=not update, help="The board's title, as racers see it."),
        click.option("--description", help="A longer text: the rules, prizes, who may race."),
        click.option("--method", type=click.Choice([m.value for m in TimingMethod], case_sensitive=False),
                     metavar="|".join(TimingMethod),
                     help="How racers are timed" + ("." if update else " (default: BEST_LAP_TIME).")),
        click.option("--min-laps", type=board_options.Count(clearable=update), metavar="N",
                     help="Completed laps to qualify (default: the method's, 1 or 3)."
                          + (" `none` goes back to it." if update else "")),
        click.option("--opens-at", type=board_options.When(clearable=update), metavar="WHEN",
                     help="When it opens: ISO 8601 with a time zone, or `now`." + clear),
        click.option("--closes-at", type=board_options.When(clearable=update), metavar="WHEN",
                     help="When it closes: ISO 8601 with a time zone, or `now`." + clear),
        click.option("--cooldown", type=board_options.Duration(clearable=update, longest_s=MAX_COOLDOWN_S),
                     metavar="DURATION",
                     help="The least time between a racer's submissions: 90s, 30m, 1h30m, 2d or "
                          "seconds." + clear),
        click.option("--max-submissions", type=board_options.Count(clearable=update), metavar="N",
                     help="The most submissions a racer may make." + clear),
        click.option("--flagged-runs", type=click.Choice(["rank", "unranked"]),
                     help="Whether runs the board's consistency checks flag still rank, or only "
                          "show below the qualified racers" + ("." if update else " (default: rank).")),
        click.option("--designs", type=click.Choice(["public", "after-close"]),
                     help="Whether everyone sees how the entries' models were built now, or only "
                          "once the board closes" + ("." if update else " (default: public).")),
    ]

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        for option in reversed(options):
            command = option(command)
        return command

    return decorate


@board_group.command(name="create")
@click.argument("board_id", metavar="ID")
@click.option("--track", required=True, help="The track (WORLD_NAME, alias or display name).")
@click.option("--custom-track", is_flag=True, help="Take --track exactly as the name of a track of your own.")
@click.option("--clockwise", is_flag=True, help="Runs go clockwise on this board.")
@click.option("--race-type", type=click.Choice([r.value for r in RaceType], case_sensitive=False),
              metavar="|".join(RaceType), help="The race type of the runs it takes (default: TIME_TRIAL).")
@_setting_options(update=False)
@pass_context
def board_create(ctx: Context, /, board_id: str, **options: Any) -> None:
    """Create a named board with its own rules, window and limits.

    ID is letters, digits, `_`, `-` and `.` (up to 64), and not a track's default board id.
    """
    with edge():
        view = ctx.board.create_board(board_options.board_spec({"board_id": board_id, **options}))
        out.print(render.board_panel(view))


@board_group.command(name="update")
@click.argument("board_id", metavar="ID")
@_setting_options(update=True)
@pass_context
def board_update(ctx: Context, /, board_id: str, **options: Any) -> None:
    """Change a named board's settings: only the options given change.

    The timing method and minimum laps change only while the board has no entries.
    """
    with edge():
        view = ctx.board.update_board(board_id, board_options.board_changes(options))
        out.print(render.board_panel(view))


@board_group.command(name="close")
@click.argument("board_id", metavar="ID")
@pass_context
def board_close(ctx: Context, board_id: str) -> None:
    """Close a named board now: it takes no more submissions; its standings stay."""
    with edge():
        out.print(render.board_panel(ctx.board.close_board(board_id)))


@board_group.command(name="delete")
@click.argument("board_id", metavar="ID")
@pass_context
def board_delete(ctx: Context, board_id: str) -> None:
    """Delete a named board softly: it leaves lists and pulls, and `restore` brings it back whole."""
    with edge():
        out.print(render.deleted_line(ctx.board.delete_board(board_id)), soft_wrap=True)


@board_group.command(name="restore")
@click.argument("board_id", metavar="ID")
@pass_context
def board_restore(ctx: Context, board_id: str) -> None:
    """Bring a deleted board back, with all its entries and submissions."""
    with edge():
        out.print(render.board_panel(ctx.board.restore_board(board_id)))


@board_group.command(name="remove-entry")
@click.argument("board_id", metavar="BOARD")
@click.argument("racer")
@pass_context
def board_remove_entry(ctx: Context, board_id: str, racer: str) -> None:
    """Take RACER's entry off BOARD; their submissions are kept, the standings recomputed."""
    with edge():
        out.print(render.moderation_line(ctx.board.remove_entry(board_id, racer), "remove-entry"),
                  soft_wrap=True)


@board_group.command(name="ban")
@click.argument("board_id", metavar="BOARD")
@click.argument("racer")
@pass_context
def board_ban(ctx: Context, board_id: str, racer: str) -> None:
    """Refuse RACER's pushes to BOARD and take their entry off it (submissions are kept)."""
    with edge():
        out.print(render.moderation_line(ctx.board.ban(board_id, racer), "ban"), soft_wrap=True)


@board_group.command(name="unban")
@click.argument("board_id", metavar="BOARD")
@click.argument("racer")
@pass_context
def board_unban(ctx: Context, board_id: str, racer: str) -> None:
    """Let RACER push to BOARD again, and put their best submission back."""
    with edge():
        out.print(render.moderation_line(ctx.board.unban(board_id, racer), "unban"), soft_wrap=True)


@cli.command()
@click.argument("board_id", metavar="BOARD")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def audit(ctx: Context, board_id: str, fmt: str) -> None:
    """Every accepted push and every organiser action on BOARD: who, when, what (organisers)."""
    with edge():
        events = []
        cursor: str | None = None
        while True:
            page = ctx.board.audit(board_id, cursor, AUDIT_PAGE)
            events.extend(page.events)
            cursor = page.next_cursor
            if cursor is None:
                break
        if fmt == "json":
            out.print_json(data=[e.model_dump(mode="json") for e in events])
        else:
            out.print(render.audit_table(board_id, events))


@cli.command()
@click.argument("name", required=False)
@pass_context
def alias(ctx: Context, name: str | None) -> None:
    """Claim NAME as the racer alias you push as, or show the one you hold.

    An alias is claimed once, by one sign-in; your first push claims its racer's alias too.
    """
    with edge():
        me = ctx.board.claim_alias(name) if name else ctx.board.me()
        out.print(render.me_line(me), soft_wrap=True)


# ---- export and import -------------------------------------------------------------------


@cli.command(name="export")
@click.argument("board_id", metavar="BOARD")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write to this file (written whole or not at all) instead of standard output.")
@pass_context
def export_command(ctx: Context, board_id: str, output: Path | None) -> None:
    """Write a board as JSON lines: a backup, or a move to another board.

    One JSON object per line: the board and its settings first, then its entries in rank order,
    then every submission with its record. `drboard import` loads the file into any board.
    """
    with edge():
        if output:
            with transfer.replaced_on_success(output) as handle:
                counts = transfer.write_export(ctx.board, board_id, handle)
        else:
            counts = transfer.write_export(ctx.board, board_id, sys.stdout)
        err.print(render.export_line(board_id, counts, str(output) if output else None), soft_wrap=True)


@cli.command(name="import")
@click.argument("source", metavar="FILE", type=click.Path(exists=True, dir_okay=False, allow_dash=True))
@click.option("--board", "board_id", metavar="NEW_ID",
              help="Import under this board id instead of the exported one.")
@pass_context
def import_command(ctx: Context, source: str, board_id: str | None) -> None:
    """Load a `drboard export` file into this board; importing twice changes nothing.

    FILE (or `-` for standard input) is checked whole first: one bad line names the line and the
    field, and nothing is imported. The board is created unless it exists (then its own settings
    stay); every submission is replayed with its first submission time, and the entries are
    recomputed under the board's rules.
    """
    with edge(), transfer.opened_export(source) as (name, handle):
        contents = transfer.check_export(name, handle)
        with render.progress(err) as progress:
            task = progress.add_task("Importing submissions", total=contents.submissions)
            summary = transfer.import_export(ctx.board, name, handle, contents, board_id,
                                             advance=lambda: progress.advance(task))
        out.print(render.import_summary(summary), soft_wrap=True)


# ---- targets: configure and serve -------------------------------------------------------


@cli.command()
@click.option("--stack-name", help="Read the board's URL from this CloudFormation stack's outputs.")
@click.option("--region", help="The stack's AWS region (default: your AWS configuration's).")
@click.option("--endpoint", "endpoint_url", metavar="URL",
              help="Use this board URL (a deployed API or a `drboard serve`).")
@click.option("--local", "use_local", is_flag=True, help="Forget the saved URL: use the embedded board.")
@click.option("--racer", help="Your racer alias, the default for `drboard history`.")
def configure(stack_name: str | None, region: str | None, endpoint_url: str | None,
              use_local: bool, racer: str | None) -> None:
    """Choose the board the commands talk to, and save it in your user config folder.

    With no option, shows what is saved.
    """
    with edge():
        if sum(map(bool, (stack_name, endpoint_url, use_local))) > 1:
            raise click.UsageError("give one of --stack-name, --endpoint or --local")
        changes: dict[str, Any] = {}
        if stack_name:
            from .cloud import stack_endpoint

            changes |= {"endpoint": stack_endpoint(stack_name, region), "stack_name": stack_name}
        elif endpoint_url:
            if not endpoint_url.startswith(("http://", "https://")):
                raise click.UsageError("--endpoint must be an http:// or https:// URL")
            changes |= {"endpoint": endpoint_url.rstrip("/"), "stack_name": None}
        elif use_local:
            changes |= {"endpoint": None, "stack_name": None}
        if racer:
            changes["racer"] = racer
        if changes:
            config.save_settings(**changes)
        settings = config.load_settings()
        target = settings.get("endpoint") or f"the embedded board ({config.default_db_path()})"
        out.print(f"Board: {target}", soft_wrap=True)
        if settings.get("stack_name"):
            out.print(f"Stack: {settings['stack_name']}")
        if settings.get("racer"):
            out.print(f"Racer: {settings['racer']}")
        out.print(f"Saved in {config.settings_path()}", style="dim", soft_wrap=True)


@cli.command()
@click.option("--host", default="127.0.0.1", show_default=True,
              help="The address to listen on; 0.0.0.0 lets racers on your network push.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
              help="The port to listen on; 0 picks a free one.")
@click.option("--table", help="Serve a DynamoDB table instead of the embedded board.")
@click.option("--endpoint-url", metavar="URL",
              help="With --table: the DynamoDB endpoint, e.g. DynamoDB Local's http://127.0.0.1:8001.")
@click.option("--code-minutes", type=click.IntRange(1, 7 * 24 * 60), default=60, show_default=True,
              help="How long each join code is good for; a new one is printed when it runs out.")
@pass_context
def serve(ctx: Context, host: str, port: int, table: str | None, endpoint_url: str | None,
          code_minutes: int) -> None:
    """Host the board over HTTP with the cloud board's own API, e.g. on an event laptop.

    Racers on your network join with the code it prints (`drboard join CODE --endpoint
    http://HOST:PORT`), then push as the alias their first push claims. The organiser commands
    (`drboard board ...`, `audit`, `export`, `import`) are answered only on this machine itself.
    Ctrl-C stops it; every push that was answered is saved.
    """
    from drboard_functions.service import LeaderboardService

    from .joins import JoinDesk
    from .serve import BoardServer

    with edge():
        if endpoint_url and not table:
            raise click.UsageError("--endpoint-url goes with --table")
        if table:
            import boto3
            from drboard_functions.stores.dynamodb import DynamoDbStore

            client = boto3.client("dynamodb", endpoint_url=endpoint_url)
            service = LeaderboardService(DynamoDbStore(table, client=client))
            where = f"DynamoDB table {table}" + (f" at {endpoint_url}" if endpoint_url else "")
        else:
            service = LeaderboardService(local_board_store(ctx.db))
            where = str(ctx.db)
        desk = JoinDesk(ctx.db.with_name(ctx.db.stem + ".joined.sqlite"), code_minutes)
        server = BoardServer((host, port), service, desk)
        bound_host, bound_port = str(server.server_address[0]), int(server.server_address[1])
        url = f"http://{_reachable(bound_host)}:{bound_port}"
        out.print(f"Serving {where} on http://{bound_host}:{bound_port}  (Ctrl-C to stop)",
                  soft_wrap=True)
        stop = threading.Event()
        announcer = threading.Thread(target=_announce_codes, args=(desk, url, stop), daemon=True)
        announcer.start()
        signal.signal(signal.SIGTERM, _interrupt)
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            out.print("Stopping…")
        finally:
            stop.set()
            server.server_close()
            desk.close()


def _announce_codes(desk: Any, url: str, stop: threading.Event) -> None:
    """Print the join code, and each new one when the last runs out."""
    shown = None
    while True:
        code = desk.current_code()
        if code != shown:
            out.print(f"Racers join with code [bold]{code.code}[/] (good until "
                      f"{code.expires_at:%H:%M} UTC): drboard join {code.code} --endpoint {url}",
                      soft_wrap=True, highlight=False)
            out.file.flush()
            shown = code
        wait = (code.expires_at - datetime.now(UTC)).total_seconds()
        if stop.wait(max(1.0, min(wait, 60.0))):
            return


def _reachable(host: str) -> str:
    """The address racers reach this computer at: for 0.0.0.0, its own on the network."""
    if host not in ("0.0.0.0", "::"):
        return f"[{host}]" if ":" in host else host
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("10.254.254.254", 1))  # no packet is sent: this only picks a route
            return str(probe.getsockname()[0])
        except OSError:
            return socket.gethostname()


def _endpoint(ctx: Context, command: str) -> str:
    if not ctx.endpoint:
        raise click.UsageError(f"give the board: drboard --endpoint URL {command} (or save it "
                               "with `drboard configure`)")
    return str(ctx.endpoint).rstrip("/")


@cli.command()
@click.option("--password", "use_password", is_flag=True,
              help="Sign in with your user name and password here, with no browser.")
@click.option("--username", help="With --password: your user name (asked for otherwise).")
@click.option("--no-browser", is_flag=True,
              help="Print the sign-in page's address instead of opening a browser.")
@pass_context
def login(ctx: Context, use_password: bool, username: str | None, no_browser: bool) -> None:
    """Sign in to a deployed board, as a racer or an organiser.

    Opens the board's sign-in page in your browser and waits for it to send you back (to
    http://localhost:8765/callback). With --password, asks for your user name and password here
    instead (an invited racer's temporary password is replaced by a new one). The token is saved
    for that board in your user config folder, readable by you only, and renewed before it
    expires; `drboard logout` forgets it.
    """
    from . import login as signing_in

    with edge():
        endpoint = _endpoint(ctx, "login")
        settings = signing_in.require_cognito(signing_in.sign_in_settings(endpoint), endpoint)
        if use_password:
            name = username or click.prompt("User name")
            password = click.prompt("Password", hide_input=True)
            token = signing_in.login_with_password(
                endpoint, settings, name, password,
                new_password=lambda: click.prompt("Choose a new password", hide_input=True,
                                                  confirmation_prompt=True))
        else:
            def show(url: str) -> None:
                err.print(f"Sign in at: {url}" if no_browser else
                          f"Opening your browser to sign in (or open {url})", soft_wrap=True)

            token = signing_in.login_in_browser(endpoint, settings, show, open_browser=not no_browser)
        out.print(f"Signed in to {endpoint} as {token.username or 'you'}.", soft_wrap=True)


@cli.command()
@pass_context
def logout(ctx: Context) -> None:
    """Forget your sign-in to the board (and revoke it, on a deployed board)."""
    from . import login as signing_in

    with edge():
        endpoint = _endpoint(ctx, "logout")
        forgot = signing_in.logout(endpoint)
        out.print(f"Signed out of {endpoint}." if forgot else f"You were not signed in to {endpoint}.",
                  soft_wrap=True)


@cli.command()
@pass_context
def whoami(ctx: Context) -> None:
    """Who the board takes you for: your sign-in, whether you organise, and your racer alias."""
    with edge():
        out.print(render.me_line(ctx.board.me()), soft_wrap=True)


@cli.command()
@click.argument("code")
@pass_context
def join(ctx: Context, code: str) -> None:
    """Sign in to a `drboard serve` board with the join code its organiser shows.

    Give the board with `--endpoint URL` (or `drboard configure --endpoint URL` first). The
    token it answers is saved for that board in your user config folder, readable by you only.
    """
    from .remote import HttpBoard

    with edge():
        board = HttpBoard(_endpoint(ctx, "join CODE"))
        joined = board.join(code)
        tokens.save(board.endpoint, tokens.SavedToken(kind="join", access_token=joined.token,
                                                      username=joined.principal))
        out.print(f"Joined {board.endpoint} as {joined.principal}. Your first push claims your "
                  "racer alias (or claim it now with `drboard alias NAME`).", soft_wrap=True)


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def local_board_store(db: Path) -> Any:
    from drboard_functions.stores.sqlite import SqliteStore

    return SqliteStore(db)


def main() -> None:  # pragma: no cover
    cli()
