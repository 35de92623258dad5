"""How seasons look in the terminal: the season's settings and rounds, its standings (and as
JSON, CSV and Markdown), and the list of seasons."""

from __future__ import annotations

import csv
import io
from typing import Any

from drboard_functions.display import DASH, ordinal, points_rule, points_text, when
from drboard_functions.models.seasons import (
    RoundScore,
    SeasonStandings,
    SeasonSummary,
    SeasonView,
    Standing,
)
from rich.console import Group
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

#: Beside a racer who qualifies for the season's final.
QUALIFIED_MARK = "Q"
_STATUS = {"OPEN": ("running", "green"), "CLOSED": ("ended", "dim")}


def season_panel(season: SeasonView) -> Group:
    """The season's settings, its rounds and its final, as an organiser set them."""
    grid = Table.grid(padding=(0, 2))
    grid.add_column(style="bold")
    grid.add_column(overflow="fold")
    label, style = _STATUS[season.status]
    grid.add_row("status", Text(label, style=style) + (f" since {when(season.closed_at)}"
                                                         if season.closed_at else ""))
    if season.description:
        grid.add_row("description", season.description)
    grid.add_row("points", points_rule(season.points, season.best_of, season.rounds))
    grid.add_row("ties", season.tie_breaks)
    if season.final is not None:
        source = f"round {season.final.from_round}" if season.final.from_round else "the season"
        qualifiers = ", ".join(season.final.qualifiers) or "nobody yet"
        grid.add_row("final", f"{season.final.board_id}: the top {season.final.top} of {source} "
                              f"({qualifiers})")
    parts: list[Any] = [Panel(grid, title=f"{season.title} · {season.season_id}", expand=False)]
    if season.rounds:
        rounds = Table(title="Rounds", header_style="bold")
        for name, justify in (("#", "right"), ("Board", "left"), ("Title", "left"),
                              ("Status", "left"), ("Racers", "right"), ("Weight", "right")):
            rounds.add_column(name, justify=justify, overflow="fold")  # type: ignore[arg-type]
        for r in season.rounds:
            status = "board deleted" if r.status == "MISSING" else str(r.status).lower()
            weight = f"×{r.weight:g}" + (", always counts" if r.always_counts else "")
            rounds.add_row(str(r.number), r.board_id, r.title, status, str(r.participants), weight)
        parts.append(rounds)
    else:
        parts.append(Text(f"No rounds yet: drboard season add-round {season.season_id} BOARD"))
    return Group(*parts)


def standings_table(standings: SeasonStandings, width: int = 120) -> Table:
    """Rank, racer, points and each round's points; a round that does not count struck out and
    dim, one not raced a dash. On a wide terminal each round's place shows too."""
    season = standings.season
    wide = width >= 40 + 10 * len(season.rounds)
    # A mark's legend only where the table shows the mark.
    notes = []
    if season.best_of and any(not score.counted for s in standings.standings
                              for score in s.rounds if score.rank is not None):
        notes.append(f"struck: past the best {season.best_of}, not counted")
    if season.final is not None and any(s.qualified_for_final for s in standings.standings):
        notes.append(f"{QUALIFIED_MARK}: qualifies for the final ({season.final.board_id})")
    caption = " · ".join(notes) or None
    table = Table(title=f"{season.title} · {season.season_id}", caption=caption, header_style="bold")
    table.add_column("Rank", justify="right")
    table.add_column("Racer", overflow="fold")
    table.add_column("Points", justify="right", style="bold")
    for r in season.rounds:
        table.add_column(f"R{r.number}" + (f" ×{r.weight:g}" if r.weight != 1 else ""),
                         justify="right", no_wrap=True)
    for standing in standings.standings:
        racer = standing.racer + (f" {QUALIFIED_MARK}" if standing.qualified_for_final else "")
        table.add_row(str(standing.rank), racer, points_text(standing.points),
                      *(_round_cell(score, wide) for score in standing.rounds))
    return table


def _round_cell(score: RoundScore, wide: bool) -> Text:
    if score.rank is None:
        return Text(DASH, style="dim")
    text = points_text(score.points)
    if wide:
        text = f"{_place(score)} {text}"
    return Text(text, style="" if score.counted else "dim strike")


def _place(score: RoundScore) -> str:
    if score.rank is None:
        return ""
    return ordinal(score.rank) if score.qualified else "DNQ"


def seasons_table(seasons: list[SeasonSummary]) -> Table:
    table = Table(title="Seasons", header_style="bold")
    table.add_column("Season", no_wrap=True)
    table.add_column("Title", overflow="fold")
    table.add_column("Status")
    table.add_column("Rounds", justify="right")
    table.add_column("Final", overflow="fold")
    for s in seasons:
        label, style = _STATUS[s.status]
        table.add_row(s.season_id, s.title, Text(label, style=style), str(s.rounds),
                      s.final_board_id or DASH)
    return table


CSV_FIELDS = ("rank", "racer", "points", "wins", "best_finish", "rounds_raced",
              "qualified_for_final")


def _flat(standing: Standing, season: SeasonView) -> dict[str, Any]:
    row: dict[str, Any] = {
        "rank": standing.rank, "racer": standing.racer, "points": points_text(standing.points),
        "wins": standing.wins, "best_finish": standing.best_finish or "",
        "rounds_raced": standing.rounds_raced, "qualified_for_final": standing.qualified_for_final,
    }
    for r, score in zip(season.rounds, standing.rounds, strict=True):
        row[f"r{r.number}_place"] = _place(score)
        row[f"r{r.number}_points"] = points_text(score.points) if score.rank is not None else ""
        row[f"r{r.number}_counted"] = score.counted
    return row


def standings_csv(standings: SeasonStandings) -> str:
    """One row a racer: ``rank, racer, points, wins, best_finish, rounds_raced,
    qualified_for_final``, then ``r<N>_place, r<N>_points, r<N>_counted`` for each round."""
    fields = [*CSV_FIELDS, *(f"r{r.number}_{part}" for r in standings.season.rounds
                             for part in ("place", "points", "counted"))]
    rows = [_flat(s, standings.season) for s in standings.standings]
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def standings_markdown(standings: SeasonStandings) -> str:
    season = standings.season
    header = ["Rank", "Racer", "Points", *(f"R{r.number}" for r in season.rounds)]
    lines = [f"## {season.title}", "", points_rule(season.points, season.best_of, season.rounds), "",
             season.tie_breaks, "", "| " + " | ".join(header) + " |",
             "|---:|---|---:|" + "---:|" * len(season.rounds)]
    for standing in standings.standings:
        cells = [str(standing.rank),
                 standing.racer + (f" ({QUALIFIED_MARK})" if standing.qualified_for_final else ""),
                 points_text(standing.points)]
        for score in standing.rounds:
            if score.rank is None:
                cells.append(DASH)
            else:
                cell = f"{_place(score)} {points_text(score.points)}"
                cells.append(cell if score.counted else f"~~{cell}~~")
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    lines += ["", "~~struck~~: a round that does not count"
              + (f"; ({QUALIFIED_MARK}): qualifies for the final" if season.final else "") + "."]
    return "\n".join(lines) + "\n"


def standings_json(standings: SeasonStandings) -> str:
    return standings.model_dump_json(indent=2) + "\n"
