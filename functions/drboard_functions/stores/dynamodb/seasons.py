"""The cloud board's seasons, in the board table (no board id starts with ``#``):

- ``#SEASON#<season_id>`` / ``#SEASON``: the season (``data``, ``season_version``), with
  ``board_kind="season"`` so that the sparse ``boards`` index lists the seasons by id too;
- ``<board_id>`` / ``#SEASON#<season_id>``: the board's link to a season it is a round or the
  final of (``data``), beside the board, so that a board page or a push to a final finds its
  seasons with one Query of the board's partition;
- ``#RESULTS#<season_id>`` / ``R#<board_id>``: the results the season keeps of a round
  (``board_version``, zlib-compressed JSON in ``results``): one Query reads them all. They sit
  in a partition of their own so that the pull function, which keeps them as it reads (see
  ``service/seasons.py``), may write only there (the template's ``dynamodb:LeadingKeys``).

A season is saved in one transaction with the links it changes, each linked board's version
bumped (its page shows the link), and the results of rounds it no longer has deleted.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING

from botocore.exceptions import ClientError

from ..aws_errors import code_of, translating
from ..base import SeasonConflict, SeasonSlice, StoredBoard, page_token, read_page_token
from .codecs import BOARD_SK, BOARDS_INDEX, NEVER_IN_A_SEASON, key, stored_board, text
from .transaction import Slots

if TYPE_CHECKING:  # the models are imported where an item is read: a push to a board in no
    # season reads none, and its cold start leaves the seasons' models out
    from mypy_boto3_dynamodb.client import DynamoDBClient
    from mypy_boto3_dynamodb.type_defs import AttributeValueTypeDef, PutTypeDef, QueryInputTypeDef

    from ...models.seasons import RoundResults, Season, SeasonLink
    from .codecs import Item

SEASON_KIND = "season"
SEASON_SK = "#SEASON"
LINK_PREFIX = "#SEASON#"
RESULTS_PREFIX = "R#"
#: A round's results bigger than this, compressed, are not kept (an item holds 400 KB): a field
#: of thousands of the longest aliases in scripts that do not compress. Its views read it again.
MAX_KEPT_RESULTS_BYTES = 350_000


def season_partition(season_id: str) -> str:
    return f"#SEASON#{season_id}"


def results_partition(season_id: str) -> str:
    return f"#RESULTS#{season_id}"


def link_sk(season_id: str) -> str:
    return LINK_PREFIX + season_id


def season_item(season: Season) -> Item:
    return {"board": text(season_partition(season.season_id)), "sk": text(SEASON_SK),
            "board_kind": text(SEASON_KIND), "data": text(season.model_dump_json()),
            "season_version": {"N": str(season.version)}}


def results_item(season_id: str, results: RoundResults) -> Item | None:
    """The round's results as an item, or None when they are too big to keep."""
    packed = zlib.compress(results.model_dump_json().encode())
    if len(packed) > MAX_KEPT_RESULTS_BYTES:
        return None
    return {"board": text(results_partition(season_id)), "sk": text(RESULTS_PREFIX + results.board_id),
            "board_version": {"N": str(results.board_version)}, "results": {"B": packed}}


