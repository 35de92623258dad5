"""The record archive in the cloud: every accepted record, as JSON, in an S3 bucket.

Keys are ``records/<board_id>/<submission_id>.json`` (the board id percent-encoded, so a board id
can never step into another prefix). The submission id is the hash of the record's content, so
the key is content-addressed: the service writes the archive *before* it commits the push (after
the board's cheap checks), and a push retried, refused afterwards (a copied run, a limit reached
meanwhile) or cut short leaves at most an object no row refers to, with the same content as a
later successful push would write. The put is conditional (``If-None-Match: *``): an object
already there is kept as it is, so a retry adds no version. Nothing is ever committed without its
archive. The bucket is versioned, expires versions that are no longer current (the template's
lifecycle rule) and is retained by the stack; the board's rows never hold more than the record
itself.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING
from urllib.parse import quote

from botocore.exceptions import BotoCoreError, ClientError

from ..errors import StoreBusy, StoreUnavailable
from .aws_errors import UNAVAILABLE_RETRY_AFTER_S, code_of, store_error

if TYPE_CHECKING:
    from botocore.config import Config
    from mypy_boto3_s3 import S3Client

PREFIX = "records/"


class S3Archive:
    """``client`` is the S3 client to use; without one, the archive makes its own (with
    ``config``) when it first writes, so that a function whose request writes no record (most of
    the admin function's) never pays for an S3 client in its cold start."""

    def __init__(self, bucket: str, client: S3Client | None = None, config: Config | None = None) -> None:
        self.bucket = bucket
        self._given = client
        self._config = config

    @cached_property
    def _client(self) -> S3Client:
        if self._given is not None:
            return self._given
        import boto3  # here, so that importing the module stays cheap for a cold start

        return boto3.client("s3", config=self._config)

    @staticmethod
    def key(board_id: str, submission_id: str) -> str:
        return f"{PREFIX}{quote(board_id, safe='')}/{quote(submission_id, safe='')}.json"

    def put(self, board_id: str, submission_id: str, record_json: str) -> None:
        """Keep the record; any failure is a store error (StoreBusy when S3 throttles,
        StoreUnavailable otherwise), so the push stores nothing and answers 503."""
        try:
            self._client.put_object(
                Bucket=self.bucket,
                Key=self.key(board_id, submission_id),
                Body=record_json.encode("utf-8"),
                ContentType="application/json",
                IfNoneMatch="*",
            )
        except ClientError as error:
            if code_of(error) in ARCHIVED:
                return  # the same content is archived (or being archived) already
            raise _archive_error(error) from error
        except BotoCoreError as error:
            raise _archive_error(error) from error


#: What a conditional put answers when the object is there already, or being written.
ARCHIVED = frozenset({"PreconditionFailed", "ConditionalRequestConflict"})


def _archive_error(error: Exception) -> StoreBusy | StoreUnavailable:
    """A failure to archive is a store error: StoreBusy when S3 throttles, StoreUnavailable
    otherwise (the push stores nothing and answers 503)."""
    busy = store_error(error, "the record archive")
    name = code_of(error) if isinstance(error, ClientError) else type(error).__name__
    return busy if isinstance(busy, StoreBusy) else StoreUnavailable(
        f"the record archive could not keep the record ({name}); nothing was stored, "
        "try again", UNAVAILABLE_RETRY_AFTER_S)
