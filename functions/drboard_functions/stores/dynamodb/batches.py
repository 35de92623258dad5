"""Items written in DynamoDB's batches: no condition, 25 to a call, and what a call leaves
unprocessed (throttled) sent again after a pause. No model is imported here."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from .retries import backoff

if TYPE_CHECKING:
    from mypy_boto3_dynamodb import DynamoDBClient

#: DynamoDB's bound on the items of one BatchWriteItem.
BATCH_WRITE_ITEMS = 25


def put_all(client: DynamoDBClient, table: str, items: Sequence[dict[str, Any]]) -> None:
    """Put every item, BATCH_WRITE_ITEMS to a call, until DynamoDB has processed them all."""
    for start in range(0, len(items), BATCH_WRITE_ITEMS):
        pending: Any = {table: [{"PutRequest": {"Item": item}}
                                for item in items[start:start + BATCH_WRITE_ITEMS]]}
        attempt = 0
        while pending:
            if attempt:
                backoff(attempt)
            pending = client.batch_write_item(RequestItems=pending).get("UnprocessedItems") or None
            attempt += 1
