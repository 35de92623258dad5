"""The SQLite store: the BoardStore contract, plus what only the embedded file does."""

from __future__ import annotations

import sqlite3
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from drboard_functions.stores.sqlite import SqliteStore

from tests.contract.store_contract import TRACK, StoreContract, at, make_board, submit
from tests.recordkit import make_record


class TestSqliteContract(StoreContract):
    @pytest.fixture
    def store(self, tmp_path: Path) -> Iterator[SqliteStore]:
        store = SqliteStore(tmp_path / "board.db")
        yield store
        store.close()


def test_creates_the_file_in_a_folder_that_does_not_exist_yet(tmp_path: Path) -> None:
    path = tmp_path / "not" / "yet" / "there" / "board.db"
    store = SqliteStore(path)
    try:
        store.create_board(make_board())
        assert path.is_file()
    finally:
        store.close()


def test_data_persists_across_reopening_the_file(tmp_path: Path) -> None:
    path = tmp_path / "board.db"
    record = make_record("Ada", [(12000, 100)])
    first = SqliteStore(path)
    outcome = submit(first, record, at(1))
    first.close()

    again = SqliteStore(path)
    try:
        stored = again.get_board(TRACK)
        assert stored is not None and stored.participants == 1
        assert again.get_entry(TRACK, "ada") == outcome.entry
        assert again.get_record(TRACK, record.submission_id) == record
        assert [s.submission_id for s in again.history("ada")] == [record.submission_id]
        assert submit(again, record, at(2)).duplicate
    finally:
        again.close()


def test_wal_mode_is_on(tmp_path: Path) -> None:
    path = tmp_path / "board.db"
    SqliteStore(path).close()
    with sqlite3.connect(path) as db:
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_two_stores_on_one_file_see_each_others_writes(tmp_path: Path) -> None:
    path = tmp_path / "board.db"
    one, two = SqliteStore(path), SqliteStore(path)
    try:
        submit(one, make_record("Ada", [(12000, 100)]), at(1))
        submit(two, make_record("Bob", [(11000, 100)]), at(2))
        assert [e.racer for e in one.top(TRACK, 10)] == ["Bob", "Ada"]
        stored = two.get_board(TRACK)
        assert stored is not None and stored.participants == 2
    finally:
        one.close()
        two.close()


def _hold_a_write_transaction(path: Path, seconds: float) -> tuple[sqlite3.Connection, threading.Timer]:
    """Another connection (another `drboard push`) in the middle of a write on ``path``."""
    other = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    other.execute("BEGIN IMMEDIATE")
    other.execute("CREATE TABLE IF NOT EXISTS other_writer (x)")
    timer = threading.Timer(seconds, other.execute, ("COMMIT",))
    timer.start()
    return other, timer


def test_opening_waits_for_another_writer_on_an_existing_board(tmp_path: Path) -> None:
    path = tmp_path / "board.db"
    SqliteStore(path).close()
    other, timer = _hold_a_write_transaction(path, 0.3)
    try:
        store = SqliteStore(path)
        store.create_board(make_board())
        store.close()
    finally:
        timer.join()
        other.close()


def test_opening_a_new_file_waits_for_another_writer(tmp_path: Path) -> None:
    path = tmp_path / "board.db"
    other, timer = _hold_a_write_transaction(path, 0.3)
    try:
        store = SqliteStore(path)
        store.create_board(make_board())
        store.close()
    finally:
        timer.join()
        other.close()


