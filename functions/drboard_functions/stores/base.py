"""The port the service owns. Adapters (SQLite, DynamoDB) implement it; one contract suite tests both."""

from __future__ import annotations

from typing import NamedTuple, Protocol

from drboard_assembler.record import Record

from ..models import Board, Entry, Submission, WriteOutcome


class StoredBoard(NamedTuple):
    board: Board
    participants: int


class BoardStore(Protocol):
    def get_board(self, board_id: str) -> StoredBoard | None:
        """The board and its number of racers, or None."""

    def create_board(self, board: Board) -> StoredBoard:
        """Create the board unless it exists; return what is stored."""

    def list_boards(self) -> list[StoredBoard]:
        """Every board, ordered by id."""

    def record_submission(self, submission: Submission, record: Record,
                          entry: Entry) -> WriteOutcome:
        """Atomically: store the submission unless its id is already on the board (a duplicate,
        which changes nothing), and make ``entry`` the racer's entry if it has a strictly lower
        score key than the current one. Concurrent calls never lose a submission or a best."""

    def top(self, board_id: str, limit: int, after: str | None = None) -> list[Entry]:
        """Up to ``limit`` entries in rank-key order, starting after the rank key ``after``."""

    def get_entry(self, board_id: str, racer_key: str) -> Entry | None:
        """The racer's entry on the board."""

    def count_better(self, board_id: str, score_key: str) -> int:
        """How many entries have a score key strictly lower than ``score_key``."""

    def history(self, racer_key: str, board_id: str | None = None) -> list[Submission]:
        """The racer's submissions, oldest first, on one board or all."""

    def get_record(self, board_id: str, submission_id: str) -> Record | None:
        """The full record of one submission."""


class RecordArchive(Protocol):
    def put(self, board_id: str, record: Record) -> None:
        """Keep the raw record of an accepted submission (S3 in the cloud)."""
