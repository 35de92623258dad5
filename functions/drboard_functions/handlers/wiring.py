"""Where the Lambda functions get their service: the only code that reads the environment.

``TABLE_NAME`` names the DynamoDB table (required); ``ARCHIVE_BUCKET`` names the S3 bucket that
keeps every accepted record (optional: the pull function has none). ``USER_POOL_ID``,
``USER_POOL_CLIENT_ID`` and ``USER_POOL_DOMAIN`` say how racers sign in (the pull function tells
clients at ``/.well-known/drboard.json``). The service and its AWS clients are built once per
container (by :mod:`drboard_functions.services`, with the functions' timeouts and retries) and
reused by every invocation. ``BOARD_URL`` is the board's address, which the NotifyFunction's
announcements link to.
"""

from __future__ import annotations

import os
from functools import cache
from typing import TYPE_CHECKING

from .. import services
from ..identity import SignIn
from ..service import LeaderboardService

if TYPE_CHECKING:
    from ..notify.notifier import Notifier

@cache
def service_from_environment() -> LeaderboardService:
    return services.dynamodb_service(os.environ["TABLE_NAME"],
                                     archive_bucket=os.environ.get("ARCHIVE_BUCKET") or None,
                                     config=services.client_config())


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
    pool = os.environ.get("USER_POOL_ID")
    if not pool:
        return SignIn()
    return SignIn(kind="cognito", region=os.environ.get("AWS_REGION") or pool.split("_", 1)[0],
                  user_pool_id=pool, client_id=os.environ.get("USER_POOL_CLIENT_ID"),
                  domain=os.environ.get("USER_POOL_DOMAIN"), scopes=["openid", "email", "profile"])
