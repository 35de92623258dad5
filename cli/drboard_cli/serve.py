"""`drboard serve`: the Lambda functions' own resolvers behind a small HTTP server.

Each HTTP request becomes an API Gateway HTTP API (v2) event for the same routes the cloud board
runs, so an event laptop hosts exactly the board that `sam deploy` would.

The organisers' routes (tag ``admin``: create, change, close, delete, restore, moderate, audit,
export, import) are answered only to the computer that runs `serve` (a loopback address): in the
cloud, IAM decides who may call them; here, the organiser is whoever sits at the serving laptop.
Anyone else on the network gets 403 ``NotAuthorized`` before the request is even parsed. The
address is the connection's own; a forwarding header cannot claim loopback. (Behind a reverse
proxy on the same computer every request would look local: do not put one in front of `serve`.)

``GET /boards/{board}/events`` streams the board's changes as Server-Sent Events (answered here:
the cloud board's pages poll with ``If-None-Match`` instead): an ``event: board`` whose data is the
board's page tag each time the standings, the settings or the status change, ``missing`` while
no board has that id yet.

Racers on the network sign in with the join code `serve` prints and the big screen shows
(``POST /join``, answered here and not by the routes; ``GET /join?code=…``, where the screen's QR
code leads, is a page saying the command): each gets a token of their own, sent as a bearer
token, which this server turns into the caller of the request (see :mod:`drboard_cli.joins`).
Unsigned pushes are refused. The pages are told the board's network address and the code
(:class:`drboard_functions.web.Invite`), so a screen opened as ``localhost`` on the serving
laptop still shows what the racers' laptops must type.

The log says what happened for people: who pushed which model, its time and rank, who joined,
what the organiser changed, and every refusal; the pages' polls are left out (``log_requests``
adds a plain line per request).

The HTTP side is uvicorn (h11): keep-alive without Nagle's delay, a listen backlog, idle
connections let go (also one that connects and never finishes a request), graceful shutdown.
Each request's resolver call runs in a small thread pool, each with resolvers of its own, so a
slow one holds neither the server loop nor the other requests; an event stream holds no thread.
The embedded board takes one write at a time: a push to it is answered on the server's loop while
no other process is writing the board's file (a hop to another thread would cost more than the
push's own work, as the threads take turns at the interpreter), and waits its turn in a thread of
its own when one is.
"""

from __future__ import annotations

import asyncio
import base64
import ipaddress
import json
import queue
import re
import socket
import sys
import threading
import time
import uuid
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple
from urllib.parse import parse_qsl, unquote, urlsplit

import uvicorn
from drboard_functions.errors import (
    BoardNotFound,
    DomainError,
    InvalidQuery,
    NotAuthorized,
    TooSoon,
)
from drboard_functions.identity import LOCAL_ORGANISER, Caller, SignIn
from drboard_functions.routes.app import CORS
from drboard_functions.routes.headers import header_values
from drboard_functions.routes.kept import answer, wanted
from drboard_functions.routes.standings import standings_of
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore
from pydantic import ValidationError
from rich.console import Console
from uvicorn.protocols.http.h11_impl import H11Protocol

from .joins import JoinDesk, JoinRequest, TooManyJoins, WrongCode

if TYPE_CHECKING:
    from aws_lambda_powertools.event_handler import APIGatewayHttpResolver
    from drboard_functions.web import Invite

MAX_BODY_BYTES = 1024 * 1024  # the routes apply the record's own, smaller bound
STREAM_POLL_S = 0.5  # how often an event stream looks at its board (one small SQLite read)
#: A stream pings this often, so a page notices a lost server within a few seconds.
STREAM_KEEPALIVE_S = 2.0
#: An idle keep-alive connection (a browser between two polls), or one that does not finish sending
#: a request, is closed after this long; stopping the server never waits on a client for long.
IDLE_CONNECTION_S = 5.0
MAX_STREAMS = 64
LISTEN_BACKLOG = 1024
RESOLVER_THREADS = 8
MAX_CONNECTIONS = 1000  # open connections and requests in flight; more are answered 503
SHUTDOWN_GRACE_S = 30.0  # how long stopping waits for requests in flight
_EVENTS_PATH = re.compile(r"^/boards/([^/]+)/events$")
_PUSH_PATH = re.compile(r"^/boards/([^/]+)/submissions$")

