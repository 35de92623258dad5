"""POST /boards/{board}/submissions, GET /me, PUT /me/alias: the racer-owned routes
(signed in the cloud).

A push that stores a run renders its board's standings (the JSON of the top pages racers ask
for most) for the board version it made and keeps them in the table, so the pull function
answers them from one read, cold or warm, without rendering them (see ``routes.standings``)."""

from __future__ import annotations

import json
from typing import Any

from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver, Response
from aws_lambda_powertools.event_handler.middlewares import NextMiddleware
from aws_lambda_powertools.logging import correlation_paths
from aws_lambda_powertools.metrics import MetricUnit
from aws_lambda_powertools.utilities.typing import LambdaContext

from ..routes import build_app, canonical_event, push_router
from ..routes.standings import renew_after_change
from . import wiring

logger = Logger()
metrics = Metrics()

SUBMISSION_METRICS = {201: "SubmissionAccepted", 200: "DuplicateSubmission"}


def count_submissions(app: APIGatewayHttpResolver, next_middleware: NextMiddleware) -> Response[Any]:
    """Count accepted and duplicate submissions (refusals answer through the error handlers)."""
    response = next_middleware(app)
    if app.current_event.http_method != "POST":  # GET /me, PUT /me/alias
        return response
    name = SUBMISSION_METRICS.get(response.status_code)
    if name:
        metrics.add_metric(name=name, unit=MetricUnit.Count, value=1)
        logger.info(name, extra={"board": app.context.get("_route_args", {}).get("board")})
    return response


def keep_standings(app: APIGatewayHttpResolver, next_middleware: NextMiddleware) -> Response[Any]:
    """After a run made its racer's entry better, its board's standings as of the version it
    made, kept for the pull function."""
    response = next_middleware(app)
    board = app.context.get("_route_args", {}).get("board")
    if app.current_event.http_method == "POST" and response.status_code == 201 and board \
            and changed_the_standings(response):
        error = renew_after_change(app.context["service"], board)
        if error is not None:
            logger.warning("StandingsNotKept", extra={"board": board, "error": error.message})
    return response


def changed_the_standings(response: Response[Any]) -> bool:
    """Whether a stored run made its racer's entry better (else the board's version, and so its
    kept pages, stay as they were)."""
    receipt = json.loads(response.body) if isinstance(response.body, str | bytes) else {}
    return bool(receipt.get("improved"))


app = build_app(push_router)
app.use(middlewares=[count_submissions, keep_standings])


@logger.inject_lambda_context(correlation_id_path=correlation_paths.API_GATEWAY_HTTP)
@metrics.log_metrics(capture_cold_start_metric=True)
def lambda_handler(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    app.append_context(service=wiring.service_from_environment())
    return app.resolve(canonical_event(event), context)
