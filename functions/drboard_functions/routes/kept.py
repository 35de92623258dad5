"""A board's top page kept as the bytes that answer it: which page a request asks for
(:func:`wanted`), a kept copy (:class:`Copy`) and its answer (:func:`answer`), the copies a
process keeps beside those its store keeps (:class:`KeptPages`), and racers' result cards drawn
from a kept page (:class:`KeptCards`).

No model, no Powertools and no service here: the pull function answers a kept page with this
module and the store's page shelf alone (:func:`event_answer`), and the card function a card
drawn from one (:func:`card_event_answer`), before either loads the resolver, pydantic or any
route. Rendering a page, and keeping it, is :mod:`.standings`' work.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from datetime import UTC, datetime
from http import HTTPStatus
from typing import TYPE_CHECKING, Any, Generic, Literal, NamedTuple, TypeVar
from urllib.parse import parse_qsl, unquote

from ..cursors import MAX_PAGE
from ..errors import StoreError
from ..stores.pages import StoredPage
from .headers import PNG, READ_CORS, SVG, SVG_POLICY, card_etag, card_headers, names_etag, origin_of

if TYPE_CHECKING:
    from ..stores.pages import PageShelf

DEFAULT_LIMIT = 100
#: The JSON pages a push renders and keeps for the board version it makes (in the cloud): the
#: page `drboard pull` asks for (its default ``--top``) and the API's default page.
PUSHED_LIMITS = (25, DEFAULT_LIMIT)
MAX_SEGMENT_CHARS = 256  # a board id, percent-encoded (the routes' own bound)
#: How many pages a process keeps (a board's JSON, web page and big screen, at a few sizes).
KEPT_PAGES = 64
#: What Powertools' router accepts as one path segment: a path it would not route is not ours.
_SEGMENT = re.compile(r"[-._~()'!*:@,;=+&$%<> \[\]{}|^\w]+")
_LIMIT = re.compile(r"[1-9][0-9]{0,2}")
_SCREEN = {"1": True, "true": True, "0": False, "false": False}

Kind = Literal["json", "view", "screen"]
CardKind = Literal["svg", "png"]
_CARD_FILES: dict[str, CardKind] = {"card.svg": "svg", "card.png": "png"}
Clock = Callable[[], datetime]
K = TypeVar("K")
V = TypeVar("V")


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


class Copy(NamedTuple):
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
    raw_headers: list[tuple[bytes, bytes]]
    raw_not_modified_headers: list[tuple[bytes, bytes]]
    #: A binary body (a card's PNG): ``text`` is its base64, as API Gateway carries it.
    binary: bool = False

    def matches(self, if_none_match: str | None) -> bool:
        """Whether the client's If-None-Match names this copy (a weak comparison: a CDN that
        compresses the page hands it on as ``W/"..."``)."""
        return names_etag(if_none_match, self.etag)

    def holds(self, version: int | None, now: datetime) -> bool:
        """Whether the copy still shows the board: its version, and not past its moment."""
        return version == self.version and (self.fresh_until is None or now < self.fresh_until)


def page_copy(version: int, fresh_until: datetime | None, etag: str, text: str,
              headers: dict[str, str], not_modified: dict[str, str]) -> Copy:
    body = text.encode("utf-8")
    return Copy(version, fresh_until, etag, text, body, headers, not_modified,
                _raw(headers, len(body)), _raw(not_modified, 0))


def card_copy(page: Copy, svg: str, kind: CardKind, draw: Callable[[str], bytes]) -> Copy:
    """A result card as the card routes answer it (see ``routes.cards``), drawn from ``svg``,
    held while the page it was drawn from holds."""
    etag = card_etag(svg, kind)
    headers = card_headers(etag)
    if kind == "svg":
        return page_copy(page.version, page.fresh_until, etag, svg,
                         headers | SVG_POLICY | {"Content-Type": SVG}, headers)
    png = draw(svg)
    ok = headers | {"Content-Type": PNG}
    return Copy(page.version, page.fresh_until, etag, base64.b64encode(png).decode("ascii"), png,
                ok, headers, _raw(ok, len(png)), _raw(headers, 0), binary=True)


def _raw(headers: Mapping[str, str], length: int) -> list[tuple[bytes, bytes]]:
    raw = [(name.lower().encode("latin-1"), value.encode("latin-1")) for name, value in headers.items()]
    return [*raw, (b"content-length", str(length).encode())]


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


def lambda_answer(kept: Answer, origin: str | None) -> dict[str, Any]:
    """A kept copy's answer as an API Gateway (HTTP API) proxy answer, with the reads' CORS
    headers when the request named its origin."""
    headers = kept.headers | READ_CORS if origin else kept.headers
    binary = kept.copy.binary and kept.status == HTTPStatus.OK
    return {"statusCode": int(kept.status), "body": kept.text, "isBase64Encoded": binary,
            "headers": headers, "cookies": []}


def copy_key(page: Wanted, address: str) -> tuple[Wanted, str]:
    """What a process keeps a copy of the page under: a web page for the address it names."""
    return page, address if page.html else ""


def shelf_key(page: Wanted, address: str) -> str:
    """The page's key on a store's shelf: its kind and size, and for a web page the address it
    names (its links and share card are absolute)."""
    name = f"{page.kind}#{page.limit}"
    if page.html:
        name += "#" + hashlib.sha256(address.encode("utf-8")).hexdigest()[:16]
    return name


class Recent(Generic[K, V]):
    """The ``size`` values last read or put, by key (thread-safe): the oldest go first."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._values: OrderedDict[K, V] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: K) -> V | None:
        with self._lock:
            value = self._values.get(key)
            if value is not None:
                self._values.move_to_end(key)
            return value

    def put(self, key: K, value: V) -> None:
        with self._lock:
            self._values[key] = value
            self._values.move_to_end(key)
            while len(self._values) > self.size:
                self._values.popitem(last=False)


