"""A board's pages kept beside the board, as the bytes that answer them: what a store that keeps
them offers (:class:`PageShelf`), and one kept page (:class:`StoredPage`).

A page is kept labelled with the board version it was rendered from; a reader answers it only
while the board's version is still that one (every push that changes the standings and every
organiser's change move it, in the same write). The DynamoDB store keeps them
(:mod:`.dynamodb.pages`), so every warm or cold container of the pull function answers a board's
standings from one read once any container, or the push that changed the board, rendered them.
No model here: the pull function reads a kept page before it loads any.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol


class StoredPage(NamedTuple):
    """One kept page: the board version it shows, until when it holds whatever the version (the
    board's next opening or closing, in seconds since the epoch; None: no such moment), its
    ETag, its headers for 200 and for 304, and its body."""

    version: int
    fresh_until: float | None
    etag: str
    headers: dict[str, str]
    not_modified_headers: dict[str, str]
    text: str


class PageShelf(Protocol):
    """Where a store keeps pages: ``key`` names the page of the board (its kind, size and, for
    a web page, the address it was rendered for)."""

    def version(self, board_id: str) -> int | None:
        """The board's version now (None: no such board), in the store's cheapest read."""

    def page(self, board_id: str, key: str) -> tuple[int | None, StoredPage | None]:
        """The board's version now and the page kept under ``key`` (None: none), in one read."""

    def keep(self, board_id: str, key: str, page: StoredPage) -> None:
        """Keep ``page`` unless a page of a later version is kept already (never raises: a page
        not kept is rendered again by its next reader)."""

    def keep_all(self, board_id: str, pages: Sequence[tuple[str, StoredPage]]) -> None:
        """Keep the pages a change of the board rendered for the version it made, as they are
        and in one write (never raises; a reader answers a page only for the version it shows)."""
