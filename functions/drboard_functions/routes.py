"""The leaderboard's HTTP routes: Powertools routers for the push, pull and admin functions.

The three Lambda functions and ``drboard serve`` build their resolver with :func:`build_app`, so
the routes, the validation, the error statuses and the OpenAPI document are the same everywhere.

- ``push_router``: a racer's submission (IAM-signed in the cloud). ``pull_router``: the public
  reads (boards, standings, racers, web pages). ``admin_router``: the organisers' routes (create,
  change, close, delete, restore, export and import boards), every one IAM-signed in the cloud
  and answered by ``drboard serve`` only to the computer it runs on.
- The routes never build a service: the caller puts one in the resolver's context before each
  ``resolve`` (``app.append_context(service=...)``); the routes reach it through ``Depends``.
- The typed domain errors become HTTP statuses in one place, :data:`ERROR_STATUS`; every error
  body is ``{"error": <name>, "message": ..., "detail": [{"loc", "msg", "type"}]}`` (the message
  says what went wrong; the detail, when there is one, says where). A store error (``StoreBusy``,
  ``StoreUnavailable``) answers 503 with ``Retry-After``, on every route: nothing was written.
- Every JSON body is bounded before it is parsed: the resolver's JSON body deserializer refuses a
  body over its route's bound (413) before ``json.loads`` sees it — a record's
  ``limits.MAX_RECORD_BYTES``; an imported submission's, a record plus a little for its timestamp
  (its record is then held to the record's own bound); a board's settings, 16 KiB — then
  Powertools validates the parsed body as the route's model (422 with field-level detail). This
  keeps each request body documented as its model's schema in the OpenAPI document, with no
  second parser. (Powertools runs request validation before any middleware, so a middleware could
  not check the size first.) A form-encoded body is parsed by Powertools' own form parser and
  refused as 422, a multipart one or an unknown content type as 415; API Gateway bounds every
  body at 10 MB anyway. Before any of this, :class:`BoardResolver` refuses a body that cannot be
  read as its headers say (400 ``UnreadableBody``: not UTF-8, bad base64, a Content-Length that
  is not a number or not the body's length).

Run ``python -m drboard_functions.routes > functions/openapi.json`` to regenerate the committed
OpenAPI document (``tests/unit/test_openapi.py`` fails when it drifts from the code).
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from http import HTTPStatus
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as distribution_version
from typing import TYPE_CHECKING, Annotated, Any, TypeVar, cast
from urllib.parse import unquote

from aws_lambda_powertools.event_handler import (
    APIGatewayHttpResolver,
    CORSConfig,
    Depends,
    Request,
    Response,
    content_types,
)
from aws_lambda_powertools.event_handler.api_gateway import Router
from aws_lambda_powertools.event_handler.openapi.exceptions import (
    RequestUnsupportedContentType,
    RequestValidationError,
)
from aws_lambda_powertools.event_handler.openapi.params import Body, Header, Path, Query
from aws_lambda_powertools.event_handler.openapi.types import OpenAPIResponse
from drboard_assembler import __version__ as assembler_version
from drboard_assembler import limits
from drboard_assembler.errors import field_path
from drboard_assembler.record import Record
from pydantic import BaseModel, ConfigDict, Field, StringConstraints

from . import web
from .errors import (
    AliasTaken,
    Banned,
    BoardClosed,
    BoardExists,
    BoardLocked,
    BoardMismatch,
    BoardNotFound,
    BoardUnreachable,
    CopiedRun,
    DesignsPrivate,
    DomainError,
    InvalidQuery,
    InvalidSubmission,
    NotAuthorized,
    NotSignedIn,
    RacerNotFound,
    StoreBusy,
    StoreError,
    StoreUnavailable,
    SubmissionLimitReached,
    SubmissionTooLarge,
    TooSoon,
    UnreadableBody,
    UnsupportedBody,
)
from .identity import Caller, SignIn, caller_from_event
from .models import (
    MAX_PAGE,
    AliasRequest,
    AuditPage,
    Board,
    BoardChanges,
    BoardList,
    BoardPage,
    BoardSpec,
    BoardView,
    Comparison,
    ExportPage,
    ImportedSubmission,
    ImportReceipt,
    Insights,
    Me,
    Moderation,
    PushReceipt,
    RacerHistory,
    RacerSummary,
    RacerView,
)
from .service import (
    DEFAULT_TOP,
    MAX_COMPARED,
    MAX_CURSOR_CHARS,
    MAX_TOP,
    LeaderboardService,
    page_tag,
)

if TYPE_CHECKING:  # Powertools' OpenAPI models: only generating the document needs them
    from aws_lambda_powertools.event_handler.openapi.models import SecurityScheme
    from aws_lambda_powertools.utilities.typing import LambdaContext

TITLE = "drboard"
DEFAULT_LIMIT = 100
MAX_PATH_PARAM_CHARS = 256  # a board id or a racer alias, percent-encoded
#: A board's settings (title, description, track, window, limits): well under this in JSON.
MAX_BOARD_BODY_BYTES = 16 * limits.KIB
#: An imported submission is a record and its first submission time: room for the envelope.
IMPORT_HEADROOM_BYTES = 4 * limits.KIB
HTML = "text/html; charset=utf-8"
#: The web pages load nothing and run no script: only their own inline style.
PAGE_HEADERS = {
    "Content-Security-Policy": "default-src 'none'; style-src 'unsafe-inline'; base-uri 'none'; "
                               "form-action 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Cache-Control": "no-store",
}
#: A live board page: its one inline script, allowed by hash, and requests to its own origin.
LIVE_PAGE_HEADERS = {
    "Content-Security-Policy": PAGE_HEADERS["Content-Security-Policy"]
    + f"; script-src '{web.LIVE_SCRIPT_HASH}'; connect-src 'self'",
}
SIGV4 = "sigv4"
#: The tag of every organiser route: IAM-signed in the cloud, loopback only on `drboard serve`.
ADMIN_TAG = "admin"

push_router = Router()
pull_router = Router()
admin_router = Router()


def api_version() -> str:
    try:
        return distribution_version("drboard")
    except PackageNotFoundError:  # pragma: no cover - a Lambda bundle without dist metadata
        return assembler_version


# ---- response and error models --------------------------------------------------------------


class FieldProblem(BaseModel):
    """One problem with one field: ``loc`` is a path such as ``evaluations[0].laps[2].time_ms``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    loc: str
    msg: str
    type: str


