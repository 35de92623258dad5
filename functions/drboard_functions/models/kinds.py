"""The kinds a board's settings and state take that need no model: how a board times its racers
and whether it is open. Plain enums (no pydantic), so that a result card can be drawn from a
kept page's JSON without loading the models (see ``cards.content``)."""

from __future__ import annotations

from enum import StrEnum


class TimingMethod(StrEnum):
    BEST_LAP_TIME = "BEST_LAP_TIME"
    AVG_LAP_TIME = "AVG_LAP_TIME"
    TOTAL_TIME = "TOTAL_TIME"


class BoardStatus(StrEnum):
    UPCOMING = "UPCOMING"
    OPEN = "OPEN"
    CLOSED = "CLOSED"
