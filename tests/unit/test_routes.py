"""The HTTP routes through Powertools' resolver, on an in-memory SQLite board.

Each test gets its own service and resolver; requests are API Gateway HTTP API (v2) events.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlencode

import pytest
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver, DependencyResolutionError
from drboard_assembler import limits
from drboard_assembler.errors import field_path
from drboard_assembler.record import Record
from drboard_functions import web
from drboard_functions.errors import (
    AliasTaken,
    Banned,
    BoardClosed,
    BoardExists,
    BoardLocked,
    CopiedRun,
    DomainError,
    InvalidSubmission,
    NotAuthorized,
    NotSignedIn,
    SubmissionLimitReached,
    TooSoon,
)
from drboard_functions.models.domain import Board
from drboard_functions.models.racer_views import RacerHistory, RacerSummary, RacerView
from drboard_functions.models.transfer import ExportedBoard, ExportedEntry, ExportedSubmission, ExportPage
from drboard_functions.models.views import BoardPage, BoardView, PushReceipt
from drboard_functions.routes import (
    IMPORT_BODY,
    MAX_BOARD_BODY_BYTES,
    admin_router,
    build_app,
    pull_router,
    push_router,
)
from drboard_functions.routes.headers import PUBLIC_CACHE
from drboard_functions.service import LeaderboardService, default_board_id
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import LapSpec, make_record, make_run

EVENTS = Path(__file__).parents[2] / "events"
TRACK = "reInvent2019_track"
T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)


class Clock:
    """A second passes at every reading; ``advance`` moves time on, as a racer waiting would."""

    def __init__(self) -> None:
        self.calls = 0
        self.waited = timedelta()

    def __call__(self) -> datetime:
        self.calls += 1
        return T0 + self.waited + timedelta(seconds=self.calls)

    def advance(self, seconds: int) -> None:
        self.waited += timedelta(seconds=seconds)


@pytest.fixture
def service() -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    yield LeaderboardService(store, clock=Clock())
    store.close()


@pytest.fixture
def app() -> APIGatewayHttpResolver:
    return build_app(push_router, pull_router, admin_router)


#: What API Gateway's IAM authorizer adds to a signed request (an organiser's script).
IAM_ORGANISER: dict[str, Any] = {"iam": {"userArn": "arn:aws:sts::123456789012:assumed-role/org/ada"}}
#: What its JWT authorizer adds for a signed-in racer who is not an organiser.
SIGNED_IN_RACER: dict[str, Any] = {"jwt": {"claims": {"sub": "7d3c", "token_use": "access",
                                                     "username": "speedy"}, "scopes": None}}


class Client:
    """Sends v2 events through the resolver, with the service in its context."""

    def __init__(self, app: APIGatewayHttpResolver, service: LeaderboardService) -> None:
        self.app = app
        self.service = service

    def request(self, method: str, path: str, *, body: str | None = None,
                query: dict[str, str | list[str]] | None = None,
                headers: dict[str, str] | None = None,
                authorizer: dict[str, Any] | None = IAM_ORGANISER) -> dict[str, Any]:
        event: dict[str, Any] = {
            "version": "2.0",
            "routeKey": "$default",
            "rawPath": path,
            "rawQueryString": urlencode(query or {}, doseq=True),
            "headers": {"content-type": "application/json"} | (headers or {}),
            # API Gateway joins a repeated parameter's values with commas
            "queryStringParameters": {name: value if isinstance(value, str) else ",".join(value)
                                      for name, value in query.items()} if query else None,
            "requestContext": {
                "accountId": "123456789012", "apiId": "local", "requestId": "r1",
                "http": {"method": method, "path": path, "protocol": "HTTP/1.1",
                         "sourceIp": "127.0.0.1", "userAgent": "pytest"},
                "routeKey": "$default", "stage": "$default", "timeEpoch": 0,
            } | ({"authorizer": authorizer} if authorizer else {}),
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

    def get(self, path: str, **query: str | list[str]) -> dict[str, Any]:
        return self.request("GET", path, query=query or None)

    def send(self, method: str, path: str, body: Any = None, **query: str) -> dict[str, Any]:
        """An organiser's request; a body that is not a string is sent as JSON."""
        text = body if body is None or isinstance(body, str) else json.dumps(body)
        return self.request(method, path, body=text, query=query or None)

    @property
    def clock(self) -> Clock:
        assert isinstance(self.service.clock, Clock)
        return self.service.clock


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
    assert client.get("/boards")["body"] == '{"boards":[],"next_cursor":null}'  # nothing was written


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
        def push(self, record: Record, board_id: str | None = None, caller: Any = None) -> PushReceipt:
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
    assert page.count("<script") == 1 and f"<script>{web.assets().script}</script>" in page
    assert "<img" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "m&#34;&gt;&lt;img src=x&gt;" in page


def test_the_index_lists_the_boards_and_escapes_custom_track_names(client: Client) -> None:
    client.push(make_record("Ada"))
    # A push names a custom track with letters, digits, _ - . only; a board stored before that
    # rule keeps its name, and the page escapes it.
    hostile = Board(board_id="custom.<b>My track</b>", track="<b>My track</b>",
                    title="<b>My track</b>", created_at=datetime(2026, 3, 1, tzinfo=UTC))
    client.service.store.create_board(hostile)
    response = client.get("/")
    assert response["statusCode"] == 200
    page = response["body"]
    assert '<a href="/boards/reInvent2019_track/view">Smile Speedway</a>' in page
    assert "<b>" not in page
    assert "&lt;b&gt;My track&lt;/b&gt;" in page
    assert 'href="/boards/custom.%3Cb%3EMy%20track%3C%2Fb%3E/view"' in page