class ErrorBody(BaseModel):
    """Every error answer: the domain error's name, a message for people, and field detail."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    error: str
    message: str
    detail: list[FieldProblem] = Field(default_factory=list)


def _error_response(description: str) -> OpenAPIResponse:
    return {"description": description, "content": {"application/json": {"model": ErrorBody}}}


def _json_response(description: str, model: type[BaseModel]) -> OpenAPIResponse:
    return {"description": description, "content": {"application/json": {"model": model}}}


_PAGE_RESPONSE: OpenAPIResponse = {
    "description": "The web page.",
    "content": {"text/html": {"schema": {"type": "string"}}},
}
_BAD_PATH = "A bad board id or racer alias (too long)."
_UNREADABLE = (" Or a body that cannot be read as its headers say (`UnreadableBody`): a "
               "Content-Length that is not its length, base64 that does not decode, text that "
               "is not UTF-8.")
_UNSIGNED = ("Not signed with SigV4 by an identity allowed to invoke the route (API Gateway's own "
             "answer, without an `error` name); on `drboard serve`, a request from another "
             "computer than the one serving (`NotAuthorized`).")

# ---- request parameters ------------------------------------------------------------------------

BoardId = Annotated[str, Path(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                              description="The board's id: a track's default board is its id, "
                                          "`<track>_cw` for clockwise runs.")]
RacerAlias = Annotated[str, Path(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                                 description="The racer's alias (any case).")]
Limit = Annotated[int, Query(ge=1, le=MAX_PAGE, description="How many entries (1..500).")]
Cursor = Annotated[str | None, Query(max_length=MAX_CURSOR_CHARS,
                                     description="`next_cursor` of the previous page.")]
Compared = Annotated[list[Annotated[str, StringConstraints(min_length=1, max_length=MAX_PATH_PARAM_CHARS)]],
                     Query(min_length=2, max_length=MAX_COMPARED,
                           description="A racer to compare: give it two to four times.")]
Top = Annotated[int, Query(ge=1, le=MAX_TOP, description="How many top models (1..20).")]
Screen = Annotated[bool, Query(description="The big-screen mode: sized for a room, every entry, "
                                           "a QR code of the page, auto-scrolling.")]
IfNoneMatch = Annotated[str | None, Header(max_length=1024, description="The `ETag` of the copy "
                                          "the client holds.")]
OnBoard = Annotated[str | None, Query(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                                      description="Only this board (default: every board).")]


def current_service(request: Request) -> LeaderboardService:
    """The service the caller put in the resolver's context for this request."""
    service = request.context.get("service")
    if not isinstance(service, LeaderboardService):
        raise RuntimeError("no LeaderboardService in the resolver's context: "
                           "call app.append_context(service=...) before app.resolve")
    return service


Service = Annotated[LeaderboardService, Depends(current_service)]


def current_caller(request: Request) -> Caller | None:
    """Who the request was authorised as (see :mod:`drboard_functions.identity`), or None."""
    return caller_from_event(request.resolved_event.raw_event)


SignedIn = Annotated[Caller | None, Depends(current_caller)]


def current_organiser(request: Request) -> Caller:
    """The caller, who must be an organiser (the ``organisers`` group, IAM, or the computer
    running `drboard serve`); anyone else is refused with 403 before the route runs."""
    caller = current_caller(request)
    if caller is None or not caller.organiser:
        raise NotAuthorized("only the board's organisers may do this")
    return caller


Organiser = Annotated[Caller, Depends(current_organiser)]


#: The routes a Cognito sign-in reaches in the cloud: the same routes under this prefix, behind
#: the HTTP API's JWT authorizer (an API Gateway route has one authorizer; the unprefixed ones
#: keep IAM, for organisers' own scripts). The functions and `drboard serve` strip it.
COGNITO_PREFIX = "/cognito"


def canonical_event(event: dict[str, Any]) -> dict[str, Any]:
    """The event as the routes know it: a ``/cognito/...`` path without its prefix."""
    path = str(event.get("rawPath") or "")
    if not path.startswith(COGNITO_PREFIX + "/"):
        return event
    event = dict(event)
    event["rawPath"] = path[len(COGNITO_PREFIX):]
    context = dict(event.get("requestContext") or {})
    http = dict(context.get("http") or {})
    if str(http.get("path", "")).startswith(COGNITO_PREFIX + "/"):
        http["path"] = http["path"][len(COGNITO_PREFIX):]
    context["http"] = http
    event["requestContext"] = context
    return event


def current_sign_in(request: Request) -> SignIn:
    sign_in = request.context.get("sign_in")
    return sign_in if isinstance(sign_in, SignIn) else SignIn()


def _segment(value: str) -> str:
    """A path parameter as the racer typed it: API Gateway's rawPath keeps percent-encoding."""
    return unquote(value)


# ---- request bodies: what each route takes, and its bound --------------------------------------


@dataclass(frozen=True)
class RequestBody:
    """What a route's JSON body is: its name in messages, its bound in bytes (checked before it
    is parsed), and the domain error a body that fails validation answers as."""

    name: str  # the ``loc`` of a problem with the body as a whole
    max_bytes: int
    invalid: type[DomainError]

    @property
    def what(self) -> str:
        return f"the {self.name}"


RECORD_BODY = RequestBody("record", limits.MAX_RECORD_BYTES, InvalidSubmission)
IMPORT_BODY = RequestBody("submission", limits.MAX_RECORD_BYTES + IMPORT_HEADROOM_BYTES,
                          InvalidSubmission)
BOARD_BODY = RequestBody("board", MAX_BOARD_BODY_BYTES, InvalidQuery)
CHANGES_BODY = RequestBody("changes", MAX_BOARD_BODY_BYTES, InvalidQuery)
ALIAS_BODY = RequestBody("alias", limits.KIB, InvalidQuery)

_BODIES: dict[Callable[..., Any], RequestBody] = {}
F = TypeVar("F", bound=Callable[..., Any])


def takes(body: RequestBody) -> Callable[[F], F]:
    """Declare the JSON body a route takes (under its router's decorator)."""
    def register(route: F) -> F:
        _BODIES[route] = body
        return route
    return register


def _route_body(app: APIGatewayHttpResolver) -> RequestBody:
    route = app.context.get("_route")
    return _BODIES.get(route.func, RECORD_BODY) if route is not None else RECORD_BODY


