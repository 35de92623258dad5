"""What the routes answer: the error body, the OpenAPI descriptions of answers, and JSON and
HTML answers (their headers and ETags: :mod:`.headers`)."""

from __future__ import annotations

from http import HTTPStatus
from typing import TYPE_CHECKING, Any

from aws_lambda_powertools.event_handler import Response, content_types
from aws_lambda_powertools.event_handler.openapi.types import OpenAPIResponse
from pydantic import BaseModel, ConfigDict, Field

from .headers import HTML, PAGE_HEADERS

if TYPE_CHECKING:
    from .params import RequestBody

# ---- response and error models --------------------------------------------------------------


class FieldProblem(BaseModel):
    """One problem with one field: ``loc`` is a path such as ``evaluations[0].laps[2].time_ms``."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    loc: str
    msg: str
    type: str


class ErrorBody(BaseModel):
    """Every error answer: the domain error's name, a message for people, and field detail."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    error: str
    message: str
    detail: list[FieldProblem] = Field(default_factory=list)


def error_response(description: str) -> OpenAPIResponse:
    return {"description": description, "content": {"application/json": {"model": ErrorBody}}}


def json_response(description: str, model: type[BaseModel]) -> OpenAPIResponse:
    return {"description": description, "content": {"application/json": {"model": model}}}


PAGE_RESPONSE: OpenAPIResponse = {
    "description": "The web page.",
    "content": {"text/html": {"schema": {"type": "string"}}},
}
BAD_PATH = "A bad board id or racer alias (too long)."
UNREADABLE = (" Or a body that cannot be read as its headers say (`UnreadableBody`): a "
              "Content-Length that is not its length, base64 that does not decode, text that "
              "is not UTF-8.")
UNSIGNED = ("Not signed with SigV4 by an identity allowed to invoke the route (API Gateway's own "
            "answer, without an `error` name); on `drboard serve`, a request from another "
            "computer than the one serving (`NotAuthorized`).")


def admin_responses(ok: OpenAPIResponse, *, ok_status: int = HTTPStatus.OK,
                     body: RequestBody | None = None,
                     errors: dict[int, str] | None = None,
                     also: dict[int, OpenAPIResponse] | None = None) -> dict[int, OpenAPIResponse]:
    """An organiser route's answers: its own, the refusal of unsigned requests, a body's (413,
    415, 422), then its own errors and other answers (which replace the general ones)."""
    responses: dict[int, OpenAPIResponse] = {ok_status: ok, 400: error_response(BAD_PATH),
                                             403: error_response(UNSIGNED)}
    if body is not None:
        verb = "are" if body.name.endswith("s") else "is"
        responses[400] = error_response(BAD_PATH + UNREADABLE)
        responses[413] = error_response(f"The body is over {body.max_bytes} bytes.")
        responses[415] = error_response("The body is not JSON.")
        responses[422] = error_response(f"The {body.name} {verb} not valid (field-level `detail`).")
    responses |= {status: error_response(text) for status, text in (errors or {}).items()}
    return responses | (also or {})


def json_answer(status: int, body: BaseModel) -> Response[Any]:
    return Response(status_code=status, content_type=content_types.APPLICATION_JSON, body=body)


def page_answer(html: str, status: int = HTTPStatus.OK,
                headers: dict[str, str] | None = None) -> Response[str]:
    return Response(status_code=status, content_type=HTML, body=html,
                    headers=PAGE_HEADERS | page_policy() | (headers or {}))


def page_policy(*, live: bool = False) -> dict[str, str]:
    """The page's Content-Security-Policy; a live page's allows its script too."""
    from ..web import content_security_policy

    return {"Content-Security-Policy": content_security_policy(live=live)}
