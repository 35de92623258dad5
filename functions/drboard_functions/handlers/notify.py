"""The NotifyFunction: announcements in the club's chat, out of the push's way.

Two kinds of event reach it:
- a batch of the table's stream records, filtered by the event source mapping to entries
  (``R#...`` items) inserted or changed: each is an :class:`EntryChange` (the old and the new
  image) for the notifier. A record whose announcement failed is reported as a batch item failure,
  so Lambda tries it again (the sent markers skip the webhooks that already have it) and, after
  its last try, sends it to the dead-letter queue;
- the schedule's ``{"check": "windows"}``: the boards' openings and closings.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from aws_lambda_powertools import Logger
from aws_lambda_powertools.utilities.batch import BatchProcessor, EventType, process_partial_response
from aws_lambda_powertools.utilities.data_classes.dynamo_db_stream_event import DynamoDBRecord
from aws_lambda_powertools.utilities.typing import LambdaContext

from ..models.domain import Entry
from ..models.notices import EntryChange
from . import collector_after_first_answer, wiring

logger = Logger()
processor = BatchProcessor(event_type=EventType.DynamoDBStreams)


class AnnouncementFailed(Exception):
    """Some webhooks did not take the announcement (their ids only: never a URL)."""


def announce_change(record: DynamoDBRecord) -> None:
    change = entry_change(record)
    if change is None:
        return
    failures = wiring.notifier_from_environment().entry_changed(change)
    if failures:
        raise AnnouncementFailed("; ".join(failure.split(":")[0] for failure in failures))


def entry_change(record: DynamoDBRecord) -> EntryChange | None:
    stream = record.dynamodb
    if stream is None or not stream.new_image or "data" not in stream.new_image:
        return None
    old = stream.old_image or {}
    at = stream.approximate_creation_date_time
    return EntryChange(board_id=str(stream.new_image["board"]),
                       before=Entry.model_validate_json(old["data"]) if "data" in old else None,
                       after=Entry.model_validate_json(stream.new_image["data"]),
                       at=at if at is not None else datetime.now(UTC))


@collector_after_first_answer
@logger.inject_lambda_context
def lambda_handler(event: dict[str, Any], context: LambdaContext) -> dict[str, Any]:
    if event.get("check") == "windows":
        failures = wiring.notifier_from_environment().check_windows()
        logger.info("WindowsChecked", extra={"failed_webhooks": len(failures)})
        return {"failed": len(failures)}
    return dict(process_partial_response(event=event, record_handler=announce_change,
                                         processor=processor, context=context))
