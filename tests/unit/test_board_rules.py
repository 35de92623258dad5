"""Named boards and their rules, through LeaderboardService, on both stores (SQLite and DynamoDB
on moto): windows, cooldowns, maximum submissions, timing methods, racer status, managing
boards, and export then import."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path

import boto3
import pytest
from drboard_functions.errors import (
    BoardClosed,
    BoardExists,
    BoardLocked,
    BoardMismatch,
    BoardNotFound,
    InvalidQuery,
    RacerNotFound,
    SubmissionLimitReached,
    TooSoon,
)
from drboard_functions.models.domain import BoardStatus, TimingMethod
from drboard_functions.models.requests import BoardChanges, BoardSpec, ImportedSubmission
from drboard_functions.models.transfer import ExportedBoard, ExportedEntry, ExportedSubmission
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.base import BoardStore
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.sqlite import SqliteStore
from moto import mock_aws

from tests.recordkit import LapSpec, make_record
from tests.tablekit import create_board_table

T0 = datetime(2026, 12, 1, 18, 0, tzinfo=UTC)
TRACK = "reInvent2019_track"
RACE = "club-finals"


class Clock:
    """A clock the test moves by hand."""

    def __init__(self) -> None:
        self.now = T0

    def __call__(self) -> datetime:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += timedelta(seconds=seconds)


def new_store(kind: str, tmp_path: Path) -> Iterator[BoardStore]:
    if kind == "sqlite":
        store = SqliteStore(tmp_path / "board.db")
        yield store
        store.close()
        return
    with mock_aws():
        client = boto3.client("dynamodb", region_name="us-east-1")
        yield DynamoDbStore(create_board_table(client, f"boards-{uuid.uuid4().hex[:8]}"), client)


@pytest.fixture(params=["sqlite", "dynamodb"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[BoardStore]:
    yield from new_store(request.param, tmp_path)


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def service(store: BoardStore, clock: Clock) -> LeaderboardService:
    return LeaderboardService(store, clock=clock)


def spec(**fields: object) -> BoardSpec:
    return BoardSpec.model_validate({"board_id": RACE, "title": "Club finals",
                                     "track": "reInvent2019"} | fields)


def run(racer: str, *laps_ms: int, model: str = "m1") -> object:
    return make_record(racer, [(ms, 100) for ms in laps_ms], model=model)


def laps(racer: str, specs: list[LapSpec], model: str = "m1") -> object:
    return make_record(racer, specs, model=model)


def standings(service: LeaderboardService, board_id: str = RACE) -> list[tuple[int, str, int | None]]:
    return [(e.rank, e.racer, e.time_ms) for e in service.board_page(board_id).entries]


# ---- creating named boards ----------------------------------------------------------------------


def test_a_named_board_takes_its_settings_and_resolves_the_track(service: LeaderboardService) -> None:
    view = service.create_board(spec(track="Smile Speedway", method="AVG_LAP_TIME",
                                     closes_at="2026-12-02T18:00:00+01:00", cooldown_s=1800,
                                     max_submissions=5, description="Final of the season"))
    assert (view.board_id, view.kind, view.track, view.method, view.min_laps) == (
        RACE, "named", TRACK, TimingMethod.AVG_LAP_TIME, 3)
    assert view.closes_at == datetime(2026, 12, 2, 17, 0, tzinfo=UTC)
    assert (view.status, view.cooldown_s, view.max_submissions) == (BoardStatus.OPEN, 1800, 5)
    assert [b.board_id for b in service.boards()] == [RACE]


def test_a_board_id_is_taken_once(service: LeaderboardService) -> None:
    service.create_board(spec())
    with pytest.raises(BoardExists):
        service.create_board(spec(title="Another"))


@pytest.mark.parametrize("board_id", ["reInvent2019_track", "reInvent2019_track_cw", "Oval_track_oa"])
def test_a_tracks_default_board_id_is_not_a_named_board(service: LeaderboardService,
                                                         board_id: str) -> None:
    with pytest.raises(BoardExists, match="default board"):
        service.create_board(spec(board_id=board_id))


def test_an_unknown_track_is_refused_unless_custom(service: LeaderboardService) -> None:
    with pytest.raises(InvalidQuery, match="custom_track"):
        service.create_board(spec(track="Garage Loop"))
    view = service.create_board(spec(track="Garage Loop", custom_track=True))
    assert view.track == "Garage Loop"


def test_a_window_must_close_after_it_opens(service: LeaderboardService) -> None:
    with pytest.raises(InvalidQuery, match="closes_at must be after opens_at"):
        service.create_board(spec(opens_at="2026-12-02T00:00:00Z", closes_at="2026-12-01T00:00:00Z"))


def test_times_without_a_time_zone_are_refused() -> None:
    with pytest.raises(ValueError, match="time zone"):
        spec(opens_at="2026-12-02T00:00:00")


# ---- pushing to a named board -------------------------------------------------------------------


def test_a_push_by_board_id_ranks_on_the_named_board(service: LeaderboardService) -> None:
    service.create_board(spec())
    receipt = service.push(run("Ada", 12000), RACE)
    assert (receipt.board_id, receipt.rank, receipt.participants) == (RACE, 1, 1)
    assert standings(service) == [(1, "Ada", 12000)]
    with pytest.raises(BoardNotFound):
        service.board_page(TRACK)  # the track's default board was not touched


def test_a_run_on_another_track_is_refused_by_a_named_board(service: LeaderboardService) -> None:
    service.create_board(spec())
    with pytest.raises(BoardMismatch):
        service.push(make_record("Ada", track="Oval_track"), RACE)


def test_an_upcoming_board_refuses_pushes(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(opens_at="2026-12-01T19:00:00Z"))
    assert service.boards()[0].status is BoardStatus.UPCOMING
    with pytest.raises(BoardClosed, match="not open yet: it opens at 2026-12-01 19:00 UTC"):
        service.push(run("Ada", 12000), RACE)
    assert service.board_page(RACE).entries == []
    clock.advance(3600)
    assert service.boards()[0].status is BoardStatus.OPEN
    assert service.push(run("Ada", 12000), RACE).status == "created"


def test_a_closed_board_refuses_new_runs_but_answers_duplicates(service: LeaderboardService,
                                                               clock: Clock) -> None:
    service.create_board(spec(closes_at="2026-12-01T19:00:00Z"))
    first = run("Ada", 12000)
    service.push(first, RACE)
    clock.advance(3600)
    assert service.boards()[0].status is BoardStatus.CLOSED
    with pytest.raises(BoardClosed, match="closed at 2026-12-01 19:00 UTC"):
        service.push(run("Ada", 11000), RACE)
    assert service.push(first, RACE).status == "duplicate"
    assert standings(service) == [(1, "Ada", 12000)]


def test_a_push_inside_the_cooldown_says_when_to_retry(service: LeaderboardService,
                                                      clock: Clock) -> None:
    service.create_board(spec(cooldown_s=1800))
    service.push(run("Ada", 12000), RACE)
    clock.advance(600)
    with pytest.raises(TooSoon) as refused:
        service.push(run("Ada", 11000), RACE)
    assert refused.value.retry_after_s == 1200
    assert "one submission every 30 min per racer" in refused.value.message
    assert "18:30 UTC" in refused.value.message
    assert [h.time_ms for h in service.history("Ada", RACE)] == [12000]
    assert service.push(run("Bob", 13000), RACE).status == "created"  # the cooldown is per racer
    clock.advance(1200)
    assert service.push(run("Ada", 11000), RACE).improved


def test_the_maximum_of_submissions_per_racer(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(max_submissions=2))
    service.push(run("Ada", 12000), RACE)
    service.push(run("Ada", 11500), RACE)
    with pytest.raises(SubmissionLimitReached, match="all 2 submissions"):
        service.push(run("Ada", 11000), RACE)
    assert service.push(run("Ada", 11500), RACE).status == "duplicate"  # never counts
    assert standings(service) == [(1, "Ada", 11500)]


def test_a_duplicate_does_not_start_a_cooldown(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(cooldown_s=60))
    first = run("Ada", 12000)
    service.push(first, RACE)
    clock.advance(61)
    assert service.push(first, RACE).status == "duplicate"
    assert service.push(run("Ada", 11000), RACE).status == "created"


# ---- timing methods on named boards -------------------------------------------------------------

# Three racers' runs, ranked by each method (min_laps 3 for AVG and TOTAL):
#   Ada:  10.0 11.0 15.0 14.0        best 10.0, avg of best 3 consecutive 12.0 (10,11,15), total 36.0
#   Bob:  11.5 11.5 11.5             best 11.5, avg 11.5, total 34.5
#   Cy:    9.0 off   12.0 12.0 12.0  best 9.0, avg 12.0 (12,12,12), total: lap 2 off track, no
RUNS: dict[str, list[LapSpec]] = {
    "Ada": [(10000, 100), (11000, 100), (15000, 100), (14000, 100)],
    "Bob": [(11500, 100), (11500, 100), (11500, 100)],
    "Cy": [(9000, 100), (4000, 35), (12000, 100), (12000, 100), (12000, 100)],
}


@pytest.mark.parametrize(("method", "expected"), [
    ("BEST_LAP_TIME", [(1, "Cy", 9000), (2, "Ada", 10000), (3, "Bob", 11500)]),
    ("AVG_LAP_TIME", [(1, "Bob", 11500), (2, "Ada", 12000), (2, "Cy", 12000)]),
    ("TOTAL_TIME", [(1, "Bob", 34500), (2, "Ada", 36000), (3, "Cy", None)]),
])
def test_the_boards_method_orders_the_same_runs(service: LeaderboardService, clock: Clock,
                                                method: str, expected: list[tuple[int, str, int | None]]
                                                ) -> None:
    service.create_board(spec(method=method))
    for racer, specs in RUNS.items():
        service.push(laps(racer, specs), RACE)
        clock.advance(1)
    assert standings(service) == expected
    qualified = {e.racer: e.qualified for e in service.board_page(RACE).entries}
    assert qualified["Cy"] is (method != "TOTAL_TIME")


def test_min_laps_decides_who_qualifies(service: LeaderboardService) -> None:
    service.create_board(spec(min_laps=4))
    for racer, specs in RUNS.items():
        service.push(laps(racer, specs), RACE)
    entries = service.board_page(RACE).entries
    assert [(e.racer, e.qualified) for e in entries] == [("Cy", True), ("Ada", True), ("Bob", False)]


# ---- racer status and history -------------------------------------------------------------------


def test_status_is_the_latest_submission_rank_gap_and_next_allowed_time(
        service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(cooldown_s=1800, max_submissions=3))
    service.push(run("Bob", 11000), RACE)
    service.push(run("Ada", 12000), RACE)
    clock.advance(1800)
    service.push(run("Ada", 12500, model="m2"), RACE)  # worse: the best stays
    clock.advance(60)
    summary = service.status("ada")
    assert summary.racer == "Ada"
    (status,) = summary.boards
    assert (status.latest.model_name, status.latest.time_ms, status.latest.is_best) == ("m2", 12500, False)
    assert (status.entry.rank, status.entry.time_ms, status.entry.gap_ms) == (2, 12000, 1000)
    assert status.board.participants == 2
    assert (status.submissions, status.submissions_left) == (2, 1)
    assert status.next_submission_at == T0 + timedelta(seconds=3600)
    clock.advance(1800)
    assert service.status("Ada", RACE).boards[0].next_submission_at is None


def test_status_lists_each_board_latest_first(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec())
    service.push(run("Ada", 12000))
    clock.advance(5)
    service.push(run("Ada", 12100), RACE)
    assert [s.board.board_id for s in service.status("Ada").boards] == [RACE, TRACK]
    assert [s.board.board_id for s in service.status("Ada", TRACK).boards] == [TRACK]
    with pytest.raises(RacerNotFound):
        service.status("Nobody")


def test_history_spans_named_and_default_boards(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec())
    service.push(run("Ada", 12000))
    clock.advance(5)
    service.push(run("Ada", 12100), RACE)
    clock.advance(5)
    service.push(run("Ada", 11900))
    history = service.history("Ada")
    assert [(h.board_id, h.time_ms, h.is_best) for h in history] == [
        (TRACK, 12000, False), (RACE, 12100, True), (TRACK, 11900, True)]


# ---- managing boards ----------------------------------------------------------------------------


def test_update_changes_only_the_given_fields(service: LeaderboardService) -> None:
    service.create_board(spec(cooldown_s=60, closes_at="2026-12-02T00:00:00Z"))
    view = service.update_board(RACE, BoardChanges.model_validate({"title": "Finals", "closes_at": None}))
    assert (view.title, view.cooldown_s, view.closes_at) == ("Finals", 60, None)


def test_the_method_changes_only_while_the_board_is_empty(service: LeaderboardService) -> None:
    service.create_board(spec())
    view = service.update_board(RACE, BoardChanges(method=TimingMethod.TOTAL_TIME))
    assert (view.method, view.min_laps) == (TimingMethod.TOTAL_TIME, 3)
    service.push(laps("Ada", RUNS["Ada"]), RACE)
    with pytest.raises(BoardLocked, match="has entries"):
        service.update_board(RACE, BoardChanges(min_laps=2))
    assert service.update_board(RACE, BoardChanges(cooldown_s=30)).cooldown_s == 30


def test_close_closes_now(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(closes_at="2026-12-24T00:00:00Z"))
    view = service.close_board(RACE)
    assert (view.status, view.closes_at) == (BoardStatus.CLOSED, T0)
    with pytest.raises(BoardClosed):
        service.push(run("Ada", 12000), RACE)


def test_closing_an_upcoming_board_never_opens_it(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(opens_at="2026-12-05T00:00:00Z"))
    view = service.close_board(RACE)
    assert view.status is BoardStatus.CLOSED
    clock.advance(10 * 24 * 3600)
    assert service.boards()[0].status is BoardStatus.CLOSED


def test_delete_is_soft_and_restore_brings_the_board_back(service: LeaderboardService) -> None:
    service.create_board(spec())
    service.push(run("Ada", 12000), RACE)
    service.delete_board(RACE)
    assert service.boards() == []
    for read in (lambda: service.board_page(RACE), lambda: service.push(run("Bob", 13000), RACE)):
        with pytest.raises(BoardNotFound, match="drboard board restore club-finals"):
            read()
    assert service.history("Ada") == []
    service.restore_board(RACE)
    assert standings(service) == [(1, "Ada", 12000)]
    assert len(service.history("Ada")) == 1


def test_a_tracks_default_board_cannot_be_managed(service: LeaderboardService) -> None:
    service.push(run("Ada", 12000))
    for change in (lambda: service.close_board(TRACK), lambda: service.delete_board(TRACK),
                   lambda: service.update_board(TRACK, BoardChanges(title="Mine"))):
        with pytest.raises(BoardLocked, match="default board"):
            change()


# ---- export and import --------------------------------------------------------------------------


def export(service: LeaderboardService, board_id: str = RACE) -> list[object]:
    lines: list[object] = []
    cursor = None
    while True:
        page = service.export_page(board_id, cursor)
        lines += page.lines
        if page.next_cursor is None:
            return lines
        cursor = page.next_cursor


def load(service: LeaderboardService, lines: list[object], board_id: str | None = None) -> list[str]:
    statuses = []
    target = board_id
    for line in lines:
        if isinstance(line, ExportedBoard):
            board = line.board.model_copy(update={"board_id": board_id or line.board.board_id})
            target = service.import_board(board)[0].board_id
        elif isinstance(line, ExportedSubmission):
            assert target is not None
            item = ImportedSubmission(submitted_at=line.submission.submitted_at, record=line.record)
            statuses.append(service.import_submission(target, item).status)
    return statuses


def filled_board(service: LeaderboardService, clock: Clock) -> None:
    service.create_board(spec(method="AVG_LAP_TIME", cooldown_s=60))
    for n, (racer, specs) in enumerate(RUNS.items()):
        service.push(laps(racer, specs), RACE)
        clock.advance(61)
        service.push(laps(racer, [*specs[:3], (20000 + n, 100)], model="m2"), RACE)
        clock.advance(61)


def test_export_is_the_board_its_entries_and_every_submission(service: LeaderboardService,
                                                              clock: Clock) -> None:
    filled_board(service, clock)
    lines = export(service)
    assert isinstance(lines[0], ExportedBoard) and lines[0].board.board_id == RACE
    entries = [line.entry.racer for line in lines if isinstance(line, ExportedEntry)]
    assert entries == [racer for _, racer, _ in standings(service)]
    submissions = [line for line in lines if isinstance(line, ExportedSubmission)]
    assert len(submissions) == 6
    assert all(s.record.submission_id == s.submission.submission_id for s in submissions)


@pytest.mark.parametrize("target_kind", ["sqlite", "dynamodb"])
def test_import_rebuilds_the_same_board_anywhere_and_twice_changes_nothing(
        service: LeaderboardService, clock: Clock, tmp_path: Path, target_kind: str) -> None:
    filled_board(service, clock)
    lines = export(service)
    for target_store in new_store(target_kind, tmp_path / "target"):
        target = LeaderboardService(target_store, clock=lambda: T0 + timedelta(days=30))
        assert load(target, lines) == ["created"] * 6
        assert standings(target) == standings(service)
        assert [e.submitted_at for e in target.board_page(RACE).entries] == [
            e.submitted_at for e in service.board_page(RACE).entries]
        assert target.boards()[0].cooldown_s == 60
        assert load(target, lines) == ["duplicate"] * 6
        assert standings(target) == standings(service)
        assert len(target.history("Ada")) == 2


def test_import_under_another_id_and_into_a_closed_board(service: LeaderboardService,
                                                        clock: Clock) -> None:
    filled_board(service, clock)
    service.close_board(RACE)
    lines = export(service)
    assert load(service, lines, board_id="finals-copy") == ["created"] * 6
    assert standings(service, "finals-copy") == standings(service)
    copy = next(b for b in service.boards() if b.board_id == "finals-copy")
    assert (copy.kind, copy.status) == ("named", BoardStatus.CLOSED)


def test_importing_into_an_existing_board_keeps_its_rules(service: LeaderboardService,
                                                          clock: Clock) -> None:
    filled_board(service, clock)
    lines = export(service)
    service.create_board(spec(board_id="best-laps"))
    assert load(service, lines, board_id="best-laps") == ["created"] * 6
    board = next(b for b in service.boards() if b.board_id == "best-laps")
    assert board.method is TimingMethod.BEST_LAP_TIME
    assert standings(service, "best-laps") == [(1, "Cy", 9000), (2, "Ada", 10000), (3, "Bob", 11500)]


def test_a_deleted_board_still_exports(service: LeaderboardService, clock: Clock) -> None:
    filled_board(service, clock)
    service.delete_board(RACE)
    assert len(export(service)) == 1 + 3 + 6


def test_a_bad_export_cursor_is_an_invalid_query(service: LeaderboardService) -> None:
    service.create_board(spec())
    with pytest.raises(InvalidQuery):
        service.export_page(RACE, "not-a-cursor")


def test_null_clears_the_description_cooldown_and_maximum(service: LeaderboardService) -> None:
    service.create_board(spec(description="Bring snacks", cooldown_s=60, max_submissions=3))
    view = service.update_board(RACE, BoardChanges.model_validate(
        {"description": None, "cooldown_s": None, "max_submissions": None}))
    assert (view.description, view.cooldown_s, view.max_submissions) == ("", 0, None)
    with pytest.raises(InvalidQuery, match="title cannot be cleared"):
        service.update_board(RACE, BoardChanges.model_validate({"title": None}))
