"""The leaderboard's HTTP routes: Powertools routers for the push and pull functions.

Both Lambda functions and ``drboard serve`` build their resolver with :func:`build_app`, so the
routes, the validation, the error statuses and the OpenAPI document are the same everywhere.

- The routes never build a service: the caller puts one in the resolver's context before each
  ``resolve`` (``app.append_context(service=...)``); the routes reach it through ``Depends``.
- The typed domain errors become HTTP statuses in one place, :func:`_register_error_handlers`;
  every error body is ``{"error": <name>, "message": ..., "detail": [{"loc", "msg", "type"}]}``
  (the message says what went wrong; the detail, when there is one, says where).
- The push body is bounded before it is parsed: the resolver's JSON body deserializer refuses a
  body over ``limits.MAX_RECORD_BYTES`` (413) before ``json.loads`` sees it, then Powertools
  validates the parsed body as a :class:`Record` (422 with field-level detail). This keeps the
  request body documented as the Record schema in the OpenAPI document, with no second parser.
  (Powertools runs request validation before any middleware, so a middleware could not check
  the size first.) A form-encoded body is parsed by Powertools' own form parser and refused as
  422, an unknown content type as 415; API Gateway bounds every body at 10 MB anyway.

Run ``python -m drboard_functions.routes > functions/openapi.json`` to regenerate the committed
OpenAPI document (``tests/unit/test_openapi.py`` fails when it drifts from the code).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from http import HTTPStatus
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as distribution_version
from typing import Annotated, Any
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
from aws_lambda_powertools.event_handler.openapi.models import APIKey, APIKeyIn, Server
from aws_lambda_powertools.event_handler.openapi.params import Body, Path, Query
from aws_lambda_powertools.event_handler.openapi.types import OpenAPIResponse
from drboard_assembler import __version__ as assembler_version
from drboard_assembler import limits
from drboard_assembler.errors import field_path
from drboard_assembler.record import Record
from pydantic import BaseModel, ConfigDict, Field

from . import web
from .errors import (
    BoardMismatch,
    BoardNotFound,
    DomainError,
    InvalidQuery,
    InvalidSubmission,
    RacerNotFound,
    SubmissionTooLarge,
    TooSoon,
)
from .models import MAX_PAGE, BoardPage, BoardView, PushReceipt, RacerView
from .service import MAX_CURSOR_CHARS, LeaderboardService

TITLE = "drboard"
DEFAULT_LIMIT = 100
MAX_PATH_PARAM_CHARS = 256  # a board id or a racer alias, percent-encoded
HTML = "text/html; charset=utf-8"
#: The web pages load nothing and run no script: only their own inline style.
PAGE_HEADERS = {
    "Content-Security-Policy": "default-src 'none'; style-src 'unsafe-inline'; base-uri 'none'; "
                               "form-action 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Cache-Control": "no-store",
}
SIGV4 = "sigv4"

push_router = Router()
pull_router = Router()


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


class BoardList(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    boards: list[BoardView]


def _error_response(description: str) -> OpenAPIResponse:
    return {"description": description, "content": {"application/json": {"model": ErrorBody}}}


def _json_response(description: str, model: type[BaseModel]) -> OpenAPIResponse:
    return {"description": description, "content": {"application/json": {"model": model}}}


_PAGE_RESPONSE: OpenAPIResponse = {
    "description": "The web page.",
    "content": {"text/html": {"schema": {"type": "string"}}},
}

# ---- request parameters ------------------------------------------------------------------------

BoardId = Annotated[str, Path(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                              description="The board's id: a track's default board is its id, "
                                          "`<track>_cw` for clockwise runs.")]
RacerAlias = Annotated[str, Path(min_length=1, max_length=MAX_PATH_PARAM_CHARS,
                                 description="The racer's alias (any case).")]
Limit = Annotated[int, Query(ge=1, le=MAX_PAGE, description="How many entries (1..500).")]
Cursor = Annotated[str | None, Query(max_length=MAX_CURSOR_CHARS,
                                     description="`next_cursor` of the previous page.")]


def current_service(request: Request) -> LeaderboardService:
    """The service the caller put in the resolver's context for this request."""
    service = request.context.get("service")
    if not isinstance(service, LeaderboardService):
        raise RuntimeError("no LeaderboardService in the resolver's context: "
                           "call app.append_context(service=...) before app.resolve")
    return service


Service = Annotated[LeaderboardService, Depends(current_service)]


def _segment(value: str) -> str:
    """A path parameter as the racer typed it: API Gateway's rawPath keeps percent-encoding."""
    return unquote(value)