def bounded_json(body: str, bound: RequestBody = RECORD_BODY) -> Any:
    """Parse a JSON request body; a body over its route's bound is refused unparsed (413)."""
    if len(body) > bound.max_bytes or len(body.encode("utf-8")) > bound.max_bytes:
        raise SubmissionTooLarge(
            f"the request body is over {bound.max_bytes} bytes, the bound of {bound.what}")
    try:
        return json.loads(body)
    except json.JSONDecodeError:
        raise  # Powertools answers it as a body that is not JSON, with where parsing stopped
    except (ValueError, RecursionError) as error:  # a number over 4,300 digits; too deep a nesting
        reason = "nested too deeply" if isinstance(error, RecursionError) else str(error).split(":")[0]
        raise bound.invalid(f"{bound.what} cannot be read: {reason}",
                            detail=[{"loc": bound.name, "msg": reason, "type": "value_error"}]) from None


def _json(status: int, body: BaseModel) -> Response[Any]:
    return Response(status_code=status, content_type=content_types.APPLICATION_JSON, body=body)


# ---- push ---------------------------------------------------------------------------------------


@push_router.post(
    "/boards/<board>/submissions",
    cors=False,
    status_code=HTTPStatus.CREATED,
    summary="Submit a run",
    description="Validates the record (derived figures, submission id, plausible laps) and stores "
                "it on the board. 201 for a new submission, 200 when the same run was already "
                "submitted (nothing changes, whatever the board's window and limits). Requests "
                "must be signed with SigV4 (IAM).",
    tags=["submissions"],
    security=[{SIGV4: []}],
    responses={
        201: _json_response("The submission was stored.", PushReceipt),
        200: _json_response("The same run was already submitted; nothing changed.", PushReceipt),
        400: _error_response(_BAD_PATH + _UNREADABLE),
        401: _error_response("No sign-in the board accepts (`NotSignedIn`)."),
        403: _error_response("The board is not open (`BoardClosed`: it opens later or has "
                             "closed), the racer has made every submission it allows "
                             "(`SubmissionLimitReached`), the alias is another racer's or the "
                             "caller pushes as another alias (`AliasTaken`), or the racer is "
                             "banned from the board (`Banned`). " + _UNSIGNED),
        409: _error_response("The run's evaluation is already on the board under another "
                             "racer (`CopiedRun`)."),
        404: _error_response("No such board, and the run's own board is another one."),
        413: _error_response(f"The body is over {limits.MAX_RECORD_BYTES} bytes."),
        415: _error_response("The body is not JSON (`UnsupportedBody` for a multipart one)."),
        422: _error_response("The record is invalid or does not belong on this board."),
        429: {**_error_response("The board's cooldown applies (`TooSoon`); see Retry-After."),
              "headers": {"Retry-After": {"description": "Seconds to wait.",
                                          "schema": {"type": "integer"}}}},
    },
)
@takes(RECORD_BODY)
def submit(
    board: BoardId,
    record: Annotated[Record, Body(description="The record `drboard assemble` builds.")],
    service: Service,
    caller: SignedIn,
) -> Response[PushReceipt]:
    receipt = service.push(record, _segment(board), caller=caller)
    return _json(HTTPStatus.CREATED if receipt.status == "created" else HTTPStatus.OK, receipt)


# ---- the signed-in caller -------------------------------------------------------------------------


@push_router.get(
    "/me",
    cors=False,
    summary="Who the board takes you for",
    description="The caller's sign-in and the alias it holds (null before the first push or "
                "`PUT /me/alias`).",
    tags=["racers"],
    security=[{SIGV4: []}],
    responses={200: _json_response("The caller.", Me),
               401: _error_response("No sign-in the board accepts (`NotSignedIn`).")},
)
def get_me(service: Service, caller: SignedIn) -> Me:
    return service.me(caller)


@push_router.put(
    "/me/alias",
    cors=False,
    summary="Claim your racer alias",
    description="Binds the alias to the caller's sign-in, once: aliases are compared after "
                "Unicode NFKC and case folding, and one holding invisible characters or mixing "
                "lookalike scripts is refused. A racer's first push claims its alias too.",
    tags=["racers"],
    security=[{SIGV4: []}],
    responses={200: _json_response("The caller, with the alias.", Me),
               400: _error_response("The alias is not one a racer may take."),
               401: _error_response("No sign-in the board accepts (`NotSignedIn`)."),
               403: _error_response("The alias is another racer's, or the caller holds another "
                                    "(`AliasTaken`)."),
               413: _error_response(f"The body is over {ALIAS_BODY.max_bytes} bytes."),
               415: _error_response("The body is not JSON."),
               422: _error_response("The body is not `{\"alias\": ...}`.")},
)
@takes(ALIAS_BODY)
def put_my_alias(request: Annotated[AliasRequest, Body(description="The alias to claim.")],
                 service: Service, caller: SignedIn) -> Me:
    return service.claim_alias(request.alias, caller=caller)


# ---- pull ---------------------------------------------------------------------------------------


@pull_router.get(
    "/boards",
    summary="List the boards",
    description="The boards by id, `limit` at a time; pass the answer's `next_cursor` as "
                "`cursor` for the next page, until it is null. (A page may hold fewer than "
                "`limit` boards: deleted boards are left out.)",
    tags=["boards"],
    responses={200: _json_response("One page of the boards, by id.", BoardList),
               400: _error_response("A bad limit or cursor.")},
)
def list_boards(service: Service, limit: Limit = DEFAULT_LIMIT, cursor: Cursor = None) -> BoardList:
    return service.boards_page(limit, cursor or None)


@pull_router.get(
    "/boards/<board>",
    summary="A board's standings",
    description="The board and its entries in rank order, `limit` at a time; pass the answer's "
                "`next_cursor` as `cursor` for the next page. The answer's `ETag` changes with "
                "the standings: send it back as `If-None-Match` and an unchanged board answers "
                "`304 Not Modified` with no body, after a single read (a screen can poll every "
                "few seconds).",
    tags=["boards"],
    responses={200: _json_response("The board and one page of its entries.", BoardPage),
               304: {"description": "Unchanged since the `ETag` sent in `If-None-Match`."},
               400: _error_response("A bad limit or cursor."),
               404: _error_response("No such board.")},
)
def get_board(board: BoardId, service: Service, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None, if_none_match: IfNoneMatch = None) -> Response[Any]:
    board_id = _segment(board)
    if if_none_match:
        etag = page_etag(service.board_tag(board_id), limit, cursor)
        if etag in (tag.strip() for tag in if_none_match.split(",")):
            return Response(status_code=HTTPStatus.NOT_MODIFIED, body="", headers=_etag_headers(etag))
    page = service.board_page(board_id, limit=limit, cursor=cursor or None)
    return Response(status_code=HTTPStatus.OK, content_type=content_types.APPLICATION_JSON,
                    body=page, headers=_etag_headers(page_etag(page_tag(page.board), limit, cursor)))


