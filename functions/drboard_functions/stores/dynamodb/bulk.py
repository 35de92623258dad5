"""A batch of a bulk import, written to DynamoDB.

What needs no condition goes in BatchWriteItem calls (25 items each, half the write units of a
transaction): every record first (``D#``: a committed submission always has its record), then,
once the submissions are committed, the audit events and the near-copy index. What must stay
consistent goes in one TransactWriteItems per part of up to ``PART_ROWS`` submissions (a
transaction holds 100 items): the submissions (each on condition that it is not on the board yet), each
racer's entry when it is their best (on condition that the entry read is still there) with the
rank counters moved to match, the racers' tallies, the board's participants and version (on
condition that its rank counters are still those read), and the part's claims of fingerprints
and skeletons (each on condition that no other racer holds it: one held meanwhile is left to
its holder, as an import claims only what is free). A part whose conditions fail is read again
and retried. The runs' first authors are kept after the parts, as a push keeps them after its
transaction (each an update on condition that it is the racer's earliest time).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from botocore.exceptions import ClientError

from ...errors import StoreBusy
from ..aws_errors import code_of
from ..base import ImportBatch, ImportedRow, ImportWritten, IndexedRun, new_rows
from .batches import put_all
from .codecs import (
    audit_item,
    author_update,
    entry_sk,
    fingerprint_item,
    key,
    lane_partition,
    near_sk,
    record_item,
    skeleton_item,
    submission_sk,
    tally_sk,
    text,
)
from .ranks import LAZY_BUILD_MAX_RACERS, TRANSACT_ITEMS, RankState
from .retries import MAX_ATTEMPTS, backoff
from .transaction import Slots

if TYPE_CHECKING:
    from .codecs import Item
    from .store import DynamoDbStore

#: Submissions one transaction commits: with their entries, tallies, claims and the counters
#: they move, they stay within a transaction's 100 items.
PART_ROWS = 12
#: A row's items in its part's transaction at most, its claims left out: its submission, its
#: racer's entry and tally, and three counters.
ROW_ITEMS = 6


class BulkWrite:
    def __init__(self, store: DynamoDbStore, board_id: str, batch: ImportBatch) -> None:
        self.store = store
        self.client = store.client
        self.table = store.table
        self.board_id = board_id
        self.batch = batch

    def run(self) -> ImportWritten:
        ranks = self.store.ranks
        state = ranks.state(self.board_id)
        if not state.exists:
            raise KeyError(self.board_id)
        if state.generation is None and state.building is None:
            ranks.build(self.board_id, max_racers=LAZY_BUILD_MAX_RACERS)
        present = self.store.present_submissions(
            self.board_id, [(row.racer_key, row.submission_id) for row in self.batch.rows])
        rows = new_rows(self.batch.rows, present)
        put_all(self.client, self.table,
                [record_item(self.board_id, row.submission_id, row.record) for row in rows])
        created = improved = 0
        for part, claims in self._parts(rows):
            stored, better = self._commit(part, claims)
            created += stored
            improved += better
        for run in self.batch.runs:
            self._index_author(run)
        put_all(self.client, self.table,
                [_near_item(self.board_id, run) for run in self.batch.runs if run.laps_ms])
        put_all(self.client, self.table, [audit_item(event) for event in self.batch.audit])
        return ImportWritten(created=created, improved=improved)

    def _parts(self, rows: list[ImportedRow]) -> list[tuple[list[ImportedRow], list[Item]]]:
        """The rows in parts of at most PART_ROWS, each with the claims of its racers that no
        earlier part made, and within a transaction's items: per row its submission, entry,
        tally and up to three counters, its claims, and the board's item."""
        claims: dict[str, list[Item]] = {}
        for fingerprint, racer in self.batch.fingerprints:
            claims.setdefault(racer, []).append(fingerprint_item(self.board_id, fingerprint, racer))
        for skeleton, racer in self.batch.skeletons:
            claims.setdefault(racer, []).append(skeleton_item(self.board_id, skeleton, racer))
        parts: list[tuple[list[ImportedRow], list[Item]]] = []
        part: list[ImportedRow] = []
        held: list[Item] = []
        for row in rows:
            mine = claims.pop(row.racer_key, [])
            if part and (len(part) == PART_ROWS
                         or 1 + ROW_ITEMS * (len(part) + 1) + len(held) + len(mine) > TRANSACT_ITEMS):
                parts.append((part, held))
                part, held = [], []
            part.append(row)
            held += mine
        if part:
            parts.append((part, held))
        return parts

    def _commit(self, part: list[ImportedRow], claims: list[Item]) -> tuple[int, int]:
        """One part in one transaction; how many submissions it stored and entries it changed."""
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                backoff(attempt)
            state = self.store.ranks.state(self.board_id)
            if not state.exists:
                raise KeyError(self.board_id)
            entries, tallies = self._read(part)
            slots, changed = self._slots(part, claims, state, entries, tallies)
            try:
                self.client.transact_write_items(TransactItems=slots.items)
            except ClientError as error:
                if code_of(error) != "TransactionCanceledException":
                    raise
                failed = slots.failed(error)
                if "submission" in failed:  # pushed meanwhile: those stay as they are
                    present = self.store.present_submissions(
                        self.board_id, [(row.racer_key, row.submission_id) for row in part])
                    part = new_rows(part, present)
                claims = [item for item, name in zip(claims, _claim_names(claims), strict=True)
                          if name not in failed]  # held by another racer meanwhile
                continue
            return len(part), changed
        raise StoreBusy(f"{self.board_id!r} is busy with other pushes: the import stopped after "
                        f"{MAX_ATTEMPTS} attempts at one batch; import the file again to go on")

    def _read(self, part: list[ImportedRow]) -> tuple[dict[str, Item], dict[str, Item]]:
        """The part's racers' entries and tallies, by racer key."""
        racers = sorted({row.racer_key for row in part})
        items = self.store.get_items(self.board_id, [entry_sk(r) for r in racers]
                                     + [tally_sk(r) for r in racers])
        return ({r: items[entry_sk(r)] for r in racers if entry_sk(r) in items},
                {r: items[tally_sk(r)] for r in racers if tally_sk(r) in items})

    def _slots(self, part: list[ImportedRow], claims: list[Item], state: RankState,
               entries: dict[str, Item], tallies: dict[str, Item]) -> tuple[Slots, int]:
        slots = Slots()
        best: dict[str, ImportedRow] = {}
        counted: dict[str, tuple[int, str]] = {}
        for row in part:
            slots.add("submission", {"Put": {"TableName": self.table, "Item": _submission_item(
                self.board_id, row), "ConditionExpression": "attribute_not_exists(sk)"}})
            current = best[row.racer_key].rank_key if row.racer_key in best else (
                entries[row.racer_key]["rank_key"]["S"] if row.racer_key in entries else None)
            if current is None or row.rank_key < current:
                best[row.racer_key] = row
            submissions, last = counted.get(row.racer_key, (0, ""))
            counted[row.racer_key] = (submissions + 1, max(last, row.submitted_at))
        for racer, row in best.items():
            seen = entries.get(racer)
            put: Any = {"TableName": self.table, "Item": _entry_item(self.board_id, row)}
            if seen is None:
                put["ConditionExpression"] = "attribute_not_exists(sk)"
            else:
                put["ConditionExpression"] = "rank_key = :seen"
                put["ExpressionAttributeValues"] = {":seen": seen["rank_key"]}
            slots.add("entry", {"Put": put})
        for racer, (submissions, last) in counted.items():
            slots.add("tally", {"Update": self._tally(racer, submissions, last, tallies.get(racer))})
        for name, item in zip(_claim_names(claims), claims, strict=True):
            slots.add(name, {"Put": {
                "TableName": self.table, "Item": item,
                "ConditionExpression": "attribute_not_exists(sk) OR racer_key = :me",
                "ExpressionAttributeValues": {":me": item["racer_key"]}}})
        if best:
            ranks = self.store.ranks
            new = sum(racer not in entries for racer in best)
            slots.add("board", ranks.board_change(self.board_id, new, state))
            slots.extend("counters", ranks.replaced(self.board_id, state, [
                ((row.score_key, row.rank_key), _keys(entries.get(racer)))
                for racer, row in best.items()]))
        return slots, len(best)

    def _tally(self, racer: str, submissions: int, last: str, seen: Item | None) -> Any:
        """The racer's tally counts the part's submissions; its last time moves forward only
        (on condition that it is still the one read)."""
        update: dict[str, Any] = {
            "TableName": self.table, "Key": key(self.board_id, tally_sk(racer)),
            "UpdateExpression": "SET submissions = if_not_exists(submissions, :zero) + :n",
            "ExpressionAttributeValues": {":zero": {"N": "0"}, ":n": {"N": str(submissions)}},
        }
        before = seen.get("last_at", {}).get("S") if seen else None
        if before is None or before < last:
            update["UpdateExpression"] += ", last_at = :at"
            update["ExpressionAttributeValues"][":at"] = text(last)
            if before is None:
                update["ConditionExpression"] = "attribute_not_exists(last_at)"
            else:
                update["ConditionExpression"] = "last_at = :before"
                update["ExpressionAttributeValues"][":before"] = text(before)
        return update

    def _index_author(self, run: IndexedRun) -> None:
        try:
            self.client.update_item(TableName=self.table, **author_update(
                run.fingerprint, run.racer_key, self.board_id, run.submission_id, run.submitted_at))
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise

