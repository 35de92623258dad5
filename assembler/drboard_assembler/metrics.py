"""Training and evaluation metrics files -> evaluation runs and the training summary."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from pydantic.dataclasses import dataclass

from . import limits
from .errors import AssemblyError
from .reading import from_validation_error, validate_json
from .record import Count, CurvePoint, EvaluationRun, Figure, Lap, Moment, Percent, TrainingSummary

# The record's own bounds, so that a file past them is refused naming its own field.
Trial = Annotated[int, Field(ge=0, le=100_000)]
Episode = Annotated[int, Field(ge=0, le=100_000_000)]
Finite = Annotated[Figure, Field(allow_inf_nan=False)]
#: How far an entry's end minus its start may stray from its elapsed time (both are rounded).
TIMESTAMP_TOLERANCE_MS = 1000


class _Entry(BaseModel):
    model_config = ConfigDict(extra="ignore")
    completion_percentage: Percent
    elapsed_time_in_milliseconds: Annotated[int, Field(ge=0, le=limits.MAX_LAP_MS)]
    episode_status: Annotated[str, Field(max_length=32)] = ""
    trial: Trial = 0


class _EvaluationEntry(_Entry):
    off_track_count: Count = 0
    crash_count: Count = 0
    reset_count: Count = 0
    immobilized_count: Count | None = None
    reversed_count: Count | None = None
    start_time: Annotated[Moment, Field(allow_inf_nan=False)] | None = None
    metric_time: Annotated[Moment, Field(allow_inf_nan=False)] | None = None


@dataclass(slots=True, config=ConfigDict(extra="ignore"))
class _TrainingEntry:
    # A slotted dataclass, not a model: a 50 MB file holds some 200,000 of these.
    completion_percentage: Percent
    elapsed_time_in_milliseconds: Annotated[int, Field(ge=0, le=limits.MAX_LAP_MS)]
    episode_status: Annotated[str, Field(max_length=32)] = ""
    trial: Trial = 0
    episode: Episode = 0
    phase: Annotated[str, Field(max_length=32)] = "training"
    reward_score: Finite = 0.0
    start_time: Annotated[Moment, Field(allow_inf_nan=False)] | None = None
    metric_time: Annotated[Moment, Field(allow_inf_nan=False)] | None = None


class _EvaluationFile(BaseModel):
    model_config = ConfigDict(extra="ignore")
    metrics: list[_EvaluationEntry]


class _TrainingFile(BaseModel):
    model_config = ConfigDict(extra="ignore")
    metrics: list[_TrainingEntry]


def load_evaluation(data: bytes, name: str) -> EvaluationRun:
    entries = validate_json(_EvaluationFile, data, name).metrics
    if not entries:
        raise AssemblyError(name, "metrics", "holds no laps")
    if len(entries) > limits.MAX_LAPS_PER_RUN:
        raise AssemblyError(name, "metrics",
                            f"holds {len(entries)} laps, over the limit of {limits.MAX_LAPS_PER_RUN}")
    try:
        return EvaluationRun.from_laps(name, [_lap(number, entry)
                                              for number, entry in enumerate(entries, start=1)])
    except ValidationError as error:
        raise from_validation_error(error, name) from None


def _lap(number: int, entry: _EvaluationEntry) -> Lap:
    return Lap(
        trial=entry.trial or number,
        time_ms=entry.elapsed_time_in_milliseconds,
        completion_pct=entry.completion_percentage,
        status=entry.episode_status,
        off_track=entry.off_track_count,
        crashes=entry.crash_count,
        resets=entry.reset_count,
        started_ms=entry.start_time,
        ended_ms=entry.metric_time,
        immobilized=entry.immobilized_count,
        reversed=entry.reversed_count,
    )


def load_training(files: Iterable[tuple[bytes, str]], training_track: str | None) -> TrainingSummary:
    """Summarise one or more training metrics files (one per DeepRacer-for-Cloud worker).

    ``files`` may be a generator, so that only one file's bytes are in memory at a time."""
    episodes: list[_TrainingEntry] = []
    duration_s = 0.0
    for data, name in files:
        entries = validate_json(_TrainingFile, data, name).metrics
        if len(episodes) + len(entries) > limits.MAX_TRAINING_ENTRIES:
            raise AssemblyError(name, "metrics", f"the training metrics hold over "
                                f"{limits.MAX_TRAINING_ENTRIES:,} entries, past any training's")
        training = [e for e in entries if e.phase.strip().lower() == "training"]
        episodes.extend(training)
        duration_s = max(duration_s, _duration_s(entries))
        del entries
    rewards = [e.reward_score for e in episodes]
    completions = [e.completion_percentage for e in episodes]
    return TrainingSummary(
        track=training_track,
        episodes=len(episodes),
        training_time_s=round(min(duration_s, limits.MAX_TRAINING_S), 1),
        best_reward=max(rewards) if rewards else None,
        mean_reward=_round(sum(rewards) / len(rewards)) if rewards else None,
        best_completion_pct=max(completions, default=0.0),
        mean_completion_pct=_round(sum(completions) / len(completions)) if completions else 0.0,
        completed_laps=sum(1 for c in completions if c >= 100),
        curve=_curve(episodes),
    )


def _duration_s(entries: list[_TrainingEntry]) -> float:
    """From the first episode's start to the last one's end, by the timestamps of the entries
    whose timestamps agree with their own elapsed time (a timestamp that does not is nonsense,
    and left out); the episodes' times added up where no entry's timestamps can be trusted."""
    timed = [e for e in entries if e.start_time is not None and e.metric_time is not None
             and abs(e.metric_time - e.start_time - e.elapsed_time_in_milliseconds) <= TIMESTAMP_TOLERANCE_MS]
    if not timed:
        return sum(e.elapsed_time_in_milliseconds for e in entries) / 1000
    ends = [e.metric_time or 0.0 for e in timed]
    return max(0.0, (max(ends) - min(e.start_time or 0.0 for e in timed)) / 1000)


def _curve(episodes: list[_TrainingEntry]) -> list[CurvePoint]:
    """At most MAX_CURVE_POINTS points: the mean reward and completion of equal buckets."""
    ordered = sorted(episodes, key=lambda e: e.episode)
    if not ordered:
        return []
    buckets = min(limits.MAX_CURVE_POINTS, len(ordered))
    points = []
    for index in range(buckets):
        chunk = ordered[index * len(ordered) // buckets:(index + 1) * len(ordered) // buckets]
        points.append(CurvePoint(
            episode=chunk[-1].episode,
            reward=_round(sum(e.reward_score for e in chunk) / len(chunk)),
            completion_pct=_round(sum(e.completion_percentage for e in chunk) / len(chunk)),
        ))
    return points


def _round(value: float) -> float:
    return round(value, 2)
