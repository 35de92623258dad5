"""The embedded board: SQLite (WAL), one transaction per push.

Entries sit in one table keyed by (board, racer) with an index on (board, rank key), so the top N
is an index range read of N rows whatever the board's size.
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from drboard_assembler.record import Record

from ..models import Board, Entry, Submission, WriteOutcome
from .base import StoredBoard

SCHEMA = """
CREATE TABLE IF NOT EXISTS boards (
    board_id     TEXT PRIMARY KEY,
    board        TEXT NOT NULL,
    participants INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS entries (
    board_id  TEXT NOT NULL,
    racer_key TEXT NOT NULL,
    score_key TEXT NOT NULL,
    rank_key  TEXT NOT NULL,
    entry     TEXT NOT NULL,
    PRIMARY KEY (board_id, racer_key)
) WITHOUT ROWID;
CREATE INDEX IF NOT EXISTS entries_by_rank ON entries (board_id, rank_key);
CREATE TABLE IF NOT EXISTS submissions (
    board_id      TEXT NOT NULL,
    submission_id TEXT NOT NULL,
    racer_key     TEXT NOT NULL,
    submitted_at  TEXT NOT NULL,
    submission    TEXT NOT NULL,
    record        TEXT NOT NULL,
    PRIMARY KEY (board_id, submission_id)
);
CREATE INDEX IF NOT EXISTS submissions_by_racer ON submissions (racer_key, submitted_at);
"""

BUSY_TIMEOUT_S = 30.0


class SqliteStore:
    def __init__(self, path: Path | str) -> None:
        self.path = str(path)
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        # Autocommit mode: every write below opens its own BEGIN IMMEDIATE transaction.
        self._db = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S, isolation_level=None,
                                   check_same_thread=False)
        self._enable_wal()
        self._db.execute("PRAGMA synchronous=NORMAL")
        with self._write():
            for statement in filter(str.strip, SCHEMA.split(";")):
                self._db.execute(statement)

    def _enable_wal(self) -> None:
        # Switching a new file to WAL needs a moment with no other writer, and SQLite does not
        # apply the busy timeout to it: wait for that moment ourselves.
        deadline = time.monotonic() + BUSY_TIMEOUT_S
        while True:
            try:
                self._db.execute("PRAGMA journal_mode=WAL")
                return
            except sqlite3.OperationalError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.01)

    def close(self) -> None:
        self._db.close()

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        self._db.execute("BEGIN IMMEDIATE")
        try:
            yield self._db
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    # ---- boards ---------------------------------------------------------------------------

    def get_board(self, board_id: str) -> StoredBoard | None:
        row = self._db.execute(
            "SELECT board, participants FROM boards WHERE board_id = ?", (board_id,)
        ).fetchone()
        return _board(row) if row else None

    def create_board(self, board: Board) -> StoredBoard:
        with self._write() as db:
            db.execute("INSERT OR IGNORE INTO boards (board_id, board) VALUES (?, ?)",
                       (board.board_id, board.model_dump_json()))
        stored = self.get_board(board.board_id)
        assert stored is not None
        return stored

    def list_boards(self) -> list[StoredBoard]:
        rows = self._db.execute("SELECT board, participants FROM boards ORDER BY board_id")
        return [_board(row) for row in rows]

    # ---- submissions ----------------------------------------------------------------------

    def record_submission(self, submission: Submission, record: Record,
                          entry: Entry) -> WriteOutcome:
        with self._write() as db:
            inserted = db.execute(
                "INSERT OR IGNORE INTO submissions VALUES (?, ?, ?, ?, ?, ?)",
                (submission.board_id, submission.submission_id, submission.racer_key,
                 submission.submitted_at.isoformat(), submission.model_dump_json(),
                 record.model_dump_json()),
            ).rowcount
            current = self._entry(db, entry.board_id, entry.racer_key)
            if not inserted:
                assert current is not None, "a stored submission always has an entry"
                return WriteOutcome(duplicate=True, improved=False, entry=current)
            if current is not None and current.score_key <= entry.score_key:
                return WriteOutcome(duplicate=False, improved=False, entry=current)
            db.execute(
                "INSERT OR REPLACE INTO entries VALUES (?, ?, ?, ?, ?)",
                (entry.board_id, entry.racer_key, entry.score_key, entry.rank_key,
                 entry.model_dump_json()),
            )
            if current is None:
                db.execute("UPDATE boards SET participants = participants + 1 WHERE board_id = ?",
                           (entry.board_id,))
            return WriteOutcome(duplicate=False, improved=True, entry=entry)

    def top(self, board_id: str, limit: int, after: str | None = None) -> list[Entry]:
        rows = self._db.execute(
            "SELECT entry FROM entries WHERE board_id = ? AND rank_key > ? "
            "ORDER BY rank_key LIMIT ?",
            (board_id, after or "", limit),
        )
        return [Entry.model_validate_json(row[0]) for row in rows]

    def get_entry(self, board_id: str, racer_key: str) -> Entry | None:
        return self._entry(self._db, board_id, racer_key)

    @staticmethod
    def _entry(db: sqlite3.Connection, board_id: str, racer_key: str) -> Entry | None:
        row = db.execute("SELECT entry FROM entries WHERE board_id = ? AND racer_key = ?",
                         (board_id, racer_key)).fetchone()
        return Entry.model_validate_json(row[0]) if row else None

    def count_better(self, board_id: str, score_key: str) -> int:
        # Score keys are fixed-width prefixes of rank keys, so "rank_key < score_key" selects
        # exactly the entries with a lower score key, using the rank index.
        row = self._db.execute(
            "SELECT COUNT(*) FROM entries WHERE board_id = ? AND rank_key < ?",
            (board_id, score_key),
        ).fetchone()
        return int(row[0])

    def history(self, racer_key: str, board_id: str | None = None) -> list[Submission]:
        if board_id is None:
            rows = self._db.execute(
                "SELECT submission FROM submissions WHERE racer_key = ? ORDER BY submitted_at",
                (racer_key,))
        else:
            rows = self._db.execute(
                "SELECT submission FROM submissions WHERE racer_key = ? AND board_id = ? "
                "ORDER BY submitted_at", (racer_key, board_id))
        return [Submission.model_validate_json(row[0]) for row in rows]

    def get_record(self, board_id: str, submission_id: str) -> Record | None:
        row = self._db.execute(
            "SELECT record FROM submissions WHERE board_id = ? AND submission_id = ?",
            (board_id, submission_id)).fetchone()
        return Record.model_validate_json(row[0]) if row else None


def _board(row: tuple[str, int]) -> StoredBoard:
    return StoredBoard(Board.model_validate_json(row[0]), int(row[1]))
