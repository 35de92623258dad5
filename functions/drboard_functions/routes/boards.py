"""The public reads: boards, standings, racers, comparisons, insights, and how to sign in."""

from __future__ import annotations

from http import HTTPStatus
from typing import Annotated, Any

from aws_lambda_powertools.event_handler import (
    Depends,
    Response,
    content_types,
)

from ..identity import SignIn
from ..models.racer_views import Comparison, Insights, RacerHistory, RacerSummary, RacerView
from ..models.views import BoardList, BoardPage
from ..service import DEFAULT_TOP
from ..views import page_tag
from .headers import etag_headers, names_etag, page_etag
from .kept import Wanted, answer
from .params import (
    DEFAULT_LIMIT,
    BoardId,
    Compared,
    Cursor,
    IfNoneMatch,
    Limit,
    OnBoard,
    RacerAlias,
    Service,
    Top,
    current_sign_in,
    pull_router,
    segment,
)
from .responses import BAD_PATH, error_response, json_response
from .standings import standings_of


@pull_router.get(
    "/boards",
    summary="List the boards",
    description="The boards by id, `limit` at a time; pass the answer's `next_cursor` as "
                "`cursor` for the next page, until it is null. (A page may hold fewer than "
                "`limit` boards: deleted boards are left out.)",
    tags=["boards"],
    responses={200: json_response("One page of the boards, by id.", BoardList),
               400: error_response("A bad limit or cursor.")},
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
                "few seconds). Like every public read, it carries `Cache-Control: public, "
                "max-age=2, stale-while-revalidate=2`: a CDN or a browser may keep it two seconds.",
    tags=["boards"],
    responses={200: json_response("The board and one page of its entries.", BoardPage),
               304: {"description": "Unchanged since the `ETag` sent in `If-None-Match`."},
               400: error_response("A bad limit or cursor."),
               404: error_response("No such board.")},
)
def get_board(board: BoardId, service: Service, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None, if_none_match: IfNoneMatch = None) -> Response[Any]:
    board_id = segment(board)
    if not cursor:  # the top page: kept as bytes, rendered once per board version
        kept = answer(standings_of(service).copy(Wanted(board_id, "json", limit)), if_none_match)
        return Response(status_code=int(kept.status), content_type=None, body=kept.text,
                        headers=kept.headers)
    if if_none_match:
        etag = page_etag(service.board_tag(board_id), limit, cursor)
        if names_etag(if_none_match, etag):
            return Response(status_code=HTTPStatus.NOT_MODIFIED, body="", headers=etag_headers(etag))
    page = service.board_page(board_id, limit=limit, cursor=cursor)
    return Response(status_code=HTTPStatus.OK, content_type=content_types.APPLICATION_JSON,
                    body=page.model_dump_json(),
                    headers=etag_headers(page_etag(page_tag(page.board), limit, cursor)))


@pull_router.get(
    "/boards/<board>/racers/<racer>",
    summary="A racer's entry and history on a board",
    description="The racer's best entry, its rank, the best run's full record (design, laps, "
                "training) and their submissions on the board, oldest first, `limit` at a "
                "time: pass the answer's `next_cursor` as `cursor` for the next ones.",
    tags=["boards"],
    responses={200: json_response("The racer's entry, best record and one page of their "
                                   "history.", RacerView),
               400: error_response(BAD_PATH + " Or a bad limit or cursor."),
               404: error_response("No such board, or the racer has no entry on it.")},
)
def get_racer(board: BoardId, racer: RacerAlias, service: Service, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None) -> RacerView:
    return service.racer(segment(board), segment(racer), limit, cursor or None)


@pull_router.get(
    "/boards/<board>/compare",
    summary="Racers' designs side by side",
    description="Two to four racers' designs as comparable facts (algorithm, action space, top "
                "speed, steering, sensors, hyperparameters, training), and the facts they differ on.",
    tags=["boards"],
    responses={200: json_response("The racers' entries and design facts.", Comparison),
               400: error_response("Fewer than two racers, or more than four."),
               404: error_response("No such board, or a racer has no entry on it.")},
)
def get_comparison(board: BoardId, service: Service, racer: Compared) -> Comparison:
    return service.compare(segment(board), racer)


@pull_router.get(
    "/boards/<board>/insights",
    summary="What the top models share",
    description="Each design fact of the board's top `top` qualified models against the field "
                "(its first 100 entries), and every entry's top speed against its time.",
    tags=["boards"],
    responses={200: json_response("The shared facts and the speed points.", Insights),
               400: error_response("A bad `top`."),
               404: error_response("No such board.")},
)
def get_insights(board: BoardId, service: Service, top: Top = DEFAULT_TOP) -> Insights:
    return service.insights(segment(board), top)


@pull_router.get(
    "/racers/<racer>",
    summary="Where a racer stands",
    description="On each board the racer pushed to (or on `board` only), latest first: their "
                "latest submission, their best entry's rank and gap, how many submissions they "
                "made and have left, and when they may submit next.",
    tags=["racers"],
    responses={200: json_response("The racer's standing on each board.", RacerSummary),
               400: error_response(BAD_PATH),
               404: error_response("No such board, or the racer has no submissions (on it).")},
)
def get_racer_status(racer: RacerAlias, service: Service, board: OnBoard = None) -> RacerSummary:
    return service.status(segment(racer), board)


@pull_router.get(
    "/racers/<racer>/submissions",
    summary="A racer's submissions",
    description="The racer's submissions on every board (or on `board` only), oldest first, "
                "`limit` at a time: pass the answer's `next_cursor` as `cursor` for the next "
                "page, until it is null. `is_best` marks the one that counts on its board. "
                "`racer` is the alias as asked. A racer with no submissions has an empty history.",
    tags=["racers"],
    responses={200: json_response("One page of the racer's submissions, oldest first.",
                                   RacerHistory),
               400: error_response(BAD_PATH + " Or a bad limit or cursor."),
               404: error_response("No such board.")},
)
def get_racer_history(racer: RacerAlias, service: Service, board: OnBoard = None,
                      limit: Limit = DEFAULT_LIMIT, cursor: Cursor = None) -> RacerHistory:
    return service.history_page(segment(racer), board, limit, cursor or None)


@pull_router.get(
    "/.well-known/drboard.json",
    summary="How to sign in to this board",
    description="What `drboard login --endpoint URL` needs: `kind` is `cognito` (a deployed "
                "board: its user pool, public app client, hosted sign-in domain and scopes; "
                "signed-in requests go to the same routes under `/cognito`), `join-code` (a "
                "`drboard serve` board: `POST /join` with the organiser's code) or `none`.",
    tags=["racers"],
    responses={200: json_response("How racers sign in.", SignIn)},
)
def well_known(sign_in: Annotated[SignIn, Depends(current_sign_in)]) -> SignIn:
    return sign_in
