"""How results read for people, wherever they are shown: the CLI's tables and the web pages."""

from __future__ import annotations

from datetime import UTC, datetime

from .models.domain import Design, TimingMethod
from .models.views import BoardView

DASH = "—"
_ALGORITHMS = {"clipped_ppo": "PPO", "sac": "SAC"}
_METHODS = {
    TimingMethod.BEST_LAP_TIME: "best lap",
    TimingMethod.AVG_LAP_TIME: "average lap",
    TimingMethod.TOTAL_TIME: "total time",
}


def seconds(ms: int | None) -> str:
    """``12345`` -> ``12.345 s``."""
    return DASH if ms is None else f"{ms / 1000:.3f} s"


def gap(ms: int | None) -> str:
    if ms is None:
        return DASH
    return "leader" if ms == 0 else f"+{ms / 1000:.3f} s"


def percent(value: float) -> str:
    return f"{value:g} %"


def algorithm_name(algorithm: str | None) -> str:
    return UNKNOWN if algorithm is None else _ALGORITHMS.get(algorithm, algorithm)


PRIVATE_DESIGN = "private until the board closes"
#: How a fact the run's files do not state reads.
UNKNOWN = "unknown"
UNKNOWN_DESIGN = "design unknown"


def design_summary(design: Design | None, *, sensors: bool = False) -> str:
    """``PPO, 14 actions, 2 m/s, ±30°`` (and the sensors, when asked); what the run's files do
    not state reads as unknown."""
    if design is None:
        return PRIVATE_DESIGN
    if not design.known:
        return UNKNOWN_DESIGN
    if design.action_space is None or design.max_speed is None or design.max_steering is None:
        summary = f"{algorithm_name(design.algorithm)}, action space unknown"
    else:
        space = f"{design.actions} actions" if design.actions else "continuous"
        summary = (f"{algorithm_name(design.algorithm)}, {space}, {design.max_speed:g} m/s, "
                   f"±{design.max_steering:g}°")
    listed = ", ".join(design.sensors or [])
    return f"{summary}; {listed}" if sensors and listed else summary


def method_label(board: BoardView) -> str:
    laps = "lap" if board.min_laps == 1 else "laps"
    return f"{_METHODS[board.method]}, {board.min_laps} {laps} to qualify"


def duration(total_s: int) -> str:
    """``5400`` -> ``1 h 30 min``; ``90`` -> ``1 min 30 s``; ``0`` -> ``0 s``."""
    minutes, secs = divmod(total_s, 60)
    hours, minutes = divmod(minutes, 60)
    days, hours = divmod(hours, 24)
    parts = [f"{days} d" if days else "", f"{hours} h" if hours else "",
             f"{minutes} min" if minutes else "", f"{secs} s" if secs else ""]
    return " ".join(part for part in parts if part) or "0 s"


def when(moment: datetime | None) -> str:
    """A moment in UTC, to the minute (to the second when it has seconds): ``2026-12-01 18:00 UTC``."""
    if moment is None:
        return DASH
    moment = moment.astimezone(UTC)
    pattern = "%Y-%m-%d %H:%M UTC" if moment.second == 0 else "%Y-%m-%d %H:%M:%S UTC"
    return moment.strftime(pattern)
