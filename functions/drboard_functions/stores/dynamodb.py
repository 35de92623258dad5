"""The cloud board: one DynamoDB table (its one definition is ``BoardTable`` in template.yaml).

Items of a board share its partition (``board``); the sort key ``sk`` tells them apart:

- ``#BOARD``: the board (its JSON in ``data``, ``participants``, ``board_version``, and
  ``board_kind="board"`` for the sparse ``boards`` index that lists boards). Its ``rank_key``
  is ``#BOARD`` too, which sorts before every entry's, so one Query of ``by_rank`` reads the
  board and its first page together;
- ``R#<racer_key>``: a racer's entry, their best (``data``, ``score_key``, and ``rank_key`` for
  the sparse local index ``by_rank``: the top N is one Query reading N items);
- ``P#<racer_key>``: the racer's tally on the board (``submissions``, ``last_at``), which the
  board's submission limits are checked against in the push transaction;
- ``S#<racer_key>#<submission_id>``: one submission, small (``data``, and ``history_racer``/
  ``submitted_at`` for the sparse ``by_racer`` index that gives a racer's history across boards);
- ``D#<submission_id>``: the submission's full record, zlib-compressed in ``record``. It sits
  apart from the submission because ``get_record`` knows the submission id but not the racer, and
  so that history reads stay small; it carries no index attribute, so no index copies it;
- ``F#<fingerprint>``: an evaluation's content on the board, and the racer (``racer_key``) who
  pushed it first: a copy under another racer fails the push transaction;
- ``A#<event_id>``: one audit event (``data``), written once and never changed;
- ``#RANK#<generation>#<node>``: the counts of entries by score, one item per node of the
  layout in ``rank_buckets``, a number attribute ``c:<child>`` per child. The board's
  ``rank_generation`` names the counters in use; every write that adds, replaces or removes an
  entry moves them in its transaction, on condition that the generation is still the board's,
  so they never drift. A rank reads the three items of its path (TransactGetItems: one moment
  of the board), whatever the board's size. A board created before the counters has no
  generation: its ranks are counted from the entries, as they were, until its counters are
  built (``build_rank_counters``: by its next push if it has at most 10,000 racers, else once
  by an operator).

Aliases live in a partition of their own, ``#ALIAS`` (no board id starts with ``#``): ``K#<key>``
holds an alias's claim and ``P#<principal>`` the same claim by its sign-in, written together in
one transaction on condition that neither exists.

A push is one transaction: the submission (and its record) is put if absent; the racer's tally
counts it, on condition that the board's limits allow it; and the entry is put if the racer has
none (the board's ``participants`` + 1 in the same transaction) or if it is strictly better — a
ConditionExpression on the stored entry, so concurrent pushes never lose a best nor pass a limit.
Only this module talks to DynamoDB.
"""

from __future__ import annotations

import random
import secrets
import time
import zlib
from collections.abc import Iterator, Sequence
from datetime import timedelta
from typing import TYPE_CHECKING, Any

import boto3
from botocore.exceptions import ClientError
from drboard_assembler.record import Record

from .. import ranking
from ..errors import BoardNotFound, StoreBusy
from ..models.domain import (
    AliasClaim,
    AuditEvent,
    Board,
    Entry,
    RacerTally,
    Submission,
    SubmissionLimits,
    WriteOutcome,
)
from . import rank_buckets
from .aws_errors import translating
from .base import (
    AliasConflict,
    AuditSlice,
    BoardHasEntries,
    BoardSlice,
    FingerprintTaken,
    HistorySlice,
    LimitReached,
    StoredBoard,
    StoredSubmissionPage,
    SubmissionPage,
    page_token,
    read_page_token,
    stored_record,
)

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.client import DynamoDBClient
    from mypy_boto3_dynamodb.type_defs import (
        AttributeValueTypeDef,
        QueryInputTypeDef,
        TransactGetItemTypeDef,
        TransactWriteItemTypeDef,
    )

    Item = dict[str, AttributeValueTypeDef]

BOARD_SK = "#BOARD"
ALIAS_PARTITION = "#ALIAS"
FIRST_ENTRY = "0"  # every entry's rank key sorts after this, the board's before it
BOARD_KIND = "board"
RANK_INDEX = "by_rank"
RACER_INDEX = "by_racer"
BOARDS_INDEX = "boards"

