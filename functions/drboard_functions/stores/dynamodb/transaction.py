"""A push as one DynamoDB transaction, its items named so that a cancellation says by name
which condition failed.

The submission (and its record) is put if absent; the racer's tally counts it, on condition
that the board's limits allow it; each evaluation's fingerprint is claimed unless another racer
holds it; the audit event is written; and the entry is put if the racer has none (the board's
``participants`` + 1 in the same transaction) or if it is strictly better — a condition on the
stored entry, so concurrent pushes never lose a best nor pass a limit — with the rank counters
moved to match. It also claims, when the push asks, the racer's alias and its confusable skeleton
on the board, on condition that the board's settings and the event's bans are still those the
push checked (``settings``, ``bans``). A write whose outcome the service did not report (a timeout
after the commit) is settled by reading the submission back. A push's runs are indexed for every
board in the same transaction when their items fit in it (one write the fewer, and the index is
never behind the board); an import's, and the runs of a record too big for the transaction, once
it has committed.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import timedelta
from typing import TYPE_CHECKING, Any

from botocore.exceptions import BotoCoreError, ClientError

from ... import ranking
from ...errors import BoardNotFound, StoreBusy, StoreError, StoreUnavailable
from ...models.domain import (
    AliasClaim,
    AuditEvent,
    Entry,
    RunPrint,
    Submission,
    SubmissionLimits,
    WriteOutcome,
)
from ..aws_errors import UNAVAILABLE_RETRY_AFTER_S, cancellation_codes, code_of, store_error
from ..base import AliasConflict, BoardChanged, FingerprintTaken, LimitReached, LookalikeTaken
from .batches import put_all
from .codecs import (
    ALIAS_PARTITION,
    BANS_SK,
    BOARD_SK,
    EVENT_PARTITION,
    alias_items,
    audit_item,
    author_update,
    entry_item,
    fingerprint_item,
    fingerprint_sk,
    key,
    near_item,
    record_item,
    skeleton_item,
    skeleton_sk,
    submission_item,
    submission_sk,
    tally_sk,
    text,
)
from .ranks import LAZY_BUILD_MAX_RACERS, RankState
from .retries import MAX_ATTEMPTS, backoff

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.type_defs import (
        AttributeValueTypeDef,
        ConditionCheckTypeDef,
        TransactWriteItemTypeDef,
    )

    from .store import DynamoDbStore

FAILED = "ConditionalCheckFailed"
#: DynamoDB's bound on the items of one transaction.
MAX_TRANSACTION_ITEMS = 100


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


def settings_condition(version: int) -> tuple[str, dict[str, AttributeValueTypeDef]]:
    """The board item's condition that its settings are still at ``version`` (a board from
    before settings versions is at 0)."""
    if version == 0:
        return "attribute_not_exists(settings_version) OR settings_version = :settings", {
            ":settings": {"N": "0"}}
    return "settings_version = :settings", {":settings": {"N": str(version)}}


def bans_condition(version: int) -> tuple[str, dict[str, AttributeValueTypeDef]]:
    """The event bans item's condition that they are still at ``version`` (0: none yet)."""
    if version == 0:
        return "attribute_not_exists(sk)", {}
    return "version = :bans", {":bans": {"N": str(version)}}


def with_settings(change: TransactWriteItemTypeDef, settings: int | None) -> TransactWriteItemTypeDef:
    """The board's update, on condition too that its settings are still at version ``settings``."""
    if settings is None:
        return change
    update: Any = dict(change["Update"])
    unchanged, values = settings_condition(settings)
    update["ConditionExpression"] = f"({update['ConditionExpression']}) AND ({unchanged})"
    update["ExpressionAttributeValues"] = {**update["ExpressionAttributeValues"], **values}
    return {"Update": update}


