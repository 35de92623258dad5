"""A racer's pages: their entry, best record and history on a board, where they stand on every
board, and their designs compared with other racers' and with what the fastest models share."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime, timedelta

from drboard_assembler.record import EvaluationRun, Record

from .. import ranking
from ..cursors import decode_page_cursor, page_cursor
from ..errors import DesignsPrivate, InvalidQuery, RacerNotFound
from ..insights import design_facts, differences, shared_facts
from ..models.domain import Board, Entry, Submission
from ..models.racer_views import (
    ComparedRacer,
    Comparison,
    Insights,
    RacerHistory,
    RacerStatus,
    RacerSummary,
    RacerView,
    SpeedPoint,
)
from ..models.views import HistoryItem
from ..stores.base import StoredBoard
from ..views import board_view, entry_view, history_item
from .boards import BoardKeeper, racer_key
from .paging import DEFAULT_PAGE, DEFAULT_TOP, MAX_COMPARED, MAX_TOP, bad_cursor, check_limit, follow
from .reading import Reading

#: Insights read this many of a board's entries (and their records) as the field.
INSIGHTS_FIELD = 100


def scored_run(record: Record, entry: Entry, board: Board) -> EvaluationRun:
    """The evaluation run of the record that the entry's score comes from (the one the board's
    timing method scored, not merely the fastest lap's)."""
    named = [run for run in record.evaluations if run.source == entry.score.run]
    if len(named) == 1:
        return named[0]
    return min(named or record.evaluations,
               key=lambda run: ranking.score_key(ranking.score_run(run, board.rules)))


