"""The cloud board: one DynamoDB table (its one definition is ``BoardTable`` in template.yaml).

How each thing is kept as an item is in ``codecs.py``; a push's transaction in
``transaction.py``; the rank counters in ``ranks.py``; seasons in ``seasons.py``. Aliases are
claimed in one transaction that writes the alias's item and its sign-in's on condition that
neither exists. Only this package talks to DynamoDB.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from datetime import datetime, timedelta
from typing import TYPE_CHECKING, Any

import boto3
from botocore.exceptions import ClientError
from drboard_assembler.record import Record

from ... import ranking
from ...errors import StoreBusy
from ...models.domain import (
    AliasClaim,
    AuditEvent,
    Board,
    Entry,
    EventBans,
    NearRun,
    RacerTally,
    RunAuthor,
    RunPrint,
    Submission,
    SubmissionLimits,
    WriteOutcome,
    with_flag,
    without_flag,
)
from ..aws_errors import cancellation_codes, code_of, translating
from ..base import (
    AliasConflict,
    AliasSlice,
    AuditSlice,
    BoardChanged,
    BoardHasEntries,
    BoardSlice,
    HistorySlice,
    ImportBatch,
    ImportWritten,
    Indexed,
    PushReads,
    RankBuild,
    RunSeen,
    StoredBoard,
    StoredSubmissionPage,
    SubmissionPage,
    delivered,
    page_token,
    read_page_token,
    stored_record,
    stored_webhook,
)
from .codecs import (
    ALIAS_PARTITION,
    BANS_SK,
    BOARD_KIND,
    BOARD_SK,
    BOARDS_INDEX,
    EVENT_PARTITION,
    FIRST_ENTRY,
    NEVER_IN_A_SEASON,
    NOTICE_PARTITION,
    RACER_INDEX,
    RANK_INDEX,
    WEBHOOK_PARTITION,
    alias_items,
    audit_event_of,
    audit_item,
    audit_sk,
    author_update,
    board_item,
    claim_of,
    entry_item,
    entry_of,
    entry_sk,
    fingerprint_item,
    fingerprint_sk,
    key,
    lane_partition,
    near_item,
    near_run_of,
    near_sk,
    record_json,
    record_sk,
    run_author_of,
    run_partition,
    skeleton_item,
    skeleton_sk,
    stored_board,
    submission_item,
    submission_of,
    submission_sk,
    tally_sk,
    text,
)
from .pages import DynamoDbPageShelf
from .ranks import FIRST_GENERATION, RankCounters
from .retries import MAX_ATTEMPTS, backoff
from .seasons import DynamoDbSeasons
from .transaction import PushTransaction, bans_condition

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.client import DynamoDBClient
    from mypy_boto3_dynamodb.type_defs import (
        AttributeValueTypeDef,
        PutItemInputTypeDef,
        QueryInputTypeDef,
        TransactWriteItemTypeDef,
    )

    from ...models.notices import Webhook
    from .codecs import Item

BATCH_GET_KEYS = 100
#: How long the table keeps a sent marker (its time to live): past any retry of its event.
NOTICE_TTL = timedelta(days=30)


#: At most this many of a push's copy-check queries at once (two per run of the record).
COPY_READERS = 8


@translating("the board's table")
class DynamoDbStore(DynamoDbSeasons):
    """The board in DynamoDB. Throttling, and a push that keeps losing races with others on the
    same board, raise StoreBusy; a timeout or a lost connection StoreUnavailable (nothing
    written either way)."""

    def __init__(self, table_name: str, client: DynamoDBClient | None = None) -> None:
        self.table = table_name
        self.client: DynamoDBClient = client if client is not None else boto3.client("dynamodb")
        self.ranks = RankCounters(self.client, table_name)
        self.pages: DynamoDbPageShelf = DynamoDbPageShelf(self.client, table_name)

    # ---- boards ---------------------------------------------------------------------------

    def get_board(self, board_id: str) -> StoredBoard | None:
        item = self.get_item(board_id, BOARD_SK)
        if not item:
            return None
        self.ranks.note(board_id, item)
        return stored_board(item)

    def board_version(self, board_id: str) -> int | None:
        # A consistent read of two small attributes (one read unit: the board item is under
        # 4 KB): a copy kept for the version it reads is never older than the last write.
        return self.pages.version(board_id)

    def create_board(self, board: Board) -> StoredBoard:
        item = board_item(board) | {"rank_generation": text(FIRST_GENERATION),
                                    NEVER_IN_A_SEASON: {"BOOL": True}}
        try:
            self.client.put_item(TableName=self.table, Item=item,
                                 ConditionExpression="attribute_not_exists(sk)")
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise
            stored = self.get_board(board.board_id)  # another push made it first
            assert stored is not None
            return stored
        self.ranks.note(board.board_id, item)
        return stored_board(item)

    def update_board(self, board: Board, *, only_if_empty: bool = False) -> StoredBoard:
        condition = "attribute_exists(sk)"
        values: dict[str, AttributeValueTypeDef] = {":data": text(board.model_dump_json()),
                                                    ":one": {"N": "1"}}
        if only_if_empty:
            condition += " AND participants = :none"
            values[":none"] = {"N": "0"}
        try:
            self.client.update_item(
                TableName=self.table, Key=key(board.board_id, BOARD_SK),
                UpdateExpression="SET #data = :data ADD board_version :one, settings_version :one",
                ConditionExpression=condition,
                ExpressionAttributeNames={"#data": "data"}, ExpressionAttributeValues=values)
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise
            if self.get_board(board.board_id) is None:
                raise KeyError(board.board_id) from None
            raise BoardHasEntries(board.board_id) from None
        stored = self.get_board(board.board_id)
        assert stored is not None
        return stored

    def list_boards(self) -> list[StoredBoard]:
        items = self._query({
            "TableName": self.table, "IndexName": BOARDS_INDEX,
            "KeyConditionExpression": "board_kind = :kind",
            "ExpressionAttributeValues": {":kind": text(BOARD_KIND)},
        })
        return [stored_board(item) for item in items]

    def boards_page(self, after: str | None, limit: int) -> BoardSlice:
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": BOARDS_INDEX,
            "KeyConditionExpression": "board_kind = :kind",
            "ExpressionAttributeValues": {":kind": text(BOARD_KIND)},
        }
        if after is not None:
            [board_id] = read_page_token(after, 1)
            request["ExclusiveStartKey"] = {"board_kind": text(BOARD_KIND), "board": text(board_id),
                                            "sk": text(BOARD_SK)}
        items, more = self._page(request, limit)
        return BoardSlice([stored_board(item) for item in items],
                          page_token([items[-1]["board"]["S"]]) if more else None)

    # ---- submissions ----------------------------------------------------------------------

    def record_submission(self, submission: Submission, record_json: str, entry: Entry,
                          limits: SubmissionLimits | None = None,
                          fingerprints: Sequence[str] = (),
                          audit: AuditEvent | None = None, *,
                          runs: Sequence[RunPrint] = (), claim: AliasClaim | None = None,
                          skeleton: str | None = None) -> WriteOutcome:
        return PushTransaction(self, submission, record_json, entry, limits, fingerprints, audit,
                               runs=runs, claim=claim, skeleton=skeleton).run()

    # ---- copies and lookalikes ------------------------------------------------------------

    def run_authors(self, fingerprint: str) -> list[RunAuthor]:
        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :run",
            "ExpressionAttributeValues": {":run": text(run_partition(fingerprint))}})
        return sorted((run_author_of(fingerprint, item) for item in items),
                      key=lambda author: author.first_at)

    def near_runs(self, lane: str, best_ms: int, tolerance_ms: int) -> list[NearRun]:
        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :lane AND sk BETWEEN :low AND :high",
            "ExpressionAttributeValues": {
                ":lane": text(lane_partition(lane)),
                ":low": text(near_sk(max(0, best_ms - tolerance_ms))),
                ":high": text(near_sk(best_ms + tolerance_ms) + "~")}}, limit=1000)
        return [near_run_of(item) for item in items]

    def lane_runs(self, lane: str) -> list[NearRun]:
        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :lane",
            "ExpressionAttributeValues": {":lane": text(lane_partition(lane))}})
        return [near_run_of(item) for item in items]

    def fingerprint_holder(self, board_id: str, fingerprint: str) -> str | None:
        item = self.get_item(board_id, fingerprint_sk(fingerprint))
        return item["racer_key"]["S"] if item else None

    def hand_over_fingerprint(self, board_id: str, fingerprint: str, racer_key: str) -> None:
        self.client.put_item(TableName=self.table,
                             Item=fingerprint_item(board_id, fingerprint, racer_key))

    def hand_over_skeleton(self, board_id: str, skeleton: str, racer_key: str) -> None:
        self.client.put_item(TableName=self.table, Item=skeleton_item(board_id, skeleton, racer_key))

    def flag_submission(self, board_id: str, racer_key: str, submission_id: str,
                        flag: str, remove: bool = False) -> bool:
        changed = without_flag if remove else with_flag
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                backoff(attempt)
            item = self.get_item(board_id, submission_sk(racer_key, submission_id))
            if item is None:
                return False
            submission = submission_of(item)
            if (flag in submission.score.flags) != remove:
                return False
            entry = self.get_entry(board_id, racer_key)
            flagged = submission_item(changed(submission, flag))
            writes: list[TransactWriteItemTypeDef] = [{"Put": {
                "TableName": self.table, "Item": flagged, "ConditionExpression": "#data = :seen",
                "ExpressionAttributeNames": {"#data": "data"},
                "ExpressionAttributeValues": {":seen": item["data"]}}}]
            if entry is not None and entry.submission_id == submission_id:
                writes.append({"Put": {
                    "TableName": self.table, "Item": entry_item(changed(entry, flag)),
                    "ConditionExpression": "rank_key = :seen",
                    "ExpressionAttributeValues": {":seen": text(entry.rank_key)}}})
                writes.append({"Update": {
                    "TableName": self.table, "Key": key(board_id, BOARD_SK),
                    "UpdateExpression": "ADD board_version :one",
                    "ExpressionAttributeValues": {":one": {"N": "1"}}}})
            try:
                self.client.transact_write_items(TransactItems=writes)
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                continue  # the submission or the entry changed meanwhile: look again
            return True
        raise StoreBusy(f"{board_id!r} is busy with other pushes: gave up flagging a run; "
                        "try again in a moment")

    def index_submission(self, submission: Submission, runs: Sequence[RunPrint],
                         fingerprints: Sequence[str], skeleton: str | None) -> Indexed:
        for run in runs:
            self.index_author(submission, run.fingerprint)
            if run.laps_ms:
                self.client.put_item(TableName=self.table, Item=near_item(run, submission))
        holders = {}
        for fingerprint in fingerprints:
            holder = self._hold(submission.board_id, fingerprint_item(
                submission.board_id, fingerprint, submission.racer_key))
            if holder is not None:
                holders[fingerprint] = holder
        lookalike = None
        if skeleton is not None:
            lookalike = self._hold(submission.board_id, skeleton_item(
                submission.board_id, skeleton, submission.racer_key))
        return Indexed(holders, lookalike)

    def index_author(self, submission: Submission, fingerprint: str) -> None:
        """The racer's first time with the run: kept unless this one is earlier."""
        try:
            self.client.update_item(TableName=self.table, **author_update(
                fingerprint, submission.racer_key, submission.board_id, submission.submission_id,
                ranking.timestamp(submission.submitted_at)))
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise

    def _hold(self, board_id: str, item: Item) -> str | None:
        """Put a racer's claim item unless another racer holds it; that racer's key, if so."""
        try:
            self.client.put_item(TableName=self.table, Item=item,
                                 ConditionExpression="attribute_not_exists(sk) OR racer_key = :me",
                                 ExpressionAttributeValues={":me": item["racer_key"]})
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise
            held = self.get_item(board_id, item["sk"]["S"])
            return held["racer_key"]["S"] if held else None
        return None

    # ---- bulk import ----------------------------------------------------------------------

    def present_submissions(self, board_id: str, keys: Sequence[tuple[str, str]]) -> set[str]:
        found = self.get_items(board_id, [submission_sk(racer, submission_id)
                                          for racer, submission_id in keys])
        return {sk.rpartition("#")[2] for sk in found}

    def authors_of(self, fingerprints: Sequence[str]) -> dict[str, list[RunAuthor]]:
        found = {fingerprint: self.run_authors(fingerprint) for fingerprint in fingerprints}
        return {fingerprint: authors for fingerprint, authors in found.items() if authors}

    def holders(self, board_id: str, fingerprints: Sequence[str],
                skeletons: Sequence[str]) -> tuple[dict[str, str], dict[str, str]]:
        found = self.get_items(board_id, [fingerprint_sk(f) for f in fingerprints]
                               + [skeleton_sk(s) for s in skeletons])
        return ({f: found[fingerprint_sk(f)]["racer_key"]["S"] for f in fingerprints
                 if fingerprint_sk(f) in found},
                {s: found[skeleton_sk(s)]["racer_key"]["S"] for s in skeletons
                 if skeleton_sk(s) in found})

    def import_batch(self, board_id: str, batch: ImportBatch) -> ImportWritten:
        from .bulk import BulkWrite  # only an import writes in bulk: a push never loads it

        return BulkWrite(self, board_id, batch).run()

    # ---- event-wide bans ------------------------------------------------------------------

    def event_bans(self) -> tuple[EventBans, int]:
        return _bans(self.get_item(EVENT_PARTITION, BANS_SK))

    def push_reads(self, board_id: str, racer_key: str, submission_id: str,
                   prints: Sequence[RunPrint], near_ms: int) -> PushReads:
        # The copy checks' queries go out while the batch read is answered (the client is
        # thread-safe): a push of one run waits for one round trip where it waited for three.
        with ThreadPoolExecutor(max_workers=min(2 * len(prints), COPY_READERS) or 1) as pool:
            authors = [pool.submit(self.run_authors, run.fingerprint) for run in prints]
            near = [pool.submit(self.near_runs, run.lane, run.laps_ms[0], near_ms) if run.laps_ms
                    else None for run in prints]
            read = self._first_reads(board_id, racer_key, submission_id)
            runs = [RunSeen(author.result(), lane.result() if lane else [])
                    for author, lane in zip(authors, near, strict=True)]
        return read._replace(runs=runs)

    def _first_reads(self, board_id: str, racer_key: str, submission_id: str) -> PushReads:
        """The board, the event's bans, the duplicate and the entry in one read (``runs`` left
        empty)."""
        submission_key, entry_key = submission_sk(racer_key, submission_id), entry_sk(racer_key)
        wanted = [key(board_id, BOARD_SK), key(EVENT_PARTITION, BANS_SK),
                  key(board_id, submission_key), key(board_id, entry_key)]
        answer = self.client.batch_get_item(RequestItems={self.table: {"Keys": wanted,
                                                                       "ConsistentRead": True}})
        if answer.get("UnprocessedKeys"):  # throttled: one read at a time
            return PushReads(self.get_board(board_id), *self.event_bans(),
                             self.get_submission(board_id, racer_key, submission_id),
                             self.get_entry(board_id, racer_key), [])
        found = {item["sk"]["S"]: item for item in answer.get("Responses", {}).get(self.table, [])}
        board, submission, entry = (found.get(sk) for sk in (BOARD_SK, submission_key, entry_key))
        if board is not None:
            self.ranks.note(board_id, board)
        return PushReads(stored_board(board) if board else None, *_bans(found.get(BANS_SK)),
                         submission_of(submission) if submission else None,
                         entry_of(entry) if entry else None, [])

    def save_event_bans(self, bans: EventBans, version: int) -> int:
        condition, values = bans_condition(version)
        request: PutItemInputTypeDef = {
            "TableName": self.table, "ConditionExpression": condition,
            "Item": {**key(EVENT_PARTITION, BANS_SK), "data": text(bans.model_dump_json()),
                     "version": {"N": str(version + 1)}}}
        if values:
            request["ExpressionAttributeValues"] = values
        try:
            self.client.put_item(**request)
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise
            raise BoardChanged("event bans") from None
        return version + 1

    # ---- moderation and audit -------------------------------------------------------------

    def remove_entry(self, board_id: str, racer_key: str) -> Entry | None:
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                backoff(attempt)
            current = self.get_entry(board_id, racer_key)
            if current is None:
                return None
            state = self.ranks.state(board_id)
            try:
                self.client.transact_write_items(TransactItems=[
                    {"Delete": {"TableName": self.table, "Key": key(board_id, entry_sk(racer_key)),
                                "ConditionExpression": "rank_key = :seen",
                                "ExpressionAttributeValues": {":seen": text(current.rank_key)}}},
                    self.ranks.board_change(board_id, -1, state),
                    *self.ranks.changes(board_id, state, None, current)])
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                continue  # the entry improved, or the counters were built, meanwhile: look again
            return current
        raise StoreBusy(f"{board_id!r} is busy with other pushes: gave up removing the entry; "
                        "try again in a moment")

    def restore_entry(self, entry: Entry) -> None:
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                backoff(attempt)
            state = self.ranks.state(entry.board_id)
            if not state.exists:
                return
            try:
                self.client.transact_write_items(TransactItems=[
                    {"Put": {"TableName": self.table, "Item": entry_item(entry),
                             "ConditionExpression": "attribute_not_exists(sk)"}},
                    self.ranks.board_change(entry.board_id, +1, state),
                    *self.ranks.changes(entry.board_id, state, entry, None)])
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                if cancellation_codes(error)[:1] == ["ConditionalCheckFailed"]:
                    return  # the racer has an entry again, from a push meanwhile
                continue  # the counters were built meanwhile, or another write was under way
            return
        raise StoreBusy(f"{entry.board_id!r} is busy with other pushes: gave up restoring the entry; "
                        "try again in a moment")

    def build_rank_counters(self, board_id: str, budget_s: float | None = None) -> RankBuild:
        """Count the entries of a board from before the rank counters into its counters (see
        ``RankCounters.build``)."""
        return self.ranks.build(board_id, budget_s=budget_s)

    def append_audit(self, event: AuditEvent) -> None:
        self.client.put_item(TableName=self.table, Item=audit_item(event),
                             ConditionExpression="attribute_not_exists(sk)")

    def audit(self, board_id: str, after: str | None, limit: int) -> AuditSlice:
        request: QueryInputTypeDef = {
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":board": text(board_id), ":prefix": text(audit_sk(""))},
            "ProjectionExpression": "#data", "ExpressionAttributeNames": {"#data": "data"},
        }
        if after is not None:
            request["ExclusiveStartKey"] = {"board": text(board_id), "sk": text(audit_sk(after))}
        events = [audit_event_of(item)
                  for item in self._query(request, limit=limit)]
        return AuditSlice(events, events[-1].event_id if len(events) == limit else None)

    # ---- aliases --------------------------------------------------------------------------

    def claim_alias(self, claim: AliasClaim) -> AliasClaim:
        try:
            self.client.transact_write_items(TransactItems=[
                {"Put": {"TableName": self.table, "Item": item,
                         "ConditionExpression": "attribute_not_exists(sk)"}}
                for item in alias_items(claim)])
        except ClientError as error:
            if code_of(error) != "TransactionCanceledException":
                raise
            for holder in (self.alias_holder(claim.racer_key), self.alias_of(claim.principal)):
                if holder is None:
                    continue
                if (holder.racer_key, holder.principal) == (claim.racer_key, claim.principal):
                    return holder
                raise AliasConflict(holder) from None
            raise  # pragma: no cover - cancelled, yet neither item exists
        return claim

    def assign_alias(self, claim: AliasClaim) -> AliasClaim | None:
        previous = self.alias_holder(claim.racer_key)
        held = self.alias_of(claim.principal)
        writes: list[TransactWriteItemTypeDef] = [
            {"Put": {"TableName": self.table, "Item": item}} for item in alias_items(claim)]
        if previous is not None and previous.principal != claim.principal:
            writes.append({"Delete": {"TableName": self.table,
                                      "Key": key(ALIAS_PARTITION, f"P#{previous.principal}")}})
        if held is not None and held.racer_key != claim.racer_key:
            writes.append({"Delete": {"TableName": self.table,
                                      "Key": key(ALIAS_PARTITION, f"K#{held.racer_key}")}})
        self.client.transact_write_items(TransactItems=writes)
        return previous

    def release_alias(self, racer_key: str) -> AliasClaim | None:
        previous = self.alias_holder(racer_key)
        if previous is not None:
            self.client.transact_write_items(TransactItems=[
                {"Delete": {"TableName": self.table, "Key": key(ALIAS_PARTITION, f"K#{racer_key}")}},
                {"Delete": {"TableName": self.table,
                            "Key": key(ALIAS_PARTITION, f"P#{previous.principal}")}}])
        return previous

    def aliases(self, after: str | None, limit: int) -> AliasSlice:
        request: QueryInputTypeDef = {
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :aliases AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":aliases": text(ALIAS_PARTITION), ":prefix": text("K#")},
        }
        if after is not None:
            [racer_key] = read_page_token(after, 1)
            request["ExclusiveStartKey"] = key(ALIAS_PARTITION, f"K#{racer_key}")
        items, more = self._page(request, limit)
        claims = [claim_of(item) for item in items]
        return AliasSlice(claims, page_token([claims[-1].racer_key]) if more and claims else None)

    def alias_of(self, principal: str) -> AliasClaim | None:
        item = self.get_item(ALIAS_PARTITION, f"P#{principal}")
        return claim_of(item) if item else None

    def alias_holder(self, racer_key: str) -> AliasClaim | None:
        item = self.get_item(ALIAS_PARTITION, f"K#{racer_key}")
        return claim_of(item) if item else None

    # ---- webhooks and announcements -------------------------------------------------------

    def put_webhook(self, webhook: Webhook) -> None:
        self.client.put_item(TableName=self.table, Item={
            **key(WEBHOOK_PARTITION, f"{webhook.target.key}#{webhook.webhook_id}"),
            "data": text(webhook.model_dump_json())})

    def webhooks(self, target_key: str) -> list[Webhook]:
        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :partition AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":partition": text(WEBHOOK_PARTITION),
                                          ":prefix": text(target_key + "#")}})
        found = [stored_webhook(item["data"]["S"]) for item in items]
        return sorted((w for w in found if w.target.key == target_key),
                      key=lambda w: (w.created_at, w.webhook_id))

    def all_webhooks(self) -> list[Webhook]:
        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :partition",
            "ExpressionAttributeValues": {":partition": text(WEBHOOK_PARTITION)}})
        return [stored_webhook(item["data"]["S"]) for item in items]

    def delete_webhook(self, target_key: str, webhook_id: str) -> Webhook | None:
        answer = self.client.delete_item(TableName=self.table, ReturnValues="ALL_OLD",
                                         Key=key(WEBHOOK_PARTITION, f"{target_key}#{webhook_id}"))
        old = answer.get("Attributes")
        return stored_webhook(old["data"]["S"]) if old else None

    def note_delivery(self, target_key: str, webhook_id: str, at: datetime,
                      error: str | None) -> None:
        item = self.get_item(WEBHOOK_PARTITION, f"{target_key}#{webhook_id}")
        if item is None:
            return
        webhook = delivered(stored_webhook(item["data"]["S"]), at, error)
        try:
            self.client.put_item(TableName=self.table, ConditionExpression="attribute_exists(sk)",
                                 Item={**key(WEBHOOK_PARTITION, f"{target_key}#{webhook_id}"),
                                       "data": text(webhook.model_dump_json())})
        except ClientError as problem:
            if code_of(problem) != "ConditionalCheckFailedException":
                raise  # removed meanwhile: nothing to note

    def claim_notice(self, notice_id: str, webhook_id: str, now: datetime, lease_s: int) -> bool:
        until = now + timedelta(seconds=lease_s)
        try:
            self.client.put_item(
                TableName=self.table,
                Item={**key(NOTICE_PARTITION, f"{notice_id}#{webhook_id}"),
                      "state": text("sending"), "lease_until": text(ranking.timestamp(until)),
                      "expires_at": {"N": str(int((now + NOTICE_TTL).timestamp()))}},
                ConditionExpression="attribute_not_exists(sk) OR #state = :failed OR "
                                    "(#state = :sending AND lease_until <= :now)",
                ExpressionAttributeNames={"#state": "state"},
                ExpressionAttributeValues={":failed": text("failed"), ":sending": text("sending"),
                                           ":now": text(ranking.timestamp(now))})
        except ClientError as problem:
            if code_of(problem) != "ConditionalCheckFailedException":
                raise
            return False
        return True

    def finish_notice(self, notice_id: str, webhook_id: str, sent: bool) -> None:
        self.client.update_item(
            TableName=self.table, Key=key(NOTICE_PARTITION, f"{notice_id}#{webhook_id}"),
            UpdateExpression="SET #state = :state", ExpressionAttributeNames={"#state": "state"},
            ExpressionAttributeValues={":state": text("sent" if sent else "failed")})

    # ---- reads ----------------------------------------------------------------------------

    def get_submission(self, board_id: str, racer_key: str, submission_id: str) -> Submission | None:
        item = self.get_item(board_id, submission_sk(racer_key, submission_id))
        return submission_of(item) if item else None

    def tally(self, board_id: str, racer_key: str) -> RacerTally:
        item = self.get_item(board_id, tally_sk(racer_key))
        if not item:
            return RacerTally()
        last = item.get("last_at")
        return RacerTally(submissions=int(item["submissions"]["N"]),
                          last_submitted_at=ranking.parse_timestamp(last["S"]) if last else None)

    def submissions(self, board_id: str, after: str | None, limit: int) -> SubmissionPage:
        page = self.stored_submissions(board_id, after, limit)
        return SubmissionPage([(s, stored_record(raw)) for s, raw in page.submissions], page.after)

    def stored_submissions(self, board_id: str, after: str | None, limit: int) -> StoredSubmissionPage:
        request: QueryInputTypeDef = {
            "TableName": self.table, "ConsistentRead": True, "Limit": limit,
            "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":board": text(board_id), ":prefix": text("S#")},
            "ProjectionExpression": "sk, #data", "ExpressionAttributeNames": {"#data": "data"},
        }
        if after is not None:
            request["ExclusiveStartKey"] = {"board": text(board_id), "sk": text(after)}
        page = self.client.query(**request)
        submissions = [submission_of(item) for item in page["Items"]]
        records = self._records(board_id, [s.submission_id for s in submissions])
        pairs: list[tuple[Submission, str | bytes]] = [
            (s, records[s.submission_id]) for s in submissions if s.submission_id in records]
        more = page.get("LastEvaluatedKey") and page["Items"]
        return StoredSubmissionPage(pairs, page["Items"][-1]["sk"]["S"] if more else None)

    def exported_entries(self, board_id: str) -> Iterator[bytes]:
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board AND rank_key > :first",
            "ExpressionAttributeValues": {":board": text(board_id), ":first": text(FIRST_ENTRY)},
            "ProjectionExpression": "#data", "ExpressionAttributeNames": {"#data": "data"},
        }
        for page in self._pages(request):
            for item in page["Items"]:
                yield item["data"]["S"].encode()

    def exported_submissions(self, board_id: str) -> Iterator[tuple[bytes, bytes]]:
        request: QueryInputTypeDef = {
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":board": text(board_id), ":prefix": text("S#")},
            "ProjectionExpression": "sk, #data", "ExpressionAttributeNames": {"#data": "data"},
        }
        for page in self._pages(request):
            # ``S#<racer key>#<submission id>``: the id is the part after the last "#".
            submissions = [(item["sk"]["S"].rpartition("#")[2], item["data"]["S"])
                           for item in page["Items"]]
            records = self._records(board_id, [submission_id for submission_id, _ in submissions])
            for submission_id, data in submissions:
                record = records.get(submission_id)
                if record is not None:
                    yield data.encode(), record

    def _records(self, board_id: str, submission_ids: list[str]) -> dict[str, bytes]:
        """The records' JSON, as stored, by submission id."""
        keys = [key(board_id, record_sk(i)) for i in dict.fromkeys(submission_ids)]
        return {item["sk"]["S"].removeprefix(record_sk("")): record_json(item)
                for item in self._batch_get(keys)}

    def front_page(self, board_id: str, limit: int) -> tuple[StoredBoard | None, list[Entry]]:
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board",
            "ExpressionAttributeValues": {":board": text(board_id)},
            "ProjectionExpression": f"sk, #data, participants, board_version, settings_version, "
                                    f"{NEVER_IN_A_SEASON}",
            "ExpressionAttributeNames": {"#data": "data"},
        }
        items = self._query(request, limit=limit + 1)
        if not items or items[0]["sk"]["S"] != BOARD_SK:
            return None, []
        return stored_board(items[0]), [entry_of(i) for i in items[1:]]

    def top(self, board_id: str, limit: int, after: str | None = None) -> list[Entry]:
        condition = "board = :board AND rank_key > :after"
        values: dict[str, AttributeValueTypeDef] = {
            ":board": text(board_id), ":after": text(FIRST_ENTRY if after is None else after)}
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "KeyConditionExpression": condition, "ExpressionAttributeValues": values,
            "ProjectionExpression": "#data", "ExpressionAttributeNames": {"#data": "data"},
        }
        return [entry_of(item)
                for item in self._query(request, limit=limit)]

    def get_entry(self, board_id: str, racer_key: str) -> Entry | None:
        item = self.get_item(board_id, entry_sk(racer_key))
        return entry_of(item) if item else None

    def count_better(self, board_id: str, score_key: str) -> int:
        return self.ranks.count_better(board_id, score_key)

    def history(self, racer_key: str, board_id: str | None = None) -> list[Submission]:
        names = {"#data": "data"}
        if board_id is None:
            request: QueryInputTypeDef = {
                "TableName": self.table, "IndexName": RACER_INDEX,
                "KeyConditionExpression": "history_racer = :racer",
                "ExpressionAttributeValues": {":racer": text(racer_key)},
                "ProjectionExpression": "#data", "ExpressionAttributeNames": names,
            }
        else:
            request = {
                "TableName": self.table, "ConsistentRead": True,
                "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
                "ExpressionAttributeValues": {":board": text(board_id),
                                              ":prefix": text(submission_sk(racer_key, ""))},
                "ProjectionExpression": "#data", "ExpressionAttributeNames": names,
            }
        submissions = [submission_of(item)
                       for item in self._query(request)]
        # A racer key may itself contain "#": keep only this racer's own submissions.
        mine = [s for s in submissions if s.racer_key == racer_key]
        return sorted(mine, key=lambda s: (s.submitted_at, s.board_id, s.submission_id))

    def history_page(self, racer_key: str, board_id: str | None, after: str | None,
                     limit: int) -> HistorySlice:
        # The racer index holds every submission by time, on every board; one board's are
        # filtered from it, so the page stays in time order.
        values: dict[str, AttributeValueTypeDef] = {":racer": text(racer_key)}
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RACER_INDEX,
            "KeyConditionExpression": "history_racer = :racer",
            "ExpressionAttributeValues": values,
            "ProjectionExpression": "board, sk, submitted_at, #data",
            "ExpressionAttributeNames": {"#data": "data"},
        }
        if board_id is not None:
            request["FilterExpression"] = "board = :board"
            values[":board"] = text(board_id)
        if after is not None:
            submitted_at, board, sk = read_page_token(after, 3)
            request["ExclusiveStartKey"] = {"history_racer": text(racer_key),
                                            "submitted_at": text(submitted_at),
                                            "board": text(board), "sk": text(sk)}
        items, more = self._page(request, limit)
        last = items[-1] if items else None
        token = page_token([last["submitted_at"]["S"], last["board"]["S"], last["sk"]["S"]]) \
            if more and last else None
        return HistorySlice([submission_of(item) for item in items],
                            token)

    def get_record(self, board_id: str, submission_id: str) -> Record | None:
        item = self.get_item(board_id, record_sk(submission_id))
        return stored_record(record_json(item)) if item else None

    # ---- plumbing -------------------------------------------------------------------------

    def get_items(self, board_id: str, sks: Sequence[str]) -> dict[str, Item]:
        """The board's items with these sort keys (those there), by sort key, read consistently."""
        return {item["sk"]["S"]: item
                for item in self._batch_get([key(board_id, sk) for sk in dict.fromkeys(sks)])}

    def _batch_get(self, keys: Sequence[dict[str, AttributeValueTypeDef]]) -> Iterator[Item]:
        """The items with these keys (those there), read consistently a hundred at a time, the
        keys DynamoDB leaves unprocessed asked again after a pause."""
        for start in range(0, len(keys), BATCH_GET_KEYS):
            pending: Any = {self.table: {"Keys": keys[start:start + BATCH_GET_KEYS],
                                         "ConsistentRead": True}}
            attempt = 0
            while pending:
                if attempt:
                    backoff(attempt)
                answer = self.client.batch_get_item(RequestItems=pending)
                yield from answer["Responses"].get(self.table, [])
                pending = answer.get("UnprocessedKeys") or None
                attempt += 1

    def get_item(self, board_id: str, sk: str) -> Item | None:
        response = self.client.get_item(TableName=self.table, ConsistentRead=True,
                                        Key=key(board_id, sk))
        return response.get("Item")

    def _pages(self, request: QueryInputTypeDef, limit: int | None = None) -> Iterator[Any]:
        """Query pages until ``limit`` items (or all of them) are read."""
        request = request.copy()
        seen = 0
        while True:
            if limit is not None:
                request["Limit"] = limit - seen
            page = self.client.query(**request)
            yield page
            seen += page["Count"]
            last = page.get("LastEvaluatedKey")
            if not last or (limit is not None and seen >= limit):
                return
            request["ExclusiveStartKey"] = last

    def _page(self, request: QueryInputTypeDef, limit: int) -> tuple[list[Item], bool]:
        """Up to ``limit`` items the query (and its filter) selects, and whether there are
        more: pages are read until the limit is reached or the query ends."""
        request = request.copy()
        items: list[Item] = []
        while True:
            request["Limit"] = limit + 1 - len(items)
            page = self.client.query(**request)
            items.extend(page["Items"])
            last = page.get("LastEvaluatedKey")
            if len(items) > limit:
                return items[:limit], True
            if not last:
                return items, False
            request["ExclusiveStartKey"] = last

    def _query(self, request: QueryInputTypeDef, limit: int | None = None) -> list[Item]:
        return [item for page in self._pages(request, limit) for item in page["Items"]]


def _bans(item: Item | None) -> tuple[EventBans, int]:
    if item is None:
        return EventBans(), 0
    return EventBans.model_validate_json(item["data"]["S"]), int(item["version"]["N"])