def page_etag(tag: str, limit: int, cursor: str | None) -> str:
    """The ETag of one page of a board: the board's page tag, the page asked for, and the API's
    version (a new release may answer differently)."""
    query = hashlib.sha256(f"{limit}|{cursor or ''}".encode()).hexdigest()[:12]
    return f'"{api_version()}.{tag}.{query}"'


def _etag_headers(etag: str) -> dict[str, str]:
    return {"ETag": etag, "Cache-Control": "no-cache"}


@pull_router.get(
    "/boards/<board>/racers/<racer>",
    summary="A racer's entry and history on a board",
    description="The racer's best entry, its rank, the best run's full record (design, laps, "
                "training) and their submissions on the board, oldest first, `limit` at a "
                "time: pass the answer's `next_cursor` as `cursor` for the next ones.",
    tags=["boards"],
    responses={200: _json_response("The racer's entry, best record and one page of their "
                                   "history.", RacerView),
               400: _error_response(_BAD_PATH + " Or a bad limit or cursor."),
               404: _error_response("No such board, or the racer has no entry on it.")},
)
def get_racer(board: BoardId, racer: RacerAlias, service: Service, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None) -> RacerView:
    return service.racer(_segment(board), _segment(racer), limit, cursor or None)


@pull_router.get(
    "/boards/<board>/compare",
    summary="Racers' designs side by side",
    description="Two to four racers' designs as comparable facts (algorithm, action space, top "
                "speed, steering, sensors, hyperparameters, training), and the facts they differ on.",
    tags=["boards"],
    responses={200: _json_response("The racers' entries and design facts.", Comparison),
               400: _error_response("Fewer than two racers, or more than four."),
               404: _error_response("No such board, or a racer has no entry on it.")},
)
def get_comparison(board: BoardId, service: Service, racer: Compared) -> Comparison:
    return service.compare(_segment(board), racer)


@pull_router.get(
    "/boards/<board>/insights",
    summary="What the top models share",
    description="Each design fact of the board's top `top` qualified models against the field "
                "(its first 100 entries), and every entry's top speed against its time.",
    tags=["boards"],
    responses={200: _json_response("The shared facts and the speed points.", Insights),
               400: _error_response("A bad `top`."),
               404: _error_response("No such board.")},
)
def get_insights(board: BoardId, service: Service, top: Top = DEFAULT_TOP) -> Insights:
    return service.insights(_segment(board), top)


@pull_router.get(
    "/racers/<racer>",
    summary="Where a racer stands",
    description="On each board the racer pushed to (or on `board` only), latest first: their "
                "latest submission, their best entry's rank and gap, how many submissions they "
                "made and have left, and when they may submit next.",
    tags=["racers"],
    responses={200: _json_response("The racer's standing on each board.", RacerSummary),
               400: _error_response(_BAD_PATH),
               404: _error_response("No such board, or the racer has no submissions (on it).")},
)
def get_racer_status(racer: RacerAlias, service: Service, board: OnBoard = None) -> RacerSummary:
    return service.status(_segment(racer), board)


@pull_router.get(
    "/racers/<racer>/submissions",
    summary="A racer's submissions",
    description="The racer's submissions on every board (or on `board` only), oldest first, "
                "`limit` at a time: pass the answer's `next_cursor` as `cursor` for the next "
                "page, until it is null. `is_best` marks the one that counts on its board. "
                "`racer` is the alias as asked. A racer with no submissions has an empty history.",
    tags=["racers"],
    responses={200: _json_response("One page of the racer's submissions, oldest first.",
                                   RacerHistory),
               400: _error_response(_BAD_PATH + " Or a bad limit or cursor."),
               404: _error_response("No such board.")},
)
def get_racer_history(racer: RacerAlias, service: Service, board: OnBoard = None,
                      limit: Limit = DEFAULT_LIMIT, cursor: Cursor = None) -> RacerHistory:
    return service.history_page(_segment(racer), board, limit, cursor or None)


@pull_router.get(
    "/.well-known/drboard.json",
    summary="How to sign in to this board",
    description="What `drboard login --endpoint URL` needs: `kind` is `cognito` (a deployed "
                "board: its user pool, public app client, hosted sign-in domain and scopes; "
                "signed-in requests go to the same routes under `/cognito`), `join-code` (a "
                "`drboard serve` board: `POST /join` with the organiser's code) or `none`.",
    tags=["racers"],
    responses={200: _json_response("How racers sign in.", SignIn)},
)
def well_known(sign_in: Annotated[SignIn, Depends(current_sign_in)]) -> SignIn:
    return sign_in


@pull_router.get("/", summary="The boards' web page", tags=["pages"],
                 responses={200: _PAGE_RESPONSE})
def index_page(service: Service) -> Response[str]:
    return _page(web.index_page(service.boards()))


@pull_router.get(
    "/boards/<board>/view",
    summary="A board's web page",
    tags=["pages"],
    responses={200: _PAGE_RESPONSE, 400: _error_response("A bad limit or cursor."),
               404: _error_response("No such board.")},
)
def board_view(board: BoardId, service: Service, request: Request, limit: Limit = DEFAULT_LIMIT,
               cursor: Cursor = None, screen: Screen = False,
               if_none_match: IfNoneMatch = None) -> Response[str]:
    board_id = _segment(board)
    if screen and limit == DEFAULT_LIMIT:
        limit = MAX_PAGE  # the big screen scrolls through the whole board
    view = "screen" if screen else "view"
    try:
        if if_none_match:
            etag = page_etag(f"{view}.{service.board_tag(board_id)}", limit, cursor)
            if etag in (tag.strip() for tag in if_none_match.split(",")):
                return _page("", HTTPStatus.NOT_MODIFIED, _etag_headers(etag))
        page = service.board_page(board_id, limit=limit, cursor=cursor or None)
    except BoardNotFound:  # a screen set up before the first push waits for the board
        return _page(web.waiting_page(board_id, screen), HTTPStatus.NOT_FOUND, LIVE_PAGE_HEADERS)
    etag = page_etag(f"{view}.{page_tag(page.board)}", limit, cursor)
    origin = _origin(request.resolved_event)
    url = origin + web.board_path(board_id)
    html = web.board_page(page, etag, screen=screen, now=service.clock(), url=url,
                          endpoint=origin, qr_svg=web.qr_svg(url) if screen else "")
    return _page(html, headers=LIVE_PAGE_HEADERS | _etag_headers(etag))