class KeptPages:
    """The pages one process keeps (thread-safe, the most recently read ``size`` of them), each
    checked against the board's version at every read; and, when the store keeps pages too (its
    ``shelf``), the page another process kept, read with the board's version in one read.

    ``address`` tells apart the copies of one web page rendered for different addresses (the
    address the browser used, and on `drboard serve` the join code); a JSON page has none."""

    def __init__(self, version: Callable[[str], int | None], shelf: PageShelf | None,
                 clock: Clock, size: int = KEPT_PAGES) -> None:
        self.version = version
        self.shelf = shelf
        self.clock = clock
        self._copies: Recent[tuple[Wanted, str], Copy] = Recent(size)

    def kept(self, page: Wanted, address: str = "") -> Copy | None:
        """The copy of the page for the board's version now, if one is kept: one read of the
        version (and of the shelf's page, when this process holds none for that version)."""
        name = copy_key(page, address)
        copy = self._copies.get(name)
        if copy is not None and copy.holds(self.version(page.board_id), self.clock()):
            return copy
        if self.shelf is None:
            return None
        version, stored = self.shelf.page(page.board_id, shelf_key(page, address))
        if stored is None:
            return None
        fresh_until = (datetime.fromtimestamp(stored.fresh_until, UTC)
                       if stored.fresh_until is not None else None)
        copy = page_copy(stored.version, fresh_until, stored.etag, stored.text, stored.headers,
                         stored.not_modified_headers)
        if not copy.holds(version, self.clock()):
            return None
        self._copies.put(name, copy)
        return copy

    def held(self, page: Wanted, address: str = "") -> Copy | None:
        """The copy of the page this process holds, whatever its version (nothing is read)."""
        return self._copies.get(copy_key(page, address))

    def keep(self, page: Wanted, address: str, copy: Copy) -> None:
        """Keep a page just rendered, here and on the store's shelf."""
        self._copies.put(copy_key(page, address), copy)
        if self.shelf is not None:
            self.shelf.keep(page.board_id, shelf_key(page, address), _stored(copy))

    def keep_all(self, board_id: str, pages: Sequence[tuple[Wanted, Copy]]) -> None:
        """Keep the pages of a board a change rendered for the version it made (no web page:
        they have no address), here and on the store's shelf, in one write."""
        for page, copy in pages:
            self._copies.put(copy_key(page, ""), copy)
        if self.shelf is not None:
            self.shelf.keep_all(board_id, [(shelf_key(page, ""), _stored(copy))
                                           for page, copy in pages])


