"""The HTTP routes through Powertools' resolver, on an in-memory SQLite board.

Each test gets its own service and resolver; requests are API Gateway HTTP API (v2) events.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlencode

import pytest
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver, DependencyResolutionError
from drboard_assembler import limits
from drboard_assembler.record import Record
from drboard_functions.errors import InvalidSubmission, TooSoon
from drboard_functions.models import BoardPage, PushReceipt, RacerView
from drboard_functions.routes import build_app, field_path, pull_router, push_router
from drboard_functions.service import LeaderboardService, default_board_id
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import LapSpec, make_record, make_run

EVENTS = Path(__file__).parents[2] / "events"
TRACK = "reInvent2019_track"
T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)


class Clock:
    def __init__(self) -> None:
        self.calls = 0

    def __call__(self) -> datetime:
        self.calls += 1
        return T0 + timedelta(seconds=self.calls)


@pytest.fixture
def service() -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    yield LeaderboardService(store, clock=Clock())
    store.close()


@pytest.fixture
def app() -> APIGatewayHttpResolver:
    return build_app(push_router, pull_router)


class Client:
    """Sends v2 events through the resolver, with the service in its context."""

    def __init__(self, app: APIGatewayHttpResolver, service: LeaderboardService) -> None:
        self.app = app
        self.service = service

    def request(self, method: str, path: str, *, body: str | None = None,
                query: dict[str, str] | None = None,
                headers: dict[str, str] | None = None) -> dict[str, Any]:
        event = {
            "version": "2.0",
            "routeKey": "$default",
            "rawPath": path,
            "rawQueryString": urlencode(query or {}),
            "headers": {"content-type": "application/json"} | (headers or {}),
            "queryStringParameters": query,
            "requestContext": {
                "accountId": "123456789012", "apiId": "local", "requestId": "r1",
                "http": {"method": method, "path": path, "protocol": "HTTP/1.1",
                         "sourceIp": "127.0.0.1", "userAgent": "pytest"},
                "routeKey": "$default", "stage": "$default", "timeEpoch": 0,
            },
            "body": body,
            "isBase64Encoded": False,
        }
        self.app.append_context(service=self.service)
        return self.app.resolve(event, None)  # type: ignore[arg-type]

    def push(self, record: Record | str | dict[str, Any], board: str | None = None) -> dict[str, Any]:
        if board is None:  # the run's own board, as `drboard push` picks it
            board = (default_board_id(record.track, record.direction, record.race_type)
                     if isinstance(record, Record) else TRACK)
        if isinstance(record, Record):
            body = record.model_dump_json()
        elif isinstance(record, dict):
            body = json.dumps(record)
        else:
            body = record
        return self.request("POST", f"/boards/{quote(board, safe='')}/submissions", body=body)

    def get(self, path: str, **query: str) -> dict[str, Any]:
        return self.request("GET", path, query=query or None)


@pytest.fixture
def client(app: APIGatewayHttpResolver, service: LeaderboardService) -> Client:
    return Client(app, service)


def body(response: dict[str, Any]) -> Any:
    return json.loads(response["body"])


def lap(ms: int) -> list[LapSpec]:
    return [(ms, 100)]


def example_record() -> Record:
    event = json.loads((EVENTS / "push.json").read_text())
    return Record.model_validate_json(event["body"])


# ---- push -------------------------------------------------------------------------------------


def test_a_new_submission_is_201_and_the_same_run_again_is_200(client: Client) -> None:
    record = example_record()
    first = client.push(record)
    assert first["statusCode"] == 201
    receipt = PushReceipt.model_validate(body(first))
    assert (receipt.status, receipt.board_id, receipt.rank, receipt.improved) == (
        "created", TRACK, 1, True)
    assert receipt.submission_id == record.submission_id
    assert receipt.entry.racer == record.racer

    again = client.push(record)
    assert again["statusCode"] == 200
    duplicate = PushReceipt.model_validate(body(again))
    assert (duplicate.status, duplicate.improved, duplicate.participants) == ("duplicate", False, 1)
    assert duplicate.submission.submitted_at == receipt.submission.submitted_at


def test_push_answers_json_without_cors_headers(client: Client) -> None:
    response = client.request("POST", f"/boards/{TRACK}/submissions",
                              body=make_record().model_dump_json(),
                              headers={"origin": "https://club.example.org"})
    assert response["statusCode"] == 201
    assert response["headers"]["Content-Type"] == "application/json"
    assert "Access-Control-Allow-Origin" not in response["headers"]


def test_a_field_out_of_bounds_is_422_with_its_path(client: Client) -> None:
    record = make_record(laps=[(12000, 100), (13000, 100), (14000, 100)]).model_dump(mode="json")
    record["evaluations"][0]["laps"][2]["time_ms"] = -5
    response = client.push(record)
    assert response["statusCode"] == 422
    answer = body(response)
    assert answer["error"] == "InvalidSubmission"
    assert {"loc": "evaluations[0].laps[2].time_ms", "msg": "Input should be greater than or equal to 0",
            "type": "greater_than_equal"} in answer["detail"]
    assert answer["message"] == "the record is invalid"


def test_a_tampered_lap_time_is_422_because_the_figures_disagree(client: Client) -> None:
    record = make_record(laps=[(12000, 100), (13000, 100)]).model_dump(mode="json")
    record["evaluations"][0]["laps"][0]["time_ms"] = 9000  # a faster lap than was driven
    response = client.push(record)
    assert response["statusCode"] == 422
    [problem] = body(response)["detail"]
    assert problem["loc"] == "evaluations[0]"
    assert "best_lap_ms is 12000 but the laps give 9000" in problem["msg"]
    assert client.get("/boards")["body"] == '{"boards":[]}'  # nothing was written


def test_a_tampered_racer_is_422_because_the_submission_id_disagrees(client: Client) -> None:
    record = make_record("Ada").model_dump(mode="json")
    record["racer"] = "Grace"
    response = client.push(record)
    assert response["statusCode"] == 422
    [problem] = body(response)["detail"]
    assert problem["loc"] == "record"
    assert "submission_id does not match" in problem["msg"]


def test_an_impossibly_fast_lap_is_422(client: Client) -> None:
    record = make_record().model_dump(mode="json")
    record["evaluations"] = [make_run([(1000, 100)]).model_dump(mode="json")]
    response = client.push(record)
    assert response["statusCode"] == 422
    assert "faster than possible" in body(response)["detail"][0]["msg"]


def test_unknown_fields_are_refused(client: Client) -> None:
    record = make_record().model_dump(mode="json")
    record["design"]["secret_sauce"] = True
    response = client.push(record)
    assert response["statusCode"] == 422
    assert body(response)["detail"][0]["loc"] == "design.secret_sauce"


def test_malformed_json_is_422(client: Client) -> None:
    response = client.push('{"track": "reInvent2019_track", ')
    assert response["statusCode"] == 422
    answer = body(response)
    assert answer["message"] == "the request body is not valid JSON"
    assert answer["detail"][0]["type"] == "json_invalid"


def test_an_empty_body_is_422(client: Client) -> None:
    response = client.push("")
    assert response["statusCode"] == 422
    assert body(response)["error"] == "InvalidSubmission"


def test_a_body_that_is_not_json_is_415(client: Client) -> None:
    response = client.request("POST", f"/boards/{TRACK}/submissions", body="racer=Ada",
                              headers={"content-type": "text/plain"})
    assert response["statusCode"] == 415


def test_an_oversized_body_is_413_before_it_is_parsed(client: Client) -> None:
    # Not even JSON: had it been parsed, the answer would be 422.
    response = client.push("{" * (limits.MAX_RECORD_BYTES + 1))
    assert response["statusCode"] == 413
    answer = body(response)
    assert answer["error"] == "SubmissionTooLarge"
    assert str(limits.MAX_RECORD_BYTES) in answer["message"]


def test_the_size_bound_counts_bytes_not_characters(client: Client) -> None:
    record = make_record().model_dump(mode="json")
    record["padding"] = "é" * (limits.MAX_RECORD_BYTES // 2)  # under the bound in characters
    assert len(json.dumps(record, ensure_ascii=False)) < limits.MAX_RECORD_BYTES
    assert client.push(json.dumps(record, ensure_ascii=False))["statusCode"] == 413


def test_a_record_just_under_the_bound_is_validated(client: Client) -> None:
    record = make_record().model_dump(mode="json")
    text = json.dumps(record)
    padded = text[:-1] + " " * (limits.MAX_RECORD_BYTES - len(text)) + "}"
    assert len(padded) == limits.MAX_RECORD_BYTES
    assert client.push(padded)["statusCode"] == 201


def test_a_run_pushed_to_another_tracks_board_is_422(client: Client) -> None:
    assert client.push(make_record("Ada", track="Vegas_track"))["statusCode"] == 201
    response = client.push(make_record("Bob"), board="Vegas_track")
    assert response["statusCode"] == 422
    assert body(response)["error"] == "BoardMismatch"


def test_a_push_to_a_board_that_does_not_exist_is_404(client: Client) -> None:
    response = client.push(make_record(), board="spring-cup")
    assert response["statusCode"] == 404
    assert body(response)["error"] == "BoardNotFound"


def test_a_submission_limit_is_429_with_retry_after(app: APIGatewayHttpResolver) -> None:
    class Limited(LeaderboardService):
        def push(self, record: Record, board_id: str | None = None) -> PushReceipt:
            raise TooSoon("one submission a minute", retry_after_s=42)

    store = SqliteStore(":memory:")
    response = Client(app, Limited(store)).push(make_record())
    store.close()
    assert response["statusCode"] == 429
    assert response["headers"]["Retry-After"] == "42"
    assert body(response)["error"] == "TooSoon"


def test_the_routes_need_a_service_in_the_context(app: APIGatewayHttpResolver) -> None:
    client = Client(app, None)  # type: ignore[arg-type]
    with pytest.raises(DependencyResolutionError, match="append_context"):
        client.get("/boards")


# ---- pull -------------------------------------------------------------------------------------


def test_boards_lists_every_board(client: Client) -> None:
    client.push(make_record("Ada"))
    client.push(make_record("Bob", direction="cw"))
    response = client.get("/boards")
    assert response["statusCode"] == 200
    boards = body(response)["boards"]
    assert [(b["board_id"], b["track_name"], b["participants"]) for b in boards] == [
        (TRACK, "Smile Speedway", 1), (TRACK + "_cw", "Smile Speedway", 1)]


def test_a_board_lists_its_entries_in_rank_order(client: Client) -> None:
    for racer, ms in [("Cleo", 14000), ("Ada", 12000), ("Bob", 13000), ("Dan", 12000)]:
        client.push(make_record(racer, lap(ms)))
    client.push(make_record("Eve", [(5000, 40)]))
    page = BoardPage.model_validate(body(client.get(f"/boards/{TRACK}")))
    assert [(e.rank, e.racer, e.gap_ms) for e in page.entries] == [
        (1, "Ada", 0), (1, "Dan", 0), (3, "Bob", 1000), (4, "Cleo", 2000), (5, "Eve", None)]
    assert page.next_cursor is None
    assert page.board.participants == 5


def test_a_board_pages_with_limit_and_cursor(client: Client) -> None:
    for n, racer in enumerate(["Ada", "Bob", "Cleo", "Dan", "Eve"]):
        client.push(make_record(racer, lap(12000 + 1000 * n)))
    seen: list[tuple[int, str]] = []
    cursor: str | None = None
    pages = 0
    while True:
        query = {"limit": "2"} | ({"cursor": cursor} if cursor else {})
        response = client.get(f"/boards/{TRACK}", **query)
        assert response["statusCode"] == 200
        page = BoardPage.model_validate(body(response))
        seen += [(e.rank, e.racer) for e in page.entries]
        pages += 1
        cursor = page.next_cursor
        if cursor is None:
            break
    assert seen == [(1, "Ada"), (2, "Bob"), (3, "Cleo"), (4, "Dan"), (5, "Eve")]
    assert pages == 3


@pytest.mark.parametrize("query", [{"limit": "0"}, {"limit": "501"}, {"limit": "ten"},
                                   {"cursor": "not-a-cursor"}, {"cursor": "x" * 2000}])
def test_a_bad_limit_or_cursor_is_400(client: Client, query: dict[str, str]) -> None:
    client.push(make_record())
    response = client.get(f"/boards/{TRACK}", **query)
    assert response["statusCode"] == 400
    answer = body(response)
    assert answer["error"] == "InvalidQuery"
    assert answer["message"]


def test_the_largest_page_is_500(client: Client) -> None:
    client.push(make_record())
    assert client.get(f"/boards/{TRACK}", limit="500")["statusCode"] == 200


def test_an_unknown_board_is_404(client: Client) -> None:
    for path in ("/boards/nowhere", "/boards/nowhere/racers/Ada", "/boards/nowhere/view"):
        response = client.get(path)
        assert response["statusCode"] == 404, path


def test_an_unknown_racer_is_404(client: Client) -> None:
    client.push(make_record("Ada"))
    response = client.get(f"/boards/{TRACK}/racers/Nobody")
    assert response["statusCode"] == 404
    assert body(response)["error"] == "RacerNotFound"


def test_a_racer_shows_entry_history_and_record(client: Client) -> None:
    client.push(make_record("Ada Lovelace", lap(13000), model="first"))
    client.push(make_record("Ada Lovelace", lap(12000), model="second"))
    client.push(make_record("Bob", lap(11000)))
    response = client.get(f"/boards/{TRACK}/racers/{quote('ada lovelace')}")
    assert response["statusCode"] == 200
    view = RacerView.model_validate(body(response))
    assert (view.racer, view.entry.rank, view.entry.gap_ms) == ("Ada Lovelace", 2, 1000)
    assert [(h.model_name, h.is_best) for h in view.history] == [("first", False), ("second", True)]
    assert view.record.model_name == "second"


def test_reads_carry_cors_headers_for_browsers(client: Client) -> None:
    client.push(make_record())
    response = client.request("GET", f"/boards/{TRACK}", headers={"origin": "https://club.example.org"})
    assert response["statusCode"] == 200
    assert response["headers"]["Access-Control-Allow-Origin"] == "*"


def test_a_cors_preflight_is_answered(client: Client) -> None:
    response = client.request("OPTIONS", "/boards", headers={
        "origin": "https://club.example.org", "access-control-request-method": "GET"})
    assert response["statusCode"] == 204
    assert response["headers"]["Access-Control-Allow-Origin"] == "*"


# ---- pages ------------------------------------------------------------------------------------


def test_the_board_page_shows_times_gaps_and_designs(client: Client) -> None:
    client.push(make_record("Ada", lap(12345)))
    client.push(make_record("Bob", lap(13000)))
    response = client.get(f"/boards/{TRACK}/view")
    assert response["statusCode"] == 200
    assert response["headers"]["Content-Type"] == "text/html; charset=utf-8"
    assert "default-src 'none'" in response["headers"]["Content-Security-Policy"]
    page = response["body"]
    assert "<title>Smile Speedway · drboard</title>" in page
    assert "12.345 s" in page and "+0.655 s" in page and "leader" in page
    assert "PPO, 3 actions, 3 m/s, ±30°; FRONT_FACING_CAMERA" in page


def test_the_board_page_escapes_what_racers_typed(client: Client) -> None:
    client.push(make_record("<script>alert(1)</script>", lap(12000), model='m"><img src=x>'))
    page = client.get(f"/boards/{TRACK}/view")["body"]
    assert "<script>" not in page and "<img" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "m&quot;&gt;&lt;img src=x&gt;" in page


def test_the_index_lists_the_boards_and_escapes_custom_track_names(client: Client) -> None:
    client.push(make_record("Ada"))
    client.push(make_record("Bob", track="<b>My track</b>"))
    response = client.get("/")
    assert response["statusCode"] == 200
    page = response["body"]
    assert '<a href="/boards/reInvent2019_track/view">Smile Speedway</a>' in page
    assert "<b>" not in page
    assert "&lt;b&gt;My track&lt;/b&gt;" in page
    assert 'href="/boards/%3Cb%3EMy%20track%3C%2Fb%3E/view"' in page


def test_the_index_of_an_empty_board_says_how_to_start(client: Client) -> None:
    assert "drboard push" in client.get("/")["body"]


def test_the_board_page_links_to_its_next_page(client: Client) -> None:
    for n, racer in enumerate(["Ada", "Bob", "Cleo"]):
        client.push(make_record(racer, lap(12000 + 1000 * n)))
    first = client.get(f"/boards/{TRACK}/view", limit="2")["body"]
    assert "Next page" in first and "cursor=" in first
    assert "Cleo" not in first


def test_a_missing_board_page_is_an_html_404(client: Client) -> None:
    response = client.get("/boards/%3Cscript%3E/view")
    assert response["statusCode"] == 404
    assert response["headers"]["Content-Type"] == "text/html; charset=utf-8"
    assert "<script>" not in response["body"]
    assert "&#x27;&lt;script&gt;&#x27;" in response["body"]


# ---- helpers ----------------------------------------------------------------------------------


def test_field_paths_read_like_the_record() -> None:
    assert field_path(("evaluations", 0, "laps", 2, "time_ms")) == "evaluations[0].laps[2].time_ms"
    assert field_path(()) == ""
    assert field_path(("design", "action_space")) == "design.action_space"


def test_a_domain_errors_own_detail_is_passed_on(app: APIGatewayHttpResolver) -> None:
    class Picky(LeaderboardService):
        def push(self, record: Record, board_id: str | None = None) -> PushReceipt:
            raise InvalidSubmission("the model is banned", detail=[{"loc": "model_name", "msg": "banned"}])

    store = SqliteStore(":memory:")
    response = Client(app, Picky(store)).push(make_record())
    store.close()
    assert response["statusCode"] == 422
    assert body(response) == {"error": "InvalidSubmission", "message": "the model is banned",
                              "detail": [{"loc": "model_name", "msg": "banned", "type": "value_error"}]}


@pytest.mark.filterwarnings("ignore:Received multipart/form-data without base64")
@pytest.mark.parametrize("content_type", ["application/x-www-form-urlencoded",
                                          "multipart/form-data; boundary=x"])
def test_a_form_body_is_refused(client: Client, content_type: str) -> None:
    response = client.request("POST", f"/boards/{TRACK}/submissions", body="racer=Ada",
                              headers={"content-type": content_type})
    assert response["statusCode"] == 422
    assert client.service.boards() == []
