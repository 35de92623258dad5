"""What callers ask of the board: an organiser's board settings and changes, an alias to claim,
a submission to import."""

from typing import Annotated

from drboard_assembler.record import RaceType, Record
from pydantic import Field, StringConstraints

from .domain import (
    BoardConditions,
    BoardId,
    CooldownSeconds,
    Description,
    Designs,
    FlaggedRuns,
    Model,
    Moment,
    SubmissionCap,
    TimingMethod,
    Title,
)


class AliasRequest(Model):
    alias: Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=64)]


class AliasAssignment(Model):
    """An organiser's hand on an alias: give it to a sign-in (``principal``, as `drboard whoami`
    shows it: ``cognito:<sub>``, ``join:<id>``), or keep it reserved for a racer who has not
    signed in yet (no principal)."""

    principal: Annotated[str, StringConstraints(min_length=1, max_length=256,
                                                pattern=r"^[a-z]+:[^\x00-\x1f\x7f]+$")] | None = None


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
    conditions: Annotated[BoardConditions | None, Field(
        description="The evaluation conditions a run must have been evaluated under (its "
                    "evaluation parameters must state each one given); null: any.")] = None
    designs: Designs = "public"
    opens_at: Moment | None = None
    closes_at: Moment | None = None
    cooldown_s: CooldownSeconds = 0
    max_submissions: SubmissionCap | None = None


class BoardChanges(Model):
    """An update of a named board: only the fields given change; ``null`` clears a time, a
    limit or the required conditions. The track, method, minimum laps, flagged-run rule and
    required conditions change only while the board has no entries."""

    title: Title | None = None
    description: Description | None = None
    method: TimingMethod | None = None
    min_laps: Annotated[int, Field(ge=1, le=100)] | None = None
    flagged_runs: FlaggedRuns | None = None
    conditions: BoardConditions | None = None
    designs: Designs | None = None
    opens_at: Moment | None = None
    closes_at: Moment | None = None
    cooldown_s: CooldownSeconds | None = None
    max_submissions: SubmissionCap | None = None


class ImportedSubmission(Model):
    """A submission as an import replays it: the record, and when it was first submitted."""

    submitted_at: Moment
    record: Record
