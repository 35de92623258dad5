"""`GET /boards` and racers' histories come a page at a time, on the embedded board (keyset
pagination in SQLite) and on DynamoDB (moto: Query with Limit and ExclusiveStartKey); the CLI's
clients follow the cursors, so `drboard boards` and `drboard history` still show everything."""

from __future__ import annotations

import base64
import json
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from typing import Any

import boto3
import pytest
from drboard_cli import remote
from drboard_cli.remote import Answer, HttpBoard
from drboard_functions.errors import DomainError, InvalidQuery
from drboard_functions.models.requests import BoardSpec
from drboard_functions.routes import admin_router, build_app, pull_router, push_router
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.sqlite import SqliteStore
from moto import mock_aws

from tests.recordkit import make_record
from tests.tablekit import create_board_table
from tests.unit.test_routes import Client

REGION = "eu-west-1"
TRACKS = ["Track_A", "Track_B", "Track_C", "Track_D", "Track_E", "Track_F", "Track_G"]
T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)


class Ticking:
    """A minute passes at every reading, so every submission has a moment of its own."""

    def __init__(self) -> None:
        self.now = T0

    def __call__(self) -> datetime:
        self.now += timedelta(minutes=1)
        return self.now


@pytest.fixture(params=["sqlite", "dynamodb"])
def service(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[LeaderboardService]:
    if request.param == "sqlite":
        store = SqliteStore(":memory:")
        yield LeaderboardService(store, clock=Ticking())
        store.close()
        return
    monkeypatch.setenv("AWS_DEFAULT_REGION", REGION)
    monkeypatch.setenv("AWS_ACCESS_KEY_ID", "testing")
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", "testing")
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        create_board_table(client, "boards")
        yield LeaderboardService(DynamoDbStore("boards", client=client), clock=Ticking())


def seven_boards_and_a_deleted_one(service: LeaderboardService) -> None:
    for n, track in enumerate(TRACKS):
        service.push(make_record(racer="Ada", track=track, laps=[(12_000 + n, 100)]))
    service.create_board(BoardSpec(board_id="gone", title="Gone", track="Track_A",
                                   custom_track=True))
    service.delete_board("gone")


def test_boards_come_a_page_at_a_time_by_id_without_deleted_ones(service: LeaderboardService) -> None:
    seven_boards_and_a_deleted_one(service)
    seen: list[str] = []
    cursor: str | None = None
    pages = 0
    while True:
        page = service.boards_page(limit=3, cursor=cursor)
        assert len(page.boards) <= 3
        seen += [board.board_id for board in page.boards]
        pages += 1
        cursor = page.next_cursor
        if cursor is None:
            break
    assert seen == sorted(f"custom.{track}" for track in TRACKS)
    assert pages == 3  # 8 boards stored, "gone" among them: 3 + 3 + 2, less the deleted one
    assert [board.board_id for board in service.boards()] == seen


def test_a_racers_history_comes_oldest_first_a_page_at_a_time(service: LeaderboardService) -> None:
    for n in range(5):
        track = TRACKS[n % 2]
        service.push(make_record(racer="Ada", track=track, laps=[(13_000 - n, 100)]))
    service.push(make_record(racer="Bob", track=TRACKS[0]))

    everything = service.history("ada")
    assert len(everything) == 5
    assert [item.submitted_at for item in everything] == sorted(item.submitted_at for item in everything)

    paged, cursor = [], None
    while True:
        page = service.history_page("Ada", None, limit=2, cursor=cursor)
        assert len(page.history) <= 2
        paged += page.history
        cursor = page.next_cursor
        if cursor is None:
            break
    assert paged == everything

    board = f"custom.{TRACKS[0]}"
    first = service.history_page("Ada", board, limit=2)
    rest = service.history_page("Ada", board, limit=2, cursor=first.next_cursor)
    assert [item.board_id for item in first.history + rest.history] == [board] * 3
    assert rest.next_cursor is None
    assert first.history + rest.history == [item for item in everything if item.board_id == board]


def test_the_racer_view_pages_through_the_history_on_its_board(service: LeaderboardService) -> None:
    for n in range(3):
        service.push(make_record(racer="Ada", track=TRACKS[0], laps=[(13_000 - n, 100)]))
    board = f"custom.{TRACKS[0]}"
    first = service.racer(board, "Ada", limit=2)
    second = service.racer(board, "Ada", limit=2, cursor=first.next_cursor)
    assert (len(first.history), len(second.history), second.next_cursor) == (2, 1, None)
    assert first.history + second.history == service.racer(board, "Ada").history
    assert sum(item.is_best for item in first.history + second.history) == 1


def cursor_of(kind: str, token: Any) -> str:
    return base64.urlsafe_b64encode(json.dumps([kind, token]).encode()).decode()


@pytest.mark.parametrize("cursor", [
    "not base64 ~~~", cursor_of("history", json.dumps(["x", "y", "z"])),  # another list's cursor
    cursor_of("boards", "not a token"), cursor_of("boards", json.dumps(["a", "b"])),
    cursor_of("boards", json.dumps([1])), "x" * 2000,
])
def test_a_cursor_the_board_did_not_give_out_is_refused(service: LeaderboardService, cursor: str) -> None:
    seven_boards_and_a_deleted_one(service)
    with pytest.raises(InvalidQuery, match="cursor"):
        service.boards_page(limit=2, cursor=cursor)


def test_a_forged_history_cursor_is_refused(service: LeaderboardService) -> None:
    service.push(make_record(racer="Ada", track=TRACKS[0]))
    with pytest.raises(InvalidQuery, match="cursor"):
        service.history_page("Ada", None, limit=2, cursor=cursor_of("history", json.dumps(["x"])))


# ---- over HTTP: the routes, and the CLI's remote client ----------------------------------------


@pytest.fixture
def client(service: LeaderboardService) -> Client:
    return Client(build_app(push_router, pull_router, admin_router), service)


def test_get_boards_takes_a_limit_and_a_cursor(client: Client) -> None:
    seven_boards_and_a_deleted_one(client.service)
    first = json.loads(client.get("/boards", limit="4")["body"])
    assert len(first["boards"]) == 4 and first["next_cursor"]
    second = json.loads(client.get("/boards", limit="4", cursor=first["next_cursor"])["body"])
    assert second["next_cursor"] is None
    assert len(first["boards"]) + len(second["boards"]) == len(TRACKS)
    for bad in ("0", "501", "many"):
        assert client.get("/boards", limit=bad)["statusCode"] == 400
    assert client.get("/boards", cursor="garbage")["statusCode"] == 400


def test_the_history_routes_take_a_limit_and_a_cursor(client: Client) -> None:
    for n in range(3):
        client.service.push(make_record(racer="Ada", track=TRACKS[0], laps=[(13_000 - n, 100)]))
    history = json.loads(client.get("/racers/Ada/submissions", limit="2")["body"])
    assert len(history["history"]) == 2 and history["next_cursor"]
    rest = json.loads(client.get("/racers/Ada/submissions", limit="2",
                                 cursor=history["next_cursor"])["body"])
    assert len(rest["history"]) == 1 and rest["next_cursor"] is None

    view = json.loads(client.get(f"/boards/custom.{TRACKS[0]}/racers/Ada", limit="1")["body"])
    assert len(view["history"]) == 1 and view["next_cursor"]


def routed(client: Client) -> Any:
    def call(method: str, path: str, *, body: Any = None, query: Any = None,
             signed: bool = False) -> Answer:
        given = {name: value for name, value in (query or {}).items() if value}
        answer = client.request(method, path, query=given or None)
        if answer["statusCode"] >= 400:
            raise DomainError(answer["body"])
        return Answer(answer["statusCode"], json.loads(answer["body"]))
    return call


def test_the_remote_client_follows_every_cursor(client: Client, monkeypatch: pytest.MonkeyPatch) -> None:
    seven_boards_and_a_deleted_one(client.service)
    for n in range(4):
        client.service.push(make_record(racer="Ada", track=TRACKS[0], laps=[(11_000 - n, 100)]))
    board = HttpBoard("https://board.example")
    monkeypatch.setattr(board, "_call", routed(client))
    monkeypatch.setattr(remote, "MAX_PAGE", 2)  # small pages: several of each

    assert [b.board_id for b in board.boards()] == [b.board_id for b in client.service.boards()]
    assert len(board.boards()) == len(TRACKS)
    assert board.history("Ada", None) == client.service.history("Ada")
    assert len(board.history("Ada", None)) == len(TRACKS) + 4
    view = board.racer(f"custom.{TRACKS[0]}", "Ada")
    assert view.history == client.service.racer(f"custom.{TRACKS[0]}", "Ada").history
    assert len(view.history) == 5
