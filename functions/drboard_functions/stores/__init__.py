"""Storage adapters behind the service's BoardStore port."""

from .base import BoardStore, StoredBoard

__all__ = ["BoardStore", "StoredBoard"]
