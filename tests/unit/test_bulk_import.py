"""An import in bulk leaves the boards exactly as replaying the same submissions one by one does:
the standings, every racer's history with its flags, the claims of fingerprints and aliases,
the runs' index and the audit trail; across batches, into a new board or one with entries, on
SQLite and on DynamoDB (moto)."""

from __future__ import annotations

import random
from collections.abc import Iterator, Sequence
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import boto3
import pytest
from drboard_assembler.aliases import confusable_skeleton
from drboard_assembler.record import Record
from drboard_functions.errors import AliasTaken, BoardMismatch, InvalidSubmission, SubmissionTooLarge
from drboard_functions.identity import Caller
from drboard_functions.models.domain import Board, NearRun
from drboard_functions.models.requests import BoardSpec, ImportedSubmission
from drboard_functions.service import LeaderboardService, racer_key
from drboard_functions.service.copies import NEAR_MS, run_prints, same_laps
from drboard_functions.service.loading import ImportTally, _Lane
from drboard_functions.stores.base import BoardStore
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.sqlite import SqliteStore
from moto import mock_aws

from tests.awskit import REGION
from tests.recordkit import copy_of, make_record
from tests.tablekit import create_board_table

T0 = datetime(2026, 3, 1, 12, 0, tzinfo=UTC)
TRACK = "reInvent2019_track"
FINALS = "club-finals"
BOB = make_record("Bob", [(9100, 100), (9300, 100), (9500, 100)])
ADA_FAST = make_record("Ada", [(8800, 100), (8900, 100), (9000, 100)], model="fast")
VETERAN = make_record("Veteran", [(9700, 100), (9750, 100), (9800, 100)])


class Clock:
    def __init__(self) -> None:
        self.now = T0 + timedelta(days=30)

    def __call__(self) -> datetime:
        self.now += timedelta(milliseconds=1)
        return self.now


def at(minutes: int) -> datetime:
    return T0 + timedelta(minutes=minutes)


def item(record: Record, minutes: int) -> ImportedSubmission:
    return ImportedSubmission(submitted_at=at(minutes), record=record)


#: An export's submissions, in its order (by submission id, not by time): copies whose first
#: author comes later in the file, near-copies (one whose first author comes later in the file,
#: two pushed at the same moment), lookalike aliases (a pair whose first comes later in the file,
#: her later run listed before both), a run already on another board (pushed there later, and
#: earlier), a racer bettering and worsening, a duplicate.
ITEMS = [
    item(BOB, 10),
    item(make_record("Zoe", [(13200, 100)], model="later"), 50),  # her second push, listed first
    item(make_record("Quick", [(10402, 100), (10503, 100), (10598, 100)]), 25),  # after Swift's
    item(make_record("Z0e", [(13000, 100)]), 45),  # an alias like Zoe's, pushed after hers
    item(make_record("Ada", [(9900, 100), (9950, 100), (9990, 100)], model="slow"), 1),
    item(copy_of(BOB, "Copycat"), 5),  # pushed before Bob: Bob's is the copy
    item(ADA_FAST, 20),
    item(make_record("Nearly", [(8802, 100), (8897, 100), (9004, 100)]), 30),
    item(make_record("Ollie", [(12000, 100)]), 2),
    item(make_record("0llie", [(12100, 100)]), 3),
    item(make_record("Ada", [(15000, 100)], model="worse"), 40),
    item(copy_of(VETERAN, "Elder"), -60),  # before the veteran's own push on another board
    item(copy_of(VETERAN, "Thief"), 50),
    item(BOB, 10),
    item(make_record("Offtrack", [(3000, 40)]), 6),
    item(make_record("Twin", [(9100, 100), (9300, 100), (9500, 100)], model="twin"), 10),
    item(make_record("TieA", [(9600, 100), (9610, 100), (9620, 100)]), 7),
    item(copy_of(make_record("TieA", [(9600, 100), (9610, 100), (9620, 100)]), "TieB"), 7),
    item(make_record("Bob", [(9100, 100), (9300, 100), (9500, 100)], model="again"), 4),
    item(make_record("Tick", [(10800, 100), (10900, 100), (11000, 100)]), 9),
    item(make_record("Tock", [(10803, 100), (10902, 100), (10998, 100)]), 9),
    item(make_record("Swift", [(10400, 100), (10500, 100), (10600, 100)]), 12),
    item(make_record("Zoe", [(13100, 100)]), 35),
]


