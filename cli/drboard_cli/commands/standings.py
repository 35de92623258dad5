"""The commands that read a board: pull, boards, compare, insights, history, show, status and
card.

Those that only read and print end the process as soon as their output is out (:func:`finish`);
card, which writes a file, ends as usual."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ..main import Context, edge, finish, out, pass_context, write_text

if TYPE_CHECKING:
    from ..target import BoardClient

FORMATS = ("table", "json", "csv", "markdown")
#: How many entries a pull shows unless told.
DEFAULT_TOP = 25
FORMAT_HELP = "table for people, json for scripts (the README documents its fields)."


def _board_id(track: str | None, board: str | None) -> str:
    from drboard_functions.board_ids import board_for_track

    if bool(track) == bool(board):
        raise click.UsageError("give one of --track or --board")
    return board if board else board_for_track(track or "")


def _racer(racer: str | None) -> str:
    from .. import config

    racer = racer or config.default_racer()
    if not racer:
        raise click.UsageError("give --racer (no racer has pushed from this machine yet)")
    return str(racer)


def format_option(command: Any) -> Any:
    return click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
                        show_default=True, help=FORMAT_HELP)(command)


@click.command()
@click.option("--track", help="The track whose default board to show (any of its names).")
@click.option("--board", help="The board id to show.")
@click.option("--top", type=click.IntRange(1, 100_000), default=DEFAULT_TOP, show_default=True,
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
        board_id = _board_id(track, board)
        if fmt == "table" and output is None and _print_kept(ctx, board_id, top):
            finish()
            return
        if board:
            page = _collect(ctx.board, board_id, top)
        else:
            page = _track_page(ctx.board, track or "", board_id, top)
        _keep(ctx, board_id, top, page)
        _emit(page, fmt, output)
    finish()


def _print_kept(ctx: Context, board_id: str, top: int) -> bool:
    """Print the standings kept beside the embedded board for the board as it is now, if any
    are; whether it did. This is how a repeated pull answers without loading the service and
    its models."""
    import json
    import time

    from drboard_functions.stores.sqlite_standings import kept_page

    from ..standings_table import Fields, print_standings

    db = ctx.embedded_file
    if db is None:
        return False
    kept = kept_page(db, board_id, top, time.time())
    if kept is None:
        return False
    print_standings(out(), json.loads(kept, object_hook=Fields))
    return True


def keep_standings(ctx: Context, board_ids: Iterable[str]) -> None:
    """After pushes to the embedded board: keep each board's standings as a pull shows them
    unless told otherwise, so that the pull that follows answers from them."""
    if ctx.embedded_file is None:
        return
    for board_id in dict.fromkeys(board_ids):
        _keep(ctx, board_id, DEFAULT_TOP, _collect(ctx.board, board_id, DEFAULT_TOP))


def _keep(ctx: Context, board_id: str, top: int, page: Any) -> None:
    """Keep the page beside the embedded board, for the next pull of it (:func:`_print_kept`)."""
    from drboard_functions.board_window import next_change
    from drboard_functions.models.domain import MAX_PAGE
    from drboard_functions.stores.sqlite_standings import keep_page

    db = ctx.embedded_file
    if db is None or top > MAX_PAGE or page.board.board_id != board_id:
        return
    change = next_change(page.board)
    keep_page(db, board_id, top, page.board.version, change.timestamp() if change else None,
              page.model_dump_json())


def _track_page(client: BoardClient, track: str, board_id: str, top: int) -> Any:
    """The standings of a track's default board; when it has none, the refusal lists the
    boards the track has (its object-avoidance or head-to-head boards, named boards)."""
    from drboard_functions.errors import BoardNotFound

    try:
        return _collect(client, board_id, top)
    except BoardNotFound:
        others = _boards_of_track(client, track)
        if not others:
            raise
        from drboard_functions.display import plural

        listing = ", ".join(f"{b.board_id} ({b.title}, {plural(b.participants, 'racer')})"
                            for b in others[:10])
        more = f" and {len(others) - 10} more" if len(others) > 10 else ""
        raise BoardNotFound(f"no board {board_id!r}: no run was pushed to the track's default "
                            f"board; its boards are {listing}{more} (use --board ID)") from None


def _boards_of_track(client: BoardClient, track: str) -> list[Any]:
    from drboard_assembler.catalog import UnknownTrackError, default_catalog

    try:
        track_id = default_catalog().resolve(track).track_id
    except UnknownTrackError:
        track_id = track.strip()
    return sorted((b for b in client.boards() if b.track == track_id), key=lambda b: b.board_id)


def _collect(client: BoardClient, board_id: str, top: int) -> Any:
    from drboard_functions.models.domain import MAX_PAGE

    page = client.board_page(board_id, min(top, MAX_PAGE), None)
    entries = list(page.entries)
    cursor = page.next_cursor
    while cursor and len(entries) < top:
        more = client.board_page(board_id, min(top - len(entries), MAX_PAGE), cursor)
        entries.extend(more.entries)
        cursor = more.next_cursor
    return page.model_copy(update={"entries": entries, "next_cursor": cursor})


def _emit(page: Any, fmt: str, output: Path | None) -> None:
    from .. import render

    if fmt == "table":
        if output:
            with output.open("w", encoding="utf-8") as handle:
                render.plain_console(handle).print(render.board_table(page))
        else:
            render.print_standings(out(), page)
        return
    text = {"json": render.board_json, "csv": render.board_csv,
            "markdown": render.board_markdown}[fmt](page)
    write_text(text, output)


@click.command()
@click.option("--status", "wanted", type=click.Choice(["open", "upcoming", "closed"], case_sensitive=False),
              help="Only the boards that are open, not open yet, or closed.")
@format_option
@pass_context
def boards(ctx: Context, wanted: str | None, fmt: str) -> None:
    """List the boards: track, timing, status, window and racers."""
    from .. import render

    with edge():
        found = [b for b in ctx.board.boards() if not wanted or b.status.value == wanted.upper()]
        if fmt == "json":
            click.echo(render.write_json([b.model_dump(mode="json") for b in found]), nl=False)
        elif found:
            out().print(render.boards_table(found, out().width))
        elif wanted:
            out().print(f"No {wanted.lower()} boards.")
        else:
            out().print("No boards yet: push a run with `drboard push PATH`.")
    finish()


@click.command()
@click.argument("racers", nargs=-1, required=True)
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@format_option
@pass_context
def compare(ctx: Context, racers: tuple[str, ...], track: str | None, board: str | None,
            fmt: str) -> None:
    """Two to four racers' designs side by side, the facts they differ on marked ≠.

    Algorithm, action space, speeds, steering, sensors, network, hyperparameters and training,
    each racer's best model on the board.
    """
    from .. import render

    with edge():
        if not 2 <= len(racers) <= 4:
            raise click.UsageError("give two to four racers")
        comparison = ctx.board.compare(_board_id(track, board), list(racers))
        if fmt == "json":
            click.echo(render.json_text(comparison.model_dump_json(indent=2)))
        else:
            out().print(render.comparison_table(comparison))
    finish()


@click.command()
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@click.option("--top", type=click.IntRange(1, 20), default=5, show_default=True,
              help="How many of the fastest qualified models make the top.")
@format_option
@pass_context
def insights(ctx: Context, track: str | None, board: str | None, top: int, fmt: str) -> None:
    """What the board's fastest models share against the field.

    For each design fact, the top models' most common choice (and how many made it) or their
    median, beside the field's (the board's first 100 entries).
    """
    from .. import render

    with edge():
        found = ctx.board.insights(_board_id(track, board), top)
        if fmt == "json":
            click.echo(render.json_text(found.model_dump_json(indent=2)))
        else:
            out().print(render.insights_table(found))
    finish()


def racer_options(command: Any) -> Any:
    """--racer, --track and --board of the commands about one racer on every board (or one)."""
    for option in reversed([
        click.option("--racer", envvar="DRBOARD_RACER",
                     help="The racer (default: the last racer who pushed from this machine). "
                          "Env: DRBOARD_RACER."),
        click.option("--track", help="Only this track's default board."),
        click.option("--board", help="Only this board."),
    ]):
        command = option(command)
    return command


@click.command()
@racer_options
@click.option("--format", "fmt", type=click.Choice(["table", "json", "csv"]), default="table",
              show_default=True, help=FORMAT_HELP + " csv: one row per submission, for a "
                                                    "notebook or a spreadsheet.")
@pass_context
def history(ctx: Context, racer: str | None, track: str | None, board: str | None,
            fmt: str) -> None:
    """A racer's submissions on every board, oldest first.

    ★ marks each board's counted submission, the racer's best there. --format csv writes them
    over time for a notebook or a spreadsheet: submitted_at, board, model, qualified, time_s,
    best_lap_s, laps completed, best completion, counted, flags.
    """
    from .. import render

    with edge():
        name = _racer(racer)
        board_id = _board_id(track, board) if (track or board) else None
        items = ctx.board.history(name, board_id)
        if fmt == "csv":
            from drboard_functions.laps import HISTORY_COLUMNS, csv_text, history_rows

            click.echo(csv_text(HISTORY_COLUMNS, history_rows(items)), nl=False)
        elif fmt == "json":
            click.echo(render.write_json([i.model_dump(mode="json") for i in items]), nl=False)
        elif items:
            out().print(render.history_table(name, items, out().width))
        else:
            out().print(f"No submissions by {name} yet.", markup=False)
    finish()


@click.command()
@click.argument("racer")
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@format_option
@pass_context
def show(ctx: Context, racer: str, track: str | None, board: str | None, fmt: str) -> None:
    """How a racer's best model was built: hyperparameters, action space, laps, training."""
    from .. import render

    with edge():
        view = ctx.board.racer(_board_id(track, board), racer)
        if fmt == "json":
            click.echo(render.json_text(view.model_dump_json(indent=2)))
        else:
            out().print(render.racer_panel(view))
    finish()


