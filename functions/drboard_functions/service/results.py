"""Results to analyse: a board's laps, page by page, and one run's laps (see :mod:`..laps`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..cursors import decode_page_cursor, page_cursor
from ..errors import DesignsPrivate, InvalidQuery, RacerNotFound
from ..laps import lap_rows, run_metrics
from ..models.domain import Board
from .boards import BoardKeeper, racer_key
from .paging import bad_cursor

#: Submissions per page of a board's laps: a page of a few thousand laps stays well under the
#: size a Lambda function may answer.
LAPS_PAGE = 200


@dataclass(frozen=True)
class LapsPage:
    board_id: str
    rows: list[dict[str, Any]]  # laps.LAP_COLUMNS
    next_cursor: str | None


class Results:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store

    def laps_page(self, board_id: str, cursor: str | None = None, limit: int | None = None) -> LapsPage:
        """Every lap of ``limit`` of the board's submissions (LAPS_PAGE by default), from
        ``cursor``; ``next_cursor`` is None on the last page. The laps show with the designs
        (a board that keeps its designs private until it closes keeps its laps too)."""
        stored = self.keeper.require(board_id)
        self._require_laps(stored.board)
        limit = LAPS_PAGE if limit is None else limit
        if not 1 <= limit <= LAPS_PAGE:
            raise InvalidQuery(f"limit must be between 1 and {LAPS_PAGE}")
        with bad_cursor():
            page = self.store.submissions(board_id, decode_page_cursor("laps", cursor), limit)
        counted: dict[str, str | None] = {}
        rows: list[dict[str, Any]] = []
        for submission, record in page.submissions:
            key = submission.racer_key
            if key not in counted:
                entry = self.store.get_entry(board_id, key)
                counted[key] = entry.submission_id if entry else None
            rows.extend(lap_rows(submission, record, counted[key] == submission.submission_id))
        return LapsPage(board_id, rows, page_cursor("laps", page.after))

    def run_laps(self, board_id: str, racer: str, submission_id: str | None = None,
                 run: int | None = None) -> dict[str, Any]:
        """One evaluation run's laps as a metrics file deepracer-utils reads: the racer's counted
        run by default, or run ``run`` (1..) of their submission ``submission_id``."""
        stored = self.keeper.require(board_id)
        self._require_laps(stored.board)
        key = racer_key(racer)
        entry = self.store.get_entry(board_id, key)
        if submission_id is None:
            if entry is None:
                raise RacerNotFound(f"{racer!r} has no entry on {board_id!r}")
            submission_id = entry.submission_id
        submission = self.store.get_submission(board_id, key, submission_id)
        record = self.store.get_record(board_id, submission_id) if submission else None
        if submission is None or record is None:
            raise RacerNotFound(f"{racer!r} has no submission {submission_id!r} on {board_id!r}")
        if run is None:
            runs = [r for r in record.evaluations if r.source == submission.score.run]
            return run_metrics(runs[0] if runs else record.evaluations[0])
        if not 1 <= run <= len(record.evaluations):
            raise InvalidQuery(f"the submission has {len(record.evaluations)} evaluation runs: "
                               f"run is 1 to {len(record.evaluations)}")
        return run_metrics(record.evaluations[run - 1])

    def _require_laps(self, board: Board) -> None:
        if not board.designs_shown(self.keeper.clock()):
            raise DesignsPrivate(f"the laps on {board.board_id!r} show once it closes, with its "
                                 "designs")
