"""Reading the boards: the boards there are, and each one's standings page by page, from its
first page (what every function shows) on."""

from __future__ import annotations

from collections.abc import Sequence

from ..cursors import RankCursor, decode_page_cursor, page_cursor
from ..errors import RacerNotFound
from ..models.domain import Entry
from ..models.views import BoardList, BoardPage, BoardView, EntryView
from ..stores.base import StoredBoard
from ..views import board_view, entry_view, page_tag
from .boards import BoardKeeper, live, racer_key
from .paging import DEFAULT_PAGE, bad_cursor, check_limit, follow


class Reading:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.clock = keeper.clock

    def boards(self) -> list[BoardView]:
        """Every live board, by id (page after page)."""
        return [view for page in follow(self.boards_page) for view in page.boards]

    def boards_page(self, limit: int = DEFAULT_PAGE, cursor: str | None = None) -> BoardList:
        """One page of the live boards, by id: the store reads ``limit`` boards, and deleted
        ones are left out, so a page may be short; ``next_cursor`` is None on the last."""
        check_limit(limit)
        with bad_cursor():
            page = self.store.boards_page(decode_page_cursor("boards", cursor), limit)
        now = self.clock()
        return BoardList(boards=[board_view(stored, now) for stored in page.boards
                                 if stored.board.deleted_at is None],
                         next_cursor=page_cursor("boards", page.after))

    def board_page(self, board_id: str, limit: int = 100, cursor: str | None = None) -> BoardPage:
        check_limit(limit)
        after = RankCursor.decode(cursor) if cursor else None
        if after is None:
            return self.board_pages(board_id, [limit])[0]
        stored = self.keeper.require(board_id)
        entries = self.store.top(board_id, limit, after.rank_key)
        return self._page(stored, entries, limit, after, self.keeper.leader(board_id))

    def board_pages(self, board_id: str, limits: Sequence[int],
                    front: tuple[StoredBoard, Sequence[Entry]] | None = None) -> list[BoardPage]:
        """The board's top pages of these sizes, from one read of the largest, or from
        ``front``: the board and its first entries as read already (at least the largest)."""
        for limit in limits:
            check_limit(limit)
        if front is None:
            found, read = self.store.front_page(board_id, max(limits))
            front = live(board_id, found), read
        stored, entries = front
        leader = entries[0] if entries else None
        return [self._page(stored, entries[:limit], limit, None, leader) for limit in limits]

    def _page(self, stored: StoredBoard, entries: Sequence[Entry], limit: int,
              after: RankCursor | None, leader: Entry | None) -> BoardPage:
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
            board=self.keeper.view(stored),
            entries=views,
            next_cursor=previous.encode() if more and previous else None,
        )

    def board_tag(self, board_id: str) -> str:
        """The board's :func:`page_tag`, in one read: unchanged, its pages are too."""
        stored = live(board_id, self.store.get_board(board_id))
        return page_tag(self.keeper.view(stored))

    def board_version(self, board_id: str) -> int | None:
        """The board's version in the store's cheapest read (None: no such board, yet)."""
        return self.store.board_version(board_id)

    def standing(self, board_id: str, racer: str) -> tuple[BoardView, EntryView]:
        """The board and the racer's entry on it, ranked, as a racer's page shows them, without
        their record or history (what a result card says: reading neither keeps a card's cold
        start from parsing a whole record)."""
        stored = self.keeper.require(board_id)
        entry = self.entry(board_id, racer)
        rank = self.store.count_better(board_id, entry.score_key) + 1
        shown = stored.board.designs_shown(self.clock())
        return (self.keeper.view(stored),
                entry_view(entry, rank, self.keeper.leader(board_id), design=shown))

    def entry(self, board_id: str, racer: str) -> Entry:
        """The racer's entry on the board (RacerNotFound: none)."""
        entry = self.store.get_entry(board_id, racer_key(racer))
        if entry is None:
            raise RacerNotFound(f"{racer!r} has no entry on {board_id!r}")
        return entry