def _origin(event: Any) -> str:
    """The board's own origin as the client reached it (https behind API Gateway)."""
    headers = event.headers or {}
    context = event.raw_event.get("requestContext") or {}
    host = headers.get("host") or context.get("domainName") or "localhost"
    scheme = headers.get("x-forwarded-proto", "http").split(",")[0].strip()
    return f"{scheme}://{host}"


@pull_router.get(
    "/boards/<board>/racers/<racer>/view",
    summary="A racer's web page",
    tags=["pages"],
    responses={200: _PAGE_RESPONSE, 404: _error_response("No such board or racer.")},
)
def racer_view(board: BoardId, racer: RacerAlias, service: Service) -> Response[str]:
    return _page(web.racer_page(service.racer(_segment(board), _segment(racer), MAX_PAGE)))


@pull_router.get(
    "/boards/<board>/compare/view",
    summary="The compare page",
    tags=["pages"],
    responses={200: _PAGE_RESPONSE, 400: _error_response("Fewer than two racers, or more than four."),
               404: _error_response("No such board or racer.")},
)
def compare_view(board: BoardId, service: Service, racer: Compared) -> Response[str]:
    return _page(web.compare_page(service.compare(_segment(board), racer)))


@pull_router.get(
    "/boards/<board>/insights/view",
    summary="The insights page",
    tags=["pages"],
    responses={200: _PAGE_RESPONSE, 404: _error_response("No such board.")},
)
def insights_view(board: BoardId, service: Service, top: Top = DEFAULT_TOP) -> Response[str]:
    return _page(web.insights_page(service.insights(_segment(board), top)))


def _page(html: str, status: int = HTTPStatus.OK,
          headers: dict[str, str] | None = None) -> Response[str]:
    return Response(status_code=status, content_type=HTML, body=html,
                    headers=PAGE_HEADERS | (headers or {}))


# ---- admin: the organisers' routes --------------------------------------------------------------


def _admin_responses(ok: OpenAPIResponse, *, ok_status: int = HTTPStatus.OK,
                     body: RequestBody | None = None,
                     errors: dict[int, str] | None = None,
                     also: dict[int, OpenAPIResponse] | None = None) -> dict[int, OpenAPIResponse]:
    """An organiser route's answers: its own, the refusal of unsigned requests, a body's (413,
    415, 422), then its own errors and other answers (which replace the general ones)."""
    responses: dict[int, OpenAPIResponse] = {ok_status: ok, 400: _error_response(_BAD_PATH),
                                             403: _error_response(_UNSIGNED)}
    if body is not None:
        verb = "are" if body.name.endswith("s") else "is"
        responses[400] = _error_response(_BAD_PATH + _UNREADABLE)
        responses[413] = _error_response(f"The body is over {body.max_bytes} bytes.")
        responses[415] = _error_response("The body is not JSON.")
        responses[422] = _error_response(f"The {body.name} {verb} not valid (field-level `detail`).")
    responses |= {status: _error_response(text) for status, text in (errors or {}).items()}
    return responses | (also or {})


_ADMIN: dict[str, Any] = {"cors": False, "tags": [ADMIN_TAG], "security": [{SIGV4: []}]}
_NO_BOARD = "No such board (or it was deleted)."
_DEFAULT_BOARD = ("The board is a track's default board, which keeps the default rules "
                  "(`BoardLocked`).")


@admin_router.post(
    "/boards",
    status_code=HTTPStatus.CREATED,
    summary="Create a named board",
    description="A board of the organiser's own on a track, with its title, timing method, window "
                "(`opens_at`, `closes_at`) and limits (`cooldown_s` between a racer's "
                "submissions, `max_submissions` per racer). Racers push to it by its id.",
    responses=_admin_responses(
        _json_response("The board was created.", BoardView), ok_status=HTTPStatus.CREATED,
        body=BOARD_BODY, errors={
            400: "An unknown or ambiguous track (the closest matches are listed), a window that "
                 "closes before it opens, or a bad board id.",
            409: "A board with this id exists, or the id is a track's default board's "
                 "(`BoardExists`)."}),
    **_ADMIN,
)
@takes(BOARD_BODY)
def create_board(spec: Annotated[BoardSpec, Body(description="The new board.")],
                 service: Service, organiser: Organiser) -> Response[BoardView]:
    return _json(HTTPStatus.CREATED, service.create_board(spec, caller=organiser))


@admin_router.patch(
    "/boards/<board>",
    summary="Change a named board",
    description="Only the fields in the body change; `null` clears a window's end or a limit. "
                "The timing method and minimum laps change only while the board has no entries.",
    responses=_admin_responses(
        _json_response("The board as it is now.", BoardView), body=CHANGES_BODY, errors={
            400: "The title or method cleared, a window that closes before it opens, or a bad "
                 "board id.",
            404: _NO_BOARD,
            409: "The change would rescore entries already on the board, or the board is a "
                 "track's default board (`BoardLocked`)."}),
    **_ADMIN,
)
@takes(CHANGES_BODY)
def update_board(board: BoardId,
                 changes: Annotated[BoardChanges, Body(description="The fields to change.")],
                 service: Service, organiser: Organiser) -> BoardView:
    return service.update_board(_segment(board), changes, caller=organiser)


@admin_router.post(
    "/boards/<board>/close",
    summary="Close a named board now",
    description="Pushes are refused from now on (`BoardClosed`); an upcoming board closes "
                "without ever opening. Closing a closed board changes nothing.",
    responses=_admin_responses(_json_response("The closed board.", BoardView),
                               errors={404: _NO_BOARD, 409: _DEFAULT_BOARD}),
    **_ADMIN,
)
def close_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.close_board(_segment(board), caller=organiser)


