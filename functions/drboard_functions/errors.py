"""Typed domain errors. Each edge (HTTP handler, CLI) maps them to its statuses in one place."""

from __future__ import annotations


class DomainError(Exception):
    """Base of every error the service raises on purpose."""

    def __init__(self, message: str, *, detail: list[dict[str, str]] | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.detail = detail or []


class InvalidSubmission(DomainError):
    """The record is malformed or inconsistent (HTTP 422)."""


class SubmissionTooLarge(DomainError):
    """The request body is over the size bound (HTTP 413)."""


class BoardMismatch(DomainError):
    """The record does not belong on this board: another track, direction or race type (422)."""


class BoardNotFound(DomainError):
    """No such board (HTTP 404)."""


class RacerNotFound(DomainError):
    """The racer has no entry on the board (HTTP 404)."""


class WebhookNotFound(DomainError):
    """No such webhook on the board (HTTP 404)."""


class InvalidQuery(DomainError):
    """A bad cursor, limit or name in a query (HTTP 400)."""


class UnreadableBody(DomainError):
    """The request cannot be read as what it says it is: a Content-Length that is not a length
    or not the body's, base64 that does not decode, text that is not UTF-8 (HTTP 400)."""


class UnsupportedBody(DomainError):
    """The body is in a form the board does not take, e.g. multipart (HTTP 415): send JSON."""


class TooSoon(DomainError):
    """A submission limit applies (HTTP 429); ``retry_after_s`` says when to try again."""

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


class BoardClosed(DomainError):
    """The board is not open: it opens later or has closed (HTTP 403). Retrying will not help
    until the organiser changes its window."""


class DesignsPrivate(DomainError):
    """The board keeps its entries' designs private until it closes (HTTP 403)."""


class SubmissionLimitReached(DomainError):
    """The racer has used every submission the board allows (HTTP 403)."""


class BoardExists(DomainError):
    """A board with this id already exists (HTTP 409)."""


class BoardLocked(DomainError):
    """The change would rescore entries already on the board, or touch a track's default
    board in a way its rules do not allow (HTTP 409)."""


class NotAuthorized(DomainError):
    """The board refused the caller (HTTP 403): not allowed to do this."""


class NotSignedIn(NotAuthorized):
    """The request carries no sign-in the board accepts (HTTP 401)."""


class AliasTaken(NotAuthorized):
    """The alias belongs to another racer, or the caller pushes as another alias (HTTP 403)."""


class Banned(NotAuthorized):
    """An organiser banned the racer from the board (HTTP 403)."""


class NotQualified(NotAuthorized):
    """The board is a season's final and the racer is not one of its qualifiers (HTTP 403)."""


class SeasonNotFound(DomainError):
    """No such season (HTTP 404)."""


class SeasonExists(DomainError):
    """A season with this id already exists (HTTP 409)."""


class SeasonLocked(DomainError):
    """The season is closed (reopen it to change it), or was changed meanwhile (HTTP 409)."""


class CopiedRun(DomainError):
    """The run's evaluation is already on the board under another racer (HTTP 409)."""


class StoreError(DomainError):
    """The board's storage could not do the work now; nothing was written (HTTP 503, with
    Retry-After). Trying again in ``retry_after_s`` seconds may succeed."""

    def __init__(self, message: str, retry_after_s: int = 1, *,
                 detail: list[dict[str, str]] | None = None) -> None:
        super().__init__(message, detail=detail)
        self.retry_after_s = retry_after_s


class StoreBusy(StoreError):
    """The storage is busy: throttled, or other writes kept winning the same rows (HTTP 503)."""


class StoreUnavailable(StoreError):
    """The storage (or the archive) did not answer in time or could not be reached (HTTP 503)."""


class StoreFailed(StoreError):
    """The storage refused the request for a reason retrying will not mend: a request it found
    invalid, access the function was not given, a table or bucket that is missing (HTTP 500,
    with the store's own error named). Nothing was written."""


class BoardUnreachable(DomainError):
    """The board could not be reached or answered with something unexpected."""
