"""The resolver the functions and ``drboard serve`` answer with: what happens before a route,
and the one place domain errors become HTTP statuses.

- :class:`BoardResolver` refuses a body that cannot be read as its headers say (400
  ``UnreadableBody``: not UTF-8, bad base64, a Content-Length that is not a number or not the
  body's length) before any route or parser sees it.
- Every JSON body is bounded before it is parsed: the resolver's JSON body deserializer refuses a
  body over its route's bound (413; the bounds are in :mod:`.params`) before ``json.loads`` sees
  it; then Powertools validates the parsed body as the route's model (422 with field-level
  detail). This keeps each request body documented as its model's schema in the OpenAPI
  document, with no second parser. (Powertools runs request validation before any middleware, so
  a middleware could not check the size first.) A form-encoded body is parsed by Powertools' own
  form parser and refused as 422, a multipart one or an unknown content type as 415; API Gateway
  bounds every body at 10 MB anyway.
- The typed domain errors become HTTP statuses in one place, :data:`ERROR_STATUS`; every error
  body is ``{"error": <name>, "message": ..., "detail": [{"loc", "msg", "type"}]}`` (the message
  says what went wrong; the detail, when there is one, says where). A store error (``StoreBusy``,
  ``StoreUnavailable``) answers 503 with ``Retry-After``, on every route: nothing was written.
"""

from __future__ import annotations

import base64
import binascii
from collections.abc import Callable, Mapping, Sequence
from http import HTTPStatus
from typing import TYPE_CHECKING, Any, cast, get_type_hints

from aws_lambda_powertools.event_handler import (
    APIGatewayHttpResolver,
    CORSConfig,
    Depends,
    Response,
    content_types,
)
from aws_lambda_powertools.event_handler.api_gateway import Router
from aws_lambda_powertools.event_handler.openapi.exceptions import (
    RequestUnsupportedContentType,
    RequestValidationError,
)
from drboard_assembler.errors import field_path

from ..errors import (
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
    NotQualified,
    NotSignedIn,
    RacerNotFound,
    SeasonExists,
    SeasonLocked,
    SeasonNotFound,
    StoreBusy,
    StoreError,
    StoreFailed,
    StoreUnavailable,
    SubmissionLimitReached,
    SubmissionTooLarge,
    TooSoon,
    UnreadableBody,
    UnsupportedBody,
    WebhookNotFound,
)
from ..identity import caller_from_event
from .headers import (
    CORS_HEADERS,
    CORS_MAX_AGE_S,
    CORS_ORIGIN,
    PUBLIC_CACHE,
    api_version,
    body_etag,
    names_etag,
)
from .params import ADMIN_TAG, SIGV4, RequestBody, bounded_json, route_body
from .responses import ErrorBody, page_answer

if TYPE_CHECKING:  # Powertools' OpenAPI models: only generating the document needs them
    from aws_lambda_powertools.event_handler.openapi.models import SecurityScheme
    from aws_lambda_powertools.utilities.typing import LambdaContext



TITLE = "drboard"


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

# ---- errors: the one place where domain errors become HTTP statuses ---------------------------

