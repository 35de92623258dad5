"""Which board the CLI talks to. Locally, the service runs in-process on the SQLite board; a
deployed board (or `drboard serve`) answers the same calls over HTTP (``remote.HttpBoard``)."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from drboard_assembler.record import Record
from drboard_functions.models import (
    Board,
    BoardChanges,
    BoardPage,
    BoardSpec,
    BoardView,
    ExportPage,
    HistoryItem,
    ImportedSubmission,
    ImportReceipt,
    PushReceipt,
    RacerSummary,
    RacerView,
)


class BoardClient(Protocol):
    # racers
    def push(self, record: Record, board_id: str | None) -> PushReceipt: ...
    def boards(self) -> list[BoardView]: ...
    def board_page(self, board_id: str, limit: int, cursor: str | None) -> BoardPage: ...
    def racer(self, board_id: str, racer: str) -> RacerView: ...
    def history(self, racer: str, board_id: str | None) -> list[HistoryItem]: ...
    def status(self, racer: str, board_id: str | None) -> RacerSummary: ...

    # organisers
    def create_board(self, spec: BoardSpec) -> BoardView: ...
    def update_board(self, board_id: str, changes: BoardChanges) -> BoardView: ...
    def close_board(self, board_id: str) -> BoardView: ...
    def delete_board(self, board_id: str) -> BoardView: ...
    def restore_board(self, board_id: str) -> BoardView: ...
    def export_page(self, board_id: str, cursor: str | None) -> ExportPage: ...
    def import_board(self, board: Board) -> tuple[BoardView, bool]: ...
    def import_submission(self, board_id: str, item: ImportedSubmission) -> ImportReceipt: ...


def local_board(db: Path) -> BoardClient:
    # Imported here so commands that need no board (assemble) start faster.
    from drboard_functions.service import LeaderboardService
    from drboard_functions.stores.sqlite import SqliteStore

    return LeaderboardService(SqliteStore(db))
