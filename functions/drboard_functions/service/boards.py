"""BoardKeeper as every part of the service sees them: which board a run belongs on, a track's
default boards, the checks a board makes of a run, and the audit trail of what is done to it."""

from __future__ import annotations

import random
import re
from collections.abc import Callable
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

from drboard_assembler.aliases import alias_key
from drboard_assembler.catalog import UnknownTrackError, default_catalog
from drboard_assembler.errors import field_path
from drboard_assembler.record import RaceType, Record
from pydantic import ValidationError

from .. import display, ranking
from ..board_ids import default_board_id as default_board_id  # and for the rooms that import it here
from ..conditions import meets, unmet
from ..errors import BoardClosed, BoardLocked, BoardMismatch, BoardNotFound, InvalidQuery
from ..identity import Caller
from ..models.domain import AuditAction, AuditEvent, Board, BoardRules, BoardStatus, Entry, run_mismatches
from ..models.views import BoardView
from ..stores.base import BoardHasEntries, BoardStore, StoredBoard
from ..views import board_view

if TYPE_CHECKING:
    from ..models.notices import EntryChange
    from ..models.requests import BoardSpec

Clock = Callable[[], datetime]


class StandingsKeeper(NamedTuple):
    """Who keeps a board's standings after a push improves it, and how many entries they need."""

    top: int
    keep: Callable[[StoredBoard, list[Entry]], None]


_RACE_TITLE = {
    RaceType.TIME_TRIAL: "",
    RaceType.OBJECT_AVOIDANCE: ", object avoidance",
    RaceType.HEAD_TO_BOT: ", head to bot",
    RaceType.HEAD_TO_MODEL: ", head to model",
    RaceType.HEAD_TO_HEAD_RACING: ", head to head",
    RaceType.F1: ", F1",
}

LOCKED = ("{!r} has entries: its track, timing method, minimum laps, flagged-run rule and required "
          "conditions can no longer change "
          "(create a new board, or export it and import into one with the new rules)")

EVENT_ID = re.compile(r"^[0-9T:.Z-]{27}-[0-9a-f]{8}$")


def utc_now() -> datetime:
    return datetime.now(UTC)


def racer_key(racer: str) -> str:
    """Racer aliases are matched after Unicode NFKC and case folding, white space collapsed."""
    return alias_key(racer)


def default_board(record: Record, now: datetime) -> Board:
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


def spec_track(spec: BoardSpec) -> tuple[str, Literal["cw", "ccw"] | None]:
    if spec.custom_track:
        return spec.track, "cw" if spec.clockwise else None
    try:
        resolved = default_catalog().resolve(spec.track)
    except UnknownTrackError as error:
        raise InvalidQuery(f"{error} (a track of your own: set custom_track)") from None
    clockwise = spec.clockwise or resolved.direction == "cw"
    return resolved.track_id, "cw" if clockwise else None


def valid_board(**fields: Any) -> Board:
    try:
        return Board.model_validate(fields)
    except ValidationError as error:
        problems = [{"loc": field_path(e["loc"]) or "board", "msg": e["msg"].removeprefix(
            "Value error, "), "type": e["type"]} for e in error.errors()]
        raise InvalidQuery(problems[0]["msg"] if len(problems) == 1 else "invalid board",
                           detail=problems) from None


def check_open(board: Board, now: datetime) -> None:
    status = board.status(now)
    if status is BoardStatus.UPCOMING:
        raise BoardClosed(f"{board.board_id!r} is not open yet: it opens at {display.when(board.opens_at)}")
    if status is BoardStatus.CLOSED:
        raise BoardClosed(f"{board.board_id!r} is closed: it closed at {display.when(board.closes_at)}")


def check_not_deleted(board: Board) -> None:
    if board.deleted_at is not None:
        raise BoardNotFound(f"board {board.board_id!r} was deleted (an organiser can bring it "
                            f"back with `drboard board restore {board.board_id}`)")


