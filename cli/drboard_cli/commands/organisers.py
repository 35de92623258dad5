"""Organisers' commands: `drboard board ...` (named boards, moderation), audit, export, import."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from .. import board_options
from ..choices import MAX_COOLDOWN_S, RACE_TYPES, TIMING_METHODS
from ..main import Context, edge, err, out, pass_context
from ..target import every_page

AUDIT_PAGE = 500
FORMAT_HELP = "table for people, json for scripts (the README documents its fields)."


@click.group(name="board")
def board_group() -> None:
    """Organisers: create, update, close, delete and restore named boards, and moderate any board.

    A named board has its own track, timing method, window and per-racer limits; racers push to
    it with `drboard push PATH --board ID`. On a deployed board these calls need an organiser's
    sign-in (`drboard login`) or, without one, are signed with your AWS credentials, which need
    an IAM policy allowing them; reading stays public.
    """


def _setting_options(update: bool) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """The options create and update share; in an update, `none` clears a time or a limit."""
    clear = " `none` clears it." if update else ""
    options = [
        click.option("--title", required=not update, help="The board's title, as racers see it."),
        click.option("--description", help="A longer text: the rules, prizes, who may race."),
        click.option("--method", type=click.Choice(TIMING_METHODS, case_sensitive=False),
                     metavar="|".join(TIMING_METHODS),
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
        click.option("--require", multiple=True, type=board_options.Requirement(clearable=update),
                     metavar="CONDITION=VALUE",
                     help="An evaluation condition runs must have been evaluated under, as their "
                          "evaluation parameters state it; repeat for each: off-track-penalty=5, "
                          "collision-penalty=5, resets=N, trials=3, continuous=yes|no, obstacles=N, "
                          "bots=N (default: any)."
                          + (" The ones given replace the board's; `none` clears them." if update else "")),
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
@click.option("--race-type", type=click.Choice(RACE_TYPES, case_sensitive=False),
              metavar="|".join(RACE_TYPES), help="The race type of the runs it takes (default: TIME_TRIAL).")
@_setting_options(update=False)
@pass_context
def board_create(ctx: Context, /, board_id: str, **options: Any) -> None:
    """Create a named board with its own rules, window and limits.

    ID is letters, digits, `_`, `-` and `.` (up to 64), and not a track's default board id.
    """
    from .. import render

    with edge():
        view = ctx.board.create_board(board_options.board_spec({"board_id": board_id, **options}))
        out().print(render.board_panel(view))


@board_group.command(name="update")
@click.argument("board_id", metavar="ID")
@_setting_options(update=True)
@pass_context
def board_update(ctx: Context, /, board_id: str, **options: Any) -> None:
    """Change a named board's settings: only the options given change.

    The timing method, minimum laps, flagged-run rule and required conditions change only while
    the board has no entries.
    """
    from .. import render

    with edge():
        view = ctx.board.update_board(board_id, board_options.board_changes(options))
        out().print(render.board_panel(view))


@board_group.command(name="close")
@click.argument("board_id", metavar="ID")
@pass_context
def board_close(ctx: Context, board_id: str) -> None:
    """Close a named board now: it takes no more submissions; its standings stay."""
    from .. import render

    with edge():
        out().print(render.board_panel(ctx.board.close_board(board_id)))


#: How long the embedded board counts between two progress reports.
LOCAL_REBUILD_STEP_S = 2.0


@board_group.command(name="rebuild-ranks")
@click.argument("board_id", metavar="ID")
@pass_context
def board_rebuild_ranks(ctx: Context, board_id: str) -> None:
    """Build the rank counters of a big board from before them, with progress.

    Until then such a board (on DynamoDB) ranks each racer by counting the better entries. The
    entries are counted a batch at a time while racers go on pushing; stopped (Ctrl-C, a lost
    connection), the command goes on where it stopped when run again. A board that has its
    counters (every embedded board does) is done at once.
    """
    from .. import render

    with edge(), render.progress(err()) as progress:
        task = progress.add_task("Counting entries", total=None)
        while True:
            built = ctx.board.rebuild_ranks(board_id, LOCAL_REBUILD_STEP_S)
            progress.update(task, completed=built.counted, total=built.participants)
            if built.done:
                break
    out().print(f"{board_id}: rank counters built ({built.participants:,} racers)", soft_wrap=True)


@board_group.command(name="delete")
@click.argument("board_id", metavar="ID")
@pass_context
def board_delete(ctx: Context, board_id: str) -> None:
    """Delete a named board softly: it leaves lists and pulls, and `restore` brings it back whole."""
    from .. import render

    with edge():
        out().print(render.deleted_line(ctx.board.delete_board(board_id)), soft_wrap=True)


@board_group.command(name="restore")
@click.argument("board_id", metavar="ID")
@pass_context
def board_restore(ctx: Context, board_id: str) -> None:
    """Bring a deleted board back, with all its entries and submissions."""
    from .. import render

    with edge():
        out().print(render.board_panel(ctx.board.restore_board(board_id)))


@board_group.command(name="remove-entry")
@click.argument("board_id", metavar="BOARD")
@click.argument("racer")
@pass_context
def board_remove_entry(ctx: Context, board_id: str, racer: str) -> None:
    """Take RACER's entry off BOARD; their submissions are kept, the standings recomputed."""
    from .. import render

    with edge():
        out().print(render.moderation_line(ctx.board.remove_entry(board_id, racer), "remove-entry"),
                    soft_wrap=True)


@board_group.command(name="ban")
@click.argument("board_id", metavar="BOARD")
@click.argument("racer")
@click.option("--only-this-board", is_flag=True,
              help="Ban from BOARD only, not from every board of the event.")
