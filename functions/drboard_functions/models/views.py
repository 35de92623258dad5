"""What the API returns and the CLI prints: the views built from stored rows. Their field names
are the stable JSON the README documents.

This module holds the views of boards and their standings, which every function shows (a push
answers with its rank and keeps the board's first page); a racer's pages, comparisons and
insights are in ``racer_views``, the organisers' in ``organiser_views``, so that a function
defines only the classes it answers with."""

from datetime import datetime
from typing import Literal

from drboard_assembler.record import Conditions, RaceType
from pydantic import Field

from .domain import (
    BoardConditions,
    BoardStatus,
    Design,
    Designs,
    FlaggedRuns,
    Model,
    TimingMethod,
)


class Me(Model):
    """Who the board takes the caller for, and the alias they push as."""

    principal: str
    name: str
    organiser: bool
    alias: str | None


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
    design: Design | None = Field(description="None while the board keeps designs private.")
    flags: list[str] = []
    conditions: Conditions | None = Field(None, description="The conditions the counted run's "
                                          "evaluation ran under, as its parameters state them.")


class BoardView(Model):
    board_id: str
    kind: Literal["default", "named"]
    title: str
    description: str
    track: str
    track_name: str
    direction: Literal["cw", "ccw"] | None
    race_type: RaceType
    method: TimingMethod
    min_laps: int
    flagged_runs: FlaggedRuns = "rank"
    conditions: BoardConditions | None = Field(None, description="The evaluation conditions the "
                                               "board requires (null: any).")
    designs: Designs = "public"
    status: BoardStatus
    opens_at: datetime | None
    closes_at: datetime | None
    cooldown_s: int
    max_submissions: int | None
    participants: int
    version: int = Field(0, description="Goes up with every change to the standings or the "
                                        "settings.")


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
    flags: list[str] = []


class PushReceipt(Model):
    status: Literal["created", "duplicate"]
    board_id: str
    submission_id: str
    improved: bool
    rank: int
    participants: int
    entry: EntryView
    submission: HistoryItem


class PushAccepted(Model):
    """A push that was stored, whose rank the board could not read back just then (HTTP 202):
    the racer's standing is at ``receipt`` (``GET``), and pushing the run again answers it."""

    status: Literal["accepted"] = "accepted"
    board_id: str
    submission_id: str
    racer: str
    receipt: str
    message: str


class BoardList(Model):
    """One page of the boards, by id; ``next_cursor`` is where the next page starts (a page may
    hold fewer than its limit when deleted boards were skipped)."""

    boards: list[BoardView]
    next_cursor: str | None = None
