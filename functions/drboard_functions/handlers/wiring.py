"""Where the Lambda functions get their service: the only code that reads the environment.

``TABLE_NAME`` names the DynamoDB table (required); ``ARCHIVE_BUCKET`` names the S3 bucket that
keeps every accepted record (optional: the pull function has none). ``USER_POOL_ID``,
``USER_POOL_CLIENT_ID`` and ``USER_POOL_DOMAIN`` say how racers sign in (the pull function tells
clients at ``/.well-known/drboard.json``). The service and its AWS clients are built once per
container and reused by every invocation.

The DynamoDB and S3 clients are built here, with timeouts and retries that fit inside the
functions' own timeout (``Timeout`` in template.yaml): one SDK call, with its retry and backoff,
gives up before the function is killed, so the board answers 503 (``StoreUnavailable`` or
``StoreBusy``, with Retry-After) rather than a timeout with nothing said.
"""

from __future__ import annotations

import os
from functools import cache
from typing import TYPE_CHECKING

from ..identity import SignIn
from ..service import LeaderboardService

#: What the handlers' X-Ray tracer patches: the AWS SDK, the one library that calls out. (By
#: default Powertools patches every library the X-Ray SDK knows that is installed, e.g. sqlite3
#: and http.client, at import, for calls the functions never make.)
TRACED_MODULES = ("botocore",)

#: The functions' ``Timeout`` in template.yaml (a test holds the two together).
FUNCTION_TIMEOUT_S = 10
CONNECT_TIMEOUT_S = 0.5
READ_TIMEOUT_S = 1.0  # DynamoDB answers in milliseconds, S3 a 64 KiB record in well under this
RETRIES = 1  # after the first attempt
#: botocore's standard mode waits up to ``2 ** (n - 1)`` s before retry n after throttling, and
#: up to 5 s more when the service asks for it with ``x-amz-retry-after``.
RETRY_AFTER_ALLOWANCE_S = 5.0

if TYPE_CHECKING:
    from botocore.config import Config


def client_config() -> Config:
    from botocore.config import Config

    return Config(connect_timeout=CONNECT_TIMEOUT_S, read_timeout=READ_TIMEOUT_S,
                  retries={"mode": "standard", "max_attempts": RETRIES})


def worst_case_call_s() -> float:
    """The longest one SDK call can take with :func:`client_config`: every attempt waiting out
    both timeouts, and every backoff at its longest."""
    attempts = RETRIES + 1
    waiting = attempts * (CONNECT_TIMEOUT_S + READ_TIMEOUT_S)
    backoff = sum(2.0 ** (n - 1) + RETRY_AFTER_ALLOWANCE_S for n in range(1, attempts))
    return waiting + backoff


@cache
def service_from_environment() -> LeaderboardService:
    # Imported here so that importing a handler does not need boto3's DynamoDB layer (and tests
    # can swap this function for an SQLite-backed service).
    import boto3

    from ..stores.dynamodb import DynamoDbStore
    from ..stores.s3_archive import S3Archive

    config = client_config()
    bucket = os.environ.get("ARCHIVE_BUCKET")
    return LeaderboardService(
        DynamoDbStore(os.environ["TABLE_NAME"], client=boto3.client("dynamodb", config=config)),
        archive=S3Archive(bucket, client=boto3.client("s3", config=config)) if bucket else None,
    )


@cache
def sign_in_from_environment() -> SignIn:
    pool = os.environ.get("USER_POOL_ID")
    if not pool:
        return SignIn()
    return SignIn(kind="cognito", region=os.environ.get("AWS_REGION") or pool.split("_", 1)[0],
                  user_pool_id=pool, client_id=os.environ.get("USER_POOL_CLIENT_ID"),
                  domain=os.environ.get("USER_POOL_DOMAIN"), scopes=["openid", "email", "profile"])
