"""A board's rank counters on DynamoDB: ranks without reading the board.

``#RANK#<generation>#<node>`` items hold the counts of entries by score, one item per node of
the layout in ``rank_buckets``, a number attribute ``c:<child>`` per child. The board's
``rank_generation`` names the counters in use; every write that adds, replaces or removes an
entry moves them in its transaction, on condition that the generation is still the board's,
so they never drift. A rank reads the three items of its path (TransactGetItems: one moment
of the board), whatever the board's size. A board created before the counters has no
generation: its ranks are counted from the entries, as they were, until its counters are
built (``build``: by its next push if it has at most 10,000 racers, else by an operator's
``drboard board rebuild-ranks``).

A build counts the entries in rank order, a batch at a time, into a new generation's counters.
The board item says how far it got (``rank_building``: the generation being built,
``rank_built_to``: the last rank key counted), so a build that stops goes on where it stopped.
Each batch commits its counts and moves ``rank_built_to`` in one transaction, on condition that
the board's version has not moved since its entries were read. Writes that change an entry
meanwhile move the building generation's counters too, for the entries already counted (rank
keys up to ``rank_built_to``), on condition that ``rank_built_to`` has not moved: so the counts
are exact when the build makes its generation the board's.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

from botocore.exceptions import ClientError

from ...models.domain import Entry
from .. import rank_buckets
from ..aws_errors import code_of
from ..base import RankBuild
from .codecs import (
    BOARD_SK,
    COUNT_PREFIX,
    FIRST_ENTRY,
    RANK_INDEX,
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

    from .codecs import Item

FIRST_GENERATION = "0"  # the rank counters of a board created with them
TRANSACT_ITEMS = 100
#: Counter items one batch of a build moves (with the board item, one transaction).
BATCH_NODES = 90
BATCH_READ = 300  # entries read for one batch (it takes as many as its nodes allow)
BATCH_ATTEMPTS = 20  # of one batch, while pushes keep moving the board
READ_ATTEMPTS = 3  # of reading a rank's counters together, while pushes move them
# A push to a board from before the rank counters builds them when the board has at most this
# many racers (about as many items as one rank used to read); a bigger board needs an
# operator's build, which may take longer than a push function may.
LAZY_BUILD_MAX_RACERS = 10_000
NOTHING_COUNTED = FIRST_ENTRY  # every entry's rank key sorts after it
#: An entry's (score key, rank key).
Keys = tuple[str, str]


class RankState(NamedTuple):
    """A board's rank counters: the generation in use (None: none yet), or the one being built
    and how far (the last rank key counted)."""

    exists: bool
    generation: str | None = None
    building: str | None = None
    built_to: str = NOTHING_COUNTED

    def counted(self, entry: Entry | None) -> Entry | None:
        """The entry, if the building generation has counted it (else None)."""
        return entry if entry is not None and entry.rank_key <= self.built_to else None


def state_of(item: Item | None) -> RankState:
    if item is None:
        return RankState(exists=False)
    if "rank_generation" in item:
        return RankState(exists=True, generation=item["rank_generation"]["S"])
    if "rank_building" in item:
        return RankState(exists=True, building=item["rank_building"]["S"],
                         built_to=item["rank_built_to"]["S"])
    return RankState(exists=True)


class RankCounters:
    def __init__(self, client: DynamoDBClient, table: str) -> None:
        self.client = client
        self.table = table
        # A board's rank generation, once set, never changes: it is safe to remember.
        self._generations: dict[str, str] = {}

    def note(self, board_id: str, item: Item) -> None:
        """Remember the generation a board item read for another reason shows (a later
        ``state`` then reads nothing)."""
        if "rank_generation" in item:
            self._generations[board_id] = item["rank_generation"]["S"]

    def state(self, board_id: str) -> RankState:
        """The board's rank counters (read, unless the board's generation is known)."""
        if board_id in self._generations:
            return RankState(exists=True, generation=self._generations[board_id])
        item = self.client.get_item(
            TableName=self.table, ConsistentRead=True, Key=key(board_id, BOARD_SK),
            ProjectionExpression="sk, rank_generation, rank_building, rank_built_to").get("Item")
        state = state_of(item)
        if state.generation is not None:
            self._generations[board_id] = state.generation
        return state

    def count_better(self, board_id: str, score_key: str) -> int:
        """How many entries of the board score better than ``score_key``."""
        generation = self.state(board_id).generation
        if generation is None:  # no board, or one whose counters are not built yet
            return self._count_entries(board_id, FIRST_ENTRY, score_key)
        nodes = [node for node, _ in rank_buckets.path(score_key)]
        read = self._read(board_id, generation, nodes)
        better = rank_buckets.count_lower(score_key, read.__getitem__)
        if rank_buckets.in_overflow(score_key):
            better += self._count_entries(board_id, rank_buckets.OVERFLOW_START, score_key)
        return better

    def changes(self, board_id: str, state: RankState, added: Entry | None,
                removed: Entry | None) -> list[TransactWriteItemTypeDef]:
        """The counter updates for the entry ``removed`` (or none) replaced by ``added`` (or
        none): in the generation in use, or in the one being built for the entries it counted."""
        if state.generation is not None:
            return self._updates(board_id, state.generation, added, removed)
        if state.building is not None:
            return self._updates(board_id, state.building, state.counted(added),
                                 state.counted(removed))
        return []

    def replaced(self, board_id: str, state: RankState,
                 changes: Sequence[tuple[Keys | None, Keys | None]]) -> list[TransactWriteItemTypeDef]:
        """The counter updates for several entries replaced at once, each (added, removed) as
        (score key, rank key) or None, merged by counter item (a transaction writes an item
        once): in the generation in use, or in the one being built for the entries it counted."""
        generation = state.generation or state.building
        if generation is None:
            return []
        moves: dict[str, dict[str, int]] = {}
        for added, removed in changes:
            if state.generation is None:
                added = added if added and added[1] <= state.built_to else None
                removed = removed if removed and removed[1] <= state.built_to else None
            for node, children in rank_buckets.changes(added[0] if added else None,
                                                       removed[0] if removed else None).items():
                merged = moves.setdefault(node, {})
                for child, change in children.items():
                    merged[child] = merged.get(child, 0) + change
        return [self._add(board_id, generation, node, kept) for node, children in moves.items()
                if (kept := {child: n for child, n in children.items() if n})]

    def board_change(self, board_id: str, change: int, state: RankState) -> TransactWriteItemTypeDef:
        """The board's number of racers changed by ``change``, and its version bumped, on
        condition that its rank counters are still as ``state`` says (so that the counter
        updates of ``changes`` in the same transaction are the right ones)."""
        values: dict[str, AttributeValueTypeDef] = {":change": {"N": str(change)}, ":one": {"N": "1"}}
        if state.generation is not None:
            condition = "rank_generation = :generation"
            values[":generation"] = text(state.generation)
        elif state.building is not None:
            condition = ("attribute_not_exists(rank_generation) AND rank_building = :building "
                         "AND rank_built_to = :built_to")
            values |= {":building": text(state.building), ":built_to": text(state.built_to)}
        else:
            condition = ("attribute_exists(sk) AND attribute_not_exists(rank_generation) AND "
                         "attribute_not_exists(rank_building)")
        return {"Update": {
            "TableName": self.table, "Key": key(board_id, BOARD_SK),
            "UpdateExpression": "SET participants = participants + :change ADD board_version :one",
            "ConditionExpression": condition, "ExpressionAttributeValues": values}}

    def _updates(self, board_id: str, generation: str, added: Entry | None,
                 removed: Entry | None) -> list[TransactWriteItemTypeDef]:
        moves = rank_buckets.changes(added.score_key if added else None,
                                     removed.score_key if removed else None)
        return [self._add(board_id, generation, node, children) for node, children in moves.items()]

    def _add(self, board_id: str, generation: str, node: str,
             children: dict[str, int]) -> TransactWriteItemTypeDef:
        names = {f"#c{i}": COUNT_PREFIX + child for i, child in enumerate(children)}
        values: dict[str, AttributeValueTypeDef] = {
            f":c{i}": {"N": str(n)} for i, n in enumerate(children.values())}
        return {"Update": {
            "TableName": self.table, "Key": key(board_id, counter_sk(generation, node)),
            "UpdateExpression": "ADD " + ", ".join(f"#c{i} :c{i}" for i in range(len(children))),
            "ExpressionAttributeNames": names, "ExpressionAttributeValues": values}}

    # ---- building the counters of a board from before them --------------------------------

    def build(self, board_id: str, max_racers: int | None = None,
              budget_s: float | None = None) -> RankBuild:
        """Count the board's entries into new counters, batch after batch, for up to
        ``budget_s`` seconds (None: to the end; at least one batch), and make them the board's
        once every entry is counted; a later call goes on where this one stopped. A board of
        more than ``max_racers`` racers is left as it is."""
        deadline = None if budget_s is None else time.monotonic() + budget_s
        conflicts = 0
        while True:
            item = self._board_item(board_id)
            progress = _progress(item)
            if item is None:
                return progress
            if progress.done:
                self._generations[board_id] = item["rank_generation"]["S"]
                return progress
            if max_racers is not None and progress.participants > max_racers:
                return progress
            try:
                self._step(board_id, item)
            except ClientError as error:
                if code_of(error) not in ("ConditionalCheckFailedException",
                                          "TransactionCanceledException"):
                    raise
                conflicts += 1  # a push (or another build) moved the board meanwhile
                if conflicts == BATCH_ATTEMPTS:
                    return progress
                backoff(min(conflicts, 5))
                continue
            conflicts = 0
            if deadline is not None and time.monotonic() >= deadline:
                return _progress(self._board_item(board_id))

    def _step(self, board_id: str, item: Item) -> None:
        state = state_of(item)
        if state.building is None:
            self._start(board_id)
        else:
            self._batch(board_id, state, item.get("board_version", {"N": "0"})["N"])

    def _board_item(self, board_id: str) -> Item | None:
        return self.client.get_item(TableName=self.table, ConsistentRead=True,
                                    Key=key(board_id, BOARD_SK)).get("Item")

    def _start(self, board_id: str) -> None:
        self.client.update_item(
            TableName=self.table, Key=key(board_id, BOARD_SK),
            UpdateExpression="SET rank_building = :building, rank_built_to = :nothing, "
                             "rank_build_counted = :zero",
            ConditionExpression="attribute_exists(sk) AND attribute_not_exists(rank_generation) "
                                "AND attribute_not_exists(rank_building)",
            ExpressionAttributeValues={":building": text(secrets.token_hex(6)),
                                       ":nothing": text(NOTHING_COUNTED), ":zero": {"N": "0"}})

    def _batch(self, board_id: str, state: RankState, version: str) -> None:
        """Count the next entries after ``state.built_to`` (as many as BATCH_NODES counters
        hold), or, when none is left, make the built generation the board's: one transaction,
        on condition that no entry changed since the board's ``version`` was read."""
        assert state.building is not None
        page = self.client.query(
            TableName=self.table, IndexName=RANK_INDEX, ConsistentRead=True, Limit=BATCH_READ,
            KeyConditionExpression="board = :board AND rank_key > :after",
            ExpressionAttributeValues={":board": text(board_id), ":after": text(state.built_to)},
            ProjectionExpression="rank_key, score_key")["Items"]
        unchanged = {":building": text(state.building), ":built_to": text(state.built_to),
                     ":seen": {"N": version}}
        condition = ("rank_building = :building AND rank_built_to = :built_to AND "
                     "(attribute_not_exists(board_version) OR board_version = :seen)")
        if not page:
            self.client.update_item(
                TableName=self.table, Key=key(board_id, BOARD_SK),
                UpdateExpression="SET rank_generation = :building "
                                 "REMOVE rank_building, rank_built_to, rank_build_counted",
                ConditionExpression=condition, ExpressionAttributeValues=unchanged)
            self._generations[board_id] = state.building
            return
        batch = _within_nodes([(i["rank_key"]["S"], i["score_key"]["S"]) for i in page])
        counters = [self._add(board_id, state.building, node, children)
                    for node, children in rank_buckets.tally([s for _, s in batch]).items()]
        self.client.transact_write_items(TransactItems=[*counters, {"Update": {
            "TableName": self.table, "Key": key(board_id, BOARD_SK),
            "UpdateExpression": "SET rank_built_to = :to ADD rank_build_counted :n",
            "ConditionExpression": condition,
            "ExpressionAttributeValues": unchanged | {":to": text(batch[-1][0]),
                                                      ":n": {"N": str(len(batch))}}}}])

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


def _progress(item: Item | None) -> RankBuild:
    if item is None:
        return RankBuild(done=False, counted=0, participants=0)
    participants = int(item["participants"]["N"])
    if "rank_generation" in item:
        return RankBuild(done=True, counted=participants, participants=participants)
    counted = int(item.get("rank_build_counted", {"N": "0"})["N"])
    return RankBuild(done=False, counted=counted, participants=participants)


def _within_nodes(entries: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """The first of these (rank key, score key) entries whose counters fit one batch."""
    nodes: set[str] = set()
    for index, (_, score_key) in enumerate(entries):
        added = {node for node, _ in rank_buckets.path(score_key)} - nodes
        if len(nodes) + len(added) > BATCH_NODES:
            return entries[:index]
        nodes |= added
    return entries
