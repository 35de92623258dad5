"""A big export's lines are checked in worker processes, one per core: the board it gives is the
one checking them in this process gives, row for row; a bad line is still the one named, and
nothing is written."""

from __future__ import annotations

import gc
import json
import os
import sqlite3
import threading
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from drboard_cli import transfer
from drboard_functions.models.requests import ImportedSubmission
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.importkit import imported
from tests.recordkit import copy_of, make_record

TRACK_BOARD = "reInvent2019_track"


@pytest.fixture
def exported(tmp_path: Path) -> Path:
    """An export of a board of 40 racers, with copies, a lookalike, a racer's better run, and an
    alias beyond ASCII (its line's characters are not its bytes) early in the file."""
    store = SqliteStore(tmp_path / "source.db")
    service = LeaderboardService(store)
    records = [make_record(f"Racer{n:02d}", [(9000 + 37 * n, 100), (9100 + 41 * n, 100),
                                             (9200 + 13 * n, 100)]) for n in range(40)]
    records += [copy_of(records[3], "Copycat"), make_record("Rac3r07", [(20000, 100)]),
                make_record("Racer05", [(8000, 100), (8100, 100)], model="better"),
                make_record("Aé-Zoë Ångström", [(12000, 100), (12100, 100), (12200, 100)])]
    service.push(records[0])
    for minute, record in enumerate(records[1:]):  # replayed, so copies are flagged, not refused
        service.import_submission(TRACK_BOARD, ImportedSubmission(
            submitted_at=datetime(2026, 3, 1, tzinfo=UTC) + timedelta(minutes=minute), record=record))
    path = tmp_path / "export.jsonl"
    with path.open("wb") as out:
        for _, line in service.export_lines(TRACK_BOARD):
            out.write(line)
    store.close()
    return path


