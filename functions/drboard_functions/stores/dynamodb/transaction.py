"""A push as one DynamoDB transaction, its items named so that a cancellation says by name
which condition failed.

The submission (and its record) is put if absent; the racer's tally counts it, on condition
that the board's limits allow it; each evaluation's fingerprint is claimed unless another racer
holds it; the audit event is written; and the entry is put if the racer has none (the board's
``participants`` + 1 in the same transaction) or if it is strictly better — a condition on the
stored entry, so concurrent pushes never lose a best nor pass a limit — with the rank counters
moved to match.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import timedelta
from typing import TYPE_CHECKING, Any

from botocore.exceptions import ClientError
from drboard_assembler.record import Record

from ... import ranking
from ...errors import BoardNotFound, StoreBusy
from ...models.domain import AuditEvent, Entry, Submission, SubmissionLimits, WriteOutcome
from ..aws_errors import cancellation_codes, code_of
from ..base import FingerprintTaken, LimitReached
from .codecs import (
    audit_item,
    entry_item,
    fingerprint_item,
    fingerprint_sk,
    key,
    record_item,
    submission_item,
    tally_sk,
    text,
)
from .ranks import LAZY_BUILD_MAX_RACERS, RankState
from .retries import MAX_ATTEMPTS, backoff

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.type_defs import TransactWriteItemTypeDef

    from .store import DynamoDbStore

FAILED = "ConditionalCheckFailed"


class Slots:
    """Transaction items, each under a name."""

    def __init__(self) -> None:
        self.items: list[TransactWriteItemTypeDef] = []
        self.names: list[str] = []

    def add(self, name: str, item: TransactWriteItemTypeDef) -> None:
        self.items.append(item)
        self.names.append(name)

    def extend(self, name: str, items: Sequence[TransactWriteItemTypeDef]) -> None:
        for item in items:
            self.add(name, item)

    def failed(self, error: ClientError) -> set[str]:
        """The names of the items whose condition failed in a cancelled transaction."""
        return {name for name, code in zip(self.names, cancellation_codes(error), strict=False)
                if code == FAILED}


class PushTransaction:
    def __init__(self, store: DynamoDbStore, submission: Submission, record: Record, entry: Entry,
                 limits: SubmissionLimits | None, fingerprints: Sequence[str],
                 audit: AuditEvent | None) -> None:
        self.store = store
        self.table = store.table
        self.submission = submission
        self.record = record
        self.entry = entry
        self.limits = limits
        self.fingerprints = fingerprints
        self.audit = audit

    def run(self) -> WriteOutcome:
        board_id, racer = self.entry.board_id, self.entry.racer_key
        ranks = self.store.ranks
        state = ranks.state(board_id)
        if state.exists and state.generation is None and state.building is None:
            ranks.build(board_id, max_racers=LAZY_BUILD_MAX_RACERS)
            state = ranks.state(board_id)
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                backoff(attempt)
            current = self.store.get_entry(board_id, racer)
            slots = self._slots(current, state)
            try:
                self.store.client.transact_write_items(TransactItems=slots.items)
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                failed = slots.failed(error)
                if "submission" in failed:
                    return self._duplicate()
                if "tally" in failed:
                    raise LimitReached(self.store.tally(board_id, racer)) from None
                if "fingerprint" in failed:
                    raise FingerprintTaken(self._copied_from()) from None
                if "board" in failed:
                    # No board, or its rank counters were built (or a build moved) meanwhile.
                    state = ranks.state(board_id)
                    if not state.exists:
                        raise BoardNotFound(f"no board {board_id!r}") from None
                    continue
                if not failed and "TransactionConflict" not in cancellation_codes(error):
                    raise
                continue  # another push changed the entry or the board meanwhile: look again
            return self._stored(current)
        raise StoreBusy(f"{board_id!r} is busy with other pushes: gave up after {MAX_ATTEMPTS} "
                        "attempts, nothing was stored; try again in a moment")

    def _slots(self, current: Entry | None, state: RankState) -> Slots:
        board_id, entry = self.entry.board_id, self.entry
        slots = Slots()
        slots.add("submission", {"Put": {"TableName": self.table,
                                         "Item": submission_item(self.submission),
                                         "ConditionExpression": "attribute_not_exists(sk)"}})
        slots.add("record", {"Put": {"TableName": self.table,
                                     "Item": record_item(board_id, self.record)}})
        slots.add("tally", {"Update": self._count_submission()})
        slots.extend("fingerprint", [{"Put": {
            "TableName": self.table, "Item": fingerprint_item(board_id, f, entry.racer_key),
            "ConditionExpression": "attribute_not_exists(sk) OR racer_key = :me",
            "ExpressionAttributeValues": {":me": text(entry.racer_key)}}} for f in self.fingerprints])
        if self.audit is not None:
            slots.add("audit", {"Put": {"TableName": self.table, "Item": audit_item(self.audit)}})
        if current is None:
            slots.add("entry", {"Put": {"TableName": self.table, "Item": entry_item(entry),
                                        "ConditionExpression": "attribute_not_exists(sk)"}})
            slots.add("board", self.store.ranks.board_change(board_id, +1, state))
        elif entry.rank_key < current.rank_key:
            # Exactly the entry read: the counters take its score off.
            slots.add("entry", {"Put": {"TableName": self.table, "Item": entry_item(entry),
                                        "ConditionExpression": "rank_key = :seen",
                                        "ExpressionAttributeValues": {":seen": text(current.rank_key)}}})
            slots.add("board", self.store.ranks.board_change(board_id, 0, state))
        else:
            return slots  # not better: the entry stays as it is (entries only ever improve)
        slots.extend("counters", self.store.ranks.changes(board_id, state, entry, current))
        return slots

    def _count_submission(self) -> Any:
        """The tally's update, conditioned on the limits: the racer's last submission is old
        enough and they have made fewer than the maximum (a first submission always passes)."""
        submission, limits = self.submission, self.limits
        update: dict[str, Any] = {
            "TableName": self.table,
            "Key": key(submission.board_id, tally_sk(submission.racer_key)),
            "UpdateExpression": "SET submissions = if_not_exists(submissions, :zero) + :one",
            "ExpressionAttributeValues": {":zero": {"N": "0"}, ":one": {"N": "1"}},
        }
        if limits is None:  # an import: the last time is moved forward after the transaction
            return update
        values = update["ExpressionAttributeValues"]
        update["UpdateExpression"] += ", last_at = :at"
        values[":at"] = text(ranking.timestamp(submission.submitted_at))
        checks = []
        if limits.max_submissions is not None:
            checks.append("submissions < :max")
            values[":max"] = {"N": str(limits.max_submissions)}
        if limits.cooldown_s:
            checks.append("(attribute_not_exists(last_at) OR last_at <= :cutoff)")
            cutoff = limits.now - timedelta(seconds=limits.cooldown_s)
            values[":cutoff"] = text(ranking.timestamp(cutoff))
        if checks:
            allowed = checks[0] if len(checks) == 1 else "(" + " AND ".join(checks) + ")"
            update["ConditionExpression"] = f"attribute_not_exists(sk) OR {allowed}"
        return update

    def _stored(self, current: Entry | None) -> WriteOutcome:
        if self.limits is None:
            self._advance_last_submitted()
        if current is None or self.entry.rank_key < current.rank_key:
            return WriteOutcome(duplicate=False, improved=True, entry=self.entry)
        return WriteOutcome(duplicate=False, improved=False, entry=current)

    def _advance_last_submitted(self) -> None:
        submission = self.submission
        try:
            self.store.client.update_item(
                TableName=self.table, Key=key(submission.board_id, tally_sk(submission.racer_key)),
                UpdateExpression="SET last_at = :at",
                ConditionExpression="attribute_not_exists(last_at) OR last_at < :at",
                ExpressionAttributeValues={":at": text(ranking.timestamp(submission.submitted_at))})
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise

    def _duplicate(self) -> WriteOutcome:
        current = self.store.get_entry(self.entry.board_id, self.entry.racer_key)
        return WriteOutcome(duplicate=True, improved=False, entry=current or self.entry)

    def _copied_from(self) -> str:
        holders = [item["racer_key"]["S"] for f in self.fingerprints
                   if (item := self.store.get_item(self.entry.board_id, fingerprint_sk(f)))]
        return holders[0] if holders else "another racer"
