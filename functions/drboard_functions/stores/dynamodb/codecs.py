"""How the board's things are written as DynamoDB items, and read back.

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
- ``#RANK#<generation>#<node>``: the counts of entries by score (see ``ranks.py``);
- ``#SEASON#<season_id>``: the board's link to a season (see ``seasons.py``, which also keeps
  the seasons themselves in partitions of their own).
- In a partition of its own, ``#PAGE#<board_id>``: the board's pages kept as the bytes that
  answer them, each labelled with the board version it shows (see ``pages.py``).

- ``K#<skeleton>``: an alias's confusable skeleton on the board, and the racer (``racer_key``)
  who holds it: a lookalike alias under another racer fails the push transaction;
- ``#BOARD`` also carries ``settings_version``, bumped by every change to the board's settings:
  a push commits on condition that it is still the one the push checked against.

Aliases live in a partition of their own, ``#ALIAS`` (no board id starts with ``#``): ``K#<key>``
holds an alias's claim and ``P#<principal>`` the same claim by its sign-in. Webhooks live in
``#WEBHOOK`` (sort key ``<target key>#<webhook id>``, the webhook in ``data``), and the markers of
announcements sent in ``#NOTICE`` (``<event id>#<webhook id>``: ``state``, ``lease_until``, and
``expires_at`` for the table's time to live). Partitions of their own too, since they hold what
spans boards:

- ``#RUN#<fingerprint>``: ``R#<racer_key>`` for each racer who pushed a run with that fingerprint,
  with their first time (``first_at``) and board (``board_id``): the first author holds the run;
- ``#LAPS#<lane>``: ``<best lap ms>#<fingerprint>#<racer_key>#<board_id>`` for each run long
  enough to be compared, with its sorted lap times (``laps``): the near-copy index, read as one
  range of best laps;
- ``#EVENT``: ``#BANS``, the bans across every board of the deployment (``data``, ``version``).
"""

from __future__ import annotations

import zlib
from typing import TYPE_CHECKING, Any

from ... import ranking
from ...models.domain import (
    AliasClaim,
    AuditEvent,
    Board,
    Entry,
    NearRun,
    RunAuthor,
    RunPrint,
    Submission,
)
from ..base import StoredBoard

# The keys that need no model live in keys.py (the pull function reads kept pages with them
# alone); the other modules take them from here with the rest of the layout.
from .keys import BOARD_SK as BOARD_SK
from .keys import key as key
from .keys import text as text

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.type_defs import AttributeValueTypeDef

    Item = dict[str, AttributeValueTypeDef]

ALIAS_PARTITION = "#ALIAS"
EVENT_PARTITION = "#EVENT"
BANS_SK = "#BANS"
BEST_DIGITS = 10
WEBHOOK_PARTITION = "#WEBHOOK"
NOTICE_PARTITION = "#NOTICE"
FIRST_ENTRY = "0"  # every entry's rank key sorts after this, the board's before it
BOARD_KIND = "board"
RANK_INDEX = "by_rank"
RACER_INDEX = "by_racer"
BOARDS_INDEX = "boards"
COUNT_PREFIX = "c:"
#: Set on a board item when the board is created, and removed for good the first time a season
#: takes the board in: while it is there, a push need not look for the board's seasons.
NEVER_IN_A_SEASON = "never_in_a_season"


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


def skeleton_sk(skeleton: str) -> str:
    return f"K#{skeleton}"


def run_partition(fingerprint: str) -> str:
    return f"#RUN#{fingerprint}"


def author_sk(racer_key: str) -> str:
    return f"R#{racer_key}"


def lane_partition(lane: str) -> str:
    return f"#LAPS#{lane}"


def near_sk(best_ms: int, fingerprint: str = "", racer_key: str = "", board_id: str = "") -> str:
    return f"{best_ms:0{BEST_DIGITS}d}#{fingerprint}#{racer_key}#{board_id}"


def audit_sk(event_id: str) -> str:
    return f"A#{event_id}"


def counter_sk(generation: str, node: str) -> str:
    return f"#RANK#{generation}#{node}"


# ---- items -----------------------------------------------------------------------------------

def board_item(board: Board) -> Item:
    """A board without rank counters (as boards were before them); what a bulk loader writes
    directly, before ``build_rank_counters``."""
    return {"board": text(board.board_id), "sk": text(BOARD_SK), "board_kind": text(BOARD_KIND),
            "rank_key": text(BOARD_SK), "data": text(board.model_dump_json()),
            "participants": {"N": "0"}}


def entry_item(entry: Entry) -> Item:
    """An entry as stored; also what a bulk loader (the benchmark) writes directly."""
    return {"board": text(entry.board_id), "sk": text(entry_sk(entry.racer_key)),
            "rank_key": text(entry.rank_key), "score_key": text(entry.score_key),
            "data": text(entry.model_dump_json())}


def counter_item(board_id: str, generation: str, node: str, counts: dict[str, int]) -> Item:
    item: Item = {"board": text(board_id), "sk": text(counter_sk(generation, node))}
    item.update({COUNT_PREFIX + child: {"N": str(n)} for child, n in counts.items()})
    return item


