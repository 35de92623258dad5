"""Organisers moderating a board: taking an entry off it, banning and unbanning a racer, and
the audit trail of everything done to the board.

A ban binds to the person: the racer's alias and the sign-in (principal) that holds it, so a
banned racer cannot come back under another alias from the same sign-in. Its scope is the
event by default — every board of the deployment (one stack's table, one `drboard serve`, one
embedded board file), so a track's clockwise board or a named board is closed to them too —
or one board (``everywhere=False``).
"""

from __future__ import annotations

from collections.abc import Callable

from ..errors import BoardNotFound, InvalidQuery, RacerNotFound, StoreBusy
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import Board, Entry, EventBans
from ..models.organiser_views import AuditPage, Moderation
from ..stores.base import BoardChanged
from .boards import EVENT_ID, BoardKeeper, racer_key
from .paging import check_limit
from .pushing import RESERVED, scored_write

BAN_ATTEMPTS = 5


class Moderating:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store

    def remove_entry(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Take the racer's entry off the board; their submissions stay, and their next push
        makes a new entry."""
        self.keeper.require(board_id)
        key, name = self._racer_on(board_id, racer)
        removed = self.store.remove_entry(board_id, key)
        self.keeper.audit(board_id, "remove-entry", caller, racer=name,
                          submission_id=removed.submission_id if removed else None)
        return self._moderation(board_id, name, removed=removed is not None)

    def ban(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER,
            everywhere: bool = True) -> Moderation:
        """Refuse the racer's pushes — by alias, and by the sign-in holding it whatever alias it
        pushes as — on every board of the event (or on this board only), and take their entry
        off this board (their submissions stay: `unban` puts their best back). A racer may be
        banned before their first push."""
        board = self.keeper.require(board_id).board
        key, name = racer_key(racer), self._known_name(board_id, racer)
        person = self._person(key)
        if everywhere:
            self._change_event_bans(lambda bans: EventBans(
                racers=_with(bans.racers, key), principals=_with(bans.principals, person)))
        elif key not in board.banned or (person and person not in board.banned_principals):
            self.keeper.save(board.model_copy(update={
                "banned": _with(board.banned, key),
                "banned_principals": _with(board.banned_principals, person)}))
        removed = self.store.remove_entry(board_id, key)
        where = "every board of the event" if everywhere else "this board"
        self.keeper.audit(board_id, "ban", caller, racer=name,
                          detail=f"from {where}" + (f", sign-in {person}" if person else ""))
        return self._moderation(board_id, name, removed=removed is not None)

    def unban(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Lift the racer's bans — on this board and across the event, by alias and by
        sign-in — and put their best submission on this board back."""
        board = self.keeper.require(board_id).board
        key, name = racer_key(racer), self._known_name(board_id, racer)
        person = self._person(key)
        if key in board.banned or person in board.banned_principals:
            board = board.model_copy(update={
                "banned": _without(board.banned, key),
                "banned_principals": _without(board.banned_principals, person)})
            self.keeper.save(board)
        bans, _ = self.store.event_bans()
        if key in bans.racers or person in bans.principals:
            self._change_event_bans(lambda bans: EventBans(
                racers=_without(bans.racers, key), principals=_without(bans.principals, person)))
        best = self._best_entry(board, key)
        if best is not None:
            self.store.restore_entry(best)
        self.keeper.audit(board_id, "unban", caller, racer=name)
        return self._moderation(board_id, name, removed=False)

    def _person(self, key: str) -> str | None:
        """The sign-in holding the alias, if a racer holds it (not an organiser's reservation)."""
        claim = self.store.alias_holder(key)
        return claim.principal if claim and not claim.principal.startswith(RESERVED) else None

    def _change_event_bans(self, change: Callable[[EventBans], EventBans]) -> None:
        for _ in range(BAN_ATTEMPTS):
            bans, version = self.store.event_bans()
            try:
                self.store.save_event_bans(change(bans), version)
                return
            except BoardChanged:
                continue
        raise StoreBusy("the event's bans kept changing; try again")

    def audit(self, board_id: str, cursor: str | None = None, limit: int = 100) -> AuditPage:
        """The board's audit trail, oldest first, ``limit`` events at a time."""
        check_limit(limit)
        if self.store.get_board(board_id) is None:
            raise BoardNotFound(f"no board {board_id!r}")
        if cursor is not None and not EVENT_ID.match(cursor):
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
        stored = self.keeper.require(board_id)
        key = racer_key(racer)
        person = self._person(key)
        bans, _ = self.store.event_bans()
        everywhere = key in bans.racers or (person is not None and person in bans.principals)
        here = key in stored.board.banned or (person is not None
                                              and person in stored.board.banned_principals)
        return Moderation(board=self.keeper.view(stored), racer=racer, banned=here or everywhere,
                          entry_removed=removed, everywhere=everywhere, principal=person)


def _with(values: list[str], value: str | None) -> list[str]:
    return values if value is None or value in values else [*values, value]


def _without(values: list[str], value: str | None) -> list[str]:
    return [v for v in values if v != value]
