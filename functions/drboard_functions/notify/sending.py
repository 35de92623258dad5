"""Posting a message to a chat service's webhook: one JSON POST, with a short timeout and a few
tries.

The standard library's ``urllib.request`` does it: each service takes one JSON body on one URL
(Discord's and Slack's incoming webhooks, or any JSON endpoint), so a client library (Slack's
``slack_sdk`` WebhookClient, ``discord-webhook`` on ``requests``) would add a dependency, and
megabytes to the functions' bundles, for a call this size.

A 429 or a 5xx answer, a timeout or a lost connection is tried again (up to ``TRIES`` times,
waiting as ``Retry-After`` says, at most ``MAX_WAIT_S``); any other 4xx is final (the webhook
was removed, or the body refused). A failure's message names the status or the network error,
never the URL (a secret).
"""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from typing import Any

TIMEOUT_S = 5.0
TRIES = 3
FIRST_WAIT_S = 0.5
MAX_WAIT_S = 10.0
USER_AGENT = "drboard-announcements"


class DeliveryFailed(Exception):
    """The chat service did not take the message; ``str()`` says why, without the URL."""


Post = Callable[[str, dict[str, Any]], None]


def post(url: str, body: dict[str, Any], *, tries: int = TRIES, timeout_s: float = TIMEOUT_S,
         sleep: Callable[[float], None] = time.sleep) -> None:
    """POST ``body`` as JSON to ``url``; DeliveryFailed once every try has failed."""
    data = json.dumps(body).encode("utf-8")
    wait = FIRST_WAIT_S
    for attempt in range(1, tries + 1):
        request = urllib.request.Request(url, data=data, method="POST", headers={
            "Content-Type": "application/json", "User-Agent": USER_AGENT})
        try:
            with urllib.request.urlopen(request, timeout=timeout_s) as answer:
                answer.read()
                return
        except urllib.error.HTTPError as error:
            problem = f"the service answered {error.code} {error.reason}".strip()
            retry_after = _seconds(error.headers.get("Retry-After"))
            if error.code != 429 and error.code < 500:
                raise DeliveryFailed(problem) from None
        except (urllib.error.URLError, TimeoutError, ConnectionError, OSError) as error:
            reason = getattr(error, "reason", error)
            problem = f"the service could not be reached: {_reason(reason)}"
            retry_after = None
        if attempt == tries:
            raise DeliveryFailed(f"{problem} ({tries} tries)")
        sleep(min(MAX_WAIT_S, retry_after if retry_after is not None else wait))
        wait *= 2
    raise AssertionError("unreachable")  # pragma: no cover


def _seconds(value: str | None) -> float | None:
    try:
        return max(0.0, float(value)) if value else None
    except ValueError:
        return None


def _reason(reason: object) -> str:
    """A network error's reason, without anything of the request (no URL, no host)."""
    if isinstance(reason, TimeoutError) or "timed out" in str(reason):
        return "timed out"
    if isinstance(reason, OSError) and reason.strerror:
        return reason.strerror
    return type(reason).__name__
