"""Importing an export file into a board file, as `drboard import` does on the embedded board."""

from __future__ import annotations

from pathlib import Path

from drboard_cli import transfer
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore


def imported(export: Path, target: Path) -> transfer.ImportSummary:
    """The export imported in bulk into the board file ``target`` (created if need be)."""
    store = SqliteStore(target)
    try:
        with export.open("rb") as handle:
            return transfer.load_export(LeaderboardService(store), str(export), handle, None)
    finally:
        store.close()
