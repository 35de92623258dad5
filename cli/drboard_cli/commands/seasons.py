"""`drboard season ...`: organisers make a season out of boards (its rounds), with a points
table, best-of, weights and a final; everyone reads its standings."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from .. import board_options
from ..main import Context, edge, out, pass_context, write_text

if TYPE_CHECKING:
    from drboard_functions.models.seasons import PointsTable, SeasonStandings

    from ..target import BoardClient

FORMATS = ("table", "json", "csv", "markdown")
#: The most rounds and racers one read of a season takes (the API's largest page).
PAGE = 500


@click.group(name="season")
def season_group() -> None:
    """Organisers: make a season out of boards, with points, best-of, weights and a final.

    Each round is a board; its finishes earn points (the league's 25-18-15-12-10-8-6-4-2-1 by
    default), the best N rounds of each racer count, and the top K may be the only entrants of a
    final. Reading a season is public; changing one is for organisers, as for `drboard board`.
    """


def _points_options(update: bool) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    options = [
        click.option("--points", "positions", metavar="LIST",
                     help="Points for 1st, 2nd, 3rd, …, comma-separated (default: "
                          "25,18,15,12,10,8,6,4,2,1); places past the list score none."),
        click.option("--percentile", type=click.IntRange(1, 10_000), metavar="MAX",
                     help="Points by place in each round's field instead: MAX to the winner, "
                          "down to 1 (for big fields)."),
        click.option("--participation", type=click.IntRange(0, 10_000), metavar="N",
                     help="Points for taking part in a round, qualified or not"
                          + ("." if update else " (default: 0).")),
        click.option("--best-of", type=board_options.Count(clearable=update), metavar="N",
                     help="Only each racer's best N rounds count"
                          + (" (`none`: every round)." if update else " (default: every round).")),
    ]

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        for option in reversed(options):
            command = option(command)
        return command

    return decorate


@season_group.command(name="create")
@click.argument("season_id", metavar="ID")
@click.option("--title", required=True, help="The season's title, as racers see it.")
@click.option("--description", help="A longer text: the rules, the prizes, the dates.")
@_points_options(update=False)
@pass_context
def season_create(ctx: Context, /, season_id: str, title: str, description: str | None,
                  positions: str | None, percentile: int | None, participation: int | None,
                  best_of: int | None) -> None:
    """Create a season: its points table and how many rounds count.

    ID is letters, digits, `_`, `-` and `.` (up to 64). Add its rounds with
    `drboard season add-round`.
    """
    from drboard_functions.models.seasons import PointsTable, SeasonSpec

    fields: dict[str, Any] = {"season_id": season_id, "title": title,
                              "points": _points(PointsTable(), positions, percentile, participation)}
    if description is not None:
        fields["description"] = description
    if best_of is not None:
        fields["best_of"] = best_of
    with edge():
        spec = board_options.validated(SeasonSpec, fields, _OPTION_OF_FIELD)
        _print_season(ctx.board.create_season(spec))


@season_group.command(name="update")
@click.argument("season_id", metavar="ID")
@click.option("--title", help="The season's title.")
@click.option("--description", help="A longer text: the rules, the prizes, the dates.")
@_points_options(update=True)
@pass_context
def season_update(ctx: Context, /, season_id: str, title: str | None, description: str | None,
                  positions: str | None, percentile: int | None, participation: int | None,
                  best_of: Any) -> None:
    """Change a season: only the options given change; the standings follow at once."""
    from drboard_functions.models.seasons import SeasonChanges

    fields: dict[str, Any] = {name: value for name, value in
                              (("title", title), ("description", description)) if value is not None}
    if best_of is not None:
        fields["best_of"] = None if best_of is board_options.CLEAR else best_of
    with edge():
        if positions is not None or percentile is not None or participation is not None:
            current = ctx.board.season(season_id, 1, None).season.points
            fields["points"] = _points(current, positions, percentile, participation)
        if not fields:
            raise click.UsageError("give at least one option to change; see "
                                   "`drboard season update --help`")
        changes = board_options.validated(SeasonChanges, fields, _OPTION_OF_FIELD)
        _print_season(ctx.board.update_season(season_id, changes))


@season_group.command(name="add-round")
@click.argument("season_id", metavar="SEASON")
@click.argument("board_id", metavar="BOARD")
@click.option("--weight", type=click.FloatRange(0.01, 10), default=1.0, show_default=True,
              help="The round's points are multiplied by it (a final: 2).")
@click.option("--always-counts", is_flag=True,
              help="The round counts whatever --best-of says (a final).")
@pass_context
def season_add_round(ctx: Context, season_id: str, board_id: str, weight: float,
                     always_counts: bool) -> None:
    """Make BOARD a round of SEASON, or change a round's weight.

    The board's page links to the season, and the season's standings follow the board: every
    push, removed entry or ban on it moves them.
    """
    from drboard_functions.models.seasons import RoundSpec

    with edge():
        spec = board_options.validated(RoundSpec, {"weight": weight, "always_counts": always_counts},
                                       _OPTION_OF_FIELD)
        _print_season(ctx.board.add_round(season_id, board_id, spec))


@season_group.command(name="remove-round")
@click.argument("season_id", metavar="SEASON")
@click.argument("board_id", metavar="BOARD")
@pass_context
def season_remove_round(ctx: Context, season_id: str, board_id: str) -> None:
    """Take BOARD out of SEASON: its results no longer count (the board stays)."""
    with edge():
        _print_season(ctx.board.remove_round(season_id, board_id))


@season_group.command(name="final")
@click.argument("season_id", metavar="SEASON")
@click.argument("board_id", metavar="BOARD")
@click.option("--top", type=click.IntRange(1, 1000), required=True, metavar="K",
              help="How many racers qualify (racers tied at the cut all do).")
@click.option("--from-round", metavar="ROUND",
              help="The top K of this round of the season, instead of the season's standings.")
@pass_context
def season_final(ctx: Context, season_id: str, board_id: str, top: int, from_round: str | None) -> None:
    """Make BOARD the final of SEASON: only its top K may push to it.

    They are the top K of the season's standings over its other rounds, or of one round
    (`--from-round`). Anyone else's push is refused, naming the qualifiers. BOARD is a named
    board; it may also be a round of the season (e.g. counting double).
    """
    from drboard_functions.models.seasons import FinalSpec

    with edge():
        final = {"board_id": board_id, "top": top, "from_round": from_round}
        spec = board_options.validated(FinalSpec, final, _OPTION_OF_FIELD)
        _print_season(ctx.board.set_final(season_id, spec))


@season_group.command(name="clear-final")
@click.argument("season_id", metavar="SEASON")
@pass_context
def season_clear_final(ctx: Context, season_id: str) -> None:
    """SEASON has no final any more: its board takes anyone's pushes again."""
    with edge():
        _print_season(ctx.board.clear_final(season_id))