def test_the_index_of_an_empty_board_says_how_to_start(client: Client) -> None:
    assert "drboard push" in client.get("/")["body"]


def test_the_board_page_links_to_its_next_page(client: Client) -> None:
    for n, racer in enumerate(["Ada", "Bob", "Cleo"]):
        client.push(make_record(racer, lap(12000 + 1000 * n)))
    first = client.get(f"/boards/{TRACK}/view", limit="2")["body"]
    assert "Next page" in first and "cursor=" in first
    assert "Cleo" not in first


def test_a_missing_board_page_is_an_html_404_that_waits_for_the_board(client: Client) -> None:
    response = client.get("/boards/%3Cscript%3E/view")
    assert response["statusCode"] == 404
    assert response["headers"]["Content-Type"] == "text/html; charset=utf-8"
    assert response["body"].count("<script") == 1
    assert "&lt;script&gt;" in response["body"]
    assert 'data-missing="1"' in response["body"] and "first push" in response["body"]


def test_the_live_page_allows_only_its_own_script(client: Client) -> None:
    client.push(make_record("Ada", lap(12000)))
    response = client.get(f"/boards/{TRACK}/view")
    policy = response["headers"]["Content-Security-Policy"]
    assert f"script-src '{web.assets().script_hash}'" in policy and "connect-src 'self'" in policy
    assert "default-src 'none'" in policy
    assert 'data-racer="Ada"' in response["body"]


def test_the_live_page_answers_304_while_the_board_is_unchanged(client: Client) -> None:
    client.push(make_record("Ada", lap(12000)))
    first = client.get(f"/boards/{TRACK}/view")
    etag = first["headers"]["ETag"]
    assert f'data-etag="{etag.replace(chr(34), "&#34;")}"' in first["body"]
    same = client.request("GET", f"/boards/{TRACK}/view", headers={"if-none-match": etag})
    assert same["statusCode"] == 304 and same["body"] == ""
    client.push(make_record("Bob", lap(11000)))
    changed = client.request("GET", f"/boards/{TRACK}/view", headers={"if-none-match": etag})
    assert changed["statusCode"] == 200 and changed["headers"]["ETag"] != etag
    assert changed["body"].index('data-racer="Bob"') < changed["body"].index('data-racer="Ada"')


# ---- helpers ----------------------------------------------------------------------------------


def test_field_paths_read_like_the_record() -> None:
    assert field_path(("evaluations", 0, "laps", 2, "time_ms")) == "evaluations[0].laps[2].time_ms"
    assert field_path(()) == ""
    assert field_path(("design", "action_space")) == "design.action_space"


def test_a_domain_errors_own_detail_is_passed_on(app: APIGatewayHttpResolver) -> None:
    class Picky(LeaderboardService):
        def push(self, record: Record, board_id: str | None = None, caller: Any = None) -> PushReceipt:
            raise InvalidSubmission("the model is banned", detail=[{"loc": "model_name", "msg": "banned"}])

    store = SqliteStore(":memory:")
    response = Client(app, Picky(store)).push(make_record())
    store.close()
    assert response["statusCode"] == 422
    assert body(response) == {"error": "InvalidSubmission", "message": "the model is banned",
                              "detail": [{"loc": "model_name", "msg": "banned", "type": "value_error"}]}


@pytest.mark.parametrize(("content_type", "status"), [
    ("application/x-www-form-urlencoded", 422), ("multipart/form-data; boundary=x", 415),
    ("multipart/form-data", 415)])
def test_a_form_body_is_refused(client: Client, content_type: str, status: int) -> None:
    response = client.request("POST", f"/boards/{TRACK}/submissions", body="racer=Ada",
                              headers={"content-type": content_type})
    assert response["statusCode"] == status
    assert client.service.boards() == []


# ---- racers across boards ---------------------------------------------------------------------


CUP = "spring-cup"


def cup_spec(**settings: Any) -> dict[str, Any]:
    return {"board_id": CUP, "title": "Spring Cup", "track": "reInvent2019"} | settings


def create_cup(client: Client, **settings: Any) -> BoardView:
    response = client.send("POST", "/boards", cup_spec(**settings))
    assert response["statusCode"] == 201, response["body"]
    return BoardView.model_validate(body(response))


def test_a_racers_status_covers_each_board_they_pushed_to_latest_first(client: Client) -> None:
    client.push(make_record("Ada Lovelace", lap(13000)))
    client.push(make_record("Bob", lap(12000)))
    client.push(make_record("Ada Lovelace", lap(12500), direction="cw"))
    response = client.get(f"/racers/{quote('ada lovelace')}")
    assert response["statusCode"] == 200
    summary = RacerSummary.model_validate(body(response))
    assert summary.racer == "Ada Lovelace"
    assert [(s.board.board_id, s.entry.rank, s.entry.gap_ms, s.submissions) for s in summary.boards] == [
        (TRACK + "_cw", 1, 0, 1), (TRACK, 2, 1000, 1)]
    one = RacerSummary.model_validate(body(client.get("/racers/Ada%20Lovelace", board=TRACK)))
    assert [s.board.board_id for s in one.boards] == [TRACK]


def test_a_racers_status_says_what_the_board_still_allows(client: Client) -> None:
    create_cup(client, cooldown_s=600, max_submissions=3)
    client.push(make_record("Ada"), board=CUP)
    [status] = RacerSummary.model_validate(body(client.get("/racers/Ada", board=CUP))).boards
    assert (status.submissions, status.submissions_left) == (1, 2)
    assert status.next_submission_at is not None
    assert status.next_submission_at - status.latest.submitted_at == timedelta(seconds=600)


