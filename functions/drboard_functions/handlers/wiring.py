"""Where the Lambda functions get their service: the only code that reads the environment.

``TABLE_NAME`` names the DynamoDB table (required); ``ARCHIVE_BUCKET`` names the S3 bucket that
keeps every accepted record (optional: the pull function has none). ``USER_POOL_ID``,
``USER_POOL_CLIENT_ID`` and ``USER_POOL_DOMAIN`` say how racers sign in (the pull function tells
clients at ``/.well-known/drboard.json``). The service and its AWS clients are built once per
container (by :mod:`drboard_functions.services`, with the functions' timeouts and retries) and
reused by every invocation. ``BOARD_URL`` is the board's address, which the NotifyFunction's
announcements link to.

Each piece is built on first use, and imports what it needs then: the pull function answers a
kept page with :func:`kept_pages_from_environment` (a DynamoDB client and the table's page shelf),
and the card function a card drawn from one with :func:`kept_cards_from_environment`, before
anything builds the service or loads a model.

``AWS_EXECUTION_ENV``, which the Lambda runtime sets (``AWS_Lambda_python3.13``), tells a
function's container from any other process that imports the handlers (tests, `drboard serve`).
"""

from __future__ import annotations

import os
from datetime import UTC, datetime
from functools import cache
from typing import TYPE_CHECKING

from .. import services

if TYPE_CHECKING:
    from mypy_boto3_dynamodb import DynamoDBClient

    from ..identity import SignIn
    from ..notify.notifier import Notifier
    from ..routes.kept import KeptCards, KeptPages
    from ..service import LeaderboardService


def in_lambda_runtime() -> bool:
    return os.environ.get("AWS_EXECUTION_ENV", "").startswith("AWS_Lambda_")


@cache
def dynamodb_client() -> DynamoDBClient:
    return services.dynamodb_client(config=services.client_config())


@cache
def service_from_environment() -> LeaderboardService:
    return services.dynamodb_service(os.environ["TABLE_NAME"],
                                     archive_bucket=os.environ.get("ARCHIVE_BUCKET") or None,
                                     config=services.client_config(), client=dynamodb_client())


@cache
def kept_pages_from_environment() -> KeptPages:
    """The pages this container keeps, and those kept in the table (by the push that changed a
    board, or by the first reader of a page in any container)."""
    from ..routes.kept import KeptPages
    from ..stores.dynamodb.pages import DynamoDbPageShelf

    shelf = DynamoDbPageShelf(dynamodb_client(), os.environ["TABLE_NAME"])
    return KeptPages(shelf.version, shelf, lambda: datetime.now(UTC))


@cache
def kept_cards_from_environment() -> KeptCards:
    """The cards this container draws from the standings kept for their board (the card
    function's)."""
    from ..routes.kept import KeptCards

    def draw(svg: str) -> bytes:
        from ..cards.png import render

        return render(svg)

    return KeptCards(kept_pages_from_environment(), draw)


@cache
def notifier_from_environment() -> Notifier:
    """The NotifyFunction's: the board's table, and its pages at ``BOARD_URL``."""
    from .. import web
    from ..notify.notifier import Notifier

    service = service_from_environment()
    base = os.environ.get("BOARD_URL", "").rstrip("/")
    return Notifier(service.store, service.clock, lambda board_id: base + web.board_path(board_id))


@cache
def sign_in_from_environment() -> SignIn:
    from ..identity import SignIn

    pool = os.environ.get("USER_POOL_ID")
    if not pool:
        return SignIn()
    return SignIn(kind="cognito", region=os.environ.get("AWS_REGION") or pool.split("_", 1)[0],
                  user_pool_id=pool, client_id=os.environ.get("USER_POOL_CLIENT_ID"),
                  domain=os.environ.get("USER_POOL_DOMAIN"), scopes=["openid", "email", "profile"])


def forget() -> None:
    """Forget what this container built: the next request reads the environment again, as a
    new container would."""
    for built in (dynamodb_client, service_from_environment, kept_pages_from_environment,
                  kept_cards_from_environment, notifier_from_environment, sign_in_from_environment):
        built.cache_clear()
