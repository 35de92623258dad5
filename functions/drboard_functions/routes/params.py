"""What every route module shares: the three routers, the request parameters, who is calling, and
the JSON body each route takes with its bound.

A body's bound is checked before it is parsed (see :mod:`.app`): a record's is
``limits.MAX_RECORD_BYTES``; an imported submission's, a record plus a little for its timestamp
(its record is then held to the record's own bound); a board's settings, 16 KiB.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Annotated, Any, NamedTuple, TypeVar
from urllib.parse import unquote

from aws_lambda_powertools.event_handler import (
    APIGatewayHttpResolver,
    Depends,
    Request,
)
from aws_lambda_powertools.event_handler.api_gateway import Router
from aws_lambda_powertools.event_handler.openapi.params import Header, Path, Query
from drboard_assembler import limits
from pydantic import StringConstraints

from ..cursors import MAX_CURSOR_CHARS
from ..errors import (
    DomainError,
    InvalidQuery,
    InvalidSubmission,
    NotAuthorized,
    SubmissionTooLarge,
)
from ..identity import Caller, SignIn, caller_from_event
from ..models.domain import MAX_PAGE
from ..service import MAX_COMPARED, MAX_TOP, LeaderboardService
from .headers import origin_of

DEFAULT_LIMIT = 100
MAX_PATH_PARAM_CHARS = 256  # a board id or a racer alias, percent-encoded
#: A board's settings (title, description, track, window, limits): well under this in JSON.
MAX_BOARD_BODY_BYTES = 16 * limits.KIB
#: An imported submission is a record and its first submission time: room for the envelope.
IMPORT_HEADROOM_BYTES = 4 * limits.KIB
SIGV4 = "sigv4"
#: The tag of every organiser route: IAM-signed in the cloud, loopback only on `drboard serve`.
ADMIN_TAG = "admin"
#: What every organiser route declares: no CORS, the organisers' tag, IAM-signed requests. One
#: tag only: Powertools keeps an operation's tags in a set, so two would come out in any order.
ADMIN_ROUTE: dict[str, Any] = {"cors": False, "tags": [ADMIN_TAG], "security": [{SIGV4: []}]}
#: An organiser route's 404.
NO_BOARD = "No such board (or it was deleted)."

#: The push function's routes (:mod:`.submissions`), the pull function's (:mod:`.boards`, :mod:`.pages`),
#: the admin function's (:mod:`.organisers`) and the card function's (:mod:`.cards`).
push_router = Router()
pull_router = Router()
admin_router = Router()
card_router = Router()

# ---- request parameters ------------------------------------------------------------------------

BoardId = Annotated[str, Path(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                              description="The board's id: a track's default board is its id, "
                                          "`<track>_cw` for clockwise runs.")]
SeasonId = Annotated[str, Path(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                               description="The season's id.")]
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
ReplaceHolder = Annotated[bool, Query(description="Move the alias from the sign-in that holds it.")]
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


def current_sign_in(request: Request) -> SignIn:
    sign_in = request.context.get("sign_in")
    return sign_in if isinstance(sign_in, SignIn) else SignIn()


def segment(value: str) -> str:
    """A path parameter as the racer typed it: API Gateway's rawPath keeps percent-encoding."""
    return unquote(value)


def origin(event: Any) -> str:
    """The scheme and host the client used to reach the board (https behind API Gateway)."""
    return origin_of(event.headers or {}, (event.raw_event.get("requestContext") or {}).get("domainName"))


# ---- request bodies: what each route takes, and its bound --------------------------------------


class RequestBody(NamedTuple):
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
ASSIGNMENT_BODY = RequestBody("assignment", limits.KIB, InvalidQuery)

_BODIES: dict[Callable[..., Any], RequestBody] = {}
F = TypeVar("F", bound=Callable[..., Any])


def takes(body: RequestBody) -> Callable[[F], F]:
    """Declare the JSON body a route takes (under its router's decorator)."""
    def register(route: F) -> F:
        _BODIES[route] = body
        return route
    return register


def route_body(app: APIGatewayHttpResolver) -> RequestBody:
    route = app.context.get("_route")
    return _BODIES.get(route.func, RECORD_BODY) if route is not None else RECORD_BODY


def bounded_json(body: str, bound: RequestBody = RECORD_BODY) -> Any:
    """Parse a JSON request body; a body over its route's bound is refused unparsed (413)."""
    if len(body) > bound.max_bytes or len(body.encode("utf-8")) > bound.max_bytes:
        raise SubmissionTooLarge(
            f"the request body is over {bound.max_bytes} bytes, the bound of {bound.what}")
    try:
        parsed = json.loads(body)
    except json.JSONDecodeError:
        raise  # Powertools answers it as a body that is not JSON, with where parsing stopped
    except (ValueError, RecursionError) as error:  # a number over 4,300 digits; too deep a nesting
        reason = "nested too deeply" if isinstance(error, RecursionError) else str(error).split(":")[0]
        raise bound.invalid(f"{bound.what} cannot be read: {reason}",
                            detail=[{"loc": bound.name, "msg": reason, "type": "value_error"}]) from None
    if not isinstance(parsed, dict):  # an array holding a record is not a record
        kind = type(parsed).__name__.replace("list", "an array").replace("dict", "an object")
        reason = f"the body must be a JSON object, not {kind}"
        raise bound.invalid(f"{bound.what} is not a JSON object",
                            detail=[{"loc": bound.name, "msg": reason, "type": "model_type"}])
    return parsed
