"""Announcements in the club's chat: the webhooks organisers set on a target (a board, or a
season), and what is announced to them.

A webhook's URL is a secret (whoever holds it may post to the channel): it is stored, sent to
nowhere but its chat service, and never shown back in full (:class:`WebhookView` shows its host
and last four characters) nor logged.
"""

from datetime import datetime
from ipaddress import ip_address
from typing import Annotated, Literal, get_args
from urllib.parse import urlsplit

from pydantic import AfterValidator, Field, StringConstraints

from .domain import Entry, Model

WebhookKind = Literal["discord", "slack", "json"]
EventKind = Literal["new-leader", "top-3", "personal-best", "board-open", "board-close"]
EVENT_KINDS: tuple[EventKind, ...] = get_args(EventKind)
MAX_WEBHOOKS = 10  # per target
MAX_ERROR_CHARS = 300


def _webhook_url(url: str) -> str:
    parts = urlsplit(url)
    if parts.scheme not in ("https", "http") or not parts.hostname:
        raise ValueError("a webhook URL is an https:// address")
    if parts.scheme == "http" and not _loopback(parts.hostname):
        raise ValueError("a webhook URL is an https:// address (plain http only to this computer)")
    if parts.username or parts.password:
        raise ValueError("a webhook URL carries no user name or password")
    return url


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ip_address(host).is_loopback
    except ValueError:
        return False


WebhookUrl = Annotated[str, StringConstraints(strip_whitespace=True, min_length=8, max_length=2048),
                       AfterValidator(_webhook_url)]


TargetKind = Literal["board", "season"]


class Target(Model):
    """What announcements are about: a board, or a season of boards (a season's webhooks hear
    its rounds' events)."""

    kind: TargetKind = "board"
    target_id: Annotated[str, StringConstraints(min_length=1, max_length=128)]

    @property
    def key(self) -> str:
        return f"{self.kind}:{self.target_id}"


class WebhookSpec(Model):
    """A webhook as an organiser adds it: the chat service, its URL and the events it hears
    (every event by default)."""

    kind: WebhookKind
    url: WebhookUrl
    events: Annotated[list[EventKind], Field(min_length=1, max_length=len(EVENT_KINDS))] = list(EVENT_KINDS)


class Webhook(Model):
    """A stored webhook, with how its last delivery went."""

    webhook_id: str
    target: Target
    kind: WebhookKind
    url: str
    events: list[EventKind]
    created_at: datetime
    last_sent_at: datetime | None = None
    last_error: str | None = None
    last_error_at: datetime | None = None

    def view(self) -> "WebhookView":
        parts = urlsplit(self.url)
        return WebhookView(
            webhook_id=self.webhook_id, target=self.target, kind=self.kind,
            url=f"{parts.scheme}://{parts.hostname}/…{self.url[-4:]}", events=self.events,
            created_at=self.created_at, last_sent_at=self.last_sent_at,
            last_error=self.last_error, last_error_at=self.last_error_at)


class WebhookView(Model):
    """A webhook as the board shows it: its URL cut to the host and its last four characters."""

    webhook_id: str
    target: Target
    kind: WebhookKind
    url: str = Field(description="The host and the last four characters only: the URL is a secret.")
    events: list[EventKind]
    created_at: datetime
    last_sent_at: datetime | None
    last_error: str | None = Field(description="Why the last delivery failed (None once one "
                                               "succeeds again).")
    last_error_at: datetime | None


class WebhookList(Model):
    target: Target
    webhooks: list[WebhookView]


class Delivery(Model):
    """What a test message (or an announcement) to one webhook did."""

    webhook: WebhookView
    sent: bool
    error: str | None = None


class Place(Model):
    """One racer on a podium."""

    rank: int
    racer: str
    model_name: str
    time_ms: int | None
    gap_ms: int | None


class Announcement(Model):
    """One thing to tell the chat. ``event_id`` is the same however often it is worked out
    again (a retried stream record, a second look at a board's window): a webhook hears each
    event once."""

    event_id: str
    kind: EventKind
    target: Target
    board_id: str
    board_title: str
    url: str  # the board's page
    at: datetime
    racer: str | None = None
    model_name: str | None = None
    time_ms: int | None = None
    gap_ms: int | None = None  # to the leader; for a new leader, their lead over the next
    rank: int | None = None
    previous_rank: int | None = None  # None: the racer's first entry on the board
    previous_leader: str | None = None
    closes_at: datetime | None = None
    podium: list[Place] = []
    test: bool = False  # an organiser's test message (`drboard board webhook test`)
    text: str = ""  # the message, in plain words


class EntryChange(Model):
    """A racer's entry on a board changed: ``before`` (None: their first) became ``after`` at
    ``at``. A push tells it to `drboard serve`'s announcer; in the cloud the table's stream does."""

    board_id: str
    before: Entry | None
    after: Entry
    at: datetime
