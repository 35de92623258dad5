"""The standings a board shows, kept as the bytes that answer them.

A board's top page — ``GET /boards/{board}`` (JSON), ``GET /boards/{board}/view`` (its web page)
and ``/view?screen=1`` (the big screen) — is rendered once per board version and kept, encoded,
in the process that rendered it. Every later read of that page makes one small read of the
board's version (its SQLite row, or one consistent DynamoDB ``GetItem`` of the board item) and,
while the version is the one the copy was rendered from, answers the copy's bytes as they are,
or ``304 Not Modified`` when the client's ``If-None-Match`` names its ETag: no entry is read,
nothing is parsed, validated or encoded again. The resolver (:class:`.app.BoardResolver`)
answers such reads before Powertools routes them, and ``drboard serve`` before it even builds an
API Gateway event; a read the copies cannot answer (another page, a cursor, a board that changed)
goes through the routes, which render the page and keep it (:meth:`Standings.copy`).

Where the copies live, and why there: in each process (``drboard serve``, the embedded board)
and in each warm Lambda container, keyed by the board and the page asked for, each labelled with
the version it was rendered from. The label is compared with the board's version at every read,
so a copy is never answered for a newer version, whoever made it (a push in another container,
another process writing the same SQLite file); a version changes with every push that changes
the standings and with every organiser's change (a season taking the board in or letting it go,
too: its page links to them), in the same write. Copies are not written
beside the board by the push: a page depends on the request too (the web page names the address
the browser used and, on ``serve``, the join code), the big screen of a large board would not fit
in a DynamoDB item, every writer (pushes, organisers, moderation, rechecks) would have to write
them in its transaction, and a push would pay for pages no one may read. A container renders a
version once; in front of many containers the CDN (see template.yaml) keeps viewers off them.

A page also depends on the clock: the board opens and closes at set times (its status, and
whether designs show), and the web page counts down to that moment. A copy is kept until the
next of these moments only, and a web page showing a countdown for at most
:data:`COUNTDOWN_REFRESH_S` (the page's script counts down between two copies).
"""

from __future__ import annotations

import re
import threading
from collections import OrderedDict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from http import HTTPStatus
from typing import TYPE_CHECKING, Literal, NamedTuple
from urllib.parse import parse_qsl, unquote
from weakref import WeakKeyDictionary

from ..board_window import next_change
from ..models.domain import MAX_PAGE
from ..views import page_tag
from .responses import HTML, PAGE_HEADERS, etag_headers, names_etag, page_etag, page_policy

if TYPE_CHECKING:
    from ..models.seasons import SeasonLink
    from ..models.views import BoardPage, BoardView
    from ..service import LeaderboardService
    from ..web import Invite

DEFAULT_LIMIT = 100
MAX_SEGMENT_CHARS = 256  # a board id, percent-encoded (the routes' own bound)
#: How many pages a process keeps (a board's JSON, web page and big screen, at a few sizes).
KEPT_PAGES = 64
#: A web page counting down to its board's opening or closing is rendered again this often.
COUNTDOWN_REFRESH_S = 30
JSON = "application/json"
#: What Powertools' router accepts as one path segment: a path it would not route is not ours.
_SEGMENT = re.compile(r"[-._~()'!*:@,;=+&$%<> \[\]{}|^\w]+")
_LIMIT = re.compile(r"[1-9][0-9]{0,2}")
_SCREEN = {"1": True, "true": True, "0": False, "false": False}

Kind = Literal["json", "view", "screen"]


class Wanted(NamedTuple):
    """A board's top page, as a request asks for it."""

    board_id: str
    kind: Kind
    limit: int

    @property
    def html(self) -> bool:
        return self.kind != "json"


