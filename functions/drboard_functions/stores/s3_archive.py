"""The record archive in the cloud: every accepted record, as JSON, in an S3 bucket.

Keys are ``records/<board_id>/<submission_id>.json`` (the board id percent-encoded, so a board id
can never step into another prefix). The bucket is versioned and retained by the stack; the
board's rows never hold more than the record itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
from urllib.parse import quote

from drboard_assembler.record import Record

if TYPE_CHECKING:
    from mypy_boto3_s3 import S3Client

PREFIX = "records/"


class S3Archive:
    def __init__(self, bucket: str, client: S3Client | None = None) -> None:
        self.bucket = bucket
        if client is None:
            import boto3  # here, so that importing the module stays cheap for a cold start

            client = boto3.client("s3")
        self._client: S3Client = client

    @staticmethod
    def key(board_id: str, submission_id: str) -> str:
        return f"{PREFIX}{quote(board_id, safe='')}/{quote(submission_id, safe='')}.json"

    def put(self, board_id: str, record: Record) -> None:
        self._client.put_object(
            Bucket=self.bucket,
            Key=self.key(board_id, record.submission_id),
            Body=record.model_dump_json().encode("utf-8"),
            ContentType="application/json",
        )
