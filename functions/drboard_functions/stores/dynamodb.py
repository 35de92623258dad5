"""The cloud board: one DynamoDB table (its one definition is ``BoardTable`` in template.yaml).

Items of a board share its partition (``board``); the sort key ``sk`` tells them apart:

- ``#BOARD``: the board (its JSON in ``data``, ``participants``, and ``board_kind="board"`` for
  the sparse ``boards`` index that lists boards);
- ``R#<racer_key>``: a racer's entry, their best (``data``, ``score_key``, and ``rank_key`` for
  the sparse local index ``by_rank``: the top N is one Query reading N items);
- ``S#<racer_key>#<submission_id>``: one submission, small (``data``, and ``history_racer``/
  ``submitted_at`` for the sparse ``by_racer`` index that gives a racer's history across boards);
- ``D#<submission_id>``: the submission's full record, zlib-compressed in ``record``. It sits
  apart from the submission because ``get_record`` knows the submission id but not the racer, and
  so that history reads stay small; it carries no index attribute, so no index copies it.

A push is one transaction: the submission (and its record) is put if absent, and the entry put if
the racer has none (the board's ``participants`` + 1 in the same transaction) or if it is strictly
better — a ConditionExpression on the stored entry, so concurrent pushes never lose a best. Only
this module talks to DynamoDB.
"""

from __future__ import annotations

import random
import time
import zlib
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import boto3
from botocore.exceptions import ClientError
from drboard_assembler.record import Record

from .. import ranking
from ..errors import BoardNotFound
from ..models import Board, Entry, Submission, WriteOutcome
from .base import StoredBoard

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.client import DynamoDBClient
    from mypy_boto3_dynamodb.type_defs import (
        AttributeValueTypeDef,
        QueryInputTypeDef,
        TransactWriteItemTypeDef,
    )

    Item = dict[str, AttributeValueTypeDef]

BOARD_SK = "#BOARD"
BOARD_KIND = "board"
RANK_INDEX = "by_rank"
RACER_INDEX = "by_racer"
BOARDS_INDEX = "boards"

MAX_ATTEMPTS = 10  # of a push that loses a race with another push of the same racer or board
BACKOFF_S = 0.01
MAX_BACKOFF_S = 0.5


class StoreContention(RuntimeError):
    """A push kept losing races with concurrent pushes; nothing was written. Retry later."""


def entry_sk(racer_key: str) -> str:
    return f"R#{racer_key}"


def submission_sk(racer_key: str, submission_id: str) -> str:
    return f"S#{racer_key}#{submission_id}"


def record_sk(submission_id: str) -> str:
    return f"D#{submission_id}"


def _s(value: str) -> AttributeValueTypeDef:
    return {"S": value}


def board_item(board: Board) -> Item:
    return {"board": _s(board.board_id), "sk": _s(BOARD_SK), "board_kind": _s(BOARD_KIND),
            "data": _s(board.model_dump_json()), "participants": {"N": "0"}}


def entry_item(entry: Entry) -> Item:
    """An entry as stored; also what a bulk loader (the benchmark) writes directly."""
    return {"board": _s(entry.board_id), "sk": _s(entry_sk(entry.racer_key)),
            "rank_key": _s(entry.rank_key), "score_key": _s(entry.score_key),
            "data": _s(entry.model_dump_json())}


def submission_item(submission: Submission) -> Item:
    return {
        "board": _s(submission.board_id),
        "sk": _s(submission_sk(submission.racer_key, submission.submission_id)),
        "history_racer": _s(submission.racer_key),
        "submitted_at": _s(ranking.timestamp(submission.submitted_at)),
        "data": _s(submission.model_dump_json()),
    }


def record_item(board_id: str, record: Record) -> Item:
    return {"board": _s(board_id), "sk": _s(record_sk(record.submission_id)),
            "record": {"B": zlib.compress(record.model_dump_json().encode())}}


