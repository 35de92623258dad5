"""POST /boards/{board}/submissions, GET /me, PUT /me/alias: the racer-owned routes
(signed in the cloud).

A push that improves its board renders the board's standings (the JSON of the top pages racers
ask for most) for the board version it made, from the read of the board its receipt is made
from, and keeps them in the table, so the pull function answers them from one read, cold or
warm, without rendering them (see ``routes.standings``)."""

from __future__ import annotations

from typing import Any

from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver, Response
from aws_lambda_powertools.event_handler.middlewares import NextMiddleware
from aws_lambda_powertools.logging import correlation_paths
from aws_lambda_powertools.metrics import MetricUnit
from aws_lambda_powertools.utilities.typing import LambdaContext

from ..errors import DomainError
from ..routes import build_app, canonical_event, push_router
from ..routes.standings import keeping_after_pushes
from . import collector_after_first_answer, wiring

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


def standings_not_kept(board_id: str, error: DomainError) -> None:
    logger.warning("StandingsNotKept", extra={"board": board_id, "error": error.message})


app = build_app(push_router)
app.use(middlewares=[count_submissions])


@collector_after_first_answer
@logger.inject_lambda_context(correlation_id_path=correlation_paths.API_GATEWAY_HTTP)
@metrics.log_metrics(capture_cold_start_metric=True)
def lambda_handler(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    service = wiring.service_from_environment()
    service.keep_standings_after_pushes(keeping_after_pushes(service, standings_not_kept))
    app.append_context(service=service)
    return app.resolve(canonical_event(event), context)
