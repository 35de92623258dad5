"""Storage adapters behind the service's BoardStore port.

Importing the package loads none of its modules (`drboard pull` reads the standings kept beside
the embedded board without the store's models); the names below load their module on first use.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .base import BoardStore, RecordArchive, StoredBoard

__all__ = ["BoardStore", "RecordArchive", "StoredBoard"]


def __getattr__(name: str) -> Any:
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.base"), name)