def test_a_racers_submissions_span_boards_oldest_first(client: Client) -> None:
    client.push(make_record("Ada", lap(13000), model="first"))
    client.push(make_record("Ada", lap(12000), model="second", direction="cw"))
    client.push(make_record("Ada", lap(14000), model="third"))
    response = client.get("/racers/ada/submissions")
    assert response["statusCode"] == 200
    history = RacerHistory.model_validate(body(response)).history
    assert [(h.model_name, h.board_id, h.is_best) for h in history] == [
        ("first", TRACK, True), ("second", TRACK + "_cw", True), ("third", TRACK, False)]
    one = RacerHistory.model_validate(body(client.get("/racers/Ada/submissions", board=TRACK)))
    assert [h.model_name for h in one.history] == ["first", "third"]


def test_a_racer_without_submissions_has_an_empty_history(client: Client) -> None:
    response = client.get("/racers/Nobody/submissions")
    assert response["statusCode"] == 200
    assert body(response) == {"racer": "Nobody", "history": [], "next_cursor": None}


@pytest.mark.parametrize(("path", "query", "error"), [
    ("/racers/Nobody", {}, "RacerNotFound"),
    ("/racers/Ada", {"board": "nowhere"}, "BoardNotFound"),
    ("/racers/Ada/submissions", {"board": "nowhere"}, "BoardNotFound"),
])
def test_a_racer_or_board_that_is_not_there_is_404(client: Client, path: str, query: dict[str, str],
                                                   error: str) -> None:
    client.push(make_record("Ada"))
    response = client.get(path, **query)
    assert response["statusCode"] == 404
    assert body(response)["error"] == error


@pytest.mark.parametrize("path", ["/racers/" + "a" * 300, "/racers/Ada/submissions"])
def test_a_racer_lookup_with_a_bad_parameter_is_400(client: Client, path: str) -> None:
    response = client.get(path, board="b" * 300)
    assert response["statusCode"] == 400
    assert body(response)["error"] == "InvalidQuery"


def test_racer_reads_are_public_and_carry_cors_headers(client: Client) -> None:
    client.push(make_record("Ada"))
    response = client.request("GET", "/racers/Ada", headers={"origin": "https://club.example.org"})
    assert response["statusCode"] == 200
    assert response["headers"]["Access-Control-Allow-Origin"] == "*"


# ---- organisers: named boards -----------------------------------------------------------------


def test_an_organiser_creates_a_named_board_that_racers_push_to(client: Client) -> None:
    board = create_cup(client, method="TOTAL_TIME", cooldown_s=60, max_submissions=5,
                       closes_at="2025-04-01T18:00:00+02:00")
    assert (board.board_id, board.kind, board.track, board.method, board.min_laps, board.status) == (
        CUP, "named", TRACK, "TOTAL_TIME", 3, "OPEN")
    assert board.closes_at == datetime(2025, 4, 1, 16, 0, tzinfo=UTC)
    assert [b["board_id"] for b in body(client.get("/boards"))["boards"]] == [CUP]
    pushed = client.push(make_record("Ada", [(12000, 100)] * 3), board=CUP)
    assert pushed["statusCode"] == 201
    assert PushReceipt.model_validate(body(pushed)).entry.time_ms == 36000


def test_a_board_id_already_taken_is_409(client: Client) -> None:
    create_cup(client)
    again = client.send("POST", "/boards", cup_spec(title="Another cup"))
    assert again["statusCode"] == 409
    assert body(again)["error"] == "BoardExists"
    default = client.send("POST", "/boards", cup_spec(board_id=TRACK))
    assert default["statusCode"] == 409
    assert body(default)["error"] == "BoardExists"


@pytest.mark.parametrize(("settings", "status", "loc"), [
    ({"track": "Nowhere Speedway"}, 400, None),
    ({"opens_at": "2025-04-01T00:00:00Z", "closes_at": "2025-03-01T00:00:00Z"}, 400, None),
    ({"cooldown_s": -1}, 422, "cooldown_s"),
    ({"board_id": "spring cup"}, 422, "board_id"),
    ({"opens_at": "2025-04-01T00:00:00"}, 422, "opens_at"),  # no time zone
    ({"colour": "red"}, 422, "colour"),
])
def test_a_bad_board_is_refused_and_nothing_is_created(client: Client, settings: dict[str, Any],
                                                       status: int, loc: str | None) -> None:
    response = client.send("POST", "/boards", cup_spec(**settings))
    assert response["statusCode"] == status, response["body"]
    answer = body(response)
    assert answer["error"] == "InvalidQuery"
    if loc:
        assert answer["detail"][0]["loc"] == loc
        assert answer["message"] == "the board is invalid"
    assert body(client.get("/boards")) == {"boards": [], "next_cursor": None}


def test_the_board_bound_fits_the_longest_board_and_refuses_more_unparsed(client: Client) -> None:
    longest = json.dumps(cup_spec(title="é" * 120, description="é" * 2000))  # escaped: 6 bytes each
    assert 12_000 < len(longest) <= MAX_BOARD_BODY_BYTES
    assert client.send("POST", "/boards", longest)["statusCode"] == 201
    response = client.send("POST", "/boards", "{" * (MAX_BOARD_BODY_BYTES + 1))
    assert response["statusCode"] == 413
    assert str(MAX_BOARD_BODY_BYTES) in body(response)["message"]


