"""Join codes: how racers on the network sign in to a `drboard serve` board.

The organiser's `drboard serve` shows one code for the room (in its terminal and on the big
screen). A racer runs ``drboard join CODE --endpoint URL``: the board answers a token of their
own, which the CLI saves (:mod:`drboard_cli.tokens`) and sends as a bearer token from then on.
Each token is a sign-in of its own (``join:<id>``), which claims an alias with its first push
like any other sign-in, so no racer on the network can push as another.

The rules, for a code on a projector that anyone in the room can read:

- **One code for the night.** It is kept in the desk's file, so it survives a restart of
  `serve`, and changes only when the organiser rotates it (``drboard joins rotate``). A code
  is letters and digits; it is compared as bytes, in constant time.
- **A capped number of joins per code** (``--max-joins``, 100 by default): past it the code
  joins no one, and the organiser rotates it. A room code rather than one code per racer: a
  night's racers join from the screen without the organiser handing out anything.
- **Joins rate-limited per client address**: at most :data:`ATTEMPTS_PER_WINDOW` attempts,
  right or wrong, per :data:`ATTEMPT_WINDOW_S` seconds (then 429 with ``Retry-After``).
- **Tokens that expire** (``--token-hours``, 24 by default). Joining again with the code while
  holding an expired token renews it for the same sign-in, so a racer keeps their alias.
- **Tokens the organiser revokes** (``drboard joins revoke ALIAS|join:ID|--all``): a revoked
  sign-in is never renewed.

Only the sha256 of a token is kept (in a small SQLite file beside the board), so racers stay
joined across restarts and a copy of the file signs no one in. The desk also notes the alias
each sign-in pushes as (from `serve`'s answers), so the organiser revokes a racer by name.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import sqlite3
import threading
import time
from collections import deque
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path

from drboard_functions.identity import Caller
from pydantic import BaseModel, ConfigDict, Field

#: No 0/O or 1/I: a code read aloud or off a projector is typed right.
CODE_ALPHABET = "ABCDEFGHJKLMNPQRSTUVWXYZ23456789"
CODE_LENGTH = 8
DEFAULT_MAX_JOINS = 100
DEFAULT_TOKEN_HOURS = 24
ATTEMPTS_PER_WINDOW = 30
ATTEMPT_WINDOW_S = 600.0
#: What a code may hold as typed: letters, digits, dashes and spaces (anything else is refused
#: before it is compared).
CODE_PATTERN = r"^[A-Za-z0-9 -]{1,32}$"

SCHEMA = """
CREATE TABLE IF NOT EXISTS joined (
    token_sha256 TEXT PRIMARY KEY,
    principal    TEXT NOT NULL,
    joined_at    TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS join_code (
    id         INTEGER PRIMARY KEY CHECK (id = 1),
    code       TEXT NOT NULL,
    created_at TEXT NOT NULL,
    joins      INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS sign_ins (
    principal  TEXT PRIMARY KEY,
    joined_at  TEXT NOT NULL,
    client     TEXT NOT NULL DEFAULT '',
    alias      TEXT,
    revoked_at TEXT
);
"""
#: Columns an older desk file lacks, added when it is opened.
_ADDED_COLUMNS = {"joined": {"expires_at": "TEXT"}}


class JoinRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    code: str = Field(min_length=1, max_length=32, pattern=CODE_PATTERN)


class Joined(BaseModel):
    """What a racer who joined gets: their token (shown once), their sign-in and until when."""

    token: str
    principal: str
    expires_at: datetime | None = None
    renewed: bool = False


class JoinCode(BaseModel):
    code: str
    created_at: datetime
    joins: int
    max_joins: int

    @property
    def joins_left(self) -> int:
        return max(0, self.max_joins - self.joins)


class JoinedRacer(BaseModel):
    """One sign-in made with a code, for the organiser's list."""

    principal: str
    joined_at: datetime
    client: str
    alias: str | None
    expires_at: datetime | None
    revoked: bool


class WrongCode(Exception):
    """The code is not the board's current one, or it joined as many racers as it may."""


class TooManyJoins(Exception):
    """This client tried to join too often; ``retry_after_s`` says when it may again."""

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


def _digest(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def normalised(code: str) -> bytes:
    """A code as typed, as the bytes it is compared by: no dashes or spaces, upper case."""
    return code.replace("-", "").replace(" ", "").upper().encode("utf-8")


def _new_code() -> str:
    raw = "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))
    return f"{raw[:4]}-{raw[4:]}"


class JoinDesk:
    """The codes and sign-ins of one `drboard serve` board, in a SQLite file of their own.

    Several processes may open the same file: `serve` and the organiser's ``drboard joins``
    commands (a rotated code or a revoked sign-in takes effect at the next request)."""

    def __init__(self, path: Path | str, *, max_joins: int = DEFAULT_MAX_JOINS,
                 token_hours: float = DEFAULT_TOKEN_HOURS,
                 clock: Callable[[], datetime] = lambda: datetime.now(UTC),
                 monotonic: Callable[[], float] = time.monotonic) -> None:
        self.max_joins = max_joins
        self.token_lifetime = timedelta(hours=token_hours)
        self.clock = clock
        self.monotonic = monotonic
        self._lock = threading.Lock()
        self._attempts: dict[str, deque[float]] = {}
        if str(path) != ":memory:":
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None,
                                   timeout=10)
        self._db.executescript(SCHEMA)
        for table, columns in _ADDED_COLUMNS.items():
            have = {row[1] for row in self._db.execute(f"PRAGMA table_info({table})")}
            for name, kind in columns.items():
                if name not in have:
                    self._db.execute(f"ALTER TABLE {table} ADD COLUMN {name} {kind}")

    def close(self) -> None:
        self._db.close()

    # ---- the code -------------------------------------------------------------------------

    def current_code(self) -> JoinCode:
        """The code racers join with: the one kept in the file, or a new one the first time."""
        with self._lock:
            row = self._db.execute("SELECT code, created_at, joins FROM join_code").fetchone()
            if row is None:
                row = self._store_code()
        return JoinCode(code=row[0], created_at=datetime.fromisoformat(row[1]), joins=row[2],
                        max_joins=self.max_joins)

    def rotate(self) -> JoinCode:
        """A new code: the old one joins no one from now on (who joined with it stays joined)."""
        with self._lock:
            self._store_code()
        return self.current_code()

    def _store_code(self) -> tuple[str, str, int]:
        row = (_new_code(), self.clock().isoformat(), 0)
        self._db.execute("INSERT OR REPLACE INTO join_code (id, code, created_at, joins) "
                         "VALUES (1, ?, ?, ?)", row)
        return row

    # ---- joining --------------------------------------------------------------------------

    def join(self, code: str, client: str = "", renewing: str | None = None) -> Joined:
        """A new sign-in for the holder of the code, or, with ``renewing`` (the racer's old
        token, expired or not), a new token for that same sign-in unless it was revoked."""
        self._count_attempt(client)
        current = self.current_code()
        if not hmac.compare_digest(normalised(code), normalised(current.code)):
            raise WrongCode("that join code is wrong: ask the organiser for the one on the big "
                            "screen (or in `drboard serve`'s window)")
        now = self.clock()
        token = secrets.token_urlsafe(32)
        expires = now + self.token_lifetime
        with self._lock:  # one connection, shared by the server's threads
            principal = self._renewable(renewing) if renewing else None
            renewed = principal is not None
            if principal is None:
                used = self._db.execute("UPDATE join_code SET joins = joins + 1 WHERE id = 1 "
                                        "AND code = ? AND joins < ?",
                                        (current.code, self.max_joins)).rowcount
                if not used:
                    raise WrongCode(f"this join code has joined {self.max_joins} racers, as many "
                                    "as it may: ask the organiser to rotate it "
                                    "(`drboard joins rotate`)")
                principal = f"join:{secrets.token_hex(8)}"
                self._db.execute("INSERT INTO sign_ins (principal, joined_at, client) "
                                 "VALUES (?, ?, ?)", (principal, now.isoformat(), client))
            self._db.execute("INSERT INTO joined (token_sha256, principal, joined_at, expires_at) "
                             "VALUES (?, ?, ?, ?)",
                             (_digest(token), principal, now.isoformat(), expires.isoformat()))
        return Joined(token=token, principal=principal, expires_at=expires, renewed=renewed)

    def _renewable(self, token: str) -> str | None:
        row = self._db.execute(
            "SELECT j.principal FROM joined j LEFT JOIN sign_ins s ON s.principal = j.principal "
            "WHERE j.token_sha256 = ? AND s.revoked_at IS NULL", (_digest(token),)).fetchone()
        return str(row[0]) if row else None

    def _count_attempt(self, client: str) -> None:
        now = self.monotonic()
        with self._lock:
            attempts = self._attempts.setdefault(client, deque())
            while attempts and now - attempts[0] >= ATTEMPT_WINDOW_S:
                attempts.popleft()
            if len(attempts) >= ATTEMPTS_PER_WINDOW:
                wait = int(ATTEMPT_WINDOW_S - (now - attempts[0])) + 1
                raise TooManyJoins(f"too many join attempts from {client or 'this computer'}: "
                                   f"try again in {wait} s", wait)
            attempts.append(now)

    # ---- who is calling -------------------------------------------------------------------

    def caller(self, token: str) -> Caller | None:
        """The racer a bearer token belongs to, or None (unknown, expired or revoked)."""
        with self._lock:
            row = self._db.execute(
                "SELECT j.principal, j.expires_at, s.alias, s.revoked_at FROM joined j "
                "LEFT JOIN sign_ins s ON s.principal = j.principal WHERE j.token_sha256 = ?",
                (_digest(token),)).fetchone()
        if row is None or row[3] is not None:
            return None
        if row[1] is not None and datetime.fromisoformat(row[1]) <= self.clock():
            return None
        return Caller(principal=row[0], name=row[2] or "")

    def note_alias(self, principal: str, alias: str) -> None:
        """The alias this sign-in pushes as (what `serve` saw the board answer)."""
        with self._lock:
            self._db.execute("INSERT INTO sign_ins (principal, joined_at, alias) VALUES (?, ?, ?) "
                             "ON CONFLICT (principal) DO UPDATE SET alias = excluded.alias",
                             (principal, self.clock().isoformat(), alias))

    # ---- the organiser's view -------------------------------------------------------------

    def joined(self) -> list[JoinedRacer]:
        """Every sign-in made with a code, oldest first, with its latest token's expiry."""
        with self._lock:
            rows = self._db.execute(
                "SELECT s.principal, s.joined_at, s.client, s.alias, s.revoked_at, "
                "(SELECT MAX(expires_at) FROM joined j WHERE j.principal = s.principal) "
                "FROM sign_ins s ORDER BY s.joined_at, s.principal").fetchall()
        return [JoinedRacer(principal=principal, joined_at=datetime.fromisoformat(joined_at),
                            client=client, alias=alias, revoked=revoked is not None,
                            expires_at=datetime.fromisoformat(expires) if expires else None)
                for principal, joined_at, client, alias, revoked, expires in rows]

    def revoke(self, who: str | None) -> list[JoinedRacer]:
        """Revoke the sign-in ``who`` names (its ``join:`` id, or the alias it pushes as, in
        any case), or every one when ``who`` is None; the ones revoked now."""
        targets = [racer for racer in self.joined() if not racer.revoked and (
            who is None or racer.principal == who
            or (racer.alias is not None and racer.alias.casefold() == who.casefold()))]
        with self._lock:
            for racer in targets:
                self._db.execute("UPDATE sign_ins SET revoked_at = ? WHERE principal = ?",
                                 (self.clock().isoformat(), racer.principal))
        return targets