_log = Console(stderr=True, highlight=False)
#: Whether the log goes to a terminal (rich's colours) or a file (plain lines): asked once.
_LOG_TO_TERMINAL = _log.is_terminal


@dataclass
class LocalContext:
    """What the resolvers read of a Lambda context."""

    function_name: str = "drboard-serve"
    memory_limit_in_mb: int = 512
    invoked_function_arn: str = "arn:aws:lambda:local:000000000000:function:drboard-serve"
    aws_request_id: str = ""


def http_event(method: str, target: str, headers: dict[str, str], body: bytes,
               client_ip: str) -> dict[str, Any]:
    parts = urlsplit(target)
    now = time.time()
    headers = {name.lower(): value for name, value in headers.items()}
    return {
        "version": "2.0",
        "routeKey": "$default",
        "rawPath": parts.path or "/",
        "rawQueryString": parts.query,
        "headers": headers,
        "queryStringParameters": _query_parameters(parts.query),
        "requestContext": {
            "accountId": "000000000000",
            "apiId": "local",
            "domainName": headers.get("host", "localhost"),
            "http": {"method": method, "path": parts.path or "/", "protocol": "HTTP/1.1",
                     "sourceIp": client_ip, "userAgent": headers.get("user-agent", "")},
            "requestId": str(uuid.uuid4()),
            "routeKey": "$default",
            "stage": "$default",
            "time": time.strftime("%d/%b/%Y:%H:%M:%S +0000", time.gmtime(now)),
            "timeEpoch": int(now * 1000),
        },
        **_event_body(body),
    }


def _event_body(body: bytes) -> dict[str, Any]:
    """The body as API Gateway passes it: text as it is, anything else base64-encoded (which the
    routes then refuse, saying it is not UTF-8)."""
    try:
        return {"body": body.decode("utf-8") if body else None, "isBase64Encoded": False}
    except UnicodeDecodeError:
        return {"body": base64.b64encode(body).decode("ascii"), "isBase64Encoded": True}


def _query_parameters(query: str) -> dict[str, str] | None:
    """As API Gateway gives them: a repeated parameter's values joined with commas."""
    values: dict[str, list[str]] = {}
    for name, value in parse_qsl(query):
        values.setdefault(name, []).append(value)
    return {name: ",".join(items) for name, items in values.items()} or None


def is_loopback(address: str) -> bool:
    """Whether a client address is this computer's own (127.0.0.0/8, ::1, or IPv4-mapped)."""
    try:
        ip = ipaddress.ip_address(address.split("%", 1)[0])
    except ValueError:
        return False
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        ip = ip.ipv4_mapped
    return ip.is_loopback


class RouteMatcher:
    """Which requests go to a set of routes, by method and path (``{param}`` is one segment)."""

    def __init__(self, routes: set[tuple[str, str]]) -> None:
        self.rules = [(method, re.compile("^" + "/".join(map(_segment_pattern, path.split("/"))) + "$"))
                      for method, path in sorted(routes)]

    def matches(self, method: str, path: str) -> bool:
        return any(method == rule_method and rule.match(path) for rule_method, rule in self.rules)


def _segment_pattern(segment: str) -> str:
    return "[^/]+" if segment.startswith("{") and segment.endswith("}") else re.escape(segment)


def tagged_routes(app: APIGatewayHttpResolver, tag: str) -> set[tuple[str, str]]:
    """(METHOD, /path/{param}) of the resolver's routes with this OpenAPI tag."""
    paths = json.loads(app.get_openapi_json_schema())["paths"]
    return {(method.upper(), path) for path, operations in paths.items()
            for method, operation in operations.items() if tag in operation.get("tags", [])}


