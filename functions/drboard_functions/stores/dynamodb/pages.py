"""A board's pages kept in the table as the bytes that answer them (see ``stores.pages``).

Each page is one item in the partition ``#PAGE#<board_id>``, under the page's key (its kind,
size and, for a web page, a digest of the address it was rendered for): ``board_version`` the
version it shows, ``fresh_until`` (seconds since the epoch; absent: no such moment), ``etag``,
``headers`` (its headers for 200 and for 304, as JSON) and ``body`` (its text, zlib-compressed:
a 100-racer page of ~46 kB keeps in ~5 kB). A partition of its own, apart from the board's,
so that the pull function, which writes the pages it renders, may write nothing else
(template.yaml limits its writes to these partitions).

One consistent BatchGetItem reads the board's version and a page together; a page a reader
rendered is written on condition that no page of a later version is kept already, and the pages
a change rendered for the version it made are written together, in one BatchWriteItem (each
reader checks the version it answers anyway). No model is imported here.
"""

from __future__ import annotations

import json
import logging
import zlib
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from botocore.exceptions import BotoCoreError, ClientError

from ..aws_errors import translated
from ..pages import StoredPage
from .batches import put_all
from .keys import BOARD_SK, key, page_partition, text

if TYPE_CHECKING:
    from mypy_boto3_dynamodb import DynamoDBClient

#: DynamoDB's item bound is 400 KB: a page whose compressed body is over this is not kept.
MAX_KEPT_BYTES = 350_000
_READ = "board, sk, board_version, fresh_until, etag, headers, body"
_NAMES = {f"#{name}": name for name in _READ.split(", ")}
_PROJECTION = ", ".join(_NAMES)

logger = logging.getLogger(__name__)


class DynamoDbPageShelf:
    """The pages kept for the boards of one table."""

    def __init__(self, client: DynamoDBClient, table: str) -> None:
        self.client = client
        self.table = table

    def version(self, board_id: str) -> int | None:
        with translated("the board's table"):
            item = self.client.get_item(TableName=self.table, ConsistentRead=True,
                                        Key=key(board_id, BOARD_SK),
                                        ProjectionExpression="sk, board_version").get("Item")
        return _version(item) if item else None

    def page(self, board_id: str, page_key: str) -> tuple[int | None, StoredPage | None]:
        wanted = [key(board_id, BOARD_SK), key(page_partition(board_id), page_key)]
        with translated("the board's table"):
            answer = self.client.batch_get_item(RequestItems={self.table: {
                "Keys": wanted, "ConsistentRead": True, "ProjectionExpression": _PROJECTION,
                "ExpressionAttributeNames": _NAMES}})
        if answer.get("UnprocessedKeys"):  # throttled: the caller reads the page the long way
            return self.version(board_id), None
        version: int | None = None
        page: StoredPage | None = None
        for item in answer.get("Responses", {}).get(self.table, []):
            if item["sk"]["S"] == BOARD_SK:
                version = _version(item)
            else:
                page = _page(item)
        return version, page

    def keep(self, board_id: str, page_key: str, page: StoredPage) -> None:
        item = _item(board_id, page_key, page)
        if item is None:
            return
        try:
            self.client.put_item(TableName=self.table, Item=item,
                                 ConditionExpression="attribute_not_exists(sk) OR board_version <= :v",
                                 ExpressionAttributeValues={":v": {"N": str(page.version)}})
        except ClientError as error:
            if error.response.get("Error", {}).get("Code") != "ConditionalCheckFailedException":
                logger.warning("a page of %s was not kept: %s", board_id, error)
        except BotoCoreError as error:
            logger.warning("a page of %s was not kept: %s", board_id, error)

    def keep_all(self, board_id: str, pages: Sequence[tuple[str, StoredPage]]) -> None:
        items = [item for page_key, page in pages if (item := _item(board_id, page_key, page))]
        if not items:
            return
        try:
            put_all(self.client, self.table, items)
        except (ClientError, BotoCoreError) as error:
            logger.warning("the pages of %s were not kept: %s", board_id, error)


def _item(board_id: str, page_key: str, page: StoredPage) -> dict[str, Any] | None:
    body = zlib.compress(page.text.encode("utf-8"))
    if len(body) > MAX_KEPT_BYTES:
        return None
    item: dict[str, Any] = key(page_partition(board_id), page_key) | {
        "board_version": {"N": str(page.version)}, "etag": text(page.etag),
        "headers": text(json.dumps([page.headers, page.not_modified_headers])),
        "body": {"B": body}}
    if page.fresh_until is not None:
        item["fresh_until"] = {"N": repr(page.fresh_until)}
    return item


def _version(item: dict[str, Any]) -> int:
    return int(item.get("board_version", {"N": "0"})["N"])


def _page(item: dict[str, Any]) -> StoredPage:
    headers, not_modified = json.loads(item["headers"]["S"])
    fresh_until = float(item["fresh_until"]["N"]) if "fresh_until" in item else None
    return StoredPage(_version(item), fresh_until, item["etag"]["S"], headers, not_modified,
                      zlib.decompress(item["body"]["B"]).decode("utf-8"))
