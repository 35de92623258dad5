"""Organisers managing their named boards: create, change, close, delete and restore."""

from __future__ import annotations

from ..board_ids import default_board_id, made_by_a_push
from ..errors import BoardExists, BoardLocked, BoardNotFound, InvalidQuery
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import BoardConditions, BoardRules, BoardStatus
from ..models.organiser_views import RankCounters
from ..models.requests import BoardChanges, BoardSpec
from ..models.views import BoardView
from .boards import LOCKED, BoardKeeper, spec_track, valid_board


def _required(conditions: BoardConditions | None) -> BoardConditions | None:
    """The conditions a board requires; None when none is given (any run's)."""
    return conditions if conditions is not None and conditions.required() else None


class Managing:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.clock = keeper.clock

    def create_board(self, spec: BoardSpec, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        now = self.clock()
        track, direction = spec_track(spec)
        if made_by_a_push(spec.board_id) or spec.board_id == default_board_id(
                track, direction, spec.race_type):
            raise BoardExists(f"{spec.board_id!r} is a track's default board id; "
                              "give a named board an id of its own")
        board = valid_board(
            board_id=spec.board_id, kind="named", track=track, direction=direction,
            race_type=spec.race_type, title=spec.title, description=spec.description,
            rules={"method": spec.method, "min_laps": spec.min_laps,
                   "flagged_runs": spec.flagged_runs, "conditions": _required(spec.conditions)},
            opens_at=spec.opens_at, closes_at=spec.closes_at, cooldown_s=spec.cooldown_s,
            max_submissions=spec.max_submissions, designs=spec.designs, created_at=now,
        )
        stored = self.store.create_board(board)  # a board already there is given back as it is
        if stored.board != board:
            raise BoardExists(f"there is already a board {board.board_id!r}")
        self.keeper.audit(board.board_id, "create", caller, detail=board.title)
        return self.keeper.view(stored)

    def update_board(self, board_id: str, changes: BoardChanges,
                     caller: Caller = LOCAL_ORGANISER) -> BoardView:
        stored = self.keeper.named(board_id)
        board = stored.board
        given = changes.model_fields_set
        for name in ("title", "method"):
            if name in given and getattr(changes, name) is None:
                raise InvalidQuery(f"{name} cannot be cleared")
        cleared = {"description": "", "cooldown_s": 0, "designs": "public"}  # what null means
        updates = {name: cleared.get(name) if getattr(changes, name) is None else getattr(changes, name)
                   for name in given if name not in ("method", "min_laps", "flagged_runs", "conditions")}
        method = changes.method if "method" in given and changes.method else board.rules.method
        min_laps = changes.min_laps if "min_laps" in given else (
            None if method != board.rules.method else board.rules.min_laps)
        flagged_runs = changes.flagged_runs or board.rules.flagged_runs
        conditions = _required(changes.conditions) if "conditions" in given else board.rules.conditions
        rules = BoardRules.model_validate({"method": method, "min_laps": min_laps,
                                           "flagged_runs": flagged_runs, "conditions": conditions})
        rescores = rules != board.rules
        updated = valid_board(**(board.model_dump() | updates | {"rules": rules.model_dump()}))
        if rescores and stored.participants:
            raise BoardLocked(LOCKED.format(board_id))
        if updated == board:  # nothing changes: nothing is written, the version stays
            return self.keeper.view(stored)
        view = self.keeper.save(updated, only_if_empty=rescores)
        self.keeper.audit(board_id, "update", caller,
                          detail=changes.model_dump_json(exclude_unset=True))
        return view

    def close_board(self, board_id: str, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        """Close the board now; an upcoming board closes without ever opening."""
        board = self.keeper.named(board_id).board
        now = self.clock()
        if board.status(now) is BoardStatus.CLOSED:
            return self.keeper.view(self.keeper.named(board_id))
        opens_at = board.opens_at if board.opens_at and board.opens_at < now else None
        view = self.keeper.save(board.model_copy(update={"closes_at": now, "opens_at": opens_at}))
        self.keeper.audit(board_id, "close", caller)
        return view

    def delete_board(self, board_id: str, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        """Delete a named board softly: it disappears from lists, pushes and pulls, and
        ``restore_board`` brings it back whole."""
        board = self.keeper.named(board_id).board
        view = self.keeper.save(board.model_copy(update={"deleted_at": self.clock()}))
        self.keeper.audit(board_id, "delete", caller)
        return view

    def restore_board(self, board_id: str, caller: Caller = LOCAL_ORGANISER) -> BoardView:
        stored = self.store.get_board(board_id)
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r}")
        view = self.keeper.save(stored.board.model_copy(update={"deleted_at": None}))
        self.keeper.audit(board_id, "restore", caller)
        return view

    def rebuild_ranks(self, board_id: str, budget_s: float | None = None) -> RankCounters:
        """Build the rank counters of a board from before them, for up to ``budget_s`` seconds
        (None: to the end); a later call goes on where this one stopped."""
        self.keeper.require(board_id)
        built = self.store.build_rank_counters(board_id, budget_s=budget_s)
        return RankCounters(board_id=board_id, done=built.done, counted=built.counted,
                            participants=built.participants)
