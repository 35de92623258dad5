"""Which board the CLI talks to. Locally, the service runs in-process on the SQLite board."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from drboard_assembler.record import Record
from drboard_functions.models import BoardPage, BoardView, HistoryItem, PushReceipt, RacerView


class BoardClient(Protocol):
    def push(self, record: Record, board_id: str | None) -> PushReceipt: ...
    def boards(self) -> list[BoardView]: ...
    def board_page(self, board_id: str, limit: int, cursor: str | None) -> BoardPage: ...
    def racer(self, board_id: str, racer: str) -> RacerView: ...
    def history(self, racer: str, board_id: str | None) -> list[HistoryItem]: ...


def local_board(db: Path) -> BoardClient:
    # Imported here so commands that need no board (assemble) start faster.
    from drboard_functions.service import LeaderboardService
    from drboard_functions.stores.sqlite import SqliteStore

    return LeaderboardService(SqliteStore(db))
