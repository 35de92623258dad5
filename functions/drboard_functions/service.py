"""The leaderboard's rules: which board a record belongs on, how it scores, ranks and gaps.

The service never touches a database: it speaks to a BoardStore. It takes validated Records and
returns the view models the API serialises and the CLI prints.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import secrets
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime, timedelta
from typing import Any, Literal, TypeVar

from drboard_assembler.aliases import alias_key
from drboard_assembler.catalog import UnknownTrackError, default_catalog
from drboard_assembler.errors import field_path
from drboard_assembler.limits import MAX_RECORD_BYTES
from drboard_assembler.record import Alias, EvaluationRun, RaceType, Record
from pydantic import TypeAdapter, ValidationError

from . import display, ranking
from .cursors import RankCursor, decode_export_cursor, decode_page_cursor, export_cursor, page_cursor
from .errors import (
    AliasTaken,
    Banned,
    BoardClosed,
    BoardExists,
    BoardLocked,
    BoardMismatch,
    BoardNotFound,
    CopiedRun,
    DesignsPrivate,
    DomainError,
    InvalidQuery,
    NotAuthorized,
    NotSignedIn,
    RacerNotFound,
    SubmissionLimitReached,
    SubmissionTooLarge,
    TooSoon,
)
from .identity import LOCAL_ORGANISER, Caller
from .insights import design_facts, differences, shared_facts
from .models.domain import (
    BOARD_ID_PATTERN,
    MAX_PAGE,
    AliasClaim,
    AuditAction,
    AuditEvent,
    Board,
    BoardRules,
    BoardStatus,
    Entry,
    RacerTally,
    Submission,
    SubmissionLimits,
    run_mismatches,
)
from .models.requests import BoardChanges, BoardSpec, ImportedSubmission
from .models.transfer import (
    ExportedBoard,
    ExportedEntry,
    ExportLine,
    ExportPage,
    ImportReceipt,
    StoredSubmissionLine,
)
from .models.views import (
    AuditPage,
    BoardList,
    BoardPage,
    BoardView,
    ComparedRacer,
    Comparison,
    EntryView,
    HistoryItem,
    Insights,
    Me,
    Moderation,
    PushReceipt,
    RacerHistory,
    RacerStatus,
    RacerSummary,
    RacerView,
    SpeedPoint,
)
from .stores.base import (
    AliasConflict,
    BadPageToken,
    BoardHasEntries,
    BoardStore,
    FingerprintTaken,
    LimitReached,
    RecordArchive,
    StoredBoard,
)
from .views import board_view, design_of, entry_view, history_item, page_tag

Clock = Callable[[], datetime]
DEFAULT_PAGE = 100
MAX_COMPARED = 4
DEFAULT_TOP, MAX_TOP = 5, 20
#: Insights read this many of a board's entries (and their records) as the field.
INSIGHTS_FIELD = 100

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
    """Racer aliases are matched after Unicode NFKC and case folding, white space collapsed."""
    return alias_key(racer)


#: A custom track's default boards are ``custom.<track>...``: a push for a track of one's own
#: can take neither an official track's board id nor a named board's (which may not start so).
CUSTOM_PREFIX = "custom."


def default_board_id(track: str, direction: str | None, race_type: RaceType) -> str:
    """A track's default board: counter-clockwise and unspecified runs share the track's board;
    clockwise runs, and race types other than time trial, rank on boards of their own."""
    prefix = "" if default_catalog().is_official(track) else CUSTOM_PREFIX
    return prefix + track + ("_cw" if direction == "cw" else "") + _RACE_SUFFIX[race_type]


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

    def push(self, record: Record, board_id: str | None = None,
             caller: Caller | None = LOCAL_ORGANISER) -> PushReceipt:
        """Store a run on its board. A run already on the board is a duplicate: it changes
        nothing and is answered whatever the board's window and limits (it never counts).
        ``caller`` is who pushes: a racer may push only as the alias their sign-in holds (their
        first push claims it); organisers push as anyone; None (unsigned) is refused."""
        check_record_size(record)
        now = self.clock()
        self._check_pusher(caller, record.racer, now)
        board = self._board_for(record, board_id, now).board
        key = racer_key(record.racer)
        if key in board.banned:
            raise Banned(f"{record.racer!r} is banned from {board.board_id!r} by its organisers")
        stored = self.store.get_submission(board.board_id, key, record.submission_id)
        if stored is not None:
            return self._duplicate_receipt(stored, record.racer)
        _check_open(board, now)
        submission, entry = scored_write(record, board, now)
        limits = SubmissionLimits(now=now, cooldown_s=board.cooldown_s,
                                  max_submissions=board.max_submissions)
        audit = self._event(board.board_id, "push", caller, now, racer=record.racer,
                            submission_id=record.submission_id, detail=record.model_name)
        self._archive(board.board_id, record)
        try:
            outcome = self.store.record_submission(submission, record, entry, limits,
                                                   fingerprints=evaluation_fingerprints(record),
                                                   audit=audit)
        except LimitReached as refused:
            raise _limit_error(board, record.racer, refused.tally, now) from None
        except FingerprintTaken as copy:
            raise CopiedRun(f"this run's evaluation is already on {board.board_id!r} under "
                            f"another racer ({copy.racer_key}): a copied run is refused") from None
        if outcome.duplicate:  # pushed twice at once: the other push stored it first
            stored = self.store.get_submission(board.board_id, key, record.submission_id)
            return self._duplicate_receipt(stored or submission, record.racer)
        return self._receipt(submission, outcome.entry, outcome.duplicate, outcome.improved)

    def _archive(self, board_id: str, record: Record) -> None:
        """Keep the record in the archive before the push commits: a failed archive write
        stores nothing (a store error, 503). Its key is the record's content hash, so a push
        refused or retried afterwards leaves at most an object no row refers to."""
        if self.archive is not None:
            self.archive.put(board_id, record)

    def _duplicate_receipt(self, stored: Submission, racer: str) -> PushReceipt:
        best = self.store.get_entry(stored.board_id, stored.racer_key)
        if best is None:
            raise NotAuthorized(f"{racer!r} was taken off {stored.board_id!r} by its organisers; "
                                "this run stays off it")
        return self._receipt(stored, best, duplicate=True, improved=False)

    def _check_pusher(self, caller: Caller | None, racer: str, now: datetime) -> None:
        if caller is None:
            raise NotSignedIn("sign in to push: `drboard login` for a deployed board, "
                              "`drboard join CODE` for a `drboard serve` board")
        if caller.organiser:
            return
        claim = self.store.alias_of(caller.principal) or self._claim(caller, racer, now)
        if claim.racer_key != racer_key(racer):
            raise AliasTaken(f"you push as {claim.alias!r}: this run is {racer!r}'s "
                             "(give `--racer` your own alias)")

    def _claim(self, caller: Caller, alias: str, now: datetime) -> AliasClaim:
        claim = AliasClaim(racer_key=racer_key(alias), alias=alias, principal=caller.principal,
                           claimed_at=now)
        try:
            return self.store.claim_alias(claim)
        except AliasConflict as conflict:
            if conflict.holder.principal == caller.principal:
                raise AliasTaken(f"you push as {conflict.holder.alias!r}, not {alias!r}: "
                                 "an alias is claimed once") from None
            raise AliasTaken(f"the alias {alias!r} belongs to another racer") from None

    # ---- who is calling -------------------------------------------------------------------

    def me(self, caller: Caller | None = LOCAL_ORGANISER) -> Me:
        if caller is None:
            raise NotSignedIn("not signed in: `drboard login` or `drboard join CODE`")
        claim = self.store.alias_of(caller.principal)
        return Me(principal=caller.principal, name=caller.name, organiser=caller.organiser,
                  alias=claim.alias if claim else None)

    def claim_alias(self, alias: str, caller: Caller | None = LOCAL_ORGANISER) -> Me:
        """Claim the alias the caller will push as (once: an alias is not renamed)."""
        if caller is None:
            raise NotSignedIn("sign in to claim an alias: `drboard login` or `drboard join CODE`")
        try:
            alias = _ALIAS.validate_python(alias)
        except ValidationError as error:
            message = error.errors()[0]["msg"].removeprefix("Value error, ")
            raise InvalidQuery(message, detail=[{"loc": "alias", "msg": message,
                                                 "type": "value_error"}]) from None
        self._claim(caller, alias, self.clock())
        return self.me(caller)

    def _receipt(self, submission: Submission, best: Entry, duplicate: bool,
                 improved: bool) -> PushReceipt:
        rank = self.store.count_better(best.board_id, best.score_key) + 1
        stored, top = self.store.front_page(best.board_id, 1)
        return PushReceipt(
            status="duplicate" if duplicate else "created",
            board_id=best.board_id,
            submission_id=submission.submission_id,
            improved=improved,
            rank=rank,
            participants=stored.participants if stored else 1,
            entry=entry_view(best, rank, top[0] if top else None),
            submission=history_item(submission, best),
        )

    def _board_for(self, record: Record, board_id: str | None, now: datetime) -> StoredBoard:
        default = _default_board(record, now)
        board_id = board_id or default.board_id
        stored = self.store.get_board(board_id)
        if stored is None:
            if board_id != default.board_id:
                raise BoardNotFound(
                    f"no board {board_id!r}; this run belongs on {default.board_id!r}")
            stored = self.store.create_board(default)
        _check_not_deleted(stored.board)
        _check_belongs(record, stored.board)
        return stored

    # ---- pull -----------------------------------------------------------------------------

    def boards(self) -> list[BoardView]:
        """Every live board, by id (page after page)."""
        return [view for page in _follow(self.boards_page) for view in page.boards]

    def boards_page(self, limit: int = DEFAULT_PAGE, cursor: str | None = None) -> BoardList:
        """One page of the live boards, by id: the store reads ``limit`` boards, and deleted
        ones are left out, so a page may be short; ``next_cursor`` is None on the last."""
        _check_limit(limit)
        with _bad_cursor():
            page = self.store.boards_page(decode_page_cursor("boards", cursor), limit)
        now = self.clock()
        return BoardList(boards=[board_view(stored, now) for stored in page.boards
                                 if stored.board.deleted_at is None],
                         next_cursor=page_cursor("boards", page.after))

    def board_page(self, board_id: str, limit: int = 100, cursor: str | None = None) -> BoardPage:
        _check_limit(limit)
        after = RankCursor.decode(cursor) if cursor else None
        if after is None:
            found, entries = self.store.front_page(board_id, limit)
            stored = self._live(board_id, found)
            leader = entries[0] if entries else None
        else:
            stored = self._require_board(board_id)
            entries = self.store.top(board_id, limit, after.rank_key)
            leader = self._leader(board_id)
        views: list[EntryView] = []
        shown = stored.board.designs_shown(self.clock())
        previous = after
        for offset, entry in enumerate(entries):
            position = (after.position if after else 0) + offset + 1
            rank = previous.rank if previous and previous.score_key == entry.score_key else position
            views.append(entry_view(entry, rank, leader, design=shown))
            previous = RankCursor(entry.rank_key, entry.score_key, rank, position)
        more = len(entries) == limit and previous is not None
        return BoardPage(
            board=board_view(stored, self.clock()),
            entries=views,
            next_cursor=previous.encode() if more and previous else None,
        )

    def board_tag(self, board_id: str) -> str:
        """The board's :func:`page_tag`, in one read: unchanged, its pages are too."""
        stored = self._live(board_id, self.store.get_board(board_id))
        return page_tag(board_view(stored, self.clock()))

    def racer(self, board_id: str, racer: str, limit: int | None = None,
              cursor: str | None = None) -> RacerView:
        """The racer's entry, rank and best record, and their history on the board: ``limit``
        submissions from ``cursor`` (every one when ``limit`` is None, for in-process callers)."""
        stored = self._require_board(board_id)
        key = racer_key(racer)
        entry, record = self._entry_and_record(board_id, racer)
        rank = self.store.count_better(board_id, entry.score_key) + 1
        shown = stored.board.designs_shown(self.clock())
        if limit is None:
            submissions, after = self.store.history(key, board_id), None
        else:
            _check_limit(limit)
            with _bad_cursor():
                page = self.store.history_page(key, board_id,
                                               decode_page_cursor("history", cursor), limit)
            submissions, after = page.submissions, page.after
        return RacerView(
            board=board_view(stored, self.clock()),
            racer=entry.racer,
            entry=entry_view(entry, rank, self._leader(board_id), design=shown),
            history=[history_item(s, entry) for s in submissions],
            record=record if shown else None,
            next_cursor=page_cursor("history", after),
        )

    def compare(self, board_id: str, racers: Sequence[str]) -> Comparison:
        """The racers' designs side by side, and the facts they differ on."""
        if not 2 <= len(racers) <= MAX_COMPARED:
            raise InvalidQuery(f"compare 2 to {MAX_COMPARED} racers")
        stored = self._require_board(board_id)
        self._require_designs(stored.board)
        leader = self._leader(board_id)
        compared = []
        for racer in racers:
            entry, record = self._entry_and_record(board_id, racer)
            rank = self.store.count_better(board_id, entry.score_key) + 1
            compared.append(ComparedRacer(racer=entry.racer, entry=entry_view(entry, rank, leader),
                                          facts=design_facts(record)))
        return Comparison(board=board_view(stored, self.clock()), racers=compared,
                          differences=differences([c.facts for c in compared]))

    def insights(self, board_id: str, top: int = DEFAULT_TOP) -> Insights:
        """What the ``top`` qualified models share against the field (the board's first
        INSIGHTS_FIELD entries), and every entry's top speed against its time."""
        if not 1 <= top <= MAX_TOP:
            raise InvalidQuery(f"top must be between 1 and {MAX_TOP}")
        self._require_designs(self._require_board(board_id).board)
        page = self.board_page(board_id, limit=INSIGHTS_FIELD)
        facts = {}
        for view in page.entries:
            _, record = self._entry_and_record(board_id, view.racer)
            facts[view.racer] = design_facts(record)
        leaders = [view.racer for view in page.entries if view.qualified][:top]
        return Insights(
            board=page.board, top=len(leaders), field=len(page.entries),
            facts=shared_facts([facts[r] for r in leaders], list(facts.values())),
            points=[SpeedPoint(racer=view.racer, max_speed=facts[view.racer].max_speed,
                               time_ms=view.time_ms, top=view.racer in leaders)
                    for view in page.entries],
        )

    def _require_designs(self, board: Board) -> None:
        if not board.designs_shown(self.clock()):
            raise DesignsPrivate(f"the designs on {board.board_id!r} are private until it closes"
                                 + (f" ({board.closes_at.isoformat()})" if board.closes_at else ""))

    def _entry_and_record(self, board_id: str, racer: str) -> tuple[Entry, Record]:
        entry = self.store.get_entry(board_id, racer_key(racer))
        if entry is None:
            raise RacerNotFound(f"{racer!r} has no entry on {board_id!r}")
        record = self.store.get_record(board_id, entry.submission_id)
        if record is None:  # pragma: no cover - an entry always has its submission
            raise RacerNotFound(f"the record of {racer!r} on {board_id!r} is missing")
        return entry, record

    def history(self, racer: str, board_id: str | None = None) -> list[HistoryItem]:
        """The racer's submissions, oldest first, on one board or on every board (page after
        page)."""
        pages = _follow(lambda limit, cursor: self.history_page(racer, board_id, limit, cursor))
        return [item for page in pages for item in page.history]

    def history_page(self, racer: str, board_id: str | None = None, limit: int = DEFAULT_PAGE,
                     cursor: str | None = None) -> RacerHistory:
        """``limit`` of the racer's submissions, oldest first, on one board or on every live
        board; ``next_cursor`` is None on the last page."""
        _check_limit(limit)
        key = racer_key(racer)
        if board_id is not None:
            self._require_board(board_id)
        with _bad_cursor():
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
            self._require_board(board_id)
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
            entry=entry_view(entry, rank, self._leader(board.board_id),
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

    def _require_board(self, board_id: str) -> StoredBoard:
        return self._live(board_id, self.store.get_board(board_id))

    @staticmethod
    def _live(board_id: str, stored: StoredBoard | None) -> StoredBoard:
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r} (no run has been pushed to it yet)")
        _check_not_deleted(stored.board)
        return stored

    def _leader(self, board_id: str) -> Entry | None:
        top = self.store.top(board_id, 1)
        return top[0] if top else None

    # ---- managing boards (organisers) -----------------------------------------------------

    def create_board(self, spec: BoardSpec, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        now = self.clock()
        track, direction = _spec_track(spec)
        if is_default_board_id(spec.board_id) or spec.board_id == default_board_id(
                track, direction, spec.race_type) or spec.board_id.startswith(CUSTOM_PREFIX):
            raise BoardExists(f"{spec.board_id!r} is a track's default board id; "
                              "give a named board an id of its own")
        board = _valid_board(
            board_id=spec.board_id, kind="named", track=track, direction=direction,
            race_type=spec.race_type, title=spec.title, description=spec.description,
            rules={"method": spec.method, "min_laps": spec.min_laps,
                   "flagged_runs": spec.flagged_runs},
            opens_at=spec.opens_at, closes_at=spec.closes_at, cooldown_s=spec.cooldown_s,
            max_submissions=spec.max_submissions, designs=spec.designs, created_at=now,
        )
        if self.store.get_board(board.board_id) is not None:
            raise BoardExists(f"there is already a board {board.board_id!r}")
        stored = self.store.create_board(board)
        if stored.board != board:
            raise BoardExists(f"there is already a board {board.board_id!r}")
        self._audit(board.board_id, "create", caller, detail=board.title)
        return board_view(stored, now)

    def update_board(self, board_id: str, changes: BoardChanges,
                     caller: Caller = LOCAL_ORGANISER) -> BoardView:
        stored = self._named(board_id)
        board = stored.board
        given = changes.model_fields_set
        for name in ("title", "method"):
            if name in given and getattr(changes, name) is None:
                raise InvalidQuery(f"{name} cannot be cleared")
        cleared = {"description": "", "cooldown_s": 0, "designs": "public"}  # what null means
        updates = {name: cleared.get(name) if getattr(changes, name) is None else getattr(changes, name)
                   for name in given if name not in ("method", "min_laps", "flagged_runs")}
        method = changes.method if "method" in given and changes.method else board.rules.method
        min_laps = changes.min_laps if "min_laps" in given else (
            None if method != board.rules.method else board.rules.min_laps)
        flagged_runs = changes.flagged_runs or board.rules.flagged_runs
        rules = BoardRules.model_validate({"method": method, "min_laps": min_laps,
                                           "flagged_runs": flagged_runs})
        rescores = rules != board.rules
        updated = _valid_board(**(board.model_dump() | updates | {"rules": rules.model_dump()}))
        if rescores and stored.participants:
            raise BoardLocked(_LOCKED.format(board_id))
        if updated == board:  # nothing changes: nothing is written, the version stays
            return board_view(stored, self.clock())
        view = self._save(updated, only_if_empty=rescores)
        self._audit(board_id, "update", caller,
                    detail=changes.model_dump_json(exclude_unset=True))
        return view

    def close_board(self, board_id: str, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        """Close the board now; an upcoming board closes without ever opening."""
        board = self._named(board_id).board
        now = self.clock()
        if board.status(now) is BoardStatus.CLOSED:
            return board_view(self._named(board_id), now)
        opens_at = board.opens_at if board.opens_at and board.opens_at < now else None
        view = self._save(board.model_copy(update={"closes_at": now, "opens_at": opens_at}))
        self._audit(board_id, "close", caller)
        return view

    def delete_board(self, board_id: str, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        """Delete a named board softly: it disappears from lists, pushes and pulls, and
        ``restore_board`` brings it back whole."""
        board = self._named(board_id).board
        view = self._save(board.model_copy(update={"deleted_at": self.clock()}))
        self._audit(board_id, "delete", caller)
        return view

    def restore_board(self, board_id: str, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        stored = self.store.get_board(board_id)
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r}")
        view = self._save(stored.board.model_copy(update={"deleted_at": None}))
        self._audit(board_id, "restore", caller)
        return view

    # ---- moderation and audit (organisers) ------------------------------------------------

    def remove_entry(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Take the racer's entry off the board; their submissions stay, and their next push
        makes a new entry."""
        self._require_board(board_id)
        key, name = self._racer_on(board_id, racer)
        removed = self.store.remove_entry(board_id, key)
        self._audit(board_id, "remove-entry", caller, racer=name,
                    submission_id=removed.submission_id if removed else None)
        return self._moderation(board_id, name, removed=removed is not None)

    def ban(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Refuse the racer's pushes to the board and take their entry off it (their
        submissions stay: `unban` puts their best back). A racer may be banned before their
        first push."""
        board = self._require_board(board_id).board
        key, name = racer_key(racer), self._known_name(board_id, racer)
        if key not in board.banned:
            self._save(board.model_copy(update={"banned": [*board.banned, key]}))
        removed = self.store.remove_entry(board_id, key)
        self._audit(board_id, "ban", caller, racer=name)
        return self._moderation(board_id, name, removed=removed is not None)

    def unban(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Take the racer off the board's ban list and put their best submission back."""
        board = self._require_board(board_id).board
        key, name = racer_key(racer), self._known_name(board_id, racer)
        if key in board.banned:
            board = board.model_copy(update={"banned": [k for k in board.banned if k != key]})
            self._save(board)
        best = self._best_entry(board, key)
        if best is not None:
            self.store.restore_entry(best)
        self._audit(board_id, "unban", caller, racer=name)
        return self._moderation(board_id, name, removed=False)

    def audit(self, board_id: str, cursor: str | None = None, limit: int = 100) -> AuditPage:
        """The board's audit trail, oldest first, ``limit`` events at a time."""
        _check_limit(limit)
        if self.store.get_board(board_id) is None:
            raise BoardNotFound(f"no board {board_id!r}")
        if cursor is not None and not _EVENT_ID.match(cursor):
            raise InvalidQuery("the cursor is not one this board gave out")
        page = self.store.audit(board_id, cursor, limit)
        return AuditPage(board_id=board_id, events=page.events, next_cursor=page.after)

    def _racer_on(self, board_id: str, racer: str) -> tuple[str, str]:
        """The racer's key and name as they pushed it, when they pushed to the board."""
        key = racer_key(racer)
        submissions = self.store.history(key, board_id)
        if not submissions:
            raise RacerNotFound(f"{racer!r} has no submissions on {board_id!r}")
        return key, submissions[-1].racer

    def _known_name(self, board_id: str, racer: str) -> str:
        submissions = self.store.history(racer_key(racer), board_id)
        return submissions[-1].racer if submissions else racer

    def _best_entry(self, board: Board, key: str) -> Entry | None:
        """The racer's best entry, recomputed from their submissions on the board."""
        best: Entry | None = None
        for submission in self.store.history(key, board.board_id):
            record = self.store.get_record(board.board_id, submission.submission_id)
            if record is None:  # pragma: no cover - a submission always has its record
                continue
            entry = scored_write(record, board, submission.submitted_at)[1]
            if best is None or entry.rank_key < best.rank_key:
                best = entry
        return best

    def _moderation(self, board_id: str, racer: str, removed: bool) -> Moderation:
        stored = self._require_board(board_id)
        return Moderation(board=board_view(stored, self.clock()), racer=racer,
                          banned=racer_key(racer) in stored.board.banned, entry_removed=removed)

    def _event(self, board_id: str, action: AuditAction, caller: Caller | None, at: datetime,
               **details: Any) -> AuditEvent:
        who = caller or Caller(principal="anonymous")
        return AuditEvent(board_id=board_id, at=at, action=action, actor=who.principal,
                          actor_name=who.name, event_id=_event_id(at), **details)

    def _audit(self, board_id: str, action: AuditAction, caller: Caller | None,
               **details: Any) -> None:
        self.store.append_audit(self._event(board_id, action, caller, self.clock(), **details))

    def _named(self, board_id: str) -> StoredBoard:
        stored = self._require_board(board_id)
        if stored.board.kind != "named":
            raise BoardLocked(f"{board_id!r} is a track's default board: it keeps the default "
                              "rules and cannot be changed; create a named board for your race")
        return stored

    def _save(self, board: Board, only_if_empty: bool = False) -> BoardView:
        try:
            stored = self.store.update_board(board, only_if_empty=only_if_empty)
        except BoardHasEntries:
            raise BoardLocked(_LOCKED.format(board.board_id)) from None
        except KeyError:
            raise BoardNotFound(f"no board {board.board_id!r}") from None
        return board_view(stored, self.clock())

    # ---- export and import ----------------------------------------------------------------

    def export_page(self, board_id: str, cursor: str | None = None) -> ExportPage:
        """One page of the board's export: the board, then its entries in rank order, then
        every submission with its record. Deleted boards export too."""
        stored = self.store.get_board(board_id)
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r}")
        part, after = decode_export_cursor(cursor) if cursor else ("entries", None)
        lines: list[ExportLine] = []
        if cursor is None:
            lines.append(ExportedBoard(exported_at=self.clock(), board=stored.board))
        if part == "entries":
            entries = self.store.top(board_id, EXPORT_ENTRIES, after)
            # Models read from the store, already valid: put in the line as they are.
            lines.extend(ExportedEntry.model_construct(entry=entry) for entry in entries)
            more = len(entries) == EXPORT_ENTRIES
            next_cursor = export_cursor("entries", entries[-1].rank_key) if more else (
                export_cursor("submissions", None))
            return ExportPage(lines=lines, next_cursor=next_cursor)
        page = self.store.stored_submissions(board_id, after, EXPORT_SUBMISSIONS)
        # Each record goes out as the JSON it was stored as (it was validated when pushed).
        lines.extend(StoredSubmissionLine.of(s, raw) for s, raw in page.submissions)
        return ExportPage(lines=lines,
                          next_cursor=export_cursor("submissions", page.after) if page.after else None)

    def import_board(self, board: Board, caller: Caller = LOCAL_ORGANISER) -> tuple[BoardView, bool]:
        """Create the exported board unless a board with its id exists (then that board's own
        settings stay). Returns the board and whether it was created."""
        now = self.clock()
        expected = default_board_id(board.track, board.direction, board.race_type)
        kind = "default" if board.board_id == expected else "named"
        if kind == "named" and not re.match(BOARD_ID_PATTERN, board.board_id):
            raise InvalidQuery(f"{board.board_id!r} is not a board id: letters, digits, _ - .")
        board = board.model_copy(update={"kind": kind, "deleted_at": None})
        existing = self.store.get_board(board.board_id)
        if existing is not None:
            self._live(board.board_id, existing)
            return board_view(existing, now), False
        stored = self.store.create_board(board)
        self._audit(board.board_id, "import", caller, detail="board")
        return board_view(stored, now), stored.board == board

    def import_submission(self, board_id: str, item: ImportedSubmission,
                          caller: Caller = LOCAL_ORGANISER) -> ImportReceipt:
        """Replay one exported submission with its first submission time, scored by this
        board's rules; the window and limits do not apply. Importing twice changes nothing."""
        board = self._require_board(board_id).board
        record = item.record
        _check_belongs(record, board)
        check_record_size(record)
        submission, entry = scored_write(record, board, item.submitted_at)
        audit = self._event(board_id, "import", caller, self.clock(), racer=record.racer,
                            submission_id=record.submission_id)
        if self.store.get_submission(board_id, submission.racer_key, record.submission_id) is None:
            self._archive(board_id, record)
        outcome = self.store.record_submission(submission, record, entry, audit=audit)
        return ImportReceipt(status="duplicate" if outcome.duplicate else "created",
                             board_id=board_id, submission_id=record.submission_id)


_LOCKED = ("{!r} has entries: its track, timing method, minimum laps and flagged-run rule can no "
           "longer change "
           "(create a new board, or export it and import into one with the new rules)")
EXPORT_ENTRIES = 500
EXPORT_SUBMISSIONS = 25  # with their records, up to 64 KiB each: a page stays under 2 MB


_ALIAS: TypeAdapter[str] = TypeAdapter(Alias)
_EVENT_ID = re.compile(r"^[0-9T:.Z-]{27}-[0-9a-f]{8}$")


def _event_id(at: datetime) -> str:
    """Unique, and in time order: the moment, then random digits."""
    return f"{ranking.timestamp(at)}-{secrets.token_hex(4)}"


def evaluation_fingerprints(record: Record) -> list[str]:
    """The sha256 of each evaluation's laps that completed a lap (what a copied run keeps,
    whatever it renames): the board refuses one already there under another racer."""
    return sorted({_fingerprint(run) for run in record.evaluations if run.laps_completed})


def _fingerprint(run: EvaluationRun) -> str:
    laps = [lap.model_dump(mode="json") for lap in run.laps]
    return hashlib.sha256(json.dumps(laps, sort_keys=True).encode()).hexdigest()


def is_default_board_id(board_id: str) -> bool:
    """Whether the id is the default board of a catalog track (for any direction and race)."""
    catalog = default_catalog()
    for race_suffix in _RACE_SUFFIX.values():
        for direction in ("_cw", ""):
            suffix = direction + race_suffix
            base = board_id[: len(board_id) - len(suffix)] if suffix else board_id
            if board_id.endswith(suffix) and base and catalog.get(base) is not None:
                return True
    return False


def check_record_size(record: Record) -> None:
    """Every board, embedded or in the cloud, holds a record to the same bound in bytes (its
    JSON, as the assembler measures it); the record's model bounds the rest (string lengths,
    laps, runs, curve points)."""
    size = len(record.model_dump_json().encode("utf-8"))
    if size > MAX_RECORD_BYTES:
        raise SubmissionTooLarge(f"the record is {size} bytes, over the {MAX_RECORD_BYTES} "
                                 "bytes a record may have")


def scored_write(record: Record, board: Board, at: datetime) -> tuple[Submission, Entry]:
    """The submission and the candidate entry a record makes on a board, as of ``at``: what a
    push (or an import) hands the store."""
    score = ranking.score_record(record, board.rules)
    key = racer_key(record.racer)
    score_key = ranking.score_key(score)
    submission = Submission(
        board_id=board.board_id, racer=record.racer, racer_key=key,
        submission_id=record.submission_id, model_name=record.model_name,
        submitted_at=at, score=score, score_key=score_key,
    )
    entry = Entry(
        board_id=board.board_id, racer=record.racer, racer_key=key,
        model_name=record.model_name, submission_id=record.submission_id,
        achieved_at=at, score=score, design=design_of(record), score_key=score_key,
        rank_key=ranking.rank_key(score_key, at, key),
    )
    return submission, entry


def _check_open(board: Board, now: datetime) -> None:
    status = board.status(now)
    if status is BoardStatus.UPCOMING:
        raise BoardClosed(f"{board.board_id!r} is not open yet: it opens at {display.when(board.opens_at)}")
    if status is BoardStatus.CLOSED:
        raise BoardClosed(f"{board.board_id!r} is closed: it closed at {display.when(board.closes_at)}")


def _check_not_deleted(board: Board) -> None:
    if board.deleted_at is not None:
        raise BoardNotFound(f"board {board.board_id!r} was deleted (an organiser can bring it "
                            f"back with `drboard board restore {board.board_id}`)")


def _limit_error(board: Board, racer: str, tally: RacerTally, now: datetime) -> DomainError:
    cap = board.max_submissions
    if cap is not None and tally.submissions >= cap:
        return SubmissionLimitReached(
            f"{racer} has made all {cap} submissions {board.board_id!r} allows")
    last = tally.last_submitted_at or now
    ready = last + timedelta(seconds=board.cooldown_s)
    wait = max(1, math.ceil((ready - now).total_seconds()))
    return TooSoon(f"{board.board_id!r} takes one submission every "
                   f"{display.duration(board.cooldown_s)} per racer: {racer} may submit again at "
                   f"{display.when(ready)} (in {display.duration(wait)})", wait)


def _spec_track(spec: BoardSpec) -> tuple[str, Literal["cw", "ccw"] | None]:
    if spec.custom_track:
        return spec.track, "cw" if spec.clockwise else None
    try:
        resolved = default_catalog().resolve(spec.track)
    except UnknownTrackError as error:
        raise InvalidQuery(f"{error} (a track of your own: set custom_track)") from None
    clockwise = spec.clockwise or resolved.direction == "cw"
    return resolved.track_id, "cw" if clockwise else None


def _valid_board(**fields: Any) -> Board:
    try:
        return Board.model_validate(fields)
    except ValidationError as error:
        problems = [{"loc": field_path(e["loc"]) or "board", "msg": e["msg"].removeprefix(
            "Value error, "), "type": e["type"]} for e in error.errors()]
        raise InvalidQuery(problems[0]["msg"] if len(problems) == 1 else "invalid board",
                           detail=problems) from None


P = TypeVar("P", BoardList, RacerHistory)


def _follow(read: Callable[[int, str | None], P]) -> Iterator[P]:
    """Every page of a paginated read, at the largest page size."""
    cursor: str | None = None
    while True:
        page = read(MAX_PAGE, cursor)
        yield page
        cursor = page.next_cursor
        if cursor is None:
            return


@contextmanager
def _bad_cursor() -> Iterator[None]:
    try:
        yield
    except BadPageToken:
        raise InvalidQuery("the cursor is not one this board gave out") from None


def _check_limit(limit: int) -> None:
    if not 1 <= limit <= MAX_PAGE:
        raise InvalidQuery(f"limit must be between 1 and {MAX_PAGE}")


def _check_belongs(record: Record, board: Board) -> None:
    problem = {
        "track": f"the run is on {record.track}, the board on {board.track}",
        "direction": "the run and the board differ in direction",
        "race_type": f"the run is {record.race_type.value}, the board {board.race_type.value}",
    }
    problems = [problem[field] for field in
                run_mismatches(record.track, record.direction, record.race_type, board)]
    if problems:
        raise BoardMismatch(f"this run does not belong on {board.board_id!r}: "
                            + "; ".join(problems))
