"""The Record: one submission to the board, as the assembler builds it and the server re-validates it.

Derived figures (laps completed, best lap, ...) travel with the record for readers, but the model
recomputes them from the laps and refuses a record whose figures disagree, so a client cannot
claim a time its laps do not show. ``submission_id`` is the sha256 of the record's canonical
content, so pushing the same run twice is recognised as a duplicate.

No ``from __future__ import annotations`` here: pydantic would have to compile and evaluate every
field's annotation from its string when the classes are built, which costs each Lambda cold start
~2-3 ms (the few forward references are quoted instead).
"""

import hashlib
import json
import re
from collections.abc import Iterator
from enum import StrEnum
from typing import Annotated, Any, Literal, NamedTuple, Self

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    ValidationInfo,
    model_validator,
)
from pydantic_core import from_json

from . import limits
from .aliases import alias_problem, text_problem, texts
from .catalog import default_catalog

SCHEMA_VERSION: Literal[1] = 1
#: Laps faster than the track's shortest lap driven at this multiple of the top speed are refused
#: (the board flags, but keeps, laps faster than it at the top speed itself).
PLAUSIBLE_SPEED_FACTOR = 2.0
#: The top speed a DeepRacer action space can ask for, in m/s: whatever a record claims, no lap
#: is timed as if the car went faster; a model whose action space is unknown is taken at it.
TOP_SPEED_BOUND_MPS = 4.0
#: No complete lap is faster than this, on any track, custom tracks included (the shortest
#: official lap, 12.3 m on the A to Z Speedway, takes 3.1 s at the top speed bound).
MIN_LAP_MS = 2000
#: Every other figure a record holds (rewards, hyperparameters) lies within ±this.
MAX_MAGNITUDE = 1e9

Name = Annotated[
    str,
    StringConstraints(
        strip_whitespace=True, min_length=1, max_length=limits.MAX_NAME_CHARS,
        pattern=r"^[^\x00-\x1f\x7f]+$",
    ),
]


def _no_lookalike(alias: str, info: ValidationInfo) -> str:
    if stored(info.context):
        return alias
    problem = alias_problem(alias)
    if problem:
        raise ValueError(f"the alias {alias!r} {problem}")
    return alias


def stored(context: Any) -> bool:
    """Whether a record is being read back from a board's own store: it was checked when it was
    stored, and is never checked again with today's rules (the catalog, the lap floors, the
    alias and text rules, its content hash), so tightening a rule never breaks a page."""
    return bool((context or {}).get("stored"))


#: A custom track's name: it becomes part of a board id (``custom.<track>``) and of its URLs.
CUSTOM_TRACK_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"


#: A racer's alias: a Name that cannot pass for another racer's in print.
Alias = Annotated[Name, AfterValidator(_no_lookalike)]
Text = Annotated[str, StringConstraints(max_length=limits.MAX_TEXT_CHARS)]
#: A number a record may hold anywhere: finite (the models refuse NaN and Infinity) and bounded.
Figure = Annotated[float, Field(ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE)]
Whole = Annotated[int, Field(ge=-int(MAX_MAGNITUDE), le=int(MAX_MAGNITUDE))]
#: A simulation timestamp in milliseconds (from its start, or since 1970).
Moment = Annotated[float, Field(ge=0, le=1e14)]
Sha256 = Annotated[str, StringConstraints(pattern=r"^[0-9a-f]{64}$")]
Count = Annotated[int, Field(ge=0, le=1_000_000)]
#: A number of training episodes: a weeks-long training of several workers runs past a million.
Episodes = Annotated[int, Field(ge=0, le=100_000_000)]
#: A time penalty, in seconds.
Penalty = Annotated[float, Field(ge=0, le=3600)]
Percent = Annotated[float, Field(ge=0, le=100)]


class RaceType(StrEnum):
    TIME_TRIAL = "TIME_TRIAL"
    OBJECT_AVOIDANCE = "OBJECT_AVOIDANCE"
    HEAD_TO_BOT = "HEAD_TO_BOT"
    HEAD_TO_MODEL = "HEAD_TO_MODEL"
    HEAD_TO_HEAD_RACING = "HEAD_TO_HEAD_RACING"
    F1 = "F1"


class SourceLayout(StrEnum):
    CONSOLE = "console"
    DRFC = "drfc"
    DROA = "droa"
    PLAIN = "plain"