def bounded_json(body: str) -> Any:
    """The resolver's JSON body parser: a body over the record size bound is refused unparsed."""
    if len(body) > limits.MAX_RECORD_BYTES or len(body.encode("utf-8")) > limits.MAX_RECORD_BYTES:
        raise SubmissionTooLarge(
            f"the request body is over {limits.MAX_RECORD_BYTES} bytes, the bound of a record")
    return json.loads(body)


# ---- push ---------------------------------------------------------------------------------------


@push_router.post(
    "/boards/<board>/submissions",
    cors=False,
    status_code=HTTPStatus.CREATED,
    summary="Submit a run",
    description="Validates the record (derived figures, submission id, plausible laps) and stores "
                "it on the board. 201 for a new submission, 200 when the same run was already "
                "submitted (nothing changes). Requests must be signed with SigV4 (IAM).",
    tags=["submissions"],
    security=[{SIGV4: []}],
    responses={
        201: _json_response("The submission was stored.", PushReceipt),
        200: _json_response("The same run was already submitted; nothing changed.", PushReceipt),
        404: _error_response("No such board, and the run's own board is another one."),
        413: _error_response(f"The body is over {limits.MAX_RECORD_BYTES} bytes."),
        415: _error_response("The body is not JSON."),
        422: _error_response("The record is invalid or does not belong on this board."),
        429: {**_error_response("A submission limit applies; see Retry-After."),
              "headers": {"Retry-After": {"description": "Seconds to wait.",
                                          "schema": {"type": "integer"}}}},
    },
)
def submit(
    board: BoardId,
    record: Annotated[Record, Body(description="The record `drboard assemble` builds.")],
    service: Service,
) -> Response[PushReceipt]:
    receipt = service.push(record, _segment(board))
    status = HTTPStatus.CREATED if receipt.status == "created" else HTTPStatus.OK
    return Response(status_code=status, content_type=content_types.APPLICATION_JSON, body=receipt)


# ---- pull ---------------------------------------------------------------------------------------


@pull_router.get("/boards", summary="List the boards", tags=["boards"],
                 response_description="Every board, by id.")
def list_boards(service: Service) -> BoardList:
    return BoardList(boards=service.boards())


@pull_router.get(
    "/boards/<board>",
    summary="A board's standings",
    description="The board and its entries in rank order, `limit` at a time; pass the answer's "
                "`next_cursor` as `cursor` for the next page.",
    tags=["boards"],
    responses={200: _json_response("The board and one page of its entries.", BoardPage),
               400: _error_response("A bad limit or cursor."),
               404: _error_response("No such board.")},
)
def get_board(board: BoardId, service: Service, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None) -> BoardPage:
    return service.board_page(_segment(board), limit=limit, cursor=cursor or None)


@pull_router.get(
    "/boards/<board>/racers/<racer>",
    summary="A racer's entry and history on a board",
    description="The racer's best entry, its rank, every submission, and the best run's full record "
                "(design, laps, training).",
    tags=["boards"],
    responses={200: _json_response("The racer's entry, history and best record.", RacerView),
               400: _error_response("A bad board id or racer alias."),
               404: _error_response("No such board, or the racer has no entry on it.")},
)
def get_racer(board: BoardId, racer: RacerAlias, service: Service) -> RacerView:
    return service.racer(_segment(board), _segment(racer))


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
def board_view(board: BoardId, service: Service, limit: Limit = DEFAULT_LIMIT,
               cursor: Cursor = None) -> Response[str]:
    page = service.board_page(_segment(board), limit=limit, cursor=cursor or None)
    return _page(web.board_page(page))


def _page(html: str, status: int = HTTPStatus.OK,
          headers: dict[str, str] | None = None) -> Response[str]:
    return Response(status_code=status, content_type=HTML, body=html,
                    headers=PAGE_HEADERS | (headers or {}))


# ---- errors: the one place where domain errors become HTTP statuses ---------------------------

#: Checked in order: the first class the error is an instance of gives its status.
ERROR_STATUS: tuple[tuple[type[DomainError], HTTPStatus], ...] = (
    (InvalidSubmission, HTTPStatus.UNPROCESSABLE_ENTITY),
    (BoardMismatch, HTTPStatus.UNPROCESSABLE_ENTITY),
    (SubmissionTooLarge, HTTPStatus.REQUEST_ENTITY_TOO_LARGE),
    (BoardNotFound, HTTPStatus.NOT_FOUND),
    (RacerNotFound, HTTPStatus.NOT_FOUND),
    (InvalidQuery, HTTPStatus.BAD_REQUEST),
    (TooSoon, HTTPStatus.TOO_MANY_REQUESTS),
)