@translating("the board's table")
class DynamoDbSeasons:
    """The season methods of ``DynamoDbStore``."""

    if TYPE_CHECKING:  # what DynamoDbStore gives
        table: str
        client: DynamoDBClient

        def get_item(self, board_id: str, sk: str) -> Item | None: ...

        def _query(self, request: QueryInputTypeDef, limit: int | None = None) -> list[Item]: ...

        def _page(self, request: QueryInputTypeDef, limit: int) -> tuple[list[Item], bool]: ...

        def _batch_get(self, keys: Sequence[dict[str, AttributeValueTypeDef]]) -> Iterator[Item]: ...

    def get_season(self, season_id: str) -> Season | None:
        from ...models.seasons import Season

        item = self.get_item(season_partition(season_id), SEASON_SK)
        return Season.model_validate_json(item["data"]["S"]) if item else None

    def save_season(self, season: Season, links: Mapping[str, SeasonLink | None],
                    forget: Sequence[str] = ()) -> Season:
        slots = Slots()
        put: PutTypeDef = {"TableName": self.table, "Item": season_item(season)}
        if season.version == 1:
            put["ConditionExpression"] = "attribute_not_exists(sk)"
        else:
            put["ConditionExpression"] = "season_version = :seen"
            put["ExpressionAttributeValues"] = {":seen": {"N": str(season.version - 1)}}
        slots.add("season", {"Put": put})
        for board_id, link in links.items():
            if link is None:
                slots.add("link", {"Delete": {"TableName": self.table,
                                              "Key": key(board_id, link_sk(season.season_id))}})
            else:
                slots.add("link", {"Put": {"TableName": self.table, "Item": {
                    "board": text(board_id), "sk": text(link_sk(season.season_id)),
                    "data": text(link.model_dump_json())}}})
            slots.add("board", {"Update": {
                "TableName": self.table, "Key": key(board_id, BOARD_SK),
                "UpdateExpression": f"ADD board_version :one REMOVE {NEVER_IN_A_SEASON}",
                "ConditionExpression": "attribute_exists(sk)",
                "ExpressionAttributeValues": {":one": {"N": "1"}}}})
        for board_id in forget:
            slots.add("results", {"Delete": {"TableName": self.table, "Key": key(
                results_partition(season.season_id), RESULTS_PREFIX + board_id)}})
        try:
            self.client.transact_write_items(TransactItems=slots.items)
        except ClientError as error:
            if code_of(error) == "TransactionCanceledException" and "season" in slots.failed(error):
                raise SeasonConflict(season.season_id) from None
            raise
        return season

    def seasons_page(self, after: str | None, limit: int) -> SeasonSlice:
        request: QueryInputTypeDef = {
            "TableName": self.table, "IndexName": BOARDS_INDEX,
            "KeyConditionExpression": "board_kind = :kind",
            "ExpressionAttributeValues": {":kind": text(SEASON_KIND)},
        }
        if after is not None:
            [season_id] = read_page_token(after, 1)
            request["ExclusiveStartKey"] = {"board_kind": text(SEASON_KIND),
                                            "board": text(season_partition(season_id)),
                                            "sk": text(SEASON_SK)}
        from ...models.seasons import Season

        items, more = self._page(request, limit)
        seasons = [Season.model_validate_json(item["data"]["S"]) for item in items]
        return SeasonSlice(seasons, page_token([seasons[-1].season_id]) if more and seasons else None)

    def season_links(self, board_id: str) -> list[SeasonLink]:
        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board AND begins_with(sk, :prefix)",
            "ExpressionAttributeValues": {":board": text(board_id), ":prefix": text(LINK_PREFIX)},
            "ProjectionExpression": "#data", "ExpressionAttributeNames": {"#data": "data"},
        })
        if not items:
            return []
        from ...models.seasons import SeasonLink

        return [SeasonLink.model_validate_json(item["data"]["S"]) for item in items]

    def boards_by_id(self, board_ids: Sequence[str]) -> dict[str, StoredBoard]:
        keys = [key(board_id, BOARD_SK) for board_id in dict.fromkeys(board_ids)]
        boards = (stored_board(item) for item in self._batch_get(keys))
        return {stored.board.board_id: stored for stored in boards}

    def round_results(self, season_id: str) -> dict[str, RoundResults]:
        from ...models.seasons import RoundResults

        items = self._query({
            "TableName": self.table, "ConsistentRead": True,
            "KeyConditionExpression": "board = :board",
            "ExpressionAttributeValues": {":board": text(results_partition(season_id))},
        })
        results = [RoundResults.model_validate_json(zlib.decompress(item["results"]["B"]))
                   for item in items]
        return {r.board_id: r for r in results}

    def keep_round_results(self, season_id: str, results: RoundResults) -> None:
        item = results_item(season_id, results)
        if item is None:
            return
        try:
            self.client.put_item(
                TableName=self.table, Item=item,
                ConditionExpression="attribute_not_exists(sk) OR board_version < :version",
                ExpressionAttributeValues={":version": {"N": str(results.board_version)}})
        except ClientError as error:
            if code_of(error) != "ConditionalCheckFailedException":
                raise  # else: results of a later version are kept already

