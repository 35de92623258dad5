"""Domain and output models of the leaderboard.

Boards, entries and submissions are what the service reasons about; the *View models are what
the API returns and the CLI prints (their field names are the stable JSON the README documents).
"""

from __future__ import annotations

from datetime import datetime
from enum import StrEnum
from typing import Annotated, Any, Literal

from drboard_assembler.record import RaceType, Record
from pydantic import BaseModel, ConfigDict, Field, model_validator

MAX_PAGE = 500


class TimingMethod(StrEnum):
    BEST_LAP_TIME = "BEST_LAP_TIME"
    AVG_LAP_TIME = "AVG_LAP_TIME"
    TOTAL_TIME = "TOTAL_TIME"


DEFAULT_MIN_LAPS = {
    TimingMethod.BEST_LAP_TIME: 1,
    TimingMethod.AVG_LAP_TIME: 3,
    TimingMethod.TOTAL_TIME: 3,
}


class Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BoardRules(Model):
    """How a board times its racers. ``min_laps`` defaults to the method's own (1, 3, 3)."""

    method: TimingMethod = TimingMethod.BEST_LAP_TIME
    min_laps: Annotated[int, Field(ge=1, le=100)] = 1

    @model_validator(mode="before")
    @classmethod
    def _method_default_laps(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("min_laps") is None:
            method = TimingMethod(data.get("method", TimingMethod.BEST_LAP_TIME))
            data = {**data, "min_laps": DEFAULT_MIN_LAPS[method]}
        return data


class Board(Model):
    board_id: str
    track: str
    direction: Literal["cw", "ccw"] | None = None
    race_type: RaceType = RaceType.TIME_TRIAL
    title: str
    rules: BoardRules = BoardRules()
    created_at: datetime


class Score(Model):
    """How a submission places under a board's rules."""

    qualified: bool
    time_ms: int | None  # the timing method's figure, when qualified
    best_completion_pct: float
    laps_completed: int
    best_lap_ms: int | None
    run: str  # the evaluation run that scored


class Design(Model):
    """The short form of a model's design, shown beside each entry."""

    algorithm: str
    action_space: Literal["discrete", "continuous"]
    actions: int | None
    max_speed: float
    max_steering: float
    sensors: list[str]


class Entry(Model):
    """A racer's best submission on a board."""

    board_id: str
    racer: str
    racer_key: str
    model_name: str
    submission_id: str
    achieved_at: datetime
    score: Score
    design: Design
    score_key: str
    rank_key: str


class Submission(Model):
    """One accepted push, kept in the racer's history."""

    board_id: str
    racer: str
    racer_key: str
    submission_id: str
    model_name: str
    submitted_at: datetime
    score: Score
    score_key: str


class WriteOutcome(Model):
    duplicate: bool
    improved: bool
    entry: Entry


# ---- views: what the API returns and the CLI prints --------------------------------------


class EntryView(Model):
    rank: int
    racer: str
    model_name: str
    qualified: bool
    time_ms: int | None
    gap_ms: int | None
    best_lap_ms: int | None
    laps_completed: int
    best_completion_pct: float
    submitted_at: datetime
    submission_id: str
    design: Design


class BoardView(Model):
    board_id: str
    track: str
    track_name: str
    direction: Literal["cw", "ccw"] | None
    race_type: RaceType
    method: TimingMethod
    min_laps: int
    title: str
    participants: int


class BoardPage(Model):
    board: BoardView
    entries: list[EntryView]
    next_cursor: str | None = None


class HistoryItem(Model):
    board_id: str
    submission_id: str
    submitted_at: datetime
    model_name: str
    qualified: bool
    time_ms: int | None
    best_lap_ms: int | None
    laps_completed: int
    best_completion_pct: float
    is_best: bool


class RacerView(Model):
    board: BoardView
    racer: str
    entry: EntryView
    history: list[HistoryItem]
    record: Record  # the best submission's full record: its design, laps and training


class PushReceipt(Model):
    status: Literal["created", "duplicate"]
    board_id: str
    submission_id: str
    improved: bool
    rank: int
    participants: int
    entry: EntryView
    submission: HistoryItem