class Strict(BaseModel):
    # NaN and Infinity would be stored as JSON null, and every later read of the record fail.
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, defer_build=True)


class Lap(Strict):
    trial: Annotated[int, Field(ge=0, le=100_000)]
    time_ms: Annotated[int, Field(ge=0, le=limits.MAX_LAP_MS)]
    completion_pct: Percent
    status: Annotated[str, StringConstraints(max_length=32)]
    off_track: Count = 0
    crashes: Count = 0
    resets: Count = 0
    # What the metrics file says besides (None where it does not): when the lap started and
    # ended, in the simulation's milliseconds, and the resets' other two causes. The board
    # checks each lap's time and reset count against them.
    started_ms: Moment | None = None
    ended_ms: Moment | None = None
    immobilized: Count | None = None
    reversed: Count | None = None

    @property
    def complete(self) -> bool:
        # "In progress" at 100 % happens in continuous evaluations: completion decides.
        return self.completion_pct >= 100


class Conditions(Strict):
    """The rules an evaluation ran under, as its parameters state them (None where they do not).

    The simulator times a lap from its start to its end, the pauses of its penalties included:
    an off-track (or a collision) with resets allowed stops the car for the penalty's seconds, so
    a lap's time and a run's total already hold every penalty, as the league timed them.
    """

    off_track_penalty_s: Penalty | None = None
    collision_penalty_s: Penalty | None = None
    #: How many resets an off-track or a crash may use before the lap ends (0: none).
    max_resets: Annotated[int, Field(ge=0, le=1_000_000)] | None = None
    trials: Annotated[int, Field(ge=1, le=100_000)] | None = None
    continuous: bool | None = None
    obstacles: Annotated[int, Field(ge=0, le=1000)] | None = None
    bots: Annotated[int, Field(ge=0, le=1000)] | None = None
    #: The file that states them: evaluation parameters or the evaluation's log.
    source: Text | None = None

    def stated(self) -> dict[str, Any]:
        """The conditions the parameters state, by name (the source left out)."""
        return self.model_dump(exclude={"source"}, exclude_none=True)


class EvaluationRun(Strict):
    """One evaluation (one metrics file): its laps and the figures derived from them."""

    source: Text
    laps: Annotated[list[Lap], Field(min_length=1, max_length=limits.MAX_LAPS_PER_RUN)]
    laps_completed: Count
    best_lap_ms: int | None
    average_lap_ms: int | None
    total_time_ms: int
    best_completion_pct: Percent
    off_track_total: Count
    resets_total: Count
    #: Whether evaluation parameters in the run folder name this metrics file (None: the
    #: folder held no evaluation parameters).
    named_by_params: bool | None = None
    conditions: Conditions | None = None

    @classmethod
    def from_laps(cls, source: str, laps: list[Lap],
                  conditions: Conditions | None = None) -> "EvaluationRun":
        return cls(source=source, laps=laps, conditions=conditions, **_derived(laps))

    @model_validator(mode="after")
    def _figures_match_laps(self) -> Self:
        for name, expected in _derived(self.laps).items():
            if getattr(self, name) != expected:
                raise ValueError(f"{name} is {getattr(self, name)!r} but the laps give {expected!r}")
        return self

    @property
    def completed_times(self) -> list[int]:
        return [lap.time_ms for lap in self.laps if lap.complete]


def _derived(laps: list[Lap]) -> dict[str, Any]:
    done: list[int] = []
    total_ms = off_track = resets = 0
    best_pct: float | None = None
    for lap in laps:  # (one pass: every record read is checked against it)
        if lap.complete:
            done.append(lap.time_ms)
        total_ms += lap.time_ms
        if best_pct is None or lap.completion_pct > best_pct:
            best_pct = lap.completion_pct
        off_track += lap.off_track
        resets += lap.resets
    return {
        "laps_completed": len(done),
        "best_lap_ms": min(done) if done else None,
        "average_lap_ms": round(sum(done) / len(done)) if done else None,
        "total_time_ms": total_ms,
        "best_completion_pct": 0.0 if best_pct is None else best_pct,
        "off_track_total": off_track,
        "resets_total": resets,
    }


class Action(Strict):
    steering_angle: Annotated[float, Field(ge=-90, le=90)]
    speed: Annotated[float, Field(gt=0, le=10)]
    index: Annotated[int, Field(ge=0, le=limits.MAX_ACTIONS)] | None = None


