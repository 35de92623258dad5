"""An import into the embedded board is one transaction: its batches are written while its lines
are checked, and nothing of it is kept unless every line is checked and every batch written. A
bad line after many written batches, an error while writing, or the process dying half-way
leaves the board file as it was; the store's held writes commit together or not at all."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
import textwrap
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import boto3
import pytest
from drboard_assembler.aliases import confusable_skeleton
from drboard_cli import transfer
from drboard_functions.models.requests import ImportedSubmission
from drboard_functions.service import LeaderboardService, scored_write
from drboard_functions.service.loading import BulkImport
from drboard_functions.stores.base import LookalikeTaken
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.sqlite import SqliteStore
from moto import mock_aws

from tests.awskit import REGION
from tests.importkit import imported
from tests.recordkit import make_record
from tests.tablekit import create_board_table

TRACK_BOARD = "reInvent2019_track"
RACERS = 30


@pytest.fixture
def exported(tmp_path: Path) -> Path:
    """An export of a board of RACERS racers."""
    store = SqliteStore(tmp_path / "source.db")
    service = LeaderboardService(store)
    start = datetime(2026, 3, 1, tzinfo=UTC)
    for n in range(RACERS):
        record = make_record(f"Racer{n:02d}", [(9000 + 37 * n, 100), (9100 + 41 * n, 100),
                                               (9200 + 13 * n, 100)])
        if n == 0:
            service.push(record)
        else:
            service.import_submission(TRACK_BOARD, ImportedSubmission(
                submitted_at=start + timedelta(minutes=n), record=record))
    path = tmp_path / "export.jsonl"
    with path.open("wb") as out:
        for _, line in service.export_lines(TRACK_BOARD):
            out.write(line)
    store.close()
    return path


@pytest.fixture
def small_batches(monkeypatch: pytest.MonkeyPatch) -> None:
    """Batches of 4 submissions, chunks of a line or two: many batches written before the end."""
    monkeypatch.setattr(transfer, "IMPORT_BATCH", 4)
    monkeypatch.setattr(transfer, "CHUNK_BYTES", 5_000)


def rows(path: Path) -> dict[str, list[tuple[Any, ...]]]:
    with sqlite3.connect(path) as db:
        tables = [name for (name,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
        return {table: sorted(db.execute(f"SELECT * FROM {table}")) for table in tables}


def board_with_a_racer(path: Path) -> dict[str, list[tuple[Any, ...]]]:
    """A board file holding the track's board with one racer of its own."""
    store = SqliteStore(path)
    LeaderboardService(store).push(make_record("Resident", [(9999, 100)]))
    store.close()
    return rows(path)


def spoiled(export: Path, number: int) -> None:
    """Line ``number`` of the export made a submission whose record was edited after export."""
    lines = export.read_bytes().splitlines(keepends=True)
    head, record = lines[number - 1].split(b'"record":', 1)
    lines[number - 1] = head + b'"record":' + record.replace(b'"model_name":"', b'"model_name":"edited-', 1)
    export.write_bytes(b"".join(lines))


@pytest.mark.usefixtures("small_batches")
@pytest.mark.parametrize("workers", [1, 2], ids=["here", "in workers"])
@pytest.mark.parametrize("existing", [False, True], ids=["new board", "board with a racer"])
def test_a_bad_last_line_after_written_batches_leaves_the_board_file_as_it_was(
        exported: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, workers: int,
        existing: bool) -> None:
    monkeypatch.setattr(transfer, "_workers", lambda size: workers)
    target = tmp_path / "target.db"
    if existing:
        before = board_with_a_racer(target)
    else:
        SqliteStore(target).close()
        before = rows(target)
    written: list[int] = []
    load = BulkImport.load

    def counted(self: BulkImport, batch: Any) -> Any:
        written.append(len(batch))
        return load(self, batch)

    monkeypatch.setattr(BulkImport, "load", counted)
    last = len(exported.read_bytes().splitlines())
    spoiled(exported, last)
    with pytest.raises(transfer.BadExportFile, match=rf"export\.jsonl:{last}: record\.submission_id"):
        imported(exported, target)
    assert sum(written) >= RACERS - 4 - 3, "the batches before the bad line were written"
    assert rows(target) == before


