"""A board's rank counters on DynamoDB: ranks without reading the board.

``#RANK#<generation>#<node>`` items hold the counts of entries by score, one item per node of
the layout in ``rank_buckets``, a number attribute ``c:<child>`` per child. The board's
``rank_generation`` names the counters in use; every write that adds, replaces or removes an
entry moves them in its transaction, on condition that the generation is still the board's,
so they never drift. A rank reads the three items of its path (TransactGetItems: one moment
of the board), whatever the board's size. A board created before the counters has no
generation: its ranks are counted from the entries, as they were, until its counters are
built (``build``: by its next push if it has at most 10,000 racers, else once by an operator).
"""

from __future__ import annotations

import secrets
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from botocore.exceptions import ClientError

from .. import rank_buckets
from ..aws_errors import code_of
from .codecs import (
    BOARD_SK,
    COUNT_PREFIX,
    FIRST_ENTRY,
    RANK_INDEX,
    counter_item,
    counter_sk,
    counts,
    key,
    text,
)
from .retries import backoff

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.client import DynamoDBClient
    from mypy_boto3_dynamodb.type_defs import (
        AttributeValueTypeDef,
        QueryInputTypeDef,
        TransactGetItemTypeDef,
        TransactWriteItemTypeDef,
    )

FIRST_GENERATION = "0"  # the rank counters of a board created with them
TRANSACT_ITEMS = 100
BUILD_ATTEMPTS = 3  # of counting a board from before the rank counters, while it changes
READ_ATTEMPTS = 3  # of reading a rank's counters together, while pushes move them
# A push to a board from before the rank counters counts its entries to build them when it has
# at most this many racers (about as many items as one rank used to read); a bigger board needs
# one build outside a push, which may take longer than a push function may.
LAZY_BUILD_MAX_RACERS = 10_000


