"""How a season's rounds add up (season_scoring): points tables, best N of M, weights, each
tie-break, percentile points, points for taking part, and who qualifies for a final."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime, timedelta

import pytest
from drboard_functions.models.seasons import (
    LEAGUE_POINTS,
    Finish,
    PointsTable,
    RoundResults,
    Season,
    SeasonRound,
)
from drboard_functions.season_scoring import (
    finish_points,
    place_points,
    round_qualifiers,
    season_qualifiers,
    standings,
)
from pydantic import ValidationError

T0 = datetime(2026, 1, 10, 19, 0, tzinfo=UTC)

#: A round: racers best first, as (racer, seconds after T0 their result was set); a racer
#: written with a trailing "?" took part without qualifying.
Placings = Sequence[tuple[str, float]]


def round_of(board_id: str, placings: Placings, field_size: int | None = None) -> RoundResults:
    finishes = []
    for position, (racer, when) in enumerate(placings, start=1):
        name = racer.rstrip("?")
        finishes.append(Finish(racer_key=name.casefold(), racer=name, rank=position,
                               qualified=not racer.endswith("?"),
                               achieved_at=T0 + timedelta(seconds=when)))
    return RoundResults(board_id=board_id, board_version=1, field=field_size or len(finishes),
                        finishes=finishes)


def in_order(*racers: str) -> Placings:
    return [(racer, n) for n, racer in enumerate(racers)]


def season_of(*rounds: str | SeasonRound, points: PointsTable | None = None,
              best_of: int | None = None) -> Season:
    listed = [r if isinstance(r, SeasonRound) else SeasonRound(board_id=r, added_at=T0) for r in rounds]
    return Season(season_id="club", title="Club", created_at=T0, version=1, rounds=listed,
                  points=points or PointsTable(), best_of=best_of)


def table(season: Season, *results: RoundResults) -> list[tuple[int, str, float]]:
    return [(r.standing.rank, r.standing.racer, r.standing.points)
            for r in standings(season, {result.board_id: result for result in results})]


def test_the_league_table_scores_the_first_ten_places() -> None:
    points = PointsTable()
    assert [place_points(points, rank, 12) for rank in range(1, 13)] == [*LEAGUE_POINTS, 0, 0]


def test_an_organisers_own_list_of_points() -> None:
    own = PointsTable(positions=[10, 6, 4, 3, 2, 1])
    night = round_of("jan", in_order("Ada", "Bo", "Cy", "Di", "Ed", "Flo", "Gus"))
    assert table(season_of("jan", points=own), night) == [
        (1, "Ada", 10), (2, "Bo", 6), (3, "Cy", 4), (4, "Di", 3), (5, "Ed", 2), (6, "Flo", 1),
        (7, "Gus", 0)]


@pytest.mark.parametrize("positions", [[10, 12, 8], [], [-1], [10_001]])
def test_a_points_list_that_rises_or_is_out_of_bounds_is_refused(positions: list[int]) -> None:
    with pytest.raises(ValidationError):
        PointsTable(positions=positions)


def test_points_add_up_over_the_rounds() -> None:
    jan = round_of("jan", in_order("Ada", "Bo", "Cy"))
    feb = round_of("feb", in_order("Cy", "Ada"))
    assert table(season_of("jan", "feb"), jan, feb) == [
        (1, "Ada", 25 + 18), (2, "Cy", 15 + 25), (3, "Bo", 18)]


def test_only_the_best_n_rounds_count_and_the_others_are_marked_dropped() -> None:
    nights = [round_of("r1", in_order("Ada", "Bo")), round_of("r2", in_order("Bo", "Ada")),
              round_of("r3", in_order("Bo", "Cy", "Ada")), round_of("r4", in_order("Ada"))]
    season = season_of("r1", "r2", "r3", "r4", best_of=2)
    ranked = standings(season, {r.board_id: r for r in nights})
    ada = next(r.standing for r in ranked if r.standing.racer == "Ada")
    assert ada.points == 25 + 25  # r1 and r4; r2's 18 and r3's 15 are dropped
    assert [(s.board_id, s.points, s.counted) for s in ada.rounds] == [
        ("r1", 25, True), ("r2", 18, False), ("r3", 15, False), ("r4", 25, True)]
    bo = next(r.standing for r in ranked if r.standing.racer == "Bo")
    assert bo.points == 25 + 25 and bo.rounds[3].rank is None and not bo.rounds[3].counted


def test_of_equal_rounds_the_earlier_counts() -> None:
    nights = [round_of("r1", in_order("Ada")), round_of("r2", in_order("Ada"))]
    ranked = standings(season_of("r1", "r2", best_of=1), {r.board_id: r for r in nights})
    assert [s.counted for s in ranked[0].standing.rounds] == [True, False]


def test_a_round_weighs_its_points() -> None:
    final = SeasonRound(board_id="final", weight=2, added_at=T0)
    jan = round_of("jan", in_order("Ada", "Bo"))
    last = round_of("final", in_order("Bo", "Ada"))
    assert table(season_of("jan", final), jan, last) == [(1, "Bo", 18 + 50), (2, "Ada", 25 + 36)]


def test_a_round_that_always_counts_is_never_dropped() -> None:
    final = SeasonRound(board_id="final", weight=2, always_counts=True, added_at=T0)
    nights = [round_of("r1", in_order("Ada")), round_of("r2", in_order("Ada")),
              round_of("final", in_order("Bo", "Cy", "Di", "Ed", "Flo", "Gus", "Hal", "Ida", "Jo", "Ada"))]
    ranked = standings(season_of("r1", "r2", final, best_of=2), {r.board_id: r for r in nights})
    ada = next(r.standing for r in ranked if r.standing.racer == "Ada")
    assert [s.counted for s in ada.rounds] == [True, False, True]
    assert ada.points == 25 + 2  # the final's tenth place (1 point) × 2, in place of r2's 25


def test_ties_go_to_more_round_wins() -> None:
    r1 = round_of("r1", in_order("Ada", "Bo", "Cy"))
    r2 = round_of("r2", in_order("Cy", "Di", "Bo", "Ed", "Flo", "Ada"))
    # Ada 25 + 8 = 33, one win; Bo 18 + 15 = 33, none
    assert table(season_of("r1", "r2"), r1, r2)[:3] == [(1, "Cy", 40), (2, "Ada", 33), (3, "Bo", 33)]


def test_then_the_better_best_finish() -> None:
    r1 = round_of("r1", in_order("Cy", "Ada", "Bo"))
    r2 = round_of("r2", in_order("Di", "Ed", "Bo", "Ada"))
    # no wins; Ada 18 + 12 = 30 with a 2nd; Bo 15 + 15 = 30 with 3rds only
    assert [row for row in table(season_of("r1", "r2"), r1, r2) if row[2] == 30] == [
        (1, "Ada", 30), (2, "Bo", 30)]


@pytest.mark.parametrize(("ada_at", "bo_at", "first"), [(10, 20, "Ada"), (30, 20, "Bo")])
def test_then_whoever_set_that_best_finish_first(ada_at: float, bo_at: float, first: str) -> None:
    r1 = round_of("r1", [("Cy", 0), ("Ada", ada_at), ("Bo", 40)])
    r2 = round_of("r2", [("Di", 0), ("Bo", bo_at), ("Ada", 50)])
    # Ada 18 + 15, Bo 15 + 18: no wins, both best 2nd; who was 2nd first?
    level = [row for row in table(season_of("r1", "r2"), r1, r2) if row[2] == 33]
    assert [racer for _, racer, _ in level] == [first, "Bo" if first == "Ada" else "Ada"]
    assert [rank for rank, _, _ in level] == [1, 2]


def test_racers_level_on_every_tie_break_share_the_rank() -> None:
    r1 = round_of("r1", [("Ada", 5), ("Cy", 6)])
    r2 = round_of("r2", [("Bo", 5), ("Cy", 6)])
    ranked = table(season_of("r1", "r2"), r1, r2)
    assert ranked == [(1, "Cy", 36), (2, "Ada", 25), (2, "Bo", 25)]


def test_percentile_points_follow_the_place_in_the_field() -> None:
    points = PointsTable(scheme="percentile", percentile_max=100)
    assert [place_points(points, rank, 200) for rank in (1, 2, 100, 199, 200)] == [100, 100, 51, 1, 1]
    assert [place_points(points, rank, 4) for rank in (1, 2, 3, 4)] == [100, 75, 50, 25]
    night = round_of("jan", in_order("Ada", "Bo"), field_size=10)  # 10 racers, 2 kept
    assert table(season_of("jan", points=points), night) == [(1, "Ada", 100), (2, "Bo", 90)]


def test_taking_part_scores_without_qualifying() -> None:
    points = PointsTable(participation=3)
    night = round_of("jan", in_order("Ada", "Bo", "Cy?"))  # Cy's model never finished a lap
    assert table(season_of("jan", points=points), night) == [(1, "Ada", 28), (2, "Bo", 21), (3, "Cy", 3)]
    unqualified = night.finishes[2]
    assert finish_points(points, unqualified, 3, weight=2) == 6


def test_wins_and_best_finish_count_only_qualified_results() -> None:
    night = round_of("jan", in_order("Ada?"))
    ranked = standings(season_of("jan", points=PointsTable(participation=1)), {"jan": night})
    assert (ranked[0].standing.wins, ranked[0].standing.best_finish) == (0, None)


def test_a_round_without_results_scores_nothing() -> None:
    jan = round_of("jan", in_order("Ada"))
    ranked = standings(season_of("jan", "feb"), {"jan": jan, "feb": None})
    assert ranked[0].standing.points == 25 and ranked[0].standing.rounds[1].rank is None


def test_a_racer_is_one_racer_whatever_the_case_of_their_alias() -> None:
    jan = round_of("jan", in_order("ada"))
    feb = round_of("feb", in_order("ADA"))
    assert table(season_of("jan", "feb"), jan, feb) == [(1, "ADA", 50)]


def test_the_season_qualifies_its_top_k_who_scored() -> None:
    nights = [round_of("r1", in_order(*"ABCDEFGHIJKL"))]
    ranked = standings(season_of("r1"), {"r1": nights[0]})
    assert [r.standing.racer for r in season_qualifiers(ranked, 3)] == ["A", "B", "C"]
    assert len(season_qualifiers(ranked, 12)) == 10, "racers on no points do not qualify"


def test_a_round_qualifies_its_top_k_whose_runs_qualified() -> None:
    night = round_of("r1", in_order("Ada", "Bo", "Cy?", "Di?"))
    assert [f.racer for f in round_qualifiers(night, 3)] == ["Ada", "Bo"]
    assert round_qualifiers(None, 3) == []
