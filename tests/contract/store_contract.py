"""The BoardStore contract: one suite every store adapter (SQLite, DynamoDB, ...) must pass.

Use it by subclassing with a ``Test`` name and supplying a ``store`` fixture that yields an
empty store::

    class TestSqliteContract(StoreContract):
        @pytest.fixture
        def store(self, tmp_path):
            yield SqliteStore(tmp_path / "board.db")

The suite only calls the BoardStore protocol's methods, and builds the Submission and Entry it
writes the way LeaderboardService.push does (``write_for`` below), so it holds for any adapter.
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from datetime import UTC, datetime, timedelta

import pytest
from drboard_assembler.record import Record
from drboard_functions import ranking
from drboard_functions.models.domain import (
    AliasClaim,
    AuditEvent,
    Board,
    BoardRules,
    Entry,
    EventBans,
    RacerTally,
    Submission,
    SubmissionLimits,
    TimingMethod,
    WriteOutcome,
)
from drboard_functions.models.notices import MAX_ERROR_CHARS, Target, Webhook
from drboard_functions.service import evaluation_fingerprints, scored_write
from drboard_functions.service.copies import run_prints
from drboard_functions.stores.base import (
    AliasConflict,
    BoardHasEntries,
    BoardStore,
    FingerprintTaken,
    ImportBatch,
    ImportedRow,
    ImportWritten,
    IndexedRun,
    LimitReached,
)

from tests.contract.season_contract import SeasonStoreContract
from tests.recordkit import LapSpec, copy_of, make_record

T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)
TRACK = "reInvent2019_track"


def at(seconds: float) -> datetime:
    return T0 + timedelta(seconds=seconds)


def make_board(board_id: str = TRACK, track: str = TRACK, title: str = "Smile Speedway",
               direction: str | None = None) -> Board:
    return Board.model_validate({
        "board_id": board_id, "track": track, "direction": direction, "title": title,
        "rules": BoardRules(), "created_at": T0,
    })


def write_for(record: Record, board: Board, when: datetime) -> tuple[Submission, Entry]:
    """The submission and candidate entry LeaderboardService.push writes for ``record``."""
    return scored_write(record, board, when)


def submit(store: BoardStore, record: Record, when: datetime, board: Board | None = None,
           limits: SubmissionLimits | None = None) -> WriteOutcome:
    board = board or make_board()
    if store.get_board(board.board_id) is None:
        store.create_board(board)
    submission, entry = write_for(record, board, when)
    return store.record_submission(submission, record.model_dump_json(), entry, limits,
                                   fingerprints=evaluation_fingerprints(record))


def imported_row(record: Record, board: Board, when: datetime) -> ImportedRow:
    """The row a bulk import writes for ``record`` (as ``loading.prepare_submission`` makes it)."""
    submission, entry = write_for(record, board, when)
    return ImportedRow(submission_id=record.submission_id, racer_key=submission.racer_key,
                       submitted_at=ranking.timestamp(when), score_key=entry.score_key,
                       rank_key=entry.rank_key, submission=submission.model_dump_json(),
                       entry=entry.model_dump_json(), record=record.model_dump_json())


def claim(alias: str, principal: str) -> AliasClaim:
    return AliasClaim(racer_key=alias.casefold(), alias=alias, principal=principal, claimed_at=T0)


def event(n: int, action: str = "push", board_id: str = TRACK) -> AuditEvent:
    return AuditEvent.model_validate({"board_id": board_id, "at": at(n), "action": action,
                                      "event_id": f"{at(n).isoformat()}-{n:08x}", "actor": "local"})


def webhook(webhook_id: str, target: Target | None = None, created: float = 0,
            url: str = "https://discord.com/api/webhooks/1/s3cr3t") -> Webhook:
    return Webhook(webhook_id=webhook_id, target=target or Target(target_id=TRACK), kind="discord",
                   url=url, events=["new-leader", "board-close"], created_at=at(created))


def cooldown(seconds: int, now: datetime) -> SubmissionLimits:
    return SubmissionLimits(now=now, cooldown_s=seconds)


def at_most(submissions: int, now: datetime) -> SubmissionLimits:
    return SubmissionLimits(now=now, max_submissions=submissions)


def lap(ms: int) -> list[LapSpec]:
    return [(ms, 100)]


def version(store: BoardStore, board_id: str = TRACK) -> int:
    stored = store.get_board(board_id)
    assert stored is not None
    assert store.board_version(board_id) == stored.version  # the cheap read agrees
    return stored.version


def participants(store: BoardStore, board_id: str = TRACK) -> int:
    stored = store.get_board(board_id)
    assert stored is not None
    return stored.participants


def ranks_by_count(store: BoardStore, board_id: str = TRACK) -> dict[str, int]:
    """Every racer's rank as the store counts it: 1 + count_better of their score key."""
    return {e.racer: store.count_better(board_id, e.score_key) + 1 for e in store.top(board_id, 1000)}


def ranks_by_listing(store: BoardStore, board_id: str = TRACK) -> dict[str, int]:
    """Every racer's rank by the definition, from the whole listing: 1 + the entries with a
    strictly lower score key."""
    entries = store.top(board_id, 1000)
    return {e.racer: 1 + sum(other.score_key < e.score_key for other in entries) for e in entries}


