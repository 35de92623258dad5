"""What the API returns and the CLI prints: the views built from stored rows. Their field names
are the stable JSON the README documents."""

from datetime import datetime
from typing import Literal

from drboard_assembler.record import Conditions, EvaluationRun, RaceType, Record
from pydantic import Field

from .domain import (
    AuditEvent,
    BoardConditions,
    BoardStatus,
    Design,
    Designs,
    FlaggedRuns,
    Model,
    TimingMethod,
)


class AuditPage(Model):
    board_id: str
    events: list[AuditEvent]
    next_cursor: str | None = None


class Me(Model):
    """Who the board takes the caller for, and the alias they push as."""

    principal: str
    name: str
    organiser: bool
    alias: str | None


class Moderation(Model):
    """What an organiser's remove-entry, ban or unban left."""

    board: "BoardView"
    racer: str
    banned: bool
    entry_removed: bool
    #: Whether the racer is banned from every board of the event (the deployment), not only this one.
    everywhere: bool = False
    #: The sign-in (principal) the ban binds, when the racer's alias is claimed.
    principal: str | None = None


class AliasView(Model):
    """An alias and who holds it: a sign-in's principal, or ``reserved:<alias>`` while an
    organiser keeps it for a racer who has not signed in yet."""

    alias: str
    racer_key: str
    principal: str
    reserved: bool
    claimed_at: datetime


class AliasList(Model):
    aliases: list[AliasView]
    next_cursor: str | None = None


class RecheckPage(Model):
    """One page of a board's recheck: how many stored submissions it went through and what it
    flagged for the organiser; pass ``next_cursor`` until it is null."""

    board_id: str
    checked: int
    flagged: list["FlaggedRun"]
    next_cursor: str | None = None


class FlaggedRun(Model):
    board_id: str
    racer: str
    submission_id: str
    flag: str
    why: str


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


class RacerView(Model):
    board: BoardView
    racer: str
    entry: EntryView
    history: list[HistoryItem]
    #: The best submission's full record (its design, laps and training); None while the board
    #: keeps designs private.
    record: Record | None
    #: Where the racer's history goes on (``cursor``); None when ``history`` is the rest of it.
    next_cursor: str | None = None
    #: The evaluation run of the record that the entry's score comes from (what the racer page
    #: charts); None while the board keeps designs private.
    scored_run: EvaluationRun | None = None


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


class RacerStatus(Model):
    """Where a racer stands on one board: their latest submission and their best's rank."""

    board: BoardView
    racer: str
    latest: HistoryItem
    entry: EntryView
    submissions: int
    submissions_left: int | None  # None: the board sets no maximum
    next_submission_at: datetime | None  # None: the racer may submit now (if the board is open)


class RacerSummary(Model):
    racer: str
    boards: list[RacerStatus]


class RacerHistory(Model):
    racer: str
    history: list[HistoryItem]
    next_cursor: str | None = None


class BoardList(Model):
    """One page of the boards, by id; ``next_cursor`` is where the next page starts (a page may
    hold fewer than its limit when deleted boards were skipped)."""

    boards: list[BoardView]
    next_cursor: str | None = None


class DesignFacts(Model):
    """What a model's design comes down to, one comparable value per fact (None: not known)."""

    algorithm: str | None
    action_space: Literal["discrete", "continuous"] | None
    actions: int | None
    max_speed: float | None
    min_speed: float | None
    max_steering: float | None
    sensors: list[str] | None
    neural_network: str | None
    discount_factor: float | None
    learning_rate: float | None
    batch_size: int | None
    entropy: float | None
    epochs: int | None
    episodes_between_training: int | None
    loss_type: str | None
    training_time_s: float | None
    training_episodes: int | None
    #: The facts the run's files do not state (the others that are None do not apply).
    unknown: list[str] = []


class ComparedRacer(Model):
    racer: str
    entry: EntryView
    facts: DesignFacts


class Comparison(Model):
    board: BoardView
    racers: list[ComparedRacer]
    #: The facts (DesignFacts' field names) on which the racers' designs differ.
    differences: list[str]


class SharedFact(Model):
    """One fact of the top models against the whole field: the most common value and how many
    have it (a choice), or the median (a number)."""

    fact: str
    label: str
    top: str
    field: str
    top_share: float | None = None
    field_share: float | None = None


class SpeedPoint(Model):
    racer: str
    max_speed: float
    time_ms: int | None
    top: bool


class Insights(Model):
    board: BoardView
    top: int
    field: int
    facts: list[SharedFact]
    points: list[SpeedPoint]


class RankCounters(Model):
    """How far the building of a board's rank counters got (a board from before them ranks by
    counting its entries until they are built)."""

    board_id: str
    done: bool
    counted: int = Field(description="Entries counted so far.")
    participants: int