def _stored(copy: Copy) -> StoredPage:
    fresh_until = copy.fresh_until.timestamp() if copy.fresh_until is not None else None
    return StoredPage(copy.version, fresh_until, copy.etag, copy.headers,
                      copy.not_modified_headers, copy.text)


class WantedCard(NamedTuple):
    """A racer's result card, as a request asks for it."""

    board_id: str
    racer: str
    kind: CardKind


def wanted_card(method: str, path: str, query: str) -> WantedCard | None:
    """The card a request asks for, if it is one a kept page may draw: a GET of a racer's card
    on a board, as SVG or PNG, with no query (anything else goes through the routes)."""
    if method != "GET" or query or not path.startswith("/boards/"):
        return None
    parts = path[8:].split("/")
    if len(parts) != 4 or parts[1] != "racers" or parts[3] not in _CARD_FILES:
        return None
    board, racer = parts[0], parts[2]
    if any(len(segment) > MAX_SEGMENT_CHARS or not _SEGMENT.fullmatch(segment)
           for segment in (board, racer)):
        return None
    return WantedCard(unquote(board), unquote(racer), _CARD_FILES[parts[3]])


class KeptCards:
    """Racers' result cards drawn from their board's standings as kept for its version now (the
    page of :data:`DEFAULT_LIMIT` entries the push kept): no model, no route, no read but the
    page's. A card is drawn once per page and kind, and held in this process while its page
    holds; a racer not on that page is the routes' to draw."""

    def __init__(self, pages: KeptPages, draw: Callable[[str], bytes], size: int = KEPT_PAGES) -> None:
        self.pages = pages
        self.draw = draw
        self._cards: Recent[tuple[str, str, CardKind], tuple[str, Copy]] = Recent(size)

    def kept(self, card: WantedCard) -> Copy | None:
        page = self.pages.kept(Wanted(card.board_id, "json", DEFAULT_LIMIT))
        if page is None:
            return None
        from drboard_assembler.aliases import alias_key

        name = (card.board_id, alias_key(card.racer), card.kind)
        held = self._cards.get(name)
        if held is not None and held[0] == page.etag:
            return held[1]
        from .. import cards

        content = cards.racer_card_on_page(json.loads(page.text), card.racer)
        if content is None:
            return None
        copy = card_copy(page, cards.racer_svg(content), card.kind, self.draw)
        self._cards.put(name, (page.etag, copy))
        return copy


def event_answer(event: Mapping[str, Any], pages: KeptPages) -> dict[str, Any] | None:
    """The answer to an API Gateway (HTTP API) event from a kept page, if it asks for one that
    is kept for the board as it is now; None: the routes answer it. A store that cannot be read
    just now is the routes' to answer too (they say so, 503)."""
    page = wanted(*_request_line(event))
    if page is None:
        return None
    headers: Mapping[str, str] = event.get("headers") or {}
    address = origin_of(headers, (event.get("requestContext") or {}).get("domainName")) if page.html else ""
    try:
        copy = pages.kept(page, address)
    except StoreError:
        return None
    return _answered(copy, headers)


def card_event_answer(event: Mapping[str, Any], cards: KeptCards) -> dict[str, Any] | None:
    """The answer to an API Gateway (HTTP API) event from a card drawn from a kept page, if it
    asks for one (see :class:`KeptCards`); None: the routes answer it."""
    card = wanted_card(*_request_line(event))
    if card is None:
        return None
    try:
        copy = cards.kept(card)
    except StoreError:
        return None
    return _answered(copy, event.get("headers") or {})


def _request_line(event: Mapping[str, Any]) -> tuple[str, str, str]:
    """An event's method, path and query string; a request with a body asks for no kept copy
    (its method is given as "", which none takes)."""
    if event.get("body"):
        return "", "", ""
    http = (event.get("requestContext") or {}).get("http") or {}
    return (str(http.get("method", "")), str(event.get("rawPath") or ""),
            str(event.get("rawQueryString") or ""))


def _answered(copy: Copy | None, headers: Mapping[str, str]) -> dict[str, Any] | None:
    if copy is None:
        return None
    return lambda_answer(answer(copy, headers.get("if-none-match")), headers.get("origin"))
