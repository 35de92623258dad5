"""What a change on a board announces.

- An entry that improved (a push): the racer takes the lead (``new-leader``), enters the top 3
  (``top-3``), or beats their own time (``personal-best``; a first time on the board counts).
  One push announces one event, the most notable. Only qualified times are announced. An entry
  whose time was set more than ``FRESH`` before the change is not a push but an import or an
  entry an organiser put back: it announces nothing.
- A board's window: its opening (``board-open``) and its closing with its podium
  (``board-close``), found by looking at the boards' windows now and then (the cloud's schedule,
  `drboard serve`'s worker); a moment more than ``LOOKBACK`` ago is not announced late.

A season's webhooks hear the events of its rounds' boards and of its final's, as the boards' own
webhooks do (each webhook hears an event once).

Ranks are the board's when the announcement is worked out (a few seconds after the push).
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime, timedelta

from .. import ranking
from ..models.domain import Board, BoardStatus, Entry
from ..models.notices import Announcement, EntryChange, Place, Target
from ..stores.base import BoardStore
from .messages import words

FRESH = timedelta(minutes=10)
LOOKBACK = timedelta(days=1)
PODIUM = 3

BoardUrl = Callable[[str], str]


def targets_of(store: BoardStore, board_id: str) -> list[Target]:
    """Whose webhooks hear a board's events: the board's own, and each season's the board is a
    round (or the final) of."""
    return [Target(kind="board", target_id=board_id),
            *(Target(kind="season", target_id=link.season_id) for link in store.season_links(board_id))]


def season_boards(store: BoardStore, season_id: str) -> list[str]:
    """The boards whose events a season's webhooks hear: its rounds and its final."""
    season = store.get_season(season_id)
    if season is None:
        return []
    boards = [r.board_id for r in season.rounds]
    if season.final is not None:
        boards.append(season.final.board_id)
    return boards


def entry_announcement(store: BoardStore, change: EntryChange, board_url: BoardUrl) -> Announcement | None:
    after, before = change.after, change.before
    if not after.score.qualified or after.score.time_ms is None:
        return None
    if before is not None and before.rank_key <= after.rank_key:
        return None
    if abs(change.at - after.achieved_at) > FRESH:
        return None
    stored = store.get_board(change.board_id)
    if stored is None or stored.board.deleted_at is not None:
        return None
    board = stored.board
    rank = store.count_better(board.board_id, after.score_key) + 1
    # The racer's own new entry is better than their old one: it is among those counted.
    previous = None if before is None else store.count_better(board.board_id, before.score_key)
    top = store.top(board.board_id, 2)
    leader = top[0] if top else after
    announcement = Announcement(
        event_id=f"{board.board_id}#entry#{after.submission_id}", kind="personal-best",
        target=Target(target_id=board.board_id), board_id=board.board_id, board_title=board.title,
        url=board_url(board.board_id), at=change.at, racer=after.racer,
        model_name=after.model_name, time_ms=after.score.time_ms, rank=rank,
        previous_rank=previous, gap_ms=_gap(after, leader))
    if leader.racer_key == after.racer_key and (previous is None or previous > 1):
        runner_up = top[1] if len(top) > 1 and top[1].score.qualified else None
        announcement = announcement.model_copy(update={
            "kind": "new-leader", "previous_leader": runner_up.racer if runner_up else None,
            "gap_ms": _gap(runner_up, after) if runner_up else None})
    elif rank <= PODIUM and (previous is None or previous > PODIUM):
        announcement = announcement.model_copy(update={"kind": "top-3"})
    return _said(announcement)


def window_announcements(store: BoardStore, board: Board, now: datetime,
                         board_url: BoardUrl) -> list[Announcement]:
    """The board's opening and closing that happened in the last ``LOOKBACK``."""
    since = now - LOOKBACK
    found = []
    base = {"target": Target(target_id=board.board_id), "board_id": board.board_id,
            "board_title": board.title, "url": board_url(board.board_id)}
    opens, closes = board.opens_at, board.closes_at
    if opens and since < opens <= now and board.status(now) is BoardStatus.OPEN:
        found.append(_said(Announcement(
            event_id=f"{board.board_id}#open#{ranking.timestamp(opens)}", kind="board-open",
            at=opens, closes_at=closes, **base)))
    if closes and since < closes <= now:
        found.append(_said(Announcement(
            event_id=f"{board.board_id}#close#{ranking.timestamp(closes)}", kind="board-close",
            at=closes, podium=podium(store, board.board_id), **base)))
    return found


def podium(store: BoardStore, board_id: str) -> list[Place]:
    """The board's first three qualified racers (equal results share a rank)."""
    entries = [e for e in store.top(board_id, PODIUM) if e.score.qualified]
    leader = entries[0] if entries else None
    return [Place(rank=store.count_better(board_id, e.score_key) + 1, racer=e.racer,
                  model_name=e.model_name, time_ms=e.score.time_ms,
                  gap_ms=_gap(e, leader) if leader else None) for e in entries]


def _gap(entry: Entry, leader: Entry) -> int | None:
    if entry.score.time_ms is None or leader.score.time_ms is None:
        return None
    return entry.score.time_ms - leader.score.time_ms


def _said(announcement: Announcement) -> Announcement:
    return announcement.model_copy(update={"text": words(announcement)})
