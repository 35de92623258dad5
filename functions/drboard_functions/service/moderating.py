"""Organisers moderating a board: taking an entry off it, banning and unbanning a racer, and
the audit trail of everything done to the board."""

from __future__ import annotations

from ..errors import BoardNotFound, InvalidQuery, RacerNotFound
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import Board, Entry
from ..models.views import AuditPage, Moderation
from .boards import EVENT_ID, BoardKeeper, racer_key
from .paging import check_limit
from .pushing import scored_write


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

    def ban(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Refuse the racer's pushes to the board and take their entry off it (their
        submissions stay: `unban` puts their best back). A racer may be banned before their
        first push."""
        board = self.keeper.require(board_id).board
        key, name = racer_key(racer), self._known_name(board_id, racer)
        if key not in board.banned:
            self.keeper.save(board.model_copy(update={"banned": [*board.banned, key]}))
        removed = self.store.remove_entry(board_id, key)
        self.keeper.audit(board_id, "ban", caller, racer=name)
        return self._moderation(board_id, name, removed=removed is not None)

    def unban(self, board_id: str, racer: str, caller: Caller = LOCAL_ORGANISER) -> Moderation:
        """Take the racer off the board's ban list and put their best submission back."""
        board = self.keeper.require(board_id).board
        key, name = racer_key(racer), self._known_name(board_id, racer)
        if key in board.banned:
            board = board.model_copy(update={"banned": [k for k in board.banned if k != key]})
            self.keeper.save(board)
        best = self._best_entry(board, key)
        if best is not None:
            self.store.restore_entry(best)
        self.keeper.audit(board_id, "unban", caller, racer=name)
        return self._moderation(board_id, name, removed=False)

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
        return Moderation(board=self.keeper.view(stored), racer=racer,
                          banned=racer_key(racer) in stored.board.banned, entry_removed=removed)
