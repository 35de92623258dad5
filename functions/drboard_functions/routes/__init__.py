"""The leaderboard's HTTP routes: Powertools routers for the push, pull and admin functions.

The three Lambda functions and ``drboard serve`` build their resolver with :func:`build_app`, so
the routes, the validation, the error statuses and the OpenAPI document are the same everywhere.

- ``card_router`` (:mod:`.cards`): the result cards (SVG, and PNG drawn from it), the
  CardFunction's in the cloud, apart so that only it ships the renderer and its fonts.
- ``push_router`` (:mod:`.submissions`): a racer's submission and alias (IAM-signed in the
  cloud). ``pull_router``: the public reads (:mod:`.boards`) and the web pages (:mod:`.pages`).
  ``admin_router`` (:mod:`.organisers`): the organisers' routes (create, change, close, delete,
  restore, export and import boards, moderation, audit), every one IAM-signed in the cloud and
  answered by ``drboard serve`` only to the computer it runs on.
- :mod:`.seasons`: the seasons' reads and page (pull) and their organisers' routes (admin).
- :mod:`.params` holds what the routes share: the routers, the request parameters, who is
  calling, and each JSON body's bound; :mod:`.responses` what they answer.
- The routes never build a service: the caller puts one in the resolver's context before each
  ``resolve`` (``app.append_context(service=...)``); the routes reach it through ``Depends``.
- :mod:`.app` builds the resolver, and is the one place domain errors become HTTP statuses.

Run ``python -m drboard_functions.routes > functions/openapi.json`` to regenerate the committed
OpenAPI document (``tests/unit/test_openapi.py`` fails when it drifts from the code).
"""

from . import (  # noqa: F401 - each registers its routes
    boards,
    cards,
    organisers,
    pages,
    results,
    seasons,
    submissions,
    webhooks,
)
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
from .responses import ErrorBody, FieldProblem, page_etag

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