class BoardServer:
    """The board over HTTP. Binds at once; :meth:`serve_forever` serves until Ctrl-C or SIGTERM
    (or :meth:`shutdown` from another thread), then :meth:`server_close` lets go of everything."""

    def __init__(self, address: tuple[str, int], service: LeaderboardService,
                 desk: JoinDesk | None = None, *, log_requests: bool = False) -> None:
        from drboard_functions.routes import (
            ADMIN_TAG,
            admin_router,
            build_app,
            card_router,
            pull_router,
            push_router,
        )

        self.service = service
        self.desk = desk
        self.log_requests = log_requests
        self.sign_in = SignIn(kind="join-code" if desk else "none")
        # Powertools keeps the request being resolved in the resolver (the resolver instance, as
        # read below, and a class-wide slot it also writes): each request in flight takes a pair
        # of resolvers of its own from this pool, one for each thread that runs them. Other
        # computers are served by a resolver without the organiser routes at all; asking for one
        # of those is answered 403 rather than 404.
        self.resolvers: queue.SimpleQueue[_Resolvers] = queue.SimpleQueue()
        for _ in range(RESOLVER_THREADS):
            self.resolvers.put(_Resolvers(build_app(push_router, pull_router, card_router, admin_router),
                                          build_app(push_router, pull_router, card_router)))
        self.organiser_routes = RouteMatcher(tagged_routes(build_app(admin_router), ADMIN_TAG))
        self.standings = standings_of(service)
        # A board's version on the embedded board is one row of a local file: read on the
        # server's loop, a kept page costs no hop to a worker thread. (A DynamoDB table's is a
        # network call: it is read in the pool.)
        self.embedded = service.store if isinstance(service.store, SqliteStore) else None
        self.pool = ThreadPoolExecutor(RESOLVER_THREADS, thread_name_prefix="drboard-serve")
        # The embedded board takes one write at a time: a push is answered on the loop while the
        # file is free (``push_here``), else it waits its turn in one thread of its own, rather
        # than in SQLite's busy handler (which sleeps between its tries) in threads that contend
        # for the interpreter meanwhile. A DynamoDB table takes pushes at once, in the pool.
        self.writes = (ThreadPoolExecutor(1, thread_name_prefix="drboard-serve-push")
                       if self.embedded is not None else self.pool)
        self.open_streams = 0
        self.socket = _listening_socket(address)
        self.server_address: tuple[str, int] = self.socket.getsockname()[:2]
        #: The address racers reach the board at (the network's, not 0.0.0.0 or localhost);
        #: `drboard serve` sets it once it knows the port.
        self.public_url = f"http://{reachable_host(str(self.server_address[0]))}:{self.server_address[1]}"
        self.server = uvicorn.Server(uvicorn.Config(
            self, http=_TimedH11Protocol, loop="asyncio", lifespan="off", ws="none",
            proxy_headers=False,  # the peer's own address decides who is local, never a header
            server_header=False, log_config=None, access_log=False, backlog=LISTEN_BACKLOG,
            timeout_keep_alive=int(IDLE_CONNECTION_S), limit_concurrency=MAX_CONNECTIONS,
            timeout_graceful_shutdown=int(SHUTDOWN_GRACE_S)))
        self._stopped = threading.Event()

    # ---- the server's life ----------------------------------------------------------------------

    def serve_forever(self) -> None:
        """Serve until stopped. On the main thread, Ctrl-C and SIGTERM stop it gracefully (requests
        in flight are answered, event streams end) and are then raised again for the caller."""
        try:
            self.server.run(sockets=[self.socket])
        finally:
            self._stopped.set()

    def shutdown(self) -> None:
        """Stop :meth:`serve_forever` running on another thread, and wait for it."""
        self.server.should_exit = True
        self._stopped.wait()

    @property
    def stopping(self) -> bool:
        return self.server.should_exit

    def server_close(self) -> None:
        self.server.should_exit = True
        self.writes.shutdown(wait=True)  # a push still being written is written
        self.pool.shutdown(wait=True)
        self.socket.close()

    # ---- requests, as API Gateway events (synchronous: run in the pool) ------------------------

    def board_tag(self, board_id: str) -> str:
        """The board's page tag, or ``missing`` when there is no such board (yet)."""
        try:
            return self.service.board_tag(board_id)
        except BoardNotFound:
            return "missing"

    def handle_event(self, event: dict[str, Any]) -> dict[str, Any]:
        handled = self._handled(event)
        self._note(handled)
        return handled.result

    def push_here(self, event: dict[str, Any]) -> dict[str, Any] | None:
        """A push to the embedded board answered on the calling thread (the server's loop) if no
        other process is writing the board's file: None if one is (nothing was written; the push
        then waits its turn in the writer thread, where waiting holds up no other request)."""
        assert self.embedded is not None
        with self.embedded.without_waiting() as attempt:
            handled = self._handled(event)
        if attempt.met_writer:
            return None
        self._note(handled)
        return handled.result

    def _handled(self, event: dict[str, Any]) -> _Handled:
        from drboard_functions.routes import canonical_event

        event = canonical_event(event)
        http = event["requestContext"]["http"]
        local = is_loopback(http["sourceIp"])
        if event["rawPath"] == "/join" and http["method"] in ("GET", "POST"):
            return _Handled(self._join(event) if http["method"] == "POST" else self._join_page(event))
        if not local and self.organiser_routes.matches(http["method"], event["rawPath"]):
            return _Handled(_refused(NotAuthorized(
                "organiser requests are answered only on the computer running `drboard serve`; "
                f"this one came from {http['sourceIp']}")))
        # serve builds every event itself, so no client can claim an authorizer context
        caller = LOCAL_ORGANISER if local else self._racer(event["headers"])
        if caller is not None:
            event["requestContext"]["authorizer"] = {"lambda": caller._asdict()}
        resolvers = self.resolvers.get()
        try:
            result = _resolve(resolvers.local if local else resolvers.public, event, self.service,
                              self.sign_in, self.invite)
        finally:
            self.resolvers.put(resolvers)
        return _Handled(result, event, caller)

    def invite(self) -> Invite:
        """What the pages tell racers: this board's network address and its join code."""
        from drboard_functions.web import Invite

        return Invite(endpoint=self.public_url,
                      code=self.desk.current_code().code if self.desk else None)

    def _racer(self, headers: dict[str, str]) -> Caller | None:
        """The racer a request's bearer token signs in, or None."""
        token = _bearer(headers)
        return self.desk.caller(token) if self.desk is not None and token else None

    def _join(self, event: dict[str, Any]) -> dict[str, Any]:
        http = event["requestContext"]["http"]
        if self.desk is None:
            return _refused(NotAuthorized("this board takes no join codes"))
        try:
            request = JoinRequest.model_validate_json(event.get("body") or "")
        except ValidationError:
            return _refused(InvalidQuery('send {"code": "<the join code>"} as JSON; a join code '
                                         "is letters and digits, e.g. K7QM-3XWD"))
        try:
            joined = self.desk.join(request.code, client=http["sourceIp"],
                                    renewing=_bearer(event["headers"]))
        except WrongCode as wrong:
            self.say(f"a join from {http['sourceIp']} was refused: {wrong}")
            return _refused(NotAuthorized(str(wrong)))
        except TooManyJoins as many:
            self.say(f"joins from {http['sourceIp']} are held back: {many}")
            return _refused(TooSoon(str(many), many.retry_after_s))
        code = self.desk.current_code()
        self.say(f"a racer {'renewed their join' if joined.renewed else 'joined'} from "
                 f"{http['sourceIp']} ({joined.principal}; the code has joined {code.joins} of "
                 f"{code.max_joins})")
        return {"statusCode": 201, "headers": {"Content-Type": "application/json"},
                "body": joined.model_dump_json(), "isBase64Encoded": False}

    def _join_page(self, event: dict[str, Any]) -> dict[str, Any]:
        from drboard_functions.routes.headers import PAGE_HEADERS
        from drboard_functions.routes.responses import page_policy
        from drboard_functions.web import join_page

        return {"statusCode": 200, "isBase64Encoded": False,
                "headers": PAGE_HEADERS | page_policy() | {"Content-Type": "text/html; charset=utf-8"},
                "body": join_page(self.invite(), self.service.boards())}

    # ---- the log --------------------------------------------------------------------------------

    def say(self, line: str) -> None:
        _log_event(f"{time.strftime('%H:%M:%S')}  {line}")

    def _note(self, handled: _Handled) -> None:
        """Log what a request the routes answered did, for people; remember the alias a joined
        racer pushes as."""
        event, result, caller = handled.event, handled.result, handled.caller
        if event is None:  # answered before the routes, and said then
            return
        http = event["requestContext"]["http"]
        method, path, status = http["method"], event["rawPath"], int(result.get("statusCode", 200))
        who = _who(caller, http["sourceIp"])
        body = result.get("body") or ""
        pushed = method == "POST" and _PUSH_PATH.match(path)
        if pushed and status in (200, 201):
            receipt = json.loads(body)  # the receipt the routes just encoded: read, not checked
            if caller is not None and self.desk is not None and caller.principal.startswith("join:"):
                self.desk.note_alias(caller.principal, receipt["entry"]["racer"])
            self.say(_push_line(receipt) + ("" if caller is None or caller.principal == "local"
                                            else f"  [{http['sourceIp']}, {caller.principal}]"))
        elif method == "PUT" and path == "/me/alias" and status == 200:
            alias = json.loads(body).get("alias")
            if alias and caller is not None and self.desk is not None:
                self.desk.note_alias(caller.principal, str(alias))
            self.say(f"{who} holds the alias {alias}")
        elif status >= 400 and (method != "GET" or status >= 500):
            self.say(f"{method} {unquote(path)} by {who}: refused, {status} {_error_text(body)}")
        elif method not in ("GET", "HEAD", "OPTIONS") and status < 300:
            self.say(f"{who}: {method} {unquote(path)} done ({status})")

    # ---- ASGI -----------------------------------------------------------------------------------

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            return
        path = (scope.get("raw_path") or scope["path"].encode()).decode("latin-1")
        events = _EVENTS_PATH.match(path) if scope["method"] == "GET" else None
        if events:
            status = await self._stream(unquote(events[1]), receive, send)
        else:
            status = await self._answer(scope, path, receive, send)
        if self.log_requests:
            query = scope["query_string"].decode("latin-1")
            _log_request(f'{_client_ip(scope)} "{scope["method"]} {path}{"?" * bool(query)}{query}" '
                         f"{status}")

    async def _answer(self, scope: Scope, path: str, receive: Receive, send: Send) -> int:
        if scope["method"] == "GET":
            if self.embedded is not None:
                kept = self.kept_answer(scope, path)
            else:
                kept = await asyncio.get_running_loop().run_in_executor(
                    self.pool, self.kept_answer, scope, path)
            if kept is not None:
                status, headers, data = kept
                await send({"type": "http.response.start", "status": status, "headers": headers})
                await send({"type": "http.response.body", "body": data})
                return status
        try:
            body = await _request_body(scope, receive)
        except _BodyTooLarge:
            return await _reply_json(send, 413, "the request body is too large", close=True)
        except TimeoutError:
            return await _reply_json(send, 408, "the request body did not arrive in time", close=True)
        query = scope["query_string"].decode("latin-1")
        event = http_event(scope["method"], f"{path}?{query}" if query else path,
                           _header_dict(scope), body, _client_ip(scope))
        pushing = scope["method"] == "POST" and _PUSH_PATH.match(path)
        result = self.push_here(event) if pushing and self.embedded is not None else None
        if result is None:
            executor = self.writes if pushing else self.pool
            result = await asyncio.get_running_loop().run_in_executor(executor, self.handle_event, event)
        status, headers, data = _http_answer(result)
        await send({"type": "http.response.start", "status": status, "headers": headers})
        await send({"type": "http.response.body", "body": data})
        return status

    def kept_answer(self, scope: Scope, path: str) -> tuple[int, list[tuple[bytes, bytes]], bytes] | None:
        """The answer of a board page kept for the board's version now (see
        :mod:`drboard_functions.routes.standings`), if the request asks for one: no event, no
        resolver, one read of the version."""
        page = wanted("GET", path, scope["query_string"].decode("latin-1"))
        if page is None:
            return None
        found = header_values(scope["headers"], b"if-none-match", b"origin", b"content-length",
                              b"transfer-encoding")
        if b"transfer-encoding" in found or found.get(b"content-length", "0") != "0":
            return None  # a GET with a body goes the routes' way
        try:
            copy = self.standings.kept(page, self.invite() if page.html else None)
        except DomainError:  # the store is busy: the routes say so
            return None
        if copy is None:
            return None
        kept = answer(copy, found.get(b"if-none-match"))
        headers = kept.raw_headers
        if b"origin" in found:
            cors = CORS.to_dict(CORS.allowed_origin(found[b"origin"]))
            headers = headers + [(name.lower().encode("latin-1"), value.encode("latin-1"))
                                 for name, value in cors.items()]
        return int(kept.status), headers, kept.body

    async def _stream(self, board_id: str, receive: Receive, send: Send) -> int:
        """Server-Sent Events: the board's tag now, then each time it changes, until the client
        goes or the server stops."""
        if self.open_streams >= MAX_STREAMS:
            return await _reply_json(send, 503, "too many open event streams", {"retry-after": "5"})
        self.open_streams += 1
        gone = asyncio.ensure_future(_disconnect(receive))
        try:
            await send({"type": "http.response.start", "status": 200, "headers": [
                (b"content-type", b"text/event-stream"), (b"cache-control", b"no-cache"),
                (b"x-content-type-options", b"nosniff")]})
            await _more(send, b"retry: 2000\n\n")
            await self._follow(board_id, gone, send)
            await send({"type": "http.response.body", "body": b""})
        finally:
            gone.cancel()
            self.open_streams -= 1
        return 200

    async def _follow(self, board_id: str, gone: asyncio.Future[None], send: Send) -> None:
        loop = asyncio.get_running_loop()
        sent, quiet = None, 0.0
        while not self.stopping and not gone.done():
            tag = await loop.run_in_executor(self.pool, self.board_tag, board_id)
            if tag != sent:
                await _more(send, f"event: board\ndata: {tag}\n\n".encode())
                sent, quiet = tag, 0.0
            elif quiet >= STREAM_KEEPALIVE_S:
                await _more(send, b"event: ping\ndata: \n\n")
                quiet = 0.0
            await asyncio.wait([gone], timeout=STREAM_POLL_S)
            quiet += STREAM_POLL_S


