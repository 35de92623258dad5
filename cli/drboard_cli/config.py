"""Where drboard keeps its files: the embedded board in the user's data folder, settings in the
user's config folder (both follow the platform's conventions, e.g. XDG on Linux)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import platformdirs

APP = "drboard"


def default_db_path() -> Path:
    return platformdirs.user_data_path(APP) / "board.db"


def watch_memory_path() -> Path:
    """Which evaluations `drboard push --watch` has pushed, so a restart pushes none again."""
    return platformdirs.user_data_path(APP) / "watched.json"


def settings_path() -> Path:
    return platformdirs.user_config_path(APP) / "settings.json"


def load_settings() -> dict[str, Any]:
    try:
        value = json.loads(settings_path().read_text("utf-8"))
    except (OSError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


def default_racer() -> str | None:
    """The racer commands mean when none is given: the one `drboard configure --racer` saved,
    else the last racer who pushed from this machine (a push never replaces a saved one)."""
    settings = load_settings()
    racer = settings.get("racer") or settings.get("last_racer")
    return str(racer) if racer else None


def save_settings(**changes: Any) -> None:
    path = settings_path()
    settings = load_settings() | changes
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    temporary.write_text(json.dumps(settings, indent=2) + "\n", "utf-8")
    temporary.replace(path)
