"""The organisers' routes (IAM-authorised in the cloud, or with a Cognito sign-in of the
``organisers`` group under ``/cognito``): POST /boards; PATCH and DELETE /boards/{board}; POST
/boards/{board}/close and /restore; GET /boards/{board}/export and /audit; PUT
/boards/{board}/import; POST /boards/{board}/imports; DELETE /boards/{board}/racers/{racer}; PUT
and DELETE /boards/{board}/bans/{racer}."""

from __future__ import annotations

from importlib import import_module
from typing import Any

from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver, Response
from aws_lambda_powertools.event_handler.middlewares import NextMiddleware
from aws_lambda_powertools.logging import correlation_paths
from aws_lambda_powertools.utilities.typing import LambdaContext

from ..errors import BoardNotFound
from ..identity import caller_from_event
from ..routes import BoardResolver, admin_routes_module, build_app, canonical_event
from . import collector_after_first_answer, wiring

logger = Logger()
metrics = Metrics()


def audit(app: APIGatewayHttpResolver, next_middleware: NextMiddleware) -> Response[Any]:
    """Log who did what to which board: the caller API Gateway authorised, the route and the
    status. (A refused request is answered by the error handlers and does not reach this log.)"""
    response = next_middleware(app)
    event = app.current_event
    caller = caller_from_event(event.raw_event)
    logger.info("OrganiserRequest", extra={
        "route": f"{event.http_method} {event.path}",
        "board": app.context.get("_route_args", {}).get("board"),
        "status": response.status_code,
        "caller": caller.principal if caller else None,
    })
    return response


#: The routes an organiser's command calls many times in a row, a step at a time (an import over
#: HTTP, a submission a request; a recheck; a build of rank counters): the pages they change are
#: rendered by their first reader instead.
ONE_OF_MANY = ("/boards/<board>/imports", "/boards/<board>/recheck", "/boards/<board>/rank-counters")


def keep_standings(app: APIGatewayHttpResolver, next_middleware: NextMiddleware) -> Response[Any]:
    """After an organiser changed a board (its settings, window, entries, bans, rounds), its
    standings as of the version the change made, kept for the pull function."""
    response = next_middleware(app)
    board = app.context.get("_route_args", {}).get("board")
    route = app.context.get("_route")
    if (app.current_event.http_method != "GET" and response.status_code < 300 and board
            and getattr(route, "path", None) not in ONE_OF_MANY):
        from ..routes.standings import renew_after_change

        error = renew_after_change(app.context["service"], board)
        if error is not None and not isinstance(error, BoardNotFound):  # a deleted board shows none
            logger.warning("StandingsNotKept", extra={"board": board, "error": error.message})
    return response


class AdminRoutes:
    """The resolver of the routes loaded so far. Each request loads the module of the routes that
    answer its path (``routes.admin_routes_module``) the first time one needs it, and the resolver
    is built again with them: a cold start loads one module's routes and models, not all of
    them."""

    def __init__(self) -> None:
        self.loaded: set[str] = set()
        self.app: BoardResolver | None = None

    def for_path(self, path: str) -> BoardResolver:
        module = admin_routes_module(path)
        if self.app is None or module not in self.loaded:
            import_module(f"..routes.{module}", __package__)
            self.loaded.add(module)
            from ..routes.params import admin_router

            self.app = build_app(admin_router)
            self.app.use(middlewares=[audit, keep_standings])
        return self.app


admin_routes = AdminRoutes()


@collector_after_first_answer
@logger.inject_lambda_context(correlation_id_path=correlation_paths.API_GATEWAY_HTTP)
@metrics.log_metrics(capture_cold_start_metric=True)
def lambda_handler(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    event = canonical_event(event)
    app = admin_routes.for_path(str(event.get("rawPath") or ""))
    app.append_context(service=wiring.service_from_environment())
    return app.resolve(event, context)
