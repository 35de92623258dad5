"""Seasons on Amazon's DynamoDB Local: a view of a season reads the season, the results it keeps
and its rounds' boards — not every round's every entry — and reads again only a round whose
board changed. Items read are counted as tests/integration/test_dynamodb_store.py counts them."""

from __future__ import annotations

from typing import Any

from drboard_functions.models.requests import BoardSpec
from drboard_functions.models.seasons import SeasonSpec
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.dynamodb import DynamoDbStore

from tests.integration.dynamodb_local import DynamoDbLocal
from tests.integration.test_dynamodb_store import local_table
from tests.recordkit import make_record

__all__ = ["local_table"]

ROUNDS = 3
RACERS = 40
SEASON = "club-2026"


class ItemsRead:
    """Items read by Query (scanned), GetItem and BatchGetItem, by a client's calls."""

    def __init__(self, client: Any) -> None:
        self.items = 0
        client.meta.events.register("after-call.dynamodb.Query", self._query)
        client.meta.events.register("after-call.dynamodb.GetItem", self._get)
        client.meta.events.register("after-call.dynamodb.BatchGetItem", self._batch)

    def _query(self, parsed: dict[str, Any], **_: Any) -> None:
        self.items += int(parsed.get("ScannedCount", 0))

    def _get(self, parsed: dict[str, Any], **_: Any) -> None:
        self.items += 1 if parsed.get("Item") else 0

    def _batch(self, parsed: dict[str, Any], **_: Any) -> None:
        self.items += sum(len(found) for found in parsed.get("Responses", {}).values())


def test_a_season_view_reads_a_bounded_number_of_items(dynamodb_local: DynamoDbLocal,
                                                       local_table: str) -> None:
    client = dynamodb_local.client()
    service = LeaderboardService(DynamoDbStore(local_table, client))
    service.create_season(SeasonSpec(season_id=SEASON, title="Club season 2026"))
    for n in range(1, ROUNDS + 1):
        board_id = f"night-{n}"
        service.create_board(BoardSpec(board_id=board_id, title=f"Night {n}", track="reInvent2019"))
        for racer in range(RACERS):
            record = make_record(f"Racer {racer:02d}", [(9_000 + 37 * ((racer * n) % RACERS), 100)],
                                 model=f"night-{n}")
            service.push(record, board_id)
        service.add_round(SEASON, board_id)
    first = service.season(SEASON)
    assert len(first.standings) == RACERS

    read = ItemsRead(client)
    again = service.season(SEASON)
    assert again == first
    season_item, kept_results, boards = 1, ROUNDS, ROUNDS
    assert read.items == season_item + kept_results + boards, "no entry of any round is read"

    service.push(make_record("Newcomer", [(8_000, 100)], model="fast"), "night-2")
    read.items = 0
    moved = service.season(SEASON)
    assert [(s.racer, s.points) for s in moved.standings if s.racer == "Newcomer"] == [("Newcomer", 25)]
    round_two = 1 + RACERS + 1  # its board item and every entry, newcomer included
    assert read.items == season_item + kept_results + boards + round_two, "only round 2 is read again"
