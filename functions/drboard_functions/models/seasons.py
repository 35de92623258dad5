"""Seasons: a club's race nights added up. A season is made of boards (its rounds); each round's
finishes earn points by the season's points table, the best N rounds of each racer count, and
the top K may be the only entrants of a later board (the final).

What a season is (``Season``, kept by the stores), what an organiser sends to make or change one
(``SeasonSpec``, ``SeasonChanges``, ``RoundSpec``, ``FinalSpec``), what a round's results are as
the stores keep them between views (``RoundResults``), and what callers get back
(``SeasonView``, ``SeasonStandings``, ``SeasonList``). How the points add up is in
``season_scoring.py``; the use cases in ``service/seasons.py``.
"""

from datetime import datetime
from typing import Annotated, Literal, Self

from pydantic import Field, model_validator

from .domain import BoardId, BoardStatus, Description, Model, Title

#: The league's position points: 1st to 10th.
LEAGUE_POINTS = (25, 18, 15, 12, 10, 8, 6, 4, 2, 1)
#: Rounds in one season (a race night a fortnight for a year, and a final).
MAX_ROUNDS = 30
#: A round counts its first racers up to this many (points go to finishes among them).
MAX_ROUND_RACERS = 2000
#: The longest list of position points an organiser may give.
MAX_POSITIONS = 100
MAX_POINTS = 10_000
MAX_WEIGHT = 10.0
#: The most qualifiers a final may take.
MAX_FINALISTS = 1000
#: ``/seasons/view`` is the page listing the seasons: no season has this id.
RESERVED_ID = "view"

SeasonId = BoardId
Points = Annotated[int, Field(ge=0, le=MAX_POINTS)]
Weight = Annotated[float, Field(gt=0, le=MAX_WEIGHT, multiple_of=0.01,
                                description="The round's points are multiplied by it (a final: 2).")]
BestOf = Annotated[int, Field(ge=1, le=MAX_ROUNDS)]
Finalists = Annotated[int, Field(ge=1, le=MAX_FINALISTS)]


class PointsTable(Model):
    """How a finish on a round becomes points, before the round's weight.

    ``positions``: the points of 1st, 2nd, 3rd, …; places past the list score none (default the
    league's 25-18-15-12-10-8-6-4-2-1). ``percentile``: points by where a racer finished in the
    round's field, for big fields: the winner scores ``percentile_max``, and a racer at rank r
    of F racers ``percentile_max × (F − r + 1) / F``, rounded, at least 1. Either way only a
    racer whose run qualified on the round scores place points; ``participation`` points go to
    every racer with an entry on the round (taking part), qualified or not.
    """

    scheme: Literal["positions", "percentile"] = "positions"
    positions: Annotated[list[Points], Field(min_length=1, max_length=MAX_POSITIONS)] = list(LEAGUE_POINTS)
    percentile_max: Annotated[int, Field(ge=1, le=MAX_POINTS)] = 100
    participation: Points = 0

    @model_validator(mode="after")
    def _positions_never_rise(self) -> Self:
        if any(later > earlier for earlier, later in zip(self.positions, self.positions[1:], strict=False)):
            raise ValueError("position points may not rise from one place to the next")
        return self


class SeasonRound(Model):
    """One round of a season: a board, how much its points weigh, and whether it always counts
    (a final is never dropped by best-of). ``starts_at`` is when its board opens (or was made,
    opening at once): a season numbers its rounds in that order, whatever order they were added
    in."""

    board_id: str
    weight: Weight = 1.0
    always_counts: bool = False
    added_at: datetime
    starts_at: datetime | None = None

    def order(self) -> tuple[datetime, datetime]:
        return (self.starts_at or self.added_at, self.added_at)


class SeasonFinal(Model):
    """The season's final: a later board that only its qualifiers may push to. They are the top
    ``top`` of the season's standings over its other rounds, or of one round (``from_round``)."""

    board_id: str
    top: Finalists
    from_round: str | None = None


