"""The season part of the BoardStore contract: seasons saved with their board links in one
write, listed by id, and the results a season keeps of its rounds. ``StoreContract`` takes these
tests in, so every adapter runs them."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest
from drboard_functions.models.domain import Board, BoardRules
from drboard_functions.models.seasons import (
    MAX_ROUND_RACERS,
    Finish,
    RoundResults,
    Season,
    SeasonFinal,
    SeasonLink,
    SeasonRound,
)
from drboard_functions.stores.base import BoardStore, SeasonConflict

T0 = datetime(2026, 1, 10, 19, 0, tzinfo=UTC)


def season(season_id: str = "club-2026", version: int = 1, title: str = "Club 2026",
           rounds: tuple[str, ...] = (), final: str | None = None) -> Season:
    return Season(season_id=season_id, title=title, created_at=T0, version=version,
                  rounds=[SeasonRound(board_id=b, added_at=T0) for b in rounds],
                  final=SeasonFinal(board_id=final, top=8) if final else None)


def link(season_id: str = "club-2026", final: bool = False) -> SeasonLink:
    return SeasonLink(season_id=season_id, title="Club 2026", final=final)


def named_board(board_id: str) -> Board:
    return Board.model_validate({"board_id": board_id, "kind": "named", "track": "reInvent2019_track",
                                 "title": board_id.title(), "rules": BoardRules(), "created_at": T0})


def results(board_id: str, version: int, racers: int = 3, name: str = "Racer") -> RoundResults:
    return RoundResults(board_id=board_id, board_version=version, field=racers, finishes=[
        Finish(racer_key=f"{name} {n}".casefold(), racer=f"{name} {n}", rank=n, qualified=True,
               achieved_at=T0 + timedelta(seconds=n)) for n in range(1, racers + 1)])


def board_version(store: BoardStore, board_id: str) -> int:
    stored = store.get_board(board_id)
    assert stored is not None
    return stored.version


class SeasonStoreContract:
    def test_an_unknown_season_is_none(self, store: BoardStore) -> None:
        assert store.get_season("nowhere") is None
        assert store.seasons_page(None, 10).seasons == []
        assert store.round_results("nowhere") == {}
        assert store.season_links("nowhere") == []

    def test_a_season_is_created_once_and_changed_only_from_the_version_read(
            self, store: BoardStore) -> None:
        first = store.save_season(season(), {})
        assert store.get_season("club-2026") == first
        with pytest.raises(SeasonConflict):
            store.save_season(season(title="Another"), {})  # a new season, with a taken id
        changed = store.save_season(season(version=2, title="Club 2026, spring"), {})
        assert store.get_season("club-2026") == changed
        with pytest.raises(SeasonConflict):  # written from version 1 again: version 2 is there
            store.save_season(season(version=2, title="Lost update"), {})
        assert store.get_season("club-2026") == changed

    def test_links_go_with_the_season_and_bump_the_boards_versions(self, store: BoardStore) -> None:
        for board_id in ("jan", "feb", "final"):
            store.create_board(named_board(board_id))
        before = {b: board_version(store, b) for b in ("jan", "feb", "final")}
        store.save_season(season(rounds=("jan", "feb"), final="final"),
                          {"jan": link(), "feb": link(), "final": link(final=True)})
        assert store.season_links("jan") == [link()]
        assert store.season_links("final") == [link(final=True)]
        assert {b: board_version(store, b) for b in before} == {b: v + 1 for b, v in before.items()}

        store.save_season(season(version=2, rounds=("jan",), final="final"), {"feb": None},
                          forget=["feb"])
        assert store.season_links("feb") == []
        assert store.season_links("jan") == [link()]
        assert board_version(store, "feb") == before["feb"] + 2
        assert board_version(store, "jan") == before["jan"] + 1, "only the boards whose links change"

    def test_a_board_a_season_took_in_may_be_in_a_season_for_good(self, store: BoardStore) -> None:
        """Where a store tells a board no season took in, a push to it looks for no final: once a
        season takes the board in, it is looked for, even after the season let it go."""
        for board_id in ("jan", "final"):
            store.create_board(named_board(board_id))
        store.save_season(season(rounds=("jan",), final="final"),
                          {"jan": link(), "final": link(final=True)})
        store.save_season(season(version=2, final="final"), {"jan": None})
        for board_id in ("jan", "final"):
            read = store.push_reads(board_id, "ada", "0" * 64, [], 5)
            for stored in (store.get_board(board_id), read.board):
                assert stored is not None and stored.maybe_in_a_season, board_id

    def test_a_board_lists_every_season_it_belongs_to_by_id(self, store: BoardStore) -> None:
        store.create_board(named_board("final"))
        store.save_season(season("winter", rounds=("final",)), {"final": link("winter")})
        store.save_season(season("autumn", rounds=("final",)), {"final": link("autumn", final=True)})
        assert [s.season_id for s in store.season_links("final")] == ["autumn", "winter"]

    def test_seasons_are_listed_by_id_a_page_at_a_time(self, store: BoardStore) -> None:
        ids = ["club-2026", "a-cup", "winter.2025", "Z-league", "b-cup"]
        for season_id in ids:
            store.save_season(season(season_id), {})
        store.create_board(named_board("jan"))  # boards are not seasons
        first = store.seasons_page(None, 3)
        rest = store.seasons_page(first.after, 3)
        assert [s.season_id for s in first.seasons + rest.seasons] == sorted(ids)
        assert len(first.seasons) == 3 and rest.after is None
        assert [b.board.board_id for b in store.list_boards()] == ["jan"]

    def test_boards_are_read_together_by_id(self, store: BoardStore) -> None:
        for board_id in ("jan", "feb"):
            store.create_board(named_board(board_id))
        found = store.boards_by_id(["feb", "missing", "jan", "feb"])
        assert sorted(found) == ["feb", "jan"]
        assert found["jan"] == store.get_board("jan")
        assert store.boards_by_id([]) == {}

    def test_a_round_keeps_its_latest_results(self, store: BoardStore) -> None:
        store.keep_round_results("club-2026", results("jan", 3))
        store.keep_round_results("club-2026", results("jan", 2, name="Stale"))  # older: not kept
        assert store.round_results("club-2026") == {"jan": results("jan", 3)}
        store.keep_round_results("club-2026", results("jan", 5, racers=4))
        store.keep_round_results("club-2026", results("feb", 1))
        assert store.round_results("club-2026") == {"jan": results("jan", 5, racers=4),
                                                     "feb": results("feb", 1)}
        assert store.round_results("club-2025") == {}, "each season keeps its own"

    def test_a_season_forgets_the_results_of_a_round_it_drops(self, store: BoardStore) -> None:
        store.create_board(named_board("jan"))
        store.save_season(season(rounds=("jan",)), {"jan": link()})
        store.keep_round_results("club-2026", results("jan", 1))
        store.save_season(season(version=2), {"jan": None}, forget=["jan"])
        assert store.round_results("club-2026") == {}

    def test_a_full_round_of_results_is_kept_whole(self, store: BoardStore) -> None:
        full = results("jan", 7, racers=MAX_ROUND_RACERS, name="A racer with a rather long alias")
        store.keep_round_results("club-2026", full)
        assert store.round_results("club-2026") == {"jan": full}