@season_group.command(name="close")
@click.argument("season_id", metavar="SEASON")
@pass_context
def season_close(ctx: Context, season_id: str) -> None:
    """Close SEASON: its standings stay as they are now, and it is listed as past.

    Later changes to its boards no longer move it; `drboard season reopen` lets them again.
    """
    with edge():
        _print_season(ctx.board.close_season(season_id))


@season_group.command(name="reopen")
@click.argument("season_id", metavar="SEASON")
@pass_context
def season_reopen(ctx: Context, season_id: str) -> None:
    """Reopen a closed SEASON: its boards move its standings again."""
    with edge():
        _print_season(ctx.board.reopen_season(season_id))


@season_group.command(name="list")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="table for people, json for scripts.")
@pass_context
def season_list(ctx: Context, fmt: str) -> None:
    """List the seasons, running and past."""
    from .. import render, season_render

    with edge():
        seasons = ctx.board.seasons()
        if fmt == "json":
            click.echo(render.write_json([s.model_dump(mode="json") for s in seasons]), nl=False)
        elif seasons:
            out().print(season_render.seasons_table(seasons))
        else:
            out().print("No seasons yet: `drboard season create ID --title T`.")


@season_group.command(name="show")
@click.argument("season_id", metavar="SEASON")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help="table for people, json for scripts.")
@pass_context
def season_show(ctx: Context, season_id: str, fmt: str) -> None:
    """A season's settings: its points, what counts, its rounds and its final's qualifiers."""
    from .. import season_render

    with edge():
        season = ctx.board.season(season_id, 1, None).season
        if fmt == "json":
            click.echo(season.model_dump_json(indent=2))
        else:
            out().print(season_render.season_panel(season))


