"""Boards and racers' histories a page at a time on Amazon's DynamoDB Local: the engine's own
Limit, ExclusiveStartKey and filter on the `boards` and `by_racer` indexes."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta

import pytest
from drboard_functions.errors import InvalidQuery
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.dynamodb import DynamoDbStore

from tests.integration.dynamodb_local import DynamoDbLocal
from tests.recordkit import make_record
from tests.tablekit import create_board_table

TRACKS = ["Track_A", "Track_B", "Track_C", "Track_D", "Track_E"]


@pytest.fixture
def service(dynamodb_local: DynamoDbLocal) -> Iterator[LeaderboardService]:
    client = dynamodb_local.client()
    table = create_board_table(client, f"drboard-test-{uuid.uuid4().hex[:12]}")
    moments = iter(datetime(2025, 3, 1, tzinfo=UTC) + timedelta(minutes=n) for n in range(10_000))
    yield LeaderboardService(DynamoDbStore(table, client), clock=lambda: next(moments))
    client.delete_table(TableName=table)


def test_boards_and_a_history_come_a_page_at_a_time(service: LeaderboardService) -> None:
    for n, track in enumerate(TRACKS):
        service.push(make_record(racer="Ada", track=track, laps=[(12_000 + n, 100)]))
        service.push(make_record(racer="Ada", track=TRACKS[0], laps=[(11_000 - n, 100)]))

    first = service.boards_page(limit=2)
    second = service.boards_page(limit=2, cursor=first.next_cursor)
    third = service.boards_page(limit=2, cursor=second.next_cursor)
    ids = [b.board_id for page in (first, second, third) for b in page.boards]
    assert ids == sorted(f"custom.{track}" for track in TRACKS)
    assert third.next_cursor is None

    history, cursor = [], None
    while True:
        page = service.history_page("Ada", f"custom.{TRACKS[0]}", limit=2, cursor=cursor)
        history += page.history
        cursor = page.next_cursor
        if cursor is None:
            break
    assert len(history) == 6  # five on Track_A, and Ada's first push there
    assert [item.submitted_at for item in history] == sorted(item.submitted_at for item in history)
    assert service.history("Ada") == sorted(service.history("Ada"), key=lambda i: i.submitted_at)
    assert len(service.history("Ada")) == 10

    with pytest.raises(InvalidQuery):
        service.history_page("Ada", None, limit=2, cursor=first.next_cursor)  # a boards cursor
