"""The Lambda handlers with the example events in events/, as `sam local invoke -e` would send them.

The wiring is swapped for an SQLite-backed service; one test runs the real wiring (DynamoDB and
S3) on moto when the DynamoDB store is there.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from drboard_cli.serve import LocalContext

# Before the handlers are imported: Powertools reads these when it builds its Tracer and Metrics.
os.environ.setdefault("POWERTOOLS_SERVICE_NAME", "drboard")
os.environ.setdefault("POWERTOOLS_METRICS_NAMESPACE", "drboard")
os.environ.setdefault("POWERTOOLS_TRACE_DISABLED", "true")

import boto3
from drboard_assembler.record import Record
from drboard_functions.handlers import admin, card, pull, push, wiring
from drboard_functions.models.transfer import ExportedSubmission, ExportPage
from drboard_functions.models.views import BoardView
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.s3_archive import S3Archive
from drboard_functions.stores.sqlite import SqliteStore

from tests.awskit import REGION
from tests.wiringkit import use_service

EVENTS = Path(__file__).parents[2] / "events"
PULL_EVENTS = ["pull_index.json", "pull_boards.json", "pull_board.json", "pull_racer.json",
               "pull_view.json", "pull_racer_status.json", "pull_racer_history.json",
               "pull_seasons.json"]
ADMIN_EVENTS = ["admin_create_board.json", "admin_update_board.json", "admin_close_board.json",
                "admin_delete_board.json", "admin_restore_board.json", "admin_import_board.json",
                "admin_import_submission.json", "admin_export_board.json", "admin_remove_entry.json",
                "admin_ban_racer.json", "admin_unban_racer.json", "admin_audit.json",
                "admin_rebuild_ranks.json", "admin_create_season.json", "admin_add_round.json",
                "admin_set_final.json", "admin_close_season.json"]
#: A season's reads: answered once the season exists (tests/integration/test_template_seasons.py).
SEASON_EVENTS = ["season_standings.json", "season_view.json"]
CARD_EVENTS = ["card_racer.json"]

pytestmark = pytest.mark.filterwarnings("ignore:No application metrics to publish")


FakeLambdaContext = LocalContext  # what `drboard serve` gives the resolvers, too


def load(name: str) -> dict[str, Any]:
    return json.loads((EVENTS / name).read_text())  # type: ignore[no-any-return]


def event_record() -> Record:
    return Record.model_validate_json(load("push.json")["body"])


@pytest.fixture
def service(monkeypatch: pytest.MonkeyPatch) -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    service = LeaderboardService(store)
    use_service(monkeypatch, service)
    yield service
    store.close()


def test_the_events_are_api_gateway_http_api_v2_events() -> None:
    for path in sorted(EVENTS.glob("*.json")):
        event = load(path.name)
        method, route = event["routeKey"].split(" ", 1)
        assert event["version"] == "2.0", path.name
        assert event["requestContext"]["http"]["method"] == method
        assert event["requestContext"]["http"]["path"] == event["rawPath"]
        for name, value in (event.get("pathParameters") or {}).items():
            assert "{" + name + "}" in route and value in event["rawPath"]
    assert "iam" in load("push.json")["requestContext"]["authorizer"]
    assert set(ADMIN_EVENTS) | set(PULL_EVENTS) | set(SEASON_EVENTS) | set(CARD_EVENTS) | {"push.json"} == {
        p.name for p in EVENTS.glob("*.json")}
    for name in ADMIN_EVENTS:  # organiser requests are signed, and API Gateway says by whom
        assert load(name)["requestContext"]["authorizer"]["iam"]["userArn"], name
        assert load(name)["headers"]["authorization"].startswith("AWS4-HMAC-SHA256 "), name
    for name in PULL_EVENTS + SEASON_EVENTS + CARD_EVENTS:
        assert "authorizer" not in load(name)["requestContext"], name
    imported = json.loads(load("admin_import_submission.json")["body"])["record"]
    assert Record.model_validate(imported) == event_record(), "the same run as push.json's"


def test_push_stores_the_event_record_then_sees_the_duplicate(
        service: LeaderboardService, capsys: pytest.CaptureFixture[str]) -> None:
    first = push.lambda_handler(load("push.json"), FakeLambdaContext())
    assert first["statusCode"] == 201, first["body"]
    receipt = json.loads(first["body"])
    assert (receipt["status"], receipt["rank"]) == ("created", 1)
    assert receipt["submission_id"] == event_record().submission_id
    assert "SubmissionAccepted" in capsys.readouterr().out  # the metric, as EMF on stdout

    again = push.lambda_handler(load("push.json"), FakeLambdaContext())
    assert again["statusCode"] == 200
    assert json.loads(again["body"])["status"] == "duplicate"
    assert "DuplicateSubmission" in capsys.readouterr().out


def test_push_refuses_a_tampered_event_body(service: LeaderboardService) -> None:
    event = load("push.json")
    record = json.loads(event["body"])
    record["evaluations"][0]["laps"][0]["time_ms"] += 1
    event["body"] = json.dumps(record)
    event["headers"]["content-length"] = str(len(event["body"].encode()))
    response = push.lambda_handler(event, FakeLambdaContext())
    assert response["statusCode"] == 422
    assert service.boards() == []


@pytest.mark.parametrize("name", PULL_EVENTS)
def test_every_pull_event_is_answered(service: LeaderboardService, name: str) -> None:
    service.push(event_record())
    response = pull.lambda_handler(load(name), FakeLambdaContext())
    assert response["statusCode"] == 200, response["body"]


def test_the_card_event_is_answered_with_the_racers_card_as_a_png(service: LeaderboardService) -> None:
    import base64
    import struct

    service.push(event_record())
    response = card.lambda_handler(load("card_racer.json"), FakeLambdaContext())
    assert response["statusCode"] == 200, response["body"]
    assert response["headers"]["Content-Type"] == "image/png" and response["isBase64Encoded"] is True
    png = base64.b64decode(response["body"])
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR"
    assert struct.unpack(">II", png[16:24]) == (1200, 630)
    again = load("card_racer.json")
    again["headers"]["if-none-match"] = response["headers"]["ETag"]
    assert card.lambda_handler(again, FakeLambdaContext())["statusCode"] == 304


def test_pull_events_answer_what_each_route_promises(service: LeaderboardService) -> None:
    record = event_record()
    service.push(record)
    context = FakeLambdaContext()

    boards = json.loads(pull.lambda_handler(load("pull_boards.json"), context)["body"])
    assert [b["board_id"] for b in boards["boards"]] == [record.track]

    board = pull.lambda_handler(load("pull_board.json"), context)
    assert board["headers"]["Access-Control-Allow-Origin"] == "*"  # the event comes from a browser
    assert [e["racer"] for e in json.loads(board["body"])["entries"]] == [record.racer]

    racer = json.loads(pull.lambda_handler(load("pull_racer.json"), context)["body"])
    assert racer["record"]["submission_id"] == record.submission_id

    view = pull.lambda_handler(load("pull_view.json"), context)
    assert view["headers"]["Content-Type"].startswith("text/html")
    assert record.racer in view["body"]

    index = pull.lambda_handler(load("pull_index.json"), context)
    assert "Smile Speedway" in index["body"]

    status = json.loads(pull.lambda_handler(load("pull_racer_status.json"), context)["body"])
    assert [(s["board"]["board_id"], s["entry"]["rank"]) for s in status["boards"]] == [(record.track, 1)]

    history = json.loads(pull.lambda_handler(load("pull_racer_history.json"), context)["body"])
    assert [item["submission_id"] for item in history["history"]] == [record.submission_id]


def test_the_pull_function_does_not_take_submissions(service: LeaderboardService) -> None:
    response = pull.lambda_handler(load("push.json"), FakeLambdaContext())
    assert response["statusCode"] == 404
    assert service.boards() == []


# ---- the admin function ------------------------------------------------------------------------


def admin_call(name: str) -> tuple[int, dict[str, Any]]:
    response = admin.lambda_handler(load(name), FakeLambdaContext())
    return response["statusCode"], json.loads(response["body"])


def test_an_organiser_manages_the_winter_cup_with_the_admin_events(
        service: LeaderboardService, caplog: pytest.LogCaptureFixture) -> None:
    status, created = admin_call("admin_create_board.json")
    assert status == 201, created
    cup = BoardView.model_validate(created)
    assert (cup.board_id, cup.track, cup.cooldown_s, cup.max_submissions) == (
        "winter-cup-2026", "reInvent2019_track", 900, 20)
    [audit] = [r for r in caplog.records if r.getMessage() == "OrganiserRequest"]
    assert (audit.route, audit.status, audit.caller) == (  # type: ignore[attr-defined]
        "POST /boards", 201, "iam:arn:aws:sts::123456789012:assumed-role/drboard-organisers/ada")

    status, updated = admin_call("admin_update_board.json")  # closes later; no maximum any more
    assert status == 200, updated
    changed = BoardView.model_validate(updated)
    assert (changed.closes_at.isoformat() if changed.closes_at else None,
            changed.max_submissions, changed.cooldown_s) == ("2026-12-22T17:00:00+00:00", None, 900)

    assert admin_call("admin_close_board.json")[1]["status"] == "CLOSED"
    assert admin_call("admin_delete_board.json")[0] == 200
    assert service.boards() == []
    assert admin_call("admin_restore_board.json")[0] == 200
    assert [b.board_id for b in service.boards()] == ["winter-cup-2026"]


def test_an_organiser_builds_a_boards_rank_counters_with_the_admin_event(
        service: LeaderboardService) -> None:
    service.push(event_record())
    status, built = admin_call("admin_rebuild_ranks.json")
    assert (status, built) == (200, {"board_id": "reInvent2019_track", "done": True,
                                     "counted": 1, "participants": 1})


def test_an_organiser_imports_last_seasons_cup_and_exports_it(service: LeaderboardService) -> None:
    assert admin_call("admin_import_board.json")[0] == 201
    assert admin_call("admin_import_board.json")[0] == 200  # it exists: nothing changes
    status, receipt = admin_call("admin_import_submission.json")
    assert (status, receipt["status"]) == (201, "created")
    assert admin_call("admin_import_submission.json")[1]["status"] == "duplicate"

    status, exported = admin_call("admin_export_board.json")
    assert status == 200
    page = ExportPage.model_validate(exported)
    assert page.lines[0].kind == "board"
    records = []
    while page.next_cursor:  # the export's later pages, as `drboard export` asks for them
        event = load("admin_export_board.json")
        event["queryStringParameters"] = {"cursor": page.next_cursor}
        event["rawQueryString"] = f"cursor={page.next_cursor}"
        page = ExportPage.model_validate(json.loads(admin.lambda_handler(event, FakeLambdaContext())["body"]))
        records += [line.record for line in page.lines if isinstance(line, ExportedSubmission)]
    assert records == [event_record()]
    history = service.history("Speedy", "spring-cup-2025")
    assert [item.submitted_at.isoformat() for item in history] == ["2025-04-12T11:40:05.120000+00:00"]


def test_the_admin_function_takes_neither_pushes_nor_reads(service: LeaderboardService) -> None:
    for name in ("push.json", "pull_boards.json", "pull_board.json"):
        response = admin.lambda_handler(load(name), FakeLambdaContext())
        assert response["statusCode"] == 404, name
    assert service.boards() == []


@pytest.mark.parametrize("name", ADMIN_EVENTS)
def test_no_other_function_answers_organiser_events(service: LeaderboardService, name: str) -> None:
    for handler in (push.lambda_handler, pull.lambda_handler):
        assert handler(load(name), FakeLambdaContext())["statusCode"] in (404, 405), name
    assert service.boards() == []


# ---- the cloud wiring, on moto -----------------------------------------------------------------


def test_the_archive_writes_the_record_as_json(aws: None) -> None:
    s3 = boto3.client("s3", region_name=REGION)
    s3.create_bucket(Bucket="archive", CreateBucketConfiguration={"LocationConstraint": REGION})
    record = event_record()
    S3Archive("archive", client=s3).put("reInvent2019_track", record.submission_id, record.model_dump_json())
    key = f"records/reInvent2019_track/{record.submission_id}.json"
    stored = s3.get_object(Bucket="archive", Key=key)
    assert stored["ContentType"] == "application/json"
    assert Record.model_validate_json(stored["Body"].read()) == record


def test_the_archive_keeps_a_board_id_inside_its_prefix() -> None:
    assert S3Archive.key("../x/y", "abc") == "records/..%2Fx%2Fy/abc.json"


def test_the_handlers_run_on_dynamodb_and_s3(aws: None, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("drboard_functions.stores.dynamodb")
    tablekit = pytest.importorskip("tests.tablekit")
    dynamodb = boto3.client("dynamodb", region_name=REGION)
    s3 = boto3.client("s3", region_name=REGION)
    tablekit.create_board_table(dynamodb, "boards")
    s3.create_bucket(Bucket="archive", CreateBucketConfiguration={"LocationConstraint": REGION})
    monkeypatch.setenv("TABLE_NAME", "boards")
    monkeypatch.setenv("ARCHIVE_BUCKET", "archive")
    wiring.forget()
    try:
        assert wiring.service_from_environment() is wiring.service_from_environment()
        created = push.lambda_handler(load("push.json"), FakeLambdaContext())
        assert created["statusCode"] == 201, created["body"]
        assert push.lambda_handler(load("push.json"), FakeLambdaContext())["statusCode"] == 200

        record = event_record()
        key = f"records/{record.track}/{record.submission_id}.json"
        assert s3.head_object(Bucket="archive", Key=key)["ContentType"] == "application/json"

        page = pull.lambda_handler(load("pull_board.json"), FakeLambdaContext())
        assert page["statusCode"] == 200
        assert [e["racer"] for e in json.loads(page["body"])["entries"]] == [record.racer]
    finally:
        wiring.forget()


# ---- signed in with Cognito: the same routes under /cognito, behind the JWT authorizer ----------


def _signed_in(event: dict[str, Any], claims: dict[str, Any]) -> dict[str, Any]:
    event = json.loads(json.dumps(event))
    for holder in (event, event["requestContext"]["http"]):
        key = "rawPath" if holder is event else "path"
        holder[key] = "/cognito" + holder[key]
    event["requestContext"]["authorizer"] = {"jwt": {"claims": claims, "scopes": None}}
    return event


ACCESS = {"sub": "ada-sub", "username": "ada", "token_use": "access",
          "cognito:groups": "[racers]"}


def test_a_racer_signed_in_with_cognito_pushes_through_the_twin_route(
        service: LeaderboardService) -> None:
    answer = push.lambda_handler(_signed_in(load("push.json"), ACCESS), FakeLambdaContext())
    assert answer["statusCode"] == 201, answer["body"]
    who = load("push.json") | {"rawPath": "/me", "routeKey": "GET /me", "body": None}
    who["requestContext"]["http"] |= {"method": "GET", "path": "/me"}
    me = push.lambda_handler(_signed_in(who, ACCESS), FakeLambdaContext())
    assert (json.loads(me["body"])["principal"], json.loads(me["body"])["alias"]) == (
        "cognito:ada-sub", event_record().racer)


def test_an_id_token_or_a_racer_cannot_reach_the_organiser_routes(service: LeaderboardService) -> None:
    as_id_token = _signed_in(load("push.json"), ACCESS | {"token_use": "id"})
    assert push.lambda_handler(as_id_token, FakeLambdaContext())["statusCode"] == 401
    racer = admin.lambda_handler(_signed_in(load("admin_create_board.json"), ACCESS), FakeLambdaContext())
    assert racer["statusCode"] == 403
    organiser = ACCESS | {"sub": "org-sub", "cognito:groups": "[organisers]"}
    created = admin.lambda_handler(_signed_in(load("admin_create_board.json"), organiser),
                                   FakeLambdaContext())
    assert created["statusCode"] == 201, created["body"]
    assert service.audit("winter-cup-2026").events[0].actor == "cognito:org-sub"