class _Handled(NamedTuple):
    """A request's answer; for one the routes answered, its event as they saw it and its caller."""

    result: dict[str, Any]
    event: dict[str, Any] | None = None
    caller: Caller | None = None


@dataclass(frozen=True)
class _Resolvers:
    local: APIGatewayHttpResolver
    public: APIGatewayHttpResolver


def _resolve(app: APIGatewayHttpResolver, event: dict[str, Any], service: LeaderboardService,
             sign_in: SignIn, invite: Callable[[], Invite]) -> dict[str, Any]:
    # Every read of the request goes through the resolver instance: setting it there (before
    # resolve also writes the class-wide slot) keeps each resolver on its own request.
    context = LocalContext(aws_request_id=event["requestContext"]["requestId"])
    app.current_event = app._to_proxy_event(event)  # type: ignore[assignment]
    app.lambda_context = context  # type: ignore[assignment]
    app.append_context(service=service, sign_in=sign_in, invite=invite)
    return app.resolve(event, context)  # type: ignore[arg-type]


Scope = dict[str, Any]
Receive = Callable[[], Awaitable[dict[str, Any]]]
Send = Callable[[dict[str, Any]], Awaitable[None]]


class _BodyTooLarge(Exception):
    pass


def _listening_socket(address: tuple[str, int]) -> socket.socket:
    host, port = address
    family, kind, proto, _, where = socket.getaddrinfo(host or None, port, type=socket.SOCK_STREAM,
                                                       flags=socket.AI_PASSIVE)[0]
    # The protocol number matters: asyncio turns Nagle's algorithm off (TCP_NODELAY) only on
    # connections whose socket says IPPROTO_TCP, and an accepted socket copies its listener's.
    listener = socket.socket(family, kind, proto)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(where)
    listener.listen(LISTEN_BACKLOG)
    return listener