def submission_item(submission: Submission) -> Item:
    return {
        "board": text(submission.board_id),
        "sk": text(submission_sk(submission.racer_key, submission.submission_id)),
        "history_racer": text(submission.racer_key),
        "submitted_at": text(ranking.timestamp(submission.submitted_at)),
        "data": text(submission.model_dump_json()),
    }


def audit_item(event: AuditEvent) -> Item:
    return {"board": text(event.board_id), "sk": text(audit_sk(event.event_id)),
            "data": text(event.model_dump_json())}


def author_update(fingerprint: str, racer_key: str, board_id: str, submission_id: str,
                  at: str, *, kept: bool = False) -> dict[str, Any]:
    """The update of a racer's first time with a run (``update_item``'s arguments but the
    table): the earliest wins, on condition (ConditionalCheckFailed: an earlier one is kept);
    with ``kept``, one already there stays, with no condition (for a push's transaction: a
    push is the newest submission of its run)."""
    update: dict[str, Any] = {
        "Key": key(run_partition(fingerprint), author_sk(racer_key)),
        "ExpressionAttributeValues": {":at": text(at), ":board": text(board_id),
                                      ":racer": text(racer_key), ":submission": text(submission_id)}}
    if kept:
        update["UpdateExpression"] = (
            "SET first_at = if_not_exists(first_at, :at), board_id = if_not_exists(board_id, :board), "
            "racer_key = if_not_exists(racer_key, :racer), "
            "submission_id = if_not_exists(submission_id, :submission)")
    else:
        update["UpdateExpression"] = ("SET first_at = :at, board_id = :board, racer_key = :racer, "
                                      "submission_id = :submission")
        update["ConditionExpression"] = "attribute_not_exists(first_at) OR first_at > :at"
    return update


def near_item(run: RunPrint, submission: Submission) -> Item:
    laps = run.laps_ms or []
    return {"board": text(lane_partition(run.lane)),
            "sk": text(near_sk(laps[0], run.fingerprint, submission.racer_key, submission.board_id)),
            "fingerprint": text(run.fingerprint), "racer_key": text(submission.racer_key),
            "board_id": text(submission.board_id), "submission_id": text(submission.submission_id),
            "laps": text(",".join(map(str, laps)))}


def near_run_of(item: Item) -> NearRun:
    return NearRun(fingerprint=item["fingerprint"]["S"], racer_key=item["racer_key"]["S"],
                   board_id=item["board_id"]["S"], submission_id=item["submission_id"]["S"],
                   laps_ms=[int(t) for t in item["laps"]["S"].split(",")])


def run_author_of(fingerprint: str, item: Item) -> RunAuthor:
    return RunAuthor(fingerprint=fingerprint, racer_key=item["racer_key"]["S"],
                     first_at=ranking.parse_timestamp(item["first_at"]["S"]),
                     board_id=item["board_id"]["S"], submission_id=item["submission_id"]["S"])


def alias_items(claim: AliasClaim) -> list[Item]:
    data = text(claim.model_dump_json())
    return [{"board": text(ALIAS_PARTITION), "sk": text(f"K#{claim.racer_key}"), "data": data},
            {"board": text(ALIAS_PARTITION), "sk": text(f"P#{claim.principal}"), "data": data}]


def record_item(board_id: str, submission_id: str, record_json: str) -> Item:
    return {"board": text(board_id), "sk": text(record_sk(submission_id)),
            "record": {"B": zlib.compress(record_json.encode())}}


def skeleton_item(board_id: str, skeleton: str, racer_key: str) -> Item:
    return {"board": text(board_id), "sk": text(skeleton_sk(skeleton)), "racer_key": text(racer_key)}


def fingerprint_item(board_id: str, fingerprint: str, racer_key: str) -> Item:
    return {"board": text(board_id), "sk": text(fingerprint_sk(fingerprint)),
            "racer_key": text(racer_key)}


# ---- reading items back ------------------------------------------------------------------------

def stored_board(item: Item) -> StoredBoard:
    return StoredBoard(Board.model_validate_json(item["data"]["S"]), int(item["participants"]["N"]),
                       int(item.get("board_version", {"N": "0"})["N"]),
                       int(item.get("settings_version", {"N": "0"})["N"]),
                       maybe_in_a_season=NEVER_IN_A_SEASON not in item)


def entry_of(item: Item) -> Entry:
    return Entry.model_validate_json(item["data"]["S"])


def submission_of(item: Item) -> Submission:
    return Submission.model_validate_json(item["data"]["S"])


def claim_of(item: Item) -> AliasClaim:
    return AliasClaim.model_validate_json(item["data"]["S"])


def audit_event_of(item: Item) -> AuditEvent:
    return AuditEvent.model_validate_json(item["data"]["S"])


def record_json(item: Item) -> bytes:
    return zlib.decompress(item["record"]["B"])


def counts(item: Item | None) -> dict[str, int]:
    """A counter item's counts by child; no item, no entries."""
    return {name[len(COUNT_PREFIX):]: int(value["N"]) for name, value in (item or {}).items()
            if name.startswith(COUNT_PREFIX) and "N" in value}
