"""The public reads: GET /, /boards, /boards/{board}, /boards/{board}/racers/{racer},
/boards/{board}/view, /racers/{racer}, /racers/{racer}/submissions and
/.well-known/drboard.json.

A board's standings kept for its version now (in this container, or in the table: see
``routes.standings``) are answered before the resolver is built: a cold container that answers
them loads neither the routes nor pydantic, only the logger, the metrics and a DynamoDB client.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING, Any

from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.logging import correlation_paths

from ..routes.kept import event_answer
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
    return event_answer(event, wiring.kept_pages_from_environment()) or resolved(event, context)


@cache
def app() -> BoardResolver:
    from ..routes import build_app, pull_router

    return build_app(pull_router)


def resolved(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    """The routes' answer, the resolver built on the first request that needs it."""
    resolver = app()
    resolver.append_context(service=wiring.service_from_environment(),
                            sign_in=wiring.sign_in_from_environment())
    return resolver.resolve(event, context)