@admin_router.delete(
    "/boards/<board>",
    summary="Delete a named board (softly)",
    description="The board disappears from lists, pushes and reads; nothing is erased, and "
                "`POST /boards/{board}/restore` brings it back whole.",
    responses=_admin_responses(_json_response("The deleted board.", BoardView),
                               errors={404: _NO_BOARD, 409: _DEFAULT_BOARD}),
    **_ADMIN,
)
def delete_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.delete_board(_segment(board), caller=organiser)


@admin_router.post(
    "/boards/<board>/restore",
    summary="Restore a deleted board",
    description="The board comes back with every entry and submission it had.",
    responses=_admin_responses(_json_response("The restored board.", BoardView),
                               errors={404: "No such board."}),
    **_ADMIN,
)
def restore_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.restore_board(_segment(board), caller=organiser)


@admin_router.get(
    "/boards/<board>/export",
    summary="Export a board, a page at a time",
    description="The first page starts with the board; then come its entries in rank order, "
                "then every submission with its record. Pass the answer's `next_cursor` as "
                "`cursor` until it is null. Deleted boards export too.",
    responses=_admin_responses(_json_response("One page of the export.", ExportPage),
                               errors={400: "A bad cursor or board id.", 404: "No such board."}),
    **_ADMIN,
)
def export_board(board: BoardId, service: Service, organiser: Organiser,
                 cursor: Cursor = None) -> Response[Any]:
    page = service.export_page(_segment(board), cursor or None)
    # Each line as it serialises itself: a stored record goes out as it was stored, unparsed.
    lines = ",".join(line.model_dump_json() for line in page.lines)
    body = f'{{"lines":[{lines}],"next_cursor":{json.dumps(page.next_cursor)}}}'
    return Response(status_code=HTTPStatus.OK, content_type=content_types.APPLICATION_JSON, body=body)


@admin_router.put(
    "/boards/<board>/import",
    status_code=HTTPStatus.CREATED,
    summary="Import a board from an export",
    description="Creates the exported board (its `board_id` must be the path's) unless a board "
                "with that id exists, whose own settings then stay: importing twice changes "
                "nothing. Then replay its submissions with `POST /boards/{board}/imports`.",
    responses=_admin_responses(
        _json_response("The board was created.", BoardView), ok_status=HTTPStatus.CREATED,
        body=BOARD_BODY, errors={
            400: "The body's `board_id` is not the path's, or is not a board id.",
            404: "A deleted board has this id: restore it, or import under another id."},
        also={200: _json_response("A board with this id exists; it keeps its own settings and "
                                  "nothing changed.", BoardView)}),
    **_ADMIN,
)
@takes(BOARD_BODY)
def import_board(board: BoardId,
                 exported: Annotated[Board, Body(description="The `board` of an export's first line.")],
                 service: Service, organiser: Organiser) -> Response[BoardView]:
    board_id = _segment(board)
    if exported.board_id != board_id:
        raise InvalidQuery(f"the body is board {exported.board_id!r} but the path names {board_id!r}",
                           detail=[{"loc": "board_id", "msg": f"should be {board_id!r}",
                                    "type": "value_error"}])
    view, created = service.import_board(exported, caller=organiser)
    return _json(HTTPStatus.CREATED if created else HTTPStatus.OK, view)


@admin_router.post(
    "/boards/<board>/imports",
    status_code=HTTPStatus.CREATED,
    summary="Replay one exported submission",
    description="Stores the record as first submitted at `submitted_at`, scored by this board's "
                "rules; the board's window and limits do not apply. Importing the same "
                "submission twice changes nothing. The body is bounded at the record's bound plus "
                f"{IMPORT_HEADROOM_BYTES} bytes, and its record at the record's own bound.",
    responses=_admin_responses(
        _json_response("The submission was stored.", ImportReceipt), ok_status=HTTPStatus.CREATED,
        body=IMPORT_BODY, errors={
            404: _NO_BOARD,
            413: f"The body is over {IMPORT_BODY.max_bytes} bytes, or its record over "
                 f"{limits.MAX_RECORD_BYTES}.",
            422: "The submission is not valid (field-level `detail`), or its run does not "
                 "belong on this board (`BoardMismatch`)."},
        also={200: _json_response("The submission was already on the board; nothing changed.",
                                  ImportReceipt)}),
    **_ADMIN,
)
@takes(IMPORT_BODY)
def import_submission(board: BoardId,
                      item: Annotated[ImportedSubmission, Body(description="A submission line of "
                                                                           "an export: its record "
                                                                           "and `submitted_at`.")],
                      service: Service, organiser: Organiser) -> Response[ImportReceipt]:
    receipt = service.import_submission(_segment(board), item, caller=organiser)
    return _json(HTTPStatus.CREATED if receipt.status == "created" else HTTPStatus.OK, receipt)


@admin_router.delete(
    "/boards/<board>/racers/<racer>",
    summary="Take a racer's entry off a board",
    description="The racer's submissions stay (and show in the audit trail); the standings are "
                "recomputed without them. Their next push makes a new entry.",
    responses=_admin_responses(_json_response("What the board now shows of the racer.", Moderation),
                               errors={404: "No such board, or the racer never pushed to it."}),
    **_ADMIN,
)
def remove_entry(board: BoardId, racer: RacerAlias, service: Service,
                 organiser: Organiser) -> Moderation:
    return service.remove_entry(_segment(board), _segment(racer), caller=organiser)


@admin_router.put(
    "/boards/<board>/bans/<racer>",
    summary="Ban a racer from a board",
    description="Their pushes are refused (`Banned`) and their entry comes off the board; their "
                "submissions stay, and `DELETE` on the same path puts their best back.",
    responses=_admin_responses(_json_response("The racer is banned.", Moderation),
                               errors={404: _NO_BOARD}),
    **_ADMIN,
)
def ban_racer(board: BoardId, racer: RacerAlias, service: Service, organiser: Organiser) -> Moderation:
    return service.ban(_segment(board), _segment(racer), caller=organiser)


@admin_router.delete(
    "/boards/<board>/bans/<racer>",
    summary="Lift a racer's ban",
    description="The racer may push again, and their best submission is back on the board.",
    responses=_admin_responses(_json_response("The racer is no longer banned.", Moderation),
                               errors={404: _NO_BOARD}),
    **_ADMIN,
)
def unban_racer(board: BoardId, racer: RacerAlias, service: Service,
                organiser: Organiser) -> Moderation:
    return service.unban(_segment(board), _segment(racer), caller=organiser)


