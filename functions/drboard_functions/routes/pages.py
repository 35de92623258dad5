"""The web pages, on the pull router: HTML built by :mod:`drboard_functions.web`.

`drboard serve` puts an ``invite`` in the resolver's context (a function answering a
:class:`~drboard_functions.web.Invite`): the board's network address and join code, which the
pages show instead of the address the browser used (a screen opened as ``localhost`` on the
serving laptop must still tell racers the address their laptops reach)."""

from __future__ import annotations

from http import HTTPStatus

from aws_lambda_powertools.event_handler import Request, Response

from .. import web
from ..errors import BoardNotFound
from ..models.domain import MAX_PAGE
from ..service import DEFAULT_TOP
from ..views import page_tag
from .headers import etag_headers, names_etag, page_etag
from .kept import Kind, Wanted, answer
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
    origin,
    pull_router,
    segment,
)
from .responses import PAGE_RESPONSE, error_response, page_answer, page_policy
from .standings import standings_of


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
    view: Kind = "screen" if screen else "view"
    invite = _invite(request)
    try:
        if not cursor:  # the top page: kept as bytes, rendered once per board version
            kept = answer(standings_of(service).copy(Wanted(board_id, view, limit), invite),
                          if_none_match)
            return Response(status_code=int(kept.status), content_type=None, body=kept.text,
                            headers=kept.headers)
        if if_none_match:
            etag = page_etag(f"{view}.{service.board_tag(board_id)}", limit, cursor)
            if names_etag(if_none_match, etag):
                return page_answer("", HTTPStatus.NOT_MODIFIED, etag_headers(etag))
        page = service.board_page(board_id, limit=limit, cursor=cursor)
    except BoardNotFound:  # a screen set up before the first push waits for the board
        return page_answer(web.waiting_page(board_id, screen, join_code=invite.code,
                                            endpoint=invite.endpoint),
                           HTTPStatus.NOT_FOUND, page_policy(live=True))
    etag = page_etag(f"{view}.{page_tag(page.board)}", limit, cursor)
    url = invite.join_url if invite.code else invite.endpoint + web.board_path(board_id)
    html = web.board_page(page, etag, screen=screen, now=service.clock(), url=url,
                          endpoint=invite.endpoint, qr_svg=web.qr_svg(url) if screen else "",
                          join_code=invite.code, seasons=service.board_seasons(board_id))
    return page_answer(html, headers=page_policy(live=True) | etag_headers(etag))


def _invite(request: Request) -> web.Invite:
    """How racers reach this board: what `drboard serve` says, else the origin the client used
    (https behind API Gateway), with no join code."""
    given = request.context.get("invite")
    if callable(given):
        invite = given()
        if isinstance(invite, web.Invite):
            return invite
    return web.Invite(endpoint=origin(request.resolved_event))


@pull_router.get(
    "/boards/<board>/racers/<racer>/view",
    summary="A racer's web page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 404: error_response("No such board or racer.")},
)
def racer_view(board: BoardId, racer: RacerAlias, service: Service, request: Request) -> Response[str]:
    view = service.racer(segment(board), segment(racer), MAX_PAGE)
    leader = ahead = None
    if view.entry.rank > 1 and view.record is not None:
        # the racers to compare with: the leader, and the one just ahead on a short enough board
        above = service.board_page(view.board.board_id, limit=min(view.entry.rank - 1, MAX_PAGE),
                                   cursor=None).entries
        leader = above[0].racer if above else None
        ahead = above[-1].racer if above and view.entry.rank - 1 <= MAX_PAGE else None
    return page_answer(web.racer_page(view, leader=leader, ahead=ahead,
                                      origin=_invite(request).endpoint))


@pull_router.get(
    "/boards/<board>/compare/view",
    summary="The compare page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 400: error_response("Fewer than two racers, or more than four."),
               404: error_response("No such board or racer.")},
)
def compare_view(board: BoardId, service: Service, racer: Compared) -> Response[str]:
    board_id = segment(board)
    comparison = service.compare(board_id, racer)
    records = [service.racer(board_id, compared.racer, 1).record for compared in comparison.racers]
    return page_answer(web.compare_page(comparison, records))


@pull_router.get(
    "/boards/<board>/insights/view",
    summary="The insights page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 404: error_response("No such board.")},
)
def insights_view(board: BoardId, service: Service, top: Top = DEFAULT_TOP) -> Response[str]:
    return page_answer(web.insights_page(service.insights(segment(board), top)))