def check_belongs(record: Record, board: Board) -> None:
    mismatches = run_mismatches(record.track, record.direction, record.race_type, board)
    required = board.rules.conditions
    unmet_by_all = not any(meets(required, run) for run in record.evaluations)
    if not mismatches and not unmet_by_all:
        return
    problem = {
        "track": f"the run is on {record.track}, the board on {board.track}",
        "direction": "the run and the board differ in direction",
        "race_type": f"the run is {record.race_type.value}, the board {board.race_type.value}",
    }
    problems = [problem[field] for field in mismatches]
    if unmet_by_all:
        problems.append("its evaluation ran under other conditions: "
                        + ", ".join(unmet(required, record.best_run.conditions)))
    raise BoardMismatch(f"this run does not belong on {board.board_id!r}: " + "; ".join(problems))


def live(board_id: str, stored: StoredBoard | None) -> StoredBoard:
    """The board, unless there is none or it was deleted."""
    if stored is None:
        raise BoardNotFound(f"no board {board_id!r} (no run has been pushed to it yet)")
    check_not_deleted(stored.board)
    return stored


def event_id(at: datetime) -> str:
    """Unique, and in time order: the moment, then random digits. The digits only tell apart the
    events of one microsecond and are no secret: Python's generator makes them, not a system call
    (which an import of 100,000 submissions would make 100,000 times)."""
    return f"{ranking.timestamp(at)}-{random.getrandbits(32):08x}"


class BoardKeeper:
    """The store and the clock every part of the service shares, and the board lookups and
    audit trail they all use."""

    def __init__(self, store: BoardStore, clock: Clock) -> None:
        self.store = store
        self.clock = clock
        #: Told of every entry a push improves (`drboard serve`'s announcer), if anyone listens.
        self.listener: Callable[[EntryChange], None] | None = None
        #: Handed the board and its first entries after a push improved it (how many: ``top``),
        #: read once for the push's receipt: the push function keeps its standings from them.
        self.standings_keeper: StandingsKeeper | None = None

    def require(self, board_id: str) -> StoredBoard:
        return live(board_id, self.store.get_board(board_id))

    def named(self, board_id: str) -> StoredBoard:
        stored = self.require(board_id)
        if stored.board.kind != "named":
            raise BoardLocked(f"{board_id!r} is a track's default board: it keeps the default "
                              "rules and cannot be changed; create a named board for your race")
        return stored

    def for_record(self, record: Record, board_id: str, stored: StoredBoard | None,
                   now: datetime) -> StoredBoard:
        """The board a run is pushed to (``stored``, as read, under ``board_id``), made by the
        run's push if it is the run's default board and does not exist yet."""
        if stored is None:
            default_id = default_board_id(record.track, record.direction, record.race_type)
            if board_id != default_id:
                raise BoardNotFound(f"no board {board_id!r}; this run belongs on {default_id!r}")
            stored = self.store.create_board(default_board(record, now))
        check_not_deleted(stored.board)
        check_belongs(record, stored.board)
        return stored

    def view(self, stored: StoredBoard) -> BoardView:
        return board_view(stored, self.clock())

    def leader(self, board_id: str) -> Entry | None:
        top = self.store.top(board_id, 1)
        return top[0] if top else None

    def save(self, board: Board, only_if_empty: bool = False) -> BoardView:
        try:
            stored = self.store.update_board(board, only_if_empty=only_if_empty)
        except BoardHasEntries:
            raise BoardLocked(LOCKED.format(board.board_id)) from None
        except KeyError:
            raise BoardNotFound(f"no board {board.board_id!r}") from None
        return self.view(stored)

    def event(self, board_id: str, action: AuditAction, caller: Caller | None, at: datetime,
              **details: Any) -> AuditEvent:
        who = caller or Caller(principal="anonymous")
        return AuditEvent(board_id=board_id, at=at, action=action, actor=who.principal,
                          actor_name=who.name, event_id=event_id(at), **details)

    def audit(self, board_id: str, action: AuditAction, caller: Caller | None,
              **details: Any) -> None:
        self.store.append_audit(self.event(board_id, action, caller, self.clock(), **details))
