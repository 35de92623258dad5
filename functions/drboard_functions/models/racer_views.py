"""What a racer's pages show, and what the board compares of racers' designs (see ``views``):
a racer's entry, record and history, where they stand on each board, designs side by side and
what the fastest models share."""

from datetime import datetime
from typing import Literal

from drboard_assembler.record import EvaluationRun, Record

from .domain import Model
from .views import BoardView, EntryView, HistoryItem


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
