"""Evaluation metrics files -> evaluation runs (training metrics: training.py)."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from . import limits
from .errors import AssemblyError
from .reading import from_validation_error, validate_json
from .record import Count, EvaluationRun, Lap, Moment, Percent

# The record's own bounds, so that a file past them is refused naming its own field.
Trial = Annotated[int, Field(ge=0, le=100_000)]


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


class _EvaluationFile(BaseModel):
    model_config = ConfigDict(extra="ignore")
    metrics: list[_EvaluationEntry]


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
