"""Training metrics files -> the record's training summary.

A long DeepRacer-for-Cloud training writes hundreds of megabytes of entries, over a million of
them. A large file is read a batch of entries at a time into compact arrays of the figures the
summary needs, so that memory stays near the file's own size: the rest of the document is checked
as JSON with its entries left out, and each batch is validated as the record's bounds require.
"""

from __future__ import annotations

import json
import re
from array import array
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError
from pydantic.dataclasses import dataclass as validated_dataclass

from . import limits
from .errors import AssemblyError, field_path
from .reading import from_validation_error, validate_json
from .record import CurvePoint, Figure, Moment, Percent, TrainingSummary

Episode = Annotated[int, Field(ge=0, le=100_000_000)]
Finite = Annotated[Figure, Field(allow_inf_nan=False)]
Timestamp = Annotated[Moment, Field(allow_inf_nan=False)]
#: How far an entry's end minus its start may stray from its elapsed time (both are rounded).
TIMESTAMP_TOLERANCE_MS = 1000
#: Files past this size are read a batch of entries at a time.
BATCHED_FROM_BYTES = 8 * limits.MIB
BATCH_ENTRIES = 20_000

_METRICS_ARRAY = re.compile(rb'"metrics"\s*:\s*\[')
_FLAT_OBJECT = re.compile(rb"\{[^{}\[\]]*\}")
_SPACE = re.compile(rb"\s*")


@validated_dataclass(slots=True, config=ConfigDict(extra="ignore"))
class _TrainingEntry:
    completion_percentage: Percent
    elapsed_time_in_milliseconds: Annotated[int, Field(ge=0, le=limits.MAX_LAP_MS)]
    episode_status: Annotated[str, Field(max_length=32)] = ""
    trial: Annotated[int, Field(ge=0, le=100_000)] = 0
    episode: Episode = 0
    phase: Annotated[str, Field(max_length=32)] = "training"
    reward_score: Finite = 0.0
    start_time: Timestamp | None = None
    metric_time: Timestamp | None = None


class _TrainingFile(BaseModel):
    model_config = ConfigDict(extra="ignore")
    metrics: list[_TrainingEntry]


_BATCH = TypeAdapter(list[_TrainingEntry])


@dataclass
class _Tally:
    """The training episodes' figures, and the entries' timespan, as the batches are read."""

    episodes: array[int] = field(default_factory=lambda: array("q"))
    rewards: array[float] = field(default_factory=lambda: array("d"))
    completions: array[float] = field(default_factory=lambda: array("d"))
    entries: int = 0
    first_start: float = float("inf")
    last_end: float = float("-inf")
    elapsed_ms: float = 0.0

    def add(self, batch: list[_TrainingEntry]) -> None:
        self.entries += len(batch)
        for entry in batch:
            self.elapsed_ms += entry.elapsed_time_in_milliseconds
            if _timestamps_agree(entry):
                self.first_start = min(self.first_start, entry.start_time or 0.0)
                self.last_end = max(self.last_end, entry.metric_time or 0.0)
            if entry.phase.strip().lower() == "training":
                self.episodes.append(entry.episode)
                self.rewards.append(entry.reward_score)
                self.completions.append(entry.completion_percentage)

    def duration_s(self) -> float:
        """From the first episode's start to the last one's end, by the timestamps of the entries
        whose timestamps agree with their own elapsed time (a timestamp that does not is nonsense,
        and left out); the episodes' times added up where no entry's timestamps can be trusted."""
        if self.last_end < self.first_start:
            return self.elapsed_ms / 1000
        return max(0.0, (self.last_end - self.first_start) / 1000)


def _timestamps_agree(entry: _TrainingEntry) -> bool:
    if entry.start_time is None or entry.metric_time is None:
        return False
    drift = entry.metric_time - entry.start_time - entry.elapsed_time_in_milliseconds
    return abs(drift) <= TIMESTAMP_TOLERANCE_MS


def load_training(files: Iterable[tuple[bytes, str]], training_track: str | None) -> TrainingSummary:
    """Summarise one or more training metrics files (one per DeepRacer-for-Cloud worker), which
    train at once: the training's time is the longest file's.

    ``files`` may be a generator, so that only one file's bytes are in memory at a time."""
    total = _Tally()
    duration_s = 0.0
    for data, name in files:
        tally = _Tally()
        for batch in _batches(data, name):
            tally.add(batch)
            if total.entries + tally.entries > limits.MAX_TRAINING_ENTRIES:
                raise AssemblyError(name, "metrics", f"the training metrics hold over "
                                    f"{limits.MAX_TRAINING_ENTRIES:,} entries, past any training's")
        duration_s = max(duration_s, tally.duration_s())
        total.entries += tally.entries
        total.episodes.extend(tally.episodes)
        total.rewards.extend(tally.rewards)
        total.completions.extend(tally.completions)
    return _summary(total, duration_s, training_track)