def wanted(method: str, path: str, query: str) -> Wanted | None:
    """The board page a request asks for, if it is one a kept copy may answer: a GET of a
    board's JSON, web page or big screen, with no cursor, and with every parameter in the one
    form the routes would take in the same way (anything else goes through the routes)."""
    if method != "GET" or not path.startswith("/boards/"):
        return None
    segment, kind = path[8:], "json"
    if segment.endswith("/view"):
        segment, kind = segment[:-5], "view"
    if len(segment) > MAX_SEGMENT_CHARS or not _SEGMENT.fullmatch(segment):
        return None
    limit, screen, seen = DEFAULT_LIMIT, False, set()
    for name, value in parse_qsl(query, keep_blank_values=True) if query else ():
        if name in seen:
            return None
        seen.add(name)
        if name == "limit":
            if not _LIMIT.fullmatch(value) or int(value) > MAX_PAGE:
                return None
            limit = int(value)
        elif name == "cursor" and value:
            return None
        elif name == "screen" and kind == "view":
            if value not in _SCREEN:
                return None
            screen = _SCREEN[value]
    if screen:
        kind = "screen"
        if limit == DEFAULT_LIMIT:
            limit = MAX_PAGE  # the big screen scrolls through the whole board
    return Wanted(unquote(segment), kind, limit)  # type: ignore[arg-type]


@dataclass(frozen=True)
class Copy:
    """One page as it answers: its bytes (and text, for an API Gateway answer), its headers for
    200 and for 304, the board version it was rendered from, and until when it holds."""

    version: int
    fresh_until: datetime | None
    etag: str
    text: str
    body: bytes
    headers: dict[str, str]
    not_modified_headers: dict[str, str]
    #: The same headers as ASGI wants them (lower-case bytes, Content-Length included).
    raw_headers: list[tuple[bytes, bytes]] = field(repr=False)
    raw_not_modified_headers: list[tuple[bytes, bytes]] = field(repr=False)

    def matches(self, if_none_match: str | None) -> bool:
        """Whether the client's If-None-Match names this copy (a weak comparison: a CDN that
        compresses the page hands it on as ``W/"..."``)."""
        return names_etag(if_none_match, self.etag)


def _raw(headers: Mapping[str, str], length: int) -> list[tuple[bytes, bytes]]:
    raw = [(name.lower().encode("latin-1"), value.encode("latin-1")) for name, value in headers.items()]
    return [*raw, (b"content-length", str(length).encode())]


def _copy(version: int, fresh_until: datetime | None, etag: str, text: str,
          headers: dict[str, str], not_modified: dict[str, str]) -> Copy:
    body = text.encode("utf-8")
    return Copy(version, fresh_until, etag, text, body, headers, not_modified,
                _raw(headers, len(body)), _raw(not_modified, 0))


def fresh_until(board: BoardView, now: datetime, *, countdown: bool) -> datetime | None:
    """Until when a page of the board rendered ``now`` holds, its version unchanged: the board's
    next opening or closing (None: never), and a countdown's refresh."""
    change = next_change(board)
    if change is not None and countdown:
        return min(change, now + timedelta(seconds=COUNTDOWN_REFRESH_S))
    return change


