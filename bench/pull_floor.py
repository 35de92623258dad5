"""The floor under `drboard pull` on the embedded board: a click + rich + sqlite3 command that reads
the same SQLite file and prints the same standings table, byte for byte, with nothing of drboard
(no models, no service, no validation). bench/bench_cli.py times it beside `drboard pull` and
checks that the two print the same bytes.

    python bench/pull_floor.py --db BOARD.db --board reInvent2019_track [--top 25]

It knows the store's layout (the `boards` and `entries` tables, the JSON each row holds) and
lays the table out as drboard's `board_table` does, for a board that states no conditions on a
terminal narrower than 110 columns (the benchmark's case: it stops on anything else); it takes
the board's id where drboard also resolves a track's name. Standard library, click and rich only.
"""

from __future__ import annotations

import json
import sqlite3
from datetime import UTC, datetime
from typing import Any

import click
from rich.console import Console
from rich.table import Table
from rich.text import Text

DASH = "—"
UNKNOWN_DESIGN = "design unknown"
FLAG_MARK = "⚑"
PRIVATE_DESIGN = "private until the board closes"
ALGORITHMS = {"clipped_ppo": "PPO", "sac": "SAC"}
METHODS = {"BEST_LAP_TIME": "best lap", "AVG_LAP_TIME": "average lap", "TOTAL_TIME": "total time"}


def moment(text: str | None) -> datetime | None:
    return datetime.fromisoformat(text.replace("Z", "+00:00")) if text else None


def designs_shown(board: dict[str, Any], now: datetime) -> bool:
    closes_at = moment(board["closes_at"])
    return board["designs"] == "public" or (closes_at is not None and now >= closes_at)


def design_summary(design: dict[str, Any] | None) -> str:
    if design is None:
        return PRIVATE_DESIGN
    if design["algorithm"] is None and design["action_space"] is None:
        return UNKNOWN_DESIGN
    algorithm = ALGORITHMS.get(design["algorithm"], design["algorithm"])
    if design["action_space"] is None or design["max_speed"] is None or design["max_steering"] is None:
        return f"{algorithm}, action space unknown"
    space = f"{design['actions']} actions" if design["actions"] else "continuous"
    return f"{algorithm}, {space}, {design['max_speed']:g} m/s, ±{design['max_steering']:g}°"


def time_label(score: dict[str, Any]) -> str:
    label = (f"{score['time_ms'] / 1000:.3f} s" if score["qualified"]
             else f"{score['best_completion_pct']:g} % done")
    return f"{label} {FLAG_MARK}" if score["flags"] else label


def gap_label(score: dict[str, Any], leader: dict[str, Any]) -> str:
    if score["time_ms"] is None or leader["time_ms"] is None:
        return DASH
    gap = score["time_ms"] - leader["time_ms"]
    return "leader" if gap == 0 else f"+{gap / 1000:.3f} s"


@click.command()
@click.option("--db", required=True, type=click.Path(exists=True, dir_okay=False))
@click.option("--board", "board_id", required=True)
@click.option("--top", type=click.IntRange(1, 500), default=25)
def pull(db: str, board_id: str, top: int) -> None:
    connection = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    board_json, participants = connection.execute(
        "SELECT board, participants FROM boards WHERE board_id = ?", (board_id,)).fetchone()
    rows = connection.execute("SELECT entry FROM entries WHERE board_id = ? ORDER BY rank_key LIMIT ?",
                              (board_id, top)).fetchall()
    board = json.loads(board_json)
    entries = [json.loads(entry) for (entry,) in rows]
    console = Console(highlight=False)
    if not entries:
        console.print(f"{board['title']}: no entries yet.", markup=False)
        return
    rules = board["rules"]
    laps = "lap" if rules["min_laps"] == 1 else "laps"
    caption = (f"{participants} racers · {METHODS[rules['method']]}, {rules['min_laps']} {laps} to "
               "qualify · times include penalties")
    if any(entry["score"]["flags"] for entry in entries):
        caption += f" · {FLAG_MARK} flagged by the board's checks"
    if board.get("conditions") is not None or console.width >= 110:
        raise click.UsageError("this floor prints a board stating no conditions, under 110 columns")
    table = Table(title=Text(f"{board['title']} · {board_id}"), caption=Text(caption), header_style="bold")
    table.add_column("Rank", justify="right")
    table.add_column("Racer", overflow="fold")
    table.add_column("Time", justify="right", no_wrap=True)
    table.add_column("Gap", justify="right", no_wrap=True)
    table.add_column("Laps", justify="right")
    table.add_column("Design")
    shown = designs_shown(board, datetime.now(UTC))
    leader = entries[0]["score"]
    rank, previous = 0, None
    for position, entry in enumerate(entries, 1):
        score = entry["score"]
        rank = rank if entry["score_key"] == previous else position  # ties share the rank
        previous = entry["score_key"]
        cells = [str(rank), entry["racer"], time_label(score), gap_label(score, leader),
                 str(score["laps_completed"]), design_summary(entry["design"] if shown else None)]
        table.add_row(*map(Text, cells), style=None if score["qualified"] else "dim")
    console.print(table)


if __name__ == "__main__":
    pull()
