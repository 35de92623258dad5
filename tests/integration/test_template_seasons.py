"""Seasons in the cloud: the functions, on moto, with only the environment and the permissions
the template gives them (as tests/integration/test_template.py checks the boards): the admin
function makes a season and its final, the pull function reads it and keeps a changed round's
results only in the seasons' results partitions, and the push function refuses a push to the
final from a racer who did not qualify."""

from __future__ import annotations

import copy
import json
from typing import Any

import boto3
import pytest
from drboard_cli.serve import LocalContext

from tests.integration.test_template import (
    EVENTS,
    CallRecorder,
    _environment,
    _granted,
    _isolate,
    aws,
    cloudformation,
    deployed,
    sam,
)
from tests.recordkit import make_record

__all__ = ["aws", "cloudformation", "deployed", "sam"]

SEASON = "club-2026"
TRACK = "reInvent2019_track"


def event(name: str, *, path: str | None = None, body: Any = None) -> dict[str, Any]:
    """An example event, sent to another path of its route or with another body."""
    loaded: dict[str, Any] = json.loads((EVENTS / name).read_text())
    changed = copy.deepcopy(loaded)
    if path is not None:
        changed["rawPath"] = changed["requestContext"]["http"]["path"] = path
    if body is not None:
        changed["body"] = body if isinstance(body, str) else json.dumps(body)
        changed["headers"]["content-length"] = str(len(changed["body"].encode()))
    return changed


def invoke(kind: str, sent: dict[str, Any]) -> dict[str, Any]:
    """Run a function's handler as a fresh container would."""
    from drboard_functions.handlers import admin, pull, push, wiring

    wiring.forget()
    handler = {"push": push, "pull": pull, "admin": admin}[kind].lambda_handler
    answer: dict[str, Any] = handler(sent, LocalContext())
    return answer


class PutKeys:
    """The partition keys of the items each PutItem call writes."""

    def __init__(self) -> None:
        self.partitions: list[str] = []

    def __call__(self, params: dict[str, Any], **_: Any) -> None:
        self.partitions.append(params["Item"]["board"]["S"])


def test_a_season_runs_on_the_functions_template_permissions(
    cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    as_function = {kind: _environment(cloudformation, f"{kind.title()}Function", deployed)
                   for kind in ("push", "pull", "admin")}
    used: dict[str, set[tuple[str, str]]] = {kind: set() for kind in as_function}

    def call(kind: str, sent: dict[str, Any], status: int) -> dict[str, Any]:
        _isolate(monkeypatch, as_function[kind])
        aws.calls.clear()
        answer = invoke(kind, sent)
        assert answer["statusCode"] == status, answer["body"][:400]
        used[kind] |= set(aws.calls)
        return answer

    call("push", event("push.json"), 201)
    call("admin", event("admin_create_season.json"), 201)
    call("admin", event("admin_add_round.json"), 200)
    final = {"board_id": "club-final", "title": "Club final", "track": "reInvent2019"}
    call("admin", event("admin_create_board.json", body=final), 201)
    call("admin", event("admin_set_final.json", body={"board_id": "club-final", "top": 1}), 200)

    blaze = make_record("Blaze", [(8_000, 100)]).model_dump_json()
    call("push", event("push.json", body=blaze), 201)  # the round's board changes
    puts = PutKeys()
    boto3_client = boto3.client
    monkeypatch.setattr(boto3, "client", lambda *a, **k: _watching(boto3_client(*a, **k), puts))
    standings = json.loads(call("pull", event("season_standings.json"), 200)["body"])
    assert [s["racer"] for s in standings["standings"]] == ["Blaze", "Speedy"]
    assert standings["season"]["final"]["qualifiers"] == ["Blaze"]
    assert puts.partitions == [f"#RESULTS#{SEASON}"], "the changed round's results, kept"
    page = call("pull", event("season_view.json"), 200)
    assert "Blaze" in page["body"] and "Content-Security-Policy" in page["headers"]
    call("pull", event("pull_seasons.json"), 200)

    speedy = json.loads(event("push.json")["body"])
    refused = call("push", event("push.json", path="/boards/club-final/submissions",
                                 body=json.dumps(speedy)), 403)
    assert json.loads(refused["body"])["error"] == "NotQualified"
    call("admin", event("admin_close_season.json"), 200)

    for kind in as_function:
        granted = _granted(cloudformation, f"{kind.title()}Function")
        assert used[kind] <= granted, f"{kind}: calls not allowed by the template: {used[kind] - granted}"
    assert ("dynamodb:BatchGetItem", "table") in used["pull"] & used["push"]


def _watching(client: Any, puts: PutKeys) -> Any:
    client.meta.events.register("before-parameter-build.dynamodb.PutItem", puts)
    return client
