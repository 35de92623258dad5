"""The organisers' changes to seasons (create, change, rounds, the final, close, reopen) on the
admin router (IAM-signed in the cloud; answered by ``drboard serve`` only to the computer it
runs on). Every change answers the season with its standings, as a read would."""

from __future__ import annotations

from http import HTTPStatus
from typing import Annotated

from aws_lambda_powertools.event_handler import Response
from aws_lambda_powertools.event_handler.openapi.params import Body
from aws_lambda_powertools.event_handler.openapi.types import OpenAPIResponse

from ..errors import InvalidQuery
from ..models.seasons import FinalSpec, RoundSpec, SeasonChanges, SeasonSpec, SeasonStandings
from .params import (
    ADMIN_ROUTE,
    MAX_BOARD_BODY_BYTES,
    BoardId,
    Organiser,
    RequestBody,
    SeasonId,
    Service,
    admin_router,
    segment,
    takes,
)
from .responses import admin_responses as _admin_responses
from .responses import json_answer, json_response

SEASON_BODY = RequestBody("season", MAX_BOARD_BODY_BYTES, InvalidQuery)
SEASON_CHANGES_BODY = RequestBody("changes", MAX_BOARD_BODY_BYTES, InvalidQuery)
ROUND_BODY = RequestBody("round", 1024, InvalidQuery)
FINAL_BODY = RequestBody("final", 1024, InvalidQuery)

_NO_SEASON = "No such season."
_CLOSED = ("The season is closed (reopen it first), or another organiser changed it meanwhile "
           "(`SeasonLocked`).")


def _standings(description: str) -> OpenAPIResponse:
    return json_response(description, SeasonStandings)



@admin_router.post(
    "/seasons",
    status_code=HTTPStatus.CREATED,
    summary="Create a season",
    description="A season of the organiser's own: its title, its points table (`points`: the "
                "league's 25-18-15-12-10-8-6-4-2-1 by default, a list of one's own, or points "
                "by percentile for big fields, and points for taking part) and how many rounds "
                "count (`best_of`; all by default). Add its rounds with "
                "`PUT /seasons/{season}/rounds/{board}`.",
    responses=_admin_responses(_standings("The season was created."), ok_status=HTTPStatus.CREATED,
                               body=SEASON_BODY,
                               errors={409: "A season with this id exists (`SeasonExists`)."}),
    **ADMIN_ROUTE,
)
@takes(SEASON_BODY)
def create_season(spec: Annotated[SeasonSpec, Body(description="The new season.")],
                  service: Service, organiser: Organiser) -> Response[SeasonStandings]:
    return json_answer(HTTPStatus.CREATED, service.create_season(spec))


@admin_router.patch(
    "/seasons/<season>",
    summary="Change a season",
    description="Only the fields in the body change (`best_of: null` counts every round). The "
                "standings follow at once: points are worked out from the rounds' places.",
    responses=_admin_responses(_standings("The season as it is now."), body=SEASON_CHANGES_BODY,
                               errors={400: "The title or points table cleared.",
                                       404: _NO_SEASON, 409: _CLOSED}),
    **ADMIN_ROUTE,
)
@takes(SEASON_CHANGES_BODY)
def update_season(season: SeasonId,
                  changes: Annotated[SeasonChanges, Body(description="The fields to change.")],
                  service: Service, organiser: Organiser) -> SeasonStandings:
    return service.update_season(segment(season), changes)


@admin_router.put(
    "/seasons/<season>/rounds/<board>",
    summary="Add a round to a season, or change one",
    description="The board becomes a round of the season (its page links to the season), with "
                "its weight (a final's points × 2) and whether it always counts whatever "
                "`best_of` says. A season has at most 30 rounds.",
    responses=_admin_responses(_standings("The season with the round."), body=ROUND_BODY,
                               errors={400: "A season has at most 30 rounds, or a bad id.",
                                       404: "No such season, or no such board.", 409: _CLOSED}),
    **ADMIN_ROUTE,
)
@takes(ROUND_BODY)
def put_round(season: SeasonId, board: BoardId,
              spec: Annotated[RoundSpec, Body(description="The round's weight and whether it "
                                                          "always counts (`{}` for the defaults).")],
              service: Service, organiser: Organiser) -> SeasonStandings:
    return service.add_round(segment(season), segment(board), spec)


@admin_router.delete(
    "/seasons/<season>/rounds/<board>",
    summary="Take a round out of a season",
    description="The board's results no longer count for the season; the board itself stays.",
    responses=_admin_responses(_standings("The season without the round."),
                               errors={404: "No such season, or the board is not one of its rounds.",
                                       409: _CLOSED + " Or the final takes its entrants from "
                                                      "this round."}),
    **ADMIN_ROUTE,
)
def delete_round(season: SeasonId, board: BoardId, service: Service,
                 organiser: Organiser) -> SeasonStandings:
    return service.remove_round(segment(season), segment(board))


@admin_router.put(
    "/seasons/<season>/final",
    summary="Set a season's final",
    description="A named board becomes the season's final: only the top `top` of the season's "
                "standings over its other rounds (or of the round `from_round`) may push to it; "
                "anyone else is refused (`NotQualified`, 403), named against the qualifiers. "
                "Racers tied at the cut all qualify.",
    responses=_admin_responses(
        _standings("The season with its final."), body=FINAL_BODY,
        errors={400: "`from_round` is not a round of the season.",
                404: "No such season, or no such board.",
                409: _CLOSED + " Or the board is a track's default board (`BoardLocked`)."}),
    **ADMIN_ROUTE,
)
@takes(FINAL_BODY)
def put_final(season: SeasonId, spec: Annotated[FinalSpec, Body(description="The final.")],
              service: Service, organiser: Organiser) -> SeasonStandings:
    return service.set_final(segment(season), spec)


@admin_router.delete(
    "/seasons/<season>/final",
    summary="Clear a season's final",
    description="The season has no final: its board takes anyone's pushes again.",
    responses=_admin_responses(_standings("The season without a final."),
                               errors={404: _NO_SEASON, 409: _CLOSED}),
    **ADMIN_ROUTE,
)
def delete_final(season: SeasonId, service: Service, organiser: Organiser) -> SeasonStandings:
    return service.clear_final(segment(season))


@admin_router.post(
    "/seasons/<season>/close",
    summary="Close a season",
    description="The season's standings stay as they are now, whatever later happens to its "
                "boards; it is listed as past. Closing a closed season changes nothing.",
    responses=_admin_responses(_standings("The closed season."), errors={404: _NO_SEASON}),
    **ADMIN_ROUTE,
)
def close_season(season: SeasonId, service: Service, organiser: Organiser) -> SeasonStandings:
    return service.close_season(segment(season))


@admin_router.post(
    "/seasons/<season>/reopen",
    summary="Reopen a closed season",
    description="Its boards move its standings again, and it may change.",
    responses=_admin_responses(_standings("The reopened season."), errors={404: _NO_SEASON}),
    **ADMIN_ROUTE,
)
def reopen_season(season: SeasonId, service: Service, organiser: Organiser) -> SeasonStandings:
    return service.reopen_season(segment(season))
