"""The standings a board shows, rendered once per board version and kept as the bytes that
answer them.

A board's top page — ``GET /boards/{board}`` (JSON), ``GET /boards/{board}/view`` (its web page)
and ``/view?screen=1`` (the big screen) — is rendered once per board version and kept, encoded
(:mod:`.kept`). Every later read of that page makes one small read of the board's version (its
SQLite row, or one consistent DynamoDB read of the board item) and, while the version is the one
the copy was rendered from, answers the copy's bytes as they are, or ``304 Not Modified`` when
the client's ``If-None-Match`` names its ETag: no entry is read, nothing is parsed, validated or
encoded again. ``drboard serve`` answers such reads before it builds an API Gateway event, and
the pull function before it loads the resolver at all; a read no copy answers (another page, a
cursor, a board that changed) goes through the routes, which render the page and keep it
(:meth:`Standings.copy`).

Where the copies live: in each process (``drboard serve``, each warm Lambda container), keyed by
the board and the page asked for; and where the store keeps pages (DynamoDB: see
``stores.dynamodb.pages``), beside the board too, so that a cold container answers a page
another rendered with one read. Each is labelled with the version it was rendered from, and the
label is compared with the board's version at every read, so a copy is never answered for a
newer version, whoever made it (a push in another container, another process writing the same
SQLite file); a version changes with every push that changes the standings and with every
organiser's change (a season taking the board in or letting it go, too: its page links to them),
in the same write. In the cloud the push, or the organiser's change, that changes a board
renders its JSON standings and keeps them, so they are there before anyone asks: a push from the
read of the board its receipt is made from (:func:`keeping_after_pushes`, in ``handlers.push``),
an organiser's change from a read of its own (:func:`renew_after_change`, in ``handlers.admin``);
other pages are rendered and kept by their first reader. In front of the containers the CDN (see
template.yaml) keeps viewers off them.

A page also depends on the clock: the board opens and closes at set times (its status, and
whether designs show), and the web page counts down to that moment. A copy is kept until the
next of these moments only, and a web page showing a countdown for at most
:data:`COUNTDOWN_REFRESH_S` (the page's script counts down between two copies).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from datetime import datetime, timedelta
from typing import TYPE_CHECKING
from weakref import WeakKeyDictionary

from ..board_window import next_change
from ..errors import DomainError
from ..views import page_tag
from .headers import HTML, JSON, PAGE_HEADERS, etag_headers, page_etag
from .kept import PUSHED_LIMITS, Copy, KeptPages, Wanted, copy_key, page_copy
from .params import segment
from .responses import page_policy

if TYPE_CHECKING:
    from ..models.domain import Entry
    from ..models.seasons import SeasonLink
    from ..models.views import BoardPage, BoardView
    from ..service import LeaderboardService, StandingsKeeper
    from ..stores.base import StoredBoard
    from ..web import Invite

#: A web page counting down to its board's opening or closing is rendered again this often.
COUNTDOWN_REFRESH_S = 30


def fresh_until(board: BoardView, now: datetime, *, countdown: bool) -> datetime | None:
    """Until when a page of the board rendered ``now`` holds, its version unchanged: the board's
    next opening or closing (None: never), and a countdown's refresh."""
    change = next_change(board)
    if change is not None and countdown:
        return min(change, now + timedelta(seconds=COUNTDOWN_REFRESH_S))
    return change