def test_threads_of_one_process_write_in_turns_and_every_push_lands(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "board.db")
    store.create_board(make_board())
    racers = [f"Racer{n:02d}" for n in range(24)]

    def push(n: int) -> None:
        submit(store, make_record(racers[n], [(10000 + 37 * n, 100)]), at(n))

    threads = [threading.Thread(target=push, args=(n,)) for n in range(len(racers))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert [entry.racer for entry in store.top(TRACK, 50)] == racers
    stored = store.get_board(TRACK)
    assert stored is not None and stored.participants == len(racers)
    store.close()


def test_a_write_held_past_the_busy_timeout_in_this_process_is_store_busy(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from drboard_functions import errors
    from drboard_functions.stores import sqlite as sqlite_store

    monkeypatch.setattr(sqlite_store, "BUSY_TIMEOUT_S", 0.2)
    store = SqliteStore(tmp_path / "board.db")
    store.create_board(make_board())
    holding, done = threading.Event(), threading.Event()

    def hold() -> None:
        with store._write():
            holding.set()
            done.wait(5)

    holder = threading.Thread(target=hold)
    holder.start()
    holding.wait(5)
    try:
        with pytest.raises(errors.StoreBusy, match="busy with another writer"):
            submit(store, make_record("Ada", [(12000, 100)]), at(1))
    finally:
        done.set()
        holder.join()
    assert store.top(TRACK, 10) == []
    store.close()


def test_a_board_file_from_before_versions_opens_and_counts_from_zero(tmp_path: Path) -> None:
    path = tmp_path / "old.db"
    old = sqlite3.connect(path)
    old.execute("CREATE TABLE boards (board_id TEXT PRIMARY KEY, board TEXT NOT NULL, "
                "participants INTEGER NOT NULL DEFAULT 0)")
    old.execute("INSERT INTO boards VALUES (?, ?, 0)", (TRACK, make_board().model_dump_json()))
    old.commit()
    old.close()
    store = SqliteStore(path)
    stored = store.get_board(TRACK)
    assert stored is not None and stored.version == 0
    submit(store, make_record("Ada"), at(1))
    stored = store.get_board(TRACK)
    assert stored is not None and stored.version == 1 and stored.participants == 1


def test_a_board_file_from_before_the_rank_counts_gets_them_on_opening(tmp_path: Path) -> None:
    path = tmp_path / "old.db"
    store = SqliteStore(path)
    laps = {"Ada": 12_000, "Bob": 12_004, "Cy": 12_004, "Dee": 13_500, "Eve": 9_999}
    for n, (racer, ms) in enumerate(laps.items()):
        submit(store, make_record(racer, [(ms, 100)]), at(n))
    submit(store, make_record("Fay", [(9_000, 60)]), at(9))
    cw = make_board("reInvent2019_track_cw", direction="cw")
    submit(store, make_record("Gus", [(15_000, 100)], direction="cw"), at(10), cw)
    store.close()
    old = sqlite3.connect(path)  # as a file written before the counts existed
    old.execute("DROP TABLE rank_counts")
    old.commit()
    old.close()

    store = SqliteStore(path)
    try:
        ranks = {e.racer: store.count_better(TRACK, e.score_key) + 1 for e in store.top(TRACK, 10)}
        assert ranks == {"Eve": 1, "Ada": 2, "Bob": 3, "Cy": 3, "Dee": 5, "Fay": 6}
        gus = store.get_entry(cw.board_id, "gus")
        assert gus is not None and store.count_better(cw.board_id, gus.score_key) == 0
        submit(store, make_record("Hal", [(12_002, 100)]), at(11))
        hal = store.get_entry(TRACK, "hal")
        assert hal is not None and store.count_better(TRACK, hal.score_key) == 2
        assert store.count_better(TRACK, "1:10000") == 7
    finally:
        store.close()


def test_a_racer_who_improves_leaves_no_empty_rank_counts_behind(tmp_path: Path) -> None:
    """The counts an improved entry leaves are taken down, and those that reach zero go: the
    file keeps only counts that count someone."""
    path = tmp_path / "board.db"
    store = SqliteStore(path)
    try:
        submit(store, make_record("Ada", [(30_000, 100)]), at(1))
        submit(store, make_record("Bob", [(12_000, 100)]), at(2))
        submit(store, make_record("Ada", [(9_000, 100)]), at(3))  # from last place to first
        ada, bob = store.get_entry(TRACK, "ada"), store.get_entry(TRACK, "bob")
        assert ada is not None and bob is not None
        assert store.count_better(TRACK, ada.score_key) == 0
        assert store.count_better(TRACK, bob.score_key) == 1
        assert store.count_better(TRACK, "1:10000") == 2
    finally:
        store.close()
    with sqlite3.connect(path) as db:
        assert db.execute("SELECT COUNT(*) FROM rank_counts WHERE entries = 0").fetchone()[0] == 0
        assert db.execute("SELECT SUM(entries) FROM rank_counts WHERE node = ''").fetchone()[0] == 2