def test_a_change_names_only_what_changes_and_null_clears(client: Client) -> None:
    create_cup(client, description="Spring", closes_at="2025-04-01T00:00:00Z", cooldown_s=600,
               max_submissions=5)
    response = client.send("PATCH", f"/boards/{CUP}", {"max_submissions": None})
    assert response["statusCode"] == 200
    board = BoardView.model_validate(body(response))
    assert (board.max_submissions, board.cooldown_s, board.closes_at, board.description) == (
        None, 600, datetime(2025, 4, 1, tzinfo=UTC), "Spring")

    nothing = BoardView.model_validate(body(client.send("PATCH", f"/boards/{CUP}", {})))
    assert nothing.model_dump(exclude={"status"}) == board.model_dump(exclude={"status"})

    reopened = BoardView.model_validate(body(client.send(
        "PATCH", f"/boards/{CUP}", {"closes_at": None, "title": "Spring Cup 2025"})))
    assert (reopened.closes_at, reopened.title, reopened.cooldown_s, reopened.description) == (
        None, "Spring Cup 2025", 600, "Spring")


@pytest.mark.parametrize("field", ["title", "method"])
def test_a_boards_title_and_method_cannot_be_cleared(client: Client, field: str) -> None:
    create_cup(client)
    response = client.send("PATCH", f"/boards/{CUP}", {field: None})
    assert response["statusCode"] == 400
    assert "cannot be cleared" in body(response)["message"]


@pytest.mark.parametrize(("changes", "loc"), [
    ({"cooldown_s": "soon"}, "cooldown_s"), ({"max_submissions": 0}, "max_submissions"),
    ({"track": "Vegas_track"}, "track"), ({"closes_at": "tomorrow"}, "closes_at"),
])
def test_an_invalid_change_is_422_naming_the_field(client: Client, changes: dict[str, Any],
                                                   loc: str) -> None:
    create_cup(client, cooldown_s=600)
    response = client.send("PATCH", f"/boards/{CUP}", changes)
    assert response["statusCode"] == 422
    answer = body(response)
    assert (answer["error"], answer["message"], answer["detail"][0]["loc"]) == (
        "InvalidQuery", "the changes are invalid", loc)
    assert client.service.board_page(CUP).board.cooldown_s == 600


def test_changes_sent_as_text_are_415_and_broken_json_422(client: Client) -> None:
    create_cup(client)
    text = client.request("PATCH", f"/boards/{CUP}", body="title=Mine",
                          headers={"content-type": "text/plain"})
    assert text["statusCode"] == 415
    assert body(text)["message"] == "send the changes as application/json"
    broken = client.send("PATCH", f"/boards/{CUP}", '{"title": ')
    assert broken["statusCode"] == 422
    assert body(broken)["message"] == "the request body is not valid JSON"


def test_rescoring_a_board_with_entries_is_409_but_its_title_may_change(client: Client) -> None:
    create_cup(client)
    client.push(make_record("Ada"), board=CUP)
    locked = client.send("PATCH", f"/boards/{CUP}", {"method": "AVG_LAP_TIME"})
    assert locked["statusCode"] == 409
    assert body(locked)["error"] == "BoardLocked"
    assert client.send("PATCH", f"/boards/{CUP}", {"title": "Renamed"})["statusCode"] == 200


@pytest.mark.parametrize(("method", "path", "payload"), [
    ("PATCH", f"/boards/{TRACK}", {"title": "Mine"}),
    ("POST", f"/boards/{TRACK}/close", None),
    ("DELETE", f"/boards/{TRACK}", None),
])
def test_a_tracks_default_board_cannot_be_managed(client: Client, method: str, path: str,
                                                  payload: Any) -> None:
    client.push(make_record())
    response = client.send(method, path, payload)
    assert response["statusCode"] == 409
    assert body(response)["error"] == "BoardLocked"


@pytest.mark.parametrize(("method", "path", "payload"), [
    ("PATCH", "/boards/nowhere", {"title": "Mine"}),
    ("POST", "/boards/nowhere/close", None),
    ("DELETE", "/boards/nowhere", None),
    ("POST", "/boards/nowhere/restore", None),
    ("GET", "/boards/nowhere/export", None),
    ("POST", "/boards/nowhere/imports", {"submitted_at": "2025-02-01T10:00:00Z",
                                         "record": make_record().model_dump(mode="json")}),
])
def test_managing_a_board_that_is_not_there_is_404(client: Client, method: str, path: str,
                                                    payload: Any) -> None:
    response = client.send(method, path, payload)
    assert response["statusCode"] == 404, response["body"]
    assert body(response)["error"] == "BoardNotFound"


# ---- organisers: windows and limits, as racers meet them ---------------------------------------


def test_a_closed_board_refuses_new_runs_with_403_but_answers_a_duplicate(client: Client) -> None:
    create_cup(client)
    record = make_record("Ada")
    assert client.push(record, board=CUP)["statusCode"] == 201
    closed = client.send("POST", f"/boards/{CUP}/close")
    assert closed["statusCode"] == 200
    assert BoardView.model_validate(body(closed)).status == "CLOSED"
    refused = client.push(make_record("Bob"), board=CUP)
    assert refused["statusCode"] == 403
    assert body(refused)["error"] == "BoardClosed"
    assert "closed" in body(refused)["message"]
    assert client.push(record, board=CUP)["statusCode"] == 200
    assert client.send("POST", f"/boards/{CUP}/close")["statusCode"] == 200  # closing again: as is


def test_an_upcoming_board_refuses_runs_with_403(client: Client) -> None:
    create_cup(client, opens_at=(T0 + timedelta(days=1)).isoformat())
    refused = client.push(make_record("Ada"), board=CUP)
    assert refused["statusCode"] == 403
    assert body(refused)["error"] == "BoardClosed"
    assert "not open yet" in body(refused)["message"]


