"""Hostile request bodies get a clean 4xx from the real handlers, never a crash; and the
embedded board refuses what the cloud refuses, because the bounds live in the service."""

from __future__ import annotations

import base64
import json
import os
from collections.abc import Callable, Iterator
from typing import Any

import pytest

os.environ.setdefault("POWERTOOLS_SERVICE_NAME", "drboard")
os.environ.setdefault("POWERTOOLS_METRICS_NAMESPACE", "drboard")
os.environ.setdefault("POWERTOOLS_TRACE_DISABLED", "true")

from drboard_assembler import limits
from drboard_cli.serve import LocalContext
from drboard_functions.errors import SubmissionTooLarge
from drboard_functions.handlers import admin, push
from drboard_functions.models.requests import ImportedSubmission
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record
from tests.unit.test_handlers import load
from tests.wiringkit import use_service

pytestmark = pytest.mark.filterwarnings("ignore:No application metrics to publish")

Handler = Callable[[dict[str, Any], Any], dict[str, Any]]
#: The routes that take a record: a racer's push, and an organiser's import of one submission.
HANDLERS = {"push": (push.lambda_handler, "push.json"),
            "import": (admin.lambda_handler, "admin_import_submission.json")}


@pytest.fixture
def service(monkeypatch: pytest.MonkeyPatch) -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    service = LeaderboardService(store)
    use_service(monkeypatch, service)
    yield service
    store.close()


def send(route: str, body: str | None, *, headers: dict[str, str] | None = None,
         base64_encoded: bool = False, exact_length: bool = True) -> dict[str, Any]:
    handler, name = HANDLERS[route]
    event = load(name)
    event["body"] = body
    event["isBase64Encoded"] = base64_encoded
    if exact_length and body is not None:
        raw = base64.b64decode(body) if base64_encoded else body.encode("utf-8", "surrogatepass")
        event["headers"]["content-length"] = str(len(raw))
    event["headers"].update(headers or {})
    return handler(event, LocalContext())


def refusal(answer: dict[str, Any]) -> tuple[int, str]:
    assert 400 <= answer["statusCode"] < 500, answer
    return answer["statusCode"], json.loads(answer["body"])["error"]


def deeply_nested(size: int) -> str:
    depth = size // 2
    return "[" * depth + "]" * depth


HOSTILE: dict[str, dict[str, Any]] = {
    "60 KB of nested arrays": {"body": deeply_nested(60_000)},
    "nested objects inside a record": {"body": '{"design": ' + '{"a": ' * 9_000 + "1" + "}" * 9_001},
    "a 5,000-digit integer": {"body": '{"racer": "Ada", "laps": ' + "9" * 5_000 + "}"},
    "multipart without a boundary": {"body": "--x\r\n\r\nAda\r\n--x--",
                                     "headers": {"content-type": "multipart/form-data"}},
    "multipart with a boundary": {"body": "--x\r\nContent-Disposition: form-data; name=a\r\n\r\n1"
                                          "\r\n--x--", "headers": {"content-type":
                                                                   "multipart/form-data; boundary=x"}},
    "a Content-Length that is not a number": {"body": "{}", "headers": {"content-length": "12abc"}},
    "a negative Content-Length": {"body": "{}", "headers": {"content-length": "-2"}},
    "a Content-Length shorter than the body": {"body": '{"racer": "Ada"}',
                                               "headers": {"content-length": "3"}},
    "a Content-Length longer than the body": {"body": "{}", "headers": {"content-length": "70000"}},
    "invalid UTF-8": {"body": base64.b64encode(b'{"racer": "Ad\xff\xfe"}').decode(),
                      "base64_encoded": True},
    "base64 that does not decode": {"body": "eyJy!!!", "base64_encoded": True},
    "a lone surrogate": {"body": '{"racer": "Ad\ud800"}'},
    "JSON that is not an object": {"body": "[1, 2, 3]"},
    "a JSON string": {"body": '"Ada"'},
}
EXPECTED = {
    "60 KB of nested arrays": (422, "InvalidSubmission"),
    "nested objects inside a record": (422, "InvalidSubmission"),
    "a 5,000-digit integer": (422, "InvalidSubmission"),
    "multipart without a boundary": (415, "UnsupportedBody"),
    "multipart with a boundary": (415, "UnsupportedBody"),
    "a Content-Length that is not a number": (400, "UnreadableBody"),
    "a negative Content-Length": (400, "UnreadableBody"),
    "a Content-Length shorter than the body": (400, "UnreadableBody"),
    "a Content-Length longer than the body": (400, "UnreadableBody"),
    "invalid UTF-8": (400, "UnreadableBody"),
    "base64 that does not decode": (400, "UnreadableBody"),
    "a lone surrogate": (400, "UnreadableBody"),
    "JSON that is not an object": (422, "InvalidSubmission"),
    "a JSON string": (422, "InvalidSubmission"),
}


@pytest.mark.parametrize("route", HANDLERS)
@pytest.mark.parametrize("case", HOSTILE)
def test_a_hostile_body_is_refused_cleanly_and_stores_nothing(
        service: LeaderboardService, route: str, case: str) -> None:
    if route == "import":
        service.store.create_board(_event_board())
    given = HOSTILE[case]
    exact = "content-length" not in given.get("headers", {})
    answer = send(route, given["body"], headers=given.get("headers"),
                  base64_encoded=given.get("base64_encoded", False), exact_length=exact)
    assert refusal(answer) == EXPECTED[case]
    assert json.loads(answer["body"])["message"]
    assert all(stored.participants == 0 for stored in service.store.list_boards())


def _event_board() -> Any:
    from drboard_functions.models.domain import Board

    return Board.model_validate_json(load("admin_import_board.json")["body"])


@pytest.mark.parametrize("route", HANDLERS)
def test_the_example_bodies_still_go_through(service: LeaderboardService, route: str) -> None:
    if route == "import":
        service.store.create_board(_event_board())
    handler, name = HANDLERS[route]
    assert handler(load(name), LocalContext())["statusCode"] == 201


# ---- the record's byte bound lives in the service ---------------------------------------------------


def big_record() -> Any:
    """A valid record of four full evaluation runs: about 148 KB of JSON."""
    return make_record(runs=[[(12_000 + lap, 100) for lap in range(limits.MAX_LAPS_PER_RUN)]] * 4)


def test_the_embedded_board_refuses_a_record_over_the_bound_as_the_cloud_does(
        service: LeaderboardService) -> None:
    record = big_record()
    size = len(record.model_dump_json().encode())
    assert size > 2 * limits.MAX_RECORD_BYTES
    with pytest.raises(SubmissionTooLarge, match=f"{size} bytes, over the {limits.MAX_RECORD_BYTES}"):
        service.push(record)
    assert service.boards() == []

    answer = send("push", record.model_dump_json())  # the cloud's push function
    assert refusal(answer) == (413, "SubmissionTooLarge")


def test_an_import_holds_its_record_to_the_same_bound(service: LeaderboardService) -> None:
    board = _event_board()
    service.store.create_board(board)
    item = ImportedSubmission(submitted_at=board.created_at,
                              record=make_record(runs=[[(12_000 + lap, 100) for lap in range(200)]] * 2,
                                                 track=board.track))
    assert len(item.record.model_dump_json()) > limits.MAX_RECORD_BYTES
    with pytest.raises(SubmissionTooLarge):
        service.import_submission(board.board_id, item)
    assert service.store.list_boards()[0].participants == 0
