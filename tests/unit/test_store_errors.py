"""When the board's storage cannot do the work: every domain error has its own status at every
HTTP edge, a busy or unreachable store answers 503 with Retry-After (never a bare 500), the
archive is written before the push commits, and the functions' AWS clients give up in time."""

from __future__ import annotations

import json
import os
import sqlite3
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

os.environ.setdefault("POWERTOOLS_SERVICE_NAME", "drboard")
os.environ.setdefault("POWERTOOLS_METRICS_NAMESPACE", "drboard")
os.environ.setdefault("POWERTOOLS_TRACE_DISABLED", "true")

import boto3
from botocore.exceptions import ClientError, ReadTimeoutError
from drboard_assembler.record import Record
from drboard_cli.serve import LocalContext, _refused
from drboard_functions import errors, services
from drboard_functions.handlers import push, wiring
from drboard_functions.models.views import BoardList
from drboard_functions.routes import ERROR_STATUS, build_app, pull_router
from drboard_functions.service import LeaderboardService
from drboard_functions.stores import dynamodb, sqlite
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.dynamodb import transaction as push_transaction
from drboard_functions.stores.dynamodb.codecs import record_sk
from drboard_functions.stores.s3_archive import S3Archive
from drboard_functions.stores.sqlite import SqliteStore
from samtranslator.yaml_helper import yaml_parse

from tests.awskit import REGION
from tests.tablekit import create_board_table
from tests.wiringkit import use_service

ROOT = Path(__file__).parents[2]

pytestmark = pytest.mark.filterwarnings("ignore:No application metrics to publish")


def load(name: str) -> dict[str, Any]:
    return json.loads((ROOT / "events" / name).read_text())  # type: ignore[no-any-return]


def every_domain_error() -> list[type[errors.DomainError]]:
    found: list[type[errors.DomainError]] = []
    pending = list(errors.DomainError.__subclasses__())
    while pending:
        kind = pending.pop()
        found.append(kind)
        pending.extend(kind.__subclasses__())
    return sorted(set(found), key=lambda kind: kind.__name__)


def instance(kind: type[errors.DomainError]) -> errors.DomainError:
    if issubclass(kind, errors.TooSoon | errors.StoreError):
        return kind("it went wrong", 7)  # type: ignore[call-arg]
    return kind("it went wrong", detail=[{"loc": "track", "msg": "bad", "type": "value_error"}])


class Failing(LeaderboardService):
    """A board whose list of boards raises one error."""

    def __init__(self, error: Exception) -> None:
        super().__init__(SqliteStore(":memory:"))
        self.error = error

    def boards_page(self, limit: int = 100, cursor: str | None = None) -> BoardList:
        raise self.error


def get_boards(service: LeaderboardService) -> dict[str, Any]:
    app = build_app(pull_router)
    app.append_context(service=service)
    return app.resolve(load("pull_boards.json"), LocalContext())


def test_every_domain_error_module_class_is_a_domain_error_found_here() -> None:
    named = {name for name, value in vars(errors).items()
             if isinstance(value, type) and issubclass(value, errors.DomainError)}
    assert named - {"DomainError"} == {kind.__name__ for kind in every_domain_error()}


@pytest.mark.parametrize("kind", every_domain_error(), ids=lambda kind: kind.__name__)
def test_every_domain_error_has_its_own_status_and_the_documented_body(
        kind: type[errors.DomainError]) -> None:
    mapped = dict(ERROR_STATUS)
    assert kind in mapped, f"{kind.__name__} has no status of its own in ERROR_STATUS"
    status = next(s for k, s in ERROR_STATUS if issubclass(kind, k))
    assert status == mapped[kind]  # no broader class earlier in the list takes it
    assert 400 <= status < 600 and status != 500

    error = instance(kind)
    answer = get_boards(Failing(error))
    assert answer["statusCode"] == status
    body = json.loads(answer["body"])
    assert body["error"] == kind.__name__
    assert body["message"] == "it went wrong"
    assert body["detail"] == ([] if isinstance(error, errors.TooSoon | errors.StoreError)
                              else [{"loc": "track", "msg": "bad", "type": "value_error"}])
    if isinstance(error, errors.TooSoon | errors.StoreError):
        assert answer["headers"]["Retry-After"] == "7"

    served = _refused(error)  # `drboard serve`'s own refusals use the same mapping
    assert served["statusCode"] == status
    assert json.loads(served["body"])["error"] == kind.__name__