class Range(Strict):
    low: Figure
    high: Figure

    @model_validator(mode="after")
    def _ordered(self) -> Self:
        if self.low > self.high:
            raise ValueError(f"low {self.low} is above high {self.high}")
        return self


class ActionSpace(Strict):
    type: Literal["discrete", "continuous"]
    actions: Annotated[list[Action], Field(max_length=limits.MAX_ACTIONS)] | None = None
    speed: Range | None = None
    steering_angle: Range | None = None
    max_speed: Annotated[float, Field(gt=0, le=10)]
    max_steering: Annotated[float, Field(ge=0, le=90)]

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.type == "discrete":
            if not self.actions:
                raise ValueError("a discrete action space needs at least one action")
            speed = max([a.speed for a in self.actions])  # (lists: every record read checks)
            steering = max([abs(a.steering_angle) for a in self.actions])
        else:
            if self.speed is None or self.steering_angle is None:
                raise ValueError("a continuous action space needs speed and steering_angle ranges")
            if not 0 < self.speed.high <= 10 or self.speed.low < 0:
                raise ValueError("speed range must lie within 0..10 m/s")
            if max(abs(self.steering_angle.low), abs(self.steering_angle.high)) > 90:
                raise ValueError("steering_angle range must lie within -90..90 degrees")
            speed = self.speed.high
            steering = max(abs(self.steering_angle.low), abs(self.steering_angle.high))
        if (self.max_speed, self.max_steering) != (speed, steering):
            raise ValueError("max_speed and max_steering must match the actions")
        return self


Scalar = bool | Whole | Figure | Annotated[str, StringConstraints(max_length=limits.MAX_NAME_CHARS)]


class Hyperparameters(Strict):
    """The training hyperparameters; PPO and SAC use different keys, so all are optional."""

    batch_size: Annotated[int, Field(gt=0, le=100_000)] | None = None
    beta_entropy: Figure | None = None
    discount_factor: Annotated[float, Field(ge=0, le=1)] | None = None
    e_greedy_value: Figure | None = None
    epsilon_steps: Annotated[int, Field(ge=0, le=int(MAX_MAGNITUDE))] | None = None
    exploration_type: Annotated[str, StringConstraints(max_length=32)] | None = None
    loss_type: Literal["huber", "mean_squared_error"] | None = None
    lr: Annotated[float, Field(gt=0, le=1)] | None = None
    num_episodes_between_training: Annotated[int, Field(gt=0, le=100_000)] | None = None
    num_epochs: Annotated[int, Field(gt=0, le=10_000)] | None = None
    stack_size: Annotated[int, Field(gt=0, le=100)] | None = None
    term_cond_avg_score: Figure | None = None
    term_cond_max_episodes: Annotated[int, Field(ge=0, le=int(MAX_MAGNITUDE))] | None = None
    sac_alpha: Figure | None = None
    other: Annotated[dict[Annotated[str, StringConstraints(max_length=64)], Scalar],
                     Field(max_length=limits.MAX_HYPERPARAMETERS)] = Field(default_factory=dict)


class DesignSources(Strict):
    """The file of the run folder each design fact was read from (None: the fact is unknown)."""

    algorithm: Text | None = None
    action_space: Text | None = None
    sensors: Text | None = None
    neural_network: Text | None = None
    metadata_version: Text | None = None
    hyperparameters: Text | None = None


class Design(Strict):
    """How the model was built: what the board shows racers besides times. Each fact is the
    evaluated model's, or None (unknown) where the run's files do not state it; records stored
    before facts could be unknown hold them all."""

    algorithm: Literal["clipped_ppo", "sac"] | None = None
    action_space: ActionSpace | None = None
    sensors: Annotated[list[Annotated[str, StringConstraints(max_length=32)]],
                       Field(max_length=limits.MAX_SENSORS)] | None = None
    neural_network: Annotated[str, StringConstraints(max_length=64)] | None = None
    metadata_version: Annotated[str, StringConstraints(max_length=16)] | None = None
    hyperparameters: Hyperparameters | None = None
    sources: DesignSources | None = None

    @property
    def max_speed(self) -> float | None:
        return self.action_space.max_speed if self.action_space is not None else None


class CurvePoint(Strict):
    episode: Episodes
    reward: Figure
    completion_pct: Percent