class StoreContract(SeasonStoreContract):
    """Behaviour every BoardStore adapter shares (seasons' in ``season_contract.py``).
    Subclasses supply the ``store`` fixture."""

    @pytest.fixture
    def store(self) -> BoardStore:
        raise NotImplementedError("a StoreContract subclass must supply an empty `store` fixture")

    # ---- boards -------------------------------------------------------------------------------

    def test_unknown_board_is_none(self, store: BoardStore) -> None:
        assert store.get_board("nowhere") is None
        assert store.list_boards() == []

    def test_create_board_returns_the_stored_board(self, store: BoardStore) -> None:
        board = make_board()
        stored = store.create_board(board)
        assert stored.board == board
        assert stored.participants == 0
        assert store.get_board(board.board_id) == stored

    def test_create_board_is_idempotent(self, store: BoardStore) -> None:
        first = make_board(title="First title")
        store.create_board(first)
        submit(store, make_record("Ada"), at(1), first)
        again = store.create_board(make_board(title="Second title"))
        assert again.board == first
        assert again.participants == 1
        assert [s.board for s in store.list_boards()] == [first]

    def test_list_boards_is_ordered_by_id(self, store: BoardStore) -> None:
        ids = ["reInvent2019_track_cw", "Oval_track", "reInvent2019_track", "2022_april_open",
               "reInvent2019_track_oa"]
        for board_id in ids:
            store.create_board(make_board(board_id, track=board_id.removesuffix("_cw")))
        assert [s.board.board_id for s in store.list_boards()] == sorted(ids)

    def test_list_boards_reports_participants(self, store: BoardStore) -> None:
        cw = make_board("reInvent2019_track_cw", direction="cw")
        submit(store, make_record("Ada"), at(1))
        submit(store, make_record("Bob"), at(2))
        submit(store, make_record("Ada", direction="cw"), at(3), cw)
        assert [(s.board.board_id, s.participants) for s in store.list_boards()] == [
            (TRACK, 2), ("reInvent2019_track_cw", 1)]

    # ---- record_submission ------------------------------------------------------------------

    def test_first_submission_of_a_racer_creates_the_entry(self, store: BoardStore) -> None:
        record = make_record("Ada", lap(12000))
        store.create_board(make_board())
        submission, entry = write_for(record, make_board(), at(1))
        outcome = store.record_submission(submission, record.model_dump_json(), entry)
        assert outcome == WriteOutcome(duplicate=False, improved=True, entry=entry)
        assert store.get_entry(TRACK, "ada") == entry
        assert participants(store) == 1
        assert store.history("ada") == [submission]

    def test_duplicate_submission_changes_nothing(self, store: BoardStore) -> None:
        record = make_record("Ada", lap(12000))
        first = submit(store, record, at(1))
        again = submit(store, record, at(5))
        assert again.duplicate is True
        assert again.improved is False
        assert again.entry == first.entry  # the stored entry, with its original time
        assert store.get_entry(TRACK, "ada") == first.entry
        assert participants(store) == 1
        assert [s.submitted_at for s in store.history("ada")] == [at(1)]

    def test_a_pushs_first_read_gives_the_board_the_events_bans_the_submission_and_the_entry(
            self, store: BoardStore) -> None:
        record = make_record("Ada", lap(12000))
        assert store.push_reads("nowhere", "ada", record.submission_id, [], 5) == (
            None, EventBans(), 0, None, None, [])
        first = store.push_reads(TRACK, "ada", record.submission_id, [], 5)
        assert (first.board, first.submission, first.entry) == (store.get_board(TRACK), None, None)
        stored = submit(store, record, at(1))
        version = store.save_event_bans(EventBans(racers=["bob"]), 0)
        read = store.push_reads(TRACK, "ada", record.submission_id, [], 5)
        assert read.board == store.get_board(TRACK) and read.board is not None
        assert read.board.participants == 1
        assert (read.bans, read.bans_version) == (EventBans(racers=["bob"]), version) == store.event_bans()
        assert read.submission == store.get_submission(TRACK, "ada", record.submission_id)
        assert read.submission is not None and read.submission.submitted_at == stored.entry.achieved_at
        assert read.entry == stored.entry == store.get_entry(TRACK, "ada")
        other = store.push_reads(TRACK, "bob", record.submission_id, [], 5)
        assert (other.submission, other.entry) == (None, None)

    def test_a_pushs_first_read_tells_who_else_drove_each_of_its_runs(self, store: BoardStore) -> None:
        """Each run's authors anywhere, and the runs of its lane within the tolerance, in the
        order of the push's runs; a run too short to compare has no near runs looked for."""
        three = [(9000, 100), (9100, 100), (9200, 100)]
        ada, short = make_record("Ada", three), make_record("Ada", lap(12000))
        board = make_board()
        store.create_board(board)
        for record, when in ((ada, 1), (short, 2)):
            submission, entry = write_for(record, board, at(when))
            store.record_submission(submission, record.model_dump_json(), entry, None,
                                    fingerprints=evaluation_fingerprints(record),
                                    runs=run_prints(record))
        [run], [short_run] = run_prints(ada), run_prints(short)
        near = run._replace(fingerprint="f-elsewhere", laps_ms=[9003, 9104, 9198])
        far = run._replace(fingerprint="f-far", laps_ms=[9020, 9100, 9200])
        read = store.push_reads(TRACK, "bob", "0" * 64, [run, short_run, near, far], 5)
        authors = [[(a.racer_key, a.board_id) for a in seen.authors] for seen in read.runs]
        assert authors == [[("ada", TRACK)], [("ada", TRACK)], [], []]
        assert [[(n.racer_key, n.laps_ms) for n in seen.near] for seen in read.runs] == [
            [("ada", [9000, 9100, 9200])], [], [("ada", [9000, 9100, 9200])], []]

    def test_duplicate_of_an_older_submission_keeps_the_best(self, store: BoardStore) -> None:
        slow, fast = make_record("Ada", lap(13000)), make_record("Ada", lap(12000))
        submit(store, slow, at(1))
        best = submit(store, fast, at(2)).entry
        again = submit(store, slow, at(3))
        assert (again.duplicate, again.improved, again.entry) == (True, False, best)
        assert len(store.history("ada")) == 2

    def test_same_record_on_another_board_is_not_a_duplicate(self, store: BoardStore) -> None:
        record = make_record("Ada", lap(12000))
        submit(store, record, at(1))
        other = make_board("spring_cup", title="Spring cup")
        outcome = submit(store, record, at(2), other)
        assert (outcome.duplicate, outcome.improved) == (False, True)
        assert participants(store, "spring_cup") == 1
        assert store.get_record("spring_cup", record.submission_id) == record

    def test_worse_submission_is_kept_in_history_and_the_entry_stays(self, store: BoardStore) -> None:
        best = submit(store, make_record("Ada", lap(12000)), at(1)).entry
        worse = make_record("Ada", lap(12500), model="m2")
        outcome = submit(store, worse, at(2))
        assert (outcome.duplicate, outcome.improved) == (False, False)
        assert outcome.entry == best
        assert store.get_entry(TRACK, "ada") == best
        assert participants(store) == 1
        assert [s.submission_id for s in store.history("ada")] == [
            best.submission_id, worse.submission_id]
        assert store.get_record(TRACK, worse.submission_id) == worse

    def test_strictly_better_submission_replaces_the_entry(self, store: BoardStore) -> None:
        submit(store, make_record("Ada", lap(12500)), at(1))
        better = make_record("Ada", lap(12499), model="m2")
        _, expected = write_for(better, make_board(), at(2))
        outcome = submit(store, better, at(2))
        assert (outcome.duplicate, outcome.improved) == (False, True)
        assert outcome.entry == expected
        assert store.get_entry(TRACK, "ada") == expected
        assert participants(store) == 1
        assert len(store.history("ada")) == 2
        assert [e.racer_key for e in store.top(TRACK, 10)] == ["ada"]

    def test_equal_score_does_not_replace_the_entry(self, store: BoardStore) -> None:
        first = submit(store, make_record("Ada", lap(12000), model="m1"), at(1)).entry
        outcome = submit(store, make_record("Ada", lap(12000), model="m2"), at(2))
        assert (outcome.duplicate, outcome.improved) == (False, False)
        assert outcome.entry == first
        assert store.get_entry(TRACK, "ada") == first
        assert len(store.history("ada")) == 2

    def test_qualifying_beats_any_completion_and_not_the_other_way(self, store: BoardStore) -> None:
        unfinished = submit(store, make_record("Ada", [(9000, 80)]), at(1))
        assert unfinished.improved and not unfinished.entry.score.qualified
        finished = submit(store, make_record("Ada", lap(20000)), at(2))
        assert finished.improved and finished.entry.score.qualified
        assert not submit(store, make_record("Ada", [(9000, 99.9)]), at(3)).improved
        assert store.get_entry(TRACK, "ada") == finished.entry

    def test_higher_completion_improves_a_non_qualified_entry(self, store: BoardStore) -> None:
        submit(store, make_record("Ada", [(9000, 50)]), at(1))
        better = submit(store, make_record("Ada", [(9000, 75.5)]), at(2))
        assert better.improved
        stored = store.get_entry(TRACK, "ada")
        assert stored is not None and stored.score.best_completion_pct == 75.5

    def test_each_racer_has_one_entry(self, store: BoardStore) -> None:
        for n, (racer, ms) in enumerate([("Ada", 12000), ("Bob", 11000), ("Ada", 11500)]):
            submit(store, make_record(racer, lap(ms)), at(n))
        assert participants(store) == 2
        assert [(e.racer_key, e.score.time_ms) for e in store.top(TRACK, 10)] == [
            ("bob", 11000), ("ada", 11500)]

    # ---- history ------------------------------------------------------------------------------

    def test_history_is_oldest_first_across_boards_and_filtered_by_board(self, store: BoardStore) -> None:
        cw = make_board("reInvent2019_track_cw", direction="cw", title="Smile Speedway (clockwise)")
        pushes = [
            (make_record("Ada", lap(12000)), make_board()),
            (make_record("Ada", lap(14000), direction="cw"), cw),
            (make_record("Ada", lap(12800)), make_board()),
            (make_record("Bob", lap(11000)), make_board()),
            (make_record("Ada", lap(13000), direction="cw"), cw),
        ]
        order = [3, 0, 4, 1, 2]  # push in a shuffled order, each at its own time
        for n in order:
            record, board = pushes[n]
            submit(store, record, at(10 + n * 1.5), board)
        ada = [pushes[n][0].submission_id for n in (0, 1, 2, 4)]
        history = store.history("ada")
        assert [s.submission_id for s in history] == ada
        assert [s.submitted_at for s in history] == sorted(s.submitted_at for s in history)
        assert [s.submission_id for s in store.history("ada", TRACK)] == [ada[0], ada[2]]
        assert [s.submission_id for s in store.history("ada", "reInvent2019_track_cw")] == [
            ada[1], ada[3]]
        assert {s.board_id for s in history} == {TRACK, "reInvent2019_track_cw"}

    def test_history_round_trips_the_submission(self, store: BoardStore) -> None:
        record = make_record("Ada Lovelace", [(12000, 100), (8000, 55)])
        submission, entry = write_for(record, make_board(), at(1))
        store.create_board(make_board())
        store.record_submission(submission, record.model_dump_json(), entry)
        assert store.history("ada lovelace") == [submission]

    def test_history_of_an_unknown_racer_is_empty(self, store: BoardStore) -> None:
        submit(store, make_record("Ada"), at(1))
        assert store.history("nobody") == []
        assert store.history("ada", "nowhere") == []

    # ---- top ----------------------------------------------------------------------------------

    def test_top_is_in_rank_key_order_with_a_limit(self, store: BoardStore) -> None:
        times = {"Ada": 12000, "Bob": 11000, "Cy": 12000, "Dee": 10500, "Eve": 13000}
        entries = [submit(store, make_record(racer, lap(ms)), at(n)).entry
                   for n, (racer, ms) in enumerate(times.items())]
        submit(store, make_record("Fay", [(9000, 90)]), at(9))
        submit(store, make_record("Gus", [(9000, 95)]), at(10))
        names = [e.racer for e in store.top(TRACK, 100)]
        assert names == ["Dee", "Bob", "Ada", "Cy", "Eve", "Gus", "Fay"]
        assert [e.racer for e in store.top(TRACK, 3)] == names[:3]
        top = store.top(TRACK, 100)
        assert [e.rank_key for e in top] == sorted(e.rank_key for e in top)
        assert top[2] == entries[0]

    def test_equal_scores_list_the_earlier_achievement_first(self, store: BoardStore) -> None:
        submit(store, make_record("Zed", lap(12000)), at(1))
        submit(store, make_record("Amy", lap(12000)), at(2))
        assert [e.racer for e in store.top(TRACK, 10)] == ["Zed", "Amy"]

    def test_top_pages_with_after_without_loss_or_repeat(self, store: BoardStore) -> None:
        racers = [(f"Racer {n:02d}", 12000 + (n % 7) * 250) for n in range(25)]
        random.Random(7).shuffle(racers)
        for n, (racer, ms) in enumerate(racers):
            submit(store, make_record(racer, lap(ms)), at(n))
        everything = store.top(TRACK, 100)
        assert len(everything) == 25
        pages: list[list[Entry]] = []
        after: str | None = None
        while True:
            page = store.top(TRACK, 10, after)
            if not page:
                break
            pages.append(page)
            after = page[-1].rank_key
        assert [len(p) for p in pages] == [10, 10, 5]
        assert [e for p in pages for e in p] == everything
        assert store.top(TRACK, 10, everything[-1].rank_key) == []

    def test_top_is_per_board(self, store: BoardStore) -> None:
        cw = make_board("reInvent2019_track_cw", direction="cw")
        submit(store, make_record("Ada", lap(12000)), at(1))
        submit(store, make_record("Bob", lap(11000), direction="cw"), at(2), cw)
        assert [e.racer for e in store.top(TRACK, 10)] == ["Ada"]
        assert [e.racer for e in store.top("reInvent2019_track_cw", 10)] == ["Bob"]
        assert store.top("nowhere", 10) == []

    # ---- get_entry, count_better, get_record ------------------------------------------------

    def test_get_entry_of_an_unknown_racer_is_none(self, store: BoardStore) -> None:
        submit(store, make_record("Ada"), at(1))
        assert store.get_entry(TRACK, "bob") is None
        assert store.get_entry("nowhere", "ada") is None

    def test_count_better_counts_strictly_better_entries(self, store: BoardStore) -> None:
        specs: Sequence[tuple[str, list[LapSpec]]] = [
            ("Ada", lap(11000)), ("Bob", lap(12000)), ("Cy", lap(12000)), ("Dee", lap(13000)),
            ("Eve", [(9000, 80)]), ("Fay", [(9000, 80)]), ("Gus", [(9000, 40)]),
        ]
        keys = {racer: submit(store, make_record(racer, laps), at(n)).entry.score_key
                for n, (racer, laps) in enumerate(specs)}
        ranks = {racer: store.count_better(TRACK, key) + 1 for racer, key in keys.items()}
        assert ranks == {"Ada": 1, "Bob": 2, "Cy": 2, "Dee": 4, "Eve": 5, "Fay": 5, "Gus": 7}
        # keys that no entry holds count the same way
        assert store.count_better(TRACK, "0:" + "0" * 12) == 0
        assert store.count_better(TRACK, keys["Bob"][:-1] + "1") == 3
        assert store.count_better(TRACK, "1:10000") == 7  # everyone has more than 0 % completion
        assert store.count_better("nowhere", keys["Dee"]) == 0

    # ---- ranks ----------------------------------------------------------------------------------

    def test_ranks_are_exact_within_one_score_bucket_and_across_buckets(self, store: BoardStore) -> None:
        specs: Sequence[tuple[str, list[LapSpec]]] = [
            ("Ada", lap(12_001)), ("Bob", lap(12_003)), ("Cy", lap(12_003)),  # one 10 ms bucket
            ("Dee", lap(12_009)), ("Eve", lap(12_010)), ("Fay", lap(12_999)),  # one second
            ("Gus", lap(13_000)), ("Hal", lap(8_000)), ("Ida", lap(30_000)),  # other seconds
            ("Jo", [(9_000, 80)]), ("Kit", [(9_000, 80)]), ("Lu", [(9_000, 79.99)]),
            ("Max", [(9_000, 40)]), ("Ned", [(9_000, 0)]),
        ]
        for n, (racer, laps) in enumerate(specs):
            submit(store, make_record(racer, laps), at(n))
        assert ranks_by_count(store) == {
            "Hal": 1, "Ada": 2, "Bob": 3, "Cy": 3, "Dee": 5, "Eve": 6, "Fay": 7, "Gus": 8,
            "Ida": 9, "Jo": 10, "Kit": 10, "Lu": 12, "Max": 13, "Ned": 14}
        # keys no entry holds, inside the same buckets
        assert store.count_better(TRACK, "0:000000012002") == 2
        assert store.count_better(TRACK, "0:000000012004") == 4
        assert store.count_better(TRACK, "0:000000012998") == 6
        assert store.count_better(TRACK, "1:02001") == 11

    def test_ranks_follow_an_improvement_past_other_racers(self, store: BoardStore) -> None:
        for n, (racer, ms) in enumerate([("Ada", 11_000), ("Bob", 11_500), ("Cy", 12_000),
                                         ("Dee", 14_250)]):
            submit(store, make_record(racer, lap(ms)), at(n))
        assert submit(store, make_record("Dee", lap(11_500), model="faster"), at(9)).improved
        assert ranks_by_count(store) == {"Ada": 1, "Bob": 2, "Dee": 2, "Cy": 4}
        assert submit(store, make_record("Cy", lap(10_999), model="faster"), at(10)).improved
        assert ranks_by_count(store) == {"Cy": 1, "Ada": 2, "Bob": 3, "Dee": 3}
        # a racer who never finished a lap, then qualifies
        submit(store, make_record("Eve", [(9_000, 50)]), at(11))
        assert ranks_by_count(store)["Eve"] == 5
        assert submit(store, make_record("Eve", lap(10_000), model="finished"), at(12)).improved
        assert ranks_by_count(store) == {"Eve": 1, "Cy": 2, "Ada": 3, "Bob": 4, "Dee": 4}

    def test_ranks_close_up_on_removal_and_open_again_on_restore(self, store: BoardStore) -> None:
        for n, (racer, ms) in enumerate([("Ada", 11_000), ("Bob", 11_004), ("Cy", 11_004),
                                         ("Dee", 11_008), ("Eve", 15_000)]):
            submit(store, make_record(racer, lap(ms)), at(n))
        before = ranks_by_count(store)
        removed = store.remove_entry(TRACK, "bob")
        assert removed is not None
        assert ranks_by_count(store) == {"Ada": 1, "Cy": 2, "Dee": 3, "Eve": 4}
        store.restore_entry(removed)
        store.restore_entry(removed)  # a second restore changes nothing
        assert ranks_by_count(store) == before == {"Ada": 1, "Bob": 2, "Cy": 2, "Dee": 4, "Eve": 5}
        for racer in ("ada", "bob", "cy", "dee", "eve"):
            store.remove_entry(TRACK, racer)
        assert store.count_better(TRACK, "1:10000") == 0

    def test_ranks_of_very_slow_qualified_results(self, store: BoardStore) -> None:
        # Results of 1,000 s and more share one bucket that is counted from its entries.
        for n, (racer, ms) in enumerate([("Ada", 999_999), ("Bob", 1_000_000), ("Cy", 1_500_000),
                                         ("Dee", 1_500_000), ("Eve", 20_000_000), ("Fay", 12_000)]):
            submit(store, make_record(racer, lap(ms)), at(n))
        submit(store, make_record("Gus", [(9_000, 50)]), at(9))
        assert ranks_by_count(store) == {"Fay": 1, "Ada": 2, "Bob": 3, "Cy": 4, "Dee": 4, "Eve": 6,
                                         "Gus": 7}
        assert submit(store, make_record("Eve", lap(1_000_001), model="faster"), at(10)).improved
        assert ranks_by_count(store) == {"Fay": 1, "Ada": 2, "Bob": 3, "Eve": 4, "Cy": 5, "Dee": 5,
                                         "Gus": 7}

    def test_ranks_stay_exact_through_a_season_of_pushes(self, store: BoardStore) -> None:
        """Random pushes (new racers, improvements, worse runs, ties), removals and restores,
        bunched in a few buckets: after every step, each racer's counted rank is their rank in
        the full listing."""
        rng = random.Random(20250301)
        racers = [f"Racer {n}" for n in range(8)]
        removed: dict[str, Entry] = {}
        for step in range(40):
            racer = rng.choice(racers)
            action = rng.random()
            if action < 0.15 and store.get_entry(TRACK, racer.casefold()) is not None:
                entry = store.remove_entry(TRACK, racer.casefold())
                assert entry is not None
                removed[racer] = entry
            elif action < 0.25 and racer in removed:
                store.restore_entry(removed.pop(racer))
            else:
                laps = (lap(rng.choice([11_000, 11_003, 11_007, 11_010, 11_990, 12_000, 14_500]))
                        if rng.random() < 0.8 else [(9_000, rng.choice([30, 55, 55.01, 90]))])
                submit(store, make_record(racer, laps, model=f"m{step}"), at(step))
            assert ranks_by_count(store) == ranks_by_listing(store), step

    def test_get_record_round_trips_the_record(self, store: BoardStore) -> None:
        record = make_record("Ada", runs=[[(12000, 100), (9000, 40)], [(11800, 100, "In progress")]],
                             direction="ccw", model="fast-one")
        submit(store, record, at(1))
        stored = store.get_record(TRACK, record.submission_id)
        assert stored == record
        assert stored is not None and stored.submission_id == record.submission_id
        assert store.get_record(TRACK, "0" * 64) is None
        assert store.get_record("nowhere", record.submission_id) is None

    # ---- reading one submission, and paging through them all --------------------------------

    def test_get_submission_finds_the_racers_own_submission(self, store: BoardStore) -> None:
        record = make_record("Ada", lap(12000))
        submit(store, record, at(1))
        found = store.get_submission(TRACK, "ada", record.submission_id)
        assert found is not None and (found.racer, found.submitted_at) == ("Ada", at(1))
        assert store.get_submission(TRACK, "bob", record.submission_id) is None
        assert store.get_submission("nowhere", "ada", record.submission_id) is None

    def test_submissions_pages_through_every_submission_with_its_record(self, store: BoardStore) -> None:
        records = [make_record(f"R{n % 4}", lap(12000 + n)) for n in range(11)]
        for n, record in enumerate(records):
            submit(store, record, at(n))
        submit(store, make_record("Other"), at(20), make_board("Oval_track", track="Oval_track"))
        seen: list[str] = []
        after = None
        pages = 0
        while True:
            page = store.submissions(TRACK, after, 4)
            pages += 1
            for submission, record in page.submissions:
                assert record.submission_id == submission.submission_id
                assert record == next(r for r in records if r.submission_id == submission.submission_id)
            seen += [s.submission_id for s, _ in page.submissions]
            if page.after is None:
                break
            after = page.after
        assert sorted(seen) == sorted(r.submission_id for r in records)
        assert pages in (3, 4)  # 11 in pages of 4; a store may need one empty last page
        assert store.submissions("nowhere", None, 4).submissions == []

    def test_an_export_reads_every_entry_and_submission_as_stored(self, store: BoardStore) -> None:
        records = [make_record(f"R{n % 4}", lap(12000 - n)) for n in range(9)]
        for n, record in enumerate(records):
            submit(store, record, at(n))
        submit(store, make_record("Other"), at(20), make_board("Oval_track", track="Oval_track"))
        entries = [Entry.model_validate_json(raw) for raw in store.exported_entries(TRACK)]
        assert entries == store.top(TRACK, 100)
        exported = list(store.exported_submissions(TRACK))
        assert len(exported) == len(records)
        for raw_submission, raw_record in exported:
            submission = Submission.model_validate_json(raw_submission)
            record = Record.model_validate_json(raw_record)
            assert record == next(r for r in records if r.submission_id == submission.submission_id)
            assert store.get_submission(TRACK, submission.racer_key, submission.submission_id) == submission
        assert list(store.exported_entries("nowhere")) == []
        assert list(store.exported_submissions("nowhere")) == []

    # ---- submission limits ------------------------------------------------------------------

    def test_tally_counts_a_racers_submissions_on_a_board(self, store: BoardStore) -> None:
        assert store.tally(TRACK, "ada") == RacerTally()
        submit(store, make_record("Ada", lap(12000)), at(1))
        submit(store, make_record("Ada", lap(13000)), at(5))
        submit(store, make_record("Ada", lap(13000)), at(9))  # a duplicate does not count
        submit(store, make_record("Bob", lap(13000)), at(7))
        assert store.tally(TRACK, "ada") == RacerTally(submissions=2, last_submitted_at=at(5))

    def test_a_push_inside_the_cooldown_is_refused_and_writes_nothing(self, store: BoardStore) -> None:
        submit(store, make_record("Ada", lap(12000)), at(0), limits=cooldown(60, at(0)))
        faster = make_record("Ada", lap(11000))
        with pytest.raises(LimitReached) as refused:
            submit(store, faster, at(59), limits=cooldown(60, at(59)))
        assert refused.value.tally == RacerTally(submissions=1, last_submitted_at=at(0))
        assert store.get_submission(TRACK, "ada", faster.submission_id) is None
        assert [s.submission_id for s in store.history("ada")] == [
            make_record("Ada", lap(12000)).submission_id]
        entry = store.get_entry(TRACK, "ada")
        assert entry is not None and entry.score.time_ms == 12000
        assert store.tally(TRACK, "ada").submissions == 1

    def test_a_push_after_the_cooldown_is_taken(self, store: BoardStore) -> None:
        submit(store, make_record("Ada", lap(12000)), at(0), limits=cooldown(60, at(0)))
        outcome = submit(store, make_record("Ada", lap(11000)), at(60), limits=cooldown(60, at(60)))
        assert outcome.improved
        submit(store, make_record("Bob", lap(13000)), at(61), limits=cooldown(60, at(61)))

    def test_the_maximum_of_submissions_is_enforced(self, store: BoardStore) -> None:
        for n in range(3):
            submit(store, make_record("Ada", lap(12000 + n)), at(n), limits=at_most(3, at(n)))
        with pytest.raises(LimitReached) as refused:
            submit(store, make_record("Ada", lap(10000)), at(9), limits=at_most(3, at(9)))
        assert refused.value.tally.submissions == 3
        assert len(store.history("ada", TRACK)) == 3
        submit(store, make_record("Bob", lap(10000)), at(10), limits=at_most(3, at(10)))

    def test_a_duplicate_is_never_refused_by_a_limit(self, store: BoardStore) -> None:
        record = make_record("Ada", lap(12000))
        submit(store, record, at(0), limits=at_most(1, at(0)))
        again = submit(store, record, at(1), limits=SubmissionLimits(now=at(1), cooldown_s=600,
                                                                    max_submissions=1))
        assert again.duplicate and not again.improved
        assert store.tally(TRACK, "ada").submissions == 1

    def test_limits_are_per_board(self, store: BoardStore) -> None:
        oval = make_board("Oval_track", track="Oval_track")
        submit(store, make_record("Ada", lap(12000)), at(0), limits=at_most(1, at(0)))
        submit(store, make_record("Ada", lap(12000), track="Oval_track"), at(1), oval,
               limits=at_most(1, at(1)))
        assert store.tally("Oval_track", "ada").submissions == 1

    def test_an_unlimited_write_keeps_the_latest_time(self, store: BoardStore) -> None:
        # An import replays submissions in any order; the tally still knows the latest one.
        submit(store, make_record("Ada", lap(12000)), at(50))
        submit(store, make_record("Ada", lap(13000)), at(10))
        assert store.tally(TRACK, "ada") == RacerTally(submissions=2, last_submitted_at=at(50))

    # ---- replays (imports): the best is the same in any order ----------------------------------

    def test_an_equal_score_achieved_earlier_becomes_the_entry(self, store: BoardStore) -> None:
        later = make_record("Ada", lap(12000), model="later")
        earlier = make_record("Ada", lap(12000), model="earlier")
        submit(store, later, at(50))
        outcome = submit(store, earlier, at(10))
        assert outcome.improved
        entry = store.get_entry(TRACK, "ada")
        assert entry is not None and entry.submission_id == earlier.submission_id

    # ---- changing a board -------------------------------------------------------------------

    def test_update_board_replaces_its_settings(self, store: BoardStore) -> None:
        store.create_board(make_board())
        submit(store, make_record("Ada"), at(1))
        changed = make_board(title="Renamed").model_copy(update={"cooldown_s": 1800})
        stored = store.update_board(changed)
        assert stored.board == changed and stored.participants == 1
        assert store.get_board(TRACK) == stored
        assert [s.board for s in store.list_boards()] == [changed]
        assert [e.racer for e in store.top(TRACK, 10)] == ["Ada"]

    def test_update_board_only_if_empty(self, store: BoardStore) -> None:
        store.create_board(make_board())
        rescored = make_board().model_copy(update={"rules": BoardRules(method=TimingMethod.TOTAL_TIME)})
        assert store.update_board(rescored, only_if_empty=True).board == rescored
        submit(store, make_record("Ada"), at(1), rescored)
        with pytest.raises(BoardHasEntries):
            store.update_board(make_board(), only_if_empty=True)
        stored = store.get_board(TRACK)
        assert stored is not None and stored.board == rescored

    def test_update_of_an_unknown_board_is_a_key_error(self, store: BoardStore) -> None:
        with pytest.raises(KeyError):
            store.update_board(make_board("nowhere"))
        assert store.get_board("nowhere") is None

    # ---- the front page ---------------------------------------------------------------------

    def test_front_page_is_the_board_and_its_first_entries(self, store: BoardStore) -> None:
        for n, racer in enumerate(["Cy", "Ada", "Bob"]):
            submit(store, make_record(racer, lap(12000 - n * 100)), at(n))
        stored, entries = store.front_page(TRACK, 2)
        assert stored == store.get_board(TRACK)
        assert [e.racer for e in entries] == ["Bob", "Ada"]
        assert store.front_page("nowhere", 2) == (None, [])
        store.create_board(make_board("Oval_track", track="Oval_track"))
        empty, none = store.front_page("Oval_track", 5)
        assert empty is not None and empty.participants == 0 and none == []

    # ---- the board's version ----------------------------------------------------------------

    def test_every_change_to_the_standings_bumps_the_version(self, store: BoardStore) -> None:
        store.create_board(make_board())
        seen = [version(store)]
        submit(store, make_record("Ada", lap(9000)), at(0))  # a new entry
        seen.append(version(store))
        submit(store, make_record("Ada", lap(8000), model="faster"), at(1))  # an improvement
        seen.append(version(store))
        store.update_board(make_board(title="Renamed"))  # the settings
        seen.append(version(store))
        removed = store.remove_entry(TRACK, "ada")
        seen.append(version(store))
        assert removed is not None
        store.restore_entry(removed)
        seen.append(version(store))
        assert seen == sorted(set(seen)), seen  # strictly increasing
        assert [s.version for s in store.list_boards()] == [seen[-1]]
        assert store.front_page(TRACK, 1)[0] == store.get_board(TRACK)

    def test_a_flag_goes_on_a_run_and_its_entry_once_and_comes_off_again(self, store: BoardStore) -> None:
        record = make_record("Ada", lap(9000))
        submit(store, record, at(0))
        seen = [version(store)]
        for remove, changes in ((False, True), (False, False), (True, True), (True, False)):
            assert store.flag_submission(TRACK, "ada", record.submission_id, "lookalike",
                                         remove=remove) is changes
            flags = [] if remove else ["lookalike"]
            stored = store.get_submission(TRACK, "ada", record.submission_id)
            entry = store.get_entry(TRACK, "ada")
            assert stored is not None and entry is not None
            assert stored.score.flags == entry.score.flags == flags
            seen.append(version(store))
        assert seen[1] > seen[0] and seen[3] > seen[2], "a page showing the flag is read again"
        assert not store.flag_submission(TRACK, "ada", "0" * 64, "lookalike")

    def test_a_board_that_is_not_there_has_no_version(self, store: BoardStore) -> None:
        assert store.board_version(TRACK) is None
        store.create_board(make_board())
        assert store.board_version(TRACK) == version(store)

    def test_what_leaves_the_standings_alone_leaves_the_version(self, store: BoardStore) -> None:
        submit(store, make_record("Ada", lap(8000)), at(0))
        before = version(store)
        assert not submit(store, make_record("Ada", lap(9000), model="slower"), at(1)).improved
        assert submit(store, make_record("Ada", lap(8000)), at(0)).duplicate
        assert store.remove_entry(TRACK, "nobody") is None
        assert version(store) == before

    # ---- copies, moderation, audit and aliases ----------------------------------------------

    def test_a_copied_run_under_another_racer_is_refused_and_writes_nothing(
            self, store: BoardStore) -> None:
        original = make_record("Ada", lap(9000))
        submit(store, original, at(0))
        with pytest.raises(FingerprintTaken) as refused:
            submit(store, copy_of(original, "Bob"), at(1))
        assert refused.value.racer_key == "ada"
        assert store.get_entry(TRACK, "bob") is None
        assert store.history("bob") == [] and participants(store) == 1

    def test_the_same_racer_may_push_their_evaluation_in_another_run(self, store: BoardStore) -> None:
        original = make_record("Ada", lap(9000), model="m1")
        submit(store, original, at(0))
        assert not submit(store, make_record("Ada", lap(9000), model="m2"), at(1)).duplicate

    def test_a_push_appends_its_audit_event_in_the_same_write(self, store: BoardStore) -> None:
        board = make_board()
        store.create_board(board)
        record = make_record("Ada", lap(9000))
        submission, entry = write_for(record, board, at(0))
        store.record_submission(submission, record.model_dump_json(), entry, audit=event(0))
        assert [e.action for e in store.audit(TRACK, None, 10).events] == ["push"]

    def test_the_audit_trail_pages_in_time_order(self, store: BoardStore) -> None:
        store.create_board(make_board())
        for n in (2, 0, 1, 3, 4):
            store.append_audit(event(n))
        first = store.audit(TRACK, None, 3)
        assert [e.at for e in first.events] == [at(0), at(1), at(2)]
        rest = store.audit(TRACK, first.after, 3)
        assert [e.at for e in rest.events] == [at(3), at(4)] and rest.after is None
        assert store.audit("elsewhere", None, 3).events == []

    def test_remove_and_restore_an_entry_keep_the_submissions(self, store: BoardStore) -> None:
        submit(store, make_record("Ada", lap(9000)), at(0))
        submit(store, make_record("Bob", lap(9500)), at(1))
        removed = store.remove_entry(TRACK, "ada")
        assert removed is not None and removed.racer == "Ada"
        assert [e.racer for e in store.top(TRACK, 10)] == ["Bob"] and participants(store) == 1
        assert len(store.history("ada", TRACK)) == 1
        assert store.remove_entry(TRACK, "ada") is None
        store.restore_entry(removed)
        store.restore_entry(removed)
        assert [e.racer for e in store.top(TRACK, 10)] == ["Ada", "Bob"] and participants(store) == 2

    def test_an_alias_is_claimed_once_by_one_sign_in(self, store: BoardStore) -> None:
        assert store.claim_alias(claim("Ada", "cognito:1")).principal == "cognito:1"
        assert store.claim_alias(claim("Ada", "cognito:1")).alias == "Ada", "claiming again is fine"
        with pytest.raises(AliasConflict) as taken:
            store.claim_alias(claim("Ada", "cognito:2"))
        assert taken.value.holder.principal == "cognito:1"
        with pytest.raises(AliasConflict):
            store.claim_alias(claim("Ada2", "cognito:1"))
        assert store.alias_of("cognito:2") is None
        assert store.alias_holder("ada2") is None
        holder = store.alias_holder("ada")
        assert holder is not None and holder.principal == "cognito:1"
        mine = store.alias_of("cognito:1")
        assert mine is not None and mine.alias == "Ada"

    # ---- bulk import ------------------------------------------------------------------------

    def test_an_import_batch_writes_as_its_submissions_one_by_one_would(self, store: BoardStore) -> None:
        board = make_board()
        submit(store, make_record("Cy", lap(9000)), at(0))
        records = [make_record("Ada", lap(12000)), make_record("Bob", lap(11000)),
                   make_record("Ada", lap(10000), model="m2"), make_record("Ada", lap(13000), model="m3"),
                   make_record("Cy", lap(9500), model="m2")]
        rows = [imported_row(record, board, at(10 + n)) for n, record in enumerate(records)]
        runs = [IndexedRun(p.fingerprint, p.lane, tuple(p.laps_ms) if p.laps_ms else None,
                           row.racer_key, row.submitted_at, row.submission_id)
                for record, row in zip(records, rows, strict=True) for p in run_prints(record)]
        batch = ImportBatch(rows=[*rows, rows[1]], fingerprints=[("f-ada", "ada"), ("f-bob", "bob")],
                            skeletons=[("ada", "ada")], runs=runs, audit=[event(10, "import")])
        written = store.import_batch(TRACK, batch)
        assert written == ImportWritten(created=5, improved=2)  # Ada's first entry, then her best
        assert [(e.racer, e.score.best_lap_ms) for e in store.top(TRACK, 10)] == [
            ("Cy", 9000), ("Ada", 10000), ("Bob", 11000)]
        assert ranks_by_count(store) == ranks_by_listing(store) and participants(store) == 3
        assert len(store.history("ada", TRACK)) == 3 and store.tally(TRACK, "ada").submissions == 3
        assert store.present_submissions(TRACK, [("ada", r.submission_id) for r in records[:1]]
                                         + [("bob", "0" * 64)]) == {records[0].submission_id}
        assert store.holders(TRACK, ["f-ada", "f-bob", "f-none"], ["ada", "bob"]) == (
            {"f-ada": "ada", "f-bob": "bob"}, {"ada": "ada"})
        fingerprint = runs[0].fingerprint
        assert [a.racer_key for a in store.authors_of([fingerprint, "unknown"])[fingerprint]] == ["ada"]
        assert [e.action for e in store.audit(TRACK, None, 10).events] == ["import"]
        again = store.import_batch(TRACK, batch)
        assert again == ImportWritten(created=0, improved=0)
        assert participants(store) == 3
        store.hand_over_skeleton(TRACK, "ada", "bob")
        assert store.holders(TRACK, [], ["ada", "bob"]) == ({}, {"ada": "bob"})

    def test_an_import_batch_indexes_runs_for_near_copies(self, store: BoardStore) -> None:
        board = make_board()
        store.create_board(board)
        record = make_record("Ada", [(9000, 100), (9100, 100), (9200, 100)])
        row = imported_row(record, board, at(1))
        [run] = run_prints(record)
        assert run.laps_ms is not None
        store.import_batch(TRACK, ImportBatch(rows=[row], fingerprints=[], skeletons=[], audit=[],
                                              runs=[IndexedRun(run.fingerprint, run.lane,
                                                               tuple(run.laps_ms), "ada",
                                                               row.submitted_at, row.submission_id)]))
        near = store.near_runs(run.lane, 9003, 5)
        assert [(n.racer_key, n.laps_ms) for n in near] == [("ada", [9000, 9100, 9200])]
        assert store.lane_runs(run.lane) == near and store.lane_runs("elsewhere") == []

    def test_an_import_batch_needs_its_board(self, store: BoardStore) -> None:
        row = imported_row(make_record("Ada"), make_board(), at(1))
        with pytest.raises(KeyError):
            store.import_batch(TRACK, ImportBatch(rows=[row], fingerprints=[], skeletons=[],
                                                  runs=[], audit=[]))

    # ---- webhooks and announcements' sent markers ----------------------------------------------

    def test_webhooks_are_kept_per_target_oldest_first_with_their_whole_url(self, store: BoardStore) -> None:
        board, other = Target(target_id=TRACK), Target(target_id=TRACK + "_cw")
        season = Target(kind="season", target_id=TRACK)
        store.put_webhook(webhook("b2", board, created=2))
        store.put_webhook(webhook("b1", board, created=1, url="https://hooks.slack.com/services/T/B/x"))
        store.put_webhook(webhook("o1", other))
        store.put_webhook(webhook("s1", season))
        assert [w.webhook_id for w in store.webhooks(board.key)] == ["b1", "b2"]
        assert store.webhooks(board.key)[0].url == "https://hooks.slack.com/services/T/B/x"
        assert [w.webhook_id for w in store.webhooks(other.key)] == ["o1"]
        assert [w.webhook_id for w in store.webhooks(season.key)] == ["s1"], "a season's are its own"
        assert store.webhooks(Target(target_id="nowhere").key) == []
        assert sorted(w.webhook_id for w in store.all_webhooks()) == ["b1", "b2", "o1", "s1"]

    def test_putting_a_webhook_again_replaces_it(self, store: BoardStore) -> None:
        store.put_webhook(webhook("b1"))
        store.put_webhook(webhook("b1").model_copy(update={"events": ["top-3"]}))
        (stored,) = store.webhooks(Target(target_id=TRACK).key)
        assert stored.events == ["top-3"]

    def test_removing_a_webhook_answers_it_once(self, store: BoardStore) -> None:
        target = Target(target_id=TRACK)
        store.put_webhook(webhook("b1", target))
        store.put_webhook(webhook("b2", target, created=1))
        removed = store.delete_webhook(target.key, "b1")
        assert removed is not None and removed.url == "https://discord.com/api/webhooks/1/s3cr3t"
        assert store.delete_webhook(target.key, "b1") is None
        assert store.delete_webhook(Target(target_id="other").key, "b2") is None, "only its target's"
        assert [w.webhook_id for w in store.webhooks(target.key)] == ["b2"]

    def test_a_delivery_is_noted_on_its_webhook_and_a_success_clears_the_error(
            self, store: BoardStore) -> None:
        target = Target(target_id=TRACK)
        store.put_webhook(webhook("b1", target))
        store.note_delivery(target.key, "b1", at(10), "the service answered 404 Not Found" + "!" * 400)
        (failed,) = store.webhooks(target.key)
        assert failed.last_error is not None and failed.last_error.startswith("the service answered 404")
        assert len(failed.last_error) == MAX_ERROR_CHARS and failed.last_error_at == at(10)
        assert failed.last_sent_at is None
        store.note_delivery(target.key, "b1", at(20), None)
        (sent,) = store.webhooks(target.key)
        assert (sent.last_sent_at, sent.last_error, sent.last_error_at) == (at(20), None, None)

    def test_a_delivery_noted_after_its_webhook_was_removed_brings_nothing_back(
            self, store: BoardStore) -> None:
        target = Target(target_id=TRACK)
        store.put_webhook(webhook("b1", target))
        store.delete_webhook(target.key, "b1")
        store.note_delivery(target.key, "b1", at(10), "timed out")
        assert store.webhooks(target.key) == [] and store.all_webhooks() == []

    def test_an_event_is_claimed_for_a_webhook_once_until_sent(self, store: BoardStore) -> None:
        assert store.claim_notice("club#entry#s1", "b1", at(0), 120) is True
        assert store.claim_notice("club#entry#s1", "b1", at(60), 120) is False, "being sent"
        assert store.claim_notice("club#entry#s1", "b2", at(60), 120) is True, "per webhook"
        assert store.claim_notice("club#entry#s2", "b1", at(60), 120) is True, "per event"
        store.finish_notice("club#entry#s1", "b1", sent=True)
        assert store.claim_notice("club#entry#s1", "b1", at(10_000), 120) is False, "sent: never again"

    def test_a_failed_event_or_a_lapsed_lease_may_be_claimed_again(self, store: BoardStore) -> None:
        assert store.claim_notice("club#open#1", "b1", at(0), 120)
        store.finish_notice("club#open#1", "b1", sent=False)
        assert store.claim_notice("club#open#1", "b1", at(1), 120) is True, "the next try takes it"
        assert store.claim_notice("club#open#1", "b1", at(100), 120) is False
        assert store.claim_notice("club#open#1", "b1", at(121), 120) is True, \
            "a sender that died after claiming holds it for its lease only"