@pytest.mark.parametrize("kind", [errors.StoreBusy, errors.StoreUnavailable])
def test_a_busy_store_answers_503_with_retry_after(kind: type[errors.StoreError]) -> None:
    answer = get_boards(Failing(kind("the board's table is busy; try again in a moment", 1)))
    assert answer["statusCode"] == 503
    assert answer["headers"]["Retry-After"] == "1"
    assert json.loads(answer["body"])["error"] == kind.__name__


# ---- the cloud stores: throttling, timeouts, contention ----------------------------------------


@pytest.fixture
def cloud(aws: None, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Any, Any]]:
    """The real wiring (DynamoDB and S3 on moto) behind the push handler."""
    db = boto3.client("dynamodb", region_name=REGION)
    s3 = boto3.client("s3", region_name=REGION)
    create_board_table(db, "boards")
    s3.create_bucket(Bucket="archive", CreateBucketConfiguration={"LocationConstraint": REGION})
    monkeypatch.setenv("TABLE_NAME", "boards")
    monkeypatch.setenv("ARCHIVE_BUCKET", "archive")
    wiring.forget()
    yield db, s3
    wiring.forget()


def push_event() -> dict[str, Any]:
    return push.lambda_handler(load("push.json"), LocalContext())


def stored_items(db: Any) -> list[dict[str, Any]]:
    return db.scan(TableName="boards")["Items"]  # type: ignore[no-any-return]


def client_error(code: str, operation: str, **extra: Any) -> ClientError:
    return ClientError({"Error": {"Code": code, "Message": code}, **extra}, operation)  # type: ignore[arg-type]


@pytest.mark.parametrize("code", ["ProvisionedThroughputExceededException", "ThrottlingException",
                                  "RequestLimitExceeded"])
def test_a_throttled_table_answers_503_and_stores_nothing(
        cloud: tuple[Any, Any], monkeypatch: pytest.MonkeyPatch, code: str) -> None:
    db, _ = cloud
    table = wiring.service_from_environment().store
    assert isinstance(table, DynamoDbStore)

    def throttled(**_: Any) -> None:
        raise client_error(code, "TransactWriteItems")

    monkeypatch.setattr(table.client, "transact_write_items", throttled)
    answer = push_event()
    assert answer["statusCode"] == 503, answer["body"]
    assert answer["headers"]["Retry-After"] == "1"
    assert json.loads(answer["body"])["error"] == "StoreBusy"
    assert not [i for i in stored_items(db) if i["sk"]["S"].startswith(("S#", "R#"))]