def test_a_cooldown_is_429_with_retry_after_then_the_racer_gets_in(client: Client) -> None:
    create_cup(client, cooldown_s=600)
    assert client.push(make_record("Ada", lap(13000)), board=CUP)["statusCode"] == 201
    too_soon = client.push(make_record("Ada", lap(12000)), board=CUP)
    assert too_soon["statusCode"] == 429
    assert body(too_soon)["error"] == "TooSoon"
    wait = int(too_soon["headers"]["Retry-After"])
    assert 590 <= wait <= 600
    assert client.push(make_record("Bob"), board=CUP)["statusCode"] == 201  # per racer
    client.clock.advance(wait)
    assert client.push(make_record("Ada", lap(12000)), board=CUP)["statusCode"] == 201


def test_past_the_last_allowed_submission_is_403(client: Client) -> None:
    create_cup(client, max_submissions=2)
    for ms in (13000, 12500):
        assert client.push(make_record("Ada", lap(ms)), board=CUP)["statusCode"] == 201
    refused = client.push(make_record("Ada", lap(12000)), board=CUP)
    assert refused["statusCode"] == 403
    assert body(refused)["error"] == "SubmissionLimitReached"
    assert "Retry-After" not in (refused.get("headers") or {})


def test_a_deleted_board_disappears_until_it_is_restored(client: Client) -> None:
    create_cup(client)
    client.push(make_record("Ada"), board=CUP)
    deleted = client.send("DELETE", f"/boards/{CUP}")
    assert deleted["statusCode"] == 200
    assert BoardView.model_validate(body(deleted)).board_id == CUP
    assert client.get(f"/boards/{CUP}")["statusCode"] == 404
    assert body(client.get("/boards")) == {"boards": [], "next_cursor": None}
    assert client.push(make_record("Bob"), board=CUP)["statusCode"] == 404
    restored = client.send("POST", f"/boards/{CUP}/restore")
    assert restored["statusCode"] == 200
    page = BoardPage.model_validate(body(client.get(f"/boards/{CUP}")))
    assert [e.racer for e in page.entries] == ["Ada"]


# ---- organisers: export and import ------------------------------------------------------------


def export_all(client: Client, board: str) -> tuple[list[Any], int]:
    """Every line of a board's export, following the cursor; and how many pages it took."""
    lines: list[Any] = []
    cursor: str | None = None
    pages = 0
    while True:
        response = client.send("GET", f"/boards/{board}/export", **({"cursor": cursor} if cursor else {}))
        assert response["statusCode"] == 200, response["body"]
        page = ExportPage.model_validate(body(response))
        lines += page.lines
        pages += 1
        cursor = page.next_cursor
        if cursor is None:
            return lines, pages


def standings(client: Client, board: str) -> list[tuple[int, str, int | None, datetime]]:
    page = BoardPage.model_validate(body(client.get(f"/boards/{board}")))
    return [(e.rank, e.racer, e.time_ms, e.submitted_at) for e in page.entries]


def test_an_export_is_the_board_its_entries_then_every_submission_with_its_record(
        client: Client) -> None:
    create_cup(client)
    records = [make_record("Ada", lap(13000)), make_record("Ada", lap(12000), model="m2"),
               make_record("Bob", lap(12500))]
    for record in records:
        client.push(record, board=CUP)
    lines, pages = export_all(client, CUP)
    assert pages == 2
    assert isinstance(lines[0], ExportedBoard)
    assert lines[0].board.board_id == CUP
    assert [line.entry.racer for line in lines if isinstance(line, ExportedEntry)] == ["Ada", "Bob"]
    exported = {line.record.submission_id: line.record for line in lines
                if isinstance(line, ExportedSubmission)}
    assert exported == {record.submission_id: record for record in records}


def test_an_export_imports_into_a_new_board_with_the_same_standings(client: Client) -> None:
    create_cup(client, max_submissions=5)
    for racer, ms in [("Ada", 13000), ("Bob", 12500), ("Ada", 12000)]:
        client.push(make_record(racer, lap(ms)), board=CUP)
    lines, _ = export_all(client, CUP)
    copy = lines[0].board.model_copy(update={"board_id": "spring-cup-copy"})

    created = client.send("PUT", "/boards/spring-cup-copy/import", copy.model_dump(mode="json"))
    assert created["statusCode"] == 201, created["body"]
    assert BoardView.model_validate(body(created)).max_submissions == 5
    for line in lines:
        if isinstance(line, ExportedSubmission):
            item = {"submitted_at": line.submission.submitted_at.isoformat(),
                    "record": line.record.model_dump(mode="json")}
            first = client.send("POST", "/boards/spring-cup-copy/imports", item)
            assert first["statusCode"] == 201, first["body"]
            assert body(first)["status"] == "created"
            again = client.send("POST", "/boards/spring-cup-copy/imports", item)
            assert (again["statusCode"], body(again)["status"]) == (200, "duplicate")
    assert standings(client, "spring-cup-copy") == standings(client, CUP)

    existing = client.send("PUT", "/boards/spring-cup-copy/import",
                           copy.model_copy(update={"title": "Other"}).model_dump(mode="json"))
    assert existing["statusCode"] == 200
    assert BoardView.model_validate(body(existing)).title == "Spring Cup"  # its own settings stay


def test_an_imported_board_must_be_the_one_its_path_names(client: Client) -> None:
    board = Board(board_id="elsewhere", kind="named", track=TRACK, title="Elsewhere",
                  created_at=T0)
    response = client.send("PUT", "/boards/spring-cup/import", board.model_dump(mode="json"))
    assert response["statusCode"] == 400
    assert body(response)["detail"][0]["loc"] == "board_id"
    assert body(client.get("/boards")) == {"boards": [], "next_cursor": None}


