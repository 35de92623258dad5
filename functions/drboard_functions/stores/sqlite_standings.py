"""The standings kept beside the embedded board: a board's top page as the JSON of its view,
labelled with the board version it was read at, for the CLI's next `drboard pull` of it.

A pull on the embedded board is a process of its own: the copies :mod:`..routes.standings` keeps
in a process do not outlive it. So a pull that reads a page through the service keeps the page's
JSON here, and a later pull that finds it for the board as the board is now prints it without
loading the service, its models or their validation. A copy holds while the board's row is the
one it was read from: the same version (which every push, organiser's change and moderation
moves, in the same write) and the same stored board (a board deleted and created again under the
same id starts its versions over), and until the board next opens or closes (its status, and
whether designs show, change then). A copy that does not hold is never read; the next pull
through the service replaces it.

Keeping a copy is an optimisation only: a board file that cannot be written to (read-only, or
held by a long write) goes without, and the pull through the service answers as before. This
module imports no model: its callers hand it and take back JSON text.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

#: How long keeping a copy waits for another process's write before going without it.
KEEP_TIMEOUT_S = 0.2

_TABLE = """CREATE TABLE IF NOT EXISTS kept_standings (
    board_id    TEXT NOT NULL,
    top         INTEGER NOT NULL,
    version     INTEGER NOT NULL,
    board       TEXT NOT NULL,
    fresh_until REAL,
    page        TEXT NOT NULL,
    PRIMARY KEY (board_id, top)
)"""

_KEEP = """INSERT OR REPLACE INTO kept_standings (board_id, top, version, board, fresh_until, page)
SELECT board_id, ?, version, board, ?, ? FROM boards WHERE board_id = ? AND version = ?"""

_KEPT = """SELECT kept.page FROM kept_standings AS kept JOIN boards USING (board_id)
WHERE kept.board_id = ? AND kept.top = ? AND kept.version = boards.version
  AND kept.board = boards.board AND (kept.fresh_until IS NULL OR kept.fresh_until > ?)"""


def kept_page(db: Path, board_id: str, top: int, now: float) -> str | None:
    """The JSON of the board's top ``top`` entries as kept for the board as it is now (``now``
    in seconds since the epoch); None when no such copy is kept, or the file cannot be read
    (absent, from before copies, busy): the caller then reads the page through the service."""
    try:
        connection = sqlite3.connect(f"{db.resolve().as_uri()}?mode=ro", uri=True)
    except (sqlite3.Error, OSError):
        return None
    try:
        row = connection.execute(_KEPT, (board_id, top, now)).fetchone()
    except sqlite3.Error:
        return None
    finally:
        connection.close()
    return str(row[0]) if row else None


def keep_page(db: Path, board_id: str, top: int, version: int, fresh_until: float | None,
              page: str) -> bool:
    """Keep ``page``, the JSON of the board's top ``top`` entries read at board ``version``,
    unless the board has moved on since; whether it was kept."""
    try:
        connection = sqlite3.connect(db, timeout=KEEP_TIMEOUT_S, isolation_level=None)
    except (sqlite3.Error, OSError):
        return False
    try:
        connection.execute(_TABLE)
        kept = connection.execute(_KEEP, (top, fresh_until, page, board_id, version)).rowcount
    except sqlite3.Error:
        return False
    finally:
        connection.close()
    return kept == 1
