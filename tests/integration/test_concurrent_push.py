"""Separate processes pushing to one SQLite board at once lose no submission and no best result.

Each worker is its own OS process (multiprocessing, "spawn"), with its own SqliteStore on the
same file, as several `drboard push` commands or server workers would be. They start together
behind a barrier. The file is created first: opening a brand-new file from several processes at
once is covered (as a known bug) by tests/unit/test_sqlite_store.py.
"""

from __future__ import annotations

import multiprocessing
from pathlib import Path
from typing import Any

from drboard_functions.errors import SubmissionLimitReached
from drboard_functions.models.requests import BoardSpec
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record

WORKERS = 4
PUSHES = 25
TRACK = "reInvent2019_track"
SHARED = "Shared Racer"


def own_racer(worker: int, n: int) -> str:
    return f"W{worker} R{n:02d}"


def shared_time(worker: int, n: int) -> int:
    # Every worker keeps improving, interleaved with the others: the best is the last of worker 3.
    return 30_000 - n * 400 - worker * 7


def push_many(path: str, worker: int, barrier: Any) -> None:
    barrier.wait(timeout=30)
    service = LeaderboardService(SqliteStore(path))
    for n in range(PUSHES):
        mine = service.push(make_record(own_racer(worker, n), [(12_000 + worker * 100 + n, 100)]))
        assert mine.status == "created" and mine.improved
        shared = service.push(make_record(SHARED, [(shared_time(worker, n), 100)], model=f"w{worker}"))
        assert shared.status == "created"


def test_concurrent_pushes_lose_nothing(tmp_path: Path) -> None:
    path = tmp_path / "boards" / "board.db"
    SqliteStore(path).close()
    context = multiprocessing.get_context("spawn")
    barrier = context.Barrier(WORKERS)
    workers = [context.Process(target=push_many, args=(str(path), w, barrier)) for w in range(WORKERS)]
    for process in workers:
        process.start()
    for process in workers:
        process.join(timeout=60)
    assert [p.exitcode for p in workers] == [0] * WORKERS

    store = SqliteStore(path)
    try:
        service = LeaderboardService(store)
        board = store.get_board(TRACK)
        assert board is not None
        assert board.participants == WORKERS * PUSHES + 1

        expected_shared = {make_record(SHARED, [(shared_time(w, n), 100)], model=f"w{w}").submission_id
                           for w in range(WORKERS) for n in range(PUSHES)}
        shared_history = service.history(SHARED, TRACK)
        assert {h.submission_id for h in shared_history} == expected_shared
        assert len(shared_history) == WORKERS * PUSHES

        best_time = min(shared_time(w, n) for w in range(WORKERS) for n in range(PUSHES))
        best = make_record(SHARED, [(best_time, 100)], model=f"w{WORKERS - 1}")
        view = service.racer(TRACK, SHARED)
        assert view.entry.time_ms == best_time
        assert view.entry.submission_id == best.submission_id
        assert [h.submission_id for h in shared_history if h.is_best] == [best.submission_id]

        for w in range(WORKERS):
            for n in range(PUSHES):
                history = service.history(own_racer(w, n))
                assert [h.time_ms for h in history] == [12_000 + w * 100 + n]
                assert history[0].is_best

        entries = service.board_page(TRACK, limit=500).entries
        assert len(entries) == WORKERS * PUSHES + 1
        assert len({e.racer for e in entries}) == len(entries)
        assert [e.rank for e in entries] == list(range(1, len(entries) + 1))  # all times differ
        # the rank counts, moved by every process's pushes, agree with the listing
        assert [store.count_better(TRACK, e.score_key) + 1 for e in store.top(TRACK, 500)] == \
            [e.rank for e in entries]
    finally:
        store.close()


# ---- limits hold across processes -----------------------------------------------------------------

LIMITED = "club-finals"


def push_limited(path: str, worker: int, barrier: Any, answers: Any) -> None:
    service = LeaderboardService(SqliteStore(path))
    record = make_record(SHARED, [(20_000 - worker * 10, 100)], model=f"w{worker}")
    barrier.wait(timeout=30)
    try:
        answers.put(service.push(record, LIMITED).status)
    except SubmissionLimitReached:
        answers.put("refused")


def test_the_maximum_of_submissions_holds_across_processes(tmp_path: Path) -> None:
    path = tmp_path / "board.db"
    store = SqliteStore(path)
    LeaderboardService(store).create_board(BoardSpec(
        board_id=LIMITED, title="Finals", track=TRACK, max_submissions=2))
    context = multiprocessing.get_context("spawn")
    barrier, answers = context.Barrier(WORKERS), context.Queue()
    workers = [context.Process(target=push_limited, args=(str(path), w, barrier, answers))
               for w in range(WORKERS)]
    for process in workers:
        process.start()
    for process in workers:
        process.join(timeout=60)
    assert [p.exitcode for p in workers] == [0] * WORKERS
    got = sorted(answers.get(timeout=5) for _ in range(WORKERS))
    assert got == sorted(["created"] * 2 + ["refused"] * (WORKERS - 2))
    assert len(LeaderboardService(store).history(SHARED, LIMITED)) == 2
    store.close()
