"""A board's standings kept as bytes (routes/standings.py): rendered once per board version,
answered from then on after one read of the version, never for a newer version; 304 for the
ETag the client holds; the same answers the routes give. On the embedded board through the
resolver, in the pull function (SQLite and DynamoDB on moto), and on `drboard serve`'s own
answer of kept pages. And the CDN's headers: on every public read, on no signed or organiser
answer."""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest

os.environ.setdefault("POWERTOOLS_SERVICE_NAME", "drboard")
os.environ.setdefault("POWERTOOLS_METRICS_NAMESPACE", "drboard")
os.environ.setdefault("POWERTOOLS_TRACE_DISABLED", "true")

import boto3
from drboard_cli.serve import BoardServer, LocalContext
from drboard_functions.handlers import pull, wiring
from drboard_functions.models.domain import Entry
from drboard_functions.routes import admin_router, build_app, pull_router, push_router
from drboard_functions.routes.headers import PUBLIC_CACHE
from drboard_functions.routes.kept import Wanted, wanted
from drboard_functions.routes.standings import COUNTDOWN_REFRESH_S
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore
from drboard_functions.web import Invite

from tests.awskit import REGION
from tests.recordkit import make_record
from tests.unit.test_routes import T0, TRACK, Client, Clock, body, cup_spec, lap
from tests.wiringkit import use_service

pytestmark = pytest.mark.filterwarnings("ignore:No application metrics to publish")
EVENTS = Path(__file__).parents[2] / "events"


class CountingStore(SqliteStore):
    """The embedded store, counting each read by name."""

    def __init__(self, path: Path | str) -> None:
        super().__init__(path)
        self.calls: Counter[str] = Counter()

    def board_version(self, board_id: str) -> Any:
        self.calls["board_version"] += 1
        return super().board_version(board_id)

    def get_board(self, board_id: str) -> Any:
        self.calls["get_board"] += 1
        return super().get_board(board_id)

    def front_page(self, board_id: str, limit: int) -> Any:
        self.calls["front_page"] += 1
        return super().front_page(board_id, limit)

    def top(self, board_id: str, limit: int, after: str | None = None) -> Any:
        self.calls["top"] += 1
        return super().top(board_id, limit, after)


@pytest.fixture
def store(tmp_path: Path) -> Iterator[CountingStore]:
    store = CountingStore(tmp_path / "board.db")
    yield store
    store.close()


@pytest.fixture
def client(store: CountingStore) -> Client:
    return Client(build_app(push_router, pull_router, admin_router),
                  LeaderboardService(store, clock=Clock()))


