"""The organisers' webhooks (IAM-signed in the cloud; answered by `drboard serve` only to the
computer it runs on): add, list, remove and test a board's chat webhooks, and a season's (which
hear its rounds' and its final's events). A webhook's URL is taken in a body and never answered
back in full."""

from __future__ import annotations

from http import HTTPStatus
from typing import Annotated

from aws_lambda_powertools.event_handler import Request, Response
from aws_lambda_powertools.event_handler.openapi.params import Body, Path

from ..errors import InvalidQuery
from ..models.notices import Delivery, WebhookList, WebhookSpec, WebhookView
from .params import (
    ADMIN_ROUTE,
    NO_BOARD,
    BoardId,
    Organiser,
    RequestBody,
    SeasonId,
    Service,
    admin_router,
    origin,
    segment,
    takes,
)
from .responses import admin_responses as _admin_responses
from .responses import json_answer, json_response

WEBHOOK_BODY = RequestBody("webhook", 4096, InvalidQuery)
WebhookId = Annotated[str, Path(min_length=1, max_length=64, description="The webhook's id.")]
_NO_WEBHOOK = "No such board, or no such webhook on it (`WebhookNotFound`)."
_NO_SEASON = "No such season (`SeasonNotFound`)."
_NO_SEASON_WEBHOOK = "No such season, or no such webhook of it (`WebhookNotFound`)."


@admin_router.post(
    "/boards/<board>/webhooks",
    status_code=HTTPStatus.CREATED,
    summary="Add a chat webhook to a board",
    description="Announcements of the board go to it: a new leader, a racer entering the top "
                "3, a personal best, the board opening and closing with its podium (`events`, "
                "every one by default). `kind` is `discord`, `slack` or `json` (any endpoint "
                "taking a JSON POST). The URL is a secret: the answer shows its host and last "
                "four characters only.",
    responses=_admin_responses(
        json_response("The webhook was added.", WebhookView), ok_status=HTTPStatus.CREATED,
        body=WEBHOOK_BODY, errors={400: "A bad board id, or the board has 10 webhooks already.",
                                   404: NO_BOARD}),
    **ADMIN_ROUTE,
)
@takes(WEBHOOK_BODY)
def add_webhook(board: BoardId, spec: Annotated[WebhookSpec, Body(description="The webhook.")],
                service: Service, organiser: Organiser) -> Response[WebhookView]:
    return json_answer(HTTPStatus.CREATED, service.add_webhook(segment(board), spec, caller=organiser))


@admin_router.get(
    "/boards/<board>/webhooks",
    summary="A board's chat webhooks",
    description="Each webhook with its URL cut short, the events it hears, and how its last "
                "delivery went (`last_sent_at`, or `last_error` and `last_error_at`).",
    responses=_admin_responses(json_response("The board's webhooks.", WebhookList),
                               errors={404: NO_BOARD}),
    **ADMIN_ROUTE,
)
def list_webhooks(board: BoardId, service: Service, organiser: Organiser) -> WebhookList:
    return service.webhooks(segment(board))


@admin_router.delete(
    "/boards/<board>/webhooks/<webhook>",
    summary="Remove a chat webhook",
    responses=_admin_responses(json_response("The removed webhook.", WebhookView),
                               errors={404: _NO_WEBHOOK}),
    **ADMIN_ROUTE,
)
def remove_webhook(board: BoardId, webhook: WebhookId, service: Service,
                   organiser: Organiser) -> WebhookView:
    return service.remove_webhook(segment(board), segment(webhook), caller=organiser)


@admin_router.post(
    "/boards/<board>/webhooks/<webhook>/test",
    summary="Send a test message to a chat webhook",
    description="Posts a test message now (with the board's podium as it stands) and answers "
                "whether the service took it; the webhook's `last_error` says why not.",
    responses=_admin_responses(json_response("What the test did.", Delivery),
                               errors={404: _NO_WEBHOOK}),
    **ADMIN_ROUTE,
)
def test_webhook(board: BoardId, webhook: WebhookId, service: Service, organiser: Organiser,
                 request: Request) -> Delivery:
    from ..web import board_path  # the pages' module, which the admin function never loads else

    board_id = segment(board)
    url = origin(request.resolved_event) + board_path(board_id)
    return service.test_webhook(board_id, segment(webhook), url)


# ---- a season's webhooks: its rounds' and its final's events ----------------------------------


@admin_router.post(
    "/seasons/<season>/webhooks",
    status_code=HTTPStatus.CREATED,
    summary="Add a chat webhook to a season",
    description="Announcements of every round of the season and of its final go to it, as a "
                "board's own webhooks hear them (`events`, every one by default; `kind` as for a "
                "board). The URL is a secret: the answer shows its host and last four characters.",
    responses=_admin_responses(
        json_response("The webhook was added.", WebhookView), ok_status=HTTPStatus.CREATED,
        body=WEBHOOK_BODY, errors={400: "A bad season id, or the season has 10 webhooks already.",
                                   404: _NO_SEASON}),
    **ADMIN_ROUTE,
)
@takes(WEBHOOK_BODY)
def add_season_webhook(season: SeasonId, spec: Annotated[WebhookSpec, Body(description="The webhook.")],
                       service: Service, organiser: Organiser) -> Response[WebhookView]:
    view = service.add_webhook(segment(season), spec, caller=organiser, kind="season")
    return json_answer(HTTPStatus.CREATED, view)


@admin_router.get(
    "/seasons/<season>/webhooks",
    summary="A season's chat webhooks",
    description="Each webhook with its URL cut short, the events it hears, and how its last "
                "delivery went.",
    responses=_admin_responses(json_response("The season's webhooks.", WebhookList),
                               errors={404: _NO_SEASON}),
    **ADMIN_ROUTE,
)
def list_season_webhooks(season: SeasonId, service: Service, organiser: Organiser) -> WebhookList:
    return service.webhooks(segment(season), kind="season")


@admin_router.delete(
    "/seasons/<season>/webhooks/<webhook>",
    summary="Remove a season's chat webhook",
    responses=_admin_responses(json_response("The removed webhook.", WebhookView),
                               errors={404: _NO_SEASON_WEBHOOK}),
    **ADMIN_ROUTE,
)
def remove_season_webhook(season: SeasonId, webhook: WebhookId, service: Service,
                          organiser: Organiser) -> WebhookView:
    return service.remove_webhook(segment(season), segment(webhook), caller=organiser, kind="season")


@admin_router.post(
    "/seasons/<season>/webhooks/<webhook>/test",
    summary="Send a test message to a season's chat webhook",
    description="Posts a test message now and answers whether the service took it; the "
                "webhook's `last_error` says why not.",
    responses=_admin_responses(json_response("What the test did.", Delivery),
                               errors={404: _NO_SEASON_WEBHOOK}),
    **ADMIN_ROUTE,
)
def test_season_webhook(season: SeasonId, webhook: WebhookId, service: Service, organiser: Organiser,
                        request: Request) -> Delivery:
    from ..web import season_path  # the pages' module, which the admin function never loads else

    season_id = segment(season)
    url = origin(request.resolved_event) + season_path(season_id)
    return service.test_webhook(season_id, segment(webhook), url, kind="season")