@admin_router.get(
    "/boards/<board>/audit",
    summary="A board's audit trail",
    description="Every accepted push and every organiser action on the board, oldest first: "
                "who (`actor`), when, what. Pass `next_cursor` as `cursor` for the next page.",
    responses=_admin_responses(_json_response("One page of the audit trail.", AuditPage),
                               errors={400: "A bad limit or cursor.", 404: "No such board."}),
    **_ADMIN,
)
def get_audit(board: BoardId, service: Service, organiser: Organiser, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None) -> AuditPage:
    return service.audit(_segment(board), cursor or None, limit)


# ---- errors: the one place where domain errors become HTTP statuses ---------------------------

#: Checked in order: the first class the error is an instance of gives its status.
ERROR_STATUS: tuple[tuple[type[DomainError], HTTPStatus], ...] = (
    (InvalidSubmission, HTTPStatus.UNPROCESSABLE_ENTITY),
    (BoardMismatch, HTTPStatus.UNPROCESSABLE_ENTITY),
    (SubmissionTooLarge, HTTPStatus.REQUEST_ENTITY_TOO_LARGE),
    (BoardNotFound, HTTPStatus.NOT_FOUND),
    (RacerNotFound, HTTPStatus.NOT_FOUND),
    (InvalidQuery, HTTPStatus.BAD_REQUEST),
    (UnreadableBody, HTTPStatus.BAD_REQUEST),
    (UnsupportedBody, HTTPStatus.UNSUPPORTED_MEDIA_TYPE),
    (TooSoon, HTTPStatus.TOO_MANY_REQUESTS),
    (BoardClosed, HTTPStatus.FORBIDDEN),
    (DesignsPrivate, HTTPStatus.FORBIDDEN),
    (SubmissionLimitReached, HTTPStatus.FORBIDDEN),
    (NotSignedIn, HTTPStatus.UNAUTHORIZED),
    (AliasTaken, HTTPStatus.FORBIDDEN),
    (Banned, HTTPStatus.FORBIDDEN),
    (NotAuthorized, HTTPStatus.FORBIDDEN),
    (CopiedRun, HTTPStatus.CONFLICT),
    (BoardExists, HTTPStatus.CONFLICT),
    (BoardLocked, HTTPStatus.CONFLICT),
    (StoreBusy, HTTPStatus.SERVICE_UNAVAILABLE),
    (StoreUnavailable, HTTPStatus.SERVICE_UNAVAILABLE),
    (StoreError, HTTPStatus.SERVICE_UNAVAILABLE),
    # Raised by clients of a board, not by the board; were one ever to reach a route, it would
    # be a board behind this one that could not be reached.
    (BoardUnreachable, HTTPStatus.BAD_GATEWAY),
)


def status_of(error: DomainError) -> HTTPStatus:
    for kind, status in ERROR_STATUS:
        if isinstance(error, kind):
            return status
    return HTTPStatus.BAD_REQUEST  # a domain error is raised on purpose: the request is at fault


def error_headers(error: DomainError) -> dict[str, str] | None:
    """The headers an error answer carries: Retry-After for a cooldown and a busy store."""
    if isinstance(error, TooSoon | StoreError):
        return {"Retry-After": str(max(0, error.retry_after_s))}
    return None


def error_body(error: DomainError) -> ErrorBody:
    """The JSON body of a domain error's answer (``drboard serve`` answers its own refusals
    with it, too)."""
    return ErrorBody.model_validate({"error": type(error).__name__, "message": error.message,
                                     "detail": _field_problems(error.detail)})


def _field_problems(detail: Sequence[dict[str, str]]) -> list[dict[str, str]]:
    return [{"loc": str(d.get("loc", "")), "msg": str(d.get("msg", "")),
             "type": str(d.get("type", "value_error"))} for d in detail]


def _problems(errors: Sequence[Any], body: RequestBody) -> tuple[str, list[dict[str, str]]]:
    """Pydantic's errors as field problems, and where they are (body, query, path)."""
    where = "body"
    problems = []
    for error in errors:
        loc = list(error.get("loc", ()))
        if loc and loc[0] in ("body", "query", "path", "header", "cookie"):
            where = str(loc.pop(0))
        kind = str(error.get("type", "value_error"))
        msg = str(error.get("msg", "invalid"))
        msg = msg.removeprefix("Value error, ").removeprefix("Assertion failed, ")
        if kind == "json_invalid":  # its loc is the character where parsing stopped
            reason = (error.get("ctx") or {}).get("error") or msg
            msg, loc = f"{reason} at character {loc[0] if loc else 0}", []
        problems.append({"loc": field_path(loc) or (body.name if where == "body" else where),
                         "msg": msg, "type": kind})
    return where, problems


def _answer(app: APIGatewayHttpResolver, error: DomainError) -> Response[Any]:
    status = status_of(error)
    headers = error_headers(error)
    if _is_page_request(app):
        return _page(web.error_page(status.value, status.phrase, error.message), status, headers)
    return Response(status_code=status, content_type=content_types.APPLICATION_JSON,
                    body=error_body(error).model_dump(mode="json"), headers=headers)


def _is_page_request(app: APIGatewayHttpResolver) -> bool:
    route = app.context.get("_route")
    return route is not None and "pages" in route.tags


def _register_error_handlers(app: APIGatewayHttpResolver) -> None:
    @app.exception_handler(DomainError)
    def domain_error(error: DomainError) -> Response[Any]:
        return _answer(app, error)

    @app.exception_handler(RequestValidationError)
    def invalid_request(error: RequestValidationError) -> Response[Any]:
        body = _route_body(app)
        where, problems = _problems(error.errors(), body)
        if where == "body":
            json_error = next((p for p in problems if p["type"] == "json_invalid"), None)
            if json_error:
                return _answer_unprocessable(app, body, "the request body is not valid JSON",
                                             [json_error])
            count = f" ({len(problems)} problems)" if len(problems) > 1 else ""
            verb = "are" if body.name.endswith("s") else "is"
            return _answer_unprocessable(app, body, f"{body.what} {verb} invalid{count}", problems)
        return _answer(app, InvalidQuery(f"invalid {where} parameter", detail=problems))

    @app.exception_handler(RequestUnsupportedContentType)
    def unsupported_body(error: RequestUnsupportedContentType) -> Response[Any]:
        body = _route_body(app)
        return _answer_unprocessable(app, body, f"send {body.what} as application/json",
                                     status=HTTPStatus.UNSUPPORTED_MEDIA_TYPE)


