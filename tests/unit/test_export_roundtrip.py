"""An export imported into a new board shows what the exported board showed: its standings and
every racer's history with its flags, for boards of many rules and pushes (copies and near-copies
pushed by the organiser, off-track laps, racers pushing again), in bulk on the embedded board and
one submission at a time on SQLite and DynamoDB; and a recheck of those boards finds nothing
more to flag. An export and a recheck list submissions by id, not in the order they were pushed:
neither may read that order as the pushes' order."""

from __future__ import annotations

import io
import random
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import boto3
import pytest
from drboard_assembler.record import Record
from drboard_cli import transfer
from drboard_functions.errors import DomainError
from drboard_functions.models.requests import BoardSpec
from drboard_functions.service import LeaderboardService, racer_key
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.s3_archive import S3Archive
from drboard_functions.stores.sqlite import SqliteStore
from moto import mock_aws

from tests.awskit import REGION
from tests.recordkit import copy_of, make_record
from tests.tablekit import create_board_table

BOARD = "finals"
RACERS = [f"Racer {n}" for n in range(12)]
PUSHES = 40


class Clock:
    def __init__(self) -> None:
        self.now = datetime(2026, 5, 1, 12, tzinfo=UTC)

    def __call__(self) -> datetime:
        return self.now


def pushed_board(service: LeaderboardService, clock: Clock, rng: random.Random) -> None:
    """A board of random rules, and PUSHES random pushes to it a few minutes apart."""
    service.create_board(BoardSpec(
        board_id=BOARD, title="Finals", track="reInvent2019",
        method=rng.choice(["BEST_LAP_TIME", "AVG_LAP_TIME", "TOTAL_TIME"]),
        min_laps=rng.choice([1, 2, 3]), flagged_runs=rng.choice(["rank", "unranked"])))
    stored: list[Record] = []
    for n in range(PUSHES):
        clock.now += timedelta(seconds=rng.randint(1, 600))
        racer, kind = rng.choice(RACERS), rng.random()
        if kind < 0.15 and stored:
            record = copy_of(rng.choice(stored), racer)
        elif kind < 0.3 and stored:  # the same laps, each a few milliseconds off
            laps = [(lap.time_ms + rng.randint(-4, 4), 100) for lap in rng.choice(stored).evaluations[0].laps]
            record = make_record(racer, laps, model=f"near-{n}")
        else:
            laps = [(rng.randint(9000, 9300), rng.choice([100, 100, 100, 60]))
                    for _ in range(rng.randint(1, 4))]
            record = make_record(racer, laps, model=f"own-{n}")
        try:
            service.push(record, BOARD)
        except DomainError:  # refused (too soon, a copy of the racer's own run): not on the board
            continue
        stored.append(record)


def shown(service: LeaderboardService) -> dict[str, Any]:
    """The board's standings and every racer's history on it, as the board shows them."""
    page = service.board_page(BOARD).model_dump()
    del page["board"]["version"]  # each board counts its own changes
    histories = {racer: [item.model_dump() for item in service.history(racer, BOARD)]
                 for racer in RACERS if service.store.tally(BOARD, racer_key(racer)).submissions}
    return {"page": page, "histories": histories}


def exported(seed: int, tmp_path: Path) -> tuple[bytes, dict[str, Any]]:
    clock = Clock()
    service = LeaderboardService(SqliteStore(tmp_path / "exported.db"), clock=clock)
    pushed_board(service, clock, random.Random(seed))
    out = io.BytesIO()
    transfer.write_export(service, BOARD, out)
    return out.getvalue(), shown(service)


@pytest.mark.parametrize("seed", range(20))
def test_an_export_imported_in_bulk_shows_what_its_board_showed(seed: int, tmp_path: Path) -> None:
    export, expected = exported(seed, tmp_path)
    service = LeaderboardService(SqliteStore(tmp_path / "imported.db"), clock=Clock())
    transfer.load_export(service, "export.jsonl", io.BytesIO(export), None)
    assert shown(service) == expected


def one_at_a_time(service: LeaderboardService, export: bytes) -> None:
    """The import `drboard import` makes into a board over HTTP: every line checked, then one
    submission a request."""
    contents = transfer.check_export("export.jsonl", io.BytesIO(export))
    transfer.import_export(service, "export.jsonl", io.BytesIO(export), contents, None)


@pytest.mark.parametrize("seed", range(20))
def test_an_export_imported_one_submission_at_a_time_shows_what_its_board_showed(
        seed: int, tmp_path: Path) -> None:
    export, expected = exported(seed, tmp_path)
    service = LeaderboardService(SqliteStore(tmp_path / "imported.db"), clock=Clock())
    one_at_a_time(service, export)
    assert shown(service) == expected


@pytest.mark.parametrize("seed", range(2))
def test_an_export_imported_into_dynamodb_shows_what_its_board_showed(seed: int, tmp_path: Path) -> None:
    export, expected = exported(seed, tmp_path)
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        service = LeaderboardService(DynamoDbStore(create_board_table(client, "boards"), client),
                                     clock=Clock())
        one_at_a_time(service, export)
        assert shown(service) == expected


def test_an_import_archives_each_record_as_the_board_keeps_it(tmp_path: Path) -> None:
    """A record kept by a board of an earlier version (without the fields later assemblers
    write, null when empty) is imported as its line holds it, and archived the same: the
    archive holds the bytes the board keeps, not the record written out again."""
    source = LeaderboardService(SqliteStore(tmp_path / "exported.db"), clock=Clock())
    record = make_record("Ada", [(9000, 100), (9100, 100), (9200, 100)])
    source.push(record)
    out = io.BytesIO()
    transfer.write_export(source, record.track, out)
    earlier = out.getvalue().replace(b',"conditions":null', b"")
    assert earlier != out.getvalue()
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        s3 = boto3.client("s3", region_name=REGION)
        s3.create_bucket(Bucket="archive", CreateBucketConfiguration={"LocationConstraint": REGION})
        store = DynamoDbStore(create_board_table(client, "boards"), client)
        service = LeaderboardService(store, clock=Clock(), archive=S3Archive("archive", client=s3))
        transfer.load_export(service, "export.jsonl", io.BytesIO(earlier), None)
        [(_, kept)] = store.exported_submissions(record.track)
        archived = s3.get_object(Bucket="archive", Key=S3Archive.key(record.track, record.submission_id))
        assert b'"conditions"' not in kept
        assert archived["Body"].read() == kept


@pytest.mark.parametrize("seed", range(20))
def test_a_recheck_of_a_board_its_pushes_checked_flags_nothing_new(seed: int, tmp_path: Path) -> None:
    """Every run of these boards was checked for copies when it was pushed: a recheck, which
    reads them by id, finds nothing more to flag (the first of two near runs included)."""
    clock = Clock()
    service = LeaderboardService(SqliteStore(tmp_path / "board.db"), clock=clock)
    pushed_board(service, clock, random.Random(seed))
    before = shown(service)
    page = service.recheck_page(BOARD)
    flagged = list(page.flagged)
    while page.next_cursor is not None:
        page = service.recheck_page(BOARD, page.next_cursor)
        flagged += page.flagged
    assert flagged == []
    assert shown(service) == before
