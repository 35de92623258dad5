"""The DynamoDB store: the BoardStore contract on moto and on Amazon's DynamoDB Local, plus what
only the real engine shows: concurrent pushes of one racer, and a top N that reads N items."""

from __future__ import annotations

import random
import threading
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import boto3
import pytest
from botocore.exceptions import EndpointConnectionError
from click.testing import CliRunner
from drboard_cli.commands import organisers
from drboard_cli.main import cli
from drboard_functions.errors import (
    AliasTaken,
    Banned,
    CopiedRun,
    StoreUnavailable,
    SubmissionLimitReached,
    TooSoon,
)
from drboard_functions.identity import Caller
from drboard_functions.models.requests import BoardSpec
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.dynamodb import DynamoDbStore, board_item, entry_item
from drboard_functions.stores.dynamodb import transaction as push_transaction
from moto import mock_aws

from tests.contract.season_contract import link, named_board, season
from tests.contract.store_contract import TRACK, StoreContract, at, make_board, write_for
from tests.integration.dynamodb_local import REGION, DynamoDbLocal
from tests.recordkit import make_record
from tests.tablekit import create_board_table, table_definition


def new_table(client: Any) -> str:
    return create_board_table(client, f"drboard-test-{uuid.uuid4().hex[:12]}")


@pytest.fixture
def local_table(dynamodb_local: DynamoDbLocal) -> Iterator[str]:
    """A fresh, empty board table on the session's DynamoDB Local."""
    client = dynamodb_local.client()
    name = new_table(client)
    yield name
    client.delete_table(TableName=name)


class TestMotoContract(StoreContract):
    @pytest.fixture
    def store(self) -> Iterator[DynamoDbStore]:
        with mock_aws():
            client = boto3.client("dynamodb", region_name=REGION)
            yield DynamoDbStore(new_table(client), client)


class TestDynamoDbLocalContract(StoreContract):
    @pytest.fixture
    def store(self, dynamodb_local: DynamoDbLocal, local_table: str) -> DynamoDbStore:
        return DynamoDbStore(local_table, dynamodb_local.client())


def test_the_table_is_the_templates_board_table(dynamodb_local: DynamoDbLocal, local_table: str) -> None:
    table = dynamodb_local.client().describe_table(TableName=local_table)["Table"]
    definition = table_definition()
    assert table["KeySchema"] == definition["KeySchema"]
    assert {i["IndexName"] for i in table["LocalSecondaryIndexes"]} == {"by_rank"}
    assert {i["IndexName"] for i in table["GlobalSecondaryIndexes"]} == {"by_racer", "boards"}


# ---- concurrent pushes ----------------------------------------------------------------------

PUSHERS = 20
SHARED = "Shared Racer"


