"""The leaderboard's domain: boards and their rules, entries, submissions, scores, aliases and
the audit trail, as the service reasons about them and the stores keep them.

The values the service and the stores only hand each other (a run's print and its authors, a
racer's tally, a push's limits and its outcome) are plain named tuples: they are made from what
was checked already and never read from JSON, so there is nothing to validate and no schema to
build when a function starts."""

from datetime import UTC, datetime
from typing import TYPE_CHECKING, Annotated, Any, Literal, NamedTuple, Self, TypeVar

from drboard_assembler.record import Conditions, RaceType
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, StringConstraints, model_validator

from ..cursors import MAX_PAGE as MAX_PAGE  # the bound of pages, kept with their cursors
from ..display import design_known
from .kinds import BoardStatus as BoardStatus  # with the other models' names, for their users
from .kinds import TimingMethod as TimingMethod

if TYPE_CHECKING:
    from .views import BoardView


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


DEFAULT_MIN_LAPS = {
    TimingMethod.BEST_LAP_TIME: 1,
    TimingMethod.AVG_LAP_TIME: 3,
    TimingMethod.TOTAL_TIME: 3,
}


FlaggedRuns = Literal["rank", "unranked"]


#: Whether everyone sees how the entries' models were built now, or once the board closes.
Designs = Literal["public", "after-close"]


class Model(BaseModel):
    # defer_build: a model's schema is built when it is first used, not when its module is
    # imported (a function imports more models than its first request uses).
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class BoardConditions(Model):
    """The evaluation conditions a board requires of a run: each one given must be what the
    run's evaluation parameters state (community boards pin them, as the league did, because
    runs evaluated under other rules are not comparable)."""

    off_track_penalty_s: Annotated[float, Field(ge=0, le=3600)] | None = None
    collision_penalty_s: Annotated[float, Field(ge=0, le=3600)] | None = None
    max_resets: Annotated[int, Field(ge=0, le=1_000_000)] | None = None
    trials: Annotated[int, Field(ge=1, le=100_000)] | None = None
    continuous: bool | None = None
    obstacles: Annotated[int, Field(ge=0, le=1000)] | None = None
    bots: Annotated[int, Field(ge=0, le=1000)] | None = None

    def required(self) -> dict[str, Any]:
        return self.model_dump(exclude_none=True)


class BoardRules(Model):
    """How a board times its racers. ``min_laps`` defaults to the method's own (1, 3, 3)."""

    method: TimingMethod = TimingMethod.BEST_LAP_TIME
    min_laps: Annotated[int, Field(ge=1, le=100)] = 1
    #: Whether a run the board's consistency checks flag still ranks, or only shows below the
    #: qualified racers.
    flagged_runs: FlaggedRuns = "rank"
    #: The evaluation conditions a run must have been evaluated under (None: any).
    conditions: BoardConditions | None = None

    @model_validator(mode="before")
    @classmethod
    def _method_default_laps(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("min_laps") is None:
            method = TimingMethod(data.get("method", TimingMethod.BEST_LAP_TIME))
            data = {**data, "min_laps": DEFAULT_MIN_LAPS[method]}
        return data


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
    #: The sign-ins (principals) of banned racers: refused whatever alias they push as.
    banned_principals: Annotated[list[str], Field(max_length=MAX_BANNED)] = []
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


class EventBans(Model):
    """Bans across every board of the event: the boards one deployment holds (a stack's table,
    one `drboard serve`, one embedded board file). A banned racer key or sign-in (principal) is
    refused on every board, under any alias."""

    racers: Annotated[list[str], Field(max_length=MAX_BANNED)] = []
    principals: Annotated[list[str], Field(max_length=MAX_BANNED)] = []


class RunPrint(NamedTuple):
    """What identifies one evaluation run of a submission, for copies and near-copies: its
    fingerprint, the lane its lap times compare in (track and direction), and the sorted times
    of its complete laps when it has enough of them to be compared (else None)."""

    fingerprint: str
    lane: str
    laps_ms: list[int] | None = None


class RunAuthor(NamedTuple):
    """A racer who pushed a run (by fingerprint), and when they first did, anywhere."""

    fingerprint: str
    racer_key: str
    first_at: datetime
    board_id: str
    submission_id: str


class NearRun(NamedTuple):
    """A stored run whose complete laps may be close to another's (see RunPrint)."""

    fingerprint: str
    racer_key: str
    board_id: str
    submission_id: str
    laps_ms: list[int]


class RacerTally(NamedTuple):
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
    conditions: Conditions | None = None  # what the scoring run's evaluation ran under


class Design(Model):
    """The short form of a model's design, shown beside each entry; None where the run's files
    do not state a fact (entries stored before facts could be unknown hold them all)."""

    algorithm: str | None = None
    action_space: Literal["discrete", "continuous"] | None = None
    actions: int | None = None
    max_speed: float | None = None
    max_steering: float | None = None
    sensors: list[str] | None = None

    @property
    def known(self) -> bool:
        return design_known(self)


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


class SubmissionLimits(NamedTuple):
    """What a store checks atomically with a push: the racer's last submission on the board is
    at least ``cooldown_s`` before ``now``, and they have made fewer than ``max_submissions``;
    and, when given, that the board's settings and the event's bans are still at the versions
    the push was checked against (else BoardChanged, nothing written)."""

    now: datetime
    cooldown_s: int = 0
    max_submissions: int | None = None
    settings_version: int | None = None
    bans_version: int | None = None
    #: The racer's entry as the push read it (None: no entry then). A store may write against
    #: it without reading it again: its write is conditioned on the entry still being this one.
    entry_seen: Entry | None = None


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


Flagged = TypeVar("Flagged", Entry, Submission)


def with_flag(item: Flagged, flag: str) -> Flagged:
    """The entry or submission with one more flag on its score."""
    score = item.score.model_copy(update={"flags": [*item.score.flags, flag]})
    return item.model_copy(update={"score": score})


def without_flag(item: Flagged, flag: str) -> Flagged:
    """The entry or submission without ``flag`` on its score."""
    score = item.score.model_copy(update={"flags": [f for f in item.score.flags if f != flag]})
    return item.model_copy(update={"score": score})


class AliasClaim(Model):
    """An alias and the sign-in that holds it: one alias per sign-in, one sign-in per alias."""

    racer_key: str
    alias: str
    principal: str
    claimed_at: datetime


AuditAction = Literal["push", "create", "update", "close", "delete", "restore", "import",
                      "remove-entry", "ban", "unban", "flag", "unflag", "alias-reserve",
                      "alias-release", "alias-assign", "recheck", "webhook-add", "webhook-remove"]


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


class WriteOutcome(NamedTuple):
    duplicate: bool
    improved: bool
    entry: Entry