@pytest.fixture
def parsed_entries(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """How many stored entries are parsed (pydantic validations of an Entry)."""
    parsed: Counter[str] = Counter()
    validate = Entry.model_validate_json.__func__  # type: ignore[attr-defined]

    def counting(cls: type[Entry], data: Any, **kwargs: Any) -> Entry:
        parsed["Entry"] += 1
        return validate(cls, data, **kwargs)  # type: ignore[no-any-return]

    monkeypatch.setattr(Entry, "model_validate_json", classmethod(counting))
    return parsed


def racers(answer: dict[str, Any]) -> list[str]:
    return [entry["racer"] for entry in body(answer)["entries"]]


# ---- the embedded board, through the resolver --------------------------------------------------


@pytest.mark.parametrize("path", [f"/boards/{TRACK}", f"/boards/{TRACK}/view",
                                  f"/boards/{TRACK}/view?screen=1"])
def test_an_unchanged_board_answers_the_same_bytes_after_one_read_of_its_version(
        client: Client, store: CountingStore, parsed_entries: Counter[str], path: str) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    client.push(make_record("Bob", laps=lap(13000)))
    route, _, query = path.partition("?")
    first = client.request("GET", route, query=dict([query.split("=")]) if query else None)
    assert first["statusCode"] == 200
    store.calls.clear()
    parsed_entries.clear()
    again = client.request("GET", route, query=dict([query.split("=")]) if query else None)
    assert (again["statusCode"], again["headers"], again["body"]) == (
        first["statusCode"], first["headers"], first["body"])
    assert store.calls == {"board_version": 1}  # no entry read, no board parsed
    assert parsed_entries == {}


def test_a_read_after_a_push_answers_the_new_standings(client: Client) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    first = client.get(f"/boards/{TRACK}")
    client.push(make_record("Bob", laps=lap(11000)))
    after = client.get(f"/boards/{TRACK}")
    assert racers(first) == ["Ada"] and racers(after) == ["Bob", "Ada"]
    assert after["headers"]["ETag"] != first["headers"]["ETag"]
    page = client.get(f"/boards/{TRACK}/view")
    assert page["body"].index("Bob") < page["body"].index("Ada")


def test_a_push_by_another_process_on_the_same_file_is_never_answered_stale(
        client: Client, tmp_path: Path) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    assert racers(client.get(f"/boards/{TRACK}")) == ["Ada"]
    other = SqliteStore(tmp_path / "board.db")  # e.g. `drboard push` beside a `drboard serve`
    try:
        LeaderboardService(other).push(make_record("Bob", laps=lap(11000)))
    finally:
        other.close()
    assert racers(client.get(f"/boards/{TRACK}")) == ["Bob", "Ada"]


def test_an_organisers_change_is_answered_at_once(client: Client) -> None:
    assert client.send("POST", "/boards", cup_spec())["statusCode"] == 201
    client.push(make_record("Ada", laps=lap(12000)), board="spring-cup")
    assert body(client.get("/boards/spring-cup"))["board"]["title"] == "Spring Cup"
    assert client.send("PATCH", "/boards/spring-cup", {"title": "Summer Cup"})["statusCode"] == 200
    assert body(client.get("/boards/spring-cup"))["board"]["title"] == "Summer Cup"
    client.send("DELETE", f"/boards/spring-cup/racers/{'Ada'}")
    assert racers(client.get("/boards/spring-cup")) == []
    assert client.send("DELETE", "/boards/spring-cup")["statusCode"] == 200
    assert client.get("/boards/spring-cup")["statusCode"] == 404


def test_a_season_taking_a_board_in_is_shown_on_its_kept_page(client: Client) -> None:
    client.send("POST", "/boards", cup_spec())
    client.push(make_record("Ada", laps=lap(12000)), board="spring-cup")
    assert "a round of" not in client.get("/boards/spring-cup/view")["body"]
    client.send("POST", "/seasons", {"season_id": "club", "title": "Club season"})
    assert client.send("PUT", "/seasons/club/rounds/spring-cup", {})["statusCode"] == 200
    assert 'a round of <a href="/seasons/club/view">Club season</a>' in \
        client.get("/boards/spring-cup/view")["body"]


@pytest.mark.parametrize("sent", ["{etag}", "W/{etag}", '"other", {etag}'])
def test_the_etag_the_client_holds_answers_304_from_the_copy(client: Client, store: CountingStore,
                                                             sent: str) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    etag = client.get(f"/boards/{TRACK}")["headers"]["ETag"]
    store.calls.clear()
    held = client.request("GET", f"/boards/{TRACK}", headers={"if-none-match": sent.format(etag=etag)})
    assert (held["statusCode"], held["body"], held["headers"]["ETag"]) == (304, "", etag)
    assert held["headers"]["Cache-Control"] == PUBLIC_CACHE
    assert store.calls == {"board_version": 1}


def test_a_304_for_a_page_never_seen_renders_it_once(client: Client, store: CountingStore) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    etag = client.get(f"/boards/{TRACK}/view")["headers"]["ETag"]
    cold = Client(build_app(pull_router), LeaderboardService(store, clock=Clock()))
    held = cold.request("GET", f"/boards/{TRACK}/view", headers={"if-none-match": etag})
    assert held["statusCode"] == 304
    store.calls.clear()
    assert cold.request("GET", f"/boards/{TRACK}/view",
                        headers={"if-none-match": etag})["statusCode"] == 304
    assert store.calls == {"board_version": 1}


@pytest.mark.parametrize("headers", [{}, {"origin": "https://club.example"}])
def test_a_kept_answer_is_the_answer_the_route_gives(client: Client, headers: dict[str, str]) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    for path in (f"/boards/{TRACK}", f"/boards/{TRACK}/view"):
        rendered = client.request("GET", path, headers=headers)  # the route renders and keeps it
        kept = client.request("GET", path, headers=headers)  # answered before the routes
        assert rendered == kept
    if headers:
        assert kept["headers"]["Access-Control-Allow-Origin"] == "*"


def test_a_board_opening_by_the_clock_is_not_answered_from_its_copy(client: Client) -> None:
    opens = T0 + timedelta(hours=1)
    client.send("POST", "/boards", cup_spec(opens_at=opens.isoformat()))
    before = client.get("/boards/spring-cup")
    assert body(before)["board"]["status"] == "UPCOMING"
    assert body(client.get("/boards/spring-cup"))["board"]["status"] == "UPCOMING"
    client.clock.advance(2 * 3600)
    assert body(client.get("/boards/spring-cup"))["board"]["status"] == "OPEN"


def test_a_page_counting_down_is_rendered_again_within_its_refresh(client: Client,
                                                                  store: CountingStore) -> None:
    closes = T0 + timedelta(hours=3)
    client.send("POST", "/boards", cup_spec(closes_at=closes.isoformat()))
    client.push(make_record("Ada", laps=lap(12000)), board="spring-cup")
    first = client.get("/boards/spring-cup/view")
    client.clock.advance(COUNTDOWN_REFRESH_S + 60)
    store.calls.clear()
    later = client.get("/boards/spring-cup/view")
    assert store.calls["front_page"] == 1 and later["body"] != first["body"]
    assert later["headers"]["ETag"] == first["headers"]["ETag"]  # the standings did not change


def test_only_plain_top_page_requests_are_answered_from_copies() -> None:
    assert wanted("GET", f"/boards/{TRACK}", "") == Wanted(TRACK, "json", 100)
    assert wanted("GET", f"/boards/{TRACK}", "limit=25") == Wanted(TRACK, "json", 25)
    assert wanted("GET", "/boards/a%20b/view", "screen=1") == Wanted("a b", "screen", 500)
    assert wanted("GET", f"/boards/{TRACK}/view", "screen=1&limit=30") == Wanted(TRACK, "screen", 30)
    for method, path, query in [("POST", f"/boards/{TRACK}", ""), ("GET", f"/boards/{TRACK}", "cursor=x"),
                                ("GET", f"/boards/{TRACK}", "limit=05"),
                                ("GET", f"/boards/{TRACK}", "limit=501"),
                                ("GET", f"/boards/{TRACK}", "limit=1&limit=2"),
                                ("GET", f"/boards/{TRACK}/view", "screen=maybe"),
                                ("GET", f"/boards/{TRACK}/racers/ada", ""), ("GET", "/boards/a\"b", ""),
                                ("GET", "/boards/" + "x" * 300, "")]:
        assert wanted(method, path, query) is None, (method, path, query)


def test_a_request_the_copies_do_not_take_is_answered_by_the_routes_as_before(client: Client) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    assert client.get(f"/boards/{TRACK}", limit="05")["statusCode"] == 200
    assert client.get(f"/boards/{TRACK}", limit="0")["statusCode"] == 400
    assert client.get(f"/boards/{TRACK}", cursor="not-a-cursor")["statusCode"] == 400
    assert client.get("/boards/nowhere")["statusCode"] == 404
    assert client.get("/boards/nowhere/view")["statusCode"] == 404


# ---- the CDN's headers --------------------------------------------------------------------------


PUBLIC_READS = ["/", "/boards", f"/boards/{TRACK}", f"/boards/{TRACK}/view",
                f"/boards/{TRACK}/racers/Ada", f"/boards/{TRACK}/racers/Ada/view", "/racers/Ada",
                "/racers/Ada/submissions", f"/boards/{TRACK}/insights", "/.well-known/drboard.json",
                f"/boards/{TRACK}/laps.csv"]


def test_every_public_read_carries_the_cdn_headers_and_answers_304_to_its_etag(client: Client) -> None:
    client.push(make_record("Ada", laps=lap(12000)))
    for path in PUBLIC_READS:
        answer = client.request("GET", path, authorizer=None)
        assert answer["statusCode"] == 200, path
        assert answer["headers"]["Cache-Control"] == PUBLIC_CACHE, path
        etag = answer["headers"]["ETag"]
        held = client.request("GET", path, authorizer=None, headers={"if-none-match": etag})
        assert (held["statusCode"], held["body"]) == (304, ""), path


def test_errors_and_signed_or_organiser_answers_carry_no_public_cache_headers(client: Client) -> None:
    created = client.push(make_record("Ada", laps=lap(12000)))
    answers = [created, client.get("/me"), client.get(f"/boards/{TRACK}/export"),
               client.get(f"/boards/{TRACK}/audit"), client.get("/aliases"),
               client.send("POST", "/boards", cup_spec()), client.get("/boards/nowhere"),
               client.get("/boards/nowhere/view"), client.get(f"/boards/{TRACK}", limit="0")]
    for answer in answers:
        cache = answer["headers"].get("Cache-Control", "")
        assert "public" not in cache and "max-age" not in cache, answer
    assert [a["statusCode"] for a in answers[:6]] == [201, 200, 200, 200, 200, 201]


# ---- the pull function -----------------------------------------------------------------------------


def event(name: str) -> dict[str, Any]:
    return json.loads((EVENTS / name).read_text())  # type: ignore[no-any-return]


def test_the_pull_function_answers_kept_bytes_on_sqlite(monkeypatch: pytest.MonkeyPatch,
                                                       store: CountingStore) -> None:
    service = LeaderboardService(store)
    use_service(monkeypatch, service)
    service.push(make_record("Ada", laps=lap(12000)))
    first = pull.lambda_handler(event("pull_board.json"), LocalContext())
    store.calls.clear()
    again = pull.lambda_handler(event("pull_board.json"), LocalContext())
    assert again["body"] == first["body"] and store.calls == {"board_version": 1}
    service.push(make_record("Bob", laps=lap(11000)))
    assert racers(pull.lambda_handler(event("pull_board.json"), LocalContext())) == ["Bob", "Ada"]


def test_the_pull_function_reads_one_board_item_per_kept_answer_on_dynamodb(
        aws: None, monkeypatch: pytest.MonkeyPatch) -> None:
    tablekit = pytest.importorskip("tests.tablekit")
    tablekit.create_board_table(boto3.client("dynamodb", region_name=REGION), "boards")
    monkeypatch.setenv("TABLE_NAME", "boards")
    monkeypatch.delenv("ARCHIVE_BUCKET", raising=False)
    wiring.forget()
    try:
        service = wiring.service_from_environment()
        calls: list[str] = []
        service.store.client.meta.events.register(  # type: ignore[attr-defined]
            "before-call.dynamodb.*", lambda model, **_: calls.append(model.name))
        service.push(make_record("Ada", laps=lap(12000)))
        first = pull.lambda_handler(event("pull_board.json"), LocalContext())
        calls.clear()
        again = pull.lambda_handler(event("pull_board.json"), LocalContext())
        # The page kept in the table, with the board's version, in one read; from then on this
        # container holds it and reads the version alone.
        assert again["body"] == first["body"] and calls == ["BatchGetItem"]
        calls.clear()
        assert pull.lambda_handler(event("pull_board.json"), LocalContext())["body"] == first["body"]
        assert calls == ["GetItem"]
        etag = first["headers"]["ETag"]
        held = pull.lambda_handler(event("pull_board.json") | {"headers": {"if-none-match": etag}},
                                   LocalContext())
        assert held["statusCode"] == 304
        service.push(make_record("Bob", laps=lap(11000)))
        assert racers(pull.lambda_handler(event("pull_board.json"), LocalContext())) == ["Bob", "Ada"]
    finally:
        wiring.forget()


# ---- drboard serve ------------------------------------------------------------------------------


def scope(path: str, query: str = "", **headers: str) -> dict[str, Any]:
    return {"type": "http", "method": "GET", "path": path, "query_string": query.encode(),
            "headers": [(name.replace("_", "-").encode(), value.encode()) for name, value in headers.items()]}


@pytest.fixture
def served(store: CountingStore) -> Iterator[BoardServer]:
    server = BoardServer(("127.0.0.1", 0), LeaderboardService(store, clock=Clock()))
    yield server
    server.server_close()


def serve_get(server: BoardServer, path: str, query: str = "") -> tuple[int, dict[str, str], bytes]:
    """What a GET is answered with by serve's resolvers (an API Gateway event, as any request)."""
    from drboard_cli.serve import _http_answer, http_event

    status, headers, data = _http_answer(server.handle_event(
        http_event("GET", f"{path}?{query}" if query else path, {"host": "board.local"}, b"",
                   "127.0.0.1")))
    return status, {name.decode(): value.decode() for name, value in headers}, data


def test_serve_answers_a_kept_page_without_a_resolver(served: BoardServer, store: CountingStore,
                                                      parsed_entries: Counter[str]) -> None:
    served.service.push(make_record("Ada", laps=lap(12000)))
    assert served.kept_answer(scope(f"/boards/{TRACK}"), f"/boards/{TRACK}") is None  # not yet
    status, headers, data = serve_get(served, f"/boards/{TRACK}")
    store.calls.clear()
    parsed_entries.clear()
    kept = served.kept_answer(scope(f"/boards/{TRACK}"), f"/boards/{TRACK}")
    assert kept is not None
    assert (kept[0], kept[2]) == (status, data)
    assert {name.decode(): value.decode() for name, value in kept[1]} == headers
    assert store.calls == {"board_version": 1} and parsed_entries == {}
    held = served.kept_answer(scope(f"/boards/{TRACK}", if_none_match=headers["etag"]), f"/boards/{TRACK}")
    assert held is not None and (held[0], held[2]) == (304, b"")
    served.service.push(make_record("Bob", laps=lap(11000)))
    assert served.kept_answer(scope(f"/boards/{TRACK}"), f"/boards/{TRACK}") is None  # a new version
    entries = json.loads(serve_get(served, f"/boards/{TRACK}")[2])["entries"]
    assert [entry["racer"] for entry in entries] == ["Bob", "Ada"]


def test_serve_keeps_a_page_for_each_invite(served: BoardServer, monkeypatch: pytest.MonkeyPatch) -> None:
    served.service.push(make_record("Ada", laps=lap(12000)))
    serve_get(served, f"/boards/{TRACK}/view", "screen=1")
    assert served.kept_answer(scope(f"/boards/{TRACK}/view", "screen=1"), f"/boards/{TRACK}/view")
    monkeypatch.setattr(served, "invite", lambda: Invite(endpoint=served.public_url, code="K7QM-3XWD"))
    assert served.kept_answer(scope(f"/boards/{TRACK}/view", "screen=1"), f"/boards/{TRACK}/view") is None
    assert b"K7QM-3XWD" in serve_get(served, f"/boards/{TRACK}/view", "screen=1")[2]
