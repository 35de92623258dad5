"""The public reads: GET /, /boards, /boards/{board}, /boards/{board}/racers/{racer},
/boards/{board}/view, /racers/{racer}, /racers/{racer}/submissions and
/.well-known/drboard.json."""

from __future__ import annotations

from typing import Any

from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.logging import correlation_paths
from aws_lambda_powertools.utilities.typing import LambdaContext

from ..routes import build_app, pull_router
from . import wiring

logger = Logger()
metrics = Metrics()

app = build_app(pull_router)


@logger.inject_lambda_context(correlation_id_path=correlation_paths.API_GATEWAY_HTTP)
@metrics.log_metrics(capture_cold_start_metric=True)
def lambda_handler(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    app.append_context(service=wiring.service_from_environment(),
                       sign_in=wiring.sign_in_from_environment())
    return app.resolve(event, context)