@season_group.command(name="standings")
@click.argument("season_id", metavar="SEASON")
@click.option("--top", type=click.IntRange(1, 100_000), default=100, show_default=True,
              help="How many racers.")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="table", show_default=True,
              help="table for people; json, csv or markdown for scripts and posts.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write to this file instead of the terminal.")
@pass_context
def season_standings(ctx: Context, season_id: str, top: int, fmt: str, output: Path | None) -> None:
    """A season's standings: rank, points and each round's place and points.

    A round that does not count (past the best N) is struck out; Q marks the final's qualifiers.
    Ties on points go to more round wins, then the better best finish, then whoever set that
    best finish first.
    """
    from .. import render, season_render

    with edge():
        standings = _collect(ctx.board, season_id, top)
        if fmt == "table":
            if output:
                with output.open("w", encoding="utf-8") as handle:
                    render.plain_console(handle).print(season_render.standings_table(standings))
            elif standings.standings:
                out().print(season_render.standings_table(standings, out().width))
            else:
                out().print(f"{standings.season.title}: no results yet.")
            return
        text = {"json": season_render.standings_json, "csv": season_render.standings_csv,
                "markdown": season_render.standings_markdown}[fmt](standings)
        write_text(text, output)


@season_group.command(name="card")
@click.argument("season_id", metavar="SEASON")
@click.option("--format", "fmt", type=click.Choice(["png", "svg"]), default="png", show_default=True,
              help="png to share, or svg, the source the PNG is drawn from.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Where to save it (default: SEASON-podium.png in this folder).")
@pass_context
def season_card(ctx: Context, season_id: str, fmt: str, output: Path | None) -> None:
    """Save a season's podium card, a PNG to share (or its SVG source).

    The card (1200×630) shows the first three, their points, wins and gaps to the leader: the
    image a link to the season's page unfurls as in a chat. Its podium page,
    /seasons/SEASON/podium/view, prints the certificates of the first three.
    """
    from .standings import file_name

    with edge():
        data = ctx.board.season_card(season_id, "svg" if fmt == "svg" else "png")
        path = output or Path(file_name(f"{season_id}-podium") + f".{fmt}")
        path.write_bytes(data)
        out().print(f"Saved the podium card of {season_id} to {path}")


def _collect(client: BoardClient, season_id: str, top: int) -> SeasonStandings:
    page = client.season(season_id, min(top, PAGE), None)
    rows = list(page.standings)
    cursor = page.next_cursor
    while cursor and len(rows) < top:
        more = client.season(season_id, min(top - len(rows), PAGE), cursor)
        rows += more.standings
        cursor = more.next_cursor
    return page.model_copy(update={"standings": rows, "next_cursor": cursor})


def _print_season(standings: SeasonStandings) -> None:
    from .. import season_render

    out().print(season_render.season_panel(standings.season))


def _points(current: PointsTable, positions: str | None, percentile: int | None,
            participation: int | None) -> dict[str, Any]:
    """The points table the options make of ``current``."""
    if positions is not None and percentile is not None:
        raise click.UsageError("give --points or --percentile, not both")
    fields = current.model_dump()
    if positions is not None:
        fields |= {"scheme": "positions", "positions": _positions(positions)}
    if percentile is not None:
        fields |= {"scheme": "percentile", "percentile_max": percentile}
    if participation is not None:
        fields["participation"] = participation
    return fields


def _positions(text: str) -> list[int]:
    parts = [part.strip() for part in text.replace(" ", ",").split(",") if part.strip()]
    if not parts or not all(part.isdigit() for part in parts):
        raise click.BadParameter(f"{text!r} is not a list of points: give e.g. 25,18,15,12,10",
                                 param_hint="'--points'")
    return [int(part) for part in parts]


_OPTION_OF_FIELD = {"season_id": "ID", "title": "--title", "description": "--description",
                    "points": "--points", "best_of": "--best-of", "weight": "--weight",
                    "top": "--top", "from_round": "--from-round", "board_id": "BOARD"}


def _add_webhook_commands() -> None:
    from .webhooks import season_webhook_group

    season_group.add_command(season_webhook_group)


_add_webhook_commands()