def new_store(kind: str, path: Path) -> Iterator[BoardStore]:
    if kind == "sqlite":
        store = SqliteStore(path)
        yield store
        store.close()
        return
    with mock_aws():
        client = boto3.client("dynamodb", region_name=REGION)
        yield DynamoDbStore(create_board_table(client, "boards"), client)


def prepared_board(store: BoardStore, with_entries: bool) -> LeaderboardService:
    """A board as found before the import: the veteran's run on the track's board, and the
    finals board with racers of its own (or no finals board yet)."""
    service = LeaderboardService(store, clock=Clock())
    service.push(VETERAN)
    if with_entries:
        service.create_board(BoardSpec(board_id=FINALS, title="Finals", track="reInvent2019"))
        service.push(make_record("Ollie", [(11000, 100)], model="own"), FINALS)
        service.push(make_record("Ada", [(9000, 100)], model="own"), FINALS)
    return service


def exported_board() -> Board:
    return Board(board_id=FINALS, track=TRACK, title="Finals", kind="named", created_at=T0)


def replayed(service: LeaderboardService, items: Sequence[ImportedSubmission]) -> list[str]:
    board_id = service.import_board(exported_board())[0].board_id
    return [service.import_submission(board_id, one).status for one in items]


def loaded(service: LeaderboardService, items: Sequence[ImportedSubmission], batch: int) -> ImportTally:
    bulk = service.bulk_import(exported_board())
    prepared = [bulk.prepare(one) for one in items]
    bulk.open()
    tallies = [bulk.load(prepared[start:start + batch]) for start in range(0, len(prepared), batch)]
    return ImportTally(sum(t.created for t in tallies), sum(t.duplicates for t in tallies))


def state(store: BoardStore) -> dict[str, Any]:
    """Everything an import writes, in a form two stores compare."""
    records = [one.record for one in ITEMS]
    fingerprints = sorted({p.fingerprint for r in records for p in run_prints(r)})
    racers = sorted({racer_key(r.racer) for r in records} | {"veteran", "ollie", "ada"})
    prints = {p.fingerprint: p for r in records for p in run_prints(r)}
    return {
        "entries": {board: [(e.racer, e.submission_id, e.score.flags, e.rank_key)
                            for e in store.top(board, 100)] for board in (FINALS, TRACK)},
        "participants": [store.get_board(board).participants  # type: ignore[union-attr]
                         for board in (FINALS, TRACK)],
        "history": {r: [(s.board_id, s.submission_id, s.submitted_at, s.score.flags)
                        for s in store.history(r)] for r in racers},
        "tallies": {r: store.tally(FINALS, r) for r in racers},
        "holders": [store.holders(board, fingerprints, [r for r in racers] + ["0llie", "ollie", "zoe"])
                    for board in (FINALS, TRACK)],
        "authors": {f: sorted((a.racer_key, a.first_at, a.board_id, a.submission_id) for a in authors)
                    for f, authors in store.authors_of(fingerprints).items()},
        "near": sorted((n.fingerprint, n.racer_key, n.board_id, n.submission_id)
                       for p in prints.values() if p.laps_ms
                       for n in store.near_runs(p.lane, p.laps_ms[0], 5)),
        "audit": {board: sorted((e.action, e.racer or "", e.submission_id or "", e.detail)
                                for e in store.audit(board, None, 1000).events)
                  for board in (FINALS, TRACK)},
        "ranks": [store.count_better(FINALS, e.score_key) for e in store.top(FINALS, 100)],
    }


@pytest.mark.parametrize("kind", ["sqlite", "dynamodb"])
@pytest.mark.parametrize("with_entries", [False, True], ids=["new board", "board with entries"])
def test_an_import_in_bulk_writes_what_replaying_it_writes(tmp_path: Path, kind: str,
                                                           with_entries: bool) -> None:
    for store in new_store(kind, tmp_path / "replayed.db"):
        replay = prepared_board(store, with_entries)
        statuses = replayed(replay, ITEMS)
        expected = state(store)
        again = replayed(replay, ITEMS)
        expected_again = state(store)
    for store in new_store(kind, tmp_path / "loaded.db"):
        bulk = prepared_board(store, with_entries)
        assert loaded(bulk, ITEMS, batch=3) == ImportTally(statuses.count("created"),
                                                           statuses.count("duplicate"))
        assert state(store) == expected
        assert loaded(bulk, ITEMS, batch=5) == ImportTally(0, len(again))
        assert state(store) == expected_again
    flagged = {racer: flags for racer, _, flags, _ in expected["entries"][FINALS] if flags}
    assert flagged["Copycat"] == ["copied-run"] and "Bob" not in flagged, "Bob pushed it first"
    assert flagged["Nearly"] == ["near-copy"]
    assert flagged["Quick"] == ["near-copy"] and "Swift" not in flagged, "Swift pushed first"
    assert flagged["Tick"] == flagged["Tock"] == ["near-copy"], "pushed at the same moment"
    assert flagged["Z0e"] == ["lookalike"] and "Zoe" not in flagged, "Zoe pushed first"
    assert expected["holders"][0][1]["zoe"] == "zoe", "and holds the alias's look"
    assert [flags for *_, flags in expected["history"]["zoe"]] == [[], []], "none of her runs"
    unflagged = [e for e in expected["audit"][FINALS] if e[0] == "unflag"]
    assert unflagged == [("unflag", "Zoe", ITEMS[1].record.submission_id,
                          "lookalike: pushed to the board before 'z0e', whose runs are flagged instead")]
    assert "lookalike" in flagged["0llie"] and flagged["Thief"] == ["copied-run"]
    assert flagged["TieA"] == flagged["TieB"] == ["copied-run"], "pushed at the same moment"
    assert expected["entries"][TRACK][0][2] == ["copied-run"], "the veteran's run, copied earlier"


