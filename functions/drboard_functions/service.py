"""The leaderboard's rules: which board a record belongs on, how it scores, ranks and gaps.

The service never touches a database: it speaks to a BoardStore. It takes validated Records and
returns the view models the API serialises and the CLI prints.
"""

from __future__ import annotations

import base64
import binascii
import json
from collections.abc import Callable
from datetime import UTC, datetime

from drboard_assembler.catalog import UnknownTrackError, default_catalog
from drboard_assembler.record import RaceType, Record

from . import ranking
from .errors import BoardMismatch, BoardNotFound, InvalidQuery, RacerNotFound
from .models import (
    MAX_PAGE,
    Board,
    BoardPage,
    BoardRules,
    BoardView,
    Design,
    Entry,
    EntryView,
    HistoryItem,
    PushReceipt,
    RacerView,
    Submission,
)
from .stores.base import BoardStore, RecordArchive, StoredBoard

Clock = Callable[[], datetime]
MAX_CURSOR_CHARS = 1024

_RACE_SUFFIX = {
    RaceType.TIME_TRIAL: "",
    RaceType.OBJECT_AVOIDANCE: "_oa",
    RaceType.HEAD_TO_BOT: "_h2b",
    RaceType.HEAD_TO_MODEL: "_h2m",
    RaceType.HEAD_TO_HEAD_RACING: "_h2h",
    RaceType.F1: "_f1",
}
_RACE_TITLE = {
    RaceType.TIME_TRIAL: "",
    RaceType.OBJECT_AVOIDANCE: ", object avoidance",
    RaceType.HEAD_TO_BOT: ", head to bot",
    RaceType.HEAD_TO_MODEL: ", head to model",
    RaceType.HEAD_TO_HEAD_RACING: ", head to head",
    RaceType.F1: ", F1",
}


def utc_now() -> datetime:
    return datetime.now(UTC)


def racer_key(racer: str) -> str:
    """Racer aliases are matched without regard to case or surrounding space."""
    return " ".join(racer.split()).casefold()


def default_board_id(track: str, direction: str | None, race_type: RaceType) -> str:
    """A track's default board: counter-clockwise and unspecified runs share the track's board;
    clockwise runs, and race types other than time trial, rank on boards of their own."""
    return track + ("_cw" if direction == "cw" else "") + _RACE_SUFFIX[race_type]


def board_for_track(name: str, race_type: RaceType = RaceType.TIME_TRIAL,
                    clockwise: bool = False) -> str:
    """The default board of a track given by any of its names (``reInvent2019``, ``Smile
    Speedway``, ``reInvent2019_track_cw``). An unknown name is taken as a custom track's id."""
    try:
        resolved = default_catalog().resolve(name)
    except UnknownTrackError as error:
        if error.ambiguous or error.candidates:
            raise InvalidQuery(str(error)) from None
        return default_board_id(name.strip(), "cw" if clockwise else None, race_type)
    direction = "cw" if clockwise else resolved.direction
    return default_board_id(resolved.track_id, direction, race_type)


def _default_board(record: Record, now: datetime) -> Board:
    track = default_catalog().get(record.track)
    name = track.display_name if track else record.track
    clockwise = record.direction == "cw"
    return Board(
        board_id=default_board_id(record.track, record.direction, record.race_type),
        track=record.track,
        direction="cw" if clockwise else None,
        race_type=record.race_type,
        title=name + (" (clockwise)" if clockwise else "") + _RACE_TITLE[record.race_type],
        rules=BoardRules(),
        created_at=now,
    )


