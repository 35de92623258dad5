"""The table's keys that need no model: the board item's, and the partition of a board's kept
pages (``codecs`` describes every item; the pull function reads a kept page with these alone)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mypy_boto3_dynamodb.type_defs import AttributeValueTypeDef

BOARD_SK = "#BOARD"
PAGE_PARTITION = "#PAGE#"


def text(value: str) -> AttributeValueTypeDef:
    return {"S": value}


def key(board_id: str, sk: str) -> dict[str, AttributeValueTypeDef]:
    return {"board": text(board_id), "sk": text(sk)}


def page_partition(board_id: str) -> str:
    return PAGE_PARTITION + board_id