def _summary(tally: _Tally, duration_s: float, track: str | None) -> TrainingSummary:
    rewards, completions = tally.rewards, tally.completions
    count = len(rewards)
    return TrainingSummary(
        track=track,
        episodes=count,
        training_time_s=round(min(duration_s, limits.MAX_TRAINING_S), 1),
        best_reward=max(rewards) if count else None,
        mean_reward=_round(sum(rewards) / count) if count else None,
        best_completion_pct=max(completions, default=0.0),
        mean_completion_pct=_round(sum(completions) / count) if count else 0.0,
        completed_laps=sum(1 for c in completions if c >= 100),
        curve=_curve(tally),
    )


def _batches(data: bytes, name: str) -> Iterator[list[_TrainingEntry]]:
    """The file's entries, all at once for a small file, else a batch at a time."""
    spans = _entry_spans(data) if len(data) >= BATCHED_FROM_BYTES else None
    if spans is None:
        yield validate_json(_TrainingFile, data, name).metrics
        return
    for first in range(0, len(spans), BATCH_ENTRIES):
        chunk = spans[first:first + BATCH_ENTRIES]
        try:
            yield _BATCH.validate_json(b"[" + b",".join(data[start:end] for start, end in chunk) + b"]")
        except ValidationError as error:
            raise _batch_error(error, first, name) from None


def _entry_spans(data: bytes) -> list[tuple[int, int]] | None:
    """Where each entry of ``{"metrics": [{...}, ...]}`` is, when the document is that: its
    entries flat objects, and the rest of it valid JSON. None when it is not so simple (the
    whole document is then validated at once, which names what is wrong)."""
    opening = _METRICS_ARRAY.search(data)
    if opening is None:
        return None
    spans, position = [], _SPACE.match(data, opening.end()).end()  # type: ignore[union-attr]
    while position < len(data) and data[position:position + 1] != b"]":
        entry = _FLAT_OBJECT.match(data, position)
        if entry is None:
            return None
        spans.append(entry.span())
        position = _SPACE.match(data, entry.end()).end()  # type: ignore[union-attr]
        if data[position:position + 1] == b",":
            position = _SPACE.match(data, position + 1).end()  # type: ignore[union-attr]
        elif data[position:position + 1] != b"]":
            return None
    try:
        rest = json.loads(data[:opening.end() - 1] + b"[]" + data[position + 1:])
    except (ValueError, RecursionError):
        return None
    return spans if isinstance(rest, dict) and rest.get("metrics") == [] else None


def _batch_error(error: ValidationError, first: int, name: str) -> AssemblyError:
    detail = error.errors(include_url=False)[0]
    location = list(detail["loc"])
    if location and isinstance(location[0], int):
        location[0] += first
    return AssemblyError(name, field_path(["metrics", *location]), detail["msg"]) if location else \
        from_validation_error(error, name)


def _curve(tally: _Tally) -> list[CurvePoint]:
    """At most MAX_CURVE_POINTS points: the mean reward and completion of equal buckets of the
    episodes, in episode order."""
    count = len(tally.episodes)
    if not count:
        return []
    order = sorted(range(count), key=tally.episodes.__getitem__)
    buckets = min(limits.MAX_CURVE_POINTS, count)
    points = []
    for index in range(buckets):
        chunk = order[index * count // buckets:(index + 1) * count // buckets]
        points.append(CurvePoint(
            episode=tally.episodes[chunk[-1]],
            reward=_round(sum(tally.rewards[i] for i in chunk) / len(chunk)),
            completion_pct=_round(sum(tally.completions[i] for i in chunk) / len(chunk)),
        ))
    return points


def coarser(curve: list[CurvePoint]) -> list[CurvePoint]:
    """The curve with half its points (no fewer than MIN_CURVE_POINTS): each pair of buckets
    merged into one, their means averaged (the buckets are of equal size, give or take one)."""
    if len(curve) <= limits.MIN_CURVE_POINTS:
        return curve
    pairs = [curve[index:index + 2] for index in range(0, len(curve), 2)]
    return [CurvePoint(episode=pair[-1].episode,
                       reward=_round(sum(p.reward for p in pair) / len(pair)),
                       completion_pct=_round(sum(p.completion_pct for p in pair) / len(pair)))
            for pair in pairs]


def _round(value: float) -> float:
    return round(value, 2)