def test_an_imported_board_is_validated_as_a_board(client: Client) -> None:
    board = Board(board_id=CUP, kind="named", track=TRACK, title="Cup", created_at=T0)
    exported = board.model_dump(mode="json") | {"title": ""}
    response = client.send("PUT", f"/boards/{CUP}/import", exported)
    assert response["statusCode"] == 422
    assert (body(response)["error"], body(response)["detail"][0]["loc"]) == ("InvalidQuery", "title")


def test_an_import_skips_the_window_and_limits_but_not_the_track(client: Client) -> None:
    create_cup(client, max_submissions=1)
    client.send("POST", f"/boards/{CUP}/close")
    for model in ("m1", "m2"):
        item = {"submitted_at": "2025-02-01T10:00:00Z",
                "record": make_record("Ada", model=model).model_dump(mode="json")}
        assert client.send("POST", f"/boards/{CUP}/imports", item)["statusCode"] == 201
    elsewhere = {"submitted_at": "2025-02-01T10:00:00Z",
                 "record": make_record("Bob", track="Vegas_track").model_dump(mode="json")}
    response = client.send("POST", f"/boards/{CUP}/imports", elsewhere)
    assert response["statusCode"] == 422
    assert body(response)["error"] == "BoardMismatch"


def test_an_imported_submission_without_a_time_zone_is_422(client: Client) -> None:
    create_cup(client)
    item = {"submitted_at": "2025-02-01T10:00:00", "record": make_record().model_dump(mode="json")}
    response = client.send("POST", f"/boards/{CUP}/imports", item)
    assert response["statusCode"] == 422
    assert (body(response)["error"], body(response)["detail"][0]["loc"]) == (
        "InvalidSubmission", "submitted_at")


def imported_body(record: Record, padding: int = 0) -> str:
    return ('{"submitted_at": "2025-02-01T10:00:00Z", "record": ' + record.model_dump_json()
            + " " * padding + "}")


def record_over_the_record_bound() -> Record:
    """A valid record just over the record bound (many evaluation runs of many laps)."""
    def sized(laps: int) -> Record:
        specs: list[LapSpec] = [(12000 + n % 997, 100) for n in range(laps)]
        return make_record("Ada", runs=[specs[i:i + 200] for i in range(0, laps, 200)])

    small, large = len(sized(200).model_dump_json()), len(sized(400).model_dump_json())
    laps = 200 + math.ceil((limits.MAX_RECORD_BYTES - small) * 200 / (large - small))
    while len(sized(laps).model_dump_json()) <= limits.MAX_RECORD_BYTES:
        laps += 1
    return sized(laps)


def test_an_imported_submission_has_headroom_for_its_time(client: Client) -> None:
    create_cup(client)
    text = imported_body(make_record())
    padded = imported_body(make_record(), padding=limits.MAX_RECORD_BYTES + 100 - len(text))
    assert limits.MAX_RECORD_BYTES < len(padded) <= IMPORT_BODY.max_bytes
    assert client.send("POST", f"/boards/{CUP}/imports", padded)["statusCode"] == 201


def test_an_imported_body_over_its_bound_is_413_before_it_is_parsed(client: Client) -> None:
    create_cup(client)
    response = client.send("POST", f"/boards/{CUP}/imports", "{" * (IMPORT_BODY.max_bytes + 1))
    assert response["statusCode"] == 413
    assert str(IMPORT_BODY.max_bytes) in body(response)["message"]


def test_an_imported_record_keeps_the_records_own_bound(client: Client) -> None:
    create_cup(client)
    record = record_over_the_record_bound()
    text = imported_body(record)
    assert len(text) <= IMPORT_BODY.max_bytes
    response = client.send("POST", f"/boards/{CUP}/imports", text)
    assert response["statusCode"] == 413
    assert f"over the {limits.MAX_RECORD_BYTES} bytes a record may have" in body(response)["message"]
    assert client.push(record, board=CUP)["statusCode"] == 413  # as a push
    assert standings(client, CUP) == []


@pytest.mark.parametrize("bad_cursor", ["not-a-cursor", "x" * 2000])
def test_a_bad_export_cursor_is_400(client: Client, bad_cursor: str) -> None:
    create_cup(client)
    response = client.send("GET", f"/boards/{CUP}/export", cursor=bad_cursor)
    assert response["statusCode"] == 400
    assert body(response)["error"] == "InvalidQuery"


def test_organiser_answers_carry_no_cors_headers(client: Client) -> None:
    origin = {"origin": "https://club.example.org"}
    created = client.request("POST", "/boards", body=json.dumps(cup_spec()), headers=origin)
    assert created["statusCode"] == 201
    exported = client.request("GET", f"/boards/{CUP}/export", headers=origin)
    assert exported["statusCode"] == 200
    for response in (created, exported):
        assert "Access-Control-Allow-Origin" not in response["headers"]


@pytest.mark.parametrize(("error", "status"), [
    (BoardClosed("closed"), 403), (SubmissionLimitReached("all used"), 403),
    (NotAuthorized("not from here"), 403), (BoardExists("taken"), 409), (BoardLocked("locked"), 409),
    (NotSignedIn("sign in"), 401), (AliasTaken("not yours"), 403), (Banned("banned"), 403),
    (CopiedRun("a copy"), 409),
])
def test_each_refusal_answers_its_status_and_names_itself(app: APIGatewayHttpResolver,
                                                          error: DomainError, status: int) -> None:
    class Refusing(LeaderboardService):
        def create_board(self, spec: Any, caller: Any = None) -> BoardView:
            raise error

    store = SqliteStore(":memory:")
    response = Client(app, Refusing(store)).send("POST", "/boards", cup_spec())
    store.close()
    assert response["statusCode"] == status
    assert body(response) == {"error": type(error).__name__, "message": error.message, "detail": []}


