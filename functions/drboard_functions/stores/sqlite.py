"""The embedded board: SQLite (WAL), one transaction per push.

Entries sit in one table keyed by (board, racer) with an index on (board, rank key), so the top N
is an index range read of N rows whatever the board's size. ``rank_counts`` holds, per board, the
counts of entries by score laid out by ``rank_buckets``, changed in the same transaction as every
entry: a rank sums at most three index ranges of bounded size, never the better entries. A board
file from before the counts gets them when it is opened.
"""

from __future__ import annotations

import sqlite3
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drboard_assembler.record import Record

from .. import ranking
from ..errors import StoreBusy
from ..models.domain import (
    AliasClaim,
    AuditEvent,
    Board,
    Entry,
    EventBans,
    NearRun,
    RacerTally,
    RunAuthor,
    RunPrint,
    Submission,
    SubmissionLimits,
    WriteOutcome,
    with_flag,
    without_flag,
)
from . import rank_buckets
from .base import (
    AliasConflict,
    AliasSlice,
    AuditSlice,
    BoardChanged,
    BoardHasEntries,
    BoardSlice,
    FingerprintTaken,
    HistorySlice,
    ImportBatch,
    ImportedRow,
    ImportWritten,
    Indexed,
    LimitReached,
    LookalikeTaken,
    PushReads,
    RankBuild,
    StoredBoard,
    StoredSubmissionPage,
    SubmissionPage,
    claimable,
    delivered,
    new_rows,
    page_token,
    read_page_token,
    runs_seen,
    stored_record,
    stored_webhook,
)
from .sqlite_seasons import SEASON_SCHEMA, SqliteSeasons

if TYPE_CHECKING:
    from ..models.notices import Webhook
    from .pages import PageShelf

SCHEMA = """
CREATE TABLE IF NOT EXISTS boards (
    board_id     TEXT PRIMARY KEY,
    board        TEXT NOT NULL,
    participants INTEGER NOT NULL DEFAULT 0,
    version      INTEGER NOT NULL DEFAULT 0
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
CREATE TABLE IF NOT EXISTS fingerprints (
    board_id    TEXT NOT NULL,
    fingerprint TEXT NOT NULL,
    racer_key   TEXT NOT NULL,
    PRIMARY KEY (board_id, fingerprint)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS audit (
    board_id TEXT NOT NULL,
    event_id TEXT NOT NULL,
    event    TEXT NOT NULL,
    PRIMARY KEY (board_id, event_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS rank_counts (
    board_id TEXT NOT NULL,
    node     TEXT NOT NULL,
    child    TEXT NOT NULL,
    entries  INTEGER NOT NULL,
    PRIMARY KEY (board_id, node, child)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS webhooks (
    target     TEXT NOT NULL,
    webhook_id TEXT NOT NULL,
    webhook    TEXT NOT NULL,
    PRIMARY KEY (target, webhook_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS notices (
    notice_id   TEXT NOT NULL,
    webhook_id  TEXT NOT NULL,
    state       TEXT NOT NULL,
    lease_until TEXT NOT NULL,
    PRIMARY KEY (notice_id, webhook_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS aliases (
    racer_key TEXT PRIMARY KEY,
    principal TEXT NOT NULL UNIQUE,
    claim     TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS run_authors (
    fingerprint TEXT NOT NULL,
    racer_key   TEXT NOT NULL,
    first_at    TEXT NOT NULL,
    board_id    TEXT NOT NULL,
    submission  TEXT NOT NULL,
    PRIMARY KEY (fingerprint, racer_key)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS near_runs (
    lane          TEXT NOT NULL,
    best_ms       INTEGER NOT NULL,
    fingerprint   TEXT NOT NULL,
    racer_key     TEXT NOT NULL,
    board_id      TEXT NOT NULL,
    submission_id TEXT NOT NULL,
    laps          TEXT NOT NULL,
    PRIMARY KEY (lane, best_ms, fingerprint, racer_key, board_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS skeletons (
    board_id  TEXT NOT NULL,
    skeleton  TEXT NOT NULL,
    racer_key TEXT NOT NULL,
    PRIMARY KEY (board_id, skeleton)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS event_settings (
    name    TEXT PRIMARY KEY,
    data    TEXT NOT NULL,
    version INTEGER NOT NULL
);
"""

EVENT_BANS = "bans"
#: A racer's first time with a run: kept unless this one is earlier.
INDEX_AUTHOR = ("INSERT INTO run_authors VALUES (?, ?, ?, ?, ?) ON CONFLICT (fingerprint, racer_key) "
                "DO UPDATE SET first_at = excluded.first_at, board_id = excluded.board_id, "
                "submission = excluded.submission WHERE excluded.first_at < first_at")
INDEX_NEAR = "INSERT OR IGNORE INTO near_runs VALUES (?, ?, ?, ?, ?, ?, ?)"
#: The page cache of a batch of an import (KiB). Pages past it are written to the WAL while the
#: import still checks lines on other cores: twice this left more for the commit to write, once
#: every line was checked, and made an import of 100,000 racers 10 % slower.
IMPORT_CACHE_KIB = 128 * 1024
#: Values one statement binds at most (SQLite's default limit is 999 before 3.32).
IN_CHUNK = 500

BUSY_TIMEOUT_S = 30.0
#: Rows an export reads at a time.
EXPORT_PAGE_ROWS = 500
BUSY_RETRY_AFTER_S = 1


@dataclass
class FirstTry:
    """Writes tried without waiting (``SqliteStore.without_waiting``): whether one met another
    writer of the file."""

    met_writer: bool = False