class Season(Model):
    """A season as the stores keep it. ``version`` goes up with every change to it."""

    season_id: SeasonId
    title: Title
    description: Description = ""
    points: PointsTable = PointsTable()
    best_of: BestOf | None = None
    rounds: Annotated[list[SeasonRound], Field(max_length=MAX_ROUNDS)] = []
    final: SeasonFinal | None = None
    created_at: datetime
    closed_at: datetime | None = None
    version: int = 0

    def round(self, board_id: str) -> SeasonRound | None:
        return next((r for r in self.rounds if r.board_id == board_id), None)

    def linked_boards(self) -> set[str]:
        """The boards whose pages link to the season: its rounds and its final."""
        return {r.board_id for r in self.rounds} | ({self.final.board_id} if self.final else set())


class SeasonLink(Model):
    """What a board knows of a season it belongs to: its id and title, and whether the board
    is the season's final (whose pushes only the season's qualifiers may make)."""

    season_id: str
    title: str
    final: bool = False


class Finish(Model):
    """A racer's place on a round, as the round's board ranks them."""

    racer_key: str
    racer: str
    rank: int
    qualified: bool
    achieved_at: datetime


class RoundResults(Model):
    """A round's finishes as of one version of its board: what a season view keeps between
    views, so that a round whose board has not changed is not read again. ``field`` is the
    board's number of racers."""

    board_id: str
    board_version: int
    field: int
    finishes: list[Finish]


# ---- what organisers send -----------------------------------------------------------------


class SeasonSpec(Model):
    """A new season: its id, title, points table and how many rounds count (all, by default)."""

    season_id: Annotated[SeasonId, Field(description="Letters, digits, `_`, `-` and `.`; up to 64; "
                                                     "not `view`.")]
    title: Title
    description: Description = ""
    points: PointsTable = PointsTable()
    best_of: BestOf | None = None

    @model_validator(mode="after")
    def _not_the_list_page(self) -> Self:
        if self.season_id == RESERVED_ID:
            raise ValueError(f"{RESERVED_ID!r} is the seasons' page: give the season another id")
        return self


class SeasonChanges(Model):
    """A change of a season: only the fields given change; ``best_of: null`` counts every round."""

    title: Title | None = None
    description: Description | None = None
    points: PointsTable | None = None
    best_of: BestOf | None = None


class RoundSpec(Model):
    """A round's weight, and whether best-of may drop it."""

    weight: Weight = 1.0
    always_counts: bool = False


class FinalSpec(Model):
    """The season's final: the board whose only entrants are the top ``top`` of the season (or
    of the round ``from_round``)."""

    board_id: BoardId
    top: Finalists
    from_round: BoardId | None = None


# ---- what callers get back ----------------------------------------------------------------

SeasonStatus = Literal["OPEN", "CLOSED"]


class RoundView(Model):
    """A round as a season shows it: its board's title and status, or ``missing`` when the
    board was deleted (its results do not count until it is restored)."""

    number: int
    board_id: str
    title: str
    weight: float
    always_counts: bool
    status: BoardStatus | Literal["MISSING"]
    participants: int


class FinalView(Model):
    board_id: str
    title: str
    top: int
    from_round: str | None
    qualifiers: list[str] = Field(description="The racers who may push to the final, best first.")


class SeasonView(Model):
    season_id: str
    title: str
    description: str
    status: SeasonStatus
    points: PointsTable
    best_of: int | None
    rounds: list[RoundView]
    final: FinalView | None
    tie_breaks: str
    created_at: datetime
    closed_at: datetime | None
    version: int


class RoundScore(Model):
    """A racer's result on one round: their rank (None: they did not take part), the points
    it earned with the round's weight, and whether it counts towards their total."""

    board_id: str
    rank: int | None
    qualified: bool
    points: float
    counted: bool


class Standing(Model):
    rank: int
    racer: str
    points: float
    wins: int
    best_finish: int | None
    rounds_raced: int
    qualified_for_final: bool
    rounds: list[RoundScore]


class SeasonStandings(Model):
    season: SeasonView
    standings: list[Standing]
    next_cursor: str | None = None


class SeasonSummary(Model):
    """A season as a list of seasons shows it."""

    season_id: str
    title: str
    status: SeasonStatus
    rounds: int
    final_board_id: str | None
    created_at: datetime
    closed_at: datetime | None


class SeasonList(Model):
    seasons: list[SeasonSummary]
    next_cursor: str | None = None
