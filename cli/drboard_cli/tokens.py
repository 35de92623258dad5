"""Sign-in tokens, one per board endpoint, in the user's config folder (file mode 0600).

`drboard login` (a deployed board's Cognito sign-in) and `drboard join` (a `drboard serve`
board's join code) save a token here; every call to that endpoint then sends it as
``Authorization: Bearer``. ``DRBOARD_TOKEN`` overrides the saved token (for CI jobs).
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime
from pathlib import Path
from typing import Literal

import platformdirs
from pydantic import BaseModel, ValidationError

from .config import APP

ENV_TOKEN = "DRBOARD_TOKEN"


class SavedToken(BaseModel):
    """What a sign-in left: the access token, and how to renew it when it is a Cognito one."""

    kind: Literal["cognito", "join"]
    access_token: str
    expires_at: datetime | None = None
    refresh_token: str | None = None
    # Cognito: where to renew (the user pool's app client and its region / domain).
    client_id: str | None = None
    region: str | None = None
    domain: str | None = None
    username: str | None = None

    def expired(self, now: datetime | None = None, margin_s: float = 60.0) -> bool:
        if self.expires_at is None:
            return False
        now = now or datetime.now(UTC)
        return (self.expires_at - now).total_seconds() <= margin_s


def tokens_path() -> Path:
    return platformdirs.user_config_path(APP) / "tokens.json"


def _key(endpoint: str) -> str:
    return endpoint.rstrip("/")


def _load_all() -> dict[str, dict[str, object]]:
    try:
        value = json.loads(tokens_path().read_text("utf-8"))
    except (OSError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


def _save_all(tokens: dict[str, dict[str, object]]) -> None:
    path = tokens_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "w", encoding="utf-8") as file:
        file.write(json.dumps(tokens, indent=2) + "\n")
    os.chmod(temporary, 0o600)  # an older file's mode is not kept by O_CREAT
    temporary.replace(path)


def load(endpoint: str) -> SavedToken | None:
    """The token saved for this endpoint, or None."""
    raw = _load_all().get(_key(endpoint))
    if raw is None:
        return None
    try:
        return SavedToken.model_validate(raw)
    except ValidationError:
        return None


def save(endpoint: str, token: SavedToken) -> None:
    tokens = _load_all()
    tokens[_key(endpoint)] = token.model_dump(mode="json")
    _save_all(tokens)


def forget(endpoint: str) -> bool:
    """Remove the endpoint's token; whether there was one."""
    tokens = _load_all()
    if tokens.pop(_key(endpoint), None) is None:
        return False
    _save_all(tokens)
    return True


def from_environment() -> str | None:
    """``DRBOARD_TOKEN``, when it is set."""
    given = os.environ.get(ENV_TOKEN, "").strip()
    return given or None


def route_prefix(token: str) -> str:
    """Where a token's requests go: a Cognito access token (a JWT) to the deployed board's
    ``/cognito`` routes, a join token to the board's own."""
    return "/cognito" if token.count(".") == 2 else ""
