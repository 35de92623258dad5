"""Seasons on the embedded board: rounds, standings that follow their boards (pushes,
moderation, bans), the final that refuses non-qualifiers, past seasons, and what a view reads."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from drboard_functions.errors import (
    BoardLocked,
    BoardNotFound,
    InvalidQuery,
    NotQualified,
    SeasonExists,
    SeasonLocked,
    SeasonNotFound,
)
from drboard_functions.models.requests import BoardSpec
from drboard_functions.models.seasons import (
    MAX_ROUNDS,
    FinalSpec,
    PointsTable,
    RoundSpec,
    SeasonChanges,
    SeasonSpec,
    SeasonStandings,
)
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record

T0 = datetime(2026, 1, 10, 19, 0, tzinfo=UTC)
SEASON = "club-2026"


class Clock:
    def __init__(self) -> None:
        self.now = T0

    def __call__(self) -> datetime:
        self.now += timedelta(seconds=1)
        return self.now


class CountingStore(SqliteStore):
    """Counts the boards whose entries are read."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.entries_read: list[str] = []

    def front_page(self, board_id: str, limit: int) -> Any:
        self.entries_read.append(board_id)
        return super().front_page(board_id, limit)


@pytest.fixture
def store(tmp_path: Path) -> Iterator[CountingStore]:
    store = CountingStore(tmp_path / "board.db")
    yield store
    store.close()


@pytest.fixture
def service(store: CountingStore) -> LeaderboardService:
    service = LeaderboardService(store, clock=Clock())
    for board_id in ("jan", "feb", "mar", "final"):
        service.create_board(BoardSpec(board_id=board_id, title=f"{board_id.title()} night",
                                       track="reInvent2019"))
    service.create_season(SeasonSpec(season_id=SEASON, title="Club season 2026"))
    return service


def race(service: LeaderboardService, board_id: str, *racers: str, model: str = "m1") -> None:
    """The racers finish in this order (each a tenth of a second behind the one before)."""
    for n, racer in enumerate(racers):
        service.push(make_record(racer, [(10_000 + 100 * n, 100)], model=f"{model}-{board_id}"), board_id)


def points(standings: SeasonStandings) -> list[tuple[int, str, float]]:
    return [(s.rank, s.racer, s.points) for s in standings.standings]