class Standings:
    """One service's board pages: those kept (:class:`.kept.KeptPages`: in this process, and on
    the store's shelf when it keeps pages), and those rendered when none is kept for the board's
    version (thread-safe; a page being rendered is rendered once, its other readers waiting)."""

    def __init__(self, service: LeaderboardService) -> None:
        self.service = service
        self.pages = KeptPages(service.board_version, service.page_shelf, service.clock)
        self._lock = threading.Lock()
        self._rendering: dict[tuple[Wanted, str], threading.Lock] = {}

    def kept(self, wanted: Wanted, invite: Invite | None = None) -> Copy | None:
        """The copy of the page for the board's version now, if one is kept: one read of the
        version (and of the store's page, when this process holds none)."""
        return self.pages.kept(wanted, _address(invite))

    def copy(self, wanted: Wanted, invite: Invite | None = None) -> Copy:
        """The page: the kept copy for the board's version now, else rendered and kept. The
        service's errors (no such board) are raised as they are."""
        address = _address(invite)
        held = self.pages.held(wanted, address)
        kept = self.pages.kept(wanted, address)
        if kept is not None:
            return kept
        name = copy_key(wanted, address)
        with self._lock:
            rendering = self._rendering.setdefault(name, threading.Lock())
        with rendering:
            rendered = self.pages.held(wanted, address)
            if rendered is not held and rendered is not None:
                return rendered  # another thread rendered it while this one waited
            copy = self._render(wanted, invite)
            self.pages.keep(wanted, address, copy)
            with self._lock:
                self._rendering.pop(name, None)
        return copy

    def renew(self, board_id: str, limits: Sequence[int],
              front: tuple[StoredBoard, Sequence[Entry]] | None = None) -> None:
        """Render the board's JSON pages of these sizes as it is now, from one read (or from
        ``front``, the board and its first entries as read already), and keep them."""
        now = self.service.clock()
        pages = self.service.board_pages(board_id, limits, front)
        self.pages.keep_all(board_id, [(Wanted(board_id, "json", limit), _json_copy(page, limit, now))
                                       for limit, page in zip(limits, pages, strict=True)])

    def _render(self, wanted: Wanted, invite: Invite | None) -> Copy:
        page = self.service.board_page(wanted.board_id, limit=wanted.limit, cursor=None)
        now = self.service.clock()
        if not wanted.html:
            return _json_copy(page, wanted.limit, now)
        assert invite is not None
        etag = page_etag(f"{wanted.kind}.{page_tag(page.board)}", wanted.limit, None)
        html = _board_html(page, etag, invite, screen=wanted.kind == "screen", now=now,
                           seasons=self.service.board_seasons(wanted.board_id))
        headers = {"Content-Type": HTML} | PAGE_HEADERS | page_policy(live=True) | etag_headers(etag)
        return page_copy(page.board.version, fresh_until(page.board, now, countdown=True), etag,
                         html, headers, headers)


def _json_copy(page: BoardPage, limit: int, now: datetime) -> Copy:
    etag = page_etag(page_tag(page.board), limit, None)
    cache = etag_headers(etag)
    return page_copy(page.board.version, fresh_until(page.board, now, countdown=False), etag,
                     page.model_dump_json(), {"Content-Type": JSON} | cache, cache)


def _address(invite: Invite | None) -> str:
    """What a web page names besides the board: the address racers use, and the join code."""
    if invite is None:
        return ""
    return invite.endpoint + (f" {invite.code}" if invite.code else "")


def keeping_after_pushes(service: LeaderboardService,
                         not_kept: Callable[[str, DomainError], None]) -> StandingsKeeper:
    """What keeps a board's standings after a push improves it (the push function's): its JSON
    pages of :data:`.kept.PUSHED_LIMITS` entries, rendered for the version the push made from
    the push's own read of the board, and kept (in the table, for every container of the pull
    function); ``not_kept`` is told of an error that kept them from being kept (their first
    reader renders them instead)."""
    from ..service import StandingsKeeper

    def keep(stored: StoredBoard, entries: list[Entry]) -> None:
        board_id = stored.board.board_id
        try:
            standings_of(service).renew(board_id, PUSHED_LIMITS, (stored, entries))
        except DomainError as error:
            not_kept(board_id, error)

    return StandingsKeeper(max(PUSHED_LIMITS), keep)


def renew_after_change(service: LeaderboardService, board: str) -> DomainError | None:
    """After a write that changed a board (the ``board`` of its path, as sent), its JSON pages of
    :data:`.kept.PUSHED_LIMITS` entries rendered for the version it made and kept (in the table,
    for every container of the pull function); the error that kept them from being kept, if
    any (their first reader renders them instead)."""
    try:
        standings_of(service).renew(segment(board), PUSHED_LIMITS)
    except DomainError as error:
        return error
    return None


def _board_html(page: BoardPage, etag: str, invite: Invite, *, screen: bool, now: datetime,
                seasons: Sequence[SeasonLink]) -> str:
    from .. import web

    url = invite.join_url if invite.code else invite.endpoint + web.board_path(page.board.board_id)
    return web.board_page(page, etag, screen=screen, now=now, url=url, endpoint=invite.endpoint,
                          qr_svg=web.qr_svg(url) if screen else "", join_code=invite.code,
                          seasons=seasons)


_kept: WeakKeyDictionary[LeaderboardService, Standings] = WeakKeyDictionary()
_kept_lock = threading.Lock()


def standings_of(service: LeaderboardService) -> Standings:
    """The copies this process keeps for the service's board (one set per service: two boards
    in one process, as in tests, never share copies)."""
    standings = _kept.get(service)
    if standings is None:
        with _kept_lock:
            standings = _kept.setdefault(service, Standings(service))
    return standings