class _TimedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol, with its idle timeout also running before a request has arrived:
    uvicorn arms it only once a response is sent, so a client that connects and sends nothing
    (or half a request) would hold its connection for ever. A request's head must now arrive
    within the timeout of connecting, or of the last response."""

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)  # type: ignore[arg-type]
        self._head_due = self.loop.time() + self.timeout_keep_alive
        self._arm_head_timeout()

    def on_response_complete(self) -> None:
        self._head_due = self.loop.time() + self.timeout_keep_alive
        super().on_response_complete()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)  # which disarms the timeout
        if self.cycle is None or self.cycle.response_complete:  # still no complete request head
            self._arm_head_timeout()

    def _arm_head_timeout(self) -> None:
        if self.timeout_keep_alive_task is None and not self.transport.is_closing():
            self.timeout_keep_alive_task = self.loop.call_at(self._head_due,
                                                             self.timeout_keep_alive_handler)


def _bearer(headers: dict[str, str]) -> str | None:
    scheme, _, token = headers.get("authorization", "").partition(" ")
    return token.strip() if scheme.lower() == "bearer" and token.strip() else None


def _push_line(receipt: dict[str, Any]) -> str:
    """``Ada pushed ada-v7 to club-final: 9.120 s, rank 2 of 12, new best (+0.465 s)`` from a
    push's receipt (its JSON, read)."""
    from drboard_functions.display import gap, percent, seconds

    pushed, entry = receipt["submission"], receipt["entry"]
    result = (seconds(pushed["time_ms"]) if pushed["qualified"]
              else f"{percent(pushed['best_completion_pct'])} done, not qualified")
    outcome = ("already on the board" if receipt["status"] == "duplicate"
               else "new best" if receipt["improved"] else "not better than their best")
    if receipt["rank"] > 1 and entry.get("gap_ms") is not None:
        outcome += f", {gap(entry['gap_ms'])} to the leader"
    return (f"{entry['racer']} pushed {pushed['model_name']} to {receipt['board_id']}: {result}, "
            f"rank {receipt['rank']} of {receipt['participants']}, {outcome}")