def test_a_racers_history_holds_what_the_push_receipt_said(client: Client) -> None:
    receipt = PushReceipt.model_validate(body(client.push(make_record("Ada"))))
    [item] = RacerHistory.model_validate(body(client.get("/racers/Ada/submissions"))).history
    assert item == receipt.submission


def test_an_import_onto_a_deleted_boards_id_is_404_until_it_is_restored(client: Client) -> None:
    create_cup(client)
    client.send("DELETE", f"/boards/{CUP}")
    board = Board(board_id=CUP, kind="named", track=TRACK, title="Imported", created_at=T0)
    response = client.send("PUT", f"/boards/{CUP}/import", board.model_dump(mode="json"))
    assert response["statusCode"] == 404
    assert "deleted" in body(response)["message"]
    client.send("POST", f"/boards/{CUP}/restore")
    again = client.send("PUT", f"/boards/{CUP}/import", board.model_dump(mode="json"))
    assert (again["statusCode"], body(again)["title"]) == (200, "Spring Cup")


@pytest.mark.parametrize("authorizer", [None, SIGNED_IN_RACER], ids=["unsigned", "racer"])
def test_only_organisers_manage_boards(client: Client, authorizer: dict[str, Any] | None) -> None:
    response = client.request("POST", "/boards", body=json.dumps(cup_spec()), authorizer=authorizer)
    assert response["statusCode"] == 403
    assert json.loads(response["body"])["error"] == "NotAuthorized"
    assert client.get("/boards/spring-cup")["statusCode"] == 404


# ---- live boards: ETag and 304 -----------------------------------------------------------------


class CountingStore(SqliteStore):
    """The embedded store, counting the reads a request makes."""

    reads = 0

    def get_board(self, board_id: str) -> Any:
        self.reads += 1
        return super().get_board(board_id)

    def board_version(self, board_id: str) -> Any:
        self.reads += 1
        return super().board_version(board_id)

    def front_page(self, board_id: str, limit: int) -> Any:
        self.reads += 1
        return super().front_page(board_id, limit)

    def top(self, board_id: str, limit: int, after: str | None = None) -> Any:
        self.reads += 1
        return super().top(board_id, limit, after)


def test_an_unchanged_board_answers_304_after_one_read(app: APIGatewayHttpResolver) -> None:
    store = CountingStore(":memory:")
    client = Client(app, LeaderboardService(store, clock=Clock()))
    client.push(make_record("Ada", laps=lap(12000)))
    first = client.get(f"/boards/{TRACK}")
    etag = first["headers"]["ETag"]
    assert first["statusCode"] == 200 and first["headers"]["Cache-Control"] == PUBLIC_CACHE
    store.reads = 0
    again = client.request("GET", f"/boards/{TRACK}", headers={"if-none-match": etag})
    assert again["statusCode"] == 304 and again["body"] == "" and again["headers"]["ETag"] == etag
    assert store.reads == 1


def test_a_push_that_changes_the_standings_changes_the_etag(client: Client) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    etag = client.get(f"/boards/{TRACK}")["headers"]["ETag"]
    client.push(make_record("Bob", laps=lap(13000)))
    changed = client.request("GET", f"/boards/{TRACK}", headers={"if-none-match": etag})
    assert changed["statusCode"] == 200
    assert [e["racer"] for e in body(changed)["entries"]] == ["Ada", "Bob"]
    assert changed["headers"]["ETag"] != etag
    slower = client.push(make_record("Bob", laps=lap(14000), model="slower"))
    assert slower["statusCode"] == 201
    unchanged = client.request("GET", f"/boards/{TRACK}",
                               headers={"if-none-match": changed["headers"]["ETag"]})
    assert unchanged["statusCode"] == 304


def test_each_page_of_a_board_has_its_own_etag(client: Client) -> None:
    for racer, ms in (("Ada", 12000), ("Bob", 13000)):
        client.push(make_record(racer, laps=lap(ms)))
    one = client.get(f"/boards/{TRACK}", limit="1")
    two = client.get(f"/boards/{TRACK}", limit="2")
    assert one["headers"]["ETag"] != two["headers"]["ETag"]
    stale = client.request("GET", f"/boards/{TRACK}", query={"limit": "2"},
                           headers={"if-none-match": one["headers"]["ETag"]})
    assert stale["statusCode"] == 200


def test_a_board_closing_by_the_clock_changes_the_etag(client: Client) -> None:
    create_cup(client, closes_at=(T0 + timedelta(hours=1)).isoformat())
    client.push(make_record("Ada", laps=lap(12000)), board=CUP)
    etag = client.get(f"/boards/{CUP}")["headers"]["ETag"]
    client.clock.advance(2 * 3600)
    after = client.request("GET", f"/boards/{CUP}", headers={"if-none-match": etag})
    assert after["statusCode"] == 200 and body(after)["board"]["status"] == "CLOSED"


def test_if_none_match_on_a_board_that_does_not_exist_is_404(client: Client) -> None:
    response = client.request("GET", "/boards/nowhere", headers={"if-none-match": '"x"'})
    assert response["statusCode"] == 404


# ---- racer pages, compare and insights ---------------------------------------------------------


