"""When a board next changes by the clock alone: it opens, or it closes. What it shows (its
status, whether designs show) holds until then, its version unchanged. No model is imported:
the board may be a view model or its JSON read back (``status``, ``opens_at``, ``closes_at``)."""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .models.views import BoardView


def next_change(board: BoardView) -> datetime | None:
    """The board's next opening (upcoming) or closing (open); None: never (closed, or open
    with no closing set)."""
    if board.status == "UPCOMING":
        return board.opens_at
    if board.status == "OPEN":
        return board.closes_at
    return None
