"""Training metrics files -> the record's training summary.

A long DeepRacer-for-Cloud training writes hundreds of megabytes of entries, over a million of
them. A large file is read a batch of entries at a time into compact arrays of the figures the
summary needs, so that memory stays near the file's own size: the rest of the document is checked
as JSON with its entries left out, and each batch, cut between two entries, is validated as the
record's bounds require. Where the batches do not read, the whole file is validated at once, which
gives the same answer and names what is wrong.
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
from .errors import AssemblyError
from .reading import validate_json
from .record import CurvePoint, Figure, Moment, Percent, TrainingSummary

Episode = Annotated[int, Field(ge=0, le=100_000_000)]
Finite = Annotated[Figure, Field(allow_inf_nan=False)]
Timestamp = Annotated[Moment, Field(allow_inf_nan=False)]
#: How far an entry's end minus its start may stray from its elapsed time (both are rounded).
TIMESTAMP_TOLERANCE_MS = 1000
#: Files past this size are read a batch of entries (of about BATCH_BYTES) at a time.
BATCHED_FROM_BYTES = 64 * limits.MIB
BATCH_BYTES = 4 * limits.MIB

_METRICS_ARRAY = re.compile(rb'"metrics"\s*:\s*\[')
#: Between two entries: the one's closing brace, a comma, the other's opening brace.
_BETWEEN_ENTRIES = re.compile(rb"\}\s*,\s*\{")


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
        self._add_times(batch)
        training = [e for e in batch if _is_training(e)]
        self.episodes.extend(e.episode for e in training)
        self.rewards.extend(e.reward_score for e in training)
        self.completions.extend(e.completion_percentage for e in training)

    def _add_times(self, batch: list[_TrainingEntry]) -> None:
        self.elapsed_ms += sum(e.elapsed_time_in_milliseconds for e in batch)
        timed = [(e.start_time or 0.0, e.metric_time or 0.0) for e in batch if _timestamps_agree(e)]
        if timed:
            self.first_start = min(self.first_start, min(start for start, _ in timed))
            self.last_end = max(self.last_end, max(end for _, end in timed))

    def duration_s(self) -> float:
        """From the first episode's start to the last one's end, by the timestamps of the entries
        whose timestamps agree with their own elapsed time (a timestamp that does not is nonsense,
        and left out); the episodes' times added up where no entry's timestamps can be trusted."""
        if self.last_end < self.first_start:
            return self.elapsed_ms / 1000
        return max(0.0, (self.last_end - self.first_start) / 1000)


def _is_training(entry: _TrainingEntry) -> bool:
    return entry.phase == "training" or entry.phase.strip().lower() == "training"


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
        tally = _file_tally(data, name, total.entries)
        duration_s = max(duration_s, tally.duration_s())
        total.entries += tally.entries
        total.episodes.extend(tally.episodes)
        total.rewards.extend(tally.rewards)
        total.completions.extend(tally.completions)
    return _summary(total, duration_s, training_track)


def _file_tally(data: bytes, name: str, before: int) -> _Tally:
    """One file's figures: a large file's a batch at a time, else (or when its batches do not
    read) the whole file's at once, which names what is wrong."""
    chunks = _entry_chunks(data) if len(data) >= BATCHED_FROM_BYTES else None
    if chunks is not None:
        tally = _Tally()
        try:
            for chunk in chunks:
                tally.add(_BATCH.validate_json(chunk))
                _check_count(before + tally.entries, name)
            return tally
        except ValidationError:
            pass
    tally = _Tally()
    tally.add(validate_json(_TrainingFile, data, name).metrics)
    _check_count(before + tally.entries, name)
    return tally


def _check_count(entries: int, name: str) -> None:
    if entries > limits.MAX_TRAINING_ENTRIES:
        raise AssemblyError(name, "metrics", f"the training metrics hold over "
                            f"{limits.MAX_TRAINING_ENTRIES:,} entries, past any training's")


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


def _entry_chunks(data: bytes) -> Iterator[bytes] | None:
    """``{"metrics": [{...}, ...]}`` cut into JSON arrays of about BATCH_BYTES each, between two
    entries; None when the document around the entries is not that."""
    opening = _METRICS_ARRAY.search(data)
    closing = data.rfind(b"]")
    if opening is None or closing < opening.end():
        return None
    try:
        rest = json.loads(data[:opening.end() - 1] + b"[]" + data[closing + 1:])
    except (ValueError, RecursionError):
        return None
    if not isinstance(rest, dict) or rest.get("metrics") != []:
        return None
    return _chunks(data, opening.end(), closing)


def _chunks(data: bytes, start: int, end: int) -> Iterator[bytes]:
    while start < end:
        cut = _BETWEEN_ENTRIES.search(data, min(start + BATCH_BYTES, end), end)
        stop = cut.start() + 1 if cut else end
        yield b"[" + data[start:stop] + b"]"
        start = cut.end() - 1 if cut else end


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
