"""The committed OpenAPI document (functions/openapi.json), built from the routes."""

from __future__ import annotations

import json
from importlib import import_module

from .app import build_app

#: Every route module, in the order the document lists their routes (each router's routes in
#: the order their modules register them).
ROUTE_MODULES_IN_ORDER = ("boards", "cards", "organisers", "transfers", "pages", "results",
                          "seasons", "season_changes", "submissions", "webhooks")

_DEFAULT_422 = "#/components/schemas/HTTPValidationError"
#: Every route's answer when the board's storage is busy or unreachable (nothing was written).
_STORE_BUSY = {
    "description": "The board's storage is busy (`StoreBusy`: throttled, or too many pushes at "
                   "once) or did not answer (`StoreUnavailable`); nothing was written. Try again "
                   "after Retry-After seconds.",
    "headers": {"Retry-After": {"description": "Seconds to wait.", "schema": {"type": "integer"}}},
    "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorBody"}}},
}


def openapi_document() -> str:
    """The OpenAPI document of the functions' routes, as committed in functions/openapi.json.

    It is Powertools' document for ``build_app(push_router, pull_router, admin_router,
    card_router)`` plus the
    503 every route may answer (a busy store), less one thing that is not true of this API: the
    default "422 Validation Error" Powertools lists on every validated route. Here a bad query
    or path parameter answers 400 and a bad body 422, both with an :class:`ErrorBody`, and the
    routes list those responses themselves."""
    for module in ROUTE_MODULES_IN_ORDER:
        import_module(f"{__package__}.{module}")
    from . import admin_router, card_router, pull_router, push_router

    document = json.loads(build_app(push_router, pull_router, admin_router,
                                    card_router).get_openapi_json_schema())
    for operations in document["paths"].values():
        for operation in operations.values():
            operation["responses"]["503"] = _STORE_BUSY
            default = operation["responses"].get("422", {})
            if default.get("content", {}).get("application/json", {}).get("schema", {}).get(
                    "$ref") == _DEFAULT_422:
                del operation["responses"]["422"]
    schemas = document["components"]["schemas"]
    if _DEFAULT_422 not in json.dumps(document["paths"]):
        schemas.pop("HTTPValidationError", None)
        schemas.pop("ValidationError", None)
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"