@pytest.mark.parametrize("kind", ["sqlite", "dynamodb"])
def test_after_an_import_the_racer_who_pushed_first_keeps_pushing_and_the_lookalike_cannot(
        tmp_path: Path, kind: str) -> None:
    """The export lists Z0e's run before Zoe's, though Zoe pushed hers first: on the board the
    import makes, Zoe still pushes under her alias, and Z0e's new push is refused."""
    for store in new_store(kind, tmp_path / "board.db"):
        service = LeaderboardService(store, clock=Clock())
        loaded(service, ITEMS, batch=4)
        zoe, z0e = (Caller(principal=f"join:{name}", name=name) for name in ("zoe", "z0e"))
        for alias, racer in (("Zoe", zoe), ("Z0e", z0e)):  # their results came without sign-ins
            service.assign_alias(alias, racer.principal)
        service.push(make_record("Zoe", [(12900, 100)], model="new"), FINALS, caller=zoe)
        with pytest.raises(AliasTaken, match="could pass for 'zoe'"):
            service.push(make_record("Z0e", [(12800, 100)], model="new"), FINALS, caller=z0e)


def test_an_import_in_bulk_checks_each_submission_before_writing_anything(tmp_path: Path) -> None:
    for store in new_store("sqlite", tmp_path / "board.db"):
        service = LeaderboardService(store, clock=Clock())
        bulk = service.bulk_import(exported_board())
        tampered = BOB.model_copy(update={"model_name": "edited after the export"})
        with pytest.raises(InvalidSubmission, match="submission_id"):
            bulk.prepare(ImportedSubmission.model_construct(submitted_at=at(1), record=tampered))
        with pytest.raises(BoardMismatch):
            bulk.prepare(item(make_record("Ada", track="Oval_track"), 1))
        huge = make_record("Ada", runs=[[(9000 + n, 100)] * 100 for n in range(50)])
        with pytest.raises(SubmissionTooLarge):
            bulk.prepare(item(huge, 1))
        assert service.boards() == []


@pytest.mark.parametrize("kind", ["sqlite", "dynamodb"])
def test_records_of_many_runs_are_imported_with_every_claim(tmp_path: Path, kind: str) -> None:
    """A store writes a batch in parts as it must (DynamoDB: 100 items to a transaction): many
    racers of many runs each still get every fingerprint claimed."""
    records = [make_record(f"Racer {n:02d}", runs=[[(9000 + 37 * n + 3 * k + lap, 100) for lap in (0, 1, 2)]
                                                    for k in range(10)]) for n in range(13)]
    for store in new_store(kind, tmp_path / "board.db"):
        service = LeaderboardService(store, clock=Clock())
        assert loaded(service, [item(r, n) for n, r in enumerate(records)], batch=100) == (
            ImportTally(13, 0))
        prints = [p.fingerprint for r in records for p in run_prints(r)]
        held, _ = store.holders(FINALS, prints, [])
        assert len(prints) == 130 and len(held) == 130
        assert store.get_board(FINALS).participants == 13  # type: ignore[union-attr]



#: Racers of random imports: two pairs of aliases that could pass for each other, and others.
SHUFFLED_RACERS = ["Zoe", "Z0e", "Ollie", "0llie", "Max", "Ann", "Bea"]


