"""What a card says, in words, from the board's views — or from a kept page's JSON of them,
read without the models (:func:`racer_card_on_page`: how the card function draws a racer's card
from the standings the push kept)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import TYPE_CHECKING, Any, Protocol

from drboard_assembler.aliases import alias_key

from ..display import gap, ordinal, percent, points_text, seconds
from ..models.kinds import BoardStatus, TimingMethod

if TYPE_CHECKING:
    from ..models.seasons import SeasonStandings, Standing

_RESULT = {TimingMethod.BEST_LAP_TIME: "best lap", TimingMethod.AVG_LAP_TIME: "average lap",
           TimingMethod.TOTAL_TIME: "total time"}


@dataclass(frozen=True)
class RacerCard:
    """A racer's result on a board."""

    board_title: str
    subtitle: str  # the track, how the board times, whether it is final
    rank: int
    field: int  # racers on the board
    racer: str
    model_name: str
    result: str  # "9.120 s", or "73 % done" for a run that did not qualify
    result_label: str  # "best lap", "average lap", "total time", "best completion"
    gap: str  # "+0.465 s to the leader", "leads by 0.200 s", or ""
    leads: bool
    date: str  # when the result was set, "2026-12-01"


#: A podium's places: the first three ranks (more racers when some share a rank).
PODIUM = 3


@dataclass(frozen=True)
class PodiumPlace:
    rank: int
    name: str
    figure: str  # "125 pts"
    detail: str  # "3 wins · 4 rounds raced"
    gap: str  # "−18 pts", or "" for the leader


@dataclass(frozen=True)
class Podium:
    """The first three of a season (or of any standings): title, a line under it, the places."""

    title: str
    subtitle: str
    places: Sequence[PodiumPlace]
    date: str


class CardBoard(Protocol):
    """What a racer's card reads of the board (a ``BoardView``, or its JSON on a kept page)."""

    @property
    def title(self) -> str: ...
    @property
    def track_name(self) -> str: ...
    @property
    def method(self) -> TimingMethod: ...
    @property
    def status(self) -> BoardStatus: ...
    @property
    def participants(self) -> int: ...


class CardEntry(Protocol):
    """What a racer's card reads of an entry (an ``EntryView``, or its JSON on a kept page)."""

    @property
    def rank(self) -> int: ...
    @property
    def racer(self) -> str: ...
    @property
    def model_name(self) -> str: ...
    @property
    def qualified(self) -> bool: ...
    @property
    def time_ms(self) -> int | None: ...
    @property
    def gap_ms(self) -> int | None: ...
    @property
    def best_completion_pct(self) -> float: ...
    @property
    def submitted_at(self) -> datetime: ...


@dataclass(frozen=True)
class PageBoard:
    title: str
    track_name: str
    method: TimingMethod
    status: BoardStatus
    participants: int


@dataclass(frozen=True)
class PageEntry:
    rank: int
    racer: str
    model_name: str
    qualified: bool
    time_ms: int | None
    gap_ms: int | None
    best_completion_pct: float
    submitted_at: datetime


def racer_card_on_page(page: Mapping[str, Any], racer: str) -> RacerCard | None:
    """The racer's card from a board page's JSON (``BoardPage``: the board and its entries in
    rank order), the same card :func:`racer_card` makes of the views; None when the racer is not
    on the page."""
    entries = page["entries"]
    key = alias_key(racer)
    found = next((n for n, entry in enumerate(entries) if alias_key(entry["racer"]) == key), None)
    if found is None:
        return None
    board = page["board"]
    runner_up = _page_entry(entries[1]) if len(entries) > 1 else None
    return racer_card(PageBoard(board["title"], board["track_name"], TimingMethod(board["method"]),
                                BoardStatus(board["status"]), board["participants"]),
                      _page_entry(entries[found]), runner_up)


def _page_entry(entry: Mapping[str, Any]) -> PageEntry:
    return PageEntry(entry["rank"], entry["racer"], entry["model_name"], entry["qualified"],
                     entry["time_ms"], entry["gap_ms"], entry["best_completion_pct"],
                     datetime.fromisoformat(entry["submitted_at"]))


def racer_card(board: CardBoard, entry: CardEntry, runner_up: CardEntry | None = None) -> RacerCard:
    """The card of the racer's ``entry`` on ``board``; ``runner_up`` is the board's second, for
    the leader's lead."""
    if entry.qualified:
        result, label = seconds(entry.time_ms), _RESULT[board.method]
        if entry.rank == 1:
            lead = (runner_up.gap_ms if runner_up is not None and runner_up.qualified
                    and runner_up.gap_ms else None)
            said = f"leads by {seconds(lead)}" if lead else "leads the board"
        else:
            said = f"{gap(entry.gap_ms)} to the leader"
    else:
        result, label, said = f"{percent(entry.best_completion_pct)} done", "best completion", ""
    status = {BoardStatus.CLOSED: "final standings", BoardStatus.UPCOMING: "not open yet"}.get(
        board.status, "live standings")
    track = "" if board.track_name == board.title else f"{board.track_name} · "
    return RacerCard(
        board_title=board.title, subtitle=f"{track}{_RESULT[board.method]} · {status}",
        rank=entry.rank, field=board.participants, racer=entry.racer, model_name=entry.model_name,
        result=result, result_label=label, gap=said, leads=entry.qualified and entry.rank == 1,
        date=entry.submitted_at.strftime("%Y-%m-%d"))


def season_podium(view: SeasonStandings, now: datetime) -> Podium:
    """The season's first three (the first page of its standings, in rank order), with their
    points, wins, rounds raced and the points they are behind the leader. ``now`` dates a
    running season's podium; a closed one is dated by its close."""
    season = view.season
    places = [s for s in view.standings if s.rank <= PODIUM]
    leader = places[0].points if places else 0.0
    raced = sum(r.participants > 0 for r in season.rounds)
    rounds = f"{len(season.rounds)} round{'s' if len(season.rounds) != 1 else ''}"
    subtitle = (f"Final podium · {rounds}" if season.status == "CLOSED"
                else f"Season podium · {raced} of {rounds} with results")
    return Podium(title=season.title, subtitle=subtitle,
                  places=[PodiumPlace(rank=s.rank, name=s.racer, figure=points(s.points),
                                      detail=standing_detail(s),
                                      gap=f"−{points(leader - s.points)}" if s.points < leader else "")
                          for s in places],
                  date=(season.closed_at or now).strftime("%Y-%m-%d"))


def points(value: float, word: str = "pt") -> str:
    """``43 pts`` (or ``43 points``); ``1 pt``."""
    return f"{points_text(value)} {word}" + ("" if value == 1 else "s")


def standing_detail(standing: Standing) -> str:
    """``3 wins · 5 rounds raced``, or ``best finish 2nd · 5 rounds raced`` without a win."""
    wins = (f"{standing.wins} win" + ("s" if standing.wins != 1 else "") if standing.wins
            else f"best finish {ordinal(standing.best_finish)}" if standing.best_finish else "")
    raced = f"{standing.rounds_raced} round" + ("s" if standing.rounds_raced != 1 else "") + " raced"
    return " · ".join(part for part in (wins, raced) if part)
