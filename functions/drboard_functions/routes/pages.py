"""The web pages, on the pull router: HTML built by :mod:`drboard_functions.web`."""

from __future__ import annotations

from http import HTTPStatus
from typing import Any

from aws_lambda_powertools.event_handler import Request, Response

from .. import web
from ..errors import BoardNotFound
from ..models.domain import MAX_PAGE
from ..service import DEFAULT_TOP
from ..views import page_tag
from .params import (
    DEFAULT_LIMIT,
    BoardId,
    Compared,
    Cursor,
    IfNoneMatch,
    Limit,
    RacerAlias,
    Screen,
    Service,
    Top,
    pull_router,
    segment,
)
from .responses import PAGE_HEADERS, PAGE_RESPONSE, error_response, etag_headers, page_answer, page_etag

#: A live board page: its one inline script, allowed by hash, and requests to its own origin.
LIVE_PAGE_HEADERS = {
    "Content-Security-Policy": PAGE_HEADERS["Content-Security-Policy"]
    + f"; script-src '{web.LIVE_SCRIPT_HASH}'; connect-src 'self'",
}


@pull_router.get("/", summary="The boards' web page", tags=["pages"],
                 responses={200: PAGE_RESPONSE})
def index_page(service: Service) -> Response[str]:
    return page_answer(web.index_page(service.boards()))


@pull_router.get(
    "/boards/<board>/view",
    summary="A board's web page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 400: error_response("A bad limit or cursor."),
               404: error_response("No such board.")},
)
def board_view(board: BoardId, service: Service, request: Request, limit: Limit = DEFAULT_LIMIT,
               cursor: Cursor = None, screen: Screen = False,
               if_none_match: IfNoneMatch = None) -> Response[str]:
    board_id = segment(board)
    if screen and limit == DEFAULT_LIMIT:
        limit = MAX_PAGE  # the big screen scrolls through the whole board
    view = "screen" if screen else "view"
    try:
        if if_none_match:
            etag = page_etag(f"{view}.{service.board_tag(board_id)}", limit, cursor)
            if etag in (tag.strip() for tag in if_none_match.split(",")):
                return page_answer("", HTTPStatus.NOT_MODIFIED, etag_headers(etag))
        page = service.board_page(board_id, limit=limit, cursor=cursor or None)
    except BoardNotFound:  # a screen set up before the first push waits for the board
        return page_answer(web.waiting_page(board_id, screen), HTTPStatus.NOT_FOUND, LIVE_PAGE_HEADERS)
    etag = page_etag(f"{view}.{page_tag(page.board)}", limit, cursor)
    origin = _origin(request.resolved_event)
    url = origin + web.board_path(board_id)
    html = web.board_page(page, etag, screen=screen, now=service.clock(), url=url,
                          endpoint=origin, qr_svg=web.qr_svg(url) if screen else "",
                          seasons=service.board_seasons(board_id))
    return page_answer(html, headers=LIVE_PAGE_HEADERS | etag_headers(etag))


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
    responses={200: PAGE_RESPONSE, 404: error_response("No such board or racer.")},
)
def racer_view(board: BoardId, racer: RacerAlias, service: Service) -> Response[str]:
    return page_answer(web.racer_page(service.racer(segment(board), segment(racer), MAX_PAGE)))


@pull_router.get(
    "/boards/<board>/compare/view",
    summary="The compare page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 400: error_response("Fewer than two racers, or more than four."),
               404: error_response("No such board or racer.")},
)
def compare_view(board: BoardId, service: Service, racer: Compared) -> Response[str]:
    return page_answer(web.compare_page(service.compare(segment(board), racer)))


@pull_router.get(
    "/boards/<board>/insights/view",
    summary="The insights page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 404: error_response("No such board.")},
)
def insights_view(board: BoardId, service: Service, top: Top = DEFAULT_TOP) -> Response[str]:
    return page_answer(web.insights_page(service.insights(segment(board), top)))