def _who(caller: Caller | None, address: str) -> str:
    if caller is None:
        return f"an unsigned client at {address}"
    if caller.principal == LOCAL_ORGANISER.principal:
        return "the organiser (this computer)"
    return f"{caller.name or 'a racer'} at {address}, {caller.principal}"


def _error_text(body: str) -> str:
    try:
        answer = json.loads(body)
    except ValueError:
        return ""
    if not isinstance(answer, dict):
        return ""
    return f"{answer.get('error', '')}: {answer.get('message', '')}".strip(": ")


def _log_event(line: str) -> None:
    if _LOG_TO_TERMINAL:
        _log.out(line, highlight=False)
    else:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()


def reachable_host(host: str) -> str:
    """The address racers reach this computer at: for 0.0.0.0 (or ::), its own on the network;
    an IPv6 address in brackets, as a URL wants it."""
    if host not in ("0.0.0.0", "::"):
        return f"[{host}]" if ":" in host else host
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("10.254.254.254", 1))  # no packet is sent: this only picks a route
            return str(probe.getsockname()[0])
        except OSError:
            return socket.gethostname()


def _log_request(line: str) -> None:
    if _LOG_TO_TERMINAL:
        _log.out(line, style="dim", highlight=False)
    else:  # a log file: plain lines, at a hundredth of rich's cost per request
        sys.stderr.write(line + "\n")


