"""drboard's leaderboard: the service (ranking and board rules), its stores, and the handlers.

Importing the package loads none of its modules (each Lambda function imports only what its
routes use); the names below load their module on first use.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .errors import DomainError
    from .service import LeaderboardService, board_for_track

__all__ = ["DomainError", "LeaderboardService", "board_for_track"]

#: Where each exported name lives.
_HOMES = {"DomainError": "errors", "LeaderboardService": "service", "board_for_track": "service"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{home}"), name)