def _answer_unprocessable(app: APIGatewayHttpResolver, body: RequestBody, message: str,
                          detail: list[dict[str, str]] | None = None,
                          status: HTTPStatus = HTTPStatus.UNPROCESSABLE_ENTITY) -> Response[Any]:
    """A body that is not the route's model: 422 (415 for another content type), named as the
    domain error of that kind of body (``InvalidSubmission`` for records)."""
    problem = ErrorBody.model_validate({"error": body.invalid.__name__, "message": message,
                                        "detail": detail or []})
    return Response(status_code=status, content_type=content_types.APPLICATION_JSON,
                    body=problem.model_dump(mode="json"))


# ---- the resolver -----------------------------------------------------------------------------


class BoardResolver(APIGatewayHttpResolver):
    """Powertools' resolver, after a look at the request's framing: a body that cannot be read
    as what its headers say is refused before any route or parser sees it (Powertools would
    raise on some of them: a multipart type without a boundary, base64 that does not decode)."""

    def resolve(self, event: Mapping[str, Any], context: LambdaContext) -> dict[str, Any]:
        problem = unreadable(event)
        if problem is not None:
            return refusal(problem)
        return super().resolve(event, context)


def unreadable(event: Mapping[str, Any]) -> DomainError | None:
    """What is wrong with the event's body as a body, if anything."""
    headers = {str(k).lower(): str(v) for k, v in (event.get("headers") or {}).items()}
    body = event.get("body")
    if event.get("isBase64Encoded") and body:
        try:
            raw = base64.b64decode(str(body), validate=True)
            raw.decode("utf-8")
        except (binascii.Error, ValueError):
            return UnreadableBody("the request body is not base64-encoded UTF-8 text")
    else:
        try:
            raw = str(body or "").encode("utf-8")
        except UnicodeEncodeError:
            return UnreadableBody("the request body is not UTF-8 text")
    length = headers.get("content-length")
    if body is not None and length is not None and (
            not length.strip().isdecimal() or int(length) != len(raw)):
        return UnreadableBody(f"the request's Content-Length ({length[:20]!r}) is not the length "
                              f"of its body ({len(raw)} bytes)")
    if body and headers.get("content-type", "").lower().startswith("multipart/"):
        return UnsupportedBody("send the body as application/json")
    return None


def refusal(error: DomainError) -> dict[str, Any]:
    """The Lambda proxy answer to an error raised before any route runs."""
    headers = {"Content-Type": content_types.APPLICATION_JSON} | (error_headers(error) or {})
    return {"statusCode": int(status_of(error)), "headers": headers,
            "body": error_body(error).model_dump_json(), "isBase64Encoded": False}



def build_app(*routers: Router) -> BoardResolver:
    """A resolver with these routers, validation, CORS for the reads, and the error statuses.

    Give each resolver its own call: a Router serves the resolver that included it last, which
    is fine because the routes read only the resolver's own request and context."""
    app: BoardResolver

    def parse_body(body: str) -> Any:
        return bounded_json(body, _route_body(app))

    app = BoardResolver(
        cors=CORSConfig(allow_origin="*", allow_headers=["Content-Type"], max_age=600),
        enable_validation=True,
        response_validation_error_http_code=HTTPStatus.INTERNAL_SERVER_ERROR,
        json_body_deserializer=parse_body,
    )
    for router in routers:
        app.include_router(router)
    _register_error_handlers(app)
    app.configure_openapi(
        title=TITLE,
        version=api_version(),
        summary="A collaborative leaderboard for AWS DeepRacer racers.",
        description="Push a model's evaluation as a record; read the standings, each racer's "
                    "history and how the fast models were built. Reads are public; submissions "
                    "and the organisers' routes (tag `admin`) are signed with SigV4 (IAM).",
        tags=["submissions", "boards", "racers", ADMIN_TAG, "pages"],
        # Plain data, which Powertools validates as an APIKey when it builds the document: its
        # OpenAPI models cost a cold start ~40 ms to import, for a document the functions never
        # serve. (No servers: Powertools' default is the same single "/".)
        security_schemes=cast("dict[str, SecurityScheme]", {SIGV4: {
            "type": "apiKey", "name": "Authorization", "in": "header",
            "description": "AWS Signature Version 4 (API Gateway IAM authorisation).",
            "x-amazon-apigateway-authtype": "awsSigv4",
        }}),
    )
    return app


_DEFAULT_422 = "#/components/schemas/HTTPValidationError"
#: Every route's answer when the board's storage is busy or unreachable (nothing was written).
_STORE_BUSY = {
    "description": "The board's storage is busy (`StoreBusy`: throttled, or too many pushes at "
                   "once) or did not answer (`StoreUnavailable`); nothing was written. Try again "
                   "after Retry-After seconds.",
    "headers": {"Retry-After": {"description": "Seconds to wait.", "schema": {"type": "integer"}}},
    "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorBody"}}},
}


def openapi_document() -> str:
    """The OpenAPI document of the three functions' routes, as committed in functions/openapi.json.

    It is Powertools' document for ``build_app(push_router, pull_router, admin_router)`` plus the
    503 every route may answer (a busy store), less one thing that is not true of this API: the
    default "422 Validation Error" Powertools lists on every validated route. Here a bad query
    or path parameter answers 400 and a bad body 422, both with an :class:`ErrorBody`, and the
    routes list those responses themselves."""
    document = json.loads(build_app(push_router, pull_router, admin_router).get_openapi_json_schema())
    for operations in document["paths"].values():
        for operation in operations.values():
            operation["responses"]["503"] = _STORE_BUSY
            default = operation["responses"].get("422", {})
            if default.get("content", {}).get("application/json", {}).get("schema", {}).get(
                    "$ref") == _DEFAULT_422:
                del operation["responses"]["422"]
    schemas = document["components"]["schemas"]
    if _DEFAULT_422 not in json.dumps(document["paths"]):
        schemas.pop("HTTPValidationError", None)
        schemas.pop("ValidationError", None)
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"


def main() -> None:  # pragma: no cover - exercised through test_openapi's drift check
    sys.stdout.write(openapi_document())


if __name__ == "__main__":  # pragma: no cover
    main()
