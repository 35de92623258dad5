"""The committed OpenAPI document (functions/openapi.json) is the one the routes generate."""

from __future__ import annotations

import json
from importlib.metadata import version
from pathlib import Path
from typing import Any

import pytest
from drboard_functions.routes import openapi_document

COMMITTED = Path(__file__).parents[2] / "functions" / "openapi.json"
REGENERATE = "python -m drboard_functions.routes > functions/openapi.json"


@pytest.fixture(scope="module")
def document() -> dict[str, Any]:
    return json.loads(openapi_document())  # type: ignore[no-any-return]


def test_the_committed_document_matches_the_code() -> None:
    assert COMMITTED.is_file(), f"functions/openapi.json is missing: run `{REGENERATE}`"
    assert COMMITTED.read_text(encoding="utf-8") == openapi_document(), (
        f"functions/openapi.json is out of date with the routes: run `{REGENERATE}` and commit it")


def test_it_names_the_api_and_its_version(document: dict[str, Any]) -> None:
    assert document["openapi"].startswith("3.")
    assert document["info"]["title"] == "drboard"
    assert document["info"]["version"] == version("drboard")


def test_it_has_every_route_of_the_template(document: dict[str, Any]) -> None:
    routes = {(method.upper(), path) for path, item in document["paths"].items() for method in item}
    assert routes == {
        ("POST", "/boards/{board}/submissions"),
        ("GET", "/"),
        ("GET", "/boards"),
        ("GET", "/boards/{board}"),
        ("GET", "/boards/{board}/racers/{racer}"),
        ("GET", "/boards/{board}/view"),
        ("GET", "/boards/{board}/compare"),
        ("GET", "/boards/{board}/insights"),
        ("GET", "/boards/{board}/racers/{racer}/view"),
        ("GET", "/boards/{board}/compare/view"),
        ("GET", "/boards/{board}/insights/view"),
        ("GET", "/racers/{racer}"),
        ("GET", "/racers/{racer}/submissions"),
        ("POST", "/boards"),
        ("PATCH", "/boards/{board}"),
        ("DELETE", "/boards/{board}"),
        ("POST", "/boards/{board}/close"),
        ("POST", "/boards/{board}/restore"),
        ("POST", "/boards/{board}/rank-counters"),
        ("GET", "/boards/{board}/export"),
        ("PUT", "/boards/{board}/import"),
        ("POST", "/boards/{board}/imports"),
        ("DELETE", "/boards/{board}/racers/{racer}"),
        ("PUT", "/boards/{board}/bans/{racer}"),
        ("DELETE", "/boards/{board}/bans/{racer}"),
        ("GET", "/boards/{board}/audit"),
        ("POST", "/boards/{board}/recheck"),
        ("GET", "/aliases"),
        ("GET", "/aliases/audit"),
        ("PUT", "/aliases/{racer}"),
        ("DELETE", "/aliases/{racer}"),
        ("GET", "/me"),
        ("PUT", "/me/alias"),
        ("GET", "/.well-known/drboard.json"),
        ("GET", "/seasons"),
        ("GET", "/seasons/{season}"),
        ("GET", "/seasons/view"),
        ("GET", "/seasons/{season}/view"),
        ("POST", "/seasons"),
        ("PATCH", "/seasons/{season}"),
        ("PUT", "/seasons/{season}/rounds/{board}"),
        ("DELETE", "/seasons/{season}/rounds/{board}"),
        ("PUT", "/seasons/{season}/final"),
        ("DELETE", "/seasons/{season}/final"),
        ("POST", "/seasons/{season}/close"),
        ("POST", "/seasons/{season}/reopen"),
        ("GET", "/boards/{board}/laps.csv"),
        ("GET", "/boards/{board}/racers/{racer}/laps.json"),
        ("GET", "/racers/{racer}/submissions.csv"),
        ("POST", "/boards/{board}/webhooks"),
        ("GET", "/boards/{board}/webhooks"),
        ("DELETE", "/boards/{board}/webhooks/{webhook}"),
        ("POST", "/boards/{board}/webhooks/{webhook}/test"),
    }


def test_every_organiser_route_is_signed_and_lists_its_refusals(document: dict[str, Any]) -> None:
    admin = [(method, path, operation) for path, item in document["paths"].items()
             for method, operation in item.items() if "admin" in operation["tags"]]
    assert len(admin) == 30, "22 for boards and aliases, 8 for seasons"
    for method, path, operation in admin:
        assert operation["security"] == [{"sigv4": []}], (method, path)
        assert {"400", "403"} <= set(operation["responses"]), (method, path)
        if "requestBody" in operation:
            assert {"413", "415", "422"} <= set(operation["responses"]), (method, path)
    public = [operation for item in document["paths"].values() for operation in item.values()
              if "admin" not in operation["tags"] and "submissions" not in operation["tags"]
              and operation["operationId"] not in ("get_me_me_get", "put_my_alias_me_alias_put")]
    assert all("security" not in operation for operation in public), "reads stay public"


def test_the_organiser_bodies_are_their_models(document: dict[str, Any]) -> None:
    def body(method: str, path: str) -> str:
        schema = document["paths"][path][method]["requestBody"]["content"]["application/json"]["schema"]
        return str(schema["$ref"].rsplit("/", 1)[1])

    assert body("post", "/boards") == "BoardSpec"
    assert body("patch", "/boards/{board}") == "BoardChanges"
    assert body("put", "/boards/{board}/import") == "Board"
    assert body("post", "/boards/{board}/imports") == "ImportedSubmission"
    for method, path, created in [("post", "/boards", {"201"}),
                                  ("put", "/boards/{board}/import", {"200", "201"}),
                                  ("post", "/boards/{board}/imports", {"200", "201"})]:
        assert created <= set(document["paths"][path][method]["responses"])
    assert "409" in document["paths"]["/boards"]["post"]["responses"]
    assert "409" in document["paths"]["/boards/{board}"]["patch"]["responses"]


def test_the_push_body_is_a_record_and_its_answers_are_listed(document: dict[str, Any]) -> None:
    push = document["paths"]["/boards/{board}/submissions"]["post"]
    schema = push["requestBody"]["content"]["application/json"]["schema"]
    assert schema["$ref"].startswith("#/components/schemas/Record")
    record = document["components"]["schemas"][schema["$ref"].rsplit("/", 1)[1]]
    assert {"submission_id", "track", "racer", "evaluations", "design"} <= set(record["required"])
    assert {"200", "201", "403", "413", "422", "429"} <= set(push["responses"])
    assert push["security"] == [{"sigv4": []}]
    assert document["components"]["securitySchemes"]["sigv4"]["x-amazon-apigateway-authtype"] == "awsSigv4"


def test_reads_list_400_not_powertools_default_422(document: dict[str, Any]) -> None:
    board = document["paths"]["/boards/{board}"]["get"]
    assert "422" not in board["responses"]
    assert board["responses"]["400"]["content"]["application/json"]["schema"]["$ref"].endswith("/ErrorBody")
    limit = next(p for p in board["parameters"] if p["name"] == "limit")
    assert (limit["in"], limit["schema"]["minimum"], limit["schema"]["maximum"]) == ("query", 1, 500)
    assert "HTTPValidationError" not in document["components"]["schemas"]


def test_pages_are_html(document: dict[str, Any]) -> None:
    for path in ("/", "/boards/{board}/view", "/seasons/{season}/view", "/seasons/view"):
        assert "text/html" in document["paths"][path]["get"]["responses"]["200"]["content"]
