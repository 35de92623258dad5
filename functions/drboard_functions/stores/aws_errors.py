"""The AWS SDK's failures as store errors: the one place the cloud stores translate them.

Throttling (after the SDK's own retries) is :class:`StoreBusy`; a timeout, a lost connection or
the service's own 5xx is :class:`StoreUnavailable`; every other error the SDK raises (a request
the service found invalid, access denied, a missing table or bucket, missing credentials) is
:class:`StoreFailed`, named after the service's own error, so no store error is a bare 500. A
condition that failed is the store's business: the stores handle those before this.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from botocore.exceptions import BotoCoreError, ClientError, HTTPClientError
from botocore.exceptions import ConnectionError as SdkConnectionError

from ..errors import StoreBusy, StoreFailed, StoreUnavailable

#: What DynamoDB and S3 answer when a caller goes faster than the table or bucket allows.
THROTTLING_CODES = frozenset({
    "ProvisionedThroughputExceededException", "ThrottlingException", "RequestLimitExceeded",
    "TransactionInProgressException", "SlowDown", "Throttling", "TooManyRequestsException",
})
#: A transaction's per-item reasons that mean the same.
THROTTLED_REASONS = frozenset({"ThrottlingError", "ProvisionedThroughputExceeded",
                               "RequestLimitExceeded", "TransactionConflict"})
UNAVAILABLE_CODES = frozenset({"InternalServerError", "ServiceUnavailable", "InternalError",
                               "RequestTimeout", "RequestTimeoutException"})
BUSY_RETRY_AFTER_S = 1
UNAVAILABLE_RETRY_AFTER_S = 5


def code_of(error: ClientError) -> str:
    return str(error.response.get("Error", {}).get("Code", ""))


def cancellation_codes(error: ClientError) -> list[str]:
    reasons: list[dict[str, Any]] = error.response.get("CancellationReasons", [])  # type: ignore[assignment]
    return [str(reason.get("Code", "None")) for reason in reasons]


def store_error(error: Exception, what: str) -> StoreBusy | StoreUnavailable | StoreFailed | None:
    """The store error ``error`` means, or None when it is not one (then let it through)."""
    if isinstance(error, (SdkConnectionError, HTTPClientError)):
        return StoreUnavailable(f"{what} did not answer in time; nothing was stored, try again",
                                UNAVAILABLE_RETRY_AFTER_S)
    if isinstance(error, BotoCoreError):
        return StoreFailed(f"{what} could not be asked ({type(error).__name__}: {error}); "
                           "nothing was stored", UNAVAILABLE_RETRY_AFTER_S)
    if not isinstance(error, ClientError):
        return None
    code = code_of(error)
    if code in THROTTLING_CODES or (code == "TransactionCanceledException" and throttled(error)):
        return StoreBusy(f"{what} is busy; try again in a moment", BUSY_RETRY_AFTER_S)
    if code in UNAVAILABLE_CODES:
        return StoreUnavailable(f"{what} is unavailable; nothing was stored, try again",
                                UNAVAILABLE_RETRY_AFTER_S)
    message = str(error.response.get("Error", {}).get("Message", ""))[:200]
    return StoreFailed(f"{what} refused the request ({code or 'an error'}: {message}); "
                       "nothing was stored", UNAVAILABLE_RETRY_AFTER_S)


def throttled(error: ClientError) -> bool:
    """A cancelled transaction whose only failures were throttling or conflicts, no condition."""
    reasons = set(cancellation_codes(error)) - {"None"}
    return bool(reasons) and reasons <= THROTTLED_REASONS


@contextmanager
def translated(what: str) -> Iterator[None]:
    """Raise the store error an SDK failure means, from here."""
    try:
        yield
    except (ClientError, BotoCoreError) as error:
        translated_error = store_error(error, what)
        if translated_error is None:
            raise
        raise translated_error from error


C = TypeVar("C", bound=type)


def translating(what: str) -> Callable[[C], C]:
    """A class decorator: each public method of the store raises store errors (around the
    method, so the store's own retries of a lost race run first)."""
    def decorate(cls: C) -> C:
        for name, method in list(vars(cls).items()):
            if callable(method) and not name.startswith("_"):
                setattr(cls, name, _translating_method(method, what))
        return cls
    return decorate


def _translating_method(method: Callable[..., Any], what: str) -> Callable[..., Any]:
    @functools.wraps(method)
    def call(*args: Any, **kwargs: Any) -> Any:
        with translated(what):
            return method(*args, **kwargs)
    return call