class RankCounters:
    def __init__(self, client: DynamoDBClient, table: str) -> None:
        self.client = client
        self.table = table
        # A board's rank generation, once set, never changes: it is safe to remember.
        self._generations: dict[str, str] = {}

    def generation(self, board_id: str) -> tuple[bool, str | None]:
        """Whether the board exists, and the generation of its rank counters (None: none)."""
        if board_id in self._generations:
            return True, self._generations[board_id]
        item = self.client.get_item(
            TableName=self.table, ConsistentRead=True, ProjectionExpression="sk, rank_generation",
            Key=key(board_id, BOARD_SK)).get("Item")
        if item is None:
            return False, None
        if "rank_generation" not in item:
            return True, None
        self._generations[board_id] = item["rank_generation"]["S"]
        return True, self._generations[board_id]

    def count_better(self, board_id: str, score_key: str) -> int:
        """How many entries of the board score better than ``score_key``."""
        _, generation = self.generation(board_id)
        if generation is None:  # no board, or one whose counters are not built yet
            return self._count_entries(board_id, FIRST_ENTRY, score_key)
        nodes = [node for node, _ in rank_buckets.path(score_key)]
        read = self._read(board_id, generation, nodes)
        better = rank_buckets.count_lower(score_key, read.__getitem__)
        if rank_buckets.in_overflow(score_key):
            better += self._count_entries(board_id, rank_buckets.OVERFLOW_START, score_key)
        return better

    def changes(self, board_id: str, generation: str | None, added: str | None,
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
                "TableName": self.table, "Key": key(board_id, counter_sk(generation, node)),
                "UpdateExpression": "ADD " + ", ".join(f"#c{i} :c{i}" for i in range(len(children))),
                "ExpressionAttributeNames": names, "ExpressionAttributeValues": values}})
        return updates

    def build(self, board_id: str, max_racers: int | None = None) -> str | None:
        """Give a board from before the rank counters its counters, counted from its entries
        (once: this reads every entry), and return their generation; None when the board does
        not exist, has more than ``max_racers`` racers, or kept changing while it was counted
        (its ranks are then still counted from the entries, and the next push tries again).
        Safe alongside pushes: the counters are written under a new generation, which becomes
        the board's only if no entry changed (the board's version did not move) since the
        entries were read."""
        for _ in range(BUILD_ATTEMPTS):
            item = self.client.get_item(TableName=self.table, ConsistentRead=True,
                                        Key=key(board_id, BOARD_SK)).get("Item")
            if item is None:
                return None
            if "rank_generation" in item:
                self._generations[board_id] = item["rank_generation"]["S"]
                return self._generations[board_id]
            if max_racers is not None and int(item["participants"]["N"]) > max_racers:
                return None
            version = item.get("board_version", {"N": "0"})["N"]
            score_keys = [entry["score_key"]["S"] for page in self._pages({
                "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
                "KeyConditionExpression": "board = :board AND rank_key > :first",
                "ExpressionAttributeValues": {":board": text(board_id), ":first": text(FIRST_ENTRY)},
                "ProjectionExpression": "score_key"}) for entry in page["Items"]]
            generation = secrets.token_hex(6)
            counters = [{"Put": {"TableName": self.table,
                                 "Item": counter_item(board_id, generation, node, tallied)}}
                        for node, tallied in rank_buckets.tally(score_keys).items()]
            for start in range(0, len(counters), TRANSACT_ITEMS):
                self.client.transact_write_items(
                    TransactItems=counters[start:start + TRANSACT_ITEMS])  # type: ignore[arg-type]
            try:
                self.client.update_item(
                    TableName=self.table, Key=key(board_id, BOARD_SK),
                    UpdateExpression="SET rank_generation = :generation",
                    ConditionExpression="attribute_not_exists(rank_generation) AND "
                                        "(attribute_not_exists(board_version) OR board_version = :seen)",
                    ExpressionAttributeValues={":generation": text(generation), ":seen": {"N": version}})
            except ClientError as error:
                if code_of(error) != "ConditionalCheckFailedException":
                    raise
                continue  # an entry changed meanwhile, or another build won: look again
            self._generations[board_id] = generation
            return generation
        return None

    def _read(self, board_id: str, generation: str, nodes: list[str]) -> dict[str, dict[str, int]]:
        """The counts of ``nodes``, read together as of one moment; should pushes keep moving
        them, read one by one (each exact, together off by what changed in between)."""
        keys = [key(board_id, counter_sk(generation, node)) for node in nodes]
        request: list[TransactGetItemTypeDef] = [{"Get": {"TableName": self.table, "Key": k}}
                                                 for k in keys]
        for attempt in range(READ_ATTEMPTS):
            if attempt:
                backoff(attempt)
            try:
                answers = self.client.transact_get_items(TransactItems=request)["Responses"]
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                continue  # a push was moving these counters
            return {node: counts(answer.get("Item")) for node, answer in zip(nodes, answers, strict=True)}
        return {node: counts(self.client.get_item(TableName=self.table, ConsistentRead=True,
                                                  Key=k).get("Item"))
                for node, k in zip(nodes, keys, strict=True)}

    def _count_entries(self, board_id: str, first: str, score_key: str) -> int:
        """How many entries have a rank key from ``first`` up to ``score_key``: score keys are
        fixed-width prefixes of rank keys, so these are the entries with a score key from
        ``first``'s and lower than ``score_key``. Reads every one of them."""
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": RANK_INDEX, "ConsistentRead": True,
            "Select": "COUNT",
            "KeyConditionExpression": "board = :board AND rank_key BETWEEN :first AND :key",
            "ExpressionAttributeValues": {":board": text(board_id), ":first": text(first),
                                          ":key": text(score_key)},
        }
        return sum(page["Count"] for page in self._pages(request))

    def _pages(self, request: QueryInputTypeDef) -> Iterator[Any]:
        request = request.copy()
        while True:
            page = self.client.query(**request)
            yield page
            last = page.get("LastEvaluatedKey")
            if not last:
                return
            request["ExclusiveStartKey"] = last
