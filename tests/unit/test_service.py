"""LeaderboardService on a SQLite store: boards, ranks, history, paging and its typed errors."""

from __future__ import annotations

import base64
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from drboard_assembler.record import RaceType
from drboard_functions.errors import (
    BoardMismatch,
    BoardNotFound,
    InvalidQuery,
    RacerNotFound,
)
from drboard_functions.service import LeaderboardService, board_for_track
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import LapSpec, make_record

TRACK = "reInvent2019_track"
T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)


class Clock:
    """Each call is one second after the previous one."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self) -> datetime:
        self.calls += 1
        return T0 + timedelta(seconds=self.calls)


def at(call: int) -> datetime:
    return T0 + timedelta(seconds=call)


@pytest.fixture
def store(tmp_path: Path) -> Iterator[SqliteStore]:
    store = SqliteStore(tmp_path / "board.db")
    yield store
    store.close()


@pytest.fixture
def service(store: SqliteStore) -> LeaderboardService:
    return LeaderboardService(store, clock=Clock())


def lap(ms: int) -> list[LapSpec]:
    return [(ms, 100)]


def standings(service: LeaderboardService, board_id: str = TRACK) -> list[tuple[int, str]]:
    return [(e.rank, e.racer) for e in service.board_page(board_id, limit=500).entries]


# ---- push -------------------------------------------------------------------------------------


def test_first_push_creates_the_board_and_the_entry(service: LeaderboardService) -> None:
    record = make_record("Ada", [(12000, 100), (13000, 100), (4000, 30)], model="fast-one")
    receipt = service.push(record)
    assert receipt.status == "created"
    assert receipt.board_id == TRACK
    assert receipt.submission_id == record.submission_id
    assert receipt.improved is True
    assert (receipt.rank, receipt.participants) == (1, 1)
    entry = receipt.entry
    assert (entry.racer, entry.model_name, entry.time_ms, entry.gap_ms) == ("Ada", "fast-one", 12000, 0)
    assert (entry.laps_completed, entry.best_lap_ms, entry.best_completion_pct) == (2, 12000, 100.0)
    assert entry.submitted_at == at(1)
    assert entry.design.actions == 3 and entry.design.max_speed == 3.0
    assert receipt.submission.is_best is True
    boards = service.boards()
    assert [(b.board_id, b.track_name, b.participants, b.title) for b in boards] == [
        (TRACK, "Smile Speedway", 1, "Smile Speedway")]


def test_pushing_the_same_record_again_is_a_duplicate(service: LeaderboardService) -> None:
    record = make_record("Ada", lap(12000))
    first = service.push(record)
    again = service.push(record)
    assert again.status == "duplicate"
    assert again.improved is False
    assert (again.rank, again.participants) == (1, 1)
    assert again.entry == first.entry
    assert len(service.history("Ada")) == 1
    assert standings(service) == [(1, "Ada")]


def test_a_worse_run_keeps_the_best_and_is_in_history(service: LeaderboardService) -> None:
    best = make_record("Ada", lap(12000), model="m1")
    worse = make_record("Ada", lap(12900), model="m2")
    service.push(best)
    receipt = service.push(worse)
    assert (receipt.status, receipt.improved) == ("created", False)
    assert receipt.entry.submission_id == best.submission_id
    assert receipt.entry.time_ms == 12000
    assert receipt.submission.is_best is False
    assert receipt.submission.time_ms == 12900
    history = service.history("Ada")
    assert [(h.submission_id, h.is_best, h.time_ms) for h in history] == [
        (best.submission_id, True, 12000), (worse.submission_id, False, 12900)]
    view = service.racer(TRACK, "Ada")
    assert view.record == best
    assert [h.is_best for h in view.history] == [True, False]


def test_a_better_run_replaces_the_entry(service: LeaderboardService) -> None:
    service.push(make_record("Bob", lap(11500)))
    service.push(make_record("Ada", lap(12000), model="m1"))
    better = make_record("Ada", lap(11000), model="m2")
    receipt = service.push(better)
    assert (receipt.status, receipt.improved, receipt.rank, receipt.participants) == (
        "created", True, 1, 2)
    assert receipt.entry.submission_id == better.submission_id
    assert receipt.entry.model_name == "m2"
    assert receipt.entry.submitted_at == at(3)
    assert [h.is_best for h in service.history("Ada")] == [False, True]
    assert standings(service) == [(1, "Ada"), (2, "Bob")]
    assert service.racer(TRACK, "Ada").record == better


def test_ties_share_the_rank_and_the_earlier_achievement_is_listed_first(
        service: LeaderboardService) -> None:
    service.push(make_record("Zed", lap(12000)))
    receipt = service.push(make_record("Amy", lap(12000)))
    service.push(make_record("Bob", lap(11000)))
    service.push(make_record("Cy", lap(13000)))
    assert receipt.rank == 1
    assert standings(service) == [(1, "Bob"), (2, "Zed"), (2, "Amy"), (4, "Cy")]
    assert service.racer(TRACK, "Amy").entry.rank == 2


def test_non_qualified_racers_rank_below_all_qualified_by_completion(
        service: LeaderboardService) -> None:
    service.push(make_record("Beginner", [(9000, 45.0), (9000, 62.5)]))
    service.push(make_record("Slow", lap(300_000)))
    service.push(make_record("Almost", [(9000, 99.0)]))
    service.push(make_record("Fast", lap(11000)))
    receipt = service.push(make_record("Also62", [(9000, 62.5)]))
    assert (receipt.rank, receipt.participants) == (4, 5)
    page = service.board_page(TRACK)
    assert [(e.rank, e.racer, e.qualified) for e in page.entries] == [
        (1, "Fast", True), (2, "Slow", True), (3, "Almost", False), (4, "Beginner", False),
        (4, "Also62", False)]
    assert [e.best_completion_pct for e in page.entries[2:]] == [99.0, 62.5, 62.5]
    assert all(e.time_ms is None and e.gap_ms is None for e in page.entries[2:])


def test_gap_to_the_leader(service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(12345)))
    service.push(make_record("Bob", lap(11000)))
    receipt = service.push(make_record("Cy", lap(15000)))
    assert receipt.entry.gap_ms == 4000
    page = service.board_page(TRACK)
    assert [(e.racer, e.gap_ms) for e in page.entries] == [("Bob", 0), ("Ada", 1345), ("Cy", 4000)]
    assert service.racer(TRACK, "Ada").entry.gap_ms == 1345
    # on a later page the gap is still to the board's leader
    second = service.board_page(TRACK, limit=2, cursor=service.board_page(TRACK, limit=2).next_cursor)
    assert [(e.racer, e.gap_ms) for e in second.entries] == [("Cy", 4000)]


def test_gap_is_none_when_the_leader_has_not_qualified(service: LeaderboardService) -> None:
    service.push(make_record("Ada", [(9000, 80.0)]))
    assert service.board_page(TRACK).entries[0].gap_ms is None


# ---- board pages ------------------------------------------------------------------------------


def test_paging_across_a_tie_at_the_page_boundary_keeps_shared_ranks(
        service: LeaderboardService) -> None:
    times = [("A", 10000), ("B", 11000), ("C", 11000), ("D", 11000), ("E", 12000), ("F", 12000),
             ("G", 13000)]
    for racer, ms in times:
        service.push(make_record(racer, lap(ms)))
    expected = [(1, "A"), (2, "B"), (2, "C"), (2, "D"), (5, "E"), (5, "F"), (7, "G")]
    assert standings(service) == expected
    seen: list[tuple[int, str]] = []
    cursor: str | None = None
    pages = 0
    while True:
        page = service.board_page(TRACK, limit=2, cursor=cursor)
        pages += 1
        seen += [(e.rank, e.racer) for e in page.entries]
        assert page.board.participants == 7
        cursor = page.next_cursor
        if cursor is None:
            break
    assert seen == expected
    assert pages == 4


def test_a_full_last_page_leads_to_an_empty_one(service: LeaderboardService) -> None:
    for n in range(4):
        service.push(make_record(f"R{n}", lap(12000 + n)))
    first = service.board_page(TRACK, limit=2)
    second = service.board_page(TRACK, limit=2, cursor=first.next_cursor)
    assert [e.rank for e in second.entries] == [3, 4]
    assert second.next_cursor is not None
    last = service.board_page(TRACK, limit=2, cursor=second.next_cursor)
    assert (last.entries, last.next_cursor) == ([], None)
    assert service.board_page(TRACK, limit=5).next_cursor is None


@pytest.mark.parametrize("cursor", [
    "not a cursor!",
    "e30",  # {}
    base64.urlsafe_b64encode(b'[1, 2, 3, 4]').decode(),
    base64.urlsafe_b64encode(b'["a", "b", 1]').decode(),
    base64.urlsafe_b64encode(b"null").decode(),
    base64.urlsafe_b64encode(b"\xff\xfe").decode(),
    "é",
])
def test_a_bad_cursor_is_an_invalid_query(service: LeaderboardService, cursor: str) -> None:
    service.push(make_record("Ada"))
    with pytest.raises(InvalidQuery):
        service.board_page(TRACK, cursor=cursor)


@pytest.mark.parametrize("depth", [700, 100_000])
def test_a_deeply_nested_cursor_is_an_invalid_query(service: LeaderboardService, depth: int) -> None:
    # json.loads raises RecursionError, not ValueError, on deep nesting: still a 400, never a 500
    service.push(make_record("Ada"))
    cursor = base64.urlsafe_b64encode(b"[" * depth + b"]" * depth).decode()
    with pytest.raises(InvalidQuery):
        service.board_page(TRACK, cursor=cursor)


@pytest.mark.parametrize("limit", [0, -1, 501])
def test_a_limit_out_of_range_is_an_invalid_query(service: LeaderboardService, limit: int) -> None:
    service.push(make_record("Ada"))
    with pytest.raises(InvalidQuery):
        service.board_page(TRACK, limit=limit)


@pytest.mark.parametrize("limit", [1, 500])
def test_limits_at_the_bounds_are_accepted(service: LeaderboardService, limit: int) -> None:
    service.push(make_record("Ada"))
    assert len(service.board_page(TRACK, limit=limit).entries) == 1


def test_an_unknown_board_page_is_board_not_found(service: LeaderboardService) -> None:
    with pytest.raises(BoardNotFound):
        service.board_page("nowhere")


# ---- which board ------------------------------------------------------------------------------


def test_a_clockwise_run_goes_to_the_clockwise_board(service: LeaderboardService) -> None:
    receipt = service.push(make_record("Ada", lap(12000), direction="cw"))
    assert receipt.board_id == "reInvent2019_track_cw"
    ccw = service.push(make_record("Bob", lap(12000), direction="ccw"))
    plain = service.push(make_record("Cy", lap(12000)))
    assert ccw.board_id == plain.board_id == TRACK
    views = {b.board_id: b for b in service.boards()}
    assert views["reInvent2019_track_cw"].direction == "cw"
    assert views["reInvent2019_track_cw"].title == "Smile Speedway (clockwise)"
    assert (views[TRACK].participants, views["reInvent2019_track_cw"].participants) == (2, 1)


def test_an_object_avoidance_run_goes_to_its_own_board(service: LeaderboardService) -> None:
    receipt = service.push(make_record("Ada", race_type=RaceType.OBJECT_AVOIDANCE))
    assert receipt.board_id == "reInvent2019_track_oa"
    cw = service.push(make_record("Ada", race_type=RaceType.OBJECT_AVOIDANCE, direction="cw"))
    assert cw.board_id == "reInvent2019_track_cw_oa"
    view = service.board_page("reInvent2019_track_oa").board
    assert view.race_type == RaceType.OBJECT_AVOIDANCE


def test_a_push_to_another_tracks_board_is_refused(service: LeaderboardService) -> None:
    service.push(make_record("Ada", track="Oval_track"))
    with pytest.raises(BoardMismatch):
        service.push(make_record("Bob"), board_id="Oval_track")
    assert standings(service, "Oval_track") == [(1, "Ada")]
    with pytest.raises(BoardNotFound):
        service.board_page(TRACK)  # nothing was created for the refused run


def test_a_push_in_the_wrong_direction_or_race_type_is_refused(service: LeaderboardService) -> None:
    service.push(make_record("Ada", direction="cw"))
    service.push(make_record("Ada"))
    with pytest.raises(BoardMismatch):
        service.push(make_record("Bob"), board_id="reInvent2019_track_cw")
    with pytest.raises(BoardMismatch):
        service.push(make_record("Bob", direction="cw"), board_id=TRACK)
    with pytest.raises(BoardMismatch):
        service.push(make_record("Bob", race_type=RaceType.OBJECT_AVOIDANCE), board_id=TRACK)


def test_a_push_to_an_existing_matching_board_by_id(service: LeaderboardService) -> None:
    service.push(make_record("Ada"))
    assert service.push(make_record("Bob", direction="ccw"), board_id=TRACK).participants == 2


def test_a_push_to_an_unknown_board_is_board_not_found(service: LeaderboardService) -> None:
    with pytest.raises(BoardNotFound):
        service.push(make_record("Ada"), board_id="spring_cup")
    assert service.boards() == []


def test_a_custom_track_gets_its_own_board(service: LeaderboardService) -> None:
    receipt = service.push(make_record("Ada", track="garage_loop"))
    assert receipt.board_id == "custom.garage_loop"
    view = service.boards()[0]
    assert (view.track, view.track_name, view.title) == ("garage_loop", "garage_loop", "garage_loop")


# ---- racers and history -----------------------------------------------------------------------


def test_racer_lookup_ignores_case_and_spacing(service: LeaderboardService) -> None:
    service.push(make_record("Ada Lovelace", lap(12000)))
    view = service.racer(TRACK, "  ada   LOVELACE ")
    assert view.racer == "Ada Lovelace"
    assert view.entry.rank == 1
    assert len(view.history) == 1
    assert [h.time_ms for h in service.history("ADA LOVELACE")] == [12000]
    # the same racer under another spelling improves the same entry
    receipt = service.push(make_record("ada lovelace", lap(11000)))
    assert (receipt.improved, receipt.participants) == (True, 1)
    assert len(service.racer(TRACK, "Ada Lovelace").history) == 2


def test_an_unknown_racer_is_racer_not_found(service: LeaderboardService) -> None:
    service.push(make_record("Ada"))
    with pytest.raises(RacerNotFound):
        service.racer(TRACK, "Bob")
    with pytest.raises(BoardNotFound):
        service.racer("nowhere", "Ada")


def test_racer_view_is_the_board_rank_history_and_best_record(service: LeaderboardService) -> None:
    service.push(make_record("Bob", lap(11000)))
    best = make_record("Ada", lap(12000), model="m1")
    service.push(best)
    service.push(make_record("Ada", lap(12500), model="m2"))
    service.push(make_record("Ada", lap(11500), direction="cw"))  # another board
    view = service.racer(TRACK, "ada")
    assert (view.board.board_id, view.entry.rank, view.entry.gap_ms) == (TRACK, 2, 1000)
    assert [h.model_name for h in view.history] == ["m1", "m2"]
    assert view.record == best


def test_history_spans_boards_oldest_first(service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(12000)))
    service.push(make_record("Ada", lap(11000), direction="cw"))
    service.push(make_record("Ada", lap(11500)))
    service.push(make_record("Ada", lap(11800), direction="cw"))
    items = service.history("Ada")
    assert [(h.board_id, h.time_ms, h.is_best) for h in items] == [
        (TRACK, 12000, False), ("reInvent2019_track_cw", 11000, True), (TRACK, 11500, True),
        ("reInvent2019_track_cw", 11800, False)]
    assert [h.submitted_at for h in items] == [at(1), at(2), at(3), at(4)]
    assert [h.time_ms for h in service.history("Ada", "reInvent2019_track_cw")] == [11000, 11800]
    assert service.history("Nobody") == []


# ---- board_for_track --------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "board"), [
    ("reInvent2019_track", "reInvent2019_track"),
    ("reInvent2019", "reInvent2019_track"),
    ("reinvent2019_track", "reInvent2019_track"),
    ("Smile Speedway", "reInvent2019_track"),
    ("  smile speedway ", "reInvent2019_track"),
    ("reInvent2019_track_cw", "reInvent2019_track_cw"),
    ("reInvent2019_track_ccw", "reInvent2019_track"),
    ("Oval_track", "Oval_track"),
    # a default board's id as a push prints it
    ("Belille_oa", "Belille_oa"),
    ("reInvent2019_cw_h2b", "reInvent2019_track_cw_h2b"),
])
def test_board_for_track_resolves_aliases(name: str, board: str) -> None:
    assert board_for_track(name) == board


def test_board_for_track_direction_and_race_type() -> None:
    assert board_for_track("Smile Speedway", clockwise=True) == "reInvent2019_track_cw"
    assert board_for_track("reInvent2019", RaceType.OBJECT_AVOIDANCE) == "reInvent2019_track_oa"
    assert board_for_track("reInvent2019_track_cw", RaceType.OBJECT_AVOIDANCE) == (
        "reInvent2019_track_cw_oa")


def test_board_for_track_refuses_an_ambiguous_name() -> None:
    with pytest.raises(InvalidQuery, match="reInvent2019_track"):
        board_for_track("reInvent")
