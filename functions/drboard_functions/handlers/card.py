"""The result cards: GET /boards/{board}/racers/{racer}/card.svg and card.png, and a season's
podium card.

A function of its own, so that only it ships the renderer (resvg) and the card fonts: the pull
function keeps its size and its cold start. A racer's card on a board whose standings are kept
for its version now (the push that changed the board kept them: see ``routes.standings``) is
drawn from them before the resolver is built: a cold container that answers it loads neither the
routes nor pydantic, only the logger, the metrics, a DynamoDB client, the card's template and
resvg."""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING, Any

from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.logging import correlation_paths

from ..routes.kept import card_event_answer
from . import collector_after_first_answer, wiring

if TYPE_CHECKING:
    from aws_lambda_powertools.utilities.typing import LambdaContext

    from ..routes import BoardResolver

logger = Logger()
metrics = Metrics()


@collector_after_first_answer
@logger.inject_lambda_context(correlation_id_path=correlation_paths.API_GATEWAY_HTTP)
@metrics.log_metrics(capture_cold_start_metric=True)
def lambda_handler(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    return card_event_answer(event, wiring.kept_cards_from_environment()) or resolved(event, context)


@cache
def app() -> BoardResolver:
    from ..routes import build_app, card_router

    return build_app(card_router)


def resolved(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    """The routes' answer, the resolver built on the first request that needs it."""
    resolver = app()
    resolver.append_context(service=wiring.service_from_environment())
    return resolver.resolve(event, context)
