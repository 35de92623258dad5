"""Join codes: how racers on the network sign in to a `drboard serve` board.

The organiser's `drboard serve` prints a short code, good for a while (an hour by default; a new
one is printed when it runs out). A racer runs `drboard join CODE --endpoint URL`: the board
answers a token of their own, which the CLI saves (:mod:`drboard_cli.tokens`) and sends as a
bearer token from then on. Each token is a sign-in of its own (``join:<id>``), which claims an
alias with its first push like any other sign-in, so no racer on the network can push as another.

Only the sha256 of a token is kept (in a small SQLite file beside the board), so racers stay
joined across restarts and a copy of the file signs no one in.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import sqlite3
import threading
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path

from drboard_functions.identity import Caller
from pydantic import BaseModel, ConfigDict, Field

#: No 0/O or 1/I: a code read aloud or off a projector is typed right.
CODE_ALPHABET = "ABCDEFGHJKLMNPQRSTUVWXYZ23456789"
CODE_LENGTH = 8
DEFAULT_CODE_MINUTES = 60

SCHEMA = """
CREATE TABLE IF NOT EXISTS joined (
    token_sha256 TEXT PRIMARY KEY,
    principal    TEXT NOT NULL,
    joined_at    TEXT NOT NULL
)
"""


class JoinRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    code: str = Field(min_length=1, max_length=32)


class Joined(BaseModel):
    """What a racer who joined gets: their token (shown once) and their sign-in."""

    token: str
    principal: str


class JoinCode(BaseModel):
    code: str
    expires_at: datetime


class WrongCode(Exception):
    """The code is not the board's current one, or it ran out."""


def _digest(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def _normalised(code: str) -> str:
    return code.replace("-", "").replace(" ", "").upper()


class JoinDesk:
    def __init__(self, path: Path | str, code_minutes: int = DEFAULT_CODE_MINUTES,
                 clock: Callable[[], datetime] = lambda: datetime.now(UTC)) -> None:
        self.lifetime = timedelta(minutes=code_minutes)
        self.clock = clock
        self._lock = threading.Lock()
        self._code: JoinCode | None = None
        if str(path) != ":memory:":
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None)
        self._db.execute(SCHEMA)

    def close(self) -> None:
        self._db.close()

    def current_code(self) -> JoinCode:
        """The code racers join with now; a new one once the last has run out."""
        with self._lock:
            now = self.clock()
            if self._code is None or now >= self._code.expires_at:
                raw = "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))
                self._code = JoinCode(code=f"{raw[:4]}-{raw[4:]}", expires_at=now + self.lifetime)
            return self._code

    def join(self, code: str) -> Joined:
        current = self.current_code()
        if not hmac.compare_digest(_normalised(code), _normalised(current.code)):
            raise WrongCode("that join code is wrong or has run out: ask the organiser for the "
                            "one `drboard serve` shows now")
        token = secrets.token_urlsafe(32)
        principal = f"join:{secrets.token_hex(8)}"
        with self._lock:  # one connection, shared by the server's threads
            self._db.execute("INSERT INTO joined VALUES (?, ?, ?)",
                             (_digest(token), principal, self.clock().isoformat()))
        return Joined(token=token, principal=principal)

    def caller(self, token: str) -> Caller | None:
        """The racer a bearer token belongs to, or None."""
        with self._lock:
            row = self._db.execute("SELECT principal FROM joined WHERE token_sha256 = ?",
                                   (_digest(token),)).fetchone()
        return Caller(principal=row[0], name=row[0]) if row else None