def _client_ip(scope: Scope) -> str:
    client = scope.get("client")
    return str(client[0]) if client else ""


def _header_dict(scope: Scope) -> dict[str, str]:
    """The request's headers by lower-case name, a repeated one's values joined with commas."""
    headers: dict[str, str] = {}
    for raw_name, raw_value in scope["headers"]:
        name, value = raw_name.decode("latin-1").lower(), raw_value.decode("latin-1")
        headers[name] = f"{headers[name]},{value}" if name in headers else value
    return headers


async def _request_body(scope: Scope, receive: Receive) -> bytes:
    declared = next((value for name, value in scope["headers"] if name.lower() == b"content-length"), b"")
    if declared.isdigit() and int(declared) > MAX_BODY_BYTES:
        raise _BodyTooLarge
    body = bytearray()
    while True:
        async with asyncio.timeout(IDLE_CONNECTION_S):
            message = await receive()
        body += message.get("body", b"")
        if len(body) > MAX_BODY_BYTES:
            raise _BodyTooLarge
        if message["type"] != "http.request" or not message.get("more_body"):
            return bytes(body)


async def _disconnect(receive: Receive) -> None:
    """Returns once the client has gone (or the response is over)."""
    while (await receive())["type"] != "http.disconnect":
        pass


async def _more(send: Send, data: bytes) -> None:
    await send({"type": "http.response.body", "body": data, "more_body": True})


