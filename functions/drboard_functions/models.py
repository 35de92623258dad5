"""Domain and output models of the leaderboard.

Boards, entries and submissions are what the service reasons about; the *View models are what
the API returns and the CLI prints (their field names are the stable JSON the README documents).
"""

from datetime import UTC, datetime
from enum import StrEnum
from typing import Annotated, Any, Literal, Self

from drboard_assembler.record import RaceType, Record
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    SerializerFunctionWrapHandler,
    StringConstraints,
    model_serializer,
    model_validator,
)
from pydantic_core import from_json

MAX_PAGE = 500
MAX_COOLDOWN_S = 7 * 24 * 3600
MAX_SUBMISSIONS = 10_000
MAX_BANNED = 1000
MAX_BOARD_ID_CHARS = 80  # a custom track's name (64) and its direction and race suffixes
BOARD_ID_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"


def _aware_utc(moment: datetime) -> datetime:
    if moment.tzinfo is None:
        raise ValueError("give a time zone, e.g. 2026-12-01T18:00:00Z or +01:00")
    return moment.astimezone(UTC)


#: A moment with a time zone, kept in UTC.
Moment = Annotated[datetime, AfterValidator(_aware_utc)]
BoardId = Annotated[str, StringConstraints(pattern=BOARD_ID_PATTERN)]
Title = Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=120)]
Description = Annotated[str, StringConstraints(strip_whitespace=True, max_length=2000)]
CooldownSeconds = Annotated[int, Field(ge=0, le=MAX_COOLDOWN_S)]
SubmissionCap = Annotated[int, Field(ge=1, le=MAX_SUBMISSIONS)]


class TimingMethod(StrEnum):
    BEST_LAP_TIME = "BEST_LAP_TIME"
    AVG_LAP_TIME = "AVG_LAP_TIME"
    TOTAL_TIME = "TOTAL_TIME"


DEFAULT_MIN_LAPS = {
    TimingMethod.BEST_LAP_TIME: 1,
    TimingMethod.AVG_LAP_TIME: 3,
    TimingMethod.TOTAL_TIME: 3,
}


FlaggedRuns = Literal["rank", "unranked"]
#: Whether everyone sees how the entries' models were built now, or once the board closes.
Designs = Literal["public", "after-close"]


class Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class BoardRules(Model):
    """How a board times its racers. ``min_laps`` defaults to the method's own (1, 3, 3)."""

    method: TimingMethod = TimingMethod.BEST_LAP_TIME
    min_laps: Annotated[int, Field(ge=1, le=100)] = 1
    #: Whether a run the board's consistency checks flag still ranks, or only shows below the
    #: qualified racers.
    flagged_runs: FlaggedRuns = "rank"

    @model_validator(mode="before")
    @classmethod
    def _method_default_laps(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("min_laps") is None:
            method = TimingMethod(data.get("method", TimingMethod.BEST_LAP_TIME))
            data = {**data, "min_laps": DEFAULT_MIN_LAPS[method]}
        return data


class BoardStatus(StrEnum):
    UPCOMING = "UPCOMING"
    OPEN = "OPEN"
    CLOSED = "CLOSED"


class Board(Model):
    """A board and its rules. A track's default board (``kind="default"``) is made by its first
    push and keeps the default rules; an organiser's named boards set their own."""

    board_id: Annotated[str, StringConstraints(min_length=1, max_length=MAX_BOARD_ID_CHARS)]
    kind: Literal["default", "named"] = "default"
    track: Annotated[str, StringConstraints(min_length=1, max_length=64)]
    direction: Literal["cw", "ccw"] | None = None
    race_type: RaceType = RaceType.TIME_TRIAL
    title: Title
    description: Description = ""
    rules: BoardRules = BoardRules()
    opens_at: datetime | None = None
    closes_at: datetime | None = None
    cooldown_s: CooldownSeconds = 0
    max_submissions: SubmissionCap | None = None
    created_at: datetime
    deleted_at: datetime | None = None
    #: Racer keys an organiser banned: their pushes are refused, their entry kept off the board.
    banned: Annotated[list[str], Field(max_length=MAX_BANNED)] = []
    designs: Designs = "public"

    def designs_shown(self, now: datetime) -> bool:
        """Whether the entries' designs show now: always, or once the board has closed."""
        return self.designs == "public" or self.status(now) == BoardStatus.CLOSED

    @model_validator(mode="after")
    def _window_in_order(self) -> Self:
        if self.opens_at and self.closes_at and self.closes_at <= self.opens_at:
            raise ValueError("closes_at must be after opens_at")
        return self

    def status(self, now: datetime) -> BoardStatus:
        if self.opens_at is not None and now < self.opens_at:
            return BoardStatus.UPCOMING
        if self.closes_at is not None and now >= self.closes_at:
            return BoardStatus.CLOSED
        return BoardStatus.OPEN


def run_mismatches(track: str, direction: str | None, race_type: RaceType,
                   board: "Board | BoardView") -> list[str]:
    """Which of a run's track, direction and race type keep it off the board (counter-clockwise
    and unspecified runs share a board): ``track``, ``direction``, ``race_type``, or none."""
    fields = []
    if track != board.track:
        fields.append("track")
    if (direction == "cw") != (board.direction == "cw"):
        fields.append("direction")
    if race_type != board.race_type:
        fields.append("race_type")
    return fields



class SubmissionLimits(Model):
    """What a store checks atomically with a push: the racer's last submission on the board is
    at least ``cooldown_s`` before ``now``, and they have made fewer than ``max_submissions``."""

    now: datetime
    cooldown_s: int = 0
    max_submissions: int | None = None


class RacerTally(Model):
    """How many submissions a racer made on a board, and when the last one was."""

    submissions: int = 0
    last_submitted_at: datetime | None = None


class Score(Model):
    """How a submission places under a board's rules."""

    qualified: bool
    time_ms: int | None  # the timing method's figure, when qualified
    best_completion_pct: float
    laps_completed: int
    best_lap_ms: int | None
    run: str  # the evaluation run that scored
    flags: list[str] = []  # the scoring run's consistency flags (see flags.py)


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


class AliasClaim(Model):
    """An alias and the sign-in that holds it: one alias per sign-in, one sign-in per alias."""

    racer_key: str
    alias: str
    principal: str
    claimed_at: datetime


AuditAction = Literal["push", "create", "update", "close", "delete", "restore", "import",
                      "remove-entry", "ban", "unban"]


class AuditEvent(Model):
    """One line of a board's audit trail: who did what, and when. Never changed or removed."""

    board_id: str
    at: datetime
    event_id: str  # unique, and in time order within a board
    action: AuditAction
    actor: str  # the caller's principal (``local``, ``cognito:<sub>``, ``iam:<arn>``, ``join:<id>``)
    actor_name: str = ""
    racer: str | None = None
    submission_id: str | None = None
    detail: str = ""


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


class AliasRequest(Model):
    alias: Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=64)]


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
    design: Design | None = Field(description="None while the board keeps designs private.")
    flags: list[str] = []


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