class SqliteStore(SqliteSeasons):
    """One SQLite connection per thread that uses the store (WAL: readers run alongside the one
    writer; writers take turns through BEGIN IMMEDIATE). ``:memory:`` is one database per
    connection, so that board keeps a single connection for every thread."""

    #: Pages are kept by the processes that read the file (and by `drboard pull`, beside it:
    #: ``sqlite_standings``): each has the file's version in one read of its own.
    pages: PageShelf | None = None

    def __init__(self, path: Path | str) -> None:
        self.path = str(path)
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        self._connections: list[sqlite3.Connection] = []
        self._connecting = threading.Lock()
        self._local = threading.local()
        self._first = self._connect()
        self._enable_wal()
        with self._write():
            counted = self._has_table("rank_counts")
            for statement in filter(str.strip, (SCHEMA + SEASON_SCHEMA).split(";")):
                self._db.execute(statement)
            if not counted:  # a board file from before the rank counts
                self._count_every_board()
            columns = {row[1] for row in self._db.execute("PRAGMA table_info(boards)")}
            if "version" not in columns:  # a board file from before versions
                self._db.execute("ALTER TABLE boards ADD COLUMN version INTEGER NOT NULL DEFAULT 0")
            if "settings_version" not in columns:  # a board file from before settings versions
                self._db.execute("ALTER TABLE boards ADD COLUMN settings_version INTEGER NOT NULL "
                                 "DEFAULT 0")

    def _connect(self) -> sqlite3.Connection:
        # Autocommit mode: every write below opens its own BEGIN IMMEDIATE transaction.
        db = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S, isolation_level=None,
                             check_same_thread=False)
        db.execute("PRAGMA synchronous=NORMAL")
        with self._connecting:
            self._connections.append(db)
        self._local.db = db
        return db

    @property
    def _db(self) -> sqlite3.Connection:
        """This thread's connection."""
        db: sqlite3.Connection | None = getattr(self._local, "db", None)
        if db is None:
            if self.path == ":memory:":
                db = self._local.db = self._first
            else:
                db = self._connect()
        return db

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

    def _has_table(self, name: str) -> bool:
        return self._db.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?",
                                (name,)).fetchone() is not None

    def _count_every_board(self) -> None:
        keys: dict[str, list[str]] = {}
        for board_id, score_key in self._db.execute("SELECT board_id, score_key FROM entries"):
            keys.setdefault(board_id, []).append(score_key)
        for board_id, score_keys in keys.items():
            self._move_counts(self._db, board_id, rank_buckets.tally(score_keys))

    def close(self) -> None:
        with self._connecting:
            for db in self._connections:
                db.close()

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (inside ``held_writes``, a savepoint of the held one). Another
        process holding the board past the busy timeout is StoreBusy (nothing written)."""
        if getattr(self._local, "held", False):
            with self._savepoint() as db:
                yield db
            return
        with _busy_as_store_busy(self.path, getattr(self._local, "first_try", None)):
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield self._db
            except BaseException:
                if self._db.in_transaction:
                    self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")

    @contextmanager
    def _savepoint(self) -> Iterator[sqlite3.Connection]:
        db = self._db
        db.execute("SAVEPOINT write")
        try:
            yield db
        except BaseException:
            db.execute("ROLLBACK TO write")
            db.execute("RELEASE write")
            raise
        db.execute("RELEASE write")

    @contextmanager
    def without_waiting(self) -> Iterator[FirstTry]:
        """The block's writes on this thread fail at once (StoreBusy) rather than wait for another
        writer of the file; the answer says whether one met such a writer (then nothing it tried
        was written, and the caller may try again where waiting holds nothing up)."""
        attempt = FirstTry()
        db = self._db
        db.execute("PRAGMA busy_timeout = 0")
        self._local.first_try = attempt
        try:
            yield attempt
        finally:
            self._local.first_try = None
            db.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")

    @contextmanager
    def held_writes(self) -> Iterator[None]:
        """Every write this thread makes in the block in one transaction, each a savepoint of
        it, with the page cache of an import's batch: committed when the block ends, rolled
        back when it raises (then nothing was written). Other writers wait for its end, up to
        the busy timeout."""
        held = getattr(self._local, "held", False)
        with self._bigger_cache(), self._write():
            self._local.held = True
            try:
                yield
            finally:
                self._local.held = held

    # ---- boards ---------------------------------------------------------------------------

    def get_board(self, board_id: str) -> StoredBoard | None:
        row = self._db.execute(
            f"SELECT {BOARD_COLUMNS} FROM boards WHERE board_id = ?", (board_id,)
        ).fetchone()
        return _board(row) if row else None

    def board_version(self, board_id: str) -> int | None:
        row = self._db.execute("SELECT version FROM boards WHERE board_id = ?", (board_id,)).fetchone()
        return int(row[0]) if row else None

    def create_board(self, board: Board) -> StoredBoard:
        with self._write() as db:
            db.execute("INSERT OR IGNORE INTO boards (board_id, board) VALUES (?, ?)",
                       (board.board_id, board.model_dump_json()))
        stored = self.get_board(board.board_id)
        assert stored is not None
        return stored

    def update_board(self, board: Board, *, only_if_empty: bool = False) -> StoredBoard:
        with self._write() as db:
            stored = self.get_board(board.board_id)
            if stored is None:
                raise KeyError(board.board_id)
            if only_if_empty and stored.participants:
                raise BoardHasEntries(board.board_id)
            db.execute("UPDATE boards SET board = ?, version = version + 1, "
                       "settings_version = settings_version + 1 WHERE board_id = ?",
                       (board.model_dump_json(), board.board_id))
        updated = self.get_board(board.board_id)
        assert updated is not None
        return updated

    def list_boards(self) -> list[StoredBoard]:
        rows = self._db.execute(f"SELECT {BOARD_COLUMNS} FROM boards ORDER BY board_id")
        return [_board(row) for row in rows]

    def boards_page(self, after: str | None, limit: int) -> BoardSlice:
        rows = self._db.execute(
            f"SELECT {BOARD_COLUMNS}, board_id FROM boards WHERE board_id > ? "
            "ORDER BY board_id LIMIT ?",
            (read_page_token(after, 1)[0] if after else "", limit + 1)).fetchall()
        page = rows[:limit]
        return BoardSlice([_board(row[:4]) for row in page],
                          page_token([page[-1][4]]) if len(rows) > limit else None)

    # ---- submissions ----------------------------------------------------------------------

    def record_submission(self, submission: Submission, record_json: str, entry: Entry,
                          limits: SubmissionLimits | None = None,
                          fingerprints: Sequence[str] = (),
                          audit: AuditEvent | None = None, *,
                          runs: Sequence[RunPrint] = (), claim: AliasClaim | None = None,
                          skeleton: str | None = None) -> WriteOutcome:
        with self._write() as db:
            current = self._entry(db, entry.board_id, entry.racer_key)
            if self._has_submission(db, submission.board_id, submission.submission_id):
                return WriteOutcome(duplicate=True, improved=False, entry=current or entry)
            if limits is not None:
                self._check_versions(db, submission.board_id, limits)
                _check_limits(self._tally(db, submission.board_id, submission.racer_key), limits)
            self._claim_fingerprints(db, entry.board_id, entry.racer_key, fingerprints)
            if skeleton is not None:
                self._hold_skeleton(db, entry.board_id, skeleton, entry.racer_key, strict=True)
            if claim is not None:
                self._claim(db, claim)
            self._index_runs(db, submission, runs)
            if audit is not None:
                self._append_audit(db, audit)
            db.execute(
                "INSERT INTO submissions VALUES (?, ?, ?, ?, ?, ?)",
                (submission.board_id, submission.submission_id, submission.racer_key,
                 ranking.timestamp(submission.submitted_at), submission.model_dump_json(),
                 record_json),
            )
            if current is not None and current.rank_key <= entry.rank_key:
                return WriteOutcome(duplicate=False, improved=False, entry=current)
            db.execute(
                "INSERT OR REPLACE INTO entries VALUES (?, ?, ?, ?, ?)",
                (entry.board_id, entry.racer_key, entry.score_key, entry.rank_key,
                 entry.model_dump_json()),
            )
            self._move_counts(db, entry.board_id, rank_buckets.changes(
                entry.score_key, current.score_key if current else None))
            db.execute("UPDATE boards SET participants = participants + ?, version = version + 1 "
                       "WHERE board_id = ?", (1 if current is None else 0, entry.board_id))
            return WriteOutcome(duplicate=False, improved=True, entry=entry)

    def _check_versions(self, db: sqlite3.Connection, board_id: str, limits: SubmissionLimits) -> None:
        if limits.settings_version is not None:
            row = db.execute("SELECT settings_version FROM boards WHERE board_id = ?",
                             (board_id,)).fetchone()
            if row is None or int(row[0]) != limits.settings_version:
                raise BoardChanged(board_id)
        if limits.bans_version is not None and self._event_bans(db)[1] != limits.bans_version:
            raise BoardChanged("event bans")

    @staticmethod
    def _hold_skeleton(db: sqlite3.Connection, board_id: str, skeleton: str, racer_key: str,
                       strict: bool) -> str | None:
        if db.execute("INSERT OR IGNORE INTO skeletons VALUES (?, ?, ?)",
                      (board_id, skeleton, racer_key)).rowcount:
            return None  # it was free: now held
        holder = _holder(db, "skeletons", "skeleton", board_id, skeleton)
        if holder == racer_key:
            return None
        if strict:
            raise LookalikeTaken(holder)
        return holder

    @staticmethod
    def _index_runs(db: sqlite3.Connection, submission: Submission, runs: Sequence[RunPrint]) -> None:
        at = ranking.timestamp(submission.submitted_at)
        for run in runs:
            db.execute(INDEX_AUTHOR, (run.fingerprint, submission.racer_key, at,
                                      submission.board_id, submission.submission_id))
            if run.laps_ms:
                db.execute(INDEX_NEAR,
                           (run.lane, run.laps_ms[0], run.fingerprint, submission.racer_key,
                            submission.board_id, submission.submission_id,
                            ",".join(map(str, run.laps_ms))))

    @staticmethod
    def _claim_fingerprints(db: sqlite3.Connection, board_id: str, racer_key: str,
                            fingerprints: Sequence[str]) -> None:
        for fingerprint in fingerprints:
            if db.execute("INSERT OR IGNORE INTO fingerprints VALUES (?, ?, ?)",
                          (board_id, fingerprint, racer_key)).rowcount:
                continue  # it was free: now claimed
            holder = _holder(db, "fingerprints", "fingerprint", board_id, fingerprint)
            if holder != racer_key:
                raise FingerprintTaken(holder)

    @staticmethod
    def _has_submission(db: sqlite3.Connection, board_id: str, submission_id: str) -> bool:
        return db.execute("SELECT 1 FROM submissions WHERE board_id = ? AND submission_id = ?",
                          (board_id, submission_id)).fetchone() is not None

    def get_submission(self, board_id: str, racer_key: str, submission_id: str) -> Submission | None:
        row = self._db.execute(
            "SELECT submission FROM submissions WHERE board_id = ? AND submission_id = ? "
            "AND racer_key = ?", (board_id, submission_id, racer_key)).fetchone()
        return Submission.model_validate_json(row[0]) if row else None

    def push_reads(self, board_id: str, racer_key: str, submission_id: str,
                   prints: Sequence[RunPrint], near_ms: int) -> PushReads:
        bans, version = self.event_bans()
        return PushReads(self.get_board(board_id), bans, version,
                         self.get_submission(board_id, racer_key, submission_id),
                         self.get_entry(board_id, racer_key), runs_seen(self, prints, near_ms))

    def tally(self, board_id: str, racer_key: str) -> RacerTally:
        return self._tally(self._db, board_id, racer_key)

    @staticmethod
    def _tally(db: sqlite3.Connection, board_id: str, racer_key: str) -> RacerTally:
        count, last = db.execute(
            "SELECT COUNT(*), MAX(submitted_at) FROM submissions WHERE racer_key = ? AND board_id = ?",
            (racer_key, board_id)).fetchone()
        return RacerTally(submissions=int(count),
                          last_submitted_at=ranking.parse_timestamp(last) if last else None)

    def submissions(self, board_id: str, after: str | None, limit: int) -> SubmissionPage:
        page = self.stored_submissions(board_id, after, limit)
        return SubmissionPage([(s, stored_record(raw)) for s, raw in page.submissions], page.after)

    def stored_submissions(self, board_id: str, after: str | None, limit: int) -> StoredSubmissionPage:
        rows = self._db.execute(
            "SELECT submission_id, submission, record FROM submissions "
            "WHERE board_id = ? AND submission_id > ? ORDER BY submission_id LIMIT ?",
            (board_id, after or "", limit)).fetchall()
        page = [(Submission.model_validate_json(row[1]), row[2]) for row in rows]
        return StoredSubmissionPage(page, rows[-1][0] if len(rows) == limit else None)

    def exported_entries(self, board_id: str) -> Iterator[bytes]:
        # CAST AS BLOB hands over the stored UTF-8 bytes as they are: nothing decoded.
        yield from self._column_pages(
            "SELECT CAST(entry AS BLOB) FROM entries WHERE board_id = ? ORDER BY rank_key",
            (board_id,), lambda row: row[0])

    def exported_submissions(self, board_id: str) -> Iterator[tuple[bytes, bytes]]:
        yield from self._column_pages(
            "SELECT CAST(submission AS BLOB), CAST(record AS BLOB) FROM submissions "
            "WHERE board_id = ? ORDER BY submission_id", (board_id,), tuple)

    def _column_pages(self, query: str, parameters: tuple[str, ...],
                      shape: Callable[[Any], Any]) -> Iterator[Any]:
        rows = self._db.execute(query, parameters)
        while page := rows.fetchmany(EXPORT_PAGE_ROWS):
            yield from map(shape, page)

    def front_page(self, board_id: str, limit: int) -> tuple[StoredBoard | None, list[Entry]]:
        stored = self.get_board(board_id)
        return stored, (self.top(board_id, limit) if stored else [])

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
        # One statement, so the counts it adds up are of one moment of the board.
        steps = rank_buckets.path(score_key)
        terms = ["(SELECT COALESCE(SUM(entries), 0) FROM rank_counts "
                 "WHERE board_id = ? AND node = ? AND child < ?)"] * len(steps)
        parameters: list[str] = [value for node, child in steps for value in (board_id, node, child)]
        if rank_buckets.in_overflow(score_key):
            # Score keys are fixed-width prefixes of rank keys, so this range holds exactly the
            # entries under the overflow with a lower score key.
            terms.append("(SELECT COUNT(*) FROM entries "
                         "WHERE board_id = ? AND rank_key >= ? AND rank_key < ?)")
            parameters += [board_id, rank_buckets.OVERFLOW_START, score_key]
        row = self._db.execute("SELECT " + " + ".join(terms), parameters).fetchone()
        return int(row[0])

    @staticmethod
    def _move_counts(db: sqlite3.Connection, board_id: str,
                     moves: dict[str, dict[str, int]]) -> None:
        db.executemany(
            "INSERT INTO rank_counts VALUES (?, ?, ?, ?) ON CONFLICT (board_id, node, child) "
            "DO UPDATE SET entries = entries + excluded.entries",
            [(board_id, node, child, change) for node, children in moves.items()
             for child, change in children.items()])
        # Only a count that went down can have reached zero.
        db.executemany("DELETE FROM rank_counts WHERE board_id = ? AND node = ? AND child = ? "
                       "AND entries = 0",
                       [(board_id, node, child) for node, children in moves.items()
                        for child, change in children.items() if change < 0])

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

    def history_page(self, racer_key: str, board_id: str | None, after: str | None,
                     limit: int) -> HistorySlice:
        # Keyset pagination on (submitted_at, board_id, submission_id), in the racer index.
        position = read_page_token(after, 3) if after else ["", "", ""]
        on_board = "AND board_id = ? " if board_id is not None else ""
        rows = self._db.execute(
            "SELECT submission, submitted_at, board_id, submission_id FROM submissions "
            f"WHERE racer_key = ? {on_board}AND (submitted_at, board_id, submission_id) > (?, ?, ?) "
            "ORDER BY submitted_at, board_id, submission_id LIMIT ?",
            (racer_key, *([board_id] if board_id is not None else []), *position, limit + 1),
        ).fetchall()
        page = rows[:limit]
        return HistorySlice([Submission.model_validate_json(row[0]) for row in page],
                            page_token(page[-1][1:]) if len(rows) > limit else None)

    def get_record(self, board_id: str, submission_id: str) -> Record | None:
        row = self._db.execute(
            "SELECT record FROM submissions WHERE board_id = ? AND submission_id = ?",
            (board_id, submission_id)).fetchone()
        return stored_record(row[0]) if row else None

    # ---- moderation and audit -------------------------------------------------------------

    def remove_entry(self, board_id: str, racer_key: str) -> Entry | None:
        with self._write() as db:
            current = self._entry(db, board_id, racer_key)
            if current is not None:
                db.execute("DELETE FROM entries WHERE board_id = ? AND racer_key = ?", (board_id, racer_key))
                self._move_counts(db, board_id, rank_buckets.changes(None, current.score_key))
                db.execute("UPDATE boards SET participants = participants - 1, version = version + 1 "
                           "WHERE board_id = ?", (board_id,))
            return current

    def build_rank_counters(self, board_id: str, budget_s: float | None = None) -> RankBuild:
        """Every board here has its rank counts: a board file from before them gets them when
        it is opened."""
        stored = self.get_board(board_id)
        participants = stored.participants if stored else 0
        return RankBuild(done=stored is not None, counted=participants, participants=participants)

    def restore_entry(self, entry: Entry) -> None:
        with self._write() as db:
            added = db.execute(
                "INSERT OR IGNORE INTO entries VALUES (?, ?, ?, ?, ?)",
                (entry.board_id, entry.racer_key, entry.score_key, entry.rank_key,
                 entry.model_dump_json())).rowcount
            if added:
                self._move_counts(db, entry.board_id, rank_buckets.changes(entry.score_key, None))
                db.execute("UPDATE boards SET participants = participants + 1, version = version + 1 "
                           "WHERE board_id = ?", (entry.board_id,))

    def append_audit(self, event: AuditEvent) -> None:
        with self._write() as db:
            self._append_audit(db, event)

    @staticmethod
    def _append_audit(db: sqlite3.Connection, event: AuditEvent) -> None:
        db.execute("INSERT INTO audit VALUES (?, ?, ?)",
                   (event.board_id, event.event_id, event.model_dump_json()))

    def audit(self, board_id: str, after: str | None, limit: int) -> AuditSlice:
        rows = self._db.execute(
            "SELECT event_id, event FROM audit WHERE board_id = ? AND event_id > ? "
            "ORDER BY event_id LIMIT ?", (board_id, after or "", limit)).fetchall()
        events = [AuditEvent.model_validate_json(row[1]) for row in rows]
        return AuditSlice(events, rows[-1][0] if len(rows) == limit else None)

    # ---- aliases --------------------------------------------------------------------------

    def claim_alias(self, claim: AliasClaim) -> AliasClaim:
        with self._write() as db:
            return self._claim(db, claim)

    def _claim(self, db: sqlite3.Connection, claim: AliasClaim) -> AliasClaim:
        for holder in (self._alias(db, "racer_key", claim.racer_key),
                       self._alias(db, "principal", claim.principal)):
            if holder is None:
                continue
            if (holder.racer_key, holder.principal) == (claim.racer_key, claim.principal):
                return holder
            raise AliasConflict(holder)
        db.execute("INSERT INTO aliases VALUES (?, ?, ?)",
                   (claim.racer_key, claim.principal, claim.model_dump_json()))
        return claim

    def assign_alias(self, claim: AliasClaim) -> AliasClaim | None:
        with self._write() as db:
            previous = self._alias(db, "racer_key", claim.racer_key)
            db.execute("DELETE FROM aliases WHERE racer_key = ? OR principal = ?",
                       (claim.racer_key, claim.principal))
            db.execute("INSERT INTO aliases VALUES (?, ?, ?)",
                       (claim.racer_key, claim.principal, claim.model_dump_json()))
            return previous

    def release_alias(self, racer_key: str) -> AliasClaim | None:
        with self._write() as db:
            previous = self._alias(db, "racer_key", racer_key)
            db.execute("DELETE FROM aliases WHERE racer_key = ?", (racer_key,))
            return previous

    def aliases(self, after: str | None, limit: int) -> AliasSlice:
        rows = self._db.execute(
            "SELECT racer_key, claim FROM aliases WHERE racer_key > ? ORDER BY racer_key LIMIT ?",
            (read_page_token(after, 1)[0] if after else "", limit + 1)).fetchall()
        page = rows[:limit]
        return AliasSlice([AliasClaim.model_validate_json(row[1]) for row in page],
                          page_token([page[-1][0]]) if len(rows) > limit else None)

    # ---- copies and lookalikes ------------------------------------------------------------

    def run_authors(self, fingerprint: str) -> list[RunAuthor]:
        rows = self._db.execute(
            "SELECT racer_key, first_at, board_id, submission FROM run_authors WHERE fingerprint = ? "
            "ORDER BY first_at", (fingerprint,)).fetchall()
        return [RunAuthor(fingerprint=fingerprint, racer_key=row[0],
                          first_at=ranking.parse_timestamp(row[1]), board_id=row[2],
                          submission_id=row[3]) for row in rows]

    def near_runs(self, lane: str, best_ms: int, tolerance_ms: int) -> list[NearRun]:
        rows = self._db.execute(
            "SELECT fingerprint, racer_key, board_id, submission_id, laps FROM near_runs "
            "WHERE lane = ? AND best_ms BETWEEN ? AND ? LIMIT 1000",
            (lane, best_ms - tolerance_ms, best_ms + tolerance_ms)).fetchall()
        return [NearRun(fingerprint=row[0], racer_key=row[1], board_id=row[2],
                        submission_id=row[3], laps_ms=[int(t) for t in row[4].split(",")])
                for row in rows]

    def lane_runs(self, lane: str) -> list[NearRun]:
        rows = self._db.execute(
            "SELECT fingerprint, racer_key, board_id, submission_id, laps FROM near_runs "
            "WHERE lane = ? ORDER BY best_ms, fingerprint, racer_key, board_id", (lane,))
        return [NearRun(fingerprint=row[0], racer_key=row[1], board_id=row[2],
                        submission_id=row[3], laps_ms=[int(t) for t in row[4].split(",")])
                for row in rows]

    def fingerprint_holder(self, board_id: str, fingerprint: str) -> str | None:
        row = self._db.execute("SELECT racer_key FROM fingerprints WHERE board_id = ? AND "
                               "fingerprint = ?", (board_id, fingerprint)).fetchone()
        return str(row[0]) if row else None

    def hand_over_fingerprint(self, board_id: str, fingerprint: str, racer_key: str) -> None:
        with self._write() as db:
            db.execute("INSERT OR REPLACE INTO fingerprints VALUES (?, ?, ?)",
                       (board_id, fingerprint, racer_key))

    def hand_over_skeleton(self, board_id: str, skeleton: str, racer_key: str) -> None:
        with self._write() as db:
            db.execute("INSERT OR REPLACE INTO skeletons VALUES (?, ?, ?)",
                       (board_id, skeleton, racer_key))

    def flag_submission(self, board_id: str, racer_key: str, submission_id: str,
                        flag: str, remove: bool = False) -> bool:
        changed = without_flag if remove else with_flag
        with self._write() as db:
            row = db.execute("SELECT submission FROM submissions WHERE board_id = ? AND "
                             "submission_id = ? AND racer_key = ?",
                             (board_id, submission_id, racer_key)).fetchone()
            if row is None:
                return False
            submission = Submission.model_validate_json(row[0])
            if (flag in submission.score.flags) != remove:
                return False
            db.execute("UPDATE submissions SET submission = ? WHERE board_id = ? AND submission_id = ?",
                       (changed(submission, flag).model_dump_json(), board_id, submission_id))
            entry = self._entry(db, board_id, racer_key)
            if entry is not None and entry.submission_id == submission_id:
                db.execute("UPDATE entries SET entry = ? WHERE board_id = ? AND racer_key = ?",
                           (changed(entry, flag).model_dump_json(), board_id, racer_key))
                db.execute("UPDATE boards SET version = version + 1 WHERE board_id = ?", (board_id,))
            return True

    def index_submission(self, submission: Submission, runs: Sequence[RunPrint],
                         fingerprints: Sequence[str], skeleton: str | None) -> Indexed:
        with self._write() as db:
            self._index_runs(db, submission, runs)
            holders = {}
            for fingerprint in fingerprints:
                try:
                    self._claim_fingerprints(db, submission.board_id, submission.racer_key,
                                             [fingerprint])
                except FingerprintTaken as taken:
                    holders[fingerprint] = taken.racer_key
            lookalike = None
            if skeleton is not None:
                lookalike = self._hold_skeleton(db, submission.board_id, skeleton,
                                                submission.racer_key, strict=False)
            return Indexed(holders, lookalike)

    # ---- bulk import ----------------------------------------------------------------------

    def present_submissions(self, board_id: str, keys: Sequence[tuple[str, str]]) -> set[str]:
        return self._present(self._db, board_id, [submission_id for _, submission_id in keys])

    @staticmethod
    def _present(db: sqlite3.Connection, board_id: str, submission_ids: Sequence[str]) -> set[str]:
        return {row[0] for row in _in_chunks(db, "SELECT submission_id FROM submissions WHERE "
                                                 "board_id = ? AND submission_id IN ({})",
                                             (board_id,), submission_ids)}

    def authors_of(self, fingerprints: Sequence[str]) -> dict[str, list[RunAuthor]]:
        authors: dict[str, list[RunAuthor]] = {}
        for fingerprint, racer, first_at, board_id, submission_id in _in_chunks(
                self._db, "SELECT fingerprint, racer_key, first_at, board_id, submission "
                          "FROM run_authors WHERE fingerprint IN ({}) ORDER BY first_at",
                (), fingerprints):
            authors.setdefault(fingerprint, []).append(RunAuthor(
                fingerprint=fingerprint, racer_key=racer, first_at=ranking.parse_timestamp(first_at),
                board_id=board_id, submission_id=submission_id))
        return authors

    def holders(self, board_id: str, fingerprints: Sequence[str],
                skeletons: Sequence[str]) -> tuple[dict[str, str], dict[str, str]]:
        held = dict(_in_chunks(self._db, "SELECT fingerprint, racer_key FROM fingerprints "
                                         "WHERE board_id = ? AND fingerprint IN ({})",
                               (board_id,), fingerprints))
        lookalikes = dict(_in_chunks(self._db, "SELECT skeleton, racer_key FROM skeletons "
                                               "WHERE board_id = ? AND skeleton IN ({})",
                                     (board_id,), skeletons))
        return held, lookalikes

    def import_batch(self, board_id: str, batch: ImportBatch) -> ImportWritten:
        with self._bigger_cache(), self._write() as db:
            if db.execute("SELECT 1 FROM boards WHERE board_id = ?", (board_id,)).fetchone() is None:
                raise KeyError(board_id)
            rows = new_rows(batch.rows, self._present(db, board_id,
                                                      [row.submission_id for row in batch.rows]))
            db.executemany("INSERT INTO submissions VALUES (?, ?, ?, ?, ?, ?)",
                           [(board_id, row.submission_id, row.racer_key, row.submitted_at,
                             row.submission, row.record) for row in rows])
            improved = self._import_entries(db, board_id, rows)
            # Each table's rows in the order of its key (a stable sort: rows of one key keep
            # their order, so the first of them still wins), so that the batch fills each
            # table's pages in turn rather than all of them at random.
            db.executemany("INSERT OR IGNORE INTO fingerprints VALUES (?, ?, ?)",
                           sorted((board_id, fingerprint, racer)
                                  for fingerprint, racer in batch.fingerprints))
            db.executemany("INSERT OR IGNORE INTO skeletons VALUES (?, ?, ?)",
                           sorted((board_id, skeleton, racer) for skeleton, racer in batch.skeletons))
            authors = [(run.fingerprint, run.racer_key, run.submitted_at, board_id,
                        run.submission_id) for run in batch.runs]
            authors.sort(key=_first(2))
            db.executemany(INDEX_AUTHOR, authors)
            near = [(run.lane, run.laps_ms[0], run.fingerprint, run.racer_key, board_id,
                     run.submission_id, ",".join(map(str, run.laps_ms)))
                    for run in batch.runs if run.laps_ms]
            near.sort(key=_first(5))
            db.executemany(INDEX_NEAR, near)
            db.executemany("INSERT OR IGNORE INTO audit VALUES (?, ?, ?)",
                           [(e.board_id, e.event_id, e.model_dump_json()) for e in batch.audit])
            return ImportWritten(created=len(rows), improved=improved)

    @contextmanager
    def _bigger_cache(self) -> Iterator[None]:
        """A batch's pages held in memory until it commits: a batch changes pages all over the
        board's tables, which the default cache (2 MiB) would write out and read back."""
        before = self._db.execute("PRAGMA cache_size").fetchone()[0]
        self._db.execute(f"PRAGMA cache_size = {-IMPORT_CACHE_KIB}")
        try:
            yield
        finally:
            self._db.execute(f"PRAGMA cache_size = {int(before)}")

    def _import_entries(self, db: sqlite3.Connection, board_id: str,
                        rows: Sequence[ImportedRow]) -> int:
        """Each racer's best of their entries and these rows' (an entry changes only for a
        strictly lower rank key), with the counts and participants moved to match; how many
        entries changed."""
        before = {racer: (score_key, rank_key) for racer, score_key, rank_key in _in_chunks(
            db, "SELECT racer_key, score_key, rank_key FROM entries WHERE board_id = ? "
                "AND racer_key IN ({})", (board_id,), list({row.racer_key for row in rows}))}
        best: dict[str, ImportedRow] = {}
        for row in rows:
            current = best[row.racer_key].rank_key if row.racer_key in best else (
                before[row.racer_key][1] if row.racer_key in before else None)
            if current is None or row.rank_key < current:
                best[row.racer_key] = row
        if not best:
            return 0
        db.executemany("INSERT OR REPLACE INTO entries VALUES (?, ?, ?, ?, ?)",
                       sorted((board_id, racer, row.score_key, row.rank_key, row.entry)
                              for racer, row in best.items()))
        # The batch's counts, tallied once: the new entries' minus those they replace.
        added = rank_buckets.tally([row.score_key for row in best.values()])
        removed = rank_buckets.tally([before[racer][0] for racer in best if racer in before])
        moves: dict[str, dict[str, int]] = {}
        for sign, counts in ((1, added), (-1, removed)):
            for node, children in counts.items():
                moved = moves.setdefault(node, {})
                for child, count in children.items():
                    moved[child] = moved.get(child, 0) + sign * count
        self._move_counts(db, board_id, {node: kept for node, children in moves.items()
                                         if (kept := {c: n for c, n in children.items() if n})})
        db.execute("UPDATE boards SET participants = participants + ?, version = version + 1 "
                   "WHERE board_id = ?", (sum(racer not in before for racer in best), board_id))
        return len(best)

    # ---- event-wide bans ------------------------------------------------------------------

    def event_bans(self) -> tuple[EventBans, int]:
        return self._event_bans(self._db)

    @staticmethod
    def _event_bans(db: sqlite3.Connection) -> tuple[EventBans, int]:
        row = db.execute("SELECT data, version FROM event_settings WHERE name = ?",
                         (EVENT_BANS,)).fetchone()
        return (EventBans.model_validate_json(row[0]), int(row[1])) if row else (EventBans(), 0)

    def save_event_bans(self, bans: EventBans, version: int) -> int:
        with self._write() as db:
            if self._event_bans(db)[1] != version:
                raise BoardChanged("event bans")
            db.execute("INSERT INTO event_settings VALUES (?, ?, ?) ON CONFLICT (name) DO UPDATE "
                       "SET data = excluded.data, version = excluded.version",
                       (EVENT_BANS, bans.model_dump_json(), version + 1))
            return version + 1

    def alias_of(self, principal: str) -> AliasClaim | None:
        return self._alias(self._db, "principal", principal)

    def alias_holder(self, racer_key: str) -> AliasClaim | None:
        return self._alias(self._db, "racer_key", racer_key)

    @staticmethod
    def _alias(db: sqlite3.Connection, column: str, value: str) -> AliasClaim | None:
        assert column in ("racer_key", "principal")
        row = db.execute(f"SELECT claim FROM aliases WHERE {column} = ?", (value,)).fetchone()
        return AliasClaim.model_validate_json(row[0]) if row else None


    # ---- webhooks and announcements -------------------------------------------------------

    def put_webhook(self, webhook: Webhook) -> None:
        with self._write() as db:
            db.execute("INSERT OR REPLACE INTO webhooks VALUES (?, ?, ?)",
                       (webhook.target.key, webhook.webhook_id, webhook.model_dump_json()))

    def webhooks(self, target_key: str) -> list[Webhook]:
        rows = self._db.execute("SELECT webhook FROM webhooks WHERE target = ?", (target_key,))
        return sorted((stored_webhook(row[0]) for row in rows),
                      key=lambda w: (w.created_at, w.webhook_id))

    def all_webhooks(self) -> list[Webhook]:
        rows = self._db.execute("SELECT webhook FROM webhooks ORDER BY target, webhook_id")
        return [stored_webhook(row[0]) for row in rows]

    def delete_webhook(self, target_key: str, webhook_id: str) -> Webhook | None:
        with self._write() as db:
            row = db.execute("SELECT webhook FROM webhooks WHERE target = ? AND webhook_id = ?",
                             (target_key, webhook_id)).fetchone()
            db.execute("DELETE FROM webhooks WHERE target = ? AND webhook_id = ?",
                       (target_key, webhook_id))
        return stored_webhook(row[0]) if row else None

    def note_delivery(self, target_key: str, webhook_id: str, at: datetime,
                      error: str | None) -> None:
        with self._write() as db:
            row = db.execute("SELECT webhook FROM webhooks WHERE target = ? AND webhook_id = ?",
                             (target_key, webhook_id)).fetchone()
            if row is None:
                return
            webhook = delivered(stored_webhook(row[0]), at, error)
            db.execute("UPDATE webhooks SET webhook = ? WHERE target = ? AND webhook_id = ?",
                       (webhook.model_dump_json(), target_key, webhook_id))

    def claim_notice(self, notice_id: str, webhook_id: str, now: datetime, lease_s: int) -> bool:
        with self._write() as db:
            row = db.execute("SELECT state, lease_until FROM notices WHERE notice_id = ? AND "
                             "webhook_id = ?", (notice_id, webhook_id)).fetchone()
            if row is not None and not claimable(row[0], row[1], now):
                return False
            db.execute("INSERT OR REPLACE INTO notices VALUES (?, ?, 'sending', ?)",
                       (notice_id, webhook_id, ranking.timestamp(now + timedelta(seconds=lease_s))))
            return True

    def finish_notice(self, notice_id: str, webhook_id: str, sent: bool) -> None:
        with self._write() as db:
            db.execute("UPDATE notices SET state = ? WHERE notice_id = ? AND webhook_id = ?",
                       ("sent" if sent else "failed", notice_id, webhook_id))


