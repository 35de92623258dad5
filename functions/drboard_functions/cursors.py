"""The cursors the service gives out with a page and takes back for the next: opaque to clients
(URL-safe base64 of a JSON list), checked when they come back."""

from __future__ import annotations

import base64
import binascii
import json
from collections.abc import Callable
from typing import Any, Protocol

from .errors import InvalidQuery

#: The most entries, boards or seasons one page holds.
MAX_PAGE = 500

MAX_CURSOR_CHARS = 1024
NOT_OURS = "the cursor is not one this board gave out"
EXPORT_PARTS = ("entries", "submissions")


class Paged(Protocol):
    """A page of a read: the cursor of the next one (None on the last)."""

    @property
    def next_cursor(self) -> str | None: ...


def _encode(fields: list[Any]) -> str:
    return base64.urlsafe_b64encode(json.dumps(fields).encode()).decode().rstrip("=")


def _decode(text: str, valid: Callable[[list[Any]], bool]) -> list[Any]:
    """The cursor's fields, if it is one this board gave out (``valid`` says which are)."""
    if len(text) > MAX_CURSOR_CHARS:
        raise InvalidQuery(NOT_OURS)
    try:
        fields = json.loads(base64.urlsafe_b64decode(text + "=" * (-len(text) % 4)))
        if not isinstance(fields, list) or not valid(fields):
            raise ValueError
    except (ValueError, TypeError, RecursionError, binascii.Error, UnicodeDecodeError):
        raise InvalidQuery(NOT_OURS) from None
    return fields


class RankCursor:
    """Where a page of standings ended: enough to continue the order and the shared ranks."""

    def __init__(self, rank_key: str, score_key: str, rank: int, position: int) -> None:
        self.rank_key = rank_key
        self.score_key = score_key
        self.rank = rank
        self.position = position

    def encode(self) -> str:
        return _encode([self.rank_key, self.score_key, self.rank, self.position])

    @classmethod
    def decode(cls, text: str) -> RankCursor:
        rank_key, score_key, rank, position = _decode(text, lambda fields: len(fields) == 4 and (
            isinstance(fields[0], str) and isinstance(fields[1], str)
            and isinstance(fields[2], int) and isinstance(fields[3], int)))
        return cls(rank_key, score_key, rank, position)


def page_cursor(kind: str, after: str | None) -> str | None:
    """A store's page token as an opaque cursor that names what it pages through."""
    return None if after is None else _encode([kind, after])


def decode_page_cursor(kind: str, text: str | None) -> str | None:
    """The store's page token in a cursor :func:`page_cursor` gave out for ``kind``."""
    if not text:
        return None
    _, after = _decode(text, lambda fields: len(fields) == 2 and fields[0] == kind
                       and isinstance(fields[1], str))
    return str(after)


def export_cursor(part: str, after: str | None) -> str:
    """Where an export stopped: in which part (``entries``, then ``submissions``), after what."""
    return _encode([part, after])


def decode_export_cursor(text: str) -> tuple[str, str | None]:
    part, after = _decode(text, lambda fields: len(fields) == 2 and fields[0] in EXPORT_PARTS
                          and (fields[1] is None or isinstance(fields[1], str)))
    return str(part), after