class Standings:
    """The copies of one service's board pages kept in this process (thread-safe; a page being
    rendered is rendered once, the other readers of it waiting for it)."""

    def __init__(self, service: LeaderboardService, size: int = KEPT_PAGES) -> None:
        self.service = service
        self.size = size
        self._copies: OrderedDict[tuple[Wanted, Invite | None], Copy] = OrderedDict()
        self._lock = threading.Lock()
        self._rendering: dict[tuple[Wanted, Invite | None], threading.Lock] = {}

    def kept(self, wanted: Wanted, invite: Invite | None = None) -> Copy | None:
        """The copy of the page for the board's version now, if one is kept: one read of the
        version, and nothing else."""
        key = (wanted, invite if wanted.html else None)
        with self._lock:
            copy = self._copies.get(key)
            if copy is not None:
                self._copies.move_to_end(key)
        if copy is None or self.service.board_version(wanted.board_id) != copy.version:
            return None
        if copy.fresh_until is not None and self.service.clock() >= copy.fresh_until:
            return None
        return copy

    def copy(self, wanted: Wanted, invite: Invite | None = None) -> Copy:
        """The page: the kept copy for the board's version now, else rendered and kept. The
        service's errors (no such board) are raised as they are."""
        key = (wanted, invite if wanted.html else None)
        kept = self.kept(wanted, invite)
        if kept is not None:
            return kept
        with self._lock:
            rendering = self._rendering.setdefault(key, threading.Lock())
        with rendering:
            kept = self.kept(wanted, invite)
            if kept is not None:
                return kept
            copy = self._render(wanted, invite)
            with self._lock:
                self._copies[key] = copy
                self._copies.move_to_end(key)
                while len(self._copies) > self.size:
                    self._copies.popitem(last=False)
                self._rendering.pop(key, None)
        return copy

    def _render(self, wanted: Wanted, invite: Invite | None) -> Copy:
        page = self.service.board_page(wanted.board_id, limit=wanted.limit, cursor=None)
        now = self.service.clock()
        if not wanted.html:
            etag = page_etag(page_tag(page.board), wanted.limit, None)
            cache = etag_headers(etag)
            return _copy(page.board.version, fresh_until(page.board, now, countdown=False), etag,
                         page.model_dump_json(), {"Content-Type": JSON} | cache, cache)
        assert invite is not None
        etag = page_etag(f"{wanted.kind}.{page_tag(page.board)}", wanted.limit, None)
        html = _board_html(page, etag, invite, screen=wanted.kind == "screen", now=now,
                           seasons=self.service.board_seasons(wanted.board_id))
        headers = {"Content-Type": HTML} | PAGE_HEADERS | page_policy(live=True) | etag_headers(etag)
        return _copy(page.board.version, fresh_until(page.board, now, countdown=True), etag, html,
                     headers, headers)


def _board_html(page: BoardPage, etag: str, invite: Invite, *, screen: bool, now: datetime,
                seasons: Sequence[SeasonLink]) -> str:
    from .. import web

    url = invite.join_url if invite.code else invite.endpoint + web.board_path(page.board.board_id)
    return web.board_page(page, etag, screen=screen, now=now, url=url, endpoint=invite.endpoint,
                          qr_svg=web.qr_svg(url) if screen else "", join_code=invite.code,
                          seasons=seasons)


class Answer(NamedTuple):
    """A kept copy's answer to one request."""

    status: int
    copy: Copy

    @property
    def headers(self) -> dict[str, str]:
        return self.copy.headers if self.status == HTTPStatus.OK else self.copy.not_modified_headers

    @property
    def raw_headers(self) -> list[tuple[bytes, bytes]]:
        return (self.copy.raw_headers if self.status == HTTPStatus.OK
                else self.copy.raw_not_modified_headers)

    @property
    def text(self) -> str:
        return self.copy.text if self.status == HTTPStatus.OK else ""

    @property
    def body(self) -> bytes:
        return self.copy.body if self.status == HTTPStatus.OK else b""


def answer(copy: Copy, if_none_match: str | None) -> Answer:
    return Answer(HTTPStatus.NOT_MODIFIED if copy.matches(if_none_match) else HTTPStatus.OK, copy)


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


def origin_of(headers: Mapping[str, str], domain: str | None) -> str:
    """The origin a client used: its Host (API Gateway's domain name without one), https
    behind API Gateway's ``X-Forwarded-Proto``."""
    host = headers.get("host") or domain or "localhost"
    scheme = headers.get("x-forwarded-proto", "http").split(",")[0].strip()
    return f"{scheme}://{host}"


def header_values(raw: Iterable[tuple[bytes, bytes]], *names: bytes) -> dict[bytes, str]:
    """The named headers of an ASGI request (lower-case names), a repeated one's values joined."""
    found: dict[bytes, str] = {}
    for name, value in raw:
        name = name.lower()
        if name in names:
            text = value.decode("latin-1")
            found[name] = f"{found[name]},{text}" if name in found else text
    return found