BATCH_GET_KEYS = 100
TRANSACT_ITEMS = 100
FIRST_GENERATION = "0"  # the rank counters of a board created with them
COUNT_PREFIX = "c:"
BUILD_ATTEMPTS = 3  # of counting a board from before the rank counters, while it changes
READ_ATTEMPTS = 3  # of reading a rank's counters together, while pushes move them
# A push to a board from before the rank counters counts its entries to build them when it has
# at most this many racers (about as many items as one rank used to read); a bigger board needs
# one build_rank_counters call outside a push, which may take longer than a push function may.
LAZY_BUILD_MAX_RACERS = 10_000
MAX_ATTEMPTS = 10  # of a push that loses a race with another push of the same racer or board
BACKOFF_S = 0.01
MAX_BACKOFF_S = 0.5


def entry_sk(racer_key: str) -> str:
    return f"R#{racer_key}"


def submission_sk(racer_key: str, submission_id: str) -> str:
    return f"S#{racer_key}#{submission_id}"


def record_sk(submission_id: str) -> str:
    return f"D#{submission_id}"


def tally_sk(racer_key: str) -> str:
    return f"P#{racer_key}"


def fingerprint_sk(fingerprint: str) -> str:
    return f"F#{fingerprint}"


def audit_sk(event_id: str) -> str:
    return f"A#{event_id}"


def counter_sk(generation: str, node: str) -> str:
    return f"#RANK#{generation}#{node}"


def _s(value: str) -> AttributeValueTypeDef:
    return {"S": value}


def board_item(board: Board) -> Item:
    """A board without rank counters (as boards were before them); what a bulk loader writes
    directly, before ``build_rank_counters``."""
    return {"board": _s(board.board_id), "sk": _s(BOARD_SK), "board_kind": _s(BOARD_KIND),
            "rank_key": _s(BOARD_SK), "data": _s(board.model_dump_json()),
            "participants": {"N": "0"}}


def entry_item(entry: Entry) -> Item:
    """An entry as stored; also what a bulk loader (the benchmark) writes directly."""
    return {"board": _s(entry.board_id), "sk": _s(entry_sk(entry.racer_key)),
            "rank_key": _s(entry.rank_key), "score_key": _s(entry.score_key),
            "data": _s(entry.model_dump_json())}


def counter_item(board_id: str, generation: str, node: str, counts: dict[str, int]) -> Item:
    item: Item = {"board": _s(board_id), "sk": _s(counter_sk(generation, node))}
    item.update({COUNT_PREFIX + child: {"N": str(n)} for child, n in counts.items()})
    return item


def submission_item(submission: Submission) -> Item:
    return {
        "board": _s(submission.board_id),
        "sk": _s(submission_sk(submission.racer_key, submission.submission_id)),
        "history_racer": _s(submission.racer_key),
        "submitted_at": _s(ranking.timestamp(submission.submitted_at)),
        "data": _s(submission.model_dump_json()),
    }


def audit_item(event: AuditEvent) -> Item:
    return {"board": _s(event.board_id), "sk": _s(audit_sk(event.event_id)),
            "data": _s(event.model_dump_json())}


def alias_items(claim: AliasClaim) -> list[Item]:
    data = _s(claim.model_dump_json())
    return [{"board": _s(ALIAS_PARTITION), "sk": _s(f"K#{claim.racer_key}"), "data": data},
            {"board": _s(ALIAS_PARTITION), "sk": _s(f"P#{claim.principal}"), "data": data}]


def record_item(board_id: str, record: Record) -> Item:
    return {"board": _s(board_id), "sk": _s(record_sk(record.submission_id)),
            "record": {"B": zlib.compress(record.model_dump_json().encode())}}