@pass_context
def board_ban(ctx: Context, board_id: str, racer: str, only_this_board: bool) -> None:
    """Refuse RACER's pushes to every board of the event and take their entry off BOARD.

    The ban binds the racer's alias and the sign-in holding it, whatever alias it pushes as. The
    event is every board of this deployment (a stack, a `drboard serve`, an embedded board); with
    --only-this-board, BOARD alone. Their submissions are kept.
    """
    from .. import render

    with edge():
        out().print(render.moderation_line(
            ctx.board.ban(board_id, racer, everywhere=not only_this_board), "ban"), soft_wrap=True)


@board_group.command(name="unban")
@click.argument("board_id", metavar="BOARD")
@click.argument("racer")
@pass_context
def board_unban(ctx: Context, board_id: str, racer: str) -> None:
    """Let RACER push to BOARD again, and put their best submission back."""
    from .. import render

    with edge():
        out().print(render.moderation_line(ctx.board.unban(board_id, racer), "unban"), soft_wrap=True)


@board_group.command(name="recheck")
@click.argument("board_ids", metavar="[BOARD]...", nargs=-1)
@pass_context
def board_recheck(ctx: Context, board_ids: tuple[str, ...]) -> None:
    """Check every stored run again: copies, lookalikes and today's rules (every board by default).

    Runs stored before copy detection get their fingerprints; runs another racer pushed first or a
    few milliseconds apart, aliases that could pass for another racer's and records today's
    checks would refuse (a tightened rule) are flagged for you, never refused or moved. Run it
    after upgrading drboard; again, it flags nothing new.
    """
    from .. import render

    with edge():
        for board_id in board_ids or [board.board_id for board in ctx.board.boards()]:
            checked, flagged = 0, []
            cursor: str | None = None
            while True:
                page = ctx.board.recheck_page(board_id, cursor)
                checked += page.checked
                flagged += page.flagged
                cursor = page.next_cursor
                if cursor is None:
                    break
            out().print(render.recheck_line(board_id, checked, flagged), soft_wrap=True)


@click.command()
@click.argument("board_id", metavar="BOARD")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def audit(ctx: Context, board_id: str, fmt: str) -> None:
    """Every accepted push and every organiser action on BOARD: who, when, what (organisers)."""
    from .. import render

    with edge():
        events = [event for page in every_page(lambda cursor: ctx.board.audit(board_id, cursor, AUDIT_PAGE))
                  for event in page.events]
        if fmt == "json":
            out().print_json(data=[e.model_dump(mode="json") for e in events])
        else:
            out().print(render.audit_table(board_id, events, out().width))


@click.command(name="export")
@click.argument("board_id", metavar="BOARD")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write to this file (written whole or not at all) instead of standard output.")
@click.option("--laps", is_flag=True,
              help="Write every lap of every submission as CSV instead, for a notebook or a "
                   "spreadsheet (anyone may: the board's laps are public).")
@pass_context
def export_command(ctx: Context, board_id: str, output: Path | None, laps: bool) -> None:
    """Write a board as JSON lines: a backup, or a move to another board.

    One JSON object per line: the board and its settings first, then its entries in rank order,
    then every submission with its record. `drboard import` loads the file into any board.
    With --laps, one CSV row per lap instead: racer, model, submission, submitted_at, run, lap,
    time_s, completion, status, off-tracks, crashes, resets.
    """
    from .. import render, transfer

    with edge():
        if laps:
            if output:
                with transfer.replaced_on_success(output) as handle:
                    rows = transfer.write_laps(ctx.board, board_id, handle)
            else:
                rows = transfer.write_laps(ctx.board, board_id, transfer.standard_output())
            err().print(render.laps_line(board_id, rows, str(output) if output else None),
                        soft_wrap=True)
            return
        if output:
            with transfer.replaced_on_success(output) as handle:
                counts = transfer.write_export(ctx.board, board_id, handle)
        else:
            counts = transfer.write_export(ctx.board, board_id, transfer.standard_output())
        err().print(render.export_line(board_id, counts, str(output) if output else None), soft_wrap=True)


@click.command(name="import")
@click.argument("source", metavar="FILE", type=click.Path(exists=True, dir_okay=False, allow_dash=True))
@click.option("--board", "board_id", metavar="NEW_ID",
              help="Import under this board id instead of the exported one.")
@pass_context
def import_command(ctx: Context, source: str, board_id: str | None) -> None:
    """Load a `drboard export` file into this board; importing twice changes nothing.

    FILE (or `-` for standard input) is checked whole first: one bad line names the line and the
    field, and nothing is imported. The board is created unless it exists (then its own settings
    stay); every submission is replayed with its first submission time, and the entries are
    recomputed under the board's rules. On the embedded board the submissions are written in
    bulk as the lines are checked, all in one transaction.
    """
    from .. import render, transfer

    with edge(), transfer.opened_export(source) as (name, handle):
        board = ctx.board
        with render.progress(err()) as progress:
            if transfer.loads_in_bulk(board):
                def phase(description: str, total: int | None) -> Callable[[int], None]:
                    task = progress.add_task(description, total=total)
                    return lambda done: progress.advance(task, done)

                summary = transfer.load_export(board, name, handle, board_id, phase)
            else:
                contents = transfer.check_export(name, handle)
                task = progress.add_task("Importing submissions", total=contents.submissions)
                summary = transfer.import_export(board, name, handle, contents, board_id,
                                                 advance=lambda: progress.advance(task))
        out().print(render.import_summary(summary), soft_wrap=True)


def _add_webhook_commands() -> None:
    from .webhooks import webhook_group

    board_group.add_command(webhook_group)


_add_webhook_commands()