class TrainingSummary(Strict):
    track: Annotated[str, StringConstraints(max_length=limits.MAX_NAME_CHARS)] | None = None
    episodes: Episodes
    training_time_s: Annotated[float, Field(ge=0, le=MAX_MAGNITUDE)]
    best_reward: Figure | None
    mean_reward: Figure | None
    best_completion_pct: Percent
    mean_completion_pct: Percent
    completed_laps: Episodes
    curve: Annotated[list[CurvePoint], Field(max_length=limits.MAX_CURVE_POINTS)]


class SourceFile(Strict):
    role: Literal[
        "model_metadata", "hyperparameters", "training_params", "evaluation_params",
        "training_metrics", "evaluation_metrics", "simulation_log", "training_log",
    ]
    path: Text
    sha256: Sha256
    bytes: Annotated[int, Field(ge=0, le=limits.MAX_TRAINING_FILE_BYTES)]


class Record(Strict):
    schema_version: Literal[1] = SCHEMA_VERSION
    submission_id: Sha256
    track: Annotated[str, StringConstraints(min_length=1, max_length=limits.MAX_NAME_CHARS)]
    custom_track: bool = False
    direction: Literal["cw", "ccw"] | None = None
    racer: Alias
    model_name: Name
    race_type: RaceType = RaceType.TIME_TRIAL
    source_layout: SourceLayout
    assembler_version: Annotated[str, StringConstraints(max_length=32)]
    evaluations: Annotated[list[EvaluationRun],
                           Field(min_length=1, max_length=limits.MAX_EVALUATION_RUNS)]
    design: Design
    training: TrainingSummary | None = None
    provenance: Annotated[list[SourceFile], Field(max_length=limits.MAX_EVALUATION_RUNS * 2 + 8)]

    @classmethod
    def build(cls, **fields: Any) -> "Record":
        """Build a record, computing its submission id from its content."""
        fields["submission_id"] = "0" * 64
        draft = cls.model_validate(fields, context={"draft": True})
        return draft.model_copy(update={"submission_id": content_hash(draft)})

    def __repr_args__(self) -> Iterator[tuple[str, Any]]:
        # A record's repr names it, not its content: Powertools formats a route's arguments into
        # a debug line on every request, printed or not, which a whole record made a tenth of a
        # push's cost.
        for name in ("submission_id", "track", "racer", "model_name"):
            yield name, getattr(self, name)

    @model_validator(mode="after")
    def _check(self, info: Any) -> Self:
        if stored(info.context):
            return self
        self._check_text()
        self._check_track()
        self._check_lap_times()
        if not (info.context or {}).get("draft") and self.submission_id != content_hash(self):
            raise ValueError("submission_id does not match the record's content")
        return self

    def _check_text(self) -> None:
        # Nearly every record is printable through and through: its JSON (in which a control
        # character would be escaped with a backslash) says so in one pass, without a walk.
        dumped = self.model_dump_json(exclude={"racer"})
        if dumped.isprintable() and "\\" not in dumped:
            return
        for path, text in texts(self.model_dump(mode="json", exclude={"racer"})):
            problem = text_problem(text)
            if problem:
                raise ValueError(f"{'.'.join(map(str, path))}: {problem}")

    def _check_track(self) -> None:
        catalog = default_catalog()
        if self.custom_track:
            if catalog.lookup(self.track):
                raise ValueError(f"track {self.track!r} is an official track, not a custom one")
            if not re.match(CUSTOM_TRACK_PATTERN, self.track):
                raise ValueError(f"a custom track's name is letters, digits, _ - and . "
                                 f"(up to 64), not {self.track!r}")
        elif not catalog.is_official(self.track):
            raise ValueError(f"track {self.track!r} is not an official WORLD_NAME")

    def _check_lap_times(self) -> None:
        problem = implausible_lap(self.track, self.design.max_speed, self.evaluations)
        if problem:
            raise ValueError(f"{problem.run.source}: {problem.message}")

    @property
    def best_run(self) -> EvaluationRun:
        """The run with the fastest completed lap, else the one that got furthest."""
        return min(self.evaluations, key=lambda run: (
            (0, run.best_lap_ms) if run.best_lap_ms is not None else (1, -run.best_completion_pct)))


class ImplausibleLap(NamedTuple):
    run: EvaluationRun
    lap_index: int
    message: str