@contextmanager
def _busy_as_store_busy(path: str, attempt: FirstTry | None = None) -> Iterator[None]:
    try:
        yield
    except sqlite3.OperationalError as error:
        if error.sqlite_errorcode & 0xFF not in (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED):
            raise
        if attempt is not None:
            attempt.met_writer = True
        raise StoreBusy(f"the board {path} is busy with another writer (waited "
                        f"{BUSY_TIMEOUT_S:g} s); nothing was stored, try again",
                        BUSY_RETRY_AFTER_S) from error


def _holder(db: sqlite3.Connection, table: str, column: str, board_id: str, key: str) -> str:
    """The racer who holds ``key`` on the board, in ``table`` (fingerprints or skeletons)."""
    row = db.execute(f"SELECT racer_key FROM {table} WHERE board_id = ? AND {column} = ?",
                     (board_id, key)).fetchone()
    return str(row[0])


def _check_limits(tally: RacerTally, limits: SubmissionLimits) -> None:
    if limits.max_submissions is not None and tally.submissions >= limits.max_submissions:
        raise LimitReached(tally)
    last = tally.last_submitted_at
    if limits.cooldown_s and last is not None and (limits.now - last).total_seconds() < limits.cooldown_s:
        raise LimitReached(tally)


def _in_chunks(db: sqlite3.Connection, query: str, fixed: tuple[str, ...],
               values: Sequence[str]) -> Iterator[Any]:
    """The rows of ``query`` (whose ``IN ({})`` takes the values), for every value, a chunk
    of values at a time."""
    for start in range(0, len(values), IN_CHUNK):
        chunk = values[start:start + IN_CHUNK]
        yield from db.execute(query.format(",".join("?" * len(chunk))), (*fixed, *chunk))


def _first(columns: int) -> Callable[[tuple[Any, ...]], tuple[Any, ...]]:
    """A row's first ``columns`` values: its key, for sorting rows by it."""
    return lambda row: row[:columns]


BOARD_COLUMNS = "board, participants, version, settings_version"


def _board(row: tuple[str, int, int, int]) -> StoredBoard:
    return StoredBoard(Board.model_validate_json(row[0]), int(row[1]), int(row[2]), int(row[3]))