def test_compare_marks_what_two_designs_differ_on(client: Client) -> None:
    client.push(make_record("Ada", lap(12000), max_speed=4.0))
    client.push(make_record("Bob", lap(13000), max_speed=3.0))
    response = client.get(f"/boards/{TRACK}/compare", racer=["Ada", "bob"])
    assert response["statusCode"] == 200, response["body"]
    compared = body(response)
    assert [r["racer"] for r in compared["racers"]] == ["Ada", "Bob"]
    assert [r["entry"]["rank"] for r in compared["racers"]] == [1, 2]
    assert compared["differences"] == ["max_speed", "min_speed"]
    assert [r["facts"]["max_speed"] for r in compared["racers"]] == [4.0, 3.0]


def test_compare_needs_two_racers_with_entries(client: Client) -> None:
    client.push(make_record("Ada", lap(12000)))
    assert client.get(f"/boards/{TRACK}/compare", racer=["Ada"])["statusCode"] == 400
    missing = client.get(f"/boards/{TRACK}/compare", racer=["Ada", "Nobody"])
    assert missing["statusCode"] == 404


def test_insights_set_the_top_against_the_field(client: Client) -> None:
    for n, (racer, speed) in enumerate([("Ada", 4.0), ("Bob", 4.0), ("Cy", 2.0), ("Di", 2.0)]):
        client.push(make_record(racer, lap(10000 + 1000 * n), max_speed=speed))
    insights = body(client.get(f"/boards/{TRACK}/insights", top="2"))
    assert (insights["top"], insights["field"]) == (2, 4)
    facts = {fact["fact"]: fact for fact in insights["facts"]}
    assert (facts["max_speed"]["top"], facts["max_speed"]["field"]) == ("4", "3")
    assert facts["algorithm"]["top_share"] == 1.0
    assert [(p["racer"], p["top"]) for p in insights["points"]] == [
        ("Ada", True), ("Bob", True), ("Cy", False), ("Di", False)]


def test_the_racer_page_draws_laps_action_space_and_history(client: Client) -> None:
    client.push(make_record("Ada", [(12000, 100), (15000, 40), (11800, 100)]))
    client.push(make_record("Ada", lap(11000), model="faster"))
    response = client.get(f"/boards/{TRACK}/racers/ada/view")
    assert response["statusCode"] == 200
    page = response["body"]
    assert "<h1>Ada</h1>" in page and "#1 on Smile Speedway" in page
    assert page.count("<figure class=\"chart\">") >= 3  # laps, action space, submissions
    assert "Lap times of Ada" in page and "Action space" in page
    assert "★ counts" in page and page.count("<tr><td>") == 2
    assert "discount factor" in page and "0.99" in page


def test_the_compare_and_insights_pages(client: Client) -> None:
    client.push(make_record("Ada", lap(12000), max_speed=4.0))
    client.push(make_record("<b>Bob</b>", lap(13000), max_speed=3.0))
    compare = client.get(f"/boards/{TRACK}/compare/view", racer=["Ada", "<b>Bob</b>"])
    assert compare["statusCode"] == 200
    page = compare["body"]
    differs = ('<tr class="differs"><th scope="row">top speed (m/s)</th><td data-label="Ada">4</td>'
               '<td data-label="&lt;b&gt;Bob&lt;/b&gt;">3</td></tr>')
    assert differs in page
    assert "<b>" not in page
    # why Ada is faster: the best runs lap by lap, first, then the designs
    assert page.index("Lap by lap") < page.index("How the designs differ")
    assert "Lap times of each racer&#39;s best run" in page
    assert '<td class="num faster" data-label="Ada">12.000 s</td>' in page
    assert '<td class="num" data-label="Difference">+1.000 s</td>' in page
    insights = client.get(f"/boards/{TRACK}/insights/view")
    assert insights["statusCode"] == 200 and "Top speed against time" in insights["body"]


def test_a_board_can_keep_designs_private_until_it_closes(client: Client) -> None:
    closes = T0 + timedelta(hours=1)
    create_cup(client, designs="after-close", closes_at=closes.isoformat())
    client.push(make_record("Ada", lap(12000), max_speed=4.0), board=CUP)
    client.push(make_record("Bob", lap(13000)), board=CUP)
    page = body(client.get(f"/boards/{CUP}"))
    assert page["board"]["designs"] == "after-close"
    assert [e["design"] for e in page["entries"]] == [None, None]
    racer = body(client.get(f"/boards/{CUP}/racers/Ada"))
    assert racer["record"] is None and racer["entry"]["design"] is None
    for path in (f"/boards/{CUP}/compare", f"/boards/{CUP}/insights"):
        refused = client.get(path, racer=["Ada", "Bob"])
        assert refused["statusCode"] == 403 and body(refused)["error"] == "DesignsPrivate"
    view = client.get(f"/boards/{CUP}/view")["body"]
    assert "private until the board closes" in view and "PPO" not in view
    assert "private until the board closes" in client.get(f"/boards/{CUP}/racers/Ada/view")["body"]

    client.clock.advance(2 * 3600)
    assert body(client.get(f"/boards/{CUP}"))["entries"][0]["design"]["max_speed"] == 4.0
    assert body(client.get(f"/boards/{CUP}/racers/Ada"))["record"] is not None
    assert client.get(f"/boards/{CUP}/compare", racer=["Ada", "Bob"])["statusCode"] == 200


def test_designs_can_be_made_public_again(client: Client) -> None:
    create_cup(client, designs="after-close")
    client.push(make_record("Ada", lap(12000)), board=CUP)
    assert body(client.get(f"/boards/{CUP}"))["entries"][0]["design"] is None
    changed = client.send("PATCH", f"/boards/{CUP}", {"designs": "public"})
    assert changed["statusCode"] == 200 and body(changed)["designs"] == "public"
    assert body(client.get(f"/boards/{CUP}"))["entries"][0]["design"] is not None