@click.command()
@racer_options
@format_option
@pass_context
def status(ctx: Context, racer: str | None, track: str | None, board: str | None, fmt: str) -> None:
    """Where a racer stands on each board they pushed to.

    For each board: the latest submission and its result, the rank and gap to the leader of the
    racer's best, the submissions used (of the board's maximum) and when the next one is allowed.
    """
    from .. import render

    with edge():
        name = _racer(racer)
        board_id = _board_id(track, board) if (track or board) else None
        summary = ctx.board.status(name, board_id)
        if fmt == "json":
            click.echo(render.json_text(summary.model_dump_json(indent=2)))
        else:
            out().print(render.status_table(summary, out().width))
    finish()


@click.command()
@click.argument("racer")
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@click.option("--format", "fmt", type=click.Choice(["png", "svg"]), default="png", show_default=True,
              help="png to share, or svg, the source the PNG is drawn from.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Where to save it (default: RACER-BOARD.png in this folder).")
@pass_context
def card(ctx: Context, racer: str, track: str | None, board: str | None, fmt: str,
         output: Path | None) -> None:
    """Save a racer's result card, a PNG to share (or its SVG source).

    The card (1200×630) says the board, the racer's rank of how many, their time, the gap to the
    leader and their model: the image a link to the racer's page unfurls as in a chat. The
    embedded board draws it here; a deployed board or a `drboard serve` answers its own.
    """
    with edge():
        board_id = _board_id(track, board)
        data = ctx.board.racer_card(board_id, racer, "svg" if fmt == "svg" else "png")
        path = output or Path(file_name(f"{racer}-{board_id}") + f".{fmt}")
        path.write_bytes(data)
        out().print(f"Saved {racer}'s card on {board_id} to {path}")


def file_name(name: str) -> str:
    """A file name anyone's system takes: letters, digits, ``-``, ``_`` and ``.`` only."""
    return "".join(char if char.isalnum() or char in "-_." else "_" for char in name).strip(".") or "card"
