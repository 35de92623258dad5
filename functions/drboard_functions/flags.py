"""Consistency checks the board runs on every record, shown beside the runs they concern.

A flag is not a refusal: real runs can be odd. Each says which figures of a run disagree, and a
board's ``flagged_runs`` rule decides whether a flagged run still ranks (``rank``, the default)
or only shows, below every qualified racer (``unranked``).
"""

from __future__ import annotations

from typing import Literal

from drboard_assembler.record import EvaluationRun, Lap, Record, lap_floor_ms

Flag = Literal["lap-timestamps", "reset-count", "params-name-another-file", "faster-than-top-speed",
               "design-unknown"]

DESCRIPTIONS: dict[str, str] = {
    "lap-timestamps": "a lap's time disagrees with its start and end timestamps",
    "reset-count": "a lap's reset count is not the sum of its crashes, off-tracks, "
                   "immobilisations and reversals",
    "params-name-another-file": "the run folder's evaluation parameters name a metrics file it "
                                "does not hold",
    "faster-than-top-speed": "a lap is faster than the track's shortest path at the model's top "
                             "speed",
    "design-unknown": "the run's files do not describe the model's action space: its top speed, "
                      "and so its laps' pace, cannot be checked",
    # For the organiser, set by the board's copy and rule checks; they never move a run.
    "copied-run": "the same laps as another racer's run (the organiser decides whose it is)",
    "near-copy": "laps within a few milliseconds of another racer's run",
    "lookalike": "an alias that could pass for another racer's on the board",
    "rule-changed": "a run stored before a rule was tightened: today's checks would refuse it",
}

#: How far a lap's time may stray from its end minus its start (the simulator rounds both).
TIMESTAMP_TOLERANCE_MS = 50


def record_flags(record: Record, run: EvaluationRun) -> list[Flag]:
    """The flags of one of a record's evaluation runs, in a fixed order."""
    flags = run_flags(run, record.track, record.design.max_speed)
    if record.design.action_space is None:
        flags.append("design-unknown")
    return flags


def run_flags(run: EvaluationRun, track: str, max_speed: float | None) -> list[Flag]:
    """The flags of one evaluation run, in a fixed order. A model whose top speed is unknown is
    checked against the fastest any action space allows."""
    flags: list[Flag] = []
    if any(_timestamps_disagree(lap) for lap in run.laps):
        flags.append("lap-timestamps")
    if any(_resets_disagree(lap) for lap in run.laps):
        flags.append("reset-count")
    if run.named_by_params is False:
        flags.append("params-name-another-file")
    fastest_ms = lap_floor_ms(track, max_speed)
    if fastest_ms is not None and any(lap.complete and lap.time_ms < fastest_ms for lap in run.laps):
        flags.append("faster-than-top-speed")
    return flags


def _timestamps_disagree(lap: Lap) -> bool:
    if lap.started_ms is None or lap.ended_ms is None:
        return False
    return abs((lap.ended_ms - lap.started_ms) - lap.time_ms) > TIMESTAMP_TOLERANCE_MS


def _resets_disagree(lap: Lap) -> bool:
    if lap.immobilized is None or lap.reversed is None:
        return False  # an older metrics file: not every cause is counted
    return lap.resets != lap.crashes + lap.off_track + lap.immobilized + lap.reversed