#: Checked in order: the first class the error is an instance of gives its status.
ERROR_STATUS: tuple[tuple[type[DomainError], HTTPStatus], ...] = (
    (InvalidSubmission, HTTPStatus.UNPROCESSABLE_ENTITY),
    (BoardMismatch, HTTPStatus.UNPROCESSABLE_ENTITY),
    (SubmissionTooLarge, HTTPStatus.REQUEST_ENTITY_TOO_LARGE),
    (BoardNotFound, HTTPStatus.NOT_FOUND),
    (RacerNotFound, HTTPStatus.NOT_FOUND),
    (SeasonNotFound, HTTPStatus.NOT_FOUND),
    (WebhookNotFound, HTTPStatus.NOT_FOUND),
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
    (NotQualified, HTTPStatus.FORBIDDEN),
    (NotAuthorized, HTTPStatus.FORBIDDEN),
    (CopiedRun, HTTPStatus.CONFLICT),
    (BoardExists, HTTPStatus.CONFLICT),
    (BoardLocked, HTTPStatus.CONFLICT),
    (SeasonExists, HTTPStatus.CONFLICT),
    (SeasonLocked, HTTPStatus.CONFLICT),
    (StoreFailed, HTTPStatus.BAD_GATEWAY),
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
        from .. import web  # the pages' module: only the pull function has pages

        return page_answer(web.error_page(status.value, status.phrase, error.message), status, headers)
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
        body = route_body(app)
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
        body = route_body(app)
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
    raise on some of them: a multipart type without a boundary, base64 that does not decode).
    An organiser route refuses a caller who does not organise before it validates anything, so
    a racer learns nothing of its body's fields (403, not 422).

    A board's top page whose copy is kept for the board's version now is answered before the
    resolver, by the edge (the pull function, ``drboard serve``: see :mod:`.kept`); the route
    renders the others and keeps them (:mod:`.standings`). Every public read's answer (a GET
    route that is neither signed nor an organiser's) carries the CDN's Cache-Control and an
    ETag, and answers 304 to an If-None-Match naming it."""

    _public_read = False

    def resolve(self, event: Mapping[str, Any], context: LambdaContext) -> dict[str, Any]:
        problem = unreadable(event)
        if problem is not None:
            return refusal(problem)
        self._public_read = False
        answer = super().resolve(event, context)
        if self._public_read:
            return public_answer(answer, (event.get("headers") or {}).get("if-none-match"))
        return answer

    def _call_route(self, route: Any, route_arguments: dict[str, str]) -> Any:
        self._public_read = (route.method == "GET" and not route.security
                             and ADMIN_TAG not in (route.tags or ()))
        if ADMIN_TAG in (route.tags or ()):
            caller = caller_from_event(self.current_event.raw_event)
            if caller is None or not caller.organiser:
                handled = self._call_exception_handler(
                    NotAuthorized("only the board's organisers may do this"), route)
                if handled is not None:
                    return handled
        return super()._call_route(route, route_arguments)


def public_answer(answer: dict[str, Any], if_none_match: str | None) -> dict[str, Any]:
    """A public read's answer as a CDN may keep it: a 200 gets an ETag (its body's digest when
    the route gave none) and becomes 304 when the client already holds it; a 200 or 304 gets
    the public Cache-Control. An error stays as it is (never kept)."""
    status = int(answer.get("statusCode", 200))
    if status not in (HTTPStatus.OK, HTTPStatus.NOT_MODIFIED):
        return answer
    headers = dict(answer.get("headers") or {})
    headers["Cache-Control"] = PUBLIC_CACHE
    if status == HTTPStatus.OK:
        etag = headers.setdefault("ETag", body_etag(str(answer.get("body") or "")))
        if names_etag(if_none_match, etag):
            return {**answer, "statusCode": int(HTTPStatus.NOT_MODIFIED), "body": "",
                    "isBase64Encoded": False, "headers": headers}
    return {**answer, "headers": headers}


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



def settle_annotations(func: Callable[..., Any]) -> None:
    """Evaluate a route's annotations (and its dependencies') once, here: Powertools reads a
    route's type hints, and its dependencies', on every request, and with postponed annotations
    each read compiled every one of them again (about a millisecond of every request)."""
    hints = getattr(func, "__annotations__", None) or {}
    if any(isinstance(hint, str) for hint in hints.values()):
        hints = func.__annotations__ = get_type_hints(func, include_extras=True)
    for hint in hints.values():
        for meta in getattr(hint, "__metadata__", ()):
            if isinstance(meta, Depends):
                settle_annotations(meta.dependency)


#: The reads' CORS headers (the signed routes set ``cors=False``); kept copies answer the same
#: (``headers.READ_CORS``).
CORS = CORSConfig(allow_origin=CORS_ORIGIN, allow_headers=list(CORS_HEADERS), max_age=CORS_MAX_AGE_S)


def build_app(*routers: Router) -> BoardResolver:
    """A resolver with these routers, validation, CORS for the reads, and the error statuses.

    Give each resolver its own call: a Router serves the resolver that included it last, which
    is fine because the routes read only the resolver's own request and context."""
    app: BoardResolver

    def parse_body(body: str) -> Any:
        return bounded_json(body, route_body(app))

    app = BoardResolver(
        cors=CORS,
        enable_validation=True,
        response_validation_error_http_code=HTTPStatus.INTERNAL_SERVER_ERROR,
        json_body_deserializer=parse_body,
    )
    for router in routers:
        app.include_router(router)
    for route in app._static_routes + app._dynamic_routes:
        settle_annotations(route.func)
    _register_error_handlers(app)
    app.configure_openapi(
        title=TITLE,
        version=api_version(),
        summary="A collaborative leaderboard for AWS DeepRacer racers.",
        description="Push a model's evaluation as a record; read the standings, each racer's "
                    "history and how the fast models were built. Reads are public; submissions "
                    "and the organisers' routes (tag `admin`) are signed with SigV4 (IAM).",
        tags=["submissions", "boards", "racers", "seasons", ADMIN_TAG, "pages", "results", "cards"],
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