def _claim_names(claims: list[Item]) -> list[str]:
    return [f"claim {item['sk']['S']}" for item in claims]


def _keys(entry: Item | None) -> tuple[str, str] | None:
    return (entry["score_key"]["S"], entry["rank_key"]["S"]) if entry else None


def _submission_item(board_id: str, row: ImportedRow) -> Item:
    return {"board": text(board_id), "sk": text(submission_sk(row.racer_key, row.submission_id)),
            "history_racer": text(row.racer_key), "submitted_at": text(row.submitted_at),
            "data": text(row.submission)}


def _entry_item(board_id: str, row: ImportedRow) -> Item:
    return {"board": text(board_id), "sk": text(entry_sk(row.racer_key)),
            "rank_key": text(row.rank_key), "score_key": text(row.score_key),
            "data": text(row.entry)}


def _near_item(board_id: str, run: IndexedRun) -> Item:
    laps = run.laps_ms or ()
    return {"board": text(lane_partition(run.lane)),
            "sk": text(near_sk(laps[0], run.fingerprint, run.racer_key, board_id)),
            "fingerprint": text(run.fingerprint), "racer_key": text(run.racer_key),
            "board_id": text(board_id), "submission_id": text(run.submission_id),
            "laps": text(",".join(map(str, laps)))}