def test_concurrent_pushes_of_one_racer_lose_nothing(dynamodb_local: DynamoDbLocal,
                                                     local_table: str) -> None:
    times = [20_000 - n * 37 for n in range(PUSHERS)]
    random.Random(3).shuffle(times)  # the best is pushed somewhere in the middle
    records = [make_record(SHARED, [(ms, 100)], model=f"m{n}") for n, ms in enumerate(times)]
    # Each thread has its own client, as separate Lambda invocations would; built beforehand.
    services = [LeaderboardService(DynamoDbStore(local_table, dynamodb_local.client()))
                for _ in range(PUSHERS)]
    barrier = threading.Barrier(PUSHERS)
    errors: list[BaseException] = []
    statuses: list[str] = []

    def push(n: int) -> None:
        try:
            barrier.wait(timeout=30)
            statuses.append(services[n].push(records[n]).status)
        except BaseException as error:
            errors.append(error)

    threads = [threading.Thread(target=push, args=(n,)) for n in range(PUSHERS)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert errors == []
    assert statuses == ["created"] * PUSHERS

    service = services[0]
    history = service.history(SHARED, TRACK)
    assert sorted(h.submission_id for h in history) == sorted(r.submission_id for r in records)
    best = records[times.index(min(times))]
    view = service.racer(TRACK, SHARED)
    assert (view.entry.time_ms, view.entry.submission_id) == (min(times), best.submission_id)
    assert [h.submission_id for h in history if h.is_best] == [best.submission_id]
    assert view.board.participants == 1
    assert [e.racer for e in service.board_page(TRACK).entries] == [SHARED]


# ---- the top N reads N items ------------------------------------------------------------------

BIG_BOARD = 1_000


def seed_board(client: Any, table: str, racers: int) -> None:
    """A board of ``racers`` entries, written directly (BatchWriteItem, 25 items a call)."""
    board = make_board()
    rng = random.Random(11)
    items = [board_item(board) | {"participants": {"N": str(racers)}}]
    for n in range(racers):
        record = make_record(f"Racer {n:04d}", [(rng.randrange(8_000, 30_000), 100)])
        items.append(entry_item(write_for(record, board, at(n))[1]))
    for start in range(0, len(items), 25):
        requests = [{"PutRequest": {"Item": item}} for item in items[start:start + 25]]
        while requests:
            response = client.batch_write_item(RequestItems={table: requests})
            requests = response.get("UnprocessedItems", {}).get(table, [])


def test_top_of_a_big_board_reads_about_limit_items(dynamodb_local: DynamoDbLocal,
                                                    local_table: str) -> None:
    client = dynamodb_local.client()
    seed_board(client, local_table, BIG_BOARD)
    scanned: list[int] = []

    def count_scanned(parsed: dict[str, Any], **_: Any) -> None:
        scanned.append(parsed["ScannedCount"])

    client.meta.events.register("after-call.dynamodb.Query", count_scanned)
    store = DynamoDbStore(local_table, client)

    top = store.top(TRACK, 10)
    assert len(top) == 10
    assert scanned == [10]  # one Query, ten items read of the board's 1,000

    everything = store.top(TRACK, BIG_BOARD)
    assert [e.rank_key for e in everything] == sorted(e.rank_key for e in everything)
    assert everything[:10] == top and len(everything) == BIG_BOARD

    scanned.clear()
    page = LeaderboardService(store).board_page(TRACK, limit=10, cursor=None)
    assert len(page.entries) == 10 and page.board.participants == BIG_BOARD
    assert sum(scanned) <= 11
    scanned.clear()
    following = LeaderboardService(store).board_page(TRACK, limit=10, cursor=page.next_cursor)
    assert [e.racer for e in following.entries] == [e.racer for e in everything[10:20]]
    assert sum(scanned) <= 11 + 1  # the page's ten, and the leader (for gaps) on a later page


# ---- limits under concurrent pushes -------------------------------------------------------------

LIMITED = "club-finals"


def race_pushes(services: list[LeaderboardService], records: list[Any], board_id: str) -> list[str]:
    """Push every record at once, one thread and one service each; what each push answered."""
    barrier = threading.Barrier(len(records))
    answers: list[str] = []

    def push(n: int) -> None:
        barrier.wait(timeout=30)
        try:
            answers.append(services[n].push(records[n], board_id).status)
        except (TooSoon, SubmissionLimitReached) as refused:
            answers.append(type(refused).__name__)

    threads = [threading.Thread(target=push, args=(n,)) for n in range(len(records))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    return answers


@pytest.mark.parametrize(("settings", "allowed", "refusal"), [
    ({"max_submissions": 3}, 3, "SubmissionLimitReached"),
    ({"cooldown_s": 1800}, 1, "TooSoon"),
])
def test_limits_hold_under_concurrent_pushes(dynamodb_local: DynamoDbLocal, local_table: str,
                                             settings: dict[str, int], allowed: int,
                                             refusal: str) -> None:
    services = [LeaderboardService(DynamoDbStore(local_table, dynamodb_local.client()))
                for _ in range(10)]
    services[0].create_board(BoardSpec.model_validate(
        {"board_id": LIMITED, "title": "Finals", "track": TRACK} | settings))
    records = [make_record(SHARED, [(20_000 - n * 10, 100)], model=f"m{n}") for n in range(10)]
    answers = race_pushes(services, records, LIMITED)
    assert sorted(answers) == sorted(["created"] * allowed + [refusal] * (10 - allowed))
    history = services[0].history(SHARED, LIMITED)
    assert len(history) == allowed
    assert services[0].status(SHARED, LIMITED).boards[0].submissions == allowed


# ---- ranks from the counters ------------------------------------------------------------------


def ranks_of(store: DynamoDbStore, board_id: str = TRACK) -> dict[str, int]:
    return {e.racer: store.count_better(board_id, e.score_key) + 1 for e in store.top(board_id, 5000)}


def listed_ranks(store: DynamoDbStore, board_id: str = TRACK) -> dict[str, int]:
    entries = store.top(board_id, 5000)
    return {e.racer: 1 + sum(o.score_key < e.score_key for o in entries) for e in entries}


class ReadCounter:
    """What a client's calls read: Query items, and items got one by one or together."""

    def __init__(self, client: Any) -> None:
        self.queried = self.got = 0
        client.meta.events.register("after-call.dynamodb.Query", self._query)
        client.meta.events.register("after-call.dynamodb.GetItem", self._get)
        client.meta.events.register("after-call.dynamodb.TransactGetItems", self._transact_get)

    def _query(self, parsed: dict[str, Any], **_: Any) -> None:
        self.queried += int(parsed.get("ScannedCount", 0))

    def _get(self, parsed: dict[str, Any], **_: Any) -> None:
        self.got += 1

    def _transact_get(self, parsed: dict[str, Any], **_: Any) -> None:
        self.got += len(parsed.get("Responses", []))

    def clear(self) -> None:
        self.queried = self.got = 0


def test_a_board_from_before_the_counters_ranks_exactly_and_gets_them_on_its_next_push() -> None:
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        table = new_table(client)
        seed_board(client, table, 200)  # entries written directly: no counters
        store = DynamoDbStore(table, client)
        reads = ReadCounter(client)
        assert ranks_of(store) == listed_ranks(store)  # counted from the entries meanwhile
        assert "rank_generation" not in client.get_item(
            TableName=table, Key={"board": {"S": TRACK}, "sk": {"S": "#BOARD"}})["Item"]

        LeaderboardService(store).push(make_record("Newcomer", [(19_000, 100)]))
        assert "rank_generation" in client.get_item(
            TableName=table, Key={"board": {"S": TRACK}, "sk": {"S": "#BOARD"}})["Item"]
        assert ranks_of(store) == listed_ranks(store)
        middle = store.get_entry(TRACK, "newcomer")
        assert middle is not None
        expected = listed_ranks(store)["Newcomer"] - 1
        reads.clear()
        assert store.count_better(TRACK, middle.score_key) == expected
        assert (reads.queried, reads.got) == (0, 3)  # three counters, no entry


def test_a_push_in_the_middle_of_a_build_batch_is_counted_once(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(push_transaction, "LAZY_BUILD_MAX_RACERS", 0)  # the push below builds nothing
    with mock_aws():
        client, builder_client = (boto3.client("dynamodb", region_name=REGION) for _ in range(2))
        table = new_table(client)
        seed_board(client, table, 50)
        builder, pusher = DynamoDbStore(table, builder_client), DynamoDbStore(table, client)
        scans = []
        real_query = builder_client.query

        def push_during_the_first_batch(**request: Any) -> Any:
            page = real_query(**request)
            if request.get("IndexName") == "by_rank" and not scans:
                scans.append(request)  # read, not yet counted: now an entry comes
                LeaderboardService(pusher).push(make_record("Sneaky", [(9_000, 100)]))
            return page

        monkeypatch.setattr(builder_client, "query", push_during_the_first_batch)
        assert builder.build_rank_counters(TRACK).done and scans
        # the push during the first batch is in the counters the board took: the racers it
        # passed rank one lower
        ranks = ranks_of(DynamoDbStore(table, client))
        assert "Sneaky" in ranks and max(ranks.values()) == 51
        assert ranks == listed_ranks(builder)


def test_a_build_that_stops_goes_on_where_it_stopped_and_writes_meanwhile_keep_it_exact(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(push_transaction, "LAZY_BUILD_MAX_RACERS", 0)
    with mock_aws():
        client, builder_client = (boto3.client("dynamodb", region_name=REGION) for _ in range(2))
        table = new_table(client)
        seed_board(client, table, 400)
        builder = DynamoDbStore(table, builder_client)
        store = DynamoDbStore(table, client)
        service = LeaderboardService(store)
        batches = []
        real_transact = builder_client.transact_write_items

        def lost_connection_after_three_batches(**request: Any) -> Any:
            if len(batches) == 3:
                raise EndpointConnectionError(endpoint_url="https://dynamodb.eu-west-1.amazonaws.com")
            batches.append(request)
            return real_transact(**request)

        monkeypatch.setattr(builder_client, "transact_write_items", lost_connection_after_three_batches)
        with pytest.raises(StoreUnavailable):
            builder.build_rank_counters(TRACK)
        monkeypatch.setattr(builder_client, "transact_write_items", real_transact)
        progress = builder.build_rank_counters(TRACK, budget_s=0)  # one batch more
        assert not progress.done and 0 < progress.counted < progress.participants == 400
        # Meanwhile racers push: counted ones improve, new ones come in ahead of and behind the
        # entries counted so far, and an organiser takes one of the counted entries off.
        first = store.top(TRACK, 3)
        service.push(make_record(first[2].racer, [(5_000, 100)], model="faster"))
        service.push(make_record("Newcomer", [(30_000, 100)]))
        service.push(make_record("Flyer", [(4_000, 100)]))
        assert store.remove_entry(TRACK, first[1].racer_key) is not None
        finished = builder.build_rank_counters(TRACK)
        assert finished.done and finished.participants == 401
        ranks = ranks_of(DynamoDbStore(table, client))
        assert ranks == listed_ranks(builder) and len(ranks) == 401
        assert ranks["Flyer"] == 1 and ranks[first[2].racer] == 2


def test_ranks_stay_exact_under_concurrent_pushes(dynamodb_local: DynamoDbLocal,
                                                  local_table: str) -> None:
    racers = 16
    rng = random.Random(5)
    # Each racer pushes three runs, in the same few buckets as the others, some improving.
    records = [[make_record(f"Racer {n:02d}", [(rng.choice([11_000, 11_004, 11_009, 11_500, 12_000])
                                                  - attempt * rng.choice([0, 3, 500]), 100)],
                            model=f"m{attempt}") for attempt in range(3)] for n in range(racers)]
    services = [LeaderboardService(DynamoDbStore(local_table, dynamodb_local.client()))
                for _ in range(racers)]
    barrier = threading.Barrier(racers)
    errors: list[BaseException] = []

    def push(n: int) -> None:
        try:
            barrier.wait(timeout=30)
            for record in records[n]:
                services[n].push(record)
        except BaseException as error:
            errors.append(error)

    threads = [threading.Thread(target=push, args=(n,)) for n in range(racers)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=180)
    assert errors == []
    store = DynamoDbStore(local_table, dynamodb_local.client())
    ranks = ranks_of(store)
    assert len(ranks) == racers
    assert ranks == listed_ranks(store)
    page = services[0].board_page(TRACK, limit=100)
    assert {e.racer: e.rank for e in page.entries} == ranks


def test_a_rank_on_a_big_board_reads_three_counters(dynamodb_local: DynamoDbLocal,
                                                     local_table: str) -> None:
    client = dynamodb_local.client()
    seed_board(client, local_table, BIG_BOARD)
    store = DynamoDbStore(local_table, client)
    assert store.build_rank_counters(TRACK).done
    reads = ReadCounter(client)
    everything = store.top(TRACK, BIG_BOARD)
    for entry in everything[::97]:
        reads.clear()
        better = store.count_better(TRACK, entry.score_key)
        assert better == sum(other.score_key < entry.score_key for other in everything)
        assert (reads.queried, reads.got) == (0, 3)


def test_a_push_leaves_a_big_board_from_before_the_counters_to_an_explicit_build(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(push_transaction, "LAZY_BUILD_MAX_RACERS", 100)
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        table = new_table(client)
        seed_board(client, table, 150)
        store = DynamoDbStore(table, client)
        receipt = LeaderboardService(store).push(make_record("Newcomer", [(19_000, 100)]))
        assert receipt.rank == listed_ranks(store)["Newcomer"]  # counted from the entries
        assert ranks_of(store) == listed_ranks(store)
        assert not store.build_rank_counters(TRACK, budget_s=0).done  # the push built none
        assert store.build_rank_counters(TRACK).done
        LeaderboardService(store).push(make_record("Latecomer", [(8_500, 100)]))
        assert ranks_of(store) == listed_ranks(store)


# ---- integrity on the real engine: what moto may let pass -----------------------------------------


def local_service(dynamodb_local: DynamoDbLocal, table: str) -> LeaderboardService:
    return LeaderboardService(DynamoDbStore(table, dynamodb_local.client()))


def test_a_push_of_fifty_runs_fits_its_transaction_and_indexes_every_run(
        dynamodb_local: DynamoDbLocal, local_table: str) -> None:
    """Each run's fingerprint is claimed in the push's transaction; the runs' index for every
    board is written once it commits (fifty runs' items would not fit in one)."""
    service = local_service(dynamodb_local, local_table)
    runs = [[(9000 + 10 * n, 100), (9100 + 10 * n, 100), (9200 + 10 * n, 100)] for n in range(50)]
    receipt = service.push(make_record("Ada", runs=runs))
    assert receipt.status == "created"
    copy = make_record("Bob", runs=[runs[49]])
    with pytest.raises(CopiedRun, match="'ada'"):
        service.push(copy, caller=Caller(principal="cognito:bob"))


def test_a_ban_landing_between_a_push_and_its_write_stops_it_on_dynamodb_local(
        dynamodb_local: DynamoDbLocal, local_table: str) -> None:
    store = DynamoDbStore(local_table, dynamodb_local.client())
    organiser = LeaderboardService(store)
    mallory = Caller(principal="join:mallory")
    organiser.push(make_record("Mallory", [(9500, 100)]), caller=mallory)
    write = store.record_submission

    def banned_meanwhile(*args: Any, **kwargs: Any) -> Any:
        store.record_submission = write  # type: ignore[method-assign]
        organiser.ban(TRACK, "Mallory", everywhere=False)
        return write(*args, **kwargs)

    store.record_submission = banned_meanwhile  # type: ignore[method-assign]
    with pytest.raises(Banned):
        organiser.push(make_record("Mallory", [(8000, 100)], model="faster"), caller=mallory)
    assert organiser.board_page(TRACK).entries == []


def test_aliases_and_lookalikes_on_dynamodb_local(dynamodb_local: DynamoDbLocal, local_table: str) -> None:
    service = local_service(dynamodb_local, local_table)
    ace = Caller(principal="cognito:ace")
    service.push(make_record("ACE", [(9000, 100)]), caller=ace)
    with pytest.raises(AliasTaken, match="could pass for"):
        service.push(make_record("\u0410\u0421\u0415", [(9100, 100)]), caller=Caller(principal="join:x"))
    assert service.me(Caller(principal="join:x")).alias is None
    service.assign_alias("Blaze")
    service.assign_alias("Blaze", "cognito:blaze")
    assert [(a.alias, a.principal) for a in service.aliases().aliases] == [
        ("ACE", "cognito:ace"), ("Blaze", "cognito:blaze")]
    service.release_alias("blaze")
    assert service.me(Caller(principal="cognito:blaze")).alias is None


def test_the_rebuild_ranks_command_builds_a_big_board_a_step_at_a_time(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(organisers, "LOCAL_REBUILD_STEP_S", 0)  # a step per call: many calls
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        table = new_table(client)
        seed_board(client, table, 300)
        store = DynamoDbStore(table, client)
        steps = []
        service = LeaderboardService(store)
        rebuild = service.rebuild_ranks

        def counted_step(board_id: str, budget_s: float | None = None) -> Any:
            steps.append(budget_s)
            return rebuild(board_id, budget_s)

        monkeypatch.setattr(service, "rebuild_ranks", counted_step)
        result = CliRunner().invoke(cli, ["--db", str(tmp_path / "unused.db"), "board",
                                          "rebuild-ranks", TRACK], obj=lambda db: service)
        assert result.exit_code == 0, result.output
        assert f"{TRACK}: rank counters built (300 racers)" in result.stdout
        assert len(steps) > 3
        assert ranks_of(store) == listed_ranks(store)
        before = len(steps)
        again = CliRunner().invoke(cli, ["--db", str(tmp_path / "unused.db"), "board",
                                         "rebuild-ranks", TRACK], obj=lambda db: service)
        assert again.exit_code == 0 and len(steps) == before + 1  # done at once


def test_a_board_no_season_took_in_says_so_until_one_does(dynamodb_local: DynamoDbLocal,
                                                          local_table: str) -> None:
    """A new board's item tells pushes that no season took it in, so they look for no final;
    the first season to take it in removes that for good."""
    store = DynamoDbStore(local_table, dynamodb_local.client())
    store.create_board(named_board("jan"))
    fresh = store.push_reads("jan", "ada", "0" * 64, [], 5).board
    assert fresh is not None and not fresh.maybe_in_a_season
    store.save_season(season(rounds=("jan",)), {"jan": link()})
    store.save_season(season(version=2), {"jan": None})
    stored = store.get_board("jan")
    assert stored is not None and stored.maybe_in_a_season