class Racers:
    def __init__(self, keeper: BoardKeeper, reading: Reading) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.clock = keeper.clock
        self.reading = reading

    def racer(self, board_id: str, racer: str, limit: int | None = None,
              cursor: str | None = None) -> RacerView:
        """The racer's entry, rank and best record, and their history on the board: ``limit``
        submissions from ``cursor`` (every one when ``limit`` is None, for in-process callers)."""
        stored = self.keeper.require(board_id)
        key = racer_key(racer)
        entry, record = self._entry_and_record(board_id, racer)
        rank = self.store.count_better(board_id, entry.score_key) + 1
        shown = stored.board.designs_shown(self.clock())
        if limit is None:
            submissions, after = self.store.history(key, board_id), None
        else:
            check_limit(limit)
            with bad_cursor():
                page = self.store.history_page(key, board_id,
                                               decode_page_cursor("history", cursor), limit)
            submissions, after = page.submissions, page.after
        # The stored record goes in as it was stored: today's checks do not run on it again.
        return RacerView.model_validate({
            "board": self.keeper.view(stored),
            "racer": entry.racer,
            "entry": entry_view(entry, rank, self.keeper.leader(board_id), design=shown),
            "history": [history_item(s, entry) for s in submissions],
            "record": record if shown else None,
            "next_cursor": page_cursor("history", after),
            "scored_run": scored_run(record, entry, stored.board) if shown else None,
        }, context={"stored": True})

    def compare(self, board_id: str, racers: Sequence[str]) -> Comparison:
        """The racers' designs side by side, and the facts they differ on."""
        if not 2 <= len(racers) <= MAX_COMPARED:
            raise InvalidQuery(f"compare 2 to {MAX_COMPARED} racers")
        stored = self.keeper.require(board_id)
        self._require_designs(stored.board)
        leader = self.keeper.leader(board_id)
        compared = []
        for racer in racers:
            entry, record = self._entry_and_record(board_id, racer)
            rank = self.store.count_better(board_id, entry.score_key) + 1
            compared.append(ComparedRacer(racer=entry.racer, entry=entry_view(entry, rank, leader),
                                          facts=design_facts(record)))
        return Comparison(board=self.keeper.view(stored), racers=compared,
                          differences=differences([c.facts for c in compared]))

    def insights(self, board_id: str, top: int = DEFAULT_TOP) -> Insights:
        """What the ``top`` qualified models share against the field (the board's first
        INSIGHTS_FIELD entries), and every entry's top speed against its time."""
        if not 1 <= top <= MAX_TOP:
            raise InvalidQuery(f"top must be between 1 and {MAX_TOP}")
        self._require_designs(self.keeper.require(board_id).board)
        page = self.reading.board_page(board_id, limit=INSIGHTS_FIELD)
        facts = {}
        for view in page.entries:
            _, record = self._entry_and_record(board_id, view.racer)
            facts[view.racer] = design_facts(record)
        # a design the run's files do not describe says nothing of what fast models share
        known = {racer: f for racer, f in facts.items()
                 if f.algorithm is not None or f.action_space is not None}
        leaders = [view.racer for view in page.entries if view.qualified and view.racer in known][:top]
        return Insights(
            board=page.board, top=len(leaders), field=len(known),
            facts=shared_facts([facts[r] for r in leaders], list(known.values())),
            points=[SpeedPoint(racer=view.racer, max_speed=speed, time_ms=view.time_ms,
                               top=view.racer in leaders)
                    for view in page.entries if (speed := facts[view.racer].max_speed) is not None],
        )

    def _require_designs(self, board: Board) -> None:
        if not board.designs_shown(self.clock()):
            raise DesignsPrivate(f"the designs on {board.board_id!r} are private until it closes"
                                 + (f" ({board.closes_at.isoformat()})" if board.closes_at else ""))

    def _entry_and_record(self, board_id: str, racer: str) -> tuple[Entry, Record]:
        entry = self.reading.entry(board_id, racer)
        record = self.store.get_record(board_id, entry.submission_id)
        if record is None:  # pragma: no cover - an entry always has its submission
            raise RacerNotFound(f"the record of {racer!r} on {board_id!r} is missing")
        return entry, record

    # ---- a racer's submissions ------------------------------------------------------------

    def history(self, racer: str, board_id: str | None = None) -> list[HistoryItem]:
        """The racer's submissions, oldest first, on one board or on every board (page after
        page)."""
        pages = follow(lambda limit, cursor: self.history_page(racer, board_id, limit, cursor))
        return [item for page in pages for item in page.history]

    def history_page(self, racer: str, board_id: str | None = None, limit: int = DEFAULT_PAGE,
                     cursor: str | None = None) -> RacerHistory:
        """``limit`` of the racer's submissions, oldest first, on one board or on every live
        board; ``next_cursor`` is None on the last page."""
        check_limit(limit)
        key = racer_key(racer)
        if board_id is not None:
            self.keeper.require(board_id)
        with bad_cursor():
            page = self.store.history_page(key, board_id, decode_page_cursor("history", cursor),
                                           limit)
        items: list[HistoryItem] = []
        for stored, submissions in self._by_board(page.submissions):
            best = self.store.get_entry(stored.board.board_id, key)
            items.extend(history_item(submission, best) for submission in submissions)
        items.sort(key=lambda item: (item.submitted_at, item.board_id, item.submission_id))
        return RacerHistory(racer=racer, history=items, next_cursor=page_cursor("history", page.after))

    def status(self, racer: str, board_id: str | None = None) -> RacerSummary:
        """Where the racer stands on each board they pushed to (or on one): their latest
        submission, their best's rank and gap, and when they may submit next."""
        key = racer_key(racer)
        if board_id is not None:
            self.keeper.require(board_id)
        now = self.clock()
        statuses = []
        for stored, submissions in self._by_board(self.store.history(key, board_id)):
            entry = self.store.get_entry(stored.board.board_id, key)
            if entry is None:  # pragma: no cover - a submission always has its entry
                continue
            statuses.append(self._racer_status(stored, entry, submissions[-1], now))
        if not statuses:
            where = f" on {board_id!r}" if board_id else ""
            raise RacerNotFound(f"{racer!r} has no submissions{where}")
        statuses.sort(key=lambda status: status.latest.submitted_at, reverse=True)
        return RacerSummary(racer=statuses[0].racer, boards=statuses)

    def _racer_status(self, stored: StoredBoard, entry: Entry, latest: Submission,
                      now: datetime) -> RacerStatus:
        board = stored.board
        rank = self.store.count_better(board.board_id, entry.score_key) + 1
        tally = self.store.tally(board.board_id, entry.racer_key)
        next_at = None
        if board.cooldown_s and tally.last_submitted_at is not None:
            ready = tally.last_submitted_at + timedelta(seconds=board.cooldown_s)
            next_at = ready if ready > now else None
        left = None
        if board.max_submissions is not None:
            left = max(0, board.max_submissions - tally.submissions)
        return RacerStatus(
            board=board_view(stored, now),
            racer=latest.racer,
            latest=history_item(latest, entry),
            entry=entry_view(entry, rank, self.keeper.leader(board.board_id),
                              design=board.designs_shown(now)),
            submissions=tally.submissions,
            submissions_left=left,
            next_submission_at=next_at,
        )

    def _by_board(self, submissions: list[Submission]) -> list[tuple[StoredBoard, list[Submission]]]:
        """The submissions of live boards (not deleted), with their board, oldest first."""
        grouped: dict[str, list[Submission]] = {}
        boards: dict[str, StoredBoard | None] = {}
        for submission in submissions:
            board_id = submission.board_id
            if board_id not in boards:
                stored = self.store.get_board(board_id)
                boards[board_id] = stored if stored and stored.board.deleted_at is None else None
            if boards[board_id] is not None:
                grouped.setdefault(board_id, []).append(submission)
        return [(stored, sorted(grouped[board_id], key=lambda s: s.submitted_at))
                for board_id, stored in boards.items() if stored is not None]
