"""The cloud board's store: one DynamoDB table (its one definition is ``BoardTable`` in
template.yaml). ``store`` is the store, ``codecs`` how things are kept as items,
``transaction`` a push, ``ranks`` the rank counters."""

from .codecs import RANK_INDEX, board_item, entry_item
from .retries import MAX_ATTEMPTS
from .store import DynamoDbStore

__all__ = ["MAX_ATTEMPTS", "RANK_INDEX", "DynamoDbStore", "board_item", "entry_item"]