def rows(path: Path) -> dict[str, list[tuple[Any, ...]]]:
    """Every row of every table; an audit event without its id and time (each import's own)."""
    with sqlite3.connect(path) as db:
        tables = [name for (name,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
        found = {table: sorted(db.execute(f"SELECT * FROM {table}")) for table in tables}
    found["audit"] = sorted((board, json.dumps({k: v for k, v in json.loads(event).items()
                                                if k not in ("event_id", "at")}, sort_keys=True))
                            for board, _, event in found["audit"])
    return found


@pytest.fixture
def in_workers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every file checked in workers, a few lines to a chunk (so that each worker gets some)."""
    monkeypatch.setattr(transfer, "PARALLEL_FROM_BYTES", 0)
    monkeypatch.setattr(transfer, "CHUNK_BYTES", 10_000)
    monkeypatch.setattr(transfer, "_workers", lambda size: 2)


@pytest.mark.parametrize("progress_bar", [False, True],
                         ids=["alone (fork)", "beside a progress bar's thread (spawn)"])
def test_lines_checked_in_workers_give_the_board_checking_them_here_gives(
        exported: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, progress_bar: bool) -> None:
    here = imported(exported, tmp_path / "here.db")
    done = threading.Event()
    other = threading.Thread(target=done.wait)
    if progress_bar:
        other.start()
    try:
        with monkeypatch.context() as patch:
            patch.setattr(transfer, "CHUNK_BYTES", 10_000)
            patch.setattr(transfer, "_workers", lambda size: 2)
            in_workers = imported(exported, tmp_path / "workers.db")
    finally:
        done.set()
    assert (in_workers.created, in_workers.duplicates) == (here.created, here.duplicates) == (44, 0)
    assert in_workers.board.participants == 43
    assert rows(tmp_path / "workers.db") == rows(tmp_path / "here.db")


@pytest.mark.usefixtures("in_workers")
@pytest.mark.parametrize(("good", "bad", "says"), [
    (b'"time_ms":', b'"time_ms":-', r"record\.evaluations\[0\]\.laps\[0\]\.time_ms: "),
    (b'"model_name":"', b'"model_name":"tampered-', r"record\.submission_id: does not match"),
], ids=["out of bounds", "tampered"])
def test_a_bad_line_checked_in_a_worker_is_named_and_nothing_is_written(
        exported: Path, tmp_path: Path, good: bytes, bad: bytes, says: str) -> None:
    lines = exported.read_bytes().splitlines(keepends=True)
    number = len(lines) - 3  # a submission line in a chunk after many good ones
    head, record = lines[number - 1].split(b'"record":', 1)
    assert good in record
    lines[number - 1] = head + b'"record":' + record.replace(good, bad, 1)
    exported.write_bytes(b"".join(lines))
    with pytest.raises(transfer.BadExportFile, match=rf"export\.jsonl:{number}: {says}"):
        imported(exported, tmp_path / "target.db")
    assert rows(tmp_path / "target.db")["submissions"] == []
    assert rows(tmp_path / "target.db")["boards"] == []


@pytest.mark.usefixtures("in_workers")
@pytest.mark.parametrize("chunk_bytes", [10_000, 1_000],
                         ids=["its end in a chunk (a worker finds it)",
                              "no end within the bound (found as the file is read)"])
def test_a_bad_line_before_one_over_the_bound_is_the_one_named(
        exported: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, chunk_bytes: int) -> None:
    """The workers are given lines far ahead of the one checked: a line too long to read among
    them waits its turn."""
    monkeypatch.setattr(transfer, "CHUNK_BYTES", chunk_bytes)
    lines = exported.read_bytes().splitlines(keepends=True)
    bad, long = len(lines) - 30, len(lines) - 3
    head, record = lines[bad - 1].split(b'"record":', 1)
    lines[bad - 1] = head + b'"record":' + record.replace(b'"time_ms":', b'"time_ms":-', 1)
    lines[long - 1] = lines[long - 1].rstrip() + b" " * 5000 + b"\n"
    exported.write_bytes(b"".join(lines))
    monkeypatch.setattr(transfer, "MAX_LINE_BYTES", 4000)
    with pytest.raises(transfer.BadExportFile, match=rf"export\.jsonl:{bad}: record\.evaluations"):
        imported(exported, tmp_path / "target.db")
    lines[bad - 1] = head + b'"record":' + record
    exported.write_bytes(b"".join(lines))
    with pytest.raises(transfer.BadExportFile, match=rf"export\.jsonl:{long}: the line is over"):
        imported(exported, tmp_path / "target.db")
    assert rows(tmp_path / "target.db")["submissions"] == []


@pytest.mark.usefixtures("in_workers")
@pytest.mark.skipif(not hasattr(os, "nice"), reason="no process priorities to set here")
def test_the_workers_checking_lines_run_behind_the_process_writing_the_board(
        exported: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The workers take the CPU left by the import's own process, whose writes cannot be split,
    and by whatever else the computer runs (a `drboard serve` answering racers)."""
    noted = tmp_path / "niceness"
    noted.mkdir()
    checked = transfer._checked_chunk

    def noting_niceness(*args: Any, **kwargs: Any) -> Any:
        (noted / str(os.getpid())).write_text(str(os.nice(0)))
        return checked(*args, **kwargs)

    monkeypatch.setattr(transfer, "_checked_chunk", noting_niceness)  # (forked workers have it)
    own = os.nice(0)
    assert imported(exported, tmp_path / "target.db").created == 44
    workers = {int(path.name): int(path.read_text()) for path in noted.iterdir()}
    assert workers and os.getpid() not in workers
    assert set(workers.values()) == {min(own + transfer.WORKER_NICENESS, 19)}
    assert os.nice(0) == own


@pytest.mark.parametrize("enabled", [True, False], ids=["collector on", "collector off"])
def test_an_import_leaves_the_cycle_collector_as_it_found_it(
        exported: Path, tmp_path: Path, enabled: bool) -> None:
    """The collector is paused while an import runs: a process that lives on after it (a
    server, a notebook) gets it back as it was."""
    was = gc.isenabled()
    (gc.enable if enabled else gc.disable)()
    try:
        assert imported(exported, tmp_path / "target.db").created == 44
        assert gc.isenabled() is enabled
    finally:
        (gc.enable if was else gc.disable)()
