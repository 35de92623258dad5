"""The bounds of reads (the routes check them too), and the reads that come a page at a time:
their cursors."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TypeVar

from ..cursors import Paged
from ..errors import InvalidQuery
from ..models.domain import MAX_PAGE
from ..stores.base import BadPageToken

DEFAULT_PAGE = 100
#: Racers whose designs are compared at once.
MAX_COMPARED = 4
#: The fastest models insights look at: by default, and at most.
DEFAULT_TOP, MAX_TOP = 5, 20

P = TypeVar("P", bound=Paged)


def follow(read: Callable[[int, str | None], P]) -> Iterator[P]:
    """Every page of a paginated read, at the largest page size."""
    cursor: str | None = None
    while True:
        page = read(MAX_PAGE, cursor)
        yield page
        cursor = page.next_cursor
        if cursor is None:
            return


@contextmanager
def bad_cursor() -> Iterator[None]:
    try:
        yield
    except BadPageToken:
        raise InvalidQuery("the cursor is not one this board gave out") from None


def check_limit(limit: int) -> None:
    if not 1 <= limit <= MAX_PAGE:
        raise InvalidQuery(f"limit must be between 1 and {MAX_PAGE}")