@translating("the board's table")
class DynamoDbStore:
    """The board in DynamoDB. Throttling, and a push that keeps losing races with others on the
    same board, raise StoreBusy; a timeout or a lost connection StoreUnavailable (nothing
    written either way)."""

    def __init__(self, table_name: str, client: DynamoDBClient | None = None) -> None:
        self.table = table_name
        self.client: DynamoDBClient = client if client is not None else boto3.client("dynamodb")
        # A board's rank generation, once set, never changes: it is safe to remember.
        self._generations: dict[str, str] = {}

    # ---- boards ---------------------------------------------------------------------------

    def get_board(self, board_id: str) -> StoredBoard | None:
        item = self._get(board_id, BOARD_SK)
        return _board(item) if item else None

    def create_board(self, board: Board) -> StoredBoard:
        try:
            self.client.put_item(
                TableName=self.table, ConditionExpression="attribute_not_exists(sk)",
                Item=board_item(board) | {"rank_generation": _s(FIRST_GENERATION)})
        except ClientError as error:
            if _code(error) != "ConditionalCheckFailedException":
                raise
        stored = self.get_board(board.board_id)
        assert stored is not None
        return stored

    def update_board(self, board: Board, *, only_if_empty: bool = False) -> StoredBoard:
        condition = "attribute_exists(sk)"
        values: dict[str, AttributeValueTypeDef] = {":data": _s(board.model_dump_json()),
                                                    ":one": {"N": "1"}}
        if only_if_empty:
            condition += " AND participants = :none"
            values[":none"] = {"N": "0"}
        try:
            self.client.update_item(
                TableName=self.table, Key={"board": _s(board.board_id), "sk": _s(BOARD_SK)},
                UpdateExpression="SET #data = :data ADD board_version :one", ConditionExpression=condition,
                ExpressionAttributeNames={"#data": "data"}, ExpressionAttributeValues=values)
        except ClientError as error:
            if _code(error) != "ConditionalCheckFailedException":
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
            "ExpressionAttributeValues": {":kind": _s(BOARD_KIND)},
        })
        return [_board(item) for item in items]

    def boards_page(self, after: str | None, limit: int) -> BoardSlice:
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": BOARDS_INDEX,
            "KeyConditionExpression": "board_kind = :kind",
            "ExpressionAttributeValues": {":kind": _s(BOARD_KIND)},
        }
        if after is not None:
            [board_id] = read_page_token(after, 1)
            request["ExclusiveStartKey"] = {"board_kind": _s(BOARD_KIND), "board": _s(board_id),
                                            "sk": _s(BOARD_SK)}
        items, more = self._page(request, limit)
        return BoardSlice([_board(item) for item in items],
                          page_token([items[-1]["board"]["S"]]) if more else None)

    # ---- submissions ----------------------------------------------------------------------

    def record_submission(self, submission: Submission, record: Record, entry: Entry,
                          limits: SubmissionLimits | None = None,
                          fingerprints: Sequence[str] = (),
                          audit: AuditEvent | None = None) -> WriteOutcome:
        board_id, key = entry.board_id, entry.racer_key
        # Cancellation reasons come back in this order: 0 submission, 1 record, 2 tally,
        # then the fingerprints, the audit event, and last the entry and the board.
        stored: list[TransactWriteItemTypeDef] = [
            {"Put": {"TableName": self.table, "Item": submission_item(submission),
                     "ConditionExpression": "attribute_not_exists(sk)"}},
            {"Put": {"TableName": self.table, "Item": record_item(board_id, record)}},
            {"Update": self._count_submission(submission, limits)},
        ]
        copies = slice(len(stored), len(stored) + len(fingerprints))
        stored.extend({"Put": {
            "TableName": self.table,
            "Item": {"board": _s(board_id), "sk": _s(fingerprint_sk(f)), "racer_key": _s(key)},
            "ConditionExpression": "attribute_not_exists(sk) OR racer_key = :me",
            "ExpressionAttributeValues": {":me": _s(key)}}} for f in fingerprints)
        if audit is not None:
            stored.append({"Put": {"TableName": self.table, "Item": audit_item(audit)}})
        board_at = len(stored) + 1
        exists, generation = self._board_generation(board_id)
        if exists and generation is None:
            generation = self.build_rank_counters(board_id, max_racers=LAZY_BUILD_MAX_RACERS)
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                _backoff(attempt)
            current = self.get_entry(board_id, key)
            items = list(stored)
            improves = current is None or entry.rank_key < current.rank_key
            if current is None:
                items.append({"Put": {"TableName": self.table, "Item": entry_item(entry),
                                      "ConditionExpression": "attribute_not_exists(sk)"}})
                items.append(self._board_change(board_id, +1, generation))
            elif improves:
                # Exactly the entry read: the counters take its score off.
                items.append({"Put": {"TableName": self.table, "Item": entry_item(entry),
                                      "ConditionExpression": "rank_key = :seen",
                                      "ExpressionAttributeValues": {":seen": _s(current.rank_key)}}})
                items.append(self._board_change(board_id, 0, generation))
            # else: not better. The entry stays as it is (entries only ever improve).
            if improves:
                items += self._count_changes(board_id, generation, entry.score_key,
                                             current.score_key if current else None)
            try:
                self.client.transact_write_items(TransactItems=items)
            except ClientError as error:
                if _code(error) != "TransactionCanceledException":
                    raise
                reasons = _cancellation_codes(error)
                if reasons[:1] == ["ConditionalCheckFailed"]:
                    return self._duplicate(board_id, key, entry)
                if reasons[2:3] == ["ConditionalCheckFailed"]:
                    raise LimitReached(self.tally(board_id, key)) from None
                if "ConditionalCheckFailed" in reasons[copies]:
                    raise FingerprintTaken(self._copied_from(board_id, fingerprints)) from None
                if reasons[board_at:board_at + 1] == ["ConditionalCheckFailed"]:
                    # No board, or its rank counters were built meanwhile.
                    exists, generation = self._board_generation(board_id)
                    if not exists:
                        raise BoardNotFound(f"no board {board_id!r}") from None
                    continue
                if not set(reasons) & {"ConditionalCheckFailed", "TransactionConflict"}:
                    raise
                continue  # another push changed the entry or the board meanwhile: look again
            if limits is None:
                self._advance_last_submitted(submission)
            if improves or current is None:
                return WriteOutcome(duplicate=False, improved=True, entry=entry)
            return WriteOutcome(duplicate=False, improved=False, entry=current)
        raise StoreBusy(f"{board_id!r} is busy with other pushes: gave up after {MAX_ATTEMPTS} "
                        "attempts, nothing was stored; try again in a moment")

    def _count_submission(self, submission: Submission,
                          limits: SubmissionLimits | None) -> Any:
        """The tally's update, conditioned on the limits: the racer's last submission is old
        enough and they have made fewer than the maximum (a first submission always passes)."""
        update: dict[str, Any] = {
            "TableName": self.table,
            "Key": {"board": _s(submission.board_id), "sk": _s(tally_sk(submission.racer_key))},
            "UpdateExpression": "SET submissions = if_not_exists(submissions, :zero) + :one",
            "ExpressionAttributeValues": {":zero": {"N": "0"}, ":one": {"N": "1"}},
        }
        if limits is None:  # an import: the last time is moved forward after the transaction
            return update
        values = update["ExpressionAttributeValues"]
        update["UpdateExpression"] += ", last_at = :at"
        values[":at"] = _s(ranking.timestamp(submission.submitted_at))
        checks = []
        if limits.max_submissions is not None:
            checks.append("submissions < :max")
            values[":max"] = {"N": str(limits.max_submissions)}
        if limits.cooldown_s:
            checks.append("(attribute_not_exists(last_at) OR last_at <= :cutoff)")
            cutoff = limits.now - timedelta(seconds=limits.cooldown_s)
            values[":cutoff"] = _s(ranking.timestamp(cutoff))
        if checks:
            allowed = checks[0] if len(checks) == 1 else "(" + " AND ".join(checks) + ")"
            update["ConditionExpression"] = f"attribute_not_exists(sk) OR {allowed}"
        return update

    def _advance_last_submitted(self, submission: Submission) -> None:
        at = ranking.timestamp(submission.submitted_at)
        try:
            self.client.update_item(
                TableName=self.table,
                Key={"board": _s(submission.board_id), "sk": _s(tally_sk(submission.racer_key))},
                UpdateExpression="SET last_at = :at",
                ConditionExpression="attribute_not_exists(last_at) OR last_at < :at",
                ExpressionAttributeValues={":at": _s(at)})
        except ClientError as error:
            if _code(error) != "ConditionalCheckFailedException":
                raise

    def _duplicate(self, board_id: str, racer_key: str, entry: Entry) -> WriteOutcome:
        current = self.get_entry(board_id, racer_key)
        return WriteOutcome(duplicate=True, improved=False, entry=current or entry)

    def _copied_from(self, board_id: str, fingerprints: Sequence[str]) -> str:
        holders = [item["racer_key"]["S"] for f in fingerprints
                   if (item := self._get(board_id, fingerprint_sk(f)))]
        return holders[0] if holders else "another racer"

    # ---- moderation and audit -------------------------------------------------------------

    def remove_entry(self, board_id: str, racer_key: str) -> Entry | None:
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                _backoff(attempt)
            current = self.get_entry(board_id, racer_key)
            if current is None:
                return None
            _, generation = self._board_generation(board_id)
            try:
                self.client.transact_write_items(TransactItems=[
                    {"Delete": {"TableName": self.table,
                                "Key": {"board": _s(board_id), "sk": _s(entry_sk(racer_key))},
                                "ConditionExpression": "rank_key = :seen",
                                "ExpressionAttributeValues": {":seen": _s(current.rank_key)}}},
                    self._board_change(board_id, -1, generation),
                    *self._count_changes(board_id, generation, None, current.score_key)])
            except ClientError as error:
                if _code(error) != "TransactionCanceledException":
                    raise
                continue  # the entry improved, or the counters were built, meanwhile: look again
            return current
        raise StoreBusy(f"{board_id!r} is busy with other pushes: gave up removing the entry; "
                        "try again in a moment")

    def restore_entry(self, entry: Entry) -> None:
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                _backoff(attempt)
            exists, generation = self._board_generation(entry.board_id)
            if not exists:
                return
            try:
                self.client.transact_write_items(TransactItems=[
                    {"Put": {"TableName": self.table, "Item": entry_item(entry),
                             "ConditionExpression": "attribute_not_exists(sk)"}},
                    self._board_change(entry.board_id, +1, generation),
                    *self._count_changes(entry.board_id, generation, entry.score_key, None)])
            except ClientError as error:
                if _code(error) != "TransactionCanceledException":
                    raise
                if _cancellation_codes(error)[:1] == ["ConditionalCheckFailed"]:
                    return  # the racer has an entry again, from a push meanwhile
                continue  # the counters were built meanwhile, or another write was under way
            return
        raise StoreBusy(f"{entry.board_id!r} is busy with other pushes: gave up restoring the entry; "
                        "try again in a moment")

    def _board_change(self, board_id: str, change: int,
                      generation: str | None) -> TransactWriteItemTypeDef:
        """The board's number of racers changed by ``change``, and its version bumped, on
        condition that its rank counters are still those of ``generation`` (None: none)."""
        values: dict[str, AttributeValueTypeDef] = {":change": {"N": str(change)}, ":one": {"N": "1"}}
        if generation is None:
            condition = "attribute_exists(sk) AND attribute_not_exists(rank_generation)"
        else:
            condition = "rank_generation = :generation"
            values[":generation"] = _s(generation)
        return {"Update": {
            "TableName": self.table, "Key": {"board": _s(board_id), "sk": _s(BOARD_SK)},
            "UpdateExpression": "SET participants = participants + :change ADD board_version :one",
            "ConditionExpression": condition, "ExpressionAttributeValues": values}}

    # ---- rank counters --------------------------------------------------------------------

    def _count_changes(self, board_id: str, generation: str | None, added: str | None,
                       removed: str | None) -> list[TransactWriteItemTypeDef]:
        """The counter updates for an entry of score key ``removed`` replaced by ``added``."""
        if generation is None:
            return []
        updates: list[TransactWriteItemTypeDef] = []
        for node, children in rank_buckets.changes(added, removed).items():
            names = {f"#c{i}": COUNT_PREFIX + child for i, child in enumerate(children)}
            values: dict[str, AttributeValueTypeDef] = {
                f":c{i}": {"N": str(n)} for i, n in enumerate(children.values())}
            updates.append({"Update": {
                "TableName": self.table,
                "Key": {"board": _s(board_id), "sk": _s(counter_sk(generation, node))},
                "UpdateExpression": "ADD " + ", ".join(f"#c{i} :c{i}" for i in range(len(children))),
                "ExpressionAttributeNames": names, "ExpressionAttributeValues": values}})
        return updates

    def _board_generation(self, board_id: str) -> tuple[bool, str | None]:
        """Whether the board exists, and the generation of its rank counters (None: none)."""
        if board_id in self._generations:
            return True, self._generations[board_id]
        item = self.client.get_item(
            TableName=self.table, ConsistentRead=True, ProjectionExpression="sk, rank_generation",
            Key={"board": _s(board_id), "sk": _s(BOARD_SK)}).get("Item")
        if item is None:
            return False, None
        if "rank_generation" not in item:
            return True, None
        self._generations[board_id] = item["rank_generation"]["S"]
        return True, self._generations[board_id]

    def build_rank_counters(self, board_id: str, max_racers: int | None = None) -> str | None:
        """Give a board from before the rank counters its counters, counted from its entries
        (once: this reads every entry), and return their generation; None when the board does
        not exist, has more than ``max_racers`` racers, or kept changing while it was counted
        (its ranks are then still counted from the entries, and the next push tries again).
        Safe alongside pushes: the counters are written under a new generation, which becomes
        the board's only if no entry changed (the board's version did not move) since the
        entries were read."""
        for _ in range(BUILD_ATTEMPTS):
            item = self._get(board_id, BOARD_SK)
            if item is None:
                return None
            if "rank_generation" in item:
                self._generations[board_id] = item["rank_generation"]["S"]
                return self._generations[board_id]
            if max_racers is not None and int(item["participants"]["N"]) > max_racers:
                return None
            version = item.get("board_version", {"N": "0"})["N"]
            score_keys = [entry["score_key"]["S"] for entry in self._query({
                "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
                "KeyConditionExpression": "board = :board AND rank_key > :first",
                "ExpressionAttributeValues": {":board": _s(board_id), ":first": _s(FIRST_ENTRY)},
                "ProjectionExpression": "score_key"})]
            generation = secrets.token_hex(6)
            counters = [{"Put": {"TableName": self.table,
                                 "Item": counter_item(board_id, generation, node, counts)}}
                        for node, counts in rank_buckets.tally(score_keys).items()]
            for start in range(0, len(counters), TRANSACT_ITEMS):
                self.client.transact_write_items(
                    TransactItems=counters[start:start + TRANSACT_ITEMS])  # type: ignore[arg-type]
            try:
                self.client.update_item(
                    TableName=self.table, Key={"board": _s(board_id), "sk": _s(BOARD_SK)},
                    UpdateExpression="SET rank_generation = :generation",
                    ConditionExpression="attribute_not_exists(rank_generation) AND "
                                        "(attribute_not_exists(board_version) OR board_version = :seen)",
                    ExpressionAttributeValues={":generation": _s(generation), ":seen": {"N": version}})
            except ClientError as error:
                if _code(error) != "ConditionalCheckFailedException":
                    raise
                continue  # an entry changed meanwhile, or another build won: look again
            self._generations[board_id] = generation
            return generation
        return None

    def _read_counters(self, board_id: str, generation: str,
                       nodes: list[str]) -> dict[str, dict[str, int]]:
        """The counts of ``nodes``, read together as of one moment; should pushes keep moving
        them, read one by one (each exact, together off by what changed in between)."""
        keys = [{"board": _s(board_id), "sk": _s(counter_sk(generation, node))} for node in nodes]
        request: list[TransactGetItemTypeDef] = [{"Get": {"TableName": self.table, "Key": key}}
                                                 for key in keys]
        for attempt in range(READ_ATTEMPTS):
            if attempt:
                _backoff(attempt)
            try:
                answers = self.client.transact_get_items(TransactItems=request)["Responses"]
            except ClientError as error:
                if _code(error) != "TransactionCanceledException":
                    raise
                continue  # a push was moving these counters
            return {node: _counts(answer.get("Item")) for node, answer in zip(nodes, answers, strict=True)}
        return {node: _counts(self._get(board_id, key["sk"]["S"]))
                for node, key in zip(nodes, keys, strict=True)}

    def append_audit(self, event: AuditEvent) -> None:
        self.client.put_item(TableName=self.table, Item=audit_item(event),
                             ConditionExpression="attribute_not_exists(sk)")

    def audit(self, board_id: str, after: str | None, limit: int) -> AuditSlice:
        request: QueryInputTypeDef = {
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":board": _s(board_id), ":prefix": _s(audit_sk(""))},
            "ProjectionExpression": "#data", "ExpressionAttributeNames": {"#data": "data"},
        }
        if after is not None:
            request["ExclusiveStartKey"] = {"board": _s(board_id), "sk": _s(audit_sk(after))}
        events = [AuditEvent.model_validate_json(item["data"]["S"])
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
            if _code(error) != "TransactionCanceledException":
                raise
            for holder in (self.alias_holder(claim.racer_key), self.alias_of(claim.principal)):
                if holder is None:
                    continue
                if (holder.racer_key, holder.principal) == (claim.racer_key, claim.principal):
                    return holder
                raise AliasConflict(holder) from None
            raise  # pragma: no cover - cancelled, yet neither item exists
        return claim

    def alias_of(self, principal: str) -> AliasClaim | None:
        item = self._get(ALIAS_PARTITION, f"P#{principal}")
        return AliasClaim.model_validate_json(item["data"]["S"]) if item else None

    def alias_holder(self, racer_key: str) -> AliasClaim | None:
        item = self._get(ALIAS_PARTITION, f"K#{racer_key}")
        return AliasClaim.model_validate_json(item["data"]["S"]) if item else None

    # ---- reads ----------------------------------------------------------------------------

    def get_submission(self, board_id: str, racer_key: str, submission_id: str) -> Submission | None:
        item = self._get(board_id, submission_sk(racer_key, submission_id))
        return Submission.model_validate_json(item["data"]["S"]) if item else None

    def tally(self, board_id: str, racer_key: str) -> RacerTally:
        item = self._get(board_id, tally_sk(racer_key))
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
            "ExpressionAttributeValues": {":board": _s(board_id), ":prefix": _s("S#")},
            "ProjectionExpression": "sk, #data", "ExpressionAttributeNames": {"#data": "data"},
        }
        if after is not None:
            request["ExclusiveStartKey"] = {"board": _s(board_id), "sk": _s(after)}
        page = self.client.query(**request)
        submissions = [Submission.model_validate_json(item["data"]["S"]) for item in page["Items"]]
        records = self._records(board_id, [s.submission_id for s in submissions])
        pairs: list[tuple[Submission, str | bytes]] = [
            (s, records[s.submission_id]) for s in submissions if s.submission_id in records]
        more = page.get("LastEvaluatedKey") and page["Items"]
        return StoredSubmissionPage(pairs, page["Items"][-1]["sk"]["S"] if more else None)

    def _records(self, board_id: str, submission_ids: list[str]) -> dict[str, bytes]:
        """The records' JSON, as stored, by submission id."""
        records: dict[str, bytes] = {}
        keys = [{"board": _s(board_id), "sk": _s(record_sk(i))} for i in dict.fromkeys(submission_ids)]
        for start in range(0, len(keys), BATCH_GET_KEYS):
            pending: Any = {self.table: {"Keys": keys[start:start + BATCH_GET_KEYS],
                                         "ConsistentRead": True}}
            attempt = 0
            while pending:
                if attempt:
                    _backoff(attempt)
                answer = self.client.batch_get_item(RequestItems=pending)
                for item in answer["Responses"].get(self.table, []):
                    submission_id = item["sk"]["S"].removeprefix(record_sk(""))
                    records[submission_id] = zlib.decompress(item["record"]["B"])
                pending = answer.get("UnprocessedKeys") or None
                attempt += 1
        return records

    def front_page(self, board_id: str, limit: int) -> tuple[StoredBoard | None, list[Entry]]:
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board",
            "ExpressionAttributeValues": {":board": _s(board_id)},
            "ProjectionExpression": "sk, #data, participants, board_version",
            "ExpressionAttributeNames": {"#data": "data"},
        }
        items = self._query(request, limit=limit + 1)
        if not items or items[0]["sk"]["S"] != BOARD_SK:
            return None, []
        return _board(items[0]), [Entry.model_validate_json(i["data"]["S"]) for i in items[1:]]

    def top(self, board_id: str, limit: int, after: str | None = None) -> list[Entry]:
        condition = "board = :board AND rank_key > :after"
        values: dict[str, AttributeValueTypeDef] = {
            ":board": _s(board_id), ":after": _s(FIRST_ENTRY if after is None else after)}
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "KeyConditionExpression": condition, "ExpressionAttributeValues": values,
            "ProjectionExpression": "#data", "ExpressionAttributeNames": {"#data": "data"},
        }
        return [Entry.model_validate_json(item["data"]["S"])
                for item in self._query(request, limit=limit)]

    def get_entry(self, board_id: str, racer_key: str) -> Entry | None:
        item = self._get(board_id, entry_sk(racer_key))
        return Entry.model_validate_json(item["data"]["S"]) if item else None

    def count_better(self, board_id: str, score_key: str) -> int:
        _, generation = self._board_generation(board_id)
        if generation is None:  # no board, or one whose counters are not built yet
            return self._count_entries(board_id, FIRST_ENTRY, score_key)
        nodes = [node for node, _ in rank_buckets.path(score_key)]
        counts = self._read_counters(board_id, generation, nodes)
        better = rank_buckets.count_lower(score_key, counts.__getitem__)
        if rank_buckets.in_overflow(score_key):
            better += self._count_entries(board_id, rank_buckets.OVERFLOW_START, score_key)
        return better

    def _count_entries(self, board_id: str, first: str, score_key: str) -> int:
        """How many entries have a rank key from ``first`` up to ``score_key``: score keys are
        fixed-width prefixes of rank keys, so these are the entries with a score key from
        ``first``'s and lower than ``score_key``. Reads every one of them."""
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "Select": "COUNT",
            "KeyConditionExpression": "board = :board AND rank_key BETWEEN :first AND :key",
            "ExpressionAttributeValues": {":board": _s(board_id), ":first": _s(first),
                                          ":key": _s(score_key)},
        }
        return sum(page["Count"] for page in self._pages(request))

    def history(self, racer_key: str, board_id: str | None = None) -> list[Submission]:
        names = {"#data": "data"}
        if board_id is None:
            request: QueryInputTypeDef = {
                "TableName": self.table, "IndexName": RACER_INDEX,
                "KeyConditionExpression": "history_racer = :racer",
                "ExpressionAttributeValues": {":racer": _s(racer_key)},
                "ProjectionExpression": "#data", "ExpressionAttributeNames": names,
            }
        else:
            request = {
                "TableName": self.table, "ConsistentRead": True,
                "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
                "ExpressionAttributeValues": {":board": _s(board_id),
                                              ":prefix": _s(submission_sk(racer_key, ""))},
                "ProjectionExpression": "#data", "ExpressionAttributeNames": names,
            }
        submissions = [Submission.model_validate_json(item["data"]["S"])
                       for item in self._query(request)]
        # A racer key may itself contain "#": keep only this racer's own submissions.
        mine = [s for s in submissions if s.racer_key == racer_key]
        return sorted(mine, key=lambda s: (s.submitted_at, s.board_id, s.submission_id))

    def history_page(self, racer_key: str, board_id: str | None, after: str | None,
                     limit: int) -> HistorySlice:
        # The racer index holds every submission by time, on every board; one board's are
        # filtered from it, so the page stays in time order.
        values: dict[str, AttributeValueTypeDef] = {":racer": _s(racer_key)}
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RACER_INDEX,
            "KeyConditionExpression": "history_racer = :racer",
            "ExpressionAttributeValues": values,
            "ProjectionExpression": "board, sk, submitted_at, #data",
            "ExpressionAttributeNames": {"#data": "data"},
        }
        if board_id is not None:
            request["FilterExpression"] = "board = :board"
            values[":board"] = _s(board_id)
        if after is not None:
            submitted_at, board, sk = read_page_token(after, 3)
            request["ExclusiveStartKey"] = {"history_racer": _s(racer_key),
                                            "submitted_at": _s(submitted_at),
                                            "board": _s(board), "sk": _s(sk)}
        items, more = self._page(request, limit)
        last = items[-1] if items else None
        token = page_token([last["submitted_at"]["S"], last["board"]["S"], last["sk"]["S"]]) \
            if more and last else None
        return HistorySlice([Submission.model_validate_json(item["data"]["S"]) for item in items],
                            token)

    def get_record(self, board_id: str, submission_id: str) -> Record | None:
        item = self._get(board_id, record_sk(submission_id))
        return Record.model_validate_json(zlib.decompress(item["record"]["B"])) if item else None

    # ---- plumbing -------------------------------------------------------------------------

    def _get(self, board_id: str, sk: str) -> Item | None:
        response = self.client.get_item(TableName=self.table, ConsistentRead=True,
                                        Key={"board": _s(board_id), "sk": _s(sk)})
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


def _board(item: Item) -> StoredBoard:
    return StoredBoard(Board.model_validate_json(item["data"]["S"]), int(item["participants"]["N"]),
                       int(item.get("board_version", {"N": "0"})["N"]))


def _counts(item: Item | None) -> dict[str, int]:
    """A counter item's counts by child; no item, no entries."""
    return {name[len(COUNT_PREFIX):]: int(value["N"]) for name, value in (item or {}).items()
            if name.startswith(COUNT_PREFIX) and "N" in value}


def _code(error: ClientError) -> str:
    return str(error.response.get("Error", {}).get("Code", ""))


def _cancellation_codes(error: ClientError) -> list[str]:
    reasons: list[dict[str, Any]] = error.response.get("CancellationReasons", [])  # type: ignore[assignment]
    return [str(reason.get("Code", "None")) for reason in reasons]


def _backoff(attempt: int) -> None:
    time.sleep(random.uniform(0, min(MAX_BACKOFF_S, BACKOFF_S * 2 ** attempt)))
