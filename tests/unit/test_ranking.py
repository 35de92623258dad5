"""The three timing methods (DESIGN §3) on worked examples, and the keys that order a board."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone

import pytest
from drboard_functions import ranking
from drboard_functions.models.domain import BoardRules, Score, TimingMethod

from tests.recordkit import LapSpec, make_record, make_run

BEST, AVG, TOTAL = TimingMethod.BEST_LAP_TIME, TimingMethod.AVG_LAP_TIME, TimingMethod.TOTAL_TIME


def score(laps: list[LapSpec], method: TimingMethod = BEST, min_laps: int = 1) -> Score:
    return ranking.score_run(make_run(laps), BoardRules(method=method, min_laps=min_laps))


def ranks(keys: list[str]) -> list[int]:
    """Rank = 1 + the number of keys strictly better, as the board shows it."""
    return [1 + sum(other < key for other in keys) for key in keys]


# ---- BEST_LAP_TIME --------------------------------------------------------------------------


def test_best_lap_is_the_fastest_completed_lap() -> None:
    result = score([(12500, 100), (11800, 100), (9000, 60), (12100, 100)])
    assert result == Score(qualified=True, time_ms=11800, best_completion_pct=100.0,
                           laps_completed=3, best_lap_ms=11800,
                           run="metrics/evaluation/eval-1.json")


def test_the_best_of_several_evaluation_runs_counts() -> None:
    record = make_record(runs=[[(12500, 100), (12600, 100)],
                               [(11900, 100), (13000, 100)],
                               [(9000, 70)]])
    result = ranking.score_record(record, BoardRules())
    assert (result.time_ms, result.run) == (11900, "metrics/evaluation/eval-2.json")


def test_a_qualifying_run_beats_a_faster_run_that_does_not_qualify() -> None:
    record = make_record(runs=[[(10000, 100), (9000, 30)], [(12000, 100), (12500, 100)]])
    result = ranking.score_record(record, BoardRules(min_laps=2))
    assert (result.qualified, result.time_ms, result.run) == (
        True, 12000, "metrics/evaluation/eval-2.json")


def test_in_progress_at_100_percent_counts_as_complete() -> None:
    result = score([(11000, 100, "In progress"), (12000, 100, "Lap complete")], min_laps=2)
    assert (result.qualified, result.time_ms, result.laps_completed) == (True, 11000, 2)


def test_a_lap_below_100_percent_is_not_complete_whatever_its_status() -> None:
    result = score([(8000, 99.9, "Lap complete"), (12000, 100)])
    assert result.time_ms == 12000


def test_min_laps_not_reached_does_not_qualify() -> None:
    result = score([(11000, 100), (5000, 40)], min_laps=2)
    assert result == Score(qualified=False, time_ms=None, best_completion_pct=100.0,
                           laps_completed=1, best_lap_ms=11000,
                           run="metrics/evaluation/eval-1.json")


def test_no_completed_lap_does_not_qualify() -> None:
    result = score([(5000, 35.5), (7000, 62.25)])
    assert (result.qualified, result.time_ms, result.best_completion_pct) == (False, None, 62.25)
    assert result.best_lap_ms is None


# ---- AVG_LAP_TIME and TOTAL_TIME --------------------------------------------------------------

# A run whose first three laps are not all complete but which later drives three in a row.
LATE_STREAK: list[LapSpec] = [(10000, 100), (11000, 100), (6000, 30), (12000, 100), (12500, 100),
                              (13000, 100)]
# Three completed laps, never two in a row.
SCATTERED: list[LapSpec] = [(10000, 100), (5000, 50), (11000, 100), (6000, 60), (12000, 100)]
# The first three laps are complete, the fourth is not.
CLEAN_START: list[LapSpec] = [(10000, 100), (11000, 100), (12000, 100), (4000, 40)]


@pytest.mark.parametrize(("laps", "best", "avg", "total"), [
    (LATE_STREAK, 10000, 12500, None),
    (SCATTERED, 10000, None, None),
    (CLEAN_START, 10000, 11000, 33000),
])
def test_one_run_under_each_method_with_three_laps(laps: list[LapSpec], best: int | None,
                                                   avg: int | None, total: int | None) -> None:
    assert score(laps, BEST, 3).time_ms == best
    assert score(laps, AVG, 3).time_ms == avg
    assert score(laps, TOTAL, 3).time_ms == total
    assert score(laps, AVG, 3).qualified is (avg is not None)
    assert score(laps, TOTAL, 3).qualified is (total is not None)


def test_average_takes_the_best_consecutive_window() -> None:
    laps: list[LapSpec] = [(13000, 100), (12000, 100), (11000, 100), (10000, 100)]
    assert score(laps, AVG, 2).time_ms == 10500  # (11000 + 10000) / 2, not the first two
    assert score(laps, AVG, 4).time_ms == 11500
    assert score(laps, AVG, 5).time_ms is None  # fewer laps than the window


def test_average_window_is_broken_by_an_incomplete_lap() -> None:
    laps: list[LapSpec] = [(10000, 100), (10000, 100), (3000, 20), (10000, 100), (12000, 100),
                           (12000, 100)]
    assert score(laps, AVG, 3).time_ms == round((10000 + 12000 + 12000) / 3)


def test_average_is_rounded_to_the_millisecond() -> None:
    assert score([(10000, 100), (10001, 100), (10001, 100)], AVG, 3).time_ms == 10001


def test_total_time_needs_the_first_laps_complete() -> None:
    # the best three in a row (32 s) do not count: the first three do
    laps: list[LapSpec] = [(12000, 100), (11000, 100), (10000, 100), (11000, 100)]
    assert score(laps, TOTAL, 3).time_ms == 33000
    assert score(laps, AVG, 3).time_ms == 10667
    # a slow but complete first lap still counts; an incomplete one disqualifies
    late_start: list[LapSpec] = [(5000, 50), (10000, 100), (10000, 100), (10000, 100)]
    assert score(late_start, TOTAL, 3).qualified is False
    assert score(late_start, AVG, 3).time_ms == 10000
    assert score(late_start, BEST, 3).time_ms == 10000


def test_total_time_with_fewer_laps_than_needed() -> None:
    assert score([(10000, 100), (10000, 100)], TOTAL, 3).qualified is False
    assert score([(10000, 100), (10000, 100)], TOTAL, 2).time_ms == 20000


def test_the_best_run_is_chosen_per_method() -> None:
    record = make_record(runs=[LATE_STREAK, CLEAN_START, [(9500, 100), (9000, 20)]])
    by = {method: ranking.score_record(record, BoardRules(method=method, min_laps=3))
          for method in (BEST, AVG, TOTAL)}
    assert (by[BEST].time_ms, by[BEST].run) == (10000, "metrics/evaluation/eval-1.json")
    assert (by[AVG].time_ms, by[AVG].run) == (11000, "metrics/evaluation/eval-2.json")
    assert (by[TOTAL].time_ms, by[TOTAL].run) == (33000, "metrics/evaluation/eval-2.json")
    # with one lap needed the third run's 9.5 s lap wins
    assert ranking.score_record(record, BoardRules()).time_ms == 9500


@pytest.mark.parametrize("method", [AVG, TOTAL])
def test_min_laps_defaults_follow_the_method(method: TimingMethod) -> None:
    assert BoardRules(method=method).min_laps == 3
    assert BoardRules(method=method, min_laps=2).min_laps == 2


def test_min_laps_default_for_best_lap_time() -> None:
    assert BoardRules().min_laps == 1
    assert BoardRules(method=BEST).min_laps == 1


# ---- score keys and ranks ---------------------------------------------------------------------


def key(laps: list[LapSpec], min_laps: int = 1) -> str:
    return ranking.score_key(score(laps, BEST, min_laps))


def test_qualified_before_not_qualified() -> None:
    slow_but_qualified = key([(600_000, 100)])
    full_lap_short_of_min_laps = key([(9000, 100)], min_laps=2)
    assert slow_but_qualified < full_lap_short_of_min_laps
    assert slow_but_qualified < key([(9000, 99.99)])


def test_faster_before_slower_whatever_the_number_of_digits() -> None:
    keys = [key([(ms, 100)]) for ms in (100_000, 9_999, 10_000, 86_400_000, 5_000)]
    assert sorted(keys) == [key([(ms, 100)]) for ms in (5_000, 9_999, 10_000, 100_000, 86_400_000)]


def test_higher_completion_before_lower_among_non_qualified() -> None:
    keys = [key([(5000, pct)]) for pct in (0.0, 80.4, 99.99, 80.5, 12.0)]
    expected = [key([(5000, pct)]) for pct in (99.99, 80.5, 80.4, 12.0, 0.0)]
    assert sorted(keys) == expected
    assert len(set(keys)) == 5


def test_equal_scores_have_equal_keys_and_share_the_rank() -> None:
    a = key([(12000, 100), (13000, 100)])
    b = key([(14000, 100), (12000, 100, "In progress")])
    c = key([(11000, 100)])
    d = key([(13000, 100)])
    e, f = key([(5000, 80)]), key([(9000, 80), (1000, 10)])
    assert a == b and e == f
    assert ranks([a, b, c, d, e, f]) == [2, 2, 1, 4, 5, 5]


def test_rank_key_orders_ties_by_achievement_then_racer() -> None:
    tied = key([(12000, 100)])
    moment = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)
    early_z = ranking.rank_key(tied, moment, "zed")
    late_a = ranking.rank_key(tied, moment + timedelta(microseconds=1), "amy")
    same_time_a = ranking.rank_key(tied, moment, "amy")
    assert same_time_a < early_z < late_a


def test_a_better_score_key_sorts_before_any_rank_key_of_a_worse_one() -> None:
    # count_better relies on this: score keys are fixed-width prefixes of rank keys
    moment = datetime(2025, 3, 1, tzinfo=UTC)
    better, worse = key([(12000, 100)]), key([(12001, 100)])
    assert ranking.rank_key(better, datetime(2099, 1, 1, tzinfo=UTC), "~~~") < worse
    assert ranking.rank_key(worse, moment, "a").startswith(worse + "|")
    assert worse < ranking.rank_key(worse, moment, "a")
    unfinished = key([(5000, 80)])
    assert ranking.rank_key(worse, moment, "zzz") < unfinished


def test_rank_key_time_is_the_same_instant_in_any_time_zone() -> None:
    tied = key([(12000, 100)])
    utc = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)
    paris = utc.astimezone(timezone(timedelta(hours=1)))
    assert ranking.rank_key(tied, utc, "ada") == ranking.rank_key(tied, paris, "ada")
    assert ranking.timestamp(paris) == "2025-03-01T12:00:00.000000Z"