class LeaderboardService:
    def __init__(self, store: BoardStore, clock: Clock = utc_now,
                 archive: RecordArchive | None = None) -> None:
        self.store = store
        self.clock = clock
        self.archive = archive

    # ---- push -----------------------------------------------------------------------------

    def push(self, record: Record, board_id: str | None = None) -> PushReceipt:
        now = self.clock()
        stored = self._board_for(record, board_id, now)
        board = stored.board
        score = ranking.score_record(record, board.rules)
        key = racer_key(record.racer)
        score_key = ranking.score_key(score)
        submission = Submission(
            board_id=board.board_id, racer=record.racer, racer_key=key,
            submission_id=record.submission_id, model_name=record.model_name,
            submitted_at=now, score=score, score_key=score_key,
        )
        entry = Entry(
            board_id=board.board_id, racer=record.racer, racer_key=key,
            model_name=record.model_name, submission_id=record.submission_id,
            achieved_at=now, score=score, design=_design(record), score_key=score_key,
            rank_key=ranking.rank_key(score_key, now, key),
        )
        outcome = self.store.record_submission(submission, record, entry)
        best = outcome.entry
        if outcome.duplicate:
            submission = self._stored_submission(submission)
        elif self.archive is not None:
            self.archive.put(board.board_id, record)
        rank = self.store.count_better(board.board_id, best.score_key) + 1
        participants = self._require_board(board.board_id).participants
        return PushReceipt(
            status="duplicate" if outcome.duplicate else "created",
            board_id=board.board_id,
            submission_id=record.submission_id,
            improved=outcome.improved,
            rank=rank,
            participants=participants,
            entry=_entry_view(best, rank, self._leader(board.board_id)),
            submission=_history_item(submission, best),
        )

    def _stored_submission(self, pushed: Submission) -> Submission:
        """A duplicate's receipt shows the submission as first stored, not the repeat."""
        for stored in self.store.history(pushed.racer_key, pushed.board_id):
            if stored.submission_id == pushed.submission_id:
                return stored
        return pushed  # pragma: no cover - a duplicate is always in the racer's history

    def _board_for(self, record: Record, board_id: str | None, now: datetime) -> StoredBoard:
        default = _default_board(record, now)
        board_id = board_id or default.board_id
        stored = self.store.get_board(board_id)
        if stored is None:
            if board_id != default.board_id:
                raise BoardNotFound(
                    f"no board {board_id!r}; this run belongs on {default.board_id!r}")
            stored = self.store.create_board(default)
        _check_belongs(record, stored.board)
        return stored

    # ---- pull -----------------------------------------------------------------------------

    def boards(self) -> list[BoardView]:
        return [_board_view(stored) for stored in self.store.list_boards()]

    def board_page(self, board_id: str, limit: int = 100, cursor: str | None = None) -> BoardPage:
        if not 1 <= limit <= MAX_PAGE:
            raise InvalidQuery(f"limit must be between 1 and {MAX_PAGE}")
        stored = self._require_board(board_id)
        after = _Cursor.decode(cursor) if cursor else None
        entries = self.store.top(board_id, limit, after.rank_key if after else None)
        leader = self._leader(board_id) if after else (entries[0] if entries else None)
        views: list[EntryView] = []
        previous = after
        for offset, entry in enumerate(entries):
            position = (after.position if after else 0) + offset + 1
            rank = previous.rank if previous and previous.score_key == entry.score_key else position
            views.append(_entry_view(entry, rank, leader))
            previous = _Cursor(entry.rank_key, entry.score_key, rank, position)
        more = len(entries) == limit and previous is not None
        return BoardPage(
            board=_board_view(stored),
            entries=views,
            next_cursor=previous.encode() if more and previous else None,
        )

    def racer(self, board_id: str, racer: str) -> RacerView:
        stored = self._require_board(board_id)
        key = racer_key(racer)
        entry = self.store.get_entry(board_id, key)
        if entry is None:
            raise RacerNotFound(f"{racer!r} has no entry on {board_id!r}")
        record = self.store.get_record(board_id, entry.submission_id)
        if record is None:  # pragma: no cover - an entry always has its submission
            raise RacerNotFound(f"the record of {racer!r} on {board_id!r} is missing")
        rank = self.store.count_better(board_id, entry.score_key) + 1
        return RacerView(
            board=_board_view(stored),
            racer=entry.racer,
            entry=_entry_view(entry, rank, self._leader(board_id)),
            history=[_history_item(s, entry) for s in self.store.history(key, board_id)],
            record=record,
        )

    def history(self, racer: str, board_id: str | None = None) -> list[HistoryItem]:
        key = racer_key(racer)
        items = []
        bests: dict[str, Entry | None] = {}
        for submission in self.store.history(key, board_id):
            if submission.board_id not in bests:
                bests[submission.board_id] = self.store.get_entry(submission.board_id, key)
            items.append(_history_item(submission, bests[submission.board_id]))
        return items

    def _require_board(self, board_id: str) -> StoredBoard:
        stored = self.store.get_board(board_id)
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r} (no run has been pushed to it yet)")
        return stored

    def _leader(self, board_id: str) -> Entry | None:
        top = self.store.top(board_id, 1)
        return top[0] if top else None


