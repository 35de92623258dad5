"""The leaderboard's HTTP routes: Powertools routers for the push, pull and admin functions.

The three Lambda functions and ``drboard serve`` build their resolver with :func:`build_app`, so
the routes, the validation, the error statuses and the OpenAPI document are the same everywhere.

- ``card_router`` (:mod:`.cards`): the result cards (SVG, and PNG drawn from it), the
  CardFunction's in the cloud, apart so that only it ships the renderer and its fonts.
- ``push_router`` (:mod:`.submissions`): a racer's submission and alias (IAM-signed in the
  cloud). ``pull_router``: the public reads (:mod:`.boards`) and the web pages (:mod:`.pages`).
  ``admin_router`` (:mod:`.organisers`): the organisers' routes (create, change, close, delete,
  restore boards, moderation, audit, aliases; :mod:`.transfers`: export, import and recheck
  boards), every one IAM-signed in the cloud and answered by ``drboard serve`` only to the
  computer it runs on.
- :mod:`.seasons`: the seasons' reads and pages (pull); :mod:`.season_changes`: the organisers'
  changes to seasons (admin).
- :mod:`.params` holds what the routes share: the routers, the request parameters, who is
  calling, and each JSON body's bound; :mod:`.responses` what they answer.
- The routes never build a service: the caller puts one in the resolver's context before each
  ``resolve`` (``app.append_context(service=...)``); the routes reach it through ``Depends``.
- :mod:`.app` builds the resolver, and is the one place domain errors become HTTP statuses.
- Importing this package loads nothing: each name loads its module on first use, and a router
  loads the modules that register its routes (:data:`ROUTE_MODULES`), so each function imports
  only its own routes (the pull function no push or admin route, the admin function no page).

Run ``python -m drboard_functions.routes > functions/openapi.json`` to regenerate the committed
OpenAPI document (``tests/unit/test_openapi.py`` fails when it drifts from the code).
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aws_lambda_powertools.event_handler.api_gateway import Router

    from .app import (
        COGNITO_PREFIX,
        ERROR_STATUS,
        BoardResolver,
        build_app,
        canonical_event,
        error_body,
        error_headers,
        refusal,
        status_of,
        unreadable,
    )
    from .headers import page_etag
    from .openapi import openapi_document
    from .params import (
        ADMIN_TAG,
        IMPORT_BODY,
        MAX_BOARD_BODY_BYTES,
        RequestBody,
        admin_router,
        bounded_json,
        card_router,
        pull_router,
        push_router,
    )
    from .responses import ErrorBody, FieldProblem

__all__ = [
    "ADMIN_TAG",
    "COGNITO_PREFIX",
    "ERROR_STATUS",
    "IMPORT_BODY",
    "MAX_BOARD_BODY_BYTES",
    "BoardResolver",
    "ErrorBody",
    "FieldProblem",
    "RequestBody",
    "admin_router",
    "bounded_json",
    "build_app",
    "canonical_event",
    "card_router",
    "error_body",
    "error_headers",
    "openapi_document",
    "page_etag",
    "pull_router",
    "push_router",
    "refusal",
    "status_of",
    "unreadable",
]

#: The modules whose routes each router holds: taking a router from this package imports them.
ROUTE_MODULES = {"push_router": ("submissions",), "pull_router": ("boards", "pages", "results", "seasons"),
                 "admin_router": ("organisers", "transfers", "season_changes", "webhooks"),
                 "card_router": ("cards",)}
#: The module each other name of the package comes from.
_HOMES = {"COGNITO_PREFIX": "app", "ERROR_STATUS": "app", "BoardResolver": "app", "build_app": "app",
          "canonical_event": "app", "error_body": "app", "error_headers": "app", "refusal": "app",
          "status_of": "app", "unreadable": "app", "openapi_document": "openapi",
          "ADMIN_TAG": "params", "IMPORT_BODY": "params", "MAX_BOARD_BODY_BYTES": "params",
          "RequestBody": "params", "bounded_json": "params", "ErrorBody": "responses",
          "FieldProblem": "responses", "page_etag": "headers"}


def __getattr__(name: str) -> Any:
    if name in ROUTE_MODULES:
        return router(name)
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{home}"), name)


#: The last segment of the paths of a board's transfers' routes (:mod:`.transfers`).
TRANSFER_ROUTES = ("export", "import", "imports", "recheck")


def admin_routes_module(path: str) -> str:
    """The module of :data:`ROUTE_MODULES`' admin routes that answers ``path`` (a canonical
    path, as :func:`.app.canonical_event` makes it): the admin function loads only that module on
    a cold start. A path no route answers goes to the organisers' module, which answers it 404."""
    parts = path.strip("/").split("/")
    if len(parts) > 2 and parts[0] in ("boards", "seasons") and parts[2] == "webhooks":
        return "webhooks"
    if len(parts) == 3 and parts[0] == "boards" and parts[2] in TRANSFER_ROUTES:
        return "transfers"
    if parts[0] == "seasons":
        return "season_changes"
    return "organisers"


def router(name: str) -> Router:
    """``push_router``, ``pull_router``, ``admin_router`` or ``card_router``, with every one of its
    routes."""
    for module in ROUTE_MODULES[name]:
        import_module(f"{__name__}.{module}")
    found: Router = getattr(import_module(f"{__name__}.params"), name)
    return found
