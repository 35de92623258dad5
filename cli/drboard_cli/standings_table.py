"""The standings table `drboard pull` prints, and the cells every table shares (part of
:mod:`.render`, which re-exports it).

Apart because it imports no model: it reads a board page's fields by name, so it renders the
view models the service returns and, as well, a page's JSON read back with :class:`Fields` (the
standings kept beside the embedded board, :mod:`drboard_functions.stores.sqlite_standings`),
with the same code and so the same bytes (that JSON keeps each entry's submission time as
text, and its conditions as a mapping: :func:`submitted` and :mod:`drboard_functions.conditions`
read both forms).
"""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING, Any

from drboard_functions import conditions
from drboard_functions.display import design_summary, gap, method_label, percent, plural, seconds
from rich.table import Table
from rich.text import Text

if TYPE_CHECKING:
    from drboard_functions.models.views import BoardPage, EntryView
    from rich.console import Console

#: Beside a run the board's consistency checks flagged (`drboard show` says which checks).
FLAG_MARK = "⚑"
#: From this many columns the standings also show each entry's model, conditions and time.
WIDE = 110


class Fields(dict[str, Any]):
    """A JSON object whose members read as attributes, as the view model's fields do (for
    ``json.loads(text, object_hook=Fields)``)."""

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


def plain_row(table: Table, *cells: Text | str, **options: Any) -> None:
    """A table row whose text cells are plain text, never rich markup."""
    table.add_row(*(Text(cell) if isinstance(cell, str) else cell for cell in cells), **options)


def time_label(entry: EntryView) -> str:
    label = seconds(entry.time_ms) if entry.qualified else f"{percent(entry.best_completion_pct)} done"
    return f"{label} {FLAG_MARK}" if entry.flags else label


def submitted(entry: EntryView) -> datetime:
    """When the entry's run was submitted (the view's time, or the JSON's text of it)."""
    moment: datetime | str = entry.submitted_at
    return datetime.fromisoformat(moment) if isinstance(moment, str) else moment


def print_standings(console: Console, page: BoardPage) -> None:
    """The standings as wide as the console, or the line that says the board has none."""
    if page.entries:
        console.print(board_table(page, console.width))
    else:
        console.print(f"{page.board.title}: no entries yet.", markup=False)


def board_table(page: BoardPage, width: int = 120) -> Table:
    """The standings; on a narrow terminal the submission time and model name give way."""
    board = page.board
    wide = width >= WIDE
    caption = f"{plural(board.participants, 'racer')} · {method_label(board)}"
    if board.conditions is not None:
        caption += f" · evaluated with {conditions.summary(board.conditions)}"
    caption += " · times include penalties"
    if any(entry.flags for entry in page.entries):
        caption += f" · {FLAG_MARK} flagged by the board's checks"
    table = Table(title=Text(f"{board.title} · {board.board_id}"), caption=Text(caption),
                  header_style="bold")
    table.add_column("Rank", justify="right")
    table.add_column("Racer", overflow="fold")
    if wide:
        table.add_column("Model", overflow="ellipsis", max_width=24)
    table.add_column("Time", justify="right", no_wrap=True)
    table.add_column("Gap", justify="right", no_wrap=True)
    table.add_column("Laps", justify="right")
    table.add_column("Design")
    # a default board takes runs of any conditions: each entry says its own
    each_conditions = wide and board.conditions is None
    if each_conditions:
        table.add_column("Conditions")
    if wide:
        table.add_column("Submitted", no_wrap=True)
    for entry in page.entries:
        cells = [str(entry.rank), entry.racer]
        if wide:
            cells.append(entry.model_name)
        cells += [time_label(entry), gap(entry.gap_ms), str(entry.laps_completed),
                  design_summary(entry.design)]
        if each_conditions:
            cells.append(conditions.short(entry.conditions))
        if wide:
            cells.append(submitted(entry).strftime("%b %d %H:%M"))
        plain_row(table, *cells, style=None if entry.qualified else "dim")
    return table