class DynamoDbStore:
    def __init__(self, table_name: str, client: DynamoDBClient | None = None) -> None:
        self.table = table_name
        self.client: DynamoDBClient = client if client is not None else boto3.client("dynamodb")

    # ---- boards ---------------------------------------------------------------------------

    def get_board(self, board_id: str) -> StoredBoard | None:
        item = self._get(board_id, BOARD_SK)
        return _board(item) if item else None

    def create_board(self, board: Board) -> StoredBoard:
        try:
            self.client.put_item(TableName=self.table, Item=board_item(board),
                                 ConditionExpression="attribute_not_exists(sk)")
        except ClientError as error:
            if _code(error) != "ConditionalCheckFailedException":
                raise
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

    # ---- submissions ----------------------------------------------------------------------

    def record_submission(self, submission: Submission, record: Record,
                          entry: Entry) -> WriteOutcome:
        board_id, key = entry.board_id, entry.racer_key
        # Cancellation reasons come back in this order: 0 submission, 1 record, 2 entry, 3 board.
        stored: list[TransactWriteItemTypeDef] = [
            {"Put": {"TableName": self.table, "Item": submission_item(submission),
                     "ConditionExpression": "attribute_not_exists(sk)"}},
            {"Put": {"TableName": self.table, "Item": record_item(board_id, record)}},
        ]
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                _backoff(attempt)
            current = self.get_entry(board_id, key)
            items = list(stored)
            improves = current is None or entry.score_key < current.score_key
            if current is None:
                items.append({"Put": {"TableName": self.table, "Item": entry_item(entry),
                                      "ConditionExpression": "attribute_not_exists(sk)"}})
                items.append({"Update": {
                    "TableName": self.table,
                    "Key": {"board": _s(board_id), "sk": _s(BOARD_SK)},
                    "UpdateExpression": "SET participants = participants + :one",
                    "ConditionExpression": "attribute_exists(sk)",
                    "ExpressionAttributeValues": {":one": {"N": "1"}},
                }})
            elif improves:
                items.append({"Put": {"TableName": self.table, "Item": entry_item(entry),
                                      "ConditionExpression": "score_key > :new",
                                      "ExpressionAttributeValues": {":new": _s(entry.score_key)}}})
            # else: not better. The entry stays as it is (entries only ever improve).
            try:
                self.client.transact_write_items(TransactItems=items)
            except ClientError as error:
                if _code(error) != "TransactionCanceledException":
                    raise
                reasons = _cancellation_codes(error)
                if reasons[:1] == ["ConditionalCheckFailed"]:
                    return self._duplicate(board_id, key)
                if reasons[3:4] == ["ConditionalCheckFailed"]:
                    raise BoardNotFound(f"no board {board_id!r}") from None
                if not set(reasons) & {"ConditionalCheckFailed", "TransactionConflict"}:
                    raise
                continue  # another push changed the entry or the board meanwhile: look again
            if improves or current is None:
                return WriteOutcome(duplicate=False, improved=True, entry=entry)
            return WriteOutcome(duplicate=False, improved=False, entry=current)
        raise StoreContention(f"gave up pushing to {board_id!r} after {MAX_ATTEMPTS} attempts")

    def _duplicate(self, board_id: str, racer_key: str) -> WriteOutcome:
        current = self.get_entry(board_id, racer_key)
        assert current is not None, "a stored submission always has an entry"
        return WriteOutcome(duplicate=True, improved=False, entry=current)

    # ---- reads ----------------------------------------------------------------------------

    def top(self, board_id: str, limit: int, after: str | None = None) -> list[Entry]:
        condition = "board = :board"
        values: dict[str, AttributeValueTypeDef] = {":board": _s(board_id)}
        if after is not None:
            condition += " AND rank_key > :after"
            values[":after"] = _s(after)
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
        # Score keys are fixed-width prefixes of rank keys, so "rank_key < score_key" selects
        # exactly the entries with a lower score key.
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "Select": "COUNT", "KeyConditionExpression": "board = :board AND rank_key < :key",
            "ExpressionAttributeValues": {":board": _s(board_id), ":key": _s(score_key)},
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

    def _query(self, request: QueryInputTypeDef, limit: int | None = None) -> list[Item]:
        return [item for page in self._pages(request, limit) for item in page["Items"]]


def _board(item: Item) -> StoredBoard:
    return StoredBoard(Board.model_validate_json(item["data"]["S"]), int(item["participants"]["N"]))


def _code(error: ClientError) -> str:
    return str(error.response.get("Error", {}).get("Code", ""))


def _cancellation_codes(error: ClientError) -> list[str]:
    reasons: list[dict[str, Any]] = error.response.get("CancellationReasons", [])  # type: ignore[assignment]
    return [str(reason.get("Code", "None")) for reason in reasons]


def _backoff(attempt: int) -> None:
    time.sleep(random.uniform(0, min(MAX_BACKOFF_S, BACKOFF_S * 2 ** attempt)))
