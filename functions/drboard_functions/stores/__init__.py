"""Storage adapters behind the service's BoardStore port."""

from .base import BoardStore, RecordArchive, StoredBoard

__all__ = ["BoardStore", "RecordArchive", "StoredBoard"]