def top_speed(max_speed: float | None) -> float:
    """The speed a model's laps are checked against: its action space's top speed, never more
    than TOP_SPEED_BOUND_MPS, and that bound where the action space is unknown."""
    return TOP_SPEED_BOUND_MPS if max_speed is None else min(max_speed, TOP_SPEED_BOUND_MPS)


def lap_floor_ms(track_id: str, max_speed: float | None) -> float | None:
    """The fastest lap a model can drive on an official track: the shortest closed path the
    car's centre can take without going off track, at the model's top speed (None for a track
    whose shape the catalog does not hold)."""
    track = default_catalog().get(track_id)
    if track is None:
        return None
    return 1000 * track.shortest_lap_m / top_speed(max_speed)


def implausible_lap(track_id: str, max_speed: float | None,
                    runs: list[EvaluationRun]) -> ImplausibleLap | None:
    """The first complete lap under MIN_LAP_MS, or faster than the track's shortest lap (where
    it is known) driven at PLAUSIBLE_SPEED_FACTOR times the top speed."""
    floor = lap_floor_ms(track_id, max_speed)
    fastest_ms = max(float(MIN_LAP_MS), floor / PLAUSIBLE_SPEED_FACTOR if floor else 0.0)
    for run in runs:
        for index, lap in enumerate(run.laps):
            if lap.complete and lap.time_ms < fastest_ms:
                return ImplausibleLap(run, index, _too_fast(lap, track_id, max_speed, fastest_ms))
    return None


def _too_fast(lap: Lap, track_id: str, max_speed: float | None, fastest_ms: float) -> str:
    said = f"lap {lap.trial} time {lap.time_ms} ms is faster than possible: "
    track = default_catalog().get(track_id)
    if track is None or fastest_ms <= MIN_LAP_MS:
        return said + f"no complete lap takes under {MIN_LAP_MS} ms"
    return said + (f"the shortest lap of {track_id} ({track.shortest_lap_m:g} m) takes "
                   f"{fastest_ms:.0f} ms at twice a top speed of {top_speed(max_speed):g} m/s")


#: Fields added to the record after its first version: left out of its content hash while they
#: are empty, so that records stored before them keep their submission id.
_LATER_LAP_FIELDS = ("started_ms", "ended_ms", "immobilized", "reversed")
_LATER_RUN_FIELDS = ("named_by_params", "conditions")
_LATER_DESIGN_FIELDS = ("sources",)


#: The record's canonical JSON: keys sorted, no spaces, text as it is. Made once: ``json.dumps``
#: with these options makes a new encoder on every call. A record's content holds no cycle to
#: look for.
_CANONICAL = json.JSONEncoder(sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                              check_circular=False)


def content_hash(record: Record) -> str:
    """The sha256 of the record's canonical content: its JSON with keys sorted, without its
    submission id and assembler version, and without the later fields it leaves empty."""
    # Python's dump, not pydantic's JSON mode: the record holds no value the two write apart
    # (text, numbers, booleans, lists; its enums are text), and it is the faster by a third.
    return _hash_of(record.model_dump(exclude=_NOT_CONTENT))


def json_content_hash(record_json: str) -> str:
    """:func:`content_hash` of the record this JSON (a valid record's) holds, read without
    building the record, in half the time: the same hash for the JSON a record writes of itself.
    Other JSON of the same record (``9100.0`` for ``9100``) may hash otherwise: where the two
    disagree, the record's own hash decides."""
    content = from_json(record_json)
    for name in _NOT_CONTENT:
        content.pop(name, None)
    return _hash_of(content)


def _hash_of(content: dict[str, Any]) -> str:
    _drop_empty(content["design"], _LATER_DESIGN_FIELDS)
    for run in content["evaluations"]:
        _drop_empty(run, _LATER_RUN_FIELDS)
        for lap in run["laps"]:
            _drop_empty(lap, _LATER_LAP_FIELDS)
    return hashlib.sha256(_CANONICAL.encode(content).encode("utf-8")).hexdigest()


_NOT_CONTENT = {"submission_id", "assembler_version"}


def _drop_empty(fields: dict[str, Any], names: tuple[str, ...]) -> None:
    for name in names:
        if fields.get(name) is None:
            fields.pop(name, None)


def record_json_schema() -> dict[str, Any]:
    return Record.model_json_schema(mode="validation")
