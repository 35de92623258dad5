"""The embedded board's seasons: three tables beside the boards' (see ``SqliteStore``).

``seasons`` holds each season (its JSON and version), ``season_links`` which boards link to
which seasons (a round's or a final's board page names its seasons; a push to a final checks
its link), and ``round_results`` the results a season keeps of each round, as of a version of
the round's board (see ``service/seasons.py``).
"""

from __future__ import annotations

import sqlite3
from collections.abc import Mapping, Sequence
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING

from .base import SeasonConflict, SeasonSlice, StoredBoard, page_token, read_page_token

if TYPE_CHECKING:  # the models are imported where a row is read: a push to a board in no season
    # reads none, and leaves the seasons' models out
    from ..models.seasons import RoundResults, Season, SeasonLink

SEASON_SCHEMA = """
CREATE TABLE IF NOT EXISTS seasons (
    season_id TEXT PRIMARY KEY,
    version   INTEGER NOT NULL,
    season    TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS season_links (
    board_id  TEXT NOT NULL,
    season_id TEXT NOT NULL,
    link      TEXT NOT NULL,
    PRIMARY KEY (board_id, season_id)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS round_results (
    season_id     TEXT NOT NULL,
    board_id      TEXT NOT NULL,
    board_version INTEGER NOT NULL,
    results       TEXT NOT NULL,
    PRIMARY KEY (season_id, board_id)
) WITHOUT ROWID;
"""


class SqliteSeasons:
    """The season methods of ``SqliteStore``, which gives them its connection and its write
    transaction."""

    if TYPE_CHECKING:  # what SqliteStore gives
        @property
        def _db(self) -> sqlite3.Connection: ...

        def _write(self) -> AbstractContextManager[sqlite3.Connection]: ...

        def get_board(self, board_id: str) -> StoredBoard | None: ...

    def get_season(self, season_id: str) -> Season | None:
        from ..models.seasons import Season

        row = self._db.execute("SELECT season FROM seasons WHERE season_id = ?", (season_id,)).fetchone()
        return Season.model_validate_json(row[0]) if row else None

    def save_season(self, season: Season, links: Mapping[str, SeasonLink | None],
                    forget: Sequence[str] = ()) -> Season:
        with self._write() as db:
            row = db.execute("SELECT version FROM seasons WHERE season_id = ?",
                             (season.season_id,)).fetchone()
            stored = int(row[0]) if row else 0
            if stored != season.version - 1:
                raise SeasonConflict(season.season_id)
            db.execute("INSERT OR REPLACE INTO seasons VALUES (?, ?, ?)",
                       (season.season_id, season.version, season.model_dump_json()))
            for board_id, link in links.items():
                if link is None:
                    db.execute("DELETE FROM season_links WHERE board_id = ? AND season_id = ?",
                               (board_id, season.season_id))
                else:
                    db.execute("INSERT OR REPLACE INTO season_links VALUES (?, ?, ?)",
                               (board_id, season.season_id, link.model_dump_json()))
                db.execute("UPDATE boards SET version = version + 1 WHERE board_id = ?", (board_id,))
            db.executemany("DELETE FROM round_results WHERE season_id = ? AND board_id = ?",
                           [(season.season_id, board_id) for board_id in forget])
        return season

    def seasons_page(self, after: str | None, limit: int) -> SeasonSlice:
        from ..models.seasons import Season

        rows = self._db.execute(
            "SELECT season_id, season FROM seasons WHERE season_id > ? ORDER BY season_id LIMIT ?",
            (read_page_token(after, 1)[0] if after else "", limit + 1)).fetchall()
        page = rows[:limit]
        return SeasonSlice([Season.model_validate_json(row[1]) for row in page],
                           page_token([page[-1][0]]) if len(rows) > limit else None)

    def season_links(self, board_id: str) -> list[SeasonLink]:
        rows = self._db.execute("SELECT link FROM season_links WHERE board_id = ? ORDER BY season_id",
                                (board_id,)).fetchall()
        if not rows:
            return []
        from ..models.seasons import SeasonLink

        return [SeasonLink.model_validate_json(row[0]) for row in rows]

    def boards_by_id(self, board_ids: Sequence[str]) -> dict[str, StoredBoard]:
        found = {board_id: self.get_board(board_id) for board_id in dict.fromkeys(board_ids)}
        return {board_id: stored for board_id, stored in found.items() if stored is not None}

    def round_results(self, season_id: str) -> dict[str, RoundResults]:
        from ..models.seasons import RoundResults

        rows = self._db.execute("SELECT board_id, results FROM round_results WHERE season_id = ?",
                                (season_id,))
        return {row[0]: RoundResults.model_validate_json(row[1]) for row in rows}

    def keep_round_results(self, season_id: str, results: RoundResults) -> None:
        with self._write() as db:
            db.execute(
                "INSERT INTO round_results VALUES (?, ?, ?, ?) ON CONFLICT (season_id, board_id) "
                "DO UPDATE SET board_version = excluded.board_version, results = excluded.results "
                "WHERE excluded.board_version > round_results.board_version",
                (season_id, results.board_id, results.board_version, results.model_dump_json()))

