"""drboard's leaderboard: the service (ranking and board rules), its stores, and the handlers."""

from .errors import DomainError
from .service import LeaderboardService, board_for_track

__all__ = ["DomainError", "LeaderboardService", "board_for_track"]