def test_a_season_adds_up_its_rounds(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo", "Cy")
    race(service, "feb", "Cy", "Ada")
    service.add_round(SEASON, "jan")
    season = service.add_round(SEASON, "feb")
    assert points(season) == [(1, "Ada", 43), (2, "Cy", 40), (3, "Bo", 18)]
    assert [(r.number, r.board_id, r.title, r.participants) for r in season.season.rounds] == [
        (1, "jan", "Jan night", 3), (2, "feb", "Feb night", 2)]
    ada = season.standings[0]
    assert [(s.rank, s.points, s.counted) for s in ada.rounds] == [(1, 25, True), (2, 18, True)]
    assert "round wins" in season.season.tie_breaks


def test_a_pushed_improvement_moves_the_season(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo")
    service.add_round(SEASON, "jan")
    service.push(make_record("Bo", [(9_000, 100)], model="faster"), "jan")
    assert points(service.season(SEASON)) == [(1, "Bo", 25), (2, "Ada", 18)]


def test_an_entry_removed_by_moderation_moves_the_season(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo", "Cy")
    service.add_round(SEASON, "jan")
    service.remove_entry("jan", "Ada")
    assert points(service.season(SEASON)) == [(1, "Bo", 25), (2, "Cy", 18)]


def test_a_ban_moves_the_season_and_an_unban_puts_it_back(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo")
    service.add_round(SEASON, "jan")
    service.ban("jan", "Ada")
    assert points(service.season(SEASON)) == [(1, "Bo", 25)]
    service.unban("jan", "Ada")
    assert points(service.season(SEASON)) == [(1, "Ada", 25), (2, "Bo", 18)]


def test_best_of_weights_and_points_change_with_the_season(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo")
    race(service, "feb", "Ada", "Bo")
    race(service, "final", "Bo", "Ada")
    for board_id in ("jan", "feb"):
        service.add_round(SEASON, board_id)
    service.add_round(SEASON, "final", RoundSpec(weight=2, always_counts=True))
    assert points(service.season(SEASON)) == [(1, "Ada", 25 + 25 + 36), (2, "Bo", 18 + 18 + 50)]
    season = service.update_season(SEASON, SeasonChanges(best_of=2))
    assert [(s.racer, s.points) for s in season.standings] == [("Bo", 68), ("Ada", 61)]
    assert [s.counted for s in season.standings[1].rounds] == [True, False, True]
    season = service.update_season(SEASON, SeasonChanges(points=PointsTable(positions=[3, 1]),
                                                         best_of=None))
    assert [(s.racer, s.points) for s in season.standings] == [("Ada", 3 + 3 + 2), ("Bo", 1 + 1 + 6)]


def test_the_final_refuses_racers_who_did_not_qualify(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo", "Cy", "Di")
    race(service, "feb", "Bo", "Ada", "Cy")
    for board_id in ("jan", "feb"):
        service.add_round(SEASON, board_id)
    season = service.set_final(SEASON, FinalSpec(board_id="final", top=2))
    assert season.season.final is not None and season.season.final.qualifiers == ["Ada", "Bo"]
    assert [s.qualified_for_final for s in season.standings] == [True, True, False, False]
    with pytest.raises(NotQualified) as refused:
        race(service, "final", "Cy")
    message = refused.value.message
    assert "'Cy' did not qualify" in message and "top 2 of the season" in message
    assert "Ada, Bo" in message and message.endswith("Cy is 3rd with 30 points.")
    assert service.board_page("final").entries == [], "nothing stored"
    race(service, "final", "Bo", "Ada")  # the qualifiers race
    assert [e.racer for e in service.board_page("final").entries] == ["Bo", "Ada"]
    assert race(service, "mar", "Cy") is None, "other boards take anyone"


def test_a_final_that_is_a_round_qualifies_on_the_other_rounds(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo", "Cy")
    service.add_round(SEASON, "jan")
    service.add_round(SEASON, "final", RoundSpec(weight=2))
    service.set_final(SEASON, FinalSpec(board_id="final", top=2))
    race(service, "final", "Bo", "Ada")
    season = service.season(SEASON)
    assert points(season) == [(1, "Bo", 18 + 50), (2, "Ada", 25 + 36), (3, "Cy", 15)]
    assert season.season.final is not None and season.season.final.qualifiers == ["Ada", "Bo"]


def test_the_top_of_one_round_may_be_the_finals_entrants(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo", "Cy")
    race(service, "feb", "Cy", "Bo")
    for board_id in ("jan", "feb"):
        service.add_round(SEASON, board_id)
    service.set_final(SEASON, FinalSpec(board_id="final", top=1, from_round="feb"))
    with pytest.raises(NotQualified, match=r"top 1 of its round 'feb': Cy\. Ada did not race it\."):
        race(service, "final", "Ada")
    with pytest.raises(NotQualified, match=r"Bo finished 2nd there\."):
        race(service, "final", "Bo")
    race(service, "final", "Cy")
    with pytest.raises(SeasonLocked, match="change or clear the final first"):
        service.remove_round(SEASON, "feb")
    service.clear_final(SEASON)
    race(service, "final", "Ada")  # no final any more: anyone


def test_qualification_follows_moderation_of_the_rounds(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo", "Cy")
    service.add_round(SEASON, "jan")
    service.set_final(SEASON, FinalSpec(board_id="final", top=2))
    service.ban("jan", "Ada", everywhere=False)  # off the round, not banned from the final
    race(service, "final", "Cy")  # Cy moves up into the top 2
    with pytest.raises(NotQualified):
        race(service, "final", "Ada")


def test_a_final_must_be_a_named_board_and_its_round_one_of_the_seasons(
        service: LeaderboardService) -> None:
    race(service, "jan", "Ada")
    service.push(make_record("Ada", [(9_000, 100)], model="open"))  # the track's default board
    with pytest.raises(BoardLocked):
        service.set_final(SEASON, FinalSpec(board_id="reInvent2019_track", top=2))
    with pytest.raises(InvalidQuery, match="not a round"):
        service.set_final(SEASON, FinalSpec(board_id="final", top=2, from_round="jan"))
    with pytest.raises(BoardNotFound):
        service.set_final(SEASON, FinalSpec(board_id="nowhere", top=2))


def test_a_closed_season_stays_as_it_ended(service: LeaderboardService) -> None:
    race(service, "jan", "Ada", "Bo")
    service.add_round(SEASON, "jan")
    closed = service.close_season(SEASON)
    assert closed.season.status == "CLOSED" and points(closed) == [(1, "Ada", 25), (2, "Bo", 18)]
    service.push(make_record("Bo", [(9_000, 100)], model="late"), "jan")
    service.delete_board("jan")
    later = service.season(SEASON)
    assert points(later) == [(1, "Ada", 25), (2, "Bo", 18)], "a past season is as it ended"
    assert later.season.rounds[0].status == "MISSING"
    with pytest.raises(SeasonLocked, match="reopen"):
        service.add_round(SEASON, "feb")
    assert [(s.season_id, s.status) for s in service.seasons()] == [(SEASON, "CLOSED")]

    service.restore_board("jan")
    reopened = service.reopen_season(SEASON)
    assert points(reopened) == [(1, "Bo", 25), (2, "Ada", 18)], "open again: the boards move it"


def test_a_deleted_rounds_results_do_not_count_until_it_is_restored(
        service: LeaderboardService) -> None:
    race(service, "jan", "Ada")
    race(service, "feb", "Bo")
    for board_id in ("jan", "feb"):
        service.add_round(SEASON, board_id)
    service.delete_board("jan")
    season = service.season(SEASON)
    assert points(season) == [(1, "Bo", 25)] and season.season.rounds[0].status == "MISSING"
    service.restore_board("jan")
    # level on points, wins and best finish: Ada won her round first
    assert points(service.season(SEASON)) == [(1, "Ada", 25), (2, "Bo", 25)]


def test_a_view_reads_only_the_rounds_whose_boards_changed(service: LeaderboardService,
                                                          store: CountingStore) -> None:
    race(service, "jan", "Ada", "Bo")
    race(service, "feb", "Bo", "Ada")
    for board_id in ("jan", "feb"):
        service.add_round(SEASON, board_id)
    service.season(SEASON)
    store.entries_read.clear()
    service.season(SEASON)
    assert store.entries_read == [], "nothing changed: the kept results serve the view"
    race(service, "feb", "Cy", model="new")
    store.entries_read.clear()
    service.season(SEASON)
    assert store.entries_read == ["feb"]


def test_rounds_are_added_changed_and_removed(service: LeaderboardService) -> None:
    race(service, "jan", "Ada")
    service.add_round(SEASON, "jan")
    changed = service.add_round(SEASON, "jan", RoundSpec(weight=1.5))
    assert [(r.board_id, r.weight) for r in changed.season.rounds] == [("jan", 1.5)]
    assert points(changed) == [(1, "Ada", 37.5)]
    assert [link.season_id for link in service.board_seasons("jan")] == [SEASON]
    removed = service.remove_round(SEASON, "jan")
    assert removed.season.rounds == [] and removed.standings == []
    assert service.board_seasons("jan") == []
    with pytest.raises(BoardNotFound, match="not a round"):
        service.remove_round(SEASON, "jan")
    with pytest.raises(BoardNotFound):
        service.add_round(SEASON, "nowhere")


def test_rounds_are_numbered_in_the_order_their_boards_open(service: LeaderboardService) -> None:
    service.create_board(BoardSpec(board_id="december", title="Season final", track="reInvent2019",
                                   opens_at=T0 + timedelta(days=330)))
    service.add_round(SEASON, "december", RoundSpec(weight=2))  # announced first
    service.add_round(SEASON, "feb")
    service.add_round(SEASON, "jan")
    season = service.add_round(SEASON, "feb", RoundSpec(weight=1.5))
    assert [(r.number, r.board_id, r.weight) for r in season.season.rounds] == [
        (1, "jan", 1), (2, "feb", 1.5), (3, "december", 2)]


def test_a_season_has_a_bounded_number_of_rounds(service: LeaderboardService) -> None:
    for n in range(MAX_ROUNDS):
        board_id = f"night-{n:02d}"
        service.create_board(BoardSpec(board_id=board_id, title=board_id, track="reInvent2019"))
        service.add_round(SEASON, board_id)
    with pytest.raises(InvalidQuery, match=f"at most {MAX_ROUNDS} rounds"):
        service.add_round(SEASON, "jan")


def test_seasons_have_ids_of_their_own(service: LeaderboardService) -> None:
    with pytest.raises(SeasonExists):
        service.create_season(SeasonSpec(season_id=SEASON, title="Again"))
    with pytest.raises(SeasonNotFound):
        service.season("nowhere")
    with pytest.raises(InvalidQuery):
        service.update_season(SEASON, SeasonChanges.model_validate({"title": None}))
    service.create_season(SeasonSpec(season_id="a-cup", title="A cup"))
    assert [s.season_id for s in service.seasons()] == ["a-cup", SEASON]
    page = service.seasons_page(limit=1)
    assert [s.season_id for s in page.seasons] == ["a-cup"]
    assert [s.season_id for s in service.seasons_page(1, page.next_cursor).seasons] == [SEASON]


def test_standings_come_a_page_at_a_time(service: LeaderboardService) -> None:
    race(service, "jan", *[f"Racer {n:02d}" for n in range(12)])
    service.add_round(SEASON, "jan")
    first = service.season(SEASON, limit=5)
    second = service.season(SEASON, limit=5, cursor=first.next_cursor)
    last = service.season(SEASON, limit=5, cursor=second.next_cursor)
    assert [s.rank for s in first.standings + second.standings + last.standings] == list(range(1, 13))
    assert last.next_cursor is None
    with pytest.raises(InvalidQuery):
        service.season(SEASON, cursor="not-a-cursor")


def test_a_round_links_to_its_season_on_its_board(service: LeaderboardService) -> None:
    before = service.board_page("jan").board.version
    service.add_round(SEASON, "jan")
    service.set_final(SEASON, FinalSpec(board_id="final", top=4))
    assert service.board_page("jan").board.version == before + 1, "the board's page changes"
    [link] = service.board_seasons("final")
    assert (link.season_id, link.title, link.final) == (SEASON, "Club season 2026", True)
    service.update_season(SEASON, SeasonChanges(title="Club season 2026/27"))
    assert [link.title for link in service.board_seasons("jan")] == ["Club season 2026/27"]
