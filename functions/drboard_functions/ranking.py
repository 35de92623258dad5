"""The board's timing methods and the sortable keys that put entries in rank order.

A score key sorts qualified entries by time ascending, then the others by best completion
descending. Ranks are shared on equal score keys (rank = 1 + entries strictly better); the rank
key adds the achievement time and racer so that, among equals, the earlier result is listed first.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC, datetime

from drboard_assembler.record import EvaluationRun, Record

from .conditions import meets
from .flags import record_flags
from .models.domain import BoardRules, Score, TimingMethod

_TIME_DIGITS = 12


def best_lap_time(run: EvaluationRun, min_laps: int) -> int | None:
    """The fastest completed lap, once ``min_laps`` laps are complete."""
    times = run.completed_times
    return min(times) if len(times) >= min_laps else None


def average_lap_time(run: EvaluationRun, min_laps: int) -> int | None:
    """The best average of ``min_laps`` consecutive laps, all complete."""
    best: float | None = None
    for start in range(len(run.laps) - min_laps + 1):
        window = run.laps[start:start + min_laps]
        if all(lap.complete for lap in window):
            average = sum(lap.time_ms for lap in window) / min_laps
            best = average if best is None else min(best, average)
    return None if best is None else round(best)


def total_time(run: EvaluationRun, min_laps: int) -> int | None:
    """The sum of the first ``min_laps`` laps, when every one of them is complete."""
    first = run.laps[:min_laps]
    if len(first) < min_laps or not all(lap.complete for lap in first):
        return None
    return sum(lap.time_ms for lap in first)


TIMING: dict[TimingMethod, Callable[[EvaluationRun, int], int | None]] = {
    TimingMethod.BEST_LAP_TIME: best_lap_time,
    TimingMethod.AVG_LAP_TIME: average_lap_time,
    TimingMethod.TOTAL_TIME: total_time,
}


def score_run(run: EvaluationRun, rules: BoardRules, flags: list[str] | None = None) -> Score:
    """How the run places; a flagged run on a board whose flagged runs do not rank does not
    qualify (it shows below every qualified racer, by completion)."""
    flags = flags or []
    time_ms = TIMING[rules.method](run, rules.min_laps)
    if flags and rules.flagged_runs == "unranked":
        time_ms = None
    return Score(
        qualified=time_ms is not None,
        time_ms=time_ms,
        best_completion_pct=run.best_completion_pct,
        laps_completed=run.laps_completed,
        best_lap_ms=run.best_lap_ms,
        run=run.source,
        flags=flags,
        conditions=run.conditions,
    )


def score_record(record: Record, rules: BoardRules) -> Score:
    """The record's best evaluation run under the board's rules, of the runs evaluated under
    the conditions the board requires (a push of none is refused before it is scored)."""
    runs = [run for run in record.evaluations if meets(rules.conditions, run)] or record.evaluations
    return min((score_run(run, rules, list(record_flags(record, run))) for run in runs), key=score_key)


def score_key(score: Score) -> str:
    if score.qualified and score.time_ms is not None:
        return f"0:{score.time_ms:0{_TIME_DIGITS}d}"
    basis_points = round(score.best_completion_pct * 100)
    return f"1:{10_000 - basis_points:05d}"


def rank_key(key: str, achieved_at: datetime, racer_key: str) -> str:
    return f"{key}|{timestamp(achieved_at)}|{racer_key}"


def timestamp(moment: datetime) -> str:
    """``2024-05-06T02:08:09.123456Z``: UTC, to the microsecond, of one width (from the year
    1000), so that as text they sort in time order."""
    return moment.astimezone(UTC).isoformat(timespec="microseconds")[:-6] + "Z"  # "+00:00"


def parse_timestamp(text: str) -> datetime:
    return datetime.fromisoformat(text).astimezone(UTC)
