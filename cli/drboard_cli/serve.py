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

Racers on the network sign in with the join code `serve` prints (``POST /join``, answered here
and not by the routes): each gets a token of their own, sent as a bearer token, which this server
turns into the caller of the request (see :mod:`drboard_cli.joins`). Unsigned pushes are refused.
"""

from __future__ import annotations

import ipaddress
import json
import re
import threading
import time
import uuid
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qsl, unquote, urlsplit

from drboard_functions.errors import DomainError, InvalidQuery, NotAuthorized
from drboard_functions.identity import LOCAL_ORGANISER, Caller, SignIn
from drboard_functions.service import LeaderboardService
from pydantic import ValidationError
from rich.console import Console

from .joins import JoinDesk, JoinRequest, WrongCode

if TYPE_CHECKING:
    from aws_lambda_powertools.event_handler import APIGatewayHttpResolver

MAX_BODY_BYTES = 1024 * 1024  # the routes apply the record's own, smaller bound
STREAM_POLL_S = 0.5  # how often an event stream looks at its board (one small SQLite read)
STREAM_KEEPALIVE_S = 15.0
IDLE_CONNECTION_S = 5.0
MAX_STREAMS = 64
_EVENTS_PATH = re.compile(r"^/boards/([^/]+)/events$")

_log = Console(stderr=True, highlight=False)


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
    return {
        "version": "2.0",
        "routeKey": "$default",
        "rawPath": parts.path or "/",
        "rawQueryString": parts.query,
        "headers": {name.lower(): value for name, value in headers.items()},
        "queryStringParameters": _query_parameters(parts.query),
        "requestContext": {
            "accountId": "000000000000",
            "apiId": "local",
            "domainName": headers.get("Host", "localhost"),
            "http": {"method": method, "path": parts.path or "/", "protocol": "HTTP/1.1",
                     "sourceIp": client_ip, "userAgent": headers.get("User-Agent", "")},
            "requestId": str(uuid.uuid4()),
            "routeKey": "$default",
            "stage": "$default",
            "time": time.strftime("%d/%b/%Y:%H:%M:%S +0000", time.gmtime(now)),
            "timeEpoch": int(now * 1000),
        },
        "body": body.decode("utf-8", errors="replace") if body else None,
        "isBase64Encoded": False,
    }


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


class BoardServer(ThreadingHTTPServer):
    daemon_threads = False  # on shutdown, let requests in flight finish: nothing is lost
    block_on_close = True

    def __init__(self, address: tuple[str, int], service: LeaderboardService,
                 desk: JoinDesk | None = None) -> None:
        from drboard_functions.routes import ADMIN_TAG, admin_router, build_app, pull_router, push_router

        super().__init__(address, _Handler)
        self.service = service
        self.desk = desk
        self.sign_in = SignIn(kind="join-code" if desk else "none")
        self.app = build_app(push_router, pull_router, admin_router)
        # Other computers are served by a resolver without the organiser routes at all; asking
        # for one of those is answered 403 rather than 404.
        self.public_app = build_app(push_router, pull_router)
        self.organiser_routes = RouteMatcher(tagged_routes(self.app, ADMIN_TAG))
        # One request at a time through the resolvers: they keep per-request context, and the
        # embedded SQLite board has a single connection.
        self.lock = threading.Lock()
        self.closing = threading.Event()  # tells the event streams to end
        self.streams = threading.BoundedSemaphore(MAX_STREAMS)

    def server_close(self) -> None:
        self.closing.set()
        super().server_close()

    def board_tag(self, board_id: str) -> str:
        """The board's page tag, or ``missing`` when there is no such board (yet)."""
        with self.lock:
            try:
                return self.service.board_tag(board_id)
            except DomainError:
                return "missing"

    def handle_event(self, event: dict[str, Any]) -> dict[str, Any]:
        from drboard_functions.routes import canonical_event

        event = canonical_event(event)
        http = event["requestContext"]["http"]
        local = is_loopback(http["sourceIp"])
        if http["method"] == "POST" and event["rawPath"] == "/join":
            return self._join(event.get("body") or "")
        if not local and self.organiser_routes.matches(http["method"], event["rawPath"]):
            return _refused(NotAuthorized(
                "organiser requests are answered only on the computer running `drboard serve`; "
                f"this one came from {http['sourceIp']}"))
        # serve builds every event itself, so no client can claim an authorizer context
        caller = LOCAL_ORGANISER if local else self._racer(event["headers"])
        if caller is not None:
            event["requestContext"]["authorizer"] = {"lambda": caller.model_dump()}
        app = self.app if local else self.public_app
        with self.lock:
            app.append_context(service=self.service, sign_in=self.sign_in)
            context = LocalContext(aws_request_id=event["requestContext"]["requestId"])
            return app.resolve(event, context)  # type: ignore[arg-type]


    def _racer(self, headers: dict[str, str]) -> Caller | None:
        """The racer a request's bearer token signs in, or None."""
        scheme, _, token = headers.get("authorization", "").partition(" ")
        if self.desk is None or scheme.lower() != "bearer" or not token.strip():
            return None
        return self.desk.caller(token.strip())

    def _join(self, body: str) -> dict[str, Any]:
        if self.desk is None:
            return _refused(NotAuthorized("this board takes no join codes"))
        try:
            request = JoinRequest.model_validate_json(body)
        except ValidationError:
            return _refused(InvalidQuery('send {"code": "<the join code>"} as JSON'))
        try:
            joined = self.desk.join(request.code)
        except WrongCode as wrong:
            return _refused(NotAuthorized(str(wrong)))
        return {"statusCode": 201, "headers": {"Content-Type": "application/json"},
                "body": joined.model_dump_json(), "isBase64Encoded": False}