def _check_belongs(record: Record, board: Board) -> None:
    problems = []
    if record.track != board.track:
        problems.append(f"the run is on {record.track}, the board on {board.track}")
    if (record.direction == "cw") != (board.direction == "cw"):
        problems.append("the run and the board differ in direction")
    if record.race_type != board.race_type:
        problems.append(f"the run is {record.race_type.value}, the board {board.race_type.value}")
    if problems:
        raise BoardMismatch(f"this run does not belong on {board.board_id!r}: "
                            + "; ".join(problems))


def _design(record: Record) -> Design:
    space = record.design.action_space
    return Design(
        algorithm=record.design.algorithm,
        action_space=space.type,
        actions=len(space.actions) if space.actions else None,
        max_speed=space.max_speed,
        max_steering=space.max_steering,
        sensors=list(record.design.sensors),
    )


def _board_view(stored: StoredBoard) -> BoardView:
    board = stored.board
    track = default_catalog().get(board.track)
    return BoardView(
        board_id=board.board_id,
        track=board.track,
        track_name=track.display_name if track else board.track,
        direction=board.direction,
        race_type=board.race_type,
        method=board.rules.method,
        min_laps=board.rules.min_laps,
        title=board.title,
        participants=stored.participants,
    )


def _entry_view(entry: Entry, rank: int, leader: Entry | None) -> EntryView:
    gap = None
    if entry.score.time_ms is not None and leader and leader.score.time_ms is not None:
        gap = entry.score.time_ms - leader.score.time_ms
    return EntryView(
        rank=rank,
        racer=entry.racer,
        model_name=entry.model_name,
        qualified=entry.score.qualified,
        time_ms=entry.score.time_ms,
        gap_ms=gap,
        best_lap_ms=entry.score.best_lap_ms,
        laps_completed=entry.score.laps_completed,
        best_completion_pct=entry.score.best_completion_pct,
        submitted_at=entry.achieved_at,
        submission_id=entry.submission_id,
        design=entry.design,
    )


def _history_item(submission: Submission, best: Entry | None) -> HistoryItem:
    return HistoryItem(
        board_id=submission.board_id,
        submission_id=submission.submission_id,
        submitted_at=submission.submitted_at,
        model_name=submission.model_name,
        qualified=submission.score.qualified,
        time_ms=submission.score.time_ms,
        best_lap_ms=submission.score.best_lap_ms,
        laps_completed=submission.score.laps_completed,
        best_completion_pct=submission.score.best_completion_pct,
        is_best=best is not None and best.submission_id == submission.submission_id,
    )


class _Cursor:
    """Where a page ended: enough to continue the order and the shared ranks."""

    def __init__(self, rank_key: str, score_key: str, rank: int, position: int) -> None:
        self.rank_key = rank_key
        self.score_key = score_key
        self.rank = rank
        self.position = position

    def encode(self) -> str:
        raw = json.dumps([self.rank_key, self.score_key, self.rank, self.position])
        return base64.urlsafe_b64encode(raw.encode()).decode().rstrip("=")

    @classmethod
    def decode(cls, text: str) -> _Cursor:
        if len(text) > MAX_CURSOR_CHARS:
            raise InvalidQuery("the cursor is not one this board gave out")
        try:
            raw = base64.urlsafe_b64decode(text + "=" * (-len(text) % 4))
            rank_key, score_key, rank, position = json.loads(raw)
            if not (isinstance(rank_key, str) and isinstance(score_key, str)
                    and isinstance(rank, int) and isinstance(position, int)):
                raise ValueError
        except (ValueError, TypeError, RecursionError, binascii.Error, UnicodeDecodeError):
            raise InvalidQuery("the cursor is not one this board gave out") from None
        return cls(rank_key, score_key, rank, position)
