"""A board's pages kept in the table (stores/dynamodb/pages.py) and answered by the pull function
before it loads the resolver (routes/kept.py, handlers/pull.py): a push keeps the standings
racers ask for most, a new container answers them from one read, a page is never answered for
another version of the board or another address, and the kept answer is the routes' answer,
headers included."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

os.environ.setdefault("POWERTOOLS_SERVICE_NAME", "drboard")
os.environ.setdefault("POWERTOOLS_METRICS_NAMESPACE", "drboard")

import boto3
from aws_lambda_powertools.event_handler import CORSConfig
from drboard_cli.serve import LocalContext
from drboard_functions.handlers import admin, card, pull, push, wiring
from drboard_functions.routes.headers import CORS_HEADERS, CORS_MAX_AGE_S, CORS_ORIGIN, READ_CORS
from drboard_functions.routes.kept import PUSHED_LIMITS, KeptPages, Wanted, event_answer, shelf_key
from drboard_functions.stores.dynamodb.pages import MAX_KEPT_BYTES, DynamoDbPageShelf
from drboard_functions.stores.pages import StoredPage

from tests.awskit import REGION
from tests.recordkit import make_record

pytestmark = pytest.mark.filterwarnings("ignore:No application metrics to publish")
EVENTS = Path(__file__).parents[2] / "events"
TABLE = "boards"
BOARD = "reInvent2019_track"


def event(name: str, **changes: Any) -> dict[str, Any]:
    sent: dict[str, Any] = json.loads((EVENTS / name).read_text())
    return sent | changes


def push_event(racer: str, lap_ms: int) -> dict[str, Any]:
    body = make_record(racer, [(lap_ms, 100)]).model_dump_json()
    return event("push.json", body=body, headers=event("push.json")["headers"]
                 | {"content-length": str(len(body.encode()))})


class Calls(list[str]):
    """The DynamoDB operations the functions' client made."""


@pytest.fixture
def cloud(aws: None, monkeypatch: pytest.MonkeyPatch) -> Iterator[Calls]:
    """The functions' real wiring on moto's table, counting each DynamoDB call by name."""
    tablekit = pytest.importorskip("tests.tablekit")
    tablekit.create_board_table(boto3.client("dynamodb", region_name=REGION), TABLE)
    monkeypatch.setenv("TABLE_NAME", TABLE)
    monkeypatch.delenv("ARCHIVE_BUCKET", raising=False)
    monkeypatch.setattr(boto3, "DEFAULT_SESSION", None)
    boto3.setup_default_session()  # every client the functions make from here is counted
    calls = Calls()
    assert boto3.DEFAULT_SESSION is not None
    boto3.DEFAULT_SESSION.events.register("before-call.dynamodb.*",
                                          lambda model, **_: calls.append(model.name))
    wiring.forget()
    yield calls
    wiring.forget()


def page_writes() -> list[str]:
    """The partitions of the pages the functions keep from now on, one per page written."""
    written: list[str] = []

    def note(item: dict[str, Any]) -> None:
        if item["board"]["S"].startswith("#PAGE#"):
            written.append(item["board"]["S"])

    def put(params: dict[str, Any], **_: Any) -> None:
        note(params["Item"])

    def batch(params: dict[str, Any], **_: Any) -> None:
        for requests in params["RequestItems"].values():
            for request in requests:
                if "PutRequest" in request:
                    note(request["PutRequest"]["Item"])

    assert boto3.DEFAULT_SESSION is not None
    boto3.DEFAULT_SESSION.events.register("before-parameter-build.dynamodb.PutItem", put)
    boto3.DEFAULT_SESSION.events.register("before-parameter-build.dynamodb.BatchWriteItem", batch)
    return written


def test_a_push_keeps_the_standings_a_new_container_answers_from_one_read(cloud: Calls) -> None:
    assert push.lambda_handler(push_event("Ada", 12_000), LocalContext())["statusCode"] == 201
    wiring.forget()
    cloud.clear()
    answer = pull.lambda_handler(event("pull_board.json"), LocalContext())
    assert answer["statusCode"] == 200
    assert cloud == ["BatchGetItem"], "the board's version and the kept page, in one read"
    assert [e["racer"] for e in json.loads(answer["body"])["entries"]] == ["Ada"]
    assert answer["headers"]["Cache-Control"].startswith("public")
    assert answer["headers"] | READ_CORS == answer["headers"], "the reads' CORS headers"

    # The routes render the same answer, bytes and headers, when nothing is kept.
    shelf = DynamoDbPageShelf(boto3.client("dynamodb", region_name=REGION), TABLE)
    version, kept = shelf.page(BOARD, shelf_key(Wanted(BOARD, "json", 25), ""))
    assert kept is not None and kept.version == version
    rendered = pull.resolved(event("pull_board.json"), LocalContext())
    assert (rendered["body"], rendered["headers"]["ETag"]) == (answer["body"], answer["headers"]["ETag"])