def status_of(error: DomainError) -> HTTPStatus:
    for kind, status in ERROR_STATUS:
        if isinstance(error, kind):
            return status
    return HTTPStatus.BAD_REQUEST  # a domain error is raised on purpose: the request is at fault


def _problems(errors: Sequence[Any]) -> tuple[str, list[dict[str, str]]]:
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
        problems.append({"loc": field_path(loc) or ("record" if where == "body" else where),
                         "msg": msg, "type": kind})
    return where, problems


def _answer(app: APIGatewayHttpResolver, status: HTTPStatus, error: str, message: str,
            detail: list[dict[str, str]] | None = None,
            headers: dict[str, str] | None = None) -> Response[Any]:
    problems = [{"loc": str(d.get("loc", "")), "msg": str(d.get("msg", "")),
                 "type": str(d.get("type", "value_error"))} for d in detail or []]
    body = ErrorBody.model_validate({"error": error, "message": message, "detail": problems})
    if _is_page_request(app):
        return _page(web.error_page(status.value, status.phrase, message), status, headers)
    return Response(status_code=status, content_type=content_types.APPLICATION_JSON,
                    body=body.model_dump(mode="json"), headers=headers)


def _is_page_request(app: APIGatewayHttpResolver) -> bool:
    route = app.context.get("_route")
    return route is not None and "pages" in route.tags


def _register_error_handlers(app: APIGatewayHttpResolver) -> None:
    @app.exception_handler(DomainError)
    def domain_error(error: DomainError) -> Response[Any]:
        status = status_of(error)
        headers = {"Retry-After": str(max(0, error.retry_after_s))} if isinstance(error, TooSoon) else None
        return _answer(app, status, type(error).__name__, error.message, error.detail, headers)

    @app.exception_handler(RequestValidationError)
    def invalid_request(error: RequestValidationError) -> Response[Any]:
        where, problems = _problems(error.errors())
        if where == "body":
            json_error = next((p for p in problems if p["type"] == "json_invalid"), None)
            if json_error:
                return _answer(app, HTTPStatus.UNPROCESSABLE_ENTITY, InvalidSubmission.__name__,
                               "the request body is not valid JSON", [json_error])
            count = f" ({len(problems)} problems)" if len(problems) > 1 else ""
            return _answer(app, HTTPStatus.UNPROCESSABLE_ENTITY, InvalidSubmission.__name__,
                           f"the record is invalid{count}", problems)
        return _answer(app, HTTPStatus.BAD_REQUEST, InvalidQuery.__name__,
                       f"invalid {where} parameter", problems)

    @app.exception_handler(RequestUnsupportedContentType)
    def unsupported_body(error: RequestUnsupportedContentType) -> Response[Any]:
        return _answer(app, HTTPStatus.UNSUPPORTED_MEDIA_TYPE, InvalidSubmission.__name__,
                       "send the record as application/json")


# ---- the resolver -----------------------------------------------------------------------------


def build_app(*routers: Router) -> APIGatewayHttpResolver:
    """A resolver with these routers, validation, CORS for the reads, and the error statuses.

    Give each resolver its own call: a Router serves the resolver that included it last, which
    is fine because the routes read only the resolver's own request and context."""
    app = APIGatewayHttpResolver(
        cors=CORSConfig(allow_origin="*", allow_headers=["Content-Type"], max_age=600),
        enable_validation=True,
        response_validation_error_http_code=HTTPStatus.INTERNAL_SERVER_ERROR,
        json_body_deserializer=bounded_json,
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
                    "are signed with SigV4 (IAM).",
        servers=[Server(url="/")],
        tags=["submissions", "boards", "pages"],
        security_schemes={SIGV4: APIKey.model_validate({
            "type": "apiKey", "name": "Authorization", "in": APIKeyIn.header.value,
            "description": "AWS Signature Version 4 (API Gateway IAM authorisation).",
            "x-amazon-apigateway-authtype": "awsSigv4",
        })},
    )
    return app


_DEFAULT_422 = "#/components/schemas/HTTPValidationError"


def openapi_document() -> str:
    """The OpenAPI document of both functions' routes, as committed in functions/openapi.json.

    It is Powertools' document for ``build_app(push_router, pull_router)`` less one thing that
    is not true of this API: the default "422 Validation Error" Powertools lists on every
    validated route. Here a bad query or path parameter answers 400 and a bad body 422, both
    with an :class:`ErrorBody`, and the routes list those responses themselves."""
    document = json.loads(build_app(push_router, pull_router).get_openapi_json_schema())
    for operations in document["paths"].values():
        for operation in operations.values():
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