def random_items(seed: int) -> list[ImportedSubmission]:
    """Submissions of SHUFFLED_RACERS at distinct times, of their own runs, copies and near-copies
    of earlier ones. No racer has the same laps twice: the runs' index keeps a racer's first
    submission of a run, so a second one's flags depend on the order it is met in."""
    rng = random.Random(seed)
    items: list[ImportedSubmission] = []
    seen: set[tuple[str, str]] = set()
    for n, minute in enumerate(rng.sample(range(1, 5000), 30)):
        racer, kind = rng.choice(SHUFFLED_RACERS), rng.random()
        if kind < 0.15 and items:
            record = copy_of(rng.choice(items).record, racer)
        elif kind < 0.35 and items:
            laps = [(lap.time_ms + rng.randint(-4, 4), 100)
                    for lap in rng.choice(items).record.evaluations[0].laps]
            record = make_record(racer, laps, model=f"near-{n}")
        else:
            record = make_record(racer, [(rng.randint(9000, 9100), 100) for _ in range(3)],
                                 model=f"own-{n}")
        run = (racer, run_prints(record)[0].fingerprint)
        if run not in seen:
            seen.add(run)
            items.append(item(record, minute))
    return items


def flags_and_holders(store: BoardStore) -> tuple[dict[str, list[tuple[str, list[str]]]], dict[str, str]]:
    history = {racer: sorted((s.submission_id, sorted(s.score.flags))
                             for s in store.history(racer_key(racer), FINALS))
               for racer in SHUFFLED_RACERS}
    return history, store.holders(FINALS, [], [confusable_skeleton(r) for r in SHUFFLED_RACERS])[1]


@pytest.mark.parametrize("seed", range(20))
def test_an_import_leaves_the_same_board_whatever_order_its_file_lists_them_in(
        tmp_path: Path, seed: int) -> None:
    """Copies, near-copies and lookalike aliases are judged by when each racer pushed, not by
    where the file lists them: in bulk in one order, and one at a time in another, the same
    runs are flagged and the same racers keep their aliases' looks."""
    items = random_items(seed)
    shuffled = random.Random(seed).sample(items, len(items))
    for store in new_store("sqlite", tmp_path / "bulk.db"):
        loaded(LeaderboardService(store, clock=Clock()), items, batch=7)
        in_bulk = flags_and_holders(store)
    for store in new_store("sqlite", tmp_path / "one-by-one.db"):
        replayed(LeaderboardService(store, clock=Clock()), shuffled)
        assert flags_and_holders(store) == in_bulk


def near_run(rng: random.Random, n: int) -> NearRun:
    best = rng.randint(9000, 9060)
    return NearRun(fingerprint=f"f{n % 50}", racer_key=f"r{n % 40}", board_id=f"b{n % 2}",
                   submission_id=f"s{n}", laps_ms=sorted([best, best + rng.randint(0, 40),
                                                         best + rng.randint(0, 40)]))


def store_order(run: NearRun) -> tuple[int, str, str, str]:
    return run.laps_ms[0], run.fingerprint, run.racer_key, run.board_id


def test_a_lane_finds_the_near_copies_looking_at_every_run_finds() -> None:
    """A lane keeps its runs by cells of their best and slowest laps: a run finds there what
    looking at every run finds, in the store's order."""
    rng = random.Random(7)
    runs = sorted((near_run(rng, n) for n in range(600)), key=store_order)
    lane = _Lane(runs)
    kept: dict[tuple[int, str, str, str], NearRun] = {}
    for run in runs:  # the first of a best lap, fingerprint, racer and board
        kept.setdefault(store_order(run), run)
    for probe in (near_run(rng, n) for n in range(1000, 1400)):
        laps = tuple(probe.laps_ms)
        every = sorted((run for run in kept.values() if run.racer_key != probe.racer_key
                        and run.fingerprint != probe.fingerprint
                        and same_laps(list(laps), run.laps_ms)), key=store_order)
        found = lane.near(probe.fingerprint, probe.racer_key, laps)
        assert [run[3] for run in found] == [run.submission_id for run in every]


@pytest.mark.parametrize(("laps", "near"), [
    ((10004, 10015, 10025), True), ((9994, 10005, 10015), True), ((10005, 10016, 10026), False),
    ((9993, 10004, 10014), False), ((10004, 10015, 10026), False),
])
def test_laps_near_ms_apart_meet_across_a_cell_s_edge(laps: tuple[int, ...], near: bool) -> None:
    assert NEAR_MS == 5
    lane = _Lane([NearRun(fingerprint="x", racer_key="a", board_id="b", submission_id="s",
                          laps_ms=[9999, 10010, 10020])])
    assert bool(lane.near("y", "c", laps)) is near