class PushReceipt(Model):
    status: Literal["created", "duplicate"]
    board_id: str
    submission_id: str
    improved: bool
    rank: int
    participants: int
    entry: EntryView
    submission: HistoryItem


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


# ---- managing boards -------------------------------------------------------------------------


class BoardSpec(Model):
    """A named board as an organiser creates it. The track is any of its names (or, with
    ``custom_track``, a track of their own named exactly); ``min_laps`` defaults to the method's."""

    board_id: Annotated[BoardId, Field(description="Letters, digits, `_`, `-` and `.`; up to 64.")]
    title: Title
    description: Description = ""
    track: Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=64)]
    custom_track: bool = False
    clockwise: bool = False
    race_type: RaceType = RaceType.TIME_TRIAL
    method: TimingMethod = TimingMethod.BEST_LAP_TIME
    min_laps: Annotated[int, Field(ge=1, le=100)] | None = None
    flagged_runs: FlaggedRuns = "rank"
    designs: Designs = "public"
    opens_at: Moment | None = None
    closes_at: Moment | None = None
    cooldown_s: CooldownSeconds = 0
    max_submissions: SubmissionCap | None = None


class BoardChanges(Model):
    """An update of a named board: only the fields given change; ``null`` clears a time or a
    limit. The track, method and minimum laps change only while the board has no entries."""

    title: Title | None = None
    description: Description | None = None
    method: TimingMethod | None = None
    min_laps: Annotated[int, Field(ge=1, le=100)] | None = None
    flagged_runs: FlaggedRuns | None = None
    designs: Designs | None = None
    opens_at: Moment | None = None
    closes_at: Moment | None = None
    cooldown_s: CooldownSeconds | None = None
    max_submissions: SubmissionCap | None = None


# ---- export and import -----------------------------------------------------------------------

class ExportedBoard(Model):
    kind: Literal["board"] = "board"
    format: Literal["drboard-export/1"] = "drboard-export/1"
    exported_at: datetime
    board: Board


class ExportedEntry(Model):
    kind: Literal["entry"] = "entry"
    entry: Entry


class ExportedSubmission(Model):
    kind: Literal["submission"] = "submission"
    submission: Submission
    record: Record


class StoredSubmissionLine(ExportedSubmission):
    """A submission line as an export reads it from the board's own store: the record stays the
    JSON it was stored as (validated when it was pushed) and is written out as it is. It is
    parsed only when ``record`` is read, so exporting a big board validates no record."""

    _record_json: str | bytes = PrivateAttr(default="")

    @classmethod
    def of(cls, submission: Submission, record_json: str | bytes) -> "StoredSubmissionLine":
        fields: dict[str, Any] = {"submission": submission}  # no record: see __getattr__
        line = cls.model_construct(**fields)
        line._record_json = record_json
        return line

    def __getattr__(self, name: str) -> Any:
        if name == "record" and "record" not in self.__dict__:
            record = Record.model_validate_json(self._record_json, context={"draft": True})
            self.__dict__["record"] = record
            return record
        return super().__getattr__(name)  # type: ignore[misc]

    @model_serializer(mode="wrap")
    def _as_stored(self, handler: SerializerFunctionWrapHandler) -> Any:
        if "record" in self.__dict__:
            return handler(self)
        return {"kind": self.kind, "submission": self.submission.model_dump(mode="json"),
                "record": from_json(self._record_json)}


ExportLine = Annotated[ExportedBoard | ExportedEntry | ExportedSubmission, Field(discriminator="kind")]


class ExportPage(Model):
    """One page of a board's export: the board first, then its entries, then every submission."""

    lines: list[ExportLine]
    next_cursor: str | None = None


class ImportedSubmission(Model):
    """A submission as an import replays it: the record, and when it was first submitted."""

    submitted_at: Moment
    record: Record


class ImportReceipt(Model):
    status: Literal["created", "duplicate"]
    board_id: str
    submission_id: str


# ---- comparing designs ---------------------------------------------------------------------------


class DesignFacts(Model):
    """What a model's design comes down to, one comparable value per fact (None: not known)."""

    algorithm: str
    action_space: Literal["discrete", "continuous"]
    actions: int | None
    max_speed: float
    min_speed: float | None
    max_steering: float
    sensors: list[str]
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