def test_a_push_keeps_the_pages_drboard_pull_and_the_api_ask_for(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    shelf = DynamoDbPageShelf(boto3.client("dynamodb", region_name=REGION), TABLE)
    for limit in PUSHED_LIMITS:
        version, kept = shelf.page(BOARD, shelf_key(Wanted(BOARD, "json", limit), ""))
        assert kept is not None and kept.version == version == 1, limit
        assert len(json.loads(kept.text)["entries"]) == 1
    from drboard_cli.commands.standings import DEFAULT_TOP

    assert DEFAULT_TOP in PUSHED_LIMITS, "`drboard pull`'s own page"
    assert "limit=25" in event("pull_board.json")["rawQueryString"]


def test_a_push_reads_what_it_checks_at_once_and_its_standings_once(cloud: Calls) -> None:
    """A push reads the board, the event's bans, whether the run is there already and the
    racer's entry at once; who pushed the run first; and the board's first entries once, for the
    receipt (rank, leader, racers) and the standings it keeps. A board no season ever took in is
    not searched for a season's final."""
    assert push.lambda_handler(push_event("Ada", 12_000), LocalContext())["statusCode"] == 201
    cloud.clear()
    answer = push.lambda_handler(push_event("Bo", 11_000), LocalContext())
    assert answer["statusCode"] == 201
    receipt = json.loads(answer["body"])
    assert (receipt["rank"], receipt["participants"], receipt["entry"]["gap_ms"]) == (1, 2, 0)
    reads = [call for call in cloud if call in ("GetItem", "BatchGetItem", "Query", "TransactGetItems")]
    assert sorted(reads[:2]) == ["BatchGetItem", "Query"], "checks, and the run's authors, at once"
    assert reads[2:] == ["Query"], "the first entries"
    shelf = DynamoDbPageShelf(boto3.client("dynamodb", region_name=REGION), TABLE)
    version, kept = shelf.page(BOARD, shelf_key(Wanted(BOARD, "json", 25), ""))
    assert kept is not None and kept.version == version
    assert [e["racer"] for e in json.loads(kept.text)["entries"]] == ["Bo", "Ada"]


def test_a_run_that_changes_no_standings_renders_no_page(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    written = page_writes()
    wiring.forget()
    slower = push.lambda_handler(push_event("Ada", 13_000), LocalContext())
    assert slower["statusCode"] == 201 and json.loads(slower["body"])["improved"] is False
    assert written == []
    assert pull.lambda_handler(event("pull_board.json"), LocalContext())["statusCode"] == 200
    wiring.forget()
    cloud.clear()
    pull.lambda_handler(event("pull_board.json"), LocalContext())
    assert cloud == ["BatchGetItem"], "the pages kept for the version the first run made still hold"


def test_a_kept_page_is_never_answered_for_another_version(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    first = pull.lambda_handler(event("pull_board.json"), LocalContext())
    push.lambda_handler(push_event("Bob", 11_000), LocalContext())
    after = pull.lambda_handler(event("pull_board.json"), LocalContext())
    assert [e["racer"] for e in json.loads(after["body"])["entries"]] == ["Bob", "Ada"]
    assert after["headers"]["ETag"] != first["headers"]["ETag"]

    # An organiser's change moves the version, and keeps the pages of the version it made.
    removed = admin.lambda_handler(remove_entry("Bob"), LocalContext())
    assert removed["statusCode"] == 200, removed["body"]
    wiring.forget()
    cloud.clear()
    answer = pull.lambda_handler(event("pull_board.json"), LocalContext())
    assert [e["racer"] for e in json.loads(answer["body"])["entries"]] == ["Ada"]
    assert cloud == ["BatchGetItem"]


def remove_entry(racer: str) -> dict[str, Any]:
    sent = event("admin_remove_entry.json")
    path = f"/boards/{BOARD}/racers/{racer}"
    sent["requestContext"]["http"]["path"] = path
    return sent | {"rawPath": path, "pathParameters": {"board": BOARD, "racer": racer}}


def test_a_page_no_one_kept_is_rendered_by_its_first_reader_and_kept_for_all(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    top_ten = event("pull_board.json", rawQueryString="limit=10", queryStringParameters={"limit": "10"})
    wiring.forget()
    cloud.clear()
    first = pull.lambda_handler(top_ten, LocalContext())
    assert first["statusCode"] == 200 and "PutItem" in cloud, "rendered, and kept"
    wiring.forget()
    cloud.clear()
    assert pull.lambda_handler(top_ten, LocalContext())["body"] == first["body"]
    assert cloud == ["BatchGetItem"]


def test_an_import_one_submission_a_request_leaves_the_pages_to_their_reader(cloud: Calls) -> None:
    kept = page_writes()
    assert admin.lambda_handler(event("admin_import_board.json"), LocalContext())["statusCode"] == 201
    board = event("admin_import_board.json")["pathParameters"]["board"]
    assert kept == [f"#PAGE#{board}"] * 2, "the new board's pages"
    kept.clear()
    imported = admin.lambda_handler(event("admin_import_submission.json"), LocalContext())
    assert imported["statusCode"] == 201, imported["body"]
    assert kept == []


def test_a_kept_web_page_is_answered_only_for_the_address_it_names(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    view = event("pull_view.json")
    first = pull.lambda_handler(view, LocalContext())
    assert first["statusCode"] == 200 and view["headers"]["host"] in first["body"]
    wiring.forget()
    cloud.clear()
    assert pull.lambda_handler(view, LocalContext())["body"] == first["body"]
    assert cloud == ["BatchGetItem"]
    elsewhere = view | {"headers": view["headers"] | {"host": "board.example.org"}}
    other = pull.lambda_handler(elsewhere, LocalContext())
    assert "board.example.org" in other["body"] and view["headers"]["host"] not in other["body"]


def test_a_kept_page_answers_304_to_the_etag_the_client_holds(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    etag = pull.lambda_handler(event("pull_board.json"), LocalContext())["headers"]["ETag"]
    wiring.forget()
    held = event("pull_board.json")
    held["headers"] = held["headers"] | {"if-none-match": f"W/{etag}"}
    answer = pull.lambda_handler(held, LocalContext())
    assert (answer["statusCode"], answer["body"]) == (304, "")


# ---- result cards, drawn from the kept standings -----------------------------------------------


def card_event(racer: str, kind: str = "png", **headers: str) -> dict[str, Any]:
    sent = event("card_racer.json")
    path = f"/boards/{BOARD}/racers/{racer}/card.{kind}"
    sent["requestContext"]["http"]["path"] = path
    return sent | {"rawPath": path, "pathParameters": {"board": BOARD, "racer": racer},
                   "headers": sent["headers"] | headers}


@pytest.mark.parametrize("kind", ["png", "svg"])
def test_a_card_is_drawn_from_the_kept_standings_as_the_routes_draw_it(cloud: Calls, kind: str) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    push.lambda_handler(push_event("Bob", 11_000), LocalContext())
    for racer in ("Ada", "bob"):  # the leader's card says by how much it leads
        wiring.forget()
        cloud.clear()
        kept = card.lambda_handler(card_event(racer, kind), LocalContext())
        assert kept["statusCode"] == 200
        assert cloud == ["BatchGetItem"], "the standings the push kept, and nothing else"
        drawn = card.resolved(card_event(racer, kind), LocalContext())
        assert {k: kept[k] for k in ("body", "headers", "isBase64Encoded")} == {
            k: drawn[k] for k in ("body", "headers", "isBase64Encoded")}, racer
    holding = card_event("bob", kind, **{"if-none-match": kept["headers"]["ETag"]})
    held = card.lambda_handler(holding, LocalContext())
    assert (held["statusCode"], held["body"], held["isBase64Encoded"]) == (304, "", False)
    assert held["headers"] == card.resolved(holding, LocalContext())["headers"]
    shared = card.lambda_handler(card_event("Ada", kind, origin="https://club.example.org"), LocalContext())
    assert shared["headers"] | READ_CORS == shared["headers"]


def test_a_card_no_kept_page_shows_is_the_routes_to_draw(cloud: Calls) -> None:
    push.lambda_handler(push_event("Ada", 12_000), LocalContext())
    assert card.lambda_handler(card_event("Nobody"), LocalContext())["statusCode"] == 404
    admin.lambda_handler(remove_entry("Ada"), LocalContext())
    assert card.lambda_handler(card_event("Ada"), LocalContext())["statusCode"] == 404
    push.lambda_handler(push_event("Cy", 15_000), LocalContext())
    assert card.lambda_handler(card_event("Cy"), LocalContext())["statusCode"] == 200


# ---- the shelf itself ----------------------------------------------------------------------------


def page(version: int, text: str = '{"entries":[]}', fresh_until: float | None = None) -> StoredPage:
    return StoredPage(version, fresh_until, f'"v{version}"', {"Content-Type": "application/json"},
                      {"ETag": f'"v{version}"'}, text)


def test_the_shelf_keeps_a_page_compressed_and_never_an_older_one(aws: None) -> None:
    tablekit = pytest.importorskip("tests.tablekit")
    client = boto3.client("dynamodb", region_name=REGION)
    tablekit.create_board_table(client, TABLE)
    shelf = DynamoDbPageShelf(client, TABLE)
    big = json.dumps({"entries": [{"racer": f"racer {n}", "design": "x" * 200} for n in range(100)]})
    shelf.keep(BOARD, "json#100", page(3, big, fresh_until=1_800_000_000.5))
    item = client.get_item(TableName=TABLE, Key={"board": {"S": f"#PAGE#{BOARD}"},
                                                 "sk": {"S": "json#100"}})["Item"]
    assert len(item["body"]["B"]) < len(big) / 5
    assert shelf.page(BOARD, "json#100") == (None, page(3, big, fresh_until=1_800_000_000.5))
    shelf.keep(BOARD, "json#100", page(2))
    assert shelf.page(BOARD, "json#100")[1] == page(3, big, fresh_until=1_800_000_000.5)
    shelf.keep(BOARD, "json#100", page(4))
    assert shelf.page(BOARD, "json#100")[1] == page(4)


def test_the_shelf_keeps_the_pages_of_a_change_together_and_skips_one_too_big(aws: None) -> None:
    tablekit = pytest.importorskip("tests.tablekit")
    client = boto3.client("dynamodb", region_name=REGION)
    tablekit.create_board_table(client, TABLE)
    shelf = DynamoDbPageShelf(client, TABLE)
    calls: list[str] = []
    client.meta.events.register("before-call.dynamodb.*",
                                lambda model, **_: calls.append(model.name))
    huge = os.urandom(MAX_KEPT_BYTES).hex()  # random: compressed, still over the bound
    shelf.keep_all(BOARD, [("json#25", page(5)), ("json#100", page(5, '{"entries":[1]}')),
                           ("json#50", page(5, huge))])
    assert calls == ["BatchWriteItem"]
    assert shelf.page(BOARD, "json#25")[1] == page(5)
    assert shelf.page(BOARD, "json#100")[1] == page(5, '{"entries":[1]}')
    assert shelf.page(BOARD, "json#50") == (None, None)


def test_kept_pages_answer_only_while_the_version_and_the_moment_hold() -> None:
    from datetime import UTC, datetime

    now = datetime(2026, 1, 1, tzinfo=UTC)

    class Shelf:
        def __init__(self) -> None:
            self.version = 7
            self.kept: dict[str, StoredPage] = {}

        def page(self, board_id: str, key: str) -> tuple[int | None, StoredPage | None]:
            return self.version, self.kept.get(key)

        def keep(self, board_id: str, key: str, stored: StoredPage) -> None:
            self.kept[key] = stored

    shelf = Shelf()
    pages = KeptPages(lambda board_id: shelf.version, shelf, lambda: now)  # type: ignore[arg-type]
    wanted = Wanted(BOARD, "json", 25)
    assert pages.kept(wanted) is None
    shelf.keep(BOARD, shelf_key(wanted, ""), page(7, fresh_until=now.timestamp() + 60))
    assert pages.kept(wanted) is not None
    shelf.version = 8
    assert pages.kept(wanted) is None, "the board moved on"
    shelf.keep(BOARD, shelf_key(wanted, ""), page(8, fresh_until=now.timestamp()))
    assert pages.kept(wanted) is None, "the board opened or closed"


def test_the_kept_answers_carry_the_resolvers_cors_headers() -> None:
    cors = CORSConfig(allow_origin=CORS_ORIGIN, allow_headers=list(CORS_HEADERS), max_age=CORS_MAX_AGE_S)
    assert cors.to_dict(cors.allowed_origin("https://club.example.org")) == READ_CORS


def test_a_request_no_kept_page_answers_goes_to_the_routes() -> None:
    class Nothing:
        def kept(self, page: Wanted, address: str = "") -> None:
            raise AssertionError("not a kept page's request")

    for name, changes in [("pull_board.json", {"rawQueryString": "limit=25&cursor=abc"}),
                          ("pull_racer.json", {}), ("push.json", {}),
                          ("pull_board.json", {"rawQueryString": "limit=25&limit=26"})]:
        assert event_answer(event(name, **changes), Nothing()) is None, name  # type: ignore[arg-type]
