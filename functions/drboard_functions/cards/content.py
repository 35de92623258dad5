"""What a card says, in words, from the board's views."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..display import gap, percent, seconds
from ..models.domain import BoardStatus, TimingMethod
from ..models.views import EntryView, RacerView

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


@dataclass(frozen=True)
class PodiumPlace:
    rank: int
    name: str
    figure: str  # "125 pts"
    detail: str  # "3 wins · best finish 1st"
    gap: str  # "−18 pts", or "" for the leader


@dataclass(frozen=True)
class Podium:
    """The first three of a season (or of any standings): title, a line under it, the places."""

    title: str
    subtitle: str
    places: Sequence[PodiumPlace]
    date: str


def racer_card(view: RacerView, runner_up: EntryView | None = None) -> RacerCard:
    """The card of ``view``'s entry; ``runner_up`` is the board's second, for the leader's lead."""
    entry, board = view.entry, view.board
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
