"""Seasons: the public reads (the seasons, a season's standings, its web page) on the pull
router. The organisers' changes are in :mod:`.season_changes`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from aws_lambda_powertools.event_handler import Request, Response
from aws_lambda_powertools.event_handler.openapi.params import Query

from ..models.domain import MAX_PAGE
from ..models.seasons import SeasonList, SeasonStandings
from .params import (
    DEFAULT_LIMIT,
    Cursor,
    Limit,
    Screen,
    SeasonId,
    Service,
    pull_router,
    segment,
)
from .responses import PAGE_RESPONSE, error_response, json_response, page_answer

if TYPE_CHECKING:  # the pages' modules load with the season pages (the admin function draws none)
    from .. import season_page

SEASONS_TAG = "seasons"

Part = Annotated[int, Query(ge=1, le=MAX_PAGE, description="The big screen's page of racers "
                                                           "(it moves on to the next by itself).")]

_NO_SEASON = "No such season."


# ---- reads ------------------------------------------------------------------------------------


@pull_router.get(
    "/seasons",
    summary="List the seasons",
    description="The seasons by id, running and past, `limit` at a time; pass the answer's "
                "`next_cursor` as `cursor` for the next page, until it is null.",
    tags=[SEASONS_TAG],
    responses={200: json_response("One page of the seasons, by id.", SeasonList),
               400: error_response("A bad limit or cursor.")},
)
def list_seasons(service: Service, limit: Limit = DEFAULT_LIMIT, cursor: Cursor = None) -> SeasonList:
    return service.seasons_page(limit, cursor or None)


@pull_router.get(
    "/seasons/<season>",
    summary="A season's standings",
    description="The season (its points table, best-of, rounds, final and tie-breaks) and its "
                "standings, best first, `limit` racers at a time: each racer's points, round "
                "wins, best finish, whether they qualify for the final, and their place and "
                "points on each round, `counted` false for a round that does not count.",
    tags=[SEASONS_TAG],
    responses={200: json_response("The season and one page of its standings.", SeasonStandings),
               400: error_response("A bad limit or cursor."),
               404: error_response(_NO_SEASON)},
)
def get_season(season: SeasonId, service: Service, limit: Limit = DEFAULT_LIMIT,
               cursor: Cursor = None) -> SeasonStandings:
    return service.season(segment(season), limit, cursor or None)


@pull_router.get("/seasons/view", summary="The seasons' web page", tags=["pages"],
                 responses={200: PAGE_RESPONSE})
def seasons_view(service: Service) -> Response[str]:
    from .. import season_page

    page = season_page.seasons_page(service.seasons())
    return page_answer(page.html, headers=_policy(page))


@pull_router.get(
    "/seasons/<season>/view",
    summary="A season's web page",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 404: error_response(_NO_SEASON)},
)
def season_view(season: SeasonId, service: Service, request: Request, screen: Screen = False,
                part: Part = 1) -> Response[str]:
    from .. import season_page, web
    from .pages import _invite

    season_id = segment(season)
    view = service.season(season_id, MAX_PAGE)
    origin = _invite(request).endpoint  # the network's address on serve
    page = season_page.season_page(view, screen=screen, part=part,
                                   url=origin + web.season_path(season_id), origin=origin)
    return page_answer(page.html, headers=_policy(page))


@pull_router.get(
    "/seasons/<season>/podium/view",
    summary="A season's podium page: its card and the certificates to print",
    description="The season's podium card, and a certificate for each racer of its first three "
                "ranks (equal points share a rank), which print one to an A4 landscape page.",
    tags=["pages"],
    responses={200: PAGE_RESPONSE, 404: error_response(_NO_SEASON)},
)
def podium_view(season: SeasonId, service: Service, request: Request) -> Response[str]:
    from .. import season_page
    from .pages import _invite

    view = service.season(segment(season), MAX_PAGE)
    page = season_page.podium_page(view, origin=_invite(request).endpoint, now=service.clock())
    return page_answer(page.html, headers=_policy(page))


def _policy(page: season_page.Page) -> dict[str, str]:
    return {"Content-Security-Policy": page.content_security_policy}