def _refused(error: DomainError) -> dict[str, Any]:
    """The answer the routes would give the error (its status from the one mapping)."""
    from drboard_functions.routes import error_body, status_of

    return {"statusCode": int(status_of(error)), "headers": {"Content-Type": "application/json"},
            "body": error_body(error).model_dump_json(), "isBase64Encoded": False}


class _Handler(BaseHTTPRequestHandler):
    server: BoardServer
    protocol_version = "HTTP/1.1"
    # An idle keep-alive connection (a browser between two polls) is closed after this long,
    # so stopping the server never waits on a client for long.
    timeout = IDLE_CONNECTION_S

    def do_GET(self) -> None:
        self._dispatch()

    def do_POST(self) -> None:
        self._dispatch()

    def do_PUT(self) -> None:
        self._dispatch()

    def do_PATCH(self) -> None:
        self._dispatch()

    def do_DELETE(self) -> None:
        self._dispatch()

    def do_OPTIONS(self) -> None:
        self._dispatch()

    def _dispatch(self) -> None:
        events = _EVENTS_PATH.match(urlsplit(self.path).path) if self.command == "GET" else None
        if events:
            self._stream(unquote(events[1]))
            return
        length = int(self.headers.get("Content-Length") or 0)
        if length > MAX_BODY_BYTES:
            self._reply(413, {"content-type": "application/json"},
                        json.dumps({"message": "the request body is too large"}).encode())
            self.close_connection = True
            return
        body = self.rfile.read(length) if length else b""
        if self.server.closing.is_set():
            self.close_connection = True  # stopping: answer, then let the client go
        event = http_event(self.command, self.path, dict(self.headers.items()), body,
                           self.client_address[0])
        result = self.server.handle_event(event)
        payload = result.get("body") or ""
        data = payload.encode("utf-8") if isinstance(payload, str) else bytes(payload)
        if result.get("isBase64Encoded"):
            import base64

            data = base64.b64decode(data)
        headers = dict(result.get("headers") or {})
        for name, values in (result.get("multiValueHeaders") or {}).items():
            headers[name] = ", ".join(values)
        self._reply(int(result.get("statusCode", 200)), headers, data)

    def _stream(self, board_id: str) -> None:
        """Server-Sent Events: the board's tag now, then each time it changes, until the client
        goes or the server stops."""
        self.close_connection = True
        if not self.server.streams.acquire(blocking=False):
            self._reply(503, {"content-type": "application/json", "retry-after": "5"},
                        json.dumps({"message": "too many open event streams"}).encode())
            return
        try:
            self.send_response(200)
            for name, value in (("Content-Type", "text/event-stream"), ("Cache-Control", "no-cache"),
                                ("X-Content-Type-Options", "nosniff")):
                self.send_header(name, value)
            self.end_headers()
            self.wfile.write(b"retry: 2000\n\n")
            sent, quiet = None, 0.0
            while not self.server.closing.is_set():
                tag = self.server.board_tag(board_id)
                if tag != sent:
                    self.wfile.write(f"event: board\ndata: {tag}\n\n".encode())
                    sent, quiet = tag, 0.0
                elif quiet >= STREAM_KEEPALIVE_S:
                    self.wfile.write(b": keep-alive\n\n")
                    quiet = 0.0
                self.wfile.flush()
                self.server.closing.wait(STREAM_POLL_S)
                quiet += STREAM_POLL_S
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            pass  # the client went away
        finally:
            self.server.streams.release()

    def _reply(self, status: int, headers: dict[str, str], data: bytes) -> None:
        self.send_response(status)
        for name, value in headers.items():
            if name.lower() not in ("content-length", "connection"):
                self.send_header(name, str(value))
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, format: str, *args: Any) -> None:
        _log.print(f"{self.client_address[0]} {format % args}", style="dim", markup=False)