class PushTransaction:
    def __init__(self, store: DynamoDbStore, submission: Submission, record_json: str, entry: Entry,
                 limits: SubmissionLimits | None, fingerprints: Sequence[str],
                 audit: AuditEvent | None, *, runs: Sequence[RunPrint] = (),
                 claim: AliasClaim | None = None, skeleton: str | None = None) -> None:
        self.store = store
        self.table = store.table
        self.submission = submission
        self.record_json = record_json
        self.entry = entry
        self.limits = limits
        self.fingerprints = fingerprints
        self.audit = audit
        self.runs = runs
        self.claim = claim
        self.skeleton = skeleton

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
            # A push read the entry already: its first attempt writes against that (the write
            # is conditioned on it); a later attempt reads it again.
            current = (self.limits.entry_seen if attempt == 0 and self.limits is not None
                       else self.store.get_entry(board_id, racer))
            slots = self._slots(current, state)
            indexed = self._add_index(slots)
            try:
                self._commit(slots)
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                failed = slots.failed(error)
                if "submission" in failed:
                    return self._duplicate()
                if "settings" in failed or "bans" in failed:
                    raise BoardChanged(board_id) from None
                if "tally" in failed:
                    raise LimitReached(self.store.tally(board_id, racer)) from None
                if "fingerprint" in failed:
                    raise FingerprintTaken(self._copied_from()) from None
                if "skeleton" in failed:
                    raise LookalikeTaken(self._held(skeleton_sk(self.skeleton or ""))) from None
                if "alias" in failed:
                    raise AliasConflict(self._alias_holder()) from None
                if "board" in failed:
                    # No board, its rank counters were built (or a build moved) meanwhile, or its
                    # settings changed.
                    state = ranks.state(board_id)
                    if not state.exists:
                        raise BoardNotFound(f"no board {board_id!r}") from None
                    if self._settings_moved():
                        raise BoardChanged(board_id) from None
                    continue
                if not failed and "TransactionConflict" not in cancellation_codes(error):
                    raise
                continue  # another push changed the entry or the board meanwhile: look again
            return self._stored(current, indexed)
        raise StoreBusy(f"{board_id!r} is busy with other pushes: gave up after {MAX_ATTEMPTS} "
                        "attempts, nothing was stored; try again in a moment")

    def _commit(self, slots: Slots) -> None:
        """Write the transaction. A failure that does not say whether it was written (a
        timeout, a lost connection, throttling or an error reported after the write) is
        settled by reading the submission back: stored means committed (the answer is then
        the write's, not an error); not stored means nothing was written."""
        try:
            self.store.client.transact_write_items(TransactItems=slots.items)
        except Exception as error:
            if isinstance(error, ClientError) and code_of(error) in (
                    "TransactionCanceledException", "ValidationException"):
                raise
            if store_error(error, "the board's table") is None and not isinstance(error, ClientError):
                raise
            written = self._written()
            if written is None:
                raise StoreUnavailable(
                    "the board's table did not say whether it stored the run: push it again "
                    "(a run already stored is answered as a duplicate, with its rank)",
                    UNAVAILABLE_RETRY_AFTER_S) from error
            if not written:
                raise

    def _written(self) -> bool | None:
        """Whether this push's submission is stored (None: that cannot be read either)."""
        try:
            item = self.store.client.get_item(
                TableName=self.table, ConsistentRead=True,
                Key=key(self.submission.board_id,
                        submission_sk(self.submission.racer_key, self.submission.submission_id)))
        except Exception:
            return None
        return "Item" in item

    def _slots(self, current: Entry | None, state: RankState) -> Slots:
        board_id, entry = self.entry.board_id, self.entry
        slots = Slots()
        slots.add("submission", {"Put": {"TableName": self.table,
                                         "Item": submission_item(self.submission),
                                         "ConditionExpression": "attribute_not_exists(sk)"}})
        slots.add("record", {"Put": {"TableName": self.table,
                                     "Item": record_item(board_id, self.submission.submission_id,
                                                         self.record_json)}})
        slots.add("tally", {"Update": self._count_submission()})
        slots.extend("fingerprint", [{"Put": {
            "TableName": self.table, "Item": fingerprint_item(board_id, f, entry.racer_key),
            "ConditionExpression": "attribute_not_exists(sk) OR racer_key = :me",
            "ExpressionAttributeValues": {":me": text(entry.racer_key)}}} for f in self.fingerprints])
        if self.audit is not None:
            slots.add("audit", {"Put": {"TableName": self.table, "Item": audit_item(self.audit)}})
        self._add_claims(slots)
        settings = self.limits.settings_version if self.limits is not None else None
        if current is None:
            slots.add("entry", {"Put": {"TableName": self.table, "Item": entry_item(entry),
                                        "ConditionExpression": "attribute_not_exists(sk)"}})
            slots.add("board", with_settings(self.store.ranks.board_change(board_id, +1, state),
                                             settings))
        elif entry.rank_key < current.rank_key:
            # Exactly the entry read: the counters take its score off.
            slots.add("entry", {"Put": {"TableName": self.table, "Item": entry_item(entry),
                                        "ConditionExpression": "rank_key = :seen",
                                        "ExpressionAttributeValues": {":seen": text(current.rank_key)}}})
            slots.add("board", with_settings(self.store.ranks.board_change(board_id, 0, state),
                                             settings))
        else:
            if settings is not None:  # the entry stays: the board's settings are checked alone
                condition, values = settings_condition(settings)
                slots.add("settings", {"ConditionCheck": {
                    "TableName": self.table, "Key": key(board_id, BOARD_SK),
                    "ConditionExpression": condition, "ExpressionAttributeValues": values}})
            return slots  # not better: the entry stays as it is (entries only ever improve)
        slots.extend("counters", self.store.ranks.changes(board_id, state, entry, current))
        return slots

    def _add_claims(self, slots: Slots) -> None:
        """The event's bans unchanged, the alias's claim, the skeleton held on the board, and
        the runs indexed for every board, in the push's own transaction."""
        board_id, racer = self.entry.board_id, self.entry.racer_key
        if self.limits is not None and self.limits.bans_version is not None:
            condition, values = bans_condition(self.limits.bans_version)
            check: ConditionCheckTypeDef = {"TableName": self.table,
                                            "Key": key(EVENT_PARTITION, BANS_SK),
                                            "ConditionExpression": condition}
            if values:
                check["ExpressionAttributeValues"] = values
            slots.add("bans", {"ConditionCheck": check})
        if self.claim is not None:
            slots.extend("alias", [{"Put": {"TableName": self.table, "Item": item,
                                            "ConditionExpression": "attribute_not_exists(sk)"}}
                                   for item in alias_items(self.claim)])
        if self.skeleton is not None:
            slots.add("skeleton", {"Put": {
                "TableName": self.table, "Item": skeleton_item(board_id, self.skeleton, racer),
                "ConditionExpression": "attribute_not_exists(sk) OR racer_key = :me",
                "ExpressionAttributeValues": {":me": text(racer)}}})

    def _settings_moved(self) -> bool:
        if self.limits is None or self.limits.settings_version is None:
            return False
        stored = self.store.get_board(self.entry.board_id)
        return stored is None or stored.settings_version != self.limits.settings_version

    def _held(self, sk: str) -> str:
        item = self.store.get_item(self.entry.board_id, sk)
        return item["racer_key"]["S"] if item else "another racer"

    def _alias_holder(self) -> AliasClaim:
        claim = self.claim
        assert claim is not None
        for sk in (f"K#{claim.racer_key}", f"P#{claim.principal}"):
            holder = self.store.get_item(ALIAS_PARTITION, sk)
            if holder is not None:
                return AliasClaim.model_validate_json(holder["data"]["S"])
        return claim

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

    def _stored(self, current: Entry | None, indexed: bool) -> WriteOutcome:
        if self.limits is None:
            self._advance_last_submitted()
        if not indexed:
            self._index_runs()
        if current is None or self.entry.rank_key < current.rank_key:
            return WriteOutcome(duplicate=False, improved=True, entry=self.entry)
        return WriteOutcome(duplicate=False, improved=False, entry=current)

    def _add_index(self, slots: Slots) -> bool:
        """A push's runs indexed for every board in its own transaction, if their items fit. A
        racer's first time with a run is kept as it is (``if_not_exists``): a push is the newest
        submission of a run, where an import's may be older (it is indexed after its commit, on
        condition that it is earlier)."""
        if self.limits is None:
            return False
        runs, submission = self.runs, self.submission
        lapped = [run for run in runs if run.laps_ms]
        if len(slots.items) + len(runs) + len(lapped) > MAX_TRANSACTION_ITEMS:
            return False
        at = ranking.timestamp(submission.submitted_at)
        for run in runs:
            first: Any = {"TableName": self.table, **author_update(
                run.fingerprint, submission.racer_key, submission.board_id,
                submission.submission_id, at, kept=True)}
            slots.add("index", {"Update": first})
        slots.extend("index", [{"Put": {"TableName": self.table, "Item": near_item(run, submission)}}
                               for run in lapped])
        return True

    def _index_runs(self) -> None:
        """Index the runs for every board once an import, or a push whose index does not fit its
        transaction (a record may hold 50 runs), has committed. It is stored whatever happens
        here; a run left out is indexed by the board's next recheck."""
        try:
            for run in self.runs:
                self.store.index_author(self.submission, run.fingerprint)
            put_all(self.store.client, self.table,
                    [near_item(run, self.submission) for run in self.runs if run.laps_ms])
        except (ClientError, BotoCoreError, StoreError):
            pass

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