def test_a_transaction_that_keeps_losing_races_answers_503(
        cloud: tuple[Any, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    table = wiring.service_from_environment().store
    calls = []

    def conflict(**_: Any) -> None:
        calls.append(1)
        raise client_error("TransactionCanceledException", "TransactWriteItems",
                           CancellationReasons=[{"Code": "None"}, {"Code": "TransactionConflict"}])

    monkeypatch.setattr(table.client, "transact_write_items", conflict)  # type: ignore[attr-defined]
    monkeypatch.setattr(push_transaction, "backoff", lambda attempt: None)
    answer = push_event()
    assert answer["statusCode"] == 503
    assert json.loads(answer["body"])["error"] == "StoreBusy"
    assert len(calls) == dynamodb.MAX_ATTEMPTS  # the store's own retries ran first


def test_a_table_that_does_not_answer_in_time_answers_503(
        cloud: tuple[Any, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    table = wiring.service_from_environment().store

    def slow(**_: Any) -> None:
        raise ReadTimeoutError(endpoint_url="https://dynamodb.eu-west-1.amazonaws.com")

    for read in ("get_item", "batch_get_item"):  # a push's first read is one of the board's items
        monkeypatch.setattr(table.client, read, slow)  # type: ignore[attr-defined]
    answer = push_event()
    assert answer["statusCode"] == 503
    assert answer["headers"]["Retry-After"] == "5"
    assert json.loads(answer["body"])["error"] == "StoreUnavailable"


def test_an_sdk_error_that_is_no_busy_store_is_named_not_hidden(aws: None) -> None:
    db = boto3.client("dynamodb", region_name=REGION)
    create_board_table(db, "boards")
    with pytest.raises(errors.StoreFailed, match="ResourceNotFoundException"):
        DynamoDbStore("no-such-table", client=db).get_board("x")


# ---- the archive comes first --------------------------------------------------------------------


def test_a_push_whose_archive_fails_answers_503_and_stores_nothing(
        cloud: tuple[Any, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    db, s3 = cloud
    monkeypatch.setenv("ARCHIVE_BUCKET", "no-such-bucket")
    wiring.forget()
    answer = push_event()
    assert answer["statusCode"] == 503, answer["body"]
    assert json.loads(answer["body"])["error"] == "StoreUnavailable"
    assert "Retry-After" in answer["headers"]
    assert not [i for i in stored_items(db) if i["sk"]["S"].startswith(("S#", "R#", "D#"))]

    monkeypatch.setenv("ARCHIVE_BUCKET", "archive")  # the bucket is back: the retry stores it
    wiring.forget()
    assert push_event()["statusCode"] == 201
    record = Record.model_validate_json(load("push.json")["body"])
    archived = s3.get_object(Bucket="archive", Key=S3Archive.key(record.track, record.submission_id))
    archived_json = archived["Body"].read()
    assert Record.model_validate_json(archived_json) == record
    # the archive holds the very bytes the board keeps of the record
    kept = next(i for i in stored_items(db) if i["sk"]["S"] == record_sk(record.submission_id))
    assert zlib.decompress(kept["record"]["B"]) == archived_json


def test_a_throttled_archive_answers_503_busy(cloud: tuple[Any, Any],
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    db, _ = cloud
    archive = wiring.service_from_environment().archive
    assert isinstance(archive, S3Archive)

    def slow_down(**_: Any) -> None:
        raise client_error("SlowDown", "PutObject")

    monkeypatch.setattr(archive._client, "put_object", slow_down)
    answer = push_event()
    assert (answer["statusCode"], json.loads(answer["body"])["error"]) == (503, "StoreBusy")
    assert not [i for i in stored_items(db) if i["sk"]["S"].startswith("S#")]


# ---- the embedded board ---------------------------------------------------------------------------


def test_a_locked_sqlite_board_answers_503(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sqlite, "BUSY_TIMEOUT_S", 0.05)
    path = tmp_path / "board.db"
    service = LeaderboardService(SqliteStore(path))
    use_service(monkeypatch, service)
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN IMMEDIATE")  # another process is writing, and keeps at it
    try:
        answer = push_event()
    finally:
        other.execute("ROLLBACK")
        other.close()
    assert answer["statusCode"] == 503, answer["body"]
    assert json.loads(answer["body"])["error"] == "StoreBusy"
    assert push_event()["statusCode"] == 201  # the writer is gone: the same push goes through


# ---- the functions' AWS clients fit in the function's timeout -------------------------------------


def template_timeouts() -> dict[str, int]:
    template = yaml_parse((ROOT / "template.yaml").read_text())
    default = template["Globals"]["Function"]["Timeout"]
    return {name: resource["Properties"].get("Timeout", default)
            for name, resource in template["Resources"].items()
            if resource["Type"] == "AWS::Serverless::Function"}


#: botocore's standard mode waits up to ``2 ** (n - 1)`` s before retry n after throttling, and
#: up to 5 s more when the service asks for it with ``x-amz-retry-after``.
RETRY_AFTER_ALLOWANCE_S = 5.0


def worst_case_call_s() -> float:
    """The longest one SDK call can take with the functions' client config: every attempt
    waiting out both timeouts, and every backoff at its longest."""
    attempts = services.RETRIES + 1
    waiting = attempts * (services.CONNECT_TIMEOUT_S + services.READ_TIMEOUT_S)
    backoff = sum(2.0 ** (n - 1) + RETRY_AFTER_ALLOWANCE_S for n in range(1, attempts))
    return waiting + backoff


def test_one_sdk_call_gives_up_before_any_function_times_out() -> None:
    timeouts = template_timeouts()
    assert timeouts
    config = services.client_config()
    assert config.retries == {"mode": "standard", "max_attempts": services.RETRIES}
    assert worst_case_call_s() < min(timeouts.values())


def test_the_functions_build_their_clients_with_that_config(cloud: tuple[Any, Any]) -> None:
    service = wiring.service_from_environment()
    assert isinstance(service.store, DynamoDbStore) and isinstance(service.archive, S3Archive)
    for client in (service.store.client, service.archive._client):
        config = client.meta.config
        assert (config.connect_timeout, config.read_timeout) == (
            services.CONNECT_TIMEOUT_S, services.READ_TIMEOUT_S)
        assert config.retries["mode"] == "standard"
        assert config.retries["total_max_attempts"] == services.RETRIES + 1
