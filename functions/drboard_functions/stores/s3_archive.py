"""The record archive in the cloud: every accepted record, as JSON, in an S3 bucket.

Keys are ``records/<board_id>/<submission_id>.json`` (the board id percent-encoded, so a board id
can never step into another prefix). The submission id is the hash of the record's content, so
the key is content-addressed: the service writes the archive *before* it commits the push, and a
push retried, refused afterwards (a limit, a copied run) or cut short leaves at most an object no
row refers to, with the same content as a later successful push would write. Nothing is ever
committed without its archive. The bucket is versioned and retained by the stack; the board's
rows never hold more than the record itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
from urllib.parse import quote

from botocore.exceptions import BotoCoreError, ClientError
from drboard_assembler.record import Record

from ..errors import StoreUnavailable
from .aws_errors import UNAVAILABLE_RETRY_AFTER_S, store_error

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
        """Keep the record; any failure is a store error (StoreBusy when S3 throttles,
        StoreUnavailable otherwise), so the push stores nothing and answers 503."""
        try:
            self._client.put_object(
                Bucket=self.bucket,
                Key=self.key(board_id, record.submission_id),
                Body=record.model_dump_json().encode("utf-8"),
                ContentType="application/json",
            )
        except (ClientError, BotoCoreError) as error:
            raise store_error(error, "the record archive") or StoreUnavailable(
                "the record archive could not keep the record; nothing was stored, try again",
                UNAVAILABLE_RETRY_AFTER_S) from error