async def _reply_json(send: Send, status: int, message: str, headers: dict[str, str] | None = None,
                      *, close: bool = False) -> int:
    data = json.dumps({"message": message}).encode()
    fields = {"content-type": "application/json", "content-length": str(len(data)), **(headers or {})}
    if close:
        fields["connection"] = "close"
    await send({"type": "http.response.start", "status": status,
                "headers": [(name.encode(), value.encode()) for name, value in fields.items()]})
    await send({"type": "http.response.body", "body": data})
    return status


def _http_answer(result: dict[str, Any]) -> tuple[int, list[tuple[bytes, bytes]], bytes]:
    """An API Gateway (v2) answer as HTTP: status, headers and body bytes."""
    payload = result.get("body") or ""
    data = payload.encode("utf-8") if isinstance(payload, str) else bytes(payload)
    if result.get("isBase64Encoded"):
        data = base64.b64decode(data)
    fields = dict(result.get("headers") or {})
    for name, values in (result.get("multiValueHeaders") or {}).items():
        fields[name] = ", ".join(values)
    headers = [(name.lower().encode("latin-1"), str(value).encode("latin-1"))
               for name, value in fields.items() if name.lower() not in ("content-length", "connection")]
    headers += [(b"set-cookie", str(cookie).encode("latin-1")) for cookie in result.get("cookies") or ()]
    headers.append((b"content-length", str(len(data)).encode()))
    return int(result.get("statusCode", 200)), headers, data


def _refused(error: DomainError) -> dict[str, Any]:
    """The answer the routes would give the error (its status and headers from the one mapping)."""
    from drboard_functions.routes import refusal

    return refusal(error)

