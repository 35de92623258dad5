"""The one place a :class:`LeaderboardService` is built with its stores: on an SQLite file (the
CLI's embedded board, ``drboard serve``) or on a DynamoDB table, with an S3 archive when there is
a bucket (the Lambda functions, ``drboard serve --table``).

The functions build their AWS clients with :func:`client_config`: timeouts and retries that fit
inside the functions' own timeout (``Timeout`` in template.yaml), so that one SDK call, with its
retry and backoff, gives up before the function is killed, and the board answers 503
(``StoreUnavailable`` or ``StoreBusy``, with Retry-After) rather than a timeout with nothing said.

boto3, the service and the stores are imported inside the functions that need them: importing
this module stays cheap (the CLI's start-up, a function's cold start, which may answer a kept page
with :func:`dynamodb_client` alone).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from botocore.config import Config
    from mypy_boto3_dynamodb import DynamoDBClient

    from .service import LeaderboardService

CONNECT_TIMEOUT_S = 0.5
READ_TIMEOUT_S = 1.0  # DynamoDB answers in milliseconds, S3 a 64 KiB record in well under this
RETRIES = 1  # after the first attempt


def client_config() -> Config:
    """The Lambda functions' AWS client settings: short timeouts, one retry."""
    from botocore.config import Config

    return Config(connect_timeout=CONNECT_TIMEOUT_S, read_timeout=READ_TIMEOUT_S,
                  retries={"mode": "standard", "max_attempts": RETRIES})


def sqlite_service(path: Path) -> LeaderboardService:
    """The board in an SQLite file (created when missing)."""
    from .service import LeaderboardService
    from .stores.sqlite import SqliteStore

    return LeaderboardService(SqliteStore(path))


def dynamodb_client(*, endpoint_url: str | None = None, config: Config | None = None) -> DynamoDBClient:
    """A DynamoDB client (at ``endpoint_url``, e.g. DynamoDB Local's); ``config`` sets its
    timeouts and retries (botocore's defaults when None)."""
    import boto3

    return boto3.client("dynamodb", endpoint_url=endpoint_url, config=config)


def dynamodb_service(table: str, *, endpoint_url: str | None = None,
                     archive_bucket: str | None = None, config: Config | None = None,
                     client: DynamoDBClient | None = None) -> LeaderboardService:
    """The board in a DynamoDB table (through ``client``, else a client of its own at
    ``endpoint_url``), keeping every accepted record in ``archive_bucket`` when there is one.
    ``config`` sets the AWS clients' timeouts and retries (botocore's defaults when None)."""
    from .service import LeaderboardService
    from .stores.dynamodb.store import DynamoDbStore
    from .stores.s3_archive import S3Archive

    store = DynamoDbStore(table, client=client or dynamodb_client(endpoint_url=endpoint_url,
                                                                  config=config))
    archive = S3Archive(archive_bucket, config=config) if archive_bucket else None  # client on first write
    return LeaderboardService(store, archive=archive)
