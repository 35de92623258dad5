"""How results read for people, wherever they are shown: the CLI's tables and the web pages."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # this module imports no model: `drboard pull` renders standings without them
    from .models.domain import Design
    from .models.seasons import PointsTable, RoundView
    from .models.views import BoardView

DASH = "—"
_ALGORITHMS = {"clipped_ppo": "PPO", "sac": "SAC"}
#: Each timing method's words, keyed by the ``TimingMethod`` members' values (which they equal).
_METHODS = {"BEST_LAP_TIME": "best lap", "AVG_LAP_TIME": "average lap", "TOTAL_TIME": "total time"}


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
    if not design_known(design):
        return UNKNOWN_DESIGN
    if design.action_space is None or design.max_speed is None or design.max_steering is None:
        summary = f"{algorithm_name(design.algorithm)}, action space unknown"
    else:
        space = f"{design.actions} actions" if design.actions else "continuous"
        summary = (f"{algorithm_name(design.algorithm)}, {space}, {design.max_speed:g} m/s, "
                   f"±{design.max_steering:g}°")
    listed = ", ".join(design.sensors or [])
    return f"{summary}; {listed}" if sensors and listed else summary


def design_known(design: Design) -> bool:
    """Whether the run's files state the design at all (its algorithm or its action space)."""
    return design.algorithm is not None or design.action_space is not None


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


# ---- seasons ---------------------------------------------------------------------------------


def points_rule(points: PointsTable, best_of: int | None, rounds: list[RoundView]) -> str:
    """The points table, what counts and the rounds' weights, in one line."""
    if points.scheme == "percentile":
        parts = [f"Points by place in each round's field: {points.percentile_max} to the winner, "
                 "down to 1"]
    else:
        listed = "-".join(str(p) for p in points.positions)
        parts = [f"Points {listed} for places 1 to {len(points.positions)}"]
    if points.participation:
        parts[0] += f", and {points.participation} for taking part"
    if best_of is None:
        parts.append("every round counts")
    elif best_of < len(rounds):
        parts.append(f"the best {best_of} of {len(rounds)} rounds count")
    else:
        parts.append(f"each racer's best {best_of} rounds count")
    for r in rounds:
        said = ([f"counts ×{r.weight:g}"] if r.weight != 1 else []) + (
            ["always counts"] if r.always_counts else [])
        if said:
            parts.append(f"R{r.number} " + " and ".join(said))
    return " · ".join(parts) + "."


def plural(count: int, word: str, words: str | None = None) -> str:
    """``1 racer``, ``2 racers`` (``words``: a plural that is not ``word`` + s)."""
    return f"{count} {word if count == 1 else words or word + 's'}"


def ordinal(rank: int) -> str:
    """``1`` -> ``1st``, ``12`` -> ``12th``, ``22`` -> ``22nd``."""
    suffix = "th" if 10 <= rank % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(rank % 10, "th")
    return f"{rank}{suffix}"


def points_text(points: float) -> str:
    return f"{points:g}"
