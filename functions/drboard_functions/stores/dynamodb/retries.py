"""How the store waits before trying a write again that lost a race with another."""

from __future__ import annotations

import random
import time

MAX_ATTEMPTS = 10  # of a write that loses a race with another write of the same racer or board
BACKOFF_S = 0.01
MAX_BACKOFF_S = 0.5


def backoff(attempt: int) -> None:
    time.sleep(random.uniform(0, min(MAX_BACKOFF_S, BACKOFF_S * 2 ** attempt)))
