"""The cloud board's store: one DynamoDB table (its one definition is ``BoardTable`` in
template.yaml). ``store`` is the store, ``codecs`` how things are kept as items,
``transaction`` a push, ``ranks`` the rank counters, ``bulk`` an import's batches, ``pages``
the board's pages kept as bytes.

Importing the package loads none of its modules (the pull function reads a kept page through
``pages`` before it loads any model); the names below load their module on first use.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .codecs import RANK_INDEX, board_item, entry_item
    from .retries import MAX_ATTEMPTS
    from .store import DynamoDbStore

__all__ = ["MAX_ATTEMPTS", "RANK_INDEX", "DynamoDbStore", "board_item", "entry_item"]

#: Where each name lives.
_HOMES = {"MAX_ATTEMPTS": "retries", "RANK_INDEX": "codecs", "DynamoDbStore": "store",
          "board_item": "codecs", "entry_item": "codecs"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{home}"), name)