@pytest.mark.usefixtures("small_batches")
def test_an_error_while_writing_a_batch_leaves_nothing(exported: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "target.db"
    before = board_with_a_racer(target)
    load = BulkImport.load
    calls: list[int] = []

    def failing(self: BulkImport, batch: Any) -> Any:
        calls.append(1)
        if len(calls) == 3:
            raise OSError("disk full")
        return load(self, batch)

    monkeypatch.setattr(BulkImport, "load", failing)
    with pytest.raises(OSError, match="disk full"):
        imported(exported, target)
    assert rows(target) == before


#: Imports ``argv[1]`` into ``argv[2]`` and dies (no clean-up at all) once three batches are
#: written.
DYING_IMPORT = textwrap.dedent("""
    import os, sys
    from drboard_cli import transfer
    from drboard_functions.service.loading import BulkImport
    from drboard_functions.services import sqlite_service

    transfer.IMPORT_BATCH, transfer.CHUNK_BYTES = 4, 5_000
    load, written = BulkImport.load, []

    def dying(self, batch):
        tally = load(self, batch)
        written.append(batch)
        if len(written) == 3:
            os._exit(9)
        return tally

    BulkImport.load = dying
    with open(sys.argv[1], "rb") as handle:
        transfer.load_export(sqlite_service(sys.argv[2]), sys.argv[1], handle, None)
""")


def test_an_import_that_dies_half_way_leaves_nothing(exported: Path, tmp_path: Path) -> None:
    target = tmp_path / "target.db"
    before = board_with_a_racer(target)
    done = subprocess.run([sys.executable, "-c", DYING_IMPORT, str(exported), str(target)],
                          capture_output=True, check=False)
    assert done.returncode == 9, done.stderr.decode()
    assert rows(target) == before
    assert imported(exported, target).created == RACERS, "the next import finds the board free"


def boards_seen_by_another_connection(store: SqliteStore) -> int:
    with sqlite3.connect(store.path) as other:
        return int(other.execute("SELECT COUNT(*) FROM boards").fetchone()[0])


def test_held_writes_commit_together_or_not_at_all(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "board.db")
    service = LeaderboardService(store)
    with pytest.raises(RuntimeError), store.held_writes():
        service.push(make_record("Ada", [(9000, 100)]))
        assert store.get_board(TRACK_BOARD) is not None, "this thread sees its own writes"
        assert boards_seen_by_another_connection(store) == 0, "no other connection sees them"
        raise RuntimeError("a later line is bad")
    assert store.get_board(TRACK_BOARD) is None
    assert boards_seen_by_another_connection(store) == 0
    store.close()


def test_a_write_refused_inside_held_writes_undoes_only_itself(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "board.db")
    service = LeaderboardService(store)
    with store.held_writes():
        service.push(make_record("Ollie", [(9000, 100)]))
        board = store.get_board(TRACK_BOARD)
        assert board is not None
        lookalike = make_record("0llie", [(9500, 100)])
        submission, entry = scored_write(lookalike, board.board, datetime.now(UTC))
        with pytest.raises(LookalikeTaken):  # after its fingerprint is claimed
            store.record_submission(submission, lookalike.model_dump_json(), entry, fingerprints=["its-run"],
                                    skeleton=confusable_skeleton("0llie"))
        service.push(make_record("Bob", [(9700, 100)]))
    assert boards_seen_by_another_connection(store) == 1
    assert store.get_board(TRACK_BOARD).participants == 2  # type: ignore[union-attr]
    assert store.fingerprint_holder(TRACK_BOARD, "its-run") is None
    store.close()


@pytest.mark.usefixtures("small_batches")
def test_a_store_that_cannot_hold_an_import_has_every_line_checked_before_it_is_written(
        exported: Path, tmp_path: Path) -> None:
    """DynamoDB commits a batch at a time: nothing is written before the last line is read."""
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        service = LeaderboardService(DynamoDbStore(create_board_table(client, "boards"), client))
        last = len(exported.read_bytes().splitlines())
        good = exported.read_bytes()
        spoiled(exported, last)
        with exported.open("rb") as handle, pytest.raises(transfer.BadExportFile,
                                                          match=rf"export\.jsonl:{last}: "):
            transfer.load_export(service, str(exported), handle, None)
        assert service.boards() == []
        exported.write_bytes(good)
        with exported.open("rb") as handle:
            summary = transfer.load_export(service, str(exported), handle, None)
        assert (summary.created, summary.board.participants) == (RACERS, RACERS)
